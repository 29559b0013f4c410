//! The navigation filter's error state vector: named offsets, sizes and the initial
//! uncertainty.

use super::SensorErrors;
use super::stationarity::Uncertainty;
use crate::Scalar;
use nalgebra::{SMatrix, SVector, Vector3};

/// Number of error states.
pub const N: usize = 21;
/// Position error north, east, down [m].
pub const POS: usize = 0;
/// Velocity error north, east, down [m/s].
pub const VEL: usize = 3;
/// Attitude error `phi` (NED axes) [rad].
pub const ATT: usize = 6;
/// Gyro bias error (body axes) [rad/s].
pub const BG: usize = 9;
/// Accelerometer bias error (body axes) [m/s^2].
pub const BA: usize = 12;
/// Gyro scale-factor error (body axes) [-].
pub const SG: usize = 15;
/// Accelerometer scale-factor error (body axes) [-].
pub const SA: usize = 18;

/// The error state vector.
pub type StateVector<T> = SVector<T, N>;
/// Its covariance (and every `N x N` matrix of the filter).
pub type Covariance<T> = SMatrix<T, N, N>;

/// 1-sigma uncertainty of the filter's start, per axis (KF-GINS's `init*std`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InitialSigma<T: Scalar> {
    /// Position north, east, down [m].
    pub position_ned_m: Vector3<T>,
    /// Velocity north, east, down [m/s].
    pub velocity_ned_m_s: Vector3<T>,
    /// Attitude: roll, pitch, yaw [rad] (taken as the NED-axis tilt and heading errors).
    pub attitude_rad: Vector3<T>,
    /// Gyro bias [rad/s].
    pub gyro_bias_rad_s: Vector3<T>,
    /// Accelerometer bias [m/s^2].
    pub accel_bias_mps2: Vector3<T>,
    /// Gyro scale factor [-].
    pub gyro_scale: Vector3<T>,
    /// Accelerometer scale factor [-].
    pub accel_scale: Vector3<T>,
}

impl<T: Scalar> InitialSigma<T> {
    /// The 1-sigma of position [m], velocity [m/s] and attitude [rad] (as the fields) with
    /// the sensor errors' `sensors`.
    pub fn new(
        position_ned_m: Vector3<T>,
        velocity_ned_m_s: Vector3<T>,
        attitude_rad: Vector3<T>,
        sensors: &SensorErrors<T>,
    ) -> Self {
        Self {
            position_ned_m,
            velocity_ned_m_s,
            attitude_rad,
            gyro_bias_rad_s: sensors.gyro_bias_rad_s,
            accel_bias_mps2: sensors.accel_bias_mps2,
            gyro_scale: sensors.gyro_scale,
            accel_scale: sensors.accel_scale,
        }
    }

    /// This start with the sensor errors' 1-sigma `sensors`.
    pub fn with_sensors(self, sensors: &SensorErrors<T>) -> Self {
        Self::new(
            self.position_ned_m,
            self.velocity_ned_m_s,
            self.attitude_rad,
            sensors,
        )
    }

    /// The sensor errors' 1-sigma.
    pub fn sensors(&self) -> SensorErrors<T> {
        SensorErrors {
            gyro_bias_rad_s: self.gyro_bias_rad_s,
            accel_bias_mps2: self.accel_bias_mps2,
            gyro_scale: self.gyro_scale,
            accel_scale: self.accel_scale,
        }
    }

    /// What the stop detector allows for at the start ([`Uncertainty`]): the largest gyro-bias
    /// 1-sigma; the largest tilt's at gravity `g` [m/s^2] with the largest accelerometer
    /// bias's (independent at the start).
    pub fn uncertainty(&self, g: T) -> Uncertainty<T> {
        let att = &self.attitude_rad;
        let tilt = g * att.x.max(att.y);
        let ba = self.accel_bias_mps2.max();
        Uncertainty {
            gyro_bias_rad_s: self.gyro_bias_rad_s.max(),
            horizontal_force_mps2: (tilt * tilt + ba * ba).sqrt(),
        }
    }

    /// The start covariance of a body at heading `yaw` [rad]: diagonal but for the tilt pair
    /// (roll and pitch errors are tilts about the body's forward and right axes: turned by the
    /// yaw into north and east ones); the scale-factor states are zero when not modelled.
    pub fn covariance(&self, yaw: T, scale_factors: bool) -> Covariance<T> {
        let mut p = Covariance::<T>::zeros();
        let put = |p: &mut Covariance<T>, at: usize, v: &Vector3<T>| {
            for k in 0..3 {
                p[(at + k, at + k)] = v[k] * v[k];
            }
        };
        put(&mut p, POS, &self.position_ned_m);
        put(&mut p, VEL, &self.velocity_ned_m_s);
        let (sy, cy) = (yaw.psin(), yaw.pcos());
        let (r2, p2) = (
            self.attitude_rad.x * self.attitude_rad.x,
            self.attitude_rad.y * self.attitude_rad.y,
        );
        p[(ATT, ATT)] = cy * cy * r2 + sy * sy * p2;
        p[(ATT + 1, ATT + 1)] = sy * sy * r2 + cy * cy * p2;
        p[(ATT, ATT + 1)] = cy * sy * (r2 - p2);
        p[(ATT + 1, ATT)] = p[(ATT, ATT + 1)];
        p[(ATT + 2, ATT + 2)] = self.attitude_rad.z * self.attitude_rad.z;
        put(&mut p, BG, &self.gyro_bias_rad_s);
        put(&mut p, BA, &self.accel_bias_mps2);
        if scale_factors {
            put(&mut p, SG, &self.gyro_scale);
            put(&mut p, SA, &self.accel_scale);
        }
        p
    }
}
