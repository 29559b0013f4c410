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
    /// What the clipped samples in the interval could have missed.
    pub clipped: ClipDoubt<T>,
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

/// The sensor axes a sample's driver found at full scale ([`AidedMechanization::step_clipped`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Clipped {
    /// A gyro axis read its full scale: the rate beyond it is not in the increment.
    pub gyro: bool,
    /// An accelerometer axis read its full scale.
    pub accel: bool,
}

/// The variances clipped samples add, per body axis ([`AidedMechanization::step_clipped`]),
/// to add to the covariance turned into the navigation frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipDoubt<T: Scalar> {
    /// Attitude variance per body axis [rad^2].
    pub attitude_var_b_rad2: Vector3<T>,
    /// Velocity variance per body axis [m^2/s^2].
    pub velocity_var_b_m2_s2: Vector3<T>,
}

impl<T: Scalar> ClipDoubt<T> {
    /// No clipped sample.
    pub fn none() -> Self {
        Self {
            attitude_var_b_rad2: Vector3::zeros(),
            velocity_var_b_m2_s2: Vector3::zeros(),
        }
    }

    /// True when a clipped sample left a doubt.
    pub fn any(&self) -> bool {
        self.attitude_var_b_rad2.iter().any(|v| *v > T::zero())
            || self.velocity_var_b_m2_s2.iter().any(|v| *v > T::zero())
    }
}

/// Largest velocity doubt a run of clipped samples adds per axis [m/s]: beyond any vehicle's
/// speed.
const MAX_CLIP_RUN_MPS: f64 = 1e4;

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
    acc_clipped: ClipDoubt<T>,
    /// The current run of clipped samples (`None`: the last sample was not clipped), per body
    /// axis: `sum |increment|` of the gyro's [rad] and the accelerometer's [m/s].
    clip_run: Option<[Vector3<T>; 2]>,
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
            acc_clipped: ClipDoubt::none(),
            clip_run: None,
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
        self.step_clipped(inc, Clipped::default())
    }

    /// [`Self::step`] for a sample whose driver found an axis at full scale (`clipped`). The
    /// rate or specific force beyond the range is not in the increment, and no model knows
    /// it: the doubt taken is that the true value was up to twice the range, as 1-sigma
    /// (3 sigma: four times), i.e. the clipped reading again, `|increment|` per body axis and
    /// sample (the driver's axes are the body's unless mounted otherwise: then the reading
    /// spreads over the body axes it turns into). The excess keeps its sign over a run of
    /// clipped samples, so the run's doubts add as 1-sigma, not as variances: the run's
    /// variance is `(sum |increment|)^2` per axis (the attitude's at most
    /// [`MAX_ATTITUDE_VAR_RAD2`], beyond which the linear error model says nothing more). It
    /// joins the propagation interval ([`ClipDoubt`]), turned into the navigation frame there.
    pub fn step_clipped(
        &mut self,
        inc: &ImuIncrement<T>,
        clipped: Clipped,
    ) -> Result<Events<T>, InputError> {
        let dt = inc.dt;
        let v_before = self.nav.state().v_eb_n;
        let comp = self.integrate(inc)?;
        let clip_run_edge = self.add_clip_doubt(inc, clipped);
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
        // NAV for up to an interval). So is a run of clipped samples as it begins and ends: the
        // rows from its first sample on carry its doubt.
        let due =
            self.acc_dt >= self.interval_s || self.acc_bridged.lost.is_some() || clip_run_edge;
        let propagation = if still.is_none() && due {
            self.flush()
        } else {
            None
        };
        Ok(Events { propagation, still })
    }

    /// The variance a clipped sample adds ([`Self::step_clipped`]); a sample not clipped ends
    /// its sensor's run. True when a run began or ended at this sample.
    fn add_clip_doubt(&mut self, inc: &ImuIncrement<T>, clipped: Clipped) -> bool {
        if clipped == Clipped::default() {
            return self.clip_run.take().is_some();
        }
        let began = self.clip_run.is_none();
        let runs = self.clip_run.get_or_insert([Vector3::zeros(); 2]);
        let max_theta = T::c(MAX_ATTITUDE_VAR_RAD2).sqrt();
        let sensors = [
            (clipped.gyro, &inc.delta_theta_ib_b, max_theta),
            (clipped.accel, &inc.delta_v_ib_b, T::c(MAX_CLIP_RUN_MPS)),
        ];
        let doubts = [
            &mut self.acc_clipped.attitude_var_b_rad2,
            &mut self.acc_clipped.velocity_var_b_m2_s2,
        ];
        for (((on, d, max), run), var) in sensors.into_iter().zip(runs).zip(doubts) {
            if !on {
                *run = Vector3::zeros();
                continue;
            }
            for k in 0..3 {
                // The run's variance grows from `before^2` to `after^2`.
                let before = run[k];
                let after = (before + d[k].abs()).min(max);
                run[k] = after;
                var[k] += after * after - before * before;
            }
        }
        began
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
            clipped: core::mem::replace(&mut self.acc_clipped, ClipDoubt::none()),
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

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::ins_filter::model::tests::noise;
    use crate::ins_filter::{ErrorFilter, InitialSigma};
    use crate::{Position, attitude};
    use std::vec;
    use std::vec::Vec;

    const DT: f64 = 0.0025;

    /// A car at 10 m/s, level at heading 30 deg (`rolled`: on its side, rolled 90 deg).
    fn car(rolled: bool) -> NavState<f64> {
        let roll = if rolled { 90f64.to_radians() } else { 0.0 };
        NavState {
            q_b_n: attitude::from_euler(roll, 0.0, 30f64.to_radians()),
            v_eb_n: Vector3::new(10.0, 0.0, 0.0),
            position: Position::from_radians(0.8, 0.1, 100.0),
        }
    }

    /// A sample turning about the body's z axis at `rate` [rad/s], the specific force 1 g
    /// along its z axis.
    fn yawing(rate: f64) -> ImuIncrement<f64> {
        ImuIncrement::new([0.0, 0.0, rate * DT], [0.0, 0.0, -9.8 * DT], DT)
    }

    /// The attitude variance [rad^2] per navigation axis that `samples` (each with its
    /// clipped flags) add beyond the same samples unflagged, through the covariance of a
    /// filter started on `state`; and the sum of the propagations' body-axis doubts.
    fn doubt_added(
        state: NavState<f64>,
        samples: &[(ImuIncrement<f64>, Clipped)],
    ) -> (Vector3<f64>, ClipDoubt<f64>) {
        let config = FilterConfig::new(noise());
        let mut mech = AidedMechanization::new(state, SensorErrors::default(), &config).unwrap();
        let sigma = InitialSigma::new(
            Vector3::repeat(0.1),
            Vector3::repeat(0.01),
            Vector3::repeat(1e-3),
            &config.start_sensor_sigma(),
        );
        let mut filter = ErrorFilter::new(&sigma, state.euler().2, config).unwrap();
        let mut twin = filter.clone();
        let mut total = ClipDoubt::none();
        for (inc, clipped) in samples {
            let Some(p) = mech.step_clipped(inc, *clipped).unwrap().propagation else {
                continue;
            };
            total.attitude_var_b_rad2 += p.clipped.attitude_var_b_rad2;
            total.velocity_var_b_m2_s2 += p.clipped.velocity_var_b_m2_s2;
            filter.propagate(&p);
            twin.propagate(&Propagation {
                clipped: ClipDoubt::none(),
                ..p
            });
        }
        let var = |f: &ErrorFilter<f64>| f.sigma(ATT).map(|s| s * s);
        (var(&filter) - var(&twin), total)
    }

    /// Five yaw-gyro samples clipped at 500 deg/s (a 1000 deg/s burst on a +-500 deg/s part
    /// misses 6.25 deg): the run's doubt is its summed reading as one 1-sigma, `(5 a)^2` in
    /// the body's z axis, not `5 a^2`; it reaches the covariance as the run begins and as it
    /// ends (not up to a propagation interval later), in the navigation axis the body's z
    /// axis lies along: down for a level car, horizontal for one on its side. A sample not
    /// flagged adds nothing, and a run's attitude doubt stops at 1 rad.
    #[test]
    fn a_clipped_run_doubts_its_summed_reading_about_its_axis() {
        let rate = 500f64.to_radians();
        let gyro = Clipped {
            gyro: true,
            accel: false,
        };
        let mut burst = vec![(yawing(0.0), Clipped::default()); 8];
        burst.extend([(yawing(rate), gyro); 5]);
        burst.push((yawing(0.0), Clipped::default()));
        let run = (5.0 * rate * DT).powi(2);
        let config = FilterConfig::new(noise());
        let mut mech = AidedMechanization::new(car(false), SensorErrors::default(), &config);
        let mech = mech.as_mut().unwrap();
        let flushed = |e: Events<f64>| e.propagation.map(|p| p.clipped.attitude_var_b_rad2.z);
        for (k, (inc, clipped)) in burst.iter().enumerate() {
            let first = (rate * DT).powi(2);
            let want = match k {
                8 => Some(first),
                9..=12 => None,
                13 => Some(run - first),
                _ => None,
            };
            let got = flushed(mech.step_clipped(inc, *clipped).unwrap());
            assert_eq!(
                got.map(|v| (v * 1e12).round()),
                want.map(|v| (v * 1e12).round())
            );
        }
        let (added, total) = doubt_added(car(false), &burst);
        assert!(
            (total.attitude_var_b_rad2.z - run).abs() < 1e-12 * run,
            "{total:?}"
        );
        assert_eq!(total.attitude_var_b_rad2.xy(), nalgebra::Vector2::zeros());
        assert_eq!(total.velocity_var_b_m2_s2, Vector3::zeros());
        assert!((added.z - run).abs() < 1e-3 * run, "{added}");
        assert!(added.xy().amax() < 1e-6 * run, "{added}");
        // On its side, the body's z axis is horizontal: the doubt is in the level, not in
        // the heading.
        let (added, _) = doubt_added(car(true), &burst);
        assert!((added.x + added.y - run).abs() < 1e-3 * run, "{added}");
        assert!(added.z.abs() < 1e-6 * run, "{added}");
        // Unflagged, the same samples add nothing.
        let plain: Vec<_> = burst
            .iter()
            .map(|(i, _)| (*i, Clipped::default()))
            .collect();
        let (added, total) = doubt_added(car(false), &plain);
        assert_eq!((added, total.any()), (Vector3::zeros(), false));
        // A clipped accelerometer doubts the velocity the same way.
        let accel = Clipped {
            gyro: false,
            accel: true,
        };
        let mut bump = vec![(yawing(0.0), accel); 4];
        bump.push((yawing(0.0), Clipped::default()));
        let (_, total) = doubt_added(car(false), &bump);
        let v = (4.0 * 9.8 * DT).powi(2);
        assert!(
            (total.velocity_var_b_m2_s2.z - v).abs() < 1e-9 * v,
            "{total:?}"
        );
        // Two seconds clipped at 2000 deg/s: 17 rad of reading, 1 rad of doubt.
        let mut long = vec![(yawing(4.0 * rate), gyro); 800];
        long.push((yawing(0.0), Clipped::default()));
        let (_, total) = doubt_added(car(false), &long);
        assert!((total.attitude_var_b_rad2.z - MAX_ATTITUDE_VAR_RAD2).abs() < 1e-9);
    }
}
