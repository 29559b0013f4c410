//! Checks of the protocol that run on the target as well as on the host: the encoder and
//! decoder round trip of every message (with resynchronisation after garbage and a CRC
//! refusal), the configuration validator (a refusal per reason code, a frame during a run,
//! a frame for another board) and the status rule.
//! No allocation, no std: the firmware's `target_tests` binary runs [`CHECKS`] on the
//! Cortex-M in QEMU, and the host's unit test runs the same list.

use super::config::{BoardIdentity, DeviceConfig, ImuModel, ReasonCode};
use super::decoder::Decoder;
use super::frame::{Encoder, MAX_FRAME};
use super::messages::*;
use super::status::{
    AidCount, HealthCounters, NavStatus, NavigatorState, RunSource, StatusFlags, StatusModel,
};
use super::vibration::VibrationLevels;
use crate::drivers::Mounting;
use crate::sample::{ImuSample, Motion, SampleFlags};
use nav_core::alignment::machine::{AlignMethod, Stage};
use nav_core::ins_filter::FilterStatus;
use nav_core::output::{FilterColumns, Row, Solution};

/// A check: `Err` names what failed.
pub type Check = fn() -> Result<(), &'static str>;

/// Every check, by name.
pub const CHECKS: [(&str, Check); 5] = [
    (
        "every message round-trips through the encoder and the decoder",
        round_trip,
    ),
    (
        "the decoder refuses a corrupted frame and resynchronises",
        corrupted_frame,
    ),
    (
        "the validator refuses each bad value with its reason code",
        config_refusals,
    ),
    (
        "a frame during a run changes the output rates only; a frame for another board is refused",
        config_on_board,
    ),
    ("the status rule", status_rule),
];

/// `Err(what)` unless `ok`.
fn ensure(ok: bool, what: &'static str) -> Result<(), &'static str> {
    if ok { Ok(()) } else { Err(what) }
}

fn solution() -> Solution {
    Solution {
        t_us: 60_002_500,
        lat_ndeg: 45_123_456_789,
        lon_ndeg: -7_500_000_123,
        h_m: 150.123_456_789_012_3,
        v_eb_n: [0.1 + 0.2, -1e-300, f64::MIN_POSITIVE],
        roll_deg: 1.5,
        pitch_deg: -2.000_000_000_000_1,
        yaw_deg: 179.999_999_999_999_97,
    }
}

/// One of every message (both rows, every field away from zero where it can be).
pub fn every_message() -> [Message; 10] {
    let aided = FilterColumns {
        sigma_ned_m: [0.5, 0.25, 1.125],
        sigma_v_ned_m_s: [0.01, 0.02, 0.03],
        sigma_att_deg: [0.003, 0.004, 0.5],
        status: "DEGRADED",
    };
    let mut config = DeviceConfig::default();
    config.run.lat_deg = 45.0;
    config.run.align_method = AlignMethod::Fine;
    config.run.align_seconds = 300.0;
    config
        .apply_line("gnss-lever-arm = 0.1, -0.2, 0.3")
        .unwrap();
    config.apply_line("gnss-correlated = 1.5, 2, 4").unwrap();
    config.apply_line("gnss-correlated-time = 90").unwrap();
    config.apply_line("lever-arm = 1,2,3").unwrap();
    config
        .apply_line("mounting = 1,0,0, 0,-1,0, 0,0,-1")
        .unwrap();
    config.rates.raw_every = 0;
    [
        Message::NavSolution(NavSolution {
            row: Row::Free(solution()),
            status: NavStatus::Nav,
            flags: StatusFlags::FREE_INERTIAL,
        }),
        Message::NavSolution(NavSolution {
            row: Row::Aided(solution(), aided),
            status: NavStatus::Degraded,
            flags: StatusFlags::AIDING_REJECTED | StatusFlags::CLIPPING,
        }),
        Message::RawIncrements(RawIncrements {
            sample: ImuSample {
                t_us: u64::MAX - 7,
                seq: 123_456,
                dt_s: 0.0025,
                motion: Motion::Increments {
                    delta_theta_ib_b: [1e-6, -2e-6, 3e-9],
                    delta_v_ib_b: [0.001, -0.002, -0.024_516],
                },
                temperature_c: 31.5,
                flags: SampleFlags::STALE,
            },
        }),
        Message::Health(HealthReport {
            t_us: 1_000_000,
            status: NavStatus::Fault,
            flags: StatusFlags::BUS_ERRORS | StatusFlags::DEVICE_FAULT,
            counters: HealthCounters {
                samples: 400_000,
                missed_data_ready: 2,
                channel_overruns: 3,
                bus_errors: 4,
                checksum_errors: 5,
                device_faults: 6,
                gyro_clips: [7, 8, 9],
                accel_clips: [10, 11, 12],
                position_aiding: AidCount {
                    accepted: 13,
                    rejected: 14,
                },
                velocity_aiding: AidCount {
                    accepted: 15,
                    rejected: 16,
                },
                watchdog_resets: 17,
            },
            vibration: VibrationLevels {
                accel_rms: [18, 19, u16::MAX],
                gyro_rms: [0, 21, 22],
            },
        }),
        Message::AlignProgress(AlignProgress {
            t_us: 5_000_000,
            stage: Stage::Fine,
            samples: 2000,
            samples_total: 120_000,
        }),
        Message::AidingEvent(AidingEvent {
            t_us: 7,
            aid: Aid::Velocity,
            outcome: AidOutcome::RejectedGate,
            nis: 42.5,
        }),
        Message::EndOfRun(EndOfRun { rows: 102 }),
        Message::Config(config),
        Message::ConfigAck(ConfigAck {
            config_seq: 9,
            refused: Some(ReasonCode::Mounting),
        }),
        Message::ConfigAck(ConfigAck {
            config_seq: 10,
            refused: None,
        }),
    ]
}

/// A change to a configuration.
pub type Mutation = fn(&mut DeviceConfig);

/// Changes of the default configuration and the reason each must be refused with.
pub fn refusal_cases() -> [(Mutation, ReasonCode); 13] {
    [
        (|c| c.run.lat_deg = 91.0, ReasonCode::Latitude),
        (|c| c.run.lon_deg = 400.0, ReasonCode::Longitude),
        (|c| c.run.h_m = -20_000.0, ReasonCode::Height),
        (|c| c.run.h_m = f64::NAN, ReasonCode::NotFinite),
        (|c| c.run.log_every = 0, ReasonCode::SolutionRate),
        (|c| c.run.bias_prior = -1.0, ReasonCode::BiasPrior),
        (|c| c.run.align_seconds = 1.0, ReasonCode::Alignment),
        (|c| c.imu_rate_hz = 0.0, ReasonCode::Alignment),
        (
            |c| {
                let _ = c.apply_line("propagation-rate = 10");
                c.run.noise.gyro_bias_rad_s = 0.0;
            },
            ReasonCode::Aiding,
        ),
        (
            |c| {
                let _ = c.apply_line("gnss-correlated = 1, 1, 1000");
            },
            ReasonCode::Aiding,
        ),
        // Without aiding too: a frame carries it (a zero variance once aiding is on).
        (|c| c.run.figures.gyro_scale = 0.0, ReasonCode::Aiding),
        (|c| c.mounting.c_s_b[0][0] = 1.01, ReasonCode::Mounting),
        (|c| c.rates.health_every = 0, ReasonCode::OutputRate),
    ]
}

/// The encoded payload of `m` equals that of `n` (NaN-proof equality).
fn same_payload(m: &Message, n: &Message) -> bool {
    let (mut a, mut b) = ([0_u8; 256], [0_u8; 256]);
    match (m.write_payload(&mut a), n.write_payload(&mut b)) {
        (Ok(x), Ok(y)) => m.id() == n.id() && a[..x] == b[..y],
        _ => false,
    }
}

/// Every message: its declared payload length, and back from its frame, fed after garbage.
fn round_trip() -> Result<(), &'static str> {
    let mut encoder = Encoder::new();
    let mut decoder = Decoder::new();
    // Garbage first: refused up to its zero, then every frame comes through.
    for b in [0x55, 0x13, 0xff, 0x00] {
        let _ = decoder.feed(b);
    }
    for (k, m) in every_message().iter().enumerate() {
        let mut payload = [0_u8; 256];
        let n = m
            .write_payload(&mut payload)
            .map_err(|_| "payload not written")?;
        ensure(
            n == m.id().payload_len(),
            "payload length differs from the declared one",
        )?;
        let mut frame = [0_u8; MAX_FRAME];
        let n = encoder
            .encode(m, &mut frame)
            .map_err(|_| "message not encoded")?;
        ensure(
            frame[..n - 1].iter().all(|b| *b != 0),
            "a zero inside a frame",
        )?;
        let mut got = None;
        for b in &frame[..n] {
            if let Some(r) = decoder.feed(*b) {
                got = Some(r);
            }
        }
        let r = got
            .ok_or("frame not delivered")?
            .map_err(|_| "frame refused")?;
        ensure(r.seq == k as u16, "sequence number differs")?;
        ensure(
            same_payload(&r.message, m),
            "message differs after the trip",
        )?;
    }
    let s = decoder.stats();
    ensure(s.skipped_bytes == 4, "garbage bytes not counted as skipped")?;
    ensure(
        s.frames_total() == 10 && s.frames_lost == 0,
        "frames miscounted",
    )
}

/// A flipped bit fails the CRC (or the COBS structure); the next frame still decodes.
fn corrupted_frame() -> Result<(), &'static str> {
    let mut encoder = Encoder::new();
    let end = Message::EndOfRun(EndOfRun { rows: 3 });
    let mut frame = [0_u8; MAX_FRAME];
    let n = encoder
        .encode(&end, &mut frame)
        .map_err(|_| "not encoded")?;
    let mut decoder = Decoder::new();
    for (bit, at) in [(0x01_u8, n / 2), (0x80, n - 2)] {
        let mut bad = frame;
        bad[at] ^= bit;
        if bad[at] == 0 {
            continue;
        }
        let mut results = 0;
        for b in &bad[..n] {
            if let Some(r) = decoder.feed(*b) {
                ensure(r.is_err(), "a corrupted frame accepted")?;
                results += 1;
            }
        }
        ensure(results == 1, "a corrupted frame not refused")?;
    }
    let mut got = None;
    for b in &frame[..n] {
        if let Some(r) = decoder.feed(*b) {
            got = Some(r);
        }
    }
    let r = got.ok_or("frame after the corrupted ones not delivered")?;
    ensure(
        r.is_ok_and(|r| r.message == end),
        "frame after the corrupted ones refused",
    )
}

/// The defaults are valid; each refusal case is refused with its reason code.
fn config_refusals() -> Result<(), &'static str> {
    let base = DeviceConfig::default();
    ensure(base.validate().is_ok(), "the defaults are refused")?;
    for (mutate, code) in refusal_cases() {
        let mut c = base;
        mutate(&mut c);
        match c.validate() {
            Ok(()) => return Err("a bad configuration accepted"),
            Err(e) => ensure(e.code() == code, "a refusal with the wrong reason code")?,
        }
    }
    let mut reflected = base;
    reflected.mounting.c_s_b[2][2] = -1.0;
    ensure(
        reflected
            .validate()
            .is_err_and(|e| e.code() == ReasonCode::Mounting),
        "a reflection taken for a rotation",
    )
}

/// The board the configuration checks run against: the defaults' IMU, rate and mounting, no
/// GNSS.
pub fn default_board() -> BoardIdentity {
    let d = DeviceConfig::default();
    BoardIdentity {
        imu_model: d.imu_model,
        imu_rate_hz: f64::from(d.imu_rate_hz),
        mounting: d.mounting,
        gnss: false,
    }
}

/// A mounting turned 90 deg about the body's down axis.
const TURNED: Mounting =
    Mounting::from_matrix([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]);

/// Changes of the default configuration that the default board refuses as not its own.
pub fn other_board_cases() -> [Mutation; 3] {
    [
        |c| c.imu_model = ImuModel::Icm42688,
        |c| c.imu_rate_hz = 200.0,
        |c| {
            let _ = c.apply_line("aiding = on");
        },
    ]
}

/// Standby (no run): the defaults accepted, another mounting accepted (the installation's:
/// the run's), another board's refused (`NotThisBoard`). During a run on the defaults: the
/// same run with other output rates accepted; another site, window, lever arm or mounting
/// refused (`RunInProgress`), a bad value still refused for its own reason; the board's
/// calibration is its own (a running calibration does not make the frame differ).
fn config_on_board() -> Result<(), &'static str> {
    let board = core::hint::black_box(default_board());
    let base = DeviceConfig::default();
    ensure(base.check_on(&board, None).is_ok(), "defaults refused")?;
    let mut turned = base;
    turned.mounting = TURNED;
    ensure(
        turned.check_on(&board, None).is_ok(),
        "another mounting refused in standby",
    )?;
    for mutate in other_board_cases() {
        let mut c = base;
        mutate(&mut c);
        ensure(
            c.validate().is_ok(),
            "another board's case does not validate",
        )?;
        ensure(
            c.check_on(&board, None)
                .is_err_and(|e| e.code() == ReasonCode::NotThisBoard),
            "another board's frame not refused as such",
        )?;
    }
    let mut running = base.run;
    running.calibration.gyro.bias = [1e-6, 0.0, 0.0];
    let mut rates = base;
    rates.rates.raw_every = 0;
    rates.rates.health_every = 40;
    ensure(
        rates
            .check_on(&board, Some((&running, &base.mounting)))
            .is_ok(),
        "new output rates refused during a run",
    )?;
    let changes: [Mutation; 4] = [
        |c| c.run.lat_deg = 45.0,
        |c| c.run.align_seconds = 120.0,
        |c| {
            let _ = c.apply_line("lever-arm = 0.1, 0.2, 0.3");
        },
        |c| c.mounting = TURNED,
    ];
    for change in changes {
        let mut c = base;
        change(&mut c);
        ensure(
            c.check_on(&board, Some((&running, &base.mounting)))
                .is_err_and(|e| e.code() == ReasonCode::RunInProgress),
            "another run configuration accepted during a run",
        )?;
    }
    let mut bad = base;
    bad.run.lat_deg = 95.0;
    ensure(
        bad.check_on(&board, Some((&running, &base.mounting)))
            .is_err_and(|e| e.code() == ReasonCode::Latitude),
        "a bad value during a run refused for another reason",
    )?;
    ensure(
        base.run_with(running.calibration) == running,
        "the frame's run does not take the board's calibration",
    )
}

/// Alignment stages, free inertial, a sensor fault for one evaluation, aiding refused, aiding
/// lost after the timeout and regained, a failed alignment; standby and the default
/// configuration's flag.
fn status_rule() -> Result<(), &'static str> {
    // Opaque inputs: the rule runs, not its value folded at compile time.
    let state = |stage, filter| {
        core::hint::black_box(NavigatorState {
            stage,
            filter,
            config: RunSource::Host,
        })
    };
    let mut model = core::hint::black_box(StatusModel::new(5.0));
    let mut c = HealthCounters::default();
    let standby = NavigatorState {
        config: RunSource::Waiting,
        ..state(Stage::Coarse, None)
    };
    let s = model.update(0, standby, &c);
    ensure(s == (NavStatus::Standby, StatusFlags::empty()), "standby")?;
    let on_default = NavigatorState {
        config: RunSource::Default,
        ..state(Stage::Aligned, None)
    };
    let s = model.update(0, on_default, &c);
    ensure(
        s == (
            NavStatus::Nav,
            StatusFlags::FREE_INERTIAL | StatusFlags::DEFAULT_CONFIG,
        ),
        "the compiled-in configuration's flag",
    )?;
    let s = model.update(0, state(Stage::Coarse, None), &c);
    ensure(
        s == (NavStatus::AlignCoarse, StatusFlags::empty()),
        "coarse",
    )?;
    let s = model.update(1, state(Stage::Fine, None), &c);
    ensure(s.0 == NavStatus::AlignFine, "fine")?;
    let s = model.update(2, state(Stage::Aligned, None), &c);
    ensure(
        s == (NavStatus::Nav, StatusFlags::FREE_INERTIAL),
        "free inertial",
    )?;
    c.bus_errors += 1;
    c.gyro_clips[1] += 1;
    let s = model.update(3, state(Stage::Aligned, None), &c);
    ensure(s.0 == NavStatus::Fault, "a bus error is a sensor failure")?;
    ensure(
        s.1.contains(StatusFlags::BUS_ERRORS | StatusFlags::CLIPPING),
        "bus and clip flags",
    )?;
    let s = model.update(4, state(Stage::Aligned, None), &c);
    ensure(
        s.0 == NavStatus::Nav,
        "the fault flag is for the evaluation after the error",
    )?;
    let aided = |f| state(Stage::Aligned, Some(f));
    let s = model.update(5, aided(FilterStatus::AidingRejected), &c);
    ensure(
        s.0 == NavStatus::Degraded && s.1.contains(StatusFlags::AIDING_REJECTED),
        "rejected",
    )?;
    // The aided phase's clock started at 5 us: 5 s later not yet lost, beyond it lost.
    let s = model.update(5_000_005, aided(FilterStatus::Nominal), &c);
    ensure(s.0 == NavStatus::Nav, "aiding lost too early")?;
    let s = model.update(5_000_006, aided(FilterStatus::Nominal), &c);
    ensure(
        s.0 == NavStatus::Degraded && s.1.contains(StatusFlags::AIDING_LOST),
        "aiding lost",
    )?;
    c.position_aiding = AidCount {
        accepted: 1,
        rejected: 0,
    };
    let s = model.update(5_000_007, aided(FilterStatus::Nominal), &c);
    ensure(
        s == (NavStatus::Nav, StatusFlags::empty()),
        "aiding regained",
    )?;
    let s = model.update(5_000_008, state(Stage::Failed, None), &c);
    ensure(s.0 == NavStatus::Fault, "a failed alignment is a fault")
}
