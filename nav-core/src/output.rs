//! The navigation solution as output: degrees and plain numbers, one CSV row per solution.
//!
//! The firmware and the host harness both write their solution logs through [`Solution`]'s
//! `Display`, so equal states print as equal text. Latitude and longitude are printed from the
//! fixed-point position as exact decimal nanodegrees; the other values are widened to `f64` and
//! printed in Rust's shortest round-trip form (platform independent).
//!
//! A log is [`CSV_HEADER`], one [`Solution`] row per line, and, as its last line, the
//! [`EndRecord`] (`# end: 102 rows, ok`). Only a run that ended normally writes the end record,
//! after its last row: a log without it was cut short (the run failed, crashed or was stopped),
//! whatever rows it has. CSV readers that skip `#` comment lines read the rows unchanged. A
//! free-inertial log marks an IMU gap that lost its solution with a [`LostRecord`] before the
//! rows after it.

use crate::{NavState, Scalar};
use core::fmt;

/// Column header of the solution CSV (more columns may be appended later).
pub const CSV_HEADER: &str =
    "t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,pitch_deg,yaw_deg";

/// The solution log's last line, written only by a run that ended normally: `# end: N rows, ok`,
/// with `N` the number of solution rows between the header and it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EndRecord {
    /// Solution rows in the log (the header and the end record not counted).
    pub rows: u32,
}

impl EndRecord {
    /// What every end record starts with (a CSV comment).
    pub const PREFIX: &'static str = "# end:";

    /// The end record of `line` (without its line terminator; surrounding blanks allowed):
    /// `None` unless it starts with [`Self::PREFIX`]; an error when it does but is not
    /// `# end: N rows, ok`.
    pub fn parse(line: &str) -> Option<Result<Self, MalformedEndRecord>> {
        let rest = line.trim().strip_prefix(Self::PREFIX)?;
        let rows = rest
            .strip_prefix(' ')
            .and_then(|r| r.strip_suffix(" rows, ok"))
            .filter(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
            .and_then(|n| n.parse::<u32>().ok());
        Some(rows.map(|rows| Self { rows }).ok_or(MalformedEndRecord))
    }
}

/// A line starts like an [`EndRecord`] but is not one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MalformedEndRecord;

impl fmt::Display for MalformedEndRecord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "malformed end record: expected '{} N rows, ok'",
            EndRecord::PREFIX
        )
    }
}

impl core::error::Error for MalformedEndRecord {}

impl fmt::Display for EndRecord {
    /// `# end: N rows, ok` (no line terminator).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} rows, ok", Self::PREFIX, self.rows)
    }
}

/// The comment record a free-inertial log writes where an IMU gap beyond the bridge
/// ([`crate::gap::MAX_BRIDGED_S`]) lost the solution, before the rows after it: `# lost: t =
/// 3615.002500 s after an IMU gap of 3600.000000 s (...): the rows from here on are no
/// solution`. The rows after it carry on from the state before the gap and look valid; a
/// reader takes the ones at or after `t_us` as lost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LostRecord {
    /// Time of the first sample after the gap [us].
    pub t_us: u64,
    /// The gap's length [us].
    pub gap_us: u64,
}

impl LostRecord {
    /// What every lost record starts with (a CSV comment).
    pub const PREFIX: &'static str = "# lost: t = ";

    /// The lost record of `line` (surrounding blanks allowed): `None` unless it starts with
    /// [`Self::PREFIX`] followed by a time in seconds (`3615.002500 s`); only the time is read.
    pub fn parse(line: &str) -> Option<Self> {
        let rest = line.trim().strip_prefix(Self::PREFIX)?;
        let (t, _) = rest.split_once(" s")?;
        let (whole, fraction) = t.split_once('.').unwrap_or((t, ""));
        let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
        if whole.is_empty() || !digits(whole) || !digits(fraction) || fraction.len() > 6 {
            return None;
        }
        let scale = 10_u64.pow(6 - fraction.len() as u32);
        let micros = if fraction.is_empty() {
            0
        } else {
            fraction.parse::<u64>().ok()? * scale
        };
        let t_us = whole
            .parse::<u64>()
            .ok()?
            .checked_mul(1_000_000)?
            .checked_add(micros)?;
        Some(Self { t_us, gap_us: 0 })
    }
}

impl fmt::Display for LostRecord {
    /// The record (no line terminator).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(Self::PREFIX)?;
        write_unsigned_decimal(f, self.t_us, 6)?;
        f.write_str(" s after an IMU gap of ")?;
        write_unsigned_decimal(f, self.gap_us, 6)?;
        write!(
            f,
            " s (beyond the {} s bridged): the solution is lost, the rows from here on are no \
             solution",
            crate::gap::MAX_BRIDGED_S
        )
    }
}

/// One navigation solution in output units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solution {
    /// Time of the sample that produced it [us].
    pub t_us: u64,
    /// Latitude [nanodegrees].
    pub lat_ndeg: i64,
    /// Longitude [nanodegrees].
    pub lon_ndeg: i64,
    /// Ellipsoidal height [m].
    pub h_m: f64,
    /// Velocity `v_eb_n` north, east, down (NED, whatever the mechanization frame) [m/s].
    pub v_eb_n: [f64; 3],
    /// Roll [deg].
    pub roll_deg: f64,
    /// Pitch [deg].
    pub pitch_deg: f64,
    /// Yaw (true heading) [deg], in (-180, 180].
    pub yaw_deg: f64,
}

impl Solution {
    /// The solution of `state` at time `t_us` [us].
    pub fn from_state<T: Scalar>(t_us: u64, state: &NavState<T>) -> Self {
        // NED quantities in f64 (at the output rate only).
        let wide = NavState::<f64> {
            q_b_n: crate::attitude::quat_to_f64(&state.q_b_n),
            v_eb_n: state.v_eb_n.map(T::to_f64),
            position: state.position,
        };
        let (q_b_ned, v_eb_ned) = wide.ned();
        // The singular band of the precision the attitude was computed in.
        let eps = T::default_epsilon().to_f64();
        let (roll, pitch, yaw) = crate::attitude::euler_to_precision(&q_b_ned, eps);
        Self {
            t_us,
            lat_ndeg: state.position.lat_ndeg(),
            lon_ndeg: state.position.lon_ndeg(),
            h_m: state.position.h_f64(),
            v_eb_n: v_eb_ned.into(),
            roll_deg: roll.to_degrees(),
            pitch_deg: pitch.to_degrees(),
            yaw_deg: yaw.to_degrees(),
        }
    }
}

/// The columns an aided run's rows add after [`CSV_HEADER`]'s: the navigation filter's 1-sigma
/// of position north, east, down [m], velocity [m/s], roll, pitch, yaw [deg], and its status
/// (`NAV` or `DEGRADED`, [`crate::ins_filter::FilterStatus::name`]).
pub const FILTER_COLUMNS: &str = "sigma_n_m,sigma_e_m,sigma_d_m,sigma_vn_mps,sigma_ve_mps,\
sigma_vd_mps,sigma_roll_deg,sigma_pitch_deg,sigma_yaw_deg,status";

/// Column header of an aided run's solution CSV: [`CSV_HEADER`], then [`FILTER_COLUMNS`].
pub const AIDED_CSV_HEADER: &str = "t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,\
pitch_deg,yaw_deg,sigma_n_m,sigma_e_m,sigma_d_m,sigma_vn_mps,sigma_ve_mps,sigma_vd_mps,\
sigma_roll_deg,sigma_pitch_deg,sigma_yaw_deg,status";

/// The navigation filter's columns of an aided row ([`FILTER_COLUMNS`]). The 1-sigmas are kept
/// in `f32` (seven digits are plenty for an uncertainty, and their text stays short).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterColumns {
    /// 1-sigma of position north, east, down [m].
    pub sigma_ned_m: [f32; 3],
    /// 1-sigma of velocity north, east, down [m/s].
    pub sigma_v_ned_m_s: [f32; 3],
    /// 1-sigma of roll, pitch, yaw [deg].
    pub sigma_att_deg: [f32; 3],
    /// The filter's status name.
    pub status: &'static str,
}

impl fmt::Display for FilterColumns {
    /// The columns after a row's solution, each with its leading comma.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for v in self
            .sigma_ned_m
            .iter()
            .chain(&self.sigma_v_ned_m_s)
            .chain(&self.sigma_att_deg)
        {
            write!(f, ",{v}")?;
        }
        write!(f, ",{}", self.status)
    }
}

/// One row of a solution log: a free-inertial solution, or an aided one with the filter's
/// columns (an aided run writes only these, under [`AIDED_CSV_HEADER`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Row {
    /// The solution alone ([`CSV_HEADER`]).
    Free(Solution),
    /// The solution and the filter's columns ([`AIDED_CSV_HEADER`]).
    Aided(Solution, FilterColumns),
}

impl Row {
    /// The navigation solution of the row.
    pub fn solution(&self) -> &Solution {
        match self {
            Self::Free(s) | Self::Aided(s, _) => s,
        }
    }

    /// The filter's columns, in an aided row.
    pub fn filter(&self) -> Option<&FilterColumns> {
        match self {
            Self::Free(_) => None,
            Self::Aided(_, c) => Some(c),
        }
    }
}

impl fmt::Display for Row {
    /// One CSV row (no line terminator).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Free(s) => write!(f, "{s}"),
            Self::Aided(s, c) => write!(f, "{s}{c}"),
        }
    }
}

/// Writes `value / 10^digits` exactly, e.g. `-0.000000500` for (-500, 9).
fn write_decimal(f: &mut fmt::Formatter<'_>, value: i64, digits: u32) -> fmt::Result {
    if value < 0 {
        f.write_str("-")?;
    }
    write_unsigned_decimal(f, value.unsigned_abs(), digits)
}

/// Writes `value / 10^digits` exactly, e.g. `18446744073709.551615` for (`u64::MAX`, 6).
fn write_unsigned_decimal(f: &mut fmt::Formatter<'_>, value: u64, digits: u32) -> fmt::Result {
    let scale = 10_u64.pow(digits);
    write!(
        f,
        "{}.{:0width$}",
        value / scale,
        value % scale,
        width = digits as usize
    )
}

impl fmt::Display for Solution {
    /// One CSV row matching [`CSV_HEADER`] (no line terminator).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Unsigned: a time of 2^63 us or more printed as negative through an i64.
        write_unsigned_decimal(f, self.t_us, 6)?;
        f.write_str(",")?;
        write_decimal(f, self.lat_ndeg, 9)?;
        f.write_str(",")?;
        write_decimal(f, self.lon_ndeg, 9)?;
        let [vn, ve, vd] = self.v_eb_n;
        write!(
            f,
            ",{},{},{},{},{},{},{}",
            self.h_m, vn, ve, vd, self.roll_deg, self.pitch_deg, self.yaw_deg
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Buf<const N: usize>([u8; N], usize);
    impl<const N: usize> fmt::Write for Buf<N> {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            let end = self.1 + s.len();
            self.0
                .get_mut(self.1..end)
                .ok_or(fmt::Error)?
                .copy_from_slice(s.as_bytes());
            self.1 = end;
            Ok(())
        }
    }

    #[test]
    fn formats_a_row() {
        let s = Solution {
            t_us: 60_002_500,
            lat_ndeg: 45_123_456_789,
            lon_ndeg: -500,
            h_m: 100.25,
            v_eb_n: [0.5, -0.0, 1e-7],
            roll_deg: 1.5,
            pitch_deg: -2.0,
            yaw_deg: 30.0,
        };
        let mut b = Buf([0; 128], 0);
        fmt::Write::write_fmt(&mut b, format_args!("{s}")).unwrap();
        assert_eq!(
            core::str::from_utf8(&b.0[..b.1]).unwrap(),
            "60.002500,45.123456789,-0.000000500,100.25,0.5,-0,0.0000001,1.5,-2,30"
        );
        assert_eq!(CSV_HEADER.split(',').count(), 10);
    }

    #[test]
    fn formats_an_aided_row_under_its_header() {
        let s = Solution {
            t_us: 1_000_000,
            lat_ndeg: 45_000_000_000,
            lon_ndeg: 7_500_000_000,
            h_m: 250.0,
            v_eb_n: [0.0; 3],
            roll_deg: 0.0,
            pitch_deg: 0.0,
            yaw_deg: 90.0,
        };
        let c = FilterColumns {
            sigma_ned_m: [0.5, 0.5, 1.25],
            sigma_v_ned_m_s: [0.01, 0.01, 0.02],
            sigma_att_deg: [0.003, 0.003, 0.5],
            status: "NAV",
        };
        let mut b = Buf([0; 256], 0);
        fmt::Write::write_fmt(&mut b, format_args!("{}", Row::Aided(s, c))).unwrap();
        let text = core::str::from_utf8(&b.0[..b.1]).unwrap();
        assert_eq!(
            text,
            "1.000000,45.000000000,7.500000000,250,0,0,0,0,0,90,0.5,0.5,1.25,0.01,0.01,0.02,\
             0.003,0.003,0.5,NAV"
        );
        assert_eq!(text.split(',').count(), AIDED_CSV_HEADER.split(',').count());
        // The aided header is the plain one and the filter's columns.
        let rest = AIDED_CSV_HEADER.strip_prefix(CSV_HEADER).unwrap();
        assert_eq!(rest.strip_prefix(','), Some(FILTER_COLUMNS));
        let mut b = Buf([0; 256], 0);
        fmt::Write::write_fmt(&mut b, format_args!("{}", Row::Free(s))).unwrap();
        assert_eq!(
            core::str::from_utf8(&b.0[..b.1]).unwrap(),
            "1.000000,45.000000000,7.500000000,250,0,0,0,0,0,90"
        );
    }

    #[test]
    fn lost_record_round_trip() {
        extern crate std;
        let r = LostRecord {
            t_us: 3_615_002_500,
            gap_us: 3_600_000_000,
        };
        let text = std::format!("{r}");
        assert!(
            text.starts_with("# lost: t = 3615.002500 s after an IMU gap of 3600.000000 s"),
            "{text}"
        );
        assert_eq!(
            LostRecord::parse(&text),
            Some(LostRecord {
                t_us: 3_615_002_500,
                gap_us: 0
            })
        );
        assert_eq!(
            LostRecord::parse("# lost: t = 12 s"),
            Some(LostRecord {
                t_us: 12_000_000,
                gap_us: 0
            })
        );
        for bad in [
            "# lost: t = x s",
            "# lost: t = 1.2345678 s",
            "# end: 1 rows, ok",
            "1,2",
        ] {
            assert_eq!(LostRecord::parse(bad), None, "{bad}");
        }
    }

    #[test]
    fn end_record_round_trip_and_refusals() {
        let mut b = Buf([0; 64], 0);
        let end = EndRecord { rows: 102 };
        fmt::Write::write_fmt(&mut b, format_args!("{end}")).unwrap();
        let text = core::str::from_utf8(&b.0[..b.1]).unwrap();
        assert_eq!(text, "# end: 102 rows, ok");
        assert_eq!(EndRecord::parse(text), Some(Ok(end)));
        assert_eq!(
            EndRecord::parse("  # end: 0 rows, ok\r"),
            Some(Ok(EndRecord { rows: 0 }))
        );
        // Rows and other comments are not end records.
        assert_eq!(EndRecord::parse("60.002500,45.1,7.5,0,0,0,0,0,0,0"), None);
        assert_eq!(EndRecord::parse("# a comment"), None);
        for bad in [
            "# end:",
            "# end: rows, ok",
            "# end: +5 rows, ok",
            "# end: 5 rows",
            "# end: 5 rows, failed",
            "# end: 99999999999 rows, ok",
        ] {
            assert_eq!(
                EndRecord::parse(bad),
                Some(Err(MalformedEndRecord)),
                "{bad}"
            );
        }
    }
}
