//! The run configuration: everything a run of the navigator is told, as plain data.
//!
//! The host's `nav replay` (clap) and the firmware's argument parser both fill one
//! [`RunConfig`], and [`RunConfig::validate`] and [`Setup::new`](super::Setup::new) check it the
//! same way for both. The options' command-line form (names and value syntax) is here too
//! ([`RunConfig::set`], [`parse_vector3`]), so the two parsers accept the same words.

use crate::alignment::machine::DEFAULT_LEVER_ARM_SIGMA_M;
use crate::alignment::{AlignMethod, BaseMotion, LeverArm, SensorNoise, SettingsError};
use crate::calibration::{CalibrationError, ImuCalibration};
use crate::ins_filter::GnssCorrelatedError;
use crate::ins_filter::limits::{self, MAX_ACCEL_BIAS_MPS2, MAX_GYRO_BIAS_RAD_S};
use crate::ins_filter::model::FilterNoise;
use crate::number::Number;
use crate::poisson::DcmIntegrator;
use crate::scalar::Scalar;
use crate::strapdown::{AttitudeMethod, MechanizationConfig, NavFrame, VerticalChannel};
use core::fmt;

/// Default number of navigation steps between logged solutions (10 Hz at 400 Hz).
pub const DEFAULT_LOG_EVERY: u32 = 40;

/// Whether the GNSS-aided filter is in this build (nav-core's feature `aided`; a small board's
/// firmware without a receiver leaves it out of its flash). The navigator's aided paths test
/// it, so that without the feature they fold away.
pub const AIDED_COMPILED_IN: bool = cfg!(feature = "aided");

/// The selectable parts of the mechanization (nav-core's defaults: wander azimuth, rotation
/// vector, free vertical channel).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MechanizationChoices {
    /// Navigation frame.
    pub frame: NavFrame,
    /// Attitude integration.
    pub attitude: AttitudeMethod,
    /// Vertical channel.
    pub vertical: VerticalChannel,
}

impl Default for MechanizationChoices {
    fn default() -> Self {
        let d = MechanizationConfig::<f64>::default();
        Self {
            frame: d.frame,
            attitude: d.attitude,
            vertical: d.vertical,
        }
    }
}

/// Names of the navigation frames on command lines (`--frame`).
pub const FRAMES: [(&str, NavFrame); 2] =
    [("wander", NavFrame::WanderAzimuth), ("ned", NavFrame::Ned)];

/// Names of the attitude integrators on command lines (`--attitude`).
pub const ATTITUDES: [(&str, AttitudeMethod); 5] = [
    ("rotation-vector", AttitudeMethod::RotationVector),
    ("euler", AttitudeMethod::Poisson(DcmIntegrator::Euler)),
    ("heun", AttitudeMethod::Poisson(DcmIntegrator::Heun)),
    ("rk4", AttitudeMethod::Poisson(DcmIntegrator::Rk4)),
    ("abm4", AttitudeMethod::Poisson(DcmIntegrator::Abm4)),
];

/// Names of the vertical-channel treatments on command lines (`--vertical`).
pub const VERTICALS: [(&str, VerticalChannel); 2] = [
    ("free", VerticalChannel::Free),
    ("hold", VerticalChannel::Hold),
];

/// An IMU's errors beyond its noise and biases ([`SensorNoise`]) that the aided filter models:
/// scale factors as states, cross-axis coupling and g-sensitivity as consider states
/// ([`crate::ins_filter::consider`]). A data sheet's noise table seldom gives them:
/// [`Self::DATASHEET`] stands for what it lacks; a simulator grade gives its own (the
/// grade's error model, `hal_adapters::drivers::noise::grade`). Single precision, as the
/// configuration frame carries them: 1-sigma figures need no more, and a configuration read
/// back from its frame is the one written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorFigures {
    /// Gyro scale-factor 1-sigma per axis [-].
    pub gyro_scale: f32,
    /// Accelerometer scale-factor 1-sigma per axis [-].
    pub accel_scale: f32,
    /// Gyro cross-axis coupling (misalignment) 1-sigma per element [rad].
    pub gyro_cross_coupling_rad: f32,
    /// Accelerometer cross-axis coupling 1-sigma per element [rad].
    pub accel_cross_coupling_rad: f32,
    /// Gyro g-sensitivity 1-sigma per element [rad/s per m/s^2].
    pub gyro_g_sensitivity: f32,
}

impl SensorFigures {
    /// What a data sheet's noise table lacks: [`DEFAULT_SCALE_SIGMA`],
    /// [`DEFAULT_CROSS_COUPLING_RAD`] and [`DEFAULT_G_SENSITIVITY`] (a tactical MEMS part's).
    pub const DATASHEET: Self = Self {
        gyro_scale: DEFAULT_SCALE_SIGMA as f32,
        accel_scale: DEFAULT_SCALE_SIGMA as f32,
        gyro_cross_coupling_rad: DEFAULT_CROSS_COUPLING_RAD as f32,
        accel_cross_coupling_rad: DEFAULT_CROSS_COUPLING_RAD as f32,
        gyro_g_sensitivity: DEFAULT_G_SENSITIVITY as f32,
    };
}

impl Default for SensorFigures {
    /// [`Self::DATASHEET`].
    fn default() -> Self {
        Self::DATASHEET
    }
}

/// The aided filter's noise model of an IMU's noise figures `n` and its other errors
/// `figures`, with [`DEFAULT_CORRELATION_TIME_S`].
pub fn filter_noise_of<T: Scalar>(n: &SensorNoise<f64>, figures: &SensorFigures) -> FilterNoise<T> {
    FilterNoise {
        arw_rad_per_sqrt_s: T::c(n.arw_rad_per_sqrt_s),
        vrw_mps_per_sqrt_s: T::c(n.vrw_mps_per_sqrt_s),
        gyro_bias_rad_s: T::c(n.gyro_bias_rad_s),
        accel_bias_mps2: T::c(n.accel_bias_mps2),
        gyro_scale: T::c(f64::from(figures.gyro_scale)),
        accel_scale: T::c(f64::from(figures.accel_scale)),
        correlation_time_s: T::c(DEFAULT_CORRELATION_TIME_S),
        gyro_cross_coupling_rad: T::c(f64::from(figures.gyro_cross_coupling_rad)),
        accel_cross_coupling_rad: T::c(f64::from(figures.accel_cross_coupling_rad)),
        gyro_g_sensitivity: T::c(f64::from(figures.gyro_g_sensitivity)),
        // A data sheet's noise figures give no correlation time: the bias instability is in
        // the bias figure.
        gyro_bias_instability_rad_s: T::zero(),
        gyro_bias_instability_time_s: T::zero(),
    }
}

/// Default scale-factor 1-sigma of the aided phase's filter [-] (1000 ppm: the noise model
/// has no scale-factor figure).
pub const DEFAULT_SCALE_SIGMA: f64 = 1e-3;
/// Default correlation time of the filter's Gauss–Markov sensor errors [s]: 100 h, far
/// beyond a run. A data sheet's bias figure is mostly a turn-on spread (a constant); the
/// Gauss–Markov drive `2 sigma^2 / tau` lets the estimate wander at `sigma sqrt(2 / tau)`,
/// still far beyond a part's in-run drift (a consumer gyro's 0.5 deg/s: 255 deg/h per
/// sqrt(h)). With KF-GINS's usual 1 h it wandered ten times faster still (0.14 deg/s in
/// 150 s), and on a straight flight the heading walked with the gyro-bias estimate: 25-50
/// deg off against a 16 deg 1-sigma, from a perfect consumer-grade IMU (BMI088, ICM-42688).
pub const DEFAULT_CORRELATION_TIME_S: f64 = 360_000.0;
/// Default cross-axis coupling (misalignment) 1-sigma of gyros and accelerometers [rad]
/// (0.1 deg, what tactical MEMS data sheets give).
pub const DEFAULT_CROSS_COUPLING_RAD: f64 = 1.745e-3;
/// Default gyro g-sensitivity 1-sigma [rad/s per m/s^2] (0.01 deg/s/g).
pub const DEFAULT_G_SENSITIVITY: f64 = 1.78e-5;
/// Default covariance propagation interval of the aided phase [s] (10 Hz).
pub const DEFAULT_PROPAGATION_INTERVAL_S: f64 = 0.1;
/// Default correlation time of the GNSS receiver's correlated position error [s] (a minute:
/// a code receiver's multipath and atmosphere change over tens of seconds to minutes).
pub const DEFAULT_GNSS_CORRELATION_TIME_S: f64 = 60.0;

/// The GNSS-aided navigation after the alignment: the closed-loop error-state filter
/// ([`crate::ins_filter`]) started from the alignment's outcome. Its noise model is the run's
/// ([`RunConfig::filter_noise`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AidingConfig {
    /// The GNSS antenna's position from the IMU, body forward, right, down [m].
    pub antenna_lever_arm_b_m: [f64; 3],
    /// Interval between covariance propagations [s] (within (0, 1]).
    pub propagation_interval_s: f64,
    /// Model the sensors' scale factors (21 states) or not (15).
    pub scale_factors: bool,
    /// Zero-velocity and zero-rate updates at stops (the IMU-only stop detector).
    pub zero_motion: bool,
    /// The GNSS receiver's time-correlated position error (multipath, atmosphere), steady-state
    /// 1-sigma north, east, down [m]: a Gauss–Markov error the filter carries as a consider
    /// state of the position fixes ([`crate::ins_filter::consider`]; `None`: the fixes' errors
    /// are white, as an RTK receiver's nearly are).
    pub gnss_correlated_sigma_ned_m: Option<[f64; 3]>,
    /// Correlation time of that error [s] (within [`limits::GNSS_ERROR_TIME_S`]; checked
    /// even without the error, as every value carried).
    pub gnss_correlated_time_s: f64,
}

impl Default for AidingConfig {
    /// No lever arm, [`DEFAULT_PROPAGATION_INTERVAL_S`], scale factors and stop updates on, no
    /// GNSS correlated error (its time [`DEFAULT_GNSS_CORRELATION_TIME_S`]).
    fn default() -> Self {
        Self {
            antenna_lever_arm_b_m: [0.0; 3],
            propagation_interval_s: DEFAULT_PROPAGATION_INTERVAL_S,
            scale_factors: true,
            zero_motion: true,
            gnss_correlated_sigma_ned_m: None,
            gnss_correlated_time_s: DEFAULT_GNSS_CORRELATION_TIME_S,
        }
    }
}

impl AidingConfig {
    /// The filter's GNSS correlated error in precision `T` (`None` when none is declared).
    pub fn gnss_correlated_error<T: Scalar>(&self) -> Option<GnssCorrelatedError<T>> {
        self.gnss_correlated_sigma_ned_m
            .map(|sigma| self.correlated_error_of(sigma))
    }

    /// The correlated error of 1-sigma `sigma_ned_m` [m] and this correlation time.
    fn correlated_error_of<T: Scalar>(&self, sigma_ned_m: [f64; 3]) -> GnssCorrelatedError<T> {
        GnssCorrelatedError {
            sigma_ned_m: sigma_ned_m.map(T::c).into(),
            correlation_time_s: T::c(self.gnss_correlated_time_s),
        }
    }
}

/// The value called `name` in a name table.
pub fn by_name<V: Copy>(table: &[(&str, V)], name: &str) -> Option<V> {
    table.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
}

/// What a run is told: the site, the alignment, the IMU's noise, the calibration, the
/// mechanization and the logging cadence. Plain data; [`Self::validate`] checks it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunConfig {
    /// Latitude of the site (the base's centre of rotation) [deg].
    pub lat_deg: f64,
    /// Longitude of the site [deg].
    pub lon_deg: f64,
    /// Ellipsoidal height of the site [m].
    pub h_m: f64,
    /// Alignment method.
    pub align_method: AlignMethod,
    /// Length of the alignment window at the start of the data [s].
    pub align_seconds: f64,
    /// The IMU's noise the alignment assumes (white-noise densities and bias 1-sigmas), before
    /// [`Self::bias_prior`] scales its biases.
    pub noise: SensorNoise<f64>,
    /// The IMU's other errors the aided filter models (set with [`Self::noise`]: the same
    /// part's or grade's).
    pub figures: SensorFigures,
    /// Scale of the noise's bias 1-sigmas [-] (1: as given; 0: biases compensated).
    pub bias_prior: f64,
    /// Where the IMU sits relative to the site: known (body FRD [m]) or an unknown prior.
    pub lever_arm: LeverArm<f64>,
    /// What the base itself does (position and translation 1-sigma [m]).
    pub base: BaseMotion<f64>,
    /// Navigation steps between logged solutions (>= 1).
    pub log_every: u32,
    /// Sensor calibration, applied to every increment before alignment and navigation.
    pub calibration: ImuCalibration,
    /// Frame, attitude integrator and vertical channel of the mechanization.
    pub mechanization: MechanizationChoices,
    /// GNSS-aided navigation after the alignment (`None`: free inertial). The aided phase
    /// navigates in the NED frame whatever [`Self::mechanization`]'s frame.
    pub aiding: Option<AidingConfig>,
}

impl RunConfig {
    /// A static alignment of `align_seconds` [s] at the site (`lat_deg`, `lon_deg` [deg],
    /// `h_m` [m]) assuming `noise`, and the defaults for the rest: bias prior 1, an unknown
    /// lever arm of [`DEFAULT_LEVER_ARM_SIGMA_M`], the default base motion, a row every
    /// [`DEFAULT_LOG_EVERY`] steps, no calibration, the default mechanization.
    pub fn new(
        lat_deg: f64,
        lon_deg: f64,
        h_m: f64,
        align_seconds: f64,
        noise: SensorNoise<f64>,
    ) -> Self {
        Self {
            lat_deg,
            lon_deg,
            h_m,
            align_method: AlignMethod::default(),
            align_seconds,
            noise,
            figures: SensorFigures::DATASHEET,
            bias_prior: 1.0,
            lever_arm: LeverArm::Unknown {
                sigma_m: DEFAULT_LEVER_ARM_SIGMA_M,
            },
            base: BaseMotion::default(),
            log_every: DEFAULT_LOG_EVERY,
            calibration: ImuCalibration::default(),
            mechanization: MechanizationChoices::default(),
            aiding: None,
        }
    }

    /// Checks what can be checked without the data's rate: the site, the cadence, the bias
    /// prior and the calibration ([`Setup::new`](super::Setup::new) then checks the alignment
    /// window and values against the rate).
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(-90.0..=90.0).contains(&self.lat_deg) {
            return Err(ConfigError::Latitude(self.lat_deg));
        }
        if !self.lon_deg.is_finite() {
            return Err(ConfigError::NotFinite("the longitude"));
        }
        if !(-180.0..=180.0).contains(&self.lon_deg) {
            return Err(ConfigError::Longitude(self.lon_deg));
        }
        if !self.h_m.is_finite() {
            return Err(ConfigError::NotFinite("the height"));
        }
        if !(MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&self.h_m) {
            return Err(ConfigError::Height(self.h_m));
        }
        if !self.align_seconds.is_finite() {
            return Err(ConfigError::NotFinite("the alignment time"));
        }
        if self.log_every == 0 {
            return Err(ConfigError::LogEvery);
        }
        if !(self.bias_prior.is_finite() && self.bias_prior >= 0.0) {
            return Err(ConfigError::BiasPrior(self.bias_prior));
        }
        // A scale that takes the biases beyond any IMU's (the noise's own are checked as such).
        let scaled = self.align_noise();
        if self.bias_prior > 1.0
            && !(scaled.gyro_bias_rad_s <= MAX_GYRO_BIAS_RAD_S
                && scaled.accel_bias_mps2 <= MAX_ACCEL_BIAS_MPS2)
        {
            return Err(ConfigError::BiasPrior(self.bias_prior));
        }
        // In f64, before the run's precision: 1e100 m is infinite in f32.
        crate::alignment::machine::check_geometry(&self.lever_arm, &self.base)
            .map_err(ConfigError::Alignment)?;
        self.calibration
            .compensation::<f64>()
            .map_err(ConfigError::Calibration)?;
        // The aided filter's figures, checked with or without aiding: a frame carries them,
        // and a value out of range is refused, not carried as valid until aiding is on.
        let f = &self.figures;
        if let Some(why) = limits::figures_out_of_range(
            [f.gyro_scale, f.accel_scale],
            [
                f.gyro_cross_coupling_rad,
                f.accel_cross_coupling_rad,
                f.gyro_g_sensitivity,
            ],
        ) {
            return Err(ConfigError::Aiding(why));
        }
        if let Some(a) = &self.aiding {
            if !AIDED_COMPILED_IN {
                return Err(ConfigError::Aiding(
                    "the GNSS-aided filter is not in this build (nav-core feature `aided`)",
                ));
            }
            let interval = a.propagation_interval_s;
            if !(interval.is_finite() && interval > 0.0 && interval <= 1.0) {
                return Err(ConfigError::Aiding(
                    "the covariance propagation interval must be within (0, 1] s",
                ));
            }
            let l = a.antenna_lever_arm_b_m;
            if !(l.iter().all(|v| v.is_finite()) && l.iter().map(|v| v * v).sum::<f64>() <= 1e4) {
                return Err(ConfigError::Aiding(
                    "the GNSS antenna lever arm must be finite and within 100 m",
                ));
            }
            // The filter's own ranges (its refusal's text), the time also without an error.
            let declared =
                a.correlated_error_of::<f64>(a.gnss_correlated_sigma_ned_m.unwrap_or_default());
            if let Some(why) = limits::gnss_error_out_of_range(&declared) {
                return Err(ConfigError::Aiding(why));
            }
            // A correlation time of no declared error would be silently ignored (the default
            // time given alone cannot be told from no time given).
            if a.gnss_correlated_sigma_ned_m.is_none()
                && a.gnss_correlated_time_s != DEFAULT_GNSS_CORRELATION_TIME_S
            {
                return Err(ConfigError::Aiding(
                    "gnss-correlated-time needs gnss-correlated (the error it is the correlation time of)",
                ));
            }
            let (n, f) = (&self.noise, &self.figures);
            let figures = [
                n.arw_rad_per_sqrt_s,
                n.vrw_mps_per_sqrt_s,
                n.gyro_bias_rad_s,
                n.accel_bias_mps2,
                f64::from(f.gyro_scale),
                f64::from(f.accel_scale),
            ];
            // A zero bias or scale-factor 1-sigma would leave the filter a zero variance (a
            // covariance fault).
            if !figures.iter().all(|v| v.is_finite() && *v > 0.0) {
                return Err(ConfigError::Aiding(
                    "the aided filter needs positive, finite noise, bias and scale-factor figures",
                ));
            }
            if let Some(why) = limits::noise_out_of_range(&self.filter_noise::<f64>()) {
                return Err(ConfigError::Aiding(why));
            }
        }
        Ok(())
    }

    /// The aided filter's noise model ([`FilterNoise`]): the run's white noise and bias
    /// 1-sigmas ([`Self::noise`], not scaled by [`Self::bias_prior`], which is the
    /// alignment's), its other errors ([`Self::figures`]) and [`DEFAULT_CORRELATION_TIME_S`].
    pub fn filter_noise<T: Scalar>(&self) -> FilterNoise<T> {
        filter_noise_of(&self.noise, &self.figures)
    }

    /// The noise the alignment assumes: [`Self::noise`] with its biases scaled by
    /// [`Self::bias_prior`].
    pub fn align_noise(&self) -> SensorNoise<f64> {
        SensorNoise {
            gyro_bias_rad_s: self.noise.gyro_bias_rad_s * self.bias_prior,
            accel_bias_mps2: self.noise.accel_bias_mps2 * self.bias_prior,
            ..self.noise
        }
    }

    /// Sets the option `--name` from its command-line `value`: `align-method NAME`,
    /// `bias-prior K`, `lever-arm X,Y,Z` (known, body FRD [m]), `lever-arm-sigma S` (unknown,
    /// [m] per axis), `log-every N`, `frame NAME`, `attitude NAME`, `vertical NAME`, and for
    /// the aided phase (which they switch on, [`Self::aiding`]) `gnss-lever-arm X,Y,Z` (body
    /// FRD [m]), `propagation-rate HZ`, `gnss-correlated N,E,D` (the receiver's correlated
    /// error's 1-sigma [m], [`AidingConfig::gnss_correlated_sigma_ned_m`]) and
    /// `gnss-correlated-time S` (its correlation time [s]). The values are checked by
    /// [`Self::validate`] and [`Setup::new`](super::Setup::new), not here, beyond their
    /// syntax.
    pub fn set(&mut self, name: &str, value: &str) -> Result<(), OptionError> {
        let bad = |option: &'static str, expected: &'static str| OptionError::Invalid {
            option,
            expected,
        };
        let number = |option, v: &str| {
            v.parse::<f64>()
                .map_err(|_| bad(option, "a number"))
                .and_then(|x| {
                    if x.is_finite() {
                        Ok(x)
                    } else {
                        Err(bad(option, "a finite number"))
                    }
                })
        };
        match name {
            "align-method" => {
                self.align_method = AlignMethod::from_name(value)
                    .ok_or(bad("align-method", "static, inertial, fine or sway"))?;
            }
            "bias-prior" => self.bias_prior = number("bias-prior", value)?,
            "lever-arm" => {
                let r = parse_vector3(value).ok_or(bad("lever-arm", "X,Y,Z (three numbers)"))?;
                self.lever_arm = LeverArm::Known(r.into());
            }
            "lever-arm-sigma" => {
                self.lever_arm = LeverArm::Unknown {
                    sigma_m: number("lever-arm-sigma", value)?,
                };
            }
            "base-translation" => {
                self.base.translation_sigma_m = number("base-translation", value)?;
            }
            "log-every" => {
                self.log_every = value
                    .parse::<u32>()
                    .map_err(|_| bad("log-every", "a whole number"))?;
            }
            "frame" => {
                self.mechanization.frame =
                    by_name(&FRAMES, value).ok_or(bad("frame", "wander or ned"))?;
            }
            "attitude" => {
                self.mechanization.attitude = by_name(&ATTITUDES, value)
                    .ok_or(bad("attitude", "rotation-vector, euler, heun, rk4 or abm4"))?;
            }
            "vertical" => {
                self.mechanization.vertical =
                    by_name(&VERTICALS, value).ok_or(bad("vertical", "free or hold"))?;
            }
            "gnss-lever-arm" => {
                let r =
                    parse_vector3(value).ok_or(bad("gnss-lever-arm", "X,Y,Z (three numbers)"))?;
                self.aiding
                    .get_or_insert_with(AidingConfig::default)
                    .antenna_lever_arm_b_m = r;
            }
            "propagation-rate" => {
                let hz = number("propagation-rate", value)?;
                if !(1.0..=1000.0).contains(&hz) {
                    return Err(bad("propagation-rate", "a rate within 1 to 1000 Hz"));
                }
                self.aiding
                    .get_or_insert_with(AidingConfig::default)
                    .propagation_interval_s = 1.0 / hz;
            }
            "gnss-correlated" => {
                let sigma =
                    parse_vector3(value).ok_or(bad("gnss-correlated", "N,E,D (three numbers)"))?;
                self.aiding
                    .get_or_insert_with(AidingConfig::default)
                    .gnss_correlated_sigma_ned_m = Some(sigma);
            }
            "gnss-correlated-time" => {
                let tau = number("gnss-correlated-time", value)?;
                self.aiding
                    .get_or_insert_with(AidingConfig::default)
                    .gnss_correlated_time_s = tau;
            }
            _ => return Err(OptionError::Unknown),
        }
        Ok(())
    }
}

/// Parses `X,Y,Z`: three finite numbers separated by commas (spaces allowed around them),
/// negative ones as written (`-5.9,0.6,-7.5`).
pub fn parse_vector3(text: &str) -> Option<[f64; 3]> {
    let mut out = [0.0; 3];
    let mut parts = text.split(',');
    for v in &mut out {
        *v = parts.next()?.trim().parse::<f64>().ok()?;
        if !v.is_finite() {
            return None;
        }
    }
    parts.next().is_none().then_some(out)
}

/// Why an option's words were refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OptionError {
    /// Not an option of the run configuration.
    Unknown,
    /// The value does not parse.
    Invalid {
        /// The option's name (without `--`).
        option: &'static str,
        /// What it takes.
        expected: &'static str,
    },
}

impl fmt::Display for OptionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unknown => f.write_str("unknown option"),
            Self::Invalid { option, expected } => write!(f, "--{option} takes {expected}"),
        }
    }
}

impl core::error::Error for OptionError {}

/// Lowest site height accepted [m] (below the deepest ocean trench).
pub const MIN_HEIGHT_M: f64 = -12_000.0;

/// Highest site height accepted [m]: the normal-gravity model's validity, far above aircraft.
pub const MAX_HEIGHT_M: f64 = 100_000.0;

/// Why a run configuration was refused (before any sample).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigError {
    /// The latitude is not within [-90, 90] deg.
    Latitude(f64),
    /// The longitude is not within [-180, 180] deg (refused, not wrapped: 400 is more likely a
    /// typing error than 40).
    Longitude(f64),
    /// The height is not within [`MIN_HEIGHT_M`, `MAX_HEIGHT_M`].
    Height(f64),
    /// A value that must be finite is not (what).
    NotFinite(&'static str),
    /// `log_every` is 0.
    LogEvery,
    /// The bias-prior scale is negative or not finite.
    BiasPrior(f64),
    /// The calibration cannot be inverted.
    Calibration(CalibrationError),
    /// The alignment settings were refused (window shorter than the method's minimum, rate,
    /// site near a pole, noise or lever arm values).
    Alignment(SettingsError),
    /// The aided phase's settings were refused (what).
    Aiding(&'static str),
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Latitude(lat) => {
                write!(f, "latitude {} deg is not within [-90, 90]", Number(*lat))
            }
            Self::Longitude(lon) => {
                write!(
                    f,
                    "longitude {} deg is not within [-180, 180]",
                    Number(*lon)
                )
            }
            Self::Height(h) => write!(
                f,
                "height {} m is not within [{MIN_HEIGHT_M}, {MAX_HEIGHT_M}] m (the Earth model's range)",
                Number(*h)
            ),
            Self::NotFinite(what) => write!(f, "{what} is not a finite number"),
            Self::LogEvery => f.write_str("log_every must be at least 1"),
            Self::BiasPrior(k) => {
                write!(
                    f,
                    "bias prior scale {} must be finite, not negative, and keep the bias \
                     1-sigmas within any IMU's ({MAX_GYRO_BIAS_RAD_S} rad/s, \
                     {MAX_ACCEL_BIAS_MPS2} m/s^2)",
                    Number(*k)
                )
            }
            Self::Calibration(e) => write!(f, "{e}"),
            Self::Alignment(e) => write!(f, "{e}"),
            Self::Aiding(what) => write!(f, "GNSS aiding: {what}"),
        }
    }
}

impl core::error::Error for ConfigError {}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::format;
    use std::string::ToString;

    fn config() -> RunConfig {
        RunConfig::new(45.0, 7.5, 150.0, 10.0, SensorNoise::seed003())
    }

    /// The documented bound 0.1 of every figure is accepted, with aiding on and off (0.1 in
    /// f32 widened to f64 was beyond 0.1, and refused); the next f32 beyond is refused.
    #[test]
    fn the_figures_bound_itself_is_accepted() {
        let at_bound = SensorFigures {
            gyro_scale: 0.1,
            accel_scale: 0.1,
            gyro_cross_coupling_rad: 0.1,
            accel_cross_coupling_rad: 0.1,
            gyro_g_sensitivity: 0.1,
        };
        for aiding in [None, Some(AidingConfig::default())] {
            let c = RunConfig {
                figures: at_bound,
                aiding,
                ..config()
            };
            assert_eq!(c.validate(), Ok(()), "aiding {}", aiding.is_some());
            let beyond = f32::from_bits(0.1_f32.to_bits() + 1);
            let c = RunConfig {
                figures: SensorFigures {
                    gyro_g_sensitivity: beyond,
                    ..at_bound
                },
                ..c
            };
            assert!(c.validate().is_err(), "aiding {}", aiding.is_some());
        }
    }

    /// Without the aided filter (nav-core's `aided` off, as the STM32F405 board's firmware) a
    /// configuration asking for aiding is refused with a reason naming the feature; with it,
    /// accepted. `cargo test -p nav-core --no-default-features --lib not_compiled_in`.
    #[test]
    fn aiding_not_compiled_in_is_refused_with_its_feature() {
        let c = RunConfig {
            aiding: Some(AidingConfig::default()),
            ..config()
        };
        if AIDED_COMPILED_IN {
            assert_eq!(c.validate(), Ok(()));
        } else {
            let e = c.validate().unwrap_err();
            assert!(matches!(e, ConfigError::Aiding(_)), "{e:?}");
            assert!(e.to_string().contains("feature `aided`"), "{e}");
        }
        assert_eq!(config().validate(), Ok(()));
    }

    #[test]
    fn vectors_parse_with_negative_components_and_refuse_garbage() {
        assert_eq!(parse_vector3("-5.9,0.6,-7.5"), Some([-5.9, 0.6, -7.5]));
        assert_eq!(parse_vector3(" 1, 2 ,3e1"), Some([1.0, 2.0, 30.0]));
        for bad in ["", "1,2", "1,2,3,4", "1,,3", "1,2,x", "1,2,nan", "1,inf,2"] {
            assert_eq!(parse_vector3(bad), None, "{bad}");
        }
    }

    #[test]
    fn options_set_the_same_fields_as_their_names_say() {
        let mut c = config();
        c.set("align-method", "fine").unwrap();
        c.set("bias-prior", "0").unwrap();
        c.set("lever-arm", "-5.9,0.6,-7.5").unwrap();
        c.set("log-every", "8").unwrap();
        c.set("frame", "ned").unwrap();
        c.set("attitude", "rk4").unwrap();
        c.set("vertical", "hold").unwrap();
        assert_eq!(c.align_method, AlignMethod::Fine);
        assert_eq!(c.bias_prior, 0.0);
        assert_eq!(c.lever_arm.known().map(|r| r.x), Some(-5.9));
        assert_eq!(c.log_every, 8);
        assert_eq!(
            c.mechanization,
            MechanizationChoices {
                frame: NavFrame::Ned,
                attitude: AttitudeMethod::Poisson(DcmIntegrator::Rk4),
                vertical: VerticalChannel::Hold,
            }
        );
        assert_eq!(c.aiding, None);
        c.set("gnss-lever-arm", "0.8,-0.3,-1.1").unwrap();
        c.set("propagation-rate", "20").unwrap();
        assert_eq!(
            c.aiding,
            Some(AidingConfig {
                antenna_lever_arm_b_m: [0.8, -0.3, -1.1],
                propagation_interval_s: 0.05,
                ..AidingConfig::default()
            })
        );
        // The correlated error's time before or after its 1-sigma: the same.
        for order in [
            [
                ("gnss-correlated", "1,1.5,-0"),
                ("gnss-correlated-time", "90"),
            ],
            [
                ("gnss-correlated-time", "90"),
                ("gnss-correlated", "1,1.5,-0"),
            ],
        ] {
            let mut d = config();
            for (name, value) in order {
                d.set(name, value).unwrap();
            }
            let a = d.aiding.unwrap();
            assert_eq!(a.gnss_correlated_sigma_ned_m, Some([1.0, 1.5, 0.0]));
            assert_eq!(a.gnss_correlated_time_s, 90.0);
            assert_eq!(
                a.gnss_correlated_error::<f32>(),
                Some(GnssCorrelatedError {
                    sigma_ned_m: nalgebra::Vector3::new(1.0, 1.5, 0.0),
                    correlation_time_s: 90.0,
                })
            );
        }
        assert_eq!(AidingConfig::default().gnss_correlated_error::<f64>(), None);
        c.set("lever-arm-sigma", "2.5").unwrap();
        assert_eq!(c.lever_arm, LeverArm::Unknown { sigma_m: 2.5 });
        // The bias prior scales the biases only.
        c.set("bias-prior", "2").unwrap();
        let n = c.align_noise();
        assert_eq!(n.gyro_bias_rad_s, 2.0 * c.noise.gyro_bias_rad_s);
        assert_eq!(n.arw_rad_per_sqrt_s, c.noise.arw_rad_per_sqrt_s);

        assert_eq!(c.set("magic", "1"), Err(OptionError::Unknown));
        for (name, value) in [
            ("align-method", "magic"),
            ("bias-prior", "x"),
            ("bias-prior", "inf"),
            ("lever-arm", "1,2"),
            ("lever-arm-sigma", ""),
            ("log-every", "-1"),
            ("frame", "enu"),
            ("attitude", "rk5"),
            ("vertical", "aided"),
            ("gnss-lever-arm", "1,2"),
            ("gnss-correlated", "1,2"),
            ("gnss-correlated", "1,2,nan"),
            ("gnss-correlated-time", "x"),
            ("gnss-correlated-time", "inf"),
            ("propagation-rate", "0.5"),
            ("propagation-rate", "x"),
        ] {
            let e = c.set(name, value).unwrap_err();
            assert!(
                e.to_string().starts_with(&format!("--{name} takes ")),
                "{e}"
            );
        }
    }

    #[test]
    fn validation_names_what_is_wrong() {
        assert_eq!(config().validate(), Ok(()));
        let cases = [
            (
                RunConfig {
                    lat_deg: 95.0,
                    ..config()
                },
                "latitude 95 deg is not within [-90, 90]",
            ),
            (
                RunConfig {
                    h_m: f64::NAN,
                    ..config()
                },
                "the height is not a finite number",
            ),
            (
                RunConfig {
                    log_every: 0,
                    ..config()
                },
                "log_every must be at least 1",
            ),
            (
                RunConfig {
                    bias_prior: -1.0,
                    ..config()
                },
                "bias prior scale -1 must be finite, not negative, and keep the bias 1-sigmas \
                 within any IMU's (0.1 rad/s, 10 m/s^2)",
            ),
            // Beyond any IMU's biases (it was accepted).
            (
                RunConfig {
                    bias_prior: 1e10,
                    ..config()
                },
                "bias prior scale 1e10 must be finite, not negative, and keep the bias 1-sigmas \
                 within any IMU's (0.1 rad/s, 10 m/s^2)",
            ),
        ];
        for (c, msg) in cases {
            assert_eq!(c.validate().unwrap_err().to_string(), msg);
        }
        for (c, msg) in [
            (
                RunConfig {
                    lon_deg: 400.0,
                    ..config()
                },
                "longitude 400 deg is not within [-180, 180]",
            ),
            (
                RunConfig {
                    h_m: -1e7,
                    ..config()
                },
                "height -1e7 m is not within [-12000, 100000] m (the Earth model's range)",
            ),
        ] {
            assert_eq!(c.validate().unwrap_err().to_string(), msg);
        }
        let edge = RunConfig {
            lon_deg: -180.0,
            h_m: -12_000.0,
            ..config()
        };
        assert_eq!(edge.validate(), Ok(()));
        let mut c = config();
        c.calibration.accel.scale = [-1.0, 0.0, 0.0];
        assert!(matches!(c.validate(), Err(ConfigError::Calibration(_))));
        // The aided phase's settings.
        let aided = |a: AidingConfig| RunConfig {
            aiding: Some(a),
            ..config()
        };
        assert_eq!(aided(AidingConfig::default()).validate(), Ok(()));
        let declared = AidingConfig {
            gnss_correlated_sigma_ned_m: Some([2.0, 2.0, 4.0]),
            gnss_correlated_time_s: 1.0,
            ..AidingConfig::default()
        };
        assert_eq!(aided(declared).validate(), Ok(()));
        for (c, msg) in [
            (
                aided(AidingConfig {
                    propagation_interval_s: 0.0,
                    ..AidingConfig::default()
                }),
                "GNSS aiding: the covariance propagation interval must be within (0, 1] s",
            ),
            (
                aided(AidingConfig {
                    antenna_lever_arm_b_m: [0.0, f64::NAN, 0.0],
                    ..AidingConfig::default()
                }),
                "GNSS aiding: the GNSS antenna lever arm must be finite and within 100 m",
            ),
            (
                aided(AidingConfig {
                    antenna_lever_arm_b_m: [80.0, 80.0, 0.0],
                    ..AidingConfig::default()
                }),
                "GNSS aiding: the GNSS antenna lever arm must be finite and within 100 m",
            ),
            // The filter's own ranges, refused before any sample.
            (
                aided(AidingConfig {
                    gnss_correlated_sigma_ned_m: Some([1.0, -1.0, 1.0]),
                    ..AidingConfig::default()
                }),
                "GNSS aiding: the GNSS correlated-error 1-sigma must be 0 to 100 m per axis",
            ),
            (
                aided(AidingConfig {
                    gnss_correlated_sigma_ned_m: Some([1.0, 1.0, 1e3]),
                    ..AidingConfig::default()
                }),
                "GNSS aiding: the GNSS correlated-error 1-sigma must be 0 to 100 m per axis",
            ),
            (
                aided(AidingConfig {
                    gnss_correlated_sigma_ned_m: Some([1.0, 1.0, 2.0]),
                    gnss_correlated_time_s: 0.5,
                    ..AidingConfig::default()
                }),
                "GNSS aiding: the GNSS correlated error's correlation time must be 1 s to 86,400 s",
            ),
            // A time out of range is refused without the error too (every value carried is).
            (
                aided(AidingConfig {
                    gnss_correlated_time_s: f64::NAN,
                    ..AidingConfig::default()
                }),
                "GNSS aiding: the GNSS correlated error's correlation time must be 1 s to 86,400 s",
            ),
            // A time in range without the error: nothing to apply it to.
            (
                aided(AidingConfig {
                    gnss_correlated_time_s: 90.0,
                    ..AidingConfig::default()
                }),
                "GNSS aiding: gnss-correlated-time needs gnss-correlated (the error it is the correlation time of)",
            ),
            (
                RunConfig {
                    noise: SensorNoise {
                        gyro_bias_rad_s: 0.0,
                        ..SensorNoise::seed003()
                    },
                    ..aided(AidingConfig::default())
                },
                "GNSS aiding: the aided filter needs positive, finite noise, bias and scale-factor figures",
            ),
            (
                RunConfig {
                    figures: SensorFigures {
                        accel_scale: 0.0,
                        ..SensorFigures::DATASHEET
                    },
                    ..aided(AidingConfig::default())
                },
                "GNSS aiding: the aided filter needs positive, finite noise, bias and scale-factor figures",
            ),
            (
                RunConfig {
                    figures: SensorFigures {
                        gyro_g_sensitivity: 0.5,
                        ..SensorFigures::DATASHEET
                    },
                    ..aided(AidingConfig::default())
                },
                "GNSS aiding: a cross-coupling or g-sensitivity 1-sigma must be 0 to 0.1 (rad, rad/s per m/s^2)",
            ),
        ] {
            assert_eq!(c.validate().unwrap_err().to_string(), msg);
        }
        // Free inertial, a zero bias 1-sigma is the alignment's business (bias prior 0).
        let free = RunConfig {
            noise: SensorNoise {
                gyro_bias_rad_s: 0.0,
                ..SensorNoise::seed003()
            },
            ..config()
        };
        assert_eq!(free.validate(), Ok(()));
    }
}
