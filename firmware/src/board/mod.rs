//! The board layer: what the RTIC app's tasks (`main.rs`) need from the hardware, one module
//! per board, chosen by cargo feature.
//!
//! Every board module provides the same items, which the tasks use and nothing else:
//! - `init(core, device, slot) -> Board`: clocks, pins, buses, the IMU initialised, the
//!   monotonic started, the compiled-in run configuration and what the board is ([`Board`]);
//! - `STANDBY_US`: how long the board waits for the host's configuration frame at start
//!   before the compiled-in run configuration runs (`crate::run_config`);
//! - `Mono`: the RTIC monotonic (its interrupt registered by the board);
//! - `now_us()`: the board's time since start [us] (also defmt's timestamp);
//! - `counts()` and `instructions_since(start)`: a free-running counter and the instructions
//!   (qemu, under icount) or core cycles (the real part) since one of its readings, for the
//!   cost figures;
//! - `Imu::read(t_ready_us)` ([`DataReady`]) and `Imu::health()`: one data-ready's sample;
//! - `Output::write(bytes)`: the output stream (the solution log today; the binary protocol's
//!   encoder plugs in here), `ConfigInput::read(buf)`: configuration bytes from the host
//!   (the configuration frame's decoder plugs in here);
//! - `Watchdog::feed()`, fed by `navigate` at every sample;
//! - `Fixes`: the GNSS fixes' source (`due(t_us)`, `remaining(n)`);
//! - `missed_data_ready()`: data-ready edges lost because the previous one was still pending;
//! - `exit(code)`: the end of a run.
//!
//! Boards: [`qemu`] (netduinoplus2 in QEMU: a pacer for the data-ready line, a simulated SPI
//! device answering from a recording, semihosting files) and `stm32f405` (a real board on
//! `stm32f4xx-hal`).

#[cfg(all(feature = "qemu", feature = "stm32f405"))]
compile_error!(
    "choose one board: --features qemu (the default) or --no-default-features --features stm32f405"
);
#[cfg(not(any(feature = "qemu", feature = "stm32f405")))]
compile_error!("no board: build with --features qemu (the default) or stm32f405");

#[cfg(feature = "qemu")]
pub mod qemu;
#[cfg(feature = "qemu")]
pub use qemu::*;

#[cfg(feature = "stm32f405")]
pub mod stm32f405;
#[cfg(feature = "stm32f405")]
pub use stm32f405::*;

use hal_adapters::ImuSample;
use hal_adapters::drivers::Health;
use hal_adapters::protocol::config::BoardIdentity;
use nav_core::navigator::RunConfig;

/// The device (PAC) the RTIC app runs on: the STM32F405's on both boards.
pub use stm32f4::stm32f405 as pac;

defmt::timestamp!("{=u64:us}", now_us());

/// What the data-ready interrupt hands to navigation.
pub enum DataReady {
    /// A sample, its data-ready time on the board's clock [us], and the instructions of its bus
    /// transaction and of its decoding.
    Sample {
        /// The driver's sample.
        sample: ImuSample,
        /// Data-ready time [us].
        t_ready_us: u64,
        /// Instructions of the bus transaction.
        bus_instr: u32,
        /// Instructions of decoding and converting the frame.
        decode_instr: u32,
    },
    /// The recording ended; the driver's final counters.
    End {
        /// The driver's counters.
        health: Health,
    },
    /// The source failed (already logged).
    SourceError,
}

impl DataReady {
    /// True when nothing follows this message (the source ended or failed).
    pub fn is_last(&self) -> bool {
        !matches!(self, Self::Sample { .. })
    }
}

/// The board, brought up: what `init` hands to the tasks.
pub struct Board {
    /// The IMU, for the data-ready task.
    pub imu: Imu,
    /// The output stream, for `navigate`.
    pub out: Output,
    /// Configuration bytes from the host (the configuration frame's seam).
    pub config_in: ConfigInput,
    /// The watchdog, fed by `navigate`.
    pub watchdog: Watchdog,
    /// The GNSS fixes and their number (an aided run).
    pub gnss: Option<(Fixes, u32)>,
    /// The compiled-in run configuration (checked at the IMU's rate): the run's unless the
    /// host's configuration frame comes in the standby window ([`STANDBY_US`]).
    pub run: RunConfig,
    /// What the board is built with (a configuration frame must name the same).
    pub identity: BoardIdentity,
}
