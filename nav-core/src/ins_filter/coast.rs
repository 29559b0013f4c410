//! The coasting test: what the corrections moved the solution by since an anchor, against how
//! far the solution could have drifted had it coasted on its sensors alone since then
//! [Groves, ch. 17: integrity by comparing the aided solution with a coasting one].
//!
//! A slow GNSS fault (a multipath ramp) that the per-fix gate and the windowed test of
//! [`super::integrity`] let through is followed by the filter: every fix pulls it a little,
//! and its covariance, which those fixes shrank, says it is right. The inertial solution
//! itself was not told about the ramp. So every [`ANCHOR_SPACING_S`] an anchor is set, and from
//! it on the filter carries the difference between its solution and the one it would have had
//! without any correction since (the sum of the corrections fed back, each carried forward by
//! the error equations: a position correction as it is, a velocity correction times the time
//! since, an attitude or accelerometer correction as an acceleration, a gyro correction as a
//! jerk through the specific force; [`super::model`]).
//!
//! The coasting solution's error at the age `tau` of the anchor is the anchor's error carried
//! by the same equations, `dr + dv tau + a tau^2 / 2 + j tau^3 / 6`, with `a` and `j` the
//! acceleration and jerk errors the attitude and sensor errors give at the anchor's specific
//! force; its variance per axis comes from the anchor's covariance with all its correlations
//! (the tilt and the accelerometer bias an aided filter cannot tell apart cancel here), plus
//! the sensor noise over `tau` and, as bounds added to the 1-sigma, what a change of the
//! specific force since the anchor does with the attitude and cross-coupling errors, and what
//! the sensor corrections since the anchor beyond [`SENSOR_CHANGE_SIGMAS`] of its 1-sigma do
//! over its age (a sensor that changed beyond its error model, which the coasting solution
//! keeps and the fixes do not: a sensor's change, not a fault's pull). The
//! difference between the two solutions is the coasting error minus the filter's own; its
//! 1-sigma per axis is bounded by the sum of theirs (whatever their correlation). Over the
//! three axes the position difference, and the velocity difference, are tested against the
//! chi-square gate. Beyond it, the part of the differences beyond the gate's ellipsoid
//! (`beyond_gate`) is reported as a doubt on the position, velocity and attitude (`d d^T`,
//! as the pull of [`super::integrity`]), not given to the filter: its own covariance would
//! let the next fixes follow the fault further.
//!
//! The carried terms drop the Schuler, Coriolis and gravity-gradient couplings, which over the
//! [`ANCHOR_KEPT_S`] an anchor lives change them by below 3 %. An anchor is kept while it
//! fails (the fault's doubt lasts while the coasting can still tell), at most
//! [`ANCHOR_KEPT_S`]; a gap in the IMU data, bridged or lost, or a re-start of the solution
//! ends all anchors.

use super::integrity::beyond_gate;
use super::model::{FilterNoise, skew};
use super::states::{ATT, BA, BG, Covariance, N, POS, SA, SG, StateVector, VEL};
use crate::Scalar;
use nalgebra::{Matrix3, SMatrix, Vector3};

/// The anchors held at once.
pub const ANCHORS: usize = 6;
/// The time between two anchors [s]: the youngest is at most this old.
pub const ANCHOR_SPACING_S: f64 = 10.0;
/// The longest an anchor is kept while it fails [s] (one that passes is replaced after
/// [`ANCHORS`] times [`ANCHOR_SPACING_S`]).
pub const ANCHOR_KEPT_S: f64 = 120.0;

/// The test's gate: the chi-square(3) 99 % point. Each axis is judged against the sum of the
/// coasting's and the filter's own 1-sigma, a bound whatever their correlation, so without a
/// fault the difference passes it more often than 99 % of the time (over the consistency
/// bench's 360 runs it moved one cell's mean NEES by 0.01).
pub const GATE_3DOF: f64 = 11.345;

/// The sensor corrections since an anchor beyond this many of its 1-sigma are taken as the
/// sensor's change, not as the anchor's error (the coasting's 1-sigma allows for them;
/// module docs) [-].
pub const SENSOR_CHANGE_SIGMAS: f64 = 3.0;

/// The errors carried from an anchor: position, velocity, acceleration, jerk.
const TERMS: usize = 4;

/// The motion the error equations are taken at: attitude, compensated specific force and
/// body rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion<T: Scalar> {
    /// `C_b_n` [-].
    pub c_b_n: Matrix3<T>,
    /// `f_ib_b` [m/s^2].
    pub f_ib_b: Vector3<T>,
    /// `omega_ib_b` [rad/s].
    pub omega_ib_b: Vector3<T>,
}

impl<T: Scalar> Motion<T> {
    /// The acceleration error [m/s^2] and the jerk error [m/s^3] of the error state: the
    /// velocity rows of the error equations, `[f_n x] phi + C_b_n (b_a + diag(f_b) s_a)`, and
    /// `[f_n x]` times the attitude rows' sensor terms, `-C_b_n (b_g + diag(omega_b) s_g)`
    /// ([`super::model`]; [Groves, eqs. 14.63–14.71]).
    fn rows(&self, scale_factors: bool) -> [SMatrix<T, 3, N>; 2] {
        let f_n = self.c_b_n * self.f_ib_b;
        let f_x = skew(&f_n);
        let mut acc = SMatrix::<T, 3, N>::zeros();
        let mut jerk = SMatrix::<T, 3, N>::zeros();
        acc.fixed_view_mut::<3, 3>(0, ATT).copy_from(&f_x);
        acc.fixed_view_mut::<3, 3>(0, BA).copy_from(&self.c_b_n);
        let rate = -(f_x * self.c_b_n);
        jerk.fixed_view_mut::<3, 3>(0, BG).copy_from(&rate);
        if scale_factors {
            let sa = self.c_b_n * Matrix3::from_diagonal(&self.f_ib_b);
            acc.fixed_view_mut::<3, 3>(0, SA).copy_from(&sa);
            let sg = rate * Matrix3::from_diagonal(&self.omega_ib_b);
            jerk.fixed_view_mut::<3, 3>(0, SG).copy_from(&sg);
        }
        [acc, jerk]
    }
}

impl<T: Scalar> Motion<T> {
    /// The rates of a deviation of the solution: its acceleration [m/s^2] and its attitude
    /// rate [rad/s] from the attitude deviation `dphi` [rad] and the sensor deviations
    /// `[b_g, b_a, s_g, s_a]` (body frame), by the same error equations
    /// ([`Motion::rows`]) at this motion, whose specific force in NED is `f_n` [m/s^2].
    fn deviation_rates(
        &self,
        f_n: &Vector3<T>,
        dphi: &Vector3<T>,
        sensors: &[Vector3<T>; 4],
    ) -> (Vector3<T>, Vector3<T>) {
        let [bg, ba, sg, sa] = sensors;
        let acc = f_n.cross(dphi) + self.c_b_n * (ba + self.f_ib_b.component_mul(sa));
        let rate = -(self.c_b_n * (bg + self.omega_ib_b.component_mul(sg)));
        (acc, rate)
    }
}

/// One anchor: the coasting solution's error model from it and the solution's difference
/// from that coasting solution (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Anchor<T: Scalar> {
    age_s: T,
    /// Per axis, the covariance of the anchor's position, velocity, acceleration and jerk
    /// errors along it [m^2, m^2/s^2, ...].
    spread: [SMatrix<T, TERMS, TERMS>; 3],
    /// The specific force at the anchor, NED [m/s^2].
    f0_n: Vector3<T>,
    /// The attitude variances' sum at the anchor [rad^2].
    attitude_var_rad2: T,
    /// The largest specific force [m/s^2] and body rate [rad/s] since the anchor.
    f_max: T,
    omega_max: T,
    /// The angle turned since the anchor [rad], and the change of the specific force from the
    /// anchor's integrated over the time since [m/s].
    turned_rad: T,
    df_integral_m_s: T,
    /// The bound of the acceleration error the maneuvers since the anchor give (module
    /// docs), integrated once [m/s] and twice [m].
    maneuver_m_s: T,
    maneuver_m: T,
    /// The solution minus the coasting one, NED: position [m], velocity [m/s], attitude
    /// [rad]; and the sensor errors the corrections took out of the compensation since the
    /// anchor, body frame, negated (gyro bias [rad/s], accelerometer bias [m/s^2], gyro and
    /// accelerometer scale factors [-]), which act through the attitude and the specific force
    /// of the moment ([`Motion::deviation_rates`]).
    dr: Vector3<T>,
    dv: Vector3<T>,
    dphi: Vector3<T>,
    sensors: [Vector3<T>; 4],
    /// The anchor's attitude `C_b_n` [-].
    c0_b_n: Matrix3<T>,
    /// The 1-sigma per axis of the anchor's sensor errors, in the order of `sensors` (the
    /// norm of one: the square root of that covariance block's trace).
    sensor_sigma_axes: [Vector3<T>; 4],
    /// What the anchor's gyro bias, turned with the body away from the anchor's attitude,
    /// adds to the attitude error, a bound [rad].
    turned_bias_rad: T,
    /// Failed the test at the last judgement.
    failing: bool,
    /// The largest part of the position and of the velocity difference that lay beyond the
    /// gate at a judgement ([`beyond_gate`]): the evidence of a fault, kept while the
    /// anchor's coasting, growing less sure with its age, tells less.
    claimed: [T; 2],
}

impl<T: Scalar> Anchor<T> {
    fn new(p: &Covariance<T>, motion: &Motion<T>, scale_factors: bool) -> Self {
        let [acc, jerk] = motion.rows(scale_factors);
        let mut l = SMatrix::<T, { 3 * TERMS }, N>::zeros();
        for k in 0..3 {
            l[(k, POS + k)] = T::one();
            l[(3 + k, VEL + k)] = T::one();
        }
        l.fixed_view_mut::<3, N>(6, 0).copy_from(&acc);
        l.fixed_view_mut::<3, N>(9, 0).copy_from(&jerk);
        let lp = l * p;
        let spread = core::array::from_fn(|axis| {
            SMatrix::<T, TERMS, TERMS>::from_fn(|a, b| {
                lp.row(3 * a + axis).dot(&l.row(3 * b + axis))
            })
        });
        let f0_n = motion.c_b_n * motion.f_ib_b;
        Self {
            age_s: T::zero(),
            spread,
            f0_n,
            attitude_var_rad2: (0..3).fold(T::zero(), |s, k| s + p[(ATT + k, ATT + k)]),
            f_max: f0_n.norm(),
            omega_max: motion.omega_ib_b.norm(),
            turned_rad: T::zero(),
            df_integral_m_s: T::zero(),
            maneuver_m_s: T::zero(),
            maneuver_m: T::zero(),
            dr: Vector3::zeros(),
            dv: Vector3::zeros(),
            dphi: Vector3::zeros(),
            sensors: [Vector3::zeros(); 4],
            c0_b_n: motion.c_b_n,
            sensor_sigma_axes: [BG, BA, SG, SA]
                .map(|at| Vector3::from_fn(|k, _| p[(at + k, at + k)].max(T::zero()).sqrt())),
            turned_bias_rad: T::zero(),
            failing: false,
            claimed: [T::zero(); 2],
        }
    }

    /// Carried over `dt` [s] at `motion`, whose specific force in NED is `f_n` [m/s^2].
    fn carried(&mut self, dt: T, motion: &Motion<T>, f_n: &Vector3<T>, noise: &FilterNoise<T>) {
        let half = T::c(0.5);
        let (acc, rate) = motion.deviation_rates(f_n, &self.dphi, &self.sensors);
        self.dr += self.dv * dt + acc * (dt * dt * half);
        self.dv += acc * dt;
        self.dphi += rate * dt;
        self.age_s += dt;
        // What the error equations at the anchor's specific force and attitude leave out as
        // they change, a bound [m/s^2]: the attitude error (the anchor's, and what the gyros'
        // cross-coupling over the turned angle, their g-sensitivity over the change of the
        // specific force and their bias turned away from the anchor's attitude add) times the
        // change of the specific force; the accelerometers' cross-coupling times that change;
        // and their bias and scale factor turned away from the anchor's attitude (by `2
        // sin(theta / 2) = sqrt(3 - tr(C C0^T))` at most). The last three act through the
        // largest specific force as well.
        let df = (f_n - self.f0_n).norm();
        self.f_max = self.f_max.max(f_n.norm());
        self.omega_max = self.omega_max.max(motion.omega_ib_b.norm());
        self.turned_rad += motion.omega_ib_b.norm() * dt;
        self.df_integral_m_s += df * dt;
        let turn = (T::c(3.0) - motion.c_b_n.component_mul(&self.c0_b_n).sum())
            .max(T::zero())
            .sqrt();
        let [sigma_bg, sigma_ba, _, sigma_sa] = self.sensor_sigma_axes.map(|v| v.norm());
        self.turned_bias_rad += sigma_bg * turn * dt;
        let gained_rad = noise.gyro_cross_coupling_rad * self.turned_rad
            + noise.gyro_g_sensitivity * self.df_integral_m_s
            + self.turned_bias_rad;
        let acc = df
            * (self.attitude_var_rad2.sqrt() + gained_rad + noise.accel_cross_coupling_rad)
            + self.f_max * gained_rad
            + turn * (sigma_ba + sigma_sa * motion.f_ib_b.norm());
        self.maneuver_m += self.maneuver_m_s * dt + acc * (dt * dt * half);
        self.maneuver_m_s += acc * dt;
    }

    /// The correction `x` fed back (the solution moves by `-x`, carried as in the module
    /// docs).
    fn taken(&mut self, x: &StateVector<T>) {
        self.dr -= x.fixed_rows::<3>(POS);
        self.dv -= x.fixed_rows::<3>(VEL);
        self.dphi -= x.fixed_rows::<3>(ATT);
        for (s, at) in self.sensors.iter_mut().zip([BG, BA, SG, SA]) {
            *s -= x.fixed_rows::<3>(at);
        }
    }

    /// The 1-sigma per axis of the coasting solution's position [m] and velocity [m/s]
    /// errors at the anchor's age (module docs).
    fn coasting_sigma(&self, noise: &FilterNoise<T>) -> [Vector3<T>; 2] {
        let t = self.age_s;
        let (t2, t3) = (t * t, t * t * t);
        let half = T::c(0.5);
        let sixth = T::c(1.0 / 6.0);
        let pos = nalgebra::SVector::<T, TERMS>::new(T::one(), t, t2 * half, t3 * sixth);
        let vel = nalgebra::SVector::<T, TERMS>::new(T::zero(), T::one(), t, t2 * half);
        // The sensor noise over the age: velocity random walk, and the angle random walk
        // through the specific force, and the gyros' bias instability as a bias over it.
        let vrw2 = noise.vrw_mps_per_sqrt_s * noise.vrw_mps_per_sqrt_s;
        let arw2 = noise.arw_rad_per_sqrt_s * noise.arw_rad_per_sqrt_s;
        let f2 = self.f_max * self.f_max;
        let bi = self.f_max * noise.gyro_bias_instability_rad_s;
        let noise_pos = vrw2 * t3 * T::c(1.0 / 3.0)
            + f2 * arw2 * t2 * t3 * T::c(0.05)
            + (bi * t3 * sixth) * (bi * t3 * sixth);
        let noise_vel =
            vrw2 * t + f2 * arw2 * t3 * T::c(1.0 / 3.0) + (bi * t2 * half) * (bi * t2 * half);
        // The part of the sensor errors the corrections took out since the anchor beyond
        // [`SENSOR_CHANGE_SIGMAS`] of the anchor's 1-sigma, had it been there from the anchor
        // on (a bound over the attitudes and motions since): a sensor that changed beyond its
        // error model (a bias step) moves the coasting solution away by its own drift, which
        // the filter, following the fixes, rightly does not share; taken as a fault's pull it
        // was reported as 200 m of doubt on a solution 0.3 m off. What the corrections took
        // within the anchor's 1-sigma is the anchor's own error, which its spread carries
        // (a ramp the filter follows moves them so; all of it allowed for hid the ramp).
        let k = T::c(SENSOR_CHANGE_SIGMAS);
        let beyond = |at: usize| {
            (self.sensors[at].abs() - self.sensor_sigma_axes[at] * k)
                .map(|v| v.max(T::zero()))
                .norm()
        };
        let [bg, ba, sg, sa] = [0, 1, 2, 3].map(beyond);
        let acc = ba + self.f_max * sa;
        let jerk = self.f_max * (bg + self.omega_max * sg);
        let extra_pos = self.maneuver_m + acc * t2 * half + jerk * t3 * sixth;
        let extra_vel = self.maneuver_m_s + acc * t + jerk * t2 * half;
        let sigma = |c: &nalgebra::SVector<T, TERMS>, q: T, extra: T| {
            Vector3::from_fn(|axis, _| {
                let v = (c.transpose() * self.spread[axis] * c)[(0, 0)];
                (v.max(T::zero()) + q).sqrt() + extra
            })
        };
        [
            sigma(&pos, noise_pos, extra_pos),
            sigma(&vel, noise_vel, extra_vel),
        ]
    }

    /// The test's statistics over the position and velocity differences, each against the
    /// sum of the coasting and the filter's 1-sigma (`own`: the filter's position and velocity
    /// variances) per axis.
    fn statistics(&self, noise: &FilterNoise<T>, own: &[Vector3<T>; 2]) -> [T; 2] {
        let coasting = self.coasting_sigma(noise);
        let stat = |d: &Vector3<T>, c: &Vector3<T>, o: &Vector3<T>| {
            (0..3).fold(T::zero(), |s, i| {
                let sigma = c[i] + o[i].max(T::zero()).sqrt();
                s + d[i] * d[i] / (sigma * sigma)
            })
        };
        [
            stat(&self.dr, &coasting[0], &own[0]),
            stat(&self.dv, &coasting[1], &own[1]),
        ]
    }
}

/// The anchors and the doubt of the last judgement (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coast<T: Scalar> {
    anchors: [Option<Anchor<T>>; ANCHORS],
    /// Time since the last anchor was set [s].
    since_anchor_s: T,
    /// The doubt on the position [m^2], velocity [m^2/s^2] and attitude [rad^2] of the
    /// anchor that failed with the largest position difference, as at the last judgement.
    doubt: Option<[Matrix3<T>; 3]>,
}

impl<T: Scalar> Coast<T> {
    /// No anchor; the first is set [`ANCHOR_SPACING_S`] on, once fixes have told the filter
    /// something (one set on a start's covariance holds its sensor priors, and a bias the
    /// first fixes found at 2.4 sigma failed it while the solution was 0.2 m off).
    pub fn none() -> Self {
        Self {
            anchors: [None; ANCHORS],
            since_anchor_s: T::zero(),
            doubt: None,
        }
    }

    /// Carried over a propagation interval of `dt` [s] at `motion`; an anchor is set from
    /// the covariance `p` (propagated to the interval's end) when one is due.
    pub fn carried(
        &mut self,
        dt: T,
        motion: &Motion<T>,
        p: &Covariance<T>,
        noise: &FilterNoise<T>,
        scale_factors: bool,
    ) {
        let f_n = motion.c_b_n * motion.f_ib_b;
        for a in self.anchors.iter_mut().flatten() {
            a.carried(dt, motion, &f_n, noise);
        }
        self.since_anchor_s += dt;
        if self.since_anchor_s < T::c(ANCHOR_SPACING_S) {
            return;
        }
        // An empty slot, else the oldest anchor that passes (or failed beyond its time).
        let replaced = self.anchors.iter().position(Option::is_none).or_else(|| {
            let old = T::c(ANCHORS as f64 * ANCHOR_SPACING_S - 0.5 * ANCHOR_SPACING_S);
            let kept = T::c(ANCHOR_KEPT_S);
            self.anchors
                .iter()
                .enumerate()
                .filter_map(|(i, a)| a.as_ref().map(|a| (i, a)))
                .filter(|(_, a)| (a.age_s >= old && !a.failing) || a.age_s >= kept)
                .max_by(|x, y| {
                    x.1.age_s
                        .partial_cmp(&y.1.age_s)
                        .unwrap_or(core::cmp::Ordering::Equal)
                })
                .map(|(i, _)| i)
        });
        if let Some(i) = replaced {
            self.anchors[i] = Some(Anchor::new(p, motion, scale_factors));
            self.since_anchor_s = T::zero();
        }
    }

    /// The correction `x` fed back into the solution.
    pub fn taken(&mut self, x: &StateVector<T>) {
        for a in self.anchors.iter_mut().flatten() {
            a.taken(x);
        }
    }

    /// Judges every anchor against [`GATE_3DOF`] with the filter's covariance `p` now
    /// and keeps the doubt of the failing one with the largest position difference. A
    /// failing anchor claims the part of its differences beyond the gate (`beyond_gate`):
    /// one just beyond it, a sensor bias the corrections found drawn at 2.4 sigma, claims
    /// next to nothing (taken whole, it reported 40 m and 5.5 m/s of doubt and a DEGRADED
    /// status for 25 s on a solution 0.2 m off); it keeps the largest part it claimed while
    /// it fails.
    pub fn judged(&mut self, p: &Covariance<T>, noise: &FilterNoise<T>) {
        let gate = T::c(GATE_3DOF);
        let own = [POS, VEL].map(|at| Vector3::from_fn(|i, _| p[(at + i, at + i)]));
        let mut worst: Option<[Vector3<T>; 3]> = None;
        for a in self.anchors.iter_mut().flatten() {
            let [pos, vel] = a.statistics(noise, &own);
            a.failing = pos > gate || vel > gate;
            if !a.failing {
                continue;
            }
            for (k, stat) in a.claimed.iter_mut().zip([pos, vel]) {
                *k = k.max(beyond_gate(stat, gate));
            }
            let [k_pos, k_vel] = a.claimed;
            let d = [a.dr * k_pos, a.dv * k_vel, a.dphi * k_pos.max(k_vel)];
            if worst.is_none_or(|w| d[0].norm_squared() > w[0].norm_squared()) {
                worst = Some(d);
            }
        }
        self.doubt = worst.map(|w| w.map(|d| d * d.transpose()));
    }

    /// The doubt of the last judgement (module docs), if an anchor failed.
    pub fn doubt(&self) -> Option<[Matrix3<T>; 3]> {
        self.doubt
    }

    /// Every anchor ended (a gap in the IMU data, a re-start of the solution).
    pub fn clear(&mut self) {
        *self = Self::none();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ins_filter::model::{self, tests::lin, tests::noise};

    fn motion_of(l: &model::Linearisation<f64>) -> Motion<f64> {
        Motion {
            c_b_n: l.c_b_n,
            f_ib_b: l.f_ib_b,
            omega_ib_b: l.omega_ib_b,
        }
    }

    /// `Phi(tau) = exp(F tau)` by scaling and squaring of a third-order step.
    fn transition(f: &Covariance<f64>, tau: f64) -> Covariance<f64> {
        let a = f * (tau / 1024.0);
        let mut phi = Covariance::identity() + a + a * a / 2.0 + a * a * a / 6.0;
        for _ in 0..10 {
            phi = phi * phi;
        }
        phi
    }

    /// Deterministic pseudo-random numbers in [-1, 1].
    fn draws(seed: u64, n: usize) -> impl Iterator<Item = f64> {
        let mut s = seed;
        (0..n).map(move |_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        })
    }

    /// The scales of the states' errors: 1 m, 5 cm/s, 1 mrad, 2 deg/h, 1 mg, 100 ppm.
    fn scale(i: usize) -> f64 {
        [1.0, 0.05, 1e-3, 1e-5, 1e-2, 1e-4, 1e-4][i / 3]
    }

    /// A correction fed back moves the solution by minus it, carried forward as the error
    /// equations carry an error, here while the body turns at 0.05 rad/s (a bias taken out
    /// before the turn acts along the body's turned axes after it): after 40 s the anchor's
    /// differences are `-x` carried through the system matrix of each moment (the Schuler,
    /// Coriolis and Gauss–Markov terms the anchor drops change them by below 2 %).
    #[test]
    fn a_correction_is_carried_by_the_error_equations() {
        let quiet = noise();
        let at = |t: f64| {
            let mut l = lin(0.7, Vector3::new(12.0, -5.0, 0.3));
            l.c_b_n = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.05 * t).matrix()
                * l.c_b_n;
            l
        };
        let x = StateVector::from_iterator(draws(3, N).enumerate().map(|(i, d)| d * scale(i)));
        let mut a = Anchor::new(&Covariance::identity(), &motion_of(&at(0.0)), true);
        a.taken(&x);
        let mut moved = -x;
        let dt = 0.01;
        for k in 0..4000 {
            let l = at((k as f64 + 0.5) * dt);
            let f = model::system_matrix(&l, &quiet, true);
            // Second order per step: F changes slowly against the step.
            moved += (f * moved + f * (f * moved) * (dt / 2.0)) * dt;
            let m = motion_of(&l);
            a.carried(dt, &m, &(m.c_b_n * m.f_ib_b), &quiet);
        }
        for (got, at, what) in [
            (a.dr, POS, "position"),
            (a.dv, VEL, "velocity"),
            (a.dphi, ATT, "attitude"),
        ] {
            let want = moved.fixed_rows::<3>(at).into_owned();
            assert!(
                (got - want).norm() < 0.02 * want.norm(),
                "{what}: {got:?} against {want:?}"
            );
        }
    }

    /// The coasting 1-sigma without sensor noise is the error equations' transition over the
    /// anchor's covariance, correlations included: within 3 % of `Phi(tau) P Phi(tau)^T` at
    /// 10, 30 and 60 s for a covariance with strong correlations.
    #[test]
    fn the_coasting_sigma_is_the_anchors_covariance_carried() {
        let l = lin(0.7, Vector3::new(12.0, -5.0, 0.3));
        let quiet = FilterNoise {
            arw_rad_per_sqrt_s: 0.0,
            vrw_mps_per_sqrt_s: 0.0,
            ..noise()
        };
        let f = model::system_matrix(&l, &quiet, true);
        let r = SMatrix::<f64, N, N>::from_iterator(draws(7, N * N));
        let s = Covariance::from_diagonal(&StateVector::from_fn(|i, _| scale(i)));
        let p = s * (r * r.transpose() / N as f64 + Covariance::identity() * 0.05) * s;
        let motion = motion_of(&l);
        let mut a = Anchor::new(&p, &motion, true);
        let mut age = 0.0;
        for tau in [10.0, 30.0, 60.0] {
            while age < tau - 1e-9 {
                a.carried(0.01, &motion, &(l.c_b_n * l.f_ib_b), &quiet);
                age += 0.01;
            }
            let phi = transition(&f, tau);
            let exact = phi * p * phi.transpose();
            let [pos, vel] = a.coasting_sigma(&quiet);
            for i in 0..3 {
                for (got, at) in [(pos[i], POS), (vel[i], VEL)] {
                    let want = exact[(at + i, at + i)].sqrt();
                    assert!(
                        (got / want - 1.0).abs() < 0.03,
                        "{tau} s, state {}: {got} against {want}",
                        at + i
                    );
                }
            }
        }
    }

    /// A steady-state covariance of a navigation-grade filter: 10 cm, 5 mm/s, 20 urad of
    /// tilt and 0.1 mrad of heading, 0.01 deg/h, 25 ug.
    fn settled(tilt_rad: f64) -> Covariance<f64> {
        let sigma = [0.1, 0.005, tilt_rad, 5e-8, 2.5e-4, 1e-5, 1e-5];
        let mut p = Covariance::from_diagonal(&StateVector::from_fn(|i, _| sigma[i / 3].powi(2)));
        p[(ATT + 2, ATT + 2)] = 1e-8;
        p
    }

    /// Level and still: the error equations at rest.
    fn at_rest() -> Motion<f64> {
        Motion {
            c_b_n: Matrix3::identity(),
            f_ib_b: Vector3::new(0.0, 0.0, -9.8),
            omega_ib_b: Vector3::zeros(),
        }
    }

    /// A navigation-grade part's noise.
    fn fine_noise() -> FilterNoise<f64> {
        FilterNoise {
            arw_rad_per_sqrt_s: 1e-6,
            vrw_mps_per_sqrt_s: 1e-4,
            ..noise()
        }
    }

    /// `seconds` of 10 fixes a second, each moving the solution `step_m` [m] east, with the
    /// filter's covariance `p` throughout.
    fn fed(c: &mut Coast<f64>, p: &Covariance<f64>, step_m: f64, seconds: usize) {
        let mut x = StateVector::zeros();
        x[POS + 1] = -step_m;
        for _ in 0..seconds * 10 {
            for _ in 0..10 {
                c.carried(0.01, &at_rest(), p, &fine_noise(), true);
            }
            c.taken(&x);
            c.judged(p, &fine_noise());
        }
    }

    /// Fed back as a ramp the fixes pull the solution along (5 m east over 30 s in steps
    /// of 0.1 s) from an anchor set before it, the corrections fail the test of a
    /// navigation-grade anchor and are reported as doubt; no correction never fails; an
    /// anchor whose tilt is 50 times as uncertain (a MEMS part) cannot tell the same ramp
    /// from its own drift.
    #[test]
    fn a_ramp_the_solution_followed_fails_against_a_coasting_that_can_tell() {
        let run = |tilt_rad: f64, step_m: f64| {
            let mut c = Coast::none();
            fed(&mut c, &settled(tilt_rad), 0.0, ANCHOR_SPACING_S as usize);
            fed(&mut c, &settled(tilt_rad), step_m, 30);
            c.doubt()
        };
        // The part beyond the gate of the anchor that saw the whole ramp (78 %).
        let doubt = run(2e-5, 5.0 / 300.0).expect("the ramp fails");
        let east = doubt[0][(1, 1)].sqrt();
        assert!((3.5..=5.01).contains(&east), "{east} m east");
        assert!(run(2e-5, 0.0).is_none());
        assert!(run(1e-3, 5.0 / 300.0).is_none());
    }

    /// A sensor that changed (a step of 50 deg/h on a horizontal gyro) and the corrections
    /// that took the change out of the compensation at once: the solution moves away from
    /// the coasting one by the drift the change gives the coasting (25 m in 40 s, as a
    /// cube of the time), and that is not a fault's pull: no doubt. Was: the anchors failed
    /// and claimed the drift as doubt (200 m on a solution 0.3 m off).
    #[test]
    fn a_sensor_change_the_corrections_took_out_is_no_fault() {
        let p = settled(2e-5);
        let mut c = Coast::none();
        fed(&mut c, &p, 0.0, ANCHOR_SPACING_S as usize + 5);
        let mut x = StateVector::zeros();
        x[BG] = -(50.0f64 / 3600.0).to_radians();
        c.taken(&x);
        fed(&mut c, &p, 0.0, 40);
        let moved = c
            .anchors
            .iter()
            .flatten()
            .map(|a| a.dr.norm())
            .fold(0.0, f64::max);
        assert!(moved > 20.0, "{moved} m");
        assert!(c.doubt().is_none());
    }

    /// A position difference whose statistic is `k` times the gate claims the part of itself
    /// beyond the gate's ellipsoid, `1 - sqrt(1 / k)`: next to nothing just beyond it (a
    /// sensor bias the fixes found, drawn at 2.4 sigma against an anchor set at the start,
    /// was reported whole, 40 m of doubt on a solution 0.2 m off), nearly all far beyond it,
    /// and nothing within it.
    #[test]
    fn the_doubt_is_the_part_beyond_the_gate() {
        let p = settled(2e-5);
        let own = [POS, VEL].map(|at| Vector3::from_fn(|i, _| p[(at + i, at + i)]));
        let claimed = |k: f64| {
            let mut c = Coast::none();
            fed(&mut c, &p, 0.0, ANCHOR_SPACING_S as usize + 5);
            let mut one = StateVector::zeros();
            one[POS + 1] = -1.0;
            let mut probe = c.anchors[0].unwrap();
            probe.taken(&one);
            let per_m2 = probe.statistics(&fine_noise(), &own)[0];
            let east_m = (k * GATE_3DOF / per_m2).sqrt();
            c.taken(&(one * east_m));
            c.judged(&p, &fine_noise());
            c.doubt().map(|d| d[0][(1, 1)].sqrt() / east_m)
        };
        assert_eq!(claimed(0.9), None);
        for k in [1.2, 4.0, 100.0] {
            let part = claimed(k).expect("beyond the gate");
            let want = 1.0 - (1.0 / k).sqrt();
            assert!((part - want).abs() < 1e-9, "{k}: {part} against {want}");
        }
    }

    /// Anchors are replaced once [`ANCHORS`] times [`ANCHOR_SPACING_S`] old while they pass;
    /// one that fails is kept until [`ANCHOR_KEPT_S`], so the doubt of a fault the solution
    /// followed lasts beyond the minute; a gap ends every anchor and the doubt.
    #[test]
    fn a_failing_anchor_is_kept_and_a_gap_ends_all() {
        let p = settled(2e-5);
        let oldest = |c: &Coast<f64>| {
            c.anchors
                .iter()
                .flatten()
                .map(|a| a.age_s)
                .fold(0.0, f64::max)
        };
        let mut c = Coast::none();
        fed(&mut c, &p, 0.0, 200);
        assert!(c.doubt().is_none());
        assert!(
            oldest(&c) <= ANCHORS as f64 * ANCHOR_SPACING_S + 1e-6,
            "{}",
            oldest(&c)
        );
        // A 5 m ramp over 30 s, then nothing: the anchor from before it is kept, and the
        // part of the ramp it claimed with it, though its coasting now tells less.
        fed(&mut c, &p, 5.0 / 300.0, 30);
        let claimed = c.doubt().expect("the ramp fails")[0][(1, 1)].sqrt();
        fed(&mut c, &p, 0.0, 60);
        let east = c.doubt().expect("kept")[0][(1, 1)].sqrt();
        assert!(
            east > 3.5 && east >= claimed - 1e-9,
            "{east} m, {claimed} m claimed"
        );
        assert!(
            oldest(&c) > ANCHORS as f64 * ANCHOR_SPACING_S + 20.0,
            "{}",
            oldest(&c)
        );
        fed(&mut c, &p, 0.0, 60);
        assert!(
            oldest(&c) <= ANCHOR_KEPT_S + ANCHOR_SPACING_S,
            "{}",
            oldest(&c)
        );
        c.clear();
        assert!(c.doubt().is_none() && c.anchors.iter().all(Option::is_none));
    }
}
