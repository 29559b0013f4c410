//! The GNSS-aided commands: `nav replay --gnss` (a recording with GNSS fixes) and the filter's
//! settings from the command line's units.

use crate::aided::{self, AidedReport, AidedRow, UpdateRecord};
use crate::atomic;
use crate::gnss::{self, GnssFix};
use crate::kf_gins_run::sensor_fields;
use crate::recording_io::ReplaySource;
use crate::sensor_model::Grade;
use anyhow::{Result, anyhow, bail};
use hal_adapters::drivers::NoiseSpec;
use hal_adapters::sample::{ClipMarked, FullScale};
use nav_core::ins_filter::latency::LatencyEstimate;
use nav_core::ins_filter::limits::MIN_BIAS_INSTABILITY_TIME_S;
use nav_core::ins_filter::model::FilterNoise;
use nav_core::ins_filter::motion::{MAX_FIX_INTERVAL_S, MIN_SPEED_SIGMAS, MotionAlignConfig};
use nav_core::ins_filter::sequencer::{RealignCause, Realignments, Sequencer, Start};
use nav_core::ins_filter::{
    AidResult, BA, BG, FilterConfig, FilterModel, InitialSigma, SA, SG, SensorErrors,
};
use nav_core::navigator::config::{MAX_HEIGHT_M, MIN_HEIGHT_M};
use nav_core::number::{Number, Rounded};
use nav_core::{NavState, Position, Scalar, Vector3, attitude};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The filter's noise model of a part's data-sheet figures (nav-core's defaults for what a
/// data sheet lacks: [`nav_core::navigator::config::filter_noise_of`]).
pub fn noise_of_spec(n: &NoiseSpec) -> FilterNoise<f64> {
    nav_core::navigator::config::filter_noise_of(&crate::pipeline::sensor_noise(n), &n.figures)
}

/// The filter's assumptions for a grade: its white noise, and per axis the largest of the
/// fixed bias, the turn-on 1-sigma and the Gauss–Markov 1-sigma (as the alignment's);
/// scale factors: the largest fixed scale error; cross-axis coupling: the RMS of the six
/// misalignment elements ([`off_diagonal_rms`]); correlation time
/// [`FILTER_CORRELATION_TIME_S`]. The start's sensor 1-sigma is the same figure, the
/// process's stationary one, so its covariance does not decay; conservative (the turn-on
/// spread is let wander in-run as well, at `sigma sqrt(2 / tau)`: a consumer gyro's 0.5 deg/s
/// wanders 255 deg/h per sqrt(h), against the grade's 10), used by `nav replay --imu-noise`
/// and by the firmware's grades. Not [`grade_filter_model`]: its in-run processes are the
/// simulator's, none for `fog` and `rlg` (constant biases), and a real part's bias instability
/// would meet bias states without process noise; at the ends of 60 s outages the two gave
/// 1-sigmas within 15 % of each other (the misalignment consider states make most of it).
/// With 1 h it wandered 100 times faster (a consumer gyro's bias 0.14 deg/s in 150 s):
/// on a straight flight the filter's heading walked with its bias estimate, 25-50 deg off
/// after 900 s against a 16 deg 1-sigma, from a perfect IMU.
pub fn grade_noise(grade: Grade) -> FilterNoise<f64> {
    let spec = grade.noise_spec();
    FilterNoise {
        gyro_bias_rad_s: spec.gyro_bias_rad_s.max(1e-9),
        accel_bias_mps2: spec.accel_bias_mps2.max(1e-7),
        ..noise_of_spec(&spec)
    }
}

/// The filter's configuration of a model `m`, the rest the defaults.
pub fn model_config(m: &FilterModel) -> FilterConfig<f64> {
    FilterConfig {
        sensor_sigma: Some(m.start_sigma),
        ..FilterConfig::new(m.noise)
    }
}

/// Correlation time of the filter's Gauss–Markov sensor-error states in
/// [`grade_filter_model`] [s]: 100 h, far beyond a run, because the grades' biases and scale
/// factors are random constants (turn-on, fixed) plus a slow in-run drift. The filter's
/// state decays as `-x / tau` ([Groves, eq. 14.80]) in its covariance, not in its estimate
/// (the feedback holds that): started at the turn-on spread, an unobserved variance loses
/// `1 - exp(-2 t / tau)` of itself, 86 % in an hour with KF-GINS's usual `corrtime` of 1 h,
/// while the true constant stays. That made the bias blocks' NEES grow 7-fold over 1 h runs
/// (fog, rlg) and the attitude overconfident with them. With 100 h it loses 2 % in an hour;
/// the drive `2 sigma^2 / tau` stays the grade's in-run drift (sigma follows tau). The same
/// as the navigator's default for a data sheet's figures (the firmware's).
pub const FILTER_CORRELATION_TIME_S: f64 = nav_core::navigator::config::DEFAULT_CORRELATION_TIME_S;

/// A simulated Gauss–Markov bias shorter than this [s] is not a drift of the bias state (it
/// decorrelates between a few GNSS fixes): a gyro's is the filter's bias-instability consider
/// state, an accelerometer's white noise; a longer one drives the bias state.
pub const WHITE_GM_BELOW_S: f64 = 60.0;

/// The filter's model of a grade ([`FilterModel`]: its two kinds of sensor error kept
/// apart, as KF-GINS keeps `imunoise` (in-run) apart from `init*std` (the start's
/// uncertainty)), from the same figures the simulator injects:
///
/// - the turn-on bias (a random constant per power-up), the fixed bias and the stationary
///   1-sigma of the Gauss–Markov bias (RSS) are the start's bias uncertainty, not an in-run
///   process: a Gauss–Markov state of 1 h driven as if the turn-on spread re-randomised every
///   hour lets the bias wander by `sigma sqrt(2 t / tau)` (a quarter of the turn-on spread in
///   two minutes), which makes the filter's sigma several times its error;
/// - a gyro Gauss–Markov bias of correlation time `T` below [`WHITE_GM_BELOW_S`] (the MEMS
///   gyros' bias instability, `T` of a few seconds) is the filter's bias-instability consider
///   state ([`nav_core::ins_filter::consider`]); an accelerometer's integrates like white noise
///   of density `2 sigma^2 T` (its spectrum at frequencies below `1 / T`, [Groves, eq. 14.80]
///   for the density of a Gauss–Markov drive), added to the random walk; a longer one, and the
///   rate random walk `K`, drive the bias state with `2 sigma^2 / T + K^2`;
/// - the scale factors are constants of the grade: the start's 1-sigma the largest of them
///   (at least 1 ppm), no in-run drift;
/// - misalignment and g-sensitivity as in [`grade_noise`]: consider states of the filter
///   ([`nav_core::ins_filter::consider`]);
/// - the Gauss–Markov states' correlation time [`FILTER_CORRELATION_TIME_S`], their drive
///   `2 sigma^2 / tau` the grade's in-run drift.
pub fn grade_filter_model(grade: Grade) -> FilterModel {
    filter_model_of(&grade.model())
}

/// What the filter's bias states hold of a triad's in-run bias, by the rules of
/// [`filter_model_of`]: the rate random walk `rw_now` and a Gauss–Markov bias `gm_now` of
/// correlation time at least [`WHITE_GM_BELOW_S`] (or a constant one); a shorter one is, to
/// the filter, a consider state or white noise [U].
pub fn bias_state_part(
    t: &crate::sensor_model::TriadErrors,
    gm_now: Vector3<f64>,
    rw_now: Vector3<f64>,
) -> Vector3<f64> {
    let tau = t.bias_instability.correlation_time_s;
    if tau.is_finite() && tau < WHITE_GM_BELOW_S {
        rw_now
    } else {
        rw_now + gm_now
    }
}

/// [`FilterModel`] of an error model `m` ([`grade_filter_model`]: the same rules).
pub fn filter_model_of(m: &crate::sensor_model::ImuErrorModel) -> FilterModel {
    let tau_f = FILTER_CORRELATION_TIME_S;
    // (white-noise density [U/sqrt(Hz)], in-run Gauss–Markov 1-sigma [U], start 1-sigma [U],
    // the short Gauss–Markov kept as such: 1-sigma [U], correlation time [s]).
    let split = |t: &crate::sensor_model::TriadErrors, keep_short: bool| {
        let gm = t.bias_instability;
        let (mut white2, mut drive, mut short) = (
            t.white_noise.density().powi(2),
            t.rate_random_walk * t.rate_random_walk,
            (0.0, 0.0),
        );
        if gm.sigma > 0.0 && gm.correlation_time_s.is_finite() {
            if gm.correlation_time_s >= WHITE_GM_BELOW_S {
                drive += 2.0 * gm.sigma * gm.sigma / gm.correlation_time_s;
            } else if keep_short && gm.correlation_time_s >= MIN_BIAS_INSTABILITY_TIME_S {
                short = (gm.sigma, gm.correlation_time_s);
            } else {
                white2 += 2.0 * gm.sigma * gm.sigma * gm.correlation_time_s;
            }
        }
        let start = t
            .turn_on_bias_sigma
            .map(|s| (s * s + gm.sigma * gm.sigma).sqrt())
            + t.bias.abs();
        (white2.sqrt(), (drive * tau_f / 2.0).sqrt(), start, short)
    };
    let (arw, gyro_in_run, gyro_start, gyro_short) = split(&m.gyro, true);
    let (vrw, accel_in_run, accel_start, _) = split(&m.accel, false);
    FilterModel {
        noise: FilterNoise {
            arw_rad_per_sqrt_s: arw,
            vrw_mps_per_sqrt_s: vrw,
            gyro_bias_rad_s: gyro_in_run,
            accel_bias_mps2: accel_in_run,
            gyro_scale: 0.0,
            accel_scale: 0.0,
            correlation_time_s: tau_f,
            gyro_cross_coupling_rad: off_diagonal_rms(&m.gyro.misalignment),
            accel_cross_coupling_rad: off_diagonal_rms(&m.accel.misalignment),
            gyro_g_sensitivity: m.g_sensitivity_rad_s_per_m_s2.amax(),
            gyro_bias_instability_rad_s: gyro_short.0,
            gyro_bias_instability_time_s: gyro_short.1,
        },
        start_sigma: SensorErrors {
            gyro_bias_rad_s: gyro_start,
            accel_bias_mps2: accel_start,
            gyro_scale: Vector3::repeat(m.gyro.scale_sigma()),
            accel_scale: Vector3::repeat(m.accel.scale_sigma()),
        },
    }
}

/// The 1-sigma of a misalignment matrix's elements (the filter's `*_cross_coupling_rad`):
/// the RMS of its six off-diagonals [rad], the grade's spread of such elements (a sensor's
/// matrix is one draw of it; `nav bench consistency` draws one per run).
pub fn off_diagonal_rms(m: &nav_core::nalgebra::Matrix3<f64>) -> f64 {
    let sum2 = m.norm_squared() - m.diagonal().norm_squared();
    (sum2.max(0.0) / 6.0).sqrt()
}

/// `f64` settings in the working scalar.
pub fn config_in<T: Scalar>(c: &FilterConfig<f64>) -> FilterConfig<T> {
    let v = |v: &Vector3<f64>| v.map(T::c);
    FilterConfig {
        noise: c.noise.cast(),
        sensor_sigma: c.sensor_sigma.map(|s| s.cast()),
        scale_factors: c.scale_factors,
        propagation_interval_s: T::c(c.propagation_interval_s),
        antenna_lever_arm_b_m: v(&c.antenna_lever_arm_b_m),
        gnss_correlated_error: c.gnss_correlated_error.map(|g| {
            nav_core::ins_filter::GnssCorrelatedError {
                sigma_ned_m: v(&g.sigma_ned_m),
                correlation_time_s: T::c(g.correlation_time_s),
            }
        }),
        gate_nis: T::c(c.gate_nis),
        gap_dynamics: nav_core::gap::GapDynamics {
            omega_sigma_rad_s: T::c(c.gap_dynamics.omega_sigma_rad_s),
            f_sigma_mps2: T::c(c.gap_dynamics.f_sigma_mps2),
            omega_accel_rad_s2: T::c(c.gap_dynamics.omega_accel_rad_s2),
        },
        rejections_to_degrade: c.rejections_to_degrade,
        refused_time_to_degrade_s: T::c(c.refused_time_to_degrade_s),
        max_horizontal_sigma_m: T::c(c.max_horizontal_sigma_m),
        zero_motion: c
            .zero_motion
            .map(|z| nav_core::ins_filter::ZeroMotionConfig {
                detector: nav_core::ins_filter::stationarity::StationarityConfig {
                    window_s: T::c(z.detector.window_s),
                    noise_ratio: T::c(z.detector.noise_ratio),
                    accel_floor_mps2_sq: T::c(z.detector.accel_floor_mps2_sq),
                    gyro_floor_rad_s_sq: T::c(z.detector.gyro_floor_rad_s_sq),
                    max_rate_rad_s: T::c(z.detector.max_rate_rad_s),
                    max_gravity_error_mps2: T::c(z.detector.max_gravity_error_mps2),
                    max_horizontal_specific_force_mps2: T::c(
                        z.detector.max_horizontal_specific_force_mps2,
                    ),
                    windows_to_declare: z.detector.windows_to_declare,
                },
                velocity_sigma_m_s: T::c(z.velocity_sigma_m_s),
                rate_sigma_rad_s: T::c(z.rate_sigma_rad_s),
                max_speed_m_s: T::c(z.max_speed_m_s),
            }),
        mechanization: nav_core::MechanizationConfig::default(),
    }
}

/// The fastest start a user may give [m/s]: faster than an orbit is a unit or typing error.
pub const MAX_START_SPEED_M_S: f64 = 8_000.0;

/// A given start in output units (KF-GINS's `initpos`, `initvel`, `initatt`, `init*std`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GivenStart {
    /// Latitude, longitude [deg], height [m] of the IMU.
    pub pos_deg_m: [f64; 3],
    /// Velocity north, east, down [m/s].
    pub vel_m_s: [f64; 3],
    /// Roll, pitch, yaw [deg].
    pub att_deg: [f64; 3],
    /// 1-sigma position north, east, down [m].
    pub pos_std_m: [f64; 3],
    /// 1-sigma velocity [m/s].
    pub vel_std_m_s: [f64; 3],
    /// 1-sigma roll, pitch, yaw [deg].
    pub att_std_deg: [f64; 3],
    /// Sensor errors known at the start (compensated from the first sample).
    pub sensors: SensorErrors<f64>,
    /// Their 1-sigma (`None`: the configuration's, [`FilterConfig::start_sensor_sigma`]).
    pub sensor_sigma: Option<SensorErrors<f64>>,
}

impl GivenStart {
    /// nav-core's start in precision `T`, or why the values are not a start.
    pub fn start<T: Scalar>(&self, config: &FilterConfig<f64>) -> Result<Start<T>> {
        let all = self
            .pos_deg_m
            .iter()
            .chain(&self.vel_m_s)
            .chain(&self.att_deg)
            .chain(&self.pos_std_m)
            .chain(&self.vel_std_m_s)
            .chain(&self.att_std_deg);
        if !all.clone().all(|v| v.is_finite()) {
            bail!("the initial state and its 1-sigma must be finite numbers");
        }
        if self.pos_deg_m[0].abs() > 90.0 {
            bail!(
                "initial latitude {} deg is beyond +-90",
                Number(self.pos_deg_m[0])
            );
        }
        if self.pos_deg_m[1].abs() > 180.0 {
            bail!(
                "initial longitude {} deg is beyond +-180",
                Number(self.pos_deg_m[1])
            );
        }
        let h_m = self.pos_deg_m[2];
        if !(MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&h_m) {
            bail!(
                "initial height {} m is not within [{MIN_HEIGHT_M}, {MAX_HEIGHT_M}] m (the \
                 Earth model's range)",
                Number(h_m)
            );
        }
        // Scaled by the largest component: the squares of 1e300 m/s would overflow to inf.
        let largest = self.vel_m_s.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let speed_m_s = if largest > 0.0 {
            largest
                * self
                    .vel_m_s
                    .iter()
                    .map(|v| (v / largest).powi(2))
                    .sum::<f64>()
                    .sqrt()
        } else {
            0.0
        };
        if speed_m_s > MAX_START_SPEED_M_S {
            bail!(
                "initial speed {} m/s is beyond {MAX_START_SPEED_M_S} m/s (faster than an \
                 orbit): check the units (m/s) and the order (north, east, down)",
                Rounded(speed_m_s)
            );
        }
        let [roll_deg, pitch_deg, yaw_deg] = self.att_deg;
        if roll_deg.abs() > 180.0 || pitch_deg.abs() > 90.0 || yaw_deg.abs() > 360.0 {
            bail!(
                "initial roll {} deg, pitch {} deg and yaw {} deg must be within +-180, +-90 and \
                 +-360 deg (check the order: roll, pitch, yaw)",
                Number(roll_deg),
                Number(pitch_deg),
                Number(yaw_deg)
            );
        }
        let [r, p, y] = self.att_deg.map(|d| T::c(d.to_radians()));
        let v3 = |a: [f64; 3]| Vector3::new(T::c(a[0]), T::c(a[1]), T::c(a[2]));
        let state = NavState {
            q_b_n: attitude::from_euler(r, p, y),
            v_eb_n: v3(self.vel_m_s),
            position: Position::from_degrees(
                self.pos_deg_m[0],
                self.pos_deg_m[1],
                self.pos_deg_m[2],
            ),
        };
        let sensors = self
            .sensor_sigma
            .unwrap_or_else(|| config.start_sensor_sigma())
            .cast();
        let sigma = InitialSigma::new(
            v3(self.pos_std_m),
            v3(self.vel_std_m_s),
            v3(self.att_std_deg.map(f64::to_radians)),
            &sensors,
        );
        if let Some(why) = nav_core::ins_filter::limits::initial_sigma_out_of_range(&sigma) {
            bail!("{why}");
        }
        let s = &self.sensors;
        Ok(Start::Given {
            state,
            sensors: SensorErrors {
                gyro_bias_rad_s: s.gyro_bias_rad_s.map(T::c),
                accel_bias_mps2: s.accel_bias_mps2.map(T::c),
                gyro_scale: s.gyro_scale.map(T::c),
                accel_scale: s.accel_scale.map(T::c),
            },
            sigma,
        })
    }
}

/// How an aided replay starts.
#[derive(Clone, Debug, PartialEq)]
pub enum AidedStart {
    /// From a given state.
    Given(Box<GivenStart>),
    /// In motion from GNSS.
    Motion {
        /// Horizontal speed above which the track gives the heading [m/s].
        min_speed_m_s: f64,
        /// 1-sigma of the body's forward axis off the ground track, the heading's doubt
        /// besides the velocity's (`MotionAlignConfig::sideslip_rad`) [rad].
        sideslip_rad: f64,
    },
}

impl AidedStart {
    /// In motion from GNSS, with the start's own heading threshold and sideslip allowance
    /// (a land vehicle's).
    pub fn motion() -> Self {
        let d = MotionAlignConfig::<f64>::default();
        AidedStart::Motion {
            min_speed_m_s: d.min_speed_m_s,
            sideslip_rad: d.sideslip_rad,
        }
    }
}

/// `nav replay --gnss`'s inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct AidedReplay {
    /// The IMU recording (any format).
    pub imu: PathBuf,
    /// The GNSS file.
    pub gnss: PathBuf,
    /// The 1-sigma of a GNSS file without its own (gnss-ins-sim's GPS file).
    pub gnss_sigma: Option<gnss::AssumedSigma>,
    /// The receiver's output latency [s]: its fixes are taken at their tags less it
    /// ([`crate::gnss_file::at_measurement_epochs`]).
    pub gnss_latency_s: f64,
    /// The solution log.
    pub out: PathBuf,
    /// The filter's settings.
    pub config: FilterConfig<f64>,
    /// The start.
    pub start: AidedStart,
    /// Samples between logged rows.
    pub log_every: u32,
    /// Where the IMU's axes clip (`--imu-range`; `None`: no sample is taken as clipped).
    pub full_scale: Option<FullScale>,
}

/// The sequencer of a start in precision `T`.
pub fn sequencer<T: Scalar>(
    config: &FilterConfig<f64>,
    start: &AidedStart,
) -> Result<Sequencer<T>> {
    let start = match start {
        AidedStart::Given(g) => g.start::<T>(config)?,
        AidedStart::Motion {
            min_speed_m_s,
            sideslip_rad,
        } => {
            let d = MotionAlignConfig::<f64>::default();
            Start::Motion(MotionAlignConfig {
                min_speed_m_s: T::c(*min_speed_m_s),
                max_accel_mps2: T::c(d.max_accel_mps2),
                sideslip_rad: T::c(*sideslip_rad),
                accel_bias_mps2: T::c(config.noise.accel_bias_mps2.max(d.accel_bias_mps2)),
                gyro_bias_rad_s: T::c(config.noise.gyro_bias_rad_s),
                arw_rad_per_sqrt_s: T::c(config.noise.arw_rad_per_sqrt_s),
            })
        }
    };
    Sequencer::new(config_in(config), start).map_err(|e| anyhow!("filter settings: {e}"))
}

/// Runs an aided replay in precision `T`, writing the log atomically.
pub fn replay_aided<T: Scalar>(a: &AidedReplay) -> Result<(AidedReport, u64)> {
    atomic::refuse_same_file(&[&a.imu, &a.gnss], &a.out)?;
    crate::gnss_file::refuse_the_imu_recording(&a.gnss, &a.imu)?;
    crate::gnss_file::check_latency(a.gnss_latency_s)?;
    let mut fixes: Vec<GnssFix> =
        crate::gnss_file::read_as_text_fixes(&a.gnss, a.gnss_sigma.as_ref())?;
    // At their measurement epochs (a tag before the latency is then not on the clock: a bad
    // time tag, as in `gnss_file::at_measurement_epochs`).
    for f in &mut fixes {
        f.t_s -= a.gnss_latency_s;
    }
    let seq = sequencer::<T>(&a.config, &a.start)?;
    let (mut source, _format) = ReplaySource::open(&a.imu)?;
    let report = atomic::write(&a.out, |w| -> Result<(AidedReport, u64)> {
        writeln!(w, "{}", aided::header())?;
        let mut tally = aided::StatusTally::default();
        let mut rows = aided::CsvRows::new(a.log_every, |row: &AidedRow| {
            tally.add(row.solution.t_us as f64 * 1e-6, row.status);
            writeln!(w, "{row}")?;
            Ok(())
        });
        let mut marked = ClipMarked {
            source: &mut source,
            full_scale: a.full_scale,
        };
        let mut report = aided::run_source(&mut marked, &fixes, seq, &mut rows)?;
        let n_rows = rows.rows();
        report.status = tally;
        if report.start_s.is_none() {
            bail!(
                "the filter never started: {}",
                match a.start {
                    AidedStart::Motion { min_speed_m_s, .. } => sparse_fixes(&fixes).unwrap_or_else(|| {
                        format!(
                            "no GNSS fix found the vehicle level (quasi-static) and then moving faster than the heading threshold ({} m/s, --start-speed) and {} times the noise of its velocity ({})",
                            nav_core::number::Number(min_speed_m_s),
                            nav_core::number::Number(MIN_SPEED_SIGMAS),
                            velocity_noise(&fixes)
                        )
                    }),
                    AidedStart::Given(_) => aided::no_usable_sample(&report),
                }
            );
        }
        crate::replay::check_refused_share(report.samples, report.rejected, "of the run")?;
        check_some_fix_used(&report.counters)?;
        writeln!(
            w,
            "{}",
            nav_core::output::EndRecord {
                rows: u32::try_from(n_rows).unwrap_or(u32::MAX)
            }
        )?;
        Ok((report, n_rows))
    })?;
    Ok(report)
}

/// The velocity noise of `fixes` as a start in motion sees it, for its refusal: the
/// receiver's velocity 1-sigma (median of the horizontal ones), or, without velocities, the
/// positions' horizontal 1-sigma differenced over their median interval (`sqrt(2) sigma /
/// dt`), each with the speed [`MIN_SPEED_SIGMAS`] times it.
fn velocity_noise(fixes: &[GnssFix]) -> String {
    let median = |mut v: Vec<f64>| {
        v.retain(|x| x.is_finite());
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    let horizontal = |s: &[f64; 3]| s[0].hypot(s[1]) / 2_f64.sqrt();
    let velocity = median(
        fixes
            .iter()
            .filter_map(|f| f.velocity.as_ref().map(|v| horizontal(&v.sigma_ned_m_s)))
            .collect(),
    );
    if let Some(sigma) = velocity {
        return format!(
            "the fixes' velocity 1-sigma {} m/s: {} m/s",
            Rounded(sigma),
            Rounded(MIN_SPEED_SIGMAS * sigma)
        );
    }
    let position = median(fixes.iter().map(|f| horizontal(&f.sigma_ned_m)).collect());
    let interval = median(fixes.windows(2).map(|w| w[1].t_s - w[0].t_s).collect());
    match (position, interval) {
        (Some(sigma), Some(dt)) if dt > 0.0 => {
            let noise = 2_f64.sqrt() * sigma / dt;
            format!(
                "{} m positions without a velocity, differenced over {} s: {} m/s",
                Rounded(sigma),
                Rounded(dt),
                Rounded(MIN_SPEED_SIGMAS * noise)
            )
        }
        _ => "positions without a velocity, differenced".to_owned(),
    }
}

/// Why a start in motion cannot start on `fixes` whatever the motion: no two consecutive
/// fixes with a finite place are within [`MAX_FIX_INTERVAL_S`] of each other (the start takes
/// fixes farther apart as an outage, `nav_core::ins_filter::motion`); `None` when two are.
pub fn sparse_fixes(fixes: &[GnssFix]) -> Option<String> {
    let placed: Vec<f64> = fixes
        .iter()
        .filter(|f| [f.lat_rad, f.lon_rad, f.h_m].iter().all(|v| v.is_finite()))
        .map(|f| f.t_s)
        .collect();
    let closest_s = placed
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    (closest_s > MAX_FIX_INTERVAL_S).then(|| {
        let closest = if closest_s.is_finite() {
            format!("the closest are {} s apart", Rounded(closest_s))
        } else {
            "there is one fix".to_owned()
        };
        format!(
            "no two GNSS fixes are within {MAX_FIX_INTERVAL_S} s of each other ({closest}): the \
             start in motion takes a velocity from two fixes at most {MAX_FIX_INTERVAL_S} s \
             apart (farther apart, their position difference is the mean velocity of an \
             outage); give fixes at 0.5 Hz or faster, or a given start (--init-pos, --init-vel, \
             --init-att)"
        )
    })
}

/// The report's lines for the terminal.
pub fn summary(r: &AidedReport, rows: u64, imu: &Path, out: &Path) -> String {
    let c = &r.counters;
    let line = |name: &str, a: &nav_core::ins_filter::AidCounters| format!("{name}: {a}");
    [
        format!(
            "{}: {} samples ({} flagged, {} refused, {} out of time order), {} rows -> {}",
            imu.display(),
            r.samples,
            r.flagged,
            r.rejected,
            r.out_of_order,
            rows,
            out.display()
        ),
        match (r.start_s, &r.motion_start) {
            (Some(t), Some(m)) => m.line(t),
            (Some(t), None) => format!("filter started at t = {t:.3} s"),
            (None, _) => "filter never started".into(),
        },
        line("GNSS position", &c.position),
        line("GNSS velocity", &c.velocity),
        line("zero velocity", &c.zero_velocity),
        line("zero rate", &c.zero_rate),
        format!(
            "fixes: {} received, {} before/after the IMU data, {} bad time tags, {} out of order, {} dropped from a full queue, {} late, {} used by the start",
            r.fixes.received,
            r.outside_imu_data,
            r.bad_time_tags,
            r.fixes.out_of_order,
            r.fixes.queue_full,
            r.fixes.late,
            r.fixes.for_start
        ),
        format!(
            "covariance propagations: {}, faults: {}",
            c.propagations, r.covariance_faults
        ),
    ]
    .into_iter()
    .chain(r.status.line())
    .chain(r.sensors.map(|e| e.line()))
    .chain(refused_run_line(&r.updates))
    .chain(r.gnss_latency.as_ref().map(latency_line))
    .chain(realignment_line(&r.realignments))
    .chain(aiding_warnings(r))
    .collect::<Vec<_>>()
    .join("\n")
}

/// Position fixes refused in a row from which the summary names the longest such run [-].
pub const REFUSED_RUN_TOLD: usize = 5;

/// The line naming the longest run of GNSS position fixes refused in a row (invalid ones
/// within it do not break it), when it is [`REFUSED_RUN_TOLD`] fixes or more; `None`
/// otherwise. The solution coasted on the IMU over it: the counts alone said nothing of 67
/// RTK fixes refused in a row, the solution 1 m off at their end.
pub fn refused_run_line(updates: &[UpdateRecord]) -> Option<String> {
    // (fixes, first, last time [s]) of the run going on, and of the longest.
    let mut run: Option<(usize, f64, f64)> = None;
    let mut longest: Option<(usize, f64, f64)> = None;
    for u in updates {
        run = match u.position {
            AidResult::Rejected { .. } => {
                Some(run.map_or((1, u.t_s, u.t_s), |(n, first, _)| (n + 1, first, u.t_s)))
            }
            AidResult::Accepted { .. } => None,
            AidResult::Invalid => run,
        };
        if let Some(r) = run
            && longest.is_none_or(|l| r.0 > l.0)
        {
            longest = Some(r);
        }
    }
    let (n, first, last) = longest.filter(|l| l.0 >= REFUSED_RUN_TOLD)?;
    Some(format!(
        "longest refusal: {n} GNSS position fixes in a row, from t = {first:.3} s to \
         {last:.3} s (the solution coasted on the IMU over those {:.1} s)",
        last - first
    ))
}

/// The line of a run that re-aligned in motion after gaps in the IMU data too long to bridge
/// or after its filter diverged (`nav_core::ins_filter::sequencer`), or is still re-aligning
/// at its end; `None` without one.
pub fn realignment_line(r: &Realignments) -> Option<String> {
    (r.begun > 0).then(|| {
        let us = |t: u64| format!("{:.3}", t as f64 * 1e-6);
        let (why, sensors) = match r.last_cause {
            RealignCause::LostGap => (
                format!(
                    "IMU data lost beyond the bridge (the last: a lost IMU gap of {} s ending \
                     at t = {} s",
                    us(r.gap_us),
                    us(r.gap_end_us)
                ),
                "with the sensor errors it had estimated",
            ),
            RealignCause::Diverged => (
                format!(
                    "the filter diverged (the last at t = {} s: it refused the fixes in a row \
                     until DEGRADED, with its own 1-sigma beyond the limit or its position \
                     never confirmed by a full window of fixes; or, its own 1-sigma beyond the \
                     limit, for a window of fixes each refused alone, moving away from it; or, \
                     for a window of fixes refused as a jump that ran away faster than any \
                     GNSS fault moves (the IMU's fault)",
                    us(r.begun_us)
                ),
                "with the sensor errors known as at the start (the diverged filter's \
                 estimates dropped)",
            ),
        };
        let diverged = match r.diverged {
            0 => String::new(),
            n if n == r.begun => String::new(),
            n => format!(", {n} of them after a divergence"),
        };
        let over = match r.started_over {
            0 => String::new(),
            n => format!(", {n} started over by another lost gap"),
        };
        if r.completed == r.begun {
            format!(
                "re-aligned in motion {} time(s) after {why}{diverged}{over}): the filter \
                 navigates again from t = {} s {sensors}; from t = {} s until then the rows are \
                 the set-aside solution's, DEGRADED",
                r.completed,
                us(r.navigating_us),
                us(r.begun_us)
            )
        } else {
            format!(
                "WARNING: re-aligning in motion since t = {} s after {why}{diverged}{over}), not \
                 completed at the end of the data (no level over a quasi-static interval, or no \
                 speed above the heading threshold: positions alone seldom show a quasi-static \
                 interval in motion, fixes with a velocity do): the rows since are the set-aside \
                 solution's, DEGRADED",
                us(r.begun_us)
            )
        }
    })
}

/// Refuses an aided run whose filter refused every GNSS fix it was given and used none
/// (`c` its counters): its solution is free-inertial from a start every fix contradicts (a
/// KF-GINS `initpos` in radians, a `starttime` after the `initpos` epoch, fixes on a clock
/// 30 s off), not the aided one asked for, and its file (a `.nav` has no status column) would
/// not say so. The same for a given start, a start in motion, `nav kf-gins` and the
/// navigator's aided phase. Fixes never given to it (all before the aided phase) leave the
/// warning of [`position_warning`].
pub fn check_some_fix_used(c: &nav_core::ins_filter::FilterCounters) -> Result<()> {
    let (p, v) = (&c.position, &c.velocity);
    if p.accepted + v.accepted > 0 || p.rejected + v.rejected == 0 {
        return Ok(());
    }
    bail!(
        "the filter refused every GNSS fix it was given (position: {} refused, {} invalid; \
         velocity: {} refused, {} invalid) and used none: the solution would be free-inertial \
         from a start the fixes contradict; check the start (--init-pos in degrees, KF-GINS's \
         initpos and its starttime epoch, or the alignment's site) and its 1-sigma, the \
         antenna lever arm, and the fixes' 1-sigma and time tags",
        p.rejected,
        p.invalid,
        v.rejected,
        v.invalid
    )
}

/// Warnings for a run whose GNSS aiding did not work as the user meant: IMU time not
/// navigated, and [`position_warning`].
pub fn aiding_warnings(r: &AidedReport) -> Vec<String> {
    let unused = format!(
        "{} before/after the IMU data, {} bad time tags",
        r.outside_imu_data, r.bad_time_tags
    );
    let position = r
        .start_s
        .and_then(|_| position_warning(&r.counters.position, &unused));
    let velocity = r
        .start_s
        .and_then(|_| velocity_warning(&r.counters.velocity));
    let stops = r.start_s.and_then(|_| stop_warning(&r.counters));
    let noisy = r.noise_scales.as_ref().and_then(noise_scale_warning);
    let unordered = out_of_order_warning(r.fixes.out_of_order);
    let late = r
        .gnss_latency
        .as_ref()
        .and_then(|e| latency_warning(e, r.gnss_late_at_s));
    r.lost
        .warning()
        .into_iter()
        .chain(r.near_pole.map(near_pole_warning))
        .chain(position)
        .chain(velocity)
        .chain(stops)
        .chain(late)
        .chain(noisy)
        .chain(unordered)
        .collect()
}

/// The sensor errors a filter had estimated by the end of a run, and their 1-sigma (SI).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorEstimate {
    /// The estimates.
    pub errors: SensorErrors<f64>,
    /// Their 1-sigma: gyro bias [rad/s], accelerometer bias [m/s^2], gyro and accelerometer
    /// scale factors [-] (zero when the filter does not estimate them).
    pub sigma: [Vector3<f64>; 4],
}

impl SensorEstimate {
    /// Of a filter whose estimates are `errors` and whose state block at offset `at` has the
    /// 1-sigma `sigma(at)`.
    pub fn of<T: Scalar>(errors: &SensorErrors<T>, sigma: impl Fn(usize) -> Vector3<T>) -> Self {
        Self {
            errors: errors.cast(),
            sigma: [BG, BA, SG, SA].map(|at| sigma(at).map(T::to_f64)),
        }
    }

    /// The summary's line, in KF-GINS's units (`nav kf-gins --imu-err`): biases [deg/h] and
    /// [mGal], scale factors [ppm] when the filter estimated them.
    pub fn line(&self) -> String {
        let e = &self.errors;
        let v = sensor_fields(
            &e.gyro_bias_rad_s,
            &e.accel_bias_mps2,
            &e.gyro_scale,
            &e.accel_scale,
        );
        let [gb, ab, gs, sa] = &self.sigma;
        let s = sensor_fields(gb, ab, gs, sa);
        let names = [
            "gyro bias [deg/h]",
            "accelerometer bias [mGal]",
            "gyro scale factor [ppm]",
            "accelerometer scale factor [ppm]",
        ];
        let parts: Vec<String> = names
            .iter()
            .enumerate()
            .filter(|(k, _)| s[3 * k..3 * k + 3].iter().any(|x| *x > 0.0))
            .map(|(k, name)| {
                let axes: Vec<String> = (3 * k..3 * k + 3)
                    .map(|i| {
                        // Three significant digits of the 1-sigma, the estimate to match.
                        let d = (2.0 - s[i].log10().floor()).clamp(0.0, 9.0) as usize;
                        format!("{:.d$} ({:.d$})", v[i], s[i])
                    })
                    .collect();
                format!("{name} {}", axes.join(", "))
            })
            .collect();
        format!(
            "sensor errors estimated at the end, x, y, z (1-sigma): {}",
            parts.join("; ")
        )
    }
}

/// The warning for `n` GNSS fixes whose time was not later than the fix before them (a
/// receiver's log that repeats an epoch or swaps two): the navigator skipped them
/// (`nav_core::ins_filter::sequencer::FixQueue::push`); `None` for none.
pub fn out_of_order_warning(n: u32) -> Option<String> {
    (n > 0).then(|| {
        format!(
            "WARNING: {n} GNSS fix(es) not later than the fix before them (an epoch the \
             receiver's log repeats, or fixes out of time order) were skipped"
        )
    })
}

/// The warning for fixes noisier than their declared 1-sigma: the learnt scales of the
/// position and velocity fixes' declared variances, `[[now, largest]; 2]`
/// (`nav_core::ins_filter::noise_scale`); `None` where neither was scaled.
pub fn noise_scale_warning(scales: &[[f64; 2]; 2]) -> Option<String> {
    let told: Vec<String> = ["position", "velocity"]
        .iter()
        .zip(scales)
        .filter(|(_, [_, peak])| *peak > 1.0)
        .map(|(name, [now, peak])| {
            format!(
                "the {name} fixes' variance as up to {peak:.1} times the declared (their 1-sigma \
                 {:.1} times; {now:.1} at the end)",
                peak.sqrt()
            )
        })
        .collect();
    (!told.is_empty()).then(|| {
        format!(
            "WARNING: the GNSS fixes were noisier than their declared 1-sigma: the filter took \
             {}, as their innovations showed; the file's 1-sigma columns are too small for \
             this receiver",
            told.join(" and ")
        )
    })
}

/// A latency test whose 1-sigma is beyond this [s] has not tested a receiver's output latency
/// (tenths of a second): its line says so rather than print the estimate.
const UNRESOLVED_LATENCY_S: f64 = 1.0;

/// The summary's line of the test of the fixes' time tags (`nav_core::ins_filter::latency`):
/// the estimate and its 1-sigma, whatever it found.
pub fn latency_line(e: &LatencyEstimate<f64>) -> String {
    let verdict = if e.detected {
        "FOUND (below)"
    } else {
        "within their noise, or too small to matter"
    };
    if !e.detected && e.sigma_s > UNRESOLVED_LATENCY_S {
        // Says nothing of a receiver's latency (a tenth of a second): one window of fixes
        // gave "late by -251.8974 s (1-sigma 239.8 s)".
        format!(
            "GNSS time tags: not tested ({} windows of fixes resolve a latency only to \
             1-sigma {:.3e} s)",
            e.windows, e.sigma_s
        )
    } else if e.sigma_s.is_finite() {
        format!(
            "GNSS time tags: the fixes late by {:.4} s (1-sigma {:.4} s) over {} windows of \
             fixes ({} left out as gross faults; their spread {:.2}): {verdict}",
            e.late_s, e.sigma_s, e.windows, e.gross_windows, e.spread
        )
    } else {
        format!(
            "GNSS time tags: not tested ({} windows of fixes, no change of velocity to show a \
             latency)",
            e.windows
        )
    }
}

/// The warning for fixes found lagging (or leading) their time tags
/// (`nav_core::ins_filter::latency`): the latency beyond any declared, with its 1-sigma and
/// what to do.
pub fn latency_warning(e: &LatencyEstimate<f64>, found_at_s: Option<f64>) -> Option<String> {
    e.detected.then(|| {
        let what = if e.late_s > 0.0 {
            format!(
                "lag their time tags by {:.3} s (1-sigma {:.3} s) beyond any declared latency: \
                 the receiver's output latency (a logger that tags fixes on arrival); declare \
                 it (nav replay --gnss-latency, added to any declared; for nav kf-gins, whose \
                 configuration has no such key, subtract it from the GNSS file's time tags)",
                e.late_s, e.sigma_s
            )
        } else {
            format!(
                "lead their time tags by {:.3} s (1-sigma {:.3} s): a declared latency too large, \
                 or the receiver's clock ahead of the IMU's",
                -e.late_s, e.sigma_s
            )
        };
        format!(
            "WARNING: the GNSS position fixes {what}; the solution followed fixes that were not \
             where their time tags said until {}, then took each fix at its tag less the \
             estimate (status DEGRADED from then on, its 1-sigma widened by the estimate's \
             1-sigma times the speed; found over {} windows of fixes)",
            found_at_s.map_or_else(
                || "it was found".to_string(),
                |t| format!("it was found at t = {t:.3} s")
            ),
            e.windows
        )
    })
}

/// The warning for a run whose filter came so near a pole (at `t_s` [s], latitude `lat_deg`
/// [deg]) that its NED error model does not hold (`nav_core::ins_filter::model::near_pole`):
/// the rows are DEGRADED from there on (a pass 97 m from the pole at 300 m/s was 22 sigma
/// off with status NAV, one over it turned to NaN).
pub fn near_pole_warning((t_s, lat_deg): (f64, f64)) -> String {
    format!(
        "WARNING: DEGRADED from t = {t_s:.3} s on: the solution came so near the {} Pole \
         (latitude {lat_deg:.6} deg) that the filter's NED error model does not hold (within \
         {} m of the polar axis, or the NED frame turning faster than {} rad/s): its solution \
         and 1-sigma are not trusted for the rest of the run",
        if lat_deg >= 0.0 { "North" } else { "South" },
        nav_core::ins_filter::model::MIN_POLE_DISTANCE_M,
        nav_core::ins_filter::model::MAX_NED_FRAME_RATE_RAD_S
    )
}

/// The warning for a run that believed stops (zero-velocity updates accepted) while it refused
/// more position fixes than it used: a vehicle moving straight at a steady speed below the
/// 1 m/s a stop is believed at looks still to the IMU, and the stops then hold the solution
/// while the fixes that show it moving are refused (a car creeping at 0.5 m/s: up to 52 m off
/// in 120 s, 105 of 120 fixes refused, 239 stops believed).
pub fn stop_warning(c: &nav_core::ins_filter::FilterCounters) -> Option<String> {
    let (p, z) = (&c.position, &c.zero_velocity);
    (z.accepted > 0 && p.rejected + p.invalid > p.accepted).then(|| {
        format!(
            "WARNING: {} stops believed (zero-velocity updates) while more GNSS position fixes \
             were refused than used: a vehicle moving straight at a steady speed below 1 m/s \
             looks still to the IMU; if it may (a ship, a robot, a crawler), run without the \
             stop updates (--no-stops)",
            z.accepted
        )
    })
}

/// The warning for a filter's GNSS velocity counters `v`: more velocity fixes refused or
/// invalid than used (the positions may carry the run alone, the velocities then ignored
/// without a word: km/h for m/s, up for down).
pub fn velocity_warning(v: &nav_core::ins_filter::AidCounters) -> Option<String> {
    if v.rejected + v.invalid > v.accepted {
        Some(format!(
            "WARNING: more GNSS velocity fixes refused ({}) or invalid ({}) than used ({}): \
             their unit (m/s), axes (north, east, down) or 1-sigma do not match the data",
            v.rejected, v.invalid, v.accepted
        ))
    } else {
        many_refused("velocity", v)
    }
}

/// Share of the fixes refused above which a run is warned of [-]: fixes as good as their
/// declared 1-sigma, to a filter whose noise model holds, are refused 0.1 % of the time by
/// the 99.9 % gate, and the windowed test's two 99.9 % tests add their own (0.1-0.5 % in
/// `nav bench consistency`; 0.2-0.3 % on 1 h of RTK fixes of white noise at their
/// 1-sigma).
const REFUSED_SHARE_WARNED: f64 = 0.05;

/// The warning for fixes of `kind` refused on more than [`REFUSED_SHARE_WARNED`] of them
/// (and not on most: the callers' stronger warning). A receiver that declares a 1-sigma
/// smaller than its noise had about half its fixes refused without a word, the solution off
/// by up to 17 of its 1-sigma, status NAV.
fn many_refused(kind: &str, c: &nav_core::ins_filter::AidCounters) -> Option<String> {
    let all = c.accepted + c.rejected;
    (c.rejected as f64 > REFUSED_SHARE_WARNED * all as f64).then(|| {
        format!(
            "WARNING: {} of {all} GNSS {kind} fixes refused ({:.0} %), where fixes as good as \
             their declared 1-sigma are refused 0.1-0.5 % of the time: the fixes' 1-sigma may \
             be too small, the filter's IMU noise too optimistic, the start, the lever arm or \
             the fixes' time tags (a receiver's latency: --gnss-latency) wrong, or the fixes faulty (jumps, \
             multipath); the solution's 1-sigma may then be too small",
            c.rejected,
            100.0 * c.rejected as f64 / all as f64
        )
    })
}

/// The warning for a filter's GNSS position counters `p`, once it ran: no fix used (the
/// solution is free-inertial; `unused` says where the others went), or more fixes refused than
/// used (the filter's noise model, the start, the lever arm or the fixes' 1-sigma do not match
/// the data).
/// The same for a given start, a start in motion and the navigator's aided phase.
pub fn position_warning(p: &nav_core::ins_filter::AidCounters, unused: &str) -> Option<String> {
    if p.accepted == 0 {
        Some(format!(
            "WARNING: no GNSS position fix was used ({} refused, {} invalid, {unused}): the \
             solution is free-inertial",
            p.rejected, p.invalid
        ))
    } else if p.rejected + p.invalid > p.accepted {
        Some(format!(
            "WARNING: more GNSS position fixes refused ({}) or invalid ({}) than used ({}): the \
             filter's IMU noise (--imu-noise, imunoise), the start and its 1-sigma (--init-*, \
             init*, or the alignment's), the antenna lever arm, the fixes' 1-sigma or their \
             time tags (a receiver's output latency, --gnss-latency: fixes tagged 0.2 s late \
             are 3 m behind a car at 15 m/s) do not match the data, and the solution may be \
             far off",
            p.rejected, p.invalid, p.accepted
        ))
    } else {
        many_refused("position", p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fixes refused on more than 5 % of them are warned of with the causes, fewer are not (a
    /// run's test of it, a receiver declaring 1 mm for 0.5 m, is now learnt by the noise
    /// scale, so the rule is held here).
    #[test]
    fn fixes_refused_beyond_the_gates_rate_are_warned_of() {
        let counters = |accepted, rejected| nav_core::ins_filter::AidCounters {
            accepted,
            rejected,
            ..Default::default()
        };
        let told = many_refused("position", &counters(260, 40)).unwrap();
        assert!(
            told.starts_with("WARNING: 40 of 300 GNSS position fixes refused (13 %)")
                && told.contains("the fixes' 1-sigma may be too small"),
            "{told}"
        );
        assert_eq!(many_refused("position", &counters(286, 14)), None);
    }

    /// The longest run of refused position fixes is named from 5 of them, an invalid fix
    /// within it not breaking it; shorter runs, and accepted fixes, are not.
    #[test]
    fn the_longest_run_of_refused_fixes_is_named() {
        let fix = |t_s: f64, position: AidResult<f64>| UpdateRecord {
            t_s,
            position,
            velocity: None,
        };
        let (ok, no) = (
            AidResult::Accepted { nis: 1.0 },
            AidResult::Rejected { nis: 20.0 },
        );
        let mut updates: Vec<_> = (0..4).map(|k| fix(f64::from(k), no)).collect();
        updates.push(fix(4.0, ok));
        assert_eq!(refused_run_line(&updates), None);
        for k in 5..12 {
            let r = if k == 8 { AidResult::Invalid } else { no };
            updates.push(fix(f64::from(k), r));
        }
        updates.push(fix(12.0, ok));
        let line = refused_run_line(&updates).unwrap();
        assert!(
            line.contains(
                "longest refusal: 6 GNSS position fixes in a row, from t = 5.000 s to 11.000 s"
            ) && line.contains("those 6.0 s"),
            "{line}"
        );
    }

    /// The latency warning names the lag or the lead with its 1-sigma, when it was found and
    /// what to do; nothing when none was found.
    #[test]
    fn the_latency_warning_says_which_way_and_what_to_do() {
        let late = LatencyEstimate {
            late_s: 0.1942,
            sigma_s: 0.0353,
            windows: 13,
            gross_windows: 0,
            spread: 1.0,
            detected: true,
        };
        let w = latency_warning(&late, Some(57.2)).unwrap();
        assert!(
            w.contains("lag their time tags by 0.194 s (1-sigma 0.035 s)"),
            "{w}"
        );
        assert!(
            w.contains("--gnss-latency") && w.contains("until it was found at t = 57.200 s"),
            "{w}"
        );
        // `nav kf-gins` takes no such option: its user is told what to do instead.
        assert!(
            w.contains("subtract it from the GNSS file's time tags"),
            "{w}"
        );
        let early = LatencyEstimate {
            late_s: -0.1,
            ..late
        };
        let w = latency_warning(&early, None).unwrap();
        assert!(w.contains("lead their time tags by 0.100 s"), "{w}");
        assert!(w.contains("a declared latency too large"), "{w}");
        assert!(w.contains("until it was found, then took each fix"), "{w}");
        let none = LatencyEstimate {
            detected: false,
            ..late
        };
        assert_eq!(latency_warning(&none, None), None);
        assert!(latency_line(&late).ends_with("FOUND (below)"));
        let line = latency_line(&none);
        assert!(
            line.contains("late by 0.1942 s (1-sigma 0.0353 s) over 13 windows"),
            "{line}"
        );
        let untested = LatencyEstimate {
            sigma_s: f64::INFINITY,
            ..none
        };
        assert!(latency_line(&untested).contains("not tested"));
        let unresolved = LatencyEstimate {
            late_s: -251.9,
            sigma_s: 239.8,
            windows: 1,
            ..none
        };
        let line = latency_line(&unresolved);
        assert!(
            line.contains("not tested (1 windows") && !line.contains("251"),
            "{line}"
        );
    }

    /// The summary's line names the cause of the last re-alignment and what the restarted
    /// filter kept: after a divergence, not the sensor errors it had estimated.
    #[test]
    fn the_realignment_line_says_why_and_what_was_kept() {
        let gap = Realignments {
            begun: 1,
            completed: 1,
            gap_us: 6_000_000,
            gap_end_us: 36_005_000,
            begun_us: 36_010_000,
            navigating_us: 38_000_000,
            ..Realignments::default()
        };
        let line = realignment_line(&gap).unwrap();
        assert!(line.contains("after IMU data lost beyond the bridge (the last: a lost IMU gap of 6.000 s ending at t = 36.005 s): the filter navigates again from t = 38.000 s with the sensor errors it had estimated"), "{line}");
        let diverged = Realignments {
            begun: 2,
            diverged: 1,
            last_cause: RealignCause::Diverged,
            begun_us: 113_000_000,
            navigating_us: 126_000_000,
            ..gap
        };
        let line = realignment_line(&diverged).unwrap();
        assert!(line.starts_with("WARNING: re-aligning in motion since t = 113.000 s after the filter diverged (the last at t = 113.000 s"), "{line}");
        let line = realignment_line(&Realignments {
            completed: 2,
            ..diverged
        })
        .unwrap();
        assert!(
            line.contains("re-aligned in motion 2 time(s) after the filter diverged"),
            "{line}"
        );
        assert!(line.contains(", 1 of them after a divergence): the filter navigates again from t = 126.000 s with the sensor errors known as at the start"), "{line}");
        assert_eq!(realignment_line(&Realignments::default()), None);
    }

    /// The grades' turn-on biases are random constants: the filter's model of them must not
    /// forget them in an hour (a Gauss–Markov state of correlation time `tau` loses
    /// `1 - exp(-2 t / tau)` of an unobserved variance; with `tau` = 1 h that was 86 %, and the
    /// bias blocks' NEES grew 7-fold over a 1 h run).
    #[test]
    fn the_turn_on_bias_is_not_forgotten_in_an_hour() {
        for grade in [
            Grade::Fog,
            Grade::Rlg,
            Grade::MemsTactical,
            Grade::MemsConsumer,
        ] {
            let m = grade_filter_model(grade);
            let kept = (-2.0 * 3600.0 / m.noise.correlation_time_s).exp();
            assert!(kept > 0.95, "{grade}: {kept}");
            let out = nav_core::ins_filter::limits::noise_out_of_range(&m.noise);
            assert_eq!(out, None, "{grade}");
            // The in-run drive is the grade's, whatever the correlation time: for the gyros
            // the rate random walk (their Gauss–Markov parts are short, counted as white).
            let drive = 2.0 * m.noise.gyro_bias_rad_s.powi(2) / m.noise.correlation_time_s;
            let rrw = grade.model().gyro.rate_random_walk;
            assert!((drive.sqrt() - rrw).abs() <= 1e-9 * rrw, "{grade}");
        }
    }
}
