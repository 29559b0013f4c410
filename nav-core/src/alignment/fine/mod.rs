//! Position-aided closed-loop fine alignment [Vavilova et al., §3]: an error-state Kalman
//! filter around a strapdown integrated at the site, that needs no initial heading and models
//! what a swaying base does to the IMU's position.
//!
//! **Design.**
//! - Mechanization: [`integrator::SiteStrapdown`], every increment (400 Hz), in a level frame
//!   `c` of unknown azimuth: started from the coarse stage's roll and pitch with any heading,
//!   the heading error is a constant rotation of `c` about down, seen only as the horizontal
//!   Earth rate in `c`, which the filter estimates (two states, [`model`]). So the filter is
//!   linear for any heading error; the heading is `atan2(-e_E, e_N)` of that rate at the end,
//!   its 1-sigma the tangential error over `Omega cos(lat)`.
//! - States ([`model`]): displacement, velocity and attitude errors, the horizontal Earth rate,
//!   gyro and accelerometer biases (body axes), the lever-arm error (body axes: known to
//!   [`LEVER_ARM_KNOWN_SIGMA_M`], or unknown with a prior), and the translation of the base's
//!   centre as a shaping process with no power at zero frequency ([`base`]): 29 states.
//! - Measurement, every filter interval ([`FineConfig::update_period_s`], 0.1 s): the IMU's
//!   displacement from the centre's mean position minus its lever-arm offset, three scalar
//!   Joseph updates (noise [`FineConfig::position_noise_m`]). With the lever arm unknown the
//!   same measurement estimates it from the sway (`C_b_c l` turns with the body): the
//!   measurement never needs the IMU's velocity.
//! - Process model: [`model`] over the interval, `Phi = I + F dt + (F dt)^2/2 + (F dt)^3/6` for
//!   the INS part (linearised about the interval's mean specific force and attitude), the
//!   translation block exactly ([`base::ShapingBlock::discrete`]); `Q_d` by the trapezoid rule
//!   [Groves, eq. 3.46] from the noise densities.
//! - Closed loop [Vavilova et al., §3]: after every update the INS error estimates go into
//!   the integrator ([`integrator::SiteStrapdown::correct`]), the lever arm into its estimate,
//!   and those states are zeroed; the translation states are the process itself and stay.
//!
//! **Honesty.** The result is refused ([`FineRefusal`]) when the heading's 1-sigma exceeds
//! [`FineConfig::max_heading_sigma_rad`] (the Earth rate not resolved: coarse gyros, too short,
//! too near a pole), when the estimated horizontal Earth rate's magnitude disagrees with
//! `Omega cos(lat)` (the gyros see something
//! else: a bias beyond the prior, a turning base), or when the position innovations' mean
//! normalised square exceeds [`MAX_MEAN_NIS`] (the base moves in a way the model does not
//! describe).
//!
//! Memory: about 10 KB in `f32` (the 29x29 covariance and the interval's transition); no
//! allocation. No input panics: increments that fail [`ImuIncrement::check`] are refused and
//! counted; a covariance that became non-finite stops the filter, whose result is then refused.

pub mod bank;
pub mod base;
pub mod blank;
pub mod euler;
pub mod integrator;
pub mod kalman;
pub mod model;

pub use blank::Blank;
pub use euler::{euler_jacobian, euler_sigma, phi_covariance};

use super::machine::LeverArm;
use super::{AttitudeEstimate, SensorNoise};
use crate::earth::OMEGA_IE;
use crate::{ImuIncrement, InputError, InputLimits, NavState, Position, Scalar, attitude};
use base::{ShapingBlock, Translation};
use integrator::{Correction, SiteStrapdown};
use kalman::{ScalarUpdate, symmetrize, update_scalar};
use model::{
    ACCEL_BIAS, ATT, BASE, EARTH, FINE_STATES, GYRO_BIAS, INS_STATES, LEVER, Linearisation, POS,
    VEL,
};
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector2, Vector3};

/// 1-sigma of a measured lever arm per axis [m] ([`LeverArm::Known`]).
pub const LEVER_ARM_KNOWN_SIGMA_M: f64 = 0.01;

/// Largest mean normalised innovation square of the position measurements accepted (about 1
/// when the model holds).
pub const MAX_MEAN_NIS: f64 = 3.0;

/// The Earth rate's magnitude is enforced once the heading 1-sigma is below this [rad]
/// (5 deg: linearised about a direction that far off, the magnitude is read `1 - cos(5 deg)`
/// = 0.4 % short).
pub const MAGNITUDE_FROM_RAD: f64 = 5.0 * core::f64::consts::PI / 180.0;

/// 1-sigma of the magnitude measurement, relative to `Omega cos(lat)` (0.5 %: the
/// linearisation's error at [`MAGNITUDE_FROM_RAD`]).
pub const MAGNITUDE_SIGMA: f64 = 5e-3;

/// The magnitude measurement's innovation may be this many of its sigma before the result is
/// refused.
pub const EARTH_RATE_SIGMAS: f64 = 4.0;

/// Settings of the filter. `Default` is the FOG IMU of [Vavilova et al., §4] on a base that
/// may sway and heave, the lever arm unknown (5 m per axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FineConfig<T: Scalar> {
    /// The IMU's white noise and bias 1-sigma ([`SensorNoise::seed003`] by default).
    pub noise: SensorNoise<T>,
    /// Gyro bias random walk [rad/s/sqrt(s)] (default 0: constant biases).
    pub gyro_bias_walk: T,
    /// Accelerometer bias random walk [m/s^2/sqrt(s)] (default 0).
    pub accel_bias_walk: T,
    /// Where the IMU sits relative to the centre.
    pub lever_arm: LeverArm<T>,
    /// The centre's translation model ([`base`]).
    pub translation: Translation<T>,
    /// 1-sigma of what the model leaves in the displacement measurement, per axis [m]
    /// (default 0.001).
    pub position_noise_m: T,
    /// Roll and pitch 1-sigma of the starting attitude [rad] (default 2 deg).
    pub tilt_sigma_rad: T,
    /// Filter interval [s] (default 0.1).
    pub update_period_s: T,
    /// Innovation gate [sigma] (default 8: only gross outliers are refused).
    pub gate_sigma: T,
    /// Largest heading 1-sigma answered [rad] (default 10 deg).
    pub max_heading_sigma_rad: T,
    /// Increment limits.
    pub limits: InputLimits<T>,
}

impl<T: Scalar> Default for FineConfig<T> {
    fn default() -> Self {
        let deg = core::f64::consts::PI / 180.0;
        Self {
            noise: SensorNoise::seed003(),
            gyro_bias_walk: T::zero(),
            accel_bias_walk: T::zero(),
            lever_arm: LeverArm::default(),
            translation: Translation::default(),
            position_noise_m: T::c(1e-4),
            tilt_sigma_rad: T::c(2.0 * deg),
            update_period_s: T::c(0.1),
            gate_sigma: T::c(8.0),
            max_heading_sigma_rad: T::c(10.0 * deg),
            limits: InputLimits::default(),
        }
    }
}

impl<T: Scalar> FineConfig<T> {
    /// The configuration with every non-finite or out-of-range value replaced by its default.
    pub fn sanitized(&self) -> Self {
        let d = Self::default();
        let nonneg = |v: T, dv: T| if v.finite() && v >= T::zero() { v } else { dv };
        let pos = |v: T, dv: T| if v.finite() && v > T::zero() { v } else { dv };
        let n = &self.noise;
        let t = &self.translation;
        Self {
            noise: SensorNoise {
                arw_rad_per_sqrt_s: nonneg(n.arw_rad_per_sqrt_s, d.noise.arw_rad_per_sqrt_s),
                vrw_mps_per_sqrt_s: nonneg(n.vrw_mps_per_sqrt_s, d.noise.vrw_mps_per_sqrt_s),
                gyro_bias_rad_s: nonneg(n.gyro_bias_rad_s, d.noise.gyro_bias_rad_s),
                accel_bias_mps2: nonneg(n.accel_bias_mps2, d.noise.accel_bias_mps2),
            },
            gyro_bias_walk: nonneg(self.gyro_bias_walk, d.gyro_bias_walk),
            accel_bias_walk: nonneg(self.accel_bias_walk, d.accel_bias_walk),
            lever_arm: match self.lever_arm {
                LeverArm::Known(r) if r.iter().all(|v| v.finite()) => LeverArm::Known(r),
                LeverArm::Unknown { sigma_m } if sigma_m.finite() && sigma_m >= T::zero() => {
                    LeverArm::Unknown { sigma_m }
                }
                _ => d.lever_arm,
            },
            translation: Translation {
                horizontal_sigma_m: nonneg(t.horizontal_sigma_m, d.translation.horizontal_sigma_m),
                vertical_sigma_m: nonneg(t.vertical_sigma_m, d.translation.vertical_sigma_m),
                omega0_rad_s: pos(t.omega0_rad_s, d.translation.omega0_rad_s),
                damping: pos(t.damping, d.translation.damping),
                corner_rad_s: pos(t.corner_rad_s, d.translation.corner_rad_s),
            },
            position_noise_m: pos(self.position_noise_m, d.position_noise_m),
            tilt_sigma_rad: pos(self.tilt_sigma_rad, d.tilt_sigma_rad),
            update_period_s: pos(self.update_period_s, d.update_period_s).min(T::c(1.0)),
            gate_sigma: pos(self.gate_sigma, d.gate_sigma),
            max_heading_sigma_rad: pos(self.max_heading_sigma_rad, d.max_heading_sigma_rad),
            limits: self.limits,
        }
    }
}

/// Counters of what the filter did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FineStatus {
    /// Increments integrated.
    pub increments: u32,
    /// Increments refused (non-finite, bad interval, out of range).
    pub rejected_increments: u32,
    /// Filter intervals completed.
    pub updates: u32,
    /// Scalar measurements accepted.
    pub accepted_measurements: u32,
    /// Scalar measurements refused by the gate or as degenerate.
    pub rejected_measurements: u32,
    /// Times the covariance became non-finite (the filter then stops: at most 1).
    pub resets: u32,
    /// Mean normalised innovation square of the accepted position measurements (1 when the
    /// model holds; 0 before any).
    pub mean_nis: f64,
}

/// Why the filter gives no answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FineRefusal {
    /// The heading 1-sigma [rad] exceeds [`FineConfig::max_heading_sigma_rad`].
    HeadingUnresolved {
        /// The heading 1-sigma [rad].
        sigma_rad: f64,
    },
    /// The horizontal Earth rate estimated disagrees with `Omega cos(lat)` (module docs): the
    /// gyros see something else.
    EarthRateMismatch {
        /// Estimated magnitude over `Omega cos(lat)` [-].
        ratio: f64,
    },
    /// The position innovations' mean normalised square exceeds [`MAX_MEAN_NIS`].
    MotionNotModelled {
        /// The mean normalised innovation square.
        mean_nis: f64,
    },
    /// The sway model ([`crate::alignment::sway`]) found a yaw sway beyond
    /// [`crate::alignment::sway::MAX_YAW_SWAY_RAD`], outside the envelope where its heading
    /// 1-sigma was found true, after its measurements had started (one beyond it at the
    /// identification switches the model off instead).
    YawSwayBeyondModel {
        /// Amplitude of the yaw sway found [rad].
        amplitude_rad: f64,
    },
    /// No filter interval has completed yet.
    NotStarted,
    /// The covariance became non-finite (inputs at the edge of the limits): the filter
    /// stopped.
    NonFinite,
}

impl core::fmt::Display for FineRefusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::HeadingUnresolved { sigma_rad } => write!(
                f,
                "heading not resolved: 1-sigma {:.1} deg (Earth rate below the gyro noise or bias)",
                sigma_rad.to_degrees()
            ),
            Self::EarthRateMismatch { ratio } => write!(
                f,
                "gyros disagree with the Earth rate ({ratio:.2} of Omega cos(lat)): bias beyond its prior or base turning"
            ),
            Self::MotionNotModelled { mean_nis } => write!(
                f,
                "base motion not modelled: position innovations {mean_nis:.1} times their variance"
            ),
            Self::YawSwayBeyondModel { amplitude_rad } => write!(
                f,
                "yaw sway of {:.2} deg grew beyond the sway model's {:.1} deg after its measurements started (its heading 1-sigma is not true there)",
                amplitude_rad.to_degrees(),
                crate::alignment::sway::MAX_YAW_SWAY_RAD.to_degrees()
            ),
            Self::NotStarted => f.write_str("fine filter has not run yet"),
            Self::NonFinite => f.write_str("fine filter's covariance became non-finite"),
        }
    }
}

/// The filter's result: the navigation state to hand over (NED, at the IMU) with its 1-sigma.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FineOutcome<T: Scalar> {
    /// Attitude, velocity and position of the IMU (NED frame).
    pub state: NavState<T>,
    /// Attitude and its roll, pitch, yaw 1-sigma.
    pub estimate: AttitudeEstimate<T>,
    /// Velocity 1-sigma, north, east, down [m/s].
    pub velocity_sigma_m_s: Vector3<T>,
    /// Position 1-sigma, north, east, down [m] (the given position's own 1-sigma not included).
    pub position_sigma_m: Vector3<T>,
}

/// What a filter variant adds to the general filter: extra states past [`FINE_STATES`], their
/// transition and their measurements (the sway model, [`super::sway`]).
pub trait Extension<T: Scalar, const N: usize> {
    /// Fills the extra states' block of the transition `phi` and of the continuous noise
    /// `q_c` (both in the filter's units) over `dt` [s]; may also propagate `x`'s extra part
    /// nonlinearly (it is then not multiplied by `phi` again: return `true`).
    fn transition(
        &mut self,
        x: &mut SVector<T, N>,
        phi: &mut SMatrix<T, N, N>,
        q_c: &mut SVector<T, N>,
        dt: T,
    ) -> bool;
    /// Applies the extra measurements after the position update.
    fn update(&mut self, core: &mut FineCore<T, N>, elapsed_s: f64);
    /// Sees every accepted increment (raw, before the filter's compensation) and the attitude
    /// `C_b_c` at its start (default: nothing).
    fn increment(&mut self, _inc: &ImuIncrement<T>, _c_b_c: &Matrix3<T>) {}
}

/// The general filter's extension: nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoExtension;

impl<T: Scalar, const N: usize> Extension<T, N> for NoExtension {
    fn transition(
        &mut self,
        _: &mut SVector<T, N>,
        _: &mut SMatrix<T, N, N>,
        _: &mut SVector<T, N>,
        _: T,
    ) -> bool {
        false
    }
    fn update(&mut self, _: &mut FineCore<T, N>, _: f64) {}
}

/// The filter of `N >= FINE_STATES` states (module docs); the extra states belong to an
/// [`Extension`].
#[derive(Clone, Debug)]
pub struct FineCore<T: Scalar, const N: usize> {
    config: FineConfig<T>,
    nav: SiteStrapdown<T>,
    /// The centre's position.
    centre: Position,
    /// `Omega cos(lat)` [rad/s].
    w_h: T,
    /// Lever-arm estimate, body axes [m].
    lever_b: Vector3<T>,
    /// `C_b_c` at the start: the displacement state is `s = dr - C0 dl` ([`model`]).
    c0: Matrix3<T>,
    /// The translation blocks of the north, east, down axes.
    blocks: [ShapingBlock<T>; 3],
    /// State (filter units, [`model::UNITS`]) and covariance.
    x: SVector<T, N>,
    p: SMatrix<T, N, N>,
    /// Set once the covariance became non-finite: the filter stops and refuses.
    broken: bool,
    q_ins: SVector<T, INS_STATES>,
    /// Interval sums: time [s], `sum C_b_c dt` [s], `sum dv_c` [m/s].
    interval_s: f64,
    sum_c: Matrix3<T>,
    sum_dv_c: Vector3<T>,
    elapsed_s: f64,
    nis_sum: f64,
    nis_n: u32,
    /// `sum -(ln S + nu^2 / S) / 2` over the accepted position updates.
    log_likelihood: f64,
    /// The magnitude measurement's normalised innovation, once applied.
    magnitude_z: Option<f64>,
    status: FineStatus,
}

/// The general position-aided filter.
pub type FineAlignment<T> = FineCore<T, FINE_STATES>;

impl<T: Scalar, const N: usize> FineCore<T, N> {
    /// Starts at the centre `position` (the base in place) from the attitude `q_b_c` (roll and
    /// pitch from the coarse stage, any heading: it defines `c`) with the body rate relative
    /// to the Earth `omega_eb_b` [rad/s] at that instant (for the lever arm's velocity).
    pub fn new(
        q_b_c: UnitQuaternion<T>,
        omega_eb_b: Vector3<T>,
        position: Position,
        config: FineConfig<T>,
    ) -> Self {
        let mut filter = Self::BLANK;
        filter.init_in(q_b_c, omega_eb_b, position, config);
        filter
    }

    /// (Re)starts the filter in place as [`Self::new`] does, through `&mut` only: the
    /// covariance is filled where it lives, so no filter-sized temporary is built (an MCU
    /// task's stack is a few tens of KB; the sway bank is some 30 KB in `f32`).
    pub fn init_in(
        &mut self,
        q_b_c: UnitQuaternion<T>,
        omega_eb_b: Vector3<T>,
        position: Position,
        config: FineConfig<T>,
    ) {
        let config = config.sanitized();
        let q_b_c = if q_b_c.coords.iter().all(|v| v.finite()) {
            q_b_c
        } else {
            UnitQuaternion::identity()
        };
        let omega_eb_b = if omega_eb_b.iter().all(|v| v.finite()) {
            omega_eb_b
        } else {
            Vector3::zeros()
        };
        let centre = position.to_ned_frame();
        let lat = centre.lat_f64();
        let h = centre.h_f64();
        let w_h = T::c(OMEGA_IE * libm::cos(lat));
        let (lever_b, lever_sigma) = match config.lever_arm {
            LeverArm::Known(r) => (r, T::c(LEVER_ARM_KNOWN_SIGMA_M)),
            LeverArm::Unknown { sigma_m } => (Vector3::zeros(), sigma_m),
        };
        let c0 = q_b_c.to_rotation_matrix().into_inner();
        let r0 = c0 * lever_b;
        let v0 = c0 * omega_eb_b.cross(&lever_b);
        let nav = SiteStrapdown::new(T::c(lat), T::c(h), q_b_c, v0, r0, [T::zero(); 2]);
        let t = &config.translation;
        let blocks = [
            ShapingBlock::new(t, t.horizontal_sigma_m),
            ShapingBlock::new(t, t.horizontal_sigma_m),
            ShapingBlock::new(t, t.vertical_sigma_m),
        ];
        let var = |s: T| s * s;
        let p0 = &mut self.p;
        p0.fill(T::zero());
        let sd = t.horizontal_sigma_m.max(t.vertical_sigma_m);
        let w_rate = omega_eb_b.norm();
        let tilt = config.tilt_sigma_rad;
        for i in 0..3 {
            let base_p = blocks[i].stationary();
            // s(0) = dr(0) - C0 dl = (C_hat0 - C0) l_hat - d(0): the tilt turning the lever arm
            // estimate, and the centre's translation (no lever-arm term).
            p0[(POS + i, POS + i)] = var(sd) + var(tilt * lever_b.norm()) + var(T::c(0.01));
            p0[(VEL + i, VEL + i)] =
                base_p[(base::D_RATE, base::D_RATE)] + var(w_rate * lever_sigma) + var(T::c(0.02));
            p0[(GYRO_BIAS + i, GYRO_BIAS + i)] = var(config.noise.gyro_bias_rad_s);
            p0[(ACCEL_BIAS + i, ACCEL_BIAS + i)] = var(config.noise.accel_bias_mps2);
            p0[(LEVER + i, LEVER + i)] = var(lever_sigma);
            for a in 0..3 {
                for b in 0..3 {
                    p0[(BASE + 3 * i + a, BASE + 3 * i + b)] = base_p[(a, b)];
                }
            }
        }
        p0[(ATT, ATT)] = var(tilt);
        p0[(ATT + 1, ATT + 1)] = var(tilt);
        // `c` is defined by the starting heading: no azimuth error about it at the start.
        p0[(ATT + 2, ATT + 2)] = var(T::c(1e-6));
        // The horizontal Earth rate in `c`: any direction, magnitude W (mean 0, isotropic).
        p0[(EARTH, EARTH)] = w_h * w_h * T::c(0.5);
        p0[(EARTH + 1, EARTH + 1)] = w_h * w_h * T::c(0.5);
        scale_cov(p0);
        let n = &config.noise;
        let q_ins = model::ins_noise(
            n.arw_rad_per_sqrt_s,
            n.vrw_mps_per_sqrt_s,
            config.gyro_bias_walk,
            config.accel_bias_walk,
        );
        // Every field by name (a field added later must be started here too: the pattern
        // does not compile without it); the covariance is already in place.
        let Self {
            config: config_in,
            nav: nav_in,
            centre: centre_in,
            w_h: w_h_in,
            lever_b: lever_b_in,
            c0: c0_in,
            blocks: blocks_in,
            x,
            p: _,
            broken,
            q_ins: q_ins_in,
            interval_s,
            sum_c,
            sum_dv_c,
            elapsed_s,
            nis_sum,
            nis_n,
            log_likelihood,
            magnitude_z,
            status,
        } = self;
        *config_in = config;
        *nav_in = nav;
        *centre_in = centre;
        *w_h_in = w_h;
        *lever_b_in = lever_b;
        *c0_in = c0;
        *blocks_in = blocks;
        x.fill(T::zero());
        *broken = false;
        *q_ins_in = q_ins;
        *interval_s = 0.0;
        *sum_c = Matrix3::zeros();
        *sum_dv_c = Vector3::zeros();
        *elapsed_s = 0.0;
        *nis_sum = 0.0;
        *nis_n = 0;
        *log_likelihood = 0.0;
        *magnitude_z = None;
        *status = FineStatus::default();
    }

    /// Adds one increment: integrates it and at the end of every filter interval propagates,
    /// updates and feeds back (with `ext`'s states and measurements). A refused increment
    /// changes nothing but the counters (and restarts the two-sample terms).
    pub fn add_with(
        &mut self,
        inc: &ImuIncrement<T>,
        ext: &mut impl Extension<T, N>,
    ) -> Result<(), InputError> {
        if self.broken {
            return Ok(());
        }
        if let Err(e) = inc.check(&self.config.limits) {
            self.status.rejected_increments = self.status.rejected_increments.saturating_add(1);
            self.nav.restart_increments();
            return Err(e);
        }
        let sums = self.nav.step(inc);
        ext.increment(inc, &sums.c_b_c);
        let dt = inc.dt;
        self.sum_c += sums.c_b_c * dt;
        self.sum_dv_c += sums.dv_c;
        self.interval_s += dt.to_f64();
        self.elapsed_s += dt.to_f64();
        self.status.increments = self.status.increments.saturating_add(1);
        // At the sample boundary nearest the period (f32 and f64 filters update on the same
        // samples).
        if self.interval_s + 0.5 * dt.to_f64() >= self.config.update_period_s.to_f64() {
            self.filter_step(ext);
        }
        Ok(())
    }

    /// A gap in the data (the two-sample terms must not span it).
    pub fn restart_increments(&mut self) {
        self.nav.restart_increments();
    }

    fn filter_step(&mut self, ext: &mut impl Extension<T, N>) {
        let dt = T::c(self.interval_s);
        let lin = Linearisation {
            omega_ie_c: self.nav.omega_ie_c(),
            f_c: self.sum_dv_c / dt,
            c_b_c: self.sum_c / dt,
            dg_dd: T::c(2.0) * self.nav.gravity() / T::c(6.371e6),
        };
        self.interval_s = 0.0;
        self.sum_c = Matrix3::zeros();
        self.sum_dv_c = Vector3::zeros();

        // Transition and noise, in the filter's units.
        let mut phi = SMatrix::<T, N, N>::identity();
        let phi_ins = model::ins_transition(&lin, dt);
        for i in 0..INS_STATES {
            for j in 0..INS_STATES {
                phi[(i, j)] = phi_ins[(i, j)] * T::c(model::unit(j) / model::unit(i));
            }
        }
        let mut q_d = SMatrix::<T, N, N>::zeros();
        for k in 0..3 {
            let (phi_b, q_b) = self.blocks[k].discrete(dt);
            for a in 0..3 {
                for b in 0..3 {
                    let (i, j) = (BASE + 3 * k + a, BASE + 3 * k + b);
                    phi[(i, j)] = phi_b[(a, b)] * T::c(model::unit(j) / model::unit(i));
                    q_d[(i, j)] = q_b[(a, b)] * T::c(1.0 / (model::unit(i) * model::unit(j)));
                }
            }
        }
        let mut q_c = SVector::<T, N>::zeros();
        for i in 0..INS_STATES {
            q_c[i] = self.q_ins[i] * T::c(1.0 / (model::unit(i) * model::unit(i)));
        }
        let ext_propagated = ext.transition(&mut self.x, &mut phi, &mut q_c, dt);
        // The parts driven by white noise (INS and extension); the translation block's exact
        // Q_d is already in.
        q_d += kalman::discrete_noise(&phi, &q_c, dt);
        let propagated = phi * self.x;
        for i in 0..N {
            if !(ext_propagated && i >= FINE_STATES) {
                self.x[i] = propagated[i];
            }
        }
        self.p = phi * self.p * phi.transpose() + q_d;
        symmetrize(&mut self.p);

        self.update_position();
        ext.update(self, self.elapsed_s);
        self.constrain_earth_rate();
        self.status.updates = self.status.updates.saturating_add(1);
        if !(kalman::all_finite(&self.p) && kalman::all_finite(&self.x)) {
            // Cannot happen with finite inputs; the filter stops and its result is refused
            // rather than restarted as if nothing had happened.
            self.broken = true;
            self.status.resets = self.status.resets.saturating_add(1);
            return;
        }
        self.feed_back();
    }

    /// The displacement measurement (module docs, [`model`]), one scalar update per axis.
    fn update_position(&mut self) {
        let c = self.nav.c_b_c();
        let offset = c * self.lever_b;
        let z = self.nav.r_c() - offset;
        let h_att = -offset.cross_matrix();
        // The model is linear in phi and dl; their product `phi x (C dl)` is not, and while
        // both are large (an unknown lever arm, the first seconds' tilt) it exceeds the
        // measurement noise: its variance, `tr(P_phi) tr(P_dl)` at most, is added to it.
        let tr = |o: usize| {
            (0..3)
                .map(|i| self.cov_si(o + i, o + i))
                .fold(T::zero(), |a, b| a + b)
        };
        let r = self.config.position_noise_m * self.config.position_noise_m + tr(ATT) * tr(LEVER);
        for k in 0..3 {
            let mut h = SVector::<T, N>::zeros();
            h[POS + k] = T::one();
            h[BASE + 3 * k + base::D] = T::one();
            for j in 0..3 {
                h[ATT + j] = h_att[(k, j)];
                h[LEVER + j] = self.c0[(k, j)] - c[(k, j)];
            }
            for i in 0..N {
                h[i] *= T::c(model::unit(i));
            }
            let innovation = z[k] - h.dot(&self.x);
            let s = h.dot(&(self.p * h)) + r;
            let nis = (innovation * innovation / s).to_f64();
            let result = update_scalar(
                &mut self.x,
                &mut self.p,
                &h,
                innovation,
                r,
                self.config.gate_sigma,
            );
            if matches!(result, ScalarUpdate::Accepted) {
                self.status.accepted_measurements =
                    self.status.accepted_measurements.saturating_add(1);
                self.nis_sum += nis;
                self.nis_n += 1;
            } else {
                self.status.rejected_measurements =
                    self.status.rejected_measurements.saturating_add(1);
            }
            // A gated innovation is not applied but is still evidence against the model: a
            // filter whose model does not hold (a still model on a translating base) gates
            // what it cannot explain and would otherwise win the bank on what it keeps
            // ([`bank`]; on the alignment family: 13 % gated, its lever arm 50 of its sigma
            // off).
            if !matches!(result, ScalarUpdate::Degenerate) {
                self.log_likelihood -= 0.5 * (libm::log(s.to_f64()) + nis);
            }
        }
        self.status.mean_nis = self.nis_sum / f64::from(self.nis_n.max(1));
    }

    /// The horizontal Earth rate's magnitude is `W = Omega cos(lat)`, exactly: once its
    /// direction is resolved (heading 1-sigma below [`MAGNITUDE_FROM_RAD`]) that is one
    /// measurement, `W = |e| = |e_hat| - u . de` (`u = e_hat / |e_hat|`), noise
    /// [`MAGNITUDE_SIGMA`] of `W`, applied once: it removes the radial component from the
    /// state's uncertainty (the states have no process noise, so it stays removed), and
    /// repeating it along a slowly turning `u` would pin the tangential one too. Without it the
    /// zero-mean prior of the two states shrinks the estimate towards zero by each direction's
    /// information ratio, which turns into a heading error wherever the information is not the
    /// same in every direction (the sway model's roll and pitch measurements). Its normalised
    /// innovation is kept: gyros that disagree with `W` beyond [`EARTH_RATE_SIGMAS`] (a bias
    /// beyond its prior, a turning base) are refused ([`FineRefusal::EarthRateMismatch`]).
    fn constrain_earth_rate(&mut self) {
        if self.magnitude_z.is_some() {
            return;
        }
        let [e_n, e_e] = self.nav.e_h();
        let de = Vector2::new(self.state_si(EARTH), self.state_si(EARTH + 1));
        let e = Vector2::new(e_n, e_e) - de;
        let mag = e.norm();
        if !(mag > T::zero() && mag.finite()) {
            return;
        }
        let u = e / mag;
        let tangent = Vector2::new(u.y, -u.x);
        let p_e = SMatrix::<T, 2, 2>::from_fn(|i, j| self.cov_si(EARTH + i, EARTH + j));
        let var_alpha = (tangent.transpose() * p_e * tangent)[0] / (self.w_h * self.w_h);
        if !(var_alpha.to_f64() < MAGNITUDE_FROM_RAD * MAGNITUDE_FROM_RAD) {
            return;
        }
        let mut h = SVector::<T, N>::zeros();
        h[EARTH] = -u.x;
        h[EARTH + 1] = -u.y;
        let r = T::c(MAGNITUDE_SIGMA * MAGNITUDE_SIGMA) * self.w_h * self.w_h;
        // W = |e_hat - de| against -u . de, linearised at the current estimate.
        let innovation = self.w_h - mag;
        let s = self.innovation_variance(&h, r);
        self.magnitude_z = Some((innovation / s.sqrt()).to_f64());
        self.update(&h, innovation, r, T::c(1e6));
    }

    /// A scalar measurement `z = h^T x + v`, `v ~ N(0, r)`, `h` in SI per state (scaled here),
    /// `innovation = z - h^T x` formed by the caller with [`Self::predict`]; for extensions.
    pub fn update(&mut self, h_si: &SVector<T, N>, innovation: T, r: T, gate: T) -> ScalarUpdate {
        let mut h = *h_si;
        for i in 0..N {
            h[i] *= T::c(model::unit(i));
        }
        update_scalar(&mut self.x, &mut self.p, &h, innovation, r, gate)
    }

    /// `h^T x` for `h` in SI per state.
    pub fn predict(&self, h_si: &SVector<T, N>) -> T {
        let mut s = T::zero();
        for i in 0..N {
            s += h_si[i] * self.x[i] * T::c(model::unit(i));
        }
        s
    }

    /// `h^T P h + r` for `h` in SI per state.
    pub fn innovation_variance(&self, h_si: &SVector<T, N>, r: T) -> T {
        let mut h = *h_si;
        for i in 0..N {
            h[i] *= T::c(model::unit(i));
        }
        h.dot(&(self.p * h)) + r
    }

    /// State `i` in SI.
    pub fn state_si(&self, i: usize) -> T {
        self.x[i] * T::c(model::unit(i))
    }

    /// Sets state `i` [SI].
    pub fn set_state_si(&mut self, i: usize, v: T) {
        self.x[i] = v / T::c(model::unit(i));
    }

    /// Covariance entry `(i, j)` in SI.
    pub fn cov_si(&self, i: usize, j: usize) -> T {
        self.p[(i, j)] * T::c(model::unit(i) * model::unit(j))
    }

    /// Adds `v` [SI] to the variance of state `i` (an extension's re-lock).
    pub fn inflate_si(&mut self, i: usize, v: T) {
        self.p[(i, i)] += v / T::c(model::unit(i) * model::unit(i));
    }

    /// Initialises an extension's states `offset..offset + k` [SI] with covariance `p`
    /// (uncorrelated with the rest).
    pub fn init_states_si<const K: usize>(
        &mut self,
        offset: usize,
        x: &SVector<T, K>,
        p: &SMatrix<T, K, K>,
    ) {
        for i in 0..N {
            for k in 0..K {
                self.p[(i, offset + k)] = T::zero();
                self.p[(offset + k, i)] = T::zero();
            }
        }
        for a in 0..K {
            self.x[offset + a] = x[a] / T::c(model::unit(offset + a));
            for b in 0..K {
                self.p[(offset + a, offset + b)] =
                    p[(a, b)] / T::c(model::unit(offset + a) * model::unit(offset + b));
            }
        }
    }

    /// Feeds the INS error estimates back (closed loop) and zeroes them.
    fn feed_back(&mut self) {
        let v3 =
            |o: usize| Vector3::new(self.state_si(o), self.state_si(o + 1), self.state_si(o + 2));
        let dl = v3(LEVER);
        let phi = v3(ATT);
        // The displacement error is `s + C0 dl`, plus the second-order term the attitude
        // correction turns the lever-arm correction by (`phi x C dl`): fed back too, the
        // measured `r - C l_hat` is the same before and after (module docs of [`model`]).
        let c_dl = self.nav.c_b_c() * dl;
        let c = Correction {
            dr: v3(POS) + self.c0 * dl + phi.cross(&c_dl),
            dv: v3(VEL),
            phi,
            de: [self.state_si(EARTH), self.state_si(EARTH + 1)],
            gyro_bias: v3(GYRO_BIAS),
            accel_bias: v3(ACCEL_BIAS),
        };
        self.nav.correct(&c);
        // `C0` turns with every attitude correction: the lever arm's Jacobian `C0 - C` then
        // holds the body's own rotation since the start, not the filter's corrections (a
        // tilt correction is no motion of the IMU: read as one, it pins the lever arm of a
        // still base that no data can give).
        self.c0 = attitude::rotation_vector_quat(&phi)
            .to_rotation_matrix()
            .into_inner()
            * self.c0;
        self.lever_b -= dl;
        for i in 0..INS_STATES {
            self.x[i] = T::zero();
        }
    }

    /// The integrator (attitude in `c`, velocity, displacement, the Earth rate in use).
    pub fn strapdown(&self) -> &SiteStrapdown<T> {
        &self.nav
    }

    /// The heading of `c` [rad]: `alpha = atan2(-e_E, e_N)` of the estimated horizontal Earth
    /// rate (`c` is NED turned by `alpha` about down).
    pub fn frame_azimuth(&self) -> T {
        let [e_n, e_e] = self.nav.e_h();
        (-e_e).patan2(e_n)
    }

    /// `d alpha / d(e_N, e_E)` [s]: `(e_E, -e_N) / W^2`, with the known magnitude
    /// `W = Omega cos(lat)` (the estimate's own magnitude is shrunk towards 0 by the prior).
    fn azimuth_gradient(&self) -> Vector2<T> {
        let [e_n, e_e] = self.nav.e_h();
        let n = (e_n * e_n + e_e * e_e).sqrt().max(T::c(1e-30));
        let w = self.w_h;
        Vector2::new(e_e / n, -e_n / n) / w
    }

    /// The covariance [SI] of `(dr, dv, phi, de)` (11 states).
    fn ins_cov(&self) -> SMatrix<T, 11, 11> {
        SMatrix::<T, 11, 11>::from_fn(|i, j| self.cov_si(i, j))
    }

    /// The attitude (body to NED) with its roll, pitch, yaw 1-sigma.
    pub fn estimate(&self) -> AttitudeEstimate<T> {
        let alpha = self.frame_azimuth();
        let r = attitude::about_z(alpha);
        let q_b_n = r * self.nav.q_b_c();
        let j = self.attitude_jacobian();
        let p = self.ins_cov();
        let p_att = j * p * j.transpose();
        AttitudeEstimate {
            q_b_n,
            sigma_rad: euler_sigma(&q_b_n, &p_att),
            elapsed_s: T::c(self.elapsed_s),
        }
    }

    /// NED attitude error `Phi = R_z(alpha) phi - e_D d_alpha` as a function of
    /// `(dr, dv, phi, de)`: `C_hat_b_n = exp(-[Phi x]) C_b_n`.
    fn attitude_jacobian(&self) -> SMatrix<T, 3, 11> {
        let r = attitude::about_z(self.frame_azimuth())
            .to_rotation_matrix()
            .into_inner();
        let g = self.azimuth_gradient();
        let mut j = SMatrix::<T, 3, 11>::zeros();
        j.fixed_view_mut::<3, 3>(0, ATT).copy_from(&r);
        j[(2, EARTH)] = -g.x;
        j[(2, EARTH + 1)] = -g.y;
        j
    }

    /// The result, or why there is none (module docs, **Honesty**).
    pub fn outcome(&self) -> Result<FineOutcome<T>, FineRefusal> {
        let solution = self.solution()?;
        let p = self.ins_cov();
        // Heading: the tangential error of the horizontal Earth rate.
        let g = self.azimuth_gradient();
        let p_e = p.fixed_view::<2, 2>(EARTH, EARTH).into_owned();
        let var_alpha = (g.transpose() * p_e * g)[0];
        let sigma_alpha = var_alpha.max(T::zero()).sqrt().to_f64();
        if !(sigma_alpha <= self.config.max_heading_sigma_rad.to_f64()) {
            return Err(FineRefusal::HeadingUnresolved {
                sigma_rad: sigma_alpha,
            });
        }
        let [e_n, e_e] = self.nav.e_h();
        let ratio = ((e_n * e_n + e_e * e_e).sqrt() / self.w_h).to_f64();
        if self
            .magnitude_z
            .is_some_and(|z| !(z.abs() <= EARTH_RATE_SIGMAS))
        {
            return Err(FineRefusal::EarthRateMismatch { ratio });
        }
        if self.status.mean_nis > MAX_MEAN_NIS {
            return Err(FineRefusal::MotionNotModelled {
                mean_nis: self.status.mean_nis,
            });
        }
        Ok(solution)
    }

    /// The state and 1-sigma the filter holds now, without [`Self::outcome`]'s checks (a
    /// comparison with another filter's); refused only before the first interval or once
    /// broken.
    pub fn solution(&self) -> Result<FineOutcome<T>, FineRefusal> {
        if self.status.updates == 0 {
            return Err(FineRefusal::NotStarted);
        }
        if self.broken {
            return Err(FineRefusal::NonFinite);
        }
        let g = self.azimuth_gradient();
        let estimate = self.estimate();
        let alpha = self.frame_azimuth();
        let rz = attitude::about_z(alpha).to_rotation_matrix().into_inner();
        let v_n = rz * self.nav.v_c();
        let r_n = rz * self.nav.r_c();
        // Velocity and displacement in NED: R dv + d_alpha (e_D x value); the displacement's
        // error is `s + C0 dl`.
        let down = Vector3::new(T::zero(), T::zero(), T::one());
        let sigma_of = |blocks: &[(usize, Matrix3<T>)], value: &Vector3<T>| {
            let mut j = SMatrix::<T, 3, N>::zeros();
            for (offset, m) in blocks {
                j.fixed_view_mut::<3, 3>(0, *offset).copy_from(m);
            }
            let turn = down.cross(value);
            for k in 0..3 {
                j[(k, EARTH)] = turn[k] * g.x;
                j[(k, EARTH + 1)] = turn[k] * g.y;
            }
            Vector3::from_fn(|k, _| {
                let mut v = T::zero();
                for a in 0..N {
                    for b in 0..N {
                        if j[(k, a)] != T::zero() && j[(k, b)] != T::zero() {
                            v += j[(k, a)] * self.cov_si(a, b) * j[(k, b)];
                        }
                    }
                }
                v.max(T::zero()).sqrt()
            })
        };
        let velocity_sigma_m_s = sigma_of(&[(VEL, rz)], &v_n);
        let position_sigma_m = sigma_of(&[(POS, rz), (LEVER, rz * self.c0)], &r_n);
        let position = self.centre.offset_ned(r_n.map(T::to_f64).into());
        Ok(FineOutcome {
            state: NavState {
                q_b_n: estimate.q_b_n,
                v_eb_n: v_n,
                position,
            },
            estimate,
            velocity_sigma_m_s,
            position_sigma_m,
        })
    }

    /// Gyro bias estimate (body axes) [rad/s] and its 1-sigma.
    pub fn gyro_bias(&self) -> (Vector3<T>, Vector3<T>) {
        (self.nav.biases().0, self.sigmas(GYRO_BIAS))
    }

    /// Accelerometer bias estimate (body axes) [m/s^2] and its 1-sigma.
    pub fn accel_bias(&self) -> (Vector3<T>, Vector3<T>) {
        (self.nav.biases().1, self.sigmas(ACCEL_BIAS))
    }

    /// Lever-arm estimate (body axes) [m] and its 1-sigma.
    pub fn lever_arm(&self) -> (Vector3<T>, Vector3<T>) {
        (self.lever_b, self.sigmas(LEVER))
    }

    /// The centre's translation estimate (`d` per axis of `c`) [m].
    pub fn translation(&self) -> Vector3<T> {
        Vector3::from_fn(|k, _| self.state_si(BASE + 3 * k + base::D))
    }

    fn sigmas(&self, offset: usize) -> Vector3<T> {
        Vector3::from_fn(|i, _| self.cov_si(offset + i, offset + i).max(T::zero()).sqrt())
    }

    /// Counters.
    pub fn status(&self) -> FineStatus {
        self.status
    }

    /// The configuration in use (sanitised).
    pub fn config(&self) -> &FineConfig<T> {
        &self.config
    }

    /// Time integrated [s].
    pub fn elapsed_s(&self) -> f64 {
        self.elapsed_s
    }

    /// Log likelihood of the position innovations so far, gated ones included,
    /// `sum -(ln S + nu^2 / S) / 2` (the constant `ln 2 pi` left out): how well this model
    /// explains the data.
    pub fn log_likelihood(&self) -> f64 {
        self.log_likelihood
    }
}

impl<T: Scalar> FineCore<T, FINE_STATES> {
    /// Adds one increment (the general filter: [`Self::add_with`] without extension).
    pub fn add(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        self.add_with(inc, &mut NoExtension)
    }
}

/// `P_SI` -> the filter's units, in place.
fn scale_cov<T: Scalar, const N: usize>(p: &mut SMatrix<T, N, N>) {
    for j in 0..N {
        for i in 0..N {
            p[(i, j)] *= T::c(1.0 / (model::unit(i) * model::unit(j)));
        }
    }
}
