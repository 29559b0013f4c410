//! The messages ([`Message::write_payload`], [`Message::read_payload`]; byte layouts in
//! `docs/protocol.md`).

use super::config::{CONFIG_LEN, DeviceConfig, ReasonCode};
use super::status::{HealthCounters, NavStatus, StatusFlags};
use super::vibration::VibrationLevels;
use super::wire::Overflow;
use crate::sample::ImuSample;
use nav_core::alignment::machine::Stage;
use nav_core::ins_filter::aiding::AidResult;
use nav_core::output::Row;
use nav_core::scalar::Scalar;

/// Message identifiers (one byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum MessageId {
    /// [`NavSolution`].
    NavSolution = 0x01,
    /// [`RawIncrements`].
    RawIncrements = 0x02,
    /// [`HealthReport`].
    Health = 0x03,
    /// [`AlignProgress`].
    AlignProgress = 0x04,
    /// [`AidingEvent`].
    AidingEvent = 0x05,
    /// [`EndOfRun`].
    EndOfRun = 0x06,
    /// A [`DeviceConfig`] (host to board).
    Config = 0x10,
    /// [`ConfigAck`] (board to host).
    ConfigAck = 0x11,
}

impl MessageId {
    /// Every message, in id order.
    pub const ALL: [Self; 8] = [
        Self::NavSolution,
        Self::RawIncrements,
        Self::Health,
        Self::AlignProgress,
        Self::AidingEvent,
        Self::EndOfRun,
        Self::Config,
        Self::ConfigAck,
    ];

    /// The message of a wire id.
    pub fn from_id(id: u8) -> Option<Self> {
        Self::ALL.into_iter().find(|m| *m as u8 == id)
    }

    /// Payload length [bytes] (every message has a fixed length).
    pub fn payload_len(self) -> usize {
        match self {
            Self::NavSolution => 120,
            Self::RawIncrements => 46,
            Self::Health => 91,
            Self::AlignProgress => 17,
            Self::AidingEvent => 14,
            Self::EndOfRun => 4,
            Self::Config => CONFIG_LEN,
            Self::ConfigAck => 3,
        }
    }

    /// Name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::NavSolution => "nav-solution",
            Self::RawIncrements => "raw-increments",
            Self::Health => "health",
            Self::AlignProgress => "align-progress",
            Self::AidingEvent => "aiding-event",
            Self::EndOfRun => "end-of-run",
            Self::Config => "config",
            Self::ConfigAck => "config-ack",
        }
    }

    /// Position in [`Self::ALL`] (for per-message counters).
    pub fn index(self) -> usize {
        Self::ALL.iter().position(|m| *m == self).unwrap_or(0)
    }
}

/// A navigation solution: one row of the solution log, with the status model's status.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavSolution {
    /// The row as nav-core produced it (an aided row carries the filter's 1-sigma and status).
    pub row: Row,
    /// The wire status.
    pub status: NavStatus,
    /// The status flags.
    pub flags: StatusFlags,
}

/// One IMU sample as the sensor delivered it (increments, at the sensor's rate).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawIncrements {
    /// The sample (rates are sent as increments: `rate * dt`).
    pub sample: ImuSample,
}

/// Health and status.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HealthReport {
    /// Time [us].
    pub t_us: u64,
    /// The wire status.
    pub status: NavStatus,
    /// The status flags.
    pub flags: StatusFlags,
    /// The counters.
    pub counters: HealthCounters,
    /// The vibration metric of the last window.
    pub vibration: VibrationLevels,
}

/// Alignment progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AlignProgress {
    /// Time [us].
    pub t_us: u64,
    /// The alignment's stage.
    pub stage: Stage,
    /// Samples used so far.
    pub samples: u32,
    /// Samples of the whole window.
    pub samples_total: u32,
}

/// Which aid a measurement came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Aid {
    /// GNSS position.
    Position = 0,
    /// GNSS velocity.
    Velocity = 1,
}

/// What became of an aiding measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum AidOutcome {
    /// Used by the filter.
    Accepted = 0,
    /// Refused by the chi-square innovation gate.
    RejectedGate = 1,
    /// Refused: not finite, non-positive 1-sigma, degenerate innovation covariance.
    Invalid = 2,
    /// Refused: applied too late after its time tag.
    Late = 3,
    /// Refused: older than the previous fix, or the queue full.
    OutOfOrder = 4,
}

impl AidingEvent {
    /// The event of the filter's answer `result` to a fix of `aid` time-tagged `t_us` [us].
    pub fn of<T: Scalar>(t_us: u64, aid: Aid, result: &AidResult<T>) -> Self {
        let (outcome, nis) = match result {
            AidResult::Accepted { nis } => (AidOutcome::Accepted, nis.to_f64() as f32),
            AidResult::Rejected { nis } => (AidOutcome::RejectedGate, nis.to_f64() as f32),
            AidResult::Invalid => (AidOutcome::Invalid, f32::NAN),
        };
        Self {
            t_us,
            aid,
            outcome,
            nis,
        }
    }
}

/// An aiding measurement accepted or refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AidingEvent {
    /// Time of the fix [us].
    pub t_us: u64,
    /// The aid.
    pub aid: Aid,
    /// The outcome.
    pub outcome: AidOutcome,
    /// Normalised innovation squared [-] (NaN when not computed).
    pub nis: f32,
}

/// The run ended normally after `rows` solution rows (the solution log's end record).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EndOfRun {
    /// Solution rows sent.
    pub rows: u32,
}

/// The board's answer to a configuration frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConfigAck {
    /// Sequence number of the configuration frame answered.
    pub config_seq: u16,
    /// `None`: accepted; else why it was refused.
    pub refused: Option<ReasonCode>,
}

/// Any message.
///
/// The configuration makes it 408 bytes; boxing is not an option without an allocator, and a
/// message lives on the stack only while it is encoded or handed over.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Message {
    /// See [`NavSolution`].
    NavSolution(NavSolution),
    /// See [`RawIncrements`].
    RawIncrements(RawIncrements),
    /// See [`HealthReport`].
    Health(HealthReport),
    /// See [`AlignProgress`].
    AlignProgress(AlignProgress),
    /// See [`AidingEvent`].
    AidingEvent(AidingEvent),
    /// See [`EndOfRun`].
    EndOfRun(EndOfRun),
    /// See [`DeviceConfig`].
    Config(DeviceConfig),
    /// See [`ConfigAck`].
    ConfigAck(ConfigAck),
}

/// Why a payload was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PayloadError {
    /// A field holds a value outside its enumeration (its name).
    Field(&'static str),
    /// A message this receiver does not take (a board's configuration input takes
    /// configuration frames only).
    NotTaken(MessageId),
}

impl core::fmt::Display for PayloadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Field(what) => write!(f, "{what} out of range"),
            Self::NotTaken(id) => write!(f, "a {} frame is not taken here", id.name()),
        }
    }
}

/// Why a message cannot be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncodeError {
    /// The output buffer is too small.
    BufferTooSmall,
    /// A row's filter status has no wire code.
    UnknownFilterStatus,
}

impl From<Overflow> for EncodeError {
    fn from(_: Overflow) -> Self {
        Self::BufferTooSmall
    }
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BufferTooSmall => "output buffer too small for the frame",
            Self::UnknownFilterStatus => "the row's filter status has no wire code",
        })
    }
}

impl Message {
    /// The message's id.
    pub fn id(&self) -> MessageId {
        match self {
            Self::NavSolution(_) => MessageId::NavSolution,
            Self::RawIncrements(_) => MessageId::RawIncrements,
            Self::Health(_) => MessageId::Health,
            Self::AlignProgress(_) => MessageId::AlignProgress,
            Self::AidingEvent(_) => MessageId::AidingEvent,
            Self::EndOfRun(_) => MessageId::EndOfRun,
            Self::Config(_) => MessageId::Config,
            Self::ConfigAck(_) => MessageId::ConfigAck,
        }
    }
}
