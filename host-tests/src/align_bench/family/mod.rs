//! `nav align-bench family`: every alignment method on a seeded family of bases
//! ([`crate::trajectory::family`]), each result checked against the truth and against its own
//! 1-sigma.
//!
//! Per member: the exact increments of its trajectory over the longest window are generated
//! once, passed through the member's seeded [`ErrorInjector`], and for each window, method
//! ([`AlignMethod::ALL`]) and lever-arm case ([`LeverCase`]) nav-core's [`Aligner`] runs over
//! the window's prefix in f64 with what a user would tell it: the centre's position, the
//! grade's noise figures (bias 1-sigmas zeroed for a member without biases), and the lever arm
//! or not. A refused settings check ([`SettingsError`])
//! or a `FAILED` alignment is a refusal with its reason; an `ALIGNED` result is compared with
//! the IMU's truth at the end of the window's last sample:
//!
//! - roll, pitch and heading errors (estimate minus truth, wrapped) against the result's own
//!   1-sigma: an honest method has each `|error| <= 4 sigma` and an RMS of `error / sigma` near
//!   1 per axis;
//! - the heading error against the member's floor ([`heading_floor`]);
//! - the handed-over velocity (NED) and position (north, east, down metres from the truth)
//!   against their 1-sigma.
//!
//! The statistics and the tables are in [`report`].

pub mod report;

use super::seed003::crb_general;
use crate::sensor_model::ErrorInjector;
use crate::trajectory::family::{Ablation, FamilyMember, RATE_HZ};
use crate::trajectory::{Sampling, generate, wrap_pi};
use crate::truth::Truth;
use anyhow::{Result, anyhow, ensure};
use nav_core::alignment::machine::DEFAULT_LEVER_ARM_SIGMA_M;
use nav_core::alignment::{
    AlignMethod, AlignNote, AlignSettings, Aligner, BaseMotion, LeverArm, Progress, SettingsError,
    samples_for,
};
use nav_core::earth::{LocalEarth, OMEGA_IE, normal_gravity};
use nav_core::{ImuIncrement, Vector3, attitude};
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Default alignment windows [s].
pub const WINDOWS_S: [f64; 3] = [60.0, 120.0, 300.0];

/// What the user tells the alignment about the IMU's place.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LeverCase {
    /// The lever arm is given: [`LeverArm::Known`] (`--lever-arm X,Y,Z`).
    Given,
    /// It is not: [`LeverArm::Unknown`] with [`DEFAULT_LEVER_ARM_SIGMA_M`].
    NotGiven,
}

impl LeverCase {
    /// Both cases, in table order.
    pub const ALL: [LeverCase; 2] = [LeverCase::Given, LeverCase::NotGiven];

    /// The name in the tables.
    pub fn name(self) -> &'static str {
        match self {
            Self::Given => "given",
            Self::NotGiven => "not given",
        }
    }

    /// The settings' lever arm for a true lever arm `l_b_m` (body FRD) [m].
    pub fn lever_arm(self, l_b_m: Vector3<f64>) -> LeverArm<f64> {
        match self {
            Self::Given => LeverArm::Known(l_b_m),
            Self::NotGiven => LeverArm::Unknown {
                sigma_m: DEFAULT_LEVER_ARM_SIGMA_M,
            },
        }
    }
}

/// An `ALIGNED` result against the truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aligned {
    /// Roll, pitch, heading errors (estimate minus truth, wrapped to `(-pi, pi]`) [rad].
    pub error_rad: Vector3<f64>,
    /// The result's 1-sigma roll, pitch, heading [rad].
    pub sigma_rad: Vector3<f64>,
    /// Handed-over velocity minus the truth, NED [m/s].
    pub v_error_m_s: Vector3<f64>,
    /// Its 1-sigma, NED [m/s].
    pub v_sigma_m_s: Vector3<f64>,
    /// Handed-over position minus the truth, north, east, down [m].
    pub p_error_m: Vector3<f64>,
    /// Its 1-sigma, north, east, down [m].
    pub p_sigma_m: Vector3<f64>,
    /// The result's note.
    pub note: Option<AlignNote>,
}

impl Aligned {
    /// Roll, pitch, heading error over 1-sigma [-] (infinite where the sigma is 0 or not a
    /// number).
    pub fn attitude_z(&self) -> Vector3<f64> {
        normalised(&self.error_rad, &self.sigma_rad)
    }

    /// Velocity error over 1-sigma, NED [-].
    pub fn velocity_z(&self) -> Vector3<f64> {
        normalised(&self.v_error_m_s, &self.v_sigma_m_s)
    }

    /// Position error over 1-sigma, NED [-].
    pub fn position_z(&self) -> Vector3<f64> {
        normalised(&self.p_error_m, &self.p_sigma_m)
    }
}

/// `e / s` per axis, `inf` where `s` is not a positive number (an error without a sigma is
/// beyond any bound).
fn normalised(e: &Vector3<f64>, s: &Vector3<f64>) -> Vector3<f64> {
    Vector3::from_fn(|i, _| {
        if s[i] > 0.0 && s[i].is_finite() {
            e[i] / s[i]
        } else {
            f64::INFINITY
        }
    })
}

/// How one alignment ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// `ALIGNED`, compared with the truth.
    Aligned(Aligned),
    /// Refused (settings or `FAILED`), with the reason.
    Refused(String),
}

/// One alignment of one member.
#[derive(Clone, Debug, PartialEq)]
pub struct Case {
    /// The method.
    pub method: AlignMethod,
    /// Lever arm given or not.
    pub lever: LeverCase,
    /// Window [s].
    pub window_s: f64,
    /// Its end.
    pub outcome: Outcome,
}

/// Every alignment of one member.
#[derive(Clone, Debug, PartialEq)]
pub struct MemberRun {
    /// The member.
    pub member: FamilyMember,
    /// `(window [s], heading floor [rad])`, windows increasing.
    pub floors: Vec<(f64, f64)>,
    /// Its alignments: per window, per method, per lever case.
    pub cases: Vec<Case>,
}

impl MemberRun {
    /// The heading floor at `window_s` [s] [rad].
    pub fn floor_at(&self, window_s: f64) -> f64 {
        self.floors
            .iter()
            .find(|f| f.0 == window_s)
            .map_or(f64::NAN, |f| f.1)
    }
}

/// A member's sensed increments and the truth at the end of each window.
#[derive(Clone, Debug)]
pub struct Recorded {
    /// Sensed increments at [`RATE_HZ`] over the longest window.
    pub sensed: Vec<ImuIncrement<f64>>,
    /// `(samples of the window, truth at the end of its last sample)`, per window.
    pub truth: Vec<(u32, Truth)>,
}

impl Recorded {
    /// The truth at the end of the `samples`-th sample.
    pub fn truth_after(&self, samples: u32) -> Option<&Truth> {
        self.truth.iter().find(|t| t.0 == samples).map(|t| &t.1)
    }
}

/// The windows, checked (finite, at least one sample, at most the member's recording) and
/// sorted.
pub fn checked_windows(windows_s: &[f64]) -> Result<Vec<f64>> {
    ensure!(!windows_s.is_empty(), "no alignment window");
    let mut w = windows_s.to_vec();
    for &s in &w {
        ensure!(
            s.is_finite() && s * RATE_HZ >= 1.0 && s <= crate::trajectory::family::FINAL_S,
            "alignment windows must be within (0, {}] s, not {}",
            crate::trajectory::family::FINAL_S,
            nav_core::number::Number(s)
        );
    }
    w.sort_by(f64::total_cmp);
    w.dedup();
    Ok(w)
}

/// Generates `member`'s increments up to the longest of `windows_s` (sorted, checked), senses
/// them through its seeded error injector, and keeps the truth at the end of every window.
pub fn record(member: &FamilyMember, windows_s: &[f64]) -> Result<Recorded> {
    let samples: Vec<u32> = windows_s.iter().map(|&w| samples_for(w, RATE_HZ)).collect();
    let n = samples.iter().copied().max().unwrap_or(0);
    let mut injector = ErrorInjector::new(member.error_model(), member.injector_seed)
        .map_err(|e| anyhow!("member {}: {e}", member.index))?;
    let mut sensed = Vec::with_capacity(n as usize);
    let mut truth = Vec::with_capacity(samples.len());
    generate(
        &member.rocking,
        Sampling {
            rate_hz: RATE_HZ,
            n: u64::from(n),
        },
        |k, _, exact, t| {
            sensed.push(injector.apply(exact));
            let done = k as u32 + 1;
            if samples.contains(&done) {
                truth.push((done, *t));
            }
        },
    );
    Ok(Recorded { sensed, truth })
}

/// The heading floor [rad] of `member` at each of `windows_s` [s] (increasing): without biases,
/// the noise-only Cramér–Rao bound ([`crb_general`]); with them, that bound with the
/// unobservable biases' share added in quadrature, `sqrt(crb^2 + (b_g / (Omega cos lat))^2 +
/// (tan(lat) b_a / g)^2)` (an east gyro bias `b_g` reads as a heading error `b_g / W`; a north
/// accelerometer bias tilts the level by `b_a / g`, which gyrocompassing turns into `tan(lat)`
/// times that of heading; Groves §14.2.1, Titterton & Weston §10.2.1), with the grade's bias
/// 1-sigmas.
pub fn heading_floor(member: &FamilyMember, windows_s: &[f64]) -> Vec<f64> {
    let n = member.noise();
    let lat = member.lat_rad();
    let crb = crb_general(windows_s, n.arw_rad_per_sqrt_s, n.vrw_mps_per_sqrt_s, lat);
    let w = OMEGA_IE * lat.cos();
    let g = normal_gravity(lat, member.rocking.h_m);
    let bias2 = (n.gyro_bias_rad_s / w).powi(2) + (lat.tan() * n.accel_bias_mps2 / g).powi(2);
    crb.iter().map(|c| (c * c + bias2).sqrt()).collect()
}

/// Runs `method` with `lever` over the first `window_s` [s] of `rec` of `member`.
pub fn align(
    member: &FamilyMember,
    rec: &Recorded,
    method: AlignMethod,
    lever: LeverCase,
    window_s: f64,
) -> Outcome {
    let settings =
        match AlignSettings::new(method, member.position(), window_s, RATE_HZ, member.noise()) {
            Ok(s) => s
                .with_lever_arm(lever.lever_arm(member.lever_arm_b_m()))
                .with_base(BaseMotion::default()),
            Err(SettingsError::WindowTooShort { .. }) => {
                return Outcome::Refused("window too short".into());
            }
            Err(e) => return Outcome::Refused(format!("settings: {}", e.reason())),
        };
    if let Err(e) = settings.validate() {
        return Outcome::Refused(format!("settings: {}", e.reason()));
    }
    let Some(truth) = rec.truth_after(settings.samples) else {
        return Outcome::Refused("no truth at the window's end (harness)".into());
    };
    let mut aligner = Aligner::new(settings);
    let mut progress = Progress::Coarse;
    for inc in rec.sensed.iter().take(settings.samples as usize) {
        progress = aligner.add(inc);
        if matches!(progress, Progress::Failed(_)) {
            break;
        }
    }
    match progress {
        Progress::Aligned(o) => {
            let (roll, pitch, yaw) = attitude::euler(&o.estimate.q_b_n);
            let (roll_t, pitch_t, yaw_t) = attitude::euler(&truth.q_b_ned);
            let position = &o.state.position;
            Outcome::Aligned(Aligned {
                error_rad: Vector3::new(
                    wrap_pi(roll - roll_t),
                    pitch - pitch_t,
                    wrap_pi(yaw - yaw_t),
                ),
                sigma_rad: o.estimate.sigma_rad,
                v_error_m_s: o.state.ned().1 - truth.v_eb_ned,
                v_sigma_m_s: o.velocity_sigma_m_s,
                p_error_m: ned_error_m(
                    position.lat_f64(),
                    position.lon_f64(),
                    position.h_f64(),
                    truth,
                ),
                p_sigma_m: o.position_sigma_m,
                note: o.note,
            })
        }
        Progress::Failed(f) => Outcome::Refused(f.reason().to_string()),
        Progress::Coarse | Progress::Fine => Outcome::Refused(format!(
            "not finished after the window ({} increments refused)",
            aligner.refused()
        )),
    }
}

/// North, east, down metres from the truth's position to `(lat, lon)` [rad], `h` [m].
fn ned_error_m(lat: f64, lon: f64, h: f64, truth: &Truth) -> Vector3<f64> {
    let e = LocalEarth::new(truth.lat, truth.h);
    Vector3::new(
        (lat - truth.lat) * (e.r_meridian + truth.h),
        wrap_pi(lon - truth.lon) * (e.r_transverse + truth.h) * truth.lat.cos(),
        truth.h - h,
    )
}

/// Every alignment of `member` over `windows_s` [s] (checked and sorted by
/// [`checked_windows`]).
pub fn run_member(member: &FamilyMember, windows_s: &[f64]) -> Result<MemberRun> {
    let windows = checked_windows(windows_s)?;
    let rec = record(member, &windows)?;
    let floors = windows
        .iter()
        .copied()
        .zip(heading_floor(member, &windows))
        .collect();
    let mut cases = Vec::with_capacity(windows.len() * 8);
    for &window_s in &windows {
        for method in AlignMethod::ALL {
            for lever in LeverCase::ALL {
                cases.push(Case {
                    method,
                    lever,
                    window_s,
                    outcome: align(member, &rec, method, lever, window_s),
                });
            }
        }
    }
    Ok(MemberRun {
        member: member.clone(),
        floors,
        cases,
    })
}

/// What [`run_family`] runs.
#[derive(Clone, Debug, PartialEq)]
pub struct FamilyOptions {
    /// The family's seed.
    pub family_seed: u64,
    /// The members' numbers.
    pub members: Range<u64>,
    /// Alignment windows [s].
    pub windows_s: Vec<f64>,
    /// Worker threads.
    pub threads: usize,
    /// Parts of every member switched off ([`FamilyMember::ablated`]; diagnosis).
    pub ablations: Vec<Ablation>,
}

impl FamilyOptions {
    /// Members `0..members` of family `family_seed` over [`WINDOWS_S`] on 2 threads, as drawn.
    pub fn new(family_seed: u64, members: u64) -> Self {
        Self {
            family_seed,
            members: 0..members,
            windows_s: WINDOWS_S.to_vec(),
            threads: 2,
            ablations: Vec::new(),
        }
    }

    /// Member `index` as these options make it.
    pub fn member(&self, index: u64) -> FamilyMember {
        FamilyMember::draw(self.family_seed, index).ablated(&self.ablations)
    }
}

/// Runs the members of `opts`, each over its windows, on its threads (each takes the next
/// member not yet taken); in member order, whatever the threads.
pub fn run_family(opts: &FamilyOptions) -> Result<Vec<MemberRun>> {
    let windows = checked_windows(&opts.windows_s)?;
    let threads = opts.threads.clamp(1, crate::MAX_THREADS);
    let all: Vec<u64> = opts.members.clone().collect();
    let next = AtomicUsize::new(0);
    let results: Vec<Result<Vec<MemberRun>>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                let (all, windows, next) = (&all, &windows, &next);
                s.spawn(move || {
                    let mut mine = Vec::new();
                    while let Some(&i) = all.get(next.fetch_add(1, Ordering::Relaxed)) {
                        mine.push(run_member(&opts.member(i), windows)?);
                    }
                    Ok(mine)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err(anyhow!("a family thread panicked")))
            })
            .collect()
    });
    let mut runs = Vec::with_capacity(all.len());
    for r in results {
        runs.extend(r?);
    }
    runs.sort_by_key(|r| r.member.index);
    Ok(runs)
}

/// The benchmark's tables of `opts`.
pub fn run(opts: &FamilyOptions) -> Result<String> {
    ensure!(!opts.members.is_empty(), "no members to run");
    let runs = run_family(opts)?;
    Ok(report::format_summary(&report::summarize(
        opts.family_seed,
        &runs,
    )))
}

/// Every method's numbers on member `index` as `opts` make it (debugging).
pub fn run_one(opts: &FamilyOptions, index: u64) -> Result<String> {
    let run = run_member(&opts.member(index), &opts.windows_s)?;
    Ok(report::format_member(&run))
}
