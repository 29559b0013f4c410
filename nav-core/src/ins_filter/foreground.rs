//! The filter's foreground half, run on every IMU sample: the sensor compensation with the
//! estimated errors, the mechanization, the increments accumulated for the next covariance
//! propagation, the stop detector, and the corrections the background sends back.

use super::background::{Correction, Snapshot};
use super::model::Linearisation;
use super::stationarity::{Stationarity, StillWindow, Uncertainty};
use super::{ATT, BA, BG, FilterConfig, FilterError, POS, SA, SG, SensorErrors, VEL};
use crate::attitude::rotation_vector_quat;
use crate::earth::LocalEarth;
use crate::gap::{GapDynamics, ImuGap, MAX_ATTITUDE_VAR_RAD2};
use crate::{ImuIncrement, InputError, MechanizationConfig, NavFrame, NavState, Scalar, Strapdown};
use nalgebra::Vector3;

/// A covariance propagation's inputs: the linearisation point and the interval [s].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Propagation<T: Scalar> {
    /// The state at the interval's end and the interval's mean sensor outputs.
    pub lin: Linearisation<T>,
    /// The interval [s].
    pub dt: T,
    /// The gaps in the IMU data the interval bridged.
    pub bridged: Bridged<T>,
}

/// What the gaps bridged in a propagation interval leave ([`crate::gap`]): the variances the
/// interpolated rates cannot know, to add to the covariance over the interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bridged<T: Scalar> {
    /// Attitude variance per axis [rad^2] ([`GapDynamics::variances`]).
    pub attitude_var_rad2: T,
    /// Velocity variance per axis [m^2/s^2].
    pub velocity_var_m2_s2: T,
    /// A gap too long to bridge: the solution is lost.
    pub lost: Option<LostGap<T>>,
}

/// A gap too long to bridge ([`crate::gap::MAX_BRIDGED_S`]): the position was carried across
/// it at the velocity before it (dead reckoning; the velocity and attitude held), and what
/// that cannot know joins the covariance at once ([`GapDynamics::variances`] over the whole
/// gap: an unknown constant acceleration and rate).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LostGap<T: Scalar> {
    /// The gap [s].
    pub lost_s: T,
    /// Attitude variance per axis [rad^2].
    pub attitude_var_rad2: T,
    /// Velocity variance per axis [m^2/s^2].
    pub velocity_var_m2_s2: T,
}

impl<T: Scalar> Bridged<T> {
    /// No gap.
    pub fn none() -> Self {
        Self {
            attitude_var_rad2: T::zero(),
            velocity_var_m2_s2: T::zero(),
            lost: None,
        }
    }
}

/// What one sample asks of the background.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Events<T: Scalar> {
    /// A propagation interval is full.
    pub propagation: Option<Propagation<T>>,
    /// A still window ended (zero-velocity and zero-rate updates due; the partial propagation
    /// interval is to be flushed first).
    pub still: Option<StillWindow<T>>,
}

/// The foreground half (module docs).
#[derive(Clone, Debug)]
pub struct AidedMechanization<T: Scalar> {
    nav: Strapdown<T>,
    sensors: SensorErrors<T>,
    interval_s: T,
    arw: T,
    vrw: T,
    acc_theta: Vector3<T>,
    acc_v: Vector3<T>,
    acc_dt: T,
    acc_bridged: Bridged<T>,
    gap_dynamics: GapDynamics<T>,
    current: Current<T>,
    detector: Option<Stationarity<T>>,
}

/// A [`Snapshot`] of the current sample without its Earth quantities: those follow from the
/// state ([`local_earth`]) and are computed where they are used (a snapshot handed out, a
/// propagation, a stop window's end), not at every sample.
#[derive(Clone, Copy, Debug)]
struct Current<T: Scalar> {
    state: NavState<T>,
    omega_ib_b: Vector3<T>,
    a_eb_n: Vector3<T>,
}

fn local_earth<T: Scalar>(st: &NavState<T>) -> LocalEarth<T> {
    let c_n = st.position.vertical_row::<T>();
    LocalEarth::from_sin_lat(-c_n.z, c_n.x * c_n.x + c_n.y * c_n.y, st.position.h::<T>())
}

impl<T: Scalar> AidedMechanization<T> {
    /// Starts from `state` with `sensors` compensated; the settings of `config`.
    pub fn new(
        state: NavState<T>,
        sensors: SensorErrors<T>,
        config: &FilterConfig<T>,
    ) -> Result<Self, FilterError> {
        let dt = config.propagation_interval_s;
        if !(dt.finite() && dt > T::zero() && dt <= T::one()) {
            return Err(FilterError::BadInterval);
        }
        let state_finite = state.v_eb_n.iter().all(|v| v.finite())
            && state.q_b_n.coords.iter().all(|v| v.finite());
        if !(state_finite && sensors.is_finite()) {
            return Err(FilterError::BadState);
        }
        if let Some(why) = super::limits::sensor_errors_out_of_range(&sensors) {
            return Err(FilterError::BadSensorErrors(why));
        }
        let mechanization = MechanizationConfig {
            frame: NavFrame::Ned,
            ..config.mechanization
        };
        let nav = Strapdown::new(state, mechanization);
        let st = *nav.state();
        Ok(Self {
            nav,
            sensors,
            interval_s: dt,
            arw: config.noise.arw_rad_per_sqrt_s,
            vrw: config.noise.vrw_mps_per_sqrt_s,
            acc_theta: Vector3::zeros(),
            acc_v: Vector3::zeros(),
            acc_dt: T::zero(),
            acc_bridged: Bridged::none(),
            gap_dynamics: config.gap_dynamics,
            current: Current {
                state: st,
                omega_ib_b: Vector3::zeros(),
                a_eb_n: Vector3::zeros(),
            },
            detector: config.zero_motion.map(|z| Stationarity::new(z.detector)),
        })
    }

    /// The navigation solution.
    pub fn state(&self) -> &NavState<T> {
        self.nav.state()
    }

    /// The mechanization.
    pub fn strapdown(&self) -> &Strapdown<T> {
        &self.nav
    }

    /// The sensor errors compensated.
    pub fn sensor_errors(&self) -> &SensorErrors<T> {
        &self.sensors
    }

    /// What the background's updates need of the current sample.
    pub fn snapshot(&self) -> Snapshot<T> {
        let c = &self.current;
        Snapshot {
            state: c.state,
            earth: local_earth(&c.state),
            omega_ib_b: c.omega_ib_b,
            a_eb_n: c.a_eb_n,
        }
    }

    /// The local gravity at the current state [m/s^2].
    pub fn gravity(&self) -> T {
        local_earth(&self.current.state).g
    }

    /// The current sample's compensated rate `omega_ib_b` [rad/s].
    pub(crate) fn omega_ib_b(&self) -> &Vector3<T> {
        &self.current.omega_ib_b
    }

    /// True while the stop detector sees the vehicle still.
    pub fn is_still(&self) -> bool {
        self.detector.as_ref().is_some_and(|d| d.is_still())
    }

    /// Gives the stop detector the filter's uncertainty ([`Uncertainty`]); every correction
    /// brings the current one, a start the initial 1-sigmas.
    pub fn allow_for(&mut self, u: Uncertainty<T>) {
        if let Some(d) = &mut self.detector {
            d.allow_for(u);
        }
    }

    /// Forgets the previous increment after a gap in the data.
    pub fn restart_increments(&mut self) {
        self.nav.restart_increments();
        if let Some(d) = &mut self.detector {
            d.restart();
        }
    }

    /// Integrates the time lost before the next sample ([`crate::gap`]): the mean rates
    /// either side, compensated as every sample, in short steps; the variances the bridge
    /// cannot know join the current propagation interval ([`Bridged`]). A gap too long to
    /// bridge is not integrated: the position is carried across it at the last velocity, and
    /// the interval is marked lost with what that cannot know ([`LostGap`]). Call before that
    /// sample's [`Self::step`].
    pub fn bridge(&mut self, gap: &ImuGap<T>) {
        self.restart_increments();
        let (att, vel) = self.gap_dynamics.variances(gap);
        if gap.bridged() {
            gap.integrate(|inc| self.integrate(inc).map(|_| ()));
            let b = &mut self.acc_bridged;
            b.attitude_var_rad2 += att;
            b.velocity_var_m2_s2 += vel;
            return;
        }
        let mut st = *self.nav.state();
        let d_r_n = st.v_eb_n * gap.lost_s;
        st.position =
            st.position
                .offset_ned([d_r_n.x.to_f64(), d_r_n.y.to_f64(), d_r_n.z.to_f64()]);
        self.nav.set_state(st);
        let lost = self.acc_bridged.lost.get_or_insert(LostGap {
            lost_s: T::zero(),
            attitude_var_rad2: T::zero(),
            velocity_var_m2_s2: T::zero(),
        });
        lost.lost_s += gap.lost_s;
        lost.attitude_var_rad2 = (lost.attitude_var_rad2 + att).min(T::c(MAX_ATTITUDE_VAR_RAD2));
        lost.velocity_var_m2_s2 += vel;
    }

    /// Compensates and integrates one increment and accumulates it for the propagation;
    /// returns the compensated increment.
    fn integrate(&mut self, inc: &ImuIncrement<T>) -> Result<ImuIncrement<T>, InputError> {
        let dt = inc.dt;
        let comp = self.sensors.compensate(inc);
        self.nav.step(&comp)?;
        self.acc_theta += comp.delta_theta_ib_b;
        self.acc_v += comp.delta_v_ib_b;
        self.acc_dt += dt;
        Ok(comp)
    }

    /// Integrates one increment, compensated with the estimated sensor errors (`true =
    /// (measured - b dt) / (1 + s)`); a refused increment leaves everything unchanged.
    pub fn step(&mut self, inc: &ImuIncrement<T>) -> Result<Events<T>, InputError> {
        let dt = inc.dt;
        let v_before = self.nav.state().v_eb_n;
        let comp = self.integrate(inc)?;
        let st = *self.nav.state();
        self.current = Current {
            state: st,
            omega_ib_b: comp.delta_theta_ib_b / dt,
            a_eb_n: (st.v_eb_n - v_before) / dt,
        };
        let still = match &mut self.detector {
            Some(det) => det.add_with_gravity(
                &self.current.omega_ib_b,
                &(comp.delta_v_ib_b / dt),
                &self.current.state.q_b_n,
                dt,
                || local_earth(&st).g,
                self.arw,
                self.vrw,
            ),
            None => None,
        };
        // A stop's updates flush the interval themselves (Events::still). A lost gap is
        // flushed at once: the filter's status says so from the first sample after it (it said
        // NAV for up to an interval).
        let due = self.acc_dt >= self.interval_s || self.acc_bridged.lost.is_some();
        let propagation = if still.is_none() && due {
            self.flush()
        } else {
            None
        };
        Ok(Events { propagation, still })
    }

    /// The propagation of the increments accumulated so far (`None` when there are none).
    pub fn flush(&mut self) -> Option<Propagation<T>> {
        if self.acc_dt <= T::zero() {
            return None;
        }
        let st = &self.current.state;
        let p = Propagation {
            lin: Linearisation {
                earth: local_earth(st),
                v_eb_n: st.v_eb_n,
                c_b_n: st.q_b_n.to_rotation_matrix().into_inner(),
                f_ib_b: self.acc_v / self.acc_dt,
                omega_ib_b: self.acc_theta / self.acc_dt,
            },
            dt: self.acc_dt,
            bridged: core::mem::replace(&mut self.acc_bridged, Bridged::none()),
        };
        self.acc_theta = Vector3::zeros();
        self.acc_v = Vector3::zeros();
        self.acc_dt = T::zero();
        Some(p)
    }

    /// Applies the background's estimate (closed loop): position, velocity and attitude into
    /// the mechanization, sensor errors into the compensation [Groves, §14.1.1]. The estimate
    /// was made at a snapshot of an earlier sample when the halves run in separate tasks; its
    /// errors change at the INS error dynamics' rates (hours), so it holds for the current one.
    pub fn apply(&mut self, c: &Correction<T>) {
        let x = &c.x;
        let mut st = *self.nav.state();
        let dr = x.fixed_rows::<3>(POS);
        st.position = st
            .position
            .offset_ned([-dr.x.to_f64(), -dr.y.to_f64(), -dr.z.to_f64()]);
        st.v_eb_n -= x.fixed_rows::<3>(VEL);
        let phi: Vector3<T> = x.fixed_rows::<3>(ATT).into();
        st.q_b_n = rotation_vector_quat(&phi) * st.q_b_n;
        let s = &mut self.sensors;
        s.gyro_bias_rad_s += x.fixed_rows::<3>(BG);
        s.accel_bias_mps2 += x.fixed_rows::<3>(BA);
        s.gyro_scale += x.fixed_rows::<3>(SG);
        s.accel_scale += x.fixed_rows::<3>(SA);
        self.nav.set_state(st);
        self.current.state = *self.nav.state();
        self.allow_for(c.uncertainty);
    }
}
