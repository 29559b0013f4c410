//! Strapdown mechanization in a local-level frame: NED or wander azimuth.
//!
//! Per increment (Savage, *Strapdown Analytics*, ch. 7; Groves §5.4–5.5; Titterton & Weston
//! ch. 3), with the navigation-frame quantities taken at mid-interval (predicted: `c_n`
//! turned by half the start's transport rate, the height and velocity advanced by half a step):
//! 1. sensor error compensation ([`crate::calibration`], [Berdinskikh et al., eqs. 3 and 8]);
//! 2. coning and sculling ([`crate::coning`]): rotation vector `phi_b` and velocity increment
//!    `dv_b` in body axes at the start of the interval;
//! 3. Earth quantities from the position matrix's vertical row `c_n` (no trigonometry):
//!    `omega_ie_n = Omega c_n`, transport rate `rho_n` ([`LocalEarth::transport_rate`], plus
//!    `-v_E tan(lat) / (R_E + h)` about down in the NED frame), `zeta = (omega_ie_n + rho_n) dt`;
//! 4. velocity: `v(k) = v(k-1) + dv_n + (g_n - (2 omega_ie_n + rho_n) x v_mid) dt`,
//!    `dv_n = (I - [zeta x] / 2) C_b_n(k-1) dv_b` (Savage (7.2.2.2-21));
//! 5. attitude: `q_b_n(k) = q(-zeta) q_b_n(k-1) q(phi_b)` (Savage (7.1.2-14)) — or Poisson's
//!    DCM equation with a selectable integrator ([`crate::poisson`],
//!    [Berdinskikh et al., eqs. 1–2]);
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
    /// Poisson's DCM equation ([Berdinskikh et al., eqs. 1–2]) with the rate modelled linear over
    /// the interval from the current and previous increments, re-orthonormalised every step.
    Poisson(DcmIntegrator),
}

/// Treatment of the vertical channel, unstable in free inertial navigation (a height error
/// lowers computed gravity and grows with time constant `sqrt(R / 2g)` ~ 570 s).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VerticalChannel {
    /// Integrated freely from the accelerometers (default).
    Free,
    /// Height and vertical velocity held at their current values: a ship at sea level
    /// ([Berdinskikh et al.]), or a vehicle whose height comes from elsewhere.
    Hold,
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
    /// Vertical channel (default free).
    pub vertical: VerticalChannel,
}

impl<T: Scalar> Default for MechanizationConfig<T> {
    fn default() -> Self {
        Self {
            limits: InputLimits::default(),
            frame: NavFrame::WanderAzimuth,
            attitude: AttitudeMethod::RotationVector,
            coning_sculling: true,
            compensation: ImuCompensation::default(),
            vertical: VerticalChannel::Free,
        }
    }
}

/// The strapdown integrator: owns the navigation state and advances it one increment at a time.
///
/// Attitude and velocity are accumulated with compensated (Kahan) summation: at 400 Hz the
/// per-step changes of a slow vehicle (Earth rate, Schuler tilt: 1e-15..1e-7) are far below the
/// `f32` spacing of a quaternion component (6e-8) and would otherwise be lost, exactly as a
/// floating-point position would stop moving. The carries make the `f32` accumulation behave
/// like ~48-bit arithmetic for a few extra additions per step.
#[derive(Clone, Debug)]
pub struct Strapdown<T: Scalar> {
    /// The output state (`q_b_n` normalised).
    state: NavState<T>,
    /// Attitude as integrated (norm within `1e-4` of 1) and its summation carry.
    q: Quaternion<T>,
    q_carry: Quaternion<T>,
    /// Summation carry of the velocity.
    v_carry: Vector3<T>,
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
            q: *initial.q_b_n.quaternion(),
            q_carry: Quaternion::default(),
            v_carry: Vector3::zeros(),
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
        self.q = *self.state.q_b_n.quaternion();
        self.q_carry = Quaternion::default();
        self.v_carry = Vector3::zeros();
        self.dcm = match self.config.attitude {
            AttitudeMethod::RotationVector => None,
            AttitudeMethod::Poisson(m) => Some((
                PoissonDcm::new(self.state.q_b_n.to_rotation_matrix().into_inner(), m),
                None,
            )),
        };
    }

    /// Vertical-channel aiding: replaces the height [m] and the down velocity [m/s] with an
    /// external reference's (barometric altimeter, depth sensor, or a test's truth), as an
    /// aircraft SINS does to keep its unstable free-inertial vertical channel bounded (Groves
    /// §5.7). Non-finite values are refused (returns `false`, state unchanged).
    pub fn aid_vertical(&mut self, h_m: f64, v_down: T) -> bool {
        if !h_m.is_finite() || !v_down.finite() {
            return false;
        }
        let p = &mut self.state.position;
        if !p.add_height(h_m - p.h_f64()) {
            return false;
        }
        self.state.v_eb_n.z = v_down;
        self.v_carry.z = T::zero();
        true
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
        let hold = self.config.vertical == VerticalChannel::Hold;
        let frame = self.config.frame;
        // Navigation-frame quantities at mid-interval, predicted from the start (the frame turns
        // at `rho_n`: `d c_n/dt = -rho_n x c_n`). Start-of-interval values would leave a bias
        // of dt/2 times their rate of change: 3.5e-12 rad/s of tilt drift at 900 km/h.
        let c_n0 = s.position.vertical_row::<T>();
        let h_mid = s.position.h::<T>() - s.v_eb_n.z * dt * half;
        let earth0 = LocalEarth::from_sin_lat(-c_n0.z, c_n0.x * c_n0.x + c_n0.y * c_n0.y, h_mid);
        let rho_0 = transport_rate(frame, &earth0, &c_n0, &s.v_eb_n);
        let c_n = c_n0 - rho_0.cross(&c_n0) * (dt * half);
        let earth = LocalEarth::from_sin_lat(-c_n.z, c_n.x * c_n.x + c_n.y * c_n.y, h_mid);
        let omega_ie_n = c_n * T::c(OMEGA_IE);
        let two_omega_ie_n = omega_ie_n * T::c(2.0);

        // Velocity (Savage (7.2.2.2-21)); the increment is summed before it meets the velocity
        // (at rest its terms cancel).
        let c_b_n = dcm_of(&self.q);
        let dv_n0 = c_b_n * c.delta_v_b;
        let dv_n = dv_n0 - ((omega_ie_n + rho_0) * dt).cross(&dv_n0) * half;
        // Coriolis and transport terms at the mid-interval velocity, predicted with the
        // start-of-interval ones (one corrector pass).
        let g_n = Vector3::new(T::zero(), T::zero(), earth.g);
        let mut predicted = dv_n + (g_n - (two_omega_ie_n + rho_0).cross(&s.v_eb_n)) * dt;
        if hold {
            predicted.z = T::zero();
        }
        let v_mid = s.v_eb_n + predicted * half;
        let rho_n = transport_rate(frame, &earth, &c_n, &v_mid);
        let zeta = (omega_ie_n + rho_n) * dt;
        let coriolis = (two_omega_ie_n + rho_n).cross(&v_mid);
        let mut delta_v = dv_n + (g_n - coriolis) * dt;
        if hold {
            delta_v.z = T::zero();
        }
        let v_old = s.v_eb_n;
        kahan_add(
            s.v_eb_n.as_mut_slice(),
            self.v_carry.as_mut_slice(),
            delta_v.as_slice(),
        );

        // Attitude.
        match &mut self.dcm {
            None => {
                let delta = rotation_vector_delta(&self.q, &c.phi_b, &zeta);
                kahan_add(
                    self.q.coords.as_mut_slice(),
                    self.q_carry.coords.as_mut_slice(),
                    delta.coords.as_slice(),
                );
                let n2 = self.q.norm_squared();
                if (n2 - T::one()).abs() > T::c(1e-4) {
                    self.q /= n2.sqrt();
                    self.q_carry = Quaternion::default();
                }
                s.q_b_n = UnitQuaternion::new_normalize(self.q);
            }
            Some((dcm, prev)) => {
                s.q_b_n = poisson_update(dcm, prev, &d_theta, &zeta, dt);
                self.q = *s.q_b_n.quaternion();
            }
        }

        // Position: trapezoidal velocity, frame rotation and height.
        let v_mid = (v_old + s.v_eb_n) * half;
        let xi = transport_rate(frame, &earth, &c_n, &v_mid) * dt;
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

/// The change `delta` with `q + delta = q(-zeta) q q(phi)`: `delta = q p + z q + z q p`
/// (`p = q(phi) - 1`, `z = q(-zeta) - 1`, Savage (7.1.2-14)), small and free of the
/// cancellation of two nearly opposite rotations (a body at rest follows the Earth).
#[inline]
pub(crate) fn rotation_vector_delta<T: Scalar>(
    q: &Quaternion<T>,
    phi_b: &Vector3<T>,
    zeta: &Vector3<T>,
) -> Quaternion<T> {
    let p = small_rotation(phi_b);
    let z = small_rotation(&(-zeta));
    let qp = q * p;
    qp + z * q + z * qp
}

/// `C_b_n` of a quaternion of any norm: `C = M(q) / |q|^2` (Savage (3.2.4.1-3)).
#[inline]
pub(crate) fn dcm_of<T: Scalar>(q: &Quaternion<T>) -> Matrix3<T> {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    let k = T::one() / q.norm_squared();
    let two = T::c(2.0);
    Matrix3::new(
        (w * w + x * x - y * y - z * z) * k,
        two * (x * y - w * z) * k,
        two * (x * z + w * y) * k,
        two * (x * y + w * z) * k,
        (w * w - x * x + y * y - z * z) * k,
        two * (y * z - w * x) * k,
        two * (x * z - w * y) * k,
        two * (y * z + w * x) * k,
        (w * w - x * x - y * y + z * z) * k,
    )
}

/// Compensated summation `sum += add` per element, the rounding remainder kept in `carry`
/// (Kahan 1965; Higham, *Accuracy and Stability of Numerical Algorithms*, §4.3).
#[inline]
pub(crate) fn kahan_add<T: Scalar>(sum: &mut [T], carry: &mut [T], add: &[T]) {
    for ((s, c), a) in sum.iter_mut().zip(carry.iter_mut()).zip(add) {
        let y = *a + *c;
        let t = *s + y;
        *c = y - (t - *s);
        *s = t;
    }
}

/// `q(phi) - 1` [-] without cancellation in the scalar part.
#[inline]
pub(crate) fn small_rotation<T: Scalar>(phi: &Vector3<T>) -> Quaternion<T> {
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
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*dcm.dcm()));
    UnitQuaternion::new_normalize(q.into_inner())
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
    fn vertical_aiding_bounds_the_free_channel() {
        // An accelerometer bias of 1e-3 m/s^2 down: the free vertical channel runs away
        // (e-folding in sqrt(R / 2g) = 570 s); aided every step it stays on the reference.
        let (lat, h) = (45f64.to_radians(), 100.0);
        let q = UnitQuaternion::identity();
        let mut inc = rest_increment(lat, h, &q, 0.0025);
        inc.delta_v_ib_b.z += 1e-3 * 0.0025;
        let start = NavState::at_rest(Position::from_radians(lat, 0.3, h), q);
        let mut free = Strapdown::new(start, MechanizationConfig::default());
        let mut aided = free.clone();
        for _ in 0..400 * 600 {
            free.step(&inc).unwrap();
            aided.step(&inc).unwrap();
            assert!(aided.aid_vertical(h, 0.0));
        }
        // Free: at least the integrated bias, 1e-3 * 600^2 / 2 = 180 m.
        assert!((free.state().position.h_f64() - h).abs() > 180.0);
        assert_eq!(aided.state().position.h_f64(), h);
        assert_eq!(aided.state().v_eb_n.z, 0.0);
        assert!(!aided.aid_vertical(f64::NAN, 0.0) && !aided.aid_vertical(h, f64::INFINITY));
        assert_eq!(aided.state().position.h_f64(), h);
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

#[cfg(test)]
mod robustness {
    use super::*;
    use crate::{Position, attitude::from_euler};
    use proptest::prelude::*;

    proptest! {
        /// Any increments within the input limits, in any frame and with any attitude method,
        /// keep the state finite and the attitude a unit quaternion; anything else is refused.
        #[test]
        fn any_accepted_input_keeps_the_state_finite(
            // Rates [rad/s] and specific forces [m/s^2] within the default limits (2000 deg/s,
            // 50 g), intervals 0.5..20 ms.
            seeds in proptest::collection::vec((-34.0f32..34.0, -34.0f32..34.0, -34.0f32..34.0,
                                                -480.0f32..480.0, -480.0f32..480.0, -480.0f32..480.0,
                                                0.0005f32..0.02), 1..200),
            lat in -90.0f64..90.0,
            wander in any::<bool>(),
            poisson in any::<bool>(),
            junk in any::<u32>(),
        ) {
            let config = MechanizationConfig {
                frame: if wander { NavFrame::WanderAzimuth } else { NavFrame::Ned },
                attitude: if poisson {
                    AttitudeMethod::Poisson(DcmIntegrator::Abm4)
                } else {
                    AttitudeMethod::RotationVector
                },
                ..MechanizationConfig::default()
            };
            let start = NavState::at_rest(
                Position::from_degrees(lat, 10.0, 100.0),
                from_euler(0.1f32, -0.2, 2.0),
            );
            let mut nav = Strapdown::new(start, config);
            for (i, &(a, b, c, d, e, f, dt)) in seeds.iter().enumerate() {
                let inc = ImuIncrement::new([a * dt, b * dt, c * dt], [d * dt, e * dt, f * dt], dt);
                prop_assert!(nav.step(&inc).is_ok());
                // A garbage value now and then is refused and changes nothing.
                if junk.rotate_left(i as u32) & 7 == 0 {
                    let before = *nav.state();
                    let bad = ImuIncrement::new([f32::NAN, 0.0, 0.0], [0.0; 3], dt);
                    prop_assert!(nav.step(&bad).is_err());
                    prop_assert_eq!(nav.state(), &before);
                }
            }
            let s = nav.state();
            prop_assert!(s.v_eb_n.iter().all(|x| x.is_finite()));
            prop_assert!((s.q_b_n.norm() - 1.0).abs() < 1e-5);
            prop_assert!(s.position.lat_f64().is_finite() && s.position.h_f64().is_finite());
        }
    }
}
