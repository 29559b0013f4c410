//! `cargo xtask <command>`: the project's automation.
//!
//! - `setup`: checks the prerequisites and installs what is missing (rustup target,
//!   qemu-system-arm, defmt-print).
//! - `demo`: the main job: generates the demo recording, builds the firmware, runs it in QEMU and
//!   prints the decoded defmt log and the navigation result.
//! - `test`: builds the firmware, runs the tests on the target (`target_tests` in QEMU: the
//!   protocol's checks), then every test of the workspace (the QEMU end-to-end test
//!   included).
//! - `bench`: the benchmark figures: guest instructions per navigation step in QEMU (free
//!   inertial, and GNSS-aided: per covariance propagation, per update, per sample amortised),
//!   host samples per second, flash and RAM.
//! - `size`: release build of the firmware and its flash/RAM use, the largest statics.
//! - `build-board`: the STM32F405 board's firmware (`--features stm32f405`, profile `board`:
//!   the release settings, linked through `flip-link` when it is installed), its flash
//!   and static RAM and the largest statics; fails above the board's targets
//!   ([`BOARD_FLASH_MAX`], [`BOARD_RAM_MAX`]).
//! - `fuzz [CASES [RECORDING_CASES]]`: the decoder fuzz targets (`hal-adapters/tests/
//!   fuzz_decoders.rs`: recording header, records, replay, the three drivers' decode paths) with
//!   `CASES` cases each (default 100 000), then the mutated-recording properties through `nav
//!   replay` (`host-tests/tests/mutated_recordings.rs`) with `RECORDING_CASES` per format
//!   (default 1000); release builds; each target prints its count and wall time.
//! - `lint`: `cargo fmt --check`, clippy with `-D warnings` for the host crates and for the
//!   no_std crates and the firmware (both boards) on the thumb target, and the docs with
//!   `-D warnings`.

// Units are written `[m/s]` in docs (project convention), which rustdoc would read as links.
#![allow(rustdoc::broken_intra_doc_links)]

use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::process::Command;

const THUMB: &str = "thumbv7em-none-eabihf";
/// The board build's flash target [B].
const BOARD_FLASH_MAX: u64 = 128 * 1024;
/// The board build's static RAM target [B] (`.data`, `.bss`, `.uninit`; the stack takes the
/// rest of the 128 KiB).
const BOARD_RAM_MAX: u64 = 32 * 1024;

/// The demo: `nav sim land-vehicle` with the `fog` grade at 45 deg N, 7.5 deg E, 250 m: the car
/// stands still for 20 s (15 s of static alignment), then drives (starts, turns, stops) for
/// 100 s.
const DEMO_SITE: [&str; 3] = ["45", "7.5", "250"];
const DEMO_ALIGN_S: &str = "15";
/// Length of the demo recording [s].
const DEMO_SECONDS: &str = "120";
/// The demo recording and its truth.
const DEMO_IMU: &str = "out/demo/imu.bin";
const DEMO_TRUTH: &str = "out/demo/truth.csv";

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = workspace_root();
    std::env::set_current_dir(&root)?;
    let command = args.first().map(String::as_str);
    // Only `fuzz` takes arguments: another command's would be ignored, and the run would not be
    // the one asked for.
    if let Some(name) = command.filter(|c| COMMANDS.contains(c)) {
        check_arguments(name, &args[1..])?;
    }
    match command {
        Some("setup") => setup(),
        Some("demo") => demo(&root),
        Some("test") => test(&root),
        Some("size") => size(&root).map(|_| ()),
        Some("build-board") => build_board(&root),
        Some("bench") => bench(&root),
        Some("lint") => lint(),
        Some("fuzz") => fuzz(&args[1..]),
        _ => {
            eprintln!("usage: cargo xtask <setup|demo|test|bench|size|build-board|lint|fuzz>");
            std::process::exit(2)
        }
    }
}

/// The commands; only `fuzz` takes arguments (at most two case counts).
const COMMANDS: [&str; 8] = [
    "setup",
    "demo",
    "test",
    "bench",
    "size",
    "build-board",
    "lint",
    "fuzz",
];

/// Refuses arguments a command does not take (`cargo xtask demo other.bin` ran the demo on its
/// own recording without a word).
fn check_arguments(command: &str, args: &[String]) -> Result<()> {
    let most = if command == "fuzz" { 2 } else { 0 };
    if args.len() > most {
        bail!(
            "cargo xtask {command} takes {}: unexpected {:?}",
            if most == 0 {
                "no argument".to_owned()
            } else {
                format!("at most {most} arguments (CASES [RECORDING_CASES])")
            },
            &args[most..]
        );
    }
    Ok(())
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace")
        .to_path_buf()
}

/// Runs a command, echoing it; fails with its exit status.
fn run(cmd: &mut Command) -> Result<()> {
    eprintln!("$ {}", show(cmd));
    let status = cmd
        .status()
        .with_context(|| format!("cannot start {}", show(cmd)))?;
    if !status.success() {
        bail!("`{}` failed with {status}", show(cmd));
    }
    Ok(())
}

fn show(cmd: &Command) -> String {
    let mut s = cmd.get_program().to_string_lossy().into_owned();
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s
}

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

fn have(tool: &str, arg: &str) -> bool {
    Command::new(tool)
        .arg(arg)
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Checks and installs the prerequisites.
fn setup() -> Result<()> {
    let targets = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output();
    let installed = targets.as_ref().is_ok_and(|o| {
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .any(|l| l.trim() == THUMB)
    });
    if !installed {
        eprintln!("setup: installing the Rust target {THUMB}");
        run(Command::new("rustup").args(["target", "add", THUMB]))?;
    }
    if !have("qemu-system-arm", "--version") {
        eprintln!("setup: qemu-system-arm is missing; installing it with apt-get");
        let sudo = if is_root() { vec![] } else { vec!["sudo"] };
        let apt = |args: &[&str]| {
            let mut c = Command::new(if sudo.is_empty() { "apt-get" } else { "sudo" });
            if !sudo.is_empty() {
                c.arg("apt-get");
            }
            c.args(args).env("DEBIAN_FRONTEND", "noninteractive");
            run(&mut c)
        };
        apt(&["update", "-qq"])?;
        apt(&["install", "-y", "-qq", "qemu-system-arm"])
            .context("install qemu-system-arm (Debian/Ubuntu: apt-get install qemu-system-arm)")?;
    }
    if !have("defmt-print", "--version") {
        eprintln!("setup: defmt-print is missing; installing it (about 3 minutes)");
        run(cargo().args(["install", "defmt-print", "--locked"]))?;
    }
    if !on_path("flip-link") {
        eprintln!("setup: flip-link is missing; installing it (the board build's linker)");
        run(cargo().args(["install", "flip-link", "--locked"]))?;
    }
    eprintln!(
        "setup: rustup target {THUMB}, qemu-system-arm, defmt-print and flip-link are present"
    );
    Ok(())
}

/// True when `tool` is an executable file in a directory of `PATH`.
fn on_path(tool: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|path| std::env::split_paths(&path).any(|dir| dir.join(tool).is_file()))
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout.starts_with(b"0\n"))
}

/// Builds the firmware (release) and returns its ELF path.
fn build_firmware(root: &Path) -> Result<PathBuf> {
    run(cargo().args(["build", "--release", "-p", "firmware", "--target", THUMB]))?;
    Ok(target_dir(root, &mut cargo())?
        .join(THUMB)
        .join("release")
        .join("firmware"))
}

fn nav_bin(root: &Path) -> Result<PathBuf> {
    run(cargo().args(["build", "--release", "-p", "host-tests", "--bin", "nav"]))?;
    Ok(target_dir(root, &mut cargo())?.join("release").join("nav"))
}

/// The directory the builds of `cargo` (the command, with its environment) go to, as cargo
/// resolves it (`CARGO_TARGET_DIR`, `build.target-dir`, else `target/`), through `cargo
/// metadata`; relative paths are taken from the workspace `root`. Taking `target/` instead ran
/// a missing or stale `nav` and firmware when `CARGO_TARGET_DIR` was set.
fn target_dir(root: &Path, cargo: &mut Command) -> Result<PathBuf> {
    let out = cargo
        .args(["metadata", "--no-deps", "--format-version", "1"])
        .current_dir(root)
        .output()
        .context("cannot start cargo metadata")?;
    if !out.status.success() {
        bail!(
            "cargo metadata failed with {}:\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok(root.join(json_string_field(
        &String::from_utf8_lossy(&out.stdout),
        "target_directory",
    )?))
}

/// The value of the string field `key` in a JSON text (its first occurrence; the escapes cargo
/// writes in a path: `\\`, `\"`, `\/`).
fn json_string_field(json: &str, key: &str) -> Result<String> {
    let pattern = format!("\"{key}\":\"");
    let at = json
        .find(&pattern)
        .with_context(|| format!("no string field {key:?} in cargo's output"))?;
    let mut value = String::new();
    let mut chars = json[at + pattern.len()..].chars();
    while let Some(c) = chars.next() {
        match c {
            '"' => return Ok(value),
            '\\' => match chars.next() {
                Some(e @ ('\\' | '"' | '/')) => value.push(e),
                e => bail!("field {key:?}: escape \\{e:?} in a path"),
            },
            c => value.push(c),
        }
    }
    bail!("field {key:?}: the string does not end")
}

/// The main job: demo recording -> firmware in QEMU -> decoded log and solution.
fn demo(root: &Path) -> Result<()> {
    let (nav, elf) = prepare_demo(root)?;
    let started = std::time::Instant::now();
    run(&mut qemu(&elf))?;
    let qemu_s = started.elapsed().as_secs_f64();
    let log = std::fs::read_to_string(root.join("out/solution-firmware.csv"))?;
    let lines: Vec<&str> = log.lines().collect();
    // The header, the rows, and the end record that only a complete run writes (`nav report`
    // warns about a log without it).
    println!(
        "\nsolution log out/solution-firmware.csv: {} rows; the first, the last and the end record:",
        lines.len().saturating_sub(2)
    );
    let tail = lines.len().saturating_sub(2).max(2);
    for l in lines.iter().take(2).chain(lines.iter().skip(tail)) {
        println!("  {l}");
    }
    println!("QEMU run time: {qemu_s:.1} s ({DEMO_SECONDS} s of data at 400 Hz)");
    // Against the simulator's truth.
    run(Command::new(&nav).args([
        "report",
        "--solution",
        "out/solution-firmware.csv",
        "--truth",
        DEMO_TRUTH,
        "--at",
        "15,60,120",
    ]))?;

    // The harness on the same recording, same precision: the logs must be identical.
    let out = output(&mut host_replay(&nav, "f32", "out/solution-host.csv"))?;
    let host = std::fs::read_to_string(root.join("out/solution-host.csv"))?;
    if host != log {
        bail!("the firmware's and the host's solution logs differ (out/solution-*.csv)");
    }
    println!(
        "host harness (nav replay, f32, simulated ADIS16505 + driver): identical solution log\n{}",
        out.trim_end()
    );
    Ok(())
}

/// Generates the demo recording and builds the harness and the firmware.
fn prepare_demo(root: &Path) -> Result<(PathBuf, PathBuf)> {
    setup()?;
    let nav = nav_bin(root)?;
    let elf = build_firmware(root)?;
    std::fs::create_dir_all(root.join("out"))?;
    let [lat, lon, h] = DEMO_SITE;
    run(Command::new(&nav).args([
        "sim",
        "land-vehicle",
        "--grade",
        "fog",
        "--seed",
        "7",
        "--seconds",
        DEMO_SECONDS,
        "--format",
        "bin",
        "--out",
        "out/demo",
        "--set",
        &format!("lat_deg={lat}"),
        "--set",
        &format!("lon_deg={lon}"),
        "--set",
        &format!("h_m={h}"),
    ]))?;
    Ok((nav, elf))
}

/// The demo site as `nav` options.
fn site_args() -> [&'static str; 6] {
    let [lat, lon, h] = DEMO_SITE;
    ["--lat", lat, "--lon", lon, "--h", h]
}

/// `(max, mean)` guest instructions of an IMU sample's decode and conversion with the simulated
/// `device` on the demo recording (the run's exit status does not matter: the costs are logged
/// even when the alignment fails). The inertial method: the static one refuses a consumer
/// part's declared gyro bias before any sample is read.
fn device_costs(elf: &Path, device: &str) -> Result<(f64, f64)> {
    let mut c = Command::new("bash");
    c.arg("firmware/qemu-run.sh")
        .arg(elf)
        .args(["--device", device, "--align-method", "inertial"])
        .args([DEMO_IMU, "out/solution-firmware.csv"])
        .args(DEMO_SITE)
        .arg(DEMO_ALIGN_S);
    eprintln!("$ {}", show(&c));
    let out = c.output().context("run QEMU")?;
    imu_costs(&String::from_utf8_lossy(&out.stdout))
}

/// `(max, mean)` guest instructions of an IMU sample's decode and conversion, from a firmware
/// log.
fn imu_costs(log: &str) -> Result<(f64, f64)> {
    let at = log
        .find("decode + conversion")
        .with_context(|| format!("no IMU read costs in:\n{log}"))?;
    let part = &log[at..];
    Ok((number_after(part, "max")?, number_after(part, "mean")?))
}

/// The firmware in QEMU on the demo recording.
fn qemu(elf: &Path) -> Command {
    qemu_with_device(elf, "adis16505")
}

/// The firmware in QEMU on the demo recording with the simulated `device`.
fn qemu_with_device(elf: &Path, device: &str) -> Command {
    let mut c = Command::new("bash");
    c.arg("firmware/qemu-run.sh")
        .arg(elf)
        .args(["--device", device])
        .args([DEMO_IMU, "out/solution-firmware.csv"])
        .args(DEMO_SITE)
        .arg(DEMO_ALIGN_S);
    c
}

/// `nav replay` of the demo recording.
fn host_replay(nav: &Path, precision: &str, out: &str) -> Command {
    let mut c = Command::new(nav);
    c.args([
        "replay",
        "--imu",
        DEMO_IMU,
        "--align-seconds",
        DEMO_ALIGN_S,
        "--out",
        out,
    ])
    .args(site_args())
    .args(["--precision", precision, "--device", "adis16505"]);
    c
}

/// Runs a command and returns its standard output (failing on a non-zero status).
fn output(cmd: &mut Command) -> Result<String> {
    eprintln!("$ {}", show(cmd));
    let out = cmd
        .output()
        .with_context(|| format!("cannot start {}", show(cmd)))?;
    if !out.status.success() {
        bail!(
            "`{}` failed with {}:\n{}",
            show(cmd),
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// The first number after `key` in `text`.
fn number_after(text: &str, key: &str) -> Result<f64> {
    let at = text
        .find(key)
        .with_context(|| format!("'{key}' not found in:\n{text}"))?;
    let rest = text[at + key.len()..].trim_start();
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(rest.len());
    rest[..end]
        .parse()
        .with_context(|| format!("no number after '{key}'"))
}

/// Benchmark figures: guest instructions per navigation step (QEMU icount), host samples per
/// second, flash and RAM.
fn bench(root: &Path) -> Result<()> {
    let (nav, elf) = prepare_demo(root)?;
    let log = output(&mut qemu(&elf))?;
    let step = &log[log.find("instructions per navigation step").unwrap_or(0)..];
    let max = number_after(step, "instructions per navigation step: max")?;
    let mean = number_after(step, "mean")?;
    let adis = imu_costs(&log)?;
    // The data-ready latency and the 400 Hz cycle with the output stream's framing.
    let latency = number_after(&log[log.find("data-ready latency").unwrap_or(0)..], "max")?;
    let stream_at = log.find("per sample of the output stream").unwrap_or(0);
    let stream = (
        number_after(&log[stream_at..], "max")?,
        number_after(&log[stream_at..], "mean")?,
    );
    let cycle = number_after(
        &log[log.find("per 400 Hz cycle (mean)").unwrap_or(0)..],
        "=",
    )?;
    // The qemu board paints the stack at start and logs its high-water mark at the end.
    let peak_stack = number_after(&log, "peak stack:")?;
    // The ICM-42688-P and BMI088 paths: their gyros cannot gyrocompass, so the runs end at the
    // alignment (exit 5) after logging the driver's costs.
    let icm = device_costs(&elf, "icm42688")?;
    let bmi = device_costs(&elf, "bmi088")?;
    let f32_speed = number_after(
        &output(&mut host_replay(&nav, "f32", "out/bench-f32.csv"))?,
        "speed:",
    )?;
    let f64_speed = number_after(
        &output(&mut host_replay(&nav, "f64", "out/bench-f64.csv"))?,
        "speed:",
    )?;
    let align = align_costs(&nav, &elf)?;
    let aided = aided_costs(&elf, &nav)?;
    let mech = output(Command::new(&nav).arg("bench"))?;
    let mech_f32 = number_after(&mech, "mechanization f32:")?;
    let mech_f64 = number_after(&mech, "mechanization f64:")?;
    let osc = osc_speed(&nav)?;
    let osc_log = output(
        Command::new("bash")
            .arg("firmware/qemu-run.sh")
            .arg(elf.with_file_name("osc_bench")),
    )?;
    let line = &osc_log[osc_log
        .find("instructions per oscillator readout")
        .unwrap_or(0)..];
    let osc_readout = (number_after(line, "max")?, number_after(line, "mean")?);
    let end = &line[line.find("at a period's end").unwrap_or(0)..];
    let osc_period = (number_after(end, "max")?, number_after(end, "mean")?);
    let (text, data, bss) = size(root)?;
    println!("\n| figure | value |\n|---|---|");
    println!("| guest instructions per navigation step (f32, QEMU icount), max | {max:.0} |");
    println!("| guest instructions per navigation step (f32, QEMU icount), mean | {mean:.0} |");
    println!(
        "| guest instructions per IMU sample, decode + conversion, ADIS16505 (max / mean) | {:.0} / {:.0} |",
        adis.0, adis.1
    );
    println!(
        "| guest instructions per IMU sample, decode + conversion, ICM-42688-P, 5 FIFO packets (max / mean) | {:.0} / {:.0} |",
        icm.0, icm.1
    );
    println!(
        "| guest instructions per IMU sample, decode + conversion, BMI088, gyro + accel frames (max / mean) | {:.0} / {:.0} |",
        bmi.0, bmi.1
    );
    for (method, (max, mean), _) in &align {
        println!(
            "| guest instructions per alignment sample, {method}, rocking bench (max / mean) | {max:.0} / {mean:.0} |"
        );
    }
    for (method, _, lost) in &align {
        let value = lost.map_or("- (alignment refused: no summary)".to_owned(), |(m, o)| {
            format!("{m:.0} / {o:.0}")
        });
        println!(
            "| samples lost at 125 MIPS (QEMU icount shift 3), {method}, rocking bench (missed / channel overruns) | {value} |"
        );
    }
    for a in &aided {
        let (r, f) = (a.rate_hz, a.figures);
        println!(
            "| guest instructions per covariance propagation (21 states, f32, every 0.1 s), demo drive aided at {r} Hz, {f} (max / mean) | {:.0} / {:.0} |",
            a.propagation.0, a.propagation.1
        );
        println!(
            "| guest instructions per GNSS update, position or velocity, {r} Hz, {f} (max / mean) | {:.0} / {:.0} |",
            a.update.0, a.update.1
        );
        println!(
            "| guest instructions per stop update (zero velocity and rate), {r} Hz, {f} (max / mean) | {:.0} / {:.0} |",
            a.stop.0, a.stop.1
        );
        println!(
            "| guest instructions per 400 Hz sample, aided, amortised (mechanization, messages, propagations, updates, reports), {r} Hz fixes, {f}; target <= 21000 | {:.0} |",
            a.amortised
        );
        println!(
            "| samples lost at 125 MIPS (QEMU icount shift 3), aided, {r} Hz fixes, {f} (missed / channel overruns) | {:.0} / {:.0} |",
            a.lost.0, a.lost.1
        );
    }
    if let Some(a) = aided.first() {
        let [f, q, c, g] = a.ram;
        println!(
            "| static RAM of the aided phase's parts: filter (covariance, state, settings; in the aligner's slot, none of its own) / fix queue / filter channel / GNSS reader [B] | {f:.0} / {q:.0} / {c:.0} / {g:.0} |"
        );
    }
    println!(
        "| data-ready latency, line pended to sample queued (the simulated SPI transaction included), demo run, max [guest instructions] | {latency:.0} |"
    );
    println!(
        "| guest instructions per sample of the output stream (raw increments, progress and health frames, vibration metric; max / mean) | {:.0} / {:.0} |",
        stream.0, stream.1
    );
    println!(
        "| guest instructions per 400 Hz cycle, free inertial (IMU read + navigation + output stream with the rows' frames), mean; target <= 21000 | {cycle:.0} |"
    );
    println!("| host mechanization, f32, steps/s (one thread, no I/O) | {mech_f32:.0} |");
    println!("| host mechanization, f64, steps/s (one thread, no I/O) | {mech_f64:.0} |");
    println!("| host replay, f32, samples/s (one thread, I/O included) | {f32_speed:.0} |");
    println!("| host replay, f64, samples/s (one thread, I/O included) | {f64_speed:.0} |");
    println!(
        "| guest instructions per oscillator readout ([Oscillator INS], f32, 5 kHz; max / mean) | {:.0} / {:.0} |",
        osc_readout.0, osc_readout.1
    );
    println!(
        "| the same, a readout that ends a period (fit, frame, loop; 100 Hz; max / mean) | {:.0} / {:.0} |",
        osc_period.0, osc_period.1
    );
    println!(
        "| host oscillator estimator ([Oscillator INS]), f32 / f64, readouts/s (one thread, no I/O) | {:.0} / {:.0} |",
        osc.0, osc.1
    );
    println!("| flash (text + data) [B] | {} |", text + data);
    println!("| static RAM (data + bss) [B] | {} |", data + bss);
    println!(
        "| peak stack, demo run (static alignment, free inertial; the aligner on the stack) [B] | {peak_stack:.0} |"
    );
    Ok(())
}

/// The firmware's aided phase on the demo drive at one fix rate: guest instructions (max,
/// mean) per covariance propagation, per GNSS update, per stop update; per 400 Hz sample
/// amortised; samples lost at 125 MIPS (missed, overruns); the aided phase's static RAM parts.
struct AidedCost {
    rate_hz: f64,
    /// The IMU figures the filter assumed (the row's words).
    figures: &'static str,
    propagation: (f64, f64),
    update: (f64, f64),
    stop: (f64, f64),
    amortised: f64,
    lost: (f64, f64),
    ram: [f64; 4],
}

/// The demo's aided run as a configuration text for `nav config`: FOG noise, and the
/// filter's other figures a data sheet's (nav-core's `SensorFigures::DATASHEET`, what the
/// board's ADIS16505 assumes), so its consider states run.
const DATASHEET_FIGURES_CONFIG: &str = "lat-deg = 45\nlon-deg = 7.5\nh-m = 250\nalign-seconds = 15\n\
imu-noise = fog\naiding = on\ngyro-scale-sigma = 1e-3\naccel-scale-sigma = 1e-3\n\
gyro-cross-coupling-rad = 1.745e-3\naccel-cross-coupling-rad = 1.745e-3\n\
gyro-g-sensitivity = 1.78e-5\n";

/// [`AidedCost`] at 1 and 10 Hz fixes of a receiver at the IMU (0.5, 0.5, 1 m; velocity
/// 0.05, 0.05, 0.1 m/s), simulated from the demo's truth (`host-tests` example `gnss_fixes`),
/// the filter assuming the FOG grade the demo recording has (which has no cross-axis coupling
/// or g-sensitivity: its consider states cost nothing); and at 10 Hz with a data sheet's
/// figures instead (a configuration frame of [`DATASHEET_FIGURES_CONFIG`], `nav`'s `nav
/// config`), the board's costlier case.
fn aided_costs(elf: &Path, nav: &Path) -> Result<Vec<AidedCost>> {
    let mut costs = Vec::new();
    std::fs::create_dir_all("out")?;
    std::fs::write("out/datasheet-figures.txt", DATASHEET_FIGURES_CONFIG)?;
    run(Command::new(nav).args([
        "config",
        "out/datasheet-figures.txt",
        "--out",
        "out/datasheet-figures.bin",
    ]))?;
    for (rate, figures) in [
        ("1", "FOG figures"),
        ("10", "FOG figures"),
        ("10", "a data sheet's figures"),
    ] {
        let dir = format!("out/demo-gnss-{rate}hz");
        run(cargo()
            .args(["run", "--release", "-q", "-p", "host-tests"])
            .args([
                "--example",
                "gnss_fixes",
                "--",
                "simulate",
                DEMO_TRUTH,
                &dir,
                rate,
            ]))?;
        let log_at = |shift: &str| -> Result<String> {
            let mut c = Command::new("bash");
            c.arg("firmware/qemu-run.sh")
                .env("QEMU_ICOUNT_SHIFT", shift)
                .arg(elf)
                .args(["--imu-noise", "fog", "--gnss", &format!("{dir}/gnss.bin")]);
            if figures != "FOG figures" {
                c.args(["--config-frame", "out/datasheet-figures.bin"]);
            }
            c.args([DEMO_IMU, &format!("{dir}/fw.csv")])
                .args(DEMO_SITE)
                .arg(DEMO_ALIGN_S);
            output(&mut c)
        };
        let log = log_at("0")?;
        let pair = |key: &str| -> Result<(f64, f64)> {
            let at = log
                .find(key)
                .with_context(|| format!("no '{key}' in:\n{log}"))?;
            let part = &log[at + key.len()..];
            Ok((number_after(part, "max")?, number_after(part, "mean")?))
        };
        let ram_line = &log[log.find("aided phase static RAM").unwrap_or(0)..];
        let slow = log_at("3")?;
        let summary = &slow[slow.find("summary:").unwrap_or(0)..];
        costs.push(AidedCost {
            rate_hz: rate.parse()?,
            figures,
            propagation: pair("per covariance propagation:")?,
            update: pair("per GNSS update (position or velocity):")?,
            stop: pair("per stop update:")?,
            amortised: number_after(&log, "amortised total")?,
            lost: (
                number_after(summary, "missed")?,
                number_after(summary, "channel overruns")?,
            ),
            ram: [
                number_after(ram_line, "filter")?,
                number_after(ram_line, "fix queue")?,
                number_after(ram_line, "filter channel")?,
                number_after(ram_line, "GNSS reader")?,
            ],
        });
    }
    Ok(costs)
}

/// Host readouts per second of the oscillator estimator, `(f32, f64)`, over 20 s of a ship's
/// rocking recorded by `nav oscillator --readouts`.
fn osc_speed(nav: &Path) -> Result<(f64, f64)> {
    let file = "out/bench-osc.csv";
    run(Command::new(nav).args([
        "oscillator",
        "ship-rocking",
        "--seconds",
        "20",
        "--readouts",
        file,
    ]))?;
    let speed = |p: &str| -> Result<f64> {
        number_after(
            &output(Command::new(nav).args(["osc-replay", file, "--precision", p]))?,
            "estimator speed:",
        )
    };
    Ok((speed("f32")?, speed("f64")?))
}

/// `(method, (max, mean))` guest instructions per alignment sample of the firmware's alignment
/// task for every method, on 40 s of the simulator's rocking `auv-bench` (FOG grade; sway's
/// maximum is a filter interval of its period identification).
/// Per alignment method on the rocking bench: guest instructions per alignment sample (max,
/// mean) at QEMU's 1000 MIPS, and the samples the firmware lost (missed data-ready, channel
/// overruns) at 125 MIPS (`QEMU_ICOUNT_SHIFT=3`: slower than a 168 MHz Cortex-M4 with flash
/// wait states; whether the tasks keep up on the real part).
/// A method whose alignment refuses the swaying bench (`static`) ends without a summary: no
/// loss figure (`None`).
type AlignCost = (&'static str, (f64, f64), Option<(f64, f64)>);

fn align_costs(nav: &Path, elf: &Path) -> Result<Vec<AlignCost>> {
    run(Command::new(nav).args([
        "sim",
        "auv-bench",
        "--grade",
        "fog",
        "--seconds",
        "42",
        "--format",
        "bin",
        "--out",
        "out/bench-rock",
    ]))?;
    let mut costs = Vec::new();
    for method in ["static", "inertial", "fine", "sway"] {
        let log_at = |shift: &str| -> Result<String> {
            let mut c = Command::new("bash");
            c.arg("firmware/qemu-run.sh")
                .env("QEMU_ICOUNT_SHIFT", shift)
                .arg(elf)
                .args(["--align-method", method])
                // The recording is FOG-grade: the board's default (ADIS16505) noise prior would
                // have `fine` refuse gyros too coarse to find north.
                .args(["--imu-noise", "fog"]);
            if method == "sway" {
                // Sway needs the lever arm given: the bench's IMU is at the centre of rotation.
                c.args(["--lever-arm", "0,0,0"]);
            }
            c.args(["out/bench-rock/imu.bin", "out/bench-rock/fw.csv"])
                .args(["45", "30", "0", "40"]);
            eprintln!("$ QEMU_ICOUNT_SHIFT={shift} {}", show(&c));
            let out = c.output().context("run QEMU")?;
            Ok(String::from_utf8_lossy(&out.stdout).into_owned())
        };
        let log = log_at("0")?;
        let at = log
            .find("instructions per alignment sample")
            .with_context(|| format!("no alignment costs in:\n{log}"))?;
        let part = &log[at..];
        let slow = log_at("3")?;
        let lost = match slow.find("summary:") {
            Some(at) => Some((
                number_after(&slow[at..], "missed")?,
                number_after(&slow[at..], "channel overruns")?,
            )),
            None => None,
        };
        costs.push((
            method,
            (number_after(part, "max")?, number_after(part, "mean")?),
            lost,
        ));
    }
    Ok(costs)
}

/// Every test of the workspace, the QEMU end-to-end test included.
fn test(root: &Path) -> Result<()> {
    setup()?;
    let elf = build_firmware(root)?;
    target_tests(&elf)?;
    run(cargo()
        .args(["test", "--workspace", "--exclude", "firmware"])
        .env("FIRMWARE_ELF", &elf))?;
    // The board build: its flash and static RAM targets enforced.
    build_board(root)
}

/// The tests on the target: `target_tests` (beside the firmware `elf`) in QEMU; fails when
/// any of them fails (its exit status).
fn target_tests(elf: &Path) -> Result<()> {
    let log = output(
        Command::new("bash")
            .arg("firmware/qemu-run.sh")
            .arg(elf.with_file_name("target_tests")),
    )?;
    print!("{log}");
    if !log.contains("target tests:") || !log.contains(", 0 failed") {
        bail!("target tests: no summary of a passing run in the log");
    }
    Ok(())
}

/// Builds the STM32F405 board's firmware (profile `board`), prints its flash, static RAM and
/// largest statics and its flash by module; fails above [`BOARD_FLASH_MAX`] or
/// [`BOARD_RAM_MAX`].
/// Linked through `flip-link` (stack-overflow protection: the stack below the statics) when
/// it is installed (`cargo xtask setup` installs it).
fn build_board(root: &Path) -> Result<()> {
    let mut build = cargo();
    build.args([
        "build",
        "-p",
        "firmware",
        "--target",
        THUMB,
        "--profile",
        "board",
    ]);
    build.args(["--no-default-features", "--features", "stm32f405"]);
    if on_path("flip-link") {
        build.args([
            "--config",
            "target.thumbv7em-none-eabihf.linker='flip-link'",
        ]);
    } else {
        eprintln!(
            "build-board: flip-link is not installed: linked without stack-overflow protection \
             (cargo install flip-link)"
        );
    }
    run(&mut build)?;
    let elf = target_dir(root, &mut cargo())?
        .join(THUMB)
        .join("board")
        .join("firmware");
    let data = std::fs::read(&elf).with_context(|| format!("read {}", elf.display()))?;
    let (text, data_sz, bss) = section_sizes(&data)?;
    let (flash, ram) = (text + data_sz, data_sz + bss);
    println!(
        "board firmware (STM32F405, {}): flash {flash} B (target <= {BOARD_FLASH_MAX}), static RAM {ram} B (target <= {BOARD_RAM_MAX})",
        elf.display()
    );
    print_statics(&data)?;
    print_code_by_module(&data)?;
    if ram > BOARD_RAM_MAX {
        bail!("board firmware: static RAM {ram} B > {BOARD_RAM_MAX} B");
    }
    if flash > BOARD_FLASH_MAX {
        bail!("board firmware: flash {flash} B > {BOARD_FLASH_MAX} B");
    }
    let margin = BOARD_FLASH_MAX - flash;
    println!(
        "board firmware: within its flash and static RAM targets (flash margin {margin} B, {:.1} % of the target)",
        100.0 * margin as f64 / BOARD_FLASH_MAX as f64
    );
    Ok(())
}

/// Prints the ten largest statics (symbols in `.data`, `.bss`, `.uninit`) of an ELF.
fn print_statics(elf: &[u8]) -> Result<()> {
    let mut statics = sized_symbols(elf, &[".data", ".bss", ".uninit"])?;
    statics.sort_unstable_by(|a, b| b.cmp(a));
    println!("largest statics [B]:");
    for (size, name) in statics.iter().take(10) {
        println!("  {size:>6}  {name}");
    }
    Ok(())
}

/// Prints the flash taken by code and constants (symbols in `.text`, `.rodata`) grouped by
/// module: `crate::module::item` for the workspace's crates, `crate::module` for the others
/// (what to cut when the board's flash is above its target).
fn print_code_by_module(elf: &[u8]) -> Result<()> {
    let mut groups = std::collections::BTreeMap::<String, u64>::new();
    for (size, name) in sized_symbols(elf, &[".text", ".rodata"])? {
        *groups.entry(module_of(&name)).or_default() += size;
    }
    let mut groups: Vec<(u64, String)> = groups.into_iter().map(|(m, s)| (s, m)).collect();
    groups.sort_unstable_by(|a, b| b.cmp(a));
    println!("largest code by module (.text, .rodata) [B]:");
    for (size, module) in groups.iter().take(15) {
        println!("  {size:>6}  {module}");
    }
    Ok(())
}

/// The sized symbols of an ELF in the named sections (or their `.name.*` parts), demangled.
fn sized_symbols(elf: &[u8], sections: &[&str]) -> Result<Vec<(u64, String)>> {
    use object::{Object as _, ObjectSection as _, ObjectSymbol as _};
    let file = object::File::parse(elf).context("not an ELF")?;
    Ok(file
        .symbols()
        .filter_map(|sym| {
            let section = file.section_by_index(sym.section_index()?).ok()?;
            let name = section.name().ok()?;
            let wanted = sections
                .iter()
                .any(|s| name == *s || name.starts_with(&format!("{s}.")));
            (wanted && sym.size() > 0).then(|| (sym.size(), demangle(sym.name().unwrap_or("?"))))
        })
        .collect())
}

/// The module a demangled symbol belongs to: an impl's (`<a..b..T as ..>::f`) by its type's
/// path; three parts deep for the workspace's crates, two for the others.
fn module_of(name: &str) -> String {
    if let Some(path) = v0_path(name) {
        return module_of(&path);
    }
    let path = name.trim_start_matches(['_', '<']).replace("..", "::");
    let mut words = path.split("$u20$");
    let own = words.next().unwrap_or_default();
    // `<&T as Trait>::f`: the trait's module.
    let path = match (own.starts_with("$RF$"), words.nth(1)) {
        (true, Some(tr)) => tr,
        _ => own,
    };
    let parts: Vec<&str> = path
        .split("::")
        .map(|p| p.split(['$', '<', '>']).next().unwrap_or_default())
        .filter(|p| !p.is_empty())
        .collect();
    let ours = matches!(
        parts.first(),
        Some(&("nav_core" | "firmware" | "hal_adapters"))
    );
    parts[..parts.len().min(if ours { 3 } else { 2 })].join("::")
}

/// The identifiers of a v0-mangled symbol's path (`_R`...: core's, as shipped), joined by
/// `::` (its crate first; enough to group by module, not a full demangler).
fn v0_path(name: &str) -> Option<String> {
    let rest = name.strip_prefix("_R")?;
    let crate_at = rest.find("Cs")? + 2;
    let mut rest = &rest[crate_at + rest[crate_at..].find('_')? + 1..];
    let mut parts = Vec::new();
    while let Some(end) = rest.find(|c: char| !c.is_ascii_digit()).filter(|&e| e > 0) {
        let len: usize = rest[..end].parse().ok()?;
        parts.push(rest.get(end..end + len)?);
        // Skip the namespace tags between identifiers (`Nv`, `Nt`, ...).
        rest = rest[end + len..].trim_start_matches(|c: char| c.is_ascii_alphabetic());
    }
    (!parts.is_empty()).then(|| parts.join("::"))
}

/// A legacy-mangled Rust symbol (`_ZN` length-prefixed parts, hash last) as `a::b::c`.
fn demangle(name: &str) -> String {
    let Some(mut rest) = name.strip_prefix("_ZN") else {
        return name.to_owned();
    };
    let mut parts = Vec::new();
    while let Some(len_end) = rest.find(|c: char| !c.is_ascii_digit()) {
        let Ok(len) = rest[..len_end].parse::<usize>() else {
            break;
        };
        let Some(part) = rest.get(len_end..len_end + len) else {
            break;
        };
        parts.push(part);
        rest = &rest[len_end + len..];
    }
    if parts
        .last()
        .is_some_and(|p| p.starts_with('h') && p.len() == 17)
    {
        parts.pop();
    }
    parts.join("::").replace("$LT$", "<").replace("$GT$", ">")
}

/// The decoder fuzz targets with `args[0]` cases each (default 100 000), then the
/// mutated-recording properties with `args[1]` per format (default 1000).
fn fuzz(args: &[String]) -> Result<()> {
    let count = |i: usize, default: u32| -> Result<String> {
        match args.get(i) {
            None => Ok(default.to_string()),
            // 0 cases would pass without fuzzing anything.
            Some(a) => a
                .parse::<u32>()
                .ok()
                .filter(|&n| n > 0)
                .map(|n| n.to_string())
                .with_context(|| format!("fuzz: case count {a:?} is not a positive number")),
        }
    };
    let (decoders, recordings) = (count(0, 100_000)?, count(1, 1000)?);
    // One thread: each target's wall time is its own.
    let targets = [
        ("hal-adapters", "fuzz_decoders", &decoders),
        ("host-tests", "mutated_recordings", &recordings),
    ];
    for (package, test, cases) in targets {
        let started = std::time::Instant::now();
        run(cargo()
            .args(["test", "--release", "-p", package, "--test", test])
            .args(["--", "--nocapture", "--test-threads", "1"])
            .env("PROPTEST_CASES", cases))?;
        eprintln!(
            "fuzz: {package} {test}: {cases} cases per target, {:.1} s in all",
            started.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// Flash and RAM use of the release firmware.
fn size(root: &Path) -> Result<(u64, u64, u64)> {
    let elf = build_firmware(root)?;
    let data = std::fs::read(&elf).with_context(|| format!("read {}", elf.display()))?;
    let (text, data_sz, bss) = section_sizes(&data)?;
    println!(
        "firmware size: text {text} B, data {data_sz} B, bss {bss} B; flash {} B of 1048576, static RAM {} B of 131072",
        text + data_sz,
        data_sz + bss
    );
    print_statics(&data)?;
    Ok((text, data_sz, bss))
}

/// Sums allocated ELF sections like `size -A`: executable or read-only (text), initialised
/// writable (data), NOBITS (bss).
fn section_sizes(elf: &[u8]) -> Result<(u64, u64, u64)> {
    use object::elf;
    use object::read::elf::{ElfFile32, FileHeader as _, SectionHeader as _};
    let file = ElfFile32::<object::Endianness>::parse(elf).context("not a 32-bit ELF")?;
    let endian = file.endian();
    let (mut text, mut data, mut bss) = (0, 0, 0);
    for s in file.elf_header().section_headers(endian, elf)? {
        let flags = s.sh_flags(endian);
        if flags & elf::SHF_ALLOC == 0 {
            continue;
        }
        let sz = u64::from(s.sh_size(endian));
        if s.sh_type(endian) == elf::SHT_NOBITS {
            bss += sz;
        } else if flags & elf::SHF_WRITE != 0 {
            data += sz;
        } else {
            text += sz;
        }
    }
    Ok((text, data, bss))
}

/// Formatting, clippy (host and thumb) and docs.
fn lint() -> Result<()> {
    run(cargo().args(["fmt", "--all", "--", "--check"]))?;
    let host = ["--workspace", "--exclude", "firmware", "--all-targets"];
    let thumb = [
        "--target",
        THUMB,
        "-p",
        "nav-core",
        "-p",
        "hal-adapters",
        "-p",
        "firmware",
    ];
    let thumb_features = [
        "--target",
        THUMB,
        "-p",
        "hal-adapters",
        "--features",
        "semihosting,defmt",
    ];
    let board = [
        "--target",
        THUMB,
        "-p",
        "firmware",
        "--no-default-features",
        "--features",
        "stm32f405",
    ];
    for selection in [&host[..], &thumb, &thumb_features, &board] {
        run(cargo()
            .arg("clippy")
            .args(selection)
            .args(["--", "-D", "warnings"]))?;
    }
    run(cargo()
        .args([
            "doc",
            "--no-deps",
            "-p",
            "nav-core",
            "-p",
            "hal-adapters",
            "-p",
            "host-tests",
            "-p",
            "xtask",
        ])
        .env("RUSTDOCFLAGS", "-D warnings"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_builds_are_found_where_cargo_puts_them() {
        let root = workspace_root();
        let elsewhere = std::env::temp_dir().join("xtask-target \"dir\"");
        let dir = target_dir(&root, cargo().env("CARGO_TARGET_DIR", &elsewhere)).unwrap();
        assert_eq!(dir, elsewhere);
        let relative = target_dir(&root, cargo().env("CARGO_TARGET_DIR", "t2")).unwrap();
        assert_eq!(relative, root.join("t2"));
    }

    #[test]
    fn a_json_path_is_unescaped() {
        let json = r#"{"packages":[],"target_directory":"C:\\a \"b\"\/c","version":1}"#;
        assert_eq!(
            json_string_field(json, "target_directory").unwrap(),
            r#"C:\a "b"/c"#
        );
        assert!(json_string_field(r#"{"target_directory":"abc"#, "target_directory").is_err());
        assert!(json_string_field("{}", "target_directory").is_err());
    }

    #[test]
    fn arguments_a_command_does_not_take_are_refused() {
        let words = |w: &[&str]| w.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let e = check_arguments("demo", &words(&["other.bin"])).unwrap_err();
        assert!(e.to_string().contains("takes no argument"), "{e}");
        assert!(check_arguments("demo", &[]).is_ok());
        assert!(check_arguments("fuzz", &words(&["10", "2"])).is_ok());
        let e = check_arguments("fuzz", &words(&["10", "2", "3"])).unwrap_err();
        assert!(e.to_string().contains("at most 2"), "{e}");
        // Refused before anything is built.
        for counts in [["0", "5"], ["5", "0"], ["-1", "5"], ["x", "5"]] {
            let e = fuzz(&words(&counts)).unwrap_err();
            assert!(e.to_string().contains("not a positive number"), "{e}");
        }
    }
}
