//! ADIS16505 / ADIS16465 register map (user page; 16-bit registers at even byte addresses,
//! low byte first). Linux `adis16475.c`, no-OS `adis1650x.c`.
//!
//! SPI: mode 3 (CPOL = 1, CPHA = 1), 16-bit words MSB first, one word per chip-select frame with
//! a [`super::model::STALL_US`] stall between frames. A read sends `[addr, 0x00]`; the register
//! comes back during the next word. A write sends `[0x80 | addr, byte]`, one byte per word.

#![allow(dead_code)] // the map is documentation too: not every register is used

/// Status and error flags (burst word 0).
pub(crate) const DIAG_STAT: u8 = 0x02;
/// Gyro x, low and high word (y at +4, z at +8).
pub(crate) const X_GYRO_LOW: u8 = 0x04;
pub(crate) const X_GYRO_OUT: u8 = 0x06;
/// Accelerometer x, low and high word (y at +4, z at +8).
pub(crate) const X_ACCL_LOW: u8 = 0x10;
pub(crate) const X_ACCL_OUT: u8 = 0x12;
/// Temperature, 0.1 deg C/LSB.
pub(crate) const TEMP_OUT: u8 = 0x1C;
/// Time stamp (sync modes).
pub(crate) const TIME_STAMP: u8 = 0x1E;
/// Output sample counter, wraps at 2^16.
pub(crate) const DATA_CNTR: u8 = 0x22;
/// Delta angle x, low and high word (y at +4, z at +8).
pub(crate) const X_DELTANG_LOW: u8 = 0x24;
pub(crate) const X_DELTANG_OUT: u8 = 0x26;
/// Delta velocity x, low and high word (y at +4, z at +8).
pub(crate) const X_DELTVEL_LOW: u8 = 0x30;
pub(crate) const X_DELTVEL_OUT: u8 = 0x32;
/// Bartlett filter size.
pub(crate) const FILT_CTRL: u8 = 0x5C;
/// Range model (read only).
pub(crate) const RANG_MDL: u8 = 0x5E;
/// Miscellaneous control: data-ready polarity, sync mode, burst selection.
pub(crate) const MSC_CTRL: u8 = 0x60;
/// Scaled-sync scale.
pub(crate) const UP_SCALE: u8 = 0x62;
/// Decimation: output rate = 2000 Hz / (DEC_RATE + 1).
pub(crate) const DEC_RATE: u8 = 0x64;
/// Global commands (write only); reading it starts a burst.
pub(crate) const GLOB_CMD: u8 = 0x68;
/// Firmware revision, day/month, year.
pub(crate) const FIRM_REV: u8 = 0x6C;
pub(crate) const FIRM_DM: u8 = 0x6E;
pub(crate) const FIRM_Y: u8 = 0x70;
/// Product identification (16505 or 16465).
pub(crate) const PROD_ID: u8 = 0x72;
/// Serial number.
pub(crate) const SERIAL_NUM: u8 = 0x74;

/// Write bit of the first byte of a word.
pub(crate) const WRITE: u8 = 0x80;
/// The burst-read command word (a read of `GLOB_CMD`).
pub(crate) const BURST_CMD: [u8; 2] = [GLOB_CMD, 0x00];

/// `GLOB_CMD` bits.
pub(crate) const GLOB_CMD_FACTORY_RESTORE: u8 = 1 << 1;
pub(crate) const GLOB_CMD_SELF_TEST: u8 = 1 << 2;
pub(crate) const GLOB_CMD_FLASH_UPDATE: u8 = 1 << 3;
pub(crate) const GLOB_CMD_FLASH_TEST: u8 = 1 << 4;
pub(crate) const GLOB_CMD_SOFTWARE_RESET: u8 = 1 << 7;

/// `MSC_CTRL` bits.
pub(crate) const MSC_CTRL_DR_POLARITY: u16 = 1 << 0;
pub(crate) const MSC_CTRL_BURST_SEL: u16 = 1 << 8;
pub(crate) const MSC_CTRL_BURST32: u16 = 1 << 9;
/// `MSC_CTRL` after reset (DR active high, point of percussion and linear-g compensation on).
pub(crate) const MSC_CTRL_DEFAULT: u16 = 0x00C1;

/// Bytes clocked in after the burst command: 16-bit and 32-bit bursts.
pub(crate) const BURST16_LEN: usize = 20;
pub(crate) const BURST32_LEN: usize = 32;
