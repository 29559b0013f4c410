//! Datasheet noise and bias figures of the supported parts, in SI: what alignment filters assume
//! for their tuning and their 1-sigma.

use nav_core::navigator::SensorFigures;

/// White noise densities and residual (in-run, after calibration) bias levels of a part, and
/// its other errors the aided filter models.
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
    /// Scale factors, cross-axis coupling and g-sensitivity ([`SensorFigures::DATASHEET`] for a
    /// part whose data sheet's noise table gives none).
    pub figures: SensorFigures,
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
    figures: SensorFigures::DATASHEET,
};

/// ICM-42688-P: 2.8 mdps/sqrt(Hz), 70 ug/sqrt(Hz) (datasheet); turn-on biases 0.5 deg/s and
/// 20 mg (typical consumer parts; assumed).
pub const ICM42688: NoiseSpec = NoiseSpec {
    gyro_arw_rad_per_sqrt_s: 2.8e-3 * DEG,
    accel_vrw_mps_per_sqrt_s: 70e-6 * G,
    gyro_bias_rad_s: 0.5 * DEG,
    accel_bias_mps2: 20e-3 * G,
    figures: SensorFigures::DATASHEET,
};

/// BMI088: gyro 0.014 deg/s/sqrt(Hz), accelerometer 175 ug/sqrt(Hz), offsets 1 deg/s and 20 mg
/// (the datasheet's typical figures as commonly quoted; not re-checked against rev. 1.3).
pub const BMI088: NoiseSpec = NoiseSpec {
    gyro_arw_rad_per_sqrt_s: 0.014 * DEG,
    accel_vrw_mps_per_sqrt_s: 175e-6 * G,
    gyro_bias_rad_s: DEG,
    accel_bias_mps2: 20e-3 * G,
    figures: SensorFigures::DATASHEET,
};

/// The simulator's sensor grades (`nav sim --grade`, the host's `sensor_model::Grade`): the
/// figures an alignment assumes for each, so the firmware can be told a recording's grade
/// (`--imu-noise GRADE`). White-noise densities, and per axis the largest of the grade's fixed
/// bias, turn-on 1-sigma and Gauss–Markov 1-sigma; for the aided filter the largest scale
/// factor of each triad (at least 1 ppm), the RMS of its six misalignment elements and the
/// largest g-sensitivity. The host's `Grade::noise_spec` derives the same numbers from its
/// error models (a test compares them).
pub mod grade {
    use super::{DEG, G, NoiseSpec, SensorFigures};

    /// A grade whose error model gives no scale factor, misalignment or g-sensitivity: scale
    /// factors at the filter's floor of 1 ppm, none of the rest.
    const NO_FIGURES: SensorFigures = SensorFigures {
        gyro_scale: 1e-6,
        accel_scale: 1e-6,
        gyro_cross_coupling_rad: 0.0,
        accel_cross_coupling_rad: 0.0,
        gyro_g_sensitivity: 0.0,
    };

    /// `fog`: 0.003 deg/s RMS at 400 Hz (1.5e-4 deg/s/sqrt(Hz)), 0.02 m/s^2 RMS at 400 Hz
    /// (1e-3 m/s^2/sqrt(Hz)), gyro bias 0.2 deg/h, accelerometer bias 0.005 m/s^2.
    pub const FOG: NoiseSpec = NoiseSpec {
        gyro_arw_rad_per_sqrt_s: 0.003 * DEG / 20.0,
        accel_vrw_mps_per_sqrt_s: 0.02 / 20.0,
        gyro_bias_rad_s: 0.2 * DEG / 3600.0,
        accel_bias_mps2: 0.005,
        figures: NO_FIGURES,
    };

    /// `rlg`: ARW 0.002 deg/sqrt(h), VRW 0.005 m/s/sqrt(h), gyro bias 0.01 deg/h,
    /// accelerometer bias 0.1 mg.
    pub const RLG: NoiseSpec = NoiseSpec {
        gyro_arw_rad_per_sqrt_s: 0.002 * DEG / 60.0,
        accel_vrw_mps_per_sqrt_s: 0.005 / 60.0,
        gyro_bias_rad_s: 0.01 * DEG / 3600.0,
        accel_bias_mps2: 0.1e-3 * G,
        figures: NO_FIGURES,
    };

    /// `mems-tactical` (ADIS16505 class): ARW 0.13 deg/sqrt(h), VRW 0.04 m/s/sqrt(h), turn-on
    /// biases 0.05 deg/s and 1 mg (above the in-run instabilities' 1-sigma).
    pub const MEMS_TACTICAL: NoiseSpec = NoiseSpec {
        gyro_arw_rad_per_sqrt_s: 0.13 * DEG / 60.0,
        accel_vrw_mps_per_sqrt_s: 0.04 / 60.0,
        gyro_bias_rad_s: 0.05 * DEG,
        accel_bias_mps2: 1e-3 * G,
        figures: SensorFigures {
            gyro_scale: 300e-6,
            accel_scale: 250e-6,
            gyro_cross_coupling_rad: 0.001_543_079,
            accel_cross_coupling_rad: 0.001_290_442_5,
            gyro_g_sensitivity: (0.005 * DEG / G) as f32,
        },
    };

    /// `mems-consumer` (ICM-42688-P class): 2.8 mdps/sqrt(Hz), 70 ug/sqrt(Hz), turn-on biases
    /// 0.5 deg/s and 20 mg.
    pub const MEMS_CONSUMER: NoiseSpec = NoiseSpec {
        gyro_arw_rad_per_sqrt_s: 2.8e-3 * DEG,
        accel_vrw_mps_per_sqrt_s: 70e-6 * G,
        gyro_bias_rad_s: 0.5 * DEG,
        accel_bias_mps2: 20e-3 * G,
        figures: SensorFigures {
            gyro_scale: 0.005,
            accel_scale: 0.005,
            gyro_cross_coupling_rad: 0.008_029_779,
            accel_cross_coupling_rad: 0.008_029_779,
            gyro_g_sensitivity: (0.1 * DEG / G) as f32,
        },
    };

    /// Every grade with a noise model, by its command-line name.
    pub const ALL: [(&str, NoiseSpec); 4] = [
        ("fog", FOG),
        ("rlg", RLG),
        ("mems-tactical", MEMS_TACTICAL),
        ("mems-consumer", MEMS_CONSUMER),
    ];

    /// The grade called `name`, if any.
    pub fn by_name(name: &str) -> Option<NoiseSpec> {
        ALL.iter().find(|(n, _)| *n == name).map(|(_, s)| *s)
    }
}
