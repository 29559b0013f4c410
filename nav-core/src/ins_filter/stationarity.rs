//! Is the vehicle stopped? An IMU-only detector for zero-velocity and zero-angular-rate updates.
//!
//! Over windows of [`StationarityConfig::window_s`] the compensated specific force and rate are
//! averaged and their per-sample scatter compared with what the IMU's white noise alone gives
//! (`vrw^2 / dt` and `arw^2 / dt` per axis; a floor stands for vibration of a stopped engine);
//! the mean rate must be below [`StationarityConfig::max_rate_rad_s`] and the mean specific force
//! within [`StationarityConfig::max_gravity_error_mps2`] of gravity [Groves, §15.3.3, the
//! acceleration-magnitude and variance tests]. A vehicle cruising straight at constant speed
//! passes the same tests: the filter's innovation gate, not the detector, refuses such a ZUPT.

use crate::Scalar;
use nalgebra::Vector3;

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
    /// Consecutive still windows before the first update.
    pub windows_to_declare: u32,
}

impl<T: Scalar> Default for StationarityConfig<T> {
    /// 0.5 s windows, variance within 4x the noise's (floors 0.05 m/s^2 and 0.2 deg/s RMS),
    /// mean rate below 0.5 deg/s, specific force within 0.05 m/s^2 of gravity, two windows.
    fn default() -> Self {
        Self {
            window_s: T::c(0.5),
            noise_ratio: T::c(4.0),
            accel_floor_mps2_sq: T::c(0.05 * 0.05),
            gyro_floor_rad_s_sq: T::c(0.2f64.to_radians() * 0.2f64.to_radians()),
            max_rate_rad_s: T::c(0.5f64.to_radians()),
            max_gravity_error_mps2: T::c(0.05),
            windows_to_declare: 2,
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
    sum_f: Vector3<T>,
    sum_f2: Vector3<T>,
    sum_w: Vector3<T>,
    sum_w2: Vector3<T>,
    still_windows: u32,
}

impl<T: Scalar> Stationarity<T> {
    /// A detector with no samples yet.
    pub fn new(config: StationarityConfig<T>) -> Self {
        Self {
            config,
            n: 0,
            t: T::zero(),
            sum_f: Vector3::zeros(),
            sum_f2: Vector3::zeros(),
            sum_w: Vector3::zeros(),
            sum_w2: Vector3::zeros(),
            still_windows: 0,
        }
    }

    /// True while the last windows were still (at least `windows_to_declare` of them).
    pub fn is_still(&self) -> bool {
        self.still_windows >= self.config.windows_to_declare
    }

    /// Forgets the current window and the still count (after a gap in the data).
    pub fn restart(&mut self) {
        *self = Self::new(self.config);
    }

    /// Adds one compensated sample: rate `omega_ib_b` [rad/s], specific force `f_ib_b`
    /// [m/s^2] over `dt` [s]; `g` [m/s^2] local gravity, `arw`, `vrw` the noise densities.
    /// Returns the window when one ends still and the vehicle has been still long enough.
    pub fn add(
        &mut self,
        omega_ib_b: &Vector3<T>,
        f_ib_b: &Vector3<T>,
        dt: T,
        g: T,
        arw: T,
        vrw: T,
    ) -> Option<StillWindow<T>> {
        self.n += 1;
        self.t += dt;
        self.sum_f += f_ib_b;
        self.sum_f2 += f_ib_b.component_mul(f_ib_b);
        self.sum_w += omega_ib_b;
        self.sum_w2 += omega_ib_b.component_mul(omega_ib_b);
        if self.t < self.config.window_s {
            return None;
        }
        let n = T::c(f64::from(self.n));
        let dt_mean = self.t / n;
        let mean_f = self.sum_f / n;
        let mean_w = self.sum_w / n;
        let c = &self.config;
        let var_ok = |sum2: &Vector3<T>, mean: &Vector3<T>, white: T, floor: T| {
            (0..3).all(|k| {
                let var = (sum2[k] / n - mean[k] * mean[k]).max(T::zero());
                var <= c.noise_ratio * white * white / dt_mean + floor
            })
        };
        let still = var_ok(&self.sum_f2, &mean_f, vrw, c.accel_floor_mps2_sq)
            && var_ok(&self.sum_w2, &mean_w, arw, c.gyro_floor_rad_s_sq)
            && mean_w.norm() <= c.max_rate_rad_s
            && (mean_f.norm() - g).abs() <= c.max_gravity_error_mps2;
        let window = StillWindow {
            omega_ib_b: mean_w,
            duration_s: self.t,
        };
        let still_windows = if still {
            self.still_windows.saturating_add(1)
        } else {
            0
        };
        *self = Self::new(self.config);
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
        let f = Vector3::new(0.0, 0.0, -g);
        let w = Vector3::new(5e-5, 0.0, -4e-5);
        let mut out = 0;
        for _ in 0..400 {
            if d.add(&w, &f, 0.0025, g, 1e-4, 1e-3).is_some() {
                out += 1;
            }
        }
        // Windows end every 200 samples; the first still window only counts.
        assert_eq!(out, 1);
        assert!(d.is_still());
        // Turning at 2 deg/s.
        let turn = Vector3::new(0.0, 0.0, 2f64.to_radians());
        for _ in 0..400 {
            assert!(d.add(&turn, &f, 0.0025, g, 1e-4, 1e-3).is_none());
        }
        assert!(!d.is_still());
        // Accelerating at 1.5 m/s^2 (the magnitude test sees 0.11 m/s^2 of it).
        let acc = Vector3::new(1.5, 0.0, -g);
        for _ in 0..400 {
            assert!(d.add(&w, &acc, 0.0025, g, 1e-4, 1e-3).is_none());
        }
    }
}
