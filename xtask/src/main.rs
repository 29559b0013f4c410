//! `cargo xtask <command>`: the project's automation.
//!
//! - `setup`: checks the prerequisites and installs what is missing (rustup target,
//!   qemu-system-arm, defmt-print).
//! - `demo`: the main job: generates the demo recording, builds the firmware, runs it in QEMU and
//!   prints the decoded defmt log and the navigation result.
//! - `test`: builds the firmware, then runs every test of the workspace (the QEMU end-to-end test
//!   included).
//! - `size`: release build of the firmware and its flash/RAM use.
//! - `lint`: `cargo fmt --check`, clippy with `-D warnings` for the host crates and for the
//!   no_std crates and the firmware on the thumb target, and the docs with `-D warnings`.

use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::process::Command;

const THUMB: &str = "thumbv7em-none-eabihf";

/// The demo: 60 s at rest at 45 deg N, 7.5 deg E, 150 m, attitude (1.5, -2, 30) deg; 30 s of
/// static alignment, then 30 s of navigation.
const DEMO_SITE: [&str; 3] = ["45", "7.5", "150"];
const DEMO_ALIGN_S: &str = "30";

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = workspace_root();
    std::env::set_current_dir(&root)?;
    match args.first().map(String::as_str) {
        Some("setup") => setup(),
        Some("demo") => demo(&root),
        Some("test") => test(&root),
        Some("size") => size(&root).map(|_| ()),
        Some("lint") => lint(),
        _ => {
            eprintln!("usage: cargo xtask <setup|demo|test|size|lint>");
            std::process::exit(2)
        }
    }
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
    eprintln!("setup: rustup target {THUMB}, qemu-system-arm and defmt-print are present");
    Ok(())
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
    Ok(root
        .join("target")
        .join(THUMB)
        .join("release")
        .join("firmware"))
}

fn nav_bin(root: &Path) -> Result<PathBuf> {
    run(cargo().args(["build", "--release", "-p", "host-tests", "--bin", "nav"]))?;
    Ok(root.join("target/release/nav"))
}

/// The main job: demo recording -> firmware in QEMU -> decoded log and solution.
fn demo(root: &Path) -> Result<()> {
    setup()?;
    let nav = nav_bin(root)?;
    let elf = build_firmware(root)?;
    std::fs::create_dir_all(root.join("out"))?;
    run(Command::new(&nav).args([
        "generate",
        "--out",
        "out/demo.bin",
        "--seconds",
        "60",
        "--rate",
        "400",
        "--lat",
        DEMO_SITE[0],
        "--lon",
        DEMO_SITE[1],
        "--h",
        DEMO_SITE[2],
        "--roll",
        "1.5",
        "--pitch",
        "-2",
        "--yaw",
        "30",
    ]))?;
    let started = std::time::Instant::now();
    run(Command::new("bash")
        .arg("firmware/qemu-run.sh")
        .arg(&elf)
        .args(["out/demo.bin", "out/solution-firmware.csv"])
        .args(DEMO_SITE)
        .arg(DEMO_ALIGN_S))?;
    let qemu_s = started.elapsed().as_secs_f64();
    let log = std::fs::read_to_string(root.join("out/solution-firmware.csv"))?;
    let rows: Vec<&str> = log.lines().collect();
    println!(
        "\nsolution log out/solution-firmware.csv: {} rows; first and last:",
        rows.len().saturating_sub(1)
    );
    for l in rows.iter().take(2).chain(rows.last()) {
        println!("  {l}");
    }
    println!("QEMU run time: {qemu_s:.1} s (60 s of data at 400 Hz)");
    Ok(())
}

/// Every test of the workspace, the QEMU end-to-end test included.
fn test(root: &Path) -> Result<()> {
    setup()?;
    let elf = build_firmware(root)?;
    run(cargo()
        .args(["test", "--workspace", "--exclude", "firmware"])
        .env("FIRMWARE_ELF", &elf))
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
    for selection in [&host[..], &thumb, &thumb_features] {
        run(cargo()
            .arg("clippy")
            .args(selection)
            .args(["--", "-D", "warnings"]))?;
    }
    run(cargo()
        .args(["doc", "--no-deps", "-p", "nav-core", "-p", "hal-adapters"])
        .env("RUSTDOCFLAGS", "-D warnings"))
}
