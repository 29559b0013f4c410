//! A simulated ICM-42688-P.

use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

use super::{Cadence, SimError, SimulatedBus, for_each_byte, is_finite, next_sample, rates, round};
use crate::drivers::Mounting;
use crate::drivers::adis16505::STANDARD_GRAVITY_MPS2;
use crate::drivers::icm42688::regs;
use crate::drivers::icm42688::{
    HEADER_EXPECTED, INVALID_20, INVALID_TEMP, OUTPUT_PERIOD_S, PACKET_LEN, PACKET_PERIOD_US,
    PACKETS_PER_SAMPLE, TEMP_LSB_PER_C, TEMP_OFFSET_C,
};
use crate::{Imu, ImuSample};

/// Bytes the simulated FIFO holds: one output sample.
const FIFO_BYTES: usize = PACKETS_PER_SAMPLE * PACKET_LEN;
/// What reading an empty FIFO returns (header bit 7: empty).
const EMPTY_FIFO_BYTE: u8 = 0xFF;
/// Gyro counts of the 19 significant bits per rad/s (131 LSB/(deg/s)).
const GYRO_COUNTS_19_PER_RAD_S: f64 = 131.0 * 180.0 / core::f64::consts::PI;
/// Accelerometer counts of the 18 significant bits per m/s^2 (8192 LSB/g).
const ACCEL_COUNTS_18_PER_MPS2: f64 = 8192.0 / STANDARD_GRAVITY_MPS2;

/// Bank-0 reset values that the driver reads back (others are 0).
const RESET_VALUES: [(u8, u8); 9] = [
    (regs::INTF_CONFIG0, 0x30),
    (regs::INTF_CONFIG1, 0x91),
    (regs::GYRO_CONFIG0, 0x06),
    (regs::ACCEL_CONFIG0, 0x06),
    (regs::TMST_CONFIG, 0x23),
    (regs::INT_CONFIG1, 0x10),
    (regs::INT_SOURCE0, 0x10),
    (regs::GYRO_CONFIG0 + 2, 0x16), // GYRO_CONFIG1
    (regs::GYRO_CONFIG0 + 3, 0x11), // GYRO_ACCEL_CONFIG0
];

/// Where a transaction is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Waiting for the address byte.
    Address,
    /// Reading from `addr` on.
    Read,
    /// Writing from `addr` on.
    Write,
}

/// A software [`SpiDevice`] that answers like an ICM-42688-P (see [`super`] for how source
/// samples become FIFO packets).
///
/// It implements the 8-bit register protocol with address auto-increment (not on `FIFO_DATA`),
/// bank 0, `WHO_AM_I`, the soft reset (`INT_STATUS.RESET_DONE` then set), the reset values the
/// driver reads back, `SIGNAL_PATH_RESET.FIFO_FLUSH`, and a FIFO that receives the next source
/// sample as five 20-bit packets whenever a read of `INT_STATUS`, `FIFO_COUNT` or `FIFO_DATA`
/// finds it empty — once the driver has switched both sensors on in low-noise mode, set a FIFO
/// mode and enabled 20-bit packets with accel, gyro, temperature and timestamps.
pub struct SimIcm42688<S: Imu> {
    source: S,
    mounting: Mounting,
    /// Bank-0 registers.
    regs: [u8; 128],
    int_status: u8,
    fifo: [u8; FIFO_BYTES],
    fifo_len: usize,
    fifo_pos: usize,
    timestamp_us: u16,
    phase: Phase,
    addr: u8,
    gyro_counts: f32,
    accel_counts: f32,
    last_sample: Option<ImuSample>,
    groups: u32,
    /// Samples carried over a time tag that does not advance ([`Cadence`]).
    cadence: Cadence,
}

impl<S: Imu> SimIcm42688<S> {
    /// A device answering from `source`, identity mounting, in its reset state.
    pub fn new(source: S) -> Self {
        let mut sim = SimIcm42688 {
            source,
            mounting: Mounting::IDENTITY,
            regs: [0; 128],
            int_status: 0,
            fifo: [0; FIFO_BYTES],
            fifo_len: 0,
            fifo_pos: 0,
            timestamp_us: 0,
            phase: Phase::Address,
            addr: 0,
            gyro_counts: GYRO_COUNTS_19_PER_RAD_S as f32,
            accel_counts: ACCEL_COUNTS_18_PER_MPS2 as f32,
            last_sample: None,
            cadence: Cadence::default(),
            groups: 0,
        };
        sim.reset();
        sim
    }

    /// With the sensor-to-body rotation of the simulated mounting (give the driver the same).
    pub fn with_mounting(mut self, mounting: Mounting) -> Self {
        self.mounting = mounting;
        self
    }

    /// The source sample behind the latest data read (its `t_us` is the recording's clock).
    pub fn last_source_sample(&self) -> Option<&ImuSample> {
        self.last_sample.as_ref()
    }

    /// Source samples turned into FIFO packets so far.
    pub fn samples_served(&self) -> u32 {
        self.groups
    }

    /// Sets `INT_STATUS.FIFO_FULL` for the next status read (fault injection).
    pub fn inject_fifo_overflow(&mut self) {
        self.int_status |= regs::INT_STATUS_FIFO_FULL;
    }

    /// The source.
    pub fn source(&self) -> &S {
        &self.source
    }

    /// Gives the source back.
    pub fn into_source(self) -> S {
        self.source
    }

    fn reset(&mut self) {
        self.regs = [0; 128];
        for (addr, value) in RESET_VALUES {
            self.regs[usize::from(addr)] = value;
        }
        self.int_status = regs::INT_STATUS_RESET_DONE;
        self.flush();
    }

    fn flush(&mut self) {
        self.fifo_len = 0;
        self.fifo_pos = 0;
    }

    fn bank(&self) -> u8 {
        self.regs[usize::from(regs::REG_BANK_SEL)] & 0x07
    }

    /// Both sensors on and the FIFO set up for 20-bit packets with everything in them.
    fn streaming(&self) -> bool {
        let reg = |addr: u8| self.regs[usize::from(addr)];
        reg(regs::PWR_MGMT0) & regs::PWR_MGMT0_GYRO_ACCEL_LN == regs::PWR_MGMT0_GYRO_ACCEL_LN
            && reg(regs::FIFO_CONFIG) >> 6 != 0
            && reg(regs::FIFO_CONFIG1) & 0x1F == 0x1F
    }

    /// One byte clocked on the bus.
    fn clock(&mut self, mosi: u8) -> Result<u8, SimError<S::Error>> {
        match self.phase {
            Phase::Address => {
                self.addr = mosi & !regs::READ;
                if mosi & regs::READ != 0 {
                    self.phase = Phase::Read;
                    let fifo_read = (regs::INT_STATUS..=regs::FIFO_DATA).contains(&self.addr);
                    if fifo_read
                        && self.bank() == 0
                        && self.fifo_pos >= self.fifo_len
                        && self.streaming()
                    {
                        self.refill()?;
                    }
                } else {
                    self.phase = Phase::Write;
                }
                Ok(0x00)
            }
            Phase::Read => {
                let miso = self.read_register(self.addr);
                if self.addr != regs::FIFO_DATA {
                    self.addr = (self.addr + 1) & 0x7F;
                }
                Ok(miso)
            }
            Phase::Write => {
                self.write_register(self.addr, mosi);
                self.addr = (self.addr + 1) & 0x7F;
                Ok(0x00)
            }
        }
    }

    fn read_register(&mut self, addr: u8) -> u8 {
        if addr == regs::REG_BANK_SEL {
            return self.bank();
        }
        if self.bank() != 0 {
            return 0;
        }
        let remaining = (self.fifo_len - self.fifo_pos.min(self.fifo_len)) as u16;
        match addr {
            regs::WHO_AM_I => regs::WHO_AM_I_VALUE,
            regs::INT_STATUS => core::mem::take(&mut self.int_status),
            regs::FIFO_COUNTH => remaining.to_be_bytes()[0],
            regs::FIFO_COUNTL => remaining.to_be_bytes()[1],
            regs::FIFO_DATA => {
                if self.fifo_pos < self.fifo_len {
                    self.fifo_pos += 1;
                    self.fifo[self.fifo_pos - 1]
                } else {
                    EMPTY_FIFO_BYTE
                }
            }
            _ => self.regs[usize::from(addr)],
        }
    }

    fn write_register(&mut self, addr: u8, value: u8) {
        if addr == regs::REG_BANK_SEL {
            self.regs[usize::from(addr)] = value & 0x07;
            return;
        }
        if self.bank() != 0 {
            return;
        }
        match addr {
            regs::DEVICE_CONFIG => {
                if value & regs::DEVICE_CONFIG_SOFT_RESET != 0 {
                    self.reset();
                }
            }
            regs::SIGNAL_PATH_RESET => {
                if value & regs::SIGNAL_PATH_RESET_FIFO_FLUSH != 0 {
                    self.flush();
                }
            }
            regs::WHO_AM_I | regs::INT_STATUS..=regs::FIFO_DATA => {}
            _ => self.regs[usize::from(addr)] = value,
        }
    }

    /// Takes the next source sample into the FIFO as five packets.
    fn refill(&mut self) -> Result<(), SimError<S::Error>> {
        let source = next_sample(&mut self.source)?;
        let (periods, sample) = self.cadence.take(source, OUTPUT_PERIOD_S);
        let (gyro, accel, temp) = if is_finite(&sample) {
            let (omega, f) = rates(&sample);
            let gyro = super::to_counts(&self.mounting, omega, self.gyro_counts, 262_143);
            let accel = super::to_counts(&self.mounting, f, self.accel_counts, 131_071);
            (
                gyro.map(|g| g * 2),
                accel.map(|a| a * 4),
                temp_counts(&sample),
            )
        } else {
            ([INVALID_20; 3], [INVALID_20; 3], temp_counts(&sample))
        };
        for i in 0..PACKETS_PER_SAMPLE {
            let step = match (periods, i) {
                (0, _) => 0,
                (k, 0) => PACKET_PERIOD_US.wrapping_add(
                    (k - 1).wrapping_mul(PACKETS_PER_SAMPLE as u16 * PACKET_PERIOD_US),
                ),
                _ => PACKET_PERIOD_US,
            };
            self.timestamp_us = self.timestamp_us.wrapping_add(step);
            let packet = &mut self.fifo[i * PACKET_LEN..(i + 1) * PACKET_LEN];
            write_packet(packet, &accel, &gyro, temp, self.timestamp_us);
        }
        self.fifo_len = FIFO_BYTES;
        self.fifo_pos = 0;
        self.int_status |= regs::INT_STATUS_FIFO_THS;
        self.last_sample = Some(sample);
        self.groups = self.groups.wrapping_add(1);
        Ok(())
    }
}

/// Temperature counts; the invalid marker for an unknown (NaN) temperature.
fn temp_counts(sample: &ImuSample) -> i16 {
    if sample.temperature_c.is_finite() {
        round((sample.temperature_c - TEMP_OFFSET_C) * TEMP_LSB_PER_C).clamp(-32767, 32767) as i16
    } else {
        INVALID_TEMP
    }
}

/// One 20-byte high-resolution packet.
fn write_packet(p: &mut [u8], accel: &[i32; 3], gyro: &[i32; 3], temp: i16, timestamp_us: u16) {
    // 20-bit two's complement: bits 19:12, 11:4, 3:0.
    let split = |v: i32| {
        let u = (v as u32) & 0xF_FFFF;
        ((u >> 12) as u8, (u >> 4) as u8, (u & 0xF) as u8)
    };
    p[0] = HEADER_EXPECTED;
    for axis in 0..3 {
        let (a1, a0, an) = split(accel[axis]);
        let (g1, g0, gn) = split(gyro[axis]);
        p[1 + 2 * axis] = a1;
        p[2 + 2 * axis] = a0;
        p[7 + 2 * axis] = g1;
        p[8 + 2 * axis] = g0;
        p[17 + axis] = (an << 4) | gn;
    }
    p[13..15].copy_from_slice(&temp.to_be_bytes());
    p[15..17].copy_from_slice(&timestamp_us.to_be_bytes());
}

impl<S: Imu> ErrorType for SimIcm42688<S> {
    type Error = SimError<S::Error>;
}

impl<S: Imu> SpiDevice for SimIcm42688<S> {
    /// One chip-select frame.
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Self::Error> {
        let result = for_each_byte(operations, |mosi| self.clock(mosi));
        self.phase = Phase::Address;
        result
    }
}

impl<S: Imu> SimulatedBus for SimIcm42688<S> {
    fn last_source_sample(&self) -> Option<&ImuSample> {
        self.last_sample.as_ref()
    }
}
