//! Euler-angle uncertainty: the map between a navigation-frame small rotation and roll, pitch,
//! yaw changes, and the 1-sigma of each angle from an attitude-error covariance.

use crate::{Scalar, attitude};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The map `A` from a navigation-frame small rotation `rho` [rad] (`C' = exp([rho x]) C`) to the
/// changes of roll, pitch and yaw [rad] of `C = q_b_n` (z-y-x Euler angles):
/// `rho' = R_z(-yaw) rho`, `d_roll = rho'_x / cos(pitch)`, `d_pitch = rho'_y`,
/// `d_yaw = rho'_z + tan(pitch) rho'_x` (Titterton & Weston eq. 3.52 inverted).
pub fn euler_jacobian<T: Scalar>(q_b_n: &UnitQuaternion<T>) -> Matrix3<T> {
    let (_, pitch, yaw) = attitude::euler(q_b_n);
    let (sy, cy) = (yaw.psin(), yaw.pcos());
    let cp = pitch.pcos().max(T::c(1e-6));
    let tp = pitch.psin() / cp;
    let rz = Matrix3::new(
        cy,
        sy,
        T::zero(),
        -sy,
        cy,
        T::zero(),
        T::zero(),
        T::zero(),
        T::one(),
    );
    let b = Matrix3::new(
        T::one() / cp,
        T::zero(),
        T::zero(),
        T::zero(),
        T::one(),
        T::zero(),
        tp,
        T::zero(),
        T::one(),
    );
    b * rz
}

/// 1-sigma roll, pitch, yaw [rad] of an attitude whose navigation-frame error covariance is
/// `p_att` [rad^2] ([`euler_jacobian`]).
pub fn euler_sigma<T: Scalar>(q_b_n: &UnitQuaternion<T>, p_att: &Matrix3<T>) -> Vector3<T> {
    let a = euler_jacobian(q_b_n);
    let s = a * p_att * a.transpose();
    Vector3::new(s[(0, 0)], s[(1, 1)], s[(2, 2)]).map(|v| v.max(T::zero()).sqrt())
}

/// Navigation-frame error covariance [rad^2] of independent roll, pitch and yaw errors of
/// 1-sigma `sigma_rad` at attitude `q_b_n`: `M diag(sigma^2) M^T`, `M` the inverse of
/// [`euler_jacobian`], `M = R_z(yaw) [[cos(pitch), 0, 0], [0, 1, 0], [-sin(pitch), 0, 1]]`.
pub fn phi_covariance<T: Scalar>(q_b_n: &UnitQuaternion<T>, sigma_rad: &Vector3<T>) -> Matrix3<T> {
    let (_, pitch, yaw) = attitude::euler(q_b_n);
    let (sy, cy) = (yaw.psin(), yaw.pcos());
    let (sp, cp) = (pitch.psin(), pitch.pcos());
    let rz = Matrix3::new(
        cy,
        -sy,
        T::zero(),
        sy,
        cy,
        T::zero(),
        T::zero(),
        T::zero(),
        T::one(),
    );
    let b_inv = Matrix3::new(
        cp,
        T::zero(),
        T::zero(),
        T::zero(),
        T::one(),
        T::zero(),
        -sp,
        T::zero(),
        T::one(),
    );
    let m = rz * b_inv;
    let d = Matrix3::from_diagonal(&sigma_rad.component_mul(sigma_rad));
    m * d * m.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_euler;

    #[test]
    fn euler_jacobian_matches_finite_differences() {
        let q = from_euler(0.07, -0.05, 1.05_f64);
        let a = euler_jacobian(&q);
        let (r0, p0, y0) = attitude::euler(&q);
        for k in 0..3 {
            let mut rho = Vector3::zeros();
            rho[k] = 1e-7;
            let (r, p, y) = attitude::euler(&(attitude::rotation_vector_quat(&rho) * q));
            let d = Vector3::new(r - r0, p - p0, y - y0) / 1e-7;
            assert!((d - a.column(k)).norm() < 1e-6, "{k}: {d} {}", a.column(k));
        }
        // phi_covariance is the inverse map: A M = I.
        let p = phi_covariance(&q, &Vector3::new(1.0, 2.0, 3.0));
        let s = euler_sigma(&q, &p);
        assert!((s - Vector3::new(1.0, 2.0, 3.0)).norm() < 1e-12, "{s}");
    }
}
