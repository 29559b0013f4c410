//! The messages and their payloads (byte layouts in `docs/protocol.md`; every field
//! little-endian, floats IEEE 754 bit for bit).

use super::config::{CONFIG_LEN, ConfigRefusal, DeviceConfig, ReasonCode};
use super::status::{HealthCounters, NavStatus, StatusFlags};
use super::vibration::VibrationLevels;
use super::wire::{Overflow, Reader, Writer};
use crate::sample::{ImuSample, Motion, SampleFlags};
use nav_core::alignment::machine::Stage;
use nav_core::ins_filter::FilterStatus;
use nav_core::ins_filter::aiding::AidResult;
use nav_core::output::{FilterColumns, Row, Solution};
use nav_core::scalar::Scalar;

/// Message identifiers (one byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
pub enum PayloadError {
    /// A field holds a value outside its enumeration (its name).
    Field(&'static str),
}

impl core::fmt::Display for PayloadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Field(what) => write!(f, "{what} out of range"),
        }
    }
}

/// Statuses of the filter that the solution log names, by their first variant: the wire code
/// of a row's filter column is its index here (0xFF: a free-inertial row).
const FILTER_NAMES: [FilterStatus; 2] = [FilterStatus::Nominal, FilterStatus::AidingRejected];

/// The wire code of a row's filter status name.
fn filter_code(name: &str) -> Option<u8> {
    FILTER_NAMES
        .iter()
        .position(|s| s.name() == name)
        .map(|i| i as u8)
}

const STAGES: [Stage; 4] = [Stage::Coarse, Stage::Fine, Stage::Aligned, Stage::Failed];
const AIDS: [Aid; 2] = [Aid::Position, Aid::Velocity];
const OUTCOMES: [AidOutcome; 5] = [
    AidOutcome::Accepted,
    AidOutcome::RejectedGate,
    AidOutcome::Invalid,
    AidOutcome::Late,
    AidOutcome::OutOfOrder,
];

/// Code `code` of `all`, or the refusal naming `what`.
fn pick<V: Copy>(all: &[V], code: u8, what: &'static str) -> Result<V, PayloadError> {
    all.get(usize::from(code))
        .copied()
        .ok_or(PayloadError::Field(what))
}

/// Why a message cannot be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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

    /// Writes the payload into `out`; returns its length.
    pub fn write_payload(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        let mut w = Writer::new(out);
        match self {
            Self::NavSolution(m) => write_solution(m, &mut w)?,
            Self::RawIncrements(m) => {
                let s = &m.sample;
                let (dtheta, dv) = s.increments();
                w.u64(s.t_us)?;
                w.u32(s.seq)?;
                w.f32(s.dt_s)?;
                w.f32s(&dtheta)?;
                w.f32s(&dv)?;
                w.f32(s.temperature_c)?;
                w.u16(s.flags.bits())?;
            }
            Self::Health(m) => {
                let c = &m.counters;
                w.u64(m.t_us)?;
                w.u8(m.status as u8)?;
                w.u16(m.flags.bits())?;
                w.u32s(&[
                    c.samples,
                    c.missed_data_ready,
                    c.channel_overruns,
                    c.bus_errors,
                    c.checksum_errors,
                    c.device_faults,
                ])?;
                w.u32s(&c.gyro_clips)?;
                w.u32s(&c.accel_clips)?;
                w.u32s(&[
                    c.position_aiding.accepted,
                    c.position_aiding.rejected,
                    c.velocity_aiding.accepted,
                    c.velocity_aiding.rejected,
                    c.watchdog_resets,
                ])?;
                for v in m.vibration.accel_rms.iter().chain(&m.vibration.gyro_rms) {
                    w.u16(*v)?;
                }
            }
            Self::AlignProgress(m) => {
                w.u64(m.t_us)?;
                w.u8(STAGES.iter().position(|s| *s == m.stage).unwrap_or(0) as u8)?;
                w.u32(m.samples)?;
                w.u32(m.samples_total)?;
            }
            Self::AidingEvent(m) => {
                w.u64(m.t_us)?;
                w.u8(m.aid as u8)?;
                w.u8(m.outcome as u8)?;
                w.f32(m.nis)?;
            }
            Self::EndOfRun(m) => w.u32(m.rows)?,
            Self::Config(c) => c.write(&mut w)?,
            Self::ConfigAck(m) => {
                w.u16(m.config_seq)?;
                w.u8(m.refused.map_or(0, |r| r as u8))?;
            }
        }
        debug_assert_eq!(w.len(), self.id().payload_len());
        Ok(w.len())
    }

    /// Reads the payload of message `id` (its length already checked).
    pub fn read_payload(id: MessageId, payload: &[u8]) -> Result<Self, PayloadError> {
        let mut r = Reader::new(payload);
        // The length was checked against the id: reads within it cannot fail.
        let short = PayloadError::Field("payload length");
        let m = match id {
            MessageId::NavSolution => Self::NavSolution(read_solution(&mut r).ok_or(short)??),
            MessageId::RawIncrements => {
                let (t_us, seq, dt_s) = (
                    r.u64().ok_or(short)?,
                    r.u32().ok_or(short)?,
                    r.f32().ok_or(short)?,
                );
                let (dtheta, dv) = (r.f32s().ok_or(short)?, r.f32s().ok_or(short)?);
                let temperature_c = r.f32().ok_or(short)?;
                let flags = SampleFlags::from_bits(r.u16().ok_or(short)?)
                    .ok_or(PayloadError::Field("sample flags"))?;
                Self::RawIncrements(RawIncrements {
                    sample: ImuSample {
                        t_us,
                        seq,
                        dt_s,
                        motion: Motion::Increments {
                            delta_theta_ib_b: dtheta,
                            delta_v_ib_b: dv,
                        },
                        temperature_c,
                        flags,
                    },
                })
            }
            MessageId::Health => {
                let t_us = r.u64().ok_or(short)?;
                let status = NavStatus::from_code(r.u8().ok_or(short)?)
                    .ok_or(PayloadError::Field("status"))?;
                let flags = StatusFlags::from_bits(r.u16().ok_or(short)?)
                    .ok_or(PayloadError::Field("status flags"))?;
                let [samples, missed, overruns, bus, checksum, faults] = r.u32s().ok_or(short)?;
                let gyro_clips = r.u32s().ok_or(short)?;
                let accel_clips = r.u32s().ok_or(short)?;
                let [pa, pr, va, vr, watchdog] = r.u32s().ok_or(short)?;
                let mut vib = [0u16; 6];
                for v in &mut vib {
                    *v = r.u16().ok_or(short)?;
                }
                Self::Health(HealthReport {
                    t_us,
                    status,
                    flags,
                    counters: HealthCounters {
                        samples,
                        missed_data_ready: missed,
                        channel_overruns: overruns,
                        bus_errors: bus,
                        checksum_errors: checksum,
                        device_faults: faults,
                        gyro_clips,
                        accel_clips,
                        position_aiding: super::status::AidCount {
                            accepted: pa,
                            rejected: pr,
                        },
                        velocity_aiding: super::status::AidCount {
                            accepted: va,
                            rejected: vr,
                        },
                        watchdog_resets: watchdog,
                    },
                    vibration: VibrationLevels {
                        accel_rms: [vib[0], vib[1], vib[2]],
                        gyro_rms: [vib[3], vib[4], vib[5]],
                    },
                })
            }
            MessageId::AlignProgress => Self::AlignProgress(AlignProgress {
                t_us: r.u64().ok_or(short)?,
                stage: pick(&STAGES, r.u8().ok_or(short)?, "alignment stage")?,
                samples: r.u32().ok_or(short)?,
                samples_total: r.u32().ok_or(short)?,
            }),
            MessageId::AidingEvent => Self::AidingEvent(AidingEvent {
                t_us: r.u64().ok_or(short)?,
                aid: pick(&AIDS, r.u8().ok_or(short)?, "aid")?,
                outcome: pick(&OUTCOMES, r.u8().ok_or(short)?, "aiding outcome")?,
                nis: r.f32().ok_or(short)?,
            }),
            MessageId::EndOfRun => Self::EndOfRun(EndOfRun {
                rows: r.u32().ok_or(short)?,
            }),
            MessageId::Config => Self::Config(DeviceConfig::read(&mut r).map_err(|e| match e {
                ConfigRefusal::Malformed(what) => PayloadError::Field(what),
                _ => short,
            })?),
            MessageId::ConfigAck => {
                let config_seq = r.u16().ok_or(short)?;
                let code = r.u8().ok_or(short)?;
                let refused = match code {
                    0 => None,
                    c => Some(ReasonCode::from_code(c).ok_or(PayloadError::Field("reason code"))?),
                };
                Self::ConfigAck(ConfigAck {
                    config_seq,
                    refused,
                })
            }
        };
        if r.is_done() { Ok(m) } else { Err(short) }
    }
}

/// The solution payload: time, position, velocity, attitude (exact: the row's own integers
/// and f64 bits), the filter's 1-sigma (f32, as the row holds them; NaN in a free-inertial
/// row), the filter column's code, the wire status and flags.
fn write_solution(m: &NavSolution, w: &mut Writer<'_>) -> Result<(), EncodeError> {
    let s = m.row.solution();
    w.u64(s.t_us)?;
    w.i64(s.lat_ndeg)?;
    w.i64(s.lon_ndeg)?;
    w.f64(s.h_m)?;
    w.f64s(&s.v_eb_n)?;
    w.f64s(&[s.roll_deg, s.pitch_deg, s.yaw_deg])?;
    let (sigmas, code) = match m.row.filter() {
        Some(c) => (
            [c.sigma_ned_m, c.sigma_v_ned_m_s, c.sigma_att_deg],
            filter_code(c.status).ok_or(EncodeError::UnknownFilterStatus)?,
        ),
        None => ([[f32::NAN; 3]; 3], 0xFF),
    };
    for v in &sigmas {
        w.f32s(v)?;
    }
    w.u8(code)?;
    w.u8(m.status as u8)?;
    w.u16(m.flags.bits())?;
    Ok(())
}

/// Reads [`write_solution`]'s payload (`None`: too short).
fn read_solution(r: &mut Reader<'_>) -> Option<Result<NavSolution, PayloadError>> {
    let solution = Solution {
        t_us: r.u64()?,
        lat_ndeg: r.i64()?,
        lon_ndeg: r.i64()?,
        h_m: r.f64()?,
        v_eb_n: r.f64s()?,
        roll_deg: r.f64()?,
        pitch_deg: r.f64()?,
        yaw_deg: r.f64()?,
    };
    let [sigma_ned_m, sigma_v_ned_m_s, sigma_att_deg] = [r.f32s()?, r.f32s()?, r.f32s()?];
    let (code, status, flags) = (r.u8()?, r.u8()?, r.u16()?);
    Some((|| {
        let row = match code {
            0xFF => Row::Free(solution),
            c => Row::Aided(
                solution,
                FilterColumns {
                    sigma_ned_m,
                    sigma_v_ned_m_s,
                    sigma_att_deg,
                    status: pick(&FILTER_NAMES, c, "filter status")?.name(),
                },
            ),
        };
        Ok(NavSolution {
            row,
            status: NavStatus::from_code(status).ok_or(PayloadError::Field("status"))?,
            flags: StatusFlags::from_bits(flags).ok_or(PayloadError::Field("status flags"))?,
        })
    })())
}
