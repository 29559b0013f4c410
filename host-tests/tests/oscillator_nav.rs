//! The oscillator's estimator as the mechanization's attitude source, against gyro-based runs
//! on the same motion. Bounds are derived where they are used.

use host_tests::oscillator::OscillatorParams;
use host_tests::oscillator::navigate::{CHECK_S, NavCompareOptions, NavComparison, compare};
use host_tests::sensor_model::Grade;
use host_tests::trajectory::scenarios::Scenario;
use std::f64::consts::PI;
use std::str::FromStr;

const SECONDS: f64 = 30.0;
/// Standard gravity [m/s^2].
const G: f64 = 9.806_65;

fn run(compensate: bool, grade: &str) -> NavComparison {
    let opts = NavCompareOptions {
        scenario: Scenario::by_name("ship-rocking").unwrap(),
        seconds: SECONDS,
        params: OscillatorParams {
            readout_noise_m: 1e-9,
            ..OscillatorParams::default()
        },
        grade: Grade::from_str(grade).unwrap(),
        compensate,
    };
    let r = compare(&opts).unwrap();
    println!("{r}");
    r
}

/// Ship rocking (sea state 6) for 30 s, readout noise 1 nm: the compensated estimator's
/// navigation stays within its own reported noise, and the method of [Oscillator INS] does worse.
#[test]
fn oscillator_navigates_within_its_reported_noise() {
    let comp = run(true, "fog");
    let seed = run(false, "ideal");
    let p = OscillatorParams::default();
    let s = &comp.stats;
    let o = &comp.oscillator;

    // Sanity: locked once and for all, no gap in the chain of increments.
    let periods = SECONDS * p.f0_hz;
    assert_eq!((s.gaps, s.slips, o.rejected), (0, 0, 0), "{s:?}");
    assert!(s.epochs as f64 > 0.98 * periods, "{} epochs", s.epochs);
    // The ideal gyro run checks the comparison itself (truth, start, mechanization): with
    // exact increments rounded to f32 the errors are those of the rounding.
    let g = &seed.gyro;
    assert!(
        g.worst_attitude_deg < 1e-4 && g.horizontal_m < 0.01,
        "{g:?}"
    );

    // --- Attitude bound. ---
    // The increments are the exact rotations between successive epoch attitudes, so their
    // chain telescopes: the navigated attitude at epoch k is the true start times
    // C_b_e(0)^T C_b_e(k) as estimated, and its error is d_k = e_k - e_0, the difference of two
    // epoch errors; nothing accumulates (the mechanization's Earth and transport rates are
    // exact to ~1e-12 rad in f64 over 30 s).
    // Noise: per ellipse axis i an epoch error has 1-sigma sigma_i (reported), times 1.2 for
    // the noise the rate estimate adds through the rotation back (nav-core's
    // `noise_matches_the_reported_sigma` allows (error/sigma)^2 up to 1.4). d_k per axis then
    // has sd <= sqrt(2) 1.2 sigma_i, and over the N = 3 x (checks) draws the largest
    // |normal| stays below z = sqrt(2 ln(N / 0.01)) with 99 % (union bound, no independence
    // needed), so |d_k| <= z sqrt(2) 1.2 |sigma| (|sigma| the norm of the three sigmas).
    let checks = (SECONDS / CHECK_S).ceil() + 1.0;
    let z = (2.0 * (3.0 * checks / 0.01_f64).ln()).sqrt();
    let sigma_norm = s.sigma_rad_mean.norm();
    let noise = z * 2f64.sqrt() * 1.2 * sigma_norm;
    // Systematic (the compensated first-order term): the rate the periods are rotated back
    // with is a quadratic through the last epochs, off by omega'' T^2/3, and the first-order
    // sensitivity is (P + |c|)/(2 w0 Q) per rad/s; the omega_dot error leaks the centre,
    // 2 omega'' T |c|/(w0^2 Q); the dropped cubic term 1.3 omega'' |c|/(w0^3 Q) (nav-core's
    // `coning_error_is_bounded_by_the_rate_estimate`). |c| = |f|/w0^2. At sea state 6
    // (|omega''| ~ 0.03 rad/s^3) this is ~1e-8 rad: negligible beside the noise (~1e-4), as are
    // the Taylor remainder (|omega| T/2)^4/24 (P + |c|)/Q ~ 1e-13 and the slerp of the truth
    // over 2 ms, |omega'| dt^2/8 ~ 1e-8.
    let w0 = 2.0 * PI * p.f0_hz;
    let t = 1.0 / p.f0_hz;
    let m = &comp.motion;
    let c = m.max_specific_force_mps2 / (w0 * w0);
    let (pm, qm) = (p.major_m, p.minor_m);
    let dd = m.max_rate_ddot_radps3;
    let systematic = dd * t * t / 3.0 * (pm + c) / (2.0 * w0 * qm)
        + 2.0 * dd * t * c / (w0 * w0 * qm)
        + 1.3 * dd * c / (w0.powi(3) * qm);
    let theta_bound = noise + systematic;
    let worst = o.worst_attitude_deg.to_radians();
    println!(
        "attitude: worst {worst:.3e} rad = {:.2} x the largest mean sigma {:.3e}; bound {theta_bound:.3e} rad = {z:.2} sqrt(2) 1.2 |sigma| ({noise:.3e}) + systematic {systematic:.3e}",
        worst / s.sigma_rad_max(),
        s.sigma_rad_max()
    );
    assert!(worst <= theta_bound, "{worst:e} > {theta_bound:e}");

    // --- Horizontal position bound. ---
    // The start is exact; a tilt error theta turns g into a horizontal acceleration error
    // g theta, and the specific-force estimate adds its own error (reported 1-sigma sigma_f
    // per component, taken as a bias: its white part only integrates to sigma_f sqrt(T t)).
    // Both held at their bounds for the whole span t give 0.5 (g theta + sigma_f) t^2. The
    // factor 3: two horizontal components of the f error adding, and the tail of its
    // realisation (sigma_f is a 1-sigma); Schuler feedback (84 min period) and Coriolis on the
    // velocity error (2 Omega |dv| ~ 1e-6 m/s^2) change nothing over 30 s.
    let span = o.end_s - o.start_s;
    let pos_bound = 0.5 * (G * theta_bound + s.sigma_f_mps2_mean) * span * span * 3.0;
    println!(
        "horizontal: {:.3e} m, bound 0.5 (g {theta_bound:.2e} + {:.2e}) {span:.2}^2 x 3 = {pos_bound:.3e} m",
        o.horizontal_m, s.sigma_f_mps2_mean
    );
    assert!(
        o.horizontal_m <= pos_bound,
        "{} > {pos_bound}",
        o.horizontal_m
    );

    // --- The method of [Oscillator INS] (attitude constant over a period) is off at first order in
    // omega/w0: at the ship's |omega| ~ 0.03 rad/s that is ~|omega| (P + 2|c|)/(2 w0 Q) ~ 2e-4
    // rad, above the compensated run's noise.
    let (ws, wc) = (seed.oscillator.worst_attitude_deg, o.worst_attitude_deg);
    println!(
        "seed method: worst attitude {ws:.3e} deg vs compensated {wc:.3e} deg ({:.1} x)",
        ws / wc
    );
    assert!(ws > wc, "seed {ws:e} deg <= compensated {wc:e} deg");
}
