//! gnss-ins-sim's output folder as a recording: the files Aceinna's Python simulator writes
//! (and its demo logs of real consumer MEMS parts, `shared/data/gnss-ins-sim-stationary`).
//!
//! ```text
//! DIR/time.csv      time (sec)
//! DIR/gyro-K.csv    gyro_x (deg/s),gyro_y (deg/s),gyro_z (deg/s)      (or rad/s)
//! DIR/accel-K.csv   accel_x (m/s^2),accel_y (m/s^2),accel_z (m/s^2)
//! ```
//!
//! One row per epoch in each file, the same count in all three; `K` numbers the simulator's
//! runs of the same motion (`-0`, `-1`, ...). Body axes FRD (x forward, z down: at rest
//! `accel_z` is about -9.8, the specific force), as this project's. The unit is read from each
//! header (a column without a known unit is refused, never guessed).
//!
//! **Rates to increments.** The files hold rates sampled at the epochs `t_k`; a record of this
//! project is the increment over `(t_(k-1), t_k]`, here `w_(k-1) (t_k - t_(k-1))`: gnss-ins-sim
//! integrates its trajectory forward from each epoch (its `pathgen` writes the row's rates
//! and state at `t_k`, then steps the state by those rates to `t_(k+1)`), so a row's rates hold
//! over the interval after it, and this rule reproduces its reference trajectory (`ref_*.csv`,
//! [`read_truth`]). On a real part's log the rule is a sample-and-hold, half a sample behind the
//! trapezoid. The first epoch starts the first interval (the recording's `t0`), so `n` epochs
//! give `n - 1` records; the last epoch's rates are not used. An epoch whose time does not
//! increase gives a record the replay flags; a value that is not finite gives a record flagged
//! as not finite.
//!
//! **Reference trajectory** ([`read_truth`], for `nav report`): `ref_pos.csv` (`ref_pos_lat`,
//! `ref_pos_lon` in deg or rad, `ref_pos_alt` in m, WGS-84), `ref_vel.csv` (`ref_vel_x/y/z`
//! [m/s], the velocity in the **body** frame, as gnss-ins-sim's data manager describes it),
//! `ref_att_euler.csv` (`ref_Yaw`, `ref_Pitch`, `ref_Roll` in deg or rad, z-y-x), one row per
//! epoch of `time.csv`. A simulation in gnss-ins-sim's virtual inertial frame (`ref_pos_x (m)`)
//! is refused: its positions are not geodetic.
//!
//! **GPS fixes** ([`read_gps`], for `nav replay --gnss`): `gps-K.csv` (`gps_lat`, `gps_lon` in
//! deg or rad, `gps_alt` [m], `gps_vN`, `gps_vE`, `gps_vD` [m/s], of the IMU's position: the
//! simulator has no antenna lever arm) with `gps_time.csv` (`gps_time (sec)`) beside it. The
//! files hold no 1-sigma; the user states the receiver's ([`AssumedSigma`]; gnss-ins-sim's
//! default receiver is 5, 5, 7 m and 0.05 m/s), and without it the file is refused: a guessed
//! sigma would make the filter's own sigma a guess. gnss-ins-sim writes a fix at every GPS
//! epoch, visible or not, and the motion definition's visibility column as
//! `gps_visibility.csv` (`gps_visibility ()`, 1 or 0 per fix) beside them: a fix flagged 0 is
//! left out (an outage, as the simulation meant it); a flag other than 0 or 1, or a count that
//! is not the fixes', refuses the file.
//!
//! A folder is recognised by its `time.csv` with a `gyro-K.csv` and an `accel-K.csv` (the
//! lowest `K` that has both); any of the three files given by name stands for its folder (a
//! `gyro-1.csv` or `accel-1.csv` for run 1).

use crate::recording_io::Recording;
use crate::text_error::seconds_to_ns;
use crate::text_recording::rate_from_times;
use crate::truth::Truth;
use anyhow::{Context, Result, anyhow, bail, ensure};
use hal_adapters::recording::{Kind, Record};
use nav_core::Vector3;
use nav_core::attitude::from_euler;
use std::path::{Path, PathBuf};

/// Runs looked for in a folder (`gyro-0.csv` ... `gyro-99.csv`).
const MAX_RUNS: u32 = 100;

/// One run of a gnss-ins-sim output folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Run {
    /// The folder.
    pub dir: PathBuf,
    /// The run's number `K` (`gyro-K.csv`, `accel-K.csv`).
    pub index: u32,
}

impl Run {
    fn time(&self) -> PathBuf {
        self.dir.join("time.csv")
    }
    fn gyro(&self) -> PathBuf {
        self.dir.join(format!("gyro-{}.csv", self.index))
    }
    fn accel(&self) -> PathBuf {
        self.dir.join(format!("accel-{}.csv", self.index))
    }
}

/// True when a file's first line is one of gnss-ins-sim's IMU headers (time, gyro or
/// accelerometer).
pub fn looks_like(first_line: &str) -> bool {
    ["time (", "gyro_x (", "accel_x ("]
        .iter()
        .any(|h| first_line.starts_with(h))
}

/// The run `path` names: a folder (its lowest complete run), or one of its files (`time.csv`:
/// the folder's lowest run; `gyro-K.csv`, `accel-K.csv`: run `K`). `None` when `path` is
/// neither.
pub fn locate(path: &Path) -> Option<Run> {
    let lowest = |dir: &Path| {
        (0..MAX_RUNS)
            .map(|index| Run {
                dir: dir.to_path_buf(),
                index,
            })
            .find(|r| r.gyro().is_file() && r.accel().is_file())
    };
    if path.is_dir() {
        return lowest(path).filter(|r| r.time().is_file());
    }
    let name = path.file_name()?.to_str()?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if name == "time.csv" {
        return lowest(&dir);
    }
    let index = ["gyro-", "accel-"]
        .iter()
        .find_map(|p| name.strip_prefix(p)?.strip_suffix(".csv")?.parse().ok())?;
    Some(Run { dir, index })
}

/// A column's unit as its header names it, and the factor to SI.
fn unit_factor(path: &Path, header: &str, units: Units) -> Result<f64> {
    let unit = header
        .split_once('(')
        .and_then(|(_, u)| u.strip_suffix(')'))
        .map(str::trim)
        .ok_or_else(|| anyhow!("{}: column '{header}' names no unit", path.display()))?;
    units
        .iter()
        .find(|(u, _)| *u == unit)
        .map(|(_, f)| *f)
        .ok_or_else(|| {
            let known: Vec<&str> = units.iter().map(|(u, _)| *u).collect();
            anyhow!(
                "{}: column '{header}': unit '{unit}' is not one of {}",
                path.display(),
                known.join(", ")
            )
        })
}

/// A unit's name and its factor to SI.
type Units<'a> = &'a [(&'a str, f64)];

/// Seconds.
const TIME_UNITS: Units = &[("sec", 1.0), ("s", 1.0)];
/// Angles in deg or rad, as the header says.
const ANGLE_UNITS: Units = &[("deg", core::f64::consts::PI / 180.0), ("rad", 1.0)];
/// Metres.
const METRES: Units = &[("m", 1.0)];
/// Metres per second.
const SPEED_UNITS: Units = &[("m/s", 1.0)];
/// No unit (gnss-ins-sim writes `name ()`).
const NO_UNIT: Units = &[("", 1.0)];

/// The rows of one file: `N` columns named `names[i] (unit)`, the unit one of `units[i]`, each
/// scaled to SI.
fn read_columns<const N: usize>(
    path: &Path,
    names: [&str; N],
    units: [Units; N],
) -> Result<Vec<[f64; N]>> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_path(path)
        .with_context(|| format!("{}", path.display()))?;
    let headers = reader
        .headers()
        .with_context(|| format!("{}: header", path.display()))?
        .clone();
    ensure!(
        headers.len() == N,
        "{}: expected {N} columns ({}), found {}",
        path.display(),
        names.join(", "),
        headers.len()
    );
    let mut factors = [0.0; N];
    for (i, (h, name)) in headers.iter().zip(names).enumerate() {
        ensure!(
            h.starts_with(name) && h[name.len()..].trim_start().starts_with('('),
            "{}: column {} is '{h}', expected '{name} (unit)'",
            path.display(),
            i + 1
        );
        factors[i] = unit_factor(path, h, units[i])?;
    }
    let mut rows = Vec::new();
    for (k, record) in reader.records().enumerate() {
        let line = k + 2;
        let record = record.with_context(|| format!("{}: line {line}", path.display()))?;
        ensure!(
            record.len() == N,
            "{}: line {line}: {} fields, expected {N}",
            path.display(),
            record.len()
        );
        let mut row = [0.0; N];
        for (i, field) in record.iter().enumerate() {
            let x: f64 = field.parse().map_err(|_| {
                anyhow!(
                    "{}: line {line}, column {}: '{field}' is not a number",
                    path.display(),
                    i + 1
                )
            })?;
            row[i] = x * factors[i];
        }
        rows.push(row);
    }
    Ok(rows)
}

/// Reads a run into a recording of increments (module docs).
pub fn read(run: &Run) -> Result<Recording> {
    let (time_path, gyro_path, accel_path) = (run.time(), run.gyro(), run.accel());
    for p in [&time_path, &gyro_path, &accel_path] {
        ensure!(
            p.is_file(),
            "gnss-ins-sim folder {}: {} is missing (a run needs time.csv, gyro-{k}.csv and \
             accel-{k}.csv)",
            run.dir.display(),
            p.file_name().unwrap_or_default().to_string_lossy(),
            k = run.index
        );
    }
    let time = read_columns(&time_path, ["time"], [TIME_UNITS])?;
    let gyro = read_columns(
        &gyro_path,
        ["gyro_x", "gyro_y", "gyro_z"],
        [&[("deg/s", core::f64::consts::PI / 180.0), ("rad/s", 1.0)]; 3],
    )?;
    let accel = read_columns(
        &accel_path,
        ["accel_x", "accel_y", "accel_z"],
        [&[("m/s^2", 1.0), ("m/s2", 1.0)]; 3],
    )?;
    ensure!(
        time.len() == gyro.len() && time.len() == accel.len(),
        "gnss-ins-sim folder {}: {} rows in time.csv, {} in {}, {} in {}: one row per epoch in each",
        run.dir.display(),
        time.len(),
        gyro.len(),
        gyro_path.display(),
        accel.len(),
        accel_path.display()
    );
    ensure!(
        time.len() >= 2,
        "gnss-ins-sim folder {}: {} epochs; at least 2 are needed for one increment",
        run.dir.display(),
        time.len()
    );
    let t_ns = time
        .iter()
        .enumerate()
        .map(|(k, [t])| {
            seconds_to_ns(*t).ok_or_else(|| {
                anyhow!(
                    "{}: line {}: time {t} s is not a finite, non-negative time",
                    time_path.display(),
                    k + 2
                )
            })
        })
        .collect::<Result<Vec<u64>>>()?;
    let records: Vec<Record> = (1..time.len())
        .map(|k| {
            let dt = time[k][0] - time[k - 1][0];
            let held = |w: &[f64; 3]| w.map(|x| (x * dt) as f32);
            Record {
                t_ns: t_ns[k],
                gyro: held(&gyro[k - 1]),
                accel: held(&accel[k - 1]),
                temperature_c: f32::NAN,
            }
        })
        .collect();
    let (rate_hz, _) = rate_from_times(&t_ns)
        .with_context(|| format!("gnss-ins-sim folder {}", run.dir.display()))?;
    if records.len() > u32::MAX as usize {
        bail!("gnss-ins-sim folder {}: too many epochs", run.dir.display());
    }
    Ok(Recording {
        kind: Kind::Increments,
        rate_hz,
        t0_ns: t_ns[0],
        records,
    })
}

/// The 1-sigma a GNSS file without its own is read with: position north, east, down [m], and
/// optionally velocity [m/s] (without it the fixes' velocity is left out).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AssumedSigma {
    /// Position 1-sigma north, east, down [m].
    pub position_ned_m: [f64; 3],
    /// Velocity 1-sigma north, east, down [m/s]; `None`: positions only.
    pub velocity_ned_m_s: Option<[f64; 3]>,
}

impl AssumedSigma {
    /// Refuses a sigma that is not a positive finite number.
    pub fn check(&self) -> Result<()> {
        let all = self
            .position_ned_m
            .iter()
            .chain(self.velocity_ned_m_s.iter().flatten());
        for x in all {
            ensure!(
                x.is_finite() && *x > 0.0,
                "a GNSS 1-sigma must be a positive finite number, not {x}"
            );
        }
        Ok(())
    }
}

/// True when a file's first line is gnss-ins-sim's GPS header.
pub fn looks_like_gps(first_line: &str) -> bool {
    first_line.starts_with("gps_lat (")
}

/// The GPS fixes of gnss-ins-sim's `gps-K.csv` at `path` (module docs), with `assumed` as
/// their 1-sigma.
pub fn read_gps(path: &Path, assumed: &AssumedSigma) -> Result<Vec<crate::gnss::GnssFix>> {
    assumed.check()?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let time_path = dir.join("gps_time.csv");
    ensure!(
        time_path.is_file(),
        "{}: gnss-ins-sim's gps_time.csv is not beside it (the fixes' times)",
        path.display()
    );
    let time = read_columns(&time_path, ["gps_time"], [TIME_UNITS])?;
    let gps = read_columns(
        path,
        [
            "gps_lat", "gps_lon", "gps_alt", "gps_vN", "gps_vE", "gps_vD",
        ],
        [
            ANGLE_UNITS,
            ANGLE_UNITS,
            METRES,
            SPEED_UNITS,
            SPEED_UNITS,
            SPEED_UNITS,
        ],
    )?;
    ensure!(
        time.len() == gps.len(),
        "{}: {} rows, {} in gps_time.csv: one row per fix in each",
        path.display(),
        gps.len(),
        time.len()
    );
    ensure!(!gps.is_empty(), "{}: no fix", path.display());
    let visible = read_visibility(&dir, gps.len())?;
    let mut previous: Option<f64> = None;
    let fixes: Vec<crate::gnss::GnssFix> = time
        .iter()
        .zip(&gps)
        .enumerate()
        .map(|(k, ([t], row))| {
            ensure!(
                seconds_to_ns(*t).is_some() && previous.is_none_or(|p| *t > p),
                "{}: line {}: time {t} s is not finite, is negative or does not increase",
                time_path.display(),
                k + 2
            );
            previous = Some(*t);
            ensure!(
                row[0].is_nan() || row[0].abs() <= core::f64::consts::FRAC_PI_2,
                "{}: line {}: latitude beyond 90 deg",
                path.display(),
                k + 2
            );
            // Refused, not wrapped, as the other GNSS readers do.
            ensure!(
                row[1].is_nan() || row[1].abs() <= core::f64::consts::PI,
                "{}: line {}: longitude beyond 180 deg",
                path.display(),
                k + 2
            );
            Ok(crate::gnss::GnssFix {
                t_s: *t,
                lat_rad: row[0],
                lon_rad: row[1],
                h_m: row[2],
                sigma_ned_m: assumed.position_ned_m,
                velocity: assumed
                    .velocity_ned_m_s
                    .map(|sigma| crate::gnss::GnssVelocity {
                        v_ned_m_s: [row[3], row[4], row[5]],
                        sigma_ned_m_s: sigma,
                    }),
            })
        })
        .collect::<Result<_>>()?;
    Ok(match visible {
        Some(v) => fixes
            .into_iter()
            .zip(v)
            .filter(|(_, v)| *v)
            .map(|(f, _)| f)
            .collect(),
        None => fixes,
    })
}

/// The visibility flags of `dir/gps_visibility.csv` (module docs), one per fix of `fixes`
/// rows; `None` without the file.
fn read_visibility(dir: &Path, fixes: usize) -> Result<Option<Vec<bool>>> {
    let path = dir.join("gps_visibility.csv");
    if !path.is_file() {
        return Ok(None);
    }
    let flags = read_columns(&path, ["gps_visibility"], [NO_UNIT])?;
    ensure!(
        flags.len() == fixes,
        "{}: {} rows, {fixes} fixes in the GPS file: one flag per fix",
        path.display(),
        flags.len()
    );
    flags
        .iter()
        .enumerate()
        .map(|(k, [x])| {
            ensure!(
                *x == 0.0 || *x == 1.0,
                "{}: line {}: visibility {x} is neither 1 (visible) nor 0 (not)",
                path.display(),
                k + 2
            );
            Ok(*x == 1.0)
        })
        .collect::<Result<_>>()
        .map(Some)
}

/// The reference trajectory of the gnss-ins-sim folder `dir` (module docs), one row per epoch.
pub fn read_truth(dir: &Path) -> Result<Vec<Truth>> {
    let file = |name: &str| {
        let p = dir.join(name);
        ensure!(
            p.is_file(),
            "gnss-ins-sim folder {}: {name} is missing (the reference trajectory needs \
             time.csv, ref_pos.csv, ref_vel.csv and ref_att_euler.csv)",
            dir.display()
        );
        Ok(p)
    };
    let pos_path = file("ref_pos.csv")?;
    let first =
        std::fs::read_to_string(&pos_path).with_context(|| format!("{}", pos_path.display()))?;
    ensure!(
        !first.trim_start().starts_with("ref_pos_x"),
        "{}: positions in gnss-ins-sim's virtual inertial frame (ref_frame=1) are not geodetic; \
         simulate in its NED frame (ref_frame=0) for a reference trajectory",
        pos_path.display()
    );
    let time = read_columns(&file("time.csv")?, ["time"], [TIME_UNITS])?;
    let pos = read_columns(
        &pos_path,
        ["ref_pos_lat", "ref_pos_lon", "ref_pos_alt"],
        [ANGLE_UNITS, ANGLE_UNITS, METRES],
    )?;
    let vel = read_columns(
        &file("ref_vel.csv")?,
        ["ref_vel_x", "ref_vel_y", "ref_vel_z"],
        [SPEED_UNITS; 3],
    )?;
    let att = read_columns(
        &file("ref_att_euler.csv")?,
        ["ref_Yaw", "ref_Pitch", "ref_Roll"],
        [ANGLE_UNITS; 3],
    )?;
    ensure!(
        [pos.len(), vel.len(), att.len()]
            .iter()
            .all(|&n| n == time.len()),
        "gnss-ins-sim folder {}: {} rows in time.csv, {} in ref_pos.csv, {} in ref_vel.csv, {} \
         in ref_att_euler.csv: one row per epoch in each",
        dir.display(),
        time.len(),
        pos.len(),
        vel.len(),
        att.len()
    );
    time.iter()
        .zip(pos.iter().zip(vel.iter().zip(&att)))
        .enumerate()
        .map(|(k, ([t], ([lat, lon, h], (v_b, [yaw, pitch, roll]))))| {
            let values = [
                *t, *lat, *lon, *h, v_b[0], v_b[1], v_b[2], *yaw, *pitch, *roll,
            ];
            ensure!(
                values.iter().all(|x| x.is_finite()) && lat.abs() <= core::f64::consts::FRAC_PI_2,
                "gnss-ins-sim folder {}: epoch {} (line {}): a value is not finite or the \
                 latitude is beyond 90 deg",
                dir.display(),
                k + 1,
                k + 2
            );
            let q_b_ned = from_euler(*roll, *pitch, *yaw);
            Ok(Truth {
                t_s: *t,
                lat: *lat,
                lon: *lon,
                h: *h,
                v_eb_ned: q_b_ned * Vector3::from(*v_b),
                q_b_ned,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(time: &str, gyro: &str, accel: &str) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("time.csv"), time).unwrap();
        std::fs::write(dir.path().join("gyro-0.csv"), gyro).unwrap();
        std::fs::write(dir.path().join("accel-0.csv"), accel).unwrap();
        dir
    }

    const TIME: &str = "time (sec)\n0\n0.01\n0.02\n";
    const GYRO: &str = "gyro_x (deg/s),gyro_y (deg/s),gyro_z (deg/s)\n0,0,10\n0,0,20\n0,0,20\n";
    const ACCEL: &str =
        "accel_x (m/s^2),accel_y (m/s^2),accel_z (m/s^2)\n1,0,-9.8\n3,0,-9.8\n3,0,-9.8\n";

    /// A row's rates hold over the interval after it; the first epoch starts the first
    /// interval.
    #[test]
    fn rates_become_increments_of_the_interval_after_them() {
        let dir = folder(TIME, GYRO, ACCEL);
        let run = locate(dir.path()).unwrap();
        assert_eq!(run.index, 0);
        let r = read(&run).unwrap();
        assert_eq!(r.records.len(), 2);
        assert_eq!(r.t0_ns, 0);
        assert_eq!(r.records[0].t_ns, 10_000_000);
        assert!((r.rate_hz - 100.0).abs() < 1e-9);
        let dz = f64::from(r.records[0].gyro[2]);
        assert!((dz - 10f64.to_radians() * 0.01).abs() < 1e-9, "{dz}");
        assert!((f64::from(r.records[0].accel[0]) - 0.01).abs() < 1e-7);
        assert!((f64::from(r.records[1].accel[0]) - 0.03).abs() < 1e-7);
        assert!((f64::from(r.records[1].accel[2]) + 0.098).abs() < 1e-7);
        // Any of the files stands for the folder.
        assert_eq!(locate(&dir.path().join("accel-0.csv")), Some(run.clone()));
        assert_eq!(locate(&dir.path().join("time.csv")), Some(run));
    }

    /// Radians per second are taken as such; an unknown unit or a bad field is refused by
    /// file, line and column.
    #[test]
    fn units_and_bad_fields() {
        let rad = "gyro_x (rad/s),gyro_y (rad/s),gyro_z (rad/s)\n0,0,1\n0,0,1\n0,0,1\n";
        let dir = folder(TIME, rad, ACCEL);
        let r = read(&locate(dir.path()).unwrap()).unwrap();
        assert!((f64::from(r.records[0].gyro[2]) - 0.01).abs() < 1e-9);
        for (gyro, want) in [
            (
                "gyro_x (deg/h),gyro_y (deg/h),gyro_z (deg/h)\n0,0,1\n0,0,1\n0,0,1\n",
                "unit 'deg/h'",
            ),
            ("gyro_x,gyro_y,gyro_z\n0,0,1\n0,0,1\n0,0,1\n", "(unit)"),
            (
                "gyro_x (deg/s),gyro_y (deg/s),gyro_z (deg/s)\n0,0,1\n0,x,1\n0,0,1\n",
                "line 3, column 2: 'x'",
            ),
            (
                "gyro_x (deg/s),gyro_y (deg/s),gyro_z (deg/s)\n0,0,1\n0,0,1\n",
                "3 rows in time.csv, 2 in",
            ),
        ] {
            let dir = folder(TIME, gyro, ACCEL);
            let e = format!("{:#}", read(&locate(dir.path()).unwrap()).unwrap_err());
            assert!(e.contains(want), "{want}: {e}");
        }
        let dir = folder("time (sec)\n0\n-1\n0.02\n", GYRO, ACCEL);
        let e = format!("{:#}", read(&locate(dir.path()).unwrap()).unwrap_err());
        assert!(e.contains("line 3: time -1 s"), "{e}");
    }

    /// The reference trajectory: body velocity turned into NED by the attitude; a virtual
    /// inertial frame is refused.
    #[test]
    fn reference_trajectory() {
        let dir = folder(TIME, GYRO, ACCEL);
        let write = |name: &str, text: &str| std::fs::write(dir.path().join(name), text).unwrap();
        write(
            "ref_pos.csv",
            "ref_pos_lat (deg),ref_pos_lon (deg),ref_pos_alt (m)\n45,7,100\n45,7,100\n45,7,100\n",
        );
        write(
            "ref_vel.csv",
            "ref_vel_x (m/s),ref_vel_y (m/s),ref_vel_z (m/s)\n10,0,0\n10,0,0\n10,0,0\n",
        );
        write(
            "ref_att_euler.csv",
            "ref_Yaw (deg),ref_Pitch (deg),ref_Roll (deg)\n90,0,0\n90,0,0\n90,0,0\n",
        );
        let t = read_truth(dir.path()).unwrap();
        assert_eq!(t.len(), 3);
        assert!((t[1].t_s - 0.01).abs() < 1e-12);
        assert!((t[0].lat - 45f64.to_radians()).abs() < 1e-15);
        // Heading east at 10 m/s along the body's x.
        assert!((t[0].v_eb_ned - Vector3::new(0.0, 10.0, 0.0)).norm() < 1e-9);
        write(
            "ref_pos.csv",
            "ref_pos_x (m),ref_pos_y (m),ref_pos_z (m)\n1,2,3\n1,2,3\n1,2,3\n",
        );
        let e = format!("{:#}", read_truth(dir.path()).unwrap_err());
        assert!(e.contains("virtual inertial frame"), "{e}");
    }

    /// GPS fixes take the stated sigma; without gps_time.csv, with a bad sigma or a time that
    /// does not increase they are refused.
    #[test]
    fn gps_fixes() {
        let dir = tempfile::tempdir().unwrap();
        let gps = dir.path().join("gps-0.csv");
        std::fs::write(
            &gps,
            "gps_lat (deg),gps_lon (deg),gps_alt (m),gps_vN (m/s),gps_vE (m/s),gps_vD (m/s)\n\
             45,7,100,1,2,3\n45.1,7,100,1,2,3\n",
        )
        .unwrap();
        let assumed = AssumedSigma {
            position_ned_m: [5.0, 5.0, 7.0],
            velocity_ned_m_s: Some([0.05; 3]),
        };
        let e = format!("{:#}", read_gps(&gps, &assumed).unwrap_err());
        assert!(e.contains("gps_time.csv is not beside it"), "{e}");
        std::fs::write(dir.path().join("gps_time.csv"), "gps_time (sec)\n0\n1\n").unwrap();
        let f = read_gps(&gps, &assumed).unwrap();
        assert_eq!(f.len(), 2);
        assert_eq!(f[1].t_s, 1.0);
        assert!((f[1].lat_rad - 45.1f64.to_radians()).abs() < 1e-15);
        assert_eq!(f[0].sigma_ned_m, [5.0, 5.0, 7.0]);
        assert_eq!(f[0].velocity.unwrap().v_ned_m_s, [1.0, 2.0, 3.0]);
        let positions_only = AssumedSigma {
            velocity_ned_m_s: None,
            ..assumed
        };
        assert!(
            read_gps(&gps, &positions_only).unwrap()[0]
                .velocity
                .is_none()
        );
        let bad = AssumedSigma {
            position_ned_m: [5.0, 0.0, 7.0],
            ..assumed
        };
        let e = format!("{:#}", read_gps(&gps, &bad).unwrap_err());
        assert!(e.contains("positive finite"), "{e}");
        std::fs::write(dir.path().join("gps_time.csv"), "gps_time (sec)\n1\n1\n").unwrap();
        let e = format!("{:#}", read_gps(&gps, &assumed).unwrap_err());
        assert!(e.contains("line 3: time 1 s"), "{e}");
        // A longitude beyond 180 deg (367 for 7) was wrapped without a word.
        std::fs::write(dir.path().join("gps_time.csv"), "gps_time (sec)\n0\n1\n").unwrap();
        std::fs::write(
            &gps,
            "gps_lat (deg),gps_lon (deg),gps_alt (m),gps_vN (m/s),gps_vE (m/s),gps_vD (m/s)\n\
             45,7,100,1,2,3\n45.1,367,100,1,2,3\n",
        )
        .unwrap();
        let e = format!("{:#}", read_gps(&gps, &assumed).unwrap_err());
        assert!(e.contains("line 3: longitude beyond 180 deg"), "{e}");
    }

    /// A fix gnss-ins-sim flags as not visible is left out (an outage); a bad flag or a count
    /// other than the fixes' refuses the file.
    #[test]
    fn gps_visibility_makes_outages() {
        let dir = tempfile::tempdir().unwrap();
        let gps = dir.path().join("gps-0.csv");
        std::fs::write(
            &gps,
            "gps_lat (deg),gps_lon (deg),gps_alt (m),gps_vN (m/s),gps_vE (m/s),gps_vD (m/s)\n\
             45,7,100,1,2,3\n45.1,7,100,1,2,3\n45.2,7,100,1,2,3\n",
        )
        .unwrap();
        std::fs::write(dir.path().join("gps_time.csv"), "gps_time (sec)\n0\n1\n2\n").unwrap();
        let assumed = AssumedSigma {
            position_ned_m: [5.0, 5.0, 7.0],
            velocity_ned_m_s: None,
        };
        let visibility = dir.path().join("gps_visibility.csv");
        // As gnss-ins-sim's numpy writes it.
        std::fs::write(
            &visibility,
            "gps_visibility ()\n1.000000000000000000e+00\n0.000000000000000000e+00\n\
             1.000000000000000000e+00\n",
        )
        .unwrap();
        let f = read_gps(&gps, &assumed).unwrap();
        assert_eq!(f.iter().map(|f| f.t_s).collect::<Vec<_>>(), [0.0, 2.0]);
        for (text, expected) in [
            (
                "gps_visibility ()\n1\n0.5\n1\n",
                "line 3: visibility 0.5 is neither",
            ),
            (
                "gps_visibility ()\n1\nnan\n1\n",
                "line 3: visibility NaN is neither",
            ),
            (
                "gps_visibility ()\n1\n1\n",
                "2 rows, 3 fixes in the GPS file",
            ),
            ("gps_visibility (m)\n1\n1\n1\n", "unit 'm' is not one of"),
        ] {
            std::fs::write(&visibility, text).unwrap();
            let e = format!("{:#}", read_gps(&gps, &assumed).unwrap_err());
            assert!(e.contains(expected), "{text:?}: {e}");
        }
    }

    /// A folder without the files is not a run; a missing accelerometer file is named.
    #[test]
    fn incomplete_folders() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(locate(dir.path()), None);
        std::fs::write(dir.path().join("time.csv"), TIME).unwrap();
        std::fs::write(dir.path().join("gyro-0.csv"), GYRO).unwrap();
        assert_eq!(locate(dir.path()), None);
        let run = locate(&dir.path().join("gyro-0.csv")).unwrap();
        let e = format!("{:#}", read(&run).unwrap_err());
        assert!(e.contains("accel-0.csv is missing"), "{e}");
    }
}
