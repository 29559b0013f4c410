//! The navigation state the mechanization propagates.

use crate::{Position, Scalar, attitude};
use nalgebra::{UnitQuaternion, Vector3};

/// Attitude, velocity and position of the body. The navigation frame `n` is the local-level
/// frame described by the position (NED, or wander azimuth with the wander angle kept in
/// [`Position`]); [`NavState::ned`] gives the NED quantities either way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavState<T: Scalar> {
    /// Body (FRD) to navigation frame attitude `q_b_n`.
    pub q_b_n: UnitQuaternion<T>,
    /// Velocity of the body relative to the Earth in navigation axes `v_eb_n` [m/s].
    pub v_eb_n: Vector3<T>,
    /// Position and navigation-frame orientation (fixed point).
    pub position: Position,
}

impl<T: Scalar> NavState<T> {
    /// A body at rest at `position` with attitude `q_b_n` (relative to the position's frame:
    /// NED for [`Position::from_degrees`]).
    pub fn at_rest(position: Position, q_b_n: UnitQuaternion<T>) -> Self {
        Self {
            q_b_n,
            v_eb_n: Vector3::zeros(),
            position,
        }
    }

    /// NED attitude `q_b_ned` and velocity `v_eb_ned` [m/s]: the navigation-frame values turned
    /// by the wander angle `alpha` about down, `C_n_ned = Rz(alpha)`.
    pub fn ned(&self) -> (UnitQuaternion<T>, Vector3<T>) {
        let q_n_ned = attitude::about_z(T::c(self.position.wander_f64()));
        (q_n_ned * self.q_b_n, q_n_ned * self.v_eb_n)
    }

    /// The same state expressed in the NED frame (wander angle 0).
    pub fn to_ned_frame(&self) -> Self {
        let (q_b_n, v_eb_n) = self.ned();
        Self {
            q_b_n,
            v_eb_n,
            position: self.position.to_ned_frame(),
        }
    }

    /// Roll, pitch, yaw [rad] relative to NED (z-y-x Euler angles of `q_b_ned`).
    pub fn euler(&self) -> (T, T, T) {
        attitude::euler(&self.ned().0)
    }
}
