//! The `qemu` board: QEMU's netduinoplus2 (an STM32F405 without an RCC model).
//!
//! - No clock set-up (it would hang on a ready bit QEMU never sets): the core runs at QEMU's
//!   fixed 168 MHz and SysTick is the monotonic.
//! - The IMU's data-ready line is emulated: [`emulate_data_ready`] pends `EXTI0` (the line a real
//!   data-ready pin uses) every 2.5 ms of SysTick time, and the IMU is a real driver over a
//!   simulated SPI device answering from a recording (`crate::imu`), read through semihosting.
//! - The compiled-in configuration is the semihosting command line (`crate::config`), the
//!   calibration and the GNSS fixes host files, the solution log and the protocol stream
//!   (`--stream`) host files, the host's configuration input a host file (`--config-frame`:
//!   its bytes are there at once, so the standby window is 0, [`STANDBY_US`]: a frame in it
//!   gives the run's configuration, replacing the command line's), defmt over semihosting
//!   stdout, and [`exit`] QEMU's exit status.
//!
//! Under QEMU's `-icount shift=0` one guest instruction takes exactly 1 ns of virtual time, so
//! SysTick timing is exact and the instruction counts the firmware prints are repeatable.

use super::{Board, DataReady, pac::Interrupt};
use crate::config::{Args, USAGE};
use crate::imu::BoardImu;
use crate::{ExitCode, log};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use cortex_m::peripheral::{NVIC, SYST};
use defmt_semihosting as _; // global defmt logger over semihosting stdout
use hal_adapters::drivers::{Error as ImuError, Health};
use hal_adapters::io::{Buffered, SemihostingFile};
use hal_adapters::protocol::config::BoardIdentity;
use hal_adapters::recording::{Header, RECORD_LEN, Record, Replay, record_offset};
use hal_adapters::sim::{SimBmi088, SimError, health_at_end};
use nav_core::calibration::ImuCalibration;
use nav_core::navigator::Setup;
use rtic_monotonics::systick::prelude::*;

pub use crate::gnss::Fixes;

/// Core clock [Hz]: QEMU's netduinoplus2 runs at 168 MHz, as the real part does.
const SYSCLK_HZ: u32 = 168_000_000;
/// SysTick monotonic rate [Hz]: one tick (and one SysTick interrupt) per data-ready period;
/// finer times read the SysTick counter ([`counts`]). Under QEMU every timer interrupt costs
/// host time, so fewer ticks make the replay 2.5x faster than 2 kHz ticks did.
const TICK_HZ: u32 = 400;
systick_monotonic!(Mono, 400);
/// SysTick counts per monotonic tick.
const COUNTS_PER_TICK: u64 = (SYSCLK_HZ / TICK_HZ) as u64;
/// The IMU's data-ready period: 400 Hz.
const DATA_READY_TICKS: u64 = (TICK_HZ / 400) as u64;
/// A duration in monotonic ticks.
type MonoDuration = fugit::Duration<u64, 1, 400>;
/// Bytes read from the host per semihosting call.
const READ_CHUNK: usize = 512;
/// The standby window [us]: none, the configuration frame's file is read before the first
/// sample (a frame in it decides the run; without one the command line's configuration runs).
pub const STANDBY_US: u64 = 0;

/// The recording the simulated IMU answers from.
type Recording = Replay<Buffered<SemihostingFile, READ_CHUNK>>;

/// Where the BMI088's simulated device lives (shared by its two chip selects).
pub type ImuSlot = Option<SimBmi088<Recording>>;
/// The empty [`ImuSlot`].
pub const IMU_SLOT: ImuSlot = None;

/// Data-ready edges lost because the previous one was still pending.
static MISSED: AtomicU32 = AtomicU32::new(0);
/// The [`counts`] reading (low 32 bits) when the pacer last pended the data-ready line.
static PENDED_AT: AtomicU32 = AtomicU32::new(0);
/// Set once the end of the recording has been delivered: the pacer stops.
static STOP: AtomicBool = AtomicBool::new(false);

/// Brings the board up: the monotonic, the command line, the calibration, the recording and
/// the IMU over it, the solution log and the GNSS file. Exits with the matching
/// [`ExitCode`] when any of them is refused.
pub fn init(
    core: cortex_m::Peripherals,
    _device: super::pac::Peripherals,
    slot: &'static mut ImuSlot,
) -> Board {
    paint_stack();
    Mono::start(core.SYST, SYSCLK_HZ);
    let mut args = read_args();
    if let Err(e) = args.run.validate() {
        bad_config(&e)
    }
    args.run.calibration = read_calibration(&args);
    let run = args.run;
    let file = SemihostingFile::open(args.imu_cstr()).unwrap_or_else(|_| {
        defmt::error!("cannot open the recording {=str}", shown(&args.imu_path));
        exit(ExitCode::Recording)
    });
    let len = file.0.metadata().map(|m| m.len());
    let source = Replay::new(Buffered::new(file)).unwrap_or_else(|e| {
        defmt::error!(
            "recording {=str}: {}",
            shown(&args.imu_path),
            defmt::Display2Format(&e)
        );
        exit(ExitCode::Recording)
    });
    let header = *source.header();
    // The header's count against the file's length, before anything is navigated (the
    // harness's rule: a cut or a tail was found only at the end, the log nearly complete).
    let Ok(len) = len else {
        defmt::error!(
            "recording {=str}: its length cannot be read",
            shown(&args.imu_path)
        );
        exit(ExitCode::Recording)
    };
    if let Err(e) = header.check_file_len(len) {
        defmt::error!(
            "recording {=str}: {}",
            shown(&args.imu_path),
            defmt::Display2Format(&e)
        );
        exit(ExitCode::Recording)
    }
    defmt::info!(
        "recording: {=u32} samples at {=f64} Hz",
        header.sample_count,
        header.rate_hz
    );
    if let Err(e) = hal_adapters::sim::check_source_rate(header.rate_hz) {
        defmt::error!(
            "recording {=str}: {}",
            shown(&args.imu_path),
            defmt::Display2Format(&e)
        );
        exit(ExitCode::Recording)
    }
    if let Err(e) = Setup::<f32>::new(&run, header.rate_hz) {
        bad_config(&e)
    }
    let device = args.device;
    let imu = BoardImu::new(device, args.imu_mounting, source, slot).unwrap_or_else(|e| {
        defmt::error!("IMU {} init failed: {}", device, e);
        exit(ExitCode::Recording)
    });
    defmt::info!("IMU: {} over a simulated SPI device", device);
    refuse_overwriting_data(args.out_cstr(), "OUT_FILE", &args);
    if let Some(path) = args.stream_cstr() {
        refuse_overwriting_data(path, "--stream FILE", &args);
    }
    let gnss = args.gnss_cstr().map(|path| {
        let fail = |e: &dyn core::fmt::Display| -> ! {
            let name = args.gnss_path.as_deref().unwrap_or_default();
            let name = name.strip_suffix(&[0]).unwrap_or(name);
            defmt::error!(
                "GNSS file {=str}: {}",
                core::str::from_utf8(name).unwrap_or("(not UTF-8)"),
                defmt::Display2Format(e)
            );
            exit(ExitCode::Recording)
        };
        // Checked whole before anything is navigated, then read as the samples come.
        let summary = crate::gnss::check(path).unwrap_or_else(|e| fail(&e));
        // Every fix before the first sample's interval or after the last record: refused
        // before anything is navigated, as the harness does (the firmware navigated the run
        // free-inertial, its rows NAV, and refused it only at its end). Fixes on both sides
        // of the data are left to the end's test.
        if let (Some(fixes), Some(data)) = (summary.span_us, data_span_us(&args, &header))
            && (fixes.1 < data.0 || fixes.0 > data.1)
        {
            crate::log::no_fix_in_span(fixes, data);
            exit(ExitCode::Recording)
        }
        let fixes = Fixes::open(path, &summary).unwrap_or_else(|e| fail(&e));
        log::gnss(summary.count, &run, crate::FILTER_CAP);
        (fixes, summary.count)
    });
    // Created once the inputs are accepted: a refused GNSS file leaves no log.
    let out = SemihostingFile::create(args.out_cstr()).unwrap_or_else(|_| {
        defmt::error!(
            "cannot create the solution log {=str}",
            shown(&args.out_path)
        );
        exit(ExitCode::Output)
    });
    let stream = args.stream_cstr().map(|path| {
        let file = SemihostingFile::create(path).unwrap_or_else(|_| {
            defmt::error!(
                "cannot create the stream {=str}",
                shown(args.stream_path.as_deref().unwrap_or_default())
            );
            exit(ExitCode::Output)
        });
        (file, heapless::Vec::new())
    });
    let config_in = ConfigInput(args.config_frame_cstr().map(|path| {
        SemihostingFile::open(path).unwrap_or_else(|_| {
            defmt::error!(
                "cannot open the configuration frame {=str}",
                shown(args.config_frame_path.as_deref().unwrap_or_default())
            );
            exit(ExitCode::Config)
        })
    }));
    Board {
        imu: Imu(imu),
        out: Output { log: out, stream },
        config_in,
        watchdog: Watchdog,
        identity: BoardIdentity {
            imu_model: device.model(),
            imu_rate_hz: header.rate_hz,
            mounting: crate::imu::MOUNTING,
            gnss: gnss.is_some(),
        },
        gnss,
        run,
    }
}

/// The IMU data's span [us]: from the header's start of the first sample's interval to the
/// last record's time (read from the file); `None` when that record cannot be read.
fn data_span_us(args: &Args, header: &Header) -> Option<(u64, u64)> {
    use semihosting::io::{Read as _, Seek as _, SeekFrom};
    let last = header.sample_count.checked_sub(1)?;
    let mut file = semihosting::fs::File::open(args.imu_cstr()).ok()?;
    file.seek(SeekFrom::Start(record_offset(last))).ok()?;
    let mut bytes = [0; RECORD_LEN];
    file.read_exact(&mut bytes).ok()?;
    let record = Record::decode(&bytes, record_offset(last), last).ok()?;
    Some((header.t0_ns / 1000, record.t_ns / 1000))
}

/// Parses the semihosting command line into the firmware's [`Args`]; exits with
/// [`ExitCode::Config`] on error.
fn read_args() -> Args {
    let args = semihosting::experimental::env::args::<512>().unwrap_or_else(|_| {
        defmt::error!("no semihosting command line: run through firmware/qemu-run.sh");
        exit(ExitCode::Config)
    });
    let words = (&args).map(|a| a.unwrap_or("")).skip(1);
    Args::parse(words).unwrap_or_else(|e| {
        defmt::error!(
            "bad arguments ({}); usage: {=str}",
            defmt::Display2Format(&e),
            USAGE
        );
        exit(ExitCode::Config)
    })
}

/// Exits with [`ExitCode::Config`] when the output `path` (`name` in the usage) already holds
/// a recording or a GNSS fix file (their magic), or the same bytes as the calibration or the
/// configuration frame file: an input reached by a path that [`Args::parse`]'s comparison as
/// written does not see (absolute against relative, a link) would be truncated before it is
/// read (a calibration was replaced by the solution log, exit 0).
fn refuse_overwriting_data(path: &core::ffi::CStr, name: &str, args: &Args) {
    let Ok(mut file) = SemihostingFile::open(path) else {
        return;
    };
    for (input, input_name) in [
        (args.cal_cstr(), "CAL_FILE"),
        (args.config_frame_cstr(), "the --config-frame FILE"),
    ] {
        if let Some(input) = input
            && same_bytes(path, input)
        {
            defmt::error!(
                "bad arguments ({=str} {=str} holds the same bytes as {=str}: refusing to overwrite it)",
                name,
                shown(path.to_bytes()),
                input_name
            );
            exit(ExitCode::Config)
        }
    }
    let mut head = [0_u8; 8];
    read_full(&mut file, &mut head);
    let kind = match head {
        hal_adapters::recording::MAGIC => "an IMU recording",
        hal_adapters::gnss_record::MAGIC => "a GNSS fix file",
        _ => return,
    };
    defmt::error!(
        "bad arguments ({=str} {=str} holds {=str}: refusing to overwrite it)",
        name,
        shown(path.to_bytes()),
        kind
    );
    exit(ExitCode::Config)
}

/// Reads `file` into `buf` until it is full or the file ends; the bytes read.
fn read_full(file: &mut SemihostingFile, buf: &mut [u8]) -> usize {
    let mut len = 0;
    while len < buf.len() {
        match embedded_io::Read::read(file, &mut buf[len..]) {
            Ok(0) | Err(_) => break,
            Ok(n) => len += n,
        }
    }
    len
}

/// The files `a` and `b` both open and hold the same bytes, not none (one file reached two
/// ways, or a copy: either way the output would destroy what the run reads; an empty file
/// holds nothing to lose).
fn same_bytes(a: &core::ffi::CStr, b: &core::ffi::CStr) -> bool {
    let (Ok(mut fa), Ok(mut fb)) = (SemihostingFile::open(a), SemihostingFile::open(b)) else {
        return false;
    };
    let (mut ba, mut bb) = ([0_u8; 64], [0_u8; 64]);
    let mut total = 0;
    loop {
        let (na, nb) = (read_full(&mut fa, &mut ba), read_full(&mut fb, &mut bb));
        if ba[..na] != bb[..nb] {
            return false;
        }
        total += na;
        if na < ba.len() {
            return total > 0;
        }
    }
}

/// Logs a refused run configuration and exits with [`ExitCode::Config`].
/// A path of the command line as the user typed it: without the terminating NUL its
/// semihosting call needs (a path that is not UTF-8 is named so).
fn shown(path: &[u8]) -> &str {
    core::str::from_utf8(path.strip_suffix(&[0]).unwrap_or(path)).unwrap_or("(a path not in UTF-8)")
}

fn bad_config(e: &dyn core::fmt::Display) -> ! {
    defmt::error!("invalid configuration: {}", defmt::Display2Format(e));
    exit(ExitCode::Config)
}

/// Loads the sensor calibration (identity without a file); exits with [`ExitCode::Config`]
/// when it cannot be read or parsed.
fn read_calibration(args: &Args) -> ImuCalibration {
    let Some(path) = args.cal_cstr() else {
        return ImuCalibration::default();
    };
    let fail = |what: &dyn core::fmt::Display| -> ! {
        defmt::error!(
            "calibration {=str}: {}",
            shown(args.cal_path.as_deref().unwrap_or_default()),
            defmt::Display2Format(what)
        );
        exit(ExitCode::Config)
    };
    let mut file = SemihostingFile::open(path).unwrap_or_else(|_| fail(&"cannot open"));
    let mut text = [0_u8; 2048];
    let mut len = 0;
    loop {
        match embedded_io::Read::read(&mut file, &mut text[len..]) {
            Ok(0) => break,
            Ok(n) => len += n,
            Err(_) => fail(&"read error"),
        }
        if len == text.len() {
            fail(&"longer than 2048 bytes");
        }
    }
    let text = core::str::from_utf8(&text[..len]).unwrap_or_else(|_| fail(&"not UTF-8 text"));
    let calibration = ImuCalibration::parse(text).unwrap_or_else(|e| fail(&e));
    if let Err(e) = calibration.compensation::<f32>() {
        fail(&e)
    }
    defmt::info!("calibration loaded: {=usize} bytes", len);
    calibration
}

/// SysTick counts since start (monotonic ticks plus the counter's progress in this tick).
pub fn counts() -> u64 {
    loop {
        let before = Mono::now().as_ticks();
        let current = u64::from(SYST::get_current());
        if Mono::now().as_ticks() == before {
            return before * COUNTS_PER_TICK + (COUNTS_PER_TICK - 1 - current);
        }
    }
}

/// Board time since start [us] (also the defmt timestamp).
pub fn now_us() -> u64 {
    counts() / u64::from(SYSCLK_HZ / 1_000_000)
}

/// Guest instructions since the [`counts`] reading `start`: 1 ns per instruction under QEMU's
/// `-icount shift=0`, 168 counts per us.
pub fn instructions_since(start: u64) -> u64 {
    (counts() - start) * 1_000_000_000 / u64::from(SYSCLK_HZ)
}

/// Guest instructions since the data-ready line was last pended (the data-ready task's
/// latency when read as it queues the sample).
pub fn since_data_ready() -> Option<u32> {
    let counts = (counts() as u32).wrapping_sub(PENDED_AT.load(Ordering::Relaxed));
    Some((u64::from(counts) * 1_000_000_000 / u64::from(SYSCLK_HZ)) as u32)
}

/// Data-ready edges lost because the previous one was still pending.
pub fn missed_data_ready() -> u32 {
    MISSED.load(Ordering::Relaxed)
}

/// The emulated data-ready line (run by the app's `pace` task): pends `EXTI0` every 2.5 ms,
/// exactly, until the recording's end has been delivered.
pub async fn emulate_data_ready() {
    let mut next = Mono::now();
    while !STOP.load(Ordering::Relaxed) {
        next += MonoDuration::from_ticks(DATA_READY_TICKS);
        Mono::delay_until(next).await;
        if NVIC::is_pending(Interrupt::EXTI0) {
            MISSED.fetch_add(1, Ordering::Relaxed);
        }
        PENDED_AT.store(counts() as u32, Ordering::Relaxed);
        rtic::pend(Interrupt::EXTI0);
    }
}

/// The IMU: a real driver over a simulated SPI device fed by the recording.
pub struct Imu(BoardImu<Recording>);

impl Imu {
    /// Reads one sample at data-ready time `t_ready_us` [us]; `None` when there is nothing to
    /// hand on (a corrupt frame, counted in the driver's health and logged).
    pub fn read(&mut self, t_ready_us: u64) -> Option<DataReady> {
        let imu = &mut self.0;
        let read = imu.read(t_ready_us, counts);
        let to_instructions = |c: u64| (c * 1_000_000_000 / u64::from(SYSCLK_HZ)) as u32;
        Some(match read.result {
            Ok(sample) => DataReady::Sample {
                sample,
                t_ready_us,
                bus_instr: to_instructions(read.bus_counts),
                decode_instr: to_instructions(read.decode_counts),
            },
            Err(ImuError::Spi(SimError::End)) => {
                // The simulated device ends the recording by failing the bus: not a bus error.
                DataReady::End {
                    health: health_at_end(imu.health()),
                }
            }
            Err(ImuError::Spi(SimError::Source(e))) => {
                defmt::error!("recording: {}", defmt::Display2Format(&e));
                DataReady::SourceError
            }
            Err(e) if e.is_transient() => {
                // A corrupt frame: counted in the driver's health, nothing to navigate.
                let n = imu.health().checksum_errors;
                if n <= 10 || n.is_multiple_of(1000) {
                    defmt::warn!("IMU frame rejected: {} ({=u32} so far)", e, n);
                }
                return None;
            }
            Err(e) => {
                defmt::error!("IMU failed: {}", e);
                DataReady::SourceError
            }
        })
    }

    /// Called once the source's last message has been handed on: the pacer stops.
    pub fn ended(&mut self) {
        STOP.store(true, Ordering::Relaxed);
    }

    /// The driver's counters.
    pub fn health(&self) -> Health {
        self.0.health()
    }
}

/// The board keeps the solution log (CSV text) beside the stream.
pub const CSV_LOG: bool = true;

/// Stream bytes gathered per semihosting write.
const STREAM_CHUNK: usize = 1024;

/// The outputs: the solution log (a host file) and, with `--stream FILE`, the output
/// protocol's byte stream (a host file, written in chunks of [`STREAM_CHUNK`] bytes).
pub struct Output {
    log: SemihostingFile,
    stream: Option<(SemihostingFile, heapless::Vec<u8, STREAM_CHUNK>)>,
}

impl Output {
    /// Writes all of `bytes` to the solution log; `Err` when the host refuses them.
    pub fn write(&mut self, bytes: &[u8]) -> Result<(), OutputError> {
        embedded_io::Write::write_all(&mut self.log, bytes).map_err(|_| OutputError)
    }

    /// Queues the frame `bytes` on the stream (nothing without `--stream`); `Err` when the
    /// host refuses a chunk.
    pub fn write_frame(&mut self, bytes: &[u8]) -> Result<(), OutputError> {
        let Some((file, buf)) = &mut self.stream else {
            return Ok(());
        };
        if buf.extend_from_slice(bytes).is_err() {
            embedded_io::Write::write_all(file, buf).map_err(|_| OutputError)?;
            buf.clear();
            // A frame is shorter than a chunk (`MAX_FRAME`).
            buf.extend_from_slice(bytes).map_err(|_| OutputError)?;
        }
        Ok(())
    }

    /// Writes the queued stream bytes out (at the end of the run).
    pub fn flush(&mut self) -> Result<(), OutputError> {
        let Some((file, buf)) = &mut self.stream else {
            return Ok(());
        };
        embedded_io::Write::write_all(file, buf).map_err(|_| OutputError)?;
        buf.clear();
        Ok(())
    }
}

/// The output stream refused bytes.
#[derive(Debug, defmt::Format)]
pub struct OutputError;

/// Configuration input: with `--config-frame FILE`, the file's bytes, as if the host had
/// sent them before the run; else none.
pub struct ConfigInput(Option<SemihostingFile>);

impl ConfigInput {
    /// Configuration bytes received since the last call, into `buf`: their number (0 once
    /// the file is read).
    pub fn read(&mut self, buf: &mut [u8]) -> usize {
        let Some(file) = &mut self.0 else { return 0 };
        match embedded_io::Read::read(file, buf) {
            Ok(n) => n,
            Err(_) => {
                defmt::error!("cannot read the configuration frame file");
                exit(ExitCode::Config)
            }
        }
    }

    /// The standby window ended without an accepted configuration frame. A file the user
    /// named that gave none (empty, corrupt, refused) is an error: the run does not fall back
    /// to the compiled-in configuration (it ran at another site, exit 0). Without the option,
    /// nothing: the compiled-in configuration runs, as on the real board.
    pub fn none_taken(&self) {
        if self.0.is_some() {
            defmt::error!(
                "--config-frame: the file gave no accepted configuration frame (empty, corrupt or refused: see above); the compiled-in configuration does not run in its place"
            );
            exit(ExitCode::Config)
        }
    }
}

/// No watchdog in QEMU.
pub struct Watchdog;

impl Watchdog {
    /// Nothing to feed.
    pub fn feed(&mut self) {}
}

use stack::{paint_stack, peak_stack};

/// The stack's high-water mark: painted at start, read at the end.
mod stack {
    #![allow(unsafe_code)]
    use core::sync::atomic::{AtomicBool, Ordering};

    /// The stack's paint: a word no stack frame is likely to hold.
    const PAINT: u32 = 0x5AC4_C0DE;
    /// Set once the stack is painted.
    static PAINTED: AtomicBool = AtomicBool::new(false);

    // The RAM's free region, from cortex-m-rt's `link.x`: the end of the static RAM
    // (`__sheap`, after `.data`, `.bss` and `.uninit`) and the top of the stack.
    unsafe extern "C" {
        static __sheap: u32;
        static _stack_start: u32;
    }

    /// The stack's region [address]: from the end of the static RAM to the top of the RAM.
    fn stack_region() -> (usize, usize) {
        (
            (&raw const __sheap) as usize,
            (&raw const _stack_start) as usize,
        )
    }

    /// Paints the free stack (below the current frame) with [`PAINT`], so that [`peak_stack`] can
    /// find the deepest word the run wrote.
    pub fn paint_stack() {
        let (low, _) = stack_region();
        let below_sp = cortex_m::register::msp::read() as usize - 256;
        let mut p = low;
        while p < below_sp {
            // SAFETY: `[low, below_sp)` is RAM no static and no live stack frame uses (the linker
            // script's free region, below this frame), word-aligned (`__sheap` is).
            unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
            p += 4;
        }
        PAINTED.store(true, Ordering::Relaxed);
    }

    /// The run's peak stack and the stack's size [B], if it was painted: the deepest word no
    /// longer holding the paint.
    pub fn peak_stack() -> Option<(usize, usize)> {
        if !PAINTED.load(Ordering::Relaxed) {
            return None;
        }
        let (low, top) = stack_region();
        let mut p = low;
        // SAFETY: reads of word-aligned RAM inside the stack region.
        while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
            p += 4;
        }
        Some((top - p, top - low))
    }
}

/// Ends the program with this exit status of QEMU (the peak stack logged first).
pub fn exit(code: ExitCode) -> ! {
    if let Some((peak, size)) = peak_stack() {
        defmt::info!(
            "peak stack: {=usize} B of the {=usize} B the static RAM leaves",
            peak,
            size
        );
    }
    defmt::flush();
    semihosting::process::exit(code as i32)
}
