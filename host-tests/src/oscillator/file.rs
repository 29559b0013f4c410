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
use crate::text_error::{TextError, TextErrorKind};
use crate::text_stream::{CsvRecords, CutCheck};
use nav_core::Vector3;
use std::fs::File;
use std::io::{self, BufReader, Read, Write};
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
pub type OscCsvError = TextError;

/// What went wrong in an `osc.csv` file.
pub type OscCsvErrorKind = TextErrorKind;

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
    crate::atomic::write(path, |out| -> std::io::Result<()> {
        let mut w = OscCsvWriter::new(out)?;
        for s in samples {
            w.write_sample(s)?;
        }
        w.finish()?.flush()
    })
    .map_err(|e| TextError::io(path, e))
}

/// Reads `path` into memory (`nav osc-replay` streams it instead: [`OscReader`]).
pub fn read(path: &Path) -> Result<Vec<OscRow>, OscCsvError> {
    let file = File::open(path).map_err(|e| TextError::io(path, e))?;
    read_from(BufReader::new(file), path)
}

/// Reads from `reader` into memory; `path` names it in errors.
pub fn read_from<R: Read>(reader: R, path: &Path) -> Result<Vec<OscRow>, OscCsvError> {
    OscReader::new(reader, path)?.collect()
}

/// Opens `path` to read its rows one at a time.
pub fn open(path: &Path) -> Result<OscReader<BufReader<File>>, OscCsvError> {
    let file = File::open(path).map_err(|e| TextError::io(path, e))?;
    OscReader::new(BufReader::new(file), path)
}

/// The rows of an `osc.csv` file, read one at a time (memory bounded by the longest line).
/// Stops after the first error.
#[derive(Debug)]
pub struct OscReader<R: Read> {
    records: CsvRecords<R>,
    path: PathBuf,
    previous_t_s: Option<f64>,
    cut: CutCheck,
    done: bool,
}

impl<R: Read> OscReader<R> {
    /// Reads and checks the header of `reader`; `path` names it in errors.
    pub fn new(reader: R, path: &Path) -> Result<Self, OscCsvError> {
        let (records, header) = CsvRecords::new(reader, path, &COLUMNS.join(","))?;
        if header.iter().ne(COLUMNS) {
            let found = header.iter().collect::<Vec<_>>().join(",");
            let line = header.position().map(|p| p.line());
            return Err(TextError::new(
                path,
                line,
                OscCsvErrorKind::WrongHeader {
                    expected: COLUMNS.join(","),
                    optional: None,
                    found,
                },
            ));
        }
        Ok(Self {
            records,
            path: path.to_owned(),
            previous_t_s: None,
            cut: CutCheck::default(),
            done: false,
        })
    }

    fn next_row(&mut self) -> Option<Result<OscRow, OscCsvError>> {
        let line = match self.records.next_record()? {
            Ok(line) => line,
            Err(e) => return Some(Err(e)),
        };
        let path = &self.path;
        let record = line.record;
        let at = |kind| TextError::new(path, Some(line.line), kind);
        if line.unterminated {
            let fields: Vec<&str> = record.iter().collect();
            let column = |i: usize| COLUMNS.get(i).copied().unwrap_or("extra").to_owned();
            let is_number = |_: usize, t: &str| t.parse::<f64>().is_ok();
            if let Err(cut) = self.cut.check(&fields, COLUMNS.len(), column, is_number) {
                let kind = OscCsvErrorKind::Truncated {
                    line: line.line,
                    cut,
                };
                return Some(Err(TextError::new(path, None, kind)));
            }
        } else {
            self.cut.note(record.iter());
        }
        let row = parse_row(record, self.previous_t_s, at);
        if let Ok(r) = &row {
            self.previous_t_s = Some(r.t_s);
        }
        Some(row)
    }
}

impl<R: Read> Iterator for OscReader<R> {
    type Item = Result<OscRow, OscCsvError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let row = self.next_row();
        self.done = !matches!(row, Some(Ok(_)));
        row
    }
}

/// One data row after a row at `previous_t_s`; `at` makes an error of its line.
fn parse_row(
    record: &csv::StringRecord,
    previous_t_s: Option<f64>,
    at: impl Fn(OscCsvErrorKind) -> OscCsvError,
) -> Result<OscRow, OscCsvError> {
    if record.len() != COLUMNS.len() {
        return Err(at(OscCsvErrorKind::ColumnCount {
            expected: format!("{} columns ({})", COLUMNS.len(), COLUMNS.join(",")),
            found: record.len(),
            hint: None,
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
    if let Some(prev) = previous_t_s
        && t_s <= prev
    {
        return Err(at(OscCsvErrorKind::SampleTimeNotIncreasing {
            previous: prev,
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
    Ok(OscRow { t_s, r_b_m })
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
