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
