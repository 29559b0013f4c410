//! SPI IMU drivers over [`embedded_hal::spi::SpiDevice`] (embedded-hal 1.0).
//!
//! - [`adis16505`]: Analog Devices ADIS16505 and ADIS16465 (tactical-grade MEMS IMUs), burst
//!   reads with checksum, 400 Hz increments (ADIS16505) or rates (ADIS16465).
//! - [`icm42688`]: TDK InvenSense ICM-42688-P (consumer MEMS IMU), 2 kHz 20-bit FIFO packets
//!   integrated into 400 Hz increments.
//! - [`bmi088`]: Bosch BMI088 (consumer MEMS IMU), gyro and accelerometer on two chip selects,
//!   native 400 Hz rates.
//!
//! # Common shape
//! A driver owns its `SpiDevice` (chip select and its timing belong to it; `release()` hands it
//! back), is set up by `init(&mut delay)` and read by `read_sample(t_us)` at data-ready, with the
//! time of the data-ready edge taken by the caller [us]. It delivers the spine's
//! [`crate::ImuSample`] in body axes forward-right-down (FRD) and SI units, after only the
//! datasheet scaling and the nominal [`Mounting`] rotation (calibration belongs in `nav-core`),
//! with data-quality [`crate::SampleFlags`] and [`Health`] counters. Hard failures are
//! [`Error`]s. All drivers implement [`ImuDriver`]; the BMI088 owns two `SpiDevice`s (one per
//! chip select), so its [`ImuDriver::Bus`] is the pair `(gyro, accel)`.
//!
//! Each `read_sample` is split into a bus half (`read_burst` / `read_fifo`, one SPI
//! transaction; `read_frames`, one per chip select) and a decode half (`decode_burst` /
//! `decode_fifo` / `decode_frames`: integer decoding, one
//! 3x3 `f32` matrix product per vector with the sensitivity folded into the mounting matrix,
//! no `f64`, no trigonometry, no division on the ADIS path), so the cost of each can be
//! measured on the target.
//!
//! # Facts and their sources
//! Sources: Linux `drivers/iio/imu/adis16475.c`; Analog Devices no-OS `drivers/imu/adis1650x.c`,
//! `adis1646x.c`, `adis.c`; PX4 `adis16470` and `icm42688p` drivers; Betaflight
//! `accgyro_spi_icm426xx.c`. Only the front pages of the ADIS16505 and ADIS16465 datasheets
//! could be read here (ranges and features); no register table, timing table or the ICM-42688-P
//! datasheet was reachable. "Not confirmed" means: taken from the driver sources named, not
//! checked against a datasheet.
//!
//! | fact | sources | datasheet |
//! | ---- | ------- | --------- |
//! | ADIS gyro ranges 125/500/2000 deg/s (-1/-2/-3); ADIS16505 accel 78.4 m/s^2, ADIS16465 +-8 g; delta-angle and delta-velocity outputs | front pages | confirmed |
//! | ADIS gyro 160/40/10 LSB/(deg/s) (16-bit), x 2^16 for 32-bit | Linux, no-OS | not confirmed |
//! | ADIS16505 accel 32000 LSB at 78.4 m/s^2 | Linux and no-OS give 32000 LSB at **78** m/s^2 (an integer field); 78.4 taken | not confirmed (0.5 % apart) |
//! | ADIS16465 accel 4000 LSB/g (16-bit) | Linux, no-OS | not confirmed |
//! | delta angle +-360/720/2160 deg, delta velocity +-100 m/s, LSB = range / 2^31 (32-bit) | Linux, no-OS | not confirmed |
//! | TEMP_OUT 0.1 deg C/LSB, 0 LSB = 0 deg C | Linux, PX4 | not confirmed (offset assumed 0) |
//! | register map (DIAG_STAT 0x02 ... PROD_ID 0x72), 16-bit words, read `[addr, 0]` answered in the next word, write one byte per word with bit 7 | Linux, no-OS, PX4 | not confirmed |
//! | SPI mode 3; 16 us stall; 1 MHz burst clock | PX4 (mode 3), Linux/no-OS (16 us, 1 MHz) | not confirmed |
//! | 2 MHz register clock | project specification only | not confirmed |
//! | burst command 0x6800; 16-bit order DIAG_STAT, gyro xyz, accel xyz, TEMP_OUT, DATA_CNTR, checksum; checksum = u16 sum of the 18 bytes before it | PX4, Linux, no-OS | not confirmed |
//! | 32-bit burst: each value `_LOW` word then `_OUT` word, checksum over 30 bytes | Linux (buffer indices) | not confirmed |
//! | `MSC_CTRL` bit 8 `BURST_SEL` (deltas), bit 9 `BURST32`; ADIS16505 only, not ADIS16465 | Linux, no-OS chip flags | not confirmed |
//! | burst deltas cover the whole decimated output interval | Linux offers them as the burst alternative | not confirmed |
//! | `DATA_CNTR` advances once per output sample (after decimation) | none found | **assumed** |
//! | DIAG_STAT bits 1..7 (overrun, flash update, SPI, standby, sensor, memory, clock), 8..10 self-test (ADIS1650x) | Linux, no-OS | not confirmed |
//! | `DEC_RATE` 0x64, rate = 2000 / (DEC_RATE + 1) | Linux | not confirmed |
//! | `GLOB_CMD` 0x68: bit 7 software reset, bit 2 self-test | Linux, no-OS, PX4 | not confirmed |
//! | software reset 255-260 ms, power-on 310 ms, self-test 24-30 ms, MSC_CTRL 200 us, DEC_RATE 30 us | Linux, no-OS (PX4: 193 ms, 14 ms for the ADIS16470) | not confirmed: the longer values are used |
//! | PROD_ID 16505 / 16465 | Linux | not confirmed |
//! | ICM `WHO_AM_I` 0x75 = 0x47; bank-0 register addresses | PX4, Betaflight | not confirmed |
//! | ICM soft reset `DEVICE_CONFIG` bit 0, 1 ms, `INT_STATUS.RESET_DONE` | PX4; drivers quoting datasheet rev. 1.8 p. 65 (1 ms) | quoted, not read |
//! | ICM: no register write for 200 us after switching a sensor on; gyro kept on at least 45 ms (PX4 waits 30 ms) | drivers quoting the datasheet (rev. 1.8 p. 77) | quoted, not read (50 ms used) |
//! | ICM ODR code 0b0101 = 2 kHz, FS code 0 = 2000 deg/s / 16 g | PX4 (neighbouring codes), Betaflight | not confirmed |
//! | ICM AFSR: `INTF_CONFIG1` bits 7:6 = 0b01 disables it | Betaflight, ArduPilot PR 25332 | **not in the public datasheet** |
//! | ICM FIFO packet 4 layout, header 0b0111_10xx, 20-bit assembly, 131 LSB/(deg/s) for 19 bits, 8192 LSB/g for 18 bits, temperature 132.48 LSB/deg C + 25 | PX4 | not confirmed |
//! | ICM invalid markers -524288 (20-bit) and -32768 (temperature) | PX4 | not confirmed |
//! | ICM FIFO config bits (`FIFO_CONFIG1`, watermark in `FIFO_CONFIG2/3`, stop-on-full, `INT_CONFIG0` clear-on-read, `INT_SOURCE0` bit 2) | PX4 | not confirmed |
//! | ICM timestamp: 1 us resolution with `TMST_RES = 0`, absolute (not delta) in the FIFO | PX4 register comments; PX4 itself scales FIFO timestamps by 16 x 32/30 us and calls the resolution undocumented | **doubtful**: used only to detect gaps, with a 1.5-period margin |
//! | ICM reading from `INT_STATUS` runs on into `FIFO_DATA`, which does not auto-increment; an empty FIFO reads with header bit 7 set | PX4 (reads that way) | not confirmed |
//! | ICM reset values used by the simulated device (`INTF_CONFIG1` 0x91, `TMST_CONFIG` 0x23) | driver comments | not confirmed |
//!
//! BMI088: datasheet rev. 1.3 (BST-BMI088-DS001-13), pages 20, 21 and 27 (register
//! descriptions of the data, sensor time, status and temperature registers) could be read here;
//! other pages only through Bosch's BMI08x sensor API (`bmi08_defs.h`, `bmi08g.c`, v1.6.0) and
//! forum answers by Bosch moderators.
//!
//! | fact | sources | datasheet |
//! | ---- | ------- | --------- |
//! | BMI088 `GYRO_CHIP_ID` 0x00 = 0x0F, `ACC_CHIP_ID` 0x00 = 0x1E | Bosch API | confirmed (p. 20, 27) |
//! | rate data 0x02..=0x07 and acceleration 0x12..=0x17 LSB first, 16-bit two's complement, LSB read locks the MSB | Bosch API | confirmed (p. 20, 27) |
//! | gyro +32767 LSB = +2000 deg/s at code 0; 32768 LSB at the range used (16.384 LSB/(deg/s)), codes 0..4 = 2000/1000/500/250/125 deg/s | Bosch API, PX4 | 32767 = 2000 deg/s confirmed (p. 27); codes not confirmed |
//! | accel `ACC_RANGE` codes 0..3 = +-3/6/12/24 g, mg = raw / 32768 * 1000 * 1.5 * 2^(code+1) | Bosch API (`* 1.5`), PX4 | **conflict**: rev. 1.3 p. 21 prints the formula without the factor 1.5 (i.e. +-2..16 g); the factor is used, as by Bosch's own code |
//! | sensor time 0x18..=0x1A, 24-bit, 39.0625 us per count, wraps after 655.36 s | Bosch API | confirmed (p. 21) |
//! | temperature 0x22/0x23, 11-bit, 0.125 deg C/LSB + 23 deg C, `TEMP_MSB` 0x80 invalid, updated every 1.28 s | Bosch API | confirmed (p. 21) |
//! | `ACC_ERR_REG` 0x02 bit 0 fatal, bits 4:2 error code; `ACC_STATUS` 0x03; `ACC_INT_STAT_1` 0x1D bit 7 cleared on read | Bosch API | confirmed (p. 20, 21) |
//! | `GYRO_INT_STAT_1` 0x0A bit 7 clears itself after 280-400 us (so no use for staleness) | - | confirmed (p. 27) |
//! | reading the reserved/status bytes 0x1B..=0x21 inside the accelerometer burst has no side effect beyond clearing `ACC_INT_STAT_1` | none found | **assumed** |
//! | accelerometer SPI read returns one dummy byte first; starts in I2C mode until a CSB1 rising edge (dummy read of `ACC_CHIP_ID`), also after its soft reset | Bosch API, Bosch forum | not confirmed (datasheet section not reachable) |
//! | `ACC_PWR_CONF` 0x7C (0x00 active, 0x03 suspend), `ACC_PWR_CTRL` 0x7D (0x04 on); waits 5 ms each | Bosch API (`BMI08_POWER_CONFIG_DELAY`) | not confirmed (450 us quoted by other drivers) |
//! | soft reset 0xB6 to `ACC_SOFTRESET` 0x7E (1 ms) and `GYRO_SOFTRESET` 0x14 (30 ms) | Bosch API | not confirmed |
//! | `ACC_CONF` 0x40 = 0xAA (normal filter, 400 Hz), reset 0xA8; `ACC_RANGE` 0x41 reset 0x01 | Bosch API | not confirmed |
//! | `GYRO_BANDWIDTH` 0x10 code 0x03 = 400 Hz ODR / 47 Hz, bit 7 reads 1; `GYRO_LPM1` 0x11 = 0 normal; `GYRO_INT_CTRL` 0x15 bit 7; `INT3_INT4_IO_CONF` 0x16 bit 0 level, bit 1 open drain; `INT3_INT4_IO_MAP` 0x18 bit 0 | Bosch API | not confirmed |
//! | data registers update in step with the sensor time (one sample per 64 counts at 400 Hz), so elapsed sensor time counts output periods | BMI160 datasheet table 11 (same family) | **assumed** for the BMI088 |
//! | SPI up to 10 MHz, modes 0 and 3 | Bosch API examples | not confirmed |

/// The accessors and the [`ImuDriver`] implementation every driver shares: fields `spi`,
/// `config` and `health`, inherent `init` and `read_sample`; expanded in the driver's module.
macro_rules! driver_common {
    ($driver:ident) => {
        impl<SPI: SpiDevice> $driver<SPI> {
            /// The configuration in effect.
            pub fn config(&self) -> &Config {
                &self.config
            }

            /// Counters so far.
            pub fn health(&self) -> Health {
                self.health
            }

            /// The bus (e.g. a simulated device, to inspect it).
            pub fn bus(&self) -> &SPI {
                &self.spi
            }

            /// The bus, mutably.
            pub fn bus_mut(&mut self) -> &mut SPI {
                &mut self.spi
            }

            /// Gives the bus back.
            pub fn release(self) -> SPI {
                self.spi
            }
        }

        impl<SPI: SpiDevice> ImuDriver for $driver<SPI> {
            type Bus = SPI;
            type BusError = SPI::Error;

            fn init(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<SPI::Error>> {
                $driver::init(self, delay)
            }

            fn read_sample(&mut self, t_us: u64) -> Result<ImuSample, Error<SPI::Error>> {
                $driver::read_sample(self, t_us)
            }

            fn health(&self) -> Health {
                self.health
            }

            fn bus(&self) -> &SPI {
                &self.spi
            }
        }
    };
}
use driver_common;

pub mod adis16505;
pub mod bmi088;
mod error;
mod health;
pub mod icm42688;
mod mounting;
pub mod noise;

pub use error::Error;
pub use health::Health;
pub use mounting::{Mounting, SignedAxis};
pub use noise::NoiseSpec;

use embedded_hal::delay::DelayNs;

use crate::ImuSample;

/// What the SPI IMU drivers have in common (used by [`crate::sim::SimulatedImu`]).
pub trait ImuDriver {
    /// The bus the driver owns.
    type Bus;
    /// The bus's error.
    type BusError: core::fmt::Debug;

    /// Resets and configures the device (waits with `delay`).
    fn init(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<Self::BusError>>;

    /// Reads one sample at data-ready; `t_us` is the time of the data-ready edge [us].
    fn read_sample(&mut self, t_us: u64) -> Result<ImuSample, Error<Self::BusError>>;

    /// Counters so far.
    fn health(&self) -> Health;

    /// The bus.
    fn bus(&self) -> &Self::Bus;
}
