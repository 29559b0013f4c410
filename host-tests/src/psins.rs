//! Reader of PSINS `.imu` text recordings (the PSINS toolbox's SIMU log format).
//!
//! Lines starting with `%` are comments, blank lines are skipped. Then three header lines:
//! 1. `pitch0 roll0 yaw0` [deg], `VE0 VN0 VU0` [m/s];
//! 2. `latitude0 longitude0` [deg], `height0` [m], `t0` [s], sampling interval [ms], `g` [m/s^2];
//! 3. scale factors `gf_x gf_y gf_z` [arcsec per count], `af_x af_y af_z` [micro-g * s per count].
//!
//! Then one line per sample: six integer counts, the gyro angle increments x y z and the
//! accelerometer velocity increments x y z over the sampling interval, body axes
//! right-forward-up (RFU). The reader converts them to SI (rad, m/s with the header's `g`) and to
//! the project's forward-right-down (FRD) body axes: `x_frd = y_rfu, y_frd = x_rfu, z_frd =
//! -z_rfu`.
//!
//! The header is checked before any sample: interval, `g` and every scale factor positive, no
//! count worth more than the largest increment nav-core accepts, the interval at least 1 ns,
//! `t0` and each sample's time `t0 + k * interval` within the recording clock's range, latitude
//! within [-90, 90] deg and longitude within [-180, 180] deg. Samples are
//! read one line at a time ([`PsinsReader`]); a last line that no newline ends is checked for a
//! cut inside a field ([`crate::text_stream`]).

use crate::text_error::{Cut, MAX_TIME_S, number_text, seconds_to_ns};
use crate::text_stream::{CutCheck, LineReader};
use std::fmt;
use std::fs::File;
use std::io::{self, BufRead, BufReader};
use std::path::{Path, PathBuf};

/// Radians per arcsecond.
const RAD_PER_ARCSEC: f64 = std::f64::consts::PI / (180.0 * 3600.0);

/// Largest gyro scale factor [arcsec per count]: one count worth 200 deg, the largest angle
/// increment nav-core accepts (its default input limits: 2000 deg/s over its longest interval,
/// 0.1 s). A coarser count makes every sample but zero one nav-core refuses.
pub const MAX_GYRO_SCALE_ARCSEC: f64 = 720_000.0;

/// Largest accelerometer scale factor [micro-g * s per count]: one count worth 5 g * s, the
/// largest velocity increment nav-core accepts (its default input limits: 50 g over 0.1 s).
pub const MAX_ACCEL_SCALE_UG_S: f64 = 5e6;

/// The three header lines of a PSINS file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PsinsHeader {
    /// Initial pitch [deg] ("maybe inaccurate" in the toolbox's own words).
    pub pitch0_deg: f64,
    /// Initial roll [deg].
    pub roll0_deg: f64,
    /// Initial yaw [deg] (PSINS convention: East-North-Up navigation frame).
    pub yaw0_deg: f64,
    /// Initial velocity east, north, up [m/s].
    pub v_enu0_mps: [f64; 3],
    /// Initial latitude [deg].
    pub lat_deg: f64,
    /// Initial longitude [deg].
    pub lon_deg: f64,
    /// Initial height [m].
    pub h_m: f64,
    /// Start time `t0` [s]: the first sample's interval starts here.
    pub t0_s: f64,
    /// Sampling interval [ms].
    pub interval_ms: f64,
    /// Gravity used by the accelerometer scale [m/s^2].
    pub g_mps2: f64,
    /// Gyro scale factors x y z (RFU) [arcsec per count].
    pub gyro_scale_arcsec: [f64; 3],
    /// Accelerometer scale factors x y z (RFU) [micro-g * s per count].
    pub accel_scale_ug_s: [f64; 3],
}

impl PsinsHeader {
    /// Sampling interval [s].
    pub fn interval_s(&self) -> f64 {
        self.interval_ms * 1e-3
    }

    /// Nominal sampling rate [Hz].
    pub fn rate_hz(&self) -> f64 {
        1e3 / self.interval_ms
    }

    /// The sampling interval rounded to whole nanoseconds [ns] (the reader checked it is at
    /// least 1 ns and fits the clock).
    pub fn interval_ns(&self) -> u64 {
        interval_ns(self.interval_ms).unwrap_or(0)
    }

    /// `t0` on the recording clock [ns] (the reader checked it fits).
    pub fn t0_ns(&self) -> u64 {
        seconds_to_ns(self.t0_s).unwrap_or(0)
    }

    /// End of sample `k`'s interval (`k` = 1 for the first sample) on the recording clock:
    /// `t0 + k * interval` [ns], or `None` when it is beyond the clock's range.
    pub fn sample_end_ns(&self, k: u64) -> Option<u64> {
        k.checked_mul(self.interval_ns())?.checked_add(self.t0_ns())
    }

    /// Converts one line of counts (RFU) to increments in SI, FRD axes.
    pub fn convert(&self, counts: [i64; 6]) -> PsinsSample {
        let gyro_rfu: [f64; 3] =
            core::array::from_fn(|i| counts[i] as f64 * self.gyro_scale_arcsec[i] * RAD_PER_ARCSEC);
        let accel_rfu: [f64; 3] = core::array::from_fn(|i| {
            counts[3 + i] as f64 * self.accel_scale_ug_s[i] * 1e-6 * self.g_mps2
        });
        PsinsSample {
            delta_theta_ib_b: rfu_to_frd(gyro_rfu),
            delta_v_ib_b: rfu_to_frd(accel_rfu),
        }
    }
}

/// RFU body axes to FRD: forward is RFU's y, right is RFU's x, down is minus RFU's z.
pub fn rfu_to_frd([x, y, z]: [f64; 3]) -> [f64; 3] {
    [y, x, -z]
}

/// One sample in SI units and FRD body axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PsinsSample {
    /// Angle increment over the interval, body FRD [rad].
    pub delta_theta_ib_b: [f64; 3],
    /// Velocity increment over the interval, body FRD [m/s].
    pub delta_v_ib_b: [f64; 3],
}

/// A PSINS recording: the header and the samples, sample `k` covering the interval
/// `[t0 + k * interval, t0 + (k + 1) * interval]`.
#[derive(Clone, Debug, PartialEq)]
pub struct PsinsRecording {
    /// The header.
    pub header: PsinsHeader,
    /// The samples, in file order.
    pub samples: Vec<PsinsSample>,
}

/// A PSINS reading error, naming the file and (for content errors) the line.
#[derive(Debug)]
pub struct PsinsError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line number, when the error is about a line.
    pub line: Option<u64>,
    /// What went wrong.
    pub kind: PsinsErrorKind,
}

/// What went wrong in a PSINS file.
#[derive(Debug)]
pub enum PsinsErrorKind {
    /// The file ended before the three header lines.
    MissingHeader {
        /// Which header line (1, 2 or 3) is missing.
        which: usize,
    },
    /// A header line does not hold six numbers.
    BadHeaderLine {
        /// Which header line (1, 2 or 3).
        which: usize,
        /// What the line should hold.
        expected: &'static str,
        /// The line's text.
        found: String,
    },
    /// A header value is out of its domain (interval, g, scales, t0).
    BadHeaderValue {
        /// Which value and what it must be.
        what: &'static str,
        /// The value found.
        found: f64,
    },
    /// A scale factor is zero or negative.
    BadScale {
        /// The sensor axis, e.g. `gyro x`.
        sensor: &'static str,
        /// The scale found.
        found: f64,
    },
    /// A scale factor is beyond [`MAX_GYRO_SCALE_ARCSEC`] or [`MAX_ACCEL_SCALE_UG_S`].
    ScaleTooLarge {
        /// The sensor axis, e.g. `gyro x`.
        sensor: &'static str,
        /// The scale found.
        found: f64,
        /// The largest accepted scale, in the scale's unit.
        max: f64,
    },
    /// A sample's time `t0 + k * interval` is beyond the recording clock's range.
    TimeOutOfRange {
        /// The sample's number `k` (1 for the first).
        sample: u64,
        /// Its time [s].
        t_s: f64,
    },
    /// The file's last line, which no newline ends, looks cut off.
    Truncated {
        /// 1-based number of the last line.
        line: u64,
        /// Why it looks cut off.
        cut: Cut,
    },
    /// A sample line does not hold six integer counts.
    BadCounts {
        /// 1-based field position (1..=6) of the first bad field, 7 for extra fields.
        field: usize,
        /// The line's text.
        found: String,
    },
    /// The file could not be opened or read.
    Io(io::Error),
}

const HEADER_EXPECTED: [&str; 3] = [
    "6 numbers: pitch0 roll0 yaw0 [deg], VE0 VN0 VU0 [m/s]",
    "6 numbers: latitude0 longitude0 [deg], height0 [m], t0 [s], interval [ms], g [m/s^2]",
    "6 numbers: gyro scales x y z [arcsec/count], accel scales x y z [ug*s/count]",
];

const COUNT_NAMES: [&str; 6] = [
    "gyro x", "gyro y", "gyro z", "accel x", "accel y", "accel z",
];

impl fmt::Display for PsinsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.path.display())?;
        if let Some(line) = self.line {
            write!(f, "line {line}: ")?;
        }
        match &self.kind {
            PsinsErrorKind::MissingHeader { which } => write!(
                f,
                "file ended before header line {which} ({})",
                HEADER_EXPECTED[which - 1]
            ),
            PsinsErrorKind::BadHeaderLine {
                which,
                expected,
                found,
            } => {
                write!(
                    f,
                    "header line {which}: expected {expected}, found '{found}'"
                )
            }
            PsinsErrorKind::BadHeaderValue { what, found } => {
                write!(f, "header: {what}, found {}", number_text(*found))
            }
            PsinsErrorKind::BadScale { sensor, found } => write!(
                f,
                "header line 3: PSINS scale factor {} for {sensor}: scale factors must be \
                 positive (gyro [arcsec/count], accel [ug*s/count])",
                number_text(*found)
            ),
            PsinsErrorKind::ScaleTooLarge { sensor, found, max } => {
                let (unit, one_count) = if sensor.starts_with("gyro") {
                    ("arcsec/count", "200 deg")
                } else {
                    ("ug*s/count", "5 g*s")
                };
                write!(
                    f,
                    "header line 3: PSINS scale factor {} {unit} for {sensor} is beyond {} \
                     {unit} (one count worth more than {one_count}, the largest increment over \
                     0.1 s the navigator accepts)",
                    number_text(*found),
                    number_text(*max)
                )
            }
            PsinsErrorKind::TimeOutOfRange { sample, t_s } => write!(
                f,
                "sample {sample} ends at t0 + {sample} * interval = {} s, beyond the \
                 recording clock's range (0 to {MAX_TIME_S} s, u64 nanoseconds)",
                number_text(*t_s)
            ),
            PsinsErrorKind::Truncated { line, cut } => write!(
                f,
                "truncated: last line {line} ends inside a field ({cut}; no newline ends the \
                 file; if the line is complete, end the file with a newline)"
            ),
            PsinsErrorKind::BadCounts { field, found } if *field <= 6 => write!(
                f,
                "expected 6 integer counts (gyro x y z, accel x y z): field {field} ({}) is not an integer or is missing, in '{found}'",
                COUNT_NAMES[field - 1]
            ),
            PsinsErrorKind::BadCounts { found, .. } => write!(
                f,
                "expected 6 integer counts (gyro x y z, accel x y z), found more fields in '{found}'"
            ),
            PsinsErrorKind::Io(e) => write!(f, "{e}"),
        }
    }
}

/// No source: the text carries the I/O error's (as [`crate::text_error::TextError`]'s does);
/// a chain of causes printed it twice ("reading X: X: No such file or directory (os error 2):
/// No such file or directory (os error 2)").
impl std::error::Error for PsinsError {}

/// Reads a PSINS recording from `path` into memory (a replay streams it instead:
/// [`PsinsReader`]).
pub fn read(path: &Path) -> Result<PsinsRecording, PsinsError> {
    let file = File::open(path).map_err(|e| error(path, None, PsinsErrorKind::Io(e)))?;
    read_from(BufReader::new(file), path)
}

/// Reads a PSINS recording from `reader` into memory; `path` names it in errors.
pub fn read_from<R: BufRead>(reader: R, path: &Path) -> Result<PsinsRecording, PsinsError> {
    let samples = PsinsReader::new(reader, path)?;
    let header = *samples.header();
    Ok(PsinsRecording {
        header,
        samples: samples.collect::<Result<_, _>>()?,
    })
}

/// The samples of a PSINS file, read one line at a time (memory bounded by the longest line)
/// after its header. Stops after the first error.
#[derive(Debug)]
pub struct PsinsReader<R> {
    lines: LineReader<R>,
    path: PathBuf,
    header: PsinsHeader,
    /// Samples read so far.
    count: u64,
    cut: CutCheck,
    done: bool,
}

impl<R: BufRead> PsinsReader<R> {
    /// Reads and checks the three header lines of `reader`; `path` names it in errors.
    pub fn new(reader: R, path: &Path) -> Result<Self, PsinsError> {
        let mut lines = LineReader::new(reader);
        let mut values: Vec<[f64; 6]> = Vec::with_capacity(3);
        while values.len() < 3 {
            let which = values.len() + 1;
            let line = match lines.next_line() {
                None => {
                    return Err(error(path, None, PsinsErrorKind::MissingHeader { which }));
                }
                Some(Err((line_no, e))) => {
                    return Err(error(path, Some(line_no), PsinsErrorKind::Io(e)));
                }
                Some(Ok(line)) => line,
            };
            let at = |kind| error(path, Some(line.number), kind);
            let text = line.text.trim();
            if text.is_empty() || text.starts_with('%') {
                continue;
            }
            let v = parse_six::<f64>(text)
                .filter(|v| v.iter().all(|x| x.is_finite()))
                .ok_or_else(|| {
                    at(PsinsErrorKind::BadHeaderLine {
                        which,
                        expected: HEADER_EXPECTED[which - 1],
                        found: text.to_owned(),
                    })
                })?;
            match which {
                2 => check_line_2(&v).map_err(at)?,
                3 => check_line_3(&v).map_err(at)?,
                _ => {}
            }
            values.push(v);
        }
        Ok(Self {
            lines,
            path: path.to_owned(),
            header: build_header(&values),
            count: 0,
            cut: CutCheck::default(),
            done: false,
        })
    }

    /// The header.
    pub fn header(&self) -> &PsinsHeader {
        &self.header
    }

    fn next_sample(&mut self) -> Option<Result<PsinsSample, PsinsError>> {
        let path = &self.path;
        loop {
            let line = match self.lines.next_line()? {
                Err((line_no, e)) => {
                    return Some(Err(error(path, Some(line_no), PsinsErrorKind::Io(e))));
                }
                Ok(line) => line,
            };
            let line_no = line.number;
            let at = |kind| error(path, Some(line_no), kind);
            let text = line.text.trim();
            if text.is_empty() || text.starts_with('%') {
                continue;
            }
            if line.unterminated {
                let fields: Vec<&str> = text.split_whitespace().collect();
                let column = |i: usize| COUNT_NAMES.get(i).copied().unwrap_or("extra").to_owned();
                let is_count = |_: usize, t: &str| t.parse::<i64>().is_ok();
                if let Err(cut) = self.cut.check(&fields, 6, column, is_count) {
                    return Some(Err(error(
                        path,
                        None,
                        PsinsErrorKind::Truncated { line: line_no, cut },
                    )));
                }
            } else {
                self.cut.note(text.split_whitespace());
            }
            let counts = match parse_counts(text) {
                Ok(counts) => counts,
                Err(field) => {
                    return Some(Err(at(PsinsErrorKind::BadCounts {
                        field,
                        found: text.to_owned(),
                    })));
                }
            };
            self.count += 1;
            // The sample's interval ends at t0 + count * interval: it must be on the clock.
            if self.header.sample_end_ns(self.count).is_none() {
                return Some(Err(at(PsinsErrorKind::TimeOutOfRange {
                    sample: self.count,
                    t_s: self.header.t0_s + self.count as f64 * self.header.interval_s(),
                })));
            }
            return Some(Ok(self.header.convert(counts)));
        }
    }
}

impl<R: BufRead> Iterator for PsinsReader<R> {
    type Item = Result<PsinsSample, PsinsError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let sample = self.next_sample();
        self.done = !matches!(sample, Some(Ok(_)));
        sample
    }
}

/// Domain checks of header line 2 (position, time, interval, g).
fn check_line_2(v: &[f64; 6]) -> Result<(), PsinsErrorKind> {
    let [lat_deg, lon_deg, _, t0_s, interval_ms, g_mps2] = *v;
    let bad = |what, found| Err(PsinsErrorKind::BadHeaderValue { what, found });
    if interval_ms <= 0.0 {
        return bad("the sampling interval [ms] must be positive", interval_ms);
    }
    if interval_ns(interval_ms).is_none() {
        return bad(
            "the sampling interval [ms] must be at least 1 ns and within the recording \
             clock's range",
            interval_ms,
        );
    }
    if g_mps2 <= 0.0 {
        return bad("g [m/s^2] must be positive", g_mps2);
    }
    if t0_s < 0.0 {
        return bad("t0 [s] must not be negative", t0_s);
    }
    if seconds_to_ns(t0_s).is_none() {
        return bad(
            "t0 [s] must be within the recording clock's range (0 to 18446744073.709553 s, \
             u64 nanoseconds)",
            t0_s,
        );
    }
    if !(-90.0..=90.0).contains(&lat_deg) {
        return bad("latitude [deg] must be within [-90, 90]", lat_deg);
    }
    if !(-180.0..=180.0).contains(&lon_deg) {
        return bad("longitude [deg] must be within [-180, 180]", lon_deg);
    }
    Ok(())
}

/// Domain check of header line 3: every scale factor positive (a zero scale turns every count
/// into 0, a negative one flips an axis) and at most [`MAX_GYRO_SCALE_ARCSEC`] or
/// [`MAX_ACCEL_SCALE_UG_S`] (1e300 turned every count into an infinite increment).
fn check_line_3(v: &[f64; 6]) -> Result<(), PsinsErrorKind> {
    for (i, (&found, sensor)) in v.iter().zip(COUNT_NAMES).enumerate() {
        let max = if i < 3 {
            MAX_GYRO_SCALE_ARCSEC
        } else {
            MAX_ACCEL_SCALE_UG_S
        };
        if found <= 0.0 {
            return Err(PsinsErrorKind::BadScale { sensor, found });
        }
        if found > max {
            return Err(PsinsErrorKind::ScaleTooLarge { sensor, found, max });
        }
    }
    Ok(())
}

/// The sampling interval `interval_ms` [ms] in whole nanoseconds, or `None` when it rounds to
/// 0 or does not fit the clock.
fn interval_ns(interval_ms: f64) -> Option<u64> {
    seconds_to_ns(interval_ms * 1e-3).filter(|&ns| ns > 0)
}

fn build_header(v: &[[f64; 6]]) -> PsinsHeader {
    let [pitch0_deg, roll0_deg, yaw0_deg, ve, vn, vu] = v[0];
    let [lat_deg, lon_deg, h_m, t0_s, interval_ms, g_mps2] = v[1];
    let [gx, gy, gz, ax, ay, az] = v[2];
    PsinsHeader {
        pitch0_deg,
        roll0_deg,
        yaw0_deg,
        v_enu0_mps: [ve, vn, vu],
        lat_deg,
        lon_deg,
        h_m,
        t0_s,
        interval_ms,
        g_mps2,
        gyro_scale_arcsec: [gx, gy, gz],
        accel_scale_ug_s: [ax, ay, az],
    }
}

/// Six whitespace-separated values, or `None`.
fn parse_six<T: std::str::FromStr + Copy + Default>(text: &str) -> Option<[T; 6]> {
    let mut out = [T::default(); 6];
    let mut fields = text.split_whitespace();
    for slot in &mut out {
        *slot = fields.next()?.parse().ok()?;
    }
    fields.next().is_none().then_some(out)
}

/// Six integer counts, or the 1-based position of the first bad field (7: extra fields).
fn parse_counts(text: &str) -> Result<[i64; 6], usize> {
    let mut out = [0_i64; 6];
    let mut fields = text.split_whitespace();
    for (i, slot) in out.iter_mut().enumerate() {
        *slot = fields.next().and_then(|f| f.parse().ok()).ok_or(i + 1)?;
    }
    match fields.next() {
        None => Ok(out),
        Some(_) => Err(7),
    }
}

fn error(path: &Path, line: Option<u64>, kind: PsinsErrorKind) -> PsinsError {
    PsinsError {
        path: path.to_owned(),
        line,
        kind,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "% comment\n%\n\n0 0 -90.6 0 0 0\n34.246048 108.909664 380.0 0 10 9.780327\n0.1 0.1 0.1 125 125 125\n-7 9 3 0 0 80\n  2 -4 7 0 2 80  \n";

    fn parse(text: &str) -> Result<PsinsRecording, PsinsError> {
        read_from(text.as_bytes(), Path::new("mem.imu"))
    }

    /// The scale bounds are one count worth nav-core's largest accepted increment.
    #[test]
    fn scale_bounds_are_the_largest_accepted_increments() {
        let l = nav_core::increment::InputLimits::<f64>::default();
        let theta_rad = MAX_GYRO_SCALE_ARCSEC * RAD_PER_ARCSEC;
        assert!((theta_rad / (l.max_rate * l.max_dt) - 1.0).abs() < 1e-12);
        let dv_mps = MAX_ACCEL_SCALE_UG_S * 1e-6 * 9.806_65;
        assert!((dv_mps / (l.max_specific_force * l.max_dt) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn reads_header_and_converts_counts() {
        let r = parse(TEXT).unwrap();
        let h = r.header;
        assert_eq!(
            (h.lat_deg, h.lon_deg, h.h_m, h.t0_s),
            (34.246048, 108.909664, 380.0, 0.0)
        );
        assert_eq!(
            (h.interval_ms, h.g_mps2, h.yaw0_deg),
            (10.0, 9.780327, -90.6)
        );
        assert_eq!(h.rate_hz(), 100.0);
        assert_eq!(r.samples.len(), 2);
        let s = r.samples[0];
        // gyro RFU (-7, 9, 3) * 0.1 arcsec -> FRD (9, -7, -3) * 0.1 arcsec.
        let arcsec = std::f64::consts::PI / 648_000.0;
        let expect = [0.9 * arcsec, -0.7 * arcsec, -0.3 * arcsec];
        for (a, b) in s.delta_theta_ib_b.iter().zip(expect) {
            assert!((a - b).abs() < 1e-20, "{a} vs {b}");
        }
        // accel z_rfu = 80 * 125 ug*s = 0.01 g*s up -> FRD z = -0.01 * g m/s.
        assert_eq!(s.delta_v_ib_b[0], 0.0);
        assert!((s.delta_v_ib_b[2] + 0.01 * 9.780327).abs() < 1e-15);
        assert!((r.samples[1].delta_v_ib_b[0] - 2.0 * 125e-6 * 9.780327).abs() < 1e-15);
    }

    #[test]
    fn errors_name_the_line() {
        let bad = TEXT.replace("2 -4 7 0 2 80", "2 -4 7 x 2 80");
        let msg = parse(&bad).unwrap_err().to_string();
        assert!(
            msg.starts_with("mem.imu: line 8: expected 6 integer counts"),
            "{msg}"
        );
        assert!(msg.contains("field 4 (accel x)"), "{msg}");

        let bad = TEXT.replace("2 -4 7 0 2 80", "2 -4 7 0 2");
        let msg = parse(&bad).unwrap_err().to_string();
        assert!(
            msg.contains("line 8") && msg.contains("field 6 (accel z)"),
            "{msg}"
        );

        let bad = TEXT.replace("2 -4 7 0 2 80", "2 -4 7 0 2 80 1");
        let msg = parse(&bad).unwrap_err().to_string();
        assert!(
            msg.contains("line 8") && msg.contains("found more fields"),
            "{msg}"
        );

        let bad = TEXT.replace("380.0 0 10", "380.0 0 0");
        let msg = parse(&bad).unwrap_err().to_string();
        assert!(
            msg.contains("line 5: header: the sampling interval"),
            "{msg}"
        );

        let bad = TEXT.replace("0.1 0.1 0.1 125 125 125", "0.1 0.1 0.1 125 125");
        let msg = parse(&bad).unwrap_err().to_string();
        assert!(
            msg.contains("line 6: header line 3: expected 6 numbers"),
            "{msg}"
        );

        let msg = parse("% only comments\n0 0 0 0 0 0\n")
            .unwrap_err()
            .to_string();
        assert!(msg.contains("file ended before header line 2"), "{msg}");
    }
}
