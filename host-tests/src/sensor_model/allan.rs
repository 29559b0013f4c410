//! Overlapping Allan variance of a rate series and a fit of the sensor noise model to it
//! (IEEE Std 952-1997 Annex C; the Gauss–Markov term as in El-Sheimy, Hou and Niu, IEEE TIM 2008).
//!
//! # Estimator
//! For `n` rate samples `y_k` at period `tau0`, the angle (or velocity) is the cumulative sum
//! `theta_k = tau0 sum_{i<k} y_i`, `k = 0..=n`, and for a cluster of `m` samples (`tau = m tau0`)
//!
//! ```text
//! AVAR(tau) = 1 / (2 tau^2 (n + 1 - 2m)) sum_{k=0}^{n-2m} (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2
//! ```
//! (IEEE Std 952-1997 Annex C, with fully overlapping clusters): each `tau` costs
//! O(n) thanks to the cumulative sum.
//!
//! # Model
//! ```text
//! AVAR(tau) = N^2 / tau                                   white noise (ARW / VRW), N [U/sqrt(Hz)]
//!           + sigma^2 f(tau / T)                          first-order Gauss–Markov, T known
//!           + K^2 tau / 3                                 rate random walk, K [U/sqrt(s)]
//! f(x) = (2 / x) [1 - (3 - 4 e^-x + e^-2x) / (2 x)]
//! ```
//! `f` is the Allan variance of a unit-variance first-order Gauss–Markov process (from its
//! autocorrelation `sigma^2 e^{-|t|/T}`): `2 sigma^2 tau / (3 T)` for `tau << T` (a rate random
//! walk of density `sqrt(2/T) sigma`) and `2 sigma^2 T / tau` for `tau >> T` (white noise).
//!
//! **Bias instability** of the model is the peak of the Gauss–Markov term's Allan deviation,
//! `B = max_tau sigma sqrt(f(tau/T)) = 0.6174 sigma`, reached at `tau = 1.8926 T`
//! ([`GM_PEAK_ADEV_PER_SIGMA`], [`GM_PEAK_TAU_PER_CORRELATION_TIME`]). The sensor model uses the
//! same definition ([`super::GaussMarkov::from_bias_instability`]), so a fitted `B` is compared
//! with the configured one like with like.
//!
//! # Fit
//! The model is linear in the unknown variances `(N^2, sigma^2, K^2)` once `T` is given:
//! weighted linear least squares on `AVAR(tau_i)`, weight `(c_i - 1) / AVAR_i^2` where `c_i =
//! floor(n / m_i)` is the number of independent clusters (the relative variance of an Allan
//! variance estimate falls roughly as `1 / c_i`), with `AVAR_i` taken from the model of the
//! previous pass (iteratively reweighted; the first pass uses the measured values). The
//! variances are constrained to be `>= 0` (exact non-negative least squares over the seven
//! subsets of the three terms). Quantisation noise (`3 Q^2 / tau^2`) is not in the model: keep
//! the LSB well below the white noise per sample, or leave out the shortest `tau`.

use super::units;

/// `tau / T` at which the Allan deviation of a first-order Gauss–Markov process peaks.
pub const GM_PEAK_TAU_PER_CORRELATION_TIME: f64 = 1.892_6;
/// Peak Allan deviation of a first-order Gauss–Markov process per unit `sigma`:
/// `sqrt(f(1.8926)) = 0.617364`.
pub const GM_PEAK_ADEV_PER_SIGMA: f64 = 0.617_364;

/// Allan variance at one averaging time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AllanPoint {
    /// Cluster size `m` [samples].
    pub cluster_size: usize,
    /// Averaging time `tau = m tau0` [s].
    pub tau_s: f64,
    /// Overlapping Allan variance [U^2].
    pub avar: f64,
    /// Number of independent (non-overlapping) clusters `floor(n / m)`.
    pub independent_clusters: usize,
}

impl AllanPoint {
    /// Allan deviation [U].
    pub fn adev(&self) -> f64 {
        self.avar.sqrt()
    }
}

/// Log-spaced cluster sizes for `n_samples` samples: `per_decade` per decade from 1, rounded and
/// without repeats, up to `n_samples / min_clusters` (at least 2 independent clusters).
pub fn log_spaced_cluster_sizes(
    n_samples: usize,
    per_decade: usize,
    min_clusters: usize,
) -> Vec<usize> {
    let max_m = n_samples / min_clusters.max(2);
    let per_decade = per_decade.max(1);
    let mut out: Vec<usize> = Vec::new();
    for k in 0.. {
        let m = 10f64.powf(k as f64 / per_decade as f64).round() as usize;
        if m > max_m {
            break;
        }
        if out.last() != Some(&m) {
            out.push(m);
        }
    }
    out
}

/// Overlapping Allan variance of the rate series `rate` [U] sampled every `sample_period_s` [s],
/// at the given cluster sizes (sizes 0 or above `rate.len() / 2` are skipped). Non-finite samples
/// make the results non-finite.
pub fn overlapping_avar(
    rate: &[f64],
    sample_period_s: f64,
    cluster_sizes: &[usize],
) -> Vec<AllanPoint> {
    let n = rate.len();
    // Cumulative sum of the rate about its mean (the second differences below do not see a
    // constant, and a smaller sum keeps more digits): theta_k / tau0.
    let mean = rate.iter().sum::<f64>() / n.max(1) as f64;
    let mut s = Vec::with_capacity(n + 1);
    s.push(0.0);
    let mut acc = 0.0;
    for &y in rate {
        acc += y - mean;
        s.push(acc);
    }
    cluster_sizes
        .iter()
        .filter(|&&m| m >= 1 && 2 * m <= n)
        .map(|&m| {
            let terms = n + 1 - 2 * m;
            let sum_sq: f64 = (0..terms)
                .map(|k| {
                    let d = s[k + 2 * m] - 2.0 * s[k + m] + s[k];
                    d * d
                })
                .sum();
            // (theta diff)^2 / (2 tau^2) = (s diff)^2 / (2 m^2).
            let mf = m as f64;
            AllanPoint {
                cluster_size: m,
                tau_s: mf * sample_period_s,
                avar: sum_sq / (2.0 * mf * mf * terms as f64),
                independent_clusters: n / m,
            }
        })
        .collect()
}

/// Allan variance of a first-order Gauss–Markov process of standard deviation `sigma` [U] and
/// correlation time `correlation_time_s` [s] at averaging time `tau_s` [s] (module docs).
/// A random constant (`T` infinite) has none.
pub fn gm_avar(tau_s: f64, sigma: f64, correlation_time_s: f64) -> f64 {
    sigma * sigma * gm_shape(tau_s / correlation_time_s)
}

/// `f(x) = (2/x) [1 - (3 - 4 e^-x + e^-2x) / (2x)]`, by its series for small `x`
/// (`2x/3 - x^2/2 + 7x^3/30 - x^4/12`, truncation error < 1e-9 relative) where the closed form
/// cancels.
fn gm_shape(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x < 1e-2 {
        return x * (2.0 / 3.0 + x * (-0.5 + x * (7.0 / 30.0 - x / 12.0)));
    }
    // 3 - 4 e^-x + e^-2x = -4 expm1(-x) + expm1(-2x).
    let g = -4.0 * (-x).exp_m1() + (-2.0 * x).exp_m1();
    (2.0 / x) * (1.0 - g / (2.0 * x))
}

/// The fitted noise model (module docs), in the unit `U` of the series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AllanFit {
    /// White-noise density `N` [U/sqrt(Hz)] (angle / velocity random walk).
    pub white_density: f64,
    /// Gauss–Markov standard deviation `sigma` [U] (0 if the term was not fitted).
    pub gm_sigma: f64,
    /// The correlation time the fit assumed [s] (`f64::INFINITY` if none).
    pub gm_correlation_time_s: f64,
    /// Rate random walk density `K` [U/sqrt(s)].
    pub rate_random_walk: f64,
    /// Number of Allan points used.
    pub points: usize,
}

impl AllanFit {
    /// Bias instability `B = 0.6174 sigma` [U] (module docs).
    pub fn bias_instability(&self) -> f64 {
        GM_PEAK_ADEV_PER_SIGMA * self.gm_sigma
    }

    /// Angle random walk [deg/sqrt(h)] of a gyro series ([rad/s]).
    pub fn arw_deg_sqrt_h(&self) -> f64 {
        units::to_deg_sqrt_h(self.white_density)
    }

    /// Bias instability [deg/h] of a gyro series ([rad/s]).
    pub fn bias_instability_deg_h(&self) -> f64 {
        units::to_deg_h(self.bias_instability())
    }

    /// Rate random walk [deg/h/sqrt(h)] of a gyro series ([rad/s]).
    pub fn rrw_deg_h_sqrt_h(&self) -> f64 {
        units::to_deg_h_sqrt_h(self.rate_random_walk)
    }

    /// Velocity random walk [m/s/sqrt(h)] of an accelerometer series ([m/s^2]).
    pub fn vrw_m_s_sqrt_h(&self) -> f64 {
        units::to_m_s_sqrt_h(self.white_density)
    }

    /// The model's Allan variance at `tau_s` [s] [U^2].
    pub fn avar(&self, tau_s: f64) -> f64 {
        self.white_density.powi(2) / tau_s
            + gm_avar(tau_s, self.gm_sigma, self.gm_correlation_time_s)
            + self.rate_random_walk.powi(2) * tau_s / 3.0
    }
}

/// Why a fit failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitError {
    /// Fewer usable points (finite, positive, at least 2 independent clusters) than unknowns.
    TooFewPoints,
    /// No subset of the terms gave a solvable, non-negative fit.
    NoSolution,
}

impl core::fmt::Display for FitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooFewPoints => write!(f, "too few usable Allan points for the fit"),
            Self::NoSolution => write!(f, "no non-negative least-squares solution"),
        }
    }
}

impl core::error::Error for FitError {}

/// Fits `N^2 / tau + sigma^2 f(tau / T) + K^2 tau / 3` to `points` (module docs).
/// `gm_correlation_time_s = None` fits white noise and rate random walk only.
pub fn fit(
    points: &[AllanPoint],
    gm_correlation_time_s: Option<f64>,
) -> Result<AllanFit, FitError> {
    let tc = gm_correlation_time_s.filter(|t| *t > 0.0 && !t.is_nan());
    let n_terms = if tc.is_some() { 3 } else { 2 };
    let usable: Vec<&AllanPoint> = points
        .iter()
        .filter(|p| {
            p.avar.is_finite() && p.avar > 0.0 && p.tau_s > 0.0 && p.independent_clusters >= 2
        })
        .collect();
    if usable.len() < n_terms {
        return Err(FitError::TooFewPoints);
    }
    // Basis functions per point: white, Gauss–Markov (per unit variance), rate random walk.
    let basis =
        |tau: f64| -> [f64; 3] { [1.0 / tau, tc.map_or(0.0, |t| gm_shape(tau / t)), tau / 3.0] };
    let g: Vec<[f64; 3]> = usable.iter().map(|p| basis(p.tau_s)).collect();
    let y: Vec<f64> = usable.iter().map(|p| p.avar).collect();
    let dof: Vec<f64> = usable
        .iter()
        .map(|p| (p.independent_clusters - 1) as f64)
        .collect();

    let mut expected = y.clone();
    let mut coef = [0.0; 3];
    for _pass in 0..6 {
        let w: Vec<f64> = dof
            .iter()
            .zip(&expected)
            .map(|(d, e)| d / (e * e))
            .collect();
        coef = nnls3(&g, &y, &w, tc.is_some()).ok_or(FitError::NoSolution)?;
        let model: Vec<f64> = g
            .iter()
            .map(|gi| gi[0] * coef[0] + gi[1] * coef[1] + gi[2] * coef[2])
            .collect();
        // Keep the previous weight where the model vanishes (cannot happen with a white term).
        for (e, m) in expected.iter_mut().zip(model) {
            if m > 0.0 {
                *e = m;
            }
        }
    }
    Ok(AllanFit {
        white_density: coef[0].sqrt(),
        gm_sigma: coef[1].sqrt(),
        gm_correlation_time_s: tc.unwrap_or(f64::INFINITY),
        rate_random_walk: coef[2].sqrt(),
        points: usable.len(),
    })
}

/// Non-negative weighted least squares with three columns: the unconstrained solutions on every
/// subset of columns, keeping the feasible one with the smallest weighted residual (exact for
/// NNLS: its solution is the unconstrained optimum on its own support).
fn nnls3(g: &[[f64; 3]], y: &[f64], w: &[f64], use_gm: bool) -> Option<[f64; 3]> {
    // Column scales, so the normal equations are well conditioned.
    let mut scale = [0.0f64; 3];
    for (gi, wi) in g.iter().zip(w) {
        for j in 0..3 {
            scale[j] += wi * gi[j] * gi[j];
        }
    }
    let scale = scale.map(|s| if s > 0.0 { s.sqrt() } else { 0.0 });
    let mut best: Option<([f64; 3], f64)> = None;
    for mask in 1u8..8 {
        let cols: Vec<usize> = (0..3)
            .filter(|&j| mask & (1 << j) != 0 && scale[j] > 0.0 && (j != 1 || use_gm))
            .collect();
        if cols.len() != mask.count_ones() as usize {
            continue;
        }
        let k = cols.len();
        let mut a = [[0.0f64; 4]; 3];
        for (gi, (yi, wi)) in g.iter().zip(y.iter().zip(w)) {
            for r in 0..k {
                let xr = gi[cols[r]] / scale[cols[r]];
                for c in 0..k {
                    a[r][c] += wi * xr * gi[cols[c]] / scale[cols[c]];
                }
                a[r][3] += wi * xr * yi;
            }
        }
        let Some(sol) = solve(&mut a, k) else {
            continue;
        };
        let mut coef = [0.0; 3];
        for (r, &j) in cols.iter().enumerate() {
            coef[j] = sol[r] / scale[j];
        }
        if coef.iter().any(|c| *c < 0.0 || !c.is_finite()) {
            continue;
        }
        let ssr: f64 = g
            .iter()
            .zip(y.iter().zip(w))
            .map(|(gi, (yi, wi))| {
                let r = yi - (gi[0] * coef[0] + gi[1] * coef[1] + gi[2] * coef[2]);
                wi * r * r
            })
            .sum();
        if best.is_none_or(|(_, b)| ssr < b) {
            best = Some((coef, ssr));
        }
    }
    best.map(|(c, _)| c)
}

/// Gaussian elimination with partial pivoting on the `k x k` system `a[..k][..k] x = a[..k][3]`.
fn solve(a: &mut [[f64; 4]; 3], k: usize) -> Option<[f64; 3]> {
    for col in 0..k {
        let piv = (col..k).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() < 1e-12 {
            return None;
        }
        a.swap(col, piv);
        let pivot = a[col];
        for row in a.iter_mut().take(k).skip(col + 1) {
            let f = row[col] / pivot[col];
            for (v, p) in row[col..].iter_mut().zip(&pivot[col..]) {
                *v -= f * p;
            }
        }
    }
    let mut x = [0.0; 3];
    for r in (0..k).rev() {
        let mut s = a[r][3];
        for c in r + 1..k {
            s -= a[r][c] * x[c];
        }
        x[r] = s / a[r][r];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn gm_peak_constants() {
        // Scan f on a fine grid: the maximum is where the constants say.
        let (mut best_x, mut best_f) = (0.0, 0.0);
        for i in 1..200_000 {
            let x = i as f64 * 1e-4;
            let f = gm_shape(x);
            if f > best_f {
                (best_x, best_f) = (x, f);
            }
        }
        assert!(
            (best_x - GM_PEAK_TAU_PER_CORRELATION_TIME).abs() < 2e-4,
            "{best_x}"
        );
        assert!(
            (best_f.sqrt() - GM_PEAK_ADEV_PER_SIGMA).abs() < 1e-6,
            "{}",
            best_f.sqrt()
        );
    }

    #[test]
    fn gm_shape_limits_and_series_join() {
        // Series and closed form agree where they meet.
        let x = 1e-2f64;
        let closed = {
            let g = -4.0 * (-x).exp_m1() + (-2.0 * x).exp_m1();
            (2.0 / x) * (1.0 - g / (2.0 * x))
        };
        assert!((gm_shape(x * (1.0 - 1e-12)) / closed - 1.0).abs() < 1e-9);
        // Short tau: random walk 2 tau / (3 T); long tau: white 2 T / tau.
        assert!((gm_shape(1e-6) / (2e-6 / 3.0) - 1.0).abs() < 1e-5);
        assert!((gm_shape(1e4) / 2e-4 - 1.0).abs() < 1e-3);
        assert_eq!(gm_avar(1.0, 1.0, f64::INFINITY), 0.0);
    }

    #[test]
    fn cumulative_sum_matches_direct_cluster_averages() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let y: Vec<f64> = (0..500)
            .map(|k| {
                let n: f64 = StandardNormal.sample(&mut rng);
                n + 1e-3 * k as f64
            })
            .collect();
        let tau0 = 0.01;
        for p in overlapping_avar(&y, tau0, &[1, 3, 17, 250]) {
            let m = p.cluster_size;
            // Direct: averages of m samples starting at every k, differences m apart.
            let avg = |k: usize| y[k..k + m].iter().sum::<f64>() / m as f64;
            let terms = y.len() + 1 - 2 * m;
            let direct = (0..terms)
                .map(|k| (avg(k + m) - avg(k)).powi(2))
                .sum::<f64>()
                / (2.0 * terms as f64);
            assert!((p.avar / direct - 1.0).abs() < 1e-9, "m = {m}");
        }
        // Cluster sizes beyond n / 2 are skipped.
        assert!(overlapping_avar(&y, tau0, &[0, 251]).is_empty());
    }

    #[test]
    fn white_noise_avar_is_n2_over_tau() {
        // y_k with standard deviation s at period tau0 has density N = s sqrt(tau0).
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (n, tau0, s) = (400_000, 0.0025f64, 0.5);
        let y: Vec<f64> = (0..n)
            .map(|_| {
                let n: f64 = StandardNormal.sample(&mut rng);
                s * n
            })
            .collect();
        let density = s * tau0.sqrt();
        for p in overlapping_avar(&y, tau0, &[1, 10, 100]) {
            // Relative standard deviation of an overlapping AVAR of white noise is about
            // sqrt(1 / c) (c independent clusters); allow 5 of them.
            let bound = 5.0 / (p.independent_clusters as f64).sqrt();
            let ratio = p.avar / (density * density / p.tau_s);
            assert!(
                (ratio - 1.0).abs() < bound,
                "m = {}: {ratio}",
                p.cluster_size
            );
        }
    }

    #[test]
    fn fit_recovers_an_exact_model_curve() {
        let truth = AllanFit {
            white_density: 3e-5,
            gm_sigma: 2e-5,
            gm_correlation_time_s: 20.0,
            rate_random_walk: 4e-8,
            points: 0,
        };
        let points: Vec<AllanPoint> = log_spaced_cluster_sizes(2_880_000, 10, 4)
            .into_iter()
            .map(|m| {
                let tau = m as f64 / 400.0;
                AllanPoint {
                    cluster_size: m,
                    tau_s: tau,
                    avar: truth.avar(tau),
                    independent_clusters: 2_880_000 / m,
                }
            })
            .collect();
        let f = fit(&points, Some(20.0)).unwrap();
        assert!((f.white_density / truth.white_density - 1.0).abs() < 1e-9);
        assert!((f.gm_sigma / truth.gm_sigma - 1.0).abs() < 1e-9);
        assert!((f.rate_random_walk / truth.rate_random_walk - 1.0).abs() < 1e-6);
        // Without the GM term the fit still succeeds (white + RRW only).
        let g = fit(&points, None).unwrap();
        assert_eq!(g.gm_sigma, 0.0);
        assert_eq!(fit(&points[..1], Some(20.0)), Err(FitError::TooFewPoints));
    }

    #[test]
    fn cluster_sizes_are_log_spaced_and_bounded() {
        let m = log_spaced_cluster_sizes(1000, 5, 4);
        assert_eq!(m.first(), Some(&1));
        assert!(*m.last().unwrap() <= 250);
        assert!(m.windows(2).all(|w| w[0] < w[1]));
        assert!(m.contains(&10) && m.contains(&100));
    }
}
