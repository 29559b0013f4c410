//! Simulated IMUs on the bus: software [`SpiDevice`]s that answer like an ADIS16505 / ADIS16465
//! ([`SimAdis16505`]), an ICM-42688-P ([`SimIcm42688`]) or a BMI088 ([`SimBmi088`], two chip
//! selects over one shared state) from a stream of samples (any [`Imu`], typically a
//! [`crate::recording::Replay`]).
//!
//! The real drivers run over them unchanged, so the firmware in QEMU exercises the driver code
//! path (init sequence, burst or FIFO read, checksum, counters, conversion) without hardware.
//! `no_std`, no allocation, deterministic (integer state and `f32` arithmetic only, no time
//! source): the host harness running the same simulation and driver gets bit-identical samples.
//!
//! Each data read (an ADIS burst, an ICM FIFO read that finds the FIFO empty) takes the next
//! source sample. The simulated device converts it from body axes to sensor axes with the
//! transpose of its [`Mounting`] and to register counts (nearest count, clamped to the
//! register's range; delta outputs carry the rounding remainder to the next sample, as an
//! integrating sensor does), so a driver configured with the same mounting gets the source back
//! within one count. Recording events become what the device would show:
//!
//! | source sample | ADIS16505 | ICM-42688-P |
//! | --- | --- | --- |
//! | interval of `k` periods (`dt_s / T` rounded; 2.5 ms) | `DATA_CNTR` advances by `k`: the driver flags `GAP` (`k` 2..=10) or `BAD_INTERVAL`, increments per period = sample / `k` | first packet's timestamp jumps by `k - 1` output periods: same flags, rates = sample / `dt_s` |
//! | `dt_s <= 0` (`BAD_INTERVAL` in the replay) | `DATA_CNTR` repeated: `STALE`; its increments carried to the next sample, which spans the time since the last one shown (`Cadence`) | timestamps repeated: `STALE`; the same |
//! | a NaN or infinite value (`NON_FINITE`) | [`NonFinite::BadChecksum`] (default): a frame with a wrong checksum, the driver returns [`Error::Checksum`], the next sample shows the lost one as a `GAP`; or [`NonFinite::ZeroFrame`]; either way the sample stream delivers the source sample, `NON_FINITE` ([`flag_unrepresentable`]) | the invalid-data marker in all five packets: `NON_FINITE`, zero increments |
//! | NaN temperature (unknown) | `TEMP_OUT` = 0 (0 deg C) | invalid temperature: NaN |
//! | value beyond the measurement range (the model's: +-500 deg/s for the -2 part; a delta output at the range times the output period) | saturated at the range, its remainder dropped: the driver flags saturation | clamped to full scale: saturation |
//! | end of the source | every bus transaction fails with [`SimError::End`] | the same |
//!
//! The BMI088 ([`SimBmi088`]) takes the next source sample at each gyro data read (the driver
//! reads at the gyro's data-ready) into both sensors' rate registers (nearest count, clamped to
//! +-32767: saturation) and advances its sensor time by `k` periods of 64 counts (`k` as above):
//! the driver sees `GAP` / `BAD_INTERVAL`; `dt_s <= 0` holds data and sensor time: `STALE`. A
//! non-finite sample also holds them (`STALE`, and `NON_FINITE` in the sample stream), and the
//! next sample's sensor time covers the lost period (`GAP`). A NaN temperature becomes the
//! invalid marker (NaN again).
//!
//! No register holds a NaN or an infinity, so whatever a device makes of a non-finite source
//! sample, the sample stream ([`SimulatedImu`], the firmware's board IMU) delivers it flagged
//! `NON_FINITE` ([`flag_unrepresentable`]): the sample is counted as non-finite on every device
//! path, as a plain replay of the recording counts it, and the driver's own handling (a rejected
//! frame, an invalid marker, held data) still runs and is counted in its health.
//!
//! # Firmware use
//! ```
//! use hal_adapters::drivers::adis16505::{Adis16505, Config, Model, Range};
//! use hal_adapters::drivers::Error;
//! use hal_adapters::recording::Replay;
//! use hal_adapters::sim::{NoDelay, SimAdis16505, SimError};
//! # use hal_adapters::recording::{Header, Kind, Record, Writer};
//! # let mut file = [0u8; 48 + 2 * 40];
//! # let header = Header { kind: Kind::Increments, rate_hz: 400.0, t0_ns: 0, sample_count: 2 };
//! # let mut w = Writer::new(&mut file[..], header).unwrap();
//! # for i in 1..=2u64 {
//! #     let record = Record { t_ns: i * 2_500_000, gyro: [1e-4, 0.0, 0.0],
//! #         accel: [0.0, 0.0, -0.0245], temperature_c: 25.0 };
//! #     w.write_record(&record).unwrap();
//! # }
//! # w.finish().unwrap();
//! # let bytes: &[u8] = &file;
//!
//! // init: the recording becomes a device on the bus, the driver initialises it.
//! let model = Model::Adis16505(Range::Dps500);
//! let replay = Replay::new(bytes).expect("valid recording");
//! let mut imu = Adis16505::new(SimAdis16505::new(replay, model), Config::new(model));
//! imu.init(&mut NoDelay)?;
//!
//! // data-ready: timestamp first, then one burst.
//! let t_ready_us = 2_500; // the board's clock at the edge
//! match imu.read_sample(t_ready_us) {
//!     Ok(sample) => { /* try_send(sample) */ }
//!     Err(Error::Spi(SimError::End)) => { /* the recording is over */ }
//!     Err(e) if e.is_transient() => { /* counted in imu.health(); wait for the next edge */ }
//!     Err(e) => panic!("IMU failed: {e}"),
//! }
//! // The recording's own time of that sample, if the log should carry it:
//! let t_recording_us = imu.bus().last_source_sample().map(|s| s.t_us);
//! assert_eq!(t_recording_us, Some(2_500));
//! # Ok::<(), Error<SimError<hal_adapters::recording::ReplayError<core::convert::Infallible>>>>(())
//! ```
//! The host harness gets the same samples as an [`Imu`] from [`SimulatedImu`].

mod adis16505;
mod bmi088;
mod icm42688;

pub use adis16505::{NonFinite, SimAdis16505};
pub use bmi088::{SimBmi088, SimBmi088Accel, SimBmi088Gyro};
pub use icm42688::SimIcm42688;

use core::fmt;

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{ErrorKind, Operation};

use crate::drivers::adis16505::{self as adis, Adis16505};
use crate::drivers::bmi088::{self as bmi, Bmi088};
use crate::drivers::icm42688::{self as icm, Icm42688};
use crate::drivers::{Error, Health, ImuDriver, Mounting};
use crate::{Imu, ImuSample, Motion, SampleFlags};

/// A [`DelayNs`] that returns at once: a simulated device needs no waiting.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoDelay;

impl DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}

/// Error of a simulated device's bus: the end of its sample source, or the source's error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SimError<E> {
    /// The source has no more samples.
    End,
    /// The source failed (carried).
    Source(E),
}

impl<E: fmt::Debug> embedded_hal::spi::Error for SimError<E> {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

impl<E: fmt::Display> fmt::Display for SimError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimError::End => write!(f, "end of the simulated device's samples"),
            SimError::Source(e) => write!(f, "simulated device's source failed: {e}"),
        }
    }
}

/// The simulated devices' output rate [Hz]: each answers one source sample per output period
/// of 2.5 ms (the ADIS16505's, ICM-42688-P's and BMI088's `OUTPUT_PERIOD_S`), and the qemu
/// board raises its data-ready line at that rate.
pub const DEVICE_RATE_HZ: f64 = 400.0;

/// Farthest a source's rate may be from [`DEVICE_RATE_HZ`], relative (a binary recording's
/// header rate is held to its time tags within the same 1 %).
pub const DEVICE_RATE_TOLERANCE: f64 = 0.01;

/// A source whose rate is not the simulated devices' output rate ([`check_source_rate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateMismatch {
    /// The source's rate [Hz].
    pub rate_hz: f64,
}

impl fmt::Display for RateMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Each output period takes the next sample, whatever the recording's rate.
        let rate = nav_core::number::Number(self.rate_hz);
        write!(
            f,
            "the recording's rate {rate} Hz is not the simulated IMU's output rate of {} Hz: ",
            DEVICE_RATE_HZ
        )?;
        if self.rate_hz > DEVICE_RATE_HZ {
            write!(
                f,
                "each output period would take the next sample, so the motion would be played \
                 {} times slower than it was recorded",
                nav_core::number::Number(self.rate_hz / DEVICE_RATE_HZ)
            )?;
        } else {
            f.write_str("each sample would reach the driver as a gap of several output periods")?;
        }
        f.write_str(" (a recording read through a device must be at its rate)")
    }
}

/// Checks that a source at `rate_hz` can be served by a simulated device: within
/// [`DEVICE_RATE_TOLERANCE`] of [`DEVICE_RATE_HZ`]. Each data read takes the next source
/// sample, so a 100 Hz recording became samples four output periods apart: its alignment
/// failed for a reason that was not the recording's ("window not complete", "base not still",
/// "horizontal Earth rate not measurable") on the ICM-42688-P and BMI088, and an inertial one on
/// the ADIS16505.
pub fn check_source_rate(rate_hz: f64) -> Result<(), RateMismatch> {
    if (rate_hz / DEVICE_RATE_HZ - 1.0).abs() <= DEVICE_RATE_TOLERANCE {
        Ok(())
    } else {
        Err(RateMismatch { rate_hz })
    }
}

/// A simulated device: which source sample it serves.
pub trait SimulatedBus {
    /// The source sample behind the latest data read (its `t_us` is the recording's clock).
    fn last_source_sample(&self) -> Option<&ImuSample>;
}

/// One data read's result as the sample stream delivers it, given the `source` sample behind
/// the read ([`SimulatedBus::last_source_sample`]): when that sample has a NaN or infinite value,
/// which no register can hold, the result is flagged [`SampleFlags::NON_FINITE`] whatever the
/// device made of it. A frame the driver rejected as corrupt ([`Error::Checksum`],
/// [`Error::ZeroFrame`]: the ADIS16505's [`NonFinite`] answers) becomes the source sample itself
/// (its time, its flags); a sample the driver decoded (the ICM-42688-P's invalid marker, the
/// BMI088's held data) gets the flag added. Other results pass unchanged.
pub fn flag_unrepresentable<E>(
    result: Result<ImuSample, Error<E>>,
    source: Option<&ImuSample>,
) -> Result<ImuSample, Error<E>> {
    let Some(source) = source.filter(|s| !is_finite(s)) else {
        return result;
    };
    match result {
        Ok(mut sample) => {
            sample.flags |= SampleFlags::NON_FINITE;
            Ok(sample)
        }
        Err(Error::Checksum { .. } | Error::ZeroFrame) => {
            let mut sample = *source;
            sample.flags |= SampleFlags::NON_FINITE;
            Ok(sample)
        }
        Err(e) => Err(e),
    }
}

/// Consecutive transient driver errors [`SimulatedImu`] skips before it reports one.
const MAX_CONSECUTIVE_TRANSIENT: u32 = 64;

/// A driver over a simulated device, as an [`Imu`]: the host harness's way to run the exact
/// sample path of the firmware.
///
/// Each [`Imu::read_sample`] is one data-ready: [`ImuDriver::read_sample`], with `t_us` set to
/// the source sample's `t_us` (the recording's clock, as [`crate::recording::Replay`] gives).
/// A non-finite source sample is delivered flagged ([`flag_unrepresentable`]); other transient
/// driver errors are skipped like a data-ready whose burst was rejected, and counted in the
/// driver's health; the end of the source is `Ok(None)`.
pub struct SimulatedImu<D> {
    driver: D,
    ended: bool,
}

/// The driver's counters `health` once its simulated device has ended the recording: the data
/// read that found the source at its end failed on the bus ([`SimError::End`]) and was counted as
/// a bus error, which it is not. The firmware's board IMU and [`SimulatedImu::health`] both
/// report this.
pub fn health_at_end(mut health: Health) -> Health {
    health.bus_errors = health.bus_errors.saturating_sub(1);
    health
}

impl<D> SimulatedImu<D> {
    /// Wraps an initialised driver.
    pub fn new(driver: D) -> Self {
        SimulatedImu {
            driver,
            ended: false,
        }
    }

    /// The driver.
    pub fn driver(&self) -> &D {
        &self.driver
    }

    /// The driver, mutably.
    pub fn driver_mut(&mut self) -> &mut D {
        &mut self.driver
    }

    /// Gives the driver back.
    pub fn into_driver(self) -> D {
        self.driver
    }
}

impl<S: Imu> SimulatedImu<Adis16505<SimAdis16505<S>>> {
    /// A simulated ADIS16505/ADIS16465 answering from `source`, with the driver configured by
    /// `config` (the device shares its model and mounting) and initialised.
    pub fn adis16505(source: S, config: adis::Config) -> Result<Self, Error<SimError<S::Error>>> {
        let bus = SimAdis16505::new(source, config.model).with_mounting(config.mounting);
        let mut driver = Adis16505::new(bus, config);
        driver.init(&mut NoDelay)?;
        Ok(Self::new(driver))
    }
}

impl<S: Imu> SimulatedImu<Icm42688<SimIcm42688<S>>> {
    /// A simulated ICM-42688-P answering from `source`, with the driver configured by `config`
    /// (the device shares its mounting) and initialised.
    pub fn icm42688(source: S, config: icm::Config) -> Result<Self, Error<SimError<S::Error>>> {
        let bus = SimIcm42688::new(source).with_mounting(config.mounting);
        let mut driver = Icm42688::new(bus, config);
        driver.init(&mut NoDelay)?;
        Ok(Self::new(driver))
    }
}

impl<'a, S: Imu> SimulatedImu<Bmi088<SimBmi088Gyro<'a, S>, SimBmi088Accel<'a, S>>> {
    /// A simulated BMI088 (`device`, which takes the mounting of `config`), with the driver
    /// configured by `config` over its two chip selects and initialised. The device lives
    /// outside (both chip selects borrow it); [`SimBmi088::into_source`] gives the source back.
    pub fn bmi088(
        device: &'a SimBmi088<S>,
        config: bmi::Config,
    ) -> Result<Self, Error<SimError<S::Error>>> {
        device.set_mounting(config.mounting);
        let mut driver = Bmi088::new(device.gyro(), device.accel(), config);
        driver.init(&mut NoDelay)?;
        Ok(Self::new(driver))
    }
}

impl<D: ImuDriver> SimulatedImu<D> {
    /// The driver's counters so far; after the end of the source, without the end's failed
    /// read ([`health_at_end`]).
    pub fn health(&self) -> Health {
        let health = self.driver.health();
        if self.ended {
            health_at_end(health)
        } else {
            health
        }
    }
}

/// A simulated IMU's failure ([`SimulatedImu`]): its driver's, or that of the sample source
/// behind the simulated device (a corrupt recording is no bus error: it was shown as `SPI bus
/// error: Source(Format(FormatError { .. }))`, and counted as one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimulatedImuError<E> {
    /// The driver failed (the simulated device's checksum, frame or fault).
    Driver(Error<SimError<E>>),
    /// The sample source failed: its error.
    Source(E),
}

impl<E: fmt::Debug + fmt::Display> fmt::Display for SimulatedImuError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Driver(e) => write!(f, "{e}"),
            Self::Source(e) => write!(f, "{e}"),
        }
    }
}

impl<E: fmt::Debug + fmt::Display> core::error::Error for SimulatedImuError<E> {}

impl<D, E> Imu for SimulatedImu<D>
where
    D: ImuDriver<BusError = SimError<E>>,
    D::Bus: SimulatedBus,
    E: fmt::Debug + fmt::Display,
{
    type Error = SimulatedImuError<E>;

    /// The next sample; `Ok(None)` once the source has ended (and after that, without a
    /// further read).
    fn read_sample(&mut self) -> Result<Option<ImuSample>, Self::Error> {
        if self.ended {
            return Ok(None);
        }
        let mut transient = 0;
        loop {
            let read = self.driver.read_sample(0);
            match flag_unrepresentable(read, self.driver.bus().last_source_sample()) {
                Ok(mut sample) => {
                    if let Some(source) = self.driver.bus().last_source_sample() {
                        sample.t_us = source.t_us;
                    }
                    return Ok(Some(sample));
                }
                Err(Error::Spi(SimError::End)) => {
                    self.ended = true;
                    return Ok(None);
                }
                Err(Error::Spi(SimError::Source(e))) => {
                    // Not a bus error either ([`health_at_end`]); nothing is read after it.
                    self.ended = true;
                    return Err(SimulatedImuError::Source(e));
                }
                Err(e) if e.is_transient() && transient < MAX_CONSECUTIVE_TRANSIENT => {
                    transient += 1;
                }
                Err(e) => return Err(SimulatedImuError::Driver(e)),
            }
        }
    }
}

/// Feeds every byte of a transaction's operations, in order, through `clock` (MOSI in, MISO
/// out). Bytes a `Read` sends are 0x00; a `Transfer`'s shorter side is padded with 0x00 or
/// dropped.
fn for_each_byte<E>(
    operations: &mut [Operation<'_, u8>],
    mut clock: impl FnMut(u8) -> Result<u8, E>,
) -> Result<(), E> {
    for op in operations {
        match op {
            Operation::Read(buf) => {
                for b in buf.iter_mut() {
                    *b = clock(0x00)?;
                }
            }
            Operation::Write(buf) => {
                for &b in buf.iter() {
                    clock(b)?;
                }
            }
            Operation::Transfer(read, write) => {
                for i in 0..read.len().max(write.len()) {
                    let miso = clock(write.get(i).copied().unwrap_or(0x00))?;
                    if let Some(r) = read.get_mut(i) {
                        *r = miso;
                    }
                }
            }
            Operation::TransferInPlace(buf) => {
                for b in buf.iter_mut() {
                    *b = clock(*b)?;
                }
            }
            Operation::DelayNs(_) => {}
        }
    }
    Ok(())
}

/// The next source sample, or the bus error that ends or fails the simulation.
fn next_sample<S: Imu>(source: &mut S) -> Result<ImuSample, SimError<S::Error>> {
    match source.read_sample() {
        Ok(Some(sample)) => Ok(sample),
        Ok(None) => Err(SimError::End),
        Err(e) => Err(SimError::Source(e)),
    }
}

/// The device's cadence over a source whose time may stand still or step back. A finite sample
/// that ends no output period (the time since the last sample shown not positive: a recording's
/// time tag repeated or stepped back) shows as a repeated sample (`STALE`), and its increments
/// are carried to the next sample that ends one: that sample spans the time since the last one
/// shown, with the carried increments added. Dropped, a record with a time tag 5 ms back lost
/// its increment while the next one's interval covered it: the vertical velocity lost `g` times
/// 5 ms (0.049 m/s), and a still base's alignment was refused as "base not still".
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Cadence {
    /// Time of the last sample shown (that ended an output period) [us].
    shown_t_us: Option<u64>,
    /// Samples are carried: the next one shown spans the time since `shown_t_us`.
    carrying: bool,
    /// Increments of the carried samples [rad], [m/s].
    carried: ([f32; 3], [f32; 3]),
}

impl Cadence {
    /// The output periods of `period_s` [s] that `sample` ends (0: none, the device repeats its
    /// last sample and `sample` is carried), and the sample the device shows. A non-finite
    /// sample is the device's own case (it shows no number): neither carried nor merged.
    pub(crate) fn take(&mut self, sample: ImuSample, period_s: f32) -> (u16, ImuSample) {
        if !is_finite(&sample) || !sample.dt_s.is_finite() {
            let periods = periods(&sample, period_s);
            if periods > 0 {
                self.shown_t_us = Some(sample.t_us);
            }
            return (periods, sample);
        }
        // The time since the last sample shown: the sample's own interval unless samples are
        // carried (their time tags are the ones that did not advance).
        let elapsed_s = match (self.carrying, self.shown_t_us) {
            (true, Some(t0)) => (sample.t_us as i64).wrapping_sub(t0 as i64) as f32 * 1e-6,
            _ => sample.dt_s,
        };
        let own = match sample.motion {
            Motion::Increments {
                delta_theta_ib_b,
                delta_v_ib_b,
            } => Some((delta_theta_ib_b, delta_v_ib_b)),
            // Rates hold whatever the interval: nothing to carry.
            Motion::Rates { .. } => None,
        };
        // Finite: `dt_s` is checked above, and the time tags are integers.
        if elapsed_s <= 0.0 {
            self.carrying = true;
            if let Some((dtheta, dv)) = own {
                let (g, a) = &mut self.carried;
                add3(g, &dtheta);
                add3(a, &dv);
            }
            return (0, sample);
        }
        let mut shown = ImuSample {
            dt_s: elapsed_s,
            ..sample
        };
        if let Some((mut dtheta, mut dv)) = own {
            add3(&mut dtheta, &self.carried.0);
            add3(&mut dv, &self.carried.1);
            shown.motion = Motion::Increments {
                delta_theta_ib_b: dtheta,
                delta_v_ib_b: dv,
            };
        }
        *self = Self {
            shown_t_us: Some(sample.t_us),
            ..Self::default()
        };
        (periods(&shown, period_s), shown)
    }
}

/// `a += b`, element-wise.
fn add3(a: &mut [f32; 3], b: &[f32; 3]) {
    for (x, y) in a.iter_mut().zip(b) {
        *x += y;
    }
}

/// Output periods `T` [s] that the sample's interval spans, rounded; 0 for `dt_s <= 0` or NaN.
fn periods(sample: &ImuSample, period_s: f32) -> u16 {
    if sample.dt_s > 0.0 {
        round(sample.dt_s / period_s).clamp(1, i32::from(u16::MAX)) as u16
    } else {
        0
    }
}

/// `true` if every inertial value of the sample is finite.
fn is_finite(sample: &ImuSample) -> bool {
    let (a, b) = match sample.motion {
        Motion::Increments {
            delta_theta_ib_b,
            delta_v_ib_b,
        } => (delta_theta_ib_b, delta_v_ib_b),
        Motion::Rates { omega_ib_b, f_ib_b } => (omega_ib_b, f_ib_b),
    };
    a.iter().chain(b.iter()).all(|v| v.is_finite())
}

/// The sample as rates [rad/s], [m/s^2] (increments divided by `dt_s`; zero for `dt_s <= 0`).
fn rates(sample: &ImuSample) -> ([f32; 3], [f32; 3]) {
    match sample.motion {
        Motion::Rates { omega_ib_b, f_ib_b } => (omega_ib_b, f_ib_b),
        Motion::Increments {
            delta_theta_ib_b,
            delta_v_ib_b,
        } => {
            if sample.dt_s > 0.0 {
                let dt = sample.dt_s;
                (
                    delta_theta_ib_b.map(|d| d / dt),
                    delta_v_ib_b.map(|d| d / dt),
                )
            } else {
                ([0.0; 3], [0.0; 3])
            }
        }
    }
}

/// The sample's increments [rad], [m/s] per output period, over `periods` periods.
fn increments_per_period(sample: &ImuSample, periods: u16) -> ([f32; 3], [f32; 3]) {
    let (dtheta, dv) = sample.increments();
    if periods > 1 {
        let k = f32::from(periods);
        (dtheta.map(|d| d / k), dv.map(|d| d / k))
    } else {
        (dtheta, dv)
    }
}

/// Nearest integer, halves away from zero; saturates; NaN gives 0.
#[inline]
fn round(x: f32) -> i32 {
    if x >= 0.0 {
        (x + 0.5) as i32
    } else {
        (x - 0.5) as i32
    }
}

/// [`to_counts`] for integrated outputs (delta angle, delta velocity): the rounding remainder
/// is carried to the next sample, as an integrating sensor's accumulator does, so the sum of the
/// output counts follows the sum of the inputs to within one count instead of drifting by up to
/// half a count per sample (a constant input, e.g. the Earth rate at rest, would otherwise
/// become a bias of up to 0.5 LSB per sample).
fn to_counts_carry(
    mounting: &Mounting,
    v_b: [f32; 3],
    counts_per_unit: f32,
    limit: i32,
    carry: &mut [f32; 3],
) -> [i32; 3] {
    let v_s = mounting.to_sensor(v_b);
    let mut out = [0; 3];
    for ((o, v), c) in out.iter_mut().zip(v_s).zip(carry.iter_mut()) {
        let x = v * counts_per_unit + *c;
        let rounded = round(x);
        *o = rounded.clamp(-limit, limit);
        // |x - o| <= 0.5 unless clamped; a clamped (saturated) output carries nothing: what
        // was beyond the range is lost, as a part's is.
        *c = if *o == rounded {
            (x - *o as f32).clamp(-1.0, 1.0)
        } else {
            0.0
        };
    }
    out
}

/// Body-axis vector to sensor-axis counts: `round(counts_per_unit * c_s_b^T v)`, clamped to
/// `[-limit, limit]`.
fn to_counts(mounting: &Mounting, v_b: [f32; 3], counts_per_unit: f32, limit: i32) -> [i32; 3] {
    mounting
        .to_sensor(v_b)
        .map(|v| round(v * counts_per_unit).clamp(-limit, limit))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::check_source_rate;
    use std::string::ToString;

    /// A 4 kHz recording read through a device was told its samples would arrive as gaps of
    /// several output periods, the effect of a slower one (audit L3).
    #[test]
    fn a_recording_off_the_devices_rate_is_told_what_it_would_do() {
        let m = check_source_rate(4000.0).unwrap_err().to_string();
        assert!(
            m.contains("played 10 times slower") && !m.contains("gap"),
            "{m}"
        );
        let m = check_source_rate(100.0).unwrap_err().to_string();
        assert!(m.contains("a gap of several output periods"), "{m}");
        assert!(check_source_rate(401.0).is_ok());
    }
}
