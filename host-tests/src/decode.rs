//! `nav decode STREAM --out solution.csv`: the board's binary output stream
//! ([`hal_adapters::protocol`]) back to the solution CSV, with the header and row formatting
//! of the harness's and the firmware's logs (nav-core's [`Row`] `Display`, the same code).
//!
//! The log ends with its end record only when the stream's end-of-run frame came and its row
//! count equals the rows decoded: a stream cut short, or one that lost solution frames, gives
//! a log without it (incomplete, as the project's logs say). A stream without a solution row
//! to write is refused, with its counts. The CSV is written atomically ([`crate::atomic`]):
//! nothing is left at the output path when the decoding fails. What the decoder skipped and
//! refused, and the frames by type, are reported ([`DecodeSummary`]'s `Display`); frames of
//! another protocol version are counted by version and named. A stream with no valid frame is
//! refused with what it was, when that can be told: frames of another protocol version, or an
//! IMU recording (`docs/recording-format.md`'s magic).

use crate::atomic::AtomicFile;
use anyhow::{Context, Result, bail};
use hal_adapters::protocol::messages::EndOfRun;
use hal_adapters::protocol::status::NavStatus;
use hal_adapters::protocol::{DecodeStats, Decoder, Message, MessageId, Refusal, VERSION};
use hal_adapters::recording::MAGIC;
use nav_core::number::Number;
use nav_core::output::{AIDED_CSV_HEADER, CSV_HEADER, EndRecord, Row};
use std::fmt;
use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// `nav decode`'s arguments.
#[derive(clap::Args, Debug)]
pub struct DecodeArgs {
    /// The binary stream (frames of `docs/protocol.md`).
    pub stream: PathBuf,
    /// The solution CSV to write.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

/// What a decoded stream held.
#[derive(Clone, Debug, Default)]
pub struct DecodeSummary {
    /// The decoder's counters.
    pub stats: DecodeStats,
    /// Solution rows written.
    pub rows: u32,
    /// The end-of-run frame, if one came after the last solution frame.
    pub end: Option<EndOfRun>,
    /// An end-of-run frame that solution frames followed (the first such), and how many
    /// solution frames came after it: the log is incomplete.
    pub early_end: Option<(EndOfRun, u32)>,
    /// Bytes of a last frame cut off by the end of the stream.
    pub cut_off_bytes: usize,
    /// The first refusals (up to [`MAX_LISTED`]), with the byte offset after the frame.
    pub refusals: Vec<(u64, Refusal)>,
    /// Solution frames refused for their content ([`implausible`]): not written, so the log
    /// is incomplete.
    pub implausible: u32,
    /// The first of them (up to [`MAX_LISTED`]), with the byte offset after the frame.
    pub refused_rows: Vec<(u64, String)>,
    /// Solution frames written, by status flag set in them (name, count; in the order
    /// first seen): the CSV has no column for them, and a run on the board's compiled-in
    /// configuration (`DEFAULT_CONFIG`), or one that lost its IMU data (`IMU_LOST`), looked like
    /// any other.
    pub flags: Vec<(&'static str, u32)>,
    /// Solution frames written, by the board's status in them (name, count; in the order
    /// first seen).
    pub statuses: Vec<(&'static str, u32)>,
    /// Rows whose frame says DEGRADED or FAULT where the CSV does not (a free-inertial row has
    /// no status column; an aided row's holds the filter's status): a FAULT board's rows
    /// decoded as a clean log.
    pub unsaid: u32,
    /// Frames refused for their protocol version (version, count; in the order first seen):
    /// a capture of a board running another version, refused whole, never misread.
    pub other_versions: Vec<(u8, u32)>,
    /// Line feeds (0x0A) in the stream, and those right after a carriage return (0x0D): in
    /// binary frames a line feed follows a carriage return by chance, 1 in 256; every one of
    /// them after one is a text-mode transfer's rewriting (LF -> CR LF).
    pub line_feeds: (u64, u64),
}

/// Adds one to `name`'s count in `counts` (appended at 1 when first seen).
fn count(counts: &mut Vec<(&'static str, u32)>, name: &'static str) {
    match counts.iter_mut().find(|(n, _)| *n == name) {
        Some((_, n)) => *n += 1,
        None => counts.push((name, 1)),
    }
}

/// `NAME n, NAME n, ...` of `counts`.
fn counts_text(counts: &[(&'static str, u32)]) -> String {
    let items: Vec<String> = counts
        .iter()
        .map(|(name, n)| format!("{name} {n}"))
        .collect();
    items.join(", ")
}

/// Line feeds from which a stream whose every line feed follows a carriage return is said to
/// have passed a text-mode transfer (by chance: 256^-8).
const CRLF_EVIDENCE: u64 = 8;

impl DecodeSummary {
    /// A hint when frames were refused and every line feed follows a carriage return.
    fn text_mode_hint(&self) -> Option<&'static str> {
        let (lf, crlf) = self.line_feeds;
        let refused = self.stats.other_refusals + self.stats.crc_failures > 0;
        (refused && lf >= CRLF_EVIDENCE && crlf == lf).then_some(
            "every line feed of the stream follows a carriage return: a text-mode transfer \
             (LF -> CR LF) rewrote it; copy the stream in binary mode",
        )
    }
}

/// Why a solution row that passed its frame's checks is not a navigator's: time not after the
/// previous row's, latitude or longitude out of range, a value that is not finite, an angle
/// beyond its range, a negative 1-sigma. Height and speed have no limit here: a free vertical
/// channel diverges (its time constant is about 10 minutes), and after hours of free-inertial
/// navigation the board reports heights and vertical speeds far beyond any site's; the decoder
/// gives them as the harness's replay writes them.
pub fn implausible(row: &Row, previous_t_us: Option<u64>) -> Option<String> {
    let s = row.solution();
    if let Some(p) = previous_t_us
        && s.t_us <= p
    {
        return Some(format!(
            "time {} us not after the previous row's {p} us",
            s.t_us
        ));
    }
    if s.lat_ndeg.unsigned_abs() > 90_000_000_000 || s.lon_ndeg.unsigned_abs() > 180_000_000_000 {
        return Some(format!(
            "latitude {} / longitude {} ndeg out of range",
            s.lat_ndeg, s.lon_ndeg
        ));
    }
    let values = [s.h_m, s.roll_deg, s.pitch_deg, s.yaw_deg];
    if !values.iter().chain(&s.v_eb_n).all(|x| x.is_finite()) {
        return Some("height, velocity or attitude not finite".into());
    }
    // Yaw is in (-180, 180] (docs/protocol.md); -180 is let through, as atan2 of a -0 gives it.
    for (name, angle_deg, limit_deg) in [
        ("roll", s.roll_deg, 180.0),
        ("pitch", s.pitch_deg, 90.0),
        ("yaw", s.yaw_deg, 180.0),
    ] {
        if angle_deg.abs() > limit_deg {
            return Some(format!(
                "{name} {} deg not within [-{limit_deg}, {limit_deg}]",
                Number(angle_deg)
            ));
        }
    }
    if let Row::Aided(_, c) = row {
        let sigmas = c
            .sigma_ned_m
            .iter()
            .chain(&c.sigma_v_ned_m_s)
            .chain(&c.sigma_att_deg);
        if !sigmas.clone().all(|x| x.is_finite() && *x >= 0.0) {
            return Some("a 1-sigma negative or not finite".into());
        }
    }
    None
}

/// Refusals listed in a summary.
pub const MAX_LISTED: usize = 10;

impl DecodeSummary {
    /// The log is complete: an end-of-run frame after the last solution frame whose row count
    /// is the rows decoded, no end-of-run frame before it, and no solution frame refused for
    /// its content.
    pub fn complete(&self) -> bool {
        self.implausible == 0
            && self.early_end.is_none()
            && self.end.is_some_and(|e| e.rows == self.rows)
    }
}

impl fmt::Display for DecodeSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.stats;
        writeln!(
            f,
            "{} bytes: {} frames, {} skipped bytes, {} CRC failures, {} other refusals, {} frames lost (sequence gaps), {} frames out of order (sequence number repeated or going back)",
            s.bytes,
            s.frames_total(),
            s.skipped_bytes,
            s.crc_failures,
            s.other_refusals,
            s.frames_lost,
            s.frames_out_of_order
        )?;
        let by_type: Vec<String> = MessageId::ALL
            .iter()
            .map(|m| format!("{} {}", m.name(), s.frames[m.index()]))
            .collect();
        writeln!(f, "frames by type: {}", by_type.join(", "))?;
        for (offset, r) in &self.refusals {
            writeln!(f, "refused frame ending at byte {offset}: {r}")?;
        }
        if let Some(hint) = self.text_mode_hint() {
            writeln!(f, "{hint}")?;
        }
        if !self.other_versions.is_empty() {
            writeln!(
                f,
                "{}; this decoder reads version {VERSION}",
                versions_text(&self.other_versions)
            )?;
        }
        if self.implausible > 0 {
            writeln!(
                f,
                "{} solution frames refused for their content (not written)",
                self.implausible
            )?;
        }
        for (offset, why) in &self.refused_rows {
            writeln!(f, "refused solution frame ending at byte {offset}: {why}")?;
        }
        if self.cut_off_bytes > 0 {
            writeln!(f, "last frame cut off: {} bytes", self.cut_off_bytes)?;
        }
        if !self.flags.is_empty() {
            writeln!(
                f,
                "status flags of the solution rows (frames with each): {}",
                counts_text(&self.flags)
            )?;
        }
        if self.statuses.iter().any(|(name, _)| *name != "NAV") {
            writeln!(
                f,
                "board status of the solution rows (frames with each): {}",
                counts_text(&self.statuses)
            )?;
        }
        if self.unsaid > 0 {
            writeln!(
                f,
                "WARNING: {} of {} rows' frames say DEGRADED or FAULT (the board's own judgement: \
                 aiding lost, a sensor or alignment failure) where the CSV does not (its status \
                 column is the filter's; a free-inertial row has none): do not take those rows \
                 as good",
                self.unsaid, self.rows
            )?;
        }
        if let Some((_, n)) = self
            .flags
            .iter()
            .find(|(name, _)| *name == "DEFAULT_CONFIG")
        {
            writeln!(
                f,
                "WARNING: {n} of {} rows from the board's compiled-in configuration \
                 (DEFAULT_CONFIG: no configuration frame accepted in its standby window): not \
                 the host's site, alignment or mounting",
                self.rows
            )?;
        }
        match (self.end, self.early_end) {
            (_, Some((e, after))) => write!(
                f,
                "{} rows, but the end-of-run frame (saying {} rows) came before the end of the \
                 stream, {after} solution frames follow it: incomplete (no end record written)",
                self.rows, e.rows
            ),
            (Some(e), None) if self.complete() => {
                write!(
                    f,
                    "{} rows, end of run: complete ({} rows)",
                    self.rows, e.rows
                )
            }
            // Every row the board counted, but frames refused besides them: the board sent
            // more solution frames than rows (one repeated, or one it never logged).
            (Some(e), None) if e.rows == self.rows => write!(
                f,
                "{} rows, as the end-of-run frame says, but {} more solution frames refused for \
                 their content: incomplete (no end record written)",
                self.rows, self.implausible
            ),
            (Some(e), None) => write!(
                f,
                "{} rows, but the end-of-run frame says {}: incomplete (no end record written)",
                self.rows, e.rows
            ),
            (None, None) => write!(
                f,
                "{} rows, no end-of-run frame: incomplete (no end record written)",
                self.rows
            ),
        }
    }
}

/// "N frames of protocol version V" for each version of `versions` (version, count).
fn versions_text(versions: &[(u8, u32)]) -> String {
    let parts: Vec<String> = versions
        .iter()
        .map(|(v, n)| format!("{n} frames of protocol version {v}"))
        .collect();
    parts.join(", ")
}

/// Leading bytes of a stream kept to tell what a stream without a valid frame is.
const HEAD_LEN: usize = 8;

/// The magic's letters, without its line end (which a text-mode copy may have changed).
const RECORDING_MAGIC: &[u8] = MAGIC.split_at(6).0;

/// Decodes the stream file `stream` into the solution CSV `out` (module docs).
pub fn decode_file(stream: &Path, out: &Path) -> Result<DecodeSummary> {
    crate::atomic::refuse_same_file(&[stream], out)
        .with_context(|| format!("output {}", out.display()))?;
    let mut input =
        File::open(stream).with_context(|| format!("cannot open {}", stream.display()))?;
    let mut file =
        AtomicFile::create(out).with_context(|| format!("cannot create {}", out.display()))?;
    let summary = decode(&mut input, file.writer())
        .with_context(|| format!("stream {}", stream.display()))?;
    file.commit()
        .with_context(|| format!("cannot write {}", out.display()))?;
    Ok(summary)
}

/// Decodes `input` and writes the solution CSV to `out` (module docs). Refuses a stream with
/// no frame at all, one with no solution row (none sent, or every one refused), and one that
/// mixes free-inertial and aided rows.
pub fn decode(input: &mut impl Read, out: &mut impl Write) -> Result<DecodeSummary> {
    let mut decoder = Decoder::new();
    let mut summary = DecodeSummary::default();
    let mut aided: Option<bool> = None;
    let mut buf = vec![0u8; 1 << 16];
    let mut failure: Option<anyhow::Error> = None;
    let mut last_t_us: Option<u64> = None;
    let mut head: Vec<u8> = Vec::with_capacity(HEAD_LEN);
    let mut previous = 0_u8;
    loop {
        let n = match input.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e).context("read error"),
        };
        let keep = n.min(HEAD_LEN - head.len());
        head.extend_from_slice(&buf[..keep]);
        for &b in &buf[..n] {
            if b == b'\n' {
                summary.line_feeds.0 += 1;
                summary.line_feeds.1 += u64::from(previous == b'\r');
            }
            previous = b;
            let Some(result) = decoder.feed(b) else {
                continue;
            };
            let received = match result {
                Ok(r) => r,
                Err(e) => {
                    if let Refusal::Version(v) = e {
                        match summary.other_versions.iter_mut().find(|(w, _)| *w == v) {
                            Some((_, count)) => *count += 1,
                            None => summary.other_versions.push((v, 1)),
                        }
                    }
                    if summary.refusals.len() < MAX_LISTED {
                        summary.refusals.push((decoder.stats().bytes, e));
                    }
                    continue;
                }
            };
            match received.message {
                Message::NavSolution(s) => {
                    // Solution frames after an end of run, written or refused (a second run's
                    // rows go back in time): the log is not complete.
                    if let Some(e) = summary.end.take() {
                        summary.early_end.get_or_insert((e, 0));
                    }
                    if let Some((_, after)) = &mut summary.early_end {
                        *after += 1;
                    }
                    // A frame whose CRC holds but whose content no navigator writes.
                    let contradiction = s.status.solution_contradiction(s.flags).map(|why| {
                        format!(
                            "board status {} with flags {:?}: {why} (no board writes it)",
                            s.status.name(),
                            s.flags
                        )
                    });
                    if let Some(why) = implausible(&s.row, last_t_us).or(contradiction) {
                        summary.implausible += 1;
                        if summary.refused_rows.len() < MAX_LISTED {
                            summary.refused_rows.push((decoder.stats().bytes, why));
                        }
                        continue;
                    }
                    last_t_us = Some(s.row.solution().t_us);
                    let is_aided = matches!(s.row, Row::Aided(..));
                    match aided {
                        None => {
                            let header = if is_aided {
                                AIDED_CSV_HEADER
                            } else {
                                CSV_HEADER
                            };
                            writeln!(out, "{header}")?;
                            aided = Some(is_aided);
                        }
                        Some(a) if a != is_aided => {
                            failure.get_or_insert_with(|| {
                                anyhow::anyhow!(
                                    "free-inertial and aided solution rows in one stream (row {})",
                                    summary.rows + 1
                                )
                            });
                            continue;
                        }
                        Some(_) => {}
                    }
                    writeln!(out, "{}", s.row)?;
                    summary.rows += 1;
                    let status = s.status.name();
                    count(&mut summary.statuses, status);
                    let said = match &s.row {
                        Row::Aided(_, columns) => columns.status == status,
                        Row::Free(_) => false,
                    };
                    if matches!(s.status, NavStatus::Degraded | NavStatus::Fault) && !said {
                        summary.unsaid += 1;
                    }
                    for (name, _) in s.flags.iter_names() {
                        count(&mut summary.flags, name);
                    }
                }
                Message::EndOfRun(e) => summary.end = Some(e),
                _ => {}
            }
        }
        if let Some(e) = failure.take() {
            return Err(e);
        }
    }
    summary.cut_off_bytes = decoder.finish();
    summary.stats = *decoder.stats();
    if summary.stats.frames_total() == 0 {
        if summary.stats.bytes == 0 {
            bail!("the stream is empty (0 bytes)");
        }
        if head.starts_with(RECORDING_MAGIC) {
            bail!(
                "an IMU recording (it starts with the NAVIMU magic of docs/recording-format.md), \
                 not the board's output stream: `nav replay --imu` reads recordings"
            );
        }
        if !summary.other_versions.is_empty() {
            bail!(
                "no frame of protocol version {VERSION} in {} bytes: {}; this decoder reads \
                 version {VERSION} (a frame of another version is refused whole, never read \
                 with this version's layout)",
                summary.stats.bytes,
                versions_text(&summary.other_versions)
            );
        }
        if let Some(hint) = summary.text_mode_hint() {
            bail!("no valid frame in {} bytes: {hint}", summary.stats.bytes);
        }
        bail!(
            "no valid frame in {} bytes ({} CRC failures): not a protocol stream?",
            summary.stats.bytes,
            summary.stats.crc_failures
        );
    }
    // A header-only CSV would read as a run that logged nothing.
    if summary.rows == 0 {
        bail!(
            "no solution frame decoded ({} solution frames in the stream, {} refused for their \
             content): nothing written\n{summary}",
            summary.stats.frames[MessageId::NavSolution.index()],
            summary.implausible
        );
    }
    if summary.complete() {
        writeln!(out, "{}", EndRecord { rows: summary.rows })?;
    }
    out.flush()?;
    Ok(summary)
}

/// `nav decode`: decodes, prints the summary to stderr and where the CSV went to stdout.
pub fn run(args: &DecodeArgs) -> Result<()> {
    let summary = decode_file(&args.stream, &args.out)?;
    eprintln!("{summary}");
    println!(
        "decoded {} to {} ({} rows{})",
        args.stream.display(),
        args.out.display(),
        summary.rows,
        if summary.complete() {
            ""
        } else {
            ", incomplete"
        }
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use hal_adapters::protocol::Encoder;
    use hal_adapters::protocol::messages::NavSolution;
    use hal_adapters::protocol::status::StatusFlags;
    use nav_core::output::{FilterColumns, Solution};

    fn frames(messages: &[Message]) -> Vec<u8> {
        let mut enc = Encoder::new();
        let mut out = Vec::new();
        for m in messages {
            enc.append(m, &mut out).unwrap();
        }
        out
    }

    fn solution(row: Row) -> Message {
        Message::NavSolution(NavSolution {
            row,
            status: NavStatus::Nav,
            flags: StatusFlags::empty(),
        })
    }

    const S: Solution = Solution {
        t_us: 1_000_000,
        lat_ndeg: 45_000_000_000,
        lon_ndeg: 7_500_000_000,
        h_m: 150.0,
        v_eb_n: [0.0; 3],
        roll_deg: 0.0,
        pitch_deg: 0.0,
        yaw_deg: 30.0,
    };

    #[test]
    fn mixed_rows_are_refused() {
        let later = Solution {
            t_us: S.t_us + 2500,
            ..S
        };
        let aided = Row::Aided(
            later,
            FilterColumns {
                sigma_ned_m: [1.0; 3],
                sigma_v_ned_m_s: [0.1; 3],
                sigma_att_deg: [0.5; 3],
                status: "NAV",
            },
        );
        let bytes = frames(&[solution(Row::Free(S)), solution(aided)]);
        let e = decode(&mut bytes.as_slice(), &mut Vec::new()).unwrap_err();
        assert!(e.to_string().contains("free-inertial and aided"), "{e}");
    }

    /// A stream with only an end-of-run frame (or a configuration frame), or whose every
    /// solution frame was refused, gave a header-only CSV and status 0: refused now, with the
    /// counts, and no file left at the output path.
    #[test]
    fn a_stream_without_a_solution_row_is_refused_and_writes_nothing() {
        let end = Message::EndOfRun(EndOfRun { rows: 0 });
        let nan = solution(Row::Free(Solution { h_m: f64::NAN, ..S }));
        for (messages, expected) in [
            (vec![end], "(0 solution frames in the stream, 0 refused"),
            (
                vec![nan, nan, end],
                "(2 solution frames in the stream, 2 refused",
            ),
        ] {
            let e = decode(&mut frames(&messages).as_slice(), &mut Vec::new()).unwrap_err();
            let msg = format!("{e:#}");
            assert!(msg.contains("no solution frame decoded"), "{msg}");
            assert!(msg.contains(expected), "{msg}");
            assert!(msg.contains("frames by type"), "{msg}");

            let dir = tempfile::tempdir().unwrap();
            let stream = dir.path().join("run.bin");
            std::fs::write(&stream, frames(&messages)).unwrap();
            let out = dir.path().join("run.csv");
            assert!(decode_file(&stream, &out).is_err());
            assert!(!out.exists());
            assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        }
    }

    /// The status flags of the written rows are counted and named (the CSV has no column for
    /// them): a run on the board's compiled-in configuration is warned of.
    #[test]
    fn the_rows_status_flags_are_counted_and_a_default_configuration_warned_of() {
        let at = |k: u64, flags: StatusFlags| {
            Message::NavSolution(NavSolution {
                row: Row::Free(Solution {
                    t_us: S.t_us + k * 2500,
                    ..S
                }),
                status: NavStatus::Nav,
                flags,
            })
        };
        let messages = [
            at(0, StatusFlags::DEFAULT_CONFIG | StatusFlags::FREE_INERTIAL),
            at(1, StatusFlags::DEFAULT_CONFIG),
            at(2, StatusFlags::empty()),
            Message::EndOfRun(EndOfRun { rows: 3 }),
        ];
        let s = decode(&mut frames(&messages).as_slice(), &mut Vec::new()).unwrap();
        assert_eq!(s.flags, [("FREE_INERTIAL", 1), ("DEFAULT_CONFIG", 2)]);
        let text = s.to_string();
        assert!(
            text.contains("status flags of the solution rows (frames with each): FREE_INERTIAL 1, DEFAULT_CONFIG 2")
                && text.contains("WARNING: 2 of 3 rows from the board's compiled-in configuration"),
            "{text}"
        );
        let plain = [
            at(0, StatusFlags::empty()),
            Message::EndOfRun(EndOfRun { rows: 1 }),
        ];
        let s = decode(&mut frames(&plain).as_slice(), &mut Vec::new()).unwrap();
        assert!(!s.to_string().contains("flags"), "{s}");
        assert!(!s.to_string().contains("board status"), "{s}");
    }

    /// The board's status in each frame is counted, and rows whose frame says DEGRADED or
    /// FAULT where the CSV does not are warned of (they decoded as a clean log, status NAV or
    /// none).
    #[test]
    fn a_degraded_or_faulty_boards_rows_are_warned_of() {
        let at = |k: u64, status: NavStatus, filter: &'static str| {
            let solution = Solution {
                t_us: S.t_us + k * 2500,
                ..S
            };
            let columns = FilterColumns {
                sigma_ned_m: [1.0; 3],
                sigma_v_ned_m_s: [0.1; 3],
                sigma_att_deg: [0.5; 3],
                status: filter,
            };
            let flags = match status {
                NavStatus::Degraded => StatusFlags::AIDING_REJECTED,
                NavStatus::Fault => StatusFlags::DEVICE_FAULT,
                _ => StatusFlags::empty(),
            };
            Message::NavSolution(NavSolution {
                row: Row::Aided(solution, columns),
                status,
                flags,
            })
        };
        let messages = [
            at(0, NavStatus::Nav, "NAV"),
            at(1, NavStatus::Degraded, "DEGRADED"),
            at(2, NavStatus::Degraded, "NAV"),
            at(3, NavStatus::Fault, "NAV"),
            Message::EndOfRun(EndOfRun { rows: 4 }),
        ];
        let s = decode(&mut frames(&messages).as_slice(), &mut Vec::new()).unwrap();
        assert_eq!(s.statuses, [("NAV", 1), ("DEGRADED", 2), ("FAULT", 1)]);
        assert_eq!(s.unsaid, 2);
        let text = s.to_string();
        assert!(
            text.contains(
                "board status of the solution rows (frames with each): NAV 1, DEGRADED 2, FAULT 1"
            ) && text.contains("WARNING: 2 of 4 rows' frames say DEGRADED or FAULT"),
            "{text}"
        );
    }

    /// Frames whose board status contradicts its own flags or gives no solution (NAV with
    /// IMU_LOST and NEAR_POLE, a STANDBY or ALIGN_COARSE row, FAULT without a failure, a
    /// failure under DEGRADED) decoded as NAV rows of a complete log, without a word. Refused
    /// now as content no board writes; the rows the status rule gives pass.
    #[test]
    fn solution_frames_whose_status_contradicts_the_rule_are_refused() {
        let row = |k: u64| {
            Row::Free(Solution {
                t_us: S.t_us + k * 2500,
                ..S
            })
        };
        let frame = |k: u64, status: NavStatus, flags: StatusFlags| {
            Message::NavSolution(NavSolution {
                row: row(k),
                status,
                flags,
            })
        };
        let free = StatusFlags::FREE_INERTIAL;
        for (status, flags) in [
            (
                NavStatus::Nav,
                free | StatusFlags::IMU_LOST | StatusFlags::NEAR_POLE,
            ),
            (NavStatus::Standby, free),
            (NavStatus::AlignCoarse, free),
            (NavStatus::AlignFine, free),
            (NavStatus::Fault, free),
            (NavStatus::Degraded, free | StatusFlags::BUS_ERRORS),
            (NavStatus::Degraded, free),
        ] {
            let messages = [
                frame(0, NavStatus::Nav, free),
                frame(1, status, flags),
                Message::EndOfRun(EndOfRun { rows: 2 }),
            ];
            let mut out = Vec::new();
            let s = decode(&mut frames(&messages).as_slice(), &mut out).unwrap();
            assert_eq!((s.rows, s.implausible), (1, 1), "{status:?} {flags:?}");
            assert!(!s.complete());
            assert!(s.to_string().contains("no board writes it"), "{s}");
        }
        for (status, flags) in [
            (NavStatus::Nav, free | StatusFlags::CLIPPING),
            (NavStatus::Degraded, free | StatusFlags::IMU_LOST),
            (
                NavStatus::Fault,
                free | StatusFlags::DEVICE_FAULT | StatusFlags::NEAR_POLE,
            ),
        ] {
            let messages = [
                frame(0, NavStatus::Nav, free),
                frame(1, status, flags),
                Message::EndOfRun(EndOfRun { rows: 2 }),
            ];
            let s = decode(&mut frames(&messages).as_slice(), &mut Vec::new()).unwrap();
            assert_eq!((s.rows, s.implausible), (2, 0), "{status:?} {flags:?}");
        }
    }

    /// Frames whose CRC holds but whose content no navigator writes are refused, counted,
    /// not written, and the log is not marked complete.
    #[test]
    fn implausible_solution_frames_are_refused_and_the_log_left_incomplete() {
        let at = |k: u64| Solution {
            t_us: S.t_us + k * 2500,
            ..S
        };
        let bad = [
            Solution {
                lat_ndeg: 1_000_000_000_000,
                ..at(1)
            },
            Solution {
                h_m: f64::NAN,
                ..at(1)
            },
            // Back in time.
            at(0),
            // Beyond an angle's range (written as valid rows before).
            Solution {
                roll_deg: 400.0,
                ..at(1)
            },
            Solution {
                pitch_deg: -200.0,
                ..at(1)
            },
            Solution {
                yaw_deg: -720.0,
                ..at(1)
            },
            Solution {
                yaw_deg: 540.0,
                ..at(1)
            },
        ];
        for b in bad {
            let messages = [
                solution(Row::Free(at(0))),
                solution(Row::Free(b)),
                Message::EndOfRun(EndOfRun { rows: 2 }),
            ];
            let mut out = Vec::new();
            let s = decode(&mut frames(&messages).as_slice(), &mut out).unwrap();
            assert_eq!((s.rows, s.implausible), (1, 1), "{b:?}");
            assert!(!s.complete(), "{b:?}");
            let text = String::from_utf8(out).unwrap();
            assert!(!text.contains("# end"), "{text}");
            assert!(s.to_string().contains("refused solution frame"), "{s}");
        }
        let sigma = Row::Aided(
            at(1),
            FilterColumns {
                sigma_ned_m: [1.0, -1.0, 1.0],
                sigma_v_ned_m_s: [0.1; 3],
                sigma_att_deg: [0.5; 3],
                status: "NAV",
            },
        );
        assert!(implausible(&sigma, None).is_some());
        assert!(implausible(&Row::Free(at(1)), Some(at(0).t_us)).is_none());
        // The ranges' ends are a navigator's, and so are a diverged free vertical channel's
        // height and speed.
        let edge = Solution {
            roll_deg: -180.0,
            pitch_deg: 90.0,
            yaw_deg: 180.0,
            ..at(1)
        };
        assert_eq!(implausible(&Row::Free(edge), None), None);
        let diverged = Solution {
            h_m: -3.0e7,
            v_eb_n: [0.0, 0.0, 5.0e4],
            ..at(1)
        };
        assert_eq!(implausible(&Row::Free(diverged), None), None);
        let why = implausible(
            &Row::Free(Solution {
                yaw_deg: 540.0,
                ..at(1)
            }),
            None,
        )
        .unwrap();
        assert_eq!(why, "yaw 540 deg not within [-180, 180]");
    }

    /// A solution frame sent twice (a capture that repeated it): the repeat is refused as not
    /// after the previous row and the log left incomplete, which the summary said as "451
    /// rows, but the end-of-run frame says 451", the counts it calls different equal. It names
    /// the refused frames now.
    /// A stream through a text-mode transfer (LF -> CR LF) was "broken COBS stuffing" 300
    /// times, no word of why; the decoder says what happened to it.
    #[test]
    fn a_stream_rewritten_by_a_text_mode_transfer_is_named_so() {
        let messages: Vec<Message> = (0..200)
            .map(|k| {
                solution(Row::Free(Solution {
                    t_us: S.t_us + k * 2500,
                    h_m: 150.0 + k as f64 * 0.37,
                    ..S
                }))
            })
            .chain([Message::EndOfRun(EndOfRun { rows: 200 })])
            .collect();
        let good = frames(&messages);
        let s = decode(&mut good.as_slice(), &mut Vec::new()).unwrap();
        assert!(s.complete() && s.text_mode_hint().is_none());
        let mut crlf = Vec::new();
        for &b in &good {
            if b == b'\n' {
                crlf.push(b'\r');
            }
            crlf.push(b);
        }
        assert!(crlf.len() >= good.len() + CRLF_EVIDENCE as usize);
        let e = format!(
            "{:#}",
            decode(&mut crlf.as_slice(), &mut Vec::new()).unwrap_err()
        );
        assert!(
            e.contains("a text-mode transfer (LF -> CR LF) rewrote it"),
            "{e}"
        );
    }

    #[test]
    fn a_repeated_solution_frame_is_named_as_the_reason_for_an_incomplete_log() {
        let row = solution(Row::Free(S));
        let messages = [row, row, Message::EndOfRun(EndOfRun { rows: 1 })];
        let mut out = Vec::new();
        let s = decode(&mut frames(&messages).as_slice(), &mut out).unwrap();
        assert_eq!((s.rows, s.implausible, s.complete()), (1, 1, false));
        let text = s.to_string();
        assert!(
            text.contains(
                "1 rows, as the end-of-run frame says, but 1 more solution frames refused for \
                 their content: incomplete (no end record written)"
            ),
            "{text}"
        );
        assert!(!text.contains("but the end-of-run frame says 1"), "{text}");
    }

    /// Times of 2^63 us and more printed as negative (an i64 on the way): `u64::MAX` us was
    /// `-0.000001`, and 2^63 - 1000 then 2^63 + 1000 us read as going back. Both in order now,
    /// and a time after the later one's is still refused as going back.
    #[test]
    fn times_beyond_i64_print_unsigned_and_in_order() {
        let at = |t_us: u64| solution(Row::Free(Solution { t_us, ..S }));
        let half = 1_u64 << 63;
        let messages = [
            at(half - 1000),
            at(half + 1000),
            at(u64::MAX),
            at(half),
            Message::EndOfRun(EndOfRun { rows: 3 }),
        ];
        let mut out = Vec::new();
        let s = decode(&mut frames(&messages).as_slice(), &mut out).unwrap();
        assert_eq!((s.rows, s.implausible), (3, 1));
        let text = String::from_utf8(out).unwrap();
        let times: Vec<&str> = text
            .lines()
            .skip(1)
            .filter_map(|l| l.split(',').next())
            .collect();
        assert_eq!(
            times,
            [
                "9223372036854.774808",
                "9223372036854.776808",
                "18446744073709.551615"
            ],
            "{text}"
        );
        assert!(
            s.to_string().contains("not after the previous row's"),
            "{s}"
        );
    }
}
