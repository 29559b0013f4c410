//! Level alignment on a rocking ship ([Ship alignment]): gyros propagate the attitude, the
//! accelerometers' output re-projected to the level frame is compared with gravity by a
//! discrete Kalman filter that estimates the two horizontal tilt errors, and the attitude is
//! corrected by a small rotation after every filter update. A constant-gain variant replaces the
//! Riccati equation with gains that are a simple function of time.
//!
//! # Why a velocity-domain measurement
//! On a ship rocking 2 deg with an 8 s period, an IMU at `R = (30, 10, 15)` m from the centre of
//! rotation feels lever-arm accelerations `omega_dot x R + omega x (omega x R)` of ~0.75 m/s^2,
//! 4 deg of apparent tilt if the level-frame specific force were compared with gravity directly.
//! The filter instead integrates the level-frame specific force plus gravity into a velocity
//! (the level-frame acceleration "compared with gravity" in integrated form) and compares it with
//! the velocity the IMU must have on the ship, `v_ref = v_centre + C_b_n (omega_nb_b x R)`
//! (transfer alignment by velocity matching; Groves §15.1.2; Titterton & Weston §10.4). `v_ref`
//! needs only the gyro rate and the known lever arm, stays bounded (~1 m/s), and its error is
//! the gyro noise times `|R|`; no angular acceleration (a differentiated, noisy rate) is needed.
//! The ship's centre of rotation is assumed to move at the known velocity
//! [`LevelFilter::set_centre_velocity`] (zero by default): surge, sway and deck flexure are not
//! modelled (their size can go into [`LevelConfig::reference_sigma_mps`]).
//!
//! # Error states and models (Groves §14.2.3 psi-angle form, NED)
//! `C_b_n(computed) = (I + [psi x]) C_b_n`, `dv = v(computed) - v`. The measurement is
//! `z = v - v_ref` (N, E) at the middle of the last sample of an update interval. The reference
//! is computed with the computed attitude and the mid-sample velocity lags the state by half a
//! sample, so `z = dv + w x psi + n` with `w = v_lever + Delta_v_last / 2`. The velocity state is
//! that combination, `e = dv + w x psi`, measured directly (`H = [0 I]`): it starts uncorrelated
//! with the tilt (the velocity starts on the reference), which keeps the `f32` covariance
//! well conditioned. States, in this order: [`TILT_N`], [`TILT_E`] (`psi_N`, `psi_E` [rad]),
//! [`VEL_N`], [`VEL_E`] (`e_N`, `e_E` [m/s]).
//! - `d psi/dt = -omega_ie_n x psi + w_g` (gyro angle random walk plus the turn-on drift and the
//!   heading error's Earth-rate drift as random walks, [`LevelConfig::tilt_process_noise`]);
//! - `d dv/dt = psi x f_n - 2 omega_ie_n x dv + w_a` (Groves eq. 14.65 without the position
//!   terms), so over an update interval `e += psi x (Delta_v_f - Delta_w)` with
//!   `Delta_v_f = sum C_b_n dv_b`: exact for a constant tilt whatever the lever-arm motion, and
//!   `-g_n T` to first order (the lever-arm acceleration integrates to the change of `w`). Only
//!   the down components couple the horizontal tilt; the heading error `psi_D` drops out
//!   (`psi_D` times the horizontal `Delta_v_f - Delta_w`, which is zero but for the Earth rate),
//!   so the heading from the ship needs no better than ~1 deg;
//! - `n`: the gyro noise through the lever arm, `cov = sigma_w^2 C (|R|^2 I - R R^T) C^T`
//!   (horizontal block), `sigma_w = N_g / sqrt(dt)`, plus [`LevelConfig::reference_sigma_mps`].
//!
//! After each update the corrections are fed back (Groves §14.1.1): `C_b_n <- (I - [psi x])
//! C_b_n`, `v <- v - (e - w x psi)`, and the states return to zero.
//!
//! Horizontal accelerometer biases are not states: with the heading constant (the ship's yaw
//! swings ~0.5 deg) a bias `b` and a tilt `b / g` give the same velocity to within the rocking's
//! second order, so a bias state would only move the ambiguity (Titterton & Weston §10.2.3;
//! Groves §14.2.4: levelling is limited to `b / g`). The filter accepts the floor and adds it to
//! the reported sigma: `sigma_roll^2 = P_roll + (sigma_b / g)^2`.
//!
//! # Frame and heading (assumptions)
//! The navigation frame is NED, fixed to the Earth and turning with it (`omega_ie_n` at the
//! configured latitude; the transport rate of a ship at rest is zero). Its level is the one of
//! the gravity the accelerometers feel along their path, i.e. at the IMU's mean position; the
//! local level at the moving IMU differs by its horizontal displacement over the Earth's radius
//! (below 3.3e-7 rad at sea state 6). The heading is the ship's (its gyrocompass plus the known parking
//! angle) and is kept: after each tilt correction the Euler yaw is turned back about down
//! (a level correction changes it by `tan(pitch)` times its roll part), the velocity with it.
//! A heading error `psi_D` still tilts the level slowly through the Earth rate
//! (`d psi_E/dt = Omega_N psi_D`, 4.5e-7 rad/s for 0.5 deg at 45 deg latitude), which the filter
//! carries as process noise ([`LevelConfig::tilt_process_noise`]).
//!
//! # Rates
//! Attitude, velocity and the coning/sculling terms every sample (400 Hz); the filter (a 4-state
//! covariance propagation and a 2-measurement Joseph update, ~1,000 flops) every
//! [`LevelConfig::update_period_s`] (default 0.1 s, 10 Hz), where the measurement is also formed.
//!
//! # Constant-gain variant ([`GainMode::Scheduled`])
//! After each update the velocity state is reset to zero (velocity gain 1) and the tilt is
//! corrected by `delta psi_E = -z_N K(t)`, `delta psi_N = z_E K(t)` with
//! `K(t) = coth(t / tau) / (g tau)`, `tau = sqrt(q_a / q_g) / g` (at least the update period:
//! [`LevelConfig::scheduled_time_constant_s`]). This is the Riccati solution of
//! the problem in its simplest form (a slope `g psi` observed through a velocity random walk of
//! density `q_a`, the slope itself a random walk of `q_c = g^2 q_g`; Gelb §4.5):
//! `P(t) = sqrt(q_c q_a) coth(t / tau)`, so `K -> 1 / (g t)` (the running mean of the slope) while `t << tau` and
//! `1 / (g tau)` after it (`t` counted from the end of the first sample). It ignores the
//! reference noise and the lever-arm part of the coupling (`Delta_w`), which the full filter
//! models; nothing but `t` changes on board. Its reported sigma is the
//! same closed form: `sigma^2 = P(t) / g^2 + 2 sigma_z^2 / (g t)^2 + (sigma_b / g)^2`.

use super::AttitudeEstimate;
use super::kahan::Kahan;
use crate::coning::ConingSculling;
use crate::earth::{LocalEarth, OMEGA_IE};
use crate::strapdown::{dcm_of, kahan_add, rotation_vector_delta, small_rotation};
use crate::{ImuIncrement, InputError, InputLimits, Scalar, attitude};
use nalgebra::{
    Matrix2, Matrix2x4, Matrix3, Matrix4, Matrix4x2, Quaternion, UnitQuaternion, Vector2, Vector3,
    Vector4,
};

/// State offset: tilt error about north `psi_N` [rad].
pub const TILT_N: usize = 0;
/// State offset: tilt error about east `psi_E` [rad].
pub const TILT_E: usize = 1;
/// State offset: north velocity error against the reference, `e_N = dv_N + (w x psi)_N` [m/s].
pub const VEL_N: usize = 2;
/// State offset: east velocity error against the reference, `e_E = dv_E + (w x psi)_E` [m/s].
pub const VEL_E: usize = 3;
/// Number of states.
pub const STATES: usize = 4;

/// How the filter's gains are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GainMode {
    /// Full discrete Kalman filter: covariance propagated and updated on board.
    Kalman,
    /// Constant-gain filter: velocity reset, tilt gain `coth(t / tau) / (g tau)`; no covariance.
    Scheduled,
}

/// Everything the filter is told before it starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelConfig<T: Scalar> {
    /// Initial roll of the IMU body relative to NED [rad] (e.g. the ship's roll transferred, or
    /// zero: the filter needs only `|error| <~ 5 deg`).
    pub roll_rad: T,
    /// Initial pitch [rad].
    pub pitch_rad: T,
    /// Heading (true yaw) of the IMU body [rad], given by the ship (its heading plus the known
    /// parking angle).
    pub yaw_rad: T,
    /// 1-sigma of the initial roll and pitch errors, each [rad].
    pub tilt_sigma_rad: T,
    /// 1-sigma of the given heading [rad] (reported as the yaw sigma; the tilt estimate does not
    /// depend on it to first order).
    pub yaw_sigma_rad: T,
    /// Geodetic latitude of the ship [rad].
    pub lat_rad: T,
    /// Ellipsoidal height [m].
    pub h_m: T,
    /// IMU position relative to the ship's centre of rotation, IMU body axes (FRD) [m]
    /// (the `R` of [Ship alignment], known from the parking spot).
    pub lever_arm_b_m: Vector3<T>,
    /// Gyro angle random walk, the white-noise density `N_g` [rad/sqrt(s)] (= [rad/s/sqrt(Hz)]).
    pub gyro_arw_rad_per_sqrt_s: T,
    /// 1-sigma of the gyro turn-on bias [rad/s]; modelled as a tilt random walk of density
    /// `sigma_d^2 tau_d`, `tau_d` = [`DRIFT_CORRELATION_S`] (a constant drift seen over the
    /// filter's memory).
    pub gyro_bias_sigma_rad_s: T,
    /// Accelerometer velocity random walk, density `N_a` [m/s/sqrt(s)] (= [m/s^2/sqrt(Hz)]).
    pub accel_vrw_mps_per_sqrt_s: T,
    /// 1-sigma of the accelerometer turn-on bias [m/s^2]: the `b / g` floor added to the
    /// reported roll/pitch sigma.
    pub accel_bias_sigma_mps2: T,
    /// White noise of the velocity reference per update [m/s] beyond the gyro noise (ship's
    /// centre velocity, surge/sway, flexure); 0 for a ship at rest.
    pub reference_sigma_mps: T,
    /// Filter update period [s] (attitude and velocity are propagated every sample).
    pub update_period_s: T,
    /// Full Kalman or constant gains.
    pub gains: GainMode,
    /// Limits every increment is checked against.
    pub limits: InputLimits<T>,
}

/// Correlation time [s] over which a constant gyro drift is spread as a tilt random walk.
pub const DRIFT_CORRELATION_S: f64 = 10.0;

/// Floor of the measurement noise [m/s] (keeps the innovation covariance invertible with ideal
/// sensor figures).
const MEASUREMENT_FLOOR_MPS: f64 = 1e-6;

impl<T: Scalar> LevelConfig<T> {
    /// A configuration with the initial attitude [rad], latitude [rad], height [m] and lever arm
    /// (IMU body axes) [m]; the rest defaults to: tilt sigma 2 deg, yaw sigma 0.5 deg, the
    /// FOG figures of [Vavilova et al., §4] (ARW 0.009 deg/sqrt(h), drift 0.2 deg/h,
    /// VRW 1e-3 m/s^2/sqrt(Hz), accelerometer bias 0.005 m/s^2), no reference noise, updates at
    /// 10 Hz, full Kalman gains, default input limits.
    pub fn new(
        roll_rad: T,
        pitch_rad: T,
        yaw_rad: T,
        lat_rad: T,
        h_m: T,
        lever_arm_b_m: Vector3<T>,
    ) -> Self {
        let deg = core::f64::consts::PI / 180.0;
        Self {
            roll_rad,
            pitch_rad,
            yaw_rad,
            tilt_sigma_rad: T::c(2.0 * deg),
            yaw_sigma_rad: T::c(0.5 * deg),
            lat_rad,
            h_m,
            lever_arm_b_m,
            gyro_arw_rad_per_sqrt_s: T::c(0.003 * deg / 20.0),
            gyro_bias_sigma_rad_s: T::c(0.2 * deg / 3600.0),
            accel_vrw_mps_per_sqrt_s: T::c(1e-3),
            accel_bias_sigma_mps2: T::c(0.005),
            reference_sigma_mps: T::zero(),
            update_period_s: T::c(0.1),
            gains: GainMode::Kalman,
            limits: InputLimits::default(),
        }
    }

    /// Checks every field (finite; spreads non-negative; sigmas of the tilt and the update period
    /// positive; latitude within +-90 deg).
    pub fn validate(&self) -> Result<(), LevelConfigError> {
        let finite = [
            self.roll_rad,
            self.pitch_rad,
            self.yaw_rad,
            self.tilt_sigma_rad,
            self.yaw_sigma_rad,
            self.lat_rad,
            self.h_m,
            self.gyro_arw_rad_per_sqrt_s,
            self.gyro_bias_sigma_rad_s,
            self.accel_vrw_mps_per_sqrt_s,
            self.accel_bias_sigma_mps2,
            self.reference_sigma_mps,
            self.update_period_s,
        ]
        .iter()
        .chain(self.lever_arm_b_m.iter())
        .all(|x| x.finite());
        if !finite {
            return Err(LevelConfigError::NonFinite);
        }
        let spreads = [
            self.yaw_sigma_rad,
            self.gyro_arw_rad_per_sqrt_s,
            self.gyro_bias_sigma_rad_s,
            self.accel_vrw_mps_per_sqrt_s,
            self.accel_bias_sigma_mps2,
            self.reference_sigma_mps,
        ];
        if spreads.iter().any(|x| *x < T::zero())
            || self.tilt_sigma_rad <= T::zero()
            || self.update_period_s <= T::zero()
            || self.update_period_s > T::one()
        {
            return Err(LevelConfigError::OutOfRange);
        }
        if self.lat_rad.abs() > T::c(core::f64::consts::FRAC_PI_2) {
            return Err(LevelConfigError::OutOfRange);
        }
        Ok(())
    }

    /// Tilt process noise density `q_g = N_g^2 + (sigma_d^2 + (Omega cos(lat) sigma_yaw)^2)
    /// tau_d` [rad^2/s]: the gyro angle random walk, the gyro drift, and the drift a heading
    /// error causes through the Earth rate (`d psi_E/dt = Omega_N psi_D`, Titterton & Weston
    /// §10.2.3), both spread over `tau_d` = [`DRIFT_CORRELATION_S`].
    pub fn tilt_process_noise(&self) -> T {
        let d = self.gyro_bias_sigma_rad_s;
        let h = T::c(OMEGA_IE) * self.lat_rad.pcos() * self.yaw_sigma_rad;
        self.gyro_arw_rad_per_sqrt_s * self.gyro_arw_rad_per_sqrt_s
            + (d * d + h * h) * T::c(DRIFT_CORRELATION_S)
    }

    /// Time constant of the constant-gain filter `tau = sqrt(q_a / q_g) / g` [s]: where the
    /// running mean of the slope stops improving because the tilt itself wanders (infinite
    /// without gyro noise), and at least [`Self::update_period_s`]: the gain `1 / (g tau)`
    /// then stays at most the dead-beat gain of one update interval `t_u` (a slope `g psi` seen
    /// over `t_u` corrected whole): a shorter `tau` overshoots, one below `t_u / 2` diverges, and
    /// without accelerometer noise `tau` is 0 and the gain infinite.
    pub fn scheduled_time_constant_s(&self) -> T {
        let g = LocalEarth::new(self.lat_rad, self.h_m).g;
        let q_g = self.tilt_process_noise();
        if q_g <= T::zero() {
            return T::c(f64::INFINITY);
        }
        ((self.accel_vrw_mps_per_sqrt_s / q_g.sqrt()) / g).max(self.update_period_s)
    }
}

/// Why a [`LevelConfig`] was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LevelConfigError {
    /// A field is NaN or infinite.
    NonFinite,
    /// A spread is negative, the tilt sigma or the update period not positive (or the period
    /// above 1 s), or the latitude beyond +-90 deg.
    OutOfRange,
}

impl core::fmt::Display for LevelConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NonFinite => "level alignment configuration contains NaN or infinity",
            Self::OutOfRange => "level alignment configuration value out of range",
        })
    }
}

impl core::error::Error for LevelConfigError {}

/// Counters of what the filter did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LevelStatus {
    /// Increments integrated.
    pub samples: u32,
    /// Increments refused by [`InputLimits`] (state unchanged).
    pub rejected_inputs: u32,
    /// Filter updates made.
    pub updates: u32,
    /// Updates skipped because the innovation covariance was not invertible or a result was not
    /// finite (the state and covariance are then left as propagated).
    pub failed_updates: u32,
}

/// Level alignment filter on a rocking base ([Ship alignment]; see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct LevelFilter<T: Scalar> {
    config: LevelConfig<T>,
    /// `q_b_n` as integrated (norm within 1e-4 of 1) and its summation carry.
    q: Quaternion<T>,
    q_carry: Quaternion<T>,
    /// Velocity `v_eb_n` [m/s] and its summation carry.
    v_eb_n: Vector3<T>,
    v_carry: Vector3<T>,
    cs: ConingSculling<T>,
    /// Error covariance (Kalman mode), states [`TILT_N`]..[`VEL_E`].
    p: Matrix4<T>,
    /// Specific-force velocity increment `sum C_b_n dv_b` over the current update interval [m/s].
    dv_f_n: Vector3<T>,
    /// Time since the last update [s].
    since_update_s: T,
    /// `w_D` of the last update [m/s]: the vertical lever-arm velocity at mid-sample plus half
    /// the sample's vertical specific-force increment (module docs).
    w_d: T,
    /// Time since the first sample [s].
    elapsed: Kahan<T>,
    /// When the velocity state starts, the end of the first sample [s].
    t_origin_s: T,
    /// `omega_ie_n` [rad/s], gravity `(0, 0, g)` [m/s^2].
    omega_ie_n: Vector3<T>,
    g_n: Vector3<T>,
    /// Velocity of the ship's centre of rotation [m/s], NED.
    v_centre_n: Vector3<T>,
    started: bool,
    status: LevelStatus,
    /// Gain of the last update (state per velocity residual).
    last_gain: Matrix4x2<T>,
}

/// One sample's quantities the measurement needs.
struct Sample<T: Scalar> {
    /// `q_b_n` at the start of the sample.
    q_prev: Quaternion<T>,
    /// Coning-compensated rotation vector of the sample [rad].
    phi_b: Vector3<T>,
    /// Mean body rate over the sample [rad/s].
    omega_ib_b: Vector3<T>,
    /// Specific-force velocity increment, NED [m/s].
    dv_n: Vector3<T>,
    /// Velocity at the start of the sample [m/s].
    v_prev: Vector3<T>,
}

impl<T: Scalar> LevelFilter<T> {
    /// A filter at the configured initial attitude, before its first sample.
    pub fn new(config: LevelConfig<T>) -> Result<Self, LevelConfigError> {
        config.validate()?;
        let earth = LocalEarth::new(config.lat_rad, config.h_m);
        let q = attitude::from_euler(config.roll_rad, config.pitch_rad, config.yaw_rad);
        let mut p = Matrix4::zeros();
        let s2 = config.tilt_sigma_rad * config.tilt_sigma_rad;
        p[(TILT_N, TILT_N)] = s2;
        p[(TILT_E, TILT_E)] = s2;
        Ok(Self {
            config,
            q: *q.quaternion(),
            q_carry: Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero()),
            v_eb_n: Vector3::zeros(),
            v_carry: Vector3::zeros(),
            cs: ConingSculling::new(),
            p,
            dv_f_n: Vector3::zeros(),
            since_update_s: T::zero(),
            w_d: T::zero(),
            elapsed: Kahan::new(),
            t_origin_s: T::zero(),
            omega_ie_n: earth.omega_ie_n(),
            g_n: Vector3::new(T::zero(), T::zero(), earth.g),
            v_centre_n: Vector3::zeros(),
            started: false,
            status: LevelStatus::default(),
            last_gain: Matrix4x2::zeros(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &LevelConfig<T> {
        &self.config
    }

    /// Counters.
    pub fn status(&self) -> LevelStatus {
        self.status
    }

    /// Time since the first sample [s].
    pub fn elapsed_s(&self) -> T {
        self.elapsed.sum
    }

    /// Sets the velocity of the ship's centre of rotation, NED [m/s] (from the ship's
    /// navigation system; zero by default). Non-finite values are refused (`false`).
    pub fn set_centre_velocity(&mut self, v_centre_n: Vector3<T>) -> bool {
        if !v_centre_n.iter().all(|x| x.finite()) {
            return false;
        }
        self.v_centre_n = v_centre_n;
        true
    }

    /// The error covariance of [`TILT_N`], [`TILT_E`], [`VEL_N`], [`VEL_E`] (Kalman mode; the
    /// constant-gain mode keeps the initial one).
    pub fn covariance(&self) -> &Matrix4<T> {
        &self.p
    }

    /// The gain of the last update, states [`TILT_N`]..[`VEL_E`] per residual `(z_N, z_E)`
    /// [rad per m/s; -]: the Kalman gain, or the constant gains.
    pub fn last_gain(&self) -> &Matrix4x2<T> {
        &self.last_gain
    }

    /// Integrates one increment and, every [`LevelConfig::update_period_s`], runs the filter.
    /// An increment failing [`ImuIncrement::check`] is counted and refused; the state is then
    /// unchanged and the two-sample coning/sculling history restarts.
    pub fn add(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        if let Err(e) = inc.check(&self.config.limits) {
            self.status.rejected_inputs = self.status.rejected_inputs.saturating_add(1);
            self.cs.reset();
            return Err(e);
        }
        let dt = inc.dt;
        let half = T::c(0.5);
        let c = self
            .cs
            .compensate(&inc.delta_theta_ib_b, &inc.delta_v_ib_b, dt, true);
        // Velocity (Savage (7.2.2.2-21)): the NED frame turns at omega_ie_n, so the body-frame
        // increment is resolved at mid-interval, `(I - [zeta x] / 2) C_b_n(k-1) dv_b`.
        let zeta = self.omega_ie_n * dt;
        let c_b_n = dcm_of(&self.q);
        let dv_n0 = c_b_n * c.delta_v_b;
        let dv_n = dv_n0 - zeta.cross(&dv_n0) * half;
        let coriolis = (self.omega_ie_n * T::c(2.0)).cross(&self.v_eb_n);
        let delta_v = dv_n + (self.g_n - coriolis) * dt;
        let sample = Sample {
            q_prev: self.q,
            phi_b: c.phi_b,
            omega_ib_b: inc.delta_theta_ib_b / dt,
            dv_n,
            v_prev: self.v_eb_n,
        };
        if !self.started {
            // Start the velocity from the reference at mid-sample (the first sample's rate
            // belongs there), stepped to the end of the sample; the velocity state
            // e = dv + w x psi starts at the end of the sample (w carries the half sample), and
            // so do the tilt coupling and the constant-gain clock.
            let v_ref = self.reference_mid(&sample);
            self.v_eb_n = v_ref + delta_v * half;
            self.v_carry = Vector3::zeros();
            self.init_velocity_covariance(&sample, dt);
            self.w_d = v_ref.z - self.v_centre_n.z + dv_n.z * half;
            self.dv_f_n = -dv_n;
            self.t_origin_s = dt;
            self.started = true;
        } else {
            kahan_add(
                self.v_eb_n.as_mut_slice(),
                self.v_carry.as_mut_slice(),
                delta_v.as_slice(),
            );
        }
        // Attitude: q(k) = q(-zeta) q(k-1) q(phi) (Savage (7.1.2-14)), summed with a carry.
        let delta = rotation_vector_delta(&self.q, &c.phi_b, &zeta);
        self.add_to_q(&delta);

        self.dv_f_n += dv_n;
        self.since_update_s += dt;
        self.elapsed.add(dt);
        self.status.samples = self.status.samples.saturating_add(1);
        if self.since_update_s >= self.config.update_period_s - dt * half {
            self.update(&sample, dt);
        }
        Ok(())
    }

    /// The current attitude with its 1-sigma roll/pitch (filter covariance, or the constant-gain
    /// closed form, plus the accelerometer-bias floor) and yaw (the given heading's sigma plus
    /// the gyro's angle random walk and drift since) [rad].
    pub fn estimate(&self) -> AttitudeEstimate<T> {
        let q_b_n = UnitQuaternion::new_normalize(self.q);
        let (_, pitch, yaw) = attitude::euler(&q_b_n);
        let t = self.elapsed.sum;
        let g = self.g_n.z;
        let floor = self.config.accel_bias_sigma_mps2 / g;
        let (var_roll, var_pitch) = match self.config.gains {
            GainMode::Kalman => {
                // Roll and pitch errors from the NED tilt: rotate by the heading; roll is about
                // the body's x axis, pitch about the level-frame y axis (Titterton & Weston
                // eq. 3.52 to first order).
                let (s, c) = (yaw.psin(), yaw.pcos());
                let cp = pitch.pcos().max(T::c(1e-3));
                let j_roll = Vector2::new(c / cp, s / cp);
                let j_pitch = Vector2::new(-s, c);
                let p2 = self.p.fixed_view::<2, 2>(TILT_N, TILT_N).into_owned();
                (
                    (j_roll.transpose() * p2 * j_roll).x,
                    (j_pitch.transpose() * p2 * j_pitch).x,
                )
            }
            GainMode::Scheduled => {
                let v = self.scheduled_variance(t - self.t_origin_s);
                (v, v)
            }
        };
        // The heading drifts with the vertical gyro: angle random walk and turn-on bias.
        let cfg = &self.config;
        let drift = cfg.gyro_bias_sigma_rad_s * t;
        let yaw_var = cfg.yaw_sigma_rad * cfg.yaw_sigma_rad
            + cfg.gyro_arw_rad_per_sqrt_s * cfg.gyro_arw_rad_per_sqrt_s * t
            + drift * drift;
        AttitudeEstimate {
            q_b_n,
            sigma_rad: Vector3::new(
                (var_roll.max(T::zero()) + floor * floor).sqrt(),
                (var_pitch.max(T::zero()) + floor * floor).sqrt(),
                yaw_var.sqrt(),
            ),
            elapsed_s: t,
        }
    }

    /// Tilt variance per axis of the constant-gain filter at `t` [s] (module docs), without the
    /// bias floor [rad^2].
    fn scheduled_variance(&self, t: T) -> T {
        let cfg = &self.config;
        let g = self.g_n.z;
        let q_a = cfg.accel_vrw_mps_per_sqrt_s * cfg.accel_vrw_mps_per_sqrt_s;
        if t <= T::zero() {
            return cfg.tilt_sigma_rad * cfg.tilt_sigma_rad;
        }
        let tau = cfg.scheduled_time_constant_s();
        // P(t) / g^2 = sqrt(q_a q_g) coth(t / tau) / g = q_a / (g^2 tau tanh(t / tau)).
        let x = t / tau;
        let slope = if x.to_f64() < 1e-3 {
            q_a / (g * g * t)
        } else {
            q_a / (g * g * tau * T::c(libm::tanh(x.to_f64())))
        };
        let sz2 = self.reference_variance_estimate();
        let gt = g * t;
        (slope + T::c(2.0) * sz2 / (gt * gt)).min(cfg.tilt_sigma_rad * cfg.tilt_sigma_rad)
    }

    /// Nominal per-axis variance of the velocity reference [m^2/s^2] (gyro noise through the
    /// lever arm at the nominal 400 Hz, plus the reference noise), for the closed-form sigma.
    fn reference_variance_estimate(&self) -> T {
        let cfg = &self.config;
        let n = cfg.gyro_arw_rad_per_sqrt_s;
        // sigma_w^2 = N^2 / dt with dt = 1/400 s; (2/3) |R|^2 is the mean of |R|^2 - R_i^2.
        n * n * T::c(400.0) * cfg.lever_arm_b_m.norm_squared() * T::c(2.0 / 3.0)
            + cfg.reference_sigma_mps * cfg.reference_sigma_mps
    }

    /// `v_ref` at the middle of the sample [m/s]: `v_centre + C_b_n (omega_nb_b x R)` with the
    /// attitude half-way through the sample and its mean rate.
    fn reference_mid(&self, s: &Sample<T>) -> Vector3<T> {
        let c_mid = dcm_of(&self.q_mid(s));
        let omega_nb_b = s.omega_ib_b - c_mid.transpose() * self.omega_ie_n;
        self.v_centre_n + c_mid * omega_nb_b.cross(&self.config.lever_arm_b_m)
    }

    /// `q_b_n` half-way through the sample.
    fn q_mid(&self, s: &Sample<T>) -> Quaternion<T> {
        s.q_prev * *attitude::rotation_vector_quat(&(s.phi_b * T::c(0.5))).quaternion()
    }

    /// Horizontal covariance of the reference's gyro noise at mid-sample [m^2/s^2]:
    /// `sigma_w^2 C (|R|^2 I - R R^T) C^T`, plus the reference and floor noises.
    fn reference_covariance(&self, c_mid: &Matrix3<T>, dt: T) -> Matrix2<T> {
        let cfg = &self.config;
        let r = cfg.lever_arm_b_m;
        let n = cfg.gyro_arw_rad_per_sqrt_s;
        let sw2 = n * n / dt;
        let m = (Matrix3::identity() * r.norm_squared() - r * r.transpose()) * sw2;
        let m_n = c_mid * m * c_mid.transpose();
        let floor = T::c(MEASUREMENT_FLOOR_MPS * MEASUREMENT_FLOOR_MPS)
            + cfg.reference_sigma_mps * cfg.reference_sigma_mps;
        let off = (m_n[(0, 1)] + m_n[(1, 0)]) * T::c(0.5);
        Matrix2::new(m_n[(0, 0)] + floor, off, off, m_n[(1, 1)] + floor)
    }

    /// Initial covariance of the velocity state `e = dv + w x psi`: the velocity starts on the
    /// reference computed with the erroneous attitude, so `e(0)` is the reference's noise alone,
    /// uncorrelated with the tilt (module docs).
    fn init_velocity_covariance(&mut self, s: &Sample<T>, dt: T) {
        let c_mid = dcm_of(&self.q_mid(s));
        let r = self.reference_covariance(&c_mid, dt);
        self.p.fixed_view_mut::<2, 2>(VEL_N, VEL_N).copy_from(&r);
    }

    /// The filter step at the end of an update interval: propagation of the covariance over the
    /// interval, the measurement at the middle of its last sample, the correction.
    fn update(&mut self, s: &Sample<T>, dt: T) {
        let half = T::c(0.5);
        let t_u = self.since_update_s;
        let dv_f = self.dv_f_n;
        self.since_update_s = T::zero();
        self.dv_f_n = Vector3::zeros();

        let q_mid = self.q_mid(s);
        let c_mid = dcm_of(&q_mid);
        let omega_nb_b = s.omega_ib_b - c_mid.transpose() * self.omega_ie_n;
        let v_lever = c_mid * omega_nb_b.cross(&self.config.lever_arm_b_m);
        let v_ref = self.v_centre_n + v_lever;
        let v_mid = (s.v_prev + self.v_eb_n) * half;
        let z = Vector2::new(v_mid.x - v_ref.x, v_mid.y - v_ref.y);
        // Vertical: not a state; kept on the reference for the Coriolis term.
        self.v_eb_n.z -= v_mid.z - v_ref.z;
        self.v_carry.z = T::zero();
        if !z.iter().all(|x| x.finite()) {
            self.status.failed_updates = self.status.failed_updates.saturating_add(1);
            return;
        }

        // w = v_lever + Delta_v_last / 2 (the mid-sample velocity lags the state by half a
        // sample); its change since the last update enters the tilt coupling.
        let w_d = v_lever.z + s.dv_n.z * half;
        let u_d = dv_f.z - (w_d - self.w_d);
        self.w_d = w_d;
        let x = match self.config.gains {
            GainMode::Kalman => {
                self.propagate(u_d, t_u);
                let r = self.reference_covariance(&c_mid, dt);
                match kalman_update(&mut self.p, &r, &z) {
                    Some((x, k)) => {
                        self.last_gain = k;
                        x
                    }
                    None => {
                        self.status.failed_updates = self.status.failed_updates.saturating_add(1);
                        return;
                    }
                }
            }
            GainMode::Scheduled => {
                let k = self.scheduled_gain(self.elapsed.sum - self.t_origin_s);
                // e_N grows as -g psi_E t, e_E as g psi_N t (psi x (-g_n)).
                let mut gain = Matrix4x2::zeros();
                gain[(TILT_N, 1)] = k;
                gain[(TILT_E, 0)] = -k;
                gain[(VEL_N, 0)] = T::one();
                gain[(VEL_E, 1)] = T::one();
                self.last_gain = gain;
                gain * z
            }
        };
        // Closed-loop correction (Groves §14.1.1): C_b_n <- (I - [psi x]) C_b_n and
        // v <- v - dv with dv = e - w x psi, which leaves e = 0 against the corrected reference.
        let yaw_before = yaw_of(&self.q);
        let psi = Vector3::new(x[TILT_N], x[TILT_E], T::zero());
        let delta = small_rotation(&(-psi)) * self.q;
        self.add_to_q(&delta);
        // (w x psi)_N = -w_D psi_E, (w x psi)_E = w_D psi_N.
        self.v_eb_n.x -= x[VEL_N] + w_d * psi.y;
        self.v_eb_n.y -= x[VEL_E] - w_d * psi.x;
        self.v_carry = Vector3::zeros();
        self.keep_heading(yaw_before);
        self.status.updates = self.status.updates.saturating_add(1);
    }

    /// Turns the attitude back about down to the Euler yaw `yaw_before` [rad], and the velocity
    /// with it. The heading is the ship's: a level correction changes the Euler yaw by
    /// `tan(pitch)` times its roll part (plus its second order), which the filter cannot observe
    /// and which would tilt the level through the Earth rate (`d psi_E/dt = Omega_N psi_D`).
    /// `v` and `v_ref` turn together, so the velocity error stays the model's. Skipped within
    /// ~8 deg of pitch +-90 deg, where the Euler yaw is ill-defined.
    fn keep_heading(&mut self, yaw_before: T) {
        let n2 = self.q.norm_squared();
        let sin_pitch = T::c(2.0) * (self.q.w * self.q.j - self.q.k * self.q.i) / n2;
        if sin_pitch.abs() > T::c(0.99) {
            return;
        }
        let pi = T::c(core::f64::consts::PI);
        let mut d_yaw = yaw_before - yaw_of(&self.q);
        if d_yaw > pi {
            d_yaw -= pi + pi;
        } else if d_yaw < -pi {
            d_yaw += pi + pi;
        }
        let turn = Vector3::new(T::zero(), T::zero(), d_yaw);
        let delta = small_rotation(&turn) * self.q;
        self.add_to_q(&delta);
        let (s, c) = (d_yaw.psin(), d_yaw.pcos());
        let v = self.v_eb_n;
        self.v_eb_n.x = c * v.x - s * v.y;
        self.v_eb_n.y = s * v.x + c * v.y;
    }

    /// Tilt gain of the constant-gain filter at `t` [s]: `coth(t / tau) / (g tau)` [rad per m/s].
    fn scheduled_gain(&self, t: T) -> T {
        let g = self.g_n.z;
        let tau = self.config.scheduled_time_constant_s();
        let t = t.max(self.config.update_period_s * T::c(0.5));
        let x = (t / tau).to_f64();
        if x < 1e-3 {
            // coth(x) / tau = 1 / t (1 + x^2 / 3 + ...)
            T::one() / (g * t)
        } else {
            T::c(1.0 / libm::tanh(x)) / (g * tau)
        }
    }

    /// `P <- Phi P Phi^T + Q` over `t_u` [s]; the tilt couples into the velocity state through
    /// `u_D` [m/s], the vertical specific-force increment minus the change of `w_D` (module
    /// docs; `-g t_u` plus the lever-arm terms).
    fn propagate(&mut self, u_d: T, t_u: T) {
        let w = self.omega_ie_n.z * t_u;
        let mut phi = Matrix4::identity();
        // d psi/dt = -omega_ie x psi (psi_D not a state).
        phi[(TILT_N, TILT_E)] = w;
        phi[(TILT_E, TILT_N)] = -w;
        // e += psi x u: (psi x u)_N = psi_E u_D, (psi x u)_E = -psi_N u_D.
        phi[(VEL_N, TILT_E)] = u_d;
        phi[(VEL_E, TILT_N)] = -u_d;
        // -2 omega_ie x dv.
        phi[(VEL_N, VEL_E)] = w * T::c(2.0);
        phi[(VEL_E, VEL_N)] = -w * T::c(2.0);
        let q_g = self.config.tilt_process_noise() * t_u;
        let q_a = self.config.accel_vrw_mps_per_sqrt_s * self.config.accel_vrw_mps_per_sqrt_s * t_u;
        let mut q = Matrix4::zeros();
        q[(TILT_N, TILT_N)] = q_g;
        q[(TILT_E, TILT_E)] = q_g;
        // The tilt noise integrated through psi x u (a linear ramp over the interval).
        let (q_vv, q_vt) = (q_a + q_g * u_d * u_d / T::c(3.0), q_g * u_d * T::c(0.5));
        q[(VEL_N, VEL_N)] = q_vv;
        q[(VEL_E, VEL_E)] = q_vv;
        q[(VEL_N, TILT_E)] = q_vt;
        q[(TILT_E, VEL_N)] = q_vt;
        q[(VEL_E, TILT_N)] = -q_vt;
        q[(TILT_N, VEL_E)] = -q_vt;
        let p = phi * self.p * phi.transpose() + q;
        self.p = (p + p.transpose()) * T::c(0.5);
    }

    /// `q += delta` with compensated summation; renormalised when the norm drifts by 1e-4.
    fn add_to_q(&mut self, delta: &Quaternion<T>) {
        kahan_add(
            self.q.coords.as_mut_slice(),
            self.q_carry.coords.as_mut_slice(),
            delta.coords.as_slice(),
        );
        let n2 = self.q.norm_squared();
        if (n2 - T::one()).abs() > T::c(1e-4) {
            self.q /= n2.sqrt();
            self.q_carry = Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero());
        }
    }
}

/// Kalman update of the velocity state measured directly, `H = [0 I]`, in the Joseph form
/// (keeps `P` symmetric positive semi-definite in `f32`; Groves eq. 3.58): returns the state
/// estimate `K z` and the gain `K`, or `None` (P untouched) when `P_vv + R` is not invertible or
/// a result is not finite.
fn kalman_update<T: Scalar>(
    p: &mut Matrix4<T>,
    r: &Matrix2<T>,
    z: &Vector2<T>,
) -> Option<(Vector4<T>, Matrix4x2<T>)> {
    let mut h = Matrix2x4::zeros();
    h[(0, VEL_N)] = T::one();
    h[(1, VEL_E)] = T::one();
    let ph_t: Matrix4x2<T> = p.fixed_view::<4, 2>(0, VEL_N).into_owned();
    let s = p.fixed_view::<2, 2>(VEL_N, VEL_N) + r;
    let det = s[(0, 0)] * s[(1, 1)] - s[(0, 1)] * s[(1, 0)];
    if det <= T::zero() || !det.finite() {
        return None;
    }
    let s_inv = Matrix2::new(s[(1, 1)], -s[(0, 1)], -s[(1, 0)], s[(0, 0)]) / det;
    let k = ph_t * s_inv;
    let x = k * z;
    let i_kh = Matrix4::identity() - k * h;
    let p_new = i_kh * *p * i_kh.transpose() + k * r * k.transpose();
    let p_new = (p_new + p_new.transpose()) * T::c(0.5);
    if !(p_new.iter().all(|v| v.finite()) && x.iter().all(|v| v.finite())) {
        return None;
    }
    *p = p_new;
    Some((x, k))
}

/// Euler yaw [rad] of `q_b_n` of any norm (Titterton & Weston eq. 3.66).
#[inline]
fn yaw_of<T: Scalar>(q: &Quaternion<T>) -> T {
    let two = T::c(2.0);
    (two * (q.w * q.k + q.i * q.j)).patan2(q.w * q.w + q.i * q.i - q.j * q.j - q.k * q.k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth;
    use proptest::prelude::*;

    /// Exact increment of a body at rest at latitude `lat` [rad] with attitude `q_b_n`.
    fn rest(lat: f64, q_b_n: &UnitQuaternion<f64>, dt: f64) -> ImuIncrement<f64> {
        let q_n_b = q_b_n.inverse();
        ImuIncrement {
            delta_theta_ib_b: q_n_b * earth::omega_ie_n(lat) * dt,
            delta_v_ib_b: q_n_b * Vector3::new(0.0, 0.0, -earth::normal_gravity(lat, 0.0)) * dt,
            dt,
        }
    }

    fn config<T: Scalar>(
        roll: f64,
        pitch: f64,
        yaw: f64,
        lat: f64,
        gains: GainMode,
    ) -> LevelConfig<T> {
        let mut c = LevelConfig::new(
            T::c(roll),
            T::c(pitch),
            T::c(yaw),
            T::c(lat),
            T::zero(),
            Vector3::new(T::c(30.0), T::c(10.0), T::c(15.0)),
        );
        c.gains = gains;
        c
    }

    fn levels_at_rest<T: Scalar>(gains: GainMode) {
        // Roll and pitch off by 1 deg, heading exact: after 20 s of exact data only the
        // second-order start transient is left (module docs), and the heading is kept.
        let (lat, roll, pitch, yaw) = (0.8, 0.02, -0.03, 2.0);
        let q = attitude::from_euler(roll, pitch, yaw);
        let inc = rest(lat, &q, 0.0025);
        let inc_t = ImuIncrement {
            delta_theta_ib_b: inc.delta_theta_ib_b.map(T::c),
            delta_v_ib_b: inc.delta_v_ib_b.map(T::c),
            dt: T::c(inc.dt),
        };
        let one = 1f64.to_radians();
        let mut f =
            LevelFilter::new(config::<T>(roll + one, pitch - one, yaw, lat, gains)).unwrap();
        for _ in 0..8000 {
            f.add(&inc_t).unwrap();
        }
        let e = f.estimate();
        let q = attitude::quat_to_f64(&e.q_b_n);
        assert_levelled(&q, roll, pitch);
        let (_, _, y) = attitude::euler(&q);
        assert!(
            (y - yaw).to_degrees().abs() < 1e-4,
            "{}",
            (y - yaw).to_degrees()
        );
        assert_eq!(f.status().updates, 200);
        assert!((e.elapsed_s.to_f64() - 20.0).abs() < 1e-6);
    }

    #[test]
    fn levels_a_body_at_rest_in_both_precisions() {
        for gains in [GainMode::Kalman, GainMode::Scheduled] {
            levels_at_rest::<f64>(gains);
            levels_at_rest::<f32>(gains);
        }
    }

    #[test]
    fn constant_gains_level_without_accelerometer_noise() {
        // Ideal sensors: tau = sqrt(q_a / q_g) / g is 0, the gain is the dead-beat one of an
        // update interval and the estimate finite (an infinite gain gave NaN and 90 deg).
        let (lat, roll, pitch, yaw) = (0.8, 0.02, -0.03, 2.0);
        let q = attitude::from_euler(roll, pitch, yaw);
        let inc = rest(lat, &q, 0.0025);
        let one = 1f64.to_radians();
        let mut c = config::<f64>(roll + one, pitch - one, yaw, lat, GainMode::Scheduled);
        c.gyro_arw_rad_per_sqrt_s = 0.0;
        c.gyro_bias_sigma_rad_s = 0.0;
        c.accel_vrw_mps_per_sqrt_s = 0.0;
        c.accel_bias_sigma_mps2 = 0.0;
        assert_eq!(c.scheduled_time_constant_s(), c.update_period_s);
        let mut f = LevelFilter::new(c).unwrap();
        for _ in 0..8000 {
            f.add(&inc).unwrap();
        }
        let e = f.estimate();
        assert!(e.sigma_rad.iter().all(|s| s.is_finite()), "{}", e.sigma_rad);
        assert_levelled(&e.q_b_n, roll, pitch);
    }

    /// Roll and pitch of `q_b_n` within 1e-4 deg of `roll`, `pitch` [rad].
    fn assert_levelled(q_b_n: &nalgebra::UnitQuaternion<f64>, roll: f64, pitch: f64) {
        let (r, p, _) = attitude::euler(q_b_n);
        let deg = |x: f64| x.to_degrees().abs();
        assert!(
            deg(r - roll) < 1e-4 && deg(p - pitch) < 1e-4,
            "{} {}",
            deg(r - roll),
            deg(p - pitch)
        );
    }

    #[test]
    fn refuses_bad_configurations_and_increments() {
        let good = config::<f32>(0.0, 0.0, 0.0, 0.5, GainMode::Kalman);
        assert!(good.validate().is_ok());
        let mut c = good;
        c.gyro_arw_rad_per_sqrt_s = f32::NAN;
        assert_eq!(c.validate(), Err(LevelConfigError::NonFinite));
        c = good;
        c.tilt_sigma_rad = 0.0;
        assert_eq!(c.validate(), Err(LevelConfigError::OutOfRange));
        c = good;
        c.lat_rad = 2.0;
        assert!(LevelFilter::new(c).is_err());
        let mut f = LevelFilter::new(good).unwrap();
        assert!(!f.set_centre_velocity(Vector3::new(f32::INFINITY, 0.0, 0.0)));
        let before = f.estimate();
        let bad = ImuIncrement::new([0.0, f32::NAN, 0.0], [0.0; 3], 0.0025);
        assert_eq!(f.add(&bad), Err(InputError::NonFinite));
        assert_eq!(f.estimate(), before);
        assert_eq!(f.status().rejected_inputs, 1);
    }

    proptest! {
        /// Any increments a ship can produce (rates to 0.5 rad/s, ten times sea state 6's peak;
        /// specific forces to 2 g) keep the state finite, the attitude a unit quaternion and the
        /// covariance symmetric positive semi-definite, in f32. (Far beyond, lever-arm velocities
        /// of ~100 m/s correlate the initial velocity with the tilt to 1 - 1e-7, past f32.)
        #[test]
        fn any_ship_motion_keeps_the_filter_sane(
            seeds in proptest::collection::vec((-0.5f32..0.5, -0.5f32..0.5, -0.5f32..0.5,
                                                -20.0f32..20.0, -20.0f32..20.0, -20.0f32..20.0), 1..400),
            lat in -1.5f32..1.5,
            scheduled in any::<bool>(),
        ) {
            let gains = if scheduled { GainMode::Scheduled } else { GainMode::Kalman };
            let mut f = LevelFilter::new(config::<f32>(0.1, -0.1, 1.0, f64::from(lat), gains)).unwrap();
            let dt = 0.0025f32;
            let mut p_max = f.covariance().amax();
            for &(a, b, c, d, e, g) in &seeds {
                let inc = ImuIncrement::new([a * dt, b * dt, c * dt], [d * dt, e * dt, g * dt - 9.8 * dt], dt);
                prop_assert!(f.add(&inc).is_ok());
                p_max = p_max.max(f.covariance().amax());
            }
            let est = f.estimate();
            prop_assert!((est.q_b_n.norm() - 1.0).abs() < 1e-5);
            prop_assert!(est.sigma_rad.iter().all(|x| x.is_finite() && *x >= 0.0));
            let p = f.covariance().map(f64::from);
            prop_assert!((p - p.transpose()).amax() <= 1e-12 * p.amax().max(1e-30));
            // PSD to f32 rounding: the Joseph update's errors are a few 2^-24 of the largest
            // covariance it has seen (a 2 deg prior, or a velocity prior correlated with it
            // through a large lever-arm velocity), whatever the covariance has shrunk to since.
            let eig = p.symmetric_eigenvalues();
            let tol = 16.0 * f64::from(f32::EPSILON) * f64::from(p_max);
            prop_assert!(eig.iter().all(|&l| l >= -tol), "{} (largest covariance seen {})", eig, p_max);
        }
    }
}
