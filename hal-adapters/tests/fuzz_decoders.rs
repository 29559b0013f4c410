//! Fuzzing of every decoder of the sensor layer, with arbitrary bytes and with mutated valid
//! input (which gets past the checks that arbitrary bytes almost never pass):
//! - the binary recording's header parser and record decoder, and [`Replay`] over a byte slice;
//! - each driver's decode path, fed through an `SpiDevice` that answers each data read with the
//!   next fuzzed frame: ADIS16505/16465 bursts (16- and 32-bit, checksum), ICM-42688-P FIFO reads
//!   (status and 20-bit packets), BMI088 gyro and accelerometer frames.
//!
//! Asserted: no panic; every sample has finite values or is flagged `NON_FINITE`, a finite
//! non-negative `dt_s` (positive when usable) and, from a driver, a temperature that is finite
//! or NaN; a sample that is neither unusable nor saturated is within
//! the sensor's range (a rate within the measurement range, an increment within the range times
//! `dt_s`); the replay's flags and counters follow `docs/recording-format.md`.
//!
//! 256 cases per target by default (CI); `PROPTEST_CASES=N` runs `N` (`cargo xtask fuzz` runs
//! 100 000 per target). Each target prints its case count and wall time.

use core::convert::Infallible;
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};
use hal_adapters::drivers::adis16505::{self, Adis16505, Model, Range, checksum};
use hal_adapters::drivers::bmi088::{self, AccelRange, Bmi088, GyroRange};
use hal_adapters::drivers::icm42688::{self, Icm42688};
use hal_adapters::drivers::{Error, ImuDriver};
use hal_adapters::recording::{
    FormatErrorKind, HEADER_LEN, Header, Kind, RECORD_LEN, Record, Replay, ReplayError,
};
use hal_adapters::{Imu, ImuSample, Motion, SampleFlags};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::collections::VecDeque;
use std::time::Instant;

const DEFAULT_CASES: u32 = 256;
const DEG: f64 = core::f64::consts::PI / 180.0;
const G: f64 = 9.806_65;
/// Relative slack of the range checks: the f32 scaling rounds (a few ulps).
const RANGE_SLACK: f64 = 1e-5;

/// Runs `test` on `cases()` inputs of `strategy`, panicking with the (shrunk) failure; prints
/// the count and the wall time.
fn fuzz<S: Strategy>(name: &str, strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>)
where
    S::Value: core::fmt::Debug,
{
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES);
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    let started = Instant::now();
    let result = runner.run(&strategy, test);
    let seconds = started.elapsed().as_secs_f64();
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    eprintln!("fuzz {name}: {cases} cases, no failure, {seconds:.2} s");
}

// ---------------------------------------------------------------------------------------------
// The binary recording.

/// Values a record may hold: non-finite, huge, tiny, anything, and plausible increments.
fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(f32::MAX),
        Just(f32::from_bits(1)),
        any::<u32>().prop_map(f32::from_bits),
        (-0.1f32..0.1),
    ]
}

/// Record times: mostly the nominal 2.5 ms steps, with gaps, repeats, backward steps and jumps.
fn time_steps() -> impl Strategy<Value = i64> {
    prop_oneof![
        6 => Just(2_500_000i64),
        2 => 1_000_000i64..4_000_000,
        1 => 4_000_000i64..30_000_000,
        1 => Just(0i64),
        1 => -5_000_000i64..0,
        1 => any::<i64>(),
    ]
}

fn records() -> impl Strategy<Value = Vec<Record>> {
    proptest::collection::vec((time_steps(), proptest::array::uniform7(any_f32())), 0..30).prop_map(
        |steps| {
            let mut t_ns = 1_000_000_000u64;
            steps
                .into_iter()
                .map(|(step, v)| {
                    t_ns = t_ns.wrapping_add_signed(step);
                    Record {
                        t_ns,
                        gyro: [v[0], v[1], v[2]],
                        accel: [v[3], v[4], v[5]],
                        temperature_c: v[6],
                    }
                })
                .collect()
        },
    )
}

fn headers() -> impl Strategy<Value = Header> {
    let rate = prop_oneof![
        Just(400.0),
        Just(100.0),
        (0.1f64..10_000.0),
        any::<u64>()
            .prop_map(f64::from_bits)
            .prop_filter("valid", |r| r.is_finite() && *r > 0.0),
    ];
    (
        any::<bool>(),
        rate,
        prop_oneof![Just(0u64), Just(1_000_000_000), any::<u64>()],
    )
        .prop_map(|(rates, rate_hz, t0_ns)| Header {
            kind: if rates { Kind::Rates } else { Kind::Increments },
            rate_hz,
            t0_ns,
            sample_count: 0,
        })
}

/// A byte-level change of a file; `reseal` recomputes the CRC of the header or record it hits.
#[derive(Clone, Debug)]
enum ByteEdit {
    Flip(prop::sample::Index, u8, bool),
    Set(prop::sample::Index, u8, bool),
    Insert(prop::sample::Index, Vec<u8>),
    Delete(prop::sample::Index, usize),
    Truncate(prop::sample::Index),
    /// The header's sample count moved by this much (its CRC resealed).
    Count(i8),
}

fn byte_edit() -> impl Strategy<Value = ByteEdit> {
    use prop::sample::Index;
    prop_oneof![
        3 => (any::<Index>(), 0u8..8, any::<bool>()).prop_map(|(i, b, r)| ByteEdit::Flip(i, b, r)),
        2 => (any::<Index>(), any::<u8>(), any::<bool>()).prop_map(|(i, v, r)| ByteEdit::Set(i, v, r)),
        1 => (any::<Index>(), proptest::collection::vec(any::<u8>(), 1..50))
            .prop_map(|(i, b)| ByteEdit::Insert(i, b)),
        1 => (any::<Index>(), 1usize..50).prop_map(|(i, n)| ByteEdit::Delete(i, n)),
        1 => any::<Index>().prop_map(ByteEdit::Truncate),
        1 => (-3i8..=3).prop_map(ByteEdit::Count),
    ]
}

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Recomputes the CRC of the header or of the record holding byte `at`, if complete.
fn reseal(bytes: &mut [u8], at: usize) {
    let (start, len) = if at < HEADER_LEN {
        (0, HEADER_LEN)
    } else {
        let k = (at - HEADER_LEN) / RECORD_LEN;
        (HEADER_LEN + RECORD_LEN * k, RECORD_LEN)
    };
    if start + len <= bytes.len() {
        let crc = CRC32.checksum(&bytes[start..start + len - 4]);
        bytes[start + len - 4..start + len].copy_from_slice(&crc.to_le_bytes());
    }
}

fn edit(bytes: &mut Vec<u8>, e: &ByteEdit) {
    match e {
        ByteEdit::Flip(i, bit, r) if !bytes.is_empty() => {
            let at = i.index(bytes.len());
            bytes[at] ^= 1 << bit;
            if *r {
                reseal(bytes, at);
            }
        }
        ByteEdit::Set(i, v, r) if !bytes.is_empty() => {
            let at = i.index(bytes.len());
            bytes[at] = *v;
            if *r {
                reseal(bytes, at);
            }
        }
        ByteEdit::Insert(i, b) => {
            let at = i.index(bytes.len() + 1);
            bytes.splice(at..at, b.iter().copied());
        }
        ByteEdit::Delete(i, n) if !bytes.is_empty() => {
            let at = i.index(bytes.len());
            bytes.drain(at..(at + n).min(bytes.len()));
        }
        ByteEdit::Truncate(i) => bytes.truncate(i.index(bytes.len() + 1)),
        ByteEdit::Count(d) if bytes.len() >= HEADER_LEN => {
            let n = u32::from_le_bytes(bytes[32..36].try_into().unwrap());
            bytes[32..36].copy_from_slice(&n.wrapping_add_signed(i32::from(*d)).to_le_bytes());
            reseal(bytes, 0);
        }
        _ => {}
    }
}

/// Checks of every sample, whatever produced it.
fn check_sample(s: &ImuSample) -> Result<(), TestCaseError> {
    let (a, b) = match s.motion {
        Motion::Increments {
            delta_theta_ib_b,
            delta_v_ib_b,
        } => (delta_theta_ib_b, delta_v_ib_b),
        Motion::Rates { omega_ib_b, f_ib_b } => (omega_ib_b, f_ib_b),
    };
    prop_assert!(
        s.flags.contains(SampleFlags::NON_FINITE) || a.iter().chain(&b).all(|v| v.is_finite()),
        "non-finite values not flagged: {s:?}"
    );
    prop_assert!(s.dt_s.is_finite() && s.dt_s >= 0.0, "{s:?}");
    prop_assert!(
        !s.flags.usable() || s.dt_s > 0.0,
        "usable with dt_s = 0: {s:?}"
    );
    Ok(())
}

/// Replays `bytes` to the end or the first error, checking every sample and the counters
/// against the reading rules.
fn replay_all(bytes: &[u8]) -> Result<(), TestCaseError> {
    let mut replay = match Replay::new(bytes) {
        Ok(r) => r,
        Err(ReplayError::Format(e)) => {
            prop_assert!(e.offset <= HEADER_LEN as u64 && e.record.is_none(), "{e}");
            return Ok(());
        }
        Err(ReplayError::Io(never)) => match never {},
    };
    let header = *replay.header();
    prop_assert!(header.rate_hz.is_finite() && header.rate_hz > 0.0);
    let mut prev_t_ns = header.t0_ns;
    // The accelerometer field of the last record of one period (the reader's reference for a
    // record of increments after a gap, docs/recording-format.md).
    let mut reference: Option<[f64; 3]> = None;
    let (mut n, mut non_finite, mut bad_interval) = (0u32, 0u32, 0u32);
    let failure = loop {
        match replay.read_sample() {
            Ok(Some(s)) => {
                check_sample(&s)?;
                let at = HEADER_LEN + RECORD_LEN * n as usize;
                let record = Record::decode(bytes[at..at + RECORD_LEN].try_into().unwrap(), 0, n)
                    .expect("a delivered record has a valid CRC");
                let nf = !record
                    .gyro
                    .iter()
                    .chain(&record.accel)
                    .all(|v| v.is_finite());
                prop_assert_eq!(s.flags.contains(SampleFlags::NON_FINITE), nf, "{:?}", s);
                // The interval rules, with the nominal period T.
                let period_ns = 1e9 / header.rate_hz;
                let accel = record.accel.map(f64::from);
                let (bad, gap, short) = if record.t_ns <= prev_t_ns {
                    prop_assert_eq!(s.dt_s, 0.0);
                    (true, false, false)
                } else {
                    let delta_ns = (record.t_ns - prev_t_ns) as f64;
                    let in_gap = delta_ns > 1.5 * period_ns && delta_ns <= 10.0 * period_ns;
                    // One period's increment after a gap: smaller than (1 + periods) / 2 times
                    // the reference's.
                    let norm2 = |v: &[f64; 3]| v.iter().map(|x| x * x).sum::<f64>();
                    let k = 0.5 * (1.0 + delta_ns / period_ns);
                    let short = in_gap
                        && header.kind == Kind::Increments
                        && !nf
                        && reference.is_some_and(|p| norm2(&accel) < k * k * norm2(&p));
                    (
                        delta_ns > 10.0 * period_ns || short,
                        in_gap && !short,
                        short,
                    )
                };
                if (short || !(bad || gap)) && !nf {
                    reference = Some(accel);
                }
                prop_assert_eq!(s.flags.contains(SampleFlags::BAD_INTERVAL), bad, "{:?}", s);
                prop_assert_eq!(s.flags.contains(SampleFlags::GAP), gap, "{:?}", s);
                prop_assert_eq!((s.seq, s.t_us), (n, record.t_ns / 1000));
                // Copied as it is (NaN = unknown; the format gives no other rule).
                prop_assert_eq!(s.temperature_c.to_bits(), record.temperature_c.to_bits());
                prev_t_ns = record.t_ns;
                n += 1;
                non_finite += u32::from(nf);
                bad_interval += u32::from(s.flags.contains(SampleFlags::BAD_INTERVAL));
                prop_assert!(n <= header.sample_count);
            }
            Ok(None) => break None,
            Err(ReplayError::Format(e)) => break Some(e),
            Err(ReplayError::Io(never)) => match never {},
        }
    };
    let stats = replay.stats();
    prop_assert_eq!(
        (stats.samples, stats.non_finite, stats.bad_interval),
        (n, non_finite, bad_interval)
    );
    match failure {
        None => {
            // A complete pass: exactly the announced records, nothing after them.
            prop_assert_eq!(n, header.sample_count);
            prop_assert_eq!(bytes.len() as u64, header.file_len());
            prop_assert!(matches!(replay.read_sample(), Ok(None)));
        }
        Some(e) => {
            prop_assert!(
                matches!(
                    e.kind,
                    FormatErrorKind::RecordCrc
                        | FormatErrorKind::Truncated
                        | FormatErrorKind::TrailingData
                ),
                "{e}"
            );
            prop_assert!(e.offset <= bytes.len() as u64, "{e}");
            // Final: the same error again.
            match replay.read_sample() {
                Err(ReplayError::Format(again)) => prop_assert_eq!(again, e),
                other => prop_assert!(false, "after {e}: {other:?}"),
            }
        }
    }
    Ok(())
}

#[test]
fn recording_header_decoder() {
    let bytes = prop_oneof![
        proptest::collection::vec(any::<u8>(), HEADER_LEN),
        (
            headers(),
            any::<u32>(),
            proptest::collection::vec(byte_edit(), 0..3)
        )
            .prop_map(|(mut h, n, edits)| {
                h.sample_count = n;
                let mut b = h.encode().to_vec();
                for e in &edits {
                    edit(&mut b, e);
                }
                b.resize(HEADER_LEN, 0);
                b
            }),
    ];
    fuzz("recording header decoder", bytes, |b| {
        let bytes: [u8; HEADER_LEN] = b.as_slice().try_into().unwrap();
        if let Ok(h) = Header::decode(&bytes) {
            prop_assert!(h.rate_hz.is_finite() && h.rate_hz > 0.0);
            // Everything a valid header holds is in the decoded value.
            prop_assert_eq!(h.encode(), bytes);
        }
        Ok(())
    });
}

#[test]
fn recording_record_decoder() {
    let bytes = (
        proptest::collection::vec(any::<u8>(), RECORD_LEN),
        any::<bool>(),
    )
        .prop_map(|(mut b, seal)| {
            if seal {
                reseal(&mut b, HEADER_LEN);
            }
            b
        });
    fuzz("recording record decoder", bytes, |b| {
        // Placed as record 0 of a file (the reseal helper works on file offsets).
        let mut file = vec![0u8; HEADER_LEN];
        file.extend_from_slice(&b);
        reseal(&mut file, HEADER_LEN);
        let sealed: [u8; RECORD_LEN] = file[HEADER_LEN..].try_into().unwrap();
        let r = Record::decode(&sealed, 48, 0).expect("a resealed record decodes");
        prop_assert_eq!(r.encode(), sealed);
        let raw: [u8; RECORD_LEN] = b.as_slice().try_into().unwrap();
        match Record::decode(&raw, 48, 0) {
            Ok(r) => prop_assert_eq!(r.encode(), raw),
            Err(e) => prop_assert_eq!(e.kind, FormatErrorKind::RecordCrc),
        }
        Ok(())
    });
}

#[test]
fn replay_of_arbitrary_bytes() {
    // Bytes alone, or after a valid header (so the records are reached).
    let bytes = (
        headers(),
        any::<u32>(),
        any::<bool>(),
        proptest::collection::vec(any::<u8>(), 0..400),
    )
        .prop_map(|(mut h, n, with_header, tail)| {
            if with_header {
                h.sample_count = n % 12;
                let mut b = h.encode().to_vec();
                b.extend(tail);
                b
            } else {
                tail
            }
        });
    fuzz("replay of arbitrary bytes", bytes, |b| replay_all(&b));
}

#[test]
fn replay_of_mutated_recordings() {
    let files = (
        headers(),
        records(),
        proptest::collection::vec(byte_edit(), 0..4),
    )
        .prop_map(|(mut h, records, edits)| {
            h.sample_count = records.len() as u32;
            let mut b = h.encode().to_vec();
            for r in &records {
                b.extend_from_slice(&r.encode());
            }
            for e in &edits {
                edit(&mut b, e);
            }
            b
        });
    fuzz("replay of mutated recordings", files, |b| replay_all(&b));
}

// ---------------------------------------------------------------------------------------------
// The drivers, fed frame by frame.

/// An `SpiDevice` that answers the data read of each transaction (its last `Read`) with the next
/// frame (zero-padded or cut to the read's length); zeros once the frames are used up.
struct FrameSpi {
    frames: VecDeque<Vec<u8>>,
}

impl FrameSpi {
    fn new(frames: Vec<Vec<u8>>) -> Self {
        FrameSpi {
            frames: frames.into(),
        }
    }
}

impl ErrorType for FrameSpi {
    type Error = Infallible;
}

impl SpiDevice for FrameSpi {
    fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        // A transaction without a read (a register write) takes no frame.
        if let Some(Operation::Read(buf)) = ops
            .iter_mut()
            .rev()
            .find(|op| matches!(op, Operation::Read(_)))
        {
            let frame = self.frames.pop_front().unwrap_or_default();
            for (i, b) in buf.iter_mut().enumerate() {
                *b = frame.get(i).copied().unwrap_or(0);
            }
        }
        Ok(())
    }
}

/// Per-axis limits of a sample's gyro and accelerometer values: in output units for rates, per
/// second of `dt_s` for increments.
struct Limits {
    gyro: f64,
    accel: f64,
}

/// The sample within `limits` unless it is unusable or saturated (identity mounting: body axes
/// are sensor axes).
fn check_range(s: &ImuSample, limits: &Limits) -> Result<(), TestCaseError> {
    check_sample(s)?;
    prop_assert!(!s.temperature_c.is_infinite(), "{s:?}");
    let saturated = SampleFlags::GYRO_SATURATED | SampleFlags::ACCEL_SATURATED;
    if !s.flags.usable() || s.flags.intersects(saturated) {
        return Ok(());
    }
    let (a, b, per) = match s.motion {
        Motion::Rates { omega_ib_b, f_ib_b } => (omega_ib_b, f_ib_b, 1.0),
        Motion::Increments {
            delta_theta_ib_b,
            delta_v_ib_b,
        } => (delta_theta_ib_b, delta_v_ib_b, f64::from(s.dt_s)),
    };
    let (gyro_max, accel_max) = (
        limits.gyro * per * (1.0 + RANGE_SLACK),
        limits.accel * per * (1.0 + RANGE_SLACK),
    );
    prop_assert!(
        a.iter().all(|v| f64::from(v.abs()) <= gyro_max),
        "gyro beyond {gyro_max}: {s:?}"
    );
    prop_assert!(
        b.iter().all(|v| f64::from(v.abs()) <= accel_max),
        "accel beyond {accel_max}: {s:?}"
    );
    Ok(())
}

/// Reads `n` samples, checking each; transient errors are what a bad frame may give.
fn drive<D: ImuDriver<BusError = Infallible>>(
    imu: &mut D,
    n: usize,
    limits: &Limits,
) -> Result<(), TestCaseError> {
    for t in 0..n as u64 {
        match imu.read_sample(t * 2500) {
            Ok(s) => check_range(&s, limits)?,
            Err(e) => prop_assert!(e.is_transient(), "{e}"),
        }
    }
    Ok(())
}

fn adis_configs() -> impl Strategy<Value = adis16505::Config> {
    let ranges = prop_oneof![
        Just(Range::Dps125),
        Just(Range::Dps500),
        Just(Range::Dps2000)
    ];
    (ranges, any::<bool>(), any::<bool>(), any::<bool>()).prop_map(|(r, adis05, inc, wide)| {
        let model = if adis05 {
            Model::Adis16505(r)
        } else {
            Model::Adis16465(r)
        };
        let output = if inc {
            adis16505::Output::Increments
        } else {
            adis16505::Output::Rates
        };
        adis16505::Config::new(model)
            .with_output(output)
            .with_burst32(wide)
    })
}

/// The ADIS measurement range of `config` (the model's datasheet ranges, written out again).
fn adis_limits(config: &adis16505::Config) -> Limits {
    let (range, accel_mps2) = match config.model {
        Model::Adis16505(r) => (r, 78.4),
        Model::Adis16465(r) => (r, 8.0 * G),
    };
    let gyro_dps = match range {
        Range::Dps125 => 125.0,
        Range::Dps500 => 500.0,
        Range::Dps2000 => 2000.0,
    };
    Limits {
        gyro: gyro_dps * DEG,
        accel: accel_mps2,
    }
}

/// The raw count at the measurement range of `config` (after [`adis16505::Config`]'s
/// model restrictions), gyro and accelerometer: the datasheet scales written out again
/// (16-bit rates: 160/40/10 LSB/(deg/s), 32000 LSB at the accelerometer range; 16-bit
/// increments: delta angle 360/720/2160 deg and delta velocity 100 m/s over 2^15; x 2^16 for
/// the 32-bit burst; 2.5 ms output period).
fn adis_clip_counts(config: &adis16505::Config) -> (f64, f64) {
    let (lsb_per_dps, delta_range_deg) = match config.model.range() {
        Range::Dps125 => (160.0, 360.0),
        Range::Dps500 => (40.0, 720.0),
        Range::Dps2000 => (10.0, 2160.0),
    };
    let limits = adis_limits(config);
    let wide = if config.burst32 { 65536.0 } else { 1.0 };
    let period_s = 0.0025;
    let (gyro, accel) = match config.output {
        adis16505::Output::Rates => (limits.gyro / DEG * lsb_per_dps, 32000.0),
        adis16505::Output::Increments => (
            limits.gyro / DEG * period_s / (delta_range_deg / 32768.0),
            limits.accel * period_s / (100.0 / 32768.0),
        ),
    };
    (gyro * wide, accel * wide)
}

/// Burst frames of the driver's `config`: the six inertial values within the range (fractions
/// of the clip count) or anywhere (clip counts, extremes, any), `DATA_CNTR` mostly advancing by
/// one, `DIAG_STAT` mostly clear, the checksum right; then byte edits, after which the checksum
/// is made right again or not.
fn adis_frames(config: adis16505::Config) -> impl Strategy<Value = Vec<Vec<u8>>> {
    let len = config.frame_len();
    let (gyro_clip, accel_clip) = adis_clip_counts(&config);
    let (lo, hi) = if config.burst32 {
        (f64::from(i32::MIN), f64::from(i32::MAX))
    } else {
        (-32768.0, 32767.0)
    };
    let value = move |clip: f64| {
        prop_oneof![
            4 => (-0.9999f64..0.9999).prop_map(move |f| f * clip),
            1 => prop_oneof![Just(clip), Just(-clip), Just(clip - 1.0), Just(lo), Just(hi)],
            1 => lo..=hi,
        ]
        .prop_map(move |v: f64| v.round().clamp(lo, hi) as i32)
    };
    let frame = (
        proptest::collection::vec(value(gyro_clip), 3),
        proptest::collection::vec(value(accel_clip), 3),
        prop_oneof![4 => Just(0u16), 1 => any::<u16>()],
        any::<u16>(),
        prop_oneof![6 => Just(1u16), 1 => Just(0), 1 => 2u16..15, 1 => any::<u16>()],
        proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..2),
        any::<bool>(),
    );
    proptest::collection::vec(frame, 1..12).prop_map(move |frames| {
        let mut cntr = 0u16;
        frames
            .into_iter()
            .map(|(gyro, accel, diag, temp, step, edits, reseal)| {
                cntr = cntr.wrapping_add(step);
                let mut words = vec![diag];
                for v in gyro.iter().chain(&accel) {
                    if config.burst32 {
                        words.extend([*v as u16, (*v >> 16) as u16]); // _LOW, then _OUT
                    } else {
                        words.push(*v as i16 as u16);
                    }
                }
                words.extend([temp, cntr, 0]);
                let mut f: Vec<u8> = words.iter().flat_map(|w| w.to_be_bytes()).collect();
                assert_eq!(f.len(), len);
                let seal = |f: &mut Vec<u8>| {
                    let sum = checksum(&f[..len - 2]);
                    f[len - 2..].copy_from_slice(&sum.to_be_bytes());
                };
                seal(&mut f);
                for (i, v) in &edits {
                    f[i.index(len)] = *v;
                }
                if reseal {
                    seal(&mut f);
                }
                f
            })
            .collect()
    })
}

#[test]
fn adis_burst_decode() {
    let cases = adis_configs().prop_flat_map(|c| {
        // The configuration in effect (the ADIS16465 has neither increments nor 32-bit bursts).
        let c = *Adis16505::new(FrameSpi::new(vec![]), c).config();
        let frames = prop_oneof![
            3 => adis_frames(c),
            1 => proptest::collection::vec(proptest::collection::vec(any::<u8>(), c.frame_len()), 1..8),
        ];
        (Just(c), frames)
    });
    fuzz("ADIS16505/16465 burst decode", cases, |(config, frames)| {
        let n = frames.len();
        let mut imu = Adis16505::new(FrameSpi::new(frames), config);
        drive(&mut imu, n, &adis_limits(&config))
    });
}

/// ICM-42688-P FIFO reads: the status (mostly "5 packets in the FIFO") and 5 packets with
/// valid headers (sometimes empty or foreign), timestamps mostly 500 us apart, values near full
/// scale or the invalid marker among random ones; then byte edits.
fn icm_reads() -> impl Strategy<Value = Vec<Vec<u8>>> {
    // Within full scale and valid (a clean read), or anything including the markers.
    let clean = -(icm42688::ACCEL_FULL_SCALE_20 - 1)..icm42688::ACCEL_FULL_SCALE_20;
    let mixed = prop_oneof![
        any::<i32>().prop_map(|v| v >> 12),
        Just(icm42688::INVALID_20),
        Just(icm42688::GYRO_FULL_SCALE_20),
        Just(icm42688::ACCEL_FULL_SCALE_20 - 4),
        Just(-524_287),
        (-3000i32..3000),
    ];
    let values = prop_oneof![
        proptest::collection::vec(clean, 30),
        proptest::collection::vec(mixed, 30)
    ];
    let packet = (
        prop_oneof![8 => Just(0x78u8), 1 => Just(0x80), 1 => any::<u8>()]
            .prop_flat_map(|h| (Just(h), 0u8..4)),
        prop_oneof![Just(-32768i16), any::<i16>(), Just(0)],
        prop_oneof![8 => Just(500u16), 1 => Just(0), 1 => any::<u16>()],
    );
    let read = (
        prop_oneof![6 => Just((0u8, 100u16)), 1 => (any::<u8>(), any::<u16>()), 1 => Just((0, 60))],
        values,
        proptest::collection::vec(packet, 5),
        proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..2),
    );
    proptest::collection::vec(read, 1..10).prop_map(|reads| {
        let mut t = 0u16;
        reads
            .into_iter()
            .map(|((int_status, count), values, packets, edits)| {
                let mut b = vec![int_status];
                b.extend(count.to_be_bytes());
                for (((header, odr), temp, step), v) in packets.into_iter().zip(values.chunks(6)) {
                    t = t.wrapping_add(step);
                    let mut p = [0u8; 20];
                    p[0] = if header == 0x78 { header | odr } else { header };
                    for axis in 0..3 {
                        let (a, g) = (v[axis] as u32 & 0xF_FFFF, v[3 + axis] as u32 & 0xF_FFFF);
                        p[1 + 2 * axis] = (a >> 12) as u8;
                        p[2 + 2 * axis] = (a >> 4) as u8;
                        p[7 + 2 * axis] = (g >> 12) as u8;
                        p[8 + 2 * axis] = (g >> 4) as u8;
                        p[17 + axis] = ((a & 0xF) << 4) as u8 | (g & 0xF) as u8;
                    }
                    p[13..15].copy_from_slice(&temp.to_be_bytes());
                    p[15..17].copy_from_slice(&t.to_be_bytes());
                    b.extend(p);
                }
                let len = b.len();
                for (i, v) in &edits {
                    b[i.index(len)] = *v;
                }
                b
            })
            .collect()
    })
}

#[test]
fn icm42688_fifo_decode() {
    let reads = prop_oneof![
        3 => icm_reads(),
        1 => proptest::collection::vec(proptest::collection::vec(any::<u8>(), 103), 1..6),
    ];
    // Full scale: 2000 deg/s and 16 g, as the 20-bit full-scale counts over the sensitivities
    // (262 LSB/(deg/s), 32768 LSB/g).
    let limits = Limits {
        gyro: f64::from(icm42688::GYRO_FULL_SCALE_20) / 262.0 * DEG,
        accel: f64::from(icm42688::ACCEL_FULL_SCALE_20) / 32768.0 * G,
    };
    fuzz("ICM-42688-P FIFO decode", reads, |reads| {
        // A FIFO flush (after an overflow or a bad header) is a transaction of its own.
        let n = reads.len();
        let mut imu = Icm42688::new(FrameSpi::new(reads), icm42688::Config::default());
        drive(&mut imu, n, &limits)
    });
}

fn bmi088_configs() -> impl Strategy<Value = bmi088::Config> {
    (0u8..5, 0u8..4).prop_map(|(g, a)| bmi088::Config {
        gyro_range: GyroRange::from_code(g),
        accel_range: AccelRange::from_code(a),
        ..Default::default()
    })
}

/// BMI088 frames: gyro rates and an accelerometer frame (dummy byte, acceleration, sensor time
/// mostly 64 counts on, temperature), values near full scale among random ones; then byte edits.
fn bmi088_frames() -> impl Strategy<Value = Vec<(Vec<u8>, Vec<u8>)>> {
    let value = prop_oneof![
        any::<i16>(),
        Just(i16::MAX),
        Just(i16::MIN),
        Just(32766),
        Just(-32766),
        (-500i16..500)
    ];
    let sample = (
        proptest::collection::vec(value.clone(), 3),
        proptest::collection::vec(value, 3),
        prop_oneof![6 => Just(64u32), 1 => Just(0), 1 => 1u32..1000, 1 => any::<u32>()],
        proptest::collection::vec(any::<u8>(), 10),
        proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..2),
    );
    proptest::collection::vec(sample, 1..12).prop_map(|samples| {
        let mut sensortime = 0u32;
        samples
            .into_iter()
            .map(|(gyro, accel, step, rest, edits)| {
                sensortime = sensortime.wrapping_add(step) & 0xFF_FFFF;
                let g: Vec<u8> = gyro.iter().flat_map(|v| v.to_le_bytes()).collect();
                let mut a = vec![rest[0]]; // the dummy byte
                a.extend(accel.iter().flat_map(|v| v.to_le_bytes()));
                a.extend(&sensortime.to_le_bytes()[..3]);
                a.extend(&rest[1..]); // status, reserved, temperature
                let mut both = g.into_iter().chain(a).collect::<Vec<u8>>();
                let len = both.len();
                for (i, v) in &edits {
                    both[i.index(len)] = *v;
                }
                let a = both.split_off(6);
                (both, a)
            })
            .collect()
    })
}

#[test]
fn bmi088_frame_decode() {
    let frames = prop_oneof![
        3 => bmi088_frames(),
        1 => proptest::collection::vec((proptest::collection::vec(any::<u8>(), 6), proptest::collection::vec(any::<u8>(), 19)), 1..8),
    ];
    let cases = (bmi088_configs(), frames);
    fuzz("BMI088 frame decode", cases, |(config, frames)| {
        let n = frames.len();
        let (gyro, accel): (Vec<_>, Vec<_>) = frames.into_iter().unzip();
        let mut imu = Bmi088::new(FrameSpi::new(gyro), FrameSpi::new(accel), config);
        // The ranges of the range codes, written out again.
        let limits = Limits {
            gyro: [2000.0, 1000.0, 500.0, 250.0, 125.0][usize::from(config.gyro_range.code())]
                * DEG,
            accel: [3.0, 6.0, 12.0, 24.0][usize::from(config.accel_range.code())] * G,
        };
        for t in 0..n as u64 {
            match imu.read_sample(t * 2500) {
                Ok(s) => check_range(&s, &limits)?,
                Err(e) => prop_assert!(matches!(e, Error::ZeroFrame), "{e}"),
            }
        }
        Ok(())
    });
}
