//! The covariance propagation `P <- Phi P Phi^T + Q_d` of [`super::model`], computed over the
//! transition matrix's block structure.
//!
//! The sensor errors are first-order Gauss–Markov processes driven only by their own noise:
//! their rows of `F` hold the decay `-1 / tau` on the diagonal and nothing else, and so do
//! their rows of `Phi = I + F dt + (F dt)^2 / 2`. With the navigation states (position,
//! velocity, attitude) first and the sensor states after them,
//!
//! ```text
//! Phi = | A  B |      Phi P Phi^T = | Phi_n W    (D W_s)^T |      W = P Phi_n^T
//!       | 0  D |                    | D W_s      D P_ss D  |
//! ```
//!
//! with `Phi_n = [A B]` the navigation rows (full), `D` diagonal and `W_s` the sensor rows of
//! `W`: the navigation block is `Phi_n W`, the cross block `W_s` scaled by `D`, and
//! the sensor block is `P_ss` scaled by `d_i d_j`. The product `W = P Phi_n^T` (21 x 9) is
//! the only large one (about 4,000 multiply-adds, against 9,261 for one dense 21 x 21
//! product), in contiguous columns of fixed length. The process noise is the trapezoidal
//! `Q_d = (Phi Q_c Phi^T + Q_c) dt / 2` of the model: `P' = Phi (P + Q_c dt / 2) Phi^T +
//! Q_c dt / 2` (Groves eq. 3.46).

use super::states::{BG, Covariance, N, StateVector};
use crate::Scalar;
use nalgebra::{SMatrix, SVector};

/// Navigation error states (position, velocity, attitude): the full rows of `Phi`.
pub const NAV: usize = BG;
/// Sensor error states: their rows of `Phi` hold only the diagonal.
pub const SENSORS: usize = N - NAV;

/// `Phi = I + F dt + (F dt)^2 / 2` by its blocks (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transition<T: Scalar> {
    /// The navigation rows of `Phi`, transposed: column `i` is row `i` [-, or the states'
    /// unit ratios].
    nav_rows_t: SMatrix<T, N, NAV>,
    /// The diagonal of the sensor rows (their Gauss–Markov decay over `dt`) [-].
    decay: SVector<T, SENSORS>,
}

impl<T: Scalar> Transition<T> {
    /// The second-order transition over `dt` [s] of the system matrix `f` ([`super::model::
    /// system_matrix`]), whose sensor rows must be diagonal ([`sensor_rows_are_diagonal`]).
    pub fn new(f: &Covariance<T>, dt: T) -> Self {
        debug_assert!(sensor_rows_are_diagonal(f));
        let a = f * dt;
        let half = T::c(0.5);
        let cols = columns(&a);
        let mut nav_rows_t = SMatrix::<T, N, NAV>::zeros();
        for (j, a_j) in cols.iter().enumerate() {
            // Column j of (F dt)^2 over the navigation rows: a[:, k] a[k, j] over the
            // navigation states k, and for a sensor column j the one term a[:, j] a[j, j].
            let mut sq = [T::zero(); NAV];
            for (a_k, &a_kj) in cols.iter().zip(&a_j[..NAV]) {
                if a_kj == T::zero() {
                    continue;
                }
                for (s, &a_ik) in sq.iter_mut().zip(&a_k[..NAV]) {
                    *s += a_ik * a_kj;
                }
            }
            if j >= NAV {
                let a_jj = a_j[j];
                for (s, &a_ij) in sq.iter_mut().zip(&a_j[..NAV]) {
                    *s += a_ij * a_jj;
                }
            }
            for (i, (&s, &a_ij)) in sq.iter().zip(&a_j[..NAV]).enumerate() {
                let mut v = s * half + a_ij;
                if i == j {
                    v += T::one();
                }
                nav_rows_t[(j, i)] = v;
            }
        }
        let decay = SVector::<T, SENSORS>::from_fn(|s, _| {
            let d = a[(NAV + s, NAV + s)];
            d * d * half + d + T::one()
        });
        Self { nav_rows_t, decay }
    }

    /// `Phi m` for a matrix `m` of `N` rows (the consider states' cross-covariance,
    /// [`super::consider`]): the navigation rows full, the sensor rows scaled by their decay;
    /// of its first `cols` columns only (the others zero).
    pub fn times<const C: usize>(&self, m: &SMatrix<T, N, C>, cols: usize) -> SMatrix<T, N, C> {
        let mut out = SMatrix::<T, N, C>::zeros();
        let phi_rows = columns(&self.nav_rows_t);
        for c in 0..cols.min(C) {
            for (i, phi_i) in phi_rows.iter().enumerate() {
                let mut v = T::zero();
                for (k, &phi_ik) in phi_i.iter().enumerate() {
                    if phi_ik != T::zero() {
                        v += phi_ik * m[(k, c)];
                    }
                }
                out[(i, c)] = v;
            }
            for s in 0..SENSORS {
                out[(NAV + s, c)] = self.decay[s] * m[(NAV + s, c)];
            }
        }
        out
    }

    /// The whole `N x N` matrix.
    pub fn matrix(&self) -> Covariance<T> {
        let mut phi = Covariance::<T>::zeros();
        for i in 0..NAV {
            for j in 0..N {
                phi[(i, j)] = self.nav_rows_t[(j, i)];
            }
        }
        for s in 0..SENSORS {
            phi[(NAV + s, NAV + s)] = self.decay[s];
        }
        phi
    }
}

/// The columns of a matrix of `N` rows, as arrays (loops of a known length).
fn columns<T: Scalar, const C: usize>(m: &SMatrix<T, N, C>) -> &[[T; N]] {
    m.as_slice().as_chunks::<N>().0
}

/// True when the sensor rows of `f` hold nothing off the diagonal (the structure
/// [`Transition`] relies on).
pub fn sensor_rows_are_diagonal<T: Scalar>(f: &Covariance<T>) -> bool {
    (NAV..N).all(|i| (0..N).all(|j| i == j || f[(i, j)] == T::zero()))
}

/// `P <- Phi (P + Q_c dt / 2) Phi^T + Q_c dt / 2` in place (module docs); `q_c` the white
/// noise's spectral densities per state, `dt` [s]. Symmetric by construction (each value
/// computed once and mirrored).
pub fn propagate<T: Scalar>(
    p: &mut Covariance<T>,
    phi: &Transition<T>,
    q_c: &StateVector<T>,
    dt: T,
) {
    let half_dt = dt * T::c(0.5);
    for i in 0..N {
        p[(i, i)] += q_c[i] * half_dt;
    }
    // W = P Phi_n^T: column i gathers the columns k of P weighted by Phi[i, k].
    let mut w = SMatrix::<T, N, NAV>::zeros();
    {
        let p_cols = columns(p);
        let phi_rows = columns(&phi.nav_rows_t);
        let (w_cols, _) = w.as_mut_slice().as_chunks_mut::<N>();
        for (w_i, phi_i) in w_cols.iter_mut().zip(phi_rows) {
            for (p_k, &phi_ik) in p_cols.iter().zip(phi_i) {
                if phi_ik == T::zero() {
                    continue;
                }
                for (w_li, &p_lk) in w_i.iter_mut().zip(p_k) {
                    *w_li += p_lk * phi_ik;
                }
            }
        }
    }
    // Sensor block: d_s P_st d_t.
    let d = &phi.decay;
    for t in 0..SENSORS {
        for s in t..SENSORS {
            let v = d[s] * p[(NAV + s, NAV + t)] * d[t];
            p[(NAV + s, NAV + t)] = v;
            p[(NAV + t, NAV + s)] = v;
        }
    }
    // Cross block: the sensor rows of W scaled by D.
    for i in 0..NAV {
        for s in 0..SENSORS {
            let v = d[s] * w[(NAV + s, i)];
            p[(NAV + s, i)] = v;
            p[(i, NAV + s)] = v;
        }
    }
    // Navigation block: Phi_n W, the lower triangle mirrored.
    let (w_cols, phi_rows) = (columns(&w), columns(&phi.nav_rows_t));
    for (j, w_j) in w_cols.iter().enumerate() {
        for (i, phi_i) in phi_rows.iter().enumerate().skip(j) {
            let mut v = T::zero();
            for (&phi_il, &w_lj) in phi_i.iter().zip(w_j) {
                v += phi_il * w_lj;
            }
            p[(i, j)] = v;
            p[(j, i)] = v;
        }
    }
    for i in 0..N {
        p[(i, i)] += q_c[i] * half_dt;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::LocalEarth;
    use crate::ins_filter::model::{self, FilterNoise, Linearisation};
    use crate::ins_filter::states::SG;
    use nalgebra::{Matrix3, Vector3};

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
            accel_cross_coupling_rad: 1e-3,
            gyro_g_sensitivity: 1e-5,
            gyro_bias_instability_rad_s: 0.0,
            gyro_bias_instability_time_s: 0.0,
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

    /// A dense, correlated, positive definite covariance.
    fn covariance() -> Covariance<f64> {
        let l = Covariance::<f64>::from_fn(|i, j| match i.cmp(&j) {
            core::cmp::Ordering::Less => 0.0,
            core::cmp::Ordering::Equal => 0.1 + 0.01 * i as f64,
            core::cmp::Ordering::Greater => 0.02 * ((3 * i + 5 * j) as f64).sin(),
        });
        l * l.transpose()
    }

    #[test]
    fn sensor_rows_of_the_system_matrix_are_diagonal() {
        for scale_factors in [true, false] {
            let f = model::system_matrix(&lin(), &noise(), scale_factors);
            assert!(sensor_rows_are_diagonal(&f));
        }
        let mut f = model::system_matrix(&lin(), &noise(), true);
        f[(SG, 0)] = 1e-9;
        assert!(!sensor_rows_are_diagonal(&f));
    }

    /// The blocks give the dense formulas of the model: `Phi` and `Phi P Phi^T + Q_d`.
    #[test]
    fn structured_propagation_is_the_dense_formula() {
        for scale_factors in [true, false] {
            let f = model::system_matrix(&lin(), &noise(), scale_factors);
            let q = model::noise_density(&noise(), scale_factors);
            for dt in [0.005, 0.1, 1.0] {
                let dense_phi = Covariance::<f64>::identity() + f * dt + f * f * (dt * dt / 2.0);
                let phi = Transition::new(&f, dt);
                assert!((phi.matrix() - dense_phi).amax() < 1e-15);
                let mut p = covariance();
                let qm = Covariance::<f64>::from_diagonal(&q);
                let dense = dense_phi * p * dense_phi.transpose()
                    + (dense_phi * qm * dense_phi.transpose() + qm) * (dt / 2.0);
                let m = Covariance::<f64>::from_fn(|i, j| ((i * 3 + j) as f64).cos());
                assert!((phi.times(&m, N) - dense_phi * m).amax() < 1e-14);
                propagate(&mut p, &phi, &q, dt);
                let err = (p - dense).amax();
                assert!(err < 1e-14 * dense.amax(), "{err}");
                assert_eq!(p, p.transpose());
            }
        }
    }

    /// Scale factors off: their rows and columns stay zero.
    #[test]
    fn unmodelled_states_stay_zero() {
        let f = model::system_matrix(&lin(), &noise(), false);
        let q = model::noise_density(&noise(), false);
        let mut p = covariance();
        p.fixed_view_mut::<6, N>(SG, 0).fill(0.0);
        p.fixed_view_mut::<N, 6>(0, SG).fill(0.0);
        propagate(&mut p, &Transition::new(&f, 0.1), &q, 0.1);
        assert!(p.fixed_view::<6, N>(SG, 0).iter().all(|v| *v == 0.0));
        assert!(p.fixed_view::<N, 6>(0, SG).iter().all(|v| *v == 0.0));
        assert!(p.fixed_view::<3, 3>(0, 0) != Matrix3::zeros());
    }
}
