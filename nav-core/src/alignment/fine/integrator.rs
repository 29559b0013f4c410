//! The fine filters' strapdown: a body at a fixed site, integrated in a local-level frame `c`
//! whose azimuth is unknown.
//!
//! `c` is the true NED frame turned about down by a constant angle `alpha` (the body's
//! initial heading minus the heading the integrator was started with), so it is level, fixed
//! to the Earth, and its Earth rate is `omega_ie_c = (W cos alpha, -W sin alpha, -Omega sin L)`,
//! `W = Omega cos L`: the horizontal part carries the heading and is estimated by the filter
//! ([`super::model`]); the integrator uses the current estimate. Everything else the filter
//! measures (the IMU's displacement from the centre, its velocity, the level) is the same in
//! any azimuth, which is why no initial heading is needed [Titterton & Weston, §10.3].
//!
//! Per increment ([Savage, 7.1.2-14, 7.2.2.2-21], as [`crate::strapdown`] at rest):
//! ```text
//! q_b_c <- q(-zeta) q_b_c q(phi_b),          zeta = omega_ie_c dt
//! v_c   <- v_c + C_b_c dv_b - zeta x (C_b_c dv_b) / 2 + (g_c - 2 omega_ie_c x v_c) dt
//! r_c   <- r_c + (v_c(old) + v_c(new)) dt / 2
//! ```
//! `phi_b`, `dv_b` the coning- and sculling-compensated increments ([`crate::coning`]) after
//! the bias compensation, `g_c = (0, 0, g(L, h - r_D))` (normal gravity with its vertical
//! gradient). The transport rate (`v / R`, below 2e-7 rad/s at 1 m/s, and oscillating) is
//! left out: the base stays in place. Attitude and velocity are summed with Kahan carries so
//! that in `f32` the Earth-rate and Schuler-tilt increments are kept.

use crate::coning::ConingSculling;
use crate::earth::{LocalEarth, OMEGA_IE};
use crate::scalar::zeros;
use crate::strapdown::{dcm_of, kahan_add, small_rotation};
use crate::{ImuIncrement, Scalar};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// What one increment contributed, for the filter's interval sums.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepSums<T: Scalar> {
    /// `C_b_c` at the start of the increment.
    pub c_b_c: Matrix3<T>,
    /// The specific-force increment in `c` [m/s].
    pub dv_c: Vector3<T>,
}

/// The site strapdown (module docs).
#[derive(Clone, Debug)]
pub struct SiteStrapdown<T: Scalar> {
    q: Quaternion<T>,
    q_carry: Quaternion<T>,
    v_c: Vector3<T>,
    v_carry: Vector3<T>,
    r_c: Vector3<T>,
    r_carry: Vector3<T>,
    cs: ConingSculling<T>,
    /// Horizontal Earth rate in `c` as estimated `(e_N, e_E)` [rad/s].
    e_h: [T; 2],
    omega_down: T,
    g0: T,
    /// `dg/dr_D` [1/s^2] (deeper: more gravity).
    dg_dd: T,
    gyro_bias_b: Vector3<T>,
    accel_bias_b: Vector3<T>,
}

impl<T: Scalar> SiteStrapdown<T> {
    /// All zero (attitude included: no rotation): the storage of an integrator started later
    /// in place (the fine filters' [`super::FineCore::BLANK`]).
    pub(crate) const BLANK: Self = Self {
        q: Quaternion::from_vector(zeros()),
        q_carry: Quaternion::from_vector(zeros()),
        v_c: zeros(),
        v_carry: zeros(),
        r_c: zeros(),
        r_carry: zeros(),
        cs: ConingSculling::new(),
        e_h: [T::ZERO; 2],
        omega_down: T::ZERO,
        g0: T::ZERO,
        dg_dd: T::ZERO,
        gyro_bias_b: zeros(),
        accel_bias_b: zeros(),
    };

    /// At latitude `lat` [rad], height `h` [m], attitude `q_b_c`, velocity `v_c` [m/s] and
    /// displacement `r_c` [m], the horizontal Earth rate taken as `e_h` [rad/s].
    pub fn new(
        lat: T,
        h: T,
        q_b_c: UnitQuaternion<T>,
        v_c: Vector3<T>,
        r_c: Vector3<T>,
        e_h: [T; 2],
    ) -> Self {
        let earth = LocalEarth::new(lat, h);
        let r = (earth.r_meridian * earth.r_transverse).sqrt();
        Self {
            q: *q_b_c.quaternion(),
            q_carry: Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero()),
            v_c,
            v_carry: Vector3::zeros(),
            r_c,
            r_carry: Vector3::zeros(),
            cs: ConingSculling::new(),
            e_h,
            omega_down: -T::c(OMEGA_IE) * earth.sin_lat,
            g0: earth.g,
            dg_dd: T::c(2.0) * earth.g / r,
            gyro_bias_b: Vector3::zeros(),
            accel_bias_b: Vector3::zeros(),
        }
    }

    /// The Earth rate in `c` the integrator uses [rad/s].
    pub fn omega_ie_c(&self) -> Vector3<T> {
        Vector3::new(self.e_h[0], self.e_h[1], self.omega_down)
    }

    /// Gravity's magnitude at the current displacement [m/s^2].
    pub fn gravity(&self) -> T {
        self.g0 + self.dg_dd * self.r_c.z
    }

    /// Integrates one (checked) increment.
    pub fn step(&mut self, inc: &ImuIncrement<T>) -> StepSums<T> {
        let dt = inc.dt;
        let half = T::c(0.5);
        let c = self.cs.compensate(
            &(inc.delta_theta_ib_b - self.gyro_bias_b * dt),
            &(inc.delta_v_ib_b - self.accel_bias_b * dt),
            dt,
            true,
        );
        let omega = self.omega_ie_c();
        let zeta = omega * dt;
        let c_b_c = dcm_of(&self.q);
        let dv_c = c_b_c * c.delta_v_b;
        let g_c = Vector3::new(T::zero(), T::zero(), self.gravity());
        let coriolis = (omega * T::c(2.0)).cross(&self.v_c);
        let delta_v = dv_c - zeta.cross(&dv_c) * half + (g_c - coriolis) * dt;
        let v_old = self.v_c;
        kahan_add(
            self.v_c.as_mut_slice(),
            self.v_carry.as_mut_slice(),
            delta_v.as_slice(),
        );
        let delta_r = (v_old + self.v_c) * (dt * half);
        kahan_add(
            self.r_c.as_mut_slice(),
            self.r_carry.as_mut_slice(),
            delta_r.as_slice(),
        );
        // q <- q(-zeta) q q(phi) = q + [q (q(phi) - 1) + (q(-zeta) - 1) q + (q(-zeta) - 1) q
        // (q(phi) - 1)]: only the small terms are rounded.
        let p = small_rotation(&c.phi_b);
        let z = small_rotation(&(-zeta));
        let qp = self.q * p;
        let delta = qp + z * self.q + z * qp;
        kahan_add(
            self.q.coords.as_mut_slice(),
            self.q_carry.coords.as_mut_slice(),
            delta.coords.as_slice(),
        );
        let n2 = self.q.norm_squared();
        if (n2 - T::one()).abs() > T::c(1e-4) {
            self.q /= n2.sqrt();
            self.q_carry = Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero());
        }
        StepSums { c_b_c, dv_c }
    }

    /// Forgets the previous increment (a gap in the data: the two-sample terms must not span
    /// it).
    pub fn restart_increments(&mut self) {
        self.cs.reset();
    }

    /// Attitude `q_b_c`.
    pub fn q_b_c(&self) -> UnitQuaternion<T> {
        UnitQuaternion::new_normalize(self.q)
    }

    /// `C_b_c`.
    pub fn c_b_c(&self) -> Matrix3<T> {
        self.q_b_c().to_rotation_matrix().into_inner()
    }

    /// Velocity relative to the Earth in `c` [m/s].
    pub fn v_c(&self) -> Vector3<T> {
        self.v_c
    }

    /// Displacement of the IMU from the centre's mean position, in `c` [m].
    pub fn r_c(&self) -> Vector3<T> {
        self.r_c
    }

    /// The bias compensation in use: gyro [rad/s] and accelerometer [m/s^2], body axes.
    pub fn biases(&self) -> (Vector3<T>, Vector3<T>) {
        (self.gyro_bias_b, self.accel_bias_b)
    }

    /// Applies the filter's estimates (closed loop): `true = q(phi) computed` for the attitude,
    /// velocity and displacement errors subtracted, the horizontal Earth-rate error subtracted,
    /// the residual biases added to the compensation.
    pub fn correct(&mut self, c: &Correction<T>) {
        let q = crate::attitude::rotation_vector_quat(&c.phi) * self.q_b_c();
        self.q = *q.quaternion();
        self.q_carry = Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero());
        self.v_c -= c.dv;
        self.v_carry = Vector3::zeros();
        self.r_c -= c.dr;
        self.r_carry = Vector3::zeros();
        self.e_h[0] -= c.de[0];
        self.e_h[1] -= c.de[1];
        self.gyro_bias_b += c.gyro_bias;
        self.accel_bias_b += c.accel_bias;
    }

    /// The horizontal Earth rate in `c` in use `(e_N, e_E)` [rad/s].
    pub fn e_h(&self) -> [T; 2] {
        self.e_h
    }
}

/// The error estimates fed back into [`SiteStrapdown`] (every error "computed minus true",
/// biases "residual in the compensated output").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correction<T: Scalar> {
    /// Displacement error [m].
    pub dr: Vector3<T>,
    /// Velocity error [m/s].
    pub dv: Vector3<T>,
    /// Attitude error (`C_hat = exp(-[phi x]) C`) [rad].
    pub phi: Vector3<T>,
    /// Horizontal Earth-rate error [rad/s].
    pub de: [T; 2],
    /// Residual gyro bias, body [rad/s].
    pub gyro_bias: Vector3<T>,
    /// Residual accelerometer bias, body [m/s^2].
    pub accel_bias: Vector3<T>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_euler;

    /// A body at rest, heading 40 deg, started with heading 0 and the true Earth rate of the
    /// frame turned by 40 deg: it stays at rest, level and still, exactly.
    #[test]
    fn at_rest_in_a_turned_frame_stays_put() {
        let lat = 0.8_f64;
        let alpha = 40f64.to_radians();
        let q_b_n = from_euler(0.01, -0.02, alpha);
        let w = OMEGA_IE * lat.cos();
        let g = crate::earth::normal_gravity(lat, 50.0);
        let q_n_b = q_b_n.inverse();
        let dt = 0.0025;
        let inc = ImuIncrement {
            delta_theta_ib_b: q_n_b * crate::earth::omega_ie_n(lat) * dt,
            delta_v_ib_b: q_n_b * Vector3::new(0.0, 0.0, -g) * dt,
            dt,
        };
        let q_b_c = crate::attitude::about_z(-alpha) * q_b_n;
        let mut s = SiteStrapdown::new(
            lat,
            50.0,
            q_b_c,
            Vector3::zeros(),
            Vector3::zeros(),
            [w * alpha.cos(), -w * alpha.sin()],
        );
        for _ in 0..40_000 {
            s.step(&inc);
        }
        assert!(s.v_c().norm() < 1e-9, "{}", s.v_c());
        assert!(s.r_c().norm() < 1e-7, "{}", s.r_c());
        assert!(s.q_b_c().angle_to(&q_b_c) < 1e-11);
    }
}
