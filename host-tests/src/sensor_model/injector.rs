//! The error injector: turns exact increments into what the modelled sensor outputs.

use super::model::ImuErrorModel;
use super::quantizer::IntegratingQuantizer;
use super::triad::{InvalidModel, TriadErrors};
use hal_adapters::SampleFlags;
use nav_core::{ImuIncrement, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The random states of one triad [U = rad/s or m/s^2].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriadState {
    /// Turn-on bias drawn at construction [U].
    pub turn_on_bias: Vector3<f64>,
    /// Gauss–Markov bias [U].
    pub gm_bias: Vector3<f64>,
    /// Rate-random-walk bias [U].
    pub rw_bias: Vector3<f64>,
    /// Quantiser remainders [U s].
    pub quantizers: [IntegratingQuantizer; 3],
}

impl TriadState {
    /// Total random bias now (turn-on + Gauss–Markov + random walk) [U]; the model's fixed bias
    /// comes on top.
    pub fn random_bias(&self) -> Vector3<f64> {
        self.turn_on_bias + self.gm_bias + self.rw_bias
    }
}

/// What happened to the samples so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InjectorCounters {
    /// Samples given to [`ErrorInjector::apply`].
    pub samples: u64,
    /// Samples with at least one gyro axis clamped at full scale.
    pub gyro_saturated: u64,
    /// Samples with at least one accelerometer axis clamped at full scale.
    pub accel_saturated: u64,
    /// Samples with a non-finite input or output (passed through as NaN).
    pub non_finite: u64,
    /// Samples with a negative interval (passed through as NaN).
    pub bad_interval: u64,
}

/// An [`ImuErrorModel`] with its random states and a seeded `ChaCha8Rng`.
///
/// **Determinism.** All draws come from stream 0 of `ChaCha8Rng::seed_from_u64(seed)` (standard
/// normals by `rand_distr::StandardNormal`) in a fixed order: at construction the gyro turn-on
/// biases (x, y, z), the accelerometer ones, then the initial Gauss–Markov states (drawn from
/// their stationary distribution, gyro then accelerometer); per valid sample 18 draws, gyro then
/// accelerometer, each as white noise (x, y, z), Gauss–Markov driving noise, random-walk noise.
/// Every draw is made even when its process is switched off, so switching one process on or off
/// does not change the others' noise. Same seed and same inputs give bit-identical outputs.
///
/// **Discretisation** (exact for each sample's own `dt`): biases are held over the interval at
/// their value at its start (zero-order hold), then propagated:
/// `b_gm <- exp(-dt/T) b_gm + sigma sqrt(1 - exp(-2dt/T)) n`, `b_rw <- b_rw + K sqrt(dt) n`;
/// white noise adds `N sqrt(dt) n` to the increment.
///
/// **Bad input.** No finite input panics. If `dt` or any input component is not finite, or `dt`
/// is negative, the output increments are NaN, `dt` is passed through, the flags say
/// [`SampleFlags::NON_FINITE`] or [`SampleFlags::BAD_INTERVAL`], and no state changes and no
/// draw is made. A finite input so large that the output overflows is passed through as
/// infinite and flagged [`SampleFlags::NON_FINITE`].
#[derive(Clone, Debug)]
pub struct ErrorInjector {
    model: ImuErrorModel,
    seed: u64,
    rng: ChaCha8Rng,
    gyro: TriadState,
    accel: TriadState,
    counters: InjectorCounters,
}

impl ErrorInjector {
    /// Validates `model` and draws the turn-on biases and initial Gauss–Markov states from `seed`.
    pub fn new(model: ImuErrorModel, seed: u64) -> Result<Self, InvalidModel> {
        model.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut gyro = TriadState::default();
        let mut accel = TriadState::default();
        gyro.turn_on_bias = normal3(&mut rng).component_mul(&model.gyro.turn_on_bias_sigma);
        accel.turn_on_bias = normal3(&mut rng).component_mul(&model.accel.turn_on_bias_sigma);
        gyro.gm_bias = normal3(&mut rng) * model.gyro.bias_instability.sigma;
        accel.gm_bias = normal3(&mut rng) * model.accel.bias_instability.sigma;
        Ok(Self {
            model,
            seed,
            rng,
            gyro,
            accel,
            counters: InjectorCounters::default(),
        })
    }

    /// The sensed increment for the exact increment `exact` (see the type's docs).
    pub fn apply(&mut self, exact: &ImuIncrement<f64>) -> ImuIncrement<f64> {
        self.apply_flagged(exact).0
    }

    /// [`Self::apply`] with the sample's data-quality flags (`GYRO_SATURATED`,
    /// `ACCEL_SATURATED`, `NON_FINITE`, `BAD_INTERVAL`).
    pub fn apply_flagged(&mut self, exact: &ImuIncrement<f64>) -> (ImuIncrement<f64>, SampleFlags) {
        self.counters.samples += 1;
        let dt = exact.dt;
        let finite = dt.is_finite()
            && exact.delta_theta_ib_b.iter().all(|x| x.is_finite())
            && exact.delta_v_ib_b.iter().all(|x| x.is_finite());
        if !finite || dt < 0.0 {
            let flag = if finite {
                self.counters.bad_interval += 1;
                SampleFlags::BAD_INTERVAL
            } else {
                self.counters.non_finite += 1;
                SampleFlags::NON_FINITE
            };
            let nan = Vector3::repeat(f64::NAN);
            return (
                ImuIncrement {
                    delta_theta_ib_b: nan,
                    delta_v_ib_b: nan,
                    dt,
                },
                flag,
            );
        }

        let mut flags = SampleFlags::empty();
        // Gyros also sense the specific force through G (Groves §4.4.6): G dv = int G f dt.
        let g_sens = self.model.g_sensitivity_rad_s_per_m_s2 * exact.delta_v_ib_b;
        let (dtheta, sat_g) = sense(
            &self.model.gyro,
            &mut self.gyro,
            &mut self.rng,
            &exact.delta_theta_ib_b,
            &g_sens,
            dt,
        );
        let (dv, sat_a) = sense(
            &self.model.accel,
            &mut self.accel,
            &mut self.rng,
            &exact.delta_v_ib_b,
            &Vector3::zeros(),
            dt,
        );
        if sat_g {
            self.counters.gyro_saturated += 1;
            flags |= SampleFlags::GYRO_SATURATED;
        }
        if sat_a {
            self.counters.accel_saturated += 1;
            flags |= SampleFlags::ACCEL_SATURATED;
        }
        if !(dtheta.iter().all(|x| x.is_finite()) && dv.iter().all(|x| x.is_finite())) {
            self.counters.non_finite += 1;
            flags |= SampleFlags::NON_FINITE;
        }
        (
            ImuIncrement {
                delta_theta_ib_b: dtheta,
                delta_v_ib_b: dv,
                dt,
            },
            flags,
        )
    }

    /// The model.
    pub fn model(&self) -> &ImuErrorModel {
        &self.model
    }

    /// The seed the injector was made with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Gyro states (biases [rad/s], quantiser remainders [rad]).
    pub fn gyro_state(&self) -> &TriadState {
        &self.gyro
    }

    /// Accelerometer states (biases [m/s^2], quantiser remainders [m/s]).
    pub fn accel_state(&self) -> &TriadState {
        &self.accel
    }

    /// Counters of the samples so far.
    pub fn counters(&self) -> InjectorCounters {
        self.counters
    }
}

/// Three independent standard normal draws.
fn normal3(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    Vector3::new(
        StandardNormal.sample(rng),
        StandardNormal.sample(rng),
        StandardNormal.sample(rng),
    )
}

/// One triad's sensed increment and whether an axis saturated; advances its states.
fn sense(
    m: &TriadErrors,
    s: &mut TriadState,
    rng: &mut ChaCha8Rng,
    exact: &Vector3<f64>,
    extra: &Vector3<f64>,
    dt: f64,
) -> (Vector3<f64>, bool) {
    let sqrt_dt = dt.sqrt();
    let white = normal3(rng) * (m.white_noise.density() * sqrt_dt);
    let gm_drive = normal3(rng);
    let rw_drive = normal3(rng);

    // Bias held over the interval (zero-order hold); model of Groves §4.4.6.
    let bias = m.bias + s.random_bias();
    let mut out = m.model_matrix() * exact + extra + bias * dt + white;

    // Propagate the bias processes to the end of the interval.
    let (phi, q) = m.bias_instability.discrete(dt);
    s.gm_bias = s.gm_bias * phi + gm_drive * q;
    s.rw_bias += rw_drive * (m.rate_random_walk * sqrt_dt);

    // Saturation of the rate, then the output register's quantisation.
    let limit = m.full_scale * dt;
    let mut saturated = false;
    for (i, x) in out.iter_mut().enumerate() {
        if x.abs() > limit {
            *x = x.clamp(-limit, limit);
            saturated = true;
        }
        *x = s.quantizers[i].quantize(*x, m.lsb);
    }
    (out, saturated)
}

#[cfg(test)]
mod tests {
    use super::super::triad::{GaussMarkov, WhiteNoise};
    use super::*;
    use nav_core::nalgebra::Matrix3;

    fn inc(w: [f64; 3], a: [f64; 3], dt: f64) -> ImuIncrement<f64> {
        ImuIncrement::new(w, a, dt)
    }

    fn noisy() -> ImuErrorModel {
        let mut m = ImuErrorModel::IDEAL;
        for t in [&mut m.gyro, &mut m.accel] {
            t.turn_on_bias_sigma = Vector3::repeat(1e-3);
            t.white_noise = WhiteNoise::Density(1e-3);
            t.bias_instability = GaussMarkov {
                sigma: 1e-4,
                correlation_time_s: 10.0,
            };
            t.rate_random_walk = 1e-5;
            t.lsb = 1e-7;
        }
        m
    }

    fn bits(x: &ImuIncrement<f64>) -> Vec<u64> {
        x.delta_theta_ib_b
            .iter()
            .chain(x.delta_v_ib_b.iter())
            .map(|v| v.to_bits())
            .collect()
    }

    fn run(seed: u64) -> Vec<u64> {
        let mut inj = ErrorInjector::new(noisy(), seed).unwrap();
        (0..1000)
            .flat_map(|k| {
                let dt = 0.0025 + 1e-6 * (k % 7) as f64;
                bits(&inj.apply(&inc([1e-4, -2e-4, 3e-4], [0.0, 0.0, -0.0245], dt)))
            })
            .collect()
    }

    #[test]
    fn same_seed_same_bits_different_seed_different() {
        assert_eq!(run(42), run(42));
        let (a, b) = (run(42), run(43));
        let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        assert!(differing > a.len() * 9 / 10, "{differing} of {}", a.len());
    }

    #[test]
    fn deterministic_errors_are_exact() {
        // Dyadic numbers: every product and sum below is exact in binary floating point.
        let mut m = ImuErrorModel::IDEAL;
        m.gyro.bias = Vector3::new(0.5, -0.25, 1.0);
        m.gyro.scale = Vector3::new(0.125, -0.25, 0.5);
        m.gyro.misalignment = Matrix3::new(0.0, 0.25, -0.5, 0.125, 0.0, 0.25, -0.25, 0.5, 0.0);
        m.g_sensitivity_rad_s_per_m_s2 =
            Matrix3::new(0.5, 0.25, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 1.0);
        m.accel.bias = Vector3::new(-1.0, 2.0, 0.5);
        m.accel.scale = Vector3::new(0.375, 0.25, -0.125);
        m.accel.misalignment = Matrix3::new(0.0, 0.25, 0.0, 0.0, 0.0, -0.25, 0.125, 0.0, 0.0);
        let mut inj = ErrorInjector::new(m, 1).unwrap();
        let (w, a, dt) = ([2.0, 4.0, -8.0], [1.0, -2.0, 4.0], 0.5);
        let out = inj.apply(&inc(w, a, dt));
        // Gyro x: 1.125*2 + 0.25*4 - 0.5*(-8) + (0.5*1 + 0.25*(-2)) (g-sens) + 0.5*0.5 (bias dt)
        //         = 7.5
        // Gyro y: 0.125*2 + 0.75*4 + 0.25*(-8) + 0.25*(-2) + (-0.25)*0.5 = 0.625
        // Gyro z: -0.25*2 + 0.5*4 + 1.5*(-8) + 1.0*4 + 1.0*0.5 = -6.0
        assert_eq!(out.delta_theta_ib_b, Vector3::new(7.5, 0.625, -6.0));
        // Accel x: 1.375*1 + 0.25*(-2) + (-1)*0.5 = 0.375
        // Accel y: 1.25*(-2) - 0.25*4 + 2*0.5 = -2.5
        // Accel z: 0.125*1 + 0.875*4 + 0.5*0.5 = 3.875
        assert_eq!(out.delta_v_ib_b, Vector3::new(0.375, -2.5, 3.875));
        assert_eq!(out.dt, dt);
        // nav-core's compensation of the same deterministic errors recovers the exact input
        // (same misalignment convention).
        let comp =
            nav_core::calibration::TriadCompensation::<f64>::new(&m.accel.calibration()).unwrap();
        let back = comp.apply(&out.delta_v_ib_b, dt);
        assert!((back - Vector3::from(a)).amax() < 1e-14, "{back}");
    }

    #[test]
    fn saturation_clamps_and_counts() {
        let mut m = ImuErrorModel::IDEAL;
        m.gyro.full_scale = 2.0; // [rad/s]
        m.accel.full_scale = 10.0; // [m/s^2]
        let mut inj = ErrorInjector::new(m, 0).unwrap();
        let dt = 0.01;
        // 3 rad/s on x, -5 rad/s on z: clamped to +-0.02 rad; accel within range.
        let (out, flags) = inj.apply_flagged(&inc([0.03, 0.01, -0.05], [0.05, 0.0, -0.098], dt));
        assert_eq!(out.delta_theta_ib_b, Vector3::new(0.02, 0.01, -0.02));
        assert_eq!(out.delta_v_ib_b, Vector3::new(0.05, 0.0, -0.098));
        assert_eq!(flags, SampleFlags::GYRO_SATURATED);
        let (out, flags) = inj.apply_flagged(&inc([0.0; 3], [0.0, 0.2, 0.0], dt));
        assert_eq!(out.delta_v_ib_b, Vector3::new(0.0, 0.1, 0.0));
        assert_eq!(flags, SampleFlags::ACCEL_SATURATED);
        inj.apply(&inc([0.0; 3], [0.0; 3], dt));
        let c = inj.counters();
        assert_eq!((c.samples, c.gyro_saturated, c.accel_saturated), (3, 1, 1));
    }

    #[test]
    fn quantised_output_sums_track_the_exact_sums() {
        let mut m = noisy();
        m.gyro.lsb = 1e-5;
        m.accel.lsb = 1e-3;
        let mut inj = ErrorInjector::new(m, 9).unwrap();
        // Compare with the same model unquantised (same draws: the stream does not depend on lsb).
        let mut m0 = m;
        m0.gyro.lsb = 0.0;
        m0.accel.lsb = 0.0;
        let mut raw = ErrorInjector::new(m0, 9).unwrap();
        let (mut sq, mut sr) = (Vector3::zeros(), Vector3::zeros());
        for k in 0..20_000 {
            let x = inc(
                [1e-4 * (k as f64).sin(), 3.3e-6, -7e-7],
                [0.01, -0.02, -0.0245],
                0.0025,
            );
            let (q, r) = (inj.apply(&x), raw.apply(&x));
            sq += q.delta_theta_ib_b;
            sr += r.delta_theta_ib_b;
            assert!((sq - sr).amax() <= m.gyro.lsb * (1.0 + 1e-9));
            for v in q.delta_v_ib_b.iter() {
                assert!(((v / m.accel.lsb).round() - v / m.accel.lsb).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn bad_input_is_flagged_not_panicking() {
        let mut inj = ErrorInjector::new(noisy(), 5).unwrap();
        let before = inj.gyro_state().gm_bias;
        for dt in [f64::NAN, f64::INFINITY] {
            let (out, flags) = inj.apply_flagged(&inc([0.0; 3], [0.0; 3], dt));
            assert!(out.delta_theta_ib_b.iter().all(|x| x.is_nan()));
            assert_eq!(flags, SampleFlags::NON_FINITE);
        }
        let (out, flags) = inj.apply_flagged(&inc([f64::NAN, 0.0, 0.0], [0.0; 3], 0.01));
        assert!(out.delta_v_ib_b.iter().all(|x| x.is_nan()));
        assert_eq!(flags, SampleFlags::NON_FINITE);
        let (_, flags) = inj.apply_flagged(&inc([0.0; 3], [0.0; 3], -0.01));
        assert_eq!(flags, SampleFlags::BAD_INTERVAL);
        assert_eq!(
            inj.gyro_state().gm_bias,
            before,
            "no state change on bad input"
        );
        // Zero and huge finite inputs do not panic; overflow comes out flagged.
        let (out, _) = inj.apply_flagged(&inc([0.0; 3], [0.0; 3], 0.0));
        assert!(out.delta_theta_ib_b.iter().all(|x| x.is_finite()));
        let (_, flags) = inj.apply_flagged(&inc([f64::MAX; 3], [f64::MAX; 3], f64::MAX));
        assert!(flags.contains(SampleFlags::NON_FINITE));
        let (out, _) = inj.apply_flagged(&inc([1e-4; 3], [0.0; 3], 0.0025));
        assert!(
            out.delta_theta_ib_b.iter().all(|x| x.is_finite()),
            "recovered"
        );
        let c = inj.counters();
        assert_eq!((c.non_finite, c.bad_interval), (4, 1));
    }

    /// Sample variance check: (n-1) s^2 / sigma^2 is chi-square with n-1 degrees of freedom,
    /// mean n-1 and standard deviation sqrt(2(n-1)); accept within 5 standard deviations.
    fn assert_variance(samples: &[f64], sigma: f64) {
        let n = samples.len() as f64;
        let mean = samples.iter().sum::<f64>() / n;
        let s2 = samples.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let bound = 5.0 * (2.0 / (n - 1.0)).sqrt();
        assert!(
            (s2 / (sigma * sigma) - 1.0).abs() < bound,
            "s2/sigma2 = {}",
            s2 / sigma / sigma
        );
    }

    #[test]
    fn white_noise_matches_its_density_and_its_rms_at_rate() {
        // [Vavilova et al., §4] gives the gyro noise as RMS at 400 Hz: sampled at 400 Hz the rate's
        // std is the RMS.
        let rms = 0.003f64.to_radians();
        let mut m = ImuErrorModel::IDEAL;
        m.gyro.white_noise = WhiteNoise::RmsAtRate {
            rms,
            rate_hz: 400.0,
        };
        m.accel.white_noise = WhiteNoise::Density(1e-3);
        let mut inj = ErrorInjector::new(m, 77).unwrap();
        let dt = 0.01; // another rate: the accel increment's std is N sqrt(dt)
        let (mut w, mut a) = (Vec::new(), Vec::new());
        let mut inj400 = ErrorInjector::new(m, 78).unwrap();
        for _ in 0..100_000 {
            let x = inj400.apply(&inc([0.0; 3], [0.0; 3], 0.0025));
            w.push(x.delta_theta_ib_b.x / 0.0025);
            let y = inj.apply(&inc([0.0; 3], [0.0; 3], dt));
            a.push(y.delta_v_ib_b.z);
        }
        assert_variance(&w, rms);
        assert_variance(&a, 1e-3 * dt.sqrt());
    }

    #[test]
    fn gauss_markov_variance_and_lag_one_correlation() {
        let (sigma, tc, dt) = (2e-3, 0.1, 0.01);
        let mut m = ImuErrorModel::IDEAL;
        m.gyro.bias_instability = GaussMarkov {
            sigma,
            correlation_time_s: tc,
        };
        let mut inj = ErrorInjector::new(m, 123).unwrap();
        let n = 200_000;
        let b: Vec<f64> = (0..n)
            .map(|_| inj.apply(&inc([0.0; 3], [0.0; 3], dt)).delta_theta_ib_b.y / dt)
            .collect();
        let phi = (-dt / tc).exp();
        // AR(1) sample variance: relative std sqrt(2/n (1 + phi^2)/(1 - phi^2)); 5 of them.
        let nf = n as f64;
        let mean = b.iter().sum::<f64>() / nf;
        let var = b.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / nf;
        let rel = (2.0 / nf * (1.0 + phi * phi) / (1.0 - phi * phi)).sqrt();
        assert!(
            (var / (sigma * sigma) - 1.0).abs() < 5.0 * rel,
            "{}",
            var / sigma / sigma
        );
        // Lag-1 autocorrelation: standard deviation about sqrt((1 - phi^2) / n).
        let r1 = b
            .windows(2)
            .map(|w| (w[0] - mean) * (w[1] - mean))
            .sum::<f64>()
            / (nf * var);
        assert!(
            (r1 - phi).abs() < 5.0 * ((1.0 - phi * phi) / nf).sqrt(),
            "{r1} vs {phi}"
        );
    }

    #[test]
    fn rate_random_walk_steps_and_turn_on_bias_spread() {
        // Consecutive rate differences are the random-walk steps K sqrt(dt) n.
        let (k, dt) = (1e-3, 0.02);
        let mut m = ImuErrorModel::IDEAL;
        m.accel.rate_random_walk = k;
        let mut inj = ErrorInjector::new(m, 4).unwrap();
        let r: Vec<f64> = (0..50_001)
            .map(|_| inj.apply(&inc([0.0; 3], [0.0; 3], dt)).delta_v_ib_b.x / dt)
            .collect();
        let steps: Vec<f64> = r.windows(2).map(|w| w[1] - w[0]).collect();
        assert_variance(&steps, k * dt.sqrt());

        // Turn-on bias: constant within a run, spread sigma across seeds. The Gauss–Markov state
        // starts in its stationary distribution: spread sigma across seeds too.
        let mut m = ImuErrorModel::IDEAL;
        m.gyro.turn_on_bias_sigma = Vector3::new(1e-4, 2e-4, 3e-4);
        m.accel.bias_instability = GaussMarkov {
            sigma: 5e-3,
            correlation_time_s: 100.0,
        };
        let (z, gm): (Vec<f64>, Vec<f64>) = (0..4000)
            .map(|seed| {
                let inj = ErrorInjector::new(m, seed).unwrap();
                (inj.gyro_state().turn_on_bias.z, inj.accel_state().gm_bias.x)
            })
            .unzip();
        assert_variance(&z, 3e-4);
        assert_variance(&gm, 5e-3);
        let mut inj = ErrorInjector::new(m, 8).unwrap();
        let first = inj.apply(&inc([0.0; 3], [0.0; 3], 1.0)).delta_theta_ib_b;
        let later = inj.apply(&inc([0.0; 3], [0.0; 3], 1.0)).delta_theta_ib_b;
        assert_eq!(first, later);
        assert_eq!(first, inj.gyro_state().turn_on_bias);
    }

    #[test]
    fn invalid_model_is_refused() {
        let mut m = ImuErrorModel::IDEAL;
        m.accel.white_noise = WhiteNoise::Density(f64::NAN);
        let e = ErrorInjector::new(m, 0).unwrap_err();
        assert_eq!((e.triad, e.field), ("accel", "white_noise"));
    }
}
