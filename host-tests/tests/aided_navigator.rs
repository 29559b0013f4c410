//! The navigator's GNSS-aided phase on simulated drives: aligned statically, then aided by
//! simulated GNSS fixes (`nav replay --gnss FILE` without a given start, the firmware's
//! `--gnss` run). Every logged solution is compared with the simulator's truth against the
//! filter's own 1-sigma in its row.

use host_tests::gnss::{self, GnssFix};
use host_tests::gnss_sim::{self, GnssSimOptions};
use host_tests::pipeline::{Report, sensor_noise};
use host_tests::recording_io;
use host_tests::replay::{ReplayOptions, replay_aided};
use host_tests::sensor_model::Grade;
use host_tests::simulate::{SimOptions, Simulated, simulate};
use host_tests::trajectory::scenarios::Scenario;
use host_tests::truth::Truth;
use nav_core::navigator::AidingConfig;
use nav_core::{Position, Scalar};
use std::path::Path;

const SITE: [f64; 3] = [45.0, 7.5, 250.0];

/// `seconds` of `nav sim land-vehicle` at the demo's site (still for 20 s, then driving), FOG
/// grade, seed 7.
fn drive(seconds: f64) -> Simulated {
    let mut scenario = Scenario::by_name("land-vehicle").unwrap();
    for (key, v) in ["lat_deg", "lon_deg", "h_m"].into_iter().zip(SITE) {
        scenario.set(key, v).unwrap();
    }
    let mut opts = SimOptions::new(scenario, Grade::Fog);
    opts.seconds = Some(seconds);
    opts.seed = 7;
    simulate(&opts, |_, _| {}).unwrap()
}

/// One row of an aided log: the solution's 10 values, the 9 1-sigmas and the status.
struct Row {
    values: [f64; 19],
    status: String,
}

fn rows(log: &str) -> Vec<Row> {
    let mut lines = log.lines();
    assert_eq!(lines.next(), Some(nav_core::output::AIDED_CSV_HEADER));
    lines
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let fields: Vec<&str> = l.split(',').collect();
            assert_eq!(fields.len(), 20, "{l}");
            let mut values = [0.0; 19];
            for (v, f) in values.iter_mut().zip(&fields) {
                *v = f.parse().unwrap();
            }
            Row {
                values,
                status: fields[19].to_owned(),
            }
        })
        .collect()
}

/// Errors of a row over its 1-sigma: position north, east, down; velocity; roll, pitch, yaw.
fn z_scores(row: &Row, truth: &Truth) -> [f64; 9] {
    let v = &row.values;
    let solution = Position::from_degrees(v[1], v[2], v[3]);
    let true_position = Position::from_radians(truth.lat, truth.lon, truth.h);
    let dp = true_position.ned_to(&solution);
    let (roll, pitch, yaw) = nav_core::attitude::euler(&truth.q_b_ned);
    let wrap = |d: f64| (d + 540.0).rem_euclid(360.0) - 180.0;
    let err = [
        dp[0],
        dp[1],
        dp[2],
        v[4] - truth.v_eb_ned.x,
        v[5] - truth.v_eb_ned.y,
        v[6] - truth.v_eb_ned.z,
        wrap(v[7] - roll.to_degrees()),
        wrap(v[8] - pitch.to_degrees()),
        wrap(v[9] - yaw.to_degrees()),
    ];
    let mut z = [0.0; 9];
    for k in 0..9 {
        z[k] = err[k] / v[10 + k];
    }
    z
}

/// The truth row at `t_s` (truth every 20 ms; rows fall on it).
fn truth_at(truth: &[Truth], t_s: f64) -> &Truth {
    let i = ((t_s - truth[0].t_s) * 50.0).round() as usize;
    let t = &truth[i.min(truth.len() - 1)];
    assert!((t.t_s - t_s).abs() < 1e-6, "no truth at {t_s}: {}", t.t_s);
    t
}

/// Runs the recording and fixes aided in precision `T`: the log's text and the report.
fn aided_log<T: Scalar>(dir: &Path, lever_arm_b_m: [f64; 3], name: &str) -> (String, Report) {
    let mut options = ReplayOptions::new(SITE[0], SITE[1], SITE[2], 15.0);
    let spec = Grade::Fog.noise_spec();
    options.run.noise = sensor_noise(&spec);
    options.run.figures = spec.figures;
    options.run.aiding = Some(AidingConfig {
        antenna_lever_arm_b_m: lever_arm_b_m,
        ..AidingConfig::default()
    });
    let out = dir.join(name);
    let r = replay_aided::<T>(
        &dir.join("imu.bin"),
        &dir.join("gnss.csv"),
        None,
        0.0,
        &out,
        &options,
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    println!(
        "{}",
        host_tests::replay::summary(&dir.join("imu.bin"), &out, name, &r.file)
    );
    (std::fs::read_to_string(out).unwrap(), r.file.report)
}

fn write_inputs(dir: &Path, sim: &Simulated, gnss: &GnssSimOptions) -> Vec<GnssFix> {
    recording_io::write(&dir.join("imu.bin"), &sim.recording).unwrap();
    let fixes = gnss_sim::simulate(&sim.truth, gnss).unwrap().fixes;
    gnss::write_gnss_csv(&dir.join("gnss.csv"), &fixes).unwrap();
    fixes
}

/// The worst `|error / sigma|` per value of a log's rows and the count of values beyond 3
/// sigma, every row's status checked.
fn consistency(log: &str, truth: &[Truth]) -> ([f64; 9], usize, usize) {
    consistency_but(log, truth, |_| false)
}

/// [`consistency`], the rows at times [s] for which `degraded` holds DEGRADED.
fn consistency_but(
    log: &str,
    truth: &[Truth],
    degraded: impl Fn(f64) -> bool,
) -> ([f64; 9], usize, usize) {
    let rows = rows(log);
    let mut worst = [0.0_f64; 9];
    let mut beyond3 = 0;
    for r in &rows {
        let status = if degraded(r.values[0]) {
            "DEGRADED"
        } else {
            "NAV"
        };
        assert_eq!(r.status, status, "at {} s", r.values[0]);
        let z = z_scores(r, truth_at(truth, r.values[0]));
        for k in 0..9 {
            worst[k] = worst[k].max(z[k].abs());
            beyond3 += usize::from(z[k].abs() > 3.0);
        }
    }
    (worst, beyond3, rows.len())
}

fn nav(dir: &Path, args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_nav"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run nav")
}

/// `nav replay` of `imu.bin` with the GNSS file `gnss`, aligned first (FOG noise, 15 s at
/// 45 deg N, 7.5 deg E, 250 m), with `rest` added.
fn replay_aligned(dir: &Path, gnss: &str, rest: &[&str]) -> std::process::Output {
    let mut args = vec![
        "replay",
        "--imu",
        "imu.bin",
        "--gnss",
        gnss,
        "--lat",
        "45",
        "--lon",
        "7.5",
        "--h",
        "250",
        "--align-seconds",
        "15",
        "--imu-noise",
        "fog",
    ];
    args.extend_from_slice(rest);
    nav(dir, &args)
}

/// 120 s of the demo's drive (15 s of static alignment, 5 s still, then starts, turns, stops)
/// with 1 Hz fixes of an antenna 1.4 m from the IMU: every row's position, velocity and
/// attitude within the filter's own 1-sigma (none beyond 5, at most 1 % of the values beyond 3:
/// an honest filter has 0.27 %), in f64 and in f32 (the same to a tenth of a sigma), far
/// better than free inertial; and `nav replay --gnss` on the CSV and on the binary fix file
/// writes the same log.
#[test]
fn an_aided_drive_stays_within_the_filters_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = drive(120.0);
    let lever = [0.8, -0.3, -1.1];
    let gnss = GnssSimOptions {
        rate_hz: 1.0,
        sigma_ned_m: [0.5, 0.5, 1.0],
        sigma_v_ned_m_s: Some([0.05, 0.05, 0.1]),
        lever_arm_b_m: lever,
        seed: 3,
        ..GnssSimOptions::default()
    };
    let fixes = write_inputs(d, &sim, &gnss);
    let (f64_log, f64_report) = aided_log::<f64>(d, lever, "f64.csv");
    let (f32_log, f32_report) = aided_log::<f32>(d, lever, "f32.csv");
    for (precision, log) in [("f64", &f64_log), ("f32", &f32_log)] {
        let (worst, beyond3, n) = consistency(log, &sim.truth);
        println!(
            "{precision}: {n} rows, worst |error / sigma| {worst:.2?}, values beyond 3 sigma: {beyond3}"
        );
        // The aligned row at 15 s, a row every 0.1 s, the last at 120 s.
        assert_eq!(n, 1 + 1050);
        assert!(worst.iter().all(|z| *z < 5.0), "{precision}: {worst:?}");
        assert!(
            beyond3 * 100 <= 9 * n,
            "{precision}: {beyond3} of {}",
            9 * n
        );
    }
    for r in [&f64_report, &f32_report] {
        let a = r.aided.unwrap();
        // Fixes at 0..15 s came during the alignment; the 105 after it were all used.
        assert_eq!(
            (a.fixes_unused, a.fixes.received, a.fixes.late),
            (16, 105, 0)
        );
        assert_eq!(a.counters.position.accepted, 105, "{:?}", a.counters);
        assert!(a.counters.velocity.accepted >= 100, "{:?}", a.counters);
        assert!(a.counters.zero_velocity.accepted > 0, "{:?}", a.counters);
        assert_eq!(a.covariance_faults, 0);
    }
    // f32 against f64: the same errors to a tenth of their sigma.
    for (a, b) in rows(&f64_log).iter().zip(rows(&f32_log).iter()) {
        let truth = truth_at(&sim.truth, a.values[0]);
        let (za, zb) = (z_scores(a, truth), z_scores(b, truth));
        for k in 0..9 {
            assert!(
                (za[k] - zb[k]).abs() < 0.1,
                "at {} s: {za:?} {zb:?}",
                a.values[0]
            );
        }
    }
    // Free inertial drifts metres in the 105 s; aided, the last row is within decimetres.
    let mut options = ReplayOptions::new(SITE[0], SITE[1], SITE[2], 15.0);
    options.run.noise = sensor_noise(&Grade::Fog.noise_spec());
    let mut free = Vec::new();
    host_tests::replay::replay_file::<f64, _>(&d.join("imu.bin"), &options, &mut free).unwrap();
    let free = String::from_utf8(free).unwrap();
    let last = |log: &str| -> f64 {
        let l = log.lines().rev().find(|l| !l.starts_with('#')).unwrap();
        let v: Vec<f64> = l.split(',').take(4).map(|x| x.parse().unwrap()).collect();
        let t = truth_at(&sim.truth, v[0]);
        let d = Position::from_radians(t.lat, t.lon, t.h)
            .ned_to(&Position::from_degrees(v[1], v[2], v[3]));
        d[0].hypot(d[1])
    };
    let (aided_m, free_m) = (last(&f64_log), last(&free));
    println!("horizontal error at 120 s: aided {aided_m:.3} m, free inertial {free_m:.3} m");
    assert!(aided_m < 1.0 && free_m > 5.0, "{aided_m} {free_m}");

    // The command line, on the CSV and on the binary fix file: the library's log.
    let o = nav(
        d,
        &["convert", "--gnss", "--in", "gnss.csv", "--out", "gnss.bin"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains(&format!("({} GNSS fixes)", fixes.len())),
        "{said}"
    );
    for (file, out) in [("gnss.csv", "cli.csv"), ("gnss.bin", "cli-bin.csv")] {
        let o = replay_aligned(
            d,
            file,
            &[
                "--gnss-lever-arm",
                "0.8,-0.3,-1.1",
                "--out",
                out,
                "--precision",
                "f32",
            ],
        );
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{}{stdout}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(stdout.contains("GNSS position: 105 accepted"), "{stdout}");
        assert_eq!(
            std::fs::read_to_string(d.join(out)).unwrap(),
            f32_log,
            "{file}"
        );
    }
}

/// Bad fixes in an aided run: a NaN position is counted invalid, a 50 m jump and a 20 m
/// spike are refused by the gate, a corrupt or missing GNSS file is an error naming it; the
/// solution stays within its sigma and no log is left by a failed run.
#[test]
fn bad_fixes_are_counted_and_bad_files_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = drive(80.0);
    let mut fixes = write_inputs(d, &sim, &GnssSimOptions::default());
    fixes[40].lat_rad = f64::NAN;
    fixes[50].lat_rad += 50.0 / 6.37e6;
    fixes[60].lon_rad -= 20.0 / 4.5e6;
    gnss::write_gnss_csv(&d.join("gnss.csv"), &fixes).unwrap();
    let (log, report) = aided_log::<f32>(d, [0.0; 3], "bad.csv");
    let a = report.aided.unwrap();
    assert_eq!(a.counters.position.invalid, 1, "{:?}", a.counters);
    assert_eq!(a.counters.position.rejected, 2, "{:?}", a.counters);
    assert_eq!(a.counters.position.accepted, 65 - 3, "{:?}", a.counters);
    // The jump and the spike disagree grossly with the solution: DEGRADED until the next fix
    // is taken (`nav_core::ins_filter::integrity::SUSPECT_NIS_FACTOR`), NAV elsewhere.
    // (A row's time is its sample's, to the microsecond.)
    let after = |k: usize, t: f64| (fixes[k].t_s..fixes[k + 1].t_s).contains(&(t + 1e-6));
    let degraded = |t| after(50, t) || after(60, t);
    let (worst, _, _) = consistency_but(&log, &sim.truth, degraded);
    assert!(worst.iter().all(|z| *z < 5.0), "{worst:?}");

    // A corrupt binary fix file and a missing one: errors naming the file, no log.
    host_tests::gnss_file::convert(&d.join("gnss.csv"), &d.join("gnss.bin"), None).unwrap();
    let mut bytes = std::fs::read(d.join("gnss.bin")).unwrap();
    bytes[32 + 112 * 7 + 3] ^= 0x01;
    std::fs::write(d.join("corrupt.bin"), &bytes).unwrap();
    for (file, expect) in [
        ("corrupt.bin", "(fix 7): record CRC mismatch"),
        ("missing.csv", "cannot open the GNSS file"),
    ] {
        let o = replay_aligned(d, file, &["--out", "x.csv"]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains(expect) && stderr.contains(file), "{stderr}");
        assert!(!d.join("x.csv").exists());
    }
}

/// The FOG drive replayed with `--imu-noise fog` through the navigator's aided phase (as the
/// firmware runs it) assumes the grade's own scale factors, misalignment and g-sensitivity
/// (the grade has none: scale factors at a 1 ppm floor), not the defaults standing for what a
/// MEMS data sheet lacks (0.1 deg of cross-axis coupling, 0.01 deg/s/g, 1000 ppm): the
/// heading's 1-sigma stays the size of its error (RMS of error / 1-sigma from 0.5 to 2 after
/// the first minute) and every value within the filter's sigma. Was: the defaults' g-sensitivity
/// let the modelled heading drift at 36 deg/h, its 1-sigma several times the error (over a
/// 1500 s FOG flight, yaw RMS error / 1-sigma 0.42, the 1-sigma grown to 1.4 deg against a
/// 0.2 deg error).
#[test]
fn a_grades_own_figures_keep_the_heading_sigma_the_size_of_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = drive(600.0);
    write_inputs(d, &sim, &GnssSimOptions::default());
    let o = replay_aligned(d, "gnss.csv", &["--out", "log.csv"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let log = std::fs::read_to_string(d.join("log.csv")).unwrap();
    let (worst, beyond3, n) = consistency(&log, &sim.truth);
    assert!(
        beyond3 * 100 <= n * 9,
        "{beyond3} of {} values beyond 3 sigma",
        n * 9
    );
    assert!(worst.iter().all(|z| *z < 5.0), "{worst:?}");
    let z: Vec<f64> = rows(&log)
        .iter()
        .filter(|r| r.values[0] > 75.0)
        .map(|r| z_scores(r, truth_at(&sim.truth, r.values[0]))[8])
        .collect();
    let rms = (z.iter().map(|x| x * x).sum::<f64>() / z.len() as f64).sqrt();
    println!("yaw RMS error / 1-sigma {rms:.2}, worst |error / sigma| {worst:.2?}");
    assert!(
        z.len() > 1000 && (0.5..=2.0).contains(&rms),
        "yaw RMS error / 1-sigma {rms:.2} over {} rows",
        z.len()
    );
}

/// A code receiver's time-correlated error declared on the navigator's aided phase (after the
/// alignment, as the firmware runs it): the options' words through nav-core's
/// `RunConfig::set` (the firmware's argument parser and `nav config`'s text) give the
/// configuration `nav replay --gnss-correlated` runs with, the same log to the byte; the
/// filter carries the error (its position 1-sigma wider than with the fixes taken as white)
/// and every row stays within it.
#[test]
fn a_declared_gnss_correlated_error_runs_after_the_alignment() {
    use host_tests::gnss_sim::CorrelatedError;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = drive(60.0);
    let lever = [0.8, -0.3, -1.1];
    let gnss = GnssSimOptions {
        rate_hz: 1.0,
        sigma_ned_m: [0.5, 0.5, 1.0],
        sigma_v_ned_m_s: Some([0.05, 0.05, 0.1]),
        lever_arm_b_m: lever,
        correlated: Some(CorrelatedError {
            sigma_ned_m: [1.5, 1.5, 3.0],
            time_s: 60.0,
        }),
        seed: 3,
        ..GnssSimOptions::default()
    };
    write_inputs(d, &sim, &gnss);
    // The firmware's words (its `Args::parse` hands every run option to `RunConfig::set`).
    let mut options = ReplayOptions::new(SITE[0], SITE[1], SITE[2], 15.0);
    let spec = Grade::Fog.noise_spec();
    options.run.noise = sensor_noise(&spec);
    options.run.figures = spec.figures;
    for (name, value) in [
        ("gnss-lever-arm", "0.8,-0.3,-1.1"),
        ("gnss-correlated-time", "60"),
        ("gnss-correlated", "1.5,1.5,3"),
    ] {
        options.run.set(name, value).unwrap();
    }
    assert_eq!(
        options.run.aiding,
        Some(AidingConfig {
            antenna_lever_arm_b_m: lever,
            gnss_correlated_sigma_ned_m: Some([1.5, 1.5, 3.0]),
            gnss_correlated_time_s: 60.0,
            ..AidingConfig::default()
        })
    );
    let run = |options: &ReplayOptions, name: &str| {
        let out = d.join(name);
        replay_aided::<f32>(
            &d.join("imu.bin"),
            &d.join("gnss.csv"),
            None,
            0.0,
            &out,
            options,
        )
        .unwrap_or_else(|e| panic!("{e:#}"));
        std::fs::read_to_string(out).unwrap()
    };
    let declared = run(&options, "declared.csv");
    let o = replay_aligned(
        d,
        "gnss.csv",
        &[
            "--gnss-lever-arm",
            "0.8,-0.3,-1.1",
            "--gnss-correlated",
            "1.5,1.5,3",
            "--gnss-correlated-time",
            "60",
            "--out",
            "cli.csv",
            "--precision",
            "f32",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(d.join("cli.csv")).unwrap(),
        declared
    );
    // The fixes taken as white: a narrower position 1-sigma in the last row.
    options.run.aiding = Some(AidingConfig {
        gnss_correlated_sigma_ned_m: None,
        ..options.run.aiding.unwrap()
    });
    let white = run(&options, "white.csv");
    let last_sigma_n = |log: &str| rows(log).last().unwrap().values[10];
    let (with, without) = (last_sigma_n(&declared), last_sigma_n(&white));
    println!("north 1-sigma at 60 s: declared {with:.3} m, white {without:.3} m");
    assert!(with > 1.5 * without, "{with} {without}");
    let (worst, beyond3, n) = consistency(&declared, &sim.truth);
    println!("declared: {n} rows, worst |error / sigma| {worst:.2?}, beyond 3 sigma: {beyond3}");
    assert!(worst.iter().all(|z| *z < 5.0), "{worst:?}");
}
