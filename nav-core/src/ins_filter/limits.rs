//! The range of the figures any IMU can have: a noise figure or an initial 1-sigma beyond it is
//! a typing or unit error (deg for rad, deg/h for rad/s), refused before the filter starts
//! rather than left to overflow its covariance. The bounds are generous: each is ten to
//! thousands of times a consumer MEMS part's figure.

use super::SensorErrors;
use super::model::FilterNoise;
use super::states::InitialSigma;
use crate::Scalar;
use nalgebra::Vector3;

/// Largest gyro angle random walk [rad/sqrt(s)] (about 340 deg/sqrt(h): hundreds of times a
/// consumer MEMS gyro's).
pub const MAX_ARW_RAD_PER_SQRT_S: f64 = 0.1;

/// Smallest gyro angle random walk an IMU's configuration may state [rad/sqrt(s)] (about
/// 3.4e-6 deg/sqrt(h), a thirtieth of a strategic-grade gyro's): below it a figure is a zero
/// written otherwise, which makes the alignment filters overconfident. The aided filter's own
/// check allows 0, an ideal IMU's.
pub const MIN_ARW_RAD_PER_SQRT_S: f64 = 1e-9;

/// Smallest accelerometer velocity random walk an IMU's configuration may state
/// [m/s/sqrt(s)] (about 1 ng/sqrt(Hz), a thousandth of a navigation-grade accelerometer's), as
/// [`MIN_ARW_RAD_PER_SQRT_S`].
pub const MIN_VRW_MPS_PER_SQRT_S: f64 = 1e-8;

/// Largest accelerometer velocity random walk [m/s/sqrt(s)] (about 1 g/sqrt(Hz): thousands
/// of times a consumer MEMS accelerometer's).
pub const MAX_VRW_MPS_PER_SQRT_S: f64 = 10.0;

/// Largest gyro bias 1-sigma [rad/s] (about 6 deg/s: ten times a consumer MEMS gyro's
/// turn-on bias).
pub const MAX_GYRO_BIAS_RAD_S: f64 = 0.1;

/// Largest accelerometer bias 1-sigma [m/s^2] (about 1 g: fifty times a consumer MEMS
/// accelerometer's turn-on bias).
pub const MAX_ACCEL_BIAS_MPS2: f64 = 10.0;

/// Largest scale-factor error 1-sigma [-] (10 %: twenty times a consumer MEMS part's).
pub const MAX_SCALE: f64 = 0.1;

/// Largest cross-axis coupling or g-sensitivity 1-sigma [rad, rad/s per m/s^2] (0.1 rad is
/// about 6 deg of misalignment; 0.1 rad/s per m/s^2 about 56 deg/s/g).
pub const MAX_COUPLING: f64 = 0.1;

/// Shortest correlation time of the Gauss–Markov sensor errors [s]: one second, ten
/// propagation intervals at the default rate; a shorter one is white noise, not a bias.
pub const MIN_CORRELATION_TIME_S: f64 = 1.0;

/// Shortest correlation time of the gyro bias instability [s]: a shorter Gauss–Markov process
/// is white noise at the propagation's rate (give it in the ARW).
pub const MIN_BIAS_INSTABILITY_TIME_S: f64 = 0.1;

/// Largest GNSS correlated-error 1-sigma [m] (a code receiver's is metres; beyond this the
/// fixes are not worth taking).
pub const MAX_GNSS_ERROR_SIGMA_M: f64 = 100.0;

/// Correlation times of the GNSS correlated error [s]: from a second (a shorter one is white
/// noise at 1 Hz fixes: give it in the fixes' 1-sigma) to a day.
pub const GNSS_ERROR_TIME_S: (f64, f64) = (1.0, 86_400.0);

/// Largest initial position 1-sigma [m] (the Earth's radius: a start anywhere).
pub const MAX_POSITION_SIGMA_M: f64 = 6.4e6;

/// Largest initial velocity 1-sigma [m/s] (orbital speed).
pub const MAX_VELOCITY_SIGMA_M_S: f64 = 8000.0;

/// Largest initial attitude 1-sigma [rad] (a full turn: the heading unknown).
pub const MAX_ATTITUDE_SIGMA_RAD: f64 = core::f64::consts::TAU;

/// Which figure is out of range, with its range (the refusal's text).
pub fn noise_out_of_range<T: Scalar>(n: &FilterNoise<T>) -> Option<&'static str> {
    let within = sigma_within::<T>;
    if !within(n.arw_rad_per_sqrt_s, MAX_ARW_RAD_PER_SQRT_S) {
        Some("the gyro ARW must be 0 to 0.1 rad/sqrt(s) (340 deg/sqrt(h))")
    } else if !within(n.vrw_mps_per_sqrt_s, MAX_VRW_MPS_PER_SQRT_S) {
        Some("the accelerometer VRW must be 0 to 10 m/s/sqrt(s) (600 m/s/sqrt(h))")
    } else if !within(n.gyro_bias_rad_s, MAX_GYRO_BIAS_RAD_S) {
        Some("the gyro bias 1-sigma must be 0 to 0.1 rad/s (20,600 deg/h)")
    } else if !within(n.accel_bias_mps2, MAX_ACCEL_BIAS_MPS2) {
        Some("the accelerometer bias 1-sigma must be 0 to 10 m/s^2 (1,000,000 mGal)")
    } else if let Some(why) = figures_out_of_range(
        [n.gyro_scale, n.accel_scale],
        [
            n.gyro_cross_coupling_rad,
            n.accel_cross_coupling_rad,
            n.gyro_g_sensitivity,
        ],
    ) {
        Some(why)
    } else if !(within(n.gyro_bias_instability_rad_s, MAX_GYRO_BIAS_RAD_S)
        && n.gyro_bias_instability_time_s.finite()
        && n.gyro_bias_instability_time_s >= T::zero()
        && (n.gyro_bias_instability_rad_s == T::zero()
            || n.gyro_bias_instability_time_s.to_f64() >= MIN_BIAS_INSTABILITY_TIME_S))
    {
        Some(
            "the gyro bias instability 1-sigma must be 0 to 0.1 rad/s, its correlation time finite and at least 0.1 s",
        )
    } else if !(n.correlation_time_s.finite()
        && n.correlation_time_s.to_f64() >= MIN_CORRELATION_TIME_S)
    {
        Some("the correlation time must be finite and at least 1 s")
    } else {
        None
    }
}

/// The refusal of a scale-factor 1-sigma out of range ([`figures_out_of_range`]).
pub const SCALE_SIGMA_OUT_OF_RANGE: &str = "a scale-factor 1-sigma must be 0 to 0.1 (100,000 ppm)";

/// The refusal of a cross-coupling or g-sensitivity 1-sigma out of range
/// ([`figures_out_of_range`]).
pub const COUPLING_SIGMA_OUT_OF_RANGE: &str =
    "a cross-coupling or g-sensitivity 1-sigma must be 0 to 0.1 (rad, rad/s per m/s^2)";

/// Why an IMU's scale-factor 1-sigmas `scale` [-] (gyro, accelerometer) or its
/// cross-coupling and g-sensitivity 1-sigmas `coupling` (gyro, accelerometer [rad]; gyro
/// g-sensitivity [rad/s per m/s^2]) are out of range (the refusal's text).
pub fn figures_out_of_range<T: Scalar>(scale: [T; 2], coupling: [T; 3]) -> Option<&'static str> {
    if !scale.iter().all(|v| sigma_within(*v, MAX_SCALE)) {
        Some(SCALE_SIGMA_OUT_OF_RANGE)
    } else if !coupling.iter().all(|v| sigma_within(*v, MAX_COUPLING)) {
        Some(COUPLING_SIGMA_OUT_OF_RANGE)
    } else {
        None
    }
}

/// Why a declared GNSS correlated error is out of range (the refusal's text).
pub fn gnss_error_out_of_range<T: Scalar>(
    g: &super::consider::GnssCorrelatedError<T>,
) -> Option<&'static str> {
    let t = g.correlation_time_s;
    if !g
        .sigma_ned_m
        .iter()
        .all(|v| sigma_within(*v, MAX_GNSS_ERROR_SIGMA_M))
    {
        Some("the GNSS correlated-error 1-sigma must be 0 to 100 m per axis")
    } else if !(t.finite()
        && t.to_f64() >= GNSS_ERROR_TIME_S.0
        && t.to_f64() <= GNSS_ERROR_TIME_S.1)
    {
        Some("the GNSS correlated error's correlation time must be 1 s to 86,400 s")
    } else {
        None
    }
}

/// Which initial 1-sigma is out of range, with its range (the refusal's text).
pub fn initial_sigma_out_of_range<T: Scalar>(s: &InitialSigma<T>) -> Option<&'static str> {
    let within = |v: &Vector3<T>, max: f64| v.iter().all(|x| sigma_within(*x, max));
    if !within(&s.position_ned_m, MAX_POSITION_SIGMA_M) {
        Some("the initial position 1-sigma must be 0 to 6,400 km")
    } else if !within(&s.velocity_ned_m_s, MAX_VELOCITY_SIGMA_M_S) {
        Some("the initial velocity 1-sigma must be 0 to 8000 m/s")
    } else if !within(&s.attitude_rad, MAX_ATTITUDE_SIGMA_RAD) {
        Some("the initial attitude 1-sigma must be 0 to 360 deg")
    } else if !within(&s.gyro_bias_rad_s, MAX_GYRO_BIAS_RAD_S) {
        Some("the initial gyro bias 1-sigma must be 0 to 0.1 rad/s (20,600 deg/h)")
    } else if !within(&s.accel_bias_mps2, MAX_ACCEL_BIAS_MPS2) {
        Some("the initial accelerometer bias 1-sigma must be 0 to 10 m/s^2 (1,000,000 mGal)")
    } else if !(within(&s.gyro_scale, MAX_SCALE) && within(&s.accel_scale, MAX_SCALE)) {
        Some("an initial scale-factor 1-sigma must be 0 to 0.1 (100,000 ppm)")
    } else {
        None
    }
}

/// A 1-sigma or noise figure `v` within `[0, max]` (and finite).
fn sigma_within<T: Scalar>(v: T, max: f64) -> bool {
    v.finite() && v >= T::zero() && v.to_f64() <= max * F32_ROUNDING
}

/// A bound's allowance for the figures' carried precision, f32 [-]: a figure typed as the
/// bound `0.1` reads as 0.10000000149 in f32, beyond the f64 bound, and the documented bound
/// itself was refused. Half an f32 epsilon of the bound (f32 rounds within it) lets it through,
/// and no f32 beyond it.
const F32_ROUNDING: f64 = 1.0 + f32::EPSILON as f64 * 0.5;

/// Which known sensor error at the start is out of range (the same bounds as the 1-sigmas,
/// on its magnitude), with its range (the refusal's text).
pub fn sensor_errors_out_of_range<T: Scalar>(e: &SensorErrors<T>) -> Option<&'static str> {
    let within = |v: &Vector3<T>, max: f64| {
        v.iter()
            .all(|x| x.finite() && x.to_f64().abs() <= max * F32_ROUNDING)
    };
    if !within(&e.gyro_bias_rad_s, MAX_GYRO_BIAS_RAD_S) {
        Some("the initial gyro bias must be within +-0.1 rad/s (20,600 deg/h)")
    } else if !within(&e.accel_bias_mps2, MAX_ACCEL_BIAS_MPS2) {
        Some("the initial accelerometer bias must be within +-10 m/s^2 (1,000,000 mGal)")
    } else if !(within(&e.gyro_scale, MAX_SCALE) && within(&e.accel_scale, MAX_SCALE)) {
        Some("an initial scale-factor error must be within +-0.1 (100,000 ppm)")
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A change of one figure and the name its refusal must carry.
    type Case<S> = (fn(&mut S), &'static str);

    fn noise() -> FilterNoise<f64> {
        FilterNoise {
            arw_rad_per_sqrt_s: 1e-4,
            vrw_mps_per_sqrt_s: 1e-3,
            gyro_bias_rad_s: 1e-5,
            accel_bias_mps2: 1e-3,
            gyro_scale: 1e-4,
            accel_scale: 1e-4,
            correlation_time_s: 3600.0,
            gyro_cross_coupling_rad: 1e-3,
            accel_cross_coupling_rad: 1e-3,
            gyro_g_sensitivity: 1e-5,
            gyro_bias_instability_rad_s: 1e-5,
            gyro_bias_instability_time_s: 5.0,
        }
    }

    fn sigma() -> InitialSigma<f64> {
        InitialSigma {
            position_ned_m: Vector3::repeat(1.0),
            velocity_ned_m_s: Vector3::repeat(0.1),
            attitude_rad: Vector3::new(0.01, 0.01, core::f64::consts::PI),
            gyro_bias_rad_s: Vector3::repeat(1e-5),
            accel_bias_mps2: Vector3::repeat(1e-3),
            gyro_scale: Vector3::repeat(1e-4),
            accel_scale: Vector3::repeat(1e-4),
        }
    }

    /// Each figure beyond its range (a unit slip: deg/h given as rad/s, hours as seconds)
    /// is named; zero, the range's end and a tactical part's figures pass.
    #[test]
    fn each_figure_beyond_its_range_is_named() {
        assert_eq!(noise_out_of_range(&noise()), None);
        let cases: [Case<FilterNoise<f64>>; 12] = [
            (|n| n.arw_rad_per_sqrt_s = 0.15, "ARW"),
            (|n| n.vrw_mps_per_sqrt_s = f64::NAN, "VRW"),
            (|n| n.gyro_bias_rad_s = 10.0, "gyro bias"),
            (|n| n.accel_bias_mps2 = -1e-3, "accelerometer bias"),
            (|n| n.gyro_scale = 300.0, "scale-factor"),
            (|n| n.accel_scale = f64::INFINITY, "scale-factor"),
            (|n| n.gyro_cross_coupling_rad = 1.0, "cross-coupling"),
            (|n| n.correlation_time_s = 1e-300, "correlation time"),
            (
                |n| n.gyro_bias_instability_rad_s = -1e-6,
                "bias instability",
            ),
            (
                |n| n.gyro_bias_instability_time_s = 0.01,
                "bias instability",
            ),
            (
                |n| n.gyro_bias_instability_time_s = f64::NAN,
                "bias instability",
            ),
            (|n| n.correlation_time_s = f64::INFINITY, "correlation time"),
        ];
        for (set, name) in cases {
            let mut n = noise();
            set(&mut n);
            let why = noise_out_of_range(&n).unwrap_or_else(|| panic!("{name} passed"));
            assert!(why.contains(name), "{name}: {why}");
        }
        let mut n = noise();
        n.arw_rad_per_sqrt_s = MAX_ARW_RAD_PER_SQRT_S;
        n.gyro_bias_rad_s = 0.0;
        n.correlation_time_s = MIN_CORRELATION_TIME_S;
        assert_eq!(noise_out_of_range(&n), None);

        assert_eq!(initial_sigma_out_of_range(&sigma()), None);
        let cases: [Case<InitialSigma<f64>>; 6] = [
            (|s| s.position_ned_m.x = 1e30, "position"),
            (|s| s.velocity_ned_m_s.z = 1e5, "velocity"),
            (|s| s.attitude_rad.z = 180.0, "attitude"),
            (|s| s.gyro_bias_rad_s.y = -1e-5, "gyro bias"),
            (|s| s.accel_bias_mps2.x = f64::NAN, "accelerometer bias"),
            (|s| s.accel_scale.x = 2.0, "scale-factor"),
        ];
        for (set, name) in cases {
            let mut s = sigma();
            set(&mut s);
            let why = initial_sigma_out_of_range(&s).unwrap_or_else(|| panic!("{name} passed"));
            assert!(why.contains(name), "{name}: {why}");
        }
    }

    /// A known start bias or scale factor beyond any IMU's (deg/h given as rad/s) is named.
    #[test]
    fn known_sensor_errors_beyond_an_imu_are_named() {
        let ok = SensorErrors::<f64> {
            gyro_bias_rad_s: Vector3::new(-0.01, 0.0, 0.01),
            accel_bias_mps2: Vector3::new(0.2, -0.2, 0.0),
            gyro_scale: Vector3::new(-0.005, 0.0, 0.005),
            accel_scale: Vector3::repeat(-0.01),
        };
        assert_eq!(sensor_errors_out_of_range(&ok), None);
        let mut e = ok;
        e.gyro_bias_rad_s.x = -1e6;
        assert!(sensor_errors_out_of_range(&e).is_some_and(|w| w.contains("gyro bias")));
        let mut e = ok;
        e.accel_bias_mps2.z = 11.0;
        assert!(sensor_errors_out_of_range(&e).is_some_and(|w| w.contains("accelerometer")));
        let mut e = ok;
        e.accel_scale.y = -1e6;
        assert!(sensor_errors_out_of_range(&e).is_some_and(|w| w.contains("scale")));
    }

    /// The f32 filter takes the same ranges.
    #[test]
    fn the_ranges_hold_in_f32() {
        let n = FilterNoise::<f32> {
            arw_rad_per_sqrt_s: 0.2,
            vrw_mps_per_sqrt_s: 1e-3,
            gyro_bias_rad_s: 1e-5,
            accel_bias_mps2: 1e-3,
            gyro_scale: 1e-4,
            accel_scale: 1e-4,
            correlation_time_s: 3600.0,
            gyro_cross_coupling_rad: 0.0,
            accel_cross_coupling_rad: 0.0,
            gyro_g_sensitivity: 0.0,
            gyro_bias_instability_rad_s: 0.0,
            gyro_bias_instability_time_s: 0.0,
        };
        assert!(noise_out_of_range(&n).is_some_and(|w| w.contains("ARW")));
    }

    /// The documented bounds are accepted in f32 as typed (`0.1` reads as 0.10000000149 in
    /// f32, which widened to f64 was beyond 0.1 and refused); the next f32 beyond is refused.
    #[test]
    fn the_bounds_themselves_pass_in_f32() {
        let (scale, coupling) = (MAX_SCALE as f32, MAX_COUPLING as f32);
        assert_eq!(
            figures_out_of_range([scale, scale], [coupling, coupling, coupling]),
            None
        );
        let beyond = f32::from_bits(scale.to_bits() + 1);
        assert_eq!(
            figures_out_of_range([beyond, 0.0], [0.0; 3]),
            Some(SCALE_SIGMA_OUT_OF_RANGE)
        );
        assert_eq!(
            figures_out_of_range([0.0; 2], [0.0, 0.0, beyond]),
            Some(COUPLING_SIGMA_OUT_OF_RANGE)
        );
        let mut e = SensorErrors::<f32> {
            gyro_bias_rad_s: Vector3::repeat(-(MAX_GYRO_BIAS_RAD_S as f32)),
            accel_bias_mps2: Vector3::zeros(),
            gyro_scale: Vector3::repeat(scale),
            accel_scale: Vector3::repeat(-scale),
        };
        assert_eq!(sensor_errors_out_of_range(&e), None);
        e.gyro_scale.z = beyond;
        assert!(sensor_errors_out_of_range(&e).is_some());
    }
}
