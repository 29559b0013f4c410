//! The process model of the navigation filter: the INS error equations in the NED frame, the
//! sensor errors as first-order Gauss–Markov processes, and their discretisation.
//!
//! Error states (all "computed minus true"), [`crate::ins_filter::states`]:
//! - `dr` position error, north, east, down [m]; `dv` velocity error [m/s];
//! - `phi` attitude error [rad]: the computed attitude is `C~_b_n = (I - [phi x]) C_b_n`
//!   (Groves' psi-angle form, §14.2.1);
//! - `b_g`, `b_a`, `s_g`, `s_a`: the errors left in the compensated gyro and accelerometer
//!   outputs: `omega~ = omega + b_g + diag(omega) s_g`, `f~ = f + b_a + diag(f) s_a`
//!   ([Berdinskikh et al., eqs. 3 and 8], the sensor model `(1 + m) x + b`).
//!
//! Continuous model `dx/dt = F x + G w` ([Groves, eqs. 14.63–14.71] written for NED position
//! errors in metres; [Berdinskikh et al., eq. 22] in the local-level frame: Schuler coupling
//! through the gravity and transport-rate terms, Earth rate, transport rate):
//! - `d(dr)/dt = F_rr dr + dv`, `F_rr` from differentiating `(R_N + h) dlat`,
//!   `(R_E + h) cos(lat) dlon`, `-dh`;
//! - `d(dv)/dt = [v x](2 W_ie + W_en_r) dr + ([v x] W_en_v - [(2 omega_ie + omega_en) x]) dv
//!   + [f_n x] phi + C_b_n (b_a + diag(f_b) s_a) + g_d dr_D + w_v`, with
//!   `g_d = 2 g / (R + h)` the vertical gravity gradient;
//! - `d(phi)/dt = (W_ie + W_en_r) dr + W_en_v dv - [(omega_ie + omega_en) x] phi
//!   - C_b_n (b_g + diag(omega_b) s_g) - w_phi`,
//!
//! where `W_ie = d omega_ie_n / d dr`, `W_en_r = d omega_en_n / d dr`,
//! `W_en_v = d omega_en_n / d dv`; the sensor errors decay as `-x / tau` driven by white noise
//! of density `2 sigma^2 / tau` (Groves eq. 14.80).
//!
//! Discretisation over the propagation interval `dt` (the increments accumulated in between):
//! `Phi = I + F dt + (F dt)^2 / 2` (second order; F at the interval's end, the specific force
//! and rate its means), `Q_d = (Phi Q_c Phi^T + Q_c) dt / 2` (trapezoidal, Groves eq. 3.46).
//! The filter computes both over the blocks of `Phi` ([`super::covariance`], whose tests hold
//! them to these dense formulas).

use super::states::{ATT, BA, BG, Covariance, N, POS, SA, SG, StateVector, VEL};
use crate::Scalar;
use crate::earth::{LocalEarth, OMEGA_IE};
use nalgebra::{Matrix3, Vector3};

/// The IMU's noise and sensor-error model, as the filter assumes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterNoise<T: Scalar> {
    /// Angle random walk [rad/sqrt(s)].
    pub arw_rad_per_sqrt_s: T,
    /// Velocity random walk [m/s/sqrt(s)].
    pub vrw_mps_per_sqrt_s: T,
    /// Gyro bias, stationary 1-sigma [rad/s].
    pub gyro_bias_rad_s: T,
    /// Accelerometer bias, stationary 1-sigma [m/s^2].
    pub accel_bias_mps2: T,
    /// Gyro scale-factor error, stationary 1-sigma [-].
    pub gyro_scale: T,
    /// Accelerometer scale-factor error, stationary 1-sigma [-].
    pub accel_scale: T,
    /// Correlation time of the Gauss–Markov bias and scale-factor processes [s].
    pub correlation_time_s: T,
    /// Gyro cross-axis coupling (misalignment), 1-sigma [rad]: not a state; its error
    /// `M omega` is covered by process noise on attitude and gyro bias while the body turns
    /// (see [`noise_density`]).
    pub gyro_cross_coupling_rad: T,
    /// Accelerometer cross-axis coupling (misalignment), 1-sigma [rad]: at rest a part of the
    /// bias; as the specific force leaves its value at rest, covered by process noise on
    /// velocity and accelerometer bias.
    pub accel_cross_coupling_rad: T,
    /// Gyro g-sensitivity, 1-sigma [rad/s per m/s^2]: at rest a part of the bias; as the
    /// specific force leaves its value at rest, covered by process noise on attitude and gyro
    /// bias.
    pub gyro_g_sensitivity: T,
}

/// What the error model is linearised about: the navigation solution at the end of the
/// propagation interval and the interval's mean sensor outputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linearisation<T: Scalar> {
    /// Earth quantities at the position.
    pub earth: LocalEarth<T>,
    /// Velocity `v_eb_n` [m/s].
    pub v_eb_n: Vector3<T>,
    /// Attitude `C_b_n` [-].
    pub c_b_n: Matrix3<T>,
    /// Mean compensated specific force `f_ib_b` [m/s^2].
    pub f_ib_b: Vector3<T>,
    /// Mean compensated body rate `omega_ib_b` [rad/s].
    pub omega_ib_b: Vector3<T>,
}

/// `[v x]`.
#[inline]
pub fn skew<T: Scalar>(v: &Vector3<T>) -> Matrix3<T> {
    crate::poisson::skew(v)
}

fn set_block<T: Scalar>(f: &mut Covariance<T>, row: usize, col: usize, m: &Matrix3<T>) {
    f.fixed_view_mut::<3, 3>(row, col).copy_from(m);
}

/// The continuous-time system matrix `F` (module docs). `scale_factors`: whether the
/// scale-factor states are modelled (off: their rows and columns stay zero).
pub fn system_matrix<T: Scalar>(
    lin: &Linearisation<T>,
    noise: &FilterNoise<T>,
    scale_factors: bool,
) -> Covariance<T> {
    let mut f = Covariance::<T>::zeros();
    let e = &lin.earth;
    let v = &lin.v_eb_n;
    let rn = e.r_meridian + e.h;
    let re = e.r_transverse + e.h;
    let s = e.sin_lat;
    // cos(lat) floored 1 cm from the pole (the NED frame's singularity).
    let c = e.cos2_lat.sqrt().max(T::c(1e-9));
    let t = s / c;
    let w = T::c(OMEGA_IE);
    let z = T::zero();

    // Partial derivatives of omega_ie_n and omega_en_n (Groves eqs. 2.123, 5.44) by the
    // position error (dlat = dr_N / (R_N + h), dh = -dr_D) and by the velocity error.
    let w_ie_r = Matrix3::new(-w * s / rn, z, z, z, z, z, -w * c / rn, z, z);
    let w_en_r = Matrix3::new(
        z,
        z,
        v.y / (re * re),
        z,
        z,
        -v.x / (rn * rn),
        -v.y / (re * c * c * rn),
        z,
        -v.y * t / (re * re),
    );
    let w_en_v = Matrix3::new(z, T::one() / re, z, -T::one() / rn, z, z, z, -t / re, z);
    let omega_ie_n = Vector3::new(w * c, z, -w * s);
    let omega_en_n = Vector3::new(v.y / re, -v.x / rn, -v.y * t / re);
    let v_x = skew(v);

    // Position.
    let f_rr = Matrix3::new(
        -v.z / rn,
        z,
        v.x / rn,
        v.y * t / rn,
        -(v.z / re + v.x * t / rn),
        v.y / re,
        z,
        z,
        z,
    );
    set_block(&mut f, POS, POS, &f_rr);
    set_block(&mut f, POS, VEL, &Matrix3::identity());

    // Velocity.
    let mut f_vr = v_x * (w_ie_r * T::c(2.0) + w_en_r);
    f_vr[(2, 2)] += T::c(2.0) * e.g / ((e.r_meridian * e.r_transverse).sqrt() + e.h);
    set_block(&mut f, VEL, POS, &f_vr);
    let f_vv = v_x * w_en_v - skew(&(omega_ie_n * T::c(2.0) + omega_en_n));
    set_block(&mut f, VEL, VEL, &f_vv);
    let f_n = lin.c_b_n * lin.f_ib_b;
    set_block(&mut f, VEL, ATT, &skew(&f_n));
    set_block(&mut f, VEL, BA, &lin.c_b_n);

    // Attitude.
    set_block(&mut f, ATT, POS, &(w_ie_r + w_en_r));
    set_block(&mut f, ATT, VEL, &w_en_v);
    set_block(&mut f, ATT, ATT, &(-skew(&(omega_ie_n + omega_en_n))));
    set_block(&mut f, ATT, BG, &(-lin.c_b_n));

    if scale_factors {
        set_block(
            &mut f,
            VEL,
            SA,
            &(lin.c_b_n * Matrix3::from_diagonal(&lin.f_ib_b)),
        );
        set_block(
            &mut f,
            ATT,
            SG,
            &(-(lin.c_b_n * Matrix3::from_diagonal(&lin.omega_ib_b))),
        );
    }

    // Sensor errors: first-order Gauss–Markov.
    let decay = -T::one() / noise.correlation_time_s;
    let last = if scale_factors { N } else { SG };
    for i in BG..last {
        f[(i, i)] = decay;
    }
    f
}

/// The time that splits a cross-coupling error into a short one, covered as white noise on
/// the integrated state, and a lasting one, covered as a random walk of the bias state [s].
pub const CROSS_COUPLING_TIME_S: f64 = 10.0;

/// The sensor errors that are not states, [Groves, §4.4.6]: `M_g omega_ib_b` and
/// `G_g f_ib_b` on the gyros, `M_a f_ib_b` on the accelerometers, each a fixed unknown matrix
/// times a quantity the IMU measures. At rest in the nominal attitude (body z down)
/// `f_ib_b = (0, 0, -g)` and `omega_ib_b` is Earth rate: there they are constants the bias
/// states absorb. What the bias states cannot hold is their change as the body moves, by
/// `d = omega_ib_b` for `M_g` (Earth rate left in: a part of 1e-5 of a car's turn) and
/// `d = f_ib_b - (0, 0, -g)` for `G_g`, `M_a` (a turn, a climb, a bank).
///
/// Per body axis `i` the error's variance is `m^2 (|d|^2 - d_i^2)` for a misalignment (its
/// row couples the two other axes, each element of 1-sigma `m`) and `k^2 |d|^2` for the
/// g-sensitivity (a full row of 1-sigma `k`): a car's yaw rate tilts, it does not turn the
/// heading. That change is covered two ways, so that a motion of any length is: over a
/// motion shorter than `T_c` ([`CROSS_COUPLING_TIME_S`]) the error `e` integrates into the
/// attitude or velocity, whose white noise `e^2 T_c` gives a variance `e^2 T_c t` at least the
/// error's `(e t)^2` for `t <= T_c`; a motion that lasts longer makes a new bias, reached by
/// the bias state's random walk `e_s^2 / T_c`, where `e_s` is the same error of the motion's
/// lasting part ([`SustainedMotion`]: `d` low-passed over `T_c`). The error of a short
/// motion (a car's turn, a braking) ends with the motion: it is not a bias, and giving it to
/// the bias states as one would keep its variance after the motion has gone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossCoupling<T: Scalar> {
    /// Gyro error variance per body axis [(rad/s)^2].
    pub gyro_b: Vector3<T>,
    /// Accelerometer error variance per body axis [(m/s^2)^2].
    pub accel_b: Vector3<T>,
}

impl<T: Scalar> CrossCoupling<T> {
    /// The variances at the linearisation point (type docs).
    pub fn at(noise: &FilterNoise<T>, lin: &Linearisation<T>) -> Self {
        Self::of(noise, &lin.omega_ib_b, &departure_from_rest(lin))
    }

    /// The variances of a body rate `omega_ib_b` [rad/s] and a specific-force departure from
    /// rest `d_f_b` [m/s^2] (type docs).
    pub fn of(noise: &FilterNoise<T>, omega_ib_b: &Vector3<T>, d_f_b: &Vector3<T>) -> Self {
        let (w, d_f) = (omega_ib_b, d_f_b);
        let (w2, f2) = (w.norm_squared(), d_f.norm_squared());
        let (m_g2, m_a2) = (
            noise.gyro_cross_coupling_rad * noise.gyro_cross_coupling_rad,
            noise.accel_cross_coupling_rad * noise.accel_cross_coupling_rad,
        );
        let k2 = noise.gyro_g_sensitivity * noise.gyro_g_sensitivity;
        Self {
            gyro_b: Vector3::from_fn(|i, _| m_g2 * (w2 - w[i] * w[i]) + k2 * f2),
            accel_b: Vector3::from_fn(|i, _| m_a2 * (f2 - d_f[i] * d_f[i])),
        }
    }
}

/// The specific force's departure from its value at rest in the nominal attitude,
/// `f_ib_b - (0, 0, -g)` [m/s^2].
fn departure_from_rest<T: Scalar>(lin: &Linearisation<T>) -> Vector3<T> {
    let mut d_f = lin.f_ib_b;
    d_f.z += lin.earth.g;
    d_f
}

/// The lasting part of the motion that the cross-coupling errors follow: the body rate and
/// the specific force's departure from rest, each low-passed over [`CROSS_COUPLING_TIME_S`]
/// (first order, `x <- x + (d - x) dt / (T_c + dt)`, stable for any interval). A motion much
/// shorter than `T_c` leaves it near zero; one that lasts several `T_c` brings it to the
/// motion's value ([`CrossCoupling`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SustainedMotion<T: Scalar> {
    /// Low-passed body rate `omega_ib_b` [rad/s].
    pub omega_ib_b: Vector3<T>,
    /// Low-passed departure of `f_ib_b` from rest [m/s^2].
    pub d_f_b: Vector3<T>,
}

impl<T: Scalar> Default for SustainedMotion<T> {
    fn default() -> Self {
        Self {
            omega_ib_b: Vector3::zeros(),
            d_f_b: Vector3::zeros(),
        }
    }
}

impl<T: Scalar> SustainedMotion<T> {
    /// Adds a propagation interval `dt` [s] whose mean motion `lin` gives.
    pub fn add(&mut self, lin: &Linearisation<T>, dt: T) {
        let a = dt / (T::c(CROSS_COUPLING_TIME_S) + dt);
        self.omega_ib_b += (lin.omega_ib_b - self.omega_ib_b) * a;
        self.d_f_b += (departure_from_rest(lin) - self.d_f_b) * a;
    }

    /// The cross-coupling variances of this lasting motion.
    pub fn cross_coupling(&self, noise: &FilterNoise<T>) -> CrossCoupling<T> {
        CrossCoupling::of(noise, &self.omega_ib_b, &self.d_f_b)
    }
}

/// A diagonal bound in the NED frame of the body-frame diagonal covariance `diag(q_b)`:
/// `Q = C_b_n diag(q_b) C_b_n^T` less its off-diagonal terms would not bound it, so each row's
/// absolute sum is taken (the difference is then diagonally dominant, so positive
/// semi-definite); for a level body and `q_x = q_y` it is `Q` itself.
fn diagonal_bound_ned<T: Scalar>(c_b_n: &Matrix3<T>, q_b: &Vector3<T>) -> Vector3<T> {
    let q = c_b_n * Matrix3::from_diagonal(q_b) * c_b_n.transpose();
    Vector3::from_fn(|k, _| (0..3).fold(T::zero(), |sum, j| sum + q[(k, j)].abs()))
}

/// Spectral densities of the driving white noise, per state (diagonal of `G Q G^T`):
/// `vrw^2` on velocity, `arw^2` on attitude (isotropic, so the rotation `C_b_n` drops out),
/// `2 sigma^2 / tau` on each Gauss–Markov state ([Groves, eq. 14.80]), and the cross-coupling
/// errors that are not states ([`CrossCoupling`]): `e^2 T_c` on attitude (gyro) or velocity
/// (accelerometer), resolved in NED (a diagonal bound), and `e_s^2 / T_c` of the lasting
/// motion `sustained` on the gyro or accelerometer bias, per body axis.
pub fn noise_density<T: Scalar>(
    noise: &FilterNoise<T>,
    scale_factors: bool,
    lin: &Linearisation<T>,
    sustained: &SustainedMotion<T>,
) -> StateVector<T> {
    let mut q = StateVector::<T>::zeros();
    let two_over_tau = T::c(2.0) / noise.correlation_time_s;
    let gm = |sigma: T| sigma * sigma * two_over_tau;
    let t_c = T::c(CROSS_COUPLING_TIME_S);
    let c = CrossCoupling::at(noise, lin);
    let lasting = sustained.cross_coupling(noise);
    let att = diagonal_bound_ned(&lin.c_b_n, &c.gyro_b);
    let vel = diagonal_bound_ned(&lin.c_b_n, &c.accel_b);
    let arw2 = noise.arw_rad_per_sqrt_s * noise.arw_rad_per_sqrt_s;
    let vrw2 = noise.vrw_mps_per_sqrt_s * noise.vrw_mps_per_sqrt_s;
    for k in 0..3 {
        q[VEL + k] = vrw2 + vel[k] * t_c;
        q[ATT + k] = arw2 + att[k] * t_c;
        q[BG + k] = gm(noise.gyro_bias_rad_s) + lasting.gyro_b[k] / t_c;
        q[BA + k] = gm(noise.accel_bias_mps2) + lasting.accel_b[k] / t_c;
        if scale_factors {
            q[SG + k] = gm(noise.gyro_scale);
            q[SA + k] = gm(noise.accel_scale);
        }
    }
    q
}

const _: () = assert!(N.is_multiple_of(7));

/// True when no element is NaN or infinite: `x * 0` is `0` for a finite `x` and NaN for any
/// other, summed in 7 independent lanes (21 x 21 = 63 x 7; no carried dependency of one sum
/// over 441 additions, no overflow).
pub(crate) fn all_finite<T: Scalar>(m: &Covariance<T>) -> bool {
    let mut lanes = [T::zero(); 7];
    for chunk in m.as_slice().chunks_exact(7) {
        for (lane, x) in lanes.iter_mut().zip(chunk) {
            *lane += *x * T::zero();
        }
    }
    lanes.iter().all(|lane| *lane == T::zero())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ins_filter::states::N;

    fn noise() -> FilterNoise<f64> {
        FilterNoise {
            arw_rad_per_sqrt_s: 1e-4,
            vrw_mps_per_sqrt_s: 1e-3,
            gyro_bias_rad_s: 1e-5,
            accel_bias_mps2: 1e-3,
            gyro_scale: 1e-4,
            accel_scale: 1e-4,
            correlation_time_s: 3600.0,
            gyro_cross_coupling_rad: 0.0,
            accel_cross_coupling_rad: 0.0,
            gyro_g_sensitivity: 0.0,
        }
    }

    fn lin(lat: f64, v: Vector3<f64>) -> Linearisation<f64> {
        Linearisation {
            earth: LocalEarth::new(lat, 100.0),
            v_eb_n: v,
            c_b_n: *nalgebra::Rotation3::from_euler_angles(0.1, -0.05, 1.0).matrix(),
            f_ib_b: Vector3::new(0.3, -0.2, -9.8),
            omega_ib_b: Vector3::new(0.01, 0.02, -0.03),
        }
    }

    /// Position-error kinematics checked against finite differences of the exact relation
    /// between a perturbed (lat, lon, h, v) and its NED offset.
    #[test]
    fn position_rows_match_finite_differences_of_the_kinematics() {
        let lat = 0.7;
        let h = 100.0;
        let v = Vector3::new(12.0, -7.0, 0.5);
        let l = lin(lat, v);
        let f = system_matrix(&l, &noise(), true);
        // d/dt of the NED offset between a true point and one displaced by dr, both moving:
        // the true with v, the displaced with v + dv.
        // The radii of curvature held at the nominal latitude: the model neglects their
        // gradient (a relative e^2 effect on terms of order v dr / R).
        let e0 = LocalEarth::new(lat, 0.0);
        let rates = |lat: f64, h: f64, v: &Vector3<f64>| {
            (
                v.x / (e0.r_meridian + h),
                v.y / ((e0.r_transverse + h) * lat.cos()),
                -v.z,
            )
        };
        let e = LocalEarth::new(lat, h);
        let dr = Vector3::new(3.0, -2.0, 1.5);
        let dlat = dr.x / (e.r_meridian + h);
        let dlon = dr.y / ((e.r_transverse + h) * lat.cos());
        let dh = -dr.z;
        let (lat_r, lon_r, h_r) = rates(lat, h, &v);
        let (lat_r2, lon_r2, h_r2) = rates(lat + dlat, h + dh, &v);
        // d(dr_N)/dt = d/dt[(R_N + h)(lat2 - lat)] etc. at fixed dr: the rates' difference
        // scaled, plus the radii's own change (dh/dt terms).
        let e2 = LocalEarth::new(lat, h);
        let d_n = (lat_r2 - lat_r) * (e2.r_meridian + h) + dlat * h_r;
        let d_e = (lon_r2 - lon_r) * (e2.r_transverse + h) * lat.cos()
            + dlon * (h_r * lat.cos() - (e2.r_transverse + h) * lat.sin() * lat_r);
        let d_d = -(h_r2 - h_r);
        let model = f.fixed_view::<3, 3>(POS, POS) * dr;
        let exact = Vector3::new(d_n, d_e, d_d);
        assert!(
            (model - exact).norm() < 1e-4 * exact.norm() + 1e-12,
            "{model} vs {exact}"
        );
    }

    #[test]
    fn schuler_period_of_the_horizontal_channel() {
        // At rest, level, no Earth rate coupling beyond the model: the eigenvalues of the
        // north channel (dr_N, dv_N, phi_E) give the Schuler frequency sqrt(g / R).
        let l = Linearisation {
            earth: LocalEarth::new(0.5, 0.0),
            v_eb_n: Vector3::zeros(),
            c_b_n: Matrix3::identity(),
            f_ib_b: Vector3::new(0.0, 0.0, -LocalEarth::new(0.5, 0.0).g),
            omega_ib_b: Vector3::zeros(),
        };
        let f = system_matrix(&l, &noise(), true);
        // dv_N' = -g phi_E ; phi_E' = -dv_N / R_N (plus Earth-rate terms of 1e-5 rad/s):
        let a = f[(VEL, ATT + 1)] * f[(ATT + 1, VEL)];
        let period_min = 2.0 * core::f64::consts::PI / (-a).sqrt() / 60.0;
        assert!((period_min - 84.4).abs() < 0.3, "{period_min}");
    }

    /// The cross-coupling noise is zero at rest in the nominal attitude (where the errors are
    /// biases the states hold) and, in a 30 deg bank, is sized by the specific force's
    /// departure from `(0, 0, -g)`: white noise `e^2 T_c` on attitude and velocity at once, a
    /// random walk on the biases only as the bank lasts (`e^2 / T_c` once it has lasted many
    /// `T_c`, a part of 1e-3 of that after one second).
    #[test]
    fn cross_coupling_noise_follows_the_departure_from_rest() {
        let mut n = noise();
        n.gyro_cross_coupling_rad = 2e-3;
        n.accel_cross_coupling_rad = 1e-3;
        n.gyro_g_sensitivity = 1e-4;
        let earth = LocalEarth::new(0.5, 0.0);
        let g = earth.g;
        let rest = Linearisation {
            earth,
            v_eb_n: Vector3::zeros(),
            c_b_n: Matrix3::identity(),
            f_ib_b: Vector3::new(0.0, 0.0, -g),
            omega_ib_b: Vector3::zeros(),
        };
        let still = SustainedMotion::default();
        let base = noise_density(&noise(), true, &rest, &still);
        assert_eq!(noise_density(&n, true, &rest, &still), base);
        let bank = 30f64.to_radians();
        let turn = Linearisation {
            f_ib_b: Vector3::new(0.0, 0.0, -g / bank.cos()),
            omega_ib_b: Vector3::new(0.0, 0.0, 0.1),
            ..rest
        };
        let d_f = g / bank.cos() - g;
        let c = CrossCoupling::at(&n, &turn);
        // Yaw rate couples into x and y, the vertical departure into x and y (misalignment)
        // and into every gyro (g-sensitivity).
        let k2 = (1e-4 * d_f).powi(2);
        let gyro = Vector3::new(
            (2e-3f64 * 0.1).powi(2) + k2,
            (2e-3f64 * 0.1).powi(2) + k2,
            k2,
        );
        let accel = Vector3::new((1e-3 * d_f).powi(2), (1e-3 * d_f).powi(2), 0.0);
        assert!((c.gyro_b - gyro).amax() < 1e-20, "{c:?}");
        assert!((c.accel_b - accel).amax() < 1e-20, "{c:?}");
        let t_c = CROSS_COUPLING_TIME_S;
        let rel = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * b.abs() + 1e-30;
        // One second into the bank, then twenty time constants.
        let (mut brief, mut lasting) = (still, still);
        for _ in 0..10 {
            brief.add(&turn, 0.1);
        }
        for _ in 0..(200.0 * t_c) as usize {
            lasting.add(&turn, 0.1);
        }
        let q = noise_density(&n, true, &turn, &lasting);
        let q_brief = noise_density(&n, true, &turn, &brief);
        for k in 0..3 {
            // Level body: the NED diagonal is the body one.
            assert!(rel(q[ATT + k] - base[ATT + k], gyro[k] * t_c, 1e-12), "{k}");
            assert!(
                rel(q[VEL + k] - base[VEL + k], accel[k] * t_c, 1e-12),
                "{k}"
            );
            assert_eq!(q_brief[ATT + k], q[ATT + k]);
            assert!(rel(q[BG + k] - base[BG + k], gyro[k] / t_c, 1e-6), "{k}");
            assert!(rel(q[BA + k] - base[BA + k], accel[k] / t_c, 1e-6), "{k}");
            // (1 - e^(-1 s / T_c))^2 of the lasting walk, about 1/110.
            assert!(
                q_brief[BG + k] - base[BG + k] <= gyro[k] / t_c / 100.0,
                "{k}"
            );
            assert!(
                q_brief[BA + k] - base[BA + k] <= accel[k] / t_c / 100.0,
                "{k}"
            );
        }
    }

    /// The NED diagonal bounds the rotated body covariance: `D - C diag(q) C^T` is positive
    /// semi-definite for any attitude.
    #[test]
    fn the_ned_diagonal_bounds_the_rotated_covariance() {
        let q_b = Vector3::new(1.0, 4.0, 0.5);
        for (r, p, y) in [(0.1, -0.05, 1.0), (0.8, 0.4, -2.0), (1.5, -1.2, 0.3)] {
            let c = *nalgebra::Rotation3::from_euler_angles(r, p, y).matrix();
            let d = diagonal_bound_ned(&c, &q_b);
            let q = c * Matrix3::from_diagonal(&q_b) * c.transpose();
            let diff = Matrix3::from_diagonal(&d) - q;
            let eig = diff.symmetric_eigenvalues();
            assert!(eig.min() > -1e-12, "{eig}");
        }
    }

    #[test]
    fn scale_factors_off_leave_their_rows_empty() {
        let f = system_matrix(&lin(0.3, Vector3::zeros()), &noise(), false);
        for i in SG..N {
            assert!(f.row(i).iter().all(|x| *x == 0.0));
            assert!(f.column(i).iter().all(|x| *x == 0.0));
        }
        let q = noise_density(
            &noise(),
            false,
            &lin(0.3, Vector3::zeros()),
            &SustainedMotion::default(),
        );
        assert!(q.rows(SG, 6).iter().all(|x| *x == 0.0));
    }
}
