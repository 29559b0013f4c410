//! Mutated recordings through the real `nav replay`: whatever the damage (bits flipped, bytes
//! inserted or deleted, the file cut, records duplicated or removed, header fields changed with
//! or without their CRC, NaN or huge values, times moved, CSV fields and lines changed), the
//! command never panics or hangs, and either
//! - exits 0 with every record of the file counted: `samples` = the file's records = aligned +
//!   flagged + rejected + navigated, the flags by cause as the format's reading rules give them
//!   (`docs/recording-format.md`, checked here by an independent reading of the bytes), and a
//!   whole, finite log at `--out` with the rows the summary announces; or
//! - exits 1 with a message, nothing left at `--out` (an existing file there untouched) and no
//!   temporary file beside it.
//!
//! A file the independent reading finds invalid (a CRC, length or header field wrong) must fail.
//!
//! Through a simulated IMU and its driver (`--device`), the same holds, and the driver's own
//! counts account for every record (see [`mutated_binary_recordings_through_a_driver`]).
//!
//! The base recordings are `nav sim static --grade fog` (12 s at 400 Hz; 10 s of static
//! alignment). 64 cases per format by default; `PROPTEST_CASES=N` runs `N`.

mod common;

use crc::{CRC_32_ISO_HDLC, Crc};
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::TestRunner;
use std::cell::Cell;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Cases per format when `PROPTEST_CASES` is not set.
const DEFAULT_CASES: u32 = 64;
/// Site of the simulated static scenario (its defaults).
const SITE: [&str; 3] = ["45", "7.5", "150"];
const ALIGN_SECONDS: &str = "10";
const LOG_EVERY: u32 = 40;
/// Longest a replay of the 12 s recording may take before it counts as a hang.
const TIMEOUT: Duration = Duration::from_secs(120);
/// Content of an `--out` file that exists before the run.
const PREVIOUS_LOG: &[u8] = b"previous run: must survive a failed replay\n";

// The binary format as `docs/recording-format.md` gives it, written out again.
const MAGIC: &[u8; 8] = b"NAVIMU\r\n";
const HEADER_LEN: usize = 48;
const RECORD_LEN: usize = 40;
const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES)
}

/// The clean recordings, simulated once by `nav sim`.
struct Base {
    binary: Vec<u8>,
    csv: Vec<u8>,
}

fn base() -> &'static Base {
    static BASE: OnceLock<Base> = OnceLock::new();
    BASE.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_nav"))
            .args(["sim", "static", "--grade", "fog", "--seconds", "12"])
            .args(["--format", "both", "--out"])
            .arg(dir.path())
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        Base {
            binary: std::fs::read(dir.path().join("imu.bin")).unwrap(),
            csv: std::fs::read(dir.path().join("imu.csv")).unwrap(),
        }
    })
}

// ---------------------------------------------------------------------------------------------
// Mutations of binary recordings.

/// A header field of the binary format.
#[derive(Clone, Copy, Debug)]
enum HeaderField {
    Magic(u8),
    Version(u16),
    HeaderLen(u16),
    RecordLen(u16),
    Kind(u16),
    RateHz(f64),
    T0Ns(u64),
    SampleCount(u32),
    /// One reserved byte (index 0..8) set.
    Reserved(usize, u8),
}

/// What happens to a record's time `t_ns`.
#[derive(Clone, Copy, Debug)]
enum TimeChange {
    /// Moved by this many nanoseconds (wrapping).
    Shift(i64),
    /// Replaced.
    Set(u64),
}

#[derive(Clone, Debug)]
enum BinMutation {
    /// One bit of any byte flipped (a CRC must catch it).
    FlipBit(Index, u8),
    /// The file cut at an offset.
    Truncate(Index),
    /// Bytes inserted at an offset.
    Insert(Index, Vec<u8>),
    /// Bytes deleted at an offset.
    Delete(Index, usize),
    /// A record repeated right after itself; with `true`, the header's count (and CRC) follow.
    DuplicateRecord(Index, bool),
    /// A record removed; with `true`, the header's count (and CRC) follow.
    RemoveRecord(Index, bool),
    /// Two records exchanged.
    SwapRecords(Index, Index),
    /// A gyro or accelerometer value (`field` 0..6) or the temperature (6) of a record replaced,
    /// the record's CRC recomputed.
    SetValue(Index, usize, f32),
    /// A record's time changed, its CRC recomputed.
    Time(Index, TimeChange),
    /// A header field overwritten; with `true`, the header CRC recomputed.
    Header(HeaderField, bool),
}

/// Values that stress the readers: non-finite, huge, tiny, anything.
fn odd_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(f32::MAX),
        Just(-1e30),
        Just(1e6),
        Just(0.0),
        Just(f32::from_bits(1)),
        any::<u32>().prop_map(f32::from_bits),
        (-1.0f32..1.0),
    ]
}

fn odd_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(0.0),
        Just(-400.0),
        Just(100.0),
        Just(400.0 * 1.005),
        Just(400.0 * 1.02),
        Just(1e-300),
        Just(1e300),
        any::<u64>().prop_map(f64::from_bits),
        (1.0f64..10_000.0),
    ]
}

fn header_field() -> impl Strategy<Value = HeaderField> {
    prop_oneof![
        any::<u8>().prop_map(HeaderField::Magic),
        prop_oneof![Just(0u16), Just(2), any::<u16>()].prop_map(HeaderField::Version),
        prop_oneof![Just(0u16), Just(40), Just(88), any::<u16>()].prop_map(HeaderField::HeaderLen),
        prop_oneof![Just(0u16), Just(48), Just(80), any::<u16>()].prop_map(HeaderField::RecordLen),
        prop_oneof![Just(0u16), Just(1), Just(2), any::<u16>()].prop_map(HeaderField::Kind),
        odd_f64().prop_map(HeaderField::RateHz),
        prop_oneof![
            Just(0u64),
            Just(2_500_000),
            Just(u64::MAX),
            Just(12_000_000_000),
            any::<u64>()
        ]
        .prop_map(HeaderField::T0Ns),
        prop_oneof![
            Just(0u32),
            Just(4799),
            Just(4801),
            Just(u32::MAX),
            any::<u32>()
        ]
        .prop_map(HeaderField::SampleCount),
        (0usize..8, 1u8..=255).prop_map(|(i, b)| HeaderField::Reserved(i, b)),
    ]
}

fn time_change() -> impl Strategy<Value = TimeChange> {
    prop_oneof![
        // Within a few periods (2.5 ms): gaps, zero and backward intervals.
        (-10_000_000i64..30_000_000).prop_map(TimeChange::Shift),
        Just(TimeChange::Shift(-2_500_000)),
        Just(TimeChange::Shift(1)),
        any::<i64>().prop_map(TimeChange::Shift),
        any::<u64>().prop_map(TimeChange::Set),
        Just(TimeChange::Set(0)),
        Just(TimeChange::Set(u64::MAX)),
    ]
}

fn bin_mutation() -> impl Strategy<Value = BinMutation> {
    prop_oneof![
        2 => (any::<Index>(), 0u8..8).prop_map(|(i, b)| BinMutation::FlipBit(i, b)),
        1 => any::<Index>().prop_map(BinMutation::Truncate),
        1 => (any::<Index>(), proptest::collection::vec(any::<u8>(), 1..80))
            .prop_map(|(i, b)| BinMutation::Insert(i, b)),
        1 => (any::<Index>(), 1usize..120).prop_map(|(i, n)| BinMutation::Delete(i, n)),
        3 => (any::<Index>(), prop::bool::weighted(0.8))
            .prop_map(|(i, f)| BinMutation::DuplicateRecord(i, f)),
        3 => (any::<Index>(), prop::bool::weighted(0.8))
            .prop_map(|(i, f)| BinMutation::RemoveRecord(i, f)),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| BinMutation::SwapRecords(a, b)),
        5 => (any::<Index>(), 0usize..7, odd_f32())
            .prop_map(|(i, f, v)| BinMutation::SetValue(i, f, v)),
        4 => (any::<Index>(), time_change()).prop_map(|(i, t)| BinMutation::Time(i, t)),
        3 => (header_field(), prop::bool::weighted(0.8))
            .prop_map(|(h, f)| BinMutation::Header(h, f)),
    ]
}

/// Complete records after the header in `bytes`.
fn record_count(bytes: &[u8]) -> usize {
    bytes.len().saturating_sub(HEADER_LEN) / RECORD_LEN
}

fn record_at(k: usize) -> usize {
    HEADER_LEN + RECORD_LEN * k
}

fn reseal_record(bytes: &mut [u8], k: usize) {
    let at = record_at(k);
    let crc = CRC32.checksum(&bytes[at..at + RECORD_LEN - 4]);
    bytes[at + RECORD_LEN - 4..at + RECORD_LEN].copy_from_slice(&crc.to_le_bytes());
}

fn reseal_header(bytes: &mut [u8]) {
    if bytes.len() >= HEADER_LEN {
        let crc = CRC32.checksum(&bytes[..44]);
        bytes[44..48].copy_from_slice(&crc.to_le_bytes());
    }
}

/// Adds `delta` to the header's sample count (if the header is there).
fn adjust_count(bytes: &mut [u8], delta: i64) {
    if bytes.len() >= HEADER_LEN {
        let n = u32::from_le_bytes(bytes[32..36].try_into().unwrap());
        let n = (i64::from(n) + delta).clamp(0, i64::from(u32::MAX)) as u32;
        bytes[32..36].copy_from_slice(&n.to_le_bytes());
        reseal_header(bytes);
    }
}

fn apply_bin(bytes: &mut Vec<u8>, m: &BinMutation) {
    let records = record_count(bytes);
    match m {
        BinMutation::FlipBit(i, bit) if !bytes.is_empty() => {
            let at = i.index(bytes.len());
            bytes[at] ^= 1 << bit;
        }
        BinMutation::Truncate(i) => {
            let at = i.index(bytes.len() + 1);
            bytes.truncate(at);
        }
        BinMutation::Insert(i, b) => {
            let at = i.index(bytes.len() + 1);
            bytes.splice(at..at, b.iter().copied());
        }
        BinMutation::Delete(i, n) if !bytes.is_empty() => {
            let at = i.index(bytes.len());
            bytes.drain(at..(at + n).min(bytes.len()));
        }
        BinMutation::DuplicateRecord(i, fix) if records > 0 => {
            let at = record_at(i.index(records));
            let copy = bytes[at..at + RECORD_LEN].to_vec();
            bytes.splice(at + RECORD_LEN..at + RECORD_LEN, copy);
            if *fix {
                adjust_count(bytes, 1);
            }
        }
        BinMutation::RemoveRecord(i, fix) if records > 0 => {
            let at = record_at(i.index(records));
            bytes.drain(at..at + RECORD_LEN);
            if *fix {
                adjust_count(bytes, -1);
            }
        }
        BinMutation::SwapRecords(a, b) if records > 0 => {
            let (a, b) = (a.index(records), b.index(records));
            for j in 0..RECORD_LEN {
                bytes.swap(record_at(a) + j, record_at(b) + j);
            }
        }
        BinMutation::SetValue(i, field, v) if records > 0 => {
            let k = i.index(records);
            let at = record_at(k) + 8 + 4 * field;
            bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
            reseal_record(bytes, k);
        }
        BinMutation::Time(i, change) if records > 0 => {
            let k = i.index(records);
            let at = record_at(k);
            let t = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
            let t = match change {
                TimeChange::Shift(d) => t.wrapping_add_signed(*d),
                TimeChange::Set(t) => *t,
            };
            bytes[at..at + 8].copy_from_slice(&t.to_le_bytes());
            reseal_record(bytes, k);
        }
        BinMutation::Header(field, fix) if bytes.len() >= HEADER_LEN => {
            let mut put = |at: usize, v: &[u8]| bytes[at..at + v.len()].copy_from_slice(v);
            match *field {
                HeaderField::Magic(b) => put(b as usize % 8, &[b]),
                HeaderField::Version(v) => put(8, &v.to_le_bytes()),
                HeaderField::HeaderLen(v) => put(10, &v.to_le_bytes()),
                HeaderField::RecordLen(v) => put(12, &v.to_le_bytes()),
                HeaderField::Kind(v) => put(14, &v.to_le_bytes()),
                HeaderField::RateHz(v) => put(16, &v.to_le_bytes()),
                HeaderField::T0Ns(v) => put(24, &v.to_le_bytes()),
                HeaderField::SampleCount(v) => put(32, &v.to_le_bytes()),
                HeaderField::Reserved(i, b) => put(36 + i, &[b]),
            }
            if *fix {
                reseal_header(bytes);
            }
        }
        _ => {} // nothing to act on in what is left of the file
    }
}

/// What the format's reading rules say about a file, read independently of `hal_adapters`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct BinCounts {
    records: u32,
    non_finite: u32,
    bad_interval: u32,
    /// Of `bad_interval`, the samples whose time is not after the previous record's (the
    /// summary counts them out of time order).
    not_after_previous: u32,
    /// Samples with either flag (a sample can have both).
    flagged: u32,
    missed: u32,
    /// Unflagged samples whose time (in whole microseconds, as the navigator takes it) is not
    /// after the last unflagged one's: the navigation's out-of-order samples when it refuses
    /// no increment (a refused one does not move the navigation's last time).
    out_of_order: u32,
}

fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes(b[at..at + 2].try_into().unwrap())
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

/// The counts a replay of `bytes` must report, or why the file is invalid
/// (`docs/recording-format.md`: header, records, reading rules and data-quality flags).
fn binary_counts(bytes: &[u8]) -> Result<BinCounts, String> {
    if bytes.len() < HEADER_LEN {
        return Err(format!("{} bytes: no complete header", bytes.len()));
    }
    let h = &bytes[..HEADER_LEN];
    let rate_hz = f64::from_le_bytes(h[16..24].try_into().unwrap());
    let count = u32::from_le_bytes(h[32..36].try_into().unwrap());
    let header_ok = h[..8] == *MAGIC
        && u16_at(h, 8) == 1
        && u16_at(h, 10) as usize == HEADER_LEN
        && u16_at(h, 12) as usize == RECORD_LEN
        && u16_at(h, 14) <= 1
        && rate_hz.is_finite()
        && rate_hz > 0.0
        && h[36..44].iter().all(|&b| b == 0)
        && u32::from_le_bytes(h[44..48].try_into().unwrap()) == CRC32.checksum(&h[..44]);
    if !header_ok {
        return Err("invalid header".into());
    }
    if bytes.len() as u64 != HEADER_LEN as u64 + RECORD_LEN as u64 * u64::from(count) {
        return Err(format!("{} bytes for {count} records", bytes.len()));
    }
    let period_ns = 1e9 / rate_hz;
    let mut c = BinCounts {
        records: count,
        ..BinCounts::default()
    };
    let mut prev_t_ns = u64_at(h, 24);
    let increments = u16_at(h, 14) == 0;
    // The accelerometer field of the last record of one period.
    let mut prev_regular_accel: Option<[f64; 3]> = None;
    let mut last_us: Option<u64> = None;
    for (k, r) in bytes[HEADER_LEN..].chunks_exact(RECORD_LEN).enumerate() {
        if u32::from_le_bytes(r[36..40].try_into().unwrap()) != CRC32.checksum(&r[..36]) {
            return Err(format!("record {k}: CRC"));
        }
        // The host's reader refuses a temperature no sensor has, as the CSV reader does.
        let temp_c = f32::from_le_bytes(r[32..36].try_into().unwrap());
        if !(temp_c.is_nan() || (-100.0..=200.0).contains(&temp_c)) {
            return Err(format!("record {k}: temperature {temp_c}"));
        }
        let t_ns = u64_at(r, 0);
        let non_finite = r[8..32]
            .chunks_exact(4)
            .any(|v| !f32::from_le_bytes(v.try_into().unwrap()).is_finite());
        let accel: [f64; 3] = core::array::from_fn(|i| {
            f64::from(f32::from_le_bytes(
                r[20 + 4 * i..24 + 4 * i].try_into().unwrap(),
            ))
        });
        let not_after_previous = t_ns <= prev_t_ns;
        let mut bad_interval = not_after_previous;
        let mut gap = false;
        let mut short = false;
        if t_ns > prev_t_ns {
            let delta_ns = (t_ns - prev_t_ns) as f64;
            if delta_ns > 10.0 * period_ns {
                bad_interval = true;
            } else if delta_ns > 1.5 * period_ns {
                gap = true;
                c.missed += ((delta_ns / period_ns).round() as u32).max(2) - 1;
                // An increment of one period where the interval is longer (docs/
                // recording-format.md): its size against the previous regular record's.
                if increments
                    && !non_finite
                    && let Some(p) = prev_regular_accel
                {
                    let norm2 = |v: &[f64; 3]| v.iter().map(|x| x * x).sum::<f64>();
                    let k = 0.5 * (1.0 + delta_ns / period_ns);
                    short = norm2(&accel) < k * k * norm2(&p);
                    bad_interval = short;
                }
            }
        }
        prev_t_ns = t_ns;
        // The last increment of one period (on time, or short after a gap) stays the
        // reference across a run of gaps.
        if (short || !(bad_interval || gap)) && !non_finite {
            prev_regular_accel = Some(accel);
        }
        c.non_finite += u32::from(non_finite);
        c.bad_interval += u32::from(bad_interval);
        c.not_after_previous += u32::from(not_after_previous);
        c.flagged += u32::from(non_finite || bad_interval);
        if !(non_finite || bad_interval) {
            let t_us = t_ns / 1000;
            if last_us.is_some_and(|l| t_us <= l) {
                c.out_of_order += 1;
            } else {
                last_us = Some(t_us);
            }
        }
    }
    Ok(c)
}

// ---------------------------------------------------------------------------------------------
// Mutations of CSV recordings.

#[derive(Clone, Debug)]
enum CsvMutation {
    /// Field `column` of a line (the header included) replaced.
    SetField(Index, usize, String),
    DeleteLine(Index),
    DuplicateLine(Index),
    SwapLines(Index, Index),
    InsertLine(Index, String),
    /// The text cut at a byte offset (inside a field, at a line end...).
    Truncate(Index),
    FlipBit(Index, u8),
    InsertBytes(Index, Vec<u8>),
    DeleteBytes(Index, usize),
    /// Every line ending written as CR LF.
    CrLf,
}

/// Field texts that stress the reader: non-finite, huge, tiny, signs, not numbers, column names.
fn odd_field() -> impl Strategy<Value = String> {
    let fixed = prop::sample::select(vec![
        "NaN", "nan", "inf", "-inf", "infinity", "1e300", "-1e300", "1e39", "3.4e38", "1e-45", "0",
        "-0", "+1", "", " 1", "abc", "0x10", "1,2", "\"0.5\"", "1e", "t_s", "temp_c", "dv_z_mps",
    ]);
    prop_oneof![
        3 => fixed.prop_map(str::to_owned),
        1 => any::<f64>().prop_map(|v| format!("{v:e}")),
        2 => (-1e-3f64..1e-3).prop_map(|v| v.to_string()),
        1 => (0.0f64..20.0).prop_map(|v| v.to_string()),
    ]
}

fn odd_line() -> impl Strategy<Value = String> {
    prop_oneof![
        Just(String::new()),
        Just("# comment".to_owned()),
        Just("t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps".to_owned()),
        Just("5.0,0,0,0,0,0,-0.0245".to_owned()),
        Just("5.0,0,0,0,0,0,-0.0245,25".to_owned()),
        "[ -~]{0,60}",
    ]
}

fn csv_mutation() -> impl Strategy<Value = CsvMutation> {
    prop_oneof![
        5 => (any::<Index>(), 0usize..8, odd_field())
            .prop_map(|(l, c, t)| CsvMutation::SetField(l, c, t)),
        4 => any::<Index>().prop_map(CsvMutation::DeleteLine),
        3 => any::<Index>().prop_map(CsvMutation::DuplicateLine),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| CsvMutation::SwapLines(a, b)),
        1 => (any::<Index>(), odd_line()).prop_map(|(l, t)| CsvMutation::InsertLine(l, t)),
        1 => any::<Index>().prop_map(CsvMutation::Truncate),
        1 => (any::<Index>(), 0u8..8).prop_map(|(i, b)| CsvMutation::FlipBit(i, b)),
        1 => (any::<Index>(), proptest::collection::vec(any::<u8>(), 1..20))
            .prop_map(|(i, b)| CsvMutation::InsertBytes(i, b)),
        1 => (any::<Index>(), 1usize..60).prop_map(|(i, n)| CsvMutation::DeleteBytes(i, n)),
        1 => Just(CsvMutation::CrLf),
    ]
}

/// `text` as lines without their `\n` (the last one is what follows the final `\n`).
fn lines_of(text: &[u8]) -> Vec<Vec<u8>> {
    text.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect()
}

fn apply_csv(text: &mut Vec<u8>, m: &CsvMutation) {
    let mut lines = lines_of(text);
    // Lines that end in `\n` (all but the last piece).
    let whole = lines.len() - 1;
    match m {
        CsvMutation::SetField(l, column, field) if whole > 0 => {
            let line = &mut lines[l.index(whole)];
            let mut fields: Vec<Vec<u8>> = line.split(|&b| b == b',').map(<[u8]>::to_vec).collect();
            let c = column % fields.len();
            fields[c] = field.as_bytes().to_vec();
            *line = fields.join(&b","[..]);
        }
        CsvMutation::DeleteLine(l) if whole > 0 => {
            lines.remove(l.index(whole));
        }
        CsvMutation::DuplicateLine(l) if whole > 0 => {
            let k = l.index(whole);
            lines.insert(k + 1, lines[k].clone());
        }
        CsvMutation::SwapLines(a, b) if whole > 0 => lines.swap(a.index(whole), b.index(whole)),
        CsvMutation::InsertLine(l, line) => {
            lines.insert(l.index(whole + 1), line.as_bytes().to_vec());
        }
        CsvMutation::Truncate(i) => {
            let at = i.index(text.len() + 1);
            text.truncate(at);
            return;
        }
        CsvMutation::FlipBit(i, bit) if !text.is_empty() => {
            let at = i.index(text.len());
            text[at] ^= 1 << bit;
            return;
        }
        CsvMutation::InsertBytes(i, b) => {
            let at = i.index(text.len() + 1);
            text.splice(at..at, b.iter().copied());
            return;
        }
        CsvMutation::DeleteBytes(i, n) if !text.is_empty() => {
            let at = i.index(text.len());
            text.drain(at..(at + n).min(text.len()));
            return;
        }
        CsvMutation::CrLf => {
            for line in lines.iter_mut().take(whole) {
                if line.last() != Some(&b'\r') {
                    line.push(b'\r');
                }
            }
        }
        _ => return,
    }
    *text = lines.join(&b"\n"[..]);
}

/// What an accepted CSV file must give: its data rows (non-empty records after the header, not
/// comments; the csv crate ends a record at `\n`, `\r` or `\r\n`) and those with a non-finite
/// increment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct CsvCounts {
    records: u32,
    non_finite: u32,
}

fn csv_counts(text: &[u8], header: bool) -> CsvCounts {
    let text = String::from_utf8_lossy(text);
    // A line whose first field, trimmed, starts with `#` is a comment, before the header too.
    let rows = text
        .split(['\n', '\r'])
        .filter(|l| !l.is_empty() && !l.trim_start().starts_with('#'))
        .skip(usize::from(header));
    let mut c = CsvCounts {
        records: 0,
        non_finite: 0,
    };
    for row in rows {
        c.records += 1;
        let non_finite = row
            .split(',')
            .skip(1)
            .take(6)
            .any(|f| f.parse::<f32>().is_ok_and(|v| !v.is_finite()));
        c.non_finite += u32::from(non_finite);
    }
    c
}

// ---------------------------------------------------------------------------------------------
// Running `nav replay` and checking its outcome.

/// Exit code (`None`: killed by a signal), stdout and stderr of a run.
struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

fn nav_replay(imu: &Path, out: &Path, extra: &[&str]) -> Run {
    let mut child = Command::new(env!("CARGO_BIN_EXE_nav"))
        .arg("replay")
        .arg("--imu")
        .arg(imu)
        .arg("--out")
        .arg(out)
        .args(["--lat", SITE[0], "--lon", SITE[1], "--h", SITE[2]])
        .args(if extra.contains(&"--align-seconds") {
            &[][..]
        } else {
            &["--align-seconds", ALIGN_SECONDS]
        })
        .args(["--log-every", &LOG_EVERY.to_string()])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let drain = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut s = Vec::new();
            r.read_to_end(&mut s).unwrap();
            String::from_utf8_lossy(&s).into_owned()
        })
    };
    let stdout = drain(Box::new(child.stdout.take().unwrap()));
    let stderr = drain(Box::new(child.stderr.take().unwrap()));
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > TIMEOUT {
            child.kill().unwrap();
            panic!("nav replay of {} hangs (> {TIMEOUT:?})", imu.display());
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    Run {
        code: status.code(),
        stdout: stdout.join().unwrap(),
        stderr: stderr.join().unwrap(),
    }
}

/// The counts of a successful run's summary.
#[derive(Clone, Copy, Debug, Default)]
struct Summary {
    samples: u32,
    flagged: u32,
    non_finite: u32,
    bad_interval: u32,
    /// Samples the navigation skipped as out of time order (`nav_core::gap`).
    out_of_order: u32,
    rejected: u32,
    missed: u32,
    nav_steps: u32,
    aligned: u32,
    rows: u32,
    /// Samples a simulated part flagged for its own causes (stale, device fault, other).
    device: u32,
}

fn numbers(s: &str) -> Vec<u32> {
    s.split(|c: char| !c.is_ascii_digit())
        .filter(|t| !t.is_empty())
        .map(|t| t.parse().unwrap())
        .collect()
}

/// Parses the lines `samples N: flagged F (non-finite A, bad interval B, time out of order O[,
/// stale K][, device fault K][, other K]), rejected R, missed M; navigation steps S`,
/// `alignment (...) over N samples (...` and `log: PATH (N rows)`.
fn parse_summary(stdout: &str) -> Summary {
    let line = |start: &str| {
        stdout
            .lines()
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no line starting {start:?} in\n{stdout}"))
    };
    let samples = line("samples ");
    // The device's own causes, after the three every summary names.
    let (head, tail) = samples.split_once(", time out of order ").unwrap();
    let (order, rest) = tail.split_once(')').unwrap();
    let order = numbers(order);
    let device: u32 = order[1..].iter().sum();
    let counts = [numbers(head), order[..1].to_vec(), numbers(rest)].concat();
    assert_eq!(counts.len(), 8, "{stdout}");
    let alignment = line("alignment (");
    let aligned = alignment
        .split_once(" over ")
        .and_then(|(_, rest)| rest.split_once(" samples"))
        .and_then(|(n, _)| n.parse().ok())
        .unwrap_or_else(|| panic!("{alignment}"));
    let log = line("log: ");
    let rows = log
        .rsplit_once('(')
        .and_then(|(_, rest)| rest.strip_suffix(" rows)"))
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{log}"));
    Summary {
        samples: counts[0],
        flagged: counts[1],
        non_finite: counts[2],
        bad_interval: counts[3],
        out_of_order: counts[4],
        rejected: counts[5],
        missed: counts[6],
        nav_steps: counts[7],
        aligned,
        rows,
        device,
    }
}

/// Names in `dir`.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A mutated file written and replayed, `--out` pre-created or not.
struct Case {
    _dir: tempfile::TempDir,
    dir: PathBuf,
    imu: PathBuf,
    out: PathBuf,
    previous: bool,
    run: Run,
}

fn replay_case(name: &str, bytes: &[u8], previous: bool, extra: &[&str]) -> Case {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().to_path_buf();
    let imu = dir.join(name);
    let out = dir.join("log.csv");
    std::fs::write(&imu, bytes).unwrap();
    if previous {
        std::fs::write(&out, PREVIOUS_LOG).unwrap();
    }
    let run = nav_replay(&imu, &out, extra);
    Case {
        _dir: tmp,
        dir,
        imu,
        out,
        previous,
        run,
    }
}

/// The outcome rules for both formats; returns the summary of a successful run.
fn check_outcome(case: &Case) -> Result<Option<Summary>, TestCaseError> {
    let Run {
        code,
        stdout,
        stderr,
    } = &case.run;
    let text = || format!("exit {code:?}\nstdout:\n{stdout}\nstderr:\n{stderr}");
    prop_assert!(*code != Some(101), "panic: {}", text());
    prop_assert!(code.is_some(), "killed by a signal: {}", text());
    let names = listing(&case.dir);
    let imu_name = case.imu.file_name().unwrap().to_string_lossy().into_owned();
    match code {
        Some(0) => {
            let s = parse_summary(stdout);
            // Every sample counted once: aligned, flagged, rejected or navigated.
            prop_assert_eq!(
                s.samples,
                s.aligned + s.flagged + s.rejected + s.nav_steps,
                "{}",
                text()
            );
            prop_assert!(s.nav_steps > 0, "{}", text());
            let expected_rows =
                1 + s.nav_steps / LOG_EVERY + u32::from(!s.nav_steps.is_multiple_of(LOG_EVERY));
            prop_assert_eq!(s.rows, expected_rows, "{}", text());
            // The log: whole (header and the rows announced), finite, on the Earth.
            let log = std::fs::read_to_string(&case.out).unwrap();
            let rows = common::parse_log(&log);
            prop_assert_eq!(rows.len() as u32, s.rows, "{}", text());
            for r in &rows {
                let values = [r.t_s, r.lat_deg, r.lon_deg, r.h_m];
                prop_assert!(
                    values
                        .iter()
                        .chain(&r.v_ned)
                        .chain(&r.rpy_deg)
                        .all(|v| v.is_finite()),
                    "{r:?}"
                );
                prop_assert!(r.lat_deg.abs() <= 90.0 && r.lon_deg.abs() <= 180.0, "{r:?}");
            }
            // In time order, whatever the recording's clock did (nav_core::gap).
            prop_assert!(rows.windows(2).all(|w| w[0].t_s < w[1].t_s), "{}", text());
            let mut expected_names = vec![imu_name, "log.csv".to_owned()];
            expected_names.sort();
            prop_assert_eq!(names, expected_names);
            Ok(Some(s))
        }
        Some(1) => {
            prop_assert!(
                stderr.starts_with("error: replay of ") && stderr.trim_end().len() > 40,
                "no message: {}",
                text()
            );
            let mut expected_names = vec![imu_name];
            if case.previous {
                prop_assert_eq!(
                    std::fs::read(&case.out).unwrap(),
                    PREVIOUS_LOG,
                    "{}",
                    text()
                );
                expected_names.push("log.csv".to_owned());
            } else {
                prop_assert!(!case.out.exists(), "a log was left behind: {}", text());
            }
            expected_names.sort();
            prop_assert_eq!(names, expected_names, "{}", text());
            Ok(None)
        }
        _ => Err(TestCaseError::fail(format!("unexpected exit: {}", text()))),
    }
}

/// The clean recordings replay: the property's success branch is reachable and its counts
/// match the reading rules.
#[test]
fn clean_recordings_replay_with_every_sample_counted() {
    let base = base();
    let expected = binary_counts(&base.binary).unwrap();
    assert_eq!(expected.flagged, 0);
    for (name, bytes) in [("imu.bin", &base.binary), ("imu.csv", &base.csv)] {
        let case = replay_case(name, bytes, true, &[]);
        let s = check_outcome(&case)
            .unwrap()
            .expect("the clean file replays");
        assert_eq!((s.samples, s.flagged), (expected.records, 0), "{name}");
    }
}

/// Runs `test` on `cases()` inputs of `strategy` (panicking with the shrunk failure) and
/// prints the count, how many replayed and the wall time.
fn run_cases<S: Strategy>(
    name: &str,
    strategy: S,
    test: impl Fn(S::Value) -> Result<bool, TestCaseError>,
) where
    S::Value: std::fmt::Debug,
{
    let cases = cases();
    let mut runner = TestRunner::new(ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    let replayed = Cell::new(0u32);
    let started = Instant::now();
    let result = runner.run(&strategy, |input| {
        let ok = test(input)?;
        replayed.set(replayed.get() + u32::from(ok));
        Ok(())
    });
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    eprintln!(
        "fuzz {name}: {cases} cases, no failure ({} replayed, the others refused), {:.1} s",
        replayed.get(),
        started.elapsed().as_secs_f64()
    );
}

#[test]
fn mutated_binary_recordings() {
    let inputs = (
        proptest::collection::vec(bin_mutation(), 1..=3),
        any::<bool>(),
    );
    run_cases(
        "mutated binary recordings",
        inputs,
        |(mutations, previous)| {
            let mut bytes = base().binary.clone();
            for m in &mutations {
                apply_bin(&mut bytes, m);
            }
            let expected = binary_counts(&bytes);
            let case = replay_case("imu.bin", &bytes, previous, &[]);
            let summary = check_outcome(&case)?;
            match (summary, expected) {
                (Some(s), Ok(c)) => {
                    let bad_interval = c.bad_interval - c.not_after_previous;
                    prop_assert_eq!(
                        (s.samples, s.non_finite, s.bad_interval, s.missed),
                        (c.records, c.non_finite, bad_interval, c.missed),
                        "{}",
                        case.run.stdout
                    );
                    // Flagged: by the source, or out of time order by the navigation; the
                    // summary's out of order has the source's times not after the previous.
                    let by_navigation = s.out_of_order - c.not_after_previous;
                    prop_assert_eq!(s.flagged, c.flagged + by_navigation, "{}", case.run.stdout);
                    if s.rejected == 0 {
                        prop_assert_eq!(by_navigation, c.out_of_order, "{}", case.run.stdout);
                    }
                }
                (Some(_), Err(why)) => {
                    prop_assert!(
                        false,
                        "an invalid file ({why}) replayed: {}",
                        case.run.stdout
                    );
                }
                (None, _) => {}
            }
            Ok(summary.is_some())
        },
    );
}

#[test]
fn mutated_csv_recordings() {
    let inputs = (
        proptest::collection::vec(csv_mutation(), 1..=3),
        any::<bool>(),
    );
    run_cases("mutated CSV recordings", inputs, |(mutations, previous)| {
        let mut text = base().csv.clone();
        for m in &mutations {
            apply_csv(&mut text, m);
        }
        let case = replay_case("imu.csv", &text, previous, &[]);
        let summary = check_outcome(&case)?;
        if let Some(s) = summary {
            // Without its header line (deleted), the file starts with a row of numbers and is
            // read as KF-GINS's IMU text, every line a record.
            let kf_gins = case.run.stdout.contains("(KF-GINS,");
            let c = csv_counts(&text, !kf_gins);
            prop_assert_eq!(s.samples, c.records, "{}", case.run.stdout);
            prop_assert_eq!(s.non_finite, c.non_finite, "{}", case.run.stdout);
            // Flagged by cause, one cause each: the causes add up.
            let causes = s.non_finite + s.bad_interval + s.out_of_order + s.device;
            prop_assert_eq!(s.flagged, causes, "{}", case.run.stdout);
        }
        Ok(summary.is_some())
    });
}

/// The CSV recording with its header line deleted starts with a row of numbers: it is read
/// as KF-GINS's IMU text, every line a record (the fuzz test above found its own model
/// skipping that first row as a header).
#[test]
fn a_csv_recording_without_its_header_replays_every_row() {
    let csv = &base().csv;
    let header_end = csv.iter().position(|&b| b == b'\n').unwrap() + 1;
    let text = csv[header_end..].to_vec();
    let case = replay_case("imu.csv", &text, false, &[]);
    let s = check_outcome(&case).unwrap().expect("replayed");
    assert!(case.run.stdout.contains("(KF-GINS,"), "{}", case.run.stdout);
    assert_eq!(s.samples, csv_counts(&text, false).records);
    assert_eq!(s.samples + 1, csv_counts(&base().csv, false).records);
}

/// The driver's counts of a run's `IMU driver: samples N, checksum errors N, stale N, device
/// missed N, bus errors N, faults N, FIFO overflows N, invalid N, gyro clips [x, y, z], accel
/// clips [x, y, z]` line (the firmware's, field for field).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct DriverCounts {
    samples: u32,
    checksum_errors: u32,
    stale: u32,
    missed: u32,
    bus_errors: u32,
    faults: u32,
    fifo_overflows: u32,
    invalid: u32,
}

fn parse_driver(stdout: &str) -> DriverCounts {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("IMU driver: samples "))
        .unwrap_or_else(|| panic!("no 'IMU driver:' line in\n{stdout}"));
    let n = numbers(line);
    assert_eq!(n.len(), 8 + 6, "{line}");
    DriverCounts {
        samples: n[0],
        checksum_errors: n[1],
        stale: n[2],
        missed: n[3],
        bus_errors: n[4],
        faults: n[5],
        fifo_overflows: n[6],
        invalid: n[7],
    }
}

/// The accounting of a driver's counts `d` over the whole of a valid file of counts `c`
/// (see [`mutated_binary_recordings_through_a_driver`]).
fn check_driver(
    device: &str,
    d: DriverCounts,
    c: &BinCounts,
    out: &str,
) -> Result<(), TestCaseError> {
    prop_assert_eq!(
        d.samples + d.checksum_errors,
        c.records,
        "{}: {}",
        device,
        out
    );
    let (checksum_errors, invalid) = match device {
        "adis16505" => (c.non_finite, 0),
        "icm42688" => (0, c.non_finite),
        _ => (0, 0),
    };
    prop_assert_eq!(
        (d.checksum_errors, d.invalid),
        (checksum_errors, invalid),
        "{}: {}",
        device,
        out
    );
    prop_assert_eq!(
        (d.bus_errors, d.faults, d.fifo_overflows),
        (0, 0, 0),
        "{}: {}",
        device,
        out
    );
    Ok(())
}

/// The same binary mutations through a simulated IMU and its driver (`--device`, the
/// firmware's sample path): no panic, whole or absent output, and the accounting exact, by the
/// simulated devices' rules (`hal_adapters::sim`):
/// - each record of the file is one data read of the device (an ADIS16505 burst, an
///   ICM-42688-P FIFO read of five packets, a BMI088 gyro data read), which the driver either
///   delivers or rejects as a corrupt frame: driver `samples + checksum errors` = the file's
///   records;
/// - a rejected frame stands for a non-finite record (no register holds a NaN), and the sample
///   stream delivers that record flagged non-finite, so the summary's `samples` = the file's
///   records; its non-finite, bad-interval and missed counts are the recording's own (the
///   reading rules, as without a device), and `samples` = aligned + flagged + rejected +
///   navigated ([`check_outcome`]);
/// - by device, a non-finite record is: ADIS16505, a frame with a wrong checksum (`checksum
///   errors` = non-finite records, `invalid` 0); ICM-42688-P, the invalid-data marker
///   (`invalid` = non-finite records, `checksum errors` 0); BMI088, held data (stale; `checksum
///   errors` and `invalid` 0);
/// - no bus errors (the end of the recording is not one), device faults or FIFO overflows.
///
/// The BMI088's gyro (1/16.4 deg/s per count) does not see the Earth rate, so its static
/// alignment fails on the still base: its runs get a window longer than the file (13 s of 12),
/// fail with "recording ended during alignment" after the driver read every record, and the
/// driver's counts of that failed run (printed as the firmware prints them) are checked.
#[test]
fn mutated_binary_recordings_through_a_driver() {
    let inputs = (
        proptest::collection::vec(bin_mutation(), 1..=3),
        any::<bool>(),
        prop::sample::select(vec!["adis16505", "icm42688", "bmi088"]),
    );
    run_cases(
        "mutated binary recordings through a driver",
        inputs,
        |(mutations, previous, device)| {
            let mut bytes = base().binary.clone();
            for m in &mutations {
                apply_bin(&mut bytes, m);
            }
            let expected = binary_counts(&bytes);
            let mut extra = vec!["--device", device];
            if device == "bmi088" {
                extra.extend_from_slice(&["--align-seconds", "13"]);
            }
            let case = replay_case("imu.bin", &bytes, previous, &extra);
            let summary = check_outcome(&case)?;
            let out = &case.run.stdout;
            match (summary, &expected) {
                (Some(s), Ok(c)) => {
                    // The flagged causes are the samples' as the part delivered them (a
                    // repeated time shows as stale, a long interval as a gap, as the
                    // firmware's): they add up (was: the recording's, which did not).
                    prop_assert_eq!((s.samples, s.missed), (c.records, c.missed), "{}", out);
                    let causes = s.non_finite + s.bad_interval + s.out_of_order + s.device;
                    prop_assert_eq!(s.flagged, causes, "{}", out);
                    check_driver(device, parse_driver(out), c, out)?;
                }
                (Some(_), Err(why)) => {
                    prop_assert!(false, "an invalid file ({why}) replayed: {}", out);
                }
                (None, Ok(c)) if case.run.stderr.contains("recording ended during alignment") => {
                    check_driver(device, parse_driver(out), c, out)?;
                }
                (None, _) => {}
            }
            Ok(summary.is_some())
        },
    );
}
