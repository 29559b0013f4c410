//! The fine filters' error model: the INS error equations at a fixed site in the level frame
//! `c` of unknown azimuth ([`super::integrator`]), the horizontal Earth rate as two states, the
//! lever arm as three, and the base's translation as a shaping process ([`super::base`]).
//!
//! Errors are "computed minus true" (biases: what is left in the compensated output):
//! ```text
//! d(dr)/dt  = dv
//! d(dv)/dt  = f_c x phi + C_b_c b_a - 2 omega_ie_c x dv + (0, 0, 2 g dr_D / R)
//! d(phi)/dt = -omega_ie_c x phi + (de_N, de_E, 0) - C_b_c b_g
//! d(de)/dt  = 0,  d(b_g)/dt = w_bg,  d(b_a)/dt = w_ba,  d(dl)/dt = 0
//! ```
//! [Titterton & Weston, eq. 12.18-12.20; Groves, §14.2.4] with the navigation frame's rate
//! error `omega_hat - omega = (de_N, de_E, 0)`: a wrong azimuth is a wrong horizontal Earth rate
//! in `c`, and gyrocompassing is the estimation of `de` from the tilt drift it causes
//! [Berdinskikh et al., eq. 22]. `C_b_c` is the integrator's own attitude, so the bias
//! couplings do not depend on the unknown heading. The attitude error is a rotation vector
//! (`C_hat = exp(-[phi x]) C`); with the heading outside the state it stays small (tilt and the
//! vertical gyro's drift), and the model is linear in it.
//!
//! The measurement, every filter interval: the IMU's displacement minus its lever-arm offset,
//! `z = r_hat - C_hat l_hat = dr + d - [(C_hat l_hat) x] phi - C_hat dl` (`d` the centre's
//! translation, [`super::base`]), per axis of `c`. The displacement state is not `dr` itself
//! but `s = dr - C0 dl` (`C0` the starting attitude): with an unknown lever arm `dr` and `dl`
//! both start metres wide and the first measurement ties them to a tenth of a millimetre, a
//! correlation `f32` cannot hold; `s` starts small (the tilt turning the lever arm, the
//! translation) and the measurement reads `z = s + d - [(C_hat l_hat) x] phi - (C_hat - C0)
//! dl`: the lever arm shows only as the body turns.
//!
//! **Units.** The filter keeps its states in the [`UNITS`] below (centimetres, millimetres
//! per second, milliradians, micro-radians per second, ...) so that in `f32` every variance
//! stays within about `1e-4..1e4`; the matrices are built in SI and scaled once.

use crate::Scalar;
use nalgebra::{Matrix3, SMatrix, Vector3};

/// Offset of the displacement error `s = dr - C0 dl` (3) [m] (module docs).
pub const POS: usize = 0;
/// Offset of the velocity error `dv` (3) [m/s].
pub const VEL: usize = 3;
/// Offset of the attitude error `phi` (3) [rad].
pub const ATT: usize = 6;
/// Offset of the horizontal Earth-rate error `(de_N, de_E)` in `c` (2) [rad/s].
pub const EARTH: usize = 9;
/// Offset of the residual gyro bias, body axes (3) [rad/s].
pub const GYRO_BIAS: usize = 11;
/// Offset of the residual accelerometer bias, body axes (3) [m/s^2].
pub const ACCEL_BIAS: usize = 14;
/// Offset of the lever-arm error `dl`, body axes (3) [m].
pub const LEVER: usize = 17;
/// The INS part: every state above.
pub const INS_STATES: usize = 20;
/// Offset of the base's translation: per axis `k` of `c` the block `(z, d, d')` at
/// `BASE + 3 k` ([`super::base`]) [m s, m, m/s].
pub const BASE: usize = 20;
/// States of the general filter.
pub const FINE_STATES: usize = 29;

/// The unit each state is kept in (SI value = filter value x unit).
pub const UNITS: [f64; FINE_STATES] = [
    1e-2, 1e-2, 1e-2, // dr: cm
    1e-3, 1e-3, 1e-3, // dv: mm/s
    1e-3, 1e-3, 1e-3, // phi: mrad
    1e-6, 1e-6, // de: urad/s
    1e-6, 1e-6, 1e-6, // b_g: urad/s
    1e-3, 1e-3, 1e-3, // b_a: mm/s^2
    1e-2, 1e-2, 1e-2, // dl: cm
    1e-1, 1e-2, 1e-2, // base N: z [dm s], d [cm], d' [cm/s]
    1e-1, 1e-2, 1e-2, // base E
    1e-1, 1e-2, 1e-2, // base D
];

/// The unit of state `i` of a filter with extra states past [`FINE_STATES`] (those in SI).
pub fn unit(i: usize) -> f64 {
    UNITS.get(i).copied().unwrap_or(1.0)
}

/// What the INS error model needs over one filter interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linearisation<T: Scalar> {
    /// The Earth rate in `c` used by the integrator [rad/s].
    pub omega_ie_c: Vector3<T>,
    /// Mean specific force over the interval in `c` [m/s^2].
    pub f_c: Vector3<T>,
    /// Mean `C_b_c` over the interval (it multiplies constant biases: its mean is the exact
    /// coupling).
    pub c_b_c: Matrix3<T>,
    /// `dg/dr_D = 2 g / R` [1/s^2].
    pub dg_dd: T,
}

/// The INS part of the system matrix `F` (module equations), in SI units.
pub fn ins_system_matrix<T: Scalar>(lin: &Linearisation<T>) -> SMatrix<T, INS_STATES, INS_STATES> {
    let mut f = SMatrix::<T, INS_STATES, INS_STATES>::zeros();
    f.fixed_view_mut::<3, 3>(POS, VEL)
        .copy_from(&Matrix3::identity());
    f.fixed_view_mut::<3, 3>(VEL, VEL)
        .copy_from(&-(lin.omega_ie_c * T::c(2.0)).cross_matrix());
    f.fixed_view_mut::<3, 3>(VEL, ATT)
        .copy_from(&lin.f_c.cross_matrix());
    f.fixed_view_mut::<3, 3>(VEL, ACCEL_BIAS)
        .copy_from(&lin.c_b_c);
    f[(VEL + 2, POS + 2)] = lin.dg_dd;
    f.fixed_view_mut::<3, 3>(ATT, ATT)
        .copy_from(&-lin.omega_ie_c.cross_matrix());
    f[(ATT, EARTH)] = T::one();
    f[(ATT + 1, EARTH + 1)] = T::one();
    f.fixed_view_mut::<3, 3>(ATT, GYRO_BIAS)
        .copy_from(&-lin.c_b_c);
    f
}

/// Transition over `dt` [s] of the INS part: `Phi = I + F dt + (F dt)^2 / 2 + (F dt)^3 / 6`
/// [Groves, eq. 3.34 truncated; the next term is below 1e-6 of the largest coupling for
/// `dt <= 0.2 s`].
pub fn ins_transition<T: Scalar>(
    lin: &Linearisation<T>,
    dt: T,
) -> SMatrix<T, INS_STATES, INS_STATES> {
    let fdt = ins_system_matrix(lin) * dt;
    let f2 = fdt * fdt;
    SMatrix::identity() + fdt + f2 * T::c(0.5) + f2 * fdt * T::c(1.0 / 6.0)
}

/// Continuous white-noise densities of the INS part (diagonal of `Q_c`, SI): accelerometer
/// white noise `vrw` [m/s/sqrt(s)] on the velocity, gyro white noise `arw` [rad/sqrt(s)] on the
/// attitude (isotropic, so the rotation to `c` drops out), bias random walks [rad/s/sqrt(s)],
/// [m/s^2/sqrt(s)].
pub fn ins_noise<T: Scalar>(
    arw: T,
    vrw: T,
    gyro_bias_walk: T,
    accel_bias_walk: T,
) -> nalgebra::SVector<T, INS_STATES> {
    let mut q = nalgebra::SVector::<T, INS_STATES>::zeros();
    for i in 0..3 {
        q[VEL + i] = vrw * vrw;
        q[ATT + i] = arw * arw;
        q[GYRO_BIAS + i] = gyro_bias_walk * gyro_bias_walk;
        q[ACCEL_BIAS + i] = accel_bias_walk * accel_bias_walk;
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::{LocalEarth, OMEGA_IE};

    fn at_rest(lat: f64, alpha: f64) -> Linearisation<f64> {
        let e = LocalEarth::new(lat, 0.0);
        let w = OMEGA_IE * lat.cos();
        Linearisation {
            omega_ie_c: Vector3::new(w * alpha.cos(), -w * alpha.sin(), -OMEGA_IE * lat.sin()),
            f_c: Vector3::new(0.0, 0.0, -e.g),
            c_b_c: Matrix3::identity(),
            dg_dd: 2.0 * e.g / e.r_meridian,
        }
    }

    #[test]
    fn earth_rate_error_tilts_the_frame_and_the_tilt_moves_the_velocity() {
        let f = ins_system_matrix(&at_rest(0.7, 0.3));
        assert_eq!(f[(ATT, EARTH)], 1.0);
        assert_eq!(f[(ATT + 1, EARTH + 1)], 1.0);
        let g = LocalEarth::new(0.7, 0.0).g;
        // d(dv_N)/dt = g phi_E, d(dv_E)/dt = -g phi_N (f = -g e_D).
        assert!((f[(VEL, ATT + 1)] - g).abs() < 1e-12);
        assert!((f[(VEL + 1, ATT)] + g).abs() < 1e-12);
    }

    #[test]
    fn schuler_loop_is_absent_but_the_tilt_loop_is_exact() {
        // A constant de_E for dt: phi_E = de_E dt, dv_N = g de_E dt^2 / 2 (+ higher order).
        let lin = at_rest(0.7, 1.0);
        let phi = ins_transition(&lin, 0.1);
        assert!((phi[(ATT + 1, EARTH + 1)] - 0.1).abs() < 1e-9);
        assert!((phi[(VEL, EARTH + 1)] - lin.f_c.z.abs() * 0.005).abs() < 1e-6);
    }
}
