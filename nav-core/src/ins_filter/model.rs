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
//! of density `2 sigma^2 / tau` (Groves eq. 14.80). The products of the attitude error with
//! the accelerometer and gyro errors, which the linearisation drops, enter `w_v` and `w_phi`
//! as noises of their size ([`second_order_velocity_density`],
//! [`second_order_attitude_density`]).
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
    /// Gyro cross-axis coupling (misalignment), 1-sigma of each off-diagonal element [rad]:
    /// a consider state ([`super::consider`]).
    pub gyro_cross_coupling_rad: T,
    /// Accelerometer cross-axis coupling (misalignment), 1-sigma of each off-diagonal element
    /// [rad]: at rest a part of the bias; its change as the specific force leaves its value
    /// at rest, a consider state.
    pub accel_cross_coupling_rad: T,
    /// Gyro g-sensitivity, 1-sigma of each element [rad/s per m/s^2]: at rest a part of the
    /// bias; its change with the specific force, a consider state.
    pub gyro_g_sensitivity: T,
    /// Gyro bias instability: the stationary 1-sigma of a Gauss–Markov bias of a few seconds
    /// [rad/s] (zero: none), a consider state.
    pub gyro_bias_instability_rad_s: T,
    /// Its correlation time [s] (zero: none).
    pub gyro_bias_instability_time_s: T,
}

impl<T: Scalar> FilterNoise<T> {
    /// This model in precision `U`.
    pub fn cast<U: Scalar>(&self) -> FilterNoise<U> {
        let c = |x: T| U::c(x.to_f64());
        FilterNoise {
            arw_rad_per_sqrt_s: c(self.arw_rad_per_sqrt_s),
            vrw_mps_per_sqrt_s: c(self.vrw_mps_per_sqrt_s),
            gyro_bias_rad_s: c(self.gyro_bias_rad_s),
            accel_bias_mps2: c(self.accel_bias_mps2),
            gyro_scale: c(self.gyro_scale),
            accel_scale: c(self.accel_scale),
            correlation_time_s: c(self.correlation_time_s),
            gyro_cross_coupling_rad: c(self.gyro_cross_coupling_rad),
            accel_cross_coupling_rad: c(self.accel_cross_coupling_rad),
            gyro_g_sensitivity: c(self.gyro_g_sensitivity),
            gyro_bias_instability_rad_s: c(self.gyro_bias_instability_rad_s),
            gyro_bias_instability_time_s: c(self.gyro_bias_instability_time_s),
        }
    }
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

/// Closest distance to the polar axis [m] at which the NED error model is taken to hold.
///
/// The filter's position error is a latitude and a longitude error and its attitude error is
/// about the NED axes at the computed position; within metres of a pole an error of a few
/// decimetres turns those axes by tens of degrees, beyond the linearisation. Measured with a
/// FOG IMU and 0.5 m fixes at 10 Hz: a vehicle standing 11 m or 5.5 m from the South Pole was
/// within its 1-sigma, one at 2 m was 9 sigma off in heading and one at the pole itself 11
/// sigma off in position and 90 deg in heading, status NAV.
pub const MIN_POLE_DISTANCE_M: f64 = 10.0;

/// Fastest turn of the NED frame relative to the Earth, `|v_E tan(lat)| / (R_E + h)`
/// [rad/s], that the filter follows.
///
/// The NED frame turns about the vertical at `v_E tan(lat) / (R_E + h)`: near a pole, the
/// east speed over the distance to the polar axis. The mechanization integrates that turn at
/// the IMU rate and the covariance at the propagation rate, neither of which follows a frame
/// that turns half a revolution within a second. Measured at 300 m/s with a FOG IMU, 200 Hz
/// increments, 10 Hz propagation and 0.5 m fixes at 10 Hz, passing a pole at 490 m (0.6
/// rad/s) and 290 m (1.0 rad/s) stayed within 3 sigma; at 195 m (1.5 rad/s) 5 sigma, at
/// 150 m 9 sigma, at 97 m 22 sigma and at 10 m 665 sigma with 30 m of error, all with status
/// NAV, and over the pole the solution turned to NaN.
pub const MAX_NED_FRAME_RATE_RAD_S: f64 = 1.0;

/// True where the NED error model does not hold (at `earth` with the velocity `v_eb_n`
/// [m/s], NED): within [`MIN_POLE_DISTANCE_M`] of the polar axis, or where the NED frame
/// turns faster than [`MAX_NED_FRAME_RATE_RAD_S`]. A wander-azimuth error model (the
/// mechanization's, [`crate::strapdown`]) would hold there; this filter reports DEGRADED
/// instead ([`super::FilterStatus::NearPole`]).
pub fn near_pole<T: Scalar>(earth: &LocalEarth<T>, v_eb_n: &Vector3<T>) -> bool {
    // Distance to the polar axis, (R_E + h) cos(lat).
    let axis_m = (earth.r_transverse + earth.h) * earth.cos2_lat.max(T::zero()).sqrt();
    let turn = (v_eb_n.y * earth.sin_lat).abs();
    !(axis_m >= T::c(MIN_POLE_DISTANCE_M) && turn <= T::c(MAX_NED_FRAME_RATE_RAD_S) * axis_m)
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

/// How many times its doubt the squared horizontal specific force must reach before the
/// attitude coupling keeps any of it ([`couple_significant_specific_force`]).
pub const SIGNIFICANT: f64 = 3.0;

/// Sets the velocity rows' attitude block of `f` ([`system_matrix`]) to `[f_n x]` with the
/// horizontal part of the specific force shrunk by its own doubt: the coefficient of the attitude
/// error is the true specific force, and the computed one carries the filter's horizontal error `g
/// x phi + C_b_n b_a` (covariance `E` from `P`'s tilt and accelerometer-bias blocks; a heading
/// error turns `f_h` without changing its size) and the interval mean's white noise (variance
/// `mean_noise_var` [m^2/s^4] per axis). The horizontal part `f_h` is kept as `f_h max(0, 1 - k tr
/// E_h / |f_h|^2)`, `k` = [`SIGNIFICANT`] [James & Stein, 1961, positive part, whose `k = 1` still
/// let a fifth of pure noise's square through; `k = 3` lets 2 %]. Taken at face value, a still
/// vehicle's `f_h` (that error, tens of milli-g on a consumer part) times the heading error told
/// the heading from the accelerometer bias, which at rest nothing can: the heading's 1-sigma fell
/// from 30 to 7 deg in 5 min with the errors beyond 3 sigma. Under a real acceleration (metres per
/// second squared, against a doubt of centimetres per second squared) the factor is 1.
pub fn couple_significant_specific_force<T: Scalar>(
    f: &mut Covariance<T>,
    p: &Covariance<T>,
    lin: &Linearisation<T>,
    mean_noise_var: T,
) {
    let c = &lin.c_b_n;
    let f_n = c * lin.f_ib_b;
    // The tilt's share turns the vertical force; the heading's only turns `f_h`, not its size.
    let s = skew(&Vector3::new(T::zero(), T::zero(), f_n.z));
    let p_aa = p.fixed_view::<3, 3>(ATT, ATT);
    let cross = s * p.fixed_view::<3, 3>(ATT, BA) * c.transpose();
    let e = s * p_aa * s.transpose()
        + cross
        + cross.transpose()
        + c * p.fixed_view::<3, 3>(BA, BA) * c.transpose();
    let doubt = (e[(0, 0)] + e[(1, 1)] + mean_noise_var * T::c(2.0)) * T::c(SIGNIFICANT);
    let h2 = f_n.x * f_n.x + f_n.y * f_n.y;
    let k = if h2 > doubt {
        T::one() - doubt / h2
    } else {
        T::zero()
    };
    let used = Vector3::new(f_n.x * k, f_n.y * k, f_n.z);
    set_block(f, VEL, ATT, &skew(&used));
}

/// Spectral densities of the driving white noise, per state (diagonal of `G Q G^T`):
/// `vrw^2` on velocity, `arw^2` on attitude (isotropic, so the rotation `C_b_n` drops out),
/// `2 sigma^2 / tau` on each Gauss–Markov state ([Groves, eq. 14.80]). The cross-coupling
/// errors and the bias instability are not noise here: they are consider states
/// ([`super::consider`]).
pub fn noise_density<T: Scalar>(noise: &FilterNoise<T>, scale_factors: bool) -> StateVector<T> {
    let mut q = StateVector::<T>::zeros();
    let two_over_tau = T::c(2.0) / noise.correlation_time_s;
    let gm = |sigma: T| sigma * sigma * two_over_tau;
    let arw2 = noise.arw_rad_per_sqrt_s * noise.arw_rad_per_sqrt_s;
    let vrw2 = noise.vrw_mps_per_sqrt_s * noise.vrw_mps_per_sqrt_s;
    for k in 0..3 {
        q[VEL + k] = vrw2;
        q[ATT + k] = arw2;
        q[BG + k] = gm(noise.gyro_bias_rad_s);
        q[BA + k] = gm(noise.accel_bias_mps2);
        if scale_factors {
            q[SG + k] = gm(noise.gyro_scale);
            q[SA + k] = gm(noise.accel_scale);
        }
    }
    q
}

/// The time [s] over which [`second_order_velocity_density`] spreads the dropped product
/// term as white noise: the density `2 m^2 tau` gives the velocity variance a bias of `m`
/// gives over about `2 tau`, here the two seconds between a 1 Hz receiver's fixes and twenty of
/// a 10 Hz one's.
pub const SECOND_ORDER_TIME_S: f64 = 1.0;

/// Spectral density [m^2/s^3] of a velocity noise per axis that stands for the term the
/// linearisation drops from the velocity error equation: the computed specific force is
/// `C~_b_n f~ = (I - [phi x]) C_b_n (f + e_a)`, `e_a = b_a + diag(f_b) s_a`, whose product
/// `-[phi x] C_b_n e_a` of two errors [`system_matrix`] leaves out. Its size is the product
/// of the attitude and accelerometer errors' 1-sigma, here the largest of each (`P` the
/// covariance, `f_ib_b` the specific force [m/s^2]); the density is `2 m^2`
/// [`SECOND_ORDER_TIME_S`] [Bar-Shalom et al., §10.3: the second-order filter adds the
/// covariance of the dropped terms]. Negligible once either error is small (a navigation-grade
/// unit: 1e-4 rad times 1e-3 m/s^2); with a consumer part started in motion (degrees times
/// tens of milli-g) it is milli-g, against which the filter would otherwise take a
/// micro-g difference between the vertical and horizontal channels for information and split
/// a lateral accelerometer bias from the roll that hides it on a straight flight: the bias's
/// sigma fell from 20 to 7 mg while the estimate, on a recording with 40 mg injected and one
/// without, stayed the same.
pub fn second_order_velocity_density<T: Scalar>(
    p: &Covariance<T>,
    f_ib_b: &Vector3<T>,
    scale_factors: bool,
) -> T {
    second_order_density(p, BA, SA, f_ib_b, scale_factors)
}

/// Spectral density [rad^2/s] of an attitude noise per axis that stands for the gyros' share
/// of the same dropped product: the computed rate `C~_b_n (omega + e_g)`, `e_g = b_g +
/// diag(omega_b) s_g`, whose product `-[phi x] C_b_n e_g` [`system_matrix`] leaves out; the
/// largest attitude 1-sigma times the largest gyro error 1-sigma (`omega_ib_b` the body rate
/// [rad/s]), spread as [`second_order_velocity_density`] does. A consumer part started in
/// motion carries a heading error of ten degrees and gyro biases known to a tenth of a degree
/// per second: the product turns the tilt by a degree a minute, which taken as known let a
/// straight flight's roll 1-sigma fall to a third of its error.
pub fn second_order_attitude_density<T: Scalar>(
    p: &Covariance<T>,
    omega_ib_b: &Vector3<T>,
    scale_factors: bool,
) -> T {
    second_order_density(p, BG, SG, omega_ib_b, scale_factors)
}

/// `2 tau` times the largest attitude variance times the largest variance of a sensor
/// triad's error: its bias states from `bias`, plus its scale-factor states from `scale`
/// times the measured `x` squared when modelled.
fn second_order_density<T: Scalar>(
    p: &Covariance<T>,
    bias: usize,
    scale: usize,
    x: &Vector3<T>,
    scale_factors: bool,
) -> T {
    let mut attitude = T::zero();
    let mut sensor = T::zero();
    for k in 0..3 {
        attitude = attitude.max(p[(ATT + k, ATT + k)]);
        let mut e = p[(bias + k, bias + k)];
        if scale_factors {
            e += p[(scale + k, scale + k)] * x[k] * x[k];
        }
        sensor = sensor.max(e);
    }
    T::c(2.0 * SECOND_ORDER_TIME_S) * attitude * sensor
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
pub(crate) mod tests {
    use super::*;
    use crate::ins_filter::states::N;

    /// A tactical-grade noise figure set for the filter's unit tests.
    /// The Euler angles' 1-sigma of a body pitched up by 80 deg at heading 0: the NED tilt
    /// about north is roll's times `cos(pitch)`, and leaks into yaw by `tan(pitch)` (was: the
    /// NED tilt's 1-sigma reported as roll's and yaw's, 5-46 times below their errors in
    /// loops). At vertical the two are not defined: at most 180 deg.
    #[test]
    fn euler_sigma_grows_towards_vertical() {
        use crate::ins_filter::{AidedIns, FilterConfig, InitialSigma};
        use crate::{NavState, Position, attitude};
        let sigma_at = |pitch: f64| {
            let state = NavState {
                q_b_n: attitude::from_euler(0.0, pitch, 0.0),
                v_eb_n: Vector3::new(100.0, 0.0, -50.0),
                position: Position::from_radians(0.8, 0.3, 1000.0),
            };
            let n = noise();
            let sigma = InitialSigma {
                position_ned_m: Vector3::repeat(0.1),
                velocity_ned_m_s: Vector3::repeat(0.01),
                attitude_rad: Vector3::new(1e-3, 2e-3, 3e-3),
                gyro_bias_rad_s: Vector3::repeat(n.gyro_bias_rad_s),
                accel_bias_mps2: Vector3::repeat(n.accel_bias_mps2),
                gyro_scale: Vector3::repeat(n.gyro_scale),
                accel_scale: Vector3::repeat(n.accel_scale),
            };
            AidedIns::new(state, Default::default(), &sigma, FilterConfig::new(n))
                .unwrap()
                .attitude_sigma_rad()
        };
        let pitch = 80f64.to_radians();
        let s = sigma_at(pitch);
        let expected = Vector3::new(
            1e-3 / pitch.cos(),
            2e-3,
            (9e-6 + (pitch.tan() * 1e-3).powi(2)).sqrt(),
        );
        assert!((s - expected).norm() < 1e-9, "{s} against {expected}");
        let level = sigma_at(0.0);
        assert!(
            (level - Vector3::new(1e-3, 2e-3, 3e-3)).norm() < 1e-12,
            "{level}"
        );
        let vertical = sigma_at(core::f64::consts::FRAC_PI_2);
        assert!(
            vertical
                .iter()
                .all(|v| v.is_finite() && *v <= core::f64::consts::PI)
        );
        assert!(vertical.x > 1.0 && vertical.z > 1.0, "{vertical}");
    }

    pub(crate) fn noise() -> FilterNoise<f64> {
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
            gyro_bias_instability_rad_s: 0.0,
            gyro_bias_instability_time_s: 0.0,
        }
    }

    pub(crate) fn lin(lat: f64, v: Vector3<f64>) -> Linearisation<f64> {
        Linearisation {
            earth: LocalEarth::new(lat, 100.0),
            v_eb_n: v,
            c_b_n: *nalgebra::Rotation3::from_euler_angles(0.1, -0.05, 1.0).matrix(),
            f_ib_b: Vector3::new(0.3, -0.2, -9.8),
            omega_ib_b: Vector3::new(0.01, 0.02, -0.03),
        }
    }

    /// The NED error model's domain: 10 m from the polar axis, and a frame turning at most
    /// 1 rad/s (east speed over the distance to the axis).
    #[test]
    fn near_pole_marks_where_the_ned_frame_cannot_follow() {
        // Latitude [rad] at `d` [m] from the North Pole's axis.
        let at = |d: f64| (d / 6_399_593.6).acos();
        let v = |v_e: f64| Vector3::new(300.0, v_e, 0.0);
        let e = |lat: f64| LocalEarth::new(lat, 0.0);
        assert!(!near_pole(&e(0.7), &v(300.0)));
        assert!(!near_pole(&e(at(11.0)), &v(0.0)));
        assert!(near_pole(&e(at(9.0)), &v(0.0)));
        assert!(near_pole(&e(core::f64::consts::FRAC_PI_2), &v(0.0)));
        assert!(near_pole(&e(-core::f64::consts::FRAC_PI_2), &v(0.0)));
        assert!(!near_pole(&e(at(310.0)), &v(300.0)));
        assert!(near_pole(&e(-at(290.0)), &v(-300.0)));
        // The speed north does not turn the frame.
        assert!(!near_pole(&e(at(100.0)), &Vector3::new(300.0, 50.0, 0.0)));
    }

    /// A filter started 100 m from the North Pole's axis, flying east at 300 m/s (its NED
    /// frame turning at 3 rad/s), reports DEGRADED from its first propagation (was NAV: on
    /// such a pass the solution went 22 sigma off, and over the pole to NaN); the same
    /// flight at 45 deg stays NAV.
    #[test]
    fn a_filter_near_a_pole_reports_degraded() {
        use crate::ins_filter::{AidedIns, FilterConfig, FilterStatus, InitialSigma};
        use crate::{ImuIncrement, NavState, Position, attitude};
        let run = |lat: f64| {
            let state = NavState {
                q_b_n: attitude::from_euler(0.0, 0.0, core::f64::consts::FRAC_PI_2),
                v_eb_n: Vector3::new(0.0, 300.0, 0.0),
                position: Position::from_radians(lat, 0.3, 100.0),
            };
            let n = noise();
            let sigma = InitialSigma {
                position_ned_m: Vector3::repeat(0.1),
                velocity_ned_m_s: Vector3::repeat(0.01),
                attitude_rad: Vector3::repeat(1e-3),
                gyro_bias_rad_s: Vector3::repeat(n.gyro_bias_rad_s),
                accel_bias_mps2: Vector3::repeat(n.accel_bias_mps2),
                gyro_scale: Vector3::repeat(n.gyro_scale),
                accel_scale: Vector3::repeat(n.accel_scale),
            };
            let mut ins =
                AidedIns::new(state, Default::default(), &sigma, FilterConfig::new(n)).unwrap();
            assert_eq!(ins.status(), FilterStatus::Nominal);
            let inc = ImuIncrement {
                delta_theta_ib_b: Vector3::zeros(),
                delta_v_ib_b: Vector3::new(0.0, 0.0, -9.8 * 0.005),
                dt: 0.005,
            };
            for _ in 0..20 {
                ins.step(&inc).unwrap();
            }
            ins.propagate();
            ins.status()
        };
        assert_eq!(
            run((100.0_f64 / 6_399_593.6).acos()),
            FilterStatus::NearPole
        );
        assert_eq!(run(core::f64::consts::FRAC_PI_4), FilterStatus::Nominal);
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

    #[test]
    fn scale_factors_off_leave_their_rows_empty() {
        let f = system_matrix(&lin(0.3, Vector3::zeros()), &noise(), false);
        for i in SG..N {
            assert!(f.row(i).iter().all(|x| *x == 0.0));
            assert!(f.column(i).iter().all(|x| *x == 0.0));
        }
        let q = noise_density(&noise(), false);
        assert!(q.rows(SG, 6).iter().all(|x| *x == 0.0));
    }

    /// The second-order velocity (attitude) noise is `2 tau` times the largest attitude
    /// variance times the largest accelerometer (gyro) error variance: bias, and the scale
    /// factor times the specific force (body rate) when modelled; nothing when either is zero.
    #[test]
    fn second_order_noises_are_the_products_of_the_largest_errors() {
        let mut p = Covariance::<f64>::zeros();
        let f = Vector3::new(0.5, 0.0, -9.8);
        assert_eq!(second_order_velocity_density(&p, &f, true), 0.0);
        p[(ATT, ATT)] = 1e-4;
        p[(ATT + 2, ATT + 2)] = 4e-2;
        assert_eq!(second_order_velocity_density(&p, &f, true), 0.0);
        p[(BA, BA)] = 1e-2;
        p[(BA + 2, BA + 2)] = 2e-2;
        let tau2 = 2.0 * SECOND_ORDER_TIME_S;
        let without = second_order_velocity_density(&p, &f, false);
        assert!((without - tau2 * 4e-2 * 2e-2).abs() < 1e-15, "{without}");
        p[(SA + 2, SA + 2)] = 1e-4;
        let with = second_order_velocity_density(&p, &f, true);
        let accel = 2e-2 + 1e-4 * 9.8 * 9.8;
        assert!((with - tau2 * 4e-2 * accel).abs() < 1e-15, "{with}");
        // The gyros' share: the gyro bias and scale-factor variances at the body rate.
        let w = Vector3::new(0.0, 0.5, 0.0);
        assert_eq!(second_order_attitude_density(&p, &w, true), 0.0);
        p[(BG + 1, BG + 1)] = 1e-6;
        p[(SG + 1, SG + 1)] = 4e-6;
        let gyro = 1e-6 + 4e-6 * 0.25;
        let with = second_order_attitude_density(&p, &w, true);
        assert!((with - tau2 * 4e-2 * gyro).abs() < 1e-18, "{with}");
        let without = second_order_attitude_density(&p, &w, false);
        assert!((without - tau2 * 4e-2 * 1e-6).abs() < 1e-18, "{without}");
    }
}
