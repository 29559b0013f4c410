//! The named scenarios of the papers, each parameterised (`key = value`, SI or degrees as the
//! key says) and documented by [`Scenario::params`].
//!
//! | name | what | source |
//! |---|---|---|
//! | `static` | at rest, any attitude | — |
//! | `ship-rocking` | harmonic roll, pitch and yaw of a ship, IMU at a lever arm from the centre of rotation | [Ship alignment] |
//! | `auv-bench` | roll and pitch 5 deg, 11 s for 5 min, then still; 15 min | [Vavilova et al., §4] |
//! | `flight` | Nizhny Novgorod UWGG to St Petersburg ULLI along the geodesic, 900 km/h at 10,000 m, climb and descent | [Stand model] |
//! | `land-vehicle` | a car: starts, stops, accelerations, turns with body roll and pitch | — |
//!
//! Sea states of `ship-rocking` ([Ship alignment] gives only sea state 6: 2 deg, 8 s; the others
//! are this project's assumption for a large ship, amplitudes roughly proportional to the
//! significant wave height): roll amplitude / period 3: 0.5 deg / 5 s, 4: 1.0 deg / 6 s, 5:
//! 1.5 deg / 7 s, 6: 2.0 deg / 8 s. Pitch has half the roll amplitude at 0.75 of its period
//! (phase +60 deg), yaw a quarter at the roll period (phase +120 deg).

use super::jet::{Jet, Profile};
use super::{Motion, Point, Trajectory, wrap_pi};
use anyhow::{Result, bail};
use nav_core::Vector3;
use nav_core::alignment::machine::MAX_LEVER_ARM_M;
use nav_core::earth::LocalEarth;
use nav_core::navigator::config::{MAX_HEIGHT_M, MIN_HEIGHT_M};
use nav_core::number::Number;
use std::f64::consts::TAU;

/// One documented parameter of a scenario.
pub struct Param<'a> {
    /// Key, e.g. `lat_deg`.
    pub key: &'static str,
    /// Its value.
    pub value: &'a mut f64,
    /// What it is.
    pub doc: &'static str,
}

/// A [`Param`].
fn param<'a>(key: &'static str, value: &'a mut f64, doc: &'static str) -> Param<'a> {
    Param { key, value, doc }
}

/// Parameter access shared by the scenarios.
pub trait Params {
    /// Every parameter, for setting and listing.
    fn params(&mut self) -> Vec<Param<'_>>;
}

/// Sets `key` to `value` in `p` (unknown keys are an error listing the known ones).
pub fn set_param(p: &mut dyn Params, key: &str, value: f64) -> Result<()> {
    let mut list = p.params();
    let known: Vec<&str> = list.iter().map(|q| q.key).collect();
    // The key first: `speed=NaN` was "speed must be a finite number", a parameter that is not.
    match list.iter_mut().find(|q| q.key == key) {
        Some(_) if !value.is_finite() => bail!("{key} must be a finite number, not {value}"),
        Some(q) => {
            *q.value = value;
            Ok(())
        }
        None => bail!(
            "unknown parameter {key:?}; this scenario has {}",
            known.join(", ")
        ),
    }
}

/// A scenario by name, with its parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum Scenario {
    /// `static`.
    Static(Static),
    /// `ship-rocking`.
    ShipRocking(Rocking),
    /// `auv-bench`.
    AuvBench(Rocking),
    /// `flight`.
    Flight(FlightPlan),
    /// `land-vehicle`.
    LandVehicle(LandVehicle),
}

impl Scenario {
    /// The names, as the CLI accepts them.
    pub const NAMES: [&'static str; 5] = [
        "static",
        "ship-rocking",
        "auv-bench",
        "flight",
        "land-vehicle",
    ];

    /// The scenario `name` with its default parameters.
    pub fn by_name(name: &str) -> Result<Self> {
        Ok(match name {
            "static" => Self::Static(Static::default()),
            "ship-rocking" => Self::ShipRocking(Rocking::ship(6)),
            "auv-bench" => Self::AuvBench(Rocking::auv_bench()),
            "flight" => Self::Flight(FlightPlan::default()),
            "land-vehicle" => Self::LandVehicle(LandVehicle::default()),
            _ => bail!(
                "unknown scenario {name:?}; the scenarios are {}",
                Self::NAMES.join(", ")
            ),
        })
    }

    /// Its name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Static(_) => "static",
            Self::ShipRocking(_) => "ship-rocking",
            Self::AuvBench(_) => "auv-bench",
            Self::Flight(_) => "flight",
            Self::LandVehicle(_) => "land-vehicle",
        }
    }

    /// Sets a parameter (`ship-rocking`'s `sea_state` resets the rocking to that sea state's
    /// table, so give it before the rocking parameters it should not override).
    pub fn set(&mut self, key: &str, value: f64) -> Result<()> {
        if let (Self::ShipRocking(r), "sea_state") = (&mut *self, key) {
            let s = value.round();
            if !(3.0..=6.0).contains(&s) || s != value {
                bail!("sea_state must be 3, 4, 5 or 6, not {value}");
            }
            let keep = r.clone();
            *r = Rocking::ship(s as u8);
            r.lat_deg = keep.lat_deg;
            r.lon_deg = keep.lon_deg;
            r.h_m = keep.h_m;
            r.heading_deg = keep.heading_deg;
            r.lever_arm_m = keep.lever_arm_m;
            r.speed_mps = keep.speed_mps;
            return Ok(());
        }
        set_param(self.params_mut(), key, value)
    }

    fn params_mut(&mut self) -> &mut dyn Params {
        match self {
            Self::Static(s) => s,
            Self::ShipRocking(r) | Self::AuvBench(r) => r,
            Self::Flight(f) => f,
            Self::LandVehicle(l) => l,
        }
    }

    /// `(key, value, doc)` of every parameter.
    pub fn describe(&mut self) -> Vec<(&'static str, f64, &'static str)> {
        self.params_mut()
            .params()
            .into_iter()
            .map(|p| (p.key, *p.value, p.doc))
            .collect()
    }

    /// Refuses a motion period too short for the sample rate `rate_hz` [Hz]
    /// ([`Rocking::check_periods`]); the scenarios without one pass.
    pub fn check_periods(&self, rate_hz: f64) -> Result<()> {
        match self {
            Self::ShipRocking(r) | Self::AuvBench(r) => r.check_periods(rate_hz),
            Self::Static(_) | Self::Flight(_) | Self::LandVehicle(_) => Ok(()),
        }
    }

    /// The trajectory (checks the parameters).
    pub fn build(&self) -> Result<Box<dyn Trajectory>> {
        Ok(match self {
            Self::Static(s) => Box::new(s.check()?),
            Self::ShipRocking(r) | Self::AuvBench(r) => Box::new(r.build()?),
            Self::Flight(f) => Box::new(f.build()?),
            Self::LandVehicle(l) => Box::new(l.build()?),
        })
    }
}

fn check_lat(lat_deg: f64) -> Result<()> {
    if !(-89.0..=89.0).contains(&lat_deg) {
        bail!(
            "lat_deg must be within [-89, 89] (the NED truth is singular at the poles), not {lat_deg}"
        );
    }
    Ok(())
}

/// Fastest speed a scenario accepts [m/s]: the scenarios are vehicles on or near the Earth
/// (an aircraft at Mach 3 flies at about 1000 m/s); towards the orbital 7.9 km/s gravity no
/// longer holds a body on such a path, and a latitude integrated at 1e9 m/s leaves [-90, 90].
pub const MAX_SPEED_MPS: f64 = 1000.0;

fn check_speed(key: &str, v: f64) -> Result<()> {
    if v.is_nan() || v.abs() > MAX_SPEED_MPS {
        bail!(
            "{key} {} is beyond {MAX_SPEED_MPS} m/s: the scenarios are vehicles on or near the Earth (Mach 3 is about 1000 m/s, orbital speed 7900 m/s)",
            Number(v)
        );
    }
    Ok(())
}

fn check_lon(key: &str, lon_deg: f64) -> Result<()> {
    if !(-180.0..=180.0).contains(&lon_deg) {
        bail!("{key} {} is not within [-180, 180] deg", Number(lon_deg));
    }
    Ok(())
}

/// Heights as `nav replay` accepts a site's ([`MIN_HEIGHT_M`], [`MAX_HEIGHT_M`]).
fn check_height(key: &str, h_m: f64) -> Result<()> {
    if !(MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&h_m) {
        bail!(
            "{key} {} is not within [{MIN_HEIGHT_M}, {MAX_HEIGHT_M}] m (the Earth model's range)",
            Number(h_m)
        );
    }
    Ok(())
}

/// A lever arm `[x, y, z]` [m] no longer than nav-core's [`MAX_LEVER_ARM_M`] (the alignment
/// refuses longer ones).
fn check_lever_arm(lever_arm_m: &[f64; 3]) -> Result<()> {
    let length_m = Vector3::from(*lever_arm_m).norm();
    if length_m.is_nan() || length_m > MAX_LEVER_ARM_M {
        bail!(
            "lever arm {} m (lever_x_m, lever_y_m, lever_z_m) is beyond {MAX_LEVER_ARM_M} m: the IMU sits on the base, within a hull's length of its centre of rotation",
            Number(length_m)
        );
    }
    Ok(())
}

/// An angle `v` [deg] within `[-limit, limit]` (a roll within 180, a heading or phase within
/// 360: a value beyond is a typing or unit error, not an orientation).
fn check_angle(key: &str, v: f64, limit: f64) -> Result<()> {
    if !(-limit..=limit).contains(&v) {
        bail!("{key} {} is not within [-{limit}, {limit}] deg", Number(v));
    }
    Ok(())
}

fn check_positive(key: &str, v: f64) -> Result<()> {
    // Infinity is a value here (a rocking that never stops, a period of no motion).
    if v.is_nan() || v <= 0.0 {
        bail!("{key} must be positive, not {}", Number(v));
    }
    Ok(())
}

/// Fewest samples a motion's period spans ([`Rocking::check_periods`]). Below 2 (Nyquist) a
/// harmonic aliases into another motion. Above it the exact increments are right, but no IMU
/// senses such a motion (its anti-aliasing filter passes well under its Nyquist frequency),
/// and the navigator's coning and sculling corrections, series in the angle turned per
/// sample, no longer hold. 10 samples (36 deg of phase a sample, a fifth of the Nyquist
/// frequency) keep both; at 400 Hz it is 25 ms, far shorter than the rocking of any vehicle
/// here (a ship's 5 to 8 s, the AUV bench's 11 s).
pub const MIN_SAMPLES_PER_PERIOD: f64 = 10.0;

/// A motion period `period_s` [s] at the sample rate `rate_hz` [Hz]: at least
/// [`MIN_SAMPLES_PER_PERIOD`] samples and at most [`MAX_SECONDS`] (finite: the rocking's taper
/// lasts one roll period).
fn check_period(key: &str, period_s: f64, rate_hz: f64) -> Result<()> {
    let min_s = MIN_SAMPLES_PER_PERIOD / rate_hz;
    if !(min_s..=MAX_SECONDS).contains(&period_s) {
        bail!(
            "{key} {} is not within [{}, {}] s: at {} Hz a motion's period must span at least \
             {MIN_SAMPLES_PER_PERIOD} samples (a shorter one aliases, or is faster than an IMU \
             senses) and be finite",
            Number(period_s),
            Number(min_s),
            Number(MAX_SECONDS),
            Number(rate_hz)
        );
    }
    Ok(())
}

/// Longest scenario [s] (11.6 days; the land vehicle plans its route lap by lap up to it: 1e300
/// or inf planned until memory ran out).
pub const MAX_SECONDS: f64 = 1e6;

/// A scenario's length: positive, within [`MAX_SECONDS`].
pub fn check_seconds(v: f64) -> Result<()> {
    check_positive("seconds", v)?;
    if v > MAX_SECONDS {
        bail!(
            "seconds must be at most {} (11 days), not {}",
            Number(MAX_SECONDS),
            Number(v)
        );
    }
    Ok(())
}

/// `static`: at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Static {
    /// Latitude [deg].
    pub lat_deg: f64,
    /// Longitude [deg].
    pub lon_deg: f64,
    /// Height [m].
    pub h_m: f64,
    /// Roll [deg].
    pub roll_deg: f64,
    /// Pitch [deg].
    pub pitch_deg: f64,
    /// Yaw [deg].
    pub yaw_deg: f64,
    /// Length [s].
    pub seconds: f64,
}

impl Default for Static {
    fn default() -> Self {
        Self {
            lat_deg: 45.0,
            lon_deg: 7.5,
            h_m: 150.0,
            roll_deg: 1.5,
            pitch_deg: -2.0,
            yaw_deg: 30.0,
            seconds: 600.0,
        }
    }
}

impl Params for Static {
    fn params(&mut self) -> Vec<Param<'_>> {
        vec![
            param("lat_deg", &mut self.lat_deg, "latitude [deg]"),
            param("lon_deg", &mut self.lon_deg, "longitude [deg]"),
            param("h_m", &mut self.h_m, "ellipsoidal height [m]"),
            param("roll_deg", &mut self.roll_deg, "roll [deg]"),
            param("pitch_deg", &mut self.pitch_deg, "pitch [deg]"),
            param("yaw_deg", &mut self.yaw_deg, "yaw (true heading) [deg]"),
            param("seconds", &mut self.seconds, "default length [s]"),
        ]
    }
}

impl Static {
    fn check(&self) -> Result<Self> {
        check_lat(self.lat_deg)?;
        check_lon("lon_deg", self.lon_deg)?;
        check_height("h_m", self.h_m)?;
        if self.pitch_deg.is_nan() || self.pitch_deg.abs() >= 89.0 {
            bail!(
                "pitch_deg must be within (-89, 89), not {}",
                Number(self.pitch_deg)
            );
        }
        check_angle("roll_deg", self.roll_deg, 180.0)?;
        check_angle("yaw_deg", self.yaw_deg, 360.0)?;
        check_seconds(self.seconds)?;
        Ok(*self)
    }
}

impl Trajectory for Static {
    fn start(&self) -> Point {
        Point {
            lat: self.lat_deg.to_radians(),
            lon: self.lon_deg.to_radians(),
            h: self.h_m,
            aux: 0.0,
        }
    }

    fn duration_s(&self) -> f64 {
        self.seconds
    }

    fn motion(&self, _t: f64, _p: &Point) -> Motion {
        Motion {
            euler: Vector3::new(self.roll_deg, self.pitch_deg, self.yaw_deg).map(f64::to_radians),
            ..Motion::default()
        }
    }
}

/// One harmonic angle: `amplitude sin(2 pi t / period + phase)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Harmonic {
    /// Amplitude [deg].
    pub amp_deg: f64,
    /// Period [s].
    pub period_s: f64,
    /// Phase [deg].
    pub phase_deg: f64,
}

impl Harmonic {
    fn at(&self, t: Jet) -> Jet {
        (t * (TAU / self.period_s) + Jet::constant(self.phase_deg.to_radians())).sin()
            * self.amp_deg.to_radians()
    }
}

/// One harmonic displacement of the centre of rotation: `amp_m sin(2 pi t / period_s + phase)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Displacement {
    /// Amplitude [m].
    pub amp_m: f64,
    /// Period [s].
    pub period_s: f64,
    /// Phase [deg].
    pub phase_deg: f64,
}

impl Displacement {
    /// No displacement (amplitude 0; the period only keeps the parameters valid).
    pub const NONE: Self = Self {
        amp_m: 0.0,
        period_s: 10.0,
        phase_deg: 0.0,
    };

    fn at(&self, t: Jet) -> Jet {
        (t * (TAU / self.period_s) + Jet::constant(self.phase_deg.to_radians())).sin() * self.amp_m
    }
}

/// How the centre of rotation moves about its mean position: harmonic surge along the mean
/// heading, sway across it (to starboard) and heave (up) [m] ([`Rocking::translation`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Translation {
    /// Along the mean heading [m].
    pub surge: Displacement,
    /// Across the mean heading, positive to starboard (mean heading + 90 deg) [m].
    pub sway: Displacement,
    /// Up [m].
    pub heave: Displacement,
}

impl Translation {
    /// The centre does not move.
    pub const NONE: Self = Self {
        surge: Displacement::NONE,
        sway: Displacement::NONE,
        heave: Displacement::NONE,
    };

    /// Whether any amplitude is non-zero.
    pub fn is_moving(&self) -> bool {
        [self.surge, self.sway, self.heave]
            .iter()
            .any(|d| d.amp_m != 0.0)
    }
}

/// Rocking about a mean attitude, with the IMU at a lever arm from the centre of rotation:
/// `ship-rocking` ([Ship alignment]) and `auv-bench` ([Vavilova et al., §4]).
///
/// The centre moves at a constant speed along the mean heading (0 by default) and may
/// oscillate about that path ([`Translation`]: surge, sway, heave; none by default); the IMU's
/// NED offset from it is `C_b_n(t) R`, whose first and second time derivatives (exact, through
/// [`Jet`]s) add the lever-arm velocity and the acceleration `omega_dot x R + omega x (omega x
/// R)` of [Ship alignment]. Roll and pitch oscillate about a mean roll and pitch (0 by default).
/// The rocking (and the translation) can stop at `rock_until_s`, tapered to rest over one roll
/// period by a smooth step.
///
/// With the defaults of the extensions (mean roll and pitch 0, [`Translation::NONE`]) the
/// motion is computed by exactly the same operations as before they existed: `ship-rocking`
/// and `auv-bench` are bit-identical. The extensions are not among their `--set` parameters
/// (their `scenario.txt` stays as it was); the alignment family
/// ([`super::family`]) draws them.
#[derive(Clone, Debug, PartialEq)]
pub struct Rocking {
    /// Latitude of the centre [deg].
    pub lat_deg: f64,
    /// Longitude of the centre [deg].
    pub lon_deg: f64,
    /// Height of the centre [m].
    pub h_m: f64,
    /// Mean heading [deg].
    pub heading_deg: f64,
    /// Roll.
    pub roll: Harmonic,
    /// Pitch.
    pub pitch: Harmonic,
    /// Yaw about the mean heading.
    pub yaw: Harmonic,
    /// IMU position relative to the centre of rotation, body FRD [m].
    pub lever_arm_m: [f64; 3],
    /// Speed of the centre along the mean heading [m/s].
    pub speed_mps: f64,
    /// Mean roll about which the roll oscillates [deg].
    pub mean_roll_deg: f64,
    /// Mean pitch about which the pitch oscillates [deg].
    pub mean_pitch_deg: f64,
    /// Harmonic translation of the centre about its mean path.
    pub translation: Translation,
    /// End of the rocking [s] (infinite: never).
    pub rock_until_s: f64,
    /// Default length [s].
    pub seconds: f64,
}

impl Rocking {
    /// `ship-rocking` at sea state `s` (3–6; see the module table), lever arm (30, 10, 15) m.
    pub fn ship(s: u8) -> Self {
        let (amp, period) = match s {
            3 => (0.5, 5.0),
            4 => (1.0, 6.0),
            5 => (1.5, 7.0),
            _ => (2.0, 8.0),
        };
        Self {
            lat_deg: 45.0,
            lon_deg: 30.0,
            h_m: 0.0,
            heading_deg: 30.0,
            roll: Harmonic {
                amp_deg: amp,
                period_s: period,
                phase_deg: 0.0,
            },
            pitch: Harmonic {
                amp_deg: amp / 2.0,
                period_s: 0.75 * period,
                phase_deg: 60.0,
            },
            yaw: Harmonic {
                amp_deg: amp / 4.0,
                period_s: period,
                phase_deg: 120.0,
            },
            lever_arm_m: [30.0, 10.0, 15.0],
            speed_mps: 0.0,
            mean_roll_deg: 0.0,
            mean_pitch_deg: 0.0,
            translation: Translation::NONE,
            rock_until_s: f64::INFINITY,
            seconds: 3600.0,
        }
    }

    /// `auv-bench` ([Vavilova et al., §4]): roll and pitch 5 deg, 11 s (pitch a quarter period
    /// behind) for 5 min, then still; 15 min; IMU on the rotation centre.
    pub fn auv_bench() -> Self {
        Self {
            lat_deg: 45.0,
            lon_deg: 30.0,
            h_m: 0.0,
            heading_deg: 60.0,
            roll: Harmonic {
                amp_deg: 5.0,
                period_s: 11.0,
                phase_deg: 0.0,
            },
            pitch: Harmonic {
                amp_deg: 5.0,
                period_s: 11.0,
                phase_deg: -90.0,
            },
            yaw: Harmonic {
                amp_deg: 0.0,
                period_s: 11.0,
                phase_deg: 0.0,
            },
            lever_arm_m: [0.0; 3],
            speed_mps: 0.0,
            mean_roll_deg: 0.0,
            mean_pitch_deg: 0.0,
            translation: Translation::NONE,
            rock_until_s: 300.0,
            seconds: 900.0,
        }
    }

    /// Checks the parameters (as [`Scenario::build`] does): a rocking base from elsewhere
    /// (the alignment family's members) is refused like one given on the command line.
    pub fn check(&self) -> Result<()> {
        self.build().map(|_| ())
    }

    /// Refuses a period of the rocking or of the centre's translation that spans fewer than
    /// [`MIN_SAMPLES_PER_PERIOD`] samples at `rate_hz` [Hz], or an infinite one: a roll period
    /// of 1 ns at 400 Hz gave 1.4e6 rad in one sample's increment.
    pub fn check_periods(&self, rate_hz: f64) -> Result<()> {
        let t = &self.translation;
        for (key, period_s) in [
            ("roll_period_s", self.roll.period_s),
            ("pitch_period_s", self.pitch.period_s),
            ("yaw_period_s", self.yaw.period_s),
            ("surge_period_s", t.surge.period_s),
            ("sway_period_s", t.sway.period_s),
            ("heave_period_s", t.heave.period_s),
        ] {
            check_period(key, period_s, rate_hz)?;
        }
        Ok(())
    }

    fn build(&self) -> Result<Self> {
        check_lat(self.lat_deg)?;
        check_lon("lon_deg", self.lon_deg)?;
        check_height("h_m", self.h_m)?;
        check_speed("speed_mps", self.speed_mps)?;
        check_lever_arm(&self.lever_arm_m)?;
        check_angle("heading_deg", self.heading_deg, 360.0)?;
        for (k, h) in [
            ("roll", self.roll),
            ("pitch", self.pitch),
            ("yaw", self.yaw),
        ] {
            check_positive(&format!("{k}_period_s"), h.period_s)?;
            if h.amp_deg.is_nan() || h.amp_deg.abs() > 45.0 {
                bail!(
                    "{k}_amp_deg must be within 45 deg, not {}",
                    Number(h.amp_deg)
                );
            }
            check_angle(&format!("{k}_phase_deg"), h.phase_deg, 360.0)?;
        }
        if self.roll.amp_deg.abs() + self.pitch.amp_deg.abs() > 80.0 {
            bail!("roll and pitch amplitudes together must stay below 80 deg");
        }
        for (k, m) in [
            ("mean_roll_deg", self.mean_roll_deg),
            ("mean_pitch_deg", self.mean_pitch_deg),
        ] {
            if m.is_nan() || m.abs() > 30.0 {
                bail!("{k} must be within 30 deg, not {}", Number(m));
            }
        }
        let t = &self.translation;
        for (k, d) in [("surge", t.surge), ("sway", t.sway), ("heave", t.heave)] {
            check_positive(&format!("{k}_period_s"), d.period_s)?;
            if d.amp_m.is_nan() || d.amp_m.abs() > 100.0 {
                bail!("{k}_amp_m must be within 100 m, not {}", Number(d.amp_m));
            }
            check_angle(&format!("{k}_phase_deg"), d.phase_deg, 360.0)?;
        }
        check_positive("rock_until_s", self.rock_until_s)?;
        check_seconds(self.seconds)?;
        Ok(self.clone())
    }

    /// Roll, pitch, yaw as jets at `t`.
    fn euler(&self, t: f64) -> [Jet; 3] {
        let tj = Jet::time(t);
        let env = self.envelope(tj);
        // A zero mean is not added: `0 + x` would turn a `-0.0` into `+0.0` and change the
        // bits of the scenarios that predate the mean.
        let about = |mean_deg: f64, x: Jet| {
            if mean_deg == 0.0 {
                x
            } else {
                Jet::constant(mean_deg.to_radians()) + x
            }
        };
        [
            about(self.mean_roll_deg, self.roll.at(tj) * env),
            about(self.mean_pitch_deg, self.pitch.at(tj) * env),
            Jet::constant(self.heading_deg.to_radians()) + self.yaw.at(tj) * env,
        ]
    }

    /// 1 while rocking, down to 0 over one roll period before `rock_until_s`, as a jet at `t`.
    fn envelope(&self, tj: Jet) -> Jet {
        let taper = self.roll.period_s;
        Jet::constant(1.0)
            - super::jet::smoothstep(
                (tj - Jet::constant(self.rock_until_s - taper)) * (1.0 / taper),
            )
    }

    /// The centre's NED displacement from its mean path [m] at `t` [s], as jets; `None` when it
    /// does not move ([`Translation::is_moving`]).
    fn centre_offset(&self, t: f64) -> Option<[Jet; 3]> {
        let tr = &self.translation;
        if !tr.is_moving() {
            return None;
        }
        let tj = Jet::time(t);
        let env = self.envelope(tj);
        let (s, c) = self.heading_deg.to_radians().sin_cos();
        let (surge, sway) = (tr.surge.at(tj) * env, tr.sway.at(tj) * env);
        let heave = tr.heave.at(tj) * env;
        Some([surge * c - sway * s, surge * s + sway * c, -heave])
    }

    /// The IMU's NED offset from the centre's mean path [m]: the lever arm's, plus the centre's
    /// own displacement when it moves.
    fn imu_offset(&self, t: f64, e: &[Jet; 3]) -> [Jet; 3] {
        let r = self.lever_offset(e);
        match self.centre_offset(t) {
            None => r,
            Some(d) => core::array::from_fn(|i| r[i] + d[i]),
        }
    }

    /// The IMU's NED offset from the centre, `C_b_n(t) R` [m], as jets.
    fn lever_offset(&self, e: &[Jet; 3]) -> [Jet; 3] {
        let c = dcm_jet(e);
        let r = self.lever_arm_m;
        core::array::from_fn(|i| {
            c[i][0] * Jet::constant(r[0])
                + c[i][1] * Jet::constant(r[1])
                + c[i][2] * Jet::constant(r[2])
        })
    }
}

impl Params for Rocking {
    fn params(&mut self) -> Vec<Param<'_>> {
        let [lx, ly, lz] = &mut self.lever_arm_m;
        vec![
            param("lat_deg", &mut self.lat_deg, "latitude of the centre [deg]"),
            param(
                "lon_deg",
                &mut self.lon_deg,
                "longitude of the centre [deg]",
            ),
            param("h_m", &mut self.h_m, "height of the centre [m]"),
            param("heading_deg", &mut self.heading_deg, "mean heading [deg]"),
            param(
                "roll_amp_deg",
                &mut self.roll.amp_deg,
                "roll amplitude [deg]",
            ),
            param("roll_period_s", &mut self.roll.period_s, "roll period [s]"),
            param(
                "roll_phase_deg",
                &mut self.roll.phase_deg,
                "roll phase [deg]",
            ),
            param(
                "pitch_amp_deg",
                &mut self.pitch.amp_deg,
                "pitch amplitude [deg]",
            ),
            param(
                "pitch_period_s",
                &mut self.pitch.period_s,
                "pitch period [s]",
            ),
            param(
                "pitch_phase_deg",
                &mut self.pitch.phase_deg,
                "pitch phase [deg]",
            ),
            param(
                "yaw_amp_deg",
                &mut self.yaw.amp_deg,
                "yaw amplitude about the mean heading [deg]",
            ),
            param("yaw_period_s", &mut self.yaw.period_s, "yaw period [s]"),
            param("yaw_phase_deg", &mut self.yaw.phase_deg, "yaw phase [deg]"),
            param("lever_x_m", lx, "IMU lever arm, forward [m]"),
            param("lever_y_m", ly, "IMU lever arm, right [m]"),
            param("lever_z_m", lz, "IMU lever arm, down [m]"),
            param(
                "speed_mps",
                &mut self.speed_mps,
                "speed of the centre along the mean heading [m/s]",
            ),
            param(
                "rock_until_s",
                &mut self.rock_until_s,
                "end of the rocking, tapered over one roll period [s] (inf: never)",
            ),
            param("seconds", &mut self.seconds, "default length [s]"),
        ]
    }
}

impl Trajectory for Rocking {
    fn start(&self) -> Point {
        // The IMU starts at the centre (displaced, if it moves) plus its lever-arm offset.
        let (lat, h) = (self.lat_deg.to_radians(), self.h_m);
        let r = self.imu_offset(0.0, &self.euler(0.0));
        let e = LocalEarth::new(lat, h);
        Point {
            lat: lat + r[0].v / (e.r_meridian + h),
            lon: self.lon_deg.to_radians() + r[1].v / ((e.r_transverse + h) * lat.cos()),
            h: h - r[2].v,
            aux: 0.0,
        }
    }

    fn duration_s(&self) -> f64 {
        self.seconds
    }

    fn motion(&self, t: f64, _p: &Point) -> Motion {
        let e = self.euler(t);
        let r = self.imu_offset(t, &e);
        let (s, c) = self.heading_deg.to_radians().sin_cos();
        Motion {
            v_eb_n: Vector3::new(
                self.speed_mps * c + r[0].d1,
                self.speed_mps * s + r[1].d1,
                r[2].d1,
            ),
            a_eb_n: Vector3::new(r[0].d2, r[1].d2, r[2].d2),
            euler: Vector3::new(e[0].v, e[1].v, e[2].v),
            euler_rate: Vector3::new(e[0].d1, e[1].d1, e[2].d1),
            aux_rate: 0.0,
        }
    }
}

/// `C_b_n = R_z(yaw) R_y(pitch) R_x(roll)` with jet entries (Groves eq. 2.22).
fn dcm_jet(e: &[Jet; 3]) -> [[Jet; 3]; 3] {
    let (sr, cr) = (e[0].sin(), e[0].cos());
    let (sp, cp) = (e[1].sin(), e[1].cos());
    let (sy, cy) = (e[2].sin(), e[2].cos());
    [
        [cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy],
        [cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy],
        [-sp, sr * cp, cr * cp],
    ]
}

/// Geodesic on the WGS-84 ellipsoid from `(lat1, lon1)` to `(lat2, lon2)` [rad]: `(initial
/// azimuth [rad], length [m])`, by shooting the geodesic equations (`dlat/ds = cos a / M`,
/// `dlon/ds = sin a / (N cos lat)`, `da/ds = sin a tan lat / N`; Clairaut) with Newton steps.
pub fn geodesic_inverse(lat1: f64, lon1: f64, lat2: f64, lon2: f64) -> Result<(f64, f64)> {
    // Spherical first guess.
    let dlon = lon2 - lon1;
    let az0 = (dlon.sin() * lat2.cos())
        .atan2(lat1.cos() * lat2.sin() - lat1.sin() * lat2.cos() * dlon.cos());
    let mut az = az0;
    let central = (lat1.sin() * lat2.sin() + lat1.cos() * lat2.cos() * dlon.cos()).clamp(-1.0, 1.0);
    let mut s = central.acos() * 6.371e6;
    let miss = |az: f64, s: f64| {
        let (la, lo) = geodesic_direct(lat1, lon1, az, s);
        let e = LocalEarth::new(lat2, 0.0);
        // North and east misses [m].
        (
            (la - lat2) * e.r_meridian,
            wrap_pi(lo - lon2) * e.r_transverse * lat2.cos(),
        )
    };
    for _ in 0..20 {
        let (n0, e0) = miss(az, s);
        if n0.hypot(e0) < 1e-4 {
            return Ok((az, s));
        }
        let (da, ds) = (1e-7, 1.0);
        let (na, ea) = miss(az + da, s);
        let (ns, es) = miss(az, s + ds);
        let j = [
            [(na - n0) / da, (ns - n0) / ds],
            [(ea - e0) / da, (es - e0) / ds],
        ];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if det.abs() < 1e-12 {
            break;
        }
        az -= (j[1][1] * n0 - j[0][1] * e0) / det;
        s -= (-j[1][0] * n0 + j[0][0] * e0) / det;
    }
    // Clairaut: the great circle's nearest approach to the polar axis is `R |sin(az) cos(lat1)|`.
    let axis_m = (az0.sin() * lat1.cos()).abs() * 6.371e6;
    if axis_m < 1000.0 && (lat1.sin() * lat2.sin() > 0.0) && dlon.cos() < 0.0 {
        bail!(
            "the route passes about {axis_m:.0} m from the {} Pole (its ends {:.3} deg of \
             longitude apart): the geodesic and the simulator's truth are latitude and longitude, \
             singular there; move an end so that the route passes at least 1 km from the pole",
            if lat1 > 0.0 { "North" } else { "South" },
            wrap_pi(dlon).abs().to_degrees()
        )
    }
    bail!("the geodesic did not converge (antipodal or coincident points?)")
}

/// End point of the geodesic from `(lat, lon)` [rad] at azimuth `az` [rad] after `s` [m] (RK4,
/// 200 m steps).
pub fn geodesic_direct(lat: f64, lon: f64, az: f64, s: f64) -> (f64, f64) {
    let n = (s.abs() / 200.0).ceil().max(1.0) as usize;
    let h = s / n as f64;
    let f = |y: [f64; 3]| {
        let e = LocalEarth::new(y[0], 0.0);
        let (sa, ca) = y[2].sin_cos();
        [
            ca / e.r_meridian,
            sa / (e.r_transverse * y[0].cos()),
            sa * y[0].tan() / e.r_transverse,
        ]
    };
    let mut y = [lat, lon, az];
    let add = |y: [f64; 3], k: [f64; 3], s: f64| core::array::from_fn(|i| y[i] + k[i] * s);
    for _ in 0..n {
        let k1 = f(y);
        let k2 = f(add(y, k1, h / 2.0));
        let k3 = f(add(y, k2, h / 2.0));
        let k4 = f(add(y, k3, h));
        y = core::array::from_fn(|i| y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
    }
    (y[0], y[1])
}

/// `flight` ([Stand model]): from one airfield to another along the geodesic. Defaults: Nizhny
/// Novgorod Strigino (UWGG, 56.2301 N 43.7840 E, 78 m) to St Petersburg Pulkovo (ULLI, 59.8003 N
/// 30.2625 E, 24 m), airfield elevations used as ellipsoidal heights.
///
/// Profile: `still_s` at rest on the runway, the take-off run to 80 m/s in 40 s, a climb to
/// `cruise_h_m` over `climb_s` while accelerating to `cruise_mps` in 400 s, cruise, a descent
/// over `climb_s` slowing to 80 m/s in its last 800 s, the landing run to rest in 40 s, 30 s
/// still. The cruise lasts what makes the ground track end at the destination. Pitch follows the
/// flight-path angle, roll is 0, and the heading follows the geodesic (`dpsi/dt = v_E tan(lat) /
/// (R_E + h)`, integrated with the position).
#[derive(Clone, Debug, PartialEq)]
pub struct FlightPlan {
    /// Departure latitude [deg].
    pub from_lat_deg: f64,
    /// Departure longitude [deg].
    pub from_lon_deg: f64,
    /// Departure height [m].
    pub from_h_m: f64,
    /// Destination latitude [deg].
    pub to_lat_deg: f64,
    /// Destination longitude [deg].
    pub to_lon_deg: f64,
    /// Destination height [m].
    pub to_h_m: f64,
    /// Cruise speed [m/s].
    pub cruise_mps: f64,
    /// Cruise height [m].
    pub cruise_h_m: f64,
    /// Climb (and descent) duration [s].
    pub climb_s: f64,
    /// Time at rest before the take-off [s].
    pub still_s: f64,
}

impl Default for FlightPlan {
    fn default() -> Self {
        Self {
            from_lat_deg: 56.2301,
            from_lon_deg: 43.7840,
            from_h_m: 78.0,
            to_lat_deg: 59.8003,
            to_lon_deg: 30.2625,
            to_h_m: 24.0,
            cruise_mps: 250.0,
            cruise_h_m: 10_000.0,
            climb_s: 1200.0,
            still_s: 60.0,
        }
    }
}

impl Params for FlightPlan {
    fn params(&mut self) -> Vec<Param<'_>> {
        vec![
            param(
                "from_lat_deg",
                &mut self.from_lat_deg,
                "departure latitude [deg]",
            ),
            param(
                "from_lon_deg",
                &mut self.from_lon_deg,
                "departure longitude [deg]",
            ),
            param("from_h_m", &mut self.from_h_m, "departure height [m]"),
            param(
                "to_lat_deg",
                &mut self.to_lat_deg,
                "destination latitude [deg]",
            ),
            param(
                "to_lon_deg",
                &mut self.to_lon_deg,
                "destination longitude [deg]",
            ),
            param("to_h_m", &mut self.to_h_m, "destination height [m]"),
            param(
                "cruise_mps",
                &mut self.cruise_mps,
                "cruise ground speed [m/s]",
            ),
            param("cruise_h_m", &mut self.cruise_h_m, "cruise height [m]"),
            param(
                "climb_s",
                &mut self.climb_s,
                "climb and descent durations [s]",
            ),
            param(
                "still_s",
                &mut self.still_s,
                "time at rest before take-off [s]",
            ),
        ]
    }
}

/// Take-off and landing speed [m/s].
const RUNWAY_MPS: f64 = 80.0;

/// A planned flight: the speed and height profiles and the initial geodesic azimuth.
#[derive(Clone, Debug, PartialEq)]
pub struct Flight {
    from: Point,
    speed: Profile,
    height: Profile,
    end_s: f64,
    /// Length of the geodesic [m].
    pub distance_m: f64,
}

impl FlightPlan {
    fn profiles(&self, cruise_end: f64) -> (Profile, Profile, f64) {
        let mut speed = Profile::new(0.0);
        let mut height = Profile::new(self.from_h_m);
        let t_air = speed.ramp(self.still_s, 40.0, RUNWAY_MPS);
        speed.ramp(t_air, 400.0, self.cruise_mps);
        height.ramp(t_air, self.climb_s, self.cruise_h_m);
        let t_down = cruise_end.max(height.end_time());
        let touch = height.ramp(t_down, self.climb_s, self.to_h_m);
        speed.ramp(touch - 800.0, 800.0, RUNWAY_MPS);
        let stop = speed.ramp(touch, 40.0, 0.0);
        (speed, height, stop + 30.0)
    }

    /// Plans the flight: the geodesic, then the cruise length that makes the ground track (at
    /// height, scaled to the ellipsoid) as long as the geodesic.
    pub fn build(&self) -> Result<Flight> {
        check_lat(self.from_lat_deg)?;
        check_lat(self.to_lat_deg)?;
        check_lon("from_lon_deg", self.from_lon_deg)?;
        check_lon("to_lon_deg", self.to_lon_deg)?;
        for (k, h) in [
            ("from_h_m", self.from_h_m),
            ("to_h_m", self.to_h_m),
            ("cruise_h_m", self.cruise_h_m),
        ] {
            check_height(k, h)?;
        }
        for (k, v) in [("cruise_mps", self.cruise_mps), ("climb_s", self.climb_s)] {
            check_positive(k, v)?;
        }
        check_speed("cruise_mps", self.cruise_mps)?;
        if self.cruise_mps <= RUNWAY_MPS {
            bail!("cruise_mps must exceed the runway speed {RUNWAY_MPS} m/s");
        }
        if self.climb_s < 800.0 {
            bail!("climb_s must be at least 800 s (the descent slows down over its last 800 s)");
        }
        if !(0.0..=MAX_SECONDS).contains(&self.still_s) {
            bail!(
                "still_s must be within [0, {}] s, not {}",
                Number(MAX_SECONDS),
                Number(self.still_s)
            );
        }
        // The ground distance is summed second by second over the profile: 1e300 s never ended.
        if self.climb_s > MAX_SECONDS {
            bail!(
                "climb_s must be at most {} s, not {}",
                Number(MAX_SECONDS),
                Number(self.climb_s)
            );
        }
        let (lat1, lon1) = (
            self.from_lat_deg.to_radians(),
            self.from_lon_deg.to_radians(),
        );
        let (az, distance_m) = geodesic_inverse(
            lat1,
            lon1,
            self.to_lat_deg.to_radians(),
            self.to_lon_deg.to_radians(),
        )?;
        let r = LocalEarth::new(0.5 * (lat1 + self.to_lat_deg.to_radians()), 0.0).r_meridian;
        // Ground distance of a profile: integral of v R / (R + h), 1 s trapezoid.
        let ground = |p: &(Profile, Profile, f64)| {
            let n = p.2.ceil() as usize;
            (0..n)
                .map(|k| {
                    let f = |t: f64| p.0.at(t).v * r / (r + p.1.at(t).v);
                    0.5 * (f(k as f64) + f(k as f64 + 1.0))
                })
                .sum::<f64>()
        };
        let mut cruise_end = self.still_s + 40.0 + self.climb_s;
        let mut plan = self.profiles(cruise_end);
        for _ in 0..3 {
            let short = distance_m - ground(&plan);
            cruise_end += short / (self.cruise_mps * r / (r + self.cruise_h_m));
            plan = self.profiles(cruise_end);
        }
        if cruise_end < self.still_s + 40.0 + self.climb_s - 1.0 {
            bail!("the airfields are too close for this climb and descent ({distance_m:.0} m)");
        }
        let (speed, height, end_s) = plan;
        Ok(Flight {
            from: Point {
                lat: lat1,
                lon: lon1,
                h: self.from_h_m,
                aux: az,
            },
            speed,
            height,
            end_s,
            distance_m,
        })
    }
}

impl Trajectory for Flight {
    fn start(&self) -> Point {
        self.from
    }

    fn duration_s(&self) -> f64 {
        self.end_s
    }

    fn motion(&self, t: f64, p: &Point) -> Motion {
        let v = self.speed.at(t);
        let h = self.height.at(t);
        let climb = h.derivative();
        let e = LocalEarth::new(p.lat, p.h);
        let (s, c) = p.aux.sin_cos();
        // Geodesic: the heading turns with the vertical transport rate.
        let psi_dot = v.v * s * p.lat.tan() / (e.r_transverse + p.h);
        // Flight-path angle (0 on the ground, where the height profile is flat).
        let gamma = if v.v > 1e-3 {
            climb.atan2_pos(v)
        } else {
            Jet::constant(0.0)
        };
        Motion {
            v_eb_n: Vector3::new(v.v * c, v.v * s, -climb.v),
            a_eb_n: Vector3::new(
                v.d1 * c - v.v * s * psi_dot,
                v.d1 * s + v.v * c * psi_dot,
                -climb.d1,
            ),
            euler: Vector3::new(0.0, gamma.v, p.aux),
            euler_rate: Vector3::new(0.0, gamma.d1, psi_dot),
            aux_rate: psi_dot,
        }
    }
}

/// `land-vehicle`: a car on a flat road repeating a route of starts, stops and turns (about
/// 3 min per lap) for `seconds`. The body rolls out of turns and pitches up when accelerating by
/// `tilt_rad_per_mps2` times the lateral and longitudinal accelerations (a soft suspension).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LandVehicle {
    /// Latitude [deg].
    pub lat_deg: f64,
    /// Longitude [deg].
    pub lon_deg: f64,
    /// Height [m].
    pub h_m: f64,
    /// Initial heading [deg].
    pub heading_deg: f64,
    /// Cruise speed of the route's first leg [m/s] (later legs scale with it).
    pub speed_mps: f64,
    /// Body tilt per acceleration [rad per m/s^2].
    pub tilt_rad_per_mps2: f64,
    /// Length [s].
    pub seconds: f64,
}

impl Default for LandVehicle {
    fn default() -> Self {
        Self {
            lat_deg: 45.0,
            lon_deg: 7.5,
            h_m: 250.0,
            heading_deg: 0.0,
            speed_mps: 15.0,
            tilt_rad_per_mps2: 0.01,
            seconds: 600.0,
        }
    }
}

impl Params for LandVehicle {
    fn params(&mut self) -> Vec<Param<'_>> {
        vec![
            param("lat_deg", &mut self.lat_deg, "latitude [deg]"),
            param("lon_deg", &mut self.lon_deg, "longitude [deg]"),
            param("h_m", &mut self.h_m, "height of the road [m]"),
            param(
                "heading_deg",
                &mut self.heading_deg,
                "initial heading [deg]",
            ),
            param(
                "speed_mps",
                &mut self.speed_mps,
                "cruise speed of the first leg [m/s]",
            ),
            param(
                "tilt_rad_per_mps2",
                &mut self.tilt_rad_per_mps2,
                "body roll/pitch per lateral/longitudinal acceleration [rad per m/s^2]",
            ),
            param("seconds", &mut self.seconds, "length [s]"),
        ]
    }
}

/// A planned drive: speed and heading profiles.
#[derive(Clone, Debug, PartialEq)]
pub struct Drive {
    start: Point,
    speed: Profile,
    heading: Profile,
    tilt: f64,
    end_s: f64,
}

impl LandVehicle {
    /// Time at rest before the car first moves [s].
    pub const START_S: f64 = 20.0;

    /// Plans the route over `seconds`.
    pub fn build(&self) -> Result<Drive> {
        check_lat(self.lat_deg)?;
        check_lon("lon_deg", self.lon_deg)?;
        check_height("h_m", self.h_m)?;
        // 1e300 was taken: its truth started at yaw -3.7 deg, far from what was asked.
        check_angle("heading_deg", self.heading_deg, 360.0)?;
        check_positive("speed_mps", self.speed_mps)?;
        check_seconds(self.seconds)?;
        if self.speed_mps > 70.0 {
            bail!(
                "speed_mps {} is beyond 70 m/s: not a road vehicle (the route's fastest leg is 4/3 of it)",
                Number(self.speed_mps)
            );
        }
        if !(0.0..=0.05).contains(&self.tilt_rad_per_mps2) {
            bail!("tilt_rad_per_mps2 must be within [0, 0.05]");
        }
        let v = self.speed_mps;
        let mut speed = Profile::new(0.0);
        let mut heading = Profile::new(self.heading_deg.to_radians());
        let mut t = Self::START_S;
        // One lap: (what, duration [s], target); turns in deg, speeds as a factor of `v`.
        enum Leg {
            Speed(f64),
            Turn(f64),
            Hold,
        }
        let lap = [
            (Leg::Speed(1.0), 10.0),
            (Leg::Hold, 20.0),
            (Leg::Turn(90.0), 8.0),
            (Leg::Hold, 20.0),
            (Leg::Speed(0.0), 6.0),
            (Leg::Hold, 10.0),
            (Leg::Speed(4.0 / 3.0), 12.0),
            (Leg::Hold, 25.0),
            (Leg::Turn(-90.0), 10.0),
            (Leg::Hold, 10.0),
            (Leg::Turn(-90.0), 10.0),
            (Leg::Speed(2.0 / 3.0), 8.0),
            (Leg::Turn(45.0), 6.0),
            (Leg::Turn(-45.0), 6.0),
            (Leg::Hold, 10.0),
            (Leg::Speed(0.0), 8.0),
            (Leg::Hold, 15.0),
        ];
        'route: loop {
            for (leg, d) in &lap {
                if t + d > self.seconds {
                    break 'route;
                }
                match leg {
                    Leg::Speed(k) => {
                        speed.ramp(t, *d, k * v);
                    }
                    Leg::Turn(deg) => {
                        let to = heading.final_value() + deg.to_radians();
                        heading.ramp(t, *d, to);
                    }
                    Leg::Hold => {}
                }
                t += d;
            }
        }
        // Come to rest if the route was cut while moving.
        if speed.final_value() != 0.0 {
            let stop = speed.final_value() / 2.0; // 2 m/s^2 mean deceleration
            let t0 = speed.end_time().max(heading.end_time());
            speed.ramp(t0, stop.max(1.0), 0.0);
        }
        let end_s = self.seconds.max(speed.end_time());
        Ok(Drive {
            start: Point {
                lat: self.lat_deg.to_radians(),
                lon: self.lon_deg.to_radians(),
                h: self.h_m,
                aux: 0.0,
            },
            speed,
            heading,
            tilt: self.tilt_rad_per_mps2,
            end_s,
        })
    }
}

impl Trajectory for Drive {
    fn start(&self) -> Point {
        self.start
    }

    fn duration_s(&self) -> f64 {
        self.end_s
    }

    fn motion(&self, t: f64, _p: &Point) -> Motion {
        let v = self.speed.at(t);
        let psi = self.heading.at(t);
        let (s, c) = psi.v.sin_cos();
        // Lateral (to the right) and longitudinal accelerations, as jets.
        let a_lat = v * psi.derivative();
        let a_lon = v.derivative();
        let roll = -a_lat * self.tilt;
        let pitch = a_lon * self.tilt;
        Motion {
            v_eb_n: Vector3::new(v.v * c, v.v * s, 0.0),
            a_eb_n: Vector3::new(
                v.d1 * c - v.v * s * psi.d1,
                v.d1 * s + v.v * c * psi.d1,
                0.0,
            ),
            euler: Vector3::new(roll.v, pitch.v, wrap_pi(psi.v)),
            euler_rate: Vector3::new(roll.d1, pitch.d1, psi.d1),
            aux_rate: 0.0,
        }
    }
}
