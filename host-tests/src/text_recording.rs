//! Text recordings (CSV, KF-GINS, PSINS) as streams of binary-format records, in memory bounded
//! by the longest line whatever the file's length.
//!
//! A replay reads a text file twice, one record at a time: a first pass ([`HeaderScan`]) checks
//! every line and finds the binary header (the count, the nominal rate and `t0`), so a damaged
//! file is refused before anything is navigated; the second pass encodes each record into the
//! binary format as the replay asks for it ([`Encoded`]), so the flags and the measured `dt` come
//! from the binary reader's code whatever the input format.
//!
//! Conversion of timed increments (see also [`crate::recording_io`]): `t_ns = round(t_s * 1e9)`,
//! the end of each interval; the nominal rate is `1 / median interval` over the first
//! [`RATE_PREFIX_RECORDS`] records (CSV, KF-GINS) or the PSINS header's; the header's `t0_ns`
//! (start of the first interval) is `t_ns[0] - round(median interval)` or the PSINS `t0`.

use crate::imu_csv::{CsvReader, CsvRow};
use crate::kf_gins::ImuReader;
use crate::psins::{PsinsError, PsinsHeader, PsinsReader};
use crate::recording_io::Format;
use crate::text_error::{TextError, seconds_to_ns};
use anyhow::{Context, Result, anyhow, ensure};
use hal_adapters::recording::{HEADER_LEN, Header, Kind, RECORD_LEN, Record, Replay};
use std::fmt;
use std::io::{self, BufRead};
use std::path::Path;

/// Records whose median interval gives the nominal rate of a CSV or KF-GINS recording (4096
/// intervals: about 10 s at 400 Hz; a bounded prefix, so the rate is known before the rest of
/// the file is read).
pub const RATE_PREFIX_RECORDS: usize = 4097;

/// An error of a text recording's reader.
#[derive(Debug)]
pub enum TextRecordError {
    /// CSV or KF-GINS.
    Text(TextError),
    /// PSINS.
    Psins(PsinsError),
}

impl fmt::Display for TextRecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Text(e) => e.fmt(f),
            Self::Psins(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for TextRecordError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Text(e) => e.source(),
            Self::Psins(e) => e.source(),
        }
    }
}

impl From<TextError> for TextRecordError {
    fn from(e: TextError) -> Self {
        Self::Text(e)
    }
}

impl From<PsinsError> for TextRecordError {
    fn from(e: PsinsError) -> Self {
        Self::Psins(e)
    }
}

/// The records of a text recording in file order, each read when asked for.
#[derive(Debug)]
pub enum TextRecords<R: BufRead> {
    /// A CSV file.
    Csv(CsvReader<R>),
    /// A KF-GINS IMU file.
    KfGins(ImuReader<R>),
    /// A PSINS file, and the samples read so far.
    Psins(PsinsReader<R>, u64),
}

impl<R: BufRead> TextRecords<R> {
    /// Starts reading `reader` (a file of the text `format`; the header, if the format has one,
    /// is read and checked here); `path` names it in errors.
    pub fn new(format: Format, reader: R, path: &Path) -> Result<Self, TextRecordError> {
        Ok(match format {
            Format::Csv => Self::Csv(CsvReader::new(reader, path)?),
            Format::KfGins => Self::KfGins(ImuReader::new(reader, path)),
            Format::Psins => Self::Psins(PsinsReader::new(reader, path)?, 0),
            Format::Binary | Format::GnssInsSim => {
                return Err(TextRecordError::Text(TextError::io(
                    path,
                    io::Error::new(
                        io::ErrorKind::InvalidInput,
                        "a binary recording or a gnss-ins-sim folder is not a one-file text format",
                    ),
                )));
            }
        })
    }

    /// The PSINS header (`None` for the other formats).
    pub fn psins_header(&self) -> Option<&PsinsHeader> {
        match self {
            Self::Psins(r, _) => Some(r.header()),
            _ => None,
        }
    }
}

/// The record of a CSV row whose time the reader checked.
fn record_of(row: &CsvRow) -> Record {
    Record {
        // The readers refuse times beyond the clock, so this never falls back.
        t_ns: seconds_to_ns(row.t_s).unwrap_or(u64::MAX),
        gyro: row.delta_theta_ib_b,
        accel: row.delta_v_ib_b,
        temperature_c: row.temperature_c,
    }
}

impl<R: BufRead> Iterator for TextRecords<R> {
    type Item = Result<Record, TextRecordError>;

    fn next(&mut self) -> Option<Self::Item> {
        let to_f32 = |v: [f64; 3]| v.map(|x| x as f32);
        Some(match self {
            Self::Csv(rows) => rows.next()?.map(|r| record_of(&r)).map_err(Into::into),
            Self::KfGins(rows) => rows
                .next()?
                .map(|r| record_of(&r.to_csv_row()))
                .map_err(Into::into),
            Self::Psins(samples, k) => match samples.next()? {
                Ok(s) => {
                    *k += 1;
                    Ok(Record {
                        // The reader refuses samples whose time is beyond the clock.
                        t_ns: samples.header().sample_end_ns(*k).unwrap_or(u64::MAX),
                        gyro: to_f32(s.delta_theta_ib_b),
                        accel: to_f32(s.delta_v_ib_b),
                        temperature_c: f32::NAN,
                    })
                }
                Err(e) => Err(e.into()),
            },
        })
    }
}

/// The nominal rate [Hz] and `t0_ns` of records timed `t_ns` (the first of a recording): `1 /
/// median interval`, and the first time minus one median interval.
pub fn rate_from_times(t_ns: &[u64]) -> Result<(f64, u64)> {
    ensure!(
        t_ns.len() >= 2,
        "at least 2 samples are needed to find the sampling rate"
    );
    let mut intervals: Vec<i128> = t_ns
        .windows(2)
        .map(|w| i128::from(w[1]) - i128::from(w[0]))
        .collect();
    intervals.sort_unstable();
    let n = intervals.len();
    let median_ns = if n % 2 == 1 {
        intervals[n / 2] as f64
    } else {
        (intervals[n / 2 - 1] + intervals[n / 2]) as f64 / 2.0
    };
    ensure!(
        median_ns > 0.0,
        "the median sampling interval is {median_ns} ns: time does not increase"
    );
    // A first sample at t = 0 gives t0 = 0: its zero interval is flagged on replay.
    let t0_ns = t_ns[0].saturating_sub(median_ns.round() as u64);
    Ok((1e9 / median_ns, t0_ns))
}

/// The binary header of a text recording, found in one pass over its records: the count, and
/// the rate and `t0` (from the PSINS header, or from the first [`RATE_PREFIX_RECORDS`] records).
#[derive(Clone, Debug)]
pub struct HeaderScan {
    prefix_t_ns: Vec<u64>,
    count: u64,
    psins: Option<(f64, u64)>,
}

impl HeaderScan {
    /// A scan of `records` (not yet read).
    pub fn new<R: BufRead>(records: &TextRecords<R>) -> Self {
        Self {
            prefix_t_ns: Vec::with_capacity(RATE_PREFIX_RECORDS),
            count: 0,
            psins: records.psins_header().map(|h| (h.rate_hz(), h.t0_ns())),
        }
    }

    /// Counts `record`, the next of the recording.
    pub fn push(&mut self, record: &Record) {
        self.count += 1;
        if self.psins.is_none() && self.prefix_t_ns.len() < RATE_PREFIX_RECORDS {
            self.prefix_t_ns.push(record.t_ns);
        }
    }

    /// The header of the records pushed.
    pub fn finish(self) -> Result<Header> {
        let sample_count = u32::try_from(self.count).map_err(|_| {
            anyhow!(
                "{} records: too many for the binary format (more than 2^32 - 1)",
                self.count
            )
        })?;
        let (rate_hz, t0_ns) = match self.psins {
            Some(nominal) => nominal,
            None => rate_from_times(&self.prefix_t_ns)?,
        };
        let header = Header {
            kind: Kind::Increments,
            rate_hz,
            t0_ns,
            sample_count,
        };
        header.validate().map_err(|e| anyhow!("{e}"))?;
        Ok(header)
    }
}

/// Reads all of `records` (a first pass) of the file `path`: the binary header, or the first
/// error (a line's error names the file and the line already).
pub fn scan<R: BufRead>(mut records: TextRecords<R>, path: &Path) -> Result<Header> {
    let mut scan = HeaderScan::new(&records);
    for record in records.by_ref() {
        scan.push(&record?);
    }
    scan.finish()
        .with_context(|| format!("recording {}", path.display()))
}

/// A header and records as the bytes of the binary format, each record encoded when the reader
/// gets to it. An error of the records is an I/O error of the bytes.
#[derive(Debug)]
pub struct Encoded<I> {
    records: I,
    buf: [u8; HEADER_LEN],
    pos: usize,
    len: usize,
}

impl<I> Encoded<I> {
    /// The bytes of `header`, then of each of `records`.
    pub fn new(header: &Header, records: I) -> Self {
        Self {
            records,
            buf: header.encode(),
            pos: 0,
            len: HEADER_LEN,
        }
    }
}

impl<I> embedded_io::ErrorType for Encoded<I> {
    type Error = io::Error;
}

impl<I, E> embedded_io::Read for Encoded<I>
where
    I: Iterator<Item = Result<Record, E>>,
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    fn read(&mut self, out: &mut [u8]) -> Result<usize, io::Error> {
        if self.pos == self.len {
            match self.records.next() {
                None => return Ok(0),
                Some(Err(e)) => return Err(io::Error::other(e)),
                Some(Ok(r)) => {
                    self.buf[..RECORD_LEN].copy_from_slice(&r.encode());
                    (self.pos, self.len) = (0, RECORD_LEN);
                }
            }
        }
        let n = out.len().min(self.len - self.pos);
        out[..n].copy_from_slice(&self.buf[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

/// The replay of a text recording.
pub type TextReplay<R> = Replay<Encoded<TextRecords<R>>>;

/// Opens a text recording of `format` for replay, reading it twice through `open` (see the
/// module docs): the first pass checks every line and finds the header, the second is the
/// replay's. `path` names the file in errors. Also gives the PSINS header, if any.
pub fn replay<R: BufRead>(
    format: Format,
    path: &Path,
    mut open: impl FnMut() -> io::Result<R>,
) -> Result<(TextReplay<R>, Option<PsinsHeader>)> {
    let context = || format!("recording {}", path.display());
    let records = TextRecords::new(format, open().with_context(context)?, path)?;
    let psins = records.psins_header().copied();
    let header = scan(records, path)?;
    let records = TextRecords::new(format, open().with_context(context)?, path)?;
    let replay = Replay::new(Encoded::new(&header, records))
        .map_err(|e| anyhow!("recording {}: {e}", path.display()))?;
    Ok((replay, psins))
}

#[cfg(test)]
mod tests {
    use super::*;
    use hal_adapters::Imu;

    #[test]
    fn encoded_records_replay_as_the_binary_format() {
        let text = "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps\n\
                    0.01,1e-6,0,0,0,0,-0.098\n0.02,0,0,0,0,0,-0.098\n0.04,NaN,0,0,0,0,-0.098\n";
        let path = Path::new("mem.csv");
        let (mut replay, psins) = replay(Format::Csv, path, || Ok(text.as_bytes())).unwrap();
        assert!(psins.is_none());
        let h = *replay.header();
        assert_eq!((h.sample_count, h.t0_ns), (3, 0));
        assert!(
            (h.rate_hz - 1e9 / 15_000_000.0).abs() < 1e-9,
            "{}",
            h.rate_hz
        );
        let mut samples = Vec::new();
        while let Some(s) = replay.read_sample().unwrap() {
            samples.push(s);
        }
        assert_eq!(samples.len(), 3);
        assert_eq!(samples[1].t_us, 20_000);
        assert!(!samples[2].flags.usable());
        assert_eq!(replay.stats().non_finite, 1);
    }

    #[test]
    fn a_bad_line_is_refused_before_the_replay() {
        let text = "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps\n\
                    0.01,0,0,0,0,0,-0.098\n0.02,0,0,0,0,0,x\n";
        let Err(e) = replay(Format::Csv, Path::new("m.csv"), || Ok(text.as_bytes())) else {
            panic!("a bad line must be refused");
        };
        let msg = format!("{e:#}");
        assert!(
            msg.contains("m.csv: line 3: column dv_z_mps: expected a number, found 'x'"),
            "{msg}"
        );
    }
}
