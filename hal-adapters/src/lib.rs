//! `hal-adapters`: the sensor layer between IMU hardware (or recordings) and the navigation core.
//!
//! - [`sample`]: the IMU sample type every source produces ([`ImuSample`], [`SampleFlags`]).
//! - [`Imu`]: the trait of sample sources (SPI drivers, replays).
//! - [`recording`]: the project's binary recording format, its reader ([`recording::Replay`]) and
//!   writer.
//! - [`gnss_record`]: the binary GNSS fix file read beside a recording (the firmware's
//!   `--gnss`), its reader ([`gnss_record::GnssReader`]) and encoders.
//! - [`io`]: byte sources for replays: slices (always), semihosting files (feature
//!   `semihosting`), std files (feature `std`).
//! - [`drivers`]: SPI IMU drivers (ADIS16505/ADIS16465, ICM-42688-P, BMI088) over
//!   `embedded-hal` 1.0.
//! - [`sim`]: simulated IMUs on the bus, answering from a sample source, so the drivers run
//!   without hardware (in QEMU and on the host).
//! - [`protocol`]: the board's binary output protocol (frames, decoder, status model, health
//!   and vibration metric, device configuration).
//!
//! `no_std`, no allocation. Only [`protocol`] uses `nav-core`: its solution frame carries
//! nav-core's output rows and its configuration is validated by nav-core's run checks.
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(unsafe_code)]
// Units are written `[m/s]` in docs (project convention), which rustdoc would read as links.
#![allow(rustdoc::broken_intra_doc_links)]
#![warn(missing_docs)]

pub mod drivers;
pub mod gnss_record;
pub mod io;
pub mod protocol;
pub mod recording;
pub mod sample;
pub mod sim;

pub use sample::{ImuSample, Motion, SampleFlags};

/// A source of IMU samples: an SPI driver or a replayed recording.
pub trait Imu {
    /// Hard failure of the source (bus error, corrupt recording...). Data-quality problems are
    /// [`SampleFlags`] on the sample instead.
    type Error: core::fmt::Debug + core::fmt::Display;

    /// Reads the next sample: `Ok(None)` at the end of a recording.
    fn read_sample(&mut self) -> Result<Option<ImuSample>, Self::Error>;
}
