//! Recordings on disk: format detection, the common in-memory form, the binary writer and the
//! replay sources.
//!
//! Every format can be read into a [`Recording`] (the binary format's header values and records),
//! or converted to the binary or CSV format without holding it in memory ([`convert`]: two
//! passes, a check that finds the header, then the records streamed into the output). For a
//! replay, binary files are read straight from disk by [`Replay`]; CSV, PSINS and KF-GINS
//! files are read from disk too, one line at a time, each record encoded into the binary format
//! as the replay reads it ([`text_recording`]), so the sample flags and the measured `dt` come
//! from the same code whatever the input format, in memory independent of the file's length.
//!
//! Conversion of timed increments to the binary format: `t_ns = round(t_s * 1e9)` (the end of each
//! interval); the nominal rate is `1 / median interval` over the first
//! [`RATE_PREFIX_RECORDS`] records (CSV, KF-GINS) or the PSINS header's; the header's `t0_ns`
//! (start of the first interval) is `t_ns[0] - round(nominal period)`, or the PSINS `t0`.

use crate::psins::PsinsHeader;
use crate::text_error::{MAX_TIME_S, seconds_to_ns};
use crate::text_recording::{
    self, HeaderScan, RATE_PREFIX_RECORDS, TextRecords, TextReplay, rate_from_times,
};
use crate::{gnss_ins_sim, imu_csv, kf_gins, psins};
use anyhow::{Context, Result, anyhow, bail, ensure};
use core::convert::Infallible;
use hal_adapters::io::StdReader;
use hal_adapters::recording::{
    FormatError, HEADER_LEN, Header, Kind, MAGIC, RECORD_LEN, Record, Replay, ReplayError,
    ReplayStats,
};
use hal_adapters::{Imu, ImuSample};
use nav_core::gap::GapDetector;
use nav_core::increment::{ImuIncrement, InputLimits};
use std::fs::File;
use std::io::{BufReader, Read, Write};
use std::path::Path;

/// A recording file's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// The project's binary format (`hal_adapters::recording`).
    Binary,
    /// The CSV increment format ([`imu_csv`]).
    Csv,
    /// PSINS `.imu` text ([`psins`]).
    Psins,
    /// KF-GINS IMU text ([`kf_gins`]).
    KfGins,
    /// A gnss-ins-sim output folder, or one of its IMU files ([`gnss_ins_sim`]).
    GnssInsSim,
}

impl core::fmt::Display for Format {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Binary => "binary",
            Self::Csv => "CSV",
            Self::Psins => "PSINS",
            Self::KfGins => "KF-GINS",
            Self::GnssInsSim => "gnss-ins-sim",
        })
    }
}

/// Detects the format of `path`: by the binary magic bytes, the CSV header (`t_s,...`), a PSINS
/// `%` comment on the first line, or a first line of 7 (or 8) numbers (KF-GINS); failing those, by
/// the extension (`.bin`, `.csv`, `.imu`, `.txt` for KF-GINS), so a damaged file still gets the
/// format's own error message. A KF-GINS GNSS file given as a recording is refused by name. A
/// folder is a gnss-ins-sim output folder or refused; so is a file with one of its headers.
pub fn detect(path: &Path) -> Result<Format> {
    crate::text_error::refuse_a_stream(path).map_err(|e| anyhow!("recording {e}"))?;
    if path.is_dir() {
        ensure!(
            gnss_ins_sim::locate(path).is_some(),
            "recording {}: a folder, and not a gnss-ins-sim output folder (time.csv, gyro-0.csv, \
             accel-0.csv): give a recording file",
            path.display()
        );
        return Ok(Format::GnssInsSim);
    }
    let mut head = Vec::with_capacity(256);
    File::open(path)
        .and_then(|f| f.take(256).read_to_end(&mut head))
        .with_context(|| format!("recording {}", path.display()))?;
    if head.starts_with(&MAGIC) {
        return Ok(Format::Binary);
    }
    let text = String::from_utf8_lossy(&head);
    let first = text.trim_start_matches('\u{feff}').trim_start();
    if first.starts_with("t_s,") || first.starts_with("t_s\n") {
        return Ok(Format::Csv);
    }
    if first.starts_with('%') {
        return Ok(Format::Psins);
    }
    if gnss_ins_sim::looks_like(first) {
        return Ok(Format::GnssInsSim);
    }
    if kf_gins::looks_like_gnss(first) {
        bail!(
            "recording {}: this is a KF-GINS GNSS file (seconds of week, latitude, longitude, \
             height, 1-sigma north, east, down), not an IMU recording: give it with --gnss",
            path.display()
        );
    }
    if kf_gins::looks_like_imu(first) {
        return Ok(Format::KfGins);
    }
    match format_of_name(path) {
        Some(format) => Ok(format),
        None => bail!(
            "recording {}: unknown format: expected the binary magic {:?}, a CSV header starting \
             with 't_s,', a PSINS file starting with '%', a KF-GINS line of 7 numbers, or the \
             extension .bin, .csv, .imu or .txt",
            path.display(),
            String::from_utf8_lossy(&MAGIC)
        ),
    }
}

/// The format [`detect`] gives a file by its extension (`.bin`, `.csv`, `.imu`, `.txt`, any
/// case), when its content does not tell.
fn format_of_name(path: &Path) -> Option<Format> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "bin" => Some(Format::Binary),
        "csv" => Some(Format::Csv),
        "imu" => Some(Format::Psins),
        "txt" => Some(Format::KfGins),
        _ => None,
    }
}

/// A recording in memory: the binary format's header values and records.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// What the records hold: increments over the interval, or rates at its end.
    pub kind: Kind,
    /// Nominal sampling rate [Hz].
    pub rate_hz: f64,
    /// Start of the first interval [ns] on the recording's clock.
    pub t0_ns: u64,
    /// The records (each timed at the END of its interval).
    pub records: Vec<Record>,
}

impl Recording {
    /// The binary header of this recording.
    pub fn header(&self) -> Result<Header> {
        let sample_count = u32::try_from(self.records.len())
            .context("too many records for the binary format (more than 2^32 - 1)")?;
        let header = Header {
            kind: self.kind,
            rate_hz: self.rate_hz,
            t0_ns: self.t0_ns,
            sample_count,
        };
        header.validate().map_err(|e| anyhow!("{e}"))?;
        Ok(header)
    }

    /// The recording encoded in the binary format.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let mut bytes = Vec::with_capacity(HEADER_LEN + RECORD_LEN * self.records.len());
        bytes.extend_from_slice(&self.header()?.encode());
        for r in &self.records {
            bytes.extend_from_slice(&r.encode());
        }
        Ok(bytes)
    }

    /// Builds a recording of increments from a CSV file's rows (see the module docs).
    pub fn from_csv(csv: &imu_csv::ImuCsv) -> Result<Self> {
        let records = csv
            .rows
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let t_ns = seconds_to_ns(r.t_s).ok_or_else(|| {
                    anyhow!(
                        "row {}: time {} s is not on the recording clock (0 to {MAX_TIME_S} s)",
                        i + 1,
                        r.t_s
                    )
                })?;
                Ok(Record {
                    t_ns,
                    gyro: r.delta_theta_ib_b,
                    accel: r.delta_v_ib_b,
                    temperature_c: r.temperature_c,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Self::timed(records)
    }

    /// A recording of increments `records`, rate and `t0` from their first times (see the
    /// module docs).
    fn timed(records: Vec<Record>) -> Result<Self> {
        let prefix: Vec<u64> = records
            .iter()
            .take(RATE_PREFIX_RECORDS)
            .map(|r| r.t_ns)
            .collect();
        let (rate_hz, t0_ns) = rate_from_times(&prefix)?;
        Ok(Self {
            kind: Kind::Increments,
            rate_hz,
            t0_ns,
            records,
        })
    }

    /// Builds a recording of increments from a PSINS file (see the module docs).
    pub fn from_psins(p: &psins::PsinsRecording) -> Result<Self> {
        let to_f32 = |v: [f64; 3]| v.map(|x| x as f32);
        let records = p
            .samples
            .iter()
            .zip(1_u64..)
            .map(|(s, k)| {
                let t_ns = p.header.sample_end_ns(k).ok_or_else(|| {
                    anyhow!("sample {k}: t0 + {k} * interval is beyond the recording clock")
                })?;
                Ok(Record {
                    t_ns,
                    gyro: to_f32(s.delta_theta_ib_b),
                    accel: to_f32(s.delta_v_ib_b),
                    temperature_c: f32::NAN,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            kind: Kind::Increments,
            rate_hz: p.header.rate_hz(),
            t0_ns: p.header.t0_ns(),
            records,
        })
    }

    /// Builds a recording of increments from a KF-GINS IMU file (as from CSV: rate from the median
    /// interval; increments rounded to f32).
    pub fn from_kf_gins(imu: &kf_gins::KfGinsImu) -> Result<Self> {
        Self::from_csv(&imu.to_imu_csv())
    }

    /// The recording as CSV rows (increments only: CSV has no rates).
    pub fn to_csv(&self) -> Result<imu_csv::ImuCsv> {
        ensure!(
            matches!(self.kind, Kind::Increments),
            "the CSV format holds increments, this recording holds rates"
        );
        let rows = self.records.iter().map(csv_row).collect();
        let has_temperature = self.records.iter().any(|r| !r.temperature_c.is_nan());
        Ok(imu_csv::ImuCsv {
            has_temperature,
            rows,
        })
    }
}

/// Reads any recording file into memory (format from [`detect`]). Errors name the file and the
/// line or byte offset. The records are those [`convert`] writes: a first pass checks the file
/// and finds the header, a second reads the records.
pub fn read(path: &Path) -> Result<Recording> {
    let format = detect(path)?;
    if format == Format::GnssInsSim {
        return read_gnss_ins_sim(path);
    }
    let scanned = scan(path, format)?;
    let mut stream = RecordStream::open(path, format)?;
    let mut records = Vec::new();
    while let Some(r) = stream.next_record()? {
        records.push(r);
    }
    let header = scanned.header;
    Ok(Recording {
        kind: header.kind,
        rate_hz: header.rate_hz,
        t0_ns: header.t0_ns,
        records,
    })
}

/// A gnss-ins-sim folder (or one of its files) read into memory.
fn read_gnss_ins_sim(path: &Path) -> Result<Recording> {
    let run = gnss_ins_sim::locate(path).ok_or_else(|| {
        anyhow!(
            "recording {}: a gnss-ins-sim IMU file, but not named time.csv, gyro-K.csv or \
             accel-K.csv: its run's other files are not found",
            path.display()
        )
    })?;
    gnss_ins_sim::read(&run).with_context(|| format!("recording {}", path.display()))
}

/// What a first pass over a recording file found: the binary header (a text file's is found as
/// a replay finds it, [`text_recording`]) and whether a record has a temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Scanned {
    header: Header,
    has_temperature: bool,
}

/// The first pass over `path` (of `format`): checks every record as a replay does (a binary file
/// through [`Replay`], so truncation and CRC errors read as they do on replay), in memory
/// independent of the file's length.
fn scan(path: &Path, format: Format) -> Result<Scanned> {
    let context = || format!("recording {}", path.display());
    if format == Format::GnssInsSim {
        return Ok(Scanned {
            header: read_gnss_ins_sim(path)?.header()?,
            has_temperature: false,
        });
    }
    let file = File::open(path).with_context(context)?;
    let mut has_temperature = false;
    let header = match format {
        Format::Binary => {
            let reader = StdReader::new(BufReader::new(file));
            let mut replay =
                Replay::new(reader).map_err(|e| in_file(path, SourceError::from(e)))?;
            while let Some(s) = replay
                .read_sample()
                .map_err(SourceError::from)
                .and_then(check_temperature)
                .map_err(|e| in_file(path, e))?
            {
                has_temperature |= !s.temperature_c.is_nan();
            }
            *replay.header()
        }
        _ => {
            let mut records = TextRecords::new(format, BufReader::new(file), path)?;
            let mut scan = HeaderScan::new(&records);
            for r in records.by_ref() {
                let r = r?;
                has_temperature |= !r.temperature_c.is_nan();
                scan.push(&r);
            }
            scan.finish().with_context(context)?
        }
    };
    Ok(Scanned {
        header,
        has_temperature,
    })
}

/// The records of a recording file in file order, each read when asked for: the second pass,
/// after [`scan`] checked the file.
enum RecordStream<'a> {
    /// A binary file after its header: the next record's index.
    Binary(BufReader<File>, u32, &'a Path),
    /// A text file (boxed: its reader is large).
    Text(Box<TextRecords<BufReader<File>>>),
    /// A recording read into memory (gnss-ins-sim's folder of files).
    Memory(std::vec::IntoIter<Record>),
}

impl<'a> RecordStream<'a> {
    /// Opens `path` (of `format`) at its first record.
    fn open(path: &'a Path, format: Format) -> Result<Self> {
        let context = || format!("recording {}", path.display());
        if format == Format::GnssInsSim {
            return Ok(Self::Memory(read_gnss_ins_sim(path)?.records.into_iter()));
        }
        let mut file = BufReader::new(File::open(path).with_context(context)?);
        Ok(match format {
            Format::Binary => {
                file.read_exact(&mut [0u8; HEADER_LEN])
                    .with_context(context)?;
                Self::Binary(file, 0, path)
            }
            _ => Self::Text(Box::new(TextRecords::new(format, file, path)?)),
        })
    }

    /// The next record; `None` at the end of the file.
    fn next_record(&mut self) -> Result<Option<Record>> {
        match self {
            Self::Binary(file, index, path) => {
                let mut bytes = [0u8; RECORD_LEN];
                match file.read(&mut bytes[..1]) {
                    Ok(0) => return Ok(None),
                    Ok(_) => {}
                    Err(e) => return Err(in_file(path, e)),
                }
                file.read_exact(&mut bytes[1..])
                    .map_err(|e| in_file(path, e))?;
                let offset = HEADER_LEN as u64 + RECORD_LEN as u64 * u64::from(*index);
                let r = Record::decode(&bytes, offset, *index).map_err(|e| in_file(path, e))?;
                *index = index.saturating_add(1);
                Ok(Some(r))
            }
            Self::Text(records) => Ok(records.next().transpose()?),
            Self::Memory(records) => Ok(records.next()),
        }
    }
}

/// What [`convert`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Converted {
    /// The input's format.
    pub format: Format,
    /// The header of the recording written (the count, rate, `t0` and kind).
    pub header: Header,
    /// Records carried over as they are although a replay flags them: time not after the
    /// last record a replay navigates (nav-core's rule, `nav_core::gap::GapDetector`: after a
    /// clock's step back every record until it passes the last time again).
    pub time_not_increasing: u64,
    /// ... and a gyro or accelerometer value that is not finite.
    pub not_finite: u64,
    /// ... and a rate or specific force beyond nav-core's plausibility limits
    /// ([`InputLimits`]: beyond any IMU's full scale).
    pub out_of_range: u64,
}

impl Converted {
    /// A warning for the records a replay will flag, if any.
    pub fn warning(&self) -> Option<String> {
        (self.time_not_increasing + self.not_finite + self.out_of_range > 0).then(|| {
            let limits = InputLimits::<f64>::default();
            format!(
                "WARNING: {} records with a time not after the last navigable record's, {} with a \
                 value that is not finite and {} with a rate beyond {:.0} deg/s or a specific \
                 force beyond {:.0} m/s^2 (beyond any IMU's full scale) were converted as they \
                 are; a replay flags or refuses them and does not navigate them",
                self.time_not_increasing,
                self.not_finite,
                self.out_of_range,
                limits.max_rate.to_degrees(),
                limits.max_specific_force
            )
        })
    }

    /// Counts `r` into the warnings, each record once, as a replay flags it; `previous_t_ns`
    /// is the previous record's time (`None` for the first record, whose interval starts at
    /// the header's `t0_ns`), `order` the navigator's time-order rule over the records so far.
    fn check(&mut self, r: &Record, previous_t_ns: Option<u64>, order: &mut GapDetector<f64>) {
        // The replay's sample time (hal-adapters' `Replay`: whole microseconds).
        let t_us = r.t_ns / 1000;
        if order.out_of_order(t_us, 0.0) {
            self.time_not_increasing += 1;
        } else if !r.gyro.iter().chain(&r.accel).all(|x| x.is_finite()) {
            self.not_finite += 1;
        } else if self.beyond_limits(r, previous_t_ns) {
            self.out_of_range += 1;
        } else {
            let wide = |v: &[f32; 3]| v.map(f64::from);
            order.note(
                t_us,
                &ImuIncrement::new(wide(&r.gyro), wide(&r.accel), 1.0 / self.header.rate_hz),
            );
        }
    }

    /// `true` when `r`'s rate or specific force exceeds [`InputLimits`]' default on any axis.
    /// An increment is divided by its measured interval, or by the nominal one when the
    /// measured interval is not positive.
    fn beyond_limits(&self, r: &Record, previous_t_ns: Option<u64>) -> bool {
        let limits = InputLimits::<f64>::default();
        let interval_s = match self.header.kind {
            Kind::Rates => 1.0,
            Kind::Increments => {
                let start_ns = previous_t_ns.unwrap_or(self.header.t0_ns);
                let measured_s = r.t_ns.saturating_sub(start_ns) as f64 * 1e-9;
                if measured_s > 0.0 {
                    measured_s
                } else {
                    1.0 / self.header.rate_hz
                }
            }
        };
        let beyond = |values: &[f32; 3], limit: f64| {
            values
                .iter()
                .any(|&x| f64::from(x).abs() > limit * interval_s)
        };
        beyond(&r.gyro, limits.max_rate) || beyond(&r.accel, limits.max_specific_force)
    }
}

/// Converts the recording `input` (any format, [`detect`]) to `out`: CSV when its name ends in
/// `.csv`, binary otherwise (refused under a PSINS or KF-GINS text name, `.imu`, `.txt`, `.nav`);
/// the same bytes as [`write`] of [`read`]'s recording, in memory
/// independent of the file's length. A first pass checks `input` and finds the header (a text
/// file's count and rate, a binary file's own; whether a record has a temperature, for the CSV
/// header), the second streams the records into `out`. `out` is written whole or not at all
/// ([`crate::atomic`]) and must not be `input`.
pub fn convert(input: &Path, out: &Path) -> Result<Converted> {
    // The output is binary unless named .csv: a text format's name would hide it.
    if let Some(text @ (Format::Psins | Format::KfGins)) = format_of_name(out) {
        bail!(
            "{}: the binary recording would carry a {text} text file's name (.{}); name it .bin \
             (or .csv for the CSV format)",
            out.display(),
            out.extension().unwrap_or_default().to_string_lossy()
        );
    }
    // Nor a KF-GINS trajectory's (`.nav`, text that `nav kf-gins` and `nav report` read).
    if out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("nav"))
    {
        bail!(
            "{}: the binary recording would carry a KF-GINS trajectory's name (.nav); name it \
             .bin (or .csv for the CSV format)",
            out.display()
        );
    }
    let format = detect(input)?;
    crate::atomic::refuse_same_file(&[input], out)?;
    let scanned = scan(input, format)?;
    let header = scanned.header;
    // The reader checks a replay applies (a recording it refuses was converted without a word).
    crate::generate::check_rate(header.rate_hz)
        .with_context(|| format!("recording {}", input.display()))?;
    if format == Format::Binary {
        check_header_rate(input, &header)?;
    }
    let writing = || format!("writing {}", out.display());
    let to_csv = is_csv(out);
    if to_csv {
        ensure!(
            header.kind == Kind::Increments,
            "writing {}: the CSV format holds increments, this recording holds rates",
            out.display()
        );
    }
    let mut converted = Converted {
        format,
        header,
        time_not_increasing: 0,
        not_finite: 0,
        out_of_range: 0,
    };
    crate::atomic::write(out, |w| -> Result<()> {
        let mut records = RecordStream::open(input, format)?;
        let mut written = 0_u64;
        let mut previous_t_ns = None;
        let mut order = GapDetector::<f64>::new();
        let mut next = |records: &mut RecordStream| -> Result<Option<Record>> {
            let r = records.next_record()?;
            if let Some(r) = &r {
                converted.check(r, previous_t_ns, &mut order);
                previous_t_ns = Some(r.t_ns);
            }
            Ok(r)
        };
        if to_csv {
            let mut csv = imu_csv::CsvWriter::new(&mut *w, scanned.has_temperature)?;
            while let Some(r) = next(&mut records)? {
                csv.write_row(&csv_row(&r))?;
                written += 1;
            }
            csv.finish()?;
        } else {
            w.write_all(&header.encode())?;
            while let Some(r) = next(&mut records)? {
                w.write_all(&r.encode())?;
                written += 1;
            }
        }
        ensure!(
            written == u64::from(header.sample_count),
            "recording {}: {written} records on the second reading, {} on the first (the file \
             changed during the conversion)",
            input.display(),
            header.sample_count
        );
        Ok(())
    })
    .with_context(writing)?;
    Ok(converted)
}

/// `true` when `path`'s name ends in `.csv` (any case).
fn is_csv(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
}

/// The CSV row of a record of increments.
fn csv_row(r: &Record) -> imu_csv::CsvRow {
    imu_csv::CsvRow {
        t_s: r.t_ns as f64 / 1e9,
        delta_theta_ib_b: r.gyro,
        delta_v_ib_b: r.accel,
        temperature_c: r.temperature_c,
    }
}

/// An error of the recording `path`: "recording PATH: byte offset ... (record ...): ...".
pub fn in_file(path: &Path, e: impl core::fmt::Display) -> anyhow::Error {
    anyhow!("recording {}: {e}", path.display())
}

/// An infallible reader's replay error is a format error.
fn format_error(e: ReplayError<Infallible>) -> FormatError {
    match e {
        ReplayError::Format(f) => f,
        ReplayError::Io(never) => match never {},
    }
}

/// Writes a binary recording to `path` (created or truncated).
pub fn write_binary(
    path: &Path,
    kind: Kind,
    rate_hz: f64,
    t0_ns: u64,
    records: &[Record],
) -> Result<()> {
    let context = || format!("writing {}", path.display());
    let sample_count = u32::try_from(records.len())
        .context("too many records for the binary format (more than 2^32 - 1)")
        .with_context(context)?;
    let header = Header {
        kind,
        rate_hz,
        t0_ns,
        sample_count,
    };
    header
        .validate()
        .map_err(|e| anyhow!("writing {}: {e}", path.display()))?;
    crate::atomic::write(path, |out| -> std::io::Result<()> {
        out.write_all(&header.encode())?;
        for r in records {
            out.write_all(&r.encode())?;
        }
        Ok(())
    })
    .with_context(context)
}

/// Writes `recording` to `path`: CSV when the name ends in `.csv`, binary otherwise.
pub fn write(path: &Path, recording: &Recording) -> Result<()> {
    if is_csv(path) {
        let csv = recording
            .to_csv()
            .with_context(|| format!("writing {}", path.display()))?;
        Ok(imu_csv::write(path, &csv)?)
    } else {
        let r = recording;
        write_binary(path, r.kind, r.rate_hz, r.t0_ns, &r.records)
    }
}

/// An owned byte buffer read through `embedded_io` (the replay of an in-memory recording).
#[derive(Clone, Debug, Default)]
pub struct MemReader {
    bytes: Vec<u8>,
    pos: usize,
}

impl MemReader {
    /// A reader at the start of `bytes`.
    pub fn new(bytes: Vec<u8>) -> Self {
        Self { bytes, pos: 0 }
    }
}

impl embedded_io::ErrorType for MemReader {
    type Error = Infallible;
}

impl embedded_io::Read for MemReader {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let rest = &self.bytes[self.pos..];
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        self.pos += n;
        Ok(n)
    }
}

/// Error of a [`ReplaySource`]: reading the file failed, or the recording is invalid.
#[derive(Debug)]
pub enum SourceError {
    /// Reading the file failed.
    Io(std::io::Error),
    /// The recording is invalid; `Display` gives e.g. `byte offset 1288 (record 31): record CRC
    /// mismatch (corrupt data)`.
    Format(FormatError),
    /// A binary record's temperature [deg C] is no sensor's
    /// ([`imu_csv::temperature_is_plausible`], the CSV format's rule): the record's index.
    Temperature {
        /// The record's index.
        record: u32,
        /// The temperature [deg C].
        temp_c: f32,
    },
}

/// Refuses a binary record's sample whose temperature is no sensor's, as the CSV reader
/// refuses its field ([`imu_csv::temperature_is_plausible`]); `s.seq` is the record's index.
fn check_temperature(s: Option<ImuSample>) -> Result<Option<ImuSample>, SourceError> {
    match s {
        Some(s) if !imu_csv::temperature_is_plausible(s.temperature_c) => {
            Err(SourceError::Temperature {
                record: s.seq,
                temp_c: s.temperature_c,
            })
        }
        s => Ok(s),
    }
}

impl core::fmt::Display for SourceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Io(e) => write!(f, "read error: {e}"),
            Self::Format(e) => write!(f, "{e}"),
            Self::Temperature { record, temp_c } => write!(
                f,
                "byte offset {} (record {record}): temperature {} (NaN when it is unknown)",
                HEADER_LEN as u64 + RECORD_LEN as u64 * u64::from(*record),
                imu_csv::BadTemperature(*temp_c)
            ),
        }
    }
}

impl std::error::Error for SourceError {}

impl From<ReplayError<std::io::Error>> for SourceError {
    fn from(e: ReplayError<std::io::Error>) -> Self {
        match e {
            ReplayError::Io(e) => Self::Io(e),
            ReplayError::Format(e) => Self::Format(e),
        }
    }
}

/// A replay of any recording file.
pub enum ReplaySource {
    /// A binary file, read from disk as it goes.
    File(Replay<StdReader>),
    /// A CSV, PSINS or KF-GINS file, read from disk as it goes (after a first pass that checked
    /// it), each record encoded to the binary format as it is read; with the PSINS header.
    Text(Box<TextReplay<BufReader<File>>>, Option<PsinsHeader>),
    /// A recording in memory, encoded to the binary format.
    Memory(Replay<MemReader>),
}

/// Most records read to check the header's rate against the timestamps.
const RATE_CHECK_RECORDS: usize = 201;

/// Intervals per span of the rate check ([`check_header_rate`]).
const RATE_SPAN: usize = 50;

/// Largest relative difference between the header's rate and the timestamps' median rate.
pub const RATE_TOLERANCE: f64 = 0.01;

/// Refuses a binary recording whose header rate contradicts its timestamps: the median of the
/// mean intervals over spans of [`RATE_SPAN`] intervals (fewer when the file is short) in the
/// first [`RATE_CHECK_RECORDS`] records against `1 / rate_hz`, within [`RATE_TOLERANCE`]. A
/// span's mean averages the time tags' jitter away (a single interval's median moved by 1.4 %
/// with ±20 % jitter, and refused good files), and the median over spans ignores a gap.
/// Records that do not decode are left to the replay's own errors.
fn check_header_rate(path: &Path, header: &Header) -> Result<()> {
    let mut file = BufReader::new(File::open(path)?);
    let mut skip = [0u8; HEADER_LEN];
    file.read_exact(&mut skip)?;
    let mut times = Vec::with_capacity(RATE_CHECK_RECORDS + 1);
    times.push(header.t0_ns);
    let mut buf = [0u8; RECORD_LEN];
    for index in 0..RATE_CHECK_RECORDS.min(header.sample_count as usize) {
        if file.read_exact(&mut buf).is_err() {
            break;
        }
        let offset = (HEADER_LEN + RECORD_LEN * index) as u64;
        let Ok(r) = Record::decode(&buf, offset, index as u32) else {
            break;
        };
        times.push(r.t_ns);
    }
    let n = times.len() - 1;
    if n < 3 {
        return Ok(());
    }
    let span = (n / 4).clamp(1, RATE_SPAN);
    let mut intervals: Vec<f64> = times
        .windows(span + 1)
        .map(|w| w[span].wrapping_sub(w[0]) as f64 * 1e-9 / span as f64)
        .collect();
    intervals.sort_by(f64::total_cmp);
    let median = intervals[intervals.len() / 2];
    let nominal = 1.0 / header.rate_hz;
    ensure!(
        (median / nominal - 1.0).abs() <= RATE_TOLERANCE,
        "recording {}: the header's rate {} Hz contradicts the timestamps (median interval {median} s, {:.6} Hz over the first {} records)",
        path.display(),
        nav_core::number::Number(header.rate_hz),
        1.0 / median,
        n
    );
    Ok(())
}

impl ReplaySource {
    /// Opens `path` for replay (format from [`detect`]). Errors name the file.
    pub fn open(path: &Path) -> Result<(Self, Format)> {
        let context = || format!("recording {}", path.display());
        let format = detect(path)?;
        let source = match format {
            Format::Binary => {
                let file = File::open(path).with_context(context)?;
                let len = file.metadata().with_context(context)?.len();
                let reader = StdReader::new(BufReader::new(file));
                let replay =
                    Replay::new(reader).map_err(|e| in_file(path, SourceError::from(e)))?;
                // The header's count against the file's length, before anything is navigated.
                replay
                    .header()
                    .check_file_len(len)
                    .map_err(|e| anyhow!("recording {}: {e}", path.display()))?;
                check_header_rate(path, replay.header())?;
                Self::File(replay)
            }
            Format::Csv | Format::Psins | Format::KfGins => {
                let (replay, psins) =
                    text_recording::replay(format, path, || File::open(path).map(BufReader::new))?;
                Self::Text(Box::new(replay), psins)
            }
            Format::GnssInsSim => Self::from_recording(&read_gnss_ins_sim(path)?)?,
        };
        Ok((source, format))
    }

    /// Replays an in-memory recording through the binary format.
    pub fn from_recording(recording: &Recording) -> Result<Self> {
        let reader = MemReader::new(recording.to_bytes()?);
        Ok(Self::Memory(
            Replay::new(reader).map_err(|e| anyhow!("{}", format_error(e)))?,
        ))
    }

    /// The recording's header.
    pub fn header(&self) -> &Header {
        match self {
            Self::File(r) => r.header(),
            Self::Text(r, _) => r.header(),
            Self::Memory(r) => r.header(),
        }
    }

    /// The PSINS file's header (its site, start time and scales), for a PSINS recording.
    pub fn psins_header(&self) -> Option<&PsinsHeader> {
        match self {
            Self::Text(_, psins) => psins.as_ref(),
            _ => None,
        }
    }

    /// The replay's counters so far.
    pub fn stats(&self) -> ReplayStats {
        match self {
            Self::File(r) => r.stats(),
            Self::Text(r, _) => r.stats(),
            Self::Memory(r) => r.stats(),
        }
    }
}

impl Imu for ReplaySource {
    type Error = SourceError;

    fn read_sample(&mut self) -> Result<Option<ImuSample>, SourceError> {
        match self {
            Self::File(r) => r
                .read_sample()
                .map_err(SourceError::from)
                .and_then(check_temperature),
            // The CSV reader refused its temperatures.
            Self::Text(r, _) => r.read_sample().map_err(SourceError::from),
            Self::Memory(r) => r
                .read_sample()
                .map_err(|e| SourceError::Format(format_error(e)))
                .and_then(check_temperature),
        }
    }
}
