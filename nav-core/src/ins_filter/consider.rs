//! Schmidt "consider" states [Schmidt, 1966]: the sensor errors the filter neither estimates
//! nor feeds back, but whose correlation with its error states it carries, so that their
//! effect on the navigation error is in the covariance exactly as the motion makes it:
//!
//! - the gyro and accelerometer cross-axis couplings (misalignments, six off-diagonal
//!   elements each: `M_g omega_ib_b`, `M_a f_ib_b`) and the gyro g-sensitivity (a full 3 x 3,
//!   `G_g f_ib_b`), constants of the IMU [Groves, §4.4.6]: the error each makes follows the
//!   motion, a constant unknown times what the IMU measures. At rest in the nominal attitude
//!   (body z down) they are constants the bias states absorb, so the specific force enters as
//!   its departure from rest `f_ib_b - (0, 0, -g)`, the body rate as it is (Earth rate left in:
//!   a part of 1e-5 of a car's turn);
//! - the gyros' bias instability, a Gauss–Markov process of a few seconds ([Groves, eq.
//!   14.80]): too short for a bias state to follow between fixes, too long to be white noise
//!   over the fixes' interval;
//! - the GNSS receiver's time-correlated position error (multipath, atmosphere: a first-order
//!   Gauss–Markov process per NED axis of a declared 1-sigma and correlation time,
//!   [`GnssCorrelatedError`]; [Groves, §14.3.2]), which only the position fixes see: a fix is
//!   `r_ant + b + v`, so the measurement "predicted minus measured" sees `-b` besides the
//!   error states ([`POSITION_SENSITIVITY`]). Unmodelled, a slow multipath ramp passes the
//!   gate fix by fix and the filter follows it with a sigma of the fixes' white noise.
//!
//! With `c` the consider states, the errors are `e_g = J_g c` on the gyros and `e_a = J_a c` on
//! the accelerometers ([`sensitivities`]), so they enter the error equations of
//! [`super::model`] as `d(dv)/dt += C_b_n J_a c` and `d(phi)/dt -= C_b_n J_g c`: the columns
//! `F_ac` of the system matrix. The consider states' covariance `P_cc` is diagonal and
//! constant (constants, and a Gauss–Markov process at its steady state, `Phi_cc P_cc Phi_cc
//! + Q_cc = P_cc`); the filter keeps `P_ac`, their cross-covariance with the error states.
//!
//! Propagation over `dt`, with `Phi_ac = F_ac dt + (F_aa F_ac + F_ac F_cc) dt^2 / 2` (the
//! second order of [`super::model`]), `X = Phi_aa P_ac`:
//! `P_aa <- (Phi_aa P_aa Phi_aa^T + Q) + X Phi_ac^T + Phi_ac X^T + Phi_ac P_cc Phi_ac^T`,
//! `P_ac <- (X + Phi_ac P_cc) Phi_cc^T`.
//!
//! Update of a scalar measurement `z = h^T x + h_c^T c + v` with gain `K` (the error states'
//! gain: the Schmidt filter gives the consider states none): `P_ac <- (I - K h^T) P_ac - K
//! h_c^T P_cc`; the gain and the error states' covariance are those of
//! [`crate::alignment::fine::kalman::update_scalar_correlated`] with the consider error `e =
//! h_c^T c` ([`consider_error`]: `u = P_ac h_c`, `var = h_c^T P_cc h_c`). Only the position
//! fixes' `h_c` is not zero (the GNSS error); the velocity fixes' lever-arm term `C (e_g x l)`
//! is neglected (1e-3 m/s for 1 m, a 0.1 deg misalignment and a 30 deg/s turn).

use super::covariance::{NAV, Transition};
use super::model::{FilterNoise, Linearisation};
use super::states::{ATT, BA, BG, Covariance, N, VEL};
use crate::Scalar;
use crate::alignment::fine::kalman::ConsiderError;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Gyro misalignment [rad]: six elements `(i, j)` of [`OFF_DIAGONAL`] (gyro `i` sees
/// `omega_j`).
pub const MG: usize = 0;
/// Gyro g-sensitivity [rad/s per m/s^2]: nine elements `(i, j)`, row after row (gyro `i` sees
/// the departure of `f_j` from rest).
pub const GS: usize = 6;
/// Accelerometer misalignment [rad]: six elements `(i, j)` of [`OFF_DIAGONAL`].
pub const MA: usize = 15;
/// Gyro bias instability (Gauss–Markov), per body axis [rad/s].
pub const GB: usize = 21;
/// GNSS position error (Gauss–Markov), north, east, down [m].
pub const GP: usize = 24;
/// Number of consider states.
pub const NC: usize = 27;

/// The position fixes' sensitivity to the GNSS error [`GP`] [-] (`z` is predicted minus
/// measured, the fix carries `+b`).
pub const POSITION_SENSITIVITY: f64 = -1.0;

/// A GNSS receiver's time-correlated position error: a first-order Gauss–Markov process per
/// NED axis [Groves, §14.3.2] (what a code receiver's multipath and atmosphere make; an RTK
/// receiver's is centimetres). Declared by the user; the fixes' own 1-sigma is the white part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssCorrelatedError<T: Scalar> {
    /// Steady-state 1-sigma, north, east, down [m].
    pub sigma_ned_m: nalgebra::Vector3<T>,
    /// Correlation time [s].
    pub correlation_time_s: T,
}

/// The off-diagonal elements `(row, column)` of a misalignment matrix, in the order of the
/// states: xy, xz, yx, yz, zx, zy.
pub const OFF_DIAGONAL: [(usize, usize); 6] = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)];

/// Rows of the system matrix the consider states reach: velocity and attitude.
const ROWS: usize = 6;
const _: () = assert!(ATT == VEL + 3 && ATT + 3 == NAV);

/// The specific force at rest whose cross-coupling errors the bias states hold [m/s^2]
/// (standard gravity: the local one differs by 0.3 %, a part of 1e-6 of gravity times a
/// misalignment of 1e-3).
const STANDARD_GRAVITY: f64 = 9.806_65;

/// The error states' cross-covariance with the consider states, `P_ac`.
pub type CrossCovariance<T> = SMatrix<T, N, NC>;

/// The consider states' model: their variances (the diagonal `P_cc`) and the bias
/// instability's correlation time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConsiderModel<T: Scalar> {
    variance: SVector<T, NC>,
    /// `1 / tau` of the bias instability [1/s] (zero when it is off).
    decay_rate: T,
    /// `1 / tau` of the GNSS error [1/s] (zero when it is off).
    gnss_decay_rate: T,
    active: bool,
}

impl<T: Scalar> ConsiderModel<T> {
    /// The model of a noise figure set: each misalignment element of 1-sigma
    /// `*_cross_coupling_rad`, each g-sensitivity element of `gyro_g_sensitivity`, the bias
    /// instability of `gyro_bias_instability_rad_s` and `gyro_bias_instability_time_s`; and
    /// the GNSS receiver's correlated error `gnss` (`None`: its fixes' errors are white).
    pub fn of(noise: &FilterNoise<T>, gnss: Option<&GnssCorrelatedError<T>>) -> Self {
        let sq = |v: T| v * v;
        let gm_on = noise.gyro_bias_instability_rad_s > T::zero()
            && noise.gyro_bias_instability_time_s > T::zero();
        let gnss = gnss.filter(|g| g.correlation_time_s > T::zero());
        let variance = SVector::<T, NC>::from_fn(|i, _| match i {
            i if i < GS => sq(noise.gyro_cross_coupling_rad),
            i if i < MA => sq(noise.gyro_g_sensitivity),
            i if i < GB => sq(noise.accel_cross_coupling_rad),
            i if i < GP && gm_on => sq(noise.gyro_bias_instability_rad_s),
            i if i < GP => T::zero(),
            i => gnss.map_or(T::zero(), |g| sq(g.sigma_ned_m[i - GP])),
        });
        let rate = |on: bool, tau: T| if on { T::one() / tau } else { T::zero() };
        Self {
            variance,
            decay_rate: rate(gm_on, noise.gyro_bias_instability_time_s),
            gnss_decay_rate: gnss.map_or(T::zero(), |g| T::one() / g.correlation_time_s),
            active: variance.iter().any(|v| *v > T::zero()),
        }
    }

    /// `1 / tau` of consider state `c` [1/s]: the bias instability's, the GNSS error's, zero
    /// for the constants.
    fn decay(&self, c: usize) -> T {
        match c {
            c if c >= GP => self.gnss_decay_rate,
            c if c >= GB => self.decay_rate,
            _ => T::zero(),
        }
    }

    /// What is left of a correlation with consider state `c` after `dt_s` [s] unpropagated:
    /// `exp(-dt / tau)`, here `1 / (1 + x + x^2 / 2)`, `x = dt / tau` (the same to second
    /// order, and towards zero, not negative, when `dt` is many `tau`); one for the constants.
    pub(crate) fn decay_over(&self, c: usize, dt_s: T) -> T {
        let x = self.decay(c) * dt_s;
        T::one() / (T::one() + x + x * x * T::c(0.5))
    }

    /// True when the GNSS error is modelled.
    pub fn has_gnss_error(&self) -> bool {
        self.gnss_decay_rate > T::zero()
    }

    /// The consider states a propagation moves: all [`NC`], or without a GNSS error the
    /// first [`GP`] (its columns of `P_ac` are zero and stay zero).
    pub fn columns(&self) -> usize {
        if self.has_gnss_error() { NC } else { GP }
    }

    /// True when any consider state has a variance (otherwise the filter skips them).
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// The variances `P_cc` [the states' units squared].
    pub fn variance(&self) -> &SVector<T, NC> {
        &self.variance
    }

    /// The bias instability's variance per axis [(rad/s)^2].
    pub fn gyro_bias_instability_variance(&self) -> T {
        self.variance[GB]
    }

    /// Variance of the change of the declared GNSS error between two fixes `dt_s` [s] apart,
    /// per NED axis [m^2]: `2 sigma^2 (1 - e^(-dt/tau))` of a first-order Gauss–Markov
    /// process [Groves, §14.3.2], bounded here by `2 sigma^2 min(dt/tau, 1)`; zero when the
    /// fixes are declared white.
    pub fn gnss_error_change_variance(&self, dt_s: T) -> Vector3<T> {
        let x = (dt_s * self.gnss_decay_rate).min(T::one()).max(T::zero());
        Vector3::from_fn(|k, _| T::c(2.0) * self.variance[GP + k] * x)
    }
}

/// The sensitivities `e_g = J_g c`, `e_a = J_a c` of the gyro and accelerometer errors to the
/// consider states at the linearisation point (module docs).
pub fn sensitivities<T: Scalar>(lin: &Linearisation<T>) -> (SMatrix<T, 3, NC>, SMatrix<T, 3, NC>) {
    let mut d_f = lin.f_ib_b;
    d_f.z += lin.earth.g;
    jacobians(&lin.omega_ib_b, &d_f, T::one())
}

/// `J_g`, `J_a` of a body rate `w` and specific force `f`; `gm` the bias instability's
/// sensitivity (one, or zero for the part at rest).
fn jacobians<T: Scalar>(
    w: &Vector3<T>,
    f: &Vector3<T>,
    gm: T,
) -> (SMatrix<T, 3, NC>, SMatrix<T, 3, NC>) {
    let mut j_g = SMatrix::<T, 3, NC>::zeros();
    let mut j_a = SMatrix::<T, 3, NC>::zeros();
    for (k, &(i, j)) in OFF_DIAGONAL.iter().enumerate() {
        j_g[(i, MG + k)] = w[j];
        j_a[(i, MA + k)] = f[j];
    }
    for i in 0..3 {
        for j in 0..3 {
            j_g[(i, GS + 3 * i + j)] = f[j];
        }
        j_g[(i, GB + i)] = gm;
    }
    (j_g, j_a)
}

/// The start of the consider states' correlation: the bias states hold, besides the sensors'
/// own biases, the cross-coupling errors at rest in the nominal attitude (`G_g f_rest`,
/// `M_a f_rest`, `f_rest = (0, 0, -g)` [m/s^2]; the gyro misalignment times Earth rate, a
/// part of 1e-7 rad/s, is left out). So the bias errors start with the variance `J_r P_cc
/// J_r^T` added and the cross-covariance `J_r P_cc`: with it, a specific force that leaves
/// rest changes the error by the same unknowns the biases hold a part of.
pub fn start<T: Scalar>(
    p: &mut Covariance<T>,
    p_ac: &mut CrossCovariance<T>,
    model: &ConsiderModel<T>,
) {
    let f_rest = Vector3::new(T::zero(), T::zero(), -T::c(STANDARD_GRAVITY));
    let (j_g, j_a) = jacobians(&Vector3::zeros(), &f_rest, T::zero());
    for (at, j) in [(BG, j_g), (BA, j_a)] {
        let mut j_p = j;
        for (c, mut col) in j_p.column_iter_mut().enumerate() {
            col *= model.variance[c];
        }
        p_ac.fixed_view_mut::<3, NC>(at, 0).copy_from(&j_p);
        let add = j_p * j.transpose();
        for r in 0..3 {
            for c in 0..3 {
                p[(at + r, at + c)] += add[(r, c)];
            }
        }
    }
}

/// `F_ac`: the velocity rows (`C_b_n J_a`) over the attitude rows (`-C_b_n J_g`).
fn system_columns<T: Scalar>(lin: &Linearisation<T>) -> SMatrix<T, ROWS, NC> {
    let (j_g, j_a) = sensitivities(lin);
    let mut f = SMatrix::<T, ROWS, NC>::zeros();
    f.fixed_view_mut::<3, NC>(0, 0)
        .copy_from(&(lin.c_b_n * j_a));
    f.fixed_view_mut::<3, NC>(3, 0)
        .copy_from(&(-(lin.c_b_n * j_g)));
    f
}

/// `Phi_ac = F_ac dt + (F_aa F_ac + F_ac F_cc) dt^2 / 2` over the navigation rows (the sensor
/// rows of `Phi_ac` are zero: their rows of `F` are diagonal), `f` the error states' system
/// matrix.
pub fn transition_columns<T: Scalar>(
    f: &Covariance<T>,
    lin: &Linearisation<T>,
    model: &ConsiderModel<T>,
    dt: T,
) -> SMatrix<T, NAV, NC> {
    let f_ac = system_columns(lin);
    let half_dt2 = dt * dt * T::c(0.5);
    let f_nav = f.fixed_view::<NAV, ROWS>(0, VEL);
    let mut phi = f_nav * f_ac * half_dt2;
    for c in 0..NC {
        let decay = -model.decay(c);
        for r in 0..ROWS {
            phi[(VEL + r, c)] += f_ac[(r, c)] * (dt + decay * half_dt2);
        }
    }
    phi
}

/// The consider part of a propagation (module docs): adds the consider terms to `p`, already
/// propagated (`Phi_aa P_aa Phi_aa^T + Q`), and moves `p_ac` over the interval. `phi` the
/// error states' transition, `phi_ac` the columns of [`transition_columns`].
///
/// Without a declared GNSS error ([`ConsiderModel::has_gnss_error`]) its columns of `P_ac`
/// (from [`GP`]) are zero and stay zero (no variance, no update reaches them): only the
/// first [`ConsiderModel::columns`] are moved by `Phi` and decayed. The fixed-size products
/// with `Phi_ac` run over all columns (its GNSS columns are zero whatever the model: the
/// dynamics do not reach that error); on the Cortex-M4 cutting them short, by hand-written
/// loops or a second instance of this function for fewer columns, cost more guest
/// instructions than it saved (QEMU, `f32`: 113,400 and 159,000 against 113,300).
pub fn propagate<T: Scalar>(
    p: &mut Covariance<T>,
    p_ac: &mut CrossCovariance<T>,
    phi: &Transition<T>,
    phi_ac: &SMatrix<T, NAV, NC>,
    model: &ConsiderModel<T>,
    dt: T,
) {
    let columns = model.columns();
    let x = phi.times(p_ac, columns);
    // X Phi_ac^T (N x NAV), mirrored into the rows and the columns of the navigation states.
    let a = x * phi_ac.transpose();
    let mut phi_p = *phi_ac;
    for (c, mut col) in phi_p.column_iter_mut().enumerate() {
        col *= model.variance[c];
    }
    let b = phi_p * phi_ac.transpose();
    for j in 0..NAV {
        for i in 0..N {
            let mut v = a[(i, j)];
            if i < NAV {
                v += a[(j, i)] + b[(i, j)];
                if i > j {
                    continue;
                }
                p[(i, j)] += v;
                if i != j {
                    p[(j, i)] += v;
                }
            } else {
                p[(i, j)] += v;
                p[(j, i)] += v;
            }
        }
    }
    for c in 0..columns {
        // exp(-dt / tau) to second order, as the error states' transition.
        let rate = model.decay(c);
        let d = T::one() - rate * dt + rate * rate * dt * dt * T::c(0.5);
        for i in 0..N {
            let extra = if i < NAV { phi_p[(i, c)] } else { T::zero() };
            p_ac[(i, c)] = (x[(i, c)] + extra) * d;
        }
    }
}

/// A scalar measurement's sensitivity to one consider state: `h_c = sensitivity e_at`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seen<T: Scalar> {
    /// The consider state ([`GP`] + axis).
    pub at: usize,
    /// `dz / dc` [-].
    pub sensitivity: T,
}

/// The consider error `e = h_c^T c` a scalar measurement sees ([`ConsiderError`]: `u = P_ac
/// h_c`, `var = h_c^T P_cc h_c`); `None` when it sees none or that state has no variance.
pub fn consider_error<T: Scalar>(
    p_ac: &CrossCovariance<T>,
    model: &ConsiderModel<T>,
    seen: Option<Seen<T>>,
) -> Option<ConsiderError<T, N>> {
    let s = seen.filter(|s| model.variance[s.at] > T::zero())?;
    Some(ConsiderError {
        u: p_ac.column(s.at) * s.sensitivity,
        var: s.sensitivity * s.sensitivity * model.variance[s.at],
    })
}

/// `P_ac <- P_ac - k (h^T P_ac + h_c^T P_cc)` of a scalar update with gain `k` (module docs).
pub fn update<T: Scalar>(
    p_ac: &mut CrossCovariance<T>,
    k: &SVector<T, N>,
    h: &SVector<T, N>,
    seen: Option<Seen<T>>,
    model: &ConsiderModel<T>,
) {
    let mut h_p = p_ac.tr_mul(h);
    if let Some(s) = seen {
        h_p[s.at] += s.sensitivity * model.variance[s.at];
    }
    for c in 0..NC {
        let hc = h_p[c];
        if hc == T::zero() {
            continue;
        }
        for i in 0..N {
            p_ac[(i, c)] -= k[i] * hc;
        }
    }
}

/// The consider errors of one set of values `c` on the gyros and accelerometers at `lin`
/// [rad/s, m/s^2] (for tests and simulations that inject them).
pub fn errors<T: Scalar>(lin: &Linearisation<T>, c: &SVector<T, NC>) -> (Vector3<T>, Vector3<T>) {
    let (j_g, j_a) = sensitivities(lin);
    (j_g * c, j_a * c)
}

/// A misalignment matrix's six elements in the order of [`OFF_DIAGONAL`].
pub fn off_diagonal<T: Scalar>(m: &Matrix3<T>) -> [T; 6] {
    OFF_DIAGONAL.map(|(i, j)| m[(i, j)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::LocalEarth;
    use crate::ins_filter::covariance;
    use crate::ins_filter::model;

    fn noise() -> FilterNoise<f64> {
        FilterNoise {
            arw_rad_per_sqrt_s: 1e-4,
            vrw_mps_per_sqrt_s: 1e-3,
            gyro_bias_rad_s: 1e-5,
            accel_bias_mps2: 1e-3,
            gyro_scale: 1e-4,
            accel_scale: 1e-4,
            correlation_time_s: 600.0,
            gyro_cross_coupling_rad: 1e-3,
            accel_cross_coupling_rad: 2e-3,
            gyro_g_sensitivity: 1e-5,
            gyro_bias_instability_rad_s: 3e-5,
            gyro_bias_instability_time_s: 6.0,
        }
    }

    fn lin() -> Linearisation<f64> {
        Linearisation {
            earth: LocalEarth::new(0.6, 250.0),
            v_eb_n: Vector3::new(20.0, -5.0, 0.3),
            c_b_n: *nalgebra::Rotation3::from_euler_angles(0.1, -0.05, 2.0).matrix(),
            f_ib_b: Vector3::new(0.8, -0.4, -9.7),
            omega_ib_b: Vector3::new(0.02, -0.01, 0.3),
        }
    }

    /// The sensitivities give the errors of the matrices they stand for: `M_g omega`,
    /// `G_g d_f + b`, `M_a d_f`.
    #[test]
    fn sensitivities_are_the_matrices_products() {
        let l = lin();
        let m_g = Matrix3::new(0.0, 1.0, 2.0, 3.0, 0.0, 4.0, 5.0, 6.0, 0.0) * 1e-3;
        let m_a = Matrix3::new(0.0, -2.0, 1.0, 4.0, 0.0, -3.0, 2.0, 5.0, 0.0) * 1e-3;
        let g_g = Matrix3::from_fn(|i, j| (i as f64 - 2.0 * j as f64) * 1e-5);
        let b = Vector3::new(1e-5, -2e-5, 3e-5);
        let mut c = SVector::<f64, NC>::zeros();
        for (k, v) in off_diagonal(&m_g).iter().enumerate() {
            c[MG + k] = *v;
        }
        for (k, v) in off_diagonal(&m_a).iter().enumerate() {
            c[MA + k] = *v;
        }
        for i in 0..3 {
            for j in 0..3 {
                c[GS + 3 * i + j] = g_g[(i, j)];
            }
            c[GB + i] = b[i];
        }
        let d_f = l.f_ib_b + Vector3::new(0.0, 0.0, l.earth.g);
        let (e_g, e_a) = errors(&l, &c);
        assert!((e_g - (m_g * l.omega_ib_b + g_g * d_f + b)).amax() < 1e-15);
        assert!((e_a - m_a * d_f).amax() < 1e-15);
    }

    /// The structured propagation is the dense one of the augmented state `[x; c]`:
    /// `Phi = I + F dt + (F dt)^2 / 2` with the consider columns in `F` and `F_cc` the bias
    /// instability's decay, `P_cc` held (its process noise keeps it at its steady state).
    #[test]
    fn structured_propagation_is_the_augmented_dense_formula() {
        const M: usize = N + NC;
        let n = noise();
        let l = lin();
        let model = ConsiderModel::of(&n, Some(&gnss()));
        let f = model::system_matrix(&l, &n, true);
        let q = model::noise_density(&n, true);
        let mut f_aug = SMatrix::<f64, M, M>::zeros();
        f_aug.fixed_view_mut::<N, N>(0, 0).copy_from(&f);
        f_aug
            .fixed_view_mut::<ROWS, NC>(VEL, N)
            .copy_from(&system_columns(&l));
        for i in 0..3 {
            f_aug[(N + GB + i, N + GB + i)] = -1.0 / n.gyro_bias_instability_time_s;
            f_aug[(N + GP + i, N + GP + i)] = -1.0 / gnss().correlation_time_s;
        }
        // A correlated start: P_ac from a dense positive definite augmented covariance.
        let lower = SMatrix::<f64, M, M>::from_fn(|i, j| match i.cmp(&j) {
            core::cmp::Ordering::Less => 0.0,
            core::cmp::Ordering::Equal => 0.1 + 0.01 * i as f64,
            core::cmp::Ordering::Greater => 0.02 * ((3 * i + 5 * j) as f64).sin(),
        });
        let full = lower * lower.transpose();
        let dt = 0.1;
        let mut p = full.fixed_view::<N, N>(0, 0).into_owned();
        let mut p_ac = full.fixed_view::<N, NC>(0, N).into_owned();
        let mut p_aug = full;
        p_aug
            .fixed_view_mut::<NC, NC>(N, N)
            .copy_from(&SMatrix::<f64, NC, NC>::from_diagonal(model.variance()));
        let phi_aug =
            SMatrix::<f64, M, M>::identity() + f_aug * dt + f_aug * f_aug * (dt * dt / 2.0);
        let mut q_aug = SVector::<f64, M>::zeros();
        q_aug.fixed_rows_mut::<N>(0).copy_from(&q);
        let qm = SMatrix::<f64, M, M>::from_diagonal(&q_aug);
        let dense = phi_aug * p_aug * phi_aug.transpose()
            + (phi_aug * qm * phi_aug.transpose() + qm) * (dt / 2.0);
        let phi = covariance::Transition::new(&f, dt);
        let phi_ac = transition_columns(&f, &l, &model, dt);
        covariance::propagate(&mut p, &phi, &q, dt);
        propagate(&mut p, &mut p_ac, &phi, &phi_ac, &model, dt);
        let scale = dense.amax();
        let e_aa = (p - dense.fixed_view::<N, N>(0, 0)).amax();
        let e_ac = (p_ac - dense.fixed_view::<N, NC>(0, N)).amax();
        assert!(e_aa < 1e-14 * scale, "{e_aa}");
        assert!(e_ac < 1e-14 * scale, "{e_ac}");
        assert_eq!(p, p.transpose());
    }

    /// Without a GNSS error the propagation over the first [`GP`] consider states gives, bit
    /// for bit, what the propagation of all [`NC`] gives (the skipped columns of `P_ac` are
    /// zero and stay zero).
    #[test]
    fn skipping_the_undeclared_gnss_error_changes_no_bit() {
        let n = noise();
        let l = lin();
        let model = ConsiderModel::of(&n, None);
        assert!(model.is_active() && !model.has_gnss_error());
        let f = model::system_matrix(&l, &n, true);
        let q = model::noise_density(&n, true);
        let dt = 0.1;
        let phi = covariance::Transition::new(&f, dt);
        let phi_ac = transition_columns(&f, &l, &model, dt);
        let lower = Covariance::<f64>::from_fn(|i, j| match i.cmp(&j) {
            core::cmp::Ordering::Less => 0.0,
            core::cmp::Ordering::Equal => 0.1 + 0.01 * i as f64,
            core::cmp::Ordering::Greater => 0.02 * ((3 * i + 5 * j) as f64).sin(),
        });
        let mut p = lower * lower.transpose();
        let mut p_ac = CrossCovariance::<f64>::zeros();
        start(&mut p, &mut p_ac, &model);
        // Correlations as the motion and the updates leave them, none with the GNSS error.
        for c in 0..GP {
            for i in 0..N {
                p_ac[(i, c)] += 1e-7 * ((7 * i + 11 * c) as f64).cos();
            }
        }
        let (mut p_all, mut p_ac_all) = (p, p_ac);
        // The same model, every column propagated (a GNSS error of zero variance).
        let mut all = model;
        all.gnss_decay_rate = 1.0 / 60.0;
        assert_eq!((model.columns(), all.columns()), (GP, NC));
        for _ in 0..3 {
            covariance::propagate(&mut p, &phi, &q, dt);
            propagate(&mut p, &mut p_ac, &phi, &phi_ac, &model, dt);
            covariance::propagate(&mut p_all, &phi, &q, dt);
            propagate(&mut p_all, &mut p_ac_all, &phi, &phi_ac, &all, dt);
        }
        let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same(p.as_slice(), p_all.as_slice()));
        assert!(same(p_ac.as_slice(), p_ac_all.as_slice()));
        assert!(p_ac.fixed_view::<N, 3>(0, GP).iter().all(|v| *v == 0.0));
    }

    fn gnss() -> GnssCorrelatedError<f64> {
        GnssCorrelatedError {
            sigma_ned_m: Vector3::new(1.0, 1.5, 2.5),
            correlation_time_s: 90.0,
        }
    }

    /// The update is the augmented Joseph update with the consider states' gain set to zero:
    /// of the error states and of their cross-covariance, for a measurement that sees a
    /// consider state (the GNSS error) and one that does not.
    #[test]
    fn update_is_the_schmidt_update() {
        use crate::alignment::fine::kalman::{ScalarUpdate, update_scalar_correlated};
        const M: usize = N + NC;
        let model = ConsiderModel::of(&noise(), Some(&gnss()));
        let lower = SMatrix::<f64, M, M>::from_fn(|i, j| match i.cmp(&j) {
            core::cmp::Ordering::Less => 0.0,
            core::cmp::Ordering::Equal => 0.5 + 0.01 * i as f64,
            core::cmp::Ordering::Greater => 0.05 * ((3 * i + 5 * j) as f64).sin(),
        });
        let mut full = lower * lower.transpose();
        // P_cc is the model's (diagonal).
        let scale = SMatrix::<f64, M, M>::from_fn(|i, j| match (i >= N, j >= N) {
            (true, true) => 0.0,
            _ => 1.0,
        });
        full = full.component_mul(&scale);
        for c in 0..NC {
            full[(N + c, N + c)] = model.variance()[c];
        }
        // Keep the augmented matrix positive definite: the cross block scaled to the P_cc.
        for c in 0..NC {
            let sd = model.variance()[c].sqrt();
            for i in 0..N {
                full[(i, N + c)] *= sd * 0.1;
                full[(N + c, i)] = full[(i, N + c)];
            }
        }
        let h =
            SVector::<f64, N>::from_fn(|i, _| [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3][i.min(7)]);
        for seen in [
            None,
            Some(Seen {
                at: GP + 1,
                sensitivity: POSITION_SENSITIVITY,
            }),
        ] {
            let mut ha = SVector::<f64, M>::zeros();
            ha.fixed_rows_mut::<N>(0).copy_from(&h);
            if let Some(s) = seen {
                ha[N + s.at] = s.sensitivity;
            }
            let r = 0.25;
            let mut ka = full * ha / (ha.dot(&(full * ha)) + r);
            ka.fixed_rows_mut::<NC>(N).fill(0.0);
            let i_kh = SMatrix::<f64, M, M>::identity() - ka * ha.transpose();
            let expected = i_kh * full * i_kh.transpose() + ka * ka.transpose() * r;
            let mut p = full.fixed_view::<N, N>(0, 0).into_owned();
            let mut p_ac = full.fixed_view::<N, NC>(0, N).into_owned();
            let e = consider_error(&p_ac, &model, seen);
            assert_eq!(e.is_some(), seen.is_some());
            let k = ConsiderError::gain(e.as_ref(), &p, &h, r).unwrap();
            let mut x = SVector::<f64, N>::zeros();
            let u = update_scalar_correlated(&mut x, &mut p, &h, e.as_ref(), 0.1, r, 1e9);
            assert_eq!(u, ScalarUpdate::Accepted);
            update(&mut p_ac, &k, &h, seen, &model);
            let e_aa = (p - expected.fixed_view::<N, N>(0, 0)).amax();
            let e_ac = (p_ac - expected.fixed_view::<N, NC>(0, N)).amax();
            assert!(e_aa < 1e-13, "{e_aa}");
            assert!(e_ac < 1e-13, "{e_ac}");
        }
    }

    #[test]
    fn nothing_is_active_without_figures() {
        let mut n = noise();
        assert!(ConsiderModel::of(&n, None).is_active());
        n.gyro_cross_coupling_rad = 0.0;
        n.accel_cross_coupling_rad = 0.0;
        n.gyro_g_sensitivity = 0.0;
        assert!(ConsiderModel::of(&n, None).is_active());
        n.gyro_bias_instability_time_s = 0.0;
        let m = ConsiderModel::of(&n, None);
        assert!(!m.is_active());
        assert!(!m.has_gnss_error());
        assert_eq!(m.gyro_bias_instability_variance(), 0.0);
        let m = ConsiderModel::of(&n, Some(&gnss()));
        assert!(m.is_active() && m.has_gnss_error());
    }

    /// Two fixes of a Gauss–Markov error differ by `2 sigma^2 dt / tau` in variance over a
    /// short interval, by no more than two independent draws over a long one, and not at all
    /// when the fixes are declared white.
    #[test]
    fn a_declared_error_changes_between_fixes() {
        let g = gnss();
        let m = ConsiderModel::of(&noise(), Some(&g));
        let short = m.gnss_error_change_variance(1.0);
        let long = m.gnss_error_change_variance(1e6);
        for k in 0..3 {
            let s2 = g.sigma_ned_m[k] * g.sigma_ned_m[k];
            assert!((short[k] - 2.0 * s2 / g.correlation_time_s).abs() < 1e-12);
            assert!((long[k] - 2.0 * s2).abs() < 1e-12);
        }
        let white = ConsiderModel::of(&noise(), None);
        assert_eq!(white.gnss_error_change_variance(1.0), Vector3::zeros());
    }
}
