//! Is the vehicle stopped? An IMU-only detector for zero-velocity and zero-angular-rate updates.
//!
//! Over windows of [`StationarityConfig::window_s`] the compensated specific force and rate are
//! averaged and their per-sample scatter compared with what the IMU's white noise alone gives
//! (`vrw^2 / dt` and `arw^2 / dt` per axis; a floor stands for vibration of a stopped engine);
//! the mean rate must be below [`StationarityConfig::max_rate_rad_s`] and the mean specific force
//! within [`StationarityConfig::max_gravity_error_mps2`] of gravity [Groves, §15.3.3, the
//! acceleration-magnitude and variance tests]. The rate and horizontal-force thresholds widen by
//! the filter's own 1-sigmas of what they measure ([`Uncertainty`]): a stop must be seen before
//! its zero-rate update can find a consumer gyro's bias. The magnitude test is blind to a horizontal
//! acceleration `a` (it sees `a^2 / 2g`: 0.002 m/s^2 of a 0.2 m/s^2 braking), so the mean
//! specific force is also levelled by the solution's attitude and its horizontal part held
//! below [`StationarityConfig::max_horizontal_specific_force_mps2`]: a vehicle easing to a stop
//! decelerates at some 0.3 m/s^2 while it still creeps at 0.2 m/s, without vibration or rate
//! that the other tests would see, and a zero velocity taken then (a 0.2 m/s innovation within
//! the gate of a filter whose velocity 1-sigma is 0.07 m/s) pulled its tilt by 0.2 deg and its
//! position by 0.9 m, after which the filter refused the true fixes and drifted by hundreds of
//! metres. A vehicle cruising straight at constant speed passes every test: the filter's
//! innovation gate, not the detector, refuses such a ZUPT.

use crate::Scalar;
use nalgebra::{UnitQuaternion, Vector3};

/// The detector's thresholds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StationarityConfig<T: Scalar> {
    /// Window length [s].
    pub window_s: T,
    /// Allowed ratio of the scatter's variance to the white noise's [-].
    pub noise_ratio: T,
    /// Variance floor of the specific force per axis [m^2/s^4].
    pub accel_floor_mps2_sq: T,
    /// Variance floor of the rate per axis [rad^2/s^2].
    pub gyro_floor_rad_s_sq: T,
    /// Largest mean rate [rad/s].
    pub max_rate_rad_s: T,
    /// Largest difference of the mean specific force's magnitude from gravity [m/s^2].
    pub max_gravity_error_mps2: T,
    /// Largest horizontal part of the mean specific force in the navigation frame [m/s^2]
    /// (levelled by the solution's attitude: a tilt error `e` reads `g e`).
    pub max_horizontal_specific_force_mps2: T,
    /// Consecutive still windows before the first update.
    pub windows_to_declare: u32,
}

impl<T: Scalar> Default for StationarityConfig<T> {
    /// 0.5 s windows, variance within 4x the noise's (floors 0.05 m/s^2 and 0.2 deg/s RMS),
    /// mean rate below 0.5 deg/s, specific force within 0.05 m/s^2 of gravity and its
    /// horizontal part below 0.1 m/s^2 (a tilt error up to 0.58 deg still passes a true stop;
    /// a vehicle easing to a stop passes once it decelerates below 0.1 m/s^2, some 0.05 m/s
    /// from standstill), two windows.
    fn default() -> Self {
        Self {
            window_s: T::c(0.5),
            noise_ratio: T::c(4.0),
            accel_floor_mps2_sq: T::c(0.05 * 0.05),
            gyro_floor_rad_s_sq: T::c(0.2f64.to_radians() * 0.2f64.to_radians()),
            max_rate_rad_s: T::c(0.5f64.to_radians()),
            max_gravity_error_mps2: T::c(0.05),
            max_horizontal_specific_force_mps2: T::c(0.1),
            windows_to_declare: 2,
        }
    }
}

/// How many 1-sigmas of the filter's own uncertainty the rate and horizontal-force tests allow
/// beyond their thresholds [-]: about the 99.9 % radius of a 3-axis error (4.03).
pub const UNCERTAINTY_SIGMAS: f64 = 4.0;

/// The filter's 1-sigmas the detector allows for ([`Stationarity::allow_for`]): the compensated
/// rate still holds the gyro-bias error, the levelled specific force the tilt and
/// accelerometer-bias errors (`g phi` plus the bias: at a stop their sum is what the zero
/// velocity sees, well known even while each alone is not). A consumer gyro's 0.5 deg/s
/// turn-on bias, or a tilt not yet levelled to 0.58 deg, would otherwise fail a true stop
/// until the zero-rate update that only a stop gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Uncertainty<T: Scalar> {
    /// Largest per-axis gyro-bias 1-sigma [rad/s].
    pub gyro_bias_rad_s: T,
    /// Largest 1-sigma of the levelled mean specific force's north and east components at a
    /// stop [m/s^2].
    pub horizontal_force_mps2: T,
}

impl<T: Scalar> Uncertainty<T> {
    /// None: the thresholds as configured.
    pub fn none() -> Self {
        Self {
            gyro_bias_rad_s: T::zero(),
            horizontal_force_mps2: T::zero(),
        }
    }

    /// Both figures finite and non-negative (anything else is taken as none).
    fn sane(self) -> Self {
        let ok = |v: T| v.finite() && v >= T::zero();
        if ok(self.gyro_bias_rad_s) && ok(self.horizontal_force_mps2) {
            self
        } else {
            Self::none()
        }
    }
}

/// A finished window that the detector found still: its mean compensated rate (for the
/// zero-angular-rate update) and its length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StillWindow<T: Scalar> {
    /// Mean `omega_ib_b` over the window [rad/s].
    pub omega_ib_b: Vector3<T>,
    /// Window length [s].
    pub duration_s: T,
}

/// Window sums of the compensated sensor outputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stationarity<T: Scalar> {
    config: StationarityConfig<T>,
    n: u32,
    t: T,
    /// The window's first outputs: the sums are of the differences from them, so the variance
    /// (mean square minus squared mean) does not cancel gravity's 96 m^2/s^4 in `f32`.
    ref_f: Vector3<T>,
    ref_w: Vector3<T>,
    sum_f: Vector3<T>,
    sum_f2: Vector3<T>,
    sum_w: Vector3<T>,
    sum_w2: Vector3<T>,
    still_windows: u32,
    uncertainty: Uncertainty<T>,
}

impl<T: Scalar> Stationarity<T> {
    /// A detector with no samples yet.
    pub fn new(config: StationarityConfig<T>) -> Self {
        Self {
            config,
            n: 0,
            t: T::zero(),
            ref_f: Vector3::zeros(),
            ref_w: Vector3::zeros(),
            sum_f: Vector3::zeros(),
            sum_f2: Vector3::zeros(),
            sum_w: Vector3::zeros(),
            sum_w2: Vector3::zeros(),
            still_windows: 0,
            uncertainty: Uncertainty::none(),
        }
    }

    /// The filter's current uncertainty, which the rate and horizontal-force tests allow
    /// [`UNCERTAINTY_SIGMAS`] times for from the next window end on.
    pub fn allow_for(&mut self, u: Uncertainty<T>) {
        self.uncertainty = u.sane();
    }

    /// True while the last windows were still (at least `windows_to_declare` of them).
    pub fn is_still(&self) -> bool {
        self.still_windows >= self.config.windows_to_declare
    }

    /// Forgets the current window and the still count (after a gap in the data).
    pub fn restart(&mut self) {
        *self = Self {
            uncertainty: self.uncertainty,
            ..Self::new(self.config)
        };
    }

    /// Adds one compensated sample: rate `omega_ib_b` [rad/s], specific force `f_ib_b`
    /// [m/s^2] over `dt` [s], `q_b_n` the solution's attitude after it (used at a window's
    /// end only, to level the mean specific force); `g` [m/s^2] local gravity, `arw`, `vrw`
    /// the noise densities. Returns the window when one ends still and the vehicle has been
    /// still long enough.
    #[allow(clippy::too_many_arguments)]
    pub fn add(
        &mut self,
        omega_ib_b: &Vector3<T>,
        f_ib_b: &Vector3<T>,
        q_b_n: &UnitQuaternion<T>,
        dt: T,
        g: T,
        arw: T,
        vrw: T,
    ) -> Option<StillWindow<T>> {
        self.add_with_gravity(omega_ib_b, f_ib_b, q_b_n, dt, || g, arw, vrw)
    }

    /// [`Self::add`] with the local gravity computed by `g()` at a window's end only, the
    /// one sample of a window that uses it (a mechanization's is a square root and three
    /// divisions: [`crate::earth::LocalEarth::from_sin_lat`]).
    #[allow(clippy::too_many_arguments)]
    pub fn add_with_gravity(
        &mut self,
        omega_ib_b: &Vector3<T>,
        f_ib_b: &Vector3<T>,
        q_b_n: &UnitQuaternion<T>,
        dt: T,
        g: impl FnOnce() -> T,
        arw: T,
        vrw: T,
    ) -> Option<StillWindow<T>> {
        if self.n == 0 {
            (self.ref_f, self.ref_w) = (*f_ib_b, *omega_ib_b);
        }
        self.n += 1;
        self.t += dt;
        let (d_f, d_w) = (f_ib_b - self.ref_f, omega_ib_b - self.ref_w);
        self.sum_f += d_f;
        self.sum_f2 += d_f.component_mul(&d_f);
        self.sum_w += d_w;
        self.sum_w2 += d_w.component_mul(&d_w);
        // Half a sample of slack: 100 steps of 5 ms sum to 0.49999997 s in `f32`, and the
        // window must end on the same sample in both precisions.
        if self.t + dt * T::c(0.5) < self.config.window_s {
            return None;
        }
        let n = T::c(f64::from(self.n));
        let dt_mean = self.t / n;
        // Means of the differences from the references (the variances' means).
        let (mean_df, mean_dw) = (self.sum_f / n, self.sum_w / n);
        let (mean_f, mean_w) = (self.ref_f + mean_df, self.ref_w + mean_dw);
        let c = &self.config;
        let var_ok = |sum2: &Vector3<T>, mean: &Vector3<T>, white: T, floor: T| {
            (0..3).all(|k| {
                let var = (sum2[k] / n - mean[k] * mean[k]).max(T::zero());
                var <= c.noise_ratio * white * white / dt_mean + floor
            })
        };
        // The mean specific force in the navigation frame: at a stop `-g_n`, whatever the
        // slope the vehicle stands on; a horizontal part is an acceleration (or a tilt error).
        let f_n = q_b_n * mean_f;
        let g = g();
        let k = T::c(UNCERTAINTY_SIGMAS);
        let u = &self.uncertainty;
        let still = var_ok(&self.sum_f2, &mean_df, vrw, c.accel_floor_mps2_sq)
            && var_ok(&self.sum_w2, &mean_dw, arw, c.gyro_floor_rad_s_sq)
            && mean_w.norm() <= c.max_rate_rad_s + k * u.gyro_bias_rad_s
            && (mean_f.norm() - g).abs() <= c.max_gravity_error_mps2
            && (f_n.x * f_n.x + f_n.y * f_n.y).sqrt()
                <= c.max_horizontal_specific_force_mps2 + k * u.horizontal_force_mps2;
        let window = StillWindow {
            omega_ib_b: mean_w,
            duration_s: self.t,
        };
        let still_windows = if still {
            self.still_windows.saturating_add(1)
        } else {
            0
        };
        self.restart();
        self.still_windows = still_windows;
        self.is_still().then_some(window)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn still_after_two_windows_and_not_when_turning_or_accelerating() {
        let mut d = Stationarity::<f64>::new(StationarityConfig::default());
        let g = 9.8;
        let level = UnitQuaternion::identity();
        let f = Vector3::new(0.0, 0.0, -g);
        let w = Vector3::new(5e-5, 0.0, -4e-5);
        let mut out = 0;
        for _ in 0..400 {
            if d.add(&w, &f, &level, 0.0025, g, 1e-4, 1e-3).is_some() {
                out += 1;
            }
        }
        // Windows end every 200 samples; the first still window only counts.
        assert_eq!(out, 1);
        assert!(d.is_still());
        // Turning at 2 deg/s.
        let turn = Vector3::new(0.0, 0.0, 2f64.to_radians());
        for _ in 0..400 {
            assert!(d.add(&turn, &f, &level, 0.0025, g, 1e-4, 1e-3).is_none());
        }
        assert!(!d.is_still());
        // Accelerating at 1.5 m/s^2 (the magnitude test sees 0.11 m/s^2 of it).
        let acc = Vector3::new(1.5, 0.0, -g);
        for _ in 0..400 {
            assert!(d.add(&w, &acc, &level, 0.0025, g, 1e-4, 1e-3).is_none());
        }
    }

    /// A gyro bias of 1 deg/s and a tilt error of 1 deg fail a stop without the filter's
    /// uncertainty and pass with it (0.5 deg/s, 0.2 m/s^2 1-sigmas), also after a restart; a
    /// non-finite allowance is none.
    #[test]
    fn the_thresholds_widen_by_the_filter_uncertainty() {
        let g = 9.8;
        let w = Vector3::new(0.0, 0.0, 1f64.to_radians());
        let tilted = UnitQuaternion::from_euler_angles(1f64.to_radians(), 0.0, 0.0);
        let f = Vector3::new(0.0, 0.0, -g);
        let run = |d: &mut Stationarity<f64>| {
            (0..800)
                .filter(|_| d.add(&w, &f, &tilted, 0.0025, g, 1e-4, 1e-3).is_some())
                .count()
        };
        let mut d = Stationarity::<f64>::new(StationarityConfig::default());
        assert_eq!(run(&mut d), 0);
        let u = Uncertainty {
            gyro_bias_rad_s: 0.5f64.to_radians(),
            horizontal_force_mps2: 0.2,
        };
        d.allow_for(u);
        assert_eq!(run(&mut d), 3);
        d.restart();
        assert_eq!(run(&mut d), 3);
        d.allow_for(Uncertainty {
            horizontal_force_mps2: f64::NAN,
            ..u
        });
        assert_eq!(run(&mut d), 0);
    }

    /// Easing to a stop: 0.2 m/s^2 of braking, level, with the specific force's magnitude
    /// exactly g (the magnitude test sees nothing) and no vibration, is not a stop; the
    /// vehicle standing on a 5 deg slope, pitched by it, is.
    #[test]
    fn braking_gently_is_not_still_and_a_slope_is() {
        let g = 9.8;
        let w = Vector3::new(5e-5, 0.0, -4e-5);
        let level = UnitQuaternion::identity();
        let braking = Vector3::new(-0.2, 0.0, -(g * g - 0.04_f64).sqrt());
        let mut d = Stationarity::<f64>::new(StationarityConfig::default());
        for _ in 0..800 {
            assert!(d.add(&w, &braking, &level, 0.0025, g, 1e-4, 1e-3).is_none());
        }
        assert!(!d.is_still());
        // Pitched up 5 deg on the slope: the body sees gravity tilted, the levelled mean none.
        let q_b_n = UnitQuaternion::from_euler_angles(0.0, 5f64.to_radians(), 30f64.to_radians());
        let f_ib_b = q_b_n.inverse() * Vector3::new(0.0, 0.0, -g);
        assert!(f_ib_b.x.abs() > 0.8);
        let mut out = 0;
        for _ in 0..400 {
            out += usize::from(d.add(&w, &f_ib_b, &q_b_n, 0.0025, g, 1e-4, 1e-3).is_some());
        }
        assert_eq!(out, 1);
    }

    /// The samples at which each precision's windows end and declare, on a still FOG-grade
    /// IMU at 200 Hz (noise 4 times below the test's level, a seeded pseudo-random sequence),
    /// and whether a vibration 3 times above the test's level is refused.
    fn declarations<T: Scalar>(vibration: f64) -> ([usize; 12], bool) {
        let mut d = Stationarity::<T>::new(StationarityConfig::default());
        let (dt, g, arw, vrw) = (0.005, 9.806_65, 1e-5, 5e-4);
        // The variance limit, c (vrw^2 / dt) + floor, as a standard deviation.
        let limit = (4.0 * vrw * vrw / dt + 0.05f64 * 0.05).sqrt();
        let mut state = 0x2545_f491_u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        // The samples that ended a still window (usize::MAX: none).
        let (mut at, mut n) = ([usize::MAX; 12], 0);
        for k in 0..1000 {
            // A uniform variable on [-0.5, 0.5] has a variance of 1/12.
            let s = 12f64.sqrt() * vibration * limit;
            let f = Vector3::new(s * uniform(), s * uniform(), -g + s * uniform());
            let w = Vector3::new(1e-5, 2e-5, -3e-5) + Vector3::repeat(arw * uniform());
            let c = |v: Vector3<f64>| v.map(T::c);
            let level = UnitQuaternion::identity();
            if d.add(
                &c(w),
                &c(f),
                &level,
                T::c(dt),
                T::c(g),
                T::c(arw),
                T::c(vrw),
            )
            .is_some()
            {
                at[n.min(11)] = k;
                n += 1;
            }
        }
        (at, d.is_still())
    }

    #[test]
    fn f32_windows_end_and_declare_on_the_samples_f64_does() {
        let (at64, still64) = declarations::<f64>(0.25);
        let (at32, still32) = declarations::<f32>(0.25);
        // Every 100th sample from the second window on.
        let expected: [usize; 12] =
            core::array::from_fn(|k| if k < 9 { 100 * k + 199 } else { usize::MAX });
        assert_eq!((at64, still64), (expected, true));
        assert_eq!((at32, still32), (at64, still64));
        for precision in [declarations::<f64>(3.0), declarations::<f32>(3.0)] {
            assert_eq!(precision, ([usize::MAX; 12], false));
        }
    }
}
