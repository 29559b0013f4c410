//! End-to-end: the firmware in QEMU and the host harness replay the same recording and must write
//! the same solution log.
//!
//! Needs `qemu-system-arm`, `defmt-print` and the `thumbv7em-none-eabihf` target (`cargo xtask
//! setup` installs them). `cargo xtask test` builds the firmware first and passes its path in
//! `FIRMWARE_ELF`; without it this test builds the firmware into `target/e2e` (a separate target
//! directory, because the running `cargo test` holds the lock on the main one).

use hal_adapters::protocol::config::{DeviceConfig, ReasonCode};
use hal_adapters::protocol::messages::{AidOutcome, ConfigAck, HealthReport};
use hal_adapters::protocol::status::{NavStatus, StatusFlags};
use hal_adapters::protocol::{Decoder, Encoder, MAX_FRAME, Message};
use host_tests::recording_io::{self, Recording};
use host_tests::sensor_model::Grade;
use host_tests::simulate::{SimOptions, simulate};
use host_tests::trajectory::scenarios::{Scenario, Static};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const THUMB: &str = "thumbv7em-none-eabihf";

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn firmware_elf() -> PathBuf {
    if let Some(p) = std::env::var_os("FIRMWARE_ELF") {
        return PathBuf::from(p);
    }
    let root = workspace_root();
    let target_dir = root.join("target/e2e");
    let status = Command::new(env!("CARGO"))
        .args(["build", "--release", "-p", "firmware", "--target", THUMB])
        .arg("--target-dir")
        .arg(&target_dir)
        .current_dir(&root)
        .status()
        .expect("run cargo build for the firmware");
    assert!(status.success(), "firmware build failed");
    target_dir.join(THUMB).join("release/firmware")
}

fn require(tool: &str) {
    let ok = Command::new(tool)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        ok,
        "{tool} is not installed: run `cargo xtask setup` (the README's test command does)"
    );
}

/// Runs the firmware in QEMU on `args` (from `dir`); returns (exit code, decoded defmt log).
fn run_firmware(dir: &Path, args: &[&str]) -> (i32, String) {
    run_firmware_at(dir, args, 0)
}

/// Runs the qemu board's diagnostic binary `name` (`crash`, `osc_bench`: built beside the
/// firmware, `firmware/src/bin/`) in QEMU on `args` (from `dir`); returns (exit code, decoded
/// defmt log).
fn run_diagnostic(dir: &Path, name: &str, args: &[&str]) -> (i32, String) {
    run_elf_at(&firmware_elf().with_file_name(name), dir, args, 0)
}

/// [`run_firmware`] with each guest instruction taking `2^shift` ns of virtual time
/// (`QEMU_ICOUNT_SHIFT`: 3 is a 125 MIPS core, slower than the real 168 MHz part with its flash
/// wait states; the timers keep virtual time, so a firmware that keeps up there keeps up on the
/// board).
fn run_firmware_at(dir: &Path, args: &[&str], shift: u32) -> (i32, String) {
    run_elf_at(&firmware_elf(), dir, args, shift)
}

/// [`run_firmware_at`] for the ELF `elf`.
fn run_elf_at(elf: &Path, dir: &Path, args: &[&str], shift: u32) -> (i32, String) {
    require("qemu-system-arm");
    require("defmt-print");
    let script = workspace_root().join("firmware/qemu-run.sh");
    let out: Output = Command::new("bash")
        .env("QEMU_ICOUNT_SHIFT", shift.to_string())
        .arg(script)
        .arg(elf)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run qemu-run.sh");
    let log = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.code().unwrap_or(-1), log)
}

fn nav(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nav"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run nav")
}

/// `nav decode STREAM --out CSV` in `dir`; its report.
fn decode_stream(dir: &Path, stream: &str, csv: &str) -> String {
    let o = nav(dir, &["decode", stream, "--out", csv]);
    let report = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "nav decode {stream}: {report}");
    report
}

/// Every frame of the stream file `path`, through the protocol's decoder: none refused, none
/// cut off.
fn stream_messages(path: &Path) -> Vec<Message> {
    let bytes = std::fs::read(path).unwrap();
    let mut decoder = Decoder::new();
    let mut messages = Vec::new();
    decoder.push(&bytes, |r| {
        messages.push(r.expect("a frame refused").message)
    });
    assert_eq!(decoder.finish(), 0, "the stream's last frame is cut off");
    assert_eq!(decoder.stats().frames_lost, 0, "frames missing");
    messages
}

/// The health frames of a stream.
fn health_frames(messages: &[Message]) -> Vec<HealthReport> {
    messages
        .iter()
        .filter_map(|m| match m {
            Message::Health(h) => Some(*h),
            _ => None,
        })
        .collect()
}

/// The configuration acknowledgements in a stream.
fn config_acks(messages: &[Message]) -> Vec<ConfigAck> {
    messages
        .iter()
        .filter_map(|m| match m {
            Message::ConfigAck(a) => Some(*a),
            _ => None,
        })
        .collect()
}

/// Frames of the message `id` in a stream.
fn count_of(messages: &[Message], id: hal_adapters::protocol::MessageId) -> usize {
    messages.iter().filter(|m| m.id() == id).count()
}

/// The number after `key` in the defmt log's summary (from its `summary:` line on), e.g.
/// `missed 0`.
fn field(log: &str, key: &str) -> u64 {
    let log = log.find("summary:").map_or(log, |at| &log[at..]);
    let at = log
        .find(key)
        .unwrap_or_else(|| panic!("'{key}' not in the firmware log:\n{log}"));
    let rest = &log[at + key.len()..];
    let digits: String = rest
        .trim_start()
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    digits
        .parse()
        .unwrap_or_else(|_| panic!("no number after '{key}' in:\n{log}"))
}

/// The IMU driver's counts in a log: the text after `IMU driver: ` to the end of its line (the
/// firmware's defmt line, or the host's summary line; the same `Health` display on both).
fn driver_counts<'a>(log: &'a str, who: &str) -> &'a str {
    log.lines()
        .find_map(|l| {
            l.split_once("IMU driver: ")
                .map(|(_, counts)| counts.trim_end())
        })
        .unwrap_or_else(|| panic!("no 'IMU driver:' line from the {who}:\n{log}"))
}

/// `seconds` of the simulator's `static` scenario (45 deg N, 7.5 deg E, 150 m, attitude (1.5,
/// -2, 30) deg) sensed by `grade` (seed 3), with its truth.
fn static_sim(seconds: f64, grade: Grade) -> host_tests::simulate::Simulated {
    let mut opts = SimOptions::new(Scenario::by_name("static").unwrap(), grade);
    opts.seconds = Some(seconds);
    opts.seed = 3;
    simulate(&opts, |_, _| {}).unwrap()
}

/// The `static` scenario's site as command-line arguments: latitude, longitude [deg], height
/// [m].
fn static_site() -> (String, String, String) {
    let s = Static::default();
    (
        s.lat_deg.to_string(),
        s.lon_deg.to_string(),
        s.h_m.to_string(),
    )
}

fn static_recording(seconds: f64, grade: Grade) -> Recording {
    static_sim(seconds, grade).recording
}

/// The calibration of [`recording_with_bad_samples`]'s injected sensor errors: biases well
/// above the FOG grade's own (1 deg/h and 3-5 mg against 0.2 deg/h and 0.5 mg), scale factors
/// and misalignments.
const CALIBRATION: &str = "# the injected errors\n\
     gyro_bias_rad_s = 5e-6 4e-6 3e-6\n\
     gyro_scale = 1e-4 -2e-4 0\n\
     accel_bias_m_s2 = 0.05, -0.04, 0.03\n\
     accel_misalignment = 1e-4 0 0 -1e-4 0 2e-4\n";

/// 20 s of the `static` scenario with FOG-grade sensor errors and the errors of
/// [`CALIBRATION`] on top (`measured = (I + S + N) sensed + bias dt`), plus two bad samples in
/// the navigation phase: a NaN gyro value (sample 5000) and a repeated timestamp (sample
/// 6000). Returns the true body-to-NED attitude.
fn recording_with_bad_samples(path: &Path) -> nav_core::UnitQuaternion<f64> {
    let sim = static_sim(20.0, Grade::Fog);
    let mut rec = sim.recording;
    let comp = nav_core::ImuCalibration::parse(CALIBRATION)
        .unwrap()
        .compensation::<f64>()
        .unwrap();
    let dt = 1.0 / rec.rate_hz;
    let inject = |v: &mut [f32; 3], t: &nav_core::calibration::TriadCompensation<f64>| {
        let sensed = nav_core::Vector3::from(v.map(f64::from));
        let m = t.k.try_inverse().unwrap() * sensed + t.bias * dt;
        *v = [m.x, m.y, m.z].map(|x| x as f32);
    };
    for r in &mut rec.records {
        inject(&mut r.gyro, &comp.gyro);
        inject(&mut r.accel, &comp.accel);
    }
    rec.records[5000].gyro[1] = f32::NAN;
    rec.records[6000].t_ns = rec.records[5999].t_ns;
    recording_io::write(path, &rec).unwrap();
    sim.truth[0].q_b_ned
}

/// Tilt and heading errors [deg] of a log's aligned row (its first) against `truth`.
fn alignment_errors(log: &str, truth: &nav_core::UnitQuaternion<f64>) -> (f64, f64) {
    let row: Vec<f64> = log
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    let (roll, pitch, yaw) = nav_core::attitude::euler(truth);
    let wrap = |d: f64| (d + 540.0).rem_euclid(360.0) - 180.0;
    let tilt = wrap(row[7] - roll.to_degrees())
        .abs()
        .max(wrap(row[8] - pitch.to_degrees()).abs());
    (tilt, wrap(row[9] - yaw.to_degrees()).abs())
}

#[test]
fn firmware_in_qemu_matches_host_replay() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = recording_with_bad_samples(&d.join("rec.bin"));
    let (lat, lon, h) = static_site();

    // The recording's true calibration: both sides must load it and apply it identically,
    // to the alignment as to the navigation.
    std::fs::write(d.join("imu.cal"), CALIBRATION).unwrap();

    // What the host sends before the run: a configuration from `nav config` (the command
    // line's run, which it replaces; alignment progress every 80 samples instead of 40), then
    // one with an impossible latitude.
    std::fs::write(
        d.join("config.txt"),
        format!(
            "lat-deg = {lat}\nlon-deg = {lon}\nh-m = {h}\nalign-seconds = 10\nalign-progress-every = 80\n"
        ),
    )
    .unwrap();
    let o = nav(d, &["config", "config.txt", "--out", "config.bin"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut frames = std::fs::read(d.join("config.bin")).unwrap();
    let mut bad = DeviceConfig::default();
    bad.run.lat_deg = 95.0;
    let mut encoder = Encoder::new();
    encoder
        .encode(&Message::Config(bad), &mut [0; MAX_FRAME])
        .unwrap(); // sequence number 1
    encoder.append(&Message::Config(bad), &mut frames).unwrap();
    std::fs::write(d.join("config.bin"), &frames).unwrap();

    let started = std::time::Instant::now();
    let (code, log) = run_firmware(
        d,
        &[
            "--stream",
            "fw.bin",
            "--config-frame",
            "config.bin",
            "rec.bin",
            "fw.csv",
            &lat,
            &lon,
            &h,
            "10",
            "40",
            "imu.cal",
        ],
    );
    println!("{log}\nQEMU run: {:.2} s", started.elapsed().as_secs_f64());
    assert_eq!(code, 0, "firmware exit code {code}; log:\n{log}");
    assert!(log.contains("calibration loaded"), "{log}");
    assert!(
        log.contains("IMU: Adis16505 over a simulated SPI device"),
        "{log}"
    );
    assert_eq!(field(&log, "missed"), 0, "missed data-ready interrupts");
    assert_eq!(field(&log, "channel overruns"), 0, "channel overruns");
    // The NaN record reaches the driver as a frame with a bad checksum: rejected and counted,
    // and the next sample shows the gap; the sample stream delivers the record flagged
    // non-finite. The repeated timestamp is a repeated DATA_CNTR: stale.
    assert_eq!(field(&log, "summary: samples"), 8000);
    assert_eq!(field(&log, "flagged"), 2, "the NaN and the stale sample");
    assert!(log.contains("flagged 2 (non-finite 1, stale 1)"), "{log}");
    // Each flagged sample's warning names its cause as the summary does (was the flags' bits,
    // `SampleFlags(0x0010)`).
    assert!(
        log.contains(" flagged non-finite: not navigated (1 so far)"),
        "{log}"
    );
    assert!(
        log.contains(" flagged stale: not navigated (2 so far)"),
        "{log}"
    );
    assert_eq!(field(&log, "checksum errors"), 1, "the NaN record's frame");
    assert_eq!(field(&log, "bus errors"), 0);
    // Data-ready k (from 1) fires at k * 2.5 ms of SysTick time: exactly 400 Hz under icount.
    assert_eq!(
        field(&log, "last data-ready at"),
        8000 * 2500,
        "data-ready pacing [us]"
    );
    let max = field(&log, "instructions per navigation step: max");
    println!("max guest instructions per navigation step: {max}");

    let site = ["--lat", &lat, "--lon", &lon, "--h", &h];
    let replay = |out: &str, calibration: Option<&str>| {
        let mut args = vec![
            "replay",
            "--imu",
            "rec.bin",
            "--align-seconds",
            "10",
            "--out",
            out,
            "--log-every",
            "40",
            "--device",
            "adis16505",
        ];
        args.extend_from_slice(&site);
        if let Some(c) = calibration {
            args.extend_from_slice(&["--calibration", c]);
        }
        let o = nav(d, &args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let host_stdout = replay("host.csv", Some("imu.cal"));
    replay("uncalibrated.csv", None);
    // The driver's own counts, the same on both sides: 7999 frames decoded, the NaN record's
    // rejected (its sample delivered flagged), the repeated DATA_CNTR stale; the frames after
    // the NaN record and after the repeated time each span two periods (one missed output
    // sample each); the end of the recording is not a bus error.
    let fw_counts = driver_counts(&log, "firmware");
    assert_eq!(
        driver_counts(&host_stdout, "host"),
        fw_counts,
        "driver counts of the host and the firmware"
    );
    assert!(
        fw_counts.starts_with(
            "samples 7999, checksum errors 1, stale 1, device missed 2, bus errors 0, faults 0, \
             FIFO overflows 0, invalid 0,"
        ),
        "{fw_counts}"
    );

    let fw = std::fs::read_to_string(d.join("fw.csv")).unwrap();
    let host = std::fs::read_to_string(d.join("host.csv")).unwrap();
    // Header, the aligned state at 10 s, then 3998 navigation steps logged every 40 (99 rows)
    // and the final one, and the end record.
    assert_eq!(host.lines().count(), 1 + 1 + 99 + 1 + 1, "host log rows");
    assert_eq!(host.lines().last(), Some("# end: 101 rows, ok"));
    // Both sides run the same f32 code with libm's functions and IEEE single arithmetic (Rust
    // does not contract to FMA), so the logs are expected to be identical text.
    assert_same_lines(&fw, &host);
    // The protocol stream: `nav decode` gives the firmware's log back, equal to the harness's.
    let report = decode_stream(d, "fw.bin", "decoded.csv");
    println!("nav decode: {report}");
    let decoded = std::fs::read_to_string(d.join("decoded.csv")).unwrap();
    assert!(
        decoded == host,
        "the decoded stream differs from the host's log\n{report}"
    );
    assert!(
        decoded == fw,
        "the decoded stream differs from the firmware's log"
    );
    let messages = stream_messages(&d.join("fw.bin"));
    use hal_adapters::protocol::MessageId as Id;
    let samples = field(&log, "summary: samples");
    assert_eq!(count_of(&messages, Id::RawIncrements) as u64, samples);
    // A health frame every 400 samples from the first, and the final one.
    let health = health_frames(&messages);
    assert_eq!(health.len() as u64, samples.div_ceil(400) + 1);
    // The final health frame's counters are the run's: the driver's (as the summary gives
    // them: 7999 frames, the NaN record's checksum error, 2 device samples missed) and the
    // board's (no missed data-ready, no overrun).
    let last = health.last().unwrap();
    assert_eq!(last.counters.samples, 7999);
    assert_eq!(last.counters.checksum_errors, 1);
    assert_eq!(last.counters.bus_errors, 0);
    assert_eq!(
        u64::from(last.counters.missed_data_ready),
        2 + field(&log, "missed")
    );
    assert_eq!(
        u64::from(last.counters.channel_overruns),
        field(&log, "channel overruns")
    );
    assert_eq!(last.t_us, 8000 * 2500);
    assert_eq!(last.status, NavStatus::Nav);
    assert!(last.flags.contains(StatusFlags::FREE_INERTIAL), "{last:?}");
    // Aligning from COARSE, then NAV from the aligned row on.
    assert_eq!(health[0].status, NavStatus::AlignCoarse);
    assert!(log.contains("status NAV"), "{log}");
    // The configuration frames: the good one accepted (its progress rate applied: some 4000
    // alignment samples every 80, not 40), the bad one refused for its latitude.
    assert_eq!(
        config_acks(&messages),
        [
            ConfigAck {
                config_seq: 0,
                refused: None
            },
            ConfigAck {
                config_seq: 1,
                refused: Some(ReasonCode::Latitude)
            }
        ]
    );
    let progress = count_of(&messages, Id::AlignProgress);
    assert!((49..=51).contains(&progress), "{progress} progress frames");
    let bytes = std::fs::metadata(d.join("fw.bin")).unwrap().len();
    println!(
        "stream: {} frames, {bytes} bytes over {} s of data: {:.0} bytes/s",
        messages.len(),
        samples / 400,
        bytes as f64 / (samples as f64 / 400.0)
    );

    // The calibration reaches the alignment: without it the biases tilt the levelling
    // (b_a / g ~ 0.3 deg) and turn the gyrocompass (east gyro bias over the horizontal Earth
    // rate ~ 6 deg); with it what is left is the FOG grade's own errors.
    let uncalibrated = std::fs::read_to_string(d.join("uncalibrated.csv")).unwrap();
    let (tilt, heading) = alignment_errors(&fw, &truth);
    let (tilt_raw, heading_raw) = alignment_errors(&uncalibrated, &truth);
    println!(
        "alignment errors with the calibration: tilt {tilt:.4} deg, heading {heading:.3} deg; without: {tilt_raw:.4} deg, {heading_raw:.3} deg"
    );
    assert!(tilt < tilt_raw / 2.0 && heading < heading_raw / 2.0);
}

/// The run's configuration from the host (`docs/protocol.md`, standby): with `--config-frame`
/// the frame's run configuration replaces the command line's. A frame with the recording's
/// site, a 12 s window, a known lever arm and a row every 20 steps, sent to a firmware whose
/// command line names another site (1 deg off), a 10 s window, no lever arm and a row every
/// 40, gives the same solution log as the command line with the frame's values; only the
/// latter run is flagged DEFAULT_CONFIG (no frame in the standby window). The frames after the
/// accepted one arrive with the run decided: the same run with other output rates is accepted
/// (raw increments every 2nd sample from then on), another site is refused as a run in
/// progress, an impossible latitude for its latitude, another mounting as a run in progress;
/// the acknowledgements say so. The frame's mounting is the installation's: the simulated IMU
/// is installed turned, and the log is still the command line's of an IMU on the body axes.
#[test]
fn firmware_takes_its_run_configuration_from_the_host() {
    // The IMU installed turned 90 deg about down (`--imu-mounting`: the board's driver does not
    // know it); the frame's mounting says so, and the run is the command line's untouched one.
    const TURNED: &str = "0,1,0,-1,0,0,0,0,1";
    use hal_adapters::protocol::MessageId as Id;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    recording_io::write(&d.join("rec.bin"), &static_recording(13.0, Grade::Fog)).unwrap();
    let (lat, lon, h) = static_site();
    let text = format!(
        "lat-deg = {lat}\nlon-deg = {lon}\nh-m = {h}\nalign-seconds = 12\nlever-arm = 0.5, -0.2, 0.1\nlog-every = 20\nmounting = {TURNED}\n"
    );
    std::fs::write(d.join("run.txt"), &text).unwrap();
    let o = nav(d, &["config", "run.txt", "--out", "frames.bin"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut frames = std::fs::read(d.join("frames.bin")).unwrap();
    let mut config = DeviceConfig::default();
    for line in text.lines() {
        config.apply_line(line).unwrap();
    }
    let mut rates = config;
    rates.rates.raw_every = 2;
    let mut other_site = config;
    other_site.run.lat_deg += 1.0;
    let mut bad = config;
    bad.run.lat_deg = 95.0;
    let mut other_mounting = config;
    other_mounting.mounting = hal_adapters::drivers::Mounting::IDENTITY;
    let mut encoder = Encoder::new();
    encoder
        .encode(&Message::Config(config), &mut [0; MAX_FRAME])
        .unwrap(); // sequence number 0: the frame of `nav config`
    for c in [rates, other_site, bad, other_mounting] {
        encoder.append(&Message::Config(c), &mut frames).unwrap();
    }
    std::fs::write(d.join("frames.bin"), &frames).unwrap();

    let s = Static::default();
    let (lat_off, lon_off) = ((s.lat_deg - 1.0).to_string(), (s.lon_deg + 1.0).to_string());
    let (code, log) = run_firmware(
        d,
        &[
            "--stream",
            "framed.bin",
            "--config-frame",
            "frames.bin",
            "--imu-mounting",
            TURNED,
            "rec.bin",
            "framed.csv",
            &lat_off,
            &lon_off,
            &h,
            "10",
        ],
    );
    assert_eq!(code, 0, "run with the frame: exit code {code}; log:\n{log}");
    for expect in [
        "configuration frame 0 accepted: the run's configuration and output rates",
        "run configuration: the host's configuration frame (0 samples in standby, not navigated)",
        "lever arm known: 0.5 -0.2 0.1 m",
        "configuration frame 1 accepted: output rates applied (the run's configuration unchanged)",
        "configuration frame 2 refused (reason 13)",
        "configuration frame 3 refused (reason 1)",
        "mounting: the host's",
        "configuration frame 4 refused (reason 13)",
    ] {
        assert!(log.contains(expect), "no '{expect}' in:\n{log}");
    }
    let (code, cli_log) = run_firmware(
        d,
        &[
            "--stream",
            "cli.bin",
            "--lever-arm",
            "0.5,-0.2,0.1",
            "rec.bin",
            "cli.csv",
            &lat,
            &lon,
            &h,
            "12",
            "20",
        ],
    );
    assert_eq!(
        code, 0,
        "run on the command line: exit code {code}; log:\n{cli_log}"
    );
    assert!(
        cli_log.contains("no configuration frame in the 0 ms standby window"),
        "{cli_log}"
    );
    let framed = std::fs::read_to_string(d.join("framed.csv")).unwrap();
    let cli = std::fs::read_to_string(d.join("cli.csv")).unwrap();
    // The aligned row at 12 s, 399 steps logged every 20 (19 rows) and the last one.
    assert_eq!(cli.lines().last(), Some("# end: 21 rows, ok"));
    assert!(
        framed == cli,
        "the frame's run differs from the command line's"
    );

    let framed_messages = stream_messages(&d.join("framed.bin"));
    let acks = config_acks(&framed_messages);
    let ack = |config_seq, refused| ConfigAck {
        config_seq,
        refused,
    };
    assert_eq!(
        acks,
        [
            ack(0, None),
            ack(1, None),
            ack(2, Some(ReasonCode::RunInProgress)),
            ack(3, Some(ReasonCode::Latitude)),
            ack(4, Some(ReasonCode::RunInProgress)),
        ]
    );
    let samples = field(&log, "summary: samples");
    assert_eq!(
        count_of(&framed_messages, Id::RawIncrements) as u64,
        samples.div_ceil(2),
        "raw increments at the accepted frame's rate"
    );
    let cli_health = health_frames(&stream_messages(&d.join("cli.bin")));
    let framed_health = health_frames(&framed_messages);
    assert!(!cli_health.is_empty() && !framed_health.is_empty());
    assert!(
        cli_health
            .iter()
            .all(|f| f.flags.contains(StatusFlags::DEFAULT_CONFIG)),
        "{cli_health:?}"
    );
    assert!(
        framed_health
            .iter()
            .all(|f| !f.flags.contains(StatusFlags::DEFAULT_CONFIG)
                && f.status != NavStatus::Standby),
        "{framed_health:?}"
    );
}

/// A `--config-frame FILE` that gives no accepted frame (a byte flipped: CRC; empty; a frame
/// the board refuses: latitude 95 deg) ran the compiled-in configuration at the command line's
/// site with exit 0. The user named the file: the run is refused (exit 3), with the reason, and
/// leaves no complete log. So is a `--base-translation` the static alignment would ignore.
#[test]
fn a_configuration_frame_file_that_gives_no_frame_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    recording_io::write(&d.join("rec.bin"), &static_recording(11.0, Grade::Fog)).unwrap();
    let (lat, lon, h) = static_site();
    let text = format!("lat-deg = {lat}\nlon-deg = {lon}\nh-m = {h}\nalign-seconds = 10\n");
    std::fs::write(d.join("run.txt"), &text).unwrap();
    let o = nav(d, &["config", "run.txt", "--out", "good.bin"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let good = std::fs::read(d.join("good.bin")).unwrap();
    let mut flipped = good.clone();
    flipped[good.len() / 2] ^= 0x10;
    let mut config = DeviceConfig::default();
    for line in text.lines() {
        config.apply_line(line).unwrap();
    }
    config.run.lat_deg = 95.0;
    // The firmware on the recording at the site, with `options` before the positionals.
    let run = |options: &[&str]| {
        let mut args = options.to_vec();
        args.extend_from_slice(&["rec.bin", "out.csv", &lat, &lon, &h, "10"]);
        run_firmware(d, &args)
    };
    let mut refused = Vec::new();
    Encoder::new()
        .append(&Message::Config(config), &mut refused)
        .unwrap();
    for (name, bytes, said) in [
        ("flipped.bin", flipped, "frame refused"),
        ("empty.bin", Vec::new(), ""),
        (
            "refused.bin",
            refused,
            "configuration frame 0 refused (reason 1)",
        ),
    ] {
        std::fs::write(d.join(name), &bytes).unwrap();
        let (code, log) = run(&["--config-frame", name]);
        assert_eq!(code, 3, "{name}: exit code {code}; log:\n{log}");
        for expect in [
            said,
            "--config-frame: the file gave no accepted configuration frame",
        ] {
            assert!(log.contains(expect), "{name}: no '{expect}' in:\n{log}");
        }
        let out = std::fs::read_to_string(d.join("out.csv")).unwrap_or_default();
        assert!(!out.contains("# end"), "{name}: {out}");
    }
    // `--base-translation` with the static alignment: ignored before, refused as `nav replay`
    // refuses it.
    let (code, log) = run(&["--base-translation", "0.5"]);
    assert_eq!(code, 3, "log:\n{log}");
    assert!(
        log.contains("--base-translation: the base translation is the base motion of the inertial, fine and sway alignments"),
        "{log}"
    );
    // The good frame runs.
    let (code, log) = run(&["--config-frame", "good.bin"]);
    assert_eq!(code, 0, "good frame: log:\n{log}");
}

/// Recordings that navigate nothing: every sample NaN (the alignment never gets one), NaN after
/// the alignment, and frozen time after the alignment (the simulated ADIS16505 repeats its
/// DATA_CNTR: stale). The firmware and `nav replay --device adis16505` fail alike, with the same
/// message counting the samples by cause and the same driver counts; the firmware's log has no
/// end record, and the host leaves no log.
#[test]
fn firmware_and_host_fail_alike_when_nothing_is_navigated() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 11 s at 400 Hz: a 10 s alignment (4000 samples) and 400 more.
    let clean = static_recording(11.0, Grade::Ideal);
    let n = clean.records.len();
    assert_eq!(n, 4400);
    let with = |from: usize, spoil: &dyn Fn(&mut hal_adapters::recording::Record, u64)| {
        let mut rec = clean.clone();
        let t_frozen = rec.records[from.max(1) - 1].t_ns;
        for r in &mut rec.records[from..] {
            spoil(r, t_frozen);
        }
        rec
    };
    let nan = |r: &mut hal_adapters::recording::Record, _| r.gyro[2] = f32::NAN;
    let frozen = |r: &mut hal_adapters::recording::Record, t: u64| r.t_ns = t;
    // (file, recording, firmware exit code, message, the driver's counts): a NaN record is a
    // frame the driver rejects (checksum), a frozen time a repeated DATA_CNTR (stale).
    let cases = [
        (
            "all-nan.bin",
            with(0, &nan),
            5,
            "recording ended during alignment: 0 of 4000 samples used (4400 flagged: non-finite 4400)",
            "samples 0, checksum errors 4400, stale 0, device missed 0, bus errors 0,",
        ),
        (
            "nav-nan.bin",
            with(4000, &nan),
            7,
            "no navigation step after the alignment: 4400 samples, 4000 used by the alignment (400 flagged: non-finite 400)",
            "samples 4000, checksum errors 400, stale 0, device missed 0, bus errors 0,",
        ),
        (
            "nav-frozen.bin",
            with(4000, &frozen),
            7,
            "no navigation step after the alignment: 4400 samples, 4000 used by the alignment (400 flagged: stale 400)",
            "samples 4400, checksum errors 0, stale 400, device missed 0, bus errors 0,",
        ),
    ];
    let (lat, lon, h) = static_site();
    for (file, rec, fw_code, expect, driver_expect) in cases {
        recording_io::write(&d.join(file), &rec).unwrap();
        let (code, log) = run_firmware(d, &[file, "fw.csv", &lat, &lon, &h, "10"]);
        assert_eq!(code, fw_code, "{file}: firmware exit code; log:\n{log}");
        let fw_msg = log
            .lines()
            .find_map(|l| l.split_once("ERROR ").map(|(_, m)| m.trim()))
            .unwrap_or_else(|| panic!("{file}: no error in the firmware log:\n{log}"));
        assert_eq!(fw_msg, expect, "{file}: firmware");
        let fw_log = std::fs::read_to_string(d.join("fw.csv")).unwrap();
        assert!(
            fw_log.starts_with(nav_core::output::CSV_HEADER) && !fw_log.contains("# end:"),
            "{file}: the firmware's log of a failed run must not look complete:\n{fw_log}"
        );

        let out = nav(
            d,
            &[
                "replay",
                "--imu",
                file,
                "--out",
                "host.csv",
                "--lat",
                &lat,
                "--lon",
                &lon,
                "--h",
                &h,
                "--align-seconds",
                "10",
                "--device",
                "adis16505",
                "--precision",
                "f32",
            ],
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{file}: host: {stderr}");
        // The driver's counts of the failed run, as the firmware logs them.
        let host_stdout = String::from_utf8_lossy(&out.stdout);
        let fw_counts = driver_counts(&log, "firmware");
        assert_eq!(
            driver_counts(&host_stdout, "host"),
            fw_counts,
            "{file}: driver counts of the host and the firmware"
        );
        assert!(fw_counts.contains(driver_expect), "{file}: {fw_counts}");
        let prefix = format!("recording {file}: ");
        let host_msg = stderr
            .lines()
            .find_map(|l| l.split_once(&prefix).map(|(_, m)| m.trim()))
            .unwrap_or_else(|| panic!("{file}: no message in:\n{stderr}"));
        assert_eq!(host_msg, fw_msg, "{file}: host and firmware differ");
        assert!(!d.join("host.csv").exists(), "{file}: the host left a log");
    }
}

/// An output that is an input however its path is written is refused (exit 3) and the input
/// left untouched: `rec.bin ./rec.bin` truncated the recording (the paths were compared as
/// bytes), and OUT_FILE over the calibration or the configuration frame was not checked at all
/// (the frame, truncated before it was read, left the compiled-in configuration running); by
/// an absolute path, the calibration was replaced by the solution log with exit 0 (an output
/// that holds the same bytes as the calibration or the frame is refused now).
#[test]
fn an_output_over_an_input_is_refused_however_its_path_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("sub")).unwrap();
    let bytes = static_recording(2.0, Grade::Ideal).to_bytes().unwrap();
    std::fs::write(d.join("rec.bin"), &bytes).unwrap();
    std::fs::write(d.join("cal.txt"), CALIBRATION).unwrap();
    let mut fixes = hal_adapters::gnss_record::MAGIC.to_vec();
    fixes.extend_from_slice(b"the rest of a fix file");
    std::fs::write(d.join("fixes.bin"), &fixes).unwrap();
    let frame = b"not read: refused before".to_vec();
    std::fs::write(d.join("frame.bin"), &frame).unwrap();
    let abs = |name: &str| d.join(name).to_str().unwrap().to_owned();
    let (abs_rec, abs_fixes) = (abs("rec.bin"), abs("fixes.bin"));
    let (abs_cal, abs_frame) = (abs("cal.txt"), abs("frame.bin"));
    let site = ["45", "7.5", "150", "10"];
    for (options, out, rest, expect) in [
        (&[][..], "./rec.bin", &[][..], "OUT_FILE is IMU_FILE"),
        (&[], "sub/../rec.bin", &[], "OUT_FILE is IMU_FILE"),
        (&[], ".//rec.bin", &[], "OUT_FILE is IMU_FILE"),
        (&[], abs_rec.as_str(), &[], "holds an IMU recording"),
        (&[], abs_fixes.as_str(), &[], "holds a GNSS fix file"),
        (&[], "./cal.txt", &["40", "cal.txt"], "OUT_FILE is CAL_FILE"),
        // Reached by an absolute path, the calibration was replaced by the log (exit 0).
        (
            &[],
            abs_cal.as_str(),
            &["40", "cal.txt"],
            "holds the same bytes as CAL_FILE",
        ),
        (
            &["--config-frame", "frame.bin"],
            abs_frame.as_str(),
            &[],
            "holds the same bytes as the --config-frame FILE",
        ),
        (
            &["--stream", abs_cal.as_str()],
            "out.csv",
            &["40", "cal.txt"],
            "--stream FILE",
        ),
        (
            &["--config-frame", "frame.bin"],
            "sub/../frame.bin",
            &[],
            "OUT_FILE is the --config-frame FILE",
        ),
        (
            &["--stream", "./rec.bin"],
            "out.csv",
            &[],
            "--stream FILE is an input",
        ),
        (
            &["--stream", abs_rec.as_str()],
            "out.csv",
            &[],
            "--stream FILE",
        ),
    ] {
        let mut args = options.to_vec();
        args.extend_from_slice(&["rec.bin", out]);
        args.extend_from_slice(&site);
        args.extend_from_slice(rest);
        let (code, log) = run_firmware(d, &args);
        assert_eq!(code, 3, "{args:?}: {log}");
        assert!(
            log.contains(expect) && log.contains("refusing to overwrite"),
            "{args:?}: expected '{expect}' in:\n{log}"
        );
        assert_eq!(std::fs::read(d.join("rec.bin")).unwrap(), bytes, "{args:?}");
        assert_eq!(
            std::fs::read(d.join("fixes.bin")).unwrap(),
            fixes,
            "{args:?}"
        );
        assert_eq!(
            std::fs::read_to_string(d.join("cal.txt")).unwrap(),
            CALIBRATION,
            "{args:?}"
        );
        assert_eq!(
            std::fs::read(d.join("frame.bin")).unwrap(),
            frame,
            "{args:?}"
        );
    }
    // A solution log of an earlier run is overwritten as before.
    std::fs::write(d.join("out.csv"), "t_s,old\n").unwrap();
    let mut args = vec!["rec.bin", "./sub/../out.csv"];
    args.extend_from_slice(&site);
    let (code, log) = run_firmware(d, &args);
    assert_ne!(code, 3, "{log}");
    assert!(
        !std::fs::read_to_string(d.join("out.csv"))
            .unwrap()
            .contains("old")
    );
}

/// A recording at another rate than the simulated IMU's 400 Hz is refused by the firmware
/// (exit 4) and by `nav replay --device`, with one message: each record reached the driver as a
/// gap of several output periods, and a valid 100 Hz or 200 Hz recording failed its alignment
/// for a reason it did not have ("window not complete", "base not still", ...).
#[test]
fn a_recording_not_at_the_devices_rate_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for rate_hz in [100.0, 200.0, 450.0] {
        let mut opts = SimOptions::new(Scenario::by_name("static").unwrap(), Grade::Fog);
        opts.seconds = Some(12.0);
        opts.rate_hz = rate_hz;
        let rec = simulate(&opts, |_, _| {}).unwrap().recording;
        recording_io::write(&d.join("rec.bin"), &rec).unwrap();
        let expect = format!(
            "the recording's rate {rate_hz} Hz is not the simulated IMU's output rate of 400 Hz"
        );
        let (code, log) = run_firmware(d, &["rec.bin", "fw.csv", "45", "7.5", "150", "10"]);
        assert_eq!(code, 4, "{rate_hz} Hz: {log}");
        assert!(log.contains(&expect), "{rate_hz} Hz: {log}");
        for device in ["adis16505", "icm42688", "bmi088"] {
            let o = nav(
                d,
                &[
                    "replay",
                    "--imu",
                    "rec.bin",
                    "--out",
                    "host.csv",
                    "--lat",
                    "45",
                    "--lon",
                    "7.5",
                    "--h",
                    "150",
                    "--align-seconds",
                    "10",
                    "--device",
                    device,
                ],
            );
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert!(!o.status.success(), "{rate_hz} Hz, {device}: {stderr}");
            assert!(
                stderr.contains(&format!("--device {device}: {expect}")),
                "{rate_hz} Hz, {device}: {stderr}"
            );
            assert!(!d.join("host.csv").exists());
        }
    }
}

/// A truncated and a corrupt recording stop the firmware with the recording exit code (4) and a
/// defmt error naming the byte offset, or, for a length the header does not give, the
/// header's count against the file's length, before anything is navigated.
#[test]
fn firmware_rejects_truncated_and_corrupt_recordings() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rec = static_recording(2.0, Grade::Ideal);
    let bytes = rec.to_bytes().unwrap();
    std::fs::write(d.join("truncated.bin"), &bytes[..bytes.len() - 13]).unwrap();
    let mut corrupt = bytes.clone();
    corrupt[48 + 40 * 300 + 10] ^= 0x40;
    std::fs::write(d.join("corrupt.bin"), &corrupt).unwrap();
    std::fs::write(
        d.join("garbage.bin"),
        b"this is not a recording at all, just text\n",
    )
    .unwrap();

    for (file, expect) in [
        (
            "truncated.bin",
            "the header says 800 samples (32048 bytes) but the file has 32035 bytes (truncated)",
        ),
        ("corrupt.bin", "record 300"),
        ("garbage.bin", "byte offset 0"),
    ] {
        let (code, log) = run_firmware(d, &[file, "out.csv", "45", "7.5", "150", "10"]);
        assert_eq!(code, 4, "{file}: exit code {code}; log:\n{log}");
        assert!(
            log.contains("ERROR") && log.contains(expect),
            "{file}: expected an error with '{expect}':\n{log}"
        );
    }
    // Bytes after the last record: refused before anything is navigated (the firmware
    // navigated the whole recording and failed only at its end, its log nearly complete), no
    // log created.
    let long = static_recording(13.0, Grade::Ideal).to_bytes().unwrap();
    let mut trailing = long.clone();
    trailing.extend_from_slice(&[0; 7]);
    std::fs::write(d.join("trailing.bin"), &trailing).unwrap();
    let (code, log) = run_firmware(d, &["trailing.bin", "tail.csv", "45", "7.5", "150", "10"]);
    assert_eq!(code, 4, "trailing bytes: {log}");
    assert!(
        log.contains("(trailing bytes after the last record)") && !log.contains("aligned"),
        "{log}"
    );
    assert!(!d.join("tail.csv").exists());
    // A recording that ends in a bad record after the alignment: the rows navigated before
    // it are in the log, and the stream carries every one of them (it lost the chunk it still
    // queued at the error exit: one row fewer than the log).
    let mut last_bad = long.clone();
    let n = last_bad.len();
    last_bad[n - 10] ^= 0x40;
    std::fs::write(d.join("last_bad.bin"), &last_bad).unwrap();
    let (code, log) = run_firmware(
        d,
        &[
            "--stream",
            "fw.bin",
            "last_bad.bin",
            "fw.csv",
            "45",
            "7.5",
            "150",
            "10",
            "40",
        ],
    );
    assert_eq!(code, 4, "a bad last record: {log}");
    let csv = std::fs::read_to_string(d.join("fw.csv")).unwrap();
    assert!(csv.lines().count() > 2 && !csv.contains("# end"), "{csv}");
    let o = nav(d, &["decode", "fw.bin", "--out", "decoded.csv"]);
    let decoded = std::fs::read_to_string(d.join("decoded.csv"))
        .unwrap_or_else(|_| panic!("nav decode: {}", String::from_utf8_lossy(&o.stderr)));
    assert!(
        decoded == csv,
        "the stream's {} lines against the log's {}",
        decoded.lines().count(),
        csv.lines().count()
    );
    let (code, log) = run_firmware(d, &["missing.bin", "out.csv", "45", "7.5", "150", "10"]);
    assert_eq!(code, 4, "missing file: {log}");
    // The path as typed, not the bytes of its semihosting string (`b"missing.bin\x00"`).
    assert!(
        log.contains("cannot open the recording missing.bin\n"),
        "missing file: expected its name as typed:\n{log}"
    );
    let (code, log) = run_firmware(d, &["truncated.bin", "out.csv", "95", "7.5", "150", "10"]);
    assert_eq!(code, 3, "latitude 95 must be refused: {log}");
    // A window shorter than the method's minimum, refused naming it (as `nav replay` does).
    std::fs::write(d.join("good.bin"), &bytes).unwrap();
    // Implausible site values, an extra argument and the log over the recording: bad
    // arguments (exit 3), the recording untouched.
    for (args, expect) in [
        (
            &["good.bin", "out.csv", "45", "7.5", "-1e7", "10"][..],
            "height -1e7 m is not within",
        ),
        (
            &["good.bin", "out.csv", "45", "400", "150", "10"],
            "longitude 400 deg",
        ),
        (
            &[
                "good.bin", "out.csv", "45", "7.5", "150", "10", "40", "cal.txt", "x",
            ],
            "unexpected argument x",
        ),
        (
            &["good.bin", "good.bin", "45", "7.5", "150", "10"],
            "refusing to overwrite the recording",
        ),
    ] {
        let (code, log) = run_firmware(d, args);
        assert_eq!(code, 3, "{args:?}: {log}");
        assert!(
            log.contains(expect),
            "{args:?}: expected '{expect}' in:\n{log}"
        );
        assert_eq!(std::fs::read(d.join("good.bin")).unwrap(), bytes);
    }
    let (code, log) = run_firmware(d, &["good.bin", "out.csv", "45", "7.5", "150", "0"]);
    assert_eq!(code, 3, "a window of 0 s: {log}");
    assert!(
        log.contains("alignment window 0 s is shorter than the static method's minimum of 10 s"),
        "{log}"
    );
    for (options, expect) in [
        (
            &["--imu-noise", "navigation"][..],
            "unknown IMU noise grade navigation",
        ),
        (
            &["--lever-arm", "1,2,3", "--lever-arm-sigma", "1"],
            "exclude each other",
        ),
        (&["--lever-arm", "1,2"], "--lever-arm takes X,Y,Z"),
        (&["--bias-prior", "-1"], "bias prior scale -1"),
    ] {
        let mut args = options.to_vec();
        args.extend_from_slice(&["good.bin", "out.csv", "45", "7.5", "150", "10"]);
        let (code, log) = run_firmware(d, &args);
        assert_eq!(code, 3, "{options:?}: {log}");
        assert!(
            log.contains(expect),
            "{options:?}: expected '{expect}' in:\n{log}"
        );
    }
    // A calibration with a typo is refused with its line number, before any navigation.
    std::fs::write(
        d.join("bad.cal"),
        "gyro_bias_rad_s = 0 0 0\naccel_scale = 0 0\n",
    )
    .unwrap();
    let (code, log) = run_firmware(
        d,
        &[
            "truncated.bin",
            "out.csv",
            "45",
            "7.5",
            "150",
            "10",
            "40",
            "bad.cal",
        ],
    );
    assert_eq!(code, 3, "bad calibration: {log}");
    assert!(log.contains("calibration line 2"), "{log}");
}

/// The ICM-42688-P and BMI088 paths run in the firmware too; a consumer gyro's resolution
/// (ICM: 1/131 deg/s per count over five packets; BMI088: 1/16.4 deg/s) does not see the Earth
/// rate, so gyrocompassing must fail loudly instead of reporting a heading of 0: the static
/// method refuses the parts' declared bias before any sample (exit 3: their heading 1-sigma
/// would be thousands of degrees), the inertial one runs the driver and finds no heading
/// signal in the data (exit 5).
#[test]
fn firmware_runs_the_mems_drivers_and_refuses_a_blind_gyrocompass() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rec = static_recording(10.5, Grade::Ideal);
    recording_io::write(&d.join("rec.bin"), &rec).unwrap();
    for (device, name) in [("icm42688", "Icm42688"), ("bmi088", "Bmi088")] {
        let site = ["rec.bin", "out.csv", "45", "7.5", "150", "10"];
        let mut args = vec!["--device", device];
        args.extend_from_slice(&site);
        let (code, log) = run_firmware(d, &args);
        assert_eq!(code, 3, "{device}: exit code; log:\n{log}");
        assert!(log.contains("gyros too coarse to find north"), "{log}");
        let mut args = vec!["--device", device, "--align-method", "inertial"];
        args.extend_from_slice(&site);
        let (code, log) = run_firmware(d, &args);
        assert_eq!(code, 5, "{device}: exit code; log:\n{log}");
        assert!(
            log.contains(&format!("IMU: {name} over a simulated SPI device")),
            "{log}"
        );
        assert!(log.contains("heading signal not resolved"), "{log}");
        assert!(log.contains("instructions per IMU read"), "{log}");
    }
    let (code, log) = run_firmware(
        d,
        &[
            "--device", "mpu6050", "rec.bin", "out.csv", "45", "7.5", "150", "10",
        ],
    );
    assert_eq!(code, 3, "unknown device: {log}");
    let (code, log) = run_firmware(
        d,
        &[
            "--align-method",
            "magic",
            "rec.bin",
            "out.csv",
            "45",
            "7.5",
            "150",
            "10",
        ],
    );
    assert_eq!(code, 3, "unknown alignment method: {log}");
    assert!(log.contains("unknown alignment method magic"), "{log}");
}

/// The gyro-free oscillator estimator ([Oscillator INS]) runs on the MCU in f32 (`osc_bench`,
/// synthetic readouts of a body spinning at 0.5 rad/s): it locks, gives an epoch every period after
/// that, and its worst attitude error is within f32 rounding of the exact answer. The rotation
/// compensation makes a constant spin exact, so what is left is rounding: readouts of
/// `|c| + P` = 45 um rounded to 6e-8 relative, amplified by `(|c| + P)/Q` = 4.5 and by the
/// chain of about 50-readout sums, the fit and the rate from attitude differences (a factor of
/// some 50): ~1.4e-5 rad; the bound is twice that.
#[test]
fn firmware_runs_the_oscillator_estimator_in_f32() {
    let dir = tempfile::tempdir().unwrap();
    let (code, log) = run_diagnostic(dir.path(), "osc_bench", &[]);
    assert_eq!(code, 0, "{log}");
    println!("{log}");
    let after = |key: &str| -> f64 {
        let at = log
            .find(key)
            .unwrap_or_else(|| panic!("'{key}' not in:\n{log}"))
            + key.len();
        log[at..]
            .trim_start()
            .split(|c: char| !(c.is_ascii_digit() || ".e-+".contains(c)))
            .next()
            .and_then(|w| w.parse().ok())
            .unwrap_or_else(|| panic!("no number after '{key}'"))
    };
    let epochs = after("readouts at 5 kHz, 100 Hz oscillator, 0.5 rad/s spin):");
    let faults = after("epochs,");
    let worst = after("worst attitude error after lock");
    // 2 s at 100 Hz: 200 periods, of which acquisition takes fewer than 20.
    assert!(
        epochs + faults >= 198.0 && faults < 20.0,
        "{epochs} {faults}"
    );
    assert!(worst < 3e-5, "{worst}");
    assert!(after("instructions per oscillator readout: max") > 0.0);
}

/// A panic and a HardFault end the run with their own exit codes (1, 2) and a logged message.
#[test]
fn firmware_panic_and_hardfault_exit_nonzero() {
    let dir = tempfile::tempdir().unwrap();
    let (code, log) = run_diagnostic(dir.path(), "crash", &["panic"]);
    assert_eq!(code, 1, "panic exit code; log:\n{log}");
    assert!(
        log.contains("panic") && log.contains("crash test requested"),
        "{log}"
    );
    let (code, log) = run_diagnostic(dir.path(), "crash", &["hardfault"]);
    assert_eq!(code, 2, "HardFault exit code; log:\n{log}");
    assert!(log.contains("HardFault at pc="), "{log}");
}

/// On rocking recordings (`auv-bench`: 5 deg / 11 s roll and pitch, FOG-grade sensors) the
/// firmware's low-priority alignment task runs the inertial coarse + position-aided Kalman fine
/// alignment (assuming the board's ADIS16505 noise), and the inertial-frame alignment of an IMU
/// swaying at a known lever arm (-5.9, 0.6, -7.5) m from the centre of rotation (assuming the
/// FOG grade: `--imu-noise fog --lever-arm -5.9,0.6,-7.5`); each logs its stages, attitude and
/// 1-sigma, misses no sample and overruns no channel on a 125 MIPS core (QEMU icount shift 3,
/// slower than the real part), and ends in the same state as the host harness given the same
/// options (identical solution logs, alignment row included). The sway method (not yet
/// real-time on the part): [`firmware_runs_the_sway_alignment_like_the_harness`].
#[test]
fn firmware_aligns_on_a_rocking_base_like_the_harness() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rocking = |lever_arm_m: Option<[f64; 3]>| {
        let mut scenario = Scenario::by_name("auv-bench").unwrap();
        for (key, v) in ["lever_x_m", "lever_y_m", "lever_z_m"]
            .into_iter()
            .zip(lever_arm_m.unwrap_or_default())
        {
            scenario.set(key, v).unwrap();
        }
        let params = scenario.describe();
        let param = |key: &str| params.iter().find(|p| p.0 == key).map(|p| p.1).unwrap();
        let centre = [param("lat_deg"), param("lon_deg"), param("h_m")];
        let mut opts = SimOptions::new(scenario, Grade::Fog);
        opts.seconds = Some(45.0);
        opts.seed = 11;
        (simulate(&opts, |_, _| {}).unwrap(), centre)
    };
    // (method, the IMU's lever arm [m], the options of both runs)
    type Case<'a> = (&'a str, Option<[f64; 3]>, &'a [&'a str]);
    let cases: [Case; 2] = [
        // The data are FOG-grade: the default (ADIS16505) noise and its 2.3 deg/h bias prior
        // cannot resolve a heading in 40 s (and the method says so).
        ("fine", None, &["--imu-noise", "fog"]),
        (
            "inertial",
            Some([-5.9, 0.6, -7.5]),
            // A motion table turns and hardly translates: with the 0.5 m default wave prior
            // its leak through 10 s ramps refuses a 40 s window; 1 cm leaks little (and the
            // leak's spectrum, computed while the window's increments arrive, is exercised).
            &[
                "--imu-noise",
                "fog",
                "--lever-arm",
                "-5.9,0.6,-7.5",
                "--base-translation",
                "0.01",
            ],
        ),
    ];
    for (method, lever_arm_m, options) in cases {
        let (sim, centre) = rocking(lever_arm_m);
        recording_io::write(&d.join("rock.bin"), &sim.recording).unwrap();
        // The site is the centre of rotation (the IMU starts at the centre plus its lever arm).
        let [lat, lon, h] = centre.map(|x| x.to_string());
        let mut args = vec!["--align-method", method];
        args.extend_from_slice(options);
        args.extend_from_slice(&["rock.bin", "fw.csv", &lat, &lon, &h, "40", "40"]);
        // At 125 MIPS: the tasks keep up on the real part, the alignment's end included (the
        // inertial leak's spectrum once took 90 million instructions there, and the samples
        // after the alignment overran).
        let (code, log) = run_firmware_at(d, &args, 3);
        println!("{log}");
        assert_eq!(code, 0, "{method}: firmware exit code {code}; log:\n{log}");
        assert!(
            log.contains(&format!("aligning: {method}, 16000 samples; stage COARSE")),
            "{log}"
        );
        if method == "fine" {
            // The coarse stage levels only: FINE_COARSE_S = 5 s.
            assert!(
                log.contains("alignment stage FINE after 2000 samples"),
                "{log}"
            );
        } else {
            assert!(log.contains("lever arm known: -5.9 0.6 -7.5 m"), "{log}");
        }
        assert!(
            log.contains("alignment stage ALIGNED after 16000 samples"),
            "{log}"
        );
        assert!(log.contains("1-sigma"), "{log}");
        assert_eq!(field(&log, "missed"), 0, "missed data-ready interrupts");
        assert_eq!(field(&log, "channel overruns"), 0, "channel overruns");

        let mut args = vec![
            "replay",
            "--imu",
            "rock.bin",
            "--align-seconds",
            "40",
            "--align-method",
            method,
            "--out",
            "host.csv",
            "--device",
            "adis16505",
            "--precision",
            "f32",
            "--lat",
            &lat,
            "--lon",
            &lon,
            "--h",
            &h,
        ];
        args.extend_from_slice(options);
        let out = nav(d, &args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let fw = std::fs::read_to_string(d.join("fw.csv")).unwrap();
        let host = std::fs::read_to_string(d.join("host.csv")).unwrap();
        assert_eq!(fw, host, "{method}: firmware and harness logs differ");
        // The aligned heading against the truth: within 4 sigma of the FOG floor at 40 s (the
        // accelerometer term of 2.46 deg at 30 s scales as T^-1.5: ~1.6 deg at 40 s).
        let (_, err) = alignment_errors(&host, &sim.truth[40 * 50].q_b_ned);
        println!("{method} alignment on the rocking bench, 40 s: yaw error {err:.3} deg");
        assert!(err < 4.0 * 1.6, "{method}: {err} deg");
    }
}

/// The member's 1-sigma of yaw [deg] from `nav replay`'s alignment line (`...; 1-sigma R P Y
/// deg`).
fn host_yaw_sigma_deg(stdout: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("alignment ("))
        .unwrap_or_else(|| panic!("no alignment line in:\n{stdout}"));
    let (_, rest) = line
        .split_once("1-sigma ")
        .unwrap_or_else(|| panic!("no 1-sigma in: {line}"));
    rest.split_whitespace()
        .nth(2)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no yaw 1-sigma in: {line}"))
}

/// The text after `note: ` in a log (the firmware's defmt line, or `nav replay`'s), if any.
fn note(log: &str) -> Option<&str> {
    log.lines()
        .find_map(|l| l.split_once("note: ").map(|(_, n)| n.trim_end()))
}

/// The sway method ([`nav_core::alignment::AlignMethod::Sway`]) in the firmware: its period
/// identification runs a few least-squares fits per filter step in the low-priority alignment
/// task, and its filters are started in place in the task's static slot. On two swaying members
/// of the alignment family (seed 1, 42 s, aligned over 40 s with the lever arm given, as the
/// member's `nav sim family` replay command gives it): member 21, whose drawn yaw sway is far
/// inside the sway model's envelope (the sway model's answer), and member 8, whose yaw sway is
/// far beyond it (the general filter's answer, with the note saying so). The firmware misses no
/// sample, overruns no channel, and ends in the same state as the host harness in `f32`
/// (identical solution logs, the same note), with a heading within 4 of its own 1-sigma.
#[test]
fn firmware_runs_the_sway_alignment_like_the_harness() {
    use host_tests::simulate_family::{FamilySimOptions, simulate_member};
    use host_tests::trajectory::family::FamilyMember;
    use nav_core::alignment::AlignMethod;
    use nav_core::alignment::sway::MAX_YAW_SWAY_RAD;

    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let envelope_deg = MAX_YAW_SWAY_RAD.to_degrees();
    // (member, the sway model applies): its yaw sway is a tenth of the envelope, or 1.5 times
    // beyond it.
    for (index, model_applies) in [(21, true), (8, false)] {
        let member = FamilyMember::draw(1, index);
        let yaw_amp_deg = member.rocking.yaw.amp_deg;
        assert!(!member.still, "member {index} must sway");
        if model_applies {
            assert!(
                yaw_amp_deg < 0.1 * envelope_deg,
                "member {index}: {yaw_amp_deg} deg"
            );
        } else {
            assert!(
                yaw_amp_deg > 1.5 * envelope_deg,
                "member {index}: {yaw_amp_deg} deg"
            );
        }
        let opts = FamilySimOptions {
            seconds: 42.0,
            ..FamilySimOptions::default()
        };
        let sim = simulate_member(&member, &opts, |_, _| {}).unwrap();
        recording_io::write(&d.join("sway.bin"), &sim.recording).unwrap();
        // The member's replay command: `nav replay --imu sway.bin --lat .. --lon .. --h ..
        // --align-seconds 40 --align-method sway --imu-noise G --bias-prior B --lever-arm X,Y,Z
        // --out solution.csv`.
        let command = member.replay_command(Path::new("sway.bin"), 40.0, AlignMethod::Sway);
        let words: Vec<&str> = command.split_whitespace().skip(2).collect();
        let value = |key: &str| {
            let at = words.iter().position(|w| *w == key).unwrap();
            words[at + 1]
        };
        let mut fw_args = vec![];
        for key in [
            "--align-method",
            "--imu-noise",
            "--bias-prior",
            "--lever-arm",
        ] {
            fw_args.extend_from_slice(&[key, value(key)]);
        }
        fw_args.extend_from_slice(&["sway.bin", "fw.csv"]);
        fw_args.extend_from_slice(&[value("--lat"), value("--lon"), value("--h"), "40", "40"]);
        let started = std::time::Instant::now();
        let (code, log) = run_firmware(d, &fw_args);
        let wall_s = started.elapsed().as_secs_f64();
        println!("{log}\nmember {index}: QEMU run {wall_s:.1} s for 42 s of data");
        assert_eq!(
            code, 0,
            "member {index}: firmware exit code {code}; log:\n{log}"
        );
        for expect in [
            "aligning: sway, 16000 samples; stage COARSE",
            "alignment stage FINE after 2000 samples",
            "alignment stage ALIGNED after 16000 samples",
            "instructions per alignment sample (sway)",
        ] {
            assert!(
                log.contains(expect),
                "member {index}: no '{expect}' in:\n{log}"
            );
        }
        assert_eq!(field(&log, "missed"), 0, "missed data-ready interrupts");
        assert_eq!(field(&log, "channel overruns"), 0, "channel overruns");

        let mut args: Vec<&str> = vec!["replay"];
        args.extend(words.iter().take_while(|w| **w != "--out"));
        args.extend_from_slice(&[
            "--out",
            "host.csv",
            "--log-every",
            "40",
            "--device",
            "adis16505",
            "--precision",
            "f32",
        ]);
        let out = nav(d, &args);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "member {index}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let fw = std::fs::read_to_string(d.join("fw.csv")).unwrap();
        let host = std::fs::read_to_string(d.join("host.csv")).unwrap();
        assert_eq!(fw, host, "member {index}: firmware and harness logs differ");
        assert_eq!(note(&log), note(&stdout), "member {index}: notes differ");
        match note(&stdout) {
            None => assert!(model_applies, "member {index}: no note:\n{stdout}"),
            Some(n) => assert!(
                !model_applies && n.starts_with("sway model not applied"),
                "member {index}: {n}"
            ),
        }
        // The IMU's truth at the end of the window (truth every 20 ms).
        let (_, err_deg) = alignment_errors(&host, &sim.truth[40 * 50].q_b_ned);
        let sigma_deg = host_yaw_sigma_deg(&stdout);
        println!("member {index}: yaw error {err_deg:.3} deg, 1-sigma {sigma_deg:.3} deg");
        assert!(err_deg < 4.0 * sigma_deg, "member {index}: {err_deg} deg");
    }
}

/// The lines of a log from `name:` to the line's end (the firmware's defmt lines and `nav
/// replay`'s summary print the aided counts alike).
fn lines_with<'a>(log: &'a str, names: &[&str]) -> Vec<&'a str> {
    names
        .iter()
        .map(|name| {
            log.lines()
                .find_map(|l| l.find(name).map(|at| l[at..].trim_end()))
                .unwrap_or_else(|| panic!("no '{name}' in:\n{log}"))
        })
        .collect()
}

/// Asserts that the firmware's log `fw` is the harness's `host` line for line (the first line
/// that differs shown), and as long.
fn assert_same_lines(fw: &str, host: &str) {
    for (i, (a, b)) in fw.lines().zip(host.lines()).enumerate() {
        assert_eq!(
            a,
            b,
            "line {} differs:\nfirmware: {a}\nhost:     {b}",
            i + 1
        );
    }
    assert_eq!(
        fw.lines().count(),
        host.lines().count(),
        "row counts differ"
    );
}

/// A free-inertial run whose IMU data lose 6 s (beyond the 5 s bridge) after the alignment:
/// the firmware's log marks the lost solution with the harness's lost record, before the
/// first row after the gap, and its rows are the harness's line for line (the firmware wrote
/// no record: its rows after the gap looked valid).
#[test]
fn firmware_marks_a_lost_free_inertial_solution_like_the_harness() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut rec = static_recording(25.0, Grade::Fog);
    // 400 Hz: the records of 14 s to 20 s.
    rec.records.drain(5_600..8_000);
    std::fs::write(d.join("rec.bin"), rec.to_bytes().unwrap()).unwrap();
    let (lat, lon, h) = static_site();
    let (code, log) = run_firmware(
        d,
        &[
            "--imu-noise",
            "fog",
            "rec.bin",
            "fw.csv",
            &lat,
            &lon,
            &h,
            "10",
            "40",
        ],
    );
    assert_eq!(code, 0, "firmware exit code {code}; log:\n{log}");
    let o = nav(
        d,
        &[
            "replay",
            "--imu",
            "rec.bin",
            "--align-seconds",
            "10",
            "--log-every",
            "40",
            "--device",
            "adis16505",
            "--imu-noise",
            "fog",
            "--lat",
            &lat,
            "--lon",
            &lon,
            "--h",
            &h,
            "--out",
            "host.csv",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fw = std::fs::read_to_string(d.join("fw.csv")).unwrap();
    let host = std::fs::read_to_string(d.join("host.csv")).unwrap();
    let lost: Vec<&str> = fw.lines().filter(|l| l.starts_with("# lost:")).collect();
    assert_eq!(lost.len(), 1, "{fw}");
    // The records resume at 20.0025 s; the ADIS16505 driver's first sample after the gap, on
    // both sides, ends at 20.005 s: 6 s lost, and a period.
    assert!(
        lost[0].starts_with("# lost: t = 20.005000 s after an IMU gap of 6.002500 s"),
        "{}",
        lost[0]
    );
    assert_same_lines(&fw, &host);
}

/// Fixes on another clock than the recording's (none within the IMU data's time span) end
/// the firmware's run with the recording's exit code (4), named as the harness names them,
/// before anything is navigated (from the header's start and the last record's time); before,
/// the run exited 0 with a complete-looking free-inertial log that said NAV, then navigated
/// it all and refused it at the end. Fixes that all come before the aided phase are warned of in the harness's
/// words (the firmware said nothing).
#[test]
fn firmware_refuses_fixes_on_another_clock_and_warns_of_unused_ones() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    aided_drive(d, 25.0, &aided_receiver());
    let csv = std::fs::read_to_string(d.join("gnss.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    let rows: Vec<(f64, &str)> = lines
        .map(|l| {
            let (t, rest) = l.split_once(',').unwrap();
            (t.parse().unwrap(), rest)
        })
        .collect();
    let write = |name: &str, rows: &mut dyn Iterator<Item = (f64, &str)>| {
        let text: String = rows.map(|(t, rest)| format!("{t},{rest}\n")).collect();
        let file = d.join(format!("{name}.csv"));
        std::fs::write(&file, format!("{header}\n{text}")).unwrap();
        host_tests::gnss_file::convert(&file, &d.join(format!("{name}.bin")), None).unwrap();
    };
    write("later", &mut rows.iter().map(|&(t, r)| (t + 1000.0, r)));
    write(
        "early",
        &mut rows.iter().copied().filter(|&(t, _)| t < 10.0),
    );
    let run = |fixes: &str| {
        run_firmware(
            d,
            &[
                "--imu-noise",
                "fog",
                "--gnss",
                fixes,
                "rec.bin",
                "fw.csv",
                "45",
                "7.5",
                "250",
                "15",
            ],
        )
    };
    // Refused before anything is navigated (the firmware navigated the whole run, its rows
    // NAV, and refused it at the end), no log created.
    let (code, log) = run("later.bin");
    assert_eq!(code, 4, "{log}");
    assert!(
        log.contains("no GNSS fix within the IMU data's time span")
            && log.contains("another clock than the recording's")
            && !log.contains("aligned"),
        "{log}"
    );
    assert!(!d.join("fw.csv").exists());
    let (code, log) = run("early.bin");
    assert_eq!(code, 0, "{log}");
    assert!(
        log.contains("WARN")
            && log.contains("no GNSS position fix was used (0 refused, 0 invalid, 50 before the aided phase, 0 after the data): the solution is free-inertial"),
        "{log}"
    );
    // The harness says the same of the same files.
    let o = nav(
        d,
        &[
            "replay",
            "--imu",
            "rec.bin",
            "--gnss",
            "early.csv",
            "--imu-noise",
            "fog",
            "--lat",
            "45",
            "--lon",
            "7.5",
            "--h",
            "250",
            "--align-seconds",
            "15",
            "--device",
            "adis16505",
            "--out",
            "host.csv",
        ],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("no GNSS position fix was used (0 refused, 0 invalid, 50 before the aided phase, 0 after the data)"),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// 6 s of IMU records lost at 30 s of the aided drive (1 Hz fixes): in the
/// firmware as in the harness, the aided phase is DEGRADED (IMU_LOST) from the gap, the
/// first fix after it sets the filter aside, the fixes after it re-align it in motion, and it
/// navigates again (NAV); the firmware's rows are the harness's line for line, its stream's
/// health frames say DEGRADED with IMU_LOST in between and NAV at the end, and its log says
/// it re-aligned. Was: DEGRADED to the end of the run in the firmware.
#[test]
fn firmware_realigns_after_a_lost_gap_like_the_harness() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 1 Hz: the re-alignment's fixes span health frames.
    aided_drive(d, 60.0, &velocity_receiver(1.0));
    let mut rec = recording_io::read(&d.join("rec.bin")).unwrap();
    rec.records.drain(12_000..14_400);
    std::fs::write(d.join("rec.bin"), rec.to_bytes().unwrap()).unwrap();
    let options = ["--imu-noise", "fog", "--gnss-lever-arm", "0.8,-0.3,-1.1"];
    let mut args = vec!["--gnss", "gnss.bin", "--stream", "fw.bin"];
    args.extend_from_slice(&options);
    args.extend_from_slice(&["rec.bin", "fw.csv", "45", "7.5", "250", "15"]);
    let (code, log) = run_firmware_at(d, &args, 3);
    assert_eq!(code, 0, "firmware exit code {code}; log:\n{log}");
    assert_eq!(field(&log, "missed"), 0, "missed data-ready interrupts");
    assert_eq!(field(&log, "channel overruns"), 0, "channel overruns");
    assert!(
        log.contains("re-aligned in motion 1 time(s) (0 after a divergence, 0 started over"),
        "{log}"
    );
    let o = replay_like_the_firmware(d, &options);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        stdout.contains("re-aligned in motion 1 time(s) after IMU data lost beyond the bridge"),
        "{stdout}"
    );
    let fw = std::fs::read_to_string(d.join("fw.csv")).unwrap();
    let host = std::fs::read_to_string(d.join("host.csv")).unwrap();
    assert_same_lines(&fw, &host);
    // Rows: NAV to the gap, DEGRADED from it to the restart, NAV from there to the end.
    let statuses: Vec<(f64, &str)> = host
        .lines()
        .filter(|l| !l.starts_with('#') && l.contains(','))
        .filter_map(|l| Some((l.split(',').next()?.parse().ok()?, l.rsplit(',').next()?)))
        .collect();
    let degraded: Vec<f64> = statuses
        .iter()
        .filter(|(_, s)| *s == "DEGRADED")
        .map(|(t, _)| *t)
        .collect();
    assert!(!degraded.is_empty(), "{host}");
    assert!(
        degraded[0] > 35.9 && degraded[degraded.len() - 1] < 42.0,
        "{degraded:?}"
    );
    assert!(
        statuses
            .iter()
            .all(|(t, s)| *s == "NAV" || (*t >= degraded[0] && *t <= degraded[degraded.len() - 1])),
        "{statuses:?}"
    );
    assert_eq!(statuses.last().unwrap().1, "NAV");
    let health = health_frames(&stream_messages(&d.join("fw.bin")));
    assert!(
        health
            .iter()
            .any(|h| h.status == NavStatus::Degraded && h.flags.contains(StatusFlags::IMU_LOST)),
        "{health:?}"
    );
    let last = health.last().unwrap();
    assert_eq!(last.status, NavStatus::Nav, "{last:?}");
    assert!(!last.flags.contains(StatusFlags::IMU_LOST), "{last:?}");
}

/// Fixes of 10 cm tagged 0.2 s late (a logger that tags them on arrival): the firmware finds
/// the latency as the harness does (its rows the harness's line for line, DEGRADED at the end,
/// its last health frame DEGRADED with AIDING_REJECTED). The fix file written at the
/// measurement epochs (`nav convert --gnss-latency`, `gnss_file::convert_at_epochs`) navigates
/// as the harness's `--gnss-latency` does: the same rows, NAV at the end.
#[test]
fn firmware_finds_a_late_receiver_and_takes_a_declared_one_like_the_harness() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rtk = host_tests::gnss_sim::GnssSimOptions {
        sigma_ned_m: [0.1, 0.1, 0.2],
        ..aided_receiver()
    };
    aided_drive(d, 75.0, &rtk);
    // The same fixes, tagged 0.2 s late: the harness's text and the firmware's two files.
    let csv = d.join("gnss.csv");
    let mut fixes = host_tests::gnss::read_gnss(&csv).unwrap();
    for f in &mut fixes {
        f.t_s += 0.2;
    }
    host_tests::gnss::write_gnss_csv(&csv, &fixes).unwrap();
    host_tests::gnss_file::convert(&csv, &d.join("gnss.bin"), None).unwrap();
    host_tests::gnss_file::convert_at_epochs(&csv, &d.join("epochs.bin"), None, 0.2).unwrap();
    let options = ["--imu-noise", "fog", "--gnss-lever-arm", "0.8,-0.3,-1.1"];
    for (file, declared, status) in [
        ("gnss.bin", &[][..], "DEGRADED"),
        ("epochs.bin", &["--gnss-latency", "0.2"][..], "NAV"),
    ] {
        let mut args = vec!["--gnss", file, "--stream", "fw.bin"];
        args.extend_from_slice(&options);
        args.extend_from_slice(&["rec.bin", "fw.csv", "45", "7.5", "250", "15"]);
        let (code, log) = run_firmware_at(d, &args, 3);
        assert_eq!(code, 0, "{file}: firmware exit code {code}; log:\n{log}");
        let o = replay_like_the_firmware(d, &[&options[..], declared].concat());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let fw = std::fs::read_to_string(d.join("fw.csv")).unwrap();
        let host = std::fs::read_to_string(d.join("host.csv")).unwrap();
        assert_same_lines(&fw, &host);
        let last = host.lines().rfind(|l| !l.starts_with('#')).unwrap();
        assert!(last.ends_with(status), "{file}: {last}");
        let health = health_frames(&stream_messages(&d.join("fw.bin")));
        let h = health.last().unwrap();
        let late =
            h.status == NavStatus::Degraded && h.flags.contains(StatusFlags::AIDING_REJECTED);
        assert_eq!(late, status == "DEGRADED", "{file}: {h:?}");
    }
}

/// The aided runs' receiver: 5 Hz fixes of 0.5/0.5/1 m, the antenna at 0.8, -0.3, -1.1 m.
fn aided_receiver() -> host_tests::gnss_sim::GnssSimOptions {
    host_tests::gnss_sim::GnssSimOptions {
        rate_hz: 5.0,
        sigma_ned_m: [0.5, 0.5, 1.0],
        lever_arm_b_m: [0.8, -0.3, -1.1],
        seed: 5,
        ..Default::default()
    }
}

/// [`aided_receiver`] at `rate_hz` [Hz], with velocities of 0.05/0.05/0.1 m/s.
fn velocity_receiver(rate_hz: f64) -> host_tests::gnss_sim::GnssSimOptions {
    host_tests::gnss_sim::GnssSimOptions {
        rate_hz,
        sigma_v_ned_m_s: Some([0.05, 0.05, 0.1]),
        ..aided_receiver()
    }
}

/// Writes `seconds` [s] of the demo's drive (FOG grade, seed 7, at 45 deg N, 7.5 deg E, 250 m)
/// into `d` as `rec.bin`, and the fixes of `gnss` along it as `gnss.csv` and the binary fix
/// file `gnss.bin`.
fn aided_drive(d: &Path, seconds: f64, gnss: &host_tests::gnss_sim::GnssSimOptions) {
    let mut scenario = Scenario::by_name("land-vehicle").unwrap();
    for (key, v) in [("lat_deg", 45.0), ("lon_deg", 7.5), ("h_m", 250.0)] {
        scenario.set(key, v).unwrap();
    }
    let mut opts = SimOptions::new(scenario, Grade::Fog);
    opts.seconds = Some(seconds);
    opts.seed = 7;
    let sim = simulate(&opts, |_, _| {}).unwrap();
    recording_io::write(&d.join("rec.bin"), &sim.recording).unwrap();
    let fixes = host_tests::gnss_sim::simulate(&sim.truth, gnss)
        .unwrap()
        .fixes;
    host_tests::gnss::write_gnss_csv(&d.join("gnss.csv"), &fixes).unwrap();
    host_tests::gnss_file::convert(&d.join("gnss.csv"), &d.join("gnss.bin"), None).unwrap();
}

/// `nav replay` of `aided_drive`'s files as the firmware runs them (aligned at the site over
/// 15 s, the ADIS16505's conversion, f32) with `options`, writing `host.csv`.
fn replay_like_the_firmware(d: &Path, options: &[&str]) -> std::process::Output {
    let mut args = vec![
        "replay",
        "--imu",
        "rec.bin",
        "--gnss",
        "gnss.csv",
        "--out",
        "host.csv",
        "--lat",
        "45",
        "--lon",
        "7.5",
        "--h",
        "250",
        "--align-seconds",
        "15",
        "--device",
        "adis16505",
        "--precision",
        "f32",
    ];
    args.extend_from_slice(options);
    nav(d, &args)
}

/// The GNSS-aided phase in the firmware (`--gnss FILE`): 60 s of the demo's drive (FOG grade;
/// 15 s of static alignment, 5 s still, then starting, turning) with 5 Hz fixes of an antenna
/// 1.4 m from the IMU, position and velocity, from the binary fix file converted from the
/// GNSS CSV. On a 125 MIPS core (QEMU icount shift 3) the firmware misses no sample and
/// overruns no channel while its background task runs the filter's propagations and updates,
/// and its solution log (the filter's 1-sigmas and status in every row) is the harness's,
/// reading the CSV, line for line, with the same counts of the aids and fixes. A corrupt fix
/// file and aided options without `--gnss` are refused before anything is navigated.
#[test]
fn firmware_navigates_aided_like_the_harness() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    aided_drive(d, 60.0, &velocity_receiver(5.0));
    let options = ["--imu-noise", "fog", "--gnss-lever-arm", "0.8,-0.3,-1.1"];
    let site = ["45", "7.5", "250", "15"];

    let mut args = vec!["--gnss", "gnss.bin", "--stream", "fw.bin"];
    args.extend_from_slice(&options);
    args.extend_from_slice(&["rec.bin", "fw.csv"]);
    args.extend_from_slice(&site);
    let started = std::time::Instant::now();
    let (code, log) = run_firmware_at(d, &args, 3);
    println!("{log}\nQEMU run: {:.2} s", started.elapsed().as_secs_f64());
    assert_eq!(code, 0, "firmware exit code {code}; log:\n{log}");
    assert!(
        log.contains(
            "GNSS-aided after the alignment: 301 fixes; antenna lever arm 0.8 -0.3 -1.1 m"
        ),
        "{log}"
    );
    assert_eq!(field(&log, "missed"), 0, "missed data-ready interrupts");
    assert_eq!(field(&log, "channel overruns"), 0, "channel overruns");
    for key in [
        "instructions per covariance propagation: max",
        "per GNSS update (position or velocity): max",
        "amortised total",
    ] {
        assert!(field(&log, key) > 0, "{key}");
    }

    let o = replay_like_the_firmware(d, &options);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fw = std::fs::read_to_string(d.join("fw.csv")).unwrap();
    let host = std::fs::read_to_string(d.join("host.csv")).unwrap();
    assert!(fw.starts_with(nav_core::output::AIDED_CSV_HEADER), "{fw}");
    // The aligned row at 15 s, a row every 0.1 s to 60 s, the end record.
    assert_eq!(host.lines().count(), 1 + 1 + 450 + 1);
    assert_same_lines(&fw, &host);
    // The stream gives the same log back, and an aiding event per fix the filter counted.
    let report = decode_stream(d, "fw.bin", "decoded.csv");
    let decoded = std::fs::read_to_string(d.join("decoded.csv")).unwrap();
    assert!(
        decoded == host,
        "the decoded stream differs from the host's log\n{report}"
    );
    let messages = stream_messages(&d.join("fw.bin"));
    let last = *health_frames(&messages).last().unwrap();
    let events = |aid, outcome| {
        messages
            .iter()
            .filter(
                |m| matches!(m, Message::AidingEvent(e) if e.aid == aid && e.outcome == outcome),
            )
            .count() as u32
    };
    use hal_adapters::protocol::messages::Aid;
    let pos = last.counters.position_aiding;
    assert_eq!(pos.accepted, 225, "{last:?}");
    assert_eq!(events(Aid::Position, AidOutcome::Accepted), pos.accepted);
    assert_eq!(
        events(Aid::Position, AidOutcome::RejectedGate)
            + events(Aid::Position, AidOutcome::Invalid),
        pos.rejected
    );
    let vel = last.counters.velocity_aiding;
    assert_eq!(events(Aid::Velocity, AidOutcome::Accepted), vel.accepted);
    assert!(
        matches!(last.status, NavStatus::Nav | NavStatus::Degraded),
        "{last:?}"
    );
    assert!(!last.flags.contains(StatusFlags::FREE_INERTIAL));
    // Flags: DEFAULT_CONFIG only (0x2000: the command line's run, no configuration frame).
    assert!(
        log.contains("status NAV at 15002500 us (flags 0x2000)"),
        "the aided phase must start NAV, not free inertial: {log}"
    );
    let names = [
        "aided navigation: status",
        "GNSS position:",
        "GNSS velocity:",
        "zero velocity:",
        "zero rate:",
        "fixes:",
    ];
    let fw_lines = lines_with(&log, &names);
    let host_lines = lines_with(&stdout, &names);
    // The host adds the status's reason: the rest is the same text.
    assert!(host_lines[0].starts_with(fw_lines[0].split(',').next().unwrap()));
    assert_eq!(fw_lines[1..], host_lines[1..]);
    // 5 Hz from 15 s (during the alignment: unused) to 60 s (after the last sample: never
    // handed over); every one in between used.
    assert_eq!(
        fw_lines[5],
        "fixes: 225 received while aided, 0 out of order, 0 dropped from a full queue, 0 late; 76 before the aided phase, 0 after the data"
    );
    assert!(
        fw_lines[1].starts_with("GNSS position: 225 accepted"),
        "{}",
        fw_lines[1]
    );

    // Refused before anything is navigated: a corrupt fix file (exit 4, naming the fix), the
    // aided options without a fix file and the log over the fix file (bad arguments, exit 3).
    let mut bytes = std::fs::read(d.join("gnss.bin")).unwrap();
    bytes[32 + 112 * 200 + 40] ^= 0x04;
    std::fs::write(d.join("corrupt.bin"), &bytes).unwrap();
    let (code, log) = run_firmware(
        d,
        &[
            "--gnss",
            "corrupt.bin",
            "rec.bin",
            "out.csv",
            "45",
            "7.5",
            "250",
            "15",
        ],
    );
    assert_eq!(code, 4, "{log}");
    assert!(
        log.contains(
            "GNSS file corrupt.bin: GNSS byte offset 22432 (fix 200): record CRC mismatch"
        ),
        "{log}"
    );
    for (args, expect) in [
        (
            &[
                "--gnss-lever-arm",
                "1,0,0",
                "rec.bin",
                "out.csv",
                "45",
                "7.5",
                "250",
                "15",
            ][..],
            "--gnss-lever-arm, --propagation-rate, --gnss-correlated and --gnss-correlated-time need --gnss FILE",
        ),
        (
            &[
                "--gnss", "gnss.bin", "rec.bin", "gnss.bin", "45", "7.5", "250", "15",
            ],
            "refusing to overwrite the fixes",
        ),
        (
            &[
                "--gnss",
                "gnss.bin",
                "--propagation-rate",
                "0.5",
                "rec.bin",
                "out.csv",
                "45",
                "7.5",
                "250",
                "15",
            ],
            "--propagation-rate takes a rate within 1 to 1000 Hz",
        ),
    ] {
        let (code, log) = run_firmware(d, args);
        assert_eq!(code, 3, "{args:?}: {log}");
        assert!(
            log.contains(expect),
            "{args:?}: expected '{expect}' in:\n{log}"
        );
    }
}

/// A code receiver's time-correlated error declared on the firmware's command line
/// (`--gnss-correlated N,E,D --gnss-correlated-time S`, nav-core's `RunConfig::set` words):
/// 25 s of the demo's drive (15 s of static alignment, then 10 s aided by 5 Hz fixes that
/// carry such an error) give the solution log of `nav replay` with the same options, line for
/// line: the firmware's parse is the harness's configuration.
#[test]
fn firmware_takes_the_gnss_correlated_error_like_the_harness() {
    use host_tests::gnss_sim::{CorrelatedError, GnssSimOptions};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    aided_drive(
        d,
        25.0,
        &GnssSimOptions {
            correlated: Some(CorrelatedError {
                sigma_ned_m: [1.5, 1.5, 2.5],
                time_s: 60.0,
            }),
            ..aided_receiver()
        },
    );
    let options = [
        "--imu-noise",
        "fog",
        "--gnss-lever-arm",
        "0.8,-0.3,-1.1",
        "--gnss-correlated",
        "1.5,1.5,2.5",
        "--gnss-correlated-time",
        "45",
    ];
    let mut args = vec!["--gnss", "gnss.bin"];
    args.extend_from_slice(&options);
    args.extend_from_slice(&["rec.bin", "fw.csv", "45", "7.5", "250", "15"]);
    let (code, log) = run_firmware(d, &args);
    assert_eq!(code, 0, "firmware exit code {code}; log:\n{log}");
    assert!(
        log.contains("GNSS correlated error: 1-sigma 1.5 1.5 2.5 m (north, east, down)"),
        "{log}"
    );
    let o = replay_like_the_firmware(d, &options);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fw = std::fs::read_to_string(d.join("fw.csv")).unwrap();
    let host = std::fs::read_to_string(d.join("host.csv")).unwrap();
    // The aligned row at 15 s, a row every 0.1 s to 25 s, the end record.
    assert_eq!(host.lines().count(), 1 + 1 + 100 + 1, "{host}");
    assert_same_lines(&fw, &host);
}

/// A path with a space in it: the firmware's semihosting command line is split at white space,
/// so `"out/sol 45" 45 7.5 150 15` became `out/sol`, longitude 45 deg, height 7.5 m, a 150 s
/// window and a row every 15 steps, and the run exited 0 at the wrong site. `qemu-run.sh`
/// refuses it (exit 3, bad arguments) before QEMU starts, and writes nothing.
#[test]
fn a_path_with_white_space_is_refused_before_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (code, log) = run_firmware(
        d,
        &[
            "--imu-noise",
            "fog",
            "imu.bin",
            "sol 45",
            "45",
            "7.5",
            "150",
            "15",
        ],
    );
    assert_eq!(code, 3, "{log}");
    assert!(log.contains("holds white space"), "{log}");
    assert!(!d.join("sol").exists() && !d.join("sol 45").exists());
}
