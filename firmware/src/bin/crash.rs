//! Diagnostic of the QEMU board: `crash panic|hardfault` makes the firmware fail on purpose, to
//! check that a panic and a HardFault reach QEMU's exit status (1 and 2, `firmware::ExitCode`)
//! with their message in the defmt log. Run through `firmware/qemu-run.sh ELF panic`.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use firmware::{ExitCode, exit};

#[cortex_m_rt::entry]
fn main() -> ! {
    let args = semihosting::experimental::env::args::<64>().unwrap_or_else(|_| {
        defmt::error!("no semihosting command line: run through firmware/qemu-run.sh");
        exit(ExitCode::Config)
    });
    match (&args).map(|a| a.unwrap_or("")).nth(1) {
        Some("panic") => panic!("crash test requested"),
        Some("hardfault") => cortex_m::asm::udf(),
        _ => {
            defmt::error!("usage: crash panic|hardfault");
            exit(ExitCode::Config)
        }
    }
}
