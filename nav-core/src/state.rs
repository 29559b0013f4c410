//! The navigation state the mechanization propagates.

use crate::{Position, Scalar, attitude};
use nalgebra::{UnitQuaternion, Vector3};

/// Attitude, velocity and position of the body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavState<T: Scalar> {
    /// Body (FRD) to navigation (NED) attitude `q_b_n`.
    pub q_b_n: UnitQuaternion<T>,
    /// Velocity of the body relative to the Earth, NED axes `v_eb_n` [m/s].
    pub v_eb_n: Vector3<T>,
    /// Geodetic position (fixed point).
    pub position: Position,
}

impl<T: Scalar> NavState<T> {
    /// A body at rest at `position` with attitude `q_b_n`.
    pub fn at_rest(position: Position, q_b_n: UnitQuaternion<T>) -> Self {
        Self {
            q_b_n,
            v_eb_n: Vector3::zeros(),
            position,
        }
    }

    /// Roll, pitch, yaw [rad] (z-y-x Euler angles of `q_b_n`).
    pub fn euler(&self) -> (T, T, T) {
        attitude::euler(&self.q_b_n)
    }
}
