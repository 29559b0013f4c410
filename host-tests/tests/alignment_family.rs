//! Every alignment method on a small seeded family of still and swaying bases
//! (`host_tests::trajectory::family`; the benchmark `nav align-bench family --runs 24
//! --seconds 60,120` prints the same runs): [`MEMBERS`] members, windows [`WINDOWS_S`], both
//! lever-arm cases (given, not given).
//!
//! What an honest method must do, and the bounds (none copied from a run):
//!
//! 1. **Every `ALIGNED` attitude within [`ATTITUDE_SIGMAS`] of its own 1-sigma**, roll, pitch
//!    and heading (the acceptance rule). For Gaussian errors with the stated sigma a value beyond
//!    4 sigma has probability 6.3e-5; this test sees at most 24 x 2 x 3 = 144 values per method
//!    and lever case, 1152 in all, so an honest set of methods fails on this family with
//!    probability below 7 % (less: the windows and methods of one member are correlated). The
//!    family is seeded: the test is deterministic, not flaky.
//! 2. **Hand-over velocity and position within [`HANDOVER_SIGMAS`]** of their 1-sigma, per NED
//!    axis. "Every value within 3 sigma" cannot be asked of an honest filter here: at
//!    probability 0.27 % per value, 144 values per method, lever case and quantity would break
//!    it with probability 32 %. So: at most [`allowance`]`(n)` values of `n` beyond 3 sigma (the
//!    binomial count exceeds it with probability below 1e-3), and none beyond
//!    [`HANDOVER_HARD_SIGMAS`] (probability 5.7e-7 per value).
//! 3. **RMS of `error / sigma` per attitude axis within a chi-square interval around 1**, per
//!    method and lever case. With `k` independent standard normal errors, `k RMS^2` is
//!    chi-square with `k` degrees of freedom; [`rms_interval`] is its two-sided 99.9 % interval
//!    for `RMS` (Wilson–Hilferty's cube-root normal approximation). The results of one member's
//!    two windows are strongly correlated (biases, the same noise), so `k` is the number of
//!    members with a result, not the number of results: a wider, conservative interval. For 24
//!    members it is about 0.55–1.50; for 200 about 0.84–1.17, inside the 0.7–1.3 target
//!    for 200 members or more. Checked when `k >=` [`MIN_RMS_MEMBERS`].
//! 4. **Coverage**: `inertial`, `fine` and `sway` with the lever arm given align every swaying
//!    `fog` or `rlg` member over 120 s (a `mems-tactical` gyro's bias of 0.05 deg/s is 12 times
//!    the Earth rate: refusing its heading is right); `static` refuses every swaying member, in
//!    every window and lever case.
//! 5. **The sway fallback**: `sway` with its model off (yaw sway beyond it at the
//!    identification) or refuted (member #17: "base motion not modelled" at 60 s, "gyros
//!    disagree with the Earth rate" at 120 s) is `fine`'s result ([`check_sway_fallback`]).
//!
//! The test prints every offending case with the member's number (`nav align-bench family
//! --member K` prints all of its numbers). `sway` without the lever arm is refused by its
//! settings check (`SettingsError::SwayNeedsLeverArm`) and so counts no results.

use host_tests::align_bench::family::{
    FamilyOptions, LeverCase, MemberRun, Outcome, align, record, run_family,
};
use host_tests::sensor_model::Grade;
use host_tests::trajectory::family::FamilyMember;
use host_tests::trajectory::{Generator, Sampling, generate};
use host_tests::truth::distance_m;
use nav_core::alignment::{AlignMethod, AlignNote};
use nav_core::attitude::quat_from_f64;
use nav_core::{MechanizationConfig, NavState, Position, Strapdown, Vector3};

/// The family (the CLI's default).
const FAMILY_SEED: u64 = 1;
/// Members `0..MEMBERS`.
const MEMBERS: u64 = 24;
/// Alignment windows [s].
const WINDOWS_S: [f64; 2] = [60.0, 120.0];
/// Attitude bound [sigma].
const ATTITUDE_SIGMAS: f64 = 4.0;
/// Hand-over bound [sigma], with [`allowance`].
const HANDOVER_SIGMAS: f64 = 3.0;
/// Hand-over bound without allowance [sigma].
const HANDOVER_HARD_SIGMAS: f64 = 5.0;
/// Fewest members with a result for the RMS check.
const MIN_RMS_MEMBERS: usize = 5;
/// Standard normal quantile of the two-sided 99.9 % intervals.
const Z_999: f64 = 3.2905;

/// `P(|N(0,1)| > x)` by the complementary error function (Abramowitz & Stegun 7.1.26, error
/// below 1.5e-7).
fn two_sided_tail(x: f64) -> f64 {
    let z = x / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    poly * (-z * z).exp()
}

/// The most of `n` honest values beyond [`HANDOVER_SIGMAS`] allowed: the smallest `a` with
/// `P(Binomial(n, p) > a) < 1e-3`, `p = P(|z| > 3)`.
fn allowance(n: usize) -> usize {
    let p = two_sided_tail(HANDOVER_SIGMAS);
    let mut term = (1.0 - p).powi(n as i32); // P(X = 0)
    let mut cdf = term;
    let mut a = 0;
    while 1.0 - cdf >= 1e-3 && a < n {
        term *= (n - a) as f64 / (a + 1) as f64 * p / (1.0 - p);
        cdf += term;
        a += 1;
    }
    a
}

/// Two-sided 99.9 % interval of the RMS of `k` standard normal values (module docs, 3).
fn rms_interval(k: usize) -> (f64, f64) {
    let k = k as f64;
    let c = 2.0 / (9.0 * k);
    let quantile = |z: f64| k * (1.0 - c + z * c.sqrt()).powi(3);
    ((quantile(-Z_999) / k).sqrt(), (quantile(Z_999) / k).sqrt())
}

const AXES: [&str; 3] = ["roll", "pitch", "heading"];

/// `|z| > k`, or `z` not a number.
fn beyond(z: f64, k: f64) -> bool {
    z.is_nan() || z.abs() > k
}
const NED: [&str; 3] = ["N", "E", "D"];

fn label(run: &MemberRun) -> String {
    format!("member #{} ({})", run.member.index, run.member.category())
}

/// Checks 1-3 for `method` and `lever`, appending what fails.
fn check_consistency(
    runs: &[MemberRun],
    method: AlignMethod,
    lever: LeverCase,
    failures: &mut Vec<String>,
) {
    let name = format!("{} (lever arm {})", method.name(), lever.name());
    let mut z2 = Vector3::<f64>::zeros();
    let (mut results, mut members) = (0usize, 0usize);
    // Per quantity (velocity, position): the values beyond 3 sigma, and whether one is beyond
    // 5 sigma.
    let mut outside: [Vec<String>; 2] = [Vec::new(), Vec::new()];
    let mut hard = [false; 2];
    for run in runs {
        let mine = run
            .cases
            .iter()
            .filter(|c| c.method == method && c.lever == lever);
        let mut counted = false;
        for (c, a) in mine.filter_map(|c| match &c.outcome {
            Outcome::Aligned(a) => Some((c, a)),
            Outcome::Refused(_) => None,
        }) {
            results += 1;
            members += usize::from(!counted);
            counted = true;
            let z = a.attitude_z();
            z2 += z.map(|v| v * v);
            for i in 0..3 {
                if beyond(z[i], ATTITUDE_SIGMAS) {
                    failures.push(format!(
                        "{name}: {} {:.0} s: {} error {:+.4} deg is {:+.1} of its sigma {:.4} deg",
                        label(run),
                        c.window_s,
                        AXES[i],
                        a.error_rad[i].to_degrees(),
                        z[i],
                        a.sigma_rad[i].to_degrees()
                    ));
                }
            }
            let handover = [
                (
                    "velocity",
                    a.velocity_z(),
                    a.v_error_m_s,
                    a.v_sigma_m_s,
                    "m/s",
                ),
                ("position", a.position_z(), a.p_error_m, a.p_sigma_m, "m"),
            ];
            for (q, (quantity, zq, e, s, unit)) in handover.into_iter().enumerate() {
                for i in 0..3 {
                    if beyond(zq[i], HANDOVER_SIGMAS) {
                        hard[q] |= beyond(zq[i], HANDOVER_HARD_SIGMAS);
                        outside[q].push(format!(
                            "{name}: {} {:.0} s: hand-over {quantity} {} error {:+.3} {unit} is {:+.1} of its sigma {:.3} {unit}",
                            label(run),
                            c.window_s,
                            NED[i],
                            e[i],
                            zq[i],
                            s[i]
                        ));
                    }
                }
            }
        }
    }
    let values = 3 * results;
    let allowed = allowance(values);
    for (q, quantity) in ["velocity", "position"].into_iter().enumerate() {
        if outside[q].len() > allowed || hard[q] {
            failures.push(format!(
                "{name}: {} of {values} hand-over {quantity} values beyond {HANDOVER_SIGMAS} sigma (at most {allowed}, none beyond {HANDOVER_HARD_SIGMAS}):",
                outside[q].len()
            ));
            failures.append(&mut outside[q]);
        }
    }
    if members >= MIN_RMS_MEMBERS {
        let (lo, hi) = rms_interval(members);
        let rms = z2.map(|s| (s / results as f64).sqrt());
        for i in 0..3 {
            if rms[i].is_nan() || rms[i] < lo || rms[i] > hi {
                failures.push(format!(
                    "{name}: RMS {} error / sigma {:.2} over {results} results of {members} members is outside [{lo:.2}, {hi:.2}]",
                    AXES[i], rms[i]
                ));
            }
        }
    }
}

/// Check 4, appending what fails.
fn check_coverage(runs: &[MemberRun], failures: &mut Vec<String>) {
    for run in runs.iter().filter(|r| !r.member.still) {
        for c in &run.cases {
            let must_align = c.method != AlignMethod::Static
                && c.lever == LeverCase::Given
                && c.window_s == 120.0
                && run.member.grade != Grade::MemsTactical;
            match &c.outcome {
                Outcome::Refused(why) if must_align => failures.push(format!(
                    "{} with the lever arm given refused swaying {} over 120 s: {why}",
                    c.method.name(),
                    label(run)
                )),
                Outcome::Aligned(a) if c.method == AlignMethod::Static => {
                    failures.push(format!(
                        "static aligned swaying {} over {:.0} s (lever arm {}): heading error {:+.3} deg, sigma {:.3} deg",
                        label(run),
                        c.window_s,
                        c.lever.name(),
                        a.error_rad.z.to_degrees(),
                        a.sigma_rad.z.to_degrees()
                    ))
                }
                _ => {}
            }
        }
    }
}

/// Check 5: a `sway` result with its model off ([`AlignNote::SwayModelOff`]) or refuted
/// ([`AlignNote::SwayModelRefuted`]) is the general filter's, `fine`'s of the same member,
/// window and lever case; the family (yaw sway up to 1.5 deg; #17) must contain both, or this
/// check tests nothing.
fn check_sway_fallback(runs: &[MemberRun], failures: &mut Vec<String>) {
    let (mut off, mut refuted) = (0, 0);
    for run in runs {
        for c in run.cases.iter().filter(|c| c.method == AlignMethod::Sway) {
            let Outcome::Aligned(a) = &c.outcome else {
                continue;
            };
            match a.note {
                Some(AlignNote::SwayModelOff { .. }) => off += 1,
                Some(AlignNote::SwayModelRefuted { .. }) => refuted += 1,
                None => continue,
            }
            let fine = run.cases.iter().find(|f| {
                f.method == AlignMethod::Fine && f.lever == c.lever && f.window_s == c.window_s
            });
            let same = match fine.map(|f| &f.outcome) {
                Some(Outcome::Aligned(f)) => {
                    (a.error_rad - f.error_rad).amax() < 1e-9
                        && (a.sigma_rad - f.sigma_rad).amax() < 1e-9
                        && (a.p_error_m - f.p_error_m).amax() < 1e-6
                }
                _ => false,
            };
            if !same {
                failures.push(format!(
                    "sway with its model off or refuted on {} over {:.0} s is not fine's result",
                    label(run),
                    c.window_s
                ));
            }
        }
    }
    if off == 0 || refuted == 0 {
        failures.push(format!(
            "sway results with the model off {off}, refuted {refuted}: check 5 needs both"
        ));
    }
}

/// Members of the 200-member family that once broke the hand-over with the lever arm not
/// given, beyond the CI family's 24: #26 over 120 s (its centre sways 0.19 m at 10.0 s, its
/// roll at 10.3 s: the quarter-translation model read the sway as a vertical lever arm 1.6 m
/// off, its down position 4 of its sigma off) and #87 over 60 s (the still model won the bank
/// on the 87 % of its innovations it kept, its lever arm 50 of its sigma off, velocity 11).
#[test]
fn former_hand_over_failures_are_within_their_sigma() {
    for (index, window_s) in [(26, 120.0), (87, 60.0)] {
        let member = FamilyMember::draw(FAMILY_SEED, index);
        let rec = record(&member, &[window_s]).unwrap();
        let outcome = align(
            &member,
            &rec,
            AlignMethod::Fine,
            LeverCase::NotGiven,
            window_s,
        );
        let Outcome::Aligned(a) = outcome else {
            panic!("member #{index} over {window_s} s refused: {outcome:?}");
        };
        let (att, v, p) = (a.attitude_z(), a.velocity_z(), a.position_z());
        assert!(
            att.amax() <= ATTITUDE_SIGMAS
                && v.amax() <= HANDOVER_SIGMAS
                && p.amax() <= HANDOVER_SIGMAS,
            "member #{index} over {window_s} s: attitude z {att:.2?}, velocity z {v:.2?}, position z {p:.2?}"
        );
    }
}

/// The family's trajectories (mean tilt, rocking, surge, sway and heave of the centre, a
/// lever arm) are exact: an f64 mechanization fed their ideal increments follows their truth.
/// A wrong derivative of the centre's translation would leave errors of its own size (tenths of
/// a metre) within a period; the mechanization's own error on a rocking ship is below 0.5 m and
/// 1e-4 deg an hour (`tests/scenarios.rs`), so 120 s must stay within a centimetre and 1e-5 deg.
#[test]
fn the_mechanization_follows_a_swaying_member() {
    // The most violent of the first 40: translation amplitudes times lever arm.
    let violence = |m: &FamilyMember| {
        let t = &m.rocking.translation;
        (t.surge.amp_m + t.sway.amp_m + t.heave.amp_m) * m.lever_arm_b_m().norm()
    };
    let member = (0..40)
        .map(|i| FamilyMember::draw(FAMILY_SEED, i))
        .max_by(|a, b| violence(a).total_cmp(&violence(b)))
        .unwrap_or_else(|| unreachable!());
    let traj = &member.rocking;
    let start = Generator::new(traj).truth();
    let state = NavState {
        q_b_n: quat_from_f64(&start.q_b_ned),
        v_eb_n: start.v_eb_ned,
        position: Position::from_radians(start.lat, start.lon, start.h),
    };
    let mut nav = Strapdown::new(state, MechanizationConfig::default());
    let (mut worst_m, mut worst_deg): (f64, f64) = (0.0, 0.0);
    generate(traj, Sampling::new(400.0, 120.0), |k, _, inc, truth| {
        nav.step(inc).unwrap();
        if (k + 1) % 400 == 0 {
            let s = nav.state().to_ned_frame();
            let p = &s.position;
            worst_m = worst_m.max(distance_m(
                p.lat_f64(),
                p.lon_f64(),
                p.h_f64(),
                truth.lat,
                truth.lon,
                truth.h,
            ));
            worst_deg = worst_deg.max((truth.q_b_ned.inverse() * s.q_b_n).angle().to_degrees());
        }
    });
    println!(
        "member #{} ({}, lever arm {:.1} m, surge, sway, heave {:.2} {:.2} {:.2} m): worst {worst_m:.2e} m, {worst_deg:.2e} deg",
        member.index,
        member.category(),
        member.lever_arm_b_m().norm(),
        traj.translation.surge.amp_m,
        traj.translation.sway.amp_m,
        traj.translation.heave.amp_m
    );
    assert!(worst_m < 0.01, "{worst_m} m");
    assert!(worst_deg < 1e-5, "{worst_deg} deg");
}

/// `nav sim family` writes the member the benchmark aligns on, and says what it drew.
#[test]
fn nav_sim_writes_a_member_and_its_drawn_values() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m5");
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_nav"))
            .args(args)
            .output()
            .unwrap()
    };
    // Member 5 of family 1, `seconds` long, into `dir`: its scenario.txt.
    let sim = |seconds: &str, dir: &std::path::Path| {
        let o = run(&[
            "sim",
            "family",
            "--seed",
            "1",
            "--set",
            "member=5",
            "--seconds",
            seconds,
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read_to_string(dir.join("scenario.txt")).unwrap()
    };
    let text = sim("32", &out);
    let m = FamilyMember::draw(1, 5);
    let value = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(&format!("{key} = ")))
            .and_then(|v| v.split_whitespace().next())
            .unwrap_or_else(|| panic!("no {key} in\n{text}"))
            .to_owned()
    };
    assert_eq!(value("grade"), m.grade.name());
    assert_eq!(value("lat_deg"), m.rocking.lat_deg.to_string());
    assert_eq!(value("roll_period_s"), m.rocking.roll.period_s.to_string());
    assert_eq!(
        value("heave_amp_m"),
        m.rocking.translation.heave.amp_m.to_string()
    );
    assert_eq!(value("lever_x_m"), m.rocking.lever_arm_m[0].to_string());
    assert_eq!(value("survey_n_m"), m.survey_error_m[0].to_string());
    // The replay line tells the surveyed position, not the centre's.
    let given_lat = m.position().lat_f64().to_degrees();
    assert_ne!(given_lat, m.rocking.lat_deg);
    assert!(text.contains(&format!("--lat {given_lat} ")), "{text}");
    assert_eq!(value("samples"), "12800");
    let [x, y, z] = m.rocking.lever_arm_m;
    assert!(
        text.contains(&format!(
            "--imu-noise {} --bias-prior {} --lever-arm {x},{y},{z}",
            m.grade.name(),
            u8::from(m.biases)
        )),
        "{text}"
    );
    for f in ["imu.bin", "imu.csv", "truth.csv"] {
        assert!(out.join(f).exists(), "{f}");
    }
    // The replay line runs as written: it aligns over all but the last 10 s, then navigates.
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("# replay: nav "))
        .unwrap_or_else(|| panic!("no replay line in\n{text}"));
    assert!(line.contains("--align-seconds 22 "), "{line}");
    let solution = dir.path().join("solution.csv");
    let args: Vec<String> = line
        .split_whitespace()
        .map(|a| {
            if a == "solution.csv" {
                solution.to_str().unwrap().to_owned()
            } else {
                a.to_owned()
            }
        })
        .collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = run(&args);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("alignment (fine)"), "{stdout}");
    assert!(solution.exists());
    // Too short for an alignment and some navigation: the line says so instead.
    let text = sim("2", &dir.path().join("short"));
    assert!(
        text.contains("# replay: none: 2.0 s is shorter than fine's 20 s minimum"),
        "{text}"
    );
    // The member draws its own grade; unknown keys are refused.
    let o = run(&[
        "sim",
        "family",
        "--grade",
        "fog",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let o = run(&[
        "sim",
        "family",
        "--set",
        "lat_deg=3",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("member"));
}

#[test]
fn the_statistics_helpers_match_known_values() {
    // P(|z| > 3) = 0.0026998, P(|z| > 4) = 6.334e-5.
    assert!((two_sided_tail(3.0) / 2.6998e-3 - 1.0).abs() < 1e-3);
    assert!((two_sided_tail(4.0) / 6.334e-5 - 1.0).abs() < 2e-3);
    // 144 values at 0.27 %: mean 0.39; P(X > 3) = 8e-4 < 1e-3 <= P(X > 2).
    assert_eq!(allowance(144), 3);
    assert_eq!(allowance(0), 0);
    // Chi-square 99.95 % quantile for 24 dof is 53.48 (tables): RMS bound sqrt(53.48/24).
    let (lo, hi) = rms_interval(24);
    assert!((hi - (53.48f64 / 24.0).sqrt()).abs() < 0.01, "{hi}");
    // 0.05 % quantile for 24 dof: 7.45.
    assert!((lo - (7.45f64 / 24.0).sqrt()).abs() < 0.01, "{lo}");
}

#[test]
fn every_method_is_honest_on_a_small_family() {
    let opts = FamilyOptions {
        windows_s: WINDOWS_S.to_vec(),
        ..FamilyOptions::new(FAMILY_SEED, MEMBERS)
    };
    let runs = run_family(&opts).unwrap();
    let mut failures = Vec::new();
    for method in AlignMethod::ALL {
        for lever in LeverCase::ALL {
            check_consistency(&runs, method, lever, &mut failures);
        }
    }
    check_coverage(&runs, &mut failures);
    check_sway_fallback(&runs, &mut failures);
    for f in &failures {
        println!("{f}");
    }
    assert!(
        failures.is_empty(),
        "{} failed checks (printed above; `nav align-bench family --member K` shows a member)",
        failures.len()
    );
}
