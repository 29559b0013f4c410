//! Attitude helpers: rotation-vector quaternion update and Euler angles.
//!
//! Euler angles are the aerospace z-y-x sequence: `c_b_n = Rz(yaw) Ry(pitch) Rx(roll)` with NED
//! navigation axes and FRD body axes (Groves eq. 2.22; Titterton & Weston eq. 3.47).

use crate::Scalar;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// The quaternion of a rotation vector `phi` [rad]: `q = [cos(|phi|/2), sin(|phi|/2) phi/|phi|]`
/// (Savage (7.1.2-20); Groves eq. 5.75). Exact for any angle, so the attitude update is exact for
/// a constant body rate. Up to [`Scalar::ROTATION_SERIES_MAX2`] the Taylor series of
/// `cos(x/2)` and `sin(x/2)/x` to `x^6` is used: exact to the working precision, no
/// trigonometry (the `f32` libm functions run in soft double precision on a Cortex-M4F), and
/// accurate for tiny angles.
#[inline]
pub fn rotation_vector_quat<T: Scalar>(phi: &Vector3<T>) -> UnitQuaternion<T> {
    let (w, s) = rotation_vector_terms(phi.norm_squared());
    UnitQuaternion::new_unchecked(Quaternion::new(
        T::one() + w,
        phi.x * s,
        phi.y * s,
        phi.z * s,
    ))
}

/// `(cos(a/2) - 1, sin(a/2)/a)` for `a2 = a^2` [rad^2]; the first term without cancellation,
/// so `q(phi) - 1` stays accurate for tiny angles.
#[inline]
pub fn rotation_vector_terms<T: Scalar>(a2: T) -> (T, T) {
    if a2 < T::c(T::ROTATION_SERIES_MAX2) {
        // cos(a/2) - 1 = -a^2/8 + a^4/384 - a^6/46080
        // sin(a/2)/a = 1/2 - a^2/48 + a^4/3840 - a^6/645120
        let c = a2 * (T::c(-1.0 / 8.0) + a2 * (T::c(1.0 / 384.0) + a2 * T::c(-1.0 / 46080.0)));
        let s = T::c(0.5)
            + a2 * (T::c(-1.0 / 48.0) + a2 * (T::c(1.0 / 3840.0) + a2 * T::c(-1.0 / 645_120.0)));
        (c, s)
    } else {
        let a = a2.sqrt();
        let quarter = a * T::c(0.25);
        let sq = quarter.psin();
        // cos(a/2) - 1 = -2 sin^2(a/4)
        (T::c(-2.0) * sq * sq, (a * T::c(0.5)).psin() / a)
    }
}

/// The rotation vector [rad] of `q` (the inverse of [`rotation_vector_quat`]): angle
/// `2 atan2(|v|, w)` about `v/|v|`, with `q` taken in the hemisphere `w >= 0` (angle <= pi).
#[inline]
pub fn rotation_vector_of<T: Scalar>(q: &UnitQuaternion<T>) -> Vector3<T> {
    let (w, v) = if q.w < T::zero() {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let s = v.norm();
    if s < T::c(1e-3) {
        // 2 atan2(s, w)/s = (2/w)(1 - s^2/(3 w^2) + ...): no division by a tiny `s`.
        let x2 = s * s / (w * w);
        v * (T::c(2.0) / w * (T::one() - x2 * (T::c(1.0 / 3.0) - x2 * T::c(0.2))))
    } else {
        v * (T::c(2.0) * s.patan2(w) / s)
    }
}

/// `q` rounded to the working scalar.
pub fn quat_from_f64<T: Scalar>(q: &UnitQuaternion<f64>) -> UnitQuaternion<T> {
    UnitQuaternion::new_unchecked(Quaternion::from(q.quaternion().coords.map(T::c)))
}

/// `q` widened to `f64` (exact).
pub fn quat_to_f64<T: Scalar>(q: &UnitQuaternion<T>) -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(Quaternion::from(q.quaternion().coords.map(T::to_f64)))
}

/// Roll, pitch and yaw [rad] of `q_b_n` (yaw in (-pi, pi]); Titterton & Weston eq. 3.66 in
/// quaternion form. Within the working precision of pitch +-90 deg, where roll and yaw are
/// not separately defined (their `atan2` arguments, `cos(pitch)` times the rest, are
/// rounding errors there: in `f32` an attitude 67.6 deg wrong came out), roll is 0 and yaw
/// carries the rotation about the vertical, `yaw -+ roll`, from `C_01` and `C_11`.
#[inline]
pub fn euler<T: Scalar>(q_b_n: &UnitQuaternion<T>) -> (T, T, T) {
    euler_to_precision(q_b_n, T::default_epsilon())
}

/// [`euler`] of a quaternion computed to the relative precision `eps` (an `f32` attitude
/// widened to `f64`: its rounding, not `f64`'s, decides where roll and yaw are undefined; an
/// IMU standing on end came out roll 0, yaw 0 where its yaw minus roll was 28.5 deg). Near
/// pitch +-90 the pitch is `atan2(sin, cos)` with `cos = |(C_21, C_22)|`: the `asin` of a sine
/// within rounding of 1 gave 89.97 deg for 90.
#[inline]
pub fn euler_to_precision<T: Scalar>(q_b_n: &UnitQuaternion<T>, eps: T) -> (T, T, T) {
    let (w, x, y, z) = (q_b_n.w, q_b_n.i, q_b_n.j, q_b_n.k);
    let (one, two) = (T::one(), T::c(2.0));
    let (c21, c22) = (two * (w * x + y * z), one - two * (x * x + y * y));
    let sin_pitch = (two * (w * y - z * x)).max(-one).min(one);
    let cos2_pitch = c21 * c21 + c22 * c22;
    if cos2_pitch < eps {
        let yaw = (two * (w * z - x * y)).patan2(one - two * (x * x + z * z));
        return (T::zero(), sin_pitch.patan2(cos2_pitch.sqrt()), yaw);
    }
    let roll = c21.patan2(c22);
    let yaw = (two * (w * z + x * y)).patan2(one - two * (y * y + z * z));
    (roll, sin_pitch.pasin(), yaw)
}

/// `q_b_n` from roll, pitch and yaw [rad]: `q = q_z(yaw) q_y(pitch) q_x(roll)`.
#[inline]
pub fn from_euler<T: Scalar>(roll: T, pitch: T, yaw: T) -> UnitQuaternion<T> {
    let half = T::c(0.5);
    let (sr, cr) = ((roll * half).psin(), (roll * half).pcos());
    let (sp, cp) = ((pitch * half).psin(), (pitch * half).pcos());
    let (sy, cy) = ((yaw * half).psin(), (yaw * half).pcos());
    UnitQuaternion::new_unchecked(Quaternion::new(
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ))
}

/// The rotation by `angle` [rad] about the z axis (down in a local-level frame).
#[inline]
pub fn about_z<T: Scalar>(angle: T) -> UnitQuaternion<T> {
    let half = angle * T::c(0.5);
    UnitQuaternion::new_unchecked(Quaternion::new(
        half.pcos(),
        T::zero(),
        T::zero(),
        half.psin(),
    ))
}

/// The rotation by `angle` [rad] about the y axis.
#[inline]
pub fn about_y<T: Scalar>(angle: T) -> UnitQuaternion<T> {
    let half = angle * T::c(0.5);
    UnitQuaternion::new_unchecked(Quaternion::new(
        half.pcos(),
        T::zero(),
        half.psin(),
        T::zero(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// At pitch +-90 deg in `f32` (and next to it) the angles describe the attitude they came
    /// from: roll and yaw are not defined separately there, their combination is (was: an
    /// attitude 67.6 deg off, roll and yaw from rounding errors).
    #[test]
    fn the_angles_at_vertical_describe_the_attitude() {
        for pitch_deg in [90.0f32, -90.0, 89.99, -89.995] {
            for (roll_deg, yaw_deg) in [(-7.6f32, 22.4), (40.0, -130.0), (0.0, 179.0)] {
                let [r, p, y] = [roll_deg, pitch_deg, yaw_deg].map(f32::to_radians);
                let q = from_euler(r, p, y);
                let (r2, p2, y2) = euler(&q);
                let back = from_euler(r2, p2, y2);
                let off_deg = back.angle_to(&q).to_degrees();
                assert!(
                    off_deg < 0.05,
                    "({roll_deg}, {pitch_deg}, {yaw_deg}) deg: {off_deg} deg off"
                );
            }
        }
        // Away from vertical the angles are the ones given.
        let (r, p, y) = euler(&from_euler(0.3f32, 1.2, -2.0));
        assert!((r - 0.3).abs() < 1e-5 && (p - 1.2).abs() < 1e-5 && (y + 2.0).abs() < 1e-5);
    }

    /// An `f32` attitude widened to `f64` (the solution rows' and the alignment line's path):
    /// `f64`'s singular band is far inside the `f32` quaternion's rounding, so an IMU on end
    /// came out roll 0, pitch 89.97, yaw 0 where its yaw minus roll was 28.5 deg (28.5 deg
    /// off). With the `f32` band, the angles describe the attitude, and the pitch is within
    /// rounding of 90 deg, not 0.03 deg short.
    #[test]
    fn widened_f32_angles_at_vertical_describe_the_attitude() {
        for pitch_deg in [90.0f32, -90.0, 89.999, -89.9999] {
            for (roll_deg, yaw_deg) in [(1.5f32, 30.0), (-40.0, 130.0), (0.0, -179.0)] {
                let [r, p, y] = [roll_deg, pitch_deg, yaw_deg].map(f32::to_radians);
                let q = quat_to_f64(&from_euler(r, p, y));
                let (r2, p2, y2) = euler_to_precision(&q, f64::from(f32::EPSILON));
                let off_deg = from_euler(r2, p2, y2).angle_to(&q).to_degrees();
                let what = (roll_deg, pitch_deg, yaw_deg);
                assert!(off_deg < 0.01, "{what:?} deg: {off_deg} deg off");
                let pitch_err = (p2.to_degrees() - f64::from(pitch_deg)).abs();
                assert!(pitch_err < 0.005, "{what:?} deg: pitch {pitch_err} deg off");
                // In f64's own band the audit's case was off by its yaw minus roll.
                let (r3, p3, y3) = euler(&q);
                if what == (1.5, 90.0, 30.0) {
                    let off = from_euler(r3, p3, y3).angle_to(&q).to_degrees();
                    assert!(off > 1.0, "{what:?} deg: {off} deg");
                }
            }
        }
    }

    #[test]
    fn constant_rate_is_exact_in_many_steps() {
        // 400 steps of a constant rate compose to the single rotation of the total angle.
        let omega = Vector3::new(0.3, -1.1, 2.0_f64);
        let dt = 0.0025;
        let mut q = UnitQuaternion::identity();
        for _ in 0..400 {
            q *= rotation_vector_quat(&(omega * dt));
        }
        let exact = UnitQuaternion::from_scaled_axis(omega * 1.0);
        assert!(q.angle_to(&exact) < 1e-12, "{}", q.angle_to(&exact));
    }

    proptest! {
        #[test]
        fn matches_axis_angle(x in -3.0..3.0_f64, y in -3.0..3.0_f64, z in -3.0..3.0_f64, s in -12i32..0) {
            let phi = Vector3::new(x, y, z) * 10f64.powi(s);
            let q = rotation_vector_quat(&phi);
            prop_assert!((q.norm() - 1.0).abs() < 1e-14);
            prop_assert!(q.angle_to(&UnitQuaternion::from_scaled_axis(phi)) < 1e-14);
        }

        #[test]
        fn euler_round_trip(r in -3.1..3.1_f64, p in -1.5..1.5_f64, y in -3.1..3.1_f64) {
            let (r2, p2, y2) = euler(&from_euler(r, p, y));
            prop_assert!((r - r2).abs() < 1e-9 && (p - p2).abs() < 1e-9 && (y - y2).abs() < 1e-9);
            // The same convention as nalgebra's (R = Rz Ry Rx).
            let q = from_euler(r, p, y);
            prop_assert!(q.angle_to(&UnitQuaternion::from_euler_angles(r, p, y)) < 1e-12);
            prop_assert!(about_z(y).angle_to(&UnitQuaternion::from_euler_angles(0.0, 0.0, y)) < 1e-12);
            prop_assert!(about_y(p).angle_to(&UnitQuaternion::from_euler_angles(0.0, p, 0.0)) < 1e-12);
        }
    }
}
