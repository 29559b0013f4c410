//! The scalar type the navigation code is generic over: `f32` on the MCU, `f64` on the host.
//!
//! Transcendental functions go through [`Scalar::psin`] and friends, which call the `libm` crate
//! directly: nalgebra's own `sin` & co. go through `num-traits`, whose `std` feature (switched on
//! by any crate in a host build, e.g. proptest) replaces them with the host C library's, which
//! can differ by an ulp and would break the firmware/harness bit-identity.

use fixed::traits::{FromFixed, ToFixed};
use nalgebra::{ArrayStorage, RealField, SMatrix};

/// A floating-point scalar usable by every nav-core algorithm.
///
/// Implemented for `f32` and `f64`. Constants are written in `f64` and rounded once with
/// [`Scalar::c`], so both precisions share one source of truth.
pub trait Scalar: RealField + Copy + ToFixed + FromFixed {
    /// Converts an `f64` constant to this scalar (rounding to nearest).
    fn c(x: f64) -> Self;
    /// Widens (or keeps) this value as `f64`, exactly.
    fn to_f64(self) -> f64;
    /// Takes a sensor's `f32` value, exactly (the same bits in `f32`, widened in `f64`).
    fn of_f32(x: f32) -> Self;
    /// `true` when the value is neither NaN nor infinite.
    fn finite(self) -> bool;
    /// `sin` from the `libm` crate: the same bits on every target (see the module docs).
    fn psin(self) -> Self;
    /// `cos` from the `libm` crate.
    fn pcos(self) -> Self;
    /// `atan2(self, x)` from the `libm` crate.
    fn patan2(self, x: Self) -> Self;
    /// `asin` from the `libm` crate.
    fn pasin(self) -> Self;
    /// Largest squared rotation angle [rad^2] for which the series of
    /// [`crate::attitude::rotation_vector_quat`] (to the 6th power) is exact to this precision:
    /// the first omitted term is `x^8 / 10321920` relative.
    const ROTATION_SERIES_MAX2: f64;
    /// Zero, for `const` values (nalgebra's `zero()` is not `const`).
    const ZERO: Self;
}

/// The zero matrix in a `const` (nalgebra's `zeros()` is not `const`): the storage of a value
/// that is written once into its place (a `static`, or a slot assigned from a `const`) rather
/// than built on the stack and copied.
pub const fn zeros<T: Scalar, const R: usize, const C: usize>() -> SMatrix<T, R, C> {
    SMatrix::from_array_storage(ArrayStorage([[T::ZERO; R]; C]))
}

impl Scalar for f32 {
    #[inline]
    fn psin(self) -> Self {
        libm::sinf(self)
    }
    #[inline]
    fn pcos(self) -> Self {
        libm::cosf(self)
    }
    #[inline]
    fn patan2(self, x: Self) -> Self {
        libm::atan2f(self, x)
    }
    #[inline]
    fn pasin(self) -> Self {
        libm::asinf(self)
    }
    // x = 0.5 rad: 3.8e-10 < 6e-8 (f32 epsilon / 2); covers 2000 deg/s at 400 Hz.
    const ROTATION_SERIES_MAX2: f64 = 0.25;
    const ZERO: Self = 0.0;
    #[inline]
    fn c(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    #[inline]
    fn of_f32(x: f32) -> Self {
        x
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
}

impl Scalar for f64 {
    #[inline]
    fn psin(self) -> Self {
        libm::sin(self)
    }
    #[inline]
    fn pcos(self) -> Self {
        libm::cos(self)
    }
    #[inline]
    fn patan2(self, x: Self) -> Self {
        libm::atan2(self, x)
    }
    #[inline]
    fn pasin(self) -> Self {
        libm::asin(self)
    }
    // x = 0.05 rad: 3.8e-18 < 1.1e-16.
    const ROTATION_SERIES_MAX2: f64 = 0.0025;
    const ZERO: Self = 0.0;
    #[inline]
    fn c(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn of_f32(x: f32) -> Self {
        f64::from(x)
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
}
