//! One reference-generator period of readouts, fitted by least squares to
//! `r(u) = c + c' u + a cos(phi) + b sin(phi)` after undoing the body's rotation within the period.
//!
//! [Oscillator INS, eq. 2.16] takes `a` and `b` as the cosine and sine components of the readout at
//! the generator's phase `phi`. Over a period the readout is not that simple:
//!
//! - the body turns by `omega T` while the ellipse stays fixed in inertial space, so the readout
//!   in body axes is `r_b(tau) = D(tau)^T rho(tau)` with `D(tau)` the body's rotation from the
//!   period's reference instant `t_e` (`tau = 0`) to `t_e + tau`;
//! - the centre `c = -f/w0^2` moves when the specific force changes (and, in body axes, when the
//!   body turns).
//!
//! Fitting the plain components leaves errors of first order in `omega/w0` (the centre alone
//! leaks `2 omega x c / w0` into `b`). Here every sample is rotated back to the body axes at
//! `t_e` with the Taylor series of the body's rotation,
//! `D(tau) = I + tau W + tau^2 (W^2 + W')/2 + tau^3 (W^3 + W' W + 2 W W')/6`
//! (`W = [omega x]`, `W' = [omega_dot x]`; from `dC/dt = C W`), and the centre is given a linear
//! trend. Since `D` is linear in the readout, the window keeps
//! the moments `S_j = sum u^j B r` (`j = 0..3`, `B` the four basis functions, `u = tau/T` the
//! time in periods) and applies `D` at the end of the period, when the rate is known: the fit
//! needs no rate while it accumulates. With `W = 0` it is the demodulation of [Oscillator INS] plus
//! the trend.

use crate::Scalar;
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};

/// Orders of the rotation's Taylor series kept (`u^0 .. u^3`).
const ORDERS: usize = 4;
/// Basis functions: `1`, `u`, `cos(phi)`, `sin(phi)`.
const BASIS: usize = 4;
/// Index of the centre's coefficient in the basis.
pub const CENTRE: usize = 0;
/// Index of the centre's trend (per period) in the basis.
pub const TREND: usize = 1;
/// Index of the cosine component `a`.
pub const COS: usize = 2;
/// Index of the sine component `b`.
pub const SIN: usize = 3;

/// The sums of one period.
#[derive(Clone, Copy, Debug)]
pub struct Window<T: Scalar> {
    /// `moments[j][i] = sum u^j B_i r` [m].
    moments: [[Vector3<T>; BASIS]; ORDERS],
    /// `sum B B^T`.
    normal: Matrix4<T>,
    /// `second[m] = sum u^m r r^T` [m^2], `m = 0..6`: the squared norm of the rotated-back
    /// readouts, `sum |D r|^2 = sum_jl tr(D_j^T D_l second[j + l])`, which the residual needs (the
    /// truncated series is not exactly a rotation, and its `|D r|^2 - |r|^2` would swamp the
    /// noise's share).
    second: [Matrix3<T>; 2 * ORDERS - 1],
    /// Samples in the window.
    samples: u32,
    /// Readouts of the period, missing ones included.
    seen: u32,
    /// `false` once a sample was missing or not finite: the period is discarded.
    intact: bool,
}

/// The fitted components of one period, in body axes at the reference instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowFit<T: Scalar> {
    /// Centre of the ellipse at `u = 0` [m].
    pub centre: Vector3<T>,
    /// Cosine component `a` [m] ([Oscillator INS, eq. 2.16]).
    pub a: Vector3<T>,
    /// Sine component `b` [m].
    pub b: Vector3<T>,
    /// RMS residual of one readout component [m].
    pub residual_rms: T,
    /// Standard error of one component of the centre per metre of readout noise [-].
    pub centre_gain: T,
    /// The same for `a` [-].
    pub cos_gain: T,
    /// The same for `b` [-] (larger than `a`'s with the trend: `sin` and the trend correlate).
    pub sin_gain: T,
}

impl<T: Scalar> Default for Window<T> {
    fn default() -> Self {
        Self {
            moments: [[Vector3::zeros(); BASIS]; ORDERS],
            normal: Matrix4::zeros(),
            second: [Matrix3::zeros(); 2 * ORDERS - 1],
            samples: 0,
            seen: 0,
            intact: true,
        }
    }
}

impl<T: Scalar> Window<T> {
    /// Adds a readout `r_b` [m] at time `u` [periods] from the reference instant and generator
    /// phase with `(cos, sin)`.
    #[inline]
    pub fn add(&mut self, u: T, cos: T, sin: T, r_b: &Vector3<T>) {
        let basis = Vector4::new(T::one(), u, cos, sin);
        self.normal += basis * basis.transpose();
        let mut w = T::one();
        for moment in self.moments.iter_mut() {
            for (m, b) in moment.iter_mut().zip(basis.iter()) {
                *m += r_b * (*b * w);
            }
            w *= u;
        }
        let rr = r_b * r_b.transpose();
        let mut w = T::one();
        for m in self.second.iter_mut() {
            *m += rr * w;
            w *= u;
        }
        self.samples += 1;
        self.seen += 1;
    }

    /// Marks the period as broken (a missing or non-finite readout).
    pub fn break_off(&mut self) {
        self.intact = false;
        self.seen += 1;
    }

    /// `true` while no readout was missing.
    pub fn intact(&self) -> bool {
        self.intact
    }

    /// Readouts fitted in the period.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Readouts of the period, missing ones included.
    pub fn samples_seen(&self) -> u32 {
        self.seen
    }

    /// The least-squares fit after rotating every readout back by the body's rotation with rate
    /// `w_t = omega T` [rad per period] and acceleration `w_dot_t2 = omega_dot T^2`; without
    /// `trend` the centre is taken constant (the plain demodulation of [Oscillator INS]). `None` if
    /// the normal matrix is singular (too few readouts).
    pub fn fit(
        &self,
        w_t: &Vector3<T>,
        w_dot_t2: &Vector3<T>,
        trend: bool,
    ) -> Option<WindowFit<T>> {
        let mut normal = self.normal;
        if !trend {
            // Decouple the trend: its coefficient solves to 0 and the others see no trend.
            for i in 0..BASIS {
                normal[(TREND, i)] = T::zero();
                normal[(i, TREND)] = T::zero();
            }
            normal[(TREND, TREND)] = T::one();
        }
        let chol = normal.cholesky()?;
        let w = w_t.cross_matrix();
        let wd = w_dot_t2.cross_matrix();
        let w2 = w * w;
        let d: [Matrix3<T>; ORDERS] = [
            Matrix3::identity(),
            w,
            (w2 + wd) * T::c(0.5),
            (w2 * w + wd * w + w * wd * T::c(2.0)) * T::c(1.0 / 6.0),
        ];
        // y_i = sum_j D_j S_j[i]: the derotated right-hand sides, one 3-vector per basis function.
        let mut y = [Vector3::<T>::zeros(); BASIS];
        for (dj, moment) in d.iter().zip(self.moments.iter()) {
            for (yi, m) in y.iter_mut().zip(moment.iter()) {
                *yi += dj * m;
            }
        }
        if !trend {
            y[TREND] = Vector3::zeros();
        }
        let mut coef = [Vector3::<T>::zeros(); BASIS];
        let mut ssr = T::zero();
        for (j, dj) in d.iter().enumerate() {
            for (l, dl) in d.iter().enumerate() {
                ssr += (dj.transpose() * dl)
                    .component_mul(&self.second[j + l])
                    .sum();
            }
        }
        for axis in 0..3 {
            let rhs = Vector4::new(y[0][axis], y[1][axis], y[2][axis], y[3][axis]);
            let x = chol.solve(&rhs);
            for i in 0..BASIS {
                coef[i][axis] = x[i];
            }
            ssr -= x.dot(&rhs);
        }
        let dof = T::c(f64::from(
            3 * self.samples.saturating_sub(BASIS as u32).max(1),
        ));
        let inv = chol.inverse();
        Some(WindowFit {
            centre: coef[CENTRE],
            a: coef[COS],
            b: coef[SIN],
            residual_rms: (ssr.max(T::zero()) / dof).sqrt(),
            centre_gain: inv[(CENTRE, CENTRE)].sqrt(),
            cos_gain: inv[(COS, COS)].sqrt(),
            sin_gain: inv[(SIN, SIN)].sqrt(),
        })
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use core::f64::consts::PI;
    use nalgebra::UnitQuaternion;

    /// A fixed ellipse seen from a body turning at a constant rate: the derotated fit recovers
    /// it exactly (to the series' fourth-order remainder); the plain fit is off at first order.
    #[test]
    fn derotation_removes_the_first_order_error() {
        let n = 200;
        let omega = Vector3::new(0.3, -0.2, 0.5_f64); // [rad per period]
        let (a, b, c) = (
            Vector3::new(20e-6, 0.0, 0.0),
            Vector3::new(0.0, 10e-6, 0.0),
            Vector3::new(1e-6, -2e-6, 25e-6),
        );
        let mut win = Window::<f64>::default();
        for k in 0..n {
            let u = (k as f64 + 0.5) / n as f64 - 0.5;
            let phi = 2.0 * PI * u;
            let rho = c + a * phi.cos() + b * phi.sin();
            // Body axes at u: r_b = D(u)^T rho, D(u) = exp(u W).
            let r_b = UnitQuaternion::from_scaled_axis(omega * u).inverse() * rho;
            win.add(u, phi.cos(), phi.sin(), &r_b);
        }
        let plain = win
            .fit(&Vector3::zeros(), &Vector3::zeros(), false)
            .unwrap();
        let fit = win.fit(&omega, &Vector3::zeros(), true).unwrap();
        // Remainder of the series: |u W|^4/24 at |u| <= 1/2, relative.
        let bound = (omega.norm() * 0.5).powi(4) / 24.0 * c.norm();
        let err = (fit.a - a)
            .norm()
            .max((fit.b - b).norm())
            .max((fit.centre - c).norm());
        let plain_err = (plain.b - b).norm();
        std::println!("derotated error {err:.2e} m (bound {bound:.2e}), plain {plain_err:.2e} m");
        assert!(err < bound, "{err:e} >= {bound:e}");
        // The plain fit's `b` is off by about 2 omega x c/(2 pi) per period (the centre leaks).
        let leak = omega.cross(&c).norm() / PI;
        assert!(plain_err > 0.5 * leak, "{plain_err:e} vs {leak:e}");
    }
}
