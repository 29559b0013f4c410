//! Byte sources (and sinks) for replays and logs, all as [`embedded_io`] traits.
//!
//! - **Slices, always:** `&[u8]` already implements [`embedded_io::Read`] (with
//!   `Error = core::convert::Infallible`), so a recording in memory (e.g. `include_bytes!`)
//!   replays with `Replay::new(&bytes[..])`.
//! - **[`Buffered`], always:** reads its inner source in chunks of `N` bytes, so that an
//!   expensive source (one semihosting call per read) is asked once per `N` bytes rather than
//!   once per 40-byte record.
//! - **`SemihostingFile`, feature `semihosting`:** a host file opened through ARM semihosting
//!   (QEMU, debug probes), readable, writable and usable with `write!` for CSV lines. Builds
//!   only for targets the `semihosting` crate supports (e.g. `thumbv7em-none-eabihf`).
//! - **`StdReader`, feature `std`:** a buffered [`std::fs::File`] behind
//!   [`embedded_io_adapters::std::FromStd`], for the host harness; `open_std_file` opens a
//!   recording in one call.
//!
//! ```
//! use hal_adapters::{Imu, io::Buffered, recording::Replay};
//! # use hal_adapters::recording::{Header, Kind, Record, Writer};
//! # let mut file = [0u8; 48 + 40];
//! # let header = Header { kind: Kind::Rates, rate_hz: 100.0, t0_ns: 0, sample_count: 1 };
//! # let mut writer = Writer::new(&mut file[..], header).unwrap();
//! # let record = Record { t_ns: 10_000_000, gyro: [0.0; 3], accel: [0.0; 3], temperature_c: f32::NAN };
//! # writer.write_record(&record).unwrap();
//! # writer.finish().unwrap();
//! let bytes: &[u8] = &file;
//! let mut replay = Replay::new(Buffered::<_, 512>::new(bytes))?;
//! while let Some(sample) = replay.read_sample()? {
//!     assert!(sample.flags.usable());
//! }
//! assert_eq!(replay.stats().samples, 1);
//! # Ok::<(), hal_adapters::recording::ReplayError<core::convert::Infallible>>(())
//! ```

use embedded_io::{BufRead, ErrorType, Read};

/// A reader that reads its inner reader in chunks of `N` bytes.
///
/// A read larger than `N` while the buffer is empty goes straight to the inner reader (nothing
/// to gain from copying). Also implements [`embedded_io::BufRead`].
pub struct Buffered<R, const N: usize> {
    inner: R,
    buf: [u8; N],
    /// Next unread byte in `buf`.
    pos: usize,
    /// End of the valid bytes in `buf`.
    len: usize,
}

impl<R, const N: usize> Buffered<R, N> {
    /// Wraps `inner` with an empty buffer.
    pub fn new(inner: R) -> Self {
        Buffered {
            inner,
            buf: [0; N],
            pos: 0,
            len: 0,
        }
    }

    /// The inner reader.
    pub fn inner(&self) -> &R {
        &self.inner
    }

    /// The bytes read from the inner reader but not yet consumed.
    pub fn buffered(&self) -> &[u8] {
        &self.buf[self.pos..self.len]
    }

    /// Gives the inner reader back; bytes still buffered ([`Buffered::buffered`]) are lost.
    pub fn into_inner(self) -> R {
        self.inner
    }
}

impl<R: ErrorType, const N: usize> ErrorType for Buffered<R, N> {
    type Error = R::Error;
}

impl<R: Read, const N: usize> Read for Buffered<R, N> {
    fn read(&mut self, out: &mut [u8]) -> Result<usize, Self::Error> {
        if out.is_empty() {
            return Ok(0);
        }
        if self.pos == self.len && out.len() >= N {
            let n = self.inner.read(out)?;
            return Ok(n.min(out.len()));
        }
        let available = self.fill_buf()?;
        let n = available.len().min(out.len());
        out[..n].copy_from_slice(&available[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl<R: Read, const N: usize> BufRead for Buffered<R, N> {
    fn fill_buf(&mut self) -> Result<&[u8], Self::Error> {
        if self.pos == self.len {
            let n = self.inner.read(&mut self.buf)?;
            self.pos = 0;
            // `min` guards against a source that claims more than it was given.
            self.len = n.min(N);
        }
        Ok(&self.buf[self.pos..self.len])
    }

    fn consume(&mut self, amt: usize) {
        self.pos = (self.pos + amt).min(self.len);
    }
}

#[cfg(feature = "semihosting")]
pub use self::semihosting_file::{SemihostingError, SemihostingFile};

#[cfg(feature = "semihosting")]
mod semihosting_file {
    use core::{ffi::CStr, fmt};

    use semihosting::io::{Read as _, Write as _};

    /// A host file through ARM semihosting (feature `semihosting`; QEMU or a debug probe).
    ///
    /// Every `read`/`write` is one semihosting call (a trap to the debugger, slow): wrap readers
    /// in [`super::Buffered`], and write whole lines.
    #[derive(Debug)]
    pub struct SemihostingFile(pub semihosting::fs::File);

    impl SemihostingFile {
        /// Opens a host file for reading.
        pub fn open(path: &CStr) -> Result<Self, semihosting::io::Error> {
            semihosting::fs::File::open(path).map(SemihostingFile)
        }

        /// Creates (or truncates) a host file for writing.
        pub fn create(path: &CStr) -> Result<Self, semihosting::io::Error> {
            semihosting::fs::File::create(path).map(SemihostingFile)
        }
    }

    /// I/O error of a [`SemihostingFile`]: a [`semihosting::io::Error`] implementing
    /// [`embedded_io::Error`].
    #[derive(Debug)]
    pub struct SemihostingError(pub semihosting::io::Error);

    impl From<semihosting::io::Error> for SemihostingError {
        fn from(error: semihosting::io::Error) -> Self {
            SemihostingError(error)
        }
    }

    impl fmt::Display for SemihostingError {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            write!(f, "semihosting I/O error: {}", self.0)
        }
    }

    impl core::error::Error for SemihostingError {}

    /// So that `ReplayError<SemihostingError>` can be logged with defmt.
    #[cfg(feature = "defmt")]
    impl defmt::Format for SemihostingError {
        fn format(&self, f: defmt::Formatter<'_>) {
            defmt::write!(
                f,
                "semihosting I/O error: {}",
                defmt::Display2Format(&self.0)
            );
        }
    }

    impl embedded_io::Error for SemihostingError {
        fn kind(&self) -> embedded_io::ErrorKind {
            use embedded_io::ErrorKind as E;
            use semihosting::io::ErrorKind as S;
            match self.0.kind() {
                S::NotFound => E::NotFound,
                S::PermissionDenied => E::PermissionDenied,
                S::AlreadyExists => E::AlreadyExists,
                S::InvalidInput => E::InvalidInput,
                S::InvalidData => E::InvalidData,
                S::TimedOut => E::TimedOut,
                S::Interrupted => E::Interrupted,
                S::Unsupported => E::Unsupported,
                S::OutOfMemory => E::OutOfMemory,
                S::WriteZero => E::WriteZero,
                _ => E::Other,
            }
        }
    }

    impl embedded_io::ErrorType for SemihostingFile {
        type Error = SemihostingError;
    }

    impl embedded_io::Read for SemihostingFile {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
            Ok(self.0.read(buf)?)
        }
    }

    impl embedded_io::Write for SemihostingFile {
        fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
            match self.0.write(buf)? {
                // embedded-io: `Ok(0)` only for an empty buffer.
                0 if !buf.is_empty() => {
                    Err(semihosting::io::Error::from(semihosting::io::ErrorKind::WriteZero).into())
                }
                n => Ok(n),
            }
        }

        /// Semihosting writes are unbuffered: nothing to flush.
        fn flush(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
    }

    /// For `write!(file, ...)` of text (CSV lines); any I/O error becomes [`fmt::Error`].
    impl fmt::Write for SemihostingFile {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            self.0.write_all(s.as_bytes()).map_err(|_| fmt::Error)
        }
    }
}

/// A buffered host file as an [`embedded_io::Read`] (feature `std`):
/// `StdReader::new(BufReader::new(file))`.
#[cfg(feature = "std")]
pub type StdReader = embedded_io_adapters::std::FromStd<std::io::BufReader<std::fs::File>>;

/// Opens a recording file on the host and reads its header (feature `std`).
///
/// Opening errors come back as [`crate::recording::ReplayError::Io`]; with `?` in a function
/// returning [`std::io::Result`] every error converts to a [`std::io::Error`] (format errors as
/// [`std::io::ErrorKind::InvalidData`]).
#[cfg(feature = "std")]
pub fn open_std_file(
    path: &std::path::Path,
) -> Result<crate::recording::Replay<StdReader>, crate::recording::ReplayError<std::io::Error>> {
    let file = std::fs::File::open(path).map_err(crate::recording::ReplayError::Io)?;
    crate::recording::Replay::new(StdReader::new(std::io::BufReader::new(file)))
}

#[cfg(test)]
mod tests {
    extern crate std;

    use core::convert::Infallible;
    use std::vec::Vec;

    use super::*;

    /// Hands out at most `max` bytes per read and counts the reads.
    struct Trickle<'a> {
        data: &'a [u8],
        max: usize,
        reads: usize,
    }

    impl ErrorType for Trickle<'_> {
        type Error = Infallible;
    }

    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
            self.reads += 1;
            let n = buf.len().min(self.max).min(self.data.len());
            buf[..n].copy_from_slice(&self.data[..n]);
            self.data = &self.data[n..];
            Ok(n)
        }
    }

    fn data(len: usize) -> Vec<u8> {
        (0..len).map(|i| (i * 7 + 3) as u8).collect()
    }

    /// Reads everything with reads of `chunk` bytes.
    fn drain<R: Read>(reader: &mut R, chunk: usize) -> Vec<u8> {
        let mut out = Vec::new();
        let mut buf = std::vec![0u8; chunk];
        loop {
            match reader.read(&mut buf) {
                Ok(0) => return out,
                Ok(n) => out.extend_from_slice(&buf[..n]),
                Err(_) => panic!("read failed"),
            }
        }
    }

    #[test]
    fn slice_is_a_reader() {
        let bytes = data(100);
        let mut reader: &[u8] = &bytes;
        assert_eq!(drain(&mut reader, 40), bytes);
    }

    #[test]
    fn buffered_reads_inner_in_chunks() {
        let bytes = data(1000);
        let mut reader = Buffered::<_, 512>::new(Trickle {
            data: &bytes,
            max: usize::MAX,
            reads: 0,
        });
        assert_eq!(drain(&mut reader, 40), bytes);
        // 512 + 488 + the read that finds EOF.
        assert_eq!(reader.inner().reads, 3);
    }

    #[test]
    fn buffered_with_short_inner_reads() {
        let bytes = data(1000);
        for max in [1, 3, 39, 40, 41, 511, 512, 513] {
            for chunk in [1, 7, 40, 512, 600] {
                let mut reader = Buffered::<_, 512>::new(Trickle {
                    data: &bytes,
                    max,
                    reads: 0,
                });
                assert_eq!(drain(&mut reader, chunk), bytes, "max {max}, chunk {chunk}");
            }
        }
    }

    #[test]
    fn buffered_large_read_bypasses_buffer() {
        let bytes = data(100);
        let mut reader = Buffered::<_, 16>::new(Trickle {
            data: &bytes,
            max: usize::MAX,
            reads: 0,
        });
        let mut small = [0u8; 4];
        assert_eq!(reader.read(&mut small), Ok(4));
        assert_eq!(reader.buffered(), &bytes[4..16]);
        // Buffered bytes first, then straight from the inner reader.
        let mut big = [0u8; 32];
        assert_eq!(reader.read(&mut big), Ok(12));
        assert_eq!(reader.read(&mut big), Ok(32));
        assert_eq!(&big[..], &bytes[16..48]);
        assert_eq!(reader.inner().reads, 2);
        assert_eq!(reader.read(&mut []), Ok(0));
    }

    #[test]
    fn buffered_bufread() {
        let bytes = data(50);
        let mut reader = Buffered::<_, 8>::new(Trickle {
            data: &bytes,
            max: 5,
            reads: 0,
        });
        assert_eq!(reader.fill_buf(), Ok(&bytes[..5]));
        reader.consume(3);
        assert_eq!(reader.fill_buf(), Ok(&bytes[3..5]));
        reader.consume(100);
        assert_eq!(reader.fill_buf(), Ok(&bytes[5..10]));
    }

    #[test]
    fn zero_sized_buffer_passes_through() {
        let bytes = data(100);
        let mut reader = Buffered::<_, 0>::new(Trickle {
            data: &bytes,
            max: 9,
            reads: 0,
        });
        assert_eq!(drain(&mut reader, 40), bytes);
    }

    #[cfg(feature = "std")]
    #[test]
    fn std_file_replay() {
        use crate::Imu;
        use crate::recording::{Header, Kind, Record, ReplayError, Writer};

        let header = Header {
            kind: Kind::Increments,
            rate_hz: 200.0,
            t0_ns: 0,
            sample_count: 2,
        };
        let sink = embedded_io_adapters::std::FromStd::new(Vec::new());
        let mut writer = Writer::new(sink, header).unwrap();
        for t_ns in [5_000_000, 10_000_000] {
            let record = Record {
                t_ns,
                gyro: [0.0; 3],
                accel: [0.0, 0.0, -0.05],
                temperature_c: 20.0,
            };
            writer.write_record(&record).unwrap();
        }
        let bytes = writer.finish().unwrap().into_inner();

        let dir = std::env::temp_dir().join(std::format!("hal-adapters-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("two.navimu");
        std::fs::write(&path, &bytes).unwrap();

        let mut replay = open_std_file(&path).unwrap();
        assert_eq!(*replay.header(), header);
        assert_eq!(replay.read_sample().unwrap().unwrap().seq, 0);
        assert_eq!(replay.read_sample().unwrap().unwrap().seq, 1);
        assert!(replay.read_sample().unwrap().is_none());

        // The type the host harness names.
        let file = std::fs::File::open(&path).unwrap();
        let replay = crate::recording::Replay::new(StdReader::new(std::io::BufReader::new(file)));
        assert_eq!(replay.unwrap().header().sample_count, 2);

        let missing = open_std_file(&dir.join("missing.navimu"));
        assert!(matches!(missing, Err(ReplayError::Io(_))));

        std::fs::write(&path, &bytes[..60]).unwrap();
        let mut replay = open_std_file(&path).unwrap();
        let error = std::io::Error::from(replay.read_sample().unwrap_err());
        assert_eq!(error.kind(), std::io::ErrorKind::InvalidData);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
