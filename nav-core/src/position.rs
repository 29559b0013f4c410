//! Geodetic position in fixed point.
//!
//! At 400 Hz a stationary or slow vehicle moves its latitude by ~1e-13 rad per step, far below the
//! ~6e-8 rad spacing of `f32` near 45 deg: a floating-point latitude would simply stop moving.
//! Latitude and longitude are therefore kept as signed 64-bit binary angles in half-turns
//! (`I1F63`: the full `i64` range spans [-pi, pi) rad, resolution pi/2^63 = 3.4e-19 rad, 2e-12 m on
//! the ground; longitude wraps for free), and height as `I32F32` metres (resolution 2.3e-10 m,
//! range +-2.1e9 m). Increments are computed in the working scalar and added exactly.

use crate::Scalar;
use fixed::types::{I1F63, I32F32};

/// Geodetic latitude, longitude and ellipsoidal height (WGS-84), fixed point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Position {
    /// Latitude [half-turns = pi rad].
    lat_ht: I1F63,
    /// Longitude [half-turns = pi rad], wrapping at +-180 deg.
    lon_ht: I1F63,
    /// Ellipsoidal height [m].
    h_m: I32F32,
}

const PI: f64 = core::f64::consts::PI;

impl Position {
    /// Builds a position from latitude [rad], longitude [rad] and height [m]. Latitude is clamped
    /// to [-pi/2, pi/2]; longitude is wrapped into [-pi, pi); height is saturated.
    pub fn from_radians(lat_rad: f64, lon_rad: f64, h_m: f64) -> Self {
        let lat = (lat_rad / PI).clamp(-0.5, 0.5);
        Self {
            lat_ht: I1F63::saturating_from_num(lat),
            lon_ht: wrap_half_turns(lon_rad / PI),
            h_m: I32F32::saturating_from_num(h_m),
        }
    }

    /// Builds a position from latitude and longitude in degrees and height [m].
    pub fn from_degrees(lat_deg: f64, lon_deg: f64, h_m: f64) -> Self {
        Self::from_radians(lat_deg.to_radians(), lon_deg.to_radians(), h_m)
    }

    /// Latitude [rad] in the working scalar.
    #[inline]
    pub fn lat<T: Scalar>(&self) -> T {
        self.lat_ht.to_num::<T>() * T::pi()
    }

    /// Longitude [rad] in the working scalar, in [-pi, pi).
    #[inline]
    pub fn lon<T: Scalar>(&self) -> T {
        self.lon_ht.to_num::<T>() * T::pi()
    }

    /// Height [m] in the working scalar.
    #[inline]
    pub fn h<T: Scalar>(&self) -> T {
        self.h_m.to_num::<T>()
    }

    /// Latitude [nanodegrees], rounded to nearest: exact integer output for logs.
    pub fn lat_ndeg(&self) -> i64 {
        half_turns_to_ndeg(self.lat_ht)
    }

    /// Longitude [nanodegrees], rounded to nearest.
    pub fn lon_ndeg(&self) -> i64 {
        half_turns_to_ndeg(self.lon_ht)
    }

    /// Height [m] as `f64` (exact conversion of the fixed-point value).
    pub fn h_f64(&self) -> f64 {
        self.h_m.to_num::<f64>()
    }

    /// Adds increments of latitude [rad], longitude [rad] and height [m] computed in the working
    /// scalar. Latitude saturates at the poles (the NED frame is singular there; the
    /// wander-azimuth frame of the mechanization issue removes that limit).
    #[inline]
    pub fn add<T: Scalar>(&mut self, d_lat: T, d_lon: T, d_h: T) {
        let pi = T::pi();
        let half = I1F63::from_bits(i64::MAX / 2 + 1);
        self.lat_ht = self
            .lat_ht
            .saturating_add(I1F63::saturating_from_num(d_lat / pi))
            .clamp(-half, half);
        self.lon_ht = self
            .lon_ht
            .wrapping_add(I1F63::wrapping_from_num(d_lon / pi));
        self.h_m = self.h_m.saturating_add(I32F32::saturating_from_num(d_h));
    }
}

/// Wraps a value in half-turns into [-1, 1) and converts it (exact for |x| < 2^11).
fn wrap_half_turns(x: f64) -> I1F63 {
    let wrapped = x - 2.0 * libm_floor((x + 1.0) / 2.0);
    I1F63::saturating_from_num(wrapped)
}

fn libm_floor(x: f64) -> f64 {
    nalgebra::ComplexField::floor(x)
}

/// 180e9 nanodegrees per half-turn: `round(bits * 180e9 / 2^63)`.
fn half_turns_to_ndeg(a: I1F63) -> i64 {
    let num = i128::from(a.to_bits()) * 180_000_000_000_i128;
    ((num + (1_i128 << 62)) >> 63) as i64
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
    }

    #[test]
    fn longitude_wraps_and_latitude_saturates() {
        let mut p = Position::from_degrees(89.999, 179.999, 0.0);
        p.add(0.01_f64, 0.002_f64.to_radians(), 0.0);
        assert_eq!(p.lat_ndeg(), 90_000_000_000);
        assert_eq!(p.lon_ndeg(), -179_999_000_000);
        assert_eq!(
            Position::from_degrees(0.0, 540.0, 0.0).lon_ndeg(),
            -180_000_000_000
        );
    }

    #[test]
    fn tiny_f32_increments_accumulate() {
        // 400 Hz for 1 h at 1 mm/s north: 3.6 m = 5.65e-7 rad; f32 latitude would not move.
        let mut p = Position::from_degrees(45.0, 0.0, 0.0);
        let d_lat = 0.001_f32 * 0.0025 / 6_367_000.0;
        for _ in 0..1_440_000 {
            p.add(d_lat, 0.0, 0.0);
        }
        let moved = (p.lat::<f64>() - 45f64.to_radians()) * 6_367_000.0;
        assert!((moved - 3.6).abs() < 1e-4, "{moved}");
    }
}
