//! A simulated BMI088: two [`SpiDevice`]s (gyro and accelerometer chip selects) over one shared
//! device state behind a `critical_section::Mutex<RefCell<_>>` (no allocation, no `unsafe`;
//! `Sync`, so the firmware can hand the chip selects to an interrupt task).

use core::cell::RefCell;
use critical_section::Mutex;

use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

use super::{Cadence, SimError, SimulatedBus, for_each_byte, is_finite, next_sample, rates, round};
use crate::drivers::Mounting;
use crate::drivers::adis16505::STANDARD_GRAVITY_MPS2;
use crate::drivers::bmi088::regs;
use crate::drivers::bmi088::{
    AccelRange, FULL_SCALE_LSB, GyroRange, OUTPUT_PERIOD_S, SENSORTIME_MASK, SENSORTIME_PER_PERIOD,
    TEMP_C_PER_LSB, TEMP_OFFSET_C,
};
use crate::{Imu, ImuSample};

/// What an accelerometer still in I2C mode, or its dummy byte, puts on MISO.
const NOT_DRIVEN: u8 = 0xFF;
/// Gyro registers after a reset that differ from 0.
const GYRO_RESET_VALUES: [(u8, u8); 3] = [
    (regs::GYRO_CHIP_ID, regs::GYRO_CHIP_ID_VALUE),
    (regs::GYRO_BANDWIDTH, regs::GYRO_BANDWIDTH_READ_BIT),
    (regs::INT3_INT4_IO_CONF, 0x0F),
];
/// Accelerometer registers after a reset that differ from 0.
const ACCEL_RESET_VALUES: [(u8, u8); 4] = [
    (regs::ACC_CHIP_ID, regs::ACC_CHIP_ID_VALUE),
    (regs::ACC_CONF, 0xA8),
    (regs::ACC_RANGE, 0x01),
    (regs::ACC_PWR_CONF, regs::ACC_PWR_CONF_SUSPEND),
];

/// Where a transaction is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Waiting for the address byte.
    Address,
    /// The accelerometer's dummy byte of a read.
    Dummy,
    /// Reading from `addr` on.
    Read,
    /// Writing from `addr` on.
    Write,
}

/// One chip-select frame in progress.
#[derive(Clone, Copy, Debug)]
struct Frame {
    phase: Phase,
    addr: u8,
}

impl Frame {
    const START: Frame = Frame {
        phase: Phase::Address,
        addr: 0,
    };
}

/// The state both chip selects share.
struct Core<S> {
    source: S,
    mounting: Mounting,
    gyro: [u8; 64],
    accel: [u8; 128],
    /// The accelerometer has seen a chip-select edge since power-on or its soft reset.
    accel_spi: bool,
    /// Sensor time, 24-bit [1/25600 s].
    sensortime: u32,
    /// Output periods of held-back (non-finite) source samples, added to the next good one.
    pending_periods: u32,
    /// Samples carried over a time tag that does not advance ([`Cadence`]).
    cadence: Cadence,
    /// The source sample taken by the latest gyro data read, for the gyro device to copy.
    taken: Option<ImuSample>,
    served: u32,
}

impl<S: Imu> Core<S> {
    fn reset_gyro(&mut self) {
        self.gyro = [0; 64];
        for (addr, value) in GYRO_RESET_VALUES {
            self.gyro[usize::from(addr)] = value;
        }
    }

    fn reset_accel(&mut self) {
        self.accel = [0; 128];
        for (addr, value) in ACCEL_RESET_VALUES {
            self.accel[usize::from(addr)] = value;
        }
        self.accel_spi = false;
    }

    /// Both sensors on: the accelerometer active and enabled, the gyro in normal mode.
    fn streaming(&self) -> bool {
        self.accel[usize::from(regs::ACC_PWR_CONF)] == regs::ACC_PWR_CONF_ACTIVE
            && self.accel[usize::from(regs::ACC_PWR_CTRL)] == regs::ACC_PWR_CTRL_ON
            && self.gyro[usize::from(regs::GYRO_LPM1)] == regs::GYRO_LPM1_NORMAL
    }

    /// One byte on the gyro's chip select.
    fn gyro_clock(&mut self, f: &mut Frame, mosi: u8) -> Result<u8, SimError<S::Error>> {
        match f.phase {
            Phase::Address => {
                f.addr = mosi & !regs::READ;
                if mosi & regs::READ != 0 {
                    f.phase = Phase::Read;
                    if f.addr == regs::RATE_X_LSB && self.streaming() {
                        self.refill()?;
                    }
                } else {
                    f.phase = Phase::Write;
                }
                Ok(0x00)
            }
            Phase::Read | Phase::Dummy => {
                let miso = self.gyro[usize::from(f.addr & 0x3F)];
                f.addr = f.addr.wrapping_add(1);
                Ok(miso)
            }
            Phase::Write => {
                match f.addr {
                    regs::GYRO_SOFTRESET if mosi == regs::SOFT_RESET_CMD => self.reset_gyro(),
                    regs::GYRO_BANDWIDTH => {
                        self.gyro[usize::from(f.addr)] = mosi | regs::GYRO_BANDWIDTH_READ_BIT;
                    }
                    // Chip ID, data and status are read only.
                    0x00..=0x0E => {}
                    a => self.gyro[usize::from(a & 0x3F)] = mosi,
                }
                f.addr = f.addr.wrapping_add(1);
                Ok(0x00)
            }
        }
    }

    /// One byte on the accelerometer's chip select (in SPI mode).
    fn accel_clock(&mut self, f: &mut Frame, mosi: u8) -> u8 {
        match f.phase {
            Phase::Address => {
                f.addr = mosi & !regs::READ;
                f.phase = if mosi & regs::READ != 0 {
                    Phase::Dummy
                } else {
                    Phase::Write
                };
                0x00
            }
            Phase::Dummy => {
                f.phase = Phase::Read;
                NOT_DRIVEN
            }
            Phase::Read => {
                let miso = self.accel[usize::from(f.addr & 0x7F)];
                f.addr = f.addr.wrapping_add(1);
                miso
            }
            Phase::Write => {
                match f.addr {
                    regs::ACC_SOFTRESET if mosi == regs::SOFT_RESET_CMD => self.reset_accel(),
                    // Chip ID, error, status, data, sensor time and temperature are read only.
                    0x00..=0x3F => {}
                    a => self.accel[usize::from(a & 0x7F)] = mosi,
                }
                f.addr = f.addr.wrapping_add(1);
                0x00
            }
        }
    }

    /// Takes the next source sample into the data registers and the sensor time.
    fn refill(&mut self) -> Result<(), SimError<S::Error>> {
        let source = next_sample(&mut self.source)?;
        let (periods, sample) = self.cadence.take(source, OUTPUT_PERIOD_S);
        let periods = u32::from(periods);
        if !is_finite(&sample) {
            // No number to give: data and sensor time held (the driver sees a repeated
            // sample), the time catches up with the next good sample (a gap).
            self.pending_periods = self.pending_periods.saturating_add(periods);
        } else if periods > 0 {
            let ticks = (periods + self.pending_periods).wrapping_mul(SENSORTIME_PER_PERIOD);
            self.sensortime = self.sensortime.wrapping_add(ticks) & SENSORTIME_MASK;
            self.pending_periods = 0;
            let deg = 180.0 / core::f64::consts::PI;
            let gyro_range = GyroRange::from_code(self.gyro[usize::from(regs::GYRO_RANGE)]);
            let accel_range = AccelRange::from_code(self.accel[usize::from(regs::ACC_RANGE)]);
            let gyro_counts = (gyro_range.lsb_per_dps() * deg) as f32;
            let accel_counts = (accel_range.lsb_per_g() / STANDARD_GRAVITY_MPS2) as f32;
            let (omega, f) = rates(&sample);
            let gyro = super::to_counts(&self.mounting, omega, gyro_counts, FULL_SCALE_LSB);
            let accel = super::to_counts(&self.mounting, f, accel_counts, FULL_SCALE_LSB);
            put_xyz(&mut self.gyro, regs::RATE_X_LSB, gyro);
            put_xyz(&mut self.accel, regs::ACC_X_LSB, accel);
            let t = self.sensortime.to_le_bytes();
            let at = usize::from(regs::SENSORTIME_0);
            self.accel[at..at + 3].copy_from_slice(&t[..3]);
        }
        let temp = temp_registers(sample.temperature_c);
        let at = usize::from(regs::TEMP_MSB);
        self.accel[at..at + 2].copy_from_slice(&temp);
        self.taken = Some(sample);
        self.served = self.served.wrapping_add(1);
        Ok(())
    }
}

/// Three 16-bit values, little-endian, from register `at` on.
fn put_xyz(regs: &mut [u8], at: u8, v: [i32; 3]) {
    for (i, value) in v.into_iter().enumerate() {
        let at = usize::from(at) + 2 * i;
        regs[at..at + 2].copy_from_slice(&(value as i16).to_le_bytes());
    }
}

/// `TEMP_MSB`, `TEMP_LSB` of a temperature [deg C]; the invalid marker for NaN.
fn temp_registers(temperature_c: f32) -> [u8; 2] {
    if temperature_c.is_finite() {
        let t = round((temperature_c - TEMP_OFFSET_C) / TEMP_C_PER_LSB).clamp(-1023, 1023);
        ((t as i16) << 5).to_be_bytes()
    } else {
        [0x80, 0x00]
    }
}

/// A simulated BMI088 (see [`super`] for how source samples become register contents): owns
/// the shared state; [`SimBmi088::gyro`] and [`SimBmi088::accel`] are its two chip selects.
///
/// It implements the 8-bit register protocol of both sensors with address auto-increment, the
/// chip IDs, both soft resets, the accelerometer's I2C mode after power-on and reset (every
/// byte of a transaction reads 0xFF and writes are ignored, until the chip select rises), its
/// dummy byte on reads, its power registers, and the range registers (read at each sample for
/// the scaling). A gyro read starting at `RATE_X_LSB`, with the accelerometer active and
/// enabled and the gyro in normal mode, takes the next source sample into both sensors' data
/// registers, the sensor time and the temperature; accelerometer reads answer from them.
pub struct SimBmi088<S: Imu> {
    core: Mutex<RefCell<Core<S>>>,
}

impl<S: Imu> SimBmi088<S> {
    /// A device answering from `source`, identity mounting, in its power-on state.
    pub fn new(source: S) -> Self {
        let mut core = Core {
            source,
            mounting: Mounting::IDENTITY,
            gyro: [0; 64],
            accel: [0; 128],
            accel_spi: false,
            sensortime: 0,
            pending_periods: 0,
            cadence: Cadence::default(),
            taken: None,
            served: 0,
        };
        core.reset_gyro();
        core.reset_accel();
        SimBmi088 {
            core: Mutex::new(RefCell::new(core)),
        }
    }

    /// With the sensor-to-body rotation of the simulated mounting (give the driver the same).
    pub fn with_mounting(self, mounting: Mounting) -> Self {
        self.set_mounting(mounting);
        self
    }

    /// Sets the sensor-to-body rotation of the simulated mounting.
    pub fn set_mounting(&self, mounting: Mounting) {
        critical_section::with(|cs| self.core.borrow_ref_mut(cs).mounting = mounting);
    }

    /// The gyro's chip select (CSB2).
    pub fn gyro(&self) -> SimBmi088Gyro<'_, S> {
        SimBmi088Gyro {
            core: &self.core,
            last_sample: None,
        }
    }

    /// The accelerometer's chip select (CSB1).
    pub fn accel(&self) -> SimBmi088Accel<'_, S> {
        SimBmi088Accel { core: &self.core }
    }

    /// Source samples taken into the data registers so far.
    pub fn samples_served(&self) -> u32 {
        critical_section::with(|cs| self.core.borrow_ref(cs).served)
    }

    /// Gives the source back.
    pub fn into_source(self) -> S {
        self.core.into_inner().into_inner().source
    }
}

/// The gyro's chip select of a [`SimBmi088`].
pub struct SimBmi088Gyro<'a, S: Imu> {
    core: &'a Mutex<RefCell<Core<S>>>,
    last_sample: Option<ImuSample>,
}

impl<S: Imu> SimBmi088Gyro<'_, S> {
    /// The source sample behind the latest data read (its `t_us` is the recording's clock).
    pub fn last_source_sample(&self) -> Option<&ImuSample> {
        self.last_sample.as_ref()
    }
}

/// The accelerometer's chip select of a [`SimBmi088`].
pub struct SimBmi088Accel<'a, S: Imu> {
    core: &'a Mutex<RefCell<Core<S>>>,
}

impl<S: Imu> ErrorType for SimBmi088Gyro<'_, S> {
    type Error = SimError<S::Error>;
}

impl<S: Imu> SpiDevice for SimBmi088Gyro<'_, S> {
    /// One chip-select frame.
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Self::Error> {
        critical_section::with(|cs| {
            let mut core = self.core.borrow_ref_mut(cs);
            let mut frame = Frame::START;
            let result = for_each_byte(operations, |mosi| core.gyro_clock(&mut frame, mosi));
            if let Some(sample) = core.taken.take() {
                self.last_sample = Some(sample);
            }
            result
        })
    }
}

impl<S: Imu> ErrorType for SimBmi088Accel<'_, S> {
    type Error = SimError<S::Error>;
}

impl<S: Imu> SpiDevice for SimBmi088Accel<'_, S> {
    /// One chip-select frame; its rising edge puts an accelerometer in I2C mode into SPI mode.
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Self::Error> {
        critical_section::with(|cs| {
            let mut core = self.core.borrow_ref_mut(cs);
            if !core.accel_spi {
                let result = for_each_byte(operations, |_| Ok(NOT_DRIVEN));
                core.accel_spi = true;
                return result;
            }
            let mut frame = Frame::START;
            for_each_byte(operations, |mosi| Ok(core.accel_clock(&mut frame, mosi)))
        })
    }
}

/// The pair a [`crate::drivers::bmi088::Bmi088`] owns: the gyro serves the source samples.
impl<S: Imu> SimulatedBus for (SimBmi088Gyro<'_, S>, SimBmi088Accel<'_, S>) {
    fn last_source_sample(&self) -> Option<&ImuSample> {
        self.0.last_source_sample()
    }
}
