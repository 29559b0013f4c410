//! The base's translation as a stochastic process: what waves do to the centre of a swaying
//! base (heave, surge, sway), per axis a band-pass shaping filter of white noise with no power
//! at zero frequency.
//!
//! Per axis, the displacement `d` of the centre from its mean position is
//! `d(s) = K s / ((s + w_c)(s^2 + 2 zeta w_0 s + w_0^2)) w(s)` (`w` unit white noise): the
//! wave model of [Fossen, §8.2.5] (a second-order resonance at the wave frequency `w_0`) with a
//! zero at the origin and a pole at `w_c`, so that the displacement has no power below `w_c`
//! (the centre does not wander: its mean position is the given one) and its velocity none at
//! zero frequency. With the states `(z, d, d')`, `z` the leaky integral of `d`:
//! ```text
//! z' = d,   d' = d',   d'' = -a0 z - a1 d - a2 d' + K w,
//! a0 = w_c w_0^2,  a1 = w_0^2 + 2 zeta w_0 w_c,  a2 = w_c + 2 zeta w_0.
//! ```
//! `K` is chosen so that the stationary 1-sigma of `d` is [`Translation::sigma_m`]. The default
//! band ([`Translation::default`]: `w_0 = 2 pi / 8 s`, `zeta = 0.5`, `w_c = 2 pi / 25 s`) is
//! flat within a factor 2 from 5 to 20 s periods and falls as `w^2` beyond 25 s: why the heading
//! of a long alignment is not lost to the base (the heading's position signature is a slow
//! cubic, [`super`]).
//!
//! The block is linear and time-invariant: its transition and process noise over the filter
//! interval are computed once ([`ShapingBlock::discrete`], series and Van Loan's integral).

use crate::Scalar;
use nalgebra::{Matrix3, Vector3};

/// Offset of the leaky integral `z` [m s] within one axis's block.
pub const Z: usize = 0;
/// Offset of the displacement `d` [m].
pub const D: usize = 1;
/// Offset of its rate `d'` [m/s].
pub const D_RATE: usize = 2;

/// The translation model's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Translation<T: Scalar> {
    /// Stationary 1-sigma of the horizontal displacement (surge, sway), per axis [m] (0: the
    /// centre does not move horizontally).
    pub horizontal_sigma_m: T,
    /// Stationary 1-sigma of the vertical displacement (heave) [m].
    pub vertical_sigma_m: T,
    /// Resonance (wave) angular frequency `w_0` [rad/s].
    pub omega0_rad_s: T,
    /// Damping ratio `zeta` [-].
    pub damping: T,
    /// Low-frequency corner `w_c` [rad/s]: no displacement power below it.
    pub corner_rad_s: T,
}

impl<T: Scalar> Default for Translation<T> {
    fn default() -> Self {
        let tau = core::f64::consts::TAU;
        Self {
            horizontal_sigma_m: T::c(0.5),
            vertical_sigma_m: T::c(0.5),
            omega0_rad_s: T::c(tau / 8.0),
            damping: T::c(0.5),
            corner_rad_s: T::c(tau / 25.0),
        }
    }
}

/// One axis's continuous model: `x' = A x + b w`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapingBlock<T: Scalar> {
    /// System matrix `A`.
    pub a: Matrix3<T>,
    /// Noise gain `K` on `d''` [m/s^3 per sqrt(Hz)].
    pub gain: T,
}

impl<T: Scalar> ShapingBlock<T> {
    /// The block of `model` for a displacement of stationary 1-sigma `sigma_m` [m].
    pub fn new(model: &Translation<T>, sigma_m: T) -> Self {
        let (w0, z, wc) = (model.omega0_rad_s, model.damping, model.corner_rad_s);
        let two = T::c(2.0);
        let a0 = wc * w0 * w0;
        let a1 = w0 * w0 + two * z * w0 * wc;
        let a2 = wc + two * z * w0;
        let a = Matrix3::new(
            T::zero(),
            T::one(),
            T::zero(),
            T::zero(),
            T::zero(),
            T::one(),
            -a0,
            -a1,
            -a2,
        );
        // Stationary variance of d for unit noise (third-order system, Routh–Hurwitz form):
        // var(z') = 1 / (2 (a1 a2 - a0) ) for z''' + a2 z'' + a1 z' + a0 z = w.
        let unit_var_d = T::one() / (two * (a1 * a2 - a0));
        let gain = sigma_m / unit_var_d.sqrt();
        Self { a, gain }
    }

    /// Stationary covariance of `(z, d, d')` [m^2 s^2, m^2, m^2/s^2 and cross terms], from the
    /// Lyapunov equation `A P + P A^T + K^2 e3 e3^T = 0`. (Closed forms for
    /// `z''' + a2 z'' + a1 z' + a0 z = K w`: `var z = K^2 a2 / (2 a0 (a1 a2 - a0))`,
    /// `var z' = K^2 / (2 (a1 a2 - a0))`; the test checks them.)
    pub fn stationary(&self) -> Matrix3<T> {
        lyapunov(&self.a, self.gain * self.gain)
    }

    /// Transition `Phi = exp(A dt)` and process noise `Q_d = int_0^dt exp(A s) b b^T exp(A^T s)
    /// ds` over `dt` [s] (Taylor series to 12 terms; `|A| dt` is below 0.5 at the filter's
    /// intervals).
    pub fn discrete(&self, dt: T) -> (Matrix3<T>, Matrix3<T>) {
        let ad = self.a * dt;
        let mut phi = Matrix3::<T>::identity();
        let mut term = Matrix3::<T>::identity();
        for k in 1..=12u32 {
            term = term * ad / T::c(f64::from(k));
            phi += term;
        }
        // Q_d by the trapezoid rule on 16 sub-steps of exp(A s) b b^T exp(A^T s) (smooth).
        let b = Vector3::new(T::zero(), T::zero(), self.gain);
        let n = 16u32;
        let h = dt / T::c(f64::from(n));
        let mut step = Matrix3::<T>::identity();
        let mut t = Matrix3::<T>::identity();
        for k in 1..=12u32 {
            t = t * (self.a * h) / T::c(f64::from(k));
            step += t;
        }
        let mut e = Matrix3::<T>::identity();
        let mut q = Matrix3::<T>::zeros();
        for k in 0..=n {
            let v = e * b;
            let w = if k == 0 || k == n {
                T::c(0.5)
            } else {
                T::one()
            };
            q += v * v.transpose() * (w * h);
            e = step * e;
        }
        (phi, q)
    }
}

/// The stationary covariance `P` of `x' = A x + (0, 0, 1) w` with noise intensity `q`:
/// `A P + P A^T + q e3 e3^T = 0`, solved as a 6x6 linear system in the upper triangle.
fn lyapunov<T: Scalar>(a: &Matrix3<T>, q: T) -> Matrix3<T> {
    use nalgebra::{SMatrix, SVector};
    const IDX: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
    let pos = |i: usize, j: usize| {
        let (i, j) = if i <= j { (i, j) } else { (j, i) };
        IDX.iter().position(|&p| p == (i, j)).unwrap_or(0)
    };
    let mut m = SMatrix::<T, 6, 6>::zeros();
    let mut rhs = SVector::<T, 6>::zeros();
    for (row, &(i, j)) in IDX.iter().enumerate() {
        // (A P)_ij + (P A^T)_ij = sum_k A_ik P_kj + P_ik A_jk.
        for k in 0..3 {
            m[(row, pos(k, j))] += a[(i, k)];
            m[(row, pos(i, k))] += a[(j, k)];
        }
        if (i, j) == (2, 2) {
            rhs[row] = -q;
        }
    }
    let sol = m.lu().solve(&rhs).unwrap_or_else(SVector::zeros);
    let mut p = Matrix3::zeros();
    for (row, &(i, j)) in IDX.iter().enumerate() {
        p[(i, j)] = sol[row];
        p[(j, i)] = sol[row];
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stationary_sigma_and_discretisation_agree() {
        let m = Translation::<f64>::default();
        let b = ShapingBlock::new(&m, 0.5);
        let p = b.stationary();
        assert!((p[(D, D)].sqrt() - 0.5).abs() < 1e-9, "{}", p[(D, D)]);
        let (a0, a1, a2) = (-b.a[(2, 0)], -b.a[(2, 1)], -b.a[(2, 2)]);
        let k2 = b.gain * b.gain;
        let var_z = k2 * a2 / (2.0 * a0 * (a1 * a2 - a0));
        assert!(
            (p[(Z, Z)] / var_z - 1.0).abs() < 1e-9,
            "{} {var_z}",
            p[(Z, Z)]
        );
        // Stationary: Phi P Phi^T + Q = P.
        let (phi, q) = b.discrete(0.1);
        let p1 = phi * p * phi.transpose() + q;
        assert!((p1 - p).norm() < 1e-6 * p.norm(), "{p1} {p}");
        // Zero mean position: E[z d] = 0 and E[d d'] = 0.
        assert!(p[(Z, D)].abs() < 1e-9 && p[(D, D_RATE)].abs() < 1e-9);
    }
}
