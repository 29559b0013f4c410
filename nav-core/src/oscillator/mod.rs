//! Gyro-free attitude and specific force from a spatial isotropic oscillator ([Oscillator INS]).
//!
//! A mass on three orthogonal springs of equal stiffness, free of other forces, moves on an
//! ellipse `rho(t) = c + p cos(w0 t) + q sin(w0 t)` that keeps its orientation in inertial space
//! however the case turns; its centre sits at `c = -f_ib/w0^2`. Read in body axes, the ellipse's
//! axes are the columns of the body-to-inertial rotation (eq. 2.7–2.11), and its centre is the
//! specific force: a strapdown system without gyros and without Poisson's equation.
//!
//! The estimator ([`OscillatorEstimator`]) follows eq. (2.16)–(2.18):
//!
//! 1. a reference generator at the oscillator frequency cuts the readouts into periods; each
//!    period is fitted for the cosine and sine components `a`, `b` and the centre
//!    ([`window`], eq. 2.16);
//! 2. a phase-locked loop on the generator drives `a . b` to zero (eq. 2.17), so `a`, `b` become
//!    the semi-axes; what is left of the phase is removed in closed form ([`ellipse`]);
//! 3. `A = [a/|a|, b/|b|, a x b/|a x b|]` (eq. 2.18) gives `C_b_e`, the body's attitude relative
//!    to the ellipse frame `e` (fixed in inertial space); `f_ib_b = -w0^2 c`.
//!
//! Beyond [Oscillator INS]: the paper takes the attitude as constant over a period, which leaves
//! errors of first order in `omega/w0` (the body turns by `2 pi omega/w0` per period). With
//! [`OscillatorConfig::compensate`] each period's readouts are rotated back to its reference
//! instant by the body rate, which the estimator measures from its own successive attitudes, and
//! the centre gets a trend; the error drops to the series' remainder and the noise.
//!
//! The ellipse fixes the inertial frame up to a half-turn about its normal (which apse is "`+p`");
//! the estimator keeps the apse it first locked on, and counts a slip if the loop jumps to the
//! other one. [`increments`] turns the epochs into [`crate::ImuIncrement`]s for the
//! mechanization.

pub mod ellipse;
mod estimator;
pub mod increments;
pub mod window;

pub use estimator::{OscillatorCounters, OscillatorEstimator};
pub use increments::OscillatorIncrements;

use crate::Scalar;
use nalgebra::{UnitQuaternion, Vector3};

/// Settings of the estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OscillatorConfig<T: Scalar> {
    /// Readout rate [Hz].
    pub sample_rate_hz: f64,
    /// Nominal natural frequency [Hz]: where the generator starts.
    pub f0_hz: f64,
    /// Time of the first readout [s] (epochs are tagged on this clock).
    pub start_s: f64,
    /// Rotate each period back by the measured body rate and fit the centre's trend (default);
    /// `false` is the method of [Oscillator INS] as written (attitude constant over a period).
    pub compensate: bool,
    /// Below this `Q/P` the ellipse is a near-line [-] (default 0.05).
    pub min_axis_ratio: T,
    /// Above this `Q/P` it is a near-circle [-] (default 0.95).
    pub max_axis_ratio: T,
    /// Largest accepted 1-sigma of any of the three angles [rad] (default 0.01): a weak or noisy
    /// oscillation is refused.
    pub max_sigma_rad: T,
    /// A period counts towards lock when the generator phase error is below this [rad]
    /// (default 0.005).
    pub lock_rad: T,
    /// Consecutive periods within `lock_rad` before epochs are given out (default 8).
    pub lock_periods: u32,
    /// Loop gains per period: phase (proportional) and frequency (integral); defaults 0.5 and
    /// 0.1 put both closed-loop poles at radius 0.77 (`z^2 - (2 - kp) z + 1 - kp + ki`).
    pub pll_kp: f64,
    /// Integral gain [-].
    pub pll_ki: f64,
}

impl<T: Scalar> OscillatorConfig<T> {
    /// Defaults for an oscillator at `f0_hz` read at `sample_rate_hz`.
    pub fn new(sample_rate_hz: f64, f0_hz: f64) -> Self {
        Self {
            sample_rate_hz,
            f0_hz,
            start_s: 0.0,
            compensate: true,
            min_axis_ratio: T::c(0.05),
            max_axis_ratio: T::c(0.95),
            max_sigma_rad: T::c(0.01),
            lock_rad: T::c(0.005),
            lock_periods: 8,
            pll_kp: 0.5,
            pll_ki: 0.1,
        }
    }

    /// Checks the settings.
    pub fn validate(&self) -> Result<(), OscillatorConfigError> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if !ok(self.f0_hz) {
            return Err(OscillatorConfigError::Frequency);
        }
        if !ok(self.sample_rate_hz) || self.sample_rate_hz < 8.0 * self.f0_hz {
            return Err(OscillatorConfigError::SampleRate);
        }
        let (lo, hi) = (self.min_axis_ratio, self.max_axis_ratio);
        if !(lo.finite() && hi.finite() && lo > T::zero() && lo < hi && hi < T::one())
            || !(self.max_sigma_rad.finite() && self.max_sigma_rad > T::zero())
            || !(self.lock_rad.finite() && self.lock_rad > T::zero())
        {
            return Err(OscillatorConfigError::Thresholds);
        }
        let (kp, ki) = (self.pll_kp, self.pll_ki);
        // Jury's conditions for z^2 - (2 - kp) z + (1 - kp + ki): both poles inside the circle.
        let c0 = 1.0 - kp + ki;
        let stable = ki > 0.0 && c0.abs() < 1.0 && 4.0 - 2.0 * kp + ki > 0.0;
        if !(kp.is_finite() && ki.is_finite() && stable) {
            return Err(OscillatorConfigError::Loop);
        }
        if !self.start_s.is_finite() {
            return Err(OscillatorConfigError::Start);
        }
        Ok(())
    }
}

/// Why a configuration is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OscillatorConfigError {
    /// The natural frequency is not a positive number.
    Frequency,
    /// The readout rate is not at least 8 times the natural frequency.
    SampleRate,
    /// Axis-ratio, sigma or lock thresholds out of range.
    Thresholds,
    /// Loop gains that do not give a stable loop.
    Loop,
    /// The start time is not finite.
    Start,
}

impl core::fmt::Display for OscillatorConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Frequency => "the natural frequency must be a positive number",
            Self::SampleRate => "the readout rate must be at least 8 times the natural frequency",
            Self::Thresholds => {
                "thresholds must satisfy 0 < min axis ratio < max axis ratio < 1 and be positive"
            }
            Self::Loop => {
                "the loop gains must give a stable loop (0 < ki < kp < 2 + ki, 4 - 2 kp + ki > 0)"
            }
            Self::Start => "the start time must be finite",
        })
    }
}

/// The attitude and specific force of one oscillator period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OscillatorEpoch<T: Scalar> {
    /// Reference instant [s]: the generator's mid-period, where the attitude holds.
    pub t_s: f64,
    /// Body-to-ellipse-frame rotation `C_b_e` (the ellipse frame is fixed in inertial space).
    pub q_b_e: UnitQuaternion<T>,
    /// Specific force `-w0^2 c` [m/s^2], body axes.
    pub f_ib_b: Vector3<T>,
    /// Body rate the period was rotated back with [rad/s] (0 without compensation).
    pub omega_ib_b: Vector3<T>,
    /// 1-sigma of the rotation about the ellipse axes `e1`, `e2`, `e3` [rad] from the fit's
    /// residual (see [`ellipse`]).
    pub sigma_rad: Vector3<T>,
    /// 1-sigma of each specific-force component [m/s^2].
    pub sigma_f_mps2: T,
    /// Semi-axes `P`, `Q` [m].
    pub semi_axes_m: (T, T),
    /// Generator phase error left this period [rad].
    pub delta_rad: T,
    /// The generator's frequency, the oscillator's measured natural frequency [Hz].
    pub frequency_hz: f64,
}

/// Why a period gives no attitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OscillatorFault {
    /// The loop has not locked yet (phase error [rad]).
    Acquiring {
        /// Generator phase error [rad].
        delta_rad: f64,
    },
    /// The loop was locked and the phase error jumped (the oscillation was disturbed).
    LostLock {
        /// Generator phase error [rad].
        delta_rad: f64,
    },
    /// `Q/P` below the threshold: the rotation about the major axis is unobservable.
    NearLine {
        /// `Q/P` [-].
        axis_ratio: f64,
    },
    /// `Q/P` above the threshold: the in-plane angle is undefined.
    NearCircle {
        /// `Q/P` [-].
        axis_ratio: f64,
    },
    /// An angle's 1-sigma exceeds the limit (weak oscillation or noisy readout).
    Noisy {
        /// The largest 1-sigma [rad].
        sigma_rad: f64,
    },
    /// The specific force the ellipse's centre gives is beyond any IMU's range (an axis above
    /// [`crate::increment::InputLimits`]'s 50 g): readouts in another unit than metres (mm
    /// gave 1000 g on a still base), or a wrong natural frequency.
    ForceBeyondRange {
        /// The largest axis [m/s^2].
        f_mps2: f64,
    },
    /// A readout in the period was missing or not finite.
    Broken,
    /// Too few readouts for the fit.
    Singular,
}

impl OscillatorFault {
    /// A short name of the kind (for counts and logs).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Acquiring { .. } => "acquiring",
            Self::LostLock { .. } => "lost lock",
            Self::NearLine { .. } => "near-line",
            Self::NearCircle { .. } => "near-circle",
            Self::Noisy { .. } => "noisy",
            Self::ForceBeyondRange { .. } => "force beyond range",
            Self::Broken => "broken",
            Self::Singular => "singular",
        }
    }
}

impl core::fmt::Display for OscillatorFault {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Acquiring { delta_rad } => {
                write!(f, "acquiring: generator phase error {delta_rad:.3} rad")
            }
            Self::LostLock { delta_rad } => {
                write!(f, "lost lock: generator phase error {delta_rad:.3} rad")
            }
            Self::NearLine { axis_ratio } => write!(
                f,
                "near-linear ellipse (Q/P = {axis_ratio:.4}): rotation about its axis unobservable"
            ),
            Self::NearCircle { axis_ratio } => write!(
                f,
                "near-circular ellipse (Q/P = {axis_ratio:.4}): in-plane angle undefined"
            ),
            Self::Noisy { sigma_rad } => {
                write!(f, "noisy oscillation: angle 1-sigma {sigma_rad:.2e} rad")
            }
            Self::ForceBeyondRange { f_mps2 } => write!(
                f,
                "specific force {f_mps2:.3e} m/s^2 beyond 50 g: readouts in another unit than metres, or a wrong natural frequency"
            ),
            Self::Broken => f.write_str("a readout in the period was missing or not finite"),
            Self::Singular => f.write_str("too few readouts in the period"),
        }
    }
}

#[cfg(test)]
mod tests;
