//! The error type shared by the SPI IMU drivers.

use core::fmt;

/// A hard failure of an SPI IMU driver. Data quality (saturation, stale or missed samples,
/// device diagnostics on a delivered sample) is reported as [`crate::SampleFlags`] on the sample
/// instead.
///
/// `E` is the error of the [`embedded_hal::spi::SpiDevice`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The SPI bus (or chip-select) operation failed.
    Spi(E),
    /// The device's identification register does not hold the expected value.
    WrongId {
        /// The value the configured model has.
        expected: u16,
        /// The value read.
        found: u16,
    },
    /// The burst frame's checksum does not match its contents (corrupt transfer).
    Checksum {
        /// The checksum the frame carried.
        received: u16,
        /// The checksum of the bytes received.
        computed: u16,
    },
    /// Every byte of the frame was zero: the device did not drive MISO (not powered, in reset,
    /// not selected). An all-zero frame carries a valid checksum, so it is rejected explicitly.
    ZeroFrame,
    /// A FIFO packet header is not the configured packet format: the byte stream is out of step
    /// (the FIFO is flushed by [`crate::drivers::icm42688::Icm42688::read_sample`]).
    BadFrame,
    /// The device does not hold a full output sample yet (FIFO below the watermark); nothing was
    /// lost, read again at the next data-ready.
    NotReady,
    /// The device reported a fault where the driver needs a pass (self-test); carries the raw
    /// diagnostic register.
    DeviceFault(u16),
    /// The device FIFO overflowed: samples were lost (the FIFO has been flushed when
    /// [`crate::drivers::icm42688::Icm42688::read_sample`] returns this).
    FifoOverflow,
    /// The device did not become ready within its specified start-up time.
    Timeout,
}

impl<E> Error<E> {
    /// `true` for failures of one read that the next data-ready may not repeat (corrupt or
    /// zero frame, FIFO not filled yet, FIFO overflow or misalignment after the flush); the
    /// driver has counted them in its [`crate::drivers::Health`]. Bus errors, wrong IDs,
    /// device faults and time-outs are not transient.
    pub fn is_transient(&self) -> bool {
        matches!(
            self,
            Error::Checksum { .. }
                | Error::ZeroFrame
                | Error::BadFrame
                | Error::NotReady
                | Error::FifoOverflow
        )
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Spi(e) => write!(f, "SPI bus error: {e:?}"),
            Error::WrongId { expected, found } => write!(
                f,
                "wrong device ID: expected {expected:#06x}, read {found:#06x}"
            ),
            Error::Checksum { received, computed } => write!(
                f,
                "burst checksum mismatch: frame says {received:#06x}, bytes sum to {computed:#06x}"
            ),
            Error::ZeroFrame => write!(f, "all-zero burst frame (device not answering)"),
            Error::BadFrame => write!(f, "unexpected FIFO packet header (stream out of step)"),
            Error::NotReady => write!(f, "no complete sample in the device yet"),
            Error::DeviceFault(bits) => write!(f, "device reports a fault: {bits:#06x}"),
            Error::FifoOverflow => write!(f, "device FIFO overflow: samples lost"),
            Error::Timeout => write!(f, "device not ready within its start-up time"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
