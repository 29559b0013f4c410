//! The alignment state machine: `COARSE -> FINE -> ALIGNED`, or `FAILED` with a reason.
//!
//! One [`Aligner`] runs the method chosen in [`AlignSettings`] on the increments it is given,
//! sample by sample, and changes stage on sample counts (never on clock time), so the firmware
//! and the host harness fed the same samples reach the same result.
//!
//! | method | coarse stage | fine stage |
//! |---|---|---|
//! | [`AlignMethod::Static`] | [`StaticAlignment`] over the whole period | — |
//! | [`AlignMethod::Inertial`] | [`InertialAlignment`] over the whole period | — |
//! | [`AlignMethod::Fine`] | [`InertialAlignment`] for [`AlignSettings::coarse_samples`] | [`FineAlignment`] ([Vavilova et al.]: position and zero velocity, closed loop) |
//! | [`AlignMethod::Sway`] | [`InertialAlignment`] for [`AlignSettings::coarse_samples`] | [`SwayAlignment`] (the base sways about a mean attitude), and the general bank beside it: the answer, with an [`AlignNote`], where the sway model is off or refuted |
//!
//! The fine stages start from the coarse attitude and its 1-sigma and use the same IMU noise
//! model; the fine filter's corrected navigation state is the result.
//!
//! The result is the navigation state at the end of the last alignment sample, with the 1-sigma
//! roll, pitch and yaw of the method's own error model, and the number of samples (and
//! seconds) each stage took.

use super::AttitudeEstimate;
use super::analytic::{AlignError, EarthRateMismatch, GravityMismatch, StaticAlignment};
use super::fine::bank::Bank;
use super::fine::base::Translation;
use super::fine::model::FINE_STATES;
use super::fine::{Blank, FineConfig, FineRefusal, NoExtension};
use super::inertial::{InertialAlignError, InertialAlignment, SensorNoise};
use super::stillness::{Scatter, Stillness};
use super::sway::SwayAlignment;
#[cfg(feature = "align-sway")]
use super::sway::SwayConfig;
use crate::number::Number;
use crate::{ImuIncrement, InputLimits, NavState, Position, Scalar, earth};
use nalgebra::{UnitQuaternion, Vector3};

/// Which alignment to run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AlignMethod {
    /// Static analytic: levelling and gyrocompassing of the mean increments (still base only).
    #[default]
    Static,
    /// Inertial-frame coarse alignment: rocking or disturbed base, no initial heading.
    Inertial,
    /// Inertial-frame coarse, then the position-aided closed-loop Kalman filter of
    /// [Vavilova et al.].
    Fine,
    /// Inertial-frame coarse, then the base-motion-model filter (still or swaying base).
    Sway,
}

impl AlignMethod {
    /// Every method, in the order of [`Self::name`]s.
    pub const ALL: [AlignMethod; 4] = [
        AlignMethod::Static,
        AlignMethod::Inertial,
        AlignMethod::Fine,
        AlignMethod::Sway,
    ];

    /// The name on command lines and in logs.
    pub fn name(self) -> &'static str {
        match self {
            Self::Static => "static",
            Self::Inertial => "inertial",
            Self::Fine => "fine",
            Self::Sway => "sway",
        }
    }

    /// The method called `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Whether the method is in this build: the fine and sway filters are nav-core's
    /// features `align-fine` and `align-sway` (a small board's firmware leaves them out of
    /// its flash); the static and inertial methods are always in.
    pub const fn compiled_in(self) -> bool {
        match self {
            Self::Static | Self::Inertial => true,
            Self::Fine => cfg!(feature = "align-fine"),
            Self::Sway => cfg!(feature = "align-sway"),
        }
    }

    /// The method models a base that translates ([`BaseMotion::translation_sigma_m`]): all
    /// but the static one, which takes a still base only (a moving one is refused). A front
    /// end refuses a translation given with it ([`BASE_TRANSLATION_STATIC`]): it was ignored.
    pub fn takes_base_translation(self) -> bool {
        self != AlignMethod::Static
    }

    /// The shortest window the method accepts [s].
    pub fn min_seconds(self) -> f64 {
        match self {
            Self::Static | Self::Inertial => super::inertial::MIN_DURATION_S,
            Self::Fine => MIN_FINE_S,
            Self::Sway => MIN_SWAY_S,
        }
    }
}

/// Coarse stage of [`AlignMethod::Fine`] and [`AlignMethod::Sway`] [s]: levelling only (the
/// filters need no heading).
pub const FINE_COARSE_S: f64 = 5.0;

/// Shortest window of [`AlignMethod::Fine`] [s]: the coarse stage's [`FINE_COARSE_S`] and 15 s
/// for the filter.
pub const MIN_FINE_S: f64 = 20.0;

/// Shortest window of [`AlignMethod::Sway`] [s]: the coarse stage, the identification of the
/// sway periods, and time for the filter.
pub const MIN_SWAY_S: f64 = 40.0;

/// Where an [`Aligner`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Accumulating the coarse solution.
    Coarse,
    /// Refining it.
    Fine,
    /// Done: [`Aligner::outcome`] has the result.
    Aligned,
    /// Given up: [`Aligner::failure`] says why.
    Failed,
}

impl Stage {
    /// Upper-case name for logs.
    pub fn name(self) -> &'static str {
        match self {
            Self::Coarse => "COARSE",
            Self::Fine => "FINE",
            Self::Aligned => "ALIGNED",
            Self::Failed => "FAILED",
        }
    }
}

/// What [`Aligner::add`] reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Progress<T: Scalar> {
    /// Still in [`Stage::Coarse`].
    Coarse,
    /// Still in [`Stage::Fine`].
    Fine,
    /// Done (reported again for every later sample).
    Aligned(AlignOutcome<T>),
    /// Given up.
    Failed(AlignFailure),
}

/// Why an alignment failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlignFailure {
    /// The static analytic solution was refused (base moving, gyros blind to the Earth rate,
    /// ...).
    Static(AlignError),
    /// The inertial-frame solution was refused.
    Inertial(InertialAlignError),
    /// The fine filter's result was refused.
    Fine(FineRefusal),
    /// The base moved: the increments scatter beyond the IMU's noise ([`Stillness`]).
    BaseMoving(Scatter),
    /// A still base's gyros over the fine stage contradict the latitude's Earth rate
    /// ([`AlignError::LatitudeMismatch`], the static method's test).
    Latitude(EarthRateMismatch),
    /// The window the increments cover is shorter than the method's minimum.
    WindowTooShort {
        /// Time covered [s].
        seconds: f64,
        /// The method's minimum [s].
        min_s: f64,
    },
    /// The method is not in this build ([`AlignMethod::compiled_in`]; settings built through
    /// [`AlignSettings::new`] refuse it before any sample).
    NotCompiledIn(AlignMethod),
}

impl core::fmt::Display for AlignFailure {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Static(e) => write!(f, "static alignment: {e}"),
            Self::Inertial(e) => write!(f, "inertial-frame alignment: {e}"),
            Self::Fine(e) => write!(f, "fine alignment: {e}"),
            Self::Latitude(m) => write!(f, "fine alignment: {}", AlignError::LatitudeMismatch(*m)),
            Self::BaseMoving(sc) => write!(
                f,
                "base not still: gyro and accelerometer outputs scatter {:.1}x and {:.1}x their noise (sway, heave or vibration; or an IMU noisier than its model)",
                sc.gyro_ratio, sc.accel_ratio
            ),
            Self::WindowTooShort { seconds, min_s } => write!(
                f,
                "the data cover {seconds:.3} s, less than the method's minimum of {min_s} s \
                 (the samples' own intervals, shortened by timestamp jitter or gaps): ask for a \
                 window {:.3} s longer or more, e.g. {} s",
                min_s - seconds,
                longer_window_s(*seconds, *min_s)
            ),
            Self::NotCompiledIn(method) => not_compiled_in(f, *method),
        }
    }
}

impl core::error::Error for AlignFailure {}

/// The window to ask for when one of `min_s` [s] covered only `seconds` [s] of the samples'
/// intervals ([`AlignFailure::WindowTooShort`]: timestamp jitter or gaps): the minimum plus the
/// shortfall, rounded up to 0.1 s (9.990 s of a 10 s window: 10.1 s).
pub fn longer_window_s(seconds: f64, min_s: f64) -> f64 {
    libm::ceil((2.0 * min_s - seconds) * 10.0 - 1e-9) / 10.0
}

impl AlignFailure {
    /// A short, fixed name of the reason (for counting refusals by kind; the `Display` text
    /// carries the figures).
    pub fn reason(&self) -> &'static str {
        use super::fine::FineRefusal as F;
        use super::inertial::InertialAlignError as I;
        match self {
            Self::Static(e) => match e {
                AlignError::NoSamples => "static: no samples",
                AlignError::SpecificForceNotGravity(_) => "static: specific force not gravity",
                AlignError::BaseRotating => "static: base rotating",
                AlignError::HeadingUnobservable => "static: Earth rate not measurable",
                AlignError::LatitudeMismatch(_) => "static: Earth rate not the latitude's",
            },
            Self::Inertial(e) => match e {
                I::TooShort => "inertial: too short",
                I::InputRefused(_) => "inertial: increment refused",
                I::NearPole => "inertial: near a pole",
                I::SpecificForceNotGravity(_) => "inertial: specific force not gravity",
                I::HeadingUnobservable => "inertial: heading not resolved",
                I::NonFinite => "inertial: not finite",
                I::BaseDisturbed => "inertial: base disturbed",
                I::TranslationLeak => "inertial: window too short for a translating base",
                I::LeverArmLeak { .. } => "inertial: unknown lever arm hides the heading",
            },
            Self::Fine(e) => match e {
                F::HeadingUnresolved { .. } => "fine: heading not resolved",
                F::EarthRateMismatch { .. } => "fine: gyros disagree with the Earth rate",
                F::MotionNotModelled { .. } => "fine: base motion not modelled",
                F::YawSwayBeyondModel { .. } => "sway: yaw sway beyond the model",
                F::NotStarted => "fine: not started",
                F::NonFinite => "fine: not finite",
            },
            Self::BaseMoving(_) => "base not still",
            Self::Latitude(_) => "fine: Earth rate not the latitude's",
            Self::WindowTooShort { .. } => "window too short",
            Self::NotCompiledIn(_) => "method not in this build",
        }
    }
}

/// [`SettingsError::BadValue`]'s names of the values [`check_geometry`] refuses (a text
/// form names its key by them).
pub const LEVER_ARM_VALUE: &str = "the lever arm";
/// See [`LEVER_ARM_VALUE`].
pub const LEVER_ARM_SIGMA_VALUE: &str = "the lever arm's 1-sigma";
/// See [`LEVER_ARM_VALUE`].
pub const BASE_MOTION_VALUE: &str = "the base motion's 1-sigma";

/// Why a base translation given with the static method is refused
/// ([`AlignMethod::takes_base_translation`]).
pub const BASE_TRANSLATION_STATIC: &str = "the base translation is the base motion of the \
     inertial, fine and sway alignments (align-method); the static one takes a still base only";

/// The largest heading 1-sigma the static method's gyros may leave [rad] (30 deg): beyond it
/// its outcome is no heading (a FOG recording aligned under a consumer part's declared noise
/// said ALIGNED with a yaw 1-sigma of 9697 deg), and the aided filter's linear model, which
/// takes it over, no longer holds ([`SettingsError::GyrosTooCoarse`], refused before any
/// sample).
pub const MAX_STATIC_HEADING_SIGMA_RAD: f64 = 30.0 * core::f64::consts::PI / 180.0;

/// Where the IMU sits relative to the given position (the base's centre of rotation, or its
/// reference point).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LeverArm<T: Scalar> {
    /// Measured: the IMU's offset from the centre of rotation, body axes (FRD) [m].
    Known(Vector3<T>),
    /// Not measured: each body component is taken as `N(0, sigma_m^2)` [m] (0: the IMU is at
    /// the given position).
    Unknown {
        /// 1-sigma per body axis [m].
        sigma_m: T,
    },
}

/// 1-sigma per axis assumed for an unknown lever arm [m] ([`LeverArm::Unknown`]): an IMU
/// within about 10 m of the given point.
pub const DEFAULT_LEVER_ARM_SIGMA_M: f64 = 5.0;

impl<T: Scalar> Default for LeverArm<T> {
    fn default() -> Self {
        Self::Unknown {
            sigma_m: T::c(DEFAULT_LEVER_ARM_SIGMA_M),
        }
    }
}

impl<T: Scalar> LeverArm<T> {
    /// The measured offset, if known [m].
    pub fn known(&self) -> Option<Vector3<T>> {
        match self {
            Self::Known(r) => Some(*r),
            Self::Unknown { .. } => None,
        }
    }
}

/// What is assumed about the base's own motion and the given position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseMotion<T: Scalar> {
    /// 1-sigma of the given position itself (survey, GNSS), per north, east, down axis [m].
    pub position_sigma_m: T,
    /// 1-sigma of the translation of the base's centre about its mean position (heave, surge,
    /// sway in waves), per axis [m]; 0: the centre does not move.
    pub translation_sigma_m: T,
}

impl<T: Scalar> Default for BaseMotion<T> {
    /// A surveyed point (0.1 m) on a base whose centre may move by waves (0.5 m).
    fn default() -> Self {
        Self {
            position_sigma_m: T::c(0.1),
            translation_sigma_m: T::c(0.5),
        }
    }
}

/// Starts the fine filters in `slot`, in place: the slot is assigned the blank bank once
/// ([`Blank::BLANK`], a `const`: written where it lives, zeros by one `memset`), then started
/// through `&mut` ([`Bank::init_in`]), so no bank is built on the stack and moved (an MCU
/// task's stack is a few tens of KB). Not inlined: its locals take stack only while the
/// filters start.
#[inline(never)]
fn start_fine<T: Scalar>(
    slot: &mut Option<Bank<T, FINE_STATES, NoExtension>>,
    q_b_c: UnitQuaternion<T>,
    omega_eb_b: Vector3<T>,
    position: Position,
    fine: FineConfig<T>,
) {
    if slot.is_none() {
        *slot = Some(Bank::BLANK);
    }
    if let Some(bank) = slot {
        bank.init_in(q_b_c, omega_eb_b, position, fine, |_| {});
    }
}

/// Starts the sway filters in `slot`, in place ([`Blank::BLANK`] once, then
/// [`SwayAlignment::init_in`]; not inlined, as [`start_fine`]).
#[inline(never)]
#[cfg(feature = "align-sway")]
fn start_sway<T: Scalar>(
    slot: &mut Option<SwayAlignment<T>>,
    q_b_c: UnitQuaternion<T>,
    omega_eb_b: Vector3<T>,
    position: Position,
    fine: FineConfig<T>,
) {
    if slot.is_none() {
        *slot = Some(SwayAlignment::BLANK);
    }
    if let Some(sway) = slot {
        sway.init_in(
            q_b_c,
            omega_eb_b,
            position,
            SwayConfig {
                fine,
                ..SwayConfig::default()
            },
        );
    }
}

/// Longest lever arm (and largest lever-arm 1-sigma) accepted [m]: the IMU sits on the base,
/// within a hull's length of its centre of rotation (a large ship's bow is some 100 m from
/// it); beyond that the value is a typing or unit error, not a base.
pub const MAX_LEVER_ARM_M: f64 = 100.0;

/// The refusal of a base translation 1-sigma beyond [`MAX_LEVER_ARM_M`] (waves move a hull's
/// centre by metres; 1e10 m is a unit or typing error).
pub const BASE_TRANSLATION_OUT_OF_RANGE: &str =
    "the base translation 1-sigma must be 0 to 100 m (waves move a hull's centre by metres)";

/// Lowest IMU sampling rate an alignment accepts [Hz]: `1 / InputLimits::max_dt` (0.1 s, the
/// navigator's default limits, [`crate::InputLimits`]). Below it every increment is longer than
/// the navigator takes, each refused: a 5 Hz recording ended its alignment with "0 of 100
/// samples used (3086 rejected)" and no word of its rate.
pub const MIN_RATE_HZ: f64 = 10.0;
/// Highest IMU sampling rate an alignment accepts [Hz] (no IMU samples faster; a rate
/// beyond it is a unit or typing error). A day's window at this rate still fits the sample
/// counter.
pub const MAX_RATE_HZ: f64 = 40_000.0;

/// Refuses a sampling rate `rate_hz` [Hz] that is not finite or not within [`MIN_RATE_HZ`] to
/// [`MAX_RATE_HZ`] ([`SettingsError::BadRate`]): the rates an alignment, and so a replay,
/// takes (the host's writers and converters check their rates with it).
pub fn check_rate(rate_hz: f64) -> Result<(), SettingsError> {
    if rate_hz.is_finite() && (MIN_RATE_HZ..=MAX_RATE_HZ).contains(&rate_hz) {
        Ok(())
    } else {
        Err(SettingsError::BadRate(rate_hz))
    }
}

/// Why the sampling rate `rate_hz` [Hz] is refused ([`SettingsError::BadRate`]): the reason of
/// the limit it crosses ("too high" explained the low limit's reason).
pub fn bad_rate_reason(rate_hz: f64) -> &'static str {
    if rate_hz > MAX_RATE_HZ {
        "no IMU samples faster than 40 kHz: a rate above it is a unit or typing error, such as \
         a time column in milliseconds read as seconds"
    } else if rate_hz.is_nan() {
        "not a number"
    } else {
        "below 10 Hz every increment is longer than the 0.1 s the navigator accepts"
    }
}

/// The reason an unknown lever arm of 1-sigma 0 is refused ([`SettingsError::LeverArmSigmaZero`]).
pub const LEVER_ARM_SIGMA_ZERO: &str = "an unknown lever arm's 1-sigma of 0 m is a known lever arm \
     of 0 m by another name: give it as known (--lever-arm 0,0,0), or a 1-sigma above 0";
/// Longest alignment window [s] (a day: longer is a unit or typing error, and its sample
/// count would not fit the counters).
pub const MAX_WINDOW_S: f64 = 86_400.0;
const _: () = assert!(MAX_WINDOW_S * MAX_RATE_HZ < u32::MAX as f64);

/// Why alignment settings were refused before any sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SettingsError {
    /// The window is shorter than the method's minimum ([`AlignMethod::min_seconds`]).
    WindowTooShort {
        /// The method.
        method: AlignMethod,
        /// The window asked for [s].
        seconds: f64,
        /// The method's minimum [s].
        min_s: f64,
    },
    /// The sampling rate is not a finite number within [`MIN_RATE_HZ`] to [`MAX_RATE_HZ`] [Hz].
    BadRate(f64),
    /// The window is longer than [`MAX_WINDOW_S`] [s].
    WindowTooLong {
        /// The window asked for [s].
        seconds: f64,
    },
    /// The latitude is not finite or within ~1 deg of a pole (gyrocompassing needs the
    /// horizontal Earth rate).
    NearPole,
    /// A noise, lever-arm or base-motion value is negative or not finite.
    BadValue(&'static str),
    /// A value outside the range any IMU can have; the text is the whole reason (the value,
    /// its key and its range).
    OutOfRange(&'static str),
    /// A known lever arm longer than [`MAX_LEVER_ARM_M`].
    LeverArmTooLong {
        /// Its length [m].
        length_m: f64,
    },
    /// An unknown lever arm's 1-sigma beyond [`MAX_LEVER_ARM_M`].
    LeverArmSigmaTooLarge {
        /// The 1-sigma per axis [m].
        sigma_m: f64,
    },
    /// The method is not in this build ([`AlignMethod::compiled_in`]).
    NotCompiledIn(AlignMethod),
    /// [`AlignMethod::Sway`] with the lever arm not given: on the alignment family its
    /// heading 1-sigma is not true then (an unknown lever arm's estimate and the sway model
    /// share the roll and pitch signal), so it is not offered.
    SwayNeedsLeverArm,
    /// An unknown lever arm whose 1-sigma is 0: a known lever arm of zero by another name,
    /// which the methods take as known ([`LEVER_ARM_SIGMA_ZERO`]).
    LeverArmSigmaZero,
    /// [`AlignMethod::Fine`] or [`AlignMethod::Sway`] with gyros whose bias 1-sigma alone puts
    /// the heading beyond the filter's limit: on a still base the east bias and the Earth
    /// rate's east tilt drift are the same signal, so the heading's 1-sigma is at least
    /// `sigma_b / (Omega cos(lat))` [Titterton & Weston, §10.3.2], and the filter's linear model
    /// no longer holds at such errors (on the family the answers were 30-60 sigma off). The
    /// same for [`AlignMethod::Static`] beyond [`MAX_STATIC_HEADING_SIGMA_RAD`].
    GyrosTooCoarse {
        /// Gyro bias 1-sigma [rad/s].
        bias_rad_s: f64,
        /// Horizontal Earth rate at the latitude [rad/s].
        earth_rad_s: f64,
    },
}

impl core::fmt::Display for SettingsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::WindowTooShort {
                method,
                seconds,
                min_s,
            } => write!(
                f,
                "alignment window {} s is shorter than the {} method's minimum of {min_s} s",
                Number(*seconds),
                method.name()
            ),
            Self::BadRate(r) => write!(
                f,
                "sampling rate {} Hz is not within [{MIN_RATE_HZ}, {MAX_RATE_HZ}] Hz ({})",
                Number(*r),
                bad_rate_reason(*r)
            ),
            Self::WindowTooLong { seconds } => write!(
                f,
                "alignment window {} s is longer than {MAX_WINDOW_S} s (a day)",
                Number(*seconds)
            ),
            Self::NearPole => f.write_str("latitude not finite or too close to a pole to align"),
            Self::NotCompiledIn(method) => not_compiled_in(f, *method),
            Self::BadValue(what) => write!(f, "{what} must be finite and not negative"),
            Self::OutOfRange(why) => f.write_str(why),
            Self::LeverArmTooLong { length_m } => write!(
                f,
                "lever arm {} m is beyond {MAX_LEVER_ARM_M} m (the IMU sits on the base, within a hull's length of its centre of rotation)",
                crate::number::Rounded(*length_m)
            ),
            Self::LeverArmSigmaTooLarge { sigma_m } => write!(
                f,
                "lever arm 1-sigma {} m is beyond {MAX_LEVER_ARM_M} m (the IMU sits on the base, within a hull's length of its centre of rotation)",
                crate::number::Rounded(*sigma_m)
            ),
            Self::SwayNeedsLeverArm => f.write_str(
                "the sway method needs the lever arm (--lever-arm X,Y,Z; 0,0,0 at the centre of rotation): with an unknown one its 1-sigma is not true; use fine",
            ),
            Self::LeverArmSigmaZero => f.write_str(LEVER_ARM_SIGMA_ZERO),
            Self::GyrosTooCoarse {
                bias_rad_s,
                earth_rad_s,
            } => {
                let deg_h = |v: f64| v.to_degrees() * 3600.0;
                write!(
                    f,
                    "gyros too coarse to find north: bias 1-sigma {:.3} deg/h against a horizontal Earth rate of {:.3} deg/h (heading 1-sigma >= {:.0} deg); give the heading or use better gyros",
                    deg_h(*bias_rad_s),
                    deg_h(*earth_rad_s),
                    (bias_rad_s / earth_rad_s).to_degrees()
                )
            }
        }
    }
}

impl SettingsError {
    /// A short name of the refusal, without its numbers (for counting).
    pub fn reason(&self) -> &'static str {
        match self {
            Self::WindowTooShort { .. } => "window too short",
            Self::BadRate(_) => "bad sampling rate",
            Self::WindowTooLong { .. } => "window too long",
            Self::NearPole => "near a pole",
            Self::NotCompiledIn(_) => "method not in this build",
            Self::BadValue(_) => "bad value",
            Self::OutOfRange(_) => "value out of range",
            Self::SwayNeedsLeverArm => "sway needs the lever arm",
            Self::LeverArmSigmaZero => "unknown lever arm of 1-sigma 0",
            Self::GyrosTooCoarse { .. } => "gyros too coarse to find north",
            Self::LeverArmTooLong { .. } | Self::LeverArmSigmaTooLarge { .. } => {
                "lever arm beyond a hull"
            }
        }
    }
}

impl core::error::Error for SettingsError {}

/// The refusal of a method left out of the build, naming the feature that has it.
fn not_compiled_in(f: &mut core::fmt::Formatter<'_>, method: AlignMethod) -> core::fmt::Result {
    write!(
        f,
        "the {} alignment is not in this build (nav-core feature `align-{}`); use static or inertial",
        method.name(),
        method.name()
    )
}

/// What to run, where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlignSettings<T: Scalar> {
    /// The method.
    pub method: AlignMethod,
    /// The known position (of the base's centre of rotation; the base does not travel).
    pub position: Position,
    /// Samples of the whole alignment (see [`super::samples_for`]).
    pub samples: u32,
    /// Samples of the coarse stage of the two-stage methods ([`coarse_samples_for`]).
    pub coarse_samples: u32,
    /// The recording's nominal rate [Hz] (the window's length in seconds is `samples /
    /// rate_hz`; the elapsed time is checked again from the increments' own intervals).
    pub rate_hz: f64,
    /// The IMU's noise, for the 1-sigma of the result (and the filters' tuning).
    pub noise: SensorNoise<T>,
    /// Where the IMU sits relative to [`Self::position`].
    pub lever_arm: LeverArm<T>,
    /// What the base itself does.
    pub base: BaseMotion<T>,
}

impl<T: Scalar> AlignSettings<T> {
    /// Settings for `method` over `seconds` [s] of data at `rate_hz` [Hz] at `position`, with
    /// the IMU's `noise`, an unknown lever arm ([`LeverArm::default`]) and the default
    /// [`BaseMotion`]; refused when the window is shorter than the method's minimum or a value
    /// is not usable.
    pub fn new(
        method: AlignMethod,
        position: Position,
        seconds: f64,
        rate_hz: f64,
        noise: SensorNoise<T>,
    ) -> Result<Self, SettingsError> {
        check_rate(rate_hz)?;
        if seconds > MAX_WINDOW_S {
            return Err(SettingsError::WindowTooLong { seconds });
        }
        // The window asked for, before its sample count (at least one) hides a zero or a
        // negative one.
        let min_s = method.min_seconds();
        if method.compiled_in() && !(seconds + 0.5 / rate_hz >= min_s) {
            return Err(SettingsError::WindowTooShort {
                method,
                seconds,
                min_s,
            });
        }
        let samples = super::samples_for(seconds, rate_hz);
        let coarse_samples = match method {
            AlignMethod::Fine | AlignMethod::Sway => {
                super::samples_for(FINE_COARSE_S, rate_hz).min(samples)
            }
            _ => coarse_samples_for(samples, rate_hz),
        };
        let settings = Self {
            method,
            position,
            samples,
            coarse_samples,
            rate_hz,
            noise,
            lever_arm: LeverArm::default(),
            base: BaseMotion::default(),
        };
        settings.validate_values()?;
        Ok(settings)
    }

    /// The same with `lever_arm`.
    pub fn with_lever_arm(mut self, lever_arm: LeverArm<T>) -> Self {
        self.lever_arm = lever_arm;
        self
    }

    /// The same with `base`.
    pub fn with_base(mut self, base: BaseMotion<T>) -> Self {
        self.base = base;
        self
    }

    /// The window's nominal length [s].
    pub fn seconds(&self) -> f64 {
        f64::from(self.samples) / self.rate_hz
    }

    /// Checks the window against the method's minimum, every value for sanity, and that the
    /// method can answer with the lever arm as given.
    pub fn validate(&self) -> Result<(), SettingsError> {
        self.validate_values()?;
        if self.method == AlignMethod::Sway && matches!(self.lever_arm, LeverArm::Unknown { .. }) {
            return Err(SettingsError::SwayNeedsLeverArm);
        }
        let limit = match self.method {
            AlignMethod::Fine | AlignMethod::Sway => {
                Some(FineConfig::<f64>::default().max_heading_sigma_rad)
            }
            AlignMethod::Static => Some(MAX_STATIC_HEADING_SIGMA_RAD),
            _ => None,
        };
        if let Some(limit) = limit {
            let bias_rad_s = self.noise.gyro_bias_rad_s.to_f64();
            let earth_rad_s = crate::earth::OMEGA_IE * libm::cos(self.position.lat_f64());
            if !(bias_rad_s <= limit * earth_rad_s) {
                return Err(SettingsError::GyrosTooCoarse {
                    bias_rad_s,
                    earth_rad_s,
                });
            }
        }
        Ok(())
    }

    /// [`Self::validate`] without the lever-arm case (the lever arm is set after [`Self::new`]).
    fn validate_values(&self) -> Result<(), SettingsError> {
        if !self.method.compiled_in() {
            return Err(SettingsError::NotCompiledIn(self.method));
        }
        if !(self.rate_hz.is_finite() && (MIN_RATE_HZ..=MAX_RATE_HZ).contains(&self.rate_hz)) {
            return Err(SettingsError::BadRate(self.rate_hz));
        }
        if self.seconds() > MAX_WINDOW_S {
            return Err(SettingsError::WindowTooLong {
                seconds: self.seconds(),
            });
        }
        let min_s = self.method.min_seconds();
        // Rounding of the sample count (a window of exactly the minimum is accepted).
        if self.seconds() + 0.5 / self.rate_hz < min_s {
            return Err(SettingsError::WindowTooShort {
                method: self.method,
                seconds: self.seconds(),
                min_s,
            });
        }
        let lat = self.position.lat_f64();
        if !(lat.is_finite() && libm::cos(lat) >= super::inertial::MIN_COS_LAT) {
            return Err(SettingsError::NearPole);
        }
        let ok = |v: T| v.finite() && v >= T::zero();
        let n = &self.noise;
        if !(ok(n.arw_rad_per_sqrt_s)
            && ok(n.vrw_mps_per_sqrt_s)
            && ok(n.gyro_bias_rad_s)
            && ok(n.accel_bias_mps2))
        {
            return Err(SettingsError::BadValue("the IMU noise"));
        }
        let lever_arm = match self.lever_arm {
            LeverArm::Known(r) => LeverArm::Known(r.map(|v| v.to_f64())),
            LeverArm::Unknown { sigma_m } => LeverArm::Unknown {
                sigma_m: sigma_m.to_f64(),
            },
        };
        let base = BaseMotion {
            position_sigma_m: self.base.position_sigma_m.to_f64(),
            translation_sigma_m: self.base.translation_sigma_m.to_f64(),
        };
        check_geometry(&lever_arm, &base)
    }
}

/// Checks the lever arm and the base's motion in `f64` (a run configuration checks them
/// before its conversion to `f32`, where 1e100 m would arrive as infinite and be refused as
/// not finite): finite, not negative, a lever arm (or its 1-sigma) within
/// [`MAX_LEVER_ARM_M`], a base translation 1-sigma within it too.
pub fn check_geometry(
    lever_arm: &LeverArm<f64>,
    base: &BaseMotion<f64>,
) -> Result<(), SettingsError> {
    let ok = |v: f64| v.is_finite() && v >= 0.0;
    match *lever_arm {
        LeverArm::Known(r) => {
            if !r.iter().all(|v| v.is_finite()) {
                return Err(SettingsError::BadValue(LEVER_ARM_VALUE));
            }
            // hypot: the squares of 1e300 m would overflow.
            let length_m = libm::hypot(libm::hypot(r.x, r.y), r.z);
            if !(length_m <= MAX_LEVER_ARM_M) {
                return Err(SettingsError::LeverArmTooLong { length_m });
            }
        }
        LeverArm::Unknown { sigma_m } => {
            if !ok(sigma_m) {
                return Err(SettingsError::BadValue(LEVER_ARM_SIGMA_VALUE));
            }
            if sigma_m == 0.0 {
                return Err(SettingsError::LeverArmSigmaZero);
            }
            if !(sigma_m <= MAX_LEVER_ARM_M) {
                return Err(SettingsError::LeverArmSigmaTooLarge { sigma_m });
            }
        }
    }
    if !(ok(base.position_sigma_m) && ok(base.translation_sigma_m)) {
        return Err(SettingsError::BadValue(BASE_MOTION_VALUE));
    }
    if !(base.translation_sigma_m <= MAX_LEVER_ARM_M) {
        return Err(SettingsError::OutOfRange(BASE_TRANSLATION_OUT_OF_RANGE));
    }
    Ok(())
}

/// Samples (and seconds) each stage took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Samples in the coarse stage.
    pub coarse_samples: u32,
    /// Samples in the fine stage.
    pub fine_samples: u32,
    /// Seconds in the coarse stage [s].
    pub coarse_s: f64,
    /// Seconds in the fine stage [s].
    pub fine_s: f64,
}

/// The result of an alignment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlignOutcome<T: Scalar> {
    /// The navigation state to start from (at rest at the known position for the coarse
    /// methods).
    pub state: NavState<T>,
    /// Attitude and its 1-sigma.
    pub estimate: AttitudeEstimate<T>,
    /// 1-sigma of the velocity handed over, north, east, down [m/s].
    pub velocity_sigma_m_s: Vector3<T>,
    /// 1-sigma of the position handed over, north, east, down [m].
    pub position_sigma_m: Vector3<T>,
    /// Where the time went.
    pub times: StageTimes,
    /// What the user should know about how the result was reached.
    pub note: Option<AlignNote>,
}

/// Something to know about an `ALIGNED` result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlignNote {
    /// [`AlignMethod::Sway`] found a yaw sway beyond its model's envelope
    /// ([`super::sway::MAX_YAW_SWAY_RAD`]) at the identification: the result is the general
    /// filter's, as [`AlignMethod::Fine`]'s, with its 1-sigma.
    SwayModelOff {
        /// The yaw sway's amplitude [rad].
        yaw_amplitude_rad: f64,
    },
    /// [`AlignMethod::Sway`]'s model was refuted by the data (the refusal it gave: roll or
    /// pitch that is not one sinusoid, a yaw sway grown beyond its envelope, an Earth rate
    /// its measurements pulled off): the result is the general filter's, run beside it, as
    /// [`AlignMethod::Fine`]'s, with its 1-sigma.
    SwayModelRefuted {
        /// What the sway model's filter refused.
        refusal: FineRefusal,
    },
}

impl AlignNote {
    /// A short, fixed name of the note (for counting; the `Display` text carries the figures).
    pub fn reason(&self) -> &'static str {
        match self {
            Self::SwayModelOff { .. } => {
                "sway: model off (yaw sway beyond it), the general filter's answer"
            }
            Self::SwayModelRefuted { .. } => "sway: model refuted, the general filter's answer",
        }
    }
}

impl core::fmt::Display for AlignNote {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::SwayModelOff { yaw_amplitude_rad } => write!(
                f,
                "sway model not applied: yaw sway of {:.2} deg is beyond its {:.1} deg; the general filter's answer (as fine)",
                yaw_amplitude_rad.to_degrees(),
                super::sway::MAX_YAW_SWAY_RAD.to_degrees()
            ),
            Self::SwayModelRefuted { refusal } => write!(
                f,
                "sway model refuted ({refusal}); the general filter's answer (as fine)"
            ),
        }
    }
}

/// Samples of the coarse stage for an alignment of `samples` at `rate_hz` [Hz]: a quarter of
/// it, within [10 s, 30 s] (the inertial method's shortest solution is 10 s; by 30 s it has
/// the heading to a few degrees with tactical sensors), and never more than `samples`.
pub fn coarse_samples_for(samples: u32, rate_hz: f64) -> u32 {
    let min = super::samples_for(super::inertial::MIN_DURATION_S, rate_hz);
    let max = super::samples_for(30.0, rate_hz);
    (samples / 4).clamp(min, max.max(min)).min(samples)
}

// One coarse stage lives in the machine for the whole alignment and is never moved in the
// sample path; no allocator (no_std) to box the larger one.
#[allow(clippy::large_enum_variant)]
enum Coarse<T: Scalar> {
    Static(StaticAlignment<T>),
    Inertial(InertialAlignment<T>),
}

/// The alignment state machine (module docs).
pub struct Aligner<T: Scalar> {
    settings: AlignSettings<T>,
    limits: InputLimits<T>,
    coarse: Coarse<T>,
    /// The fine stage, kept apart so that only the one in use is ever made, and started in
    /// place ([`start_fine`], [`start_sway`]: the sway filters are some 30 KB in `f32`, beyond
    /// what an MCU task's stack can hold twice). The sway method runs the general bank beside
    /// its own: its answer when the sway model is off or refuted.
    kalman: Option<Bank<T, FINE_STATES, NoExtension>>,
    /// Only in a build with the sway method: its filters would take their 30 KB of the
    /// (stack-held) machine in every run otherwise.
    #[cfg(feature = "align-sway")]
    sway: Option<SwayAlignment<T>>,
    stage: Stage,
    times: StageTimes,
    failure: Option<AlignFailure>,
    outcome: Option<AlignOutcome<T>>,
    refused: u32,
    /// Body rate of the last increment [rad/s] (the lever arm's velocity at the hand-over).
    last_rate: Vector3<T>,
    /// Block scatter of the coarse stage's increments (is the base still?).
    still: Stillness,
    /// The fine stage's mean increments: on a still base, their Earth rate against the
    /// latitude's ([`AlignFailure::Latitude`]).
    fine_means: StaticAlignment<T>,
}

impl<T: Scalar> Aligner<T> {
    /// A machine at the start of the coarse stage ([`Stage::Failed`] at once, with
    /// [`AlignFailure::NotCompiledIn`], for a method not in this build: settings made past
    /// [`AlignSettings::new`]'s check).
    pub fn new(settings: AlignSettings<T>) -> Self {
        let missing = !settings.method.compiled_in();
        let lat = settings.position.lat::<T>();
        let h = settings.position.h::<T>();
        let coarse = match settings.method {
            AlignMethod::Static => Coarse::Static(StaticAlignment::new()),
            AlignMethod::Inertial | AlignMethod::Fine | AlignMethod::Sway => {
                // The window: the whole alignment for the inertial method, the coarse stage
                // (levelling only) for the two-stage ones.
                let samples = if settings.method == AlignMethod::Inertial {
                    settings.samples
                } else {
                    settings.coarse_samples
                };
                let window_s = f64::from(samples) / settings.rate_hz;
                let a = InertialAlignment::new(lat, h, window_s).with_noise(settings.noise);
                Coarse::Inertial(match settings.lever_arm {
                    LeverArm::Known(r) => a.with_lever_arm(r),
                    LeverArm::Unknown { sigma_m } => a.with_lever_arm_unknown(sigma_m),
                })
            }
        };
        Self {
            settings,
            limits: InputLimits::default(),
            coarse,
            kalman: None,
            #[cfg(feature = "align-sway")]
            sway: None,
            stage: if missing {
                Stage::Failed
            } else {
                Stage::Coarse
            },
            times: StageTimes::default(),
            failure: missing.then_some(AlignFailure::NotCompiledIn(settings.method)),
            outcome: None,
            refused: 0,
            last_rate: Vector3::zeros(),
            still: Stillness::new(),
            fine_means: StaticAlignment::new(),
        }
    }

    /// The stage now.
    pub fn stage(&self) -> Stage {
        self.stage
    }

    /// Why it failed, once [`Stage::Failed`].
    pub fn failure(&self) -> Option<AlignFailure> {
        self.failure
    }

    /// The result, once [`Stage::Aligned`].
    pub fn outcome(&self) -> Option<&AlignOutcome<T>> {
        self.outcome.as_ref()
    }

    /// The general filter bank, once the fine stage of [`AlignMethod::Fine`] or
    /// [`AlignMethod::Sway`] has started (for inspection).
    pub fn fine_bank(&self) -> Option<&Bank<T, FINE_STATES, NoExtension>> {
        self.kalman.as_ref()
    }

    /// The sway stage, once [`AlignMethod::Sway`]'s has started (for inspection; no longer
    /// fed once no filter applies its model, [`SwayAlignment::model_in_use`]).
    #[cfg(feature = "align-sway")]
    pub fn sway(&self) -> Option<&SwayAlignment<T>> {
        self.sway.as_ref()
    }

    /// The sway stage: never in a build without the sway method.
    #[cfg(not(feature = "align-sway"))]
    pub fn sway(&self) -> Option<&SwayAlignment<T>> {
        None
    }

    /// [`Self::sway`], to feed it.
    #[cfg(feature = "align-sway")]
    fn sway_mut(&mut self) -> Option<&mut SwayAlignment<T>> {
        self.sway.as_mut()
    }

    /// [`Self::sway`], to feed it: never in a build without the sway method.
    #[cfg(not(feature = "align-sway"))]
    fn sway_mut(&mut self) -> Option<&mut SwayAlignment<T>> {
        None
    }

    /// Increments refused by the input limits (not counted as alignment samples).
    pub fn refused(&self) -> u32 {
        self.refused
    }

    /// Samples used so far.
    pub fn samples(&self) -> u32 {
        self.times.coarse_samples + self.times.fine_samples
    }

    /// Feeds one increment (ignored once aligned or failed); returns where the machine is
    /// after it.
    pub fn add(&mut self, inc: &ImuIncrement<T>) -> Progress<T> {
        if matches!(self.stage, Stage::Coarse | Stage::Fine) {
            if inc.check(&self.limits).is_err() {
                self.refused = self.refused.saturating_add(1);
            } else {
                self.step(inc);
            }
        }
        self.progress()
    }

    /// Where the machine is.
    pub fn progress(&self) -> Progress<T> {
        match (self.stage, self.outcome, self.failure) {
            (Stage::Aligned, Some(o), _) => Progress::Aligned(o),
            (Stage::Failed, _, Some(f)) => Progress::Failed(f),
            (Stage::Fine, ..) => Progress::Fine,
            _ => Progress::Coarse,
        }
    }

    fn step(&mut self, inc: &ImuIncrement<T>) {
        let dt = inc.dt.to_f64();
        self.last_rate = inc.delta_theta_ib_b / inc.dt;
        if self.stage == Stage::Fine {
            self.step_fine(inc, dt);
        } else {
            self.step_coarse(inc, dt);
        }
    }

    /// One sample of the coarse stage (`dt` [s]); starts the fine stage or ends the
    /// alignment after its last. Not inlined, as [`Self::step_fine`]: the two stages' frames
    /// are never on the stack together.
    #[inline(never)]
    fn step_coarse(&mut self, inc: &ImuIncrement<T>, dt: f64) {
        self.still.add(inc);
        match &mut self.coarse {
            Coarse::Static(a) => a.add(inc),
            Coarse::Inertial(a) => {
                // Checked above with the same limits: cannot be refused.
                let _ = a.add(inc);
            }
        }
        self.times.coarse_samples += 1;
        self.times.coarse_s += dt;
        let two_stage = matches!(self.settings.method, AlignMethod::Fine | AlignMethod::Sway);
        if self.samples() >= self.settings.samples {
            self.finish_coarse();
        } else if two_stage && self.times.coarse_samples >= self.settings.coarse_samples {
            self.start_fine();
        }
    }

    /// One sample of the fine stage (`dt` [s]). Not inlined: the filters' interval
    /// temporaries (some 30 KB in `f32` for the sway filters' 37 states) then take stack only
    /// on this path, not under the coarse stage's ([`Self::step_coarse`]) or the filters'
    /// start ([`start_sway`]).
    #[inline(never)]
    fn step_fine(&mut self, inc: &ImuIncrement<T>, dt: f64) {
        // The filters' code is linked only where their features are on (`cfg!` folds to a
        // constant: the calls are dead code without them, and the stage never starts).
        if !cfg!(feature = "align-fine") {
            return;
        }
        // Checked above with the filters' default limits: cannot be refused.
        if let Some(f) = &mut self.kalman {
            let _ = f.add(inc);
        }
        // With its model off in every filter the sway bank is the general one: not run
        // twice.
        if let Some(f) = self.sway_mut().filter(|f| f.model_in_use()) {
            let _ = f.add(inc);
        }
        self.fine_means.add(inc);
        self.times.fine_samples += 1;
        self.times.fine_s += dt;
        if self.samples() >= self.settings.samples {
            self.finish_fine();
        }
    }

    /// Hands the coarse attitude and its 1-sigma to the fine stage.
    fn start_fine(&mut self) {
        let Coarse::Inertial(a) = &self.coarse else {
            return;
        };
        // Not reached without the feature (the settings refuse the method): its code left out.
        if !cfg!(feature = "align-fine") {
            return;
        }
        let position = self.settings.position;
        // A mean specific force a factor off gravity is the data's scale (rate, timestamps,
        // units), not the base's motion: refused here with the numbers, not later as an
        // unresolved heading. (Motion of a swaying base is the fine stage's to judge.)
        let mismatch = GravityMismatch {
            measured_mps2: a.mean_specific_force_mps2(),
            gravity_mps2: crate::earth::normal_gravity(position.lat_f64(), position.h_f64()),
        };
        if mismatch.is_scale() {
            self.failure = Some(AlignFailure::Inertial(
                InertialAlignError::SpecificForceNotGravity(mismatch),
            ));
            self.stage = Stage::Failed;
            return;
        }
        let Some(q_b_c) = a.level() else {
            self.failure = Some(AlignFailure::Inertial(InertialAlignError::NonFinite));
            self.stage = Stage::Failed;
            return;
        };
        let fine = FineConfig {
            noise: self.settings.noise,
            lever_arm: self.settings.lever_arm,
            translation: Translation {
                horizontal_sigma_m: self.settings.base.translation_sigma_m,
                vertical_sigma_m: self.settings.base.translation_sigma_m,
                ..Translation::default()
            },
            ..FineConfig::default()
        };
        #[cfg(feature = "align-sway")]
        if self.settings.method == AlignMethod::Sway {
            start_sway(&mut self.sway, q_b_c, self.last_rate, position, fine);
        }
        start_fine(&mut self.kalman, q_b_c, self.last_rate, position, fine);
        self.stage = Stage::Fine;
    }

    /// Ends the alignment with the fine stage's result.
    fn finish_fine(&mut self) {
        let Some(general) = &self.kalman else {
            return;
        };
        // The filters take the latitude's Earth rate as given: gyros that contradict it on a
        // still base (a FOG at 45 deg aligned at -45 or 0 deg) are refused as the static
        // method refuses them (a swaying base's mean rates hold its sway: not tested).
        let n = &self.settings.noise;
        let still = self
            .still
            .check(n.arw_rad_per_sqrt_s.to_f64(), n.vrw_mps_per_sqrt_s.to_f64());
        let position = self.settings.position;
        if let (Some((true, _)), Err(AlignError::LatitudeMismatch(m))) = (
            still,
            self.fine_means
                .solve(position.lat::<T>(), position.h::<T>()),
        ) {
            self.failure = Some(AlignFailure::Latitude(m));
            self.stage = Stage::Failed;
            return;
        }
        // The sway model's answer where it holds; else the general filter's, with a note
        // (its refusal where it refuses too: the data support no answer).
        let (result, note) = match self.sway() {
            None => (general.outcome(), None),
            Some(f) => match f.model_off() {
                Some(a) => (
                    general.outcome(),
                    Some(AlignNote::SwayModelOff {
                        yaw_amplitude_rad: a,
                    }),
                ),
                None => match f.outcome() {
                    Ok(o) => (Ok(o), None),
                    Err(refusal) => (
                        general.outcome(),
                        Some(AlignNote::SwayModelRefuted { refusal }),
                    ),
                },
            },
        };
        let o = match result {
            Ok(o) => o,
            Err(r) => {
                self.failure = Some(AlignFailure::Fine(r));
                self.stage = Stage::Failed;
                return;
            }
        };
        let site = self.settings.base.position_sigma_m;
        let (state, estimate, velocity_sigma_m_s) = (o.state, o.estimate, o.velocity_sigma_m_s);
        let position_sigma_m = o.position_sigma_m.map(|s| (s * s + site * site).sqrt());
        self.outcome = Some(AlignOutcome {
            state,
            estimate,
            velocity_sigma_m_s,
            position_sigma_m,
            times: self.times,
            note,
        });
        self.stage = Stage::Aligned;
    }

    /// Solves the coarse stage and ends the alignment with its result.
    fn finish_coarse(&mut self) {
        let position = self.settings.position;
        let n = &self.settings.noise;
        let scatter = self
            .still
            .check(n.arw_rad_per_sqrt_s.to_f64(), n.vrw_mps_per_sqrt_s.to_f64());
        let min_s = self.settings.method.min_seconds();
        // Half a nominal interval of slack: f32 intervals of 2.5 ms sum to 9.99999977 s in 10 s.
        let estimate = if self.times.coarse_s + 0.5 / self.settings.rate_hz < min_s {
            // The header's rate said enough samples; their own intervals say otherwise.
            Err(AlignFailure::WindowTooShort {
                seconds: self.times.coarse_s,
                min_s,
            })
        } else {
            match &self.coarse {
                Coarse::Static(a) => match scatter {
                    Some((false, sc)) => Err(AlignFailure::BaseMoving(sc)),
                    _ => a
                        .solve(position.lat::<T>(), position.h::<T>())
                        .map(|r| AttitudeEstimate {
                            q_b_n: r.q_b_n(),
                            sigma_rad: static_sigma(&self.settings, r.duration),
                            elapsed_s: r.duration,
                        })
                        .map_err(AlignFailure::Static),
                },
                Coarse::Inertial(a) => a
                    .estimate()
                    .and_then(|e| match scatter {
                        // A still base does not translate (its accelerometers would scatter).
                        Some((true, _)) => Ok(e),
                        _ => with_translation_leak(a, &self.settings, e),
                    })
                    .map_err(AlignFailure::Inertial),
            }
        };
        match estimate {
            Ok(estimate) => {
                let still = matches!(scatter, Some((true, _)));
                let accel_excess = scatter.map_or(f64::INFINITY, |(_, sc)| sc.accel_excess);
                self.outcome = Some(coarse_handover(
                    &self.settings,
                    estimate,
                    &self.last_rate,
                    still.then_some(accel_excess),
                    self.times,
                ));
                self.stage = Stage::Aligned;
            }
            Err(e) => {
                self.failure = Some(e);
                self.stage = Stage::Failed;
            }
        }
    }
}

/// The inertial-frame estimate `e` of a base that is not still, with ramps shorter than
/// [`RAMP_MAX_S`](super::inertial::RAMP_MAX_S) (windows below 120 s): the leak of its
/// translation prior ([`BaseMotion::translation_sigma_m`], the fine filter's wave model)
/// through the ramps added to its 1-sigma ([`InertialAlignment::translation_leak`]), or refused
/// when that leak alone is beyond the largest heading 1-sigma answered. With such ramps the
/// check's half-length ramps leak about as much as the main ones and can agree with them by
/// chance (on the family, 60 s windows answered 12 sigma off in heading). With the longest
/// ramps the check's leak is some 50 times the main one's, so its excess bounds what is
/// left (module docs of [`super::inertial`]) and the prior, a worst case, is not added.
fn with_translation_leak<T: Scalar>(
    a: &InertialAlignment<T>,
    s: &AlignSettings<T>,
    mut e: AttitudeEstimate<T>,
) -> Result<AttitudeEstimate<T>, InertialAlignError> {
    if a.ramp_s() >= super::inertial::RAMP_MAX_S - 1e-9 {
        return Ok(e);
    }
    let wave = Translation {
        horizontal_sigma_m: s.base.translation_sigma_m.to_f64(),
        ..Translation::<f64>::default()
    };
    let (tilt, heading) = a.translation_leak(&wave);
    let add = |sigma: T, leak: f64| {
        let s = sigma.to_f64();
        T::c(libm::sqrt(s * s + leak * leak))
    };
    e.sigma_rad = Vector3::new(
        add(e.sigma_rad.x, tilt),
        add(e.sigma_rad.y, tilt),
        add(e.sigma_rad.z, heading),
    );
    // The leak with the rest: a heading 1-sigma beyond the limit is no heading.
    if !(e.sigma_rad.z.to_f64() <= super::inertial::MAX_HEADING_SIGMA_RAD) {
        return Err(InertialAlignError::TranslationLeak);
    }
    Ok(e)
}

/// Longest period of base motion the still-base velocity bound assumes [s].
const STILL_LONGEST_PERIOD_S: f64 = 20.0;

/// The hand-over of a coarse method: the IMU at the centre plus its lever-arm offset, moving
/// with the lever arm's velocity `C_b_n (omega x l)` (`omega` the last increment's rate; the
/// Earth rate's share, below 1e-3 m/s at 10 m, left in the 1-sigma), with 1-sigma from what
/// is known: the given position's, the unknown lever arm's prior, the attitude's 1-sigma turning
/// the lever arm, and the base's translation — on a base the stillness test found still
/// (`still_accel_excess` [m^2/s^4]: the accelerometers' block variance above their noise), the
/// velocity an oscillation of that acceleration could have at periods up to
/// [`STILL_LONGEST_PERIOD_S`] (at least 1 mm/s); otherwise the translation prior's
/// ([`BaseMotion::translation_sigma_m`] at [`Translation::default`]'s wave frequency).
fn coarse_handover<T: Scalar>(
    s: &AlignSettings<T>,
    estimate: AttitudeEstimate<T>,
    omega_ib_b: &Vector3<T>,
    still_accel_excess: Option<f64>,
    times: StageTimes,
) -> AlignOutcome<T> {
    let c_b_n = estimate.q_b_n.to_rotation_matrix().into_inner();
    let (lever, lever_sigma) = match s.lever_arm {
        LeverArm::Known(r) => (r, T::c(super::fine::LEVER_ARM_KNOWN_SIGMA_M)),
        LeverArm::Unknown { sigma_m } => (Vector3::zeros(), sigma_m),
    };
    let offset = c_b_n * lever;
    let v_eb_n = c_b_n * omega_ib_b.cross(&lever);
    let att = estimate
        .sigma_rad
        .iter()
        .map(|v| if v.finite() { *v * *v } else { T::zero() })
        .fold(T::zero(), |a, b| a + b);
    let site = s.base.position_sigma_m;
    let (trans_p, trans_v) = match still_accel_excess {
        Some(excess) => {
            let w = core::f64::consts::TAU / STILL_LONGEST_PERIOD_S;
            let v = (libm::sqrt(excess.max(0.0)) / w).max(1e-3);
            (T::c(v / w), T::c(v))
        }
        None => {
            let d = s.base.translation_sigma_m;
            (d, d * Translation::<T>::default().omega0_rad_s)
        }
    };
    let rate = omega_ib_b.norm();
    let l2 = lever.norm_squared();
    let p2 = site * site + trans_p * trans_p + lever_sigma * lever_sigma + att * l2;
    let v2 = trans_v * trans_v + rate * rate * (lever_sigma * lever_sigma + att * l2);
    let position = s.position.offset_ned(offset.map(T::to_f64).into());
    AlignOutcome {
        state: NavState {
            q_b_n: estimate.q_b_n,
            v_eb_n,
            position,
        },
        estimate,
        velocity_sigma_m_s: Vector3::repeat(v2.sqrt()),
        position_sigma_m: Vector3::repeat(p2.sqrt()),
        times,
        note: None,
    }
}

/// Roll, pitch, yaw 1-sigma [rad] of a static analytic alignment over `t_s` [s]: levelling
/// from the mean specific force (`VRW / (g sqrt(T))` and `b_a / g`), gyrocompassing from the
/// mean rate (`ARW / (w sqrt(T))` and `b_g / w`, `w = Omega cos(lat)`; Groves §14.2.1 with the
/// east gyro error over the horizontal Earth rate), the tilt's share of the heading
/// (`tan(lat)` times the tilt, Titterton & Weston §10.2.1).
fn static_sigma<T: Scalar>(settings: &AlignSettings<T>, t_s: T) -> Vector3<T> {
    let n = &settings.noise;
    let lat = settings.position.lat::<T>();
    let g = earth::normal_gravity(lat, settings.position.h::<T>());
    let w = T::c(earth::OMEGA_IE) * lat.pcos();
    let tilt2 = n.vrw_mps_per_sqrt_s * n.vrw_mps_per_sqrt_s / (g * g * t_s)
        + n.accel_bias_mps2 * n.accel_bias_mps2 / (g * g);
    let tan_lat = lat.psin() / lat.pcos();
    let yaw2 = (n.arw_rad_per_sqrt_s * n.arw_rad_per_sqrt_s / t_s
        + n.gyro_bias_rad_s * n.gyro_bias_rad_s)
        / (w * w)
        + tilt2 * tan_lat * tan_lat;
    Vector3::new(tilt2.sqrt(), tilt2.sqrt(), yaw2.sqrt())
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::attitude::from_euler;
    use nalgebra::UnitQuaternion;

    const DT: f64 = 0.0025;

    fn settings(method: AlignMethod, seconds: f64) -> AlignSettings<f64> {
        let noise = SensorNoise {
            arw_rad_per_sqrt_s: 2.6e-6,
            vrw_mps_per_sqrt_s: 1e-3,
            gyro_bias_rad_s: 1e-6,
            accel_bias_mps2: 5e-3,
        };
        let position = Position::from_degrees(45.0, 7.5, 100.0);
        let samples = super::super::samples_for(seconds, 1.0 / DT);
        AlignSettings {
            method,
            position,
            samples,
            coarse_samples: coarse_samples_for(samples, 1.0 / DT),
            rate_hz: 1.0 / DT,
            noise,
            lever_arm: LeverArm::Known(Vector3::zeros()),
            base: BaseMotion::default(),
        }
    }

    /// The exact increment of a body at rest at the settings' position.
    fn at_rest(s: &AlignSettings<f64>, q_b_n: &UnitQuaternion<f64>) -> ImuIncrement<f64> {
        let lat = s.position.lat::<f64>();
        let q_n_b = q_b_n.inverse();
        let g = earth::normal_gravity(lat, s.position.h::<f64>());
        ImuIncrement {
            delta_theta_ib_b: q_n_b * earth::omega_ie_n(lat) * DT,
            delta_v_ib_b: q_n_b * Vector3::new(0.0, 0.0, -g) * DT,
            dt: DT,
        }
    }

    /// A method left out of the build (nav-core without `align-fine`/`align-sway`, as the
    /// STM32F405 board's firmware) is refused by the settings with a reason naming the
    /// feature, and a machine made past that check fails at once instead of running another
    /// method. `cargo test -p nav-core --no-default-features --lib not_compiled_in`.
    #[test]
    fn a_method_not_compiled_in_is_refused_with_its_feature() {
        let position = Position::from_degrees(45.0, 7.5, 100.0);
        let noise = settings(AlignMethod::Static, 60.0).noise;
        for method in AlignMethod::ALL {
            let made = AlignSettings::new(method, position, 60.0, 1.0 / DT, noise);
            if method.compiled_in() {
                assert!(made.is_ok(), "{method:?}: {made:?}");
                continue;
            }
            assert_eq!(made, Err(SettingsError::NotCompiledIn(method)));
            let text = std::format!("{}", SettingsError::NotCompiledIn(method));
            assert!(
                text.contains(&std::format!("align-{}", method.name())),
                "{text}"
            );
            let forced = AlignSettings {
                method,
                ..settings(AlignMethod::Inertial, 60.0)
            };
            let machine = Aligner::new(forced);
            assert_eq!(machine.stage(), Stage::Failed);
            assert_eq!(machine.failure(), Some(AlignFailure::NotCompiledIn(method)));
        }
        // The default build has every method.
        let all = cfg!(feature = "align-fine") && cfg!(feature = "align-sway");
        assert_eq!(AlignMethod::ALL.iter().all(|m| m.compiled_in()), all);
    }

    #[test]
    fn every_method_aligns_on_exact_data_through_its_stages() {
        let q = from_euler(0.02, -0.01, 1.0);
        for method in AlignMethod::ALL {
            let s = settings(method, 40.0);
            let inc = at_rest(&s, &q);
            let mut a = Aligner::new(s);
            let mut fine_at = None;
            let mut outcome = None;
            for k in 1..=s.samples {
                match a.add(&inc) {
                    Progress::Coarse => assert!(fine_at.is_none(), "{method:?}: back to coarse"),
                    Progress::Fine => {
                        fine_at.get_or_insert(k);
                    }
                    Progress::Aligned(o) => {
                        assert_eq!(k, s.samples, "{method:?}: aligned early");
                        outcome = Some(o);
                    }
                    Progress::Failed(f) => panic!("{method:?}: {f}"),
                }
            }
            let o = outcome.unwrap_or_else(|| panic!("{method:?}: not aligned"));
            let two_stage = matches!(method, AlignMethod::Fine | AlignMethod::Sway);
            // Fine once the coarse stage's last sample is in.
            assert_eq!(fine_at, two_stage.then_some(s.coarse_samples), "{method:?}");
            assert_eq!(o.times.coarse_samples + o.times.fine_samples, s.samples);
            // Exact data: the analytic methods are exact; the filter is left with a
            // millionth of its prior (0.2 mdeg of a 10 deg-scale prior after 35 s).
            let err = o.estimate.q_b_n.angle_to(&q).to_degrees();
            let tol = if method == AlignMethod::Fine {
                1e-3
            } else {
                1e-4
            };
            assert!(err < tol, "{method:?}: {err} deg");
            assert!(
                o.estimate
                    .sigma_rad
                    .iter()
                    .all(|x| x.is_finite() && *x > 0.0)
            );
            assert_eq!(a.stage(), Stage::Aligned);
            // Later samples change nothing.
            assert_eq!(a.add(&inc), Progress::Aligned(o));
        }
    }

    #[test]
    fn refuses_with_a_reason_and_skips_bad_increments() {
        let q = UnitQuaternion::identity();
        // A base turning at 1 deg/s: static alignment refuses it.
        let s = settings(AlignMethod::Static, 12.0);
        let mut inc = at_rest(&s, &q);
        inc.delta_theta_ib_b.z += 1f64.to_radians() * DT;
        let mut a = Aligner::new(s);
        let mut last = Progress::Coarse;
        for _ in 0..s.samples {
            last = a.add(&inc);
        }
        assert_eq!(
            last,
            Progress::Failed(AlignFailure::Static(AlignError::BaseRotating))
        );
        assert_eq!(a.stage(), Stage::Failed);
        // A window or a rate beyond any IMU's: refused (their sample count would be clamped
        // to the counter's range, and the window reported as something else).
        let site = Position::from_degrees(45.0, 7.5, 100.0);
        let noise = settings(AlignMethod::Static, 60.0).noise;
        let long = AlignSettings::new(AlignMethod::Static, site, 1e300, 400.0, noise);
        assert!(
            matches!(long, Err(SettingsError::WindowTooLong { .. })),
            "{long:?}"
        );
        for rate in [1e12, 0.0, f64::NAN] {
            let fast = AlignSettings::new(AlignMethod::Static, site, 60.0, rate, noise);
            assert!(matches!(fast, Err(SettingsError::BadRate(_))), "{rate}");
        }
        assert!(
            AlignSettings::new(AlignMethod::Static, site, MAX_WINDOW_S, MAX_RATE_HZ, noise).is_ok()
        );
        // Below the navigator's longest interval's rate every increment is refused: a 5 Hz
        // recording aligned on none of them ("0 of 100 samples used") without naming its rate;
        // a 1e-6 Hz one (a PSINS interval of 1e9 ms) was refused for a window of 1e6 s.
        let max_dt = crate::InputLimits::<f64>::default().max_dt;
        assert_eq!(MIN_RATE_HZ, 1.0 / max_dt);
        for rate in [5.0, 1e-6, MIN_RATE_HZ - 1e-9] {
            let slow = AlignSettings::new(AlignMethod::Static, site, 20.0, rate, noise);
            assert!(matches!(slow, Err(SettingsError::BadRate(_))), "{rate}");
        }
        assert_eq!(
            std::format!("{}", SettingsError::BadRate(5.0)),
            "sampling rate 5 Hz is not within [10, 40000] Hz (below 10 Hz every increment is \
             longer than the 0.1 s the navigator accepts)"
        );
        // A window at the minimum that timestamp jitter shortened: how much longer to ask.
        let e = std::format!(
            "{}",
            AlignFailure::WindowTooShort {
                seconds: 9.990,
                min_s: 10.0
            }
        );
        assert!(
            e.ends_with("ask for a window 0.010 s longer or more, e.g. 10.1 s"),
            "{e}"
        );
        assert_eq!(longer_window_s(9.621, 10.0), 10.4);
        assert_eq!(longer_window_s(29.9, 30.0), 30.1);
        // Too high: the high limit's reason (it gave the low limit's).
        let e = std::format!("{}", SettingsError::BadRate(5e4));
        assert!(e.contains("(no IMU samples faster than 40 kHz"), "{e}");
        assert!(AlignSettings::new(AlignMethod::Static, site, 20.0, MIN_RATE_HZ, noise).is_ok());
        // A window shorter than the method's minimum: refused by the settings, and by the
        // machine from the increments' own intervals when the settings were built by hand.
        for method in AlignMethod::ALL {
            let e = AlignSettings::new(
                method,
                Position::from_degrees(45.0, 7.5, 100.0),
                0.0,
                400.0,
                settings(method, 60.0).noise,
            )
            .unwrap_err();
            assert!(
                matches!(e, SettingsError::WindowTooShort { min_s, .. } if min_s == method.min_seconds()),
                "{method:?}: {e}"
            );
            let text = std::format!("{e}");
            assert!(text.contains("minimum"), "{text}");
        }
        // Sway needs the lever arm given (any value, zero at the centre).
        let sway =
            settings(AlignMethod::Sway, 60.0).with_lever_arm(LeverArm::Unknown { sigma_m: 5.0 });
        assert_eq!(sway.validate(), Err(SettingsError::SwayNeedsLeverArm));
        assert!(std::format!("{}", SettingsError::SwayNeedsLeverArm).contains("--lever-arm"));
        let given = sway.with_lever_arm(LeverArm::Known(Vector3::zeros()));
        assert_eq!(given.validate(), Ok(()));
        // Gyros whose bias alone puts the heading beyond 10 deg: the filters refuse them
        // before any sample; the coarse methods answer or refuse from the data, the static one
        // up to a heading 1-sigma of 30 deg.
        for method in AlignMethod::ALL {
            let mut s = settings(method, 120.0).with_lever_arm(LeverArm::Known(Vector3::zeros()));
            let earth = crate::earth::OMEGA_IE * libm::cos(s.position.lat_f64());
            s.noise.gyro_bias_rad_s = 0.5 * earth;
            let refused = matches!(s.validate(), Err(SettingsError::GyrosTooCoarse { .. }));
            let filter = matches!(method, AlignMethod::Fine | AlignMethod::Sway);
            assert_eq!(refused, filter, "{method:?} at 0.5");
            s.noise.gyro_bias_rad_s = 0.55 * earth;
            let refused = matches!(s.validate(), Err(SettingsError::GyrosTooCoarse { .. }));
            assert_eq!(
                refused,
                method != AlignMethod::Inertial,
                "{method:?} at 0.55"
            );
        }
        for method in AlignMethod::ALL {
            let mut s = settings(method, 120.0).with_lever_arm(LeverArm::Known(Vector3::zeros()));
            let earth = crate::earth::OMEGA_IE * libm::cos(s.position.lat_f64());
            s.noise.gyro_bias_rad_s = 0.15 * earth;
            assert!(s.validate().is_ok(), "{method:?} at 0.15 of the Earth rate");
            s.noise.gyro_bias_rad_s = 0.2 * earth;
            let filter = matches!(method, AlignMethod::Fine | AlignMethod::Sway);
            match s.validate() {
                Err(e @ SettingsError::GyrosTooCoarse { .. }) if filter => {
                    assert!(
                        std::format!("{e}").contains("too coarse to find north"),
                        "{e}"
                    );
                }
                Ok(()) if !filter => {}
                other => panic!("{method:?}: {other:?}"),
            }
        }
        let s = settings(AlignMethod::Inertial, 5.0);
        let inc = at_rest(&s, &q);
        let mut a = Aligner::new(s);
        for _ in 0..s.samples {
            last = a.add(&inc);
        }
        assert!(
            matches!(
                last,
                Progress::Failed(AlignFailure::WindowTooShort { min_s: 10.0, .. })
            ),
            "{last:?}"
        );
        // A NaN increment is refused and not counted.
        let s = settings(AlignMethod::Fine, 40.0);
        let mut a = Aligner::new(s);
        let mut bad = at_rest(&s, &q);
        bad.delta_v_ib_b.x = f64::NAN;
        assert_eq!(a.add(&bad), Progress::Coarse);
        assert_eq!((a.samples(), a.refused()), (0, 1));
    }

    /// A lever arm (or its 1-sigma) beyond a hull's length is refused naming its size, in f32
    /// too (whose square of 1e30 would overflow); 100 m itself is accepted.
    #[test]
    fn a_lever_arm_beyond_the_plausible_size_is_refused() {
        let s = settings(AlignMethod::Fine, 40.0);
        let e = s
            .with_lever_arm(LeverArm::Known(Vector3::new(1e30, 0.0, 0.0)))
            .validate()
            .unwrap_err();
        assert_eq!(e, SettingsError::LeverArmTooLong { length_m: 1e30 });
        assert!(
            std::format!("{e}").starts_with("lever arm 1.000e30 m is beyond 100 m"),
            "{e}"
        );
        let e = s
            .with_lever_arm(LeverArm::Known(Vector3::new(60.0, 0.0, 80.0 + 1e-9)))
            .validate()
            .unwrap_err();
        assert!(matches!(e, SettingsError::LeverArmTooLong { length_m } if length_m > 100.0));
        let at_limit = Vector3::new(60.0, 0.0, 80.0);
        assert_eq!(
            s.with_lever_arm(LeverArm::Known(at_limit)).validate(),
            Ok(())
        );
        let e = s
            .with_lever_arm(LeverArm::Unknown { sigma_m: 1e3 })
            .validate()
            .unwrap_err();
        assert_eq!(e, SettingsError::LeverArmSigmaTooLarge { sigma_m: 1e3 });
        assert!(
            std::format!("{e}").starts_with("lever arm 1-sigma 1000 m is beyond 100 m"),
            "{e}"
        );
        // A 1-sigma of 0 was accepted: a known zero lever arm by another name.
        let e = s
            .with_lever_arm(LeverArm::Unknown { sigma_m: 0.0 })
            .validate()
            .unwrap_err();
        assert_eq!(e, SettingsError::LeverArmSigmaZero);
        assert!(std::format!("{e}").contains("--lever-arm 0,0,0"), "{e}");
        let mut s32 = AlignSettings::<f32>::new(
            AlignMethod::Inertial,
            Position::from_degrees(45.0, 7.5, 100.0),
            20.0,
            400.0,
            SensorNoise::seed003(),
        )
        .unwrap();
        s32.lever_arm = LeverArm::Known(Vector3::new(1e30_f32, 1e30, 0.0));
        assert!(matches!(
            s32.validate(),
            Err(SettingsError::LeverArmTooLong { length_m }) if length_m > 1e30
        ));
    }

    /// A sway over a whole number of periods averages out of the mean rate and specific force,
    /// but not out of their block scatter: static alignment refuses it whatever the window.
    #[test]
    fn static_refuses_a_sway_of_whole_periods() {
        for seconds in [20.0, 40.0, 96.0] {
            let s = settings(AlignMethod::Static, seconds);
            let mut a = Aligner::new(s);
            let mut last = Progress::Coarse;
            let (amp, w) = (1f64.to_radians(), core::f64::consts::TAU / 4.0);
            for k in 0..s.samples {
                let t = f64::from(k) * DT;
                let q = from_euler(amp * (w * t).sin(), 0.0, 0.3);
                let mut inc = at_rest(&s, &q);
                inc.delta_theta_ib_b.x += amp * w * (w * (t + DT / 2.0)).cos() * DT;
                last = a.add(&inc);
            }
            assert!(
                matches!(last, Progress::Failed(AlignFailure::BaseMoving(_))),
                "{seconds} s: {last:?}"
            );
        }
    }

    #[test]
    fn coarse_stage_is_a_quarter_within_ten_to_thirty_seconds() {
        assert_eq!(coarse_samples_for(400 * 120, 400.0), 400 * 30);
        assert_eq!(coarse_samples_for(400 * 60, 400.0), 400 * 15);
        assert_eq!(coarse_samples_for(400 * 20, 400.0), 400 * 10);
        assert_eq!(coarse_samples_for(400 * 5, 400.0), 400 * 5);
        assert_eq!(coarse_samples_for(400 * 600, 400.0), 400 * 30);
    }
}
