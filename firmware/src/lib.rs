//! Support for the navigation firmware: the board layer (`board`: one module per board,
//! chosen by cargo feature), exit codes, the panic and HardFault handlers (knurling
//! app-template style), the arguments, the IMU, the defmt summaries, and small output helpers.
//!
//! Navigation math lives in `nav-core`; sensor sources in `hal-adapters`; the RTIC app in
//! `main.rs` holds the tasks and only wires them together.
#![no_std]
#![warn(missing_docs)]

use core::fmt::Write as _;

pub mod board;
pub mod config;
pub mod errors;
#[cfg(feature = "qemu")]
pub mod gnss;
pub mod imu;
pub mod log;
pub mod run_config;
pub mod stream;

pub use board::exit;

/// Samples queued from the data-ready interrupt to `navigate`.
pub const SAMPLE_CAP: usize = 16;
/// Alignment increments queued for `align` (its fine stage's fits lag behind).
pub const ALIGN_CAP: usize = 32;
/// The aided phase's messages queued for `align`: propagations, then an update or report
/// `navigate` waits for (a separate channel: its messages are 6 times an increment's size).
pub const FILTER_CAP: usize = 2;

/// Process exit codes: every failure has its own, so CI and scripts can tell them apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
#[repr(i32)]
pub enum ExitCode {
    /// The recording was navigated to its end.
    Success = 0,
    /// A Rust panic (message in the defmt log).
    Panic = 1,
    /// A HardFault exception (stacked PC in the defmt log).
    HardFault = 2,
    /// Bad command-line (semihosting) arguments.
    Config = 3,
    /// The recording (or the GNSS fix file) could not be opened, or it is truncated or
    /// corrupt.
    Recording = 4,
    /// Alignment failed (base moving, bad sensors...), or the recording ended before it had
    /// its samples, or the navigation filter cannot start from its outcome.
    Alignment = 5,
    /// The solution log could not be written.
    Output = 6,
    /// Aligned, but not one navigation step followed: every later sample was flagged or
    /// refused, or there was none (the counts by cause in the defmt log).
    NothingNavigated = 7,
}

/// Logs the panic and ends the run. The qemu board formats the message's arguments (core's
/// formatting, float included); a real board logs the message when it has none, else its
/// place, which keeps the formatting out of its flash.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    if cfg!(feature = "qemu") {
        defmt::error!("panic: {}", defmt::Display2Format(info));
    } else {
        let message = info
            .message()
            .as_str()
            .unwrap_or("(message with arguments)");
        match info.location() {
            Some(l) => defmt::error!(
                "panic at {=str}:{=u32}: {=str}",
                l.file(),
                l.line(),
                message
            ),
            None => defmt::error!("panic: {=str}", message),
        }
    }
    exit(ExitCode::Panic)
}

// cortex-m-rt requires `unsafe` on the HardFault handler's signature; it only logs and exits.
#[allow(unsafe_code)]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!(
        "HardFault at pc={=u32:#010x} lr={=u32:#010x}",
        frame.pc(),
        frame.lr()
    );
    exit(ExitCode::HardFault)
}

/// Instruction statistics of a repeated piece of work.
#[derive(Clone, Copy, Default)]
pub struct StepCost {
    /// Largest [instructions].
    pub max: u64,
    /// Sum [instructions].
    pub sum: u64,
    /// Count.
    pub n: u64,
}

impl StepCost {
    /// Adds one piece of work's `instructions`.
    pub fn add(&mut self, instructions: u64) {
        self.max = self.max.max(instructions);
        self.sum += instructions;
        self.n += 1;
    }

    /// Mean [instructions] (0 before any).
    pub fn mean(&self) -> u64 {
        self.sum.checked_div(self.n).unwrap_or(0)
    }
}

/// The background's costs of the navigation filter's work, by kind of message.
#[derive(Clone, Copy, Default)]
pub struct FilterCosts {
    /// Covariance propagations.
    pub propagation: StepCost,
    /// GNSS position and velocity updates.
    pub gnss: StepCost,
    /// Zero-velocity and zero-rate updates at stops.
    pub zero_motion: StepCost,
    /// Reports for rows.
    pub report: StepCost,
}

impl FilterCosts {
    /// Where a message's cost is counted.
    pub fn kind(
        message: &nav_core::navigator::ToBackground<f32>,
    ) -> fn(&mut FilterCosts) -> &mut StepCost {
        use nav_core::navigator::ToBackground as M;
        match message {
            M::Propagate(_) => |c| &mut c.propagation,
            // A restart is a fix's work (a re-alignment's last fix).
            M::Position { .. } | M::Velocity { .. } | M::Restart { .. } => |c| &mut c.gnss,
            M::Still { .. } => |c| &mut c.zero_motion,
            // Alignment increments have their own figures (the `align` task's log).
            M::Report { .. } | M::Align(_) => |c| &mut c.report,
        }
    }
}

/// A line of text formatted into a fixed buffer (no allocation): an aided row's 20 columns fit
/// (some 330 characters at most: ten `f64` in their shortest form, nine `f32`, the status).
pub type Line = heapless::String<400>;

/// Formats `value` followed by a newline into a [`Line`]; `None` if it does not fit.
#[inline(never)]
pub fn line(value: impl core::fmt::Display) -> Option<Line> {
    let mut s = Line::new();
    writeln!(s, "{value}").ok()?;
    Some(s)
}
