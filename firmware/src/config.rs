//! The firmware's arguments, given as semihosting arguments by the QEMU runner:
//! `firmware [OPTIONS] IMU_FILE OUT_FILE LAT_DEG LON_DEG H_M ALIGN_S [LOG_EVERY [CAL_FILE]]`.
//!
//! They parse into nav-core's [`RunConfig`] (the host's `nav replay` fills the same type), with
//! its option names and value syntax ([`RunConfig::set`]); only the files, the device and the
//! noise grade are the firmware's own. `--gnss FILE` (a binary fix file,
//! `hal_adapters::gnss_record`) switches the GNSS-aided phase on ([`RunConfig::aiding`]);
//! `--gnss-lever-arm X,Y,Z`, `--propagation-rate HZ`, `--gnss-correlated N,E,D` and
//! `--gnss-correlated-time S` (the receiver's correlated error) tune it and need it, with
//! `nav replay --gnss`'s names and syntax. `--stream FILE`
//! writes the output protocol's byte stream beside the solution log; `--config-frame FILE`
//! feeds a file's bytes (`nav config`'s frame) to the configuration input before the run.

use crate::imu::Device;
use core::ffi::CStr;
use core::fmt;
use hal_adapters::drivers::noise::grade;
use hal_adapters::drivers::{Mounting, NoiseSpec};
use hal_adapters::protocol::config::MOUNTING_TOL;
use nav_core::alignment::{AlignMethod, SensorNoise};
use nav_core::navigator::{AidingConfig, OptionError, RunConfig};

/// Longest accepted path, including the terminating NUL.
pub const MAX_PATH: usize = 96;

/// What to replay, where to write, and the run configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct Args {
    /// Recording to replay (binary recording format), NUL-terminated.
    pub imu_path: heapless::Vec<u8, MAX_PATH>,
    /// Solution log to write (CSV), NUL-terminated.
    pub out_path: heapless::Vec<u8, MAX_PATH>,
    /// Sensor calibration (nav-core's text form), NUL-terminated; none: identity.
    pub cal_path: Option<heapless::Vec<u8, MAX_PATH>>,
    /// GNSS fixes (binary fix file), NUL-terminated; none: free inertial after the alignment.
    pub gnss_path: Option<heapless::Vec<u8, MAX_PATH>>,
    /// The output protocol's byte stream to write beside the solution log, NUL-terminated.
    pub stream_path: Option<heapless::Vec<u8, MAX_PATH>>,
    /// Bytes the host sends on the configuration input before the run (a configuration frame
    /// from `nav config`), NUL-terminated.
    pub config_frame_path: Option<heapless::Vec<u8, MAX_PATH>>,
    /// The IMU on the bus.
    pub device: Device,
    /// How the simulated IMU is installed (`--imu-mounting`, `c_s_b`): the recording's body axes
    /// reach the driver turned into these sensor axes. The driver applies the board's
    /// [`crate::imu::MOUNTING`]; a configuration frame's mounting is the run's.
    pub imu_mounting: Mounting,
    /// The run configuration (the calibration is loaded into it from [`Self::cal_path`]).
    pub run: RunConfig,
}

/// What is wrong with the arguments (borrowing the words it names).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ArgError<'a> {
    /// Fewer than the six required arguments (name of the first missing one).
    Missing(&'static str),
    /// A positional argument is not valid (its name).
    Invalid(&'static str),
    /// `--device NAME` names no supported device.
    UnknownDevice(&'a str),
    /// `--imu-noise GRADE` names no grade.
    UnknownGrade(&'a str),
    /// `--align-method NAME` names no method.
    UnknownMethod(&'a str),
    /// `--NAME` is not an option.
    UnknownOption(&'a str),
    /// `--lever-arm` and `--lever-arm-sigma` together.
    LeverArmTwice,
    /// `--base-translation` with the static alignment, which takes a still base only.
    BaseTranslationStatic,
    /// A run-configuration option was refused (its message).
    Option(OptionError),
    /// An option without its value.
    NoValue(&'a str),
    /// An argument after the last positional one.
    Extra(&'a str),
    /// The solution log would overwrite the recording.
    SameFile,
    /// The solution log would overwrite the GNSS file.
    GnssSameFile,
    /// The solution log would overwrite the calibration or the configuration frame (the
    /// option or argument).
    InputSameFile(&'static str),
    /// `--gnss FILE` is not a valid path.
    BadGnssPath,
    /// `--stream FILE` or `--config-frame FILE` is not a valid path (the option).
    BadPath(&'static str),
    /// The stream would overwrite the solution log or an input.
    StreamSameFile,
    /// An aided phase's option without `--gnss FILE`.
    AidingWithoutGnss,
    /// `--imu-mounting` is not 9 numbers of a rotation.
    BadMounting,
}

impl fmt::Display for ArgError<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Missing(name) => write!(f, "{name} is missing"),
            Self::Invalid(name) => write!(f, "{name} is not valid"),
            Self::UnknownDevice(name) => {
                write!(f, "unknown device {name}: adis16505, icm42688 or bmi088")
            }
            Self::UnknownGrade(name) => write!(
                f,
                "unknown IMU noise grade {name}: fog, rlg, mems-tactical or mems-consumer"
            ),
            Self::UnknownMethod(name) => {
                write!(
                    f,
                    "unknown alignment method {name}: static, inertial, fine or sway"
                )
            }
            Self::UnknownOption(name) => write!(f, "unknown option --{name}"),
            Self::BadMounting => write!(
                f,
                "--imu-mounting is not a rotation: 9 numbers, row by row, comma-separated"
            ),
            Self::LeverArmTwice => f.write_str(
                "--lever-arm (known) and --lever-arm-sigma (unknown) exclude each other",
            ),
            Self::BaseTranslationStatic => write!(
                f,
                "--base-translation: {}",
                nav_core::alignment::machine::BASE_TRANSLATION_STATIC
            ),
            Self::Option(e) => write!(f, "{e}"),
            Self::NoValue(name) => write!(f, "--{name} has no value"),
            Self::Extra(word) => write!(f, "unexpected argument {word} after CAL_FILE"),
            Self::SameFile => {
                f.write_str("OUT_FILE is IMU_FILE: refusing to overwrite the recording")
            }
            Self::GnssSameFile => {
                f.write_str("OUT_FILE is the GNSS file: refusing to overwrite the fixes")
            }
            Self::InputSameFile(name) => {
                write!(f, "OUT_FILE is {name}: refusing to overwrite it")
            }
            Self::BadGnssPath => f.write_str("--gnss FILE is not a valid path"),
            Self::BadPath(option) => write!(f, "{option} FILE is not a valid path"),
            Self::StreamSameFile => f.write_str(
                "--stream FILE is an input or the solution log: refusing to overwrite it",
            ),
            Self::AidingWithoutGnss => f.write_str(
                "--gnss-lever-arm, --propagation-rate, --gnss-correlated and \
                     --gnss-correlated-time need --gnss FILE",
            ),
        }
    }
}

const NAMES: [&str; 8] = [
    "IMU_FILE",
    "OUT_FILE",
    "LAT_DEG",
    "LON_DEG",
    "H_M",
    "ALIGN_S",
    "LOG_EVERY",
    "CAL_FILE",
];

/// The usage line for error messages.
pub const USAGE: &str = "firmware [--device adis16505|icm42688|bmi088] [--imu-mounting R11,R12,..,R33] [--align-method static|inertial|fine|sway] [--imu-noise fog|rlg|mems-tactical|mems-consumer] [--bias-prior K] [--lever-arm X,Y,Z | --lever-arm-sigma S] [--base-translation M] [--frame wander|ned] [--attitude NAME] [--vertical free|hold] [--gnss FILE [--gnss-lever-arm X,Y,Z] [--propagation-rate HZ] [--gnss-correlated N,E,D [--gnss-correlated-time S]]] [--stream FILE] [--config-frame FILE] IMU_FILE OUT_FILE LAT_DEG LON_DEG H_M ALIGN_S [LOG_EVERY [CAL_FILE]]";

/// nav-core's noise model of a part's or grade's figures.
pub fn sensor_noise(n: &NoiseSpec) -> SensorNoise<f64> {
    SensorNoise {
        arw_rad_per_sqrt_s: n.gyro_arw_rad_per_sqrt_s,
        vrw_mps_per_sqrt_s: n.accel_vrw_mps_per_sqrt_s,
        gyro_bias_rad_s: n.gyro_bias_rad_s,
        accel_bias_mps2: n.accel_bias_mps2,
    }
}

impl Args {
    /// Parses the arguments after the program name: options (`--name value`, in any order),
    /// then the positional arguments. Values are checked for syntax here; the run
    /// configuration's values by [`RunConfig::validate`] and `Setup::new`.
    pub fn parse<'a>(args: impl Iterator<Item = &'a str>) -> Result<Self, ArgError<'a>> {
        let mut args = args.peekable();
        let mut device = Device::Adis16505;
        let mut imu_mounting = Mounting::IDENTITY;
        let mut noise: Option<NoiseSpec> = None;
        let mut lever_arm_given = (false, false);
        let mut base_translation_given = false;
        let mut gnss_path = None;
        let mut stream_path: Option<heapless::Vec<u8, MAX_PATH>> = None;
        let mut config_frame_path = None;
        // The run configuration's values wait for the positional site and window.
        let mut run = RunConfig::new(0.0, 0.0, 0.0, 0.0, SensorNoise::seed003());
        while let Some(name) = args.peek().and_then(|w| w.strip_prefix("--")) {
            args.next();
            let value = args.next().ok_or(ArgError::NoValue(name))?;
            match name {
                "device" => device = Device::parse(value).ok_or(ArgError::UnknownDevice(value))?,
                "imu-mounting" => {
                    imu_mounting = Mounting::parse_rows(value)
                        .filter(|m| m.is_rotation(MOUNTING_TOL))
                        .ok_or(ArgError::BadMounting)?;
                }
                "imu-noise" => {
                    noise = Some(grade::by_name(value).ok_or(ArgError::UnknownGrade(value))?);
                }
                "align-method" => {
                    run.align_method =
                        AlignMethod::from_name(value).ok_or(ArgError::UnknownMethod(value))?;
                }
                "gnss" => gnss_path = Some(c_path(value).ok_or(ArgError::BadGnssPath)?),
                "stream" => {
                    stream_path = Some(c_path(value).ok_or(ArgError::BadPath("--stream"))?);
                }
                "config-frame" => {
                    config_frame_path =
                        Some(c_path(value).ok_or(ArgError::BadPath("--config-frame"))?);
                }
                _ => {
                    match name {
                        "lever-arm" => lever_arm_given.0 = true,
                        "lever-arm-sigma" => lever_arm_given.1 = true,
                        "base-translation" => base_translation_given = true,
                        _ => {}
                    }
                    run.set(name, value).map_err(|e| match e {
                        OptionError::Unknown => ArgError::UnknownOption(name),
                        e => ArgError::Option(e),
                    })?;
                }
            }
        }
        if lever_arm_given == (true, true) {
            return Err(ArgError::LeverArmTwice);
        }
        if base_translation_given && !run.align_method.takes_base_translation() {
            return Err(ArgError::BaseTranslationStatic);
        }
        let mut next = |i: usize| args.next().ok_or(ArgError::Missing(NAMES[i]));
        let imu_path = c_path(next(0)?).ok_or(ArgError::Invalid(NAMES[0]))?;
        let out_path = c_path(next(1)?).ok_or(ArgError::Invalid(NAMES[1]))?;
        let num = |i: usize, s: &str| {
            s.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or(ArgError::Invalid(NAMES[i]))
        };
        run.lat_deg = num(2, next(2)?)?;
        run.lon_deg = num(3, next(3)?)?;
        run.h_m = num(4, next(4)?)?;
        run.align_seconds = num(5, next(5)?)?;
        if let Ok(s) = next(6) {
            run.log_every = s.parse::<u32>().map_err(|_| ArgError::Invalid(NAMES[6]))?;
        }
        let cal_path = match next(7) {
            Ok(s) => Some(c_path(s).ok_or(ArgError::Invalid(NAMES[7]))?),
            Err(_) => None,
        };
        if let Some(extra) = args.next() {
            return Err(ArgError::Extra(extra));
        }
        // Compared as written (`same_path`): the board refuses to overwrite a recording or a
        // fix file reached another way (an absolute path, a link).
        let is_out =
            |p: Option<&heapless::Vec<u8, MAX_PATH>>| p.is_some_and(|p| same_path(p, &out_path));
        if is_out(Some(&imu_path)) {
            return Err(ArgError::SameFile);
        }
        if is_out(gnss_path.as_ref()) {
            return Err(ArgError::GnssSameFile);
        }
        if is_out(cal_path.as_ref()) {
            return Err(ArgError::InputSameFile("CAL_FILE"));
        }
        if is_out(config_frame_path.as_ref()) {
            return Err(ArgError::InputSameFile("the --config-frame FILE"));
        }
        if let Some(stream) = &stream_path
            && [
                Some(&imu_path),
                Some(&out_path),
                gnss_path.as_ref(),
                cal_path.as_ref(),
                config_frame_path.as_ref(),
            ]
            .into_iter()
            .flatten()
            .any(|p| same_path(p, stream))
        {
            return Err(ArgError::StreamSameFile);
        }
        match (&gnss_path, &mut run.aiding) {
            (None, Some(_)) => return Err(ArgError::AidingWithoutGnss),
            (Some(_), aiding) => {
                aiding.get_or_insert_with(AidingConfig::default);
            }
            (None, None) => {}
        }
        // The device's datasheet figures unless a grade is given.
        let spec = noise.unwrap_or(device.noise());
        run.noise = sensor_noise(&spec);
        run.figures = spec.figures;
        Ok(Self {
            imu_path,
            out_path,
            cal_path,
            gnss_path,
            stream_path,
            config_frame_path,
            device,
            imu_mounting,
            run,
        })
    }

    /// The recording's path as a C string.
    pub fn imu_cstr(&self) -> &CStr {
        CStr::from_bytes_with_nul(&self.imu_path).unwrap_or(c"")
    }

    /// The calibration file's path as a C string, if one was given.
    pub fn cal_cstr(&self) -> Option<&CStr> {
        self.cal_path
            .as_ref()
            .map(|p| CStr::from_bytes_with_nul(p).unwrap_or(c""))
    }

    /// The GNSS fix file's path as a C string, if one was given.
    pub fn gnss_cstr(&self) -> Option<&CStr> {
        self.gnss_path
            .as_ref()
            .map(|p| CStr::from_bytes_with_nul(p).unwrap_or(c""))
    }

    /// The stream's path as a C string, if one was given.
    pub fn stream_cstr(&self) -> Option<&CStr> {
        self.stream_path
            .as_ref()
            .map(|p| CStr::from_bytes_with_nul(p).unwrap_or(c""))
    }

    /// The configuration frame file's path as a C string, if one was given.
    pub fn config_frame_cstr(&self) -> Option<&CStr> {
        self.config_frame_path
            .as_ref()
            .map(|p| CStr::from_bytes_with_nul(p).unwrap_or(c""))
    }

    /// The solution log's path as a C string.
    pub fn out_cstr(&self) -> &CStr {
        CStr::from_bytes_with_nul(&self.out_path).unwrap_or(c"")
    }
}

/// Whether the paths `a` and `b` (a trailing NUL ignored) name one file as written: compared
/// component by component, `.` and empty components left out and `name/..` resolved, so
/// `./rec.bin`, `logs//../rec.bin` and `rec.bin` are one file (the firmware overwrote the
/// recording given as `rec.bin ./rec.bin`). Absolute against relative paths and links are not
/// resolved here (the guest knows no working directory).
pub fn same_path(a: &[u8], b: &[u8]) -> bool {
    /// A path's absoluteness and its resolved components; `None` when it has more than fit.
    fn resolved(p: &[u8]) -> Option<(bool, heapless::Vec<&[u8], MAX_PATH>)> {
        let p = p.strip_suffix(&[0]).unwrap_or(p);
        let absolute = p.first() == Some(&b'/');
        let mut parts: heapless::Vec<&[u8], MAX_PATH> = heapless::Vec::new();
        for part in p.split(|&c| c == b'/') {
            match part {
                b"" | b"." => {}
                b".." if parts.last().is_some_and(|&l| l != b"..") => {
                    parts.pop();
                }
                // Above the root is the root.
                b".." if absolute => {}
                part => parts.push(part).ok()?,
            }
        }
        Some((absolute, parts))
    }
    match (resolved(a), resolved(b)) {
        (Some(a), Some(b)) => a == b,
        // Not reached: a path of at most MAX_PATH bytes has fewer components.
        _ => a == b,
    }
}

/// Copies a path and appends the NUL a semihosting open needs.
fn c_path(s: &str) -> Option<heapless::Vec<u8, MAX_PATH>> {
    if s.is_empty() || s.as_bytes().contains(&0) {
        return None;
    }
    let mut v = heapless::Vec::new();
    v.extend_from_slice(s.as_bytes()).ok()?;
    v.push(0).ok()?;
    Some(v)
}
