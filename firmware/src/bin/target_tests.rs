//! Tests on the target (the qemu board): the output protocol's checks
//! (`hal_adapters::protocol::selftest`: the encoder and decoder round trip, the configuration
//! validator's refusals, the status rule) run on the Cortex-M, the same list the host's unit
//! test runs. Each check is logged with its result and its guest instructions; the exit status
//! is 0 only when every check passed (`cargo xtask test` runs it through
//! `firmware/qemu-run.sh ELF`).
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use cortex_m::peripheral::syst::SystClkSource;
use firmware::{ExitCode, exit};
use hal_adapters::protocol::selftest::CHECKS;

/// Core clock [Hz] (SysTick counts at this rate; 1 ns per guest instruction under icount).
const SYSCLK_HZ: u64 = 168_000_000;

#[cortex_m_rt::entry]
fn main() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else {
        exit(ExitCode::Panic)
    };
    // SysTick free-running at the core clock over its whole 24-bit range (a check takes
    // less than its 0.1 s).
    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(0x00ff_ffff);
    core.SYST.clear_current();
    core.SYST.enable_counter();
    let mut failed = 0_u32;
    for (name, check) in CHECKS {
        let start = cortex_m::peripheral::SYST::get_current();
        let result = core::hint::black_box(check)();
        let counts = start.wrapping_sub(cortex_m::peripheral::SYST::get_current()) & 0x00ff_ffff;
        let instructions = u64::from(counts) * 1_000_000_000 / SYSCLK_HZ;
        match result {
            Ok(()) => defmt::info!(
                "test {=str} ... ok ({=u64} instructions)",
                name,
                instructions
            ),
            Err(what) => {
                failed += 1;
                defmt::error!("test {=str} ... FAILED: {=str}", name, what);
            }
        }
    }
    defmt::info!(
        "target tests: {=usize} run, {=u32} failed",
        CHECKS.len(),
        failed
    );
    exit(if failed == 0 {
        ExitCode::Success
    } else {
        ExitCode::Panic
    })
}
