//! The error model of one sensor triad (three gyros or three accelerometers), Groves 2nd ed.
//! §4.4.6, [Berdinskikh et al., eqs. 3 and 8].
//!
//! Units: every field is in the triad's SI unit `U` = [rad/s] for gyros, [m/s^2] for
//! accelerometers, combined with time as written ([U/sqrt(Hz)], [U/sqrt(s)]).

use super::allan::GM_PEAK_ADEV_PER_SIGMA;
use nav_core::Vector3;
use nav_core::nalgebra::Matrix3;

/// White noise on the sensed rate, given either way datasheets and papers give it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WhiteNoise {
    /// Density `N` [U/sqrt(Hz)] (datasheet convention, so an angle random walk in
    /// [deg/sqrt(h)] is `60 N` with `N` in [deg/s/sqrt(Hz)]). An increment over `dt` gets
    /// `N sqrt(dt) n`, `n ~ N(0, 1)` (IEEE Std 952-1997 Annex C: Allan variance `N^2 / tau`).
    Density(f64),
    /// RMS of the rate sampled at `rate_hz` ([U], [Hz]), as [Vavilova et al., §4] gives it
    /// ("0.003 deg/s RMS at 400 Hz"): density = `rms / sqrt(rate_hz)` (the rate averaged over
    /// `1 / rate_hz`).
    RmsAtRate {
        /// RMS of one rate sample [U].
        rms: f64,
        /// Sampling rate the RMS refers to [Hz].
        rate_hz: f64,
    },
}

impl WhiteNoise {
    /// No white noise.
    pub const OFF: Self = Self::Density(0.0);

    /// The density `N` [U/sqrt(Hz)].
    pub fn density(&self) -> f64 {
        match *self {
            Self::Density(n) => n,
            Self::RmsAtRate { rms, rate_hz } => rms / rate_hz.sqrt(),
        }
    }
}

/// A first-order Gauss–Markov bias (Groves §4.4.6; IEEE Std 952-1997 Annex C "exponentially
/// correlated noise"): `db/dt = -b / tau + w`, stationary standard deviation `sigma`.
///
/// **Bias instability.** This model's bias instability `B` is defined as the maximum over
/// averaging time of the Allan deviation of this process alone; it is reached at
/// `tau_avg = 1.89 tau` and equals `B = 0.6174 sigma` ([`GM_PEAK_ADEV_PER_SIGMA`]). A datasheet's
/// "in-run bias stability" (the floor of its measured Allan deviation) is mapped to the
/// process by [`GaussMarkov::from_bias_instability`], `sigma = B / 0.6174`, so that the hump of
/// the simulated Allan curve reaches the datasheet's value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussMarkov {
    /// Stationary standard deviation `sigma` [U].
    pub sigma: f64,
    /// Correlation time `tau` [s] (`f64::INFINITY`: a random constant of standard deviation
    /// `sigma`).
    pub correlation_time_s: f64,
}

impl GaussMarkov {
    /// No Gauss–Markov bias.
    pub const OFF: Self = Self {
        sigma: 0.0,
        correlation_time_s: f64::INFINITY,
    };

    /// The process whose bias instability (the peak of its Allan deviation) is
    /// `bias_instability` [U], with correlation time `correlation_time_s` [s].
    pub fn from_bias_instability(bias_instability: f64, correlation_time_s: f64) -> Self {
        Self {
            sigma: bias_instability / GM_PEAK_ADEV_PER_SIGMA,
            correlation_time_s,
        }
    }

    /// Bias instability `B = 0.6174 sigma` [U] (see the type's docs).
    pub fn bias_instability(&self) -> f64 {
        GM_PEAK_ADEV_PER_SIGMA * self.sigma
    }

    /// Exact discretisation over `dt_s` [s]: `(phi, q)` with `b_{k+1} = phi b_k + q n`,
    /// `phi = exp(-dt / tau)`, `q = sigma sqrt(1 - phi^2)`, `n ~ N(0, 1)`.
    pub fn discrete(&self, dt_s: f64) -> (f64, f64) {
        let phi = (-dt_s / self.correlation_time_s).exp();
        // 1 - phi^2 = -expm1(-2 dt / tau), without cancellation for dt << tau.
        let q = self.sigma * (-(-2.0 * dt_s / self.correlation_time_s).exp_m1()).sqrt();
        (phi, q)
    }
}

/// Error model of one triad. The sensed increment over an interval `dt` is
/// (Groves §4.4.6; [Berdinskikh et al., eqs. 3, 8]: `measured = (1 + m) true + bias` per axis)
///
/// ```text
/// d_meas = (I + diag(scale) + misalignment) d_true
///        + (bias + b_turn_on + b_gm + b_rw) dt + N sqrt(dt) n     [+ G dv_true, gyros]
/// ```
/// then clamped per axis to `+-full_scale dt` and quantised to `lsb` with the remainder carried.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriadErrors {
    /// Fixed bias, body axes [U].
    pub bias: Vector3<f64>,
    /// Turn-on bias (bias repeatability) 1-sigma per axis [U]: drawn once per seed, then constant.
    pub turn_on_bias_sigma: Vector3<f64>,
    /// Scale-factor errors `m` per axis [-] (`m_omega`, `m_a` of [Berdinskikh et al., eqs. 3, 8]).
    pub scale: Vector3<f64>,
    /// Misalignment / non-orthogonality [rad]: `M_ij` couples true axis `j` into sensed axis `i`
    /// (small angles). The diagonal should be zero (scale errors live in `scale`); it is used as
    /// given.
    pub misalignment: Matrix3<f64>,
    /// White noise on the rate (angle / velocity random walk).
    pub white_noise: WhiteNoise,
    /// Bias instability as a first-order Gauss–Markov process, independent per axis.
    pub bias_instability: GaussMarkov,
    /// Rate random walk density `K` [U/sqrt(s)]: `b_rw += K sqrt(dt) n` (Allan variance
    /// `K^2 tau / 3`, IEEE Std 952-1997 Annex C).
    pub rate_random_walk: f64,
    /// Quantum of the increment output [U s] ([rad] or [m/s]); 0 = not quantised. The quantiser
    /// integrates: each sample's rounding remainder is carried into the next.
    pub lsb: f64,
    /// Full scale of the rate [U]; each axis of an increment is clamped to `+-full_scale dt`.
    /// `f64::INFINITY` = no saturation.
    pub full_scale: f64,
}

impl TriadErrors {
    /// The filter's scale-factor 1-sigma of this triad: its largest scale error, at least
    /// 1 ppm (a zero variance would be a covariance fault) [-].
    pub fn scale_sigma(&self) -> f64 {
        self.scale.amax().max(1e-6)
    }

    /// A perfect triad.
    pub const IDEAL: Self = Self {
        bias: Vector3::new(0.0, 0.0, 0.0),
        turn_on_bias_sigma: Vector3::new(0.0, 0.0, 0.0),
        scale: Vector3::new(0.0, 0.0, 0.0),
        misalignment: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        white_noise: WhiteNoise::OFF,
        bias_instability: GaussMarkov::OFF,
        rate_random_walk: 0.0,
        lsb: 0.0,
        full_scale: f64::INFINITY,
    };

    /// `I + diag(scale) + misalignment` [-].
    pub fn model_matrix(&self) -> Matrix3<f64> {
        Matrix3::identity() + Matrix3::from_diagonal(&self.scale) + self.misalignment
    }

    /// The deterministic part as nav-core's calibration type (fixed bias, scale, off-diagonal
    /// misalignment), e.g. to give a filter test the true calibration.
    pub fn calibration(&self) -> nav_core::calibration::TriadErrors {
        let m = &self.misalignment;
        nav_core::calibration::TriadErrors {
            bias: self.bias.into(),
            scale: self.scale.into(),
            misalignment: [
                m[(0, 1)],
                m[(0, 2)],
                m[(1, 0)],
                m[(1, 2)],
                m[(2, 0)],
                m[(2, 1)],
            ],
        }
    }

    /// Checks that every parameter is usable; `name` prefixes the field in the error.
    pub(super) fn validate(&self, name: &'static str) -> Result<(), InvalidModel> {
        let err = |field: &'static str, requirement: &'static str| {
            Err(InvalidModel {
                triad: name,
                field,
                requirement,
            })
        };
        let finite3 = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
        let finite_nonneg = |x: f64| x.is_finite() && x >= 0.0;
        if !finite3(&self.bias) {
            return err("bias", "finite");
        }
        if !self.turn_on_bias_sigma.iter().all(|&x| finite_nonneg(x)) {
            return err("turn_on_bias_sigma", "finite, >= 0");
        }
        if !finite3(&self.scale) {
            return err("scale", "finite");
        }
        if !self.misalignment.iter().all(|x| x.is_finite()) {
            return err("misalignment", "finite");
        }
        match self.white_noise {
            WhiteNoise::Density(n) if !finite_nonneg(n) => {
                return err("white_noise", "density finite, >= 0");
            }
            WhiteNoise::RmsAtRate { rms, rate_hz }
                if !(finite_nonneg(rms) && rate_hz.is_finite() && rate_hz > 0.0) =>
            {
                return err("white_noise", "rms finite, >= 0; rate finite, > 0");
            }
            _ => {}
        }
        let gm = self.bias_instability;
        if !finite_nonneg(gm.sigma) {
            return err("bias_instability.sigma", "finite, >= 0");
        }
        if gm.correlation_time_s.is_nan() || gm.correlation_time_s <= 0.0 {
            return err(
                "bias_instability.correlation_time_s",
                "> 0 (may be infinite)",
            );
        }
        if !finite_nonneg(self.rate_random_walk) {
            return err("rate_random_walk", "finite, >= 0");
        }
        if !finite_nonneg(self.lsb) {
            return err("lsb", "finite, >= 0");
        }
        if self.full_scale.is_nan() || self.full_scale <= 0.0 {
            return err("full_scale", "> 0 (may be infinite)");
        }
        Ok(())
    }
}

impl Default for TriadErrors {
    fn default() -> Self {
        Self::IDEAL
    }
}

/// A model parameter that cannot be used (non-finite or out of range).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InvalidModel {
    /// `"gyro"`, `"accel"` or `"model"`.
    pub triad: &'static str,
    /// The field's name.
    pub field: &'static str,
    /// What the field must be.
    pub requirement: &'static str,
}

impl core::fmt::Display for InvalidModel {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "invalid sensor model: {}.{} must be {}",
            self.triad, self.field, self.requirement
        )
    }
}

impl core::error::Error for InvalidModel {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rms_at_rate_is_density_times_sqrt_rate() {
        // [Vavilova et al., §4]: 0.003 deg/s RMS at 400 Hz -> 1.5e-4 deg/s/sqrt(Hz).
        let w = WhiteNoise::RmsAtRate {
            rms: 0.003,
            rate_hz: 400.0,
        };
        assert!((w.density() - 1.5e-4).abs() < 1e-18);
        assert_eq!(WhiteNoise::Density(2.0).density(), 2.0);
    }

    #[test]
    fn gauss_markov_discretisation() {
        let gm = GaussMarkov {
            sigma: 2.0,
            correlation_time_s: 10.0,
        };
        let (phi, q) = gm.discrete(1.0);
        assert!((phi - (-0.1f64).exp()).abs() < 1e-15);
        // Stationary: phi^2 sigma^2 + q^2 = sigma^2.
        assert!((phi * phi * 4.0 + q * q - 4.0).abs() < 1e-12);
        // Random constant: phi = 1, no driving noise.
        assert_eq!(GaussMarkov::OFF.discrete(0.1), (1.0, 0.0));
        let b = GaussMarkov::from_bias_instability(1.0, 5.0);
        assert!((b.bias_instability() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn validation_names_the_field() {
        let mut t = TriadErrors::IDEAL;
        assert!(t.validate("gyro").is_ok());
        t.lsb = -1.0;
        let e = t.validate("gyro").unwrap_err();
        assert_eq!(e.field, "lsb");
        assert!(e.to_string().contains("gyro.lsb"));
        t.lsb = 0.0;
        t.bias_instability.correlation_time_s = 0.0;
        assert!(t.validate("gyro").is_err());
        t.bias_instability.correlation_time_s = f64::INFINITY;
        t.white_noise = WhiteNoise::RmsAtRate {
            rms: 1.0,
            rate_hz: 0.0,
        };
        assert!(t.validate("gyro").is_err());
    }

    #[test]
    fn calibration_maps_off_diagonals() {
        let mut t = TriadErrors::IDEAL;
        t.misalignment = Matrix3::new(0.0, 1.0, 2.0, 3.0, 0.0, 4.0, 5.0, 6.0, 0.0);
        t.scale = Vector3::new(0.1, 0.2, 0.3);
        let c = t.calibration();
        assert_eq!(c.misalignment, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(c.scale, [0.1, 0.2, 0.3]);
    }
}
