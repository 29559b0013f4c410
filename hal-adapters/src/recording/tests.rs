extern crate std;

use core::convert::Infallible;
use std::{string::ToString, vec::Vec};

use proptest::prelude::*;

use super::*;

/// Nominal rate of the test recordings [Hz]: period 10 ms.
const RATE_HZ: f64 = 100.0;
const PERIOD_NS: u64 = 10_000_000;
const T0_NS: u64 = 1_000_000_000;

fn header(kind: Kind, sample_count: u32) -> Header {
    Header {
        kind,
        rate_hz: RATE_HZ,
        t0_ns: T0_NS,
        sample_count,
    }
}

fn record(t_ns: u64) -> Record {
    Record {
        t_ns,
        gyro: [1e-4, -2e-4, 3e-4],
        accel: [0.01, -0.02, -0.098],
        temperature_c: 24.5,
    }
}

/// Records `1..=n` periods after `T0_NS`.
fn regular_records(n: u32) -> Vec<Record> {
    (1..=u64::from(n))
        .map(|k| record(T0_NS + k * PERIOD_NS))
        .collect()
}

fn file(header: &Header, records: &[Record]) -> Vec<u8> {
    let mut bytes = header.encode().to_vec();
    for record in records {
        bytes.extend_from_slice(&record.encode());
    }
    bytes
}

/// Rewrites the header CRC after a field was patched.
fn fix_header_crc(bytes: &mut [u8]) {
    let crc = CRC32.checksum(&bytes[..44]);
    bytes[44..48].copy_from_slice(&crc.to_le_bytes());
}

/// Replays until the end or the first error (bounded: a replay that does not stop is a bug).
fn replay_all(bytes: &[u8]) -> (Vec<ImuSample>, Result<ReplayStats, FormatError>) {
    let mut replay = match Replay::new(bytes) {
        Ok(replay) => replay,
        Err(ReplayError::Format(error)) => return (Vec::new(), Err(error)),
        Err(ReplayError::Io(never)) => match never {},
    };
    let mut samples = Vec::new();
    for _ in 0..bytes.len() / RECORD_LEN + 2 {
        match replay.read_sample() {
            Ok(Some(sample)) => samples.push(sample),
            Ok(None) => {
                // The end is sticky.
                assert!(matches!(replay.read_sample(), Ok(None)));
                return (samples, Ok(replay.stats()));
            }
            Err(ReplayError::Format(error)) => {
                // Errors are sticky too.
                assert!(matches!(replay.read_sample(), Err(ReplayError::Format(e)) if e == error));
                return (samples, Err(error));
            }
            Err(ReplayError::Io(never)) => match never {},
        }
    }
    panic!("replay did not stop");
}

fn replay_error(bytes: &[u8]) -> FormatError {
    replay_all(bytes).1.expect_err("expected a format error")
}

/// Sample with every float as bits, so that NaNs compare.
fn bits(sample: &ImuSample) -> (u64, u32, u32, [u32; 3], [u32; 3], bool, u32, u16) {
    let (increments, gyro, accel) = match sample.motion {
        Motion::Increments {
            delta_theta_ib_b,
            delta_v_ib_b,
        } => (true, delta_theta_ib_b, delta_v_ib_b),
        Motion::Rates { omega_ib_b, f_ib_b } => (false, omega_ib_b, f_ib_b),
    };
    (
        sample.t_us,
        sample.seq,
        sample.dt_s.to_bits(),
        gyro.map(f32::to_bits),
        accel.map(f32::to_bits),
        increments,
        sample.temperature_c.to_bits(),
        sample.flags.bits(),
    )
}

/// An `embedded_io::Write` sink into a `Vec` (embedded-io's own impl needs its `alloc` feature).
#[derive(Debug, Default)]
struct VecSink(Vec<u8>);

impl embedded_io::ErrorType for VecSink {
    type Error = Infallible;
}

impl Write for VecSink {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.0.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

fn error(kind: FormatErrorKind, offset: u64, record: Option<u32>) -> FormatError {
    FormatError {
        kind,
        offset,
        record,
        expected_records: None,
    }
}

// ---- encoding against the spec, written out independently -------------------------------

#[test]
fn crc_is_crc32_iso_hdlc() {
    // The catalogue check value of CRC-32/ISO-HDLC.
    assert_eq!(CRC32.checksum(b"123456789"), 0xCBF4_3926);
}

/// Bytes computed by hand from the spec (Python `struct` and `zlib.crc32`), not by `encode`.
const SPEC_HEADER: [u8; 48] = [
    0x4e, 0x41, 0x56, 0x49, 0x4d, 0x55, 0x0d, 0x0a, // magic "NAVIMU\r\n"
    0x01, 0x00, // version 1
    0x30, 0x00, // header_len 48
    0x28, 0x00, // record_len 40
    0x01, 0x00, // kind 1 = rates
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x69, 0x40, // rate_hz 200.0
    0x00, 0xca, 0x9a, 0x3b, 0x00, 0x00, 0x00, 0x00, // t0_ns 1e9
    0x03, 0x00, 0x00, 0x00, // sample_count 3
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // reserved
    0xce, 0x42, 0x65, 0x37, // header_crc 0x376542ce
];

/// As [`SPEC_HEADER`]: t_ns 1.005e9, gyro [0.25, -0.5, 1.0], accel [0, 0, -9.75], 25.5 deg C.
const SPEC_RECORD: [u8; 40] = [
    0x40, 0x15, 0xe7, 0x3b, 0x00, 0x00, 0x00, 0x00, // t_ns
    0x00, 0x00, 0x80, 0x3e, 0x00, 0x00, 0x00, 0xbf, 0x00, 0x00, 0x80, 0x3f, // gyro
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1c, 0xc1, // accel
    0x00, 0x00, 0xcc, 0x41, // temperature
    0x4d, 0xc3, 0xc3, 0xcb, // record_crc
];

#[test]
fn header_encodes_to_spec_bytes() {
    let header = Header {
        kind: Kind::Rates,
        rate_hz: 200.0,
        t0_ns: 1_000_000_000,
        sample_count: 3,
    };
    assert_eq!(header.encode(), SPEC_HEADER);
    assert_eq!(Header::decode(&SPEC_HEADER), Ok(header));
    assert_eq!(header.period_ns(), 5e6);
    assert_eq!(header.file_len(), 48 + 3 * 40);
}

#[test]
fn record_encodes_to_spec_bytes() {
    let record = Record {
        t_ns: 1_005_000_000,
        gyro: [0.25, -0.5, 1.0],
        accel: [0.0, 0.0, -9.75],
        temperature_c: 25.5,
    };
    assert_eq!(record.encode(), SPEC_RECORD);
    assert_eq!(Record::decode(&SPEC_RECORD, 48, 0), Ok(record));
}

#[test]
fn spec_file_replays() {
    let mut bytes = SPEC_HEADER.to_vec();
    bytes.extend_from_slice(&SPEC_RECORD);
    // The header announces 3 records; only one follows.
    assert_eq!(
        replay_all(&bytes).1,
        Err(FormatError {
            kind: FormatErrorKind::Truncated,
            offset: 88,
            record: Some(1),
            expected_records: Some(3)
        })
    );
    let (samples, _) = replay_all(&bytes);
    assert_eq!(samples.len(), 1);
    let sample = samples[0];
    assert_eq!(sample.t_us, 1_005_000);
    assert_eq!(sample.dt_s, 0.005);
    assert_eq!(
        sample.motion,
        Motion::Rates {
            omega_ib_b: [0.25, -0.5, 1.0],
            f_ib_b: [0.0, 0.0, -9.75]
        }
    );
    assert_eq!(sample.temperature_c, 25.5);
    assert_eq!(sample.flags, SampleFlags::empty());
}

#[test]
fn kind_codes() {
    for kind in [Kind::Increments, Kind::Rates] {
        assert_eq!(Kind::from_code(kind.code()), Some(kind));
    }
    assert_eq!(Kind::Increments.code(), 0);
    assert_eq!(Kind::Rates.code(), 1);
    assert_eq!(Kind::from_code(2), None);
}

// ---- round trips ----------------------------------------------------------------------------

#[test]
fn header_round_trip() {
    for kind in [Kind::Increments, Kind::Rates] {
        for (rate_hz, t0_ns, sample_count) in [
            (1.0, 0, 0),
            (400.0, u64::MAX, u32::MAX),
            (f64::MIN_POSITIVE, 12_345, 7),
            (f64::MAX, 1, 1),
        ] {
            let header = Header {
                kind,
                rate_hz,
                t0_ns,
                sample_count,
            };
            assert_eq!(Header::decode(&header.encode()), Ok(header));
        }
    }
}

#[test]
fn record_round_trip() {
    let records = [
        record(0),
        record(u64::MAX),
        Record {
            t_ns: 5,
            gyro: [f32::NAN, f32::INFINITY, -0.0],
            accel: [f32::MIN, f32::MAX, 1e-45],
            temperature_c: f32::NAN,
        },
    ];
    for record in records {
        let decoded = Record::decode(&record.encode(), 0, 0).unwrap();
        assert_eq!(decoded.t_ns, record.t_ns);
        assert_eq!(
            decoded.gyro.map(f32::to_bits),
            record.gyro.map(f32::to_bits)
        );
        assert_eq!(
            decoded.accel.map(f32::to_bits),
            record.accel.map(f32::to_bits)
        );
        assert_eq!(
            decoded.temperature_c.to_bits(),
            record.temperature_c.to_bits()
        );
    }
}

#[test]
fn writer_round_trip_and_count_checks() {
    let header = header(Kind::Increments, 3);
    let records = regular_records(3);
    let mut writer = Writer::new(VecSink::default(), header).unwrap();
    for record in &records {
        writer.write_record(record).unwrap();
    }
    assert_eq!(writer.written(), 3);
    assert!(matches!(
        writer.write_record(&records[0]),
        Err(WriteError::TooManyRecords(3))
    ));
    let bytes = writer.finish().unwrap();
    assert_eq!(bytes.0, file(&header, &records));

    let mut writer = Writer::new(VecSink::default(), header).unwrap();
    writer.write_record(&records[0]).unwrap();
    assert!(matches!(
        writer.finish(),
        Err(WriteError::TooFewRecords {
            expected: 3,
            written: 1
        })
    ));

    let bad = Header {
        rate_hz: f64::NAN,
        ..header
    };
    assert!(matches!(
        Writer::new(VecSink::default(), bad),
        Err(WriteError::InvalidHeader(FormatError { offset: 16, .. }))
    ));
}

// ---- sample semantics -----------------------------------------------------------------------

#[test]
fn regular_recording_replays() {
    for kind in [Kind::Increments, Kind::Rates] {
        let records = regular_records(5);
        let (samples, end) = replay_all(&file(&header(kind, 5), &records));
        assert_eq!(
            end,
            Ok(ReplayStats {
                samples: 5,
                ..ReplayStats::default()
            })
        );
        assert_eq!(samples.len(), 5);
        for (i, (sample, record)) in samples.iter().zip(&records).enumerate() {
            assert_eq!(sample.seq, i as u32);
            assert_eq!(sample.t_us, record.t_ns / 1000);
            assert_eq!(sample.dt_s, 0.01);
            assert_eq!(sample.temperature_c, 24.5);
            assert_eq!(sample.flags, SampleFlags::empty());
            let expected = match kind {
                Kind::Increments => Motion::Increments {
                    delta_theta_ib_b: record.gyro,
                    delta_v_ib_b: record.accel,
                },
                Kind::Rates => Motion::Rates {
                    omega_ib_b: record.gyro,
                    f_ib_b: record.accel,
                },
            };
            assert_eq!(sample.motion, expected);
        }
    }
}

#[test]
fn empty_recording() {
    let (samples, end) = replay_all(&file(&header(Kind::Rates, 0), &[]));
    assert!(samples.is_empty());
    assert_eq!(end, Ok(ReplayStats::default()));
}

#[test]
fn t_us_truncates_and_first_dt_is_from_t0() {
    let records = [record(T0_NS + 2_500_999)];
    let (samples, _) = replay_all(&file(&header(Kind::Rates, 1), &records));
    assert_eq!(samples[0].t_us, 1_002_500);
    assert_eq!(samples[0].dt_s, (2_500_999.0f64 * 1e-9) as f32);
}

#[test]
fn nan_sample_is_flagged_not_an_error() {
    let mut records = regular_records(4);
    records[1].gyro[1] = f32::NAN;
    records[2].accel[2] = f32::NEG_INFINITY;
    records[3].temperature_c = f32::NAN; // unknown temperature: fine
    let (samples, end) = replay_all(&file(&header(Kind::Increments, 4), &records));
    assert_eq!(
        end,
        Ok(ReplayStats {
            samples: 4,
            non_finite: 2,
            ..ReplayStats::default()
        })
    );
    assert_eq!(samples[0].flags, SampleFlags::empty());
    assert_eq!(samples[1].flags, SampleFlags::NON_FINITE);
    assert_eq!(samples[2].flags, SampleFlags::NON_FINITE);
    assert!(!samples[1].flags.usable());
    assert_eq!(samples[3].flags, SampleFlags::empty());
    assert!(samples[3].temperature_c.is_nan());
}

#[test]
fn time_going_backwards_is_bad_interval() {
    let records = [
        record(T0_NS + PERIOD_NS),
        record(T0_NS + 2 * PERIOD_NS),
        record(T0_NS + PERIOD_NS + PERIOD_NS / 2), // backwards
        record(T0_NS + PERIOD_NS + PERIOD_NS / 2), // repeated
        record(T0_NS + 2 * PERIOD_NS + PERIOD_NS / 2), // one period after the previous record
    ];
    let (samples, end) = replay_all(&file(&header(Kind::Rates, 5), &records));
    assert_eq!(
        end,
        Ok(ReplayStats {
            samples: 5,
            bad_interval: 2,
            not_after_previous: 2,
            ..ReplayStats::default()
        })
    );
    assert_eq!(samples[2].flags, SampleFlags::BAD_INTERVAL);
    assert_eq!(samples[2].dt_s, 0.0);
    assert_eq!(samples[3].flags, SampleFlags::BAD_INTERVAL);
    assert_eq!(samples[3].dt_s, 0.0);
    assert_eq!(samples[4].flags, SampleFlags::empty());
    assert_eq!(samples[4].dt_s, 0.01);
}

#[test]
fn three_period_gap() {
    // The increment after the gap covers its three periods (a sensor accumulating between
    // reads), as the format defines it.
    let mut covering = record(T0_NS + 4 * PERIOD_NS);
    covering.accel = covering.accel.map(|a| 3.0 * a);
    let records = [
        record(T0_NS + PERIOD_NS),
        covering,
        record(T0_NS + 5 * PERIOD_NS),
    ];
    let (samples, end) = replay_all(&file(&header(Kind::Increments, 3), &records));
    assert_eq!(
        end,
        Ok(ReplayStats {
            samples: 3,
            missed: 2,
            ..ReplayStats::default()
        })
    );
    assert_eq!(samples[1].flags, SampleFlags::GAP);
    assert!(samples[1].flags.usable());
    assert_eq!(samples[1].dt_s, 0.03);
    assert_eq!(samples[1].seq, 1);
    assert_eq!(samples[2].flags, SampleFlags::empty());
}

/// A logger that drops every other record for a while: every increment after a gap covers
/// one period and is a bad interval, the second and later ones too (was: taken as covering
/// their two periods, half the increments lost).
#[test]
fn every_increment_of_one_period_in_a_run_of_gaps_is_a_bad_interval() {
    let records = [
        record(T0_NS + PERIOD_NS),
        record(T0_NS + 3 * PERIOD_NS),
        record(T0_NS + 5 * PERIOD_NS),
        record(T0_NS + 7 * PERIOD_NS),
        record(T0_NS + 8 * PERIOD_NS),
    ];
    let (samples, end) = replay_all(&file(&header(Kind::Increments, 5), &records));
    for s in &samples[1..4] {
        assert_eq!(s.flags, SampleFlags::BAD_INTERVAL, "{s:?}");
    }
    assert_eq!(samples[4].flags, SampleFlags::empty());
    assert_eq!(end.unwrap().bad_interval, 3);
}

/// Records dropped by a logger: the increment after the gap covers one period, not the three
/// of its interval. Integrated over the interval it would lose gravity's balance for two
/// periods; it is refused as a bad interval (the navigation bridges the time), and counted.
/// An increment after the gap with no one-period record before it keeps the definition.
#[test]
fn an_increment_of_one_period_after_a_gap_is_a_bad_interval() {
    let records = [
        record(T0_NS + PERIOD_NS),
        record(T0_NS + 4 * PERIOD_NS),
        record(T0_NS + 5 * PERIOD_NS),
    ];
    let (samples, end) = replay_all(&file(&header(Kind::Increments, 3), &records));
    assert_eq!(samples[1].flags, SampleFlags::BAD_INTERVAL);
    assert_eq!(samples[2].flags, SampleFlags::empty());
    let stats = end.unwrap();
    assert_eq!((stats.missed, stats.bad_interval), (2, 1));
    // Rates are held over the interval by definition: a gap.
    let (samples, _) = replay_all(&file(&header(Kind::Rates, 3), &records));
    assert_eq!(samples[1].flags, SampleFlags::GAP);
    // The first record after the header's start has no record before it.
    let (samples, _) = replay_all(&file(
        &header(Kind::Increments, 1),
        &[record(T0_NS + 3 * PERIOD_NS)],
    ));
    assert_eq!(samples[0].flags, SampleFlags::GAP);
}

#[test]
fn interval_thresholds() {
    // (delta [ns], flags, missed)
    let cases = [
        (PERIOD_NS * 3 / 2, SampleFlags::empty(), 0), // exactly 1.5 periods: jitter, not a gap
        (PERIOD_NS * 3 / 2 + 1, SampleFlags::GAP, 1),
        (PERIOD_NS * 5 / 2, SampleFlags::GAP, 2), // 2.5 periods rounds half away from zero
        (PERIOD_NS * 10, SampleFlags::GAP, 9),
        (PERIOD_NS * 10 + 1, SampleFlags::BAD_INTERVAL, 0),
        (u64::MAX - T0_NS, SampleFlags::BAD_INTERVAL, 0),
    ];
    for (delta_ns, flags, missed) in cases {
        let (samples, end) =
            replay_all(&file(&header(Kind::Rates, 1), &[record(T0_NS + delta_ns)]));
        assert_eq!(samples[0].flags, flags, "delta {delta_ns} ns");
        assert_eq!(samples[0].dt_s, (delta_ns as f64 * 1e-9) as f32);
        assert_eq!(end.unwrap().missed, missed, "delta {delta_ns} ns");
    }
}

// ---- format errors, with exact offsets --------------------------------------------------------

#[test]
fn bad_magic() {
    let mut bytes = file(&header(Kind::Rates, 1), &regular_records(1));
    bytes[3] = b'X';
    assert_eq!(
        replay_error(&bytes),
        error(FormatErrorKind::BadMagic, 0, None)
    );

    // A text-mode transfer that turned CR LF into LF.
    let good = file(&header(Kind::Rates, 1), &regular_records(1));
    let mut mangled = good[..6].to_vec();
    mangled.extend_from_slice(&good[7..]);
    assert_eq!(
        replay_error(&mangled),
        error(FormatErrorKind::BadMagic, 0, None)
    );

    // Too short to be a header, and not a recording either.
    assert_eq!(
        replay_error(b"time,gx\n"),
        error(FormatErrorKind::BadMagic, 0, None)
    );
}

#[test]
fn unsupported_version() {
    let mut bytes = file(&header(Kind::Rates, 0), &[]);
    bytes[8] = 2;
    fix_header_crc(&mut bytes);
    assert_eq!(
        replay_error(&bytes),
        error(FormatErrorKind::UnsupportedVersion(2), 8, None)
    );
    // Reported before the CRC: another version may have another header layout.
    bytes[8] = 7;
    assert_eq!(
        replay_error(&bytes),
        error(FormatErrorKind::UnsupportedVersion(7), 8, None)
    );
}

#[test]
fn header_crc() {
    let mut bytes = file(&header(Kind::Rates, 1), &regular_records(1));
    bytes[30] ^= 0x01; // in t0_ns
    assert_eq!(
        replay_error(&bytes),
        error(FormatErrorKind::HeaderCrc, 0, None)
    );
    let mut bytes = file(&header(Kind::Rates, 1), &regular_records(1));
    bytes[47] ^= 0x80; // in the CRC itself
    assert_eq!(
        replay_error(&bytes),
        error(FormatErrorKind::HeaderCrc, 0, None)
    );
}

#[test]
fn bad_header_fields() {
    let patch = |at: usize, value: &[u8]| {
        let mut bytes = file(&header(Kind::Rates, 0), &[]);
        bytes[at..at + value.len()].copy_from_slice(value);
        fix_header_crc(&mut bytes);
        replay_error(&bytes)
    };
    let bad_header = |offset| {
        move |e: FormatError| {
            assert!(matches!(e.kind, FormatErrorKind::BadHeader(_)), "{e:?}");
            assert_eq!((e.offset, e.record), (offset, None), "{e:?}");
        }
    };
    bad_header(10)(patch(10, &40u16.to_le_bytes()));
    bad_header(12)(patch(12, &48u16.to_le_bytes()));
    bad_header(14)(patch(14, &2u16.to_le_bytes()));
    for rate_hz in [
        0.0,
        -0.0,
        -100.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ] {
        bad_header(16)(patch(16, &f64::to_le_bytes(rate_hz)));
    }
    bad_header(36)(patch(43, &[1]));
    assert_eq!(
        patch(14, &9u16.to_le_bytes()).to_string(),
        "byte offset 14: invalid header: unknown kind (expected 0 = increments or 1 = rates)"
    );
}

#[test]
fn record_crc() {
    let mut bytes = file(&header(Kind::Rates, 40), &regular_records(40));
    bytes[48 + 31 * 40 + 13] ^= 0x04; // a gyro byte of record 31
    let (samples, end) = replay_all(&bytes);
    assert_eq!(samples.len(), 31);
    let error = end.unwrap_err();
    assert_eq!(
        error,
        self::error(FormatErrorKind::RecordCrc, 1288, Some(31))
    );
    assert_eq!(
        error.to_string(),
        "byte offset 1288 (record 31): record CRC mismatch (corrupt data)"
    );
}

#[test]
fn truncated() {
    // Nothing after the header.
    let bytes = file(&header(Kind::Increments, 2400), &[]);
    let error = replay_error(&bytes);
    assert_eq!(
        error,
        FormatError {
            kind: FormatErrorKind::Truncated,
            offset: 48,
            record: Some(0),
            expected_records: Some(2400)
        }
    );
    assert_eq!(
        error.to_string(),
        "byte offset 48 (record 0): file ends inside the recording: expected 2400 records \
         (96048 bytes), found 0 complete records"
    );

    // Inside record 2.
    let bytes = file(&header(Kind::Increments, 3), &regular_records(3));
    let (samples, end) = replay_all(&bytes[..48 + 2 * 40 + 17]);
    assert_eq!(samples.len(), 2);
    assert_eq!(
        end,
        Err(FormatError {
            kind: FormatErrorKind::Truncated,
            offset: 128,
            record: Some(2),
            expected_records: Some(3)
        })
    );

    // Inside the header (and the empty file).
    for len in [0, 5, 8, 47] {
        assert_eq!(
            replay_error(&bytes[..len]),
            error_at_header(FormatErrorKind::Truncated)
        );
    }
    assert_eq!(
        replay_error(&bytes[..20]).to_string(),
        "byte offset 0: file ends inside the header: expected 48 header bytes, found fewer"
    );
}

fn error_at_header(kind: FormatErrorKind) -> FormatError {
    error(kind, 0, None)
}

#[test]
fn trailing_data() {
    let mut bytes = file(&header(Kind::Rates, 3), &regular_records(3));
    bytes.push(0);
    let (samples, end) = replay_all(&bytes);
    assert_eq!(samples.len(), 3);
    let error = end.unwrap_err();
    assert_eq!(
        error,
        FormatError {
            kind: FormatErrorKind::TrailingData,
            offset: 168,
            record: None,
            expected_records: Some(3)
        }
    );
    assert_eq!(
        error.to_string(),
        "byte offset 168: unexpected data after the last record: the header announces 3 \
         records, so the file should end after 168 bytes, but it is longer"
    );
}

#[test]
fn replay_error_display() {
    let error: ReplayError<Infallible> = error_at_header(FormatErrorKind::HeaderCrc).into();
    assert_eq!(
        error.to_string(),
        "invalid recording: byte offset 0: header CRC mismatch (corrupt header)"
    );
}

// ---- byte sources -----------------------------------------------------------------------------

/// Hands out at most `max` bytes per read; once the header is delivered, fails every
/// `fail_every`-th read.
struct Flaky<'a> {
    data: &'a [u8],
    max: usize,
    fail_every: usize,
    reads: usize,
    delivered: usize,
}

#[derive(Debug, PartialEq)]
struct Glitch;

impl fmt::Display for Glitch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("glitch")
    }
}

impl core::error::Error for Glitch {}

impl embedded_io::Error for Glitch {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Interrupted
    }
}

impl embedded_io::ErrorType for Flaky<'_> {
    type Error = Glitch;
}

impl Read for Flaky<'_> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Glitch> {
        self.reads += 1;
        if self.delivered >= HEADER_LEN && self.reads.is_multiple_of(self.fail_every) {
            return Err(Glitch);
        }
        let n = buf.len().min(self.max).min(self.data.len());
        buf[..n].copy_from_slice(&self.data[..n]);
        self.data = &self.data[n..];
        self.delivered += n;
        Ok(n)
    }
}

#[test]
fn short_reads_and_io_errors_resume_in_place() {
    let mut records = regular_records(6);
    records[3].t_ns += 2 * PERIOD_NS;
    let bytes = file(&header(Kind::Rates, 6), &records);
    let (expected, _) = replay_all(&bytes);

    for max in [1, 3, 7, 40, 41, 1000] {
        let flaky = Flaky {
            data: &bytes,
            max,
            fail_every: 4,
            reads: 0,
            delivered: 0,
        };
        let mut replay = Replay::new(flaky).unwrap();
        let mut samples = Vec::new();
        let mut io_errors = 0;
        loop {
            match replay.read_sample() {
                Ok(Some(sample)) => samples.push(sample),
                Ok(None) => break,
                Err(ReplayError::Io(Glitch)) => io_errors += 1,
                Err(ReplayError::Format(e)) => panic!("max {max}: {e}"),
            }
            assert!(io_errors < 10_000, "max {max}: replay does not progress");
        }
        assert!(io_errors > 0, "max {max}");
        assert_eq!(
            samples.iter().map(bits).collect::<Vec<_>>(),
            expected.iter().map(bits).collect::<Vec<_>>(),
            "max {max}"
        );
        assert_eq!(replay.stats().missed, 2);
    }
}

#[test]
fn buffered_replay_matches() {
    let bytes = file(&header(Kind::Increments, 30), &regular_records(30));
    let (expected, _) = replay_all(&bytes);
    let mut replay = Replay::new(crate::io::Buffered::<_, 512>::new(&bytes[..])).unwrap();
    let mut samples = Vec::new();
    while let Some(sample) = replay.read_sample().unwrap() {
        samples.push(sample);
    }
    assert_eq!(samples, expected);
    assert!(replay.into_inner().buffered().is_empty());
}

// ---- properties -------------------------------------------------------------------------------

fn any_record() -> impl Strategy<Value = Record> {
    let float = any::<u32>().prop_map(f32::from_bits);
    (
        any::<u64>(),
        [float.clone(), float.clone(), float.clone()],
        [float.clone(), float.clone(), float.clone()],
        float,
    )
        .prop_map(|(t_ns, gyro, accel, temperature_c)| Record {
            t_ns,
            gyro,
            accel,
            temperature_c,
        })
}

/// A plausible record (near-regular timing, finite values): what a real file holds.
fn plausible_records(n: usize) -> impl Strategy<Value = Vec<Record>> {
    proptest::collection::vec(
        (0..3 * PERIOD_NS, [-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0]),
        n,
    )
    .prop_map(|steps| {
        let mut t_ns = T0_NS;
        steps
            .into_iter()
            .map(|(step, v)| {
                t_ns += step;
                Record {
                    t_ns,
                    gyro: v,
                    accel: v.map(|x| 10.0 * x),
                    temperature_c: 25.0,
                }
            })
            .collect()
    })
}

fn any_rate() -> impl Strategy<Value = f64> {
    prop_oneof![
        1.0f64..10_000.0,
        any::<u64>()
            .prop_map(f64::from_bits)
            .prop_filter("valid rate", |r| rate_is_valid(*r)),
    ]
}

fn any_kind() -> impl Strategy<Value = Kind> {
    prop_oneof![Just(Kind::Increments), Just(Kind::Rates)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = replay_all(&bytes);
        let mut with_magic = MAGIC.to_vec();
        with_magic.extend_from_slice(&bytes);
        let _ = replay_all(&with_magic);
    }

    #[test]
    fn valid_header_random_tail_never_panics(
        kind in any_kind(),
        rate_hz in any_rate(),
        t0_ns in any::<u64>(),
        sample_count in prop_oneof![0u32..8, any::<u32>()],
        tail in proptest::collection::vec(any::<u8>(), 0..400),
    ) {
        let mut bytes = Header { kind, rate_hz, t0_ns, sample_count }.encode().to_vec();
        bytes.extend_from_slice(&tail);
        let _ = replay_all(&bytes);
    }

    /// Arbitrary record contents (any bits) with valid CRCs replay exactly, flagged as needed.
    #[test]
    fn arbitrary_records_replay_exactly(
        kind in any_kind(),
        rate_hz in any_rate(),
        t0_ns in any::<u64>(),
        records in proptest::collection::vec(any_record(), 0..12),
    ) {
        let header = Header { kind, rate_hz, t0_ns, sample_count: records.len() as u32 };
        let (samples, end) = replay_all(&file(&header, &records));
        let stats = end.unwrap();
        prop_assert_eq!(samples.len(), records.len());
        prop_assert_eq!(stats.samples as usize, records.len());
        let mut prev_t_ns = t0_ns;
        for (sample, record) in samples.iter().zip(&records) {
            let (gyro, accel) = match sample.motion {
                Motion::Increments { delta_theta_ib_b, delta_v_ib_b } => (delta_theta_ib_b, delta_v_ib_b),
                Motion::Rates { omega_ib_b, f_ib_b } => (omega_ib_b, f_ib_b),
            };
            prop_assert_eq!(gyro.map(f32::to_bits), record.gyro.map(f32::to_bits));
            prop_assert_eq!(accel.map(f32::to_bits), record.accel.map(f32::to_bits));
            prop_assert_eq!(sample.temperature_c.to_bits(), record.temperature_c.to_bits());
            prop_assert_eq!(sample.t_us, record.t_ns / 1000);
            let finite = record.gyro.iter().chain(&record.accel).all(|v| v.is_finite());
            prop_assert_eq!(sample.flags.contains(SampleFlags::NON_FINITE), !finite);
            if record.t_ns <= prev_t_ns {
                prop_assert!(sample.flags.contains(SampleFlags::BAD_INTERVAL));
                prop_assert_eq!(sample.dt_s, 0.0);
            } else {
                prop_assert!(sample.dt_s >= 0.0);
            }
            prev_t_ns = record.t_ns;
        }
    }

    /// One corrupted byte anywhere: an error, and every sample before it is the original one.
    #[test]
    fn corrupted_byte_is_detected(
        kind in any_kind(),
        records in plausible_records(6),
        position in any::<proptest::sample::Index>(),
        mask in 1u8..=255,
    ) {
        let bytes = file(&header(kind, 6), &records);
        let (original, end) = replay_all(&bytes);
        prop_assert!(end.is_ok());

        let mut corrupted = bytes.clone();
        let at = position.index(corrupted.len());
        corrupted[at] ^= mask;
        let (samples, end) = replay_all(&corrupted);
        let error = end.unwrap_err();
        if at >= HEADER_LEN {
            let index = ((at - HEADER_LEN) / RECORD_LEN) as u32;
            prop_assert_eq!(error, self::error(FormatErrorKind::RecordCrc, record_offset(index), Some(index)));
        } else {
            prop_assert_eq!(error.record, None);
        }
        prop_assert_eq!(
            samples.iter().map(bits).collect::<Vec<_>>(),
            original[..samples.len()].iter().map(bits).collect::<Vec<_>>()
        );
    }

    /// A truncated valid file: `Truncated` at the incomplete record (or header), samples before it
    /// unchanged.
    #[test]
    fn truncation_is_detected(records in plausible_records(5), cut in any::<proptest::sample::Index>()) {
        let bytes = file(&header(Kind::Rates, 5), &records);
        let len = cut.index(bytes.len()); // 0..len-1: always short
        let (samples, end) = replay_all(&bytes[..len]);
        let error = end.unwrap_err();
        prop_assert_eq!(error.kind, FormatErrorKind::Truncated);
        if len < HEADER_LEN {
            prop_assert_eq!(error.offset, 0);
        } else {
            let complete = (len - HEADER_LEN) / RECORD_LEN;
            prop_assert_eq!(samples.len(), complete);
            prop_assert_eq!(error.offset, record_offset(complete as u32));
        }
    }
}
