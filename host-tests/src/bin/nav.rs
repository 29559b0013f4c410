//! `nav`: generate, convert and replay IMU recordings on the desktop.
//!
//! ```text
//! nav generate --out FILE [--seconds 60] [--rate 400] [--lat 45] [--lon 7.5] [--h 150]
//!              [--roll 1.5] [--pitch -2] [--yaw 30]
//! nav sim      SCENARIO --out DIR [--grade ideal|fog|rlg|mems-tactical|mems-consumer]
//!              [--seconds N] [--rate 400] [--seed 1] [--set KEY=VALUE]... [--truth-rate 50]
//!              [--format both|bin|csv] [--list-params]
//! nav align-bench seed002|seed003|lasergyro [--runs 50] [--grade fog] [--threads 2] [--data FILE]
//! nav align-bench family [--runs 50] [--family-seed 1] [--seconds 60,120,300] [--threads 2]
//!              [--member K]
//! nav sim      family --out DIR [--seed 1] [--set member=K] [--seconds 300] ...
//! nav convert  --in FILE --out FILE
//! nav bench    [--passes 10]
//! nav replay   --imu FILE --lat DEG --lon DEG --h M --align-seconds S --out FILE
//!              [--log-every 40] [--precision f32|f64] [--calibration FILE]
//!              [--device recording|adis16505|icm42688|bmi088] [--frame wander|ned]
//!              [--attitude rotation-vector|euler|heun|rk4|abm4] [--vertical free|hold]
//!              [--align-method static|inertial|fine|sway] [--imu-noise GRADE]
//!              [--bias-prior K] [--lever-arm X,Y,Z | --lever-arm-sigma S]
//!              [--imu-range GYRO_DEG_S,ACCEL_G]
//! nav report   --solution FILE --truth FILE [--at 60,300] [--plots DIR]
//! nav decode   STREAM --out FILE
//! nav config   FILE.txt --out FILE
//! nav emulate  --truth FILE --out FILE [--preset none|seed004-rlg] [--errors FILE]
//!              [--set 'KEY = V1 V2 V3']... [--vertical aided|free] [--errors-out FILE]
//! ```
//! Output recordings are binary unless the file name ends in `.csv`. Errors name the file and the
//! line or byte offset, and exit with status 1.

// Units are written `[m/s]` in docs (project convention), which rustdoc would read as links.
#![allow(rustdoc::broken_intra_doc_links)]

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use hal_adapters::sample::FullScale;
use host_tests::generate::Stationary;
use host_tests::pipeline::{DEFAULT_LOG_EVERY, MechanizationChoices, RunConfig, sensor_noise};
use host_tests::recording_io;
use host_tests::replay::{FileReport, ImuDevice, ReplayOptions, replay_file};
use nav_core::alignment::{AlignMethod, BaseMotion, LeverArm};
use nav_core::navigator::config;
use nav_core::{AttitudeMethod, ImuCalibration, NavFrame, VerticalChannel};
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
    /// Emulate a SINS with given errors along a truth trajectory [Stand model]: propagate the
    /// linearised error model and write truth + errors in the trajectory CSV format. Errors come
    /// from the preset, then the error file, then each --set line (see `host_tests::emulate`
    /// for the keys; e.g. `gyro_drift_deg_h = 0.01 0.01 0.01`).
    Emulate {
        /// Truth trajectory (CSV: t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,...).
        #[arg(long, value_name = "FILE")]
        truth: PathBuf,
        /// Displayed trajectory to write (the same CSV format).
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// Starting errors.
        #[arg(long, value_enum, default_value_t = host_tests::emulate::Preset::None)]
        preset: host_tests::emulate::Preset,
        /// Error file (`key = v1 v2 v3` lines; the key's suffix is the unit).
        #[arg(long, value_name = "FILE")]
        errors: Option<PathBuf>,
        /// One `key = v1 v2 v3` line applied after the file (repeatable).
        #[arg(long, value_name = "KEY = V1 V2 V3")]
        set: Vec<String>,
        /// Vertical channel: aided by baro/truth (dh = dv_D = 0) or free inertial.
        #[arg(long, value_enum, default_value_t = host_tests::emulate::Vertical::Aided)]
        vertical: host_tests::emulate::Vertical,
        /// Also write the error series (CSV: attitude, velocity and position errors).
        #[arg(long, value_name = "FILE")]
        errors_out: Option<PathBuf>,
    },
    /// Simulate a scenario: exact increments through a sensor grade's error model, written as
    /// DIR/imu.bin and DIR/imu.csv (recordings), DIR/truth.csv and DIR/scenario.txt.
    #[command(allow_negative_numbers = true)]
    Sim(Box<SimArgs>),
    /// Alignment benchmarks with their physical floors: the level filter on a rocking ship [Ship alignment]
    /// (sea states 3-6), fine alignment on the AUV bench [Vavilova et al.], heading repeatability on
    /// the real laser-gyro recording, and every method on a seeded family of still and swaying
    /// bases (family).
    #[command(allow_negative_numbers = true)]
    AlignBench {
        /// seed002, seed003, lasergyro or family.
        which: AlignBenchKind,
        /// Monte Carlo runs per cell (seed002, seed003); members (family).
        #[arg(long, default_value_t = 50)]
        runs: usize,
        /// Sensor grade of the `seed002` runs.
        #[arg(long, default_value = "fog")]
        grade: host_tests::sensor_model::Grade,
        /// Threads (seed003, family; 1 to 256, as `nav bench`).
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// The laser-gyro recording (lasergyro).
        #[arg(long, value_name = "FILE")]
        data: Option<PathBuf>,
        /// The family's seed (family).
        #[arg(long, default_value_t = 1)]
        family_seed: u64,
        /// Alignment windows [s] (family).
        #[arg(long, value_name = "S,...", value_delimiter = ',', allow_hyphen_values = true, default_values_t = host_tests::align_bench::family::WINDOWS_S)]
        seconds: Vec<f64>,
        /// Only this member, every method's numbers (family).
        #[arg(long, value_name = "K")]
        member: Option<u64>,
        /// Switch parts of every member off, to find what a method trips on (family):
        /// translation, surge-sway (the horizontal translation only), lever-arm, biases, yaw, rotation, mean-tilt.
        #[arg(long, value_name = "PART,...", value_delimiter = ',', value_parser = parse_ablation)]
        ablate: Vec<host_tests::trajectory::family::Ablation>,
    },
    /// Gyro-free attitude from an isotropic oscillator [Oscillator INS]: the estimator's accuracy
    /// against the ratio of the oscillator frequency to the body rate and against readout noise,
    /// for the paper's method as written and with the rotation compensation.
    #[command(allow_negative_numbers = true)]
    OscBench {
        /// Seconds of coning per row (after 1 s of lock).
        #[arg(long, default_value_t = 4.0)]
        seconds: f64,
        /// The ratio w0/|omega| of the noise table.
        #[arg(long, default_value_t = 500.0)]
        noise_ratio: f64,
    },
    /// Navigate a scenario on the gyro-free oscillator [Oscillator INS] and on a gyro IMU of the same
    /// motion: the oscillator's attitude and specific force feed the same mechanization; prints
    /// both runs' errors against the truth.
    #[command(allow_negative_numbers = true)]
    Oscillator {
        /// Scenario (static, ship-rocking, auv-bench, flight, land-vehicle).
        scenario: String,
        /// Length [s].
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
        /// Grade of the gyro IMU it is compared with.
        #[arg(long, default_value = "fog")]
        grade: host_tests::sensor_model::Grade,
        /// Oscillator readout noise, 1 sigma per axis per sample [m].
        #[arg(long, default_value_t = 1e-9)]
        noise_m: f64,
        /// Natural frequency [Hz] (readout at 50 samples per period).
        #[arg(long, default_value_t = 100.0)]
        f0_hz: f64,
        /// The paper's method as written (no rotation compensation).
        #[arg(long)]
        seed_method: bool,
        /// Also write the oscillator's readouts (the `osc.csv` format) to this file.
        #[arg(long, value_name = "FILE")]
        readouts: Option<PathBuf>,
    },
    /// Run the oscillator estimator [Oscillator INS] over a readout file (`t_s,x_m,y_m,z_m`, e.g. from
    /// `nav oscillator --readouts`): counts, faults and, with --out, one CSV row per epoch
    /// (attitude C_b_e as a quaternion, specific force, 1-sigma, frequency).
    #[command(allow_negative_numbers = true)]
    OscReplay {
        /// The readout file.
        file: PathBuf,
        /// The oscillator's nominal natural frequency [Hz].
        #[arg(long, default_value_t = 100.0)]
        f0_hz: f64,
        /// Epoch rows to write.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
        /// The paper's method as written (no rotation compensation).
        #[arg(long)]
        seed_method: bool,
        /// Precision of the estimator.
        #[arg(long, default_value = "f64")]
        precision: Precision,
    },
    /// Benchmarks, printed: the mechanization alone (the default: steps per second on one
    /// thread, f32 and f64, over 10 min of exact 400 Hz increments of a 900 km/h flight), `nav
    /// kf-gins` speed and accuracy, the aided filter's NEES/NIS consistency, GNSS outages,
    /// GNSS outliers and gaps in the IMU data.
    #[command(allow_negative_numbers = true)]
    Bench {
        /// What to measure: mechanization (steps/s, no I/O), filter (`nav kf-gins` speed and
        /// accuracy on a generated 1-hour KF-GINS data set), consistency (NEES/NIS Monte Carlo
        /// of the GNSS-aided filter), outages (drift in GNSS outages of `--outage-seconds`
        /// every 180 s), outliers (jumps, spikes, multipath, NaN fixes) or gaps (IMU records
        /// removed: the error against the widened 1-sigma after each gap).
        #[arg(default_value = "mechanization")]
        what: BenchKind,
        /// Passes over the 240,000 increments (mechanization; at least 1).
        #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
        passes: u32,
        /// Monte Carlo runs per cell [default: 60 for consistency (each run's drawn
        /// misalignment holds through all its epochs, so with 30 the fraction of epochs inside
        /// the bounds moves by several percent from one set of seeds to the next), 30 for
        /// outages, 1 for outliers (above 1: each outlier's figures over the seeds), 10 for gaps]
        #[arg(long)]
        runs: Option<usize>,
        /// Threads (consistency, outages; 1 to 256, as `nav align-bench`).
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Length of each simulated run [s] (consistency; filter and outages use 1 h).
        #[arg(long, default_value_t = 600.0)]
        seconds: f64,
        /// Length of each outage [s] (outages; one every 180 s).
        #[arg(long, default_value_t = host_tests::gnss_bench::OUTAGE_S)]
        outage_seconds: f64,
        /// Directory for the generated data set (filter) [default: a temporary directory].
        #[arg(long, value_name = "DIR")]
        dir: Option<PathBuf>,
        /// Zero-velocity and zero-rate updates at the simulated stops (consistency; off by
        /// default: their 1-sigma stands for a real vehicle's residual motion at a stop, which
        /// the exactly still simulated stops lack, so the filter is conservative there by
        /// design).
        #[arg(long)]
        zero_motion: bool,
        /// Sensor errors the simulator leaves out, and the filter's noise model with them,
        /// comma-separated (consistency; diagnostics): misalignment (gyro-misalignment,
        /// accel-misalignment), g-sensitivity, scale, bias, bias-instability,
        /// rate-random-walk, white-noise, quantisation.
        #[arg(long, value_delimiter = ',')]
        without: Vec<host_tests::sensor_model::ErrorSource>,
        /// Only these cells of the table, 1-based, comma-separated (consistency) [default: all].
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        cells: Vec<usize>,
        /// Print each block's mean NEES per tenth of the run (consistency).
        #[arg(long)]
        blocks: bool,
        /// Seed of the first run; run k uses this + k (consistency: another value draws an
        /// independent family of the same size; outliers: the seed of the table).
        #[arg(long, default_value_t = 1)]
        first_seed: u64,
        /// Independent families of --runs runs per cell, on consecutive seeds (consistency):
        /// one row each and the spread of their NEES-inside fractions. An error correlated
        /// over a minute or more (a misalignment, a receiver's correlated error) makes the
        /// fraction of one family move by 10 % or more from one family to the next even when
        /// the filter is consistent; the mean over families is the figure to judge.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
        families: u32,
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
    /// Convert a recording (CSV, PSINS, KF-GINS, gnss-ins-sim folder or binary; auto-detected)
    /// to binary, or to CSV when the output ends in .csv; with --gnss, a GNSS file (the
    /// project's CSV, KF-GINS's text, or gnss-ins-sim's GPS file with --gnss-sigma) to the
    /// binary fix file the firmware's --gnss reads.
    #[command(allow_negative_numbers = true)]
    Convert {
        /// Input recording (or GNSS file, with --gnss).
        #[arg(long = "in", value_name = "FILE")]
        input: PathBuf,
        /// Output file.
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// The input is a GNSS file: write docs/gnss-record-format.md's binary fix file.
        #[arg(long)]
        gnss: bool,
        #[command(flatten)]
        gnss_sigma: GnssSigmaArgs,
        /// With --gnss: the receiver's output latency [s] (as `nav replay --gnss-latency`):
        /// each fix is written at its tag less it, its measurement epoch, for the firmware's
        /// --gnss. Within 0 to 1 s.
        #[arg(long, value_name = "S", requires = "gnss", default_value_t = 0.0)]
        gnss_latency: f64,
    },
    /// Run a KF-GINS configuration file as it is (its IMU and GNSS text files, start, noise and
    /// lever arm) through this project's GNSS-aided filter, writing KF-GINS's 11-column .nav
    /// trajectory, one row per IMU epoch.
    KfGins {
        /// The KF-GINS YAML configuration (keys imupath, gnsspath, outputpath, imudatalen,
        /// imudatarate, starttime, endtime, initpos, initvel, initatt, init*std, imunoise,
        /// antlever; KF-GINS's units).
        config: PathBuf,
        /// The trajectory to write [default: OUTPUTPATH/KF_GINS_Navresult.nav].
        #[arg(long, value_name = "FILE.nav")]
        out: Option<PathBuf>,
        /// Also write KF-GINS's IMU error file here (13 columns: time, gyro biases [deg/h],
        /// accelerometer biases [mGal], gyro and accelerometer scale factors [ppm]; KF-GINS
        /// names it OUTPUTPATH/KF_GINS_IMU_ERR.txt).
        #[arg(long, value_name = "FILE")]
        imu_err: Option<PathBuf>,
        /// Also write KF-GINS's 1-sigma file here (22 columns: time, position north, east,
        /// down [m], velocity [m/s], roll, pitch, yaw [deg], then the sensor errors' in the IMU
        /// error file's units; KF-GINS names it OUTPUTPATH/KF_GINS_STD.txt).
        #[arg(long, value_name = "FILE")]
        std: Option<PathBuf>,
        /// No zero-velocity and zero-rate updates at stops, as KF-GINS (which has none): for a
        /// vehicle that may move straight at a steady speed below 1 m/s, which looks still to
        /// the IMU.
        #[arg(long)]
        no_stops: bool,
    },
    /// Align and navigate over a recording (any format), writing the solution log as CSV.
    #[command(allow_negative_numbers = true)]
    Replay(Box<ReplayArgs>),
    /// Decode the board's binary output stream (docs/protocol.md) back to the solution CSV;
    /// report skipped bytes, CRC failures and frames by type on stderr.
    Decode(host_tests::decode::DecodeArgs),
    /// Encode a configuration frame from its text form (`key = value` lines), refusing bad
    /// values with their line and reason.
    Config(host_tests::config_cmd::ConfigArgs),
    /// Compare a solution log with a truth trajectory: RMS, max and chosen-time errors of
    /// position, velocity and attitude, and optional SVG plots.
    Report {
        /// Solution log (CSV of `nav replay`, or a KF-GINS .nav result).
        #[arg(long, value_name = "FILE")]
        solution: PathBuf,
        /// Truth trajectory (CSV with the solution log's header, a KF-GINS .nav file, or a
        /// gnss-ins-sim output folder's reference trajectory).
        #[arg(long, value_name = "FILE")]
        truth: PathBuf,
        /// Times [s] after the start of the truth (its first row) at which to print the errors (nearest row),
        /// comma-separated; a time outside the compared rows' span is refused.
        #[arg(
            long,
            value_name = "S,...",
            value_delimiter = ',',
            allow_hyphen_values = true
        )]
        at: Vec<f64>,
        /// Directory for the SVG plots (created if missing).
        #[arg(long, value_name = "DIR")]
        plots: Option<PathBuf>,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Precision {
    F32,
    F64,
}

/// `nav align-bench` tables.
#[derive(Clone, Copy, PartialEq, Eq, Debug, ValueEnum)]
enum AlignBenchKind {
    /// Level alignment on a rocking ship [Ship alignment].
    Seed002,
    /// Fine alignment on the AUV bench [Vavilova et al.].
    Seed003,
    /// The real laser-gyro recording.
    Lasergyro,
    /// Every method on a seeded family of still and swaying bases.
    Family,
}

/// `nav bench` measurements.
#[derive(Clone, Copy, PartialEq, Eq, Debug, ValueEnum)]
enum BenchKind {
    /// Mechanization steps per second.
    Mechanization,
    /// `nav kf-gins` speed and accuracy.
    Filter,
    /// NEES/NIS consistency.
    Consistency,
    /// GNSS outages.
    Outages,
    /// GNSS outliers.
    Outliers,
    /// Gaps in the IMU data: bridged up to 5 s, beyond lost and the filter re-aligned in
    /// motion on the fixes after it.
    Gaps,
}

/// Recording files of `nav sim`.
#[derive(Clone, Copy, ValueEnum)]
enum SimFormat {
    /// imu.bin only.
    Bin,
    /// imu.csv only.
    Csv,
    /// Both.
    Both,
}

/// `nav replay`'s arguments: the run configuration ([`RunConfig`], shared with the firmware's
/// arguments) and the files.
#[derive(clap::Args)]
struct ReplayArgs {
    /// Input recording (binary, CSV, PSINS, KF-GINS or a gnss-ins-sim output folder;
    /// auto-detected).
    #[arg(long, value_name = "FILE")]
    imu: PathBuf,
    /// Latitude of the site [deg].
    #[arg(long, required_unless_present_any = ["init_pos", "start_in_motion"], conflicts_with_all = ["init_pos", "start_in_motion"])]
    lat: Option<f64>,
    /// Longitude of the site [deg].
    #[arg(long, required_unless_present_any = ["init_pos", "start_in_motion"], conflicts_with_all = ["init_pos", "start_in_motion"])]
    lon: Option<f64>,
    /// Ellipsoidal height of the site [m].
    #[arg(long, required_unless_present_any = ["init_pos", "start_in_motion"], conflicts_with_all = ["init_pos", "start_in_motion"])]
    h: Option<f64>,
    /// Length of the alignment window at the start [s] (at least the method's minimum: 10 s
    /// for static and inertial, 20 s for fine, 40 s for sway).
    #[arg(long, required_unless_present_any = ["init_pos", "start_in_motion"], conflicts_with_all = ["init_pos", "start_in_motion"])]
    align_seconds: Option<f64>,
    /// GNSS fixes: CSV with units in the header (t_s,lat_deg,lon_deg,h_m,sigma_n_m,...),
    /// KF-GINS's text (7 columns, or 13 with velocity), or gnss-ins-sim's GPS file (gps-K.csv
    /// or its folder, with --gnss-sigma). Navigates with the GNSS-aided filter, started by
    /// --init-pos/--init-vel/--init-att or --start-in-motion.
    #[arg(long, value_name = "FILE")]
    gnss: Option<PathBuf>,
    /// The GNSS antenna's position from the IMU, body forward,right,down [m].
    #[arg(long, value_name = "X,Y,Z", requires = "gnss", allow_hyphen_values = true, value_parser = parse_vector3)]
    gnss_lever_arm: Option<[f64; 3]>,
    #[command(flatten)]
    gnss_sigma: GnssSigmaArgs,
    /// The GNSS receiver's output latency [s]: its fixes are tagged this long after the epoch
    /// they were measured at (a logger that tags them on arrival), and are taken at their tag
    /// less it. Within 0 to 1 s. Unstated, a latency of 0.1 s puts a car at 15 m/s 1.5 m
    /// behind its fixes, beyond an RTK fix's 1-sigma.
    #[arg(long, value_name = "S", requires = "gnss", default_value_t = 0.0)]
    gnss_latency: f64,
    /// The receiver's time-correlated position error (multipath, atmosphere), 1-sigma north,
    /// east, down [m]: a Gauss–Markov error the filter carries as a consider state of the
    /// position fixes (a code receiver's is metres; leave it out for RTK). Any start: given,
    /// in motion or after the alignment (the firmware's `--gnss` run takes the same option).
    #[arg(long, value_name = "N,E,D", requires = "gnss", allow_hyphen_values = true, value_parser = parse_vector3)]
    gnss_correlated: Option<[f64; 3]>,
    /// Correlation time of --gnss-correlated [s].
    #[arg(
        long,
        value_name = "S",
        requires = "gnss_correlated",
        default_value_t = nav_core::navigator::config::DEFAULT_GNSS_CORRELATION_TIME_S
    )]
    gnss_correlated_time: f64,
    /// Initial position of the IMU: latitude, longitude [deg], height [m] (KF-GINS's initpos).
    /// The given start holds at the beginning of the first sample's interval (its time tag
    /// less one interval): the first sample is integrated from it. KF-GINS's start holds at
    /// its `starttime` epoch, which it does not integrate (`nav kf-gins`): a state taken at the
    /// first sample's time tag is one interval late here (v dt: 7.5 cm at 15 m/s and 200 Hz).
    #[arg(long, value_name = "LAT,LON,H", requires_all = ["gnss", "init_vel", "init_att"], allow_hyphen_values = true, value_parser = parse_vector3)]
    init_pos: Option<[f64; 3]>,
    /// Initial velocity north, east, down [m/s] (initvel).
    #[arg(long, value_name = "VN,VE,VD", requires = "init_pos", allow_hyphen_values = true, value_parser = parse_vector3)]
    init_vel: Option<[f64; 3]>,
    /// Initial roll, pitch, yaw [deg] (initatt).
    #[arg(long, value_name = "ROLL,PITCH,YAW", requires = "init_pos", allow_hyphen_values = true, value_parser = parse_vector3)]
    init_att: Option<[f64; 3]>,
    /// 1-sigma of the initial position [m], velocity [m/s] and attitude [deg]: three values,
    /// each for all three axes, or nine, per axis as KF-GINS's initposstd, initvelstd and
    /// initattstd (north, east, down; roll, pitch, yaw: a heading known to 10 deg with a level
    /// known to 0.1 deg is `1,1,1,0.1,0.1,0.1,0.1,0.1,10`). Positive: a zero would claim an
    /// exactly known state.
    #[arg(long, value_name = "POS,VEL,ATT", requires = "init_pos", default_value = "1,0.1,1", allow_hyphen_values = true, value_parser = parse_init_std)]
    init_std: [[f64; 3]; 3],
    /// Start the filter in motion from GNSS (level when quasi-static, heading from the track
    /// above --start-speed): for IMUs that cannot find north (MEMS).
    #[arg(long, requires = "gnss", conflicts_with = "init_pos")]
    start_in_motion: bool,
    /// With --start-in-motion: the horizontal speed above which the heading is taken from the
    /// track [m/s], 0.5 to 100 (default 5): lower it for a slow vehicle (a robot, a boat). The
    /// speed must also be 4 times the noise of the velocity (with the receiver's velocity, a
    /// few decimetres per second; 0.5 m positions differenced over a second, 3 m/s). The
    /// heading's 1-sigma is the velocity's over the speed with the sideslip's, so a slow start
    /// is a start with a wide heading 1-sigma.
    #[arg(long, value_name = "M/S")]
    start_speed: Option<f64>,
    /// With --start-in-motion: 1-sigma of the angle between the body's forward axis and the
    /// ground track the heading is taken from [deg], at most 45. A car's sideslip is within the
    /// default; a boat's or an aircraft's crab in a crosswind, or an IMU whose forward axis is
    /// turned from the direction of travel, is not: its heading would start that far off with
    /// a 3 deg 1-sigma.
    /// (default 3).
    #[arg(long, value_name = "DEG", value_parser = parse_sideslip_sigma)]
    sideslip_sigma: Option<f64>,
    /// Leave the scale-factor states out of the filter (15 states).
    #[arg(long, requires = "gnss")]
    no_scale_factors: bool,
    /// No zero-velocity and zero-rate updates at stops (a given start or a start in motion):
    /// for a vehicle that may move straight at a steady speed below 1 m/s (a ship, a robot, a
    /// crawler), which looks still to the IMU; the stops then held its solution while the
    /// fixes that showed it moving were refused.
    #[arg(long)]
    no_stops: bool,
    /// Covariance propagation rate of the filter [Hz].
    #[arg(long, requires = "gnss", default_value_t = 10.0)]
    propagation_rate: f64,
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
    /// misalignments), applied before the alignment and the navigation; identity without it.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["init_pos", "start_in_motion"])]
    calibration: Option<PathBuf>,
    /// The sample path: the recording as it is, or a simulated IMU on an SPI bus read by its
    /// real driver (the firmware's path on the `qemu` board is `adis16505`); from the
    /// alignment only (a given start or a start in motion replays the recording as it is).
    #[arg(long, value_enum, default_value_t = ImuDevice::Recording, conflicts_with_all = ["init_pos", "start_in_motion"])]
    device: ImuDevice,
    /// The recorded IMU's full scale, gyro [deg/s] and accelerometer [g], e.g. 500,8. A sample
    /// with an axis at it (to 0.1 %) or beyond is taken as clipped: the GNSS-aided filter
    /// doubts what the range cut off, as for a driver's clip (README). A recording carries no
    /// range: without this option no sample is taken as clipped. Any start, with --gnss (a
    /// free-inertial run has no covariance to doubt); not with --device (the driver knows
    /// its part's).
    #[arg(long, value_name = "DEG_S,G", value_parser = parse_full_scale, requires = "gnss", conflicts_with = "device")]
    imu_range: Option<FullScale>,
    /// Navigation frame of the mechanization, wander or ned (outputs are NED either way).
    #[arg(long, default_value = "wander", value_parser = named(&config::FRAMES), conflicts_with_all = ["init_pos", "start_in_motion"])]
    frame: NavFrame,
    /// Attitude integration: rotation-vector (quaternion), or Poisson's DCM equation with
    /// euler, heun, rk4 or abm4.
    #[arg(long, default_value = "rotation-vector", value_parser = named(&config::ATTITUDES), conflicts_with_all = ["init_pos", "start_in_motion"])]
    attitude: AttitudeMethod,
    /// Vertical channel: free (integrated) or hold (held at the start height).
    #[arg(long, default_value = "free", value_parser = named(&config::VERTICALS), conflicts_with_all = ["init_pos", "start_in_motion"])]
    vertical: VerticalChannel,
    /// Alignment method: static (analytic, still base), inertial (inertial-frame coarse:
    /// rocking base, no initial heading), fine (inertial coarse, then the
    /// position-aided Kalman filter [Vavilova et al.]), sway (inertial coarse, then the swaying-base model).
    #[arg(long, default_value = "static", value_parser = parse_align_method, conflicts_with_all = ["init_pos", "start_in_motion"])]
    align_method: AlignMethod,
    /// IMU noise assumed by the alignment and by the GNSS-aided filter, as a simulator grade
    /// (fog, rlg, mems-tactical, mems-consumer; not ideal where an alignment runs: a
    /// noise-free model cannot judge stillness); default: the device's datasheet (the board's
    /// ADIS16505 for a plain recording). A filter that assumes a better IMU than the
    /// recording's refuses the fixes it should use: give the grade of the sensor.
    #[arg(long, value_name = "GRADE")]
    imu_noise: Option<host_tests::sensor_model::Grade>,
    /// Scale of the assumed noise's bias 1-sigmas (0: biases compensated).
    #[arg(long, value_name = "K", default_value_t = 1.0, conflicts_with_all = ["init_pos", "start_in_motion"])]
    bias_prior: f64,
    /// The IMU's lever arm from the base's centre of rotation, body forward,right,down [m]
    /// (known: a ship's deck), e.g. -5.9,0.6,-7.5.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_vector3, conflicts_with_all = ["init_pos", "start_in_motion"])]
    lever_arm: Option<[f64; 3]>,
    /// Without --lever-arm: the unknown lever arm's prior, 1-sigma per body axis [m].
    #[arg(long, value_name = "S", conflicts_with_all = ["lever_arm", "init_pos", "start_in_motion"],
          default_value_t = nav_core::alignment::machine::DEFAULT_LEVER_ARM_SIGMA_M)]
    lever_arm_sigma: f64,
    /// The base's horizontal translation (waves' surge and sway of its centre), stationary
    /// 1-sigma per axis [m]; 0 for a base that only turns (a motion table). The inertial,
    /// fine and sway alignments' (the static one refuses a base that moves).
    /// (default 0.5).
    #[arg(long, value_name = "M", conflicts_with_all = ["init_pos", "start_in_motion"])]
    base_translation: Option<f64>,
}

impl ReplayArgs {
    /// The run configuration these arguments describe (checked when the replay starts).
    fn options(&self) -> Result<ReplayOptions> {
        let calibration = match &self.calibration {
            None => ImuCalibration::default(),
            Some(path) => {
                host_tests::atomic::refuse_same_file(&[path], &self.out)?;
                let text = host_tests::text_error::read_text(path)
                    .with_context(|| format!("--calibration {}", path.display()))?;
                let calibration = ImuCalibration::parse(&text).map_err(|e| {
                    anyhow::anyhow!("--calibration {}: {}", path.display(), e.in_text(&text))
                })?;
                // Missing keys stay identity, but a file with none is an empty or truncated
                // one, or the wrong one (as `nav config` refuses one).
                let has_key = text
                    .trim_start_matches('\u{feff}')
                    .lines()
                    .any(|l| !l.split('#').next().unwrap_or("").trim().is_empty());
                anyhow::ensure!(
                    has_key,
                    "--calibration {}: no 'key = values' line (an empty or truncated file, or \
                     the wrong one): give the keys ({}), or leave --calibration out for \
                     identity",
                    path.display(),
                    nav_core::calibration::KEYS.join(", ")
                );
                calibration
            }
        };
        // Zero noise made the stillness test's scatter "infx" its noise.
        anyhow::ensure!(
            self.imu_noise != Some(host_tests::sensor_model::Grade::Ideal),
            "--imu-noise ideal: the alignment judges whether the base is still, and weighs its \
             measurements, by the IMU's noise, and a noise-free model has none; give the grade \
             of the recording's IMU (fog, rlg, mems-tactical, mems-consumer), or leave \
             --imu-noise out for the device's datasheet"
        );
        let noise = self
            .imu_noise
            .map_or(self.device.noise(), |g| g.noise_spec());
        let run = RunConfig {
            figures: noise.figures,
            align_method: self.align_method,
            bias_prior: self.bias_prior,
            lever_arm: match self.lever_arm {
                Some(r) => LeverArm::Known(r.into()),
                None => LeverArm::Unknown {
                    sigma_m: self.lever_arm_sigma,
                },
            },
            log_every: self.log_every,
            base: BaseMotion {
                translation_sigma_m: self.base_translation(),
                ..BaseMotion::default()
            },
            calibration,
            mechanization: MechanizationChoices {
                frame: self.frame,
                attitude: self.attitude,
                vertical: self.vertical,
            },
            ..RunConfig::new(
                self.lat.unwrap_or(f64::NAN),
                self.lon.unwrap_or(f64::NAN),
                self.h.unwrap_or(f64::NAN),
                self.align_seconds.unwrap_or(f64::NAN),
                sensor_noise(&noise),
            )
        };
        self.check_geometry(&run)?;
        // The base's translation was ignored without a word.
        anyhow::ensure!(
            self.base_translation.is_none() || self.align_method.takes_base_translation(),
            "--base-translation: {}",
            nav_core::alignment::machine::BASE_TRANSLATION_STATIC
        );
        Ok(ReplayOptions {
            run,
            device: self.device,
            full_scale: self.imu_range,
        })
    }

    /// `--base-translation`, or its default [m].
    fn base_translation(&self) -> f64 {
        self.base_translation
            .unwrap_or(BaseMotion::<f64>::default().translation_sigma_m)
    }

    /// nav-core's check of the lever arm and the base's motion, its refusal named by the
    /// option that gave the value ("the base motion must be finite ..." named neither).
    fn check_geometry(&self, run: &RunConfig) -> Result<()> {
        use nav_core::alignment::machine::check_geometry;
        use nav_core::number::Number;
        let lever = match self.lever_arm {
            Some(r) => format!(
                "--lever-arm {},{},{}",
                Number(r[0]),
                Number(r[1]),
                Number(r[2])
            ),
            None => format!("--lever-arm-sigma {}", Number(self.lever_arm_sigma)),
        };
        check_geometry(&run.lever_arm, &BaseMotion::default()).context(lever)?;
        check_geometry(&LeverArm::default(), &run.base)
            .with_context(|| format!("--base-translation {}", Number(self.base_translation())))?;
        Ok(())
    }
}

/// The lowest natural frequency `nav oscillator` simulates [Hz]: measured on the still base
/// and the land vehicle with the default amplitude, 30 Hz locks at once (13 periods acquiring)
/// while 20 Hz never locked, even with a readout noise of 1e-12 m (the failure blamed the
/// noise).
const MIN_SIMULATED_F0_HZ: f64 = 30.0;

/// Most runs of a Monte Carlo bench.
const MAX_RUNS: usize = 100_000;
/// Refuses a bench's `--runs` outside `min_runs..=MAX_RUNS` and `--threads` outside
/// [`check_threads`]'s range.
fn check_monte_carlo(runs: usize, min_runs: usize, threads: usize) -> Result<()> {
    anyhow::ensure!(
        (min_runs..=MAX_RUNS).contains(&runs),
        "--runs must be from {min_runs} to {MAX_RUNS}, not {runs}"
    );
    check_threads(threads)
}

/// Refuses a bench's `--threads` outside `1..=MAX_THREADS` (every bench's range).
fn check_threads(threads: usize) -> Result<()> {
    use host_tests::MAX_THREADS;
    anyhow::ensure!(
        (1..=MAX_THREADS).contains(&threads),
        "--threads must be from 1 to {MAX_THREADS}, not {threads}"
    );
    Ok(())
}

/// `nav bench outages`: 1-hour land-vehicle runs, 60 s outages every 180 s.
fn bench_outages(runs: usize, threads: usize, outage_s: f64) -> Result<()> {
    use host_tests::gnss_bench::{OUTAGE_PERIOD_S, outage_case, outage_drifts};
    use host_tests::sensor_model::Grade;
    check_monte_carlo(runs, 1, threads)?;
    anyhow::ensure!(
        (1.0..=OUTAGE_PERIOD_S - 10.0).contains(&outage_s),
        "--outage-seconds must be from 1 to {} s (an outage every {OUTAGE_PERIOD_S} s, with fixes between), not {}",
        OUTAGE_PERIOD_S - 10.0,
        nav_core::number::Number(outage_s)
    );
    println!(
        "1 h land vehicle, 1 Hz fixes (0.5/0.5/1 m), {outage_s} s outages every {OUTAGE_PERIOD_S} s from 300 s; {runs} run(s) per grade; drift = horizontal error at the outage's end"
    );
    println!(
        "| grade | outages | drift RMS [m] | drift max [m] | predicted 1-sigma RMS [m] | max drift/sigma | beyond 3 sigma |"
    );
    println!("|---|---|---|---|---|---|---|");
    for grade in [
        Grade::Rlg,
        Grade::Fog,
        Grade::MemsTactical,
        Grade::MemsConsumer,
    ] {
        let seeds: Vec<u64> = (1..=runs as u64).collect();
        let all = std::sync::Mutex::new(Vec::new());
        std::thread::scope(|s| {
            for t in 0..threads.max(1) {
                let (all, seeds) = (&all, &seeds);
                s.spawn(move || {
                    for seed in seeds.iter().skip(t).step_by(threads.max(1)) {
                        let r = outage_drifts(&outage_case(grade, 3600.0, outage_s, *seed));
                        all.lock().expect("no panic").push(r);
                    }
                });
            }
        });
        let mut drifts = Vec::new();
        for r in all.into_inner().expect("no panic") {
            drifts.extend(r?);
        }
        let n = drifts.len().max(1) as f64;
        let rms = |f: &dyn Fn(&host_tests::gnss_bench::OutageDrift) -> f64| {
            (drifts.iter().map(|d| f(d).powi(2)).sum::<f64>() / n).sqrt()
        };
        println!(
            "| {grade} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {} |",
            drifts.len(),
            rms(&|d| d.drift_m),
            drifts.iter().map(|d| d.drift_m).fold(0.0, f64::max),
            rms(&|d| d.sigma_m),
            drifts
                .iter()
                .map(|d| d.drift_m / d.sigma_m)
                .fold(0.0, f64::max),
            drifts
                .iter()
                .filter(|d| d.drift_m > 3.0 * d.sigma_m)
                .count()
        );
    }
    Ok(())
}

/// `nav bench outliers`: seed `first_seed`'s table, and with `runs` above 1 each outlier's
/// figures over seeds `first_seed ..` (one draw shows one draw: a slow ramp is bounded on
/// some seeds and not on others).
fn bench_outliers(runs: usize, first_seed: u64) -> Result<()> {
    use host_tests::gnss_bench::{
        CODE_RECEIVER_CORRELATED, OUTLIER_VELOCITY_SIGMA_M_S, OutlierOutcome, outlier_case,
        outlier_case_code_receiver, outlier_case_with_velocity, outliers,
    };
    use host_tests::sensor_model::Grade;
    check_monte_carlo(runs, 1, 1)?;
    let last_seed = first_seed
        .checked_add(runs as u64 - 1)
        .ok_or_else(|| anyhow::anyhow!("--first-seed {first_seed} + --runs {runs} overflows"))?;
    println!(
        "land vehicle, 1 Hz fixes of 0.5 m white noise (where the GNSS column says so, with velocity of {} m/s, or with a code receiver's correlated error of {:?} m, tau {} s, simulated and declared to the filter; the outliers move the positions alone); each outlier, what the gate did, the largest horizontal error from its start to 30 s after it and the largest ratio of the error to the filter's reported 1-sigma there, and the same from the outlier's end on (the true fixes back); seed {first_seed}",
        OUTLIER_VELOCITY_SIGMA_M_S[0], CODE_RECEIVER_CORRELATED.0, CODE_RECEIVER_CORRELATED.1
    );
    println!(
        "| grade | GNSS | outlier | at [s] | fixes | refused | max error [m] | 1-sigma there [m] | max error/1-sigma | after its end | DEGRADED | accepted again |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    type CaseOf = fn(Grade, u64) -> host_tests::aided_bench::Case;
    let cases: [(Grade, &str, CaseOf); 4] = [
        (Grade::Fog, "position", outlier_case),
        (Grade::MemsTactical, "position", outlier_case),
        (
            Grade::MemsTactical,
            "position + velocity",
            outlier_case_with_velocity,
        ),
        (
            Grade::MemsTactical,
            "position, correlated error declared",
            outlier_case_code_receiver,
        ),
    ];
    // Per case, per seed, its outcomes.
    let mut all: Vec<Vec<Vec<OutlierOutcome>>> = Vec::new();
    for (grade, gnss, case_of) in &cases {
        let mut by_seed = Vec::new();
        for seed in first_seed..=last_seed {
            let out = outliers(&case_of(*grade, seed))?;
            if seed == first_seed {
                for o in &out {
                    println!(
                        "| {grade} | {gnss} | {} | {} | {} | {} | {:.2} | {:.2} | {:.1} | {:.1} | {} | {} |",
                        o.name,
                        o.t_s,
                        o.fixes,
                        o.refused,
                        o.max_error_m,
                        o.sigma_at_max_m,
                        o.max_error_per_sigma,
                        o.max_error_per_sigma_after,
                        if o.degraded { "yes" } else { "no" },
                        if o.reacquired { "yes" } else { "no" }
                    );
                }
            }
            by_seed.push(out);
        }
        all.push(by_seed);
    }
    if runs > 1 {
        println!(
            "\nover seeds {first_seed}–{last_seed}: each outlier's median and largest max error/1-sigma while it lasts and after it, the seeds where either passed 3, the fixes refused (fewest–most) and the seeds where the true fixes were accepted again within 60 s"
        );
        println!(
            "| grade | GNSS | outlier | at [s] | median / max during | median / max after | seeds beyond 3 sigma | refused | accepted again |"
        );
        println!("|---|---|---|---|---|---|---|---|---|");
        for ((grade, gnss, _), by_seed) in cases.iter().zip(&all) {
            for k in 0..by_seed[0].len() {
                let of_k: Vec<&OutlierOutcome> = by_seed.iter().map(|out| &out[k]).collect();
                let stats = |f: fn(&OutlierOutcome) -> f64| {
                    let mut v: Vec<f64> = of_k.iter().map(|o| f(o)).collect();
                    v.sort_by(f64::total_cmp);
                    (v[v.len() / 2], v[v.len() - 1])
                };
                let during = stats(|o| o.max_error_per_sigma);
                let after = stats(|o| o.max_error_per_sigma_after);
                let beyond: Vec<String> = (first_seed..)
                    .zip(&of_k)
                    .filter(|(_, o)| {
                        o.max_error_per_sigma > 3.0 || o.max_error_per_sigma_after > 3.0
                    })
                    .map(|(s, _)| s.to_string())
                    .collect();
                let refused = of_k.iter().map(|o| o.refused);
                let (lo, hi) = (
                    refused.clone().min().unwrap_or(0),
                    refused.max().unwrap_or(0),
                );
                println!(
                    "| {grade} | {gnss} | {} | {} | {:.1} / {:.1} | {:.1} / {:.1} | {} | {lo}–{hi} of {} | {}/{} |",
                    of_k[0].name,
                    of_k[0].t_s,
                    during.0,
                    during.1,
                    after.0,
                    after.1,
                    if beyond.is_empty() {
                        "none".to_string()
                    } else {
                        beyond.join(", ")
                    },
                    of_k[0].fixes,
                    of_k.iter().filter(|o| o.reacquired).count(),
                    of_k.len()
                );
            }
        }
    }
    Ok(())
}

/// `nav bench gaps`: per grade and gap length, `runs` land-vehicle runs (seeds `first_seed
/// ..`), each with one gap of its IMU records at a time drawn from its seed; the gaps beyond
/// the bridge with positions alone and with fixes that carry a velocity (the re-alignment in
/// motion finds its level from those).
fn bench_gaps(runs: usize, first_seed: u64) -> Result<()> {
    use host_tests::gap_bench::{
        GapOutcome, WATCH_S, gap_case, gap_case_with_velocity, gap_run, gap_start_s,
        median_max_cell,
    };
    use host_tests::sensor_model::Grade;
    check_monte_carlo(runs, 1, 1)?;
    let last_seed = first_seed
        .checked_add(runs as u64 - 1)
        .ok_or_else(|| anyhow::anyhow!("--first-seed {first_seed} + --runs {runs} overflows"))?;
    // chi^2(9) at 99.9 %.
    const NEES9_999: f64 = 27.877;
    println!(
        "land vehicle, 300 s at 200 Hz, 1 Hz fixes of 0.5 m; one gap of the IMU records per run at 60-240 s, bridged with the rates either side (nav_core::gap; at most {} s), a longer one lost and the filter re-aligned in motion on the fixes after it (nav_core::ins_filter::sequencer); seeds {first_seed}-{last_seed}: the NEES of position, velocity and attitude at the first filter sample after the gap (after a lost gap the restarted filter's; 9 dof, 99.9 % point {NEES9_999}), the largest horizontal error per reported 1-sigma over the {WATCH_S} s after the gap, the largest error, the fixes refused then, the runs re-aligned and the median time from the gap's end to NAV again, the runs that ended DEGRADED, and over the lost filter's DEGRADED rows (a gap beyond the bridge, until the re-alignment) their largest horizontal error per reported 1-sigma",
        nav_core::gap::MAX_BRIDGED_S
    );
    println!(
        "| grade | gap [s] | NEES after: median / max | runs beyond 99.9 % | max error/1-sigma: median / max | max error [m]: median / max | refused | re-aligned (median time to NAV [s]) | DEGRADED | lost rows' max error/1-sigma: median / max |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for grade in [Grade::Fog, Grade::MemsTactical, Grade::MemsConsumer] {
        let rows = [0.025, 0.1, 0.5, 1.0, 2.0, 4.0, 6.0, 20.0]
            .map(|s| (s, false))
            .into_iter()
            .chain([(6.0, true), (20.0, true)]);
        for (lost_s, velocity) in rows {
            let mut out: Vec<GapOutcome> = Vec::new();
            for seed in first_seed..=last_seed {
                let case = if velocity {
                    gap_case_with_velocity(grade, seed)
                } else {
                    gap_case(grade, seed)
                };
                out.push(gap_run(&case, gap_start_s(seed), lost_s)?);
            }
            let gap = if velocity {
                format!("{lost_s}, fixes with velocity")
            } else {
                lost_s.to_string()
            };
            let median = |mut v: Vec<f64>| -> (f64, f64) {
                v.sort_by(f64::total_cmp);
                match v.len() {
                    0 => (f64::NAN, f64::NAN),
                    n => (v[n / 2], v[n - 1]),
                }
            };
            // Over the runs whose filter navigated within the watch (NaN: not one).
            let stats = |f: fn(&GapOutcome) -> f64| {
                median(out.iter().map(f).filter(|v| !v.is_nan()).collect())
            };
            let nees = stats(|o| o.nees_after);
            let ratio = stats(|o| o.max_error_per_sigma);
            let error = stats(|o| o.max_error_m);
            let lost_ratio = stats(|o| o.lost_max_error_per_sigma);
            let beyond = out.iter().filter(|o| o.nees_after > NEES9_999).count();
            let refused: usize = out.iter().map(|o| o.refused).sum();
            let fixes: usize = out.iter().map(|o| o.fixes).sum();
            let degraded = out
                .iter()
                .filter(|o| o.status != nav_core::ins_filter::FilterStatus::Nominal)
                .count();
            let realigned: Vec<f64> = out.iter().filter_map(|o| o.realigned_after_s).collect();
            let realigned = match realigned.len() {
                0 => "-".to_owned(),
                n => format!("{n} of {runs} ({:.1})", median(realigned).0),
            };
            // "-" where no run gave the figure, as the re-aligned column.
            println!(
                "| {grade} | {gap} | {} | {beyond} of {runs} | {} | {} | {refused} of {fixes} | {realigned} | {degraded} of {runs} | {} |",
                median_max_cell(nees, 1),
                median_max_cell(ratio, 2),
                median_max_cell(error, 2),
                median_max_cell(lost_ratio, 2)
            );
        }
    }
    Ok(())
}

/// `nav bench filter`.
fn bench_filter(dir: Option<PathBuf>) -> Result<()> {
    use host_tests::filter_bench::{FilterBenchOptions, generate, run};
    let temp = tempfile::tempdir()?;
    let dir = dir.unwrap_or_else(|| temp.path().to_path_buf());
    // A file gave "creating FILE: File exists (os error 17)".
    if dir.exists() && !dir.is_dir() {
        anyhow::bail!(
            "--dir {} is a file: nav bench filter writes a folder (the KF-GINS data set: IMU and \
             GNSS text, configuration, truth, result); give a folder's path (created if missing)",
            dir.display()
        );
    }
    let o = FilterBenchOptions::default();
    println!(
        "generating {} s of {} at {} Hz with 1 Hz RTK fixes ({:?} m) in {} ...",
        o.seconds,
        o.grade,
        o.imu_rate_hz,
        o.gnss_sigma_ned_m,
        dir.display()
    );
    let data = generate(&dir, &o)?;
    let r = run(&data)?;
    println!(
        "nav kf-gins: {} IMU samples in {:.3} s: {:.0} samples/s (one thread; text parsing and .nav writing included; target >= 650000)",
        r.samples,
        r.seconds,
        r.samples as f64 / r.seconds
    );
    println!(
        "of those seconds, {:.3} s the disk took to store the .nav file (sync and rename; KF-GINS does not sync its output): {:.0} samples/s without that wait",
        r.store_seconds,
        r.samples as f64 / (r.seconds - r.store_seconds).max(1e-9)
    );
    if let Some(cpu) = r.cpu_seconds {
        println!(
            "the thread's CPU time: {cpu:.3} s: {:.0} samples/s per busy core (the wall clock above also counts the time other jobs on this machine held the cores)",
            r.samples as f64 / cpu
        );
    }
    println!(
        "accuracy over {} truth epochs: horizontal RMS {:.4} m (target <= 0.02), max {:.4} m; vertical RMS {:.4} m; yaw RMS {:.4} deg (target <= 0.06)",
        r.compared, r.horizontal_rms_m, r.horizontal_max_m, r.vertical_rms_m, r.yaw_rms_deg
    );
    println!(
        "the filter's own 1-sigma, RMS over the run: horizontal {:.4} m, yaw {:.4} deg (the error a consistent filter expects on these fixes and this IMU)",
        r.sigma_rms.horizontal_m, r.sigma_rms.yaw_deg
    );
    Ok(())
}

/// `nav bench consistency`'s diagnostic choices.
struct ConsistencyChoice {
    /// Sensor errors left out of the simulation.
    without: Vec<host_tests::sensor_model::ErrorSource>,
    /// 1-based cells to run (empty: all).
    cells: Vec<usize>,
    /// Print the blocks' NEES over time.
    blocks: bool,
    /// Seed of the first run.
    first_seed: u64,
    /// Independent families of runs per cell.
    families: usize,
}

/// Cells of `nav bench consistency`'s table.
const CONSISTENCY_CELLS: usize = 6;

/// `nav bench consistency`.
fn bench_consistency(
    runs: usize,
    threads: usize,
    seconds: f64,
    zero_motion: bool,
    choice: &ConsistencyChoice,
) -> Result<()> {
    use host_tests::aided_bench::{Case, average_chi2_bounds, consistency_cell};
    use host_tests::gnss_sim::GnssSimOptions;
    use host_tests::sensor_model::Grade;
    check_monte_carlo(runs, 2, threads)?;
    // Before the table's header: each run's scenario checks it again.
    host_tests::trajectory::scenarios::check_seconds(seconds)?;
    if let Some(cell) = choice
        .cells
        .iter()
        .find(|c| !(1..=CONSISTENCY_CELLS).contains(*c))
    {
        anyhow::bail!("--cells {cell}: the table has cells 1 to {CONSISTENCY_CELLS}");
    }
    // The seeds wrapped silently past u64::MAX (a table of seeds 18446744073709551615–0).
    let seeds = (runs as u64).checked_mul(choice.families as u64);
    if seeds
        .and_then(|n| choice.first_seed.checked_add(n.saturating_sub(1)))
        .is_none()
    {
        anyhow::bail!(
            "--first-seed {} + --runs {runs} x --families {} overflows the seeds (at most {})",
            choice.first_seed,
            choice.families,
            u64::MAX
        );
    }
    let (lo9, hi9) = average_chi2_bounds(9.0, runs);
    let (lo3, hi3) = average_chi2_bounds(3.0, runs);
    println!(
        "{runs} runs per family, {} {} per cell, {} s each, zero-velocity/rate updates {}; \
         95 % bounds of the average NEES (9 dof) [{lo9:.2}, {hi9:.2}], NIS (3 dof) [{lo3:.2}, {hi3:.2}]",
        choice.families,
        if choice.families == 1 {
            "family"
        } else {
            "families"
        },
        nav_core::number::Number(seconds),
        if zero_motion { "on" } else { "off" }
    );
    println!(
        "| seeds | scenario | grade | GNSS | epochs | NEES inside | mean NEES (pos/vel/att) | NIS inside | mean NIS | bias z RMS gyro/accel | max |bias z| | within 3 sigma b_g/b_a/s_g/s_a | gated |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut block_tables = Vec::new();
    let mut summaries = Vec::new();
    // The last cell: a code receiver, whose time-correlated error is simulated and declared.
    let (code_sigma, code_time) = host_tests::gnss_bench::CODE_RECEIVER_CORRELATED;
    let code = Some(host_tests::gnss_sim::CorrelatedError {
        sigma_ned_m: code_sigma,
        time_s: code_time,
    });
    let table: [_; CONSISTENCY_CELLS] = [
        ("land-vehicle", Grade::Fog, 1.0, [0.5, 0.5, 1.0], None, None),
        (
            "land-vehicle",
            Grade::MemsTactical,
            1.0,
            [0.5, 0.5, 1.0],
            None,
            None,
        ),
        (
            "land-vehicle",
            Grade::MemsConsumer,
            10.0,
            [1.0, 1.0, 2.0],
            Some([0.05, 0.05, 0.1]),
            None,
        ),
        (
            "flight",
            Grade::Rlg,
            5.0,
            [0.5, 0.5, 1.0],
            Some([0.05, 0.05, 0.1]),
            None,
        ),
        (
            "flight",
            Grade::MemsTactical,
            2.0,
            [1.0, 1.0, 2.0],
            None,
            None,
        ),
        (
            "land-vehicle",
            Grade::MemsTactical,
            1.0,
            [0.5, 0.5, 1.0],
            None,
            code,
        ),
    ];
    for (cell, (scenario, grade, rate, sigma, vel, correlated)) in table.into_iter().enumerate() {
        if !(choice.cells.is_empty() || choice.cells.contains(&(cell + 1))) {
            continue;
        }
        let case = Case {
            scenario: scenario.into(),
            grade,
            seconds,
            imu_rate_hz: 200.0,
            gnss: GnssSimOptions {
                rate_hz: rate,
                sigma_ned_m: sigma,
                sigma_v_ned_m_s: vel,
                lever_arm_b_m: [0.8, -0.3, -1.1],
                correlated,
                ..GnssSimOptions::default()
            },
            seed: choice.first_seed,
            zero_motion,
            without: choice.without.clone(),
        };
        let gnss = match correlated {
            Some(c) => format!(
                "{rate} Hz, correlated {:?} m, {} s",
                c.sigma_ned_m, c.time_s
            ),
            None => format!("{rate} Hz"),
        };
        let mut inside = Vec::new();
        for family in 0..choice.families as u64 {
            // Checked above: no overflow.
            let first = choice.first_seed + family * runs as u64;
            let seeds = format!("{first}–{}", first + (runs as u64 - 1));
            let r = consistency_cell(
                &Case {
                    seed: first,
                    ..case.clone()
                },
                runs,
                threads,
            )?;
            println!(
                "| {seeds} | {scenario} | {grade} | {gnss} | {} | {:.0} % | {:.2} ({:.2}/{:.2}/{:.2}) | {:.0} % | {:.2} | {:.2} / {:.2} | {:.2} | {} | {}/{} |",
                r.epochs,
                100.0 * r.nees_inside,
                r.nees_mean,
                r.nees_blocks_mean[0],
                r.nees_blocks_mean[1],
                r.nees_blocks_mean[2],
                100.0 * r.nis_inside,
                r.nis_mean,
                r.bias_z_rms.0,
                r.bias_z_rms.1,
                r.bias_z_max,
                r.sensor_within_3_sigma
                    .map(|f| format!("{:.0} %", 100.0 * f))
                    .join(" / "),
                r.rejected.0,
                r.rejected.1
            );
            inside.push(100.0 * r.nees_inside);
            block_tables.push((
                format!("{scenario} {grade} {gnss}, seeds {seeds}"),
                r.blocks_over_time,
            ));
        }
        if inside.len() > 1 {
            let mean = inside.iter().sum::<f64>() / inside.len() as f64;
            let each: Vec<String> = inside.iter().map(|x| format!("{x:.0}")).collect();
            summaries.push(format!(
                "cell {} ({scenario}, {grade}, {gnss}): NEES inside per family {} %, mean {mean:.0} %",
                cell + 1,
                each.join(" / ")
            ));
        }
    }
    for line in &summaries {
        println!("{line}");
    }
    if choice.blocks {
        use host_tests::aided_bench::NEES_BLOCKS;
        for (name, rows) in block_tables {
            println!(
                "\n{name}: mean NEES per block (3 dof each; 95 % of one epoch's average inside [{lo3:.2}, {hi3:.2}])"
            );
            println!("| until [s] | {} |", NEES_BLOCKS.join(" | "));
            for (t, m) in rows {
                let cells: Vec<String> = m.iter().map(|x| format!("{x:.2}")).collect();
                println!("| {t:.0} | {} |", cells.join(" | "));
            }
        }
    }
    Ok(())
}

/// `nav replay --gnss`: the aided filter.
fn replay_aided(a: &ReplayArgs, gnss: &std::path::Path) -> Result<()> {
    use host_tests::aided_cmd::{self, AidedReplay, AidedStart, GivenStart};
    let spec = a.imu_noise.map_or(a.device.noise(), |g| g.noise_spec());
    let noise = match a.imu_noise {
        Some(g) => aided_cmd::grade_noise(g),
        None => aided_cmd::noise_of_spec(&spec),
    };
    anyhow::ensure!(
        a.propagation_rate.is_finite() && (1.0..=1000.0).contains(&a.propagation_rate),
        "--propagation-rate must be within 1 to 1000 Hz, not {}",
        nav_core::number::Number(a.propagation_rate)
    );
    let mut config = nav_core::ins_filter::FilterConfig::new(noise);
    config.scale_factors = !a.no_scale_factors;
    if a.no_stops {
        config.zero_motion = None;
    }
    config.propagation_interval_s = 1.0 / a.propagation_rate;
    config.antenna_lever_arm_b_m = a.gnss_lever_arm.unwrap_or([0.0; 3]).into();
    config.gnss_correlated_error =
        a.gnss_correlated
            .map(|s| nav_core::ins_filter::GnssCorrelatedError {
                sigma_ned_m: s.into(),
                correlation_time_s: a.gnss_correlated_time,
            });
    let start = match (a.init_pos, a.init_vel, a.init_att) {
        (Some(pos), Some(vel), Some(att)) => AidedStart::Given(Box::new(GivenStart {
            pos_deg_m: pos,
            vel_m_s: vel,
            att_deg: att,
            pos_std_m: a.init_std[0],
            vel_std_m_s: a.init_std[1],
            att_std_deg: a.init_std[2],
            sensors: Default::default(),
            sensor_sigma: None,
        })),
        _ if a.start_in_motion => {
            let d = nav_core::ins_filter::motion::MotionAlignConfig::<f64>::default();
            let min_speed_m_s = a.start_speed.unwrap_or(d.min_speed_m_s);
            anyhow::ensure!(
                min_speed_m_s.is_finite() && (0.5..=100.0).contains(&min_speed_m_s),
                "--start-speed must be within 0.5 to 100 m/s, not {}",
                nav_core::number::Number(min_speed_m_s)
            );
            AidedStart::Motion {
                min_speed_m_s,
                sideslip_rad: a.sideslip_sigma.map_or(d.sideslip_rad, f64::to_radians),
            }
        }
        _ => {
            // From the navigator's alignment (the firmware's `--gnss` run): the run
            // configuration of a plain replay, with the aided phase after the alignment.
            let mut options = a.options()?;
            options.run.aiding = Some(nav_core::navigator::AidingConfig {
                antenna_lever_arm_b_m: a.gnss_lever_arm.unwrap_or([0.0; 3]),
                propagation_interval_s: 1.0 / a.propagation_rate,
                scale_factors: !a.no_scale_factors,
                gnss_correlated_sigma_ned_m: a.gnss_correlated,
                gnss_correlated_time_s: a.gnss_correlated_time,
                ..nav_core::navigator::AidingConfig::default()
            });
            return host_tests::replay::replay_aided_cli(
                &a.imu,
                gnss,
                a.gnss_sigma.assumed().as_ref(),
                a.gnss_latency,
                &a.out,
                &options,
                a.precision == Precision::F64,
            );
        }
    };
    let job = AidedReplay {
        imu: a.imu.clone(),
        gnss: gnss.to_path_buf(),
        gnss_sigma: a.gnss_sigma.assumed(),
        gnss_latency_s: a.gnss_latency,
        out: a.out.clone(),
        config,
        start,
        log_every: a.log_every,
        full_scale: a.imu_range,
    };
    let started = std::time::Instant::now();
    let (report, rows) = match a.precision {
        Precision::F32 => aided_cmd::replay_aided::<f32>(&job),
        Precision::F64 => aided_cmd::replay_aided::<f64>(&job),
    }
    .with_context(|| {
        format!(
            "aided replay of {} into {}",
            a.imu.display(),
            a.out.display()
        )
    })?;
    let seconds = started.elapsed().as_secs_f64();
    println!("{}", aided_cmd::summary(&report, rows, &a.imu, &a.out));
    println!(
        "speed: {:.0} samples/s ({seconds:.3} s wall clock, file reading and logging included)",
        report.samples as f64 / seconds.max(1e-9)
    );
    Ok(())
}

/// `nav replay`.
fn replay(a: ReplayArgs) -> Result<()> {
    // clap's `requires` takes a flag's default `false` as present.
    anyhow::ensure!(
        a.start_speed.is_none() || a.start_in_motion,
        "--start-speed is the heading threshold of a --start-in-motion"
    );
    anyhow::ensure!(
        a.sideslip_sigma.is_none() || a.start_in_motion,
        "--sideslip-sigma is the heading's doubt of a --start-in-motion (a given start's is in \
         --init-std, an alignment's its own)"
    );
    anyhow::ensure!(
        !a.no_stops || a.start_in_motion || a.init_pos.is_some(),
        "--no-stops applies to a GNSS-aided run from a given start (--init-pos) or a start in \
         motion (--start-in-motion)"
    );
    if let Some(gnss) = a.gnss.clone() {
        return replay_aided(&a, &gnss);
    }
    anyhow::ensure!(
        a.lat.is_some() && a.lon.is_some() && a.h.is_some() && a.align_seconds.is_some(),
        "without --gnss, --lat, --lon, --h and --align-seconds are required"
    );
    anyhow::ensure!(
        a.gnss_sigma.assumed().is_none(),
        "--gnss-sigma is the 1-sigma of a --gnss file"
    );
    let options = a.options()?;
    let (imu, out) = (&a.imu, &a.out);
    host_tests::atomic::refuse_same_file(&[imu], out)?;
    let started = std::time::Instant::now();
    // The log is renamed into place only after a successful replay (nothing is left at
    // `--out` otherwise, and an existing file there is untouched).
    let report = host_tests::atomic::write(out, |writer| match a.precision {
        Precision::F32 => replay_file::<f32, _>(imu, &options, writer),
        Precision::F64 => replay_file::<f64, _>(imu, &options, writer),
    })
    .map_err(|failure| {
        // The driver's counts of a failed run too, as the firmware logs them.
        if let Some(h) = failure.driver {
            println!("IMU driver: {h}");
        }
        failure.error
    })
    .with_context(|| format!("replay of {} into {}", imu.display(), out.display()))?;
    let seconds = started.elapsed().as_secs_f64();
    print_summary(imu, out, a.precision, &report);
    // Benchmark figure: whole pipeline (read, check, navigate, log), one thread.
    println!(
        "speed: {:.0} samples/s ({:.3} s wall clock, file reading and logging included)",
        f64::from(report.report.samples) / seconds.max(1e-9),
        seconds
    );
    Ok(())
}

/// A clap value parser of a nav-core name table.
fn named<V: Copy + Send + Sync + 'static>(
    table: &'static [(&'static str, V)],
) -> impl Fn(&str) -> Result<V, String> + Clone + Send + Sync + 'static {
    move |s| {
        config::by_name(table, s).ok_or_else(|| {
            let names: Vec<&str> = table.iter().map(|(n, _)| *n).collect();
            format!("expected one of {}", names.join(", "))
        })
    }
}

/// `X,Y,Z` values: three finite numbers (nav-core's syntax, as the firmware's).
/// The 1-sigma of a GNSS file that has none (gnss-ins-sim's GPS file).
#[derive(clap::Args, Clone, Debug, Default)]
struct GnssSigmaArgs {
    /// 1-sigma of the fixes' position north, east, down [m], for gnss-ins-sim's GPS file
    /// (gps-K.csv, which holds none; its default receiver: 5,5,7); refused for a file with its
    /// own.
    #[arg(long, value_name = "N,E,D", allow_hyphen_values = true, value_parser = parse_vector3)]
    gnss_sigma: Option<[f64; 3]>,
    /// 1-sigma of the fixes' velocity north, east, down [m/s], to use gnss-ins-sim's GPS
    /// velocity (its default receiver: 0.05,0.05,0.05); without it, positions only.
    #[arg(long, value_name = "VN,VE,VD", requires = "gnss_sigma", allow_hyphen_values = true, value_parser = parse_vector3)]
    gnss_velocity_sigma: Option<[f64; 3]>,
}

impl GnssSigmaArgs {
    fn assumed(&self) -> Option<host_tests::gnss::AssumedSigma> {
        self.gnss_sigma.map(|p| host_tests::gnss::AssumedSigma {
            position_ned_m: p,
            velocity_ned_m_s: self.gnss_velocity_sigma,
        })
    }
}

fn parse_vector3(s: &str) -> Result<[f64; 3], String> {
    config::parse_vector3(s)
        .ok_or_else(|| format!("expected X,Y,Z (three finite numbers), not {s:?}"))
}

/// `--init-std`: three positive 1-sigmas (position, velocity, attitude, each for all three
/// axes) or nine (per axis).
/// The largest `--sideslip-sigma` [deg]: the linearised filter takes a heading that far off
/// (an IMU turned 45 deg in its mount: yaw within its 1-sigma as an unturned one's), not much
/// more (60 deg: 17 % of the rows beyond 3 sigma; 90 deg: the fixes refused, DEGRADED).
const MAX_SIDESLIP_SIGMA_DEG: f64 = 45.0;

/// `--imu-range GYRO_DEG_S,ACCEL_G`: a gyro full scale of 1 to 100,000 deg/s and an
/// accelerometer's above 1 g (gravity alone would clip it at rest) to 10,000 g.
fn parse_full_scale(s: &str) -> Result<FullScale, String> {
    let values: Vec<f64> = s.split(',').filter_map(|v| v.trim().parse().ok()).collect();
    match values[..] {
        [gyro_deg_s, accel_g]
            if (1.0..=1e5).contains(&gyro_deg_s) && accel_g > 1.0 && accel_g <= 1e4 =>
        {
            Ok(FullScale {
                gyro_rad_s: gyro_deg_s.to_radians() as f32,
                accel_mps2: (accel_g * host_tests::emulate::G0_M_S2) as f32,
            })
        }
        _ => Err(format!(
            "expected GYRO_DEG_S,ACCEL_G: the gyro full scale, 1 to 100000 deg/s, and the \
             accelerometer's, above 1 g (gravity alone would clip it at rest) and at most \
             10000 g; not {s:?}"
        )),
    }
}

fn parse_sideslip_sigma(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite() && *x > 0.0 && *x <= MAX_SIDESLIP_SIGMA_DEG)
        .ok_or_else(|| {
            format!(
                "expected a 1-sigma above 0 and at most {MAX_SIDESLIP_SIGMA_DEG} deg, not {s:?}"
            )
        })
}

fn parse_init_std(s: &str) -> Result<[[f64; 3]; 3], String> {
    use nav_core::ins_filter::limits::{
        MAX_ATTITUDE_SIGMA_RAD, MAX_POSITION_SIGMA_M, MAX_VELOCITY_SIGMA_M_S,
    };
    use nav_core::number::Number;
    let values: Vec<&str> = s.split(',').map(str::trim).collect();
    if !matches!(values.len(), 3 | 9) {
        return Err(format!(
            "expected three or nine 1-sigmas (POS,VEL,ATT or N,E,D,VN,VE,VD,ROLL,PITCH,YAW), \
             not {s:?}"
        ));
    }
    // (what, unit, largest) of value `i` (three: one of each; nine: three of each).
    let kinds = [
        ("position", "m", MAX_POSITION_SIGMA_M),
        ("velocity", "m/s", MAX_VELOCITY_SIGMA_M_S),
        ("attitude", "deg", MAX_ATTITUDE_SIGMA_RAD.to_degrees()),
    ];
    let mut v = Vec::with_capacity(values.len());
    for (i, text) in values.iter().enumerate() {
        let (what, unit, max) = kinds[i * 3 / values.len()];
        let x = text
            .parse::<f64>()
            .map_err(|_| format!("the {what} 1-sigma {text:?} in {s:?} is not a number"))?;
        if x == 0.0 {
            return Err(format!(
                "the {what} 1-sigma in {s:?} is 0: a zero claims an exactly known state (every \
                 fix that disagrees would be refused)"
            ));
        }
        if !(x > 0.0 && x <= max) {
            return Err(format!(
                "the {what} 1-sigma {} {unit} in {s:?} must be above 0 and at most {} {unit}",
                Number(x),
                Number(max)
            ));
        }
        v.push(x);
    }
    Ok(match v[..] {
        [p, v, a] => [[p; 3], [v; 3], [a; 3]],
        _ => core::array::from_fn(|k| core::array::from_fn(|i| v[3 * k + i])),
    })
}

/// `nav sim`'s arguments.
#[derive(clap::Args)]
struct SimArgs {
    /// static, ship-rocking, auv-bench, flight, land-vehicle, or family (a member of the
    /// alignment family: --seed is the family's seed, --set member=K the member).
    scenario: String,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR", required_unless_present = "list_params")]
    out: Option<PathBuf>,
    /// Sensor grade: ideal, fog, rlg, mems-tactical, mems-consumer [default: ideal; a family
    /// member draws its own].
    #[arg(long)]
    grade: Option<host_tests::sensor_model::Grade>,
    /// Length [s] (default: the scenario's own).
    #[arg(long)]
    seconds: Option<f64>,
    /// IMU rate [Hz].
    #[arg(long, default_value_t = 400.0)]
    rate: f64,
    /// Seed of every random draw (same seed, same files).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Scenario parameter `KEY=VALUE` (repeatable; see --list-params).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Truth rate [Hz] (must divide the IMU rate).
    #[arg(long, default_value_t = 50.0)]
    truth_rate: f64,
    /// Recording files to write.
    #[arg(long, value_enum, default_value_t = SimFormat::Both)]
    format: SimFormat,
    /// Print the scenario's parameters with their defaults and exit.
    #[arg(long)]
    list_params: bool,
    /// Also write DIR/gnss.csv and DIR/gnss.bin (the firmware's binary fix file): a simulated
    /// GNSS receiver at this rate [Hz] (its interval a whole number of truth intervals), on the
    /// truth of the run.
    #[arg(long, value_name = "HZ")]
    gnss_rate: Option<f64>,
    /// GNSS position 1-sigma north, east, down [m].
    #[arg(long, value_name = "N,E,D", default_value = "0.5,0.5,1", allow_hyphen_values = true, value_parser = parse_vector3, requires = "gnss_rate")]
    gnss_sigma: [f64; 3],
    /// GNSS velocity 1-sigma north, east, down [m/s] (without it: position only).
    #[arg(long, value_name = "N,E,D", allow_hyphen_values = true, value_parser = parse_vector3, requires = "gnss_rate")]
    gnss_velocity_sigma: Option<[f64; 3]>,
    /// The antenna's position from the IMU, body forward,right,down [m].
    #[arg(long, value_name = "X,Y,Z", default_value = "0,0,0", allow_hyphen_values = true, value_parser = parse_vector3, requires = "gnss_rate")]
    gnss_lever_arm: [f64; 3],
    /// Outages: PERIOD,LENGTH,FIRST [s] (e.g. 180,60,300: 60 s without fixes every 180 s
    /// from 300 s).
    #[arg(long, value_name = "PERIOD,LENGTH,FIRST", allow_hyphen_values = true, value_parser = parse_vector3, requires = "gnss_rate")]
    gnss_outages: Option<[f64; 3]>,
    /// A position jump T,LENGTH,N,E,D [s, s, m] (repeatable).
    #[arg(long, value_name = "T,LEN,N,E,D", allow_hyphen_values = true, value_parser = parse_numbers::<5>, requires = "gnss_rate")]
    gnss_jump: Vec<[f64; 5]>,
    /// A one-fix spike T,N,E,D [s, m] (repeatable).
    #[arg(long, value_name = "T,N,E,D", allow_hyphen_values = true, value_parser = parse_numbers::<4>, requires = "gnss_rate")]
    gnss_spike: Vec<[f64; 4]>,
    /// A multipath bias growing linearly to N,E,D over LENGTH from T, then gone:
    /// T,LENGTH,N,E,D [s, s, m] (repeatable).
    #[arg(long, value_name = "T,LEN,N,E,D", allow_hyphen_values = true, value_parser = parse_numbers::<5>, requires = "gnss_rate")]
    gnss_ramp: Vec<[f64; 5]>,
    /// A NaN fix at T [s] (repeatable).
    #[arg(long, value_name = "T", requires = "gnss_rate")]
    gnss_nan: Vec<f64>,
    /// A time-correlated position error (multipath, atmosphere) added to the white noise: a
    /// first-order Gauss–Markov process of this steady-state 1-sigma north, east, down [m]; the
    /// fixes still report --gnss-sigma.
    #[arg(long, value_name = "N,E,D", allow_hyphen_values = true, value_parser = parse_vector3, requires = "gnss_rate")]
    gnss_correlated: Option<[f64; 3]>,
    /// The correlated error's correlation time [s].
    #[arg(
        long,
        value_name = "S",
        default_value_t = 60.0,
        requires = "gnss_correlated"
    )]
    gnss_correlated_time: f64,
}

/// `K` comma-separated finite numbers.
fn parse_numbers<const K: usize>(s: &str) -> Result<[f64; K], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected {K} comma-separated numbers, not {s:?}"))?;
    let arr: [f64; K] = v
        .try_into()
        .map_err(|_| format!("expected {K} comma-separated numbers, not {s:?}"))?;
    if arr.iter().all(|x| x.is_finite()) {
        Ok(arr)
    } else {
        Err(format!("expected finite numbers, not {s:?}"))
    }
}

/// `nav sim --gnss-rate`'s receiver.
fn gnss_options(
    a: &SimArgs,
    rate_hz: f64,
    seconds: f64,
) -> Result<host_tests::gnss_sim::GnssSimOptions> {
    use host_tests::gnss_sim::{CorrelatedError, GnssSimOptions, Outage, Outlier};
    if let Some([period, length, _]) = a.gnss_outages
        && !(period > 0.0 && (0.0..period).contains(&length))
    {
        anyhow::bail!(
            "--gnss-outages {period},{length},...: the period must be positive and the outage \
             length at least 0 and shorter than the period (else no fix is left)"
        );
    }
    let mut outliers = Vec::new();
    for j in &a.gnss_jump {
        outliers.push(Outlier::Jump {
            t_s: j[0],
            length_s: j[1],
            offset_ned_m: [j[2], j[3], j[4]],
        });
    }
    for p in &a.gnss_spike {
        outliers.push(Outlier::Spike {
            t_s: p[0],
            offset_ned_m: [p[1], p[2], p[3]],
        });
    }
    for r in &a.gnss_ramp {
        outliers.push(Outlier::Ramp {
            start_s: r[0],
            length_s: r[1],
            final_offset_ned_m: [r[2], r[3], r[4]],
        });
    }
    for (i, t) in a.gnss_nan.iter().enumerate() {
        // Listed twice, one fix made NaN once: not the receiver asked for.
        if a.gnss_nan[..i].contains(t) {
            anyhow::bail!("--gnss-nan {t} is given twice: give each fix's time once");
        }
        outliers.push(Outlier::NaN { t_s: *t });
    }
    Ok(GnssSimOptions {
        rate_hz,
        sigma_ned_m: a.gnss_sigma,
        sigma_v_ned_m_s: a.gnss_velocity_sigma,
        lever_arm_b_m: a.gnss_lever_arm,
        outages: a
            .gnss_outages
            .map(|[p, l, f]| Outage::every(p, l, f, seconds))
            .unwrap_or_default(),
        outliers,
        correlated: a.gnss_correlated.map(|sigma_ned_m| CorrelatedError {
            sigma_ned_m,
            time_s: a.gnss_correlated_time,
        }),
        seed: a.seed,
    })
}

/// The `--set KEY=VALUE` pairs of `nav sim`.
/// The `--set KEY=VALUE` pairs; a key given twice is refused, as `nav config` refuses one
/// (the last one won silently).
fn key_values(set: &[String]) -> Result<Vec<(&str, f64)>> {
    let pairs = set
        .iter()
        .map(|kv| {
            let (k, v) = kv
                .split_once('=')
                .with_context(|| format!("--set {kv:?}: expected KEY=VALUE"))?;
            let v: f64 = v
                .trim()
                .parse()
                .with_context(|| format!("--set {kv:?}: the value is not a number"))?;
            Ok((k.trim(), v))
        })
        .collect::<Result<Vec<_>>>()?;
    for (i, (k, v)) in pairs.iter().enumerate() {
        if let Some((_, first)) = pairs[..i].iter().find(|(key, _)| key == k) {
            anyhow::bail!("--set {k} is given twice ({first} and {v}): give each parameter once");
        }
    }
    Ok(pairs)
}

fn sim_formats(f: SimFormat) -> host_tests::simulate::Formats {
    use host_tests::simulate::Formats;
    match f {
        SimFormat::Bin => Formats::Binary,
        SimFormat::Csv => Formats::Csv,
        SimFormat::Both => Formats::Both,
    }
}

/// `nav sim family`: member `--set member=K` of family `--seed`.
fn sim_family(a: SimArgs) -> Result<()> {
    use host_tests::simulate_family::{FamilySimOptions, simulate_member, write_member};
    use host_tests::trajectory::family::FamilyMember;
    let mut member = 0u64;
    for (k, v) in key_values(&a.set)? {
        match k {
            "member" if v >= 0.0 && v.fract() == 0.0 && v < 9.0e15 => member = v as u64,
            "member" => anyhow::bail!(
                "member must be a whole number from 0 to 9e15, not {}",
                nav_core::number::Number(v)
            ),
            _ => anyhow::bail!("unknown parameter {k:?}; family has member"),
        }
    }
    if a.list_params {
        println!("family parameters:");
        println!(
            "  member = {member}  (the member's number; --seed is the family's seed; every other value is drawn, see host_tests::trajectory::family)"
        );
        return Ok(());
    }
    if let Some(g) = a.grade {
        anyhow::bail!("--grade {g}: a family member draws its own grade");
    }
    let Some(out) = a.out else {
        anyhow::bail!("--out DIR is required");
    };
    let m = FamilyMember::draw(a.seed, member);
    let opts = FamilySimOptions {
        seconds: a.seconds.unwrap_or(FamilySimOptions::default().seconds),
        rate_hz: a.rate,
        truth_rate_hz: a.truth_rate,
        formats: sim_formats(a.format),
    };
    let bar = progress_bar();
    let sim = simulate_member(&m, &opts, |done, total| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(done);
        }
    })?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let files = write_member(&out, &m, &opts, &sim)?;
    let n = sim.recording.records.len();
    println!(
        "family {} member {} ({}, lever arm {:.2} m, {:.2} deg lat): {n} samples at {} Hz ({:.1} s)",
        a.seed,
        member,
        m.category(),
        m.lever_arm_b_m().norm(),
        m.rocking.lat_deg,
        opts.rate_hz,
        n as f64 / opts.rate_hz
    );
    for p in [&files.binary, &files.csv].into_iter().flatten() {
        println!("  recording  {}", p.display());
    }
    println!("  truth      {}", files.truth.display());
    println!("  scenario   {}", files.description.display());
    print_removed(&files);
    Ok(())
}

/// Lists the files of an earlier `nav sim` run that this run removed (it did not write them;
/// [`host_tests::simulate::earlier_run_files`]).
fn print_removed(files: &host_tests::simulate::SimFiles) {
    for p in &files.removed {
        println!(
            "  removed    {} (an earlier nav sim run's, not this one's)",
            p.display()
        );
    }
}

fn sim(a: SimArgs) -> Result<()> {
    use host_tests::simulate::{ReceiverOutput, SimOptions, simulate, write_with_receiver};
    use host_tests::simulate_family::{SCENARIO_NAME, sim_scenario_names};
    use host_tests::trajectory::scenarios::Scenario;
    if let Some(out) = &a.out {
        host_tests::simulate::check_out_dir(out)?;
    }
    if a.scenario == SCENARIO_NAME {
        return sim_family(a);
    }
    if !Scenario::NAMES.contains(&a.scenario.as_str()) {
        anyhow::bail!(
            "unknown scenario '{}'; nav sim takes {}",
            a.scenario,
            sim_scenario_names().join(", ")
        );
    }
    let mut scenario = Scenario::by_name(&a.scenario)?;
    let set = key_values(&a.set)?;
    for &(k, v) in &set {
        scenario.set(k, v)?;
    }
    // Two lengths that disagree: --seconds took precedence without a word.
    if let (Some(given), Some(&(_, v))) = (a.seconds, set.iter().rfind(|(k, _)| *k == "seconds"))
        && given != v
    {
        anyhow::bail!(
            "--seconds {} and --set seconds={}: two lengths; give one",
            nav_core::number::Number(given),
            nav_core::number::Number(v)
        );
    }
    if a.list_params {
        println!("{} parameters:", scenario.name());
        for (k, v, doc) in scenario.describe() {
            println!("  {k} = {v}  ({doc})");
        }
        return Ok(());
    }
    let Some(out) = a.out.clone() else {
        anyhow::bail!("--out DIR is required");
    };
    let opts = SimOptions {
        seconds: a.seconds,
        rate_hz: a.rate,
        truth_rate_hz: a.truth_rate,
        seed: a.seed,
        formats: sim_formats(a.format),
        ..SimOptions::new(
            scenario,
            a.grade.unwrap_or(host_tests::sensor_model::Grade::Ideal),
        )
    };
    if let Some(rate) = a.gnss_rate {
        // The receiver's options are checked before anything is simulated or written.
        gnss_options(&a, rate, 0.0)?.check()?;
    }
    let bar = progress_bar();
    let sim = simulate(&opts, |done, total| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(done);
        }
    })?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let n = sim.recording.records.len();
    // The receiver is simulated before anything is written: a refusal leaves no recording.
    let receiver = match a.gnss_rate {
        Some(rate) => {
            let g = gnss_options(&a, rate, n as f64 / opts.rate_hz)?;
            let r = host_tests::gnss_sim::simulate(&sim.truth, &g)
                .context("simulated GNSS receiver")?;
            // An outlier or outage that reaches no fix injects nothing: a receiver that is not
            // the one asked for (a time past the run's end, or a typo), refused before
            // anything is written.
            let run_s = n as f64 / opts.rate_hz;
            if let Some(&k) = r.missed_outliers.first() {
                let o = &g.outliers[k];
                anyhow::bail!(
                    "--gnss-{} at {} s reaches no fix (the run is {} s long and its fixes in \
                     outages are dropped): nothing would be injected",
                    o.name().to_lowercase(),
                    nav_core::number::Number(o.start_s()),
                    nav_core::number::Number(run_s)
                );
            }
            if let Some(last) = sim.truth.last() {
                g.check_within_run(last.t_s)?;
            }
            if let Some([_, _, first]) = a.gnss_outages
                && g.outages.iter().all(|o| o.start_s >= run_s)
            {
                anyhow::bail!(
                    "--gnss-outages: the first outage at {} s is past the run's end ({} s): \
                     it would drop no fix",
                    nav_core::number::Number(first),
                    nav_core::number::Number(run_s)
                );
            }
            Some((g, r))
        }
        None => None,
    };
    // The receiver's settings and the replay that takes its fixes, in scenario.txt.
    let receiver_text = receiver.as_ref().map(|(g, r)| {
        let v3 = |v: [f64; 3]| format!("{},{},{}", v[0], v[1], v[2]);
        let mut text = format!(
            "# GNSS receiver (gnss.csv, gnss.bin)\ngnss_rate_hz = {}\ngnss_sigma_ned_m = {}\n\
             gnss_velocity_sigma_ned_m_s = {}\ngnss_lever_arm_b_m = {}\n",
            g.rate_hz,
            v3(g.sigma_ned_m),
            g.sigma_v_ned_m_s.map_or_else(|| "none".to_owned(), v3),
            v3(g.lever_arm_b_m),
        );
        for line in r.describe(g).lines() {
            text.push_str(&format!("# {line}\n"));
        }
        let mut options = format!("--gnss {}", out.join("gnss.csv").display());
        if g.lever_arm_b_m != [0.0; 3] {
            options.push_str(&format!(" --gnss-lever-arm {}", v3(g.lever_arm_b_m)));
        }
        if let Some(c) = &g.correlated {
            options.push_str(&format!(
                " --gnss-correlated {} --gnss-correlated-time {}",
                v3(c.sigma_ned_m),
                c.time_s
            ));
        }
        (text, options)
    });
    let files = write_with_receiver(
        &out,
        &opts,
        &sim,
        receiver_text
            .as_ref()
            .zip(receiver.as_ref())
            .map(|((text, replay_options), (_, r))| ReceiverOutput {
                text,
                replay_options,
                fixes: &r.fixes,
            }),
    )?;
    let (gnss_csv, gnss_bin) = (out.join("gnss.csv"), out.join("gnss.bin"));
    if let Some((g, receiver)) = receiver {
        println!(
            "  GNSS       {} and {} ({} fixes)",
            gnss_csv.display(),
            gnss_bin.display(),
            receiver.fixes.len()
        );
        for line in receiver.describe(&g).lines() {
            println!("    {line}");
        }
    }
    println!(
        "{} ({} grade, seed {}): {n} samples at {} Hz ({:.1} s)",
        opts.scenario.name(),
        opts.grade,
        opts.seed,
        opts.rate_hz,
        n as f64 / opts.rate_hz
    );
    for p in [&files.binary, &files.csv].into_iter().flatten() {
        println!("  recording  {}", p.display());
    }
    println!("  truth      {}", files.truth.display());
    println!("  scenario   {}", files.description.display());
    print_removed(&files);
    let c = sim.counters;
    if c.gyro_saturated + c.accel_saturated > 0 {
        println!(
            "  saturated samples: gyro {}, accelerometer {}",
            c.gyro_saturated, c.accel_saturated
        );
    }
    Ok(())
}

/// A progress bar on stderr when it is a terminal; `None` when piped.
fn progress_bar() -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} samples, {eta} left")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    })
}

/// `--ablate` values.
fn parse_ablation(s: &str) -> Result<host_tests::trajectory::family::Ablation, String> {
    use host_tests::trajectory::family::Ablation;
    Ablation::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = Ablation::ALL.iter().map(|a| a.name()).collect();
        format!("expected one of {}", names.join(", "))
    })
}

/// `--align-method` values: nav-core's method names.
fn parse_align_method(s: &str) -> Result<AlignMethod, String> {
    AlignMethod::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = AlignMethod::ALL.iter().map(|m| m.name()).collect();
        format!("expected one of {}", names.join(", "))
    })
}

/// Writes the oscillator's readouts of `opts` to `path` (the `osc.csv` format).
fn write_readouts(
    opts: &host_tests::oscillator::navigate::NavCompareOptions,
    path: &std::path::Path,
) -> Result<()> {
    use host_tests::oscillator::{file::OscCsvWriter, simulate_oscillator};
    let traj = opts.scenario.build()?;
    host_tests::atomic::write(path, |out| -> Result<()> {
        let mut w = OscCsvWriter::new(out)?;
        let mut failed = None;
        simulate_oscillator(traj.as_ref(), &opts.params, opts.seconds, |_, s, _| {
            if failed.is_none() {
                failed = w.write_sample(s).err();
            }
        })?;
        if let Some(e) = failed {
            return Err(e.into());
        }
        w.finish()?;
        Ok(())
    })
    .with_context(|| format!("writing {}", path.display()))
}

fn main() -> ExitCode {
    // Output piped into `head` ends the process as it ends `cat`'s, without a panic message.
    sigpipe::reset();
    // Ctrl-C or SIGTERM: no hidden partial output left beside `--out`.
    if let Err(e) = host_tests::atomic::remove_partial_outputs_on_interrupt() {
        eprintln!("error: cannot install the interrupt handler: {e}");
        return ExitCode::FAILURE;
    }
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Refuses an option of `nav align-bench` given with other than its default to a benchmark
/// that does not use it (it was ignored: `nav align-bench seed003 --seconds 5` ran the
/// default benchmark without a word), and a `--threads` the benchmarks do not run (0, or more
/// than [`host_tests::MAX_THREADS`]: they took 1 and 64).
fn refuse_unused_align_bench_options(command: &Command) -> Result<()> {
    let Command::AlignBench {
        which,
        runs,
        grade,
        threads,
        data,
        family_seed,
        seconds,
        member,
        ablate,
    } = command
    else {
        return Ok(());
    };
    use AlignBenchKind::{Family as F, Lasergyro as L, Seed002 as S2, Seed003 as S3};
    // (option, given with other than its default, the benchmarks that use it)
    let options: [(&str, bool, &[AlignBenchKind]); 8] = [
        ("--runs", *runs != 50, &[S2, S3, F]),
        (
            "--grade",
            *grade != host_tests::sensor_model::Grade::Fog,
            &[S2],
        ),
        ("--threads", *threads != 2, &[S3, F]),
        ("--data", data.is_some(), &[L]),
        ("--family-seed", *family_seed != 1, &[F]),
        (
            "--seconds",
            seconds.as_slice() != host_tests::align_bench::family::WINDOWS_S,
            &[F],
        ),
        ("--member", member.is_some(), &[F]),
        ("--ablate", !ablate.is_empty(), &[F]),
    ];
    for (name, given, kinds) in options {
        if !given {
            continue;
        }
        if !kinds.contains(which) {
            let names: Vec<String> = kinds
                .iter()
                .map(|k| format!("{k:?}").to_lowercase())
                .collect();
            anyhow::bail!(
                "{name} is an option of `nav align-bench {}`, not of `nav align-bench {}`",
                names.join("` and `nav align-bench "),
                format!("{which:?}").to_lowercase()
            );
        }
        // One member: its numbers alone, on one thread.
        if member.is_some() && ["--runs", "--threads"].contains(&name) {
            anyhow::bail!(
                "{name} is not an option of `nav align-bench family --member K` (one member's \
                 numbers, on one thread)"
            );
        }
    }
    check_monte_carlo(*runs, 1, *threads)
}

/// Refuses an option of `nav bench` given with other than its default to a measurement that
/// does not use it (it was ignored).
fn refuse_unused_bench_options(command: &Command) -> Result<()> {
    if let Command::Bench {
        what,
        passes,
        runs,
        threads,
        seconds,
        outage_seconds,
        dir,
        zero_motion,
        without,
        cells,
        blocks,
        first_seed,
        families,
    } = command
    {
        use BenchKind::{Consistency as C, Filter as F, Mechanization as M, Outages as O};
        // (option, given with other than its default, the measurements that use it)
        let options: [(&str, bool, &[BenchKind]); 12] = [
            ("--passes", *passes != 10, &[M]),
            (
                "--runs",
                runs.is_some(),
                &[C, O, BenchKind::Outliers, BenchKind::Gaps],
            ),
            ("--threads", *threads != 2, &[C, O]),
            ("--seconds", *seconds != 600.0, &[C]),
            (
                "--outage-seconds",
                *outage_seconds != host_tests::gnss_bench::OUTAGE_S,
                &[O],
            ),
            ("--dir", dir.is_some(), &[F]),
            ("--zero-motion", *zero_motion, &[C]),
            ("--without", !without.is_empty(), &[C]),
            ("--cells", !cells.is_empty(), &[C]),
            ("--blocks", *blocks, &[C]),
            (
                "--first-seed",
                *first_seed != 1,
                &[C, BenchKind::Outliers, BenchKind::Gaps],
            ),
            ("--families", *families != 1, &[C]),
        ];
        if let Some((name, _, kinds)) = options
            .iter()
            .find(|(_, given, kinds)| *given && !kinds.contains(what))
        {
            let names: Vec<String> = kinds
                .iter()
                .map(|k| format!("{k:?}").to_lowercase())
                .collect();
            anyhow::bail!(
                "{name} is an option of `nav bench {}`, not of `nav bench {}`",
                names.join("` and `nav bench "),
                format!("{what:?}").to_lowercase()
            );
        }
    }
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    refuse_unused_bench_options(&cli.command)?;
    refuse_unused_align_bench_options(&cli.command)?;
    match cli.command {
        Command::AlignBench {
            which,
            runs,
            grade,
            threads,
            data,
            family_seed,
            seconds,
            member,
            ablate,
        } => {
            use host_tests::align_bench::{family, lasergyro, seed002, seed003};
            let text = match which {
                AlignBenchKind::Seed002 => seed002::run(runs, grade)?,
                AlignBenchKind::Seed003 => seed003::run(runs, threads)?,
                AlignBenchKind::Lasergyro => {
                    lasergyro::run(&data.unwrap_or_else(lasergyro::default_path))?
                }
                AlignBenchKind::Family => {
                    let started = std::time::Instant::now();
                    let opts = family::FamilyOptions {
                        windows_s: seconds,
                        threads,
                        ablations: ablate,
                        ..family::FamilyOptions::new(family_seed, runs as u64)
                    };
                    let text = match member {
                        Some(k) => family::run_one(&opts, k)?,
                        None => family::run(&opts)?,
                    };
                    // On stderr: the tables stay deterministic.
                    eprintln!("run time {:.1} s", started.elapsed().as_secs_f64());
                    text
                }
            };
            print!("{text}");
            Ok(())
        }
        Command::Sim(args) => sim(*args),
        Command::Oscillator {
            scenario,
            seconds,
            grade,
            noise_m,
            f0_hz,
            seed_method,
            readouts,
        } => {
            use host_tests::oscillator::navigate::{NavCompareOptions, compare};
            let mut opts = NavCompareOptions::new(
                host_tests::trajectory::scenarios::Scenario::by_name(&scenario)?,
                seconds,
            );
            opts.grade = grade;
            opts.compensate = !seed_method;
            // Named by the options (the parameters' own names are no option's).
            let number = nav_core::number::Number;
            anyhow::ensure!(
                noise_m.is_finite() && noise_m >= 0.0,
                "--noise-m must be a finite number >= 0, not {}",
                number(noise_m)
            );
            let min_f0_hz = (1.0 / opts.params.drive_time_constant_s).max(MIN_SIMULATED_F0_HZ);
            anyhow::ensure!(
                f0_hz.is_finite() && f0_hz >= min_f0_hz,
                "--f0-hz must be at least {} Hz, not {}: below it the estimator does not lock on \
                 the simulated oscillator, even without readout noise (20 Hz gave no epoch in 30 \
                 s, 25 Hz noisy periods), and the amplitude drive averages over {} s, at least \
                 one period",
                number(min_f0_hz),
                number(f0_hz),
                number(opts.params.drive_time_constant_s)
            );
            opts.params.readout_noise_m = noise_m;
            opts.params.f0_hz = f0_hz;
            opts.params.sample_rate_hz = 50.0 * f0_hz;
            if let Some(path) = readouts {
                write_readouts(&opts, &path)?;
            }
            print!("{}", compare(&opts)?);
            Ok(())
        }
        Command::OscReplay {
            file,
            f0_hz,
            out,
            seed_method,
            precision,
        } => {
            use host_tests::oscillator::{file as osc_file, replay};
            // Read one row at a time, as the estimator goes.
            let rows = osc_file::open(&file)?;
            let run = move |w: Option<&mut dyn std::io::Write>| match precision {
                Precision::F32 => replay::replay_rows::<f32, _>(rows, f0_hz, !seed_method, w),
                Precision::F64 => replay::replay_rows::<f64, _>(rows, f0_hz, !seed_method, w),
            };
            // The reader's errors name the file and line; a write error names the output; the
            // estimator's own refusals (a time jump, no rate) name the readout file.
            let name = |e: anyhow::Error, out: Option<&Path>| match out {
                _ if e.is::<host_tests::text_error::TextError>() => e,
                Some(p) if e.is::<std::io::Error>() => {
                    e.context(format!("writing {}", p.display()))
                }
                _ => e.context(file.display().to_string()),
            };
            let summary = match &out {
                Some(p) => {
                    host_tests::atomic::refuse_same_file(&[&file], p)?;
                    let writing = || format!("writing {}", p.display());
                    let mut f = host_tests::atomic::AtomicFile::create(p).with_context(writing)?;
                    let summary = run(Some(f.writer())).map_err(|e| name(e, Some(p)))?;
                    f.commit().with_context(writing)?;
                    summary
                }
                None => run(None).map_err(|e| name(e, None))?,
            };
            print!("{summary}");
            Ok(())
        }
        Command::OscBench {
            seconds,
            noise_ratio,
        } => {
            use host_tests::oscillator::{OscillatorParams, bench};
            let params = OscillatorParams::default();
            let (by_ratio, by_noise) = bench::tables(&params, seconds, noise_ratio)?;
            print!("{}", bench::render(&by_ratio, &by_noise));
            // The same with damping and the amplitude-keeping drive (1e-9 m noise).
            let damped = OscillatorParams {
                damping_ratio: 1e-3,
                readout_noise_m: 1e-9,
                ..params
            };
            let traj = bench::coning_for(noise_ratio, params.f0_hz, seconds + 1.0);
            let d = bench::measure(&traj, &damped, seconds)?.compensated;
            println!("\n{}", bench::render_damped(&d, noise_ratio));
            Ok(())
        }
        Command::Emulate {
            truth,
            out,
            preset,
            errors,
            set,
            vertical,
            errors_out,
        } => {
            let job = host_tests::emulate::EmulateJob {
                truth: &truth,
                out: &out,
                preset,
                errors_file: errors.as_deref(),
                set: &set,
                options: host_tests::emulate::EmulatorOptions {
                    vertical,
                    ..Default::default()
                },
                errors_out: errors_out.as_deref(),
            };
            print!("{}", job.run()?);
            Ok(())
        }
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
        Command::Bench {
            what: BenchKind::Consistency,
            runs,
            threads,
            seconds,
            zero_motion,
            without,
            cells,
            blocks,
            first_seed,
            families,
            ..
        } => bench_consistency(
            runs.unwrap_or(60),
            threads,
            seconds,
            zero_motion,
            &ConsistencyChoice {
                without,
                cells,
                blocks,
                first_seed,
                families: families as usize,
            },
        ),
        Command::Bench {
            what: BenchKind::Filter,
            dir,
            ..
        } => bench_filter(dir),
        Command::Bench {
            what: BenchKind::Outages,
            runs,
            threads,
            outage_seconds,
            ..
        } => bench_outages(runs.unwrap_or(30), threads, outage_seconds),
        Command::Bench {
            what: BenchKind::Outliers,
            runs,
            first_seed,
            ..
        } => bench_outliers(runs.unwrap_or(1), first_seed),
        Command::Bench {
            what: BenchKind::Gaps,
            runs,
            first_seed,
            ..
        } => bench_gaps(runs.unwrap_or(10), first_seed),
        Command::Bench { passes, .. } => {
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
        Command::Convert {
            input,
            out,
            gnss: true,
            gnss_sigma,
            gnss_latency,
        } => {
            let (n, dropped) = host_tests::gnss_file::convert_at_epochs(
                &input,
                &out,
                gnss_sigma.assumed().as_ref(),
                gnss_latency,
            )?;
            let epochs = if gnss_latency > 0.0 {
                format!(
                    ", at their tags less a latency of {gnss_latency} s ({dropped} tagged before \
                     it left out)"
                )
            } else {
                String::new()
            };
            println!(
                "converted {} ({n} GNSS fixes{epochs}) to the binary fix file {}",
                input.display(),
                out.display()
            );
            Ok(())
        }
        Command::Convert {
            input,
            out,
            gnss: false,
            gnss_sigma,
            ..
        } => {
            anyhow::ensure!(
                gnss_sigma.assumed().is_none(),
                "--gnss-sigma is for a GNSS file (--gnss)"
            );
            // Streamed: memory independent of the file's length.
            let c = recording_io::convert(&input, &out)?;
            println!(
                "converted {} ({}, {} samples at {} Hz) to {}",
                input.display(),
                c.format,
                c.header.sample_count,
                c.header.rate_hz,
                out.display()
            );
            if let Some(w) = c.warning() {
                eprintln!("{w}");
            }
            Ok(())
        }
        Command::Report {
            solution,
            truth,
            at,
            plots,
        } => {
            let text = host_tests::report::report_files(&solution, &truth, &at, plots.as_deref())?;
            print!("{text}");
            Ok(())
        }
        Command::Replay(args) => replay(*args),
        Command::Decode(args) => host_tests::decode::run(&args),
        Command::Config(args) => host_tests::config_cmd::run(&args),
        Command::KfGins {
            config,
            out,
            imu_err,
            std,
            no_stops,
        } => {
            let started = std::time::Instant::now();
            let outputs = host_tests::kf_gins_run::Outputs {
                nav: out,
                imu_err,
                std,
            };
            let run =
                host_tests::kf_gins_run::run_with(&config, &outputs, !no_stops).map_err(|e| {
                    let label = format!("KF-GINS configuration {}", config.display());
                    host_tests::text_error::told_as(e, &config, label)
                })?;
            let seconds = started.elapsed().as_secs_f64();
            // On stderr, as convert's: the summary on stdout is the result.
            for w in &run.warnings {
                eprintln!("warning: {w}");
            }
            println!(
                "{}",
                host_tests::aided_cmd::summary(&run.report, run.rows, &config, &run.out)
            );
            for (what, path) in [("IMU errors", &run.imu_err), ("1-sigma", &run.std)] {
                if let Some(p) = path {
                    println!("{what}: {} ({} rows)", p.display(), run.rows);
                }
            }
            println!("IMU epochs before starttime: {}", run.before_start);
            if let Some(t) = run.stopped_after_end_s {
                println!(
                    "IMU file read up to endtime: the epochs from t = {t:.3} s on were not read"
                );
            }
            println!(
                "the filter's 1-sigma, RMS over the rows: horizontal {:.4} m, yaw {:.4} deg",
                run.sigma_rms.horizontal_m, run.sigma_rms.yaw_deg
            );
            let samples = run.report.samples as f64;
            println!(
                "speed: {:.0} IMU samples/s ({seconds:.3} s wall clock, text parsing and .nav writing included); {:.0} without the {:.3} s the disk took to store the file (sync and rename)",
                samples / seconds.max(1e-9),
                samples / (seconds - run.store_s).max(1e-9),
                run.store_s
            );
            Ok(())
        }
    }
}

fn print_summary(imu: &Path, out: &Path, precision: Precision, fr: &FileReport) {
    let p = match precision {
        Precision::F32 => "f32",
        Precision::F64 => "f64",
    };
    println!("{}", host_tests::replay::summary(imu, out, p, fr));
    if let Some(w) = fr.report.lost.warning() {
        println!("{w}");
    }
}
