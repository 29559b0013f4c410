//! A navigation solution compared with a truth trajectory: errors, statistics, a table and SVG
//! plots (`nav report`).
//!
//! Each solution row is compared with the truth at the same time: the truth is interpolated
//! linearly in time between its rows (latitude, longitude, height, velocity; attitude by slerp).
//! Solution rows outside the truth's time span (with 1 us of slack, the solution log's
//! resolution) are skipped and counted, and so are rows inside a gap of the truth (an interval
//! over [`TRUTH_GAP_FACTOR`] times its median: a straight line across it is not the
//! trajectory). Errors are solution minus truth:
//! - position north and east [m]: the latitude and longitude differences times the radii of
//!   curvature at the truth (`(R_N + h) dlat`, `(R_E + h) cos(lat) dlon`), their horizontal
//!   norm, and the height difference [m];
//! - velocity north, east, down [m/s];
//! - roll, pitch and yaw differences [deg], each wrapped to [-180, 180), and the total rotation
//!   angle of `q_true^-1 q_sol` [deg] (free of the Euler angles' singularities).
//!
//! An aided run's log carries the filter's own 1-sigma ([`crate::sigma_log`]): the table then
//! adds, per quantity, the share of rows whose error is within 3 sigma and the RMS of the
//! normalised error (1 for an honest sigma), and the plots draw the ±3-sigma envelope beside
//! each error.
//!
//! A solution log ends with its end record (`# end: N rows, ok`, [`EndRecord`]), which only a
//! run that finished writes. A CSV solution without it is still compared (the rows it has are
//! valid), with a warning on stderr that the run was cut short; the exit status stays 0. An end
//! record whose count differs from the rows read, or anything after it, is an error. The rows
//! at and after a free-inertial log's lost record ([`LostRecord`]: an IMU gap beyond the
//! bridge lost the solution there) are not compared, and the report says how many.

use crate::sigma_log::{self, Sigma};
use crate::truth::{TRUTH_GAP_FACTOR, Truth, median_interval_s};
use crate::{kf_gins, truth_csv};
use anyhow::{Context, Result, anyhow, bail, ensure};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use nav_core::attitude::euler;
use nav_core::earth::radii;
use nav_core::number::Number;
use nav_core::output::{EndRecord, LostRecord};
use plotters::prelude::*;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{self, BufRead, BufReader, IsTerminal, Read, Write as _};
use std::path::{Path, PathBuf};

/// Slack [s] at the ends of the truth's span: the solution log's time resolution.
pub const SPAN_SLACK_S: f64 = 1e-6;

/// Files at least this large [bytes] get a progress bar while read (when stderr is a terminal).
const PROGRESS_MIN_BYTES: u64 = 4 << 20;

/// At most this many points per plotted line (min and max of each bucket are kept).
const PLOT_MAX_POINTS: usize = 4000;

/// The errors of one solution row (solution minus truth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorSample {
    /// Time of the solution row [s].
    pub t_s: f64,
    /// Position error north, `(R_N + h) (lat_sol - lat_true)` [m].
    pub north_m: f64,
    /// Position error east, `(R_E + h) cos(lat) (lon_sol - lon_true)` [m].
    pub east_m: f64,
    /// Horizontal position error, `hypot(north, east)` [m].
    pub horizontal_m: f64,
    /// Height error, `h_sol - h_true` [m].
    pub height_m: f64,
    /// Velocity error `v_eb_ned` north, east, down [m/s].
    pub v_ned_mps: [f64; 3],
    /// Roll error [deg], in [-180, 180).
    pub roll_deg: f64,
    /// Pitch error [deg].
    pub pitch_deg: f64,
    /// Yaw (heading) error [deg], in [-180, 180).
    pub yaw_deg: f64,
    /// Rotation angle of `q_true^-1 q_sol` [deg], in [0, 180].
    pub rotation_deg: f64,
    /// The solution's own 1-sigma, when its log has them (an aided run's).
    pub sigma: Option<Sigma>,
}

/// The errors of a solution against a truth.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorSeries {
    /// Time of the truth's first row [s] (the start of a simulated recording): the origin of
    /// relative times.
    pub t_start_s: f64,
    /// The truth's time span [s].
    pub truth_span_s: (f64, f64),
    /// One sample per compared solution row, in solution order.
    pub samples: Vec<ErrorSample>,
    /// Solution rows skipped because they are before the truth's span.
    pub skipped_before: usize,
    /// Solution rows skipped because they are after the truth's span.
    pub skipped_after: usize,
    /// Solution rows skipped because they fall in a gap of the truth longer than
    /// [`TRUTH_GAP_FACTOR`] times its median interval (interpolated across it, the truth is
    /// not the trajectory).
    pub skipped_in_gaps: usize,
    /// The longest interval between truth rows the comparison interpolates across [s].
    pub max_truth_interval_s: f64,
}

/// An error quantity of an [`ErrorSample`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// Position north [m].
    North,
    /// Position east [m].
    East,
    /// Horizontal position [m].
    Horizontal,
    /// Height [m].
    Height,
    /// Velocity north [m/s].
    VelocityNorth,
    /// Velocity east [m/s].
    VelocityEast,
    /// Velocity down [m/s].
    VelocityDown,
    /// Roll [deg].
    Roll,
    /// Pitch [deg].
    Pitch,
    /// Yaw [deg].
    Yaw,
    /// Total attitude rotation [deg].
    Rotation,
}

impl Quantity {
    /// Every quantity, in table order.
    pub const ALL: [Self; 11] = [
        Self::North,
        Self::East,
        Self::Horizontal,
        Self::Height,
        Self::VelocityNorth,
        Self::VelocityEast,
        Self::VelocityDown,
        Self::Roll,
        Self::Pitch,
        Self::Yaw,
        Self::Rotation,
    ];

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            Self::North => "north",
            Self::East => "east",
            Self::Horizontal => "horizontal",
            Self::Height => "height",
            Self::VelocityNorth => "v north",
            Self::VelocityEast => "v east",
            Self::VelocityDown => "v down",
            Self::Roll => "roll",
            Self::Pitch => "pitch",
            Self::Yaw => "yaw",
            Self::Rotation => "rotation",
        }
    }

    /// Unit.
    pub fn unit(self) -> &'static str {
        match self {
            Self::North | Self::East | Self::Horizontal | Self::Height => "m",
            Self::VelocityNorth | Self::VelocityEast | Self::VelocityDown => "m/s",
            Self::Roll | Self::Pitch | Self::Yaw | Self::Rotation => "deg",
        }
    }

    /// The solution's 1-sigma of the quantity in `e`, when it has one (not for the horizontal
    /// distance and the rotation angle, whose distributions are not symmetric about zero).
    pub fn sigma(self, e: &ErrorSample) -> Option<f64> {
        let k = match self {
            Self::North => 0,
            Self::East => 1,
            // The height error is minus the down error: the same 1-sigma.
            Self::Height => 2,
            Self::VelocityNorth => 3,
            Self::VelocityEast => 4,
            Self::VelocityDown => 5,
            Self::Roll => 6,
            Self::Pitch => 7,
            Self::Yaw => 8,
            Self::Horizontal | Self::Rotation => return None,
        };
        e.sigma.map(|s| s[k])
    }

    /// The quantity's value in `e`.
    pub fn of(self, e: &ErrorSample) -> f64 {
        match self {
            Self::North => e.north_m,
            Self::East => e.east_m,
            Self::Horizontal => e.horizontal_m,
            Self::Height => e.height_m,
            Self::VelocityNorth => e.v_ned_mps[0],
            Self::VelocityEast => e.v_ned_mps[1],
            Self::VelocityDown => e.v_ned_mps[2],
            Self::Roll => e.roll_deg,
            Self::Pitch => e.pitch_deg,
            Self::Yaw => e.yaw_deg,
            Self::Rotation => e.rotation_deg,
        }
    }
}

/// Statistics of one quantity over a series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorStats {
    /// Root mean square, in the quantity's unit.
    pub rms: f64,
    /// Largest absolute value, in the quantity's unit.
    pub max_abs: f64,
    /// Time of the largest absolute value (its first occurrence) [s].
    pub t_max_s: f64,
}

/// A quantity's errors over the solution's 1-sigma.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalisedStats {
    /// RMS of error / sigma (1 when the sigma is honest).
    pub rms: f64,
    /// Share of rows with |error| <= 3 sigma (0.997 for a Gaussian error and an honest sigma).
    pub within_3_sigma: f64,
}

impl ErrorSeries {
    /// Statistics of `q`; `None` for an empty series.
    pub fn stats(&self, q: Quantity) -> Option<ErrorStats> {
        let first = self.samples.first()?;
        let mut sum2 = 0.0;
        let (mut max_abs, mut t_max_s) = (q.of(first).abs(), first.t_s);
        for e in &self.samples {
            let x = q.of(e);
            sum2 += x * x;
            if x.abs() > max_abs {
                (max_abs, t_max_s) = (x.abs(), e.t_s);
            }
        }
        Some(ErrorStats {
            rms: (sum2 / self.samples.len() as f64).sqrt(),
            max_abs,
            t_max_s,
        })
    }

    /// The errors of `q` over the solution's own 1-sigma, on the rows that have one (and a
    /// positive one); `None` when none has.
    pub fn normalised(&self, q: Quantity) -> Option<NormalisedStats> {
        let z: Vec<f64> = self
            .samples
            .iter()
            .filter_map(|e| q.sigma(e).filter(|s| *s > 0.0).map(|s| q.of(e) / s))
            .collect();
        if z.is_empty() {
            return None;
        }
        let n = z.len() as f64;
        Some(NormalisedStats {
            rms: (z.iter().map(|z| z * z).sum::<f64>() / n).sqrt(),
            within_3_sigma: z.iter().filter(|z| z.abs() <= 3.0).count() as f64 / n,
        })
    }

    /// The sample nearest in time to `t_s` [s] (the earlier one on a tie); `None` when empty.
    pub fn nearest(&self, t_s: f64) -> Option<&ErrorSample> {
        let k = self.samples.partition_point(|e| e.t_s < t_s);
        let after = self.samples.get(k);
        let before = k.checked_sub(1).and_then(|i| self.samples.get(i));
        match (before, after) {
            (Some(b), Some(a)) => Some(if t_s - b.t_s <= a.t_s - t_s { b } else { a }),
            (b, a) => b.or(a),
        }
    }
}

/// Compares `solution` with `truth` (both in time order; see the module docs). Errors when the
/// truth is empty or not in time order, or when no solution row lies within the truth's span.
pub fn compare(solution: &[Truth], truth: &[Truth]) -> Result<ErrorSeries> {
    compare_with_sigma(solution, None, truth)
}

/// [`compare`], each error with its solution row's 1-sigma from `sigma` (one per row).
pub fn compare_with_sigma(
    solution: &[Truth],
    sigma: Option<&[Sigma]>,
    truth: &[Truth],
) -> Result<ErrorSeries> {
    if let Some(sigma) = sigma {
        ensure!(
            sigma.len() == solution.len(),
            "{} rows of 1-sigma for {} solution rows",
            sigma.len(),
            solution.len()
        );
    }
    let (Some(first), Some(last)) = (truth.first(), truth.last()) else {
        bail!("the truth has no rows");
    };
    let Some(start) = solution.first() else {
        bail!("the solution has no rows");
    };
    // Interpolation between truth rows needs their times strictly increasing.
    if let Some(k) = truth.windows(2).position(|w| w[1].t_s <= w[0].t_s) {
        let how = if truth[k + 1].t_s == truth[k].t_s {
            "repeats"
        } else {
            "goes backwards"
        };
        bail!(
            "truth time {how} at row {}: {} s after {} s",
            k + 2,
            truth[k + 1].t_s,
            truth[k].t_s
        );
    }
    let (t0, t1) = (first.t_s, last.t_s);
    let max_truth_interval_s = TRUTH_GAP_FACTOR * median_interval_s(truth);
    let mut series = ErrorSeries {
        t_start_s: t0,
        truth_span_s: (t0, t1),
        samples: Vec::with_capacity(solution.len()),
        skipped_before: 0,
        skipped_after: 0,
        skipped_in_gaps: 0,
        max_truth_interval_s,
    };
    for (k, s) in solution.iter().enumerate() {
        match interpolate(truth, s.t_s) {
            Some(_) if in_gap(truth, s.t_s, max_truth_interval_s) => series.skipped_in_gaps += 1,
            Some(t) => series.samples.push(ErrorSample {
                sigma: sigma.map(|sigma| sigma[k]),
                ..errors(s, &t)
            }),
            None if s.t_s < t0 => series.skipped_before += 1,
            None => series.skipped_after += 1,
        }
    }
    if series.samples.is_empty() {
        let t_end = solution.last().map_or(start.t_s, |s| s.t_s);
        let gaps = if series.skipped_in_gaps > 0 {
            format!(
                "; {} rows fall in gaps of the truth longer than {} s",
                series.skipped_in_gaps,
                Number(max_truth_interval_s)
            )
        } else {
            String::new()
        };
        bail!(
            "no solution row within the truth's time span [{t0}, {t1}] s (the solution spans \
             [{}, {t_end}] s){gaps}",
            start.t_s
        );
    }
    Ok(series)
}

/// Whether `t_s` lies strictly between two truth rows more than `max_interval_s` apart.
fn in_gap(truth: &[Truth], t_s: f64, max_interval_s: f64) -> bool {
    let k = truth.partition_point(|r| r.t_s <= t_s);
    match (k.checked_sub(1).and_then(|i| truth.get(i)), truth.get(k)) {
        (Some(a), Some(b)) => a.t_s < t_s && b.t_s - a.t_s > max_interval_s,
        _ => false,
    }
}

/// The truth at `t_s` [s]: linear in time between the rows around it, attitude by slerp; `None`
/// outside the span (beyond [`SPAN_SLACK_S`]). `truth` must be in time order.
pub fn interpolate(truth: &[Truth], t_s: f64) -> Option<Truth> {
    let (first, last) = (truth.first()?, truth.last()?);
    if !(t_s >= first.t_s - SPAN_SLACK_S && t_s <= last.t_s + SPAN_SLACK_S) {
        return None;
    }
    // The first row later than t_s; the row before it is at or before t_s.
    let k = truth.partition_point(|r| r.t_s <= t_s);
    let (a, b) = match k {
        0 => return Some(Truth { t_s, ..*first }),
        k if k == truth.len() => return Some(Truth { t_s, ..*last }),
        k => (&truth[k - 1], &truth[k]),
    };
    if a.t_s == t_s {
        // On a row: exactly that row (slerp at 0 would round).
        return Some(*a);
    }
    // a.t_s < t_s < b.t_s, so the span is positive.
    let f = (t_s - a.t_s) / (b.t_s - a.t_s);
    let lerp = |x: f64, y: f64| x + f * (y - x);
    let q_b_ned = a
        .q_b_ned
        .try_slerp(&b.q_b_ned, f, 1e-12)
        // Half a turn between rows: no unique path; take the nearer row.
        .unwrap_or(if f < 0.5 { a.q_b_ned } else { b.q_b_ned });
    Some(Truth {
        t_s,
        lat: lerp(a.lat, b.lat),
        lon: wrap_pi(a.lon + f * wrap_pi(b.lon - a.lon)),
        h: lerp(a.h, b.h),
        v_eb_ned: a.v_eb_ned + (b.v_eb_ned - a.v_eb_ned) * f,
        q_b_ned,
    })
}

/// The errors of `sol` against `truth` at the same time.
fn errors(sol: &Truth, truth: &Truth) -> ErrorSample {
    let (r_n, r_e) = radii(truth.lat);
    let north_m = (sol.lat - truth.lat) * (r_n + truth.h);
    let east_m = wrap_pi(sol.lon - truth.lon) * (r_e + truth.h) * truth.lat.cos();
    let (roll_s, pitch_s, yaw_s) = euler(&sol.q_b_ned);
    let (roll_t, pitch_t, yaw_t) = euler(&truth.q_b_ned);
    let dq = truth.q_b_ned.inverse() * sol.q_b_ned;
    // 2 atan2(|v|, |w|): accurate for small angles too (acos(|w|) is not).
    let rotation = 2.0 * dq.imag().norm().atan2(dq.w.abs());
    let dv = sol.v_eb_ned - truth.v_eb_ned;
    ErrorSample {
        t_s: sol.t_s,
        north_m,
        east_m,
        horizontal_m: north_m.hypot(east_m),
        height_m: sol.h - truth.h,
        v_ned_mps: [dv.x, dv.y, dv.z],
        roll_deg: wrap_pi(roll_s - roll_t).to_degrees(),
        pitch_deg: (pitch_s - pitch_t).to_degrees(),
        yaw_deg: wrap_pi(yaw_s - yaw_t).to_degrees(),
        rotation_deg: rotation.to_degrees(),
        sigma: None,
    }
}

/// `a` [rad] wrapped to [-pi, pi).
fn wrap_pi(a: f64) -> f64 {
    (a + PI).rem_euclid(2.0 * PI) - PI
}

/// A trajectory file as read ([`read_trajectory_file`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    /// The rows, in file order.
    pub rows: Vec<Truth>,
    /// The file is a KF-GINS `.nav` file (otherwise the solution log's CSV).
    pub kf_gins: bool,
    /// The solution log's end record, if the file has one (its count matches `rows`).
    pub end: Option<EndRecord>,
    /// The first record of a solution lost by an IMU gap, if the log has one: the rows at
    /// or after its time are no solution.
    pub lost: Option<LostRecord>,
}

/// Reads a trajectory: a CSV with the solution log's header (truth files, `nav replay` logs), a
/// KF-GINS `.nav` file (first data line all numbers), or a gnss-ins-sim output folder's
/// reference trajectory ([`crate::gnss_ins_sim::read_truth`]). Shows a progress bar for large files when
/// `progress` is set and stderr is a terminal.
///
/// The readers stream ([`truth_csv::TruthReader`], [`kf_gins::NavReader`]); the rows are held
/// here because the comparison's result holds one error sample per solution row anyway (the
/// statistics, the table at chosen times and the plots are made from the whole series), and the
/// truth is interpolated at each solution time by a search over all its rows.
pub fn read_trajectory(path: &Path, progress: bool) -> Result<Vec<Truth>> {
    Ok(read_trajectory_file(path, progress)?.rows)
}

/// [`read_trajectory`], with the file's format and its end record (see the module docs).
pub fn read_trajectory_file(path: &Path, progress: bool) -> Result<Trajectory> {
    if path.is_dir() {
        // A gnss-ins-sim output folder: its reference trajectory.
        return Ok(Trajectory {
            rows: crate::gnss_ins_sim::read_truth(path)?,
            kf_gins: false,
            end: None,
            lost: None,
        });
    }
    let file = File::open(path).with_context(|| format!("{}", path.display()))?;
    let len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let bar = (progress && len >= PROGRESS_MIN_BYTES && std::io::stderr().is_terminal())
        .then(|| progress_bar(path, len));
    let reader: Box<dyn Read> = match &bar {
        Some(bar) => Box::new(bar.wrap_read(file)),
        None => Box::new(file),
    };
    let mut reader = BufReader::new(reader);
    let is_kf_gins = first_data_line(&mut reader)
        .with_context(|| format!("{}", path.display()))?
        .is_some_and(|line| {
            line.split([' ', '\t', ','])
                .all(|f| f.is_empty() || f.parse::<f64>().is_ok())
        });
    let mut lines = EndRecordFilter::new(reader);
    let rows = if is_kf_gins {
        kf_gins::read_truth_from(BufReader::new(&mut lines), path).map_err(anyhow::Error::from)
    } else {
        truth_csv::read_from(&mut lines, path).map_err(anyhow::Error::from)
    };
    // Cleared on errors too, so the message is not printed after a stale bar.
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let rows = rows?;
    if let Some(end) = lines.end
        && end.rows as usize != rows.len()
    {
        bail!(
            "{}: line {}: the end record says {} rows, the file has {}",
            path.display(),
            lines.line,
            end.rows,
            rows.len()
        );
    }
    Ok(Trajectory {
        rows,
        kf_gins: is_kf_gins,
        end: lines.end,
        lost: lines.lost,
    })
}

/// Passes a file's lines on, one at a time, up to the solution log's end record, which it keeps
/// instead; a malformed end record, or anything but blank lines after it, is an error.
struct EndRecordFilter<R> {
    inner: R,
    /// Lines read so far (the number of the current one).
    line: usize,
    /// The current line and how much of it was passed on.
    buf: Vec<u8>,
    at: usize,
    end: Option<EndRecord>,
    /// The first lost record seen (passed on too: a comment).
    lost: Option<LostRecord>,
}

impl<R: BufRead> EndRecordFilter<R> {
    fn new(inner: R) -> Self {
        Self {
            inner,
            line: 0,
            buf: Vec::new(),
            at: 0,
            end: None,
            lost: None,
        }
    }

    /// Reads the next line into `buf`, unless it is the end record or follows it; `false` at
    /// the end of the file.
    fn next_line(&mut self) -> io::Result<bool> {
        loop {
            self.buf.clear();
            self.at = 0;
            if self.inner.read_until(b'\n', &mut self.buf)? == 0 {
                return Ok(false);
            }
            self.line += 1;
            let text = String::from_utf8_lossy(&self.buf);
            let bad = |what: String| io::Error::new(io::ErrorKind::InvalidData, what);
            if let Some(end) = self.end {
                if text.trim().is_empty() {
                    continue;
                }
                return Err(bad(format!(
                    "line {}: text after the end record '{end}'",
                    self.line
                )));
            }
            if self.lost.is_none() {
                self.lost = LostRecord::parse(&text);
            }
            match EndRecord::parse(&text) {
                None => return Ok(true),
                Some(Ok(end)) => self.end = Some(end),
                Some(Err(e)) => return Err(bad(format!("line {}: {e}", self.line))),
            }
        }
    }
}

impl<R: BufRead> Read for EndRecordFilter<R> {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        if self.at == self.buf.len() && !self.next_line()? {
            return Ok(0);
        }
        let n = (&self.buf[self.at..]).read(out)?;
        self.at += n;
        Ok(n)
    }
}

/// The first line that is not blank or a `#`/`%` comment, without consuming the buffer.
fn first_data_line<R: BufRead>(reader: &mut R) -> std::io::Result<Option<String>> {
    let head = reader.fill_buf()?;
    let text = String::from_utf8_lossy(head);
    Ok(text
        .trim_start_matches('\u{feff}')
        .lines()
        .map(str::trim)
        .find(|l| !(l.is_empty() || l.starts_with('#') || l.starts_with('%')))
        .map(str::to_owned))
}

fn progress_bar(path: &Path, len: u64) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{msg} [{bar:40}] {bytes}/{total_bytes} ({eta})")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(format!("reading {}", path.display()));
    bar
}

/// `x` with about 4 significant digits, fixed-point when readable.
fn number(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e6).contains(&a) {
        format!("{x:.3e}")
    } else {
        let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{x:.decimals$}")
    }
}

/// The statistics table: one row per [`Quantity`], columns RMS, max |e|, its time and the value
/// at each time of `at_s` [s since [`ErrorSeries::t_start_s`]] (nearest compared row).
pub fn format_table(series: &ErrorSeries, at_s: &[f64]) -> String {
    let t0 = series.t_start_s;
    let mut header = vec![
        "error (solution - truth)".to_owned(),
        "RMS".to_owned(),
        "max |e|".to_owned(),
        "t(max) - t0 [s]".to_owned(),
    ];
    let at_rows: Vec<Option<&ErrorSample>> = at_s.iter().map(|&t| series.nearest(t0 + t)).collect();
    let with_sigma = series.samples.iter().any(|e| e.sigma.is_some());
    if with_sigma {
        header.extend(["|e| <= 3 sigma".to_owned(), "RMS e/sigma".to_owned()]);
    }
    header.extend(at_s.iter().map(|t| format!("at t0 + {} s", Number(*t))));
    let mut rows = vec![header];
    for q in Quantity::ALL {
        let Some(s) = series.stats(q) else { continue };
        let mut row = vec![
            format!("{} [{}]", q.name(), q.unit()),
            number(s.rms),
            number(s.max_abs),
            format!("{:.3}", s.t_max_s - t0),
        ];
        if with_sigma {
            row.extend(match series.normalised(q) {
                Some(n) => [
                    format!("{:.1} %", 100.0 * n.within_3_sigma),
                    format!("{:.2}", n.rms),
                ],
                None => ["-".to_owned(), "-".to_owned()],
            });
        }
        row.extend(
            at_rows
                .iter()
                .map(|e| e.map_or("-".into(), |e| number(q.of(e)))),
        );
        rows.push(row);
    }
    let widths: Vec<usize> = (0..rows[0].len())
        .map(|c| rows.iter().map(|r| r[c].len()).max().unwrap_or(0))
        .collect();
    let mut out = String::new();
    for row in &rows {
        for (c, cell) in row.iter().enumerate() {
            if c == 0 {
                let _ = write!(out, "{cell:<w$}", w = widths[c]);
            } else {
                let _ = write!(out, "  {cell:>w$}", w = widths[c]);
            }
        }
        out.push('\n');
    }
    for (&t, e) in at_s.iter().zip(&at_rows) {
        if let Some(e) = e
            && (e.t_s - (t0 + t)).abs() > SPAN_SLACK_S
        {
            let _ = writeln!(
                out,
                "at t0 + {} s: the nearest compared row is at t0 + {:.6} s",
                Number(t),
                e.t_s - t0
            );
        }
    }
    out
}

/// Refuses a time of `at_s` [s since [`ErrorSeries::t_start_s`]] farther outside the
/// compared rows' span than their median interval: its nearest row's error was printed under
/// its label (`--at 1e9` gave the last row's, `--at -5` the first's).
pub fn check_at_times(series: &ErrorSeries, at_s: &[f64]) -> Result<()> {
    let (Some(first), Some(last)) = (series.samples.first(), series.samples.last()) else {
        return Ok(());
    };
    let mut intervals_s: Vec<f64> = series
        .samples
        .windows(2)
        .map(|w| w[1].t_s - w[0].t_s)
        .collect();
    intervals_s.sort_by(f64::total_cmp);
    let slack_s = intervals_s
        .get(intervals_s.len() / 2)
        .copied()
        .unwrap_or(0.0)
        + SPAN_SLACK_S;
    let t0 = series.t_start_s;
    for &t in at_s {
        let t_s = t0 + t;
        if t_s < first.t_s - slack_s || t_s > last.t_s + slack_s {
            bail!(
                "--at {} s is outside the compared rows' span, t0 + {:.6} .. {:.6} s (t0 = {} \
                 s, the truth's first row): give times within it",
                Number(t),
                first.t_s - t0,
                last.t_s - t0,
                Number(t0)
            );
        }
    }
    Ok(())
}

/// Compares the trajectory files `solution` and `truth` (see [`read_trajectory`]) and returns
/// the report: what was compared, the table of [`format_table`] and, with `plots`, the SVG files
/// written there (see [`write_plots`]).
pub fn report_files(
    solution: &Path,
    truth: &Path,
    at_s: &[f64],
    plots: Option<&Path>,
) -> Result<String> {
    if let Some(t) = at_s.iter().find(|t| !t.is_finite()) {
        bail!("--at {t}: expected finite times in seconds");
    }
    let Trajectory {
        rows: mut sol,
        kf_gins,
        end,
        lost,
    } = read_trajectory_file(solution, true)?;
    let complete = if end.is_some() || kf_gins {
        ""
    } else {
        // A KF-GINS solution has no end record to miss.
        eprintln!(
            "warning: {}: no end record ('{} N rows, ok'): the run that wrote this log did \
             not finish (it failed, crashed or was stopped); comparing the {} rows it has",
            solution.display(),
            EndRecord::PREFIX,
            sol.len()
        );
        ", no end record: cut short"
    };
    let mut sigma = if kf_gins {
        None
    } else {
        sigma_log::read(solution)?
    };
    let file_rows = sol.len();
    // The rows after an IMU gap that lost the solution (the log's lost record) look valid.
    let lost_rows = lost.map(|l| {
        let t_s = l.t_us as f64 * 1e-6;
        let keep = sol.iter().position(|r| r.t_s >= t_s).unwrap_or(sol.len());
        let n = sol.len() - keep;
        sol.truncate(keep);
        if let Some(sigma) = &mut sigma {
            sigma.truncate(keep);
        }
        format!(
            "not compared: the {n} rows from t = {} s on, after an IMU gap that lost the \
             solution (the log's lost record)\n",
            Number(t_s)
        )
    });
    let tru = read_trajectory(truth, true)?;
    let series = compare_with_sigma(&sol, sigma.as_deref(), &tru).with_context(|| {
        format!(
            "comparing the solution {} with the truth {}",
            solution.display(),
            truth.display()
        )
    })?;
    check_at_times(&series, at_s)?;
    let (t_a, t_b) = series.truth_span_s;
    let mut out = format!(
        "solution {} ({} rows{complete}) against truth {} ({} rows, t = {t_a} .. {t_b} s)\n\
         compared {} rows, skipped {} before and {} after the truth's span; t0 = {} s (the \
         truth's first row)\n",
        solution.display(),
        file_rows,
        truth.display(),
        tru.len(),
        series.samples.len(),
        series.skipped_before,
        series.skipped_after,
        series.t_start_s
    );
    if series.skipped_in_gaps > 0 {
        let _ = writeln!(
            out,
            "skipped {} rows inside gaps of the truth (intervals longer than {} s, {} times its \
             median): not compared",
            series.skipped_in_gaps,
            Number(series.max_truth_interval_s),
            TRUTH_GAP_FACTOR
        );
    }
    out.extend(lost_rows);
    out.push_str(&format_table(&series, at_s));
    if let Some(dir) = plots {
        for path in write_plots(&series, dir, &[solution, truth])? {
            let _ = writeln!(out, "plot: {}", path.display());
        }
    }
    Ok(out)
}

/// One plot: a file name, a title, the y axis and its lines.
struct PlotSpec {
    file: &'static str,
    title: &'static str,
    y_desc: &'static str,
    lines: &'static [Quantity],
}

const PLOTS: [PlotSpec; 3] = [
    PlotSpec {
        file: "attitude_errors.svg",
        title: "Attitude errors (solution - truth)",
        y_desc: "error [deg]",
        lines: &[Quantity::Roll, Quantity::Pitch, Quantity::Yaw],
    },
    PlotSpec {
        file: "velocity_errors.svg",
        title: "Velocity errors (solution - truth)",
        y_desc: "error [m/s]",
        lines: &[
            Quantity::VelocityNorth,
            Quantity::VelocityEast,
            Quantity::VelocityDown,
        ],
    },
    PlotSpec {
        file: "position_errors.svg",
        title: "Position errors (solution - truth)",
        y_desc: "error [m]",
        lines: &[
            Quantity::North,
            Quantity::East,
            Quantity::Horizontal,
            Quantity::Height,
        ],
    },
];

const COLORS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
];

/// Writes `attitude_errors.svg`, `velocity_errors.svg` and `position_errors.svg` into `dir`
/// (created if missing): the errors against time since [`ErrorSeries::t_start_s`], with the
/// ±3-sigma envelope of each quantity whose 1-sigma the solution carries. Each is drawn
/// first, then written whole ([`crate::atomic`]); a plot's path that is one of `inputs` (the
/// same file under any name, a link to it) is refused before any is written. Returns the
/// files written.
pub fn write_plots(series: &ErrorSeries, dir: &Path, inputs: &[&Path]) -> Result<Vec<PathBuf>> {
    ensure!(!series.samples.is_empty(), "no errors to plot");
    ensure!(
        !dir.exists() || dir.is_dir(),
        "--plots {} is a file, not a directory for the plots",
        dir.display()
    );
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let drawn = PLOTS
        .iter()
        .map(|spec| {
            let path = dir.join(spec.file);
            crate::atomic::refuse_same_file(inputs, &path)?;
            let svg = plot(spec, series).map_err(|e| anyhow!("drawing {}: {e}", path.display()))?;
            Ok((path, svg))
        })
        .collect::<Result<Vec<_>>>()?;
    drawn
        .into_iter()
        .map(|(path, svg)| {
            crate::atomic::write(&path, |w| w.write_all(svg.as_bytes()))
                .with_context(|| format!("writing {}", path.display()))?;
            Ok(path)
        })
        .collect()
}

/// One plot, as SVG text.
fn plot(spec: &PlotSpec, series: &ErrorSeries) -> Result<String, String> {
    let t0 = series.t_start_s;
    let lines: Vec<(Quantity, Vec<(f64, f64)>)> = spec
        .lines
        .iter()
        .map(|&q| {
            let points: Vec<(f64, f64)> = series
                .samples
                .iter()
                .map(|e| (e.t_s - t0, q.of(e)))
                .collect();
            (q, decimate(&points, PLOT_MAX_POINTS))
        })
        .collect();
    let all = || lines.iter().flat_map(|(_, p)| p.iter());
    let (x_lo, x_hi) = padded_range(all().map(|p| p.0), 0.0);
    let (e_lo, e_hi) = padded_range(all().map(|p| p.1), 0.05);
    // The +3-sigma line of each quantity that has one (the envelope is symmetric).
    let envelopes: Vec<(usize, Vec<(f64, f64)>)> = spec
        .lines
        .iter()
        .enumerate()
        .filter_map(|(i, &q)| {
            let points: Vec<(f64, f64)> = series
                .samples
                .iter()
                .filter_map(|e| q.sigma(e).map(|s| (e.t_s - t0, 3.0 * s)))
                .collect();
            (!points.is_empty()).then(|| (i, decimate(&points, PLOT_MAX_POINTS)))
        })
        .collect();
    // The envelopes widen the axis, but to at most 4 times the errors' own span: a start's
    // large sigma must not flatten the errors (the envelope leaves the chart there).
    let width = e_hi - e_lo;
    let (y_lo, y_hi) =
        envelopes
            .iter()
            .flat_map(|(_, p)| p.iter())
            .fold((e_lo, e_hi), |(lo, hi), p| {
                (
                    lo.min((-p.1).max(e_lo - 4.0 * width)),
                    hi.max(p.1.min(e_hi + 4.0 * width)),
                )
            });

    let e = |e: &dyn std::fmt::Display| e.to_string();
    let mut svg = String::new();
    let root = SVGBackend::with_string(&mut svg, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(spec.title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(90)
        .build_cartesian_2d(x_lo..x_hi, y_lo..y_hi)
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc(format!(
            "time since the start of the truth [s] (t0 = {t0} s)"
        ))
        .y_desc(spec.y_desc)
        .y_label_formatter(&|y| tick_label(*y, y_hi - y_lo))
        .draw()
        .map_err(|x| e(&x))?;
    for (i, points) in envelopes {
        let color = COLORS[i % COLORS.len()].mix(0.45);
        let clip = |y: f64| y.clamp(y_lo, y_hi);
        let upper: Vec<(f64, f64)> = points.iter().map(|p| (p.0, clip(p.1))).collect();
        let lower: Vec<(f64, f64)> = points.iter().map(|p| (p.0, clip(-p.1))).collect();
        chart
            .draw_series(LineSeries::new(upper, color))
            .map_err(|x| e(&x))?
            .label(format!("±3 sigma of {}", spec.lines[i].name()))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        chart
            .draw_series(LineSeries::new(lower, color))
            .map_err(|x| e(&x))?;
    }
    for (i, (q, points)) in lines.into_iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        chart
            .draw_series(LineSeries::new(points, &color))
            .map_err(|x| e(&x))?
            .label(format!("{} [{}]", q.name(), q.unit()))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))?;
    drop(chart);
    drop(root);
    Ok(svg)
}

/// A tick label for `y` on an axis spanning `span`: enough decimals for ticks a tenth of the
/// span apart, scientific when that would take more than 4.
fn tick_label(y: f64, span: f64) -> String {
    let decimals = (1 - (span / 10.0).log10().floor() as i32).max(0) as usize;
    if y == 0.0 {
        "0".into()
    } else if decimals > 4 || y.abs() >= 1e6 {
        format!("{y:.2e}")
    } else {
        format!("{y:.decimals$}")
    }
}

/// The range of `values`, widened by `pad` of its width on each side; never empty.
fn padded_range(values: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return (-1.0, 1.0);
    }
    let width = hi - lo;
    if width <= 1e-12 * lo.abs().max(hi.abs()).max(1e-300) {
        // A constant: a unit window around it (or its own scale).
        let half = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        return (lo - half, hi + half);
    }
    (lo - pad * width, hi + pad * width)
}

/// At most about `max_points` points: the minimum and maximum of each of `max_points / 2` time
/// buckets, in time order, so the envelope (and every peak) stays.
fn decimate(points: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
    if points.len() <= max_points {
        return points.to_vec();
    }
    let buckets = (max_points / 2).max(1);
    let size = points.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(2 * buckets);
    for chunk in points.chunks(size) {
        let lo = chunk.iter().min_by(|a, b| a.1.total_cmp(&b.1));
        let hi = chunk.iter().max_by(|a, b| a.1.total_cmp(&b.1));
        if let (Some(&lo), Some(&hi)) = (lo, hi) {
            if lo.0 <= hi.0 {
                out.extend([lo, hi]);
            } else {
                out.extend([hi, lo]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use nav_core::attitude::from_euler;
    use nav_core::{UnitQuaternion, Vector3};

    /// A truth row at `t_s`: moving north-east, turning, at 45 deg latitude.
    fn row(t_s: f64) -> Truth {
        Truth {
            t_s,
            lat: 45f64.to_radians() + 1e-6 * t_s,
            lon: 7.5f64.to_radians() + 2e-6 * t_s,
            h: 150.0 + 0.5 * t_s,
            v_eb_ned: Vector3::new(6.0 + t_s, 10.0, -0.5),
            q_b_ned: from_euler(
                2f64.to_radians(),
                -3f64.to_radians(),
                (30.0 + 10.0 * t_s).to_radians(),
            ),
        }
    }

    fn truth() -> Vec<Truth> {
        (0..=10).map(|k| row(k as f64)).collect()
    }

    #[test]
    fn plots_into_a_file_are_refused_naming_it() {
        let t = truth();
        let series = compare(&t, &t).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plots");
        std::fs::write(&file, "not a directory").unwrap();
        let e = write_plots(&series, &file, &[]).unwrap_err().to_string();
        assert!(e.contains("is a file, not a directory"), "{e}");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a directory");
    }

    #[test]
    fn identical_inputs_give_zero_errors() {
        let t = truth();
        let series = compare(&t, &t).unwrap();
        assert_eq!(series.samples.len(), t.len());
        assert_eq!((series.skipped_before, series.skipped_after), (0, 0));
        for q in Quantity::ALL {
            let s = series.stats(q).unwrap();
            assert_eq!((s.rms, s.max_abs), (0.0, 0.0), "{q:?}");
        }
    }

    #[test]
    fn known_offsets_give_those_errors() {
        let t = truth();
        let sol: Vec<Truth> = t
            .iter()
            .map(|r| {
                let (r_n, _) = radii(r.lat);
                let (roll, pitch, yaw) = euler(&r.q_b_ned);
                Truth {
                    lat: r.lat + 10.0 / (r_n + r.h),
                    v_eb_ned: r.v_eb_ned + Vector3::new(0.0, 0.1, 0.0),
                    q_b_ned: from_euler(roll, pitch, yaw + 1f64.to_radians()),
                    ..*r
                }
            })
            .collect();
        let series = compare(&sol, &t).unwrap();
        for e in &series.samples {
            assert!((e.north_m - 10.0).abs() < 1e-8, "{e:?}");
            assert!(e.east_m.abs() < 1e-8 && (e.horizontal_m - 10.0).abs() < 1e-8);
            assert_eq!(e.height_m, 0.0);
            assert_eq!(e.v_ned_mps[0], 0.0);
            assert!((e.v_ned_mps[1] - 0.1).abs() < 1e-14);
            assert!((e.yaw_deg - 1.0).abs() < 1e-9, "{e:?}");
            assert!(e.roll_deg.abs() < 1e-9 && e.pitch_deg.abs() < 1e-9);
            // A yaw offset is a rotation by the same angle (about the rotated z axis).
            assert!((e.rotation_deg - 1.0).abs() < 1e-9, "{e:?}");
        }
        let s = series.stats(Quantity::Yaw).unwrap();
        assert!((s.rms - 1.0).abs() < 1e-9 && (s.max_abs - 1.0).abs() < 1e-9);
    }

    #[test]
    fn a_truth_whose_time_repeats_or_goes_back_is_refused() {
        let t = truth();
        let mut twice = t.clone();
        twice[2].t_s = twice[1].t_s;
        let e = compare(&t, &twice).unwrap_err().to_string();
        assert!(e.contains("truth time repeats at row 3"), "{e}");
        let mut back = t.clone();
        back[2].t_s = back[1].t_s - 0.5;
        let e = compare(&t, &back).unwrap_err().to_string();
        assert!(e.contains("goes backwards at row 3"), "{e}");
    }

    #[test]
    fn yaw_error_wraps() {
        let mut a = row(0.0);
        a.q_b_ned = from_euler(0.0, 0.0, 179f64.to_radians());
        let mut b = a;
        b.q_b_ned = from_euler(0.0, 0.0, (-179f64).to_radians());
        let e = compare(&[b], &[a]).unwrap().samples[0];
        assert!((e.yaw_deg - 2.0).abs() < 1e-9 && (e.rotation_deg - 2.0).abs() < 1e-9);
    }

    #[test]
    fn interpolates_between_truth_rows() {
        let t = truth();
        // 2.25 s: a quarter of the way from row 2 to row 3.
        let i = interpolate(&t, 2.25).unwrap();
        let (a, b) = (row(2.0), row(3.0));
        assert!((i.lat - (a.lat + 0.25 * (b.lat - a.lat))).abs() < 1e-15);
        assert!((i.h - 151.125).abs() < 1e-12);
        assert!((i.v_eb_ned.x - 8.25).abs() < 1e-12);
        // The yaw turns 10 deg/s about a fixed roll and pitch: slerp is a quarter of the
        // rotation between the rows.
        let rel = a.q_b_ned.inverse() * b.q_b_ned;
        let expect = a.q_b_ned * UnitQuaternion::from_scaled_axis(rel.scaled_axis() * 0.25);
        assert!(i.q_b_ned.angle_to(&expect) < 1e-12);

        // A solution on the interpolated truth has no error; rows outside the span are skipped.
        let sol = [Truth { t_s: -1.0, ..i }, i, Truth { t_s: 10.5, ..i }];
        let series = compare(&sol, &t).unwrap();
        assert_eq!(series.samples.len(), 1);
        assert_eq!((series.skipped_before, series.skipped_after), (1, 1));
        assert!(series.samples[0].horizontal_m < 1e-9);
        assert!(series.samples[0].rotation_deg < 1e-9);
        assert_eq!(series.t_start_s, t[0].t_s);

        // A hole in the truth (rows 3..7 missing, 5 times the median interval of 1 s): rows
        // inside it are skipped, not compared with a straight line across it; rows on its
        // edges and in ordinary intervals are.
        let holed: Vec<Truth> = t
            .iter()
            .filter(|r| !(2.5..7.5).contains(&r.t_s))
            .copied()
            .collect();
        let sol: Vec<Truth> = [1.5, 2.0, 4.0, 6.5, 8.0, 9.5].map(row).to_vec();
        let series = compare(&sol, &holed).unwrap();
        assert_eq!(series.skipped_in_gaps, 2);
        assert_eq!(series.samples.len(), 4);
        let err = compare(&[row(5.0)], &holed).unwrap_err().to_string();
        assert!(
            err.contains("1 rows fall in gaps of the truth longer than 5 s"),
            "{err}"
        );

        // The ends are inside (with 1 us of slack), beyond them not.
        assert!(interpolate(&t, 10.0 + 0.5e-6).is_some());
        assert!(interpolate(&t, -2e-6).is_none());
        let err = compare(&[row(20.0)], &t).unwrap_err().to_string();
        assert!(
            err.contains("no solution row within the truth's time span"),
            "{err}"
        );
    }

    /// `--at` beyond the compared rows by more than their interval is refused, naming the
    /// span; within one interval of either end it is the end row (a 10 Hz log ending at
    /// 59.9 s is read at 60 s).
    #[test]
    fn at_times_outside_the_compared_span_are_refused() {
        let t = truth();
        // Solution rows from 2 to 8 s, every second; the truth from 0 to 10 s.
        let series = compare(&t[2..=8], &t).unwrap();
        for ok in [1.0, 2.0, 5.5, 8.0, 9.0] {
            check_at_times(&series, &[ok]).unwrap();
        }
        for bad in [-5.0, 0.5, 9.5, 1e9] {
            let e = check_at_times(&series, &[3.0, bad])
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("is outside the compared rows' span, t0 + 2.000000 .. 8.000000 s"),
                "{bad}: {e}"
            );
            assert!(e.starts_with(&format!("--at {} s", Number(bad))), "{e}");
        }
    }

    #[test]
    fn table_has_stats_and_at_columns() {
        let t = truth();
        let mut sol = t.clone();
        for r in &mut sol {
            r.h += r.t_s; // height error = t
        }
        let series = compare(&sol, &t).unwrap();
        let table = format_table(&series, &[3.0, 7.4]);
        let height = table.lines().find(|l| l.starts_with("height [m]")).unwrap();
        let cells: Vec<&str> = height.split_whitespace().collect();
        // rms of 0..=10 = sqrt(385 / 11), max 10 at t 10, value 3 at 3 s and 7 at 7.4 s.
        assert_eq!(cells[2..], ["5.916", "10.00", "10.000", "3.000", "7.000"]);
        assert!(table.contains("at t0 + 7.4 s: the nearest compared row is at t0 + 7.000000 s"));
        assert!(table.lines().next().unwrap().contains("at t0 + 3 s"));
        // A time far beyond the run reads as typed (it printed 301 digits, in the header too).
        let table = format_table(&series, &[1e300]);
        assert!(table.lines().next().unwrap().ends_with("at t0 + 1e300 s"));
        assert!(table.contains("at t0 + 1e300 s: the nearest compared row is at t0 + 10.000000 s"));
        assert!(table.len() < 2000, "{table}");
    }

    #[test]
    fn reports_files_and_writes_svg_plots() {
        let dir = tempfile::tempdir().unwrap();
        let (sol_path, truth_path) = (dir.path().join("sol.csv"), dir.path().join("truth.nav"));
        // The solution as `nav replay` writes it (nav-core's header, extra columns ignored).
        let t = truth();
        truth_csv::write(&sol_path, &t).unwrap();
        // The truth as a KF-GINS .nav file.
        let mut nav = String::new();
        for r in &t {
            let (roll, pitch, yaw) = euler(&r.q_b_ned);
            let v = r.v_eb_ned;
            writeln!(
                nav,
                "0 {} {} {} {} {} {} {} {} {} {}",
                r.t_s,
                r.lat.to_degrees(),
                r.lon.to_degrees(),
                r.h,
                v.x,
                v.y,
                v.z,
                roll.to_degrees(),
                pitch.to_degrees(),
                yaw.to_degrees()
            )
            .unwrap();
        }
        std::fs::write(&truth_path, nav).unwrap();
        let plots = dir.path().join("plots");
        let text = report_files(&sol_path, &truth_path, &[5.0], Some(&plots)).unwrap();
        assert!(
            text.contains("compared 11 rows, skipped 0 before and 0 after"),
            "{text}"
        );
        // Written without an end record: compared, and said to be cut short.
        assert!(
            text.contains("(11 rows, no end record: cut short)"),
            "{text}"
        );
        for name in ["attitude_errors", "velocity_errors", "position_errors"] {
            let svg = std::fs::read_to_string(plots.join(format!("{name}.svg"))).unwrap();
            assert!(svg.starts_with("<svg") && svg.len() > 1000, "{name}");
            assert!(svg.contains("time since the start of the truth [s]"));
            assert!(text.contains(&format!("{name}.svg")));
        }
        let svg = std::fs::read_to_string(plots.join("velocity_errors.svg")).unwrap();
        assert!(svg.contains("error [m/s]") && svg.contains("v north [m/s]"));

        let err = report_files(&sol_path, &dir.path().join("missing.nav"), &[], None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing.nav"), "{err}");
    }

    /// An aided log's 1-sigma: the share within 3 sigma and the RMS of the normalised error in
    /// the table (north off by 2 m with a 0.5 m sigma on every row: 0 % and 4; east exact:
    /// 100 % and 0), and the envelopes in the plots; a 1-sigma that is not a number is refused.
    #[test]
    fn an_aided_log_gets_normalised_errors_and_envelopes() {
        let dir = tempfile::tempdir().unwrap();
        let (sol_path, truth_path) = (dir.path().join("sol.csv"), dir.path().join("truth.csv"));
        let t = truth();
        truth_csv::write(&truth_path, &t).unwrap();
        // The solution 2 m north of the truth, with the 1-sigma columns appended.
        let north: Vec<Truth> = t
            .iter()
            .map(|r| Truth {
                lat: r.lat + 2.0 / (radii(r.lat).0 + r.h),
                ..*r
            })
            .collect();
        truth_csv::write(&sol_path, &north).unwrap();
        let plain = std::fs::read_to_string(&sol_path).unwrap();
        let mut log = format!("{}\n", crate::aided::header());
        for row in plain.lines().skip(1) {
            writeln!(log, "{row},0.5,0.5,1,0.1,0.1,0.1,0.01,0.01,0.2,NAV").unwrap();
        }
        writeln!(log, "# end: {} rows, ok", t.len()).unwrap();
        std::fs::write(&sol_path, &log).unwrap();
        let plots = dir.path().join("plots");
        let text = report_files(&sol_path, &truth_path, &[], Some(&plots)).unwrap();
        let line = |name: &str| {
            text.lines()
                .find(|l| l.starts_with(name))
                .unwrap_or_else(|| panic!("no {name} row in {text}"))
                .split_whitespace()
                .map(str::to_owned)
                .collect::<Vec<_>>()
        };
        assert!(
            text.contains("|e| <= 3 sigma") && text.contains("RMS e/sigma"),
            "{text}"
        );
        let north = line("north");
        assert_eq!(&north[north.len() - 3..], ["0.0", "%", "4.00"], "{text}");
        let east = line("east");
        assert_eq!(&east[east.len() - 3..], ["100.0", "%", "0.00"], "{text}");
        let horizontal = line("horizontal");
        assert_eq!(&horizontal[horizontal.len() - 2..], ["-", "-"], "{text}");
        let svg = std::fs::read_to_string(plots.join("position_errors.svg")).unwrap();
        assert!(svg.contains("±3 sigma of north"), "{svg}");
        assert!(!svg.contains("±3 sigma of horizontal"));

        // A 1-sigma that is not a number: refused, naming its column.
        let cut = log.replacen(
            ",0.5,0.5,1,0.1,0.1,0.1,0.01,0.01,0.2,NAV",
            ",0.5,0.5,1,0.1,0.1,0.1,0.01,0.01,x,NAV",
            1,
        );
        std::fs::write(&sol_path, cut).unwrap();
        let err = format!(
            "{:#}",
            report_files(&sol_path, &truth_path, &[], None).unwrap_err()
        );
        assert!(err.contains("sigma_yaw_deg"), "{err}");
    }

    #[test]
    fn reads_the_end_record_and_refuses_a_wrong_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sol.csv");
        let t = truth();
        truth_csv::write(&path, &t).unwrap();
        let rows = std::fs::read_to_string(&path).unwrap();
        let read = |text: &str| {
            std::fs::write(&path, text).unwrap();
            read_trajectory_file(&path, false).map_err(|e| format!("{e:#}"))
        };
        // Without an end record: the rows, and no end.
        let plain = read(&rows).unwrap();
        assert_eq!(
            (plain.rows.len(), plain.end, plain.kf_gins),
            (11, None, false)
        );
        // With it (and blank lines after it): the same rows.
        let complete = read(&format!("{rows}# end: 11 rows, ok\n\n")).unwrap();
        assert_eq!(complete.rows, plain.rows);
        assert_eq!(complete.end, Some(EndRecord { rows: 11 }));
        // A count that does not match, a malformed end record, rows after it: refused.
        let e = read(&format!("{rows}# end: 12 rows, ok\n")).unwrap_err();
        assert!(
            e.contains("line 13: the end record says 12 rows, the file has 11"),
            "{e}"
        );
        let e = read(&format!("{rows}# end: eleven rows\n")).unwrap_err();
        assert!(e.contains("line 13: malformed end record"), "{e}");
        let last = rows.lines().last().unwrap();
        let e = read(&format!("{rows}# end: 11 rows, ok\n{last}\n")).unwrap_err();
        assert!(e.contains("line 14: text after the end record"), "{e}");
    }

    #[test]
    fn decimation_keeps_peaks() {
        let points: Vec<(f64, f64)> = (0..100_000)
            .map(|k| (k as f64, if k == 54_321 { 9.0 } else { (k % 7) as f64 }))
            .collect();
        let d = decimate(&points, 1000);
        assert!(d.len() <= 1000);
        assert!(d.contains(&(54_321.0, 9.0)));
        assert!(d.windows(2).all(|w| w[0].0 <= w[1].0));
    }
}
