//! `nav sim family`: one member of the alignment family ([`crate::trajectory::family`]) written
//! like any scenario of [`crate::simulate`]: `DIR/imu.bin` and/or `DIR/imu.csv`,
//! `DIR/truth.csv` (the IMU's truth) and `DIR/scenario.txt`, which lists every drawn value
//! (motion, lever arm, site, grade, biases, injector seed) and the `nav replay` command that
//! aligns on the recording as the benchmark's "lever arm given" case does.
//!
//! The member's own grade and biases make the sensor errors (its
//! [`FamilyMember::error_model`] seeded with its [`FamilyMember::injector_seed`]), so the
//! recording is the one `nav align-bench family` aligns on, rounded to the binary format's f32.

use crate::generate::TEMPERATURE_C;
use crate::recording_io::Recording;
use crate::sensor_model::ErrorInjector;
use crate::simulate::{Formats, SimFiles, Simulated};
use crate::trajectory::family::FamilyMember;
use crate::trajectory::{Generator, Sampling, generate};
use anyhow::{Context, Result, anyhow, bail, ensure};
use hal_adapters::recording::{Kind, Record};
use nav_core::alignment::AlignMethod;
use std::fmt::Write as _;
use std::path::Path;

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

impl Default for FamilySimOptions {
    /// The member's whole recording ([`crate::trajectory::family::FINAL_S`] at
    /// [`crate::trajectory::family::RATE_HZ`]), truth at 50 Hz, both formats.
    fn default() -> Self {
        Self {
            seconds: crate::trajectory::family::FINAL_S,
            rate_hz: crate::trajectory::family::RATE_HZ,
            truth_rate_hz: 50.0,
            formats: Formats::Both,
        }
    }
}

/// Simulates `member` in memory; `progress(done, total)` is called every 4096 samples.
pub fn simulate_member(
    member: &FamilyMember,
    opts: &FamilySimOptions,
    mut progress: impl FnMut(u64, u64),
) -> Result<Simulated> {
    ensure!(
        opts.rate_hz.is_finite() && opts.rate_hz > 0.0 && opts.rate_hz <= 100_000.0,
        "the rate must be within (0, 100000] Hz, not {}",
        opts.rate_hz
    );
    ensure!(
        opts.seconds.is_finite() && opts.seconds > 0.0,
        "the length must be positive, not {} s",
        opts.seconds
    );
    let every = (opts.rate_hz / opts.truth_rate_hz).round();
    ensure!(
        opts.truth_rate_hz > 0.0
            && every >= 1.0
            && (every * opts.truth_rate_hz - opts.rate_hz).abs() < 1e-9 * opts.rate_hz,
        "the truth rate {} Hz must divide the IMU rate {} Hz",
        opts.truth_rate_hz,
        opts.rate_hz
    );
    let every = every as u64;
    let sampling = Sampling::new(opts.rate_hz, opts.seconds);
    crate::simulate::check_sample_count(sampling, opts.seconds)?;
    member.rocking.check().context("the member's trajectory")?;
    let mut injector = ErrorInjector::new(member.error_model(), member.injector_seed)
        .map_err(|e| anyhow!("grade {}: {e}", member.grade))?;
    let traj = &member.rocking;
    let mut records = Vec::with_capacity(sampling.n as usize);
    let mut truth = vec![Generator::new(traj).truth()];
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
        }
        if k % 4096 == 0 {
            progress(k, sampling.n);
        }
    });
    progress(sampling.n, sampling.n);
    crate::simulate::checked(Simulated {
        recording: Recording {
            kind: Kind::Increments,
            rate_hz: opts.rate_hz,
            t0_ns: 0,
            records,
        },
        truth,
        counters: injector.counters(),
    })
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
    crate::simulate::write_files(dir, opts.formats, sim, &description)
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
    writeln!(s, "truth_rate_hz = {}", opts.truth_rate_hz)?;
    writeln!(s, "samples = {samples}")?;
    writeln!(s, "seconds = {}", samples as f64 / opts.rate_hz)?;
    writeln!(s, "gyro_saturated_samples = {}", c.gyro_saturated)?;
    writeln!(s, "accel_saturated_samples = {}", c.accel_saturated)?;
    writeln!(
        s,
        "# drawn values (the position is the centre of rotation's)"
    )?;
    s.push_str(&member.describe());
    writeln!(s, "# start (the IMU's truth at t = 0)")?;
    writeln!(s, "start_lat_deg = {}", start.lat.to_degrees())?;
    writeln!(s, "start_lon_deg = {}", start.lon.to_degrees())?;
    writeln!(s, "start_h_m = {}", start.h)?;
    writeln!(s, "start_roll_deg = {}", roll.to_degrees())?;
    writeln!(s, "start_pitch_deg = {}", pitch.to_degrees())?;
    writeln!(s, "start_yaw_deg = {}", yaw.to_degrees())?;
    let align_s = (samples as f64 / opts.rate_hz).min(crate::trajectory::family::FINAL_S);
    writeln!(
        s,
        "# replay: {}",
        member.replay_command(imu, align_s, AlignMethod::Fine)
    )?;
    writeln!(
        s,
        "# (--align-method inertial, sway or static the same way; without --lever-arm: the benchmark's \"not given\" case)"
    )?;
    Ok(s)
}
