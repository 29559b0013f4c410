//! The exact IMU generator: trajectory -> ideal increments and truth (the inverse of
//! navigation, [Stand model]).
//!
//! A [`Trajectory`] gives, at any time and position, the body's NED velocity and its derivative,
//! and its roll, pitch and yaw with their rates. The generator integrates the position and, over
//! each sample interval, the integrals of what ideal sensors sense (Groves §5.4.1, eq. 5.53–5.54,
//! rearranged; [Stand model] writes the same in its level frame):
//!
//! - `omega_ib_b = omega_nb_b + C_n_b (omega_ie_n + omega_en_n)`, with `omega_nb_b` from the
//!   Euler-angle rates (Titterton & Weston eq. 3.52);
//! - `f_ib_b = C_n_b (dv_eb_n/dt + (2 omega_ie_n + omega_en_n) x v_eb_n - g_n)`,
//!   `g_n = (0, 0, g)` from the same WGS-84 normal gravity as nav-core's mechanization.
//!
//! The position `(lat, lon, h)`, an auxiliary state (a heading that a trajectory integrates,
//! e.g. along a geodesic) and the two integrals are one ODE, integrated by RK4 with
//! [`SUBSTEPS`] steps per sample. The increments are the integrals themselves — what an
//! integrating IMU outputs — so the sampling adds no coning or sculling error of its own; their
//! error is RK4's (`O(h^5)` per step), below 1e-12 rad and 1e-10 m/s per increment for the
//! scenarios here (the convergence test checks it against 4x finer steps).
//!
//! A [`Rider`] is an extra ODE driven by the body's motion (e.g. the isotropic oscillator of
//! [`crate::oscillator`]): [`Generator::advance_with`] integrates it with the same RK4 stages,
//! seeing at each stage the same `omega_ib_b` and `f_ib_b` as the increments.

pub mod family;
pub mod jet;
pub mod scenarios;

use crate::truth::Truth;
use nav_core::earth::{LocalEarth, OMEGA_IE};
use nav_core::nalgebra::Matrix3;
use nav_core::{ImuIncrement, UnitQuaternion, Vector3, attitude};

/// RK4 steps per sample interval.
pub const SUBSTEPS: usize = 4;

/// Where the body is: the integrated state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Point {
    /// Geodetic latitude [rad].
    pub lat: f64,
    /// Longitude [rad].
    pub lon: f64,
    /// Ellipsoidal height [m].
    pub h: f64,
    /// A trajectory's own integrated quantity (e.g. a geodesic's heading [rad]); 0 if unused.
    pub aux: f64,
}

/// How the body moves at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    /// Velocity relative to the Earth, north, east, down [m/s].
    pub v_eb_n: Vector3<f64>,
    /// Time derivative of the NED components of `v_eb_n` [m/s^2].
    pub a_eb_n: Vector3<f64>,
    /// Roll, pitch, yaw of the body (FRD) relative to NED [rad].
    pub euler: Vector3<f64>,
    /// Their time derivatives [rad/s].
    pub euler_rate: Vector3<f64>,
    /// Time derivative of [`Point::aux`].
    pub aux_rate: f64,
}

/// A trajectory: a start and the motion as a function of time and position.
pub trait Trajectory {
    /// Where it starts (at `t = 0`).
    fn start(&self) -> Point;
    /// Its natural length [s] (a generator may stop earlier).
    fn duration_s(&self) -> f64;
    /// The motion at time `t` [s] at point `p`.
    fn motion(&self, t: f64, p: &Point) -> Motion;
}

/// `omega_nb_b` [rad/s] from roll, pitch, yaw and their rates, for `C_b_n = R_z(yaw) R_y(pitch)
/// R_x(roll)` (Titterton & Weston eq. 3.52).
pub fn body_rate_from_euler(euler: &Vector3<f64>, rate: &Vector3<f64>) -> Vector3<f64> {
    let (sr, cr) = euler.x.sin_cos();
    let (sp, cp) = euler.y.sin_cos();
    Vector3::new(
        rate.x - rate.z * sp,
        rate.y * cr + rate.z * sr * cp,
        -rate.y * sr + rate.z * cr * cp,
    )
}

/// `C_b_n` of roll, pitch, yaw [rad].
pub fn c_b_n_from_euler(euler: &Vector3<f64>) -> Matrix3<f64> {
    attitude::from_euler(euler.x, euler.y, euler.z)
        .to_rotation_matrix()
        .into_inner()
}

/// Time derivatives of the integrated quantities: `(d point/dt, omega_ib_b, f_ib_b)`.
fn rates(traj: &dyn Trajectory, t: f64, p: &Point) -> (Point, Vector3<f64>, Vector3<f64>) {
    let m = traj.motion(t, p);
    let e = LocalEarth::new(p.lat, p.h);
    let v = m.v_eb_n;
    let (sin_lat, cos_lat) = p.lat.sin_cos();
    let (rm_h, rn_h) = (e.r_meridian + p.h, e.r_transverse + p.h);
    // Groves eq. 2.111 and 5.44.
    let d_point = Point {
        lat: v.x / rm_h,
        lon: v.y / (rn_h * cos_lat),
        h: -v.z,
        aux: m.aux_rate,
    };
    let omega_ie_n = Vector3::new(OMEGA_IE * cos_lat, 0.0, -OMEGA_IE * sin_lat);
    let omega_en_n = Vector3::new(v.y / rn_h, -v.x / rm_h, -v.y * sin_lat / (rn_h * cos_lat));
    let c_n_b = c_b_n_from_euler(&m.euler).transpose();
    let omega_ib_b =
        body_rate_from_euler(&m.euler, &m.euler_rate) + c_n_b * (omega_ie_n + omega_en_n);
    let g_n = Vector3::new(0.0, 0.0, e.g);
    let f_ib_b = c_n_b * (m.a_eb_n + (omega_ie_n * 2.0 + omega_en_n).cross(&v) - g_n);
    (d_point, omega_ib_b, f_ib_b)
}

/// What ideal sensors sense at time `t` [s] at point `p`: `(omega_ib_b [rad/s], f_ib_b [m/s^2])`,
/// body axes (the integrands of the increments).
pub fn sensed_at(traj: &dyn Trajectory, t: f64, p: &Point) -> (Vector3<f64>, Vector3<f64>) {
    let (_, omega_ib_b, f_ib_b) = rates(traj, t, p);
    (omega_ib_b, f_ib_b)
}

/// The truth of `traj` at `t` [s] and point `p`.
pub fn truth_at(traj: &dyn Trajectory, t: f64, p: &Point) -> Truth {
    let m = traj.motion(t, p);
    Truth {
        t_s: t,
        lat: p.lat,
        lon: wrap_pi(p.lon),
        h: p.h,
        v_eb_ned: m.v_eb_n,
        q_b_ned: attitude::from_euler(m.euler.x, m.euler.y, m.euler.z),
    }
}

/// `a` wrapped to `(-pi, pi]`.
pub fn wrap_pi(a: f64) -> f64 {
    let pi = core::f64::consts::PI;
    let w = (a + pi).rem_euclid(2.0 * pi) - pi;
    if w == -pi { pi } else { w }
}

/// The state carried from one interval to the next.
#[derive(Clone, Copy)]
pub struct Generator<'a> {
    traj: &'a dyn Trajectory,
    point: Point,
    t: f64,
    substeps: usize,
}

impl<'a> Generator<'a> {
    /// A generator at the trajectory's start.
    pub fn new(traj: &'a dyn Trajectory) -> Self {
        Self::with_substeps(traj, SUBSTEPS)
    }

    /// The same with `substeps` RK4 steps per interval (tests of convergence).
    pub fn with_substeps(traj: &'a dyn Trajectory, substeps: usize) -> Self {
        Self {
            traj,
            point: traj.start(),
            t: 0.0,
            substeps: substeps.max(1),
        }
    }

    /// The truth now.
    pub fn truth(&self) -> Truth {
        truth_at(self.traj, self.t, &self.point)
    }

    /// Time now [s].
    pub fn t(&self) -> f64 {
        self.t
    }

    /// Advances to `t_end` [s], returning the exact increment over `[t, t_end]` and the truth at
    /// `t_end`.
    pub fn advance_to(&mut self, t_end: f64) -> (ImuIncrement<f64>, Truth) {
        self.advance_with(t_end, &mut NoRider)
    }

    /// The same, integrating `rider` along: each RK4 stage evaluates the rider's derivative at
    /// the stage's time with the stage's `omega_ib_b` and `f_ib_b`, and the rider's stage states
    /// are `y + k h/2`, `y + k h/2`, `y + k h` as for the position (classic RK4).
    pub fn advance_with<R: Rider>(
        &mut self,
        t_end: f64,
        rider: &mut R,
    ) -> (ImuIncrement<f64>, Truth) {
        let dt = t_end - self.t;
        let h = dt / self.substeps as f64;
        let mut d_theta = Vector3::zeros();
        let mut d_v = Vector3::zeros();
        let add = |p: &Point, k: &Point, s: f64| Point {
            lat: p.lat + k.lat * s,
            lon: p.lon + k.lon * s,
            h: p.h + k.h * s,
            aux: p.aux + k.aux * s,
        };
        for i in 0..self.substeps {
            let t0 = self.t + h * i as f64;
            let p = self.point;
            let y = *rider;
            let (k1, w1, f1) = rates(self.traj, t0, &p);
            let r1 = y.deriv(t0, &w1, &f1);
            let (k2, w2, f2) = rates(self.traj, t0 + 0.5 * h, &add(&p, &k1, 0.5 * h));
            let r2 = y.axpy(&r1, 0.5 * h).deriv(t0 + 0.5 * h, &w2, &f2);
            let (k3, w3, f3) = rates(self.traj, t0 + 0.5 * h, &add(&p, &k2, 0.5 * h));
            let r3 = y.axpy(&r2, 0.5 * h).deriv(t0 + 0.5 * h, &w3, &f3);
            let (k4, w4, f4) = rates(self.traj, t0 + h, &add(&p, &k3, h));
            let r4 = y.axpy(&r3, h).deriv(t0 + h, &w4, &f4);
            let k = Point {
                lat: k1.lat + 2.0 * k2.lat + 2.0 * k3.lat + k4.lat,
                lon: k1.lon + 2.0 * k2.lon + 2.0 * k3.lon + k4.lon,
                h: k1.h + 2.0 * k2.h + 2.0 * k3.h + k4.h,
                aux: k1.aux + 2.0 * k2.aux + 2.0 * k3.aux + k4.aux,
            };
            self.point = add(&p, &k, h / 6.0);
            *rider = y
                .axpy(&r1, h / 6.0)
                .axpy(&r2, h / 3.0)
                .axpy(&r3, h / 3.0)
                .axpy(&r4, h / 6.0);
            d_theta += (w1 + (w2 + w3) * 2.0 + w4) * (h / 6.0);
            d_v += (f1 + (f2 + f3) * 2.0 + f4) * (h / 6.0);
        }
        self.t = t_end;
        (
            ImuIncrement {
                delta_theta_ib_b: d_theta,
                delta_v_ib_b: d_v,
                dt,
            },
            self.truth(),
        )
    }
}

/// An ODE integrated along a trajectory ([`Generator::advance_with`]): its state is `Self`, and
/// its derivative depends on time and on the body's `omega_ib_b` and `f_ib_b` only. The
/// derivative has the type of the state; constants a rider carries are taken from the state in
/// [`Rider::axpy`] and are ignored in the derivative.
pub trait Rider: Copy {
    /// `dy/dt` at time `t` [s] for state `self`, with the body's angular rate `omega_ib_b`
    /// [rad/s] and specific force `f_ib_b` [m/s^2] (body axes) at that instant.
    fn deriv(&self, t: f64, omega_ib_b: &Vector3<f64>, f_ib_b: &Vector3<f64>) -> Self;
    /// `self + k s` (`k` a derivative, `s` a time step [s]).
    fn axpy(&self, k: &Self, s: f64) -> Self;
}

/// The rider of [`Generator::advance_to`]: nothing.
#[derive(Clone, Copy, Debug)]
struct NoRider;

impl Rider for NoRider {
    #[inline]
    fn deriv(&self, _: f64, _: &Vector3<f64>, _: &Vector3<f64>) -> Self {
        NoRider
    }
    #[inline]
    fn axpy(&self, _: &Self, _: f64) -> Self {
        NoRider
    }
}

/// Sampling of a generated run: `n` intervals at `rate_hz`, interval `k` ending at
/// `round((k + 1) 1e9 / rate_hz)` ns (the recording's timestamps).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling {
    /// Rate [Hz].
    pub rate_hz: f64,
    /// Number of samples.
    pub n: u64,
}

impl Sampling {
    /// `seconds` [s] at `rate_hz` [Hz] (rounded to whole samples).
    pub fn new(rate_hz: f64, seconds: f64) -> Self {
        Self {
            rate_hz,
            n: (seconds * rate_hz).round().max(0.0) as u64,
        }
    }

    /// End of interval `k` [ns].
    pub fn t_ns(&self, k: u64) -> u64 {
        ((k + 1) as f64 * 1e9 / self.rate_hz).round() as u64
    }
}

/// Runs `traj` sampled by `s`, calling `visit(k, t_ns, exact increment, truth at its end)`.
pub fn generate(
    traj: &dyn Trajectory,
    s: Sampling,
    mut visit: impl FnMut(u64, u64, &ImuIncrement<f64>, &Truth),
) {
    let mut g = Generator::new(traj);
    for k in 0..s.n {
        let t_ns = s.t_ns(k);
        let (inc, truth) = g.advance_to(t_ns as f64 * 1e-9);
        visit(k, t_ns, &inc, &truth);
    }
}

/// `q_b_ned` as a unit quaternion from an Euler triple (convenience for scenario code).
pub fn q_from_euler(euler: &Vector3<f64>) -> UnitQuaternion<f64> {
    attitude::from_euler(euler.x, euler.y, euler.z)
}
