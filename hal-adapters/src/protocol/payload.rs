//! The payloads' codec: every field little-endian, floats IEEE 754 bit for bit (byte layouts
//! in `docs/protocol.md`).

use super::config::{ConfigRefusal, DeviceConfig, ReasonCode};
use super::messages::*;
use super::status::{AidCount, HealthCounters, NavStatus, StatusFlags};
use super::vibration::VibrationLevels;
use super::wire::{Reader, Writer, pick};
use crate::sample::{ImuSample, Motion, SampleFlags};
use nav_core::alignment::machine::Stage;
use nav_core::ins_filter::FilterStatus;
use nav_core::output::{FilterColumns, Row, Solution};

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
fn field<V: Copy>(all: &[V], code: u8, what: &'static str) -> Result<V, PayloadError> {
    pick(all, code).ok_or(PayloadError::Field(what))
}

impl Message {
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

    /// Reads a configuration payload ([`DeviceConfig::read`]).
    pub(crate) fn read_config(payload: &[u8]) -> Result<Self, PayloadError> {
        let short = PayloadError::Field("payload length");
        let mut r = Reader::new(payload);
        let config = DeviceConfig::read(&mut r).map_err(|e| match e {
            ConfigRefusal::Malformed(what) => PayloadError::Field(what),
            _ => short,
        })?;
        if r.is_done() {
            Ok(Self::Config(config))
        } else {
            Err(short)
        }
    }

    /// Reads the payload of `id` when it is a configuration, refuses any other
    /// ([`PayloadError::NotTaken`]): a board's configuration input, whose flash then holds no
    /// other message's reader.
    pub(crate) fn read_config_only(id: MessageId, payload: &[u8]) -> Result<Self, PayloadError> {
        match id {
            MessageId::Config => Self::read_config(payload),
            other => Err(PayloadError::NotTaken(other)),
        }
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
                        position_aiding: AidCount {
                            accepted: pa,
                            rejected: pr,
                        },
                        velocity_aiding: AidCount {
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
                stage: field(&STAGES, r.u8().ok_or(short)?, "alignment stage")?,
                samples: r.u32().ok_or(short)?,
                samples_total: r.u32().ok_or(short)?,
            }),
            MessageId::AidingEvent => Self::AidingEvent(AidingEvent {
                t_us: r.u64().ok_or(short)?,
                aid: field(&AIDS, r.u8().ok_or(short)?, "aid")?,
                outcome: field(&OUTCOMES, r.u8().ok_or(short)?, "aiding outcome")?,
                nis: r.f32().ok_or(short)?,
            }),
            MessageId::EndOfRun => Self::EndOfRun(EndOfRun {
                rows: r.u32().ok_or(short)?,
            }),
            MessageId::Config => return Self::read_config(payload),
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
                    status: field(&FILTER_NAMES, c, "filter status")?.name(),
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
