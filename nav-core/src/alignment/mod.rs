//! Initial alignment: finding the attitude before navigation starts.
//!
//! - [`analytic`]: static analytic (coarse) alignment — levelling from the mean specific force,
//!   heading by gyrocompassing the mean angular rate.
//!
//! Every method takes increments one at a time (`add`) and solves when asked, so the firmware
//! can run it in a task below sampling and navigation.

pub mod analytic;
mod kahan;

pub use analytic::{AlignError, AlignmentResult, StaticAlignment, samples_for};

use crate::Scalar;
use nalgebra::{UnitQuaternion, Vector3};

/// An attitude with its uncertainty, as every alignment method reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttitudeEstimate<T: Scalar> {
    /// Body-to-NED attitude.
    pub q_b_n: UnitQuaternion<T>,
    /// 1-sigma uncertainty of roll, pitch and yaw [rad] (NaN where the method has no model of
    /// its own uncertainty).
    pub sigma_rad: Vector3<T>,
    /// Data used so far [s].
    pub elapsed_s: T,
}
