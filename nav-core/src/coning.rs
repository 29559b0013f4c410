//! Two-sample coning and sculling compensation from increments (previous sample plus current
//! sample), exact for angular rate and specific force linear in time over two intervals.
//!
//! - Rotation vector (Savage §7.1.1.1, the two-sample algorithm with one previous sample;
//!   Titterton & Weston §11.2.1): `phi = dtheta_k + dtheta_{k-1} x dtheta_k / 12`.
//! - Velocity (Savage (7.2.2.2-11) and (7.2.2.2-22)): rotation compensation
//!   `dtheta_k x dv_k / 2 + dtheta_k x (dtheta_k x dv_k) / 6` plus sculling `(dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k) / 12`.
//!
//! The previous sample is used only when it is contiguous (same interval length to 1 %); after
//! a gap, a refused increment or a reset, the step falls back to the single-sample terms.

use crate::Scalar;
use nalgebra::Vector3;

/// Increments compensated for coning and sculling, in body axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compensated<T: Scalar> {
    /// Rotation vector of the body over the interval [rad].
    pub phi_b: Vector3<T>,
    /// Velocity increment resolved in the body axes at the start of the interval [m/s].
    pub delta_v_b: Vector3<T>,
}

/// Keeps the previous increment for the two-sample terms.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ConingSculling<T: Scalar> {
    prev: Option<(Vector3<T>, Vector3<T>, T)>,
}

impl<T: Scalar> ConingSculling<T> {
    /// No previous sample yet.
    pub const fn new() -> Self {
        Self { prev: None }
    }

    /// Forgets the previous sample (after a gap or a rejected increment).
    pub fn reset(&mut self) {
        self.prev = None;
    }

    /// Compensates the increment `delta_theta` [rad], `delta_v` [m/s] over `dt` [s]; with
    /// `two_sample == false` only the rotation compensation `dtheta x dv / 2` is applied.
    #[inline]
    pub fn compensate(
        &mut self,
        delta_theta: &Vector3<T>,
        delta_v: &Vector3<T>,
        dt: T,
        two_sample: bool,
    ) -> Compensated<T> {
        let half = T::c(0.5);
        let mut phi_b = *delta_theta;
        // Rotation compensation to second order, `a x u / 2 + a x (a x u) / 6` (Savage
        // (7.2.2.2-19) expanded): the second term rectifies under rocking (`w^2 g dt^2 / 6`,
        // 2.6e-8 m/s^2 at 0.05 rad/s and 400 Hz), which a free vertical channel amplifies.
        let rot = delta_theta.cross(delta_v);
        let mut delta_v_b = delta_v + rot * half + delta_theta.cross(&rot) * T::c(1.0 / 6.0);
        if let Some((theta_prev, v_prev, dt_prev)) = self.prev
            && two_sample
            && (dt - dt_prev).abs() <= dt * T::c(0.01)
        {
            let twelfth = T::c(1.0 / 12.0);
            phi_b += theta_prev.cross(delta_theta) * twelfth;
            delta_v_b += (theta_prev.cross(delta_v) + v_prev.cross(delta_theta)) * twelfth;
        }
        self.prev = Some((*delta_theta, *delta_v, dt));
        Compensated { phi_b, delta_v_b }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::attitude::rotation_vector_quat;
    use nalgebra::{Quaternion, UnitQuaternion};
    use std::println;

    /// Classical coning with half-angle `a` [rad] at `w` [rad/s]:
    /// `q(t) = [cos(a/2), sin(a/2) cos(wt), sin(a/2) sin(wt), 0]`, body rate
    /// `w (-sin a sin wt, sin a cos wt, -2 sin^2(a/2))`.
    fn q_true(a: f64, w: f64, t: f64) -> UnitQuaternion<f64> {
        let (s, c) = ((a / 2.0).sin(), (a / 2.0).cos());
        UnitQuaternion::from_quaternion(Quaternion::new(
            c,
            s * (w * t).cos(),
            s * (w * t).sin(),
            0.0,
        ))
    }

    /// Exact angle increment over [t0, t1] (the rate integrates in closed form).
    fn dtheta(a: f64, w: f64, t0: f64, t1: f64) -> Vector3<f64> {
        let sa = a.sin();
        Vector3::new(
            sa * ((w * t1).cos() - (w * t0).cos()),
            sa * ((w * t1).sin() - (w * t0).sin()),
            -2.0 * (a / 2.0).sin().powi(2) * w * (t1 - t0),
        )
    }

    /// Drift rate [rad/s] of the attitude computed at 400 Hz, with or without the coning term:
    /// the growth of the error from 5 s to 10 s (whole coning periods), which leaves out the
    /// first interval's error (it has no previous sample).
    fn drift_rate(a: f64, w: f64, coning: bool) -> f64 {
        let dt = 1.0 / 400.0;
        let mut q = q_true(a, w, 0.0);
        let mut cs = ConingSculling::new();
        let mut err_5s = 0.0;
        for k in 0..4000 {
            let th = dtheta(a, w, k as f64 * dt, (k + 1) as f64 * dt);
            let c = cs.compensate(&th, &Vector3::zeros(), dt, coning);
            q *= rotation_vector_quat(&c.phi_b);
            if k + 1 == 2000 {
                err_5s = q.angle_to(&q_true(a, w, 5.0));
            }
        }
        (q.angle_to(&q_true(a, w, 10.0)) - err_5s) / 5.0
    }

    #[test]
    fn coning_drift_is_removed_to_the_theoretical_residual() {
        // Per interval T the true coning term is sin^2(a) (x - sin x) / 2, x = w T; the
        // correction dtheta_{k-1} x dtheta_k / 12 matches it to sin^2(a) x^5 / 60
        // (x^3/12 - x^5/240 against x^3/12 - x^5/48). Drift rates: uncorrected
        // sin^2(a) w^3 T^2 / 12, corrected sin^2(a) w^5 T^4 / 60; ratio 5 / x^2.
        let (a, w, t) = (1f64.to_radians(), 2.0 * core::f64::consts::PI * 5.0, 0.0025);
        let x = w * t;
        let uncorrected = drift_rate(a, w, false);
        let corrected = drift_rate(a, w, true);
        let s2 = a.sin().powi(2);
        let theory_uncorrected = s2 * (x - x.sin()) / 2.0 / t;
        // Exact first-order residual; its leading term is s2 w^5 T^4 / 60.
        let theory_corrected =
            s2 * ((x - x.sin()) / 2.0 - (x / 2.0).sin().powi(2) * x.sin() / 3.0) / t;
        assert!((theory_corrected / (s2 * w.powi(5) * t.powi(4) / 60.0) - 1.0).abs() < 0.01);
        println!(
            "coning 1 deg at 5 Hz, 400 Hz: drift uncorrected {uncorrected:.4e} rad/s \
             (theory {theory_uncorrected:.4e}), corrected {corrected:.4e} rad/s \
             (theory {theory_corrected:.4e}), improvement {:.0}x",
            uncorrected / corrected
        );
        assert!((uncorrected / theory_uncorrected - 1.0).abs() < 0.02);
        assert!((corrected / theory_corrected - 1.0).abs() < 0.01);
        assert!(uncorrected / corrected >= 100.0);
    }

    #[test]
    fn two_sample_terms_need_contiguous_samples() {
        let mut cs = ConingSculling::<f64>::new();
        let a = Vector3::new(1e-3, 0.0, 0.0);
        let b = Vector3::new(0.0, 1e-3, 0.0);
        cs.compensate(&a, &b, 0.0025, true);
        // Different interval length: no coning term.
        let c = cs.compensate(&b, &a, 0.005, true);
        assert_eq!(c.phi_b, b);
        cs.reset();
        let c = cs.compensate(&a, &b, 0.005, true);
        assert_eq!(c.phi_b, a);
        let c = cs.compensate(&b, &a, 0.005, true);
        assert!((c.phi_b - b - a.cross(&b) / 12.0).norm() < 1e-18);
    }
}

#[cfg(test)]
mod sculling_tests {
    extern crate std;
    use super::*;
    use crate::attitude::rotation_vector_quat;
    use nalgebra::UnitQuaternion;
    use std::println;

    /// Sculling: roll `theta(t) = a sin(wt)` with specific force `b sin(wt)` along body y, in
    /// phase. Returns the velocity error [m/s] after `seconds` at 400 Hz against the exact
    /// inertial velocity, for the full compensation, the rotation term only, and none.
    fn sculling_errors(a: f64, b: f64, w: f64, seconds: f64) -> [f64; 3] {
        let dt = 1.0 / 400.0;
        let n = (seconds / dt).round() as usize;
        // Exact increments by fine Simpson quadrature of the body-frame rate and force, and the
        // exact inertial velocity from the same quadrature of C(t) f_b(t).
        let sub = 64;
        let h = dt / sub as f64;
        let omega = |t: f64| Vector3::new(a * w * (w * t).cos(), 0.0, 0.0);
        let f_b = |t: f64| Vector3::new(0.0, b * (w * t).sin(), 0.0);
        let f_i = |t: f64| {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), a * (w * t).sin()) * f_b(t)
        };
        let simpson = |g: &dyn Fn(f64) -> Vector3<f64>, t0: f64| {
            let mut s = g(t0) + g(t0 + dt);
            for j in 1..sub {
                s += g(t0 + j as f64 * h) * if j % 2 == 1 { 4.0 } else { 2.0 };
            }
            s * (h / 3.0)
        };
        let mut out = [0.0; 3];
        for (mode, e) in out.iter_mut().enumerate() {
            let mut cs = ConingSculling::new();
            let mut q = UnitQuaternion::identity();
            let (mut v, mut v_true) = (Vector3::zeros(), Vector3::zeros());
            for k in 0..n {
                let t0 = k as f64 * dt;
                let th = simpson(&omega, t0);
                let dv = simpson(&f_b, t0);
                v_true += simpson(&f_i, t0);
                let c = cs.compensate(&th, &dv, dt, mode == 0);
                let dv_b = if mode == 2 { dv } else { c.delta_v_b };
                v += q * dv_b;
                q *= rotation_vector_quat(&c.phi_b);
            }
            *e = (v - v_true).norm();
        }
        out
    }

    #[test]
    fn sculling_compensation_removes_the_rectified_error() {
        let [full, rotation_only, none] = sculling_errors(
            1f64.to_radians(),
            1.0,
            2.0 * core::f64::consts::PI * 5.0,
            10.0,
        );
        println!(
            "sculling 1 deg / 1 m/s^2 at 5 Hz, 10 s: error full {full:.3e}, rotation only {rotation_only:.3e}, none {none:.3e} m/s"
        );
        // The rectified sculling error is the dual of the coning drift (Savage §7.2.2.2): the
        // two-sample terms remove it to the same O(x^2) ratio, 5 / x^2 = 811 at x = w T = 0.0785.
        assert!(rotation_only / full >= 100.0, "{full} {rotation_only}");
        assert!(none / full >= 100.0, "{full} {none}");
    }

    #[test]
    fn second_order_rotation_compensation_is_exact_for_a_steady_spin() {
        // Spin at w about x under a specific force fixed in the reference frame, f = (0, 0, -g):
        // the body sees f_b(t) = R_x(-w t) f, and over [T, 2T] the velocity change in the axes
        // of the body at T is exactly R_x(-w T) f T. The two-sample sculling term and
        // a x (a x u) / 6 together cancel the second order; without the latter the error is
        // w^2 g T^3 / 12.
        let (w, g, dt) = (1.0_f64, 9.8_f64, 0.01_f64);
        let inc = |a: f64, b: f64| {
            let dv_b = Vector3::new(
                0.0,
                g * ((w * b).cos() - (w * a).cos()) / w,
                -g * ((w * b).sin() - (w * a).sin()) / w,
            );
            (Vector3::new(w * (b - a), 0.0, 0.0), dv_b)
        };
        let mut cs = ConingSculling::new();
        let (th0, v0) = inc(0.0, dt);
        cs.compensate(&th0, &v0, dt, true);
        let (th1, v1) = inc(dt, 2.0 * dt);
        let c = cs.compensate(&th1, &v1, dt, true);
        let exact = Vector3::new(0.0, -g * (w * dt).sin(), -g * (w * dt).cos()) * dt;
        let err = (c.delta_v_b - exact).norm();
        let second_order = w * w * g * dt * dt * dt / 12.0;
        println!("steady spin: residual {err:.2e} m/s, second-order term {second_order:.2e} m/s");
        assert!(err < 1e-2 * second_order, "{err} vs {second_order}");
    }
}
