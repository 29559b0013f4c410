//! The navigator's foreground half: every sample through the gate, the calibration, the
//! alignment hand-over and the strapdown (or, in an aided run, the filter's mechanization and
//! the GNSS fixes' timing), with the counters and the logging cadence (rules in the
//! [module docs](super)).

use super::background::{Background, FilterReport, FromBackground, ToBackground, initial_sigma};
use super::setup::Setup;
use crate::Scalar;
use crate::alignment::{AlignFailure, AlignMethod, AlignOutcome};
use crate::calibration::ImuCompensation;
use crate::gap::{GapCounters, GapDetector, ImuGap};
use crate::increment::{ImuIncrement, InputError, InputLimits};
use crate::ins_filter::motion::{MotionAlign, MotionAlignConfig};
use crate::ins_filter::restart::{Carried, Restart};
use crate::ins_filter::sequencer::{
    FixCounters, FixQueue, GnssFixInput, RealignCause, Realignments,
};
use crate::ins_filter::stationarity::StillWindow;
use crate::ins_filter::{
    AidedMechanization, Clipped, FilterConfig, FilterError, FilterStatus, GnssVelocity,
    Propagation, SensorErrors,
};
use crate::output::{EndRecord, FilterColumns, LostRecord, Row, Solution};
use crate::strapdown::{MechanizationConfig, Strapdown};
use core::fmt;
use nalgebra::Vector3;

/// One IMU sample as the navigator takes it (sources convert theirs to this).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuInput {
    /// Time of the end of the sample's interval [us] (the time of its solution row).
    pub t_us: u64,
    /// The increments as the sensor gave them: `delta_theta_ib_b` [rad], `delta_v_ib_b` [m/s],
    /// body FRD, over the measured interval `dt` [s].
    pub increment: ImuIncrement<f32>,
    /// Why the source's flags forbid navigating it (non-finite values, an implausible interval,
    /// stale data, a device fault...); `None`: usable.
    pub unusable: Option<Unusable>,
    /// Samples were lost just before this one.
    pub gap: bool,
    /// Sensor axes the driver found at full scale: navigated, with the doubt of what the
    /// range cut off ([`AidedMechanization::step_clipped`]).
    pub clipped: Clipped,
}

/// Why a source flagged a sample as not usable: the first of these causes that applies (a
/// source converting its flags names one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unusable {
    /// A value is NaN or infinite.
    NonFinite,
    /// The interval is zero, negative or implausibly long (time went backwards or jumped).
    BadInterval,
    /// The sensor repeated its previous data.
    Stale,
    /// The sensor reported an internal fault.
    DeviceFault,
    /// Another reason of the source's.
    Other,
    /// Its time is not after the last navigated sample's (the navigator's own rule: a clock
    /// that stepped back, [`crate::gap`]).
    OutOfOrder,
}

impl Unusable {
    /// Its name in logs and summaries, e.g. `non-finite`.
    pub fn name(self) -> &'static str {
        match self {
            Self::NonFinite => "non-finite",
            Self::BadInterval => "bad interval",
            Self::Stale => "stale",
            Self::DeviceFault => "device fault",
            Self::Other => "other",
            Self::OutOfOrder => "time out of order",
        }
    }
}

/// Flagged samples by cause ([`Unusable`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FlaggedCounts {
    /// NaN or infinite values.
    pub non_finite: u32,
    /// Implausible intervals.
    pub bad_interval: u32,
    /// Stale data.
    pub stale: u32,
    /// Device faults.
    pub device_fault: u32,
    /// Other causes.
    pub other: u32,
    /// Times not after the last navigated sample's.
    pub out_of_order: u32,
}

impl FlaggedCounts {
    /// Counts one sample flagged for `cause`.
    pub fn add(&mut self, cause: Unusable) {
        let n = match cause {
            Unusable::NonFinite => &mut self.non_finite,
            Unusable::BadInterval => &mut self.bad_interval,
            Unusable::Stale => &mut self.stale,
            Unusable::DeviceFault => &mut self.device_fault,
            Unusable::Other => &mut self.other,
            Unusable::OutOfOrder => &mut self.out_of_order,
        };
        *n = n.saturating_add(1);
    }

    /// The counts with their names, in [`Unusable`]'s order.
    pub fn by_name(&self) -> [(&'static str, u32); 6] {
        [
            (Unusable::NonFinite.name(), self.non_finite),
            (Unusable::BadInterval.name(), self.bad_interval),
            (Unusable::Stale.name(), self.stale),
            (Unusable::DeviceFault.name(), self.device_fault),
            (Unusable::Other.name(), self.other),
            (Unusable::OutOfOrder.name(), self.out_of_order),
        ]
    }
}

impl fmt::Display for FlaggedCounts {
    /// The causes that occurred, e.g. `non-finite 4000, stale 2` (`none` without any).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut first = true;
        for (name, n) in self.by_name().into_iter().filter(|(_, n)| *n > 0) {
            if !first {
                f.write_str(", ")?;
            }
            write!(f, "{name} {n}")?;
            first = false;
        }
        if first {
            f.write_str("none")?;
        }
        Ok(())
    }
}

impl ImuInput {
    /// A sample at `t_us` [us] of increments `delta_theta_ib_b` [rad] and `delta_v_ib_b`
    /// [m/s] over `dt_s` [s], with why it is not usable (`None`: usable) and its gap flag.
    pub fn new(
        t_us: u64,
        delta_theta_ib_b: [f32; 3],
        delta_v_ib_b: [f32; 3],
        dt_s: f32,
        unusable: Option<Unusable>,
        gap: bool,
    ) -> Self {
        Self {
            t_us,
            increment: ImuIncrement::new(delta_theta_ib_b, delta_v_ib_b, dt_s),
            unusable,
            gap,
            clipped: Clipped::default(),
        }
    }

    /// The sample with the axes its driver found at full scale.
    pub fn with_clipped(self, clipped: Clipped) -> Self {
        Self { clipped, ..self }
    }
}

/// What the navigator has counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Samples taken.
    pub samples: u32,
    /// Samples skipped for their flags.
    pub flagged: u32,
    /// The same by cause.
    pub flagged_by: FlaggedCounts,
    /// Increments refused by the input limits (aligning or navigating).
    pub rejected: u32,
    /// Navigation steps integrated after the alignment.
    pub nav_steps: u32,
    /// Solution rows produced (the aligned row, the periodic rows, the final row).
    pub rows: u32,
    /// GNSS fixes handed over while the run was not in its aided phase (aligning, or free
    /// inertial): not used.
    pub fixes_unused: u32,
    /// Gaps in the IMU data found while navigating ([`crate::gap`]).
    pub gaps: GapCounters,
    /// Gaps inside a static alignment's window (its averages take them).
    pub alignment_gaps: GapCounters,
}

impl Counters {
    /// What was not used, e.g. ` (4000 flagged: non-finite 4000; 3 rejected)`, with its
    /// leading blank; empty when every sample was used.
    fn unused(&self) -> Unused<'_> {
        Unused(self)
    }
}

/// [`Counters::unused`]'s text.
struct Unused<'a>(&'a Counters);

impl fmt::Display for Unused<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = self.0;
        match (c.flagged, c.rejected) {
            (0, 0) => Ok(()),
            (0, r) => write!(f, " ({r} rejected)"),
            (n, 0) => write!(f, " ({n} flagged: {})", c.flagged_by),
            (n, r) => write!(f, " ({n} flagged: {}; {r} rejected)", c.flagged_by),
        }
    }
}

/// What became of one sample ([`Navigator::push`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step<T: Scalar> {
    /// Skipped for its flags, or out of time order: the cause (counted in `flagged`).
    Flagged(Unusable),
    /// Refused by the input limits (counted in `rejected`).
    Rejected(InputError),
    /// Aligning: hand the increment to the background ([`ToBackground::Align`]). With
    /// `await_reply`, it was the last alignment sample: deliver the background's answer
    /// ([`Navigator::on_background`]) before the next sample. (The increment alone, not the
    /// message: a step stays small on the MCU's stack.)
    Forward {
        /// The compensated, checked increment.
        increment: ImuIncrement<T>,
        /// The foreground now waits for the background's answer.
        await_reply: bool,
    },
    /// Integrated; a solution row to log when the cadence says so.
    Navigated(Option<Solution>),
    /// Integrated by the aided phase's mechanization: take the sample's work for the
    /// background from [`Navigator::next_message`] (its row, when one is due, comes with the
    /// background's last answer, [`Navigator::on_background`]).
    Aided,
    /// Not taken (and not counted): the navigator waits for the background's answer, the
    /// previous sample's work is not all taken ([`Navigator::next_message`]), or the run
    /// failed. Deliver the answer or take the work, then push the sample again.
    NotReady,
    /// The sample ended the run ([`NavError::GapDuringAlignment`]).
    Failed(NavError),
}

/// Why a run ended without navigating to the end of its data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NavError {
    /// The alignment failed.
    Alignment {
        /// Samples it had used.
        samples: u32,
        /// Why.
        failure: AlignFailure,
        /// Gaps in the IMU data inside its window (the static method takes them: its window
        /// of samples then spans their time too, and may reach a vehicle that set off).
        gaps: GapCounters,
    },
    /// The data ended before the alignment had its samples.
    EndedDuringAlignment {
        /// Samples forwarded to the alignment.
        samples: u32,
        /// Samples it needs.
        n_align: u32,
        /// What was counted (the samples flagged or rejected by cause).
        counters: Counters,
    },
    /// The alignment finished but not one navigation step followed it: every later sample was
    /// flagged or rejected, or there was none.
    NothingNavigated {
        /// Samples the alignment used.
        n_align: u32,
        /// What was counted.
        counters: Counters,
    },
    /// The alignment finished but the navigation filter cannot start from its outcome.
    Filter(FilterError),
    /// Time was lost inside the window of an alignment that integrates the body's attitude
    /// (inertial, fine, sway: an attitude step across the gap is as large as the Earth-rate
    /// signal the heading comes from); the static method's averages do not mind one.
    GapDuringAlignment {
        /// Samples forwarded to the alignment before the gap.
        samples: u32,
        /// The time lost [us].
        lost_us: u64,
    },
}

impl fmt::Display for NavError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Alignment {
                samples,
                failure,
                gaps,
            } => {
                write!(f, "alignment failed after {samples} samples: {failure}")?;
                let n = gaps.bridged.saturating_add(gaps.lost);
                if n > 0 {
                    write!(
                        f,
                        " ({n} gap(s) in the IMU data inside its window, {} us in all, the \
                         longest {} us: its samples spanned that much more time than asked, \
                         the base may have moved in it)",
                        gaps.time_us, gaps.longest_us
                    )?;
                }
                Ok(())
            }
            Self::EndedDuringAlignment {
                samples,
                n_align,
                counters,
            } => write!(
                f,
                "recording ended during alignment: {samples} of {n_align} samples used{}",
                counters.unused()
            ),
            Self::NothingNavigated { n_align, counters } => write!(
                f,
                "no navigation step after the alignment: {} samples, {n_align} used by the alignment{}",
                counters.samples,
                counters.unused()
            ),
            Self::Filter(e) => write!(
                f,
                "the navigation filter cannot start from the alignment's outcome: {e}"
            ),
            Self::GapDuringAlignment { samples, lost_us } => write!(
                f,
                "{lost_us} us of IMU data missing after {samples} samples of the alignment: \
                 its method integrates the body's attitude, which a gap breaks (align where \
                 the data have no gap, or with the static method on a still base)"
            ),
        }
    }
}

impl core::error::Error for NavError {}

/// The end of a run ([`Navigator::finish`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary<T: Scalar> {
    /// The final row to log (the last navigation step, unless it was already logged).
    pub final_row: Option<Row>,
    /// The last solution logged (the final row, or the last row before it).
    pub last_solution: Solution,
    /// The counters.
    pub counters: Counters,
    /// The alignment's result.
    pub alignment: AlignOutcome<T>,
    /// The filter's last report, in an aided run.
    pub filter: Option<FilterReport<T>>,
    /// The GNSS fixes' counters of the aided phase.
    pub fixes: FixCounters,
    /// The aided phase's re-alignments in motion (after a lost gap or a divergence).
    pub realignments: Realignments,
}

impl<T: Scalar> Summary<T> {
    /// The solution log's end record, to write after the final row.
    pub fn end_record(&self) -> EndRecord {
        EndRecord {
            rows: self.counters.rows,
        }
    }
}

enum Phase<T: Scalar> {
    /// Forwarding increments to the background's alignment.
    Aligning,
    /// The last alignment increment is forwarded; waiting for the answer.
    AwaitingAlignment,
    /// Navigating from the alignment's state.
    Navigating(Strapdown<T>),
    /// Navigating from the alignment's state, aided: the filter's mechanization (its
    /// covariance is the background's).
    Aided(AidedMechanization<T>),
    /// The alignment failed.
    Failed(NavError),
}

/// Where a GNSS fix's updates are at the current sample.
#[derive(Clone, Copy, Debug, PartialEq)]
enum FixStage<T: Scalar> {
    /// None under way.
    Idle,
    /// The position update is next (with its lag [s]).
    Position(GnssFixInput<T>, T),
    /// The velocity update is next (the position's correction fed back).
    Velocity(GnssVelocity<T>, T),
    /// Re-aligning: the fix (with its lag [s]) goes to the start in motion.
    ForStart(GnssFixInput<T>, T),
    /// Re-aligning: the start is found; the filter restarts from it next.
    Restart(Restart<T>),
    /// The restart is asked for; the new mechanization starts from it with the answer.
    Restarting(Restart<T>),
}

/// The aided phase's re-alignment in motion (the sequencer's rule,
/// [`crate::ins_filter::sequencer`]): after a gap in the IMU data too long to bridge, at the
/// first fix after it, or once the filter diverged, the filter is set aside (it goes on
/// free-inertial, fixes withheld, its rows DEGRADED) and the fixes and samples go to a start in
/// motion; once level and heading are known, the filter restarts from it.
struct Realign<T: Scalar> {
    /// Lost time since a lost gap, before the first fix after it [s] (`Some`: lost).
    lost_s: Option<T>,
    /// Under way.
    under_way: Option<UnderWay<T>>,
    counters: Realignments,
}

/// A re-alignment under way.
struct UnderWay<T: Scalar> {
    motion: MotionAlign<T>,
    /// The sensor errors the start's samples are compensated with.
    sensors: SensorErrors<T>,
    /// Lost time the filter set aside did not propagate over [s].
    unpropagated_s: T,
    cause: RealignCause,
}

/// When the current aided sample's row is due.
#[derive(Clone, Copy, Debug, PartialEq)]
enum RowStage {
    /// No row.
    None,
    /// A row at this time [us] once the sample's updates are done: ask for the report.
    Due(u64),
    /// The report is asked for; the row at this time [us] comes with it.
    Requested(u64),
}

/// The background work of the current aided sample, handed out one message at a time
/// ([`Navigator::next_message`]) in [`AidedIns`](crate::ins_filter::AidedIns)'s order: the
/// stop's updates (their partial propagation first), the full propagation interval, each due
/// fix's position then velocity update (each after the propagation of what has accumulated),
/// then the report for a row.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Work<T: Scalar> {
    /// Time of the sample [us].
    t_us: u64,
    still: Option<StillWindow<T>>,
    propagation: Option<Propagation<T>>,
    /// The fix queue may hold fixes due at this sample.
    fixes_due: bool,
    fix: FixStage<T>,
    /// A GNSS update of this sample found the filter diverged.
    diverged: bool,
    row: RowStage,
}

impl<T: Scalar> Work<T> {
    const NONE: Self = Self {
        t_us: 0,
        still: None,
        propagation: None,
        fixes_due: false,
        fix: FixStage::Idle,
        diverged: false,
        row: RowStage::None,
    };

    fn pending(&self) -> bool {
        self.still.is_some()
            || self.propagation.is_some()
            || self.fixes_due
            || self.fix != FixStage::Idle
            || self.row != RowStage::None
    }
}

/// The answer the foreground waits for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Awaiting {
    /// An update's ([`FromBackground::Updated`]).
    Update,
    /// A restart's ([`FromBackground::Restarted`]).
    Restart,
    /// The report ([`FromBackground::Report`]).
    Report,
}

/// The foreground half of the navigator (module docs): small, no allocation; the firmware's
/// `navigate` task owns one.
pub struct Navigator<T: Scalar> {
    compensation: ImuCompensation<T>,
    limits: InputLimits<T>,
    mechanization: MechanizationConfig<T>,
    log_every: u32,
    n_align: u32,
    align_method: AlignMethod,
    phase: Phase<T>,
    counters: Counters,
    /// Increments forwarded to the alignment, and the time of the last one [us].
    forwarded: u32,
    last_forwarded_us: u64,
    /// Time of the last navigation step [us].
    last_step_us: u64,
    last_row: Option<Row>,
    alignment: Option<AlignOutcome<T>>,
    /// [`Self::finish`] was called, or the aided run's final row given.
    finished: bool,
    /// The aided phase's filter settings (`None`: free inertial after the alignment).
    filter: Option<FilterConfig<T>>,
    /// Time lost between navigated samples.
    gaps: GapDetector<T>,
    /// GNSS fixes waiting for their sample.
    fixes: FixQueue<T>,
    /// The current aided sample's background work.
    work: Work<T>,
    /// The answer awaited before anything else.
    awaiting: Option<Awaiting>,
    /// The filter's last report.
    report: Option<FilterReport<T>>,
    /// Re-alignments in motion.
    realign: Realign<T>,
    /// The record of a gap that lost the free-inertial solution, for the log
    /// ([`Self::take_lost_record`]).
    lost_record: Option<LostRecord>,
}

impl<T: Scalar> Navigator<T> {
    /// The foreground of a run of `setup`, at the start of the alignment.
    pub fn new(setup: &Setup<T>) -> Self {
        Self {
            compensation: setup.compensation,
            limits: setup.limits,
            mechanization: setup.mechanization,
            log_every: setup.log_every,
            n_align: setup.n_align(),
            align_method: setup.align.method,
            phase: Phase::Aligning,
            counters: Counters::default(),
            forwarded: 0,
            last_forwarded_us: 0,
            last_step_us: 0,
            last_row: None,
            alignment: None,
            finished: false,
            filter: setup.filter,
            gaps: GapDetector::new(),
            fixes: FixQueue::new(),
            work: Work::NONE,
            awaiting: None,
            report: None,
            realign: Realign {
                lost_s: None,
                under_way: None,
                counters: Realignments::default(),
            },
            lost_record: None,
        }
    }

    /// The log's record of the IMU gap beyond the bridge that lost the free-inertial
    /// solution at the last sample, once ([`LostRecord`]: the rows after it carry on from the
    /// state before the gap and look valid); an aided run's rows say DEGRADED instead and it
    /// re-aligns. The caller writes it before that sample's row.
    pub fn take_lost_record(&mut self) -> Option<LostRecord> {
        self.lost_record.take()
    }

    /// Hands over a GNSS fix (time order; at most a few ahead of the samples: hand each over
    /// before the first sample at or after its time). In the aided phase it is held until
    /// that sample and applied there ([`FixQueue`]: a fix out of order is refused and counted,
    /// a full queue drops its oldest, one applied more than 0.1 s late is dropped and
    /// counted); otherwise
    /// it is counted in [`Counters::fixes_unused`]. Returns whether it was taken.
    pub fn push_fix(&mut self, fix: GnssFixInput<T>) -> bool {
        if matches!(self.phase, Phase::Aided(_)) {
            self.fixes.push(fix)
        } else {
            self.counters.fixes_unused = self.counters.fixes_unused.saturating_add(1);
            false
        }
    }

    /// Takes one sample (rules in the module docs).
    pub fn push(&mut self, input: &ImuInput) -> Step<T> {
        if matches!(self.phase, Phase::AwaitingAlignment | Phase::Failed(_))
            || self.awaiting.is_some()
            || self.work.pending()
        {
            return Step::NotReady;
        }
        let c = &mut self.counters;
        c.samples = c.samples.saturating_add(1);
        if input.unusable.is_some() || input.gap {
            // The two-sample coning/sculling terms must not span a hole in the data.
            self.restart_increments();
        }
        if let Some(cause) = input.unusable {
            self.counters.flagged = self.counters.flagged.saturating_add(1);
            self.counters.flagged_by.add(cause);
            return Step::Flagged(cause);
        }
        let inc = self.compensated(&input.increment);
        if let Err(e) = inc.check(&self.limits) {
            self.counters.rejected = self.counters.rejected.saturating_add(1);
            // As the strapdown does for an increment it refuses.
            self.restart_increments();
            return Step::Rejected(e);
        }
        if self.gaps.out_of_order(input.t_us, inc.dt) {
            self.restart_increments();
            self.counters.flagged = self.counters.flagged.saturating_add(1);
            self.counters.flagged_by.add(Unusable::OutOfOrder);
            return Step::Flagged(Unusable::OutOfOrder);
        }
        let gap = self.gaps.note(input.t_us, &inc);
        if let Some(gap) = &gap {
            if matches!(self.phase, Phase::Aligning) && self.align_method != AlignMethod::Static {
                let e = NavError::GapDuringAlignment {
                    samples: self.forwarded,
                    lost_us: (gap.lost_s.to_f64() * 1e6) as u64,
                };
                return Step::Failed(self.fail(e));
            }
            if matches!(self.phase, Phase::Aligning) {
                self.counters.alignment_gaps.add(gap);
            }
            self.bridge(gap, input.t_us);
        }
        match &mut self.phase {
            Phase::Navigating(nav) => {
                if let Err(e) = nav.step(&inc) {
                    // Not reached: the strapdown checks the same limits.
                    self.counters.rejected = self.counters.rejected.saturating_add(1);
                    return Step::Rejected(e);
                }
                self.counters.nav_steps += 1;
                self.last_step_us = input.t_us;
                if !self.counters.nav_steps.is_multiple_of(self.log_every) {
                    return Step::Navigated(None);
                }
                let row = Solution::from_state(input.t_us, nav.state());
                self.logged(Row::Free(row));
                Step::Navigated(Some(row))
            }
            Phase::Aided(_) if super::config::AIDED_COMPILED_IN => {
                self.step_aided(input.t_us, &inc, input.clipped)
            }
            // Not reached: without the aided filter the phase is never entered.
            Phase::Aided(_) => Step::NotReady,
            _ => {
                self.forwarded += 1;
                self.last_forwarded_us = input.t_us;
                let await_reply = self.forwarded >= self.n_align;
                if await_reply {
                    self.phase = Phase::AwaitingAlignment;
                }
                Step::Forward {
                    increment: inc,
                    await_reply,
                }
            }
        }
    }

    /// An aided navigation step (the filter's mechanization) and its work for the background.
    /// Not inlined into [`Self::push`]: its temporaries must not deepen the stack of a push
    /// that preempts the background's alignment on the MCU.
    #[inline(never)]
    fn step_aided(&mut self, t_us: u64, inc: &ImuIncrement<T>, clipped: Clipped) -> Step<T> {
        let Phase::Aided(mech) = &mut self.phase else {
            return Step::NotReady;
        };
        let events = match mech.step_clipped(inc, clipped) {
            Ok(events) => events,
            Err(e) => {
                // Not reached: the mechanization checks the same limits.
                self.counters.rejected = self.counters.rejected.saturating_add(1);
                return Step::Rejected(e);
            }
        };
        if let Some(u) = &mut self.realign.under_way {
            u.motion.add_imu(&u.sensors.compensate(inc));
        }
        self.counters.nav_steps += 1;
        self.last_step_us = t_us;
        let row_due = self.counters.nav_steps.is_multiple_of(self.log_every);
        self.work = Work {
            t_us,
            still: events.still,
            propagation: events.propagation,
            fixes_due: true,
            fix: FixStage::Idle,
            diverged: false,
            row: if row_due {
                RowStage::Due(t_us)
            } else {
                RowStage::None
            },
        };
        Step::Aided
    }

    /// Takes the background's answer; returns the row it completes, to log. Aligned:
    /// navigation starts from the alignment's state (aided, with the filter's mechanization),
    /// and the row of that state at the time of the last alignment sample is returned. Failed
    /// (the alignment, or the filter's start): the run ends with the error. Updated: the
    /// estimate is fed back. Report: the row it was asked for.
    pub fn on_background(&mut self, message: FromBackground<T>) -> Result<Option<Row>, NavError> {
        match message {
            FromBackground::Aligned(outcome) => {
                if !matches!(self.phase, Phase::Aligning | Phase::AwaitingAlignment) {
                    return Ok(None);
                }
                self.alignment = Some(outcome);
                // Without the aided filter `filter` is None (`RunConfig::validate`): the
                // constant makes its branch dead code.
                let row = match self.filter.filter(|_| super::config::AIDED_COMPILED_IN) {
                    None => {
                        let nav = Strapdown::new(outcome.state, self.mechanization);
                        let row = Solution::from_state(self.last_forwarded_us, nav.state());
                        self.phase = Phase::Navigating(nav);
                        Row::Free(row)
                    }
                    Some(config) => {
                        let mut mech = AidedMechanization::new(
                            outcome.state,
                            SensorErrors::default(),
                            &config,
                        )
                        .map_err(|e| self.fail(NavError::Filter(e)))?;
                        let sigma = initial_sigma(&outcome, &config);
                        mech.allow_for(sigma.uncertainty(mech.gravity()));
                        let columns = columns(
                            &sigma.position_ned_m,
                            &sigma.velocity_ned_m_s,
                            &sigma.attitude_rad,
                            FilterStatus::Nominal,
                        );
                        let row = Solution::from_state(self.last_forwarded_us, mech.state());
                        self.phase = Phase::Aided(mech);
                        Row::Aided(row, columns)
                    }
                };
                Ok(Some(self.logged(row)))
            }
            FromBackground::AlignFailed { samples, failure } => {
                Err(self.fail(NavError::Alignment {
                    samples,
                    failure,
                    gaps: self.counters.alignment_gaps,
                }))
            }
            FromBackground::FilterFailed(e) => Err(self.fail(NavError::Filter(e))),
            FromBackground::Updated {
                correction,
                diverged,
            } => {
                if self.awaiting == Some(Awaiting::Update) {
                    self.awaiting = None;
                    self.work.diverged |= diverged;
                    if let (Some(c), Phase::Aided(mech)) = (correction, &mut self.phase) {
                        mech.apply(&c);
                    }
                }
                Ok(None)
            }
            FromBackground::Restarted(allowance) => {
                if self.awaiting == Some(Awaiting::Restart) {
                    self.awaiting = None;
                    self.restarted(allowance);
                }
                Ok(None)
            }
            FromBackground::Report(report) => {
                if self.awaiting != Some(Awaiting::Report) {
                    return Ok(None);
                }
                self.awaiting = None;
                self.report = Some(report);
                let (RowStage::Requested(t_us), Phase::Aided(mech)) = (self.work.row, &self.phase)
                else {
                    return Ok(None);
                };
                self.work.row = RowStage::None;
                let row = Row::Aided(
                    Solution::from_state(t_us, mech.state()),
                    report_columns(&report),
                );
                if t_us == self.last_step_us
                    && !self.counters.nav_steps.is_multiple_of(self.log_every)
                {
                    // The final row ([`Self::end_of_data`]).
                    self.finished = true;
                }
                Ok(Some(self.logged(row)))
            }
        }
    }

    /// The next message of the current aided sample's work for the background (`None`: the
    /// sample's work is done, or an answer is awaited). Deliver the answer of a message that
    /// [`ToBackground::is_answered`] ([`Self::on_background`]) before asking again, and take
    /// every message before the next sample (the firmware sends them over its channel; the
    /// harness hands them over in line, [`Self::push_inline`]).
    pub fn next_message(&mut self) -> Option<ToBackground<T>> {
        // Without the aided filter there is no aided phase: the constant leaves its work out.
        if self.awaiting.is_some() || !super::config::AIDED_COMPILED_IN {
            return None;
        }
        let Phase::Aided(mech) = &mut self.phase else {
            return None;
        };
        let w = &mut self.work;
        if let Some(window) = w.still {
            if let Some(p) = mech.flush() {
                return Some(ToBackground::Propagate(p));
            }
            w.still = None;
            self.awaiting = Some(Awaiting::Update);
            return Some(ToBackground::Still {
                snapshot: mech.snapshot(),
                window,
            });
        }
        if let Some(p) = w.propagation.take() {
            return Some(ToBackground::Propagate(p));
        }
        loop {
            match w.fix {
                FixStage::Idle => {
                    if !w.fixes_due {
                        break;
                    }
                    let Some((fix, lag)) = self.fixes.pop_due(w.t_us) else {
                        w.fixes_due = false;
                        if core::mem::take(&mut w.diverged) {
                            let r = &mut self.realign;
                            r.begin(
                                self.filter.as_ref(),
                                SensorErrors::default(),
                                T::zero(),
                                RealignCause::Diverged,
                                w.t_us,
                            );
                        }
                        continue;
                    };
                    if let Some(lost_s) = self.realign.lost_s.take() {
                        let sensors = *mech.sensor_errors();
                        self.realign.begin(
                            self.filter.as_ref(),
                            sensors,
                            lost_s,
                            RealignCause::LostGap,
                            w.t_us,
                        );
                    }
                    w.fix = match self.realign.under_way {
                        Some(_) => FixStage::ForStart(fix, lag),
                        None => FixStage::Position(fix, lag),
                    };
                }
                FixStage::ForStart(fix, lag_s) => {
                    self.fixes.count_for_start();
                    w.fix = FixStage::Idle;
                    let Some(u) = &mut self.realign.under_way else {
                        continue;
                    };
                    let t_s = fix.t_us as f64 * 1e-6;
                    let Some(found) = u.motion.add_fix(t_s, &fix.position, fix.velocity.as_ref())
                    else {
                        continue;
                    };
                    let Some(config) = self.filter else { continue };
                    let (carried, sensors) = match u.cause {
                        RealignCause::LostGap => (
                            Carried::Sensors {
                                unpropagated_s: u.unpropagated_s,
                            },
                            *mech.sensor_errors(),
                        ),
                        RealignCause::Diverged => (Carried::Counters, u.sensors),
                    };
                    let start = Restart::plan(&found, lag_s, &config, sensors, None, carried);
                    w.fix = FixStage::Restart(start);
                }
                FixStage::Restart(start) => {
                    // The covariance set aside brought up to the sample first, when its
                    // sensor block is carried.
                    if matches!(start.carried, Carried::Sensors { .. })
                        && let Some(p) = mech.flush()
                    {
                        return Some(ToBackground::Propagate(p));
                    }
                    let Some(config) = self.filter else {
                        w.fix = FixStage::Idle;
                        continue;
                    };
                    // Built here for the state as it takes it, again with the answer.
                    let Ok(new) = AidedMechanization::new(start.state, start.sensors, &config)
                    else {
                        w.fix = FixStage::Idle;
                        continue;
                    };
                    w.fix = FixStage::Restarting(start);
                    self.awaiting = Some(Awaiting::Restart);
                    return Some(ToBackground::Restart {
                        start,
                        mech_state: *new.state(),
                        gravity_mps2: new.gravity(),
                    });
                }
                // Not reached: the answer is awaited first.
                FixStage::Restarting(_) => return None,
                FixStage::Position(fix, lag_s) => {
                    // The covariance brought up to the sample first.
                    if let Some(p) = mech.flush() {
                        return Some(ToBackground::Propagate(p));
                    }
                    w.fix = match fix.velocity {
                        Some(v) => FixStage::Velocity(v, lag_s),
                        None => FixStage::Idle,
                    };
                    self.awaiting = Some(Awaiting::Update);
                    return Some(ToBackground::Position {
                        snapshot: mech.snapshot(),
                        fix: fix.position,
                        lag_s,
                    });
                }
                FixStage::Velocity(fix, lag_s) => {
                    if let Some(p) = mech.flush() {
                        return Some(ToBackground::Propagate(p));
                    }
                    w.fix = FixStage::Idle;
                    self.awaiting = Some(Awaiting::Update);
                    return Some(ToBackground::Velocity {
                        snapshot: mech.snapshot(),
                        fix,
                        lag_s,
                    });
                }
            }
        }
        if let RowStage::Due(t_us) = w.row {
            w.row = RowStage::Requested(t_us);
            self.awaiting = Some(Awaiting::Report);
            return Some(ToBackground::Report {
                q_b_n: mech.state().q_b_n,
            });
        }
        None
    }

    /// The data have ended: in an aided run whose last step was not logged, its row is due,
    /// with the filter's report (take it from [`Self::next_message`] before
    /// [`Self::finish`]). Nothing otherwise.
    pub fn end_of_data(&mut self) {
        let aided = matches!(self.phase, Phase::Aided(_));
        let steps = self.counters.nav_steps;
        if aided
            && steps > 0
            && !steps.is_multiple_of(self.log_every)
            && !self.finished
            && !self.work.pending()
            && self.awaiting.is_none()
        {
            self.work.row = RowStage::Due(self.last_step_us);
        }
    }

    /// Ends the run in `e` (returned).
    fn fail(&mut self, e: NavError) -> NavError {
        self.phase = Phase::Failed(e);
        e
    }

    /// [`Self::push`] with the background run in line on what it forwards (the harness's way;
    /// the firmware's tasks do the same across their channels): returns the row to log, if any.
    pub fn push_inline(
        &mut self,
        background: &mut Background<T>,
        input: &ImuInput,
    ) -> Result<Option<Row>, NavError> {
        match self.push(input) {
            Step::Forward { increment, .. } => {
                match background.handle(ToBackground::Align(increment)) {
                    Some(answer) => self.on_background(answer),
                    None => Ok(None),
                }
            }
            Step::Navigated(row) => Ok(row.map(Row::Free)),
            Step::Aided => self.work_inline(background),
            Step::NotReady => match self.phase {
                Phase::Failed(e) => Err(e),
                _ => Ok(None),
            },
            Step::Flagged(_) | Step::Rejected(_) => Ok(None),
            Step::Failed(e) => Err(e),
        }
    }

    /// Hands every message of the current work ([`Self::next_message`]) to `background` in
    /// line and takes its answers: returns the row they complete, if any. After the last
    /// sample, [`Self::end_of_data`] then this give an aided run's final row.
    pub fn work_inline(&mut self, background: &mut Background<T>) -> Result<Option<Row>, NavError> {
        let mut row = None;
        while let Some(message) = self.next_message() {
            if let Some(answer) = background.handle(message)
                && let Some(r) = self.on_background(answer)?
            {
                row = Some(r);
            }
        }
        Ok(row)
    }

    /// Ends the run: the final row (the last step, unless already logged, or already given by
    /// an earlier call) and the summary; an error when the alignment failed or never finished,
    /// or when no navigation step followed it.
    pub fn finish(&mut self) -> Result<Summary<T>, NavError> {
        let ended_during_alignment = NavError::EndedDuringAlignment {
            samples: self.forwarded,
            n_align: self.n_align,
            counters: self.counters,
        };
        let state = match &self.phase {
            Phase::Navigating(nav) => *nav.state(),
            Phase::Aided(mech) => *mech.state(),
            Phase::Failed(e) => return Err(*e),
            Phase::Aligning | Phase::AwaitingAlignment => return Err(ended_during_alignment),
        };
        let steps = self.counters.nav_steps;
        if steps == 0 {
            return Err(NavError::NothingNavigated {
                n_align: self.n_align,
                counters: self.counters,
            });
        }
        let final_row = (!steps.is_multiple_of(self.log_every) && !self.finished).then(|| {
            let solution = Solution::from_state(self.last_step_us, &state);
            // Aided without [`Self::end_of_data`]: the filter's columns of the last row.
            match self.last_row.as_ref().and_then(Row::filter) {
                Some(c) => Row::Aided(solution, *c),
                None => Row::Free(solution),
            }
        });
        self.finished = true;
        if let Some(row) = final_row {
            self.logged(row);
        }
        match (self.last_row, self.alignment) {
            (Some(last), Some(alignment)) => Ok(Summary {
                final_row,
                last_solution: *last.solution(),
                counters: self.counters,
                alignment,
                filter: self.report,
                fixes: *self.fixes.counters(),
                realignments: self.realign.counters,
            }),
            // Navigating implies both (the aligned row is logged at the hand-over).
            _ => Err(ended_during_alignment),
        }
    }

    /// The counters so far.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// Samples the alignment takes.
    pub fn n_align(&self) -> u32 {
        self.n_align
    }

    /// `true` until navigation has started (and the alignment has not failed).
    pub fn is_aligning(&self) -> bool {
        matches!(self.phase, Phase::Aligning | Phase::AwaitingAlignment)
    }

    /// `true` once the last alignment increment is forwarded and the answer is still due, or
    /// while an aided update's or report's answer is due.
    pub fn awaits_background(&self) -> bool {
        matches!(self.phase, Phase::AwaitingAlignment) || self.awaiting.is_some()
    }

    /// `true` in the aided phase.
    pub fn is_aided(&self) -> bool {
        matches!(self.phase, Phase::Aided(_))
    }

    /// The aided phase's mechanization, once navigating aided.
    pub fn aided(&self) -> Option<&AidedMechanization<T>> {
        match &self.phase {
            Phase::Aided(mech) => Some(mech),
            _ => None,
        }
    }

    /// The aided phase's re-alignments in motion so far.
    pub fn realignments(&self) -> &Realignments {
        &self.realign.counters
    }

    /// True while the aided phase re-aligns in motion (the filter set aside, its rows
    /// DEGRADED).
    pub fn realigning(&self) -> bool {
        self.realign.under_way.is_some()
    }

    /// The aided phase's filter status (`None` outside it): the last report's, but from the
    /// first sample after a gap too long to bridge, before a report has said so,
    /// [`FilterStatus::ImuLost`], and while re-aligning the filter set aside's (DEGRADED:
    /// [`FilterStatus::ImuLost`] after a lost gap, by refusals after a divergence).
    pub fn filter_status(&self) -> Option<FilterStatus> {
        if !self.is_aided() || !super::config::AIDED_COMPILED_IN {
            return None;
        }
        let reported = self.report.map_or(FilterStatus::Nominal, |r| r.status);
        let r = &self.realign;
        Some(match (r.lost_s, &r.under_way) {
            (Some(_), _) => FilterStatus::ImuLost,
            (None, Some(u)) if u.cause == RealignCause::LostGap => FilterStatus::ImuLost,
            (None, Some(_)) if reported == FilterStatus::Nominal => FilterStatus::AidingRejected,
            _ => reported,
        })
    }

    /// The filter's last report (aided phase).
    pub fn filter_report(&self) -> Option<&FilterReport<T>> {
        self.report.as_ref()
    }

    /// The GNSS fixes' counters of the aided phase.
    pub fn fix_counters(&self) -> FixCounters {
        *self.fixes.counters()
    }

    /// The alignment's result, once navigating.
    pub fn alignment(&self) -> Option<&AlignOutcome<T>> {
        self.alignment.as_ref()
    }

    /// The navigation state, once navigating (aided or not).
    pub fn strapdown(&self) -> Option<&Strapdown<T>> {
        match &self.phase {
            Phase::Navigating(nav) => Some(nav),
            Phase::Aided(mech) => Some(mech.strapdown()),
            _ => None,
        }
    }

    /// Integrates the time lost before the current sample, navigating ([`crate::gap`]): free
    /// inertial, the strapdown over the interpolated rates; aided, the filter's mechanization,
    /// which widens the covariance. Counted in [`Counters::gaps`].
    fn bridge(&mut self, gap: &ImuGap<T>, t_us: u64) {
        match &mut self.phase {
            Phase::Navigating(nav) => {
                nav.restart_increments();
                gap.integrate(|inc| nav.step(inc));
            }
            Phase::Aided(mech) => {
                mech.bridge(gap);
                if super::config::AIDED_COMPILED_IN && !gap.bridged() {
                    self.realign.lost(gap, t_us, self.filter.as_ref());
                }
            }
            _ => return,
        }
        let gap_us = self.counters.gaps.add(gap);
        if !gap.bridged() && matches!(self.phase, Phase::Navigating(_)) {
            self.lost_record = Some(LostRecord { t_us, gap_us });
        }
    }

    /// The filter restarted ([`FromBackground::Restarted`]): the new mechanization from the
    /// start, with the stop detector's allowance; refused, the filter set aside goes on.
    fn restarted(&mut self, allowance: Option<crate::ins_filter::stationarity::Uncertainty<T>>) {
        let FixStage::Restarting(start) = self.work.fix else {
            return;
        };
        if !super::config::AIDED_COMPILED_IN {
            return;
        }
        self.work.fix = FixStage::Idle;
        let (Some(u), Some(config)) = (allowance, self.filter) else {
            return;
        };
        // Built before the message from the same values: it does not fail here.
        let Ok(mut mech) = AidedMechanization::new(start.state, start.sensors, &config) else {
            return;
        };
        mech.allow_for(u);
        self.phase = Phase::Aided(mech);
        let r = &mut self.realign;
        r.under_way = None;
        r.counters.completed = r.counters.completed.saturating_add(1);
        r.counters.navigating_us = self.work.t_us;
    }

    fn restart_increments(&mut self) {
        match &mut self.phase {
            Phase::Navigating(nav) => nav.restart_increments(),
            Phase::Aided(mech) => mech.restart_increments(),
            _ => {}
        }
    }

    /// The sensor's increment in `T` (exactly), compensated.
    fn compensated(&self, inc: &ImuIncrement<f32>) -> ImuIncrement<T> {
        let dt = T::of_f32(inc.dt);
        ImuIncrement {
            delta_theta_ib_b: self
                .compensation
                .gyro
                .apply(&inc.delta_theta_ib_b.map(T::of_f32), dt),
            delta_v_ib_b: self
                .compensation
                .accel
                .apply(&inc.delta_v_ib_b.map(T::of_f32), dt),
            dt,
        }
    }

    fn logged(&mut self, row: Row) -> Row {
        self.counters.rows += 1;
        self.last_row = Some(row);
        row
    }
}

impl<T: Scalar> Realign<T> {
    /// A gap too long to bridge ended at `t_us` [us]: lost until the next fix; during a
    /// re-alignment, it starts over (the level's span would cross the gap).
    fn lost(&mut self, gap: &ImuGap<T>, t_us: u64, config: Option<&FilterConfig<T>>) {
        match &mut self.under_way {
            None => self.lost_s = Some(self.lost_s.unwrap_or_else(T::zero) + gap.lost_s),
            Some(u) => {
                u.unpropagated_s += gap.lost_s;
                u.motion = start_in_motion(config);
                let c = &mut self.counters;
                c.started_over = c.started_over.saturating_add(1);
            }
        }
        self.counters.cause(gap, t_us);
    }

    /// The filter is set aside at `t_us` [us] for `cause`; the start in motion begins,
    /// its samples compensated with `sensors`.
    fn begin(
        &mut self,
        config: Option<&FilterConfig<T>>,
        sensors: SensorErrors<T>,
        unpropagated_s: T,
        cause: RealignCause,
        t_us: u64,
    ) {
        self.under_way = Some(UnderWay {
            motion: start_in_motion(config),
            sensors,
            unpropagated_s,
            cause,
        });
        let c = &mut self.counters;
        c.begun = c.begun.saturating_add(1);
        c.diverged = c
            .diverged
            .saturating_add(u32::from(cause == RealignCause::Diverged));
        c.last_cause = cause;
        c.begun_us = t_us;
    }
}

/// A re-alignment's start in motion, for the aided filter of `config`: its lever arm, the
/// settings of a run that did not start in motion.
fn start_in_motion<T: Scalar>(config: Option<&FilterConfig<T>>) -> MotionAlign<T> {
    match config {
        Some(c) => MotionAlign::new(
            MotionAlignConfig::for_realignment(c),
            c.antenna_lever_arm_b_m,
        ),
        None => MotionAlign::new(MotionAlignConfig::default(), Vector3::zeros()),
    }
}

/// The filter's columns of a row: 1-sigma of position [m], velocity [m/s], roll, pitch, yaw
/// [rad] (printed in degrees) and the status.
fn columns<T: Scalar>(
    position: &Vector3<T>,
    velocity: &Vector3<T>,
    attitude_rad: &Vector3<T>,
    status: FilterStatus,
) -> FilterColumns {
    let narrow = |v: &Vector3<T>, k: f64| [v.x, v.y, v.z].map(|x| (x.to_f64() * k) as f32);
    FilterColumns {
        sigma_ned_m: narrow(position, 1.0),
        sigma_v_ned_m_s: narrow(velocity, 1.0),
        sigma_att_deg: narrow(attitude_rad, 180.0 / core::f64::consts::PI),
        status: status.name(),
    }
}

/// [`columns`] of a report.
fn report_columns<T: Scalar>(r: &FilterReport<T>) -> FilterColumns {
    columns(
        &r.sigma_ned_m,
        &r.sigma_v_ned_m_s,
        &r.sigma_att_rad,
        r.status,
    )
}
