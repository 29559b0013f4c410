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

/// Earth quantities at one place, computed once per navigation step from the local vertical
/// (no trigonometry: `sin(lat)` and `cos(lat)^2` are elements of the position matrix, see
/// [`crate::Position::vertical_row`]; libm's `f32` trigonometry runs in soft double precision on a
/// Cortex-M4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalEarth<T: Scalar> {
    /// `sin(lat)` [-].
    pub sin_lat: T,
    /// `cos(lat)^2` [-] (kept squared: exact from the position matrix, no square root).
    pub cos2_lat: T,
    /// Height `h` [m].
    pub h: T,
    /// Meridian radius of curvature `R_N` [m] (Groves eq. 2.105).
    pub r_meridian: T,
    /// Transverse (prime-vertical) radius of curvature `R_E` [m] (Groves eq. 2.106).
    pub r_transverse: T,
    /// Normal gravity magnitude [m/s^2]; the gravity vector in any local-level frame is
    /// `(0, 0, g)` (down).
    pub g: T,
}

impl<T: Scalar> LocalEarth<T> {
    /// Earth quantities at geodetic latitude `lat` [rad] and height `h` [m] (one `sin`, one
    /// `cos`; the navigation step uses [`LocalEarth::from_sin_lat`] instead).
    #[inline]
    pub fn new(lat: T, h: T) -> Self {
        let c = lat.pcos();
        Self::from_sin_lat(lat.psin(), c * c, h)
    }

    /// Earth quantities from `sin(lat)`, `cos(lat)^2` [-] and height `h` [m].
    #[inline]
    pub fn from_sin_lat(sin_lat: T, cos2_lat: T, h: T) -> Self {
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
            cos2_lat,
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
        Vector3::new(w * self.cos2_lat.sqrt(), T::zero(), -w * self.sin_lat)
    }

    /// Transport rate `omega_en_n` [rad/s] of the NED frame for velocity `v_eb_n` [m/s]
    /// (Groves eq. 5.44). Singular at the poles: use [`LocalEarth::transport_rate`] with a
    /// wander-azimuth frame there.
    #[inline]
    pub fn omega_en_n(&self, v_eb_n: &Vector3<T>) -> Vector3<T> {
        let re_h = self.r_transverse + self.h;
        Vector3::new(
            v_eb_n.y / re_h,
            -v_eb_n.x / (self.r_meridian + self.h),
            -v_eb_n.y * self.sin_lat / (self.cos2_lat.sqrt() * re_h),
        )
    }

    /// Horizontal transport rate [rad/s] of any local-level frame whose vertical row of
    /// `C_n_e` is `c_n` (`c_n = (cos(lat) cos(alpha), -cos(lat) sin(alpha), -sin(lat))` for a
    /// wander angle `alpha`), for velocity `v_eb_n` [m/s]; the vertical component is 0 (the
    /// wander-azimuth frame's definition; add `-v_E tan(lat) / (R_E + h)` for NED).
    ///
    /// `rho_h = -F_c (u_d x v)` with the curvature matrix `F_c = I / (R_N + h) - k c c^T`,
    /// `k = a e^2 / (D^3 (R_N + h)(R_E + h))`, `D^2 = 1 - e^2 sin^2(lat)`: the north direction
    /// (along `c`) takes `1 / (R_E + h)`, the east one `1 / (R_N + h)` (Groves eq. 5.44 rotated
    /// by the wander angle; Savage §5.3). Regular at the poles, where `c` vanishes.
    #[inline]
    pub fn transport_rate(&self, c_n: &Vector3<T>, v_eb_n: &Vector3<T>) -> Vector3<T> {
        let rn_h = self.r_meridian + self.h;
        let re_h = self.r_transverse + self.h;
        // a e^2 / D^3 = e^2 R_N / (1 - e^2)
        let k = T::c(E2 / (1.0 - E2)) * self.r_meridian / (rn_h * re_h);
        // u_d x v = (-v_y, v_x, 0)
        let (ux, uy) = (-v_eb_n.y, v_eb_n.x);
        let cu = c_n.x * ux + c_n.y * uy;
        Vector3::new(
            -(ux / rn_h - k * c_n.x * cu),
            -(uy / rn_h - k * c_n.y * cu),
            T::zero(),
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
    Vector3::new(w * lat.pcos(), T::zero(), -w * lat.psin())
}

/// WGS-84 normal gravity magnitude [m/s^2] at geodetic latitude `lat` [rad] and height `h` [m]:
/// Somigliana's formula on the ellipsoid (Groves eq. 2.134) with the second-order height
/// correction (Groves eq. 2.139). The NED gravity vector is `(0, 0, normal_gravity)`.
pub fn normal_gravity<T: Scalar>(lat: T, h: T) -> T {
    LocalEarth::new(lat, h).g
}

/// Oblateness coefficient of [Berdinskikh et al., eq. 14], `I = 1.6375e-3` [-] (the classical
/// `3/2 J2`; WGS-84's `J2 = 1.08263e-3` gives 1.6239e-3).
pub const OBLATENESS_I: f64 = 1.6375e-3;

/// Gravitation (mass attraction only, no centrifugal term) [m/s^2] at the Earth-centred position
/// `r` [m], [Berdinskikh et al., eq. 14]:
/// `g_x = -(GM/r^3) [1 + I a^2/r^2 (1 - 5 z^2/r^2)] x`, the same for `y`, and
/// `g_z = -(GM/r^3) [1 + I a^2/r^2 (3 - 5 z^2/r^2)] z`.
///
/// The axes may be Earth-fixed or inertial as long as `z` is the polar axis. Returns zeros for
/// `r = 0`.
pub fn gravitation<T: Scalar>(r: &Vector3<T>) -> Vector3<T> {
    gravitation_with(r, T::c(OBLATENESS_I))
}

/// [`gravitation`] with another oblateness coefficient `i` [-] (e.g. `1.5 * J2_WGS84`).
pub fn gravitation_with<T: Scalar>(r: &Vector3<T>, i: T) -> Vector3<T> {
    let r2 = r.norm_squared();
    if r2 <= T::zero() {
        return Vector3::zeros();
    }
    let rn = r2.sqrt();
    let gm_r3 = T::c(GM) / (r2 * rn);
    let j = i * T::c(A_M * A_M) / r2;
    let z2 = r.z * r.z / r2;
    let k_xy = T::one() + j * (T::one() - T::c(5.0) * z2);
    let k_z = T::one() + j * (T::c(3.0) - T::c(5.0) * z2);
    Vector3::new(-gm_r3 * k_xy * r.x, -gm_r3 * k_xy * r.y, -gm_r3 * k_z * r.z)
}

/// Earth-centred Earth-fixed position [m] of geodetic latitude, longitude [rad] and height [m]
/// (Groves eq. 2.112).
pub fn geodetic_to_ecef(lat: f64, lon: f64, h: f64) -> Vector3<f64> {
    let (s, c) = (libm_sin(lat), libm_cos(lat));
    let r_e = A_M / libm::sqrt(1.0 - E2 * s * s);
    Vector3::new(
        (r_e + h) * c * libm_cos(lon),
        (r_e + h) * c * libm_sin(lon),
        ((1.0 - E2) * r_e + h) * s,
    )
}

/// WGS-84 second zonal harmonic `J2` [-] (NIMA TR8350.2).
pub const J2_WGS84: f64 = 1.082_626_683_553e-3;

/// Gravity (gravitation plus centrifugal) [m/s^2] in ECEF axes at ECEF position `r_e` [m], from
/// the oblate gravitation of [Berdinskikh et al., eq. 14] (Groves eq. 2.133 for the centrifugal
/// term).
pub fn gravity_ecef(r_e: &Vector3<f64>) -> Vector3<f64> {
    gravity_ecef_with(r_e, OBLATENESS_I)
}

fn gravity_ecef_with(r_e: &Vector3<f64>, i: f64) -> Vector3<f64> {
    let w2 = OMEGA_IE * OMEGA_IE;
    gravitation_with(r_e, i) + Vector3::new(w2 * r_e.x, w2 * r_e.y, 0.0)
}

fn libm_sin(x: f64) -> f64 {
    libm::sin(x)
}

fn libm_cos(x: f64) -> f64 {
    libm::cos(x)
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
    fn oblate_gravitation_agrees_with_normal_gravity_at_the_surface() {
        // With WGS-84's J2 (I = 3/2 J2) the J2 field plus the centrifugal term matches
        // Somigliana up to the omitted J4 term, |J4| = 1.62e-6: its gradient is below
        // 10 |J4| g = 1.6e-4 m/s^2 and tilts gravity by less than 10 |J4| = 1.6e-5 rad.
        // The I = 1.6375e-3 of [Berdinskikh et al., eq. 14] then differs by its own (I - 3/2 J2)
        // term on top.
        let i_wgs84 = 1.5 * J2_WGS84;
        let (j4_g, j4_rad) = (10.0 * 1.62e-6 * 9.83, 10.0 * 1.62e-6);
        for lat_deg in [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0_f64] {
            let lat = lat_deg.to_radians();
            let r = geodetic_to_ecef(lat, 0.4, 0.0);
            let gamma = normal_gravity(lat, 0.0);
            let g_wgs = gravity_ecef_with(&r, i_wgs84);
            assert!(
                (g_wgs.norm() - gamma).abs() < j4_g,
                "{lat_deg}: {} {gamma}",
                g_wgs.norm()
            );
            // Direction: along the ellipsoid normal (down) to within the same truncation.
            let down = -Vector3::new(
                lat.cos() * 0.4f64.cos(),
                lat.cos() * 0.4f64.sin(),
                lat.sin(),
            );
            assert!(g_wgs.normalize().cross(&down).norm() < j4_rad, "{lat_deg}");
            let g_seed = gravity_ecef(&r);
            let di_term =
                (gravitation_with(&r, OBLATENESS_I) - gravitation_with(&r, i_wgs84)).norm();
            assert!(
                (g_seed.norm() - gamma).abs() < di_term + j4_g,
                "{lat_deg}: {} {gamma} {di_term}",
                g_seed.norm()
            );
        }
        // The oblateness term is what makes them agree: without it the pole is off by ~0.03.
        let r = geodetic_to_ecef(core::f64::consts::FRAC_PI_2, 0.0, 0.0);
        let spherical = GM / r.norm_squared();
        assert!((spherical - normal_gravity(core::f64::consts::FRAC_PI_2, 0.0)).abs() > 0.01);
    }

    #[test]
    fn wander_transport_rate_matches_ned_rotated() {
        let (lat, h, alpha) = (0.7_f64, 500.0, 0.9_f64);
        let e = LocalEarth::new(lat, h);
        let v_ned = Vector3::new(120.0, -80.0, 3.0);
        let ned = e.omega_en_n(&v_ned);
        // NED -> wander: rotate by -alpha about down.
        let rot = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), -alpha);
        let v_w = rot * v_ned;
        let c_w = Vector3::new(
            lat.cos() * alpha.cos(),
            -lat.cos() * alpha.sin(),
            -lat.sin(),
        );
        let rho_w = e.transport_rate(&c_w, &v_w);
        let expect = rot * Vector3::new(ned.x, ned.y, 0.0);
        assert!((rho_w - expect).norm() < 1e-18, "{rho_w} {expect}");
        // At the pole the wander rate stays finite.
        let p = LocalEarth::new(core::f64::consts::FRAC_PI_2, 0.0);
        let rho = p.transport_rate(
            &Vector3::new(0.0, 0.0, -1.0),
            &Vector3::new(250.0, 0.0, 0.0),
        );
        assert!(rho.norm().is_finite() && (rho.y + 250.0 / p.r_meridian).abs() < 1e-15);
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
