//! The replay pipeline: a sample source through nav-core's navigator
//! ([`nav_core::navigator`]), its background run in line, the rows written as CSV.
//!
//! Every rule (the sample gate, the calibration, the counters, the align -> navigate hand-over,
//! the logging cadence, the aided phase's fix timing and filter work) is the navigator's; the
//! firmware's tasks drive the same navigator across their channels, and an end-to-end test
//! compares the two logs line by line. This module only reads samples, converts them
//! ([`hal_adapters::ImuSample::nav_input`]), hands each GNSS fix over before the first sample at or after its time (as
//! the firmware does), writes [`CSV_HEADER`] (an aided run: [`AIDED_CSV_HEADER`]), one row
//! (its `Display`) per line, a free-inertial run's [`nav_core::output::LostRecord`] where an
//! IMU gap lost its solution (the navigator's, [`nav_core::navigator::Navigator::take_lost_record`]), and the end record ([`nav_core::output::EndRecord`]), and
//! reports in output units.

use crate::aided_cmd::SensorEstimate;
use hal_adapters::Imu;
use hal_adapters::drivers::Health;
use nav_core::alignment::{AlignMethod, AlignNote, AlignOutcome};
use nav_core::ins_filter::sequencer::{FixCounters, GnssFixInput, Realignments};
use nav_core::ins_filter::{FilterCounters, FilterStatus};
use nav_core::navigator::{
    Background, ConfigError, FilterReport, FlaggedCounts, NavError, Navigator, Setup,
};
use nav_core::output::{AIDED_CSV_HEADER, CSV_HEADER, Row};
use nav_core::{Scalar, Solution};
use std::fmt;
use std::io::{self, Write};

pub use nav_core::navigator::RunConfig;
pub use nav_core::navigator::config::{DEFAULT_LOG_EVERY, MechanizationChoices};

/// nav-core's noise model of a part's (or grade's) figures (one definition, the protocol's
/// configuration uses it too).
pub use hal_adapters::protocol::config::sensor_noise;

/// The alignment result in output units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlignmentDeg {
    /// The method.
    pub method: AlignMethod,
    /// Roll [deg].
    pub roll_deg: f64,
    /// Pitch [deg].
    pub pitch_deg: f64,
    /// Yaw (true heading) [deg].
    pub yaw_deg: f64,
    /// 1-sigma of roll, pitch, yaw [deg] (the method's own error model).
    pub sigma_deg: [f64; 3],
    /// 1-sigma of the velocity handed over, north, east, down [m/s].
    pub velocity_sigma_m_s: [f64; 3],
    /// 1-sigma of the position handed over, north, east, down [m].
    pub position_sigma_m: [f64; 3],
    /// Samples used.
    pub samples: u32,
    /// Time used [s].
    pub duration_s: f64,
    /// Time in the coarse stage [s].
    pub coarse_s: f64,
    /// Time in the fine stage [s].
    pub fine_s: f64,
    /// What to know about how the result was reached.
    pub note: Option<AlignNote>,
}

impl AlignmentDeg {
    /// The outcome of `method` in output units.
    pub fn new<T: Scalar>(method: AlignMethod, o: &AlignOutcome<T>) -> Self {
        // The singular band of the precision the attitude was computed in.
        let q = nav_core::attitude::quat_to_f64(&o.estimate.q_b_n);
        let eps = T::default_epsilon().to_f64();
        let (roll, pitch, yaw) = nav_core::attitude::euler_to_precision(&q, eps);
        let wide = |v: &nav_core::Vector3<T>| [v.x, v.y, v.z].map(T::to_f64);
        Self {
            method,
            roll_deg: roll.to_degrees(),
            pitch_deg: pitch.to_degrees(),
            yaw_deg: yaw.to_degrees(),
            sigma_deg: wide(&o.estimate.sigma_rad).map(f64::to_degrees),
            velocity_sigma_m_s: wide(&o.velocity_sigma_m_s),
            position_sigma_m: wide(&o.position_sigma_m),
            samples: o.times.coarse_samples + o.times.fine_samples,
            duration_s: o.times.coarse_s + o.times.fine_s,
            coarse_s: o.times.coarse_s,
            fine_s: o.times.fine_s,
            note: o.note,
        }
    }
}

/// The aided phase's outcome in output units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AidedOutcome {
    /// 1-sigma of position north, east, down [m] at the end.
    pub sigma_ned_m: [f64; 3],
    /// 1-sigma of velocity north, east, down [m/s] at the end.
    pub sigma_v_ned_m_s: [f64; 3],
    /// 1-sigma of roll, pitch, yaw [deg] at the end.
    pub sigma_att_deg: [f64; 3],
    /// The filter's health at the end.
    pub status: FilterStatus,
    /// The aids' counters.
    pub counters: FilterCounters,
    /// Times the covariance lost a positive variance.
    pub covariance_faults: u32,
    /// The test of the fixes' time tags at the end (`nav_core::ins_filter::latency`).
    pub gnss_latency: nav_core::ins_filter::latency::LatencyEstimate<f64>,
    /// The learnt scales of the fixes' declared noise (`nav_core::ins_filter::noise_scale`):
    /// position and velocity, now and their largest [-].
    pub noise_scales: [[f64; 2]; 2],
    /// The fix queue's counters (received in the aided phase, refused, late).
    pub fixes: FixCounters,
    /// Fixes handed over before the aided phase (during the alignment).
    pub fixes_unused: u32,
    /// Fixes of the file after the last sample (never handed over).
    pub fixes_after_data: u32,
    /// Re-alignments in motion after a lost IMU gap or a divergence.
    pub realignments: Realignments,
    /// The sensor errors estimated by the end (`None` when the run ended re-aligning).
    pub sensors: Option<SensorEstimate>,
}

impl AidedOutcome {
    fn new<T: Scalar>(
        r: &FilterReport<T>,
        fixes: FixCounters,
        realignments: Realignments,
        unused: u32,
        after: u32,
    ) -> Self {
        let wide = |v: &nav_core::Vector3<T>| [v.x, v.y, v.z].map(T::to_f64);
        Self {
            sigma_ned_m: wide(&r.sigma_ned_m),
            sigma_v_ned_m_s: wide(&r.sigma_v_ned_m_s),
            sigma_att_deg: wide(&r.sigma_att_rad).map(f64::to_degrees),
            status: r.status,
            counters: r.counters,
            covariance_faults: r.covariance_faults,
            gnss_latency: r.gnss_latency.cast(),
            noise_scales: r.noise_scales.map(|a| a.map(T::to_f64)),
            fixes,
            fixes_unused: unused,
            fixes_after_data: after,
            realignments,
            sensors: None,
        }
    }
}

impl fmt::Display for AidedOutcome {
    /// The aided phase's lines for a terminal (no final newline).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = &self.counters;
        let aid =
            |f: &mut fmt::Formatter<'_>, name: &str, a: &nav_core::ins_filter::AidCounters| {
                writeln!(f, "  {name}: {a}")
            };
        writeln!(
            f,
            "aided navigation: status {} ({:?}), {} covariance propagations, {} covariance faults",
            self.status.name(),
            self.status,
            c.propagations,
            self.covariance_faults
        )?;
        aid(f, "GNSS position", &c.position)?;
        aid(f, "GNSS velocity", &c.velocity)?;
        aid(f, "zero velocity", &c.zero_velocity)?;
        aid(f, "zero rate", &c.zero_rate)?;
        let x = &self.fixes;
        writeln!(
            f,
            "  fixes: {} received while aided, {} out of order, {} dropped from a full queue, {} late; {} before the aided phase, {} after the data",
            x.received,
            x.out_of_order,
            x.queue_full,
            x.late,
            self.fixes_unused,
            self.fixes_after_data
        )?;
        writeln!(
            f,
            "  {}",
            crate::aided_cmd::latency_line(&self.gnss_latency)
        )?;
        let (p, v, a) = (self.sigma_ned_m, self.sigma_v_ned_m_s, self.sigma_att_deg);
        write!(
            f,
            "  final 1-sigma: position {:.3} {:.3} {:.3} m, velocity {:.4} {:.4} {:.4} m/s (N E D), roll {:.4} pitch {:.4} yaw {:.4} deg",
            p[0], p[1], p[2], v[0], v[1], v[2], a[0], a[1], a[2]
        )?;
        match &self.sensors {
            Some(e) => write!(f, "\n  {}", e.line()),
            None => Ok(()),
        }
    }
}

/// Counters of the replay source (see `hal_adapters::recording::ReplayStats`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SourceCounters {
    /// Samples missed before delivered ones (gaps).
    pub missed: u32,
    /// Samples flagged NaN or infinite.
    pub non_finite: u32,
    /// Samples flagged for an implausible interval (a short increment after a gap, a jump).
    pub bad_interval: u32,
    /// Samples flagged because their time is not after the previous record's (a repeated
    /// time tag, a swapped pair, a clock that stepped back): out of time order, as the
    /// navigator calls a time not after the last navigated sample's.
    pub out_of_order: u32,
}

/// What a run did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Report {
    /// Samples read from the source.
    pub samples: u32,
    /// Samples skipped for their flags.
    pub flagged: u32,
    /// The same by cause.
    pub flagged_by: FlaggedCounts,
    /// Increments refused by nav-core's input checks (alignment or navigation).
    pub rejected: u32,
    /// Samples of the alignment (`n_align`).
    pub n_align: u32,
    /// Navigation steps integrated after the alignment.
    pub nav_steps: u32,
    /// Samples taken after the alignment's hand-over (flagged, refused or navigated).
    pub after_alignment: u32,
    /// Of those, increments refused by nav-core's input limits.
    pub rejected_after_alignment: u32,
    /// Solution rows written (after the header line).
    pub rows: u32,
    /// The aided rows by status (none in a free-inertial run).
    pub status: crate::aided::StatusTally,
    /// The source's own counters, when it is a replay (filled by [`crate::replay`]).
    pub source: Option<SourceCounters>,
    /// The driver's counters, when the samples came through a simulated IMU's driver (filled
    /// by [`crate::replay`]; the firmware logs the same).
    pub driver: Option<Health>,
    /// The alignment.
    pub alignment: AlignmentDeg,
    /// The last solution written.
    pub final_solution: Solution,
    /// The aided phase's outcome, in an aided run.
    pub aided: Option<AidedOutcome>,
    /// The time the samples cover [us], from the start of the first's interval to the end
    /// of the last ([`nav_core::gap::data_span_us`]; `None`: no sample).
    pub span_us: Option<(u64, u64)>,
    /// IMU time not navigated (the spans of unusable samples).
    pub lost: crate::aided::LostImuTime,
}

/// Why a run failed.
#[derive(Debug)]
pub enum PipelineError<E> {
    /// The configuration is invalid.
    Config(ConfigError),
    /// The sample source failed (I/O, corrupt recording).
    Source(E),
    /// The alignment failed or never finished.
    Navigation(NavError),
    /// Writing the log failed.
    Output(io::Error),
}

impl<E: fmt::Display> fmt::Display for PipelineError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Config(e) => write!(f, "invalid configuration: {e}"),
            Self::Source(e) => write!(f, "{e}"),
            Self::Navigation(e) => write!(f, "{e}"),
            Self::Output(e) => write!(f, "writing the log: {e}"),
        }
    }
}

impl<E: fmt::Debug + fmt::Display> std::error::Error for PipelineError<E> {}

/// Runs `config` in precision `T` over every sample of `source` (nominal rate `rate_hz` [Hz]),
/// writing the log to `out`.
pub fn run<T: Scalar, I: Imu, W: Write>(
    config: &RunConfig,
    rate_hz: f64,
    source: &mut I,
    out: W,
) -> Result<Report, PipelineError<I::Error>> {
    run_with_fixes::<T, I, W>(config, rate_hz, source, &[], out)
}

/// [`run`] with GNSS fixes (time order, on the source's clock): each is handed to the
/// navigator before the first sample at or after its time; an aided run
/// ([`RunConfig::aiding`]) uses them after the alignment.
pub fn run_with_fixes<T: Scalar, I: Imu, W: Write>(
    config: &RunConfig,
    rate_hz: f64,
    source: &mut I,
    fixes: &[GnssFixInput<f64>],
    mut out: W,
) -> Result<Report, PipelineError<I::Error>> {
    let setup = Setup::<T>::new(config, rate_hz).map_err(PipelineError::Config)?;
    let mut navigator = Navigator::new(&setup);
    // Boxed: the fine filters make it large.
    let mut background = Box::new(Background::new(&setup));
    let mut status = crate::aided::StatusTally::default();
    let mut row = |out: &mut W, r: &Row| {
        if let Some(c) = r.filter() {
            status.add(r.solution().t_us as f64 * 1e-6, c.status);
        }
        writeln!(out, "{r}").map_err(PipelineError::Output)
    };
    let header = if config.aiding.is_some() {
        AIDED_CSV_HEADER
    } else {
        CSV_HEADER
    };
    writeln!(out, "{header}").map_err(PipelineError::Output)?;
    let mut next_fix = fixes.iter().peekable();
    let mut span_us: Option<(u64, u64)> = None;
    let mut lost = crate::aided::LostImuTime::default();
    let (mut after_alignment, mut rejected_after_alignment) = (0_u32, 0_u32);
    while let Some(s) = source.read_sample().map_err(PipelineError::Source)? {
        let first_us = || nav_core::gap::data_span_us(s.t_us, f64::from(s.dt_s), 0).0;
        span_us = Some((span_us.map_or_else(first_us, |(a, _)| a), s.t_us));
        let usable = s.flags.usable();
        let aligning = navigator.is_aligning();
        lost.set_aligning(aligning);
        while let Some(f) = next_fix.next_if(|f| f.t_us <= s.t_us) {
            navigator.push_fix(crate::gnss_file::narrow::<T>(f));
        }
        let out_of_order = navigator.counters().flagged_by.out_of_order;
        let rejected = navigator.counters().rejected;
        let logged = navigator
            .push_inline(&mut background, &s.nav_input())
            .map_err(PipelineError::Navigation)?;
        if !aligning {
            after_alignment += 1;
            rejected_after_alignment += navigator.counters().rejected - rejected;
        }
        // The navigator's word on the sample's time (nav_core::gap) and on its increment (a
        // refused one is lost time as an unusable one is).
        if navigator.counters().flagged_by.out_of_order > out_of_order {
            lost.out_of_order(f64::from(s.dt_s));
        } else {
            let navigated = usable && navigator.counters().rejected == rejected;
            lost.note(s.t_us, navigated.then_some(f64::from(s.dt_s)));
        }
        if let Some(r) = navigator.take_lost_record() {
            writeln!(out, "{r}").map_err(PipelineError::Output)?;
        }
        if let Some(r) = logged {
            row(&mut out, &r)?;
        }
    }
    // An aided run's last step: its row with the filter's report.
    navigator.end_of_data();
    if let Some(r) = navigator
        .work_inline(&mut background)
        .map_err(PipelineError::Navigation)?
    {
        row(&mut out, &r)?;
    }
    // The sensor errors of the aided phase (read before `finish` takes the navigator).
    let sensors = navigator
        .aided()
        .zip(background.filter())
        .map(|(m, f)| SensorEstimate::of(m.sensor_errors(), |at| f.sigma(at)));
    let summary = navigator.finish().map_err(PipelineError::Navigation)?;
    if let Some(r) = summary.final_row {
        row(&mut out, &r)?;
    }
    // Only a complete run ends its log with the end record.
    writeln!(out, "{}", summary.end_record()).map_err(PipelineError::Output)?;
    out.flush().map_err(PipelineError::Output)?;
    let c = summary.counters;
    lost.finish();
    Ok(Report {
        samples: c.samples,
        flagged: c.flagged,
        flagged_by: c.flagged_by,
        rejected: c.rejected,
        n_align: setup.n_align(),
        nav_steps: c.nav_steps,
        after_alignment,
        rejected_after_alignment,
        rows: c.rows,
        status,
        source: None,
        driver: None,
        alignment: AlignmentDeg::new(config.align_method, &summary.alignment),
        final_solution: summary.last_solution,
        aided: summary.filter.map(|r| AidedOutcome {
            sensors,
            ..AidedOutcome::new(
                &r,
                summary.fixes,
                summary.realignments,
                c.fixes_unused,
                u32::try_from(next_fix.count()).unwrap_or(u32::MAX),
            )
        }),
        span_us,
        lost,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use hal_adapters::{ImuSample, Motion, SampleFlags};

    /// A source of `n` identical level samples at rest at 100 Hz, some of them flagged.
    struct Still {
        n: u32,
        k: u32,
        bad: Vec<(u32, SampleFlags)>,
    }

    impl Imu for Still {
        type Error = &'static str;
        fn read_sample(&mut self) -> Result<Option<ImuSample>, &'static str> {
            if self.k == self.n {
                return Ok(None);
            }
            if self.k == u32::MAX {
                return Err("broken");
            }
            self.k += 1;
            let dt = 0.01_f32;
            let lat = 45f64.to_radians();
            let w = nav_core::earth::omega_ie_n(lat) * f64::from(dt);
            let g = nav_core::earth::normal_gravity(lat, 0.0) * f64::from(dt);
            let flags = self
                .bad
                .iter()
                .find(|b| b.0 == self.k)
                .map_or(SampleFlags::empty(), |b| b.1);
            Ok(Some(ImuSample {
                t_us: u64::from(self.k) * 10_000,
                seq: self.k,
                dt_s: dt,
                motion: Motion::Increments {
                    delta_theta_ib_b: [w.x as f32, w.y as f32, w.z as f32],
                    delta_v_ib_b: [0.0, 0.0, -g as f32],
                },
                temperature_c: f32::NAN,
                flags,
            }))
        }
    }

    fn config(align_seconds: f64, log_every: u32) -> RunConfig {
        RunConfig {
            log_every,
            ..RunConfig::new(
                45.0,
                0.0,
                0.0,
                align_seconds,
                sensor_noise(&hal_adapters::drivers::noise::ADIS16505),
            )
        }
    }

    #[test]
    fn flags_reach_the_gate_and_rows_the_log() {
        let mut src = Still {
            n: 2000,
            k: 0,
            bad: vec![
                (5, SampleFlags::NON_FINITE),
                (1500, SampleFlags::STALE),
                (1600, SampleFlags::GAP),
            ],
        };
        let mut log = Vec::new();
        let r = run::<f64, _, _>(&config(10.0, 40), 100.0, &mut src, &mut log).unwrap();
        // 2 unusable samples (a GAP alone is usable): 1000 aligned, 998 navigation steps.
        assert_eq!(
            (r.samples, r.flagged, r.rejected, r.n_align, r.nav_steps),
            (2000, 2, 0, 1000, 998)
        );
        assert_eq!(r.rows, 1 + 24 + 1);
        let text = String::from_utf8(log).unwrap();
        let mut lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(lines.pop(), Some("# end: 26 rows, ok"));
        assert_eq!(lines.len(), 1 + r.rows as usize);
        assert_eq!((r.flagged_by.non_finite, r.flagged_by.stale), (1, 1));
        // The alignment ended on sample 1001 (sample 5 was skipped).
        assert!(
            lines[1].starts_with("10.010000,45.000000000,0.000000000,0,0,0,0,"),
            "{}",
            lines[1]
        );
        assert!(lines.last().unwrap().starts_with("20.000000,"));
        assert_eq!(r.final_solution.t_us, 20_000_000);
        assert!(r.alignment.roll_deg.abs() < 1e-4 && r.alignment.pitch_deg.abs() < 1e-4);
        assert!(r.alignment.position_sigma_m.iter().all(|s| *s > 0.0));
    }

    #[test]
    fn reports_failures() {
        let mut log = Vec::new();
        let still = |n, k| Still { n, k, bad: vec![] };
        let e =
            run::<f64, _, _>(&config(10.0, 40), 100.0, &mut still(50, 0), &mut log).unwrap_err();
        assert_eq!(
            e.to_string(),
            "recording ended during alignment: 50 of 1000 samples used"
        );
        // All flagged: counted by cause, and the log has no end record.
        let mut all_nan = still(1500, 0);
        all_nan.bad = (1..=1500).map(|k| (k, SampleFlags::NON_FINITE)).collect();
        let mut log = Vec::new();
        let e = run::<f64, _, _>(&config(10.0, 40), 100.0, &mut all_nan, &mut log).unwrap_err();
        assert_eq!(
            e.to_string(),
            "recording ended during alignment: 0 of 1000 samples used (1500 flagged: non-finite 1500)"
        );
        assert_eq!(String::from_utf8(log).unwrap(), format!("{CSV_HEADER}\n"));
        // Aligned, then nothing usable.
        let mut stale = still(1500, 0);
        stale.bad = (1001..=1500).map(|k| (k, SampleFlags::STALE)).collect();
        let e =
            run::<f64, _, _>(&config(10.0, 40), 100.0, &mut stale, &mut Vec::new()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "no navigation step after the alignment: 1500 samples, 1000 used by the alignment (500 flagged: stale 500)"
        );
        let mut log = Vec::new();
        let e = run::<f64, _, _>(&config(10.0, 40), 100.0, &mut still(50, u32::MAX), &mut log)
            .unwrap_err();
        assert_eq!(e.to_string(), "broken");
        let e = run::<f64, _, _>(&config(0.0, 40), 100.0, &mut still(50, 0), &mut log).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid configuration: alignment window 0 s is shorter than the static method's minimum of 10 s"
        );
        let e = run::<f64, _, _>(&config(10.0, 0), 100.0, &mut still(50, 0), &mut log).unwrap_err();
        assert!(matches!(e, PipelineError::Config(_)), "{e}");
    }
}
