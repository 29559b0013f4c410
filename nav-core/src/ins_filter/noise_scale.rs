//! How much larger an aid's noise is than its declared 1-sigma, learnt from the innovations
//! [Mehra, 1972; Mohamed & Schwarz, 1999: innovation-based adaptive estimation].
//!
//! A receiver whose declared 1-sigma is two or three times too small (a common mistake: the
//! receiver's own figure, or a value copied from another one) fails the per-fix gate and the
//! windowed test of [`super::integrity`] on fixes that are only noise: the filter refused most
//! of them, coasted, diverged and re-aligned again and again, and ended hundreds of metres to
//! 100 km from white 2 m fixes declared at 0.7-1 m (a tactical part; a FOG 133 m).
//!
//! The innovations of a consistent filter are white: three consecutive ones, `z_2`, `z_1` and `z`
//! (innovation covariances `S_i = H P_i H^T + R_i`, declared noise `R_0i`), are uncorrelated, so
//! their second difference `d = z - 2 z_1 + z_2` has `E|d|^2 = o + lambda r`, with
//! `o = tr(H P H^T) + 4 tr(H P_1 H^T) + tr(H P_2 H^T)` and `r = tr R_0 + 4 tr R_01 + tr R_02`,
//! when the true noise is `lambda` times the declared. Each triple's sample of `lambda` is that
//! solved for `lambda`. Second differences, not the innovations: an offset that the fixes share and
//! that holds or moves steadily cancels in them, while the noise grows six times. Taken on the
//! innovations, a multipath ramp of 5 m over 30 s raised the scale, and the FOG filter it then
//! pulled was 6.3 sigma off (from 3.8); taken on first differences, the fixes a FOG filter with its
//! heading 90 deg off refused as they ran away from it at 11 m/s did, and its reported 1-sigma lost
//! their offset (13 sigma). A sample's spread grows with the share of `o + lambda r` that is the
//! filter's own, so each joins an exponential mean of [`MEMORY_FIXES`] samples with the weight
//! `(lambda r / (o + lambda r))^2` at the scale in use (its memory the samples taken plus
//! [`START_SAMPLES`] until then): a filter that has just coasted through an outage learns next to
//! nothing from its first fixes. Each sample is clamped to the gate over the dimension, times the
//! scale, either way (a sample at the per-fix gate's tail): a lone outlier, in the three samples it
//! enters, moves the mean by about half, within the dead band. Fixes ten times noisier than
//! declared pass the gate only where they fall near the prediction: the clamped samples of the
//! others raise the scale until the gate passes them. The scale applied to the declared noise is
//! the mean once it exceeds 1 by [`DEAD_BAND`], else 1 (a fix is never taken as better than
//! declared), at most [`SCALE_MAX`]: the mean of a declared noise that is right has a 1-sigma of
//! about 0.14 (consecutive samples share two fixes), so the dead band holds the scale at 1 (seven
//! of its sigma; over 40 seeded runs of an hour, fixes at 1 Hz, it never left 1), and the scale of
//! fixes three times noisier than declared reaches 70 % of their variance in about 30 fixes.

use crate::Scalar;
use nalgebra::{SMatrix, SVector};

/// The samples the mean remembers [-].
pub const MEMORY_FIXES: f64 = 30.0;
/// The samples counted before the first: the mean's memory is this plus the samples taken,
/// up to [`MEMORY_FIXES`] [-].
pub const START_SAMPLES: f64 = 5.0;
/// What the mean must exceed 1 by before it is the scale [-].
pub const DEAD_BAND: f64 = 1.0;
/// The largest scale of the declared variance [-] (ten times the 1-sigma).
pub const SCALE_MAX: f64 = 100.0;

/// The learnt scale of one aid's declared noise variance, an aid of `M` components (module
/// docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseScale<T: Scalar, const M: usize> {
    mean: T,
    /// Samples taken (the mean's memory until [`MEMORY_FIXES`]).
    samples: T,
    peak: T,
    /// The last two fixes learnt from, the last first: innovation, `tr(H P H^T)` and
    /// `tr(R_0)`.
    last: [Option<(SVector<T, M>, T, T)>; 2],
}

impl<T: Scalar, const M: usize> Default for NoiseScale<T, M> {
    fn default() -> Self {
        Self {
            mean: T::one(),
            samples: T::zero(),
            peak: T::one(),
            last: [None; 2],
        }
    }
}

impl<T: Scalar, const M: usize> NoiseScale<T, M> {
    /// The scale of the declared noise variance now [-]: the mean once beyond `1 +`
    /// [`DEAD_BAND`], else 1, at most [`SCALE_MAX`].
    pub fn scale(&self) -> T {
        if self.mean > T::c(1.0 + DEAD_BAND) {
            self.mean.min(T::c(SCALE_MAX))
        } else {
            T::one()
        }
    }

    /// The largest scale applied so far [-].
    pub fn peak(&self) -> T {
        self.peak
    }

    /// Learns from a fix: innovation `z`, its covariance `s` and the noise variances `r` it
    /// was taken with (the declared ones times [`Self::scale`]), under the per-fix gate
    /// `gate` (chi-square with `M` degrees of freedom).
    pub fn learn(&mut self, z: &SVector<T, M>, s: &SMatrix<T, M, M>, r: &SVector<T, M>, gate: T) {
        let (s_trace, r_trace) = (s.trace(), r.sum());
        if !(r_trace > T::zero() && s_trace >= r_trace) {
            self.last = [None; 2];
            return;
        }
        let scale = self.scale();
        let (own, declared) = (s_trace - r_trace, r_trace / scale);
        if let [
            Some((z_1, own_1, declared_1)),
            Some((z_2, own_2, declared_2)),
        ] = self.last
        {
            // The second difference z - 2 z_1 + z_2, weights 1, 4, 1 on the variances.
            let four = T::c(4.0);
            let cap = gate / T::c(M as f64) * scale;
            let own_sum = own + four * own_1 + own_2;
            let declared_sum = declared + four * declared_1 + declared_2;
            let d2 = z - z_1 * T::c(2.0) + z_2;
            let sample = ((d2.norm_squared() - own_sum) / declared_sum)
                .max(-cap)
                .min(cap);
            let share = declared_sum * scale / (own_sum + declared_sum * scale);
            self.samples += T::one();
            let memory = (self.samples + T::c(START_SAMPLES)).min(T::c(MEMORY_FIXES));
            self.mean += (sample - self.mean) * share * share / memory;
            self.peak = self.peak.max(self.scale());
        }
        self.last = [Some((*z, own, declared)), self.last[0]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    /// A seeded stream of standard normal draws (Box–Muller on a linear congruential
    /// generator), enough for the statistics below.
    fn normals(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        move || (-2.0 * uniform().ln()).sqrt() * (2.0 * core::f64::consts::PI * uniform()).cos()
    }

    /// Fixes of noise `true_sigma` declared at `declared_sigma`, the filter's own predicted
    /// variance `p` per axis: the scale after `n` fixes under the gate (16.3, chi-square(3) at
    /// 99.9 %).
    fn learnt(
        true_sigma: f64,
        declared_sigma: f64,
        p: f64,
        n: usize,
        seed: u64,
    ) -> NoiseScale<f64, 3> {
        let mut draw = normals(seed);
        let mut scale = NoiseScale::<f64, 3>::default();
        for _ in 0..n {
            let r = Vector3::repeat(declared_sigma * declared_sigma * scale.scale());
            let s = Matrix3::from_diagonal(&r.add_scalar(p));
            let spread = (true_sigma * true_sigma + p).sqrt();
            let z = Vector3::from_fn(|_, _| draw() * spread);
            scale.learn(&z, &s, &r, 16.27);
        }
        scale
    }

    #[test]
    fn a_declared_noise_that_is_right_is_left_as_it_is() {
        for seed in 1..=20 {
            for p in [0.0, 0.05, 1.0] {
                // Never left 1 over the hour, not only at its end.
                assert_eq!(
                    learnt(0.5, 0.5, p, 3600, seed).peak(),
                    1.0,
                    "seed {seed}, p {p}"
                );
            }
        }
    }

    #[test]
    fn a_noise_declared_too_small_is_learnt() {
        for seed in 1..=20 {
            // Twice (variance 4) and three times (9) the declared 1-sigma, a settled filter.
            for (declared, want) in [(1.0, 4.0), (0.7, 8.16)] {
                let got = learnt(2.0, declared, 0.1, 300, seed).scale();
                // The spread of the mean (about 14 %) and the gate's truncation.
                assert!(
                    got > 0.6 * want && got < 1.4 * want,
                    "seed {seed}: {got} for {want}"
                );
            }
        }
    }

    #[test]
    fn a_noise_declared_ten_times_too_small_is_learnt_from_the_refused_fixes() {
        for seed in 1..=20 {
            let got = learnt(2.0, 0.2, 0.01, 600, seed).scale();
            assert!(got > 50.0 && got < 120.0, "seed {seed}: {got} for 100");
        }
    }

    #[test]
    fn fixes_after_an_outage_teach_next_to_nothing() {
        // The filter's own variance 100 times the noise's: each sample is mostly its spread.
        for seed in 1..=20 {
            assert_eq!(learnt(0.5, 0.5, 25.0, 30, seed).peak(), 1.0, "seed {seed}");
        }
    }
}
