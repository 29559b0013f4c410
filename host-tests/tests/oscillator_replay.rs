//! `nav osc-replay`'s library: the estimator over a readout file with holes and NaN rows, and a
//! corrupt file refused with its line.

use host_tests::oscillator::file::{self, OscRow};
use host_tests::oscillator::{OscillatorParams, replay, simulate_oscillator};
use host_tests::trajectory::scenarios::Scenario;
use std::path::Path;

fn readouts(seconds: f64) -> Vec<OscRow> {
    let traj = Scenario::by_name("static").unwrap().build().unwrap();
    let mut rows = Vec::new();
    simulate_oscillator(
        traj.as_ref(),
        &OscillatorParams::default(),
        seconds,
        |_, s, _| {
            rows.push(OscRow {
                t_s: s.t_s,
                r_b_m: Some(s.r_b_m),
            })
        },
    )
    .unwrap();
    rows
}

#[test]
fn holes_and_nan_rows_cost_only_their_periods() {
    let mut rows = readouts(3.0);
    let clean = replay::replay::<f64>(&rows, 100.0, true, None).unwrap();
    rows[5000].r_b_m = None; // a NaN row at 1 s
    rows.drain(10_000..10_003); // three readouts lost at 2 s
    let holed = replay::replay::<f64>(&rows, 100.0, true, None).unwrap();
    println!("clean: {clean}holed: {holed}");
    assert_eq!(holed.missing, 4);
    assert_eq!(holed.faults.get("broken"), Some(&2));
    // Each broken period also restarts nothing else: the rest give epochs as before.
    assert_eq!(holed.epochs + 2, clean.epochs);
    let f32s = replay::replay::<f32>(&rows, 100.0, true, None).unwrap();
    assert_eq!(f32s.epochs, holed.epochs);
}

#[test]
fn a_corrupt_file_is_refused_with_its_line() {
    let text = "t_s,x_m,y_m,z_m\n0.0002,1e-5,2e-5,3e-5\n0.0004,1e-5,zz,3e-5\n";
    let err = file::read_from(text.as_bytes(), Path::new("osc.csv")).unwrap_err();
    let msg = err.to_string();
    println!("{msg}");
    assert!(msg.contains("osc.csv") && msg.contains('3'), "{msg}");
    let short = [OscRow {
        t_s: 0.0,
        r_b_m: None,
    }];
    assert!(replay::replay::<f64>(&short, 100.0, true, None).is_err());
}

/// Readouts that are all NaN give no epoch: a failure naming the counts, and `nav
/// osc-replay` exits non-zero leaving nothing at `--out`.
#[test]
fn no_epoch_is_a_failure() {
    let mut rows = readouts(1.0);
    for r in &mut rows {
        r.r_b_m = None;
    }
    let msg = replay::replay::<f64>(&rows, 100.0, true, None)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("no attitude epoch"), "{msg}");
    assert!(msg.contains(&format!("({} missing)", rows.len())), "{msg}");
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("osc.csv");
    let text: String = std::iter::once("t_s,x_m,y_m,z_m\n".to_string())
        .chain(rows.iter().map(|r| format!("{},NaN,NaN,NaN\n", r.t_s)))
        .collect();
    std::fs::write(&input, text).unwrap();
    let out = dir.path().join("epochs.csv");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_nav"))
        .args([
            "osc-replay",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(
        !o.status.success(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("no attitude epoch"), "{stderr}");
    // The refusal is the readout file's, not a failure to write the output.
    assert!(
        stderr.contains(&format!("error: {}: ", input.display())) && !stderr.contains("writing"),
        "{stderr}"
    );
    assert!(!out.exists());
    // A corrupt line is named once, by the reader.
    std::fs::write(&input, "t_s,x_m,y_m,z_m\n0,1,2,3\nfoo,1,2\n").unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_nav"))
        .args(["osc-replay", input.to_str().unwrap(), "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && !out.exists(), "{stderr}");
    assert_eq!(
        stderr.trim(),
        format!(
            "error: {}: line 3: expected 4 columns (t_s,x_m,y_m,z_m), found 3",
            input.display()
        ),
        "{stderr}"
    );
}

/// Readouts in millimetres where metres belong (1000 times): the estimator locked on them and
/// wrote a specific force of 1000 g on a still base, exit 0. Each period is now a fault whose
/// force is beyond any IMU's 50 g, so no epoch comes out and the failure names the cause; the
/// readouts in metres give their epochs.
#[test]
fn readouts_in_another_unit_give_no_epoch() {
    let rows = readouts(3.0);
    let good = replay::replay::<f64>(&rows, 100.0, true, None).unwrap();
    assert!(good.epochs > 0 && !good.faults.contains_key("force beyond range"));
    let mm: Vec<OscRow> = rows
        .iter()
        .map(|r| OscRow {
            r_b_m: r.r_b_m.map(|v| v * 1000.0),
            ..*r
        })
        .collect();
    for msg in [
        replay::replay::<f64>(&mm, 100.0, true, None),
        replay::replay::<f32>(&mm, 100.0, true, None),
    ]
    .map(|r| r.unwrap_err().to_string())
    {
        assert!(
            msg.contains("no attitude epoch")
                && msg.contains("force beyond range")
                && msg.contains("readouts in another unit than metres"),
            "{msg}"
        );
    }
}
