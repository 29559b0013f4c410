//! BMI088 register maps: the gyroscope and the accelerometer are two devices with their own chip
//! selects and address spaces (datasheet rev. 1.3 ch. 5; Bosch `bmi08_defs.h`). 8-bit
//! registers; a transaction starts with the address byte, bit 7 set for a read, and the address
//! then increments. An accelerometer read returns one dummy byte before the data.

#![allow(dead_code)] // the map is documentation too: not every register is used

/// Read bit of the address byte.
pub(crate) const READ: u8 = 0x80;
/// The soft-reset command, for both `GYRO_SOFTRESET` and `ACC_SOFTRESET`.
pub(crate) const SOFT_RESET_CMD: u8 = 0xB6;

// Gyroscope (chip select CSB2).
pub(crate) const GYRO_CHIP_ID: u8 = 0x00;
pub(crate) const GYRO_CHIP_ID_VALUE: u8 = 0x0F;
/// Rate x, y, z, LSB then MSB each (reading an LSB locks its MSB).
pub(crate) const RATE_X_LSB: u8 = 0x02;
/// Bit 7: data ready; clears itself after 280-400 us (so of no use to a reader).
pub(crate) const GYRO_INT_STAT_1: u8 = 0x0A;
pub(crate) const GYRO_RANGE: u8 = 0x0F;
/// ODR and filter bandwidth code (bits 3:0); bit 7 reads 1.
pub(crate) const GYRO_BANDWIDTH: u8 = 0x10;
/// Code 0x03: 400 Hz ODR, 47 Hz filter bandwidth.
pub(crate) const GYRO_BANDWIDTH_400_HZ: u8 = 0x03;
/// Bit 7 of `GYRO_BANDWIDTH` as read back.
pub(crate) const GYRO_BANDWIDTH_READ_BIT: u8 = 0x80;
/// Power mode: 0x00 normal, 0x80 suspend, 0x20 deep suspend.
pub(crate) const GYRO_LPM1: u8 = 0x11;
pub(crate) const GYRO_LPM1_NORMAL: u8 = 0x00;
pub(crate) const GYRO_SOFTRESET: u8 = 0x14;
/// Bit 7: data-ready interrupt enable.
pub(crate) const GYRO_INT_CTRL: u8 = 0x15;
pub(crate) const GYRO_INT_CTRL_DRDY: u8 = 0x80;
/// INT3 level (bit 0, 1 = active high) and open drain (bit 1); INT4 bits 2, 3.
pub(crate) const INT3_INT4_IO_CONF: u8 = 0x16;
/// INT3 push-pull, active high.
pub(crate) const INT3_PUSH_PULL_ACTIVE_HIGH: u8 = 0x01;
/// Bit 0: data ready to INT3; bit 7: to INT4.
pub(crate) const INT3_INT4_IO_MAP: u8 = 0x18;
pub(crate) const INT3_INT4_IO_MAP_DRDY_INT3: u8 = 0x01;

// Accelerometer (chip select CSB1).
pub(crate) const ACC_CHIP_ID: u8 = 0x00;
pub(crate) const ACC_CHIP_ID_VALUE: u8 = 0x1E;
/// Bit 0 `fatal_err`, bits 4:2 `error_code` (1: invalid `ACC_CONF`).
pub(crate) const ACC_ERR_REG: u8 = 0x02;
/// Bit 7: data ready, reset when a data register is read.
pub(crate) const ACC_STATUS: u8 = 0x03;
/// Acceleration x, y, z, LSB then MSB each (reading an LSB locks its MSB).
pub(crate) const ACC_X_LSB: u8 = 0x12;
/// 24-bit sensor time, 39.0625 us per count, LSB first (0x18..=0x1A).
pub(crate) const SENSORTIME_0: u8 = 0x18;
/// Bit 7: data-ready interrupt, cleared on read.
pub(crate) const ACC_INT_STAT_1: u8 = 0x1D;
/// Temperature, 11 bits: `TEMP_MSB` then bits 7:5 of `TEMP_LSB`.
pub(crate) const TEMP_MSB: u8 = 0x22;
pub(crate) const TEMP_LSB: u8 = 0x23;
/// `acc_bwp` (bits 7:4) and `acc_odr` (bits 3:0).
pub(crate) const ACC_CONF: u8 = 0x40;
/// Normal filter (0xA), 400 Hz (0xA).
pub(crate) const ACC_CONF_NORMAL_400_HZ: u8 = 0xAA;
pub(crate) const ACC_RANGE: u8 = 0x41;
/// 0x00 active, 0x03 suspend (after reset).
pub(crate) const ACC_PWR_CONF: u8 = 0x7C;
pub(crate) const ACC_PWR_CONF_ACTIVE: u8 = 0x00;
pub(crate) const ACC_PWR_CONF_SUSPEND: u8 = 0x03;
/// 0x04 on, 0x00 off (after reset).
pub(crate) const ACC_PWR_CTRL: u8 = 0x7D;
pub(crate) const ACC_PWR_CTRL_ON: u8 = 0x04;
pub(crate) const ACC_SOFTRESET: u8 = 0x7E;

/// Bytes of a gyro data read after the address: `RATE_X_LSB..=RATE_Z_MSB`.
pub(crate) const GYRO_FRAME_LEN: usize = 6;
/// Bytes of an accelerometer data read after the address and the dummy byte:
/// `ACC_X_LSB..=TEMP_LSB` (data, sensor time, status and reserved bytes, temperature).
pub(crate) const ACCEL_FRAME_LEN: usize = (TEMP_LSB - ACC_X_LSB) as usize + 1;
