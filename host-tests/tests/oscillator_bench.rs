//! The oscillator estimator's accuracy table checked against physics:
//! the method of [Oscillator INS] is first order in `omega/w0`; the compensated one is bounded by
//! its rate estimate's error; with noise, the error follows the estimator's own 1-sigma.

use host_tests::oscillator::OscillatorParams;
use host_tests::oscillator::bench::{coning_for, measure};
use std::f64::consts::PI;

#[test]
fn accuracy_follows_the_derived_orders_and_bounds() {
    let p = OscillatorParams {
        readout_noise_m: 0.0,
        ..OscillatorParams::default()
    };
    let row = |ratio: f64| {
        let mut r = measure(&coning_for(ratio, p.f0_hz, 4.0), &p, 3.0).unwrap();
        r.ratio = ratio;
        r
    };
    let (r1, r10) = (row(1000.0), row(10000.0));
    // First order: ten times the ratio, a tenth of the error.
    let order = r1.seed.attitude_max_deg / r10.seed.attitude_max_deg;
    println!(
        "seed method: worst {:.3e} deg at 1000, {:.3e} at 10000 (ratio {order:.2}, first order: 10)",
        r1.seed.attitude_max_deg, r10.seed.attitude_max_deg
    );
    assert!((8.0..12.5).contains(&order), "{order}");

    // Compensated: the rate estimate's error omega'' T^2/3 and omega_dot's omega'' T times the
    // first-order sensitivities (see nav-core's oscillator tests), for coning at half-angle
    // 0.2 rad: |omega| = 2 sin(0.1) w, omega'' = |omega| w^2.
    let (pm, qm, cm) = (p.major_m, p.minor_m, 9.81 / (2.0 * PI * p.f0_hz).powi(2));
    for r in [&r1, &row(500.0)] {
        let w0 = 2.0 * PI * p.f0_hz;
        let w = w0 / r.ratio / 0.2;
        let rate = 2.0 * 0.1_f64.sin() * w;
        let (t, dd) = (1.0 / p.f0_hz, rate * w * w);
        let bound = dd * t * t / 3.0 * (pm + cm) / (2.0 * w0 * qm)
            + 2.0 * dd * t * cm / (w0 * w0 * qm)
            + 1.3 * dd * cm / (w0.powi(3) * qm);
        let worst = r.compensated.attitude_max_deg.to_radians();
        println!(
            "compensated at {:.0}: worst {worst:.3e} rad, bound {bound:.3e} rad; seed method {:.3e} rad",
            r.ratio,
            r.seed.attitude_max_deg.to_radians()
        );
        assert!(worst < bound, "{worst:e} >= {bound:e}");
    }

    // Noise: the total angle's RMS against the mean largest per-axis 1-sigma (three axes: up
    // to sqrt(3) of it), at 1e-8 m where the noise dominates the motion's share.
    let pn = OscillatorParams {
        readout_noise_m: 1e-8,
        ..OscillatorParams::default()
    };
    let rn = measure(&coning_for(500.0, pn.f0_hz, 6.0), &pn, 5.0).unwrap();
    let k = rn.compensated.attitude_rms_deg / rn.compensated.sigma_deg;
    println!(
        "noise 1e-8 m: rms {:.3e} deg, mean largest 1-sigma {:.3e} deg, ratio {k:.2}",
        rn.compensated.attitude_rms_deg, rn.compensated.sigma_deg
    );
    assert!((0.9..3f64.sqrt() * 1.1).contains(&k), "{k}");
}
