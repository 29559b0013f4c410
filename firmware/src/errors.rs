//! nav-core's and the protocol's errors as defmt formats: the reason as an interned string,
//! the figures as defmt parameters (`{=f64}`, `{=u32}`), formatted on the host.
//!
//! Their `Display` texts (what `nav replay` prints) go through core's float formatting, some
//! 15-18 KB of flash that the board cannot spare; these wrappers say the same words (interned:
//! no flash) with the same figures (at full precision: defmt has no `{:.1}`; some in the
//! unit of their field). Texts without a float are word for word
//! the `Display`'s (the end-to-end tests compare the firmware's failures and driver counts
//! with the host's).

use defmt::{Format, Formatter, write};
use hal_adapters::drivers::Health;
use hal_adapters::protocol::config::{ConfigRefusal, MOUNTING_TOL};
use nav_core::alignment::fine::FineRefusal;
use nav_core::alignment::machine::{
    AlignFailure, AlignMethod, LEVER_ARM_SIGMA_ZERO, MAX_LEVER_ARM_M, MAX_RATE_HZ, MAX_WINDOW_S,
    MIN_RATE_HZ, SettingsError, bad_rate_reason, longer_window_s,
};
use nav_core::alignment::sway::MAX_YAW_SWAY_RAD;
use nav_core::alignment::{AlignError, EarthRateMismatch, GravityMismatch, InertialAlignError};
use nav_core::calibration::CalibrationError;
use nav_core::navigator::config::ConfigError;
use nav_core::navigator::{AIDED_COMPILED_IN, Counters, FlaggedCounts, NavError};

/// A run that could not navigate ([`NavError`]).
pub struct Nav<'a>(pub &'a NavError);

impl Format for Nav<'_> {
    fn format(&self, f: Formatter<'_>) {
        match self.0 {
            NavError::Alignment {
                samples,
                failure,
                gaps,
            } => {
                write!(
                    f,
                    "alignment failed after {=u32} samples: {}",
                    samples,
                    Failure(failure)
                );
                let n = gaps.bridged.saturating_add(gaps.lost);
                if n > 0 {
                    write!(
                        f,
                        " ({=u32} gap(s) in the IMU data inside its window, {=u64} us in all, the longest {=u64} us: its samples spanned that much more time than asked, the base may have moved in it)",
                        n, gaps.time_us, gaps.longest_us
                    );
                }
            }
            NavError::EndedDuringAlignment {
                samples,
                n_align,
                counters,
            } => write!(
                f,
                "recording ended during alignment: {=u32} of {=u32} samples used{}",
                samples,
                n_align,
                Unused(counters)
            ),
            NavError::NothingNavigated { n_align, counters } => write!(
                f,
                "no navigation step after the alignment: {=u32} samples, {=u32} used by the alignment{}",
                counters.samples,
                n_align,
                Unused(counters)
            ),
            NavError::GapDuringAlignment { samples, lost_us } => write!(
                f,
                "{=u64} us of IMU data missing after {=u32} samples of the alignment: its method integrates the body's attitude, which a gap breaks (align where the data have no gap, or with the static method on a still base)",
                lost_us, samples
            ),
            // Only a build with the filter has it (its text has no float).
            NavError::Filter(e) => {
                if AIDED_COMPILED_IN {
                    write!(
                        f,
                        "the navigation filter cannot start from the alignment's outcome: {}",
                        defmt::Display2Format(e)
                    )
                }
            }
        }
    }
}

/// What a failed run did not use, with its leading blank (nav-core's `Counters::unused`).
struct Unused<'a>(&'a Counters);

impl Format for Unused<'_> {
    fn format(&self, f: Formatter<'_>) {
        let c = self.0;
        let by = Flagged(&c.flagged_by);
        match (c.flagged, c.rejected) {
            (0, 0) => {}
            (0, r) => write!(f, " ({=u32} rejected)", r),
            (n, 0) => write!(f, " ({=u32} flagged: {})", n, by),
            (n, r) => write!(f, " ({=u32} flagged: {}; {=u32} rejected)", n, by, r),
        }
    }
}

/// The flagged samples by cause, e.g. `non-finite 4000, stale 2` (`none` without any): the
/// text of nav-core's `FlaggedCounts` `Display`.
pub struct Flagged<'a>(pub &'a FlaggedCounts);

impl Format for Flagged<'_> {
    fn format(&self, f: Formatter<'_>) {
        let mut first = true;
        for (name, n) in self.0.by_name().into_iter().filter(|(_, n)| *n > 0) {
            if !first {
                write!(f, ", ");
            }
            write!(f, "{=str} {=u32}", name, n);
            first = false;
        }
        if first {
            write!(f, "none");
        }
    }
}

/// The IMU driver's counters: the text of their `Display` (which `nav replay --device`
/// prints).
pub struct DriverHealth<'a>(pub &'a Health);

impl Format for DriverHealth<'_> {
    fn format(&self, f: Formatter<'_>) {
        let h = self.0;
        write!(
            f,
            "samples {=u32}, checksum errors {=u32}, stale {=u32}, device missed {=u32}, bus errors {=u32}, faults {=u32}, FIFO overflows {=u32}, invalid {=u32}, gyro clips [{=u32}, {=u32}, {=u32}], accel clips [{=u32}, {=u32}, {=u32}]",
            h.samples,
            h.checksum_errors,
            h.stale,
            h.missed,
            h.bus_errors,
            h.device_faults,
            h.fifo_overflows,
            h.invalid,
            h.gyro_clips[0],
            h.gyro_clips[1],
            h.gyro_clips[2],
            h.accel_clips[0],
            h.accel_clips[1],
            h.accel_clips[2]
        )
    }
}

/// Why an alignment failed ([`AlignFailure`]).
pub struct Failure<'a>(pub &'a AlignFailure);

impl Format for Failure<'_> {
    fn format(&self, f: Formatter<'_>) {
        match self.0 {
            AlignFailure::Static(e) => write!(f, "static alignment: {}", Static(e)),
            AlignFailure::Inertial(e) => write!(f, "inertial-frame alignment: {}", Inertial(e)),
            AlignFailure::Fine(e) => write!(f, "fine alignment: {}", Fine(e)),
            AlignFailure::Latitude(m) => write!(f, "fine alignment: {}", EarthRate(m)),
            AlignFailure::BaseMoving(sc) => write!(
                f,
                "base not still: gyro and accelerometer outputs scatter {=f64}x and {=f64}x their noise (sway, heave or vibration; or an IMU noisier than its model)",
                sc.gyro_ratio, sc.accel_ratio
            ),
            AlignFailure::WindowTooShort { seconds, min_s } => write!(
                f,
                "the data cover {=f64} s, less than the method's minimum of {=f64} s (the \
                 samples' own intervals, shortened by timestamp jitter or gaps): ask for a \
                 window of {=f64} s or more",
                seconds,
                min_s,
                longer_window_s(*seconds, *min_s)
            ),
            AlignFailure::NotCompiledIn(method) => write!(f, "{}", NotCompiledIn(*method)),
        }
    }
}

/// The static alignment's refusal ([`AlignError`]).
struct Static<'a>(&'a AlignError);

impl Format for Static<'_> {
    fn format(&self, f: Formatter<'_>) {
        match self.0 {
            AlignError::NoSamples => write!(f, "no samples to align on"),
            AlignError::SpecificForceNotGravity(m) => write!(f, "{}", Gravity(m)),
            AlignError::BaseRotating => write!(
                f,
                "mean angular rate exceeds the Earth rate: the base turning, or gyro biases beyond the Earth rate (a part that cannot find north: start in motion, or from a given attitude)"
            ),
            AlignError::HeadingUnobservable => write!(
                f,
                "horizontal Earth rate not measurable for gyrocompassing (near a pole, or gyros too coarse or biased)"
            ),
            AlignError::LatitudeMismatch(m) => write!(f, "{}", EarthRate(m)),
        }
    }
}

/// The inertial-frame alignment's refusal ([`InertialAlignError`]).
struct Inertial<'a>(&'a InertialAlignError);

impl Format for Inertial<'_> {
    fn format(&self, f: Formatter<'_>) {
        use nav_core::InputError;
        use nav_core::alignment::InertialAlignError as I;
        match self.0 {
            I::TooShort => write!(f, "window not complete or shorter than 10 s"),
            I::InputRefused(e) => write!(
                f,
                "an increment was refused ({=str}); restart",
                match e {
                    InputError::NonFinite => "increment contains NaN or infinity",
                    InputError::BadInterval => "sampling interval is not positive or too long",
                    InputError::OutOfRange => "rate or specific force beyond the plausible range",
                    InputError::OutOfOrder => "time not after the last navigated sample's",
                }
            ),
            I::NearPole => write!(f, "latitude too close to a pole (or not finite)"),
            I::SpecificForceNotGravity(m) => write!(f, "{}", Gravity(m)),
            I::HeadingUnobservable => write!(
                f,
                "Earth-rate heading signal not resolved (noise, disturbance or coarse gyros)"
            ),
            I::NonFinite => write!(f, "alignment solution not finite"),
            I::BaseDisturbed => write!(
                f,
                "heading depends on the taper: base disturbed beyond what the window hides (unknown lever arm?)"
            ),
            I::TranslationLeak => write!(
                f,
                "base moving: its translation (1-sigma --base-translation) leaks so much heading through this window's ramps that the heading 1-sigma passes 15 deg; align 120 s or more, or give a smaller translation"
            ),
            I::LeverArmLeak { heading_sigma_rad } => write!(
                f,
                "heading not resolved: the unknown lever arm's motion on this swaying base leaves a heading 1-sigma of {=f64} deg (more than 15); give the lever arm (--lever-arm X,Y,Z) or align longer",
                heading_sigma_rad.to_degrees()
            ),
        }
    }
}

/// The fine (and sway) filters' refusal ([`FineRefusal`]).
struct Fine<'a>(&'a FineRefusal);

impl Format for Fine<'_> {
    fn format(&self, f: Formatter<'_>) {
        match self.0 {
            FineRefusal::HeadingUnresolved { sigma_rad } => write!(
                f,
                "heading not resolved: 1-sigma {=f64} deg (Earth rate below the gyro noise or bias)",
                sigma_rad.to_degrees()
            ),
            FineRefusal::EarthRateMismatch { ratio } => write!(
                f,
                "gyros disagree with the Earth rate ({=f64} of Omega cos(lat)): bias beyond its prior or base turning",
                ratio
            ),
            FineRefusal::MotionNotModelled { mean_nis } => write!(
                f,
                "base motion not modelled: position innovations {=f64} times their variance",
                mean_nis
            ),
            FineRefusal::YawSwayBeyondModel { amplitude_rad } => write!(
                f,
                "yaw sway of {=f64} deg grew beyond the sway model's {=f64} deg after its measurements started (its heading 1-sigma is not true there)",
                amplitude_rad.to_degrees(),
                MAX_YAW_SWAY_RAD.to_degrees()
            ),
            FineRefusal::NotStarted => write!(f, "fine filter has not run yet"),
            FineRefusal::NonFinite => write!(f, "fine filter's covariance became non-finite"),
        }
    }
}

/// A method left out of this build.
struct NotCompiledIn(AlignMethod);

impl Format for NotCompiledIn {
    fn format(&self, f: Formatter<'_>) {
        let name = self.0.name();
        write!(
            f,
            "the {=str} alignment is not in this build (nav-core feature `align-{=str}`); use static or inertial",
            name, name
        )
    }
}

/// A mean specific force that is not gravity.
/// The gyros' Earth rate against the latitude's ([`EarthRateMismatch`]).
struct EarthRate<'a>(&'a EarthRateMismatch);

impl Format for EarthRate<'_> {
    fn format(&self, f: Formatter<'_>) {
        let [lat, up, level, up0, level0, tol] = self.0.figures_unrounded();
        write!(
            f,
            "the gyros measure an Earth rate of {=f64} deg/h up and {=f64} deg/h level, latitude {=f64} deg's is {=f64} and {=f64}: the latitude wrong (its hemisphere?), or gyro biases beyond {=f64} deg/h",
            up, level, lat, up0, level0, tol
        )
    }
}

struct Gravity<'a>(&'a GravityMismatch);

impl Format for Gravity<'_> {
    fn format(&self, f: Formatter<'_>) {
        let m = self.0;
        write!(
            f,
            "mean specific force {=f64} m/s^2 against gravity {=f64} m/s^2 ({=f64} times it; {=str})",
            m.measured_mps2,
            m.gravity_mps2,
            m.ratio(),
            if m.is_scale() {
                "sample rate, timestamps or units wrong?"
            } else {
                "base accelerating?"
            }
        )
    }
}

/// A refused run configuration ([`ConfigError`]).
pub struct Config<'a>(pub &'a ConfigError);

impl Format for Config<'_> {
    fn format(&self, f: Formatter<'_>) {
        use nav_core::navigator::config::{MAX_HEIGHT_M, MIN_HEIGHT_M};
        match self.0 {
            ConfigError::Latitude(lat) => {
                write!(f, "latitude {=f64} deg is not within [-90, 90]", lat)
            }
            ConfigError::Longitude(lon) => {
                write!(f, "longitude {=f64} deg is not within [-180, 180]", lon)
            }
            ConfigError::Height(h) => write!(
                f,
                "height {=f64} m is not within [{=f64}, {=f64}] m (the Earth model's range)",
                h, MIN_HEIGHT_M, MAX_HEIGHT_M
            ),
            ConfigError::NotFinite(what) => write!(f, "{=str} is not a finite number", what),
            ConfigError::LogEvery => write!(f, "log_every must be at least 1"),
            ConfigError::BiasPrior(k) => write!(
                f,
                "bias prior scale {=f64} must be finite, not negative, and keep the bias 1-sigmas within any IMU's (0.1 rad/s, 10 m/s^2)",
                k
            ),
            ConfigError::Calibration(e) => write!(f, "{}", Calibration(e)),
            ConfigError::Alignment(e) => write!(f, "{}", Settings(e)),
            ConfigError::Aiding(what) => write!(f, "GNSS aiding: {=str}", what),
        }
    }
}

/// Refused alignment settings ([`SettingsError`]).
pub struct Settings<'a>(pub &'a SettingsError);

impl Format for Settings<'_> {
    fn format(&self, f: Formatter<'_>) {
        const HULL: &str =
            "(the IMU sits on the base, within a hull's length of its centre of rotation)";
        match self.0 {
            SettingsError::WindowTooShort {
                method,
                seconds,
                min_s,
            } => write!(
                f,
                "alignment window {=f64} s is shorter than the {=str} method's minimum of {=f64} s",
                seconds,
                method.name(),
                min_s
            ),
            SettingsError::BadRate(r) => write!(
                f,
                "sampling rate {=f64} Hz is not within [{=f64}, {=f64}] Hz ({=str})",
                r,
                MIN_RATE_HZ,
                MAX_RATE_HZ,
                bad_rate_reason(*r)
            ),
            SettingsError::WindowTooLong { seconds } => write!(
                f,
                "alignment window {=f64} s is longer than {=f64} s (a day)",
                seconds, MAX_WINDOW_S
            ),
            SettingsError::NearPole => {
                write!(f, "latitude not finite or too close to a pole to align")
            }
            SettingsError::NotCompiledIn(method) => write!(f, "{}", NotCompiledIn(*method)),
            SettingsError::BadValue(what) => {
                write!(f, "{=str} must be finite and not negative", what)
            }
            SettingsError::OutOfRange(why) => write!(f, "{=str}", why),
            SettingsError::LeverArmTooLong { length_m } => write!(
                f,
                "lever arm {=f64} m is beyond {=f64} m {=str}",
                length_m, MAX_LEVER_ARM_M, HULL
            ),
            SettingsError::LeverArmSigmaTooLarge { sigma_m } => write!(
                f,
                "lever arm 1-sigma {=f64} m is beyond {=f64} m {=str}",
                sigma_m, MAX_LEVER_ARM_M, HULL
            ),
            SettingsError::LeverArmSigmaZero => write!(f, "{=str}", LEVER_ARM_SIGMA_ZERO),
            SettingsError::SwayNeedsLeverArm => write!(
                f,
                "the sway method needs the lever arm (--lever-arm X,Y,Z; 0,0,0 at the centre of rotation): with an unknown one its 1-sigma is not true; use fine"
            ),
            SettingsError::GyrosTooCoarse {
                bias_rad_s,
                earth_rad_s,
            } => write!(
                f,
                "gyros too coarse to find north: bias 1-sigma {=f64} deg/h against a horizontal Earth rate of {=f64} deg/h (heading 1-sigma >= {=f64} deg); give the heading or use better gyros",
                bias_rad_s.to_degrees() * 3600.0,
                earth_rad_s.to_degrees() * 3600.0,
                (bias_rad_s / earth_rad_s).to_degrees()
            ),
        }
    }
}

/// A refused calibration ([`CalibrationError`]).
pub struct Calibration<'a>(pub &'a CalibrationError);

impl Format for Calibration<'_> {
    fn format(&self, f: Formatter<'_>) {
        match self.0 {
            CalibrationError::Syntax { line } => write!(
                f,
                "calibration line {=usize}: expected `key = values`",
                line
            ),
            CalibrationError::UnknownKey { line, .. } => {
                write!(f, "calibration line {=usize}: unknown key", line)
            }
            CalibrationError::BadValues { line } => write!(
                f,
                "calibration line {=usize}: wrong number of values or not a finite number",
                line
            ),
            CalibrationError::Duplicate { line } => {
                write!(f, "calibration line {=usize}: key given twice", line)
            }
            CalibrationError::Implausible { key, limit } => write!(
                f,
                "calibration: {=str} is beyond physical plausibility (magnitude at most {=f64})",
                key, limit
            ),
            _ => write!(
                f,
                "calibration: scale/misalignment matrix is not invertible or implausible"
            ),
        }
    }
}

/// A configuration frame's refusal ([`ConfigRefusal`]).
pub struct Refusal<'a>(pub &'a ConfigRefusal);

impl Format for Refusal<'_> {
    fn format(&self, f: Formatter<'_>) {
        match self.0 {
            ConfigRefusal::Run(e) => write!(f, "{}", Config(e)),
            ConfigRefusal::Malformed(what) => {
                write!(f, "malformed configuration payload: {=str}", what)
            }
            ConfigRefusal::Mounting => write!(
                f,
                "the mounting matrix is not a rotation (orthonormal, determinant +1, within {=f32})",
                MOUNTING_TOL
            ),
            ConfigRefusal::HealthOff => write!(
                f,
                "health frames cannot be switched off (health-every >= 1)"
            ),
            ConfigRefusal::RunInProgress => write!(
                f,
                "a run is in progress with another run configuration: only the output rates apply (restart the board to change it)"
            ),
            ConfigRefusal::NotThisBoard(what) => write!(f, "{=str} is not the board's", what),
        }
    }
}
