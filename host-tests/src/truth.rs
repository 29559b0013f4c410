//! Exactly known trajectories and their exact IMU increments, for the mechanization's physics
//! tests (f64).
//!
//! - [`Stationary`]: a body at rest on the WGS-84 ellipsoid with any attitude.
//! - [`MeridianFlight`]: constant ground speed and height along a meridian, level and heading
//!   along it, over a pole if it gets there.
//!
//! Increments are the integrals of `omega_ib_b` and `f_ib_b` over each interval (what an ideal
//! integrating IMU outputs), computed by RK4 on the smooth kinematics; the kinematics use the
//! same WGS-84 radii and normal gravity as nav-core, so with exact inputs the mechanization's
//! error is its own.

use nav_core::earth::{self, LocalEarth, OMEGA_IE};
use nav_core::{ImuIncrement, UnitQuaternion, Vector3};

/// Truth at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth {
    /// Time [s].
    pub t_s: f64,
    /// Geodetic latitude [rad].
    pub lat: f64,
    /// Longitude [rad].
    pub lon: f64,
    /// Ellipsoidal height [m].
    pub h: f64,
    /// Velocity north, east, down [m/s].
    pub v_eb_ned: Vector3<f64>,
    /// Body-to-NED attitude.
    pub q_b_ned: UnitQuaternion<f64>,
}

/// A gap in a truth trajectory: an interval between its rows longer than this many times their
/// median interval. Across one a straight line (the comparison's interpolation, the
/// emulator's motion recovered per interval) is not the trajectory: a truth hole of 200 s of a
/// turning car was reported as a 1 km error of the solution.
pub const TRUTH_GAP_FACTOR: f64 = 5.0;

/// The median interval between consecutive rows of `truth` [s] (infinite for one row: no
/// gap can be told).
pub fn median_interval_s(truth: &[Truth]) -> f64 {
    let mut d: Vec<f64> = truth.windows(2).map(|w| w[1].t_s - w[0].t_s).collect();
    if d.is_empty() {
        return f64::INFINITY;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// The first gap of `truth` ([`TRUTH_GAP_FACTOR`]): the index of the row before it.
pub fn first_gap(truth: &[Truth]) -> Option<usize> {
    let max_interval_s = TRUTH_GAP_FACTOR * median_interval_s(truth);
    truth
        .windows(2)
        .position(|w| w[1].t_s - w[0].t_s > max_interval_s)
}

/// Distance [m] between two geodetic positions (through ECEF).
pub fn distance_m(lat1: f64, lon1: f64, h1: f64, lat2: f64, lon2: f64, h2: f64) -> f64 {
    (earth::geodetic_to_ecef(lat1, lon1, h1) - earth::geodetic_to_ecef(lat2, lon2, h2)).norm()
}

/// Horizontal distance [m]: the same with both heights set to `h1`.
pub fn horizontal_distance_m(lat1: f64, lon1: f64, h1: f64, lat2: f64, lon2: f64) -> f64 {
    distance_m(lat1, lon1, h1, lat2, lon2, h1)
}

/// A body at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stationary {
    /// Latitude [rad].
    pub lat: f64,
    /// Longitude [rad].
    pub lon: f64,
    /// Height [m].
    pub h: f64,
    /// Attitude `q_b_ned`.
    pub q_b_ned: UnitQuaternion<f64>,
}

impl Stationary {
    /// The constant increment over `dt` [s]: `omega_ib_b = C_n_b omega_ie_n`,
    /// `f_ib_b = C_n_b (0, 0, -g)`.
    pub fn increment(&self, dt: f64) -> ImuIncrement<f64> {
        let e = LocalEarth::new(self.lat, self.h);
        let q_n_b = self.q_b_ned.inverse();
        ImuIncrement {
            delta_theta_ib_b: q_n_b * e.omega_ie_n() * dt,
            delta_v_ib_b: q_n_b * Vector3::new(0.0, 0.0, -e.g) * dt,
            dt,
        }
    }

    /// The truth (constant).
    pub fn truth(&self, t_s: f64) -> Truth {
        Truth {
            t_s,
            lat: self.lat,
            lon: self.lon,
            h: self.h,
            v_eb_ned: Vector3::zeros(),
            q_b_ned: self.q_b_ned,
        }
    }
}

/// Level flight along a meridian at constant ground speed and height, heading along the
/// meridian (north when `speed > 0` starts it northward).
///
/// The kinematics are written in the body frame with the "unwrapped latitude" `psi`, the angle
/// of the ellipsoid normal to the equator measured along the direction of travel: past a pole
/// `psi > pi/2`, the true latitude is `pi - psi` and the longitude is `lon0 + pi`, but the body
/// rates keep their NED form with `lat -> psi` (the frame is the travel-north-down frame):
/// `omega_ib_b = (Omega cos psi, -v / (R_N + h), -Omega sin psi)`,
/// `f_ib_b = (0, -2 Omega v sin psi, v^2 / (R_N + h) - g)`, `dpsi/dt = v / (R_N + h)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeridianFlight {
    /// Start latitude [rad].
    pub lat0: f64,
    /// Longitude [rad].
    pub lon0: f64,
    /// Height [m].
    pub h: f64,
    /// Ground speed [m/s], northward at the start.
    pub speed: f64,
}

/// `(dpsi/dt, omega_ib_b, f_ib_b)` at unwrapped latitude `psi`.
fn meridian_rates(psi: f64, h: f64, v: f64) -> (f64, Vector3<f64>, Vector3<f64>) {
    let e = LocalEarth::new(psi, h);
    let (s, c) = (psi.sin(), psi.cos());
    let rn_h = e.r_meridian + h;
    (
        v / rn_h,
        Vector3::new(OMEGA_IE * c, -v / rn_h, -OMEGA_IE * s),
        Vector3::new(0.0, -2.0 * OMEGA_IE * v * s, v * v / rn_h - e.g),
    )
}

impl MeridianFlight {
    /// Runs the flight for `n` intervals of `dt` [s], calling `visit(increment, truth at the end
    /// of the interval)`.
    pub fn run(&self, dt: f64, n: usize, mut visit: impl FnMut(&ImuIncrement<f64>, &Truth)) {
        let mut psi = self.lat0;
        let sub = 4;
        let h_sub = dt / sub as f64;
        for k in 0..n {
            let mut d_theta = Vector3::zeros();
            let mut d_v = Vector3::zeros();
            for _ in 0..sub {
                // RK4 on (psi, theta, v): the rates depend on psi only.
                let r = |p: f64| meridian_rates(p, self.h, self.speed);
                let (k1, w1, f1) = r(psi);
                let (k2, w2, f2) = r(psi + 0.5 * h_sub * k1);
                let (k3, w3, f3) = r(psi + 0.5 * h_sub * k2);
                let (k4, w4, f4) = r(psi + h_sub * k3);
                psi += h_sub / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
                d_theta += (w1 + 2.0 * w2 + 2.0 * w3 + w4) * (h_sub / 6.0);
                d_v += (f1 + 2.0 * f2 + 2.0 * f3 + f4) * (h_sub / 6.0);
            }
            let inc = ImuIncrement {
                delta_theta_ib_b: d_theta,
                delta_v_ib_b: d_v,
                dt,
            };
            visit(&inc, &self.truth_at(psi, (k + 1) as f64 * dt));
        }
    }

    fn truth_at(&self, psi: f64, t_s: f64) -> Truth {
        let half_pi = core::f64::consts::FRAC_PI_2;
        let pi = core::f64::consts::PI;
        let over = psi > half_pi;
        let (lat, lon, yaw, v) = if over {
            (pi - psi, wrap(self.lon0 + pi), pi, -self.speed)
        } else {
            (psi, self.lon0, 0.0, self.speed)
        };
        Truth {
            t_s,
            lat,
            lon,
            h: self.h,
            v_eb_ned: Vector3::new(v, 0.0, 0.0),
            q_b_ned: UnitQuaternion::from_euler_angles(0.0, 0.0, yaw),
        }
    }
}

fn wrap(a: f64) -> f64 {
    let pi = core::f64::consts::PI;
    (a + pi).rem_euclid(2.0 * pi) - pi
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meridian_increments_are_consistent() {
        // 1 s at 900 km/h from 45 deg: the latitude change is v t / (R_N + h).
        let f = MeridianFlight {
            lat0: 45f64.to_radians(),
            lon0: 0.5,
            h: 10_000.0,
            speed: 250.0,
        };
        let mut last = None;
        let mut sum_w = Vector3::zeros();
        f.run(0.0025, 400, |inc, t| {
            sum_w += inc.delta_theta_ib_b;
            last = Some(*t);
        });
        let t = last.unwrap();
        // R_N at mid-path (it changes by 2.5 m over the 9.8 km).
        let mid = 45f64.to_radians() + 125.0 / 6.4e6;
        let rn = LocalEarth::new(mid, 0.0).r_meridian;
        let expect = 250.0 / (rn + 10_000.0);
        assert!(((t.lat - 45f64.to_radians()) - expect).abs() < 1e-12);
        // Pitching down about -y at v / (R_N + h).
        assert!((sum_w.y + expect).abs() < 1e-12);
    }
}
