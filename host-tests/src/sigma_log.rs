//! The 1-sigma columns of an aided solution log ([`crate::aided::SIGMA_COLUMNS`]), for
//! `nav report`'s normalised errors and ±3-sigma envelopes.
//!
//! A log without those columns (a free-inertial or alignment run, a truth file) has none: the
//! reader answers `None`. A log with only some of them, or with a value that is not a finite
//! number >= 0, is refused with its line; so is a status word none of the logs write, and a header
//! naming one of the columns read twice.

use crate::aided::SIGMA_COLUMNS;
use crate::text_error::{TextError, TextErrorKind};
use crate::text_stream::column_position;
use anyhow::{Context, Result, bail};
use hal_adapters::protocol::status::NavStatus;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// The 1-sigma column names, in [`Sigma`]'s order (those of the writer's
/// [`SIGMA_COLUMNS`]).
pub fn columns() -> [&'static str; 9] {
    let mut names = SIGMA_COLUMNS.split(',').filter(|c| c.starts_with("sigma_"));
    core::array::from_fn(|_| names.next().unwrap_or_default())
}

/// One row's 1-sigma: position north, east, down [m], velocity north, east, down [m/s], roll,
/// pitch, yaw [deg].
pub type Sigma = [f64; 9];

/// The 1-sigma of every row of the solution log at `path` (its end record skipped), or `None`
/// when the log has no 1-sigma columns.
pub fn read(path: &Path) -> Result<Option<Vec<Sigma>>> {
    let file = File::open(path).with_context(|| format!("{}", path.display()))?;
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(BufReader::new(file));
    let header = reader
        .headers()
        .with_context(|| format!("{}: header", path.display()))?
        .clone();
    let names = columns();
    let index: Vec<Option<usize>> = names
        .iter()
        .map(|name| position(path, &header, name))
        .collect::<Result<_>>()?;
    if index.iter().all(Option::is_none) {
        check_status_words(path, &header, reader.records())?;
        return Ok(None);
    }
    if let Some(k) = index.iter().position(Option::is_none) {
        bail!(
            "{}: the header has some 1-sigma columns but not {}",
            path.display(),
            names[k]
        );
    }
    let index: Vec<usize> = index.into_iter().flatten().collect();
    let status = position(path, &header, STATUS)?;
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = record.with_context(|| format!("{}", path.display()))?;
        let line = record.position().map_or(0, |p| p.line());
        check_status_word(path, line, status.and_then(|i| record.get(i)))?;
        let mut sigma = [0.0; 9];
        for (s, (&i, name)) in sigma.iter_mut().zip(index.iter().zip(names)) {
            let text = record.get(i).unwrap_or("");
            *s = match text.parse::<f64>() {
                Ok(v) if v.is_finite() && v >= 0.0 => v,
                _ => bail!(
                    "{}: line {line}: {name} is {text:?}, not a finite number >= 0",
                    path.display()
                ),
            };
        }
        rows.push(sigma);
    }
    Ok(Some(rows))
}

/// The position of column `name` in `header`, refusing a header that names it twice.
fn position(path: &Path, header: &csv::StringRecord, name: &'static str) -> Result<Option<usize>> {
    let names: Vec<&str> = header.iter().collect();
    column_position(&names, name).map_err(|positions| {
        let line = header.position().map(|p| p.line());
        let kind = TextErrorKind::HeaderDuplicateColumn {
            column: name,
            positions,
        };
        TextError::new(path, line, kind).into()
    })
}

/// The status column's name.
const STATUS: &str = "status";

/// Refuses a row whose status (`word`, when the log has the column) is none of the words the
/// logs write ([`NavStatus`]'s names): "FOO" was read and compared as a solution.
fn check_status_word(path: &Path, line: u64, word: Option<&str>) -> Result<()> {
    let Some(word) = word else { return Ok(()) };
    if NavStatus::ALL.iter().any(|s| s.name() == word) {
        return Ok(());
    }
    let known: Vec<&str> = NavStatus::ALL.iter().map(|s| s.name()).collect();
    bail!(
        "{}: line {line}: column {STATUS}: unknown status word {word:?} (the solution logs \
         write {})",
        path.display(),
        known.join(", ")
    )
}

/// [`check_status_word`] for every row of a log without 1-sigma columns that has a status
/// column.
fn check_status_words<R: std::io::Read>(
    path: &Path,
    header: &csv::StringRecord,
    records: csv::StringRecordsIter<'_, R>,
) -> Result<()> {
    let Some(status) = position(path, header, STATUS)? else {
        return Ok(());
    };
    for record in records {
        let record = record.with_context(|| format!("{}", path.display()))?;
        let line = record.position().map_or(0, |p| p.line());
        check_status_word(path, line, record.get(status))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(text: &str) -> tempfile::NamedTempFile {
        let f = tempfile::NamedTempFile::new().unwrap();
        std::fs::write(f.path(), text).unwrap();
        f
    }

    const HEADER: &str = "t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,pitch_deg,\
yaw_deg,sigma_n_m,sigma_e_m,sigma_d_m,sigma_vn_mps,sigma_ve_mps,sigma_vd_mps,sigma_roll_deg,\
sigma_pitch_deg,sigma_yaw_deg,status";

    #[test]
    fn the_columns_are_the_writers() {
        assert_eq!(crate::aided::header(), HEADER);
        assert!(columns().iter().all(|c| c.starts_with("sigma_")));
    }

    #[test]
    fn reads_the_columns_and_skips_the_end_record() {
        let f = file(&format!(
            "{HEADER}\n1,45,7,100,0,0,0,0,0,0,1,2,3,0.1,0.2,0.3,0.01,0.02,0.5,NAV\n# end: 1 rows, ok\n"
        ));
        let rows = read(f.path()).unwrap().unwrap();
        assert_eq!(rows, vec![[1.0, 2.0, 3.0, 0.1, 0.2, 0.3, 0.01, 0.02, 0.5]]);
    }

    #[test]
    fn a_log_without_sigma_has_none() {
        let f = file("t_s,lat_deg\n1,45\n");
        assert_eq!(read(f.path()).unwrap(), None);
    }

    #[test]
    fn refuses_a_partial_header_and_bad_values() {
        let f = file("t_s,sigma_n_m\n1,2\n");
        let e = read(f.path()).unwrap_err().to_string();
        assert!(e.contains("not sigma_e_m"), "{e}");
        for bad in ["-1", "NaN", "x", "inf"] {
            let f = file(&format!(
                "{HEADER}\n1,45,7,100,0,0,0,0,0,0,{bad},2,3,0.1,0.2,0.3,0.01,0.02,0.5,NAV\n"
            ));
            let e = format!("{:#}", read(f.path()).unwrap_err());
            assert!(e.contains("line 2: sigma_n_m"), "{bad}: {e}");
        }
    }

    /// A header naming a column twice: the first one was read silently.
    #[test]
    fn refuses_a_column_named_twice() {
        let f = file(&format!("{HEADER},sigma_e_m\n"));
        let e = read(f.path()).unwrap_err().to_string();
        assert!(
            e.contains("line 1: the header names column sigma_e_m twice, as fields 12 and 21"),
            "{e}"
        );
        let f = file("t_s,status,lat_deg,status\n1,NAV,45,FOO\n");
        let e = read(f.path()).unwrap_err().to_string();
        assert!(e.contains("column status twice, as fields 2 and 4"), "{e}");
    }

    /// A status "FOO" was read and compared as a solution.
    #[test]
    fn refuses_an_unknown_status_word() {
        for header in [HEADER, "t_s,lat_deg,status"] {
            let row = match header {
                HEADER => "1,45,7,100,0,0,0,0,0,0,1,2,3,0.1,0.2,0.3,0.01,0.02,0.5",
                _ => "1,45",
            };
            let f = file(&format!("{header}\n{row},NAV\n{row},DEGRADED\n"));
            assert!(read(f.path()).is_ok(), "{header}");
            let f = file(&format!("{header}\n{row},NAV\n{row},FOO\n"));
            let e = format!("{:#}", read(f.path()).unwrap_err());
            assert!(
                e.contains(
                    "line 3: column status: unknown status word \"FOO\" (the solution \
                            logs write ALIGN_COARSE, ALIGN_FINE, NAV, DEGRADED, FAULT, STANDBY)"
                ),
                "{e}"
            );
        }
    }
}
