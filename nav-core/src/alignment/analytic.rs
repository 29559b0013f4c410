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
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlignError {
    /// Nothing was accumulated.
    NoSamples,
    /// The mean specific force differs from normal gravity by more than 2 %: the base was
    /// accelerating, or the accelerometers are faulty.
    SpecificForceNotGravity,
    /// The mean angular rate exceeds 3x the Earth rate: the base was turning.
    BaseRotating,
    /// The horizontal Earth rate is too small to gyrocompass: within ~1 deg of a pole, or the
    /// levelled gyros measure less than half of `Omega cos(lat)` (a gyro too coarse or too
    /// biased to see the Earth's rotation).
    HeadingUnobservable,
}

impl core::fmt::Display for AlignError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NoSamples => "no samples to align on",
            Self::SpecificForceNotGravity => {
                "mean specific force is not gravity (base accelerating?)"
            }
            Self::BaseRotating => "mean angular rate exceeds the Earth rate (base turning?)",
            Self::HeadingUnobservable => {
                "horizontal Earth rate not measurable for gyrocompassing (near a pole, or gyros too coarse or biased)"
            }
        })
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
        if (f_mean - g).abs() > T::c(0.02) * g {
            return Err(AlignError::SpecificForceNotGravity);
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
        assert_eq!(a.solve(lat, 0.0), Err(AlignError::SpecificForceNotGravity));
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
}
