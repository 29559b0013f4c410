//! The navigator's background half: the work that runs below sampling and navigation (the
//! firmware's `align` task), driven by messages from the foreground: the alignment, then, in
//! an aided run, the navigation filter's covariance ([`ErrorFilter`]: propagation and updates).

use super::config::AIDED_COMPILED_IN;
use super::setup::Setup;
use crate::NavState;
use crate::Scalar;
use crate::alignment::{AlignFailure, AlignOutcome, AlignSettings, Aligner, Progress, Stage};
use crate::increment::ImuIncrement;
use crate::ins_filter::latency::LatencyEstimate;
use crate::ins_filter::restart::Restart;
use crate::ins_filter::stationarity::StillWindow;
use crate::ins_filter::stationarity::Uncertainty;
use crate::ins_filter::{
    Correction, ErrorFilter, FilterConfig, FilterCounters, FilterError, FilterStatus, GnssPosition,
    GnssVelocity, InitialSigma, POS, Propagation, Snapshot, VEL,
};
use nalgebra::{UnitQuaternion, Vector3};

/// What the foreground hands to the background.
///
/// Aligning, the increments; in the aided phase, the filter's work: propagations (not
/// answered) and updates (each answered with [`FromBackground::Updated`] before the foreground
/// takes its next sample), and a request for the filter's [`FilterReport`] where a row is
/// logged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToBackground<T: Scalar> {
    /// A compensated, checked increment for the alignment.
    Align(ImuIncrement<T>),
    /// Propagate the covariance over the increments accumulated since the last propagation.
    Propagate(Propagation<T>),
    /// A GNSS position fix of the antenna taken `lag_s` [s] before the snapshot's sample.
    Position {
        /// The solution at the sample that applies the fix.
        snapshot: Snapshot<T>,
        /// The fix.
        fix: GnssPosition<T>,
        /// Its lag behind the sample [s].
        lag_s: T,
    },
    /// A GNSS velocity of the antenna taken `lag_s` [s] before the snapshot's sample (sent
    /// after the same fix's position update has been fed back, as
    /// [`AidedIns`](crate::ins_filter::AidedIns) does).
    Velocity {
        /// The solution at the sample that applies the fix, the position update fed back.
        snapshot: Snapshot<T>,
        /// The fix's velocity.
        fix: GnssVelocity<T>,
        /// Its lag behind the sample [s].
        lag_s: T,
    },
    /// A still window ended: zero-velocity and zero-rate updates.
    Still {
        /// The solution at the window's last sample.
        snapshot: Snapshot<T>,
        /// The window.
        window: StillWindow<T>,
    },
    /// A re-alignment in motion found its start ([`crate::ins_filter::restart`]): the filter
    /// restarts from it in place of the one set aside (its covariance brought up to the
    /// sample first), taking over what [`Restart::carried`] says.
    Restart {
        /// The start.
        start: Restart<T>,
        /// Its state as the foreground's new mechanization took it.
        mech_state: NavState<T>,
        /// Gravity at its position [m/s^2].
        gravity_mps2: T,
    },
    /// The filter's 1-sigmas and status for a row, the Euler angles' at the attitude `q_b_n`.
    Report {
        /// The solution's attitude.
        q_b_n: UnitQuaternion<T>,
    },
}

impl<T: Scalar> ToBackground<T> {
    /// True for the messages the background answers (the foreground waits for the answer
    /// before its next sample).
    pub fn is_answered(&self) -> bool {
        !matches!(self, Self::Align(_) | Self::Propagate(_))
    }
}

/// The filter's uncertainty and health, for the rows and the summary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterReport<T: Scalar> {
    /// 1-sigma of position north, east, down [m].
    pub sigma_ned_m: Vector3<T>,
    /// 1-sigma of velocity north, east, down [m/s].
    pub sigma_v_ned_m_s: Vector3<T>,
    /// 1-sigma of roll, pitch, yaw [rad].
    pub sigma_att_rad: Vector3<T>,
    /// The health.
    pub status: FilterStatus,
    /// The aids' counters.
    pub counters: FilterCounters,
    /// Times the covariance lost a positive variance and was reset to its diagonal.
    pub covariance_faults: u32,
    /// The test of the fixes' time tags ([`crate::ins_filter::latency`]).
    pub gnss_latency: LatencyEstimate<T>,
    /// The learnt scales of the position and velocity fixes' declared noise variances, now
    /// and their largest [-] ([`crate::ins_filter::noise_scale`]).
    pub noise_scales: [[T; 2]; 2],
}

impl<T: Scalar> FilterReport<T> {
    /// The report of a filter, the Euler angles' 1-sigma at the attitude `q_b_n`.
    pub fn of(filter: &ErrorFilter<T>, q_b_n: &UnitQuaternion<T>) -> Self {
        Self {
            sigma_ned_m: filter.sigma(POS),
            sigma_v_ned_m_s: filter.sigma(VEL),
            sigma_att_rad: filter.attitude_sigma_rad(q_b_n),
            status: filter.status(),
            counters: *filter.counters(),
            covariance_faults: filter.covariance_faults(),
            gnss_latency: filter.gnss_latency(),
            noise_scales: filter.noise_scales(),
        }
    }
}

/// What the background answers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FromBackground<T: Scalar> {
    /// The alignment is done: navigation starts from this outcome's state (in an aided run,
    /// the filter has started from its 1-sigmas, [`initial_sigma`]).
    Aligned(AlignOutcome<T>),
    /// The alignment gave up.
    AlignFailed {
        /// Samples the alignment had used.
        samples: u32,
        /// Why.
        failure: AlignFailure,
    },
    /// The alignment is done but the filter cannot start from its outcome.
    FilterFailed(FilterError),
    /// An update's outcome.
    Updated {
        /// The estimate to feed back (`None`: the measurement was refused, counted in the
        /// filter's counters).
        correction: Option<Correction<T>>,
        /// After a GNSS update: the filter has diverged beyond what its fixes can bring back
        /// ([`ErrorFilter::diverged`]; the foreground sets it aside and re-aligns in motion).
        diverged: bool,
    },
    /// The filter restarted ([`ToBackground::Restart`]): the stop detector's allowance
    /// ([`Uncertainty`]), or `None` when the start was refused (not finite): the filter set
    /// aside goes on.
    Restarted(Option<Uncertainty<T>>),
    /// The filter's report ([`ToBackground::Report`]).
    Report(FilterReport<T>),
}

/// 1-sigma floors of the filter's start (position [m], velocity [m/s], attitude [rad]): an
/// alignment may hand over an exactly known value (at rest, no lever arm), whose zero variance
/// the filter would take for a covariance fault.
pub const SIGMA_FLOORS: [f64; 3] = [1e-3, 1e-3, 1e-6];

/// The filter's start uncertainty from an alignment's outcome: its position, velocity and
/// attitude 1-sigmas (floored at [`SIGMA_FLOORS`]), the sensor errors' `config`'s start ones
/// ([`FilterConfig::start_sensor_sigma`]).
pub fn initial_sigma<T: Scalar>(
    outcome: &AlignOutcome<T>,
    config: &FilterConfig<T>,
) -> InitialSigma<T> {
    let floor = |v: &Vector3<T>, f: f64| v.map(|x| if x < T::c(f) { T::c(f) } else { x });
    InitialSigma::new(
        floor(&outcome.position_sigma_m, SIGMA_FLOORS[0]),
        floor(&outcome.velocity_sigma_m_s, SIGMA_FLOORS[1]),
        floor(&outcome.estimate.sigma_rad, SIGMA_FLOORS[2]),
        &config.start_sensor_sigma(),
    )
}

/// A GNSS update's answer: `update`'s correction, and whether the filter has diverged after it.
fn gnss_updated<T: Scalar>(
    filter: Option<&mut ErrorFilter<T>>,
    update: impl FnOnce(&mut ErrorFilter<T>) -> Option<Correction<T>>,
) -> FromBackground<T> {
    match filter {
        Some(f) => FromBackground::Updated {
            correction: update(f),
            diverged: f.diverged(),
        },
        None => FromBackground::Updated {
            correction: None,
            diverged: false,
        },
    }
}

/// What the background holds: the aligner, then the filter in its place (the two are never
/// needed together, and on the MCU the aligner is the largest piece of RAM, kept on the
/// `align` task's stack: the filter costs none of its own). The size difference is the point:
/// no boxing.
#[allow(clippy::large_enum_variant)]
enum Work<T: Scalar> {
    /// Aligning (or the alignment answered, free inertial).
    Aligning(Aligner<T>),
    /// The navigation filter, started from the alignment (its samples kept for the logs).
    Filtering {
        /// The filter.
        filter: ErrorFilter<T>,
        /// Samples the alignment used.
        aligned_samples: u32,
    },
}

/// The background half: nav-core's [`Aligner`] on the forwarded increments (large: in the
/// firmware it lives in the `align` task, built there from the [`Setup`]), then, in an aided
/// run, the [`ErrorFilter`] started from the alignment's outcome, in the aligner's place.
pub struct Background<T: Scalar> {
    settings: AlignSettings<T>,
    work: Work<T>,
    answered: bool,
    filter_config: Option<FilterConfig<T>>,
}

impl<T: Scalar> Background<T> {
    /// The background of a run of `setup`, at the start of the alignment.
    pub fn new(setup: &Setup<T>) -> Self {
        Self {
            settings: setup.align,
            work: Work::Aligning(Aligner::new(setup.align)),
            answered: false,
            filter_config: setup.filter,
        }
    }

    /// Does the work `message` asks for; returns the answer once there is one (each
    /// alignment answer is given once; later alignment increments are ignored). Every
    /// message [`ToBackground::is_answered`] is answered.
    pub fn handle(&mut self, message: ToBackground<T>) -> Option<FromBackground<T>> {
        match message {
            ToBackground::Align(inc) => self.align(&inc),
            filter_work => self.filter_work(filter_work),
        }
    }

    /// The navigation filter's work. Not inlined: its matrices (some 10 KB of temporaries in a
    /// propagation) must not sit in the stack frame under the alignment's deepest path (the
    /// fine stage's filters, [`Self::align`]).
    #[inline(never)]
    fn filter_work(&mut self, message: ToBackground<T>) -> Option<FromBackground<T>> {
        let filter = match &mut self.work {
            // Not entered without the aided filter: the constant leaves its work out.
            Work::Filtering { filter, .. } if AIDED_COMPILED_IN => Some(filter),
            Work::Filtering { .. } | Work::Aligning(_) => None,
        };
        match message {
            ToBackground::Align(inc) => self.align(&inc),
            ToBackground::Propagate(p) => {
                if let Some(f) = filter {
                    f.propagate(&p);
                }
                None
            }
            ToBackground::Position {
                snapshot,
                fix,
                lag_s,
            } => Some(gnss_updated(filter, |f| {
                f.position(&snapshot, &fix, lag_s).1
            })),
            ToBackground::Velocity {
                snapshot,
                fix,
                lag_s,
            } => Some(gnss_updated(filter, |f| {
                f.velocity(&snapshot, &fix, lag_s).1
            })),
            ToBackground::Still { snapshot, window } => Some(FromBackground::Updated {
                correction: filter.and_then(|f| f.zero_motion(&snapshot, &window).2),
                diverged: false,
            }),
            ToBackground::Restart {
                start,
                mech_state,
                gravity_mps2,
            } => Some(FromBackground::Restarted(filter.and_then(|f| {
                let config = self.filter_config?;
                let restarted = start.filter(config, Some(f), &mech_state, gravity_mps2);
                restarted.ok().map(|r| {
                    *f = r;
                    f.uncertainty()
                })
            }))),
            ToBackground::Report { q_b_n } => match filter {
                Some(f) => Some(FromBackground::Report(FilterReport::of(f, &q_b_n))),
                // Not reached: the foreground asks only once the filter runs.
                None => Some(FromBackground::FilterFailed(FilterError::BadState)),
            },
        }
    }

    /// The alignment's step.
    fn align(&mut self, inc: &ImuIncrement<T>) -> Option<FromBackground<T>> {
        let Work::Aligning(aligner) = &mut self.work else {
            return None;
        };
        if self.answered {
            return None;
        }
        let answer = match aligner.add(inc) {
            Progress::Coarse | Progress::Fine => None,
            Progress::Aligned(outcome) => Some(self.start_filter(outcome)),
            Progress::Failed(failure) => Some(FromBackground::AlignFailed {
                samples: aligner.samples(),
                failure,
            }),
        };
        self.answered = answer.is_some();
        answer
    }

    /// The aligned answer, the filter started from the outcome in an aided run. Not inlined:
    /// the filter's start (its covariance built, then moved in) must not add its temporaries
    /// to [`Self::align`]'s frame, under the fine stage's deepest path.
    #[inline(never)]
    fn start_filter(&mut self, outcome: AlignOutcome<T>) -> FromBackground<T> {
        let Some(config) = self.filter_config.filter(|_| AIDED_COMPILED_IN) else {
            return FromBackground::Aligned(outcome);
        };
        let yaw = outcome.state.euler().2;
        match ErrorFilter::new(&initial_sigma(&outcome, &config), yaw, config) {
            Ok(filter) => {
                // The aligner is done: the filter takes its place (written in place).
                let aligned_samples = self.samples();
                self.work = Work::Filtering {
                    filter,
                    aligned_samples,
                };
                FromBackground::Aligned(outcome)
            }
            Err(e) => FromBackground::FilterFailed(e),
        }
    }

    /// The alignment's stage (for logs of stage changes).
    pub fn stage(&self) -> Stage {
        match &self.work {
            Work::Aligning(a) => a.stage(),
            Work::Filtering { .. } => Stage::Aligned,
        }
    }

    /// Samples the alignment has used.
    pub fn samples(&self) -> u32 {
        match &self.work {
            Work::Aligning(a) => a.samples(),
            Work::Filtering {
                aligned_samples, ..
            } => *aligned_samples,
        }
    }

    /// The alignment's settings.
    pub fn settings(&self) -> &AlignSettings<T> {
        &self.settings
    }

    /// The navigation filter, once it runs.
    pub fn filter(&self) -> Option<&ErrorFilter<T>> {
        match &self.work {
            Work::Filtering { filter, .. } => Some(filter),
            Work::Aligning(_) => None,
        }
    }
}
