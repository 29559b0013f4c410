//! The scalar type the navigation code is generic over: `f32` on the MCU, `f64` on the host.

use fixed::traits::{FromFixed, ToFixed};
use nalgebra::RealField;

/// A floating-point scalar usable by every nav-core algorithm.
///
/// Implemented for `f32` and `f64`. Constants are written in `f64` and rounded once with
/// [`Scalar::c`], so both precisions share one source of truth.
pub trait Scalar: RealField + Copy + ToFixed + FromFixed {
    /// Converts an `f64` constant to this scalar (rounding to nearest).
    fn c(x: f64) -> Self;
    /// Widens (or keeps) this value as `f64`, exactly.
    fn to_f64(self) -> f64;
    /// `true` when the value is neither NaN nor infinite.
    fn finite(self) -> bool;
    /// Largest squared rotation angle [rad^2] for which the series of
    /// [`crate::attitude::rotation_vector_quat`] (to the 6th power) is exact to this precision:
    /// the first omitted term is `x^8 / 10321920` relative.
    const ROTATION_SERIES_MAX2: f64;
}

impl Scalar for f32 {
    // x = 0.5 rad: 3.8e-10 < 6e-8 (f32 epsilon / 2); covers 2000 deg/s at 400 Hz.
    const ROTATION_SERIES_MAX2: f64 = 0.25;
    #[inline]
    fn c(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
}

impl Scalar for f64 {
    // x = 0.05 rad: 3.8e-18 < 1.1e-16.
    const ROTATION_SERIES_MAX2: f64 = 0.0025;
    #[inline]
    fn c(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
}
