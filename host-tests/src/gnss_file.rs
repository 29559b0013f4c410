//! GNSS fix files as the navigator takes them: the text formats ([`crate::gnss`]: the
//! project's CSV, KF-GINS's text) and the binary fix file the firmware reads
//! ([`hal_adapters::gnss_record`], `docs/gnss-record-format.md`), read into nav-core's
//! [`GnssFixInput`]s on the IMU recording's clock; and the binary file written from any of
//! them ([`write_record_file`], [`convert`]).
//!
//! A text fix becomes a [`GnssFixInput`] through [`crate::aided::fix_input`] (its time tag
//! rounded to the microsecond); the binary file stores exactly that fix in `f64`, so the
//! firmware reading it and the harness reading the text navigate the same values.

use crate::aided::fix_input;
use crate::atomic;
use crate::gnss::{self, GnssFix};
use crate::text_error::told_as;
use anyhow::{Context, Result, anyhow, bail};
use hal_adapters::gnss_record::{self, GnssReader, GnssRecord};
use nav_core::Scalar;
use nav_core::Vector3;
use nav_core::ins_filter::sequencer::GnssFixInput;
use nav_core::ins_filter::{GnssPosition, GnssVelocity};
use std::io::{Read, Write};
use std::path::Path;

/// The fixes of a file, in `f64` ([`narrow`] gives them in the run's precision).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GnssFixes {
    /// The fixes, in the file's order (a time not later than the previous fix's is the
    /// navigator's to skip and count, [`gnss`] module docs).
    pub fixes: Vec<GnssFixInput<f64>>,
    /// Fixes of a text file whose time tag is not a time on the IMU clock (left out).
    pub bad_time_tags: u32,
}

/// The largest receiver output latency a run may declare [s] (`--gnss-latency`): receivers'
/// are tens to hundreds of milliseconds; a second is a wrong unit or clock.
pub const MAX_GNSS_LATENCY_S: f64 = 1.0;

/// The fixes' time tags less a receiver's output latency `latency_s` [s] (its fixes tagged that
/// long after the epoch they were measured at, as a logger that tags them on arrival does):
/// each fix is taken at its measurement epoch. A fix tagged before the latency has no epoch
/// on the clock: left out and counted as a bad time tag. Refuses a latency outside `[0,`
/// [`MAX_GNSS_LATENCY_S`]`]` ([`check_latency`]).
pub fn at_measurement_epochs(fixes: &mut GnssFixes, latency_s: f64) -> Result<()> {
    check_latency(latency_s)?;
    let latency_us = (latency_s * 1e6).round() as u64;
    let before = fixes.fixes.len();
    fixes
        .fixes
        .retain_mut(|f| match f.t_us.checked_sub(latency_us) {
            Some(t_us) => {
                f.t_us = t_us;
                true
            }
            None => false,
        });
    let dropped = before - fixes.fixes.len();
    fixes.bad_time_tags = fixes.bad_time_tags.saturating_add(dropped as u32);
    Ok(())
}

/// Refuses a receiver latency `latency_s` [s] outside `[0,` [`MAX_GNSS_LATENCY_S`]`]`.
pub fn check_latency(latency_s: f64) -> Result<()> {
    if !(0.0..=MAX_GNSS_LATENCY_S).contains(&latency_s) {
        bail!(
            "--gnss-latency must be within 0 to {MAX_GNSS_LATENCY_S} s (the receiver's output \
             latency), not {}",
            nav_core::number::Number(latency_s)
        );
    }
    Ok(())
}

/// Refuses a GNSS file that is the IMU recording itself (the same file under any name): a
/// KF-GINS IMU file has the 7 columns of its GNSS file and read as fixes at latitude 0 with
/// negative 1-sigmas, every one refused by the filter, a free-inertial run. A gnss-ins-sim
/// output folder holds both and may be given for both.
pub fn refuse_the_imu_recording(gnss: &Path, imu: &Path) -> Result<()> {
    if gnss.is_file()
        && let (Ok(g), Ok(i)) = (gnss.canonicalize(), imu.canonicalize())
        && g == i
    {
        bail!(
            "the GNSS file {} is the IMU recording {}: give the receiver's fixes",
            gnss.display(),
            imu.display()
        );
    }
    Ok(())
}

/// True when `path` starts like a binary fix file ([`gnss_record::MAGIC`]).
pub fn is_record_file(path: &Path) -> Result<bool> {
    crate::text_error::refuse_a_stream(path).map_err(|e| anyhow!("GNSS file {e}"))?;
    let mut head = [0_u8; 8];
    let mut file = std::fs::File::open(path)
        .with_context(|| format!("cannot open the GNSS file {}", path.display()))?;
    let mut n = 0;
    while n < head.len() {
        match file.read(&mut head[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n == head.len() && head == gnss_record::MAGIC)
}

/// Reads a GNSS file of any format: binary ([`gnss_record`]) when it starts with its magic,
/// text otherwise ([`gnss::read_gnss_assuming`], `assumed` the 1-sigma of a gnss-ins-sim GPS
/// file). Errors name the file (and the line, or the byte offset and fix).
pub fn read_fixes(path: &Path, assumed: Option<&gnss::AssumedSigma>) -> Result<GnssFixes> {
    let in_file = || format!("GNSS file {}", path.display());
    if path.is_dir() || !is_record_file(path)? {
        let text =
            gnss::read_gnss_assuming(path, assumed).map_err(|e| told_as(e, path, in_file()))?;
        let mut out = GnssFixes::default();
        for f in &text {
            match fix_input::<f64>(f) {
                Some(fix) => out.fixes.push(fix),
                None => out.bad_time_tags += 1,
            }
        }
        return Ok(out);
    }
    let file = std::fs::File::open(path)
        .with_context(|| format!("cannot open the GNSS file {}", path.display()))?;
    let bytes = hal_adapters::io::StdReader::new(std::io::BufReader::new(file));
    let mut reader = GnssReader::new(bytes)
        .map_err(|e| anyhow!("{e}"))
        .with_context(in_file)?;
    let mut out = GnssFixes::default();
    while let Some(r) = reader
        .next_fix()
        .map_err(|e| anyhow!("{e}"))
        .with_context(in_file)?
    {
        out.fixes.push(fix_of_record(&r));
    }
    Ok(out)
}

/// Reads a GNSS file of any format ([`read_fixes`]) as text fixes, for the runs that take
/// those (a given start, a start in motion): a binary record's fix, taken back to the text
/// form, goes through [`fix_input`] to the same fix. Errors name the file.
pub fn read_as_text_fixes(
    path: &Path,
    assumed: Option<&gnss::AssumedSigma>,
) -> Result<Vec<GnssFix>> {
    if path.is_dir() || !is_record_file(path)? {
        return gnss::read_gnss_assuming(path, assumed)
            .map_err(|e| told_as(e, path, format!("GNSS file {}", path.display())));
    }
    Ok(read_fixes(path, assumed)?
        .fixes
        .iter()
        .map(|f| GnssFix {
            t_s: f.t_us as f64 * 1e-6,
            lat_rad: f.position.lat_rad,
            lon_rad: f.position.lon_rad,
            h_m: f.position.h_m,
            sigma_ned_m: f.position.sigma_ned_m.into(),
            velocity: f.velocity.map(|v| gnss::GnssVelocity {
                v_ned_m_s: v.v_ned_m_s.into(),
                sigma_ned_m_s: v.sigma_ned_m_s.into(),
            }),
        })
        .collect())
}

/// nav-core's fix of a binary record (the firmware's conversion, in `f64`).
pub fn fix_of_record(r: &GnssRecord) -> GnssFixInput<f64> {
    GnssFixInput {
        t_us: r.t_us,
        position: GnssPosition {
            lat_rad: r.lat_rad,
            lon_rad: r.lon_rad,
            h_m: r.h_m,
            sigma_ned_m: Vector3::from(r.sigma_ned_m),
        },
        velocity: r.velocity.map(|(v, s)| GnssVelocity {
            v_ned_m_s: Vector3::from(v),
            sigma_ned_m_s: Vector3::from(s),
        }),
    }
}

/// A fix in the run's precision `T` (the 1-sigmas and the velocity rounded as
/// [`fix_input::<T>`](fix_input) rounds them; the place stays `f64`).
pub fn narrow<T: Scalar>(f: &GnssFixInput<f64>) -> GnssFixInput<T> {
    GnssFixInput {
        t_us: f.t_us,
        position: GnssPosition {
            lat_rad: f.position.lat_rad,
            lon_rad: f.position.lon_rad,
            h_m: f.position.h_m,
            sigma_ned_m: f.position.sigma_ned_m.map(T::c),
        },
        velocity: f.velocity.map(|v| GnssVelocity {
            v_ned_m_s: v.v_ned_m_s.map(T::c),
            sigma_ned_m_s: v.sigma_ned_m_s.map(T::c),
        }),
    }
}

/// The binary record of a fix.
fn record_of(f: &GnssFixInput<f64>) -> GnssRecord {
    let v3 = |v: &Vector3<f64>| [v.x, v.y, v.z];
    GnssRecord {
        t_us: f.t_us,
        lat_rad: f.position.lat_rad,
        lon_rad: f.position.lon_rad,
        h_m: f.position.h_m,
        sigma_ned_m: v3(&f.position.sigma_ned_m),
        velocity: f.velocity.map(|v| (v3(&v.v_ned_m_s), v3(&v.sigma_ned_m_s))),
    }
}

/// Writes `fixes` as a binary fix file at `path`, atomically ([`atomic::write`]). Refused: a
/// fix whose time tag is not on the IMU clock.
pub fn write_record_file(path: &Path, fixes: &[GnssFix]) -> Result<()> {
    write_inputs(path, &record_inputs(fixes)?)
}

/// The fixes as the binary file stores them, in their order (one not later than the previous
/// is the navigator's to skip and count). Refused: a fix whose time tag is not on the IMU
/// clock.
fn record_inputs(fixes: &[GnssFix]) -> Result<Vec<GnssFixInput<f64>>> {
    let mut inputs = Vec::with_capacity(fixes.len());
    for (i, f) in fixes.iter().enumerate() {
        let fix = fix_input::<f64>(f).ok_or_else(|| {
            anyhow!(
                "fix {i}: time {} s is not a time on the IMU recording's clock",
                f.t_s
            )
        })?;
        inputs.push(fix);
    }
    Ok(inputs)
}

/// Writes `inputs` as a binary fix file at `path`, atomically ([`atomic::write`]).
fn write_inputs(path: &Path, inputs: &[GnssFixInput<f64>]) -> Result<()> {
    let count = u32::try_from(inputs.len()).context("more than 2^32 fixes")?;
    atomic::write(path, |w| -> Result<()> {
        w.write_all(&gnss_record::encode_header(count))?;
        for f in inputs {
            w.write_all(&record_of(f).encode())?;
        }
        Ok(())
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// Converts a GNSS text file (the project's CSV or KF-GINS's text, or gnss-ins-sim's GPS file
/// with the 1-sigma `assumed`) into the binary fix file the firmware reads; returns the number
/// of fixes.
pub fn convert(input: &Path, output: &Path, assumed: Option<&gnss::AssumedSigma>) -> Result<usize> {
    convert_at_epochs(input, output, assumed, 0.0).map(|(n, _)| n)
}

/// [`convert`], each fix taken at its measurement epoch, its tag less the receiver's output
/// latency `latency_s` [s] ([`at_measurement_epochs`]: the firmware reads the file as it
/// is); returns the number of fixes written and of fixes tagged before the latency (left out).
pub fn convert_at_epochs(
    input: &Path,
    output: &Path,
    assumed: Option<&gnss::AssumedSigma>,
    latency_s: f64,
) -> Result<(usize, u32)> {
    check_latency(latency_s)?;
    // The output is binary: a text file's name would hide it.
    if let Some(ext) = output.extension().and_then(|e| e.to_str())
        && ["csv", "txt", "pos", "nav"].contains(&ext.to_ascii_lowercase().as_str())
    {
        bail!(
            "{}: the binary fix file would carry a text file's name (.{ext}); name it .bin",
            output.display()
        );
    }
    atomic::refuse_same_file(&[input], output)?;
    let fixes = gnss::read_gnss_assuming(input, assumed)
        .map_err(|e| told_as(e, input, format!("GNSS file {}", input.display())))?;
    let mut fixes = GnssFixes {
        fixes: record_inputs(&fixes)?,
        bad_time_tags: 0,
    };
    at_measurement_epochs(&mut fixes, latency_s)?;
    write_inputs(output, &fixes.fixes)?;
    Ok((fixes.fixes.len(), fixes.bad_time_tags))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gnss::GnssVelocity as TextVelocity;

    #[test]
    fn a_text_name_for_the_binary_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("gnss.csv");
        let out = dir.path().join("fixes.CSV");
        let e = convert(&input, &out, None).unwrap_err().to_string();
        assert!(e.contains("name it .bin"), "{e}");
        assert!(!out.exists());
    }

    fn fixes() -> Vec<GnssFix> {
        (1..=5)
            .map(|k| GnssFix {
                t_s: 1.25 * f64::from(k) + 0.000_000_4,
                lat_rad: 45.123_456_789_f64.to_radians(),
                lon_rad: (-7.5_f64).to_radians(),
                h_m: 250.5 + f64::from(k),
                sigma_ned_m: [0.5, 0.5, 1.0],
                velocity: (k % 2 == 0).then_some(TextVelocity {
                    v_ned_m_s: [10.0, -0.3, 0.01],
                    sigma_ned_m_s: [0.05, 0.05, f64::NAN],
                }),
            })
            .collect()
    }

    /// The fixes' binary records (bit for bit, a NaN sigma included).
    fn encoded(f: &GnssFixes) -> Vec<[u8; 112]> {
        f.fixes.iter().map(|f| record_of(f).encode()).collect()
    }

    #[test]
    fn text_and_binary_files_give_the_same_fixes() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("gnss.csv");
        let bin = dir.path().join("gnss.bin");
        gnss::write_gnss_csv(&csv, &fixes()).unwrap();
        assert_eq!(convert(&csv, &bin, None).unwrap(), 5);
        assert!(is_record_file(&bin).unwrap() && !is_record_file(&csv).unwrap());
        let (a, b) = (
            read_fixes(&csv, None).unwrap(),
            read_fixes(&bin, None).unwrap(),
        );
        assert_eq!(a.fixes.len(), 5);
        assert_eq!(a.bad_time_tags, 0);
        // Bit for bit (a NaN sigma included): compare the records.
        assert_eq!(encoded(&a), encoded(&b));
        assert_eq!(b.fixes[0].t_us, 1_250_000);
        assert!(b.fixes[1].velocity.is_some() && b.fixes[0].velocity.is_none());
        // In f32 as fix_input gives them (compared as text: the NaN sigma is not equal to
        // itself).
        let f32_fix = narrow::<f32>(&b.fixes[1]);
        assert_eq!(
            format!("{:?}", Some(f32_fix)),
            format!("{:?}", fix_input::<f32>(&fixes()[1]))
        );
    }

    /// A binary file written for a receiver's latency holds the fixes the replay takes from
    /// the text with `--gnss-latency`, bit for bit: one rule ([`at_measurement_epochs`]) for
    /// the firmware's file and the harness. A fix tagged before the latency is left out.
    #[test]
    fn a_file_written_at_the_measurement_epochs_holds_what_the_replay_takes() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("gnss.csv");
        let bin = dir.path().join("gnss.bin");
        gnss::write_gnss_csv(&csv, &fixes()).unwrap();
        assert_eq!(convert_at_epochs(&csv, &bin, None, 0.2).unwrap(), (5, 0));
        let mut text = read_fixes(&csv, None).unwrap();
        at_measurement_epochs(&mut text, 0.2).unwrap();
        let binary = read_fixes(&bin, None).unwrap();
        assert_eq!(encoded(&binary), encoded(&text));
        assert_eq!(binary.fixes[0].t_us, 1_050_000);
        let mut early = fixes();
        early[0].t_s = 0.1;
        gnss::write_gnss_csv(&csv, &early).unwrap();
        assert_eq!(convert_at_epochs(&csv, &bin, None, 0.2).unwrap(), (4, 1));
        assert_eq!(read_fixes(&bin, None).unwrap().fixes[0].t_us, 2_300_000);
        let e = convert_at_epochs(&csv, &bin, None, 1.5).unwrap_err();
        assert!(
            e.to_string().contains("--gnss-latency must be within"),
            "{e}"
        );
    }

    /// The given start and the start in motion take text fixes: a binary file gives them the
    /// same fixes as its text (was: refused as a GNSS file with an unknown header, while the
    /// run after an alignment took it).
    #[test]
    fn a_binary_file_reads_as_the_same_text_fixes() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("gnss.csv");
        let bin = dir.path().join("gnss.bin");
        gnss::write_gnss_csv(&csv, &fixes()).unwrap();
        convert(&csv, &bin, None).unwrap();
        let (a, b) = (
            read_as_text_fixes(&csv, None).unwrap(),
            read_as_text_fixes(&bin, None).unwrap(),
        );
        assert_eq!(a.len(), 5);
        let inputs = |f: &[GnssFix]| -> Vec<String> {
            f.iter()
                .map(|f| format!("{:?}", fix_input::<f64>(f)))
                .collect()
        };
        assert_eq!(inputs(&a), inputs(&b));
    }

    #[test]
    fn bad_files_and_fixes_are_refused_with_the_place() {
        let dir = tempfile::tempdir().unwrap();
        let bin = dir.path().join("gnss.bin");
        let mut f = fixes();
        f[3].t_s = -1.0;
        let e = write_record_file(&bin, &f).unwrap_err();
        assert!(format!("{e:#}").contains("fix 3: time"), "{e:#}");
        assert!(!bin.exists());
        // A repeated time is written and read back: the navigator skips and counts it.
        f[3].t_s = f[2].t_s;
        write_record_file(&bin, &f).unwrap();
        let times: Vec<u64> = read_fixes(&bin, None)
            .unwrap()
            .fixes
            .iter()
            .map(|f| f.t_us)
            .collect();
        assert_eq!(times[2], times[3]);
        write_record_file(&bin, &fixes()).unwrap();
        let mut bytes = std::fs::read(&bin).unwrap();
        bytes[32 + 112 * 2 + 9] ^= 0x10;
        std::fs::write(&bin, &bytes).unwrap();
        let e = read_fixes(&bin, None).unwrap_err();
        assert_eq!(
            format!("{e:#}"),
            format!(
                "GNSS file {}: GNSS byte offset 256 (fix 2): record CRC mismatch (corrupt data)",
                bin.display()
            )
        );
        std::fs::write(&bin, &bytes[..100]).unwrap();
        let e = read_fixes(&bin, None).unwrap_err();
        assert!(format!("{e:#}").contains("truncated"), "{e:#}");
    }
}
