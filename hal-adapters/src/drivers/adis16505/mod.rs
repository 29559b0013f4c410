//! Analog Devices ADIS16505 (and ADIS16465, same protocol) over an
//! [`embedded_hal::spi::SpiDevice`].
//!
//! # Bus
//! SPI mode 3 (CPOL = 1, CPHA = 1), MSB first, at most [`MAX_BURST_SCLK_HZ`] (1 MHz) when bursts
//! are read ([`MAX_SCLK_HZ`] for register access only). Configure the `SpiDevice` accordingly:
//! chip select and its set-up/hold timing belong to it.
//!
//! Register access is one 16-bit word per chip-select frame, and the device needs a
//! [`STALL_US`] (16 us) chip-select-high stall between words. An `SpiDevice` cannot express a
//! minimum chip-select-high time ([`embedded_hal::spi::Operation::DelayNs`] runs with chip
//! select asserted), so the driver owns the stall: every register-level method takes a
//! [`DelayNs`] and waits after each word. The hot path, [`Adis16505::read_sample`], is one
//! transaction (command word and burst under one chip select) and needs no delay: bursts come
//! 2.5 ms apart.
//!
//! # Output: increments
//! With the ADIS16505 the driver sets `MSC_CTRL.BURST_SEL`, so the burst carries delta angles and
//! delta velocities: the device integrates its 2000 Hz samples over each 2.5 ms output interval
//! (as the Linux driver's use of them implies; not confirmed against the datasheet), free of the
//! aliasing and coning error that sampling rates at 400 Hz would add, and `nav-core` integrates
//! increments. It also sets `BURST32`: the 16-bit delta-angle LSB of the -1 model is
//! 0.011 deg per sample, far coarser than the sensor noise; the 32-bit one is 1.7e-7 deg.
//! The ADIS16465 has neither bit (per the Linux and no-OS chip tables), so it delivers 16-bit
//! [`Motion::Rates`]; [`Config::new`] picks the best each model can do.
//!
//! # Sample semantics
//! - `DEC_RATE = 4`: 400 Hz from the 2000 Hz internal rate; `dt_s` is the device's output
//!   period times the `DATA_CNTR` advance (sensor time: the measured board-clock interval is the
//!   caller's, from the `t_us` it passes).
//! - `DATA_CNTR` repeated: [`SampleFlags::STALE`], `dt_s = 0`. Advanced by `k > 1`: `k - 1`
//!   samples missed ([`Health::missed`]), [`SampleFlags::GAP`] (or [`SampleFlags::BAD_INTERVAL`]
//!   above 10 periods, as the replay does), `dt_s = k T`, and the increments are extrapolated
//!   over the whole interval (multiplied by `k`), as rates times `dt_s` would be.
//! - `DIAG_STAT` bits in [`DiagStat::SAMPLE_FAULTS`]: [`SampleFlags::DEVICE_FAULT`].
//! - A value at or beyond the measurement range ([`Range::gyro_range_dps`],
//!   [`Model::accel_range_mps2`]; for increments, range times the output period):
//!   [`SampleFlags::GYRO_SATURATED`] / [`SampleFlags::ACCEL_SATURATED`] and a clip count per
//!   sensor axis. An increment cannot show a clip inside the interval that its average hides.
//! - Bad checksum or all-zero frame: [`Error::Checksum`] / [`Error::ZeroFrame`] (transient, the
//!   next burst is independent).

mod decode;
mod model;
pub(crate) mod regs;

pub use decode::{DiagStat, FrameError, RawBurst, checksum, decode_burst};
pub use model::*;

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};

use super::health::{add, clip_mask, inc};
use super::mounting::ScaledRotation;
use super::{Error, Health, ImuDriver, Mounting};
use crate::{ImuSample, Motion, SampleFlags};

/// Above this many output periods an interval is [`SampleFlags::BAD_INTERVAL`] rather than a
/// [`SampleFlags::GAP`] (the replay's threshold).
const BAD_INTERVAL_PERIODS: u16 = 10;
/// `PROD_ID` reads that mean "nobody answered"; retried before [`Error::Timeout`].
const NO_ANSWER: [u16; 2] = [0x0000, 0xFFFF];
/// `PROD_ID` retries after the reset wait, [`PROD_ID_RETRY_MS`] apart.
const PROD_ID_RETRIES: u32 = 3;
/// Wait between `PROD_ID` retries [ms].
const PROD_ID_RETRY_MS: u32 = 100;

/// What the burst carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Output {
    /// Delta angle [rad] and delta velocity [m/s] over the output period (`BURST_SEL = 1`,
    /// ADIS16505 only): [`Motion::Increments`].
    Increments,
    /// Angular rate [rad/s] and specific force [m/s^2] (`BURST_SEL = 0`): [`Motion::Rates`].
    Rates,
}

/// Driver configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// The device and its range variant.
    pub model: Model,
    /// Burst contents.
    pub output: Output,
    /// 32-bit burst (`BURST32`, ADIS16505 only).
    pub burst32: bool,
    /// Sensor to body (forward-right-down) rotation.
    pub mounting: Mounting,
}

impl Config {
    /// The best the model supports: increments in a 32-bit burst for the ADIS16505, 16-bit rates
    /// for the ADIS16465; identity mounting.
    pub const fn new(model: Model) -> Self {
        Config {
            model,
            output: if model.has_delta_burst() {
                Output::Increments
            } else {
                Output::Rates
            },
            burst32: model.has_burst32(),
            mounting: Mounting::IDENTITY,
        }
    }

    /// With `output` (ignored by [`Adis16505::new`] where the model lacks it).
    pub const fn with_output(mut self, output: Output) -> Self {
        self.output = output;
        self
    }

    /// With or without the 32-bit burst (ignored where the model lacks it).
    pub const fn with_burst32(mut self, burst32: bool) -> Self {
        self.burst32 = burst32;
        self
    }

    /// With the sensor-to-body rotation `mounting`.
    pub const fn with_mounting(mut self, mounting: Mounting) -> Self {
        self.mounting = mounting;
        self
    }

    /// The configuration with what the model lacks switched off.
    const fn effective(mut self) -> Self {
        if !self.model.has_delta_burst() {
            self.output = Output::Rates;
        }
        if !self.model.has_burst32() {
            self.burst32 = false;
        }
        self
    }

    /// The `MSC_CTRL` burst bits of this configuration.
    const fn msc_ctrl_burst_bits(&self) -> u16 {
        let mut bits = 0;
        if matches!(self.output, Output::Increments) {
            bits |= regs::MSC_CTRL_BURST_SEL;
        }
        if self.burst32 {
            bits |= regs::MSC_CTRL_BURST32;
        }
        bits
    }

    /// Length of the burst frame after the command word [bytes].
    pub const fn frame_len(&self) -> usize {
        if self.burst32 {
            regs::BURST32_LEN
        } else {
            regs::BURST16_LEN
        }
    }
}

/// Raw counts to SI, precomputed from the configuration.
#[derive(Clone, Copy, Debug)]
struct Conversion {
    /// Raw gyro counts (sensor axes) to rad/s or rad in body axes.
    gyro: ScaledRotation,
    /// Raw accelerometer counts to m/s^2 or m/s in body axes.
    accel: ScaledRotation,
    /// |raw| at or above which a gyro axis counts as clipped.
    gyro_clip: i32,
    /// |raw| at or above which an accelerometer axis counts as clipped.
    accel_clip: i32,
}

impl Conversion {
    fn new(config: &Config) -> Self {
        let model = config.model;
        let wide = if config.burst32 { 65536.0 } else { 1.0 };
        let period = f64::from(OUTPUT_PERIOD_S);
        let gyro_range = model.range().gyro_range_dps() * (core::f64::consts::PI / 180.0);
        let accel_range = model.accel_range_mps2();
        // (scale of the 16-bit word, its count at the measurement range), gyro then accel.
        let (gyro_lsb, gyro_fs, accel_lsb, accel_fs) = match config.output {
            Output::Rates => {
                let (g, a) = (model.gyro_rad_s_per_lsb(), model.accel_mps2_per_lsb());
                (g, gyro_range / g, a, accel_range / a)
            }
            Output::Increments => {
                let (g, a) = (
                    model.delta_angle_rad_per_lsb(),
                    model.delta_velocity_mps_per_lsb(),
                );
                (g, gyro_range * period / g, a, accel_range * period / a)
            }
        };
        Conversion {
            gyro: config.mounting.scaled((gyro_lsb / wide) as f32),
            accel: config.mounting.scaled((accel_lsb / wide) as f32),
            gyro_clip: (gyro_fs * wide) as i32,
            accel_clip: (accel_fs * wide) as i32,
        }
    }
}

/// The ADIS16505 / ADIS16465 driver.
///
/// ```
/// # use hal_adapters::drivers::adis16505::{Adis16505, Config, Model, Range};
/// # use hal_adapters::sim::{NoDelay, SimAdis16505};
/// # use hal_adapters::recording::{Header, Kind, Record, Replay, Writer};
/// # let mut file = [0u8; 48 + 40];
/// # let header = Header { kind: Kind::Increments, rate_hz: 400.0, t0_ns: 0, sample_count: 1 };
/// # let mut w = Writer::new(&mut file[..], header).unwrap();
/// # let record = Record { t_ns: 2_500_000, gyro: [1e-4, 0.0, 0.0],
/// #     accel: [0.0, 0.0, -0.0245], temperature_c: 25.0 };
/// # w.write_record(&record).unwrap();
/// # w.finish().unwrap();
/// # let replay = Replay::new(&file[..]).unwrap();
/// # let spi = SimAdis16505::new(replay, Model::Adis16505(Range::Dps500));
/// # let mut delay = NoDelay;
/// let mut imu = Adis16505::new(spi, Config::new(Model::Adis16505(Range::Dps500)));
/// imu.init(&mut delay)?;
/// // In the data-ready interrupt, with the time of the edge [us]:
/// let sample = imu.read_sample(2_500)?;
/// assert!(sample.flags.usable());
/// # Ok::<(), hal_adapters::drivers::Error<_>>(())
/// ```
pub struct Adis16505<SPI> {
    spi: SPI,
    config: Config,
    conv: Conversion,
    frame: [u8; regs::BURST32_LEN],
    last_cntr: Option<u16>,
    seq: u32,
    health: Health,
    last_diag: DiagStat,
}

impl<SPI: SpiDevice> Adis16505<SPI> {
    /// A driver for the device on `spi`; nothing is sent until [`Adis16505::init`]. Options the
    /// model lacks are switched off (see [`Adis16505::config`]).
    pub fn new(spi: SPI, config: Config) -> Self {
        let config = config.effective();
        Adis16505 {
            spi,
            config,
            conv: Conversion::new(&config),
            frame: [0; regs::BURST32_LEN],
            last_cntr: None,
            seq: 0,
            health: Health::default(),
            last_diag: DiagStat::empty(),
        }
    }

    /// Software reset, `PROD_ID` check, `DEC_RATE = 4` (400 Hz) and the burst selection in
    /// `MSC_CTRL`. Call at least [`POWER_ON_MS`] after power-up. Takes about
    /// [`SOFTWARE_RESET_MS`].
    pub fn init(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<SPI::Error>> {
        self.software_reset(delay)?;
        self.check_product_id(delay)?;
        self.write_register(regs::DEC_RATE, DEC_RATE_400_HZ, delay)?;
        delay.delay_us(DEC_RATE_UPDATE_US);
        if self.config.model.has_delta_burst() || self.config.model.has_burst32() {
            let msc = self.read_register(regs::MSC_CTRL, delay)?;
            let burst_mask = regs::MSC_CTRL_BURST_SEL | regs::MSC_CTRL_BURST32;
            let wanted = (msc & !burst_mask) | self.config.msc_ctrl_burst_bits();
            if wanted != msc {
                self.write_register(regs::MSC_CTRL, wanted, delay)?;
                delay.delay_us(MSC_CTRL_UPDATE_US);
            }
        }
        self.last_cntr = None;
        self.seq = 0;
        Ok(())
    }

    /// `GLOB_CMD` software reset, then the [`SOFTWARE_RESET_MS`] recovery wait.
    pub fn software_reset(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<SPI::Error>> {
        self.write_byte(regs::GLOB_CMD, regs::GLOB_CMD_SOFTWARE_RESET, delay)?;
        delay.delay_ms(SOFTWARE_RESET_MS);
        Ok(())
    }

    /// Reads `PROD_ID` and compares it with the model's: [`Error::WrongId`] if another device
    /// answers, [`Error::Timeout`] if none does (all-zero or all-one reads) within
    /// [`PROD_ID_RETRIES`] retries.
    fn check_product_id(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<SPI::Error>> {
        let expected = self.config.model.prod_id();
        let mut found = self.read_register(regs::PROD_ID, delay)?;
        let mut retries = 0;
        while NO_ANSWER.contains(&found) && retries < PROD_ID_RETRIES {
            delay.delay_ms(PROD_ID_RETRY_MS);
            found = self.read_register(regs::PROD_ID, delay)?;
            retries += 1;
        }
        if found == expected {
            Ok(())
        } else if NO_ANSWER.contains(&found) {
            Err(Error::Timeout)
        } else {
            Err(Error::WrongId { expected, found })
        }
    }

    /// Runs the on-demand self-test (`GLOB_CMD` bit 2), waits [`SELF_TEST_MS`] and reads
    /// `DIAG_STAT`: [`Error::DeviceFault`] if a sensor failed, else the diagnostics read. Call
    /// with the device at rest, then [`Adis16505::init`] again (the burst counter moved on).
    pub fn self_test(&mut self, delay: &mut impl DelayNs) -> Result<DiagStat, Error<SPI::Error>> {
        self.write_byte(regs::GLOB_CMD, regs::GLOB_CMD_SELF_TEST, delay)?;
        delay.delay_ms(SELF_TEST_MS);
        let diag = DiagStat::from_bits_retain(self.read_register(regs::DIAG_STAT, delay)?);
        self.last_diag = diag;
        if diag.intersects(DiagStat::SELF_TEST_FAILURES) {
            Err(Error::DeviceFault(diag.bits()))
        } else {
            Ok(diag)
        }
    }

    /// Reads the 16-bit register at the even byte address `addr`: two words, each followed by
    /// the stall.
    pub fn read_register(
        &mut self,
        addr: u8,
        delay: &mut impl DelayNs,
    ) -> Result<u16, Error<SPI::Error>> {
        self.word(&mut [addr & !regs::WRITE, 0x00], delay)?;
        let mut response = [0x00, 0x00];
        self.word(&mut response, delay)?;
        Ok(u16::from_be_bytes(response))
    }

    /// Writes the 16-bit register at the even byte address `addr`: low byte, then high byte.
    pub fn write_register(
        &mut self,
        addr: u8,
        value: u16,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<SPI::Error>> {
        let [high, low] = value.to_be_bytes();
        self.write_byte(addr, low, delay)?;
        self.write_byte(addr.wrapping_add(1), high, delay)
    }

    /// Writes one byte (one word `[0x80 | addr, value]`).
    fn write_byte(
        &mut self,
        addr: u8,
        value: u8,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<SPI::Error>> {
        self.word(&mut [regs::WRITE | addr, value], delay)
    }

    /// One 16-bit word in its own chip-select frame (the response replaces `word`), then the
    /// stall.
    fn word(
        &mut self,
        word: &mut [u8; 2],
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<SPI::Error>> {
        let result = self.spi.transfer_in_place(word);
        delay.delay_us(STALL_US);
        result.map_err(|e| self.bus_error(e))
    }

    fn bus_error(&mut self, e: SPI::Error) -> Error<SPI::Error> {
        inc(&mut self.health.bus_errors);
        Error::Spi(e)
    }

    /// Reads one burst and converts it: call at data-ready with the time of the edge `t_us`
    /// [us] (the board's clock; it goes into [`ImuSample::t_us`] unchanged). Equivalent to
    /// [`Adis16505::read_burst`] then [`Adis16505::decode_burst`].
    pub fn read_sample(&mut self, t_us: u64) -> Result<ImuSample, Error<SPI::Error>> {
        self.read_burst()?;
        self.decode_burst(t_us)
    }

    /// Bus half of [`Adis16505::read_sample`]: one transaction, the `0x6800` command word then
    /// the frame.
    pub fn read_burst(&mut self) -> Result<(), Error<SPI::Error>> {
        let n = self.config.frame_len();
        let result = self.spi.transaction(&mut [
            Operation::Write(&regs::BURST_CMD),
            Operation::Read(&mut self.frame[..n]),
        ]);
        result.map_err(|e| self.bus_error(e))
    }

    /// Decode-and-convert half of [`Adis16505::read_sample`]: the last frame read, as a sample
    /// at `t_us` [us]. No bus access, no `f64`, no trigonometry.
    pub fn decode_burst(&mut self, t_us: u64) -> Result<ImuSample, Error<SPI::Error>> {
        let raw = match decode_burst(&self.frame[..self.config.frame_len()]) {
            Ok(raw) => raw,
            Err(e) => {
                inc(&mut self.health.checksum_errors);
                return Err(match e {
                    FrameError::Checksum { received, computed } => {
                        Error::Checksum { received, computed }
                    }
                    // A frame of the configured length is never `Length`.
                    FrameError::ZeroFrame | FrameError::Length => Error::ZeroFrame,
                });
            }
        };
        Ok(self.convert(&raw, t_us))
    }

    /// Counter bookkeeping, flags and SI conversion of a valid frame.
    fn convert(&mut self, raw: &RawBurst, t_us: u64) -> ImuSample {
        let mut flags = SampleFlags::empty();
        // Output periods since the previous sample (1 for the first).
        let periods = match self.last_cntr {
            None => 1,
            Some(prev) => raw.data_cntr.wrapping_sub(prev),
        };
        self.seq = match self.last_cntr {
            None => 0,
            Some(_) => self.seq.wrapping_add(u32::from(periods)),
        };
        self.last_cntr = Some(raw.data_cntr);
        match periods {
            0 => {
                flags |= SampleFlags::STALE;
                inc(&mut self.health.stale);
            }
            1 => {}
            k => {
                add(&mut self.health.missed, u32::from(k - 1));
                flags |= if k > BAD_INTERVAL_PERIODS {
                    SampleFlags::BAD_INTERVAL
                } else {
                    SampleFlags::GAP
                };
            }
        }

        let diag = DiagStat::from_bits_retain(raw.diag_stat);
        self.last_diag = diag;
        if diag.intersects(DiagStat::SAMPLE_FAULTS) {
            flags |= SampleFlags::DEVICE_FAULT;
            inc(&mut self.health.device_faults);
        }

        let gyro_clips = clip_mask(&raw.gyro, self.conv.gyro_clip);
        let accel_clips = clip_mask(&raw.accel, self.conv.accel_clip);
        if gyro_clips != 0 {
            flags |= SampleFlags::GYRO_SATURATED;
        }
        if accel_clips != 0 {
            flags |= SampleFlags::ACCEL_SATURATED;
        }
        self.health.count_clips(gyro_clips, accel_clips);

        let mut gyro = self.conv.gyro.apply(raw.gyro);
        let mut accel = self.conv.accel.apply(raw.accel);
        let dt_s = match periods {
            1 => OUTPUT_PERIOD_S,
            k => OUTPUT_PERIOD_S * f32::from(k),
        };
        let motion = match self.config.output {
            Output::Rates => Motion::Rates {
                omega_ib_b: gyro,
                f_ib_b: accel,
            },
            Output::Increments => {
                if periods > 1 {
                    // Extrapolate the last period's increment over the whole interval.
                    let k = f32::from(periods);
                    gyro = gyro.map(|g| g * k);
                    accel = accel.map(|a| a * k);
                }
                Motion::Increments {
                    delta_theta_ib_b: gyro,
                    delta_v_ib_b: accel,
                }
            }
        };
        inc(&mut self.health.samples);
        ImuSample {
            t_us,
            seq: self.seq,
            dt_s,
            motion,
            temperature_c: f32::from(raw.temp) * TEMP_C_PER_LSB,
            flags,
        }
    }

    /// `DIAG_STAT` of the last burst or self-test.
    pub fn last_diag(&self) -> DiagStat {
        self.last_diag
    }
}

super::driver_common!(Adis16505);
