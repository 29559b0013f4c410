//! `nav-core`: the strapdown navigation core shared by the firmware (f32 on a Cortex-M4F) and the
//! host harness (f32 or f64).
//!
//! `#![no_std]`, no allocation, no I/O: it knows nothing of sensors, RTIC, files or std. Inputs are
//! IMU increments ([`ImuIncrement`]); outputs are a navigation state ([`NavState`]) and alignment
//! results. Frames and units follow Groves' notation: `c_b_n` rotates body (forward-right-down)
//! vectors into the local-level navigation frame (north-east-down), `omega_ib_b` is the body rate
//! relative to inertial space in body axes, `f_ib_b` is specific force. SI units throughout.
#![no_std]
#![deny(unsafe_code)]
// Units are written `[m/s]` in docs (project convention), which rustdoc would read as links.
#![allow(rustdoc::broken_intra_doc_links)]
#![warn(missing_docs)]
// `!(x <= limit)` is the NaN-safe idiom here: a NaN must fail every check, and `partial_cmp`
// spelled out would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod alignment;
pub mod attitude;
pub mod calibration;
pub mod coning;
pub mod earth;
pub mod gap;
pub mod increment;
pub mod ins_filter;
pub mod navigator;
pub mod number;
pub mod oscillator;
pub mod output;
pub mod poisson;
pub mod position;
pub mod scalar;
pub mod state;
pub mod strapdown;

pub use alignment::{AlignError, AlignmentResult, StaticAlignment};
pub use calibration::{ImuCalibration, ImuCompensation};
pub use increment::{ImuIncrement, InputError, InputLimits};
pub use output::Solution;
pub use poisson::DcmIntegrator;
pub use position::Position;
pub use scalar::Scalar;
pub use state::NavState;
pub use strapdown::{AttitudeMethod, MechanizationConfig, NavFrame, Strapdown, VerticalChannel};

/// Re-exported linear-algebra types used in the public API.
pub use nalgebra::{UnitQuaternion, Vector3};

/// The linear-algebra crate of the public API (so users share its exact version and features).
pub use nalgebra;
