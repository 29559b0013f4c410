//! The output protocol end to end on the host: solution logs of real replays (free inertial
//! and GNSS-aided) sent as frames among other frames and garbage, and `nav decode` giving the
//! same log back byte for byte; cut-off, garbage-only and missing streams; `nav config` on good
//! and bad files.

mod common;

use common::{nav, output_text, replay_args};
use hal_adapters::protocol::messages::{EndOfRun, HealthReport, NavSolution, RawIncrements};
use hal_adapters::protocol::status::{HealthCounters, NavStatus, StatusFlags};
use hal_adapters::protocol::vibration::VibrationLevels;
use hal_adapters::protocol::{Decoder, Encoder, Message};
use hal_adapters::{ImuSample, Motion, SampleFlags};
use nav_core::ins_filter::FilterStatus;
use nav_core::output::{FilterColumns, Row, Solution};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// `value / 10^digits` written as a decimal, back to the integer.
fn decimal(text: &str, digits: usize) -> i64 {
    let (neg, mag) = match text.strip_prefix('-') {
        Some(m) => (true, m),
        None => (false, text),
    };
    let (int, frac) = mag.split_once('.').unwrap();
    assert_eq!(frac.len(), digits, "{text}");
    let v: i64 = format!("{int}{frac}").parse().unwrap();
    if neg { -v } else { v }
}

/// A solution log's row back to nav-core's row (every printed value round-trips exactly:
/// integers as decimals, floats in their shortest round-trip form).
fn parse_row(line: &str) -> Row {
    let f: Vec<&str> = line.split(',').collect();
    let x = |i: usize| f[i].parse::<f64>().unwrap();
    let s = Solution {
        t_us: decimal(f[0], 6) as u64,
        lat_ndeg: decimal(f[1], 9),
        lon_ndeg: decimal(f[2], 9),
        h_m: x(3),
        v_eb_n: [x(4), x(5), x(6)],
        roll_deg: x(7),
        pitch_deg: x(8),
        yaw_deg: x(9),
    };
    if f.len() == 10 {
        return Row::Free(s);
    }
    let y = |i: usize| f[i].parse::<f32>().unwrap();
    let status = [FilterStatus::Nominal, FilterStatus::AidingRejected]
        .into_iter()
        .map(FilterStatus::name)
        .find(|n| *n == f[19])
        .unwrap();
    Row::Aided(
        s,
        FilterColumns {
            sigma_ned_m: [y(10), y(11), y(12)],
            sigma_v_ned_m_s: [y(13), y(14), y(15)],
            sigma_att_deg: [y(16), y(17), y(18)],
            status,
        },
    )
}

/// The stream a board would send for `log`: each row as a solution frame, between raw and
/// health frames, then the end of run; with `garbage`, random bytes (and a corrupted frame)
/// between frames. Returns the stream and the garbage bytes added.
fn stream_of(log: &str, garbage: bool) -> (Vec<u8>, usize) {
    let mut lines = log.lines();
    lines.next(); // header
    let rows: Vec<Row> = lines
        .filter(|l| !l.starts_with('#'))
        .map(parse_row)
        .collect();
    let mut enc = Encoder::new();
    let mut rng = ChaCha8Rng::seed_from_u64(0x0123_4567_89ab_cdef);
    let mut out = Vec::new();
    let mut added = 0;
    let mut frame = |m: &Message, out: &mut Vec<u8>| {
        enc.append(m, out).unwrap();
    };
    let raw = Message::RawIncrements(RawIncrements {
        sample: ImuSample {
            t_us: 1,
            seq: 1,
            dt_s: 0.0025,
            motion: Motion::Increments {
                delta_theta_ib_b: [0.0; 3],
                delta_v_ib_b: [0.0, 0.0, -0.0245],
            },
            temperature_c: 25.0,
            flags: SampleFlags::empty(),
        },
    });
    let health = Message::Health(HealthReport {
        t_us: 1,
        status: NavStatus::Nav,
        flags: StatusFlags::empty(),
        counters: HealthCounters::default(),
        vibration: VibrationLevels::default(),
    });
    for (k, row) in rows.iter().enumerate() {
        if garbage && k % 7 == 3 {
            // Never a zero inside (it would split the garbage into frames of its own), so
            // the decoder must skip exactly these bytes and the zero after them.
            let n: usize = rng.random_range(1..=40);
            let junk: Vec<u8> = (0..n).map(|_| rng.random_range(1..=255u8)).collect();
            added += junk.len();
            out.extend(junk);
            out.push(0);
            added += 1;
        }
        frame(&raw, &mut out);
        let m = Message::NavSolution(NavSolution {
            row: *row,
            status: NavStatus::Nav,
            flags: StatusFlags::empty(),
        });
        frame(&m, &mut out);
        if k % 10 == 0 {
            frame(&health, &mut out);
        }
    }
    frame(
        &Message::EndOfRun(EndOfRun {
            rows: rows.len() as u32,
        }),
        &mut out,
    );
    (out, added)
}

/// The `k`-th free-inertial solution frame of a still run at 400 Hz from 1 s.
fn free_row(k: u64) -> Message {
    Message::NavSolution(NavSolution {
        row: Row::Free(Solution {
            t_us: 1_000_000 + k * 2500,
            lat_ndeg: 45_000_000_000,
            lon_ndeg: 7_500_000_000,
            h_m: 150.0,
            v_eb_n: [0.0; 3],
            roll_deg: 0.0,
            pitch_deg: 0.0,
            yaw_deg: 30.0,
        }),
        status: NavStatus::Nav,
        flags: StatusFlags::empty(),
    })
}

fn run_ok(args: &[&str]) -> String {
    let o = nav(args);
    let text = output_text(&o);
    assert!(o.status.success(), "nav {args:?}: {text}");
    text
}

fn run_err(args: &[&str]) -> String {
    let o = nav(args);
    let text = output_text(&o);
    assert!(!o.status.success(), "nav {args:?} should fail: {text}");
    text
}

/// Sends `log` through the stream and `nav decode`, and checks the decoded log is the same
/// text; returns the decoder's report.
fn decode_round_trip(dir: &Path, name: &str, log: &str) -> String {
    let (stream, garbage) = stream_of(log, true);
    let path = dir.join(format!("{name}.bin"));
    std::fs::write(&path, &stream).unwrap();
    let out = dir.join(format!("{name}.decoded.csv"));
    let report = run_ok(&[
        "decode",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let decoded = std::fs::read_to_string(&out).unwrap();
    assert!(decoded == log, "{name}: decoded log differs\n{report}");
    // Every garbage byte skipped, the frames all counted.
    assert!(
        report.contains(&format!("{garbage} skipped bytes")),
        "{report}"
    );
    assert!(
        report.contains("frames lost") && report.contains("complete"),
        "{report}"
    );
    report
}

#[test]
fn replayed_logs_come_back_byte_for_byte_through_garbage() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Free inertial: a stationary recording, a row every step.
    let imu = d.join("still.bin");
    run_ok(&[
        "generate",
        "--out",
        imu.to_str().unwrap(),
        "--seconds",
        "30",
    ]);
    let free = d.join("free.csv");
    run_ok(&replay_args(
        imu.to_str().unwrap(),
        free.to_str().unwrap(),
        &["--log-every", "1"],
    ));
    let log = std::fs::read_to_string(&free).unwrap();
    assert!(log.lines().count() > 7000);
    decode_round_trip(d, "free", &log);

    // GNSS-aided after the navigator's alignment (the firmware's `--gnss` run): a simulated
    // land vehicle, the filter's 1-sigma and status columns.
    let sim = d.join("sim");
    run_ok(&[
        "sim",
        "land-vehicle",
        "--grade",
        "fog",
        "--seconds",
        "60",
        "--gnss-rate",
        "2",
        "--format",
        "bin",
        "--out",
        sim.to_str().unwrap(),
    ]);
    let aided = d.join("aided.csv");
    run_ok(&[
        "replay",
        "--imu",
        sim.join("imu.bin").to_str().unwrap(),
        "--gnss",
        sim.join("gnss.csv").to_str().unwrap(),
        "--imu-noise",
        "fog",
        "--lat",
        "45",
        "--lon",
        "7.5",
        "--h",
        "250",
        "--align-seconds",
        "10",
        "--log-every",
        "4",
        "--out",
        aided.to_str().unwrap(),
    ]);
    let log = std::fs::read_to_string(&aided).unwrap();
    assert!(log.lines().next().unwrap().ends_with(",status"));
    assert!(log.lines().count() > 1000);
    let report = decode_round_trip(d, "aided", &log);
    assert!(report.contains("nav-solution"), "{report}");
}

#[test]
fn cut_off_garbage_and_missing_streams() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let log = "t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,pitch_deg,yaw_deg\n\
               1.000000,45.000000000,7.500000000,150,0,0,0,0.5,-0.25,30\n\
               1.100000,45.000000001,7.500000000,150.000001,0.001,0,0,0.5,-0.25,30.000001\n\
               # end: 2 rows, ok\n";
    let (stream, _) = stream_of(log, false);
    let out = d.join("out.csv");
    let out_s = out.to_str().unwrap();

    // Whole: the same log.
    let full = d.join("full.bin");
    std::fs::write(&full, &stream).unwrap();
    run_ok(&["decode", full.to_str().unwrap(), "--out", out_s]);
    assert_eq!(std::fs::read_to_string(&out).unwrap(), log);

    // Cut before its end-of-run frame: the rows, no end record, and said so.
    let cut = d.join("cut.bin");
    std::fs::write(&cut, &stream[..stream.len() - 5]).unwrap();
    let report = run_ok(&["decode", cut.to_str().unwrap(), "--out", out_s]);
    assert!(
        report.contains("incomplete") && report.contains("cut off"),
        "{report}"
    );
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().count(), 3);
    assert!(!text.contains("# end"));

    // A flipped bit: one CRC failure reported, its row lost, no end record.
    let mut bad = stream.clone();
    let mid = bad.len() / 2;
    bad[mid] ^= 0x10;
    let flipped = d.join("flipped.bin");
    std::fs::write(&flipped, &bad).unwrap();
    let report = run_ok(&["decode", flipped.to_str().unwrap(), "--out", out_s]);
    assert!(
        report.contains("1 CRC failures") || report.contains("1 other refusals"),
        "{report}"
    );

    // Garbage only, or no file: an error, and the earlier output untouched.
    let before = std::fs::read_to_string(&out).unwrap();
    let junk = d.join("junk.bin");
    std::fs::write(
        &junk,
        (0..5000u32).map(|i| (i * 7 + 1) as u8).collect::<Vec<u8>>(),
    )
    .unwrap();
    let e = run_err(&["decode", junk.to_str().unwrap(), "--out", out_s]);
    assert!(e.contains("no valid frame"), "{e}");
    let e = run_err(&[
        "decode",
        d.join("none.bin").to_str().unwrap(),
        "--out",
        out_s,
    ]);
    assert!(e.contains("cannot open"), "{e}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), before);
}

/// An end-of-run frame followed by solution frames is named as such and the log left
/// incomplete; a repeated frame (its sequence number again) is counted out of order, not as
/// 65535 frames lost.
#[test]
fn early_end_of_run_and_repeated_frames_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out.csv");
    let out_s = out.to_str().unwrap();
    let end = Message::EndOfRun(EndOfRun { rows: 2 });
    let encode = |messages: &[&Message]| -> Vec<Vec<u8>> {
        let mut enc = Encoder::new();
        messages
            .iter()
            .map(|m| {
                let mut frame = Vec::new();
                enc.append(m, &mut frame).unwrap();
                frame
            })
            .collect()
    };

    // The end of run first, then the solutions.
    let early = d.join("early.bin");
    std::fs::write(&early, encode(&[&end, &free_row(0), &free_row(1)]).concat()).unwrap();
    let report = run_ok(&["decode", early.to_str().unwrap(), "--out", out_s]);
    assert!(
        report.contains("end-of-run frame (saying 2 rows) came before the end of the stream")
            && report.contains("2 solution frames follow it")
            && report.contains("incomplete"),
        "{report}"
    );
    assert!(!report.contains("no end-of-run frame"), "{report}");
    assert!(!std::fs::read_to_string(&out).unwrap().contains("# end"));

    // The end-of-run frame sent twice (the same sequence number): one frame out of order,
    // none lost, the log complete.
    let frames = encode(&[&free_row(0), &free_row(1), &end]);
    let repeated = d.join("repeated.bin");
    std::fs::write(&repeated, [frames.concat(), frames[2].clone()].concat()).unwrap();
    let report = run_ok(&["decode", repeated.to_str().unwrap(), "--out", out_s]);
    assert!(
        report.contains("0 frames lost") && report.contains("1 frames out of order"),
        "{report}"
    );
    assert!(report.contains("complete (2 rows)"), "{report}");

    // Two runs' streams one after the other (a capture across a restart): the second run's
    // rows go back in time and are refused; they still follow the first run's end, and the
    // summary says so (it said "2 rows, but the end-of-run frame says 2: incomplete").
    let run = encode(&[&free_row(0), &free_row(1), &end]).concat();
    let two = d.join("two-runs.bin");
    std::fs::write(&two, [run.clone(), run].concat()).unwrap();
    let report = run_ok(&["decode", two.to_str().unwrap(), "--out", out_s]);
    assert!(
        report.contains("end-of-run frame (saying 2 rows) came before the end of the stream")
            && report.contains("2 solution frames follow it"),
        "{report}"
    );
    let log = std::fs::read_to_string(&out).unwrap();
    assert_eq!(log.lines().count(), 3, "{log}");
    assert!(!log.contains("# end"), "{log}");
}

/// COBS decoding of one frame (its delimiter left off).
fn unstuffed(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let code = usize::from(bytes[i]);
        out.extend_from_slice(&bytes[i + 1..i + code]);
        i += code;
        if code < 0xff && i < bytes.len() {
            out.push(0);
        }
    }
    out
}

/// COBS encoding of the raw frame `raw`, with the zero delimiter.
fn stuffed(raw: &[u8]) -> Vec<u8> {
    let mut out = vec![0];
    let mut code_at = 0;
    for &b in raw {
        if b != 0 {
            out.push(b);
        }
        if b == 0 || out.len() - code_at == 0xff {
            out[code_at] = (out.len() - code_at) as u8;
            code_at = out.len();
            out.push(0);
        }
    }
    out[code_at] = (out.len() - code_at) as u8;
    out.push(0);
    out
}

/// The frame of `message` as a board of protocol version `version` sends it: the version
/// byte changed, the CRC recomputed over it.
fn frame_of_version(message: &Message, seq: u16, version: u8) -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut frame = Vec::new();
    for _ in 0..=seq {
        frame.clear();
        enc.append(message, &mut frame).unwrap();
    }
    let mut raw = unstuffed(&frame[..frame.len() - 1]);
    raw[0] = version;
    let end = raw.len() - 4;
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&raw[..end]);
    raw[end..].copy_from_slice(&crc.to_le_bytes());
    let out = stuffed(&raw);
    if version == hal_adapters::protocol::VERSION {
        assert_eq!(out, frame, "the test's COBS and CRC are not the encoder's");
    }
    out
}

/// A stream of valid frames of protocol version 4 was refused as "no valid frame in 39732
/// bytes (0 CRC failures): not a protocol stream?", and an IMU recording as CRC failures: the
/// other version's frames are counted and named (refused, never misread), among this
/// version's frames too, and a recording is named as one.
#[test]
fn frames_of_another_version_and_recordings_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out.csv");
    let out_s = out.to_str().unwrap();
    let end = Message::EndOfRun(EndOfRun { rows: 3 });
    let run = |version: u8| -> Vec<u8> {
        let messages = [free_row(0), free_row(1), free_row(2), end];
        let frames = messages.iter().enumerate();
        frames
            .flat_map(|(k, m)| frame_of_version(m, k as u16, version))
            .collect()
    };

    // Version 4 only: refused, the frames counted by version.
    let v4 = d.join("v4.bin");
    std::fs::write(&v4, run(4)).unwrap();
    let e = run_err(&["decode", v4.to_str().unwrap(), "--out", out_s]);
    assert!(
        e.contains("no frame of protocol version 5 in")
            && e.contains(": 4 frames of protocol version 4; this decoder reads version 5"),
        "{e}"
    );
    assert!(!out.exists());

    // A capture across a firmware update: this version's run decoded, the others named.
    let mixed = d.join("mixed.bin");
    std::fs::write(&mixed, [run(3), run(5), run(4)].concat()).unwrap();
    let report = run_ok(&["decode", mixed.to_str().unwrap(), "--out", out_s]);
    assert!(
        report.contains(
            "4 frames of protocol version 3, 4 frames of protocol version 4; this decoder reads \
             version 5"
        ),
        "{report}"
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap().lines().count(), 5);

    // An IMU recording.
    let recording = d.join("still.bin");
    common::generated_recording(&recording, "1");
    let e = run_err(&["decode", recording.to_str().unwrap(), "--out", out_s]);
    assert!(
        e.contains("an IMU recording (it starts with the NAVIMU magic"),
        "{e}"
    );
    let empty = d.join("empty.bin");
    std::fs::write(&empty, []).unwrap();
    let e = run_err(&["decode", empty.to_str().unwrap(), "--out", out_s]);
    assert!(e.contains("the stream is empty"), "{e}");
}

#[test]
fn config_files_encode_or_are_refused_with_line_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = "# the board on the roof\n\
                lat-deg = 45.5\n\
                lon-deg = 7.25\n\
                h-m = 250\n\
                imu-model = adis16505\n\
                imu-noise = fog\n\
                mounting = 1,0,0, 0,-1,0, 0,0,-1\n\
                align-method = fine\n\
                align-seconds = 300\n\
                aiding = on\n\
                gnss-lever-arm = 0.5, 0, -1\n\
                gnss-correlated = 2, 2, 4 # a code receiver\n\
                gnss-correlated-time = 90\n\
                log-every = 40\n\
                health-every = 400\n";
    let file = d.join("good.txt");
    std::fs::write(&file, good).unwrap();
    let bin = d.join("config.bin");
    run_ok(&[
        "config",
        file.to_str().unwrap(),
        "--out",
        bin.to_str().unwrap(),
    ]);
    // The frame decodes to the configuration the text says.
    let bytes = std::fs::read(&bin).unwrap();
    let mut decoder = Decoder::new();
    let mut got = Vec::new();
    decoder.push(&bytes, |r| got.push(r));
    let [Ok(r)] = got.as_slice() else {
        panic!("{got:?}")
    };
    let Message::Config(c) = r.message else {
        panic!("{:?}", r.message)
    };
    assert_eq!(
        (c.run.lat_deg, c.run.lon_deg, c.run.h_m),
        (45.5, 7.25, 250.0)
    );
    assert_eq!(c.mounting.c_s_b[2], [0.0, 0.0, -1.0]);
    assert_eq!(
        c.run.aiding.unwrap().antenna_lever_arm_b_m,
        [0.5, 0.0, -1.0]
    );
    // The GNSS correlated error, as `nav replay --gnss-correlated 2,2,4
    // --gnss-correlated-time 90` gives it.
    let a = c.run.aiding.unwrap();
    assert_eq!(
        (a.gnss_correlated_sigma_ned_m, a.gnss_correlated_time_s),
        (Some([2.0, 2.0, 4.0]), 90.0)
    );

    // The site, after the lines a case is about (their line numbers unchanged).
    let site = |text: &str| format!("{text}lat-deg = 45\nlon-deg = 7\nh-m = 150\n");
    for (name, text, want) in [
        (
            "syntax",
            "lat-deg = 45\nlon-deg = east\n".to_string(),
            "bad-syntax.txt:2: lon-deg: takes a finite number, got east",
        ),
        (
            "key",
            "lat-deg = 45\n\ncolour = red\n".to_string(),
            "bad-key.txt:3: unknown key 'colour'",
        ),
        (
            "lat",
            "lat-deg = 95\nlon-deg = 7\nh-m = 0\n".to_string(),
            "bad-lat.txt:1: refused (reason code 1): latitude 95",
        ),
        (
            "mount",
            site("mounting = 1,0,0,0,1,0,0,0,-1\n"),
            "bad-mount.txt:1: refused (reason code 10)",
        ),
        (
            "align",
            site("align-method = fine\nimu-model = bmi088\n"),
            "refused (reason code 8)",
        ),
        (
            "health",
            site("# quiet\nhealth-every = 0\n"),
            "bad-health.txt:2: refused (reason code 11)",
        ),
        // A refusal names its own key's line (a short window named the latitude's too).
        (
            "window",
            "align-seconds = 5\n# c\n\nlat-deg = 45\nlon-deg = 7\nh-m = 0\n".to_string(),
            "bad-window.txt:1: refused (reason code 8): alignment window 5 s",
        ),
        // A refusal about several keys names each one's line.
        (
            "coarse",
            site("imu-noise = mems-consumer\n"),
            "bad-coarse.txt:1,2: refused (reason code 8): gyros too coarse to find north: bias \
             1-sigma 1800.000 deg/h against a horizontal Earth rate of 10.636 deg/h (heading \
             1-sigma >= 9697 deg); give the heading or use better gyros (keys imu-noise (line 1), \
             lat-deg (line 2))",
        ),
        // No key at all (an empty or truncated file, comments only): the frame would carry the
        // compiled-in configuration as the host's, without the DEFAULT_CONFIG flag.
        (
            "empty",
            String::new(),
            "bad-empty.txt: no 'key = value' line",
        ),
        (
            "comments",
            "# the roof antenna board\n\n   \n# lat-deg = 45\n".to_string(),
            "bad-comments.txt: no 'key = value' line",
        ),
        // The same for the site: keys, but not the site's (the compiled-in one, 0, 0, 0).
        (
            "site",
            "log-every = 40\n".to_string(),
            "bad-site.txt: the site is not given (lat-deg, lon-deg, h-m missing)",
        ),
        (
            "height",
            "lat-deg = 45\nlon-deg = 7\n".to_string(),
            "bad-height.txt: the site is not given (h-m missing)",
        ),
        // Keys `nav replay` refuses together, named with both lines.
        (
            "levers",
            site("lever-arm = 1,0,0\nlever-arm-sigma = 2\n"),
            "bad-levers.txt:2: lever-arm-sigma: cannot be used with lever-arm (line 1)",
        ),
        // Named by the file's key, not by `nav replay`'s option or nav-core's field.
        (
            "log-every",
            site("log-every = -1\n"),
            "bad-log-every.txt:1: log-every: takes a whole number within 1 to 4294967295, got -1",
        ),
        // A comment after a value; a rate no IMU has.
        (
            "inline",
            "lat-deg = 95 # the site\nlon-deg = 7\nh-m = 0\n".to_string(),
            "bad-inline.txt:1: refused (reason code 1): latitude 95",
        ),
        (
            "rate",
            site("imu-rate-hz = 1e12\n"),
            "bad-rate.txt:1: refused (reason code 8): sampling rate 9.99999995904e11 Hz is not \
             within [10, 40000] Hz",
        ),
        // Below 10 Hz every increment is longer than the navigator takes: the board aligned on
        // none of them.
        (
            "slow",
            site("imu-rate-hz = 5\n"),
            "bad-slow.txt:1: refused (reason code 8): sampling rate 5 Hz is not within [10, 40000] Hz",
        ),
        // Noise densities of zero (an overconfident filter) or beyond any IMU's.
        (
            "arw0",
            site("log-every = 4\ngyro-arw-rad-per-sqrt-s = 0\n"),
            "bad-arw0.txt:2: refused (reason code 8): gyro-arw-rad-per-sqrt-s must be 1e-9 (less",
        ),
        (
            "vrw",
            site("accel-vrw-mps-per-sqrt-s = 1e9\n"),
            "bad-vrw.txt:1: refused (reason code 8): accel-vrw-mps-per-sqrt-s must be 1e-8 (less",
        ),
        (
            "bias",
            site("gyro-bias-rad-s = 1e9\n"),
            "bad-bias.txt:1: refused (reason code 8): gyro-bias-rad-s must be 0 or more",
        ),
        // A scale factor's 1-sigma of 0 (encoded as valid with aiding off before).
        (
            "scale0",
            site("gyro-scale-sigma = 0\n"),
            "bad-scale0.txt:1: refused (reason code 9): IMU error figures: a scale-factor 1-sigma \
             (gyro-scale-sigma, accel-scale-sigma) must be above 0",
        ),
        // An unknown lever arm of 1-sigma 0 (accepted before): a known zero lever arm.
        (
            "lever-sigma0",
            site("lever-arm-sigma = 0\n"),
            "bad-lever-sigma0.txt:1: refused (reason code 8): an unknown lever arm's 1-sigma of 0 m \
             is a known lever arm of 0 m by another name: give it as known (lever-arm = 0,0,0)",
        ),
        // Too high a rate: the high limit's reason (it gave the low limit's).
        (
            "fast",
            site("imu-rate-hz = 1e9\n"),
            "Hz (no IMU samples faster than 40 kHz",
        ),
        // The GNSS correlated error beyond the filter's range, named by its line.
        (
            "correlated",
            site("aiding = on\ngnss-correlated = 1, 1, 500\n"),
            "bad-correlated.txt:1,2: refused (reason code 9): GNSS aiding: the GNSS correlated-error 1-sigma must be 0 to 100 m per axis",
        ),
    ] {
        let f = d.join(format!("bad-{name}.txt"));
        std::fs::write(&f, text).unwrap();
        let out = d.join(format!("bad-{name}.bin"));
        let e = run_err(&[
            "config",
            f.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(e.contains(want), "{name}: {e}");
        assert!(
            !out.exists(),
            "{name}: a refused configuration wrote its output"
        );
    }
}
