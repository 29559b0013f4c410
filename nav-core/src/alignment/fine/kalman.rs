//! Kalman-filter building blocks shared by the fine-alignment filters ([`super::FineAlignment`]
//! and [`crate::alignment::sway::SwayAlignment`]): covariance propagation and the Joseph-form
//! scalar measurement update, for any state size, without allocation.

use crate::Scalar;
use nalgebra::{SMatrix, SVector};

/// What became of one scalar measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScalarUpdate {
    /// Used.
    Accepted,
    /// Refused by the innovation gate (|innovation| > gate * sqrt(S)).
    Gated,
    /// Refused: innovation variance not positive or something not finite.
    Degenerate,
}

/// `P <- Phi P Phi^T + Q_d`, symmetrised.
pub fn propagate<T: Scalar, const N: usize>(
    p: &mut SMatrix<T, N, N>,
    phi: &SMatrix<T, N, N>,
    q_d: &SMatrix<T, N, N>,
) {
    *p = phi * *p * phi.transpose() + q_d;
    symmetrize(p);
}

/// `P <- (P + P^T) / 2`.
pub fn symmetrize<T: Scalar, const N: usize>(p: &mut SMatrix<T, N, N>) {
    let half = T::c(0.5);
    for i in 0..N {
        for j in (i + 1)..N {
            let m = (p[(i, j)] + p[(j, i)]) * half;
            p[(i, j)] = m;
            p[(j, i)] = m;
        }
    }
}

/// Discrete process noise of the continuous white-noise spectral densities `q_c` (diagonal,
/// [state unit^2 / s]) over `dt` [s] with transition `phi`: the trapezoidal rule
/// `Q_d = (Phi Q_c Phi^T + Q_c) dt / 2` (Groves eq. 3.46 to second order in `dt`).
pub fn discrete_noise<T: Scalar, const N: usize>(
    phi: &SMatrix<T, N, N>,
    q_c: &SVector<T, N>,
    dt: T,
) -> SMatrix<T, N, N> {
    let mut q = SMatrix::<T, N, N>::zeros();
    for i in 0..N {
        for j in 0..N {
            let mut s = T::zero();
            for k in 0..N {
                if q_c[k] != T::zero() {
                    s += phi[(i, k)] * q_c[k] * phi[(j, k)];
                }
            }
            q[(i, j)] = s;
        }
    }
    for i in 0..N {
        q[(i, i)] += q_c[i];
    }
    q * (dt * T::c(0.5))
}

/// Scalar measurement `z = h^T x + v`, `v ~ N(0, r)`, with innovation `innovation = z - h^T x`
/// already formed by the caller (so a nonlinear prediction can be used): Kalman gain
/// `K = P h / S`, `S = h^T P h + r`; `x <- x + K innovation`; Joseph form
/// `P <- (I - K h^T) P (I - K h^T)^T + r K K^T` (Groves eq. 3.58), symmetrised.
///
/// `gate` [sigma]: an innovation beyond `gate * sqrt(S)` is refused (`T::infinity`-like large
/// values switch the gate off). Nothing changes unless the measurement is accepted.
pub fn update_scalar<T: Scalar, const N: usize>(
    x: &mut SVector<T, N>,
    p: &mut SMatrix<T, N, N>,
    h: &SVector<T, N>,
    innovation: T,
    r: T,
    gate: T,
) -> ScalarUpdate {
    let ph = times(p, h);
    let s = h.dot(&ph) + r;
    if !(s.finite() && s > T::zero() && innovation.finite()) {
        return ScalarUpdate::Degenerate;
    }
    if innovation * innovation > gate * gate * s {
        return ScalarUpdate::Gated;
    }
    let k = ph / s;
    if !k.iter().all(|v| v.finite()) {
        return ScalarUpdate::Degenerate;
    }
    *x += k * innovation;
    // In place, element by element (no N x N temporary: 5.5 KB each at 37 states in `f32`,
    // on an MCU task's stack), the same operations in the same order as the matrix form
    // `A = P - K (P h)^T`, `P = A - (A h) K^T + K K^T r`. `A = (I - K h^T) P` for a
    // symmetric P.
    for j in 0..N {
        for i in 0..N {
            p[(i, j)] -= k[i] * ph[j];
        }
    }
    let ah = times(p, h);
    for j in 0..N {
        for i in 0..N {
            p[(i, j)] = p[(i, j)] - ah[i] * k[j] + k[i] * k[j] * r;
        }
    }
    symmetrize(p);
    ScalarUpdate::Accepted
}

/// `m v` with `m` by reference (`*p * h` would copy the covariance: 5.5 KB at 37 states in
/// `f32`, on an MCU task's stack).
fn times<T: Scalar, const N: usize>(m: &SMatrix<T, N, N>, v: &SVector<T, N>) -> SVector<T, N> {
    m * v
}

/// True when every element is finite.
pub fn all_finite<T: Scalar, const R: usize, const C: usize>(m: &SMatrix<T, R, C>) -> bool {
    m.iter().all(|v| v.finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};
    use proptest::prelude::*;

    #[test]
    fn scalar_update_matches_the_textbook_form() {
        let mut p = Matrix2::new(4.0, 1.0, 1.0, 2.0_f64);
        let mut x = Vector2::new(0.5, -1.0);
        let h = Vector2::new(1.0, 2.0);
        let (z, r) = (3.0, 0.5);
        let innovation = z - h.dot(&x);
        let s = (h.transpose() * p * h)[0] + r;
        let k = p * h / s;
        let x_expect = x + k * innovation;
        let p_expect = (Matrix2::identity() - k * h.transpose()) * p;
        assert_eq!(
            update_scalar(&mut x, &mut p, &h, innovation, r, 1e9),
            ScalarUpdate::Accepted
        );
        assert!((x - x_expect).norm() < 1e-14);
        assert!((p - p_expect).norm() < 1e-14, "{p} {p_expect}");
    }

    #[test]
    fn gate_and_degenerate_leave_the_state_alone() {
        let mut p = Matrix2::new(1.0, 0.0, 0.0, 1.0_f64);
        let mut x = Vector2::zeros();
        let h = Vector2::new(1.0, 0.0);
        let before = (x, p);
        assert_eq!(
            update_scalar(&mut x, &mut p, &h, 10.0, 1.0, 3.0),
            ScalarUpdate::Gated
        );
        assert_eq!(
            update_scalar(&mut x, &mut p, &h, f64::NAN, 1.0, 3.0),
            ScalarUpdate::Degenerate
        );
        assert_eq!(
            update_scalar(&mut x, &mut p, &Vector2::zeros(), 1.0, 0.0, 3.0),
            ScalarUpdate::Degenerate
        );
        assert_eq!((x, p), before);
    }

    proptest! {
        /// The Joseph form keeps the covariance symmetric and positive semi-definite, and never
        /// increases the variance of any state.
        #[test]
        fn joseph_update_keeps_covariance_valid(
            a in -3.0..3.0_f64, b in -3.0..3.0_f64, c in -3.0..3.0_f64,
            h0 in -2.0..2.0_f64, h1 in -2.0..2.0_f64, r in 1e-6..10.0_f64, e in -5.0..5.0_f64,
        ) {
            let l = Matrix2::new(a.abs() + 0.1, 0.0, b, c.abs() + 0.1);
            let mut p = l * l.transpose();
            let before = p;
            let mut x = Vector2::zeros();
            let h = Vector2::new(h0, h1);
            let u = update_scalar(&mut x, &mut p, &h, e, r, 1e9);
            prop_assert!(u == ScalarUpdate::Accepted);
            prop_assert_eq!(p[(0, 1)], p[(1, 0)]);
            let eig = p.symmetric_eigenvalues();
            prop_assert!(eig.min() >= -1e-12 * before.norm(), "{}", eig);
            prop_assert!(p[(0, 0)] <= before[(0, 0)] * (1.0 + 1e-12));
            prop_assert!(p[(1, 1)] <= before[(1, 1)] * (1.0 + 1e-12));
        }
    }
}
