//! The trajectory CSV format: truth files and the solution logs of `nav replay` share it.
//!
//! ```text
//! t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,pitch_deg,yaw_deg
//! 12.5,45.000000123,7.5,150,0.01,-0.002,0,1.5,-2,30
//! ```
//!
//! The header is nav-core's [`CSV_HEADER`]: time [s], geodetic latitude and longitude [deg],
//! ellipsoidal height [m], velocity `v_eb_n` north, east, down [m/s], and the z-y-x Euler angles
//! of `q_b_ned` (FRD body axes to NED; roll, pitch, yaw) [deg]. Columns are found by name, so
//! columns appended later (or in another order) are ignored; a column named twice is refused.
//!
//! Every value must be a finite number, the latitude within [-90, 90] deg, the yaw within
//! [-360, 360] deg ([`MAX_YAW_DEG`]), and time must not go backwards (equal times are allowed). Rows are read one at a time ([`TruthReader`]); a last
//! line that no newline ends is checked for a cut inside a field ([`crate::text_stream`]).
//!
//! The writer prints floats in their shortest round-trip form, so degrees keep the full f64
//! resolution (1.4e-14 deg at 100 deg, 2 nm on the Earth). Reading back is exact for time, height
//! and velocity; latitude, longitude and attitude pass through the deg <-> rad conversion and the
//! Euler angles, which round to within a few ulp (below 1e-12 deg).

use crate::text_error::{Record, TextError, TextErrorKind};
use crate::text_stream::{CsvRecords, CutCheck, column_position};
use crate::truth::Truth;
use nav_core::Vector3;
use nav_core::attitude::{euler, from_euler};
use nav_core::output::CSV_HEADER;
use std::fs::File;
use std::io::{self, BufReader, Read, Write};
use std::path::{Path, PathBuf};

/// The column names, in the order the writer uses (nav-core's [`CSV_HEADER`]).
pub const COLUMNS: [&str; 10] = [
    "t_s",
    "lat_deg",
    "lon_deg",
    "h_m",
    "v_n_mps",
    "v_e_mps",
    "v_d_mps",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
];

/// Largest yaw magnitude a trajectory row may have [deg]: either convention of a heading, the
/// solution logs' (-180, 180] (nav-core's [`nav_core::output::Solution`]) and KF-GINS's
/// [0, 360); a yaw beyond is no heading (490 deg was compared as 130).
pub const MAX_YAW_DEG: f64 = 360.0;

/// Column positions in [`COLUMNS`].
const T: usize = 0;
const LAT: usize = 1;
const LON: usize = 2;
const H: usize = 3;
const VEL: usize = 4;
const ATT: usize = 7;

/// A trajectory CSV reading or writing error, naming the file and (for content errors) the line.
pub type TruthCsvError = TextError;

/// What went wrong in a trajectory CSV file.
pub type TruthCsvErrorKind = TextErrorKind;

/// Writes trajectory rows one at a time (the header first).
#[derive(Debug)]
pub struct TruthWriter<W: Write> {
    out: W,
    rows: u32,
}

impl<W: Write> TruthWriter<W> {
    /// Writes the header row to `out`. Wrap files in a `BufWriter`: rows are written line by line.
    pub fn new(mut out: W) -> io::Result<Self> {
        writeln!(out, "{CSV_HEADER}")?;
        Ok(Self { out, rows: 0 })
    }

    /// Writes one row: `truth` in the file's units (degrees for angles).
    pub fn write(&mut self, truth: &Truth) -> io::Result<()> {
        let (roll, pitch, yaw) = euler(&truth.q_b_ned);
        let v = &truth.v_eb_ned;
        writeln!(
            self.out,
            "{},{},{},{},{},{},{},{},{},{}",
            truth.t_s,
            truth.lat.to_degrees(),
            truth.lon.to_degrees(),
            truth.h,
            v.x,
            v.y,
            v.z,
            roll.to_degrees(),
            pitch.to_degrees(),
            yaw.to_degrees()
        )?;
        self.rows = self.rows.saturating_add(1);
        Ok(())
    }

    /// Flushes and returns the writer.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }

    /// Writes the solution log's end record ([`nav_core::output::EndRecord`], the rows
    /// written), flushes and returns the writer: for a trajectory that is a run's solution
    /// (`nav emulate`'s), which `nav report` would otherwise call cut short.
    pub fn finish_solution(mut self) -> io::Result<W> {
        let end = nav_core::output::EndRecord { rows: self.rows };
        writeln!(self.out, "{end}")?;
        self.finish()
    }
}

/// Writes `rows` to `path` (created or truncated).
pub fn write(path: &Path, rows: &[Truth]) -> Result<(), TruthCsvError> {
    crate::atomic::write(path, |out| -> std::io::Result<()> {
        let mut w = TruthWriter::new(out)?;
        for row in rows {
            w.write(row)?;
        }
        w.finish()?;
        Ok(())
    })
    .map_err(|e| TextError::io(path, e))?;
    Ok(())
}

/// Reads a trajectory (truth file or solution log) from `path` into memory.
pub fn read(path: &Path) -> Result<Vec<Truth>, TruthCsvError> {
    let file = File::open(path).map_err(|e| TextError::io(path, e))?;
    read_from(BufReader::new(file), path)
}

/// Reads a trajectory from `reader` into memory; `path` names it in errors.
pub fn read_from<R: Read>(reader: R, path: &Path) -> Result<Vec<Truth>, TruthCsvError> {
    TruthReader::new(reader, path)?.collect()
}

/// The rows of a trajectory CSV, read one at a time (memory bounded by the longest line). Stops
/// after the first error.
#[derive(Debug)]
pub struct TruthReader<R: Read> {
    records: CsvRecords<R>,
    path: PathBuf,
    /// Field index of each of [`COLUMNS`].
    index: [usize; COLUMNS.len()],
    /// The header's names (for a cut-off last line).
    names: Vec<String>,
    previous_t_s: Option<f64>,
    cut: CutCheck,
    done: bool,
}

impl<R: Read> TruthReader<R> {
    /// Reads the header of `reader` and finds the columns; `path` names it in errors.
    pub fn new(reader: R, path: &Path) -> Result<Self, TruthCsvError> {
        let (records, header) = CsvRecords::new(reader, path, CSV_HEADER)?;
        let header_line = header.position().map(|p| p.line());
        let names: Vec<String> = header
            .iter()
            .map(|h| h.trim_start_matches('\u{feff}').to_owned())
            .collect();
        let mut index = [0_usize; COLUMNS.len()];
        for (slot, &name) in index.iter_mut().zip(&COLUMNS) {
            let at = |kind| TextError::new(path, header_line, kind);
            *slot = match column_position(&names, name) {
                Ok(Some(i)) => i,
                Ok(None) => {
                    return Err(at(TruthCsvErrorKind::HeaderMissingColumn {
                        column: name,
                        expected: CSV_HEADER.to_owned(),
                        found: header.iter().collect::<Vec<_>>().join(","),
                    }));
                }
                Err(positions) => {
                    return Err(at(TruthCsvErrorKind::HeaderDuplicateColumn {
                        column: name,
                        positions,
                    }));
                }
            };
        }
        Ok(Self {
            records,
            path: path.to_owned(),
            index,
            names,
            previous_t_s: None,
            cut: CutCheck::default(),
            done: false,
        })
    }

    fn next_row(&mut self) -> Option<Result<Truth, TruthCsvError>> {
        let line = match self.records.next_record()? {
            Ok(line) => line,
            Err(e) => return Some(Err(e)),
        };
        let path = &self.path;
        let record = line.record;
        let at = |kind| TextError::new(path, Some(line.line), kind);
        if line.unterminated {
            let fields: Vec<&str> = record.iter().collect();
            let names = &self.names;
            let column = |i: usize| {
                names
                    .get(i)
                    .cloned()
                    .unwrap_or_else(|| format!("{}", i + 1))
            };
            // Only the required columns must be numbers; others are the writer's business.
            let index = &self.index;
            let is_number = |i: usize, t: &str| !index.contains(&i) || t.parse::<f64>().is_ok();
            if let Err(cut) = self.cut.check(&fields, names.len(), column, is_number) {
                let kind = TruthCsvErrorKind::Truncated {
                    line: line.line,
                    cut,
                };
                return Some(Err(TextError::new(path, None, kind)));
            }
        } else {
            self.cut.note(record.iter());
        }
        let mut values = [0.0_f64; COLUMNS.len()];
        for (c, value) in values.iter_mut().enumerate() {
            let column = COLUMNS[c];
            let Some(text) = record.get(self.index[c]) else {
                return Some(Err(at(TruthCsvErrorKind::MissingColumn {
                    column,
                    found: record.len(),
                })));
            };
            let Ok(x) = text.parse::<f64>() else {
                return Some(Err(at(TruthCsvErrorKind::NotANumber {
                    column,
                    found: text.to_owned(),
                })));
            };
            if !x.is_finite() {
                return Some(Err(at(TruthCsvErrorKind::NotFinite {
                    column,
                    found: text.to_owned(),
                })));
            }
            *value = x;
        }
        if !(-90.0..=90.0).contains(&values[LAT]) {
            return Some(Err(at(TruthCsvErrorKind::BadLatitude {
                column: COLUMNS[LAT],
                lat_deg: values[LAT],
            })));
        }
        if values[ATT + 2].abs() > MAX_YAW_DEG {
            return Some(Err(at(TruthCsvErrorKind::BadYaw {
                column: COLUMNS[ATT + 2],
                yaw_deg: values[ATT + 2],
            })));
        }
        if let Some(previous) = self.previous_t_s
            && values[T] < previous
        {
            return Some(Err(at(TruthCsvErrorKind::TimeBackwards {
                column: COLUMNS[T],
                t_s: values[T],
                previous_t_s: previous,
                record: Record::Row,
            })));
        }
        self.previous_t_s = Some(values[T]);
        Some(Ok(truth_from_degrees(&values)))
    }
}

impl<R: Read> Iterator for TruthReader<R> {
    type Item = Result<Truth, TruthCsvError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let row = self.next_row();
        self.done = !matches!(row, Some(Ok(_)));
        row
    }
}

/// The [`Truth`] of one row of values in the file's units, in [`COLUMNS`] order.
fn truth_from_degrees(v: &[f64; COLUMNS.len()]) -> Truth {
    Truth {
        t_s: v[T],
        lat: v[LAT].to_radians(),
        lon: v[LON].to_radians(),
        h: v[H],
        v_eb_ned: Vector3::new(v[VEL], v[VEL + 1], v[VEL + 2]),
        q_b_ned: from_euler(
            v[ATT].to_radians(),
            v[ATT + 1].to_radians(),
            v[ATT + 2].to_radians(),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nav_core::UnitQuaternion;

    fn parse(text: &str) -> Result<Vec<Truth>, TruthCsvError> {
        read_from(text.as_bytes(), Path::new("mem.csv"))
    }

    fn sample(t_s: f64, k: f64) -> Truth {
        Truth {
            t_s,
            lat: (45.123_456_789_012_3 + k * 1e-9).to_radians(),
            lon: (-122.987_654_321_098_7 - k * 1e-9).to_radians(),
            h: 150.25 + k,
            v_eb_ned: Vector3::new(0.1 + k, -3.25e-7, 12.0),
            q_b_ned: from_euler(
                1.5_f64.to_radians(),
                -2.0_f64.to_radians(),
                (179.999 + k).to_radians(),
            ),
        }
    }

    #[test]
    fn header_is_nav_cores() {
        assert_eq!(COLUMNS.join(","), CSV_HEADER);
    }

    #[test]
    fn write_then_read_round_trips() {
        let rows: Vec<Truth> = (0..5)
            .map(|k| sample(456_300.005 + 0.005 * k as f64, k as f64))
            .collect();
        let mut bytes = Vec::new();
        let mut w = TruthWriter::new(&mut bytes).unwrap();
        for r in &rows {
            w.write(r).unwrap();
        }
        w.finish().unwrap();
        let back = read_from(bytes.as_slice(), Path::new("mem.csv")).unwrap();
        assert_eq!(back.len(), rows.len());
        for (a, b) in rows.iter().zip(&back) {
            // Printed and parsed directly: bit for bit.
            assert_eq!(a.t_s.to_bits(), b.t_s.to_bits());
            assert_eq!(a.h.to_bits(), b.h.to_bits());
            assert_eq!(a.v_eb_ned, b.v_eb_ned);
            // Through deg <-> rad (one rounding each way): within an ulp or two.
            assert!((a.lat - b.lat).abs() <= 2.0 * f64::EPSILON * a.lat.abs());
            assert!((a.lon - b.lon).abs() <= 2.0 * f64::EPSILON * a.lon.abs());
            // Through the Euler angles: within rounding.
            assert!(a.q_b_ned.angle_to(&b.q_b_ned) < 1e-14);
        }
        // A second pass stays within the same bounds (no drift).
        let mut again = Vec::new();
        let mut w = TruthWriter::new(&mut again).unwrap();
        for r in &back {
            w.write(r).unwrap();
        }
        w.finish().unwrap();
        let twice = read_from(again.as_slice(), Path::new("mem.csv")).unwrap();
        for (a, b) in back.iter().zip(&twice) {
            assert!((a.lat - b.lat).abs() <= 2.0 * f64::EPSILON * a.lat.abs());
            assert!(a.q_b_ned.angle_to(&b.q_b_ned) < 1e-14);
        }
    }

    #[test]
    fn degrees_keep_1e_11_deg() {
        // Latitudes 1e-11 deg apart stay apart and keep their difference.
        let a = sample(0.0, 0.0);
        let mut b = a;
        b.lat = (a.lat.to_degrees() + 1e-11).to_radians();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        write(&path, &[a, b]).unwrap();
        let back = read(&path).unwrap();
        let d_deg = (back[1].lat - back[0].lat).to_degrees();
        assert!((d_deg - 1e-11).abs() < 1e-13, "{d_deg}");
    }

    #[test]
    fn reads_exact_values_and_ignores_extra_columns() {
        let text = format!(
            "{CSV_HEADER},extra\n1.5,45,7.5,150,1,2,3,0,0,90,x\n\n1.5,-45,-7.5,0,0,0,0,0,0,-90,\n"
        );
        let rows = parse(&text).unwrap();
        assert_eq!(rows.len(), 2);
        let r = rows[0];
        assert_eq!((r.t_s, r.h), (1.5, 150.0));
        assert_eq!(r.lat, 45f64.to_radians());
        assert_eq!(r.v_eb_ned, Vector3::new(1.0, 2.0, 3.0));
        let yaw_90 = UnitQuaternion::from_euler_angles(0.0, 0.0, 90f64.to_radians());
        assert!(r.q_b_ned.angle_to(&yaw_90) < 1e-15);

        // Columns found by name, in any order.
        let rows = parse(
            "yaw_deg,pitch_deg,roll_deg,v_d_mps,v_e_mps,v_n_mps,h_m,lon_deg,lat_deg,t_s\n\
             0,0,0,3,2,1,10,20,30,4\n",
        )
        .unwrap();
        assert_eq!(rows[0].t_s, 4.0);
        assert_eq!(rows[0].lat, 30f64.to_radians());
        assert_eq!(rows[0].v_eb_ned, Vector3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let ok = "1,45,7.5,150,0,0,0,0,0,0";
        let msg = |text: &str| parse(text).unwrap_err().to_string();

        assert_eq!(
            msg(&format!("{CSV_HEADER}\n{ok}\n2,45,7.5,150,0,abc,0,0,0,0\n")),
            "mem.csv: line 3: column v_e_mps: expected a number, found 'abc'"
        );
        assert_eq!(
            msg(&format!("{CSV_HEADER}\n{ok}\n2,45,7.5,150,0,0,0,0,NaN,0\n")),
            "mem.csv: line 3: column pitch_deg: expected a finite number, found 'NaN'"
        );
        assert_eq!(
            msg(&format!("{CSV_HEADER}\n{ok}\n2,45,7.5,150,0,0,0,0\n")),
            "mem.csv: line 3: column pitch_deg: missing (the line has only 8 columns)"
        );
        assert_eq!(
            msg(&format!("{CSV_HEADER}\n{ok}\n0.5,45,7.5,150,0,0,0,0,0,0\n")),
            "mem.csv: line 3: column t_s: time goes backwards: 0.5 s after 1 s on the previous row"
        );
        assert_eq!(
            msg(&format!("{CSV_HEADER}\n1,95,7.5,150,0,0,0,0,0,0\n")),
            "mem.csv: line 2: column lat_deg: latitude 95 deg is outside [-90, 90]"
        );
        // A yaw of 490 deg was read (and compared as 130 deg); +-360 is either convention's.
        assert!(
            msg(&format!("{CSV_HEADER}\n{ok}\n2,45,7.5,150,0,0,0,0,0,490\n")).starts_with(
                "mem.csv: line 3: column yaw_deg: yaw 490 deg is outside [-360, 360] (a heading"
            )
        );
        assert!(
            parse(&format!(
                "{CSV_HEADER}\n1,45,7.5,150,0,0,0,0,0,-360\n2,45,7.5,150,0,0,0,0,0,359.9\n"
            ))
            .is_ok()
        );
        let m = msg("t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,pitch_deg\n");
        assert!(
            m.starts_with("mem.csv: line 1: the header has no column yaw_deg"),
            "{m}"
        );
        assert!(msg("").contains("empty file"));
        // Equal times are allowed.
        parse(&format!("{CSV_HEADER}\n{ok}\n{ok}\n")).unwrap();
    }
}
