//! The real laser-gyro recording (`shared/data/psins-lasergyro`, see its README): heading
//! repeatability of the alignment methods over windows sliding along the recording.
//!
//! A land vehicle stood for 1,847 s at 100 Hz with its engine running and people moving: the
//! base is disturbed (angular jitter and small velocities), and there is no truth. Each method
//! aligns on every window of 30, 60, 120 and 300 s starting every [`STEP_S`] seconds; the
//! table gives, per window length and method, how many windows it solved and refused, and the
//! mean, standard deviation, minimum and maximum of the headings it gave (circular statistics:
//! deviations are taken from the mean direction, wrapped to +-180 deg). The spread over windows
//! is the method's repeatability on this base.
//!
//! - `static`: [`StaticAlignment`], levelling on the window's mean specific force and
//!   gyrocompassing its mean angular rate (heading for the window's mean attitude). Any net
//!   rotation of the body over the window (a 0.01 deg sway) shows up in the mean rate next to
//!   the Earth rate's 12.4 deg/h horizontal component here.
//! - `inertial`: [`InertialAlignment`], heading at the window's end; the body's rotations are
//!   integrated exactly, only the base's velocity disturbs it ([`nav_core::alignment::inertial`],
//!   eq. 9).
//! - `fine`: nav-core's alignment machine ([`nav_core::alignment::Aligner`]) as `nav replay
//!   --align-method fine --lever-arm 0,0,0 --imu-noise rlg` runs it: inertial coarse, then
//!   the position-aided Kalman filter, with the machine's refusal checks.
//!
//! **Checks bypassed.** The `static` and `inertial` rows call the raw estimators, without the
//! refusal checks the product applies around them (the base's stillness; the inertial-frame
//! heading's taper and base-disturbance checks): their `refused` column counts only what the
//! estimator itself refuses, and a window counted as solved may be refused by `nav replay
//! --align-method static|inertial` (on this base it refuses the first 30 s window). The table
//! says so ([`CHECKS_NOTE`]); the rows measure the estimators' repeatability, not the product's.
//!
//! Adjacent windows overlap (a 300 s window shares 270 s with the next), so the spread of the
//! long windows understates that of independent ones.
//!
//! Beside each window length, the Cramér–Rao floor of the heading for rlg-grade white noise
//! ([`Grade::Rlg`]: assumed, the recording's own noise is not documented),
//! `sqrt((ARW / (w sqrt(T)))^2 + (sqrt(12) VRW / (g w T^1.5))^2)`, `w = Omega cos(lat)`, shows
//! what a quiet base would allow (a spread below it means the recording's sensors are quieter
//! than the preset).

use crate::psins::{self, PsinsRecording};
use crate::sensor_model::Grade;
use crate::trajectory::wrap_pi;
use anyhow::{Result, ensure};
use nav_core::ImuIncrement;
use nav_core::alignment::{InertialAlignment, StaticAlignment};
use nav_core::attitude::euler;
use nav_core::earth::{OMEGA_IE, normal_gravity};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The table's note on the checks it bypasses (module docs).
pub const CHECKS_NOTE: &str = "checks: the static and inertial rows run the raw estimators \
     WITHOUT the refusal checks nav replay applies (base stillness; the inertial heading's taper \
     and base-disturbance checks): a window solved here may be refused by nav replay \
     --align-method static|inertial; the fine rows run nav-core's alignment machine with its \
     checks, as nav replay --align-method fine --lever-arm 0,0,0 --imu-noise rlg";

/// Window lengths of the table [s].
pub const WINDOWS_S: [f64; 4] = [30.0, 60.0, 120.0, 300.0];
/// A window starts every `STEP_S` seconds [s].
pub const STEP_S: f64 = 30.0;

/// The recording's place in the shared data folder, relative to this crate.
pub fn default_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/psins-lasergyro/lasergyro.imu")
}

/// An alignment method of the table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Static analytic alignment ([`StaticAlignment`]).
    Static,
    /// Inertial-frame coarse alignment ([`InertialAlignment`]).
    Inertial,
    /// Inertial coarse, then the position-aided Kalman filter (nav-core's alignment machine).
    Fine,
}

impl Method {
    /// The methods, in table order.
    pub const ALL: [Method; 3] = [Method::Static, Method::Inertial, Method::Fine];

    /// The name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Method::Static => "static",
            Method::Inertial => "inertial",
            Method::Fine => "fine",
        }
    }
}

/// Where the recording was made (its header).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Site {
    /// Latitude [rad].
    pub lat_rad: f64,
    /// Height [m].
    pub h_m: f64,
}

/// The heading [deg] that `method` gives on `window` (increments in FRD, SI), or why it gave none.
pub fn heading_deg(
    method: Method,
    window: &[ImuIncrement<f64>],
    site: &Site,
) -> Result<f64, String> {
    let yaw = match method {
        Method::Static => {
            let mut a = StaticAlignment::new();
            for inc in window {
                a.add(inc);
            }
            a.solve(site.lat_rad, site.h_m)
                .map_err(|e| e.to_string())?
                .yaw
        }
        Method::Fine => {
            // nav-core's state machine: inertial coarse for a quarter of the window (10-30 s),
            // then the position-aided Kalman filter, assuming laser-gyro noise.
            use nav_core::alignment::{AlignMethod, AlignSettings, Aligner, LeverArm, Progress};
            let rate_hz = window.len() as f64 / window.iter().map(|i| i.dt).sum::<f64>();
            let seconds = window.len() as f64 / rate_hz;
            let settings = AlignSettings::new(
                AlignMethod::Fine,
                nav_core::Position::from_radians(site.lat_rad, 0.0, site.h_m),
                seconds,
                rate_hz,
                crate::pipeline::sensor_noise(&Grade::Rlg.noise_spec()),
            )
            .map_err(|e| e.to_string())?
            .with_lever_arm(LeverArm::Known(nav_core::Vector3::zeros()));
            debug_assert_eq!(settings.samples as usize, window.len());
            let mut a = Aligner::new(settings);
            let mut last = Progress::Coarse;
            for inc in window {
                last = a.add(inc);
            }
            match last {
                Progress::Aligned(o) => euler(&o.estimate.q_b_n).2,
                Progress::Failed(f) => return Err(f.to_string()),
                Progress::Coarse | Progress::Fine => return Err("not finished".into()),
            }
        }
        Method::Inertial => {
            let window_s: f64 = window.iter().map(|i| i.dt).sum();
            let mut a = InertialAlignment::new(site.lat_rad, site.h_m, window_s);
            for inc in window {
                a.add(inc).map_err(|e| e.to_string())?;
            }
            euler(&a.estimate().map_err(|e| e.to_string())?.q_b_n).2
        }
    };
    Ok(yaw.to_degrees())
}

/// Statistics of one method over the windows of one length.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Window length [s].
    pub window_s: f64,
    /// The method.
    pub method: Method,
    /// Windows it was given.
    pub windows: usize,
    /// Headings it gave [deg], in window order.
    pub headings_deg: Vec<f64>,
    /// Refusals, with their reasons.
    pub refused: Vec<String>,
}

impl Row {
    /// Circular mean heading [deg] (NaN if none).
    pub fn mean_deg(&self) -> f64 {
        let (s, c) = self.headings_deg.iter().fold((0.0, 0.0), |(s, c), h| {
            (s + h.to_radians().sin(), c + h.to_radians().cos())
        });
        if self.headings_deg.is_empty() {
            f64::NAN
        } else {
            s.atan2(c).to_degrees()
        }
    }

    /// Deviations from the circular mean [deg], wrapped to +-180.
    pub fn deviations_deg(&self) -> Vec<f64> {
        let m = self.mean_deg().to_radians();
        self.headings_deg
            .iter()
            .map(|h| wrap_pi(h.to_radians() - m).to_degrees())
            .collect()
    }

    /// Standard deviation over the windows [deg] (NaN below two).
    pub fn std_deg(&self) -> f64 {
        let d = self.deviations_deg();
        if d.len() < 2 {
            return f64::NAN;
        }
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (d.len() - 1) as f64).sqrt()
    }

    /// Smallest and largest heading [deg], as the mean plus the extreme deviations.
    pub fn min_max_deg(&self) -> (f64, f64) {
        let d = self.deviations_deg();
        let m = self.mean_deg();
        let lo = d.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = d.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (m + lo, m + hi)
    }
}

/// The recording's increments (FRD, SI) and site.
pub fn load(path: &Path) -> Result<(Vec<ImuIncrement<f64>>, Site, PsinsRecording)> {
    // A folder was read as text: "line 1: Is a directory (os error 21)".
    ensure!(
        !path.is_dir(),
        "--data {} is a folder: give the laser-gyro recording (a PSINS .imu file)",
        path.display()
    );
    // The error names the file and the cause.
    let rec = psins::read(path)?;
    let dt = rec.header.interval_s();
    let incs = rec
        .samples
        .iter()
        .map(|s| ImuIncrement::new(s.delta_theta_ib_b, s.delta_v_ib_b, dt))
        .collect();
    let site = Site {
        lat_rad: rec.header.lat_deg.to_radians(),
        h_m: rec.header.h_m,
    };
    Ok((incs, site, rec))
}

/// Every method on every window (see the module docs).
pub fn evaluate(incs: &[ImuIncrement<f64>], site: &Site, rate_hz: f64) -> Vec<Row> {
    let step = (STEP_S * rate_hz).round() as usize;
    let mut rows = Vec::new();
    for &window_s in &WINDOWS_S {
        let len = (window_s * rate_hz).round() as usize;
        for method in Method::ALL {
            let mut row = Row {
                window_s,
                method,
                windows: 0,
                headings_deg: Vec::new(),
                refused: Vec::new(),
            };
            let mut start = 0;
            while start + len <= incs.len() {
                row.windows += 1;
                match heading_deg(method, &incs[start..start + len], site) {
                    Ok(h) => row.headings_deg.push(h),
                    Err(e) => row.refused.push(e),
                }
                start += step;
            }
            rows.push(row);
        }
    }
    rows
}

/// Cramér–Rao floor of the heading [deg] after `t_s` [s] at `site` for white noise of
/// densities `arw` [rad/sqrt(s)] and `vrw` [m/s/sqrt(s)].
pub fn heading_floor_deg(site: &Site, t_s: f64, arw: f64, vrw: f64) -> f64 {
    let w = OMEGA_IE * site.lat_rad.cos();
    let g = normal_gravity(site.lat_rad, site.h_m);
    ((arw / (w * t_s.sqrt())).powi(2) + (12f64.sqrt() * vrw / (g * w * t_s.powf(1.5))).powi(2))
        .sqrt()
        .to_degrees()
}

/// Runs the benchmark on the recording at `path` and returns the table.
pub fn run(path: &Path) -> Result<String> {
    let (incs, site, rec) = load(path)?;
    let rate_hz = rec.header.rate_hz();
    ensure!(
        incs.len() as f64 >= WINDOWS_S[3] * rate_hz,
        "the recording is shorter than the longest window"
    );
    let rows = evaluate(&incs, &site, rate_hz);
    let rlg = Grade::Rlg.model();
    let (arw, vrw) = (
        rlg.gyro.white_noise.density(),
        rlg.accel.white_noise.density(),
    );
    let mut out = String::new();
    let h = rec.header;
    writeln!(
        out,
        "PSINS laser-gyro recording: {} samples at {} Hz ({:.1} s), {:.6} N {:.6} E, {} m; \
         heading (true, NED, deg) from windows starting every {STEP_S} s; header yaw0 {} deg \
         (PSINS, north-west positive: heading {} deg, 'maybe inaccurate')",
        incs.len(),
        rate_hz,
        incs.len() as f64 / rate_hz,
        h.lat_deg,
        h.lon_deg,
        h.h_m,
        h.yaw0_deg,
        -h.yaw0_deg
    )?;
    writeln!(out, "{CHECKS_NOTE}")?;
    writeln!(
        out,
        "| window | method | windows | refused | mean | std | min | max | floor (rlg noise, assumed) |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|---|---|")?;
    for r in &rows {
        let (lo, hi) = r.min_max_deg();
        writeln!(
            out,
            "| {:.0} s | {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            r.window_s,
            r.method.name(),
            r.windows,
            r.refused.len(),
            r.mean_deg(),
            r.std_deg(),
            lo,
            hi,
            heading_floor_deg(&site, r.window_s, arw, vrw)
        )?;
    }
    let mut reasons: Vec<(String, &str, usize)> = Vec::new();
    for r in &rows {
        for e in &r.refused {
            let key = format!("{:.0} s {}", r.window_s, r.method.name());
            match reasons.iter_mut().find(|x| x.0 == key && x.1 == e) {
                Some(x) => x.2 += 1,
                None => reasons.push((key, e, 1)),
            }
        }
    }
    for (key, e, n) in reasons {
        writeln!(out, "refused: {key}: {n} x {e}")?;
    }
    Ok(out)
}
