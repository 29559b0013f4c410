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

#[test]
fn the_end_record_marks_a_complete_log_and_report_warns_without_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 20 s of the `static` scenario (45 deg N, 7.5 deg E, 150 m) with its truth.
    let o = nav(
        d,
        &[
            "sim",
            "static",
            "--out",
            "sim",
            "--seconds",
            "20",
            "--format",
            "bin",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
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
