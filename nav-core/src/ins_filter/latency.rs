//! A GNSS receiver's unstated output latency, found from the fixes themselves.
//!
//! A receiver (or a logger that tags its fixes on arrival) whose fixes carry a time tag `tau`
//! [s] after their epoch gives `p(t - tau) ~ p(t) - v tau`: each fix is behind the vehicle by
//! its velocity times the latency. At a steady velocity no test can tell this from a position
//! error, and the filter follows the fixes (3 m behind a car at 15 m/s for 0.2 s, with the
//! 1-sigma of RTK fixes); it shows only where the velocity changes, and the filter's velocity
//! and position, pulled by every fix, adapt to it as well.
//!
//! So the test does not go through the filter's estimate. Over a window of [`WINDOW_S`], it
//! takes the solution as the IMU alone carried it from the window's first fix: each fix's
//! measurement "predicted minus measured" before its update, `z_i`, plus what the corrections
//! since the window began moved the predicted antenna position by (undone: the position's
//! `x_pos + [l_n x] phi` at once, the velocity's `x_vel (t_i - t_l)` since its time `t_l`, and
//! `c (t_i - t_l)^2 / 2` of the acceleration's, `c = [f_n x] phi + C_b_n (b_a + f_b s_a)` the
//! attitude, accelerometer bias and scale-factor corrections through the velocity error's rate
//! of [`super::model`]), `y_i`, is then
//!
//! ```text
//! y_i = dp + dv t_i + da t_i^2 / 2 + tau u_i + e_i,   u_i = v_i - v_0 (the IMU's velocity
//!                                                     change, its corrections undone the
//!                                                     same way)
//! ```
//!
//! with `dp`, `dv` the solution's position and velocity errors at the window's start (whatever
//! the filter had adapted them to: nuisance parameters, per axis), `da` its acceleration error
//! (tilt, accelerometer bias: constant over the window, a nuisance whose prior is the filter's
//! own variance of it, `sigma_a^2` at the window's first fix) and `e_i` the fix's noise. A fix
//! that also gives the velocity adds a row of its own, the position's row differentiated:
//!
//! ```text
//! y_v,i = dv + da t_i + tau a_i + e_v,i,   a_i the IMU's acceleration over the interval
//!                                          before the fix (the change of u over it)
//! ```
//!
//! The weighted least squares of the shared `tau` with the nuisance marginalised
//! [Bar-Shalom et al., §3.4] sums, over the windows and axes, the information `I = u^T W u -
//! u^T W X (X^T W X + L)^-1 X^T W u` (a position row's `X` row `(1, t, t^2 / 2)`, a velocity
//! row's `(0, 1, t)`; `L` the acceleration's prior information `1 / sigma_a^2`) and `b` the
//! same with `y` for the second `u`: `tau = b / I`, 1-sigma `1 / sqrt(I)`. A heading error is
//! fitted per window with the offsets (`Window::add`): in a turn it moves the position as a
//! latency of `psi / omega` would. What is left to see is the velocity change that is not
//! linear in time over the window: turns and stops. A window spans [`WINDOW_S`] and
//! [`WINDOW_FIXES`] fixes (at most [`MAX_WINDOW_S`]). Without the attitude's corrections
//! undone, a still base's drift, corrected at every fix, correlated with its own velocity
//! change: 190-500 s of apparent latency at 2-4 sigma. With the acceleration error taken as
//! noise of each fix (`sigma_a^2 t^4 / 4`) instead of one nuisance, a consumer part's rows
//! after a second or two had no weight: its 0.05 m/s velocity fixes 0.2 s late went unfound for
//! 155 s, the solution 357 m off meanwhile; as a nuisance, found at 26 s.
//!
//! The sensors' scale-factor and cross-coupling errors `S` give an apparent latency of about
//! `|S| T / 2` over a window `T` (their error `S u` integrated): 4 ms for a consumer part's
//! scale factor (0.1 %) over 8 s; its cross-coupling (1 %) only in part, through windows whose
//! drift variance (its tilt's) leaves them little weight. A latency is reported
//! ([`LatencyEstimate::detected`]) beyond [`DETECTION_SIGMAS`] of its 1-sigma, beyond
//! [`MIN_LATENCY_S`] and within [`MAX_LATENCY_S`].
//!
//! Once one is detected the filter retimes the fixes ([`LatencyMonitor::retime`],
//! [`LatencyMonitor::applied`]): each is taken at its tag less the estimate, as a declared
//! latency is, and follows the estimate as more windows refine it (the test itself always
//! sees the fixes as their tags give them). What the solution took from the fixes before
//! (the change of latency times the velocity, the acceleration and the rotation rate) joins
//! the filter's covariance at each change; the estimate's own 1-sigma, common to every fix,
//! widens the reported 1-sigma ([`LatencyMonitor::doubt`]).

use crate::Scalar;
use nalgebra::{Matrix3, Vector3};

/// Sigmas beyond which an estimated latency is reported [-].
pub const DETECTION_SIGMAS: f64 = 5.0;
/// Smallest latency reported [s] (module docs: five times the apparent latency of a consumer
/// part's scale-factor error over an 8 s window).
pub const MIN_LATENCY_S: f64 = 0.02;
/// Largest latency reported [s]: a receiver's output latency is below a second (the range
/// `--gnss-latency` takes); an estimate beyond it is the solution's own drift correlating with
/// its velocity change (a vehicle at rest: the velocity change is the drift), not a latency.
pub const MAX_LATENCY_S: f64 = 1.0;
/// Shortest window [s]: a car's turn changes the velocity non-linearly over seconds; the
/// drift of an acceleration error grows as its fourth power.
pub const WINDOW_S: f64 = 4.0;
/// Fixes a window holds at least, unless it reaches [`MAX_WINDOW_S`] (1 Hz fixes: 8 s).
pub const WINDOW_FIXES: u32 = 8;
/// Longest window [s].
pub const MAX_WINDOW_S: f64 = 10.0;
/// Longest interval between two fixes of one window [s]: a longer gap ends the window.
pub const MAX_FIX_INTERVAL_S: f64 = 2.5;
/// A window whose fit (nuisance and its own latency) leaves a chi-square beyond this many
/// times its degrees of freedom (plus [`MAX_WINDOW_CHI2_EXTRA`]) holds a gross fault (a jump,
/// an outlier) and is left out [-].
pub const MAX_WINDOW_CHI2_PER_DOF: f64 = 3.0;
/// See [`MAX_WINDOW_CHI2_PER_DOF`] [-].
pub const MAX_WINDOW_CHI2_EXTRA: f64 = 25.0;
/// Window closes in a row whose estimate fails the test (for a latency applied, its own:
/// `LatencyMonitor::holds`) before a retiming is undone [-] (a latency found stays found
/// through a window or two that pull the estimate back within the test's bounds).
pub const UNDO_WINDOWS: u8 = 3;
/// Time over which the largest acceleration and rotation rate are kept for the retiming's
/// doubt [s] (they fade as `exp(-t / PEAK_MEMORY_S)`): about the time a filter's velocity and
/// tilt take to follow the fixes.
pub const PEAK_MEMORY_S: f64 = 30.0;

/// What the corrections since the previous position fix did (undone by the test, module
/// docs); times from that fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corrections<T: Scalar> {
    /// Sum of the predicted antenna position's corrections `x_pos + [l_n x] phi` [m].
    pub position_m: Vector3<T>,
    /// Sum of the velocity corrections `x_vel` [m/s].
    pub velocity_m_s: Vector3<T>,
    /// Sum of `x_vel t_l`, `t_l` the correction's time after the previous fix [m].
    pub velocity_time_m: Vector3<T>,
    /// Sum of the acceleration corrections `c = [f_n x] phi + C_b_n (b_a + f_b s_a)` (the
    /// attitude's, accelerometer bias's and scale factor's, through the velocity error's
    /// rate; the specific force as at the correction) [m/s^2].
    pub accel_mps2: Vector3<T>,
    /// Sum of `c t_l` [m/s].
    pub accel_time_m_s: Vector3<T>,
    /// Sum of `c t_l^2` [m].
    pub accel_time2_m: Vector3<T>,
}

impl<T: Scalar> Default for Corrections<T> {
    fn default() -> Self {
        Self {
            position_m: Vector3::zeros(),
            velocity_m_s: Vector3::zeros(),
            velocity_time_m: Vector3::zeros(),
            accel_mps2: Vector3::zeros(),
            accel_time_m_s: Vector3::zeros(),
            accel_time2_m: Vector3::zeros(),
        }
    }
}

impl<T: Scalar> Corrections<T> {
    /// `other`, whose times start `dt_s` [s] after these, added to these.
    fn add_later(&mut self, other: &Self, dt_s: T) {
        self.position_m += other.position_m;
        self.velocity_time_m += other.velocity_time_m + other.velocity_m_s * dt_s;
        self.velocity_m_s += other.velocity_m_s;
        self.accel_time2_m += other.accel_time2_m
            + other.accel_time_m_s * (dt_s + dt_s)
            + other.accel_mps2 * (dt_s * dt_s);
        self.accel_time_m_s += other.accel_time_m_s + other.accel_mps2 * dt_s;
        self.accel_mps2 += other.accel_mps2;
    }

    /// What they moved the predicted antenna position [m] and the velocity [m/s] at `t_s` [s]
    /// by (subtracted): `x_pos + x_vel (t - t_l) + c (t - t_l)^2 / 2` summed, and `x_vel +
    /// c (t - t_l)`.
    fn at(&self, t_s: T) -> (Vector3<T>, Vector3<T>) {
        let half = T::c(0.5);
        let position = self.position_m + self.velocity_m_s * t_s - self.velocity_time_m
            + (self.accel_mps2 * (t_s * t_s) - self.accel_time_m_s * (t_s + t_s)
                + self.accel_time2_m)
                * half;
        let velocity = self.velocity_m_s + self.accel_mps2 * t_s - self.accel_time_m_s;
        (position, velocity)
    }
}

/// One valid position fix as the test needs it, whether the filter took it or not (the fixes
/// a latency puts off their tags are refused at the turns that show it; a gross fault spoils
/// its window's fit, and the window is left out: [`MAX_WINDOW_CHI2_PER_DOF`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatencyFix<T: Scalar> {
    /// The measurement "predicted minus measured" before the update, NED [m].
    pub z_m: Vector3<T>,
    /// The fix's noise variances, NED [m^2].
    pub r_m2: Vector3<T>,
    /// Variance of the solution's acceleration error [m^2/s^4] (tilt and accelerometer
    /// bias): at a window's first fix, the prior of its acceleration nuisance.
    pub accel_var: T,
    /// The receiver's declared time-correlated error ([`super::GnssCorrelatedError`]), if
    /// any: its steady-state variances, NED [m^2], and correlation time [s].
    pub correlated: Option<(Vector3<T>, T)>,
    /// The solution's velocity at the fix's epoch, NED [m/s].
    pub v_eb_n: Vector3<T>,
    /// Time since the previous position fix [s].
    pub dt_s: T,
    /// The corrections since the previous position fix ([`LatencyMonitor::take_corrections`],
    /// taken before this fix's update).
    pub corrections: Corrections<T>,
}

/// The test's estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatencyEstimate<T: Scalar> {
    /// The fixes' lag behind their time tags [s] (negative: ahead of them).
    pub late_s: T,
    /// Its 1-sigma [s] (infinite before any velocity change was seen).
    pub sigma_s: T,
    /// Windows of fixes used.
    pub windows: u32,
    /// Windows left out for a gross fault ([`MAX_WINDOW_CHI2_PER_DOF`]).
    pub gross_windows: u32,
    /// The windows' own latencies about the shared one, chi-square per degree of freedom
    /// (about 1 when one latency explains them all) [-].
    pub spread: T,
    /// Beyond [`DETECTION_SIGMAS`] of its 1-sigma and beyond [`MIN_LATENCY_S`], within
    /// [`MAX_LATENCY_S`], the windows agreeing on it (`LatencyMonitor::passes`), at the last
    /// window's close; or the fixes retimed by it ([`LatencyMonitor::retime`]: until it has
    /// failed that test at [`UNDO_WINDOWS`] closes in a row).
    pub detected: bool,
}

impl<T: Scalar> LatencyEstimate<T> {
    /// The estimate in another precision.
    pub fn cast<U: Scalar>(&self) -> LatencyEstimate<U> {
        LatencyEstimate {
            late_s: U::c(self.late_s.to_f64()),
            sigma_s: U::c(self.sigma_s.to_f64()),
            windows: self.windows,
            gross_windows: self.gross_windows,
            spread: U::c(self.spread.to_f64()),
            detected: self.detected,
        }
    }
}

/// The weighted sums of one axis over a window's rows, each row with its nuisance columns
/// `x` (module docs: a position fix's `(1, t, t^2 / 2)`, a velocity fix's `(0, 1, t)`): of
/// `x x^T`, of `x` times the latency's regressor `u`, the measurement `y` and the heading's
/// regressor `r`, and of their products `u^2, u y, y^2, r^2, r u, r y`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct AxisSums<T: Scalar> {
    rows: u32,
    xx: Matrix3<T>,
    xu: Vector3<T>,
    xy: Vector3<T>,
    xr: Vector3<T>,
    uu: T,
    uy: T,
    yy: T,
    rr: T,
    ru: T,
    ry: T,
}

impl<T: Scalar> AxisSums<T> {
    fn new() -> Self {
        Self {
            rows: 0,
            xx: Matrix3::zeros(),
            xu: Vector3::zeros(),
            xy: Vector3::zeros(),
            xr: Vector3::zeros(),
            uu: T::zero(),
            uy: T::zero(),
            yy: T::zero(),
            rr: T::zero(),
            ru: T::zero(),
            ry: T::zero(),
        }
    }

    /// Adds a row of weight `wt` (module docs): columns `x`, the latency's regressor `u`,
    /// the heading's `r`, the measurement `y`; a row whose values are not finite is left out.
    fn add(&mut self, wt: T, x: Vector3<T>, u: T, r: T, y: T) {
        if !(wt > T::zero() && wt.finite() && y.finite() && u.finite() && r.finite()) {
            return;
        }
        let wx = x * wt;
        self.xx += wx * x.transpose();
        self.xu += wx * u;
        self.xy += wx * y;
        self.xr += wx * r;
        self.uu += wt * u * u;
        self.uy += wt * u * y;
        self.yy += wt * y * y;
        self.rr += wt * r * r;
        self.ru += wt * r * u;
        self.ry += wt * r * y;
        self.rows += 1;
    }
}

/// Inner products over a window's axes of `u` (the velocity change), `r` (the heading's
/// regressor) and `y` (the measurement), each with the axis's offset and rate projected out.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Projected<T> {
    uu: T,
    uy: T,
    yy: T,
    rr: T,
    ru: T,
    ry: T,
}

impl<T: Scalar> Projected<T> {
    const ZERO: Self = Self {
        uu: T::ZERO,
        uy: T::ZERO,
        yy: T::ZERO,
        rr: T::ZERO,
        ru: T::ZERO,
        ry: T::ZERO,
    };
}

/// The window being filled.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Window<T: Scalar> {
    /// Time since its first fix [s].
    age_s: T,
    /// Its first fix's velocity [m/s].
    v0: Vector3<T>,
    /// Its first fix's measurement [m]: the others' are taken from it (the nuisance offset
    /// absorbs it; the sums stay small in `f32` after a start metres off).
    z0: Vector3<T>,
    /// The 1-sigma of the solution's acceleration error at its first fix [m/s^2]: the
    /// acceleration nuisance's column is scaled by it, its prior then of unit variance.
    accel_sigma: T,
    /// The fixes' declared time-correlated error (variances [m^2], correlation time [s]):
    /// what it moves by after the first fix is noise of the later ones.
    correlated: Option<(Vector3<T>, T)>,
    /// Corrections since its first fix, times from it.
    undone: Corrections<T>,
    /// The velocity change's integral since its first fix [m] and the last fix's change
    /// [m/s] (trapezoids between fixes).
    moved: Vector3<T>,
    last_u: Vector3<T>,
    /// The velocity change's rate over the interval before the last position fix [m/s^2],
    /// for that fix's velocity row ([`LatencyMonitor::velocity`]); `None` at the window's
    /// first fix and once taken.
    accel: Option<Vector3<T>>,
    sums: [AxisSums<T>; 3],
    fixes: u32,
}

impl<T: Scalar> Window<T> {
    /// Adds a fix at `t` [s] with the velocity change `u` [m/s], the measurement `y` [m] and
    /// the variances `var` [m^2] (an axis whose values are not finite is left out).
    ///
    /// The heading's regressor `r = [d x] integral(u)` (`d` down): a heading error `psi`
    /// turns the velocity change and moves the position by `psi r` [Groves, §14.2.4], and in
    /// a turn `r` correlates with `u` (an apparent latency of `psi / omega`: a start 90 deg off
    /// gave 0.9 s at 5 sigma); it is fitted per window with the offsets.
    fn add(&mut self, t: T, dt: T, u: &Vector3<T>, y: &Vector3<T>, var: &Vector3<T>) {
        self.moved += (self.last_u + u) * (dt * T::c(0.5));
        self.accel = (dt > T::zero()).then(|| (u - self.last_u) / dt);
        self.last_u = *u;
        let r = heading_regressor(&self.moved);
        let x = Vector3::new(T::one(), t, self.accel_sigma * t * t * T::c(0.5));
        for (k, s) in self.sums.iter_mut().enumerate() {
            s.add(T::one() / var[k], x, u[k], r[k], y[k]);
        }
        self.fixes += 1;
    }

    /// Adds the velocity fix of the last position fix's epoch: the measurement `y` [m/s]
    /// (its corrections undone) and the variances `var` [m^2/s^2]. Its offset is the velocity
    /// error's (the position rows' rate), its latency regressor the acceleration, its
    /// heading's the velocity change turned (the position rows' regressors differentiated).
    fn add_velocity(&mut self, y: &Vector3<T>, var: &Vector3<T>) {
        let Some(a) = self.accel.take() else {
            return;
        };
        let r = heading_regressor(&self.last_u);
        let x = Vector3::new(T::zero(), T::one(), self.accel_sigma * self.age_s);
        for (k, s) in self.sums.iter_mut().enumerate() {
            s.add(T::one() / var[k], x, a[k], r[k], y[k]);
        }
    }
}

/// `[d x] v` (`d` down): what a heading error turns `v` by, per radian [Groves, §14.2.4].
fn heading_regressor<T: Scalar>(v: &Vector3<T>) -> Vector3<T> {
    Vector3::new(-v.y, v.x, T::zero())
}

/// The test (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatencyMonitor<T: Scalar> {
    window: Option<Window<T>>,
    pending: Corrections<T>,
    information: T,
    b: T,
    /// Sum over the windows of `b_w^2 / I_w` (their spread about the shared latency).
    bb: T,
    windows: u32,
    /// Windows left out for a gross fault.
    gross: u32,
    /// The velocity [m/s] and acceleration [m/s^2] at the last fix (the retiming's doubt).
    last_v: Vector3<T>,
    last_a: Vector3<T>,
    /// Per axis, the largest acceleration [m/s^2] and rotation rate [rad/s] of the vehicle
    /// over about [`PEAK_MEMORY_S`] (the retiming's doubt).
    peak_a: Vector3<T>,
    peak_w: Vector3<T>,
    /// The latency the fixes are retimed by [s] ([`LatencyMonitor::retime`]); zero until one
    /// is detected.
    applied_s: T,
    /// Whether the estimate passed the test ([`Self::passes`]) at the last window close, and
    /// the closes in a row since it failed it ([`UNDO_WINDOWS`]).
    passing: bool,
    failed: u8,
}

impl<T: Scalar> Default for LatencyMonitor<T> {
    fn default() -> Self {
        Self {
            window: None,
            pending: Corrections::default(),
            information: T::zero(),
            b: T::zero(),
            bb: T::zero(),
            windows: 0,
            gross: 0,
            last_v: Vector3::zeros(),
            last_a: Vector3::zeros(),
            peak_a: Vector3::zeros(),
            peak_w: Vector3::zeros(),
            applied_s: T::zero(),
            passing: false,
            failed: 0,
        }
    }
}

impl<T: Scalar> LatencyMonitor<T> {
    /// A correction fed back `since_fix_s` [s] after the last position fix: the predicted
    /// antenna position by `-dr_m` [m], the velocity by `-dv_m_s` [m/s], the acceleration by
    /// `-da_mps2` [m/s^2] ([`Corrections::accel_mps2`]).
    pub fn corrected(
        &mut self,
        dr_m: &Vector3<T>,
        dv_m_s: &Vector3<T>,
        da_mps2: &Vector3<T>,
        since_fix_s: T,
    ) {
        let one = Corrections {
            position_m: *dr_m,
            velocity_m_s: *dv_m_s,
            velocity_time_m: Vector3::zeros(),
            accel_mps2: *da_mps2,
            accel_time_m_s: Vector3::zeros(),
            accel_time2_m: Vector3::zeros(),
        };
        self.pending.add_later(&one, since_fix_s);
    }

    /// The corrections since the last position fix, from zero again.
    pub fn take_corrections(&mut self) -> Corrections<T> {
        core::mem::take(&mut self.pending)
    }

    /// The window ends without being counted (the fixes' chain broke: an invalid fix).
    pub fn broken(&mut self) {
        self.window = None;
    }

    /// Takes position fix `f` (its measurement as its time tag gives it, not retimed), with
    /// the solution's acceleration `a_eb_n` [m/s^2] and rotation rate `omega_n` [rad/s] at
    /// it.
    pub fn fix(&mut self, f: &LatencyFix<T>, a_eb_n: &Vector3<T>, omega_n: &Vector3<T>) {
        self.last_v = f.v_eb_n;
        self.last_a = *a_eb_n;
        let keep = if f.dt_s.finite() && f.dt_s >= T::zero() {
            (-f.dt_s / T::c(PEAK_MEMORY_S)).exp()
        } else {
            T::zero()
        };
        self.peak_a = (self.peak_a * keep).zip_map(a_eb_n, |p, a| p.max(a.abs()));
        self.peak_w = (self.peak_w * keep).zip_map(omega_n, |p, w| p.max(w.abs()));
        if let Some(w) = &mut self.window {
            w.undone.add_later(&f.corrections, w.age_s);
            w.age_s += f.dt_s;
            if !(f.dt_s <= T::c(MAX_FIX_INTERVAL_S) && w.age_s.finite()) {
                self.close();
            } else {
                let t = w.age_s;
                let (dp, dv) = w.undone.at(t);
                let u = f.v_eb_n + dv - w.v0;
                let y = f.z_m - w.z0 + dp;
                // A Gauss-Markov error moves from the first fix's value by a variance of
                // `2 s^2 (1 - exp(-t / tau))` [Groves, §14.3.2]: the later fixes' noise (a
                // code receiver's multipath, shared by the window's fixes, bends their offsets
                // beyond the nuisance's quadratic).
                let var = w.correlated.map_or(f.r_m2, |(s2, tau)| {
                    f.r_m2 + s2 * (T::c(2.0) * (T::one() - (-t / tau).exp()))
                });
                w.add(t, f.dt_s, &u, &y, &var);
                if t >= T::c(MAX_WINDOW_S) || (t >= T::c(WINDOW_S) && w.fixes >= WINDOW_FIXES) {
                    self.close();
                }
            }
            return;
        }
        let mut w = Window {
            age_s: T::zero(),
            v0: f.v_eb_n,
            z0: f.z_m,
            correlated: f.correlated,
            accel_sigma: if f.accel_var > T::zero() && f.accel_var.finite() {
                f.accel_var.sqrt()
            } else {
                T::zero()
            },
            undone: Corrections::default(),
            moved: Vector3::zeros(),
            last_u: Vector3::zeros(),
            accel: None,
            sums: [AxisSums::new(); 3],
            fixes: 0,
        };
        // The first fix: `t`, `u`, `y` and `r` are zero.
        let zero = Vector3::zeros();
        w.add(T::zero(), T::zero(), &zero, &zero, &f.r_m2);
        self.window = Some(w);
    }

    /// Takes the velocity fix of the position fix just taken ([`Self::fix`]; the same epoch):
    /// its measurement "predicted minus measured" `z_m_s` [m/s] as its time tag gives it,
    /// before its update, and the variances `r_m2_s2` [m^2/s^2]. A row of the open window
    /// (module docs); nothing once that fix closed it, or at its first fix.
    pub fn velocity(&mut self, z_m_s: &Vector3<T>, r_m2_s2: &Vector3<T>) {
        let pending = self.pending;
        let Some(w) = &mut self.window else {
            return;
        };
        let t = w.age_s;
        let (_, dv) = w.undone.at(t);
        let (_, dv_since_fix) = pending.at(T::zero());
        let y = z_m_s + dv + dv_since_fix;
        w.add_velocity(&y, r_m2_s2);
    }

    /// Ends the window, adding its information (module docs) unless its own fit shows a
    /// gross fault ([`MAX_WINDOW_CHI2_PER_DOF`]).
    fn close(&mut self) {
        let Some(w) = self.window.take() else {
            return;
        };
        if w.fixes < 3 {
            return;
        }
        let mut sum = Projected::<T>::ZERO;
        let mut dof = -1_i32;
        for a in &w.sums {
            // Rows too few or too close in time to tell the offset, rate and acceleration
            // apart.
            // The acceleration nuisance's unit prior (its column scaled by its 1-sigma).
            let mut xx = a.xx;
            xx[(2, 2)] += T::one();
            let Some(m) = xx.cholesky() else {
                continue;
            };
            if a.rows < 3 {
                continue;
            }
            // `p^T W X (X^T W X)^-1 X^T W q` of the sums `X^T W p`, `X^T W q`.
            let proj = |p: &Vector3<T>, q: &Vector3<T>| p.dot(&m.solve(q));
            sum.uu += a.uu - proj(&a.xu, &a.xu);
            sum.uy += a.uy - proj(&a.xu, &a.xy);
            sum.yy += a.yy - proj(&a.xy, &a.xy);
            sum.rr += a.rr - proj(&a.xr, &a.xr);
            sum.ru += a.ru - proj(&a.xr, &a.xu);
            sum.ry += a.ry - proj(&a.xr, &a.xy);
            dof += a.rows as i32 - 2;
        }
        let (mut info, mut b, mut chi2) = (sum.uu, sum.uy, sum.yy);
        // The heading projected out as well (one parameter of the window).
        if sum.rr > T::c(1e-9) * sum.uu.max(T::c(1e-30)) && sum.rr.finite() {
            info -= sum.ru * sum.ru / sum.rr;
            b -= sum.ru * sum.ry / sum.rr;
            chi2 -= sum.ry * sum.ry / sum.rr;
            dof -= 1;
        }
        if !(info > T::zero() && info.finite() && b.finite() && dof > 0) {
            return;
        }
        let chi2 = chi2 - b * b / info;
        let limit = T::c(MAX_WINDOW_CHI2_PER_DOF * f64::from(dof) + MAX_WINDOW_CHI2_EXTRA);
        if chi2 > limit || !chi2.finite() {
            self.gross = self.gross.saturating_add(1);
            return;
        }
        self.information += info;
        self.b += b;
        self.bb += b * b / info;
        self.windows = self.windows.saturating_add(1);
        self.passing = self.passes();
        self.failed = if self.passing || self.holds() {
            0
        } else {
            self.failed.saturating_add(1)
        };
    }

    /// The estimate so far (the windows closed).
    pub fn estimate(&self) -> LatencyEstimate<T> {
        if self.information <= T::zero() {
            return LatencyEstimate {
                late_s: T::zero(),
                sigma_s: T::c(f64::INFINITY),
                windows: self.windows,
                gross_windows: self.gross,
                spread: T::zero(),
                detected: false,
            };
        }
        let (late_s, sigma_s) = self.latency();
        let dof = T::c(f64::from(self.windows.max(2) - 1));
        let spread = (self.bb - self.b * late_s).max(T::zero()) / dof;
        LatencyEstimate {
            late_s,
            sigma_s,
            windows: self.windows,
            gross_windows: self.gross,
            spread,
            detected: self.passing || self.applied_s != T::zero(),
        }
    }

    /// The shared latency and its 1-sigma [s] (module docs; the information must be
    /// positive).
    fn latency(&self) -> (T, T) {
        (
            self.b / self.information,
            T::one() / self.information.sqrt(),
        )
    }

    /// The estimate beyond [`DETECTION_SIGMAS`] of its 1-sigma, beyond [`MIN_LATENCY_S`]
    /// and within [`MAX_LATENCY_S`], and one latency for all the windows: their spread about
    /// it ([`LatencyEstimate::spread`]) within `1 + DETECTION_SIGMAS sqrt(2 / dof)` (chi-square
    /// per degree of freedom, its mean plus that many of its standard deviations). A start
    /// 90 deg off in heading gave windows of -1.9 +- 0.2 s and +1.7 +- 0.1 s (spread 20-57);
    /// the audit's late receivers 0.5-1.0.
    fn passes(&self) -> bool {
        if !(self.information > T::zero()) {
            return false;
        }
        let e = self.estimate();
        let dof = T::c(f64::from(self.windows.max(2) - 1));
        e.spread <= T::one() + T::c(DETECTION_SIGMAS) * (T::c(2.0) / dof).sqrt()
            && e.late_s.abs() > T::c(DETECTION_SIGMAS) * e.sigma_s
            && e.late_s.abs() > T::c(MIN_LATENCY_S)
            && e.late_s.abs() <= T::c(MAX_LATENCY_S)
    }

    /// Whether a latency the fixes are retimed by still holds: the estimate beyond
    /// [`DETECTION_SIGMAS`] of its 1-sigma widened by the windows' spread (`sqrt(spread)`
    /// when above 1: the windows scatter more than their own 1-sigma say), beyond
    /// [`MIN_LATENCY_S`] and within [`MAX_LATENCY_S`]. The spread's own test
    /// ([`Self::passes`]) is for finding one; applied to a latency found, an aircraft's 0.15 s
    /// (estimated 0.1447 s, 1-sigma 0.0006 s) was undone at 207 s when its windows' spread
    /// reached 1.9, and the solution then ran 12-15 m off under a 1-sigma of 0.1-0.9 m.
    fn holds(&self) -> bool {
        if self.applied_s == T::zero() || !(self.information > T::zero()) {
            return false;
        }
        let e = self.estimate();
        let sigma = e.sigma_s * e.spread.max(T::one()).sqrt();
        e.late_s.abs() > T::c(DETECTION_SIGMAS) * sigma
            && e.late_s.abs() > T::c(MIN_LATENCY_S)
            && e.late_s.abs() <= T::c(MAX_LATENCY_S)
    }

    /// The latency the fixes are taken at and its 1-sigma [s]: once one is detected, the
    /// estimate (each fix's epoch is its tag minus it); `(0, 0)` before.
    pub fn applied(&self) -> (T, T) {
        if self.applied_s == T::zero() {
            return (T::zero(), T::zero());
        }
        (self.applied_s, self.estimate().sigma_s)
    }

    /// What the retiming's own error leaves doubtful, `(position [m^2], velocity
    /// [m^2/s^2])`: the fixes are taken `sigma` [s] off their epochs, the same for all of
    /// them, which no number of fixes averages out, so `sigma^2 v v^T` and `sigma^2 a a^T` at
    /// the last fix (reported, not gated: a consider parameter's); `None` before a latency
    /// is detected.
    pub fn doubt(&self) -> Option<(Matrix3<T>, Matrix3<T>)> {
        let (late_s, sigma_s) = self.applied();
        (late_s != T::zero()).then(|| {
            let k = sigma_s * sigma_s;
            (
                self.last_v * self.last_v.transpose() * k,
                self.last_a * self.last_a.transpose() * k,
            )
        })
    }

    /// Moves the retiming ([`Self::applied`]) to the estimate, once one was detected, and
    /// returns what the change `d` [s] leaves doubtful in the filter's state, `(position
    /// [m^2], velocity [m^2/s^2], attitude [rad^2])`: the solution followed fixes `d v`
    /// behind the vehicle and `d a` slow, its attitude up to `d omega` behind, so `(d^2 +
    /// sigma^2)` times `v v^T`, and the diagonal of the largest accelerations and rotation
    /// rates of the last [`PEAK_MEMORY_S`] (the filter's memory of the fixes: the velocity
    /// and attitude it took from them); `None` when nothing moves.
    pub fn retime(&mut self) -> Option<(Matrix3<T>, Matrix3<T>, Matrix3<T>)> {
        let e = self.estimate();
        let to = if self.failed >= UNDO_WINDOWS {
            T::zero()
        } else if e.detected {
            e.late_s
        } else {
            self.applied_s
        };
        if !(to.finite() && to != self.applied_s) {
            return None;
        }
        let d = to - self.applied_s;
        self.applied_s = to;
        let k = d * d + e.sigma_s * e.sigma_s;
        let diag = |p: &Vector3<T>| Matrix3::from_diagonal(&p.component_mul(p)) * k;
        Some((
            self.last_v * self.last_v.transpose() * k,
            diag(&self.peak_a),
            diag(&self.peak_w),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A car at 15 m/s turning at 0.2 rad/s for 10 s in every 30, fixes at `rate` [Hz] of
    /// 1-sigma `sigma` [m] (and velocity fixes of `sigma_v` [m/s]) tagged `tau` [s] late;
    /// the solution moves as the car between fixes, its heading `psi` [rad] off and its
    /// acceleration off by `accel_error` [m/s^2] (declared to the test as `accel_sigma`),
    /// and each update takes half the innovation, in position and in velocity (the
    /// velocity's correction taken from the innovation's change since the previous fix,
    /// and half of a velocity fix's); the fixes off by 50 m for 2 s from `jump_at` [s].
    #[derive(Clone, Copy)]
    struct Drive {
        tau: f64,
        sigma: f64,
        sigma_v: Option<f64>,
        rate: f64,
        seconds: f64,
        jump_at: Option<f64>,
        psi: f64,
        accel_error: Vector3<f64>,
        accel_sigma: f64,
        /// The fixes' noise over their declared 1-sigma [-].
        noise_scale: f64,
        /// Whether the drive retimes its fixes as the filter does ([`LatencyMonitor::retime`]).
        retimes: bool,
    }

    impl Drive {
        fn new(tau: f64, sigma: f64, rate: f64) -> Self {
            Self {
                tau,
                sigma,
                sigma_v: None,
                rate,
                seconds: 300.0,
                jump_at: None,
                psi: 0.0,
                accel_error: Vector3::zeros(),
                accel_sigma: 0.0,
                noise_scale: 1.0,
                retimes: false,
            }
        }

        fn run(&self) -> LatencyEstimate<f64> {
            let mut m = LatencyMonitor::<f64>::default();
            let speed = 15.0;
            let omega = |t: f64| if t % 30.0 < 10.0 { 0.2 } else { 0.0 };
            let step = 1e-3;
            let mut noise = 0.37_f64;
            let mut draw = |sigma: f64| {
                Vector3::from_fn(|_, _| {
                    noise = (noise * 9301.0 + 0.4927).fract();
                    (2.0 * noise - 1.0) * sigma
                })
            };
            let (mut heading, mut p) = (0.0_f64, Vector3::zeros());
            // The car's positions and velocities of the last 0.512 s, one per step.
            let mut history = [(Vector3::<f64>::zeros(), Vector3::<f64>::zeros()); 512];
            let lag = (self.tau / step).round() as usize;
            let mut n_step = 0_usize;
            let (mut p_ins, mut v_err) =
                (Vector3::new(3.0, -2.0, 1.0), Vector3::new(0.1, 0.0, 0.0));
            let mut prev_z: Option<Vector3<f64>> = None;
            let (mut t, mut next_fix) = (0.0, 1.0);
            while t < self.seconds {
                let v = Vector3::new(heading.cos(), heading.sin(), 0.0) * speed;
                let turned = heading + self.psi;
                let v_ins = Vector3::new(turned.cos(), turned.sin(), 0.0) * speed;
                p += v * step;
                v_err += self.accel_error * step;
                p_ins += (v_ins + v_err) * step;
                heading += omega(t) * step;
                t += step;
                n_step += 1;
                history[n_step % 512] = (p, v);
                if t + 1e-9 >= next_fix {
                    next_fix += 1.0 / self.rate;
                    let n = draw(self.sigma * self.noise_scale);
                    let jump = match self.jump_at {
                        Some(j) if (j..j + 2.0).contains(&t) => Vector3::new(30.0, 40.0, 0.0),
                        _ => Vector3::zeros(),
                    };
                    let (p_then, v_then) = history[(n_step - lag) % 512];
                    let z = p_ins - (p_then + n + jump);
                    let corrections = m.take_corrections();
                    m.fix(
                        &LatencyFix {
                            z_m: z,
                            r_m2: Vector3::repeat(self.sigma * self.sigma / 3.0),
                            accel_var: self.accel_sigma * self.accel_sigma,
                            correlated: None,
                            v_eb_n: v_ins + v_err,
                            dt_s: 1.0 / self.rate,
                            corrections,
                        },
                        &Vector3::zeros(),
                        &Vector3::zeros(),
                    );
                    let dv = prev_z.map_or(Vector3::zeros(), |p| (z - p) * self.rate * 0.3);
                    prev_z = Some(z * 0.5);
                    p_ins -= z * 0.5;
                    v_err -= dv;
                    m.corrected(&(z * 0.5), &dv, &Vector3::zeros(), 0.0);
                    if let Some(sigma_v) = self.sigma_v {
                        let z_v = v_ins + v_err - (v_then + draw(sigma_v));
                        m.velocity(&z_v, &Vector3::repeat(sigma_v * sigma_v / 3.0));
                        v_err -= z_v * 0.5;
                        m.corrected(&Vector3::zeros(), &(z_v * 0.5), &Vector3::zeros(), 0.0);
                    }
                    if self.retimes {
                        m.retime();
                    }
                }
            }
            m.estimate()
        }
    }

    /// [`Drive`] of fixes at `rate` [Hz], 1-sigma `sigma` [m], `tau` [s] late, the solution
    /// otherwise exact, the fixes off by 50 m for 2 s from `jump_at` [s]: the test finds
    /// `tau` within its 1-sigma, and nothing when the tags are right.
    fn run(
        tau: f64,
        sigma: f64,
        rate: f64,
        seconds: f64,
        jump_at: Option<f64>,
    ) -> LatencyEstimate<f64> {
        Drive {
            seconds,
            jump_at,
            ..Drive::new(tau, sigma, rate)
        }
        .run()
    }

    #[test]
    fn a_late_receiver_is_found_and_a_punctual_one_is_not() {
        let late = run(0.1, 0.1, 5.0, 300.0, None);
        assert!(late.detected, "{late:?}");
        assert!((late.late_s - 0.1).abs() < 4.0 * late.sigma_s, "{late:?}");
        let on_time = run(0.0, 0.1, 5.0, 300.0, None);
        assert!(!on_time.detected, "{on_time:?}");
        assert!(on_time.late_s.abs() < 4.0 * on_time.sigma_s, "{on_time:?}");
        // Code fixes of 3 m: 0.1 s is within their noise.
        let coarse = run(0.1, 3.0, 1.0, 300.0, None);
        assert!(!coarse.detected, "{coarse:?}");
    }

    /// Fixes noisier than declared (1.5 times): the windows' spread about the latency grows to
    /// about 2.25, beyond the test that finds one once there are many windows, but 0.1 s stays
    /// far beyond its 1-sigma widened by that spread: the retiming holds to the end (was:
    /// undone once the spread crossed the finding test's bound).
    #[test]
    fn a_latency_found_holds_when_its_windows_scatter() {
        let e = Drive {
            seconds: 600.0,
            noise_scale: 1.5,
            retimes: true,
            ..Drive::new(0.1, 0.1, 5.0)
        }
        .run();
        assert!(e.spread > 1.8, "{e:?}");
        assert!(e.detected, "{e:?}");
        assert!(
            (e.late_s - 0.1).abs() < 4.0 * e.sigma_s * e.spread.sqrt(),
            "{e:?}"
        );
    }

    #[test]
    fn a_steady_velocity_says_nothing() {
        let mut m = LatencyMonitor::<f64>::default();
        let v = Vector3::new(15.0, 0.0, 0.0);
        for _ in 0..20 {
            m.fix(
                &LatencyFix {
                    z_m: v * 0.2,
                    r_m2: Vector3::repeat(1e-4),
                    accel_var: 0.0,
                    correlated: None,
                    v_eb_n: v,
                    dt_s: 1.0,
                    corrections: Corrections::default(),
                },
                &Vector3::zeros(),
                &Vector3::zeros(),
            );
        }
        let e = m.estimate();
        assert_eq!(e.windows, 0);
        assert!(!e.detected && e.sigma_s.is_infinite(), "{e:?}");
        assert!(m.retime().is_none());
        assert_eq!(m.applied(), (0.0, 0.0));
    }

    /// A heading 3 deg off turns the solution's velocity change in each turn, as a latency of
    /// `psi / omega` (0.26 s at 0.2 rad/s) would move it: fitted per window, it is not taken
    /// for one, and a true latency is still found under it.
    #[test]
    fn a_heading_error_is_not_a_latency() {
        let psi = 3_f64.to_radians();
        let turned = |tau| {
            Drive {
                psi,
                ..Drive::new(tau, 0.1, 5.0)
            }
            .run()
        };
        let e = turned(0.0);
        assert!(!e.detected && e.late_s.abs() < 4.0 * e.sigma_s, "{e:?}");
        let late = turned(0.1);
        assert!(
            late.detected && (late.late_s - 0.1).abs() < 4.0 * late.sigma_s,
            "{late:?}"
        );
    }

    /// Once found, the fixes are retimed by the estimate, and the change's doubt is that of
    /// fixes `d` behind: `(d^2 + sigma^2) v v^T`; nothing moves again until the estimate
    /// does, and the reported doubt is the estimate's 1-sigma times the velocity.
    #[test]
    fn a_found_latency_retimes_the_fixes_once() {
        let mut m = LatencyMonitor::<f64> {
            information: 1e4,
            b: 0.2 * 1e4,
            last_v: Vector3::new(15.0, 0.0, 0.0),
            peak_a: Vector3::new(0.0, 2.0, 0.0),
            peak_w: Vector3::new(0.0, 0.0, 0.3),
            ..Default::default()
        };
        assert_eq!(m.applied(), (0.0, 0.0));
        assert!(m.retime().is_none() && !m.estimate().detected);
        m.passing = true;
        let (p, v, a) = m.retime().expect("detected: 0.2 s, 1-sigma 0.01 s");
        let k = 0.2 * 0.2 + 0.01 * 0.01;
        assert!(
            (p[(0, 0)] - k * 225.0).abs() < 1e-9 && p[(1, 1)] == 0.0,
            "{p}"
        );
        assert!((v[(1, 1)] - k * 4.0).abs() < 1e-9 && (a[(2, 2)] - k * 0.09).abs() < 1e-9);
        let (late, sigma) = m.applied();
        assert!((late - 0.2).abs() < 1e-12 && (sigma - 0.01).abs() < 1e-12);
        assert!(m.retime().is_none());
        let (dp, _) = m.doubt().unwrap();
        assert!((dp[(0, 0)] - 0.01 * 0.01 * 225.0).abs() < 1e-9, "{dp}");
        // A later window moves the estimate to 0.25 s: a change of 0.05 s.
        m.b = 0.25 * 1e4;
        let (p, _, _) = m.retime().unwrap();
        assert!(
            (p[(0, 0)] - (0.05 * 0.05 + 1e-4) * 225.0).abs() < 1e-9,
            "{p}"
        );
        // Failed at one window close: kept; at enough in a row: undone.
        (m.passing, m.failed) = (false, 1);
        assert!(m.retime().is_none() && m.applied().0 == 0.25);
        m.failed = UNDO_WINDOWS;
        let (p, _, _) = m.retime().unwrap();
        assert!(
            (p[(0, 0)] - (0.25 * 0.25 + 1e-4) * 225.0).abs() < 1e-9,
            "{p}"
        );
        assert_eq!(m.applied(), (0.0, 0.0));
    }

    /// A consumer part's fixes, 0.5 m and 0.05 m/s, 0.1 s late, with the solution's
    /// acceleration off by 0.05 m/s^2 (a tilt of 0.3 deg; its 1-sigma declared): the
    /// positions alone leave the latency within their noise; the velocities find it, and a
    /// solution whose acceleration is off is not a latency (the windows fit it as their
    /// nuisance, its prior the declared 1-sigma).
    #[test]
    fn velocity_fixes_find_a_latency_the_positions_leave_in_their_noise() {
        let drive = |tau, sigma_v| {
            Drive {
                sigma_v,
                accel_error: Vector3::new(0.03, -0.04, 0.0),
                accel_sigma: 0.05,
                ..Drive::new(tau, 0.5, 5.0)
            }
            .run()
        };
        let positions = drive(0.1, None);
        assert!(!positions.detected, "{positions:?}");
        let both = drive(0.1, Some(0.05));
        assert!(
            both.detected && (both.late_s - 0.1).abs() < 4.0 * both.sigma_s,
            "{both:?}"
        );
        assert!(
            both.sigma_s < 0.25 * positions.sigma_s,
            "{both:?} {positions:?}"
        );
        let on_time = drive(0.0, Some(0.05));
        assert!(
            !on_time.detected && on_time.late_s.abs() < 4.0 * on_time.sigma_s,
            "{on_time:?}"
        );
    }

    /// A 50 m jump in the fixes for 2 s: its windows are left out, and the punctual fixes
    /// stay punctual.
    #[test]
    fn a_jump_in_the_fixes_is_left_out() {
        let e = run(0.0, 0.1, 5.0, 300.0, Some(101.0));
        assert!(e.gross_windows >= 1, "{e:?}");
        assert!(!e.detected && e.late_s.abs() < 4.0 * e.sigma_s, "{e:?}");
    }
}
