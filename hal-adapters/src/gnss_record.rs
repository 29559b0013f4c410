//! The project's binary GNSS fix file (version 1): what the firmware reads through
//! semihosting beside the IMU recording (`--gnss FILE`), and what `nav replay --gnss` reads as
//! well as the text formats. Fixed-size, CRC-protected records of the values the navigation
//! filter takes, in `f64` (the text files' values exactly), so the MCU parses no text and the
//! firmware and the host harness navigate the same numbers.
//!
//! A file is a 32-byte header followed by `fix_count` records of 112 bytes each, all
//! little-endian, nothing after the last record. `docs/gnss-record-format.md` holds the same
//! description.
//!
//! # Header (32 bytes)
//!
//! | offset | size | field        | meaning |
//! | -----: | ---: | ------------ | ------- |
//! |      0 |    8 | `magic`      | `b"NAVGNSS\n"` ([`MAGIC`]) |
//! |      8 |    2 | `version`    | `u16` = 1 ([`VERSION`]) |
//! |     10 |    2 | `header_len` | `u16` = 32 ([`HEADER_LEN`]) |
//! |     12 |    2 | `record_len` | `u16` = 112 ([`RECORD_LEN`]) |
//! |     14 |    2 | `reserved`   | zero |
//! |     16 |    4 | `fix_count`  | `u32`, number of records |
//! |     20 |    8 | `reserved`   | zero |
//! |     28 |    4 | `header_crc` | `u32`, CRC-32/ISO-HDLC of bytes 0..28 |
//!
//! # Record (112 bytes)
//!
//! | offset | size | field             | meaning |
//! | -----: | ---: | ----------------- | ------- |
//! |      0 |    8 | `t_us`            | `u64`, time of the fix on the IMU recording's clock [us] |
//! |      8 |    8 | `lat_rad`         | `f64`, geodetic latitude of the antenna [rad] |
//! |     16 |    8 | `lon_rad`         | `f64`, longitude [rad] |
//! |     24 |    8 | `h_m`             | `f64`, ellipsoidal height [m] |
//! |     32 |   24 | `sigma_ned_m`     | 3 x `f64`, position 1-sigma north, east, down [m] |
//! |     56 |   24 | `v_ned_m_s`       | 3 x `f64`, antenna velocity north, east, down [m/s] |
//! |     80 |   24 | `sigma_v_ned_m_s` | 3 x `f64`, its 1-sigma [m/s] |
//! |    104 |    4 | `flags`           | `u32`: bit 0 set when the fix has a velocity (the velocity fields are zero otherwise); other bits zero |
//! |    108 |    4 | `record_crc`      | `u32`, CRC-32/ISO-HDLC of bytes 0..108 of the record |
//!
//! CRC-32/ISO-HDLC is the recording format's ([`crate::recording`]).
//!
//! # Validation
//!
//! [`decode_header`] checks the magic, the version, the header CRC, the lengths and the
//! reserved bytes; [`GnssReader`] each record's CRC and flags, that the file holds
//! `fix_count` complete records and nothing after them. All are hard errors
//! ([`GnssFormatError`]). A value that is not finite, or a 1-sigma that is not positive, is not
//! a format error: the fix is delivered as it is, for the navigation filter to refuse and count
//! (receivers do output such fixes). Nor is a time not later than the previous fix's (a
//! receiver's log that repeats or swaps an epoch): the navigator skips and counts it as out of
//! order (`nav_core::ins_filter::sequencer::FixQueue::push`).

use core::fmt;

use crc::{CRC_32_ISO_HDLC, Crc};
use embedded_io::Read;

/// The file signature at offset 0.
pub const MAGIC: [u8; 8] = *b"NAVGNSS\n";
/// The format version this module reads and writes.
pub const VERSION: u16 = 1;
/// Length of the header [bytes].
pub const HEADER_LEN: usize = 32;
/// Length of one record [bytes].
pub const RECORD_LEN: usize = 112;

const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

// Header field offsets [bytes].
const H_VERSION: usize = 8;
const H_HEADER_LEN: usize = 10;
const H_RECORD_LEN: usize = 12;
const H_RESERVED_A: usize = 14;
const H_COUNT: usize = 16;
const H_RESERVED_B: usize = 20;
const H_CRC: usize = 28;

// Record field offsets [bytes].
const R_T_US: usize = 0;
const R_LAT: usize = 8;
const R_LON: usize = 16;
const R_H: usize = 24;
const R_SIGMA: usize = 32;
const R_V: usize = 56;
const R_SIGMA_V: usize = 80;
const R_FLAGS: usize = 104;
const R_CRC: usize = 108;

/// [`GnssRecord::flags`] bit: the fix has a velocity.
const FLAG_VELOCITY: u32 = 1;

/// One GNSS fix as the file holds it (SI units, `f64`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssRecord {
    /// Time of the fix on the IMU recording's clock [us].
    pub t_us: u64,
    /// Geodetic latitude of the antenna [rad].
    pub lat_rad: f64,
    /// Longitude [rad].
    pub lon_rad: f64,
    /// Ellipsoidal height [m].
    pub h_m: f64,
    /// Position 1-sigma north, east, down [m].
    pub sigma_ned_m: [f64; 3],
    /// The antenna's velocity north, east, down [m/s] and its 1-sigma [m/s], when the fix
    /// has one.
    pub velocity: Option<([f64; 3], [f64; 3])>,
}

fn put_f64s(bytes: &mut [u8], at: usize, v: &[f64; 3]) {
    for (k, x) in v.iter().enumerate() {
        bytes[at + 8 * k..at + 8 * k + 8].copy_from_slice(&x.to_le_bytes());
    }
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    let mut b = [0; 8];
    b.copy_from_slice(&bytes[at..at + 8]);
    u64::from_le_bytes(b)
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    let mut b = [0; 4];
    b.copy_from_slice(&bytes[at..at + 4]);
    u32::from_le_bytes(b)
}

fn u16_at(bytes: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([bytes[at], bytes[at + 1]])
}

fn f64_at(bytes: &[u8], at: usize) -> f64 {
    f64::from_bits(u64_at(bytes, at))
}

fn f64s_at(bytes: &[u8], at: usize) -> [f64; 3] {
    [
        f64_at(bytes, at),
        f64_at(bytes, at + 8),
        f64_at(bytes, at + 16),
    ]
}

impl GnssRecord {
    /// The record's bytes, CRC included.
    pub fn encode(&self) -> [u8; RECORD_LEN] {
        let mut b = [0_u8; RECORD_LEN];
        b[R_T_US..R_T_US + 8].copy_from_slice(&self.t_us.to_le_bytes());
        b[R_LAT..R_LAT + 8].copy_from_slice(&self.lat_rad.to_le_bytes());
        b[R_LON..R_LON + 8].copy_from_slice(&self.lon_rad.to_le_bytes());
        b[R_H..R_H + 8].copy_from_slice(&self.h_m.to_le_bytes());
        put_f64s(&mut b, R_SIGMA, &self.sigma_ned_m);
        let mut flags = 0;
        if let Some((v, s)) = &self.velocity {
            put_f64s(&mut b, R_V, v);
            put_f64s(&mut b, R_SIGMA_V, s);
            flags |= FLAG_VELOCITY;
        }
        b[R_FLAGS..R_FLAGS + 4].copy_from_slice(&flags.to_le_bytes());
        let crc = CRC32.checksum(&b[..R_CRC]);
        b[R_CRC..].copy_from_slice(&crc.to_le_bytes());
        b
    }

    /// The record of `bytes`: its CRC and flags checked.
    pub fn decode(bytes: &[u8; RECORD_LEN]) -> Result<Self, GnssFormatErrorKind> {
        if CRC32.checksum(&bytes[..R_CRC]) != u32_at(bytes, R_CRC) {
            return Err(GnssFormatErrorKind::RecordCrc);
        }
        let flags = u32_at(bytes, R_FLAGS);
        if flags & !FLAG_VELOCITY != 0 {
            return Err(GnssFormatErrorKind::BadFlags(flags));
        }
        Ok(Self {
            t_us: u64_at(bytes, R_T_US),
            lat_rad: f64_at(bytes, R_LAT),
            lon_rad: f64_at(bytes, R_LON),
            h_m: f64_at(bytes, R_H),
            sigma_ned_m: f64s_at(bytes, R_SIGMA),
            velocity: (flags & FLAG_VELOCITY != 0)
                .then(|| (f64s_at(bytes, R_V), f64s_at(bytes, R_SIGMA_V))),
        })
    }
}

/// The header of a file of `fix_count` records, CRC included.
pub fn encode_header(fix_count: u32) -> [u8; HEADER_LEN] {
    let mut b = [0_u8; HEADER_LEN];
    b[..8].copy_from_slice(&MAGIC);
    b[H_VERSION..H_VERSION + 2].copy_from_slice(&VERSION.to_le_bytes());
    b[H_HEADER_LEN..H_HEADER_LEN + 2].copy_from_slice(&(HEADER_LEN as u16).to_le_bytes());
    b[H_RECORD_LEN..H_RECORD_LEN + 2].copy_from_slice(&(RECORD_LEN as u16).to_le_bytes());
    b[H_COUNT..H_COUNT + 4].copy_from_slice(&fix_count.to_le_bytes());
    let crc = CRC32.checksum(&b[..H_CRC]);
    b[H_CRC..].copy_from_slice(&crc.to_le_bytes());
    b
}

/// The fix count of a header, its fields checked.
pub fn decode_header(b: &[u8; HEADER_LEN]) -> Result<u32, GnssFormatErrorKind> {
    if b[..8] != MAGIC {
        return Err(GnssFormatErrorKind::BadMagic);
    }
    let version = u16_at(b, H_VERSION);
    if version != VERSION {
        return Err(GnssFormatErrorKind::UnsupportedVersion(version));
    }
    if CRC32.checksum(&b[..H_CRC]) != u32_at(b, H_CRC) {
        return Err(GnssFormatErrorKind::HeaderCrc);
    }
    if usize::from(u16_at(b, H_HEADER_LEN)) != HEADER_LEN {
        return Err(GnssFormatErrorKind::BadHeader("header length is not 32"));
    }
    if usize::from(u16_at(b, H_RECORD_LEN)) != RECORD_LEN {
        return Err(GnssFormatErrorKind::BadHeader("record length is not 112"));
    }
    if u16_at(b, H_RESERVED_A) != 0 || u64_at(b, H_RESERVED_B) != 0 {
        return Err(GnssFormatErrorKind::BadHeader(
            "reserved bytes are not zero",
        ));
    }
    Ok(u32_at(b, H_COUNT))
}

/// What is wrong with a GNSS fix file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GnssFormatErrorKind {
    /// The file does not start with [`MAGIC`].
    BadMagic,
    /// The header's version (carried) is not [`VERSION`].
    UnsupportedVersion(u16),
    /// A header field is invalid (the text says which).
    BadHeader(&'static str),
    /// The header CRC does not match bytes 0..28.
    HeaderCrc,
    /// A record's CRC does not match its bytes 0..108.
    RecordCrc,
    /// A record's flags (carried) have bits other than bit 0.
    BadFlags(u32),
    /// The file ends inside the header or before `fix_count` complete records.
    Truncated,
    /// There are bytes after the last record.
    TrailingData,
}

impl fmt::Display for GnssFormatErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BadMagic => {
                f.write_str("not a NAVGNSS fix file: the file does not start with \"NAVGNSS\\n\"")
            }
            Self::UnsupportedVersion(v) => write!(
                f,
                "unsupported GNSS file version {v} (this reader supports version {VERSION})"
            ),
            Self::BadHeader(what) => write!(f, "invalid header: {what}"),
            Self::HeaderCrc => f.write_str("header CRC mismatch (corrupt header)"),
            Self::RecordCrc => f.write_str("record CRC mismatch (corrupt data)"),
            Self::BadFlags(flags) => write!(f, "unknown flags {flags:#x}"),
            Self::Truncated => f.write_str("file ends early (truncated)"),
            Self::TrailingData => f.write_str("unexpected data after the last record"),
        }
    }
}

/// A GNSS file error and where it is: `Display` gives e.g. `GNSS byte offset 256 (fix 2):
/// record CRC mismatch (corrupt data)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GnssFormatError {
    /// What is wrong.
    pub kind: GnssFormatErrorKind,
    /// Byte offset where the problem starts (0 in the header, the record's start, or the end
    /// of the last record for trailing data).
    pub offset: u64,
    /// Index of the fix, if the problem is in a record.
    pub fix: Option<u32>,
}

impl fmt::Display for GnssFormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "GNSS byte offset {}", self.offset)?;
        if let Some(i) = self.fix {
            write!(f, " (fix {i})")?;
        }
        write!(f, ": {}", self.kind)
    }
}

impl core::error::Error for GnssFormatError {}

/// Error of [`GnssReader`]: the byte source failed, or the file is invalid.
#[derive(Debug)]
pub enum GnssReadError<E> {
    /// The byte source failed.
    Io(E),
    /// The file is invalid.
    Format(GnssFormatError),
}

impl<E: fmt::Debug> fmt::Display for GnssReadError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io(e) => write!(f, "GNSS file read error: {e:?}"),
            Self::Format(e) => write!(f, "{e}"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for GnssReadError<E> {}

/// Reads the fixes of a GNSS file one at a time (no allocation), checking every rule of the
/// module docs.
pub struct GnssReader<R: Read> {
    reader: R,
    count: u32,
    next: u32,
    ended: bool,
}

/// Fills `buf` from `reader`: `Ok(n)` with `n < buf.len()` at the end of the data.
fn read_full<R: Read>(reader: &mut R, buf: &mut [u8]) -> Result<usize, R::Error> {
    let mut n = 0;
    while n < buf.len() {
        match reader.read(&mut buf[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n)
}

impl<R: Read> GnssReader<R> {
    /// Reads and checks the header.
    pub fn new(mut reader: R) -> Result<Self, GnssReadError<R::Error>> {
        let mut h = [0_u8; HEADER_LEN];
        let n = read_full(&mut reader, &mut h).map_err(GnssReadError::Io)?;
        let error = |kind| {
            GnssReadError::Format(GnssFormatError {
                kind,
                offset: 0,
                fix: None,
            })
        };
        if n < HEADER_LEN {
            // A short file that is not a GNSS file at all says so.
            let kind = if n >= 8 && h[..8] != MAGIC {
                GnssFormatErrorKind::BadMagic
            } else {
                GnssFormatErrorKind::Truncated
            };
            return Err(error(kind));
        }
        let count = decode_header(&h).map_err(error)?;
        Ok(Self {
            reader,
            count,
            next: 0,
            ended: false,
        })
    }

    /// The number of fixes the header announces.
    pub fn fix_count(&self) -> u32 {
        self.count
    }

    /// The next fix (`Ok(None)` after the last one, once the end of the file is checked).
    pub fn next_fix(&mut self) -> Result<Option<GnssRecord>, GnssReadError<R::Error>> {
        let offset = HEADER_LEN as u64 + u64::from(self.next) * RECORD_LEN as u64;
        let error = |kind, fix| GnssReadError::Format(GnssFormatError { kind, offset, fix });
        if self.next == self.count {
            if !self.ended {
                let mut extra = [0_u8; 1];
                if read_full(&mut self.reader, &mut extra).map_err(GnssReadError::Io)? != 0 {
                    return Err(error(GnssFormatErrorKind::TrailingData, None));
                }
                self.ended = true;
            }
            return Ok(None);
        }
        let index = self.next;
        let mut b = [0_u8; RECORD_LEN];
        if read_full(&mut self.reader, &mut b).map_err(GnssReadError::Io)? < RECORD_LEN {
            return Err(error(GnssFormatErrorKind::Truncated, Some(index)));
        }
        let r = GnssRecord::decode(&b).map_err(|k| error(k, Some(index)))?;
        self.next += 1;
        Ok(Some(r))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;

    fn fix(t_us: u64, velocity: bool) -> GnssRecord {
        GnssRecord {
            t_us,
            lat_rad: 0.702_398_163_397_448_3,
            lon_rad: -0.130_899_693_899_574_7,
            h_m: 251.25,
            sigma_ned_m: [0.5, 0.5, f64::NAN],
            velocity: velocity.then_some(([10.0, -0.25, 0.0], [0.05, 0.05, 0.1])),
        }
    }

    fn file(fixes: &[GnssRecord]) -> [u8; HEADER_LEN + 3 * RECORD_LEN] {
        let mut b = [0_u8; HEADER_LEN + 3 * RECORD_LEN];
        b[..HEADER_LEN].copy_from_slice(&encode_header(fixes.len() as u32));
        for (i, f) in fixes.iter().enumerate() {
            let at = HEADER_LEN + i * RECORD_LEN;
            b[at..at + RECORD_LEN].copy_from_slice(&f.encode());
        }
        b
    }

    #[test]
    fn records_round_trip_bit_for_bit() {
        let fixes = [
            fix(1_000_000, true),
            fix(2_000_000, false),
            fix(2_100_000, true),
        ];
        let bytes = file(&fixes);
        let mut r = GnssReader::new(&bytes[..]).unwrap();
        assert_eq!(r.fix_count(), 3);
        for f in &fixes {
            let got = r.next_fix().unwrap().unwrap();
            // NaN sigmas are kept as they are: compare the bits.
            assert_eq!(got.encode(), f.encode());
            assert_eq!(got.velocity.is_some(), f.velocity.is_some());
        }
        assert!(r.next_fix().unwrap().is_none());
        assert!(r.next_fix().unwrap().is_none());
    }

    #[test]
    fn damaged_files_are_refused_with_the_place() {
        let fixes = [
            fix(1_000_000, true),
            fix(2_000_000, false),
            fix(3_000_000, true),
        ];
        let good = file(&fixes);
        let read_all = |bytes: &[u8]| -> Result<u32, GnssFormatError> {
            let mut r = GnssReader::new(bytes).map_err(|e| match e {
                GnssReadError::Format(e) => e,
                GnssReadError::Io(_) => unreachable!(),
            })?;
            let mut n = 0;
            loop {
                match r.next_fix() {
                    Ok(Some(_)) => n += 1,
                    Ok(None) => return Ok(n),
                    Err(GnssReadError::Format(e)) => return Err(e),
                    Err(GnssReadError::Io(_)) => unreachable!(),
                }
            }
        };
        assert_eq!(read_all(&good), Ok(3));
        let mut flipped = good;
        flipped[HEADER_LEN + RECORD_LEN + 20] ^= 1;
        let e = read_all(&flipped).unwrap_err();
        assert_eq!((e.kind, e.fix), (GnssFormatErrorKind::RecordCrc, Some(1)));
        assert_eq!(
            e.to_string(),
            "GNSS byte offset 144 (fix 1): record CRC mismatch (corrupt data)"
        );
        let e = read_all(&good[..good.len() - 5]).unwrap_err();
        assert_eq!((e.kind, e.fix), (GnssFormatErrorKind::Truncated, Some(2)));
        let mut long = [0_u8; HEADER_LEN + 3 * RECORD_LEN + 1];
        long[..good.len()].copy_from_slice(&good);
        assert_eq!(
            read_all(&long).unwrap_err().kind,
            GnssFormatErrorKind::TrailingData
        );
        let e = read_all(b"t_s,lat_deg,lon_deg,h_m,sigma_n_m,sigma_e_m,sigma_d_m\n").unwrap_err();
        assert_eq!(e.kind, GnssFormatErrorKind::BadMagic);
        assert_eq!(
            read_all(b"NAVGNSS\n").unwrap_err().kind,
            GnssFormatErrorKind::Truncated
        );
        let mut header = good;
        header[3] = b'X';
        assert_eq!(
            read_all(&header).unwrap_err().kind,
            GnssFormatErrorKind::BadMagic
        );
        let mut header = good;
        header[H_COUNT] = 2;
        assert_eq!(
            read_all(&header).unwrap_err().kind,
            GnssFormatErrorKind::HeaderCrc
        );
        // A repeated or earlier time is delivered: the navigator skips and counts it.
        let unordered = [
            fix(1_000_000, true),
            fix(1_000_000, true),
            fix(500_000, false),
        ];
        let bytes = file(&unordered);
        let mut r = GnssReader::new(&bytes[..]).unwrap();
        for f in unordered {
            let read = r.next_fix().unwrap().unwrap();
            assert_eq!((read.t_us, read.velocity), (f.t_us, f.velocity));
        }
        assert_eq!(r.next_fix().unwrap(), None);
        // Unknown flags.
        let mut r = fix(1, false).encode();
        r[R_FLAGS] = 2;
        let crc = CRC32.checksum(&r[..R_CRC]);
        r[R_CRC..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(
            GnssRecord::decode(&r),
            Err(GnssFormatErrorKind::BadFlags(2))
        );
    }
}
