//! The CSV IMU recording format: one row of increments per sampling interval.
//!
//! ```text
//! t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps[,temp_c]
//! 0.0025,1.2e-7,0,-1.3e-7,0.0009,-0.0006,-0.0245[,25]
//! ```
//!
//! Each row holds the angle increment `delta_theta_ib_b` [rad] and the velocity increment
//! `delta_v_ib_b` [m/s] over the interval that ENDS at `t_s` [s], body axes forward-right-down.
//! The optional `temp_c` column is the sensor temperature [deg C] (empty or `NaN`: unknown);
//! a value outside [`TEMPERATURE_RANGE_C`] (or infinite) is no sensor's and is an error.
//! A line that starts with `#` is a comment, before the header or between rows.
//!
//! NaN and infinite increments are parsed, not refused (the replay flags them), and so is time
//! that does not increase (the replay flags the interval); a time that is negative, not a number
//! or beyond the recording clock's range ([`crate::text_error::MAX_TIME_S`]) cannot be placed on
//! the recording's clock and is an error. A last line that no newline ends is checked for a cut
//! inside a field ([`crate::text_stream`]).

use crate::text_error::{TextError, TextErrorKind, seconds_to_ns};
use crate::text_stream::{CsvRecords, CutCheck};
use serde::Serialize;
use std::fs::File;
use std::io::{self, BufReader, Read, Write};
use std::path::{Path, PathBuf};

/// Column names without the optional temperature.
pub const COLUMNS: [&str; 7] = [
    "t_s",
    "dtheta_x_rad",
    "dtheta_y_rad",
    "dtheta_z_rad",
    "dv_x_mps",
    "dv_y_mps",
    "dv_z_mps",
];
/// Name of the optional eighth column.
pub const TEMPERATURE_COLUMN: &str = "temp_c";

/// The temperatures a `temp_c` field may hold [deg C]: wider than any IMU's storage range
/// (-65 to +150 deg C for the usual ones), so that only a wrong column or unit (1e6, a time)
/// is refused.
pub const TEMPERATURE_RANGE_C: (f32, f32) = (-100.0, 200.0);

/// Whether `temp_c` [deg C] may be a sensor's temperature: unknown (NaN) or within
/// [`TEMPERATURE_RANGE_C`]. The rule of every recording format (CSV here, binary in
/// [`crate::recording_io`]).
pub fn temperature_is_plausible(temp_c: f32) -> bool {
    let (low, high) = TEMPERATURE_RANGE_C;
    temp_c.is_nan() || (low..=high).contains(&temp_c)
}

/// The refusal of a temperature [`temperature_is_plausible`] refuses [deg C]: `1e30 deg C is
/// outside [-100, 200], not a sensor's temperature` (the value compact at any magnitude).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BadTemperature(pub f32);

impl std::fmt::Display for BadTemperature {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (t, (low, high)) = (self.0, TEMPERATURE_RANGE_C);
        // f32's own shortest digits: 1e30, not 1.0000000150474662e30 through f64.
        if t == 0.0 || (1e-3..1e6).contains(&t.abs()) {
            write!(f, "{t}")?;
        } else {
            write!(f, "{t:e}")?;
        }
        write!(
            f,
            " deg C is outside [{low}, {high}], not a sensor's temperature"
        )
    }
}

/// One row: the increments over the interval ending at `t_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CsvRow {
    /// End of the interval [s] on the recording's clock.
    pub t_s: f64,
    /// Angle increment, integral of `omega_ib_b` over the interval, body FRD [rad].
    pub delta_theta_ib_b: [f32; 3],
    /// Velocity increment, integral of `f_ib_b` over the interval, body FRD [m/s].
    pub delta_v_ib_b: [f32; 3],
    /// Sensor temperature [deg C]; NaN when unknown or absent.
    pub temperature_c: f32,
}

/// A CSV recording: its rows and whether the file had the temperature column.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuCsv {
    /// `true` when the header had the `temp_c` column.
    pub has_temperature: bool,
    /// The rows, in file order.
    pub rows: Vec<CsvRow>,
}

/// A CSV reading or writing error, naming the file and (for content errors) the line.
pub type CsvError = TextError;

/// What went wrong in a CSV file.
pub type CsvErrorKind = TextErrorKind;

/// The header row, with or without the temperature column.
pub fn header_line(with_temperature: bool) -> String {
    let mut s = COLUMNS.join(",");
    if with_temperature {
        s.push(',');
        s.push_str(TEMPERATURE_COLUMN);
    }
    s
}

/// Reads a CSV recording from `path` into memory (a replay streams it instead: [`CsvReader`]).
pub fn read(path: &Path) -> Result<ImuCsv, CsvError> {
    let file = File::open(path).map_err(|e| TextError::io(path, e))?;
    read_from(BufReader::new(file), path)
}

/// Reads a CSV recording from `reader` into memory; `path` names it in errors.
pub fn read_from<R: Read>(reader: R, path: &Path) -> Result<ImuCsv, CsvError> {
    let rows = CsvReader::new(reader, path)?;
    let has_temperature = rows.has_temperature();
    Ok(ImuCsv {
        has_temperature,
        rows: rows.collect::<Result<_, _>>()?,
    })
}

/// The rows of a CSV recording, read one at a time (memory bounded by the longest line). Stops
/// after the first error.
#[derive(Debug)]
pub struct CsvReader<R: Read> {
    records: CsvRecords<R>,
    path: PathBuf,
    has_temperature: bool,
    cut: CutCheck,
    failed: bool,
}

impl<R: Read> CsvReader<R> {
    /// Reads and checks the header of `reader`; `path` names it in errors.
    pub fn new(reader: R, path: &Path) -> Result<Self, CsvError> {
        let (records, header) = CsvRecords::new(reader, path, &header_line(false))?;
        let names: Vec<&str> = header.iter().collect();
        let has_temperature = if names == COLUMNS {
            false
        } else if names.len() == COLUMNS.len() + 1
            && names[..COLUMNS.len()] == COLUMNS
            && names[COLUMNS.len()] == TEMPERATURE_COLUMN
        {
            true
        } else {
            return Err(TextError::new(
                path,
                header.position().map(|p| p.line()),
                CsvErrorKind::WrongHeader {
                    expected: header_line(false),
                    optional: Some(TEMPERATURE_COLUMN),
                    found: names.join(","),
                },
            ));
        };
        Ok(Self {
            records,
            path: path.to_owned(),
            has_temperature,
            cut: CutCheck::default(),
            failed: false,
        })
    }

    /// `true` when the header has the `temp_c` column.
    pub fn has_temperature(&self) -> bool {
        self.has_temperature
    }

    fn next_row(&mut self) -> Option<Result<CsvRow, CsvError>> {
        let width = COLUMNS.len() + usize::from(self.has_temperature);
        let line = match self.records.next_record()? {
            Ok(line) => line,
            Err(e) => return Some(Err(e)),
        };
        let path = &self.path;
        let record = line.record;
        let at = |kind| TextError::new(path, Some(line.line), kind);
        let column = |i: usize| COLUMNS.get(i).copied().unwrap_or(TEMPERATURE_COLUMN);
        if line.unterminated {
            let fields: Vec<&str> = record.iter().collect();
            let is_number = |i: usize, text: &str| {
                (i == COLUMNS.len() && text.is_empty()) || text.parse::<f64>().is_ok()
            };
            if let Err(cut) = self
                .cut
                .check(&fields, width, |i| column(i).to_owned(), is_number)
            {
                let kind = CsvErrorKind::Truncated {
                    line: line.line,
                    cut,
                };
                return Some(Err(TextError::new(path, None, kind)));
            }
        } else {
            self.cut.note(record.iter());
        }
        Some(parse_row(record, width, at))
    }
}

impl<R: Read> Iterator for CsvReader<R> {
    type Item = Result<CsvRow, CsvError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        let row = self.next_row();
        self.failed = matches!(row, Some(Err(_)));
        row
    }
}

/// One data row of `width` fields; `at` makes an error of its line.
fn parse_row(
    record: &csv::StringRecord,
    width: usize,
    at: impl Fn(CsvErrorKind) -> CsvError,
) -> Result<CsvRow, CsvError> {
    if record.len() < width {
        let column = if record.len() < COLUMNS.len() {
            COLUMNS[record.len()]
        } else {
            TEMPERATURE_COLUMN
        };
        return Err(at(CsvErrorKind::MissingColumn {
            column,
            found: record.len(),
        }));
    }
    if record.len() > width {
        return Err(at(CsvErrorKind::ExtraColumns {
            expected: width,
            found: record.len(),
        }));
    }
    let t_text = &record[0];
    let t_s: f64 = t_text.parse().map_err(|_| {
        at(CsvErrorKind::NotANumber {
            column: COLUMNS[0],
            found: t_text.to_owned(),
        })
    })?;
    if !(t_s.is_finite() && t_s >= 0.0) {
        return Err(at(CsvErrorKind::BadTime {
            found: t_text.to_owned(),
        }));
    }
    if seconds_to_ns(t_s).is_none() {
        return Err(at(CsvErrorKind::TimeOutOfRange {
            column: COLUMNS[0],
            t_s,
        }));
    }
    // Increments are parsed straight to f32 (correctly rounded, no double rounding through
    // f64), so writing and reading back is lossless.
    let number = |i: usize| -> Result<f32, CsvError> {
        record[i].parse().map_err(|_| {
            at(CsvErrorKind::NotANumber {
                column: COLUMNS[i],
                found: record[i].to_owned(),
            })
        })
    };
    let delta_theta_ib_b = [number(1)?, number(2)?, number(3)?];
    let delta_v_ib_b = [number(4)?, number(5)?, number(6)?];
    // Empty and NaN both say "unknown" (the writer writes NaN for it).
    let temperature_c = match record.get(COLUMNS.len()) {
        None | Some("") => f32::NAN,
        Some(text) => text.parse().map_err(|_| {
            at(CsvErrorKind::NotANumber {
                column: TEMPERATURE_COLUMN,
                found: text.to_owned(),
            })
        })?,
    };
    if !temperature_is_plausible(temperature_c) {
        return Err(at(CsvErrorKind::BadTemperature {
            column: TEMPERATURE_COLUMN,
            temp_c: temperature_c,
        }));
    }
    Ok(CsvRow {
        t_s,
        delta_theta_ib_b,
        delta_v_ib_b,
        temperature_c,
    })
}

/// Writes `csv` to `path` (created or truncated).
pub fn write(path: &Path, csv: &ImuCsv) -> Result<(), CsvError> {
    crate::atomic::write(path, |out| write_to(out, csv)).map_err(|e| TextError::io(path, e))
}

/// One row as written: the field names are the column names. Floats are printed in their
/// shortest round-trip form, so a written file reads back bit for bit.
#[derive(Serialize)]
struct RowOut {
    t_s: f64,
    dtheta_x_rad: f32,
    dtheta_y_rad: f32,
    dtheta_z_rad: f32,
    dv_x_mps: f32,
    dv_y_mps: f32,
    dv_z_mps: f32,
    #[serde(skip_serializing_if = "Option::is_none")]
    temp_c: Option<f32>,
}

/// Writes the header and the rows of `csv` to `out`.
pub fn write_to<W: Write>(out: W, csv: &ImuCsv) -> io::Result<()> {
    let mut w = CsvWriter::new(out, csv.has_temperature)?;
    for row in &csv.rows {
        w.write_row(row)?;
    }
    w.finish()
}

/// A CSV recording written row by row: the header first, then each row as it comes (memory
/// independent of the number of rows).
#[derive(Debug)]
pub struct CsvWriter<W: Write> {
    w: csv::Writer<W>,
    has_temperature: bool,
}

impl<W: Write> CsvWriter<W> {
    /// Writes the header row to `out`, with the `temp_c` column when `has_temperature`.
    pub fn new(out: W, has_temperature: bool) -> io::Result<Self> {
        let mut w = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(out);
        w.write_record(header_line(has_temperature).split(','))?;
        Ok(Self { w, has_temperature })
    }

    /// Writes `row` (its temperature only when the header has the column), or refuses a
    /// temperature outside [`TEMPERATURE_RANGE_C`] (the reader's rule: a file it would refuse
    /// is not written; NaN is an unknown temperature).
    pub fn write_row(&mut self, row: &CsvRow) -> io::Result<()> {
        let (low, high) = TEMPERATURE_RANGE_C;
        let t = row.temperature_c;
        if self.has_temperature && !t.is_nan() && !(low..=high).contains(&t) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "the sample at t = {} s has a temperature of {} deg C, outside [{low}, \
                     {high}] deg C (no IMU's)",
                    nav_core::number::Number(row.t_s),
                    nav_core::number::Number(f64::from(t))
                ),
            ));
        }
        let [dtheta_x_rad, dtheta_y_rad, dtheta_z_rad] = row.delta_theta_ib_b;
        let [dv_x_mps, dv_y_mps, dv_z_mps] = row.delta_v_ib_b;
        self.w.serialize(RowOut {
            t_s: row.t_s,
            dtheta_x_rad,
            dtheta_y_rad,
            dtheta_z_rad,
            dv_x_mps,
            dv_y_mps,
            dv_z_mps,
            temp_c: self.has_temperature.then_some(row.temperature_c),
        })?;
        Ok(())
    }

    /// Flushes the rows written to the output.
    pub fn finish(mut self) -> io::Result<()> {
        self.w.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<ImuCsv, CsvError> {
        read_from(text.as_bytes(), Path::new("mem.csv"))
    }

    const HEADER: &str = "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps";

    #[test]
    fn reads_rows_with_and_without_temperature() {
        let csv = parse(&format!(
            "{HEADER}\n0.01,1e-7,2,3,4,5,-0.098\n0.02,0,0,0,0,0,0\n"
        ))
        .unwrap();
        assert!(!csv.has_temperature);
        assert_eq!(csv.rows.len(), 2);
        assert_eq!(csv.rows[0].t_s, 0.01);
        assert_eq!(csv.rows[0].delta_theta_ib_b, [1e-7, 2.0, 3.0]);
        assert_eq!(csv.rows[0].delta_v_ib_b, [4.0, 5.0, -0.098]);
        assert!(csv.rows[0].temperature_c.is_nan());

        let csv = parse(&format!(
            "{HEADER},temp_c\n1, 0,0,0,0,0,0 ,24.5\n2,0,0,0,0,0,0,\n"
        ))
        .unwrap();
        assert!(csv.has_temperature);
        assert_eq!(csv.rows[0].temperature_c, 24.5);
        assert!(csv.rows[1].temperature_c.is_nan());
    }

    /// A temperature no sensor has (1e6 deg C, a wrong column or unit) was read and copied by
    /// `nav convert`; it is refused with its line and column. Empty and NaN are "unknown".
    #[test]
    fn temperatures_outside_a_physical_range_are_refused() {
        let csv = parse(&format!(
            "{HEADER},temp_c\n1,0,0,0,0,0,0,NaN\n2,0,0,0,0,0,0,\n3,0,0,0,0,0,0,-100\n4,0,0,0,0,0,0,200\n"
        ))
        .unwrap();
        let temps: Vec<f32> = csv.rows.iter().map(|r| r.temperature_c).collect();
        assert!(temps[0].is_nan() && temps[1].is_nan(), "{temps:?}");
        assert_eq!(temps[2..], [-100.0, 200.0]);
        for bad in ["1e6", "200.1", "-273.15", "inf", "-inf"] {
            let msg = parse(&format!(
                "{HEADER},temp_c\n1,0,0,0,0,0,0,25\n2,0,0,0,0,0,0,{bad}\n"
            ))
            .unwrap_err()
            .to_string();
            assert!(
                msg.starts_with("mem.csv: line 3: column temp_c: ")
                    && msg.contains("deg C is outside [-100, 200]"),
                "{bad}: {msg}"
            );
        }
    }

    /// The writer refuses what the reader would (a binary recording's garbage temperature
    /// converted to CSV), and writes an unknown one as NaN.
    #[test]
    fn the_writer_refuses_a_temperature_the_reader_would() {
        let row = |temperature_c: f32| CsvRow {
            t_s: 2.5,
            delta_theta_ib_b: [0.0; 3],
            delta_v_ib_b: [0.0; 3],
            temperature_c,
        };
        let mut out = Vec::new();
        let mut w = CsvWriter::new(&mut out, true).unwrap();
        w.write_row(&row(f32::NAN)).unwrap();
        w.write_row(&row(-40.0)).unwrap();
        let e = w.write_row(&row(1e6)).unwrap_err().to_string();
        assert!(
            e.contains("t = 2.5 s has a temperature of 1e6 deg C, outside [-100, 200]"),
            "{e}"
        );
        assert!(w.write_row(&row(f32::INFINITY)).is_err());
        w.finish().unwrap();
        let csv = read_from(out.as_slice(), Path::new("mem.csv")).unwrap();
        assert_eq!(csv.rows.len(), 2);
        // Without the column, the temperature is not written and not judged.
        let mut w = CsvWriter::new(Vec::new(), false).unwrap();
        w.write_row(&row(1e6)).unwrap();
    }

    #[test]
    fn parses_non_finite_values_and_decreasing_time() {
        let csv = parse(&format!(
            "{HEADER}\n2,NaN,inf,-inf,nan,0,0\n1,0,0,0,0,0,0\n"
        ))
        .unwrap();
        let r = csv.rows[0];
        assert!(r.delta_theta_ib_b[0].is_nan() && r.delta_v_ib_b[0].is_nan());
        assert_eq!(r.delta_theta_ib_b[1], f32::INFINITY);
        assert_eq!(r.delta_theta_ib_b[2], f32::NEG_INFINITY);
        assert_eq!(csv.rows[1].t_s, 1.0);
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let text = format!("{HEADER}\n0.01,0,0,0,0,0,0\n0.02,0,0,0,0,abc,0\n");
        let msg = parse(&text).unwrap_err().to_string();
        assert_eq!(
            msg,
            "mem.csv: line 3: column dv_y_mps: expected a number, found 'abc'"
        );

        let msg = parse(&format!("{HEADER}\n0.01,0,0,0,0,0\n"))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("line 2: column dv_z_mps: missing"), "{msg}");

        let msg = parse(&format!("{HEADER}\n0.01,0,0,0,0,0,0,7\n"))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("line 2: expected 7 columns"), "{msg}");

        let msg = parse("t,gx,gy,gz,ax,ay,az\n1,0,0,0,0,0,0\n")
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("line 1: expected the header row 't_s,dtheta_x_rad"),
            "{msg}"
        );
        assert!(msg.contains("found 't,gx,gy,gz,ax,ay,az'"), "{msg}");

        let msg = parse("").unwrap_err().to_string();
        assert!(msg.contains("empty file"), "{msg}");

        let msg = parse(&format!("{HEADER}\n-1,0,0,0,0,0,0\n"))
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("line 2: column t_s: expected a finite, non-negative time"),
            "{msg}"
        );
    }

    #[test]
    fn write_then_read_is_lossless() {
        let rows = vec![
            CsvRow {
                t_s: 60.0025,
                delta_theta_ib_b: [1.234_567_9e-7, -3.0e-30, f32::NAN],
                delta_v_ib_b: [0.1 + 1e-8, f32::INFINITY, -0.024_512_3],
                temperature_c: 25.0,
            },
            CsvRow {
                t_s: 0.1 + 0.2,
                delta_theta_ib_b: [0.0, -0.0, f32::MIN_POSITIVE],
                delta_v_ib_b: [f32::MAX, 1.0, 2.0],
                temperature_c: f32::NAN,
            },
        ];
        for has_temperature in [false, true] {
            let csv = ImuCsv {
                has_temperature,
                rows: rows.clone(),
            };
            let mut bytes = Vec::new();
            write_to(&mut bytes, &csv).unwrap();
            let back = read_from(bytes.as_slice(), Path::new("x")).unwrap();
            assert_eq!(back.has_temperature, has_temperature);
            for (a, b) in rows.iter().zip(&back.rows) {
                assert_eq!(a.t_s.to_bits(), b.t_s.to_bits());
                let bits = |r: &CsvRow| {
                    r.delta_theta_ib_b
                        .iter()
                        .chain(&r.delta_v_ib_b)
                        .map(|x| x.to_bits())
                        .collect::<Vec<_>>()
                };
                assert_eq!(bits(a), bits(b));
                if has_temperature {
                    assert_eq!(a.temperature_c.to_bits(), b.temperature_c.to_bits());
                } else {
                    assert!(b.temperature_c.is_nan());
                }
            }
        }
    }
}
