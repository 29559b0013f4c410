//! Reading text files one record at a time, in memory bounded by the longest line: CSV records
//! ([`CsvRecords`]) and plain lines ([`LineReader`]), each telling whether it is the file's last
//! line without a newline, and [`CutCheck`], the test of such a line against the lines before it.
//!
//! The rule for a last line that no newline ends (a file cut off, e.g. by a full disk or an
//! interrupted copy, ends that way): it is refused as [`Cut`] when it has fewer fields than a line
//! of the file needs, when its last field is not a number, or when its last field is shorter than
//! that column's field on every line before it. A complete line without the final newline passes
//! (its numbers have their full length); a cut one is caught unless the cut fell exactly at the
//! end of a field no shorter than the column's others.

use crate::text_error::{Cut, TextError, TextErrorKind};
use std::io::{self, BufRead, Read};
use std::path::{Path, PathBuf};

/// The 0-based position of column `name` in the header `names`: `Ok(None)` when absent,
/// `Err((first, second))` (1-based field positions) when the header names it twice, for readers
/// that find their columns by name (the first match would otherwise win silently).
pub fn column_position<S: AsRef<str>>(
    names: &[S],
    name: &str,
) -> Result<Option<usize>, (usize, usize)> {
    let mut at = names
        .iter()
        .enumerate()
        .filter(|(_, h)| h.as_ref() == name)
        .map(|(i, _)| i);
    match (at.next(), at.next()) {
        (Some(first), Some(second)) => Err((first + 1, second + 1)),
        (first, _) => Ok(first),
    }
}

/// Keeps the last byte read from `inner`: whether the file ended with a newline.
#[derive(Debug)]
pub struct LastByte<R> {
    inner: R,
    last: Option<u8>,
}

impl<R> LastByte<R> {
    /// `true` when the last byte read so far is a line end (`\n` or `\r`).
    fn ends_line(&self) -> bool {
        matches!(self.last, Some(b'\n' | b'\r'))
    }
}

impl<R: Read> Read for LastByte<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        if n > 0 {
            self.last = Some(buf[n - 1]);
        }
        Ok(n)
    }
}

/// What was read ahead of the record handed out.
#[derive(Debug)]
enum Ahead {
    /// A record, in `CsvRecords::ahead_record`.
    Record,
    /// The end of the file.
    End,
    /// A reading error, handed out after the records before it.
    Error(csv::Error),
}

/// The CSV records of a file as the project's CSV formats read them (rows of any length, fields
/// trimmed, lines that start with `#` comments wherever they are), one at a time, one record
/// read ahead so the last one is known as such.
#[derive(Debug)]
pub struct CsvRecords<R: Read> {
    reader: csv::Reader<LastByte<R>>,
    path: PathBuf,
    current: csv::StringRecord,
    ahead_record: csv::StringRecord,
    ahead: Ahead,
}

/// One CSV record handed out by [`CsvRecords::next_record`].
#[derive(Debug)]
pub struct CsvLine<'a> {
    /// The record (its position gives the line).
    pub record: &'a csv::StringRecord,
    /// 1-based line number.
    pub line: u64,
    /// `true` for the file's last line when no newline ends it.
    pub unterminated: bool,
}

impl<R: Read> CsvRecords<R> {
    /// Starts reading `reader`: the first record (the header, the caller's to check) and the
    /// reader of the records after it. A file without a record is
    /// [`TextErrorKind::MissingHeader`], `expected` naming the header row; `path` names the file
    /// in errors.
    pub fn new(
        reader: R,
        path: &Path,
        expected: &str,
    ) -> Result<(Self, csv::StringRecord), TextError> {
        let reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            // Numbers only: a quote is a character (one in a comment opens no field).
            .quoting(false)
            .from_reader(LastByte {
                inner: reader,
                last: None,
            });
        let mut records = Self {
            reader,
            path: path.to_owned(),
            current: csv::StringRecord::new(),
            ahead_record: csv::StringRecord::new(),
            ahead: Ahead::End,
        };
        records.read_ahead();
        match records.next_record() {
            None => Err(TextError::new(
                path,
                None,
                TextErrorKind::MissingHeader {
                    expected: expected.to_owned(),
                },
            )),
            Some(header) => {
                let header = header?.record.clone();
                Ok((records, header))
            }
        }
    }

    /// Reads the next record that is not a comment (its first field starts with `#`: read as
    /// a record, not by the reader's own comment rule, so that the line numbers count it).
    fn read_ahead(&mut self) {
        self.ahead = loop {
            match self.reader.read_record(&mut self.ahead_record) {
                Ok(true) if self.ahead_record.get(0).is_some_and(|f| f.starts_with('#')) => {}
                Ok(true) => break Ahead::Record,
                Ok(false) => break Ahead::End,
                Err(e) => break Ahead::Error(e),
            }
        };
    }

    /// The next record, `None` at the end of the file (and after an error).
    pub fn next_record(&mut self) -> Option<Result<CsvLine<'_>, TextError>> {
        match std::mem::replace(&mut self.ahead, Ahead::End) {
            Ahead::End => None,
            Ahead::Error(e) => Some(Err(TextError::from_csv(&self.path, e))),
            Ahead::Record => {
                std::mem::swap(&mut self.current, &mut self.ahead_record);
                self.read_ahead();
                let unterminated =
                    matches!(self.ahead, Ahead::End) && !self.reader.get_ref().ends_line();
                let line = self.current.position().map_or(0, |p| p.line());
                Some(Ok(CsvLine {
                    record: &self.current,
                    line,
                    unterminated,
                }))
            }
        }
    }
}

/// One line handed out by [`LineReader::next_line`].
#[derive(Debug)]
pub struct Line<'a> {
    /// The text, without the line end.
    pub text: &'a str,
    /// 1-based line number.
    pub number: u64,
    /// `true` for the file's last line when no newline ends it.
    pub unterminated: bool,
}

/// The lines of a text file one at a time: a line that lies whole in the reader's buffer is
/// handed out in place (no copy: 720,000-line IMU files), one that crosses the buffer's end is
/// gathered in one reused buffer.
#[derive(Debug)]
pub struct LineReader<R> {
    reader: R,
    buf: Vec<u8>,
    /// Bytes of the reader's buffer handed out last time, consumed before the next line.
    pending: usize,
    number: u64,
    /// Byte offset of the next line's start in the file.
    offset: u64,
}

impl<R: BufRead> LineReader<R> {
    /// Reads `reader` from its start.
    pub fn new(reader: R) -> Self {
        Self {
            reader,
            buf: Vec::new(),
            pending: 0,
            number: 0,
            offset: 0,
        }
    }

    /// The next line, `None` at the end of the file; an error carries the number of the line
    /// that could not be read (e.g. invalid UTF-8).
    pub fn next_line(&mut self) -> Option<Result<Line<'_>, (u64, io::Error)>> {
        let (bytes, number, unterminated, start) = match self.next_bytes()? {
            Ok(line) => (line.bytes, line.number, line.unterminated, line.start),
            Err(e) => return Some(Err(e)),
        };
        let text = match std::str::from_utf8(bytes) {
            Ok(text) => text.trim_end_matches(['\n', '\r']),
            Err(e) => return Some(Err((number, not_utf8(bytes, start, &e)))),
        };
        Some(Ok(Line {
            text,
            number,
            unterminated,
        }))
    }

    /// The next line as bytes, without its `\n` (a `\r` before it stays), not checked as UTF-8
    /// (a caller that parses ASCII numbers needs no second pass; [`Self::next_line`] checks).
    pub fn next_bytes(&mut self) -> Option<Result<RawLine<'_>, (u64, io::Error)>> {
        self.reader.consume(std::mem::take(&mut self.pending));
        self.number += 1;
        let number = self.number;
        let start = self.offset;
        // Where the line ends in the reader's buffer, if it does.
        let end = match self.reader.fill_buf() {
            Ok([]) => return None,
            Ok(available) => memchr::memchr(b'\n', available),
            Err(e) => return Some(Err((number, e))),
        };
        let (bytes, unterminated) = match end {
            Some(end) => match self.reader.fill_buf() {
                Ok(available) => {
                    self.pending = end + 1;
                    self.offset += self.pending as u64;
                    (&available[..end], false)
                }
                Err(e) => return Some(Err((number, e))),
            },
            None => {
                self.buf.clear();
                if let Err(e) = self.reader.read_until(b'\n', &mut self.buf) {
                    return Some(Err((number, e)));
                }
                self.offset += self.buf.len() as u64;
                let unterminated = self.buf.last() != Some(&b'\n');
                let text = if unterminated {
                    &self.buf[..]
                } else {
                    &self.buf[..self.buf.len() - 1]
                };
                (text, unterminated)
            }
        };
        Some(Ok(RawLine {
            bytes,
            number,
            unterminated,
            start,
        }))
    }
}

/// One line handed out by [`LineReader::next_bytes`].
#[derive(Debug)]
pub struct RawLine<'a> {
    /// The bytes, without the `\n`.
    pub bytes: &'a [u8],
    /// 1-based line number.
    pub number: u64,
    /// `true` for the file's last line when no newline ends it.
    pub unterminated: bool,
    /// Byte offset of the line's start in the file.
    pub start: u64,
}

/// The error of a line `bytes` starting at byte `start` of its file that is not UTF-8 (`e`):
/// the byte where it stops being, as [`crate::text_error::read_text`] says it (`std`'s "stream
/// did not contain valid UTF-8" named no byte).
pub fn not_utf8(bytes: &[u8], start: u64, e: &std::str::Utf8Error) -> io::Error {
    let at = e.valid_up_to();
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!(
            "not UTF-8 text (byte {}, 0x{:02x}): save the file as UTF-8",
            start + at as u64,
            bytes.get(at).copied().unwrap_or(0)
        ),
    )
}

/// The lines seen so far, for the test of an unterminated last line (see the module docs): the
/// fewest characters of each column's fields, and the field count of the line before.
#[derive(Clone, Debug, Default)]
pub struct CutCheck {
    shortest: Vec<usize>,
    previous_fields: usize,
}

impl CutCheck {
    /// Notes a complete line's fields.
    pub fn note<'a>(&mut self, fields: impl IntoIterator<Item = &'a str>) {
        self.note_lengths(fields.into_iter().map(|f| f.chars().count()));
    }

    /// Notes a complete line's fields by their lengths in characters.
    pub fn note_lengths(&mut self, lengths: impl IntoIterator<Item = usize>) {
        let mut n = 0;
        for (i, len) in lengths.into_iter().enumerate() {
            match self.shortest.get_mut(i) {
                Some(s) => *s = (*s).min(len),
                None => self.shortest.push(len),
            }
            n = i + 1;
        }
        self.previous_fields = n;
    }

    /// Checks an unterminated last line of `fields`: a line needs at least `min_fields` fields
    /// (and as many as the line before); `column(i)` names field `i`, `is_number(i, text)` says
    /// whether `text` is a valid value of field `i`.
    pub fn check(
        &self,
        fields: &[&str],
        min_fields: usize,
        column: impl Fn(usize) -> String,
        is_number: impl Fn(usize, &str) -> bool,
    ) -> Result<(), Cut> {
        let expected = min_fields.max(self.previous_fields);
        if fields.len() < expected {
            return Err(Cut::Fields {
                found: fields.len(),
                expected,
            });
        }
        let Some((last, text)) = fields.iter().enumerate().next_back() else {
            return Ok(());
        };
        if !is_number(last, text) {
            return Err(Cut::NotANumber {
                column: column(last),
                found: (*text).to_owned(),
            });
        }
        match self.shortest.get(last) {
            Some(&shortest) if text.chars().count() < shortest => Err(Cut::Shorter {
                column: column(last),
                found: (*text).to_owned(),
                shortest,
            }),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn column_position_refuses_a_name_given_twice() {
        let names = ["t_s", "lat_deg", "h_m", "lat_deg"];
        assert_eq!(column_position(&names, "t_s"), Ok(Some(0)));
        assert_eq!(column_position(&names, "lon_deg"), Ok(None));
        assert_eq!(column_position(&names, "lat_deg"), Err((2, 4)));
    }

    fn csv_lines(text: &str) -> Vec<(Vec<String>, u64, bool)> {
        let (mut r, header) = CsvRecords::new(text.as_bytes(), Path::new("m.csv"), "a,b").unwrap();
        assert_eq!(&header[0], "a");
        let mut out = Vec::new();
        while let Some(l) = r.next_record() {
            let l = l.unwrap();
            out.push((
                l.record.iter().map(str::to_owned).collect(),
                l.line,
                l.unterminated,
            ));
        }
        out
    }

    #[test]
    fn csv_records_know_the_unterminated_last_line() {
        let lines = csv_lines("a,b\n1,2\n3,4");
        assert_eq!(lines.len(), 2);
        assert_eq!((lines[0].1, lines[0].2), (2, false));
        assert_eq!((lines[1].1, lines[1].2), (3, true));
        for text in ["a,b\n1,2\n3,4\n", "a,b\r\n1,2\r\n3,4\r\n"] {
            let lines = csv_lines(text);
            assert_eq!(lines.len(), 2);
            assert!(lines.iter().all(|l| !l.2), "{text:?}");
        }
        assert!(csv_lines("a,b").is_empty());
        let Err(e) = CsvRecords::new(&b""[..], Path::new("f.csv"), "a,b") else {
            panic!("an empty file has no header");
        };
        assert_eq!(
            e.to_string(),
            "f.csv: empty file: expected the header row 'a,b'"
        );
    }

    #[test]
    fn line_reader_numbers_lines_and_knows_the_last() {
        let mut r = LineReader::new("x\r\n\ny z".as_bytes());
        let mut got = Vec::new();
        while let Some(l) = r.next_line() {
            let l = l.unwrap();
            got.push((l.text.to_owned(), l.number, l.unterminated));
        }
        assert_eq!(
            got,
            [
                ("x".to_owned(), 1, false),
                (String::new(), 2, false),
                ("y z".to_owned(), 3, true)
            ]
        );
    }

    /// A line that is not UTF-8 was "stream did not contain valid UTF-8": its line and the
    /// byte, counted from the file's start across lines and the reader's buffer, are named.
    #[test]
    fn a_line_not_utf8_names_its_byte() {
        let text = b"ab\r\nc\n\nd\xe9f\n";
        for capacity in [1, 3, 64] {
            let mut r = LineReader::new(io::BufReader::with_capacity(capacity, &text[..]));
            let starts: Vec<u64> = (0..3)
                .map(|_| r.next_line().unwrap().unwrap().number)
                .collect();
            assert_eq!(starts, [1, 2, 3]);
            let (line, e) = r.next_line().unwrap().unwrap_err();
            assert_eq!(line, 4, "{capacity}");
            assert_eq!(
                e.to_string(),
                "not UTF-8 text (byte 8, 0xe9): save the file as UTF-8",
                "{capacity}"
            );
        }
    }

    #[test]
    fn cut_check_compares_with_the_lines_before() {
        let mut c = CutCheck::default();
        c.note(["0.01", "-0.098"]);
        c.note(["0.02", "-0.0981"]);
        let name = |i: usize| format!("c{i}");
        let num = |_: usize, t: &str| t.parse::<f64>().is_ok();
        assert_eq!(c.check(&["0.03", "-0.098"], 2, name, num), Ok(()));
        assert_eq!(
            c.check(&["0.03"], 2, name, num),
            Err(Cut::Fields {
                found: 1,
                expected: 2
            })
        );
        assert_eq!(
            c.check(&["0.03", "-0.0"], 2, name, num),
            Err(Cut::Shorter {
                column: "c1".into(),
                found: "-0.0".into(),
                shortest: 6
            })
        );
        assert_eq!(
            c.check(&["0.03", "-"], 2, name, num),
            Err(Cut::NotANumber {
                column: "c1".into(),
                found: "-".into()
            })
        );
        // Nothing before: only the field count and the number are checked.
        let first = CutCheck::default();
        assert_eq!(first.check(&["1", "2"], 2, name, num), Ok(()));
    }
}
