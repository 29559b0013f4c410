//! Inertial-frame coarse alignment ("ib0" method): gravity observed in a frame frozen in inertial
//! space, on a rocking or disturbed base, with no initial heading (seed 003's coarse stage).
//!
//! References: Gu, El-Sheimy, Hassan, Syed, *Coarse alignment for marine SINS using gravity in
//! the inertial frame as a reference*, IEEE/ION PLANS 2008; Silson, *Coarse alignment of a ship's
//! strapdown inertial attitude reference system using velocity loci*, IEEE Trans. Instrum. Meas.
//! 60(6), 2011; Wu & Pan, *Velocity/position integration formula, part I*, IEEE Trans. Aerosp.
//! Electron. Syst. 49(2), 2013 (velocity and position forms); Shuster & Oh, *Three-axis attitude
//! determination from vector observations*, J. Guid. Control 4(1), 1981 (TRIAD).
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
//!   two-sample coning term ([`crate::coning`]); the quaternion is summed with a compensated
//!   (two-sum) carry, so the 1.8e-7 rad Earth-rate increments of a 400 Hz `f32` run are not lost
//!   to rounding against components of size 1 (they carry the heading).
//! - Specific force in `b0` (eq. 3): `dV_b0,k = C_b_b0(t_{k-1}) (dv_k + rotation + sculling)`
//!   ([`crate::coning`], Savage (7.2.2.2-11), (7.2.2.2-22)).
//! - The two observation vectors over `[0, T]` (Wu & Pan's velocity and position forms combined):
//!   `V(T) = int f dt` (eq. 4) and `M(T) = T V(T) - 2 P(T) = int (2t - T) f dt` (eq. 5),
//!   `P(T) = int V dt`. With the trapezoidal `P`, `M` obeys the recursion
//!   `M_k = M_{k-1} + T_{k-1} dV_k - dt_k V_{k-1}` (eq. 6), summed with Kahan compensation: its
//!   two terms nearly cancel (exactly, for a constant specific force), so only the small part that
//!   carries the heading is accumulated.
//! - Reference in `i0` (eq. 7), closed form: at rest the specific force is
//!   `f_n = (0, 0, -g)` (the gravity reaction) and `f_i0(t) = R(u, Omega t) f_n`, the rotation
//!   by the Earth rate `Omega` about the polar axis `u = (cos L, 0, -sin L)`. With
//!   `f_par = u (u . f_n)`, `f_perp = f_n - f_par`, `u x f_n = (0, g cos L, 0)` (east) and
//!   `x = Omega T`:
//!   `V_i0 = T [f_par + f_perp sin(x)/x + (u x f_n) (1 - cos x)/x]`,
//!   `M_i0 = T^2 [f_perp (x sin x - 2 (1 - cos x))/x^2 + (u x f_n) (2 sin x - x - x cos x)/x^2]`,
//!   evaluated by their Taylor series for `x < 1` (no cancellation). `M_i0` is east to
//!   `O(x)`: `g Omega cos(L) T^3 / 6`, the rotation of the vertical towards the east.
//! - `C_b0_i0` from the two vector pairs by TRIAD (eq. 8): `a1 = V/|V|`,
//!   `a2 = (V x M)/|V x M|`, `a3 = a1 x a2`, `C_b0_i0 = [a1 a2 a3]_i0 [a1 a2 a3]_b0^T`. It is
//!   the solution of Wahba's problem that trusts `V` fully for the level and takes the heading
//!   from the part of `M` normal to `V`.
//!
//! # Why these two vectors
//! Linearised, the tilt of `b0` is the mean of the specific force's direction (`V`) and the
//! heading error is the least-squares slope of its north component divided by `g Omega cos L`
//! (`M` is the ordinary least-squares slope window `2t - T`). That is the maximum-likelihood
//! estimate for white accelerometer noise, and `1.095x` the bound for gyro white noise (see
//! [`SensorNoise`]). A disturbance velocity `v_d` (lever arm, waves, people walking on the base;
//! in `i0`) enters `M` only as (eq. 9)
//! `dM = T (v_d(T) + v_d(0)) - 2 (r_d(T) - r_d(0))`, `r_d` its displacement. TRIAD turns the
//! horizontal `M_E e + dM_h` onto east (`M_E = g Omega cos(L) T^3 / 6`), so the heading error is
//! `atan2(dM_N, M_E + dM_E)`, at most `asin(|dM_h| / M_E)`; to first order
//! `[6 (v_N(0) + v_N(T)) / T^2 - 12 (r_N(T) - r_N(0)) / T^3] / (g Omega cos L)`: the disturbance
//! tilt `v / (g T)` over the Earth-rate geometry `Omega cos(L) T`. The level error is
//! `|v_d(T) - v_d(0)| / (g T)`, plus `2 sin(|psi| / 2) Omega cos(L) T / 2` from a heading error
//! `psi` (a turn about the window's mean vertical, not today's). Where `|M_E e + dM_h|` is off
//! by more than [`HEADING_SIGNAL_TOLERANCE`], the estimate is refused. A known lever arm removes
//! its part of `v_d` (eq. 10).
//!
//! # Known lever arm
//! With [`InertialAlignment::with_lever_arm`] the IMU's offset `R` (body axes) from a centre of
//! rotation at rest at the known position is compensated exactly: the IMU's inertial velocity
//! relative to the centre is `v_l = C_b_i (omega_ib_b x R)`, so (eq. 10)
//! `V_c = V - v_l(T) + v_l(0)`, `M_c = M - T (v_l(T) + v_l(0)) + 2 int v_l dt`, with `v_l` in
//! `b0` from the gyro rate: interior samples by the central mean `(w_{k-1} + w_k) / 2` of the
//! interval rates `w_k = dtheta_k / dt_k`, the two ends by linear extrapolation
//! `(3 w_k - w_{k-1}) / 2` (errors `O(dt^2 d2omega/dt2)`). The gyro white noise enters only
//! through the end rates (see [`SensorNoise`]).
//!
//! The attitude is for the time of the last increment ([`InertialAlignment::estimate`]), so a
//! later stage (fine alignment) can continue from it while this one keeps accumulating.

use super::AttitudeEstimate;
use super::kahan::{Kahan, Kahan3};
use crate::coning::ConingSculling;
use crate::{ImuIncrement, InputError, InputLimits, Scalar, attitude, earth};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// Shortest accumulation [s] before an estimate is given. The heading signal `|M_i0|` grows as
/// `T^3`: at 10 s even a navigation-grade IMU (0.002 deg/sqrt(h), 5 ug/sqrt(Hz)) has a heading
/// 1-sigma of 0.65 deg at 45 deg latitude ([`SensorNoise`]).
pub const MIN_DURATION_S: f64 = 10.0;

/// Smallest `cos(latitude)` accepted (about 88.85 deg): the heading signal is proportional to
/// `cos(L)`, and `C_i0_n` is built for a fixed NED frame.
pub const MIN_COS_LAT: f64 = 0.02;

/// Largest relative difference between `|V_b0|` and the reference `|V_i0|` [-]: the mean
/// specific force must be gravity to 2 % (as for [`super::StaticAlignment`]).
pub const GRAVITY_TOLERANCE: f64 = 0.02;

/// Largest relative difference between the heading signal measured (the part of `M_b0` normal to
/// `V_b0`) and the reference one [-]: beyond it the heading would be dominated by noise,
/// disturbance or a gyro that cannot see the Earth rate.
pub const HEADING_SIGNAL_TOLERANCE: f64 = 0.5;

/// Spacing of the snapshots kept for the disturbance check [s].
pub const SNAPSHOT_EVERY_S: f64 = 2.0;

/// Snapshots kept: with [`SNAPSHOT_EVERY_S`] they span the last 14–16 s, longer than a wave or
/// sway period.
pub const SNAPSHOTS: usize = 8;

/// A snapshot's solution may differ from the current one by this many of its own 1-sigma
/// before the base counts as disturbed ([`InertialAlignError::BaseDisturbed`]).
pub const DISTURBANCE_SIGMAS: f64 = 6.0;

/// Why the inertial-frame alignment gave no attitude.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InertialAlignError {
    /// Less than [`MIN_DURATION_S`] accumulated.
    TooShort,
    /// An increment was refused (non-finite, bad interval or out of range): the attitude
    /// integration has a gap, so nothing after it is valid. Start again with
    /// [`InertialAlignment::reset`].
    InputRefused(InputError),
    /// The latitude is not finite or within ~1.15 deg of a pole ([`MIN_COS_LAT`]), or the
    /// height is not finite.
    NearPole,
    /// `|V_b0|` differs from the integral of gravity by more than [`GRAVITY_TOLERANCE`]: the
    /// base accelerated (moved) or the accelerometers are faulty.
    SpecificForceNotGravity,
    /// The heading signal differs from the Earth rate's by more than
    /// [`HEADING_SIGNAL_TOLERANCE`]: too noisy, too disturbed, or the gyros do not resolve the
    /// Earth rate.
    HeadingUnobservable,
    /// The solution is not finite (inputs so large that a sum overflowed).
    NonFinite,
    /// The solutions of the last seconds disagree by more than [`DISTURBANCE_SIGMAS`] of their
    /// noise: a translational disturbance (an unknown lever arm on a rocking ship, waves)
    /// turns the heading by `[6 (|v(0)| + |v(T)|) / T^2 + 12 |dr| / T^3] / (g Omega cos L)`
    /// (module docs, eq. 9), which the 1-sigma does not model. Give the lever arm, or align
    /// longer.
    BaseDisturbed,
}

impl core::fmt::Display for InertialAlignError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort => f.write_str("too short for inertial-frame alignment (< 10 s)"),
            Self::InputRefused(e) => write!(f, "an increment was refused ({e}); restart"),
            Self::NearPole => f.write_str("latitude too close to a pole (or not finite)"),
            Self::SpecificForceNotGravity => {
                f.write_str("integrated specific force is not gravity (base moving?)")
            }
            Self::HeadingUnobservable => f.write_str(
                "Earth-rate heading signal not resolved (noise, disturbance or coarse gyros)",
            ),
            Self::NonFinite => f.write_str("alignment solution not finite"),
            Self::BaseDisturbed => f.write_str(
                "heading unstable over the last seconds: base disturbed (unknown lever arm?)",
            ),
        }
    }
}

impl core::error::Error for InertialAlignError {}

/// White noise and bias levels of the IMU, from which [`InertialAlignment::estimate`] derives
/// its 1-sigma (and with which the fine filters, [`FineConfig`](super::fine::FineConfig) and
/// [`SwayConfig`](super::sway::SwayConfig), are tuned).
///
/// With `w = Omega cos(L)`, `T` the time accumulated (eqs. S1, S2):
/// ```text
/// sigma_yaw^2  = [12 VRW^2 / (g^2 T^3) + (6/5) ARW^2 / T + b_g^2] / w^2 + ARW^2 T + b_g^2 T^2
///                + 72 s_v^2 / (g^2 w^2 T^4)
/// sigma_tilt^2 = VRW^2 / (g^2 T) + ARW^2 T / 3 + (b_a / g)^2 + (b_g T / 2)^2 + 2 s_v^2 / (g T)^2
/// ```
/// The first two yaw terms are the least-squares slope of the north specific force: white
/// accelerometer noise (variance `12 VRW^2 / T^3`, the Cramér–Rao bound itself) and the
/// gyros' attitude random walk (a Wiener process, whose least-squares slope has variance
/// `(6/5) ARW^2 / T`: 1.095x the bound `ARW^2 / T`); `b_g / w` is the east gyro bias' heading
/// error; `ARW^2 T + b_g^2 T^2` the vertical gyro's drift from `b0` to the current time. The
/// tilt is the mean specific force direction (accelerometer noise and bias) propagated from the
/// window's centre to its end (gyro random walk `T/3`, bias `T/2`). With a known lever arm `R`
/// the two end rates' noise adds `s_v^2 = (5/3) ARW^2 |R|^2 / dt` per axis (extrapolation
/// weights `(3, -1)/2`, averaged over axes) to `v_l(0)` and `v_l(T)`: eq. 9 with white `v`.
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
    /// Seed 003's FOG IMU, the fine filters' defaults: gyro white noise 0.003 deg/s RMS at
    /// 400 Hz = 2.618e-6 rad/sqrt(s), accelerometer white noise 0.02 m/s^2 RMS at 400 Hz =
    /// 1e-3 m/s/sqrt(s), gyro bias 0.2 deg/h, accelerometer bias 0.005 m/s^2 (1-sigma per
    /// axis).
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

/// The known lever arm and its velocity terms (eq. 10), in `b0`.
#[derive(Clone, Debug)]
struct LeverArm<T: Scalar> {
    /// IMU position relative to the centre of rotation, body axes [m].
    r_b_m: Vector3<T>,
    /// Body rate over the last interval `w_k` [rad/s].
    omega_last: Option<Vector3<T>>,
    /// Body rate over the interval before `w_{k-1}` [rad/s].
    omega_prev: Option<Vector3<T>>,
    /// Length of the last interval [s].
    dt_last: T,
    /// `v_l(0)` [m/s], once two intervals are known.
    v_l0_b0: Option<Vector3<T>>,
    /// `v_l(t_{k-1})` [m/s], the latest interior value.
    v_l_b0: Vector3<T>,
    /// Trapezoidal `int_0^{t_{k-1}} v_l dt` [m].
    int_v_l_b0: Kahan3<T>,
}

impl<T: Scalar> LeverArm<T> {
    fn new(r_b_m: Vector3<T>) -> Self {
        Self {
            r_b_m,
            omega_last: None,
            omega_prev: None,
            dt_last: T::zero(),
            v_l0_b0: None,
            v_l_b0: Vector3::zeros(),
            int_v_l_b0: Kahan3::new(),
        }
    }

    /// Takes the rate of the interval just ended; `q_b_b0` is the attitude at its start.
    fn add(&mut self, omega_ib_b: Vector3<T>, dt: T, q_b_b0: &UnitQuaternion<T>) {
        if let Some(w_prev) = self.omega_last {
            // v_l at the start of this interval, from the central mean of the rates.
            let v = q_b_b0 * ((w_prev + omega_ib_b) * T::c(0.5)).cross(&self.r_b_m);
            match self.v_l0_b0 {
                None => {
                    // Second interval: v_l(0) by extrapolating back (C_b_b0(0) = I).
                    let v0 = (w_prev * T::c(1.5) - omega_ib_b * T::c(0.5)).cross(&self.r_b_m);
                    self.v_l0_b0 = Some(v0);
                    self.int_v_l_b0
                        .add(&((v0 + v) * (self.dt_last * T::c(0.5))));
                }
                Some(_) => self
                    .int_v_l_b0
                    .add(&((self.v_l_b0 + v) * (self.dt_last * T::c(0.5)))),
            }
            self.v_l_b0 = v;
        }
        self.omega_prev = self.omega_last;
        self.omega_last = Some(omega_ib_b);
        self.dt_last = dt;
    }

    /// `(v_l(T) - v_l(0), T (v_l(T) + v_l(0)) - 2 int_0^T v_l dt)` [m/s], [m]: what eq. 10
    /// takes off `V` and `M`; `q_b_b0` is the attitude now.
    fn corrections(&self, t_s: T, q_b_b0: &UnitQuaternion<T>) -> Option<(Vector3<T>, Vector3<T>)> {
        let (w, w_prev, v0) = (self.omega_last?, self.omega_prev?, self.v_l0_b0?);
        let v_t = q_b_b0 * (w * T::c(1.5) - w_prev * T::c(0.5)).cross(&self.r_b_m);
        let int_v = self.int_v_l_b0.sum() + (self.v_l_b0 + v_t) * (self.dt_last * T::c(0.5));
        Some((v_t - v0, (v_t + v0) * t_s - int_v * T::c(2.0)))
    }
}

/// `(t [s], V_b0 [m/s], M_b0 [m])` at one instant, the lever arm removed.
type Snapshot<T> = (T, Vector3<T>, Vector3<T>);

/// Inertial-frame coarse alignment at a known position (module docs).
///
/// Feed every increment from the start with [`InertialAlignment::add`]; ask for the attitude
/// now with [`InertialAlignment::estimate`] as often as wanted (O(1), no allocation).
#[derive(Clone, Debug)]
pub struct InertialAlignment<T: Scalar> {
    lat_rad: T,
    h_m: T,
    noise: Option<SensorNoise<T>>,
    limits: InputLimits<T>,
    lever: Option<LeverArm<T>>,
    coning: ConingSculling<T>,
    q_b_b0: CompensatedQuat<T>,
    /// `V_b0 = int f_b0 dt` [m/s] (eq. 4).
    v_b0: Kahan3<T>,
    /// `M_b0 = int (2t - T) f_b0 dt` [m] (eq. 5).
    m_b0: Kahan3<T>,
    t_s: Kahan<T>,
    samples: u32,
    refused: Option<InputError>,
    /// `(t, V_b0, M_b0)` every [`SNAPSHOT_EVERY_S`] (lever arm removed), oldest overwritten.
    snapshots: [Option<Snapshot<T>>; SNAPSHOTS],
    next_snapshot: usize,
}

impl<T: Scalar> InertialAlignment<T> {
    /// An empty alignment at geodetic latitude `lat_rad` [rad] and height `h_m` [m] (the
    /// position is known, seed 003); no noise model (1-sigma NaN), default input limits.
    pub fn new(lat_rad: T, h_m: T) -> Self {
        Self {
            lat_rad,
            h_m,
            noise: None,
            limits: InputLimits::default(),
            lever: None,
            coning: ConingSculling::new(),
            q_b_b0: CompensatedQuat::identity(),
            v_b0: Kahan3::new(),
            m_b0: Kahan3::new(),
            t_s: Kahan::new(),
            samples: 0,
            refused: None,
            snapshots: [None; SNAPSHOTS],
            next_snapshot: 0,
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
    /// known position, compensated exactly (module docs, eq. 10; seed 002's ship lever arm).
    pub fn with_lever_arm(mut self, r_b_m: Vector3<T>) -> Self {
        self.lever = Some(LeverArm::new(r_b_m));
        self
    }

    /// Starts again from the next increment (same position, noise model, limits and lever arm).
    pub fn reset(&mut self) {
        *self = Self {
            noise: self.noise,
            limits: self.limits,
            lever: self.lever.as_ref().map(|l| LeverArm::new(l.r_b_m)),
            ..Self::new(self.lat_rad, self.h_m)
        };
    }

    /// Adds the next increment (eqs. 2, 3, 6). A refused one (see [`ImuIncrement::check`]) is
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
        // Eq. 3 with the attitude at the start of the interval (`hi` is unit to the working
        // precision; its rounding is not accumulated).
        let q_b_b0 = UnitQuaternion::new_unchecked(self.q_b_b0.hi);
        let dv_b0 = q_b_b0.transform_vector(&c.delta_v_b);
        if let Some(l) = &mut self.lever {
            l.add(inc.delta_theta_ib_b / inc.dt, inc.dt, &q_b_b0);
        }
        // Eq. 6, before V and T advance.
        self.m_b0
            .add(&(dv_b0 * self.t_s.sum - self.v_b0.sum() * inc.dt));
        self.v_b0.add(&dv_b0);
        let t_before = self.t_s.sum;
        self.t_s.add(inc.dt);
        self.q_b_b0.rotate(&c.phi_b);
        self.samples = self.samples.saturating_add(1);
        // A snapshot whenever t crosses a multiple of SNAPSHOT_EVERY_S.
        let every = T::c(SNAPSHOT_EVERY_S);
        if (self.t_s.sum / every).floor() > (t_before / every).floor()
            && let Some((v, m)) = self.corrected(self.t_s.sum, &self.q_b_b0.unit())
        {
            let k = self.next_snapshot % SNAPSHOTS;
            self.snapshots[k] = Some((self.t_s.sum, v, m));
            self.next_snapshot = (k + 1) % SNAPSHOTS;
        }
        Ok(())
    }

    /// `(V_b0, M_b0)` at `t_s` with the known lever arm's share removed (eq. 10); `None` while
    /// the lever arm has fewer than two intervals.
    fn corrected(&self, t_s: T, q_b_b0: &UnitQuaternion<T>) -> Option<(Vector3<T>, Vector3<T>)> {
        let (mut v_b0, mut m_b0) = (self.v_b0.sum(), self.m_b0.sum());
        if let Some(l) = &self.lever {
            let (dv, dm) = l.corrections(t_s, q_b_b0)?;
            v_b0 -= dv;
            m_b0 -= dm;
        }
        Some((v_b0, m_b0))
    }

    /// The attitude at the end of the last increment levelled on the mean specific force
    /// (`V_b0`, the known lever arm's share removed), with an arbitrary azimuth: `q_b_c` for a
    /// level frame `c` (the fine filters' start, [`super::fine`]). The vertical is the window's
    /// mean one, so it is off by up to `Omega T` (the Earth's turn) plus what the base's
    /// translation leaves in `V`; `None` before two intervals or without a specific force.
    pub fn level(&self) -> Option<UnitQuaternion<T>> {
        let q_b_b0 = self.q_b_b0.unit();
        let (v_b0, _) = self.corrected(self.t_s.sum, &q_b_b0)?;
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

    /// The reference vectors `(V_i0, M_i0)` [m/s], [m] after `t_s` [s] (eq. 7).
    pub fn reference(&self, t_s: T) -> (Vector3<T>, Vector3<T>) {
        let (sin_lat, cos_lat) = (self.lat_rad.psin(), self.lat_rad.pcos());
        let g = earth::normal_gravity(self.lat_rad, self.h_m);
        let u = Vector3::new(cos_lat, T::zero(), -sin_lat);
        let f_n = Vector3::new(T::zero(), T::zero(), -g);
        let f_par = u * (g * sin_lat);
        let f_perp = f_n - f_par;
        let east = Vector3::new(T::zero(), g * cos_lat, T::zero());
        let k = cone_terms(T::c(earth::OMEGA_IE) * t_s);
        let v_i0 = (f_par + f_perp * k.sinc + east * k.cosc) * t_s;
        let m_i0 = (f_perp * k.a + east * k.b) * (t_s * t_s);
        (v_i0, m_i0)
    }

    /// The attitude at the end of the last increment, with its 1-sigma if a noise model was
    /// given (eqs. 1, 7, 8; [`SensorNoise`]), or why there is none.
    pub fn estimate(&self) -> Result<AttitudeEstimate<T>, InertialAlignError> {
        if let Some(e) = self.refused {
            return Err(InertialAlignError::InputRefused(e));
        }
        let t_s = self.t_s.sum;
        if self.samples == 0 || !t_s.finite() || t_s < T::c(MIN_DURATION_S) {
            return Err(InertialAlignError::TooShort);
        }
        let cos_lat = self.lat_rad.pcos();
        if !cos_lat.finite() || cos_lat < T::c(MIN_COS_LAT) || !self.h_m.finite() {
            return Err(InertialAlignError::NearPole);
        }
        let q_b_b0 = self.q_b_b0.unit();
        // Eq. 10 (at least two intervals: MIN_DURATION_S has passed).
        let (v_b0, m_b0) = self
            .corrected(t_s, &q_b_b0)
            .ok_or(InertialAlignError::TooShort)?;
        let c_b0_i0 = self.solve(&v_b0, &m_b0, t_s)?;
        self.check_disturbance(&c_b0_i0, t_s, cos_lat)?;
        let q_b0_i0 =
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(c_b0_i0));
        // C_n_i0(T): the NED frame turned by Omega T about the polar axis since the start.
        let half = T::c(0.5 * earth::OMEGA_IE) * t_s;
        let (sh, ch) = (half.psin(), half.pcos());
        let sin_lat = self.lat_rad.psin();
        let q_n_i0 = UnitQuaternion::new_unchecked(Quaternion::new(
            ch,
            cos_lat * sh,
            T::zero(),
            -sin_lat * sh,
        ));
        // Eq. 1.
        let q_b_n = q_n_i0.inverse() * q_b0_i0 * q_b_b0;
        if !q_b_n.coords.iter().all(|x| x.finite()) {
            return Err(InertialAlignError::NonFinite);
        }
        Ok(AttitudeEstimate {
            q_b_n,
            sigma_rad: self.sigma(t_s, cos_lat),
            elapsed_s: t_s,
        })
    }

    /// `C_b0_i0` from `V_b0`, `M_b0` after `t_s` [s] (eqs. 7, 8), or why not.
    fn solve(
        &self,
        v_b0: &Vector3<T>,
        m_b0: &Vector3<T>,
        t_s: T,
    ) -> Result<Matrix3<T>, InertialAlignError> {
        let (v_i0, m_i0) = self.reference(t_s);
        if !(v_b0.iter().chain(m_b0.iter()).all(|x| x.finite())) {
            return Err(InertialAlignError::NonFinite);
        }
        let (nv_b0, nv_i0) = (v_b0.norm(), v_i0.norm());
        if (nv_b0 - nv_i0).abs() > T::c(GRAVITY_TOLERANCE) * nv_i0 {
            return Err(InertialAlignError::SpecificForceNotGravity);
        }
        // Eq. 8: TRIAD frames; the heading signal is the part of M normal to V.
        let (a1_b0, a1_i0) = (v_b0 / nv_b0, v_i0 / nv_i0);
        let (c_b0, c_i0) = (a1_b0.cross(m_b0), a1_i0.cross(&m_i0));
        let (nc_b0, nc_i0) = (c_b0.norm(), c_i0.norm());
        if (nc_b0 - nc_i0).abs() > T::c(HEADING_SIGNAL_TOLERANCE) * nc_i0 {
            return Err(InertialAlignError::HeadingUnobservable);
        }
        let triad =
            |a1: Vector3<T>, a2: Vector3<T>| Matrix3::from_columns(&[a1, a2, a1.cross(&a2)]);
        Ok(triad(a1_i0, c_i0 / nc_i0) * triad(a1_b0, c_b0 / nc_b0).transpose())
    }

    /// The disturbance check: the constant `C_b0_i0` solved from each snapshot of the last
    /// [`SNAPSHOTS`] x [`SNAPSHOT_EVERY_S`] seconds must agree about the vertical with the
    /// current one within [`DISTURBANCE_SIGMAS`] of the snapshot's own heading 1-sigma. With
    /// noise only, the solutions share most of their data and differ by about one sigma; an
    /// endpoint disturbance velocity (eq. 9) swings the heading as it oscillates. Needs a noise
    /// model (without one there is no scale: no check).
    fn check_disturbance(
        &self,
        c_b0_i0: &Matrix3<T>,
        t_s: T,
        cos_lat: T,
    ) -> Result<(), InertialAlignError> {
        if self.noise.is_none() {
            return Ok(());
        }
        for (t_k, v_k, m_k) in self.snapshots.iter().flatten() {
            if *t_k < T::c(MIN_DURATION_S) || *t_k > t_s - T::c(0.5 * SNAPSHOT_EVERY_S) {
                continue;
            }
            let Ok(c_k) = self.solve(v_k, m_k, *t_k) else {
                return Err(InertialAlignError::BaseDisturbed);
            };
            // The rotation from the current solution to the snapshot's, about the i0 vertical.
            let r = Rotation3::from_matrix_unchecked(c_k * c_b0_i0.transpose());
            let d_yaw = r.scaled_axis().z.abs();
            let sigma_k = self.sigma(*t_k, cos_lat).z;
            if d_yaw > T::c(DISTURBANCE_SIGMAS) * sigma_k {
                return Err(InertialAlignError::BaseDisturbed);
            }
        }
        Ok(())
    }

    /// Roll, pitch, yaw 1-sigma [rad] after `t_s` [s] (eqs. S1, S2 of [`SensorNoise`]); NaN
    /// without a noise model.
    fn sigma(&self, t_s: T, cos_lat: T) -> Vector3<T> {
        let Some(n) = self.noise else {
            return Vector3::repeat(T::c(f64::NAN));
        };
        let g = earth::normal_gravity(self.lat_rad, self.h_m);
        let w = T::c(earth::OMEGA_IE) * cos_lat;
        let (arw2, vrw2) = (
            n.arw_rad_per_sqrt_s * n.arw_rad_per_sqrt_s,
            n.vrw_mps_per_sqrt_s * n.vrw_mps_per_sqrt_s,
        );
        let (bg2, ba2) = (
            n.gyro_bias_rad_s * n.gyro_bias_rad_s,
            n.accel_bias_mps2 * n.accel_bias_mps2,
        );
        let (g2, t2) = (g * g, t_s * t_s);
        // Lever-arm end-rate noise s_v^2 [m^2/s^2].
        let sv2 = self.lever.as_ref().map_or(T::zero(), |l| {
            T::c(5.0 / 3.0) * arw2 * l.r_b_m.norm_squared() / l.dt_last
        });
        let yaw2 = (T::c(12.0) * vrw2 / (g2 * t2 * t_s) + T::c(1.2) * arw2 / t_s + bg2) / (w * w)
            + arw2 * t_s
            + bg2 * t2
            + T::c(72.0) * sv2 / (g2 * w * w * t2 * t2);
        let tilt2 = vrw2 / (g2 * t_s)
            + arw2 * t_s / T::c(3.0)
            + ba2 / g2
            + bg2 * t2 / T::c(4.0)
            + T::c(2.0) * sv2 / (g2 * t2);
        Vector3::new(tilt2.sqrt(), tilt2.sqrt(), yaw2.sqrt())
    }
}

/// The functions of `x = Omega T` in eq. 7.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ConeTerms<T: Scalar> {
    /// `sin(x)/x`.
    sinc: T,
    /// `(1 - cos x)/x`.
    cosc: T,
    /// `(x sin x - 2 (1 - cos x))/x^2 = -x^2/12 + x^4/180 - ...`.
    a: T,
    /// `(2 sin x - x - x cos x)/x^2 = x/6 - x^3/40 + ...`.
    b: T,
}

/// [`ConeTerms`] of `x` [rad]: Taylor series for `|x| < 1` (12 terms: the first omitted is below
/// `x^24 / 24!`), the closed forms beyond (an alignment of more than 3.8 h).
fn cone_terms<T: Scalar>(x: T) -> ConeTerms<T> {
    let x2 = x * x;
    if x.abs() < T::one() {
        // sinc = sum (-1)^k x^2k / (2k+1)!;  cosc / x = sum_{k>=1} (-1)^(k-1) x^(2k-2) / (2k)!;
        // a = sum_{m>=1} (-1)^m 2m x^2m / (2m+2)!;  b / x = sum_{k>=1} (-1)^(k+1) (2k-1) x^(2k-2) / (2k+1)!.
        let (mut sinc, mut cosc, mut a, mut b) = (T::zero(), T::zero(), T::zero(), T::zero());
        let mut p = T::one(); // (-1)^k x^2k
        let mut fact = T::one(); // (2k)!
        for k in 0..12u32 {
            let kf = T::c(f64::from(k));
            let f1 = fact * (T::c(2.0) * kf + T::one()); // (2k+1)!
            let f2 = f1 * (T::c(2.0) * kf + T::c(2.0)); // (2k+2)!
            sinc += p / f1;
            cosc += p / f2;
            a += p * T::c(2.0) * kf / f2;
            // b: index k+1 of the series above, (2(k+1)-1) p / (2k+3)!
            let f3 = f2 * (T::c(2.0) * kf + T::c(3.0));
            b += p * (T::c(2.0) * kf + T::one()) / f3;
            p = -p * x2;
            fact = f2;
        }
        ConeTerms {
            sinc,
            cosc: cosc * x,
            a,
            b: b * x,
        }
    } else {
        let (s, c) = (x.psin(), x.pcos());
        let half = (x * T::c(0.5)).psin();
        let one_minus_cos = T::c(2.0) * half * half;
        ConeTerms {
            sinc: s / x,
            cosc: one_minus_cos / x,
            a: (x * s - T::c(2.0) * one_minus_cos) / x2,
            b: (T::c(2.0) * s - x - x * c) / x2,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::{euler, from_euler};

    /// Exact increments of a body at rest at `roll, pitch, yaw` [rad], latitude `lat` [rad]:
    /// the body rate and specific force are constant, so the increments are too.
    fn static_inc(roll: f64, pitch: f64, yaw: f64, lat: f64, dt: f64) -> ImuIncrement<f64> {
        let q_n_b = from_euler(roll, pitch, yaw).inverse();
        let dtheta = q_n_b * earth::omega_ie_n(lat) * dt;
        let dv = q_n_b * Vector3::new(0.0, 0.0, -earth::normal_gravity(lat, 0.0)) * dt;
        ImuIncrement {
            delta_theta_ib_b: dtheta,
            delta_v_ib_b: dv,
            dt,
        }
    }

    fn run<T: Scalar>(inc: &ImuIncrement<f64>, lat: f64, n: u32) -> InertialAlignment<T> {
        let inc = ImuIncrement {
            delta_theta_ib_b: inc.delta_theta_ib_b.map(T::c),
            delta_v_ib_b: inc.delta_v_ib_b.map(T::c),
            dt: T::c(inc.dt),
        };
        let mut a = InertialAlignment::new(T::c(lat), T::zero());
        for _ in 0..n {
            a.add(&inc).unwrap();
        }
        a
    }

    fn wrap(a: f64) -> f64 {
        libm::remainder(a, 2.0 * core::f64::consts::PI)
    }

    #[test]
    fn cone_terms_series_match_closed_forms() {
        // Where both are accurate (x about 1, little cancellation) they agree; the series'
        // leading terms are the hand-derived ones.
        for x in [0.3_f64, 0.7, 0.999] {
            let s = cone_terms(x);
            let d = ConeTerms {
                sinc: x.sin() / x,
                cosc: (1.0 - x.cos()) / x,
                a: (x * x.sin() - 2.0 * (1.0 - x.cos())) / (x * x),
                b: (2.0 * x.sin() - x - x * x.cos()) / (x * x),
            };
            for (u, v) in [(s.sinc, d.sinc), (s.cosc, d.cosc), (s.a, d.a), (s.b, d.b)] {
                assert!((u - v).abs() < 1e-13, "{x}: {u} {v}");
            }
        }
        // Continuous where the evaluation switches.
        let (below, above) = (cone_terms(1.0 - 1e-12_f64), cone_terms(1.0 + 1e-12_f64));
        for (u, v) in [
            (below.sinc, above.sinc),
            (below.cosc, above.cosc),
            (below.a, above.a),
            (below.b, above.b),
        ] {
            // The functions' slopes are below 1: 2e-12 apart, they differ by less than that.
            assert!((u - v).abs() < 3e-12, "{u} {v}");
        }
        let x = 1e-3_f64;
        let s = cone_terms(x);
        assert!((s.a / (-x * x / 12.0) - 1.0).abs() < 1e-6);
        assert!((s.b / (x / 6.0) - 1.0).abs() < 1e-6);
        let big = cone_terms(1.5_f64);
        assert!((big.sinc - 1.5f64.sin() / 1.5).abs() < 1e-15);
    }

    #[test]
    fn reference_matches_numerical_integration() {
        // V_i0 and M_i0 against a fine midpoint rule over the rotating gravity vector.
        let a = InertialAlignment::<f64>::new(0.7, 100.0);
        let t_end = 600.0;
        let n = 60_000;
        let h = t_end / f64::from(n);
        let lat: f64 = 0.7;
        let u = Vector3::new(lat.cos(), 0.0, -lat.sin());
        let f_n = Vector3::new(0.0, 0.0, -earth::normal_gravity(lat, 100.0));
        let (mut v, mut m) = (Vector3::zeros(), Vector3::zeros());
        for k in 0..n {
            let t = (f64::from(k) + 0.5) * h;
            let f = UnitQuaternion::from_scaled_axis(u * (earth::OMEGA_IE * t)) * f_n;
            v += f * h;
            m += f * ((2.0 * t - t_end) * h);
        }
        let (v_i0, m_i0) = a.reference(t_end);
        assert!((v - v_i0).norm() < 1e-9 * v.norm(), "{v} {v_i0}");
        // Midpoint error h^2/24 int g'' dt for g = (2t - T) f, dominated by
        // 4 |f(T) - f(0)| h^2 / 24 = 4 g cos(L) x h^2 / 24 = 5.3e-6 m (x = Omega T = 0.044).
        assert!((m - m_i0).norm() < 1e-5, "{m} {m_i0}");
        assert!(m_i0.y > 0.0 && m_i0.y.abs() > 50.0 * m_i0.x.abs());
    }

    #[test]
    fn recovers_attitude_from_exact_static_data() {
        let lat = 45f64.to_radians();
        for &(r, p, y) in &[(0.02, -0.01, 1.0), (-0.5, 0.3, -2.5), (0.0, 0.0, 3.0)] {
            let inc = static_inc(r, p, y, lat, 0.0025);
            let est = run::<f64>(&inc, lat, 24_000).estimate().unwrap();
            let (r2, p2, y2) = euler(&est.q_b_n);
            assert!((r2 - r).abs() < 1e-9 && (p2 - p).abs() < 1e-9, "{r2} {p2}");
            assert!(wrap(y2 - y).abs() < 1e-8, "{y2} vs {y}");
            assert!(est.sigma_rad.iter().all(|s| s.is_nan()));
            assert_eq!(est.elapsed_s, 60.0);
            // f32: the compensated quaternion keeps the Earth rate (3x f32's unit roundoff per
            // 1.8e-7 rad increment would otherwise be lost); see the host test for the bound.
            let est32 = run::<f32>(&inc, lat, 24_000).estimate().unwrap();
            let (r3, p3, y3) = euler(&est32.q_b_n);
            assert!((f64::from(r3) - r).abs() < 1e-5 && (f64::from(p3) - p).abs() < 1e-5);
            assert!(wrap(f64::from(y3) - y).abs() < 1e-3, "{y3} vs {y}");
        }
    }

    #[test]
    fn refuses_clearly() {
        let lat = 45f64.to_radians();
        let inc = static_inc(0.1, 0.2, 0.3, lat, 0.01);
        assert_eq!(
            InertialAlignment::<f64>::new(lat, 0.0).estimate(),
            Err(InertialAlignError::TooShort)
        );
        assert_eq!(
            run::<f64>(&inc, lat, 999).estimate(),
            Err(InertialAlignError::TooShort)
        );
        assert!(run::<f64>(&inc, lat, 1000).estimate().is_ok());
        // Position wrong for the data, near a pole or not finite.
        let mut a = run::<f64>(&inc, lat, 1000);
        a.lat_rad = 89.5f64.to_radians();
        assert_eq!(a.estimate(), Err(InertialAlignError::NearPole));
        a.lat_rad = f64::NAN;
        assert_eq!(a.estimate(), Err(InertialAlignError::NearPole));
        // A non-finite increment is refused and latched until reset.
        let mut a = run::<f64>(&inc, lat, 1000);
        let mut bad = inc;
        bad.delta_v_ib_b.x = f64::NAN;
        assert_eq!(a.add(&bad), Err(InputError::NonFinite));
        assert_eq!(
            a.estimate(),
            Err(InertialAlignError::InputRefused(InputError::NonFinite))
        );
        a.reset();
        assert_eq!(a.samples(), 0);
        for _ in 0..1000 {
            a.add(&inc).unwrap();
        }
        assert!(a.estimate().is_ok());
        // Accelerating: 3 m/s^2 along x on top of gravity (|f| 4.5 % above g).
        let mut push = inc;
        push.delta_v_ib_b.x += 3.0 * inc.dt;
        assert_eq!(
            run::<f64>(&push, lat, 1000).estimate(),
            Err(InertialAlignError::SpecificForceNotGravity)
        );
        // Gyros that do not see the Earth rate (no heading signal), or that see 3x of it.
        for k in [0.0, 3.0] {
            let mut blind = inc;
            blind.delta_theta_ib_b *= k;
            assert_eq!(
                run::<f64>(&blind, lat, 6000).estimate(),
                Err(InertialAlignError::HeadingUnobservable),
                "{k}"
            );
        }
        // Overflowing input: refused by the limits, never a panic.
        let mut huge = inc;
        huge.delta_v_ib_b.z = f64::MAX;
        let mut a = InertialAlignment::<f64>::new(lat, 0.0);
        assert_eq!(a.add(&huge), Err(InputError::OutOfRange));
    }

    #[test]
    fn sigma_follows_the_documented_formula() {
        let lat = 45f64.to_radians();
        let inc = static_inc(0.0, 0.0, 0.0, lat, 0.01);
        let noise = SensorNoise {
            arw_rad_per_sqrt_s: 2.618e-6,
            vrw_mps_per_sqrt_s: 1e-3,
            gyro_bias_rad_s: 0.0,
            accel_bias_mps2: 0.0,
        };
        let mut a = InertialAlignment::new(lat, 0.0).with_noise(noise);
        for _ in 0..30_000 {
            a.add(&inc).unwrap();
        }
        let s = a.estimate().unwrap().sigma_rad;
        // 300 s at 45 deg: accelerometer term 1.318e-3 rad, gyro term sqrt(1.2) x 2.932e-3 rad.
        let expect = (1.318e-3f64.powi(2) + 1.2 * 2.932e-3f64.powi(2)).sqrt();
        assert!((s.z / expect - 1.0).abs() < 2e-3, "{} {expect}", s.z);
        assert!(s.x == s.y && s.x > 0.0);
    }
}
