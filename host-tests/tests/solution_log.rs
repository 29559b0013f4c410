//! The solution log's end record through the real command line: `nav replay` ends a complete
//! log with it, and `nav report` compares a log without it with a warning that the run was cut
//! short, and refuses an end record that does not match the rows.

mod common;

use std::path::Path;
use std::process::{Command, Output};

fn nav(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nav"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `seconds` of the `static` scenario (45 deg N, 7.5 deg E, 150 m) into `d/sim`, with its
/// truth (`sim/imu.bin`, `sim/truth.csv`).
fn simulate_static(d: &Path, seconds: &str) {
    let args = ["sim", "static", "--out", "sim", "--seconds", seconds];
    let o = nav(d, &[&args[..], &["--format", "bin"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn the_end_record_marks_a_complete_log_and_report_warns_without_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 20 s of the `static` scenario (45 deg N, 7.5 deg E, 150 m) with its truth.
    simulate_static(d, "20");
    let o = nav(d, &common::replay_args("sim/imu.bin", "log.csv", &[]));
    assert!(o.status.success(), "{}", stderr(&o));
    let log = std::fs::read_to_string(d.join("log.csv")).unwrap();
    let lines: Vec<&str> = log.lines().collect();
    // The header, the aligned row, 100 rows every 40 steps of 4000, the end record.
    assert_eq!(lines.len(), 1 + 1 + 100 + 1);
    assert_eq!(lines.last(), Some(&"# end: 101 rows, ok"));

    let report = |solution: &str| {
        nav(
            d,
            &["report", "--solution", solution, "--truth", "sim/truth.csv"],
        )
    };
    // Complete: no warning.
    let o = report("log.csv");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("solution log.csv (101 rows) against"),
        "{stdout}"
    );

    // Cut after 50 rows (no end record): compared, with a warning; exit status 0.
    std::fs::write(d.join("cut.csv"), lines[..51].join("\n") + "\n").unwrap();
    let o = report("cut.csv");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "warning: cut.csv: no end record ('# end: N rows, ok'): the run that wrote this log did not finish"
        ),
        "{}",
        stderr(&o)
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("solution cut.csv (50 rows, no end record: cut short)"),
        "{stdout}"
    );

    // Rows removed before the end record: refused, naming the counts.
    let mut short = lines[..51].to_vec();
    short.push(lines[lines.len() - 1]);
    std::fs::write(d.join("short.csv"), short.join("\n") + "\n").unwrap();
    let o = report("short.csv");
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("short.csv: line 52: the end record says 101 rows, the file has 50"),
        "{}",
        stderr(&o)
    );
}

/// A free-inertial log after an IMU gap beyond the bridge (6 s here): its rows carried on from
/// the state before the gap and looked valid, with nothing in the file to say otherwise. The
/// log marks the gap with its lost record now, and `nav report` does not compare the rows
/// after it, saying how many.
#[test]
fn rows_after_a_lost_imu_gap_are_marked_and_not_compared() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate_static(d, "30");
    let mut r = host_tests::recording_io::read(&d.join("sim/imu.bin")).unwrap();
    // 6 s of records lost from t = 15 s.
    r.records
        .retain(|x| !(15_000_000_000..21_000_000_000).contains(&(x.t_ns - r.t0_ns)));
    host_tests::recording_io::write(&d.join("gap.bin"), &r).unwrap();
    let o = nav(d, &common::replay_args("gap.bin", "log.csv", &[]));
    assert!(o.status.success(), "{}", stderr(&o));
    let log = std::fs::read_to_string(d.join("log.csv")).unwrap();
    let lost: Vec<&str> = log.lines().filter(|l| l.starts_with("# lost:")).collect();
    assert_eq!(lost.len(), 1, "{log}");
    assert!(
        lost[0].starts_with("# lost: t = 21.00") && lost[0].contains("after an IMU gap of "),
        "{}",
        lost[0]
    );
    let after = log
        .lines()
        .skip_while(|l| !l.starts_with("# lost:"))
        .filter(|l| !l.starts_with('#'))
        .count();
    assert!(after > 0);
    let o = nav(
        d,
        &[
            "report",
            "--solution",
            "log.csv",
            "--truth",
            "sim/truth.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains(&format!("not compared: the {after} rows from t = 21.00"))
            && stdout.contains("after an IMU gap that lost the solution"),
        "{stdout}"
    );
}

/// A trajectory header naming a column twice (two `lat_deg`): the first one was read silently,
/// here the zeros, putting the truth on the equator. Refused for the truth and the solution,
/// naming the column and its positions; the solution's 1-sigma and status columns too.
#[test]
fn report_refuses_a_column_named_twice() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let header = nav_core::output::CSV_HEADER;
    let rows = |extra: &str| {
        (0..3)
            .map(|k| format!("{k},45,7.5,250,0,0,0,0,0,0{extra}\n"))
            .collect::<String>()
    };
    std::fs::write(
        d.join("sol.csv"),
        format!("{header}\n{}# end: 3 rows, ok\n", rows("")),
    )
    .unwrap();
    std::fs::write(d.join("truth.csv"), format!("{header}\n{}", rows(""))).unwrap();
    let o = nav(
        d,
        &["report", "--solution", "sol.csv", "--truth", "truth.csv"],
    );
    assert!(o.status.success(), "{}", stderr(&o));

    std::fs::write(
        d.join("dup.csv"),
        format!(
            "lat_deg,{header}\n{}",
            rows("")
                .lines()
                .map(|l| format!("0,{l}\n"))
                .collect::<String>()
        ),
    )
    .unwrap();
    let expected = "dup.csv: line 1: the header names column lat_deg twice, as fields 1 and 3";
    let o = nav(
        d,
        &["report", "--solution", "sol.csv", "--truth", "dup.csv"],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains(expected), "{}", stderr(&o));
    std::fs::write(
        d.join("dup.csv"),
        format!(
            "lat_deg,{header}\n{}# end: 3 rows, ok\n",
            rows("")
                .lines()
                .map(|l| format!("0,{l}\n"))
                .collect::<String>()
        ),
    )
    .unwrap();
    let o = nav(
        d,
        &["report", "--solution", "dup.csv", "--truth", "truth.csv"],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains(expected), "{}", stderr(&o));

    std::fs::write(
        d.join("status.csv"),
        format!(
            "{header},status,status\n{}# end: 3 rows, ok\n",
            rows(",NAV,FOO")
        ),
    )
    .unwrap();
    let o = nav(
        d,
        &["report", "--solution", "status.csv", "--truth", "truth.csv"],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "status.csv: line 1: the header names column status twice, as fields 11 and 12"
        ),
        "{}",
        stderr(&o)
    );
}
