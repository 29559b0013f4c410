//! The text readers (CSV, KF-GINS, PSINS, truth CSV, oscillator readouts): a cut-off last line,
//! times beyond the recording clock and PSINS header values are refused naming the cause, and
//! every reader (and `nav convert`) streams in memory independent of the file's length (a
//! per-thread counting allocator watches the peak while generated files of many rows run
//! through).

mod common;

use common::nav;
use common::{replay, replay_error};
use hal_adapters::Imu;
use hal_adapters::recording::Record;
use host_tests::generate::Stationary;
use host_tests::kf_gins;
use host_tests::oscillator::file::{self as osc_file, OscReader, OscRow};
use host_tests::oscillator::replay as osc_replay;
use host_tests::psins;
use host_tests::recording_io::{self, Format, Recording};
use host_tests::replay::ReplayOptions;
use host_tests::text_recording;
use host_tests::truth_csv::{self, TruthReader};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};
use std::time::Instant;

// ---------------------------------------------------------------------------------------------
// A counting allocator: bytes live and their peak, per thread (tests run in parallel threads).

/// The system allocator, counting the bytes each thread holds.
struct Counting;

thread_local! {
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

fn count(delta: isize) {
    // `try_with`: nothing to count once the thread's locals are gone.
    let _ = LIVE.try_with(|live| {
        let now = live.get() + delta;
        live.set(now);
        let _ = PEAK.try_with(|peak| peak.set(peak.get().max(now)));
    });
}

// The only unsafe code of the tests: a global allocator must be an `unsafe impl`; it forwards
// every call to the system allocator unchanged and only counts.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        count(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            count(new_size as isize - layout.size() as isize);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `f` and returns its value and the most bytes this thread held above what it held when
/// `f` started.
fn peak_bytes<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let start = LIVE.with(Cell::get);
    PEAK.with(|p| p.set(start));
    let value = f();
    let peak = PEAK.with(Cell::get) - start;
    (value, peak.max(0) as usize)
}

/// Most memory a reader may hold, whatever the file's length [bytes]: buffers, one line, the
/// rate prefix (4097 times of 8 bytes). The readers that collected every row held ~40 bytes
/// per row and more: 16 MB for the 400 000 rows of the CI-sized case.
const BOUND_BYTES: usize = 1 << 20;

// ---------------------------------------------------------------------------------------------
// Generated files: a `Read` that makes its lines as they are read, nothing on disk.

/// A text file of `lines` lines, line `k` written by `make(k, buf)` when the reader gets to it.
struct Generated {
    lines: u64,
    next: u64,
    line: Vec<u8>,
    pos: usize,
    make: fn(u64, &mut Vec<u8>),
}

impl Generated {
    fn new(lines: u64, make: fn(u64, &mut Vec<u8>)) -> BufReader<Self> {
        BufReader::new(Self {
            lines,
            next: 0,
            line: Vec::with_capacity(256),
            pos: 0,
            make,
        })
    }
}

impl Read for Generated {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.pos == self.line.len() {
            if self.next == self.lines {
                return Ok(0);
            }
            self.line.clear();
            (self.make)(self.next, &mut self.line);
            self.next += 1;
            self.pos = 0;
        }
        let n = buf.len().min(self.line.len() - self.pos);
        buf[..n].copy_from_slice(&self.line[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

const CSV_HEADER: &str = "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps";

/// CSV at 400 Hz: the header, then rows at rest with a little variation.
fn csv_line(k: u64, out: &mut Vec<u8>) {
    use std::io::Write;
    if k == 0 {
        writeln!(out, "{CSV_HEADER}").unwrap();
    } else {
        let j = (k % 7) as f32;
        writeln!(
            out,
            "{},{},0,{},0.0001,-0.0002,{}",
            k as f64 * 0.0025,
            1e-7 * j,
            -2e-7,
            -0.024_516 - 1e-6 * j
        )
        .unwrap();
    }
}

/// KF-GINS IMU text at 200 Hz, seconds of week, `%.9f` fields as its datasets have them.
fn kf_gins_line(k: u64, out: &mut Vec<u8>) {
    use std::io::Write;
    let j = (k % 5) as f64;
    writeln!(
        out,
        "{:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}",
        456_300.0 + (k + 1) as f64 * 0.005,
        -1.1e-5 + 1e-8 * j,
        2.7e-6,
        -3.3e-6,
        2.2e-4,
        -3.0e-5,
        -0.049_042 - 1e-7 * j
    )
    .unwrap();
}

/// PSINS at 100 Hz: three header lines, then counts.
fn psins_line(k: u64, out: &mut Vec<u8>) {
    use std::io::Write;
    match k {
        0 => writeln!(out, "0 0 -90.6 0 0 0").unwrap(),
        1 => writeln!(out, "34.246048 108.909664 380.0 0 10 9.780327").unwrap(),
        2 => writeln!(out, "0.1 0.1 0.1 125 125 125").unwrap(),
        k => writeln!(out, "{} 9 3 0 {} 80", k % 11, k % 3).unwrap(),
    }
}

/// A trajectory CSV at 100 Hz.
fn truth_line(k: u64, out: &mut Vec<u8>) {
    use std::io::Write;
    if k == 0 {
        writeln!(out, "{}", nav_core::output::CSV_HEADER).unwrap();
    } else {
        let t = k as f64 * 0.01;
        writeln!(out, "{t},45.0{k},7.5,150,0.01,-0.002,0,1.5,-2,30").unwrap();
    }
}

/// Oscillator readouts at 5 kHz.
fn osc_line(k: u64, out: &mut Vec<u8>) {
    use std::io::Write;
    if k == 0 {
        writeln!(out, "t_s,x_m,y_m,z_m").unwrap();
    } else {
        let t = k as f64 * 0.0002;
        let (s, c) = (t * 3000.0).sin_cos();
        writeln!(out, "{t},{:e},{:e},{:e}", 1e-5 * s, 1e-5 * c, 2e-6 * s).unwrap();
    }
}

/// A generated format: its generator and its lines that are not samples.
type Case = (Format, fn(u64, &mut Vec<u8>), u64);

/// Replays a generated text recording of `lines` lines through the harness's text replay (two
/// passes, as `nav replay` reads a file); returns the samples and the peak bytes held.
fn replay_generated(format: Format, lines: u64, make: fn(u64, &mut Vec<u8>)) -> (u64, usize) {
    peak_bytes(|| {
        let path = Path::new("generated");
        let (mut replay, _) =
            text_recording::replay(format, path, || Ok(Generated::new(lines, make))).unwrap();
        let mut samples = 0_u64;
        while replay.read_sample().unwrap().is_some() {
            samples += 1;
        }
        assert_eq!(u64::from(replay.header().sample_count), samples);
        samples
    })
}

#[test]
fn text_replays_stream_in_bounded_memory() {
    let cases: [Case; 3] = [
        (Format::Csv, csv_line, 1),
        (Format::KfGins, kf_gins_line, 0),
        (Format::Psins, psins_line, 3),
    ];
    for (format, make, header_lines) in cases {
        let mut peaks = Vec::new();
        for samples in [20_000_u64, 400_000] {
            let (n, peak) = replay_generated(format, samples + header_lines, make);
            assert_eq!(n, samples, "{format}");
            println!("{format}: {samples} samples, peak {} KiB", peak / 1024);
            assert!(
                peak < BOUND_BYTES,
                "{format}: {samples} samples held {peak} bytes at the peak"
            );
            peaks.push(peak);
        }
        // Twenty times the rows, about the same memory (the rate prefix is full in both).
        assert!(
            peaks[1] <= peaks[0] + 64 * 1024,
            "{format}: peak grows with the length: {peaks:?}"
        );
    }
}

#[test]
fn trajectory_and_readout_readers_stream_in_bounded_memory() {
    for rows in [20_000_u64, 400_000] {
        let (n, peak) = peak_bytes(|| {
            let mut reader =
                TruthReader::new(Generated::new(rows + 1, truth_line), Path::new("t")).unwrap();
            reader.try_fold(0_u64, |n, r| r.map(|_| n + 1)).unwrap()
        });
        assert_eq!(n, rows);
        assert!(peak < BOUND_BYTES, "truth: {rows} rows held {peak} bytes");
        let (n, peak) = peak_bytes(|| {
            let mut reader =
                OscReader::new(Generated::new(rows + 1, osc_line), Path::new("o")).unwrap();
            reader.try_fold(0_u64, |n, r| r.map(|_| n + 1)).unwrap()
        });
        assert_eq!(n, rows);
        assert!(peak < BOUND_BYTES, "osc: {rows} rows held {peak} bytes");
    }
}

/// `lines` lines of `make` written to `path` (streamed, nothing held).
fn write_generated(path: &Path, lines: u64, make: fn(u64, &mut Vec<u8>)) {
    let mut file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    std::io::copy(&mut Generated::new(lines, make), &mut file).unwrap();
}

/// `nav convert` ([`recording_io::convert`]) streams: CSV to binary and binary to CSV of 50 000
/// and of 200 000 rows hold about the same memory at the peak, far below either file's size
/// (the in-memory conversion held every record, 40 bytes each and more).
#[test]
fn convert_streams_in_bounded_memory() {
    let dir = tempfile::tempdir().unwrap();
    let mut peaks = Vec::new();
    for samples in [50_000_u64, 200_000] {
        let csv = dir.path().join(format!("in-{samples}.csv"));
        write_generated(&csv, samples + 1, csv_line);
        let (bin, back) = (
            dir.path().join(format!("{samples}.bin")),
            dir.path().join(format!("{samples}.csv")),
        );
        let (c, to_binary) = peak_bytes(|| recording_io::convert(&csv, &bin).unwrap());
        assert_eq!(
            (c.format, u64::from(c.header.sample_count)),
            (Format::Csv, samples)
        );
        let (c, to_csv) = peak_bytes(|| recording_io::convert(&bin, &back).unwrap());
        assert_eq!(
            (c.format, u64::from(c.header.sample_count)),
            (Format::Binary, samples)
        );
        let size = |p: &Path| std::fs::metadata(p).unwrap().len() as usize;
        let smallest = size(&csv).min(size(&bin)).min(size(&back));
        println!(
            "convert {samples} samples: CSV ({} KiB) to binary ({} KiB) peak {} KiB, back to CSV \
             peak {} KiB",
            size(&csv) / 1024,
            size(&bin) / 1024,
            to_binary / 1024,
            to_csv / 1024
        );
        for (what, peak) in [("CSV to binary", to_binary), ("binary to CSV", to_csv)] {
            assert!(
                peak < BOUND_BYTES && peak < smallest / 8,
                "{what}, {samples} samples: {peak} bytes at the peak, files of {smallest} bytes and more"
            );
        }
        peaks.push((to_binary, to_csv));
    }
    // Four times the rows, about the same memory.
    for (what, small, large) in [
        ("CSV to binary", peaks[0].0, peaks[1].0),
        ("binary to CSV", peaks[0].1, peaks[1].1),
    ] {
        assert!(
            large <= small + 64 * 1024,
            "{what}: the peak grows with the length: {small} then {large} bytes"
        );
    }
}

/// The benchmark: 12 million samples (an 11.5 M-sample KF-GINS file held 1.76 GiB with the
/// readers that collected every row) through the text replay, samples/s and the peak.
/// `cargo test -p host-tests --release --test text_readers -- --ignored --nocapture`
#[test]
#[ignore = "benchmark: 12 M samples per format, tens of seconds in release"]
fn text_replay_benchmark_12m_samples() {
    let samples = 12_000_000_u64;
    let cases: [Case; 3] = [
        (Format::Csv, csv_line, 1),
        (Format::KfGins, kf_gins_line, 0),
        (Format::Psins, psins_line, 3),
    ];
    for (format, make, header_lines) in cases {
        let started = Instant::now();
        let (n, peak) = replay_generated(format, samples + header_lines, make);
        let seconds = started.elapsed().as_secs_f64();
        assert_eq!(n, samples);
        println!(
            "{format}: {n} samples in {seconds:.2} s (two passes): {:.0} samples/s, peak {} KiB",
            n as f64 / seconds,
            peak / 1024
        );
        assert!(peak < BOUND_BYTES, "{format}: peak {peak} bytes");
    }
}

// ---------------------------------------------------------------------------------------------
// Cut-off last lines.

fn scenario() -> Stationary {
    Stationary {
        seconds: 20.0,
        ..Stationary::default()
    } // 8000 samples at 400 Hz
}

fn options() -> ReplayOptions {
    let s = scenario();
    ReplayOptions::new(s.lat_deg, s.lon_deg, s.h_m, 10.0)
}

/// `text` without its final newline, its last line's last field (after a `,` or a blank) cut
/// to its first `keep` characters.
fn cut(text: &str, keep: usize) -> String {
    let body = text.strip_suffix('\n').unwrap_or(text);
    let start = body.rfind([',', ' ']).map_or(0, |i| i + 1);
    assert!(
        body.len() - start > keep,
        "the last field is too short to cut"
    );
    body[..start + keep].to_owned()
}

/// The scenario's recording as CSV text.
fn scenario_csv(dir: &Path) -> String {
    let path = dir.join("full.csv");
    recording_io::write(&path, &scenario().recording().unwrap()).unwrap();
    std::fs::read_to_string(&path).unwrap()
}

#[test]
fn a_csv_cut_inside_its_last_field_is_refused_and_nothing_is_left_at_out() {
    let dir = tempfile::tempdir().unwrap();
    let text = scenario_csv(dir.path());
    // Keep two characters of the last field (the temperature, written `25.0` on every row).
    let imu = dir.path().join("cut.csv");
    std::fs::write(&imu, cut(&text, 2)).unwrap();
    let out = dir.path().join("log.csv");
    std::fs::write(&out, "an older log\n").unwrap();
    let (lat, lon, h) = (scenario().lat_deg, scenario().lon_deg, scenario().h_m);
    let o = nav(&[
        "replay",
        "--imu",
        imu.to_str().unwrap(),
        "--lat",
        &lat.to_string(),
        "--lon",
        &lon.to_string(),
        "--h",
        &h.to_string(),
        "--align-seconds",
        "10",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("cut.csv: truncated: last line 8001 ends inside a field (column temp_c:"),
        "{stderr}"
    );
    assert!(stderr.contains("no newline ends the file"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "an older log\n");

    // Cut at a separator: the last line has 6 of its 8 fields.
    let at_comma = text.strip_suffix('\n').unwrap();
    let at_comma = &at_comma[..at_comma.rfind(',').unwrap()];
    let at_comma = &at_comma[..at_comma.rfind(',').unwrap()];
    std::fs::write(&imu, at_comma).unwrap();
    let msg = replay_error(&imu, &options());
    assert!(
        msg.contains("truncated: last line 8001 ends inside a field (it has 6 of the 8 fields"),
        "{msg}"
    );
    // `nav convert` reads with the same reader.
    let msg = format!("{:#}", recording_io::read(&imu).unwrap_err());
    assert!(msg.contains("truncated: last line 8001"), "{msg}");

    // A complete last line without the final newline is a complete file.
    std::fs::write(&imu, text.strip_suffix('\n').unwrap()).unwrap();
    let (fr, _) = replay::<f32>(&imu, &options());
    assert_eq!(fr.report.samples, 8000);
}

/// `#` comment lines in a CSV recording, before the header and between rows, are skipped by
/// the replay and by `nav convert` alike: the same samples and the same solution.
#[test]
fn comment_lines_in_a_csv_recording_are_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let text = scenario_csv(dir.path());
    let lines: Vec<&str> = text.lines().collect();
    let mut commented = String::from("# a bench recording\n");
    for (k, line) in lines.iter().enumerate() {
        if k == 4000 {
            commented.push_str("# the IMU was re-seated here\n");
        }
        commented.push_str(line);
        commented.push('\n');
    }
    let (plain, with) = (dir.path().join("plain.csv"), dir.path().join("with.csv"));
    std::fs::write(&plain, &text).unwrap();
    std::fs::write(&with, commented).unwrap();
    let (a, log_a) = replay::<f32>(&plain, &options());
    let (b, log_b) = replay::<f32>(&with, &options());
    assert_eq!((a.report.samples, b.report.samples), (8000, 8000));
    assert_eq!(log_a, log_b);
    let (ra, rb) = (
        recording_io::read(&plain).unwrap(),
        recording_io::read(&with).unwrap(),
    );
    assert_eq!(ra.records, rb.records);
}

#[test]
fn every_text_format_refuses_a_cut_last_line() {
    let dir = tempfile::tempdir().unwrap();
    // KF-GINS: fixed-width fields, so any cut inside the last one is shorter.
    let text: String = (0..3000)
        .map(|k| {
            let mut line = Vec::new();
            kf_gins_line(k, &mut line);
            String::from_utf8(line).unwrap()
        })
        .collect();
    let path = dir.path().join("imu.txt");
    std::fs::write(&path, cut(&text, 9)).unwrap();
    let msg = replay_error(&path, &options());
    assert!(
        msg.contains(
            "imu.txt: truncated: last line 3000 ends inside a field (column dv z: '-0.0490"
        ),
        "{msg}"
    );
    assert!(
        msg.contains("has 9 characters, the lines before at least 12"),
        "{msg}"
    );
    // PSINS: counts; "80" cut to "8".
    let text: String = (0..503)
        .map(|k| {
            let mut line = Vec::new();
            psins_line(k, &mut line);
            String::from_utf8(line).unwrap()
        })
        .collect();
    let e = psins::read_from(cut(&text, 1).as_bytes(), Path::new("p.imu")).unwrap_err();
    assert_eq!(
        e.to_string(),
        "p.imu: truncated: last line 503 ends inside a field (column accel z: '8' has 1 \
         characters, the lines before at least 2; no newline ends the file; if the line is \
         complete, end the file with a newline)"
    );
    // The truth CSV (`nav report`) and the oscillator readouts (`nav osc-replay`).
    let truth: String = (0..100)
        .map(|k| {
            let mut line = Vec::new();
            truth_line(k, &mut line);
            String::from_utf8(line).unwrap()
        })
        .collect();
    let e = truth_csv::read_from(cut(&truth, 1).as_bytes(), Path::new("t.csv")).unwrap_err();
    assert!(
        e.to_string().starts_with(
            "t.csv: truncated: last line 100 ends inside a field (column yaw_deg: '3'"
        ),
        "{e}"
    );
    let e = truth_csv::read_from(
        truth
            .trim_end()
            .trim_end_matches("30")
            .trim_end_matches(',')
            .as_bytes(),
        Path::new("t.csv"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("it has 9 of the 10 fields"), "{e}");
    let readouts: String = (0..100)
        .map(|k| {
            let mut line = Vec::new();
            osc_line(k, &mut line);
            String::from_utf8(line).unwrap()
        })
        .collect();
    let e = osc_file::read_from(cut(&readouts, 2).as_bytes(), Path::new("o.csv")).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("o.csv: truncated: last line 100 ends inside a field (column z_m:"),
        "{e}"
    );
    // A last field that is no number any more ('-1.2e-6' cut to '-1.2e').
    let e = osc_file::read_from(
        "t_s,x_m,y_m,z_m\n0.1,1e-5,2e-5,-1.2e-6\n0.2,1e-5,2e-5,-1.2e".as_bytes(),
        Path::new("o.csv"),
    )
    .unwrap_err();
    assert!(
        e.to_string()
            .contains("last line 3 ends inside a field (column z_m: '-1.2e' is not a number"),
        "{e}"
    );
    // Each, complete but without the final newline, reads.
    assert_eq!(
        truth_csv::read_from(truth.trim_end().as_bytes(), Path::new("t"))
            .unwrap()
            .len(),
        99
    );
    assert_eq!(
        osc_file::read_from(readouts.trim_end().as_bytes(), Path::new("o"))
            .unwrap()
            .len(),
        99
    );
    let rec = psins::read_from(text.trim_end().as_bytes(), Path::new("p")).unwrap();
    assert_eq!(rec.samples.len(), 500);
    let imu = kf_gins::read_imu_from(
        "456300.005 1e-6 0 0 0 0 -0.049\n456300.010 1e-6 0 0 0 0 -0.049".as_bytes(),
        Path::new("k"),
    )
    .unwrap();
    assert_eq!(imu.rows.len(), 2);
}

// ---------------------------------------------------------------------------------------------
// Times beyond the recording clock (u64 nanoseconds).

#[test]
fn times_beyond_the_clock_are_refused_with_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("t.csv");
    std::fs::write(
        &csv,
        format!("{CSV_HEADER}\n0.0025,0,0,0,0,0,-0.0245\n1e300,0,0,0,0,0,-0.0245\n"),
    )
    .unwrap();
    let msg = replay_error(&csv, &options());
    assert!(
        msg.contains(
            "t.csv: line 3: column t_s: time 1e300 s is beyond the recording clock's range (0 to \
             18446744073.709553 s, u64 nanoseconds)"
        ),
        "{msg}"
    );
    let kf = dir.path().join("k.txt");
    std::fs::write(&kf, "2e10 0 0 0 0 0 -0.049\n").unwrap();
    let msg = replay_error(&kf, &options());
    assert!(
        msg.contains(
            "k.txt: line 1: column seconds of week: time 20000000000 s is beyond the recording \
             clock's range"
        ),
        "{msg}"
    );
}

/// A PSINS file of `samples` count lines after the header lines 2 and 3 given.
fn psins_text(line_2: &str, line_3: &str, samples: usize) -> String {
    let mut text = format!("% test\n0 0 -90.6 0 0 0\n{line_2}\n{line_3}\n");
    for k in 0..samples {
        text.push_str(&format!("{} 9 3 0 2 80\n", k % 7));
    }
    text
}

#[test]
fn psins_header_values_are_refused_naming_the_cause() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| -> PathBuf {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    let site = "34.246048 108.909664 380.0";
    let scales = "0.1 0.1 0.1 125 125 125";
    let mut options = ReplayOptions::new(34.246048, 108.909664, 380.0, 10.0);
    options.run.log_every = 100;

    // t0 = 1e300 s wrapped the timestamps (first row at 0.0025 s).
    let p = write(
        "t0.imu",
        &psins_text(&format!("{site} 1e300 10 9.780327"), scales, 10),
    );
    let msg = replay_error(&p, &options);
    assert!(
        msg.contains("t0.imu: line 3: header: t0 [s] must be within the recording clock's range"),
        "{msg}"
    );
    // A t0 that fits, but the samples after it do not: the first one beyond is named.
    let p = write(
        "late.imu",
        &psins_text(&format!("{site} 18446744073.69 10 9.780327"), scales, 5),
    );
    let msg = replay_error(&p, &options);
    assert!(
        msg.contains("late.imu: line 6: sample 2 ends at t0 + 2 * interval"),
        "{msg}"
    );
    // Scale factors <= 0: named, before any alignment ("mean specific force is not gravity").
    let p = write(
        "gyro.imu",
        &psins_text(
            &format!("{site} 0 10 9.780327"),
            "0 0.1 0.1 125 125 125",
            10,
        ),
    );
    let msg = replay_error(&p, &options);
    assert!(
        msg.contains("gyro.imu: line 4: header line 3: PSINS scale factor 0 for gyro x"),
        "{msg}"
    );
    let p = write(
        "accel.imu",
        &psins_text(
            &format!("{site} 0 10 9.780327"),
            "0.1 0.1 0.1 125 125 -125",
            10,
        ),
    );
    let msg = replay_error(&p, &options);
    assert!(msg.contains("PSINS scale factor -125 for accel z"), "{msg}");
    // Scale factors beyond one count worth nav-core's largest increment: 1e300 converted to
    // infinite increments; the bounds themselves are accepted.
    for (line_3, expected) in [
        (
            "1e300 1 1 1 1 1",
            "header line 3: PSINS scale factor 1e300 arcsec/count for gyro x is beyond 720000 \
             arcsec/count",
        ),
        (
            "0.1 0.1 0.1 125 5000001 125",
            "header line 3: PSINS scale factor 5000001 ug*s/count for accel y is beyond 5000000 \
             ug*s/count",
        ),
    ] {
        let p = write(
            "coarse.imu",
            &psins_text(&format!("{site} 0 10 9.780327"), line_3, 10),
        );
        let msg = replay_error(&p, &options);
        assert!(msg.contains("coarse.imu: line 4: "), "{msg}");
        assert!(msg.contains(expected), "{msg}");
    }
    let p = write(
        "bounds.imu",
        &psins_text(
            &format!("{site} 0 10 9.780327"),
            "720000 720000 720000 5e6 5e6 5e6",
            1,
        ),
    );
    host_tests::psins::read(&p).unwrap();
    // A sub-nanosecond interval would give every sample the same time.
    let p = write(
        "fast.imu",
        &psins_text(&format!("{site} 0 1e-7 9.780327"), scales, 10),
    );
    let msg = replay_error(&p, &options);
    assert!(
        msg.contains("the sampling interval [ms] must be at least 1 ns"),
        "{msg}"
    );
    // A longitude outside [-180, 180].
    let p = write(
        "lon.imu",
        &psins_text("34.246048 400 380.0 0 10 9.780327", scales, 10),
    );
    let msg = replay_error(&p, &options);
    assert!(
        msg.contains("longitude [deg] must be within [-180, 180], found 400"),
        "{msg}"
    );
}

/// The scenario's recording as PSINS counts (fine scales, so rounding stays far below the
/// increments), with the header site `lat_deg, lon_deg`.
fn scenario_psins(lat_deg: f64, lon_deg: f64) -> String {
    const RAD_PER_ARCSEC: f64 = std::f64::consts::PI / 648_000.0;
    let (gyro_scale_arcsec, accel_scale_ug_s, g) = (1e-4, 0.01, 9.8);
    let rec = scenario().recording().unwrap();
    let interval_ms = 1e3 / rec.rate_hz;
    let mut text = format!(
        "% from the stationary scenario\n0 0 0 0 0 0\n{lat_deg} {lon_deg} {} {} {interval_ms} {g}\n\
         {s} {s} {s} {a} {a} {a}\n",
        scenario().h_m,
        rec.t0_ns as f64 * 1e-9,
        s = gyro_scale_arcsec,
        a = accel_scale_ug_s
    );
    let frd_to_rfu = |v: [f32; 3]| [f64::from(v[1]), f64::from(v[0]), -f64::from(v[2])];
    for r in &rec.records {
        let w = frd_to_rfu(r.gyro).map(|x| (x / (gyro_scale_arcsec * RAD_PER_ARCSEC)).round());
        let a = frd_to_rfu(r.accel).map(|x| (x / (accel_scale_ug_s * 1e-6 * g)).round());
        text.push_str(&format!(
            "{} {} {} {} {} {}\n",
            w[0], w[1], w[2], a[0], a[1], a[2]
        ));
    }
    text
}

#[test]
fn a_psins_site_far_from_the_run_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let s = scenario();
    let path = dir.path().join("site.imu");
    // Header site 0.01 deg (1.1 km) north of --lat.
    std::fs::write(&path, scenario_psins(s.lat_deg + 0.01, s.lon_deg)).unwrap();
    let msg = replay_error(&path, &options());
    assert!(
        msg.contains("site.imu: the PSINS header's site (45.01 deg, 7.5 deg) is 111")
            && msg.contains("m from --lat 45 --lon 7.5 (more than 1000 m)"),
        "{msg}"
    );
    // The height 1000 m off --h (accepted before, the heading's 1-sigma grown from 0.08 to
    // 11 deg on the laser-gyro data): refused too.
    std::fs::write(&path, scenario_psins(s.lat_deg, s.lon_deg)).unwrap();
    let mut far = options();
    far.run.h_m += 1000.0;
    let msg = replay_error(&path, &far);
    assert!(
        msg.contains(&format!(
            "site.imu: the PSINS header's height {} m is 1000 m from --h {} (more than 200 m",
            s.h_m, far.run.h_m
        )),
        "{msg}"
    );
    // 0.005 deg (556 m) is within the bound: the replay runs.
    std::fs::write(&path, scenario_psins(s.lat_deg + 0.005, s.lon_deg)).unwrap();
    let (fr, _) = replay::<f64>(&path, &options());
    assert_eq!(fr.format, Format::Psins);
    assert_eq!((fr.report.samples, fr.report.flagged), (8000, 0));
    assert!(fr.report.nav_steps > 0);
}

// ---------------------------------------------------------------------------------------------
// The streaming replay keeps the in-memory reading's header; the oscillator's holes.

#[test]
fn the_text_replay_header_is_the_converters() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.csv");
    std::fs::write(&path, scenario_csv(dir.path())).unwrap();
    let in_memory: Recording = recording_io::read(&path).unwrap();
    let (source, format) = recording_io::ReplaySource::open(&path).unwrap();
    assert_eq!(format, Format::Csv);
    let h = source.header();
    assert_eq!(
        (h.rate_hz, h.t0_ns, h.sample_count as usize),
        (in_memory.rate_hz, in_memory.t0_ns, in_memory.records.len())
    );
    // The rate comes from the first 4097 records only: a file that halves its rate after them
    // keeps the first rate (the whole file's median interval would be the later one; the
    // replay flags the later intervals as gaps).
    let records: Vec<Record> = (1..=12_000_u64)
        .map(|k| Record {
            t_ns: k * 2_500_000 + if k > 4097 { (k - 4097) * 2_500_000 } else { 0 },
            gyro: [0.0; 3],
            accel: [0.0, 0.0, -0.0245],
            temperature_c: f32::NAN,
        })
        .collect();
    let r = Recording {
        kind: hal_adapters::recording::Kind::Increments,
        rate_hz: 400.0,
        t0_ns: 0,
        records,
    };
    let path = dir.path().join("two-rates.csv");
    recording_io::write(&path, &r).unwrap();
    let back = recording_io::read(&path).unwrap();
    assert_eq!(back.rate_hz, 400.0);
    let (source, _) = recording_io::ReplaySource::open(&path).unwrap();
    assert_eq!(source.header().rate_hz, 400.0);
}

#[test]
fn an_oscillator_time_far_ahead_is_refused_not_counted_for_ever() {
    let rows: Vec<OscRow> = (1..=2000)
        .map(|k| OscRow {
            t_s: f64::from(k) * 0.0002,
            r_b_m: Some(nav_core::Vector3::new(1e-5, 2e-5, 3e-6)),
        })
        .chain([OscRow {
            t_s: 1e300,
            r_b_m: Some(nav_core::Vector3::new(1e-5, 2e-5, 3e-6)),
        }])
        .collect();
    let e = osc_replay::replay::<f64>(&rows, 100.0, true, None).unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("the readout times jump from 0.4 s to 1e300 s")
            && msg.contains("more than 10000000; a wrong time?"),
        "{msg}"
    );
}
