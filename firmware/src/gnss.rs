//! GNSS fixes from a second host file (`--gnss FILE`): the binary fix file
//! (`hal_adapters::gnss_record`, `docs/gnss-record-format.md`; `nav` writes it from the GNSS CSV
//! or KF-GINS text, `host_tests::gnss_file::convert`) read through semihosting, one record
//! at a time, and handed to the navigator before the first sample at or after each fix's time
//! (the harness's pipeline does the same).
//!
//! The whole file is checked when the run starts ([`check`]: every record's CRC and flags, the
//! count), so a damaged file is refused before anything is navigated, as a damaged recording
//! is. A fix whose time is not later than the previous one's (a receiver's log that repeats or
//! swaps an epoch) is handed over in its turn, and the navigator skips and counts it as out of
//! order, as the harness's does.

use core::ffi::CStr;
use hal_adapters::gnss_record::{GnssReadError, GnssReader, GnssRecord};
use hal_adapters::io::{Buffered, SemihostingError, SemihostingFile};
use nav_core::Scalar;
use nav_core::Vector3;
use nav_core::ins_filter::sequencer::GnssFixInput;
use nav_core::ins_filter::{GnssPosition, GnssVelocity};

/// Bytes read from the host per semihosting call: one record (at 1-10 Hz the calls cost
/// nothing; the buffer is static RAM, which the fine alignment's stack needs).
const READ_CHUNK: usize = hal_adapters::gnss_record::RECORD_LEN;

/// The file's reader.
type Reader = GnssReader<Buffered<SemihostingFile, READ_CHUNK>>;

/// Why the GNSS file cannot be used.
pub enum GnssFileError {
    /// It cannot be opened.
    Open,
    /// It is not a valid fix file, or reading failed (where and what).
    Read(GnssReadError<SemihostingError>),
}

impl core::fmt::Display for GnssFileError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Open => f.write_str("cannot open the GNSS file"),
            Self::Read(e) => write!(f, "{e}"),
        }
    }
}

fn open(path: &CStr) -> Result<Reader, GnssFileError> {
    let file = SemihostingFile::open(path).map_err(|_| GnssFileError::Open)?;
    GnssReader::new(Buffered::new(file)).map_err(GnssFileError::Read)
}

/// What [`check`] found in a fix file.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FileSummary {
    /// The number of fixes.
    pub count: u32,
    /// The earliest and the latest fix's time [us] (`None`: no fix).
    pub span_us: Option<(u64, u64)>,
}

/// Reads the whole file once, checking every rule of the format: the number of fixes and
/// their time span.
pub fn check(path: &CStr) -> Result<FileSummary, GnssFileError> {
    let mut reader = open(path)?;
    let mut summary = FileSummary::default();
    while let Some(r) = reader.next_fix().map_err(GnssFileError::Read)? {
        summary.count += 1;
        let (a, b) = summary.span_us.unwrap_or((r.t_us, r.t_us));
        summary.span_us = Some((a.min(r.t_us), b.max(r.t_us)));
    }
    Ok(summary)
}

/// nav-core's fix of a record, in `f32` (the values rounded as the harness rounds the same
/// file's, `Scalar::c`; the place stays `f64`).
pub fn fix_of(r: &GnssRecord) -> GnssFixInput<f32> {
    let v3 = |a: [f64; 3]| Vector3::new(f32::c(a[0]), f32::c(a[1]), f32::c(a[2]));
    GnssFixInput {
        t_us: r.t_us,
        position: GnssPosition {
            lat_rad: r.lat_rad,
            lon_rad: r.lon_rad,
            h_m: r.h_m,
            sigma_ned_m: v3(r.sigma_ned_m),
        },
        velocity: r.velocity.map(|(v, s)| GnssVelocity {
            v_ned_m_s: v3(v),
            sigma_ned_m_s: v3(s),
        }),
    }
}

/// The fixes of the file in its order, one read ahead.
pub struct Fixes {
    reader: Reader,
    next: Option<GnssFixInput<f32>>,
    /// Fixes read so far.
    pub read: u32,
    /// The time of the first sample [us] (the first [`Fixes::due`] call's).
    data_start_us: Option<u64>,
    /// Fixes handed over at or after the first sample's time: within the IMU data's span.
    pub in_span: u32,
    /// The file's first and last fix time [us] ([`FileSummary::span_us`]).
    file_span_us: Option<(u64, u64)>,
}

impl Fixes {
    /// The file's fixes from the first (checked by [`check`] before, which found `summary`).
    pub fn open(path: &CStr, summary: &FileSummary) -> Result<Self, GnssFileError> {
        let mut fixes = Self {
            reader: open(path)?,
            next: None,
            read: 0,
            data_start_us: None,
            in_span: 0,
            file_span_us: summary.span_us,
        };
        fixes.advance()?;
        Ok(fixes)
    }

    fn advance(&mut self) -> Result<(), GnssFileError> {
        self.next = self
            .reader
            .next_fix()
            .map_err(GnssFileError::Read)?
            .map(|r| fix_of(&r));
        self.read += u32::from(self.next.is_some());
        Ok(())
    }

    /// The next fix if it is due at a sample ending at `t_us` [us] over `dt_s` [s] (its time
    /// at or before it).
    pub fn due(
        &mut self,
        t_us: u64,
        dt_s: f32,
    ) -> Result<Option<GnssFixInput<f32>>, GnssFileError> {
        let start = *self
            .data_start_us
            .get_or_insert_with(|| nav_core::gap::data_span_us(t_us, f64::from(dt_s), t_us).0);
        match self.next {
            Some(f) if f.t_us <= t_us => {
                self.advance()?;
                self.in_span += u32::from(f.t_us >= start);
                Ok(Some(f))
            }
            _ => Ok(None),
        }
    }

    /// Fixes not handed over (after the last sample).
    pub fn remaining(&self, total: u32) -> u32 {
        total - self.read + u32::from(self.next.is_some())
    }

    /// The fixes' span and the IMU data's (the start of the first sample's interval to
    /// `last_sample_us`, [`nav_core::gap::data_span_us`]) [us] when the file has fixes and not
    /// one of them lies within the data's span: the run was free-inertial while looking aided
    /// (the harness refuses the same, `host_tests::aided::check_fixes_in_span`).
    pub fn none_in_span(&self, last_sample_us: u64) -> Option<[(u64, u64); 2]> {
        let start = self.data_start_us?;
        let file = self.file_span_us?;
        (self.in_span == 0).then_some([file, (start, last_sample_us)])
    }
}
