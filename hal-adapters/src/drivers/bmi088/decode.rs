//! Frame decoding: pure functions, no bus.
//!
//! The gyro frame is the 6 bytes `RATE_X_LSB..=RATE_Z_MSB`. The accelerometer frame is the 18
//! bytes `ACC_X_LSB..=TEMP_LSB` after the dummy byte:
//!
//! | byte   | register | contents |
//! | -----: | -------- | -------- |
//! |  0..6  | 0x12..=0x17 | acceleration x, y, z, 16-bit little-endian |
//! |  6..9  | 0x18..=0x1A | sensor time, 24-bit little-endian, 39.0625 us per count |
//! |  9..16 | 0x1B..=0x21 | status, reserved (ignored) |
//! | 16, 17 | 0x22, 0x23  | temperature: `TEMP_MSB`, `TEMP_LSB` bits 7:5 (11-bit) |

use super::regs::{ACC_X_LSB, ACCEL_FRAME_LEN, GYRO_FRAME_LEN, SENSORTIME_0, TEMP_MSB};

/// Offset of the sensor time in the accelerometer frame.
const SENSORTIME_AT: usize = (SENSORTIME_0 - ACC_X_LSB) as usize;
/// Offset of the temperature in the accelerometer frame.
const TEMP_AT: usize = (TEMP_MSB - ACC_X_LSB) as usize;

/// The 11-bit temperature that marks "invalid" (`TEMP_MSB` = 0x80) [LSB].
pub const INVALID_TEMP: i16 = -1024;
/// Temperature sensitivity [deg C/LSB] and value at 0 LSB [deg C] (datasheet 5.3.7).
pub const TEMP_C_PER_LSB: f32 = 0.125;
/// Temperature at 0 LSB [deg C].
pub const TEMP_OFFSET_C: f32 = 23.0;
/// Sensor-time counts per second (39.0625 us per count).
pub const SENSORTIME_HZ: u32 = 25_600;
/// The sensor time is a 24-bit counter.
pub const SENSORTIME_MASK: u32 = 0x00FF_FFFF;

/// An accelerometer frame's fields, raw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelFrame {
    /// Acceleration x, y, z, sensor axes [LSB].
    pub accel: [i32; 3],
    /// Sensor time when the frame was read [1/25600 s], 24-bit.
    pub sensortime: u32,
    /// Temperature, 11-bit two's complement [LSB] ([`INVALID_TEMP`] = invalid).
    pub temp: i16,
}

/// Three 16-bit little-endian values.
#[inline]
fn xyz(b: &[u8]) -> [i32; 3] {
    [0, 1, 2].map(|i| i32::from(i16::from_le_bytes([b[2 * i], b[2 * i + 1]])))
}

/// Decodes a gyro frame: rate x, y, z, sensor axes [LSB].
#[inline]
pub fn decode_gyro(frame: &[u8; GYRO_FRAME_LEN]) -> [i32; 3] {
    xyz(frame)
}

/// Decodes an accelerometer frame (the bytes after the dummy byte).
#[inline]
pub fn decode_accel(frame: &[u8; ACCEL_FRAME_LEN]) -> AccelFrame {
    let t = &frame[SENSORTIME_AT..SENSORTIME_AT + 3];
    // `Temp_uint11 = TEMP_MSB * 8 + TEMP_LSB / 32`, two's complement: the top 11 bits of the
    // big-endian pair, shifted arithmetically.
    let temp = i16::from_be_bytes([frame[TEMP_AT], frame[TEMP_AT + 1]]) >> 5;
    AccelFrame {
        accel: xyz(frame),
        sensortime: u32::from_le_bytes([t[0], t[1], t[2], 0]),
        temp,
    }
}

/// The temperature of an 11-bit reading [deg C]; NaN for [`INVALID_TEMP`].
#[inline]
pub fn temperature_c(temp: i16) -> f32 {
    if temp == INVALID_TEMP {
        f32::NAN
    } else {
        f32::from(temp) * TEMP_C_PER_LSB + TEMP_OFFSET_C
    }
}

/// Whole periods of `ticks_per_period` sensor-time counts from `prev` to `now` (24-bit
/// wrapping), rounded to the nearest: the reads' jitter around the data-ready edges is absorbed.
#[inline]
pub fn elapsed_periods(prev: u32, now: u32, ticks_per_period: u32) -> u32 {
    let ticks = now.wrapping_sub(prev) & SENSORTIME_MASK;
    (ticks + ticks_per_period / 2) / ticks_per_period
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_frames() {
        assert_eq!(
            decode_gyro(&[0x01, 0x00, 0xFF, 0xFF, 0x00, 0x80]),
            [1, -1, -32768]
        );
        let mut f = [0u8; ACCEL_FRAME_LEN];
        f[..6].copy_from_slice(&[0xFF, 0x7F, 0x34, 0x12, 0xFE, 0xFF]);
        f[6..9].copy_from_slice(&[0x56, 0x34, 0x12]);
        f[16] = 0xC1; // -504: -40 deg C
        let a = decode_accel(&f);
        assert_eq!(a.accel, [32767, 0x1234, -2]);
        assert_eq!(a.sensortime, 0x12_3456);
        assert_eq!(temperature_c(a.temp), -40.0);
    }

    #[test]
    fn temperature_table_of_the_datasheet() {
        let t = |msb: u8, lsb: u8| {
            let mut f = [0u8; ACCEL_FRAME_LEN];
            f[16] = msb;
            f[17] = lsb;
            temperature_c(decode_accel(&f).temp)
        };
        assert_eq!(t(0x3E, 0x00), 85.0);
        assert_eq!(t(0x00, 0x60), 23.375);
        assert_eq!(t(0x00, 0x20), 23.125);
        assert_eq!(t(0x00, 0x00), 23.0);
        assert!(t(0x80, 0x00).is_nan());
    }

    #[test]
    fn periods_round_and_wrap() {
        assert_eq!(elapsed_periods(100, 100, 64), 0);
        assert_eq!(elapsed_periods(100, 131, 64), 0);
        assert_eq!(elapsed_periods(100, 132, 64), 1);
        assert_eq!(elapsed_periods(100, 164 + 64, 64), 2);
        assert_eq!(elapsed_periods(SENSORTIME_MASK - 10, 54, 64), 1);
    }
}
