//! Starting in motion from GNSS, for IMUs that cannot find north by gyrocompassing (MEMS).
//!
//! - Level: over an interval between two fixes in which the GNSS velocity changes by less than
//!   [`MotionAlignConfig::max_accel_mps2`] (quasi-static: the specific force is gravity), roll
//!   and pitch from the mean specific force (Groves eq. 5.101); their 1-sigma is the
//!   acceleration bound plus the accelerometer bias over `g`.
//! - Heading: once the horizontal speed exceeds [`MotionAlignConfig::min_speed_m_s`], the
//!   ground track `atan2(v_E, v_N)` (a land vehicle moves along its forward axis); 1-sigma from
//!   the velocity's 1-sigma over the speed and the sideslip allowance.
//! - Velocity: the GNSS velocity, or the difference of two positions over their interval.
//!
//! - Fixes farther apart than [`MAX_FIX_INTERVAL_S`] (an outage) are not an interval: their
//!   position difference is the mean velocity over the outage, not the velocity at the fix, and
//!   a small velocity change across it does not make the vehicle quasi-static in between. The
//!   level and velocity found before it are dropped, and the start begins again at the fix
//!   after it.
//!
//! When both are known at a fix, [`MotionAlign::add_fix`] returns the start of the filter with a
//! large heading 1-sigma; the filter's GNSS updates refine it as the vehicle accelerates and
//! turns.

use super::aiding::{GnssPosition, GnssVelocity};
use super::states::InitialSigma;
use crate::{NavState, Position, Scalar, attitude};
use nalgebra::Vector3;

/// Longest interval between two fixes the start takes as consecutive [s]: a 0.5 Hz receiver's
/// (a position-differenced velocity over a 57 s outage, at a turn, once started the filter 54
/// deg off in heading with a 5 deg 1-sigma).
pub const MAX_FIX_INTERVAL_S: f64 = 2.0;

/// The start-in-motion thresholds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionAlignConfig<T: Scalar> {
    /// Horizontal speed above which the track gives the heading [m/s].
    pub min_speed_m_s: T,
    /// Largest GNSS acceleration of a quasi-static interval [m/s^2].
    pub max_accel_mps2: T,
    /// Sideslip allowance: the body's forward axis off the track, 1-sigma [rad].
    pub sideslip_rad: T,
    /// Accelerometer bias 1-sigma [m/s^2] (for the level's 1-sigma).
    pub accel_bias_mps2: T,
}

impl<T: Scalar> Default for MotionAlignConfig<T> {
    /// 5 m/s, 0.3 m/s^2, 3 deg, 0.02 m/s^2.
    fn default() -> Self {
        Self {
            min_speed_m_s: T::c(5.0),
            max_accel_mps2: T::c(0.3),
            sideslip_rad: T::c(3f64.to_radians()),
            accel_bias_mps2: T::c(0.02),
        }
    }
}

/// The filter's start found by [`MotionAlign`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionStart<T: Scalar> {
    /// The IMU's state at the fix (position from the antenna's less the lever arm).
    pub state: NavState<T>,
    /// Its 1-sigma (biases and scale factors left at zero: the caller's noise model).
    pub sigma: InitialSigma<T>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Fix<T: Scalar> {
    t_s: f64,
    pos: GnssPosition<T>,
    vel: Option<GnssVelocity<T>>,
}

/// The in-motion start (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionAlign<T: Scalar> {
    config: MotionAlignConfig<T>,
    lever_arm_b_m: Vector3<T>,
    sum_dv: Vector3<T>,
    sum_dt: T,
    last: Option<Fix<T>>,
    last_velocity: Option<(Vector3<T>, T)>,
    /// Roll, pitch [rad] and their 1-sigma [rad].
    level: Option<(T, T, T)>,
}

impl<T: Scalar> MotionAlign<T> {
    /// Nothing seen yet; `lever_arm_b_m` is the antenna's position from the IMU (body FRD) [m].
    pub fn new(config: MotionAlignConfig<T>, lever_arm_b_m: Vector3<T>) -> Self {
        Self {
            config,
            lever_arm_b_m,
            sum_dv: Vector3::zeros(),
            sum_dt: T::zero(),
            last: None,
            last_velocity: None,
            level: None,
        }
    }

    /// Adds one IMU increment (compensated): its velocity increment [m/s] over `dt` [s].
    pub fn add_imu(&mut self, delta_v_ib_b: &Vector3<T>, dt: T) {
        if delta_v_ib_b.iter().all(|v| v.finite()) && dt.finite() && dt > T::zero() {
            self.sum_dv += delta_v_ib_b;
            self.sum_dt += dt;
        }
    }

    /// Whether the level has been found.
    pub fn has_level(&self) -> bool {
        self.level.is_some()
    }

    /// Adds a fix at time `t_s` [s]; returns the start once level and heading are known.
    pub fn add_fix(
        &mut self,
        t_s: f64,
        pos: &GnssPosition<T>,
        vel: Option<&GnssVelocity<T>>,
    ) -> Option<MotionStart<T>> {
        if !pos.is_valid() || !t_s.is_finite() {
            return None;
        }
        let vel = vel.filter(|v| v.is_valid()).copied();
        let fix = Fix {
            t_s,
            pos: *pos,
            vel,
        };
        let prev = self.last.replace(fix);
        let (f_mean, interval) = (self.sum_dv, self.sum_dt);
        self.sum_dv = Vector3::zeros();
        self.sum_dt = T::zero();
        let prev = prev?;
        let dt = T::c(t_s - prev.t_s);
        if !(dt > T::zero()) {
            return None;
        }
        if t_s - prev.t_s > MAX_FIX_INTERVAL_S {
            // An outage: what was known before it is stale (module docs).
            self.last_velocity = None;
            self.level = None;
            return None;
        }
        // Velocity at this fix and its 1-sigma (RMS over the axes).
        let (v, sv) = match vel {
            Some(v) => (
                v.v_ned_m_s,
                v.sigma_ned_m_s.norm() / T::c(1.732_050_807_568_877_2),
            ),
            None => {
                let a = Position::from_radians(prev.pos.lat_rad, prev.pos.lon_rad, prev.pos.h_m);
                let b = Position::from_radians(pos.lat_rad, pos.lon_rad, pos.h_m);
                let d = a.ned_to(&b);
                let s = (pos.sigma_ned_m.norm_squared() + prev.pos.sigma_ned_m.norm_squared())
                    .sqrt()
                    / T::c(1.732_050_807_568_877_2);
                (
                    Vector3::new(T::c(d[0]), T::c(d[1]), T::c(d[2])) / dt,
                    s / dt,
                )
            }
        };
        // Level over a quasi-static interval (the specific force of the IMU samples between
        // the two fixes against the GNSS acceleration over them).
        if let Some((v_prev, _)) = self.last_velocity
            && interval > T::zero()
        {
            let accel = (v - v_prev) / dt;
            let c = &self.config;
            if accel.norm() <= c.max_accel_mps2 {
                let f = f_mean / interval;
                let g = f.norm();
                let roll = (-f.y).patan2(-f.z);
                let pitch = f.x.patan2((f.y * f.y + f.z * f.z).sqrt());
                let sigma = (c.max_accel_mps2 + c.accel_bias_mps2) / g;
                self.level = Some((roll, pitch, sigma));
            }
        }
        self.last_velocity = Some((v, sv));
        let (roll, pitch, tilt_sigma) = self.level?;
        let speed = (v.x * v.x + v.y * v.y).sqrt();
        if !(speed >= self.config.min_speed_m_s) {
            return None;
        }
        let yaw = v.y.patan2(v.x);
        let yaw_sigma = ((sv / speed) * (sv / speed)
            + self.config.sideslip_rad * self.config.sideslip_rad)
            .sqrt();
        let q_b_n = attitude::from_euler(roll, pitch, yaw);
        let l_n = q_b_n * self.lever_arm_b_m;
        let antenna = Position::from_radians(pos.lat_rad, pos.lon_rad, pos.h_m);
        let position = antenna.offset_ned([-l_n.x.to_f64(), -l_n.y.to_f64(), -l_n.z.to_f64()]);
        // The lever arm's position error from the attitude's: |l| times the tilt / heading
        // 1-sigma, added in quadrature.
        let l = self.lever_arm_b_m.norm();
        let ang = tilt_sigma.max(yaw_sigma);
        let pos_sigma = pos.sigma_ned_m.map(|s| (s * s + l * l * ang * ang).sqrt());
        Some(MotionStart {
            state: NavState {
                q_b_n,
                v_eb_n: v,
                position,
            },
            sigma: InitialSigma {
                position_ned_m: pos_sigma,
                velocity_ned_m_s: Vector3::repeat(sv),
                attitude_rad: Vector3::new(tilt_sigma, tilt_sigma, yaw_sigma),
                gyro_bias_rad_s: Vector3::zeros(),
                accel_bias_mps2: Vector3::zeros(),
                gyro_scale: Vector3::zeros(),
                accel_scale: Vector3::zeros(),
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fix(north_m: f64, east_m: f64) -> GnssPosition<f64> {
        let p = Position::from_degrees(45.0, 7.5, 250.0).offset_ned([north_m, east_m, 0.0]);
        GnssPosition {
            lat_rad: p.lat_f64(),
            lon_rad: p.lon_f64(),
            h_m: p.h_f64(),
            sigma_ned_m: Vector3::repeat(0.5),
        }
    }

    /// Level at rest, then `dt_s` later a fix 14 m/s east on average: a start at once when the
    /// fixes are consecutive, none across an outage (its mean velocity is not the velocity at
    /// the fix, and the vehicle may have turned and climbed meanwhile).
    fn start_after(dt_s: f64) -> Option<MotionStart<f64>> {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let still = GnssVelocity {
            v_ned_m_s: Vector3::zeros(),
            sigma_ned_m_s: Vector3::repeat(0.05),
        };
        for k in 0..3 {
            m.add_imu(&Vector3::new(0.0, 0.0, -9.8 * 0.01), 0.01);
            assert!(
                m.add_fix(f64::from(k), &fix(0.0, 0.0), Some(&still))
                    .is_none()
            );
        }
        assert!(m.has_level());
        m.add_imu(&Vector3::new(0.0, 0.0, -9.8 * dt_s), dt_s);
        m.add_fix(2.0 + dt_s, &fix(0.0, 14.0 * dt_s), None)
    }

    #[test]
    fn an_outage_is_not_an_interval() {
        let s = start_after(1.0).expect("consecutive fixes start");
        assert!(
            (s.state.v_eb_n.y - 14.0).abs() < 0.1,
            "{:?}",
            s.state.v_eb_n
        );
        assert!(start_after(MAX_FIX_INTERVAL_S).is_some());
        assert_eq!(start_after(57.0), None);
    }
}
