//! Outputs are whole or absent, inputs are never overwritten, a run that navigated nothing
//! fails, and implausible sites are refused: through the real command line.

use host_tests::generate::Stationary;
use host_tests::recording_io;
use std::path::Path;
mod common;
use common::{nav, output_text as text, replay_args};

fn recording(dir: &Path, seconds: f64) -> String {
    let s = Stationary {
        seconds,
        ..Stationary::default()
    };
    let path = dir.join("imu.bin");
    recording_io::write(&path, &s.recording().unwrap()).unwrap();
    path.to_str().unwrap().to_owned()
}

#[test]
fn output_equal_to_the_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let imu = recording(dir.path(), 20.0);
    let before = std::fs::read(&imu).unwrap();
    let o = nav(&replay_args(&imu, &imu, &[]));
    assert!(!o.status.success());
    assert!(text(&o).contains("is the input"), "{}", text(&o));
    assert_eq!(std::fs::read(&imu).unwrap(), before);
    // The same for `nav convert`, under another spelling of the path.
    let other = dir.path().join(".").join("imu.bin");
    let o = nav(&["convert", "--in", &imu, "--out", other.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("is the input"), "{}", text(&o));
    assert_eq!(std::fs::read(&imu).unwrap(), before);
}

#[test]
fn a_failed_replay_leaves_an_existing_output_untouched_and_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let imu = recording(dir.path(), 20.0);
    let out = dir.path().join("log.csv");
    std::fs::write(&out, "previous run\n").unwrap();
    let out_s = out.to_str().unwrap();
    // Fails after the log was opened: the recording ends during the alignment.
    let o = nav(&replay_args(&imu, out_s, &["--align-seconds", "30"]));
    assert!(!o.status.success(), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "previous run\n");
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    // A missing input: refused, nothing created.
    let fresh = dir.path().join("fresh.csv");
    let o = nav(&replay_args(
        "/nonexistent.bin",
        fresh.to_str().unwrap(),
        &[],
    ));
    assert!(!o.status.success());
    assert!(!fresh.exists());
    // A good run replaces it.
    let o = nav(&replay_args(&imu, out_s, &[]));
    assert!(o.status.success(), "{}", text(&o));
    assert!(std::fs::read_to_string(&out).unwrap().starts_with("t_s"));
}

#[test]
fn a_run_that_navigates_nothing_fails_with_the_counts() {
    let dir = tempfile::tempdir().unwrap();
    // 10 s exactly: the alignment uses every sample, no navigation step is left.
    let imu = recording(dir.path(), 10.0);
    let out = dir.path().join("log.csv");
    let o = nav(&replay_args(&imu, out.to_str().unwrap(), &[]));
    assert!(!o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains(
            "no navigation step after the alignment: 4000 samples, 4000 used by the alignment"
        ),
        "{t}"
    );
    assert!(!out.exists());
}

#[test]
fn implausible_longitude_and_height_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let imu = recording(dir.path(), 20.0);
    let out = dir.path().join("log.csv");
    let out_s = out.to_str().unwrap();
    for (key, value, msg) in [
        (
            "--lon",
            "400",
            "longitude 400 deg is not within [-180, 180]",
        ),
        ("--h", "-1e7", "height -1e7 m is not within"),
    ] {
        let mut args = replay_args(&imu, out_s, &[]);
        let i = args.iter().position(|a| *a == key).unwrap();
        args[i + 1] = value;
        let o = nav(&args);
        assert!(!o.status.success());
        assert!(text(&o).contains(msg), "{key}: {}", text(&o));
        assert!(!out.exists());
    }
}

/// `nav report --plots DIR` where a plot's name is a link to the solution: refused before any
/// plot is written, the solution kept. Was: the plot written through the link over the
/// solution log (plots were written in place, not whole).
#[test]
fn a_plot_over_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let header = "t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,pitch_deg,yaw_deg";
    let rows: String = (0..5)
        .map(|k| format!("{k},45,7.5,150,0,0,0,1,2,{}\n", 30 + k))
        .collect();
    let log = format!("{header}\n{rows}# end: 5 rows, ok\n");
    let solution = dir.path().join("sol.csv");
    std::fs::write(&solution, &log).unwrap();
    let truth = dir.path().join("truth.csv");
    std::fs::write(&truth, format!("{header}\n{rows}")).unwrap();
    let plots = dir.path().join("plots");
    std::fs::create_dir(&plots).unwrap();
    std::os::unix::fs::symlink("../sol.csv", plots.join("position_errors.svg")).unwrap();
    let path = |p: &Path| p.to_str().unwrap().to_owned();
    let report = || {
        nav(&[
            "report",
            "--solution",
            &path(&solution),
            "--truth",
            &path(&truth),
            "--plots",
            &path(&plots),
        ])
    };
    let o = report();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("is the input"), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(&solution).unwrap(), log);
    assert!(!plots.join("attitude_errors.svg").exists());
    // Without the link: the three plots.
    std::fs::remove_file(plots.join("position_errors.svg")).unwrap();
    let o = report();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    for name in [
        "attitude_errors.svg",
        "velocity_errors.svg",
        "position_errors.svg",
    ] {
        let svg = std::fs::read_to_string(plots.join(name)).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
            "{name}"
        );
    }
}

/// Ctrl-C (SIGINT) or SIGTERM during a replay left its hidden `.log.csv.XXXX.part` beside
/// `--out` (piling up at every interrupt); now the run removes it and exits with the status a
/// shell gives the signal (130, 143), nothing at `--out`.
#[cfg(unix)]
#[test]
fn an_interrupted_run_leaves_no_partial_output() {
    let dir = tempfile::tempdir().unwrap();
    // Long enough that the run is still writing when the signal comes (about 2 s of replay).
    let imu = recording(dir.path(), 3600.0);
    for (signal, status) in [("INT", 130), ("TERM", 143)] {
        let out = dir.path().join("log.csv");
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_nav"))
            .args(replay_args(
                &imu,
                out.to_str().unwrap(),
                &["--log-every", "1"],
            ))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let part = || {
            std::fs::read_dir(dir.path())
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .any(|n| n.ends_with(".part"))
        };
        let start = std::time::Instant::now();
        while !part() {
            assert!(start.elapsed().as_secs() < 30, "no partial output appeared");
            assert!(child.try_wait().unwrap().is_none(), "the run ended first");
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        let sent = std::process::Command::new("kill")
            .args([&format!("-{signal}"), &child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        let exit = child.wait().unwrap();
        assert_eq!(exit.code(), Some(status), "SIG{signal}: {exit:?}");
        assert!(!part(), "SIG{signal}: a partial output is left");
        assert!(!out.exists(), "SIG{signal}: an output at --out");
    }
}

/// `nav report --at` outside the compared rows' span is refused, naming the span: `--at
/// 1e9` printed the last row's error under "at t0 + 1e9 s", `--at -5` the first's.
#[test]
fn report_at_a_time_outside_the_solution_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let header = "t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,pitch_deg,yaw_deg";
    let row = |k: u32| format!("{k},45,7.5,150,0,0,0,1,2,30\n");
    // The truth from 0 to 20 s, the solution from 5 to 15 s.
    let truth: String = (0..=20).map(row).collect();
    let rows: String = (5..=15).map(row).collect();
    let (solution, truth_path) = (dir.path().join("sol.csv"), dir.path().join("truth.csv"));
    std::fs::write(&solution, format!("{header}\n{rows}# end: 11 rows, ok\n")).unwrap();
    std::fs::write(&truth_path, format!("{header}\n{truth}")).unwrap();
    let report = |at: &str| {
        nav(&[
            "report",
            "--solution",
            solution.to_str().unwrap(),
            "--truth",
            truth_path.to_str().unwrap(),
            "--at",
            at,
        ])
    };
    let o = report("5,10,15");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    for at in ["1e9", "-5", "10,2"] {
        let o = report(at);
        assert_eq!(o.status.code(), Some(1), "{at}: {}", text(&o));
        assert!(
            text(&o).contains("is outside the compared rows' span, t0 + 5.000000 .. 15.000000 s"),
            "{at}: {}",
            text(&o)
        );
    }
}
