//! The vibration metric of the health frame: per-axis RMS of the high-passed specific force
//! [m/s^2] and angular rate [rad/s] over a window of samples, as flight controllers report
//! vibration (the accelerometer's output minus its low-passed value, then an RMS).
//!
//! The high-pass is the input minus a first-order low-pass of cut-off [`CUTOFF_HZ`]:
//! `lp += alpha (x - lp)`, `alpha = dt / (RC + dt)`, `RC = 1 / (2 pi f_c)`, so motion below
//! a few hertz (manoeuvres, gravity) is not counted as vibration. Every [`Vibration::window`]
//! samples the mean square per axis gives the RMS, quantised to [`ACCEL_LSB_MPS2`] and
//! [`GYRO_LSB_RAD_S`] (the wire's `u16`, saturating).
//!
//! The square root is `micromath`'s (a bit-level estimate, ~5 % off) refined by two Newton
//! steps, which bring its relative error to ~1e-6: below the resolution at any value the
//! `u16` can carry (the test compares with an f64 reference on random vibration). The metric
//! is a health figure: nothing navigates with it.

use micromath::F32;

/// Cut-off of the high-pass [Hz] (below it: motion, not vibration).
pub const CUTOFF_HZ: f32 = 5.0;

/// Resolution of the accelerometer RMS on the wire [m/s^2] (0.01; up to 655.35).
pub const ACCEL_LSB_MPS2: f32 = 0.01;

/// Resolution of the gyro RMS on the wire [rad/s] (1e-4; up to 6.5535).
pub const GYRO_LSB_RAD_S: f32 = 1e-4;

/// The metric of the last complete window, quantised for the wire.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VibrationLevels {
    /// RMS of the high-passed specific force per body axis [`ACCEL_LSB_MPS2`].
    pub accel_rms: [u16; 3],
    /// RMS of the high-passed angular rate per body axis [`GYRO_LSB_RAD_S`].
    pub gyro_rms: [u16; 3],
}

/// Running vibration metric (6 axes: accelerometer x, y, z, then gyro x, y, z).
#[derive(Clone, Copy, Debug)]
pub struct Vibration {
    /// Samples per window.
    window: u32,
    low_pass: Option<[f32; 6]>,
    sum_sq: [f32; 6],
    count: u32,
    last: VibrationLevels,
    last_rms: [f32; 6],
}

impl Vibration {
    /// A metric over windows of `window` samples (at least 1).
    pub fn new(window: u32) -> Self {
        Self {
            window: window.max(1),
            low_pass: None,
            sum_sq: [0.0; 6],
            count: 0,
            last: VibrationLevels::default(),
            last_rms: [0.0; 6],
        }
    }

    /// Samples per window.
    pub fn window(&self) -> u32 {
        self.window
    }

    /// Adds one sample: specific force `f_ib_b` [m/s^2] and rate `omega_ib_b` [rad/s] over
    /// `dt_s` [s]. Non-finite inputs or a non-positive `dt_s` are skipped (a flagged sample).
    /// Returns true when it completed a window.
    pub fn push(&mut self, f_ib_b: [f32; 3], omega_ib_b: [f32; 3], dt_s: f32) -> bool {
        let x = [
            f_ib_b[0],
            f_ib_b[1],
            f_ib_b[2],
            omega_ib_b[0],
            omega_ib_b[1],
            omega_ib_b[2],
        ];
        if !(dt_s > 0.0 && x.iter().all(|v| v.is_finite())) {
            return false;
        }
        let rc = 1.0 / (2.0 * core::f32::consts::PI * CUTOFF_HZ);
        let alpha = dt_s / (rc + dt_s);
        let lp = self.low_pass.get_or_insert(x);
        for i in 0..6 {
            lp[i] += alpha * (x[i] - lp[i]);
            let hp = x[i] - lp[i];
            self.sum_sq[i] += hp * hp;
        }
        self.count += 1;
        if self.count < self.window {
            return false;
        }
        let n = self.count as f32;
        for i in 0..6 {
            self.last_rms[i] = sqrt(self.sum_sq[i] / n);
        }
        self.sum_sq = [0.0; 6];
        self.count = 0;
        let q = |v: f32, lsb: f32| (v / lsb + 0.5).min(f32::from(u16::MAX)) as u16;
        let r = self.last_rms;
        self.last = VibrationLevels {
            accel_rms: [0, 1, 2].map(|i| q(r[i], ACCEL_LSB_MPS2)),
            gyro_rms: [3, 4, 5].map(|i| q(r[i], GYRO_LSB_RAD_S)),
        };
        true
    }

    /// The levels of the last complete window (zeros before the first).
    pub fn levels(&self) -> VibrationLevels {
        self.last
    }

    /// The RMS of the last complete window before quantisation: accelerometer x, y, z
    /// [m/s^2], gyro x, y, z [rad/s].
    pub fn rms(&self) -> [f32; 6] {
        self.last_rms
    }
}

/// Square root: micromath's estimate and two Newton steps `s = (s + x/s) / 2` (module docs).
fn sqrt(x: f32) -> f32 {
    if x <= 0.0 {
        return 0.0;
    }
    let mut s = F32(x).sqrt().0;
    for _ in 0..2 {
        s = 0.5 * (s + x / s);
    }
    s
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::protocol::tests::Rng;

    /// The same metric in f64 with the library square root.
    fn reference(samples: &[([f64; 6], f64)]) -> [f64; 6] {
        let mut lp = samples[0].0;
        let mut sum = [0.0; 6];
        for (x, dt) in samples {
            let rc = 1.0 / (2.0 * core::f64::consts::PI * f64::from(CUTOFF_HZ));
            let alpha = dt / (rc + dt);
            for i in 0..6 {
                lp[i] += alpha * (x[i] - lp[i]);
                sum[i] += (x[i] - lp[i]).powi(2);
            }
        }
        sum.map(|s| (s / samples.len() as f64).sqrt())
    }

    #[test]
    fn micromath_error_is_below_the_resolution_on_random_vibration() {
        let mut d = Rng(0x9e37_79b9_7f4a_7c15);
        let dt = 0.0025;
        let mut worst = [0.0f64; 2];
        // Amplitudes from quiet to violent: 0.05 to 50 m/s^2 and 0.005 to 5 rad/s (within the
        // u16's range).
        for case in 0..60 {
            let scale = 10f64.powf(f64::from(case % 3) - 3.0 + d.uniform().abs());
            let window = 400;
            let samples: std::vec::Vec<([f64; 6], f64)> = (0..window)
                .map(|k| {
                    let t = f64::from(k) * dt;
                    let tone = (2.0 * core::f64::consts::PI * 80.0 * t).sin();
                    let x = core::array::from_fn(|i| {
                        let base = if i < 3 { 50.0 } else { 5.0 };
                        let g = if i == 2 { -9.81 } else { 0.0 };
                        g + base * scale * (0.7 * tone + 0.3 * d.uniform())
                    });
                    (x, dt)
                })
                .collect();
            let mut v = Vibration::new(window);
            let mut done = false;
            for (x, dt) in &samples {
                let f = [x[0], x[1], x[2]].map(|v| v as f32);
                let w = [x[3], x[4], x[5]].map(|v| v as f32);
                done = v.push(f, w, *dt as f32);
            }
            assert!(done);
            let r = reference(&samples);
            let levels = v.levels();
            for i in 0..6 {
                let lsb = if i < 3 {
                    ACCEL_LSB_MPS2
                } else {
                    GYRO_LSB_RAD_S
                };
                let err = (f64::from(v.rms()[i]) - r[i]).abs() / f64::from(lsb);
                worst[usize::from(i >= 3)] = worst[usize::from(i >= 3)].max(err);
                // The quantised value is the reference's, give or take the rounding boundary.
                let q = if i < 3 {
                    levels.accel_rms[i]
                } else {
                    levels.gyro_rms[i - 3]
                };
                let exact = r[i] / f64::from(lsb);
                assert!(
                    (f64::from(q) - exact).abs() <= 0.5 + err,
                    "axis {i}: {q} vs {exact}"
                );
            }
        }
        std::println!(
            "vibration metric: worst |micromath - f64| = {:.2e} LSB (accel), {:.2e} LSB (gyro)",
            worst[0],
            worst[1]
        );
        // Below a tenth of the resolution (f32 accumulation included).
        assert!(worst.iter().all(|e| *e < 0.1), "{worst:?}");
    }

    #[test]
    fn micromath_alone_would_not_do() {
        // Without the Newton steps the estimate is off by several percent: the reason for them.
        let x = 3.0f32;
        assert!((F32(x).sqrt().0 - x.sqrt()).abs() / x.sqrt() > 0.01);
        assert!((sqrt(x) - x.sqrt()).abs() / x.sqrt() < 1e-6);
    }

    #[test]
    fn steady_motion_is_no_vibration_and_bad_samples_are_skipped() {
        let mut v = Vibration::new(100);
        for _ in 0..99 {
            assert!(!v.push([0.1, 0.2, -9.81], [0.01, 0.0, 0.0], 0.0025));
        }
        assert!(!v.push([f32::NAN, 0.0, 0.0], [0.0; 3], 0.0025));
        assert!(!v.push([0.0; 3], [0.0; 3], 0.0));
        assert!(v.push([0.1, 0.2, -9.81], [0.01, 0.0, 0.0], 0.0025));
        assert_eq!(v.levels(), VibrationLevels::default());
    }
}
