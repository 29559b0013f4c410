//! The board's IMU: a real SPI driver from `hal-adapters` over its bus.
//!
//! On the `qemu` board the bus is a simulated device answering from a recording
//! (`hal_adapters::sim`), so the driver's whole path (init, burst or FIFO read, checksum,
//! counters, scaling, mounting) runs as it would on hardware. The host harness builds the same
//! pair (`nav replay --device ...`), so both navigate bit-identical samples.

use hal_adapters::drivers::adis16505::{self as adis, Adis16505, Model};
use hal_adapters::drivers::bmi088::{self as bmi, Bmi088};
use hal_adapters::drivers::icm42688::{self as icm, Icm42688};
use hal_adapters::drivers::{Error, Health, Mounting};
use hal_adapters::protocol::config::ImuModel;
use hal_adapters::sim::{
    NoDelay, SimAdis16505, SimBmi088, SimBmi088Accel, SimBmi088Gyro, SimError, SimIcm42688,
    SimulatedBus, flag_unrepresentable,
};
use hal_adapters::{Imu, ImuSample};

/// The simulated IMUs' mounting: their axes are the body's.
pub const MOUNTING: Mounting = Mounting::IDENTITY;

/// Which device sits on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Device {
    /// Analog Devices ADIS16505-2 (+-500 deg/s, 32-bit delta-angle/velocity burst): the
    /// board's tactical IMU, the default.
    Adis16505,
    /// TDK ICM-42688-P (2 kHz FIFO, five packets per 400 Hz increment).
    Icm42688,
    /// Bosch BMI088 (two chip selects, 400 Hz data registers, rates).
    Bmi088,
}

impl Device {
    /// Parses a device name as given on the command line.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "adis16505" => Some(Self::Adis16505),
            "icm42688" => Some(Self::Icm42688),
            "bmi088" => Some(Self::Bmi088),
            _ => None,
        }
    }

    /// The ADIS model the board carries.
    pub const ADIS_MODEL: Model = Model::BOARD;

    /// The protocol's name of the device (a configuration frame's IMU model).
    pub fn model(self) -> ImuModel {
        match self {
            Self::Adis16505 => ImuModel::Adis16505,
            Self::Icm42688 => ImuModel::Icm42688,
            Self::Bmi088 => ImuModel::Bmi088,
        }
    }

    /// The part's datasheet noise, which the alignment assumes.
    pub fn noise(self) -> hal_adapters::drivers::NoiseSpec {
        use hal_adapters::drivers::noise;
        match self {
            Self::Adis16505 => noise::ADIS16505,
            Self::Icm42688 => noise::ICM42688,
            Self::Bmi088 => noise::BMI088,
        }
    }
}

/// The IMU driver over a simulated device fed by `S`.
pub enum BoardImu<S: Imu + 'static> {
    /// ADIS16505 driver and device.
    Adis(Adis16505<SimAdis16505<S>>),
    /// ICM-42688-P driver and device.
    Icm(Icm42688<SimIcm42688<S>>),
    /// BMI088 driver over the two chip selects of one simulated device.
    Bmi(Bmi088<SimBmi088Gyro<'static, S>, SimBmi088Accel<'static, S>>),
}

/// A driver error on the simulated bus.
pub type ImuError<S> = Error<SimError<<S as Imu>::Error>>;

/// One data-ready's read: the sample (or the error) and the guest-instruction split.
pub struct Read<S: Imu + 'static> {
    /// The sample, with `t_us` the recording's time of the sample.
    pub result: Result<ImuSample, ImuError<S>>,
    /// SysTick counts of the bus transaction (on QEMU: the simulated device's answer).
    pub bus_counts: u64,
    /// SysTick counts of decoding and converting the frame.
    pub decode_counts: u64,
}

impl<S: Imu + 'static> BoardImu<S> {
    /// The driver for `device` over a simulated device answering from `source`, installed as
    /// `installed` (sensor to body), initialised; the driver applies [`MOUNTING`]. The
    /// BMI088's device is shared by its two chip selects and lives in `bmi_slot`.
    pub fn new(
        device: Device,
        installed: Mounting,
        source: S,
        bmi_slot: &'static mut Option<SimBmi088<S>>,
    ) -> Result<Self, ImuError<S>> {
        let mounting = MOUNTING;
        Ok(match device {
            Device::Adis16505 => {
                let config = adis::Config::new(Device::ADIS_MODEL).with_mounting(mounting);
                let bus = SimAdis16505::new(source, config.model).with_mounting(installed);
                let mut driver = Adis16505::new(bus, config);
                driver.init(&mut NoDelay)?;
                Self::Adis(driver)
            }
            Device::Icm42688 => {
                let bus = SimIcm42688::new(source).with_mounting(installed);
                let mut driver = Icm42688::new(bus, icm::Config { mounting });
                driver.init(&mut NoDelay)?;
                Self::Icm(driver)
            }
            Device::Bmi088 => {
                let sim: &'static SimBmi088<S> =
                    bmi_slot.insert(SimBmi088::new(source).with_mounting(installed));
                let config = bmi::Config {
                    mounting,
                    ..bmi::Config::default()
                };
                let mut driver = Bmi088::new(sim.gyro(), sim.accel(), config);
                driver.init(&mut NoDelay)?;
                Self::Bmi(driver)
            }
        })
    }

    /// Reads one sample at data-ready time `t_ready_us` [us], timing the bus and decode halves
    /// with `counts` (a free-running cycle counter). The sample's `t_us` is the recording's time
    /// of the sample (the simulated device's source), so logs match the host harness.
    pub fn read(&mut self, t_ready_us: u64, counts: impl Fn() -> u64) -> Read<S> {
        let c0 = counts();
        let (c1, result) = match self {
            Self::Adis(d) => {
                let bus = d.read_burst();
                let c1 = counts();
                (c1, bus.and_then(|()| d.decode_burst(t_ready_us)))
            }
            Self::Icm(d) => {
                let bus = d.read_fifo();
                let c1 = counts();
                let decoded = bus.and_then(|()| d.decode_fifo(t_ready_us));
                if let Err(Error::FifoOverflow | Error::BadFrame) = decoded {
                    // Resynchronise on the next packet boundary (counted in the health).
                    let _ = d.flush_fifo();
                }
                (c1, decoded)
            }
            Self::Bmi(d) => {
                let bus = d.read_frames();
                let c1 = counts();
                (c1, bus.and_then(|()| d.decode_frames(t_ready_us)))
            }
        };
        let c2 = counts();
        // A non-finite source sample is delivered flagged, as the host's `SimulatedImu` does.
        let source = self.last_source_sample();
        let result = flag_unrepresentable(result, source).map(|mut s| {
            if let Some(source) = source {
                s.t_us = source.t_us;
            }
            s
        });
        Read {
            result,
            bus_counts: c1 - c0,
            decode_counts: c2 - c1,
        }
    }

    /// The driver's counters.
    pub fn health(&self) -> Health {
        match self {
            Self::Adis(d) => d.health(),
            Self::Icm(d) => d.health(),
            Self::Bmi(d) => d.health(),
        }
    }

    fn last_source_sample(&self) -> Option<&ImuSample> {
        match self {
            Self::Adis(d) => d.bus().last_source_sample(),
            Self::Icm(d) => d.bus().last_source_sample(),
            Self::Bmi(d) => SimulatedBus::last_source_sample(d.bus()),
        }
    }
}
