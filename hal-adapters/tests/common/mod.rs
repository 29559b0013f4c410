//! Helpers shared by the integration tests.
#![allow(dead_code)]

use embedded_hal_mock::eh1::spi::Transaction as Spi;
use hal_adapters::recording::{Header, Kind, Record};

/// 400 Hz: 2.5 ms.
pub const PERIOD_NS: u64 = 2_500_000;
pub const T0_NS: u64 = 1_000_000_000;

/// A recording file in memory.
pub fn recording(kind: Kind, records: &[Record]) -> Vec<u8> {
    let header = Header {
        kind,
        rate_hz: 400.0,
        t0_ns: T0_NS,
        sample_count: records.len() as u32,
    };
    let mut bytes = header.encode().to_vec();
    for record in records {
        bytes.extend_from_slice(&record.encode());
    }
    bytes
}

/// `|a - b| <= tol`, element-wise, with a message.
pub fn assert_close(a: [f32; 3], b: [f32; 3], tol: [f32; 3], what: &str) {
    for i in 0..3 {
        assert!(
            (a[i] - b[i]).abs() <= tol[i],
            "{what}[{i}]: {} vs {} (tol {})",
            a[i],
            b[i],
            tol[i]
        );
    }
}

/// An 8-bit register write `[reg, value]` in one chip-select frame.
pub fn register_write(reg: u8, value: u8) -> Vec<Spi<u8>> {
    vec![
        Spi::transaction_start(),
        Spi::write_vec(vec![reg, value]),
        Spi::transaction_end(),
    ]
}

/// An 8-bit register read: the address with bit 7 set, then `response` (the value, after any
/// dummy bytes the device sends first).
pub fn register_read(reg: u8, response: Vec<u8>) -> Vec<Spi<u8>> {
    vec![
        Spi::transaction_start(),
        Spi::write_vec(vec![reg | 0x80]),
        Spi::read_vec(response),
        Spi::transaction_end(),
    ]
}
