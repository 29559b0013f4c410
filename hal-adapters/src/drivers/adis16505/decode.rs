//! Burst-frame decoding: pure functions, no bus.
//!
//! A 16-bit burst (after the `0x6800` command word) is ten big-endian words: `DIAG_STAT`,
//! gyro x/y/z, accelerometer x/y/z (or delta angle and delta velocity with `BURST_SEL`),
//! `TEMP_OUT`, `DATA_CNTR`, checksum. The 32-bit burst (`BURST32`) sends each of the six inertial
//! values as its `_LOW` word followed by its `_OUT` word (16 words). The checksum is the `u16`
//! sum of all bytes before it (18 or 30).

use bitflags::bitflags;

use super::regs::{BURST16_LEN, BURST32_LEN};

bitflags! {
    /// `DIAG_STAT` bits (Linux `adis16475_status_error_msgs`, no-OS `adis1650x_def`).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct DiagStat: u16 {
        /// Data path overrun: an internal processing step was skipped.
        const DATA_PATH_OVERRUN = 1 << 1;
        /// The last flash memory update failed.
        const FLASH_UPDATE_FAILURE = 1 << 2;
        /// An SPI frame did not have a multiple of 16 clocks.
        const SPI_COMM_ERROR = 1 << 3;
        /// Standby mode (supply too low).
        const STANDBY = 1 << 4;
        /// Self-test (or sensor) failure.
        const SENSOR_FAILURE = 1 << 5;
        /// Flash memory test failure.
        const MEMORY_FAILURE = 1 << 6;
        /// Clock error (sync modes).
        const CLOCK_ERROR = 1 << 7;
        /// Gyro 1 self-test failure (ADIS1650x only).
        const GYRO1_FAILURE = 1 << 8;
        /// Gyro 2 self-test failure (ADIS1650x only).
        const GYRO2_FAILURE = 1 << 9;
        /// Accelerometer self-test failure (ADIS1650x only).
        const ACCEL_FAILURE = 1 << 10;
    }
}

impl DiagStat {
    /// Bits that make the data of the same burst untrustworthy ([`crate::SampleFlags::
    /// DEVICE_FAULT`]). `SPI_COMM_ERROR` and `FLASH_UPDATE_FAILURE` concern earlier operations
    /// and are only kept in [`super::Adis16505::last_diag`].
    pub const SAMPLE_FAULTS: DiagStat = DiagStat::DATA_PATH_OVERRUN
        .union(DiagStat::STANDBY)
        .union(DiagStat::SENSOR_FAILURE)
        .union(DiagStat::MEMORY_FAILURE)
        .union(DiagStat::CLOCK_ERROR)
        .union(DiagStat::GYRO1_FAILURE)
        .union(DiagStat::GYRO2_FAILURE)
        .union(DiagStat::ACCEL_FAILURE);

    /// Bits a self-test sets when a sensor fails.
    pub const SELF_TEST_FAILURES: DiagStat = DiagStat::SENSOR_FAILURE
        .union(DiagStat::GYRO1_FAILURE)
        .union(DiagStat::GYRO2_FAILURE)
        .union(DiagStat::ACCEL_FAILURE);
}

#[cfg(feature = "defmt")]
impl defmt::Format for DiagStat {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "DiagStat({=u16:#06x})", self.bits());
    }
}

/// A burst frame's fields, as raw device counts in sensor axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawBurst {
    /// `DIAG_STAT` (all bits, known or not).
    pub diag_stat: u16,
    /// Gyro rate or delta angle, x/y/z: the `_OUT` word (16-bit burst) or `_OUT << 16 | _LOW`
    /// (32-bit burst) [LSB].
    pub gyro: [i32; 3],
    /// Acceleration or delta velocity, x/y/z, as `gyro` [LSB].
    pub accel: [i32; 3],
    /// `TEMP_OUT` [LSB].
    pub temp: i16,
    /// `DATA_CNTR`.
    pub data_cntr: u16,
}

/// Why a burst frame was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The checksum word does not match the bytes.
    Checksum {
        /// The checksum word of the frame.
        received: u16,
        /// The sum of the bytes before it.
        computed: u16,
    },
    /// Every byte is zero.
    ZeroFrame,
    /// The frame is not 20 (16-bit burst) or 32 (32-bit burst) bytes long.
    Length,
}

/// The `u16` sum of `bytes` (the burst checksum of the bytes before the checksum word).
#[inline]
pub fn checksum(bytes: &[u8]) -> u16 {
    bytes
        .iter()
        .fold(0u16, |sum, &b| sum.wrapping_add(u16::from(b)))
}

/// Decodes a burst frame (the bytes after the command word): 20 bytes for a 16-bit burst, 32
/// for a 32-bit burst. Checks the checksum and rejects an all-zero frame.
pub fn decode_burst(frame: &[u8]) -> Result<RawBurst, FrameError> {
    let burst32 = match frame.len() {
        BURST16_LEN => false,
        BURST32_LEN => true,
        _ => return Err(FrameError::Length),
    };
    let n = frame.len();
    let word = |i: usize| u16::from_be_bytes([frame[2 * i], frame[2 * i + 1]]);
    let received = word(n / 2 - 1);
    let computed = checksum(&frame[..n - 2]);
    if received != computed {
        return Err(FrameError::Checksum { received, computed });
    }
    if frame.iter().all(|&b| b == 0) {
        return Err(FrameError::ZeroFrame);
    }
    // Inertial value k (0..6): word 1 + k (16-bit) or words 1 + 2k (low), 2 + 2k (out).
    let value = |k: usize| -> i32 {
        if burst32 {
            (i32::from(word(2 + 2 * k) as i16) << 16) | i32::from(word(1 + 2 * k))
        } else {
            i32::from(word(1 + k) as i16)
        }
    };
    let tail = if burst32 { 13 } else { 7 };
    Ok(RawBurst {
        diag_stat: word(0),
        gyro: [value(0), value(1), value(2)],
        accel: [value(3), value(4), value(5)],
        temp: word(tail) as i16,
        data_cntr: word(tail + 1),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame16(words: [u16; 9]) -> [u8; 20] {
        let mut f = [0u8; 20];
        for (i, w) in words.iter().enumerate() {
            f[2 * i..2 * i + 2].copy_from_slice(&w.to_be_bytes());
        }
        let sum = checksum(&f[..18]);
        f[18..].copy_from_slice(&sum.to_be_bytes());
        f
    }

    #[test]
    fn decodes_a_16_bit_frame() {
        let f = frame16([0x0002, 1, 0xFFFF, 3, 0x8000, 5, 0x7FFF, 250, 77]);
        let raw = decode_burst(&f).unwrap();
        assert_eq!(raw.diag_stat, 2);
        assert_eq!(raw.gyro, [1, -1, 3]);
        assert_eq!(raw.accel, [-32768, 5, 32767]);
        assert_eq!((raw.temp, raw.data_cntr), (250, 77));
    }

    #[test]
    fn decodes_a_32_bit_frame() {
        let mut f = [0u8; 32];
        // gyro x: low 0x8001, out 0xFFFE -> 0xFFFE8001
        f[2..4].copy_from_slice(&0x8001u16.to_be_bytes());
        f[4..6].copy_from_slice(&0xFFFEu16.to_be_bytes());
        f[28..30].copy_from_slice(&9u16.to_be_bytes());
        let sum = checksum(&f[..30]);
        f[30..].copy_from_slice(&sum.to_be_bytes());
        let raw = decode_burst(&f).unwrap();
        assert_eq!(raw.gyro[0], 0xFFFE_8001_u32 as i32);
        assert_eq!(raw.data_cntr, 9);
    }

    #[test]
    fn rejects_bad_frames() {
        let mut f = frame16([0, 1, 2, 3, 4, 5, 6, 7, 8]);
        f[3] ^= 0x10;
        assert!(matches!(decode_burst(&f), Err(FrameError::Checksum { .. })));
        assert_eq!(decode_burst(&[0u8; 20]), Err(FrameError::ZeroFrame));
        assert_eq!(decode_burst(&[0u8; 21]), Err(FrameError::Length));
    }
}
