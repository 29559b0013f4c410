//! The oscillator as the mechanization's attitude source, against a gyro-based run on the same
//! motion.
//!
//! - **Oscillator run**: the simulated readouts ([`simulate_oscillator`]) go through
//!   [`OscillatorEstimator`] (f64), its epochs through [`OscillatorIncrements`] (exact rotation
//!   vector between epochs, trapezoid velocity increment) into a [`Strapdown`] with
//!   `coning_sculling: false` (the angle increments are exact rotations, not integrated rates: a
//!   coning term would add a spurious correction). It starts from the true state at the first
//!   epoch's reference instant.
//! - **Gyro run**: the exact increments of the same trajectory at 400 Hz through the sensor model
//!   of a [`Grade`], rounded to `f32` as in a recording ([`crate::simulate`]), into a
//!   [`Strapdown`] with the default mechanization, from the true state at `t = 0`.
//!
//! The truth at an epoch's instant is interpolated from the simulator's truth kept every
//! [`TRUTH_STRIDE`]-th sample (linear in position and velocity, slerp in attitude). Both
//! vertical channels are free. Errors are taken at the end of each run and the attitude error
//! also every [`CHECK_S`] along the way.

use super::{OscillatorParams, simulate_oscillator};
use crate::sensor_model::{ErrorInjector, Grade};
use crate::trajectory::scenarios::Scenario;
use crate::trajectory::{Generator, Sampling, generate};
use crate::truth::{Truth, horizontal_distance_m};
use anyhow::{Result, anyhow, bail};
use nav_core::oscillator::{OscillatorConfig, OscillatorEstimator, OscillatorIncrements};
use nav_core::{ImuIncrement, MechanizationConfig, NavState, Position, Strapdown, Vector3};
use std::collections::BTreeMap;
use std::fmt;

/// Oscillator samples per kept truth (500 Hz at the default 5 kHz).
pub const TRUTH_STRIDE: u64 = 10;
/// Interval of the attitude checks along the runs [s].
pub const CHECK_S: f64 = 0.1;
/// Rate of the gyro-based IMU [Hz].
pub const GYRO_RATE_HZ: f64 = 400.0;

/// What to compare.
#[derive(Clone, Debug, PartialEq)]
pub struct NavCompareOptions {
    /// The motion.
    pub scenario: Scenario,
    /// Length [s].
    pub seconds: f64,
    /// The oscillator (its `seed` also seeds the gyro IMU's error model).
    pub params: OscillatorParams,
    /// Grade of the gyro-based IMU.
    pub grade: Grade,
    /// The estimator's rate compensation (`false`: the method of [Oscillator INS] as written).
    pub compensate: bool,
}

impl NavCompareOptions {
    /// `scenario` for `seconds` with the default oscillator, a FOG IMU, compensation on.
    pub fn new(scenario: Scenario, seconds: f64) -> Self {
        Self {
            scenario,
            seconds,
            params: OscillatorParams::default(),
            grade: Grade::Fog,
            compensate: true,
        }
    }
}

/// Errors of one navigation run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NavErrors {
    /// Start of the navigation [s].
    pub start_s: f64,
    /// End of the navigation, where the final errors are taken [s].
    pub end_s: f64,
    /// Horizontal position error at the end [m].
    pub horizontal_m: f64,
    /// Height error at the end (estimate - truth) [m].
    pub height_m: f64,
    /// Norm of the velocity error at the end [m/s].
    pub velocity_mps: f64,
    /// Attitude error at the end (angle between estimated and true `q_b_n`) [deg].
    pub attitude_deg: f64,
    /// Largest attitude error over the checks (every [`CHECK_S`]) and the end [deg].
    pub worst_attitude_deg: f64,
    /// Increments the mechanization refused.
    pub rejected: u32,
}

/// What the oscillator's estimator met.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OscillatorStats {
    /// Epochs given out.
    pub epochs: u64,
    /// Periods without an epoch.
    pub faults: u64,
    /// Those by kind, e.g. `"acquiring 9, noisy 1"` (`"none"`).
    pub faults_by_kind: String,
    /// Faults after navigation started: each loses the rotation over its gap.
    pub gaps: u64,
    /// Apse slips.
    pub slips: u64,
    /// Mean reported 1-sigma about the ellipse axes `e1`, `e2`, `e3` over the epochs [rad].
    pub sigma_rad_mean: Vector3<f64>,
    /// Mean reported 1-sigma of a specific-force component [m/s^2].
    pub sigma_f_mps2_mean: f64,
    /// The measured natural frequency at the end [Hz].
    pub frequency_hz: f64,
}

impl OscillatorStats {
    /// The largest axis of [`Self::sigma_rad_mean`] [rad].
    pub fn sigma_rad_max(&self) -> f64 {
        self.sigma_rad_mean.max()
    }
}

/// The motion's body rate and its derivatives, from the kept truth (mean rates over a readout
/// interval, differenced over [`TRUTH_STRIDE`] samples).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RateStats {
    /// Largest `|omega_ib_b|` [rad/s].
    pub max_rate_radps: f64,
    /// Largest `|d omega/dt|` [rad/s^2].
    pub max_rate_dot_radps2: f64,
    /// Largest `|d^2 omega/dt^2|` [rad/s^3].
    pub max_rate_ddot_radps3: f64,
    /// Largest `|f_ib_b|` [m/s^2].
    pub max_specific_force_mps2: f64,
}

/// The two runs' errors.
#[derive(Clone, Debug, PartialEq)]
pub struct NavComparison {
    /// Scenario name.
    pub scenario: &'static str,
    /// Requested length [s].
    pub seconds: f64,
    /// The estimator compensated the body rate.
    pub compensate: bool,
    /// Grade of the gyro run.
    pub grade: Grade,
    /// Oscillator-based run.
    pub oscillator: NavErrors,
    /// Gyro-based run.
    pub gyro: NavErrors,
    /// The estimator's counts.
    pub stats: OscillatorStats,
    /// The motion.
    pub motion: RateStats,
}

/// The navigation state of a truth (NED frame).
pub fn state_of(t: &Truth) -> NavState<f64> {
    NavState {
        q_b_n: t.q_b_ned,
        v_eb_n: t.v_eb_ned,
        position: Position::from_radians(t.lat, t.lon, t.h),
    }
}

/// The truth at `t_s` [s] from `kept` (ascending in time): linear in position and velocity,
/// slerp in attitude; `None` outside the kept span.
pub fn interpolate(kept: &[Truth], t_s: f64) -> Option<Truth> {
    let i = kept.partition_point(|x| x.t_s <= t_s);
    if i == 0 {
        return None;
    }
    let a = &kept[i - 1];
    if i == kept.len() {
        return (t_s - a.t_s <= 1e-12).then_some(*a);
    }
    let b = &kept[i];
    let u = (t_s - a.t_s) / (b.t_s - a.t_s);
    let lerp = |x: f64, y: f64| x + (y - x) * u;
    Some(Truth {
        t_s,
        lat: lerp(a.lat, b.lat),
        lon: lerp(a.lon, b.lon),
        h: lerp(a.h, b.h),
        v_eb_ned: a.v_eb_ned.lerp(&b.v_eb_ned, u),
        q_b_ned: a.q_b_ned.slerp(&b.q_b_ned, u),
    })
}

/// Attitude error [deg] of `nav` against `truth`.
fn attitude_error_deg(nav: &Strapdown<f64>, truth: &Truth) -> f64 {
    let s = nav.state().to_ned_frame();
    (truth.q_b_ned.inverse() * s.q_b_n).angle().to_degrees()
}

/// Final errors of `nav` against `truth`, into `e`.
fn finish(nav: &Strapdown<f64>, truth: &Truth, e: &mut NavErrors) {
    let s = nav.state().to_ned_frame();
    let p = &s.position;
    e.end_s = truth.t_s;
    e.horizontal_m = horizontal_distance_m(p.lat_f64(), p.lon_f64(), truth.h, truth.lat, truth.lon);
    e.height_m = p.h_f64() - truth.h;
    e.velocity_mps = (s.v_eb_n - truth.v_eb_ned).norm();
    e.attitude_deg = attitude_error_deg(nav, truth);
    e.worst_attitude_deg = e.worst_attitude_deg.max(e.attitude_deg);
    e.rejected = nav.rejected();
}

/// The oscillator run: its errors, the estimator's counts and the motion's rates.
fn oscillator_run(opts: &NavCompareOptions) -> Result<(NavErrors, OscillatorStats, RateStats)> {
    let p = &opts.params;
    let traj = opts.scenario.build()?;
    let mut cfg = OscillatorConfig::<f64>::new(p.sample_rate_hz, p.f0_hz);
    cfg.start_s = 1.0 / p.sample_rate_hz;
    cfg.compensate = opts.compensate;
    let lock_periods = cfg.lock_periods;
    let mut est =
        OscillatorEstimator::new(cfg).map_err(|e| anyhow!("oscillator estimator: {e}"))?;
    let mut incs = OscillatorIncrements::<f64>::new();
    let mech = MechanizationConfig {
        coning_sculling: false,
        ..Default::default()
    };
    let n = p.readouts_in(opts.seconds)?;
    let stride_dt = TRUTH_STRIDE as f64 / p.sample_rate_hz;

    let mut kept: Vec<Truth> = Vec::with_capacity((n / TRUTH_STRIDE + 2) as usize);
    let mut motion = RateStats::default();
    let mut rates: [Option<Vector3<f64>>; 2] = [None, None];
    let mut nav: Option<Strapdown<f64>> = None;
    let mut errors = NavErrors::default();
    let mut stats = OscillatorStats::default();
    let mut kinds: BTreeMap<&'static str, u64> = BTreeMap::new();
    let (mut sigma_sum, mut sigma_f_sum) = (Vector3::zeros(), 0.0);
    let mut next_check = 0.0;
    let mut last_t = None;
    let mut failure: Option<anyhow::Error> = None;

    simulate_oscillator(traj.as_ref(), p, opts.seconds, |k, sample, truth| {
        if failure.is_some() {
            return;
        }
        motion.max_rate_radps = motion.max_rate_radps.max(truth.omega_ib_b.norm());
        motion.max_specific_force_mps2 = motion.max_specific_force_mps2.max(truth.f_ib_b.norm());
        if (k + 1) % TRUTH_STRIDE == 0 || k + 1 == n {
            kept.push(truth.nav);
            if (k + 1) % TRUTH_STRIDE == 0 {
                let w = truth.omega_ib_b;
                if let Some(w1) = rates[0] {
                    let d1 = (w - w1) / stride_dt;
                    motion.max_rate_dot_radps2 = motion.max_rate_dot_radps2.max(d1.norm());
                    if let Some(w2) = rates[1] {
                        let d2 = (w - w1 * 2.0 + w2) / (stride_dt * stride_dt);
                        motion.max_rate_ddot_radps3 = motion.max_rate_ddot_radps3.max(d2.norm());
                    }
                }
                rates = [Some(w), rates[0]];
            }
        }
        let epoch = match est.add(&sample.r_b_m) {
            None => return,
            Some(Err(f)) => {
                stats.faults += 1;
                *kinds.entry(f.kind()).or_default() += 1;
                if nav.is_some() {
                    stats.gaps += 1;
                    incs.reset();
                }
                return;
            }
            Some(Ok(e)) => e,
        };
        stats.epochs += 1;
        sigma_sum += epoch.sigma_rad;
        sigma_f_sum += epoch.sigma_f_mps2;
        let Some(t_true) = interpolate(&kept, epoch.t_s) else {
            failure = Some(anyhow!("no truth at the epoch at {} s", epoch.t_s));
            return;
        };
        let inc = incs.push(&epoch);
        match (&mut nav, inc) {
            (None, _) => {
                nav = Some(Strapdown::new(state_of(&t_true), mech));
                errors.start_s = epoch.t_s;
                next_check = epoch.t_s + CHECK_S;
            }
            (Some(nav), Some(inc)) => {
                // A refused increment is counted by the mechanization (`rejected`).
                let _ = nav.step(&inc);
                last_t = Some(t_true);
                if epoch.t_s >= next_check {
                    next_check += CHECK_S;
                    let a = attitude_error_deg(nav, &t_true);
                    errors.worst_attitude_deg = errors.worst_attitude_deg.max(a);
                }
            }
            (Some(_), None) => {}
        }
    })?;
    if let Some(e) = failure {
        return Err(e);
    }
    let (Some(nav), Some(t_end)) = (nav, last_t) else {
        // A loop that never locked, its readouts clean: the run was too short (0.1 s was blamed
        // on a readout noise 1e4 times below the amplitude).
        let acquiring_only = !kinds.is_empty() && kinds.keys().all(|k| *k == "acquiring");
        if acquiring_only && p.readout_noise_m < 0.1 * p.major_m {
            bail!(
                "the oscillator gave {} epochs in {} s: nothing to navigate on (its phase-locked \
                 loop did not lock in the run's {} periods of the {} Hz oscillation: it must \
                 hold the phase for {} periods in a row, and an increment takes two epochs; a \
                 longer --seconds)",
                stats.epochs,
                opts.seconds,
                est.counters().periods,
                nav_core::number::Number(p.f0_hz),
                lock_periods
            );
        }
        bail!(
            "the oscillator gave {} epochs in {} s: nothing to navigate on (readout noise {} m \
             against an oscillation of {} m: a noise near the amplitude hides its periods; \
             --noise-m)",
            stats.epochs,
            opts.seconds,
            nav_core::number::Number(opts.params.readout_noise_m),
            nav_core::number::Number(opts.params.major_m)
        );
    };
    finish(&nav, &t_end, &mut errors);
    let c = est.counters();
    stats.slips = c.slips;
    stats.frequency_hz = est.frequency_hz();
    let m = stats.epochs.max(1) as f64;
    stats.sigma_rad_mean = sigma_sum / m;
    stats.sigma_f_mps2_mean = sigma_f_sum / m;
    stats.faults_by_kind = if kinds.is_empty() {
        "none".into()
    } else {
        kinds
            .iter()
            .map(|(k, v)| format!("{k} {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    Ok((errors, stats, motion))
}

/// The gyro run: the grade's IMU at [`GYRO_RATE_HZ`], `f32` increments, default mechanization.
fn gyro_run(opts: &NavCompareOptions) -> Result<NavErrors> {
    let traj = opts.scenario.build()?;
    let mut injector = ErrorInjector::new(opts.grade.model(), opts.params.seed)
        .map_err(|e| anyhow!("grade {}: {e}", opts.grade))?;
    let start = Generator::new(traj.as_ref()).truth();
    let mut nav = Strapdown::new(state_of(&start), MechanizationConfig::default());
    let mut errors = NavErrors {
        start_s: start.t_s,
        ..NavErrors::default()
    };
    let every = (CHECK_S * GYRO_RATE_HZ).round().max(1.0) as u64;
    let mut last = start;
    generate(
        traj.as_ref(),
        Sampling::new(GYRO_RATE_HZ, opts.seconds),
        |k, _, exact, truth| {
            let s = injector.apply(exact);
            let f32s = |v: &Vector3<f64>| v.map(|x| f64::from(x as f32));
            let inc = ImuIncrement {
                delta_theta_ib_b: f32s(&s.delta_theta_ib_b),
                delta_v_ib_b: f32s(&s.delta_v_ib_b),
                dt: s.dt,
            };
            let _ = nav.step(&inc);
            if (k + 1) % every == 0 {
                let a = attitude_error_deg(&nav, truth);
                errors.worst_attitude_deg = errors.worst_attitude_deg.max(a);
            }
            last = *truth;
        },
    );
    finish(&nav, &last, &mut errors);
    Ok(errors)
}

/// Runs both navigations on `opts.scenario` for `opts.seconds`.
pub fn compare(opts: &NavCompareOptions) -> Result<NavComparison> {
    if !(opts.seconds.is_finite() && opts.seconds > 0.0) {
        bail!(
            "seconds must be a positive number, not {}",
            nav_core::number::Number(opts.seconds)
        );
    }
    let (oscillator, stats, motion) = oscillator_run(opts)?;
    let gyro = gyro_run(opts)?;
    Ok(NavComparison {
        scenario: opts.scenario.name(),
        seconds: opts.seconds,
        compensate: opts.compensate,
        grade: opts.grade,
        oscillator,
        gyro,
        stats,
        motion,
    })
}

impl fmt::Display for NavComparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{}, {} s:", self.scenario, self.seconds)?;
        writeln!(f)?;
        writeln!(
            f,
            "| run | span [s] | horizontal [m] | height [m] | velocity [m/s] | attitude [deg] | worst attitude [deg] |"
        )?;
        writeln!(f, "|---|---|---|---|---|---|---|")?;
        let method = if self.compensate {
            "compensated"
        } else {
            "seed"
        };
        let gyro = format!("gyro {}", self.grade);
        for (name, e) in [
            (format!("oscillator ({method})"), &self.oscillator),
            (gyro, &self.gyro),
        ] {
            writeln!(
                f,
                "| {name} | {:.3}-{:.3} | {:.3e} | {:.3e} | {:.3e} | {:.3e} | {:.3e} |",
                e.start_s,
                e.end_s,
                e.horizontal_m,
                e.height_m,
                e.velocity_mps,
                e.attitude_deg,
                e.worst_attitude_deg
            )?;
        }
        writeln!(f)?;
        let s = &self.stats;
        writeln!(
            f,
            "oscillator: {} epochs, faults {} ({}), {} gaps in navigation, {} slips, {} + {} refused increments; mean 1-sigma {:.3e} / {:.3e} / {:.3e} rad (e1/e2/e3), {:.3e} m/s^2; f0 {:.6} Hz",
            s.epochs,
            s.faults,
            s.faults_by_kind,
            s.gaps,
            s.slips,
            self.oscillator.rejected,
            self.gyro.rejected,
            s.sigma_rad_mean.x,
            s.sigma_rad_mean.y,
            s.sigma_rad_mean.z,
            s.sigma_f_mps2_mean,
            s.frequency_hz
        )?;
        let m = &self.motion;
        writeln!(
            f,
            "motion: |omega| <= {:.3e} rad/s, |omega'| <= {:.3e} rad/s^2, |omega''| <= {:.3e} rad/s^3, |f| <= {:.3} m/s^2",
            m.max_rate_radps,
            m.max_rate_dot_radps2,
            m.max_rate_ddot_radps3,
            m.max_specific_force_mps2
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nav_core::UnitQuaternion;

    #[test]
    fn interpolation_is_linear_and_slerps() {
        let a = Truth {
            t_s: 1.0,
            lat: 0.1,
            lon: 0.2,
            h: 10.0,
            v_eb_ned: Vector3::new(1.0, 0.0, 0.0),
            q_b_ned: UnitQuaternion::identity(),
        };
        let b = Truth {
            t_s: 2.0,
            lat: 0.3,
            lon: 0.4,
            h: 20.0,
            v_eb_ned: Vector3::new(3.0, 0.0, 0.0),
            q_b_ned: UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.4),
        };
        let kept = [a, b];
        let m = interpolate(&kept, 1.25).unwrap();
        assert!((m.lat - 0.15).abs() < 1e-15 && (m.h - 12.5).abs() < 1e-12);
        assert!((m.v_eb_ned.x - 1.5).abs() < 1e-15);
        assert!((m.q_b_ned.angle() - 0.1).abs() < 1e-15);
        assert!(interpolate(&kept, 0.5).is_none());
        assert!(interpolate(&kept, 2.5).is_none());
        assert_eq!(interpolate(&kept, 2.0).unwrap().h, 20.0);
    }
}
