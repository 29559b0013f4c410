//! `nav sim family`: one member of the alignment family ([`crate::trajectory::family`]) written
//! like any scenario of [`crate::simulate`]: `DIR/imu.bin` and/or `DIR/imu.csv`,
//! `DIR/truth.csv` (the IMU's truth) and `DIR/scenario.txt`, which lists every drawn value
//! (motion, lever arm, site, grade, biases, injector seed) and the `nav replay` command that
//! aligns on the recording as the benchmark's "lever arm given" case does.
//!
//! The member's own grade and biases make the sensor errors (its
//! [`FamilyMember::error_model`] seeded with its [`FamilyMember::injector_seed`]), so the
//! recording is the one `nav align-bench family` aligns on, rounded to the binary format's f32.

use crate::sensor_model::ErrorInjector;
use crate::simulate::{Formats, SimFiles, Simulated};
use crate::trajectory::family::FamilyMember;
use anyhow::{Context, Result, anyhow, bail};
use nav_core::alignment::AlignMethod;
use std::fmt::Write as _;
use std::path::Path;

/// The scenario name `nav sim` takes for a member of the alignment family.
pub const SCENARIO_NAME: &str = "family";

/// Every scenario name `nav sim` takes: the trajectory scenarios'
/// ([`crate::trajectory::scenarios::Scenario::NAMES`]) and the family's ([`SCENARIO_NAME`]).
pub fn sim_scenario_names() -> Vec<&'static str> {
    let mut names = crate::trajectory::scenarios::Scenario::NAMES.to_vec();
    names.push(SCENARIO_NAME);
    names
}

/// What to write of a member.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FamilySimOptions {
    /// Length [s].
    pub seconds: f64,
    /// IMU rate [Hz].
    pub rate_hz: f64,
    /// Truth output rate [Hz] (must divide `rate_hz`).
    pub truth_rate_hz: f64,
    /// Recording files.
    pub formats: Formats,
}

/// Seconds of the recording left after the replay line's alignment window, so that the run
/// navigates (a replay whose alignment takes every sample fails: nothing was navigated).
pub const NAVIGATE_AFTER_S: f64 = 10.0;

impl Default for FamilySimOptions {
    /// The benchmark's longest window ([`crate::trajectory::family::FINAL_S`]) and
    /// [`NAVIGATE_AFTER_S`] more at [`crate::trajectory::family::RATE_HZ`], truth at 50 Hz,
    /// both formats.
    fn default() -> Self {
        Self {
            seconds: crate::trajectory::family::FINAL_S + NAVIGATE_AFTER_S,
            rate_hz: crate::trajectory::family::RATE_HZ,
            truth_rate_hz: 50.0,
            formats: Formats::Both,
        }
    }
}

/// The alignment window [s] of the replay line for a recording of `seconds` [s]: all but the
/// last [`NAVIGATE_AFTER_S`], at most the benchmark's longest window; `None` when that is
/// shorter than `fine`'s minimum.
pub fn replay_window_s(seconds: f64) -> Option<f64> {
    let align_s = (seconds - NAVIGATE_AFTER_S).min(crate::trajectory::family::FINAL_S);
    (align_s >= AlignMethod::Fine.min_seconds()).then_some(align_s)
}

/// Simulates `member` in memory; `progress(done, total)` is called every 4096 samples.
pub fn simulate_member(
    member: &FamilyMember,
    opts: &FamilySimOptions,
    progress: impl FnMut(u64, u64),
) -> Result<Simulated> {
    let (sampling, every) = crate::simulate::plan(opts.rate_hz, opts.truth_rate_hz, opts.seconds)?;
    member.rocking.check().context("the member's trajectory")?;
    member
        .rocking
        .check_periods(opts.rate_hz)
        .context("the member's trajectory")?;
    let injector = ErrorInjector::new(member.error_model(), member.injector_seed)
        .map_err(|e| anyhow!("grade {}: {e}", member.grade))?;
    crate::simulate::sense(&member.rocking, sampling, every, injector, progress)
}

/// Writes `sim` of `member` into `dir` (created if missing), as [`crate::simulate::write`]
/// does.
pub fn write_member(
    dir: &Path,
    member: &FamilyMember,
    opts: &FamilySimOptions,
    sim: &Simulated,
) -> Result<SimFiles> {
    let replay_file = if opts.formats != Formats::Csv {
        dir.join("imu.bin")
    } else {
        dir.join("imu.csv")
    };
    let description = describe_member(member, opts, sim, &replay_file)?;
    crate::simulate::write_files(dir, opts.formats, sim, &description, None)
}

/// The `scenario.txt` text of `member`.
pub fn describe_member(
    member: &FamilyMember,
    opts: &FamilySimOptions,
    sim: &Simulated,
    imu: &Path,
) -> Result<String> {
    let Some(start) = sim.truth.first() else {
        bail!("no truth");
    };
    let samples = sim.recording.records.len();
    let (roll, pitch, yaw) = nav_core::attitude::euler(&start.q_b_ned);
    let c = &sim.counters;
    let mut s = String::new();
    writeln!(
        s,
        "# nav sim family: member {} of alignment family {} (a still or swaying base, the IMU at a lever arm)",
        member.index, member.family_seed
    )?;
    writeln!(s, "scenario = family")?;
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
    writeln!(
        s,
        "# drawn values (lat_deg, lon_deg, h_m: the centre of rotation; given_*: as surveyed, what the alignment is told)"
    )?;
    s.push_str(&member.describe());
    writeln!(s, "# start (the IMU's truth at t = 0)")?;
    writeln!(s, "start_lat_deg = {}", start.lat.to_degrees())?;
    writeln!(s, "start_lon_deg = {}", start.lon.to_degrees())?;
    writeln!(s, "start_h_m = {}", start.h)?;
    writeln!(s, "start_roll_deg = {}", roll.to_degrees())?;
    writeln!(s, "start_pitch_deg = {}", pitch.to_degrees())?;
    writeln!(s, "start_yaw_deg = {}", yaw.to_degrees())?;
    match replay_window_s(samples as f64 / opts.rate_hz) {
        Some(align_s) => writeln!(
            s,
            "# replay: {}",
            member.replay_command(imu, align_s, AlignMethod::Fine)
        )?,
        None => writeln!(
            s,
            "# replay: none: {:.1} s is shorter than fine's {} s minimum window and {NAVIGATE_AFTER_S} s of navigation after it",
            samples as f64 / opts.rate_hz,
            AlignMethod::Fine.min_seconds()
        )?,
    }
    writeln!(
        s,
        "# (--align-method inertial, sway or static the same way; without --lever-arm: the benchmark's \"not given\" case)"
    )?;
    Ok(s)
}
