//! Datasheet noise and bias figures of the supported parts, in SI: what alignment filters assume
//! for their tuning and their 1-sigma.

/// White noise densities and residual (in-run, after calibration) bias levels of a part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseSpec {
    /// Gyro angle random walk (white rate noise density) [rad/sqrt(s)].
    pub gyro_arw_rad_per_sqrt_s: f64,
    /// Accelerometer velocity random walk (white noise density) [m/s/sqrt(s)].
    pub accel_vrw_mps_per_sqrt_s: f64,
    /// Gyro bias 1-sigma per axis [rad/s].
    pub gyro_bias_rad_s: f64,
    /// Accelerometer bias 1-sigma per axis [m/s^2].
    pub accel_bias_mps2: f64,
}

const DEG: f64 = core::f64::consts::PI / 180.0;
const G: f64 = 9.806_65;

/// ADIS16505-2: ARW 0.13 deg/sqrt(h), in-run bias stability 2.3 deg/h (datasheet front page);
/// VRW 0.04 m/s/sqrt(h) and an accelerometer residual bias of 0.1 mg (assumed; turn-on biases
/// are removed by the calibration file).
pub const ADIS16505: NoiseSpec = NoiseSpec {
    gyro_arw_rad_per_sqrt_s: 0.13 * DEG / 60.0,
    accel_vrw_mps_per_sqrt_s: 0.04 / 60.0,
    gyro_bias_rad_s: 2.3 * DEG / 3600.0,
    accel_bias_mps2: 1e-4 * G,
};

/// ICM-42688-P: 2.8 mdps/sqrt(Hz), 70 ug/sqrt(Hz) (datasheet); turn-on biases 0.5 deg/s and
/// 20 mg (typical consumer parts; assumed).
pub const ICM42688: NoiseSpec = NoiseSpec {
    gyro_arw_rad_per_sqrt_s: 2.8e-3 * DEG,
    accel_vrw_mps_per_sqrt_s: 70e-6 * G,
    gyro_bias_rad_s: 0.5 * DEG,
    accel_bias_mps2: 20e-3 * G,
};

/// BMI088: gyro 0.014 deg/s/sqrt(Hz), accelerometer 175 ug/sqrt(Hz), offsets 1 deg/s and 20 mg
/// (the datasheet's typical figures as commonly quoted; not re-checked against rev. 1.3).
pub const BMI088: NoiseSpec = NoiseSpec {
    gyro_arw_rad_per_sqrt_s: 0.014 * DEG,
    accel_vrw_mps_per_sqrt_s: 175e-6 * G,
    gyro_bias_rad_s: DEG,
    accel_bias_mps2: 20e-3 * G,
};
