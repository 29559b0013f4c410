//! Direction-cosine attitude by Poisson's equation `dC/dt = C [omega x]`
//! ([Berdinskikh et al., eqs. 1–2, 6]) with selectable integrators, each step followed by
//! re-orthonormalisation ([Berdinskikh et al., eq. 7]).
//!
//! The integrators solve any matrix ODE `dC/dt = f(t, C)`; the mechanization uses
//! `f = C [omega_ib_b(t) x] - [omega_in_n x] C` (Savage (7.1.1.1-1) for the body-to-navigation
//! matrix), the order test uses a rotation with a known closed form.

use crate::Scalar;
use nalgebra::Matrix3;

/// Integration method for Poisson's equation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DcmIntegrator {
    /// Explicit Euler, order 1.
    Euler,
    /// Heun (trapezoidal predictor–corrector), order 2.
    Heun,
    /// Classic fourth-order Runge–Kutta.
    Rk4,
    /// Fourth-order Adams–Bashforth predictor with the three-step Adams–Moulton corrector
    /// (PECE), started with RK4. One new evaluation of `f` per step beyond the corrector's.
    Abm4,
}

/// Re-orthonormalises `c` in place: `C <- C - (C C^T - I) C / 2`, one step of the iteration
/// that converges to the nearest orthonormal matrix (Savage (7.1.1.3-4); it enforces
/// [Berdinskikh et al., eq. 7] `sum_k C_ik C_jk = delta_ij` to second order in the deviation).
pub fn orthonormalize<T: Scalar>(c: &mut Matrix3<T>) {
    let e = *c * c.transpose() - Matrix3::identity();
    *c -= e * *c * T::c(0.5);
}

/// A direction-cosine matrix integrated by one of the [`DcmIntegrator`] methods.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoissonDcm<T: Scalar> {
    method: DcmIntegrator,
    c: Matrix3<T>,
    /// `f` at the previous three steps, newest first (multistep history).
    history: [Matrix3<T>; 3],
    n_history: usize,
    /// Step of the history [s]: a different step restarts the multistep method.
    h_history: T,
}

impl<T: Scalar> PoissonDcm<T> {
    /// Starts from the matrix `c`.
    pub fn new(c: Matrix3<T>, method: DcmIntegrator) -> Self {
        Self {
            method,
            c,
            history: [Matrix3::zeros(); 3],
            n_history: 0,
            h_history: T::zero(),
        }
    }

    /// The current matrix.
    pub fn dcm(&self) -> &Matrix3<T> {
        &self.c
    }

    /// The integration method.
    pub fn method(&self) -> DcmIntegrator {
        self.method
    }

    /// Replaces the matrix (e.g. after a correction) and restarts the multistep history.
    pub fn reset(&mut self, c: Matrix3<T>) {
        self.c = c;
        self.n_history = 0;
    }

    /// Advances by `h` [s] from `t0` [s] for `dC/dt = f(t, C)`, then re-orthonormalises.
    /// Multistep methods need a constant `h`: a different one restarts them (with RK4).
    pub fn step<F: Fn(T, &Matrix3<T>) -> Matrix3<T>>(&mut self, t0: T, h: T, f: F) {
        if (h - self.h_history).abs() > h * T::c(1e-6) {
            self.n_history = 0;
            self.h_history = h;
        }
        let c = self.c;
        let half = T::c(0.5);
        let f0 = f(t0, &c);
        let next = match self.method {
            DcmIntegrator::Euler => c + f0 * h,
            DcmIntegrator::Heun => {
                let p = c + f0 * h;
                c + (f0 + f(t0 + h, &p)) * (h * half)
            }
            DcmIntegrator::Rk4 => rk4(&c, &f0, t0, h, &f),
            DcmIntegrator::Abm4 if self.n_history < 3 => rk4(&c, &f0, t0, h, &f),
            DcmIntegrator::Abm4 => {
                let [f1, f2, f3] = &self.history;
                let k = h / T::c(24.0);
                // Adams–Bashforth 4 predictor, Adams–Moulton 3-step (order 4) corrector.
                let p =
                    c + (f0 * T::c(55.0) - f1 * T::c(59.0) + f2 * T::c(37.0) - f3 * T::c(9.0)) * k;
                let fp = f(t0 + h, &p);
                c + (fp * T::c(9.0) + f0 * T::c(19.0) - f1 * T::c(5.0) + f2) * k
            }
        };
        if self.method == DcmIntegrator::Abm4 {
            self.history = [f0, self.history[0], self.history[1]];
            self.n_history = (self.n_history + 1).min(3);
        }
        self.c = next;
        // One iteration is enough for small steps; a large step (a big rotation through a
        // low-order method) may need a few more to converge.
        for _ in 0..4 {
            orthonormalize(&mut self.c);
            let e = self.c * self.c.transpose() - Matrix3::identity();
            if e.amax() < T::default_epsilon() * T::c(16.0) {
                break;
            }
        }
    }
}

fn rk4<T: Scalar, F: Fn(T, &Matrix3<T>) -> Matrix3<T>>(
    c: &Matrix3<T>,
    f0: &Matrix3<T>,
    t0: T,
    h: T,
    f: &F,
) -> Matrix3<T> {
    let half = T::c(0.5);
    let k2 = f(t0 + h * half, &(c + f0 * (h * half)));
    let k3 = f(t0 + h * half, &(c + k2 * (h * half)));
    let k4 = f(t0 + h, &(c + k3 * h));
    c + (f0 + (k2 + k3) * T::c(2.0) + k4) * (h / T::c(6.0))
}

/// The skew-symmetric matrix `[v x]`.
pub fn skew<T: Scalar>(v: &nalgebra::Vector3<T>) -> Matrix3<T> {
    v.cross_matrix()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Quaternion, UnitQuaternion, Vector3};

    /// Classical coning: `q(t) = [cos(a/2), sin(a/2) cos(wt), sin(a/2) sin(wt), 0]`, body rate
    /// `w (-sin a sin wt, sin a cos wt, -2 sin^2(a/2))` (derived from `omega = 2 q* dq/dt`).
    struct Coning {
        a: f64,
        w: f64,
    }

    impl Coning {
        fn c(&self, t: f64) -> Matrix3<f64> {
            let (s, c) = ((self.a / 2.0).sin(), (self.a / 2.0).cos());
            let q = Quaternion::new(c, s * (self.w * t).cos(), s * (self.w * t).sin(), 0.0);
            UnitQuaternion::from_quaternion(q)
                .to_rotation_matrix()
                .into_inner()
        }
        fn omega(&self, t: f64) -> Vector3<f64> {
            let sa = self.a.sin();
            let s2 = (self.a / 2.0).sin().powi(2);
            self.w * Vector3::new(-sa * (self.w * t).sin(), sa * (self.w * t).cos(), -2.0 * s2)
        }
    }

    fn error(method: DcmIntegrator, n: usize) -> f64 {
        // Not a whole number of periods: Euler's O(h) error term, h/2 (omega(T) - omega(0)),
        // would cancel over full periods.
        let cone = Coning { a: 0.5, w: 5.0 };
        let t_end = 1.0;
        let h = t_end / n as f64;
        let mut dcm = PoissonDcm::new(cone.c(0.0), method);
        for k in 0..n {
            dcm.step(k as f64 * h, h, |t, c| c * skew(&cone.omega(t)));
        }
        (dcm.dcm() - cone.c(t_end)).norm()
    }

    /// Order = log2(e(h) / e(h/2)), averaged over three halvings.
    fn order(method: DcmIntegrator) -> f64 {
        let e: [f64; 4] = [40, 80, 160, 320].map(|n| error(method, n));
        (e[0] / e[3]).log2() / 3.0
    }

    #[test]
    fn closed_form_is_consistent_with_its_rate() {
        // The test rotation satisfies dC/dt = C [omega x] (finite difference).
        let cone = Coning { a: 0.5, w: 3.0 };
        let (t, d) = (0.3, 1e-6);
        let dc = (cone.c(t + d) - cone.c(t - d)) / (2.0 * d);
        assert!((dc - cone.c(t) * skew(&cone.omega(t))).norm() < 1e-8);
    }

    #[test]
    fn integrators_have_their_order_of_accuracy() {
        let euler = order(DcmIntegrator::Euler);
        let heun = order(DcmIntegrator::Heun);
        let rk4 = order(DcmIntegrator::Rk4);
        let abm = order(DcmIntegrator::Abm4);
        extern crate std;
        std::println!(
            "measured order of accuracy: Euler {euler:.3}, Heun {heun:.3}, RK4 {rk4:.3}, ABM4 {abm:.3}"
        );
        assert!((euler - 1.0).abs() < 0.15, "Euler {euler}");
        assert!((heun - 2.0).abs() < 0.15, "Heun {heun}");
        assert!((rk4 - 4.0).abs() < 0.2, "RK4 {rk4}");
        assert!((abm - 4.0).abs() < 0.3, "ABM4 {abm}");
    }

    #[test]
    fn orthonormalisation_restores_eq_7() {
        let mut c = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0)
            .to_rotation_matrix()
            .into_inner();
        c[(0, 1)] += 1e-4;
        c[(2, 2)] -= 2e-4;
        let before = (c * c.transpose() - Matrix3::identity()).norm();
        orthonormalize(&mut c);
        let after = (c * c.transpose() - Matrix3::identity()).norm();
        assert!(after < before * before * 10.0, "{before} {after}");
    }
}
