//! Position-aided closed-loop fine alignment (seed 003; issue 6, requirement 2b): an
//! error-state Kalman filter around a [`Strapdown`] mechanization.
//!
//! **Design.**
//! - Mechanization: the project's [`Strapdown`] in the NED frame, every increment (400 Hz),
//!   the increments first compensated with the filter's bias estimates.
//! - Filter: 15 error states ([`model`]: position, velocity, attitude `phi`, gyro bias,
//!   accelerometer bias; named offsets), process model the linearised INS error equations
//!   (Titterton & Weston ch. 12, Groves §14.2, seed 000 eq. (22)), discretised over the filter
//!   interval ([`FineConfig::update_period_s`], 0.1 s by default): `Phi = I + F dt + (F dt)^2 / 2`,
//!   `Q_d = (Phi Q_c Phi^T + Q_c) dt / 2`, `F` linearised about the *reference* motion (the
//!   known position and velocity, so the specific force of a base at rest is `-g_n`: the
//!   computed one carries the tilt error, whose horizontal part would couple the heading error
//!   into the velocity and fake a heading observation before the levelling settles) with the
//!   interval's mean `C_b_n` for the gyro bias. At 10 Hz a 15-state propagation and six scalar
//!   Joseph updates cost about 2e4 multiply-adds, 2e5 per second: a few per cent of a
//!   Cortex-M4F, while the mechanization runs at the full rate.
//! - Measurements, every filter interval: the known position (computed minus known latitude,
//!   longitude and height, as north, east, down metres, noise [`FineConfig::position_sigma_m`])
//!   and the known velocity (zero by default, noise [`FineConfig::velocity_sigma_m_s`]): six
//!   scalar updates in Joseph form, symmetrised, each gated at
//!   [`FineConfig::gate_sigma`]. The height measurement aids the (free) vertical channel.
//! - Closed loop (seed 003: "estimates fed back into the navigation algorithm, the state
//!   zeroed"): after every update the attitude (`q_b_n <- q(phi) q_b_n`), velocity and position
//!   estimates are applied to the strapdown through [`Strapdown::set_state`] (which restarts
//!   its Kahan carries: harmless at 10 Hz), the bias estimates are added to the compensation
//!   (gyro in body axes, accelerometer in NED axes: [`model`]), and the error state is zeroed.
//!
//! **Large heading error.** No initial heading is assumed: the filter starts from a coarse
//! result with a large heading sigma (10 deg by default when the coarse stage gives none). The
//! attitude-error dynamics are exact in rotation-vector form for any heading error
//! ([`model`]), and at rest a heading error does not reach the velocity at all (the specific
//! force is vertical); the one small-angle step is the tilt's velocity signature `f x phi`,
//! which a heading error `psi` turns by `psi / 2` (heading read as `psi (1 - psi^2/6)`). Every
//! feedback removes what was estimated and the tilt is held at the noise level from the first
//! seconds, so the filter is an EKF re-linearised at 10 Hz whose only large error, the
//! heading, is the one it models exactly. Checked (`host-tests/tests/alignment_fine.rs` and
//! by hand): on exact data the residual of a 10 deg start is the linear filter's
//! `e0 P_T / P_0` to 5 %, still to 20 % from 60 deg and within 2x from 90 deg (all below
//! 0.15 deg at 30 s); with the noise, 32-run RMS from 10, 30 and 60 deg starts agree within
//! their 12 % spread. The validity limit is therefore the tilt, not the heading: the coarse
//! stage's roll and pitch must be within a few degrees (`f x phi` linear; seed 003's coarse
//! levelling gives tenths).
//!
//! **Observability on a still or rocking base.** Heading is seen through the east tilt drift
//! `Omega cos(L) psi` (gyrocompassing); the east gyro bias makes the same drift, so it leaves a
//! heading error `eps_E / (Omega cos L)`; a horizontal accelerometer bias leaves a tilt
//! `b / g`. Rocking by a few degrees does not separate them (the bias projections change by
//! `1 - cos(5 deg) = 0.4 %`; the accelerometer bias is modelled in NED axes, see [`model`]).
//! The filter's sigmas include these limits through the bias priors; the vertical
//! accelerometer bias and the north gyro bias are observed.
//!
//! Memory: 2.7 KB in `f32` (5.2 KB in `f64`), the covariance included; no allocation.
//!
//! No input panics: increments that fail [`ImuIncrement::check`] are refused and counted,
//! non-finite configuration values fall back to the defaults, and a covariance that became
//! non-finite is re-initialised (counted in [`FineStatus::resets`]).

pub mod kalman;
pub mod model;

use super::{AttitudeEstimate, SensorNoise};
use crate::earth::LocalEarth;
use crate::{
    ImuIncrement, InputError, MechanizationConfig, NavFrame, NavState, Position, Scalar, Strapdown,
    attitude,
};
use kalman::{ScalarUpdate, discrete_noise, propagate, update_scalar};
use model::{ACCEL_BIAS, ATT, GYRO_BIAS, Linearisation, Matrix, POS, State, VEL};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// Noise model and settings of [`FineAlignment`]. `Default` is seed 003's FOG IMU on a still
/// or rocking bench with the position known.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FineConfig<T: Scalar> {
    /// The IMU's noise: gyro white-noise density (angle random walk) [rad/s/sqrt(Hz)] =
    /// [rad/sqrt(s)] on the attitude, accelerometer white-noise density (velocity random walk)
    /// [m/s^2/sqrt(Hz)] = [m/s/sqrt(s)] on the velocity, and the initial 1-sigma of each gyro
    /// bias [rad/s] and accelerometer bias [m/s^2] (0: biases known to be compensated).
    /// Default [`SensorNoise::seed003`]: seed 003's 0.003 deg/s and 0.02 m/s^2 RMS at 400 Hz
    /// (2.618e-6 rad/sqrt(s), 1e-3 m/s/sqrt(s)), 0.2 deg/h, 0.005 m/s^2.
    pub noise: SensorNoise<T>,
    /// Gyro bias random walk [rad/s/sqrt(s)] (default 0: constant biases).
    pub gyro_bias_walk: T,
    /// Accelerometer bias random walk [m/s^2/sqrt(s)] (default 0).
    pub accel_bias_walk: T,
    /// 1-sigma noise of the position measurement, per NED axis [m] (default 0.1: a surveyed
    /// bench or an RTK fix; a stand-alone GNSS receiver: 2–5).
    pub position_sigma_m: T,
    /// 1-sigma noise of the known-velocity measurement, per NED axis [m/s] (default 1e-3:
    /// the bench is still at the centre of its rotation; a surfaced vehicle in waves should
    /// give its wave-induced velocity here).
    pub velocity_sigma_m_s: T,
    /// Initial 1-sigma of the velocity error [m/s] (default 0.1).
    pub initial_velocity_sigma_m_s: T,
    /// Roll and pitch 1-sigma used when the coarse estimate gives none (NaN) [rad] (default
    /// 1 deg).
    pub fallback_level_sigma: T,
    /// Heading 1-sigma used when the coarse estimate gives none (NaN) [rad] (default 10 deg).
    pub fallback_yaw_sigma: T,
    /// Filter interval: covariance propagation and measurement updates [s] (default 0.1).
    pub update_period_s: T,
    /// Innovation gate [sigma] (default 8: only gross outliers are refused).
    pub gate_sigma: T,
    /// Mechanization (its frame is forced to [`NavFrame::Ned`], the filter's frame).
    pub mechanization: MechanizationConfig<T>,
}

impl<T: Scalar> Default for FineConfig<T> {
    fn default() -> Self {
        let deg = core::f64::consts::PI / 180.0;
        Self {
            noise: SensorNoise::seed003(),
            gyro_bias_walk: T::zero(),
            accel_bias_walk: T::zero(),
            position_sigma_m: T::c(0.1),
            velocity_sigma_m_s: T::c(1e-3),
            initial_velocity_sigma_m_s: T::c(0.1),
            fallback_level_sigma: T::c(deg),
            fallback_yaw_sigma: T::c(10.0 * deg),
            update_period_s: T::c(0.1),
            gate_sigma: T::c(8.0),
            mechanization: MechanizationConfig::default(),
        }
    }
}

impl<T: Scalar> FineConfig<T> {
    /// The configuration with every non-finite or negative value replaced by its default
    /// (a zero or negative filter interval or gate too).
    pub fn sanitized(&self) -> Self {
        let d = Self::default();
        let nonneg = |v: T, dv: T| if v.finite() && v >= T::zero() { v } else { dv };
        let pos = |v: T, dv: T| if v.finite() && v > T::zero() { v } else { dv };
        Self {
            noise: SensorNoise {
                arw_rad_per_sqrt_s: nonneg(
                    self.noise.arw_rad_per_sqrt_s,
                    d.noise.arw_rad_per_sqrt_s,
                ),
                vrw_mps_per_sqrt_s: nonneg(
                    self.noise.vrw_mps_per_sqrt_s,
                    d.noise.vrw_mps_per_sqrt_s,
                ),
                gyro_bias_rad_s: nonneg(self.noise.gyro_bias_rad_s, d.noise.gyro_bias_rad_s),
                accel_bias_mps2: nonneg(self.noise.accel_bias_mps2, d.noise.accel_bias_mps2),
            },
            gyro_bias_walk: nonneg(self.gyro_bias_walk, d.gyro_bias_walk),
            accel_bias_walk: nonneg(self.accel_bias_walk, d.accel_bias_walk),
            position_sigma_m: pos(self.position_sigma_m, d.position_sigma_m),
            velocity_sigma_m_s: pos(self.velocity_sigma_m_s, d.velocity_sigma_m_s),
            initial_velocity_sigma_m_s: pos(
                self.initial_velocity_sigma_m_s,
                d.initial_velocity_sigma_m_s,
            ),
            fallback_level_sigma: pos(self.fallback_level_sigma, d.fallback_level_sigma),
            fallback_yaw_sigma: pos(self.fallback_yaw_sigma, d.fallback_yaw_sigma),
            // The mechanization's interval limit keeps the filter interval sane too.
            update_period_s: pos(self.update_period_s, d.update_period_s).min(T::c(10.0)),
            gate_sigma: pos(self.gate_sigma, d.gate_sigma),
            mechanization: MechanizationConfig {
                frame: NavFrame::Ned,
                ..self.mechanization
            },
        }
    }
}

/// Counters of what the filter did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FineStatus {
    /// Increments integrated.
    pub increments: u32,
    /// Increments refused (non-finite, bad interval, out of range).
    pub rejected_increments: u32,
    /// Filter intervals completed (propagation, updates and feedback).
    pub updates: u32,
    /// Scalar measurements accepted.
    pub accepted_measurements: u32,
    /// Scalar measurements refused by the gate or as degenerate.
    pub rejected_measurements: u32,
    /// Covariance re-initialisations after a non-finite value.
    pub resets: u32,
}

/// The position-aided closed-loop fine-alignment filter (module docs).
#[derive(Clone, Debug)]
pub struct FineAlignment<T: Scalar> {
    config: FineConfig<T>,
    nav: Strapdown<T>,
    /// Known position and velocity `v_eb_n` [m/s] (NED).
    reference: (Position, Vector3<T>),
    /// The known velocity at the previous filter interval [m/s].
    reference_v_prev: Vector3<T>,
    p: Matrix<T>,
    p0: Matrix<T>,
    q_c: State<T>,
    /// Bias estimates subtracted from the increments: gyro (body axes) [rad/s],
    /// accelerometer (NED axes) [m/s^2].
    gyro_bias: Vector3<T>,
    accel_bias_n: Vector3<T>,
    /// Accumulated over the current filter interval: time [s] and `int C_b_n dt` [s].
    interval_s: f64,
    sum_c_b_n: Matrix3<T>,
    /// `C_b_n` at the end of the last increment.
    c_b_n: Matrix3<T>,
    elapsed_s: f64,
    status: FineStatus,
}

impl<T: Scalar> FineAlignment<T> {
    /// Starts fine alignment at the known `position` (NED frame; the vehicle at rest or
    /// rocking in place) from a coarse `initial` attitude and its 1-sigma roll, pitch and yaw
    /// (NaN sigmas: [`FineConfig::fallback_level_sigma`], [`FineConfig::fallback_yaw_sigma`]).
    pub fn new(initial: AttitudeEstimate<T>, position: Position, config: FineConfig<T>) -> Self {
        let config = config.sanitized();
        let position = position.to_ned_frame();
        let q = initial.q_b_n;
        let q = if q.coords.iter().all(|v| v.finite()) {
            q
        } else {
            UnitQuaternion::identity()
        };
        let start = NavState::at_rest(position, q);
        let nav = Strapdown::new(start, config.mechanization);
        let sigma = |s: T, fallback: T| {
            if s.finite() && s > T::zero() {
                s
            } else {
                fallback
            }
        };
        let euler_sigma = Vector3::new(
            sigma(initial.sigma_rad.x, config.fallback_level_sigma),
            sigma(initial.sigma_rad.y, config.fallback_level_sigma),
            sigma(initial.sigma_rad.z, config.fallback_yaw_sigma),
        );
        let mut p0 = Matrix::<T>::zeros();
        let var = |s: T| s * s;
        for i in 0..3 {
            p0[(POS + i, POS + i)] = var(config.position_sigma_m);
            p0[(VEL + i, VEL + i)] = var(config.initial_velocity_sigma_m_s);
            p0[(GYRO_BIAS + i, GYRO_BIAS + i)] = var(config.noise.gyro_bias_rad_s);
            p0[(ACCEL_BIAS + i, ACCEL_BIAS + i)] = var(config.noise.accel_bias_mps2);
        }
        p0.fixed_view_mut::<3, 3>(ATT, ATT)
            .copy_from(&phi_covariance(&q, &euler_sigma));
        let q_c = model::noise_densities(
            config.noise.arw_rad_per_sqrt_s,
            config.noise.vrw_mps_per_sqrt_s,
            config.gyro_bias_walk,
            config.accel_bias_walk,
        );
        let c_b_n = q.to_rotation_matrix().into_inner();
        Self {
            config,
            nav,
            reference: (position, Vector3::zeros()),
            reference_v_prev: Vector3::zeros(),
            p: p0,
            p0,
            q_c,
            gyro_bias: Vector3::zeros(),
            accel_bias_n: Vector3::zeros(),
            interval_s: 0.0,
            sum_c_b_n: Matrix3::zeros(),
            c_b_n,
            elapsed_s: 0.0,
            status: FineStatus::default(),
        }
    }

    /// Replaces the known position and velocity `v_eb_n` [m/s] (NED) the measurements compare
    /// against (e.g. a new GNSS fix). Non-finite velocities are refused (returns `false`).
    pub fn set_reference(&mut self, position: Position, v_eb_n: Vector3<T>) -> bool {
        if !v_eb_n.iter().all(|v| v.finite()) {
            return false;
        }
        self.reference = (position.to_ned_frame(), v_eb_n);
        if self.status.updates == 0 {
            // No previous reference to difference against yet.
            self.reference_v_prev = v_eb_n;
        }
        true
    }

    /// Adds one increment: compensates it with the bias estimates, integrates it, and at the
    /// end of every filter interval propagates the covariance, applies the position and
    /// velocity measurements and feeds the estimates back. A refused increment changes nothing
    /// but the counters.
    pub fn add(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        if let Err(e) = inc.check(&self.config.mechanization.limits) {
            self.status.rejected_increments = self.status.rejected_increments.saturating_add(1);
            self.nav.restart_increments();
            return Err(e);
        }
        let dt = inc.dt;
        // Gyro bias in body axes; accelerometer bias in NED axes, turned into the body with the
        // attitude at the start of the increment (the mechanization's own projection).
        let compensated = ImuIncrement {
            delta_theta_ib_b: inc.delta_theta_ib_b - self.gyro_bias * dt,
            delta_v_ib_b: inc.delta_v_ib_b - self.c_b_n.transpose() * self.accel_bias_n * dt,
            dt,
        };
        if let Err(e) = self.nav.step(&compensated) {
            self.status.rejected_increments = self.status.rejected_increments.saturating_add(1);
            return Err(e);
        }
        self.status.increments = self.status.increments.saturating_add(1);
        // Trapezoidal mean of C_b_n over the increment, for the bias coupling.
        let c_end = self.nav.state().q_b_n.to_rotation_matrix().into_inner();
        let c_mid = (self.c_b_n + c_end) * T::c(0.5);
        self.c_b_n = c_end;
        self.sum_c_b_n += c_mid * dt;
        self.interval_s += dt.to_f64();
        self.elapsed_s += dt.to_f64();
        // At the sample boundary nearest the period, whatever the rounding of `dt` and of the
        // period in `T` (f32 and f64 filters update on the same samples).
        if self.interval_s + 0.5 * dt.to_f64() >= self.config.update_period_s.to_f64() {
            self.filter_step();
        }
        Ok(())
    }

    /// One filter interval: propagation, six scalar updates, feedback.
    fn filter_step(&mut self) {
        let dt = T::c(self.interval_s);
        let s = *self.nav.state();
        let (lat, h) = (s.position.lat_f64(), s.position.h_f64());
        let earth = LocalEarth::new(T::c(lat), T::c(h));
        // Linearised about the reference (known) motion, not the computed one: the true
        // specific force of a base at rest is -g_n exactly, while the computed one carries the
        // tilt error (`g e` horizontally), which would couple the heading error into the
        // velocity (`f_h x phi_D`) and fake a heading observation before the levelling settles.
        let (_, ref_v) = self.reference;
        let f_ib_n = (ref_v - self.reference_v_prev) / dt
            + (earth.omega_ie_n() * T::c(2.0)).cross(&ref_v)
            - Vector3::new(T::zero(), T::zero(), earth.g);
        self.reference_v_prev = ref_v;
        let lin = Linearisation {
            earth,
            v_eb_n: ref_v,
            f_ib_n,
            c_b_n: self.sum_c_b_n / dt,
        };
        let phi = model::transition(&lin, dt);
        let q_d = discrete_noise(&phi, &self.q_c, dt);
        propagate(&mut self.p, &phi, &q_d);
        self.interval_s = 0.0;
        self.sum_c_b_n = Matrix3::zeros();

        // Innovations: computed minus known position (north, east, down metres) and velocity.
        let (ref_pos, ref_v) = self.reference;
        let e64 = LocalEarth::<f64>::new(lat, h);
        let d_lat = lat - ref_pos.lat_f64();
        let d_lon = wrap_pi(s.position.lon_f64() - ref_pos.lon_f64());
        let dr_n = [
            d_lat * (e64.r_meridian + h),
            d_lon * (e64.r_transverse + h) * libm::cos(lat),
            -(h - ref_pos.h_f64()),
        ];
        let mut x = State::<T>::zeros();
        let r_pos = self.config.position_sigma_m * self.config.position_sigma_m;
        let r_vel = self.config.velocity_sigma_m_s * self.config.velocity_sigma_m_s;
        for i in 0..6 {
            let (index, z, r) = if i < 3 {
                (POS + i, T::c(dr_n[i]), r_pos)
            } else {
                (VEL + i - 3, s.v_eb_n[i - 3] - ref_v[i - 3], r_vel)
            };
            let mut h_row = State::<T>::zeros();
            h_row[index] = T::one();
            let innovation = z - x[index];
            match update_scalar(
                &mut x,
                &mut self.p,
                &h_row,
                innovation,
                r,
                self.config.gate_sigma,
            ) {
                ScalarUpdate::Accepted => {
                    self.status.accepted_measurements =
                        self.status.accepted_measurements.saturating_add(1)
                }
                ScalarUpdate::Gated | ScalarUpdate::Degenerate => {
                    self.status.rejected_measurements =
                        self.status.rejected_measurements.saturating_add(1)
                }
            }
        }
        self.status.updates = self.status.updates.saturating_add(1);
        if !(kalman::all_finite(&self.p) && kalman::all_finite(&x)) {
            // Cannot happen with finite inputs; start the covariance afresh rather than panic.
            self.p = self.p0;
            self.status.resets = self.status.resets.saturating_add(1);
            return;
        }
        self.feed_back(&s, &x, &e64);
    }

    /// Applies the error estimate `x` to the strapdown and the bias compensation (seed 003:
    /// re-initialise with corrected values; the error state is then zero).
    fn feed_back(&mut self, s: &NavState<T>, x: &State<T>, e64: &LocalEarth<f64>) {
        let phi = Vector3::new(x[ATT], x[ATT + 1], x[ATT + 2]);
        // Computed = exp(-[phi x]) true, so true = q(phi) computed.
        let q_b_n = attitude::rotation_vector_quat(&phi) * s.q_b_n;
        let v_eb_n = s.v_eb_n - Vector3::new(x[VEL], x[VEL + 1], x[VEL + 2]);
        let (lat, lon, h) = (
            s.position.lat_f64(),
            s.position.lon_f64(),
            s.position.h_f64(),
        );
        let d_n = x[POS].to_f64();
        let d_e = x[POS + 1].to_f64();
        let d_d = x[POS + 2].to_f64();
        let lat_new = lat - d_n / (e64.r_meridian + h);
        let lon_new = lon - d_e / ((e64.r_transverse + h) * libm::cos(lat).max(1e-9));
        let position = Position::from_radians(lat_new, lon_new, h + d_d);
        self.nav.set_state(NavState {
            q_b_n,
            v_eb_n,
            position,
        });
        self.c_b_n = q_b_n.to_rotation_matrix().into_inner();
        self.gyro_bias += Vector3::new(x[GYRO_BIAS], x[GYRO_BIAS + 1], x[GYRO_BIAS + 2]);
        self.accel_bias_n += Vector3::new(x[ACCEL_BIAS], x[ACCEL_BIAS + 1], x[ACCEL_BIAS + 2]);
    }

    /// The current attitude (body to NED) with the filter's 1-sigma roll, pitch and yaw (from
    /// the covariance at the last filter interval) and the time aligned so far.
    pub fn estimate(&self) -> AttitudeEstimate<T> {
        let q_b_n = self.nav.state().ned().0;
        let p_att = self.p.fixed_view::<3, 3>(ATT, ATT).into_owned();
        AttitudeEstimate {
            q_b_n,
            sigma_rad: euler_sigma(&q_b_n, &p_att),
            elapsed_s: T::c(self.elapsed_s),
        }
    }

    /// Gyro bias estimate (body axes) [rad/s] and its 1-sigma [rad/s].
    pub fn gyro_bias(&self) -> (Vector3<T>, Vector3<T>) {
        (self.gyro_bias, self.sigmas(GYRO_BIAS))
    }

    /// Accelerometer bias estimate in NED axes [m/s^2] ([`model`] says why not body axes) and
    /// its 1-sigma [m/s^2]. Its horizontal part is as unobservable as the tilt it mimics.
    pub fn accel_bias_n(&self) -> (Vector3<T>, Vector3<T>) {
        (self.accel_bias_n, self.sigmas(ACCEL_BIAS))
    }

    fn sigmas(&self, offset: usize) -> Vector3<T> {
        Vector3::from_fn(|i, _| self.p[(offset + i, offset + i)].max(T::zero()).sqrt())
    }

    /// The error-state covariance after the last filter interval (offsets in [`model`]).
    pub fn covariance(&self) -> &Matrix<T> {
        &self.p
    }

    /// The navigation state (NED frame) of the strapdown the filter corrects.
    pub fn state(&self) -> &NavState<T> {
        self.nav.state()
    }

    /// Counters.
    pub fn status(&self) -> FineStatus {
        self.status
    }

    /// The configuration in use (sanitised).
    pub fn config(&self) -> &FineConfig<T> {
        &self.config
    }
}

/// `a` [rad] wrapped to (-pi, pi].
fn wrap_pi(a: f64) -> f64 {
    let pi = core::f64::consts::PI;
    if a > pi {
        a - 2.0 * pi
    } else if a <= -pi {
        a + 2.0 * pi
    } else {
        a
    }
}

/// The map `A` from a navigation-frame small rotation `rho` [rad] (`C' = exp([rho x]) C`) to the
/// changes of roll, pitch and yaw [rad] of `C = q_b_n` (z-y-x Euler angles):
/// `rho' = R_z(-yaw) rho`, `d_roll = rho'_x / cos(pitch)`, `d_pitch = rho'_y`,
/// `d_yaw = rho'_z + tan(pitch) rho'_x` (Titterton & Weston eq. 3.52 inverted).
pub fn euler_jacobian<T: Scalar>(q_b_n: &UnitQuaternion<T>) -> Matrix3<T> {
    let (_, pitch, yaw) = attitude::euler(q_b_n);
    let (sy, cy) = (yaw.psin(), yaw.pcos());
    let cp = pitch.pcos().max(T::c(1e-6));
    let tp = pitch.psin() / cp;
    let rz = Matrix3::new(
        cy,
        sy,
        T::zero(),
        -sy,
        cy,
        T::zero(),
        T::zero(),
        T::zero(),
        T::one(),
    );
    let b = Matrix3::new(
        T::one() / cp,
        T::zero(),
        T::zero(),
        T::zero(),
        T::one(),
        T::zero(),
        tp,
        T::zero(),
        T::one(),
    );
    b * rz
}

/// 1-sigma roll, pitch, yaw [rad] of an attitude whose navigation-frame error covariance is
/// `p_att` [rad^2] ([`euler_jacobian`]).
pub fn euler_sigma<T: Scalar>(q_b_n: &UnitQuaternion<T>, p_att: &Matrix3<T>) -> Vector3<T> {
    let a = euler_jacobian(q_b_n);
    let s = a * p_att * a.transpose();
    Vector3::new(s[(0, 0)], s[(1, 1)], s[(2, 2)]).map(|v| v.max(T::zero()).sqrt())
}

/// Navigation-frame error covariance [rad^2] of independent roll, pitch and yaw errors of
/// 1-sigma `sigma_rad` at attitude `q_b_n`: `M diag(sigma^2) M^T`, `M` the inverse of
/// [`euler_jacobian`], `M = R_z(yaw) [[cos(pitch), 0, 0], [0, 1, 0], [-sin(pitch), 0, 1]]`.
pub fn phi_covariance<T: Scalar>(q_b_n: &UnitQuaternion<T>, sigma_rad: &Vector3<T>) -> Matrix3<T> {
    let (_, pitch, yaw) = attitude::euler(q_b_n);
    let (sy, cy) = (yaw.psin(), yaw.pcos());
    let (sp, cp) = (pitch.psin(), pitch.pcos());
    let rz = Matrix3::new(
        cy,
        -sy,
        T::zero(),
        sy,
        cy,
        T::zero(),
        T::zero(),
        T::zero(),
        T::one(),
    );
    let b_inv = Matrix3::new(
        cp,
        T::zero(),
        T::zero(),
        T::zero(),
        T::one(),
        T::zero(),
        -sp,
        T::zero(),
        T::one(),
    );
    let m = rz * b_inv;
    let d = Matrix3::from_diagonal(&sigma_rad.component_mul(sigma_rad));
    m * d * m.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_euler;

    #[test]
    fn euler_jacobian_matches_finite_differences() {
        let q = from_euler(0.07, -0.05, 1.05_f64);
        let a = euler_jacobian(&q);
        let (r0, p0, y0) = attitude::euler(&q);
        for k in 0..3 {
            let mut rho = Vector3::zeros();
            rho[k] = 1e-7;
            let (r, p, y) = attitude::euler(&(attitude::rotation_vector_quat(&rho) * q));
            let d = Vector3::new(r - r0, p - p0, y - y0) / 1e-7;
            assert!((d - a.column(k)).norm() < 1e-6, "{k}: {d} {}", a.column(k));
        }
        // phi_covariance is the inverse map: A M = I.
        let p = phi_covariance(&q, &Vector3::new(1.0, 2.0, 3.0));
        let s = euler_sigma(&q, &p);
        assert!((s - Vector3::new(1.0, 2.0, 3.0)).norm() < 1e-12, "{s}");
    }
}
