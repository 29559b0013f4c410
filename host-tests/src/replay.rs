//! A recording file replayed end to end: open (any format), run the [`pipeline`] in the chosen
//! precision, attach the replay's counters, and name the file in every error.

use crate::pipeline::{self, MechanizationChoices, PipelineConfig, Report, SourceCounters};
use crate::recording_io::{Format, ReplaySource, in_file};
use anyhow::{Result, anyhow};
use hal_adapters::Imu;
use hal_adapters::drivers::Mounting;
use hal_adapters::drivers::adis16505::{self, Model};
use hal_adapters::drivers::{NoiseSpec, bmi088, icm42688, noise};
use hal_adapters::sim::{SimBmi088, SimulatedImu};
use nav_core::alignment::AlignMethod;
use nav_core::{ImuCalibration, Scalar};
use std::io::Write;
use std::path::Path;

impl ImuDevice {
    /// The part's datasheet noise (the board's ADIS16505 for a plain recording).
    pub fn noise(self) -> NoiseSpec {
        match self {
            Self::Recording | Self::Adis16505 => noise::ADIS16505,
            Self::Icm42688 => noise::ICM42688,
            Self::Bmi088 => noise::BMI088,
        }
    }
}

/// What produces the samples: the recording itself, or a simulated IMU answering from it on an
/// SPI bus, read by the real driver (the firmware's path on the `qemu` board).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum ImuDevice {
    /// The recording's samples as they are.
    #[default]
    Recording,
    /// The board's ADIS16505 ([`Model::BOARD`]), 32-bit delta bursts.
    Adis16505,
    /// A TDK ICM-42688-P, 2 kHz FIFO integrated to 400 Hz.
    Icm42688,
    /// A Bosch BMI088, 400 Hz data registers (rates), two chip selects.
    Bmi088,
}

/// The pipeline settings that do not come from the recording.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReplayOptions {
    /// Latitude of the site [deg].
    pub lat_deg: f64,
    /// Longitude of the site [deg].
    pub lon_deg: f64,
    /// Ellipsoidal height of the site [m].
    pub h_m: f64,
    /// Length of the still period averaged by the alignment [s].
    pub align_seconds: f64,
    /// Navigation steps between logged solutions (>= 1).
    pub log_every: u32,
    /// Sensor calibration (default identity).
    pub calibration: ImuCalibration,
    /// Frame, attitude integrator and vertical channel.
    pub choices: MechanizationChoices,
    /// The sample path (default: the recording as it is).
    pub device: ImuDevice,
    /// Alignment method.
    pub align_method: AlignMethod,
    /// The IMU noise the alignment assumes (`None`: the device's datasheet figures, the board's
    /// ADIS16505 for a plain recording, as the firmware assumes).
    pub noise: Option<NoiseSpec>,
    /// The IMU's lever arm from the base's centre of rotation, body FRD [m], if known.
    pub lever_arm_m: Option<[f64; 3]>,
}

impl ReplayOptions {
    /// The pipeline configuration for a recording sampled at `rate_hz` [Hz].
    pub fn with_rate(&self, rate_hz: f64) -> PipelineConfig {
        PipelineConfig {
            lat_deg: self.lat_deg,
            lon_deg: self.lon_deg,
            h_m: self.h_m,
            align_seconds: self.align_seconds,
            log_every: self.log_every,
            rate_hz,
            calibration: self.calibration,
            choices: self.choices,
            align_method: self.align_method,
            noise: self.noise.unwrap_or(self.device.noise()),
            lever_arm_m: self.lever_arm_m,
        }
    }
}

/// What a replay of a file did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FileReport {
    /// The file's format.
    pub format: Format,
    /// The recording's nominal rate [Hz].
    pub rate_hz: f64,
    /// The pipeline's report (with the replay's counters).
    pub report: Report,
}

/// Replays `path` in precision `T`, writing the solution log to `out`.
pub fn replay_file<T: Scalar, W: Write>(
    path: &Path,
    options: &ReplayOptions,
    out: W,
) -> Result<FileReport> {
    let (mut source, format) = ReplaySource::open(path)?;
    let config = options.with_rate(source.header().rate_hz);
    let stats = match options.device {
        ImuDevice::Recording => {
            let report = run_source::<T, _, _>(path, &config, &mut source, out)?;
            (report, source.stats())
        }
        ImuDevice::Adis16505 => {
            let driver_config = adis16505::Config::new(Model::BOARD);
            let mut imu = SimulatedImu::adis16505(source, driver_config)
                .map_err(|e| anyhow!("simulated ADIS16505: {e}"))?;
            let report = run_source::<T, _, _>(path, &config, &mut imu, out)?;
            (report, imu.driver().bus().source().stats())
        }
        ImuDevice::Icm42688 => {
            let driver_config = icm42688::Config {
                mounting: Mounting::IDENTITY,
            };
            let mut imu = SimulatedImu::icm42688(source, driver_config)
                .map_err(|e| anyhow!("simulated ICM-42688-P: {e}"))?;
            let report = run_source::<T, _, _>(path, &config, &mut imu, out)?;
            (report, imu.driver().bus().source().stats())
        }
        ImuDevice::Bmi088 => {
            let device = SimBmi088::new(source);
            let mut imu = SimulatedImu::bmi088(&device, bmi088::Config::default())
                .map_err(|e| anyhow!("simulated BMI088: {e}"))?;
            let report = run_source::<T, _, _>(path, &config, &mut imu, out)?;
            (report, device.into_source().stats())
        }
    };
    let (mut report, stats) = stats;
    report.source = Some(SourceCounters {
        missed: stats.missed,
        non_finite: stats.non_finite,
        bad_interval: stats.bad_interval,
    });
    Ok(FileReport {
        format,
        rate_hz: config.rate_hz,
        report,
    })
}

/// Runs the pipeline over `source`, naming `path` in its errors.
fn run_source<T: Scalar, I: Imu, W: Write>(
    path: &Path,
    config: &PipelineConfig,
    source: &mut I,
    out: W,
) -> Result<Report>
where
    I::Error: std::error::Error + Send + Sync + 'static,
{
    match pipeline::run::<T, _, _>(config, source, out) {
        Ok(report) => Ok(report),
        Err(pipeline::PipelineError::Output(e)) => Err(anyhow!(e).context("writing the log")),
        Err(e) => Err(in_file(path, e)),
    }
}
