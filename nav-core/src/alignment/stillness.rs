//! Is the base still? The scatter of short-block means of the gyro and accelerometer outputs
//! against what the IMU's white noise alone would give.
//!
//! The increments are averaged over blocks of [`BLOCK_S`]; on a still base every block mean is
//! the constant Earth rate (gravity) plus white noise of variance `N^2 / tau` per axis (`N`
//! the noise density, `tau` the block length), so the blocks' sample variance `s^2` obeys
//! `(n - 1) s^2 / sigma^2 ~ chi^2(n - 1)` [Groves, §4.4.3]. A base that sways, heaves or
//! vibrates adds its own variance: a roll of 0.01 deg at 10 s already doubles the FOG gyros'
//! block variance. The test ([`Stillness::check`]) refuses a variance above
//! [`NOISE_MARGIN`] times the noise's plus [`CHI2_SIGMAS`] of the chi-square spread, per axis.
//! A mean over the window is blind to any of this: a sway over a whole number of periods
//! averages out of the mean rate and specific force, and the rectified part left (the coning
//! of the mean, the lever arm's centripetal acceleration) turns a static solution by degrees.

use crate::{ImuIncrement, Scalar};
use nalgebra::Vector3;

/// Block length [s].
pub const BLOCK_S: f64 = 0.1;

/// Variance allowed above the noise model's (a real IMU's noise within 1.4x of its data
/// sheet's density passes).
pub const NOISE_MARGIN: f64 = 2.0;

/// Statistical margin [sigma of the chi-square spread of the variance].
pub const CHI2_SIGMAS: f64 = 5.0;

/// What the stillness test found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scatter {
    /// Blocks.
    pub blocks: u32,
    /// Largest ratio over the three gyro axes of the block variance to the noise's [-].
    pub gyro_ratio: f64,
    /// The same for the accelerometers [-].
    pub accel_ratio: f64,
    /// The accelerometers' block variance above the noise's, largest axis [m^2/s^4].
    pub accel_excess: f64,
}

/// Block statistics of the increments (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stillness {
    block_theta: Vector3<f64>,
    block_v: Vector3<f64>,
    block_s: f64,
    n: u32,
    sum_w: Vector3<f64>,
    sum_w2: Vector3<f64>,
    sum_f: Vector3<f64>,
    sum_f2: Vector3<f64>,
    sum_tau: f64,
}

impl Stillness {
    /// No blocks yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one (checked) increment.
    pub fn add<T: Scalar>(&mut self, inc: &ImuIncrement<T>) {
        self.block_theta += inc.delta_theta_ib_b.map(T::to_f64);
        self.block_v += inc.delta_v_ib_b.map(T::to_f64);
        self.block_s += inc.dt.to_f64();
        if self.block_s + 1e-9 >= BLOCK_S {
            let (w, f) = (self.block_theta / self.block_s, self.block_v / self.block_s);
            self.sum_w += w;
            self.sum_w2 += w.component_mul(&w);
            self.sum_f += f;
            self.sum_f2 += f.component_mul(&f);
            self.sum_tau += self.block_s;
            self.n += 1;
            self.block_theta = Vector3::zeros();
            self.block_v = Vector3::zeros();
            self.block_s = 0.0;
        }
    }

    /// Block variances of the rate [rad^2/s^2] and specific force [m^2/s^4] per axis.
    fn variances(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        if self.n < 3 {
            return None;
        }
        let n = f64::from(self.n);
        let var = |s: &Vector3<f64>, s2: &Vector3<f64>| {
            Vector3::from_fn(|i, _| ((s2[i] - s[i] * s[i] / n) / (n - 1.0)).max(0.0))
        };
        Some((
            var(&self.sum_w, &self.sum_w2),
            var(&self.sum_f, &self.sum_f2),
        ))
    }

    /// The scatter against white noise of densities `arw` [rad/sqrt(s)] and `vrw`
    /// [m/s/sqrt(s)]; `None` before three blocks.
    pub fn scatter(&self, arw: f64, vrw: f64) -> Option<Scatter> {
        let (vw, vf) = self.variances()?;
        let tau = self.sum_tau / f64::from(self.n);
        let (nw, nf) = (arw * arw / tau, vrw * vrw / tau);
        let ratio = |v: &Vector3<f64>, noise: f64| {
            if noise > 0.0 {
                v.max() / noise
            } else if v.max() > 0.0 {
                f64::INFINITY
            } else {
                0.0
            }
        };
        Some(Scatter {
            blocks: self.n,
            gyro_ratio: ratio(&vw, nw),
            accel_ratio: ratio(&vf, nf),
            accel_excess: (vf.max() - nf).max(0.0),
        })
    }

    /// `true` when both triads' scatter is within the noise model's (module docs); `None`
    /// before three blocks.
    pub fn check(&self, arw: f64, vrw: f64) -> Option<(bool, Scatter)> {
        let s = self.scatter(arw, vrw)?;
        let limit = NOISE_MARGIN + CHI2_SIGMAS * libm::sqrt(2.0 / (f64::from(s.blocks) - 1.0));
        Some((s.gyro_ratio <= limit && s.accel_ratio <= limit, s))
    }

    /// Blocks so far.
    pub fn blocks(&self) -> u32 {
        self.n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic stand-in for white noise: a xorshift sequence scaled to variance 1.
    fn noise(state: &mut u64) -> f64 {
        let mut s = 0.0;
        for _ in 0..12 {
            *state ^= *state << 13;
            *state ^= *state >> 7;
            *state ^= *state << 17;
            s += (*state >> 11) as f64 / (1u64 << 53) as f64;
        }
        s - 6.0
    }

    #[test]
    fn still_passes_and_a_small_sway_does_not() {
        let (arw, vrw, dt) = (2.6e-6, 1e-3, 0.0025);
        for (amp_deg, still) in [(0.0_f64, true), (0.02, false)] {
            let mut s = Stillness::new();
            let mut st = 7u64;
            for k in 0..(60.0 / dt) as usize {
                let t = k as f64 * dt;
                // Roll sway amp sin(2 pi t / 10): rate amp w cos(w t).
                let w = core::f64::consts::TAU / 10.0;
                let rate = amp_deg.to_radians() * w * (w * t).cos();
                let inc = ImuIncrement {
                    delta_theta_ib_b: Vector3::new(
                        rate * dt + arw * dt.sqrt() * noise(&mut st),
                        1e-5 * dt + arw * dt.sqrt() * noise(&mut st),
                        arw * dt.sqrt() * noise(&mut st),
                    ),
                    delta_v_ib_b: Vector3::new(
                        vrw * dt.sqrt() * noise(&mut st),
                        vrw * dt.sqrt() * noise(&mut st),
                        -9.8 * dt + vrw * dt.sqrt() * noise(&mut st),
                    ),
                    dt,
                };
                s.add(&inc);
            }
            let (ok, sc) = s.check(arw, vrw).unwrap();
            assert_eq!(ok, still, "{amp_deg}: {sc:?}");
            if still {
                assert!((sc.gyro_ratio - 1.0).abs() < 0.3, "{sc:?}");
            }
        }
    }
}
