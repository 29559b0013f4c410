//! GNSS fixes (position, optionally velocity, with their 1-sigma): the fix type, the readers of
//! the project's GNSS CSV and of KF-GINS's GNSS text file (and gnss-ins-sim's GPS file with a
//! stated 1-sigma, [`read_gnss_assuming`]), and the CSV writer.
//!
//! **Project CSV** (header first, units in the column names):
//!
//! ```text
//! t_s,lat_deg,lon_deg,h_m,sigma_n_m,sigma_e_m,sigma_d_m[,v_n_m_s,v_e_m_s,v_d_m_s,sigma_vn_m_s,sigma_ve_m_s,sigma_vd_m_s]
//! 1,45.0000123,7.5,250.3,0.5,0.5,1.2[,10.1,0.02,-0.01,0.05,0.05,0.1]
//! ```
//!
//! Receiver time tag [s], geodetic latitude and longitude [deg], ellipsoidal height of the
//! antenna [m], position 1-sigma north, east, down [m]; with the six velocity columns in the
//! header, the antenna velocity north, east, down [m/s] and its 1-sigma [m/s]. A row may leave
//! all six velocity fields empty: that fix has no velocity. Columns are in this order.
//!
//! **KF-GINS GNSS text** (no header; fields separated by any run of spaces, tabs and commas;
//! blank lines and lines starting with `#` or `%` skipped): 7 columns — GNSS seconds of week [s],
//! latitude, longitude [deg], height [m], 1-sigma north, east, down [m] — or 13 columns, in
//! KF-GINS's order: time, latitude, longitude, height, **velocity north, east, down [m/s]**, then
//! the position 1-sigma [m] and the velocity 1-sigma [m/s] (KF-GINS's `GnssFileLoader` takes the
//! position sigmas from columns 8-10 of a 13-column line). Lines of 7 and 13 columns may mix.
//!
//! **Rules** (both formats): a wrong number of fields, a field that is not a number, a time that
//! is not finite or negative, a finite latitude outside [-90, 90] deg or
//! longitude outside [-180, 180] deg, and a last line cut off inside a field ([`crate::text_stream`]) are errors naming the file, the
//! line and the column; so is a file without a fix. A NaN or infinite position or velocity value,
//! and a sigma that is zero, negative, NaN or infinite, are **not** file errors: the fix is kept
//! as read, for the navigation filter to reject and count (a receiver does output such fixes).
//! Nor is a time not later than the previous fix's (a receiver's log that repeats an epoch, or
//! swaps two): the fix is kept, and the navigator skips and counts it as out of order
//! (`nav_core::ins_filter::sequencer::FixQueue::push`), in the firmware and the harness alike.
//! A file none of whose fixes is usable so (neither its position, nav-core's
//! `GnssPosition::is_valid`, nor its velocity, `GnssVelocity::is_valid`) is an error: no
//! receiver records only those, and a KF-GINS IMU text file, 7 columns too, reads so.
//!
//! The writer prints floats in their shortest round-trip form (degrees keep the full f64
//! resolution); reading back is exact for time, height, velocity and sigmas, and within an ulp
//! or two for latitude and longitude (one deg <-> rad rounding each way).

use crate::kf_gins::{
    DataLines, Fields, FileKind, GNSS_COLUMNS, GNSS_VELOCITY_COLUMNS, LineError, check_time,
};
use crate::text_error::{TextError, TextErrorKind, seconds_to_ns};
use crate::text_stream::{CsvRecords, CutCheck, LineReader};
use nav_core::ins_filter::aiding::{GnssPosition, GnssVelocity as NavGnssVelocity};
use nav_core::number::Number;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Write};
use std::path::Path;

pub use crate::gnss_ins_sim::AssumedSigma;

/// One GNSS fix, in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFix {
    /// Receiver time tag [s] (GNSS seconds of week for KF-GINS files).
    pub t_s: f64,
    /// Geodetic latitude of the antenna [rad].
    pub lat_rad: f64,
    /// Longitude of the antenna [rad].
    pub lon_rad: f64,
    /// Ellipsoidal height of the antenna [m].
    pub h_m: f64,
    /// Position 1-sigma north, east, down [m].
    pub sigma_ned_m: [f64; 3],
    /// The antenna velocity, when the fix has one.
    pub velocity: Option<GnssVelocity>,
}

/// The velocity of a GNSS fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssVelocity {
    /// Antenna velocity relative to the Earth, north, east, down [m/s].
    pub v_ned_m_s: [f64; 3],
    /// Its 1-sigma north, east, down [m/s].
    pub sigma_ned_m_s: [f64; 3],
}

/// The CSV columns of a fix without velocity.
pub const CSV_COLUMNS: [&str; 7] = [
    "t_s",
    "lat_deg",
    "lon_deg",
    "h_m",
    "sigma_n_m",
    "sigma_e_m",
    "sigma_d_m",
];

/// The six CSV velocity columns that may follow [`CSV_COLUMNS`].
pub const CSV_VELOCITY_COLUMNS: [&str; 6] = [
    "v_n_m_s",
    "v_e_m_s",
    "v_d_m_s",
    "sigma_vn_m_s",
    "sigma_ve_m_s",
    "sigma_vd_m_s",
];

/// [`CSV_VELOCITY_COLUMNS`] as they follow the header (for messages).
const CSV_VELOCITY_TAIL: &str = "v_n_m_s,v_e_m_s,v_d_m_s,sigma_vn_m_s,sigma_ve_m_s,sigma_vd_m_s";

/// The two GNSS file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GnssFormat {
    /// The project's CSV (header `t_s,lat_deg,...`).
    Csv,
    /// KF-GINS's GNSS text file (7 or 13 numbers a line, no header).
    KfGins,
}

/// The name of CSV column `i` (0-based).
fn csv_column(i: usize) -> &'static str {
    CSV_COLUMNS
        .iter()
        .chain(&CSV_VELOCITY_COLUMNS)
        .nth(i)
        .copied()
        .unwrap_or("(extra)")
}

/// The format of a GNSS file: the project's CSV when its first line that is not blank or a
/// `#`/`%` comment is a header (its first field not a number: `t_s`, or a header the CSV
/// reader then refuses by name, such as `T_S`), KF-GINS's text otherwise.
pub fn detect(path: &Path) -> Result<GnssFormat, TextError> {
    let file = File::open(path).map_err(|e| TextError::io(path, e))?;
    let mut lines = LineReader::new(BufReader::new(file));
    while let Some(line) = lines.next_line() {
        let line = line.map_err(|(n, e)| TextError::new(path, Some(n), TextErrorKind::Io(e)))?;
        let text = line.text.trim().trim_start_matches('\u{feff}');
        if text.is_empty() || text.starts_with('#') || text.starts_with('%') {
            continue;
        }
        let first_field = text.split([',', ' ', '\t']).next().unwrap_or("");
        return Ok(if first_field.trim().parse::<f64>().is_ok() {
            GnssFormat::KfGins
        } else {
            GnssFormat::Csv
        });
    }
    Ok(GnssFormat::KfGins) // no data line: the text reader says so
}

/// Reads a GNSS file of either format ([`detect`]); gnss-ins-sim's GPS file, which has no
/// 1-sigma, is refused ([`read_gnss_assuming`]).
pub fn read_gnss(path: &Path) -> anyhow::Result<Vec<GnssFix>> {
    read_gnss_assuming(path, None)
}

/// [`read_gnss`], or gnss-ins-sim's GPS file (`gps-K.csv`, or its folder for `gps-0.csv`;
/// [`crate::gnss_ins_sim::read_gps`]) with the 1-sigma `assumed`, which it needs: that file
/// holds none. A file with its own 1-sigma and an `assumed` one is refused (which would
/// count is not for this reader to guess).
pub fn read_gnss_assuming(
    path: &Path,
    assumed: Option<&AssumedSigma>,
) -> anyhow::Result<Vec<GnssFix>> {
    let gps_csv = path.join("gps-0.csv");
    let path = if path.is_dir() && gps_csv.is_file() {
        gps_csv.as_path()
    } else {
        path
    };
    crate::text_error::refuse_a_stream(path)?;
    // The first line as bytes: a file that is not UTF-8 text is refused by the text reader
    // below, with its line and byte (read as a string here it was "stream did not contain
    // valid UTF-8", naming neither).
    let mut first = Vec::new();
    File::open(path)
        .map(BufReader::new)
        .and_then(|mut r| r.read_until(b'\n', &mut first))
        .map_err(|e| TextError::io(path, e))?;
    let first = String::from_utf8_lossy(&first);
    if crate::gnss_ins_sim::looks_like_gps(first.trim_start_matches('\u{feff}')) {
        let Some(assumed) = assumed else {
            anyhow::bail!(
                "{}: gnss-ins-sim's GPS file holds no 1-sigma: state the receiver's with \
                 --gnss-sigma N,E,D [m] (and --gnss-velocity-sigma VN,VE,VD [m/s] to use its \
                 velocity); gnss-ins-sim's default receiver is 5,5,7 m and 0.05 m/s",
                path.display()
            );
        };
        let fixes = crate::gnss_ins_sim::read_gps(path, assumed)?;
        refuse_without_a_usable_fix(path, &fixes)?;
        return Ok(fixes);
    }
    anyhow::ensure!(
        assumed.is_none(),
        "{}: this GNSS file gives each fix its own 1-sigma; --gnss-sigma is for gnss-ins-sim's \
         GPS file, which has none",
        path.display()
    );
    let fixes = read_text_gnss(path)?;
    refuse_without_a_usable_fix(path, &fixes)?;
    Ok(fixes)
}

/// Refuses a file none of whose fixes the filter can use: no usable position (nav-core's
/// rule, [`GnssPosition::is_valid`]) and no usable velocity ([`NavGnssVelocity::is_valid`]; the
/// navigator applies a fix's velocity when its position is refused). Such a file would run
/// free-inertial (or, converted, make a fix file of nothing but refused fixes). No receiver
/// records that; a KF-GINS IMU text file given for the fixes does: it has the GNSS text's 7
/// columns, its angle increments read as a place near latitude 0 and its velocity increments as
/// 1-sigmas, the vertical one negative on every line.
fn refuse_without_a_usable_fix(path: &Path, fixes: &[GnssFix]) -> anyhow::Result<()> {
    let usable = |f: &GnssFix| {
        let position = GnssPosition::<f64> {
            lat_rad: f.lat_rad,
            lon_rad: f.lon_rad,
            h_m: f.h_m,
            sigma_ned_m: f.sigma_ned_m.into(),
        };
        let velocity = f.velocity.map(|v| NavGnssVelocity::<f64> {
            v_ned_m_s: v.v_ned_m_s.into(),
            sigma_ned_m_s: v.sigma_ned_m_s.into(),
        });
        position.is_valid() || velocity.is_some_and(|v| v.is_valid())
    };
    let Some(first) = fixes.first() else {
        return Ok(()); // the readers refuse a file without a fix
    };
    if fixes.iter().any(usable) {
        return Ok(());
    }
    let s = first.sigma_ned_m;
    anyhow::bail!(
        "{}: none of its {} fixes is usable (a finite place with latitude within +-90 deg and \
         height within 10000 km, every 1-sigma positive and at most 1e7 m; or such a velocity): \
         the first, at t = {} s, is at {} deg, {} deg, {} m with 1-sigma {}, {}, {} m; not a \
         receiver's fixes (a KF-GINS IMU file has the GNSS text's 7 columns: its increments read \
         as a place near latitude 0 and as 1-sigmas)",
        path.display(),
        fixes.len(),
        Number(first.t_s),
        Number(first.lat_rad.to_degrees()),
        Number(first.lon_rad.to_degrees()),
        Number(first.h_m),
        Number(s[0]),
        Number(s[1]),
        Number(s[2]),
    )
}

/// The project's CSV or KF-GINS's text ([`detect`]).
fn read_text_gnss(path: &Path) -> anyhow::Result<Vec<GnssFix>> {
    // The firmware's binary fix file is not a text this reads: say what it is.
    let mut magic = [0u8; 8];
    let head = File::open(path)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut magic))
        .map_err(|e| TextError::io(path, e))?;
    if head == magic.len() && magic == hal_adapters::gnss_record::MAGIC {
        anyhow::bail!(
            "{}: this is the binary fix file the firmware reads (docs/gnss-record-format.md); \
             give the GNSS text it was converted from (the project's CSV or KF-GINS's text)",
            path.display()
        );
    }
    // An IMU recording read as text failed with "line 1: expected 7 numbers ..., found 1".
    if head >= 6 && magic.starts_with(&hal_adapters::recording::MAGIC[..6]) {
        anyhow::bail!(
            "{}: an IMU recording (it starts with the NAVIMU magic of \
             docs/recording-format.md), not GNSS fixes: give the receiver's fixes (the \
             project's CSV or KF-GINS's text)",
            path.display()
        );
    }
    let format = detect(path)?;
    let file = File::open(path).map_err(|e| TextError::io(path, e))?;
    let reader = BufReader::new(file);
    Ok(match format {
        GnssFormat::Csv => read_csv_from(reader, path)?,
        GnssFormat::KfGins => read_kf_gins_from(reader, path)?,
    })
}

/// Reads KF-GINS GNSS text from `reader`; `path` names it in errors.
pub fn read_kf_gins_from<R: BufRead>(reader: R, path: &Path) -> Result<Vec<GnssFix>, TextError> {
    let mut lines = DataLines::new(reader, path, FileKind::Gnss);
    let mut fixes: Vec<GnssFix> = Vec::new();
    loop {
        let fix = lines.next_with(kf_gins_fix);
        match fix {
            None => return Ok(fixes),
            Some(fix) => fixes.push(fix?),
        }
    }
}

/// One KF-GINS GNSS line of 7 or 13 fields (the count is checked by [`DataLines`]).
fn kf_gins_fix(fields: &Fields, at: LineError) -> Result<GnssFix, TextError> {
    let names: &[&'static str] = if fields.len() == GNSS_COLUMNS.len() {
        &GNSS_COLUMNS
    } else {
        &GNSS_VELOCITY_COLUMNS
    };
    let mut v = [0.0_f64; GNSS_VELOCITY_COLUMNS.len()];
    for (i, slot) in v.iter_mut().enumerate().take(fields.len()) {
        *slot = fields.number(i, names[i]).map_err(at)?;
    }
    check_time(v[0], || fields.text(0)).map_err(at)?;
    check_latitude(v[1], names[1]).map_err(at)?;
    check_longitude(v[2], names[2]).map_err(at)?;
    let (sigma_ned_m, velocity) = if fields.len() == GNSS_COLUMNS.len() {
        ([v[4], v[5], v[6]], None)
    } else {
        let velocity = GnssVelocity {
            v_ned_m_s: [v[4], v[5], v[6]],
            sigma_ned_m_s: [v[10], v[11], v[12]],
        };
        ([v[7], v[8], v[9]], Some(velocity))
    };
    Ok(GnssFix {
        t_s: v[0],
        lat_rad: v[1].to_radians(),
        lon_rad: v[2].to_radians(),
        h_m: v[3],
        sigma_ned_m,
        velocity,
    })
}

/// A finite latitude must be within [-90, 90] deg (a NaN one is a bad fix, kept).
fn check_latitude(lat_deg: f64, column: &'static str) -> Result<(), TextErrorKind> {
    if lat_deg.is_finite() && !(-90.0..=90.0).contains(&lat_deg) {
        Err(TextErrorKind::BadLatitude { column, lat_deg })
    } else {
        Ok(())
    }
}

/// A finite longitude must be within [-180, 180] deg (a NaN one is a bad fix, kept).
fn check_longitude(lon_deg: f64, column: &'static str) -> Result<(), TextErrorKind> {
    if lon_deg.is_finite() && !(-180.0..=180.0).contains(&lon_deg) {
        Err(TextErrorKind::BadLongitude { column, lon_deg })
    } else {
        Ok(())
    }
}

/// Reads the project's GNSS CSV from `reader`; `path` names it in errors.
pub fn read_csv_from<R: Read>(reader: R, path: &Path) -> Result<Vec<GnssFix>, TextError> {
    let expected = CSV_COLUMNS.join(",");
    let (mut records, header) = CsvRecords::new(reader, path, &expected)?;
    let names: Vec<&str> = header
        .iter()
        .enumerate()
        .map(|(i, h)| {
            if i == 0 {
                h.trim_start_matches('\u{feff}')
            } else {
                h
            }
        })
        .collect();
    let width = if names == CSV_COLUMNS {
        CSV_COLUMNS.len()
    } else if names.len() == CSV_COLUMNS.len() + CSV_VELOCITY_COLUMNS.len()
        && names[..CSV_COLUMNS.len()] == CSV_COLUMNS
        && names[CSV_COLUMNS.len()..] == CSV_VELOCITY_COLUMNS
    {
        names.len()
    } else {
        return Err(TextError::new(
            path,
            header.position().map(|p| p.line()),
            TextErrorKind::WrongHeader {
                expected,
                optional: Some(CSV_VELOCITY_TAIL),
                found: names.join(","),
            },
        ));
    };
    let mut cut = CutCheck::default();
    let mut fixes: Vec<GnssFix> = Vec::new();
    while let Some(line) = records.next_record() {
        let line = line?;
        let record = line.record;
        if line.unterminated {
            let fields: Vec<&str> = record.iter().collect();
            let is_number = |i: usize, text: &str| {
                (i >= CSV_COLUMNS.len() && text.is_empty()) || text.parse::<f64>().is_ok()
            };
            let column = |i: usize| csv_column(i).to_owned();
            if let Err(cut) = cut.check(&fields, width, column, is_number) {
                let kind = TextErrorKind::Truncated {
                    line: line.line,
                    cut,
                };
                return Err(TextError::new(path, None, kind));
            }
        } else {
            cut.note(record.iter());
        }
        let at = |kind| TextError::new(path, Some(line.line), kind);
        fixes.push(csv_fix(record, width).map_err(at)?);
    }
    if fixes.is_empty() {
        let kind = TextErrorKind::NoData {
            columns: &CSV_COLUMNS,
        };
        return Err(TextError::new(path, None, kind));
    }
    Ok(fixes)
}

/// One CSV row of `width` fields (7, or 13 with velocity).
fn csv_fix(record: &csv::StringRecord, width: usize) -> Result<GnssFix, TextErrorKind> {
    if record.len() < width {
        return Err(TextErrorKind::MissingColumn {
            column: csv_column(record.len()),
            found: record.len(),
        });
    }
    if record.len() > width {
        return Err(TextErrorKind::ExtraColumns {
            expected: width,
            found: record.len(),
        });
    }
    let number = |i: usize| -> Result<f64, TextErrorKind> {
        record[i].parse().map_err(|_| TextErrorKind::NotANumber {
            column: csv_column(i),
            found: record[i].to_owned(),
        })
    };
    let t_s = number(0)?;
    if !(t_s.is_finite() && t_s >= 0.0) {
        return Err(TextErrorKind::BadTime {
            found: record[0].to_owned(),
        });
    }
    if seconds_to_ns(t_s).is_none() {
        return Err(TextErrorKind::TimeOutOfRange {
            column: CSV_COLUMNS[0],
            t_s,
        });
    }
    let lat_deg = number(1)?;
    check_latitude(lat_deg, CSV_COLUMNS[1])?;
    let (lon_deg, h_m) = (number(2)?, number(3)?);
    check_longitude(lon_deg, CSV_COLUMNS[2])?;
    let sigma_ned_m = [number(4)?, number(5)?, number(6)?];
    let n = CSV_COLUMNS.len();
    let velocity = if width == n || (n..width).all(|i| record[i].is_empty()) {
        None
    } else {
        // All six or none: an empty one among numbers is not a number.
        Some(GnssVelocity {
            v_ned_m_s: [number(n)?, number(n + 1)?, number(n + 2)?],
            sigma_ned_m_s: [number(n + 3)?, number(n + 4)?, number(n + 5)?],
        })
    };
    Ok(GnssFix {
        t_s,
        lat_rad: lat_deg.to_radians(),
        lon_rad: lon_deg.to_radians(),
        h_m,
        sigma_ned_m,
        velocity,
    })
}

/// Writes `fixes` to `path` as the project's GNSS CSV, atomically ([`crate::atomic`]): with the
/// velocity columns when any fix has a velocity (the others leave them empty).
pub fn write_gnss_csv(path: &Path, fixes: &[GnssFix]) -> anyhow::Result<()> {
    crate::atomic::write(path, |out| write_csv_to(out, fixes))
        .map_err(|e| TextError::io(path, e))?;
    Ok(())
}

/// Writes `fixes` as the project's GNSS CSV to `out` (see [`write_gnss_csv`]).
pub fn write_csv_to<W: Write>(mut out: W, fixes: &[GnssFix]) -> io::Result<()> {
    let with_velocity = fixes.iter().any(|f| f.velocity.is_some());
    write!(out, "{}", CSV_COLUMNS.join(","))?;
    if with_velocity {
        write!(out, ",{CSV_VELOCITY_TAIL}")?;
    }
    writeln!(out)?;
    for f in fixes {
        let s = &f.sigma_ned_m;
        write!(
            out,
            "{},{},{},{},{},{},{}",
            f.t_s,
            f.lat_rad.to_degrees(),
            f.lon_rad.to_degrees(),
            f.h_m,
            s[0],
            s[1],
            s[2]
        )?;
        match (with_velocity, &f.velocity) {
            (false, _) => {}
            (true, None) => write!(out, ",,,,,,")?,
            (true, Some(v)) => {
                let (v_m_s, s) = (&v.v_ned_m_s, &v.sigma_ned_m_s);
                write!(
                    out,
                    ",{},{},{},{},{},{}",
                    v_m_s[0], v_m_s[1], v_m_s[2], s[0], s[1], s[2]
                )?;
            }
        }
        writeln!(out)?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_binary_fix_file_is_named_not_parsed() {
        let dir = tempfile::tempdir().unwrap();
        let bin = dir.path().join("gnss.bin");
        let mut bytes = hal_adapters::gnss_record::MAGIC.to_vec();
        bytes.extend_from_slice(&[0u8; 40]);
        std::fs::write(&bin, bytes).unwrap();
        let e = read_gnss(&bin).unwrap_err().to_string();
        assert!(e.contains("binary fix file the firmware reads"), "{e}");
        // An IMU recording: named, not read as text ("line 1: expected 7 numbers").
        let mut bytes = hal_adapters::recording::MAGIC.to_vec();
        bytes.extend_from_slice(&[0u8; 40]);
        std::fs::write(&bin, bytes).unwrap();
        let e = read_gnss(&bin).unwrap_err().to_string();
        assert!(
            e.contains("an IMU recording (it starts with the NAVIMU magic"),
            "{e}"
        );
    }

    fn csv(text: &str) -> Result<Vec<GnssFix>, TextError> {
        read_csv_from(text.as_bytes(), Path::new("mem.csv"))
    }

    fn kf(text: &str) -> Result<Vec<GnssFix>, TextError> {
        read_kf_gins_from(text.as_bytes(), Path::new("mem.txt"))
    }

    /// Two lines as KF-GINS's demo GNSS file looks (fixed-width, a trailing blank).
    const KF7: &str = "456250.000    30.4447858054   114.4718661162     21.095    0.010    0.009    0.019 \n\
                       456251.000    30.4447857891   114.4718661133     21.091    0.010    0.009    0.019 \n";

    #[test]
    fn reads_kf_gins_7_and_13_columns() {
        let f = kf(KF7).unwrap();
        assert_eq!(f.len(), 2);
        assert_eq!(f[0].t_s, 456_250.0);
        assert_eq!(f[0].lat_rad, 30.4447858054_f64.to_radians());
        assert_eq!(f[0].lon_rad, 114.4718661162_f64.to_radians());
        assert_eq!(f[0].h_m, 21.095);
        assert_eq!(f[0].sigma_ned_m, [0.010, 0.009, 0.019]);
        assert_eq!(f[0].velocity, None);
        // 13 columns: velocity before the sigmas, as KF-GINS reads them; commas and comments.
        let f =
            kf("% a comment\n\n456252,30.5,114.5,21,1.5,-2.5,0.25,0.01,0.02,0.03,0.1,0.2,0.3\n")
                .unwrap();
        assert_eq!(f[0].sigma_ned_m, [0.01, 0.02, 0.03]);
        assert_eq!(
            f[0].velocity,
            Some(GnssVelocity {
                v_ned_m_s: [1.5, -2.5, 0.25],
                sigma_ned_m_s: [0.1, 0.2, 0.3]
            })
        );
    }

    #[test]
    fn bad_values_are_kept_bad_files_are_errors() {
        let f = kf("1 nan 7 100 0 -1 inf\n2 45 7 100 1 1 1\n").unwrap();
        assert!(f[0].lat_rad.is_nan());
        assert_eq!(f[0].sigma_ned_m[..2], [0.0, -1.0]);
        let msg = |text: &str| kf(text).unwrap_err().to_string();
        // A repeated time is kept, for the navigator to skip and count.
        assert_eq!(kf("1 45 7 100 1 1 1\n1 45 7 100 1 1 1\n").unwrap().len(), 2);
        assert_eq!(
            msg("1 45 7 100 1 x 1\n"),
            "mem.txt: line 1: column sigma east: expected a number, found 'x'"
        );
        assert_eq!(
            msg("1 45 7 100 1 2 3 4 5 6 7 8 y\n"),
            "mem.txt: line 1: column sigma v down: expected a number, found 'y'"
        );
        let m = msg("1 45 7 100 1 1\n");
        assert!(m.starts_with("mem.txt: line 1: expected 7 numbers"), "{m}");
        assert!(m.ends_with("found 6"), "{m}");
        assert!(msg("# nothing\n").contains("no data"));
        assert!(msg("1 95 7 100 1 1 1\n").contains("line 1: column latitude: 95 deg"));
        // A longitude beyond +-180 deg (367.5 for 7.5) was wrapped without a word.
        let m = msg("1 45 367.5 100 1 1 1\n");
        assert!(
            m.contains("line 1: column longitude: 367.5 deg is outside [-180, 180]"),
            "{m}"
        );
        assert!(msg("1 45 -180.5 100 1 1 1\n").contains("-180.5 deg is outside"));
        assert_eq!(
            kf("1 45 -180 100 1 1 1\n2 45 NaN 100 1 1 1\n")
                .unwrap()
                .len(),
            2
        );
        assert!(msg("1 45 7 100 1 1 1\n2 45 7 100 1 1").contains("truncated: last line 2"));
    }

    /// A KF-GINS IMU text file given as the GNSS file (another copy than the replay's
    /// recording) was read as fixes near latitude 0 with a negative down 1-sigma, converted and
    /// navigated as such (every fix refused by the filter: a free-inertial run, no word why).
    #[test]
    fn a_file_without_a_usable_fix_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let file = |name: &str, text: &str| {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            p
        };
        let imu = file(
            "imu.txt",
            "432000.0025 1.2e-7 -8.5e-8 -1.4e-7 -1.6e-5 -1.3e-5 -0.0245934\n\
             432000.0050 2.3e-7 6.1e-8 -2.1e-7 7.7e-6 4.1e-5 -0.0244789\n",
        );
        let m = read_gnss(&imu).unwrap_err().to_string();
        assert!(
            m.contains("imu.txt: none of its 2 fixes is usable")
                && m.contains("1-sigma -1.6e-5, -1.3e-5, -0.0245934 m")
                && m.contains("KF-GINS IMU file"),
            "{m}"
        );
        let out = dir.path().join("gnss.bin");
        let m = format!(
            "{:#}",
            crate::gnss_file::convert(&imu, &out, None).unwrap_err()
        );
        assert!(m.contains("none of its 2 fixes is usable"), "{m}");
        assert!(!out.exists());
        // Every fix bad (zero, NaN 1-sigmas; NaN place) in the project's CSV too.
        let header = CSV_COLUMNS.join(",");
        let csv = file(
            "bad.csv",
            &format!("{header}\n1,45,7,100,0,1,1\n2,NaN,7,100,1,1,1\n3,45,7,100,1,NaN,1\n"),
        );
        let m = read_gnss(&csv).unwrap_err().to_string();
        assert!(m.contains("none of its 3 fixes is usable"), "{m}");
        // A receiver's "no fix" 1-sigma (1e30 m, or just beyond nav-core's bound) is no fix:
        // before, such a file was read and run free-inertial with a warning, while the
        // same file with 1-sigma 0 was refused.
        let csv = file(
            "huge.csv",
            &format!("{header}\n1,45,7,100,1e30,1e30,1e30\n2,45,7,100,1,1.1e7,1\n"),
        );
        let m = read_gnss(&csv).unwrap_err().to_string();
        assert!(
            m.contains("none of its 2 fixes is usable") && m.contains("at most 1e7 m"),
            "{m}"
        );
        // One usable fix among bad ones: the file is read, the bad fixes kept for the filter.
        let csv = file(
            "one.csv",
            &format!("{header}\n1,45,7,100,0,1,1\n2,45,7,100,1,1,1\n"),
        );
        assert_eq!(read_gnss(&csv).unwrap().len(), 2);
        // No usable position but a usable velocity (the navigator applies it): read.
        let csv = file(
            "velocity.csv",
            &format!("{header},{CSV_VELOCITY_TAIL}\n1,45,7,100,0,1,1,1,0,0,0.1,0.1,0.1\n"),
        );
        assert_eq!(read_gnss(&csv).unwrap().len(), 1);
    }

    /// A header in capitals was read as KF-GINS text: "column seconds of week: expected a
    /// number, found 'T_S'", a column the file does not have. Told as the CSV header it is.
    #[test]
    fn a_header_in_capitals_is_refused_as_a_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("upper.csv");
        let header = CSV_COLUMNS.join(",").to_uppercase();
        std::fs::write(&path, format!("{header}\n1,45,7,100,1,1,1\n")).unwrap();
        assert_eq!(detect(&path).unwrap(), GnssFormat::Csv);
        let m = read_gnss(&path).unwrap_err().to_string();
        assert!(
            m.contains("line 1: expected the header row 't_s,lat_deg,")
                && m.contains("found 'T_S,LAT_DEG,"),
            "{m}"
        );
        // A KF-GINS line is still KF-GINS text.
        std::fs::write(&path, "1 45 7 100 1 1 1\n").unwrap();
        assert_eq!(detect(&path).unwrap(), GnssFormat::KfGins);
    }

    #[test]
    fn csv_round_trips_with_and_without_velocity() {
        let a = GnssFix {
            t_s: 0.1 + 0.2,
            lat_rad: 45.123_456_789_012_3_f64.to_radians(),
            lon_rad: (-122.987_654_321_098_7_f64).to_radians(),
            h_m: 250.123_456_789,
            sigma_ned_m: [0.5, 0.6, 1.25],
            velocity: None,
        };
        let b = GnssFix {
            t_s: 1.3,
            velocity: Some(GnssVelocity {
                v_ned_m_s: [10.0 / 3.0, -1e-7, 0.0],
                sigma_ned_m_s: [0.05, 0.05, 0.1],
            }),
            ..a
        };
        for fixes in [vec![a], vec![a, b]] {
            let mut bytes = Vec::new();
            write_csv_to(&mut bytes, &fixes).unwrap();
            let back = csv(std::str::from_utf8(&bytes).unwrap()).unwrap();
            assert_eq!(back.len(), fixes.len());
            for (x, y) in fixes.iter().zip(&back) {
                assert_eq!(x.t_s.to_bits(), y.t_s.to_bits());
                assert_eq!(
                    (x.h_m, x.sigma_ned_m, x.velocity),
                    (y.h_m, y.sigma_ned_m, y.velocity)
                );
                assert!((x.lat_rad - y.lat_rad).abs() <= 2.0 * f64::EPSILON * x.lat_rad.abs());
                assert!((x.lon_rad - y.lon_rad).abs() <= 2.0 * f64::EPSILON * x.lon_rad.abs());
            }
        }
    }

    #[test]
    fn csv_errors_name_line_and_column() {
        let h7 = CSV_COLUMNS.join(",");
        let h13 = format!("{h7},{CSV_VELOCITY_TAIL}");
        let msg = |text: &str| csv(text).unwrap_err().to_string();
        assert_eq!(
            msg(&format!("{h13}\n1,45,7,100,1,1,1,0,,0,1,1,1\n")),
            "mem.csv: line 2: column v_e_m_s: expected a number, found ''"
        );
        assert_eq!(
            msg(&format!("{h7}\n1,45,7,100,1,1\n")),
            "mem.csv: line 2: column sigma_d_m: missing (the line has only 6 columns)"
        );
        let back = csv(&format!("{h7}\n2,45,7,100,1,1,1\n1,45,7,100,1,1,1\n")).unwrap();
        assert_eq!((back[0].t_s, back[1].t_s), (2.0, 1.0));
        assert!(msg(&format!("{h7}\n")).contains("no data"));
        assert_eq!(
            msg(&format!("{h7}\n1,45,-352.5,100,1,1,1\n")),
            "mem.csv: line 2: column lon_deg: longitude -352.5 deg is outside [-180, 180] \
             (refused, not wrapped: a converter's error)"
        );
        assert!(msg("").contains("empty file"));
        let m = msg("t_s,lat_deg\n");
        assert!(m.contains("optionally followed by ',v_n_m_s,"), "{m}");
        // Empty velocity: no velocity; NaN values kept.
        let f = csv(&format!(
            "{h13}\n1,NaN,7,100,0,1,1,,,,,,\n2,45,7,100,1,1,1,1,2,3,0,0,0\n"
        ))
        .unwrap();
        assert!(f[0].lat_rad.is_nan() && f[0].velocity.is_none());
        assert_eq!(f[1].velocity.unwrap().v_ned_m_s, [1.0, 2.0, 3.0]);
    }
}
