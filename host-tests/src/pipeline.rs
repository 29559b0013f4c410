//! The replay pipeline: alignment on the first samples (nav-core's [`Aligner`] running the
//! chosen method), then strapdown navigation, with a solution row every `log_every` navigation
//! steps.
//!
//! The firmware implements exactly these semantics (split across its RTIC tasks) and an
//! end-to-end test compares the two logs line by line, so every rule below is part of the
//! contract:
//!
//! - every sample counts in `samples`; a sample whose flags are not
//!   [`usable`](hal_adapters::SampleFlags::usable) counts in `flagged` and is skipped;
//! - the increments are converted `f32 -> f64 -> T` (exact for `T = f64`, identity for `f32`),
//!   with the sample's measured `dt_s`;
//! - aligning: an increment failing [`ImuIncrement::check`] against the default
//!   [`InputLimits`] counts in `rejected`; otherwise it goes to the [`Aligner`]; once `n_align =
//!   max(1, ceil(align_seconds * rate_hz - 1e-9))` are accepted the alignment ends at the
//!   configured position, navigation starts from its state, and that state is logged at the time
//!   of the last alignment sample;
//! - navigating: an increment refused by [`Strapdown::step`] counts in `rejected`; every
//!   `log_every`-th accepted step is logged; at the end, the last accepted step is logged unless it
//!   already was.
//!
//! The log is [`CSV_HEADER`] then one [`Solution`] row (its `Display`) per line.

use hal_adapters::drivers::NoiseSpec;
use hal_adapters::{Imu, SampleFlags};
use nav_core::alignment::{
    AlignFailure, AlignMethod, AlignOutcome, AlignSettings, Aligner, BaseMotion, LeverArm,
    Progress, SensorNoise,
};
use nav_core::output::CSV_HEADER;
use nav_core::{
    AttitudeMethod, ImuCalibration, ImuIncrement, InputLimits, MechanizationConfig, NavFrame,
    Position, Scalar, Solution, Strapdown, VerticalChannel,
};
use std::fmt;
use std::io::{self, Write};

/// Default number of navigation steps between logged solutions (10 Hz at 400 Hz).
pub const DEFAULT_LOG_EVERY: u32 = 40;

/// The pipeline's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineConfig {
    /// Latitude of the site [deg].
    pub lat_deg: f64,
    /// Longitude of the site [deg].
    pub lon_deg: f64,
    /// Ellipsoidal height of the site [m].
    pub h_m: f64,
    /// Length of the still period averaged by the alignment [s].
    pub align_seconds: f64,
    /// Navigation steps between logged solutions (>= 1).
    pub log_every: u32,
    /// Nominal sampling rate [Hz] (from the recording's header).
    pub rate_hz: f64,
    /// Sensor calibration applied before the mechanization (default identity).
    pub calibration: ImuCalibration,
    /// Frame, attitude integrator and vertical channel of the mechanization.
    pub choices: MechanizationChoices,
    /// Alignment method.
    pub align_method: AlignMethod,
    /// The IMU's noise, assumed by the alignment (its 1-sigma and filter tuning).
    pub noise: NoiseSpec,
    /// The IMU's lever arm from the base's centre of rotation, body FRD [m], if known.
    pub lever_arm_m: Option<[f64; 3]>,
}

/// nav-core's noise model of a part's figures.
pub fn sensor_noise<T: Scalar>(n: &NoiseSpec) -> SensorNoise<T> {
    SensorNoise {
        arw_rad_per_sqrt_s: T::c(n.gyro_arw_rad_per_sqrt_s),
        vrw_mps_per_sqrt_s: T::c(n.accel_vrw_mps_per_sqrt_s),
        gyro_bias_rad_s: T::c(n.gyro_bias_rad_s),
        accel_bias_mps2: T::c(n.accel_bias_mps2),
    }
}

/// The selectable parts of the mechanization (nav-core's defaults: wander azimuth, rotation
/// vector, free vertical channel).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MechanizationChoices {
    /// Navigation frame.
    pub frame: NavFrame,
    /// Attitude integration.
    pub attitude: AttitudeMethod,
    /// Vertical channel.
    pub vertical: VerticalChannel,
}

impl Default for MechanizationChoices {
    fn default() -> Self {
        let d = MechanizationConfig::<f64>::default();
        Self {
            frame: d.frame,
            attitude: d.attitude,
            vertical: d.vertical,
        }
    }
}

impl PipelineConfig {
    /// Number of samples averaged by the alignment: `max(1, ceil(align_seconds * rate_hz -
    /// 1e-9))` (the `1e-9` keeps e.g. 10 s at 400 Hz at 4000 despite rounding), computed by
    /// nav-core's [`samples_for`](nav_core::alignment::samples_for) as in the firmware.
    pub fn n_align(&self) -> u32 {
        nav_core::alignment::samples_for(self.align_seconds, self.rate_hz)
    }

    fn validate(&self) -> Result<(), String> {
        if !(-90.0..=90.0).contains(&self.lat_deg) {
            return Err(format!(
                "latitude {} deg is not within [-90, 90]",
                self.lat_deg
            ));
        }
        if !self.lon_deg.is_finite() || !self.h_m.is_finite() {
            return Err(format!(
                "position ({}, {}) is not finite",
                self.lon_deg, self.h_m
            ));
        }
        if !(self.align_seconds.is_finite() && self.align_seconds >= 0.0) {
            return Err(format!(
                "alignment time {} s is not a non-negative number",
                self.align_seconds
            ));
        }
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Err(format!(
                "the recording's rate {} Hz is not positive",
                self.rate_hz
            ));
        }
        if self.log_every == 0 {
            return Err("log_every must be at least 1".into());
        }
        Ok(())
    }
}

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
    /// Samples used.
    pub samples: u32,
    /// Time used [s].
    pub duration_s: f64,
    /// Time in the coarse stage [s].
    pub coarse_s: f64,
    /// Time in the fine stage [s].
    pub fine_s: f64,
}

impl AlignmentDeg {
    /// The outcome of `method` in output units.
    pub fn new<T: Scalar>(method: AlignMethod, o: &AlignOutcome<T>) -> Self {
        let q = nav_core::attitude::quat_to_f64(&o.estimate.q_b_n);
        let (roll, pitch, yaw) = nav_core::attitude::euler(&q);
        let sigma = o.estimate.sigma_rad.map(|x| x.to_f64().to_degrees());
        Self {
            method,
            roll_deg: roll.to_degrees(),
            pitch_deg: pitch.to_degrees(),
            yaw_deg: yaw.to_degrees(),
            sigma_deg: [sigma.x, sigma.y, sigma.z],
            samples: o.times.coarse_samples + o.times.fine_samples,
            duration_s: o.times.coarse_s + o.times.fine_s,
            coarse_s: o.times.coarse_s,
            fine_s: o.times.fine_s,
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
    /// Samples flagged for a zero, negative or implausible interval.
    pub bad_interval: u32,
}

/// What a run did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Report {
    /// Samples read from the source.
    pub samples: u32,
    /// Samples skipped for their flags.
    pub flagged: u32,
    /// Increments refused by nav-core's input checks (alignment or navigation).
    pub rejected: u32,
    /// Samples averaged by the alignment (`n_align`).
    pub n_align: u32,
    /// Navigation steps integrated after the alignment.
    pub nav_steps: u32,
    /// Solution rows written (after the header line).
    pub rows: u32,
    /// The source's own counters, when it is a replay (filled by [`crate::replay`]).
    pub source: Option<SourceCounters>,
    /// The alignment.
    pub alignment: AlignmentDeg,
    /// The last solution written.
    pub final_solution: Solution,
}

/// Why a run failed.
#[derive(Debug)]
pub enum PipelineError<E> {
    /// The configuration is invalid.
    Config(String),
    /// The sample source failed (I/O, corrupt recording).
    Source(E),
    /// The alignment failed.
    Alignment {
        /// Samples accumulated.
        samples: u32,
        /// Why.
        error: AlignFailure,
    },
    /// The source ended before `n_align` samples were accumulated.
    EndedDuringAlignment {
        /// Samples accumulated.
        samples: u32,
        /// Samples needed.
        n_align: u32,
    },
    /// Writing the log failed.
    Output(io::Error),
}

impl<E: fmt::Display> fmt::Display for PipelineError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Config(msg) => write!(f, "invalid configuration: {msg}"),
            Self::Source(e) => write!(f, "{e}"),
            Self::Alignment { samples, error } => {
                write!(f, "alignment failed after {samples} samples: {error}")
            }
            Self::EndedDuringAlignment { samples, n_align } => {
                write!(
                    f,
                    "recording ended during alignment: {samples} of {n_align} samples"
                )
            }
            Self::Output(e) => write!(f, "writing the log: {e}"),
        }
    }
}

impl<E: fmt::Debug + fmt::Display> std::error::Error for PipelineError<E> {}

enum Phase<T: Scalar> {
    Aligning(Box<Aligner<T>>),
    Navigating {
        nav: Strapdown<T>,
        alignment: AlignmentDeg,
    },
}

/// Runs the pipeline in precision `T` over every sample of `source`, writing the log to `out`.
pub fn run<T: Scalar, I: Imu, W: Write>(
    config: &PipelineConfig,
    source: &mut I,
    mut out: W,
) -> Result<Report, PipelineError<I::Error>> {
    config.validate().map_err(PipelineError::Config)?;
    let n_align = config.n_align();
    let position = Position::from_degrees(config.lat_deg, config.lon_deg, config.h_m);
    let limits = InputLimits::<T>::default();
    let mechanization = MechanizationConfig::<T> {
        compensation: config
            .calibration
            .compensation()
            .map_err(|e| PipelineError::Config(e.to_string()))?,
        frame: config.choices.frame,
        attitude: config.choices.attitude,
        vertical: config.choices.vertical,
        ..MechanizationConfig::default()
    };
    let row = |out: &mut W, s: &Solution| writeln!(out, "{s}").map_err(PipelineError::Output);

    writeln!(out, "{CSV_HEADER}").map_err(PipelineError::Output)?;
    let mut phase = Phase::Aligning(Box::new(Aligner::new(AlignSettings {
        method: config.align_method,
        position,
        samples: n_align,
        coarse_samples: nav_core::alignment::machine::coarse_samples_for(n_align, config.rate_hz),
        rate_hz: config.rate_hz,
        noise: sensor_noise(&config.noise),
        lever_arm: match config.lever_arm_m {
            Some(r) => LeverArm::Known(nav_core::Vector3::from(r.map(T::c))),
            None => LeverArm::default(),
        },
        base: BaseMotion::default(),
    })));
    let (mut samples, mut flagged, mut rejected, mut nav_steps, mut rows) =
        (0_u32, 0_u32, 0_u32, 0_u32, 0_u32);
    let mut last_t_us = 0_u64;
    let mut last_logged: Option<Solution> = None;

    while let Some(s) = source.read_sample().map_err(PipelineError::Source)? {
        samples = samples.saturating_add(1);
        if !s.flags.usable() || s.flags.contains(SampleFlags::GAP) {
            // The two-sample coning/sculling terms must not span a hole in the data.
            if let Phase::Navigating { nav, .. } = &mut phase {
                nav.restart_increments();
            }
        }
        if !s.flags.usable() {
            flagged = flagged.saturating_add(1);
            continue;
        }
        let (dtheta, dv) = s.increments();
        let widen = |v: [f32; 3]| v.map(|x| T::c(f64::from(x)));
        let inc = ImuIncrement::<T>::new(widen(dtheta), widen(dv), T::c(f64::from(s.dt_s)));
        match &mut phase {
            Phase::Aligning(aligner) => {
                if inc.check(&limits).is_err() {
                    rejected = rejected.saturating_add(1);
                    continue;
                }
                match aligner.add(&inc) {
                    Progress::Coarse | Progress::Fine => {}
                    Progress::Failed(error) => {
                        return Err(PipelineError::Alignment {
                            samples: aligner.samples(),
                            error,
                        });
                    }
                    Progress::Aligned(outcome) => {
                        let nav = Strapdown::new(outcome.state, mechanization);
                        // The aligned state, at the time of the last alignment sample.
                        let sol = Solution::from_state(s.t_us, nav.state());
                        row(&mut out, &sol)?;
                        rows += 1;
                        last_logged = Some(sol);
                        phase = Phase::Navigating {
                            nav,
                            alignment: AlignmentDeg::new(config.align_method, &outcome),
                        };
                    }
                }
            }
            Phase::Navigating { nav, .. } => {
                if nav.step(&inc).is_err() {
                    rejected = rejected.saturating_add(1);
                    continue;
                }
                nav_steps += 1;
                if nav_steps.is_multiple_of(config.log_every) {
                    let sol = Solution::from_state(s.t_us, nav.state());
                    row(&mut out, &sol)?;
                    rows += 1;
                    last_logged = Some(sol);
                }
                last_t_us = s.t_us;
            }
        }
    }

    match phase {
        Phase::Aligning(aligner) => Err(PipelineError::EndedDuringAlignment {
            samples: aligner.samples(),
            n_align,
        }),
        Phase::Navigating { nav, alignment } => {
            let mut final_solution =
                last_logged.unwrap_or_else(|| Solution::from_state(last_t_us, nav.state()));
            if nav_steps > 0 && !nav_steps.is_multiple_of(config.log_every) {
                final_solution = Solution::from_state(last_t_us, nav.state());
                row(&mut out, &final_solution)?;
                rows += 1;
            }
            out.flush().map_err(PipelineError::Output)?;
            Ok(Report {
                samples,
                flagged,
                rejected,
                n_align,
                nav_steps,
                rows,
                source: None,
                alignment,
                final_solution,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hal_adapters::{ImuSample, Motion, SampleFlags};

    /// A source of `n` identical level samples at rest (exact enough for counting tests).
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

    fn config(align_seconds: f64, log_every: u32) -> PipelineConfig {
        PipelineConfig {
            lat_deg: 45.0,
            lon_deg: 0.0,
            h_m: 0.0,
            align_seconds,
            log_every,
            rate_hz: 100.0,
            calibration: ImuCalibration::default(),
            choices: MechanizationChoices::default(),
            align_method: AlignMethod::Static,
            noise: hal_adapters::drivers::noise::ADIS16505,
            lever_arm_m: None,
        }
    }

    #[test]
    fn n_align_rounds_up_but_not_for_rounding_noise() {
        let c = |s, r| {
            PipelineConfig {
                rate_hz: r,
                ..config(s, 1)
            }
            .n_align()
        };
        assert_eq!(c(10.0, 400.0), 4000);
        assert_eq!(c(0.1 + 0.2, 10.0), 3); // 3.0000000000000004
        assert_eq!(c(0.301, 10.0), 4);
        assert_eq!(c(0.0, 400.0), 1);
    }

    #[test]
    fn counts_rows_and_logs_the_last_step() {
        let mut src = Still {
            n: 1000,
            k: 0,
            bad: vec![
                (5, SampleFlags::NON_FINITE),
                (500, SampleFlags::STALE),
                (600, SampleFlags::GAP),
            ],
        };
        let mut log = Vec::new();
        let r = run::<f64, _, _>(&config(1.0, 40), &mut src, &mut log).unwrap();
        // 1000 samples, 2 unusable (GAP alone is usable), 100 aligned, 898 navigation steps.
        assert_eq!(
            (r.samples, r.flagged, r.rejected, r.n_align, r.nav_steps),
            (1000, 2, 0, 100, 898)
        );
        // Alignment row, 22 periodic rows (880 steps), and the final step 898.
        assert_eq!(r.rows, 1 + 22 + 1);
        let text = String::from_utf8(log).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(lines.len(), 1 + r.rows as usize);
        // The alignment ended on sample 101 (sample 5 was skipped).
        assert!(
            lines[1].starts_with("1.010000,45.000000000,0.000000000,0,0,0,0,"),
            "{}",
            lines[1]
        );
        assert!(lines.last().unwrap().starts_with("10.000000,"));
        assert_eq!(r.final_solution.t_us, 10_000_000);
        assert!(r.alignment.roll_deg.abs() < 1e-4 && r.alignment.pitch_deg.abs() < 1e-4);
    }

    #[test]
    fn no_final_row_when_the_last_step_was_logged() {
        let mut src = Still {
            n: 140,
            k: 0,
            bad: vec![],
        };
        let mut log = Vec::new();
        let r = run::<f32, _, _>(&config(1.0, 40), &mut src, &mut log).unwrap();
        assert_eq!((r.nav_steps, r.rows), (40, 2));
    }

    #[test]
    fn reports_failures() {
        let mut log = Vec::new();
        let mut src = Still {
            n: 50,
            k: 0,
            bad: vec![],
        };
        let e = run::<f64, _, _>(&config(1.0, 40), &mut src, &mut log).unwrap_err();
        assert_eq!(
            e.to_string(),
            "recording ended during alignment: 50 of 100 samples"
        );

        let mut src = Still {
            n: 50,
            k: u32::MAX,
            bad: vec![],
        };
        let e = run::<f64, _, _>(&config(1.0, 40), &mut src, &mut log).unwrap_err();
        assert_eq!(e.to_string(), "broken");

        let mut src = Still {
            n: 50,
            k: 0,
            bad: vec![],
        };
        let polar = PipelineConfig {
            lat_deg: 89.9,
            ..config(0.1, 40)
        };
        let e = run::<f64, _, _>(&polar, &mut src, &mut log).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("alignment failed after 10 samples: "),
            "{e}"
        );

        let e = run::<f64, _, _>(&config(0.1, 0), &mut src, &mut log).unwrap_err();
        assert!(matches!(e, PipelineError::Config(_)), "{e}");
    }
}
