//! The error model of a whole IMU: two triads and the gyros' g-sensitivity.

use super::triad::{InvalidModel, TriadErrors};
use nav_core::nalgebra::Matrix3;

/// Error model of an IMU (Groves 2nd ed. §4.4.6).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuErrorModel {
    /// Gyro triad; its unit `U` is [rad/s] (increments [rad]).
    pub gyro: TriadErrors,
    /// Accelerometer triad; its unit `U` is [m/s^2] (increments [m/s]).
    pub accel: TriadErrors,
    /// Gyro g-sensitivity `G` [rad/s per m/s^2]: the gyros sense `G f_ib_b` on top of the rate
    /// (row: gyro axis, column: specific-force axis).
    pub g_sensitivity_rad_s_per_m_s2: Matrix3<f64>,
}

impl ImuErrorModel {
    /// A perfect IMU.
    pub const IDEAL: Self = Self {
        gyro: TriadErrors::IDEAL,
        accel: TriadErrors::IDEAL,
        g_sensitivity_rad_s_per_m_s2: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    };

    /// Checks every parameter (finite, and non-negative where it is a spread or a size).
    pub fn validate(&self) -> Result<(), InvalidModel> {
        self.gyro.validate("gyro")?;
        self.accel.validate("accel")?;
        if !self
            .g_sensitivity_rad_s_per_m_s2
            .iter()
            .all(|x| x.is_finite())
        {
            return Err(InvalidModel {
                triad: "model",
                field: "g_sensitivity_rad_s_per_m_s2",
                requirement: "finite",
            });
        }
        Ok(())
    }

    /// The deterministic part as nav-core's calibration (what a perfect calibration would
    /// compensate; the turn-on biases are drawn per seed, see
    /// [`super::ErrorInjector::gyro_state`]).
    pub fn calibration(&self) -> nav_core::calibration::ImuCalibration {
        nav_core::calibration::ImuCalibration {
            gyro: self.gyro.calibration(),
            accel: self.accel.calibration(),
        }
    }
}

/// One kind of sensor error, to switch off alone (`nav bench consistency --without`): which
/// of them a filter's inconsistency comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorSource {
    /// Axis misalignment / non-orthogonality of both triads.
    Misalignment,
    /// The gyros' misalignment alone.
    GyroMisalignment,
    /// The accelerometers' misalignment alone.
    AccelMisalignment,
    /// The gyros' g-sensitivity.
    GSensitivity,
    /// Scale-factor errors of both triads.
    Scale,
    /// Fixed and turn-on biases.
    Bias,
    /// Gauss–Markov bias instability.
    BiasInstability,
    /// Rate random walk.
    RateRandomWalk,
    /// White noise (angle and velocity random walk).
    WhiteNoise,
    /// Quantisation and saturation.
    Quantisation,
}

impl ErrorSource {
    /// Every source, in the order of the names.
    pub const ALL: [ErrorSource; 10] = [
        ErrorSource::Misalignment,
        ErrorSource::GyroMisalignment,
        ErrorSource::AccelMisalignment,
        ErrorSource::GSensitivity,
        ErrorSource::Scale,
        ErrorSource::Bias,
        ErrorSource::BiasInstability,
        ErrorSource::RateRandomWalk,
        ErrorSource::WhiteNoise,
        ErrorSource::Quantisation,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ErrorSource::Misalignment => "misalignment",
            ErrorSource::GyroMisalignment => "gyro-misalignment",
            ErrorSource::AccelMisalignment => "accel-misalignment",
            ErrorSource::GSensitivity => "g-sensitivity",
            ErrorSource::Scale => "scale",
            ErrorSource::Bias => "bias",
            ErrorSource::BiasInstability => "bias-instability",
            ErrorSource::RateRandomWalk => "rate-random-walk",
            ErrorSource::WhiteNoise => "white-noise",
            ErrorSource::Quantisation => "quantisation",
        }
    }
}

impl core::str::FromStr for ErrorSource {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|e| e.name()).collect();
                format!(
                    "unknown error source '{s}'; expected one of: {}",
                    names.join(", ")
                )
            })
    }
}

impl ImuErrorModel {
    /// This model with `source` switched off in both triads.
    pub fn without(&self, source: ErrorSource) -> Self {
        let mut m = *self;
        for t in [&mut m.gyro, &mut m.accel] {
            match source {
                ErrorSource::Misalignment => t.misalignment = Matrix3::zeros(),
                ErrorSource::Scale => t.scale = TriadErrors::IDEAL.scale,
                ErrorSource::Bias => {
                    t.bias = TriadErrors::IDEAL.bias;
                    t.turn_on_bias_sigma = TriadErrors::IDEAL.turn_on_bias_sigma;
                }
                ErrorSource::BiasInstability => {
                    t.bias_instability = TriadErrors::IDEAL.bias_instability
                }
                ErrorSource::RateRandomWalk => t.rate_random_walk = 0.0,
                ErrorSource::WhiteNoise => t.white_noise = TriadErrors::IDEAL.white_noise,
                ErrorSource::Quantisation => {
                    t.lsb = 0.0;
                    t.full_scale = f64::INFINITY;
                }
                ErrorSource::GSensitivity
                | ErrorSource::GyroMisalignment
                | ErrorSource::AccelMisalignment => {}
            }
        }
        match source {
            ErrorSource::GSensitivity => m.g_sensitivity_rad_s_per_m_s2 = Matrix3::zeros(),
            ErrorSource::GyroMisalignment => m.gyro.misalignment = Matrix3::zeros(),
            ErrorSource::AccelMisalignment => m.accel.misalignment = Matrix3::zeros(),
            _ => {}
        }
        m
    }
}

impl Default for ImuErrorModel {
    fn default() -> Self {
        Self::IDEAL
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor_model::Grade;

    #[test]
    fn each_source_switches_off_alone() {
        let m = Grade::MemsTactical.model();
        for source in ErrorSource::ALL {
            assert_eq!(source.name().parse::<ErrorSource>(), Ok(source));
            let w = m.without(source);
            assert!(w.validate().is_ok(), "{source:?}");
            assert_ne!(w, m, "{source:?} changed nothing");
        }
        let w = m.without(ErrorSource::AccelMisalignment);
        assert_eq!(w.accel.misalignment, Matrix3::zeros());
        assert_eq!(w.gyro, m.gyro);
        let w = m.without(ErrorSource::Misalignment);
        assert_eq!(w.gyro.misalignment, Matrix3::zeros());
        assert_eq!(w.accel.misalignment, Matrix3::zeros());
        assert_eq!(
            w.g_sensitivity_rad_s_per_m_s2,
            m.g_sensitivity_rad_s_per_m_s2
        );
        assert!(
            "misaligned"
                .parse::<ErrorSource>()
                .unwrap_err()
                .contains("scale")
        );
    }
}
