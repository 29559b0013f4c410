//! Inertial-frame coarse alignment (`nav_core::alignment::inertial`, issue 6 requirements 1b and
//! 5) on the simulator's exact increments: exact data, rocking with and without a lever arm,
//! white noise against the Cramér–Rao floor, an east gyro bias, and f32 against f64.
//!
//! Every bound is derived in the test (or in the module docs, eq. 9) from physics or from the
//! estimator's own 1-sigma, never copied from a run.

use host_tests::sensor_model::{ErrorInjector, Grade, ImuErrorModel};
use host_tests::trajectory::scenarios::Scenario;
use host_tests::trajectory::{Generator, Sampling, generate, wrap_pi};
use host_tests::truth::Truth;
use nav_core::alignment::{AttitudeEstimate, InertialAlignError, InertialAlignment, SensorNoise};
use nav_core::attitude::{euler, quat_to_f64};
use nav_core::earth::{self, OMEGA_IE};
use nav_core::{ImuIncrement, Scalar, UnitQuaternion, Vector3};
use std::sync::OnceLock;

const RATE_HZ: f64 = 400.0;
/// f32's unit roundoff.
const EPS32: f64 = f32::EPSILON as f64 / 2.0;

/// A scenario's exact increments and truths (truth `k` at the end of increment `k`; `start` at
/// t = 0), with the centre's latitude and height (the known position).
struct Exact {
    incs: Vec<ImuIncrement<f64>>,
    truths: Vec<Truth>,
    start: Truth,
    lat: f64,
    h: f64,
}

fn exact(name: &str, params: &[(&str, f64)], seconds: f64) -> Exact {
    let mut s = Scenario::by_name(name).unwrap();
    for (k, v) in params {
        s.set(k, *v).unwrap();
    }
    let desc = s.describe();
    let get = |key: &str| desc.iter().find(|p| p.0 == key).unwrap().1;
    let (lat, h) = (get("lat_deg").to_radians(), get("h_m"));
    let traj = s.build().unwrap();
    let start = Generator::new(traj.as_ref()).truth();
    let (mut incs, mut truths) = (Vec::new(), Vec::new());
    generate(
        traj.as_ref(),
        Sampling::new(RATE_HZ, seconds),
        |_, _, inc, t| {
            incs.push(*inc);
            truths.push(*t);
        },
    );
    Exact {
        incs,
        truths,
        start,
        lat,
        h,
    }
}

fn auv_bench() -> &'static Exact {
    static DATA: OnceLock<Exact> = OnceLock::new();
    DATA.get_or_init(|| exact("auv-bench", &[], 300.0))
}

/// Sample index whose end is at `t_s` [s].
fn index_at(t_s: f64) -> usize {
    (t_s * RATE_HZ).round() as usize - 1
}

/// Roll, pitch and yaw errors [rad] of `q_b_n` against the truth.
fn errors<T: Scalar>(est: &AttitudeEstimate<T>, truth: &Truth) -> Vector3<f64> {
    let (r, p, y) = euler(&quat_to_f64(&est.q_b_n));
    let (rt, pt, yt) = euler(&truth.q_b_ned);
    Vector3::new(wrap_pi(r - rt), p - pt, wrap_pi(y - yt))
}

/// Runs the alignment over `incs` (converted to `T`), calling `at(k, estimate)` after the
/// samples whose index is in `checkpoints`.
fn align<T: Scalar>(
    incs: impl Iterator<Item = ImuIncrement<f64>>,
    lat: f64,
    h: f64,
    noise: Option<SensorNoise<T>>,
    checkpoints: &[usize],
    mut at: impl FnMut(usize, AttitudeEstimate<T>),
) {
    align_or_refuse(incs, lat, h, noise, None, checkpoints, |k, r| {
        at(k, r.unwrap())
    });
}

/// [`align`] with the estimate's refusals passed on.
fn align_or_refuse<T: Scalar>(
    incs: impl Iterator<Item = ImuIncrement<f64>>,
    lat: f64,
    h: f64,
    noise: Option<SensorNoise<T>>,
    lever_arm_b_m: Option<Vector3<f64>>,
    checkpoints: &[usize],
    mut at: impl FnMut(usize, Result<AttitudeEstimate<T>, InertialAlignError>),
) {
    let mut a = InertialAlignment::new(T::c(lat), T::c(h));
    if let Some(n) = noise {
        a = a.with_noise(n);
    }
    if let Some(r) = lever_arm_b_m {
        a = a.with_lever_arm(r.map(T::c));
    }
    for (k, inc) in incs.enumerate() {
        let inc = ImuIncrement {
            delta_theta_ib_b: inc.delta_theta_ib_b.map(T::c),
            delta_v_ib_b: inc.delta_v_ib_b.map(T::c),
            dt: T::c(inc.dt),
        };
        a.add(&inc).unwrap();
        if checkpoints.contains(&k) {
            at(k, a.estimate());
        }
    }
}

fn deg(v: Vector3<f64>) -> Vector3<f64> {
    v.map(f64::to_degrees)
}

/// `[x, y, z]` in scientific notation.
fn sci(v: Vector3<f64>) -> String {
    format!("[{:.2e}, {:.2e}, {:.2e}]", v.x, v.y, v.z)
}

/// Issue requirement 5: exact static data, f64, 60 s: every angle within 1e-4 deg.
#[test]
fn exact_static_data_within_1e4_deg() {
    let d = exact("static", &[], 60.0);
    let k = index_at(60.0);
    let mut e = Vector3::repeat(f64::NAN);
    align::<f64>(d.incs.iter().copied(), d.lat, d.h, None, &[k], |_, est| {
        e = errors(&est, &d.truths[k]);
    });
    println!(
        "static, exact, 60 s: roll/pitch/yaw errors {} deg",
        sci(deg(e))
    );
    assert!(deg(e).amax() < 1e-4, "{}", deg(e));
}

/// Rocking 5 deg / 11 s (auv-bench) with the IMU at the centre of rotation: no disturbance
/// velocity, so eq. 9 allows no error beyond the increments' own (below 1e-10 m/s and 1e-12 rad
/// each, scenarios.rs): over N = 120,000 samples at most 1.2e-5 m/s of velocity and 1.2e-7 rad
/// of attitude, i.e. by eq. 9 and the bias formula below 2e-6 rad at 60 s: 1e-4 deg holds
/// with margin at every time.
#[test]
fn rocking_without_lever_arm_is_exact() {
    let d = auv_bench();
    let times = [30.0, 60.0, 120.0, 300.0];
    let ks: Vec<usize> = times.iter().map(|&t| index_at(t)).collect();
    align::<f64>(d.incs.iter().copied(), d.lat, d.h, None, &ks, |k, est| {
        let e = deg(errors(&est, &d.truths[k]));
        println!(
            "auv-bench, exact, {:.0} s: roll/pitch/yaw errors {} deg",
            est.elapsed_s,
            sci(e)
        );
        assert!(e.amax() < 1e-4, "{e}");
    });
}

/// `C_n_i0(t)` (the NED frame turned by the Earth rate about the polar axis).
fn q_n_i0(lat: f64, t_s: f64) -> UnitQuaternion<f64> {
    let u = Vector3::new(lat.cos(), 0.0, -lat.sin());
    UnitQuaternion::from_scaled_axis(u * (OMEGA_IE * t_s))
}

/// Sea state 6 with the seed 002 lever arm (30, 10, 15) m, ideal sensors. The lever-arm velocity
/// `v_d` (up to ~1 m/s) is a disturbance that adds `dM = T (v_d(T) + v_d(0)) - 2 (r_d(T) -
/// r_d(0))` to `M_b0` (module docs, eq. 9; `r_d` its displacement, all in `i0`). The TRIAD turns
/// the horizontal `M_E e + dM_h` onto east, so the heading error is `atan2(dM_N, M_E + dM_E)`
/// (predicted), at most `asin(|dM_h| / M_E)` with
/// `|dM_h| <= T (|v_h(T)| + |v_h(0)|) + 2 |r_h(T) - r_h(0)|` (the bound: the disturbance tilt
/// `v / (g T)` over the Earth-rate geometry `Omega cos(L) T`, since
/// `M_E = g Omega cos(L) T^3 / 6`). The level error is at most `|v_h(T) - v_h(0)| / (g T)` (the
/// mean specific force's tilt) plus `2 sin(|psi| / 2) Omega cos(L) T / 2`: the heading error
/// `psi` is a rotation about the window's mean vertical `V_i0`, which is `Omega cos(L) T / 2`
/// away from the vertical now.
/// Neglected: terms of relative order `Omega T` (< 5 %) and the tilt coupling through the
/// vertical part of `M`; the test allows 10 % of the prediction plus 1e-5 rad. Where the
/// predicted heading signal `|M_E e + dM_h| / M_E` is off by more than the gate's 50 %, the
/// estimate must be refused (`HeadingUnobservable`), and accepted where it is clearly within.
#[test]
fn lever_arm_error_follows_the_velocity_over_g_t_bound() {
    let d = exact("ship-rocking", &[("sea_state", 6.0)], 600.0);
    let times = [60.0, 120.0, 300.0, 600.0];
    let ks: Vec<usize> = times.iter().map(|&t| index_at(t)).collect();
    let g = earth::normal_gravity(d.lat, d.h);
    // Disturbance velocity and displacement in i0: the Earth-relative velocity turned by
    // C_n_i0(t), integrated sample by sample.
    let v_i0 = |t: &Truth| q_n_i0(d.lat, t.t_s) * t.v_eb_ned;
    let v0 = v_i0(&d.start);
    let mut r = Vector3::zeros();
    let mut r_at = Vec::new();
    let mut prev = v0;
    for (k, t) in d.truths.iter().enumerate() {
        let v = v_i0(t);
        r += (prev + v) * (0.5 / RATE_HZ);
        prev = v;
        if ks.contains(&k) {
            r_at.push(r);
        }
    }
    let reference = InertialAlignment::<f64>::new(d.lat, d.h);
    let mut i = 0;
    let mut accepted = 0;
    align_or_refuse::<f64>(
        d.incs.iter().copied(),
        d.lat,
        d.h,
        None,
        None,
        &ks,
        |k, est| {
            let t = (k + 1) as f64 / RATE_HZ;
            let vt = v_i0(&d.truths[k]);
            let m_e = reference.reference(t).1.y;
            let dm = (vt + v0) * t - r_at[i] * 2.0;
            let predicted = dm.x.atan2(m_e + dm.y);
            let signal = (m_e + dm.y).hypot(dm.x) / m_e;
            let dm_max = t * (vt.xy().norm() + v0.xy().norm()) + 2.0 * r_at[i].xy().norm();
            let bound = (dm_max / m_e).min(1.0).asin();
            let level_v = (vt - v0).xy().norm() / (g * t);
            i += 1;
            let e = match est {
                Ok(est) => errors(&est, &d.truths[k]),
                Err(e) => {
                    println!(
                        "ship-rocking SS6, lever arm, {t:.0} s: refused ({e}); predicted heading \
                     signal {signal:.2}x the Earth rate's, heading error {:.1} deg",
                        predicted.to_degrees()
                    );
                    assert_eq!(e, InertialAlignError::HeadingUnobservable);
                    assert!((signal - 1.0).abs() > 0.4, "{signal}");
                    return;
                }
            };
            accepted += 1;
            let level = level_v + 2.0 * (e.z.abs() / 2.0).sin() * OMEGA_IE * d.lat.cos() * t / 2.0;
            println!(
                "ship-rocking SS6, lever arm, {t:.0} s: heading error {:.4} deg, predicted {:.4} deg, \
             bound {:.4} deg; roll/pitch {:.4}/{:.4} deg, bound {:.4} deg \
             (v_h(0) {:.3}, v_h(T) {:.3} m/s, r_h {:.3} m)",
                e.z.to_degrees(),
                predicted.to_degrees(),
                bound.to_degrees(),
                e.x.to_degrees(),
                e.y.to_degrees(),
                level.to_degrees(),
                v0.xy().norm(),
                vt.xy().norm(),
                r_at[i - 1].xy().norm()
            );
            assert!((signal - 1.0).abs() < 0.6, "{signal}");
            assert!(
                (e.z - predicted).abs() <= 0.1 * predicted.abs() + 1e-5,
                "{} vs {}",
                e.z,
                predicted
            );
            assert!(e.z.abs() <= 1.1 * bound + 1e-5, "{} > {bound}", e.z);
            assert!(e.xy().amax() <= 1.1 * level + 1e-6, "{} > {level}", e.xy());
        },
    );
    // The longer windows (the heading signal grows as T^3, the disturbance as T) must align.
    assert!(accepted >= 2, "{accepted}");

    // The same with the lever arm known (eq. 10). What is left of the disturbance is the end
    // rates' extrapolation error, at most dt^2 |d2omega/dt2| |R| (|d2omega/dt2| <= the sum of
    // amplitude x (2 pi / period)^3 of the three harmonics), which eq. 9 turns into
    // asin(2 T v / M_E) of heading and 2 v / (g T) of level; and the IMU's truth is relative to
    // the local level at the IMU, up to |R| / R_earth (plumb line, meridian convergence) away
    // from the centre's used by the alignment.
    let desc = {
        let mut s = Scenario::by_name("ship-rocking").unwrap();
        s.set("sea_state", 6.0).unwrap();
        s.describe()
    };
    let get = |key: &str| desc.iter().find(|p| p.0 == key).unwrap().1;
    let r_b = Vector3::new(get("lever_x_m"), get("lever_y_m"), get("lever_z_m"));
    let jerk: f64 = ["roll", "pitch", "yaw"]
        .iter()
        .map(|a| {
            get(&format!("{a}_amp_deg")).to_radians()
                * (std::f64::consts::TAU / get(&format!("{a}_period_s"))).powi(3)
        })
        .sum();
    let v_res = jerk * r_b.norm() / (RATE_HZ * RATE_HZ);
    let place = r_b.norm() / 6.37e6;
    align_or_refuse::<f64>(
        d.incs.iter().copied(),
        d.lat,
        d.h,
        None,
        Some(r_b),
        &ks,
        |k, est| {
            let t = (k + 1) as f64 / RATE_HZ;
            let e = errors(&est.unwrap(), &d.truths[k]);
            let m_e = reference.reference(t).1.y;
            let heading = (2.0 * t * v_res / m_e).asin() + place;
            let level = 2.0 * v_res / (g * t) + place;
            println!(
                "ship-rocking SS6, lever arm known, {t:.0} s: heading error {:.2e} deg (bound \
                 {:.2e}), roll/pitch {:.2e}/{:.2e} deg (bound {:.2e}); residual velocity \
                 {v_res:.1e} m/s",
                e.z.to_degrees(),
                heading.to_degrees(),
                e.x.to_degrees(),
                e.y.to_degrees(),
                level.to_degrees()
            );
            assert!(e.z.abs() <= heading, "{} > {heading}", e.z);
            assert!(e.xy().amax() <= level, "{} > {level}", e.xy());
        },
    );
}

/// Issue requirement 5: an east gyro bias `eps_E` alone turns the apparent Earth axis by
/// `eps_E / (Omega cos L)` towards the east, so the heading (measured from the apparent north)
/// is short by that much: error `-eps_E / (Omega cos L)`, independent of time (the
/// least-squares slope of a linearly growing tilt is exact), within 5 %.
#[test]
fn east_gyro_bias_gives_the_gyrocompass_heading_error() {
    let d = exact("static", &[], 300.0);
    let eps = 0.2_f64.to_radians() / 3600.0; // seed 003's 0.2 deg/h
    let mut model = ImuErrorModel::IDEAL;
    model.gyro.bias = d.start.q_b_ned.inverse() * Vector3::new(0.0, eps, 0.0);
    let mut inj = ErrorInjector::new(model, 1).unwrap();
    let predicted = -eps / (OMEGA_IE * d.lat.cos());
    let ks = [index_at(60.0), index_at(300.0)];
    align::<f64>(
        d.incs.iter().map(|i| inj.apply(i)),
        d.lat,
        d.h,
        None,
        &ks,
        |k, est| {
            let e = errors(&est, &d.truths[k]);
            println!(
                "east gyro bias 0.2 deg/h, {:.0} s: heading error {:.5} deg, \
                 -eps_E/(Omega cos L) = {:.5} deg (ratio {:.4})",
                est.elapsed_s,
                e.z.to_degrees(),
                predicted.to_degrees(),
                e.z / predicted
            );
            assert!((e.z / predicted - 1.0).abs() < 0.05, "{} {predicted}", e.z);
        },
    );
}

/// Wilson–Hilferty approximation of the chi-square quantile with `n` degrees of freedom at
/// standard-normal quantile `z` (accurate to < 1 % for n >= 20).
fn chi2_quantile(n: f64, z: f64) -> f64 {
    let c = 2.0 / (9.0 * n);
    n * (1.0 - c + z * c.sqrt()).powi(3)
}

/// Seed 003's FOG with its turn-on biases zeroed: white noise only.
fn fog_white() -> (ImuErrorModel, SensorNoise<f64>) {
    let mut model = Grade::Fog.model();
    model.gyro.turn_on_bias_sigma = Vector3::zeros();
    model.accel.turn_on_bias_sigma = Vector3::zeros();
    let noise = SensorNoise {
        arw_rad_per_sqrt_s: model.gyro.white_noise.density(),
        vrw_mps_per_sqrt_s: model.accel.white_noise.density(),
        gyro_bias_rad_s: 0.0,
        accel_bias_mps2: 0.0,
    };
    (model, noise)
}

/// Heading errors over `seeds` runs of `model` on `d` at `times` [s]: per time, the errors
/// [rad] and the estimator's own 1-sigma [rad].
fn monte_carlo(
    d: &Exact,
    model: ImuErrorModel,
    noise: SensorNoise<f64>,
    lever_arm_b_m: Option<Vector3<f64>>,
    seeds: u64,
    times: &[f64],
) -> Vec<(Vec<f64>, f64)> {
    let ks: Vec<usize> = times.iter().map(|&t| index_at(t)).collect();
    let mut out = vec![(Vec::new(), 0.0); times.len()];
    for seed in 0..seeds {
        let mut inj = ErrorInjector::new(model, 1000 + seed).unwrap();
        align_or_refuse::<f64>(
            d.incs.iter().map(|i| inj.apply(i)),
            d.lat,
            d.h,
            Some(noise),
            lever_arm_b_m,
            &ks,
            |k, est| {
                let est = est.unwrap();
                let j = ks.iter().position(|&x| x == k).unwrap();
                out[j].0.push(errors(&est, &d.truths[k]).z);
                out[j].1 = est.sigma_rad.z;
            },
        );
    }
    out
}

/// `(RMS, mean)` [rad] of `e`.
fn rms_mean(e: &[f64]) -> (f64, f64) {
    let n = e.len() as f64;
    (
        (e.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
        e.iter().sum::<f64>() / n,
    )
}

/// Two-sided 0.1 % chi-square band of `RMS / sigma` over `n` runs: `sqrt(chi2_n / n)`.
fn rms_band(n: f64) -> (f64, f64) {
    (
        (chi2_quantile(n, -3.29) / n).sqrt(),
        (chi2_quantile(n, 3.29) / n).sqrt(),
    )
}

/// White noise only (seed 003's FOG: 0.003 deg/s and 0.02 m/s^2 RMS at 400 Hz; turn-on biases
/// zeroed) on the rocking bench, many seeds: the RMS heading error against
/// - the Cramér–Rao floor of issue 6,
///   `sqrt((ARW / (w sqrt(T)))^2 + (sqrt(12) VRW / (g w T^1.5))^2)`, `w = Omega cos(L)`,
///   computed from the model's noise densities;
/// - the estimator's own 1-sigma (`SensorNoise` docs: the accelerometer term is the floor's, the
///   gyro term 1.095x it), which must be at most 1.3x the floor by construction.
///
/// With `n` independent seeds, `n RMS^2 / sigma^2` is chi-square with `n` degrees of freedom,
/// so the RMS must lie within `sigma sqrt(chi2_{n, 0.0005..0.9995} / n)` (two-sided 0.1 %), and
/// the "RMS <= 1.3x floor" is asserted with the same upper spread allowed. The mean
/// error must be within `3.29 sigma / sqrt(n)` of 0 (no systematic error).
#[test]
fn white_noise_heading_rms_against_the_cramer_rao_floor() {
    let d = auv_bench();
    let (model, noise) = fog_white();
    let (arw, vrw) = (noise.arw_rad_per_sqrt_s, noise.vrw_mps_per_sqrt_s);
    let g = earth::normal_gravity(d.lat, d.h);
    let w = OMEGA_IE * d.lat.cos();
    let floor = |t: f64| {
        ((arw / (w * t.sqrt())).powi(2) + (12f64.sqrt() * vrw / (g * w * t.powf(1.5))).powi(2))
            .sqrt()
    };
    let times = [30.0, 60.0, 120.0, 300.0];
    let seeds = 100u64;
    let runs = monte_carlo(d, model, noise, None, seeds, &times);
    let n = seeds as f64;
    let (lo, hi) = rms_band(n);
    for (&t, (err, sigma)) in times.iter().zip(&runs) {
        let (rms, mean) = rms_mean(err);
        let (sigma, f) = (*sigma, floor(t));
        println!(
            "FOG white noise, {seeds} seeds, {t:.0} s: RMS heading error {:.3} deg, \
             Cramér–Rao floor {:.3} deg, ratio {:.3}; own 1-sigma {:.3} deg ({:.3}x floor); \
             mean {:+.3} deg",
            rms.to_degrees(),
            f.to_degrees(),
            rms / f,
            sigma.to_degrees(),
            sigma / f,
            mean.to_degrees()
        );
        assert!(sigma <= 1.3 * f && sigma >= f, "{sigma} {f}");
        assert!(
            rms >= lo * sigma && rms <= hi * sigma,
            "{t} s: RMS {rms} outside [{}, {}]",
            lo * sigma,
            hi * sigma
        );
        assert!(rms <= 1.3 * hi * f, "{t} s: RMS {rms} > 1.3 x {hi} x {f}");
        assert!(mean.abs() <= 3.29 * sigma / n.sqrt(), "{t} s: mean {mean}");
    }
}

/// The same white noise on the ship (sea state 6) with its lever arm known: the end rates'
/// gyro noise through the 35 m lever arm adds the `s_v` term of the 1-sigma (`SensorNoise`
/// docs), comparable to the floor at 60 s. The RMS must lie in the chi-square band of the
/// estimator's own 1-sigma, as above.
#[test]
fn white_noise_with_a_known_lever_arm_matches_its_sigma() {
    let d = exact("ship-rocking", &[("sea_state", 6.0)], 300.0);
    let (model, noise) = fog_white();
    let times = [60.0, 120.0, 300.0];
    let seeds = 50u64;
    let r_b = Vector3::new(30.0, 10.0, 15.0); // the scenario's default (seed 002)
    let runs = monte_carlo(&d, model, noise, Some(r_b), seeds, &times);
    let n = seeds as f64;
    let (lo, hi) = rms_band(n);
    for (&t, (err, sigma)) in times.iter().zip(&runs) {
        let (rms, mean) = rms_mean(err);
        println!(
            "FOG white noise, ship SS6, lever arm known, {seeds} seeds, {t:.0} s: RMS heading \
             error {:.3} deg, own 1-sigma {:.3} deg (ratio {:.3}), mean {:+.3} deg",
            rms.to_degrees(),
            sigma.to_degrees(),
            rms / sigma,
            mean.to_degrees()
        );
        assert!(
            rms >= lo * sigma && rms <= hi * sigma,
            "{t} s: {rms} vs {sigma}"
        );
        assert!(mean.abs() <= 3.29 * sigma / n.sqrt(), "{t} s: mean {mean}");
    }
}

/// The same exact rocking data in f32 and f64. Rounding bound (f32 unit roundoff `u`), worst
/// case (every rounding the same sign):
/// - the specific-force path (input rounding, the rotation into `b0`, the recursion eq. 6 and
///   the `V` it uses: about 10 roundings of size `u g t dt` per sample) perturbs `M` by at most
///   `10 u g T^2 / 2`; over `M_E = g w T^3 / 6` that is `30 u / (w T)` of heading;
/// - the attitude path (input and quaternion-increment rounding, ~4 roundings of `u |dtheta|`
///   per sample) is a drift of at most `4 u |omega|`, i.e. `4 u |omega| / w` of heading with
///   `|omega|` the mean rate magnitude.
///
/// The tilt error is bounded by `10 u + 4 u |omega| T` the same way.
#[test]
fn f32_matches_f64_within_the_rounding_bound() {
    for (name, d) in [
        ("static", &exact("static", &[], 300.0)),
        ("auv-bench", auv_bench()),
    ] {
        let times = [30.0, 60.0, 120.0, 300.0];
        let ks: Vec<usize> = times.iter().map(|&t| index_at(t)).collect();
        let mut e64 = Vec::new();
        align::<f64>(d.incs.iter().copied(), d.lat, d.h, None, &ks, |k, est| {
            e64.push(errors(&est, &d.truths[k]));
        });
        let w = OMEGA_IE * d.lat.cos();
        let mut j = 0;
        align::<f32>(d.incs.iter().copied(), d.lat, d.h, None, &ks, |k, est| {
            let t = f64::from(est.elapsed_s);
            let omega = d.incs[..=k]
                .iter()
                .map(|i| i.delta_theta_ib_b.norm())
                .sum::<f64>()
                / t;
            let diff = errors(&est, &d.truths[k]) - e64[j];
            let heading = 30.0 * EPS32 / (w * t) + 4.0 * EPS32 * omega / w;
            let tilt = 10.0 * EPS32 + 4.0 * EPS32 * omega * t;
            println!(
                "{name}, f32 - f64, {t:.0} s: roll/pitch/yaw {} deg; bounds: heading \
                 {:.2e} deg, tilt {:.2e} deg",
                sci(deg(diff)),
                heading.to_degrees(),
                tilt.to_degrees()
            );
            assert!(diff.z.abs() <= heading, "{} > {heading}", diff.z);
            assert!(diff.xy().amax() <= tilt, "{} > {tilt}", diff.xy());
            j += 1;
        });
    }
}

/// The real laser-gyro recording (skipped with a message when the shared data folder is absent):
/// the benchmark table (`align_bench::lasergyro`), and two physical facts.
/// - On this base (engine running, people moving) the body sways: the static method's
///   gyrocompass reads the window's net rotation rate `dtheta / T` as Earth rate (0.01 deg of
///   sway over 300 s is 0.12 deg/h, 1 % of the 12.4 deg/h horizontal Earth rate here: 0.55 deg
///   of heading), while the inertial-frame method integrates the rotation exactly and only the base's
///   velocity reaches it, attenuated as `1 / T^2` (eq. 9). Its window-to-window spread must be
///   below the static method's at every window length, and it must solve every 300 s window.
/// - Its mean heading over the 300 s windows must agree with the recording's known heading,
///   90.6 deg (header yaw0 -90.6 in PSINS' north-west-positive convention; the data README's
///   independent inertial-frame alignment converges to the same), within 0.3 deg: three times
///   the heading error `eps / (Omega cos L)` = 0.046 deg of an rlg-grade gyro bias (0.01 deg/h,
///   seed 004; unknown and uncompensated here), plus the 0.05 deg rounding of the reference.
#[test]
fn lasergyro_repeatability() {
    use host_tests::align_bench::lasergyro::{self, Method};
    let path = lasergyro::default_path();
    if !path.is_file() {
        eprintln!(
            "skipped: {} is absent (shared data folder not checked out)",
            path.display()
        );
        return;
    }
    println!("{}", lasergyro::run(&path).unwrap());
    let (incs, site, rec) = lasergyro::load(&path).unwrap();
    let rows = lasergyro::evaluate(&incs, &site, rec.header.rate_hz());
    for &w in &lasergyro::WINDOWS_S {
        let row = |m| {
            rows.iter()
                .find(|r| r.window_s == w && r.method == m)
                .unwrap()
        };
        let (st, inr) = (row(Method::Static), row(Method::Inertial));
        assert!(
            inr.std_deg() < st.std_deg(),
            "{w} s: inertial {} vs static {}",
            inr.std_deg(),
            st.std_deg()
        );
        if w == 300.0 {
            assert!(inr.refused.is_empty(), "{:?}", inr.refused);
            let known = -rec.header.yaw0_deg;
            assert!(
                (inr.mean_deg() - known).abs() < 0.3,
                "{} vs {known}",
                inr.mean_deg()
            );
        }
    }
}

/// The disturbance check ([`InertialAlignError::BaseDisturbed`]): on the ship at sea state 6
/// with the lever arm unknown, eq. 9 swings the heading by tens of degrees at 60–120 s (the
/// test above): with a noise model the estimator refuses instead of answering wrongly. With the
/// lever arm known the same data pass the check and the heading is right to the noise level;
/// on the rocking bench without a lever arm (no disturbance) no seed trips the check.
#[test]
fn an_unknown_lever_arm_is_refused_not_answered() {
    let d = exact("ship-rocking", &[("sea_state", 6.0)], 120.5);
    let (model, noise) = fog_white();
    let ks = [index_at(60.0), index_at(120.0)];
    for lever in [None, Some(Vector3::new(30.0, 10.0, 15.0))] {
        let mut inj = ErrorInjector::new(model, 7).unwrap();
        let sensed: Vec<_> = d.incs.iter().map(|i| inj.apply(i)).collect();
        align_or_refuse::<f64>(
            sensed.into_iter(),
            d.lat,
            d.h,
            Some(noise),
            lever,
            &ks,
            |k, est| {
                let t = (k + 1) as f64 / RATE_HZ;
                match (lever, est) {
                    (None, Err(e)) => {
                        println!("lever arm unknown, {t:.0} s: refused ({e})");
                        assert!(
                            matches!(
                                e,
                                InertialAlignError::BaseDisturbed
                                    | InertialAlignError::HeadingUnobservable
                            ),
                            "{e}"
                        );
                    }
                    (None, Ok(est)) => panic!(
                        "lever arm unknown, {t:.0} s: answered with heading error {:.2} deg",
                        errors(&est, &d.truths[k]).z.to_degrees()
                    ),
                    (Some(_), Ok(est)) => {
                        let e = errors(&est, &d.truths[k]);
                        println!(
                            "lever arm known, {t:.0} s: heading error {:.3} deg, 1-sigma {:.3} deg",
                            e.z.to_degrees(),
                            est.sigma_rad.z.to_degrees()
                        );
                        assert!(e.z.abs() < 4.0 * est.sigma_rad.z, "{e}");
                    }
                    (Some(_), Err(e)) => panic!("lever arm known, {t:.0} s: refused ({e})"),
                }
            },
        );
    }
    // No disturbance: 20 seeds on the rocking bench, never refused.
    let bench = auv_bench();
    let ks = [index_at(30.0), index_at(60.0), index_at(120.0)];
    for seed in 0..20 {
        let mut inj = ErrorInjector::new(model, 100 + seed).unwrap();
        let sensed: Vec<_> = bench.incs.iter().map(|i| inj.apply(i)).collect();
        align_or_refuse::<f64>(
            sensed.into_iter(),
            bench.lat,
            bench.h,
            Some(noise),
            None,
            &ks,
            |k, est| {
                if let Err(e) = est {
                    panic!("auv-bench seed {seed}, sample {k}: refused ({e})");
                }
            },
        );
    }
}
