//! The oscillator readout file `osc.csv`: one row per sample.
//!
//! ```text
//! t_s,x_m,y_m,z_m
//! 0.0002,-7.1349155574e-6,1.3021806469e-5,2.7036637498e-5
//! 0.0004,NaN,NaN,NaN
//! ```
//!
//! `t_s` is the sample time [s] (finite, >= 0, increasing); `x_m, y_m, z_m` the displacement
//! `r_b` [m], body axes. Numbers are written in their shortest round-trip form (`{}` for time,
//! `{:e}` for the displacement), so a file reads back bit for bit. A row whose three values are
//! NaN (any case) is a missing or flagged sample and reads as `None`; a row with only some NaN,
//! an infinite value, or text that is not a number is an error naming the line and the column.

use super::OscSample;
use nav_core::Vector3;
use std::fmt;
use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// The columns.
pub const COLUMNS: [&str; 4] = ["t_s", "x_m", "y_m", "z_m"];

/// One row read back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OscRow {
    /// Sample time [s].
    pub t_s: f64,
    /// Displacement, body axes [m]; `None` for a missing sample (NaN row).
    pub r_b_m: Option<Vector3<f64>>,
}

/// A reading or writing error, naming the file and (for content errors) the line.
#[derive(Debug)]
pub struct OscCsvError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line number, when the error is about a line.
    pub line: Option<u64>,
    /// What went wrong.
    pub kind: OscCsvErrorKind,
}

/// What went wrong in an `osc.csv` file.
#[derive(Debug)]
pub enum OscCsvErrorKind {
    /// No header row.
    MissingHeader,
    /// The first row is not `t_s,x_m,y_m,z_m`.
    WrongHeader {
        /// The row found.
        found: String,
    },
    /// A row does not have 4 fields.
    ColumnCount {
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
    /// A displacement is infinite.
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
    /// The time is negative, NaN or infinite.
    BadTime {
        /// The field's text.
        found: String,
    },
    /// The time does not increase.
    TimeNotIncreasing {
        /// The previous row's time [s].
        previous: f64,
        /// This row's time [s].
        found: f64,
    },
    /// Malformed CSV (quoting, invalid UTF-8).
    Syntax(String),
    /// The file could not be opened, read or written.
    Io(io::Error),
}

impl fmt::Display for OscCsvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.path.display())?;
        if let Some(line) = self.line {
            write!(f, "line {line}: ")?;
        }
        let header = COLUMNS.join(",");
        match &self.kind {
            OscCsvErrorKind::MissingHeader => {
                write!(f, "empty file: expected the header row '{header}'")
            }
            OscCsvErrorKind::WrongHeader { found } => {
                write!(f, "expected the header row '{header}', found '{found}'")
            }
            OscCsvErrorKind::ColumnCount { found } => {
                write!(f, "expected 4 columns ({header}), found {found}")
            }
            OscCsvErrorKind::NotANumber { column, found } => {
                write!(f, "column {column}: expected a number, found '{found}'")
            }
            OscCsvErrorKind::Infinite { column, found } => write!(
                f,
                "column {column}: expected a finite displacement or NaN, found '{found}'"
            ),
            OscCsvErrorKind::PartlyMissing { column } => write!(
                f,
                "column {column}: NaN, but not all of x_m, y_m, z_m are (a missing sample has all three NaN)"
            ),
            OscCsvErrorKind::BadTime { found } => write!(
                f,
                "column t_s: expected a finite, non-negative time in seconds, found '{found}'"
            ),
            OscCsvErrorKind::TimeNotIncreasing { previous, found } => write!(
                f,
                "column t_s: time {found} s does not increase (previous row {previous} s)"
            ),
            OscCsvErrorKind::Syntax(msg) => write!(f, "malformed CSV: {msg}"),
            OscCsvErrorKind::Io(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for OscCsvError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            OscCsvErrorKind::Io(e) => Some(e),
            _ => None,
        }
    }
}

/// Writes rows to `osc.csv` (the header first).
pub struct OscCsvWriter<W: Write> {
    w: csv::Writer<W>,
}

impl<W: Write> OscCsvWriter<W> {
    /// A writer on `out`; writes the header.
    pub fn new(out: W) -> io::Result<Self> {
        let mut w = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(out);
        w.write_record(COLUMNS)?;
        Ok(Self { w })
    }

    /// One row: `r_b_m` [m] at `t_s` [s], or a missing sample (NaN row) for `None`.
    pub fn write_row(&mut self, t_s: f64, r_b_m: Option<&Vector3<f64>>) -> io::Result<()> {
        let r = r_b_m.copied().unwrap_or(Vector3::repeat(f64::NAN));
        self.w.write_record([
            format!("{t_s}"),
            format!("{:e}", r.x),
            format!("{:e}", r.y),
            format!("{:e}", r.z),
        ])?;
        Ok(())
    }

    /// One sample.
    pub fn write_sample(&mut self, s: &OscSample) -> io::Result<()> {
        self.write_row(s.t_s, Some(&s.r_b_m))
    }

    /// Flushes and returns the output.
    pub fn finish(self) -> io::Result<W> {
        self.w.into_inner().map_err(|e| e.into_error())
    }
}

/// Writes `samples` to `path` (created or truncated).
pub fn write(path: &Path, samples: &[OscSample]) -> Result<(), OscCsvError> {
    let io_err = |e| error(path, None, OscCsvErrorKind::Io(e));
    let file = File::create(path).map_err(io_err)?;
    let mut w = OscCsvWriter::new(BufWriter::new(file)).map_err(io_err)?;
    for s in samples {
        w.write_sample(s).map_err(io_err)?;
    }
    w.finish().map_err(io_err)?.flush().map_err(io_err)
}

/// Reads `path`.
pub fn read(path: &Path) -> Result<Vec<OscRow>, OscCsvError> {
    let file = File::open(path).map_err(|e| error(path, None, OscCsvErrorKind::Io(e)))?;
    read_from(BufReader::new(file), path)
}

/// Reads from `reader`; `path` names it in errors.
pub fn read_from<R: Read>(reader: R, path: &Path) -> Result<Vec<OscRow>, OscCsvError> {
    let mut csv = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(reader);
    let mut records = csv.records();
    let header = match records.next() {
        None => return Err(error(path, None, OscCsvErrorKind::MissingHeader)),
        Some(r) => r.map_err(|e| csv_error(path, e))?,
    };
    if header.iter().ne(COLUMNS) {
        let found = header.iter().collect::<Vec<_>>().join(",");
        let line = header.position().map(|p| p.line());
        return Err(error(path, line, OscCsvErrorKind::WrongHeader { found }));
    }

    let mut rows: Vec<OscRow> = Vec::new();
    for record in records {
        let record = record.map_err(|e| csv_error(path, e))?;
        let line = record.position().map(|p| p.line());
        let at = |kind| error(path, line, kind);
        if record.len() != COLUMNS.len() {
            return Err(at(OscCsvErrorKind::ColumnCount {
                found: record.len(),
            }));
        }
        let number = |i: usize| -> Result<f64, OscCsvError> {
            record[i].parse().map_err(|_| {
                at(OscCsvErrorKind::NotANumber {
                    column: COLUMNS[i],
                    found: record[i].to_owned(),
                })
            })
        };
        let t_s = number(0)?;
        if !(t_s.is_finite() && t_s >= 0.0) {
            return Err(at(OscCsvErrorKind::BadTime {
                found: record[0].to_owned(),
            }));
        }
        if let Some(prev) = rows.last()
            && t_s <= prev.t_s
        {
            return Err(at(OscCsvErrorKind::TimeNotIncreasing {
                previous: prev.t_s,
                found: t_s,
            }));
        }
        let v = [number(1)?, number(2)?, number(3)?];
        if let Some(i) = v.iter().position(|x| x.is_infinite()) {
            return Err(at(OscCsvErrorKind::Infinite {
                column: COLUMNS[i + 1],
                found: record[i + 1].to_owned(),
            }));
        }
        let nan = v.iter().filter(|x| x.is_nan()).count();
        let r_b_m = match nan {
            0 => Some(Vector3::from(v)),
            3 => None,
            _ => {
                let i = v.iter().position(|x| x.is_nan()).unwrap_or(0);
                return Err(at(OscCsvErrorKind::PartlyMissing {
                    column: COLUMNS[i + 1],
                }));
            }
        };
        rows.push(OscRow { t_s, r_b_m });
    }
    Ok(rows)
}

fn error(path: &Path, line: Option<u64>, kind: OscCsvErrorKind) -> OscCsvError {
    OscCsvError {
        path: path.to_owned(),
        line,
        kind,
    }
}

fn csv_error(path: &Path, e: csv::Error) -> OscCsvError {
    let line = e.position().map(|p| p.line());
    let kind = match e.into_kind() {
        csv::ErrorKind::Io(e) => OscCsvErrorKind::Io(e),
        csv::ErrorKind::Utf8 { err, .. } => {
            OscCsvErrorKind::Syntax(format!("invalid UTF-8: {err}"))
        }
        other => OscCsvErrorKind::Syntax(format!("{other:?}")),
    };
    error(path, line, kind)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<OscRow>, OscCsvError> {
        read_from(text.as_bytes(), Path::new("osc.csv"))
    }

    #[test]
    fn round_trip_is_bit_exact_and_keeps_missing_samples() {
        let r = Vector3::new(1.0 / 3.0 * 1e-5, -2.718281828459045e-6, 5e-324);
        let mut w = OscCsvWriter::new(Vec::new()).unwrap();
        w.write_row(0.0002, Some(&r)).unwrap();
        w.write_row(0.0004, None).unwrap();
        w.write_sample(&OscSample {
            t_s: 0.1 + 0.2,
            r_b_m: -r,
        })
        .unwrap();
        let bytes = w.finish().unwrap();
        let text = String::from_utf8(bytes).unwrap();
        assert!(text.starts_with("t_s,x_m,y_m,z_m\n0.0002,"), "{text}");
        assert!(text.contains("\n0.0004,NaN,NaN,NaN\n"), "{text}");
        let rows = parse(&text).unwrap();
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[0].r_b_m, Some(r));
        assert_eq!(rows[1].r_b_m, None);
        assert_eq!(rows[2].t_s, 0.1 + 0.2);
        assert_eq!(rows[2].r_b_m, Some(-r));
        assert_eq!(
            parse("t_s,x_m,y_m,z_m\n1, nan ,NAN,NaN\n").unwrap()[0].r_b_m,
            None
        );
    }

    #[test]
    fn errors_name_line_and_column() {
        let h = "t_s,x_m,y_m,z_m";
        let msg = |text: &str| parse(text).unwrap_err().to_string();
        assert_eq!(
            msg(&format!("{h}\n0.1,0,0,0\n0.2,0,abc,0\n")),
            "osc.csv: line 3: column y_m: expected a number, found 'abc'"
        );
        assert_eq!(
            msg(&format!("{h}\n0.1,0,NaN,0\n")),
            "osc.csv: line 2: column y_m: NaN, but not all of x_m, y_m, z_m are (a missing sample has all three NaN)"
        );
        assert!(
            msg(&format!("{h}\n0.1,0,0,inf\n")).contains("line 2: column z_m: expected a finite")
        );
        assert!(msg(&format!("{h}\n0.1,0,0\n")).contains("line 2: expected 4 columns"));
        assert!(msg(&format!("{h}\n0.1,0,0,0,0\n")).contains("found 5"));
        assert!(msg(&format!("{h}\n-1,0,0,0\n")).contains("line 2: column t_s: expected a finite"));
        assert!(msg(&format!("{h}\nNaN,0,0,0\n")).contains("column t_s"));
        assert!(
            msg(&format!("{h}\n0.2,0,0,0\n0.2,0,0,0\n"))
                .contains("line 3: column t_s: time 0.2 s does not increase")
        );
        assert!(
            msg("t,x,y,z\n")
                .contains("line 1: expected the header row 't_s,x_m,y_m,z_m', found 't,x,y,z'")
        );
        assert!(msg("").contains("empty file"));
    }
}
