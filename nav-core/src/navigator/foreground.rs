//! The navigator's foreground half: every sample through the gate, the calibration, the
//! alignment hand-over and the strapdown, with the counters and the logging cadence (rules in
//! the [module docs](super)).

use super::background::{Background, FromBackground, ToBackground};
use super::setup::Setup;
use crate::Scalar;
use crate::alignment::{AlignFailure, AlignOutcome};
use crate::calibration::ImuCompensation;
use crate::increment::{ImuIncrement, InputError, InputLimits};
use crate::output::{EndRecord, Solution};
use crate::strapdown::{MechanizationConfig, Strapdown};
use core::fmt;

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
        };
        *n = n.saturating_add(1);
    }

    /// The counts with their names, in [`Unusable`]'s order.
    pub fn by_name(&self) -> [(&'static str, u32); 5] {
        [
            ("non-finite", self.non_finite),
            ("bad interval", self.bad_interval),
            ("stale", self.stale),
            ("device fault", self.device_fault),
            ("other", self.other),
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
        }
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
    /// Skipped for its flags (counted in `flagged`).
    Flagged,
    /// Refused by the input limits (counted in `rejected`).
    Rejected(InputError),
    /// Aligning: hand `message` to the background. With `await_reply`, it was the last
    /// alignment sample: deliver the background's answer ([`Navigator::on_background`])
    /// before the next sample.
    Forward {
        /// The message.
        message: ToBackground<T>,
        /// The foreground now waits for the background's answer.
        await_reply: bool,
    },
    /// Integrated; a solution row to log when the cadence says so.
    Navigated(Option<Solution>),
    /// Not taken (and not counted): the navigator waits for the background's answer, or the
    /// alignment failed. Deliver the answer, then push the sample again.
    NotReady,
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
}

impl fmt::Display for NavError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Alignment { samples, failure } => {
                write!(f, "alignment failed after {samples} samples: {failure}")
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
        }
    }
}

impl core::error::Error for NavError {}

/// The end of a run ([`Navigator::finish`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary<T: Scalar> {
    /// The final row to log (the last navigation step, unless it was already logged).
    pub final_row: Option<Solution>,
    /// The last solution logged (the final row, or the last row before it).
    pub last_solution: Solution,
    /// The counters.
    pub counters: Counters,
    /// The alignment's result.
    pub alignment: AlignOutcome<T>,
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
    /// The alignment failed.
    Failed(NavError),
}

/// The foreground half of the navigator (module docs): small, no allocation; the firmware's
/// `navigate` task owns one.
pub struct Navigator<T: Scalar> {
    compensation: ImuCompensation<T>,
    limits: InputLimits<T>,
    mechanization: MechanizationConfig<T>,
    log_every: u32,
    n_align: u32,
    phase: Phase<T>,
    counters: Counters,
    /// Increments forwarded to the alignment, and the time of the last one [us].
    forwarded: u32,
    last_forwarded_us: u64,
    /// Time of the last navigation step [us].
    last_step_us: u64,
    last_row: Option<Solution>,
    alignment: Option<AlignOutcome<T>>,
    /// [`Self::finish`] was called.
    finished: bool,
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
            phase: Phase::Aligning,
            counters: Counters::default(),
            forwarded: 0,
            last_forwarded_us: 0,
            last_step_us: 0,
            last_row: None,
            alignment: None,
            finished: false,
        }
    }

    /// Takes one sample (rules in the module docs).
    pub fn push(&mut self, input: &ImuInput) -> Step<T> {
        if matches!(self.phase, Phase::AwaitingAlignment | Phase::Failed(_)) {
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
            return Step::Flagged;
        }
        let inc = self.compensated(&input.increment);
        if let Err(e) = inc.check(&self.limits) {
            self.counters.rejected = self.counters.rejected.saturating_add(1);
            // As the strapdown does for an increment it refuses.
            self.restart_increments();
            return Step::Rejected(e);
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
                Step::Navigated(Some(self.logged(row)))
            }
            _ => {
                self.forwarded += 1;
                self.last_forwarded_us = input.t_us;
                let await_reply = self.forwarded >= self.n_align;
                if await_reply {
                    self.phase = Phase::AwaitingAlignment;
                }
                Step::Forward {
                    message: ToBackground::Align(inc),
                    await_reply,
                }
            }
        }
    }

    /// Takes the background's answer. Aligned: navigation starts from the alignment's state,
    /// and the row of that state at the time of the last alignment sample is returned (to log).
    /// Failed: the run ends with the error.
    pub fn on_background(
        &mut self,
        message: FromBackground<T>,
    ) -> Result<Option<Solution>, NavError> {
        match message {
            FromBackground::Aligned(outcome) => {
                if !matches!(self.phase, Phase::Aligning | Phase::AwaitingAlignment) {
                    return Ok(None);
                }
                let nav = Strapdown::new(outcome.state, self.mechanization);
                let row = Solution::from_state(self.last_forwarded_us, nav.state());
                self.phase = Phase::Navigating(nav);
                self.alignment = Some(outcome);
                Ok(Some(self.logged(row)))
            }
            FromBackground::AlignFailed { samples, failure } => {
                let e = NavError::Alignment { samples, failure };
                self.phase = Phase::Failed(e);
                Err(e)
            }
        }
    }

    /// [`Self::push`] with the background run in line on what it forwards (the harness's way;
    /// the firmware's tasks do the same across their channels): returns the row to log, if any.
    pub fn push_inline(
        &mut self,
        background: &mut Background<T>,
        input: &ImuInput,
    ) -> Result<Option<Solution>, NavError> {
        match self.push(input) {
            Step::Forward { message, .. } => match background.handle(message) {
                Some(answer) => self.on_background(answer),
                None => Ok(None),
            },
            Step::Navigated(row) => Ok(row),
            Step::NotReady => match self.phase {
                Phase::Failed(e) => Err(e),
                _ => Ok(None),
            },
            Step::Flagged | Step::Rejected(_) => Ok(None),
        }
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
        let nav = match &self.phase {
            Phase::Navigating(nav) => nav,
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
        let final_row = (!steps.is_multiple_of(self.log_every) && !self.finished)
            .then(|| Solution::from_state(self.last_step_us, nav.state()));
        self.finished = true;
        if let Some(row) = final_row {
            self.logged(row);
        }
        match (self.last_row, self.alignment) {
            (Some(last_solution), Some(alignment)) => Ok(Summary {
                final_row,
                last_solution,
                counters: self.counters,
                alignment,
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

    /// `true` once the last alignment increment is forwarded and the answer is still due.
    pub fn awaits_background(&self) -> bool {
        matches!(self.phase, Phase::AwaitingAlignment)
    }

    /// The alignment's result, once navigating.
    pub fn alignment(&self) -> Option<&AlignOutcome<T>> {
        self.alignment.as_ref()
    }

    /// The navigation state, once navigating.
    pub fn strapdown(&self) -> Option<&Strapdown<T>> {
        match &self.phase {
            Phase::Navigating(nav) => Some(nav),
            _ => None,
        }
    }

    fn restart_increments(&mut self) {
        if let Phase::Navigating(nav) = &mut self.phase {
            nav.restart_increments();
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

    fn logged(&mut self, row: Solution) -> Solution {
        self.counters.rows += 1;
        self.last_row = Some(row);
        row
    }
}
