//! The project's binary IMU recording format (version 1): its reader [`Replay`] and its writer
//! [`Writer`].
//!
//! A recording is a 48-byte header followed by `sample_count` records of 40 bytes each, all
//! little-endian, nothing after the last record. The same description lives in
//! `docs/recording-format.md`.
//!
//! # Header (48 bytes)
//!
//! | offset | size | field          | meaning |
//! | -----: | ---: | -------------- | ------- |
//! |      0 |    8 | `magic`        | `b"NAVIMU\r\n"` ([`MAGIC`]; the CR LF catches text-mode mangling, like PNG) |
//! |      8 |    2 | `version`      | `u16` = 1 ([`VERSION`]) |
//! |     10 |    2 | `header_len`   | `u16` = 48 ([`HEADER_LEN`]) |
//! |     12 |    2 | `record_len`   | `u16` = 40 ([`RECORD_LEN`]) |
//! |     14 |    2 | `kind`         | `u16`: 0 = increments (gyro [rad], accel [m/s] over the interval), 1 = rates (gyro [rad/s], accel [m/s^2] at the end of the interval); see [`Kind`] |
//! |     16 |    8 | `rate_hz`      | `f64`, nominal sample rate [Hz], finite and > 0 |
//! |     24 |    8 | `t0_ns`        | `u64`, start time of the first sample's interval [ns] |
//! |     32 |    4 | `sample_count` | `u32`, number of records |
//! |     36 |    8 | `reserved`     | zero |
//! |     44 |    4 | `header_crc`   | `u32`, CRC-32/ISO-HDLC of bytes 0..44 |
//!
//! # Record (40 bytes), `sample_count` of them right after the header
//!
//! | offset | size | field         | meaning |
//! | -----: | ---: | ------------- | ------- |
//! |      0 |    8 | `t_ns`        | `u64`, time at the end of the interval [ns] (recording clock) |
//! |      8 |   12 | `gyro`        | 3 x `f32`, body axes forward-right-down (FRD) |
//! |     20 |   12 | `accel`       | 3 x `f32`, FRD |
//! |     32 |    4 | `temperature` | `f32` [deg C], NaN = unknown |
//! |     36 |    4 | `record_crc`  | `u32`, CRC-32/ISO-HDLC of bytes 0..36 of the record |
//!
//! CRC-32/ISO-HDLC is the common "CRC-32" of zlib, PNG and Ethernet (`crc::CRC_32_ISO_HDLC`,
//! Python's `zlib.crc32`): check value `0xCBF43926` for `b"123456789"`.
//!
//! # Validation
//!
//! [`Header::decode`] checks, in this order: magic, version, header CRC, `header_len`,
//! `record_len`, `kind`, `rate_hz`, reserved bytes. [`Replay`] then checks each record's CRC,
//! that the file does not end before `sample_count` records, and that nothing follows the last
//! record. All of these are hard errors ([`FormatError`]); data-quality problems inside valid
//! records (non-finite values, time going backwards, gaps) are [`SampleFlags`] on the samples.
//!
//! # Replay semantics
//!
//! [`Replay`] turns record `i` into an [`ImuSample`] with `seq = i`, `t_us = t_ns / 1000`
//! (integer division) and `dt_s = ((t_ns - prev_t_ns) as f64 * 1e-9) as f32`, where `prev_t_ns`
//! is the previous record's `t_ns` (the header's `t0_ns` for record 0). With the nominal period
//! `T = 1e9 / rate_hz` [ns] and `delta = t_ns - prev_t_ns` [ns]:
//!
//! - `delta <= 0`: `dt_s = 0` and [`SampleFlags::BAD_INTERVAL`];
//! - `delta > 10 T`: [`SampleFlags::BAD_INTERVAL`];
//! - `1.5 T < delta <= 10 T`: [`SampleFlags::GAP`], and `round(delta / T) - 1` samples are
//!   counted as missed in [`ReplayStats::missed`]; but a record of increments whose velocity
//!   increment covers its last period alone rather than the interval
//!   ([`crate::sample::increment_spans_interval`] against the previous record's, when that one
//!   covered one period: a logger that dropped records) is [`SampleFlags::BAD_INTERVAL`]
//!   instead (the navigation bridges the interval);
//! - any gyro or accelerometer component NaN or infinite: [`SampleFlags::NON_FINITE`] (a NaN
//!   temperature means "unknown" and is not flagged).
//!
//! The period comparisons are done in `f64` on the integer nanosecond difference, so the firmware
//! and the host harness produce bit-identical samples from the same file.

use core::fmt;

use crc::{CRC_32_ISO_HDLC, Crc};
use embedded_io::{Read, Write};

use crate::sample::increment_spans_interval;
use crate::{Imu, ImuSample, Motion, SampleFlags};

/// The file signature at offset 0.
pub const MAGIC: [u8; 8] = *b"NAVIMU\r\n";
/// The format version this module reads and writes.
pub const VERSION: u16 = 1;
/// Length of the header [bytes].
pub const HEADER_LEN: usize = 48;
/// Length of one record [bytes].
pub const RECORD_LEN: usize = 40;

/// CRC-32/ISO-HDLC, used for the header and every record.
const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

// Header field offsets [bytes].
const H_MAGIC: usize = 0;
const H_VERSION: usize = 8;
const H_HEADER_LEN: usize = 10;
const H_RECORD_LEN: usize = 12;
const H_KIND: usize = 14;
const H_RATE_HZ: usize = 16;
const H_T0_NS: usize = 24;
const H_SAMPLE_COUNT: usize = 32;
const H_RESERVED: usize = 36;
const H_CRC: usize = 44;

// Record field offsets [bytes].
const R_T_NS: usize = 0;
const R_GYRO: usize = 8;
const R_ACCEL: usize = 20;
const R_TEMPERATURE: usize = 32;
const R_CRC: usize = 36;

/// Above this many nominal periods an interval is [`SampleFlags::BAD_INTERVAL`].
const BAD_INTERVAL_PERIODS: f64 = 10.0;
/// Above this many nominal periods (and up to [`BAD_INTERVAL_PERIODS`]) an interval is a
/// [`SampleFlags::GAP`].
const GAP_PERIODS: f64 = 1.5;

/// What the gyro and accelerometer fields of the records hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Kind {
    /// Code 0: increments over the interval, gyro `delta_theta_ib_b` [rad] and accelerometer
    /// `delta_v_ib_b` [m/s] (replayed as [`Motion::Increments`]).
    Increments,
    /// Code 1: values at the end of the interval, gyro `omega_ib_b` [rad/s] and accelerometer
    /// `f_ib_b` [m/s^2] (replayed as [`Motion::Rates`]).
    Rates,
}

impl Kind {
    /// The `kind` code in the header (0 = increments, 1 = rates).
    pub const fn code(self) -> u16 {
        match self {
            Kind::Increments => 0,
            Kind::Rates => 1,
        }
    }

    /// The kind for a header `kind` code; `None` for an unknown code.
    pub const fn from_code(code: u16) -> Option<Kind> {
        match code {
            0 => Some(Kind::Increments),
            1 => Some(Kind::Rates),
            _ => None,
        }
    }
}

/// The decoded recording header (the constant fields `magic`, `version`, `header_len`,
/// `record_len` and `reserved` are implied).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header {
    /// What the records' gyro and accelerometer fields hold.
    pub kind: Kind,
    /// Nominal sample rate [Hz]; finite and > 0 in a valid file.
    pub rate_hz: f64,
    /// Start time of the first sample's interval [ns] (recording clock).
    pub t0_ns: u64,
    /// Number of records following the header.
    pub sample_count: u32,
}

/// A file whose length is not its header's ([`Header::check_file_len`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LengthMismatch {
    /// The header's sample count.
    pub count: u32,
    /// The length [bytes] the header gives.
    pub expected: u64,
    /// The file's length [bytes].
    pub len: u64,
}

impl fmt::Display for LengthMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Self {
            count,
            expected,
            len,
        } = self;
        let why = if len < expected {
            "truncated"
        } else {
            "trailing bytes after the last record"
        };
        write!(
            f,
            "the header says {count} samples ({expected} bytes) but the file has {len} bytes ({why})"
        )
    }
}

impl core::error::Error for LengthMismatch {}

impl Header {
    /// The 48 header bytes, CRC included. Does not validate: see [`Header::validate`].
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut bytes = [0u8; HEADER_LEN];
        bytes[H_MAGIC..H_MAGIC + 8].copy_from_slice(&MAGIC);
        bytes[H_VERSION..H_VERSION + 2].copy_from_slice(&VERSION.to_le_bytes());
        bytes[H_HEADER_LEN..H_HEADER_LEN + 2].copy_from_slice(&(HEADER_LEN as u16).to_le_bytes());
        bytes[H_RECORD_LEN..H_RECORD_LEN + 2].copy_from_slice(&(RECORD_LEN as u16).to_le_bytes());
        bytes[H_KIND..H_KIND + 2].copy_from_slice(&self.kind.code().to_le_bytes());
        bytes[H_RATE_HZ..H_RATE_HZ + 8].copy_from_slice(&self.rate_hz.to_le_bytes());
        bytes[H_T0_NS..H_T0_NS + 8].copy_from_slice(&self.t0_ns.to_le_bytes());
        bytes[H_SAMPLE_COUNT..H_SAMPLE_COUNT + 4].copy_from_slice(&self.sample_count.to_le_bytes());
        // Reserved bytes 36..44 stay zero.
        let crc = CRC32.checksum(&bytes[..H_CRC]);
        bytes[H_CRC..H_CRC + 4].copy_from_slice(&crc.to_le_bytes());
        bytes
    }

    /// Decodes and validates a header: magic, version, CRC, lengths, kind, rate and reserved
    /// bytes, in this order. Errors carry the file offset of the offending field (0 for a CRC
    /// mismatch: the corruption can be anywhere in bytes 0..44) and no record index.
    pub fn decode(bytes: &[u8; HEADER_LEN]) -> Result<Header, FormatError> {
        let err = |kind, offset: usize| FormatError::in_header(kind, offset as u64);

        if bytes[H_MAGIC..H_MAGIC + 8] != MAGIC {
            return Err(err(FormatErrorKind::BadMagic, H_MAGIC));
        }
        let version = u16_at(bytes, H_VERSION);
        if version != VERSION {
            return Err(err(FormatErrorKind::UnsupportedVersion(version), H_VERSION));
        }
        if u32_at(bytes, H_CRC) != CRC32.checksum(&bytes[..H_CRC]) {
            return Err(err(FormatErrorKind::HeaderCrc, 0));
        }
        if usize::from(u16_at(bytes, H_HEADER_LEN)) != HEADER_LEN {
            return Err(err(
                FormatErrorKind::BadHeader("header_len is not 48"),
                H_HEADER_LEN,
            ));
        }
        if usize::from(u16_at(bytes, H_RECORD_LEN)) != RECORD_LEN {
            return Err(err(
                FormatErrorKind::BadHeader("record_len is not 40"),
                H_RECORD_LEN,
            ));
        }
        let Some(kind) = Kind::from_code(u16_at(bytes, H_KIND)) else {
            return Err(err(
                FormatErrorKind::BadHeader("unknown kind (expected 0 = increments or 1 = rates)"),
                H_KIND,
            ));
        };
        let rate_hz = f64::from_le_bytes(array_at(bytes, H_RATE_HZ));
        if !rate_is_valid(rate_hz) {
            return Err(err(
                FormatErrorKind::BadHeader("rate_hz is not finite and > 0"),
                H_RATE_HZ,
            ));
        }
        if bytes[H_RESERVED..H_CRC].iter().any(|&b| b != 0) {
            return Err(err(
                FormatErrorKind::BadHeader("reserved bytes are not zero"),
                H_RESERVED,
            ));
        }
        Ok(Header {
            kind,
            rate_hz,
            t0_ns: u64::from_le_bytes(array_at(bytes, H_T0_NS)),
            sample_count: u32_at(bytes, H_SAMPLE_COUNT),
        })
    }

    /// Checks a file's length `len` [bytes] against [`Header::file_len`], before anything is
    /// read past the header (a cut or a tail is found at once, not after the run).
    pub fn check_file_len(&self, len: u64) -> Result<(), LengthMismatch> {
        let expected = self.file_len();
        (len == expected).then_some(()).ok_or(LengthMismatch {
            count: self.sample_count,
            expected,
            len,
        })
    }

    /// Checks the fields a valid file constrains (`rate_hz` finite and > 0); the error is the
    /// one [`Header::decode`] would report for the encoded header.
    pub fn validate(&self) -> Result<(), FormatError> {
        if rate_is_valid(self.rate_hz) {
            Ok(())
        } else {
            Err(FormatError::in_header(
                FormatErrorKind::BadHeader("rate_hz is not finite and > 0"),
                H_RATE_HZ as u64,
            ))
        }
    }

    /// Nominal sample period `1e9 / rate_hz` [ns].
    pub fn period_ns(&self) -> f64 {
        1e9 / self.rate_hz
    }

    /// Length of the whole file this header announces [bytes]: `48 + 40 * sample_count`.
    pub fn file_len(&self) -> u64 {
        record_offset(self.sample_count)
    }
}

/// One record as stored (before it becomes an [`ImuSample`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Record {
    /// Time at the end of the interval [ns] (recording clock).
    pub t_ns: u64,
    /// Gyro, body axes FRD: `delta_theta_ib_b` [rad] or `omega_ib_b` [rad/s] (see [`Kind`]).
    pub gyro: [f32; 3],
    /// Accelerometer, body axes FRD: `delta_v_ib_b` [m/s] or `f_ib_b` [m/s^2] (see [`Kind`]).
    pub accel: [f32; 3],
    /// Sensor temperature [deg C]; NaN when unknown.
    pub temperature_c: f32,
}

impl Record {
    /// The 40 record bytes, CRC included.
    pub fn encode(&self) -> [u8; RECORD_LEN] {
        let mut bytes = [0u8; RECORD_LEN];
        bytes[R_T_NS..R_T_NS + 8].copy_from_slice(&self.t_ns.to_le_bytes());
        for (axis, value) in self.gyro.iter().enumerate() {
            let at = R_GYRO + 4 * axis;
            bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
        }
        for (axis, value) in self.accel.iter().enumerate() {
            let at = R_ACCEL + 4 * axis;
            bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
        }
        bytes[R_TEMPERATURE..R_TEMPERATURE + 4].copy_from_slice(&self.temperature_c.to_le_bytes());
        let crc = CRC32.checksum(&bytes[..R_CRC]);
        bytes[R_CRC..R_CRC + 4].copy_from_slice(&crc.to_le_bytes());
        bytes
    }

    /// Decodes a record after checking its CRC. `offset` (the record's byte offset in the file)
    /// and `index` (its record index) only go into the error.
    pub fn decode(
        bytes: &[u8; RECORD_LEN],
        offset: u64,
        index: u32,
    ) -> Result<Record, FormatError> {
        if u32_at(bytes, R_CRC) != CRC32.checksum(&bytes[..R_CRC]) {
            return Err(FormatError {
                kind: FormatErrorKind::RecordCrc,
                offset,
                record: Some(index),
                expected_records: None,
            });
        }
        let f32_at = |at: usize| f32::from_le_bytes(array_at(bytes, at));
        Ok(Record {
            t_ns: u64::from_le_bytes(array_at(bytes, R_T_NS)),
            gyro: [f32_at(R_GYRO), f32_at(R_GYRO + 4), f32_at(R_GYRO + 8)],
            accel: [f32_at(R_ACCEL), f32_at(R_ACCEL + 4), f32_at(R_ACCEL + 8)],
            temperature_c: f32_at(R_TEMPERATURE),
        })
    }
}

/// What is wrong with a recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FormatErrorKind {
    /// The file does not start with [`MAGIC`] (not a recording, or mangled by a text-mode
    /// transfer).
    BadMagic,
    /// The header's version (carried) is not [`VERSION`].
    UnsupportedVersion(u16),
    /// A header field is invalid: wrong lengths, unknown kind, bad rate, nonzero reserved bytes
    /// (the text says which).
    BadHeader(&'static str),
    /// The header CRC does not match bytes 0..44.
    HeaderCrc,
    /// A record's CRC does not match its bytes 0..36.
    RecordCrc,
    /// The file ends inside the header or before `sample_count` complete records.
    Truncated,
    /// There are bytes after the last record.
    TrailingData,
}

impl fmt::Display for FormatErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FormatErrorKind::BadMagic => write!(
                f,
                "not a NAVIMU recording: the file does not start with \"NAVIMU\\r\\n\" \
                 (or a text-mode transfer rewrote its line endings)"
            ),
            FormatErrorKind::UnsupportedVersion(version) => write!(
                f,
                "unsupported format version {version} (this reader supports version {VERSION})"
            ),
            FormatErrorKind::BadHeader(what) => write!(f, "invalid header: {what}"),
            FormatErrorKind::HeaderCrc => write!(f, "header CRC mismatch (corrupt header)"),
            FormatErrorKind::RecordCrc => write!(f, "record CRC mismatch (corrupt data)"),
            FormatErrorKind::Truncated => write!(f, "file ends early (truncated)"),
            FormatErrorKind::TrailingData => write!(f, "unexpected data after the last record"),
        }
    }
}

/// A recording format error and where it is.
///
/// `Display` gives e.g. `byte offset 1288 (record 31): record CRC mismatch (corrupt data)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FormatError {
    /// What is wrong.
    pub kind: FormatErrorKind,
    /// Byte offset in the file where the problem starts: the offending header field, 0 for a
    /// header CRC mismatch or a file that ends inside the header, the start of the record for
    /// record errors, the end of the last record for [`FormatErrorKind::TrailingData`].
    pub offset: u64,
    /// Record index, if the problem is in a record.
    pub record: Option<u32>,
    /// For [`FormatErrorKind::Truncated`] and [`FormatErrorKind::TrailingData`] reported by
    /// [`Replay`]: the `sample_count` the header announces (so the message can say what was
    /// expected). `None` otherwise.
    pub expected_records: Option<u32>,
}

impl FormatError {
    fn in_header(kind: FormatErrorKind, offset: u64) -> FormatError {
        FormatError {
            kind,
            offset,
            record: None,
            expected_records: None,
        }
    }
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "byte offset {}", self.offset)?;
        if let Some(record) = self.record {
            write!(f, " (record {record})")?;
        }
        write!(f, ": ")?;
        match (self.kind, self.record, self.expected_records) {
            (FormatErrorKind::Truncated, None, _) => write!(
                f,
                "file ends inside the header: expected {HEADER_LEN} header bytes, found fewer"
            ),
            (FormatErrorKind::Truncated, Some(index), Some(expected)) => write!(
                f,
                "file ends inside the recording: expected {expected} records ({} bytes), \
                 found {index} complete records",
                record_offset(expected)
            ),
            (FormatErrorKind::Truncated, Some(index), None) => {
                write!(
                    f,
                    "file ends inside the recording: record {index} is incomplete"
                )
            }
            (FormatErrorKind::TrailingData, _, Some(expected)) => write!(
                f,
                "unexpected data after the last record: the header announces {expected} \
                 records, so the file should end after {} bytes, but it is longer",
                record_offset(expected)
            ),
            (kind, _, _) => write!(f, "{kind}"),
        }
    }
}

impl core::error::Error for FormatError {}

/// Error of [`Replay`]: the byte source failed, or the recording is invalid.
#[derive(Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ReplayError<E> {
    /// The byte source failed.
    Io(E),
    /// The recording is invalid (corrupt, truncated, not a recording...).
    Format(FormatError),
}

impl<E> From<FormatError> for ReplayError<E> {
    fn from(error: FormatError) -> Self {
        ReplayError::Format(error)
    }
}

impl<E: fmt::Display> fmt::Display for ReplayError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReplayError::Io(error) => write!(f, "reading the recording failed: {error}"),
            ReplayError::Format(error) => write!(f, "invalid recording: {error}"),
        }
    }
}

impl<E: fmt::Debug + fmt::Display> core::error::Error for ReplayError<E> {}

#[cfg(feature = "std")]
impl From<FormatError> for std::io::Error {
    fn from(error: FormatError) -> Self {
        std::io::Error::new(std::io::ErrorKind::InvalidData, error)
    }
}

#[cfg(feature = "std")]
impl From<ReplayError<std::io::Error>> for std::io::Error {
    fn from(error: ReplayError<std::io::Error>) -> Self {
        match error {
            ReplayError::Io(error) => error,
            ReplayError::Format(error) => error.into(),
        }
    }
}

/// Counters of a [`Replay`] so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReplayStats {
    /// Samples returned (every record, flagged or not).
    pub samples: u32,
    /// Samples estimated missing from [`SampleFlags::GAP`] intervals: `round(delta / T) - 1`
    /// per gap.
    pub missed: u32,
    /// Samples flagged [`SampleFlags::NON_FINITE`].
    pub non_finite: u32,
    /// Samples flagged [`SampleFlags::BAD_INTERVAL`].
    pub bad_interval: u32,
    /// Of [`Self::bad_interval`], the samples whose time is not after the previous record's
    /// (a repeated time tag, a swapped pair, a clock that stepped back): out of time order.
    pub not_after_previous: u32,
}

#[derive(Clone, Copy, Debug)]
enum State {
    Reading,
    Done,
    Failed(FormatError),
}

/// Replays a recording from a byte source as an [`Imu`] (see the [module docs](self) for the
/// format and the exact sample semantics).
///
/// A format error is final: every later [`Imu::read_sample`] returns the same error. An I/O
/// error of the source is passed on and the replay keeps its place (a partially read record is
/// kept), so a later call retries the read.
///
/// The replay reads 40 bytes (one record) at a time; wrap a source for which each read is
/// expensive in [`crate::io::Buffered`].
pub struct Replay<R: Read> {
    reader: R,
    header: Header,
    period_ns: f64,
    next_index: u32,
    prev_t_ns: u64,
    /// The previous record's velocity increment, when it covered one nominal period.
    prev_delta_v: Option<[f32; 3]>,
    record_buf: [u8; RECORD_LEN],
    record_filled: usize,
    state: State,
    stats: ReplayStats,
}

impl<R: Read> Replay<R> {
    /// Reads and validates the header.
    pub fn new(mut reader: R) -> Result<Self, ReplayError<R::Error>> {
        let mut bytes = [0u8; HEADER_LEN];
        let found = read_full(&mut reader, &mut bytes).map_err(ReplayError::Io)?;
        if found < HEADER_LEN {
            // A short file that does not even start like a recording is not a recording.
            let magic_part = found.min(MAGIC.len());
            let kind = if bytes[..magic_part] == MAGIC[..magic_part] {
                FormatErrorKind::Truncated
            } else {
                FormatErrorKind::BadMagic
            };
            return Err(FormatError::in_header(kind, 0).into());
        }
        let header = Header::decode(&bytes)?;
        Ok(Replay {
            reader,
            header,
            period_ns: header.period_ns(),
            next_index: 0,
            prev_t_ns: header.t0_ns,
            prev_delta_v: None,
            record_buf: [0; RECORD_LEN],
            record_filled: 0,
            state: State::Reading,
            stats: ReplayStats::default(),
        })
    }

    /// The recording's header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Counters so far.
    pub fn stats(&self) -> ReplayStats {
        self.stats
    }

    /// Gives the byte source back (positioned wherever the replay stopped).
    pub fn into_inner(self) -> R {
        self.reader
    }

    /// Records the error as final and returns it.
    fn fail(&mut self, error: FormatError) -> ReplayError<R::Error> {
        self.state = State::Failed(error);
        ReplayError::Format(error)
    }

    /// The sample for `record`, which is record number `self.next_index`; updates the counters.
    fn make_sample(&mut self, record: &Record) -> ImuSample {
        let mut flags = SampleFlags::empty();
        // The record's increment covers one period: on time, or judged short after a gap.
        let mut one_period = false;
        let dt_s = if record.t_ns > self.prev_t_ns {
            let delta_ns = (record.t_ns - self.prev_t_ns) as f64;
            if delta_ns > BAD_INTERVAL_PERIODS * self.period_ns {
                flags |= SampleFlags::BAD_INTERVAL;
            } else if delta_ns > GAP_PERIODS * self.period_ns {
                // An increment of the last period alone cannot be integrated over the gap.
                // A non-finite record is flagged as such alone.
                let finite = record
                    .gyro
                    .iter()
                    .chain(&record.accel)
                    .all(|v| v.is_finite());
                let short = self.header.kind == Kind::Increments
                    && finite
                    && self.prev_delta_v.is_some_and(|p| {
                        !increment_spans_interval(&record.accel, &p, delta_ns / self.period_ns)
                    });
                one_period = short;
                flags |= if short {
                    SampleFlags::BAD_INTERVAL
                } else {
                    SampleFlags::GAP
                };
                // round(delta / T) for a positive value (core has no f64::round); at least one
                // sample is missing in a gap, whatever the last-bit rounding of the quotient.
                let periods = (delta_ns / self.period_ns + 0.5) as u32;
                self.stats.missed = self.stats.missed.saturating_add(periods.max(2) - 1);
            }
            (delta_ns * 1e-9) as f32
        } else {
            flags |= SampleFlags::BAD_INTERVAL;
            self.stats.not_after_previous = self.stats.not_after_previous.saturating_add(1);
            0.0
        };
        if !record
            .gyro
            .iter()
            .chain(record.accel.iter())
            .all(|v| v.is_finite())
        {
            flags |= SampleFlags::NON_FINITE;
        }

        self.stats.samples = self.stats.samples.saturating_add(1);
        if flags.contains(SampleFlags::NON_FINITE) {
            self.stats.non_finite = self.stats.non_finite.saturating_add(1);
        }
        if flags.contains(SampleFlags::BAD_INTERVAL) {
            self.stats.bad_interval = self.stats.bad_interval.saturating_add(1);
        }
        self.prev_t_ns = record.t_ns;
        // The last increment of one period stays the reference for the next gap: a run of
        // gaps (a logger dropping every other record) is judged record by record, not taken
        // as covering from the second one on (was: a second of half-rate records lost half
        // its increments, 5 m/s of vertical velocity, silently).
        if (flags.is_empty() || one_period) && !flags.contains(SampleFlags::NON_FINITE) {
            self.prev_delta_v = Some(record.accel);
        }

        let motion = match self.header.kind {
            Kind::Increments => Motion::Increments {
                delta_theta_ib_b: record.gyro,
                delta_v_ib_b: record.accel,
            },
            Kind::Rates => Motion::Rates {
                omega_ib_b: record.gyro,
                f_ib_b: record.accel,
            },
        };
        ImuSample {
            t_us: record.t_ns / 1000,
            seq: self.next_index,
            dt_s,
            motion,
            temperature_c: record.temperature_c,
            flags,
        }
    }
}

impl<R: Read> Imu for Replay<R> {
    type Error = ReplayError<R::Error>;

    fn read_sample(&mut self) -> Result<Option<ImuSample>, Self::Error> {
        match self.state {
            State::Reading => {}
            State::Done => return Ok(None),
            State::Failed(error) => return Err(ReplayError::Format(error)),
        }
        let index = self.next_index;
        let offset = record_offset(index);

        if index >= self.header.sample_count {
            // All records read: the file must end here.
            let mut probe = [0u8; 1];
            if self.reader.read(&mut probe).map_err(ReplayError::Io)? == 0 {
                self.state = State::Done;
                return Ok(None);
            }
            return Err(self.fail(FormatError {
                kind: FormatErrorKind::TrailingData,
                offset,
                record: None,
                expected_records: Some(self.header.sample_count),
            }));
        }

        while self.record_filled < RECORD_LEN {
            let n = self
                .reader
                .read(&mut self.record_buf[self.record_filled..])
                .map_err(ReplayError::Io)?;
            if n == 0 {
                return Err(self.fail(FormatError {
                    kind: FormatErrorKind::Truncated,
                    offset,
                    record: Some(index),
                    expected_records: Some(self.header.sample_count),
                }));
            }
            // `min` guards against a source that claims more than it was given.
            self.record_filled += n.min(RECORD_LEN - self.record_filled);
        }
        self.record_filled = 0;

        let record = match Record::decode(&self.record_buf, offset, index) {
            Ok(record) => record,
            Err(error) => return Err(self.fail(error)),
        };
        let sample = self.make_sample(&record);
        self.next_index += 1;
        Ok(Some(sample))
    }
}

/// Error of [`Writer`].
#[derive(Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WriteError<E> {
    /// The byte sink failed.
    Io(E),
    /// The header is invalid (see [`Header::validate`]); nothing was written.
    InvalidHeader(FormatError),
    /// More records than the header's `sample_count` (carried) were written.
    TooManyRecords(u32),
    /// [`Writer::finish`] before the header's `sample_count` records were written.
    TooFewRecords {
        /// The header's `sample_count`.
        expected: u32,
        /// Records written.
        written: u32,
    },
}

impl<E: fmt::Display> fmt::Display for WriteError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WriteError::Io(error) => write!(f, "writing the recording failed: {error}"),
            WriteError::InvalidHeader(error) => write!(f, "cannot write this header: {error}"),
            WriteError::TooManyRecords(expected) => {
                write!(f, "too many records: the header announces {expected}")
            }
            WriteError::TooFewRecords { expected, written } => write!(
                f,
                "recording incomplete: the header announces {expected} records, {written} written"
            ),
        }
    }
}

impl<E: fmt::Debug + fmt::Display> core::error::Error for WriteError<E> {}

/// Writes a recording: the header (whose `sample_count` must be known up front), then exactly
/// `sample_count` records.
pub struct Writer<W: Write> {
    writer: W,
    header: Header,
    written: u32,
}

impl<W: Write> Writer<W> {
    /// Validates and writes the header.
    pub fn new(mut writer: W, header: Header) -> Result<Self, WriteError<W::Error>> {
        header.validate().map_err(WriteError::InvalidHeader)?;
        writer.write_all(&header.encode()).map_err(WriteError::Io)?;
        Ok(Writer {
            writer,
            header,
            written: 0,
        })
    }

    /// Writes the next record.
    pub fn write_record(&mut self, record: &Record) -> Result<(), WriteError<W::Error>> {
        if self.written >= self.header.sample_count {
            return Err(WriteError::TooManyRecords(self.header.sample_count));
        }
        self.writer
            .write_all(&record.encode())
            .map_err(WriteError::Io)?;
        self.written += 1;
        Ok(())
    }

    /// The header written.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Records written so far.
    pub fn written(&self) -> u32 {
        self.written
    }

    /// Checks that all `sample_count` records were written, flushes and gives the sink back.
    pub fn finish(mut self) -> Result<W, WriteError<W::Error>> {
        if self.written != self.header.sample_count {
            return Err(WriteError::TooFewRecords {
                expected: self.header.sample_count,
                written: self.written,
            });
        }
        self.writer.flush().map_err(WriteError::Io)?;
        Ok(self.writer)
    }
}

/// Byte offset [bytes] of record `index` in a file (or, for `index == sample_count`, of the
/// end of the file).
pub fn record_offset(index: u32) -> u64 {
    HEADER_LEN as u64 + u64::from(index) * RECORD_LEN as u64
}

fn rate_is_valid(rate_hz: f64) -> bool {
    rate_hz.is_finite() && rate_hz > 0.0
}

/// Reads until `buf` is full or the source is at EOF; returns the number of bytes read.
fn read_full<R: Read>(reader: &mut R, buf: &mut [u8]) -> Result<usize, R::Error> {
    let mut filled = 0;
    while filled < buf.len() {
        match reader.read(&mut buf[filled..])? {
            0 => break,
            n => filled += n.min(buf.len() - filled),
        }
    }
    Ok(filled)
}

fn array_at<const N: usize>(bytes: &[u8], at: usize) -> [u8; N] {
    let mut out = [0u8; N];
    out.copy_from_slice(&bytes[at..at + N]);
    out
}

fn u16_at(bytes: &[u8], at: usize) -> u16 {
    u16::from_le_bytes(array_at(bytes, at))
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(array_at(bytes, at))
}

#[cfg(test)]
mod tests;
