//! The estimator's accuracy: attitude and specific-force error against
//! truth as functions of the ratio of the oscillator frequency to the body rate and of the
//! readout noise, for the method of [Oscillator INS] as written and with the rotation compensation.
//!
//! The motion is coning, the harshest for attitude algorithms: roll `beta sin(w t)`, pitch
//! `beta cos(w t)` (half-angle `beta` = 0.2 rad), on the ground at 45 deg; the body rate is about
//! `beta w`, and the ratio is `w0 / (beta w)`. The rate is set through `w` at a fixed
//! oscillator (100 Hz, 5 kHz readout, `P` = 20 um, `Q` = 10 um, no damping).

use super::{OscillatorParams, simulate_oscillator};
use crate::trajectory::{Motion, Point, Trajectory};
use anyhow::{Result, ensure};
use nav_core::number::Number;
use nav_core::oscillator::{OscillatorConfig, OscillatorEstimator, OscillatorFault};
use nav_core::{UnitQuaternion, Vector3};
use std::f64::consts::PI;
use std::fmt::Write as _;

/// Coning on the ground: roll `beta sin(w t)`, pitch `beta cos(w t)`.
#[derive(Clone, Copy, Debug)]
pub struct Coning {
    /// Half-angle `beta` [rad].
    pub half_angle_rad: f64,
    /// Cone frequency `w` [rad/s].
    pub w_rad_s: f64,
    /// Length [s].
    pub seconds: f64,
}

impl Coning {
    /// Peak body rate relative to the ground [rad/s] (`beta w` to first order).
    pub fn rate_rad_s(&self) -> f64 {
        self.half_angle_rad * self.w_rad_s
    }
}

impl Trajectory for Coning {
    fn start(&self) -> Point {
        Point {
            lat: 45f64.to_radians(),
            lon: 7.5f64.to_radians(),
            h: 250.0,
            aux: 0.0,
        }
    }

    fn duration_s(&self) -> f64 {
        self.seconds
    }

    fn motion(&self, t: f64, _p: &Point) -> Motion {
        let (b, w) = (self.half_angle_rad, self.w_rad_s);
        let (s, c) = (w * t).sin_cos();
        Motion {
            euler: Vector3::new(b * s, b * c, 0.0),
            euler_rate: Vector3::new(b * w * c, -b * w * s, 0.0),
            ..Motion::default()
        }
    }
}

/// Errors of one estimator over one run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Accuracy {
    /// Epochs given out.
    pub epochs: usize,
    /// Periods without an epoch (acquisition, faults).
    pub faults: usize,
    /// RMS and worst attitude error after the first second [deg].
    pub attitude_rms_deg: f64,
    /// Worst attitude error [deg].
    pub attitude_max_deg: f64,
    /// Mean of the epochs' largest 1-sigma [deg].
    pub sigma_deg: f64,
    /// RMS specific-force error [m/s^2].
    pub f_rms_mps2: f64,
}

/// One row of the table: a motion and the two estimators on it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// `w0 / |omega|` [-].
    pub ratio: f64,
    /// Readout noise [m].
    pub noise_m: f64,
    /// The method of [Oscillator INS] as written.
    pub seed: Accuracy,
    /// With the rotation compensation.
    pub compensated: Accuracy,
}

/// Truth kept per readout for interpolation at the epochs' instants.
struct TruthTrack {
    t0: f64,
    dt: f64,
    q_b_i: Vec<UnitQuaternion<f64>>,
    /// Specific force at the middle of each readout interval.
    f_mid: Vec<Vector3<f64>>,
}

impl TruthTrack {
    fn q_at(&self, t: f64) -> Option<UnitQuaternion<f64>> {
        let x = (t - self.t0) / self.dt;
        let k = x.floor();
        let (i, s) = (k as usize, x - k);
        let (a, b) = (self.q_b_i.get(i)?, self.q_b_i.get(i + 1)?);
        Some(a.slerp(b, s))
    }

    fn f_at(&self, t: f64) -> Option<Vector3<f64>> {
        let x = (t - (self.t0 - 0.5 * self.dt)) / self.dt;
        let k = x.floor();
        let (i, s) = (k as usize, x - k);
        Some(self.f_mid.get(i)? * (1.0 - s) + self.f_mid.get(i + 1)? * s)
    }
}

/// Runs the oscillator along `traj` for `seconds` and both estimators on its readouts.
pub fn measure(traj: &dyn Trajectory, params: &OscillatorParams, seconds: f64) -> Result<Row> {
    params.validate()?;
    let n = params.readouts_in(seconds)? as usize;
    let mut readouts = Vec::with_capacity(n);
    let mut track = TruthTrack {
        t0: 1.0 / params.sample_rate_hz,
        dt: 1.0 / params.sample_rate_hz,
        q_b_i: Vec::with_capacity(n),
        f_mid: Vec::with_capacity(n),
    };
    let run = simulate_oscillator(traj, params, seconds, |_, s, t| {
        readouts.push(s.r_b_m);
        track.q_b_i.push(t.q_b_i);
        track.f_mid.push(t.f_ib_b);
    })?;
    ensure!(!readouts.is_empty(), "no readouts");
    let mut row = Row {
        ratio: 0.0,
        noise_m: params.readout_noise_m,
        seed: Accuracy::default(),
        compensated: Accuracy::default(),
    };
    for compensate in [false, true] {
        let mut cfg = OscillatorConfig::<f64>::new(params.sample_rate_hz, params.f0_hz);
        cfg.start_s = track.t0;
        cfg.compensate = compensate;
        let acc = estimate(&readouts, cfg, &track, &run.ellipse_i)?;
        if compensate {
            row.compensated = acc;
        } else {
            row.seed = acc;
        }
    }
    Ok(row)
}

fn estimate(
    readouts: &[Vector3<f64>],
    cfg: OscillatorConfig<f64>,
    track: &TruthTrack,
    ellipse_i: &UnitQuaternion<f64>,
) -> Result<Accuracy> {
    let mut est = OscillatorEstimator::new(cfg).map_err(|e| anyhow::anyhow!("{e}"))?;
    let half_turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), PI);
    let (mut flip, mut acc) = (None, Accuracy::default());
    let (mut sum2, mut f2, mut sigma) = (0.0, 0.0, 0.0);
    for r in readouts {
        match est.add(r) {
            Some(Ok(e)) => {
                let (Some(q_b_i), Some(f)) = (track.q_at(e.t_s), track.f_at(e.t_s)) else {
                    continue;
                };
                let truth = ellipse_i.inverse() * q_b_i;
                // The ellipse fixes the frame up to a half-turn about its normal (which apse is
                // `+p`): matched once, at the first epoch.
                let flipped = *flip.get_or_insert(e.q_b_e.angle_to(&truth) > PI / 2.0);
                let truth = if flipped { half_turn * truth } else { truth };
                if e.t_s < 1.0 {
                    continue;
                }
                let err = e.q_b_e.angle_to(&truth).to_degrees();
                acc.epochs += 1;
                sum2 += err * err;
                acc.attitude_max_deg = acc.attitude_max_deg.max(err);
                f2 += (e.f_ib_b - f).norm_squared();
                sigma += e.sigma_rad.max().to_degrees();
            }
            Some(Err(OscillatorFault::Acquiring { .. })) | None => {}
            Some(Err(_)) => acc.faults += 1,
        }
    }
    let n = acc.epochs.max(1) as f64;
    acc.attitude_rms_deg = (sum2 / n).sqrt();
    acc.f_rms_mps2 = (f2 / n).sqrt();
    acc.sigma_deg = sigma / n;
    Ok(acc)
}

/// The ratios of the table.
pub const RATIOS: [f64; 9] = [
    20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 3000.0, 10000.0, 30000.0,
];
/// Largest ratio `w0/|omega|` of the noise table (a body turning 0.003 rad/s under a 100 Hz
/// oscillator; beyond it the coning is no motion to measure).
pub const MAX_RATIO: f64 = 1e6;
/// The readout noises of the table [m].
pub const NOISES_M: [f64; 5] = [0.0, 1e-10, 1e-9, 1e-8, 1e-7];

/// The coning motion with `w0/|omega|` = `ratio` for an oscillator at `f0_hz`.
pub fn coning_for(ratio: f64, f0_hz: f64, seconds: f64) -> Coning {
    let beta = 0.2;
    Coning {
        half_angle_rad: beta,
        w_rad_s: 2.0 * PI * f0_hz / ratio / beta,
        seconds,
    }
}

/// The table against the ratio (noise-free readouts) and against noise (at `noise_ratio`).
pub fn tables(
    params: &OscillatorParams,
    seconds: f64,
    noise_ratio: f64,
) -> Result<(Vec<Row>, Vec<Row>)> {
    ensure!(
        (1.0..=MAX_RATIO).contains(&noise_ratio),
        "the noise table's ratio w0/|omega| must be within [1, {}], not {}",
        Number(MAX_RATIO),
        Number(noise_ratio)
    );
    let mut by_ratio = Vec::new();
    for ratio in RATIOS {
        let p = OscillatorParams {
            readout_noise_m: 0.0,
            ..*params
        };
        let mut row = measure(&coning_for(ratio, p.f0_hz, seconds + 1.0), &p, seconds)?;
        row.ratio = ratio;
        by_ratio.push(row);
    }
    let mut by_noise = Vec::new();
    for noise in NOISES_M {
        let p = OscillatorParams {
            readout_noise_m: noise,
            ..*params
        };
        let mut row = measure(
            &coning_for(noise_ratio, p.f0_hz, seconds + 1.0),
            &p,
            seconds,
        )?;
        row.ratio = noise_ratio;
        by_noise.push(row);
    }
    Ok((by_ratio, by_noise))
}

/// The smallest ratio at which the worst attitude error is below `deg`, interpolated in log-log
/// between the table's rows (errors fall with the ratio); `None` if no row reaches it.
pub fn ratio_needed(rows: &[Row], deg: f64, pick: fn(&Row) -> f64) -> Option<f64> {
    if rows.first().is_some_and(|r| pick(r) <= deg) {
        return rows.first().map(|r| r.ratio);
    }
    rows.windows(2).find_map(|w| {
        let (e0, e1) = (pick(&w[0]), pick(&w[1]));
        (e0 > deg && e1 <= deg).then(|| {
            let s = (deg.ln() - e0.ln()) / (e1.ln() - e0.ln());
            (w[0].ratio.ln() + s * (w[1].ratio.ln() - w[0].ratio.ln())).exp()
        })
    })
}

/// The worst attitude error [deg]; infinite when the estimator gave no epoch.
pub fn worst(a: &Accuracy) -> f64 {
    if a.epochs == 0 {
        f64::INFINITY
    } else {
        a.attitude_max_deg
    }
}

/// The tables as markdown.
pub fn render(by_ratio: &[Row], by_noise: &[Row]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Attitude error against w0/|omega| (coning, half-angle 0.2 rad; noise-free readout)\n"
    );
    let _ = writeln!(
        s,
        "| w0/|omega| | seed method: rms / max [deg] | f rms [m/s^2] | compensated: rms / max [deg] | f rms [m/s^2] |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|");
    let cell = |a: &Accuracy| {
        if a.epochs == 0 {
            format!("no epochs ({} periods refused) | -", a.faults)
        } else {
            format!(
                "{:.2e} / {:.2e} | {:.1e}",
                a.attitude_rms_deg, a.attitude_max_deg, a.f_rms_mps2
            )
        }
    };
    for r in by_ratio {
        let _ = writeln!(
            s,
            "| {:.0} | {} | {} |",
            r.ratio,
            cell(&r.seed),
            cell(&r.compensated)
        );
    }
    let fmt = |x: Option<f64>| x.map_or("beyond the table".to_string(), |r| format!("{r:.0}"));
    let seed = |r: &Row| worst(&r.seed);
    let comp = |r: &Row| worst(&r.compensated);
    let _ = writeln!(
        s,
        "\nRatio needed (worst error): 0.1 deg: seed {}, compensated {}; 0.01 deg: seed {}, compensated {}\n",
        fmt(ratio_needed(by_ratio, 0.1, seed)),
        fmt(ratio_needed(by_ratio, 0.1, comp)),
        fmt(ratio_needed(by_ratio, 0.01, seed)),
        fmt(ratio_needed(by_ratio, 0.01, comp)),
    );
    if let Some(r0) = by_noise.first() {
        let _ = writeln!(
            s,
            "Attitude error against readout noise (w0/|omega| = {:.0})\n",
            r0.ratio
        );
    }
    let _ = writeln!(
        s,
        "| noise [m] | seed: rms [deg] | compensated: rms / max [deg] | its 1-sigma [deg] | f rms [m/s^2] | periods refused |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for r in by_noise {
        let seed = if r.seed.epochs == 0 {
            "no epochs".to_string()
        } else {
            format!("{:.2e}", r.seed.attitude_rms_deg)
        };
        let c = &r.compensated;
        let compensated = if c.epochs == 0 {
            "no epochs | - | -".to_string()
        } else {
            format!(
                "{:.2e} / {:.2e} | {:.2e} | {:.1e}",
                c.attitude_rms_deg, c.attitude_max_deg, c.sigma_deg, c.f_rms_mps2
            )
        };
        let _ = writeln!(
            s,
            "| {:.0e} | {seed} | {compensated} | {} |",
            r.noise_m, c.faults
        );
    }
    s
}

/// The line of the damped run with the drive (`d`: its compensated estimator; noise 1e-9 m at
/// `noise_ratio`); says so when the run gave no epoch rather than printing zero errors.
pub fn render_damped(d: &Accuracy, noise_ratio: f64) -> String {
    let errors = if d.epochs == 0 {
        format!("no epochs ({} periods refused)", d.faults)
    } else {
        format!(
            "compensated rms / max {:.2e} / {:.2e} deg, 1-sigma {:.2e} deg, f rms {:.1e} m/s^2",
            d.attitude_rms_deg, d.attitude_max_deg, d.sigma_deg, d.f_rms_mps2
        )
    };
    format!(
        "With damping ratio 1e-3 and the drive (noise 1e-9 m, w0/|omega| = {noise_ratio:.0}): {errors}"
    )
}
