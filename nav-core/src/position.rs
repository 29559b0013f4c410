//! Position in fixed point: the orientation of the local-level navigation frame relative to the
//! Earth (`q_n_e`) and the ellipsoidal height.
//!
//! **Why a quaternion.** Latitude/longitude are singular at the poles; the quaternion `q_n_e`
//! (navigation frame to Earth-fixed) describes latitude, longitude and the wander angle of the
//! frame everywhere, and its vertical row gives `sin(lat)` and `cos(lat)^2` without
//! trigonometry (Savage §4.1.2, Titterton & Weston §3.6). The update is
//! `C_n_e(k) = C_n_e(k-1) exp([xi x])`, `xi = omega_en_n dt` (Savage (5.3.1-6)).
//!
//! **Why fixed point.** At 400 Hz a vehicle at 1 m/s moves its frame by 4e-10 rad per step, below
//! the 6e-8 resolution of an `f32` quaternion component: a floating-point position would stop
//! moving. Each component is an `I2F62` (`i64`, range [-2, 2), resolution 2^-62 = 2.2e-19,
//! i.e. 2.8e-12 m on the ground: a component change `dq` is a rotation of `2 dq`). The
//! increment `q (q(xi) - 1)` is small and computed in the working scalar (its relative error,
//! ~1e-7 in `f32`, applies to the increment only: 4e-8 m per step at 250 m/s) and added
//! exactly. Height is an `I32F32` [m] (resolution 2.3e-10 m,
//! range +-2.1e9 m).

use crate::Scalar;
use crate::attitude::{about_y, about_z, rotation_vector_terms};
use fixed::types::{I2F62, I32F32};
use nalgebra::{Quaternion, Vector3};

/// Position of the body and orientation of the local-level navigation frame, fixed point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Position {
    /// `q_n_e` components `(w, x, y, z)` [-], norm 1.
    q_n_e: [I2F62; 4],
    /// Ellipsoidal height [m].
    h_m: I32F32,
}

impl Position {
    /// All zero: no place (its `q_n_e` is not a rotation), only the storage of a value started
    /// later in place (the fine filters' [`crate::alignment::fine::FineCore::BLANK`]).
    pub(crate) const BLANK: Self = Self {
        q_n_e: [I2F62::ZERO; 4],
        h_m: I32F32::ZERO,
    };

    /// Position at geodetic latitude `lat` [rad] (clamped to +-pi/2), longitude `lon` [rad] and
    /// height `h` [m] (saturated), with a north-pointing (NED) navigation frame.
    pub fn from_radians(lat: f64, lon: f64, h: f64) -> Self {
        Self::with_wander(lat, lon, 0.0, h)
    }

    /// Position from latitude and longitude [deg] and height [m] (NED frame).
    pub fn from_degrees(lat_deg: f64, lon_deg: f64, h_m: f64) -> Self {
        Self::from_radians(lat_deg.to_radians(), lon_deg.to_radians(), h_m)
    }

    /// Position with a wander-azimuth frame whose x axis points `wander` [rad] east of north:
    /// `C_n_e = Rz(lon) Ry(-(pi/2 + lat)) Rz(wander)` (Groves eq. 2.150 with the wander
    /// rotation).
    pub fn with_wander(lat: f64, lon: f64, wander: f64, h: f64) -> Self {
        let half_pi = core::f64::consts::FRAC_PI_2;
        let lat = if lat.is_finite() {
            lat.clamp(-half_pi, half_pi)
        } else {
            0.0
        };
        let lon = if lon.is_finite() { lon } else { 0.0 };
        let wander = if wander.is_finite() { wander } else { 0.0 };
        let q = about_z(lon) * about_y(-(half_pi + lat)) * about_z(wander);
        let c = q.into_inner().coords;
        Self {
            q_n_e: [c.w, c.x, c.y, c.z].map(f64::to_fixed_saturating),
            h_m: (if h.is_finite() { h } else { 0.0 }).to_fixed_saturating(),
        }
    }

    /// The place `d_ned` [m] (north, east, down) away, on the local radii of curvature (NED
    /// frame; for offsets of metres to kilometres: the error is `|d|^2 / R`).
    pub fn offset_ned(&self, d_ned: [f64; 3]) -> Self {
        let (lat, lon, h) = (self.lat_f64(), self.lon_f64(), self.h_f64());
        let (r_n, r_e) = crate::earth::radii(lat);
        let cos_lat = libm::cos(lat).max(1e-9);
        Self::from_radians(
            lat + d_ned[0] / (r_n + h),
            lon + d_ned[1] / ((r_e + h) * cos_lat),
            h - d_ned[2],
        )
    }

    /// The north, east, down offset [m] of `other` from `self` (the inverse of
    /// [`Self::offset_ned`] for nearby places).
    pub fn ned_to(&self, other: &Self) -> [f64; 3] {
        let (lat, h) = (self.lat_f64(), self.h_f64());
        let (r_n, r_e) = crate::earth::radii(lat);
        let mut d_lon = other.lon_f64() - self.lon_f64();
        let pi = core::f64::consts::PI;
        if d_lon > pi {
            d_lon -= 2.0 * pi;
        } else if d_lon < -pi {
            d_lon += 2.0 * pi;
        }
        [
            (other.lat_f64() - lat) * (r_n + h),
            d_lon * (r_e + h) * libm::cos(lat),
            -(other.h_f64() - h),
        ]
    }

    /// The same place with the frame turned to north (wander angle 0).
    pub fn to_ned_frame(&self) -> Self {
        Self::from_radians(self.lat_f64(), self.lon_f64(), self.h_f64())
    }

    /// `q_n_e` in the working scalar (not renormalised).
    #[inline]
    pub fn q_n_e<T: Scalar>(&self) -> Quaternion<T> {
        let [w, x, y, z] = self.q_n_e.map(T::of_fixed);
        Quaternion::new(w, x, y, z)
    }

    /// The vertical (third) row of `C_n_e`, `c_n = C_e_n (0, 0, 1)`:
    /// `(cos(lat) cos(alpha), -cos(lat) sin(alpha), -sin(lat))` [-]. It gives
    /// `omega_ie_n = Omega c_n`, `sin(lat) = -c_z` and `cos(lat)^2 = c_x^2 + c_y^2`.
    #[inline]
    pub fn vertical_row<T: Scalar>(&self) -> Vector3<T> {
        vertical_row(&self.q_n_e::<T>())
    }

    /// Height [m] in the working scalar.
    #[inline]
    pub fn h<T: Scalar>(&self) -> T {
        T::of_fixed(self.h_m)
    }

    /// Height [m] as `f64` (exact conversion of the fixed-point value).
    pub fn h_f64(&self) -> f64 {
        f64::of_fixed(self.h_m)
    }

    /// Geodetic latitude [rad] in the working scalar (an `atan2`: for alignment and output, not
    /// per step).
    pub fn lat<T: Scalar>(&self) -> T {
        T::c(self.lat_f64())
    }

    /// Longitude [rad] in the working scalar, in (-pi, pi]; 0 at a pole.
    pub fn lon<T: Scalar>(&self) -> T {
        T::c(self.lon_f64())
    }

    /// Geodetic latitude [rad], computed in `f64`.
    pub fn lat_f64(&self) -> f64 {
        let c = self.vertical_row::<f64>();
        libm_atan2(-c.z, libm_hypot(c.x, c.y))
    }

    /// Longitude [rad] in (-pi, pi], computed in `f64`; 0 at a pole.
    pub fn lon_f64(&self) -> f64 {
        // Down axis in ECEF, the third column of C_n_e: -(cos lat cos lon, cos lat sin lon, sin lat).
        let [w, x, y, z] = self.q_n_e.map(f64::of_fixed);
        let d_x = 2.0 * (x * z + w * y);
        let d_y = 2.0 * (y * z - w * x);
        libm_atan2(-d_y, -d_x)
    }

    /// Wander angle [rad]: azimuth of the frame's x axis east of north, in (-pi, pi]; 0 at a pole
    /// (undefined there).
    pub fn wander_f64(&self) -> f64 {
        let c = self.vertical_row::<f64>();
        libm_atan2(-c.y, c.x)
    }

    /// Latitude [nanodegrees], rounded to nearest: exact integer output for logs.
    pub fn lat_ndeg(&self) -> i64 {
        rad_to_ndeg(self.lat_f64())
    }

    /// Longitude [nanodegrees], rounded to nearest.
    pub fn lon_ndeg(&self) -> i64 {
        rad_to_ndeg(self.lon_f64())
    }

    /// Turns the navigation frame by the rotation `xi` [rad] (navigation axes) relative to the
    /// Earth: `q_n_e <- q_n_e q(xi)`, adding the small `q_n_e (q(xi) - 1)` exactly; saturates
    /// instead of overflowing.
    /// A non-finite increment is refused (returns `false`, position unchanged).
    #[inline]
    pub fn rotate<T: Scalar>(&mut self, xi: &Vector3<T>) -> bool {
        let (w, s) = rotation_vector_terms(xi.norm_squared());
        let p = Quaternion::from_parts(w, xi * s);
        let d = self.q_n_e::<T>() * p;
        let d = [d.w, d.i, d.j, d.k];
        if !d.iter().all(|x| x.finite()) {
            return false;
        }
        for (c, dc) in self.q_n_e.iter_mut().zip(d) {
            *c = c.saturating_add(dc.to_fixed_saturating());
        }
        true
    }

    /// Adds a height increment `d_h` [m] computed in the working scalar (saturating). A
    /// non-finite increment is refused (returns `false`).
    #[inline]
    pub fn add_height<T: Scalar>(&mut self, d_h: T) -> bool {
        if !d_h.finite() {
            return false;
        }
        self.h_m = self.h_m.saturating_add(d_h.to_fixed_saturating());
        true
    }
}

/// Third row of the rotation matrix of `q` = `(w, x, y, z)`, assuming a unit quaternion.
#[inline]
fn vertical_row<T: Scalar>(q: &Quaternion<T>) -> Vector3<T> {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    let two = T::c(2.0);
    Vector3::new(
        two * (x * z - w * y),
        two * (y * z + w * x),
        w * w - x * x - y * y + z * z,
    )
}

fn libm_atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

fn libm_hypot(x: f64, y: f64) -> f64 {
    libm::hypot(x, y)
}

/// Radians to nanodegrees, rounded to nearest.
fn rad_to_ndeg(a: f64) -> i64 {
    let ndeg = a.to_degrees() * 1e9;
    libm::round(ndeg) as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_output() {
        let p = Position::from_degrees(45.0, -120.5, 123.25);
        assert_eq!(p.lat_ndeg(), 45_000_000_000);
        assert_eq!(p.lon_ndeg(), -120_500_000_000);
        assert_eq!(p.h_f64(), 123.25);
        assert!((p.lat::<f64>() - 45f64.to_radians()).abs() < 1e-15);
        assert!(p.wander_f64().abs() < 1e-15);
        let w = Position::with_wander(-0.3, 2.0, 1.2, 0.0);
        assert!((w.lat_f64() + 0.3).abs() < 1e-15 && (w.lon_f64() - 2.0).abs() < 1e-15);
        assert!((w.wander_f64() - 1.2).abs() < 1e-15);
        let n = w.to_ned_frame();
        assert!(n.wander_f64().abs() < 1e-15 && (n.lat_f64() + 0.3).abs() < 1e-15);
    }

    #[test]
    fn vertical_row_is_sin_and_cos_of_latitude() {
        let p = Position::with_wander(0.6, 1.0, 0.25, 0.0);
        let c = p.vertical_row::<f64>();
        let expect = Vector3::new(
            0.6f64.cos() * 0.25f64.cos(),
            -0.6f64.cos() * 0.25f64.sin(),
            -0.6f64.sin(),
        );
        assert!((c - expect).norm() < 1e-15, "{c} {expect}");
    }

    #[test]
    fn bad_inputs_give_a_valid_position() {
        let p = Position::from_radians(f64::NAN, f64::INFINITY, f64::NAN);
        assert_eq!((p.lat_ndeg(), p.lon_ndeg(), p.h_f64()), (0, 0, 0.0));
        assert_eq!(
            Position::from_degrees(95.0, 0.0, 0.0).lat_ndeg(),
            90_000_000_000
        );
    }

    #[test]
    fn longitude_wraps() {
        assert_eq!(
            Position::from_degrees(0.0, 540.0, 0.0).lon_ndeg(),
            180_000_000_000
        );
    }

    #[test]
    fn tiny_f32_increments_accumulate() {
        // 400 Hz for 1 h at 1 mm/s north: 3.6 m = 5.65e-7 rad; an f32 latitude would not move.
        let mut p = Position::from_degrees(45.0, 0.0, 0.0);
        // NED: moving north turns the frame about -east.
        let xi = Vector3::new(0.0, -0.001_f32 * 0.0025 / 6_367_000.0, 0.0);
        for _ in 0..1_440_000 {
            p.rotate(&xi);
        }
        let moved = (p.lat::<f64>() - 45f64.to_radians()) * 6_367_000.0;
        assert!((moved - 3.6).abs() < 1e-4, "{moved}");
    }
}
