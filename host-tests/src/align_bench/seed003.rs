//! Seed 003 benchmark: fine alignment of an AUV's SINS at the surface under rocking, position
//! known (`auv-bench`: roll and pitch 5 deg, 11 s, for 5 min, IMU on the rotation centre, 45 deg
//! latitude), FOG sensors ([`Grade::Fog`]).
//!
//! The exact increments are generated once; every Monte Carlo run passes them through its own
//! seeded [`ErrorInjector`] and starts from its own coarse attitude (roll, pitch and heading off
//! by `INITIAL_*_DEG` with random signs, the same figures as the filter's initial sigmas, so
//! the expected squared error at every time equals the filter's variance when the filter is
//! optimal and consistent: for a fixed prior error `e0` the posterior mean error is
//! `(P_T / P_0) e0`, and with `|e0| = sigma_0` the mean squared error is exactly `P_T`).
//!
//! Tabulated at 30, 60, 120 and 300 s: the heading error's RMS over the runs with its 95 %
//! interval (`RMS / sqrt(1 +- 1.96 sqrt(2/N))`... computed from the chi-square spread), the
//! filters' own 1-sigma (deterministic: the covariance does not depend on the data), and the
//! floors, computed from the noise densities (`N_g` gyro [rad/sqrt(s)], `N_a` accelerometer
//! [m/s/sqrt(s)]), `W = Omega_ie cos(lat)`:
//! - general (motion unknown) Cramer–Rao floor
//!   `sqrt((N_g / (W sqrt(T)))^2 + (sqrt(12) N_a / (g W T^1.5))^2)`: the heading is the east
//!   tilt drift `W psi` over `W`; the gyro noise makes the tilt a random walk (its drift known to
//!   `N_g / sqrt(T)`), the accelerometers observe the tilt in white noise of density `N_a / g`
//!   (a line's slope over `T`: variance `12 (N_a/g)^2 / T^3`);
//! - motion-known floor `N_g / (W sqrt(T))`: the base sways about a fixed mean attitude, so the
//!   gyro-integrated attitude itself shows the tilt drift and only the gyro noise limits it.
//!
//! A second table runs with fixed biases (gyro 0.2 deg/h, accelerometer 0.005 m/s^2 on every
//! axis) and compares the errors at 300 s with the unobservable-bias predictions: heading
//! `eps_E / W` (plus the small `tan(lat) b_E / g` from the north tilt), level `b_N / g`,
//! `b_E / g` (nav-frame projections of the body biases, averaged over the rocking).

use crate::sensor_model::{ErrorInjector, Grade, ImuErrorModel};
use crate::trajectory::scenarios::Scenario;
use crate::trajectory::{Generator, Sampling, generate};
use anyhow::{Result, ensure};
use nav_core::alignment::AttitudeEstimate;
use nav_core::alignment::fine::{FineAlignment, FineConfig};
use nav_core::attitude::{self, quat_from_f64, quat_to_f64};
use nav_core::earth::{OMEGA_IE, normal_gravity};
use nav_core::{ImuIncrement, Position, Scalar, UnitQuaternion, Vector3};
use std::fmt::Write as _;

/// IMU rate [Hz].
pub const RATE_HZ: f64 = 400.0;
/// Times at which the errors are tabulated [s].
pub const CHECKPOINTS_S: [f64; 4] = [30.0, 60.0, 120.0, 300.0];
/// Initial roll and pitch errors of the coarse stage (random signs), also the filters' initial
/// 1-sigma [deg].
pub const INITIAL_LEVEL_ERROR_DEG: f64 = 0.5;
/// Initial heading error of the coarse stage (random sign), also the filters' initial 1-sigma
/// [deg].
pub const INITIAL_HEADING_ERROR_DEG: f64 = 10.0;
/// Fixed gyro bias of the bias table, every body axis [deg/h].
pub const GYRO_BIAS_DEG_H: f64 = 0.2;
/// Fixed accelerometer bias of the bias table, every body axis [m/s^2].
pub const ACCEL_BIAS_M_S2: f64 = 0.005;

/// `auv-bench`'s exact increments and truth, generated once.
#[derive(Clone, Debug)]
pub struct Recorded {
    /// Exact increments at [`RATE_HZ`].
    pub increments: Vec<ImuIncrement<f64>>,
    /// Truth `q_b_ned` at the end of each increment.
    pub q_b_n: Vec<UnitQuaternion<f64>>,
    /// Truth at the start.
    pub q_start: UnitQuaternion<f64>,
    /// Position of the IMU (fixed: it sits on the rotation centre).
    pub position: Position,
    /// Latitude [rad].
    pub lat_rad: f64,
    /// Height [m].
    pub h_m: f64,
}

impl Recorded {
    /// Index of the increment ending at `t_s` [s] (rounded), if recorded.
    pub fn index_at(&self, t_s: f64) -> Option<usize> {
        let k = (t_s * RATE_HZ).round() as usize;
        (k >= 1 && k <= self.increments.len()).then(|| k - 1)
    }
}

/// Generates `seconds` [s] of `scenario` (the IMU must not move: `auv-bench` has it on the
/// rotation centre) at [`RATE_HZ`].
pub fn record(scenario: &Scenario, seconds: f64) -> Result<Recorded> {
    let traj = scenario.build()?;
    let start = Generator::new(traj.as_ref()).truth();
    let s = Sampling::new(RATE_HZ, seconds);
    let mut increments = Vec::with_capacity(s.n as usize);
    let mut q_b_n = Vec::with_capacity(s.n as usize);
    let mut moved: f64 = 0.0;
    generate(traj.as_ref(), s, |_, _, inc, truth| {
        increments.push(*inc);
        q_b_n.push(truth.q_b_ned);
        moved = moved.max(truth.v_eb_ned.norm());
    });
    ensure!(
        moved < 1e-9,
        "the IMU moves ({moved} m/s): seed 003's bench has it on the rotation centre"
    );
    Ok(Recorded {
        increments,
        q_b_n,
        q_start: start.q_b_ned,
        position: Position::from_radians(start.lat, start.lon, start.h),
        lat_rad: start.lat,
        h_m: start.h,
    })
}

/// `auv-bench` with its defaults (45 deg latitude), `seconds` [s] long.
pub fn auv_bench(seconds: f64) -> Result<Recorded> {
    record(&Scenario::by_name("auv-bench")?, seconds)
}

/// The FOG grade with its noise only (turn-on biases off).
pub fn fog_noise_only() -> ImuErrorModel {
    let mut m = Grade::Fog.model();
    m.gyro.turn_on_bias_sigma = Vector3::zeros();
    m.accel.turn_on_bias_sigma = Vector3::zeros();
    m
}

/// Exact increments with fixed biases, `gyro_rad_s` [rad/s] and `accel_m_s2` [m/s^2] on every
/// body axis, and the FOG noise if `noise`.
pub fn fixed_biases(gyro_rad_s: f64, accel_m_s2: f64, noise: bool) -> ImuErrorModel {
    let mut m = if noise {
        fog_noise_only()
    } else {
        ImuErrorModel::IDEAL
    };
    m.gyro.bias = Vector3::repeat(gyro_rad_s);
    m.accel.bias = Vector3::repeat(accel_m_s2);
    m
}

/// The alignment method under test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// [`FineAlignment`]: the general position-aided filter.
    Fine,
}

/// The errors of one run at one checkpoint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checkpoint {
    /// Time [s].
    pub t_s: f64,
    /// Estimated minus true roll, pitch, yaw [rad].
    pub euler_error_rad: Vector3<f64>,
    /// Navigation-frame attitude error `phi_n` (estimate = `exp(-[phi x])` truth) [rad].
    pub phi_n_rad: Vector3<f64>,
    /// The filter's 1-sigma roll, pitch, yaw [rad].
    pub sigma_rad: Vector3<f64>,
}

/// One run's set-up.
#[derive(Clone, Copy, Debug)]
pub struct RunSetup<'a> {
    /// The sensor model.
    pub model: &'a ImuErrorModel,
    /// Injector seed.
    pub seed: u64,
    /// Initial roll, pitch, yaw errors of the coarse stage [rad].
    pub initial_error_rad: Vector3<f64>,
    /// Initial 1-sigma given to the filter [rad].
    pub initial_sigma_rad: Vector3<f64>,
    /// Filter configuration.
    pub fine: FineConfig<f64>,
}

/// The coarse stage's output: truth perturbed by `error` [rad], with `sigma` [rad].
pub fn coarse<T: Scalar>(
    q_true: &UnitQuaternion<f64>,
    error: &Vector3<f64>,
    sigma: &Vector3<f64>,
) -> AttitudeEstimate<T> {
    let (r, p, y) = attitude::euler(q_true);
    AttitudeEstimate {
        q_b_n: quat_from_f64(&attitude::from_euler(r + error.x, p + error.y, y + error.z)),
        sigma_rad: sigma.map(T::c),
        elapsed_s: T::zero(),
    }
}

/// Errors of `estimate` against the truth `q_true`.
pub fn errors<T: Scalar>(
    t_s: f64,
    estimate: &AttitudeEstimate<T>,
    q_true: &UnitQuaternion<f64>,
) -> Checkpoint {
    let q = quat_to_f64(&estimate.q_b_n);
    let (r, p, y) = attitude::euler(&q);
    let (r0, p0, y0) = attitude::euler(q_true);
    Checkpoint {
        t_s,
        euler_error_rad: Vector3::new(r - r0, p - p0, wrap_pi(y - y0)),
        phi_n_rad: -(q * q_true.inverse()).scaled_axis(),
        sigma_rad: estimate.sigma_rad.map(T::to_f64),
    }
}

fn wrap_pi(a: f64) -> f64 {
    crate::trajectory::wrap_pi(a)
}

/// Runs the general filter in precision `T` over `rec` with `setup`, returning the errors at
/// `checkpoints` [s] (those within the recording) and the final filter.
pub fn run_fine<T: Scalar>(
    rec: &Recorded,
    setup: &RunSetup<'_>,
    checkpoints: &[f64],
) -> Result<(Vec<Checkpoint>, FineAlignment<T>)> {
    let initial = coarse::<T>(
        &rec.q_start,
        &setup.initial_error_rad,
        &setup.initial_sigma_rad,
    );
    let config = fine_config_in::<T>(&setup.fine);
    let mut filter = FineAlignment::new(initial, rec.position, config);
    let mut injector = ErrorInjector::new(*setup.model, setup.seed)?;
    let marks: Vec<(usize, f64)> = checkpoints
        .iter()
        .filter_map(|&t| rec.index_at(t).map(|k| (k, t)))
        .collect();
    let mut out = Vec::with_capacity(marks.len());
    let mut next = marks.iter().peekable();
    for (k, exact) in rec.increments.iter().enumerate() {
        let sensed = injector.apply(exact);
        let inc = ImuIncrement {
            delta_theta_ib_b: sensed.delta_theta_ib_b.map(T::c),
            delta_v_ib_b: sensed.delta_v_ib_b.map(T::c),
            dt: T::c(sensed.dt),
        };
        filter.add(&inc)?;
        while let Some(&&(kk, t)) = next.peek() {
            if kk != k {
                break;
            }
            out.push(errors(t, &filter.estimate(), &rec.q_b_n[k]));
            next.next();
        }
    }
    Ok((out, filter))
}

/// `config` (f64) in precision `T`.
pub fn fine_config_in<T: Scalar>(c: &FineConfig<f64>) -> FineConfig<T> {
    let d = FineConfig::<T>::default();
    FineConfig {
        gyro_noise: T::c(c.gyro_noise),
        accel_noise: T::c(c.accel_noise),
        gyro_bias_sigma: T::c(c.gyro_bias_sigma),
        accel_bias_sigma: T::c(c.accel_bias_sigma),
        gyro_bias_walk: T::c(c.gyro_bias_walk),
        accel_bias_walk: T::c(c.accel_bias_walk),
        position_sigma_m: T::c(c.position_sigma_m),
        velocity_sigma_m_s: T::c(c.velocity_sigma_m_s),
        initial_velocity_sigma_m_s: T::c(c.initial_velocity_sigma_m_s),
        fallback_level_sigma: T::c(c.fallback_level_sigma),
        fallback_yaw_sigma: T::c(c.fallback_yaw_sigma),
        update_period_s: T::c(c.update_period_s),
        gate_sigma: T::c(c.gate_sigma),
        mechanization: d.mechanization,
    }
}

/// The filter configuration matched to a sensor model: its white-noise densities, and bias
/// sigmas `gyro_bias_sigma` [rad/s], `accel_bias_sigma` [m/s^2] (0 for the noise-only runs).
pub fn matched_config(
    model: &ImuErrorModel,
    gyro_bias_sigma: f64,
    accel_bias_sigma: f64,
) -> FineConfig<f64> {
    FineConfig {
        gyro_noise: model.gyro.white_noise.density(),
        accel_noise: model.accel.white_noise.density(),
        gyro_bias_sigma,
        accel_bias_sigma,
        ..FineConfig::default()
    }
}

/// The initial error of run `i`: the magnitudes of [`INITIAL_LEVEL_ERROR_DEG`] and
/// [`INITIAL_HEADING_ERROR_DEG`] with the signs of the bits of `i` (balanced over 8 runs).
pub fn initial_error(i: usize) -> Vector3<f64> {
    let sign = |bit: usize| if (i >> bit) & 1 == 0 { 1.0 } else { -1.0 };
    Vector3::new(
        sign(0) * INITIAL_LEVEL_ERROR_DEG,
        sign(1) * INITIAL_LEVEL_ERROR_DEG,
        sign(2) * INITIAL_HEADING_ERROR_DEG,
    )
    .map(f64::to_radians)
}

/// The filters' initial 1-sigma [rad].
pub fn initial_sigma() -> Vector3<f64> {
    Vector3::new(
        INITIAL_LEVEL_ERROR_DEG,
        INITIAL_LEVEL_ERROR_DEG,
        INITIAL_HEADING_ERROR_DEG,
    )
    .map(f64::to_radians)
}

/// Floors of the module docs [rad] at `t_s` [s] for noise densities `gyro_noise`
/// [rad/sqrt(s)] and `accel_noise` [m/s/sqrt(s)] at latitude `lat` [rad]: `(general, motion
/// known)`.
pub fn floors(t_s: f64, gyro_noise: f64, accel_noise: f64, lat: f64) -> (f64, f64) {
    let w = OMEGA_IE * lat.cos();
    let g = normal_gravity(lat, 0.0);
    let gyro = gyro_noise / (w * t_s.sqrt());
    let accel = 12f64.sqrt() * accel_noise / (g * w * t_s.powf(1.5));
    (gyro.hypot(accel), gyro)
}

/// Prints the benchmark tables for `runs` Monte Carlo runs per method (at least 20).
pub fn run(runs: usize) -> Result<String> {
    ensure!(runs >= 20, "at least 20 runs, not {runs}");
    let seconds = CHECKPOINTS_S[CHECKPOINTS_S.len() - 1];
    let rec = auv_bench(seconds)?;
    let model = fog_noise_only();
    let config = matched_config(&model, 0.0, 0.0);
    let mut out = String::new();
    let mut sq = vec![0.0; CHECKPOINTS_S.len()];
    let mut sigma = vec![0.0; CHECKPOINTS_S.len()];
    for i in 0..runs {
        let setup = RunSetup {
            model: &model,
            seed: i as u64,
            initial_error_rad: initial_error(i),
            initial_sigma_rad: initial_sigma(),
            fine: config,
        };
        let (cps, _) = run_fine::<f64>(&rec, &setup, &CHECKPOINTS_S)?;
        for (j, c) in cps.iter().enumerate() {
            sq[j] += c.euler_error_rad.z.powi(2);
            sigma[j] = c.sigma_rad.z;
        }
    }
    for (j, &t) in CHECKPOINTS_S.iter().enumerate() {
        let (general, known) = floors(t, config.gyro_noise, config.accel_noise, rec.lat_rad);
        writeln!(
            out,
            "{t:5.0} s  RMS {:.3} deg  sigma {:.3} deg  floor {:.3} deg  known {:.3}",
            (sq[j] / runs as f64).sqrt().to_degrees(),
            sigma[j].to_degrees(),
            general.to_degrees(),
            known.to_degrees()
        )?;
    }
    Ok(out)
}
