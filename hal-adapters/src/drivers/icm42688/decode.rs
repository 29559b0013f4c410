//! FIFO decoding: pure functions, no bus.
//!
//! The driver reads `INT_STATUS`, `FIFO_COUNTH`, `FIFO_COUNTL` and then packets from
//! `FIFO_DATA` in one transaction. A high-resolution packet ("packet 4") is 20 bytes:
//!
//! | byte  | contents |
//! | ----: | -------- |
//! |     0 | header: `0b0111_10xx` (accel, gyro, 20-bit, ODR timestamp; bits 1:0 = ODR changed) |
//! |  1..7 | accel x, y, z bits 19:12 and 11:4 |
//! | 7..13 | gyro x, y, z bits 19:12 and 11:4 |
//! | 13,14 | temperature, 16-bit |
//! | 15,16 | timestamp, 16-bit [us] |
//! | 17..20| per axis x, y, z: accel bits 3:0 in the high nibble, gyro bits 3:0 in the low one |
//!
//! All big-endian (the `INTF_CONFIG0` reset value). Gyro values are 19-bit (bit 0 is 0), 262
//! LSB/(deg/s) as 20-bit numbers; accelerometer values 18-bit (bits 1:0 are 0), 32768 LSB/g;
//! the range is fixed at +-2000 deg/s and +-16 g. Invalid data is marked with -32768 in the
//! 16-bit fields: an inertial value of `-524288` (`0x80000`, upper 16 bits -32768, lower bits 0)
//! and a temperature of `-32768`.

/// Bytes before the first packet: `INT_STATUS`, `FIFO_COUNTH`, `FIFO_COUNTL`.
pub const STATUS_LEN: usize = 3;
/// Length of a high-resolution FIFO packet [bytes].
pub const PACKET_LEN: usize = 20;
/// 2 kHz packets integrated into one 400 Hz sample.
pub const PACKETS_PER_SAMPLE: usize = 5;
/// Longest FIFO read [bytes].
pub const READ_LEN: usize = STATUS_LEN + PACKETS_PER_SAMPLE * PACKET_LEN;

/// Header bit 7: the FIFO is empty (no packet).
pub const HEADER_EMPTY: u8 = 1 << 7;
/// Header bits that must match [`HEADER_EXPECTED`] (bits 1:0, "ODR changed", are ignored).
pub const HEADER_MASK: u8 = 0xFC;
/// Accel (bit 6), gyro (bit 5), 20-bit (bit 4), ODR timestamp (bits 3:2 = 0b10).
pub const HEADER_EXPECTED: u8 = 0x78;
/// Invalid-data marker of a 20-bit inertial value.
pub const INVALID_20: i32 = -524_288;
/// Invalid-data marker of the temperature.
pub const INVALID_TEMP: i16 = -32_768;
/// Largest gyro magnitude (19-bit full scale, as a 20-bit number) [LSB].
pub const GYRO_FULL_SCALE_20: i32 = 262_143 * 2;
/// Largest accelerometer magnitude (18-bit full scale, as a 20-bit number) [LSB].
pub const ACCEL_FULL_SCALE_20: i32 = 131_071 * 4;

/// Gyro sensitivity of the 20-bit value [LSB/(deg/s)] (131 LSB/(deg/s) for the 19 significant
/// bits: PX4 `ICM42688P::ProcessGyro`).
pub const GYRO_LSB_PER_DPS_20: f64 = 262.0;
/// Accelerometer sensitivity of the 20-bit value [LSB/g] (8192 LSB/g for the 18 significant
/// bits: PX4 `ICM42688P::ProcessAccel`).
pub const ACCEL_LSB_PER_G_20: f64 = 32768.0;
/// Temperature sensitivity [LSB/deg C] and offset [deg C] (PX4 `TEMPERATURE_SENSITIVITY`,
/// `TEMPERATURE_OFFSET`).
pub const TEMP_LSB_PER_C: f32 = 132.48;
/// Temperature at 0 LSB [deg C].
pub const TEMP_OFFSET_C: f32 = 25.0;

/// `INT_STATUS` and `FIFO_COUNT` [bytes] read before the packets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FifoStatus {
    /// `INT_STATUS` (cleared by the read).
    pub int_status: u8,
    /// Bytes in the FIFO when the read started.
    pub count: u16,
}

/// Decodes the three status bytes.
pub fn decode_status(bytes: &[u8; STATUS_LEN]) -> FifoStatus {
    FifoStatus {
        int_status: bytes[0],
        count: u16::from_be_bytes([bytes[1], bytes[2]]),
    }
}

/// One FIFO packet, raw counts in sensor axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Packet {
    /// Accelerometer x, y, z, 20-bit [LSB] ([`INVALID_20`] = invalid).
    pub accel: [i32; 3],
    /// Gyro x, y, z, 20-bit [LSB] ([`INVALID_20`] = invalid).
    pub gyro: [i32; 3],
    /// Temperature [LSB] ([`INVALID_TEMP`] = invalid).
    pub temp: i16,
    /// ODR timestamp [us], wraps at 2^16.
    pub timestamp_us: u16,
}

/// What a 20-byte FIFO slot holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Slot {
    /// A packet.
    Packet(Packet),
    /// The FIFO was empty (header bit 7).
    Empty,
    /// A header of another format (carried): the stream is out of step.
    BadHeader(u8),
}

/// A 20-bit two's complement value from bits 19:12, 11:4 and 3:0.
#[inline]
pub fn raw20(bits_19_12: u8, bits_11_4: u8, bits_3_0: u8) -> i32 {
    (i32::from(bits_19_12 as i8) << 12) | (i32::from(bits_11_4) << 4) | i32::from(bits_3_0 & 0x0F)
}

/// Decodes one 20-byte FIFO slot.
pub fn decode_packet(p: &[u8; PACKET_LEN]) -> Slot {
    let header = p[0];
    if header & HEADER_EMPTY != 0 {
        return Slot::Empty;
    }
    if header & HEADER_MASK != HEADER_EXPECTED {
        return Slot::BadHeader(header);
    }
    let (mut accel, mut gyro) = ([0; 3], [0; 3]);
    for (axis, (a, g)) in accel.iter_mut().zip(gyro.iter_mut()).enumerate() {
        let ext = p[17 + axis];
        *a = raw20(p[1 + 2 * axis], p[2 + 2 * axis], ext >> 4);
        *g = raw20(p[7 + 2 * axis], p[8 + 2 * axis], ext & 0x0F);
    }
    Slot::Packet(Packet {
        accel,
        gyro,
        temp: i16::from_be_bytes([p[13], p[14]]),
        timestamp_us: u16::from_be_bytes([p[15], p[16]]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assembles_20_bit_values() {
        assert_eq!(raw20(0x00, 0x00, 0x1), 1);
        assert_eq!(raw20(0xFF, 0xFF, 0xF), -1);
        assert_eq!(raw20(0x80, 0x00, 0x0), INVALID_20);
        assert_eq!(raw20(0x7F, 0xFF, 0xF), 524_287);
        assert_eq!(raw20(0x12, 0x34, 0x5), 0x12345);
    }

    #[test]
    fn decodes_a_packet() {
        let mut p = [0u8; PACKET_LEN];
        p[0] = 0x7A; // ODR-changed bit set: still a packet
        p[1] = 0xFF; // accel x = 0xFFF?0 with nibble 0xC -> -4
        p[2] = 0xFF;
        p[17] = 0xC2; // accel x low nibble 0xC, gyro x low nibble 0x2
        p[8] = 0x01; // gyro x bits 11:4 = 0x01 -> 0x12
        p[13] = 0x01;
        p[14] = 0x00;
        p[15] = 0x12;
        p[16] = 0x34;
        let Slot::Packet(k) = decode_packet(&p) else {
            panic!("not a packet")
        };
        assert_eq!(k.accel[0], -4);
        assert_eq!(k.gyro[0], 0x12);
        assert_eq!((k.temp, k.timestamp_us), (256, 0x1234));
        p[0] = 0x80;
        assert_eq!(decode_packet(&p), Slot::Empty);
        p[0] = 0x68;
        assert_eq!(decode_packet(&p), Slot::BadHeader(0x68));
    }
}
