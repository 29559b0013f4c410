//! A recording file replayed end to end: open (any format), run the [`pipeline`] in the chosen
//! precision, attach the replay's counters (and the driver's, through a simulated IMU), and name
//! the file in every error. A PSINS file's header site must be within
//! [`PSINS_SITE_TOLERANCE_M`] of the run's `--lat/--lon`.
//!
//! With a GNSS file ([`replay_aided`], `nav replay --gnss FILE` without a given start) the run
//! aligns as a plain replay does, then navigates aided ([`RunConfig::aiding`]): the firmware's
//! `--gnss` run, whose log it reproduces line for line.

use crate::gnss_file::{self, GnssFixes};
use crate::pipeline::{self, Report, RunConfig, SourceCounters, sensor_noise};
use crate::psins::PsinsHeader;
use crate::recording_io::{Format, ReplaySource, in_file};
use anyhow::{Result, anyhow};
use hal_adapters::Imu;
use hal_adapters::drivers::adis16505::{self, Model};
use hal_adapters::drivers::{Health, Mounting};
use hal_adapters::drivers::{NoiseSpec, bmi088, icm42688, noise};
use hal_adapters::sample::{ClipMarked, FullScale};
use hal_adapters::sim::{SimBmi088, SimulatedImu};
use nav_core::Scalar;
use nav_core::ins_filter::sequencer::GnssFixInput;
use nav_core::navigator::Unusable;
use std::fmt;
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
    /// The board's ADIS16505 (ADIS16505-2), 32-bit delta bursts.
    Adis16505,
    /// A TDK ICM-42688-P, 2 kHz FIFO integrated to 400 Hz.
    Icm42688,
    /// A Bosch BMI088, 400 Hz data registers (rates), two chip selects.
    Bmi088,
}

/// What to replay: the run configuration (nav-core's, shared with the firmware) and the sample
/// path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReplayOptions {
    /// The run configuration.
    pub run: RunConfig,
    /// The sample path (default: the recording as it is).
    pub device: ImuDevice,
    /// Where the recording's axes clip (`--imu-range`; `None`: no sample is taken as clipped;
    /// a simulated device's driver knows its own).
    pub full_scale: Option<FullScale>,
}

impl ReplayOptions {
    /// A replay of the recording's own samples with a `align_seconds` [s] static alignment at
    /// (`lat_deg`, `lon_deg` [deg], `h_m` [m]), assuming the board's ADIS16505 noise (as the
    /// firmware does), and the run configuration's defaults for the rest.
    pub fn new(lat_deg: f64, lon_deg: f64, h_m: f64, align_seconds: f64) -> Self {
        let device = ImuDevice::Recording;
        Self {
            run: RunConfig::new(
                lat_deg,
                lon_deg,
                h_m,
                align_seconds,
                sensor_noise(&device.noise()),
            ),
            device,
            full_scale: None,
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
    /// The pipeline's report (with the replay's counters, and the driver's with `--device`).
    pub report: Report,
}

/// A failed replay: why, and the driver's counters at the failure when the samples came through
/// a simulated IMU's driver (the firmware logs them before its error too).
#[derive(Debug)]
pub struct ReplayFailure {
    /// Why (naming the file).
    pub error: anyhow::Error,
    /// The driver's counters at the failure ([`ImuDevice`] other than the recording).
    pub driver: Option<Health>,
}

impl fmt::Display for ReplayFailure {
    /// The error's message; with `{:#}`, its whole chain.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if f.alternate() {
            write!(f, "{:#}", self.error)
        } else {
            write!(f, "{}", self.error)
        }
    }
}

impl std::error::Error for ReplayFailure {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.error.source()
    }
}

impl From<anyhow::Error> for ReplayFailure {
    fn from(error: anyhow::Error) -> Self {
        Self {
            error,
            driver: None,
        }
    }
}

impl From<std::io::Error> for ReplayFailure {
    fn from(e: std::io::Error) -> Self {
        anyhow::Error::from(e).into()
    }
}

/// Replays `path` in precision `T`, writing the solution log to `out`.
pub fn replay_file<T: Scalar, W: Write>(
    path: &Path,
    options: &ReplayOptions,
    out: W,
) -> Result<FileReport, ReplayFailure> {
    replay_file_with_fixes::<T, W>(path, options, &[], out)
}

/// [`replay_file`] with GNSS fixes ([`pipeline::run_with_fixes`]).
pub fn replay_file_with_fixes<T: Scalar, W: Write>(
    path: &Path,
    options: &ReplayOptions,
    fixes: &[GnssFixInput<f64>],
    out: W,
) -> Result<FileReport, ReplayFailure> {
    let (mut source, format) = ReplaySource::open(path)?;
    if let Some(h) = source.psins_header() {
        check_psins_site(path, h, &options.run)?;
    }
    let rate_hz = source.header().rate_hz;
    if options.device != ImuDevice::Recording {
        hal_adapters::sim::check_source_rate(rate_hz).map_err(|e| {
            let device = clap::ValueEnum::to_possible_value(&options.device)
                .map_or_else(String::new, |v| v.get_name().to_owned());
            anyhow!("recording {}: --device {device}: {e}", path.display())
        })?;
    }
    let config = (&options.run, rate_hz, fixes);
    let (run, driver, stats) = match options.device {
        ImuDevice::Recording => {
            let mut marked = ClipMarked {
                source: &mut source,
                full_scale: options.full_scale,
            };
            let run = run_source::<T, _, _>(path, config, &mut marked, out);
            (run, None, source.stats())
        }
        ImuDevice::Adis16505 => {
            let driver_config = adis16505::Config::new(Model::BOARD);
            let mut imu = SimulatedImu::adis16505(source, driver_config)
                .map_err(|e| anyhow!("simulated ADIS16505: {e}"))?;
            let run = run_source::<T, _, _>(path, config, &mut imu, out);
            (run, Some(imu.health()), imu.driver().bus().source().stats())
        }
        ImuDevice::Icm42688 => {
            let driver_config = icm42688::Config {
                mounting: Mounting::IDENTITY,
            };
            let mut imu = SimulatedImu::icm42688(source, driver_config)
                .map_err(|e| anyhow!("simulated ICM-42688-P: {e}"))?;
            let run = run_source::<T, _, _>(path, config, &mut imu, out);
            (run, Some(imu.health()), imu.driver().bus().source().stats())
        }
        ImuDevice::Bmi088 => {
            let device = SimBmi088::new(source);
            let mut imu = SimulatedImu::bmi088(&device, bmi088::Config::default())
                .map_err(|e| anyhow!("simulated BMI088: {e}"))?;
            let run = run_source::<T, _, _>(path, config, &mut imu, out);
            (run, Some(imu.health()), device.into_source().stats())
        }
    };
    let mut report = run.map_err(|error| ReplayFailure { error, driver })?;
    report.source = Some(SourceCounters {
        missed: stats.missed,
        non_finite: stats.non_finite,
        bad_interval: stats.bad_interval - stats.not_after_previous,
        out_of_order: stats.not_after_previous,
    });
    report.driver = driver;
    check_refused_share(
        report.after_alignment.into(),
        report.rejected_after_alignment.into(),
        "after the alignment",
    )
    .map_err(|e| ReplayFailure {
        error: in_file(path, e),
        driver,
    })?;
    Ok(FileReport {
        format,
        rate_hz,
        report,
    })
}

/// Largest share of a run's navigation samples nav-core's input limits may refuse [-]: beyond
/// it the recording's values are no IMU's (a wrong unit or scale, mg for m/s^2), and rows
/// integrated over the few left and bridged across the rest are no solution (a run with 88 %
/// refused ended `ok` with 481 m/s at rest). A few refused samples are bridged and counted.
pub const MAX_REFUSED_SHARE: f64 = 0.5;

/// Refuses a run whose input limits refused more than [`MAX_REFUSED_SHARE`] of its `samples`
/// navigation samples (`rejected` of them; `which` names them in the message, e.g. "after the
/// alignment"). The same for every replay, aided or not, and `nav kf-gins`.
pub fn check_refused_share(samples: u64, rejected: u64, which: &str) -> Result<()> {
    let (samples_f, rejected_f) = (samples as f64, rejected as f64);
    if rejected_f <= MAX_REFUSED_SHARE * samples_f {
        return Ok(());
    }
    let limits = nav_core::InputLimits::<f64>::default();
    Err(anyhow!(
        "the increment limits refused {rejected} of the {samples} samples {which} ({:.0} %, more \
         than {:.0} %): an interval beyond {} s, a rate beyond {:.0} deg/s or a specific force \
         beyond {:.0} m/s^2 is no IMU's (values in another unit or scale?), and the solution \
         bridged across them is none",
        100.0 * rejected_f / samples_f,
        100.0 * MAX_REFUSED_SHARE,
        limits.max_dt,
        limits.max_rate.to_degrees(),
        limits.max_specific_force
    ))
}

/// Farthest a PSINS header's site may be from the run's `--lat/--lon` [m].
pub const PSINS_SITE_TOLERANCE_M: f64 = 1000.0;

/// Largest difference between a PSINS header's height and the run's `--h` [m]: beyond the
/// geoid's separation from the ellipsoid anywhere (about -106 to +85 m), so a header in
/// either kind of height passes and a typing error (1380 m for 380 m, accepted before with
/// the heading's 1-sigma grown from 0.08 to 11 deg) does not.
pub const PSINS_HEIGHT_TOLERANCE_M: f64 = 200.0;

/// Refuses a PSINS recording whose header site (latitude, longitude) is more than
/// [`PSINS_SITE_TOLERANCE_M`] from the run's, or whose height is more than
/// [`PSINS_HEIGHT_TOLERANCE_M`] from it: one of the two is wrong, and the alignment would use
/// the run's without a word.
fn check_psins_site(path: &Path, h: &PsinsHeader, run: &RunConfig) -> Result<()> {
    let dh_m = (h.h_m - run.h_m).abs();
    if dh_m > PSINS_HEIGHT_TOLERANCE_M {
        return Err(anyhow!(
            "recording {}: the PSINS header's height {} m is {:.0} m from --h {} (more than \
             {PSINS_HEIGHT_TOLERANCE_M} m, beyond the geoid's separation from the ellipsoid): \
             pass the header's height or correct the header",
            path.display(),
            h.h_m,
            dh_m,
            run.h_m
        ));
    }
    let distance_m = horizontal_distance_m(
        (h.lat_deg.to_radians(), h.lon_deg.to_radians()),
        (run.lat_deg.to_radians(), run.lon_deg.to_radians()),
    );
    if distance_m > PSINS_SITE_TOLERANCE_M {
        return Err(anyhow!(
            "recording {}: the PSINS header's site ({} deg, {} deg) is {:.0} m from --lat {} \
             --lon {} (more than {PSINS_SITE_TOLERANCE_M} m): pass the header's position or \
             correct the header",
            path.display(),
            h.lat_deg,
            h.lon_deg,
            distance_m,
            run.lat_deg,
            run.lon_deg
        ));
    }
    Ok(())
}

/// Great-circle distance [m] between two (latitude, longitude) [rad] points (haversine), on the
/// sphere of the Gaussian radius `sqrt(R_N R_E)` at their mean latitude (radii of curvature
/// [Groves, eqs. 2.105-2.106]): within 0.5 % of the ellipsoidal distance, enough for a
/// plausibility bound.
fn horizontal_distance_m((lat_a, lon_a): (f64, f64), (lat_b, lon_b): (f64, f64)) -> f64 {
    let (r_n, r_e) = nav_core::earth::radii(0.5 * (lat_a + lat_b));
    let hav = |x: f64| (0.5 * x).sin().powi(2);
    let a = hav(lat_b - lat_a) + lat_a.cos() * lat_b.cos() * hav(lon_b - lon_a);
    2.0 * (r_n * r_e).sqrt() * a.sqrt().min(1.0).asin()
}

/// Runs the pipeline over `source`, naming `path` in its errors.
fn run_source<T: Scalar, I: Imu, W: Write>(
    path: &Path,
    (config, rate_hz, fixes): (&RunConfig, f64, &[GnssFixInput<f64>]),
    source: &mut I,
    out: W,
) -> Result<Report>
where
    I::Error: std::error::Error + Send + Sync + 'static,
{
    match pipeline::run_with_fixes::<T, _, _>(config, rate_hz, source, fixes, out) {
        Ok(report) => Ok(report),
        Err(pipeline::PipelineError::Output(e)) => Err(anyhow!(e).context("writing the log")),
        Err(e) => Err(in_file(path, e)),
    }
}

/// What an aided replay did: the file's report and the GNSS file's.
#[derive(Clone, Debug, PartialEq)]
pub struct AidedFileReport {
    /// The replay.
    pub file: FileReport,
    /// Fixes read from the GNSS file.
    pub fixes_read: usize,
    /// Fixes of a text file whose time tag is not on the IMU clock (left out).
    pub bad_time_tags: u32,
}

/// `nav replay --gnss GNSS` from the navigator's alignment: `imu` replayed in precision `T`
/// with `options` (their [`RunConfig::aiding`] set), the fixes of `gnss` (any format,
/// [`gnss_file::read_fixes`], `gnss_sigma` the 1-sigma of a gnss-ins-sim GPS file, taken at
/// their tags less the receiver's latency `latency_s` [s],
/// [`gnss_file::at_measurement_epochs`]) handed over at their samples, the log written to
/// `out` atomically (nothing is left there on failure).
pub fn replay_aided<T: Scalar>(
    imu: &Path,
    gnss: &Path,
    gnss_sigma: Option<&crate::gnss::AssumedSigma>,
    latency_s: f64,
    out: &Path,
    options: &ReplayOptions,
) -> Result<AidedFileReport, ReplayFailure> {
    if options.run.aiding.is_none() {
        return Err(anyhow!("an aided replay needs the run's aiding settings").into());
    }
    crate::atomic::refuse_same_file(&[imu, gnss], out)?;
    gnss_file::refuse_the_imu_recording(gnss, imu)?;
    let mut read = gnss_file::read_fixes(gnss, gnss_sigma)?;
    gnss_file::at_measurement_epochs(&mut read, latency_s)?;
    let GnssFixes {
        fixes,
        bad_time_tags,
    } = read;
    let file = crate::atomic::write(out, |w| {
        let file = replay_file_with_fixes::<T, _>(imu, options, &fixes, w)?;
        // Before the log is renamed into place.
        crate::aided::check_fixes_in_span(
            fixes.iter().map(|f| f.t_us as f64 * 1e-6),
            file.report.span_us,
        )
        .map_err(|e| file.report.lost.explain(e))?;
        if let Some(a) = &file.report.aided {
            crate::aided_cmd::check_some_fix_used(&a.counters)?;
        }
        Ok::<_, ReplayFailure>(file)
    })?;
    Ok(AidedFileReport {
        file,
        fixes_read: fixes.len(),
        bad_time_tags,
    })
}

/// The summary lines of a replay for a terminal (as `nav replay` prints them): the file, the
/// samples' counts, the driver's counts (with a simulated IMU), the alignment and its
/// hand-over 1-sigma, the final solution, the log, and an aided run's filter lines.
pub fn summary(imu: &Path, out: &Path, precision: &str, fr: &FileReport) -> String {
    use std::fmt::Write as _;
    let r = &fr.report;
    let mut s = String::new();
    let c = r.source.unwrap_or_default();
    let a = &r.alignment;
    let (v, p) = (a.velocity_sigma_m_s, a.position_sigma_m);
    let f = &r.final_solution;
    // Writing to a String cannot fail.
    let _ = writeln!(
        s,
        "replay of {} ({}, {} Hz, {precision})",
        imu.display(),
        fr.format,
        fr.rate_hz
    );
    // The navigator's causes, which add up to `flagged`. The reader flags a record whose
    // time is not after the previous one's as a bad interval, which the summary calls out of
    // order, as the navigator's own; a simulated part shows it as stale instead (counted so).
    let n = &r.flagged_by;
    let behind = if r.driver.is_some() {
        0
    } else {
        c.out_of_order
    };
    let device_causes: String = [
        (Unusable::Stale, n.stale),
        (Unusable::DeviceFault, n.device_fault),
        (Unusable::Other, n.other),
    ]
    .iter()
    .filter(|(_, k)| *k > 0)
    .map(|(cause, k)| format!(", {} {k}", cause.name()))
    .collect();
    let _ = writeln!(
        s,
        "samples {}: flagged {} (non-finite {}, bad interval {}, time out of order {}{device_causes}), rejected {}, missed {}; navigation steps {}",
        r.samples,
        r.flagged,
        n.non_finite,
        n.bad_interval.saturating_sub(behind),
        n.out_of_order + behind,
        r.rejected,
        c.missed,
        r.nav_steps
    );
    if let Some(h) = r.driver {
        let _ = writeln!(s, "IMU driver: {h}");
    }
    let _ = writeln!(
        s,
        "alignment ({}) over {} samples ({:.3} s: coarse {:.3} s, fine {:.3} s): roll {:.6} deg, pitch {:.6} deg, yaw {:.6} deg; 1-sigma {:.4} {:.4} {:.4} deg",
        a.method.name(),
        a.samples,
        a.duration_s,
        a.coarse_s,
        a.fine_s,
        a.roll_deg,
        a.pitch_deg,
        a.yaw_deg,
        a.sigma_deg[0],
        a.sigma_deg[1],
        a.sigma_deg[2]
    );
    if let Some(note) = a.note {
        let _ = writeln!(s, "  note: {note}");
    }
    let _ = writeln!(
        s,
        "  hand-over 1-sigma: velocity {:.2} {:.2} {:.2} m/s, position {:.2} {:.2} {:.2} m (N E D)",
        v[0], v[1], v[2], p[0], p[1], p[2]
    );
    if let Some(aided) = &r.aided {
        let _ = writeln!(s, "{aided}");
    }
    if let Some(line) = r.status.line() {
        let _ = writeln!(s, "{line}");
    }
    let _ = writeln!(
        s,
        "final at t = {:.6} s: lat {:.9} deg, lon {:.9} deg, h {:.3} m; v_NED {:.6} {:.6} {:.6} m/s; roll {:.6} pitch {:.6} yaw {:.6} deg",
        f.t_us as f64 / 1e6,
        f.lat_ndeg as f64 / 1e9,
        f.lon_ndeg as f64 / 1e9,
        f.h_m,
        f.v_eb_n[0],
        f.v_eb_n[1],
        f.v_eb_n[2],
        f.roll_deg,
        f.pitch_deg,
        f.yaw_deg
    );
    let _ = write!(s, "log: {} ({} rows)", out.display(), r.rows);
    s
}

/// `nav replay --gnss FILE` without a given start: [`replay_aided`] in `f32` or `f64`, its
/// summary printed ([`summary`] and the GNSS file's counts) with the speed; a failure's driver
/// counts printed too (as the firmware logs them).
pub fn replay_aided_cli(
    imu: &Path,
    gnss: &Path,
    gnss_sigma: Option<&crate::gnss::AssumedSigma>,
    latency_s: f64,
    out: &Path,
    options: &ReplayOptions,
    f64_precision: bool,
) -> Result<()> {
    let started = std::time::Instant::now();
    let run = if f64_precision {
        replay_aided::<f64>(imu, gnss, gnss_sigma, latency_s, out, options)
    } else {
        replay_aided::<f32>(imu, gnss, gnss_sigma, latency_s, out, options)
    };
    let r = run
        .map_err(|failure| {
            if let Some(h) = failure.driver {
                println!("IMU driver: {h}");
            }
            failure.error
        })
        .map_err(|e| {
            e.context(format!(
                "aided replay of {} into {}",
                imu.display(),
                out.display()
            ))
        })?;
    let seconds = started.elapsed().as_secs_f64();
    let precision = if f64_precision { "f64" } else { "f32" };
    println!("{}", summary(imu, out, precision, &r.file));
    if let Some(w) = r.file.report.lost.warning() {
        println!("{w}");
    }
    // The given start's warnings, for the aided phase after the alignment.
    if let Some(a) = &r.file.report.aided {
        let unused = format!(
            "{} before the aided phase, {} after the data",
            a.fixes_unused, a.fixes_after_data
        );
        let position = crate::aided_cmd::position_warning(&a.counters.position, &unused);
        let velocity = crate::aided_cmd::velocity_warning(&a.counters.velocity);
        let realigned = crate::aided_cmd::realignment_line(&a.realignments);
        let late = crate::aided_cmd::latency_warning(&a.gnss_latency, None);
        let noisy = crate::aided_cmd::noise_scale_warning(&a.noise_scales);
        let unordered = crate::aided_cmd::out_of_order_warning(a.fixes.out_of_order);
        for w in realigned
            .into_iter()
            .chain(position)
            .chain(velocity)
            .chain(late)
            .chain(noisy)
            .chain(unordered)
        {
            println!("{w}");
        }
    }
    println!(
        "GNSS file {}: {} fixes ({} with a time tag off the IMU clock, left out)",
        gnss.display(),
        r.fixes_read,
        r.bad_time_tags
    );
    println!(
        "speed: {:.0} samples/s ({seconds:.3} s wall clock, file reading and logging included)",
        f64::from(r.file.report.samples) / seconds.max(1e-9)
    );
    Ok(())
}
