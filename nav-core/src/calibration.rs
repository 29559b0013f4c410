//! Sensor error compensation before the mechanization ([Berdinskikh et al., eqs. 3 and 8]).
//!
//! Per triad the sensor model is `measured = (I + S + N) true + bias`, with `S` the diagonal of
//! scale-factor errors `m` ([Berdinskikh et al., eq. 3]: `(1 + m) * true + bias` per axis) and `N`
//! the off-diagonal misalignment / non-orthogonality [rad]. Compensation inverts it once, at load:
//! `true = K (measured - bias)`, `K = (I + S + N)^-1`; applied to increments the bias is
//! multiplied by the interval. Defaults are identity (no compensation).
//!
//! The text form the firmware and the harness both load (one key per line, `#` comments, SI
//! units, values separated by spaces or commas):
//!
//! ```text
//! gyro_bias_rad_s     = 1e-6 -2e-6 0
//! gyro_scale          = 100e-6 0 0          # m_x m_y m_z [-]
//! gyro_misalignment   = 0 0 0 0 0 0         # N_xy N_xz N_yx N_yz N_zx N_zy [rad]
//! accel_bias_m_s2     = 0.001 0 0
//! accel_scale         = 0 0 0
//! accel_misalignment  = 0 0 0 0 0 0
//! ```
//! Missing keys keep their identity values.

use crate::Scalar;
use core::fmt;
use nalgebra::{Matrix3, Vector3};

/// Error model of one sensor triad.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriadErrors {
    /// Bias [rad/s for gyros, m/s^2 for accelerometers].
    pub bias: [f64; 3],
    /// Scale-factor errors `m` per axis [-].
    pub scale: [f64; 3],
    /// Misalignment `N_xy N_xz N_yx N_yz N_zx N_zy` [rad]: `N_ij` couples true axis `j` into
    /// measured axis `i`.
    pub misalignment: [f64; 6],
}

impl TriadErrors {
    /// No errors.
    pub const IDENTITY: Self = Self {
        bias: [0.0; 3],
        scale: [0.0; 3],
        misalignment: [0.0; 6],
    };

    /// `I + S + N`.
    fn model_matrix(&self) -> Matrix3<f64> {
        let [xy, xz, yx, yz, zx, zy] = self.misalignment;
        let [sx, sy, sz] = self.scale;
        Matrix3::new(1.0 + sx, xy, xz, yx, 1.0 + sy, yz, zx, zy, 1.0 + sz)
    }
}

impl Default for TriadErrors {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// The calibration of an IMU: the error models of its gyro and accelerometer triads.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImuCalibration {
    /// Gyro errors (bias [rad/s]).
    pub gyro: TriadErrors,
    /// Accelerometer errors (bias [m/s^2]).
    pub accel: TriadErrors,
}

/// Why a calibration could not be loaded.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum CalibrationError {
    /// A line is not `key = values`.
    Syntax {
        /// 1-based line number.
        line: usize,
    },
    /// The key is not one of the documented keys ([`KEYS`]).
    UnknownKey {
        /// 1-based line number.
        line: usize,
        /// Where the key is in the parsed text: its first byte's offset and its length in
        /// bytes ([`Self::in_text`] names it).
        key_at: (usize, usize),
    },
    /// A value is not a finite number, or there are too few or too many values.
    BadValues {
        /// 1-based line number.
        line: usize,
    },
    /// The key appeared twice.
    Duplicate {
        /// 1-based line number of the second occurrence.
        line: usize,
    },
    /// `I + S + N` of a triad cannot be inverted, or a value is implausible (|scale| or
    /// |misalignment| >= 0.5).
    Singular,
    /// A value beyond physical plausibility: a bias above [`MAX_GYRO_BIAS_RAD_S`] or
    /// [`MAX_ACCEL_BIAS_M_S2`], a scale factor or misalignment of 50 % or more.
    Implausible {
        /// The key.
        key: &'static str,
        /// The largest magnitude accepted, in the key's unit.
        limit: f64,
    },
}

/// Largest gyro bias accepted [rad/s] (10 deg/s).
pub const MAX_GYRO_BIAS_RAD_S: f64 = 10.0 * core::f64::consts::PI / 180.0;

/// Largest accelerometer bias accepted [m/s^2] (1 g).
pub const MAX_ACCEL_BIAS_M_S2: f64 = 9.806_65;

/// Largest scale-factor error or misalignment accepted [-] (exclusive).
pub const MAX_SCALE: f64 = 0.5;

impl fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Syntax { line } => write!(f, "calibration line {line}: expected `key = values`"),
            Self::UnknownKey { line, .. } => unknown_key(f, *line, None),
            Self::BadValues { line } => {
                write!(
                    f,
                    "calibration line {line}: wrong number of values or not a finite number"
                )
            }
            Self::Duplicate { line } => write!(f, "calibration line {line}: key given twice"),
            Self::Singular => f.write_str(
                "calibration: scale/misalignment matrix is not invertible or implausible",
            ),
            Self::Implausible { key, limit } => write!(
                f,
                "calibration: {key} is beyond physical plausibility (magnitude at most {limit})"
            ),
        }
    }
}

impl core::error::Error for CalibrationError {}

impl CalibrationError {
    /// The error with the key it names read from `text`, the text given to
    /// [`ImuCalibration::parse`] ("unknown key `gyro_bias_deg_h`" rather than "unknown key").
    pub fn in_text<'a>(&'a self, text: &'a str) -> impl fmt::Display + 'a {
        InText { error: self, text }
    }
}

/// [`CalibrationError::in_text`].
struct InText<'a> {
    error: &'a CalibrationError,
    text: &'a str,
}

impl fmt::Display for InText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self.error {
            CalibrationError::UnknownKey {
                line,
                key_at: (at, len),
            } => unknown_key(f, line, self.text.get(at..at + len)),
            ref e => e.fmt(f),
        }
    }
}

/// "calibration line N: unknown key `KEY` (known: ...)".
fn unknown_key(f: &mut fmt::Formatter<'_>, line: usize, key: Option<&str>) -> fmt::Result {
    write!(f, "calibration line {line}: unknown key")?;
    if let Some(key) = key {
        write!(f, " `{key}`")?;
    }
    f.write_str(" (known: ")?;
    for (i, k) in KEYS.iter().enumerate() {
        if i > 0 {
            f.write_str(", ")?;
        }
        f.write_str(k)?;
    }
    f.write_str("; SI units)")
}

/// The keys of the text form (module docs).
pub const KEYS: [&str; 6] = [
    "gyro_bias_rad_s",
    "gyro_scale",
    "gyro_misalignment",
    "accel_bias_m_s2",
    "accel_scale",
    "accel_misalignment",
];

impl ImuCalibration {
    /// Parses the text form (see the module docs). A UTF-8 byte-order mark before the first
    /// line (an editor's on Windows) is not part of its key.
    pub fn parse(text: &str) -> Result<Self, CalibrationError> {
        let mut cal = Self::default();
        let mut seen = [false; KEYS.len()];
        let whole = text;
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let content = raw.split('#').next().unwrap_or("").trim();
            if content.is_empty() {
                continue;
            }
            let (key, values) = content
                .split_once('=')
                .ok_or(CalibrationError::Syntax { line })?;
            let key = key.trim();
            let k = KEYS.iter().position(|&k| k == key).ok_or_else(|| {
                // Both slices of `whole`: the key's offset in it.
                let at = key.as_ptr() as usize - whole.as_ptr() as usize;
                CalibrationError::UnknownKey {
                    line,
                    key_at: (at, key.len()),
                }
            })?;
            if core::mem::replace(&mut seen[k], true) {
                return Err(CalibrationError::Duplicate { line });
            }
            let triad = if k < 3 { &mut cal.gyro } else { &mut cal.accel };
            let dest: &mut [f64] = match k % 3 {
                0 => &mut triad.bias,
                1 => &mut triad.scale,
                _ => &mut triad.misalignment,
            };
            parse_values(values, dest).ok_or(CalibrationError::BadValues { line })?;
        }
        cal.compensation::<f64>()?;
        Ok(cal)
    }

    /// The compensation in the working scalar; fails when a triad's model cannot be inverted
    /// or is implausible.
    pub fn compensation<T: Scalar>(&self) -> Result<ImuCompensation<T>, CalibrationError> {
        let limits = [
            MAX_GYRO_BIAS_RAD_S,
            MAX_SCALE,
            MAX_SCALE,
            MAX_ACCEL_BIAS_M_S2,
            MAX_SCALE,
            MAX_SCALE,
        ];
        for (k, (&key, &limit)) in KEYS.iter().zip(&limits).enumerate() {
            let triad = if k < 3 { &self.gyro } else { &self.accel };
            let values: &[f64] = match k % 3 {
                0 => &triad.bias,
                1 => &triad.scale,
                _ => &triad.misalignment,
            };
            // Scale and misalignment: exclusive (a scale of -1 zeroes the axis).
            let ok = |v: f64| {
                if k % 3 == 0 {
                    v.abs() <= limit
                } else {
                    v.abs() < limit
                }
            };
            if !values.iter().all(|&v| ok(v)) {
                return Err(CalibrationError::Implausible { key, limit });
            }
        }
        Ok(ImuCompensation {
            gyro: TriadCompensation::new(&self.gyro)?,
            accel: TriadCompensation::new(&self.accel)?,
        })
    }
}

/// Fills `dest` from whitespace- or comma-separated numbers; `None` unless exactly
/// `dest.len()` finite numbers are given.
fn parse_values(values: &str, dest: &mut [f64]) -> Option<()> {
    let mut it = values
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|s| !s.is_empty());
    for d in dest.iter_mut() {
        let v: f64 = it.next()?.parse().ok()?;
        if !v.is_finite() {
            return None;
        }
        *d = v;
    }
    it.next().is_none().then_some(())
}

/// Compensation of one triad: `true = k (measured - bias)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriadCompensation<T: Scalar> {
    /// `(I + S + N)^-1` [-].
    pub k: Matrix3<T>,
    /// Bias [rad/s or m/s^2].
    pub bias: Vector3<T>,
}

impl<T: Scalar> TriadCompensation<T> {
    /// Inverts the error model of `errors`.
    pub fn new(errors: &TriadErrors) -> Result<Self, CalibrationError> {
        let plausible = errors
            .scale
            .iter()
            .chain(&errors.misalignment)
            .all(|x| x.abs() < 0.5)
            && errors.bias.iter().all(|b| b.is_finite());
        let k = errors
            .model_matrix()
            .try_inverse()
            .filter(|_| plausible)
            .ok_or(CalibrationError::Singular)?;
        Ok(Self {
            k: k.map(T::c),
            bias: Vector3::from(errors.bias.map(T::c)),
        })
    }

    /// Compensates the increment `measured` over `dt` [s].
    #[inline]
    pub fn apply(&self, measured: &Vector3<T>, dt: T) -> Vector3<T> {
        self.k * (measured - self.bias * dt)
    }
}

impl<T: Scalar> Default for TriadCompensation<T> {
    fn default() -> Self {
        Self {
            k: Matrix3::identity(),
            bias: Vector3::zeros(),
        }
    }
}

/// The compensation of both triads, ready to apply to increments.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuCompensation<T: Scalar> {
    /// Gyro triad.
    pub gyro: TriadCompensation<T>,
    /// Accelerometer triad.
    pub accel: TriadCompensation<T>,
}

impl<T: Scalar> Default for ImuCompensation<T> {
    fn default() -> Self {
        Self {
            gyro: TriadCompensation::default(),
            accel: TriadCompensation::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    #[test]
    fn compensation_inverts_the_error_model() {
        let errors = TriadErrors {
            bias: [1e-5, -2e-5, 3e-5],
            scale: [1e-3, -2e-3, 5e-4],
            misalignment: [1e-3, -1e-3, 2e-3, 0.5e-3, -0.7e-3, 1.1e-3],
        };
        let truth = Vector3::new(0.01, -0.02, 0.005_f64);
        let dt = 0.0025;
        let measured = errors.model_matrix() * truth + Vector3::from(errors.bias) * dt;
        let comp = TriadCompensation::<f64>::new(&errors).unwrap();
        assert!((comp.apply(&measured, dt) - truth).norm() < 1e-17);
        // Identity by default.
        let id = TriadCompensation::<f32>::default();
        let m = Vector3::new(1.0, 2.0, 3.0_f32);
        assert_eq!(id.apply(&m, 0.0025), m);
    }

    #[test]
    fn parses_the_text_form() {
        let text = "# bench calibration\n\
                    gyro_bias_rad_s = 1e-6, -2e-6, 0\n\
                    accel_scale = 1e-4 0 0   # x only\n\
                    \n\
                    accel_misalignment = 0 0 0 0 0 1e-3\n";
        let cal = ImuCalibration::parse(text).unwrap();
        assert_eq!(cal.gyro.bias, [1e-6, -2e-6, 0.0]);
        assert_eq!(cal.accel.scale, [1e-4, 0.0, 0.0]);
        assert_eq!(cal.accel.misalignment[5], 1e-3);
        assert_eq!(cal.gyro.scale, [0.0; 3]);
        assert_eq!(
            ImuCalibration::parse("").unwrap(),
            ImuCalibration::default()
        );
    }

    /// A file saved with a byte-order mark (Notepad's UTF-8) was refused as "calibration line
    /// 1: unknown key", its first key read with the mark; its CRLF lines were read.
    #[test]
    fn a_byte_order_mark_is_not_part_of_the_first_key() {
        let text = "\u{feff}gyro_bias_rad_s = 1e-6 0 0\r\naccel_scale = 1e-4 0 0\r\n";
        let cal = ImuCalibration::parse(text).unwrap();
        assert_eq!(cal.gyro.bias, [1e-6, 0.0, 0.0]);
        assert_eq!(cal.accel.scale, [1e-4, 0.0, 0.0]);
        // Only at the start: elsewhere it is a character of a key.
        assert_eq!(
            ImuCalibration::parse("gyro_scale = 0 0 0\n\u{feff}accel_scale = 0 0 0"),
            Err(CalibrationError::UnknownKey {
                line: 2,
                key_at: (19, 14)
            })
        );
    }

    /// "calibration line 1: unknown key" named neither the key nor the known ones.
    #[test]
    fn an_unknown_key_is_named_with_the_known_ones() {
        use std::string::ToString;
        let text = "\u{feff}# units\n  gyro_bias_deg_h = 1 0 0\n";
        let e = ImuCalibration::parse(text).unwrap_err();
        let known = "(known: gyro_bias_rad_s, gyro_scale, gyro_misalignment, accel_bias_m_s2, \
                     accel_scale, accel_misalignment; SI units)";
        assert_eq!(
            e.in_text(text).to_string(),
            std::format!("calibration line 2: unknown key `gyro_bias_deg_h` {known}")
        );
        assert_eq!(
            e.to_string(),
            std::format!("calibration line 2: unknown key {known}")
        );
    }

    proptest::proptest! {
        /// No text can panic the parser; whatever it accepts is a usable calibration.
        #[test]
        fn any_text_parses_or_is_refused(text in "(([a-z_]{0,20} *= *)?[-0-9e., a-z]{0,40}\n){0,8}") {
            if let Ok(cal) = ImuCalibration::parse(&text) {
                proptest::prop_assert!(cal.compensation::<f32>().is_ok());
            }
        }
    }

    #[test]
    fn refuses_bad_text() {
        use CalibrationError::*;
        let cases = [
            ("gyro_bias_rad_s 1 2 3", Syntax { line: 1 }),
            (
                "\nmag_bias = 1 2 3",
                UnknownKey {
                    line: 2,
                    key_at: (1, 8),
                },
            ),
            ("gyro_scale = 1 2", BadValues { line: 1 }),
            ("gyro_scale = 0 0 0 0", BadValues { line: 1 }),
            ("gyro_scale = 0 nan 0", BadValues { line: 1 }),
            ("gyro_scale = 0 x 0", BadValues { line: 1 }),
            (
                "gyro_scale = 0 0 0\ngyro_scale = 0 0 0",
                Duplicate { line: 2 },
            ),
            (
                "accel_scale = -1 0 0",
                Implausible {
                    key: "accel_scale",
                    limit: MAX_SCALE,
                },
            ),
            (
                "accel_misalignment = 0.7 0 0 0 0 0",
                Implausible {
                    key: "accel_misalignment",
                    limit: MAX_SCALE,
                },
            ),
            (
                "accel_bias_m_s2 = 1e6 0 0",
                Implausible {
                    key: "accel_bias_m_s2",
                    limit: MAX_ACCEL_BIAS_M_S2,
                },
            ),
            (
                "gyro_bias_rad_s = 0 0 -0.2",
                Implausible {
                    key: "gyro_bias_rad_s",
                    limit: MAX_GYRO_BIAS_RAD_S,
                },
            ),
        ];
        for (text, err) in cases {
            assert_eq!(ImuCalibration::parse(text), Err(err), "{text}");
        }
        // At the limits: accepted (a 1 g bias, a 10 deg/s one, scale 0.49).
        let edge =
            "accel_bias_m_s2 = 9.80665 0 0\ngyro_bias_rad_s = 0.174 0 0\ngyro_scale = 0.49 0 0";
        assert!(ImuCalibration::parse(edge).is_ok());
        let msg = std::format!(
            "{}",
            ImuCalibration::parse("accel_bias_m_s2 = 1e6 0 0").unwrap_err()
        );
        assert!(msg.contains("accel_bias_m_s2"), "{msg}");
    }
}
