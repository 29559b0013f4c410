//! Inertial-frame coarse alignment: gravity observed in a frame frozen in inertial space, on a
//! rocking or disturbed base, with no initial heading [Gu et al., 2008; Silson, 2011].
//!
//! # Frames
//! - `b0`: the body frame at the first sample, frozen in inertial space.
//! - `i0`: the NED frame at the first sample, frozen in inertial space.
//!
//! `C_b_n(t) = C_i0_n(t) C_b0_i0 C_b_b0(t)` (eq. 1): `C_b_b0(t)` comes from the gyros, `C_i0_n(t)`
//! from the Earth's rotation since the start, and only the constant `C_b0_i0` is unknown.
//!
//! # Equations
//! - Attitude (eq. 2): `q_b_b0 <- q_b_b0 (x) q(phi_k)`, `phi_k` the rotation vector with the
//!   two-sample coning term ([`crate::coning`]), summed with a compensated (two-sum) carry so
//!   that the 1.8e-7 rad Earth-rate increments of a 400 Hz `f32` run are kept.
//! - Specific force in `b0` (eq. 3): `dV_b0,k = C_b_b0(t_{k-1}) (dv_k + rotation + sculling)`
//!   [Savage, 7.2.2.2-11, 7.2.2.2-22].
//! - Two weighted observation vectors over the window `[0, T]` (eq. 4):
//!   `V_w = int w0(t) f_b0 dt` (the mean vertical) and `M_w = int w1(t) f_b0 dt` (its slope:
//!   gravity turns with the Earth, east at `g Omega cos(L) t` in `i0`), `w0 = e(t)`,
//!   `w1 = (t - T/2) e(t)`, with the envelope `e` rising from 0 to 1 over a ramp of
//!   [`RAMP_FRACTION`] of the window (at most [`RAMP_MAX_S`]) by the smooth step of order 4 (its first four derivatives
//!   zero at both ends of the ramp) and falling likewise at the end. The same sums of the
//!   reference specific force at rest, `f_i0(t) = R(u_pole, Omega t) (0, 0, -g)`, give
//!   `V_w,i0` and `M_w,i0` (eq. 5).
//! - `C_b0_i0` by TRIAD (eq. 6) [Shuster & Oh, 1981]: `a1 = V/|V|`, `a2 = (V x M)/|V x M|`,
//!   `a3 = a1 x a2`, `C_b0_i0 = [a1 a2 a3]_i0 [a1 a2 a3]_b0^T`: the level from `V`, the heading
//!   from the part of `M` normal to it.
//!
//! # Why the taper
//! A disturbance acceleration `a_d` of the IMU (waves, an unknown lever arm, people on the base)
//! enters `M_w` as `int w1 a_d dt`; since `w1`, `w1'` and `w1''` vanish at both ends, two
//! integrations by parts leave `int w1'' r_d dt`, `r_d` the displacement, and `w1''` lives on
//! the ramps only: a motion bounded in position leaks as much as the ramps' spectrum has at its
//! frequency, and a constant drift velocity not at all. The ramps' derivative is a bump about a
//! sixth of the ramp wide, whose spectrum falls like `exp(-(w tau / 6)^2 / 2)` only once
//! `w tau > 6`: with `tau = T/4`, 0.4 m of surge at 16 s leaks 0.8 rad of heading at 60 s
//! (which the check below refuses) and 2e-4 rad at 120 s, a twentieth of the FOG's 1-sigma
//! there; ramps of 30 s keep that rejection at any longer window. Without the
//! taper (`w1 = 2t - T`, the least-squares slope) the leak is
//! `T (v_d(0) + v_d(T)) - 2 (r_d(T) - r_d(0))`: the velocities at the two ends, tens of degrees
//! of heading for a lever arm of a few metres at 2 min. The cost of the taper is efficiency:
//! the heading 1-sigma is 1.38, 1.36, 1.32 and 1.15 times the Cramér–Rao floor at 30, 60, 120
//! and 300 s for the FOG (`tests/alignment_inertial.rs`).
//!
//! # Known lever arm
//! The IMU's offset `l` (body axes) from a centre of rotation at rest at the known position
//! moves it by `r_l(t) = C_b_b0(t) l` relative to the centre, so its acceleration's share is
//! (eq. 7) `int w a_l dt = int w'' C_b_b0 l dt` (two integrations by parts, `w`, `w'` zero at
//! the ends): the sums `G = int w'' C_b_b0 dt` are kept and `G l` is taken off `V_w`, `M_w`.
//! No body rate is needed, so no rate noise enters.
//!
//! # Unknown lever arm
//! With the offset `l` unknown (1-sigma `s` per axis, [`InertialAlignment::with_lever_arm_unknown`])
//! the sums `G` are kept all the same and the leak `G l` is a random vector of covariance
//! `s^2 G G^T`: its heading share (along `a2`, against the heading signal `|M_perp|`) and its
//! tilt share (normal to `V`, against `|V|`) join the 1-sigma. A rotation at periods the ramps
//! reject leaves `G` near zero; one they pass (a slow yaw of a few metres' arm) does not.
//!
//! # Disturbance check
//! A second slope vector with shorter ramps ([`CHECK_RAMP_FRACTION`], `M_w'`, eq. 8) leaks more
//! of a bounded disturbance (at 120 s, 50 times more of a 16 s surge); its heading must agree
//! with the main one within [`DISTURBANCE_SIGMAS`] of the noise of their difference (computed
//! like the 1-sigma below) plus [`DISTURBANCE_SHARE`] of the main 1-sigma, or the estimate is
//! refused ([`InertialAlignError::BaseDisturbed`]) when the lever arm is not given (its
//! leak reaches the tilt too, unseen by this check). A difference beyond [`EXCESS_SIGMAS`] of
//! its noise is a leak the main slope shares (the short ramps leak more of the same motion):
//! the excess is added to the heading's 1-sigma; with the lever arm given (what is left is the
//! base's translation) and ramps of [`RAMP_MAX_S`] (windows of 120 s or more) that replaces the
//! refusal, unless the excess alone is beyond the largest heading 1-sigma answered. (With
//! shorter ramps the tilt leaks too: 60 s windows answered so were up to 65 sigma off in roll
//! on the alignment family.)
//!
//! # 1-sigma
//! For any weights ([`SensorNoise`], eqs. S1–S3), with `S(t) = int_0^t w` and `W = Omega cos L`:
//! - heading: `[VRW^2 int w1^2 + g^2 ARW^2 int (S1(T) - S1(u))^2 du] / (g W int w1 t)^2` (the
//!   accelerometers' white noise on the slope, the gyros' attitude random walk turning
//!   gravity), `+ b_g^2 / W^2` (east gyro bias), `+ ARW^2 T + b_g^2 T^2` (vertical gyro drift
//!   to the end);
//! - tilt: `VRW^2 int w0^2 / (g int w0)^2 + ARW^2 int (S0(u) / S0(T))^2 du + (b_a / g)^2 +
//!   (b_g (T - t0))^2`, `t0` the centroid of `w0` (the vertical is measured there and carried
//!   to the end by the gyros);
//! - the heading's measurement error `psi` (its first term, and the disturbance check's excess)
//!   is an error about the vertical of `t0`, which the Earth turns east by `W (T - t0)` until
//!   the end: an east tilt `psi W (T - t0)` there, pitch by `cos(yaw)` and roll by `sin(yaw)`
//!   (0.002 deg of pitch for 1.6 deg of heading at 56 deg latitude and 60 s).
//!
//! For `w1 = 2t - T` these are the least-squares slope's `12 VRW^2 / (g^2 W^2 T^3)` (the
//! Cramér–Rao bound itself) and `(6/5) ARW^2 / (W^2 T)`.
//!
//! The attitude is for the time of the last increment ([`InertialAlignment::estimate`]), once
//! the window has been accumulated; [`InertialAlignment::level`] gives a levelled attitude at any
//! time (the fine filters' start).

mod ramp_power;

use super::AttitudeEstimate;
use super::analytic::GravityMismatch;
use super::kahan::{Kahan, Kahan3};
use crate::coning::ConingSculling;
use crate::{ImuIncrement, InputError, InputLimits, Scalar, attitude, earth};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// Shortest window [s]. The heading signal grows as `T^3`: at 10 s even a navigation-grade IMU
/// (0.002 deg/sqrt(h), 5 ug/sqrt(Hz)) has a heading 1-sigma of 0.65 deg at 45 deg latitude.
pub const MIN_DURATION_S: f64 = 10.0;

/// Smallest `cos(latitude)` accepted (about 88.85 deg): the heading signal is proportional to
/// `cos(L)`.
pub const MIN_COS_LAT: f64 = 0.02;

/// Largest relative difference between `|V_w|` and the reference's [-]: the mean specific force
/// must be gravity to 2 % (the static method's tolerance).
pub const GRAVITY_TOLERANCE: f64 = super::analytic::GRAVITY_TOLERANCE;

/// Largest relative difference between the heading signal measured (the part of `M_w` normal to
/// `V_w`) and the reference's [-]: beyond it the heading would be dominated by noise,
/// disturbance or a gyro that cannot see the Earth rate.
pub const HEADING_SIGNAL_TOLERANCE: f64 = 0.5;

/// Length of the taper's ramps, as a fraction of the window [-], at most [`RAMP_MAX_S`].
pub const RAMP_FRACTION: f64 = 0.25;

/// Longest ramp [s]: beyond it the taper costs efficiency and buys no rejection a base's
/// motion (periods below 40 s) needs.
pub const RAMP_MAX_S: f64 = 30.0;

/// Ramps of the check's second slope vector, as a fraction of the main ramps [-].
pub const CHECK_RAMP_FRACTION: f64 = 0.5;

/// The headings of the two ramp lengths may differ by this many 1-sigma of their difference
/// plus [`DISTURBANCE_SHARE`] of the heading's own 1-sigma before the base counts as disturbed.
pub const DISTURBANCE_SIGMAS: f64 = 3.0;

/// See [`DISTURBANCE_SIGMAS`].
pub const DISTURBANCE_SHARE: f64 = 0.3;

/// The two headings' difference beyond this many 1-sigma of its noise is a disturbance's
/// leak, added to the heading's 1-sigma (module docs).
pub const EXCESS_SIGMAS: f64 = 2.0;

/// Frequencies of [`InertialAlignment::translation_leak`]'s spectral integral.
const LEAK_FREQUENCIES: usize = 96;

/// The frequencies [rad/s] of [`InertialAlignment::translation_leak`]'s spectral integral for
/// a wave model resonant at `omega0` [rad/s]: log-spaced over two decades either side.
fn leak_omegas(omega0: f64) -> [f64; LEAK_FREQUENCIES] {
    let (lo, hi) = (0.01 * omega0, 100.0 * omega0);
    let n = LEAK_FREQUENCIES;
    core::array::from_fn(|k| lo * libm::pow(hi / lo, k as f64 / (n - 1) as f64))
}

/// Midpoint steps per ramp of its transfer integrals.
const LEAK_STEPS: usize = 256;

/// Largest heading 1-sigma answered [rad] (15 deg): beyond it the Earth rate is not resolved.
pub const MAX_HEADING_SIGMA_RAD: f64 = 15.0 * core::f64::consts::PI / 180.0;

/// Why the inertial-frame alignment gave no attitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InertialAlignError {
    /// Less than [`MIN_DURATION_S`] or less than the window accumulated.
    TooShort,
    /// An increment was refused (non-finite, bad interval or out of range): the attitude
    /// integration has a gap, so nothing after it is valid. Start again with
    /// [`InertialAlignment::reset`].
    InputRefused(InputError),
    /// The latitude is not finite or within ~1.15 deg of a pole ([`MIN_COS_LAT`]), or the
    /// height is not finite.
    NearPole,
    /// `|V_w|` differs from the reference by more than [`GRAVITY_TOLERANCE`]: the base
    /// accelerated (moved), the accelerometers are faulty, or (a large factor) the sample
    /// rate, timestamps or units are wrong. The measured value is the weighted mean
    /// `g |V_w| / |V_w,i0|`.
    SpecificForceNotGravity(GravityMismatch),
    /// The heading signal differs from the Earth rate's by more than
    /// [`HEADING_SIGNAL_TOLERANCE`], or the heading 1-sigma exceeds [`MAX_HEADING_SIGMA_RAD`]:
    /// too noisy, too disturbed, or the gyros do not resolve the Earth rate.
    HeadingUnobservable,
    /// The solution is not finite (inputs so large that a sum overflowed).
    NonFinite,
    /// The headings of the two ramp lengths disagree (module docs, disturbance check): the base
    /// moves in a way the taper does not hide (a slow oscillation, an unknown lever arm on a
    /// slowly yawing base). Give the lever arm, or align longer.
    BaseDisturbed,
    /// On a moving base, the translation prior's leak through the ramps
    /// ([`InertialAlignment::translation_leak`]) takes the heading 1-sigma beyond
    /// [`MAX_HEADING_SIGMA_RAD`]: the window is too short to hide waves of its size.
    TranslationLeak,
    /// The heading 1-sigma with what an unknown lever arm's motion leaks (module docs,
    /// **Unknown lever arm**) exceeds [`MAX_HEADING_SIGMA_RAD`]: the swaying IMU's offset
    /// from the centre, not known, hides the Earth rate. Give the lever arm, or align longer.
    LeverArmLeak {
        /// The heading 1-sigma, leaks included [rad].
        heading_sigma_rad: f64,
    },
}

impl core::fmt::Display for InertialAlignError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort => f.write_str("window not complete or shorter than 10 s"),
            Self::InputRefused(e) => write!(f, "an increment was refused ({e}); restart"),
            Self::NearPole => f.write_str("latitude too close to a pole (or not finite)"),
            Self::SpecificForceNotGravity(m) => write!(f, "{m}"),
            Self::HeadingUnobservable => f.write_str(
                "Earth-rate heading signal not resolved (noise, disturbance or coarse gyros)",
            ),
            Self::NonFinite => f.write_str("alignment solution not finite"),
            Self::BaseDisturbed => f.write_str(
                "heading depends on the taper: base disturbed beyond what the window hides (unknown lever arm?)",
            ),
            Self::TranslationLeak => f.write_str(
                "base moving: its translation (1-sigma --base-translation) leaks so much heading through this window's ramps that the heading 1-sigma passes 15 deg; align 120 s or more, or give a smaller translation",
            ),
            Self::LeverArmLeak { heading_sigma_rad } => write!(
                f,
                "heading not resolved: the unknown lever arm's motion on this swaying base leaves a heading 1-sigma of {:.1} deg (more than 15); give the lever arm (--lever-arm X,Y,Z) or align longer",
                heading_sigma_rad.to_degrees()
            ),
        }
    }
}

impl core::error::Error for InertialAlignError {}

/// White noise and bias levels of the IMU, from which the alignment methods derive their
/// 1-sigma and with which the fine filters are tuned ([`super::fine::FineConfig`]).
///
/// The inertial-frame method's 1-sigma (module docs, eqs. S1–S3) is exact for these noises
/// and any weights; the static method's is in [`super::machine`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorNoise<T: Scalar> {
    /// Gyro angle random walk `ARW` (white rate noise density) [rad/sqrt(s)].
    pub arw_rad_per_sqrt_s: T,
    /// Accelerometer velocity random walk `VRW` (white noise density) [m/s/sqrt(s)].
    pub vrw_mps_per_sqrt_s: T,
    /// Gyro bias 1-sigma per axis `b_g` [rad/s] (0: calibrated out).
    pub gyro_bias_rad_s: T,
    /// Accelerometer bias 1-sigma per axis `b_a` [m/s^2].
    pub accel_bias_mps2: T,
}

impl<T: Scalar> SensorNoise<T> {
    /// The FOG IMU of [Vavilova et al., §4], the fine filters' defaults: gyro white noise
    /// 0.003 deg/s RMS at 400 Hz = 2.618e-6 rad/sqrt(s), accelerometer white noise 0.02 m/s^2
    /// RMS at 400 Hz = 1e-3 m/s/sqrt(s), gyro bias 0.2 deg/h, accelerometer bias 0.005 m/s^2
    /// (1-sigma per axis).
    pub fn seed003() -> Self {
        let deg = core::f64::consts::PI / 180.0;
        Self {
            arw_rad_per_sqrt_s: T::c(0.003 * deg / 20.0),
            vrw_mps_per_sqrt_s: T::c(0.02 / 20.0),
            gyro_bias_rad_s: T::c(0.2 * deg / 3600.0),
            accel_bias_mps2: T::c(0.005),
        }
    }
}

/// A quaternion summed with a compensated carry per component (Neumaier's two-sum, the carry
/// folded back each step; Higham, *Accuracy and Stability of Numerical Algorithms*, §4.3):
/// `hi + lo` is the attitude, `hi` its rounding to the working precision.
#[derive(Clone, Copy, Debug)]
struct CompensatedQuat<T: Scalar> {
    hi: Quaternion<T>,
    lo: Quaternion<T>,
}

impl<T: Scalar> CompensatedQuat<T> {
    fn identity() -> Self {
        Self {
            hi: Quaternion::identity(),
            lo: Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero()),
        }
    }

    /// `q <- q (x) q(phi) = q + q (x) (q(phi) - 1)`: only the small increment is rounded.
    #[inline]
    fn rotate(&mut self, phi: &Vector3<T>) {
        let (c, s) = attitude::rotation_vector_terms(phi.norm_squared());
        let inc = self.hi * Quaternion::new(c, phi.x * s, phi.y * s, phi.z * s);
        for (h, (l, d)) in self
            .hi
            .coords
            .iter_mut()
            .zip(self.lo.coords.iter_mut().zip(inc.coords.iter()))
        {
            // Two-sum (Neumaier): `err` is the exact rounding error of `h + d`.
            let sum = *h + *d;
            let err = if h.abs() >= d.abs() {
                (*h - sum) + *d
            } else {
                (*d - sum) + *h
            };
            // Fold the carry back (fast two-sum, |sum| >= |carry|), so that `hi` stays the
            // rounded attitude: the next increment and eq. 3 use `hi` alone.
            let carry = *l + err;
            *h = sum + carry;
            *l = carry - (*h - sum);
        }
        // The increments are unit to the working precision, so the norm hardly drifts;
        // renormalise (both parts) only if it does.
        let n2 = self.hi.norm_squared();
        if (n2 - T::one()).abs() > T::c(64.0) * T::default_epsilon() {
            let inv = T::one() / n2.sqrt();
            self.hi *= inv;
            self.lo *= inv;
        }
    }

    /// The attitude rounded to the working precision (normalised).
    fn unit(&self) -> UnitQuaternion<T> {
        UnitQuaternion::new_normalize(self.hi + self.lo)
    }
}

/// `x^2`.
fn sq(x: f64) -> f64 {
    x * x
}

/// Coefficients of the smooth step of order 4, `126 u^5 - 420 u^6 + 540 u^7 - 315 u^8 + 70 u^9`:
/// 0 to 1 with its first four derivatives zero at both ends. Against the order 2 step
/// (`10 u^3 - 15 u^4 + 6 u^5`) it costs 3 % more heading noise at `tau = T/4` and its check
/// catches a 30 m unknown lever arm on sea state 6 that the order 2 check lets through at 4.4
/// sigma (`tests/alignment_inertial.rs`).
const SMOOTHSTEP: [f64; 10] = [0.0, 0.0, 0.0, 0.0, 0.0, 126.0, -420.0, 540.0, -315.0, 70.0];

/// The smooth step (module docs, eq. 4) and its first two derivatives in `u`.
fn smoothstep(u: f64) -> (f64, f64, f64) {
    let u = u.clamp(0.0, 1.0);
    let (mut s, mut s1, mut s2) = (0.0, 0.0, 0.0);
    // Horner's rule for the polynomial and its derivatives.
    for &c in SMOOTHSTEP.iter().rev() {
        s2 = s2 * u + 2.0 * s1;
        s1 = s1 * u + s;
        s = s * u + c;
    }
    (s, s1, s2)
}

/// The weights of one taper over a window `T` with ramps of `ramp` [s] (module docs, eq. 4).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Taper {
    window: f64,
    ramp: f64,
}

/// `(w0, w1, w0'', w1'')` at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Weights {
    w0: f64,
    w1: f64,
    w0_dd: f64,
    w1_dd: f64,
}

impl Taper {
    fn at(&self, t: f64) -> Weights {
        let (t_w, r) = (self.window, self.ramp);
        // Envelope e and its derivatives in t.
        let (e, e_d, e_dd) = if t <= 0.0 || t >= t_w {
            (0.0, 0.0, 0.0)
        } else if t < r {
            let (s, s1, s2) = smoothstep(t / r);
            (s, s1 / r, s2 / (r * r))
        } else if t > t_w - r {
            let (s, s1, s2) = smoothstep((t_w - t) / r);
            (s, -s1 / r, s2 / (r * r))
        } else {
            (1.0, 0.0, 0.0)
        };
        let x = t - 0.5 * t_w;
        Weights {
            w0: e,
            w1: x * e,
            w0_dd: e_dd,
            w1_dd: x * e_dd + 2.0 * e_d,
        }
    }
}

impl Taper {
    /// `(|int w0'' e^(i w t) dt|^2, |int w1'' e^(i w t) dt|^2)` [1/s^2, -] at each of `omega`
    /// [rad/s], each ramp's integral by midpoint sums (`w''` vanishes elsewhere; the phasors
    /// advanced by rotation) and the two ramps' squares added: their interference turns with
    /// `w T`, many times across a wave spectrum, and averages out of its integral.
    fn ramp_power<const N: usize>(&self, omega: &[f64; N]) -> [(f64, f64); N] {
        let mut power = [(0.0_f64, 0.0_f64); N];
        let h = self.ramp / LEAK_STEPS as f64;
        for start in [0.0, self.window - self.ramp] {
            let t0 = start + 0.5 * h;
            let mut sums = [[0.0_f64; 4]; N];
            let mut phasor: [(f64, f64); N] =
                core::array::from_fn(|k| (libm::cos(omega[k] * t0), libm::sin(omega[k] * t0)));
            let step: [(f64, f64); N] =
                core::array::from_fn(|k| (libm::cos(omega[k] * h), libm::sin(omega[k] * h)));
            for j in 0..LEAK_STEPS {
                let w = self.at(t0 + j as f64 * h);
                for k in 0..N {
                    let (c, s) = phasor[k];
                    let acc = &mut sums[k];
                    acc[0] += w.w0_dd * c * h;
                    acc[1] += w.w0_dd * s * h;
                    acc[2] += w.w1_dd * c * h;
                    acc[3] += w.w1_dd * s * h;
                    let (cd, sd) = step[k];
                    phasor[k] = (c * cd - s * sd, s * cd + c * sd);
                }
            }
            for (p, a) in power.iter_mut().zip(&sums) {
                p.0 += a[0] * a[0] + a[1] * a[1];
                p.1 += a[2] * a[2] + a[3] * a[3];
            }
        }
        power
    }
}

/// The noise integrals of one weight (module docs, eqs. S1–S3), in `f64`: `int w^2`,
/// `int w t`, the running `S(t) = int w`, `int S`, `int S^2`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Moments {
    w2: f64,
    wt: f64,
    s: f64,
    int_s: f64,
    int_s2: f64,
}

impl Moments {
    fn add(&mut self, w: f64, t_mid: f64, dt: f64) {
        let s0 = self.s;
        self.s += w * dt;
        self.w2 += w * w * dt;
        self.wt += w * t_mid * dt;
        // Trapezoid over the interval for S and S^2.
        self.int_s += 0.5 * (s0 + self.s) * dt;
        self.int_s2 += 0.5 * (s0 * s0 + self.s * self.s) * dt;
    }

    /// `int (S(T) - S(u))^2 du` over `[0, t]`.
    fn tail2(&self, t: f64) -> f64 {
        (t * self.s * self.s - 2.0 * self.s * self.int_s + self.int_s2).max(0.0)
    }
}

/// A 3x3 matrix summed with Kahan compensation.
#[derive(Clone, Copy, Debug)]
struct Kahan33<T: Scalar>([Kahan3<T>; 3]);

impl<T: Scalar> Kahan33<T> {
    fn new() -> Self {
        Self([Kahan3::new(); 3])
    }
    fn add(&mut self, m: &Matrix3<T>) {
        for (k, c) in self.0.iter_mut().zip(m.column_iter()) {
            k.add(&c.into_owned());
        }
    }
    fn sum(&self) -> Matrix3<T> {
        Matrix3::from_columns(&[self.0[0].sum(), self.0[1].sum(), self.0[2].sum()])
    }
}

/// One slope vector (eq. 4 or 8): the measured and reference sums, the lever-arm sums, the
/// noise moments.
#[derive(Clone, Copy, Debug)]
struct Slope<T: Scalar> {
    taper: Taper,
    m_b0: Kahan3<T>,
    m_i0: Kahan3<T>,
    g: Kahan33<T>,
    moments: Moments,
}

impl<T: Scalar> Slope<T> {
    fn new(taper: Taper) -> Self {
        Self {
            taper,
            m_b0: Kahan3::new(),
            m_i0: Kahan3::new(),
            g: Kahan33::new(),
            moments: Moments::default(),
        }
    }
}

/// Inertial-frame coarse alignment at a known position over a window known in advance (module
/// docs).
///
/// Feed every increment from the start with [`InertialAlignment::add`]; ask for the attitude
/// once the window is complete with [`InertialAlignment::estimate`] (O(1), no allocation).
#[derive(Clone, Debug)]
pub struct InertialAlignment<T: Scalar> {
    lat_rad: T,
    h_m: T,
    noise: Option<SensorNoise<T>>,
    limits: InputLimits<T>,
    lever_b_m: Option<Vector3<T>>,
    /// 1-sigma per axis of an unknown lever arm [m] (its leak joins the 1-sigma).
    lever_sigma_m: Option<f64>,
    coning: ConingSculling<T>,
    q_b_b0: CompensatedQuat<T>,
    /// Plain `int f_b0 dt` [m/s] (the levelling of [`Self::level`]).
    v_b0: Kahan3<T>,
    /// `V_w` and its reference, the lever-arm sum `int w0'' C_b_b0 dt`, moments of `w0`.
    v_w_b0: Kahan3<T>,
    v_w_i0: Kahan3<T>,
    g0: Kahan33<T>,
    m0: Moments,
    /// `int w0 t dt` (the centroid of `w0`).
    w0_t: f64,
    /// The main and the short-ramp slope vectors.
    slope: Slope<T>,
    slope_short: Slope<T>,
    /// `int w1 w1' dt` and `int S1 S1' du` of the two slopes (their difference's noise).
    cross_w: f64,
    cross_s: f64,
    t_s: Kahan<T>,
    dt_last: f64,
    samples: u32,
    refused: Option<InputError>,
    /// The main ramps' power spectrum at the default wave model's frequencies
    /// ([`Self::translation_leak`]), computed while the increments arrive; `None` for ramps
    /// of [`RAMP_MAX_S`], whose leak is not asked for.
    leak_power: Option<ramp_power::RampPower>,
}

impl<T: Scalar> InertialAlignment<T> {
    /// An empty alignment at geodetic latitude `lat_rad` [rad] and height `h_m` [m] over a window
    /// of `window_s` [s]; no noise model (1-sigma NaN), default input limits.
    pub fn new(lat_rad: T, h_m: T, window_s: f64) -> Self {
        let window = if window_s.is_finite() && window_s > 0.0 {
            window_s
        } else {
            MIN_DURATION_S
        };
        let ramp = (RAMP_FRACTION * window).min(RAMP_MAX_S);
        let main = Taper { window, ramp };
        Self {
            lat_rad,
            h_m,
            noise: None,
            limits: InputLimits::default(),
            lever_b_m: None,
            lever_sigma_m: None,
            coning: ConingSculling::new(),
            q_b_b0: CompensatedQuat::identity(),
            v_b0: Kahan3::new(),
            v_w_b0: Kahan3::new(),
            v_w_i0: Kahan3::new(),
            g0: Kahan33::new(),
            m0: Moments::default(),
            w0_t: 0.0,
            slope: Slope::new(main),
            slope_short: Slope::new(Taper {
                window,
                ramp: CHECK_RAMP_FRACTION * ramp,
            }),
            cross_w: 0.0,
            cross_s: 0.0,
            t_s: Kahan::new(),
            dt_last: 0.0,
            samples: 0,
            refused: None,
            leak_power: (ramp < RAMP_MAX_S - 1e-9).then(|| {
                let wave = super::fine::base::Translation::<f64>::default();
                ramp_power::RampPower::new(main, leak_omegas(wave.omega0_rad_s))
            }),
        }
    }

    /// The same with the IMU's noise levels, so that estimates carry a 1-sigma ([`SensorNoise`]).
    pub fn with_noise(mut self, noise: SensorNoise<T>) -> Self {
        self.noise = Some(noise);
        self
    }

    /// The same with other plausibility limits for the increments.
    pub fn with_limits(mut self, limits: InputLimits<T>) -> Self {
        self.limits = limits;
        self
    }

    /// The same with the IMU at `r_b_m` [m] (body axes) from a centre of rotation at rest at the
    /// known position, removed exactly (module docs, eq. 7).
    pub fn with_lever_arm(mut self, r_b_m: Vector3<T>) -> Self {
        self.lever_b_m = Some(r_b_m);
        self.lever_sigma_m = None;
        self
    }

    /// The same with the IMU at an unknown offset from a centre of rotation at rest at the
    /// known position, `sigma_m` [m] 1-sigma per axis: what its motion leaks through the sums
    /// (eq. 7 with the measured `G`) joins the 1-sigma (module docs).
    pub fn with_lever_arm_unknown(mut self, sigma_m: T) -> Self {
        self.lever_b_m = None;
        self.lever_sigma_m = Some(sigma_m.to_f64());
        self
    }

    /// Starts again from the next increment (same position, window, noise model, limits and
    /// lever arm).
    pub fn reset(&mut self) {
        *self = Self {
            noise: self.noise,
            limits: self.limits,
            lever_b_m: self.lever_b_m,
            lever_sigma_m: self.lever_sigma_m,
            ..Self::new(self.lat_rad, self.h_m, self.slope.taper.window)
        };
    }

    /// The reference specific force at rest in `i0` at `t` [s] (eq. 5): gravity's reaction
    /// turned by the Earth rate about the polar axis.
    fn reference_f(&self, t: f64) -> Vector3<T> {
        let lat = self.lat_rad.to_f64();
        let g = earth::normal_gravity(lat, self.h_m.to_f64());
        let (sin_lat, cos_lat) = (libm::sin(lat), libm::cos(lat));
        let u = Vector3::new(cos_lat, 0.0, -sin_lat);
        let f_n = Vector3::new(0.0, 0.0, -g);
        let f_par = u * (-g * -sin_lat);
        let f_perp = f_n - f_par;
        let east = Vector3::new(0.0, g * cos_lat, 0.0);
        let (s, c) = (
            libm::sin(earth::OMEGA_IE * t),
            libm::cos(earth::OMEGA_IE * t),
        );
        (f_par + f_perp * c + east * s).map(T::c)
    }

    /// Adds the next increment (eqs. 2–5, 7, 8). A refused one (see [`ImuIncrement::check`]) is
    /// not used and latches [`InertialAlignError::InputRefused`]: the attitude integration
    /// cannot bridge a gap.
    pub fn add(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        if let Err(e) = inc.check(&self.limits) {
            self.refused.get_or_insert(e);
            return Err(e);
        }
        let c = self
            .coning
            .compensate(&inc.delta_theta_ib_b, &inc.delta_v_ib_b, inc.dt, true);
        let q_b_b0 = UnitQuaternion::new_unchecked(self.q_b_b0.hi);
        let dv_b0 = q_b_b0.transform_vector(&c.delta_v_b);
        let dt = inc.dt.to_f64();
        let t_mid = self.t_s.sum.to_f64() + 0.5 * dt;
        self.v_b0.add(&dv_b0);
        // Weights at the interval's middle.
        let wa = self.slope.taper.at(t_mid);
        let wb = self.slope_short.taper.at(t_mid);
        let f_ref = self.reference_f(t_mid) * inc.dt;
        self.v_w_b0.add(&(dv_b0 * T::c(wa.w0)));
        self.v_w_i0.add(&(f_ref * T::c(wa.w0)));
        self.m0.add(wa.w0, t_mid, dt);
        self.w0_t += wa.w0 * t_mid * dt;
        let (s1, s2) = (self.slope.moments.s, self.slope_short.moments.s);
        for (slope, w) in [(&mut self.slope, &wa), (&mut self.slope_short, &wb)] {
            slope.m_b0.add(&(dv_b0 * T::c(w.w1)));
            slope.m_i0.add(&(f_ref * T::c(w.w1)));
            slope.moments.add(w.w1, t_mid, dt);
        }
        self.cross_w += wa.w1 * wb.w1 * dt;
        self.cross_s += 0.5 * (s1 * s2 + self.slope.moments.s * self.slope_short.moments.s) * dt;
        if self.lever_b_m.is_some() || self.lever_sigma_m.is_some() {
            // C_b_b0 at the interval's middle, where the weights are taken (to first order
            // in the increment): the start's would shift the sums by dt/2, a leak of
            // `dt/2 int w'' v_l dt` that short ramps make visible.
            let half_turn = Matrix3::identity() + (c.phi_b * T::c(0.5)).cross_matrix();
            let c_b_b0 = q_b_b0.to_rotation_matrix().into_inner() * half_turn * inc.dt;
            self.g0.add(&(c_b_b0 * T::c(wa.w0_dd)));
            self.slope.g.add(&(c_b_b0 * T::c(wa.w1_dd)));
            self.slope_short.g.add(&(c_b_b0 * T::c(wb.w1_dd)));
        }
        self.t_s.add(inc.dt);
        self.dt_last = dt;
        self.q_b_b0.rotate(&c.phi_b);
        self.samples = self.samples.saturating_add(1);
        if let Some(l) = &mut self.leak_power {
            l.advance(dt);
            // The window complete (as [`Self::estimate`] has it): whatever is left, now.
            if self.t_s.sum.to_f64() + 0.5 * dt >= self.slope.taper.window {
                l.finish();
            }
        }
        Ok(())
    }

    /// Time accumulated [s].
    pub fn elapsed_s(&self) -> T {
        self.t_s.sum
    }

    /// Increments accumulated.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// `C_b_b0` of the last increment's end, as `q_b_b0`.
    pub fn q_b_b0(&self) -> UnitQuaternion<T> {
        self.q_b_b0.unit()
    }

    /// Magnitude of the plain mean specific force `|int f_b0 dt| / t` [m/s^2] so far (NaN
    /// before any time has passed).
    pub fn mean_specific_force_mps2(&self) -> f64 {
        let t = self.t_s.sum.to_f64();
        if t > 0.0 {
            self.v_b0.sum().norm().to_f64() / t
        } else {
            f64::NAN
        }
    }

    /// The attitude at the end of the last increment levelled on the plain mean specific force
    /// (`int f_b0 dt`), with an arbitrary azimuth: `q_b_c` for a level frame `c` (the fine
    /// filters' start, [`super::fine`]). The vertical is the window's mean one, so it is off by
    /// up to `Omega T` (the Earth's turn) plus what the base's motion leaves in the mean;
    /// `None` without a specific force.
    pub fn level(&self) -> Option<UnitQuaternion<T>> {
        let q_b_b0 = self.q_b_b0.unit();
        let v_b0 = self.v_b0.sum();
        let n = v_b0.norm();
        if !(n.finite() && n > T::zero()) {
            return None;
        }
        // The integrated specific force points up: down is -V.
        let down_b0 = -v_b0 / n;
        let e_d = Vector3::new(T::zero(), T::zero(), T::one());
        let q_b0_c = UnitQuaternion::rotation_between(&down_b0, &e_d)?;
        Some(q_b0_c * q_b_b0)
    }

    /// The attitude at the end of the last increment, with its 1-sigma if a noise model was
    /// given (eqs. 1, 6; module docs), or why there is none.
    pub fn estimate(&self) -> Result<AttitudeEstimate<T>, InertialAlignError> {
        if let Some(e) = self.refused {
            return Err(InertialAlignError::InputRefused(e));
        }
        let t = self.t_s.sum.to_f64();
        let window = self.slope.taper.window;
        if self.samples == 0
            || !t.is_finite()
            || t < MIN_DURATION_S
            || t + 0.5 * self.dt_last < window
        {
            return Err(InertialAlignError::TooShort);
        }
        let cos_lat = libm::cos(self.lat_rad.to_f64());
        if !cos_lat.is_finite() || cos_lat < MIN_COS_LAT || !self.h_m.finite() {
            return Err(InertialAlignError::NearPole);
        }
        let lever = |g: &Kahan33<T>| self.lever_b_m.map_or(Vector3::zeros(), |l| g.sum() * l);
        let v_b0 = self.v_w_b0.sum() - lever(&self.g0);
        let v_i0 = self.v_w_i0.sum();
        let m_b0 = self.slope.m_b0.sum() - lever(&self.slope.g);
        let m_i0 = self.slope.m_i0.sum();
        let g = earth::normal_gravity(self.lat_rad.to_f64(), self.h_m.to_f64());
        let c_b0_i0 = solve(&v_b0, &m_b0, &v_i0, &m_i0, g)?;
        let parts = self.sigma(t, cos_lat);
        let sigma = parts.map(|p| p.sigma);
        if let Some(s) = sigma
            && !(s.z.to_f64() <= MAX_HEADING_SIGMA_RAD)
        {
            return Err(InertialAlignError::HeadingUnobservable);
        }
        let excess = self.check_disturbance(&c_b0_i0, &v_b0, &v_i0, t, cos_lat, sigma)?;
        let q_b0_i0 =
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(c_b0_i0));
        // C_n_i0(T): the NED frame turned by Omega T about the polar axis since the start.
        let half = 0.5 * earth::OMEGA_IE * t;
        let (sh, ch) = (libm::sin(half), libm::cos(half));
        let sin_lat = libm::sin(self.lat_rad.to_f64());
        let q_n_i0 = UnitQuaternion::new_unchecked(Quaternion::new(
            T::c(ch),
            T::c(cos_lat * sh),
            T::zero(),
            T::c(-sin_lat * sh),
        ));
        // Eq. 1.
        let q_b_n = q_n_i0.inverse() * q_b0_i0 * self.q_b_b0.unit();
        if !q_b_n.coords.iter().all(|x| x.finite()) {
            return Err(InertialAlignError::NonFinite);
        }
        let (_, _, yaw) = attitude::euler(&q_b_n);
        let c_b0_n = (q_n_i0.inverse() * q_b0_i0)
            .to_rotation_matrix()
            .into_inner();
        let lever = self.lever_leak(&v_b0, &m_b0, &c_b0_n);
        let sigma = parts.map(|p| p.with_leaks(excess, &lever, yaw.to_f64()));
        // The noise alone resolved the heading (above); with the leaks it may not be: an
        // answer whose heading 1-sigma is beyond the limit is no heading.
        if let Some(s) = sigma
            && !(s.z.to_f64() <= MAX_HEADING_SIGMA_RAD)
        {
            return Err(if lever.heading2 >= sq(excess) {
                InertialAlignError::LeverArmLeak {
                    heading_sigma_rad: s.z.to_f64(),
                }
            } else {
                InertialAlignError::BaseDisturbed
            });
        }
        Ok(AttitudeEstimate {
            q_b_n,
            sigma_rad: sigma.unwrap_or_else(|| Vector3::repeat(T::c(f64::NAN))),
            elapsed_s: self.t_s.sum,
        })
    }

    /// Length of the main ramps [s] ([`RAMP_FRACTION`] of the window, at most [`RAMP_MAX_S`]).
    pub fn ramp_s(&self) -> f64 {
        self.slope.taper.ramp
    }

    /// Tilt and heading 1-sigma [rad] that a horizontal translation of the base's centre
    /// leaks through the main ramps (module docs, **Why the taper**): a displacement `r(t)`
    /// enters `V_w` and `M_w` as `int w'' r dt`, seen against the signals `g int w0` (the
    /// vertical) and `g Omega cos(L) int w1 t` (the heading's). `r` per horizontal axis is the
    /// fine filter's wave model `t` ([`super::fine::base`], [Fossen, §8.2.5]: a resonance at
    /// `omega0` with damping `zeta`, no power below `corner` [rad/s]) scaled to the stationary
    /// 1-sigma `t.horizontal_sigma_m`; the variances are `int S |F|^2 dw` over the spectrum
    /// `S`. The heading's leak also tilts the vertical carried from the centroid of `w0` to the
    /// end by the Earth's turn, `Omega cos(L) (T - t0)` of it. A bound the disturbance check
    /// cannot give: two ramp lengths can leak the same heading by chance.
    pub fn translation_leak(&self, t: &super::fine::base::Translation<f64>) -> (f64, f64) {
        let g = earth::normal_gravity(self.lat_rad.to_f64(), self.h_m.to_f64());
        let w_h = earth::OMEGA_IE * libm::cos(self.lat_rad.to_f64());
        let (s0, wt) = (self.m0.s, self.slope.moments.wt);
        let (sigma, omega0, zeta, corner) = (
            t.horizontal_sigma_m,
            t.omega0_rad_s,
            t.damping,
            t.corner_rad_s,
        );
        if !(sigma > 0.0 && omega0 > 0.0 && zeta > 0.0 && corner >= 0.0 && s0 > 0.0 && wt > 0.0) {
            return (0.0, 0.0);
        }
        let omega = leak_omegas(omega0);
        let n = LEAK_FREQUENCIES;
        // Computed while the increments arrived where it could be (the default wave model, a
        // complete window), else now.
        let early = self
            .leak_power
            .as_ref()
            .filter(|l| l.omega() == &omega)
            .and_then(|l| l.power().copied());
        let power = early.unwrap_or_else(|| self.slope.taper.ramp_power(&omega));
        // |H(i w)|^2 up to the gain, which the stationary 1-sigma fixes.
        let shape = |w: f64| {
            let d = omega0 * omega0 - w * w;
            w * w / ((w * w + corner * corner) * (d * d + sq(2.0 * zeta * omega0 * w)))
        };
        // Trapezoid in w.
        let (mut total, mut v0, mut v1) = (0.0, 0.0, 0.0);
        for k in 1..n {
            let dw = 0.5 * (omega[k] - omega[k - 1]);
            let (sa, sb) = (shape(omega[k - 1]), shape(omega[k]));
            total += dw * (sa + sb);
            v0 += dw * (sa * power[k - 1].0 + sb * power[k].0);
            v1 += dw * (sa * power[k - 1].1 + sb * power[k].1);
        }
        let scale = sigma * sigma / total;
        let heading = libm::sqrt(v1 * scale) / (g * w_h * wt);
        let carried = w_h * (self.slope.taper.window - self.w0_t / s0);
        let tilt = libm::sqrt(v0 * scale) / (g * s0) + heading * carried.abs();
        (tilt, heading)
    }

    /// What an unknown lever arm's motion leaks (module docs, **Unknown lever arm**): the
    /// sums take `G0 l` and `G1 l` for the offset `l`, 1-sigma `s` per axis, so the heading
    /// (from the part of `M` along `a2 = V x M / |V x M|` against `|M_perp|`) has a variance
    /// `s^2 |G1^T a2|^2 / |M_perp|^2`, and the vertical `a1` moves by `P G0 l / |V|` (`P` the
    /// projection normal to `V`), carried to NED at the end by `c_b0_n`. Nothing without an
    /// unknown lever arm.
    fn lever_leak(&self, v_b0: &Vector3<T>, m_b0: &Vector3<T>, c_b0_n: &Matrix3<T>) -> LeverLeak {
        let Some(s) = self.lever_sigma_m else {
            return LeverLeak::default();
        };
        let f = |m: &Matrix3<T>| m.map(|x| x.to_f64());
        let (v, m) = (v_b0.map(|x| x.to_f64()), m_b0.map(|x| x.to_f64()));
        let (g0, g1, r) = (f(&self.g0.sum()), f(&self.slope.g.sum()), f(c_b0_n));
        let a1 = v.normalize();
        let m_perp = m - a1 * a1.dot(&m);
        let a2 = v.cross(&m).normalize();
        let (vn, mn) = (v.norm(), m_perp.norm());
        if !(vn > 0.0 && mn > 0.0 && a2.iter().all(|x| x.is_finite())) {
            return LeverLeak::default();
        }
        let heading2 = s * s * (g1.transpose() * a2).norm_squared() / (mn * mn);
        let p = Matrix3::identity() - a1 * a1.transpose();
        let down = r * p * g0 / vn;
        LeverLeak {
            heading2,
            level_n: down * down.transpose() * (s * s),
        }
    }

    /// The disturbance check (module docs, eq. 8): the short-ramp heading against the main one.
    fn check_disturbance(
        &self,
        c_b0_i0: &Matrix3<T>,
        v_b0: &Vector3<T>,
        v_i0: &Vector3<T>,
        t: f64,
        cos_lat: f64,
        sigma: Option<Vector3<T>>,
    ) -> Result<f64, InertialAlignError> {
        let (Some(n), Some(sigma)) = (self.noise, sigma) else {
            return Ok(0.0);
        };
        let lever = self
            .lever_b_m
            .map_or(Vector3::zeros(), |l| self.slope_short.g.sum() * l);
        let m_b0 = self.slope_short.m_b0.sum() - lever;
        let g = earth::normal_gravity(self.lat_rad.to_f64(), self.h_m.to_f64());
        let c2 = solve(v_b0, &m_b0, v_i0, &self.slope_short.m_i0.sum(), g)
            .map_err(|_| InertialAlignError::BaseDisturbed)?;
        let r = Rotation3::from_matrix_unchecked(c2 * c_b0_i0.transpose());
        let d_yaw = r.scaled_axis().z.abs().to_f64();
        // Noise of the difference of the two normalised slopes.
        let w = earth::OMEGA_IE * cos_lat;
        let (a, b) = (&self.slope.moments, &self.slope_short.moments);
        let (na, nb) = (a.wt, b.wt);
        let vrw2 = sq(n.vrw_mps_per_sqrt_s.to_f64());
        let arw2 = sq(n.arw_rad_per_sqrt_s.to_f64());
        let acc = a.w2 / (na * na) + b.w2 / (nb * nb) - 2.0 * self.cross_w / (na * nb);
        let tail_ab = t * a.s * b.s - a.s * b.int_s - b.s * a.int_s + self.cross_s;
        let gyro = a.tail2(t) / (na * na) + b.tail2(t) / (nb * nb) - 2.0 * tail_ab / (na * nb);
        let var = (vrw2 * acc.max(0.0) / (g * g) + arw2 * gyro.max(0.0)) / (w * w);
        let limit = DISTURBANCE_SIGMAS * libm::sqrt(var) + DISTURBANCE_SHARE * sigma.z.to_f64();
        let excess = (d_yaw - EXCESS_SIGMAS * libm::sqrt(var)).max(0.0);
        // A disturbance leaks into the tilt as well, which the check does not see: beyond the
        // limit it is refused, unless the lever arm is given (what is left is the base's
        // translation) and the ramps are the longest (their leak of motion at periods below
        // 16 s is then negligible in the tilt, and the excess bounds the heading's; module
        // docs). A leak that alone exceeds the largest heading 1-sigma answered is refused.
        let long_ramps = self.slope.taper.ramp >= RAMP_MAX_S - 1e-9;
        let excess_answered = self.lever_b_m.is_some() && long_ramps;
        let beyond = !(d_yaw <= limit) && !excess_answered;
        if beyond || !(excess <= MAX_HEADING_SIGMA_RAD) {
            return Err(InertialAlignError::BaseDisturbed);
        }
        Ok(excess)
    }

    /// Roll, pitch, yaw 1-sigma [rad] after `t` [s] (module docs, eqs. S1–S3) and what the
    /// heading's error tilts the end by; `None` without a noise model.
    fn sigma(&self, t: f64, cos_lat: f64) -> Option<SigmaParts<T>> {
        let n = self.noise?;
        let g = earth::normal_gravity(self.lat_rad.to_f64(), self.h_m.to_f64());
        let w = earth::OMEGA_IE * cos_lat;
        let f = |x: T| x.to_f64();
        let (arw2, vrw2) = (sq(f(n.arw_rad_per_sqrt_s)), sq(f(n.vrw_mps_per_sqrt_s)));
        let (bg2, ba2) = (sq(f(n.gyro_bias_rad_s)), sq(f(n.accel_bias_mps2)));
        let m1 = &self.slope.moments;
        let heading_scale = g * w * m1.wt;
        let slope2 = (vrw2 * m1.w2 + g * g * arw2 * m1.tail2(t)) / (heading_scale * heading_scale);
        let yaw2 = slope2 + bg2 / (w * w) + arw2 * t + bg2 * t * t;
        let m0 = &self.m0;
        let centroid = self.w0_t / m0.s;
        let tilt2 = vrw2 * m0.w2 / sq(g * m0.s)
            + arw2 * m0.int_s2 / (m0.s * m0.s)
            + ba2 / (g * g)
            + bg2 * sq(t - centroid);
        Some(SigmaParts {
            sigma: Vector3::new(
                T::c(libm::sqrt(tilt2)),
                T::c(libm::sqrt(tilt2)),
                T::c(libm::sqrt(yaw2)),
            ),
            slope_heading2: slope2,
            carried_rad: w * (t - centroid),
        })
    }
}

/// The 1-sigma of an estimate before the disturbance check's excess, with what its heading's
/// measurement error does to the tilt at the end.
#[derive(Clone, Copy, Debug)]
struct SigmaParts<T: Scalar> {
    /// Roll, pitch, yaw 1-sigma [rad] (eqs. S1–S3).
    sigma: Vector3<T>,
    /// Variance of the heading measured by the slope (TRIAD's error about the vertical at the
    /// centroid of `w0`) [rad^2].
    slope_heading2: f64,
    /// The Earth's turn of the vertical from that centroid to the end, `Omega cos(L) (T - t0)`
    /// [rad].
    carried_rad: f64,
}

impl<T: Scalar> SigmaParts<T> {
    /// The 1-sigma with the disturbance check's `excess` [rad] and an unknown lever arm's leak
    /// added, and the east tilt the heading's error leaves at the end: TRIAD's error is about
    /// the vertical of `t0`, which the Earth has turned east by `carried_rad` by the end, so its
    /// heading error `psi` is also an east tilt `psi carried_rad` there. A tilt `phi` (north,
    /// east) is roll `phi_N cos(yaw) + phi_E sin(yaw)` and pitch `-phi_N sin(yaw) + phi_E
    /// cos(yaw)` (`yaw` [rad], the estimate's); a move `d` of the measured vertical is the tilt
    /// `(-d_E, d_N)`.
    fn with_leaks(&self, excess: f64, lever: &LeverLeak, yaw: f64) -> Vector3<T> {
        let heading2 = self.slope_heading2 + sq(excess) + lever.heading2;
        let d = &lever.level_n;
        // Tilt covariance (north, east): the lever's, and the heading's carried east.
        let (nn, ee, ne) = (
            d[(1, 1)],
            d[(0, 0)] + heading2 * sq(self.carried_rad),
            -d[(0, 1)],
        );
        let (s, c) = (libm::sin(yaw), libm::cos(yaw));
        let roll2 = c * c * nn + s * s * ee + 2.0 * c * s * ne;
        let pitch2 = s * s * nn + c * c * ee - 2.0 * c * s * ne;
        let f = |x: T| x.to_f64();
        Vector3::new(
            T::c(libm::sqrt(sq(f(self.sigma.x)) + roll2.max(0.0))),
            T::c(libm::sqrt(sq(f(self.sigma.y)) + pitch2.max(0.0))),
            T::c(libm::sqrt(
                sq(f(self.sigma.z)) + sq(excess) + lever.heading2,
            )),
        )
    }
}

/// What an unknown lever arm leaks into the estimate ([`InertialAlignment::lever_leak`]).
#[derive(Clone, Copy, Debug, Default)]
struct LeverLeak {
    /// Heading variance [rad^2].
    heading2: f64,
    /// Covariance of the measured vertical's move in NED at the end [rad^2].
    level_n: Matrix3<f64>,
}

/// `C_b0_i0` from the observation vectors in `b0` and their references in `i0` by TRIAD
/// (eq. 6), or why not; `g_mps2` is the site's normal gravity (the references' magnitude).
fn solve<T: Scalar>(
    v_b0: &Vector3<T>,
    m_b0: &Vector3<T>,
    v_i0: &Vector3<T>,
    m_i0: &Vector3<T>,
    g_mps2: f64,
) -> Result<Matrix3<T>, InertialAlignError> {
    if !(v_b0.iter().chain(m_b0.iter()).all(|x| x.finite())) {
        return Err(InertialAlignError::NonFinite);
    }
    let (nv_b0, nv_i0) = (v_b0.norm(), v_i0.norm());
    if !(nv_i0 > T::zero()) || (nv_b0 - nv_i0).abs() > T::c(GRAVITY_TOLERANCE) * nv_i0 {
        return Err(InertialAlignError::SpecificForceNotGravity(
            GravityMismatch {
                measured_mps2: g_mps2 * (nv_b0 / nv_i0).to_f64(),
                gravity_mps2: g_mps2,
            },
        ));
    }
    let (a1_b0, a1_i0) = (v_b0 / nv_b0, v_i0 / nv_i0);
    let (c_b0, c_i0) = (a1_b0.cross(m_b0), a1_i0.cross(m_i0));
    let (nc_b0, nc_i0) = (c_b0.norm(), c_i0.norm());
    if !(nc_i0 > T::zero()) || (nc_b0 - nc_i0).abs() > T::c(HEADING_SIGNAL_TOLERANCE) * nc_i0 {
        return Err(InertialAlignError::HeadingUnobservable);
    }
    let triad = |a1: Vector3<T>, a2: Vector3<T>| Matrix3::from_columns(&[a1, a2, a1.cross(&a2)]);
    Ok(triad(a1_i0, c_i0 / nc_i0) * triad(a1_b0, c_b0 / nc_b0).transpose())
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::attitude::from_euler;

    const DT: f64 = 0.0025;

    /// Feeds `seconds` of a body at rest with attitude `(roll, pitch, yaw)` [rad], its
    /// specific force scaled by `f_scale` and its gyros seeing `w_scale` of the Earth rate.
    fn feed<T: Scalar>(
        a: &mut InertialAlignment<T>,
        lat: f64,
        seconds: f64,
        f_scale: f64,
        w_scale: f64,
    ) {
        let q_n_b = from_euler(0.02, -0.01, 1.0).inverse();
        let g = earth::normal_gravity(lat, 0.0);
        let dtheta = q_n_b * earth::omega_ie_n(lat) * (DT * w_scale);
        let dv = q_n_b * Vector3::new(0.0, 0.0, -g * f_scale) * DT;
        let inc = ImuIncrement::new(dtheta.map(T::c).into(), dv.map(T::c).into(), T::c(DT));
        for _ in 0..libm::round(seconds / DT) as u32 {
            a.add(&inc).unwrap();
        }
    }

    fn heading_error_deg(est: &AttitudeEstimate<f64>) -> f64 {
        let (_, _, yaw) = attitude::euler(&est.q_b_n);
        (yaw - 1.0).to_degrees()
    }

    /// Translations drawn from the wave model leak into the heading and tilt with the RMS
    /// [`InertialAlignment::translation_leak`] predicts (24 realisations per window: the RMS
    /// of 24 normal errors is within 0.6-1.45 of its sigma at 3 sigma of its spread).
    #[test]
    fn the_translation_leak_is_what_waves_leak() {
        use super::super::fine::base::Translation;
        let lat = 0.7_f64;
        let dt = 0.005;
        let q_n_b = from_euler(0.02, -0.01, 1.0).inverse();
        let g = earth::normal_gravity(lat, 0.0);
        let dtheta = q_n_b * earth::omega_ie_n(lat) * dt;
        let wave = Translation {
            horizontal_sigma_m: 0.05,
            ..Translation::<f64>::default()
        };
        // Unnormalised |H|^2 of the model, as the method's.
        let (w0, z, wc) = (wave.omega0_rad_s, wave.damping, wave.corner_rad_s);
        let shape = |w: f64| {
            let d = w0 * w0 - w * w;
            w * w / ((w * w + wc * wc) * (d * d + (2.0 * z * w0 * w) * (2.0 * z * w0 * w)))
        };
        let mut seed = 0x9E37_79B9_7F4A_7C15_u64;
        let mut uniform = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        const K: usize = 60;
        for window in [60.0, 120.0] {
            let (mut sum_h, mut sum_t, mut n) = (0.0, 0.0, 0.0);
            let mut predicted = (0.0, 0.0);
            for _ in 0..24 {
                // Sinusoids at jittered log-spaced frequencies, amplitudes from the spectrum.
                let mut comp = [(0.0, 0.0, 0.0); K];
                let (lo, hi) = (0.05 * w0, 8.0 * w0);
                let mut var = 0.0;
                for (k, c) in comp.iter_mut().enumerate() {
                    let a = lo * libm::pow(hi / lo, k as f64 / K as f64);
                    let b = lo * libm::pow(hi / lo, (k + 1) as f64 / K as f64);
                    let w = a + (b - a) * uniform();
                    let amp2 = 2.0 * shape(w) * (b - a);
                    var += 0.5 * amp2;
                    *c = (w, libm::sqrt(amp2), core::f64::consts::TAU * uniform());
                }
                let norm = wave.horizontal_sigma_m / libm::sqrt(var);
                let mut a = InertialAlignment::<f64>::new(lat, 0.0, window);
                for k in 0..libm::round(window / dt) as u32 {
                    let t = (f64::from(k) + 0.5) * dt;
                    // North displacement r = sum amp cos(w t + p): acceleration -sum amp w^2 cos.
                    let acc: f64 = comp
                        .iter()
                        .map(|&(w, amp, p)| -amp * w * w * libm::cos(w * t + p))
                        .sum();
                    let f = Vector3::new(acc * norm, 0.0, -g);
                    a.add(&ImuIncrement::new(
                        dtheta.into(),
                        (q_n_b * f * dt).into(),
                        dt,
                    ))
                    .unwrap();
                }
                predicted = a.translation_leak(&wave);
                let est = a.estimate().unwrap();
                let (roll, pitch, _) = attitude::euler(&est.q_b_n);
                sum_h += heading_error_deg(&est).to_radians().powi(2);
                sum_t += (roll - 0.02).powi(2) + (pitch + 0.01).powi(2);
                n += 1.0;
            }
            let (rms_h, rms_t) = (libm::sqrt(sum_h / n), libm::sqrt(sum_t / n));
            std::println!(
                "{window} s: heading RMS {rms_h:.2e} rad (predicted {:.2e}), tilt {rms_t:.2e} (predicted {:.2e})",
                predicted.1,
                predicted.0
            );
            let ratio = rms_h / predicted.1;
            assert!((0.6..=1.45).contains(&ratio), "{window} s heading: {ratio}");
            // The tilt's carried share is added in full (an upper bound): not below.
            assert!(rms_t <= 1.45 * predicted.0, "{window} s tilt");
        }
    }

    #[test]
    fn exact_still_data_give_the_attitude_with_a_sigma() {
        let lat = 45f64.to_radians();
        let mut a =
            InertialAlignment::<f64>::new(lat, 0.0, 30.0).with_noise(SensorNoise::seed003());
        feed(&mut a, lat, 30.0, 1.0, 1.0);
        let est = a.estimate().unwrap();
        assert!(
            heading_error_deg(&est).abs() < 1e-4,
            "{}",
            heading_error_deg(&est)
        );
        let s = est.sigma_rad;
        assert!(s.iter().all(|v| v.is_finite() && *v > 0.0), "{s:?}");
        assert!(
            s.z > 10.0 * s.x,
            "heading sigma {} not above tilt {}",
            s.z,
            s.x
        );
    }

    #[test]
    fn an_incomplete_or_short_window_is_refused() {
        let lat = 45f64.to_radians();
        let mut a = InertialAlignment::<f64>::new(lat, 0.0, 30.0);
        feed(&mut a, lat, 20.0, 1.0, 1.0);
        assert_eq!(a.estimate().unwrap_err(), InertialAlignError::TooShort);
        let mut short = InertialAlignment::<f64>::new(lat, 0.0, 5.0);
        feed(&mut short, lat, 5.0, 1.0, 1.0);
        assert_eq!(short.estimate().unwrap_err(), InertialAlignError::TooShort);
        assert_eq!(
            InertialAlignment::<f64>::new(lat, 0.0, 30.0)
                .estimate()
                .unwrap_err(),
            InertialAlignError::TooShort
        );
    }

    #[test]
    fn a_pole_or_a_nan_position_is_refused() {
        for (lat, h) in [
            (89.5f64.to_radians(), 0.0),
            (f64::NAN, 0.0),
            (0.7, f64::NAN),
        ] {
            let mut a = InertialAlignment::<f64>::new(lat, h, 20.0);
            // The increments of 45 deg: the position check comes first.
            feed(&mut a, 45f64.to_radians(), 20.0, 1.0, 1.0);
            assert_eq!(
                a.estimate().unwrap_err(),
                InertialAlignError::NearPole,
                "{lat} {h}"
            );
        }
    }

    #[test]
    fn a_refused_increment_latches_until_reset() {
        let lat = 45f64.to_radians();
        let mut a = InertialAlignment::<f32>::new(lat as f32, 0.0, 20.0);
        feed(&mut a, lat, 10.0, 1.0, 1.0);
        let bad = ImuIncrement::new([0.0, f32::NAN, 0.0], [0.0, 0.0, -0.0245], 0.0025);
        assert_eq!(a.add(&bad), Err(InputError::NonFinite));
        feed(&mut a, lat, 10.0, 1.0, 1.0);
        assert_eq!(
            a.estimate().unwrap_err(),
            InertialAlignError::InputRefused(InputError::NonFinite)
        );
        a.reset();
        feed(&mut a, lat, 20.0, 1.0, 1.0);
        let est = a.estimate().unwrap();
        let (_, _, yaw) = attitude::euler(&est.q_b_n);
        // f32 over 8000 increments: well inside a degree, far from a silent 0.
        assert!((yaw - 1.0).abs() < 0.02, "{yaw}");
    }

    #[test]
    fn wrong_gravity_or_no_earth_rate_is_refused() {
        let lat = 45f64.to_radians();
        let mut heavy = InertialAlignment::<f64>::new(lat, 0.0, 20.0);
        feed(&mut heavy, lat, 20.0, 1.05, 1.0);
        let e = heavy.estimate().unwrap_err();
        let InertialAlignError::SpecificForceNotGravity(m) = e else {
            panic!("{e:?}");
        };
        // The weighted mean of a force 1.05 g is 1.05 g: the message gives both and reads
        // as motion, not as a wrong scale.
        let g = earth::normal_gravity(lat, 0.0);
        assert!((m.measured_mps2 / (1.05 * g) - 1.0).abs() < 1e-9, "{m:?}");
        assert_eq!(m.gravity_mps2, g);
        assert!(!m.is_scale());
        // Increments ten times too large for their intervals (a rate 10x too low): a factor.
        let mut fast = InertialAlignment::<f64>::new(lat, 0.0, 20.0);
        feed(&mut fast, lat, 20.0, 10.0, 1.0);
        let text = std::format!("{}", fast.estimate().unwrap_err());
        assert!(
            text.starts_with("mean specific force 98.06 m/s^2 is not gravity 9.806 m/s^2 (10.00 times it): sample rate"),
            "{text}"
        );
        let mut blind = InertialAlignment::<f64>::new(lat, 0.0, 20.0);
        feed(&mut blind, lat, 20.0, 1.0, 0.0);
        assert_eq!(
            blind.estimate().unwrap_err(),
            InertialAlignError::HeadingUnobservable
        );
    }

    #[test]
    fn a_heading_sigma_beyond_the_limit_is_refused() {
        // Gyro noise 100 times a FOG's: the heading 1-sigma exceeds 15 deg at 10 s.
        let lat = 45f64.to_radians();
        let mut n = SensorNoise::<f64>::seed003();
        n.arw_rad_per_sqrt_s *= 100.0;
        n.vrw_mps_per_sqrt_s *= 100.0;
        let mut a = InertialAlignment::<f64>::new(lat, 0.0, 10.0).with_noise(n);
        feed(&mut a, lat, 10.0, 1.0, 1.0);
        assert_eq!(
            a.estimate().unwrap_err(),
            InertialAlignError::HeadingUnobservable
        );
    }
}
