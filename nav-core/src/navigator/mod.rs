//! The navigator: the one implementation of a run's rules, shared by the firmware's RTIC tasks
//! and the host harness's replay pipeline.
//!
//! It is split where the firmware splits its priorities:
//! - the FOREGROUND ([`Navigator`], the firmware's `navigate` task) takes every sample: the
//!   sample gate, the calibration, the counters, the strapdown mechanization, the logging
//!   cadence and the align -> navigate hand-over;
//! - the BACKGROUND ([`Background`], the firmware's low-priority `align` task) does the slow
//!   work: the alignment ([`Aligner`](crate::alignment::Aligner)), then, in an aided run, the
//!   navigation filter's covariance ([`ErrorFilter`](crate::ins_filter::ErrorFilter)). They
//!   talk by messages only: the foreground returns [`ToBackground`] messages to forward, the
//!   background answers with [`FromBackground`] messages, which the foreground takes in
//!   [`Navigator::on_background`].
//!
//! The firmware carries the messages over `rtic_sync` channels; the harness hands them over in
//! line ([`Navigator::push_inline`]), in the same order, so both reach bit-identical results.
//!
//! The rules (every one is part of the contract between firmware and harness):
//! - every sample counts in `samples`; a sample that is not usable (its source's flags) counts
//!   in `flagged`, and by its cause ([`Unusable`]) in `flagged_by`, and is skipped; an unusable sample or one after a gap restarts the
//!   strapdown's two-sample coning/sculling history;
//! - the increments are taken from `f32` exactly ([`Scalar::of_f32`](crate::Scalar::of_f32))
//!   with the sample's measured interval, then the calibration ([`ImuCompensation`]) is applied
//!   ONCE, before both the alignment and the mechanization (the strapdown itself gets an
//!   identity compensation);
//! - an increment failing [`ImuIncrement::check`] against the default [`InputLimits`] counts
//!   in `rejected` (navigating, it also restarts the two-sample history);
//! - a sample whose time is not after the last taken sample's is out of order
//!   ([`crate::gap`]): flagged ([`Unusable::OutOfOrder`]), skipped, and the history restarted;
//!   the time such samples covered is lost time before the next taken sample (bridged, or lost
//!   beyond [`MAX_BRIDGED_S`](crate::gap::MAX_BRIDGED_S));
//! - aligning: the accepted increments go to the background; after the `n_align`-th (the
//!   alignment's sample count, [`samples_for`](crate::alignment::samples_for)) the foreground
//!   waits for the background's answer: aligned, navigation starts from the alignment's state,
//!   and that state is logged at the time of the last alignment sample; failed, the run ends;
//! - navigating: every `log_every`-th navigation step is logged; at the end, the last step is
//!   logged unless it already was, and the log's last line is the end record
//!   ([`Summary::end_record`]);
//! - a run fails, with the counts by cause, when the data end during the alignment or when not
//!   one navigation step follows it (every later sample flagged or rejected, or none).
//!
//! GNSS-aided runs ([`RunConfig::aiding`]): after the alignment the foreground runs the
//! filter's mechanization ([`AidedMechanization`](crate::ins_filter::AidedMechanization):
//! NED frame, the estimated sensor errors compensated) from the alignment's state, and the
//! background the filter's covariance ([`ErrorFilter`](crate::ins_filter::ErrorFilter)),
//! started from the alignment's 1-sigmas and the noise model's sensor errors
//! ([`initial_sigma`]). Per navigation step, the work goes over as messages
//! ([`Navigator::next_message`]) in the order [`AidedIns`](crate::ins_filter::AidedIns) runs
//! it in line:
//! - a stop's zero-velocity and zero-rate updates ([`ToBackground::Still`]), the propagation
//!   of the increments accumulated so far first ([`ToBackground::Propagate`]);
//! - a full propagation interval's [`ToBackground::Propagate`];
//! - every GNSS fix due at the sample (handed over by [`Navigator::push_fix`] before the
//!   first sample at or after its time, held and timed by
//!   [`FixQueue`](crate::ins_filter::sequencer::FixQueue), the rule the sequencer uses too):
//!   the propagation so far, [`ToBackground::Position`], then, with the position's estimate
//!   fed back, [`ToBackground::Velocity`];
//! - where a row is due, [`ToBackground::Report`]: the row is the state after the sample's
//!   updates with the filter's 1-sigmas and status ([`crate::output::Row::Aided`], under
//!   [`crate::output::AIDED_CSV_HEADER`]).
//!
//! Propagations are not answered; updates and reports are, and their answers are delivered
//! before the next sample (the firmware's `navigate` task waits for them; the background is
//! below it, so the work still runs at the background's priority, and the data-ready
//! interrupt keeps filling the sample channel meanwhile). Every estimate is thus fed back at
//! a defined sample, the same in the firmware and the harness. At the end,
//! [`Navigator::end_of_data`] asks for the last step's row and report. Fixes handed over
//! outside the aided phase count in [`Counters::fixes_unused`].
//!
//! The aided phase re-aligns in motion as the sequencer does ([`crate::ins_filter::sequencer`],
//! the same rule and the same code: [`MotionAlign`], [`Restart`]), after a gap in the IMU data
//! too long to bridge ([`crate::gap::MAX_BRIDGED_S`]: DEGRADED, IMU_LOST, from the first sample
//! after it) at the first fix after it, or once a GNSS update's answer says the filter diverged
//! ([`FromBackground::Updated`]`::diverged`, checked after the sample's fixes): the filter is
//! set aside (its mechanization and covariance go on free-inertial, fixes withheld, its rows
//! and [`Navigator::filter_status`] DEGRADED) and the foreground feeds the fixes and the
//! samples to a start in motion; once level and heading are known it sends
//! [`ToBackground::Restart`] (after the propagation so far when the sensor block is kept), the
//! background restarts the filter from the start with what [`Restart::carried`] says (after a
//! lost gap the sensor errors' estimates and covariance, after a divergence the counters
//! only), and with its answer the foreground's mechanization restarts (NAV once the 1-sigma is
//! within the limits). A lost gap during a re-alignment starts it over. The protocol has no
//! stage of its own for it: DEGRADED with the set-aside filter's flags until the restart.
//! [`Summary::realignments`] counts them.
//!
//! The run's settings are one plain [`RunConfig`] (the CLI's and the firmware's arguments),
//! checked and converted for the data's rate into a [`Setup`] from which both halves are built.
//!
//! [`ImuCompensation`]: crate::calibration::ImuCompensation
//! [`MotionAlign`]: crate::ins_filter::motion::MotionAlign
//! [`Restart`]: crate::ins_filter::restart::Restart
//! [`Restart::carried`]: crate::ins_filter::restart::Restart::carried
//! [`ImuIncrement::check`]: crate::increment::ImuIncrement::check
//! [`InputLimits`]: crate::increment::InputLimits

mod background;
pub mod config;
mod foreground;
mod setup;
#[cfg(test)]
mod tests;

pub use background::{
    Background, FilterReport, FromBackground, SIGMA_FLOORS, ToBackground, initial_sigma,
};
pub use config::{
    AIDED_COMPILED_IN, AidingConfig, ConfigError, MechanizationChoices, OptionError, RunConfig,
    SensorFigures,
};
pub use foreground::{
    Counters, FlaggedCounts, ImuInput, NavError, Navigator, Step, Summary, Unusable,
};
pub use setup::Setup;
