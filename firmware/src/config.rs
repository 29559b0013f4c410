//! The run configuration, given as semihosting arguments by the QEMU runner:
//! `firmware IMU_FILE OUT_FILE LAT_DEG LON_DEG H_M ALIGN_S [LOG_EVERY [CAL_FILE]]`.

use core::ffi::CStr;

/// Longest accepted path, including the terminating NUL.
pub const MAX_PATH: usize = 96;

/// What to replay and where to start.
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    /// Recording to replay (binary recording format), NUL-terminated.
    pub imu_path: heapless::Vec<u8, MAX_PATH>,
    /// Solution log to write (CSV), NUL-terminated.
    pub out_path: heapless::Vec<u8, MAX_PATH>,
    /// Initial latitude [deg].
    pub lat_deg: f64,
    /// Initial longitude [deg].
    pub lon_deg: f64,
    /// Initial ellipsoidal height [m].
    pub h_m: f64,
    /// Static alignment time [s].
    pub align_s: f64,
    /// Write a solution row every this many navigation steps.
    pub log_every: u32,
    /// Sensor calibration (nav-core's text form), NUL-terminated; none: identity.
    pub cal_path: Option<heapless::Vec<u8, MAX_PATH>>,
}

/// What is wrong with the arguments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum ConfigError {
    /// Fewer than the six required arguments.
    Missing(&'static str),
    /// An argument is not valid (name of the argument).
    Invalid(&'static str),
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
pub const USAGE: &str =
    "firmware IMU_FILE OUT_FILE LAT_DEG LON_DEG H_M ALIGN_S [LOG_EVERY [CAL_FILE]]";

impl Config {
    /// Parses the arguments after the program name.
    pub fn parse<'a>(mut args: impl Iterator<Item = &'a str>) -> Result<Self, ConfigError> {
        let mut next = |i: usize| args.next().ok_or(ConfigError::Missing(NAMES[i]));
        let imu_path = c_path(next(0)?).ok_or(ConfigError::Invalid(NAMES[0]))?;
        let out_path = c_path(next(1)?).ok_or(ConfigError::Invalid(NAMES[1]))?;
        let num = |i: usize, s: &str| {
            s.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or(ConfigError::Invalid(NAMES[i]))
        };
        let lat_deg = num(2, next(2)?)?;
        let lon_deg = num(3, next(3)?)?;
        let h_m = num(4, next(4)?)?;
        let align_s = num(5, next(5)?)?;
        let log_every = match next(6) {
            Ok(s) => s
                .parse::<u32>()
                .ok()
                .filter(|&n| n > 0)
                .ok_or(ConfigError::Invalid(NAMES[6]))?,
            Err(_) => 40,
        };
        let cal_path = match next(7) {
            Ok(s) => Some(c_path(s).ok_or(ConfigError::Invalid(NAMES[7]))?),
            Err(_) => None,
        };
        if !(-90.0..=90.0).contains(&lat_deg) {
            return Err(ConfigError::Invalid(NAMES[2]));
        }
        if !(align_s > 0.0 && align_s < 3600.0) {
            return Err(ConfigError::Invalid(NAMES[5]));
        }
        Ok(Self {
            imu_path,
            out_path,
            lat_deg,
            lon_deg,
            h_m,
            align_s,
            log_every,
            cal_path,
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

    /// The solution log's path as a C string.
    pub fn out_cstr(&self) -> &CStr {
        CStr::from_bytes_with_nul(&self.out_path).unwrap_or(c"")
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
