//! KF-GINS's YAML configuration file (`kf-gins.yaml`), read into SI units.
//!
//! The keys, units and defaults are KF-GINS's (`src/kf_gins.cpp`, `loadConfig` and `main`; its
//! example `dataset/kf-gins.yaml`):
//!
//! | key | unit in the file | field | unit |
//! | --- | --- | --- | --- |
//! | `imupath`, `gnsspath` | path | `imu_path`, `gnss_path` | |
//! | `outputpath` | path (a folder) | `output_dir` | |
//! | `imudatalen` | 7 or 8 columns | `imu_columns` | |
//! | `imudatarate` | Hz | `imu_rate_hz` | Hz |
//! | `starttime`, `endtime` | s of week (`endtime` < 0: to the end) | `start_time_s`, `end_time_s` | s |
//! | `initpos` | deg, deg, m | `init_lat_rad`, `init_lon_rad`, `init_h_m` | rad, rad, m |
//! | `initvel` | m/s N, E, D | `init_v_eb_n_m_s` | m/s |
//! | `initatt` | deg roll, pitch, yaw | `init_euler_rad` | rad |
//! | `initgyrbias`, `initaccbias` | deg/h, mGal | `init_gyro_bias_rad_s`, `init_accel_bias_m_s2` | rad/s, m/s^2 |
//! | `initgyrscale`, `initaccscale` | ppm | `init_gyro_scale`, `init_accel_scale` | - |
//! | `initposstd`, `initvelstd`, `initattstd` | m, m/s, deg | `init_pos_std_ned_m`, `init_vel_std_ned_m_s`, `init_att_std_rad` | m, m/s, rad |
//! | `initbgstd`, `initbastd` (optional) | deg/h, mGal | `init_gyro_bias_std_rad_s`, `init_accel_bias_std_m_s2` | rad/s, m/s^2 |
//! | `initsgstd`, `initsastd` (optional) | ppm | `init_gyro_scale_std`, `init_accel_scale_std` | - |
//! | `imunoise.arw`, `imunoise.vrw` | deg/sqrt(h), m/s/sqrt(h) | `arw_rad_sqrt_s`, `vrw_m_s_sqrt_s` | rad/sqrt(s), m/s/sqrt(s) |
//! | `imunoise.gbstd`, `imunoise.abstd` | deg/h, mGal | `gyro_bias_std_rad_s`, `accel_bias_std_m_s2` | rad/s, m/s^2 |
//! | `imunoise.gsstd`, `imunoise.asstd` | ppm | `gyro_scale_std`, `accel_scale_std` | - |
//! | `imunoise.corrtime` | h | `corr_time_s` | s |
//! | `antlever` | m, body forward, right, down | `lever_arm_b_m` | m |
//!
//! The optional initial sensor-error sigmas default, as in KF-GINS, to the `imunoise` values
//! (`gbstd`, `abstd`, `gsstd`, `asstd`). 1 mGal = 1e-5 m/s^2; 1 ppm = 1e-6.
//!
//! **Paths.** KF-GINS opens its paths as written, relative to the directory it runs in. A
//! relative path is resolved the same way (against the current directory) when that file or
//! folder exists, else against the configuration file's directory when it exists there, else
//! left relative to the current directory (opening it then names it). `nav kf-gins` prints the
//! paths it reads, and warns when `imupath` and `gnsspath` were found in different folders or
//! an input is found in both (two different files).
//!
//! **Checks** (each message names the file and the key): a missing required key, an array that
//! is not 3 numbers, a value that is not finite, a negative standard deviation or noise density,
//! a rate that is not positive, `corrtime` <= 0, `imudatalen` other than 7 or 8, a latitude
//! outside [-90, 90] deg, a time outside a GNSS week (0 to 604800 s), `endtime` before
//! `starttime` (a negative `endtime` means "to the end of the IMU file", as KF-GINS takes any
//! negative value), an empty path, a file of no keys. Where 3 numbers are expected, what was
//! found instead is named with the key; other YAML syntax and type errors carry the parser's
//! line and column. Keys KF-GINS does not read are ignored and listed in the returned warnings.

use anyhow::{Result, bail};
use nav_core::number::Number;
use serde::Deserialize;
use serde::de::IgnoredAny;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Seconds in a GNSS week: the largest time of week [s].
pub const WEEK_S: f64 = 604_800.0;

/// KF-GINS's configuration, in SI units (see the module docs for the keys).
#[derive(Clone, Debug, PartialEq)]
pub struct KfGinsConfig {
    /// IMU text file (`imupath`), resolved (module docs).
    pub imu_path: PathBuf,
    /// GNSS text file (`gnsspath`), resolved.
    pub gnss_path: PathBuf,
    /// Output folder (`outputpath`), resolved.
    pub output_dir: PathBuf,
    /// Columns of the IMU file (`imudatalen`): 7, or 8 with an odometer column.
    pub imu_columns: usize,
    /// IMU data rate (`imudatarate`) [Hz].
    pub imu_rate_hz: f64,
    /// Start of processing (`starttime`), GNSS seconds of week [s].
    pub start_time_s: f64,
    /// End of processing (`endtime`), GNSS seconds of week [s]; `None`: to the end of the IMU
    /// file (`endtime` negative).
    pub end_time_s: Option<f64>,
    /// Initial geodetic latitude [rad].
    pub init_lat_rad: f64,
    /// Initial longitude [rad].
    pub init_lon_rad: f64,
    /// Initial ellipsoidal height [m].
    pub init_h_m: f64,
    /// Initial velocity relative to the Earth, north, east, down [m/s].
    pub init_v_eb_n_m_s: [f64; 3],
    /// Initial roll, pitch, yaw (z-y-x Euler angles of FRD body to NED) [rad].
    pub init_euler_rad: [f64; 3],
    /// Initial gyro bias, body axes [rad/s].
    pub init_gyro_bias_rad_s: [f64; 3],
    /// Initial accelerometer bias, body axes [m/s^2].
    pub init_accel_bias_m_s2: [f64; 3],
    /// Initial gyro scale-factor error, body axes [-].
    pub init_gyro_scale: [f64; 3],
    /// Initial accelerometer scale-factor error, body axes [-].
    pub init_accel_scale: [f64; 3],
    /// Initial position 1-sigma north, east, down [m].
    pub init_pos_std_ned_m: [f64; 3],
    /// Initial velocity 1-sigma north, east, down [m/s].
    pub init_vel_std_ned_m_s: [f64; 3],
    /// Initial roll, pitch, yaw 1-sigma [rad].
    pub init_att_std_rad: [f64; 3],
    /// Initial gyro bias 1-sigma [rad/s] (`initbgstd`, default `imunoise.gbstd`).
    pub init_gyro_bias_std_rad_s: [f64; 3],
    /// Initial accelerometer bias 1-sigma [m/s^2] (`initbastd`, default `imunoise.abstd`).
    pub init_accel_bias_std_m_s2: [f64; 3],
    /// Initial gyro scale-factor 1-sigma [-] (`initsgstd`, default `imunoise.gsstd`).
    pub init_gyro_scale_std: [f64; 3],
    /// Initial accelerometer scale-factor 1-sigma [-] (`initsastd`, default `imunoise.asstd`).
    pub init_accel_scale_std: [f64; 3],
    /// The IMU noise model (`imunoise`).
    pub imu_noise: KfGinsImuNoise,
    /// GNSS antenna position relative to the IMU, body forward, right, down (`antlever`) [m].
    pub lever_arm_b_m: [f64; 3],
}

/// KF-GINS's IMU noise model (`imunoise`): white noise, and first-order Gauss-Markov bias and
/// scale-factor errors with one correlation time.
#[derive(Clone, Debug, PartialEq)]
pub struct KfGinsImuNoise {
    /// Angle random walk, body axes [rad/sqrt(s)].
    pub arw_rad_sqrt_s: [f64; 3],
    /// Velocity random walk, body axes [m/s/sqrt(s)].
    pub vrw_m_s_sqrt_s: [f64; 3],
    /// Gyro bias instability 1-sigma [rad/s].
    pub gyro_bias_std_rad_s: [f64; 3],
    /// Accelerometer bias instability 1-sigma [m/s^2].
    pub accel_bias_std_m_s2: [f64; 3],
    /// Gyro scale-factor 1-sigma [-].
    pub gyro_scale_std: [f64; 3],
    /// Accelerometer scale-factor 1-sigma [-].
    pub accel_scale_std: [f64; 3],
    /// Correlation time of the Gauss-Markov processes [s].
    pub corr_time_s: f64,
}

/// The file as written: every key optional here, so a missing one gets a message naming it.
#[derive(Debug, Deserialize)]
struct RawConfig {
    imupath: Option<String>,
    gnsspath: Option<String>,
    outputpath: Option<String>,
    imudatalen: Option<f64>,
    imudatarate: Option<f64>,
    starttime: Option<f64>,
    endtime: Option<f64>,
    initpos: Option<Numbers>,
    initvel: Option<Numbers>,
    initatt: Option<Numbers>,
    initgyrbias: Option<Numbers>,
    initaccbias: Option<Numbers>,
    initgyrscale: Option<Numbers>,
    initaccscale: Option<Numbers>,
    initposstd: Option<Numbers>,
    initvelstd: Option<Numbers>,
    initattstd: Option<Numbers>,
    initbgstd: Option<Numbers>,
    initbastd: Option<Numbers>,
    initsgstd: Option<Numbers>,
    initsastd: Option<Numbers>,
    imunoise: Option<RawNoise>,
    antlever: Option<Numbers>,
    #[serde(flatten)]
    unknown: BTreeMap<String, IgnoredAny>,
}

#[derive(Debug, Deserialize)]
struct RawNoise {
    arw: Option<Numbers>,
    vrw: Option<Numbers>,
    gbstd: Option<Numbers>,
    abstd: Option<Numbers>,
    gsstd: Option<Numbers>,
    asstd: Option<Numbers>,
    corrtime: Option<f64>,
    #[serde(flatten)]
    unknown: BTreeMap<String, IgnoredAny>,
}

/// A value where numbers are expected, as written: the numbers, or what was found instead
/// (the parser's "expected sequence start" named neither the key nor what it wanted).
#[derive(Debug)]
struct Numbers(std::result::Result<Vec<f64>, String>);

impl<'de> Deserialize<'de> for Numbers {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        Ok(Numbers(match Written::deserialize(d)? {
            Written::Sequence(items) => items
                .into_iter()
                .enumerate()
                .map(|(k, e)| {
                    e.number()
                        .map_err(|what| format!("{what} as value {}", k + 1))
                })
                .collect(),
            Written::Number { text, .. } => Err(format!("a single number ({text})")),
            Written::Mapping => Err("a mapping (keys and values)".to_owned()),
            other => Err(other.number().map_or_else(
                |what| what,
                |_| format!("a single number ({})", other.text()),
            )),
        }))
    }
}

/// A YAML value as written, as far as [`Numbers`] tells it.
#[derive(Debug)]
enum Written {
    /// A number, and its text for a message.
    Number {
        value: f64,
        text: String,
    },
    Text(String),
    Bool(bool),
    Nothing,
    Sequence(Vec<Written>),
    Mapping,
}

impl Written {
    /// The number it is (text that reads as one too), or what it is instead.
    fn number(&self) -> std::result::Result<f64, String> {
        match self {
            Written::Number { value, .. } => Ok(*value),
            Written::Text(text) => text
                .trim()
                .parse::<f64>()
                .map_err(|_| format!("the text '{text}'")),
            Written::Bool(b) => Err(format!("'{b}'")),
            Written::Nothing => Err("nothing".to_owned()),
            Written::Sequence(_) => Err("a sequence".to_owned()),
            Written::Mapping => Err("a mapping".to_owned()),
        }
    }

    /// The text of a number or a text.
    fn text(&self) -> &str {
        match self {
            Written::Number { text, .. } | Written::Text(text) => text,
            _ => "",
        }
    }
}

impl<'de> Deserialize<'de> for Written {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        d.deserialize_any(WrittenVisitor)
    }
}

struct WrittenVisitor;

impl<'de> serde::de::Visitor<'de> for WrittenVisitor {
    type Value = Written;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a sequence of numbers")
    }

    fn visit_f64<E>(self, x: f64) -> std::result::Result<Written, E> {
        let text = Number(x).to_string();
        Ok(Written::Number { value: x, text })
    }

    fn visit_i64<E>(self, x: i64) -> std::result::Result<Written, E> {
        let text = x.to_string();
        Ok(Written::Number {
            value: x as f64,
            text,
        })
    }

    fn visit_u64<E>(self, x: u64) -> std::result::Result<Written, E> {
        let text = x.to_string();
        Ok(Written::Number {
            value: x as f64,
            text,
        })
    }

    fn visit_str<E>(self, text: &str) -> std::result::Result<Written, E> {
        Ok(Written::Text(text.to_owned()))
    }

    fn visit_bool<E>(self, b: bool) -> std::result::Result<Written, E> {
        Ok(Written::Bool(b))
    }

    fn visit_unit<E>(self) -> std::result::Result<Written, E> {
        Ok(Written::Nothing)
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(
        self,
        mut seq: A,
    ) -> std::result::Result<Written, A::Error> {
        let mut items = Vec::new();
        while let Some(e) = seq.next_element::<Written>()? {
            items.push(e);
        }
        Ok(Written::Sequence(items))
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(
        self,
        mut map: A,
    ) -> std::result::Result<Written, A::Error> {
        while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
        Ok(Written::Mapping)
    }
}

/// deg/h -> rad/s.
const DEG_PER_H: f64 = std::f64::consts::PI / 180.0 / 3600.0;
/// mGal -> m/s^2.
const MGAL: f64 = 1e-5;
/// ppm -> 1.
const PPM: f64 = 1e-6;
/// 1/sqrt(h) -> 1/sqrt(s).
const PER_SQRT_H: f64 = 1.0 / 60.0;

/// Reads and checks KF-GINS's configuration file `path`: the configuration in SI units and one
/// warning per key that KF-GINS does not read.
pub fn load(path: &Path) -> Result<(KfGinsConfig, Vec<String>)> {
    let text = crate::text_error::read_text(path)?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    parse(&text, path, dir)
}

/// Parses configuration `text`; `path` names it in messages, relative paths are resolved
/// against the current directory or `dir` (module docs).
pub fn parse(text: &str, path: &Path, dir: &Path) -> Result<(KfGinsConfig, Vec<String>)> {
    // An empty file (or comments only) read as a configuration of no keys: "missing key
    // 'imunoise'" blamed one key of many.
    if let Ok(None) = serde_saphyr::from_str::<Option<BTreeMap<String, IgnoredAny>>>(text)
        .map(|keys| keys.filter(|k| !k.is_empty()))
    {
        bail!(
            "{}: no keys (an empty file, or comments only): a KF-GINS configuration gives \
             imupath, gnsspath, outputpath, imudatalen, imudatarate, starttime, endtime, the \
             initial state and its 1-sigma, imunoise and antlever",
            path.display()
        );
    }
    // `.nan` and `.inf` reach the checks, which name the key (the parser refuses them in a
    // value read as any type, as the numbers of [`Numbers`] are, with no key).
    let mut options = serde_saphyr::Options::default();
    options.non_finite_float_policy = serde_saphyr::NonFiniteFloatPolicy::PassThrough;
    let raw: RawConfig = serde_saphyr::from_str_with_options(text, options).map_err(|e| {
        let inner = match &e {
            serde_saphyr::Error::WithSnippet { error, .. } => error.as_ref(),
            e => e,
        };
        match inner {
            // The parser's own words name its API ("use from_str_multiple ...").
            serde_saphyr::Error::MultipleDocuments { location, .. } => anyhow::anyhow!(
                "{}: line {}: a second YAML document (after '---'): a KF-GINS configuration \
                 is one document",
                path.display(),
                location.line()
            ),
            _ => anyhow::anyhow!("{}: not a KF-GINS configuration: {e}", path.display()),
        }
    })?;
    let c = Check { path };
    let mut warnings: Vec<String> = raw
        .unknown
        .keys()
        .map(|k| {
            format!(
                "{}: key '{k}' ignored (KF-GINS does not read it)",
                path.display()
            )
        })
        .collect();

    let noise = c.required("imunoise", raw.imunoise, "the IMU noise parameters")?;
    warnings.extend(noise.unknown.keys().map(|k| {
        format!(
            "{}: key 'imunoise.{k}' ignored (KF-GINS does not read it)",
            path.display()
        )
    }));
    let imu_noise = KfGinsImuNoise {
        arw_rad_sqrt_s: c.density3(
            "imunoise.arw",
            noise.arw,
            "deg/sqrt(h)",
            1f64.to_radians() * PER_SQRT_H,
        )?,
        vrw_m_s_sqrt_s: c.density3("imunoise.vrw", noise.vrw, "m/s/sqrt(h)", PER_SQRT_H)?,
        gyro_bias_std_rad_s: c.std3("imunoise.gbstd", noise.gbstd, "deg/h", DEG_PER_H)?,
        accel_bias_std_m_s2: c.std3("imunoise.abstd", noise.abstd, "mGal", MGAL)?,
        gyro_scale_std: c.std3("imunoise.gsstd", noise.gsstd, "ppm", PPM)?,
        accel_scale_std: c.std3("imunoise.asstd", noise.asstd, "ppm", PPM)?,
        corr_time_s: {
            let h = c.number("imunoise.corrtime", noise.corrtime, "h")?;
            if h <= 0.0 {
                bail!(c.key("imunoise.corrtime", format!("{} h: must be > 0", Number(h))));
            }
            h * 3600.0
        },
    };

    let imu_columns = {
        let n = c.number("imudatalen", raw.imudatalen, "columns")?;
        if n != 7.0 && n != 8.0 {
            bail!(c.key(
                "imudatalen",
                format!(
                    "{}: expected 7 (time, 3 gyro, 3 accelerometer) or 8 (and an odometer)",
                    Number(n)
                )
            ));
        }
        n as usize
    };
    let imu_rate_hz = c.number("imudatarate", raw.imudatarate, "Hz")?;
    if imu_rate_hz <= 0.0 {
        bail!(c.key(
            "imudatarate",
            format!("{} Hz: must be > 0", Number(imu_rate_hz))
        ));
    }
    let start_time_s = c.number("starttime", raw.starttime, "s of week")?;
    if !(0.0..=WEEK_S).contains(&start_time_s) {
        bail!(c.key(
            "starttime",
            format!(
                "{} s: a time of week is within 0 to {WEEK_S} s",
                Number(start_time_s)
            )
        ));
    }
    let end = c.number("endtime", raw.endtime, "s of week, -1: to the end")?;
    let end_time_s = if end < 0.0 {
        None
    } else if end > WEEK_S {
        bail!(c.key(
            "endtime",
            format!(
                "{} s: a time of week is within 0 to {WEEK_S} s (-1: to the end)",
                Number(end)
            )
        ));
    } else if end < start_time_s {
        bail!(c.key(
            "endtime",
            format!(
                "{} s is before starttime {} s (-1: to the end)",
                Number(end),
                Number(start_time_s)
            )
        ));
    } else {
        Some(end)
    };

    let pos = c.array3("initpos", raw.initpos, "[lat deg, lon deg, h m]")?;
    if !(-90.0..=90.0).contains(&pos[0]) {
        bail!(c.key(
            "initpos",
            format!("latitude {} deg is outside [-90, 90]", Number(pos[0]))
        ));
    }
    let deg = |v: [f64; 3]| v.map(f64::to_radians);
    let scaled = |v: [f64; 3], k: f64| v.map(|x| x * k);
    let imu_path = c.file_path("imupath", raw.imupath, dir, &mut warnings)?;
    let gnss_path = c.file_path("gnsspath", raw.gnsspath, dir, &mut warnings)?;
    // One input from the current directory, the other beside the configuration: two data sets
    // mixed (an unrelated imu.txt where the run started), each file valid on its own.
    let here = |f: &Found| matches!(f, Found::Here | Found::HereAndBeside(_));
    if here(&imu_path.1) && gnss_path.1 == Found::Beside
        || imu_path.1 == Found::Beside && here(&gnss_path.1)
    {
        warnings.push(format!(
            "{}: imupath {} and gnsspath {} were found in different folders (the current one, \
             then the configuration's): check that they are one data set",
            path.display(),
            imu_path.0.display(),
            gnss_path.0.display()
        ));
    }
    let config = KfGinsConfig {
        imu_path: imu_path.0,
        gnss_path: gnss_path.0,
        output_dir: c.path("outputpath", raw.outputpath, dir)?.0,
        imu_columns,
        imu_rate_hz,
        start_time_s,
        end_time_s,
        init_lat_rad: pos[0].to_radians(),
        init_lon_rad: pos[1].to_radians(),
        init_h_m: pos[2],
        init_v_eb_n_m_s: c.array3("initvel", raw.initvel, "[m/s north, east, down]")?,
        init_euler_rad: deg(c.array3("initatt", raw.initatt, "[deg roll, pitch, yaw]")?),
        init_gyro_bias_rad_s: scaled(
            c.array3("initgyrbias", raw.initgyrbias, "[deg/h]")?,
            DEG_PER_H,
        ),
        init_accel_bias_m_s2: scaled(c.array3("initaccbias", raw.initaccbias, "[mGal]")?, MGAL),
        init_gyro_scale: scaled(c.array3("initgyrscale", raw.initgyrscale, "[ppm]")?, PPM),
        init_accel_scale: scaled(c.array3("initaccscale", raw.initaccscale, "[ppm]")?, PPM),
        init_pos_std_ned_m: c.start_std3("initposstd", raw.initposstd, "m", 1.0)?,
        init_vel_std_ned_m_s: c.start_std3("initvelstd", raw.initvelstd, "m/s", 1.0)?,
        init_att_std_rad: c.start_std3("initattstd", raw.initattstd, "deg", 1f64.to_radians())?,
        init_gyro_bias_std_rad_s: match raw.initbgstd {
            None => imu_noise.gyro_bias_std_rad_s,
            v => c.std3("initbgstd", v, "deg/h", DEG_PER_H)?,
        },
        init_accel_bias_std_m_s2: match raw.initbastd {
            None => imu_noise.accel_bias_std_m_s2,
            v => c.std3("initbastd", v, "mGal", MGAL)?,
        },
        init_gyro_scale_std: match raw.initsgstd {
            None => imu_noise.gyro_scale_std,
            v => c.std3("initsgstd", v, "ppm", PPM)?,
        },
        init_accel_scale_std: match raw.initsastd {
            None => imu_noise.accel_scale_std,
            v => c.std3("initsastd", v, "ppm", PPM)?,
        },
        lever_arm_b_m: c.array3("antlever", raw.antlever, "[m forward, right, down]")?,
        imu_noise,
    };
    Ok((config, warnings))
}

/// The checks of one file's values, each message naming the file and the key.
struct Check<'a> {
    path: &'a Path,
}

impl Check<'_> {
    /// A message about `key`.
    fn key(&self, key: &str, what: impl std::fmt::Display) -> String {
        format!("{}: key '{key}': {what}", self.path.display())
    }

    fn required<T>(&self, key: &str, value: Option<T>, what: &str) -> Result<T> {
        value
            .ok_or_else(|| anyhow::anyhow!("{}: missing key '{key}' ({what})", self.path.display()))
    }

    /// A finite number.
    fn number(&self, key: &str, value: Option<f64>, unit: &str) -> Result<f64> {
        let x = self.required(key, value, &format!("a number [{unit}]"))?;
        if !x.is_finite() {
            bail!(self.key(key, format!("{x} is not a finite number [{unit}]")));
        }
        Ok(x)
    }

    /// Three finite numbers.
    fn array3(&self, key: &str, value: Option<Numbers>, what: &str) -> Result<[f64; 3]> {
        let v = self.required(key, value, &format!("3 numbers {what}"))?;
        let v = v.0.map_err(|found| {
            anyhow::anyhow!(self.key(key, format!("expected 3 numbers {what}, found {found}")))
        })?;
        let Ok(v) = <[f64; 3]>::try_from(v.as_slice()) else {
            bail!(self.key(key, format!("expected 3 numbers {what}, found {}", v.len())));
        };
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            bail!(self.key(
                key,
                format!("value {} ({}) is not a finite number", i + 1, v[i])
            ));
        }
        Ok(v)
    }

    /// Three non-negative standard deviations in `unit`, times `to_si`.
    fn std3(&self, key: &str, value: Option<Numbers>, unit: &str, to_si: f64) -> Result<[f64; 3]> {
        let v = self.array3(key, value, &format!("[{unit}]"))?;
        if let Some(i) = v.iter().position(|x| *x < 0.0) {
            bail!(self.key(
                key,
                format!(
                    "value {} ({} {unit}) is negative: a standard deviation is >= 0",
                    i + 1,
                    Number(v[i])
                )
            ));
        }
        Ok(v.map(|x| x * to_si))
    }

    /// Three positive standard deviations of the start's state ([`Self::std3`], a zero
    /// refused: it would claim an exactly known state, which no fix could then correct).
    fn start_std3(
        &self,
        key: &str,
        value: Option<Numbers>,
        unit: &str,
        to_si: f64,
    ) -> Result<[f64; 3]> {
        self.positive3(
            key,
            value,
            unit,
            to_si,
            "the start's 1-sigma must be positive (a zero claims an exactly known state)",
        )
    }

    /// Three positive white-noise densities ([`Self::std3`], a zero refused: a noiseless
    /// sensor makes the filter trust its own prediction over every fix).
    fn density3(
        &self,
        key: &str,
        value: Option<Numbers>,
        unit: &str,
        to_si: f64,
    ) -> Result<[f64; 3]> {
        self.positive3(
            key,
            value,
            unit,
            to_si,
            "a noise density must be positive (a noiseless sensor makes the filter trust its \
             prediction over every fix)",
        )
    }

    /// [`Self::std3`] with a zero refused, `why` the refusal's reason.
    fn positive3(
        &self,
        key: &str,
        value: Option<Numbers>,
        unit: &str,
        to_si: f64,
        why: &str,
    ) -> Result<[f64; 3]> {
        let v = self.std3(key, value, unit, to_si)?;
        if let Some(i) = v.iter().position(|x| *x == 0.0) {
            bail!(self.key(key, format!("value {} is 0 {unit}: {why}", i + 1)));
        }
        Ok(v)
    }

    /// A path, resolved as KF-GINS would find it, else beside the configuration file, and
    /// where it was found.
    fn path(&self, key: &str, value: Option<String>, dir: &Path) -> Result<(PathBuf, Found)> {
        let text = self.required(key, value, "a path")?;
        if text.is_empty() {
            bail!(self.key(key, "the path is empty"));
        }
        let p = PathBuf::from(text);
        if p.is_absolute() {
            return Ok((p, Found::Absolute));
        }
        let beside = dir.join(&p);
        Ok(match (p.exists(), beside.exists()) {
            (true, true) if !same_file(&p, &beside) => (p, Found::HereAndBeside(beside)),
            (true, _) => (p, Found::Here),
            (false, true) => (beside, Found::Beside),
            (false, false) => (p, Found::Nowhere),
        })
    }

    /// [`Self::path`] of a file to read: a folder is refused naming the key (it was read as
    /// a text file: ".: line 1: Is a directory (os error 21)"); a relative path found both
    /// here and, another file, beside the configuration is warned about in `warnings`.
    fn file_path(
        &self,
        key: &str,
        value: Option<String>,
        dir: &Path,
        warnings: &mut Vec<String>,
    ) -> Result<(PathBuf, Found)> {
        let (p, found) = self.path(key, value, dir)?;
        if p.is_dir() {
            bail!(self.key(key, format_args!("{} is a folder, not a file", p.display())));
        }
        if let Found::HereAndBeside(other) = &found {
            warnings.push(self.key(
                key,
                format_args!(
                    "{} is read from the current folder, as KF-GINS reads it; the \
                     configuration's folder has another ({})",
                    p.display(),
                    other.display()
                ),
            ));
        }
        Ok((p, found))
    }
}

/// Where a relative path of the configuration was found (module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
enum Found {
    /// Absolute: no folder to choose.
    Absolute,
    /// Relative to the current folder.
    Here,
    /// Relative to the current folder, and another file of that name is beside the
    /// configuration (its path).
    HereAndBeside(PathBuf),
    /// Relative to the configuration file's folder.
    Beside,
    /// In neither (left relative to the current folder; opening it names it).
    Nowhere,
}

/// True when `a` and `b` name one file (both canonical paths equal).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Written like KF-GINS's `dataset/kf-gins.yaml` (comments, flow sequences, the optional
    /// sigmas commented out), with one key KF-GINS does not read.
    pub(crate) const EXAMPLE: &str = r#"# KF-GINS configuration file

# imudata and gnssdata filepath
imupath: "./dataset/Leador-A15.txt"
gnsspath: "./dataset/GNSS-RTK.txt"

# output folder path
outputpath: "./dataset"

# IMU data columns, only use the first seven columns
imudatalen: 7
# IMU datarate [Hz]
imudatarate: 200

# processing interval[s]
# process until the imufile end if set endtime to -1
starttime: 456300
endtime: -1

# initial position, latitude, longitude, altitude. [deg, deg, m]
initpos: [ 30.4447873701, 114.4718632047, 20.899 ]
initvel: [ 0.0, 0.0, 0.0 ]
# initial attitude, euler angle(ZYX rotation), roll, pitch, yaw [deg, deg, deg]
initatt: [ 0.85421502, -2.03480295, 185.70235133 ]

initgyrbias: [ 0, 0, 0 ]    # [deg/h]
initaccbias: [ 0, 0, 0 ]    # [mGal]
initgyrscale: [ 0, 0, 0 ]   # [ppm]
initaccscale: [ 0, 0, 0 ]   # [ppm]

initposstd: [ 0.005, 0.004, 0.008 ]
initvelstd: [ 0.003, 0.004, 0.004 ]
initattstd: [ 0.003, 0.003, 0.023 ]

# default to the noise parameters of IMU bias and scale error.
#initbgstd: [ 1, 1, 1 ]          # [deg/h]
#initbastd: [ 50, 50, 50 ]       # [mGal]

imunoise:
  arw: [0.003, 0.003, 0.003]          # [deg/sqrt(hr)]
  vrw: [0.03, 0.03, 0.03]          # [m/s/sqrt(hr)]
  gbstd: [0.027, 0.027, 0.027]        # [deg/hr]
  abstd: [15.0, 15.0, 15.0]     # [mGal]
  gsstd: [300.0, 300.0, 300.0]  # [ppm]
  asstd: [300.0, 300.0, 300.0]  # [ppm]
  corrtime: 4.0                    # [hr]

# antenna lever, forward, right and down in the imu frame. [m]
antlever:  [ 0.136, -0.301, -0.184 ]
odolever: [ 1, 2, 3 ]
"#;

    fn parse_text(text: &str) -> Result<(KfGinsConfig, Vec<String>)> {
        parse(text, Path::new("kf.yaml"), Path::new("/nonexistent"))
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-15 * b.abs().max(1e-300)
    }

    #[test]
    fn reads_kf_gins_example_in_si() {
        let (c, warnings) = parse_text(EXAMPLE).unwrap();
        assert_eq!(c.imu_path, PathBuf::from("./dataset/Leador-A15.txt"));
        assert_eq!(c.output_dir, PathBuf::from("./dataset"));
        assert_eq!((c.imu_columns, c.imu_rate_hz), (7, 200.0));
        assert_eq!((c.start_time_s, c.end_time_s), (456_300.0, None));
        assert_eq!(c.init_lat_rad, 30.4447873701_f64.to_radians());
        assert_eq!(c.init_h_m, 20.899);
        assert_eq!(c.init_euler_rad[2], 185.70235133_f64.to_radians());
        assert_eq!(c.init_att_std_rad[2], 0.023 * 1f64.to_radians());
        let n = &c.imu_noise;
        // 0.003 deg/sqrt(h) = 0.003 * pi/180 / 60 rad/sqrt(s).
        assert!(close(
            n.arw_rad_sqrt_s[0],
            0.003 * std::f64::consts::PI / 180.0 / 60.0
        ));
        assert!(close(n.vrw_m_s_sqrt_s[1], 0.03 / 60.0));
        assert!(close(
            n.gyro_bias_std_rad_s[2],
            0.027 * std::f64::consts::PI / 180.0 / 3600.0
        ));
        assert!(close(n.accel_bias_std_m_s2[0], 15.0e-5));
        assert!(close(n.gyro_scale_std[0], 300e-6));
        assert_eq!(n.corr_time_s, 4.0 * 3600.0);
        // The optional initial sigmas default to the noise model's.
        assert_eq!(c.init_gyro_bias_std_rad_s, n.gyro_bias_std_rad_s);
        assert_eq!(c.init_accel_bias_std_m_s2, n.accel_bias_std_m_s2);
        assert_eq!(c.init_gyro_scale_std, n.gyro_scale_std);
        assert_eq!(c.init_accel_scale_std, n.accel_scale_std);
        assert_eq!(c.lever_arm_b_m, [0.136, -0.301, -0.184]);
        assert_eq!(warnings.len(), 1);
        assert!(warnings[0].contains("'odolever' ignored"), "{warnings:?}");
    }

    #[test]
    fn given_optional_sigmas_are_used() {
        let text = EXAMPLE.replace("#initbgstd: [ 1, 1, 1 ]", "initbgstd: [ 1, 2, 3 ]");
        let (c, _) = parse_text(&text).unwrap();
        assert!(close(c.init_gyro_bias_std_rad_s[1], 2.0 * DEG_PER_H));
        let text = EXAMPLE.replace("endtime: -1", "endtime: 457000.5");
        assert_eq!(parse_text(&text).unwrap().0.end_time_s, Some(457_000.5));
    }

    #[test]
    fn bad_values_name_the_key() {
        let msg = |from: &str, to: &str| {
            let text = EXAMPLE.replace(from, to);
            assert_ne!(text, EXAMPLE, "{from}");
            format!("{:#}", parse_text(&text).unwrap_err())
        };
        let cases = [
            (
                "gnsspath: \"./dataset/GNSS-RTK.txt\"\n",
                "",
                "missing key 'gnsspath'",
            ),
            (
                "corrtime: 4.0",
                "corrtimes: 4.0",
                "missing key 'imunoise.corrtime'",
            ),
            (
                "initvel: [ 0.0, 0.0, 0.0 ]",
                "initvel: [ 0.0, 0.0 ]",
                "key 'initvel': expected 3 numbers",
            ),
            (
                "initvel: [ 0.0, 0.0, 0.0 ]",
                "initvel: [ 0.0, .nan, 0.0 ]",
                "key 'initvel': value 2 (NaN) is not a finite",
            ),
            (
                "endtime: -1",
                "endtime: .inf",
                "key 'endtime': inf is not a finite",
            ),
            (
                "initposstd: [ 0.005, 0.004, 0.008 ]",
                "initposstd: [ 0.005, -0.004, 0.008 ]",
                "key 'initposstd': value 2 (-0.004 m) is negative",
            ),
            (
                "initattstd: [ 0.003, 0.003, 0.023 ]",
                "initattstd: [ 0.003, 0, 0.023 ]",
                "key 'initattstd': value 2 is 0 deg",
            ),
            (
                "arw: [0.003, 0.003, 0.003]",
                "arw: [0.003, 0.003, -0.003]",
                "key 'imunoise.arw': value 3",
            ),
            (
                "imudatarate: 200",
                "imudatarate: 0",
                "key 'imudatarate': 0 Hz: must be > 0",
            ),
            (
                "corrtime: 4.0",
                "corrtime: 0",
                "key 'imunoise.corrtime': 0 h: must be > 0",
            ),
            (
                "endtime: -1",
                "endtime: 456000",
                "key 'endtime': 456000 s is before starttime 456300 s",
            ),
            (
                "imudatalen: 7",
                "imudatalen: 9",
                "key 'imudatalen': 9: expected 7",
            ),
            ("starttime: 456300", "starttime: 700000", "key 'starttime'"),
            (
                "vrw: [0.03, 0.03, 0.03]",
                "vrw: [0.03, 0, 0.03]",
                "key 'imunoise.vrw': value 2 is 0 m/s/sqrt(h): a noise density must be positive",
            ),
            // A huge value reads as typed, not as 301 digits.
            (
                "starttime: 456300",
                "starttime: 1e300",
                "key 'starttime': 1e300 s: a time of week",
            ),
            (
                "initpos: [ 30.4447873701,",
                "initpos: [ 95,",
                "key 'initpos': latitude 95 deg",
            ),
            (
                "imupath: \"./dataset/Leador-A15.txt\"",
                "imupath: \"\"",
                "key 'imupath': the path is empty",
            ),
            // A folder read as a text file: ".: line 1: Is a directory (os error 21)".
            (
                "imupath: \"./dataset/Leador-A15.txt\"",
                "imupath: \".\"",
                "key 'imupath': . is a folder, not a file",
            ),
        ];
        for (from, to, expected) in cases {
            let m = msg(from, to);
            assert!(m.starts_with("kf.yaml: "), "{m}");
            assert!(m.contains(expected), "{expected}: {m}");
        }
        // Where 3 numbers are expected: the key and what was found ("line 19 column 8:
        // expected sequence start" before).
        for (to, found) in [
            ("arw: 0.2", "found a single number (0.2)"),
            ("arw: fast", "found the text 'fast'"),
            ("arw: [0.2, x, 0.2]", "found the text 'x' as value 2"),
            ("arw: {x: 1}", "found a mapping"),
        ] {
            let m = msg("arw: [0.003, 0.003, 0.003]", to);
            assert!(
                m.contains(&format!(
                    "kf.yaml: key 'imunoise.arw': expected 3 numbers [deg/sqrt(h)], {found}"
                )),
                "{to}: {m}"
            );
        }
        // Type and syntax errors: the parser's position.
        let m = msg("imudatarate: 200", "imudatarate: fast");
        assert!(m.starts_with("kf.yaml: not a KF-GINS configuration"), "{m}");
        assert!(m.contains("line 13"), "{m}");
    }

    /// An empty file said "missing key 'imunoise'", one key of many.
    #[test]
    fn an_empty_file_is_told_as_such() {
        for text in [
            "",
            "\n\n",
            "# KF-GINS configuration file\n",
            "---\n",
            "{}\n",
        ] {
            let m = format!("{:#}", parse_text(text).unwrap_err());
            assert!(
                m.starts_with("kf.yaml: no keys (an empty file, or comments only)"),
                "{text:?}: {m}"
            );
        }
        let m = format!("{:#}", parse_text("imudatarate: 200\n").unwrap_err());
        assert!(m.contains("missing key"), "{m}");
    }

    /// A second YAML document was refused in the parser's words ("use from_str_multiple or
    /// from_str_multiple_with_options"); a file not in UTF-8 with "stream did not contain
    /// valid UTF-8", no line. Both in a user's terms now, with the line.
    #[test]
    fn a_second_document_and_a_file_not_in_utf8_are_told_plainly() {
        let m = format!(
            "{:#}",
            parse_text(&format!("{EXAMPLE}---\nimudatarate: 200\n")).unwrap_err()
        );
        assert!(m.contains("a second YAML document (after '---')"), "{m}");
        assert!(!m.contains("from_str"), "{m}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("kf.yaml");
        let mut bytes = EXAMPLE.as_bytes().to_vec();
        let at = EXAMPLE.find("imudatalen").unwrap();
        bytes.insert(at, 0xe9);
        std::fs::write(&path, bytes).unwrap();
        let line = 1 + EXAMPLE[..at].matches('\n').count();
        let m = format!("{:#}", load(&path).unwrap_err());
        assert!(
            m.contains(&format!(
                "kf.yaml: line {line}: not UTF-8 text (byte {at}, 0xe9)"
            )),
            "{m}"
        );
    }

    #[test]
    fn relative_paths_fall_back_to_the_config_directory() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("imu.txt"), "").unwrap();
        let text = EXAMPLE.replace("./dataset/Leador-A15.txt", "imu.txt");
        let config = dir.path().join("kf-gins.yaml");
        std::fs::write(&config, text).unwrap();
        let (c, _) = load(&config).unwrap();
        assert_eq!(c.imu_path, dir.path().join("imu.txt"));
        // Not found anywhere: left as KF-GINS would open it.
        assert_eq!(c.gnss_path, PathBuf::from("./dataset/GNSS-RTK.txt"));
        let m = format!("{:#}", load(&dir.path().join("none.yaml")).unwrap_err());
        assert!(m.contains("none.yaml"), "{m}");
    }
}
