//! One IMU sample as nav-core sees it: angle and velocity increments over an interval.

use crate::Scalar;
use nalgebra::Vector3;

/// Gyro and accelerometer increments over one sampling interval, body axes (FRD).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuIncrement<T: Scalar> {
    /// Integral of `omega_ib_b` over the interval [rad].
    pub delta_theta_ib_b: Vector3<T>,
    /// Integral of `f_ib_b` over the interval [m/s].
    pub delta_v_ib_b: Vector3<T>,
    /// Length of the interval [s] (the measured one, not the nominal one).
    pub dt: T,
}

impl<T: Scalar> ImuIncrement<T> {
    /// Builds an increment from plain arrays: `delta_theta_ib_b` [rad], `delta_v_ib_b` [m/s],
    /// `dt` [s].
    pub fn new(delta_theta_ib_b: [T; 3], delta_v_ib_b: [T; 3], dt: T) -> Self {
        Self {
            delta_theta_ib_b: Vector3::from(delta_theta_ib_b),
            delta_v_ib_b: Vector3::from(delta_v_ib_b),
            dt,
        }
    }

    /// Checks the increment against `limits`; nav-core refuses anything that fails.
    pub fn check(&self, limits: &InputLimits<T>) -> Result<(), InputError> {
        let all_finite = self.delta_theta_ib_b.iter().all(|x| x.finite())
            && self.delta_v_ib_b.iter().all(|x| x.finite());
        if !all_finite || !self.dt.finite() {
            return Err(InputError::NonFinite);
        }
        if self.dt <= T::zero() || self.dt > limits.max_dt {
            return Err(InputError::BadInterval);
        }
        if self.delta_theta_ib_b.amax() > limits.max_rate * self.dt
            || self.delta_v_ib_b.amax() > limits.max_specific_force * self.dt
        {
            return Err(InputError::OutOfRange);
        }
        Ok(())
    }
}

/// Plausibility limits applied to every increment before it reaches the mechanization.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InputLimits<T: Scalar> {
    /// Longest accepted interval [s].
    pub max_dt: T,
    /// Largest accepted body rate magnitude per axis [rad/s].
    pub max_rate: T,
    /// Largest accepted specific force per axis [m/s^2].
    pub max_specific_force: T,
}

impl<T: Scalar> Default for InputLimits<T> {
    /// 0.1 s, 2000 deg/s, 50 g: beyond any tactical IMU's range, so only garbage is refused.
    fn default() -> Self {
        Self {
            max_dt: T::c(0.1),
            max_rate: T::c(2000.0_f64.to_radians()),
            max_specific_force: T::c(50.0 * 9.806_65),
        }
    }
}

/// Why an increment was refused (the navigation state is left untouched).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputError {
    /// A component or `dt` is NaN or infinite.
    NonFinite,
    /// `dt` is zero, negative or longer than [`InputLimits::max_dt`].
    BadInterval,
    /// A rate or specific force beyond [`InputLimits`].
    OutOfRange,
    /// The sample's time is not after the last navigated sample's ([`crate::gap`]).
    OutOfOrder,
}

impl core::fmt::Display for InputError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NonFinite => "increment contains NaN or infinity",
            Self::BadInterval => "sampling interval is not positive or too long",
            Self::OutOfRange => "rate or specific force beyond the plausible range",
            Self::OutOfOrder => "time not after the last navigated sample's",
        })
    }
}

impl core::error::Error for InputError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_garbage() {
        let l = InputLimits::<f32>::default();
        let ok = ImuIncrement::new([1e-4; 3], [0.0, 0.0, -0.0245], 0.0025_f32);
        assert_eq!(ok.check(&l), Ok(()));
        let mut bad = ok;
        bad.delta_v_ib_b.x = f32::NAN;
        assert_eq!(bad.check(&l), Err(InputError::NonFinite));
        bad = ok;
        bad.delta_theta_ib_b.z = f32::INFINITY;
        assert_eq!(bad.check(&l), Err(InputError::NonFinite));
        for dt in [0.0, -0.0025, 0.5, f32::NAN] {
            bad = ok;
            bad.dt = dt;
            assert!(bad.check(&l).is_err(), "dt {dt}");
        }
        bad = ok;
        bad.delta_v_ib_b.x = 10.0; // 4000 m/s^2 over 2.5 ms
        assert_eq!(bad.check(&l), Err(InputError::OutOfRange));
    }
}
