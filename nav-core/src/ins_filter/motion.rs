//! Starting in motion from GNSS, for IMUs that cannot find north by gyrocompassing (MEMS).
//!
//! - Level: over a span of fixes in which the body turns at a mean rate below
//!   [`MAX_SPAN_RATE_RAD_S`] and the span's mean GNSS acceleration, its RMS with the noise of
//!   the velocities it is differenced from, is within [`MotionAlignConfig::max_accel_mps2`]
//!   (quasi-static: the mean specific force is gravity), roll and pitch from the mean specific
//!   force (Groves eq. 5.101); their 1-sigma is the acceleration bound plus the accelerometer
//!   bias over `g` (the mean specific force is the mean acceleration less gravity: a mean
//!   horizontal acceleration `a` tilts the level by `a / g`; the bound, not the RMS, also
//!   covers the body's pitching within the span). The span grows fix by fix until its mean
//!   acceleration is known well enough: one interval with the receiver's velocity (0.05 m/s),
//!   a few seconds with velocities differenced from 0.5 m positions (0.7 m/s each: over one
//!   second their difference is 1 m/s^2 of noise, and a single interval never showed a
//!   vehicle standing still as quasi-static). A span that turns, accelerates beyond doubt
//!   (three sigma), or passes [`MAX_SPAN_S`] starts again at its last fix.
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
use crate::{ImuIncrement, NavState, Position, Scalar, attitude};
use nalgebra::Vector3;

/// Longest interval between two fixes the start takes as consecutive [s]: a 0.5 Hz receiver's
/// (a position-differenced velocity over a 57 s outage, at a turn, once started the filter 54
/// deg off in heading with a 5 deg 1-sigma).
pub const MAX_FIX_INTERVAL_S: f64 = 2.0;

/// Longest span of fixes the level is taken over [s].
pub const MAX_SPAN_S: f64 = 30.0;

/// Largest mean rate of the body over a span the level is taken over [rad/s] (5 deg/s): the
/// mean of the rotation increments (their vector sum over the span's length, so that the
/// gyros' noise averages out and a consumer part's uncompensated bias of a few deg/s passes).
/// What it excludes is a span the GNSS cannot: a vehicle circling back to its velocity
/// within [`MAX_SPAN_S`] (at 12 deg/s or more), whose mean specific force holds its
/// centripetal acceleration (10 deg of roll at 5 m/s on a 15 m radius). A turn slower than
/// that changes the GNSS velocity over the span beyond the acceleration bound.
pub const MAX_SPAN_RATE_RAD_S: f64 = 0.087;

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

/// The IMU and GNSS since the fix a span of the level starts at.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Span<T: Scalar> {
    /// Time of its first fix [s].
    t0_s: f64,
    /// Velocity at its first fix [m/s] and its 1-sigma [m/s].
    v0: (Vector3<T>, T),
    /// Sum of the velocity increments since [m/s] and of their intervals [s].
    sum_dv: Vector3<T>,
    sum_dt: T,
    /// Sum of the rotation increments since [rad].
    turn_rad: Vector3<T>,
}

impl<T: Scalar> Span<T> {
    fn at(t0_s: f64, v0: (Vector3<T>, T)) -> Self {
        Self {
            t0_s,
            v0,
            sum_dv: Vector3::zeros(),
            sum_dt: T::zero(),
            turn_rad: Vector3::zeros(),
        }
    }
}

/// The in-motion start (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionAlign<T: Scalar> {
    config: MotionAlignConfig<T>,
    lever_arm_b_m: Vector3<T>,
    last: Option<Fix<T>>,
    /// The span the level is sought over, from the last fix whose velocity is known.
    span: Option<Span<T>>,
    /// Roll, pitch [rad] and their 1-sigma [rad].
    level: Option<(T, T, T)>,
}

impl<T: Scalar> MotionAlign<T> {
    /// Nothing seen yet; `lever_arm_b_m` is the antenna's position from the IMU (body FRD) [m].
    pub fn new(config: MotionAlignConfig<T>, lever_arm_b_m: Vector3<T>) -> Self {
        Self {
            config,
            lever_arm_b_m,
            last: None,
            span: None,
            level: None,
        }
    }

    /// Adds one IMU increment (compensated).
    pub fn add_imu(&mut self, inc: &ImuIncrement<T>) {
        let finite = inc
            .delta_v_ib_b
            .iter()
            .chain(inc.delta_theta_ib_b.iter())
            .all(|v| v.finite());
        if let Some(span) = &mut self.span
            && finite
            && inc.dt.finite()
            && inc.dt > T::zero()
        {
            span.sum_dv += inc.delta_v_ib_b;
            span.sum_dt += inc.dt;
            span.turn_rad += inc.delta_theta_ib_b;
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
        let prev = prev?;
        let dt = T::c(t_s - prev.t_s);
        if !(dt > T::zero()) {
            return None;
        }
        if t_s - prev.t_s > MAX_FIX_INTERVAL_S {
            // An outage: what was known before it is stale (module docs).
            self.span = None;
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
        self.level_over_span(t_s, v, sv);
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

impl<T: Scalar> MotionAlign<T> {
    /// The span's test at a fix of velocity `v` [m/s] (1-sigma `sv` [m/s]) at `t_s` [s]
    /// (module docs): the level when the span was quasi-static; a new span from this fix when
    /// it turned, accelerated beyond doubt or grew too long.
    fn level_over_span(&mut self, t_s: f64, v: Vector3<T>, sv: T) {
        let here = Span::at(t_s, (v, sv));
        let Some(span) = self.span.replace(here) else {
            return;
        };
        let c = &self.config;
        let length_s = t_s - span.t0_s;
        if !(span.sum_dt > T::zero())
            || span.turn_rad.norm() > T::c(MAX_SPAN_RATE_RAD_S) * span.sum_dt
        {
            return;
        }
        let t = T::c(length_s);
        let (v0, sv0) = span.v0;
        let accel = (v - v0).norm() / t;
        let accel_sigma = (sv * sv + sv0 * sv0).sqrt() / t;
        // The span's mean acceleration, as the GNSS knows it: its RMS with the noise.
        let accel_rms = (accel * accel + accel_sigma * accel_sigma).sqrt();
        if accel_rms <= c.max_accel_mps2 {
            let f = span.sum_dv / span.sum_dt;
            let g = f.norm();
            let roll = (-f.y).patan2(-f.z);
            let pitch = f.x.patan2((f.y * f.y + f.z * f.z).sqrt());
            let sigma = (c.max_accel_mps2 + c.accel_bias_mps2) / g;
            self.level = Some((roll, pitch, sigma));
            return;
        }
        // Undecided: the span goes on (it is not quasi-static beyond doubt, nor too long).
        let accelerating = accel > c.max_accel_mps2 + T::c(3.0) * accel_sigma;
        if !accelerating && length_s < MAX_SPAN_S {
            self.span = Some(span);
        }
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

    /// The increment of a level body at rest over `dt_s` [s].
    fn still_for(dt_s: f64) -> ImuIncrement<f64> {
        ImuIncrement::new([0.0; 3], [0.0, 0.0, -9.8 * dt_s], dt_s)
    }

    /// A fixed draw of noise in [-1, 1] per fix and axis (a small LCG).
    fn noise(k: u64, axis: u64) -> f64 {
        let x = (k * 3 + axis + 1).wrapping_mul(6_364_136_223_846_793_005);
        let x = x.wrapping_add(1_442_695_040_888_963_407) >> 11;
        (x as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    /// Fixes of positions alone, 0.5 m of noise at 1 Hz, a car standing still for
    /// `still_s` seconds pitched up by 2 deg, then driving east at 10 m/s: the velocities
    /// differenced from the positions are noisy to 0.7 m/s, and one interval never told a
    /// car standing still from one accelerating at 1 m/s^2. The span finds it level at rest.
    fn start_on_positions(still_s: u32) -> Option<MotionStart<f64>> {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let pitch = 2f64.to_radians();
        let f_b = [9.8 * pitch.sin(), 0.0, -9.8 * pitch.cos()];
        for k in 0..u64::from(still_s) + 5 {
            let moving_s = (k as f64 - f64::from(still_s)).max(0.0);
            m.add_imu(&ImuIncrement::new([0.0; 3], f_b, 1.0));
            let at = fix(0.5 * noise(k, 0), 10.0 * moving_s + 0.5 * noise(k, 1));
            if let Some(s) = m.add_fix(k as f64, &at, None) {
                return Some(s);
            }
        }
        None
    }

    #[test]
    fn a_car_standing_still_is_level_on_positions_alone() {
        let s = start_on_positions(20).expect("a start once the car moves");
        let (roll, pitch, yaw) = s.state.euler();
        assert!(roll.abs() < 1e-9 && (pitch.to_degrees() - 2.0).abs() < 1e-9);
        assert!(
            (yaw.to_degrees() - 90.0).abs() < 15.0,
            "{}",
            yaw.to_degrees()
        );
        // Two seconds still are not enough to tell it from a car accelerating.
        assert_eq!(start_on_positions(2), None);
    }

    /// A car accelerating at 0.6 m/s^2 (its specific force tilted by 3.5 deg against gravity)
    /// with exact velocities is never taken as quasi-static, however long the span.
    #[test]
    fn an_accelerating_car_is_not_level() {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let a = 0.6;
        for k in 0..40 {
            m.add_imu(&ImuIncrement::new([0.0; 3], [a, 0.0, -9.8], 1.0));
            let v = GnssVelocity {
                v_ned_m_s: Vector3::new(a * f64::from(k), 0.0, 0.0),
                sigma_ned_m_s: Vector3::repeat(0.05),
            };
            let p = fix(0.5 * a * f64::from(k * k), 0.0);
            assert_eq!(m.add_fix(f64::from(k), &p, Some(&v)), None);
        }
        assert!(!m.has_level());
    }

    /// A span over which the body turns at 6 deg/s is not levelled (a vehicle circling back
    /// to its velocity: its mean specific force holds the centripetal acceleration), even
    /// when the fixes say its velocity did not change.
    #[test]
    fn a_turning_span_is_not_level() {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let still = GnssVelocity {
            v_ned_m_s: Vector3::zeros(),
            sigma_ned_m_s: Vector3::repeat(0.05),
        };
        for k in 0..10 {
            m.add_imu(&ImuIncrement::new([0.0, 0.0, 0.1], [0.0, 0.0, -9.8], 1.0));
            assert_eq!(m.add_fix(f64::from(k), &fix(0.0, 0.0), Some(&still)), None);
        }
        assert!(!m.has_level());
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
            m.add_imu(&still_for(0.01));
            assert!(
                m.add_fix(f64::from(k), &fix(0.0, 0.0), Some(&still))
                    .is_none()
            );
        }
        assert!(m.has_level());
        m.add_imu(&still_for(dt_s));
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
