//! Strapdown mechanization in a local-level frame: NED or wander azimuth.
//!
//! Per increment (Savage, *Strapdown Analytics*, ch. 7; Groves §5.4–5.5; Titterton & Weston
//! ch. 3), with the navigation-frame quantities taken at the start of the interval:
//! 1. sensor error compensation ([`crate::calibration`], seed 000 eqs. 3 and 8);
//! 2. coning and sculling ([`crate::coning`]): rotation vector `phi_b` and velocity increment
//!    `dv_b` in body axes at the start of the interval;
//! 3. Earth quantities from the position matrix's vertical row `c_n` (no trigonometry):
//!    `omega_ie_n = Omega c_n`, transport rate `rho_n` ([`LocalEarth::transport_rate`], plus
//!    `-v_E tan(lat) / (R_E + h)` about down in the NED frame), `zeta = (omega_ie_n + rho_n) dt`;
//! 4. velocity: `v(k) = v(k-1) + dv_n + (g_n - (2 omega_ie_n + rho_n) x v(k-1)) dt`,
//!    `dv_n = (I - [zeta x] / 2) C_b_n(k-1) dv_b` (Savage (7.2.2.2-21));
//! 5. attitude: `q_b_n(k) = q(-zeta) q_b_n(k-1) q(phi_b)` (Savage (7.1.2-14)) — or Poisson's
//!    DCM equation with a selectable integrator ([`crate::poisson`], seed 000);
//! 6. position: `C_n_e(k) = C_n_e(k-1) exp([xi x])`, `xi = rho_n(v_mid) dt` with the
//!    trapezoidal velocity `v_mid`, and `h(k) = h(k-1) - v_D,mid dt` ([`Position`], fixed
//!    point).
//!
//! The wander-azimuth frame (seeds 003, 004) has no vertical transport rate: it works over the
//! poles; NED outputs come from its wander angle ([`NavState::ned`]). The NED frame is singular
//! at the poles (`tan(lat)`), as in any NED mechanization.

use crate::calibration::ImuCompensation;
use crate::coning::ConingSculling;
use crate::earth::{LocalEarth, OMEGA_IE};
use crate::poisson::{DcmIntegrator, PoissonDcm};
use crate::{ImuIncrement, InputError, InputLimits, NavState, Scalar};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// The local-level navigation frame of the mechanization.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NavFrame {
    /// North-east-down: the frame turns about the vertical to stay north (singular at a pole).
    Ned,
    /// Wander azimuth: no rotation about the vertical relative to the Earth
    /// (`omega_en_n . u_d = 0`); the wander angle is kept in the position.
    WanderAzimuth,
}

/// How the attitude is integrated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AttitudeMethod {
    /// Rotation-vector quaternion update, exact for a constant rate (the default).
    RotationVector,
    /// Poisson's DCM equation (seed 000) with the rate modelled linear over the interval from
    /// the current and previous increments, re-orthonormalised every step.
    Poisson(DcmIntegrator),
}

/// Mechanization options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MechanizationConfig<T: Scalar> {
    /// Limits every increment is checked against before use.
    pub limits: InputLimits<T>,
    /// The navigation frame (default wander azimuth).
    pub frame: NavFrame,
    /// The attitude integration (default rotation vector).
    pub attitude: AttitudeMethod,
    /// Two-sample coning and sculling compensation (default on).
    pub coning_sculling: bool,
    /// Sensor error compensation (default identity).
    pub compensation: ImuCompensation<T>,
}

impl<T: Scalar> Default for MechanizationConfig<T> {
    fn default() -> Self {
        Self {
            limits: InputLimits::default(),
            frame: NavFrame::WanderAzimuth,
            attitude: AttitudeMethod::RotationVector,
            coning_sculling: true,
            compensation: ImuCompensation::default(),
        }
    }
}

/// The strapdown integrator: owns the navigation state and advances it one increment at a time.
#[derive(Clone, Debug)]
pub struct Strapdown<T: Scalar> {
    state: NavState<T>,
    config: MechanizationConfig<T>,
    cs: ConingSculling<T>,
    /// Poisson mode: the DCM and the previous mean rate (for the linear rate model).
    dcm: Option<(PoissonDcm<T>, Option<Vector3<T>>)>,
    steps: u32,
    rejected: u32,
}

impl<T: Scalar> Strapdown<T> {
    /// Starts navigating from `initial`. In the NED frame the position's frame is turned to
    /// north first.
    pub fn new(initial: NavState<T>, config: MechanizationConfig<T>) -> Self {
        let mut s = Self {
            state: initial,
            config,
            cs: ConingSculling::new(),
            dcm: None,
            steps: 0,
            rejected: 0,
        };
        s.set_state(initial);
        s
    }

    /// The current navigation state.
    pub fn state(&self) -> &NavState<T> {
        &self.state
    }

    /// The configuration.
    pub fn config(&self) -> &MechanizationConfig<T> {
        &self.config
    }

    /// Replaces the state (e.g. after alignment or a filter correction). In the NED frame a
    /// state in a wander frame is converted to NED.
    pub fn set_state(&mut self, state: NavState<T>) {
        self.state = if self.config.frame == NavFrame::Ned {
            state.to_ned_frame()
        } else {
            state
        };
        self.dcm = match self.config.attitude {
            AttitudeMethod::RotationVector => None,
            AttitudeMethod::Poisson(m) => Some((
                PoissonDcm::new(self.state.q_b_n.to_rotation_matrix().into_inner(), m),
                None,
            )),
        };
    }

    /// Number of increments integrated.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Number of increments refused by [`InputLimits`].
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Forgets the previous increment (call after a gap in the data so the two-sample terms do
    /// not span it).
    pub fn restart_increments(&mut self) {
        self.cs.reset();
        if let Some((_, prev)) = &mut self.dcm {
            *prev = None;
        }
    }

    /// Integrates one increment. An increment that fails [`ImuIncrement::check`] is counted and
    /// refused; the state is then unchanged (and the two-sample history restarts).
    pub fn step(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        if let Err(e) = inc.check(&self.config.limits) {
            self.rejected = self.rejected.saturating_add(1);
            self.restart_increments();
            return Err(e);
        }
        let dt = inc.dt;
        let half = T::c(0.5);
        let comp = &self.config.compensation;
        let d_theta = comp.gyro.apply(&inc.delta_theta_ib_b, dt);
        let d_v = comp.accel.apply(&inc.delta_v_ib_b, dt);
        let c = self
            .cs
            .compensate(&d_theta, &d_v, dt, self.config.coning_sculling);

        let s = &mut self.state;
        let c_n = s.position.vertical_row::<T>();
        let sin_lat = -c_n.z;
        let cos2_lat = c_n.x * c_n.x + c_n.y * c_n.y;
        let earth = LocalEarth::from_sin_lat(sin_lat, cos2_lat, s.position.h::<T>());
        let omega_ie_n = c_n * T::c(OMEGA_IE);
        let rho_n = transport_rate(self.config.frame, &earth, &c_n, &s.v_eb_n);
        let zeta = (omega_ie_n + rho_n) * dt;

        // Velocity (Savage (7.2.2.2-21)), Coriolis and gravity at the start of the interval.
        let dv_n0 = s.q_b_n * c.delta_v_b;
        let dv_n = dv_n0 - zeta.cross(&dv_n0) * half;
        let g_n = Vector3::new(T::zero(), T::zero(), earth.g);
        let coriolis = (omega_ie_n * T::c(2.0) + rho_n).cross(&s.v_eb_n);
        let v_old = s.v_eb_n;
        s.v_eb_n = v_old + dv_n + (g_n - coriolis) * dt;

        // Attitude.
        match &mut self.dcm {
            None => s.q_b_n = rotation_vector_update(&s.q_b_n, &c.phi_b, &zeta),
            Some((dcm, prev)) => {
                s.q_b_n = poisson_update(dcm, prev, &d_theta, &zeta, dt);
            }
        }

        // Position: trapezoidal velocity, frame rotation and height.
        let v_mid = (v_old + s.v_eb_n) * half;
        let xi = transport_rate(self.config.frame, &earth, &c_n, &v_mid) * dt;
        s.position.rotate(&xi);
        s.position.add_height(-v_mid.z * dt);

        self.steps = self.steps.wrapping_add(1);
        Ok(())
    }
}

/// `rho_n` [rad/s] of `frame` for velocity `v` [m/s].
#[inline]
fn transport_rate<T: Scalar>(
    frame: NavFrame,
    earth: &LocalEarth<T>,
    c_n: &Vector3<T>,
    v: &Vector3<T>,
) -> Vector3<T> {
    let mut rho = earth.transport_rate(c_n, v);
    if frame == NavFrame::Ned {
        // -v_E tan(lat) / (R_E + h); cos(lat) floored at 1e-9 (1 cm from the pole).
        let cos_lat = earth.cos2_lat.sqrt().max(T::c(1e-9));
        rho.z = -v.y * earth.sin_lat / (cos_lat * (earth.r_transverse + earth.h));
    }
    rho
}

/// `q(-zeta) q q(phi)`, computed as `q + delta` with the small `delta = q p + z q + z q p`
/// (`p = q(phi) - 1`, `z = q(-zeta) - 1`) so that two nearly cancelling rotations (a body at
/// rest follows the Earth) leave `q` bit-exact in `f32`; then a first-order renormalisation.
#[inline]
fn rotation_vector_update<T: Scalar>(
    q_b_n: &UnitQuaternion<T>,
    phi_b: &Vector3<T>,
    zeta: &Vector3<T>,
) -> UnitQuaternion<T> {
    let q = *q_b_n.quaternion();
    let p = small_rotation(phi_b);
    let z = small_rotation(&(-zeta));
    let qp = q * p;
    let delta = qp + z * q + z * qp;
    let n = q + delta;
    let n2 = n.norm_squared();
    UnitQuaternion::new_unchecked(n * ((T::c(3.0) - n2) * T::c(0.5)))
}

/// `q(phi) - 1` [-] without cancellation in the scalar part.
#[inline]
fn small_rotation<T: Scalar>(phi: &Vector3<T>) -> Quaternion<T> {
    let (w, s) = crate::attitude::rotation_vector_terms(phi.norm_squared());
    Quaternion::from_parts(w, phi * s)
}

/// Poisson mode: the rate is modelled `omega(s) = mean + b (s - dt/2)` over the interval from
/// the current and previous mean rates; `dC/dt = C [omega x] - [omega_in x] C`.
fn poisson_update<T: Scalar>(
    dcm: &mut PoissonDcm<T>,
    prev: &mut Option<Vector3<T>>,
    d_theta: &Vector3<T>,
    zeta: &Vector3<T>,
    dt: T,
) -> UnitQuaternion<T> {
    let mean = d_theta / dt;
    let slope = prev.map_or(Vector3::zeros(), |p| (mean - p) / dt);
    *prev = Some(mean);
    let omega_in = zeta.cross_matrix() / dt;
    let half_dt = dt * T::c(0.5);
    dcm.step(T::zero(), dt, |t, c: &Matrix3<T>| {
        let omega = mean + slope * (t - half_dt);
        c * omega.cross_matrix() - omega_in * c
    });
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*dcm.dcm()))
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
