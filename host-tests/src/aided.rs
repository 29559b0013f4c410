//! The GNSS-aided run: IMU samples and GNSS fixes through nav-core's sequencer
//! ([`nav_core::ins_filter::sequencer`]), one solution row per logged sample with its 1-sigma
//! and the filter's status.
//!
//! Every navigation rule (the fix timing, the start, the gate, the status) is nav-core's; this
//! module converts the file types, feeds fixes ahead of the samples they belong to, and writes
//! rows.

use crate::gnss::GnssFix;
use anyhow::{Result, anyhow};
use hal_adapters::{Imu, ImuSample, SampleFlags};
use nav_core::ins_filter::sequencer::{FixCounters, GnssFixInput, Phase, Sequencer};
use nav_core::ins_filter::{
    AidResult, AidedIns, FilterCounters, GnssPosition, GnssVelocity, POS, VEL,
};
use nav_core::output::CSV_HEADER;
use nav_core::{ImuIncrement, Scalar, Solution, Vector3};
use std::fmt;

/// The columns the aided solution adds to [`CSV_HEADER`]: 1-sigma of position [m], velocity
/// [m/s], roll, pitch, yaw [deg], and the status (`NAV` or `DEGRADED`).
pub const SIGMA_COLUMNS: &str = "sigma_n_m,sigma_e_m,sigma_d_m,sigma_vn_mps,sigma_ve_mps,\
sigma_vd_mps,sigma_roll_deg,sigma_pitch_deg,sigma_yaw_deg,status";

/// The aided solution log's header.
pub fn header() -> String {
    format!("{CSV_HEADER},{SIGMA_COLUMNS}")
}

/// One aided solution row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AidedRow {
    /// The solution.
    pub solution: Solution,
    /// 1-sigma of position north, east, down [m].
    pub sigma_pos_m: [f64; 3],
    /// 1-sigma of velocity north, east, down [m/s].
    pub sigma_vel_m_s: [f64; 3],
    /// 1-sigma of roll, pitch, yaw [deg].
    pub sigma_att_deg: [f64; 3],
    /// The filter's status name.
    pub status: &'static str,
}

impl AidedRow {
    /// The row of the filter's state at `t_us`.
    pub fn of<T: Scalar>(t_us: u64, ins: &AidedIns<T>) -> Self {
        let wide = |v: Vector3<T>| [v.x, v.y, v.z].map(T::to_f64);
        Self {
            solution: Solution::from_state(t_us, ins.state()),
            sigma_pos_m: wide(ins.sigma(POS)),
            sigma_vel_m_s: wide(ins.sigma(VEL)),
            sigma_att_deg: wide(ins.attitude_sigma_rad()).map(f64::to_degrees),
            status: ins.status().name(),
        }
    }
}

impl fmt::Display for AidedRow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.solution)?;
        for v in self
            .sigma_pos_m
            .iter()
            .chain(&self.sigma_vel_m_s)
            .chain(&self.sigma_att_deg)
        {
            write!(f, ",{v}")?;
        }
        write!(f, ",{}", self.status)
    }
}

/// nav-core's fix of a file's, on the IMU clock (`t_s` seconds -> microseconds); `None` for a
/// time tag that is not a time on that clock (negative or not finite).
pub fn fix_input<T: Scalar>(f: &GnssFix) -> Option<GnssFixInput<T>> {
    if !(f.t_s.is_finite() && f.t_s >= 0.0 && f.t_s < 1e12) {
        return None;
    }
    let v3 = |a: [f64; 3]| Vector3::new(T::c(a[0]), T::c(a[1]), T::c(a[2]));
    Some(GnssFixInput {
        t_us: (f.t_s * 1e6).round() as u64,
        position: GnssPosition {
            lat_rad: f.lat_rad,
            lon_rad: f.lon_rad,
            h_m: f.h_m,
            sigma_ned_m: v3(f.sigma_ned_m),
        },
        velocity: f.velocity.map(|v| GnssVelocity {
            v_ned_m_s: v3(v.v_ned_m_s),
            sigma_ned_m_s: v3(v.sigma_ned_m_s),
        }),
    })
}

/// One GNSS update's record, for the consistency statistics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateRecord {
    /// Time of the fix [s].
    pub t_s: f64,
    /// The position update's outcome.
    pub position: AidResult<f64>,
    /// The velocity update's outcome, when the fix had a velocity.
    pub velocity: Option<AidResult<f64>>,
}

/// What an aided run did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AidedReport {
    /// Samples read.
    pub samples: u64,
    /// Samples skipped as unusable (their flags).
    pub flagged: u64,
    /// Increments refused by nav-core's limits.
    pub rejected: u64,
    /// Fixes whose time tag is not on the IMU clock.
    pub bad_time_tags: u64,
    /// Fixes before the first sample or after the last.
    pub outside_imu_data: u64,
    /// Time of the first filter sample [s] (`None`: the start in motion never completed).
    pub start_s: Option<f64>,
    /// The filter's aid counters.
    pub counters: FilterCounters,
    /// The sequencer's fix counters.
    pub fixes: FixCounters,
    /// Covariance faults.
    pub covariance_faults: u32,
    /// Every update's outcome.
    pub updates: Vec<UpdateRecord>,
}

fn wide(r: &AidResult<impl Scalar>) -> AidResult<f64> {
    match *r {
        AidResult::Accepted { nis } => AidResult::Accepted { nis: nis.to_f64() },
        AidResult::Rejected { nis } => AidResult::Rejected { nis: nis.to_f64() },
        AidResult::Invalid => AidResult::Invalid,
    }
}

/// One IMU sample as the aided run takes it: end time [us], increment, and whether it is
/// unusable or follows a gap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AidedSample<T: Scalar> {
    /// End of the interval [us].
    pub t_us: u64,
    /// The increment.
    pub increment: ImuIncrement<T>,
    /// Not usable (its source's flags).
    pub unusable: bool,
    /// A gap precedes it.
    pub gap: bool,
}

/// The aided run's sample of a replay source's sample.
pub fn sample_of<T: Scalar>(s: &ImuSample) -> AidedSample<T> {
    let (d_theta, d_v) = s.increments();
    AidedSample {
        t_us: s.t_us,
        increment: ImuIncrement::new(
            d_theta.map(T::of_f32),
            d_v.map(T::of_f32),
            T::of_f32(s.dt_s),
        ),
        unusable: s.flags.unusable_cause().is_some(),
        gap: s.flags.contains(SampleFlags::GAP),
    }
}

/// Where an aided run's filter samples go.
pub trait AidedSink<T: Scalar> {
    /// Every sample the filter integrated, at its end time `t_us` [us].
    fn sample(&mut self, t_us: u64, ins: &AidedIns<T>) -> Result<()>;
    /// After a sample at which fixes were applied (called before [`Self::sample`]).
    fn updated(&mut self, _t_us: u64, _ins: &AidedIns<T>) {}
    /// The run ended normally.
    fn finish(&mut self) -> Result<()> {
        Ok(())
    }
}

/// The solution log's rows: every `log_every`-th filter sample and the last one.
pub struct CsvRows<F> {
    log_every: u32,
    since_log: u32,
    pending: Option<AidedRow>,
    rows: u64,
    write: F,
}

impl<F: FnMut(&AidedRow) -> Result<()>> CsvRows<F> {
    /// Rows to `write`, every `log_every`-th sample (the first one included).
    pub fn new(log_every: u32, write: F) -> Self {
        Self {
            log_every: log_every.max(1),
            since_log: log_every.max(1) - 1,
            pending: None,
            rows: 0,
            write,
        }
    }

    /// Rows written.
    pub fn rows(&self) -> u64 {
        self.rows
    }
}

impl<T: Scalar, F: FnMut(&AidedRow) -> Result<()>> AidedSink<T> for CsvRows<F> {
    fn sample(&mut self, t_us: u64, ins: &AidedIns<T>) -> Result<()> {
        self.since_log += 1;
        if self.since_log >= self.log_every {
            self.since_log = 0;
            self.pending = None;
            self.rows += 1;
            (self.write)(&AidedRow::of(t_us, ins))
        } else {
            self.pending = Some(AidedRow::of(t_us, ins));
            Ok(())
        }
    }

    fn finish(&mut self) -> Result<()> {
        if let Some(row) = self.pending.take() {
            self.rows += 1;
            (self.write)(&row)?;
        }
        Ok(())
    }
}

/// Runs `samples` with `fixes` (time order) through `seq` into `sink`.
pub fn run<T: Scalar, E: fmt::Display>(
    mut samples: impl FnMut() -> Result<Option<AidedSample<T>>, E>,
    fixes: &[GnssFix],
    mut seq: Sequencer<T>,
    sink: &mut impl AidedSink<T>,
) -> Result<AidedReport> {
    let mut report = AidedReport::default();
    // Converted once, not at every sample that waits for the fix.
    let inputs: Vec<Option<GnssFixInput<T>>> = fixes.iter().map(fix_input::<T>).collect();
    let mut next_fix = 0;
    let mut first = true;
    while let Some(s) = samples().map_err(|e| anyhow!("{e}"))? {
        report.samples += 1;
        // Fixes due at or before this sample go in first (held by the sequencer until it).
        while let Some(input) = inputs.get(next_fix) {
            let Some(input) = *input else {
                report.bad_time_tags += 1;
                next_fix += 1;
                continue;
            };
            if input.t_us > s.t_us {
                break;
            }
            next_fix += 1;
            if first {
                report.outside_imu_data += 1;
                continue;
            }
            seq.push_fix(input);
        }
        first = false;
        if s.unusable {
            report.flagged += 1;
            seq.restart_increments();
            continue;
        }
        if s.gap {
            seq.restart_increments();
        }
        match seq.on_sample(s.t_us, &s.increment) {
            Err(_) => {
                report.rejected += 1;
                continue;
            }
            Ok(Phase::Starting) => continue,
            Ok(Phase::Navigating) => {}
        }
        let mut updated = false;
        for (t_us, p, v) in seq.last_results() {
            updated = true;
            report.updates.push(UpdateRecord {
                t_s: *t_us as f64 * 1e-6,
                position: wide(p),
                velocity: v.as_ref().map(wide),
            });
        }
        let Some(ins) = seq.filter() else { continue };
        if report.start_s.is_none() {
            report.start_s = Some(s.t_us as f64 * 1e-6);
        }
        if updated {
            sink.updated(s.t_us, ins);
        }
        sink.sample(s.t_us, ins)?;
    }
    sink.finish()?;
    report.outside_imu_data += (fixes.len() - next_fix) as u64;
    if let Some(ins) = seq.filter() {
        report.counters = *ins.counters();
        report.covariance_faults = ins.covariance_faults();
    }
    report.fixes = *seq.fix_counters();
    Ok(report)
}

/// [`run`] over a replay source.
pub fn run_source<T: Scalar, S: Imu>(
    source: &mut S,
    fixes: &[GnssFix],
    seq: Sequencer<T>,
    sink: &mut impl AidedSink<T>,
) -> Result<AidedReport> {
    run(
        || source.read_sample().map(|s| s.map(|s| sample_of::<T>(&s))),
        fixes,
        seq,
        sink,
    )
}
