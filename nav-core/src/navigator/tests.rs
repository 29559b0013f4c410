//! The navigator's rules, one test each: counting, the gate, the cadence, the hand-over, the
//! calibration reaching the alignment, the failures, and the firmware's split (a lagging
//! background) giving the inline result.

extern crate std;

use super::*;
use crate::Scalar;
use crate::alignment::{AlignMethod, SensorNoise};
use crate::attitude::from_euler;
use crate::output::Solution;
use crate::{Position, earth};
use nalgebra::{UnitQuaternion, Vector3};
use std::collections::VecDeque;
use std::string::ToString;
use std::vec::Vec;

const RATE_HZ: f64 = 100.0;
const DT: f64 = 1.0 / RATE_HZ;
const LAT_DEG: f64 = 45.0;

fn config(align_seconds: f64, log_every: u32) -> RunConfig {
    RunConfig {
        log_every,
        ..RunConfig::new(LAT_DEG, 0.0, 0.0, align_seconds, SensorNoise::seed003())
    }
}

/// The exact increments at rest at the site with attitude `q_b_n` (f64), plus `dtheta_extra`
/// [rad] and `dv_extra` [m/s] over the interval (sensor errors, motion).
fn at_rest(
    q_b_n: &UnitQuaternion<f64>,
    dtheta_extra: Vector3<f64>,
    dv_extra: Vector3<f64>,
) -> ([f64; 3], [f64; 3]) {
    let lat = LAT_DEG.to_radians();
    let q_n_b = q_b_n.inverse();
    let g = earth::normal_gravity(lat, 0.0);
    let dtheta = q_n_b * earth::omega_ie_n(lat) * DT + dtheta_extra;
    let dv = q_n_b * Vector3::new(0.0, 0.0, -g) * DT + dv_extra;
    (dtheta.into(), dv.into())
}

fn input(k: u32, dtheta: [f64; 3], dv: [f64; 3]) -> ImuInput {
    ImuInput::new(
        u64::from(k) * 10_000,
        dtheta.map(|x| x as f32),
        dv.map(|x| x as f32),
        DT as f32,
        None,
        false,
    )
}

/// `n` level samples at rest (samples numbered from 1).
fn still(n: u32) -> impl Iterator<Item = ImuInput> {
    let (dtheta, dv) = at_rest(
        &UnitQuaternion::identity(),
        Vector3::zeros(),
        Vector3::zeros(),
    );
    (1..=n).map(move |k| input(k, dtheta, dv))
}

/// Runs `inputs` in line; returns the rows logged and the summary (or the error).
fn run<T: Scalar>(
    config: &RunConfig,
    inputs: impl Iterator<Item = ImuInput>,
) -> (Vec<Solution>, Result<Summary<T>, NavError>) {
    let setup = Setup::<T>::new(config, RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    let mut rows = Vec::new();
    for i in inputs {
        match nav.push_inline(&mut bg, &i) {
            Ok(row) => rows.extend(row),
            Err(e) => return (rows, Err(e)),
        }
    }
    let summary = nav.finish();
    if let Ok(s) = &summary {
        rows.extend(s.final_row);
    }
    (rows, summary)
}

#[test]
fn counts_rows_and_logs_the_last_step() {
    let inputs = still(2000).map(|mut i| {
        match i.t_us / 10_000 {
            5 => i.unusable = Some(Unusable::NonFinite),
            1500 => i.unusable = Some(Unusable::Stale),
            1600 => i.gap = true,
            _ => {}
        }
        i
    });
    let (rows, summary) = run::<f64>(&config(10.0, 40), inputs);
    let s = summary.unwrap();
    // 2000 samples, 2 unusable (a gap alone is usable), 1000 aligned, 998 navigation steps.
    let c = s.counters;
    assert_eq!(
        (c.samples, c.flagged, c.rejected, c.nav_steps),
        (2000, 2, 0, 998)
    );
    assert_eq!(
        c.flagged_by,
        FlaggedCounts {
            non_finite: 1,
            stale: 1,
            ..FlaggedCounts::default()
        }
    );
    // The aligned row, 24 periodic rows (960 steps), and the final step 998.
    assert_eq!(c.rows, 1 + 24 + 1);
    assert_eq!(rows.len(), c.rows as usize);
    // The alignment ended on sample 1001 (sample 5 was skipped).
    assert_eq!(rows[0].t_us, 10_010_000);
    assert_eq!(rows[1].t_us, 10_010_000 + 40 * 10_000);
    assert_eq!(rows.last().unwrap().t_us, 20_000_000);
    assert_eq!(s.final_row, rows.last().copied());
    assert_eq!(s.last_solution, *rows.last().unwrap());
    assert_eq!(s.alignment.times.coarse_samples, 1000);
    assert_eq!(s.end_record().to_string(), "# end: 26 rows, ok");
}

#[test]
fn no_final_row_when_the_last_step_was_logged() {
    let (rows, summary) = run::<f32>(&config(10.0, 40), still(1040));
    let s = summary.unwrap();
    assert_eq!((s.counters.nav_steps, s.counters.rows), (40, 2));
    assert_eq!(s.final_row, None);
    assert_eq!(rows.len(), 2);
    // A second finish gives the same summary and no row again.
    let setup = Setup::<f32>::new(&config(10.0, 7), RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    for i in still(1040) {
        nav.push_inline(&mut bg, &i).unwrap();
    }
    let first = nav.finish().unwrap();
    assert_eq!(first.final_row.map(|r| r.t_us), Some(10_400_000));
    let again = nav.finish().unwrap();
    assert_eq!((again.final_row, again.counters), (None, first.counters));
    assert_eq!(s.last_solution.t_us, 10_400_000);
}

#[test]
fn the_gate_rejects_garbage_and_restarts_the_two_sample_history() {
    // Navigation on a base that turns about a changing axis, so coning terms are not zero.
    let q = from_euler(0.01, -0.02, 0.5);
    let moving = |k: u32| {
        let w = Vector3::new(
            1e-3 * libm::sin(f64::from(k) * 0.3),
            2e-3 * libm::cos(f64::from(k) * 0.2),
            5e-4,
        );
        let (dtheta, dv) = at_rest(&q, w, Vector3::zeros());
        input(k, dtheta, dv)
    };
    let aligned_on = |k: u32| {
        let (dtheta, dv) = at_rest(&q, Vector3::zeros(), Vector3::zeros());
        input(k, dtheta, dv)
    };
    let inputs = |gap_at: Option<u32>, nan_at: Option<u32>| {
        (1..=1200_u32).map(move |k| {
            let mut i = if k <= 1000 { aligned_on(k) } else { moving(k) };
            if Some(k) == gap_at {
                i.gap = true;
            }
            if Some(k) == nan_at || k == 500 {
                i.increment.delta_v_ib_b.y = f32::NAN;
            }
            i
        })
    };
    let c = config(10.0, 1);
    let (plain, s) = run::<f64>(&c, inputs(None, None));
    let s = s.unwrap();
    // Sample 500 (NaN, usable) was refused during the alignment: 1001 samples aligned it.
    assert_eq!((s.counters.rejected, s.counters.nav_steps), (1, 199));
    let (gapped, _) = run::<f64>(&c, inputs(Some(1100), None));
    let (refused, s) = run::<f64>(&c, inputs(None, Some(1100)));
    assert_eq!(s.unwrap().counters.rejected, 2);
    // The same steps, driven by hand: restart at the gap, or skip the refused sample (which
    // restarts too).
    let setup = Setup::<f64>::new(&c, RATE_HZ).unwrap();
    let replay = |skip: bool| {
        let mut nav = crate::Strapdown::new(
            plain_alignment(&c, &inputs(None, None)),
            setup.mechanization,
        );
        let mut last = None;
        for k in 1002..=1200 {
            if k == 1100 {
                nav.restart_increments();
                if skip {
                    continue;
                }
            }
            let i = moving(k).increment;
            let inc = crate::ImuIncrement::<f64>::new(
                i.delta_theta_ib_b.map(f64::from).into(),
                i.delta_v_ib_b.map(f64::from).into(),
                f64::from(i.dt),
            );
            nav.step(&inc).unwrap();
            last = Some(Solution::from_state(u64::from(k) * 10_000, nav.state()));
        }
        last.unwrap()
    };
    assert_eq!(*gapped.last().unwrap(), replay(false));
    assert_eq!(*refused.last().unwrap(), replay(true));
    // And the restart matters here: without it the last state differs.
    assert_ne!(gapped.last(), plain.last());
}

/// The state the alignment of `inputs` hands over.
fn plain_alignment(
    c: &RunConfig,
    inputs: &(impl Iterator<Item = ImuInput> + Clone),
) -> crate::NavState<f64> {
    let setup = Setup::<f64>::new(c, RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    for i in inputs.clone() {
        nav.push_inline(&mut bg, &i).unwrap();
        if let Some(a) = nav.alignment() {
            return a.state;
        }
    }
    panic!("not aligned");
}

#[test]
fn navigation_starts_from_the_aligned_state_at_the_last_alignment_sample() {
    let setup = Setup::<f32>::new(&config(10.0, 40), RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    let mut it = still(1001);
    for i in it.by_ref().take(999) {
        assert_eq!(nav.push_inline(&mut bg, &i), Ok(None));
        assert!(nav.is_aligning() && !nav.awaits_background());
    }
    // The 1000th: forwarded, then the foreground waits.
    let i = it.next().unwrap();
    let Step::Forward {
        message,
        await_reply: true,
    } = nav.push(&i)
    else {
        panic!("not the last alignment sample")
    };
    assert!(nav.awaits_background());
    let next = it.next().unwrap();
    assert_eq!(nav.push(&next), Step::NotReady);
    assert_eq!(
        nav.counters().samples,
        1000,
        "a refused push is not counted"
    );
    let answer = bg.handle(message).unwrap();
    let FromBackground::Aligned(outcome) = answer else {
        panic!("{answer:?}")
    };
    let row = nav.on_background(answer).unwrap().unwrap();
    assert_eq!(row.t_us, 10_000_000);
    assert_eq!(nav.strapdown().unwrap().state(), &outcome.state);
    assert_eq!(row, Solution::from_state(10_000_000, &outcome.state));
    assert!(matches!(nav.push(&next), Step::Navigated(None)));
}

#[test]
fn calibration_reaches_the_alignment_and_the_navigation() {
    // A tilted, turned IMU with known biases, scale factors and misalignments.
    let q = from_euler(0.02, -0.03, 0.8);
    let mut cal = crate::ImuCalibration::default();
    cal.gyro.bias = [3e-6, 4e-6, -2e-6];
    cal.gyro.scale = [2e-4, -1e-4, 3e-4];
    cal.accel.bias = [0.05, -0.04, 0.03];
    cal.accel.misalignment = [1e-3, 0.0, -1e-3, 0.0, 5e-4, 0.0];
    let comp = cal.compensation::<f64>().unwrap();
    // measured = (I + S + N) true + bias dt: the inverse of the compensation.
    let measured = |truth: [f64; 3], t: &crate::calibration::TriadCompensation<f64>| {
        let m = t.k.try_inverse().unwrap() * Vector3::from(truth) + t.bias * DT;
        [m.x, m.y, m.z]
    };
    let (dtheta, dv) = at_rest(&q, Vector3::zeros(), Vector3::zeros());
    let (dtheta, dv) = (measured(dtheta, &comp.gyro), measured(dv, &comp.accel));
    let inputs = || (1..=1500).map(move |k| input(k, dtheta, dv));
    let errors = |calibration| {
        let c = RunConfig {
            calibration,
            ..config(10.0, 40)
        };
        let (rows, s) = run::<f64>(&c, inputs());
        let a = s.unwrap().alignment;
        // Levelling absorbs the horizontal errors; the vertical one shows in the height.
        let h_m = rows.last().unwrap().h_m;
        (a.estimate.q_b_n.angle_to(&q).to_degrees(), h_m.abs())
    };
    let (with_deg, with_m) = errors(cal);
    let (without_deg, without_m) = errors(crate::ImuCalibration::default());
    // Exact data: the calibrated alignment is exact to f32 rounding of the inputs; the
    // uncalibrated one is off by the biases (tilt ~ b_a / g = 0.3 deg, heading by the east
    // gyro bias over the horizontal Earth rate: degrees).
    assert!(with_deg < 1e-3, "{with_deg} deg");
    assert!(without_deg > 0.2, "{without_deg} deg");
    // And the navigation: 5 s after the alignment, at rest with the calibration; without it
    // the vertical accelerometer error (~0.03 m/s^2) drops the height by ~0.4 m.
    assert!(with_m < 1e-2, "{with_m} m");
    assert!(without_m > 0.1, "{without_m} m");
}

#[test]
fn failures_end_the_run_with_a_reason() {
    // A base turning at 0.2 deg/s: the static alignment refuses it at the end of its window.
    let (dtheta, dv) = at_rest(
        &UnitQuaternion::identity(),
        Vector3::new(0.0, 0.0, 0.2_f64.to_radians() * DT),
        Vector3::zeros(),
    );
    let (rows, e) = run::<f64>(&config(10.0, 40), (1..=1500).map(|k| input(k, dtheta, dv)));
    let e = e.unwrap_err();
    assert!(rows.is_empty());
    assert!(
        e.to_string()
            .starts_with("alignment failed after 1000 samples: static alignment: "),
        "{e}"
    );
    // The data ends first.
    let (_, e) = run::<f64>(&config(10.0, 40), still(500));
    assert_eq!(
        e.unwrap_err().to_string(),
        "recording ended during alignment: 500 of 1000 samples used"
    );
    // Settings refused before any sample, naming the minimum window.
    let e = Setup::<f32>::new(&config(0.0, 40), RATE_HZ).unwrap_err();
    assert_eq!(
        e.to_string(),
        "alignment window 0.01 s is shorter than the static method's minimum of 10 s"
    );
    let fine = RunConfig {
        align_method: AlignMethod::Fine,
        ..config(15.0, 40)
    };
    let e = Setup::<f32>::new(&fine, RATE_HZ).unwrap_err();
    assert!(
        e.to_string().contains("fine method's minimum of 20 s"),
        "{e}"
    );
    let polar = RunConfig {
        lat_deg: 89.9,
        ..config(10.0, 40)
    };
    assert!(matches!(
        Setup::<f64>::new(&polar, RATE_HZ),
        Err(ConfigError::Alignment(_))
    ));
    assert_eq!(
        Setup::<f64>::new(&config(10.0, 0), RATE_HZ),
        Err(ConfigError::LogEvery)
    );
    let bad_lever = RunConfig {
        lever_arm: crate::alignment::LeverArm::Unknown { sigma_m: -1.0 },
        ..config(10.0, 40)
    };
    assert!(Setup::<f64>::new(&bad_lever, RATE_HZ).is_err());
}

/// A run that navigated nothing fails, with the samples counted by cause: all flagged from the
/// start (the data end during the alignment), all flagged or refused after the alignment, or no
/// sample after it.
#[test]
fn a_run_that_navigates_nothing_fails_with_the_counts() {
    let flag = |cause: Unusable, from: u32| {
        move |mut i: ImuInput| {
            if i.t_us / 10_000 >= u64::from(from) {
                i.unusable = Some(cause);
            }
            i
        }
    };
    let c = config(10.0, 40);
    let (rows, e) = run::<f64>(&c, still(2000).map(flag(Unusable::NonFinite, 1)));
    assert!(rows.is_empty());
    assert_eq!(
        e.unwrap_err().to_string(),
        "recording ended during alignment: 0 of 1000 samples used (2000 flagged: non-finite 2000)"
    );
    // Aligned on the first 1000, then nothing usable: the aligned row only, and an error.
    let (rows, e) = run::<f64>(&c, still(2000).map(flag(Unusable::BadInterval, 1001)));
    assert_eq!(rows.len(), 1);
    let e = e.unwrap_err();
    let NavError::NothingNavigated { n_align, counters } = e else {
        panic!("{e}")
    };
    assert_eq!(
        (
            n_align,
            counters.samples,
            counters.flagged,
            counters.nav_steps
        ),
        (1000, 2000, 1000, 0)
    );
    assert_eq!(
        e.to_string(),
        "no navigation step after the alignment: 2000 samples, 1000 used by the alignment (1000 flagged: bad interval 1000)"
    );
    // Flagged and refused by the input limits.
    let mixed = still(1300).map(|mut i| {
        match i.t_us / 10_000 {
            1001..=1100 => i.unusable = Some(Unusable::DeviceFault),
            1101..=1200 => i.increment.delta_theta_ib_b.x = 1.0e3,
            1201.. => i.unusable = Some(Unusable::Stale),
            _ => {}
        }
        i
    });
    let (_, e) = run::<f32>(&c, mixed);
    assert_eq!(
        e.unwrap_err().to_string(),
        "no navigation step after the alignment: 1300 samples, 1000 used by the alignment (200 flagged: stale 100, device fault 100; 100 rejected)"
    );
    // No sample after the alignment at all; a second finish says the same.
    let setup = Setup::<f64>::new(&c, RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    for i in still(1000) {
        nav.push_inline(&mut bg, &i).unwrap();
    }
    let e = nav.finish().unwrap_err();
    assert_eq!(
        e.to_string(),
        "no navigation step after the alignment: 1000 samples, 1000 used by the alignment"
    );
    assert_eq!(nav.finish().unwrap_err(), e);
}

/// The firmware's way: the background runs later than the foreground (a queue between them,
/// drained a few messages per sample, fully when the foreground waits). Same rows.
#[test]
fn a_lagging_background_gives_the_inline_result() {
    let q = from_euler(0.01, 0.02, -1.0);
    let (dtheta, dv) = at_rest(&q, Vector3::new(1e-9, 0.0, 0.0), Vector3::zeros());
    // 20 s: at 10 s the inertial method's heading 1-sigma (the FOG noise of `SensorNoise::seed003` through its
    // taper) exceeds its 15 deg limit and the window is refused.
    let inputs = || (1..=2300).map(move |k| input(k, dtheta, dv));
    for method in [AlignMethod::Static, AlignMethod::Inertial] {
        let c = RunConfig {
            align_method: method,
            ..config(20.0, 7)
        };
        let (inline, s) = run::<f32>(&c, inputs());
        let s = s.unwrap();
        let setup = Setup::<f32>::new(&c, RATE_HZ).unwrap();
        let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
        let mut queue = VecDeque::new();
        let mut rows = Vec::new();
        for i in inputs() {
            for _ in 0..3 {
                if let Some(m) = queue.pop_front()
                    && let Some(answer) = bg.handle(m)
                {
                    rows.extend(nav.on_background(answer).unwrap());
                }
            }
            match nav.push(&i) {
                Step::Forward {
                    message,
                    await_reply,
                } => {
                    queue.push_back(message);
                    if await_reply {
                        let answer = queue.drain(..).find_map(|m| bg.handle(m)).unwrap();
                        rows.extend(nav.on_background(answer).unwrap());
                    }
                }
                Step::Navigated(row) => rows.extend(row),
                other => panic!("{other:?}"),
            }
        }
        let split = nav.finish().unwrap();
        rows.extend(split.final_row);
        assert_eq!(rows, inline, "{method:?}");
        assert_eq!(split.counters, s.counters);
    }
}

#[test]
fn setup_keeps_the_configured_values() {
    let mut c = config(10.0, 40);
    c.set("lever-arm", "-5.9,0.6,-7.5").unwrap();
    c.set("bias-prior", "0").unwrap();
    let s = Setup::<f32>::new(&c, 400.0).unwrap();
    assert_eq!(s.n_align(), 4000);
    assert_eq!(
        s.align.lever_arm.known(),
        Some(Vector3::new(-5.9_f32, 0.6, -7.5))
    );
    assert_eq!(s.align.noise.gyro_bias_rad_s, 0.0);
    assert_eq!(s.mechanization.compensation, Default::default());
    assert_eq!(s.align.position, Position::from_degrees(LAT_DEG, 0.0, 0.0));
    // 10.1 + 0.2 s at 10 Hz: 103 samples despite the rounding of the sum.
    assert_eq!(
        Setup::<f64>::new(&config(10.1 + 0.2, 40), 10.0)
            .unwrap()
            .n_align(),
        103
    );
}
