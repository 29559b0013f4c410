//! The navigator's background half: the work that runs below sampling and navigation (the
//! firmware's `align` task), driven by messages from the foreground.

use super::setup::Setup;
use crate::Scalar;
use crate::alignment::{AlignFailure, AlignOutcome, AlignSettings, Aligner, Progress, Stage};
use crate::increment::ImuIncrement;

/// What the foreground hands to the background.
///
/// One variant per kind of work; a navigation filter adds its own (e.g. the navigation state to
/// propagate), answered by its own [`FromBackground`] variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToBackground<T: Scalar> {
    /// A compensated, checked increment for the alignment.
    Align(ImuIncrement<T>),
}

/// What the background answers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FromBackground<T: Scalar> {
    /// The alignment is done: navigation starts from this outcome's state.
    Aligned(AlignOutcome<T>),
    /// The alignment gave up.
    AlignFailed {
        /// Samples the alignment had used.
        samples: u32,
        /// Why.
        failure: AlignFailure,
    },
}

/// The background half: nav-core's [`Aligner`] on the forwarded increments (large: in the
/// firmware it lives in the `align` task, built there from the [`Setup`]).
pub struct Background<T: Scalar> {
    settings: AlignSettings<T>,
    aligner: Aligner<T>,
    answered: bool,
}

impl<T: Scalar> Background<T> {
    /// The background of a run of `setup`, at the start of the alignment.
    pub fn new(setup: &Setup<T>) -> Self {
        Self {
            settings: setup.align,
            aligner: Aligner::new(setup.align),
            answered: false,
        }
    }

    /// Does the work `message` asks for; returns the answer once there is one (each answer is
    /// given once; later alignment increments are ignored).
    pub fn handle(&mut self, message: ToBackground<T>) -> Option<FromBackground<T>> {
        match message {
            ToBackground::Align(inc) => {
                if self.answered {
                    return None;
                }
                let answer = match self.aligner.add(&inc) {
                    Progress::Coarse | Progress::Fine => None,
                    Progress::Aligned(outcome) => Some(FromBackground::Aligned(outcome)),
                    Progress::Failed(failure) => Some(FromBackground::AlignFailed {
                        samples: self.aligner.samples(),
                        failure,
                    }),
                };
                self.answered = answer.is_some();
                answer
            }
        }
    }

    /// The alignment's stage (for logs of stage changes).
    pub fn stage(&self) -> Stage {
        self.aligner.stage()
    }

    /// Samples the alignment has used.
    pub fn samples(&self) -> u32 {
        self.aligner.samples()
    }

    /// The alignment's settings.
    pub fn settings(&self) -> &AlignSettings<T> {
        &self.settings
    }
}
