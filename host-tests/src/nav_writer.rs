//! The KF-GINS trajectory (`.nav`) writer: 11 columns — GNSS week, GNSS seconds of week [s],
//! latitude, longitude [deg], ellipsoidal height [m], velocity north, east, down [m/s], roll,
//! pitch, yaw [deg] — the file KF-GINS writes as `KF_GINS_Navresult.nav` and
//! [`crate::kf_gins::NavReader`] reads.
//!
//! **As KF-GINS writes it** (`kf_gins.cpp` `writeNavResult`, `FileSaver::dump_`): the week column
//! is always 0 (KF-GINS knows no week: its times are seconds of week), every field is printed as
//! C's `%-15.9lf ` (9 decimals, left-aligned in 15 characters, then one blank; so every line
//! ends with a blank before its `\n`), and the yaw is in [0, 360) deg (KF-GINS's
//! `Rotation::matrix2euler` adds 360 deg to a negative heading). Nine decimals are 1e-9 deg
//! (0.1 mm) in latitude and longitude, 1 nm in height, 1 nm/s in velocity.
//!
//! **Fast.** A field is formatted as a fixed-point integer (`round(|x| 1e9)`, ties to even on the
//! exact binary value, as C's `printf` rounds) written digit pair by digit pair into blanks
//! reserved at the end of the rows gathered for one 1 MiB write: no `format!`, no allocation
//! and no copy per row. The output is byte-identical to
//! `printf("%-15.9f ")` (and to Rust's `{:<15.9} `) for every finite value; values of 9e9 or
//! more (beyond the fixed-point integer) go through Rust's formatter. NaN and infinities are
//! written as C writes them (`nan`, `inf`, `-inf`, `-nan`); the reader refuses such lines.
//!
//! The same writer writes KF-GINS's other text files, row by row of plain fields
//! ([`NavWriter::write_fields`]: `KF_GINS_IMU_ERR.txt`, `KF_GINS_STD.txt`).
//!
//! **Atomic.** Rows go to a temporary file beside the output ([`crate::atomic::AtomicFile`]),
//! renamed into place by [`NavWriter::finish`]; a writer dropped without `finish` (an error, a
//! panic) leaves no file, and an existing file at the path untouched.

use crate::atomic::AtomicFile;
use crate::text_error::TextError;
use crate::truth::Truth;
use nav_core::attitude::euler;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The week KF-GINS writes in the first column.
pub const KF_GINS_WEEK: f64 = 0.0;

/// One trajectory row, in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavRow {
    /// GNSS seconds of week [s].
    pub t_s: f64,
    /// Geodetic latitude [rad].
    pub lat_rad: f64,
    /// Longitude [rad].
    pub lon_rad: f64,
    /// Ellipsoidal height [m].
    pub h_m: f64,
    /// Velocity relative to the Earth, north, east, down [m/s].
    pub v_eb_n_m_s: [f64; 3],
    /// Roll, pitch, yaw of the FRD body relative to NED (z-y-x Euler angles) [rad]; a negative
    /// yaw is written plus 360 deg.
    pub euler_rad: [f64; 3],
}

impl NavRow {
    /// The row of a [`Truth`] (its `t_s` taken as seconds of week).
    pub fn from_truth(truth: &Truth) -> Self {
        let (roll, pitch, yaw) = euler(&truth.q_b_ned);
        let v = &truth.v_eb_ned;
        Self {
            t_s: truth.t_s,
            lat_rad: truth.lat,
            lon_rad: truth.lon,
            h_m: truth.h,
            v_eb_n_m_s: [v.x, v.y, v.z],
            euler_rad: [roll, pitch, yaw],
        }
    }
}

/// Appends `row` to `line` as one `.nav` line, `\n` included.
pub fn format_row(row: &NavRow, line: &mut Vec<u8>) {
    // In [0, 360) as written: a yaw a hair below 0 (or 360) is written 0, not 360.000000000.
    let mut yaw_deg = rem_360(row.euler_rad[2].to_degrees());
    if yaw_deg >= 360.0 - 0.5e-9 {
        yaw_deg = 0.0;
    }
    let v = &row.v_eb_n_m_s;
    // The week column never changes: its text once (a tenth of a row's formatting).
    line.extend_from_slice(WEEK_FIELD);
    append_fields(
        &[
            row.t_s,
            row.lat_rad.to_degrees(),
            row.lon_rad.to_degrees(),
            row.h_m,
            v[0],
            v[1],
            v[2],
            row.euler_rad[0].to_degrees(),
            row.euler_rad[1].to_degrees(),
            yaw_deg,
        ],
        line,
    );
    line.push(b'\n');
}

/// `x.rem_euclid(360.0)`, without its `fmod` (a library call) for an `x` within a turn
/// either side of 0 (every yaw): `x % 360` is `x` itself there, plus 360 when negative.
fn rem_360(x: f64) -> f64 {
    if (0.0..360.0).contains(&x) {
        x
    } else if x > -360.0 && x < 0.0 {
        x + 360.0
    } else {
        x.rem_euclid(360.0)
    }
}

/// [`KF_GINS_WEEK`] as C's `%-15.9lf ` writes it (checked in the tests).
const WEEK_FIELD: &[u8] = b"0.000000000     ";

/// The width C's `%-15.9lf` pads a field to.
const WIDTH: usize = 15;

/// The most bytes a common field takes: '-', 10 integer digits, '.', 9 decimals, the blank.
const FIELD_BYTES: usize = 22;

/// The fields of the widest row KF-GINS writes (its 1-sigma file, `KF_GINS_STD.txt`).
const MAX_ROW_FIELDS: usize = 22;

/// `"00".."99"`: two digits a lookup.
const PAIRS: &[u8; 200] = b"\
0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// Appends each of `fields` as C's `%-15.9lf ` does: the common ones straight into blanks
/// reserved at the end of `line` (no copy of the row), a rare one ([`format_rare`]) on its
/// own.
fn append_fields(fields: &[f64], line: &mut Vec<u8>) {
    let reserved = fields.len() * FIELD_BYTES;
    let mut start = line.len();
    line.resize(start + reserved, b' ');
    let mut at = 0;
    for &x in fields {
        // False for NaN and the infinities too.
        if x.abs() < 9.0e9 {
            let field: &mut [u8; FIELD_BYTES] = (&mut line[start + at..][..FIELD_BYTES])
                .try_into()
                .expect("FIELD_BYTES long");
            at += format_field(x, field);
        } else {
            line.truncate(start + at);
            format_rare(x, line);
            start = line.len();
            at = 0;
            line.resize(start + reserved, b' ');
        }
    }
    line.truncate(start + at);
}

/// Writes a finite `x` with `|x| < 9e9` as C's `%-15.9lf ` at the start of `out` (blanks);
/// returns the bytes used, padding included.
fn format_field(x: f64, out: &mut [u8; FIELD_BYTES]) -> usize {
    // Without a branch on the sign (velocities and small angles change it at random): a
    // positive value's first digit overwrites the '-'.
    out[0] = b'-';
    let mut i = usize::from(x.is_sign_negative());
    let n = nano_units(x.abs());
    let (int, frac) = (n / 1_000_000_000, (n % 1_000_000_000) as u32);
    i += write_integer(int, &mut out[i..i + 10]);
    out[i] = b'.';
    write_nine_digits(frac, &mut out[i + 1..i + 10]);
    i += 10;
    i.max(WIDTH) + 1
}

/// NaN, infinities (as C writes them) and values of 9e9 or more (never a position, speed or
/// angle; through Rust's exact formatter).
#[cold]
fn format_rare(x: f64, line: &mut Vec<u8>) {
    let start = line.len();
    if x.is_nan() {
        line.extend_from_slice(if x.is_sign_negative() {
            b"-nan"
        } else {
            b"nan"
        });
    } else if x.is_infinite() {
        line.extend_from_slice(if x < 0.0 { b"-inf" } else { b"inf" });
    } else {
        // Writing into a Vec cannot fail.
        let _ = write!(line, "{x:.9}");
    }
    let written = line.len() - start;
    line.resize(start + written.max(WIDTH), b' ');
    line.push(b' ');
}

/// `a * 1e9` rounded to an integer, ties to even, exactly as the decimal expansion of `a`
/// rounds (C's `printf`): `a` in [0, 9e9).
///
/// The product is `p + e` exactly: `1e9 = 1953125 * 2^9` has 21 significant bits, so with `a`
/// split into halves of 26 and 27 bits both partial products are exact (Dekker's product;
/// no fused multiply-add, which is a library call on baseline x86-64). The choice between
/// `floor(p + e)` and the integer above compares the exact fraction with one half.
fn nano_units(a: f64) -> u64 {
    const TWO_POW_52: f64 = 4_503_599_627_370_496.0;
    const SPLIT: f64 = 134_217_729.0; // 2^27 + 1
    let p = a * 1e9;
    let t = a * SPLIT;
    let a_hi = t - (t - a);
    let a_lo = a - a_hi;
    let e = (a_hi * 1e9 - p) + a_lo * 1e9;
    // floor: p is in [0, 9e18), below 2^63: through i64, one conversion instruction (u64's
    // own needs a dozen on baseline x86-64), the same value.
    let n = p as i64 as u64;
    if p >= TWO_POW_52 {
        // p is an integer; the fraction is e's (|e| <= 512).
        let m = e.floor();
        let f = e - m; // exact
        let base = if m >= 0.0 {
            n + m as u64
        } else {
            n - (-m) as u64
        };
        return if f > 0.5 || (f == 0.5 && base % 2 == 1) {
            base + 1
        } else {
            base
        };
    }
    // Here |e| <= ulp(p) / 2 <= 0.25.
    let fp = p - n as i64 as f64; // exact, in [0, 1)
    // Exact for fp in [0.25, 1) (Sterbenz); for fp below, r >= 0.25 >= e (rounding keeps
    // 0.5 - fp above 0.25), and e == r would need ulp(p) = 0.5, so fp = 0 and r = 0.5: no
    // round-up, as it must be (fp + e < 0.5). No branch: fp is random.
    let r = 0.5 - fp;
    n + u64::from((e > r) | ((e == r) & (n % 2 == 1)))
}

/// Writes the decimal digits of `n` (< 1e10; no leading zeros, "0" for 0) at the start of
/// `out`; returns their count.
fn write_integer(n: u64, out: &mut [u8]) -> usize {
    let len = match n {
        0..10 => 1,
        10..100 => 2,
        100..1_000 => 3,
        1_000..10_000 => 4,
        10_000..100_000 => 5,
        100_000..1_000_000 => 6,
        1_000_000..10_000_000 => 7,
        10_000_000..100_000_000 => 8,
        100_000_000..1_000_000_000 => 9,
        _ => 10,
    };
    let (mut n, mut i) = (n as usize, len);
    while i >= 2 {
        let k = (n % 100) * 2;
        n /= 100;
        i -= 2;
        out[i..i + 2].copy_from_slice(&PAIRS[k..k + 2]);
    }
    if i == 1 {
        out[0] = b'0' + n as u8;
    }
    len
}

/// Writes `n` (< 1e9) as exactly nine digits: the first, then two groups of four (each two
/// pairs), computed side by side.
fn write_nine_digits(n: u32, out: &mut [u8]) {
    let (first, rest) = (n / 100_000_000, n % 100_000_000);
    let (hi, lo) = (rest / 10_000, rest % 10_000);
    out[0] = b'0' + first as u8;
    for (at, group) in [(1, hi), (5, lo)] {
        let (a, b) = ((group / 100) as usize * 2, (group % 100) as usize * 2);
        out[at..at + 2].copy_from_slice(&PAIRS[a..a + 2]);
        out[at + 2..at + 4].copy_from_slice(&PAIRS[b..b + 2]);
    }
}

/// Writes a KF-GINS `.nav` file row by row, atomically (see the module docs).
#[derive(Debug)]
pub struct NavWriter {
    file: AtomicFile,
    path: PathBuf,
    /// Rows formatted and not yet written, [`CHUNK_BYTES`] at most (and one row).
    pending: Vec<u8>,
    rows: u64,
}

/// Rows are written [`CHUNK_BYTES`] at a time: the kernel fills the page cache for a large
/// write in large folios; 8 KiB writes (`BufWriter`'s) cost about twice the system time of a
/// 128 MB trajectory, and copy each byte once more.
const CHUNK_BYTES: usize = 1 << 20;

impl NavWriter {
    /// Starts writing `path`: a temporary file beside it until [`Self::finish`].
    pub fn create(path: &Path) -> Result<Self, TextError> {
        Ok(Self {
            file: AtomicFile::create(path).map_err(|e| TextError::io(path, e))?,
            path: path.to_owned(),
            pending: Vec::with_capacity(CHUNK_BYTES + MAX_ROW_FIELDS * FIELD_BYTES + 1),
            rows: 0,
        })
    }

    /// Writes one row (to the file once `CHUNK_BYTES` are gathered).
    pub fn write_row(&mut self, row: &NavRow) -> Result<(), TextError> {
        format_row(row, &mut self.pending);
        self.rows += 1;
        if self.pending.len() >= CHUNK_BYTES {
            self.write_pending()?;
        }
        Ok(())
    }

    /// Writes one row of `fields` as KF-GINS's `FileSaver` writes its other text files (the
    /// IMU errors, the 1-sigma): each field `%-15.9lf `, then `\n`; at most 22 fields.
    pub fn write_fields(&mut self, fields: &[f64]) -> Result<(), TextError> {
        debug_assert!(fields.len() <= MAX_ROW_FIELDS);
        append_fields(fields, &mut self.pending);
        self.pending.push(b'\n');
        self.rows += 1;
        if self.pending.len() >= CHUNK_BYTES {
            self.write_pending()?;
        }
        Ok(())
    }

    /// Writes the rows gathered; the `BufWriter` passes a write this large straight through.
    fn write_pending(&mut self) -> Result<(), TextError> {
        self.file
            .writer()
            .write_all(&self.pending)
            .map_err(|e| TextError::io(&self.path, e))?;
        self.pending.clear();
        Ok(())
    }

    /// Writes the row of `truth` ([`NavRow::from_truth`]).
    pub fn write_truth(&mut self, truth: &Truth) -> Result<(), TextError> {
        self.write_row(&NavRow::from_truth(truth))
    }

    /// Rows taken so far (in the file once [`Self::finish`] returns).
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Flushes, syncs and puts the file in place; returns the number of rows.
    pub fn finish(self) -> Result<u64, TextError> {
        self.finish_timed().map(|(rows, _)| rows)
    }

    /// [`Self::finish`], and the time [s] the last step took: syncing the file to the disk
    /// and renaming it into place, a wait on the disk rather than processing.
    pub fn finish_timed(mut self) -> Result<(u64, f64), TextError> {
        self.write_pending()?;
        let path = self.path;
        let started = std::time::Instant::now();
        self.file.commit().map_err(|e| TextError::io(&path, e))?;
        Ok((self.rows, started.elapsed().as_secs_f64()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal, Uniform};

    fn field(x: f64) -> String {
        let mut line = Vec::new();
        append_fields(&[x], &mut line);
        String::from_utf8(line).unwrap()
    }

    #[test]
    fn fields_are_printf_fields() {
        assert_eq!(field(0.0), "0.000000000     ");
        assert_eq!(field(456_300.005), "456300.005000000 ");
        assert_eq!(field(-2.03480295), "-2.034802950    ");
        assert_eq!(field(-0.0), "-0.000000000    ");
        assert_eq!(field(-1e-12), "-0.000000000    ");
        // Exact ties go to the even digit, as printf rounds them.
        assert_eq!(field(1.0 / 1024.0), "0.000976562     ");
        assert_eq!(field(3.0 / 1024.0), "0.002929688     ");
        assert_eq!(field(f64::NAN), "nan             ");
        assert_eq!(field(f64::NEG_INFINITY), "-inf            ");
        assert_eq!(field(1.5e10), "15000000000.000000000 ");
    }

    #[test]
    fn fields_equal_the_exact_formatter() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let unit = Uniform::new(0.0, 1.0).unwrap();
        for k in 0..200_000 {
            let x: f64 = match k % 4 {
                0 => {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    z * 10f64.powi(k % 11 - 5)
                }
                1 => 604_800.0 * unit.sample(&mut rng),
                // Near ties: multiples of 0.5e-9 and their neighbours.
                2 => {
                    let m = (unit.sample(&mut rng) * 1e12).floor() + 0.5;
                    let x = m * 1e-9;
                    if k % 8 == 2 { x.next_up() } else { x }
                }
                _ => (k as f64) / 1024.0 - 100.0,
            };
            assert_eq!(field(x), format!("{x:<15.9} "), "{x:e}");
        }
    }

    /// A rare field between common ones breaks the row's buffer without moving a byte.
    #[test]
    fn rare_fields_keep_their_place_in_the_row() {
        let xs = [1.0, f64::NAN, -2.5, 1.5e10, 3.0, f64::INFINITY, -0.125];
        let mut line = Vec::new();
        append_fields(&xs, &mut line);
        let each: String = xs.iter().map(|x| field(*x)).collect();
        assert_eq!(String::from_utf8(line).unwrap(), each);
        assert_eq!(field(-0.125), "-0.125000000    ");
    }

    /// The week column's constant text is the week's field.
    #[test]
    fn the_week_field_is_the_weeks() {
        assert_eq!(field(KF_GINS_WEEK).as_bytes(), WEEK_FIELD);
    }

    #[test]
    fn rem_360_is_rem_euclid() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let unit = Uniform::new(-1.0, 1.0).unwrap();
        let edges = [
            0.0,
            -0.0,
            -1e-300,
            1e-300,
            360.0,
            -360.0,
            360.0_f64.next_down(),
            (-360.0_f64).next_up(),
            180.0,
            -180.0,
            720.5,
            -1e6,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let random = (0..100_000).map(|k| unit.sample(&mut rng) * [1.0, 180.0, 400.0, 1e9][k % 4]);
        for x in edges.into_iter().chain(random) {
            let (got, want) = (rem_360(x), x.rem_euclid(360.0));
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{x:e}"
            );
        }
    }

    #[test]
    fn yaw_is_written_in_0_360() {
        let row = NavRow {
            t_s: 1.0,
            lat_rad: 0.5,
            lon_rad: -2.0,
            h_m: 10.0,
            v_eb_n_m_s: [1.0, 2.0, 3.0],
            euler_rad: [0.0, 0.0, -std::f64::consts::FRAC_PI_2],
        };
        let mut line = Vec::new();
        format_row(&row, &mut line);
        let text = String::from_utf8(line).unwrap();
        assert!(
            text.starts_with("0.000000000     1.000000000     "),
            "{text}"
        );
        assert!(text.ends_with("270.000000000   \n"), "{text}");
        assert_eq!(text.len(), 11 * 16 + 1);
        // Just below north: 0, not 360.
        let mut line = Vec::new();
        format_row(
            &NavRow {
                euler_rad: [0.0, 0.0, -1e-13],
                ..row
            },
            &mut line,
        );
        let text = String::from_utf8(line).unwrap();
        assert!(text.ends_with(" 0.000000000     \n"), "{text}");
    }
}
