//! The mean horizontal acceleration of a span of GNSS positions, by least squares.
//!
//! The positions, in the tangent plane of the span's first fix (Earth-fixed: its north and east
//! axes there, `C_e_n` of [Groves, eq. 2.150]), are fitted with `p(t) = p0 + v0 t + a t^2 / 2`
//! per horizontal axis by ordinary least squares (the normal equations). Their running sums
//! are all that is kept, so a span of any length costs the same memory. The acceleration's
//! 1-sigma is the fit's, `2 sigma sqrt(((X^T X)^-1)_22)`, with `sigma^2` the larger of the
//! fixes' declared variance and the residuals' (`RSS / (n - 3)`): a span whose acceleration
//! was not constant leaves residuals that widen it, and so does a receiver noisier than it
//! says.
//!
//! Only the horizontal axes are fitted: a vertical acceleration changes the size of the
//! specific force, not its direction (the level), to first order; and a receiver's height is
//! its noisiest axis.

use crate::Scalar;
use crate::earth::geodetic_to_ecef;
use nalgebra::{Matrix3, Vector3};

use super::aiding::GnssPosition;

/// Fewest fixes the acceleration is estimated from (three residual degrees of freedom).
pub const MIN_FIXES: u32 = 6;

/// The span's running sums (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpanFit {
    /// Time of the first fix [s].
    t0_s: f64,
    /// ECEF position of the first fix [m] and the north and east axes there (rows of
    /// `C_e_n`).
    origin_e_m: Vector3<f64>,
    north_e: Vector3<f64>,
    east_e: Vector3<f64>,
    /// Latitude of the first fix [rad] (the Earth rate's axes).
    lat0_rad: f64,
    /// Number of fixes.
    n: u32,
    /// Sums of `t^k`, k = 0..4 [s^k].
    t_pow: [f64; 5],
    /// Sums of `t^k x`, k = 0..2, north and east [m s^k].
    tx: [[f64; 3]; 2],
    /// Sums of `x^2`, north and east [m^2].
    xx: [f64; 2],
    /// Sum of the declared variances, north and east [m^2].
    var: [f64; 2],
}

/// The fit's estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpanAcceleration {
    /// Mean horizontal acceleration, north and east [m/s^2], relative to the Earth.
    pub accel_m_s2: [f64; 2],
    /// Its 1-sigma per axis [m/s^2].
    pub sigma_m_s2: [f64; 2],
    /// Horizontal velocity at the span's middle, north and east [m/s].
    pub v_mid_m_s: [f64; 2],
    /// The horizontal Coriolis acceleration `2 omega_ie x v` at the span's middle, north and
    /// east [m/s^2]: what the accelerometers feel beside the acceleration ([Groves, eq. 5.54]
    /// in an Earth-fixed frame).
    pub coriolis_m_s2: [f64; 2],
}

impl SpanFit {
    /// A span from the fix `p0` at `t0_s` [s].
    pub fn new<T: Scalar>(t0_s: f64, p0: &GnssPosition<T>) -> Self {
        let (lat, lon) = (p0.lat_rad, p0.lon_rad);
        let (sl, cl) = (libm::sin(lat), libm::cos(lat));
        let (so, co) = (libm::sin(lon), libm::cos(lon));
        let mut fit = Self {
            t0_s,
            origin_e_m: geodetic_to_ecef(lat, lon, p0.h_m),
            north_e: Vector3::new(-sl * co, -sl * so, cl),
            east_e: Vector3::new(-so, co, 0.0),
            lat0_rad: lat,
            n: 0,
            t_pow: [0.0; 5],
            tx: [[0.0; 3]; 2],
            xx: [0.0; 2],
            var: [0.0; 2],
        };
        fit.add(t0_s, p0);
        fit
    }

    /// Adds the fix `p` at `t_s` [s].
    pub fn add<T: Scalar>(&mut self, t_s: f64, p: &GnssPosition<T>) {
        let d = geodetic_to_ecef(p.lat_rad, p.lon_rad, p.h_m) - self.origin_e_m;
        let x = [self.north_e.dot(&d), self.east_e.dot(&d)];
        let t = t_s - self.t0_s;
        let mut tk = 1.0;
        for s in &mut self.t_pow {
            *s += tk;
            tk *= t;
        }
        for (axis, x) in x.into_iter().enumerate() {
            let mut tk = 1.0;
            for s in &mut self.tx[axis] {
                *s += tk * x;
                tk *= t;
            }
            self.xx[axis] += x * x;
            let sigma = p.sigma_ned_m[axis].to_f64();
            self.var[axis] += sigma * sigma;
        }
        self.n += 1;
    }

    /// Number of fixes.
    pub fn fixes(&self) -> u32 {
        self.n
    }

    /// The estimate, over the fixes up to `t_s` [s] (the last one's time); `None` below
    /// [`MIN_FIXES`] or when the times do not determine a quadratic.
    pub fn acceleration(&self, t_s: f64) -> Option<SpanAcceleration> {
        if self.n < MIN_FIXES {
            return None;
        }
        let s = &self.t_pow;
        let gram = Matrix3::new(s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4]);
        let inv = gram.try_inverse()?;
        let dof = f64::from(self.n - 3);
        let t_mid = 0.5 * (t_s - self.t0_s);
        let mut accel = [0.0; 2];
        let mut sigma = [0.0; 2];
        let mut v_mid = [0.0; 2];
        for axis in 0..2 {
            let rhs = Vector3::from(self.tx[axis]);
            let beta = inv * rhs;
            // RSS = x^T x - beta^T X^T x (the normal equations' residual).
            let rss = (self.xx[axis] - beta.dot(&rhs)).max(0.0);
            let var = (self.var[axis] / f64::from(self.n)).max(rss / dof);
            accel[axis] = 2.0 * beta.z;
            sigma[axis] = 2.0 * libm::sqrt(var * inv[(2, 2)].max(0.0));
            v_mid[axis] = beta.y + 2.0 * beta.z * t_mid;
        }
        let v = Vector3::new(v_mid[0], v_mid[1], 0.0);
        let c = (crate::earth::omega_ie_n(self.lat0_rad) * 2.0).cross(&v);
        let coriolis = [c.x, c.y];
        let ok = accel
            .iter()
            .chain(sigma.iter())
            .chain(v_mid.iter())
            .all(|x| x.is_finite());
        ok.then_some(SpanAcceleration {
            accel_m_s2: accel,
            sigma_m_s2: sigma,
            v_mid_m_s: v_mid,
            coriolis_m_s2: coriolis,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Position;

    /// A fix `north`, `east` [m] from a place at latitude `lat` [rad], 1-sigma `sigma` [m].
    fn fix(lat: f64, north: f64, east: f64, sigma: f64) -> GnssPosition<f64> {
        let p = Position::from_radians(lat, 0.2, 100.0).offset_ned([north, east, 0.0]);
        GnssPosition {
            lat_rad: p.lat_f64(),
            lon_rad: p.lon_f64(),
            h_m: p.h_f64(),
            sigma_ned_m: Vector3::new(sigma, sigma, 2.0 * sigma),
        }
    }

    /// Exact positions of a constant acceleration give it back, with the velocity at the
    /// span's middle, the Coriolis term of that velocity, and a 1-sigma that falls as the
    /// span grows.
    #[test]
    fn a_constant_acceleration_is_found() {
        let lat = 1.0;
        let at = |t: f64| fix(lat, 1.0 + 2.0 * t + 0.15 * t * t, 5.0 * t, 0.5);
        let mut fit = SpanFit::new(10.0, &at(0.0));
        let mut sigmas = [0.0; 2];
        for k in 1..=20 {
            let t = f64::from(k) * 0.5;
            fit.add(10.0 + t, &at(t));
            if k == 10 {
                sigmas[0] = fit.acceleration(10.0 + t).unwrap().sigma_m_s2[0];
            }
        }
        let a = fit.acceleration(20.0).expect("21 fixes");
        // The offsets are on the ellipsoid, the fit in the tangent plane: millimetres apart.
        assert!((a.accel_m_s2[0] - 0.3).abs() < 1e-3, "{a:?}");
        assert!(a.accel_m_s2[1].abs() < 1e-3, "{a:?}");
        assert!((a.v_mid_m_s[0] - 3.5).abs() < 1e-3 && (a.v_mid_m_s[1] - 5.0).abs() < 1e-3);
        let w = 2.0 * crate::earth::OMEGA_IE * libm::sin(lat);
        assert!((a.coriolis_m_s2[0] - w * 5.0).abs() < 1e-6);
        assert!((a.coriolis_m_s2[1] + w * 3.5).abs() < 1e-6);
        sigmas[1] = a.sigma_m_s2[0];
        assert!(sigmas[1] > 0.0 && sigmas[1] < sigmas[0] / 4.0, "{sigmas:?}");
        // Five fixes do not make an estimate.
        let mut short = SpanFit::new(0.0, &at(0.0));
        for k in 1..5 {
            short.add(f64::from(k), &at(f64::from(k)));
        }
        assert_eq!(short.fixes(), 5);
        assert!(short.acceleration(4.0).is_none());
    }

    /// Positions that do not follow a parabola (a stop, then a start) leave residuals that
    /// widen the acceleration's 1-sigma beyond what the declared noise gives.
    #[test]
    fn residuals_widen_the_sigma() {
        let sigma_of = |moving: bool| {
            let at = |t: f64| {
                let east = if moving && t > 6.0 {
                    4.0 * (t - 6.0)
                } else {
                    0.0
                };
                fix(0.5, 0.0, east, 0.1)
            };
            let mut fit = SpanFit::new(0.0, &at(0.0));
            for k in 1..=10 {
                fit.add(f64::from(k), &at(f64::from(k)));
            }
            fit.acceleration(10.0).unwrap().sigma_m_s2[1]
        };
        assert!(sigma_of(true) > 10.0 * sigma_of(false));
    }
}
