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

impl Default for ImuErrorModel {
    fn default() -> Self {
        Self::IDEAL
    }
}
