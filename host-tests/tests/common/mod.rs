//! Helpers shared by the integration tests.
#![allow(dead_code)]

use host_tests::pipeline::Report;
use host_tests::replay::{FileReport, ReplayOptions, replay_file};
use nav_core::Scalar;
use std::path::Path;

/// `nav replay`'s given start of the simulated land vehicle (`nav sim land-vehicle`'s
/// defaults: at rest, level, facing north at 45 deg N, 7.5 deg E, 250 m).
pub const GIVEN: [&str; 6] = [
    "--init-pos",
    "45,7.5,250",
    "--init-vel",
    "0,0,0",
    "--init-att",
    "0,0,0",
];

/// Mean Earth radius [m], to turn latitude/longitude differences into metres (1e-3 relative is
/// plenty for error bounds).
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// One parsed row of a solution log.
#[derive(Clone, Copy, Debug)]
pub struct Row {
    pub t_s: f64,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub h_m: f64,
    pub v_ned: [f64; 3],
    pub rpy_deg: [f64; 3],
}

/// Parses a solution log, checking its header line and its end record (the last line, with the
/// number of rows).
pub fn parse_log(text: &str) -> Vec<Row> {
    let mut lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines.first().copied(),
        Some(nav_core::output::CSV_HEADER),
        "log header"
    );
    let end = lines.pop().and_then(nav_core::output::EndRecord::parse);
    let rows = lines.len() - 1;
    assert_eq!(
        end,
        Some(Ok(nav_core::output::EndRecord { rows: rows as u32 })),
        "end record of a log with {rows} rows"
    );
    lines[1..]
        .iter()
        .map(|line| {
            let v: Vec<f64> = line
                .split(',')
                .map(|f| f.parse().unwrap_or_else(|_| panic!("bad field in {line}")))
                .collect();
            assert_eq!(v.len(), 10, "{line}");
            Row {
                t_s: v[0],
                lat_deg: v[1],
                lon_deg: v[2],
                h_m: v[3],
                v_ned: [v[4], v[5], v[6]],
                rpy_deg: [v[7], v[8], v[9]],
            }
        })
        .collect()
}

/// Replays `path` in precision `T`; returns the report and the log text.
pub fn replay<T: Scalar>(path: &Path, options: &ReplayOptions) -> (FileReport, String) {
    let mut log = Vec::new();
    let report = replay_file::<T, _>(path, options, &mut log)
        .unwrap_or_else(|e| panic!("replay of {} failed: {e:#}", path.display()));
    (report, String::from_utf8(log).unwrap())
}

/// Replays `path` expecting an error; returns its full message (with the context chain).
pub fn replay_error(path: &Path, options: &ReplayOptions) -> String {
    match replay_file::<f64, _>(path, options, std::io::sink()) {
        Ok(r) => panic!("replay of {} succeeded: {:?}", path.display(), r.report),
        Err(e) => format!("{e:#}"),
    }
}

/// Expected number of solution rows: the alignment row, one every `log_every` navigation steps,
/// and the last step when it was not logged.
pub fn expected_rows(report: &Report, log_every: u32) -> u32 {
    let n = report.nav_steps;
    1 + n / log_every + u32::from(!n.is_multiple_of(log_every))
}

/// Runs the `nav` binary with `args`.
pub fn nav(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_nav"))
        .args(args)
        .output()
        .expect("run nav")
}

/// `nav replay` of `imu` into `out` at the tests' site (45 deg, 7.5 deg, 150 m) with a 10 s
/// alignment window, followed by `extra`.
pub fn replay_args<'a>(imu: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "replay",
        "--imu",
        imu,
        "--out",
        out,
        "--lat",
        "45",
        "--lon",
        "7.5",
        "--h",
        "150",
        "--align-seconds",
        "10",
    ];
    v.extend_from_slice(extra);
    v
}

/// Writes a still recording of `seconds` [s] to `path` with `nav generate`, which must succeed.
pub fn generated_recording(path: &Path, seconds: &str) {
    let o = nav(&[
        "generate",
        "--out",
        path.to_str().unwrap(),
        "--seconds",
        seconds,
    ]);
    assert!(o.status.success(), "{}", output_text(&o));
}

/// A command's stdout and stderr, as text.
pub fn output_text(o: &std::process::Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}
