//! A simulated GNSS receiver: fixes of the antenna from a truth trajectory, with white noise, a
//! time-correlated error, outages and injected outliers, reproducible from a seed.
//!
//! **Epochs.** The truth rows come at a fixed rate (e.g. 50 Hz, as `nav sim` writes them). A fix
//! is made at each truth row whose time is a whole multiple of the GNSS interval `1 / rate_hz`
//! (within a quarter of the truth interval), tagged with that row's time: receivers tag whole
//! epochs. The GNSS interval must be a whole number of truth intervals (a 1, 2, 5, 10 or 25 Hz
//! receiver on 50 Hz truth); another rate is an error rather than an interpolation.
//!
//! **Antenna** at `l = lever_arm_b_m` (body FRD) from the IMU (Groves §14.2.1, eqs. 14.5–14.6,
//! resolved in NED):
//!
//! - position: the truth position moved by `C_b_n l` north, east, down on the local radii of
//!   curvature ([`Position::offset_ned`]; error `|l|^2 / R`, below a micrometre for metre arms);
//! - velocity: `v_ea_n = v_eb_n + C_b_n (omega_eb_b x l)`, `omega_eb_b = omega_nb_b + C_n_b
//!   omega_en_n`. `omega_nb_b` is the central difference of the truth attitude between the
//!   neighbouring rows (`2 dt omega_nb_b = rotation vector of q_b_n(k-1)^-1 q_b_n(k+1)`; one-sided
//!   at the ends), exact for a constant rate and within `O(dt^2)` otherwise; `omega_en_n` is the
//!   transport rate of the truth velocity ([`LocalEarth::omega_en_n`]).
//!
//! **Noise.** White Gaussian, independent per axis and fix: the position moved by `sigma_ned_m`
//! times three standard normals (north, east, down, on the local radii again), the velocity plus
//! `sigma_v_ned_m_s` times three more. The fix reports these same sigmas, whatever was injected.
//! All white draws come from one stream of `ChaCha8Rng::seed_from_u64(seed)` (stream
//! [`WHITE_STREAM`]; the sensor simulator of the same seed draws from stream 0, so a run's fixes
//! and its sensor errors are independent), in epoch order:
//! position then velocity normals for **every** epoch, those in outages included, so adding an
//! outage or an outlier leaves the noise of every other fix unchanged.
//!
//! **Correlated error** (optional, [`CorrelatedError`]): what a code receiver's multipath and
//! atmosphere leave, a first-order Gauss–Markov process per axis with steady-state 1-sigma
//! `sigma` and correlation time `tau`, discretised exactly between epochs `dt` apart:
//!
//! ```text
//! b_0 = sigma w_0                                          (started in its steady state)
//! b_k = exp(-dt/tau) b_(k-1) + sigma sqrt(1 - exp(-2 dt/tau)) w_k,   w_k ~ N(0, 1)
//! ```
//!
//! so `E[b_k^2] = sigma^2` and `E[b_k b_(k+m)] = sigma^2 exp(-m dt/tau)`. It is added to the white
//! position noise (north, east, down, on the local radii) before the outliers; the fix still
//! reports the white `sigma_ned_m` as its sigma, as a receiver that does not know its multipath
//! does. Its normals come from a second stream of the same seed
//! (`set_stream(`[`CORRELATED_STREAM`]`)`), three per epoch, outages included: turning it on
//! leaves every white draw as it was, and an outage leaves the error of every other fix as it
//! was. [`GnssSim::correlated_ned_m`] holds what each fix got.
//!
//! **Outages** drop the fixes with `start_s <= t < start_s + length_s`. **Outliers** (position
//! only; velocity is left as it is) add to the noisy position:
//!
//! - [`Outlier::Jump`]: `offset_ned_m` on every fix with `t_s <= t < t_s + length_s` (a step
//!   that persists, then ends);
//! - [`Outlier::Spike`]: `offset_ned_m` on one fix, the first epoch at or after `t_s`;
//! - [`Outlier::Ramp`]: `final_offset_ned_m (t - start_s) / length_s` on the fixes with
//!   `start_s <= t < start_s + length_s` (a multipath bias growing linearly, then vanishing);
//! - [`Outlier::NaN`]: the first epoch at or after `t_s` gets NaN latitude, longitude, height
//!   (and velocity, when fixes have one): a receiver's invalid fix, which readers keep.
//!
//! Offsets of overlapping outliers add; a NaN wins. What was injected comes back as
//! [`Injection`]s, one per fix and outlier; an outlier whose fixes all fell in outages or
//! outside the truth is listed in [`GnssSim::missed_outliers`].

use crate::gnss::{GnssFix, GnssVelocity};
use crate::truth::Truth;
use anyhow::{Result, bail};
use nav_core::alignment::machine::MAX_LEVER_ARM_M;
use nav_core::attitude::rotation_vector_of;
use nav_core::earth::LocalEarth;
use nav_core::number::{Number, Rounded};
use nav_core::{Position, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::fmt::Write as _;

/// A time without fixes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outage {
    /// Start [s].
    pub start_s: f64,
    /// Length [s]: fixes with `start_s <= t < start_s + length_s` are dropped.
    pub length_s: f64,
}

impl Outage {
    /// Whether the fix at `t_s` [s] is dropped.
    pub fn contains(&self, t_s: f64) -> bool {
        within(t_s, self.start_s, self.length_s)
    }

    /// Outages of `length_s` [s] every `period_s` [s], the first at `first_start_s` [s], the last
    /// starting before `until_s` [s]: "60 s every 180 s" is `every(180.0, 60.0, 120.0, end)`.
    pub fn every(period_s: f64, length_s: f64, first_start_s: f64, until_s: f64) -> Vec<Self> {
        if !(period_s > 0.0 && period_s.is_finite() && first_start_s.is_finite()) {
            return Vec::new();
        }
        (0_u32..)
            .map(|k| first_start_s + f64::from(k) * period_s)
            .take_while(|&start_s| start_s < until_s)
            .map(|start_s| Self { start_s, length_s })
            .collect()
    }
}

/// An error injected into the fixes' positions (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outlier {
    /// A step of `offset_ned_m` [m] on the fixes in `[t_s, t_s + length_s)` [s].
    Jump {
        /// Start [s].
        t_s: f64,
        /// How long it persists [s].
        length_s: f64,
        /// Offset north, east, down [m].
        offset_ned_m: [f64; 3],
    },
    /// `offset_ned_m` [m] on the one fix at or after `t_s` [s].
    Spike {
        /// Time [s].
        t_s: f64,
        /// Offset north, east, down [m].
        offset_ned_m: [f64; 3],
    },
    /// A bias growing linearly from 0 at `start_s` towards `final_offset_ned_m` at `start_s +
    /// length_s` [s], gone from then on.
    Ramp {
        /// Start [s].
        start_s: f64,
        /// Length [s].
        length_s: f64,
        /// The offset it grows to, north, east, down [m].
        final_offset_ned_m: [f64; 3],
    },
    /// A NaN fix: the one at or after `t_s` [s].
    NaN {
        /// Time [s].
        t_s: f64,
    },
}

impl Outlier {
    /// Its name in descriptions.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Jump { .. } => "jump",
            Self::Spike { .. } => "spike",
            Self::Ramp { .. } => "ramp",
            Self::NaN { .. } => "NaN",
        }
    }

    /// When it starts [s].
    pub fn start_s(&self) -> f64 {
        match *self {
            Self::Jump { t_s, .. } | Self::Spike { t_s, .. } | Self::NaN { t_s } => t_s,
            Self::Ramp { start_s, .. } => start_s,
        }
    }

    /// Its times are finite, its offsets within [`MAX_OUTLIER_OFFSET_M`] on each axis, its
    /// lengths not negative.
    fn is_valid(&self) -> bool {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        let offset = |v: &[f64]| v.iter().all(|x| x.abs() <= MAX_OUTLIER_OFFSET_M);
        // An event before the first fix would land on it.
        if self.start_s().is_nan() || self.start_s() < 0.0 {
            return false;
        }
        match self {
            Self::Jump {
                t_s,
                length_s,
                offset_ned_m,
            } => finite(&[*t_s, *length_s]) && *length_s >= 0.0 && offset(offset_ned_m),
            Self::Spike { t_s, offset_ned_m } => t_s.is_finite() && offset(offset_ned_m),
            Self::Ramp {
                start_s,
                length_s,
                final_offset_ned_m,
            } => finite(&[*start_s, *length_s]) && *length_s > 0.0 && offset(final_offset_ned_m),
            Self::NaN { t_s } => t_s.is_finite(),
        }
    }
}

/// Largest GNSS position 1-sigma `nav sim` writes [m]: a fix that poor is no fix.
pub const MAX_SIGMA_M: f64 = 1000.0;
/// Largest GNSS velocity 1-sigma `nav sim` writes [m/s].
pub const MAX_SIGMA_V_M_S: f64 = 100.0;
/// Largest steady-state 1-sigma of the correlated error [m]: the filter's
/// ([`nav_core::ins_filter::limits::MAX_GNSS_ERROR_SIGMA_M`]: a receiver it could not take is
/// not simulated).
pub const MAX_CORRELATED_SIGMA_M: f64 = nav_core::ins_filter::limits::MAX_GNSS_ERROR_SIGMA_M;
/// Largest outlier offset `nav sim` injects, per axis [m]: 100 km, far beyond any gate, while
/// the fix stays a point near the truth on the Earth model.
pub const MAX_OUTLIER_OFFSET_M: f64 = 1.0e5;
/// Shortest and longest correlation time of the correlated error [s]: the filter's
/// ([`nav_core::ins_filter::limits::GNSS_ERROR_TIME_S`]; was 0 to 1e6 s here, a receiver
/// `nav replay` then refused).
pub const CORRELATION_TIME_S: (f64, f64) = nav_core::ins_filter::limits::GNSS_ERROR_TIME_S;
/// The ChaCha8 stream (of the same seed) the correlated error draws from.
pub const CORRELATED_STREAM: u64 = 1;
/// The ChaCha8 stream (of the same seed) the white noise draws from. Not stream 0: the sensor
/// simulator ([`crate::sensor_model::ErrorInjector`]) of a run draws from stream 0 of the same
/// seed, and its turn-on biases and white noise were the fixes' noise, number for number.
pub const WHITE_STREAM: u64 = 2;

/// A time-correlated position error: a first-order Gauss–Markov process per axis (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CorrelatedError {
    /// Steady-state 1-sigma north, east, down [m].
    pub sigma_ned_m: [f64; 3],
    /// Correlation time [s].
    pub time_s: f64,
}

impl CorrelatedError {
    /// `b` [m] advanced by `dt_s` [s] with the standard normals `w`: `exp(-dt/tau) b + sigma
    /// sqrt(1 - exp(-2 dt/tau)) w` (module docs).
    fn step(&self, b: [f64; 3], dt_s: f64, w: [f64; 3]) -> [f64; 3] {
        let phi = (-dt_s / self.time_s).exp();
        // 1 - exp(-2 dt/tau) without cancellation for dt << tau.
        let q = (-(-2.0 * dt_s / self.time_s).exp_m1()).sqrt();
        std::array::from_fn(|j| phi * b[j] + self.sigma_ned_m[j] * q * w[j])
    }
}

/// `a,b,c` as typed on the command line.
fn list(v: &[f64; 3]) -> String {
    format!("{},{},{}", Number(v[0]), Number(v[1]), Number(v[2]))
}

/// An injected offset [m]: to the millimetre, or to four digits when that would be long.
fn offset_m(x: f64) -> String {
    if x.abs() < 1e6 {
        format!("{x:.3}")
    } else {
        Rounded(x).to_string()
    }
}

/// The simulated receiver.
#[derive(Clone, Debug, PartialEq)]
pub struct GnssSimOptions {
    /// Fix rate [Hz]; its interval must be a whole number of truth intervals.
    pub rate_hz: f64,
    /// Position noise 1-sigma north, east, down [m] (also the fixes' reported sigma).
    pub sigma_ned_m: [f64; 3],
    /// Velocity noise 1-sigma north, east, down [m/s]; `None`: fixes without velocity.
    pub sigma_v_ned_m_s: Option<[f64; 3]>,
    /// Antenna position relative to the IMU, body forward, right, down [m].
    pub lever_arm_b_m: [f64; 3],
    /// Times without fixes.
    pub outages: Vec<Outage>,
    /// Errors injected into the positions.
    pub outliers: Vec<Outlier>,
    /// Time-correlated position error, added to the white noise; `None`: white noise only.
    pub correlated: Option<CorrelatedError>,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for GnssSimOptions {
    /// 1 Hz, 0.5 m north and east and 1 m down, no velocity, no lever arm, no outage or outlier,
    /// no correlated error, seed 0.
    fn default() -> Self {
        Self {
            rate_hz: 1.0,
            sigma_ned_m: [0.5, 0.5, 1.0],
            sigma_v_ned_m_s: None,
            lever_arm_b_m: [0.0; 3],
            outages: Vec::new(),
            outliers: Vec::new(),
            correlated: None,
            seed: 0,
        }
    }
}

/// What an outlier did to one fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Injected {
    /// The position moved by `offset_ned_m` north, east, down [m].
    Offset([f64; 3]),
    /// The values set to NaN.
    NaN,
}

/// One outlier's effect on one fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Injection {
    /// Index of the outlier in [`GnssSimOptions::outliers`].
    pub outlier: usize,
    /// Index of the fix in [`GnssSim::fixes`].
    pub fix: usize,
    /// The fix's time [s].
    pub t_s: f64,
    /// What was done.
    pub injected: Injected,
}

/// The simulated fixes and what was injected into them.
#[derive(Clone, Debug, PartialEq)]
pub struct GnssSim {
    /// The fixes, time increasing.
    pub fixes: Vec<GnssFix>,
    /// Index of each fix's truth row.
    pub truth_rows: Vec<usize>,
    /// The correlated error in each fix, north, east, down [m] (zeros without one).
    pub correlated_ned_m: Vec<[f64; 3]>,
    /// The outliers' effects, by fix.
    pub injections: Vec<Injection>,
    /// Epochs dropped by outages.
    pub dropped: usize,
    /// Outliers that reached no fix (all in outages, or outside the truth's span).
    pub missed_outliers: Vec<usize>,
}

impl GnssSim {
    /// What was simulated and injected, one line each, with the `options` it was made with.
    pub fn describe(&self, options: &GnssSimOptions) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{} fixes at {} Hz ({}), {} epochs dropped in {} outages",
            self.fixes.len(),
            options.rate_hz,
            if options.sigma_v_ned_m_s.is_some() {
                "position and velocity"
            } else {
                "position only"
            },
            self.dropped,
            options.outages.len()
        );
        if let Some(c) = &options.correlated {
            let _ = writeln!(
                s,
                "correlated error: 1-sigma N {} E {} D {} m, correlation time {} s",
                c.sigma_ned_m[0], c.sigma_ned_m[1], c.sigma_ned_m[2], c.time_s
            );
        }
        for i in &self.injections {
            let name = options.outliers[i.outlier].name();
            match i.injected {
                Injected::Offset(d) => {
                    let _ = writeln!(
                        s,
                        "t {} s (fix {}): {name} #{}: N {} E {} D {} m",
                        Number(i.t_s),
                        i.fix,
                        i.outlier,
                        offset_m(d[0]),
                        offset_m(d[1]),
                        offset_m(d[2])
                    );
                }
                Injected::NaN => {
                    let _ = writeln!(s, "t {} s (fix {}): NaN #{}", i.t_s, i.fix, i.outlier);
                }
            }
        }
        for &k in &self.missed_outliers {
            let name = options.outliers[k].name();
            let _ = writeln!(
                s,
                "{name} #{k}: reached no fix (outage or outside the truth)"
            );
        }
        s
    }
}

/// `omega_nb_b` [rad/s] at truth row `k`: the central difference of the attitude (one-sided at
/// the ends; zero for a single row).
pub fn omega_nb_b(truth: &[Truth], k: usize) -> Vector3<f64> {
    let (a, b) = (
        k.saturating_sub(1),
        (k + 1).min(truth.len().saturating_sub(1)),
    );
    if a == b {
        return Vector3::zeros();
    }
    let q = truth[a].q_b_ned.inverse() * truth[b].q_b_ned;
    rotation_vector_of(&q) / (truth[b].t_s - truth[a].t_s)
}

/// The antenna's position and velocity for `truth` turning at `omega_nb_b` [rad/s], the antenna
/// at `lever_arm_b_m` [m] (body FRD): `(position, v_ea_n [m/s])` (module docs).
pub fn antenna(
    truth: &Truth,
    omega_nb_b: &Vector3<f64>,
    lever_arm_b_m: &[f64; 3],
) -> (Position, Vector3<f64>) {
    let l_b = Vector3::from(*lever_arm_b_m);
    let c_b_n = truth.q_b_ned;
    let l_n = c_b_n * l_b;
    let position =
        Position::from_radians(truth.lat, truth.lon, truth.h).offset_ned([l_n.x, l_n.y, l_n.z]);
    let omega_en_n = LocalEarth::new(truth.lat, truth.h).omega_en_n(&truth.v_eb_ned);
    let omega_eb_b = omega_nb_b + c_b_n.inverse() * omega_en_n;
    let v_ea_n = truth.v_eb_ned + c_b_n * omega_eb_b.cross(&l_b);
    (position, v_ea_n)
}

/// `start_s <= t_s < start_s + length_s` [s].
fn within(t_s: f64, start_s: f64, length_s: f64) -> bool {
    t_s >= start_s && t_s < start_s + length_s
}

/// Simulates the receiver along `truth` (rows at a fixed rate, time increasing).
pub fn simulate(truth: &[Truth], options: &GnssSimOptions) -> Result<GnssSim> {
    let epochs = epochs(truth, options)?;
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    rng.set_stream(WHITE_STREAM);
    let mut normals = || -> [f64; 3] {
        [
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
        ]
    };
    // The correlated error's own stream: the white draws above stay as they are.
    let mut rng_c = ChaCha8Rng::seed_from_u64(options.seed);
    rng_c.set_stream(CORRELATED_STREAM);
    let mut b_ned_m = [0.0; 3];
    let mut last_t_s: Option<f64> = None;
    let mut sim = GnssSim {
        fixes: Vec::with_capacity(epochs.len()),
        truth_rows: Vec::with_capacity(epochs.len()),
        correlated_ned_m: Vec::with_capacity(epochs.len()),
        injections: Vec::new(),
        dropped: 0,
        missed_outliers: Vec::new(),
    };
    let mut spike_done = vec![false; options.outliers.len()];
    for &k in &epochs {
        let t_s = truth[k].t_s;
        let z_p = normals();
        let z_v = options.sigma_v_ned_m_s.map(|_| normals());
        // Advanced at every epoch, outages included.
        if let Some(c) = &options.correlated {
            let w: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(&mut rng_c));
            b_ned_m = match last_t_s {
                None => std::array::from_fn(|j| c.sigma_ned_m[j] * w[j]),
                Some(t0_s) => c.step(b_ned_m, t_s - t0_s, w),
            };
            last_t_s = Some(t_s);
        }
        // A one-fix outlier belongs to the first epoch at or after its time, outage or not.
        let mut once = |i: usize, at_s: f64| {
            let hit = !spike_done[i] && t_s >= at_s;
            spike_done[i] |= hit;
            hit
        };
        let effects: Vec<(usize, Injected)> = options
            .outliers
            .iter()
            .enumerate()
            .filter_map(|(i, o)| effect(o, t_s, |at_s| once(i, at_s)).map(|e| (i, e)))
            .collect();
        if options.outages.iter().any(|o| o.contains(t_s)) {
            sim.dropped += 1;
            continue;
        }
        let (position, v_ea_n) = antenna(&truth[k], &omega_nb_b(truth, k), &options.lever_arm_b_m);
        let s = options.sigma_ned_m;
        let mut d_ned: [f64; 3] = std::array::from_fn(|j| s[j] * z_p[j] + b_ned_m[j]);
        let mut nan = false;
        let fix_index = sim.fixes.len();
        for &(outlier, injected) in &effects {
            match injected {
                Injected::Offset(d) => (0..3).for_each(|j| d_ned[j] += d[j]),
                Injected::NaN => nan = true,
            }
            sim.injections.push(Injection {
                outlier,
                fix: fix_index,
                t_s,
                injected,
            });
        }
        let p = position.offset_ned(d_ned);
        let velocity = options
            .sigma_v_ned_m_s
            .zip(z_v)
            .map(|(s_v, z)| GnssVelocity {
                v_ned_m_s: [
                    v_ea_n.x + s_v[0] * z[0],
                    v_ea_n.y + s_v[1] * z[1],
                    v_ea_n.z + s_v[2] * z[2],
                ],
                sigma_ned_m_s: s_v,
            });
        let mut fix = GnssFix {
            t_s,
            lat_rad: p.lat_f64(),
            lon_rad: p.lon_f64(),
            h_m: p.h_f64(),
            sigma_ned_m: s,
            velocity,
        };
        if nan {
            (fix.lat_rad, fix.lon_rad, fix.h_m) = (f64::NAN, f64::NAN, f64::NAN);
            if let Some(v) = &mut fix.velocity {
                v.v_ned_m_s = [f64::NAN; 3];
            }
        }
        sim.fixes.push(fix);
        sim.truth_rows.push(k);
        sim.correlated_ned_m.push(b_ned_m);
    }
    sim.missed_outliers = (0..options.outliers.len())
        .filter(|&i| !sim.injections.iter().any(|j| j.outlier == i))
        .collect();
    Ok(sim)
}

/// What `outlier` does to the fix at `t_s` [s]; `once(at_s)` says whether a one-fix outlier at
/// `at_s` hits this epoch (and marks it used).
fn effect(outlier: &Outlier, t_s: f64, mut once: impl FnMut(f64) -> bool) -> Option<Injected> {
    match *outlier {
        Outlier::Jump {
            t_s: start_s,
            length_s,
            offset_ned_m,
        } => within(t_s, start_s, length_s).then_some(Injected::Offset(offset_ned_m)),
        Outlier::Spike {
            t_s: at_s,
            offset_ned_m,
        } => once(at_s).then_some(Injected::Offset(offset_ned_m)),
        Outlier::Ramp {
            start_s,
            length_s,
            final_offset_ned_m,
        } => within(t_s, start_s, length_s).then(|| {
            let u = (t_s - start_s) / length_s;
            Injected::Offset(final_offset_ned_m.map(|x| x * u))
        }),
        Outlier::NaN { t_s: at_s } => once(at_s).then_some(Injected::NaN),
    }
}

impl GnssSimOptions {
    /// Checks the options alone (before any truth is simulated): a positive rate, positive
    /// finite sigmas, a lever arm within [`MAX_LEVER_ARM_M`], a correlated error within
    /// [`MAX_CORRELATED_SIGMA_M`] and [`CORRELATION_TIME_S`], valid outages and outliers.
    pub fn check(&self) -> Result<()> {
        let o = self;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(o.rate_hz > 0.0 && o.rate_hz.is_finite()) {
            bail!(
                "GNSS rate {} Hz: must be a positive number",
                Number(o.rate_hz)
            );
        }
        // The file carries the sigmas to the filter, which refuses a fix with a zero one.
        // ... and a receiver's noise beyond these would put its fixes off the Earth model.
        let within = |s: &[f64; 3], max: f64| s.iter().all(|x| *x > 0.0 && *x <= max);
        if !within(&o.sigma_ned_m, MAX_SIGMA_M) {
            bail!(
                "GNSS position 1-sigma {} m: each must be positive and at most {MAX_SIGMA_M} m \
                 (the filter refuses a fix with a zero 1-sigma)",
                list(&o.sigma_ned_m)
            );
        }
        if let Some(v) = &o.sigma_v_ned_m_s
            && !within(v, MAX_SIGMA_V_M_S)
        {
            bail!(
                "GNSS velocity 1-sigma {} m/s: each must be positive and at most \
                 {MAX_SIGMA_V_M_S} m/s",
                list(v)
            );
        }
        let arm_m = o.lever_arm_b_m.iter().map(|x| x * x).sum::<f64>().sqrt();
        if arm_m.is_nan() || arm_m > MAX_LEVER_ARM_M {
            bail!(
                "lever arm {} m: must be finite and within {MAX_LEVER_ARM_M} m",
                list(&o.lever_arm_b_m)
            );
        }
        if let Some(bad) = o
            .outages
            .iter()
            .find(|g| !(finite(&[g.start_s, g.length_s]) && g.start_s >= 0.0 && g.length_s >= 0.0))
        {
            bail!(
                "GNSS outage at {} s for {} s: start and length must be finite and >= 0",
                Number(bad.start_s),
                Number(bad.length_s)
            );
        }
        if let Some(c) = &o.correlated {
            if !c
                .sigma_ned_m
                .iter()
                .all(|x| (0.0..=MAX_CORRELATED_SIGMA_M).contains(x))
            {
                bail!(
                    "GNSS correlated error 1-sigma {} m: each must be finite, at least 0 and at \
                     most {MAX_CORRELATED_SIGMA_M} m",
                    list(&c.sigma_ned_m)
                );
            }
            let (shortest_s, longest_s) = CORRELATION_TIME_S;
            if !(shortest_s..=longest_s).contains(&c.time_s) {
                bail!(
                    "GNSS correlated error time {} s: must be within {shortest_s} to \
                     {longest_s} s, as the filter takes it",
                    Number(c.time_s)
                );
            }
        }
        if let Some(bad) = o.outliers.iter().find(|x| !x.is_valid()) {
            bail!(
                "GNSS {} at {} s: times must be >= 0 and finite, offsets within \
                 {MAX_OUTLIER_OFFSET_M} m on each axis, lengths >= 0 (a ramp's > 0)",
                bad.name(),
                Number(bad.start_s())
            );
        }
        Ok(())
    }
}

impl GnssSimOptions {
    /// Checks the outliers against a run that ends at `end_s` [s]: a jump or ramp
    /// that lasts past it by more than one fix interval (a jump of 1e9 s in a 5 s run; a ramp
    /// that never reaches its offset) and an outlier listed twice (its offset added twice) are
    /// not the receiver asked for. Before any fix is written (`nav sim`).
    pub fn check_within_run(&self, end_s: f64) -> Result<()> {
        let interval_s = 1.0 / self.rate_hz;
        for (i, o) in self.outliers.iter().enumerate() {
            if self.outliers[..i].contains(o) {
                bail!(
                    "GNSS {} at {} s is given twice (their offsets would add): give each once",
                    o.name(),
                    Number(o.start_s())
                );
            }
            let length_s = match *o {
                Outlier::Jump { length_s, .. } | Outlier::Ramp { length_s, .. } => length_s,
                Outlier::Spike { .. } | Outlier::NaN { .. } => continue,
            };
            if o.start_s() + length_s > end_s + interval_s {
                bail!(
                    "GNSS {} at {} s for {} s ends at {} s, past the run's end at {} s: \
                     give a length of at most {} s",
                    o.name(),
                    Number(o.start_s()),
                    Number(length_s),
                    Number(o.start_s() + length_s),
                    Number(end_s),
                    Number((end_s + interval_s - o.start_s()).max(0.0))
                );
            }
        }
        Ok(())
    }
}

/// The truth rows that are GNSS epochs (module docs), after checking the options.
fn epochs(truth: &[Truth], options: &GnssSimOptions) -> Result<Vec<usize>> {
    let o = options;
    o.check()?;
    if truth.len() < 2 {
        bail!("the truth has {} rows: at least 2 are needed", truth.len());
    }
    let dt_s = truth[1].t_s - truth[0].t_s;
    if !(dt_s > 0.0 && dt_s.is_finite()) {
        bail!(
            "the truth's time does not increase ({} s, then {} s)",
            truth[0].t_s,
            truth[1].t_s
        );
    }
    let interval_s = 1.0 / o.rate_hz;
    let ratio = interval_s / dt_s;
    if ratio.round() < 1.0 || (ratio - ratio.round()).abs() > 1e-6 * ratio {
        bail!(
            "a {} Hz receiver on truth at {} Hz: the GNSS interval must be a whole number of \
             truth intervals (no interpolation)",
            Number(o.rate_hz),
            Number(1.0 / dt_s)
        );
    }
    let mut rows = Vec::new();
    let mut last_epoch = None;
    for (k, row) in truth.iter().enumerate() {
        let m = (row.t_s * o.rate_hz).round();
        if (row.t_s - m * interval_s).abs() <= 0.25 * dt_s && last_epoch != Some(m) {
            rows.push(k);
            last_epoch = Some(m);
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nav_core::attitude::from_euler;

    /// A body at rest turning about the vertical at `rate` [rad/s], 50 Hz.
    fn turning(seconds: f64, rate: f64) -> Vec<Truth> {
        (0..=(seconds * 50.0) as usize)
            .map(|k| {
                let t_s = k as f64 * 0.02;
                Truth {
                    t_s,
                    lat: 45f64.to_radians(),
                    lon: 7.5f64.to_radians(),
                    h: 250.0,
                    v_eb_ned: Vector3::zeros(),
                    q_b_ned: from_euler(0.1, -0.05, rate * t_s),
                }
            })
            .collect()
    }

    /// A jump of 1e9 s in a 5 s run, and an outlier listed twice, were simulated silently.
    #[test]
    fn outliers_past_the_run_or_listed_twice_are_refused() {
        let jump = |t_s, length_s| Outlier::Jump {
            t_s,
            length_s,
            offset_ned_m: [1.0; 3],
        };
        let with = |outliers: Vec<Outlier>| GnssSimOptions {
            rate_hz: 1.0,
            outliers,
            ..GnssSimOptions::default()
        };
        // To the last fix at 5 s (and its interval): the run's.
        with(vec![jump(1.0, 5.0), jump(0.0, 1.0)])
            .check_within_run(5.0)
            .unwrap();
        let e = with(vec![jump(1.0, 1e9)])
            .check_within_run(5.0)
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "GNSS jump at 1 s for 1e9 s ends at 1.000000001e9 s, past the run's end at 5 s: \
             give a length of at most 5 s"
        );
        let ramp = Outlier::Ramp {
            start_s: 2.0,
            length_s: 10.0,
            final_offset_ned_m: [3.0; 3],
        };
        let e = with(vec![ramp]).check_within_run(5.0).unwrap_err();
        assert!(
            e.to_string().starts_with("GNSS ramp at 2 s for 10 s"),
            "{e}"
        );
        let spike = Outlier::Spike {
            t_s: 2.0,
            offset_ned_m: [3.0; 3],
        };
        let e = with(vec![spike, jump(1.0, 1.0), spike])
            .check_within_run(5.0)
            .unwrap_err();
        assert!(e.to_string().contains("spike at 2 s is given twice"), "{e}");
    }

    #[test]
    fn epochs_are_whole_intervals_and_rates_must_divide() {
        let truth = turning(10.0, 0.0);
        let options = GnssSimOptions {
            rate_hz: 5.0,
            ..GnssSimOptions::default()
        };
        let sim = simulate(&truth, &options).unwrap();
        assert_eq!(sim.fixes.len(), 51);
        assert!(
            sim.fixes
                .windows(2)
                .all(|w| (w[1].t_s - w[0].t_s - 0.2).abs() < 1e-9)
        );
        let bad = GnssSimOptions {
            rate_hz: 3.0,
            ..GnssSimOptions::default()
        };
        let m = simulate(&truth, &bad).unwrap_err().to_string();
        assert!(m.contains("whole number of truth intervals"), "{m}");
    }

    #[test]
    fn options_a_filter_could_not_use_are_refused_with_the_reason() {
        let ok = GnssSimOptions::default();
        assert!(ok.check().is_ok());
        let cases = [
            (
                GnssSimOptions {
                    sigma_ned_m: [0.5, 0.0, 1.0],
                    ..ok.clone()
                },
                "positive",
            ),
            (
                GnssSimOptions {
                    sigma_v_ned_m_s: Some([0.1, f64::NAN, 0.1]),
                    ..ok.clone()
                },
                "positive",
            ),
            (
                GnssSimOptions {
                    lever_arm_b_m: [80.0, 80.0, 0.0],
                    ..ok.clone()
                },
                "within 100 m",
            ),
            (
                GnssSimOptions {
                    rate_hz: 0.0,
                    ..ok.clone()
                },
                "positive number",
            ),
            // An offset of 1e300 m put the fix at the pole with its usual sigma.
            (
                GnssSimOptions {
                    outliers: vec![Outlier::Spike {
                        t_s: 2.0,
                        offset_ned_m: [1e300, 0.0, 0.0],
                    }],
                    ..ok.clone()
                },
                "offsets within 100000 m",
            ),
            (
                GnssSimOptions {
                    outliers: vec![Outlier::Ramp {
                        start_s: 2.0,
                        length_s: 10.0,
                        final_offset_ned_m: [0.0, -2e5, 0.0],
                    }],
                    ..ok.clone()
                },
                "offsets within 100000 m",
            ),
        ];
        for (bad, reason) in cases {
            let m = bad.check().unwrap_err().to_string();
            assert!(m.contains(reason), "{m}");
            // The same refusal before any fix is drawn.
            assert!(simulate(&turning(2.0, 0.0), &bad).is_err());
        }
    }

    #[test]
    fn omega_is_exact_for_a_constant_rate() {
        let truth = turning(2.0, 0.3);
        let w = omega_nb_b(&truth, 40);
        // C_b_n = Rz(r t) A: omega_nb_b = r A^T z.
        let expected = truth[40].q_b_ned.inverse() * Vector3::new(0.0, 0.0, 0.3);
        assert!((w - expected).norm() < 1e-12, "{w} {expected}");
    }

    /// A body at rest at 45 deg N, `n` rows `dt_s` [s] apart.
    fn at_rest(n: usize, dt_s: f64) -> Vec<Truth> {
        (0..n)
            .map(|k| Truth {
                t_s: k as f64 * dt_s,
                lat: 45f64.to_radians(),
                lon: 7.5f64.to_radians(),
                h: 250.0,
                v_eb_ned: Vector3::zeros(),
                q_b_ned: from_euler(0.0, 0.0, 0.3),
            })
            .collect()
    }

    /// Per axis, `sum x_i y_i / sqrt(sum x_i^2 sum y_i^2)` (zero-mean correlation).
    fn correlation(x: &[[f64; 3]], y: &[[f64; 3]]) -> [f64; 3] {
        std::array::from_fn(|j| {
            let dot = |a: &[[f64; 3]], b: &[[f64; 3]]| -> f64 {
                a.iter().zip(b).map(|(p, q)| p[j] * q[j]).sum()
            };
            dot(x, y) / (dot(x, x) * dot(y, y)).sqrt()
        })
    }

    /// Per axis, the root mean square.
    fn rms(x: &[[f64; 3]]) -> [f64; 3] {
        std::array::from_fn(|j| {
            (x.iter().map(|p| p[j] * p[j]).sum::<f64>() / x.len() as f64).sqrt()
        })
    }

    #[test]
    fn the_correlated_error_is_added_on_top_of_unchanged_white_noise() {
        let truth = turning(120.0, 0.05);
        let white = GnssSimOptions {
            rate_hz: 5.0,
            sigma_v_ned_m_s: Some([0.1, 0.1, 0.2]),
            lever_arm_b_m: [0.8, -0.3, -1.1],
            outages: vec![Outage {
                start_s: 40.0,
                length_s: 20.0,
            }],
            outliers: vec![Outlier::Jump {
                t_s: 70.0,
                length_s: 5.0,
                offset_ned_m: [10.0, 0.0, -3.0],
            }],
            seed: 9,
            ..GnssSimOptions::default()
        };
        let correlated = GnssSimOptions {
            correlated: Some(CorrelatedError {
                sigma_ned_m: [2.0, 3.0, 5.0],
                time_s: 30.0,
            }),
            ..white.clone()
        };
        let a = simulate(&truth, &white).unwrap();
        let b = simulate(&truth, &correlated).unwrap();
        assert!(a.correlated_ned_m.iter().all(|d| *d == [0.0; 3]));
        assert_eq!(a.correlated_ned_m.len(), a.fixes.len());
        assert_eq!(b.correlated_ned_m.len(), b.fixes.len());
        assert_eq!(
            (a.truth_rows.clone(), a.dropped),
            (b.truth_rows.clone(), b.dropped)
        );
        assert_eq!(a.injections, b.injections);
        for ((fa, fb), (&k, d)) in a
            .fixes
            .iter()
            .zip(&b.fixes)
            .zip(a.truth_rows.iter().zip(&b.correlated_ned_m))
        {
            // The white draws are the same: velocity (drawn after the position) to the bit.
            assert_eq!(
                (fa.t_s, fa.sigma_ned_m, fa.velocity),
                (fb.t_s, fb.sigma_ned_m, fb.velocity)
            );
            let (p0, _) = antenna(&truth[k], &omega_nb_b(&truth, k), &white.lever_arm_b_m);
            let pa = Position::from_radians(fa.lat_rad, fa.lon_rad, fa.h_m);
            let pb = Position::from_radians(fb.lat_rad, fb.lon_rad, fb.h_m);
            let (da, db) = (p0.ned_to(&pa), p0.ned_to(&pb));
            for j in 0..3 {
                assert!(
                    (db[j] - da[j] - d[j]).abs() < 1e-6,
                    "{} s: {db:?} - {da:?} != {d:?}",
                    fa.t_s
                );
            }
        }
        // Something was injected, of the size asked for.
        let r = rms(&b.correlated_ned_m);
        assert!(r.iter().all(|x| *x > 0.5), "{r:?}");
        // The process runs through outages: without the outage the other fixes' errors stay.
        let c = simulate(
            &truth,
            &GnssSimOptions {
                outages: Vec::new(),
                ..correlated.clone()
            },
        )
        .unwrap();
        for (&k, d) in b.truth_rows.iter().zip(&b.correlated_ned_m) {
            let i = c.truth_rows.iter().position(|&r| r == k).unwrap();
            assert_eq!(c.correlated_ned_m[i], *d);
        }
        assert!(b.describe(&correlated).contains("correlation time 30 s"));
    }

    /// The white noise of the fixes is not the sensor simulator's: the injector of the same
    /// seed draws from stream 0, whose normals were once the fixes' noise one for one.
    #[test]
    fn the_white_noise_is_independent_of_the_sensor_simulators_draws() {
        let n = 3000;
        let options = GnssSimOptions {
            rate_hz: 1.0,
            sigma_ned_m: [1.0, 1.0, 1.0],
            seed: 17,
            ..GnssSimOptions::default()
        };
        let truth = at_rest(n, 1.0);
        let sim = simulate(&truth, &options).unwrap();
        let noise: Vec<[f64; 3]> = sim
            .fixes
            .iter()
            .zip(&sim.truth_rows)
            .map(|(f, &k)| {
                let (p0, _) = antenna(&truth[k], &Vector3::zeros(), &options.lever_arm_b_m);
                p0.ned_to(&Position::from_radians(f.lat_rad, f.lon_rad, f.h_m))
            })
            .collect();
        assert_eq!(noise.len(), n);
        // Unit white noise as drawn: 1-sigma 1 m.
        let r = rms(&noise);
        assert!(r.iter().all(|x| (x - 1.0).abs() < 0.1), "{r:?}");
        let ErrorInjectorDraws(stream0) = ErrorInjectorDraws::of(options.seed, n);
        let rho = correlation(&noise, &stream0);
        // Independent: |rho| within 4 standard errors of zero.
        let tol = 4.0 / (n as f64).sqrt();
        assert!(rho.iter().all(|r| r.abs() < tol), "{rho:?} {tol}");
    }

    /// The first `3 n` standard normals of stream 0 of `seed`, as the sensor simulator draws
    /// them, three per row.
    struct ErrorInjectorDraws(Vec<[f64; 3]>);

    impl ErrorInjectorDraws {
        fn of(seed: u64, n: usize) -> Self {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            Self(
                (0..n)
                    .map(|_| std::array::from_fn(|_| StandardNormal.sample(&mut rng)))
                    .collect(),
            )
        }
    }

    #[test]
    fn the_correlated_error_has_its_sigma_and_correlation_time() {
        // 1 Hz fixes on 1 Hz truth; 1-sigma distinct per axis, so a swap of axes fails.
        let (n, tau_s) = (120_000, 30.0);
        let sigma_ned_m = [2.0, 3.0, 5.0];
        let options = GnssSimOptions {
            correlated: Some(CorrelatedError {
                sigma_ned_m,
                time_s: tau_s,
            }),
            seed: 4,
            ..GnssSimOptions::default()
        };
        let sim = simulate(&at_rest(n, 1.0), &options).unwrap();
        let b = &sim.correlated_ned_m;
        assert_eq!(b.len(), n);
        // Large-sample standard errors of an AR(1) of coefficient phi (Bartlett), 4 of them
        // allowed: 1-sigma via the variance of the sample variance, 2 sigma^4 / N (1 + phi^2) /
        // (1 - phi^2); the lag-m autocorrelation, ((1 + phi^2)(1 - phi^2m) / (1 - phi^2) - 2 m
        // phi^2m) / N.
        let (nf, m) = (n as f64, tau_s as usize);
        let phi2 = (-2.0 / tau_s).exp();
        let ratio = (1.0 + phi2) / (1.0 - phi2);
        let tol_sigma = 4.0 * 0.5 * (2.0 * ratio / nf).sqrt();
        let phi2m = phi2.powi(m as i32);
        let tol_rho = 4.0 * ((ratio * (1.0 - phi2m) - 2.0 * m as f64 * phi2m) / nf).sqrt();
        assert!(tol_sigma < 0.05 && tol_rho < 0.1, "{tol_sigma} {tol_rho}");
        let r = rms(b);
        let rho = correlation(&b[..n - m], &b[m..]);
        for j in 0..3 {
            assert!(
                (r[j] / sigma_ned_m[j] - 1.0).abs() < tol_sigma,
                "{r:?} {tol_sigma}"
            );
            assert!(
                (rho[j] - (-1f64).exp()).abs() < tol_rho,
                "{rho:?} {tol_rho}"
            );
        }
    }

    #[test]
    fn the_correlated_error_starts_in_its_steady_state_and_steps_exactly() {
        // Across seeds: the first two epochs, dt = tau = 1 s (where an Euler step would give a
        // correlation of 0): each 1-sigma `sigma`, their correlation exp(-1).
        let truth = at_rest(2, 1.0);
        let sigma_ned_m = [2.0, 3.0, 5.0];
        let seeds = 2000;
        let (mut b0, mut b1) = (Vec::new(), Vec::new());
        for seed in 0..seeds {
            let options = GnssSimOptions {
                correlated: Some(CorrelatedError {
                    sigma_ned_m,
                    time_s: 1.0,
                }),
                seed,
                ..GnssSimOptions::default()
            };
            let sim = simulate(&truth, &options).unwrap();
            b0.push(sim.correlated_ned_m[0]);
            b1.push(sim.correlated_ned_m[1]);
        }
        // 4 standard errors of independent normals: 1-sigma 1 / sqrt(2 N), correlation (1 -
        // rho^2) / sqrt(N).
        let nf = seeds as f64;
        let rho = (-1f64).exp();
        let tol_sigma = 4.0 / (2.0 * nf).sqrt();
        let tol_rho = 4.0 * (1.0 - rho * rho) / nf.sqrt();
        let (r0, r1, c) = (rms(&b0), rms(&b1), correlation(&b0, &b1));
        for j in 0..3 {
            assert!((r0[j] / sigma_ned_m[j] - 1.0).abs() < tol_sigma, "{r0:?}");
            assert!((r1[j] / sigma_ned_m[j] - 1.0).abs() < tol_sigma, "{r1:?}");
            assert!((c[j] - rho).abs() < tol_rho, "{c:?}");
        }
    }

    #[test]
    fn a_correlated_error_out_of_range_is_refused() {
        let with = |sigma_ned_m: [f64; 3], time_s: f64| GnssSimOptions {
            correlated: Some(CorrelatedError {
                sigma_ned_m,
                time_s,
            }),
            ..GnssSimOptions::default()
        };
        // A zero 1-sigma is allowed (no error on that axis), as are the limits.
        assert!(with([0.0, 100.0, 1.0], 86_400.0).check().is_ok());
        assert!(with([1.0; 3], 1.0).check().is_ok());
        let cases = [
            (with([-0.1, 1.0, 1.0], 60.0), "1-sigma -0.1,1,1 m"),
            (with([1.0, f64::NAN, 1.0], 60.0), "1-sigma 1,NaN,1 m"),
            (with([1.0, 1.0, 100.5], 60.0), "at most 100 m"),
            (with([1.0, 1.0, f64::INFINITY], 60.0), "1-sigma 1,1,inf m"),
            (with([1.0; 3], 0.0), "time 0 s"),
            (with([1.0; 3], -5.0), "time -5 s"),
            (with([1.0; 3], f64::NAN), "time NaN s"),
            (with([1.0; 3], 86_401.0), "must be within 1 to 86400 s"),
            // Shorter than the filter takes (`nav replay` refused the receiver simulated).
            (
                with([1.0; 3], 0.001),
                "time 0.001 s: must be within 1 to 86400 s",
            ),
        ];
        for (bad, reason) in cases {
            let m = bad.check().unwrap_err().to_string();
            assert!(m.contains("correlated error") && m.contains(reason), "{m}");
            assert!(simulate(&turning(2.0, 0.0), &bad).is_err());
        }
    }

    #[test]
    fn every_makes_periodic_outages() {
        let o = Outage::every(180.0, 60.0, 120.0, 600.0);
        assert_eq!(o.len(), 3);
        assert_eq!(
            o[2],
            Outage {
                start_s: 480.0,
                length_s: 60.0
            }
        );
        assert!(o[0].contains(120.0) && o[0].contains(179.9) && !o[0].contains(180.0));
    }
}
