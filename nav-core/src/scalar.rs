//! The scalar type the navigation code is generic over: `f32` on the MCU, `f64` on the host.
//!
//! Transcendental functions go through [`Scalar::psin`] and friends, which call the `libm` crate
//! directly: nalgebra's own `sin` & co. go through `num-traits`, whose `std` feature (switched on
//! by any crate in a host build, e.g. proptest) replaces them with the host C library's, which
//! can differ by an ulp and would break the firmware/harness bit-identity.

use fixed::traits::{Fixed, FromFixed, ToFixed};
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
    /// The natural logarithm, `ln` from the `libm` crate.
    fn pln(self) -> Self;
    /// `2^self`, `exp2` from the `libm` crate.
    fn pexp2(self) -> Self;
    /// The value of a 64-bit fixed-point number (the position's `I2F62`, `I32F32`), rounded
    /// to nearest, ties to even: `fixed`'s `to_num`, bit for bit.
    fn of_fixed<F: Fixed<Bits = i64>>(x: F) -> Self;
    /// This value as a 64-bit fixed-point number, rounded to nearest, ties to even, and
    /// saturated: `fixed`'s `saturating_from_num`, bit for bit. Not for NaN (the callers refuse
    /// it first).
    fn to_fixed_saturating<F: Fixed<Bits = i64>>(self) -> F;
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
    #[inline]
    fn pln(self) -> Self {
        libm::logf(self)
    }
    #[inline]
    fn pexp2(self) -> Self {
        libm::exp2f(self)
    }
    #[inline]
    fn of_fixed<F: Fixed<Bits = i64>>(x: F) -> Self {
        x.to_num()
    }
    #[inline]
    fn to_fixed_saturating<F: Fixed<Bits = i64>>(self) -> F {
        F::saturating_from_num(self)
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
    #[inline]
    fn pln(self) -> Self {
        libm::log(self)
    }
    #[inline]
    fn pexp2(self) -> Self {
        libm::exp2(self)
    }
    // The two below give `fixed`'s results with a fraction of its generic conversion's work (a
    // fixed-point component was converted a dozen times per step: 6 % of a host run).
    #[inline]
    fn of_fixed<F: Fixed<Bits = i64>>(x: F) -> Self {
        // The cast rounds to nearest, ties to even; the power of two scales exactly.
        x.to_bits() as f64 * pow2(-(F::FRAC_NBITS as i32))
    }
    #[inline]
    fn to_fixed_saturating<F: Fixed<Bits = i64>>(self) -> F {
        debug_assert!(!self.is_nan());
        // Scaling by a power of two is exact (an overflow is infinite and saturates below);
        // `rint` rounds ties to even, and the cast saturates as `fixed` does.
        F::from_bits(libm::rint(self * pow2(F::FRAC_NBITS as i32)) as i64)
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

/// `2^e` for `e` in [-1022, 1023].
#[inline]
fn pow2(e: i32) -> f64 {
    f64::from_bits(((1023 + e) as u64) << 52)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fixed::types::{I2F62, I32F32};

    /// `n` pseudo-random `u64`, the same on every run.
    fn bits(n: usize) -> impl Iterator<Item = u64> {
        use proptest::prelude::Rng;
        use proptest::test_runner::{RngAlgorithm, TestRng};
        let mut rng = TestRng::deterministic_rng(RngAlgorithm::ChaCha);
        (0..n).map(move |_| rng.next_u64())
    }

    fn of_fixed_is_to_num<F: Fixed<Bits = i64>>() {
        let edges = [
            0,
            1,
            -1,
            i64::MAX,
            i64::MIN,
            1 << 53,
            (1 << 53) + 1,
            (1 << 54) + 2,
        ];
        let shifted = bits(200_000).map(|b| (b as i64) >> (b % 64));
        for b in edges.into_iter().chain(shifted) {
            let x = F::from_bits(b);
            assert_eq!(
                f64::of_fixed(x).to_bits(),
                x.to_num::<f64>().to_bits(),
                "{b}"
            );
        }
    }

    fn to_fixed_is_saturating_from_num<F: Fixed<Bits = i64>>() {
        let ulp = pow2(-(F::FRAC_NBITS as i32));
        let edges = [
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE / 4.0,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.5 * ulp,
            1.5 * ulp,
            -2.5 * ulp,
            2.5 * ulp,
            (0.5 * ulp).next_up(),
            (0.5 * ulp).next_down(),
            9.2e18 * ulp,
            -9.3e18 * ulp,
        ];
        // Random signs, mantissas and exponents around the fixed-point range, and ties.
        let random = bits(200_000).map(|b| {
            let e = (b >> 52) as i32 % 140 - 70 - F::FRAC_NBITS as i32 / 2;
            let m = f64::from_bits((b & ((1 << 52) - 1)) | (1023 << 52));
            let x = m * pow2(e);
            let x = if b % 3 == 0 {
                ((b >> 20) as f64 + 0.5) * ulp
            } else {
                x
            };
            if b % 2 == 0 { -x } else { x }
        });
        for x in edges.into_iter().chain(random) {
            assert_eq!(
                x.to_fixed_saturating::<F>(),
                F::saturating_from_num(x),
                "{x:e}"
            );
        }
    }

    #[test]
    fn fast_fixed_conversions_equal_fixeds() {
        of_fixed_is_to_num::<I2F62>();
        of_fixed_is_to_num::<I32F32>();
        to_fixed_is_saturating_from_num::<I2F62>();
        to_fixed_is_saturating_from_num::<I32F32>();
    }
}
