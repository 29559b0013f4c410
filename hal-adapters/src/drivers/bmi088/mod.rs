//! Bosch BMI088 over two [`embedded_hal::spi::SpiDevice`]s: the gyroscope (CSB2) and the
//! accelerometer (CSB1) are separate devices in one package, with their own chip selects,
//! register maps, clocks and data-ready lines.
//!
//! # Bus
//! SPI mode 0 or 3, up to 10 MHz; 8-bit registers, address byte first (bit 7 = read). The
//! accelerometer answers a read with one dummy byte before the data, and starts in I2C mode
//! after power-on and after its soft reset: a rising edge on CSB1 switches it to SPI, so the
//! driver does a dummy read of `ACC_CHIP_ID` first. Both `SpiDevice`s must have the same error
//! type (on a board they are two chip selects on one bus).
//!
//! # Output: rates at the native 400 Hz
//! Both sensors run at 400 Hz (gyro: 47 Hz filter; accelerometer: normal filter, 145 Hz
//! per Bosch) and deliver data registers, not increments, so the driver delivers
//! [`Motion::Rates`]: integrating rates sampled at 400 Hz is what the part allows (the FIFO
//! holds the same samples). Call [`Bmi088::read_sample`] at the gyro's data-ready (INT3,
//! configured push-pull active high). The accelerometer runs on its own clock, unsynchronised
//! (Bosch's "data sync" mode needs a configuration upload and is not used): its latest sample
//! is up to one period older than the gyro's.
//!
//! # Sample semantics
//! - Sensor time (the accelerometer's 24-bit counter, 39.0625 us, read in the same burst):
//!   the periods elapsed since the previous read, rounded, are `k`. `k = 0`: the device was
//!   read twice for one sample, [`SampleFlags::STALE`], `dt_s = 0`. `k > 1`: `k - 1` data-ready
//!   edges were missed ([`Health::missed`]), [`SampleFlags::GAP`] (or
//!   [`SampleFlags::BAD_INTERVAL`] above 10 periods), `dt_s = k T`. The gyro has no counter: a
//!   stopped gyro alone goes unseen. Unchanged data is not taken as stale: a sensor at rest, a
//!   clipped axis or a simulated device repeat values legitimately.
//! - A value at full scale (|raw| >= 32767): [`SampleFlags::GYRO_SATURATED`] /
//!   [`SampleFlags::ACCEL_SATURATED`] and a clip count per sensor axis.
//! - An all-zero accelerometer frame (sensor time, data and temperature 0): [`Error::ZeroFrame`]
//!   (transient: the device did not answer).
//! - Temperature: 11-bit, 0.125 deg C, updated every 1.28 s; NaN when marked invalid.

mod decode;
pub(crate) mod regs;

pub use decode::*;

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};

use super::health::{add, clip_mask, inc};
use super::mounting::ScaledRotation;
use super::{Error, Health, ImuDriver, Mounting};
use crate::{ImuSample, Motion, SampleFlags};

/// `GYRO_CHIP_ID` of the BMI088.
pub const GYRO_CHIP_ID: u8 = regs::GYRO_CHIP_ID_VALUE;
/// `ACC_CHIP_ID` of the BMI088.
pub const ACCEL_CHIP_ID: u8 = regs::ACC_CHIP_ID_VALUE;
/// Output data rate of both sensors [Hz].
pub const ODR_HZ: u32 = 400;
/// Output period [s].
pub const OUTPUT_PERIOD_S: f32 = 0.0025;
/// Sensor-time counts per output period (2.5 ms / 39.0625 us).
pub const SENSORTIME_PER_PERIOD: u32 = SENSORTIME_HZ / ODR_HZ;
/// Wait after the gyro soft reset [ms] (Bosch `BMI08_GYRO_SOFTRESET_DELAY`).
pub const GYRO_SOFT_RESET_MS: u32 = 30;
/// Wait after the accelerometer soft reset [ms] (Bosch `BMI08_ACCEL_SOFTRESET_DELAY_MS`).
pub const ACCEL_SOFT_RESET_MS: u32 = 1;
/// Wait after each accelerometer power write (`ACC_PWR_CONF`, `ACC_PWR_CTRL`) [ms] (Bosch
/// `BMI08_POWER_CONFIG_DELAY`; longer than the datasheet's 450 us as quoted by others).
pub const ACCEL_POWER_MS: u32 = 5;
/// Full-scale magnitude of both sensors' 16-bit outputs [LSB].
pub const FULL_SCALE_LSB: i32 = 32767;

/// Above this many output periods an interval is [`SampleFlags::BAD_INTERVAL`] (as the
/// replay and the other drivers).
const BAD_INTERVAL_PERIODS: u32 = 10;

/// Gyro measurement range (`GYRO_RANGE`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroRange {
    /// +-2000 deg/s, 16.384 LSB/(deg/s) (the reset value).
    #[default]
    Dps2000,
    /// +-1000 deg/s, 32.768 LSB/(deg/s).
    Dps1000,
    /// +-500 deg/s, 65.536 LSB/(deg/s).
    Dps500,
    /// +-250 deg/s, 131.072 LSB/(deg/s).
    Dps250,
    /// +-125 deg/s, 262.144 LSB/(deg/s).
    Dps125,
}

impl GyroRange {
    /// The `GYRO_RANGE` code.
    pub const fn code(self) -> u8 {
        match self {
            GyroRange::Dps2000 => 0x00,
            GyroRange::Dps1000 => 0x01,
            GyroRange::Dps500 => 0x02,
            GyroRange::Dps250 => 0x03,
            GyroRange::Dps125 => 0x04,
        }
    }

    /// The range of a `GYRO_RANGE` code (bits 2:0; codes above 4 read as +-125 deg/s).
    pub const fn from_code(code: u8) -> Self {
        match code & 0x07 {
            0x00 => GyroRange::Dps2000,
            0x01 => GyroRange::Dps1000,
            0x02 => GyroRange::Dps500,
            0x03 => GyroRange::Dps250,
            _ => GyroRange::Dps125,
        }
    }

    /// Measurement range [deg/s].
    pub const fn range_dps(self) -> f64 {
        2000.0 / (1u32 << self.code()) as f64
    }

    /// Sensitivity: 32768 LSB at the range [LSB/(deg/s)].
    pub const fn lsb_per_dps(self) -> f64 {
        32768.0 / self.range_dps()
    }
}

/// Accelerometer measurement range (`ACC_RANGE`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelRange {
    /// +-3 g, 10920 LSB/g.
    G3,
    /// +-6 g, 5460 LSB/g (the reset value).
    G6,
    /// +-12 g, 2730 LSB/g.
    G12,
    /// +-24 g, 1365 LSB/g: the default here (vibration clipping costs more than resolution).
    #[default]
    G24,
}

impl AccelRange {
    /// The `ACC_RANGE` code.
    pub const fn code(self) -> u8 {
        match self {
            AccelRange::G3 => 0x00,
            AccelRange::G6 => 0x01,
            AccelRange::G12 => 0x02,
            AccelRange::G24 => 0x03,
        }
    }

    /// The range of an `ACC_RANGE` code (bits 1:0).
    pub const fn from_code(code: u8) -> Self {
        match code & 0x03 {
            0x00 => AccelRange::G3,
            0x01 => AccelRange::G6,
            0x02 => AccelRange::G12,
            _ => AccelRange::G24,
        }
    }

    /// Measurement range [g]: `1.5 * 2^(code + 1)` (see the facts table of
    /// [`crate::drivers`] on the factor 1.5).
    pub const fn range_g(self) -> f64 {
        1.5 * (2u32 << self.code()) as f64
    }

    /// Sensitivity: 32768 LSB at the range [LSB/g].
    pub const fn lsb_per_g(self) -> f64 {
        32768.0 / self.range_g()
    }
}

/// Driver configuration.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Gyro range.
    pub gyro_range: GyroRange,
    /// Accelerometer range.
    pub accel_range: AccelRange,
    /// Sensor to body (forward-right-down) rotation (the same for both sensors: their axes
    /// coincide in the package).
    pub mounting: Mounting,
}

/// The BMI088 driver: `GYRO` and `ACCEL` are the two chip selects' `SpiDevice`s.
pub struct Bmi088<GYRO, ACCEL> {
    /// (gyro, accelerometer).
    bus: (GYRO, ACCEL),
    config: Config,
    /// Raw gyro counts (sensor axes) to body-axis rate [rad/s].
    gyro: ScaledRotation,
    /// Raw accelerometer counts (sensor axes) to body-axis specific force [m/s^2].
    accel: ScaledRotation,
    gyro_frame: [u8; regs::GYRO_FRAME_LEN],
    /// Dummy byte, then the frame.
    accel_frame: [u8; 1 + regs::ACCEL_FRAME_LEN],
    last_sensortime: Option<u32>,
    seq: u32,
    health: Health,
}

impl<GYRO, ACCEL> Bmi088<GYRO, ACCEL>
where
    GYRO: SpiDevice,
    ACCEL: SpiDevice<Error = GYRO::Error>,
{
    /// A driver for the devices on `gyro` and `accel`; nothing is sent until
    /// [`Bmi088::init`].
    pub fn new(gyro: GYRO, accel: ACCEL, config: Config) -> Self {
        let deg = core::f64::consts::PI / 180.0;
        let gyro_lsb = deg / config.gyro_range.lsb_per_dps();
        let accel_lsb = super::adis16505::STANDARD_GRAVITY_MPS2 / config.accel_range.lsb_per_g();
        Bmi088 {
            bus: (gyro, accel),
            config,
            gyro: config.mounting.scaled(gyro_lsb as f32),
            accel: config.mounting.scaled(accel_lsb as f32),
            gyro_frame: [0; regs::GYRO_FRAME_LEN],
            accel_frame: [0; 1 + regs::ACCEL_FRAME_LEN],
            last_sensortime: None,
            seq: 0,
            health: Health::default(),
        }
    }

    /// Gyro: soft reset, chip ID; accelerometer: dummy read (to SPI mode), soft reset, dummy
    /// read again, chip ID, power on (active, then enabled, each with [`ACCEL_POWER_MS`]),
    /// 400 Hz normal filter, range; gyro: range, 400 Hz / 47 Hz, normal mode, data ready on
    /// INT3 (push-pull, active high); finally `ACC_ERR_REG` must be clear
    /// ([`Error::DeviceFault`] with its value otherwise). About 45 ms.
    pub fn init(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<GYRO::Error>> {
        self.gyro_write(regs::GYRO_SOFTRESET, regs::SOFT_RESET_CMD)?;
        delay.delay_ms(GYRO_SOFT_RESET_MS);
        check_id(self.gyro_read(regs::GYRO_CHIP_ID)?, GYRO_CHIP_ID)?;

        self.accel_read(regs::ACC_CHIP_ID)?; // CSB1 edge: to SPI mode
        self.accel_write(regs::ACC_SOFTRESET, regs::SOFT_RESET_CMD)?;
        delay.delay_ms(ACCEL_SOFT_RESET_MS);
        self.accel_read(regs::ACC_CHIP_ID)?; // back in I2C mode after the reset
        check_id(self.accel_read(regs::ACC_CHIP_ID)?, ACCEL_CHIP_ID)?;
        self.accel_write(regs::ACC_PWR_CONF, regs::ACC_PWR_CONF_ACTIVE)?;
        delay.delay_ms(ACCEL_POWER_MS);
        self.accel_write(regs::ACC_PWR_CTRL, regs::ACC_PWR_CTRL_ON)?;
        delay.delay_ms(ACCEL_POWER_MS);
        self.accel_write(regs::ACC_CONF, regs::ACC_CONF_NORMAL_400_HZ)?;
        self.accel_write(regs::ACC_RANGE, self.config.accel_range.code())?;

        self.gyro_write(regs::GYRO_RANGE, self.config.gyro_range.code())?;
        self.gyro_write(regs::GYRO_BANDWIDTH, regs::GYRO_BANDWIDTH_400_HZ)?;
        self.gyro_write(regs::GYRO_LPM1, regs::GYRO_LPM1_NORMAL)?;
        self.gyro_write(regs::GYRO_INT_CTRL, regs::GYRO_INT_CTRL_DRDY)?;
        self.gyro_write(regs::INT3_INT4_IO_CONF, regs::INT3_PUSH_PULL_ACTIVE_HIGH)?;
        self.gyro_write(regs::INT3_INT4_IO_MAP, regs::INT3_INT4_IO_MAP_DRDY_INT3)?;

        let err = self.accel_read(regs::ACC_ERR_REG)?;
        if err != 0 {
            return Err(Error::DeviceFault(err.into()));
        }
        self.last_sensortime = None;
        self.seq = 0;
        Ok(())
    }

    /// Reads one gyro register.
    pub fn gyro_read(&mut self, reg: u8) -> Result<u8, Error<GYRO::Error>> {
        let mut value = [0u8];
        let result = read_from(&mut self.bus.0, reg, &mut value);
        result.map_err(|e| self.bus_error(e))?;
        Ok(value[0])
    }

    /// Writes one gyro register.
    pub fn gyro_write(&mut self, reg: u8, value: u8) -> Result<(), Error<GYRO::Error>> {
        let result = self.bus.0.write(&[reg & !regs::READ, value]);
        result.map_err(|e| self.bus_error(e))
    }

    /// Reads one accelerometer register (the dummy byte first).
    pub fn accel_read(&mut self, reg: u8) -> Result<u8, Error<GYRO::Error>> {
        let mut value = [0u8; 2];
        let result = read_from(&mut self.bus.1, reg, &mut value);
        result.map_err(|e| self.bus_error(e))?;
        Ok(value[1])
    }

    /// Writes one accelerometer register.
    pub fn accel_write(&mut self, reg: u8, value: u8) -> Result<(), Error<GYRO::Error>> {
        let result = self.bus.1.write(&[reg & !regs::READ, value]);
        result.map_err(|e| self.bus_error(e))
    }

    fn bus_error(&mut self, e: GYRO::Error) -> Error<GYRO::Error> {
        inc(&mut self.health.bus_errors);
        Error::Spi(e)
    }

    /// Reads one sample and converts it: call at the gyro's data-ready with the time of the
    /// edge `t_us` [us] (the board's clock; it goes into [`ImuSample::t_us`] unchanged).
    /// [`Bmi088::read_frames`] then [`Bmi088::decode_frames`].
    pub fn read_sample(&mut self, t_us: u64) -> Result<ImuSample, Error<GYRO::Error>> {
        self.read_frames()?;
        self.decode_frames(t_us)
    }

    /// Bus half of [`Bmi088::read_sample`]: one gyro transaction (rates) and one
    /// accelerometer transaction (dummy byte, acceleration, sensor time, temperature).
    pub fn read_frames(&mut self) -> Result<(), Error<GYRO::Error>> {
        let result = read_from(&mut self.bus.0, regs::RATE_X_LSB, &mut self.gyro_frame);
        result.map_err(|e| self.bus_error(e))?;
        let result = read_from(&mut self.bus.1, regs::ACC_X_LSB, &mut self.accel_frame);
        result.map_err(|e| self.bus_error(e))
    }

    /// Decode-and-convert half of [`Bmi088::read_sample`]: the last frames read, as a sample
    /// at `t_us` [us]. No bus access, no `f64`, no trigonometry, no division.
    pub fn decode_frames(&mut self, t_us: u64) -> Result<ImuSample, Error<GYRO::Error>> {
        let mut frame = [0u8; regs::ACCEL_FRAME_LEN];
        frame.copy_from_slice(&self.accel_frame[1..]);
        if frame.iter().all(|&b| b == 0) {
            inc(&mut self.health.checksum_errors);
            return Err(Error::ZeroFrame);
        }
        let accel = decode_accel(&frame);
        let gyro = decode_gyro(&self.gyro_frame);

        let mut flags = SampleFlags::empty();
        let periods = match self.last_sensortime {
            None => 1,
            Some(prev) => elapsed_periods(prev, accel.sensortime, SENSORTIME_PER_PERIOD),
        };
        self.seq = match self.last_sensortime {
            None => 0,
            Some(_) => self.seq.wrapping_add(periods),
        };
        self.last_sensortime = Some(accel.sensortime);
        match periods {
            0 => {
                flags |= SampleFlags::STALE;
                inc(&mut self.health.stale);
            }
            1 => {}
            k => {
                add(&mut self.health.missed, k - 1);
                flags |= if k > BAD_INTERVAL_PERIODS {
                    SampleFlags::BAD_INTERVAL
                } else {
                    SampleFlags::GAP
                };
            }
        }

        let gyro_clips = clip_mask(&gyro, FULL_SCALE_LSB);
        let accel_clips = clip_mask(&accel.accel, FULL_SCALE_LSB);
        if gyro_clips != 0 {
            flags |= SampleFlags::GYRO_SATURATED;
        }
        if accel_clips != 0 {
            flags |= SampleFlags::ACCEL_SATURATED;
        }
        self.health.count_clips(gyro_clips, accel_clips);

        inc(&mut self.health.samples);
        Ok(ImuSample {
            t_us,
            seq: self.seq,
            dt_s: OUTPUT_PERIOD_S * periods as f32,
            motion: Motion::Rates {
                omega_ib_b: self.gyro.apply(gyro),
                f_ib_b: self.accel.apply(accel.accel),
            },
            temperature_c: temperature_c(accel.temp),
            flags,
        })
    }

    /// The configuration in effect.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Counters so far.
    pub fn health(&self) -> Health {
        self.health
    }

    /// The buses (gyro, accelerometer), e.g. simulated devices, to inspect them.
    pub fn bus(&self) -> &(GYRO, ACCEL) {
        &self.bus
    }

    /// The buses, mutably.
    pub fn bus_mut(&mut self) -> &mut (GYRO, ACCEL) {
        &mut self.bus
    }

    /// Gives the buses back: (gyro, accelerometer).
    pub fn release(self) -> (GYRO, ACCEL) {
        self.bus
    }
}

/// One read transaction: the address byte of `reg` with the read bit, then `buf` (for the
/// accelerometer, its first byte is the dummy byte).
fn read_from<S: SpiDevice>(spi: &mut S, reg: u8, buf: &mut [u8]) -> Result<(), S::Error> {
    spi.transaction(&mut [Operation::Write(&[reg | regs::READ]), Operation::Read(buf)])
}

/// [`Error::WrongId`] unless `found` is `expected`.
fn check_id<E>(found: u8, expected: u8) -> Result<(), Error<E>> {
    if found == expected {
        Ok(())
    } else {
        Err(Error::WrongId {
            expected: expected.into(),
            found: found.into(),
        })
    }
}

/// The bus of the trait is the pair (gyro, accelerometer), whose error types agree.
impl<GYRO, ACCEL> ImuDriver for Bmi088<GYRO, ACCEL>
where
    GYRO: SpiDevice,
    ACCEL: SpiDevice<Error = GYRO::Error>,
{
    type Bus = (GYRO, ACCEL);
    type BusError = GYRO::Error;

    fn init(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<GYRO::Error>> {
        Bmi088::init(self, delay)
    }

    fn read_sample(&mut self, t_us: u64) -> Result<ImuSample, Error<GYRO::Error>> {
        Bmi088::read_sample(self, t_us)
    }

    fn health(&self) -> Health {
        self.health
    }

    fn bus(&self) -> &(GYRO, ACCEL) {
        &self.bus
    }
}
