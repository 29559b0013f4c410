//! A recording file replayed end to end: open (any format), run the [`pipeline`] in the chosen
//! precision, attach the replay's counters, and name the file in every error.

use crate::pipeline::{self, PipelineConfig, Report, SourceCounters};
use crate::recording_io::{Format, ReplaySource, in_file};
use anyhow::{Result, anyhow};
use nav_core::{ImuCalibration, Scalar};
use std::io::Write;
use std::path::Path;

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
    let rate_hz = source.header().rate_hz;
    let result = pipeline::run::<T, _, _>(&options.with_rate(rate_hz), &mut source, out);
    let mut report = match result {
        Ok(report) => report,
        Err(pipeline::PipelineError::Output(e)) => {
            return Err(anyhow!(e).context("writing the log"));
        }
        Err(e) => return Err(in_file(path, e)),
    };
    let stats = source.stats();
    report.source = Some(SourceCounters {
        missed: stats.missed,
        non_finite: stats.non_finite,
        bad_interval: stats.bad_interval,
    });
    Ok(FileReport {
        format,
        rate_hz,
        report,
    })
}
