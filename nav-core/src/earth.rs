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

/// Earth quantities at one place, computed once per navigation step: one `sin` and one `cos` of
/// the latitude serve the radii, the rates and gravity (libm's `f32` trigonometry is costly on a
/// Cortex-M4, which has no double-precision FPU).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalEarth<T: Scalar> {
    /// `sin(lat)` [-].
    pub sin_lat: T,
    /// `cos(lat)` [-].
    pub cos_lat: T,
    /// Height `h` [m].
    pub h: T,
    /// Meridian radius of curvature `R_N` [m] (Groves eq. 2.105).
    pub r_meridian: T,
    /// Transverse (prime-vertical) radius of curvature `R_E` [m] (Groves eq. 2.106).
    pub r_transverse: T,
    /// Normal gravity magnitude [m/s^2]; the NED gravity vector is `(0, 0, g)`.
    pub g: T,
}

impl<T: Scalar> LocalEarth<T> {
    /// Earth quantities at geodetic latitude `lat` [rad] and height `h` [m].
    #[inline]
    pub fn new(lat: T, h: T) -> Self {
        let (sin_lat, cos_lat) = (lat.sin(), lat.cos());
        let s2 = sin_lat * sin_lat;
        let den = T::one() - T::c(E2) * s2;
        let sqrt_den = den.sqrt();
        let r_transverse = T::c(A_M) / sqrt_den;
        let r_meridian = T::c(A_M * (1.0 - E2)) / (den * sqrt_den);
        // Somigliana (Groves eq. 2.134) with the height correction (Groves eq. 2.139).
        let g0 = T::c(GAMMA_EQUATOR) * (T::one() + T::c(SOMIGLIANA_K) * s2) / sqrt_den;
        let a = T::c(A_M);
        let lin = T::c(2.0) / a
            * (T::one() + T::c(FLATTENING) + T::c(M_GRAV) - T::c(2.0 * FLATTENING) * s2);
        let g = g0 * (T::one() - lin * h + T::c(3.0) * h * h / (a * a));
        Self {
            sin_lat,
            cos_lat,
            h,
            r_meridian,
            r_transverse,
            g,
        }
    }

    /// Earth rotation rate in NED axes `omega_ie_n` [rad/s] (Groves eq. 2.123).
    #[inline]
    pub fn omega_ie_n(&self) -> Vector3<T> {
        let w = T::c(OMEGA_IE);
        Vector3::new(w * self.cos_lat, T::zero(), -w * self.sin_lat)
    }

    /// Transport rate `omega_en_n` [rad/s] of the NED frame for velocity `v_eb_n` [m/s]
    /// (Groves eq. 5.44).
    #[inline]
    pub fn omega_en_n(&self, v_eb_n: &Vector3<T>) -> Vector3<T> {
        let re_h = self.r_transverse + self.h;
        Vector3::new(
            v_eb_n.y / re_h,
            -v_eb_n.x / (self.r_meridian + self.h),
            -v_eb_n.y * self.sin_lat / (self.cos_lat * re_h),
        )
    }
}

/// Radii of curvature at geodetic latitude `lat` [rad]: `(r_meridian, r_transverse)` [m]
/// (Groves eqs. 2.105 and 2.106; `R_N` and `R_E` in Groves' notation).
pub fn radii<T: Scalar>(lat: T) -> (T, T) {
    let e = LocalEarth::new(lat, T::zero());
    (e.r_meridian, e.r_transverse)
}

/// Earth rotation rate resolved in NED axes `omega_ie_n` [rad/s] at latitude `lat` [rad]
/// (Groves eq. 2.123).
pub fn omega_ie_n<T: Scalar>(lat: T) -> Vector3<T> {
    let w = T::c(OMEGA_IE);
    Vector3::new(w * lat.cos(), T::zero(), -w * lat.sin())
}

/// WGS-84 normal gravity magnitude [m/s^2] at geodetic latitude `lat` [rad] and height `h` [m]:
/// Somigliana's formula on the ellipsoid (Groves eq. 2.134) with the second-order height
/// correction (Groves eq. 2.139). The NED gravity vector is `(0, 0, normal_gravity)`.
pub fn normal_gravity<T: Scalar>(lat: T, h: T) -> T {
    LocalEarth::new(lat, h).g
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
    fn transport_rate_of_an_eastward_velocity() {
        // East at 100 m/s on the equator: the frame turns about north at v / R_E.
        let e = LocalEarth::new(0.0_f64, 0.0);
        let w = e.omega_en_n(&Vector3::new(0.0, 100.0, 0.0));
        assert!((w.x - 100.0 / A_M).abs() < 1e-15 && w.y == 0.0 && w.z.abs() < 1e-15);
        // North at 45 deg: about -east at v / (R_N + h).
        let e = LocalEarth::new(45f64.to_radians(), 1000.0);
        let w = e.omega_en_n(&Vector3::new(100.0, 0.0, 0.0));
        assert!((w.y + 100.0 / (e.r_meridian + 1000.0)).abs() < 1e-15);
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
