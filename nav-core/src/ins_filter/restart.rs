//! The filter's start from a start in motion ([`super::motion`]), one rule for the sequencer
//! ([`super::sequencer`]) and the navigator's aided phase ([`crate::navigator`]): at the run's
//! start in motion, and at the end of a re-alignment after a gap in the IMU data too long to
//! bridge or after the filter diverged (the recovery by re-initialisation of [Groves, ch. 17]).
//!
//! - The position, velocity and attitude are the start's, with its 1-sigma; the start's
//!   position is a fix's, so its error holds the receiver's declared correlated error
//!   ([`ErrorFilter::start_position_from_fix`]), and its level the accelerometers'
//!   ([`ErrorFilter::level_on_accelerometers`]).
//! - After a lost gap ([`Carried::Sensors`]) the sensor errors' estimates and their covariance
//!   go on: a gap destroys where the body is and how it is turned, not what the sensors are
//!   [Groves, §4.4]; their variances grow over the time the lost filter never propagated
//!   ([`ErrorFilter::take_sensors_from`]).
//! - At the run's start ([`Carried::Nothing`]) and after a divergence ([`Carried::Counters`]:
//!   a filter that ran away took sensor errors that are wrong) the sensors are known as at the
//!   run's start (a given start's 1-sigma, or the configuration's,
//!   [`FilterConfig::start_sensor_sigma`]), combined with the gyro bias
//!   found at rest when the start's level span was still.

use super::motion::MotionStart;
use super::{ErrorFilter, FilterConfig, FilterError, InitialSigma, SensorErrors};
use crate::{NavState, Scalar};

/// What a filter started in motion takes over from the filter it replaces (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Carried<T: Scalar> {
    /// Nothing: the run's first start.
    Nothing,
    /// After a lost gap: the sensor errors' estimates, their covariance grown over the
    /// `unpropagated_s` [s] the replaced filter never propagated, and the counters.
    Sensors {
        /// Lost time the replaced filter's covariance was not propagated over [s].
        unpropagated_s: T,
    },
    /// After a divergence: the counters only.
    Counters,
}

/// A filter's start in motion (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Restart<T: Scalar> {
    /// The state at the current sample.
    pub state: NavState<T>,
    /// The sensor errors compensated from the start.
    pub sensors: SensorErrors<T>,
    /// The 1-sigma of the start (the sensors' as [`Carried`] says).
    pub sigma: InitialSigma<T>,
    /// 1-sigma of the level span's mean acceleration [m/s^2]
    /// ([`MotionStart::level_acceleration_mps2`]).
    pub level_acceleration_mps2: T,
    /// What the replaced filter hands over.
    pub carried: Carried<T>,
}

impl<T: Scalar> Restart<T> {
    /// The start `s` found at a fix `lag_s` [s] before the current sample, for a filter of
    /// `config`: `sensors` are the sensor errors the start's samples were compensated with
    /// (after a lost gap, the replaced filter's estimates); `start_sigma` the sensors' 1-sigma
    /// at the run's start when it was given (`None`: `config`'s), used unless the
    /// sensors are carried.
    pub fn plan(
        s: &MotionStart<T>,
        lag_s: T,
        config: &FilterConfig<T>,
        sensors: SensorErrors<T>,
        start_sigma: Option<&InitialSigma<T>>,
        carried: Carried<T>,
    ) -> Self {
        let mut sigma = s.sigma.with_sensors(&config.start_sensor_sigma());
        let fresh = !matches!(carried, Carried::Sensors { .. });
        if let Some(given) = start_sigma.filter(|_| fresh) {
            sigma = sigma.with_sensors(&given.sensors());
        }
        let mut state = s.state;
        // From the fix's time to the current sample's.
        let d = state.v_eb_n * lag_s;
        state.position = state
            .position
            .offset_ned([d.x.to_f64(), d.y.to_f64(), d.z.to_f64()]);
        // The gyro bias found at rest, combined with the start's knowledge (not when the
        // sensors are carried: the samples were compensated by the carried estimate). The
        // samples were compensated by `sensors`: the bias found is what is left.
        let mut sensors = sensors;
        if let Some((b, s_rest)) = s.gyro_bias_at_rest.filter(|_| fresh) {
            for k in 0..3 {
                let (p2, r2) = (sigma.gyro_bias_rad_s[k].powi(2), s_rest[k] * s_rest[k]);
                if r2 > T::zero() && p2 > T::zero() {
                    sensors.gyro_bias_rad_s[k] += b[k] * p2 / (p2 + r2);
                    sigma.gyro_bias_rad_s[k] = (p2 * r2 / (p2 + r2)).sqrt();
                }
            }
        }
        Self {
            state,
            sensors,
            sigma,
            level_acceleration_mps2: s.level_acceleration_mps2,
            carried,
        }
    }

    /// The error filter of this start, in place of `replaced` (`None` at the run's first
    /// start, or when nothing is carried): `mech_state` is the state as the mechanization
    /// started from it took it, `g` [m/s^2] its gravity there.
    pub fn filter(
        &self,
        config: FilterConfig<T>,
        replaced: Option<&ErrorFilter<T>>,
        mech_state: &NavState<T>,
        g: T,
    ) -> Result<ErrorFilter<T>, FilterError> {
        let mut f = ErrorFilter::new(&self.sigma, mech_state.euler().2, config)?;
        match (self.carried, replaced) {
            (Carried::Sensors { unpropagated_s }, Some(r)) => {
                f.take_sensors_from(r, unpropagated_s)
            }
            (Carried::Counters, Some(r)) => f.take_counters_from(r),
            _ => {}
        }
        f.start_position_from_fix();
        let c_b_n = mech_state.q_b_n.to_rotation_matrix().into_inner();
        f.level_on_accelerometers(&c_b_n, g, self.level_acceleration_mps2);
        Ok(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ins_filter::model::tests::noise;
    use crate::{NavState, Position};
    use nalgebra::{UnitQuaternion, Vector3};

    fn start() -> MotionStart<f64> {
        MotionStart {
            state: NavState {
                q_b_n: UnitQuaternion::identity(),
                v_eb_n: Vector3::new(10.0, 0.0, 0.0),
                position: Position::from_radians(0.8, 0.2, 100.0),
            },
            sigma: InitialSigma::new(
                Vector3::repeat(1.0),
                Vector3::repeat(0.1),
                Vector3::new(0.01, 0.01, 0.05),
                &SensorErrors::default(),
            ),
            level_acceleration_mps2: 0.01,
            gyro_bias_at_rest: None,
        }
    }

    /// A start in motion knows the sensors as the configuration says at the start: its own
    /// start 1-sigma when it has one (a grade's turn-on spread), not the in-run model's
    /// stationary 1-sigma, also after a divergence; a given start's wins.
    #[test]
    fn the_sensors_start_with_the_configured_sigma() {
        let plan = |config: &FilterConfig<f64>, given: Option<&InitialSigma<f64>>, carried| {
            Restart::plan(
                &start(),
                0.0,
                config,
                SensorErrors::default(),
                given,
                carried,
            )
        };
        let mut config = FilterConfig::new(noise());
        let of_noise = plan(&config, None, Carried::Nothing);
        assert_eq!(of_noise.sigma.sensors(), config.start_sensor_sigma());
        assert_eq!(
            of_noise.sigma.accel_bias_mps2,
            Vector3::repeat(noise().accel_bias_mps2)
        );
        let turn_on = SensorErrors {
            gyro_bias_rad_s: Vector3::new(1e-3, 2e-3, 3e-3),
            accel_bias_mps2: Vector3::new(0.1, 0.2, 0.3),
            gyro_scale: Vector3::repeat(5e-3),
            accel_scale: Vector3::repeat(4e-3),
        };
        config.sensor_sigma = Some(turn_on);
        let fresh = plan(&config, None, Carried::Nothing);
        assert_eq!(fresh.sigma.sensors(), turn_on);
        assert_eq!(fresh.sigma.position_ned_m, start().sigma.position_ned_m);
        let again = plan(&config, None, Carried::Counters);
        assert_eq!(again.sigma.sensors(), turn_on);
        let given = InitialSigma::new(
            Vector3::repeat(1.0),
            Vector3::repeat(1.0),
            Vector3::repeat(1.0),
            &SensorErrors {
                accel_bias_mps2: Vector3::repeat(0.05),
                ..turn_on
            },
        );
        let given_plan = plan(&config, Some(&given), Carried::Nothing);
        assert_eq!(given_plan.sigma.accel_bias_mps2, Vector3::repeat(0.05));
        // The re-alignment's level allows for the start's accelerometer bias.
        let realign = crate::ins_filter::motion::MotionAlignConfig::for_realignment(&config);
        assert!(realign.accel_bias_mps2 >= 0.3, "{realign:?}");
    }
}
