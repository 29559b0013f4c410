//! WGS-84 Earth model: radii of curvature, Earth and transport rates, normal gravity.
//!
//! References: NIMA TR8350.2 (WGS-84 constants); Groves, *Principles of GNSS, Inertial, and
//! Multisensor Integrated Navigation Systems*, 2nd ed., ch. 2 (eqs. 2.105–2.106, 2.123, 2.134,
//! 2.139); Titterton & Weston ch. 3.

use crate::Scalar;
use nalgebra::Vector3;

/// WGS-84 semi-major axis `a` [m].
pub const A_M: f64 = 6_378_137.0;
/// WGS-84 flattening `f` [-].
pub const FLATTENING: f64 = 1.0 / 298.257_223_563;
/// First eccentricity squared `e^2 = f (2 - f)` [-].
pub const E2: f64 = FLATTENING * (2.0 - FLATTENING);
/// Semi-minor axis `b = a (1 - f)` [m].
pub const B_M: f64 = A_M * (1.0 - FLATTENING);
/// Earth rotation rate `Omega_ie` [rad/s].
pub const OMEGA_IE: f64 = 7.292_115e-5;
/// Earth gravitational constant `GM` [m^3/s^2].
pub const GM: f64 = 3.986_004_418e14;
/// Normal gravity at the equator `gamma_e` [m/s^2].
pub const GAMMA_EQUATOR: f64 = 9.780_325_335_9;
/// Somigliana's constant `k = (b gamma_p) / (a gamma_e) - 1` [-].
pub const SOMIGLIANA_K: f64 = 0.001_931_852_652_458;
/// `m = Omega^2 a^2 b / GM`, used by the height correction of normal gravity [-].
pub const M_GRAV: f64 = OMEGA_IE * OMEGA_IE * A_M * A_M * B_M / GM;

/// Radii of curvature at geodetic latitude `lat` [rad]: `(r_meridian, r_transverse)` [m]
/// (Groves eqs. 2.105 and 2.106; `R_N` and `R_E` in Groves' notation).
#[inline]
pub fn radii<T: Scalar>(lat: T) -> (T, T) {
    let s = lat.sin();
    let den = T::one() - T::c(E2) * s * s;
    let r_transverse = T::c(A_M) / den.sqrt();
    let r_meridian = T::c(A_M * (1.0 - E2)) / (den * den.sqrt());
    (r_meridian, r_transverse)
}

/// Earth rotation rate resolved in NED axes `omega_ie_n` [rad/s] at latitude `lat` [rad]
/// (Groves eq. 2.123).
#[inline]
pub fn omega_ie_n<T: Scalar>(lat: T) -> Vector3<T> {
    let w = T::c(OMEGA_IE);
    Vector3::new(w * lat.cos(), T::zero(), -w * lat.sin())
}

/// Transport rate `omega_en_n` [rad/s] of the NED frame for velocity `v_eb_n` [m/s] at latitude
/// `lat` [rad] and height `h` [m] (Groves eq. 5.44).
#[inline]
pub fn omega_en_n<T: Scalar>(lat: T, h: T, v_eb_n: &Vector3<T>) -> Vector3<T> {
    let (r_meridian, r_transverse) = radii(lat);
    let re_h = r_transverse + h;
    Vector3::new(
        v_eb_n.y / re_h,
        -v_eb_n.x / (r_meridian + h),
        -v_eb_n.y * lat.tan() / re_h,
    )
}

/// WGS-84 normal gravity magnitude [m/s^2] at geodetic latitude `lat` [rad] and height `h` [m]:
/// Somigliana's formula on the ellipsoid (Groves eq. 2.134) with the second-order height
/// correction (Groves eq. 2.139). The NED gravity vector is `(0, 0, normal_gravity)`.
#[inline]
pub fn normal_gravity<T: Scalar>(lat: T, h: T) -> T {
    let s2 = lat.sin() * lat.sin();
    let g0 = T::c(GAMMA_EQUATOR) * (T::one() + T::c(SOMIGLIANA_K) * s2)
        / (T::one() - T::c(E2) * s2).sqrt();
    let a = T::c(A_M);
    let lin = T::c(2.0) / a * (T::one() + T::c(FLATTENING) + T::c(M_GRAV) - T::c(2.0 * FLATTENING) * s2);
    g0 * (T::one() - lin * h + T::c(3.0) * h * h / (a * a))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_gravity_matches_published_values() {
        // WGS-84 (NIMA TR8350.2 table 3.4): gamma_e = 9.7803253359, gamma_p = 9.8321849378 m/s^2.
        assert!((normal_gravity(0.0_f64, 0.0) - 9.780_325_335_9).abs() < 1e-9);
        let pole = normal_gravity(core::f64::consts::FRAC_PI_2, 0.0);
        assert!((pole - 9.832_184_937_8).abs() < 1e-8, "{pole}");
        // Free-air gradient ~ -3.086e-6 s^-2 near the surface.
        let grad = (normal_gravity(0.8_f64, 1000.0) - normal_gravity(0.8_f64, 0.0)) / 1000.0;
        assert!((grad + 3.086e-6).abs() < 0.01e-6, "{grad}");
    }

    #[test]
    fn radii_at_equator_and_pole() {
        let (rm, rt) = radii(0.0_f64);
        assert!((rt - A_M).abs() < 1e-6);
        assert!((rm - A_M * (1.0 - E2)).abs() < 1e-6);
        let (rm, rt) = radii(core::f64::consts::FRAC_PI_2);
        // At the pole both radii equal a^2 / b.
        assert!((rm - A_M * A_M / B_M).abs() < 1e-4 && (rt - rm).abs() < 1e-4);
    }
}
