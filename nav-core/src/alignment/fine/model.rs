//! The linearised INS error model of the fine-alignment filter: NED phi-angle (true-frame)
//! form, Titterton & Weston ch. 12, Groves 2nd ed. §14.2 (seed 000 eq. (22) in local-level
//! axes; the same equations as the host emulator `host_tests::emulate`), with the sensor biases
//! as states.
//!
//! State (offsets below), every error "computed minus true":
//! position error `dr_n = (dN, dE, dD)` [m], velocity error `dv_eb_n` [m/s], attitude error
//! `phi_n` [rad] (the computed attitude is `C_b_n(computed) = exp(-[phi_n x]) C_b_n`), residual
//! gyro bias `b_g` [rad/s] (body axes) and accelerometer bias `b_a` [m/s^2] (NED axes), measured
//! minus true, after the filter's own compensation:
//!
//! ```text
//! d(dr_n)/dt  = dv_eb_n
//! d(dv)/dt    = f_ib_n x phi + b_a - (2 omega_ie_n + omega_en_n) x dv + (0, 0, 2 g dD / R)
//! d(phi)/dt   = -omega_in_n x phi + d_omega_ie_n + d_omega_en_n - C_b_n b_g
//! d(b_g)/dt   = w_bg,  d(b_a)/dt = w_ba      (random walks, or constants)
//! ```
//! with `d_omega_ie_n = Omega (-sin L, 0, -cos L) dN / (R_N + h)` (Groves eq. 2.123
//! differentiated) and `d_omega_en_n = (dv_E / (R_E + h), -dv_N / (R_N + h),
//! -dv_E tan L / (R_E + h))` (Groves eq. 5.44 differentiated in the velocity).
//!
//! **Why the accelerometer bias is in NED axes.** On a base that does not turn (still, or
//! swaying by a few degrees) a body-fixed bias has a constant NED projection, to
//! `1 - cos(sway)` (0.4 % at 5 deg) horizontally; its sway-rate part (`b_x sin(pitch)` in the
//! vertical, `b_z sin(roll)` horizontally, 4e-4 m/s^2 at 5 deg) is left to the velocity's
//! process noise. Body-axis states projected with the computed attitude, `C_b_n b_a`, would
//! turn with every heading correction, while the tilt's velocity signature, `f x phi`, does not
//! in the small-angle model (it is turned by `psi / 2`, below): with the heading still moving by
//! degrees the filter then reads the correction as a change of the bias projection and
//! "observes" the horizontal bias that a still base cannot show (16–25 % of `b / g` in the
//! tests). In NED axes the tilt and the bias stay exactly as inseparable as they are. The cost:
//! on a rocking base with a well-measured vertical channel, the body bias's rocking in the
//! vertical (`b_x sin(pitch)`) would make the horizontal body biases weakly observable; that
//! information is not used.
//!
//! Neglected, because the filter aligns a base at rest or swaying about a fixed point
//! (`|v| < 1 m/s`): the terms of the transport rate in the position and height errors
//! (`~ v / R^2`, below `2.5e-14 rad/s per m`), `-(2 d_omega_ie + d_omega_en) x v` (below
//! `1e-10 m/s^2 per m`), and the horizontal position-error terms of `d(dr)/dt` (`v / R` per m).
//!
//! **Exactness for a large heading error.** With the attitude error as a rotation vector and the
//! navigation-frame rate known (position known), the attitude error obeys
//! `E(t) = exp(-[omega t]) E(0) exp([omega t])` for `E = C_b_n(computed) C_b_n^T`, so its
//! rotation vector obeys `d(phi)/dt = -omega_ie_n x phi` *exactly*, whatever the size of the
//! heading error. The only small-angle
//! step is the specific-force term `f_ib_n x phi`: the computed specific force is
//! `exp(-[phi x]) f_ib_n`, which at rest depends on the tilt part `e` of `phi` only, as
//! `f_ib_n x e'` with `e' = R_z(-psi/2) e * 2 sin(psi/2) / psi` for a heading error `psi`
//! (first order in `e`, exact in `psi`): the model's `f x phi` is turned by `psi / 2` and
//! scaled by `1 - psi^2/24`. The tilt drift `Omega cos(L) psi t` (exact) is therefore read as
//! a heading `psi (1 - psi^2/6)` (0.5 % short at 10 deg, 4.6 % at 30 deg) plus a cross drift
//! `~psi^2/2 Omega cos(L)`; the feedback of every update shrinks the heading error and the
//! model becomes exact again (validity in the module docs of [`super`]).

use crate::Scalar;
use crate::earth::{LocalEarth, OMEGA_IE};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Offset of the position error `(dN, dE, dD)` [m].
pub const POS: usize = 0;
/// Offset of the velocity error `dv_eb_n` [m/s].
pub const VEL: usize = 3;
/// Offset of the attitude error `phi_n` [rad].
pub const ATT: usize = 6;
/// Offset of the residual gyro bias `b_g` (body axes) [rad/s].
pub const GYRO_BIAS: usize = 9;
/// Offset of the residual accelerometer bias `b_a` (NED axes, module docs) [m/s^2].
pub const ACCEL_BIAS: usize = 12;
/// Number of states.
pub const N_STATES: usize = 15;

/// A state vector.
pub type State<T> = SVector<T, N_STATES>;
/// A state covariance or transition matrix.
pub type Matrix<T> = SMatrix<T, N_STATES, N_STATES>;

/// What the error model needs to know about the navigation solution over one filter interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linearisation<T: Scalar> {
    /// Earth quantities at the computed position.
    pub earth: LocalEarth<T>,
    /// Velocity `v_eb_n` [m/s] (NED).
    pub v_eb_n: Vector3<T>,
    /// Mean specific force over the interval `f_ib_n` [m/s^2] (NED).
    pub f_ib_n: Vector3<T>,
    /// Mean body-to-NED rotation over the interval `C_b_n` [-] (it multiplies the constant
    /// gyro bias, so its time average is the exact coupling).
    pub c_b_n: Matrix3<T>,
}

/// The system matrix `F` of the module's equations.
pub fn system_matrix<T: Scalar>(lin: &Linearisation<T>) -> Matrix<T> {
    let e = &lin.earth;
    let cos_lat = e.cos2_lat.sqrt();
    let (rn_h, re_h) = (e.r_meridian + e.h, e.r_transverse + e.h);
    let omega = T::c(OMEGA_IE);
    let omega_ie_n = Vector3::new(omega * cos_lat, T::zero(), -omega * e.sin_lat);
    // NED transport rate (Groves eq. 5.44); tan(lat) floored away from the pole.
    let tan_lat = e.sin_lat / cos_lat.max(T::c(1e-9));
    let v = &lin.v_eb_n;
    let omega_en_n = Vector3::new(v.y / re_h, -v.x / rn_h, -v.y * tan_lat / re_h);
    let omega_in_n = omega_ie_n + omega_en_n;

    let mut f = Matrix::<T>::zeros();
    // Position.
    f.fixed_view_mut::<3, 3>(POS, VEL)
        .copy_from(&Matrix3::identity());
    // Velocity.
    f.fixed_view_mut::<3, 3>(VEL, VEL)
        .copy_from(&-(omega_ie_n * T::c(2.0) + omega_en_n).cross_matrix());
    f.fixed_view_mut::<3, 3>(VEL, ATT)
        .copy_from(&lin.f_ib_n.cross_matrix());
    f.fixed_view_mut::<3, 3>(VEL, ACCEL_BIAS)
        .copy_from(&Matrix3::identity());
    // Vertical gravity gradient dg/dh = -2 g / R: a deeper computed position, more gravity.
    f[(VEL + 2, POS + 2)] = T::c(2.0) * e.g / (e.r_meridian * e.r_transverse).sqrt();
    // Attitude.
    f.fixed_view_mut::<3, 3>(ATT, ATT)
        .copy_from(&-omega_in_n.cross_matrix());
    // d_omega_ie_n from the latitude error dN / (R_N + h).
    f[(ATT, POS)] = -omega * e.sin_lat / rn_h;
    f[(ATT + 2, POS)] = -omega * cos_lat / rn_h;
    // d_omega_en_n from the velocity error.
    f[(ATT, VEL + 1)] = T::one() / re_h;
    f[(ATT + 1, VEL)] = -T::one() / rn_h;
    f[(ATT + 2, VEL + 1)] = -tan_lat / re_h;
    f.fixed_view_mut::<3, 3>(ATT, GYRO_BIAS)
        .copy_from(&-lin.c_b_n);
    f
}

/// Transition matrix over `dt` [s]: `Phi = I + F dt + (F dt)^2 / 2` (Groves eq. 3.34
/// truncated; the next term, `(F dt)^3 / 6`, is below `2e-4` of the `f x phi` coupling for
/// `dt <= 0.2 s`).
pub fn transition<T: Scalar>(lin: &Linearisation<T>, dt: T) -> Matrix<T> {
    let fdt = system_matrix(lin) * dt;
    Matrix::<T>::identity() + fdt + fdt * fdt * T::c(0.5)
}

/// Continuous process-noise spectral densities (diagonal of `Q_c`): gyro white noise
/// `gyro_noise` [rad/sqrt(s)] on the attitude, accelerometer white noise `accel_noise`
/// [m/s/sqrt(s)] on the velocity (both isotropic, so the rotation `C_b_n` drops out), bias
/// random walks `gyro_bias_walk` [rad/s/sqrt(s)] and `accel_bias_walk` [m/s^2/sqrt(s)].
pub fn noise_densities<T: Scalar>(
    gyro_noise: T,
    accel_noise: T,
    gyro_bias_walk: T,
    accel_bias_walk: T,
) -> State<T> {
    let mut q = State::<T>::zeros();
    for i in 0..3 {
        q[VEL + i] = accel_noise * accel_noise;
        q[ATT + i] = gyro_noise * gyro_noise;
        q[GYRO_BIAS + i] = gyro_bias_walk * gyro_bias_walk;
        q[ACCEL_BIAS + i] = accel_bias_walk * accel_bias_walk;
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at_rest(lat: f64) -> Linearisation<f64> {
        let earth = LocalEarth::new(lat, 0.0);
        Linearisation {
            earth,
            v_eb_n: Vector3::zeros(),
            f_ib_n: Vector3::new(0.0, 0.0, -earth.g),
            c_b_n: Matrix3::identity(),
        }
    }

    #[test]
    fn heading_error_tilts_east_at_the_horizontal_earth_rate() {
        // d(phi_E)/dt = Omega cos(L) phi_D (gyrocompassing); d(dv_N)/dt = g phi_E.
        let lat = 45f64.to_radians();
        let f = system_matrix(&at_rest(lat));
        assert!((f[(ATT + 1, ATT + 2)] - OMEGA_IE * lat.cos()).abs() < 1e-18);
        assert!((f[(VEL, ATT + 1)] - LocalEarth::new(lat, 0.0).g).abs() < 1e-12);
        assert!((f[(VEL + 1, ATT)] + LocalEarth::new(lat, 0.0).g).abs() < 1e-12);
    }

    #[test]
    fn schuler_period_of_the_horizontal_loop() {
        // Tilt -> velocity -> tilt: omega_s^2 = g / R (84.4 min, seed 000).
        let lat = 0.3;
        let f = system_matrix(&at_rest(lat));
        let w2 = -f[(VEL, ATT + 1)] * f[(ATT + 1, VEL)];
        let period_min = core::f64::consts::TAU / w2.sqrt() / 60.0;
        assert!((period_min - 84.4).abs() < 0.3, "{period_min}");
    }

    #[test]
    fn transition_of_a_constant_bias() {
        // A gyro bias tilts the frame at -C_b_n b_g: after dt, phi = -b_g dt to first order.
        let lin = at_rest(0.7);
        let phi = transition(&lin, 0.1);
        assert!((phi[(ATT, GYRO_BIAS)] + 0.1).abs() < 1e-9);
        assert!((phi[(POS, VEL)] - 0.1).abs() < 1e-12);
        // Position picks up half the velocity response to a tilt: g dt^2 / 2.
        assert!((phi[(POS, ATT + 1)] - lin.earth.g * 0.005).abs() < 1e-9);
    }
}
