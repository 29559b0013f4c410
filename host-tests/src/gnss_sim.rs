//! A simulated GNSS receiver: fixes of the antenna from a truth trajectory, with white noise,
//! outages and injected outliers, reproducible from a seed.
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
//! All draws come from one `ChaCha8Rng::seed_from_u64(seed)` stream, in epoch order: position
//! then velocity normals for **every** epoch, those in outages included, so adding an outage or
//! an outlier leaves the noise of every other fix unchanged.
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

    /// Its times and offsets are finite, its lengths not negative.
    /// When it starts [s].
    pub fn start_s(&self) -> f64 {
        match *self {
            Self::Jump { t_s, .. } | Self::Spike { t_s, .. } | Self::NaN { t_s } => t_s,
            Self::Ramp { start_s, .. } => start_s,
        }
    }

    fn is_valid(&self) -> bool {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        // An event before the first fix would land on it.
        if self.start_s().is_nan() || self.start_s() < 0.0 {
            return false;
        }
        match self {
            Self::Jump {
                t_s,
                length_s,
                offset_ned_m,
            } => finite(&[*t_s, *length_s]) && *length_s >= 0.0 && finite(offset_ned_m),
            Self::Spike { t_s, offset_ned_m } => t_s.is_finite() && finite(offset_ned_m),
            Self::Ramp {
                start_s,
                length_s,
                final_offset_ned_m,
            } => finite(&[*start_s, *length_s]) && *length_s > 0.0 && finite(final_offset_ned_m),
            Self::NaN { t_s } => t_s.is_finite(),
        }
    }
}

/// Largest GNSS position 1-sigma `nav sim` writes [m]: a fix that poor is no fix.
pub const MAX_SIGMA_M: f64 = 1000.0;
/// Largest GNSS velocity 1-sigma `nav sim` writes [m/s].
pub const MAX_SIGMA_V_M_S: f64 = 100.0;

/// `a,b,c` as typed on the command line.
fn list(v: &[f64; 3]) -> String {
    format!("{},{},{}", v[0], v[1], v[2])
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
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for GnssSimOptions {
    /// 1 Hz, 0.5 m north and east and 1 m down, no velocity, no lever arm, no outage or outlier,
    /// seed 0.
    fn default() -> Self {
        Self {
            rate_hz: 1.0,
            sigma_ned_m: [0.5, 0.5, 1.0],
            sigma_v_ned_m_s: None,
            lever_arm_b_m: [0.0; 3],
            outages: Vec::new(),
            outliers: Vec::new(),
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
        for i in &self.injections {
            let name = options.outliers[i.outlier].name();
            match i.injected {
                Injected::Offset(d) => {
                    let _ = writeln!(
                        s,
                        "t {} s (fix {}): {name} #{}: N {:.3} E {:.3} D {:.3} m",
                        i.t_s, i.fix, i.outlier, d[0], d[1], d[2]
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
    let mut normals = || -> [f64; 3] {
        [
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
        ]
    };
    let mut sim = GnssSim {
        fixes: Vec::with_capacity(epochs.len()),
        truth_rows: Vec::with_capacity(epochs.len()),
        injections: Vec::new(),
        dropped: 0,
        missed_outliers: Vec::new(),
    };
    let mut spike_done = vec![false; options.outliers.len()];
    for &k in &epochs {
        let t_s = truth[k].t_s;
        let z_p = normals();
        let z_v = options.sigma_v_ned_m_s.map(|_| normals());
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
        let mut d_ned = [s[0] * z_p[0], s[1] * z_p[1], s[2] * z_p[2]];
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
    /// finite sigmas, a lever arm within [`MAX_LEVER_ARM_M`], valid outages and outliers.
    pub fn check(&self) -> Result<()> {
        let o = self;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(o.rate_hz > 0.0 && o.rate_hz.is_finite()) {
            bail!("GNSS rate {} Hz: must be a positive number", o.rate_hz);
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
                bad.start_s,
                bad.length_s
            );
        }
        if let Some(bad) = o.outliers.iter().find(|x| !x.is_valid()) {
            bail!(
                "GNSS {} at {} s: times must be >= 0 and finite, offsets finite, lengths >= 0 \
                 (a ramp's > 0)",
                bad.name(),
                bad.start_s()
            );
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
            o.rate_hz,
            1.0 / dt_s
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
