//! The ellipse of one period: its principal axes from the generator's components, the rotation
//! they define, and the two degenerate shapes ([Oscillator INS, eqs. 2.7–2.18]).
//!
//! With the oscillator's phase ahead of the generator's by `delta`, the components of the
//! principal semi-axes `p` (major) and `q` (minor) are `a = p cos(delta) + q sin(delta)` and
//! `b = q cos(delta) - p sin(delta)`, so `a . b = -(P^2 - Q^2) sin(2 delta)/2` (eq. 2.12): the
//! feedback that drives `a . b` to zero (eq. 2.17) drives `delta` to zero, and
//! `tan(2 delta) = -2 a . b / (|a|^2 - |b|^2)` measures what is left. The axes are then
//! `p = a cos(delta) - b sin(delta)`, `q = a sin(delta) + b cos(delta)`, and the rotation is
//! `A = [p/|p|, q/|q|, p x q/|p x q|]` (eq. 2.18), re-orthogonalised (`e2 = e3 x e1`).
//!
//! Degenerate shapes (eq. 2.11, 2.15), with the 1-sigma of the three angles for component noises
//! `s_a`, `s_b` (derived by perturbing `a`, `b` and `delta` to first order; with `s_a = s_b = s`):
//!
//! - about `e1` (the major axis) `s_b/Q`: a near-line (`Q/P` small) loses the rotation about it;
//! - about `e2`: `s_a/P`;
//! - about `e3` (in the plane) `sqrt(s_a^2 P^2 + s_b^2 Q^2)/(P^2 - Q^2)`, i.e.
//!   `s sqrt(P^2 + Q^2)/(P^2 - Q^2)`: a near-circle has no apse, so the in-plane angle is
//!   undefined.
//!
//! The default thresholds, `Q/P >= 0.05` and `Q/P <= 0.95`, bound the first two factors at 20 and
//! 14 times the best case's `s/P`; the best shape, where the two are equal, is near `Q/P = 0.6`.

use crate::Scalar;
use nalgebra::{Matrix3, Vector3};

/// Principal axes of one period's ellipse, in body axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse<T: Scalar> {
    /// Semi-major axis `p` [m].
    pub p: Vector3<T>,
    /// Semi-minor axis `q` [m] (orthogonal to `p` up to noise).
    pub q: Vector3<T>,
    /// Phase of the oscillator ahead of the generator [rad], in `(-pi/2, pi/2]`.
    pub delta: T,
}

impl<T: Scalar> Ellipse<T> {
    /// The principal axes of the components `a`, `b` [m].
    pub fn from_components(a: &Vector3<T>, b: &Vector3<T>) -> Self {
        let half = T::c(0.5);
        let delta = (T::c(-2.0) * a.dot(b)).patan2(a.norm_squared() - b.norm_squared()) * half;
        let (s, c) = (delta.psin(), delta.pcos());
        Self {
            p: a * c - b * s,
            q: a * s + b * c,
            delta,
        }
    }

    /// Semi-major axis length `P` [m].
    pub fn major(&self) -> T {
        self.p.norm()
    }

    /// Semi-minor axis length `Q` [m].
    pub fn minor(&self) -> T {
        self.q.norm()
    }

    /// `Q/P` [-] (0 for a line, 1 for a circle; 0 when there is no motion).
    pub fn axis_ratio(&self) -> T {
        let p = self.major();
        if p > T::zero() {
            self.minor() / p
        } else {
            T::zero()
        }
    }

    /// The same ellipse read from the opposite apse (`p, q -> -p, -q`): a half-turn about `e3`.
    pub fn flipped(&self) -> Self {
        Self {
            p: -self.p,
            q: -self.q,
            delta: self.delta,
        }
    }

    /// `C_e_b`: the columns are the unit axes `e1 = p/|p|`, `e2`, `e3 = p x q/|p x q|` in body
    /// axes (eq. 2.18), `e2 = e3 x e1` so the matrix is a rotation even when noise leaves `p`
    /// and `q` slightly oblique.
    pub fn c_e_b(&self) -> Matrix3<T> {
        let e1 = self.p.normalize();
        let e3 = self.p.cross(&self.q).normalize();
        let e2 = e3.cross(&e1);
        Matrix3::from_columns(&[e1, e2, e3])
    }

    /// 1-sigma [rad] of the rotation about `e1`, `e2`, `e3` for noises `s_a`, `s_b` [m] of each
    /// component of `a` and `b`.
    pub fn sigma_rad(&self, s_a: T, s_b: T) -> Vector3<T> {
        let (p, q) = (self.major(), self.minor());
        let in_plane = (s_a * s_a * p * p + s_b * s_b * q * q).sqrt() / (p * p - q * q);
        Vector3::new(s_b / q, s_a / p, in_plane)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    #[test]
    fn principal_axes_from_any_generator_phase() {
        let rot = UnitQuaternion::from_euler_angles(0.3, -0.4, 1.2_f64);
        let p = rot * Vector3::new(3.0, 0.0, 0.0);
        let q = rot * Vector3::new(0.0, 1.0, 0.0);
        for delta in [-1.5, -0.7, 0.0, 0.2, 1.4_f64] {
            let a = p * delta.cos() + q * delta.sin();
            let b = q * delta.cos() - p * delta.sin();
            let e = Ellipse::from_components(&a, &b);
            assert!((e.delta - delta).abs() < 1e-12, "{} vs {delta}", e.delta);
            assert!((e.p - p).norm() < 1e-12 && (e.q - q).norm() < 1e-12);
            let c = e.c_e_b();
            assert!((c - rot.to_rotation_matrix().into_inner()).norm() < 1e-12);
            assert!((e.axis_ratio() - 1.0 / 3.0).abs() < 1e-12);
        }
    }
}
