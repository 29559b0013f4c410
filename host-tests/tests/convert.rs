//! Conversions: every format replays through the same binary records, so CSV, CSV converted to
//! binary, and the generated binary give the same log.

mod common;

use common::replay;
use host_tests::generate::Stationary;
use host_tests::recording_io::{self, Format};
use host_tests::replay::ReplayOptions;
use std::process::Command;

fn options(s: &Stationary) -> ReplayOptions {
    let mut o = ReplayOptions::new(s.lat_deg, s.lon_deg, s.h_m, 10.0);
    o.run.log_every = 25;
    o
}

#[test]
fn csv_to_binary_replays_identically() {
    let dir = tempfile::tempdir().unwrap();
    let s = Stationary {
        seconds: 15.0,
        rate_hz: 200.0,
        ..Stationary::default()
    };
    let generated = s.recording().unwrap();
    let (bin, csv, converted) = (
        dir.path().join("gen.bin"),
        dir.path().join("gen.csv"),
        dir.path().join("converted.bin"),
    );
    recording_io::write(&bin, &generated).unwrap();
    recording_io::write(&csv, &generated).unwrap();
    assert_eq!(recording_io::detect(&bin).unwrap(), Format::Binary);
    assert_eq!(recording_io::detect(&csv).unwrap(), Format::Csv);

    // CSV -> binary with the CLI.
    let out = Command::new(env!("CARGO_BIN_EXE_nav"))
        .args([
            "convert",
            "--in",
            csv.to_str().unwrap(),
            "--out",
            converted.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // The CSV keeps every bit: times as shortest round-trip decimals, f32 values likewise; the
    // rate (1 / median interval) and t0 (first time - period) come back exactly.
    let back = recording_io::read(&converted).unwrap();
    assert_eq!(back, generated);

    for (name, log) in [
        ("csv", replay::<f32>(&csv, &options(&s))),
        ("converted", replay::<f32>(&converted, &options(&s))),
    ] {
        let (reference, reference_log) = replay::<f32>(&bin, &options(&s));
        assert_eq!(log.0.report, reference.report, "{name}");
        assert_eq!(log.1, reference_log, "{name}");
    }
    let (fr, _) = replay::<f32>(&csv, &options(&s));
    assert_eq!(fr.format, Format::Csv);
    assert_eq!(fr.rate_hz, 200.0);
}

#[test]
fn binary_to_csv_and_back() {
    let dir = tempfile::tempdir().unwrap();
    // 300 Hz: the nanosecond intervals alternate between 3333333 and 3333334.
    let s = Stationary {
        seconds: 2.0,
        rate_hz: 300.0,
        ..Stationary::default()
    };
    let generated = s.recording().unwrap();
    let (bin, csv) = (dir.path().join("a.bin"), dir.path().join("a.csv"));
    recording_io::write(&bin, &generated).unwrap();
    let csv_from_bin = recording_io::read(&bin).unwrap();
    assert_eq!(csv_from_bin, generated);
    recording_io::write(&csv, &csv_from_bin).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with(
        "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps,temp_c\n"
    ));
    let back = recording_io::read(&csv).unwrap();
    assert_eq!(back.records, generated.records);
    // The median interval is 3333333 ns here, not 1e9 / 300.
    assert!((back.rate_hz - 300.0).abs() < 1e-4, "{}", back.rate_hz);
}

/// `recording_io::convert` (`nav convert`, streaming) writes the bytes the in-memory path wrote
/// (`recording_io::read`, then `recording_io::write`) for every input format, to binary and to
/// CSV; a recording converts CSV -> binary -> CSV to the bytes of the CSV and binary writers.
#[test]
fn convert_writes_the_bytes_of_the_in_memory_path() {
    use hal_adapters::recording::Kind;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = Stationary {
        seconds: 12.0,
        ..Stationary::default()
    };
    let generated = s.recording().unwrap();
    let mut without_temperature = generated.clone();
    for r in &mut without_temperature.records {
        r.temperature_c = f32::NAN;
    }
    let mut rates = generated.clone();
    rates.kind = Kind::Rates;
    let mut inputs = Vec::new();
    for (name, rec) in [
        ("gen.bin", &generated),
        ("gen.csv", &generated),
        ("no-temp.csv", &without_temperature),
        ("rates.bin", &rates),
    ] {
        recording_io::write(&d.join(name), rec).unwrap();
        inputs.push(d.join(name));
    }
    let kf_gins: String = (1..=3000)
        .map(|k| {
            let t = 456_300.0 + f64::from(k) * 0.005;
            format!("{t:.9} 1.1e-7 -2.0e-8 3.3e-7 1.2e-4 -3.0e-5 -0.049042\n")
        })
        .collect();
    std::fs::write(d.join("imu.txt"), kf_gins).unwrap();
    inputs.push(d.join("imu.txt"));
    let mut psins = "% test\n0 0 -90.6 0 0 0\n34.246048 108.909664 380.0 0 10 9.780327\n\
                     0.1 0.1 0.1 125 125 125\n"
        .to_owned();
    for k in 0..2000 {
        psins.push_str(&format!("{} 9 3 0 {} 80\n", k % 11, k % 3));
    }
    std::fs::write(d.join("imu.imu"), psins).unwrap();
    inputs.push(d.join("imu.imu"));

    for input in &inputs {
        let recording = recording_io::read(input).unwrap();
        for ext in ["bin", "csv"] {
            let (expected, converted) = (
                d.join(format!("expected.{ext}")),
                d.join(format!("converted.{ext}")),
            );
            let name = format!("{} to {ext}", input.display());
            for p in [&expected, &converted] {
                let _ = std::fs::remove_file(p);
            }
            match recording_io::write(&expected, &recording) {
                Ok(()) => {
                    let c = recording_io::convert(input, &converted).unwrap();
                    assert_eq!(c.header, recording.header().unwrap(), "{name}");
                    assert_eq!(
                        std::fs::read(&converted).unwrap(),
                        std::fs::read(&expected).unwrap(),
                        "{name}"
                    );
                }
                Err(e) => {
                    // Rates to CSV: the same refusal, and nothing written.
                    assert_eq!(recording.kind, Kind::Rates, "{name}: {e:#}");
                    let msg = format!(
                        "{:#}",
                        recording_io::convert(input, &converted).unwrap_err()
                    );
                    assert!(
                        msg.contains("the CSV format holds increments, this recording holds rates"),
                        "{msg}"
                    );
                    assert!(!converted.exists(), "{name}");
                }
            }
        }
    }

    // CSV -> binary -> CSV: the binary writer's bytes, then the CSV writer's again.
    let (bin, csv) = (d.join("round.bin"), d.join("round.csv"));
    recording_io::convert(&d.join("gen.csv"), &bin).unwrap();
    assert_eq!(
        std::fs::read(&bin).unwrap(),
        generated.to_bytes().unwrap(),
        "CSV to binary"
    );
    recording_io::convert(&bin, &csv).unwrap();
    assert_eq!(
        std::fs::read(&csv).unwrap(),
        std::fs::read(d.join("gen.csv")).unwrap(),
        "binary back to CSV"
    );
}

/// A failed conversion leaves an existing output as it was and no temporary file; an output
/// that is the input is refused.
#[test]
fn a_failed_convert_leaves_the_output_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps\n\
                0.0025,0,0,0,0,0,-0.0245\n0.005,0,0,0,0,x,-0.0245\n0.0075,0,0,0,0,0,-0.0245\n";
    std::fs::write(d.join("bad.csv"), text).unwrap();
    std::fs::write(d.join("out.bin"), "older output\n").unwrap();
    let e = recording_io::convert(&d.join("bad.csv"), &d.join("out.bin")).unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("bad.csv: line 3: column dv_y_mps: expected a number, found 'x'"),
        "{msg}"
    );
    assert_eq!(
        std::fs::read_to_string(d.join("out.bin")).unwrap(),
        "older output\n"
    );
    let mut names: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["bad.csv", "out.bin"]);
    let e = recording_io::convert(&d.join("out.bin"), &d.join(".").join("out.bin")).unwrap_err();
    assert!(e.to_string().contains("is the input"), "{e}");
}

/// Records a replay will flag (time repeated or going back, a NaN) are converted as they are,
/// counted and warned about; a clean recording gives no warning.
#[test]
fn convert_warns_about_records_a_replay_flags() {
    let dir = tempfile::tempdir().unwrap();
    let generated = Stationary {
        seconds: 2.0,
        ..Stationary::default()
    }
    .recording()
    .unwrap();
    let clean = dir.path().join("clean.bin");
    recording_io::write(&clean, &generated).unwrap();
    let c = recording_io::convert(&clean, &dir.path().join("clean.csv")).unwrap();
    assert_eq!(c.warning(), None);
    let mut bad = generated.clone();
    bad.records[5].t_ns = bad.records[4].t_ns;
    bad.records[9].t_ns = bad.records[7].t_ns;
    bad.records[12].gyro[1] = f32::NAN;
    let input = dir.path().join("bad.bin");
    recording_io::write(&input, &bad).unwrap();
    let c = recording_io::convert(&input, &dir.path().join("bad.csv")).unwrap();
    assert_eq!((c.time_not_increasing, c.not_finite), (2, 1));
    assert!(c.warning().unwrap().contains("WARNING: 2 records"));
}

/// A record with an increment beyond any IMU's full scale (1e30 rad, or a velocity increment
/// of 2000 m/s^2 beyond the limit) is converted as it is, counted and named in the warning;
/// increments just inside the limits are not.
#[test]
fn convert_warns_about_increments_beyond_full_scale() {
    let dir = tempfile::tempdir().unwrap();
    let generated = Stationary {
        seconds: 2.0,
        ..Stationary::default()
    }
    .recording()
    .unwrap();
    let limits = nav_core::increment::InputLimits::<f64>::default();
    let dt_s = 1.0 / generated.rate_hz;
    let mut bad = generated.clone();
    bad.records[3].gyro[0] = 1e30;
    bad.records[6].accel[2] = (-1.01 * limits.max_specific_force * dt_s) as f32;
    bad.records[8].gyro[2] = (0.99 * limits.max_rate * dt_s) as f32;
    let input = dir.path().join("bad.bin");
    recording_io::write(&input, &bad).unwrap();
    let c = recording_io::convert(&input, &dir.path().join("bad.csv")).unwrap();
    assert_eq!(
        (c.time_not_increasing, c.not_finite, c.out_of_range),
        (0, 0, 2)
    );
    let w = c.warning().unwrap();
    assert!(w.contains("2 with a rate beyond 2000 deg/s"), "{w}");
    assert!(w.contains("490 m/s^2"), "{w}");
}

/// A clock that steps back 1 s and stays behind: a replay skips every record until the time
/// passes the last navigated one again (400 here); `nav convert` counted only the first ("1
/// records with a time not after the previous one's"). Both count by nav-core's rule now.
#[test]
fn convert_counts_the_records_a_replay_skips_after_a_step_back() {
    let dir = tempfile::tempdir().unwrap();
    let s = Stationary {
        seconds: 15.0,
        ..Stationary::default()
    };
    let mut stepped = s.recording().unwrap();
    let at = (12.0 * s.rate_hz) as usize;
    for r in &mut stepped.records[at..] {
        r.t_ns -= 1_000_000_000;
    }
    let input = dir.path().join("stepped.bin");
    recording_io::write(&input, &stepped).unwrap();
    let c = recording_io::convert(&input, &dir.path().join("stepped.csv")).unwrap();
    let (replayed, _) = replay::<f32>(&input, &options(&s));
    // The first after the step has a negative interval (flagged so), the others are out of
    // time order: both skipped.
    let flagged = replayed.report.flagged_by;
    let skipped = flagged.out_of_order + flagged.bad_interval;
    assert_eq!(skipped, 400);
    assert_eq!(c.time_not_increasing, u64::from(skipped));
    assert!(c.warning().unwrap().contains("WARNING: 400 records"));
}

/// Recordings a replay refuses were converted into valid-looking files without a word: a
/// header rate the timestamps contradict (200 Hz on 100 Hz samples) and a CSV whose time
/// column is in milliseconds (0.1 Hz). Refused now by the replay's own checks.
#[test]
fn convert_refuses_what_a_replay_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let s = Stationary {
        seconds: 3.0,
        rate_hz: 100.0,
        ..Stationary::default()
    };
    let r = s.recording().unwrap();
    let wrong = dir.path().join("rate_wrong.bin");
    recording_io::write_binary(&wrong, r.kind, 200.0, r.t0_ns, &r.records).unwrap();
    let e = format!(
        "{:#}",
        recording_io::convert(&wrong, &dir.path().join("a.bin")).unwrap_err()
    );
    assert!(
        e.contains("the header's rate 200 Hz contradicts the timestamps"),
        "{e}"
    );
    let csv = dir.path().join("time_ms.csv");
    recording_io::write(&csv, &r).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut ms = String::new();
    for (i, line) in text.lines().enumerate() {
        match line.split_once(',') {
            Some((t, rest)) if i > 0 => {
                let t: f64 = t.parse().unwrap();
                ms += &format!("{},{rest}\n", t * 1000.0);
            }
            _ => ms += &format!("{line}\n"),
        }
    }
    std::fs::write(&csv, ms).unwrap();
    let e = format!(
        "{:#}",
        recording_io::convert(&csv, &dir.path().join("b.bin")).unwrap_err()
    );
    assert!(
        e.contains("time_ms.csv: the rate must be within [10, 40000] Hz"),
        "{e}"
    );
    assert!(!dir.path().join("a.bin").exists() && !dir.path().join("b.bin").exists());
}
