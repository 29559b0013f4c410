//! Readers of the text formats of KF-GINS (the open-source EKF GNSS/INS program of the i2Nav group,
//! Wuhan University) and of its datasets (awesome-gins-datasets).
//!
//! Both are plain numbers, one record a line, separated by spaces, tabs or commas (runs of
//! separators count as one, as in KF-GINS's own loader); no header. Blank lines and lines starting
//! with `#` or `%` are skipped.
//!
//! IMU file (7 columns): GNSS seconds of week [s], angle increments x y z [rad], velocity
//! increments x y z [m/s], body axes forward-right-down, each over the interval ending at the
//! time tag. KF-GINS's optional 8th column (odometer, config `imudatalen: 8`) is accepted and
//! ignored; `nav kf-gins` holds every line to its configuration's `imudatalen`
//! ([`ImuReader::with_columns`]). Time must increase from line to line; NaN or infinite increments are parsed, not
//! refused (the replay flags them), as in the project's CSV format.
//!
//! Trajectory file (`truth.nav`, and KF-GINS's own `KF_GINS_Navresult.nav`; 11 columns): GNSS week,
//! GNSS seconds of week [s], latitude, longitude [deg], ellipsoidal height [m], velocity north,
//! east, down [m/s], roll, pitch, yaw [deg] (z-y-x Euler angles, FRD body to NED). Every value
//! must be finite, the week a non-negative whole number that does not change within the file, and
//! time must not go backwards. Times are returned as seconds of week: the IMU file has no week.
//!
//! Both are read one line at a time ([`ImuReader`], [`NavReader`]); a last line that no newline
//! ends is checked for a cut inside a field ([`crate::text_stream`]). KF-GINS's GNSS position
//! file goes through the same line reading ([`crate::gnss`]).

use crate::imu_csv::{CsvRow, ImuCsv};
use crate::text_error::{Record, TextError, TextErrorKind, seconds_to_ns};
use crate::text_stream::{CutCheck, LineReader};
use crate::truth::Truth;
use nav_core::Vector3;
use nav_core::attitude::from_euler;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// IMU file columns, as named in errors.
pub const IMU_COLUMNS: [&str; 7] = [
    "seconds of week",
    "dtheta x",
    "dtheta y",
    "dtheta z",
    "dv x",
    "dv y",
    "dv z",
];

/// Trajectory (`.nav`) file columns, as named in errors.
pub const NAV_COLUMNS: [&str; 11] = [
    "week",
    "seconds of week",
    "latitude",
    "longitude",
    "height",
    "v north",
    "v east",
    "v down",
    "roll",
    "pitch",
    "yaw",
];

/// GNSS file columns without velocity (7), as named in errors ([`crate::gnss`]).
pub const GNSS_COLUMNS: [&str; 7] = [
    "seconds of week",
    "latitude",
    "longitude",
    "height",
    "sigma north",
    "sigma east",
    "sigma down",
];

/// GNSS file columns with velocity (13, KF-GINS's order: velocity before the sigmas), as named
/// in errors ([`crate::gnss`]).
pub const GNSS_VELOCITY_COLUMNS: [&str; 13] = [
    "seconds of week",
    "latitude",
    "longitude",
    "height",
    "v north",
    "v east",
    "v down",
    "sigma north",
    "sigma east",
    "sigma down",
    "sigma v north",
    "sigma v east",
    "sigma v down",
];

/// Column positions in [`NAV_COLUMNS`].
const WEEK: usize = 0;
const SOW: usize = 1;
const LAT: usize = 2;
const LON: usize = 3;
const H: usize = 4;
const VEL: usize = 5;
const ATT: usize = 8;

/// One IMU line: the increments over the interval ending at `t_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KfGinsImuRow {
    /// End of the interval: GNSS seconds of week [s].
    pub t_s: f64,
    /// Angle increment, integral of `omega_ib_b` over the interval, body FRD [rad].
    pub delta_theta_ib_b: [f64; 3],
    /// Velocity increment, integral of `f_ib_b` over the interval, body FRD [m/s].
    pub delta_v_ib_b: [f64; 3],
}

/// A KF-GINS IMU file.
#[derive(Clone, Debug, PartialEq)]
pub struct KfGinsImu {
    /// The rows, in file order (time increasing).
    pub rows: Vec<KfGinsImuRow>,
}

impl KfGinsImu {
    /// The rows in the project's CSV form (increments rounded to f32 as the binary format stores
    /// them; no temperature).
    pub fn to_imu_csv(&self) -> ImuCsv {
        ImuCsv {
            has_temperature: false,
            rows: self.rows.iter().map(KfGinsImuRow::to_csv_row).collect(),
        }
    }
}

impl KfGinsImuRow {
    /// The row in the project's CSV form (increments rounded to f32 as the binary format stores
    /// them; no temperature).
    pub fn to_csv_row(&self) -> CsvRow {
        let to_f32 = |v: [f64; 3]| v.map(|x| x as f32);
        CsvRow {
            t_s: self.t_s,
            delta_theta_ib_b: to_f32(self.delta_theta_ib_b),
            delta_v_ib_b: to_f32(self.delta_v_ib_b),
            temperature_c: f32::NAN,
        }
    }
}

/// A KF-GINS reading error, naming the file and (for content errors) the line.
pub type KfGinsError = TextError;

/// What went wrong in a KF-GINS file.
pub type KfGinsErrorKind = TextErrorKind;

/// Which KF-GINS file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// The IMU text file (7 columns).
    Imu,
    /// The trajectory file (`.nav`, 11 columns).
    Nav,
    /// The GNSS position file (7 columns, or 13 with velocity).
    Gnss,
}

impl FileKind {
    fn columns(self) -> &'static [&'static str] {
        match self {
            Self::Imu => &IMU_COLUMNS,
            Self::Nav => &NAV_COLUMNS,
            Self::Gnss => &GNSS_COLUMNS,
        }
    }

    /// The name of field `i` on a line of `fields` fields.
    fn column(self, i: usize, fields: usize) -> String {
        let name = match self {
            Self::Imu => Some(IMU_COLUMNS.get(i).copied().unwrap_or("odometer")),
            Self::Nav => NAV_COLUMNS.get(i).copied(),
            Self::Gnss if fields > GNSS_COLUMNS.len() => GNSS_VELOCITY_COLUMNS.get(i).copied(),
            Self::Gnss => GNSS_COLUMNS.get(i).copied(),
        };
        name.map_or_else(|| format!("{}", i + 1), str::to_owned)
    }

    /// Whether a line of `fields` fields has a valid count.
    fn allows(self, fields: usize) -> bool {
        match self {
            Self::Imu => matches!(fields, 7 | 8),
            Self::Nav => fields == NAV_COLUMNS.len(),
            Self::Gnss => matches!(fields, 7 | 13),
        }
    }

    /// What a line holds, for the message of a line with the wrong number of fields.
    fn expected(self) -> &'static str {
        match self {
            Self::Imu => {
                "7 numbers (seconds of week, dtheta x y z [rad], dv x y z [m/s]; an 8th, \
                 odometer, column is allowed)"
            }
            Self::Nav => {
                "11 numbers (week, seconds of week, latitude, longitude [deg], height [m], \
                 v north east down [m/s], roll, pitch, yaw [deg])"
            }
            Self::Gnss => {
                "7 numbers (seconds of week, latitude, longitude [deg], height [m], sigma north \
                 east down [m]) or 13 (the same with v north east down [m/s] after the height \
                 and sigma v north east down [m/s] at the end)"
            }
        }
    }

    /// A guess at what a line of `found` fields is from, when it is the other kind of file.
    fn hint(self, found: usize) -> Option<&'static str> {
        match (self, found) {
            (Self::Imu, 11) => Some("is this a KF-GINS .nav trajectory?"),
            (Self::Nav, 7 | 8) => Some("is this a KF-GINS IMU file?"),
            (Self::Gnss, 11) => Some("is this a KF-GINS .nav trajectory?"),
            (Self::Gnss, 8) => Some("is this a KF-GINS IMU file?"),
            _ => None,
        }
    }
}

/// The fields of a line: separated by any run of spaces, tabs and commas.
fn fields(text: &str) -> impl Iterator<Item = &str> {
    text.split([' ', '\t', ','])
        .map(str::trim)
        .filter(|f| !f.is_empty())
}

/// The fields of a line of plain numbers, split and parsed in one pass (no `char` machinery,
/// no second scan: 720,000-line files): each field must be one whole number as
/// [`fast_float2::parse_partial`] reads it (the syntax of `str::parse::<f64>`), followed by a
/// blank, a tab, a comma or the line's end; `spans` gets each field's byte range. `None` for any
/// other line (more fields than `values` holds, a field that is not a number, white space other
/// than blanks and tabs, any byte that is not ASCII): the caller then splits it with [`fields`]
/// and its errors name the field. A line it splits is all ASCII.
fn ascii_numbers(
    bytes: &[u8],
    spans: &mut [(usize, usize); MAX_FIELDS],
    values: &mut [f64; MAX_FIELDS],
) -> Option<usize> {
    let is_separator = |b: u8| matches!(b, b' ' | b'\t' | b',');
    let (mut n, mut i) = (0, 0);
    loop {
        while i < bytes.len() && is_separator(bytes[i]) {
            i += 1;
        }
        if i == bytes.len() {
            return Some(n);
        }
        let (value, len) = fast_float2::parse_partial::<f64, _>(&bytes[i..]).ok()?;
        let end = i + len;
        if len == 0 || (end < bytes.len() && !is_separator(bytes[end])) {
            return None;
        }
        *spans.get_mut(n)? = (i, end);
        *values.get_mut(n)? = value;
        n += 1;
        i = end;
    }
}

/// `bytes` without the white space `str::trim` takes off an ASCII line.
fn trim_ascii(bytes: &[u8]) -> &[u8] {
    let white = |b: &u8| matches!(b, b' ' | b'\t' | b'\n' | b'\x0b' | b'\x0c' | b'\r');
    let start = bytes.iter().position(|b| !white(b)).unwrap_or(bytes.len());
    let end = bytes
        .iter()
        .rposition(|b| !white(b))
        .map_or(start, |e| e + 1);
    &bytes[start..end]
}

/// The fields of one data line, as a reader's row closure gets them: their text and, when the
/// line was split by the fast path ([`ascii_numbers`]), their values.
pub(crate) struct Fields<'a> {
    texts: Texts<'a>,
    values: Option<&'a [f64]>,
}

/// Where the fields' text is.
enum Texts<'a> {
    /// Byte ranges of an all-ASCII line (the fast path's: not checked as UTF-8 a second time).
    Ascii {
        line: &'a [u8],
        spans: &'a [(usize, usize)],
    },
    /// Split as text.
    Text(&'a [&'a str]),
}

impl<'a> Fields<'a> {
    /// How many fields.
    pub(crate) fn len(&self) -> usize {
        match self.texts {
            Texts::Ascii { spans, .. } => spans.len(),
            Texts::Text(texts) => texts.len(),
        }
    }

    /// Field `i` as written.
    pub(crate) fn text(&self, i: usize) -> &'a str {
        match self.texts {
            Texts::Ascii { line, spans } => {
                let (start, end) = spans[i];
                std::str::from_utf8(&line[start..end]).expect("the fast path's lines are ASCII")
            }
            Texts::Text(texts) => texts[i],
        }
    }

    /// The values of a line the fast path split ([`ascii_numbers`]), all of its fields.
    pub(crate) fn values(&self) -> Option<&'a [f64]> {
        self.values
    }

    /// Field `i` as a number ([`parse`]; `column` names it in the error).
    pub(crate) fn number(&self, i: usize, column: &'static str) -> Result<f64, KfGinsErrorKind> {
        match self.values {
            Some(values) => Ok(values[i]),
            None => parse(self.text(i), column),
        }
    }
}

/// The most fields a line is split into without a vector (every format has fewer).
const MAX_FIELDS: usize = 16;

/// A line to skip: blank or a comment.
fn skipped(text: &str) -> bool {
    text.is_empty() || text.starts_with('#') || text.starts_with('%')
}

/// `true` when the first data line of `head` (the start of a file) is a complete line of 7 or 8
/// numbers: a KF-GINS IMU file (a `.nav` trajectory has 11, PSINS lines 6).
pub fn looks_like_imu(head: &str) -> bool {
    first_numbers(head).is_some_and(|f| matches!(f.len(), 7 | 8)) && !looks_like_gnss(head)
}

/// `true` when the first data line of `head` is a KF-GINS GNSS fix of 7 numbers (seconds of
/// week, latitude and longitude [deg], height [m], 1-sigma north, east, down [m]), not an IMU
/// line of the same width: a latitude and longitude inside their ranges, one of them beyond
/// 1 — no IMU's angle increment reaches 1 rad in one sample — and three positive 1-sigmas.
pub fn looks_like_gnss(head: &str) -> bool {
    first_numbers(head).is_some_and(|f| {
        f.len() == 7
            && f[1].abs() <= 90.0
            && f[2].abs() <= 180.0
            && (f[1].abs() > 1.0 || f[2].abs() > 1.0)
            && f[4..].iter().all(|s| *s > 0.0)
    })
}

/// The numbers of the first complete data line of `head` (the start of a file), if all of its
/// fields are numbers.
fn first_numbers(head: &str) -> Option<Vec<f64>> {
    let head = head.trim_start_matches('\u{feff}');
    // Only complete lines: the last piece may be cut off.
    let mut lines: Vec<&str> = head.split('\n').collect();
    lines.pop();
    let line = lines.into_iter().map(str::trim).find(|l| !skipped(l))?;
    fields(line).map(|x| x.parse::<f64>().ok()).collect()
}

/// Reads a KF-GINS IMU file into memory (a replay streams it instead: [`ImuReader`]).
pub fn read_imu(path: &Path) -> Result<KfGinsImu, KfGinsError> {
    let file = File::open(path).map_err(|e| TextError::io(path, e))?;
    read_imu_from(BufReader::new(file), path)
}

/// Reads a KF-GINS IMU file from `reader` into memory; `path` names it in errors.
pub fn read_imu_from<R: BufRead>(reader: R, path: &Path) -> Result<KfGinsImu, KfGinsError> {
    Ok(KfGinsImu {
        rows: ImuReader::new(reader, path).collect::<Result<_, _>>()?,
    })
}

/// The rows of a KF-GINS IMU file, read one at a time (memory bounded by the longest line).
/// Stops after the first error.
#[derive(Debug)]
pub struct ImuReader<R> {
    lines: DataLines<R>,
    previous_t_s: Option<f64>,
    /// The columns every line must have (KF-GINS's `imudatalen`); `None`: 7 or 8.
    columns: Option<usize>,
}

impl<R: BufRead> ImuReader<R> {
    /// Reads `reader` from its start; `path` names it in errors.
    pub fn new(reader: R, path: &Path) -> Self {
        Self {
            lines: DataLines::new(reader, path, FileKind::Imu),
            previous_t_s: None,
            columns: None,
        }
    }

    /// Refuses a line of other than `columns` fields (a configuration's `imudatalen`: KF-GINS
    /// reads that many numbers a line, so a file of the other width is misread there).
    pub fn with_columns(mut self, columns: usize) -> Self {
        self.columns = Some(columns);
        self
    }
}

impl<R: BufRead> Iterator for ImuReader<R> {
    type Item = Result<KfGinsImuRow, KfGinsError>;

    fn next(&mut self) -> Option<Self::Item> {
        let previous_t_s = &mut self.previous_t_s;
        let columns = self.columns;
        self.lines.next_with(|values, at| {
            if let Some(n) = columns
                && values.len() != n
            {
                return Err(at(KfGinsErrorKind::ColumnCount {
                    expected: format!("{n} columns (imudatalen)"),
                    found: values.len(),
                    hint: None,
                }));
            }
            let number = |i: usize| values.number(i, IMU_COLUMNS[i]).map_err(at);
            // A line the fast path split has its values at hand: taken as they are (720,000
            // lines; [`Fields::number`] returns each through a `Result` that carries a whole
            // error). 7 or 8 fields: checked before.
            let fast = values.values();
            let t_s = match fast {
                Some(v) => v[0],
                None => number(0)?,
            };
            check_time(t_s, || values.text(0)).map_err(at)?;
            if let Some(previous) = *previous_t_s
                && t_s <= previous
            {
                return Err(at(KfGinsErrorKind::TimeNotIncreasing {
                    column: IMU_COLUMNS[0],
                    t_s,
                    previous_t_s: previous,
                    record: Record::Line,
                }));
            }
            *previous_t_s = Some(t_s);
            Ok(match fast {
                Some(v) => KfGinsImuRow {
                    t_s,
                    delta_theta_ib_b: [v[1], v[2], v[3]],
                    delta_v_ib_b: [v[4], v[5], v[6]],
                },
                None => KfGinsImuRow {
                    t_s,
                    delta_theta_ib_b: [number(1)?, number(2)?, number(3)?],
                    delta_v_ib_b: [number(4)?, number(5)?, number(6)?],
                },
            })
        })
    }
}

/// Reads a KF-GINS trajectory (`.nav`) file; times are seconds of week.
pub fn read_truth(path: &Path) -> Result<Vec<Truth>, KfGinsError> {
    let file = File::open(path).map_err(|e| TextError::io(path, e))?;
    read_truth_from(BufReader::new(file), path)
}

/// Reads a KF-GINS trajectory from `reader`; `path` names it in errors.
pub fn read_truth_from<R: BufRead>(reader: R, path: &Path) -> Result<Vec<Truth>, KfGinsError> {
    NavReader::new(reader, path).collect()
}

/// The rows of a KF-GINS trajectory (`.nav`) file, read one at a time. Stops after the first
/// error.
#[derive(Debug)]
pub struct NavReader<R> {
    lines: DataLines<R>,
    week0: Option<f64>,
    previous_t_s: Option<f64>,
}

impl<R: BufRead> NavReader<R> {
    /// Reads `reader` from its start; `path` names it in errors.
    pub fn new(reader: R, path: &Path) -> Self {
        Self {
            lines: DataLines::new(reader, path, FileKind::Nav),
            week0: None,
            previous_t_s: None,
        }
    }
}

impl<R: BufRead> Iterator for NavReader<R> {
    type Item = Result<Truth, KfGinsError>;

    fn next(&mut self) -> Option<Self::Item> {
        let (week0, previous_t_s) = (&mut self.week0, &mut self.previous_t_s);
        self.lines.next_with(|fields, at| {
            let mut v = [0.0_f64; NAV_COLUMNS.len()];
            for (i, slot) in v.iter_mut().enumerate() {
                let x = fields.number(i, NAV_COLUMNS[i]).map_err(at)?;
                if !x.is_finite() {
                    return Err(at(KfGinsErrorKind::NotFinite {
                        column: NAV_COLUMNS[i],
                        found: fields.text(i).to_owned(),
                    }));
                }
                *slot = x;
            }
            let week = v[WEEK];
            if week < 0.0 || week.fract() != 0.0 {
                return Err(at(KfGinsErrorKind::BadWeek { week }));
            }
            match *week0 {
                Some(w) if w != week => {
                    return Err(at(KfGinsErrorKind::WeekChange { from: w, to: week }));
                }
                _ => *week0 = Some(week),
            }
            check_time(v[SOW], || fields.text(SOW)).map_err(at)?;
            if let Some(previous) = *previous_t_s
                && v[SOW] < previous
            {
                return Err(at(KfGinsErrorKind::TimeBackwards {
                    column: NAV_COLUMNS[SOW],
                    t_s: v[SOW],
                    previous_t_s: previous,
                    record: Record::Line,
                }));
            }
            *previous_t_s = Some(v[SOW]);
            if !(-90.0..=90.0).contains(&v[LAT]) {
                return Err(at(KfGinsErrorKind::BadLatitude {
                    column: NAV_COLUMNS[LAT],
                    lat_deg: v[LAT],
                }));
            }
            Ok(Truth {
                t_s: v[SOW],
                lat: v[LAT].to_radians(),
                lon: v[LON].to_radians(),
                h: v[H],
                v_eb_ned: Vector3::new(v[VEL], v[VEL + 1], v[VEL + 2]),
                q_b_ned: from_euler(
                    v[ATT].to_radians(),
                    v[ATT + 1].to_radians(),
                    v[ATT + 2].to_radians(),
                ),
            })
        })
    }
}

/// Makes an error of the current line.
pub(crate) type LineError<'a> = &'a dyn Fn(KfGinsErrorKind) -> KfGinsError;

/// The data lines of a KF-GINS file with the right number of fields, one at a time; the last
/// line, when no newline ends it, checked for a cut ([`crate::text_stream`]). Errors when there
/// is no data line; stops after the first error.
#[derive(Debug)]
pub(crate) struct DataLines<R> {
    lines: LineReader<R>,
    path: PathBuf,
    file: FileKind,
    cut: CutCheck,
    any: bool,
    done: bool,
}

impl<R: BufRead> DataLines<R> {
    pub(crate) fn new(reader: R, path: &Path, file: FileKind) -> Self {
        Self {
            lines: LineReader::new(reader),
            path: path.to_owned(),
            file,
            cut: CutCheck::default(),
            any: false,
            done: false,
        }
    }

    /// `row(fields, at)` of the next data line; `at` makes an error of that line.
    pub(crate) fn next_with<T>(
        &mut self,
        row: impl FnOnce(&Fields, LineError) -> Result<T, KfGinsError>,
    ) -> Option<Result<T, KfGinsError>> {
        if self.done {
            return None;
        }
        let result = self.next_line(row);
        self.done = !matches!(result, Some(Ok(_)));
        result
    }

    fn next_line<T>(
        &mut self,
        row: impl FnOnce(&Fields, LineError) -> Result<T, KfGinsError>,
    ) -> Option<Result<T, KfGinsError>> {
        let (path, file) = (&self.path, self.file);
        loop {
            let line = match self.lines.next_bytes() {
                None if self.any => return None,
                None => {
                    let kind = KfGinsErrorKind::NoData {
                        columns: file.columns(),
                    };
                    return Some(Err(TextError::new(path, None, kind)));
                }
                Some(Err((line_no, e))) => {
                    return Some(Err(TextError::new(
                        path,
                        Some(line_no),
                        KfGinsErrorKind::Io(e),
                    )));
                }
                Some(Ok(line)) => line,
            };
            let line_no = line.number;
            let at = |kind| TextError::new(path, Some(line_no), kind);
            // The fields in stack arrays (no allocation per line: 720,000-line files), a
            // vector only for a line the fast path does not take.
            let mut spans = [(0, 0); MAX_FIELDS];
            let mut numbers = [0.0; MAX_FIELDS];
            // The fast path: a complete line of ASCII numbers, split straight from the bytes
            // (what the text path below does with it, without its UTF-8 check and trims).
            if !line.unterminated {
                let bytes = trim_ascii(line.bytes);
                if let Some(n) = ascii_numbers(bytes, &mut spans, &mut numbers)
                    && n > 0
                {
                    let spans = &spans[..n];
                    // ASCII: the fields' characters are their bytes.
                    self.cut.note_lengths(spans.iter().map(|(a, b)| b - a));
                    let fields = Fields {
                        texts: Texts::Ascii { line: bytes, spans },
                        values: Some(&numbers[..n]),
                    };
                    return Some(data_row(file, &mut self.any, &fields, &at, row));
                }
            }
            let text = match std::str::from_utf8(line.bytes) {
                Ok(text) => text,
                Err(e) => {
                    let e = crate::text_stream::not_utf8(line.bytes, line.start, &e);
                    return Some(Err(at(KfGinsErrorKind::Io(e))));
                }
            };
            let text = text
                .trim_end_matches(['\n', '\r'])
                .trim()
                .trim_start_matches('\u{feff}');
            if skipped(text) {
                continue;
            }
            let fast = ascii_numbers(text.as_bytes(), &mut spans, &mut numbers);
            let mut array = [""; MAX_FIELDS];
            let spilled: Option<Vec<&str>> = match fast {
                Some(n) => {
                    for (t, (a, b)) in array.iter_mut().zip(&spans[..n]) {
                        *t = &text[*a..*b]; // ASCII bytes: character boundaries
                    }
                    None
                }
                None => Some(fields(text).collect()),
            };
            let values: &[&str] = match (&spilled, fast) {
                (Some(v), _) => v,
                (None, n) => &array[..n.unwrap_or(0)],
            };
            if line.unterminated {
                let n = values.len();
                let column = |i: usize| file.column(i, n);
                let is_number = |_: usize, text: &str| text.parse::<f64>().is_ok();
                let min_fields = file.columns().len();
                if let Err(cut) = self.cut.check(values, min_fields, column, is_number) {
                    let kind = KfGinsErrorKind::Truncated { line: line_no, cut };
                    return Some(Err(TextError::new(path, None, kind)));
                }
            } else if fast.is_some() {
                // The fast path's fields are ASCII: their characters are their bytes.
                self.cut.note_lengths(values.iter().map(|f| f.len()));
            } else {
                self.cut.note(values.iter().copied());
            }
            let fields = Fields {
                texts: Texts::Text(values),
                values: fast.map(|n| &numbers[..n]),
            };
            return Some(data_row(file, &mut self.any, &fields, &at, row));
        }
    }
}

/// `row(fields, at)` of a data line of `file` whose fields are split, after the check of
/// their count; `any` notes that the file has a data line.
fn data_row<T>(
    file: FileKind,
    any: &mut bool,
    fields: &Fields,
    at: LineError,
    row: impl FnOnce(&Fields, LineError) -> Result<T, KfGinsError>,
) -> Result<T, KfGinsError> {
    let n = fields.len();
    if !file.allows(n) {
        return Err(at(KfGinsErrorKind::ColumnCount {
            expected: file.expected().to_owned(),
            found: n,
            hint: file.hint(n),
        }));
    }
    *any = true;
    row(fields, at)
}

pub(crate) fn parse(text: &str, column: &'static str) -> Result<f64, KfGinsErrorKind> {
    // Correctly rounded, and the syntax of `str::parse::<f64>` (checked in the tests).
    fast_float2::parse(text).map_err(|_| KfGinsErrorKind::NotANumber {
        column,
        found: text.to_owned(),
    })
}

/// A time must be finite, non-negative and within the recording clock's range (it becomes
/// nanoseconds on the recording's clock); `text()` is the field as written, for the error.
pub(crate) fn check_time<'a>(
    t_s: f64,
    text: impl FnOnce() -> &'a str,
) -> Result<(), KfGinsErrorKind> {
    if !t_s.is_finite() {
        Err(KfGinsErrorKind::NotFinite {
            column: "seconds of week",
            found: text().to_owned(),
        })
    } else if t_s < 0.0 {
        Err(KfGinsErrorKind::NegativeTime { t_s })
    } else if seconds_to_ns(t_s).is_none() {
        Err(KfGinsErrorKind::TimeOutOfRange {
            column: "seconds of week",
            t_s,
        })
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nav_core::UnitQuaternion;

    /// Three lines as KF-GINS's demo data looks (200 Hz, seconds of week), one with commas and
    /// an odometer column.
    const IMU: &str = "456300.005000000  -0.000011342  0.000002745 -0.000003281  0.000220490 -0.000030405 -0.049042720\n\
                       456300.010000000\t-0.000011120\t0.000002540\t-0.000003501\t0.000222310\t-0.000030801\t-0.049046570\n\
                       \n\
                       456300.015,-1.1e-5, 2.6e-6,-3.4e-6,0.00022,-3.1e-5,-0.04904, 0.0\n";

    fn imu(text: &str) -> Result<KfGinsImu, KfGinsError> {
        read_imu_from(text.as_bytes(), Path::new("mem.txt"))
    }

    fn nav(text: &str) -> Result<Vec<Truth>, KfGinsError> {
        read_truth_from(text.as_bytes(), Path::new("mem.nav"))
    }

    #[test]
    fn reads_imu_lines() {
        let r = imu(IMU).unwrap();
        assert_eq!(r.rows.len(), 3);
        assert_eq!(r.rows[0].t_s, 456_300.005);
        assert_eq!(
            r.rows[0].delta_theta_ib_b,
            [-0.000011342, 0.000002745, -0.000003281]
        );
        assert_eq!(r.rows[1].delta_v_ib_b[2], -0.049046570);
        assert_eq!(r.rows[2].t_s, 456_300.015);
        assert_eq!(r.rows[2].delta_v_ib_b, [0.00022, -3.1e-5, -0.04904]);
        let csv = r.to_imu_csv();
        assert_eq!(csv.rows[0].delta_v_ib_b[2], -0.049_042_72_f64 as f32);
        assert!(csv.rows[0].temperature_c.is_nan());
    }

    /// The fast path reads numbers as `str::parse::<f64>` does (same values to the bit, same
    /// refusals), and hands any other line to the general split.
    #[test]
    fn fast_numbers_are_str_parse() {
        for text in [
            "456300.005000000",
            "-5.822414095746353e-6",
            "1e-300",
            "4.9e-324",
            "1.7976931348623157e308",
            "1e309",
            "+1.5",
            ".5",
            "5.",
            "1E+5",
            "0.1",
            "-0",
            "nan",
            "NaN",
            "-nan",
            "inf",
            "-inf",
            "Infinity",
            "123456789012345678901234567890",
            "2.2250738585072011e-308",
            "",
            ".",
            "e5",
            "1e",
            "1e+",
            "--1",
            "0x10",
            "1_000",
            "1.2.3",
            "١",
        ] {
            let std = text.parse::<f64>();
            let fast = fast_float2::parse::<f64, _>(text);
            assert_eq!(std.is_ok(), fast.is_ok(), "{text:?}");
            if let (Ok(a), Ok(b)) = (std, fast) {
                assert!(
                    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                    "{text:?}"
                );
            }
        }
        let (mut spans, mut values) = ([(0, 0); MAX_FIELDS], [0.0; MAX_FIELDS]);
        assert_eq!(
            ascii_numbers(b"1 -2e3,\t.5 ", &mut spans, &mut values),
            Some(3)
        );
        assert_eq!((spans[1], values[1]), ((2, 6), -2000.0));
        for other in ["1 2x 3", "1\r 2", "1 \u{a0}2", &"1 ".repeat(MAX_FIELDS + 1)] {
            assert_eq!(
                ascii_numbers(other.as_bytes(), &mut spans, &mut values),
                None,
                "{other:?}"
            );
        }
        assert_eq!(trim_ascii(b" \t\x0b1 2\r\x0c"), b"1 2");
        assert_eq!(trim_ascii(b" \r "), b"");
        // What the fast path trims is what `str::trim` takes off an ASCII line.
        let ascii: String = (0..128u8).map(char::from).collect();
        let white: String = ascii.chars().filter(|c| c.is_whitespace()).collect();
        let padded = format!("{white}1{white}");
        assert_eq!(trim_ascii(padded.as_bytes()), padded.trim().as_bytes());
    }

    #[test]
    fn detects_imu_files_only() {
        assert!(looks_like_imu(IMU));
        assert!(looks_like_imu(&format!("# comment\n\n{IMU}")));
        // A .nav line (11 numbers), a PSINS header line (6), a CSV header, a cut-off line.
        assert!(!looks_like_imu(
            "0 456300.005 30.44 114.47 20.9 0 0 0 0.85 -2.03 185.7\n"
        ));
        assert!(!looks_like_imu("0 0 -90.6 0 0 0\n1 2 3 4 5 6 7\n"));
        assert!(!looks_like_imu(
            "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps\n"
        ));
        assert!(!looks_like_imu("456300.005 1 2 3 4 5 6"));
    }

    #[test]
    fn tells_a_gnss_file_from_an_imu_file_of_the_same_width() {
        let gnss = "456300.000 30.4447873 114.4718270 20.830 0.02 0.02 0.04\n";
        assert!(looks_like_gnss(gnss));
        assert!(!looks_like_imu(gnss));
        assert!(looks_like_gnss(&format!("# fixes\n{gnss}")));
        assert!(!looks_like_gnss(IMU));
        // Near the origin of latitude and longitude, or with a zero sigma: not taken for GNSS.
        assert!(!looks_like_gnss("456300 0.5 0.5 20 0.02 0.02 0.04\n"));
        assert!(!looks_like_gnss("456300 30.4 114.4 20 0 0.02 0.04\n"));
        assert!(!looks_like_gnss("456300 95 114.4 20 0.02 0.02 0.04\n"));
    }

    #[test]
    fn imu_errors_name_file_line_and_column() {
        let msg = |text: &str| imu(text).unwrap_err().to_string();
        let bad = IMU.replace("0.000002540", "0.0000x2540");
        assert_eq!(
            msg(&bad),
            "mem.txt: line 2: column dtheta y: expected a number, found '0.0000x2540'"
        );
        let bad = IMU.replace("456300.010000000", "456300.005");
        assert_eq!(
            msg(&bad),
            "mem.txt: line 2: column seconds of week: time does not increase: 456300.005 s after \
             456300.005 s on the previous line"
        );
        let m = msg("1 2 3 4 5 6\n");
        assert!(
            m.starts_with("mem.txt: line 1: expected 7 numbers") && m.ends_with("found 6"),
            "{m}"
        );
        let m = msg("0 456300.005 30.44 114.47 20.9 0 0 0 0.85 -2.03 185.7\n");
        assert!(
            m.ends_with("found 11 (is this a KF-GINS .nav trajectory?)"),
            "{m}"
        );
        assert!(msg("-1 0 0 0 0 0 0\n").contains("non-negative time"));
        assert!(msg("# only a comment\n").contains("no data"));
        // NaN increments are parsed (the replay flags them), a NaN time is not.
        assert!(imu("1 NaN 0 0 0 0 0\n").unwrap().rows[0].delta_theta_ib_b[0].is_nan());
        assert_eq!(
            msg("nan 0 0 0 0 0 0\n"),
            "mem.txt: line 1: column seconds of week: expected a finite number, found 'nan'"
        );
    }

    #[test]
    fn recording_io_detects_and_converts() {
        use crate::recording_io::{self, Format};
        use hal_adapters::recording::Kind;
        let dir = tempfile::tempdir().unwrap();
        // 200 Hz with one 10 ms gap; any file name.
        let text: String = [0, 1, 2, 4, 5]
            .iter()
            .map(|k| {
                format!(
                    "{} 1e-6 0 0 0 0 -0.049\n",
                    456_300.0 + 0.005 * f64::from(*k)
                )
            })
            .collect();
        let path = dir.path().join("imu.data");
        std::fs::write(&path, &text).unwrap();
        assert_eq!(recording_io::detect(&path).unwrap(), Format::KfGins);
        let r = recording_io::read(&path).unwrap();
        assert_eq!(r.kind, Kind::Increments);
        assert_eq!(r.records.len(), 5);
        assert!((r.rate_hz - 200.0).abs() < 1e-6, "{}", r.rate_hz);
        assert_eq!(r.records[0].t_ns, 456_300_000_000_000);
        assert_eq!(r.t0_ns, 456_299_995_000_000);
        assert_eq!(r.records[3].t_ns, 456_300_020_000_000);
        assert_eq!(r.records[0].gyro, [1e-6, 0.0, 0.0]);
        assert!(r.records[0].temperature_c.is_nan());

        // A damaged .txt file gets the KF-GINS reader's message.
        let bad = dir.path().join("bad.txt");
        std::fs::write(&bad, "456300 1 2 3\n").unwrap();
        assert_eq!(recording_io::detect(&bad).unwrap(), Format::KfGins);
        let msg = format!("{:#}", recording_io::read(&bad).unwrap_err());
        assert!(msg.contains("bad.txt: line 1: expected 7 numbers"), "{msg}");
    }

    /// KF-GINS writes `%-15.9lf ` fields: left-aligned, trailing blanks.
    const NAV: &str = "0.000000000     456300.005000000 30.444787370    114.471863205   20.899000000    0.000100000     -0.000200000    0.000300000     0.854215020     -2.034802950    185.702351330   \n\
                       0.000000000     456300.010000000 30.444787371    114.471863205   20.899100000    0.000100000     -0.000200000    0.000300000     0.854215020     -2.034802950    185.702351330   \n";

    #[test]
    fn reads_nav_lines() {
        let t = nav(NAV).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t[0].t_s, 456_300.005);
        assert_eq!(t[0].lat, 30.444787370_f64.to_radians());
        assert_eq!(t[0].lon, 114.471863205_f64.to_radians());
        assert_eq!(t[1].h, 20.8991);
        assert_eq!(t[0].v_eb_ned, Vector3::new(0.0001, -0.0002, 0.0003));
        let q = UnitQuaternion::from_euler_angles(
            0.854215020_f64.to_radians(),
            (-2.034802950_f64).to_radians(),
            185.702351330_f64.to_radians(),
        );
        assert!(t[0].q_b_ned.angle_to(&q) < 1e-15);
    }

    #[test]
    fn nav_errors_name_file_line_and_column() {
        let msg = |text: &str| nav(text).unwrap_err().to_string();
        let second = NAV.lines().nth(1).unwrap();
        let first = NAV.lines().next().unwrap();
        assert_eq!(
            msg(&format!("{second}\n{first}\n")),
            "mem.nav: line 2: column seconds of week: time goes backwards: 456300.005 s after \
             456300.01 s on the previous line"
        );
        assert_eq!(
            msg(&NAV.replace("185.702351330   \n0.0", "NaN\n0.0")),
            "mem.nav: line 1: column yaw: expected a finite number, found 'NaN'"
        );
        assert!(msg(&NAV.replacen("0.000000000 ", "1.5 ", 1)).contains("line 1: column week"));
        let m = msg(&NAV.replacen("0.000000000 ", "1 ", 1));
        assert!(
            m.contains("line 2: column week: the GNSS week changes from 1 to 0"),
            "{m}"
        );
        let m = msg("456300.005 1 2 3 4 5 6\n");
        assert!(m.ends_with("found 7 (is this a KF-GINS IMU file?)"), "{m}");
        assert!(msg(&NAV.replace("30.444787370", "91")).contains("latitude: 91 deg"));
        // Equal times are allowed in a trajectory.
        let first = format!("{first}\n");
        nav(&first.repeat(2)).unwrap();
    }
}
