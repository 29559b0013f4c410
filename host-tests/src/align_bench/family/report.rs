//! The family benchmark's statistics and tables.
//!
//! A [`Cell`] gathers the cases of one method, lever-arm case and window (or all windows):
//!
//! - counts: runs, `ALIGNED`, refusals by reason;
//! - attitude consistency: the largest `|error / sigma|` over roll, pitch and heading (with its
//!   member), how many results have an axis beyond [`ATTITUDE_SIGMAS`], and the RMS of
//!   `error / sigma` per axis (1 for an honest sigma; the target is 0.7–1.3 over 200
//!   members or more);
//! - heading against the floor, over the aligned members whose floor is below
//!   [`FLOOR_CAP_DEG`] (the `mems-tactical` members' gyro biases leave the heading
//!   unobservable: their floor is many radians): RMS heading error, RMS floor, RMS of `error /
//!   floor` (the target for `fine`: at most [`FLOOR_TARGET`]) and RMS of `sigma /
//!   floor` (below 1: the method claims more than the data can hold), and the RMS of `error /
//!   floor` over the still members and over the swaying ones apart (the floor is the noise's
//!   and the biases'; a swaying base's unknown translation raises the real one);
//! - hand-over: how many velocities and positions have an axis beyond [`HANDOVER_SIGMAS`] and
//!   the RMS of `error / sigma` per NED axis.

use super::{Aligned, Case, LeverCase, MemberRun, Outcome};
use crate::sensor_model::Grade;
use crate::trajectory::family::{Ablation, Category, FamilyMember};
use nav_core::Vector3;
use nav_core::alignment::AlignMethod;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

/// Attitude errors beyond this many of their own sigma are counted.
pub const ATTITUDE_SIGMAS: f64 = 4.0;
/// Hand-over velocity and position errors beyond this many of their sigma are counted.
pub const HANDOVER_SIGMAS: f64 = 3.0;
/// Members whose heading floor exceeds this are left out of the floor columns [deg].
pub const FLOOR_CAP_DEG: f64 = 10.0;
/// The target for `fine`: RMS of heading error over floor at most this.
pub const FLOOR_TARGET: f64 = 1.2;

/// The largest normalised attitude error of a cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Worst {
    /// `|error / sigma|`.
    pub z: f64,
    /// The member.
    pub member: u64,
    /// Its window [s].
    pub window_s: f64,
    /// 0 roll, 1 pitch, 2 heading.
    pub axis: usize,
}

/// Statistics of a set of cases (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cell {
    /// Cases.
    pub runs: usize,
    /// `ALIGNED` cases.
    pub aligned: usize,
    /// Refusals by reason.
    pub refused: BTreeMap<String, usize>,
    /// `ALIGNED` cases with a note, by note.
    pub noted: BTreeMap<String, usize>,
    /// Aligned cases with an attitude axis beyond [`ATTITUDE_SIGMAS`].
    pub beyond: usize,
    /// Those cases, each at its worst axis.
    pub outliers: Vec<Worst>,
    /// The largest `|error / sigma|` of attitude.
    pub worst: Option<Worst>,
    /// Sum of `(error / sigma)^2`, roll, pitch, heading.
    pub z2: Vector3<f64>,
    /// Aligned cases in the floor columns.
    pub floor_n: usize,
    /// Sum of squared heading errors there [rad^2].
    pub heading2: f64,
    /// Sum of squared floors [rad^2].
    pub floor2: f64,
    /// Sum of `(error / floor)^2`.
    pub error_floor2: f64,
    /// Sum of `(sigma / floor)^2`.
    pub sigma_floor2: f64,
    /// Still members in the floor columns, and their sum of `(error / floor)^2` (the floor is
    /// the noise's and the biases' only; a swaying base's translation adds to it).
    pub still_floor: (usize, f64),
    /// Aligned cases with a velocity axis beyond [`HANDOVER_SIGMAS`].
    pub v_beyond: usize,
    /// Sum of `(velocity error / sigma)^2`, NED.
    pub v_z2: Vector3<f64>,
    /// Aligned cases with a position axis beyond [`HANDOVER_SIGMAS`].
    pub p_beyond: usize,
    /// Sum of `(position error / sigma)^2`, NED.
    pub p_z2: Vector3<f64>,
}

impl Cell {
    /// Adds `case` of `run`.
    pub fn add(&mut self, run: &MemberRun, case: &Case) {
        self.runs += 1;
        let a = match &case.outcome {
            Outcome::Refused(why) => {
                *self.refused.entry(why.clone()).or_default() += 1;
                return;
            }
            Outcome::Aligned(a) => a,
        };
        self.aligned += 1;
        if let Some(note) = a.note {
            *self.noted.entry(note.reason().to_string()).or_default() += 1;
        }
        let z = a.attitude_z();
        if z.amax() > ATTITUDE_SIGMAS || z.iter().any(|v| v.is_nan()) {
            self.beyond += 1;
            let axis = (0..3)
                .max_by(|&i, &j| z[i].abs().total_cmp(&z[j].abs()))
                .unwrap_or(0);
            self.outliers.push(Worst {
                z: z[axis].abs(),
                member: run.member.index,
                window_s: case.window_s,
                axis,
            });
        }
        for (axis, v) in z.iter().enumerate() {
            if self.worst.is_none_or(|w| v.abs() > w.z) {
                self.worst = Some(Worst {
                    z: v.abs(),
                    member: run.member.index,
                    window_s: case.window_s,
                    axis,
                });
            }
        }
        self.z2 += z.map(|v| v * v);
        let floor = run.floor_at(case.window_s);
        if floor <= FLOOR_CAP_DEG.to_radians() {
            self.floor_n += 1;
            let (e, s) = (a.error_rad.z, a.sigma_rad.z);
            self.heading2 += e * e;
            self.floor2 += floor * floor;
            self.error_floor2 += (e / floor).powi(2);
            self.sigma_floor2 += (s / floor).powi(2);
            if run.member.still {
                self.still_floor.0 += 1;
                self.still_floor.1 += (e / floor).powi(2);
            }
        }
        let (vz, pz) = (a.velocity_z(), a.position_z());
        self.v_beyond += usize::from(vz.amax() > HANDOVER_SIGMAS);
        self.p_beyond += usize::from(pz.amax() > HANDOVER_SIGMAS);
        self.v_z2 += vz.map(|v| v * v);
        self.p_z2 += pz.map(|v| v * v);
    }

    /// RMS of attitude `error / sigma`, roll, pitch, heading (NaN without results).
    pub fn rms_z(&self) -> Vector3<f64> {
        rms3(&self.z2, self.aligned)
    }

    /// RMS of velocity `error / sigma`, NED.
    pub fn rms_v_z(&self) -> Vector3<f64> {
        rms3(&self.v_z2, self.aligned)
    }

    /// RMS of position `error / sigma`, NED.
    pub fn rms_p_z(&self) -> Vector3<f64> {
        rms3(&self.p_z2, self.aligned)
    }

    /// `(RMS heading error, RMS floor, RMS error/floor, RMS sigma/floor)` over the floor
    /// columns' members ([rad], [rad], -, -).
    pub fn floor_columns(&self) -> [f64; 4] {
        let n = self.floor_n as f64;
        [
            self.heading2,
            self.floor2,
            self.error_floor2,
            self.sigma_floor2,
        ]
        .map(|s| (s / n).sqrt())
    }

    /// RMS of `error / floor` over the still members and over the swaying ones (NaN without).
    pub fn error_floor_by_base(&self) -> [f64; 2] {
        let (n, sum) = self.still_floor;
        let rest = self.floor_n - n;
        [
            (sum / n as f64).sqrt(),
            ((self.error_floor2 - sum).max(0.0) / rest as f64).sqrt(),
        ]
    }

    /// Refused cases.
    pub fn refusals(&self) -> usize {
        self.refused.values().sum()
    }
}

fn rms3(sum: &Vector3<f64>, n: usize) -> Vector3<f64> {
    sum.map(|s| (s / n as f64).sqrt())
}

/// Everything the tables show.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The family's seed.
    pub family_seed: u64,
    /// The members run, in order.
    pub members: Vec<u64>,
    /// The windows [s], increasing.
    pub windows_s: Vec<f64>,
    /// Members per category, in [`category_key`] order.
    pub categories: Vec<(Category, usize)>,
    /// Per method, lever case and window (`None`: all windows).
    pub cells: Vec<(AlignMethod, LeverCase, Option<f64>, Cell)>,
    /// Per method, lever case and category, all windows.
    pub by_category: Vec<(AlignMethod, LeverCase, Category, Cell)>,
    /// What was switched off in every member (diagnosis; empty: the members as drawn).
    pub ablations: Vec<Ablation>,
}

impl Summary {
    /// The cell of `method`, `lever` and `window_s` (`None`: all windows), if run.
    pub fn cell(
        &self,
        method: AlignMethod,
        lever: LeverCase,
        window_s: Option<f64>,
    ) -> Option<&Cell> {
        self.cells
            .iter()
            .find(|c| c.0 == method && c.1 == lever && c.2 == window_s)
            .map(|c| &c.3)
    }
}

/// Sort key of a category: still first, then fog, rlg, mems-tactical, then without biases
/// first.
pub fn category_key(c: &Category) -> (u8, u8, u8) {
    let grade = match c.grade {
        Grade::Fog => 0,
        Grade::Rlg => 1,
        _ => 2,
    };
    (u8::from(!c.still), grade, u8::from(c.biases))
}

/// The statistics of `runs` of family `family_seed`.
pub fn summarize(family_seed: u64, runs: &[MemberRun]) -> Summary {
    let mut windows_s: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.cases.iter().map(|c| c.window_s))
        .collect();
    windows_s.sort_by(f64::total_cmp);
    windows_s.dedup();
    let mut counts: BTreeMap<(u8, u8, u8), (Category, usize)> = BTreeMap::new();
    for r in runs {
        let c = r.member.category();
        counts.entry(category_key(&c)).or_insert((c, 0)).1 += 1;
    }
    let categories: Vec<(Category, usize)> = counts.into_values().collect();
    let mut cells = Vec::new();
    let mut by_category = Vec::new();
    for method in AlignMethod::ALL {
        for lever in LeverCase::ALL {
            let select = |window: Option<f64>, cat: Option<Category>| {
                let mut cell = Cell::default();
                for r in runs {
                    if cat.is_some_and(|c| c != r.member.category()) {
                        continue;
                    }
                    for c in &r.cases {
                        if c.method == method
                            && c.lever == lever
                            && window.is_none_or(|w| w == c.window_s)
                        {
                            cell.add(r, c);
                        }
                    }
                }
                cell
            };
            for &w in &windows_s {
                cells.push((method, lever, Some(w), select(Some(w), None)));
            }
            cells.push((method, lever, None, select(None, None)));
            for (cat, _) in &categories {
                by_category.push((method, lever, *cat, select(None, Some(*cat))));
            }
        }
    }
    Summary {
        family_seed,
        members: runs.iter().map(|r| r.member.index).collect(),
        windows_s,
        categories,
        cells,
        by_category,
        ablations: runs
            .first()
            .map(|r| r.member.ablations.clone())
            .unwrap_or_default(),
    }
}

const AXES: [&str; 3] = ["roll", "pitch", "head"];

/// `v` with `prec` decimals, right-aligned in `width`; `-` for NaN (no results).
fn f(v: f64, width: usize, prec: usize) -> String {
    if v.is_nan() {
        format!("{:>width$}", "-")
    } else {
        format!("{v:>width$.prec$}")
    }
}

/// A number from 1 for each key of the cells' `counts` (refusals or notes), in key order.
fn code_map(s: &Summary, counts: fn(&Cell) -> &BTreeMap<String, usize>) -> BTreeMap<String, usize> {
    let keys: BTreeSet<&String> = s.cells.iter().flat_map(|c| counts(&c.3).keys()).collect();
    keys.into_iter()
        .enumerate()
        .map(|(i, r)| (r.clone(), i + 1))
        .collect()
}

fn refusal_list(cell: &Cell, codes: &BTreeMap<String, usize>) -> String {
    let list: Vec<String> = cell
        .refused
        .iter()
        .map(|(r, n)| format!("R{} {n}", codes.get(r).copied().unwrap_or(0)))
        .collect();
    if list.is_empty() {
        "-".into()
    } else {
        list.join(", ")
    }
}

/// `"; N1 98, ..."` for the cell's notes, or nothing.
fn note_list(cell: &Cell, codes: &BTreeMap<String, usize>) -> String {
    cell.noted
        .iter()
        .map(|(r, n)| format!("; N{} {n}", codes.get(r).copied().unwrap_or(0)))
        .collect()
}

fn window_name(w: Option<f64>) -> String {
    w.map_or_else(|| "all".into(), |w| format!("{w:.0}"))
}

fn worst_text(cell: &Cell) -> String {
    cell.worst.map_or_else(
        || "-".into(),
        |w| {
            format!(
                "{:.1} (#{} {:.0}s {})",
                w.z, w.member, w.window_s, AXES[w.axis]
            )
        },
    )
}

/// The tables of `s` as text.
pub fn format_summary(s: &Summary) -> String {
    let mut out = String::new();
    let w = &mut out;
    let windows: Vec<String> = s.windows_s.iter().map(|w| format!("{w:.0}")).collect();
    let (first, last) = (
        s.members.first().copied().unwrap_or(0),
        s.members.last().copied().unwrap_or(0),
    );
    let _ = writeln!(
        w,
        "alignment family {}: {} members (#{first}..#{last}), windows {} s, {} Hz; every method, lever arm given and not",
        s.family_seed,
        s.members.len(),
        windows.join(", "),
        crate::trajectory::family::RATE_HZ
    );
    let cats: Vec<String> = s
        .categories
        .iter()
        .map(|(c, n)| format!("{c} {n}"))
        .collect();
    let _ = writeln!(w, "members: {}", cats.join(", "));
    if !s.ablations.is_empty() {
        let names: Vec<&str> = s.ablations.iter().map(|a| a.name()).collect();
        let _ = writeln!(
            w,
            "ablated in every member (diagnosis): {}",
            names.join(", ")
        );
    }
    let codes = code_map(s, |c| &c.refused);
    let note_codes = code_map(s, |c| &c.noted);

    let _ = writeln!(
        w,
        "\n1. attitude against the result's own 1-sigma: z = error / sigma (honest: RMS z 0.7-1.3 per axis, every |z| <= {ATTITUDE_SIGMAS})"
    );
    let _ = writeln!(
        w,
        "{:<8} {:<9} {:>6} {:>5} {:>5} {:>5}  {:<30} {:>8} {:>8} {:>8}  refused",
        "method",
        "lever",
        "T [s]",
        "runs",
        "algn",
        ">4sig",
        "worst |z| (member T axis)",
        "RMS z r",
        "p",
        "head"
    );
    for (m, l, win, c) in &s.cells {
        let z = c.rms_z();
        let _ = writeln!(
            w,
            "{:<8} {:<9} {:>6} {:>5} {:>5} {:>5}  {:<30} {} {} {}  {}",
            m.name(),
            l.name(),
            window_name(*win),
            c.runs,
            c.aligned,
            c.beyond,
            worst_text(c),
            f(z.x, 8, 2),
            f(z.y, 8, 2),
            f(z.z, 8, 2),
            refusal_list(c, &codes) + &note_list(c, &note_codes)
        );
    }

    let _ = writeln!(
        w,
        "\n2. heading against the floor (members with a floor below {FLOOR_CAP_DEG} deg; noise-only CRB, plus the bias share for members with biases); target for fine: RMS e/floor <= {FLOOR_TARGET}"
    );
    let _ = writeln!(
        w,
        "{:<8} {:<9} {:>6} {:>5} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "method",
        "lever",
        "T [s]",
        "n",
        "RMS e [deg]",
        "floor [deg]",
        "RMS e/floor",
        "RMS sig/flr",
        "still e/flr",
        "sway e/flr"
    );
    for (m, l, win, c) in s.cells.iter().filter(|c| c.2.is_some()) {
        let [e, fl, ef, sf] = c.floor_columns();
        let [still, sway] = c.error_floor_by_base();
        let _ = writeln!(
            w,
            "{:<8} {:<9} {:>6} {:>5} {} {} {} {} {} {}",
            m.name(),
            l.name(),
            window_name(*win),
            c.floor_n,
            f(e.to_degrees(), 12, 4),
            f(fl.to_degrees(), 12, 4),
            f(ef, 12, 2),
            f(sf, 12, 2),
            f(still, 12, 2),
            f(sway, 12, 2)
        );
    }

    let _ = writeln!(
        w,
        "\n3. hand-over at the window's end against the IMU's truth: velocity and position error / 1-sigma (honest: RMS 0.7-1.3, few beyond {HANDOVER_SIGMAS})"
    );
    let _ = writeln!(
        w,
        "{:<8} {:<9} {:>6} {:>5} {:>5} {:>8} {:>8} {:>8} {:>5} {:>8} {:>8} {:>8}",
        "method",
        "lever",
        "T [s]",
        "algn",
        "v>3s",
        "RMS zvN",
        "zvE",
        "zvD",
        "p>3s",
        "RMS zpN",
        "zpE",
        "zpD"
    );
    for (m, l, win, c) in &s.cells {
        let (v, p) = (c.rms_v_z(), c.rms_p_z());
        let _ = writeln!(
            w,
            "{:<8} {:<9} {:>6} {:>5} {:>5} {} {} {} {:>5} {} {} {}",
            m.name(),
            l.name(),
            window_name(*win),
            c.aligned,
            c.v_beyond,
            f(v.x, 8, 2),
            f(v.y, 8, 2),
            f(v.z, 8, 2),
            c.p_beyond,
            f(p.x, 8, 2),
            f(p.y, 8, 2),
            f(p.z, 8, 2)
        );
    }

    let _ = writeln!(
        w,
        "\n4. results beyond {ATTITUDE_SIGMAS} sigma (|z| #member window axis)"
    );
    for (m, l, _, c) in s.cells.iter().filter(|c| c.2.is_none()) {
        if c.outliers.is_empty() {
            continue;
        }
        let list: Vec<String> = c
            .outliers
            .iter()
            .map(|o| {
                format!(
                    "{:.1} #{} {:.0}s {}",
                    o.z, o.member, o.window_s, AXES[o.axis]
                )
            })
            .collect();
        let _ = writeln!(w, "{:<8} {:<9} {}", m.name(), l.name(), list.join("; "));
    }

    let _ = writeln!(w, "\n5. by kind of member, all windows");
    let _ = writeln!(
        w,
        "{:<8} {:<9} {:<24} {:>5} {:>5} {:>5} {:>8} {:>8} {:>8} {:>5} {:>5}  refused",
        "method",
        "lever",
        "members",
        "runs",
        "algn",
        ">4sig",
        "RMS z r",
        "p",
        "head",
        "v>3s",
        "p>3s"
    );
    for (m, l, cat, c) in &s.by_category {
        let z = c.rms_z();
        let _ = writeln!(
            w,
            "{:<8} {:<9} {:<24} {:>5} {:>5} {:>5} {} {} {} {:>5} {:>5}  {}",
            m.name(),
            l.name(),
            cat.to_string(),
            c.runs,
            c.aligned,
            c.beyond,
            f(z.x, 8, 2),
            f(z.y, 8, 2),
            f(z.z, 8, 2),
            c.v_beyond,
            c.p_beyond,
            refusal_list(c, &codes)
        );
    }
    let _ = writeln!(w, "\nrefusal reasons:");
    for (r, code) in &codes {
        let _ = writeln!(w, "  R{code}: {r}");
    }
    if !note_codes.is_empty() {
        let _ = writeln!(
            w,
            "notes (ALIGNED with one, in table 1 after the refusals):"
        );
        for (r, code) in &note_codes {
            let _ = writeln!(w, "  N{code}: {r}");
        }
    }
    out
}

/// One member's values and every case's numbers, for debugging.
pub fn format_member(run: &MemberRun) -> String {
    let m: &FamilyMember = &run.member;
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(
        w,
        "member #{} of family {}: {}",
        m.index,
        m.family_seed,
        m.category()
    );
    out.push_str(&m.describe());
    let w = &mut out;
    for (t, f) in &run.floors {
        let _ = writeln!(w, "heading floor at {t:.0} s: {:.4} deg", f.to_degrees());
    }
    let _ = writeln!(
        w,
        "\nerrors [deg] / 1-sigma [deg] (z) roll, pitch, heading; hand-over velocity [m/s] and position [m] error (z) N, E, D"
    );
    for c in &run.cases {
        let head = format!(
            "{:>4.0} s {:<8} lever {:<9}",
            c.window_s,
            c.method.name(),
            c.lever.name()
        );
        match &c.outcome {
            Outcome::Refused(why) => {
                let _ = writeln!(w, "{head} REFUSED: {why}");
            }
            Outcome::Aligned(a) => {
                let _ = writeln!(w, "{head} {}", aligned_text(a));
            }
        }
    }
    out
}

fn aligned_text(a: &Aligned) -> String {
    let z = a.attitude_z();
    let (vz, pz) = (a.velocity_z(), a.position_z());
    let att: Vec<String> = (0..3)
        .map(|i| {
            format!(
                "{:+.4}/{:.4} ({:+.1})",
                a.error_rad[i].to_degrees(),
                a.sigma_rad[i].to_degrees(),
                z[i]
            )
        })
        .collect();
    let vec3 = |e: &Vector3<f64>, z: &Vector3<f64>| {
        (0..3)
            .map(|i| format!("{:+.3} ({:+.1})", e[i], z[i]))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let note = a.note.map(|n| format!(" | {n}")).unwrap_or_default();
    format!(
        "{} | v {} | p {}{note}",
        att.join(" "),
        vec3(&a.v_error_m_s, &vz),
        vec3(&a.p_error_m, &pz)
    )
}
