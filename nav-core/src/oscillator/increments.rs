//! Oscillator epochs as IMU increments, so the unchanged mechanization navigates on them.
//!
//! Between epochs `k-1` and `k` the body turns by `C_b(k)^b(k-1) = C_b_e(k-1)^T C_b_e(k)`; its
//! rotation vector is the exact angle increment (not a gyro's integrated rate, so the
//! mechanization must run without the two-sample coning term: `coning_sculling = false`). The
//! velocity increment is the trapezoid of the body-axes specific force, what an accelerometer
//! would integrate, to which the mechanization adds its rotation compensation.

use super::OscillatorEpoch;
use crate::attitude::rotation_vector_of;
use crate::{ImuIncrement, Scalar};
use nalgebra::{UnitQuaternion, Vector3};

/// Turns a stream of epochs into increments.
#[derive(Clone, Copy, Debug, Default)]
pub struct OscillatorIncrements<T: Scalar> {
    last: Option<(f64, UnitQuaternion<T>, Vector3<T>)>,
}

impl<T: Scalar> OscillatorIncrements<T> {
    /// No epoch yet.
    pub fn new() -> Self {
        Self { last: None }
    }

    /// Forgets the last epoch (after a fault: the next increment would span the gap).
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// The increment from the last epoch to `e` (none for the first one).
    pub fn push(&mut self, e: &OscillatorEpoch<T>) -> Option<ImuIncrement<T>> {
        let out = self.last.map(|(t, q, f)| {
            let dt = e.t_s - t;
            ImuIncrement {
                delta_theta_ib_b: rotation_vector_of(&(q.inverse() * e.q_b_e)),
                delta_v_ib_b: (f + e.f_ib_b) * T::c(0.5 * dt),
                dt: T::c(dt),
            }
        });
        self.last = Some((e.t_s, e.q_b_e, e.f_ib_b));
        out
    }

    /// The last epoch's attitude `C_b_e`, if any.
    pub fn last_attitude(&self) -> Option<UnitQuaternion<T>> {
        self.last.map(|(_, q, _)| q)
    }
}
