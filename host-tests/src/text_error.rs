//! The error of the text-format readers and writers ([`crate::imu_csv`], [`crate::truth_csv`],
//! [`crate::kf_gins`], [`crate::oscillator::file`]): the file, the line (for content errors) and
//! what went wrong; and the conversion of a text time to the recording clock
//! ([`seconds_to_ns`]).
//!
//! Messages read `<path>: line <n>: <what>` (no line for errors about the whole file). Where two
//! formats word the same case differently, the kind carries what differs (the column's name, the
//! expected header, whether records are rows or lines).

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

use crate::truth_csv::MAX_YAW_DEG;
use nav_core::number::{Number, Shown};

/// The largest time the recording clock holds [s]: `u64::MAX` nanoseconds (about 584 years).
/// The binary format's `t_ns` and the samples' `t_us` derive from it.
pub const MAX_TIME_S: f64 = 18_446_744_073.709_553;

/// `round(t_s * 1e9)` [ns] on the recording clock, or `None` for a time that is not finite, is
/// negative or is beyond [`MAX_TIME_S`] (a cast would saturate or wrap silently).
pub fn seconds_to_ns(t_s: f64) -> Option<u64> {
    // 2^64 is exactly representable in f64; anything rounding to it or above does not fit.
    const TWO_POW_64: f64 = 18_446_744_073_709_551_616.0;
    let ns = (t_s * 1e9).round();
    (t_s.is_finite() && t_s >= 0.0 && ns < TWO_POW_64).then_some(ns as u64)
}

/// `e` told as `label` (what the file is, and its path): the readers' errors start with the
/// file's path already, which then follows the label rather than repeating it (`GNSS file
/// g.txt: line 1: ...`, not `GNSS file g.txt: g.txt: line 1: ...`); an error that does not
/// start with it gets the label in front.
pub fn told_as(e: anyhow::Error, path: &Path, label: String) -> anyhow::Error {
    let message = format!("{e:#}");
    match message.strip_prefix(&format!("{}: ", path.display())) {
        Some(rest) => anyhow::anyhow!("{label}: {rest}"),
        None => e.context(label),
    }
}

/// The text of the whole file `path`; not UTF-8, refused with the line and byte where it stops
/// being (`std`'s "stream did not contain valid UTF-8" named neither). Errors start with the
/// path.
pub fn read_text(path: &Path) -> anyhow::Result<String> {
    let bytes = std::fs::read(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        anyhow::anyhow!(
            "{}: line {line}: not UTF-8 text (byte {at}, 0x{:02x}): save the file as UTF-8",
            path.display(),
            bytes[at]
        )
    })
}

/// Refuses `path` when it is neither a regular file nor a folder (a pipe, a FIFO, a device):
/// the readers open an input more than once (its format is told from its first bytes, then it
/// is read from the start; `nav convert` reads it twice), and a stream read a second time
/// starts where the first read stopped, so valid data were refused as damaged. A path that
/// cannot be looked at is left to the open, which says why.
pub fn refuse_a_stream(path: &Path) -> io::Result<()> {
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() && !m.is_dir() => Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{}: not a regular file (a pipe, FIFO or device): pipes are not supported, as \
                 the file is read more than once; give a file (save the stream to one first)",
                path.display()
            ),
        )),
        _ => Ok(()),
    }
}

/// `x` as a message shows it: `{}`, but in exponent form when very large or very small (`1e300`,
/// not 301 digits).
pub fn number_text(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-6..1e15).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// Why the last line of a file, which no newline ends, looks cut off inside a field. A line that
/// ends with a newline is complete; one that does not is checked against the lines before it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Cut {
    /// It has fewer fields than a line of the file needs.
    Fields {
        /// Fields found.
        found: usize,
        /// Fields a line has (the header's, or the line before's).
        expected: usize,
    },
    /// Its last field is not a number (e.g. `1.5e` or `-`).
    NotANumber {
        /// Name of the last field's column.
        column: String,
        /// The field's text.
        found: String,
    },
    /// Its last field has fewer characters than that column's field on every line before it.
    Shorter {
        /// Name of the last field's column.
        column: String,
        /// The field's text.
        found: String,
        /// The fewest characters of that column's fields on the lines before.
        shortest: usize,
    },
}

impl fmt::Display for Cut {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Fields { found, expected } => {
                write!(f, "it has {found} of the {expected} fields of a line")
            }
            Self::NotANumber { column, found } => {
                write!(f, "column {column}: '{found}' is not a number")
            }
            Self::Shorter {
                column,
                found,
                shortest,
            } => write!(
                f,
                "column {column}: '{found}' has {} characters, the lines before at least {shortest}",
                found.chars().count()
            ),
        }
    }
}

/// A reading or writing error, naming the file and (for content errors) the line.
#[derive(Debug)]
pub struct TextError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line number, when the error is about a line.
    pub line: Option<u64>,
    /// What went wrong.
    pub kind: TextErrorKind,
}

/// What a file's records are called in messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Record {
    /// A CSV row.
    Row,
    /// A line of a whitespace-separated text file.
    Line,
}

impl fmt::Display for Record {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Row => "row",
            Self::Line => "line",
        })
    }
}

/// What went wrong in a text file.
#[derive(Debug)]
pub enum TextErrorKind {
    /// The file is empty: no header row.
    MissingHeader {
        /// The expected header row.
        expected: String,
    },
    /// The first row is not the expected header.
    WrongHeader {
        /// The expected header row.
        expected: String,
        /// A column that may follow the expected ones.
        optional: Option<&'static str>,
        /// The header row found.
        found: String,
    },
    /// The header lacks a required column.
    HeaderMissingColumn {
        /// The missing column's name.
        column: &'static str,
        /// The expected columns, as a header row.
        expected: String,
        /// The header row found.
        found: String,
    },
    /// The header names a column the reader maps by name twice (which one is meant is unknown).
    HeaderDuplicateColumn {
        /// The column's name.
        column: &'static str,
        /// 1-based positions of its first two occurrences.
        positions: (usize, usize),
    },
    /// The file holds no data line (headerless formats).
    NoData {
        /// The columns of a line.
        columns: &'static [&'static str],
    },
    /// A line has the wrong number of fields.
    ColumnCount {
        /// What was expected, e.g. `4 columns (t_s,x_m,y_m,z_m)`.
        expected: String,
        /// Number of fields found.
        found: usize,
        /// A guess at what the file is instead, e.g. `is this a KF-GINS IMU file?`.
        hint: Option<&'static str>,
    },
    /// A row is shorter than the header: the first missing column.
    MissingColumn {
        /// Name of the missing column.
        column: &'static str,
        /// Number of fields found on the line.
        found: usize,
    },
    /// A row has more columns than the header.
    ExtraColumns {
        /// Number of columns expected.
        expected: usize,
        /// Number of fields found.
        found: usize,
    },
    /// A field is not a number.
    NotANumber {
        /// Column name.
        column: &'static str,
        /// The field's text.
        found: String,
    },
    /// A field is NaN or infinite where a finite number is needed.
    NotFinite {
        /// Column name.
        column: &'static str,
        /// The field's text.
        found: String,
    },
    /// A displacement is infinite (NaN marks a missing sample).
    Infinite {
        /// Column name.
        column: &'static str,
        /// The field's text.
        found: String,
    },
    /// Some but not all of `x_m, y_m, z_m` are NaN.
    PartlyMissing {
        /// The first NaN column.
        column: &'static str,
    },
    /// The time (column `t_s`) is negative, NaN or infinite.
    BadTime {
        /// The field's text.
        found: String,
    },
    /// The time (GNSS seconds of week) is negative.
    NegativeTime {
        /// The time found [s].
        t_s: f64,
    },
    /// The GNSS week is not a non-negative whole number.
    BadWeek {
        /// The week found.
        week: f64,
    },
    /// The GNSS week changes within the file.
    WeekChange {
        /// The previous line's week.
        from: f64,
        /// This line's week.
        to: f64,
    },
    /// The latitude is outside [-90, 90] deg.
    BadLatitude {
        /// Column name; the message names the latitude unless the column is called `latitude`.
        column: &'static str,
        /// The latitude found [deg].
        lat_deg: f64,
    },
    /// A sensor temperature is outside [`crate::imu_csv::TEMPERATURE_RANGE_C`] (or infinite).
    BadTemperature {
        /// Column name.
        column: &'static str,
        /// The temperature found [deg C].
        temp_c: f32,
    },
    /// A trajectory's yaw is outside [-[`MAX_YAW_DEG`], [`MAX_YAW_DEG`]] deg.
    BadYaw {
        /// Column name.
        column: &'static str,
        /// The yaw found [deg].
        yaw_deg: f64,
    },
    /// The longitude is outside [-180, 180] deg (refused, not wrapped, as a site's).
    BadLongitude {
        /// Column name; the message names the longitude unless the column is called
        /// `longitude`.
        column: &'static str,
        /// The longitude found [deg].
        lon_deg: f64,
    },
    /// A sample's time (column `t_s`) is not later than the previous row's.
    SampleTimeNotIncreasing {
        /// The previous row's time [s].
        previous: f64,
        /// This row's time [s].
        found: f64,
    },
    /// A time is not later than the previous record's.
    TimeNotIncreasing {
        /// Column name.
        column: &'static str,
        /// This record's time [s].
        t_s: f64,
        /// The previous record's time [s].
        previous_t_s: f64,
        /// What a record is called.
        record: Record,
    },
    /// A time is earlier than the previous record's.
    TimeBackwards {
        /// Column name.
        column: &'static str,
        /// This record's time [s].
        t_s: f64,
        /// The previous record's time [s].
        previous_t_s: f64,
        /// What a record is called.
        record: Record,
    },
    /// A time is beyond the recording clock's range: `u64` nanoseconds, [`MAX_TIME_S`].
    TimeOutOfRange {
        /// Column name.
        column: &'static str,
        /// The time found [s].
        t_s: f64,
    },
    /// The file's last line, which no newline ends, looks cut off (see [`Cut`]).
    Truncated {
        /// 1-based number of the last line.
        line: u64,
        /// Why it looks cut off.
        cut: Cut,
    },
    /// Malformed CSV (quoting).
    Syntax(String),
    /// The file could not be opened, read or written.
    Io(io::Error),
}

impl TextError {
    /// An error in `path`, at `line` when the error is about a line.
    pub fn new(path: &Path, line: Option<u64>, kind: TextErrorKind) -> Self {
        Self {
            path: path.to_owned(),
            line,
            kind,
        }
    }

    /// `path` could not be opened, read or written.
    pub fn io(path: &Path, e: io::Error) -> Self {
        Self::new(path, None, TextErrorKind::Io(e))
    }

    /// A CSV reader's error in `path`: I/O or syntax, at the line the reader reports.
    pub fn from_csv(path: &Path, e: csv::Error) -> Self {
        let line = e.position().map(|p| p.line());
        let text = e.to_string();
        let kind = match e.into_kind() {
            csv::ErrorKind::Io(e) => TextErrorKind::Io(e),
            // Was "malformed CSV: invalid UTF-8: invalid utf-8: invalid UTF-8 in field 6 near
            // byte index 1".
            csv::ErrorKind::Utf8 { pos, err } => {
                let row =
                    pos.map_or_else(String::new, |p| format!(" of the row at byte {}", p.byte()));
                TextErrorKind::Io(io::Error::new(
                    io::ErrorKind::InvalidData,
                    format!(
                        "not UTF-8 text (field {}{row}, its byte {}): save the file as UTF-8",
                        err.field() + 1,
                        err.valid_up_to()
                    ),
                ))
            }
            csv::ErrorKind::UnequalLengths {
                expected_len, len, ..
            } => TextErrorKind::Syntax(format!(
                "a row of {len} fields where the previous row has {expected_len}"
            )),
            // The remaining kinds (seek, serialisation) are not a reader's: the error's text.
            _ => TextErrorKind::Syntax(text),
        };
        Self::new(path, line, kind)
    }
}

impl fmt::Display for TextError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.path.display())?;
        if let Some(line) = self.line {
            write!(f, "line {line}: ")?;
        }
        fmt::Display::fmt(&self.kind, f)
    }
}

impl fmt::Display for TextErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::MissingHeader { expected } => {
                write!(f, "empty file: expected the header row '{expected}'")
            }
            Self::WrongHeader {
                expected,
                optional,
                found,
            } => {
                write!(f, "expected the header row '{expected}'")?;
                if let Some(column) = optional {
                    write!(f, " (optionally followed by ',{column}')")?;
                }
                write!(f, ", found '{}'", Shown(found))
            }
            Self::HeaderMissingColumn {
                column,
                expected,
                found,
            } => write!(
                f,
                "the header has no column {column}: expected the columns '{expected}', found '{}'",
                Shown(found)
            ),
            Self::HeaderDuplicateColumn { column, positions } => write!(
                f,
                "the header names column {column} twice, as fields {} and {}: which one holds \
                 the values is unknown",
                positions.0, positions.1
            ),
            Self::NoData { columns } => write!(
                f,
                "no data: expected lines of {} numbers ({})",
                columns.len(),
                columns.join(", ")
            ),
            Self::ColumnCount {
                expected,
                found,
                hint,
            } => {
                write!(f, "expected {expected}, found {found}")?;
                match hint {
                    Some(hint) => write!(f, " ({hint})"),
                    None => Ok(()),
                }
            }
            Self::MissingColumn { column, found } => write!(
                f,
                "column {column}: missing (the line has only {found} columns)"
            ),
            Self::ExtraColumns { expected, found } => write!(
                f,
                "expected {expected} columns as in the header, found {found}"
            ),
            Self::NotANumber { column, found } => {
                write!(
                    f,
                    "column {column}: expected a number, found '{}'",
                    Shown(found)
                )
            }
            Self::NotFinite { column, found } => write!(
                f,
                "column {column}: expected a finite number, found '{}'",
                Shown(found)
            ),
            Self::Infinite { column, found } => write!(
                f,
                "column {column}: expected a finite displacement or NaN, found '{}'",
                Shown(found)
            ),
            Self::PartlyMissing { column } => write!(
                f,
                "column {column}: NaN, but not all of x_m, y_m, z_m are (a missing sample has all three NaN)"
            ),
            Self::BadTime { found } => write!(
                f,
                "column t_s: expected a finite, non-negative time in seconds, found '{}'",
                Shown(found)
            ),
            Self::NegativeTime { t_s } => write!(
                f,
                "column seconds of week: expected a non-negative time, found {t_s} s"
            ),
            Self::BadWeek { week } => write!(
                f,
                "column week: expected a non-negative whole GNSS week, found {week}"
            ),
            Self::WeekChange { from, to } => write!(
                f,
                "column week: the GNSS week changes from {from} to {to}; times are seconds of \
                 week, so a file must stay within one week"
            ),
            Self::BadLatitude { column, lat_deg } => {
                let what = if *column == "latitude" {
                    ""
                } else {
                    "latitude "
                };
                write!(
                    f,
                    "column {column}: {what}{} deg is outside [-90, 90]",
                    Number(*lat_deg)
                )
            }
            Self::BadTemperature { column, temp_c } => write!(
                f,
                "column {column}: {} (leave the field empty or write NaN when it is unknown)",
                crate::imu_csv::BadTemperature(*temp_c)
            ),
            Self::BadYaw { column, yaw_deg } => write!(
                f,
                "column {column}: yaw {} deg is outside [-{MAX_YAW_DEG}, {MAX_YAW_DEG}] \
                 (a heading: the solution logs write it in (-180, 180], KF-GINS in [0, 360))",
                Number(*yaw_deg)
            ),
            Self::BadLongitude { column, lon_deg } => {
                let what = if *column == "longitude" {
                    ""
                } else {
                    "longitude "
                };
                write!(
                    f,
                    "column {column}: {what}{} deg is outside [-180, 180] (refused, not \
                     wrapped: a converter's error)",
                    Number(*lon_deg)
                )
            }
            Self::SampleTimeNotIncreasing { previous, found } => write!(
                f,
                "column t_s: time {found} s does not increase (previous row {previous} s)"
            ),
            Self::TimeNotIncreasing {
                column,
                t_s,
                previous_t_s,
                record,
            } => write!(
                f,
                "column {column}: time does not increase: {t_s} s after {previous_t_s} s on the \
                 previous {record}"
            ),
            Self::TimeBackwards {
                column,
                t_s,
                previous_t_s,
                record,
            } => write!(
                f,
                "column {column}: time goes backwards: {t_s} s after {previous_t_s} s on the \
                 previous {record}"
            ),
            Self::TimeOutOfRange { column, t_s } => write!(
                f,
                "column {column}: time {} s is beyond the recording clock's range (0 to \
                 {MAX_TIME_S} s, u64 nanoseconds)",
                number_text(*t_s)
            ),
            Self::Truncated { line, cut } => write!(
                f,
                "truncated: last line {line} ends inside a field ({cut}; no newline ends the \
                 file; if the line is complete, end the file with a newline)"
            ),
            Self::Syntax(msg) => write!(f, "malformed CSV: {msg}"),
            Self::Io(e) => write!(f, "{e}"),
        }
    }
}

/// No `source`: the message already carries an I/O error's text, and an error chain printed
/// with its sources (`{:#}`) would repeat it.
impl std::error::Error for TextError {}

#[cfg(test)]
mod tests {
    use super::*;
    use std::error::Error;

    #[test]
    fn names_the_file_and_the_line_when_there_is_one() {
        let path = Path::new("f.csv");
        let e = TextError::new(
            path,
            Some(3),
            TextErrorKind::TimeBackwards {
                column: "t_s",
                t_s: 0.5,
                previous_t_s: 1.0,
                record: Record::Row,
            },
        );
        assert_eq!(
            e.to_string(),
            "f.csv: line 3: column t_s: time goes backwards: 0.5 s after 1 s on the previous row"
        );
        assert!(e.source().is_none());
        let e = TextError::io(path, io::Error::other("disk full"));
        assert_eq!(e.to_string(), "f.csv: disk full");
        assert!(e.source().is_none());
        assert_eq!(
            format!("{:#}", anyhow::Error::new(e).context("GNSS file")),
            "GNSS file: f.csv: disk full"
        );
    }

    /// A CSV reader's error is told in words, not as the csv crate's Debug dump.
    #[test]
    fn a_csv_row_of_the_wrong_length_is_told_in_words() {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .from_reader("1,2,3\n4,5\n".as_bytes());
        let e = reader
            .records()
            .find_map(|r| r.err())
            .expect("a row of the wrong length");
        let text = TextError::from_csv(Path::new("f.csv"), e).to_string();
        assert_eq!(
            text,
            "f.csv: line 2: malformed CSV: a row of 2 fields where the previous row has 3"
        );
    }

    /// A yaw, latitude, longitude or temperature of 1e300 printed 301 digits.
    #[test]
    fn huge_values_are_told_compact() {
        let told = |kind| TextError::new(Path::new("t.csv"), Some(2), kind).to_string();
        let column = "c";
        assert_eq!(
            told(TextErrorKind::BadYaw {
                column,
                yaw_deg: 1e300
            }),
            "t.csv: line 2: column c: yaw 1e300 deg is outside [-360, 360] (a heading: the \
             solution logs write it in (-180, 180], KF-GINS in [0, 360))"
        );
        let lat = told(TextErrorKind::BadLatitude {
            column,
            lat_deg: -1e300,
        });
        assert!(lat.contains("latitude -1e300 deg is outside"), "{lat}");
        let lon = told(TextErrorKind::BadLongitude {
            column,
            lon_deg: 1e300,
        });
        assert!(lon.contains("longitude 1e300 deg is outside"), "{lon}");
        let temp = told(TextErrorKind::BadTemperature {
            column,
            temp_c: 1e30,
        });
        assert!(temp.contains("column c: 1e30 deg C is outside"), "{temp}");
    }

    #[test]
    fn times_beyond_the_clock_do_not_convert() {
        assert_eq!(seconds_to_ns(0.0025), Some(2_500_000));
        assert_eq!(seconds_to_ns(1.8e10), Some(18_000_000_000_000_000_000));
        assert_eq!(number_text(1e300), "1e300");
        assert_eq!(number_text(2e10), "20000000000");
        assert_eq!(number_text(-0.0025), "-0.0025");
        for t_s in [MAX_TIME_S, 1e300, f64::INFINITY, f64::NAN, -1e-9] {
            assert_eq!(seconds_to_ns(t_s), None, "{t_s}");
        }
    }
}
