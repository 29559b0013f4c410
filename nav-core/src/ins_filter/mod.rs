//! The navigation filter: a closed-loop error-state Kalman filter on the strapdown solution,
//! aided by GNSS position and velocity, zero-velocity and zero-angular-rate updates.
//!
//! - [`states`]: the 21 error states and their named offsets;
//! - [`model`]: the INS error equations (the process model) and their discretisation;
//! - [`covariance`]: the covariance propagation over the transition matrix's blocks;
//! - [`consider`]: the sensor errors carried as Schmidt consider states (cross-coupling,
//!   g-sensitivity, the gyros' bias instability);
//! - [`aiding`]: the measurements, their outcomes and counters;
//! - [`integrity`]: the windowed innovation test and the refusal of a consistent cluster of
//!   wrong position fixes;
//! - [`latency`]: a GNSS receiver's unstated output latency, found from windows of fixes;
//! - [`coast`]: the solution against where it would be had it coasted on its sensors since an
//!   anchor (a slow fault the fixes pulled it along);
//! - [`limits`]: the range of the noise figures and initial 1-sigmas any IMU can have;
//! - [`stationarity`]: the IMU-only stop detector;
//! - [`motion`]: the start in motion from GNSS (level from the accelerometers, heading from the
//!   GNSS track).
//!
//! [`AidedIns`] owns the mechanization ([`Strapdown`], NED frame) and the covariance. Every
//! IMU sample is compensated with the estimated sensor errors and integrated at its own rate;
//! the increments are accumulated and the covariance propagated every
//! [`FilterConfig::propagation_interval_s`]; before each update the covariance is brought up to
//! the current sample. Updates are Joseph-form scalar updates in sequence
//! ([`crate::alignment::fine::kalman::update_scalar`], [Groves, eq. 3.58]) after a chi-square
//! gate on the whole measurement vector; the estimate is fed back at once (position, velocity,
//! attitude into the mechanization, sensor errors into the compensation) and the error state
//! reset to zero [Groves, §14.1.1, closed-loop correction].
//!
//! Time tags: a fix taken between two IMU samples is applied at the first sample after it,
//! its prediction moved back by the lag `t_sample - t_fix` along the solution's velocity (and,
//! for a velocity fix, its acceleration): at 400 Hz the lag is below 2.5 ms, and the neglected
//! second-order terms (`a lag^2 / 2`) below 3 um at 1 g.

pub mod aiding;
pub mod background;
pub mod coast;
pub mod consider;
pub mod covariance;
pub mod foreground;
pub mod integrity;
pub mod latency;
pub mod limits;
pub mod model;
pub mod motion;
pub mod noise_scale;
pub mod restart;
pub mod sequencer;
pub mod span_fit;
pub mod states;
pub mod stationarity;

use crate::gap::{GapDynamics, ImuGap};
use crate::{ImuIncrement, InputError, MechanizationConfig, NavState, Scalar, Strapdown};
pub use aiding::{
    AidCounters, AidResult, CHI2_3DOF_999, FilterCounters, GnssPosition, GnssVelocity,
};
pub use background::{Correction, ErrorFilter, Snapshot};
pub use consider::GnssCorrelatedError;
pub use foreground::{
    AidedMechanization, Bridged, ClipDoubt, Clipped, Events, LostGap, Propagation,
};
use model::FilterNoise;
use nalgebra::{Matrix3, Vector3};
use restart::Restart;
pub use states::{ATT, BA, BG, Covariance, InitialSigma, N, POS, SA, SG, StateVector, VEL};
use stationarity::StationarityConfig;

/// Zero-velocity and zero-angular-rate updates at stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZeroMotionConfig<T: Scalar> {
    /// The stop detector.
    pub detector: StationarityConfig<T>,
    /// 1-sigma of the zero velocity (residual motion of a stopped vehicle) [m/s].
    pub velocity_sigma_m_s: T,
    /// 1-sigma of the zero rate beyond the window mean's white noise [rad/s].
    pub rate_sigma_rad_s: T,
    /// Largest solution speed at which a stop is believed [m/s], and largest horizontal
    /// velocity 1-sigma per axis: a vehicle cruising straight at constant speed looks still
    /// to the IMU, and once the velocity's 1-sigma has grown (a GNSS outage, a gap in the IMU
    /// data) the chi-square gate alone would let such a ZUPT in.
    pub max_speed_m_s: T,
}

impl<T: Scalar> Default for ZeroMotionConfig<T> {
    /// Default detector, 0.02 m/s, 0.01 deg/s, stops believed below 1 m/s.
    fn default() -> Self {
        Self {
            detector: StationarityConfig::default(),
            velocity_sigma_m_s: T::c(0.02),
            rate_sigma_rad_s: T::c(0.01f64.to_radians()),
            max_speed_m_s: T::c(1.0),
        }
    }
}

/// The filter's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterConfig<T: Scalar> {
    /// The IMU's noise and sensor-error model.
    pub noise: FilterNoise<T>,
    /// 1-sigma of the sensor errors at the start, per axis (gyro bias [rad/s], accelerometer
    /// bias [m/s^2], scale factors [-]), when they are not [`Self::noise`]'s Gauss–Markov
    /// 1-sigmas (`None`: they are). A grade's turn-on bias is a constant of the run and its
    /// in-run drift far smaller: one figure for both drives the bias between fixes as if the
    /// turn-on spread re-drew itself every correlation time.
    pub sensor_sigma: Option<SensorErrors<T>>,
    /// Model the scale factors (21 states) or not (15 states used, the rest held at zero).
    pub scale_factors: bool,
    /// Interval between covariance propagations [s] (the mechanization runs on every sample).
    pub propagation_interval_s: T,
    /// The GNSS antenna's position from the IMU, body forward, right, down [m].
    pub antenna_lever_arm_b_m: Vector3<T>,
    /// The receiver's time-correlated position error, a consider state of the position fixes
    /// ([`consider`]; `None`: the fixes' errors are white, as an RTK receiver's nearly are).
    pub gnss_correlated_error: Option<GnssCorrelatedError<T>>,
    /// Chi-square gate of a 3-component measurement [-] (default [`CHI2_3DOF_999`]).
    pub gate_nis: T,
    /// Consecutive position rejections after which the filter reports itself degraded (and
    /// after which the recovery rules of [`integrity`] apply).
    pub rejections_to_degrade: u32,
    /// Time from the first to the last of the position fixes refused in a row after which
    /// the filter reports itself degraded, however few they are [s]: at 1 Hz the count
    /// alone left it NAV for 100 s of refusals (a given start's heading 90 deg off under a
    /// declared 0.1 deg: 1.3 km off, NAV).
    pub refused_time_to_degrade_s: T,
    /// Horizontal position 1-sigma above which the filter reports itself degraded [m].
    pub max_horizontal_sigma_m: T,
    /// Zero-velocity and zero-rate updates (`None`: off).
    pub zero_motion: Option<ZeroMotionConfig<T>>,
    /// The mechanization's options (its frame is always NED here).
    pub mechanization: MechanizationConfig<T>,
    /// The motion a bridged gap in the IMU data may hide ([`crate::gap`]).
    pub gap_dynamics: GapDynamics<T>,
}

impl<T: Scalar> FilterConfig<T> {
    /// Defaults around `noise`: scale factors on, propagation at 10 Hz, no lever arm, the
    /// 99.9 % gate, degraded after 100 rejections in a row, after refusals in a row over 5 s
    /// or beyond 50 m, ZUPT/ZARU on.
    pub fn new(noise: FilterNoise<T>) -> Self {
        Self {
            noise,
            sensor_sigma: None,
            scale_factors: true,
            propagation_interval_s: T::c(0.1),
            antenna_lever_arm_b_m: Vector3::zeros(),
            gnss_correlated_error: None,
            gate_nis: T::c(CHI2_3DOF_999),
            rejections_to_degrade: 100,
            refused_time_to_degrade_s: T::c(5.0),
            max_horizontal_sigma_m: T::c(50.0),
            zero_motion: Some(ZeroMotionConfig::default()),
            mechanization: MechanizationConfig::default(),
            gap_dynamics: GapDynamics::default(),
        }
    }

    /// The sensor errors' 1-sigma at the start: [`Self::sensor_sigma`], or the noise model's
    /// bias and scale-factor figures.
    pub fn start_sensor_sigma(&self) -> SensorErrors<T> {
        let n = &self.noise;
        self.sensor_sigma.unwrap_or(SensorErrors {
            gyro_bias_rad_s: Vector3::repeat(n.gyro_bias_rad_s),
            accel_bias_mps2: Vector3::repeat(n.accel_bias_mps2),
            gyro_scale: Vector3::repeat(n.gyro_scale),
            accel_scale: Vector3::repeat(n.accel_scale),
        })
    }
}

/// A sensor model whole: the in-run processes apart from the sensor errors' spread at the
/// start, as KF-GINS keeps `imunoise` apart from `init*std` (a data sheet's bias figure holds
/// both: [`FilterConfig::sensor_sigma`] `None`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterModel {
    /// The in-run processes ([`FilterConfig::noise`]).
    pub noise: FilterNoise<f64>,
    /// The sensor errors' 1-sigma at the start ([`FilterConfig::sensor_sigma`]).
    pub start_sigma: SensorErrors<f64>,
}

/// Why a filter cannot start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterError {
    /// A noise figure is negative, not finite or beyond any IMU's, or the correlation time
    /// too short ([`limits`]); the text names it and its range.
    BadNoise(&'static str),
    /// An initial 1-sigma is negative, not finite or beyond its range ([`limits`]); the text
    /// names it and its range.
    BadInitialSigma(&'static str),
    /// The propagation interval is not within (0, 1] s.
    BadInterval,
    /// The initial state or sensor errors are not finite.
    BadState,
    /// A known sensor error at the start is beyond any IMU's ([`limits`]); the text names it
    /// and its range.
    BadSensorErrors(&'static str),
    /// The lever arm is not finite or beyond 100 m.
    BadLeverArm,
    /// The GNSS correlated error's 1-sigma or correlation time is out of range ([`limits`]);
    /// the text names it and its range.
    BadGnssError(&'static str),
}

impl core::fmt::Display for FilterError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BadNoise(why)
            | Self::BadInitialSigma(why)
            | Self::BadSensorErrors(why)
            | Self::BadGnssError(why) => why,
            Self::BadInterval => "the covariance propagation interval must be within (0, 1] s",
            Self::BadState => "the initial state or sensor errors are not finite",
            Self::BadLeverArm => "the antenna lever arm is not finite or beyond 100 m",
        })
    }
}

impl core::error::Error for FilterError {}

/// The sensor errors the filter has estimated and compensates: `true = (measured - b) / (1 + s)`
/// per axis ([Berdinskikh et al., eqs. 3 and 8]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorErrors<T: Scalar> {
    /// Gyro bias [rad/s].
    pub gyro_bias_rad_s: Vector3<T>,
    /// Accelerometer bias [m/s^2].
    pub accel_bias_mps2: Vector3<T>,
    /// Gyro scale-factor error [-].
    pub gyro_scale: Vector3<T>,
    /// Accelerometer scale-factor error [-].
    pub accel_scale: Vector3<T>,
}

impl<T: Scalar> SensorErrors<T> {
    /// These errors in precision `U`.
    pub fn cast<U: Scalar>(&self) -> SensorErrors<U> {
        let c = |v: &Vector3<T>| v.map(|x| U::c(x.to_f64()));
        SensorErrors {
            gyro_bias_rad_s: c(&self.gyro_bias_rad_s),
            accel_bias_mps2: c(&self.accel_bias_mps2),
            gyro_scale: c(&self.gyro_scale),
            accel_scale: c(&self.accel_scale),
        }
    }
}

impl<T: Scalar> Default for SensorErrors<T> {
    fn default() -> Self {
        Self {
            gyro_bias_rad_s: Vector3::zeros(),
            accel_bias_mps2: Vector3::zeros(),
            gyro_scale: Vector3::zeros(),
            accel_scale: Vector3::zeros(),
        }
    }
}

impl<T: Scalar> SensorErrors<T> {
    pub(crate) fn is_finite(&self) -> bool {
        [
            &self.gyro_bias_rad_s,
            &self.accel_bias_mps2,
            &self.gyro_scale,
            &self.accel_scale,
        ]
        .iter()
        .all(|v| v.iter().all(|x| x.finite()))
    }

    /// The increment `inc` compensated: each component less its bias times `dt`, divided by
    /// one plus its scale-factor error.
    #[inline]
    pub fn compensate(&self, inc: &ImuIncrement<T>) -> ImuIncrement<T> {
        let dt = inc.dt;
        ImuIncrement {
            delta_theta_ib_b: Self::apply(
                &inc.delta_theta_ib_b,
                &self.gyro_bias_rad_s,
                &self.gyro_scale,
                dt,
            ),
            delta_v_ib_b: Self::apply(
                &inc.delta_v_ib_b,
                &self.accel_bias_mps2,
                &self.accel_scale,
                dt,
            ),
            dt,
        }
    }

    /// Compensates an increment `measured` [rad or m/s] over `dt` [s].
    #[inline]
    pub(crate) fn apply(
        measured: &Vector3<T>,
        bias: &Vector3<T>,
        scale: &Vector3<T>,
        dt: T,
    ) -> Vector3<T> {
        (measured - bias * dt).component_div(&scale.add_scalar(T::one()))
    }
}

/// The filter's health.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterStatus {
    /// Aided (or free inertial within its limits).
    Nominal,
    /// [`FilterConfig::rejections_to_degrade`] position fixes in a row refused, or refused in
    /// a row over [`FilterConfig::refused_time_to_degrade_s`], or the last fix of an aid
    /// refused as a gross disagreement within that time ([`integrity::SUSPECT_NIS_FACTOR`]),
    /// or the last velocity fixes taken share a bias beyond their covariance
    /// ([`integrity::INCONSISTENT_GATE_FACTOR`]).
    AidingRejected,
    /// Horizontal position 1-sigma above [`FilterConfig::max_horizontal_sigma_m`].
    SigmaAboveLimit,
    /// The covariance lost a positive variance (it has been reset to its diagonal).
    CovarianceFault,
    /// A gap in the IMU data was too long to bridge ([`crate::gap::MAX_BRIDGED_S`]): the
    /// solution is lost for the rest of this filter's run (the sequencer and the navigator's
    /// aided phase re-align in motion on the fixes after it and restart a filter,
    /// [`sequencer`], [`crate::navigator`]).
    ImuLost,
    /// The solution came within [`model::MIN_POLE_DISTANCE_M`] of a pole's axis, or so near
    /// one that the NED frame turned faster than [`model::MAX_NED_FRAME_RATE_RAD_S`]
    /// ([`model::near_pole`]): the filter's NED error model does not hold there, and its
    /// solution and 1-sigma are not trusted for the rest of this filter's run (latched).
    NearPole,
    /// The position fixes lag their time tags (or lead them) beyond what the filter can take
    /// as noise ([`latency`]: an undeclared receiver output latency): from then on each fix
    /// is taken at its tag less the estimate, the covariance widened by what the solution
    /// took from the fixes before, and the reported 1-sigma by the estimate's own 1-sigma
    /// times the velocity and acceleration (it rests on an estimate: not NAV).
    GnssLate,
}

impl FilterStatus {
    /// The name in logs.
    pub fn name(self) -> &'static str {
        match self {
            Self::Nominal => "NAV",
            Self::AidingRejected
            | Self::SigmaAboveLimit
            | Self::CovarianceFault
            | Self::ImuLost
            | Self::NearPole
            | Self::GnssLate => "DEGRADED",
        }
    }
}

/// The closed-loop error-state filter with its mechanization (module docs): the foreground
/// ([`AidedMechanization`]: every sample) and the background ([`ErrorFilter`]: propagation
/// and updates) run in line, in the order the firmware's tasks run them.
#[derive(Clone, Debug)]
pub struct AidedIns<T: Scalar> {
    mech: AidedMechanization<T>,
    filter: ErrorFilter<T>,
}

impl<T: Scalar> AidedIns<T> {
    /// Starts from `state` with sensor errors `sensors` already known (compensated from the
    /// start) and the 1-sigma uncertainties `sigma`.
    pub fn new(
        state: NavState<T>,
        sensors: SensorErrors<T>,
        sigma: &InitialSigma<T>,
        config: FilterConfig<T>,
    ) -> Result<Self, FilterError> {
        let mut mech = AidedMechanization::new(state, sensors, &config)?;
        let yaw = mech.state().euler().2;
        let filter = ErrorFilter::new(sigma, yaw, config)?;
        mech.allow_for(sigma.uncertainty(mech.gravity()));
        Ok(Self { mech, filter })
    }

    /// Starts in motion as `start` says ([`restart`]), in place of `replaced` (`None` at the
    /// run's first start): after a lost gap its sensor estimates and their covariance go on,
    /// after a divergence only its counters.
    pub fn start(
        start: &Restart<T>,
        config: FilterConfig<T>,
        replaced: Option<&AidedIns<T>>,
    ) -> Result<Self, FilterError> {
        let mut mech = AidedMechanization::new(start.state, start.sensors, &config)?;
        let filter = start.filter(
            config,
            replaced.map(|r| &r.filter),
            mech.state(),
            mech.gravity(),
        )?;
        mech.allow_for(filter.uncertainty());
        Ok(Self { mech, filter })
    }

    /// True when the filter diverged beyond what its fixes can bring back
    /// ([`ErrorFilter::diverged`]).
    pub fn diverged(&self) -> bool {
        self.filter.diverged()
    }

    /// The navigation solution (NED frame).
    pub fn state(&self) -> &NavState<T> {
        self.mech.state()
    }

    /// The mechanization.
    pub fn strapdown(&self) -> &Strapdown<T> {
        self.mech.strapdown()
    }

    /// The estimated sensor errors being compensated.
    pub fn sensor_errors(&self) -> &SensorErrors<T> {
        self.mech.sensor_errors()
    }

    /// The filter's own error covariance (at the last propagation or update; the one its gate
    /// uses: the reported position covariance is [`Self::position_covariance`]).
    pub fn covariance(&self) -> &Covariance<T> {
        self.filter.covariance()
    }

    /// The reported position covariance, NED [m^2]
    /// ([`ErrorFilter::position_covariance`]: the filter's own plus the doubt a refused
    /// cluster leaves).
    pub fn position_covariance(&self) -> Matrix3<T> {
        self.filter.position_covariance()
    }

    /// The background half.
    pub fn filter(&self) -> &ErrorFilter<T> {
        &self.filter
    }

    /// The settings.
    pub fn config(&self) -> &FilterConfig<T> {
        self.filter.config()
    }

    /// The aids' counters.
    pub fn counters(&self) -> &FilterCounters {
        self.filter.counters()
    }

    /// The learnt scales of the position and velocity fixes' declared noise variances, now
    /// and their largest ([`ErrorFilter::noise_scales`]).
    pub fn noise_scales(&self) -> [[T; 2]; 2] {
        self.filter.noise_scales()
    }

    /// Times the covariance lost a positive variance and was reset to its diagonal.
    pub fn covariance_faults(&self) -> u32 {
        self.filter.covariance_faults()
    }

    /// 1-sigma of the state's block at `at` (one of the offsets), per axis.
    pub fn sigma(&self, at: usize) -> Vector3<T> {
        self.filter.sigma(at)
    }

    /// 1-sigma of roll, pitch, yaw [rad] ([`ErrorFilter::attitude_sigma_rad`]).
    pub fn attitude_sigma_rad(&self) -> Vector3<T> {
        self.filter.attitude_sigma_rad(&self.state().q_b_n)
    }

    /// The health.
    pub fn status(&self) -> FilterStatus {
        self.filter.status()
    }

    /// The test of the fixes' time tags ([`ErrorFilter::gnss_latency`]).
    pub fn gnss_latency(&self) -> latency::LatencyEstimate<T> {
        self.filter.gnss_latency()
    }

    /// True when the covariance is positive definite ([`ErrorFilter::is_positive_definite`]).
    pub fn covariance_is_positive_definite(&self) -> bool {
        self.filter.is_positive_definite()
    }

    /// Forgets the previous increment after a gap in the data.
    pub fn restart_increments(&mut self) {
        self.mech.restart_increments();
    }

    /// Integrates the time lost before the next sample ([`AidedMechanization::bridge`]).
    pub fn bridge(&mut self, gap: &ImuGap<T>) {
        self.mech.bridge(gap);
    }

    /// Integrates one IMU increment (compensated with the estimated sensor errors), and
    /// propagates the covariance when the interval is full; at a stop, the zero-velocity and
    /// zero-rate updates. A refused increment leaves everything unchanged.
    pub fn step(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        self.step_clipped(inc, Clipped::default())
    }

    /// [`Self::step`] for a sample with axes at full scale
    /// ([`AidedMechanization::step_clipped`]).
    pub fn step_clipped(
        &mut self,
        inc: &ImuIncrement<T>,
        clipped: Clipped,
    ) -> Result<(), InputError> {
        let events = self.mech.step_clipped(inc, clipped)?;
        if let Some(w) = events.still {
            self.propagate();
            let (_, _, c) = self.filter.zero_motion(&self.mech.snapshot(), &w);
            if let Some(c) = c {
                self.mech.apply(&c);
            }
        }
        if let Some(p) = events.propagation {
            self.filter.propagate(&p);
        }
        Ok(())
    }

    /// Brings the covariance up to the current sample (no-op when it is).
    pub fn propagate(&mut self) {
        if let Some(p) = self.mech.flush() {
            self.filter.propagate(&p);
        }
    }

    /// A GNSS position fix of the antenna taken `lag_s` [s] before the current sample
    /// (0 <= lag < one sample interval; module docs). Counted in
    /// [`FilterCounters::position`].
    pub fn aid_position(&mut self, fix: &GnssPosition<T>, lag_s: T) -> AidResult<T> {
        self.propagate();
        let (r, c) = self.filter.position(&self.mech.snapshot(), fix, lag_s);
        if let Some(c) = c {
            self.mech.apply(&c);
        }
        r
    }

    /// A GNSS velocity of the antenna taken `lag_s` [s] before the current sample. Counted in
    /// [`FilterCounters::velocity`].
    pub fn aid_velocity(&mut self, fix: &GnssVelocity<T>, lag_s: T) -> AidResult<T> {
        self.propagate();
        let (r, c) = self.filter.velocity(&self.mech.snapshot(), fix, lag_s);
        if let Some(c) = c {
            self.mech.apply(&c);
        }
        r
    }

    /// True while the stop detector sees the vehicle still.
    pub fn is_still(&self) -> bool {
        self.mech.is_still()
    }

    /// The current sample's compensated rate `omega_ib_b` [rad/s].
    pub fn omega_ib_b(&self) -> &Vector3<T> {
        self.mech.omega_ib_b()
    }
}
