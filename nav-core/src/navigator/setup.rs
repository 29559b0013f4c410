//! A run configuration checked and converted for the data's rate: what both halves of the
//! navigator are built from.

use super::config::{ConfigError, RunConfig};
use crate::Scalar;
use crate::alignment::{AlignSettings, BaseMotion, LeverArm, SensorNoise};
use crate::calibration::ImuCompensation;
use crate::increment::InputLimits;
use crate::ins_filter::{FilterConfig, ZeroMotionConfig};
use crate::position::Position;
use crate::strapdown::{MechanizationConfig, NavFrame};
use nalgebra::Vector3;

/// The settings of one run in precision `T`, validated (small and `Copy`: the firmware hands
/// it to both of its tasks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setup<T: Scalar> {
    /// The alignment's settings (its `samples` is `n_align`).
    pub align: AlignSettings<T>,
    /// The mechanization's settings, with an identity compensation (the navigator compensates).
    pub mechanization: MechanizationConfig<T>,
    /// The sensor compensation applied to every increment, before alignment and navigation.
    pub compensation: ImuCompensation<T>,
    /// Limits every compensated increment is checked against.
    pub limits: InputLimits<T>,
    /// Navigation steps between logged solutions (>= 1).
    pub log_every: u32,
    /// The aided phase's filter (`None`: free inertial after the alignment). Its mechanization
    /// is [`Self::mechanization`] in the NED frame.
    pub filter: Option<FilterConfig<T>>,
}

impl<T: Scalar> Setup<T> {
    /// Checks `config` ([`RunConfig::validate`], then the alignment settings through
    /// [`AlignSettings::new`]: a window shorter than the method's minimum is refused with a
    /// message naming it) for data at `rate_hz` [Hz], and converts it to `T`.
    pub fn new(config: &RunConfig, rate_hz: f64) -> Result<Self, ConfigError> {
        config.validate()?;
        let compensation = config
            .calibration
            .compensation::<T>()
            .map_err(ConfigError::Calibration)?;
        let position = Position::from_degrees(config.lat_deg, config.lon_deg, config.h_m);
        let align = AlignSettings::new(
            config.align_method,
            position,
            config.align_seconds,
            rate_hz,
            noise_in(&config.align_noise()),
        )
        .map_err(ConfigError::Alignment)?
        .with_lever_arm(match config.lever_arm {
            LeverArm::Known(r) => LeverArm::Known(r.map(T::c)),
            LeverArm::Unknown { sigma_m } => LeverArm::Unknown {
                sigma_m: T::c(sigma_m),
            },
        })
        .with_base(BaseMotion {
            position_sigma_m: T::c(config.base.position_sigma_m),
            translation_sigma_m: T::c(config.base.translation_sigma_m),
        });
        // The lever arm and the base were set after `new`'s check.
        align.validate().map_err(ConfigError::Alignment)?;
        let choices = config.mechanization;
        let mechanization = MechanizationConfig {
            frame: choices.frame,
            attitude: choices.attitude,
            vertical: choices.vertical,
            compensation: ImuCompensation::default(),
            ..MechanizationConfig::default()
        };
        let filter = config.aiding.map(|a| {
            let mut f = FilterConfig::new(config.filter_noise());
            f.scale_factors = a.scale_factors;
            f.propagation_interval_s = T::c(a.propagation_interval_s);
            f.antenna_lever_arm_b_m = Vector3::from(a.antenna_lever_arm_b_m.map(T::c));
            f.gnss_correlated_error = a.gnss_correlated_error();
            f.zero_motion = a.zero_motion.then(ZeroMotionConfig::default);
            f.mechanization = MechanizationConfig {
                frame: NavFrame::Ned,
                ..mechanization
            };
            f
        });
        Ok(Self {
            align,
            limits: mechanization.limits,
            mechanization,
            compensation,
            log_every: config.log_every,
            filter,
        })
    }

    /// Samples of the alignment.
    pub fn n_align(&self) -> u32 {
        self.align.samples
    }
}

/// `noise` in precision `T`.
fn noise_in<T: Scalar>(noise: &SensorNoise<f64>) -> SensorNoise<T> {
    SensorNoise {
        arw_rad_per_sqrt_s: T::c(noise.arw_rad_per_sqrt_s),
        vrw_mps_per_sqrt_s: T::c(noise.vrw_mps_per_sqrt_s),
        gyro_bias_rad_s: T::c(noise.gyro_bias_rad_s),
        accel_bias_mps2: T::c(noise.accel_bias_mps2),
    }
}
