//! SINS emulator for test stands ([Stand model]): what a strapdown INS with
//! given sensor and initial errors would display along a known (truth) trajectory, without IMU
//! data.
//!
//! The errors are propagated with the linearised INS error model in the NED frame, in the
//! phi-angle (true-frame) form of Titterton & Weston ch. 12 and Groves 2nd ed. §14.2
//! ([Berdinskikh et al., eq. 22] in local-level axes). State: misalignment `phi_n`, velocity error
//! `dv_eb_n`, position error `(d_lat, d_lon, d_h)`:
//!
//! ```text
//! dphi/dt  = -omega_in_n x phi + d_omega_ie_n + d_omega_en_n - C_b_n d_omega_ib_b
//! ddv/dt   =  f_ib_n x phi + C_b_n d_f_ib_b - (2 d_omega_ie_n + d_omega_en_n) x v_eb_n
//!             - (2 omega_ie_n + omega_en_n) x dv + (0, 0, dg)
//! dlat/dt  =  dv_N / (R_N + h) - v_N dh / (R_N + h)^2
//! dlon/dt  =  dv_E / ((R_E + h) cos lat) + v_E sin lat dlat / ((R_E + h) cos^2 lat)
//!             - v_E dh / ((R_E + h)^2 cos lat)
//! dh/dt    = -dv_D
//! ```
//! with `d_omega_ie_n = Omega (-sin lat, 0, -cos lat) dlat` (from Groves eq. 2.123),
//! `d_omega_en_n` the linearisation of Groves eq. 5.44 in `dv`, `dlat`, `dh`, and `dg` the
//! change of nav-core's normal gravity with latitude and height. The sensor errors are those of
//! [Berdinskikh et al., eqs. 3, 8]: `d_omega_ib_b = drift + m_omega omega_ib_b`,
//! `d_f_ib_b = bias + m_a f_ib_b` (measured minus true, body FRD axes).
//!
//! **Sign convention of the attitude error.** `phi_n` is the small rotation of the computed
//! navigation frame from the true one: the displayed attitude is
//! `C_b_n(displayed) = exp(-[phi_n x]) C_b_n ~ (I - [phi_n x]) C_b_n` (Titterton & Weston's
//! `C~ = B C`, `B = I - Psi`), i.e. `q_b_n(displayed) = q(-phi_n) q_b_n`. The initial attitude
//! errors are given as errors of the displayed Euler angles (roll, pitch, heading: displayed =
//! true + error) and converted exactly with the initial truth attitude
//! ([`EmulatorErrors::misalignment_n`]); for a level body heading `psi` this is
//! `phi_n = -(Rz(psi) (d_roll, d_pitch, 0) + (0, 0, d_heading))`.
//!
//! The emulator's only input is the truth trajectory: the specific force is recovered from it
//! (the "ideal accelerometer output" of [Stand model]), per truth interval, as the mean
//! `f_ib_n = (v(k+1) - v(k)) / dt + (2 omega_ie_n + omega_en_n) x v - g_n` (the NED velocity
//! equation, Groves §5.4, solved for `f`), and the body rate for the gyro scale factor from the
//! attitude change. The error ODE is integrated by RK4 over each truth interval (sub-stepped to
//! at most [`EmulatorOptions::max_step_s`]), with position and velocity interpolated linearly
//! and the attitude by slerp inside the interval; the dynamics (Schuler 84 min, Earth rate) are
//! slow, so this is accurate for truth at 400 Hz as well as at 0.1–10 Hz. Neglected: products
//! of errors (linear model) and the change of the radii of curvature with latitude (relative
//! `e^2 ~ 0.7 %` of the position-dependent terms). A truth with a hole (an interval over
//! [`crate::truth::TRUTH_GAP_FACTOR`] times its median, as `nav report` tells one) is refused:
//! the mean over a hole is not the motion in it.
//!
//! The linear model holds for small errors only, so errors beyond its range are refused
//! before anything is written, naming the key and the limit: an attitude error beyond
//! [`MAX_MISALIGNMENT_RAD`], a gyro drift that over the truth's length (or a gyro scale error
//! that over the angle the body turns) would turn the attitude beyond it, an accelerometer bias
//! or scale error whose balancing tilt (bias / g) is beyond it, a velocity error beyond
//! [`MAX_VELOCITY_ERROR_M_S`], a position error beyond [`MAX_POSITION_ERROR_M`]. Errors that
//! grow out of that range during the run (the misalignment, the position error) refuse it at
//! the first row beyond, and every displayed row is checked as the trajectory CSV's reader
//! would ([`crate::output_check`]).
//!
//! The vertical channel is [`Vertical::Aided`] by default (height from an external baro or
//! the truth: `dh = dv_D = 0`, as on aircraft SINS); [`Vertical::Free`] integrates it and
//! diverges with time constant `sqrt(R / 2g)` ~ 570 s.
//!
//! ## Error file
//!
//! [`EmulatorErrors::parse`] reads one key per line, `#` comments, three values per key separated
//! by spaces or commas; the key's suffix is the unit. Missing keys are zero; a quantity may be
//! given once.
//!
//! ```text
//! attitude_error_arcmin = 0.3 0.3 3       # roll pitch heading (also _rad, _deg)
//! gyro_drift_deg_h      = 0.01 0.01 0.01  # body x y z (also _rad_s)
//! gyro_scale_ppm        = 0 0 0           # (also gyro_scale [-])
//! accel_bias_g          = 1e-4 1e-4 1e-4  # g = 9.80665 m/s^2 (also _mg, _m_s2)
//! accel_scale_ppm       = 0 0 0           # (also accel_scale [-])
//! velocity_error_m_s    = 0.3 0 0         # north east down
//! position_error_m      = 0 0 0           # north east down
//! ```
//!
//! On the command line ([`EmulateJob`]):
//! `nav emulate --truth FILE --out FILE [--preset none|seed004-rlg] [--errors FILE]
//! [--set 'KEY = V1 V2 V3']... [--vertical aided|free] [--errors-out FILE]`; the preset, the file
//! and the `--set` lines apply in that order, each overriding the quantities it names.

use crate::output_check::RowError;
use crate::truth::Truth;
use anyhow::Context;
use core::f64::consts::PI;
use core::fmt;
use nav_core::attitude;
use nav_core::earth::{LocalEarth, OMEGA_IE};
use nav_core::nalgebra::{Matrix3, SVector, UnitQuaternion, Vector3};
use nav_core::number::Rounded;
use std::io::Write;
use std::path::Path;

/// Standard gravity `g0` [m/s^2], the unit of accelerometer errors given in g.
pub const G0_M_S2: f64 = 9.806_65;
/// One arc minute [rad].
pub const ARCMIN_RAD: f64 = PI / (180.0 * 60.0);
/// One degree per hour [rad/s].
pub const DEG_H_RAD_S: f64 = PI / (180.0 * 3600.0);
/// Largest absolute truth latitude [rad] (89 deg): the NED error model is singular at the poles
/// (`tan(lat)`, `1 / cos(lat)`).
pub const MAX_ABS_LAT_RAD: f64 = 89.0 * PI / 180.0;

/// Largest misalignment the linear error model is used for [rad] (11.5 deg): the phi-angle
/// model takes `sin(phi) = phi` and `cos(phi) = 1`, within 0.7 % and 2 % there.
pub const MAX_MISALIGNMENT_RAD: f64 = 0.2;

/// Largest position error [m] (1.6 % of the Earth's radius): the model's coefficients (radii,
/// Earth rate, gravity) are those at the true position, which differ from those at the
/// displayed one by about the error over the radius.
pub const MAX_POSITION_ERROR_M: f64 = 100_000.0;

/// Largest initial velocity error [m/s]: the transport-rate product `(dv / R) dv` the model
/// drops stays below a ninth of its Coriolis term `2 Omega dv` (`2 Omega R` ~ 930 m/s).
pub const MAX_VELOCITY_ERROR_M_S: f64 = 100.0;

// Offsets in the error state.
const PHI: usize = 0;
const VEL: usize = 3;
const LAT: usize = 6;
const LON: usize = 7;
const HGT: usize = 8;
const N_STATES: usize = 9;

type ErrorState = SVector<f64, N_STATES>;

/// The errors of the emulated SINS (SI units; sensor errors are measured minus true, in body
/// FRD axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmulatorErrors {
    /// Initial errors of the displayed Euler angles roll, pitch, heading [rad] (displayed = true
    /// + error); converted to the misalignment `phi_n` by [`EmulatorErrors::misalignment_n`].
    pub euler_error_rad: Vector3<f64>,
    /// Gyro drift (bias) per body axis [rad/s].
    pub gyro_drift_rad_s: Vector3<f64>,
    /// Gyro scale-factor error `m_omega` per body axis [-].
    pub gyro_scale: Vector3<f64>,
    /// Accelerometer bias per body axis [m/s^2].
    pub accel_bias_m_s2: Vector3<f64>,
    /// Accelerometer scale-factor error `m_a` per body axis [-].
    pub accel_scale: Vector3<f64>,
    /// Initial velocity error north, east, down `dv_eb_n` [m/s] (down needs
    /// [`Vertical::Free`]).
    pub dv_eb_n_m_s: Vector3<f64>,
    /// Initial position error north, east, down [m] (down needs [`Vertical::Free`]).
    pub dr_n_m: Vector3<f64>,
}

impl Default for EmulatorErrors {
    fn default() -> Self {
        Self::zero()
    }
}

impl EmulatorErrors {
    /// No errors: the emulator then displays the truth.
    pub fn zero() -> Self {
        Self {
            euler_error_rad: Vector3::zeros(),
            gyro_drift_rad_s: Vector3::zeros(),
            gyro_scale: Vector3::zeros(),
            accel_bias_m_s2: Vector3::zeros(),
            accel_scale: Vector3::zeros(),
            dv_eb_n_m_s: Vector3::zeros(),
            dr_n_m: Vector3::zeros(),
        }
    }

    /// The ring-laser-gyro SINS of [Stand model]: gyro drift 0.01 deg/h and accelerometer bias
    /// 0.1e-3 g on every body axis (all positive), roll and pitch errors +0.3 arcmin, heading error
    /// +3 arcmin, initial velocity error 0.3 m/s north; no scale-factor or position errors.
    pub fn seed004_rlg() -> Self {
        Self {
            euler_error_rad: Vector3::new(0.3, 0.3, 3.0) * ARCMIN_RAD,
            gyro_drift_rad_s: Vector3::repeat(0.01 * DEG_H_RAD_S),
            accel_bias_m_s2: Vector3::repeat(0.1e-3 * G0_M_S2),
            dv_eb_n_m_s: Vector3::new(0.3, 0.0, 0.0),
            ..Self::zero()
        }
    }

    /// The initial misalignment `phi_n` [rad] of these Euler-angle errors at the true attitude
    /// `q_b_n`: `q(-phi_n) = q_b_n(displayed) q_b_n^-1` exactly, with the displayed attitude
    /// built from the perturbed Euler angles (nav-core's z-y-x convention).
    pub fn misalignment_n(&self, q_b_n: &UnitQuaternion<f64>) -> Vector3<f64> {
        if self.euler_error_rad == Vector3::zeros() {
            return Vector3::zeros(); // exact: no Euler round trip
        }
        let (roll, pitch, yaw) = attitude::euler(q_b_n);
        let e = &self.euler_error_rad;
        let displayed = attitude::from_euler(roll + e.x, pitch + e.y, yaw + e.z);
        -(displayed * q_b_n.inverse()).scaled_axis()
    }

    /// True when any error would move the vertical channel (a down velocity or position error).
    fn has_vertical_initial_error(&self) -> bool {
        self.dv_eb_n_m_s.z != 0.0 || self.dr_n_m.z != 0.0
    }

    fn fields(&self) -> [&Vector3<f64>; 7] {
        [
            &self.euler_error_rad,
            &self.gyro_drift_rad_s,
            &self.gyro_scale,
            &self.accel_bias_m_s2,
            &self.accel_scale,
            &self.dv_eb_n_m_s,
            &self.dr_n_m,
        ]
    }

    /// Reads the error file (module docs) on top of [`EmulatorErrors::zero`].
    pub fn parse(text: &str) -> Result<Self, ParseError> {
        let mut e = Self::zero();
        e.apply_text(text)?;
        Ok(e)
    }

    /// Overrides the quantities named in `text` (the error file format), keeping the others:
    /// e.g. a preset with one quantity changed. On an error `self` is unchanged.
    /// A byte-order mark before the first line (an editor's on Windows) is not part of its key.
    pub fn apply_text(&mut self, text: &str) -> Result<(), ParseError> {
        self.apply_text_noting(text, |_| {})
    }

    /// [`Self::apply_text`], telling `noted` each quantity set, the line and the key as
    /// written (for messages in the file's words).
    fn apply_text_noting(
        &mut self,
        text: &str,
        mut noted: impl FnMut(Given),
    ) -> Result<(), ParseError> {
        let mut next = *self;
        let mut seen = [false; Quantity::COUNT];
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let content = raw.split('#').next().unwrap_or("").trim();
            if content.is_empty() {
                continue;
            }
            let err = |kind| ParseError { line, kind };
            let (key, values) = content
                .split_once('=')
                .ok_or_else(|| err(ParseErrorKind::Syntax))?;
            let key = key.trim();
            let &(name, quantity, unit) = KEYS
                .iter()
                .find(|(k, _, _)| *k == key)
                .ok_or_else(|| err(ParseErrorKind::UnknownKey(key.to_string())))?;
            if core::mem::replace(&mut seen[quantity as usize], true) {
                return Err(err(ParseErrorKind::Duplicate(key.to_string())));
            }
            let v = parse_triple(values)
                .ok_or_else(|| err(ParseErrorKind::BadValues(key.to_string())))?
                * unit;
            *next.field_mut(quantity) = v;
            noted(Given {
                quantity,
                place: String::new(),
                line,
                key: name,
                unit,
            });
        }
        *self = next;
        Ok(())
    }

    /// The error file of these errors in SI keys (parses back to the same values).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for (quantity, key) in SI_KEYS {
            let v = self.fields()[quantity as usize];
            s += &format!("{key} = {:e} {:e} {:e}\n", v.x, v.y, v.z);
        }
        s
    }

    fn field_mut(&mut self, q: Quantity) -> &mut Vector3<f64> {
        match q {
            Quantity::Attitude => &mut self.euler_error_rad,
            Quantity::GyroDrift => &mut self.gyro_drift_rad_s,
            Quantity::GyroScale => &mut self.gyro_scale,
            Quantity::AccelBias => &mut self.accel_bias_m_s2,
            Quantity::AccelScale => &mut self.accel_scale,
            Quantity::Velocity => &mut self.dv_eb_n_m_s,
            Quantity::Position => &mut self.dr_n_m,
        }
    }
}

/// The quantities of the error file, in the order of [`EmulatorErrors::fields`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Quantity {
    Attitude = 0,
    GyroDrift = 1,
    GyroScale = 2,
    AccelBias = 3,
    AccelScale = 4,
    Velocity = 5,
    Position = 6,
}

impl Quantity {
    const COUNT: usize = 7;
}

/// Where a quantity of the errors was given last: the place (the error file and line, a
/// `--set`), the line in the text, the key as written and the key's factor to SI.
#[derive(Clone, Debug)]
struct Given {
    quantity: Quantity,
    place: String,
    line: usize,
    key: &'static str,
    unit: f64,
}

/// Keys of the error file: name, quantity, factor to SI.
const KEYS: &[(&str, Quantity, f64)] = &[
    ("attitude_error_rad", Quantity::Attitude, 1.0),
    ("attitude_error_deg", Quantity::Attitude, PI / 180.0),
    ("attitude_error_arcmin", Quantity::Attitude, ARCMIN_RAD),
    ("gyro_drift_rad_s", Quantity::GyroDrift, 1.0),
    ("gyro_drift_deg_h", Quantity::GyroDrift, DEG_H_RAD_S),
    ("gyro_scale", Quantity::GyroScale, 1.0),
    ("gyro_scale_ppm", Quantity::GyroScale, 1e-6),
    ("accel_bias_m_s2", Quantity::AccelBias, 1.0),
    ("accel_bias_mg", Quantity::AccelBias, 1e-3 * G0_M_S2),
    ("accel_bias_g", Quantity::AccelBias, G0_M_S2),
    ("accel_scale", Quantity::AccelScale, 1.0),
    ("accel_scale_ppm", Quantity::AccelScale, 1e-6),
    ("velocity_error_m_s", Quantity::Velocity, 1.0),
    ("position_error_m", Quantity::Position, 1.0),
];

/// The SI key of each quantity ([`EmulatorErrors::to_text`]).
const SI_KEYS: [(Quantity, &str); Quantity::COUNT] = [
    (Quantity::Attitude, "attitude_error_rad"),
    (Quantity::GyroDrift, "gyro_drift_rad_s"),
    (Quantity::GyroScale, "gyro_scale"),
    (Quantity::AccelBias, "accel_bias_m_s2"),
    (Quantity::AccelScale, "accel_scale"),
    (Quantity::Velocity, "velocity_error_m_s"),
    (Quantity::Position, "position_error_m"),
];

/// Exactly three finite numbers separated by whitespace or commas.
fn parse_triple(values: &str) -> Option<Vector3<f64>> {
    let mut it = values
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|s| !s.is_empty());
    let mut v = Vector3::zeros();
    for d in v.iter_mut() {
        *d = it.next()?.parse::<f64>().ok().filter(|x| x.is_finite())?;
    }
    it.next().is_none().then_some(v)
}

/// A line of the error file that could not be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParseError {
    /// Line number (1-based).
    pub line: usize,
    /// What is wrong with it.
    pub kind: ParseErrorKind,
}

/// What is wrong with a line of the error file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ParseErrorKind {
    /// Not `key = values`.
    Syntax,
    /// A key the format does not have.
    UnknownKey(String),
    /// The quantity was already given (under this or another unit).
    Duplicate(String),
    /// Not exactly three finite numbers.
    BadValues(String),
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let line = self.line;
        match &self.kind {
            ParseErrorKind::Syntax => write!(f, "line {line}: expected `key = v1 v2 v3`"),
            ParseErrorKind::UnknownKey(k) => {
                let known: Vec<&str> = KEYS.iter().map(|(k, _, _)| *k).collect();
                write!(
                    f,
                    "line {line}: unknown key `{k}` (known: {})",
                    known.join(", ")
                )
            }
            ParseErrorKind::Duplicate(k) => {
                write!(f, "line {line}: `{k}`: quantity given twice")
            }
            ParseErrorKind::BadValues(k) => {
                write!(f, "line {line}: `{k}` needs exactly three finite numbers")
            }
        }
    }
}

impl std::error::Error for ParseError {}

/// Treatment of the emulated vertical channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Vertical {
    /// Height from an external baro altimeter or the truth: `dh = dv_D = 0` (aircraft SINS).
    #[default]
    Aided,
    /// Free inertial vertical channel (unstable, time constant ~ 570 s).
    Free,
}

impl Vertical {
    /// Its name on the command line (`--vertical`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Aided => "aided",
            Self::Free => "free",
        }
    }
}

/// Emulator options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmulatorOptions {
    /// Vertical channel (default aided).
    pub vertical: Vertical,
    /// Longest RK4 step [s] (default 1 s): longer truth intervals are sub-stepped.
    pub max_step_s: f64,
}

impl Default for EmulatorOptions {
    fn default() -> Self {
        Self {
            vertical: Vertical::Aided,
            max_step_s: 1.0,
        }
    }
}

/// Why the emulator refused its input.
#[derive(Clone, Debug, PartialEq)]
pub enum EmulateError {
    /// Fewer than two truth rows.
    TooFewRows {
        /// Rows given.
        rows: usize,
    },
    /// A truth row with a NaN or infinite value, or a non-unit attitude quaternion.
    NonFinite {
        /// Row index (0-based).
        row: usize,
    },
    /// A truth row whose time does not increase.
    NonMonotonicTime {
        /// Row index (0-based).
        row: usize,
        /// Previous time [s].
        prev_t_s: f64,
        /// This row's time [s].
        t_s: f64,
    },
    /// A hole in the truth ([`crate::truth::first_gap`]): the motion is recovered from the
    /// truth per interval, which across a hole is not the trajectory (a 60 s hole was stepped
    /// over in one go, silently).
    TruthGap {
        /// Index (0-based) of the row before the hole.
        row: usize,
        /// Its time and the next row's [s].
        t_s: (f64, f64),
        /// The truth's median interval [s].
        median_s: f64,
    },
    /// A truth row closer to a pole than [`MAX_ABS_LAT_RAD`].
    NearPole {
        /// Row index (0-based).
        row: usize,
    },
    /// Non-finite error parameters.
    NonFiniteErrors,
    /// Initial down velocity or position errors with the vertical channel aided.
    VerticalErrorWhenAided,
    /// `max_step_s` not positive and finite.
    BadStep,
    /// An error parameter beyond the linear model's range (the limits' docs say why).
    BeyondLinearRange {
        /// The quantity's SI key in the error file.
        key: &'static str,
        /// Its size: the largest component (with its sign) or the norm [the key's unit].
        value: f64,
        /// The vector whose norm `value` is (`None`: `value` is its largest component) [the
        /// key's unit].
        vector: Option<[f64; 3]>,
        /// The largest accepted [the key's unit].
        limit: f64,
        /// Why the limit.
        reason: &'static str,
    },
    /// The propagated errors left the linear model's range (or overflowed) at a truth row.
    LeftLinearRange {
        /// Row index (0-based).
        row: usize,
        /// Its time [s].
        t_s: f64,
        /// Which error (`misalignment`, `position error`, `error state`).
        quantity: &'static str,
        /// Its size, in `unit`.
        value: f64,
        /// The range's limit, in `unit`.
        limit: f64,
        /// The unit.
        unit: &'static str,
    },
    /// A displayed row its readers would refuse (a latitude beyond a pole, a non-finite
    /// value).
    Row(RowError),
}

/// "KEY VALUE is beyond +-LIMIT: REASON" for a component, "KEY: the magnitude of (X, Y, Z) is
/// VALUE, beyond LIMIT: REASON" for a vector's norm ([`EmulateError::BeyondLinearRange`]; the
/// norm read as a component was "680 680 680 arcmin: 1178 is beyond +-687.5").
fn beyond_linear_range(
    key: &str,
    value: f64,
    vector: Option<[f64; 3]>,
    limit: f64,
    reason: &str,
) -> String {
    match vector {
        None => format!(
            "{key} {} is beyond +-{}: {reason}",
            Rounded(value),
            Rounded(limit)
        ),
        Some([x, y, z]) => format!(
            "{key}: the magnitude of ({}, {}, {}) is {}, beyond {}: {reason}",
            Rounded(x),
            Rounded(y),
            Rounded(z),
            Rounded(value),
            Rounded(limit)
        ),
    }
}

impl fmt::Display for EmulateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooFewRows { rows } => {
                write!(f, "the truth needs at least 2 rows, it has {rows}")
            }
            Self::NonFinite { row } => write!(
                f,
                "truth row {row}: non-finite value or non-unit attitude quaternion"
            ),
            Self::NonMonotonicTime { row, prev_t_s, t_s } => write!(
                f,
                "truth row {row}: time {t_s} s does not increase (previous {prev_t_s} s)"
            ),
            Self::TruthGap { row, t_s, median_s } => write!(
                f,
                "truth rows {row} and {} (t = {} s and {} s) are {} s apart, over {} times the \
                 truth's median interval {} s: the emulator recovers the motion between rows, \
                 and across a hole it is not the trajectory; give the truth without holes",
                row + 1,
                Rounded(t_s.0),
                Rounded(t_s.1),
                Rounded(t_s.1 - t_s.0),
                crate::truth::TRUTH_GAP_FACTOR,
                Rounded(*median_s)
            ),
            Self::NearPole { row } => write!(
                f,
                "truth row {row}: latitude beyond +-89 deg (the NED error model is singular at the poles)"
            ),
            Self::NonFiniteErrors => write!(f, "the error parameters must be finite"),
            Self::VerticalErrorWhenAided => write!(
                f,
                "down velocity/position errors need the free vertical channel (aided holds dh = dv_D = 0)"
            ),
            Self::BadStep => write!(f, "max_step_s must be positive and finite"),
            Self::BeyondLinearRange {
                key,
                value,
                vector,
                limit,
                reason,
            } => f.write_str(&beyond_linear_range(key, *value, *vector, *limit, reason)),
            Self::LeftLinearRange {
                row,
                t_s,
                quantity,
                value,
                limit,
                unit,
            } => write!(
                f,
                "row {row} (t = {} s): the {quantity} reached {} {unit}, beyond the linear error model's range {} {unit} (smaller errors or a shorter truth)",
                Rounded(*t_s),
                Rounded(*value),
                Rounded(*limit)
            ),
            Self::Row(e) => write!(f, "refusing to write {e}"),
        }
    }
}

impl std::error::Error for EmulateError {}

/// The error state at one truth time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorSample {
    /// Time [s].
    pub t_s: f64,
    /// Misalignment of the computed navigation frame `phi_n` (NED) [rad]; displayed
    /// `q_b_n = q(-phi_n) q_b_n(true)`.
    pub phi_n_rad: Vector3<f64>,
    /// Velocity error `dv_eb_n` (NED) [m/s], displayed minus true.
    pub dv_eb_n_m_s: Vector3<f64>,
    /// Latitude error [rad].
    pub d_lat_rad: f64,
    /// Longitude error [rad].
    pub d_lon_rad: f64,
    /// Height error [m].
    pub d_h_m: f64,
    /// Position error north, east, down [m] (the angles times the radii of curvature).
    pub dr_n_m: Vector3<f64>,
}

/// The emulator's output.
#[derive(Clone, Debug, PartialEq)]
pub struct Emulated {
    /// What the SINS displays at every truth time: truth plus errors.
    pub displayed: Vec<Truth>,
    /// The error state at every truth time.
    pub errors: Vec<ErrorSample>,
}

/// Emulates the SINS with `errors` along `truth` (module docs). Each output row is at a truth
/// row's time; the first is the truth with the initial errors.
pub fn emulate(
    truth: &[Truth],
    errors: &EmulatorErrors,
    opts: &EmulatorOptions,
) -> Result<Emulated, EmulateError> {
    validate(truth, errors, opts)?;
    let first = &truth[0];
    let e0 = LocalEarth::new(first.lat, first.h);
    let mut x = ErrorState::zeros();
    x.fixed_rows_mut::<3>(PHI)
        .copy_from(&errors.misalignment_n(&first.q_b_ned));
    x.fixed_rows_mut::<3>(VEL).copy_from(&errors.dv_eb_n_m_s);
    x[LAT] = errors.dr_n_m.x / (e0.r_meridian + first.h);
    x[LON] = errors.dr_n_m.y / ((e0.r_transverse + first.h) * first.lat.cos());
    x[HGT] = -errors.dr_n_m.z;

    let mut out = Emulated {
        displayed: Vec::with_capacity(truth.len()),
        errors: Vec::with_capacity(truth.len()),
    };
    out.push(first, &x);
    out.check_last()?;
    for pair in truth.windows(2) {
        let interval = Interval::new(&pair[0], &pair[1], errors);
        let n_sub = (interval.dt / opts.max_step_s).ceil().max(1.0) as usize;
        let h = 1.0 / n_sub as f64;
        let mut start = interval.at(0.0);
        for j in 0..n_sub {
            let mid = interval.at((j as f64 + 0.5) * h);
            let end = interval.at((j + 1) as f64 * h);
            x = rk4(&x, &start, &mid, &end, interval.dt * h, opts.vertical);
            start = end;
        }
        out.push(&pair[1], &x);
        out.check_last()?;
    }
    crate::output_check::check_truth("displayed row", &out.displayed).map_err(EmulateError::Row)?;
    Ok(out)
}

impl Emulated {
    /// Refuses the last error sample if it left the linear model's range
    /// ([`MAX_MISALIGNMENT_RAD`], [`MAX_POSITION_ERROR_M`]) or is not finite.
    fn check_last(&self) -> Result<(), EmulateError> {
        let row = self.errors.len() - 1;
        let e = &self.errors[row];
        let left = |quantity, value, limit, unit| EmulateError::LeftLinearRange {
            row,
            t_s: e.t_s,
            quantity,
            value,
            limit,
            unit,
        };
        let state = [
            e.phi_n_rad.as_slice(),
            e.dv_eb_n_m_s.as_slice(),
            &[e.d_lat_rad, e.d_lon_rad, e.d_h_m],
            e.dr_n_m.as_slice(),
        ];
        if let Some(&v) = state.iter().flat_map(|s| s.iter()).find(|v| !v.is_finite()) {
            return Err(left("error state", v, f64::MAX, "(SI)"));
        }
        // Finite here: NaN was refused above.
        let phi = e.phi_n_rad.norm();
        if phi > MAX_MISALIGNMENT_RAD {
            return Err(left("misalignment", phi, MAX_MISALIGNMENT_RAD, "rad"));
        }
        let dr = e.dr_n_m.norm();
        if dr > MAX_POSITION_ERROR_M {
            return Err(left("position error", dr, MAX_POSITION_ERROR_M, "m"));
        }
        Ok(())
    }

    fn push(&mut self, truth: &Truth, x: &ErrorState) {
        let e = LocalEarth::new(truth.lat, truth.h);
        let phi_n_rad: Vector3<f64> = x.fixed_rows::<3>(PHI).into_owned();
        let dv_eb_n_m_s: Vector3<f64> = x.fixed_rows::<3>(VEL).into_owned();
        let dr_n_m = Vector3::new(
            x[LAT] * (e.r_meridian + truth.h),
            x[LON] * (e.r_transverse + truth.h) * truth.lat.cos(),
            0.0 - x[HGT], // +0 rather than -0 when aided
        );
        self.errors.push(ErrorSample {
            t_s: truth.t_s,
            phi_n_rad,
            dv_eb_n_m_s,
            d_lat_rad: x[LAT],
            d_lon_rad: x[LON],
            d_h_m: x[HGT],
            dr_n_m,
        });
        self.displayed.push(Truth {
            t_s: truth.t_s,
            lat: truth.lat + x[LAT],
            lon: wrap_pi(truth.lon + x[LON]),
            h: truth.h + x[HGT],
            v_eb_ned: truth.v_eb_ned + dv_eb_n_m_s,
            q_b_ned: displayed_attitude(&truth.q_b_ned, &phi_n_rad),
        });
    }
}

/// The displayed attitude `q(-phi_n) q_b_n` of the true attitude `q_b_n` with misalignment
/// `phi_n` [rad] (the module's sign convention).
pub fn displayed_attitude(
    q_b_n: &UnitQuaternion<f64>,
    phi_n: &Vector3<f64>,
) -> UnitQuaternion<f64> {
    UnitQuaternion::from_scaled_axis(-phi_n) * q_b_n
}

/// `a` [rad] in (-pi, pi] (unchanged when already there).
fn wrap_pi(a: f64) -> f64 {
    if a > -PI && a <= PI {
        a
    } else {
        PI - (PI - a).rem_euclid(2.0 * PI)
    }
}

fn validate(
    truth: &[Truth],
    errors: &EmulatorErrors,
    opts: &EmulatorOptions,
) -> Result<(), EmulateError> {
    if !(opts.max_step_s.is_finite() && opts.max_step_s > 0.0) {
        return Err(EmulateError::BadStep);
    }
    if errors
        .fields()
        .iter()
        .any(|v| !v.iter().all(|x| x.is_finite()))
    {
        return Err(EmulateError::NonFiniteErrors);
    }
    if opts.vertical == Vertical::Aided && errors.has_vertical_initial_error() {
        return Err(EmulateError::VerticalErrorWhenAided);
    }
    if truth.len() < 2 {
        return Err(EmulateError::TooFewRows { rows: truth.len() });
    }
    for (row, t) in truth.iter().enumerate() {
        let q = t.q_b_ned.quaternion();
        let finite = [t.t_s, t.lat, t.lon, t.h]
            .iter()
            .chain(t.v_eb_ned.iter())
            .chain(q.coords.iter())
            .all(|x| x.is_finite());
        if !finite || (q.norm() - 1.0).abs() > 1e-6 {
            return Err(EmulateError::NonFinite { row });
        }
        if t.lat.abs() > MAX_ABS_LAT_RAD {
            return Err(EmulateError::NearPole { row });
        }
        if row > 0 && t.t_s <= truth[row - 1].t_s {
            return Err(EmulateError::NonMonotonicTime {
                row,
                prev_t_s: truth[row - 1].t_s,
                t_s: t.t_s,
            });
        }
    }
    if let Some(row) = crate::truth::first_gap(truth) {
        return Err(EmulateError::TruthGap {
            row,
            t_s: (truth[row].t_s, truth[row + 1].t_s),
            median_s: crate::truth::median_interval_s(truth),
        });
    }
    check_linear_range(truth, errors)
}

/// Refuses errors beyond the linear model's range: the misalignment each causes
/// (directly, by drift over the truth's length, by scale factor over the angle the body turns,
/// or as the tilt that balances an accelerometer error) beyond [`MAX_MISALIGNMENT_RAD`],
/// a velocity error beyond [`MAX_VELOCITY_ERROR_M_S`], a position error beyond
/// [`MAX_POSITION_ERROR_M`].
fn check_linear_range(truth: &[Truth], errors: &EmulatorErrors) -> Result<(), EmulateError> {
    let duration_s = truth[truth.len() - 1].t_s - truth[0].t_s;
    // The angle the body turns relative to inertial space (its own turns and the Earth's).
    let turned_rad = truth
        .windows(2)
        .map(|w| w[0].q_b_ned.angle_to(&w[1].q_b_ned))
        .sum::<f64>()
        + OMEGA_IE * duration_s;
    // Signed: the message keeps the sign of the value given.
    let largest = |v: &Vector3<f64>| v[v.iamax()];
    // The norm without overflow: 1e300 deg/h squared is beyond f64.
    let norm = |v: &Vector3<f64>| {
        let m = v.amax();
        if m > 0.0 && m.is_finite() {
            m * (v / m).norm()
        } else {
            m
        }
    };
    let of = |v: &Vector3<f64>| Some([v.x, v.y, v.z]);
    let checks = [
        (
            "attitude_error_rad",
            norm(&errors.euler_error_rad),
            of(&errors.euler_error_rad),
            MAX_MISALIGNMENT_RAD,
            "beyond the linear error model's small-angle range (0.2 rad)",
        ),
        (
            "gyro_drift_rad_s",
            norm(&errors.gyro_drift_rad_s),
            of(&errors.gyro_drift_rad_s),
            MAX_MISALIGNMENT_RAD / duration_s,
            "over the truth's length the drift turns the attitude beyond the linear error model's small-angle range (0.2 rad)",
        ),
        (
            "gyro_scale",
            largest(&errors.gyro_scale),
            None,
            MAX_MISALIGNMENT_RAD / turned_rad,
            "times the angle the body turns over the truth it turns the attitude beyond the linear error model's small-angle range (0.2 rad)",
        ),
        (
            "accel_bias_m_s2",
            norm(&errors.accel_bias_m_s2),
            of(&errors.accel_bias_m_s2),
            MAX_MISALIGNMENT_RAD * G0_M_S2,
            "the tilt bias/g that balances it is beyond the linear error model's small-angle range (0.2 rad)",
        ),
        (
            "accel_scale",
            largest(&errors.accel_scale),
            None,
            MAX_MISALIGNMENT_RAD,
            "on gravity it is a bias of scale x g, balanced by a tilt beyond the linear error model's small-angle range (0.2 rad)",
        ),
        (
            "velocity_error_m_s",
            norm(&errors.dv_eb_n_m_s),
            of(&errors.dv_eb_n_m_s),
            MAX_VELOCITY_ERROR_M_S,
            "the transport-rate products the linear error model drops are no longer small",
        ),
        (
            "position_error_m",
            norm(&errors.dr_n_m),
            of(&errors.dr_n_m),
            MAX_POSITION_ERROR_M,
            "the linear error model takes the radii, Earth rate and gravity at the true position; 100 km is 1.6 % of the Earth's radius",
        ),
    ];
    for (key, value, vector, limit, reason) in checks {
        // Finite values only reach here (validated above): `>` refuses what is beyond.
        if value.abs() > limit {
            return Err(EmulateError::BeyondLinearRange {
                key,
                value,
                vector,
                limit,
                reason,
            });
        }
    }
    Ok(())
}

/// One truth interval: endpoints and the mean specific force and body rate.
struct Interval<'a> {
    a: &'a Truth,
    b: &'a Truth,
    dt: f64,
    /// Mean specific force `f_ib_n` [m/s^2] over the interval.
    f_ib_n: Vector3<f64>,
    /// Attitude change `q_a^-1 q_b` as a rotation vector [rad] (body axes).
    rot_b: Vector3<f64>,
    errors: &'a EmulatorErrors,
}

/// Truth-derived coefficients of the error ODE at one instant.
struct Coeffs {
    c_b_n: Matrix3<f64>,
    f_ib_n: Vector3<f64>,
    v_eb_n: Vector3<f64>,
    lat: f64,
    h: f64,
    earth: LocalEarth<f64>,
    omega_ie_n: Vector3<f64>,
    omega_en_n: Vector3<f64>,
    /// `dg/dlat` [m/s^2/rad] and `dg/dh` [1/s^2] of the normal gravity.
    dg_dlat: f64,
    dg_dh: f64,
    /// Sensor errors `d_omega_ib_b` [rad/s] and `d_f_ib_b` [m/s^2]
    /// ([Berdinskikh et al., eqs. 3, 8]).
    d_omega_ib_b: Vector3<f64>,
    d_f_ib_b: Vector3<f64>,
}

impl<'a> Interval<'a> {
    fn new(a: &'a Truth, b: &'a Truth, errors: &'a EmulatorErrors) -> Self {
        let dt = b.t_s - a.t_s;
        let v_mid = (a.v_eb_ned + b.v_eb_ned) * 0.5;
        let e = LocalEarth::new(0.5 * (a.lat + b.lat), 0.5 * (a.h + b.h));
        let coriolis = (e.omega_ie_n() * 2.0 + e.omega_en_n(&v_mid)).cross(&v_mid);
        // The NED velocity equation (Groves §5.4) solved for f (the ideal accelerometer output of
        // [Stand model]), mean over dt.
        let f_ib_n = (b.v_eb_ned - a.v_eb_ned) / dt + coriolis - Vector3::new(0.0, 0.0, e.g);
        Self {
            a,
            b,
            dt,
            f_ib_n,
            rot_b: (a.q_b_ned.inverse() * b.q_b_ned).scaled_axis(),
            errors,
        }
    }

    /// Coefficients at the fraction `s` in [0, 1] of the interval.
    fn at(&self, s: f64) -> Coeffs {
        let (a, b) = (self.a, self.b);
        let lat = a.lat + s * (b.lat - a.lat);
        let h = a.h + s * (b.h - a.h);
        let v_eb_n = a.v_eb_ned + (b.v_eb_ned - a.v_eb_ned) * s;
        let q_b_n = a.q_b_ned * UnitQuaternion::from_scaled_axis(self.rot_b * s);
        let c_b_n = q_b_n.to_rotation_matrix().into_inner();
        let earth = LocalEarth::new(lat, h);
        let omega_ie_n = earth.omega_ie_n();
        let omega_en_n = earth.omega_en_n(&v_eb_n);
        // Normal gravity is quadratic in h: the central difference is its exact derivative.
        let dg_dh = (LocalEarth::new(lat, h + 1.0).g - LocalEarth::new(lat, h - 1.0).g) / 2.0;
        let dg_dlat = (LocalEarth::new(lat + 1e-6, h).g - LocalEarth::new(lat - 1e-6, h).g) / 2e-6;
        // omega_ib_b = C_n_b omega_in_n + omega_nb_b (Poisson: dC_b_n/dt = C_b_n [omega_nb_b x]).
        let omega_ib_b = c_b_n.transpose() * (omega_ie_n + omega_en_n) + self.rot_b / self.dt;
        let f_ib_b = c_b_n.transpose() * self.f_ib_n;
        let e = self.errors;
        Coeffs {
            c_b_n,
            f_ib_n: self.f_ib_n,
            v_eb_n,
            lat,
            h,
            earth,
            omega_ie_n,
            omega_en_n,
            dg_dlat,
            dg_dh,
            d_omega_ib_b: e.gyro_drift_rad_s + e.gyro_scale.component_mul(&omega_ib_b),
            d_f_ib_b: e.accel_bias_m_s2 + e.accel_scale.component_mul(&f_ib_b),
        }
    }
}

/// The error ODE's right-hand side (module docs; Titterton & Weston ch. 12, Groves §14.2).
fn derivative(x: &ErrorState, c: &Coeffs, vertical: Vertical) -> ErrorState {
    let phi: Vector3<f64> = x.fixed_rows::<3>(PHI).into_owned();
    let dv: Vector3<f64> = x.fixed_rows::<3>(VEL).into_owned();
    let (d_lat, d_h) = (x[LAT], x[HGT]);
    let v = &c.v_eb_n;
    let rn_h = c.earth.r_meridian + c.h;
    let re_h = c.earth.r_transverse + c.h;
    let (sin_lat, cos_lat) = c.lat.sin_cos();
    let tan_lat = sin_lat / cos_lat;

    // Position-error rates of omega_ie_n (Groves eq. 2.123) and omega_en_n (Groves eq. 5.44).
    let d_omega_ie_n = Vector3::new(-sin_lat, 0.0, -cos_lat) * (OMEGA_IE * d_lat);
    let d_omega_en_n = Vector3::new(
        dv.y / re_h - v.y * d_h / (re_h * re_h),
        -dv.x / rn_h + v.x * d_h / (rn_h * rn_h),
        -dv.y * tan_lat / re_h - v.y * d_lat / (re_h * cos_lat * cos_lat)
            + v.y * tan_lat * d_h / (re_h * re_h),
    );
    let omega_in_n = c.omega_ie_n + c.omega_en_n;

    let d_phi = -omega_in_n.cross(&phi) + d_omega_ie_n + d_omega_en_n - c.c_b_n * c.d_omega_ib_b;
    let d_g = c.dg_dlat * d_lat + c.dg_dh * d_h;
    let mut d_dv = c.f_ib_n.cross(&phi) + c.c_b_n * c.d_f_ib_b
        - (d_omega_ie_n * 2.0 + d_omega_en_n).cross(v)
        - (c.omega_ie_n * 2.0 + c.omega_en_n).cross(&dv)
        + Vector3::new(0.0, 0.0, d_g);
    let d_lat_dt = dv.x / rn_h - v.x * d_h / (rn_h * rn_h);
    let d_lon_dt = dv.y / (re_h * cos_lat) + v.y * sin_lat * d_lat / (re_h * cos_lat * cos_lat)
        - v.y * d_h / (re_h * re_h * cos_lat);
    let mut d_h_dt = -dv.z;
    if vertical == Vertical::Aided {
        d_dv.z = 0.0;
        d_h_dt = 0.0;
    }

    let mut out = ErrorState::zeros();
    out.fixed_rows_mut::<3>(PHI).copy_from(&d_phi);
    out.fixed_rows_mut::<3>(VEL).copy_from(&d_dv);
    out[LAT] = d_lat_dt;
    out[LON] = d_lon_dt;
    out[HGT] = d_h_dt;
    out
}

/// One classical RK4 step of length `dt` [s] with the coefficients at its start, middle, end.
fn rk4(
    x: &ErrorState,
    start: &Coeffs,
    mid: &Coeffs,
    end: &Coeffs,
    dt: f64,
    vertical: Vertical,
) -> ErrorState {
    let k1 = derivative(x, start, vertical);
    let k2 = derivative(&(x + k1 * (0.5 * dt)), mid, vertical);
    let k3 = derivative(&(x + k2 * (0.5 * dt)), mid, vertical);
    let k4 = derivative(&(x + k3 * dt), end, vertical);
    x + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0)
}

/// Error presets of the command line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Preset {
    /// No errors.
    #[default]
    None,
    /// The ring-laser-gyro SINS of [Stand model]: 0.01 deg/h, 0.1 mg, 0.3'/0.3'/3', 0.3 m/s north
    /// (`EmulatorErrors::seed004_rlg`).
    Seed004Rlg,
}

impl Preset {
    /// The preset's errors.
    pub fn errors(self) -> EmulatorErrors {
        match self {
            Self::None => EmulatorErrors::zero(),
            Self::Seed004Rlg => EmulatorErrors::seed004_rlg(),
        }
    }
}

/// One `nav emulate` run: files, error sources and options.
#[derive(Clone, Copy, Debug)]
pub struct EmulateJob<'a> {
    /// Truth trajectory (trajectory CSV, [`crate::truth_csv`]).
    pub truth: &'a Path,
    /// Displayed trajectory to write (the same format).
    pub out: &'a Path,
    /// Starting errors.
    pub preset: Preset,
    /// Error file applied over the preset.
    pub errors_file: Option<&'a Path>,
    /// Single `key = values` lines applied last, in order.
    pub set: &'a [String],
    /// Emulator options.
    pub options: EmulatorOptions,
    /// Where to write the error series (CSV, [`write_errors_csv`]), if anywhere.
    pub errors_out: Option<&'a Path>,
}

impl EmulateJob<'_> {
    /// The errors: the preset, then the file, then each `set` line, each overriding the
    /// quantities it names.
    pub fn errors(&self) -> anyhow::Result<EmulatorErrors> {
        Ok(self.errors_given()?.0)
    }

    /// [`Self::errors`], and where each quantity was given last (`None`: the preset's).
    fn errors_given(&self) -> anyhow::Result<(EmulatorErrors, [Option<Given>; Quantity::COUNT])> {
        let mut e = self.preset.errors();
        let mut given: [Option<Given>; Quantity::COUNT] = Default::default();
        if let Some(path) = self.errors_file {
            let text = crate::text_error::read_text(path)?;
            let place = format!("error file {}", path.display());
            e.apply_text_noting(&text, |g| {
                given[g.quantity as usize] = Some(Given {
                    place: format!("{place} line {}", g.line),
                    ..g
                });
            })
            .context(place.clone())?;
        }
        // The `--set` that gave each quantity: a second one was silently taken over the first,
        // where an error file refuses a quantity given twice, and so does `nav sim --set`.
        let mut set_by: [Option<usize>; Quantity::COUNT] = Default::default();
        for (i, line) in self.set.iter().enumerate() {
            let place = format!("--set #{} `{line}`", i + 1);
            // An empty `--set ''` was accepted without a word.
            anyhow::ensure!(
                !line.trim().is_empty(),
                "{place}: empty; give `key = v1 v2 v3`"
            );
            let mut twice = None;
            e.apply_text_noting(line, |g| {
                if let Some(first) = set_by[g.quantity as usize].replace(i) {
                    twice = Some((first, g.key));
                }
                given[g.quantity as usize] = Some(Given {
                    place: place.clone(),
                    ..g
                });
            })
            .context(place.clone())?;
            if let Some((first, key)) = twice {
                anyhow::bail!(
                    "{place}: `{key}` gives a quantity --set #{} `{}` gave already: give each \
                     quantity once",
                    first + 1,
                    self.set[first]
                );
            }
        }
        Ok((e, given))
    }

    /// A refusal of a quantity beyond the linear model's range in the words it was given in
    /// (the file and line, the key, the value in the key's unit); others as they are.
    fn in_given_words(error: EmulateError, given: &[Option<Given>]) -> anyhow::Error {
        let EmulateError::BeyondLinearRange {
            key,
            value,
            vector,
            limit,
            reason,
        } = error
        else {
            return error.into();
        };
        let given = SI_KEYS
            .iter()
            .find(|(_, k)| *k == key)
            .and_then(|(q, _)| given[*q as usize].as_ref());
        match given {
            Some(g) => anyhow::anyhow!(
                "{}: {}",
                g.place,
                beyond_linear_range(
                    g.key,
                    value / g.unit,
                    vector.map(|v| v.map(|x| x / g.unit)),
                    limit / g.unit,
                    reason
                )
            ),
            None => anyhow::anyhow!("the preset's {}", error),
        }
    }

    /// Reads the truth, emulates, writes the outputs; returns a summary for the terminal.
    ///
    /// Nothing is written unless every row is valid ([`emulate`]); the error series is
    /// renamed into place before the displayed trajectory, which is renamed only if the
    /// series was written.
    pub fn run(&self) -> anyhow::Result<String> {
        // The error file (`--errors`) is an input too.
        let inputs: Vec<&Path> = std::iter::once(self.truth)
            .chain(self.errors_file)
            .collect();
        crate::atomic::refuse_same_file(&inputs, self.out)?;
        if let Some(path) = self.errors_out {
            crate::atomic::refuse_same_file(&inputs, path)?;
            // Was "output E is the input E" when --out existed.
            crate::atomic::refuse_shared_outputs(&[("--out", self.out), ("--errors-out", path)])?;
        }
        let (errors, given) = self.errors_given()?;
        let truth = crate::truth_csv::read(self.truth)?;
        let out = emulate(&truth, &errors, &self.options)
            .map_err(|e| Self::in_given_words(e, &given))
            .with_context(|| format!("emulating along {}", self.truth.display()))?;
        crate::atomic::write(self.out, |w| -> anyhow::Result<()> {
            let mut rows = crate::truth_csv::TruthWriter::new(w)?;
            for row in &out.displayed {
                rows.write(row)?;
            }
            // A complete solution, as replay's (`nav report` said "cut short" without it).
            rows.finish_solution()?;
            if let Some(path) = self.errors_out {
                write_errors_csv(path, &out.errors)?;
            }
            Ok(())
        })
        .with_context(|| format!("writing {}", self.out.display()))?;
        let (first, last) = (&out.errors[0], &out.errors[out.errors.len() - 1]);
        let mut s = format!(
            "emulated {} rows ({} s to {} s) of {} into {} (vertical {})\nerrors:\n{}",
            out.displayed.len(),
            first.t_s,
            last.t_s,
            self.truth.display(),
            self.out.display(),
            self.options.vertical.name(),
            errors.to_text()
        );
        s += &format!(
            "final error: position N {:.1} E {:.1} D {:.1} m, velocity N {:.3} E {:.3} D {:.3} m/s, \
             misalignment N {:.3} E {:.3} D {:.3} arcmin\n",
            last.dr_n_m.x,
            last.dr_n_m.y,
            last.dr_n_m.z,
            last.dv_eb_n_m_s.x,
            last.dv_eb_n_m_s.y,
            last.dv_eb_n_m_s.z,
            last.phi_n_rad.x / ARCMIN_RAD,
            last.phi_n_rad.y / ARCMIN_RAD,
            last.phi_n_rad.z / ARCMIN_RAD
        );
        if let Some(path) = self.errors_out {
            s += &format!("error series: {}\n", path.display());
        }
        Ok(s)
    }
}

/// Whether `a` and `b` name the same path (not yet existing files compared as written).
/// Writes the error series as CSV: `t_s`, `phi_{n,e,d}_rad`, `dv_{n,e,d}_mps`,
/// `dr_{n,e,d}_m`.
pub fn write_errors_csv(path: &Path, errors: &[ErrorSample]) -> anyhow::Result<()> {
    let write = |w: &mut std::io::BufWriter<std::fs::File>| -> std::io::Result<()> {
        writeln!(
            w,
            "t_s,phi_n_rad,phi_e_rad,phi_d_rad,dv_n_mps,dv_e_mps,dv_d_mps,dr_n_m,dr_e_m,dr_d_m"
        )?;
        for e in errors {
            let (p, v, r) = (&e.phi_n_rad, &e.dv_eb_n_m_s, &e.dr_n_m);
            writeln!(
                w,
                "{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}",
                e.t_s, p.x, p.y, p.z, v.x, v.y, v.z, r.x, r.y, r.z
            )?;
        }
        w.flush()
    };
    crate::atomic::write(path, write).with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::{EmulatorErrors, Vertical};
    use clap::ValueEnum;

    /// An error file saved with a byte-order mark (Notepad's UTF-8) was refused as "line 1:
    /// unknown key `gyro_drift_deg_h`", the mark invisible inside the quotes.
    #[test]
    fn a_byte_order_mark_is_not_part_of_the_first_key() {
        let text = "\u{feff}gyro_drift_deg_h = 0.01 0.01 0.01\r\n";
        assert_eq!(
            EmulatorErrors::parse(text).unwrap(),
            EmulatorErrors::parse("gyro_drift_deg_h = 0.01 0.01 0.01").unwrap()
        );
    }

    /// The summary names the vertical channel as `--vertical` takes it.
    #[test]
    fn vertical_names_are_the_command_line_values() {
        for v in Vertical::value_variants() {
            assert_eq!(Vertical::from_str(v.name(), false), Ok(*v));
        }
    }
}
