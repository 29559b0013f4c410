//! `nav sim`: a scenario's exact increments ([`crate::trajectory`]) through a sensor error model
//! ([`crate::sensor_model`]) into files.
//!
//! `DIR/imu.bin` (the binary recording the firmware replays) and/or `DIR/imu.csv` (the CSV
//! recording format), `DIR/truth.csv` (the truth at `truth_rate_hz`), and `DIR/scenario.txt`
//! (`key = value` lines: scenario, grade, seed, rates, parameters, the start, and the `nav
//! replay` command that navigates the recording). Same options and seed: the same files, byte
//! for byte.
//!
//! Parameters are checked by the scenario ([`Scenario::build`]: speeds, heights, lever arms
//! within physical ranges), a length giving no sample is refused, and, independently, every
//! truth row and IMU record is checked before the first file is written
//! ([`crate::output_check`]): a refused run leaves nothing new in `DIR`.

use crate::recording_io::{self, Recording};
use crate::sensor_model::{ErrorInjector, Grade, InjectorCounters};
use crate::simulate_family::NAVIGATE_AFTER_S;
use crate::trajectory::scenarios::{LandVehicle, Scenario};
use crate::trajectory::{Sampling, generate};
use crate::truth::Truth;
use crate::{generate::TEMPERATURE_C, imu_csv, truth_csv};
use anyhow::{Context, Result, bail, ensure};
use hal_adapters::recording::{Kind, Record};
use nav_core::alignment::AlignMethod;
use nav_core::number::{Number, Rounded};
use std::fmt::Write as _;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Which recording files to write.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Formats {
    /// `imu.bin` only.
    Binary,
    /// `imu.csv` only.
    Csv,
    /// Both.
    #[default]
    Both,
}

/// What to simulate.
#[derive(Clone, Debug, PartialEq)]
pub struct SimOptions {
    /// The scenario with its parameters.
    pub scenario: Scenario,
    /// Sensor grade.
    pub grade: Grade,
    /// Length [s]; `None`: the scenario's own.
    pub seconds: Option<f64>,
    /// IMU rate [Hz].
    pub rate_hz: f64,
    /// Truth output rate [Hz] (must divide `rate_hz`).
    pub truth_rate_hz: f64,
    /// Seed of every random draw.
    pub seed: u64,
    /// Recording files.
    pub formats: Formats,
}

impl SimOptions {
    /// Defaults: 400 Hz, truth at 50 Hz, seed 1, both formats.
    pub fn new(scenario: Scenario, grade: Grade) -> Self {
        Self {
            scenario,
            grade,
            seconds: None,
            rate_hz: 400.0,
            truth_rate_hz: 50.0,
            seed: 1,
            formats: Formats::Both,
        }
    }
}

/// A simulated run in memory.
#[derive(Clone, Debug)]
pub struct Simulated {
    /// The sensed recording (increments, `f32`).
    pub recording: Recording,
    /// Truth at the start and at the end of every `truth_every`-th sample.
    pub truth: Vec<Truth>,
    /// What the sensor model did.
    pub counters: InjectorCounters,
    /// The sensors' in-run biases at each truth row (the injector's state after the row's
    /// last sample).
    pub in_run_biases: Vec<InRunBiases>,
}

/// The simulated sensors' in-run bias parts at one instant: Gauss–Markov and rate random walk,
/// gyros [rad/s] and accelerometers [m/s^2] (the turn-on and fixed biases are constants).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InRunBiases {
    /// Gyro Gauss–Markov bias [rad/s].
    pub gyro_gm: nav_core::Vector3<f64>,
    /// Gyro rate-random-walk bias [rad/s].
    pub gyro_rw: nav_core::Vector3<f64>,
    /// Accelerometer Gauss–Markov bias [m/s^2].
    pub accel_gm: nav_core::Vector3<f64>,
    /// Accelerometer random-walk bias [m/s^2].
    pub accel_rw: nav_core::Vector3<f64>,
}

impl InRunBiases {
    fn of(injector: &ErrorInjector) -> Self {
        let (g, a) = (injector.gyro_state(), injector.accel_state());
        Self {
            gyro_gm: g.gm_bias,
            gyro_rw: g.rw_bias,
            accel_gm: a.gm_bias,
            accel_rw: a.rw_bias,
        }
    }
}

/// Runs the simulation in memory; `progress(done, total)` is called every 4096 samples.
pub fn simulate(opts: &SimOptions, progress: impl FnMut(u64, u64)) -> Result<Simulated> {
    let traj = opts.scenario.build()?;
    let seconds = opts.seconds.unwrap_or(traj.duration_s());
    let (sampling, every) = plan(opts.rate_hz, opts.truth_rate_hz, seconds)?;
    opts.scenario.check_periods(opts.rate_hz)?;
    let injector = ErrorInjector::new(opts.grade.model(), opts.seed)
        .map_err(|e| anyhow::anyhow!("grade {}: {e}", opts.grade))?;
    sense(traj.as_ref(), sampling, every, injector, progress)
}

/// The sampling of `seconds` [s] at `rate_hz` [Hz] and the number of samples between truth
/// rows at `truth_rate_hz` [Hz], or why the three do not make a run.
pub(crate) fn plan(rate_hz: f64, truth_rate_hz: f64, seconds: f64) -> Result<(Sampling, u64)> {
    crate::generate::check_rate(rate_hz)?;
    let every = (rate_hz / truth_rate_hz).round();
    ensure!(
        truth_rate_hz > 0.0
            && every >= 1.0
            && (every * truth_rate_hz - rate_hz).abs() < 1e-9 * rate_hz,
        "the truth rate {} Hz must divide the IMU rate {} Hz",
        Number(truth_rate_hz),
        Number(rate_hz)
    );
    ensure!(
        seconds.is_finite() && seconds > 0.0,
        "the length must be positive, not {} s",
        Number(seconds)
    );
    let sampling = Sampling::new(rate_hz, seconds);
    check_sample_count(sampling, seconds)?;
    // Truth rows at the start and after every `every` samples: 1e-300 Hz or a run of 0.004 s
    // wrote a truth of its start alone, which no report can compare with.
    let every_text = if every < 1e15 {
        format!("{every}")
    } else {
        Rounded(every).to_string()
    };
    ensure!(
        every <= sampling.n as f64,
        "{} s at {} Hz gives {} samples, fewer than the {} between truth rows at {} Hz: the \
         truth needs at least 2 rows (the start and one more), so the run must be at least {} s \
         or the truth rate higher",
        Number(seconds),
        Number(rate_hz),
        sampling.n,
        every_text,
        Number(truth_rate_hz),
        Rounded(every / rate_hz)
    );
    Ok((sampling, every as u64))
}

/// `traj` sampled by `sampling`, sensed through `injector`, with a truth row at the start and
/// every `every` samples, checked as its readers would ([`checked`]); `progress(done, total)`
/// every 4096 samples.
pub(crate) fn sense(
    traj: &dyn crate::trajectory::Trajectory,
    sampling: Sampling,
    every: u64,
    mut injector: ErrorInjector,
    mut progress: impl FnMut(u64, u64),
) -> Result<Simulated> {
    let mut records = Vec::with_capacity(sampling.n as usize);
    let mut truth = vec![crate::trajectory::Generator::new(traj).truth()];
    let mut in_run_biases = vec![InRunBiases::of(&injector)];
    generate(traj, sampling, |k, t_ns, exact, t| {
        let sensed = injector.apply(exact);
        let f32s = |v: &nav_core::Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
        records.push(Record {
            t_ns,
            gyro: f32s(&sensed.delta_theta_ib_b),
            accel: f32s(&sensed.delta_v_ib_b),
            temperature_c: TEMPERATURE_C,
        });
        if (k + 1) % every == 0 {
            truth.push(*t);
            in_run_biases.push(InRunBiases::of(&injector));
        }
        if k % 4096 == 0 {
            progress(k, sampling.n);
        }
    });
    progress(sampling.n, sampling.n);
    checked(Simulated {
        recording: Recording {
            kind: Kind::Increments,
            rate_hz: sampling.rate_hz,
            t0_ns: 0,
            records,
        },
        truth,
        counters: injector.counters(),
        in_run_biases,
    })
}

/// Most samples a simulated recording holds (it is built in memory, 40 bytes a record: 2 GB;
/// 34 h at 400 Hz), well within the binary format's `u32` count.
pub const MAX_SAMPLES: f64 = 5e7;

/// Refuses a length that gives fewer than 2 samples (a recording of one was written, and every
/// reader refused it: its rate is told from its intervals), or more than [`MAX_SAMPLES`].
pub(crate) fn check_sample_count(sampling: Sampling, seconds: f64) -> Result<()> {
    // From the product itself: `sampling.n` saturates at u64::MAX.
    let n = (seconds * sampling.rate_hz).round();
    ensure!(
        n >= 2.0,
        "{} s at {} Hz gives {}: a recording needs at least 2 samples",
        Number(seconds),
        Number(sampling.rate_hz),
        if n < 1.0 { "no sample" } else { "1 sample" }
    );
    ensure!(
        n <= MAX_SAMPLES,
        "{} s at {} Hz is {} samples: a simulated recording holds at most {} ({} h at this rate)",
        Number(seconds),
        Number(sampling.rate_hz),
        Rounded(n),
        Rounded(MAX_SAMPLES),
        Rounded(MAX_SAMPLES / sampling.rate_hz / 3600.0)
    );
    Ok(())
}

/// `sim` if every truth row and IMU record is one its readers accept
/// ([`crate::output_check`]): a trajectory that left the Earth model's range (a latitude
/// beyond a pole, a value that overflowed) is refused before anything is written.
pub(crate) fn checked(sim: Simulated) -> Result<Simulated> {
    let refuse = |e: crate::output_check::RowError| {
        anyhow::anyhow!("the simulated run is not a valid recording, nothing written: {e}")
    };
    crate::output_check::check_truth("truth row", &sim.truth).map_err(refuse)?;
    crate::output_check::check_records(sim.recording.t0_ns, &sim.recording.records)
        .map_err(refuse)?;
    Ok(sim)
}

/// The files written by [`write`].
#[derive(Clone, Debug)]
pub struct SimFiles {
    /// `imu.bin`, if written.
    pub binary: Option<PathBuf>,
    /// `imu.csv`, if written.
    pub csv: Option<PathBuf>,
    /// `truth.csv`.
    pub truth: PathBuf,
    /// `scenario.txt`.
    pub description: PathBuf,
    /// An earlier run's files that this run did not write, removed ([`earlier_run_files`]).
    pub removed: Vec<PathBuf>,
}

/// Writes `sim` of `opts` into `dir` (created if missing). Every file's content is made
/// before the first is written, and each is written whole or not at all ([`crate::atomic`]).
pub fn write(dir: &Path, opts: &SimOptions, sim: &Simulated) -> Result<SimFiles> {
    write_with_receiver(dir, opts, sim, None)
}

/// The simulated receiver's part of a `nav sim` output: its settings (the text to add to
/// `scenario.txt`, and the `nav replay` options that read its fixes) and its fixes (written
/// as `gnss.csv` and `gnss.bin`).
#[derive(Clone, Copy, Debug)]
pub struct ReceiverOutput<'a> {
    /// The settings' text.
    pub text: &'a str,
    /// The `nav replay` options that read the fixes.
    pub replay_options: &'a str,
    /// The fixes.
    pub fixes: &'a [crate::gnss::GnssFix],
}

/// [`write`], with the simulated receiver's settings at the end of `scenario.txt`, its replay
/// line taking the fixes, and the fixes, all in the one set written whole or not at all.
pub fn write_with_receiver(
    dir: &Path,
    opts: &SimOptions,
    sim: &Simulated,
    receiver: Option<ReceiverOutput<'_>>,
) -> Result<SimFiles> {
    let replay_file = if opts.formats != Formats::Csv {
        dir.join("imu.bin")
    } else {
        dir.join("imu.csv")
    };
    let mut description = describe(opts, sim, &replay_file)?;
    if receiver.is_none() {
        // A start in motion needs the fixes.
        let bias_deg_h = opts.grade.noise_spec().gyro_bias_rad_s.to_degrees() * 3600.0;
        description = description
            .lines()
            .map(|l| match l.starts_with("# replay: nav replay") && l.contains(" --start-in-motion") {
                true => format!(
                    "# replay: none: a {} part's gyro bias ({bias_deg_h:.1} deg/h) hides the Earth rate, so it cannot find north at rest; simulate GNSS fixes (--gnss-rate) to start in motion\n",
                    opts.grade
                ),
                false => format!("{l}\n"),
            })
            .collect();
    }
    if let Some(ReceiverOutput {
        text,
        replay_options,
        ..
    }) = receiver
    {
        const END: &str = " --out solution.csv";
        description = description
            .lines()
            .map(|l| match l.strip_suffix(END) {
                Some(head) if l.starts_with("# replay: nav replay") => {
                    format!("{head} {replay_options}{END}\n")
                }
                _ => format!("{l}\n"),
            })
            .collect();
        description.push_str(text);
    }
    write_files(
        dir,
        opts.formats,
        sim,
        &description,
        receiver.map(|r| r.fixes),
    )
}

/// Refuses an output folder `dir` that is something other than a folder (an existing file
/// gave "creating FILE: File exists (os error 17)"): `nav sim` writes a set of files. Refuses
/// as well a folder holding a file of [`SIM_FILE_NAMES`] that an earlier `nav sim` did not
/// write ([`earlier_run_files`]): the run would replace or remove it.
pub fn check_out_dir(dir: &Path) -> Result<()> {
    check_is_folder(dir)?;
    earlier_run_files(dir)?;
    Ok(())
}

/// The first half of [`check_out_dir`]: `dir` is a folder or is missing.
fn check_is_folder(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!(
            "--out {} is a file: nav sim writes a folder of files (imu.bin or imu.csv, \
             truth.csv, scenario.txt, and gnss.csv and gnss.bin with --gnss-rate); give a \
             folder's path (created if missing)",
            dir.display()
        );
    }
    Ok(())
}

/// Writes the recording(s) of `sim` as `formats` asks, `truth.csv`, `scenario.txt` (the
/// text `description`) and the receiver's `fixes` (`gnss.csv`, `gnss.bin`) into `dir`
/// (created if missing), as one set written whole or not at all ([`crate::atomic::FileSet`]).
pub(crate) fn write_files(
    dir: &Path,
    formats: Formats,
    sim: &Simulated,
    description: &str,
    fixes: Option<&[crate::gnss::GnssFix]>,
) -> Result<SimFiles> {
    let binary = dir.join("imu.bin");
    let csv = dir.join("imu.csv");
    let want_bin = formats != Formats::Csv;
    let want_csv = formats != Formats::Binary;
    let r = &sim.recording;
    let csv_rows = if want_csv { Some(r.to_csv()?) } else { None };
    check_is_folder(dir)?;
    // Before this run's scenario.txt replaces the one that shows whose they are.
    let earlier = earlier_run_files(dir)?;
    fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut names = vec!["truth.csv", "scenario.txt"];
    names.extend(want_bin.then_some("imu.bin"));
    names.extend(want_csv.then_some("imu.csv"));
    if fixes.is_some() {
        names.extend(["gnss.csv", "gnss.bin"]);
    }
    let set = crate::atomic::FileSet::new(dir, &names)
        .with_context(|| format!("writing into {}", dir.display()))?;
    // Every name was given to the set above.
    let staged = |name: &str| set.staged(name).unwrap_or_else(|| dir.join(name));
    if want_bin {
        recording_io::write_binary(&staged("imu.bin"), r.kind, r.rate_hz, r.t0_ns, &r.records)?;
    }
    if let Some(rows) = &csv_rows {
        imu_csv::write(&staged("imu.csv"), rows)?;
    }
    truth_csv::write(&staged("truth.csv"), &sim.truth)?;
    let description_path = staged("scenario.txt");
    crate::atomic::write(&description_path, |w| w.write_all(description.as_bytes()))
        .with_context(|| format!("writing {}", description_path.display()))?;
    if let Some(fixes) = fixes {
        crate::gnss::write_gnss_csv(&staged("gnss.csv"), fixes)?;
        crate::gnss_file::write_record_file(&staged("gnss.bin"), fixes)?;
    }
    set.commit()
        .with_context(|| format!("writing into {}", dir.display()))?;
    let stale: Vec<PathBuf> = earlier
        .into_iter()
        .filter(|p| !names.iter().any(|n| dir.join(n) == *p))
        .collect();
    let removed = remove_stale(&stale)?;
    let truth = dir.join("truth.csv");
    let description_path = dir.join("scenario.txt");
    Ok(SimFiles {
        binary: want_bin.then_some(binary),
        csv: want_csv.then_some(csv),
        truth,
        description: description_path,
        removed,
    })
}

/// The files `nav sim` writes into its output directory: the recordings, the truth, the
/// description and the simulated receiver's fixes.
pub const SIM_FILE_NAMES: [&str; 6] = [
    "imu.bin",
    "imu.csv",
    "truth.csv",
    "scenario.txt",
    "gnss.csv",
    "gnss.bin",
];

/// The first line of every `scenario.txt` that `nav sim` writes (a family member's goes on
/// `" family: ..."`).
pub const SCENARIO_MARK: &str = "# nav sim";

/// The files of [`SIM_FILE_NAMES`] in `dir`, each one an earlier `nav sim` run's, or an error
/// naming the first that is not provably one: `dir` must hold a `scenario.txt` whose first
/// line is [`SCENARIO_MARK`], and each other file must begin as `nav sim` writes it (the
/// binary formats' magic, the CSV files' header). A user's own `gnss.csv` or `imu.csv` in the
/// folder was removed as "an earlier run's". What is not a regular file is not listed (never
/// removed; [`crate::atomic::FileSet`] refuses to write over it).
pub fn earlier_run_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut found = Vec::new();
    for name in SIM_FILE_NAMES {
        let path = dir.join(name);
        // Through a symbolic link, as the set's writer goes; a FIFO is never opened.
        if fs::metadata(&path).is_ok_and(|m| m.is_file()) {
            found.push((name, path));
        }
    }
    if found.is_empty() {
        return Ok(Vec::new());
    }
    let refuse = |path: &Path, why: &str| {
        anyhow::anyhow!(
            "--out {}: {} was not written by nav sim ({why}), and this run would replace or \
             remove it; choose an empty folder, or move the file away",
            dir.display(),
            path.display()
        )
    };
    let scenario = dir.join("scenario.txt");
    if !found.iter().any(|(name, _)| *name == "scenario.txt") {
        let (_, path) = &found[0];
        return Err(refuse(
            path,
            "no scenario.txt of an earlier nav sim run beside it",
        ));
    }
    for (name, path) in &found {
        let mark = match *name {
            "scenario.txt" => SCENARIO_MARK.to_owned(),
            "imu.bin" => String::from_utf8_lossy(&hal_adapters::recording::MAGIC).into_owned(),
            "gnss.bin" => String::from_utf8_lossy(&hal_adapters::gnss_record::MAGIC).into_owned(),
            "imu.csv" => imu_csv::COLUMNS.join(","),
            "gnss.csv" => crate::gnss::CSV_COLUMNS.join(","),
            _ => nav_core::output::CSV_HEADER.to_owned(),
        };
        let mut head = vec![0_u8; mark.len()];
        let read =
            fs::File::open(path).and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head));
        if read.is_err() || head != mark.as_bytes() {
            let why = if path == &scenario {
                format!("its first line is not \"{SCENARIO_MARK} ...\"")
            } else {
                format!("it does not begin as nav sim's {name} does")
            };
            return Err(refuse(path, &why));
        }
    }
    Ok(found.into_iter().map(|(_, path)| path).collect())
}

/// Removes the earlier run's files `stale` ([`earlier_run_files`]) that this run did not
/// write, and returns them: an earlier run's `imu.csv` or `gnss.csv` left beside this run's
/// truth made a set that looked whole (`nav sim static --format bin` into the directory of a
/// `land-vehicle --gnss-rate 1` run kept the car's CSV recording and fixes). Called after
/// this run's files are written, so a failed run leaves the earlier set as it was.
fn remove_stale(stale: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut removed = Vec::new();
    for path in stale {
        match fs::remove_file(path) {
            Ok(()) => removed.push(path.clone()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => {
                return Err(e)
                    .with_context(|| format!("removing {} (an earlier run's)", path.display()));
            }
        }
    }
    Ok(removed)
}

/// The `scenario.txt` text.
pub fn describe(opts: &SimOptions, sim: &Simulated, imu: &Path) -> Result<String> {
    let Some(start) = sim.truth.first() else {
        bail!("no truth");
    };
    let mut s = String::new();
    let mut scenario = opts.scenario.clone();
    let samples = sim.recording.records.len();
    let (roll, pitch, yaw) = nav_core::attitude::euler(&start.q_b_ned);
    let c = &sim.counters;
    writeln!(
        s,
        "# nav sim: exact increments of a scenario through a sensor error model"
    )?;
    writeln!(s, "scenario = {}", scenario.name())?;
    writeln!(s, "grade = {}", opts.grade)?;
    writeln!(s, "seed = {}", opts.seed)?;
    writeln!(s, "rate_hz = {}", opts.rate_hz)?;
    writeln!(
        s,
        "truth_rate_hz = {}",
        nav_core::number::Number(opts.truth_rate_hz)
    )?;
    writeln!(s, "samples = {samples}")?;
    writeln!(s, "seconds = {}", samples as f64 / opts.rate_hz)?;
    writeln!(s, "gyro_saturated_samples = {}", c.gyro_saturated)?;
    writeln!(s, "accel_saturated_samples = {}", c.accel_saturated)?;
    writeln!(s, "# parameters")?;
    let seconds = samples as f64 / opts.rate_hz;
    for (key, value, doc) in scenario.describe() {
        match opts.seconds {
            // The recording's length, not the scenario's default.
            Some(given) if key == "seconds" => writeln!(
                s,
                "{key} = {given}  # {doc} (--seconds; the scenario's own is {value})"
            )?,
            _ => writeln!(s, "{key} = {value}  # {doc}")?,
        }
    }
    writeln!(s, "# start (truth at t = 0)")?;
    writeln!(s, "start_lat_deg = {}", start.lat.to_degrees())?;
    writeln!(s, "start_lon_deg = {}", start.lon.to_degrees())?;
    writeln!(s, "start_h_m = {}", start.h)?;
    writeln!(s, "start_roll_deg = {}", roll.to_degrees())?;
    writeln!(s, "start_pitch_deg = {}", pitch.to_degrees())?;
    writeln!(s, "start_yaw_deg = {}", yaw.to_degrees())?;
    let hint = ReplayHint::of(&opts.scenario, opts.grade);
    let window_s = hint.window_s(&opts.scenario, seconds);
    let bias_deg_h = opts.grade.noise_spec().gyro_bias_rad_s.to_degrees() * 3600.0;
    let moves = still_at_start_s(&opts.scenario).is_some();
    if !hint.finds_north && moves {
        // Its GNSS options are added where the fixes are written; without fixes, none.
        writeln!(
            s,
            "# replay: nav replay --imu {} --start-in-motion --imu-noise {} --out solution.csv",
            imu.display(),
            opts.grade
        )?;
    } else if !hint.finds_north {
        writeln!(
            s,
            "# replay: none: a {} part's gyro bias ({bias_deg_h:.1} deg/h) hides the Earth rate, so it cannot find north at rest, and this scenario does not move for a start in motion",
            opts.grade
        )?;
    } else if window_s >= hint.shortest_s {
        writeln!(
            s,
            "# replay: nav replay --imu {} --lat {} --lon {} --h {} --align-seconds {window_s}{} --out solution.csv",
            imu.display(),
            start.lat.to_degrees(),
            start.lon.to_degrees(),
            start.h,
            hint.options
        )?;
    } else {
        writeln!(
            s,
            "# replay: none: {seconds:.1} s leave a {window_s} s alignment window ({}{NAVIGATE_AFTER_S} s kept to navigate), shorter than the {} s the {} method needs here",
            match still_at_start_s(&opts.scenario) {
                Some(still_s) => format!("at rest for the first {still_s} s, "),
                None => String::new(),
            },
            hint.shortest_s,
            hint.method.name()
        )?;
    }
    Ok(s)
}

/// Rest kept between a replay hint's alignment window and the first motion [s].
pub const REST_MARGIN_S: f64 = 5.0;

/// How long `scenario` is at rest from its start [s] before it moves (`None`: at rest, or in
/// a motion its hint's method aligns in, throughout).
fn still_at_start_s(scenario: &Scenario) -> Option<f64> {
    match scenario {
        Scenario::LandVehicle(_) => Some(LandVehicle::START_S),
        Scenario::Flight(f) => Some(f.still_s),
        Scenario::Static(_) | Scenario::ShipRocking(_) | Scenario::AuvBench(_) => None,
    }
}

/// The alignment of a scenario's `nav replay` hint.
struct ReplayHint {
    method: AlignMethod,
    /// The options after `--align-seconds`.
    options: String,
    /// Longest window [s].
    longest_s: f64,
    /// Shortest window that aligns on this scenario [s].
    shortest_s: f64,
    /// The grade's gyros can find north at rest: their bias 1-sigma within a tenth of the
    /// Earth rate (a tenth of a radian of heading at most; MEMS parts' are tens of deg/h).
    finds_north: bool,
}

impl ReplayHint {
    /// The method that suits `scenario`: a rocking ship needs the inertial-frame method, its
    /// lever arm and 120 s (shorter windows leak too much heading through the heave); the AUV
    /// bench the fine method, whose north finding needs gyros of the grade's (an ideal
    /// sensor's noise assumed as FOG's: the default, the board's ADIS16505, is too coarse).
    fn of(scenario: &Scenario, grade: Grade) -> Self {
        let (method, mut options, longest_s, shortest_s) = match scenario {
            Scenario::ShipRocking(r) => {
                let [x, y, z] = r.lever_arm_m;
                (
                    AlignMethod::Inertial,
                    format!(" --align-method inertial --lever-arm {x},{y},{z}"),
                    120.0,
                    120.0,
                )
            }
            Scenario::AuvBench(_) => (
                AlignMethod::Fine,
                " --align-method fine".to_owned(),
                60.0,
                AlignMethod::Fine.min_seconds(),
            ),
            _ => (
                AlignMethod::Static,
                String::new(),
                60.0,
                AlignMethod::Static.min_seconds(),
            ),
        };
        match grade {
            // A zero noise model refuses every real scatter: the device default instead.
            Grade::Ideal if method == AlignMethod::Fine => options += " --imu-noise fog",
            Grade::Ideal => {}
            g => options += &format!(" --imu-noise {g}"),
        }
        Self {
            method,
            options,
            longest_s,
            shortest_s,
            finds_north: grade.noise_spec().gyro_bias_rad_s < 0.1 * nav_core::earth::OMEGA_IE,
        }
    }

    /// The window for a recording of `seconds` [s] of `scenario`, whole seconds: at most
    /// `longest_s`, ending [`REST_MARGIN_S`] before the first motion (a static alignment
    /// refuses a moving base), with [`NAVIGATE_AFTER_S`] left to navigate.
    fn window_s(&self, scenario: &Scenario, seconds: f64) -> f64 {
        let rest_s = still_at_start_s(scenario).map_or(f64::INFINITY, |s| s - REST_MARGIN_S);
        self.longest_s
            .min(rest_s)
            .min(seconds - NAVIGATE_AFTER_S)
            .floor()
            .max(0.0)
    }
}
