//! A seeded family of alignment bases: still, or swaying about a mean attitude, the IMU at a
//! lever arm from the centre of rotation, at random sites, with random sensor grades and biases
//! — the kind of recordings an independent tester aligns on (`nav sim family`, `nav align-bench
//! family`).
//!
//! [`FamilyMember::draw`]`(family_seed, index)` draws member `index` of family `family_seed`
//! from its own ChaCha8 stream (seed bytes: `family_seed`, `index`, a tag; uniforms from the
//! stream's 64-bit words with plain arithmetic), so a member is the same on every platform and
//! does not depend on the other members. Its trajectory is a [`Rocking`] (harmonic roll, pitch
//! and yaw about a mean attitude, harmonic surge, sway and heave of the centre, the IMU at the
//! lever arm; exact derivatives through jets), [`FINAL_S`] long at [`RATE_HZ`].
//!
//! # Ranges (all uniform unless said otherwise; angles in degrees)
//!
//! | quantity | range |
//! |---|---|
//! | base | still with probability [`STILL_PROBABILITY`] (no rotation and no translation at all), else swaying |
//! | latitude / longitude / height of the centre | [`LATITUDE_DEG`] / [`LONGITUDE_DEG`] / [`HEIGHT_M`] m |
//! | mean heading | [`HEADING_DEG`] |
//! | mean roll, mean pitch (still members too) | each [`MEAN_TILT_DEG`] |
//! | roll amplitude / period | [`ROLL_AMP_DEG`] / [`ROLL_PERIOD_S`] s |
//! | pitch amplitude / period | [`PITCH_AMP_DEG`] / [`PITCH_PERIOD_S`] s |
//! | yaw amplitude / period (about the mean heading) | [`YAW_AMP_DEG`] / [`YAW_PERIOD_S`] s |
//! | phases of every harmonic | [`PHASE_DEG`] |
//! | heave of the centre (up) amplitude / period | [`HEAVE_AMP_M`] m / [`HEAVE_PERIOD_S`] s |
//! | surge (along the mean heading) and sway (across) of the centre, each, in [`SURGE_PROBABILITY`] of the swaying members | [`SURGE_AMP_M`] m / [`SURGE_PERIOD_S`] s |
//! | lever arm (IMU from the centre, body FRD) | length [`LEVER_ARM_M`] m, direction uniform on the sphere; still members too |
//! | grade | `fog` [`FOG_SHARE`], `rlg` [`RLG_SHARE`], `mems-tactical` the rest |
//! | turn-on biases | drawn by the grade's error model for half ([`BIAS_PROBABILITY`]) of the `fog` and `rlg` members, for every `mems-tactical` one |
//! | error-injector seed | a 64-bit word of the stream |
//!
//! Incommensurate periods: the roll, pitch and yaw periods are drawn again (all three) while
//! the ratio of two of them is within [`RESONANCE_TOLERANCE`] of a ratio `p/q` of small
//! integers (`p, q <= `[`RESONANCE_MAX_TERM`]), at most [`MAX_PERIOD_DRAWS`] times; a swaying
//! base whose angles repeat together is a special case an estimator could exploit or trip on.
//! The translation periods are free.
//!
//! The given position is the centre's as surveyed ([`FamilyMember::position`]): the centre plus
//! a survey error drawn per north, east and down axis from a normal distribution of the
//! alignment's default site 1-sigma ([`BaseMotion::position_sigma_m`], 0.1 m), as a user's
//! surveyed point is never exact (without it, every hand-over position would look several
//! times better than its 1-sigma). The IMU is at `C_b_n l` from the centre, so even a still
//! member's IMU is up to 10 m away from the position the user types. The truth (attitude,
//! velocity, position) is the IMU's.
//!
//! Draw order (fixed, whatever the base): still, latitude, longitude, height, heading, mean
//! roll, mean pitch, lever length, lever direction (z, azimuth), grade, biases, injector seed,
//! then amplitude and phase of roll, pitch, yaw, heave, surge, sway, their periods (heave,
//! surge, sway), the rotation periods with their redraws, whether the centre surges and sways,
//! and last the survey error (north, east, down). A still member draws the
//! same values and sets the amplitudes to 0, so its site, lever arm and grade are those it
//! would have had swaying.

use super::scenarios::{Displacement, Harmonic, Rocking, Translation};
use crate::pipeline::sensor_noise;
use crate::sensor_model::{Grade, ImuErrorModel};
use nav_core::alignment::{AlignMethod, BaseMotion, SensorNoise};
use nav_core::{Position, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::fmt::Write as _;
use std::path::Path;

/// A closed interval `[lo, hi]` of a uniform draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

impl Span {
    const fn new(lo: f64, hi: f64) -> Self {
        Self { lo, hi }
    }

    fn draw(&self, rng: &mut ChaCha8Rng) -> f64 {
        self.lo + (self.hi - self.lo) * unit(rng)
    }
}

/// IMU rate of every member [Hz].
pub const RATE_HZ: f64 = 400.0;
/// Length of a member's recording [s] (the longest alignment window of the benchmark).
pub const FINAL_S: f64 = 300.0;
/// Probability of a still base.
pub const STILL_PROBABILITY: f64 = 0.25;
/// Latitude of the centre [deg].
pub const LATITUDE_DEG: Span = Span::new(-60.0, 60.0);
/// Longitude of the centre [deg].
pub const LONGITUDE_DEG: Span = Span::new(-180.0, 180.0);
/// Ellipsoidal height of the centre [m].
pub const HEIGHT_M: Span = Span::new(-10.0, 100.0);
/// Mean heading [deg].
pub const HEADING_DEG: Span = Span::new(0.0, 360.0);
/// Mean roll and mean pitch, each [deg].
pub const MEAN_TILT_DEG: Span = Span::new(-3.0, 3.0);
/// Roll amplitude [deg].
pub const ROLL_AMP_DEG: Span = Span::new(1.0, 6.0);
/// Roll period [s].
pub const ROLL_PERIOD_S: Span = Span::new(5.0, 16.0);
/// Pitch amplitude [deg].
pub const PITCH_AMP_DEG: Span = Span::new(0.5, 3.0);
/// Pitch period [s].
pub const PITCH_PERIOD_S: Span = Span::new(4.0, 12.0);
/// Yaw amplitude about the mean heading [deg].
pub const YAW_AMP_DEG: Span = Span::new(0.0, 1.5);
/// Yaw period [s].
pub const YAW_PERIOD_S: Span = Span::new(8.0, 40.0);
/// Phase of every harmonic [deg].
pub const PHASE_DEG: Span = Span::new(0.0, 360.0);
/// Heave amplitude of the centre [m].
pub const HEAVE_AMP_M: Span = Span::new(0.0, 0.6);
/// Heave period [s].
pub const HEAVE_PERIOD_S: Span = Span::new(5.0, 12.0);
/// Surge and sway amplitude of the centre, each [m].
pub const SURGE_AMP_M: Span = Span::new(0.0, 0.2);
/// Surge and sway period, each [s].
pub const SURGE_PERIOD_S: Span = Span::new(5.0, 14.0);
/// Probability that a swaying member's centre surges and sways (the others only heave: a
/// moored or large vessel; the tester's family had none).
pub const SURGE_PROBABILITY: f64 = 0.5;
/// Length of the lever arm [m].
pub const LEVER_ARM_M: Span = Span::new(0.0, 10.0);
/// Share of `fog` members.
pub const FOG_SHARE: f64 = 0.55;
/// Share of `rlg` members (the rest, 10 %, are `mems-tactical`).
pub const RLG_SHARE: f64 = 0.35;
/// Probability that a `fog` or `rlg` member has its turn-on biases.
pub const BIAS_PROBABILITY: f64 = 0.5;
/// Relative distance of two rotation periods' ratio from a small-integer ratio below which the
/// periods are drawn again.
pub const RESONANCE_TOLERANCE: f64 = 0.02;
/// Largest numerator and denominator of the ratios avoided.
pub const RESONANCE_MAX_TERM: u32 = 4;
/// Most draws of the rotation periods (the last one is kept).
pub const MAX_PERIOD_DRAWS: u32 = 1000;

/// A uniform draw in `[0, 1)` from the top 53 bits of a 64-bit word.
fn unit(rng: &mut ChaCha8Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Whether `a / b` is within [`RESONANCE_TOLERANCE`] of some `p / q`, `p, q <=`
/// [`RESONANCE_MAX_TERM`].
pub fn near_resonance(a: f64, b: f64) -> bool {
    let r = a / b;
    (1..=RESONANCE_MAX_TERM).any(|p| {
        (1..=RESONANCE_MAX_TERM)
            .any(|q| (r * f64::from(q) / f64::from(p) - 1.0).abs() < RESONANCE_TOLERANCE)
    })
}

/// One drawn base.
#[derive(Clone, Debug, PartialEq)]
pub struct FamilyMember {
    /// The family's seed.
    pub family_seed: u64,
    /// The member's number in the family.
    pub index: u64,
    /// No motion at all (else swaying).
    pub still: bool,
    /// The trajectory: centre's site, mean heading and attitude, harmonics, translation, lever
    /// arm.
    pub rocking: Rocking,
    /// Sensor grade.
    pub grade: Grade,
    /// Whether the grade's turn-on biases are drawn (else the sensors have white noise only).
    pub biases: bool,
    /// Seed of the member's [`crate::sensor_model::ErrorInjector`].
    pub injector_seed: u64,
    /// How many times the rotation periods were drawn (1: the first draw was incommensurate).
    pub period_draws: u32,
    /// Error of the given (surveyed) position from the centre's, north, east, down [m].
    pub survey_error_m: [f64; 3],
    /// What was switched off after the draw ([`Self::ablated`]; empty: the member as drawn).
    pub ablations: Vec<Ablation>,
}

/// A part of a member switched off after the draw, to find which part of the motion or of the
/// sensors a method trips on (`--ablate`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Ablation {
    /// No translation of the centre (surge, sway, heave amplitudes 0).
    Translation,
    /// No surge and sway of the centre (its horizontal translation); the heave stays.
    SurgeSway,
    /// The IMU on the centre (lever arm 0).
    LeverArm,
    /// No turn-on or fixed biases (and none assumed), whatever the grade; a bias instability
    /// (`mems-tactical`) stays, and is assumed.
    Biases,
    /// No yaw oscillation.
    Yaw,
    /// No rotation at all (roll, pitch and yaw amplitudes 0; a translation stays).
    Rotation,
    /// Mean roll and pitch 0.
    MeanTilt,
}

impl Ablation {
    /// Every ablation.
    pub const ALL: [Ablation; 7] = [
        Ablation::Translation,
        Ablation::SurgeSway,
        Ablation::LeverArm,
        Ablation::Biases,
        Ablation::Yaw,
        Ablation::Rotation,
        Ablation::MeanTilt,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Translation => "translation",
            Self::SurgeSway => "surge-sway",
            Self::LeverArm => "lever-arm",
            Self::Biases => "biases",
            Self::Yaw => "yaw",
            Self::Rotation => "rotation",
            Self::MeanTilt => "mean-tilt",
        }
    }

    /// The ablation called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|a| a.name() == name)
    }
}

impl FamilyMember {
    /// Member `index` of family `family_seed` (module docs: ranges and draw order).
    pub fn draw(family_seed: u64, index: u64) -> Self {
        let mut seed = [0u8; 32];
        seed[..8].copy_from_slice(&family_seed.to_le_bytes());
        seed[8..16].copy_from_slice(&index.to_le_bytes());
        seed[16..24].copy_from_slice(b"alignfam");
        let rng = &mut ChaCha8Rng::from_seed(seed);
        let still = unit(rng) < STILL_PROBABILITY;
        let lat_deg = LATITUDE_DEG.draw(rng);
        let lon_deg = LONGITUDE_DEG.draw(rng);
        let h_m = HEIGHT_M.draw(rng);
        let heading_deg = HEADING_DEG.draw(rng);
        let mean_roll_deg = MEAN_TILT_DEG.draw(rng);
        let mean_pitch_deg = MEAN_TILT_DEG.draw(rng);
        let lever_arm_m = lever_arm(rng);
        let u = unit(rng);
        let grade = if u < FOG_SHARE {
            Grade::Fog
        } else if u < FOG_SHARE + RLG_SHARE {
            Grade::Rlg
        } else {
            Grade::MemsTactical
        };
        let biases = unit(rng) < BIAS_PROBABILITY || grade == Grade::MemsTactical;
        let injector_seed = rng.next_u64();
        let mut harmonic = |amp: Span| Harmonic {
            amp_deg: amp.draw(rng),
            period_s: 0.0,
            phase_deg: PHASE_DEG.draw(rng),
        };
        let (mut roll, mut pitch, mut yaw) = (
            harmonic(ROLL_AMP_DEG),
            harmonic(PITCH_AMP_DEG),
            harmonic(YAW_AMP_DEG),
        );
        let mut displacement = |amp: Span| Displacement {
            amp_m: amp.draw(rng),
            period_s: 0.0,
            phase_deg: PHASE_DEG.draw(rng),
        };
        let mut translation = Translation {
            heave: displacement(HEAVE_AMP_M),
            surge: displacement(SURGE_AMP_M),
            sway: displacement(SURGE_AMP_M),
        };
        translation.heave.period_s = HEAVE_PERIOD_S.draw(rng);
        translation.surge.period_s = SURGE_PERIOD_S.draw(rng);
        translation.sway.period_s = SURGE_PERIOD_S.draw(rng);
        let mut period_draws = 0;
        while period_draws < MAX_PERIOD_DRAWS {
            period_draws += 1;
            roll.period_s = ROLL_PERIOD_S.draw(rng);
            pitch.period_s = PITCH_PERIOD_S.draw(rng);
            yaw.period_s = YAW_PERIOD_S.draw(rng);
            let (r, p, y) = (roll.period_s, pitch.period_s, yaw.period_s);
            if !(near_resonance(r, p) || near_resonance(r, y) || near_resonance(p, y)) {
                break;
            }
        }
        // Drawn after the others, so that the draws above do not depend on it.
        if unit(rng) >= SURGE_PROBABILITY {
            translation.surge.amp_m = 0.0;
            translation.sway.amp_m = 0.0;
        }
        let survey = BaseMotion::<f64>::default().position_sigma_m;
        let survey_error_m: [f64; 3] = core::array::from_fn(|_| {
            let z: f64 = StandardNormal.sample(&mut *rng);
            survey * z
        });
        if still {
            for h in [&mut roll, &mut pitch, &mut yaw] {
                h.amp_deg = 0.0;
            }
            translation = Translation {
                surge: Displacement {
                    amp_m: 0.0,
                    ..translation.surge
                },
                sway: Displacement {
                    amp_m: 0.0,
                    ..translation.sway
                },
                heave: Displacement {
                    amp_m: 0.0,
                    ..translation.heave
                },
            };
        }
        let rocking = Rocking {
            lat_deg,
            lon_deg,
            h_m,
            heading_deg,
            roll,
            pitch,
            yaw,
            lever_arm_m,
            speed_mps: 0.0,
            mean_roll_deg,
            mean_pitch_deg,
            translation,
            rock_until_s: f64::INFINITY,
            seconds: FINAL_S,
        };
        Self {
            family_seed,
            index,
            still,
            rocking,
            grade,
            biases,
            injector_seed,
            period_draws,
            survey_error_m,
            ablations: Vec::new(),
        }
    }

    /// The same member with `ablations` switched off (the draw itself is unchanged).
    pub fn ablated(mut self, ablations: &[Ablation]) -> Self {
        let r = &mut self.rocking;
        for &a in ablations {
            match a {
                Ablation::Translation => {
                    for d in [
                        &mut r.translation.surge,
                        &mut r.translation.sway,
                        &mut r.translation.heave,
                    ] {
                        d.amp_m = 0.0;
                    }
                }
                Ablation::SurgeSway => {
                    r.translation.surge.amp_m = 0.0;
                    r.translation.sway.amp_m = 0.0;
                }
                Ablation::LeverArm => r.lever_arm_m = [0.0; 3],
                Ablation::Biases => self.biases = false,
                Ablation::Yaw => r.yaw.amp_deg = 0.0,
                Ablation::Rotation => {
                    for h in [&mut r.roll, &mut r.pitch, &mut r.yaw] {
                        h.amp_deg = 0.0;
                    }
                }
                Ablation::MeanTilt => {
                    r.mean_roll_deg = 0.0;
                    r.mean_pitch_deg = 0.0;
                }
            }
            if !self.ablations.contains(&a) {
                self.ablations.push(a);
            }
        }
        self
    }

    /// The sensor error model: the grade's, without its turn-on and fixed biases unless
    /// [`Self::biases`].
    pub fn error_model(&self) -> ImuErrorModel {
        let mut m = self.grade.model();
        if !self.biases {
            for t in [&mut m.gyro, &mut m.accel] {
                t.turn_on_bias_sigma = Vector3::zeros();
                t.bias = Vector3::zeros();
            }
        }
        m
    }

    /// What the user tells the alignment about the IMU: the grade's noise figures
    /// (`--imu-noise GRADE`), the bias 1-sigmas zeroed for a member without biases
    /// (`--bias-prior 0`; a grade's bias instability, which no member of the family lacks,
    /// stays: only an ablated `mems-tactical` member has one without turn-on biases).
    pub fn noise(&self) -> SensorNoise<f64> {
        let mut n = sensor_noise::<f64>(&self.grade.noise_spec());
        if !self.biases {
            let m = self.grade.model();
            n.gyro_bias_rad_s = m.gyro.bias_instability.sigma;
            n.accel_bias_mps2 = m.accel.bias_instability.sigma;
        }
        n
    }

    /// The IMU's lever arm from the centre, body FRD [m].
    pub fn lever_arm_b_m(&self) -> Vector3<f64> {
        Vector3::from(self.rocking.lever_arm_m)
    }

    /// The given position: the centre's as surveyed (module docs).
    pub fn position(&self) -> Position {
        self.centre().offset_ned(self.survey_error_m)
    }

    /// The centre's true position.
    pub fn centre(&self) -> Position {
        let r = &self.rocking;
        Position::from_degrees(r.lat_deg, r.lon_deg, r.h_m)
    }

    /// Latitude of the centre [rad].
    pub fn lat_rad(&self) -> f64 {
        self.rocking.lat_deg.to_radians()
    }

    /// The member's class.
    pub fn category(&self) -> Category {
        Category {
            still: self.still,
            grade: self.grade,
            biases: self.biases,
        }
    }

    /// `key = value  # doc` lines of every drawn value.
    pub fn describe(&self) -> String {
        let r = &self.rocking;
        let t = &r.translation;
        let l = self.lever_arm_b_m();
        let mut s = String::new();
        let mut line = |key: &str, value: String, doc: &str| {
            let _ = writeln!(s, "{key} = {value}  # {doc}");
        };
        line("family_seed", self.family_seed.to_string(), "the family");
        line("member", self.index.to_string(), "the member's number");
        if !self.ablations.is_empty() {
            let names: Vec<&str> = self.ablations.iter().map(|a| a.name()).collect();
            line("ablated", names.join(","), "switched off after the draw");
        }
        line("base", self.category().base().into(), "still or sway");
        line("grade", self.grade.name().into(), "sensor grade");
        line(
            "biases",
            u8::from(self.biases).to_string(),
            "turn-on biases drawn (1) or white noise only (0)",
        );
        line(
            "injector_seed",
            self.injector_seed.to_string(),
            "seed of the sensor errors",
        );
        line(
            "lat_deg",
            r.lat_deg.to_string(),
            "latitude of the centre [deg]",
        );
        line(
            "lon_deg",
            r.lon_deg.to_string(),
            "longitude of the centre [deg]",
        );
        line("h_m", r.h_m.to_string(), "height of the centre [m]");
        line(
            "heading_deg",
            r.heading_deg.to_string(),
            "mean heading [deg]",
        );
        line(
            "mean_roll_deg",
            r.mean_roll_deg.to_string(),
            "mean roll [deg]",
        );
        line(
            "mean_pitch_deg",
            r.mean_pitch_deg.to_string(),
            "mean pitch [deg]",
        );
        for (name, h) in [("roll", r.roll), ("pitch", r.pitch), ("yaw", r.yaw)] {
            line(
                &format!("{name}_amp_deg"),
                h.amp_deg.to_string(),
                "amplitude [deg]",
            );
            line(
                &format!("{name}_period_s"),
                h.period_s.to_string(),
                "period [s]",
            );
            line(
                &format!("{name}_phase_deg"),
                h.phase_deg.to_string(),
                "phase [deg]",
            );
        }
        line(
            "period_draws",
            self.period_draws.to_string(),
            "draws of the rotation periods",
        );
        for (name, d, doc) in [
            ("heave", t.heave, "up"),
            ("surge", t.surge, "along the mean heading"),
            ("sway", t.sway, "across the mean heading, to starboard"),
        ] {
            line(
                &format!("{name}_amp_m"),
                d.amp_m.to_string(),
                &format!("centre {doc}: amplitude [m]"),
            );
            line(
                &format!("{name}_period_s"),
                d.period_s.to_string(),
                "period [s]",
            );
            line(
                &format!("{name}_phase_deg"),
                d.phase_deg.to_string(),
                "phase [deg]",
            );
        }
        line(
            "lever_x_m",
            l.x.to_string(),
            "IMU from the centre, forward [m]",
        );
        line(
            "lever_y_m",
            l.y.to_string(),
            "IMU from the centre, right [m]",
        );
        line(
            "lever_z_m",
            l.z.to_string(),
            "IMU from the centre, down [m]",
        );
        line("lever_m", l.norm().to_string(), "lever-arm length [m]");
        for (k, axis) in ["n", "e", "d"].into_iter().enumerate() {
            line(
                &format!("survey_{axis}_m"),
                self.survey_error_m[k].to_string(),
                "given position less the centre's [m]",
            );
        }
        let given = self.position();
        for (name, v, doc) in [
            (
                "given_lat_deg",
                given.lat_f64().to_degrees(),
                "given latitude [deg]",
            ),
            (
                "given_lon_deg",
                given.lon_f64().to_degrees(),
                "given longitude [deg]",
            ),
            ("given_h_m", given.h_f64(), "given height [m]"),
        ] {
            line(name, v.to_string(), doc);
        }
        s
    }

    /// The `nav replay` command that aligns on this member's recording `imu` over
    /// `align_seconds` [s] with `method`, telling it what the benchmark's "lever arm given" case
    /// does: the given (surveyed) position, the grade's noise, whether to assume biases, the
    /// lever arm.
    pub fn replay_command(&self, imu: &Path, align_seconds: f64, method: AlignMethod) -> String {
        let [x, y, z] = self.rocking.lever_arm_m;
        let given = self.position();
        format!(
            "nav replay --imu {} --lat {} --lon {} --h {} --align-seconds {align_seconds} --align-method {} --imu-noise {} --bias-prior {} --lever-arm {x},{y},{z} --out solution.csv",
            imu.display(),
            given.lat_f64().to_degrees(),
            given.lon_f64().to_degrees(),
            given.h_f64(),
            method.name(),
            self.grade.name(),
            u8::from(self.biases),
        )
    }
}

/// A lever arm of uniform length in [`LEVER_ARM_M`] and uniform direction (body FRD) [m].
fn lever_arm(rng: &mut ChaCha8Rng) -> [f64; 3] {
    let length = LEVER_ARM_M.draw(rng);
    let z = Span::new(-1.0, 1.0).draw(rng);
    let (s, c) = Span::new(0.0, core::f64::consts::TAU).draw(rng).sin_cos();
    let rho = (1.0 - z * z).max(0.0).sqrt();
    [length * rho * c, length * rho * s, length * z]
}

/// What kind of member: base, grade, biases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Category {
    /// Still base (else swaying).
    pub still: bool,
    /// Sensor grade.
    pub grade: Grade,
    /// Turn-on biases on.
    pub biases: bool,
}

impl Category {
    /// `still` or `sway`.
    pub fn base(&self) -> &'static str {
        if self.still { "still" } else { "sway" }
    }
}

impl core::fmt::Display for Category {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let b = if self.biases { "+bias" } else { "" };
        write!(f, "{} {}{b}", self.base(), self.grade.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::{Generator, Sampling, Trajectory, generate};

    #[test]
    fn draws_are_reproducible_and_within_the_ranges() {
        let mut still = 0;
        let mut grades = [0usize; 3];
        let mut survey_sq = 0.0;
        for i in 0..400 {
            let m = FamilyMember::draw(7, i);
            assert_eq!(m, FamilyMember::draw(7, i));
            assert_ne!(m, FamilyMember::draw(8, i));
            let r = &m.rocking;
            // Every member passes the scenario checks `nav sim family` applies.
            r.check().unwrap();
            let within = |v: f64, s: Span| v >= s.lo && v <= s.hi;
            assert!(within(r.lat_deg, LATITUDE_DEG) && within(r.h_m, HEIGHT_M));
            survey_sq += m.survey_error_m.iter().map(|e| e * e).sum::<f64>();
            // The given position is the centre's moved by the survey error.
            let (given, centre) = (m.position(), m.centre());
            let back = given.offset_ned(m.survey_error_m.map(|e| -e));
            assert!((back.lat_f64() - centre.lat_f64()).abs() < 1e-12);
            assert!((given.h_f64() - centre.h_f64() + m.survey_error_m[2]).abs() < 1e-9);
            assert!(within(m.lever_arm_b_m().norm(), LEVER_ARM_M));
            assert!(within(r.mean_roll_deg, MEAN_TILT_DEG));
            assert!(within(r.roll.period_s, ROLL_PERIOD_S));
            assert!(within(r.yaw.period_s, YAW_PERIOD_S));
            if m.still {
                still += 1;
                assert!(!r.translation.is_moving() && r.roll.amp_deg == 0.0);
                assert_eq!(m.clone().ablated(&[Ablation::Rotation]).rocking, m.rocking);
            } else {
                assert!(within(r.roll.amp_deg, ROLL_AMP_DEG));
                assert!(within(r.pitch.amp_deg, PITCH_AMP_DEG));
                assert!(within(r.translation.heave.amp_m, HEAVE_AMP_M));
                let (a, b, c) = (r.roll.period_s, r.pitch.period_s, r.yaw.period_s);
                assert!(
                    m.period_draws == MAX_PERIOD_DRAWS
                        || !(near_resonance(a, b) || near_resonance(a, c) || near_resonance(b, c))
                );
            }
            grades[match m.grade {
                Grade::Fog => 0,
                Grade::Rlg => 1,
                _ => 2,
            }] += 1;
            if m.grade == Grade::MemsTactical {
                assert!(m.biases);
            }
            if !m.biases {
                assert_eq!(m.noise().gyro_bias_rad_s, 0.0);
                assert_eq!(m.error_model().gyro.turn_on_bias_sigma, Vector3::zeros());
            }
        }
        // Binomial counts within 4 sigma of their means (400 draws).
        let near = |n: usize, p: f64| {
            let (mean, sd) = (400.0 * p, (400.0 * p * (1.0 - p)).sqrt());
            (n as f64 - mean).abs() < 4.0 * sd
        };
        assert!(near(still, STILL_PROBABILITY), "{still}");
        // 1200 survey errors of 1-sigma 0.1 m: RMS within 10 % of it (the chi-square's 1-sigma
        // is 2 %).
        let rms = (survey_sq / 1200.0).sqrt();
        let sigma = BaseMotion::<f64>::default().position_sigma_m;
        assert!((rms / sigma - 1.0).abs() < 0.1, "{rms}");
        assert!(
            near(grades[0], FOG_SHARE) && near(grades[1], RLG_SHARE),
            "{grades:?}"
        );
    }

    #[test]
    fn resonances_are_recognised() {
        assert!(near_resonance(10.0, 5.05));
        assert!(near_resonance(9.0, 12.1));
        assert!(near_resonance(7.0, 7.0));
        assert!(!near_resonance(10.0, 7.0));
        assert!(!near_resonance(11.0, 5.0)); // 2.2: not within 2 % of 2 (or 9/4, not small)
    }

    #[test]
    fn the_imu_starts_at_the_lever_arm_and_a_still_member_does_not_move() {
        let m = (0..)
            .map(|i| FamilyMember::draw(1, i))
            .find(|m| m.still && m.lever_arm_b_m().norm() > 3.0)
            .unwrap_or_else(|| unreachable!());
        let traj = &m.rocking;
        let start = Generator::new(traj).truth();
        let c_b_n = start.q_b_ned.to_rotation_matrix();
        let offset = c_b_n * m.lever_arm_b_m();
        let e = nav_core::earth::LocalEarth::new(m.lat_rad(), m.rocking.h_m);
        let north = (start.lat - m.lat_rad()) * (e.r_meridian + m.rocking.h_m);
        let down = m.rocking.h_m - start.h;
        assert!((north - offset.x).abs() < 1e-6 && (down - offset.z).abs() < 1e-9);
        let mut moved: f64 = 0.0;
        generate(traj, Sampling::new(RATE_HZ, 2.0), |_, _, _, t| {
            moved = moved.max(t.v_eb_ned.norm());
        });
        assert_eq!(moved, 0.0);
        assert_eq!(traj.duration_s(), FINAL_S);
    }
}
