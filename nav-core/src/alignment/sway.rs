//! Base-motion-model fine alignment (`--align-method sway`; issue 6, requirement 4): a base
//! known to be still or to sway about a fixed mean attitude.
//!
//! **Why it beats the general floor.** The general filter ([`super::fine`]) knows nothing of
//! how the body turns: the heading shows only as the east tilt drift `W psi`
//! (`W = Omega_ie cos(lat)`), which it must find from the accelerometers' noisy view of the
//! tilt, so its floor has the term `sqrt(12) N_a / (g W T^1.5)`. If the body is known to sway
//! about a *fixed* mean attitude, the gyro-integrated attitude itself shows the drift: its
//! roll and pitch, once the (modelled) sway is removed, should be constant, and every change is
//! the attitude error `phi` drifting at `-omega_ie x phi` (heading error `psi` -> east tilt
//! drift `W psi`) plus the gyro noise's random walk. Only the gyro noise limits the estimate
//! then: the motion-known floor `N_g / (W sqrt(T))` (gyrocompassing).
//!
//! **Model.** An attitude integrator (rotation-vector quaternion update with coning, Earth rate
//! removed in the NED frame at the known position, Kahan-compensated as in [`crate::strapdown`])
//! gives `C_hat = exp(-[phi x]) C`. The true roll and pitch are modelled as
//! `mean + s(t)`, each `s` a narrow-band oscillator (phasor `(s, c)`: `ds/dt = w c`,
//! `dc/dt = -w s`, amplitude random walk), its frequency `w` identified from the data and
//! tracked by a frequency-error state. Yaw sway needs no model: it only enters through the
//! Euler-angle Jacobian, computed from the integrated attitude. States ([`SWAY_STATES`]):
//! `phi` (3, NED), gyro bias in NED axes (3), horizontal accelerometer bias in NED axes (2),
//! mean roll and pitch (2), two phasors (4), two frequency errors (2). Measurements every
//! [`SwayConfig::update_period_s`] (0.2 s):
//! - the integrated roll and pitch, `mean + s - A phi` (`A` the Euler-angle Jacobian of the
//!   attitude, [`euler_jacobian`]), noise [`SwayConfig::euler_sigma_rad`] (what the oscillators
//!   do not describe); the filter runs closed loop, `phi` is zero before every update, so this
//!   linear model is exact to first order in one update's correction;
//! - the horizontal specific force averaged over the interval, `f x phi + b` with
//!   `f = (0, 0, -g)` (a base swaying about the IMU: no lever-arm acceleration), noise
//!   `N_a^2 / dt`: the level.
//!
//! The process model: `phi` turns at `-omega_ie_n x phi` (exact for the rotation vector, any
//! size: [`super::fine::model`]) and collects the gyro noise and bias; the phasors rotate at
//! their frequencies (exactly), the frequency errors entering through their EKF Jacobian and
//! folded into the frequencies after every update.
//!
//! Gyro and accelerometer biases are modelled in NED axes: a sway of a few degrees changes
//! their projections by `1 - cos(sway)` (0.4 % at 5 deg), and they are as unobservable as in the
//! general filter (east gyro bias with heading, horizontal accelerometer bias with level).
//!
//! **Identification and start.** For the first [`SwayConfig::identify_s`] (25 s) the
//! measurements are kept (decimated, [`BUFFER_LEN`] at most) while the integrator runs open
//! loop; then each axis's sway frequency is found by least squares (mean, trend, one sinusoid:
//! the frequency leaving the least residual, grid then golden section, between
//! [`SwayConfig::min_period_s`] and [`SwayConfig::max_period_s`]); an axis whose sinusoid is
//! below [`SwayConfig::min_amplitude_rad`] is still (its oscillator switched off: a still base
//! is the special case). The kept attitudes are first levelled exactly (nonlinear, from the
//! mean specific force over [`LEVEL_S`]): the roll and pitch measurements are so precise that
//! the second-order terms of a large tilt correction made by a linear update (`tilt^2/2`,
//! 4e-5 rad at 0.5 deg) would read as a drift, i.e. as heading. The filter then runs over the
//! kept measurements closed loop all the same: each correction is applied to the kept
//! attitudes that follow, propagated as the integrator would have carried it (a correction
//! `R` made at `t_j` is `N R N^-1` at `t`, `N = exp(-[omega_ie (t - t_j)])`), and at the end
//! to the integrator; online, every update's `phi` goes to the integrator and the biases to
//! its compensation, those states zeroed. Until then [`SwayAlignment::estimate`] returns the
//! coarse attitude propagated by the gyros, with the coarse sigmas.
//!
//! **Large heading error.** As in the general filter the attitude-error dynamics are exact for
//! any heading error and a heading correction does not change roll or pitch; on exact data a
//! start 10 to 90 deg off converges to a few hundredths of a degree in 30 s. With noise the
//! Monte Carlo RMS at 120 s grows by about 15 % (30 deg) and 25 % (60 deg) over a 10 deg start:
//! give it the coarse stage's heading to 10–20 deg.
//!
//! **Limits.** A lever arm between the IMU and the centre of the sway adds periodic specific
//! force that the level measurement does not model; non-sinusoidal roll or pitch (several
//! periods) leaves what one oscillator per axis cannot follow to the Euler-angle noise and to
//! the covariance inflation of the oscillators: an innovation beyond 3 sigma inflates that
//! axis's phasor covariance so the model can follow a changing amplitude (counted in
//! [`SwayStatus::relocks`]). The end of `auv-bench`'s rocking (the amplitude falls to zero in
//! one period) goes through this way and leaks 0.007 deg into the heading on exact data (4 % of
//! its sigma then). Memory: 13.7 KB in `f32` (23 KB in `f64`), mostly the kept measurements,
//! and 6 KB of stack for the identification, done once in `f64` (about 300 least-squares fits
//! of 125 samples: 1e6 multiply-adds and 8e4 sine/cosine pairs, well under a second of a
//! Cortex-M4F's low-priority task).

use super::fine::kalman::{ScalarUpdate, discrete_noise, propagate, update_scalar};
use super::fine::{euler_jacobian, phi_covariance};
use super::{AttitudeEstimate, SensorNoise};
use crate::coning::ConingSculling;
use crate::earth::LocalEarth;
use crate::strapdown::{dcm_of, kahan_add, small_rotation};
use crate::{ImuIncrement, InputError, InputLimits, Position, Scalar, attitude};
use nalgebra::{Matrix3, Matrix4, Quaternion, SMatrix, SVector, UnitQuaternion, Vector3, Vector4};

/// Offset of the attitude error `phi_n` [rad] (NED; `C_hat = exp(-[phi x]) C`).
pub const ATT: usize = 0;
/// Offset of the residual gyro bias in NED axes [rad/s].
pub const GYRO_BIAS: usize = 3;
/// Offset of the residual horizontal accelerometer bias in NED axes (north, east) [m/s^2].
pub const ACCEL_BIAS: usize = 6;
/// Offset of the mean roll and pitch [rad].
pub const MEAN: usize = 8;
/// Offset of the roll phasor `(s, c)` [rad]; the pitch phasor follows at `OSC + 2`.
pub const OSC: usize = 10;
/// Offset of the roll and pitch sway frequency errors [rad/s].
pub const FREQ: usize = 14;
/// Number of states.
pub const SWAY_STATES: usize = 16;
/// Measurements kept for the identification (at the default 0.2 s: 51 s).
pub const BUFFER_LEN: usize = 256;
/// Averaging time of the initial exact levelling [s].
pub const LEVEL_S: f64 = 2.0;

type State<T> = SVector<T, SWAY_STATES>;
type Cov<T> = SMatrix<T, SWAY_STATES, SWAY_STATES>;

/// Settings of [`SwayAlignment`]. `Default` is seed 003's FOG IMU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwayConfig<T: Scalar> {
    /// The IMU's noise: gyro white-noise density [rad/sqrt(s)], accelerometer white-noise
    /// density [m/s/sqrt(s)] (positive: it weights the level measurement), initial 1-sigma of
    /// each gyro bias [rad/s] and accelerometer bias [m/s^2]. Default
    /// [`SensorNoise::seed003`]: 2.618e-6 (0.003 deg/s RMS at 400 Hz), 1e-3 (0.02 m/s^2 at
    /// 400 Hz), 0.2 deg/h, 0.005.
    pub noise: SensorNoise<T>,
    /// 1-sigma of what the sway model leaves in the integrated roll and pitch [rad] (default
    /// 1e-5; it must stay well below the gyro noise's walk over a sway period,
    /// `N_g sqrt(P)`, or the drift is lost in it).
    pub euler_sigma_rad: T,
    /// Random walk of each phasor component (narrow-band sway) [rad/sqrt(s)] (default 1e-6).
    pub amplitude_walk: T,
    /// Random walk of each sway frequency [rad/s/sqrt(s)] (default 1e-6).
    pub frequency_walk: T,
    /// Identification window [s] (default 25; at most [`BUFFER_LEN`] update periods).
    pub identify_s: T,
    /// Filter interval [s] (default 0.2).
    pub update_period_s: T,
    /// Shortest sway period searched [s] (default 2).
    pub min_period_s: T,
    /// Longest sway period searched [s] (default 20; the window should hold two of them).
    pub max_period_s: T,
    /// Smallest sinusoid amplitude taken as sway [rad] (default 1e-4).
    pub min_amplitude_rad: T,
    /// Roll and pitch 1-sigma when the coarse estimate gives none [rad] (default 1 deg).
    pub fallback_level_sigma: T,
    /// Heading 1-sigma when the coarse estimate gives none [rad] (default 10 deg).
    pub fallback_yaw_sigma: T,
    /// Innovation gate of the level measurement [sigma] (default 8).
    pub gate_sigma: T,
    /// Increment limits.
    pub limits: InputLimits<T>,
}

impl<T: Scalar> Default for SwayConfig<T> {
    fn default() -> Self {
        let deg = core::f64::consts::PI / 180.0;
        Self {
            noise: SensorNoise::seed003(),
            euler_sigma_rad: T::c(1e-5),
            amplitude_walk: T::c(1e-6),
            frequency_walk: T::c(1e-6),
            identify_s: T::c(25.0),
            update_period_s: T::c(0.2),
            min_period_s: T::c(2.0),
            max_period_s: T::c(20.0),
            min_amplitude_rad: T::c(1e-4),
            fallback_level_sigma: T::c(deg),
            fallback_yaw_sigma: T::c(10.0 * deg),
            gate_sigma: T::c(8.0),
            limits: InputLimits::default(),
        }
    }
}

impl<T: Scalar> SwayConfig<T> {
    /// Every non-finite or out-of-range value replaced by its default.
    pub fn sanitized(&self) -> Self {
        let d = Self::default();
        let nonneg = |v: T, dv: T| if v.finite() && v >= T::zero() { v } else { dv };
        let pos = |v: T, dv: T| if v.finite() && v > T::zero() { v } else { dv };
        let mut c = Self {
            noise: SensorNoise {
                arw_rad_per_sqrt_s: nonneg(
                    self.noise.arw_rad_per_sqrt_s,
                    d.noise.arw_rad_per_sqrt_s,
                ),
                vrw_mps_per_sqrt_s: pos(self.noise.vrw_mps_per_sqrt_s, d.noise.vrw_mps_per_sqrt_s),
                gyro_bias_rad_s: nonneg(self.noise.gyro_bias_rad_s, d.noise.gyro_bias_rad_s),
                accel_bias_mps2: nonneg(self.noise.accel_bias_mps2, d.noise.accel_bias_mps2),
            },
            euler_sigma_rad: pos(self.euler_sigma_rad, d.euler_sigma_rad),
            amplitude_walk: nonneg(self.amplitude_walk, d.amplitude_walk),
            frequency_walk: nonneg(self.frequency_walk, d.frequency_walk),
            identify_s: pos(self.identify_s, d.identify_s),
            update_period_s: pos(self.update_period_s, d.update_period_s).min(T::c(10.0)),
            min_period_s: pos(self.min_period_s, d.min_period_s),
            max_period_s: pos(self.max_period_s, d.max_period_s),
            min_amplitude_rad: pos(self.min_amplitude_rad, d.min_amplitude_rad),
            fallback_level_sigma: pos(self.fallback_level_sigma, d.fallback_level_sigma),
            fallback_yaw_sigma: pos(self.fallback_yaw_sigma, d.fallback_yaw_sigma),
            gate_sigma: pos(self.gate_sigma, d.gate_sigma),
            limits: self.limits,
        };
        if c.max_period_s <= c.min_period_s {
            c.min_period_s = d.min_period_s;
            c.max_period_s = d.max_period_s;
        }
        // The window is what the buffer holds.
        let longest = c.update_period_s * T::c(BUFFER_LEN as f64 - 1.0);
        c.identify_s = c.identify_s.min(longest);
        c
    }
}

/// Where the sway filter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SwayPhase {
    /// Keeping measurements for the identification.
    Identifying,
    /// Sway identified, filter running closed loop.
    Running,
}

/// The identified sway of one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwayAxis<T: Scalar> {
    /// Period [s] (NaN: no sway found on this axis).
    pub period_s: T,
    /// Amplitude [rad] (from the phasor now).
    pub amplitude_rad: T,
}

/// Counters and the identification result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwayStatus<T: Scalar> {
    /// Phase.
    pub phase: SwayPhase,
    /// Increments integrated.
    pub increments: u32,
    /// Increments refused.
    pub rejected_increments: u32,
    /// Filter updates.
    pub updates: u32,
    /// Level measurements refused by the gate.
    pub rejected_measurements: u32,
    /// Roll/pitch innovations beyond 3 sigma that inflated a phasor covariance.
    pub relocks: u32,
    /// Covariance re-initialisations after a non-finite value.
    pub resets: u32,
    /// Roll sway.
    pub roll: SwayAxis<T>,
    /// Pitch sway.
    pub pitch: SwayAxis<T>,
    /// Innovations of the last update: roll, pitch [rad], north and east specific force
    /// [m/s^2].
    pub innovations: [T; 4],
}

/// One decimated measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Sample<T: Scalar> {
    /// Time since the start [s].
    t_s: f64,
    /// Length of the interval it closes [s].
    dt_s: T,
    /// Integrator attitude at its end.
    q_b_n: UnitQuaternion<T>,
    /// Mean specific force over the interval, NED axes of the integrator [m/s^2].
    f_n: Vector3<T>,
}

/// The base-motion-model fine alignment (module docs).
#[derive(Clone, Debug)]
pub struct SwayAlignment<T: Scalar> {
    config: SwayConfig<T>,
    /// Integrator attitude (norm within 1e-4 of 1) and its summation carry.
    q: Quaternion<T>,
    q_carry: Quaternion<T>,
    cs: ConingSculling<T>,
    omega_ie_n: Vector3<T>,
    g: T,
    /// Bias compensation: gyro in NED axes [rad/s], horizontal accelerometer NED [m/s^2].
    gyro_bias_n: Vector3<T>,
    accel_bias_n: Vector3<T>,
    initial_sigma: Vector3<T>,
    x: State<T>,
    p: Cov<T>,
    /// Sway frequencies [rad/s] of roll and pitch; `None`: no sway on that axis.
    omega: [Option<T>; 2],
    /// Current interval: time [s], `sum C_b_n dv_b` [m/s].
    interval_s: f64,
    sum_dv_n: Vector3<T>,
    elapsed_s: f64,
    buffer: [Option<Sample<T>>; BUFFER_LEN],
    buffered: usize,
    status: SwayStatus<T>,
}

impl<T: Scalar> SwayAlignment<T> {
    /// Starts at the known `position` (the base sways in place) from a coarse `initial`
    /// attitude and its 1-sigma roll, pitch and yaw (NaN: the configuration's fallbacks).
    pub fn new(initial: AttitudeEstimate<T>, position: Position, config: SwayConfig<T>) -> Self {
        let config = config.sanitized();
        let q = if initial.q_b_n.coords.iter().all(|v| v.finite()) {
            initial.q_b_n
        } else {
            UnitQuaternion::identity()
        };
        let lat = position.lat_f64();
        let earth = LocalEarth::new(T::c(lat), T::c(position.h_f64()));
        let sigma = |s: T, fallback: T| {
            if s.finite() && s > T::zero() {
                s
            } else {
                fallback
            }
        };
        let initial_sigma = Vector3::new(
            sigma(initial.sigma_rad.x, config.fallback_level_sigma),
            sigma(initial.sigma_rad.y, config.fallback_level_sigma),
            sigma(initial.sigma_rad.z, config.fallback_yaw_sigma),
        );
        let axis = SwayAxis {
            period_s: T::c(f64::NAN),
            amplitude_rad: T::zero(),
        };
        Self {
            config,
            q: *q.quaternion(),
            q_carry: Quaternion::default(),
            cs: ConingSculling::new(),
            omega_ie_n: earth.omega_ie_n(),
            g: earth.g,
            gyro_bias_n: Vector3::zeros(),
            accel_bias_n: Vector3::zeros(),
            initial_sigma,
            x: State::zeros(),
            p: Cov::zeros(),
            omega: [None; 2],
            interval_s: 0.0,
            sum_dv_n: Vector3::zeros(),
            elapsed_s: 0.0,
            buffer: [None; BUFFER_LEN],
            buffered: 0,
            status: SwayStatus {
                phase: SwayPhase::Identifying,
                increments: 0,
                rejected_increments: 0,
                updates: 0,
                rejected_measurements: 0,
                relocks: 0,
                resets: 0,
                roll: axis,
                pitch: axis,
                innovations: [T::zero(); 4],
            },
        }
    }

    /// Adds one increment (refused and counted if it fails [`ImuIncrement::check`]).
    pub fn add(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        if let Err(e) = inc.check(&self.config.limits) {
            self.status.rejected_increments = self.status.rejected_increments.saturating_add(1);
            self.cs.reset();
            return Err(e);
        }
        let dt = inc.dt;
        let c = self
            .cs
            .compensate(&inc.delta_theta_ib_b, &inc.delta_v_ib_b, dt, true);
        // Specific force in the NED axes of the interval's start (rotation and sculling
        // compensated by `compensate`).
        let c_b_n = dcm_of(&self.q);
        self.sum_dv_n += c_b_n * c.delta_v_b;
        // Attitude: q <- q(-zeta) q q(phi_b), zeta = (omega_ie_n + gyro bias in NED) dt
        // (Savage (7.1.2-14); the frame is fixed to the Earth: no transport rate at rest).
        let zeta = (self.omega_ie_n + self.gyro_bias_n) * dt;
        let p = small_rotation(&c.phi_b);
        let z = small_rotation(&(-zeta));
        let qp = self.q * p;
        let delta = qp + z * self.q + z * qp;
        kahan_add(
            self.q.coords.as_mut_slice(),
            self.q_carry.coords.as_mut_slice(),
            delta.coords.as_slice(),
        );
        let n2 = self.q.norm_squared();
        if (n2 - T::one()).abs() > T::c(1e-4) {
            self.q /= n2.sqrt();
            self.q_carry = Quaternion::default();
        }
        self.status.increments = self.status.increments.saturating_add(1);
        self.interval_s += dt.to_f64();
        self.elapsed_s += dt.to_f64();
        if self.interval_s + 0.5 * dt.to_f64() >= self.config.update_period_s.to_f64() {
            let dt_s = T::c(self.interval_s);
            let sample = Sample {
                t_s: self.elapsed_s,
                dt_s,
                q_b_n: UnitQuaternion::new_normalize(self.q),
                f_n: self.sum_dv_n / dt_s,
            };
            self.interval_s = 0.0;
            self.sum_dv_n = Vector3::zeros();
            match self.status.phase {
                SwayPhase::Identifying => self.keep(sample),
                SwayPhase::Running => {
                    self.filter_step(&sample, dt_s);
                    let phi = self.take_corrections();
                    let q = UnitQuaternion::new_normalize(self.q);
                    self.q = *(attitude::rotation_vector_quat(&phi) * q).quaternion();
                    self.q_carry = Quaternion::default();
                }
            }
        }
        Ok(())
    }

    /// Keeps `sample`; at the end of the window identifies the sway and runs the filter over
    /// the window.
    fn keep(&mut self, sample: Sample<T>) {
        if self.buffered < BUFFER_LEN {
            self.buffer[self.buffered] = Some(sample);
            self.buffered += 1;
        }
        let full = self.buffered >= BUFFER_LEN;
        if !(full || sample.t_s + 1e-9 >= self.config.identify_s.to_f64()) {
            return;
        }
        let phi0 = self.identify_and_start();
        // The kept measurements were made open loop: run the filter over them closed loop all
        // the same, applying every correction to them instead of to the integrator. A
        // correction `R` made at `t_j` would have become `N R N^-1` at `t` in the integrator,
        // `N = exp(-[omega_ie (t - t_j)])` (its nav-side propagation), and the bias
        // compensation turns it by `-b dt` more per step; so the kept attitudes are corrected
        // by `fix`, propagated that way, and every feedback multiplies `fix` on the left.
        let mut fix = attitude::rotation_vector_quat(&phi0);
        for k in 0..self.buffered {
            let Some(s) = self.buffer[k] else { continue };
            let dt = if k == 0 { T::zero() } else { s.dt_s };
            let earth = attitude::rotation_vector_quat(&(self.omega_ie_n * dt));
            let with_bias =
                attitude::rotation_vector_quat(&(-(self.omega_ie_n + self.gyro_bias_n) * dt));
            fix = UnitQuaternion::new_normalize(*(with_bias * fix * earth).quaternion());
            let corrected = Sample {
                q_b_n: fix * s.q_b_n,
                f_n: fix * s.f_n,
                ..s
            };
            self.filter_step(&corrected, dt);
            let phi = self.take_corrections();
            fix = attitude::rotation_vector_quat(&phi) * fix;
        }
        self.buffered = 0;
        self.status.phase = SwayPhase::Running;
        // The last kept sample is now: its correction goes to the integrator.
        let q = UnitQuaternion::new_normalize(self.q);
        self.q = *(fix * q).quaternion();
        self.q_carry = Quaternion::default();
    }

    /// Identifies the sway of roll and pitch over the kept measurements and initialises the
    /// state and covariance at the first of them; returns the levelling correction `phi0`
    /// [rad] of the first kept attitude.
    ///
    /// The integrator's tilt is first found exactly (nonlinear levelling, Groves eq. 5.101,
    /// from the mean specific force over the first [`LEVEL_S`]): the roll and pitch
    /// measurements are so precise ([`SwayConfig::euler_sigma_rad`]) that the second-order
    /// terms of a large tilt correction made by a linear update (`tilt^2 / 2`, 4e-5 rad at
    /// 0.5 deg) would be read as a drift, i.e. as heading.
    fn identify_and_start(&mut self) -> Vector3<T> {
        let n = self.buffered;
        let mut t = [0.0f64; BUFFER_LEN];
        let mut y = [[0.0f64; BUFFER_LEN]; 2];
        let mut f_sum = Vector3::<T>::zeros();
        let mut level_s = T::zero();
        let first = self.buffer[0].map_or(0.0, |s| s.t_s);
        for (k, s) in self.buffer.iter().take(n).flatten().enumerate() {
            t[k] = s.t_s;
            let (r, p, _) = attitude::euler(&s.q_b_n);
            y[0][k] = r.to_f64();
            y[1][k] = p.to_f64();
            if k == 0 || s.t_s - first <= LEVEL_S {
                f_sum += s.f_n * s.dt_s;
                level_s += s.dt_s;
            }
        }
        let first_q = self.buffer[0].map_or(UnitQuaternion::identity(), |s| s.q_b_n);
        let c = self.config;
        let var = |s: T| s * s;
        // exp(-[phi x]) e_D = u (the down seen by the integrator): phi = angle * unit(u x e_D).
        let mut phi0 = Vector3::<T>::zeros();
        let f_norm = f_sum.norm();
        if f_norm > T::zero() && f_norm.finite() {
            let u = -f_sum / f_norm;
            let axis = Vector3::new(u.y, -u.x, T::zero());
            let sin_a = axis.norm();
            if sin_a > T::zero() {
                phi0 = axis * (sin_a.patan2(u.z) / sin_a);
            }
        }
        let mut x = State::<T>::zeros();
        let mut p = Cov::<T>::zeros();
        // Level: the averaging's noise, plus the accelerometer bias it cannot tell from tilt
        // (f_N = g phi_E + b_N, f_E = -g phi_N + b_E).
        let g = self.g;
        let level_var = var(c.noise.vrw_mps_per_sqrt_s / g) / level_s.max(c.update_period_s)
            * T::c(4.0)
            + T::c(1e-10);
        let bias_var = var(c.noise.accel_bias_mps2);
        p[(ATT, ATT)] = level_var + bias_var / (g * g);
        p[(ATT + 1, ATT + 1)] = level_var + bias_var / (g * g);
        p[(ATT, ACCEL_BIAS + 1)] = bias_var / g;
        p[(ACCEL_BIAS + 1, ATT)] = bias_var / g;
        p[(ATT + 1, ACCEL_BIAS)] = -bias_var / g;
        p[(ACCEL_BIAS, ATT + 1)] = -bias_var / g;
        p[(ATT + 2, ATT + 2)] = phi_covariance(&first_q, &self.initial_sigma)[(2, 2)];
        for i in 0..3 {
            p[(GYRO_BIAS + i, GYRO_BIAS + i)] = var(c.noise.gyro_bias_rad_s);
        }
        for i in 0..2 {
            p[(ACCEL_BIAS + i, ACCEL_BIAS + i)] = bias_var;
        }
        // The levelled attitude at the first sample: its roll and pitch are mean + sway.
        let (roll0, pitch0, _) =
            attitude::euler(&(attitude::rotation_vector_quat(&phi0) * first_q));
        let (w_min, w_max) = (
            core::f64::consts::TAU / c.max_period_s.to_f64(),
            core::f64::consts::TAU / c.min_period_s.to_f64(),
        );
        for axis in 0..2 {
            let fit = identify(&t[..n], &y[axis][..n], first, w_min, w_max);
            let (s, cc) = (OSC + 2 * axis, OSC + 2 * axis + 1);
            let sway = fit.amplitude() >= c.min_amplitude_rad.to_f64() && fit.omega.is_finite();
            let info = if axis == 0 {
                &mut self.status.roll
            } else {
                &mut self.status.pitch
            };
            let level0 = if axis == 0 { roll0 } else { pitch0 };
            p[(MEAN + axis, MEAN + axis)] = level_var + bias_var / (g * g);
            if sway {
                self.omega[axis] = Some(T::c(fit.omega));
                info.period_s = T::c(core::f64::consts::TAU / fit.omega);
                x[s] = T::c(fit.cos);
                x[cc] = T::c(fit.sin);
                x[MEAN + axis] = level0 - x[s];
                // The fit is good to its residual; the filter refines.
                let r = var(T::c(fit.residual_rms.max(1e-5))) * T::c(4.0);
                p[(s, s)] = r;
                p[(cc, cc)] = r;
                p[(MEAN + axis, MEAN + axis)] += r;
                p[(FREQ + axis, FREQ + axis)] = var(T::c(1e-3 * fit.omega));
            } else {
                self.omega[axis] = None;
                info.period_s = T::c(f64::NAN);
                x[MEAN + axis] = level0;
            }
        }
        self.x = x;
        self.p = p;
        phi0
    }

    /// Propagates over `dt` [s] (0 at the first sample) and applies `sample`'s measurements.
    fn filter_step(&mut self, sample: &Sample<T>, dt: T) {
        let c = self.config;
        // Transition: phi rotates at -omega_ie (exact for the rotation vector) and collects
        // -b_g dt; phasors rotate at w dt (exact), with the frequency error's Jacobian.
        let mut phi = Cov::<T>::identity();
        let wdt = (self.omega_ie_n * dt).cross_matrix();
        phi.fixed_view_mut::<3, 3>(ATT, ATT)
            .copy_from(&(Matrix3::identity() - wdt + wdt * wdt * T::c(0.5)));
        phi.fixed_view_mut::<3, 3>(ATT, GYRO_BIAS)
            .copy_from(&(Matrix3::identity() * (-dt)));
        let mut x = self.x;
        for axis in 0..2 {
            let (s, cc, f) = (OSC + 2 * axis, OSC + 2 * axis + 1, FREQ + axis);
            let w = self.omega[axis].unwrap_or(T::zero());
            let (sn, cs) = ((w * dt).psin(), (w * dt).pcos());
            phi[(s, s)] = cs;
            phi[(s, cc)] = sn;
            phi[(cc, s)] = -sn;
            phi[(cc, cc)] = cs;
            let (s1, c1) = (cs * x[s] + sn * x[cc], -sn * x[s] + cs * x[cc]);
            x[s] = s1;
            x[cc] = c1;
            if self.omega[axis].is_some() {
                phi[(s, f)] = c1 * dt;
                phi[(cc, f)] = -s1 * dt;
            }
        }
        // The linear part of x (phi, biases) propagates with Phi.
        let att = phi.fixed_view::<3, 3>(ATT, ATT) * x.fixed_rows::<3>(ATT)
            + phi.fixed_view::<3, 3>(ATT, GYRO_BIAS) * x.fixed_rows::<3>(GYRO_BIAS);
        x.fixed_rows_mut::<3>(ATT).copy_from(&att);
        let mut q_c = State::<T>::zeros();
        for i in 0..3 {
            q_c[ATT + i] = c.noise.arw_rad_per_sqrt_s * c.noise.arw_rad_per_sqrt_s;
        }
        for axis in 0..2 {
            if self.omega[axis].is_some() {
                let a = c.amplitude_walk * c.amplitude_walk;
                q_c[OSC + 2 * axis] = a;
                q_c[OSC + 2 * axis + 1] = a;
                q_c[FREQ + axis] = c.frequency_walk * c.frequency_walk;
            }
        }
        let q_d = discrete_noise(&phi, &q_c, dt);
        propagate(&mut self.p, &phi, &q_d);
        self.x = x;

        self.update_euler(sample);
        self.update_level(sample);
        // The frequency errors are folded into the frequencies at once (the phasors must
        // rotate at the estimated frequency, also during the open-loop pass).
        for axis in 0..2 {
            if let Some(w) = &mut self.omega[axis] {
                *w += self.x[FREQ + axis];
            }
            self.x[FREQ + axis] = T::zero();
        }
        self.status.updates = self.status.updates.saturating_add(1);
        if !(self.x.iter().all(|v| v.finite()) && self.p.iter().all(|v| v.finite())) {
            // Cannot happen with finite inputs: restart the error covariance rather than panic.
            self.x.fixed_rows_mut::<8>(ATT).fill(T::zero());
            self.p = Cov::identity() * T::c(1e-6);
            self.status.resets = self.status.resets.saturating_add(1);
        }
    }

    /// Roll and pitch of the (corrected) integrator against the sway model: `z = mean + s -
    /// A phi` (`A` the Euler-angle Jacobian [`euler_jacobian`], `phi` zero before the update:
    /// the filter runs closed loop, so the linear model is exact to first order).
    fn update_euler(&mut self, sample: &Sample<T>) {
        let r_e = self.config.euler_sigma_rad * self.config.euler_sigma_rad;
        let jac = euler_jacobian(&sample.q_b_n);
        let (roll, pitch, _) = attitude::euler(&sample.q_b_n);
        for axis in 0..2 {
            let mut h = State::<T>::zeros();
            for k in 0..3 {
                h[ATT + k] = -jac[(axis, k)];
            }
            h[MEAN + axis] = T::one();
            h[OSC + 2 * axis] = T::one();
            let z = if axis == 0 { roll } else { pitch };
            let innovation = wrap_pi(z - h.dot(&self.x));
            self.status.innovations[axis] = innovation;
            // A sway that left its model (amplitude change, the end of the rocking): inflate
            // this axis's phasor covariance so the model can follow, instead of refusing.
            let s = h.dot(&(self.p * h)) + r_e;
            if self.omega[axis].is_some() && innovation * innovation > T::c(9.0) * s {
                let extra = innovation * innovation - s;
                for k in 0..2 {
                    let i = OSC + 2 * axis + k;
                    self.p[(i, i)] += extra;
                }
                self.status.relocks = self.status.relocks.saturating_add(1);
            }
            // Roll and pitch are never gated: a gap in them would lose the drift.
            update_scalar(&mut self.x, &mut self.p, &h, innovation, r_e, T::c(1e6));
        }
    }

    /// Horizontal specific force: the level of the attitude, `f_N = g phi_E + b_N`,
    /// `f_E = -g phi_N + b_E` (`f x phi` with `f = (0, 0, -g)`).
    fn update_level(&mut self, sample: &Sample<T>) {
        let n_a = self.config.noise.vrw_mps_per_sqrt_s;
        let r = n_a * n_a / sample.dt_s;
        for axis in 0..2 {
            let mut h = State::<T>::zeros();
            if axis == 0 {
                h[ATT + 1] = self.g;
            } else {
                h[ATT] = -self.g;
            }
            h[ACCEL_BIAS + axis] = T::one();
            // Compensated with the bias already estimated (the state holds the residual).
            let innovation = sample.f_n[axis] - self.accel_bias_n[axis] - h.dot(&self.x);
            self.status.innovations[2 + axis] = innovation;
            match update_scalar(
                &mut self.x,
                &mut self.p,
                &h,
                innovation,
                r,
                self.config.gate_sigma,
            ) {
                ScalarUpdate::Accepted => {}
                _ => {
                    self.status.rejected_measurements =
                        self.status.rejected_measurements.saturating_add(1)
                }
            }
        }
    }

    /// Takes the attitude correction `phi` [rad] out of the state (the caller applies
    /// `q(phi)` to the attitude it corrects), moves the bias estimates into the compensation
    /// and zeroes those states.
    fn take_corrections(&mut self) -> Vector3<T> {
        let phi = Vector3::new(self.x[ATT], self.x[ATT + 1], self.x[ATT + 2]);
        self.gyro_bias_n += Vector3::new(
            self.x[GYRO_BIAS],
            self.x[GYRO_BIAS + 1],
            self.x[GYRO_BIAS + 2],
        );
        self.accel_bias_n.x += self.x[ACCEL_BIAS];
        self.accel_bias_n.y += self.x[ACCEL_BIAS + 1];
        self.x.fixed_rows_mut::<8>(ATT).fill(T::zero());
        for axis in 0..2 {
            if let Some(w) = self.omega[axis] {
                let info = if axis == 0 {
                    &mut self.status.roll
                } else {
                    &mut self.status.pitch
                };
                info.period_s = T::c(core::f64::consts::TAU) / w;
                info.amplitude_rad =
                    (self.x[OSC + 2 * axis].powi(2) + self.x[OSC + 2 * axis + 1].powi(2)).sqrt();
            }
        }
        phi
    }

    /// The current attitude (body to NED) with the filter's 1-sigma roll, pitch, yaw. While
    /// identifying: the coarse attitude propagated by the gyros, with the coarse sigmas.
    pub fn estimate(&self) -> AttitudeEstimate<T> {
        let q = UnitQuaternion::new_normalize(self.q);
        let sigma_rad = match self.status.phase {
            SwayPhase::Identifying => self.initial_sigma,
            SwayPhase::Running => {
                super::fine::euler_sigma(&q, &self.p.fixed_view::<3, 3>(ATT, ATT).into_owned())
            }
        };
        AttitudeEstimate {
            q_b_n: q,
            sigma_rad,
            elapsed_s: T::c(self.elapsed_s),
        }
    }

    /// Gyro bias estimate in NED axes [rad/s] and its 1-sigma.
    pub fn gyro_bias_n(&self) -> (Vector3<T>, Vector3<T>) {
        let s =
            Vector3::from_fn(|i, _| self.p[(GYRO_BIAS + i, GYRO_BIAS + i)].max(T::zero()).sqrt());
        (self.gyro_bias_n, s)
    }

    /// Counters, phase and the identified sway.
    pub fn status(&self) -> SwayStatus<T> {
        self.status
    }

    /// The error-state covariance (offsets above).
    pub fn covariance(&self) -> &SMatrix<T, SWAY_STATES, SWAY_STATES> {
        &self.p
    }

    /// The configuration in use (sanitised).
    pub fn config(&self) -> &SwayConfig<T> {
        &self.config
    }
}

/// A least-squares fit `y = mean + trend (t - t0) + cos a(t) + sin b(t)` over `a(t) =
/// w (t - t0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SinusoidFit {
    /// Angular frequency [rad/s] (NaN if none could be fitted).
    pub omega: f64,
    /// Value of the mean line at `t0` [rad].
    pub mean: f64,
    /// Trend [rad/s].
    pub trend: f64,
    /// Cosine amplitude [rad] (the sinusoid's value at `t0`).
    pub cos: f64,
    /// Sine amplitude [rad] (its rate at `t0` over `w`).
    pub sin: f64,
    /// RMS of the residual [rad].
    pub residual_rms: f64,
}

impl SinusoidFit {
    /// Amplitude [rad].
    pub fn amplitude(&self) -> f64 {
        libm::hypot(self.cos, self.sin)
    }
}

/// Least-squares fit of a line plus a sinusoid of angular frequency `omega` [rad/s] to
/// `(t, y)`, times relative to `t0`; `None` if singular.
fn fit_at(t: &[f64], y: &[f64], t0: f64, omega: f64) -> Option<SinusoidFit> {
    let mut a = Matrix4::<f64>::zeros();
    let mut b = Vector4::<f64>::zeros();
    for (&ti, &yi) in t.iter().zip(y) {
        let tau = ti - t0;
        let row = Vector4::new(1.0, tau, libm::cos(omega * tau), libm::sin(omega * tau));
        a += row * row.transpose();
        b += row * yi;
    }
    let sol = a.cholesky()?.solve(&b);
    let mut sse = 0.0;
    for (&ti, &yi) in t.iter().zip(y) {
        let tau = ti - t0;
        let e = yi
            - (sol[0]
                + sol[1] * tau
                + sol[2] * libm::cos(omega * tau)
                + sol[3] * libm::sin(omega * tau));
        sse += e * e;
    }
    Some(SinusoidFit {
        omega,
        mean: sol[0],
        trend: sol[1],
        cos: sol[2],
        sin: sol[3],
        residual_rms: libm::sqrt(sse / t.len().max(1) as f64),
    })
}

/// The sway of one axis: the frequency in `[w_min, w_max]` [rad/s] whose line-plus-sinusoid
/// fit leaves the least residual (a grid of spacing `pi / (4 window)`, then a golden-section
/// search around the best), computed in `f64` (a one-off cost).
pub fn identify(t: &[f64], y: &[f64], t0: f64, w_min: f64, w_max: f64) -> SinusoidFit {
    let none = SinusoidFit {
        omega: f64::NAN,
        mean: y.iter().sum::<f64>() / y.len().max(1) as f64,
        trend: 0.0,
        cos: 0.0,
        sin: 0.0,
        residual_rms: f64::INFINITY,
    };
    let window = t.last().copied().unwrap_or(t0) - t0;
    let usable = window > 0.0 && w_max > w_min; // false for NaN too
    if t.len() < 8 || !usable {
        return none;
    }
    let step = core::f64::consts::PI / (4.0 * window);
    let cost = |w: f64| fit_at(t, y, t0, w).map_or(f64::INFINITY, |f| f.residual_rms);
    let (mut best_w, mut best) = (f64::NAN, f64::INFINITY);
    let mut w = w_min;
    while w <= w_max {
        let c = cost(w);
        if c < best {
            (best_w, best) = (w, c);
        }
        w += step;
    }
    if !best_w.is_finite() {
        return none;
    }
    // Golden section on [best - step, best + step].
    let g = 0.5 * (libm::sqrt(5.0) - 1.0);
    let (mut lo, mut hi) = ((best_w - step).max(w_min), (best_w + step).min(w_max));
    let (mut a, mut b) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut ca, mut cb) = (cost(a), cost(b));
    for _ in 0..60 {
        if ca < cb {
            hi = b;
            b = a;
            cb = ca;
            a = hi - g * (hi - lo);
            ca = cost(a);
        } else {
            lo = a;
            a = b;
            ca = cb;
            b = lo + g * (hi - lo);
            cb = cost(b);
        }
    }
    fit_at(t, y, t0, 0.5 * (lo + hi)).unwrap_or(none)
}

/// `a` [rad] wrapped to (-pi, pi].
fn wrap_pi<T: Scalar>(a: T) -> T {
    let pi = T::c(core::f64::consts::PI);
    if a > pi {
        a - pi - pi
    } else if a <= -pi {
        a + pi + pi
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    #[test]
    fn identifies_a_sinusoid_on_a_trend() {
        let w = core::f64::consts::TAU / 11.0;
        let t: Vec<f64> = (1..=125).map(|k| 0.2 * k as f64).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&t| 0.01 + 1e-5 * t + 0.087 * libm::sin(w * t + 0.3))
            .collect();
        let fit = identify(
            &t,
            &y,
            t[0],
            core::f64::consts::TAU / 20.0,
            core::f64::consts::PI,
        );
        assert!((fit.omega - w).abs() < 1e-9 * w, "{fit:?}");
        assert!((fit.amplitude() - 0.087).abs() < 1e-9 && fit.residual_rms < 1e-9);
        assert!((fit.trend - 1e-5).abs() < 1e-12);
        // No sway: nothing above the noise.
        let flat: Vec<f64> = t.iter().map(|&t| 0.01 + 1e-5 * t).collect();
        let fit = identify(
            &t,
            &flat,
            t[0],
            core::f64::consts::TAU / 20.0,
            core::f64::consts::PI,
        );
        assert!(fit.amplitude() < 1e-12, "{fit:?}");
    }
}
