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
    update_scalar_correlated(x, p, h, None, innovation, r, gate)
}

/// A consider error `e` the measurement sees besides the states (`z = h^T x + e + v`, e.g.
/// `e = h_c^T c` of Schmidt consider states `c` [Schmidt, 1966]): its covariance with the
/// states `u = E[x e]` and its variance `var = E[e^2]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConsiderError<T: Scalar, const N: usize> {
    /// `E[x e]` [state unit times measurement unit].
    pub u: SVector<T, N>,
    /// `E[e^2]` [measurement unit^2].
    pub var: T,
}

impl<T: Scalar, const N: usize> ConsiderError<T, N> {
    /// The gain of the states (the consider error gets none: Schmidt's filter),
    /// `K = (P h + u) / S`, `S = h^T P h + 2 h^T u + var + r`; `None` when `S` is not positive
    /// and finite.
    pub fn gain(
        consider: Option<&Self>,
        p: &SMatrix<T, N, N>,
        h: &SVector<T, N>,
        r: T,
    ) -> Option<SVector<T, N>> {
        let ph = times(p, h);
        let (a, s) = Self::gain_terms(consider, &ph, h, r);
        (s.finite() && s > T::zero()).then(|| a / s)
    }

    /// `P h + u` and `S` from `ph = P h`.
    fn gain_terms(
        consider: Option<&Self>,
        ph: &SVector<T, N>,
        h: &SVector<T, N>,
        r: T,
    ) -> (SVector<T, N>, T) {
        let s = h.dot(ph) + r;
        match consider {
            Some(c) => (ph + c.u, s + T::c(2.0) * h.dot(&c.u) + c.var),
            None => (*ph, s),
        }
    }
}

/// [`update_scalar`] of a measurement that also sees a consider error (`z = h^T x + e + v`,
/// [`ConsiderError`]; `None`: none): gain [`ConsiderError::gain`], and the Joseph form of the
/// augmented state `[x; e]` with the consider error's gain set to zero,
/// `P <- (I - K h^T) P (I - K h^T)^T - w K^T - K w^T + (var + r) K K^T`, `w = (I - K h^T) u`
/// (the consider error's own covariance with the states, `u <- w - K var`, is the caller's).
pub fn update_scalar_correlated<T: Scalar, const N: usize>(
    x: &mut SVector<T, N>,
    p: &mut SMatrix<T, N, N>,
    h: &SVector<T, N>,
    consider: Option<&ConsiderError<T, N>>,
    innovation: T,
    r: T,
    gate: T,
) -> ScalarUpdate {
    let ph = times(p, h);
    let (a, s) = ConsiderError::gain_terms(consider, &ph, h, r);
    if !(s.finite() && s > T::zero() && innovation.finite()) {
        return ScalarUpdate::Degenerate;
    }
    if innovation * innovation > gate * gate * s {
        return ScalarUpdate::Gated;
    }
    let k = a / s;
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
    match consider {
        None => {
            for j in 0..N {
                for i in 0..N {
                    p[(i, j)] = p[(i, j)] - ah[i] * k[j] + k[i] * k[j] * r;
                }
            }
        }
        Some(c) => {
            let w = c.u - k * h.dot(&c.u);
            let b = ah + w;
            let r_all = r + c.var;
            for j in 0..N {
                for i in 0..N {
                    p[(i, j)] = p[(i, j)] - b[i] * k[j] - k[i] * w[j] + k[i] * k[j] * r_all;
                }
            }
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

    /// The consider-error update is the Joseph update of the augmented state `[x; e]` with
    /// the consider error's gain set to zero, and its gain is that of the Schmidt filter.
    #[test]
    fn correlated_update_is_the_augmented_schmidt_update() {
        use nalgebra::{Matrix3, Vector3};
        // Augmented covariance of [x0, x1, e], positive definite.
        let l = Matrix3::new(1.0, 0.0, 0.0, 0.3, 0.8, 0.0, -0.4, 0.5, 0.7_f64);
        let pa = l * l.transpose();
        let (h, r, innovation) = (Vector2::new(0.7, -1.2), 0.3, 0.4);
        let ha = Vector3::new(h[0], h[1], 1.0);
        let s = ha.dot(&(pa * ha)) + r;
        let mut ka = pa * ha / s;
        ka[2] = 0.0;
        let i_kh = Matrix3::identity() - ka * ha.transpose();
        let expected = i_kh * pa * i_kh.transpose() + ka * ka.transpose() * r;
        let mut p = Matrix2::new(pa[(0, 0)], pa[(0, 1)], pa[(1, 0)], pa[(1, 1)]);
        let c = ConsiderError {
            u: Vector2::new(pa[(0, 2)], pa[(1, 2)]),
            var: pa[(2, 2)],
        };
        let mut x = Vector2::zeros();
        let k = ConsiderError::gain(Some(&c), &p, &h, r).unwrap();
        assert!((k - Vector2::new(ka[0], ka[1])).amax() < 1e-15);
        let u = update_scalar_correlated(&mut x, &mut p, &h, Some(&c), innovation, r, 1e9);
        assert_eq!(u, ScalarUpdate::Accepted);
        assert!((x - k * innovation).amax() < 1e-15);
        for i in 0..2 {
            for j in 0..2 {
                assert!(
                    (p[(i, j)] - expected[(i, j)]).abs() < 1e-14,
                    "{p} {expected}"
                );
            }
        }
        // The consider error's covariance with the states afterwards: w - K var.
        let w = c.u - k * h.dot(&c.u) - k * c.var;
        assert!((w - Vector2::new(expected[(0, 2)], expected[(1, 2)])).amax() < 1e-14);
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
