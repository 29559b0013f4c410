//! The GNSS-aided run: IMU samples and GNSS fixes through nav-core's sequencer
//! ([`nav_core::ins_filter::sequencer`]), one solution row per logged sample with its 1-sigma
//! and the filter's status.
//!
//! Every navigation rule (the fix timing, the start, the gate, the status) is nav-core's; this
//! module converts the file types, feeds fixes ahead of the samples they belong to, and writes
//! rows.

use crate::aided_cmd::SensorEstimate;
use crate::gnss::GnssFix;
use anyhow::{Result, anyhow};
use hal_adapters::{Imu, ImuSample, SampleFlags};
use nav_core::ins_filter::latency::LatencyEstimate;
use nav_core::ins_filter::sequencer::{
    FixCounters, GnssFixInput, Phase, Realignments, Sequencer, Start,
};
use nav_core::ins_filter::{
    AidResult, AidedIns, Clipped, FilterCounters, GnssPosition, GnssVelocity, POS, VEL,
};
use nav_core::navigator::config::{MAX_HEIGHT_M, MIN_HEIGHT_M};
use nav_core::output::CSV_HEADER;
use nav_core::{ImuIncrement, InputError, Scalar, Solution, Vector3};
use std::fmt;

/// The columns the aided solution adds to [`CSV_HEADER`]: 1-sigma of position [m], velocity
/// [m/s], roll, pitch, yaw [deg], and the status (`NAV` or `DEGRADED`).
pub const SIGMA_COLUMNS: &str = "sigma_n_m,sigma_e_m,sigma_d_m,sigma_vn_mps,sigma_ve_mps,\
sigma_vd_mps,sigma_roll_deg,sigma_pitch_deg,sigma_yaw_deg,status";

/// The aided solution log's header.
pub fn header() -> String {
    format!("{CSV_HEADER},{SIGMA_COLUMNS}")
}

/// One aided solution row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AidedRow {
    /// The solution.
    pub solution: Solution,
    /// 1-sigma of position north, east, down [m].
    pub sigma_pos_m: [f64; 3],
    /// 1-sigma of velocity north, east, down [m/s].
    pub sigma_vel_m_s: [f64; 3],
    /// 1-sigma of roll, pitch, yaw [deg].
    pub sigma_att_deg: [f64; 3],
    /// The filter's status name.
    pub status: &'static str,
}

impl AidedRow {
    /// The row of the filter's state at `t_us`.
    pub fn of<T: Scalar>(t_us: u64, ins: &AidedIns<T>) -> Self {
        let wide = |v: Vector3<T>| [v.x, v.y, v.z].map(T::to_f64);
        Self {
            solution: Solution::from_state(t_us, ins.state()),
            sigma_pos_m: wide(ins.sigma(POS)),
            sigma_vel_m_s: wide(ins.sigma(VEL)),
            sigma_att_deg: wide(ins.attitude_sigma_rad()).map(f64::to_degrees),
            status: ins.status().name(),
        }
    }
}

impl fmt::Display for AidedRow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.solution)?;
        for v in self
            .sigma_pos_m
            .iter()
            .chain(&self.sigma_vel_m_s)
            .chain(&self.sigma_att_deg)
        {
            write!(f, ",{v}")?;
        }
        write!(f, ",{}", self.status)
    }
}

/// nav-core's fix of a file's, on the IMU clock (`t_s` seconds -> microseconds); `None` for a
/// time tag that is not a time on that clock (negative or not finite).
pub fn fix_input<T: Scalar>(f: &GnssFix) -> Option<GnssFixInput<T>> {
    if !(f.t_s.is_finite() && f.t_s >= 0.0 && f.t_s < 1e12) {
        return None;
    }
    let v3 = |a: [f64; 3]| Vector3::new(T::c(a[0]), T::c(a[1]), T::c(a[2]));
    Some(GnssFixInput {
        t_us: (f.t_s * 1e6).round() as u64,
        position: GnssPosition {
            lat_rad: f.lat_rad,
            lon_rad: f.lon_rad,
            h_m: f.h_m,
            sigma_ned_m: v3(f.sigma_ned_m),
        },
        velocity: f.velocity.map(|v| GnssVelocity {
            v_ned_m_s: v3(v.v_ned_m_s),
            sigma_ned_m_s: v3(v.sigma_ned_m_s),
        }),
    })
}

/// One GNSS update's record, for the consistency statistics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateRecord {
    /// Time of the fix [s].
    pub t_s: f64,
    /// The position update's outcome.
    pub position: AidResult<f64>,
    /// The velocity update's outcome, when the fix had a velocity.
    pub velocity: Option<AidResult<f64>>,
}

/// IMU time not covered by a navigated sample: the time between a navigated sample and the
/// next one that its interval does not cover (samples lost, unusable or refused between them),
/// measured as `nav_core::gap::GapDetector` measures the gaps the navigation bridges: from the
/// last navigated sample, so that a time tag gone backwards (an unusable sample) loses nothing
/// and the samples after it are not taken for a gap. The navigation bridges them
/// (`nav_core::gap`: the rates either side, the filter's 1-sigma widened, a span beyond
/// [`nav_core::gap::MAX_BRIDGED_S`] lost); this is the data's account of them for the terminal.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LostImuTime {
    /// Spans lost (a run of consecutive unnavigated samples is one).
    pub gaps: u32,
    /// Their sum [s].
    pub total_s: f64,
    /// Those beyond [`nav_core::gap::MAX_BRIDGED_S`] (not bridged: the solution lost).
    pub unbridged: u32,
    /// The longest [s] and the time it ended [s].
    pub longest_s: f64,
    /// End of the longest [s].
    pub longest_end_s: f64,
    /// The first sample's end [us].
    first_us: Option<u64>,
    /// The last navigated sample's end [us].
    navigated_us: Option<u64>,
    /// The latest end of a sample seen since the last navigated one (or the first) [us].
    latest_us: Option<u64>,
    /// Spans that ended before navigation started, on a sample the alignment or the start in
    /// motion took (not in [`Self::gaps`]: no solution to lose yet; the alignment takes them
    /// or fails naming the gap, the start in motion begins again after them).
    pub alignment_gaps: u32,
    /// Their sum [s].
    pub alignment_s: f64,
    /// The samples noted come before navigation ([`Self::set_aligning`]).
    aligning: bool,
    /// Intervals of the samples the navigation skipped as out of time order since the last
    /// navigated one [s] ([`Self::out_of_order`]).
    skipped_s: f64,
    /// The data's end not navigated ([`Self::finish`]): its length [s] and the last navigated
    /// sample's time [s] (nothing follows it to bridge to: not in [`Self::gaps`]).
    pub tail: Option<(f64, f64)>,
    /// The largest step back of the time tags (a sample's end before the last navigated
    /// one's) [s], and the time it stepped back to [s].
    pub step_back: Option<(f64, f64)>,
}

/// A lost span shorter than this is not reported [s] (rounding of the time tags).
const LOST_TOLERANCE_S: f64 = 1e-4;

/// A GPS week [s]: time tags in seconds of week step back by it at a rollover.
const GPS_WEEK_S: f64 = 604_800.0;

impl LostImuTime {
    /// One sample ending at `t_us` [us]: navigated over `navigated_dt_s` [s], or not (`None`).
    pub fn note(&mut self, t_us: u64, navigated_dt_s: Option<f64>) {
        let first = *self.first_us.get_or_insert(t_us);
        let Some(dt_s) = navigated_dt_s else {
            self.latest_us = Some(self.latest_us.map_or(t_us, |l| l.max(t_us)));
            if let Some(navigated_us) = self.navigated_us
                && t_us < navigated_us
            {
                let back_s = (navigated_us - t_us) as f64 * 1e-6;
                if self.step_back.is_none_or(|(b, _)| back_s > b) {
                    self.step_back = Some((back_s, t_us as f64 * 1e-6));
                }
            }
            return;
        };
        self.latest_us = Some(t_us);
        let from = self.navigated_us.replace(t_us).unwrap_or(first);
        let skipped_s = std::mem::take(&mut self.skipped_s);
        let lost_s = (t_us.saturating_sub(from) as f64 * 1e-6 - dt_s).max(skipped_s);
        // Within half the sample's interval: time-tag jitter (the gap detector's rule).
        if lost_s > (0.5 * dt_s).max(LOST_TOLERANCE_S) {
            self.add(lost_s, t_us);
        }
    }

    /// A sample the navigation skipped as out of time order (`nav_core::gap`: a clock that
    /// stepped back), of interval `dt_s` [s]: the time it covered is lost, though its tag
    /// does not show it.
    pub fn out_of_order(&mut self, dt_s: f64) {
        self.skipped_s += dt_s;
    }

    /// The samples noted from now on come before navigation (`true`: the alignment's or the
    /// start in motion's), or are navigated.
    pub fn set_aligning(&mut self, aligning: bool) {
        self.aligning = aligning;
    }

    fn add(&mut self, lost_s: f64, end_us: u64) {
        if self.aligning {
            self.alignment_gaps += 1;
            self.alignment_s += lost_s;
            return;
        }
        self.gaps += 1;
        self.total_s += lost_s;
        if lost_s > nav_core::gap::MAX_BRIDGED_S {
            self.unbridged += 1;
        }
        if lost_s > self.longest_s {
            self.longest_s = lost_s;
            self.longest_end_s = end_us as f64 * 1e-6;
        }
    }

    /// Ends the data: the samples after the last navigated one, if any, were not navigated;
    /// before navigation started, a gap the alignment took, after it, the solution's end
    /// ([`Self::tail`]).
    pub fn finish(&mut self) {
        let (Some(first), Some(latest)) = (self.first_us, self.latest_us) else {
            return;
        };
        let navigated = self.navigated_us.take();
        let from = navigated.unwrap_or(first);
        let skipped_s = std::mem::take(&mut self.skipped_s);
        let lost_s = (latest.saturating_sub(from) as f64 * 1e-6).max(skipped_s);
        if lost_s <= LOST_TOLERANCE_S {
            return;
        }
        match navigated {
            Some(from_us) if !self.aligning => self.tail = Some((lost_s, from_us as f64 * 1e-6)),
            _ => self.add(lost_s, latest),
        }
    }

    /// The warnings for the terminal, when time was lost.
    pub fn warning(&self) -> Option<String> {
        let aligning = (self.alignment_gaps > 0).then(|| {
            format!(
                "WARNING: {:.3} s of IMU data missing in {} gap(s) before navigation started \
                 (the alignment or the start in motion took them): no solution was lost",
                self.alignment_s, self.alignment_gaps
            )
        });
        let tail = self.tail.map(|(lost_s, from_s)| {
            format!(
                "WARNING: the last {lost_s:.3} s of IMU data were not navigated (samples \
                 unusable, refused by the input limits or out of time order): the solution \
                 ends at t = {from_s:.3} s"
            )
        });
        // Was only "the last 30 s were not navigated", no word of why.
        let rollover = self.week_rollover().map(|r| format!("WARNING: {r}"));
        let lines: Vec<String> = [aligning, self.navigation_warning(), tail, rollover]
            .into_iter()
            .flatten()
            .collect();
        (!lines.is_empty()).then(|| lines.join("\n"))
    }

    /// The largest step back of the time tags told as a GPS week rollover, when it is within
    /// a second of a week (seconds of week restarting at 0).
    pub fn week_rollover(&self) -> Option<String> {
        self.step_back
            .filter(|(back_s, _)| (back_s - GPS_WEEK_S).abs() < 1.0)
            .map(|(back_s, to_s)| {
                format!(
                    "the time tags stepped back by {back_s:.3} s (to t = {to_s:.3} s): a GPS \
                     week rollover (seconds of week restarting at 0)? The samples after it are \
                     out of time order; give the times on one clock (add {GPS_WEEK_S} s after \
                     the rollover)"
                )
            })
    }

    /// `e` (a refusal of the run) followed by the GPS week rollover of the IMU time tags, when
    /// they had one ([`Self::week_rollover`]): a run refused as "GNSS on another clock" with
    /// the IMU data covering "604770 .. 30 s" said nothing of it.
    pub fn explain(&self, e: anyhow::Error) -> anyhow::Error {
        match self.week_rollover() {
            Some(r) => anyhow!("{e:#}; in the IMU data, {r}"),
            None => e,
        }
    }

    /// The warning for time lost while navigating.
    fn navigation_warning(&self) -> Option<String> {
        (self.gaps > 0).then(|| {
            format!(
                "WARNING: {:.3} s of IMU data missing in {} gap(s) (the longest {:.3} s, ending \
                 at t = {:.3} s): {}",
                self.total_s,
                self.gaps,
                self.longest_s,
                self.longest_end_s,
                if self.longest_s <= nav_core::gap::MAX_BRIDGED_S {
                    format!(
                        "bridged with the rates either side (an aided run's 1-sigma widened for \
                         the motion a gap may hide; up to {} s are bridged)",
                        nav_core::gap::MAX_BRIDGED_S
                    )
                } else {
                    format!(
                        "a gap beyond {} s is not bridged: the solution is lost from there (an \
                         aided run's status DEGRADED, its position carried across the gap at the \
                         velocity before it, its 1-sigma widened for the motion the gap hid)",
                        nav_core::gap::MAX_BRIDGED_S
                    )
                }
            )
        })
    }
}

/// What an aided run did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AidedReport {
    /// Samples read.
    pub samples: u64,
    /// Samples skipped as unusable (their flags).
    pub flagged: u64,
    /// Increments refused by nav-core's limits.
    pub rejected: u64,
    /// Samples whose time is not after the last navigated one's (`nav_core::gap`) or the
    /// previous one's ([`AidedSample::behind`]), skipped.
    pub out_of_order: u64,
    /// Fixes whose time tag is not on the IMU clock.
    pub bad_time_tags: u64,
    /// Fixes before the first sample or after the last.
    pub outside_imu_data: u64,
    /// Time of the first filter sample [s] (`None`: the start in motion never completed).
    pub start_s: Option<f64>,
    /// The filter's aid counters.
    pub counters: FilterCounters,
    /// The sequencer's fix counters.
    pub fixes: FixCounters,
    /// Covariance faults.
    pub covariance_faults: u32,
    /// Every update's outcome.
    pub updates: Vec<UpdateRecord>,
    /// IMU time not navigated.
    pub lost: LostImuTime,
    /// Re-alignments in motion after gaps in the IMU data too long to bridge (no rows while
    /// one runs).
    pub realignments: Realignments,
    /// The first sample at which the filter found itself so near a pole that its NED error
    /// model does not hold (`nav_core::ins_filter::model::near_pole`): its time [s] and
    /// latitude [deg]; DEGRADED from there on.
    pub near_pole: Option<(f64, f64)>,
    /// The attitude a start in motion took (`None` for a given start).
    pub motion_start: Option<MotionStartAttitude>,
    /// The test of the fixes' time tags at the end (`nav_core::ins_filter::latency`; `None`
    /// when no filter ran).
    pub gnss_latency: Option<LatencyEstimate<f64>>,
    /// When the fixes were first found lagging their time tags [s] (status DEGRADED).
    pub gnss_late_at_s: Option<f64>,
    /// The solution log's rows by status (counted by the writer of the rows).
    pub status: StatusTally,
    /// The learnt scales of the fixes' declared noise at the end
    /// (`nav_core::ins_filter::noise_scale`; `None` when no filter ran): position and
    /// velocity, now and their largest [-].
    pub noise_scales: Option<[[f64; 2]; 2]>,
    /// The sensor errors estimated by the end (`None` when no filter ran).
    pub sensors: Option<SensorEstimate>,
}

/// The attitude the filter started with in motion, as its user is told it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionStartAttitude {
    /// Roll, pitch, yaw [deg].
    pub euler_deg: [f64; 3],
    /// Their 1-sigma [deg].
    pub sigma_deg: [f64; 3],
    /// The heading against the track of the start's velocity (a vehicle moving backwards).
    pub backwards: bool,
}

impl MotionStartAttitude {
    /// The start of `ins`.
    fn of<T: Scalar>(ins: &AidedIns<T>) -> Self {
        let (r, p, y) = ins.state().euler();
        let v = ins.state().v_eb_n.map(T::to_f64);
        let track = v.y.atan2(v.x);
        let off = (y.to_f64() - track).sin_cos();
        Self {
            euler_deg: [r, p, y].map(|a| a.to_f64().to_degrees()),
            sigma_deg: ins
                .attitude_sigma_rad()
                .map(T::to_f64)
                .map(f64::to_degrees)
                .into(),
            backwards: off.1 < 0.0,
        }
    }

    /// The line of the run's summary: where the heading came from, and the level.
    pub fn line(&self, t_s: f64) -> String {
        let [r, p, y] = self.euler_deg;
        let [sr, sp, sy] = self.sigma_deg;
        let along = if self.backwards {
            "against the GNSS track (moving backwards: the accelerometers felt it)"
        } else {
            "along the GNSS track"
        };
        format!(
            "filter started at t = {t_s:.3} s, in motion: heading {y:.1} deg (1-sigma {sy:.1}) \
             {along}, roll {r:.1} deg (1-sigma {sr:.1}), pitch {p:.1} deg (1-sigma {sp:.1}) \
             from the accelerometers"
        )
    }
}

fn wide(r: &AidResult<impl Scalar>) -> AidResult<f64> {
    match *r {
        AidResult::Accepted { nis } => AidResult::Accepted { nis: nis.to_f64() },
        AidResult::Rejected { nis } => AidResult::Rejected { nis: nis.to_f64() },
        AidResult::Invalid => AidResult::Invalid,
    }
}

/// One IMU sample as the aided run takes it: end time [us], increment, and whether it is
/// unusable or follows a gap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AidedSample<T: Scalar> {
    /// End of the interval [us].
    pub t_us: u64,
    /// The increment.
    pub increment: ImuIncrement<T>,
    /// Not usable (its source's flags).
    pub unusable: bool,
    /// Of the unusable: its time is not after the previous sample's (the source's bad
    /// interval of no length), counted out of time order.
    pub behind: bool,
    /// A gap precedes it.
    pub gap: bool,
    /// Axes at full scale (its source's flags).
    pub clipped: Clipped,
}

/// The aided run's sample of a replay source's sample.
pub fn sample_of<T: Scalar>(s: &ImuSample) -> AidedSample<T> {
    let (d_theta, d_v) = s.increments();
    AidedSample {
        t_us: s.t_us,
        increment: ImuIncrement::new(
            d_theta.map(T::of_f32),
            d_v.map(T::of_f32),
            T::of_f32(s.dt_s),
        ),
        unusable: s.flags.unusable_cause().is_some(),
        behind: s.flags.unusable_cause() == Some(SampleFlags::BAD_INTERVAL) && s.dt_s <= 0.0,
        gap: s.flags.contains(SampleFlags::GAP),
        clipped: s.flags.clipped(),
    }
}

/// Where an aided run's filter samples go.
pub trait AidedSink<T: Scalar> {
    /// Every sample the filter integrated, at its end time `t_us` [us].
    fn sample(&mut self, t_us: u64, ins: &AidedIns<T>) -> Result<()>;
    /// After a sample at which fixes were applied (called before [`Self::sample`]).
    fn updated(&mut self, _t_us: u64, _ins: &AidedIns<T>) {}
    /// The run ended normally.
    fn finish(&mut self) -> Result<()> {
        Ok(())
    }
}

/// The solution log's rows by status, for the summary: how many said DEGRADED of how many,
/// and the first and last of them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StatusTally {
    /// Rows written.
    pub rows: u64,
    /// Of those, rows whose status was DEGRADED.
    pub degraded: u64,
    /// Times of the first and the last DEGRADED row [s].
    pub degraded_span_s: Option<(f64, f64)>,
}

impl StatusTally {
    /// Counts a row at `t_s` [s] of status `status` (a status name).
    pub fn add(&mut self, t_s: f64, status: &str) {
        self.rows += 1;
        if status == "DEGRADED" {
            self.degraded += 1;
            let first = self.degraded_span_s.map_or(t_s, |(a, _)| a);
            self.degraded_span_s = Some((first, t_s));
        }
    }

    /// The summary's line: the rows that said DEGRADED (an aided run's status column), or
    /// that none did; `None` without rows counted.
    pub fn line(&self) -> Option<String> {
        (self.rows > 0).then(|| match self.degraded_span_s {
            Some((a, b)) => format!(
                "status: DEGRADED on {} of {} rows, the first at t = {a:.3} s, the last at t = \
                 {b:.3} s",
                self.degraded, self.rows
            ),
            None => format!("status: NAV on all {} rows", self.rows),
        })
    }
}

/// The solution log's rows: every `log_every`-th filter sample and the last one.
pub struct CsvRows<F> {
    log_every: u32,
    since_log: u32,
    pending: Option<AidedRow>,
    rows: u64,
    write: F,
}

impl<F: FnMut(&AidedRow) -> Result<()>> CsvRows<F> {
    /// Rows to `write`, every `log_every`-th sample (the first one included).
    pub fn new(log_every: u32, write: F) -> Self {
        Self {
            log_every: log_every.max(1),
            since_log: log_every.max(1) - 1,
            pending: None,
            rows: 0,
            write,
        }
    }

    /// Rows written.
    pub fn rows(&self) -> u64 {
        self.rows
    }
}

impl<T: Scalar, F: FnMut(&AidedRow) -> Result<()>> AidedSink<T> for CsvRows<F> {
    fn sample(&mut self, t_us: u64, ins: &AidedIns<T>) -> Result<()> {
        self.since_log += 1;
        if self.since_log >= self.log_every {
            self.since_log = 0;
            self.pending = None;
            self.rows += 1;
            (self.write)(&AidedRow::of(t_us, ins))
        } else {
            self.pending = Some(AidedRow::of(t_us, ins));
            Ok(())
        }
    }

    fn finish(&mut self) -> Result<()> {
        if let Some(row) = self.pending.take() {
            self.rows += 1;
            (self.write)(&row)?;
        }
        Ok(())
    }
}

/// Refuses a run in which not one GNSS fix lies within the IMU data's time span
/// `imu_span_us` ([`nav_core::gap::data_span_us`]; `None`: no sample): the run would be
/// free-inertial while looking aided. Far from the data, the two files' time tags are on
/// different clocks ([`nav_core::gap::on_another_clock`]: GNSS seconds of week against a
/// recording that starts at 0, or milliseconds for seconds), and the message says so; near
/// it, it names the nearest fix. A file without fixes, or with some in the span, passes.
pub fn check_fixes_in_span(
    fix_times_s: impl IntoIterator<Item = f64>,
    imu_span_us: Option<(u64, u64)>,
) -> Result<()> {
    let times: Vec<f64> = fix_times_s.into_iter().collect();
    if times.is_empty() {
        return Ok(());
    }
    // The earliest and the latest (a receiver's log may repeat or swap epochs).
    let first = &times.iter().copied().fold(f64::INFINITY, f64::min);
    let last = &times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let Some((a_us, b_us)) = imu_span_us else {
        return Ok(());
    };
    let (a_s, b_s) = (a_us as f64 * 1e-6, b_us as f64 * 1e-6);
    if times.iter().any(|t| (a_s..=b_s).contains(t)) {
        return Ok(());
    }
    use nav_core::number::Number;
    let spans = format!(
        "the {} fixes are at {} .. {} s, the IMU data cover {} .. {} s",
        times.len(),
        Number(*first),
        Number(*last),
        Number(a_s),
        Number(b_s)
    );
    let to_us = |t: f64| crate::text_error::seconds_to_ns(t).map_or(u64::MAX, |ns| ns / 1000);
    if nav_core::gap::on_another_clock((to_us(*first), to_us(*last)), (a_us, b_us)) {
        return Err(anyhow!(
            "no GNSS fix within the IMU data's time span: {spans}: the GNSS time tags are on \
             another clock than the recording's (e.g. GNSS seconds of week against a recording \
             that starts at 0); give the fixes the recording's time"
        ));
    }
    let (nearest, how) = if *last < a_s {
        (*last, format!("{} s before", Number(a_s - last)))
    } else {
        (*first, format!("{} s after", Number(first - b_s)))
    };
    Err(anyhow!(
        "no GNSS fix within the IMU data's time span: {spans}; the nearest fix, at {} s, is {how} \
         it: the run would be free-inertial",
        Number(nearest)
    ))
}

/// Why a filter started from a given state never ran although samples came: their counts,
/// and the limits that refused them (increments given as rates, or in degrees, fail them).
pub fn no_usable_sample(r: &AidedReport) -> String {
    let limits = nav_core::InputLimits::<f64>::default();
    format!(
        "not one of the {} IMU samples was usable: {} flagged by the reader, {} refused by the \
         increment limits (an interval beyond {} s, a rate beyond {:.0} deg/s or a specific \
         force beyond {:.0} m/s^2: rates or degrees where increments in radians and m/s \
         belong?)",
        r.samples,
        r.flagged,
        r.rejected,
        limits.max_dt,
        limits.max_rate.to_degrees(),
        limits.max_specific_force
    )
}

/// Runs `samples` with `fixes` (in the file's order: one not later than the fix before it is
/// the sequencer's to skip and count) through `seq` into `sink`; refused when no fix lies
/// within the samples' time span ([`check_fixes_in_span`]).
pub fn run<T: Scalar, E: fmt::Display>(
    mut samples: impl FnMut() -> Result<Option<AidedSample<T>>, E>,
    fixes: &[GnssFix],
    mut seq: Sequencer<T>,
    sink: &mut impl AidedSink<T>,
) -> Result<AidedReport> {
    let mut report = AidedReport::default();
    // Converted once, not at every sample that waits for the fix.
    let inputs: Vec<Option<GnssFixInput<T>>> = fixes.iter().map(fix_input::<T>).collect();
    let mut next_fix = 0;
    let mut first = true;
    let mut span_us: Option<(u64, u64)> = None;
    while let Some(s) = samples().map_err(|e| anyhow!("{e}"))? {
        report.samples += 1;
        let first_us = || nav_core::gap::data_span_us(s.t_us, s.increment.dt.to_f64(), 0).0;
        span_us = Some((span_us.map_or_else(first_us, |(a, _)| a), s.t_us));
        // Fixes due at or before this sample go in first (held by the sequencer until it).
        while let Some(input) = inputs.get(next_fix) {
            let Some(input) = *input else {
                report.bad_time_tags += 1;
                next_fix += 1;
                continue;
            };
            if input.t_us > s.t_us {
                break;
            }
            next_fix += 1;
            if first {
                report.outside_imu_data += 1;
                continue;
            }
            seq.push_fix(input);
        }
        first = false;
        if s.unusable {
            // A time not after the previous sample's is out of time order (the README's
            // rule), as the navigation's own are below.
            if s.behind {
                report.out_of_order += 1;
            } else {
                report.flagged += 1;
            }
            report.lost.note(s.t_us, None);
            seq.restart_increments();
            continue;
        }
        if s.gap {
            seq.restart_increments();
        }
        let navigated = seq.on_sample_clipped(s.t_us, &s.increment, s.clipped);
        // Before the first start no solution exists to lose (a re-alignment has the lost one).
        report.lost.set_aligning(report.start_s.is_none());
        if navigated == Err(InputError::OutOfOrder) {
            report.out_of_order += 1;
            report.lost.out_of_order(s.increment.dt.to_f64());
            continue;
        }
        report
            .lost
            .note(s.t_us, navigated.is_ok().then(|| s.increment.dt.to_f64()));
        match navigated {
            Err(_) => {
                report.rejected += 1;
                continue;
            }
            // Starting in motion: nothing navigated, no row. Re-aligning after a lost gap:
            // the lost solution's rows go on, DEGRADED, as before the re-alignment began.
            Ok(Phase::Starting) => {
                if let Some(ins) = seq.lost_filter() {
                    sink.sample(s.t_us, ins)?;
                }
                continue;
            }
            Ok(Phase::Navigating) => {}
        }
        let mut updated = false;
        for (t_us, p, v) in seq.last_results() {
            updated = true;
            report.updates.push(UpdateRecord {
                t_s: *t_us as f64 * 1e-6,
                position: wide(p),
                velocity: v.as_ref().map(wide),
            });
        }
        let Some(ins) = seq.filter() else { continue };
        check_within_earth_model(ins, s.t_us)?;
        if report.start_s.is_none() {
            report.start_s = Some(s.t_us as f64 * 1e-6);
            if matches!(seq.start(), Start::Motion(_)) {
                report.motion_start = Some(MotionStartAttitude::of(ins));
            }
        }
        if report.near_pole.is_none() && ins.filter().near_pole() {
            let lat = ins.state().position.lat_f64().to_degrees();
            report.near_pole = Some((s.t_us as f64 * 1e-6, lat));
        }
        if updated && report.gnss_late_at_s.is_none() && ins.gnss_latency().detected {
            report.gnss_late_at_s = Some(s.t_us as f64 * 1e-6);
        }
        if updated {
            sink.updated(s.t_us, ins);
        }
        sink.sample(s.t_us, ins)?;
    }
    check_fixes_in_span(fixes.iter().map(|f| f.t_s), span_us)
        .map_err(|e| report.lost.explain(e))?;
    report.lost.finish();
    sink.finish()?;
    report.outside_imu_data += (fixes.len() - next_fix) as u64;
    // Re-aligning at the end: the lost filter set aside holds the run's counters.
    if let Some(ins) = seq.filter().or(seq.lost_filter()) {
        report.counters = *ins.counters();
        report.covariance_faults = ins.covariance_faults();
        report.gnss_latency = Some(ins.gnss_latency().cast());
        report.noise_scales = Some(ins.noise_scales().map(|a| a.map(T::to_f64)));
        report.sensors = Some(SensorEstimate::of(ins.sensor_errors(), |at| ins.sigma(at)));
    }
    report.fixes = *seq.fix_counters();
    report.realignments = *seq.realignments();
    Ok(report)
}

/// Refuses a solution whose height left the Earth model's range ([`MIN_HEIGHT_M`],
/// [`MAX_HEIGHT_M`]: a site's, as `nav replay` accepts one) at `t_us` [us]: no fix can bring
/// it back, and the rows after it are not a solution. A KF-GINS IMU file with its gyro and
/// accelerometer columns swapped ran to the end at -451 km (3 km/s down), exit 0.
fn check_within_earth_model<T: Scalar>(ins: &AidedIns<T>, t_us: u64) -> Result<()> {
    let h = ins.state().position.h_f64();
    if (MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&h) {
        return Ok(());
    }
    let p = &ins.counters().position;
    Err(anyhow!(
        "the solution diverged: height {:.0} m at t = {:.3} s, outside the Earth model's range \
         [{MIN_HEIGHT_M}, {MAX_HEIGHT_M}] m, with {} GNSS position fixes used and {} refused; \
         the IMU data (its columns: angle increments [rad] before velocity increments [m/s], \
         body front-right-down; their units), the start or the IMU noise do not match the \
         fixes",
        h,
        t_us as f64 * 1e-6,
        p.accepted,
        p.rejected
    ))
}

/// [`run`] over a replay source.
pub fn run_source<T: Scalar, S: Imu>(
    source: &mut S,
    fixes: &[GnssFix],
    seq: Sequencer<T>,
    sink: &mut impl AidedSink<T>,
) -> Result<AidedReport> {
    run(
        || source.read_sample().map(|s| s.map(|s| sample_of::<T>(&s))),
        fixes,
        seq,
        sink,
    )
}

#[cfg(test)]
mod tests {
    use super::{LostImuTime, StatusTally};

    /// The summary's status line: none without rows, the DEGRADED rows' count and span, or
    /// that every row said NAV.
    #[test]
    fn the_status_line_counts_the_degraded_rows() {
        let mut tally = StatusTally::default();
        assert_eq!(tally.line(), None);
        for (t_s, status) in [
            (1.0, "NAV"),
            (2.0, "DEGRADED"),
            (3.0, "NAV"),
            (4.5, "DEGRADED"),
        ] {
            tally.add(t_s, status);
        }
        assert_eq!(
            tally.line().unwrap(),
            "status: DEGRADED on 2 of 4 rows, the first at t = 2.000 s, the last at t = 4.500 s"
        );
        let mut nav = StatusTally::default();
        nav.add(1.0, "NAV");
        assert_eq!(nav.line().unwrap(), "status: NAV on all 1 rows");
    }

    const P_US: u64 = 2_500;
    const P_S: f64 = 0.0025;

    /// Notes samples `(t_us, navigated)`, each navigated one over one period.
    fn lost(samples: &[(u64, bool)]) -> LostImuTime {
        let mut l = LostImuTime::default();
        for &(t_us, navigated) in samples {
            l.note(t_us, navigated.then_some(P_S));
        }
        l.finish();
        l
    }

    /// One time tag 1 s back (unusable), and the next one unusable too (its interval from the
    /// tag gone back): two samples' time lost, as the navigation bridges it, not the second
    /// the tags spanned (was: 1.003 s reported missing and bridged).
    #[test]
    fn a_time_tag_gone_back_loses_only_its_samples() {
        let t = 100_000_000;
        let l = lost(&[
            (t, true),
            (t + P_US - 1_000_000, false),
            (t + 2 * P_US, false),
            (t + 3 * P_US, true),
            (t + 4 * P_US, true),
        ]);
        assert_eq!(l.gaps, 1, "{l:?}");
        assert!((l.total_s - 2.0 * P_S).abs() < 1e-9, "{l:?}");
    }

    /// A clock that stepped back 1 s for good: the first sample behind it unusable (the
    /// source's bad interval), the next 399 skipped by the navigation as out of time order
    /// (`nav_core::gap`), then the clock is past the last navigated sample again: the 399
    /// samples' intervals are lost though the tags show none. The same at the end of the
    /// data: lost at the finish.
    #[test]
    fn a_clock_stepped_back_loses_the_samples_the_navigation_skipped() {
        let t = 100_000_000;
        let mut l = LostImuTime::default();
        l.note(t, Some(P_S));
        l.note(t - 1_000_000 + P_US, None);
        for _ in 0..399 {
            l.out_of_order(P_S);
        }
        l.note(t + P_US, Some(P_S));
        l.finish();
        assert_eq!(l.gaps, 1, "{l:?}");
        assert!((l.total_s - 399.0 * P_S).abs() < 1e-9, "{l:?}");
        let mut l = LostImuTime::default();
        l.note(t, Some(P_S));
        for _ in 0..400 {
            l.out_of_order(P_S);
        }
        l.finish();
        assert_eq!(l.gaps, 0, "{l:?}");
        let (tail_s, from_s) = l.tail.unwrap();
        assert!((tail_s - 400.0 * P_S).abs() < 1e-9, "{l:?}");
        assert_eq!(from_s, t as f64 * 1e-6);
        let w = l.warning().unwrap();
        assert!(
            w.contains("the last 1.000 s of IMU data were not navigated"),
            "{w}"
        );
        assert!(w.contains("the solution ends at t = 100.000 s"), "{w}");
        assert!(!w.contains("bridged"), "{w}");
    }

    /// Time tags in seconds of week restarting at 0 (a GPS week rollover): the tail was "not
    /// navigated", no word of why; the step back is named as a rollover.
    #[test]
    fn a_step_back_of_a_week_is_named_a_rollover() {
        let t = 604_799_997_500;
        let mut l = LostImuTime::default();
        l.note(t, Some(P_S));
        l.note(0, None);
        for _ in 0..399 {
            l.out_of_order(P_S);
        }
        l.finish();
        let w = l.warning().unwrap();
        assert!(
            w.contains("the time tags stepped back by 604799.99")
                && w.contains("(to t = 0.000 s): a GPS week rollover"),
            "{w}"
        );
        // A step back of a minute is not one.
        let mut l = LostImuTime::default();
        l.note(t, Some(P_S));
        l.note(t - 60_000_000, None);
        l.finish();
        assert!(l.warning().is_none_or(|w| !w.contains("rollover")), "{l:?}");
    }

    /// A second of records missing, the first after it unusable; unusable samples at the start
    /// and at the end.
    #[test]
    fn lost_spans_are_counted_from_the_last_navigated_sample() {
        let l = lost(&[
            (0, true),
            (P_US, true),
            (1_000_000 + 2 * P_US, false),
            (1_000_000 + 3 * P_US, true),
        ]);
        assert_eq!(l.gaps, 1, "{l:?}");
        assert!((l.longest_s - (1.0 + P_S)).abs() < 1e-9, "{l:?}");
        assert!((l.longest_end_s - (1.0 + 3.0 * P_S)).abs() < 1e-9, "{l:?}");
        let l = lost(&[
            (0, false),
            (P_US, false),
            (2 * P_US, true),
            (3 * P_US, true),
            (4 * P_US, false),
        ]);
        assert_eq!(l.gaps, 1, "{l:?}");
        assert!((l.total_s - P_S).abs() < 1e-9, "{l:?}");
        assert_eq!(l.tail, Some((P_S, 3.0 * P_S)), "{l:?}");
        // Every sample on time: nothing.
        let l = lost(&[(0, true), (P_US, true), (2 * P_US, true)]);
        assert_eq!(l.gaps, 0, "{l:?}");
    }
}
