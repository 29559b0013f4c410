//! The configuration's text form: `key = value` lines, `#` comments and blank lines ignored,
//! each line applied to a [`DeviceConfig`] starting from the compiled-in defaults. Units are in
//! the key names or below; the keys that nav-core's run options already define are passed to
//! [`RunConfig::set`](nav_core::navigator::RunConfig::set) with the same names and value
//! syntax as `nav replay`'s options.
//!
//! | key | value |
//! | --- | --- |
//! | `lat-deg`, `lon-deg`, `h-m` | site latitude, longitude [deg], ellipsoidal height [m] |
//! | `imu-model` | `adis16505`, `icm42688` or `bmi088` (also sets the noise to the part's datasheet figures) |
//! | `imu-rate-hz` | IMU output rate [Hz] |
//! | `imu-noise` | a grade's figures instead: `fog`, `rlg`, `mems-tactical`, `mems-consumer` |
//! | `gyro-arw-rad-per-sqrt-s`, `accel-vrw-mps-per-sqrt-s`, `gyro-bias-rad-s`, `accel-bias-mps2` | one noise figure |
//! | `gyro-scale-sigma`, `accel-scale-sigma` [-] (above 0), `gyro-cross-coupling-rad`, `accel-cross-coupling-rad` [rad], `gyro-g-sensitivity` [rad/s per m/s^2] (0: none) | one of the aided filter's other figures |
//! | `mounting` | sensor-to-body rotation `c_s_b`, 9 numbers row by row, comma-separated |
//! | `align-seconds` | alignment window [s] |
//! | `raw-every`, `health-every`, `align-progress-every` | output rates [IMU samples between frames], 0: off |
//! | `aiding` | `on` or `off` (GNSS-aided phase) |
//! | `align-method`, `bias-prior`, `lever-arm` (X,Y,Z [m]), `lever-arm-sigma` [m], `base-translation` [m], `log-every` (solution rate, [navigation steps], at least 1), `frame`, `attitude`, `vertical`, `gnss-lever-arm` (X,Y,Z [m]), `propagation-rate` [Hz], `gnss-correlated` (N,E,D 1-sigma [m]), `gnss-correlated-time` [s] | as `nav replay`'s options |
//!
//! What a whole file must hold, and which keys exclude or replace others, is checked by its
//! reader (`nav config`) from the tables here: [`SITE_KEYS`], [`EXCLUSIVE_KEYS`],
//! [`AIDING_KEYS`], [`REPLACING_KEYS`].

use super::config::{DeviceConfig, ImuModel, sensor_noise};
use crate::drivers::Mounting;
use crate::drivers::noise::grade;
use core::fmt;
use nav_core::ins_filter::limits::{COUPLING_SIGMA_OUT_OF_RANGE, SCALE_SIGMA_OUT_OF_RANGE};
use nav_core::navigator::OptionError;
use nav_core::navigator::config::AidingConfig;

/// Why a line was refused. Its `Display` names the file's key, never a command-line option.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineError<'a> {
    /// No `=` on the line.
    NoEquals,
    /// A key no configuration has (the key).
    UnknownKey(&'a str),
    /// The value does not parse, or is out of the key's range (the key, what it takes).
    Invalid {
        /// The key.
        key: &'a str,
        /// What it takes.
        expected: &'static str,
        /// The value given (trimmed).
        value: &'a str,
    },
}

impl fmt::Display for LineError<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoEquals => f.write_str("expected 'key = value'"),
            Self::UnknownKey(k) => write!(f, "unknown key '{}'", nav_core::number::Shown(k)),
            Self::Invalid {
                key,
                expected,
                value: "",
            } => write!(f, "{key}: takes {expected}, got nothing"),
            Self::Invalid {
                key,
                expected,
                value,
            } => write!(
                f,
                "{key}: takes {expected}, got {}",
                nav_core::number::Shown(value)
            ),
        }
    }
}

/// The keys of the site: a file must give each (the compiled-in site, latitude 0, longitude
/// 0, height 0, is no board's).
pub const SITE_KEYS: [&str; 3] = ["lat-deg", "lon-deg", "h-m"];

/// Keys that cannot be given together (as `nav replay`'s options of the same names), and why.
pub const EXCLUSIVE_KEYS: [(&str, &str, &str); 1] = [(
    "lever-arm",
    "lever-arm-sigma",
    "the lever arm is known (its offset) or unknown (its 1-sigma), not both",
)];

/// The keys that switch the GNSS-aided phase on: not with `aiding = off`.
pub const AIDING_KEYS: [&str; 4] = [
    "gnss-lever-arm",
    "propagation-rate",
    "gnss-correlated",
    "gnss-correlated-time",
];

/// Keys that replace the values of other keys, which must therefore come after them (a figure
/// given before `imu-model` or `imu-noise` would be lost): the key, the keys it replaces.
pub const REPLACING_KEYS: [(&str, &[&str]); 2] =
    [("imu-model", MODEL_REPLACES), ("imu-noise", FIGURE_KEYS)];

/// The keys of one of the IMU's figures ([`NOISE_KEYS`] after the model and the grade).
const FIGURE_KEYS: &[&str] = NOISE_KEYS.split_at(2).1;

/// What `imu-model` replaces: a grade's figures and every single figure ([`NOISE_KEYS`]
/// after the model).
const MODEL_REPLACES: &[&str] = NOISE_KEYS.split_at(1).1;

/// The `key` and `value` of a line (trimmed, a `#` comment removed), `Ok(None)` for a blank
/// or comment line.
pub fn key_value(line: &str) -> Result<Option<(&str, &str)>, LineError<'_>> {
    // A `#` starts a comment, on its own line or after a value.
    let line = line
        .split_once('#')
        .map_or(line, |(before, _)| before)
        .trim();
    if line.is_empty() {
        return Ok(None);
    }
    let (key, value) = line.split_once('=').ok_or(LineError::NoEquals)?;
    Ok(Some((key.trim(), value.trim())))
}

impl DeviceConfig {
    /// Applies one line of the text form (module docs); blank and comment lines do nothing.
    /// Values are checked for syntax here and by [`Self::validate`] for sense.
    pub fn apply_line<'a>(&mut self, line: &'a str) -> Result<(), LineError<'a>> {
        match key_value(line)? {
            Some((key, value)) => self.set(key, value),
            None => Ok(()),
        }
    }

    /// Sets `key` to `value` (module docs).
    pub fn set<'a>(&mut self, key: &'a str, value: &'a str) -> Result<(), LineError<'a>> {
        let bad = |expected| LineError::Invalid {
            key,
            expected,
            value,
        };
        let number = || {
            value
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or(bad("a finite number"))
        };
        // A figure the frame carries in f32: 1e300 became "inf" in the refusal's text.
        let number32 = || {
            number()
                .ok()
                .map(|v| v as f32)
                .filter(|v| v.is_finite())
                .ok_or(bad("a finite number within f32's range (3.4e38)"))
        };
        let count = || {
            value
                .parse::<u16>()
                .map_err(|_| bad("a whole number within 0 to 65535"))
        };
        let run = &mut self.run;
        match key {
            "lat-deg" => run.lat_deg = number()?,
            "lon-deg" => run.lon_deg = number()?,
            "h-m" => run.h_m = number()?,
            "align-seconds" => run.align_seconds = number()?,
            "imu-rate-hz" => self.imu_rate_hz = number32()?,
            "imu-model" => {
                self.imu_model =
                    ImuModel::from_name(value).ok_or(bad("adis16505, icm42688 or bmi088"))?;
                run.noise = sensor_noise(&self.imu_model.noise());
                run.figures = self.imu_model.noise().figures;
            }
            "imu-noise" => {
                let spec =
                    grade::by_name(value).ok_or(bad("fog, rlg, mems-tactical or mems-consumer"))?;
                run.noise = sensor_noise(&spec);
                run.figures = spec.figures;
            }
            "gyro-scale-sigma" => run.figures.gyro_scale = number32()?,
            "accel-scale-sigma" => run.figures.accel_scale = number32()?,
            "gyro-cross-coupling-rad" => run.figures.gyro_cross_coupling_rad = number32()?,
            "accel-cross-coupling-rad" => run.figures.accel_cross_coupling_rad = number32()?,
            "gyro-g-sensitivity" => run.figures.gyro_g_sensitivity = number32()?,
            "gyro-arw-rad-per-sqrt-s" => run.noise.arw_rad_per_sqrt_s = number()?,
            "accel-vrw-mps-per-sqrt-s" => run.noise.vrw_mps_per_sqrt_s = number()?,
            "gyro-bias-rad-s" => run.noise.gyro_bias_rad_s = number()?,
            "accel-bias-mps2" => run.noise.accel_bias_mps2 = number()?,
            "mounting" => {
                self.mounting = Mounting::parse_rows(value)
                    .ok_or(bad("9 numbers, row by row, comma-separated"))?;
            }
            "raw-every" => self.rates.raw_every = count()?,
            "health-every" => self.rates.health_every = count()?,
            "align-progress-every" => self.rates.align_progress_every = count()?,
            "aiding" => match value {
                "on" => {
                    run.aiding.get_or_insert_with(AidingConfig::default);
                }
                "off" => run.aiding = None,
                _ => return Err(bad("on or off")),
            },
            // Refused where it is written (nav-core refuses 0 as the run's check, reason code 5).
            "log-every" => {
                run.log_every = value
                    .parse::<u32>()
                    .ok()
                    .filter(|n| *n >= 1)
                    .ok_or(bad("a whole number within 1 to 4294967295"))?;
            }
            // nav-core's option parser; its refusal named with the key, not as an option.
            _ => match run.set(key, value) {
                Ok(()) => {}
                Err(OptionError::Unknown) => return Err(LineError::UnknownKey(key)),
                Err(OptionError::Invalid { expected, .. }) => return Err(bad(expected)),
            },
        }
        Ok(())
    }
}

/// The keys of the IMU's noise figures.
const NOISE_KEYS: [&str; 11] = [
    "imu-model",
    "imu-noise",
    "gyro-arw-rad-per-sqrt-s",
    "accel-vrw-mps-per-sqrt-s",
    "gyro-bias-rad-s",
    "accel-bias-mps2",
    "gyro-scale-sigma",
    "accel-scale-sigma",
    "gyro-cross-coupling-rad",
    "accel-cross-coupling-rad",
    "gyro-g-sensitivity",
];

/// The text keys a refusal is about (a host names the lines that set them).
pub fn keys_of(
    refusal: &super::config::ConfigRefusal,
) -> impl Iterator<Item = &'static str> + use<> {
    use super::config::ConfigRefusal as R;
    use super::config::{
        ACCEL_BIAS_OUT_OF_RANGE, ARW_OUT_OF_RANGE, GYRO_BIAS_OUT_OF_RANGE, SCALE_OUT_OF_RANGE,
        VRW_OUT_OF_RANGE,
    };
    use nav_core::alignment::machine::{self, SettingsError};
    use nav_core::navigator::ConfigError as E;
    let (own, noise): (&'static [&'static str], bool) = match refusal {
        R::Run(E::Latitude(_)) => (&["lat-deg"], false),
        R::Run(E::Longitude(_)) => (&["lon-deg"], false),
        R::Run(E::Height(_)) => (&["h-m"], false),
        R::Run(E::NotFinite(_)) => (&["lon-deg", "h-m", "align-seconds"], false),
        R::Run(E::LogEvery) => (&["log-every"], false),
        R::Run(E::BiasPrior(_)) => (&["bias-prior"], false),
        R::Run(E::Alignment(SettingsError::OutOfRange(why))) => (
            match *why {
                ARW_OUT_OF_RANGE => &["gyro-arw-rad-per-sqrt-s", "imu-model", "imu-noise"],
                VRW_OUT_OF_RANGE => &["accel-vrw-mps-per-sqrt-s", "imu-model", "imu-noise"],
                GYRO_BIAS_OUT_OF_RANGE => &["gyro-bias-rad-s", "imu-model", "imu-noise"],
                ACCEL_BIAS_OUT_OF_RANGE => &["accel-bias-mps2", "imu-model", "imu-noise"],
                nav_core::alignment::machine::BASE_TRANSLATION_OUT_OF_RANGE => {
                    &["base-translation"]
                }
                _ => &NOISE_KEYS,
            },
            false,
        ),
        R::Run(E::Alignment(SettingsError::BadValue(what))) => match *what {
            machine::LEVER_ARM_VALUE => (&["lever-arm"], false),
            machine::LEVER_ARM_SIGMA_VALUE => (&["lever-arm-sigma"], false),
            machine::BASE_MOTION_VALUE => (&["base-translation"], false),
            _ => (&NOISE_KEYS, false),
        },
        R::Run(E::Alignment(SettingsError::WindowTooShort { .. })) => {
            (&["align-seconds", "align-method"], false)
        }
        R::Run(E::Alignment(SettingsError::GyrosTooCoarse { .. })) => {
            (&["align-method", "lat-deg"], true)
        }
        R::Run(E::Alignment(SettingsError::BadRate(_))) => (&["imu-rate-hz"], false),
        R::Run(E::Alignment(SettingsError::WindowTooLong { .. })) => (&["align-seconds"], false),
        R::Run(E::Alignment(SettingsError::NearPole)) => (&["lat-deg"], false),
        R::Run(E::Alignment(SettingsError::LeverArmTooLong { .. })) => (&["lever-arm"], false),
        R::Run(E::Alignment(
            SettingsError::LeverArmSigmaTooLarge { .. } | SettingsError::LeverArmSigmaZero,
        )) => (&["lever-arm-sigma"], false),
        // The lever arm is not given (an unknown one's 1-sigma may be).
        R::Run(E::Alignment(SettingsError::SwayNeedsLeverArm)) => {
            (&["align-method", "lever-arm-sigma"], false)
        }
        R::Run(E::Alignment(_)) => (
            &[
                "align-method",
                "align-seconds",
                "imu-rate-hz",
                "lat-deg",
                "lever-arm",
                "lever-arm-sigma",
                "base-translation",
                "bias-prior",
            ],
            true,
        ),
        R::Run(E::Aiding(why)) if *why == SCALE_OUT_OF_RANGE => (
            &[
                "gyro-scale-sigma",
                "accel-scale-sigma",
                "imu-model",
                "imu-noise",
            ],
            false,
        ),
        R::Run(E::Aiding(why)) if *why == COUPLING_SIGMA_OUT_OF_RANGE => (
            &[
                "gyro-cross-coupling-rad",
                "accel-cross-coupling-rad",
                "gyro-g-sensitivity",
                "imu-model",
                "imu-noise",
            ],
            false,
        ),
        R::Run(E::Aiding(_)) => (
            &[
                "aiding",
                "gnss-lever-arm",
                "propagation-rate",
                "gnss-correlated",
                "gnss-correlated-time",
            ],
            true,
        ),
        R::Mounting => (&["mounting"], false),
        R::HealthOff => (&["health-every"], false),
        R::NotThisBoard(_) => (&["imu-model", "imu-rate-hz", "aiding"], false),
        R::Run(E::Calibration(_)) | R::Malformed(_) | R::RunInProgress => (&[], false),
    };
    let noise: &'static [&'static str] = if noise { &NOISE_KEYS } else { &[] };
    own.iter().chain(noise).copied()
}

/// `true` for nav-core's refusal of the IMU's other figures (scale factor, cross-coupling,
/// g-sensitivity), which [`ConfigError::Aiding`](nav_core::navigator::ConfigError::Aiding)
/// carries with or without aiding.
fn is_figures_refusal(why: &str) -> bool {
    [
        super::config::SCALE_OUT_OF_RANGE,
        SCALE_SIGMA_OUT_OF_RANGE,
        COUPLING_SIGMA_OUT_OF_RANGE,
    ]
    .contains(&why)
}

/// A refusal in the text form's words: the refusal's own text, but a file's key where
/// nav-core's names a command-line option (`--lever-arm`) or a field (`log_every`).
#[derive(Clone, Copy, Debug)]
pub struct InText<'a>(pub &'a super::config::ConfigRefusal);

impl fmt::Display for InText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use super::config::ConfigRefusal as R;
        use nav_core::alignment::machine::SettingsError;
        use nav_core::navigator::ConfigError as E;
        match self.0 {
            R::Run(E::Alignment(SettingsError::SwayNeedsLeverArm)) => f.write_str(
                "the sway method needs the lever arm (lever-arm = X,Y,Z; 0,0,0 at the centre of \
                 rotation): with an unknown one its 1-sigma is not true; use fine",
            ),
            R::Run(E::Alignment(SettingsError::LeverArmSigmaZero)) => f.write_str(
                "an unknown lever arm's 1-sigma of 0 m is a known lever arm of 0 m by another \
                 name: give it as known (lever-arm = 0,0,0), or a 1-sigma above 0",
            ),
            R::Run(E::LogEvery) => f.write_str("log-every must be at least 1"),
            // Checked with aiding on or off (a frame carries them): named by their own group,
            // not "GNSS aiding", which the file may have switched off.
            R::Run(E::Aiding(why)) if is_figures_refusal(why) => {
                write!(f, "IMU error figures: {why}")
            }
            r => write!(f, "{r}"),
        }
    }
}
