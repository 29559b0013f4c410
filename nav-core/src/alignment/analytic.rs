//! Static analytic (coarse) alignment: levelling from the mean specific force, heading by
//! gyrocompassing the mean angular rate (Groves §5.6.2, eqs. 5.101 and 5.103; Titterton & Weston
//! §10.2.1).
//!
//! The accumulator sums increments with Kahan compensation, so a minute of 400 Hz `f32` samples
//! averages without losing the small horizontal components that carry the tilt and heading.

use super::kahan::{Kahan, Kahan3};
use crate::{ImuIncrement, Scalar, attitude, earth};
use nalgebra::UnitQuaternion;

/// Accumulates increments over a still period and solves for roll, pitch and heading.
#[derive(Clone, Debug)]
pub struct StaticAlignment<T: Scalar> {
    sum_dtheta: Kahan3<T>,
    sum_dv: Kahan3<T>,
    sum_dt: Kahan<T>,
    samples: u32,
}

/// Result of an alignment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlignmentResult<T: Scalar> {
    /// Roll [rad].
    pub roll: T,
    /// Pitch [rad].
    pub pitch: T,
    /// True heading (yaw) [rad], in (-pi, pi].
    pub yaw: T,
    /// Samples averaged.
    pub samples: u32,
    /// Time averaged [s].
    pub duration: T,
    /// Mean specific force magnitude [m/s^2].
    pub f_mean: T,
    /// Mean angular rate magnitude [rad/s].
    pub omega_mean: T,
}

impl<T: Scalar> AlignmentResult<T> {
    /// The aligned attitude `q_b_n`.
    pub fn q_b_n(&self) -> UnitQuaternion<T> {
        attitude::from_euler(self.roll, self.pitch, self.yaw)
    }
}

/// Why static alignment failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlignError {
    /// Nothing was accumulated.
    NoSamples,
    /// The mean specific force differs from normal gravity by more than
    /// [`GRAVITY_TOLERANCE`]: the base was accelerating, the accelerometers are faulty, or
    /// (a large factor) the sample rate, timestamps or units are wrong.
    SpecificForceNotGravity(GravityMismatch),
    /// The mean angular rate exceeds 3x the Earth rate: the base was turning.
    BaseRotating,
    /// The horizontal Earth rate is too small to gyrocompass: within ~1 deg of a pole, or the
    /// levelled gyros measure less than half of `Omega cos(lat)` (a gyro too coarse or too
    /// biased to see the Earth's rotation).
    HeadingUnobservable,
    /// The levelled gyros' Earth rate is not the one of the given latitude
    /// ([`EARTH_RATE_TOLERANCE`]): the latitude is wrong (its hemisphere, or tens of degrees
    /// off), or the gyro biases are beyond the tolerance.
    LatitudeMismatch(EarthRateMismatch),
}

/// The Earth rate the levelled gyros measured against the given latitude's, for the message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EarthRateMismatch {
    /// The given latitude [rad].
    pub lat_rad: f64,
    /// Measured vertical (up) and horizontal Earth rate [rad/s].
    pub measured_rad_s: [f64; 2],
}

impl EarthRateMismatch {
    /// The message's figures, rounded: the latitude [deg], the measured vertical and
    /// horizontal rates, the latitude's, and the tolerance [deg/h] (`+ 0.0`: no "-0.0" of a
    /// rounded -1e-9).
    pub fn figures(&self) -> [f64; 6] {
        let round = |x: f64, per_unit: f64| libm::round(x * per_unit) / per_unit + 0.0;
        let [lat, up, level, up0, level0, tol] = self.figures_unrounded();
        let tenths = |x| round(x, 10.0);
        [
            round(lat, 100.0),
            tenths(up),
            tenths(level),
            tenths(up0),
            tenths(level0),
            tenths(tol),
        ]
    }

    /// [`Self::figures`] as computed (the firmware's log prints them so).
    pub fn figures_unrounded(&self) -> [f64; 6] {
        let omega = earth::OMEGA_IE * RAD_S_TO_DEG_H;
        let [up, level] = self.measured_rad_s.map(|x| x * RAD_S_TO_DEG_H);
        [
            self.lat_rad.to_degrees(),
            up,
            level,
            omega * libm::sin(self.lat_rad),
            omega * libm::cos(self.lat_rad),
            omega * EARTH_RATE_TOLERANCE,
        ]
    }
}

impl core::fmt::Display for AlignError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoSamples => f.write_str("no samples to align on"),
            Self::SpecificForceNotGravity(m) => write!(f, "{m}"),
            Self::BaseRotating => {
                f.write_str(
                    "mean angular rate exceeds the Earth rate: the base turning, or gyro biases beyond \
                     the Earth rate (a part that cannot find north: start in motion, or from a given \
                     attitude)",
                )
            }
            Self::HeadingUnobservable => f.write_str(
                "horizontal Earth rate not measurable for gyrocompassing (near a pole, or gyros too coarse or biased)",
            ),
            Self::LatitudeMismatch(m) => {
                let [lat, up, level, up0, level0, tol] = m.figures();
                write!(
                    f,
                    "the gyros measure an Earth rate of {up:.1} deg/h up and {level:.1} deg/h level, latitude {lat:.2} deg's is {up0:.1} and {level0:.1}: the latitude wrong (its hemisphere?), or gyro biases beyond {tol:.1} deg/h"
                )
            }
        }
    }
}

/// Largest difference between the levelled gyros' vertical or horizontal rate and the given
/// latitude's Earth rate, `Omega sin(lat)` and `Omega cos(lat)`, as a fraction of `Omega` [-]
/// (7.5 deg/h: half the Earth rate, as the gyrocompass's own test of the horizontal rate). A
/// FOG at 45 deg aligned at -45 deg: 21 deg/h off (its heading then drifting at that rate);
/// at 0 deg, 11 deg/h (and the height 10 m off in 30 s on the wrong gravity).
pub const EARTH_RATE_TOLERANCE: f64 = 0.5;

const RAD_S_TO_DEG_H: f64 = 180.0 / core::f64::consts::PI * 3600.0;

/// Largest relative difference between the mean specific force and normal gravity at rest [-]
/// (2 %), for the static and the inertial-frame methods.
pub const GRAVITY_TOLERANCE: f64 = 0.02;

/// Beyond this factor (or below its inverse) between the mean specific force and gravity, the
/// mismatch is not motion but the data's scale: increments over the wrong intervals (a sample
/// rate or timestamps off by a factor) or in the wrong units (g instead of m/s^2). A vehicle
/// at rest does not sustain half a g for the window.
pub const SCALE_MISMATCH_FACTOR: f64 = 1.5;

/// A mean specific force that is not gravity: what was measured and what the site's normal
/// gravity is, so the message can tell a wrong scale (a factor) from motion (a few %).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GravityMismatch {
    /// Magnitude of the mean specific force over the window [m/s^2].
    pub measured_mps2: f64,
    /// Normal gravity at the site's latitude and height [m/s^2].
    pub gravity_mps2: f64,
}

impl GravityMismatch {
    /// `measured / gravity` [-].
    pub fn ratio(&self) -> f64 {
        self.measured_mps2 / self.gravity_mps2
    }

    /// Whether the mismatch is a factor ([`SCALE_MISMATCH_FACTOR`]) rather than a few %.
    pub fn is_scale(&self) -> bool {
        let r = self.ratio();
        !(r <= SCALE_MISMATCH_FACTOR && r * SCALE_MISMATCH_FACTOR >= 1.0)
    }
}

impl core::fmt::Display for GravityMismatch {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        use crate::number::Rounded;
        write!(
            f,
            "mean specific force {} m/s^2 is not gravity {} m/s^2",
            Rounded(self.measured_mps2),
            Rounded(self.gravity_mps2)
        )?;
        if self.is_scale() {
            write!(
                f,
                " ({} times it): sample rate, timestamps or units wrong?",
                Rounded(self.ratio())
            )
        } else {
            write!(
                f,
                " (beyond {} %): base accelerating?",
                crate::number::Number(GRAVITY_TOLERANCE * 100.0)
            )
        }
    }
}

impl core::error::Error for AlignError {}

impl<T: Scalar> Default for StaticAlignment<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Scalar> StaticAlignment<T> {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self {
            sum_dtheta: Kahan3::new(),
            sum_dv: Kahan3::new(),
            sum_dt: Kahan::new(),
            samples: 0,
        }
    }

    /// Adds one (already validated) increment.
    pub fn add(&mut self, inc: &ImuIncrement<T>) {
        self.sum_dtheta.add(&inc.delta_theta_ib_b);
        self.sum_dv.add(&inc.delta_v_ib_b);
        self.sum_dt.add(inc.dt);
        self.samples = self.samples.saturating_add(1);
    }

    /// Samples accumulated so far.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Time accumulated so far [s].
    pub fn duration(&self) -> T {
        self.sum_dt.sum
    }

    /// Solves for the attitude at latitude `lat` [rad] and height `h` [m].
    pub fn solve(&self, lat: T, h: T) -> Result<AlignmentResult<T>, AlignError> {
        let duration = self.sum_dt.sum;
        if self.samples == 0 || duration <= T::zero() {
            return Err(AlignError::NoSamples);
        }
        let f_ib_b = self.sum_dv.sum() / duration;
        let omega_ib_b = self.sum_dtheta.sum() / duration;
        let g = earth::normal_gravity(lat, h);
        let (f_mean, omega_mean) = (f_ib_b.norm(), omega_ib_b.norm());
        if !((f_mean - g).abs() <= T::c(GRAVITY_TOLERANCE) * g) {
            return Err(AlignError::SpecificForceNotGravity(GravityMismatch {
                measured_mps2: f_mean.to_f64(),
                gravity_mps2: g.to_f64(),
            }));
        }
        if omega_mean > T::c(3.0 * earth::OMEGA_IE) {
            return Err(AlignError::BaseRotating);
        }
        if lat.pcos() < T::c(0.02) {
            return Err(AlignError::HeadingUnobservable);
        }
        // Levelling, Groves eq. 5.101 (f = -g at rest).
        let roll = (-f_ib_b.y).patan2(-f_ib_b.z);
        let pitch = f_ib_b
            .x
            .patan2((f_ib_b.y * f_ib_b.y + f_ib_b.z * f_ib_b.z).sqrt());
        // Gyrocompassing, Groves eq. 5.103: the levelled gyro vector points north.
        let (sr, cr) = (roll.psin(), roll.pcos());
        let (sp, cp) = (pitch.psin(), pitch.pcos());
        let w = omega_ib_b;
        let (east, north) = (
            -w.y * cr + w.z * sr,
            w.x * cp + w.y * sr * sp + w.z * cr * sp,
        );
        // The levelled horizontal rate must be the Earth's, Omega cos(lat): half of it or less
        // means the gyros cannot see it and the heading would be noise or a bias.
        if (east * east + north * north).sqrt() < T::c(0.5 * earth::OMEGA_IE) * lat.pcos() {
            return Err(AlignError::HeadingUnobservable);
        }
        // The levelled vertical rate (up) and the horizontal one must both be the latitude's
        // [Groves, eq. 2.123] (the horizontal test above only says the gyros see one).
        let up = w.x * sp - w.y * sr * cp - w.z * cr * cp;
        let level = (east * east + north * north).sqrt();
        let omega = T::c(earth::OMEGA_IE);
        let expected = [omega * lat.psin(), omega * lat.pcos()];
        let tolerance = T::c(EARTH_RATE_TOLERANCE) * omega;
        if !((up - expected[0]).abs() <= tolerance && level - expected[1] <= tolerance) {
            return Err(AlignError::LatitudeMismatch(EarthRateMismatch {
                lat_rad: lat.to_f64(),
                measured_rad_s: [up.to_f64(), level.to_f64()],
            }));
        }
        let yaw = east.patan2(north);
        Ok(AlignmentResult {
            roll,
            pitch,
            yaw,
            samples: self.samples,
            duration,
            f_mean,
            omega_mean,
        })
    }
}

/// Number of samples a static alignment of `seconds` [s] averages at `rate_hz` [Hz]:
/// `max(1, ceil(seconds * rate_hz))` (a 1e-9 slack absorbs rounding of exact products), so the
/// firmware and the host harness stop aligning on the same sample.
pub fn samples_for(seconds: f64, rate_hz: f64) -> u32 {
    let n = libm::ceil(seconds * rate_hz - 1e-9);
    if n.is_finite() && n >= 1.0 {
        n.min(f64::from(u32::MAX)) as u32
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::attitude::from_euler;
    use nalgebra::Vector3;

    fn feed<T: Scalar>(roll: f64, pitch: f64, yaw: f64, lat: f64, n: u32) -> StaticAlignment<T> {
        let q_n_b = from_euler(roll, pitch, yaw).inverse();
        let dt = 0.0025;
        let dtheta = q_n_b * earth::omega_ie_n(lat) * dt;
        let dv = q_n_b * Vector3::new(0.0, 0.0, -earth::normal_gravity(lat, 0.0)) * dt;
        let inc = ImuIncrement::new(dtheta.map(T::c).into(), dv.map(T::c).into(), T::c(dt));
        let mut a = StaticAlignment::new();
        for _ in 0..n {
            a.add(&inc);
        }
        a
    }

    #[test]
    fn recovers_attitude_from_exact_inputs() {
        let lat = 45f64.to_radians();
        for &(r, p, y) in &[(0.02, -0.01, 1.0), (-0.5, 0.3, -2.5), (0.0, 0.0, 3.0)] {
            let res = feed::<f64>(r, p, y, lat, 24_000).solve(lat, 0.0).unwrap();
            assert!((res.roll - r).abs() < 1e-9 && (res.pitch - p).abs() < 1e-9);
            assert!((res.yaw - y).abs() < 1e-6, "{} vs {y}", res.yaw);
            // f32 over a minute of samples: Kahan summation keeps the heading to ~1e-3 rad
            // (f32 resolution of the ~7e-8 rad per-sample horizontal Earth-rate increments).
            let res32 = feed::<f32>(r, p, y, lat, 24_000)
                .solve(lat as f32, 0.0)
                .unwrap();
            assert!((f64::from(res32.roll) - r).abs() < 1e-5);
            assert!(
                (f64::from(res32.yaw) - y).abs() < 1e-3,
                "{} vs {y}",
                res32.yaw
            );
        }
    }

    #[test]
    fn alignment_window_in_samples() {
        assert_eq!(samples_for(30.0, 400.0), 12_000);
        assert_eq!(samples_for(0.1, 400.0), 40);
        assert_eq!(samples_for(0.0001, 400.0), 1);
        assert_eq!(samples_for(f64::NAN, 400.0), 1);
        assert_eq!(samples_for(2.0 / 3.0, 100.0), 67);
    }

    #[test]
    fn reports_failures() {
        let lat = 45f64.to_radians();
        assert_eq!(
            StaticAlignment::<f64>::new().solve(lat, 0.0),
            Err(AlignError::NoSamples)
        );
        let mut a = feed::<f64>(0.0, 0.0, 0.0, lat, 100);
        a.add(&ImuIncrement::new([0.0; 3], [1.0, 0.0, 0.0], 0.0025));
        assert!(matches!(
            a.solve(lat, 0.0),
            Err(AlignError::SpecificForceNotGravity(_))
        ));
        // The message gives the numbers, and a factor points at the data's scale.
        let g = earth::normal_gravity(lat, 0.0);
        let mut fast = StaticAlignment::<f64>::new();
        for _ in 0..100 {
            // 400 Hz increments stamped 10 times too far apart: a tenth of gravity.
            fast.add(&ImuIncrement::new([0.0; 3], [0.0, 0.0, -g * 0.0025], 0.025));
        }
        let e = fast.solve(lat, 0.0).unwrap_err();
        let AlignError::SpecificForceNotGravity(m) = e else {
            panic!("{e:?}");
        };
        assert!((m.measured_mps2 - g / 10.0).abs() < 1e-12 && m.gravity_mps2 == g);
        assert_eq!(
            std::format!("{e}"),
            "mean specific force 0.9806 m/s^2 is not gravity 9.806 m/s^2 (0.1000 times it): sample rate, timestamps or units wrong?"
        );
        let mut pushed = feed::<f64>(0.0, 0.0, 0.0, lat, 100);
        for _ in 0..10 {
            pushed.add(&ImuIncrement::new(
                [0.0; 3],
                [0.1, 0.0, -g * 0.0025],
                0.0025,
            ));
        }
        let text = std::format!("{}", pushed.solve(lat, 0.0).unwrap_err());
        assert!(text.ends_with("(beyond 2 %): base accelerating?"), "{text}");
        let mut a = feed::<f64>(0.0, 0.0, 0.0, lat, 100);
        a.add(&ImuIncrement::new(
            [0.0, 0.0, 0.01],
            [0.0, 0.0, -0.0245],
            0.0025,
        ));
        assert_eq!(a.solve(lat, 0.0), Err(AlignError::BaseRotating));
        let polar = 89.5f64.to_radians();
        assert_eq!(
            feed::<f64>(0.0, 0.0, 0.0, polar, 100).solve(polar, 0.0),
            Err(AlignError::HeadingUnobservable)
        );
        // A gyro that does not see the Earth rate (consumer MEMS resolution): no heading.
        let mut blind = StaticAlignment::<f64>::new();
        let g = earth::normal_gravity(lat, 0.0);
        for _ in 0..100 {
            blind.add(&ImuIncrement::new(
                [0.0; 3],
                [0.0, 0.0, -g * 0.0025],
                0.0025,
            ));
        }
        assert_eq!(blind.solve(lat, 0.0), Err(AlignError::HeadingUnobservable));
    }

    /// Gyros at 45 deg aligned at a latitude in the other hemisphere, at the equator or near
    /// the pole: refused with the rates; within the tolerance (30 deg), aligned.
    #[test]
    fn a_latitude_the_gyros_contradict_is_refused() {
        let lat = 45f64.to_radians();
        let a = feed::<f64>(0.02, -0.01, 1.0, lat, 24_000);
        for wrong in [-45.0_f64, 0.0, 80.0] {
            let e = a.solve(wrong.to_radians(), 0.0).unwrap_err();
            let AlignError::LatitudeMismatch(m) = e else {
                panic!("{wrong}: {e:?}");
            };
            let [lat_deg, up, ..] = m.figures();
            assert!(
                (up - 10.63).abs() < 0.06 && (lat_deg - wrong).abs() < 1e-9,
                "{m:?}"
            );
            let text = std::format!("{e}");
            assert!(
                text.contains("the latitude wrong (its hemisphere?)"),
                "{text}"
            );
        }
        for right in [45.0_f64, 30.0, 60.0] {
            assert!(a.solve(right.to_radians(), 0.0).is_ok(), "{right}");
        }
    }
}
