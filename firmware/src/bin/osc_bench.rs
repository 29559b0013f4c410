//! Benchmark binary of the QEMU board: the gyro-free oscillator estimator ([Oscillator INS], `nav_core::oscillator`) in
//! `f32` on the MCU, timed per readout.
//!
//! The board has no oscillator sensor, so the readouts are made on the target: the exact
//! solution of an undamped isotropic oscillator (a fixed ellipse under a constant specific force)
//! seen from a body spinning at 0.5 rad/s, 5 kHz readout of a 100 Hz oscillator. Building a
//! readout (f64 sin/cos, a rotation) is outside the timed span; only `OscillatorEstimator::add`
//! is timed, with the SysTick counter (1 count = 1000/168 guest instructions under QEMU's
//! `-icount shift=0`), separately for ordinary readouts and for the readouts that end a period
//! (where the fit, the frame and the loop run). The worst attitude error after lock is printed
//! against the closed form, a check that the f32 build is the estimator the host tests cover.
//! Run through `firmware/qemu-run.sh ELF`; exits 0 after logging its figures.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use firmware::{ExitCode, StepCost, exit};
use nav_core::Scalar;
use nav_core::nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use nav_core::oscillator::{OscillatorConfig, OscillatorEstimator};

/// Readout rate [Hz].
const RATE_HZ: f64 = 5000.0;
/// Natural frequency [Hz].
const F0_HZ: f64 = 100.0;
/// Readouts timed (2 s).
const READOUTS: u32 = 10_000;
/// Core clock [Hz] (SysTick counts at this rate).
const SYSCLK_HZ: u64 = 168_000_000;

/// Guest instructions in `counts` SysTick counts.
fn instructions(counts: u64) -> u64 {
    counts * 1_000_000_000 / SYSCLK_HZ
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else {
        exit(ExitCode::Panic)
    };
    // SysTick free-running at the core clock over its whole 24-bit range.
    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(0x00ff_ffff);
    core.SYST.clear_current();
    core.SYST.enable_counter();
    run();
    exit(ExitCode::Success)
}

/// Runs the benchmark and logs its figures.
fn run() {
    let reload = u64::from(SYST::get_reload()) + 1;
    let Ok(mut est) = OscillatorEstimator::<f32>::new(OscillatorConfig::new(RATE_HZ, F0_HZ)) else {
        defmt::error!("oscillator bench: bad configuration");
        return;
    };
    // The ellipse (inertial axes) and the body's spin.
    let axes = UnitQuaternion::from_euler_angles(0.3, -0.5, 0.9);
    let (p, q) = (
        axes * Vector3::new(20e-6, 0.0, 0.0),
        axes * Vector3::new(0.0, 10e-6, 0.0),
    );
    let c = Vector3::new(1e-6, -3e-6, -24.5e-6);
    let spin = Vector3::new(0.2, -0.2, 0.42);
    let q_b_i = |t: f64| UnitQuaternion::from_scaled_axis(spin * t);
    let c_e_i = {
        let e1 = p.normalize();
        let e3 = p.cross(&q).normalize();
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            Matrix3::from_columns(&[e1, e3.cross(&e1), e3]),
        ))
    };
    let (mut plain, mut period_end) = (StepCost::default(), StepCost::default());
    let (mut epochs, mut faults, mut worst) = (0_u32, 0_u32, 0.0_f64);
    let mut flip: Option<bool> = None;
    for k in 0..READOUTS {
        let t = f64::from(k) / RATE_HZ;
        // 50 readouts per period exactly: the phase from the readout's place in its period.
        let per_period = (RATE_HZ / F0_HZ) as u32;
        let phase = 2.0 * core::f64::consts::PI * f64::from(k % per_period) / f64::from(per_period);
        let (s, co) = (phase.psin(), phase.pcos());
        let r = q_b_i(t).inverse() * (c + p * co + q * s);
        let r32 = r.map(|x| x as f32);
        let c0 = u64::from(SYST::get_current());
        let out = est.add(&r32);
        let c1 = u64::from(SYST::get_current());
        // SysTick counts down and wraps at `reload` (one readout is far shorter than a wrap).
        let counts = (c0 + reload - c1) % reload;
        match out {
            None => plain.add(counts),
            Some(result) => {
                period_end.add(counts);
                match result {
                    Ok(e) => {
                        epochs += 1;
                        let truth = c_e_i.inverse() * q_b_i(e.t_s);
                        let est_q = nav_core::attitude::quat_to_f64(&e.q_b_e);
                        let flipped = *flip
                            .get_or_insert(est_q.angle_to(&truth) > core::f64::consts::FRAC_PI_2);
                        let truth = if flipped {
                            UnitQuaternion::from_axis_angle(
                                &Vector3::z_axis(),
                                core::f64::consts::PI,
                            ) * truth
                        } else {
                            truth
                        };
                        worst = worst.max(est_q.angle_to(&truth));
                    }
                    Err(_) => faults += 1,
                }
            }
        }
    }
    defmt::info!(
        "oscillator bench (f32, {=u32} readouts at 5 kHz, 100 Hz oscillator, 0.5 rad/s spin): {=u32} epochs, {=u32} periods without one; worst attitude error after lock {=f64} rad",
        READOUTS,
        epochs,
        faults,
        worst
    );
    defmt::info!(
        "instructions per oscillator readout: max {=u64}, mean {=u64}; at a period's end: max {=u64}, mean {=u64}",
        instructions(plain.max),
        instructions(plain.mean()),
        instructions(period_end.max),
        instructions(period_end.mean())
    );
}
