//! `nav`: generate, convert and replay IMU recordings on the desktop.
//!
//! ```text
//! nav generate --out FILE [--seconds 60] [--rate 400] [--lat 45] [--lon 7.5] [--h 150]
//!              [--roll 1.5] [--pitch -2] [--yaw 30]
//! nav convert  --in FILE --out FILE
//! nav bench    [--passes 10]
//! nav replay   --imu FILE --lat DEG --lon DEG --h M --align-seconds S --out FILE
//!              [--log-every 40] [--precision f32|f64] [--calibration FILE]
//!              [--device recording|adis16505|icm42688|bmi088] [--frame wander|ned]
//!              [--attitude rotation-vector|euler|heun|rk4|abm4] [--vertical free|hold]
//! ```
//! Output recordings are binary unless the file name ends in `.csv`. Errors name the file and the
//! line or byte offset, and exit with status 1.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use host_tests::generate::Stationary;
use host_tests::pipeline::DEFAULT_LOG_EVERY;
use host_tests::pipeline::MechanizationChoices;
use host_tests::recording_io;
use host_tests::replay::{FileReport, ImuDevice, ReplayOptions, replay_file};
use nav_core::{AttitudeMethod, DcmIntegrator, ImuCalibration, NavFrame, VerticalChannel};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "nav",
    version,
    about = "Generate, convert and replay IMU recordings"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Benchmark the mechanization alone (no I/O): steps per second on one thread, f32 and f64,
    /// over 10 min of exact 400 Hz increments of a 900 km/h flight.
    Bench {
        /// Passes over the 240,000 increments.
        #[arg(long, default_value_t = 10)]
        passes: u32,
    },
    /// Write a synthetic recording of a body at rest on the Earth (exact inputs).
    #[command(allow_negative_numbers = true)]
    Generate {
        /// Output file (binary, or CSV when it ends in .csv).
        #[arg(long)]
        out: PathBuf,
        /// Length [s].
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
        /// Sampling rate [Hz].
        #[arg(long, default_value_t = 400.0)]
        rate: f64,
        /// Latitude [deg].
        #[arg(long, default_value_t = 45.0)]
        lat: f64,
        /// Longitude [deg].
        #[arg(long, default_value_t = 7.5)]
        lon: f64,
        /// Ellipsoidal height [m].
        #[arg(long, default_value_t = 150.0)]
        h: f64,
        /// Roll [deg].
        #[arg(long, default_value_t = 1.5)]
        roll: f64,
        /// Pitch [deg].
        #[arg(long, default_value_t = -2.0)]
        pitch: f64,
        /// Yaw (true heading) [deg].
        #[arg(long, default_value_t = 30.0)]
        yaw: f64,
    },
    /// Convert a recording (CSV, PSINS or binary; auto-detected) to binary, or to CSV when the
    /// output ends in .csv.
    Convert {
        /// Input recording.
        #[arg(long = "in", value_name = "FILE")]
        input: PathBuf,
        /// Output file.
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
    },
    /// Align and navigate over a recording (any format), writing the solution log as CSV.
    #[command(allow_negative_numbers = true)]
    Replay {
        /// Input recording (binary, CSV or PSINS; auto-detected).
        #[arg(long, value_name = "FILE")]
        imu: PathBuf,
        /// Latitude of the site [deg].
        #[arg(long)]
        lat: f64,
        /// Longitude of the site [deg].
        #[arg(long)]
        lon: f64,
        /// Ellipsoidal height of the site [m].
        #[arg(long)]
        h: f64,
        /// Length of the still period at the start used for the alignment [s].
        #[arg(long)]
        align_seconds: f64,
        /// Solution log (CSV).
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// Navigation steps between logged solutions.
        #[arg(long, default_value_t = DEFAULT_LOG_EVERY, value_parser = clap::value_parser!(u32).range(1..))]
        log_every: u32,
        /// Arithmetic precision of the navigation (the firmware uses f32).
        #[arg(long, value_enum, default_value_t = Precision::F32)]
        precision: Precision,
        /// Sensor calibration file (nav-core's text form: biases, scale factors,
        /// misalignments); identity without it.
        #[arg(long, value_name = "FILE")]
        calibration: Option<PathBuf>,
        /// The sample path: the recording as it is, or a simulated IMU on an SPI bus read by its
        /// real driver (the firmware's path on the `qemu` board is `adis16505`).
        #[arg(long, value_enum, default_value_t = ImuDevice::Recording)]
        device: ImuDevice,
        /// Navigation frame of the mechanization (outputs are NED either way).
        #[arg(long, value_enum, default_value_t = Frame::Wander)]
        frame: Frame,
        /// Attitude integration: rotation-vector quaternion, or Poisson's DCM equation with an
        /// integrator.
        #[arg(long, value_enum, default_value_t = Attitude::RotationVector)]
        attitude: Attitude,
        /// Vertical channel: integrated freely, or held at the start height.
        #[arg(long, value_enum, default_value_t = Vertical::Free)]
        vertical: Vertical,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Frame {
    Ned,
    Wander,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Attitude {
    RotationVector,
    Euler,
    Heun,
    Rk4,
    Abm4,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Vertical {
    Free,
    Hold,
}

/// The mechanization choices of the command line.
fn choices(frame: Frame, attitude: Attitude, vertical: Vertical) -> MechanizationChoices {
    MechanizationChoices {
        frame: match frame {
            Frame::Ned => NavFrame::Ned,
            Frame::Wander => NavFrame::WanderAzimuth,
        },
        attitude: match attitude {
            Attitude::RotationVector => AttitudeMethod::RotationVector,
            Attitude::Euler => AttitudeMethod::Poisson(DcmIntegrator::Euler),
            Attitude::Heun => AttitudeMethod::Poisson(DcmIntegrator::Heun),
            Attitude::Rk4 => AttitudeMethod::Poisson(DcmIntegrator::Rk4),
            Attitude::Abm4 => AttitudeMethod::Poisson(DcmIntegrator::Abm4),
        },
        vertical: match vertical {
            Vertical::Free => VerticalChannel::Free,
            Vertical::Hold => VerticalChannel::Hold,
        },
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Precision {
    F32,
    F64,
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Generate {
            out,
            seconds,
            rate,
            lat,
            lon,
            h,
            roll,
            pitch,
            yaw,
        } => {
            let scenario = Stationary {
                lat_deg: lat,
                lon_deg: lon,
                h_m: h,
                roll_deg: roll,
                pitch_deg: pitch,
                yaw_deg: yaw,
                rate_hz: rate,
                seconds,
            };
            let recording = scenario.recording()?;
            recording_io::write(&out, &recording)?;
            println!(
                "wrote {}: {} samples at {rate} Hz, at rest at {lat} deg, {lon} deg, {h} m, roll {roll}, pitch {pitch}, yaw {yaw} deg",
                out.display(),
                recording.records.len()
            );
            Ok(())
        }
        Command::Bench { passes } => {
            let increments = host_tests::bench::flight_increments();
            for (name, rate) in [
                (
                    "f32",
                    host_tests::bench::steps_per_second::<f32>(&increments, passes),
                ),
                (
                    "f64",
                    host_tests::bench::steps_per_second::<f64>(&increments, passes),
                ),
            ] {
                println!("mechanization {name}: {rate:.0} steps/s (one thread, no I/O)");
            }
            Ok(())
        }
        Command::Convert { input, out } => {
            let format = recording_io::detect(&input)?;
            let recording = recording_io::read(&input)?;
            recording_io::write(&out, &recording)?;
            println!(
                "converted {} ({format}, {} samples at {} Hz) to {}",
                input.display(),
                recording.records.len(),
                recording.rate_hz,
                out.display()
            );
            Ok(())
        }
        Command::Replay {
            imu,
            lat,
            lon,
            h,
            align_seconds,
            out,
            log_every,
            precision,
            calibration,
            device,
            frame,
            attitude,
            vertical,
        } => {
            let calibration = match calibration {
                None => ImuCalibration::default(),
                Some(path) => {
                    let text = std::fs::read_to_string(&path)
                        .with_context(|| format!("reading {}", path.display()))?;
                    ImuCalibration::parse(&text)
                        .with_context(|| format!("in {}", path.display()))?
                }
            };
            let options = ReplayOptions {
                lat_deg: lat,
                lon_deg: lon,
                h_m: h,
                align_seconds,
                log_every,
                calibration,
                device,
                choices: choices(frame, attitude, vertical),
            };
            let file = File::create(&out).with_context(|| format!("creating {}", out.display()))?;
            let writer = BufWriter::new(file);
            let started = std::time::Instant::now();
            let report = match precision {
                Precision::F32 => replay_file::<f32, _>(&imu, &options, writer),
                Precision::F64 => replay_file::<f64, _>(&imu, &options, writer),
            }
            .with_context(|| format!("replay of {} into {}", imu.display(), out.display()))?;
            let seconds = started.elapsed().as_secs_f64();
            print_summary(&imu, &out, precision, &report);
            // Benchmark figure: whole pipeline (read, check, navigate, log), one thread.
            println!(
                "speed: {:.0} samples/s ({:.3} s wall clock, file reading and logging included)",
                f64::from(report.report.samples) / seconds.max(1e-9),
                seconds
            );
            Ok(())
        }
    }
}

fn print_summary(imu: &Path, out: &Path, precision: Precision, fr: &FileReport) {
    let r = &fr.report;
    let format = fr.format;
    let p = match precision {
        Precision::F32 => "f32",
        Precision::F64 => "f64",
    };
    println!(
        "replay of {} ({format}, {} Hz, {p})",
        imu.display(),
        fr.rate_hz
    );
    let c = r.source.unwrap_or_default();
    println!(
        "samples {}: flagged {} (non-finite {}, bad interval {}), rejected {}, missed {}; navigation steps {}",
        r.samples, r.flagged, c.non_finite, c.bad_interval, r.rejected, c.missed, r.nav_steps
    );
    let a = &r.alignment;
    println!(
        "alignment over {} samples ({:.3} s): roll {:.6} deg, pitch {:.6} deg, yaw {:.6} deg (|f| {:.5} m/s^2, |omega| {:.3} deg/h)",
        a.samples,
        a.duration_s,
        a.roll_deg,
        a.pitch_deg,
        a.yaw_deg,
        a.f_mean_mps2,
        a.omega_mean_dph
    );
    let s = &r.final_solution;
    println!(
        "final at t = {:.6} s: lat {:.9} deg, lon {:.9} deg, h {:.3} m; v_NED {:.6} {:.6} {:.6} m/s; roll {:.6} pitch {:.6} yaw {:.6} deg",
        s.t_us as f64 / 1e6,
        s.lat_ndeg as f64 / 1e9,
        s.lon_ndeg as f64 / 1e9,
        s.h_m,
        s.v_eb_n[0],
        s.v_eb_n[1],
        s.v_eb_n[2],
        s.roll_deg,
        s.pitch_deg,
        s.yaw_deg
    );
    println!("log: {} ({} rows)", out.display(), r.rows);
}
