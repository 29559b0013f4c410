//! Strapdown mechanization in the local-level NED frame (spine version).
//!
//! Per increment (Groves §5.4 / Titterton & Weston §3.5, first-order in the navigation-frame
//! rates):
//! - attitude: `q_b_n(k) = q(-zeta) * q_b_n(k-1) * q(delta_theta)`, `zeta = (omega_ie_n +
//!   omega_en_n) dt`, with the exact rotation-vector quaternion `q(.)`;
//! - velocity: `v(k) = v(k-1) + dv_n + (g_n - (2 omega_ie_n + omega_en_n) x v) dt` with
//!   `dv_n = (I - [zeta x]/2) c_b_n(k-1) (delta_v + delta_theta x delta_v / 2)` (rotation
//!   compensation of the body and navigation frames, Savage (7.2.2.2-11) and (7.2.2.2-21));
//! - position: trapezoidal integration of the NED velocity into latitude, longitude and height.
//!
//! Coning/sculling corrections, the oblate gravitation model, selectable attitude integrators and
//! the wander-azimuth frame come with the full mechanization; [`MechanizationConfig`] is where
//! their switches will live.

use crate::attitude::rotation_vector_quat;
use crate::earth::LocalEarth;
use crate::{ImuIncrement, InputError, InputLimits, NavState, Scalar};
use nalgebra::Vector3;

/// Mechanization options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MechanizationConfig<T: Scalar> {
    /// Limits every increment is checked against before use.
    pub limits: InputLimits<T>,
}

impl<T: Scalar> Default for MechanizationConfig<T> {
    fn default() -> Self {
        Self {
            limits: InputLimits::default(),
        }
    }
}

/// The strapdown integrator: owns the navigation state and advances it one increment at a time.
#[derive(Clone, Debug)]
pub struct Strapdown<T: Scalar> {
    state: NavState<T>,
    config: MechanizationConfig<T>,
    steps: u32,
    rejected: u32,
}

impl<T: Scalar> Strapdown<T> {
    /// Starts navigating from `initial`.
    pub fn new(initial: NavState<T>, config: MechanizationConfig<T>) -> Self {
        Self {
            state: initial,
            config,
            steps: 0,
            rejected: 0,
        }
    }

    /// The current navigation state.
    pub fn state(&self) -> &NavState<T> {
        &self.state
    }

    /// Replaces the state (e.g. after alignment or a filter correction).
    pub fn set_state(&mut self, state: NavState<T>) {
        self.state = state;
    }

    /// Number of increments integrated.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Number of increments refused by [`InputLimits`].
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Integrates one increment. An increment that fails [`ImuIncrement::check`] is counted and
    /// refused; the state is then unchanged.
    pub fn step(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        if let Err(e) = inc.check(&self.config.limits) {
            self.rejected = self.rejected.saturating_add(1);
            return Err(e);
        }
        let s = &mut self.state;
        let dt = inc.dt;
        let earth = LocalEarth::new(s.position.lat::<T>(), s.position.h::<T>());
        let omega_ie_n = earth.omega_ie_n();
        let omega_en_n = earth.omega_en_n(&s.v_eb_n);

        // Navigation-frame rotation over the interval.
        let zeta = (omega_ie_n + omega_en_n) * dt;

        // Velocity increment resolved at mid-interval: body rotation compensation
        // `delta_theta x delta_v / 2` and the navigation-frame term `-zeta x dv_n / 2`.
        let half = T::c(0.5);
        let dv_b = inc.delta_v_ib_b + inc.delta_theta_ib_b.cross(&inc.delta_v_ib_b) * half;
        let dv_n0 = s.q_b_n * dv_b;
        let dv_n = dv_n0 - zeta.cross(&dv_n0) * half;

        // Attitude: body rotation then navigation-frame rotation.
        s.q_b_n =
            rotation_vector_quat(&(-zeta)) * s.q_b_n * rotation_vector_quat(&inc.delta_theta_ib_b);
        s.q_b_n.renormalize_fast();

        // Velocity: specific force, gravity, Coriolis and transport rate.
        let g_n = Vector3::new(T::zero(), T::zero(), earth.g);
        let coriolis = (omega_ie_n * T::c(2.0) + omega_en_n).cross(&s.v_eb_n);
        let v_old = s.v_eb_n;
        s.v_eb_n = v_old + dv_n + (g_n - coriolis) * dt;

        // Position: trapezoidal rule on the velocity.
        let v_mid = (v_old + s.v_eb_n) * half;
        let d_lat = v_mid.x / (earth.r_meridian + earth.h) * dt;
        let d_lon = v_mid.y / ((earth.r_transverse + earth.h) * earth.cos_lat) * dt;
        let d_h = -v_mid.z * dt;
        s.position.add(d_lat, d_lon, d_h);

        self.steps = self.steps.wrapping_add(1);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Position, attitude::from_euler, earth};
    use nalgebra::UnitQuaternion;

    /// Exact increments of a body at rest on the Earth with attitude `q_b_n`.
    fn rest_increment(lat: f64, h: f64, q_b_n: &UnitQuaternion<f64>, dt: f64) -> ImuIncrement<f64> {
        let q_n_b = q_b_n.inverse();
        let omega_ib_b = q_n_b * earth::omega_ie_n(lat);
        let f_ib_b = q_n_b * Vector3::new(0.0, 0.0, -earth::normal_gravity(lat, h));
        ImuIncrement {
            delta_theta_ib_b: omega_ib_b * dt,
            delta_v_ib_b: f_ib_b * dt,
            dt,
        }
    }

    #[test]
    fn stationary_exact_inputs_stay_put() {
        let (lat, h) = (45f64.to_radians(), 100.0);
        let q = from_euler(0.02, -0.01, 1.0);
        let start = NavState::at_rest(Position::from_radians(lat, 0.3, h), q);
        let mut nav = Strapdown::new(start, MechanizationConfig::default());
        let inc = rest_increment(lat, h, &q, 0.0025);
        for _ in 0..400 * 600 {
            nav.step(&inc).unwrap();
        }
        let s = nav.state();
        // 10 min of exact inputs: only rounding, far below a millimetre per second.
        assert!(s.v_eb_n.norm() < 1e-6, "{}", s.v_eb_n);
        assert!((s.position.lat::<f64>() - lat).abs() * 6.4e6 < 1e-3);
        assert!((s.position.h_f64() - h).abs() < 1e-3);
        assert!(s.q_b_n.angle_to(&q) < 1e-9);
    }

    #[test]
    fn refused_increment_leaves_state_unchanged() {
        let q = UnitQuaternion::identity();
        let start = NavState::<f32>::at_rest(Position::from_degrees(10.0, 20.0, 0.0), q);
        let mut nav = Strapdown::new(start, MechanizationConfig::default());
        let bad = ImuIncrement::new([f32::NAN, 0.0, 0.0], [0.0; 3], 0.0025);
        assert_eq!(nav.step(&bad), Err(InputError::NonFinite));
        assert_eq!(nav.state(), &start);
        assert_eq!((nav.steps(), nav.rejected()), (0, 1));
    }

    #[test]
    fn free_fall_free_of_specific_force_accelerates_at_g() {
        // Zero specific force and zero rate: the body falls; 1 s gives ~g m/s down.
        let start = NavState::at_rest(
            Position::from_degrees(0.0, 0.0, 1000.0),
            UnitQuaternion::identity(),
        );
        let mut nav = Strapdown::new(start, MechanizationConfig::default());
        let inc = ImuIncrement::new([0.0; 3], [0.0; 3], 0.0025_f64);
        for _ in 0..400 {
            nav.step(&inc).unwrap();
        }
        let g = earth::normal_gravity(0.0, 1000.0);
        let s = nav.state();
        assert!((s.v_eb_n.z - g).abs() < 2e-3 * g, "{}", s.v_eb_n);
        assert!((1000.0 - s.position.h_f64() - 0.5 * g).abs() < 0.01 * g);
    }
}
