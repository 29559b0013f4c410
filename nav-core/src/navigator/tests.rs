//! The navigator's rules, one test each: counting, the gate, the cadence, the hand-over, the
//! calibration reaching the alignment, the failures, and the firmware's split (a lagging
//! background) giving the inline result.

extern crate std;

use super::*;
use crate::ImuIncrement;
use crate::Scalar;
use crate::alignment::{AlignMethod, SensorNoise};
use crate::attitude::from_euler;
use crate::ins_filter::sequencer::GnssFixInput;
use crate::ins_filter::{FilterStatus, GnssPosition, GnssVelocity, integrity};
use crate::output::{Row, Solution};
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
            Ok(row) => rows.extend(row.map(|r| *r.solution())),
            Err(e) => return (rows, Err(e)),
        }
    }
    let summary = nav.finish();
    if let Ok(s) = &summary {
        rows.extend(s.final_row.map(|r| *r.solution()));
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
    assert_eq!(s.final_row, rows.last().copied().map(Row::Free));
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
    assert_eq!(first.final_row.map(|r| r.solution().t_us), Some(10_400_000));
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
            // Still through the alignment's 1001 samples (one refused): a turning sample in
            // its mean would put the gyros' Earth rate off the latitude's.
            let mut i = if k <= 1001 { aligned_on(k) } else { moving(k) };
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
    // restarts too), whose interval the next sample bridges ([`crate::gap`]).
    let setup = Setup::<f64>::new(&c, RATE_HZ).unwrap();
    let replay = |skip: bool| {
        let mut nav = crate::Strapdown::new(
            plain_alignment(&c, &inputs(None, None)),
            setup.mechanization,
        );
        let increment = |k: u32| {
            let i = moving(k).increment;
            crate::ImuIncrement::<f64>::new(
                i.delta_theta_ib_b.map(f64::from).into(),
                i.delta_v_ib_b.map(f64::from).into(),
                f64::from(i.dt),
            )
        };
        let mut last = None;
        for k in 1002..=1200 {
            if k == 1100 {
                nav.restart_increments();
                if skip {
                    let mut gaps = crate::gap::GapDetector::new();
                    gaps.note(1099 * 10_000, &increment(1099));
                    let gap = gaps.note(1101 * 10_000, &increment(1101)).unwrap();
                    let (n, bridge) = gap.step();
                    assert_eq!(n, 1);
                    nav.step(&bridge).unwrap();
                    continue;
                }
            }
            let inc = increment(k);
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
        increment,
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
    let answer = bg.handle(ToBackground::Align(increment)).unwrap();
    let FromBackground::Aligned(outcome) = answer else {
        panic!("{answer:?}")
    };
    let row = nav.on_background(answer).unwrap().unwrap();
    assert_eq!(row.solution().t_us, 10_000_000);
    assert_eq!(nav.strapdown().unwrap().state(), &outcome.state);
    assert_eq!(
        row,
        Row::Free(Solution::from_state(10_000_000, &outcome.state))
    );
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
    // The window as asked (0 s, -1 s), not its sample count's one sample.
    let e = Setup::<f32>::new(&config(0.0, 40), RATE_HZ).unwrap_err();
    assert_eq!(
        e.to_string(),
        "alignment window 0 s is shorter than the static method's minimum of 10 s"
    );
    let e = Setup::<f32>::new(&config(-1.0, 40), RATE_HZ).unwrap_err();
    assert_eq!(
        e.to_string(),
        "alignment window -1 s is shorter than the static method's minimum of 10 s"
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
                    increment,
                    await_reply,
                } => {
                    queue.push_back(ToBackground::Align(increment));
                    if await_reply {
                        let answer = queue.drain(..).find_map(|m| bg.handle(m)).unwrap();
                        rows.extend(nav.on_background(answer).unwrap());
                    }
                }
                Step::Navigated(row) => rows.extend(row.map(Row::Free)),
                other => panic!("{other:?}"),
            }
        }
        let split = nav.finish().unwrap();
        rows.extend(split.final_row);
        let rows: Vec<Solution> = rows.iter().map(|r| *r.solution()).collect();
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

/// An aided run of `config(10.0, log_every)` at 100 Hz: the site's position as GNSS fixes.
fn aided_config(log_every: u32) -> RunConfig {
    RunConfig {
        aiding: Some(AidingConfig::default()),
        ..config(10.0, log_every)
    }
}

/// A fix of the site at `t_us` with 1-sigma `sigma_m` [m] per axis, and a zero velocity.
fn site_fix<T: Scalar>(t_us: u64, sigma_m: f64) -> GnssFixInput<T> {
    GnssFixInput {
        t_us,
        position: GnssPosition {
            lat_rad: LAT_DEG.to_radians(),
            lon_rad: 0.0,
            h_m: 0.0,
            sigma_ned_m: Vector3::repeat(T::c(sigma_m)),
        },
        velocity: Some(GnssVelocity {
            v_ned_m_s: Vector3::zeros(),
            sigma_ned_m_s: Vector3::repeat(T::c(0.05)),
        }),
    }
}

/// Runs `inputs` with `fixes` (each handed over before the first sample at or after its
/// time) in line; returns the rows and the summary.
fn run_aided<T: Scalar>(
    config: &RunConfig,
    inputs: impl Iterator<Item = ImuInput>,
    fixes: &[GnssFixInput<T>],
) -> (Vec<Row>, Summary<T>) {
    let setup = Setup::<T>::new(config, RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    let mut rows = Vec::new();
    let mut next = fixes.iter().peekable();
    for i in inputs {
        while let Some(f) = next.next_if(|f| f.t_us <= i.t_us) {
            nav.push_fix(*f);
        }
        rows.extend(nav.push_inline(&mut bg, &i).unwrap());
    }
    nav.end_of_data();
    rows.extend(nav.work_inline(&mut bg).unwrap());
    let s = nav.finish().unwrap();
    rows.extend(s.final_row);
    (rows, s)
}

/// Fixes of the site every second from 1 s to `seconds`, 0.3 ms after the sample grid.
fn site_fixes<T: Scalar>(seconds: u64) -> Vec<GnssFixInput<T>> {
    (1..=seconds)
        .map(|k| site_fix(k * 1_000_000 + 300, 0.5))
        .collect()
}

#[test]
fn an_aided_run_logs_the_filter_and_counts_the_fixes() {
    // 10 s aligning, 30 s aided at rest; fixes of the site at 1 Hz from the start.
    let (rows, s) = run_aided::<f64>(&aided_config(100), still(4000), &site_fixes(40));
    // The aligned row (its columns the filter's start: the alignment's 1-sigmas), a row a
    // second, the last step's.
    assert_eq!(s.counters.nav_steps, 3000);
    assert_eq!(rows.len(), 1 + 30);
    assert_eq!(rows.len() as u32, s.counters.rows);
    assert!(rows.iter().all(|r| r.filter().is_some()), "aided rows only");
    let first = rows[0].filter().unwrap();
    let a = s.alignment;
    assert_eq!(
        first.sigma_att_deg[2],
        a.estimate.sigma_rad.z.to_degrees() as f32
    );
    assert_eq!(first.sigma_ned_m[0], a.position_sigma_m.x as f32);
    // Fixes 1..9 came during the alignment (unused; it ended with the sample at 10 s); 10..39
    // at their samples, 9.7 ms late for the first, 0.3 ms late for the others; 40 after the
    // last sample.
    assert_eq!(s.counters.fixes_unused, 9);
    assert_eq!(s.fixes.received, 30);
    assert_eq!((s.fixes.late, s.fixes.out_of_order), (0, 0));
    let f = s.filter.unwrap();
    assert_eq!(
        (f.counters.position.accepted, f.counters.velocity.accepted),
        (30, 30)
    );
    // Stops: zero-velocity and zero-rate updates from the detector.
    assert!(f.counters.zero_velocity.accepted > 10, "{:?}", f.counters);
    assert_eq!(f.status, FilterStatus::Nominal);
    assert_eq!(f.covariance_faults, 0);
    // The position converges on the fixes: 1-sigma below the fix's after 30 of them, and
    // the solution within 3 of it.
    let last = rows.last().unwrap();
    let c = last.filter().unwrap();
    assert!(c.sigma_ned_m[0] < 0.5 && c.sigma_ned_m[1] < 0.5, "{c:?}");
    assert_eq!(c.status, "NAV");
    let sol = last.solution();
    let site = Position::from_degrees(LAT_DEG, 0.0, 0.0);
    let fixed = Position::from_degrees(
        sol.lat_ndeg as f64 * 1e-9,
        sol.lon_ndeg as f64 * 1e-9,
        sol.h_m,
    );
    let d = site.ned_to(&fixed);
    for k in 0..3 {
        assert!(
            d[k].abs() < 3.0 * f64::from(c.sigma_ned_m[k]),
            "{d:?} {c:?}"
        );
    }
    assert_eq!(sol.t_us, 40_000_000);
    // The log's text: the aided header's column count on every row.
    let columns = crate::output::AIDED_CSV_HEADER.split(',').count();
    for r in &rows {
        assert_eq!(r.to_string().split(',').count(), columns, "{r}");
    }
}

/// The sequencer started from the alignment of `s` (a run of `c` aligned over its first
/// 10 s) as the navigator's aided phase starts, fed the samples and fixes after it as the
/// navigator was.
fn sequencer_from_alignment<T: Scalar>(
    c: &RunConfig,
    s: &Summary<T>,
    inputs: impl Iterator<Item = ImuInput>,
    fixes: &[GnssFixInput<T>],
) -> crate::ins_filter::sequencer::Sequencer<T> {
    use crate::ins_filter::sequencer::{Sequencer, Start};
    let config = Setup::<T>::new(c, RATE_HZ).unwrap().filter.unwrap();
    let start = Start::Given {
        state: s.alignment.state,
        sensors: crate::ins_filter::SensorErrors::default(),
        sigma: initial_sigma(&s.alignment, &config),
    };
    let mut seq = Sequencer::new(config, start).unwrap();
    let aligned_us = 10_000_000;
    let mut next = fixes.iter().filter(|f| f.t_us > aligned_us).peekable();
    for i in inputs.filter(|i| i.t_us > aligned_us) {
        while let Some(f) = next.next_if(|f| f.t_us <= i.t_us) {
            seq.push_fix(*f);
        }
        let inc = ImuIncrement {
            delta_theta_ib_b: i.increment.delta_theta_ib_b.map(T::of_f32),
            delta_v_ib_b: i.increment.delta_v_ib_b.map(T::of_f32),
            dt: T::of_f32(i.increment.dt),
        };
        seq.on_sample(i.t_us, &inc).unwrap();
    }
    seq
}

/// The navigator's aided phase is the filter run in line ([`crate::ins_filter::AidedIns`]
/// under the [`crate::ins_filter::sequencer::Sequencer`]) started from the alignment's
/// outcome: the same state to the last bit, in both precisions.
#[test]
fn the_aided_phase_is_the_sequencer_started_from_the_alignment() {
    fn check<T: Scalar>() {
        let q = from_euler(0.01, -0.02, 0.7);
        // Turning and accelerating gently after the alignment.
        let sample = |k: u32| {
            let (w, a) = if k > 1000 {
                let t = f64::from(k) * 0.01;
                (
                    Vector3::new(0.0, 0.0, 2e-3 * libm::sin(t)) * DT,
                    Vector3::new(0.05 * libm::cos(0.5 * t), 0.0, 0.0) * DT,
                )
            } else {
                (Vector3::zeros(), Vector3::zeros())
            };
            let (dtheta, dv) = at_rest(&q, w, a);
            input(k, dtheta, dv)
        };
        let c = aided_config(7);
        let fixes = site_fixes::<T>(30);
        let (rows, s) = run_aided::<T>(&c, (1..=3000).map(sample), &fixes);
        let seq = sequencer_from_alignment(&c, &s, (1..=3000).map(sample), &fixes);
        let ins = seq.filter().unwrap();
        let last = Solution::from_state(30_000_000, ins.state());
        assert_eq!(*rows.last().unwrap().solution(), last);
        let f = s.filter.unwrap();
        assert_eq!(f.counters, *ins.counters());
        assert_eq!(f.sigma_ned_m, ins.sigma(crate::ins_filter::POS));
        // Every fix from 10 s to the last sample was applied (the made-up motion disagrees
        // with some of them: the gate's path too).
        let p = f.counters.position;
        assert_eq!(p.accepted + p.rejected, 20, "{:?}", f.counters);
        assert!(f.counters.propagations > 190, "{:?}", f.counters);
    }
    check::<f64>();
    check::<f32>();
}

/// [`run_aided`] the firmware's way: the background lags one message per sample behind
/// the foreground, which waits for the answered messages; returns the rows and the summary.
fn run_split<T: Scalar>(
    config: &RunConfig,
    inputs: impl Iterator<Item = ImuInput>,
    fixes: &[GnssFixInput<T>],
) -> (Vec<Row>, Summary<T>) {
    let setup = Setup::<T>::new(config, RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    let mut queue: VecDeque<ToBackground<T>> = VecDeque::new();
    let mut rows = Vec::new();
    let mut next = fixes.iter().peekable();
    let answered = |nav: &mut Navigator<T>,
                    queue: &mut VecDeque<ToBackground<T>>,
                    bg: &mut Background<T>,
                    rows: &mut Vec<Row>| {
        // The queue in order up to the awaited message's answer.
        let answer = core::iter::from_fn(|| queue.pop_front())
            .find_map(|m| bg.handle(m))
            .unwrap();
        rows.extend(nav.on_background(answer).unwrap());
    };
    for i in inputs {
        // The background lags: one message per sample between the foreground's turns.
        if let Some(m) = queue.pop_front() {
            assert!(!m.is_answered());
            assert_eq!(bg.handle(m), None);
        }
        while let Some(f) = next.next_if(|f| f.t_us <= i.t_us) {
            nav.push_fix(*f);
        }
        match nav.push(&i) {
            Step::Forward {
                increment,
                await_reply,
            } => {
                queue.push_back(ToBackground::Align(increment));
                if await_reply {
                    answered(&mut nav, &mut queue, &mut bg, &mut rows);
                }
            }
            Step::Aided => {
                while let Some(m) = nav.next_message() {
                    let wait = m.is_answered();
                    queue.push_back(m);
                    if wait {
                        assert_eq!(nav.push(&i), Step::NotReady);
                        answered(&mut nav, &mut queue, &mut bg, &mut rows);
                    }
                }
            }
            other => panic!("{other:?}"),
        }
    }
    nav.end_of_data();
    while let Some(m) = nav.next_message() {
        let wait = m.is_answered();
        queue.push_back(m);
        if wait {
            answered(&mut nav, &mut queue, &mut bg, &mut rows);
        }
    }
    let split = nav.finish().unwrap();
    rows.extend(split.final_row);
    (rows, split)
}

/// The firmware's way in the aided phase: propagations queue up behind the foreground,
/// answered messages are waited for. Same rows as in line; fixes refused by the queue and
/// bad fixes counted, never a panic.
#[test]
fn an_aided_split_run_gives_the_inline_result_and_counts_bad_fixes() {
    let mut fixes = site_fixes::<f32>(25);
    // A NaN fix, and one that repeats its predecessor's time.
    fixes[14].position.lat_rad = f64::NAN;
    fixes.insert(16, fixes[15]);
    let c = aided_config(40);
    let (inline, s) = run_aided::<f32>(&c, still(2500), &fixes);
    let f = s.filter.unwrap();
    assert_eq!(f.counters.position.invalid, 1, "{:?}", f.counters);
    assert_eq!(s.fixes.out_of_order, 1);

    let (rows, split) = run_split::<f32>(&c, still(2500), &fixes);
    assert_eq!(rows, inline);
    assert_eq!(split.filter, s.filter);
}

#[test]
fn fixes_are_held_and_timed_by_the_queue() {
    // A fix 0.15 s old when handed over is late; the others apply.
    let c = aided_config(100);
    let setup = Setup::<f64>::new(&c, RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    // Before the aided phase: not taken.
    assert!(!nav.push_fix(site_fix(5_000_000, 0.5)));
    for i in still(1100) {
        nav.push_inline(&mut bg, &i).unwrap();
    }
    assert!(nav.is_aided());
    assert!(nav.push_fix(site_fix(10_850_000, 0.5)));
    // Not later than the previous one: refused.
    assert!(!nav.push_fix(site_fix(10_850_000, 0.5)));
    for i in still(1200).skip(1100) {
        nav.push_inline(&mut bg, &i).unwrap();
    }
    nav.end_of_data();
    nav.work_inline(&mut bg).unwrap();
    let s = nav.finish().unwrap();
    assert_eq!(s.counters.fixes_unused, 1);
    assert_eq!(
        (s.fixes.received, s.fixes.out_of_order, s.fixes.late),
        (2, 1, 1)
    );
    assert_eq!(s.filter.unwrap().counters.position.accepted, 0);
    // A free-inertial run takes no fix.
    let setup = Setup::<f64>::new(&config(10.0, 100), RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    for i in still(1100) {
        nav.push_inline(&mut bg, &i).unwrap();
    }
    assert!(!nav.push_fix(site_fix(10_950_000, 0.5)));
    assert_eq!(nav.counters().fixes_unused, 1);
    assert_eq!(nav.next_message(), None);
}

#[test]
fn an_aided_run_refuses_bad_settings_and_an_unstartable_filter() {
    let bad = RunConfig {
        aiding: Some(AidingConfig {
            propagation_interval_s: 2.0,
            ..AidingConfig::default()
        }),
        ..config(10.0, 40)
    };
    assert!(matches!(
        Setup::<f32>::new(&bad, RATE_HZ),
        Err(ConfigError::Aiding(_))
    ));
    // The filter refuses a non-finite start: the run ends with the reason.
    let setup = Setup::<f64>::new(&aided_config(40), RATE_HZ).unwrap();
    let mut nav = Navigator::<f64>::new(&setup);
    let e = nav
        .on_background(FromBackground::FilterFailed(
            crate::ins_filter::FilterError::BadInitialSigma(
                "the initial position 1-sigma must be 0 to 6,400 km",
            ),
        ))
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "the navigation filter cannot start from the alignment's outcome: the initial position 1-sigma must be 0 to 6,400 km"
    );
    assert_eq!(nav.push(&still(1).next().unwrap()), Step::NotReady);
    assert_eq!(nav.finish().unwrap_err(), e);
}

/// A declared GNSS correlated error reaches the aided phase's filter, in the run's precision;
/// without one, the filter has none; out of its range, the run is refused with the filter's
/// reason.
#[test]
fn the_gnss_correlated_error_reaches_the_filter() {
    let filter_error = |a: AidingConfig| {
        let c = RunConfig {
            aiding: Some(a),
            ..config(10.0, 40)
        };
        Setup::<f32>::new(&c, RATE_HZ).map(|s| s.filter.unwrap().gnss_correlated_error)
    };
    assert_eq!(filter_error(AidingConfig::default()), Ok(None));
    let declared = AidingConfig {
        gnss_correlated_sigma_ned_m: Some([2.0, 2.5, 4.0]),
        gnss_correlated_time_s: 90.0,
        ..AidingConfig::default()
    };
    assert_eq!(
        filter_error(declared),
        Ok(Some(crate::ins_filter::GnssCorrelatedError {
            sigma_ned_m: Vector3::new(2.0, 2.5, 4.0),
            correlation_time_s: 90.0,
        }))
    );
    let e = filter_error(AidingConfig {
        gnss_correlated_time_s: 1e9,
        ..declared
    })
    .unwrap_err();
    assert!(
        e.to_string().contains("correlation time must be 1 s"),
        "{e}"
    );
}

/// A gap beyond the bridge while navigating free inertial leaves the log its lost record,
/// once, at the first sample after it; a bridged gap none (f32, as the firmware).
#[test]
fn a_lost_free_inertial_gap_leaves_its_record_once() {
    let setup = Setup::<f32>::new(&config(10.0, 40), RATE_HZ).unwrap();
    let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
    let mut records = Vec::new();
    for mut i in still(3000) {
        // 1 s lost after sample 1200 (bridged), 6 s more after sample 1500 (lost).
        i.t_us += match i.t_us / 10_000 {
            k if k > 1500 => 7_000_000,
            k if k > 1200 => 1_000_000,
            _ => 0,
        };
        nav.push_inline(&mut bg, &i).unwrap();
        if let Some(r) = nav.take_lost_record() {
            records.push((i.t_us, r));
        }
    }
    assert_eq!(records.len(), 1, "{records:?}");
    let (t_us, r) = records[0];
    assert_eq!((t_us, r.t_us), (22_010_000, 22_010_000));
    assert!(r.gap_us.abs_diff(6_000_000) <= 1, "{r:?}");
    assert_eq!(nav.counters().gaps.bridged, 1);
    assert_eq!(nav.counters().gaps.lost, 1);
}

/// A gap inside the window of an alignment that integrates the attitude ends the run with the
/// gap named (was: skipped, a heading 136 deg off claiming a 3.3 deg 1-sigma); the static
/// method's averages take it.
#[test]
fn a_gap_inside_an_integrating_alignment_ends_the_run() {
    let gapped = || {
        still(2500).map(|mut i| {
            if i.t_us > 5_000_000 {
                i.t_us += 1_000_000;
            }
            i
        })
    };
    let mut c = config(15.0, 100);
    c.align_method = AlignMethod::Inertial;
    let (_, s) = run::<f64>(&c, gapped());
    let e = s.unwrap_err();
    assert_eq!(
        e,
        NavError::GapDuringAlignment {
            samples: 500,
            lost_us: 1_000_000
        }
    );
    assert!(
        e.to_string().contains("1000000 us of IMU data missing"),
        "{e}"
    );
    // The same data through the static method: aligned, and the later samples navigated.
    let (_, s) = run::<f64>(&config(15.0, 100), gapped());
    assert!(s.is_ok(), "{s:?}");
}

/// A flagged sample's step names its cause, the navigator's own (out of time order) as well
/// as its flags' (the firmware's log said "flagged usable" for a clock that stepped back).
#[test]
fn a_flagged_step_names_its_cause() {
    let setup = Setup::<f64>::new(&config(10.0, 40), RATE_HZ).unwrap();
    let mut nav = Navigator::new(&setup);
    let mut inputs = still(3);
    let (a, b, mut c) = (
        inputs.next().unwrap(),
        inputs.next().unwrap(),
        inputs.next().unwrap(),
    );
    assert!(!matches!(nav.push(&b), Step::Flagged(_)));
    assert_eq!(nav.push(&a), Step::Flagged(Unusable::OutOfOrder));
    c.unusable = Some(Unusable::Stale);
    assert_eq!(nav.push(&c), Step::Flagged(Unusable::Stale));
}

/// A clock that steps back for good while navigating: its samples are flagged out of order
/// until their time passes the last navigated one, the rows stay in time order, and the time
/// the skipped samples covered is a gap before the next navigated sample: bridged for 2 s,
/// lost for 6 s.
#[test]
fn a_clock_that_steps_back_is_flagged_and_its_time_is_a_gap() {
    for (step_back_us, skipped, bridged, lost) in [(2_000_000, 200, 1, 0), (6_000_000, 600, 0, 1)] {
        let inputs = still(3000).map(|mut i| {
            if i.t_us >= 15_000_000 {
                i.t_us -= step_back_us;
            }
            i
        });
        let (rows, summary) = run::<f64>(&config(10.0, 40), inputs);
        let s = summary.unwrap();
        let c = s.counters;
        assert_eq!(
            (c.flagged, c.flagged_by.out_of_order),
            (skipped, skipped),
            "{c:?}"
        );
        assert_eq!(c.nav_steps, 2000 - skipped);
        assert_eq!((c.gaps.bridged, c.gaps.lost), (bridged, lost), "{c:?}");
        let lost_us = u64::from(skipped) * 10_000;
        assert!(c.gaps.longest_us.abs_diff(lost_us) <= 1, "{c:?}");
        assert!(rows.windows(2).all(|w| w[0].t_us < w[1].t_us));
        let by_cause = std::string::ToString::to_string(&c.flagged_by);
        assert_eq!(by_cause, std::format!("time out of order {skipped}"));
    }
}

/// A static alignment takes a gap in its window (its averages do not integrate the attitude),
/// but its window of samples then spans the gap's time too: when the base moved after the gap
/// (here, turning at 0.2 deg/s), the refusal names the gap. Without a gap it does not.
#[test]
fn a_static_alignment_that_fails_after_a_gap_names_it() {
    let still_then_turning = |gap_us: u64| {
        let (still_theta, dv) = at_rest(
            &UnitQuaternion::identity(),
            Vector3::zeros(),
            Vector3::zeros(),
        );
        let (turning_theta, _) = at_rest(
            &UnitQuaternion::identity(),
            Vector3::new(0.0, 0.0, 0.2_f64.to_radians() * DT),
            Vector3::zeros(),
        );
        (1..=1500).map(move |k| {
            let mut i = input(k, if k <= 500 { still_theta } else { turning_theta }, dv);
            if k > 500 {
                i.t_us += gap_us;
            }
            i
        })
    };
    let (_, e) = run::<f64>(&config(10.0, 40), still_then_turning(6_000_000));
    let text = std::string::ToString::to_string(&e.unwrap_err());
    assert!(
        text.starts_with("alignment failed after 1000 samples: ")
            && text.ends_with(
                "(1 gap(s) in the IMU data inside its window, 6000000 us in all, the longest \
                 6000000 us: its samples spanned that much more time than asked, the base may \
                 have moved in it)"
            ),
        "{text}"
    );
    let (_, e) = run::<f64>(&config(10.0, 40), still_then_turning(0));
    let text = std::string::ToString::to_string(&e.unwrap_err());
    assert!(!text.contains("gap"), "{text}");
}

/// The aided phase re-aligns in motion as the sequencer does ([`crate::ins_filter::sequencer`]):
/// after a gap in the IMU data too long to bridge, and after the filter diverged.
mod realign {
    use super::*;
    use crate::ins_filter::sequencer::RealignCause;
    use crate::ins_filter::sequencer::tests::drive::east_increment;

    /// Speed once driving [m/s] (east, body forward).
    const V_E: f64 = 10.0;

    fn heading_east() -> UnitQuaternion<f64> {
        from_euler(0.0, 0.0, core::f64::consts::FRAC_PI_2)
    }

    /// A fix at `t_us` of the site moved `east_m` [m] east, 1-sigma 0.5 m, with the
    /// velocity `v_e` [m/s] east (`None`: position only).
    fn fix_at<T: Scalar>(t_us: u64, east_m: f64, v_e: Option<f64>) -> GnssFixInput<T> {
        let p = Position::from_degrees(LAT_DEG, 0.0, 0.0).offset_ned([0.0, east_m, 0.0]);
        GnssFixInput {
            t_us,
            position: GnssPosition {
                lat_rad: p.lat_f64(),
                lon_rad: p.lon_f64(),
                h_m: p.h_f64(),
                sigma_ned_m: Vector3::repeat(T::c(0.5)),
            },
            velocity: v_e.map(|v| GnssVelocity {
                v_ned_m_s: Vector3::new(T::zero(), T::c(v), T::zero()),
                sigma_ned_m_s: Vector3::repeat(T::c(0.05)),
            }),
        }
    }

    /// The navigator's run (in line, and the firmware's way with a lagging background: the
    /// same rows) and the sequencer's, started from its alignment, on the same samples and
    /// fixes: both end on the same state, counters and re-alignments. Returns the navigator's
    /// rows and summary.
    fn navigator_and_sequencer<T: Scalar>(
        inputs: &[ImuInput],
        fixes: &[GnssFixInput<T>],
    ) -> (Vec<Row>, Summary<T>) {
        let c = aided_config(100);
        let (rows, s) = run_aided::<T>(&c, inputs.iter().copied(), fixes);
        // The firmware's way: the same rows.
        let (split_rows, split) = run_split::<T>(&c, inputs.iter().copied(), fixes);
        assert_eq!(split_rows, rows);
        assert_eq!(split.realignments, s.realignments);
        let seq = sequencer_from_alignment(&c, &s, inputs.iter().copied(), fixes);
        let ins = seq.filter().unwrap();
        let t_end = inputs.last().unwrap().t_us;
        assert_eq!(
            *rows.last().unwrap().solution(),
            Solution::from_state(t_end, ins.state())
        );
        assert_eq!(s.filter.unwrap().counters, *ins.counters());
        assert_eq!(s.realignments, *seq.realignments());
        assert_eq!(s.fixes.for_start, seq.fix_counters().for_start);
        (rows, s)
    }

    /// Horizontal error [m] of `row` against the site moved `east_m` east, and the row's
    /// horizontal 1-sigma [m].
    fn horizontal(row: &Row, east_m: f64) -> (f64, f64) {
        let sol = row.solution();
        let at = Position::from_degrees(
            sol.lat_ndeg as f64 * 1e-9,
            sol.lon_ndeg as f64 * 1e-9,
            sol.h_m,
        );
        let d = Position::from_degrees(LAT_DEG, 0.0, 0.0)
            .offset_ned([0.0, east_m, 0.0])
            .ned_to(&at);
        let c = row.filter().unwrap();
        let s = c.sigma_ned_m.map(f64::from);
        (
            (d[0] * d[0] + d[1] * d[1]).sqrt(),
            (s[0] * s[0] + s[1] * s[1]).sqrt(),
        )
    }

    /// Aligned at rest heading east, aided by fixes at rest to 20 s; the IMU data lost from
    /// 20 to 26 s, while the vehicle drove off (30 m east at 26 s, 10 m/s); fixes of the drive
    /// from 26 s. The first fix after the gap sets the filter aside (its rows DEGRADED), the
    /// next ones find level and heading, and the filter navigates again (NAV) within 3 sigma
    /// to the end, as the sequencer does to the last bit. Was: DEGRADED (IMU_LOST) to the end.
    #[test]
    fn a_lost_gap_with_fixes_after_it_realigns_the_aided_phase() {
        let q = heading_east();
        let (rest_theta, rest_v) = at_rest(&q, Vector3::zeros(), Vector3::zeros());
        let drive = east_increment(LAT_DEG.to_radians(), 0.0, V_E, DT);
        let inputs: Vec<ImuInput> = (1..=2000)
            .map(|k| input(k, rest_theta, rest_v))
            .chain(
                (2601..=6000)
                    .map(|k| input(k, drive.delta_theta_ib_b.into(), drive.delta_v_ib_b.into())),
            )
            .collect();
        let east_at = |t_s: f64| {
            if t_s <= 20.0 {
                0.0
            } else {
                30.0 + V_E * (t_s - 26.0)
            }
        };
        fn fixes<T: Scalar>(east_at: impl Fn(f64) -> f64) -> Vec<GnssFixInput<T>> {
            (1..=20)
                .chain(26..=60)
                .map(|k| match k {
                    1..=20 => site_fix(k * 1_000_000 + 300, 0.5),
                    _ => fix_at(k * 1_000_000 + 300, east_at(k as f64 + 3e-4), Some(V_E)),
                })
                .collect()
        }
        // At the first sample after the gap the filter is set aside (the fix at 26 s is due):
        // the status is the lost solution's, before any report says so.
        let setup = Setup::<f64>::new(&aided_config(100), RATE_HZ).unwrap();
        let (mut nav, mut bg) = (Navigator::new(&setup), Background::new(&setup));
        let all = fixes::<f64>(east_at);
        let mut next = all.iter().peekable();
        for i in &inputs[..2001] {
            while let Some(f) = next.next_if(|f| f.t_us <= i.t_us) {
                nav.push_fix(*f);
            }
            nav.push_inline(&mut bg, i).unwrap();
        }
        assert!(nav.realigning());
        assert_eq!(nav.filter_status(), Some(FilterStatus::ImuLost));
        assert_eq!(nav.filter_report().unwrap().status, FilterStatus::Nominal);
        // In the MCU's precision too.
        let (_, s32) = navigator_and_sequencer::<f32>(&inputs, &fixes(east_at));
        let (rows, s) = navigator_and_sequencer::<f64>(&inputs, &fixes(east_at));
        assert_eq!(s32.realignments.completed, 1, "{:?}", s32.realignments);
        let r = s.realignments;
        assert_eq!(
            (r.begun, r.completed, r.started_over, r.last_cause),
            (1, 1, 0, RealignCause::LostGap),
            "{r:?}"
        );
        assert_eq!(
            (r.begun_us, r.gap_end_us),
            (26_010_000, 26_010_000),
            "{r:?}"
        );
        assert!((r.gap_us as f64 - 6e6).abs() < 20.0, "{r:?}");
        assert!(r.navigating_us <= 30_010_000, "{r:?}");
        assert!(s.fixes.for_start >= 2, "{:?}", s.fixes);
        for row in &rows {
            let t = row.solution().t_us;
            let status = row.filter().unwrap().status;
            if t > 20_000_000 && t < r.navigating_us {
                assert_eq!(status, "DEGRADED", "{row}");
            }
            if t >= r.navigating_us {
                assert_eq!(status, "NAV", "{row}");
                let (e, sigma) = horizontal(row, east_at(t as f64 * 1e-6));
                assert!(e < 3.0 * sigma, "{e} m against {sigma} m at {t} us");
            }
        }
        assert_eq!(s.filter.unwrap().status, FilterStatus::Nominal);
    }

    /// Aligned at rest heading east, then 10 s at 1 m/s^2 east and driving at 10 m/s; fixes
    /// of position only from 11 s; a gyro transient of 1e-3 rad/s (a thousand times the
    /// model's bias 1-sigma) from 10 to 70 s. The filter runs away from its fixes and refuses
    /// them; once it diverged it is set aside, and the re-alignment in motion on the fixes restarts it (NAV) with the
    /// sensors known as at the start, as the sequencer does to the last bit. Was: every fix
    /// refused to the end.
    #[test]
    fn a_filter_that_diverged_is_set_aside_and_the_aided_phase_realigns() {
        let q = heading_east();
        let east_at = |t_s: f64| match t_s {
            t if t <= 10.0 => 0.0,
            t if t <= 20.0 => 0.5 * (t - 10.0) * (t - 10.0),
            t => 50.0 + V_E * (t - 20.0),
        };
        let drive = east_increment(LAT_DEG.to_radians(), 0.0, V_E, DT);
        let inputs: Vec<ImuInput> = (1..=30_000u32)
            .map(|k| {
                let t_s = f64::from(k) * DT;
                let transient = if t_s > 10.0 && t_s <= 70.0 {
                    1e-3 * DT
                } else {
                    0.0
                };
                let (mut dtheta, dv) = if t_s <= 20.0 {
                    let a = if t_s > 10.0 { 1.0 } else { 0.0 };
                    at_rest(&q, Vector3::zeros(), Vector3::new(a * DT, 0.0, 0.0))
                } else {
                    (drive.delta_theta_ib_b.into(), drive.delta_v_ib_b.into())
                };
                dtheta[0] += transient;
                input(k, dtheta, dv)
            })
            .collect();
        let fixes: Vec<GnssFixInput<f64>> = (11..=300)
            .map(|k| fix_at(k * 1_000_000 + 300, east_at(k as f64 + 3e-4), None))
            .collect();
        let (rows, s) = navigator_and_sequencer::<f64>(&inputs, &fixes);
        let r = s.realignments;
        assert_eq!(
            (r.begun, r.diverged, r.completed, r.last_cause),
            (1, 1, 1, RealignCause::Diverged),
            "{r:?}"
        );
        assert!((70_000_000..=290_000_000).contains(&r.begun_us), "{r:?}");
        assert!(r.navigating_us < r.begun_us + 10_000_000, "{r:?}");
        let p = s.filter.unwrap().counters.position;
        let window = integrity::WINDOW as u32;
        assert!(p.rejected >= window && p.consecutive_rejected == 0, "{p}");
        for row in rows.iter().filter(|row| row.solution().t_us > r.begun_us) {
            let t = row.solution().t_us;
            let status = row.filter().unwrap().status;
            if t < r.navigating_us {
                assert_eq!(status, "DEGRADED", "{row}");
            } else {
                assert_eq!(status, "NAV", "{row}");
                let (e, sigma) = horizontal(row, east_at(t as f64 * 1e-6));
                assert!(e < 3.0 * sigma, "{e} m against {sigma} m at {t} us");
            }
        }
    }
}
