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
//!
//! That mean learns nothing where the declared noise is a small share of the second difference's
//! spread: fixes of 2 m declared at 2-7 cm were refused by half, the filter coasted to a
//! variance of metres squared before it took one, and each sample's weight was `1e-5` or less
//! (NAV rows 10-22 sigma off). So each sample also joins a bank of log-likelihood ratios
//! [Willsky, 1976]: for the declared variance times `2^k` (`k` = 1 to [`HYPOTHESES`]), the
//! second difference's Gaussian log-likelihood (the spread `o + 2^k r` shared by the `M`
//! components) less that of the declared noise, in an exponential sum of [`MEMORY_FIXES`]
//! samples. One sum takes each sample clamped to [`SAMPLE_EVIDENCE_MAX`], so a lone outlier,
//! in its two or three samples, adds less than [`EVIDENCE_THRESHOLD`]; the other takes it as it
//! is, to choose the hypothesis. The most likely hypothesis, refined between the grid's points,
//! is the bank's estimate once its clamped evidence exceeds the threshold, and the scale where
//! it exceeds twice the mean's ([`NoiseScale::scale`]). A declared noise that is right makes
//! every ratio's expectation negative (`-M (1/rho - 1 + ln rho) / 2`, `rho` the spread's ratio,
//! whatever the axes' shares): for twice the declared variance, with the filter settled, the
//! sum's mean is about -9 against the threshold 12, at its 1-sigma of about 3.4 (consecutive
//! samples share fixes); where the filter's own variance dwarfs the declared, the ratios are
//! near 0 and so is the sum. Over 60 seeded runs in each of `nav bench consistency`'s six cells
//! the bank never took the scale.

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
/// The bank's hypotheses: the declared variance times `2^k`, `k` = 1 to this [-] (the 1-sigma
/// up to 4096 times the declared: a receiver that declares millimetres for metres).
pub const HYPOTHESES: usize = 24;
/// The most one sample adds to a hypothesis's clamped evidence [-] (natural log of a
/// likelihood ratio).
pub const SAMPLE_EVIDENCE_MAX: f64 = 2.0;
/// The clamped evidence a hypothesis needs before it is the bank's estimate [-] (natural log).
pub const EVIDENCE_THRESHOLD: f64 = 12.0;

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
    /// The bank's sums of log-likelihood ratios, hypothesis `2^(k+1)` at `k`: as taken, and
    /// with each sample clamped (module docs).
    fit: [T; HYPOTHESES],
    evidence: [T; HYPOTHESES],
    /// The bank's estimate of the scale [-] (1 where no hypothesis holds).
    bank: T,
}

impl<T: Scalar, const M: usize> Default for NoiseScale<T, M> {
    fn default() -> Self {
        Self {
            mean: T::one(),
            samples: T::zero(),
            peak: T::one(),
            last: [None; 2],
            fit: [T::zero(); HYPOTHESES],
            evidence: [T::zero(); HYPOTHESES],
            bank: T::one(),
        }
    }
}

impl<T: Scalar, const M: usize> NoiseScale<T, M> {
    /// The scale of the declared noise variance now [-]: the mean once beyond `1 +`
    /// [`DEAD_BAND`], else 1, at most [`SCALE_MAX`]; the bank's estimate instead where that
    /// is more than twice as large. Between, both estimate the same noise, the mean with the
    /// longer memory, and taking the larger of the two would bias the scale up by their spread.
    pub fn scale(&self) -> T {
        let mean = if self.mean > T::c(1.0 + DEAD_BAND) {
            self.mean.min(T::c(SCALE_MAX))
        } else {
            T::one()
        };
        if self.bank > T::c(2.0) * mean {
            self.bank
        } else {
            mean
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
            self.weigh(d2.norm_squared(), own_sum, declared_sum);
            self.peak = self.peak.max(self.scale());
        }
        self.last = [Some((*z, own, declared)), self.last[0]];
    }

    /// Adds a second difference of squared length `d2` (spread `own + lambda declared`) to the
    /// bank [Willsky, 1976], and sets its estimate (module docs).
    fn weigh(&mut self, d2: T, own: T, declared: T) {
        let (half_m, keep) = (T::c(M as f64 / 2.0), T::one() - T::c(1.0 / MEMORY_FIXES));
        // The Gaussian log-likelihood of d2 with the spread v shared by M components,
        // -M (d2 / v + ln v) / 2 up to a constant, less that with the declared noise.
        let v_0 = own + declared;
        let mut lambda = T::one();
        for k in 0..HYPOTHESES {
            lambda *= T::c(2.0);
            let v = own + lambda * declared;
            let ratio = half_m * (d2 * (T::one() / v_0 - T::one() / v) - (v / v_0).pln());
            self.fit[k] = self.fit[k] * keep + ratio;
            self.evidence[k] = self.evidence[k] * keep + ratio.min(T::c(SAMPLE_EVIDENCE_MAX));
        }
        self.bank = T::one();
        let Some(best) = (0..HYPOTHESES)
            .filter(|&k| self.fit[k] > T::zero())
            .max_by(|&i, &j| {
                self.fit[i]
                    .partial_cmp(&self.fit[j])
                    .unwrap_or(core::cmp::Ordering::Equal)
            })
        else {
            return;
        };
        if self.evidence[best] > T::c(EVIDENCE_THRESHOLD) {
            // The most likely scale between the grid's points: the vertex of the parabola
            // through the best and its neighbours in log2 of the scale (the declared noise's
            // ratio, 0, left of the first; none right of the last).
            let left = if best == 0 {
                T::zero()
            } else {
                self.fit[best - 1]
            };
            let curvature = |right: T| left - T::c(2.0) * self.fit[best] + right;
            let offset = match self.fit.get(best + 1) {
                Some(&right) if curvature(right) < T::zero() => {
                    let half = T::c(0.5);
                    (half * (left - right) / curvature(right))
                        .max(-half)
                        .min(half)
                }
                _ => T::zero(),
            };
            self.bank = (T::c((best + 1) as f64) + offset).pexp2();
        }
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
        learnt_with(true_sigma, declared_sigma, p, n, seed, |_| Vector3::zeros())
    }

    /// [`learnt`], fix `i` offset by `offset(i)` [m].
    fn learnt_with(
        true_sigma: f64,
        declared_sigma: f64,
        p: f64,
        n: usize,
        seed: u64,
        offset: impl Fn(usize) -> Vector3<f64>,
    ) -> NoiseScale<f64, 3> {
        let mut draw = normals(seed);
        let mut scale = NoiseScale::<f64, 3>::default();
        for i in 0..n {
            let r = Vector3::repeat(declared_sigma * declared_sigma * scale.scale());
            let s = Matrix3::from_diagonal(&r.add_scalar(p));
            let spread = (true_sigma * true_sigma + p).sqrt();
            let z = Vector3::from_fn(|_, _| draw() * spread) + offset(i);
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
            // The bank's estimate over its memory of 30 samples spreads by about 20 %.
            assert!(got > 50.0 && got < 150.0, "seed {seed}: {got} for 100");
        }
    }

    #[test]
    fn fixes_after_an_outage_teach_next_to_nothing() {
        // The filter's own variance 100 times the noise's: each sample is mostly its spread.
        for seed in 1..=20 {
            assert_eq!(learnt(0.5, 0.5, 25.0, 30, seed).peak(), 1.0, "seed {seed}");
        }
    }

    #[test]
    fn a_noise_declared_a_hundred_times_too_small_is_learnt_by_the_bank() {
        // 2 m fixes declared at 2 cm: the filter's own variance (0.01-1 m^2 per axis) is
        // 25-2500 times the declared, so the mean's weights are 1e-3 to 1e-7.
        for seed in 1..=20 {
            for p in [0.01, 1.0] {
                let got = learnt(2.0, 0.02, p, 300, seed);
                assert!(
                    got.scale() > 5e3 && got.scale() < 2e4,
                    "seed {seed}, p {p}: {} for 1e4",
                    got.scale()
                );
            }
        }
    }

    #[test]
    fn lone_outliers_do_not_raise_the_scale() {
        // A 50 m spike every 40 fixes, and a 50 m jump that stays, in fixes as good as
        // declared: a settled filter and one whose own variance dwarfs the fixes'.
        let spike = |i: usize| Vector3::new(50.0, -30.0, 20.0) * f64::from(u8::from(i % 40 == 20));
        let jump = |i: usize| Vector3::new(0.0, 50.0, 0.0) * f64::from(u8::from(i >= 300));
        for seed in 1..=20 {
            for p in [0.05, 25.0] {
                let spiked = learnt_with(0.5, 0.5, p, 600, seed, spike).peak();
                let jumped = learnt_with(0.5, 0.5, p, 600, seed, jump).peak();
                assert_eq!((spiked, jumped), (1.0, 1.0), "seed {seed}, p {p}");
            }
        }
    }
}
