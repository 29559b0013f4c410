//! The device configuration the host sends in a configuration frame: the run configuration
//! nav-core navigates with ([`RunConfig`]: site, alignment method and window, IMU noise, lever
//! arms, mechanization, aiding, solution rate), the IMU model and rate, the mounting rotation
//! and the other output rates. Compiled-in defaults ([`DeviceConfig::default`]); validation
//! ([`DeviceConfig::validate`]) is nav-core's own check of a run ([`Setup::new`]) plus the
//! checks of what nav-core does not see (mounting, output rates), each refusal with a
//! [`ReasonCode`]. Its byte layout is in `docs/protocol.md`. The sensor calibration is not
//! part of it (identity: the board's calibration is its own file).

use super::wire::{Overflow, Reader, Writer, pick};
use crate::drivers::Mounting;
use crate::drivers::noise::{self, NoiseSpec};
use core::fmt;
use nav_core::alignment::SensorNoise;
use nav_core::alignment::machine::{AlignMethod, BaseMotion, LeverArm, SettingsError};
use nav_core::calibration::ImuCalibration;
use nav_core::navigator::config::{
    ATTITUDES, AidingConfig, ConfigError, FRAMES, RunConfig, VERTICALS,
};
use nav_core::navigator::{SensorFigures, Setup};
use nav_core::scalar::Scalar;

/// The IMUs the board's drivers support.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum ImuModel {
    /// Analog Devices ADIS16505-2.
    Adis16505 = 0,
    /// TDK ICM-42688-P.
    Icm42688 = 1,
    /// Bosch BMI088.
    Bmi088 = 2,
}

impl ImuModel {
    /// Every model, in code order.
    pub const ALL: [Self; 3] = [Self::Adis16505, Self::Icm42688, Self::Bmi088];

    /// Name in configuration files and on command lines.
    pub fn name(self) -> &'static str {
        match self {
            Self::Adis16505 => "adis16505",
            Self::Icm42688 => "icm42688",
            Self::Bmi088 => "bmi088",
        }
    }

    /// The model called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The part's datasheet noise.
    pub fn noise(self) -> NoiseSpec {
        match self {
            Self::Adis16505 => noise::ADIS16505,
            Self::Icm42688 => noise::ICM42688,
            Self::Bmi088 => noise::BMI088,
        }
    }
}

/// nav-core's noise model of a part's or grade's figures, in precision `T`.
pub fn sensor_noise<T: Scalar>(n: &NoiseSpec) -> SensorNoise<T> {
    SensorNoise {
        arw_rad_per_sqrt_s: T::c(n.gyro_arw_rad_per_sqrt_s),
        vrw_mps_per_sqrt_s: T::c(n.accel_vrw_mps_per_sqrt_s),
        gyro_bias_rad_s: T::c(n.gyro_bias_rad_s),
        accel_bias_mps2: T::c(n.accel_bias_mps2),
    }
}

/// Output rates other than the solution's ([`RunConfig::log_every`]), in IMU samples between
/// frames (0: off).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputRates {
    /// Raw increment frames (1: every sample, 400 Hz at 400 Hz).
    pub raw_every: u16,
    /// Health frames (at least 1: the host must see the status).
    pub health_every: u16,
    /// Alignment progress frames while aligning.
    pub align_progress_every: u16,
}

impl Default for OutputRates {
    /// Raw increments at every sample, health every 400 samples (1 Hz at 400 Hz), alignment
    /// progress every 40 (10 Hz).
    fn default() -> Self {
        Self {
            raw_every: 1,
            health_every: 400,
            align_progress_every: 40,
        }
    }
}

/// What the host configures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceConfig {
    /// The run configuration (its calibration is not carried: identity).
    pub run: RunConfig,
    /// The IMU on the bus.
    pub imu_model: ImuModel,
    /// The IMU's output rate [Hz].
    pub imu_rate_hz: f32,
    /// Sensor axes to body axes.
    pub mounting: Mounting,
    /// Output rates of the other frames.
    pub rates: OutputRates,
}

impl Default for DeviceConfig {
    /// The compiled-in defaults: an ADIS16505 at 400 Hz mounted with its axes the body's, its
    /// datasheet noise, a 60 s static alignment at latitude 0, longitude 0, height 0 (the
    /// host sends the site), nav-core's defaults for the rest, [`OutputRates::default`].
    fn default() -> Self {
        let model = ImuModel::Adis16505;
        Self {
            run: RunConfig::new(0.0, 0.0, 0.0, 60.0, sensor_noise(&model.noise())),
            imu_model: model,
            imu_rate_hz: 400.0,
            mounting: Mounting::IDENTITY,
            rates: OutputRates::default(),
        }
    }
}

/// Why a configuration was refused, as the acknowledgement frame reports it (one byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum ReasonCode {
    /// Latitude not within [-90, 90] deg.
    Latitude = 1,
    /// Longitude not within [-180, 180] deg.
    Longitude = 2,
    /// Height outside the Earth model's range.
    Height = 3,
    /// A value that must be finite is not.
    NotFinite = 4,
    /// Solution rate: `log_every` is 0.
    SolutionRate = 5,
    /// Bias-prior scale negative or not finite.
    BiasPrior = 6,
    /// Calibration not invertible.
    Calibration = 7,
    /// Alignment settings refused (window, rate, site near a pole, noise, lever arm).
    Alignment = 8,
    /// Aided phase settings refused (propagation interval, antenna lever arm, noise, GNSS
    /// correlated error).
    Aiding = 9,
    /// The mounting is not a rotation.
    Mounting = 10,
    /// An output rate refused (health frames off).
    OutputRate = 11,
    /// The payload does not decode (an enumeration value out of range).
    Malformed = 12,
    /// A run is in progress with another run configuration (only output rates change during
    /// a run).
    RunInProgress = 13,
    /// The IMU model, its rate, the mounting or the GNSS aiding is not what the board has.
    NotThisBoard = 14,
}

impl ReasonCode {
    /// Every code, in order.
    pub const ALL: [Self; 14] = [
        Self::Latitude,
        Self::Longitude,
        Self::Height,
        Self::NotFinite,
        Self::SolutionRate,
        Self::BiasPrior,
        Self::Calibration,
        Self::Alignment,
        Self::Aiding,
        Self::Mounting,
        Self::OutputRate,
        Self::Malformed,
        Self::RunInProgress,
        Self::NotThisBoard,
    ];

    /// The reason of a wire code.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.into_iter().find(|r| *r as u8 == code)
    }
}

/// A refused configuration: its reason, and nav-core's error where the check was nav-core's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigRefusal {
    /// nav-core refused the run ([`Setup::new`]).
    Run(ConfigError),
    /// The mounting matrix is not orthonormal with determinant +1 (within [`MOUNTING_TOL`]).
    Mounting,
    /// Health frames switched off.
    HealthOff,
    /// A field of the payload is out of range (its name).
    Malformed(&'static str),
    /// A run is in progress with another run configuration.
    RunInProgress,
    /// What the board does not have (its name: IMU model, IMU rate, mounting, GNSS aiding).
    NotThisBoard(&'static str),
}

/// Tolerance of the mounting's orthonormality and determinant [-].
pub const MOUNTING_TOL: f32 = 1e-4;

impl ConfigRefusal {
    /// The wire reason code.
    pub fn code(&self) -> ReasonCode {
        match self {
            Self::Run(e) => match e {
                ConfigError::Latitude(_) => ReasonCode::Latitude,
                ConfigError::Longitude(_) => ReasonCode::Longitude,
                ConfigError::Height(_) => ReasonCode::Height,
                ConfigError::NotFinite(_) => ReasonCode::NotFinite,
                ConfigError::LogEvery => ReasonCode::SolutionRate,
                ConfigError::BiasPrior(_) => ReasonCode::BiasPrior,
                ConfigError::Calibration(_) => ReasonCode::Calibration,
                ConfigError::Alignment(_) => ReasonCode::Alignment,
                ConfigError::Aiding(_) => ReasonCode::Aiding,
            },
            Self::Mounting => ReasonCode::Mounting,
            Self::HealthOff => ReasonCode::OutputRate,
            Self::Malformed(_) => ReasonCode::Malformed,
            Self::RunInProgress => ReasonCode::RunInProgress,
            Self::NotThisBoard(_) => ReasonCode::NotThisBoard,
        }
    }
}

impl fmt::Display for ConfigRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Run(e) => write!(f, "{e}"),
            Self::Mounting => write!(
                f,
                "the mounting matrix is not a rotation (orthonormal, determinant +1, within {MOUNTING_TOL})"
            ),
            Self::HealthOff => {
                f.write_str("health frames cannot be switched off (health-every >= 1)")
            }
            Self::Malformed(what) => write!(f, "malformed configuration payload: {what}"),
            Self::RunInProgress => f.write_str(
                "a run is in progress with another run configuration: only the output rates apply (restart the board to change it)",
            ),
            Self::NotThisBoard(what) => write!(f, "{what} is not the board's"),
        }
    }
}

impl core::error::Error for ConfigRefusal {}

/// What a board is built with: a configuration frame must name the same (the board cannot
/// change them at run time).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardIdentity {
    /// The IMU on the bus.
    pub imu_model: ImuModel,
    /// The IMU's output rate [Hz].
    pub imu_rate_hz: f64,
    /// Sensor axes to body axes, as the driver applies them (the board's compiled-in
    /// mounting; a frame's replaces it for the run: [`Mounting::relative_to`]).
    pub mounting: Mounting,
    /// A GNSS source is connected (an aided run needs one; a board with one runs aided).
    pub gnss: bool,
}

/// Relative tolerance of a frame's IMU rate against the board's [-] (the frame's is an `f32`).
pub const RATE_TOL: f64 = 1e-6;

impl BoardIdentity {
    /// `Err` naming the first item of `config` the board does not have.
    pub fn check(&self, config: &DeviceConfig) -> Result<(), ConfigRefusal> {
        let rate_off = (f64::from(config.imu_rate_hz) - self.imu_rate_hz).abs()
            > RATE_TOL * self.imu_rate_hz.abs();
        let what = if config.imu_model != self.imu_model {
            "the IMU model"
        } else if rate_off {
            "the IMU rate"
        } else if config.run.aiding.is_some() != self.gnss {
            "GNSS aiding (on or off)"
        } else {
            return Ok(());
        };
        Err(ConfigRefusal::NotThisBoard(what))
    }
}

// The ranges are nav-core's, the filter's own (one place for the rule).
pub use nav_core::ins_filter::limits::{
    MAX_ACCEL_BIAS_MPS2, MAX_ARW_RAD_PER_SQRT_S, MAX_GYRO_BIAS_RAD_S, MAX_SCALE,
    MAX_VRW_MPS_PER_SQRT_S, MIN_ARW_RAD_PER_SQRT_S, MIN_VRW_MPS_PER_SQRT_S,
};

/// The refusal of a gyro ARW out of range ([`SettingsError::OutOfRange`], reason
/// [`ReasonCode::Alignment`]).
pub const ARW_OUT_OF_RANGE: &str = "gyro-arw-rad-per-sqrt-s must be 1e-9 (less makes the \
     filters overconfident) to 0.1 rad/sqrt(s) (more than any IMU's)";

/// The refusal of an accelerometer VRW out of range.
pub const VRW_OUT_OF_RANGE: &str = "accel-vrw-mps-per-sqrt-s must be 1e-8 (less makes the \
     filters overconfident) to 10 m/s/sqrt(s) (more than any IMU's)";

/// The refusal of a gyro bias 1-sigma out of range.
pub const GYRO_BIAS_OUT_OF_RANGE: &str =
    "gyro-bias-rad-s must be 0 or more and at most 0.1 rad/s (more than any IMU's)";

/// The refusal of an accelerometer bias 1-sigma out of range.
pub const ACCEL_BIAS_OUT_OF_RANGE: &str =
    "accel-bias-mps2 must be 0 or more and at most 10 m/s^2 (more than any IMU's)";

/// The refusal of a scale-factor 1-sigma not above 0 or beyond [`MAX_SCALE`] (reason
/// [`ReasonCode::Aiding`], with or without aiding: a frame carries it).
pub const SCALE_OUT_OF_RANGE: &str = "a scale-factor 1-sigma (gyro-scale-sigma, \
     accel-scale-sigma) must be above 0 and at most 0.1 (100,000 ppm): at 0 the aided filter's \
     scale-factor states would have a zero variance (a part without scale-factor errors: 1e-6)";

/// `Err` when a scale-factor 1-sigma of `figures` is not above 0 or beyond [`MAX_SCALE`].
/// nav-core refuses 0 only with aiding on (its check of the other figures, 0 allowed for
/// none, applies to both); a scale factor's 1-sigma is never "none" (it is the aided filter's
/// state's initial and driving 1-sigma), so a frame is refused for it whatever its aiding.
fn check_scale_factors(figures: &SensorFigures) -> Result<(), ConfigRefusal> {
    // NaN fails the comparison. In f32, the figure's precision: 0.1 widened to f64 is
    // 0.10000000149, and the documented bound itself was refused.
    let ok = |v: f32| v > 0.0 && v <= MAX_SCALE as f32;
    if ok(figures.gyro_scale) && ok(figures.accel_scale) {
        Ok(())
    } else {
        Err(ConfigRefusal::Run(ConfigError::Aiding(SCALE_OUT_OF_RANGE)))
    }
}

/// `Err` when the noise figures of `noise` are out of an IMU's range: the white noise
/// densities below [`MIN_ARW_RAD_PER_SQRT_S`], [`MIN_VRW_MPS_PER_SQRT_S`] (a zero density, or
/// 1e-300, makes the filters overconfident) or beyond [`MAX_ARW_RAD_PER_SQRT_S`],
/// [`MAX_VRW_MPS_PER_SQRT_S`]; the bias 1-sigmas negative or
/// beyond [`MAX_GYRO_BIAS_RAD_S`], [`MAX_ACCEL_BIAS_MPS2`]. The refusal is the alignment's
/// noise refusal.
fn check_noise_densities(noise: &SensorNoise<f64>) -> Result<(), ConfigRefusal> {
    // NaN fails every comparison.
    let density = |v: f64, min: f64, max: f64| (min..=max).contains(&v);
    let sigma = |v: f64, max: f64| (0.0..=max).contains(&v);
    let why = if !density(
        noise.arw_rad_per_sqrt_s,
        MIN_ARW_RAD_PER_SQRT_S,
        MAX_ARW_RAD_PER_SQRT_S,
    ) {
        ARW_OUT_OF_RANGE
    } else if !density(
        noise.vrw_mps_per_sqrt_s,
        MIN_VRW_MPS_PER_SQRT_S,
        MAX_VRW_MPS_PER_SQRT_S,
    ) {
        VRW_OUT_OF_RANGE
    } else if !sigma(noise.gyro_bias_rad_s, MAX_GYRO_BIAS_RAD_S) {
        GYRO_BIAS_OUT_OF_RANGE
    } else if !sigma(noise.accel_bias_mps2, MAX_ACCEL_BIAS_MPS2) {
        ACCEL_BIAS_OUT_OF_RANGE
    } else {
        return Ok(());
    };
    Err(ConfigRefusal::Run(ConfigError::Alignment(
        SettingsError::OutOfRange(why),
    )))
}

/// Payload length of a configuration frame [bytes] (201 in protocol version 1, before the
/// GNSS correlated error; 233 in versions 2 to 4, before the IMU's other figures).
pub const CONFIG_LEN: usize = 253;

/// The aiding bits of a configuration frame: aiding on, scale-factor states, stop updates, a
/// GNSS correlated error declared.
const AIDING_ON: u8 = 1;
const SCALE_FACTORS: u8 = 1 << 1;
const ZERO_MOTION: u8 = 1 << 2;
const GNSS_CORRELATED: u8 = 1 << 3;
const AIDING_BITS: u8 = AIDING_ON | SCALE_FACTORS | ZERO_MOTION | GNSS_CORRELATED;

impl DeviceConfig {
    /// Checks the configuration: the white noise densities (above zero, within an IMU's
    /// range), the scale-factor 1-sigmas (above zero, [`SCALE_OUT_OF_RANGE`]), nav-core's
    /// checks of the run at the IMU's rate ([`Setup::new`], the same as every run's), then the
    /// mounting and the output rates.
    /// The run is checked in `f32`, the precision the board navigates in: the check its run's
    /// start makes (and no `f64` copy of the setup's code in the board's flash).
    pub fn validate(&self) -> Result<(), ConfigRefusal> {
        check_noise_densities(&self.run.noise)?;
        check_scale_factors(&self.run.figures)?;
        Setup::<f32>::new(&self.run, f64::from(self.imu_rate_hz)).map_err(ConfigRefusal::Run)?;
        if !self.mounting.is_rotation(MOUNTING_TOL) {
            return Err(ConfigRefusal::Mounting);
        }
        if self.rates.health_every == 0 {
            return Err(ConfigRefusal::HealthOff);
        }
        Ok(())
    }

    /// Checks a frame the board received: [`Self::validate`], then against the `board`
    /// ([`BoardIdentity::check`]), then, with a run in progress on `running` (its run
    /// configuration and mounting), that its run configuration (the calibration aside: the
    /// board's own, not carried) and mounting are the running ones, so that only its output
    /// rates change.
    pub fn check_on(
        &self,
        board: &BoardIdentity,
        running: Option<(&RunConfig, &Mounting)>,
    ) -> Result<(), ConfigRefusal> {
        self.validate()?;
        board.check(self)?;
        if let Some((running, mounting)) = running {
            let run = RunConfig {
                calibration: running.calibration,
                ..self.run
            };
            if run != *running || self.mounting != *mounting {
                return Err(ConfigRefusal::RunInProgress);
            }
        }
        Ok(())
    }

    /// The run configuration to navigate with: the frame's, with the board's `calibration`.
    pub fn run_with(&self, calibration: ImuCalibration) -> RunConfig {
        RunConfig {
            calibration,
            ..self.run
        }
    }

    /// Writes the payload (`docs/protocol.md`, [`CONFIG_LEN`] bytes).
    pub(crate) fn write(&self, w: &mut Writer<'_>) -> Result<(), Overflow> {
        let r = &self.run;
        w.f64s(&[r.lat_deg, r.lon_deg, r.h_m])?;
        w.u8(self.imu_model as u8)?;
        w.f32(self.imu_rate_hz)?;
        for row in &self.mounting.c_s_b {
            w.f32s(row)?;
        }
        let n = &r.noise;
        w.f64s(&[
            n.arw_rad_per_sqrt_s,
            n.vrw_mps_per_sqrt_s,
            n.gyro_bias_rad_s,
            n.accel_bias_mps2,
            r.bias_prior,
        ])?;
        w.u8(index(&AlignMethod::ALL, &r.align_method))?;
        w.f64(r.align_seconds)?;
        match r.lever_arm {
            LeverArm::Known(v) => {
                w.u8(0)?;
                w.f64s(&[v[0], v[1], v[2]])?;
            }
            LeverArm::Unknown { sigma_m } => {
                w.u8(1)?;
                w.f64s(&[sigma_m, 0.0, 0.0])?;
            }
        }
        w.f64s(&[r.base.position_sigma_m, r.base.translation_sigma_m])?;
        let m = &r.mechanization;
        w.u8(index_of(&FRAMES, &m.frame))?;
        w.u8(index_of(&ATTITUDES, &m.attitude))?;
        w.u8(index_of(&VERTICALS, &m.vertical))?;
        w.u32(r.log_every)?;
        let a = r.aiding.unwrap_or_default();
        let flag = |on: bool, bit: u8| if on { bit } else { 0 };
        w.u8(flag(r.aiding.is_some(), AIDING_ON)
            | flag(a.scale_factors, SCALE_FACTORS)
            | flag(a.zero_motion, ZERO_MOTION)
            | flag(a.gnss_correlated_sigma_ned_m.is_some(), GNSS_CORRELATED))?;
        w.f64s(&a.antenna_lever_arm_b_m)?;
        w.f64(a.propagation_interval_s)?;
        w.f64s(&a.gnss_correlated_sigma_ned_m.unwrap_or_default())?;
        w.f64(a.gnss_correlated_time_s)?;
        w.u16(self.rates.raw_every)?;
        w.u16(self.rates.health_every)?;
        w.u16(self.rates.align_progress_every)?;
        let f = &r.figures;
        w.f32s(&[
            f.gyro_scale,
            f.accel_scale,
            f.gyro_cross_coupling_rad,
            f.accel_cross_coupling_rad,
            f.gyro_g_sensitivity,
        ])
    }

    /// Reads a payload written by [`Self::write`] (not validated: [`Self::validate`] does).
    pub(crate) fn read(r: &mut Reader<'_>) -> Result<Self, ConfigRefusal> {
        let short = ConfigRefusal::Malformed("payload too short");
        let [lat_deg, lon_deg, h_m] = r.f64s().ok_or(short)?;
        let imu_model = field(&ImuModel::ALL, r.u8().ok_or(short)?, "IMU model")?;
        let imu_rate_hz = r.f32().ok_or(short)?;
        let c_s_b = [
            r.f32s().ok_or(short)?,
            r.f32s().ok_or(short)?,
            r.f32s().ok_or(short)?,
        ];
        let [arw, vrw, gyro_bias, accel_bias, bias_prior] = r.f64s().ok_or(short)?;
        let align_method = field(&AlignMethod::ALL, r.u8().ok_or(short)?, "alignment method")?;
        let align_seconds = r.f64().ok_or(short)?;
        let kind = r.u8().ok_or(short)?;
        let [x, y, z] = r.f64s().ok_or(short)?;
        let lever_arm = match kind {
            0 => LeverArm::Known([x, y, z].into()),
            1 => LeverArm::Unknown { sigma_m: x },
            _ => return Err(ConfigRefusal::Malformed("lever arm kind")),
        };
        let [position_sigma_m, translation_sigma_m] = r.f64s().ok_or(short)?;
        let frame = field(&FRAMES, r.u8().ok_or(short)?, "navigation frame")?.1;
        let attitude = field(&ATTITUDES, r.u8().ok_or(short)?, "attitude method")?.1;
        let vertical = field(&VERTICALS, r.u8().ok_or(short)?, "vertical channel")?.1;
        let log_every = r.u32().ok_or(short)?;
        let bits = r.u8().ok_or(short)?;
        if bits & !AIDING_BITS != 0 {
            return Err(ConfigRefusal::Malformed("aiding bits"));
        }
        let antenna_lever_arm_b_m = r.f64s().ok_or(short)?;
        let propagation_interval_s = r.f64().ok_or(short)?;
        let gnss_correlated_sigma_ned_m: [f64; 3] = r.f64s().ok_or(short)?;
        let gnss_correlated_time_s = r.f64().ok_or(short)?;
        let rates = OutputRates {
            raw_every: r.u16().ok_or(short)?,
            health_every: r.u16().ok_or(short)?,
            align_progress_every: r.u16().ok_or(short)?,
        };
        let [
            gyro_scale,
            accel_scale,
            gyro_coupling,
            accel_coupling,
            g_sensitivity,
        ] = r.f32s().ok_or(short)?;
        let mut run = RunConfig::new(
            lat_deg,
            lon_deg,
            h_m,
            align_seconds,
            SensorNoise {
                arw_rad_per_sqrt_s: arw,
                vrw_mps_per_sqrt_s: vrw,
                gyro_bias_rad_s: gyro_bias,
                accel_bias_mps2: accel_bias,
            },
        );
        run.figures = SensorFigures {
            gyro_scale,
            accel_scale,
            gyro_cross_coupling_rad: gyro_coupling,
            accel_cross_coupling_rad: accel_coupling,
            gyro_g_sensitivity: g_sensitivity,
        };
        run.align_method = align_method;
        run.bias_prior = bias_prior;
        run.lever_arm = lever_arm;
        run.base = BaseMotion {
            position_sigma_m,
            translation_sigma_m,
        };
        run.mechanization.frame = frame;
        run.mechanization.attitude = attitude;
        run.mechanization.vertical = vertical;
        run.log_every = log_every;
        run.aiding = (bits & AIDING_ON != 0).then_some(AidingConfig {
            antenna_lever_arm_b_m,
            propagation_interval_s,
            scale_factors: bits & SCALE_FACTORS != 0,
            zero_motion: bits & ZERO_MOTION != 0,
            gnss_correlated_sigma_ned_m: (bits & GNSS_CORRELATED != 0)
                .then_some(gnss_correlated_sigma_ned_m),
            gnss_correlated_time_s,
        });
        Ok(Self {
            run,
            imu_model,
            imu_rate_hz,
            mounting: Mounting { c_s_b },
            rates,
        })
    }
}

/// Position of `v` in `all` (the wire code of an enumeration listed in a table).
fn index<V: PartialEq>(all: &[V], v: &V) -> u8 {
    all.iter().position(|x| x == v).unwrap_or(0) as u8
}

/// Position of `v` in a name table.
fn index_of<V: PartialEq>(table: &[(&str, V)], v: &V) -> u8 {
    table.iter().position(|(_, x)| x == v).unwrap_or(0) as u8
}

/// The entry of wire code `code` in `all`, or a refusal naming `what`.
fn field<V: Copy>(all: &[V], code: u8, what: &'static str) -> Result<V, ConfigRefusal> {
    pick(all, code).ok_or(ConfigRefusal::Malformed(what))
}
