//! A simulated ADIS16505 / ADIS16465.

use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

use super::{
    Cadence, SimError, SimulatedBus, for_each_byte, increments_per_period, is_finite, next_sample,
    rates, round, to_counts, to_counts_carry,
};
use crate::drivers::Mounting;
use crate::drivers::adis16505::regs;
use crate::drivers::adis16505::{INTERNAL_RATE_HZ, Model, TEMP_C_PER_LSB, checksum};
use crate::{Imu, ImuSample};

/// What the simulated ADIS sends for a source sample with a NaN or infinite value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NonFinite {
    /// A frame with zero data and a wrong checksum (the default): a corrupted transfer. The
    /// device's `DATA_CNTR` still advanced, so the next good frame shows the lost sample.
    #[default]
    BadChecksum,
    /// An all-zero frame: a device that did not answer.
    ZeroFrame,
}

/// Register counts per SI unit for one burst mode.
#[derive(Clone, Copy, Debug)]
struct Counts {
    /// Gyro counts per rad/s (rates) or per rad (deltas), 16-bit word.
    gyro: f32,
    /// Accelerometer counts per m/s^2 (rates) or per m/s (deltas), 16-bit word.
    accel: f32,
}

/// A software [`SpiDevice`] that answers like an ADIS16505 or ADIS16465 (see [`super`] for how
/// source samples become bursts).
///
/// It implements the 16-bit word protocol: reads (the register comes back during the next word),
/// byte writes, `GLOB_CMD` software reset and self-test (which passes), `PROD_ID`, `DEC_RATE`
/// (the output period is `(DEC_RATE + 1) / 2000 Hz`), `MSC_CTRL` (`BURST_SEL`, `BURST32` where
/// the model has them) and the `0x6800` burst, which takes the next source sample. Chip-select
/// stalls are not checked.
pub struct SimAdis16505<S: Imu> {
    source: S,
    model: Model,
    mounting: Mounting,
    non_finite: NonFinite,
    /// 16-bit registers, index = byte address / 2.
    regs: [u16; 64],
    /// `DIAG_STAT` sent in bursts and register reads.
    diag_stat: u16,
    data_cntr: u16,
    /// Response to the previous read request, clocked out during the next word.
    pending_read: u16,
    /// The response being clocked out in the current word.
    word_out: u16,
    /// First byte of the current word, once received.
    first_byte: Option<u8>,
    /// Position in `burst` while a burst is being clocked out.
    burst_pos: Option<usize>,
    burst: [u8; regs::BURST32_LEN],
    rates: Counts,
    deltas: Counts,
    /// Rounding remainders of the delta outputs [counts], gyro then accelerometer.
    carry: [[f32; 3]; 2],
    /// [`Self::range_counts`] of the configured burst (computed in `f64`, which the Cortex-M4
    /// emulates: at each configuration write, not in the burst).
    range: [i32; 2],
    last_sample: Option<ImuSample>,
    bursts: u32,
    /// Samples carried over a time tag that does not advance ([`Cadence`]).
    cadence: Cadence,
}

impl<S: Imu> SimAdis16505<S> {
    /// A device of `model` answering from `source`, identity mounting, in its reset state.
    pub fn new(source: S, model: Model) -> Self {
        let mut sim = SimAdis16505 {
            source,
            model,
            mounting: Mounting::IDENTITY,
            non_finite: NonFinite::default(),
            regs: [0; 64],
            diag_stat: 0,
            data_cntr: 0,
            pending_read: 0,
            word_out: 0,
            first_byte: None,
            burst_pos: None,
            burst: [0; regs::BURST32_LEN],
            rates: Counts {
                gyro: (1.0 / model.gyro_rad_s_per_lsb()) as f32,
                accel: (1.0 / model.accel_mps2_per_lsb()) as f32,
            },
            deltas: Counts {
                gyro: (1.0 / model.delta_angle_rad_per_lsb()) as f32,
                accel: (1.0 / model.delta_velocity_mps_per_lsb()) as f32,
            },
            carry: [[0.0; 3]; 2],
            range: [i32::MAX; 2],
            last_sample: None,
            cadence: Cadence::default(),
            bursts: 0,
        };
        sim.reset();
        sim
    }

    /// With the sensor-to-body rotation of the simulated mounting (give the driver the same).
    pub fn with_mounting(mut self, mounting: Mounting) -> Self {
        self.mounting = mounting;
        self
    }

    /// With the frame sent for non-finite source samples.
    pub fn with_non_finite(mut self, non_finite: NonFinite) -> Self {
        self.non_finite = non_finite;
        self
    }

    /// Sets `DIAG_STAT` for the following bursts and register reads (fault injection).
    pub fn set_diag_stat(&mut self, bits: u16) {
        self.diag_stat = bits;
    }

    /// The source sample behind the latest data read (its `t_us` is the recording's clock).
    pub fn last_source_sample(&self) -> Option<&ImuSample> {
        self.last_sample.as_ref()
    }

    /// Bursts served so far.
    pub fn bursts(&self) -> u32 {
        self.bursts
    }

    /// The source.
    pub fn source(&self) -> &S {
        &self.source
    }

    /// Gives the source back.
    pub fn into_source(self) -> S {
        self.source
    }

    /// Register values after a reset.
    fn reset(&mut self) {
        self.regs = [0; 64];
        self.regs[usize::from(regs::MSC_CTRL / 2)] = regs::MSC_CTRL_DEFAULT;
        self.regs[usize::from(regs::PROD_ID / 2)] = self.model.prod_id();
        self.pending_read = 0;
        self.carry = [[0.0; 3]; 2];
        self.refresh_range();
    }

    /// The configured burst: delta outputs, and the 32-bit words.
    fn burst_mode(&self) -> (bool, bool) {
        let msc = self.reg(regs::MSC_CTRL);
        (
            self.model.has_delta_burst() && msc & regs::MSC_CTRL_BURST_SEL != 0,
            self.model.has_burst32() && msc & regs::MSC_CTRL_BURST32 != 0,
        )
    }

    /// [`Self::range`] for the configured burst.
    fn refresh_range(&mut self) {
        let (deltas, wide) = self.burst_mode();
        self.range = self.range_counts(deltas, if wide { 65536.0 } else { 1.0 });
    }

    fn reg(&self, addr: u8) -> u16 {
        self.regs[usize::from(addr / 2) % self.regs.len()]
    }

    /// One byte clocked on the bus.
    fn clock(&mut self, mosi: u8) -> Result<u8, SimError<S::Error>> {
        if let Some(pos) = self.burst_pos {
            self.burst_pos = Some(pos.saturating_add(1));
            return Ok(self.burst.get(pos).copied().unwrap_or(0));
        }
        match self.first_byte.take() {
            None => {
                self.word_out = self.pending_read;
                self.first_byte = Some(mosi);
                Ok(self.word_out.to_be_bytes()[0])
            }
            Some(first) => {
                let miso = self.word_out.to_be_bytes()[1];
                self.word(first, mosi)?;
                Ok(miso)
            }
        }
    }

    /// A complete 16-bit word `[b0, b1]`.
    fn word(&mut self, b0: u8, b1: u8) -> Result<(), SimError<S::Error>> {
        self.pending_read = 0;
        if b0 & regs::WRITE != 0 {
            self.write_byte(b0 & !regs::WRITE, b1);
        } else if b0 == regs::GLOB_CMD {
            self.start_burst()?;
        } else {
            self.pending_read = self.read_register(b0 & 0x7E);
        }
        Ok(())
    }

    fn read_register(&self, addr: u8) -> u16 {
        match addr {
            regs::DIAG_STAT => self.diag_stat,
            regs::DATA_CNTR => self.data_cntr,
            _ => self.reg(addr),
        }
    }

    fn write_byte(&mut self, addr: u8, value: u8) {
        match addr {
            regs::GLOB_CMD => {
                if value & regs::GLOB_CMD_SOFTWARE_RESET != 0 {
                    self.reset();
                }
                // A self-test passes: DIAG_STAT keeps whatever was injected.
            }
            // Outputs, GLOB_CMD's high byte and the identification registers are read only.
            0x00..=0x3F | 0x69..=0x75 => {}
            _ => {
                let reg = &mut self.regs[usize::from(addr / 2) % 64];
                let mut bytes = reg.to_le_bytes();
                bytes[usize::from(addr % 2)] = value;
                *reg = u16::from_le_bytes(bytes);
                self.refresh_range();
            }
        }
    }

    /// The output counts at the model's measurement range, gyro then accelerometer: of the
    /// rates, or of the deltas over one output period (`DEC_RATE`), in the 16-bit word's
    /// counts times `scale` (2^16 for the 32-bit burst); rounded up, so at or beyond the
    /// driver's clip threshold (the same range in `f64`).
    fn range_counts(&self, deltas: bool, scale: f32) -> [i32; 2] {
        let m = self.model;
        let gyro_rad_s = m.range().gyro_range_dps() * (core::f64::consts::PI / 180.0);
        let accel_mps2 = m.accel_range_mps2();
        let counts = if deltas {
            let dec_rate = self.reg(regs::DEC_RATE) & 0x07FF;
            let period_s = f64::from(dec_rate + 1) / f64::from(INTERNAL_RATE_HZ);
            [
                gyro_rad_s * period_s / m.delta_angle_rad_per_lsb(),
                accel_mps2 * period_s / m.delta_velocity_mps_per_lsb(),
            ]
        } else {
            [
                gyro_rad_s / m.gyro_rad_s_per_lsb(),
                accel_mps2 / m.accel_mps2_per_lsb(),
            ]
        };
        counts.map(|c| {
            let x = (c * f64::from(scale)).min(f64::from(i32::MAX));
            // Rounded up (core has no f64::ceil).
            let t = x as i32;
            if f64::from(t) < x { t + 1 } else { t }
        })
    }

    /// The burst command: takes the next source sample and prepares the frame.
    fn start_burst(&mut self) -> Result<(), SimError<S::Error>> {
        let source = next_sample(&mut self.source)?;
        let dec_rate = self.reg(regs::DEC_RATE) & 0x07FF;
        let period_s = f32::from(dec_rate + 1) / INTERNAL_RATE_HZ as f32;
        let (periods, sample) = self.cadence.take(source, period_s);
        self.data_cntr = self.data_cntr.wrapping_add(periods);
        self.fill_burst(&sample, periods);
        self.last_sample = Some(sample);
        self.burst_pos = Some(0);
        self.bursts = self.bursts.wrapping_add(1);
        Ok(())
    }

    /// Writes the burst frame of `sample` (spanning `periods` output periods) into `burst`.
    fn fill_burst(&mut self, sample: &ImuSample, periods: u16) {
        let (deltas, wide) = self.burst_mode();
        let len = if wide {
            regs::BURST32_LEN
        } else {
            regs::BURST16_LEN
        };
        let finite = is_finite(sample);
        if !finite && self.non_finite == NonFinite::ZeroFrame {
            self.burst = [0; regs::BURST32_LEN];
            return;
        }
        let (gyro, accel, counts) = if !finite {
            ([0.0; 3], [0.0; 3], self.rates)
        } else if deltas {
            let (g, a) = increments_per_period(sample, periods);
            (g, a, self.deltas)
        } else {
            let (g, a) = rates(sample);
            (g, a, self.rates)
        };
        let (scale, limit) = if wide {
            (65536.0, i32::MAX)
        } else {
            (1.0, i32::from(i16::MAX))
        };
        // A part senses no rate beyond its measurement range: each sensor axis saturates there
        // (a delta output at the range times the output period), at the count its driver
        // flags as clipped (the simulated part used to deliver 1000 deg/s from a 500 deg/s
        // part, and flag it).
        let (gyro_limit, accel_limit) = (limit.min(self.range[0]), limit.min(self.range[1]));
        let (gyro, accel) = if deltas && finite {
            let [carry_g, carry_a] = &mut self.carry;
            (
                to_counts_carry(
                    &self.mounting,
                    gyro,
                    counts.gyro * scale,
                    gyro_limit,
                    carry_g,
                ),
                to_counts_carry(
                    &self.mounting,
                    accel,
                    counts.accel * scale,
                    accel_limit,
                    carry_a,
                ),
            )
        } else {
            (
                to_counts(&self.mounting, gyro, counts.gyro * scale, gyro_limit),
                to_counts(&self.mounting, accel, counts.accel * scale, accel_limit),
            )
        };
        let temp = if sample.temperature_c.is_finite() {
            round(sample.temperature_c / TEMP_C_PER_LSB).clamp(-32768, 32767)
        } else {
            0
        };

        let mut at = 0;
        let mut put = |burst: &mut [u8], word: u16| {
            burst[at..at + 2].copy_from_slice(&word.to_be_bytes());
            at += 2;
        };
        put(&mut self.burst, self.diag_stat);
        for value in gyro.into_iter().chain(accel) {
            if wide {
                put(&mut self.burst, value as u16);
                put(&mut self.burst, (value >> 16) as u16);
            } else {
                put(&mut self.burst, value as u16);
            }
        }
        put(&mut self.burst, temp as u16);
        put(&mut self.burst, self.data_cntr);
        let mut sum = checksum(&self.burst[..len - 2]);
        if !finite {
            sum = !sum;
        }
        put(&mut self.burst, sum);
    }
}

impl<S: Imu> ErrorType for SimAdis16505<S> {
    type Error = SimError<S::Error>;
}

impl<S: Imu> SpiDevice for SimAdis16505<S> {
    /// One chip-select frame.
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Self::Error> {
        let result = for_each_byte(operations, |mosi| self.clock(mosi));
        // Chip select rises: a partial word is dropped, a burst ends.
        self.first_byte = None;
        self.burst_pos = None;
        result
    }
}

impl<S: Imu> SimulatedBus for SimAdis16505<S> {
    fn last_source_sample(&self) -> Option<&ImuSample> {
        self.last_sample.as_ref()
    }
}
