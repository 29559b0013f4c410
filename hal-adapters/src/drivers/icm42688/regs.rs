//! ICM-42688-P register map, user bank 0 (PX4 `InvenSense_ICM42688P_registers.hpp`, Betaflight
//! `accgyro_spi_icm426xx.c`). 8-bit registers; a transaction starts with the address byte, bit 7
//! set for a read; the address then increments, except on `FIFO_DATA`, which pops the FIFO.

#![allow(dead_code)] // the map is documentation too: not every register is used

pub(crate) const DEVICE_CONFIG: u8 = 0x11;
pub(crate) const DEVICE_CONFIG_SOFT_RESET: u8 = 1 << 0;
pub(crate) const INT_CONFIG: u8 = 0x14;
/// INT1 pulsed, push-pull, active high.
pub(crate) const INT_CONFIG_INT1_PUSH_PULL_ACTIVE_HIGH: u8 = (1 << 1) | (1 << 0);
pub(crate) const FIFO_CONFIG: u8 = 0x16;
/// `FIFO_MODE` (bits 7:6) = 0b10: stop on full.
pub(crate) const FIFO_CONFIG_STOP_ON_FULL: u8 = 0b10 << 6;
pub(crate) const TEMP_DATA1: u8 = 0x1D;
pub(crate) const INT_STATUS: u8 = 0x2D;
pub(crate) const INT_STATUS_RESET_DONE: u8 = 1 << 4;
pub(crate) const INT_STATUS_DATA_RDY: u8 = 1 << 3;
pub(crate) const INT_STATUS_FIFO_THS: u8 = 1 << 2;
pub(crate) const INT_STATUS_FIFO_FULL: u8 = 1 << 1;
pub(crate) const FIFO_COUNTH: u8 = 0x2E;
pub(crate) const FIFO_COUNTL: u8 = 0x2F;
pub(crate) const FIFO_DATA: u8 = 0x30;
pub(crate) const SIGNAL_PATH_RESET: u8 = 0x4B;
pub(crate) const SIGNAL_PATH_RESET_FIFO_FLUSH: u8 = 1 << 1;
pub(crate) const INTF_CONFIG0: u8 = 0x4C;
pub(crate) const INTF_CONFIG1: u8 = 0x4D;
/// `INTF_CONFIG1` bits 7:6: adaptive full-scale range (AFSR) control; 0b01 disables it (the
/// mode switches the gyro's range on its own and stalls the output while it does: ArduPilot
/// PR 25332, Betaflight `ICM426XX_INTF_CONFIG1_AFSR_*`). Not in the public datasheet.
pub(crate) const INTF_CONFIG1_AFSR_MASK: u8 = 0b11 << 6;
pub(crate) const INTF_CONFIG1_AFSR_DISABLE: u8 = 0b01 << 6;
pub(crate) const PWR_MGMT0: u8 = 0x4E;
/// Gyro (bits 3:2) and accelerometer (bits 1:0) in low-noise mode.
pub(crate) const PWR_MGMT0_GYRO_ACCEL_LN: u8 = (0b11 << 2) | 0b11;
pub(crate) const GYRO_CONFIG0: u8 = 0x4F;
pub(crate) const ACCEL_CONFIG0: u8 = 0x50;
/// `GYRO_FS_SEL`/`ACCEL_FS_SEL` (bits 7:5) = 0: +-2000 deg/s, +-16 g; ODR (bits 3:0) = 0b0101:
/// 2 kHz.
pub(crate) const CONFIG0_FULL_SCALE_2_KHZ: u8 = 0b0101;
pub(crate) const TMST_CONFIG: u8 = 0x54;
pub(crate) const TMST_CONFIG_EN: u8 = 1 << 0;
/// `TMST_TO_REGS_EN`, `TMST_RES` (16 us), `TMST_DELTA_EN`, `TMST_FSYNC_EN`: all cleared.
pub(crate) const TMST_CONFIG_CLEAR: u8 = (1 << 4) | (1 << 3) | (1 << 2) | (1 << 1);
pub(crate) const FIFO_CONFIG1: u8 = 0x5F;
/// Watermark interrupt while count >= watermark, 20-bit (high-resolution) packets, timestamps,
/// temperature, gyro, accelerometer.
pub(crate) const FIFO_CONFIG1_HIRES_PACKETS: u8 =
    (1 << 5) | (1 << 4) | (1 << 3) | (1 << 2) | (1 << 1) | 1;
pub(crate) const FIFO_CONFIG2: u8 = 0x60;
pub(crate) const FIFO_CONFIG3: u8 = 0x61;
pub(crate) const INT_CONFIG0: u8 = 0x63;
/// `FIFO_THS_INT_CLEAR` (bits 3:2) = 0b10: cleared by reading FIFO data.
pub(crate) const INT_CONFIG0_FIFO_THS_CLEAR_ON_READ: u8 = 0b10 << 2;
pub(crate) const INT_CONFIG1: u8 = 0x64;
/// `INT_ASYNC_RESET` (bit 4) cleared, as the datasheet asks for proper INT1/INT2 operation.
pub(crate) const INT_CONFIG1_VALUE: u8 = 0x00;
pub(crate) const INT_SOURCE0: u8 = 0x65;
pub(crate) const INT_SOURCE0_FIFO_THS_INT1: u8 = 1 << 2;
pub(crate) const WHO_AM_I: u8 = 0x75;
pub(crate) const REG_BANK_SEL: u8 = 0x76;

/// Read bit of the address byte.
pub(crate) const READ: u8 = 0x80;
/// `WHO_AM_I` of the ICM-42688-P.
pub(crate) const WHO_AM_I_VALUE: u8 = 0x47;
/// FIFO size [bytes].
pub(crate) const FIFO_SIZE: u16 = 2048;
