//! TDK InvenSense ICM-42688-P over an [`embedded_hal::spi::SpiDevice`].
//!
//! # Bus
//! SPI mode 0 or 3, up to 24 MHz; 8-bit registers, address byte first (bit 7 = read). No
//! stall between transactions is needed; the [`DelayNs`] passed to [`Icm42688::init`] is for
//! the reset and start-up waits only.
//!
//! # 400 Hz from 2 kHz
//! The part has no 400 Hz output data rate. The driver runs gyro and accelerometer at 2 kHz and
//! lets the FIFO collect high-resolution (20-bit) packets with timestamps; the FIFO watermark is
//! 5 packets (100 bytes) and raises INT1, the data-ready line. Each [`Icm42688::read_sample`]
//! reads the status and 5 packets in one transaction and integrates them into one 400 Hz
//! increment: the sum of the five rates times the 500 us packet period (rectangle rule). Five
//! samples per output lower aliasing and the coning error of rate sampling.
//!
//! # Sample semantics
//! - `dt_s` = 5 packet periods (sensor time), [`Motion::Increments`].
//! - FIFO timestamps (16-bit, 1 us) between consecutive packets: 0 is
//!   [`SampleFlags::STALE`]; more than 1.5 periods means packets were missed
//!   ([`Health::missed`] counts packets), [`SampleFlags::GAP`] (or
//!   [`SampleFlags::BAD_INTERVAL`] above 10 output periods), `dt_s` covers the missed packets and
//!   the increments are extrapolated over it. A gap longer than the 65.5 ms timestamp wrap
//!   goes unseen.
//! - The invalid-data marker (`-524288`) in a packet: the packet is left out of the sum (the
//!   others are extrapolated over the interval) and the sample is [`SampleFlags::NON_FINITE`]:
//!   the device had no number to give.
//! - A value at full scale: [`SampleFlags::GYRO_SATURATED`] / [`SampleFlags::ACCEL_SATURATED`]
//!   and a clip count per sensor axis.
//! - FIFO full ([`Error::FifoOverflow`]) or an unexpected packet header ([`Error::BadFrame`]):
//!   the FIFO is flushed and the next sample carries [`SampleFlags::GAP`].
//! - Fewer than 5 packets in the FIFO: those present are kept, [`Error::NotReady`].

mod decode;
pub(crate) mod regs;

pub use decode::*;

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};

use super::health::{add, clip_mask, inc};
use super::mounting::ScaledRotation;
use super::{Error, Health, ImuDriver, Mounting};
use crate::{ImuSample, Motion, SampleFlags};

/// `WHO_AM_I` of the ICM-42688-P.
pub const WHO_AM_I: u8 = regs::WHO_AM_I_VALUE;
/// Output data rate of gyro and accelerometer [Hz].
pub const ODR_HZ: u32 = 2000;
/// FIFO packet period [us].
pub const PACKET_PERIOD_US: u16 = 500;
/// FIFO packet period [s].
pub const PACKET_PERIOD_S: f32 = 0.0005;
/// Output period: [`PACKETS_PER_SAMPLE`] packets [s].
pub const OUTPUT_PERIOD_S: f32 = 0.0025;
/// FIFO watermark: one output sample [bytes].
pub const FIFO_WATERMARK_BYTES: u16 = (PACKETS_PER_SAMPLE * PACKET_LEN) as u16;
/// Wait after the soft reset [ms] (PX4: "wait 1 ms for soft reset to be effective").
pub const SOFT_RESET_MS: u32 = 1;
/// Polls of `INT_STATUS.RESET_DONE` after the soft reset, [`SOFT_RESET_MS`] apart, before
/// [`Error::Timeout`].
pub const RESET_DONE_POLLS: u32 = 10;
/// No register write for this long after switching the sensors on [us] (datasheet note
/// quoted by other drivers).
pub const POWER_MODE_SETTLE_US: u32 = 200;
/// Wait after switching the sensors on [ms]: the gyro must stay on at least 45 ms (datasheet
/// rev. 1.8 p. 77 as quoted by other drivers; PX4 waits 30 ms for valid data).
pub const SENSOR_STARTUP_MS: u32 = 50;

/// Timestamp step above which packets count as missed [us] (1.5 periods).
const GAP_THRESHOLD_US: u16 = PACKET_PERIOD_US + PACKET_PERIOD_US / 2;
/// Above this many packets an interval is [`SampleFlags::BAD_INTERVAL`] (10 output periods).
const BAD_INTERVAL_PACKETS: u32 = 10 * PACKETS_PER_SAMPLE as u32;

/// Driver configuration.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Sensor to body (forward-right-down) rotation.
    pub mounting: Mounting,
}

/// The packets of the output sample being collected.
#[derive(Clone, Copy, Debug, Default)]
struct Accumulator {
    /// Packets taken (valid or not).
    packets: u8,
    /// Packets with valid inertial data, summed below.
    valid: u8,
    /// Sums of the valid packets' raw values, sensor axes [LSB].
    gyro: [i32; 3],
    accel: [i32; 3],
    /// Sum and count of the valid temperatures [LSB].
    temp_sum: i32,
    temp_n: u8,
    /// Packets missed before or between these ones (timestamps).
    missed: u32,
    stale: bool,
    invalid: bool,
    gyro_clips: u8,
    accel_clips: u8,
}

/// The ICM-42688-P driver.
pub struct Icm42688<SPI> {
    spi: SPI,
    config: Config,
    /// Summed raw gyro counts to a body-axis angle increment [rad].
    gyro: ScaledRotation,
    /// Summed raw accelerometer counts to a body-axis velocity increment [m/s].
    accel: ScaledRotation,
    buf: [u8; READ_LEN],
    read_len: usize,
    acc: Accumulator,
    last_timestamp: Option<u16>,
    /// A flush lost packets: the next sample gets [`SampleFlags::GAP`].
    gap_pending: bool,
    delivered: bool,
    seq: u32,
    health: Health,
}

impl<SPI: SpiDevice> Icm42688<SPI> {
    /// A driver for the device on `spi`; nothing is sent until [`Icm42688::init`].
    pub fn new(spi: SPI, config: Config) -> Self {
        let deg = core::f64::consts::PI / 180.0;
        let packet_s = f64::from(PACKET_PERIOD_S);
        let gyro_lsb = deg / GYRO_LSB_PER_DPS_20 * packet_s;
        let accel_lsb = super::adis16505::STANDARD_GRAVITY_MPS2 / ACCEL_LSB_PER_G_20 * packet_s;
        Icm42688 {
            spi,
            config,
            gyro: config.mounting.scaled(gyro_lsb as f32),
            accel: config.mounting.scaled(accel_lsb as f32),
            buf: [0; READ_LEN],
            read_len: 0,
            acc: Accumulator::default(),
            last_timestamp: None,
            gap_pending: false,
            delivered: false,
            seq: 0,
            health: Health::default(),
        }
    }

    /// Soft reset, `WHO_AM_I` check, reset-done poll, AFSR off, 2 kHz at +-2000 deg/s and
    /// +-16 g, 1 us timestamps, 20-bit FIFO packets with a 5-packet watermark on INT1
    /// (push-pull, active high, pulsed), sensors on in low-noise mode, start-up wait
    /// ([`SENSOR_STARTUP_MS`]), FIFO flush.
    pub fn init(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<SPI::Error>> {
        self.write(regs::REG_BANK_SEL, 0)?;
        self.write(regs::DEVICE_CONFIG, regs::DEVICE_CONFIG_SOFT_RESET)?;
        delay.delay_ms(SOFT_RESET_MS);
        let found = self.read(regs::WHO_AM_I)?;
        if found != WHO_AM_I {
            return Err(Error::WrongId {
                expected: WHO_AM_I.into(),
                found: found.into(),
            });
        }
        let mut polls = 1;
        while self.read(regs::INT_STATUS)? & regs::INT_STATUS_RESET_DONE == 0 {
            if polls >= RESET_DONE_POLLS {
                return Err(Error::Timeout);
            }
            delay.delay_ms(SOFT_RESET_MS);
            polls += 1;
        }
        self.modify(
            regs::INTF_CONFIG1,
            regs::INTF_CONFIG1_AFSR_MASK,
            regs::INTF_CONFIG1_AFSR_DISABLE,
        )?;
        self.write(regs::GYRO_CONFIG0, regs::CONFIG0_FULL_SCALE_2_KHZ)?;
        self.write(regs::ACCEL_CONFIG0, regs::CONFIG0_FULL_SCALE_2_KHZ)?;
        self.modify(
            regs::TMST_CONFIG,
            regs::TMST_CONFIG_CLEAR,
            regs::TMST_CONFIG_EN,
        )?;
        self.write(regs::FIFO_CONFIG1, regs::FIFO_CONFIG1_HIRES_PACKETS)?;
        let [wm_high, wm_low] = FIFO_WATERMARK_BYTES.to_be_bytes();
        self.write(regs::FIFO_CONFIG2, wm_low)?;
        self.write(regs::FIFO_CONFIG3, wm_high)?;
        self.write(
            regs::INT_CONFIG,
            regs::INT_CONFIG_INT1_PUSH_PULL_ACTIVE_HIGH,
        )?;
        self.write(regs::INT_CONFIG0, regs::INT_CONFIG0_FIFO_THS_CLEAR_ON_READ)?;
        self.write(regs::INT_CONFIG1, regs::INT_CONFIG1_VALUE)?;
        self.write(regs::INT_SOURCE0, regs::INT_SOURCE0_FIFO_THS_INT1)?;
        self.write(regs::FIFO_CONFIG, regs::FIFO_CONFIG_STOP_ON_FULL)?;
        self.write(regs::PWR_MGMT0, regs::PWR_MGMT0_GYRO_ACCEL_LN)?;
        delay.delay_us(POWER_MODE_SETTLE_US);
        delay.delay_ms(SENSOR_STARTUP_MS);
        self.flush_fifo()?;
        self.gap_pending = false;
        self.delivered = false;
        self.seq = 0;
        Ok(())
    }

    /// Reads one register.
    pub fn read(&mut self, reg: u8) -> Result<u8, Error<SPI::Error>> {
        let mut value = [0u8];
        let result = self.spi.transaction(&mut [
            Operation::Write(&[reg | regs::READ]),
            Operation::Read(&mut value),
        ]);
        result.map_err(|e| self.bus_error(e))?;
        Ok(value[0])
    }

    /// Writes one register.
    pub fn write(&mut self, reg: u8, value: u8) -> Result<(), Error<SPI::Error>> {
        let result = self.spi.write(&[reg & !regs::READ, value]);
        result.map_err(|e| self.bus_error(e))
    }

    /// Read-modify-write: clears `clear`, sets `set`, keeps the other bits.
    fn modify(&mut self, reg: u8, clear: u8, set: u8) -> Result<(), Error<SPI::Error>> {
        let value = self.read(reg)?;
        self.write(reg, (value & !clear) | set)
    }

    fn bus_error(&mut self, e: SPI::Error) -> Error<SPI::Error> {
        inc(&mut self.health.bus_errors);
        Error::Spi(e)
    }

    /// Empties the FIFO (`SIGNAL_PATH_RESET.FIFO_FLUSH`) and drops the packets collected so far;
    /// the next sample carries [`SampleFlags::GAP`] if samples were delivered before. Needed
    /// after [`Error::FifoOverflow`] or [`Error::BadFrame`] from [`Icm42688::decode_fifo`]
    /// ([`Icm42688::read_sample`] does it itself).
    pub fn flush_fifo(&mut self) -> Result<(), Error<SPI::Error>> {
        self.acc = Accumulator::default();
        self.last_timestamp = None;
        self.gap_pending = self.delivered;
        self.write(regs::SIGNAL_PATH_RESET, regs::SIGNAL_PATH_RESET_FIFO_FLUSH)
    }

    /// Reads and integrates the next 400 Hz sample: call at data-ready (the FIFO watermark on
    /// INT1) with the time of the edge `t_us` [us] (the board's clock; it goes into
    /// [`ImuSample::t_us`] unchanged). [`Icm42688::read_fifo`], [`Icm42688::decode_fifo`], and
    /// [`Icm42688::flush_fifo`] after an overflow or a bad header.
    pub fn read_sample(&mut self, t_us: u64) -> Result<ImuSample, Error<SPI::Error>> {
        self.read_fifo()?;
        match self.decode_fifo(t_us) {
            Err(e @ (Error::FifoOverflow | Error::BadFrame)) => {
                self.flush_fifo()?;
                Err(e)
            }
            result => result,
        }
    }

    /// Bus half of [`Icm42688::read_sample`]: `INT_STATUS`, `FIFO_COUNT` and the packets still
    /// missing from the sample, in one transaction.
    pub fn read_fifo(&mut self) -> Result<(), Error<SPI::Error>> {
        let packets = PACKETS_PER_SAMPLE - usize::from(self.acc.packets);
        let len = STATUS_LEN + packets * PACKET_LEN;
        let result = self.spi.transaction(&mut [
            Operation::Write(&[regs::INT_STATUS | regs::READ]),
            Operation::Read(&mut self.buf[..len]),
        ]);
        self.read_len = len;
        result.map_err(|e| self.bus_error(e))
    }

    /// Decode-and-integrate half of [`Icm42688::read_sample`]: the last FIFO read, as a sample
    /// at `t_us` [us] once 5 packets are in. No bus access, no `f64`, no trigonometry.
    pub fn decode_fifo(&mut self, t_us: u64) -> Result<ImuSample, Error<SPI::Error>> {
        let mut status = [0u8; STATUS_LEN];
        status.copy_from_slice(&self.buf[..STATUS_LEN]);
        let status = decode_status(&status);
        if status.int_status & regs::INT_STATUS_FIFO_FULL != 0 || status.count >= regs::FIFO_SIZE {
            inc(&mut self.health.fifo_overflows);
            return Err(Error::FifoOverflow);
        }
        let available = usize::from(status.count) / PACKET_LEN;
        let read = (self.read_len.clamp(STATUS_LEN, READ_LEN) - STATUS_LEN) / PACKET_LEN;
        let mut packet = [0u8; PACKET_LEN];
        for i in 0..read.min(available) {
            let at = STATUS_LEN + i * PACKET_LEN;
            packet.copy_from_slice(&self.buf[at..at + PACKET_LEN]);
            match decode_packet(&packet) {
                Slot::Packet(p) => self.accumulate(&p),
                Slot::Empty => break,
                Slot::BadHeader(_) => {
                    inc(&mut self.health.checksum_errors);
                    return Err(Error::BadFrame);
                }
            }
        }
        if usize::from(self.acc.packets) < PACKETS_PER_SAMPLE {
            return Err(Error::NotReady);
        }
        Ok(self.emit(t_us))
    }

    /// Adds one packet to the sample being collected.
    fn accumulate(&mut self, p: &Packet) {
        let acc = &mut self.acc;
        if let Some(prev) = self.last_timestamp {
            let step = p.timestamp_us.wrapping_sub(prev);
            if step == 0 {
                acc.stale = true;
            } else if step > GAP_THRESHOLD_US {
                let period = u32::from(PACKET_PERIOD_US);
                let periods = (u32::from(step) + period / 2) / period;
                acc.missed = acc.missed.saturating_add(periods - 1);
            }
        }
        self.last_timestamp = Some(p.timestamp_us);
        acc.packets += 1;
        if p.accel.contains(&INVALID_20) || p.gyro.contains(&INVALID_20) {
            acc.invalid = true;
        } else {
            acc.valid += 1;
            for axis in 0..3 {
                acc.gyro[axis] += p.gyro[axis];
                acc.accel[axis] += p.accel[axis];
            }
            acc.gyro_clips |= clip_mask(&p.gyro, GYRO_FULL_SCALE_20);
            acc.accel_clips |= clip_mask(&p.accel, ACCEL_FULL_SCALE_20);
        }
        if p.temp != INVALID_TEMP {
            acc.temp_sum += i32::from(p.temp);
            acc.temp_n += 1;
        }
    }

    /// The sample of the 5 collected packets; starts a new collection.
    fn emit(&mut self, t_us: u64) -> ImuSample {
        let acc = core::mem::take(&mut self.acc);
        let mut flags = SampleFlags::empty();
        let packets = PACKETS_PER_SAMPLE as u32 + acc.missed;
        if acc.stale {
            flags |= SampleFlags::STALE;
            inc(&mut self.health.stale);
        }
        if acc.missed > 0 || self.gap_pending {
            add(&mut self.health.missed, acc.missed);
            flags |= if packets > BAD_INTERVAL_PACKETS {
                SampleFlags::BAD_INTERVAL
            } else {
                SampleFlags::GAP
            };
        }
        if acc.invalid {
            flags |= SampleFlags::NON_FINITE;
            inc(&mut self.health.invalid);
        }
        if acc.gyro_clips != 0 {
            flags |= SampleFlags::GYRO_SATURATED;
        }
        if acc.accel_clips != 0 {
            flags |= SampleFlags::ACCEL_SATURATED;
        }
        self.health.count_clips(acc.gyro_clips, acc.accel_clips);

        let mut delta_theta = self.gyro.apply(acc.gyro);
        let mut delta_v = self.accel.apply(acc.accel);
        if acc.valid == 0 {
            delta_theta = [0.0; 3];
            delta_v = [0.0; 3];
        } else if packets != u32::from(acc.valid) {
            // Extrapolate the valid packets over the whole interval.
            let k = packets as f32 / f32::from(acc.valid);
            delta_theta = delta_theta.map(|d| d * k);
            delta_v = delta_v.map(|d| d * k);
        }
        let dt_s = if acc.missed == 0 {
            OUTPUT_PERIOD_S
        } else {
            PACKET_PERIOD_S * packets as f32
        };
        let temperature_c = if acc.temp_n == 0 {
            f32::NAN
        } else {
            acc.temp_sum as f32 / (f32::from(acc.temp_n) * TEMP_LSB_PER_C) + TEMP_OFFSET_C
        };
        self.seq = if self.delivered {
            let skipped = (acc.missed + PACKETS_PER_SAMPLE as u32 / 2) / PACKETS_PER_SAMPLE as u32;
            self.seq.wrapping_add(1 + skipped)
        } else {
            0
        };
        self.delivered = true;
        self.gap_pending = false;
        inc(&mut self.health.samples);
        ImuSample {
            t_us,
            seq: self.seq,
            dt_s,
            motion: Motion::Increments {
                delta_theta_ib_b: delta_theta,
                delta_v_ib_b: delta_v,
            },
            temperature_c,
            flags,
        }
    }
}

super::driver_common!(Icm42688);
