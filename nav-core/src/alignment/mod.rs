//! Initial alignment: finding the attitude before navigation starts.
//!
//! - [`analytic`]: static analytic (coarse) alignment — levelling from the mean specific force,
//!   heading by gyrocompassing the mean angular rate.
//! - [`fine`]: position-aided closed-loop fine alignment ([Vavilova et al.]) — an error-state
//!   Kalman filter (position, velocity, attitude, sensor biases) around the strapdown, fed the
//!   known position and zero velocity, its estimates fed back.
//! - [`inertial`]: inertial-frame coarse alignment — gravity observed in a frame frozen in
//!   inertial space; rocking base, no initial heading.
//! - [`level`]: level alignment on a rocking ship ([Ship alignment]) — a Kalman or constant-gain
//!   filter of the horizontal tilt from the lever-arm-compensated level-frame velocity.
//! - [`machine`]: the state machine `COARSE -> FINE -> ALIGNED` (or `FAILED`) that runs one of
//!   them as the firmware's alignment task and the harness's replay do.
//! - [`sway`]: base-motion-model fine alignment — a base still or swaying about a fixed mean
//!   attitude (identified roll and pitch oscillators): the heading from the gyro-integrated
//!   drift alone, below the general filter's floor.
//!
//! Every method takes increments one at a time (`add`) and solves when asked, so the firmware
//! can run it in a task below sampling and navigation.

pub mod analytic;
pub mod fine;
pub mod inertial;
mod kahan;
pub mod level;
pub mod machine;
pub mod stillness;
pub mod sway;

pub use analytic::{
    AlignError, AlignmentResult, EarthRateMismatch, GravityMismatch, StaticAlignment, samples_for,
};
pub use fine::{FineAlignment, FineConfig, FineStatus};
pub use inertial::{InertialAlignError, InertialAlignment, SensorNoise};
pub use level::{GainMode, LevelConfig, LevelConfigError, LevelFilter, LevelStatus};
pub use machine::{
    AlignFailure, AlignMethod, AlignNote, AlignOutcome, AlignSettings, Aligner, BaseMotion,
    LeverArm, Progress, SettingsError, Stage, StageTimes,
};
pub use sway::{SwayAlignment, SwayConfig, SwayStatus};

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
