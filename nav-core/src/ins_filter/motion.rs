//! Starting in motion from GNSS, for IMUs that cannot find north by gyrocompassing (MEMS).
//!
//! - Level: over a span of fixes in which the body turns at a mean rate below
//!   [`MAX_SPAN_RATE_RAD_S`] and the span's mean GNSS acceleration, its RMS with the noise of
//!   the velocities it is differenced from, is within [`MotionAlignConfig::max_accel_mps2`]
//!   (quasi-static: the mean specific force is gravity), roll and pitch from the mean specific
//!   force (Groves eq. 5.101); their 1-sigma is the acceleration bound and the accelerometer
//!   bias over `g`, in quadrature (the mean specific force is the mean acceleration less
//!   gravity: a mean horizontal acceleration `a` tilts the level by `a / g`; the bound, not the
//!   RMS, also covers the body's pitching within the span), and the RMS angle of the specific
//!   force's direction over [`LEVEL_BLOCK_S`] blocks about its mean: the level holds at the
//!   span's last fix, where a rolling boat's body may be tilted from its mean by the roll's
//!   amplitude (a boat rolling 5 deg was levelled 8.5 deg off with a 1.8 deg 1-sigma). The
//!   bias's share is the bias error's own: the filter starts with the tilt correlated with it
//!   ([`super::AidedIns::level_on_accelerometers`]). From its fix on, the gyros carry the
//!   level to the fix the filter starts at (the mean rate at rest taken out when known), its
//!   1-sigma growing by the bias left and the angle random walk. The span grows fix by fix
//!   until its mean acceleration is known well enough: one interval with the receiver's
//!   velocity (0.05 m/s); without it, from the least-squares fit of all the span's positions
//!   ([`SpanFit`]: a few seconds with 0.5 m positions, about 8 s with 2 m ones at 10 Hz, where
//!   the difference of two velocities differenced a second apart is 4 m/s^2 of noise and
//!   needed half a minute still). A span that turns, accelerates beyond doubt
//!   (three sigma), or passes [`MAX_SPAN_S`] starts again at its last fix.
//! - Gyro bias: while the level spans find the vehicle standing still (the antenna moved by
//!   no more than three times the fixes' noise and [`REST_DISPLACEMENT_M`]), their rotation
//!   increments are summed; after [`MIN_REST_S`] their mean rate, less the Earth rate's
//!   vertical part, is the gyro bias, 1-sigma from the angle random walk, a rocking of
//!   [`REST_ROCKING_RAD`] over the time summed and the Earth rate's horizontal part (the
//!   heading is not known yet). A consumer part's turn-on bias of a degree per second,
//!   unknown at the start, turned the heading by tens of degrees before the fixes found it,
//!   and the filter linearised about that took false information on the roll. A body that
//!   turns in place while its antenna stands still (a turntable) is outside this model.
//! - Heading: once the horizontal speed exceeds [`MotionAlignConfig::min_speed_m_s`] and
//!   [`MIN_SPEED_SIGMAS`] times its noise, the ground track `atan2(v_E, v_N)` (a land vehicle
//!   moves along its forward axis); 1-sigma from the velocity's 1-sigma over the speed and the
//!   sideslip allowance. The forward axis is taken against the track when the body moves
//!   backwards: since the level was found, the fixes' speed grew beyond three sigma while the
//!   accelerometers (levelled) felt the forward velocity fall beyond three sigma of the level's
//!   and the bias's error (a car that reversed out of a parking space was started 179 deg off
//!   with a 3 deg 1-sigma); or since the anchor (a stop's last fix, or the slowest fix since;
//!   within [`MAX_SPAN_S`]), the IMU's velocity change, levelled now and turned by the
//!   track's heading, points against the fixes' velocity change, that change beyond 2.5 sigma
//!   of both (a car that reversed to 7 m/s before the level was found, at constant speed, was
//!   started 180 deg off with a 3 deg 1-sigma). The gyros carry the anchor's axes to the
//!   body's now; the error grows with the tilt's, the accelerometer bias's and the gyro
//!   bias's share of gravity's sum: a consumer part's level (2.5 deg) does not tell a
//!   reversal at 1-2 m/s^2 within a few seconds. Otherwise the body is taken to move
//!   forwards.
//! - Velocity: the GNSS velocity, or the difference of two positions at least
//!   [`MIN_DIFFERENCE_INTERVAL_S`] apart (a 10 Hz receiver's consecutive positions, 0.5 m
//!   each, differ by 7 m/s of noise: no span of 30 s was quasi-static beyond that doubt, and
//!   the start never came), less
//!   the antenna's lever-arm velocity `C_b_n (omega_ib_b x l_b)` (Groves eq. 14.134, Earth rate
//!   neglected), the body rate from the gyros (the last increment for a receiver's velocity, the
//!   mean over the interval for a differenced one): a car body rocking at 1 Hz turns at tens of
//!   deg/s, which moves an antenna 2 m away by decimetres per second against the receiver's
//!   centimetres. Its 1-sigma adds the lever arm times the gyro bias and `|omega x l|` times
//!   the attitude's 1-sigma.
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

use super::FilterConfig;
use super::aiding::{GnssPosition, GnssVelocity};
use super::span_fit::SpanFit;
use super::states::InitialSigma;
use crate::earth::LocalEarth;
use crate::{ImuIncrement, NavState, Position, Scalar, attitude};
use nalgebra::{UnitQuaternion, Vector3};

/// Longest interval between two fixes the start takes as consecutive [s]: a 0.5 Hz receiver's
/// (a position-differenced velocity over a 57 s outage, at a turn, once started the filter 54
/// deg off in heading with a 5 deg 1-sigma).
pub const MAX_FIX_INTERVAL_S: f64 = 2.0;

/// Shortest interval two positions are differenced over for a velocity [s] (a 1 Hz
/// receiver's, its time tags' jitter allowed): the velocity's noise falls as the interval
/// grows, its lag behind the fix (half the interval) grows with it.
pub const MIN_DIFFERENCE_INTERVAL_S: f64 = 0.95;

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

/// Length of the blocks whose mean specific force's direction measures the body's tilt
/// about its mean over a level span [s] (module docs).
pub const LEVEL_BLOCK_S: f64 = 0.1;

/// Fewest 1-sigma of the horizontal velocity (per axis) the speed must reach for the track to
/// give the heading. A vehicle standing still with 2 m fixes differenced over a second shows
/// 2.8 m/s of noise per axis, and crossed a 5 m/s threshold within seconds: its heading was
/// the noise's, 150 deg off with a 30 deg 1-sigma. The speed of a still vehicle is Rayleigh
/// distributed: beyond 4 sigma with a chance of `exp(-8)` (3e-4) per fix.
pub const MIN_SPEED_SIGMAS: f64 = 4.0;

/// Shortest time at rest the gyro bias is taken over [s].
pub const MIN_REST_S: f64 = 10.0;

/// Largest net rotation of a vehicle standing still over the time its gyro bias is taken
/// over [rad] (1 deg: a parked car rocked by its passengers, a ship at anchor); divided by that
/// time, a share of the bias's 1-sigma.
pub const REST_ROCKING_RAD: f64 = 0.017_453_292_519_943_295;

/// Largest horizontal displacement of a span that stood still [m], beyond three times the
/// two fixes' noise (a parked car moves by centimetres; one creeping at 0.1 m/s moves 1 m in
/// 10 s).
pub const REST_DISPLACEMENT_M: f64 = 0.3;

/// True when the antenna moved between the fixes `a` and `b` by no more horizontally than
/// their noise (three times it) and [`REST_DISPLACEMENT_M`] allow: the vehicle stood still
/// (module docs).
fn stood_still<T: Scalar>(a: &GnssPosition<T>, b: &GnssPosition<T>) -> bool {
    let pa = Position::from_radians(a.lat_rad, a.lon_rad, a.h_m);
    let pb = Position::from_radians(b.lat_rad, b.lon_rad, b.h_m);
    let d = pa.ned_to(&pb);
    let horizontal = (T::c(d[0]) * T::c(d[0]) + T::c(d[1]) * T::c(d[1])).sqrt();
    let noise = |p: &GnssPosition<T>| p.sigma_ned_m.fixed_rows::<2>(0).norm_squared();
    horizontal <= T::c(3.0) * (noise(a) + noise(b)).sqrt() + T::c(REST_DISPLACEMENT_M)
}

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
    /// Gyro bias 1-sigma [rad/s] (for the lever-arm velocity's 1-sigma).
    pub gyro_bias_rad_s: T,
    /// Angle random walk [rad/sqrt(s)] (the noise of the gyro bias found at rest).
    pub arw_rad_per_sqrt_s: T,
}

impl<T: Scalar> Default for MotionAlignConfig<T> {
    /// 5 m/s, 0.3 m/s^2, 3 deg, 0.02 m/s^2, 0.5 deg/s (a consumer part's turn-on bias),
    /// 0.17 deg/sqrt(h) (its angle random walk).
    fn default() -> Self {
        Self {
            min_speed_m_s: T::c(5.0),
            max_accel_mps2: T::c(0.3),
            sideslip_rad: T::c(3f64.to_radians()),
            accel_bias_mps2: T::c(0.02),
            gyro_bias_rad_s: T::c(0.5f64.to_radians()),
            arw_rad_per_sqrt_s: T::c(0.17f64.to_radians() / 60.0),
        }
    }
}

impl<T: Scalar> MotionAlignConfig<T> {
    /// The settings of a re-alignment in motion of a run that did not start in motion (a
    /// given start's, the navigator's alignment at rest): the defaults, with `config`'s
    /// angle random walk and its start accelerometer bias 1-sigma when larger.
    pub fn for_realignment(config: &FilterConfig<T>) -> Self {
        let d = Self::default();
        Self {
            accel_bias_mps2: d
                .accel_bias_mps2
                .max(config.start_sensor_sigma().accel_bias_mps2.max()),
            arw_rad_per_sqrt_s: config.noise.arw_rad_per_sqrt_s,
            ..d
        }
    }
}

/// The filter's start found by [`MotionAlign`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionStart<T: Scalar> {
    /// The IMU's state at the fix (position from the antenna's less the lever arm).
    pub state: NavState<T>,
    /// Its 1-sigma (biases and scale factors left at zero: the configuration's start ones,
    /// [`FilterConfig::start_sensor_sigma`]).
    pub sigma: InitialSigma<T>,
    /// 1-sigma of the level span's mean acceleration per axis [m/s^2]: the level's error
    /// besides the accelerometer bias's ([`super::AidedIns::level_on_accelerometers`]).
    pub level_acceleration_mps2: T,
    /// The gyro bias found while the vehicle stood still, and its 1-sigma per axis [rad/s]
    /// (module docs); `None` when it never stood still long enough.
    pub gyro_bias_at_rest: Option<(Vector3<T>, Vector3<T>)>,
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
    /// Its first fix's position.
    p0: GnssPosition<T>,
    /// Velocity at its first fix [m/s] and its 1-sigma [m/s].
    v0: (Vector3<T>, T),
    /// Sum of the velocity increments since [m/s] and of their intervals [s].
    sum_dv: Vector3<T>,
    sum_dt: T,
    /// Sum of the rotation increments since [rad].
    turn_rad: Vector3<T>,
    /// Its positions, fitted (receivers without velocity).
    fit: SpanFit,
    /// Sum of the directions of the specific force over blocks of [`LEVEL_BLOCK_S`], and
    /// their number.
    sum_dir: Vector3<T>,
    blocks: u32,
}

impl<T: Scalar> Span<T> {
    fn at(t0_s: f64, p0: GnssPosition<T>, v0: (Vector3<T>, T)) -> Self {
        Self {
            t0_s,
            p0,
            v0,
            sum_dv: Vector3::zeros(),
            sum_dt: T::zero(),
            turn_rad: Vector3::zeros(),
            fit: SpanFit::new(t0_s, &p0),
            sum_dir: Vector3::zeros(),
            blocks: 0,
        }
    }
}

/// The in-motion start (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionAlign<T: Scalar> {
    config: MotionAlignConfig<T>,
    lever_arm_b_m: Vector3<T>,
    last: Option<Fix<T>>,
    /// The fix the next position-differenced velocity starts from.
    base: Option<Fix<T>>,
    /// The span the level is sought over, from the last fix whose velocity is known.
    span: Option<Span<T>>,
    /// Roll, pitch [rad] and their 1-sigma [rad].
    level: Option<(T, T, T)>,
    /// Body rate of the last increment [rad/s].
    rate_ib_b_rad_s: Vector3<T>,
    /// Sum of the rotation increments [rad] and of their intervals [s] since `base`.
    turn_since_fix_rad: Vector3<T>,
    dt_since_fix_s: T,
    /// Sum of the velocity increments since `base` [m/s].
    dv_since_fix_b: Vector3<T>,
    /// The rotation increments [rad] and their intervals [s] summed over the consecutive
    /// level spans the vehicle stood still in (module docs).
    rest: Option<(Vector3<T>, T)>,
    /// The velocity increments [m/s] and their intervals [s] summed into the block of
    /// [`LEVEL_BLOCK_S`] being filled.
    block: (Vector3<T>, T),
    /// What the IMU and the fixes saw since the level was last found (the direction of
    /// travel, module docs).
    since_level: Option<SinceLevel<T>>,
    /// What the IMU felt since the anchor fix (the direction of travel, module docs).
    since_anchor: Option<SinceAnchor<T>>,
    /// The level carried by the gyros from the fix it was found at (module docs).
    level_track: Option<LevelTrack<T>>,
}

/// The IMU's velocity change since a fix (the anchor, module docs), in that fix's body axes,
/// for the direction of travel.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SinceAnchor<T: Scalar> {
    /// Its fix's time [s], GNSS velocity [m/s] and that velocity's 1-sigma per axis [m/s].
    t_s: f64,
    v_ned_m_s: Vector3<T>,
    v_sigma_m_s: T,
    /// The body's attitude now from its attitude at the anchor (the gyros, less `bias_rad_s`).
    q_a_b: UnitQuaternion<T>,
    /// Sum of the velocity increments since, in the anchor's body axes [m/s], and of their
    /// intervals [s].
    sum_dv_a: Vector3<T>,
    sum_dt: T,
    /// The gyro bias taken out [rad/s], and the 1-sigma of what is left of it [rad/s].
    bias_rad_s: Vector3<T>,
    bias_sigma_rad_s: T,
}

/// The level found at a fix, carried to the later fixes by the gyros.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LevelTrack<T: Scalar> {
    /// The body's attitude from a level frame whose heading is its own at the fix.
    q_b_l: UnitQuaternion<T>,
    /// Time carried [s].
    dt: T,
    /// The gyro bias taken out [rad/s], and the 1-sigma of what is left of it [rad/s].
    bias_rad_s: Vector3<T>,
    bias_sigma_rad_s: T,
}

/// The body's travel since the level was found.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SinceLevel<T: Scalar> {
    /// Horizontal speed at the level's fix [m/s] and its 1-sigma [m/s].
    speed_m_s: T,
    speed_sigma_m_s: T,
    /// Sum of the velocity increments since [m/s], body axes, and of their intervals [s].
    sum_dv_b: Vector3<T>,
    sum_dt: T,
}

impl<T: Scalar> MotionAlign<T> {
    /// Nothing seen yet; `lever_arm_b_m` is the antenna's position from the IMU (body FRD) [m].
    pub fn new(config: MotionAlignConfig<T>, lever_arm_b_m: Vector3<T>) -> Self {
        Self {
            config,
            lever_arm_b_m,
            last: None,
            base: None,
            span: None,
            level: None,
            rate_ib_b_rad_s: Vector3::zeros(),
            turn_since_fix_rad: Vector3::zeros(),
            dt_since_fix_s: T::zero(),
            dv_since_fix_b: Vector3::zeros(),
            rest: None,
            block: (Vector3::zeros(), T::zero()),
            since_level: None,
            since_anchor: None,
            level_track: None,
        }
    }

    /// Adds one IMU increment (compensated).
    pub fn add_imu(&mut self, inc: &ImuIncrement<T>) {
        let finite = inc
            .delta_v_ib_b
            .iter()
            .chain(inc.delta_theta_ib_b.iter())
            .all(|v| v.finite());
        if !(finite && inc.dt.finite() && inc.dt > T::zero()) {
            return;
        }
        self.rate_ib_b_rad_s = inc.delta_theta_ib_b / inc.dt;
        self.turn_since_fix_rad += inc.delta_theta_ib_b;
        self.dt_since_fix_s += inc.dt;
        self.dv_since_fix_b += inc.delta_v_ib_b;
        if let Some(l) = &mut self.level_track {
            let turn = inc.delta_theta_ib_b - l.bias_rad_s * inc.dt;
            l.q_b_l *= attitude::rotation_vector_quat(&turn);
            l.dt += inc.dt;
        }
        if let Some(s) = &mut self.since_level {
            s.sum_dv_b += inc.delta_v_ib_b;
            s.sum_dt += inc.dt;
        }
        if let Some(a) = &mut self.since_anchor {
            a.sum_dv_a += a.q_a_b * inc.delta_v_ib_b;
            a.q_a_b *=
                attitude::rotation_vector_quat(&(inc.delta_theta_ib_b - a.bias_rad_s * inc.dt));
            a.sum_dt += inc.dt;
        }
        self.block.0 += inc.delta_v_ib_b;
        self.block.1 += inc.dt;
        let block_dir = (self.block.1 >= T::c(LEVEL_BLOCK_S)).then(|| {
            let dir = self.block.0 / self.block.0.norm();
            self.block = (Vector3::zeros(), T::zero());
            dir
        });
        if let Some(span) = &mut self.span {
            span.sum_dv += inc.delta_v_ib_b;
            span.sum_dt += inc.dt;
            span.turn_rad += inc.delta_theta_ib_b;
            if let Some(dir) = block_dir.filter(|d| d.iter().all(|x| x.finite())) {
                span.sum_dir += dir;
                span.blocks += 1;
            }
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
        // The body rate at this fix: the last increment's for a receiver's velocity, the mean
        // over the interval for a differenced one (module docs).
        let rate_ib_b = match vel {
            Some(_) => self.rate_ib_b_rad_s,
            None if self.dt_since_fix_s > T::zero() => {
                self.turn_since_fix_rad / self.dt_since_fix_s
            }
            None => self.rate_ib_b_rad_s,
        };
        // The mean specific force since the base fix (a differenced velocity's interval).
        let f_mean_b =
            (self.dt_since_fix_s > T::zero()).then(|| self.dv_since_fix_b / self.dt_since_fix_s);
        let fix = Fix {
            t_s,
            pos: *pos,
            vel,
        };
        let Some(prev) = self.last.replace(fix) else {
            self.restart_base(fix);
            return None;
        };
        if !(t_s - prev.t_s > 0.0) {
            return None;
        }
        if t_s - prev.t_s > MAX_FIX_INTERVAL_S {
            // An outage: what was known before it is stale (module docs).
            self.span = None;
            self.level = None;
            self.rest = None;
            self.since_level = None;
            self.since_anchor = None;
            self.level_track = None;
            self.restart_base(fix);
            return None;
        }
        if vel.is_none()
            && let Some(span) = &mut self.span
        {
            span.fit.add(t_s, pos);
        }
        let prev = match (vel, self.base) {
            (Some(_), _) => prev,
            (None, Some(base)) if t_s - base.t_s >= MIN_DIFFERENCE_INTERVAL_S => base,
            // Too close to the base for a velocity: the next fix may be.
            (None, Some(_)) => return None,
            (None, None) => {
                self.restart_base(fix);
                return None;
            }
        };
        self.restart_base(fix);
        let dt = T::c(t_s - prev.t_s);
        // Velocity and its 1-sigma per axis: the receiver's at this fix, or the mean over the
        // interval of a position difference.
        let (v, sv_ned) = match vel {
            Some(v) => (v.v_ned_m_s, v.sigma_ned_m_s),
            None => {
                let a = Position::from_radians(prev.pos.lat_rad, prev.pos.lon_rad, prev.pos.h_m);
                let b = Position::from_radians(pos.lat_rad, pos.lon_rad, pos.h_m);
                let d = a.ned_to(&b);
                let s = Vector3::from_fn(|k, _| {
                    (pos.sigma_ned_m[k] * pos.sigma_ned_m[k]
                        + prev.pos.sigma_ned_m[k] * prev.pos.sigma_ned_m[k])
                        .sqrt()
                        / dt
                });
                (Vector3::new(T::c(d[0]), T::c(d[1]), T::c(d[2])) / dt, s)
            }
        };
        // The span's test takes one 1-sigma, the RMS over the axes.
        let sv_rms = sv_ned.norm() / T::c(1.732_050_807_568_877_2);
        self.anchor_at(t_s, &v, sv_rms);
        self.level_over_span(
            t_s,
            pos,
            v,
            sv_ned.norm() / T::c(1.732_050_807_568_877_2),
            vel.is_none(),
        );
        let (roll, pitch, tilt_sigma) = self.carried_level()?;
        // A difference is the mean velocity over its interval, half an interval behind the fix:
        // carried to the fix by the IMU's mean acceleration `C_b_n f + g` times `dt / 2`
        // (attitude from the level and the track), whose error, the tilt's and the heading's
        // share of the specific force and the accelerometer bias, joins the 1-sigma.
        let (v, sv_ned) = match (vel, f_mean_b) {
            (None, Some(f_b)) => {
                let q0 = attitude::from_euler(roll, pitch, v.y.patan2(v.x));
                let g = crate::earth::normal_gravity(pos.lat_rad, pos.h_m);
                // The NED velocity's rate, `C_b_n f + g - (2 omega_ie + omega_en) x v`: near a
                // pole the NED frame turns the velocity by metres per second over half a
                // second (200 m/s 11 km from the North Pole's axis: 1.8 m/s, 4 sigma at the
                // start, before the frame's turn was in).
                let earth = LocalEarth::new(T::c(pos.lat_rad), T::c(pos.h_m));
                let turning = (earth.omega_ie_n() * T::c(2.0) + earth.omega_en_n(&v)).cross(&v);
                let a_n = q0 * f_b + Vector3::new(T::zero(), T::zero(), T::c(g)) - turning;
                let half = dt * T::c(0.5);
                let speed0 = (v.x * v.x + v.y * v.y).sqrt().max(T::c(1e-3));
                let yaw0_sigma = (sv_ned.x.max(sv_ned.y) / speed0).min(T::c(core::f64::consts::PI));
                let f_norm = f_b.norm();
                let a_sigma = ((f_norm * tilt_sigma).powi(2)
                    + (a_n.norm() * yaw0_sigma).powi(2)
                    + self.config.accel_bias_mps2 * self.config.accel_bias_mps2)
                    .sqrt();
                (
                    v + a_n * half,
                    sv_ned.map(|s| (s * s + (a_sigma * half).powi(2)).sqrt()),
                )
            }
            _ => (v, sv_ned),
        };
        let sv =
            (sv_ned.x * sv_ned.x + sv_ned.y * sv_ned.y).sqrt() / T::c(core::f64::consts::SQRT_2);
        // The antenna's lever-arm velocity in body axes; taken out in NED with the attitude
        // found from the track, twice: the track of the IMU's velocity, not the antenna's.
        let lever_v_b = rate_ib_b.cross(&self.lever_arm_b_m);
        // The body's forward axis along the track, or against it when reversing.
        let backwards = if self.reversing(roll, pitch, tilt_sigma, &v, sv)
            || self.reversed_since_anchor(roll, pitch, tilt_sigma, &v, sv)
        {
            T::c(core::f64::consts::PI)
        } else {
            T::zero()
        };
        let mut q_b_n = attitude::from_euler(roll, pitch, v.y.patan2(v.x) + backwards);
        for _ in 0..2 {
            let v_imu = v - q_b_n * lever_v_b;
            q_b_n = attitude::from_euler(roll, pitch, v_imu.y.patan2(v_imu.x) + backwards);
        }
        let v = v - q_b_n * lever_v_b;
        let speed = (v.x * v.x + v.y * v.y).sqrt();
        if !(speed >= self.config.min_speed_m_s && speed >= T::c(MIN_SPEED_SIGMAS) * sv) {
            return None;
        }
        let yaw_sigma = ((sv / speed) * (sv / speed)
            + self.config.sideslip_rad * self.config.sideslip_rad)
            .sqrt();
        // The lever-arm velocity's 1-sigma: the gyro bias's share and the attitude's.
        let lever_sigma_b = self.lever_arm_b_m.norm() * self.config.gyro_bias_rad_s;
        let lever_sigma_att = lever_v_b.norm() * tilt_sigma.max(yaw_sigma);
        let lever_sigma2 = lever_sigma_b * lever_sigma_b + lever_sigma_att * lever_sigma_att;
        let sv_ned = sv_ned.map(|s| (s * s + lever_sigma2).sqrt());
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
                velocity_ned_m_s: sv_ned,
                attitude_rad: Vector3::new(tilt_sigma, tilt_sigma, yaw_sigma),
                gyro_bias_rad_s: Vector3::zeros(),
                accel_bias_mps2: Vector3::zeros(),
                gyro_scale: Vector3::zeros(),
                accel_scale: Vector3::zeros(),
            },
            level_acceleration_mps2: self.config.max_accel_mps2,
            gyro_bias_at_rest: self.gyro_bias_at_rest(pos, roll, pitch),
        })
    }
}

impl<T: Scalar> MotionAlign<T> {
    /// The gyro bias from the rest spans (module docs): their mean rate less the Earth rate's
    /// vertical part in body axes (level `roll`, `pitch` [rad] at the fix `pos`), and its
    /// 1-sigma per axis: the angle random walk over the time summed, a body that rocks by
    /// [`REST_ROCKING_RAD`] over it, and the Earth rate's horizontal part (the heading is not
    /// known). `None` below [`MIN_REST_S`].
    fn gyro_bias_at_rest(
        &self,
        pos: &GnssPosition<T>,
        roll: T,
        pitch: T,
    ) -> Option<(Vector3<T>, Vector3<T>)> {
        let (rate, sigma) = self.mean_rate_at_rest()?;
        let w_ie_n = crate::earth::omega_ie_n(T::c(pos.lat_rad.to_f64()));
        let down_rate_n = Vector3::new(T::zero(), T::zero(), w_ie_n.z);
        let c_n_b = attitude::from_euler(roll, pitch, T::zero()).inverse();
        let bias = rate - c_n_b * down_rate_n;
        let earth = w_ie_n.x;
        Some((
            bias,
            Vector3::repeat((sigma * sigma + earth * earth).sqrt()),
        ))
    }

    /// The mean body rate over the rest spans [rad/s] (Earth rate in) and its 1-sigma per axis
    /// [rad/s]: the angle random walk over the time summed and a rocking of
    /// [`REST_ROCKING_RAD`] over it. `None` below [`MIN_REST_S`].
    fn mean_rate_at_rest(&self) -> Option<(Vector3<T>, T)> {
        let (turn, dt) = self.rest?;
        if !(dt >= T::c(MIN_REST_S)) {
            return None;
        }
        let arw = self.config.arw_rad_per_sqrt_s;
        let rock = T::c(REST_ROCKING_RAD) / dt;
        Some((turn / dt, (arw * arw / dt + rock * rock).sqrt()))
    }

    /// Roll, pitch [rad] and their 1-sigma [rad] now: the level found at a fix, carried on by
    /// the gyros (a rolling boat's level found 3 s before the fix that started it was 7.8 deg
    /// off at the start, 4 sigma), its 1-sigma grown by the gyro bias left and the angle
    /// random walk over the time carried.
    fn carried_level(&self) -> Option<(T, T, T)> {
        let (_, _, sigma) = self.level?;
        let l = self.level_track?;
        let (roll, pitch, _) = attitude::euler(&l.q_b_l);
        let arw = self.config.arw_rad_per_sqrt_s;
        let drift = l.bias_sigma_rad_s * l.dt;
        Some((
            roll,
            pitch,
            (sigma * sigma + drift * drift + arw * arw * l.dt).sqrt(),
        ))
    }

    /// True when the body moves backwards along its track (module docs): since the level, the
    /// fixes' speed `v` [m/s] (1-sigma `sv` [m/s] per axis) grew beyond doubt while the
    /// accelerometers, levelled by `roll`, `pitch` [rad] (1-sigma `tilt_sigma` [rad]), felt the
    /// body's forward velocity fall beyond doubt.
    fn reversing(&self, roll: T, pitch: T, tilt_sigma: T, v: &Vector3<T>, sv: T) -> bool {
        let Some(s) = &self.since_level else {
            return false;
        };
        let gain = (v.x * v.x + v.y * v.y).sqrt() - s.speed_m_s;
        let gain_sigma = (sv * sv + s.speed_sigma_m_s * s.speed_sigma_m_s).sqrt();
        let forward = (attitude::from_euler(roll, pitch, T::zero()) * s.sum_dv_b).x;
        let g = T::c(crate::earth::GAMMA_EQUATOR);
        let forward_sigma = ((g * tilt_sigma).powi(2)
            + self.config.accel_bias_mps2 * self.config.accel_bias_mps2)
            .sqrt()
            * s.sum_dt;
        gain > T::c(3.0) * gain_sigma && forward < T::c(-3.0) * forward_sigma
    }

    /// Takes the fix at `t_s` [s], of velocity `v` [m/s] (1-sigma `sv` [m/s] per axis), as
    /// the anchor of the direction test when it is slower than the anchor, or may stand still
    /// and is not faster than the anchor beyond their noise (the anchor is a stop's last fix,
    /// or the slowest since), or when the anchor is older than [`MAX_SPAN_S`] (module docs).
    fn anchor_at(&mut self, t_s: f64, v: &Vector3<T>, sv: T) {
        let speed = |v: &Vector3<T>| (v.x * v.x + v.y * v.y).sqrt();
        // A fix that may stand still (within 3 sigma of rest) and is not faster than the
        // anchor beyond their noise, or one slower than the anchor, takes its place.
        let keep = self.since_anchor.is_some_and(|a| {
            let sigma = (sv * sv + a.v_sigma_m_s * a.v_sigma_m_s).sqrt();
            let (now, then) = (speed(v), speed(&a.v_ned_m_s));
            let replaces = now < then || (now <= then + sigma && now <= T::c(3.0) * sv);
            t_s - a.t_s <= MAX_SPAN_S && !replaces
        });
        if keep || !(speed(v).finite() && sv.finite()) {
            return;
        }
        let (bias_rad_s, bias_sigma_rad_s) = self
            .mean_rate_at_rest()
            .unwrap_or((Vector3::zeros(), self.config.gyro_bias_rad_s));
        self.since_anchor = Some(SinceAnchor {
            t_s,
            v_ned_m_s: *v,
            v_sigma_m_s: sv,
            q_a_b: UnitQuaternion::identity(),
            sum_dv_a: Vector3::zeros(),
            sum_dt: T::zero(),
            bias_rad_s,
            bias_sigma_rad_s,
        });
    }

    /// Whether the body moves backwards along its track `v` [m/s] (1-sigma `sv` [m/s] per
    /// axis), judged from the anchor (module docs): the IMU's horizontal velocity change
    /// since, levelled by `roll`, `pitch` [rad] (1-sigma `tilt_sigma` [rad]) and turned by
    /// the track's heading, points against the fixes' velocity change, which is beyond 2.5
    /// sigma of both (a tactical car reversing to 3 m/s was 2.6 sigma of the IMU's doubt
    /// alone, 2.75 m/s against 1.05: a 3-sigma test on the IMU's change missed it).
    /// Integrated velocity vectors compared as in [Silson, 2011], with two headings to choose
    /// from. Waiting for an undecided IMU does not help: at a steady acceleration its change
    /// and its doubt grow alike (a wait of up to 10 s, tried, only delayed the starts of
    /// vehicles driving forwards).
    fn reversed_since_anchor(
        &self,
        roll: T,
        pitch: T,
        tilt_sigma: T,
        v: &Vector3<T>,
        sv: T,
    ) -> bool {
        let Some(a) = &self.since_anchor else {
            return false;
        };
        let t = a.sum_dt;
        // The IMU's velocity change in the level frame of the body's heading now: the specific
        // force's sum turned to the body now, levelled, plus gravity's `g t` down.
        let g = T::c(crate::earth::GAMMA_EQUATOR);
        let c_l_b = attitude::from_euler(roll, pitch, T::zero());
        let dv_l =
            c_l_b * (a.q_a_b.inverse() * a.sum_dv_a) + Vector3::new(T::zero(), T::zero(), g * t);
        // Its horizontal error: the tilt's and the accelerometer bias's, growing with `t`,
        // and the gyro bias's turn of gravity's sum, `g b t^2 / 2`, in quadrature.
        let turn = g * a.bias_sigma_rad_s * t * T::c(0.5);
        let imu_sigma = ((g * tilt_sigma).powi(2)
            + self.config.accel_bias_mps2 * self.config.accel_bias_mps2
            + turn * turn)
            .sqrt()
            * t;
        // The fixes' change and the IMU's turned to NED with the body facing along the track,
        // projected on the fixes' direction: about `+g` facing forwards, `-g` backwards.
        let gnss = v - a.v_ned_m_s;
        let g_h = (gnss.x * gnss.x + gnss.y * gnss.y).sqrt();
        let yaw = v.y.patan2(v.x);
        let (sy, cy) = (yaw.psin(), yaw.pcos());
        let along = ((cy * dv_l.x - sy * dv_l.y) * gnss.x + (sy * dv_l.x + cy * dv_l.y) * gnss.y)
            / g_h.max(T::c(1e-9));
        let gnss_sigma = (sv * sv + a.v_sigma_m_s * a.v_sigma_m_s).sqrt();
        let sigma = (imu_sigma * imu_sigma + gnss_sigma * gnss_sigma).sqrt();
        // The two hypotheses `2 g` apart, beyond 5 sigma (a forward body taken backwards with
        // a chance of 0.6 % at that bound), and the IMU's change within 3 sigma of backwards.
        g_h > T::c(2.5) * sigma && along < T::zero() && along + g_h < T::c(3.0) * sigma
    }

    /// `fix` the start of the next position difference.
    fn restart_base(&mut self, fix: Fix<T>) {
        self.base = Some(fix);
        self.turn_since_fix_rad = Vector3::zeros();
        self.dt_since_fix_s = T::zero();
        self.dv_since_fix_b = Vector3::zeros();
    }

    /// The span's test at a fix of velocity `v` [m/s] (1-sigma `sv` [m/s]) at `t_s` [s]
    /// (module docs): the level when the span was quasi-static; a new span from this fix when
    /// it turned, accelerated beyond doubt or grew too long. `positions_only`: the velocity was
    /// differenced from positions, and the span's mean acceleration is taken from the fit of
    /// all its positions once it has enough ([`SpanFit`]).
    fn level_over_span(
        &mut self,
        t_s: f64,
        pos: &GnssPosition<T>,
        v: Vector3<T>,
        sv: T,
        positions_only: bool,
    ) {
        let here = Span::at(t_s, *pos, (v, sv));
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
        // The mean acceleration the accelerometers feel (less gravity): the change of the NED
        // velocity plus the Coriolis and transport-rate terms, `(2 omega_ie + omega_en) x v`
        // (Groves eq. 5.54 rearranged). Near a pole the NED frame turns at `v_E tan(lat) /
        // (R_E + h)`: a body circling the North Pole 11 km from it at 200 m/s keeps its NED
        // velocity while it accelerates at 3.6 m/s^2 (20 deg of bank), and was levelled 20 deg
        // off with a 1.8 deg 1-sigma. Not finite at the pole itself: no level there.
        let earth = LocalEarth::new(
            T::c(0.5 * (span.p0.lat_rad + pos.lat_rad)),
            T::c(0.5 * (span.p0.h_m + pos.h_m)),
        );
        let v_mid = (v + v0) * T::c(0.5);
        let turning = (earth.omega_ie_n() * T::c(2.0) + earth.omega_en_n(&v_mid)).cross(&v_mid);
        let fitted = span.fit.acceleration(t_s).filter(|_| positions_only);
        let (accel, accel_sigma) = match fitted {
            // The fit's horizontal acceleration and its Coriolis term, and the RMS of their
            // two axes' 1-sigma.
            Some(a) => {
                let [n, e] = [0, 1].map(|k| a.accel_m_s2[k] + a.coriolis_m_s2[k]);
                let [sn, se] = a.sigma_m_s2;
                (
                    T::c(libm::sqrt(n * n + e * e)),
                    T::c(libm::sqrt(0.5 * (sn * sn + se * se))),
                )
            }
            None => (
                ((v - v0) / t + turning).norm(),
                (sv * sv + sv0 * sv0).sqrt() / t,
            ),
        };
        if !accel.finite() {
            return;
        }
        // The span's mean acceleration, as the GNSS knows it: its RMS with the noise.
        let accel_rms = (accel * accel + accel_sigma * accel_sigma).sqrt();
        if accel_rms <= c.max_accel_mps2 {
            let f = span.sum_dv / span.sum_dt;
            let g = f.norm();
            let roll = (-f.y).patan2(-f.z);
            let pitch = f.x.patan2((f.y * f.y + f.z * f.z).sqrt());
            // The body's tilt about its mean over the span: 1 - |mean direction|^2 is the
            // mean square angle of the directions from their mean (small angles).
            let scatter2 = if span.blocks >= 2 {
                let mean = span.sum_dir / T::c(f64::from(span.blocks));
                (T::one() - mean.norm_squared()).max(T::zero())
            } else {
                T::zero()
            };
            let sigma = ((c.max_accel_mps2 * c.max_accel_mps2
                + c.accel_bias_mps2 * c.accel_bias_mps2)
                / (g * g)
                + scatter2)
                .sqrt();
            self.level = Some((roll, pitch, sigma));
            self.since_level = Some(SinceLevel {
                speed_m_s: (v.x * v.x + v.y * v.y).sqrt(),
                speed_sigma_m_s: sv,
                sum_dv_b: Vector3::zeros(),
                sum_dt: T::zero(),
            });
            // Still, or moving without a turn the GNSS can bound: only the first sums the gyro
            // bias (module docs).
            self.rest = if stood_still(&span.p0, pos) {
                let (turn, dt) = self.rest.unwrap_or((Vector3::zeros(), T::zero()));
                Some((turn + span.turn_rad, dt + span.sum_dt))
            } else {
                None
            };
            // The gyros carry the level on from here: with the mean rate at rest taken out
            // when known (Earth rate in, as the level turns with the Earth), else the
            // configured bias's 1-sigma left in.
            let (bias_rad_s, bias_sigma_rad_s) = self
                .mean_rate_at_rest()
                .unwrap_or((Vector3::zeros(), self.config.gyro_bias_rad_s));
            self.level_track = Some(LevelTrack {
                q_b_l: attitude::from_euler(roll, pitch, T::zero()),
                dt: T::zero(),
                bias_rad_s,
                bias_sigma_rad_s,
            });
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
        start_on_positions_at(still_s, 1)
    }

    /// [`start_on_positions`] with `per_s` fixes per second.
    fn start_on_positions_at(still_s: u32, per_s: u32) -> Option<MotionStart<f64>> {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let pitch = 2f64.to_radians();
        let dt = 1.0 / f64::from(per_s);
        let f_b = [9.8 * pitch.sin() * dt, 0.0, -9.8 * pitch.cos() * dt];
        for k in 0..u64::from((still_s + 5) * per_s) {
            let t = k as f64 * dt;
            let moving_s = (t - f64::from(still_s)).max(0.0);
            m.add_imu(&ImuIncrement::new([0.0; 3], f_b, dt));
            let at = fix(0.5 * noise(k, 0), 10.0 * moving_s + 0.5 * noise(k, 1));
            if let Some(s) = m.add_fix(t, &at, None) {
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

    /// The same car with a 10 Hz receiver: its positions are differenced over a second, not
    /// over 0.1 s (7 m/s of noise: it never started), and the start's velocity 1-sigma is a
    /// second's.
    #[test]
    fn a_10_hz_receiver_starts_as_a_1_hz_one() {
        let s = start_on_positions_at(20, 10).expect("a start once the car moves");
        let (roll, pitch, _) = s.state.euler();
        assert!(roll.abs() < 1e-9 && (pitch.to_degrees() - 2.0).abs() < 1e-9);
        assert!(s.sigma.velocity_ned_m_s.x < 1.0, "{:?}", s.sigma);
        assert!((s.state.v_eb_n.y - 10.0).abs() < 3.0 * s.sigma.velocity_ned_m_s.y);
    }

    /// Noise of about unit 1-sigma per fix and axis (three of [`noise`]'s draws summed).
    fn gauss(k: u64, axis: u64) -> f64 {
        noise(k, axis) + noise(k + 7_919, axis + 3) + noise(k + 104_729, axis + 6)
    }

    /// A car level at rest for `still_s` seconds, then driving east at `speed` [m/s], with
    /// 10 Hz fixes of positions alone, 2 m of noise (a code receiver without velocity, as
    /// KF-GINS's files hold); `None` when it never started within 60 s of driving.
    fn start_on_code_fixes(still_s: u32, speed: f64) -> Option<(f64, MotionStart<f64>)> {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let dt = 0.1;
        for k in 0..u64::from((still_s + 60) * 10) {
            let t = k as f64 * dt;
            let moving_s = (t - f64::from(still_s)).max(0.0);
            m.add_imu(&ImuIncrement::new([0.0; 3], [0.0, 0.0, -9.8 * dt], dt));
            let mut at = fix(2.0 * gauss(k, 0), speed * moving_s + 2.0 * gauss(k, 1));
            at.sigma_ned_m = Vector3::new(2.0, 2.0, 4.0);
            if let Some(s) = m.add_fix(t, &at, None) {
                return Some((t, s));
            }
        }
        None
    }

    /// 2 m fixes at 10 Hz: the span's mean acceleration from the fit of all its positions
    /// (0.05 m/s^2 over 10 s) finds a car standing 12 s level; two fixes a second apart
    /// differ by 2.8 m/s of noise, and the span needed about 30 s still (none came).
    #[test]
    fn a_car_is_level_on_code_fixes_after_seconds() {
        let (t, s) = start_on_code_fixes(12, 20.0).expect("level at rest, then a start");
        assert!(t > 12.0, "started at {t} s, before the car moved");
        let (roll, pitch, yaw) = s.state.euler();
        assert!(roll.abs() < 1e-9 && pitch.abs() < 1e-9);
        let yaw_err = yaw - core::f64::consts::FRAC_PI_2;
        assert!(
            yaw_err.abs() < 3.0 * s.sigma.attitude_rad.z,
            "yaw {} deg off, 1-sigma {} deg",
            yaw_err.to_degrees(),
            s.sigma.attitude_rad.z.to_degrees()
        );
    }

    /// A car standing still for a minute with 2 m fixes at 10 Hz is level, but never moving:
    /// positions a second apart differ by 2.8 m/s of noise per axis, which crossed the 5 m/s
    /// threshold within seconds (a start 150 deg off in heading, 1-sigma 30 deg).
    #[test]
    fn noise_is_not_a_track() {
        assert_eq!(start_on_code_fixes(120, 0.0), None);
    }

    /// Level at rest with the receiver's velocity (0.05 m/s at 1 Hz), body forward north,
    /// then accelerating at 2 m/s^2 along the body's `sign` x axis until the speed passes
    /// the threshold; the start's heading error [rad] and 1-sigma [rad].
    fn start_accelerating(sign: f64) -> (f64, f64) {
        let mut m = levelled_at_rest(Vector3::zeros());
        let (a, dt) = (2.0 * sign, 0.01);
        let mut v = 0.0;
        for k in 3..10 {
            for _ in 0..100 {
                m.add_imu(&ImuIncrement::new([0.0; 3], [a * dt, 0.0, -9.8 * dt], dt));
                v += a * dt;
            }
            let vel = GnssVelocity {
                v_ned_m_s: Vector3::new(v, 0.0, 0.0),
                sigma_ned_m_s: Vector3::repeat(0.05),
            };
            if let Some(s) = m.add_fix(f64::from(k), &fix(0.0, 0.0), Some(&vel)) {
                let (_, _, yaw) = s.state.euler();
                return (yaw, s.sigma.attitude_rad.z);
            }
        }
        panic!("no start");
    }

    /// A car reversing out of a parking space: its track points backwards, and the
    /// accelerometers say so (was: started 180 deg off in heading with a 3 deg 1-sigma).
    #[test]
    fn a_reversing_start_faces_against_its_track() {
        for sign in [1.0, -1.0] {
            let (yaw_err, sigma) = start_accelerating(sign);
            assert!(
                yaw_err.abs() < 3.0 * sigma,
                "driving {sign}: heading {} deg off, 1-sigma {} deg",
                yaw_err.to_degrees(),
                sigma.to_degrees()
            );
        }
    }

    /// A car that reverses from rest to `speed` [m/s] at 3 m/s^2 along `sign` times its
    /// forward (north) axis, then holds it, with the receiver's velocity (0.1 m/s) at 5 Hz: it
    /// is levelled only on the span at constant speed; the start's heading error [rad], its
    /// 1-sigma [rad] and time [s] (`None`: no start in 20 s).
    fn reverse_from_rest(sign: f64, speed: f64) -> Option<(f64, f64, f64)> {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let (dt, accel) = (0.01, 3.0 * sign);
        let mut v = 0.0_f64;
        for k in 0..2_000u32 {
            let a = if v.abs() < speed { accel } else { 0.0 };
            m.add_imu(&ImuIncrement::new([0.0; 3], [a * dt, 0.0, -9.8 * dt], dt));
            v += a * dt;
            if (k + 1) % 20 == 0 {
                let t = f64::from(k + 1) * dt;
                let vel = GnssVelocity {
                    v_ned_m_s: Vector3::new(v, 0.0, 0.0),
                    sigma_ned_m_s: Vector3::repeat(0.1),
                };
                if let Some(s) = m.add_fix(t, &fix(0.0, 0.0), Some(&vel)) {
                    let (_, _, yaw) = s.state.euler();
                    return Some((yaw, s.sigma.attitude_rad.z, t));
                }
            }
        }
        None
    }

    /// A car reversing to 6 m/s before any span was quasi-static: the level comes at constant
    /// speed, where the speed already passes the threshold, and the IMU's velocity change
    /// since the anchor (at rest) says which way the body faces (was: started 180 deg
    /// off with a 3 deg 1-sigma). Driving forwards the same way starts as before.
    #[test]
    fn a_car_that_reversed_before_its_level_faces_against_its_track() {
        for sign in [-1.0, 1.0] {
            let (yaw_err, sigma, t) = reverse_from_rest(sign, 6.0).expect("a start");
            assert!(
                yaw_err.abs() < 3.0 * sigma,
                "driving {sign}: heading {} deg off at {t} s, 1-sigma {} deg",
                yaw_err.to_degrees(),
                sigma.to_degrees()
            );
            assert!(t > 2.0, "started at {t} s, before the level");
        }
    }

    /// Level at rest, then the body rolls by 8.6 deg (a boat in a wave) before the fix that
    /// starts it: the level found before is carried on by the gyros (was: the level of its
    /// fix, 8.6 deg off against a 1.8 deg 1-sigma).
    #[test]
    fn the_level_is_carried_to_the_start() {
        let mut m = levelled_at_rest(Vector3::zeros());
        let (rate, dt) = (0.1, 0.01);
        let mut roll: f64 = 0.0;
        for _ in 0..150 {
            let f_b = [0.0, -9.8 * roll.sin() * dt, -9.8 * roll.cos() * dt];
            m.add_imu(&ImuIncrement::new([rate * dt, 0.0, 0.0], f_b, dt));
            roll += rate * dt;
        }
        let vel = GnssVelocity {
            v_ned_m_s: Vector3::new(10.0, 0.0, 0.0),
            sigma_ned_m_s: Vector3::repeat(0.05),
        };
        let s = m
            .add_fix(3.5, &fix(10.0, 0.0), Some(&vel))
            .expect("level and moving: a start");
        let (r, _, _) = s.state.euler();
        assert!(
            (r - roll).abs() < 3.0 * s.sigma.attitude_rad.x,
            "roll {} deg against {} deg, 1-sigma {} deg",
            r.to_degrees(),
            roll.to_degrees(),
            s.sigma.attitude_rad.x.to_degrees()
        );
    }

    /// A body standing still but rolling +-5 deg with an 8 s period, 0.5 m fixes at 1 Hz: each
    /// span's level is its mean roll, and the level's 1-sigma holds the body's roll about it
    /// at the span's last fix (was: the acceleration bound's 1.8 deg against errors of 5 deg).
    #[test]
    fn a_rolling_body_is_levelled_with_its_roll() {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let (amplitude, period, dt) = (5f64.to_radians(), 8.0, 0.01);
        let roll_at = |t: f64| amplitude * (2.0 * core::f64::consts::PI * t / period).sin();
        let mut checked = 0;
        for k in 0..6_000u64 {
            let t = k as f64 * dt;
            let roll = roll_at(t + 0.5 * dt);
            let rate = (roll_at(t + dt) - roll_at(t)) / dt;
            let f_b = [0.0, -9.8 * roll.sin() * dt, -9.8 * roll.cos() * dt];
            m.add_imu(&ImuIncrement::new([rate * dt, 0.0, 0.0], f_b, dt));
            if (k + 1) % 100 == 0 {
                let at = fix(0.5 * noise(k, 0), 0.5 * noise(k, 1));
                assert_eq!(m.add_fix(t + dt, &at, None), None);
                if let Some((r, _, sigma)) = m.carried_level() {
                    let err = r - roll_at(t + dt);
                    assert!(
                        err.abs() < 3.0 * sigma,
                        "t {} s: roll {} deg off, 1-sigma {} deg",
                        t + dt,
                        err.to_degrees(),
                        sigma.to_degrees()
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 10, "levelled at {checked} fixes");
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

    /// A start that found the level over 2 s at rest with the receiver's velocity.
    fn levelled_at_rest(lever_arm_b_m: Vector3<f64>) -> MotionAlign<f64> {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), lever_arm_b_m);
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
        m
    }

    /// Level at rest, then `dt_s` later a fix 14 m/s east on average: a start at once when the
    /// fixes are consecutive, none across an outage (its mean velocity is not the velocity at
    /// the fix, and the vehicle may have turned and climbed meanwhile).
    fn start_after(dt_s: f64) -> Option<MotionStart<f64>> {
        let mut m = levelled_at_rest(Vector3::zeros());
        m.add_imu(&still_for(dt_s));
        m.add_fix(2.0 + dt_s, &fix(0.0, 14.0 * dt_s), None)
    }

    /// Level at rest, then a fix with the receiver's velocity while the body rolls at 0.5
    /// rad/s (a car rocking on rough ground) and the antenna sits 2 m above the IMU: the
    /// antenna moves 1 m/s sideways relative to the IMU. The start's velocity is the IMU's,
    /// within 3 of its 1-sigma, and so is its heading (was: the antenna's, 20 sigma off, and the
    /// track 6 deg off).
    #[test]
    fn the_start_takes_out_the_lever_arm_velocity() {
        let lever_arm_b_m = Vector3::new(0.0, 0.0, -2.0);
        let mut m = levelled_at_rest(lever_arm_b_m);
        // Heading north at 10 m/s, rolling right at 0.5 rad/s: omega x l = (0, 1, 0) m/s.
        let roll_rate = 0.5;
        let dt = 0.01;
        m.add_imu(&ImuIncrement::new(
            [roll_rate * dt, 0.0, 0.0],
            [0.0, 0.0, -9.8 * dt],
            dt,
        ));
        let v_imu = Vector3::new(10.0, 0.0, 0.0);
        let antenna = GnssVelocity {
            v_ned_m_s: v_imu + Vector3::new(roll_rate, 0.0, 0.0).cross(&lever_arm_b_m),
            sigma_ned_m_s: Vector3::repeat(0.05),
        };
        let s = m
            .add_fix(3.0, &fix(10.0, 0.0), Some(&antenna))
            .expect("level and moving: a start");
        let err = s.state.v_eb_n - v_imu;
        for i in 0..3 {
            assert!(
                err[i].abs() < 3.0 * s.sigma.velocity_ned_m_s[i],
                "velocity error {err:?} against 1-sigma {:?}",
                s.sigma.velocity_ned_m_s
            );
        }
        let (_, _, yaw) = s.state.euler();
        assert!(
            yaw.abs() < 3.0 * s.sigma.attitude_rad.z,
            "yaw {} deg, 1-sigma {} deg",
            yaw.to_degrees(),
            s.sigma.attitude_rad.z.to_degrees()
        );
    }

    /// A body circling the North Pole 11 km from its axis at 200 m/s east, held level (a flat
    /// skidding turn, so that the level is known: roll 0), receiver velocities at 10 Hz: its
    /// NED velocity stays (0, 200, 0) while it accelerates towards the pole at 3.6 m/s^2,
    /// which its accelerometers feel. The start must not take that for gravity (was: levelled
    /// at 20 deg of roll, 1-sigma 1.8 deg).
    /// A level body flying east at `speed` [m/s] on the circle `d_axis` [m] from the North
    /// Pole's axis, its NED velocity constant: latitude [rad], NED velocity [m/s], and the
    /// body rate [rad/s] and specific force [m/s^2] it senses, body forward east, right south,
    /// down down.
    fn circling_the_pole(
        d_axis: f64,
        speed: f64,
    ) -> (f64, Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let lat = (d_axis / 6_399_593.6_f64).acos();
        let earth = LocalEarth::new(lat, 0.0);
        let v = Vector3::new(0.0, speed, 0.0);
        let w_in = earth.omega_ie_n() + earth.omega_en_n(&v);
        let g = crate::earth::normal_gravity(lat, 0.0);
        // Constant NED velocity: f_n = (2 omega_ie + omega_en) x v - g.
        let f_n = (earth.omega_ie_n() + w_in).cross(&v) - Vector3::new(0.0, 0.0, g);
        let to_b = |n: Vector3<f64>| Vector3::new(n.y, -n.x, n.z);
        (lat, v, to_b(w_in), to_b(f_n))
    }

    #[test]
    fn circling_a_pole_is_not_quasi_static() {
        let (d_axis, speed, dt) = (11_000.0, 200.0, 0.1);
        let (lat, v, w_b, f_b) = circling_the_pole(d_axis, speed);
        // Towards the pole (body right is south).
        assert!((-f_b.y - speed * speed / d_axis).abs() < 0.05, "{f_b:?}");
        let (w_b, f_b) = (w_b * dt, f_b * dt);
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let vel = GnssVelocity {
            v_ned_m_s: v,
            sigma_ned_m_s: Vector3::repeat(0.05),
        };
        for k in 0..100 {
            let t_s = f64::from(k) * dt;
            let pos = GnssPosition {
                lat_rad: lat,
                lon_rad: speed / d_axis * t_s,
                h_m: 0.0,
                sigma_ned_m: Vector3::repeat(0.5),
            };
            m.add_imu(&ImuIncrement::new(w_b.into(), f_b.into(), dt));
            if let Some(s) = m.add_fix(t_s, &pos, Some(&vel)) {
                let (roll, _, _) = s.state.euler();
                assert!(
                    roll.abs() < 3.0 * s.sigma.attitude_rad.x,
                    "roll {} deg, 1-sigma {} deg",
                    roll.to_degrees(),
                    s.sigma.attitude_rad.x.to_degrees()
                );
            }
        }
        assert!(!m.has_level());
    }

    /// Positions alone, a body flying east at 200 m/s on the circle 11 km from the North
    /// Pole's axis (its NED velocity constant): the velocity differenced over a second is
    /// carried to the fix with the accelerometers' 3.6 m/s^2 towards the pole, which the NED
    /// frame's turn cancels. The start's north velocity is 0 within its 1-sigma (was 1.8 m/s
    /// against 0.7).
    #[test]
    fn a_differenced_velocity_near_a_pole_turns_with_the_frame() {
        let (d_axis, speed) = (11_000.0, 200.0);
        let (lat, _, w_b, f_b) = circling_the_pole(d_axis, speed);
        let at = |t_s: f64| GnssPosition {
            lat_rad: lat,
            lon_rad: speed / d_axis * t_s,
            h_m: 0.0,
            sigma_ned_m: Vector3::repeat(0.5),
        };
        // Level at rest there first, on the receiver's velocity.
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let still = GnssVelocity {
            v_ned_m_s: Vector3::zeros(),
            sigma_ned_m_s: Vector3::repeat(0.05),
        };
        for k in 0..3 {
            m.add_imu(&still_for(0.01));
            assert!(m.add_fix(f64::from(k), &at(0.0), Some(&still)).is_none());
        }
        m.add_imu(&still_for(1.0));
        assert!(m.add_fix(3.0, &at(0.0), None).is_none());
        assert!(m.has_level());
        m.add_imu(&ImuIncrement::new(w_b.into(), f_b.into(), 1.0));
        let s = m
            .add_fix(4.0, &at(1.0), None)
            .expect("level and moving: a start");
        let (v, sv) = (s.state.v_eb_n, s.sigma.velocity_ned_m_s);
        assert!(
            v.x.abs() < 3.0 * sv.x && v.x.abs() < 0.3,
            "{v:?}, 1-sigma {sv:?}"
        );
        assert!((v.y - speed).abs() < 3.0 * sv.y, "{v:?}, 1-sigma {sv:?}");
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

    /// A position difference is the mean velocity over its interval: a car that leaves the
    /// level at 10 m/s east and accelerates at 4 m/s^2 covers 12 m in the next second and is
    /// at 14 m/s at its end. The start carries the mean to the fix with the IMU's acceleration
    /// (was: 12 m/s, 2 m/s slow against a 1-sigma of 0.7 m/s).
    #[test]
    fn a_differenced_velocity_is_carried_to_the_fix() {
        let mut m = levelled_at_rest(Vector3::zeros());
        // Heading east: body x east; one increment over the second.
        m.add_imu(&ImuIncrement::new([0.0; 3], [4.0, 0.0, -9.8], 1.0));
        let s = m
            .add_fix(3.0, &fix(0.0, 12.0), None)
            .expect("level and moving: a start");
        let v = s.state.v_eb_n;
        // North: the Coriolis term of the carry, 2 Omega sin(lat) v_E dt / 2 (0.6 mm/s), which
        // these increments without the Earth's rate leave out.
        assert!((v.y - 14.0).abs() < 0.05 && v.x.abs() < 1e-3, "{v:?}");
        assert!(v.z.abs() < 0.01, "{v:?}");
        assert!((v.y - 14.0).abs() < 3.0 * s.sigma.velocity_ned_m_s.y);
    }

    /// Each axis of a differenced velocity has its own 1-sigma, `sqrt(s1^2 + s2^2) / dt` of
    /// the two fixes' (plus the carry to the fix and the lever arm): a receiver's 2 m
    /// vertical gives the vertical velocity 2 m/s, its 0.5 m horizontal 0.7 m/s (was: their
    /// RMS on every axis, 1.2 m/s: the vertical 1.7 times too small).
    #[test]
    fn a_differenced_velocity_has_a_1_sigma_per_axis() {
        let mut m = levelled_at_rest(Vector3::zeros());
        m.add_imu(&still_for(1.0));
        let mut at = fix(0.0, 14.0);
        at.sigma_ned_m = Vector3::new(0.5, 0.5, 2.0);
        let s = m.add_fix(3.0, &at, None).expect("a start");
        let sv = s.sigma.velocity_ned_m_s;
        let vertical = (0.5f64 * 0.5 + 2.0 * 2.0).sqrt();
        let horizontal = (2.0f64 * 0.5 * 0.5).sqrt();
        assert!(sv.z >= vertical && sv.z < vertical * 1.05, "{sv:?}");
        for k in 0..2 {
            assert!(sv[k] >= horizontal && sv[k] < horizontal * 1.1, "{sv:?}");
        }
    }

    /// A car standing still for `still_s` seconds with gyro biases `bias` [rad/s], then
    /// driving east at 10 m/s on 1 Hz fixes of exact positions: the start.
    fn start_after_standing(still_s: u32, bias: Vector3<f64>) -> MotionStart<f64> {
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        for k in 0..(still_s + 10) {
            let t = f64::from(k);
            let moving_s = (t - f64::from(still_s)).max(0.0);
            m.add_imu(&ImuIncrement::new(bias.into(), [0.0, 0.0, -9.8], 1.0));
            if let Some(s) = m.add_fix(t, &fix(0.0, 10.0 * moving_s), None) {
                return s;
            }
        }
        panic!("no start");
    }

    /// Standing still for 30 s, the mean gyro output is the bias (less the Earth rate's
    /// vertical part; its horizontal part, the body's rocking and the angle random walk in the
    /// 1-sigma): the start carries it within 3 of a 1-sigma of hundredths of a degree per
    /// second. Standing for 5 s gives none (below [`MIN_REST_S`]), and neither does a car
    /// that drove at a constant velocity all along (quasi-static, level, but not still: its
    /// gyros may see a slow turn).
    #[test]
    fn a_vehicle_that_stood_still_gives_its_gyro_bias() {
        let bias = Vector3::new(0.3, -0.2, 1.45).map(f64::to_radians);
        let s = start_after_standing(30, bias);
        let (b, sigma) = s.gyro_bias_at_rest.expect("a bias at rest");
        let earth = Vector3::new(0.0, 0.0, crate::earth::OMEGA_IE * 45f64.to_radians().sin());
        for k in 0..3 {
            assert!(sigma[k] < 0.05f64.to_radians(), "{sigma:?}");
            let e = b[k] - (bias[k] + earth[k]);
            assert!(
                e.abs() < 3.0 * sigma[k],
                "{b:?} against {bias:?}: {sigma:?}"
            );
        }
        assert_eq!(start_after_standing(5, bias).gyro_bias_at_rest, None);
        let mut m = MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros());
        let mut start = None;
        for k in 0..60 {
            m.add_imu(&ImuIncrement::new(bias.into(), [0.0, 0.0, -9.8], 1.0));
            start = start.or(m.add_fix(f64::from(k), &fix(0.0, 10.0 * f64::from(k)), None));
        }
        let s = start.expect("a start on the move");
        assert_eq!(s.gyro_bias_at_rest, None);
    }
}
