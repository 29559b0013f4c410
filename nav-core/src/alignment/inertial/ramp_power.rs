//! The ramps' power spectrum ([`Taper::ramp_power`]) computed a little at a time while the
//! window's increments arrive, so that the end of the alignment does not wait for it.
//!
//! The spectrum takes two ramps x [`LEAK_STEPS`] midpoints x [`LEAK_FREQUENCIES`]
//! frequencies, some 0.7 million `f64` operations: in one go at the window's end, some 90
//! million instructions on an MCU (whose `f64` is software), during which the samples that
//! follow the alignment overran the firmware's channels. It depends only on the taper and the
//! frequencies, both known from the start: [`RampPower::advance`] does a share of it with
//! every increment (the same operations in the same order as [`Taper::ramp_power`], so the
//! result is the same to the bit) and [`RampPower::finish`] whatever is left.

use super::{LEAK_FREQUENCIES, LEAK_STEPS, Taper, Weights};

/// Where the computation is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// At midpoint `j` of ramp `ramp` (0 or 1), frequency `k`.
    At { ramp: usize, j: usize, k: usize },
    /// Complete.
    Done,
}

/// [`Taper::ramp_power`] of a taper at the frequencies `omega`, a share at a time.
#[derive(Clone, Debug)]
pub(super) struct RampPower {
    taper: Taper,
    omega: [f64; LEAK_FREQUENCIES],
    step: [(f64, f64); LEAK_FREQUENCIES],
    phasor: [(f64, f64); LEAK_FREQUENCIES],
    sums: [[f64; 4]; LEAK_FREQUENCIES],
    power: [(f64, f64); LEAK_FREQUENCIES],
    /// The weights at the current midpoint.
    w: Weights,
    phase: Phase,
}

/// One unit of work: one frequency at one midpoint.
const UNITS: usize = 2 * LEAK_STEPS * LEAK_FREQUENCIES;

impl RampPower {
    /// The computation for `taper` at `omega` [rad/s], not started.
    pub(super) fn new(taper: Taper, omega: [f64; LEAK_FREQUENCIES]) -> Self {
        Self {
            taper,
            omega,
            step: [(0.0, 0.0); LEAK_FREQUENCIES],
            phasor: [(0.0, 0.0); LEAK_FREQUENCIES],
            sums: [[0.0; 4]; LEAK_FREQUENCIES],
            power: [(0.0, 0.0); LEAK_FREQUENCIES],
            w: Weights {
                w0: 0.0,
                w1: 0.0,
                w0_dd: 0.0,
                w1_dd: 0.0,
            },
            phase: Phase::At {
                ramp: 0,
                j: 0,
                k: 0,
            },
        }
    }

    /// The frequencies [rad/s].
    pub(super) fn omega(&self) -> &[f64; LEAK_FREQUENCIES] {
        &self.omega
    }

    /// The spectrum, once complete.
    pub(super) fn power(&self) -> Option<&[(f64, f64); LEAK_FREQUENCIES]> {
        (self.phase == Phase::Done).then_some(&self.power)
    }

    /// Does the share of an increment of `dt` [s]: all of it over half the window.
    pub(super) fn advance(&mut self, dt: f64) {
        let share = dt / (0.5 * self.taper.window);
        let units = if share.is_finite() && share > 0.0 {
            libm::ceil(UNITS as f64 * share.min(1.0)) as usize
        } else {
            UNITS
        };
        self.run(units);
    }

    /// Does what is left.
    pub(super) fn finish(&mut self) {
        self.run(UNITS);
    }

    /// Does up to `units` units ([`Taper::ramp_power`]'s loops unrolled into a state).
    fn run(&mut self, units: usize) {
        let h = self.taper.ramp / LEAK_STEPS as f64;
        for _ in 0..units {
            let Phase::At { ramp, j, k } = self.phase else {
                return;
            };
            let start = if ramp == 0 {
                0.0
            } else {
                self.taper.window - self.taper.ramp
            };
            let t0 = start + 0.5 * h;
            if j == 0 {
                // The ramp's first midpoint: its phasors (and the steps, the same for both).
                let om = self.omega[k];
                self.phasor[k] = (libm::cos(om * t0), libm::sin(om * t0));
                self.step[k] = (libm::cos(om * h), libm::sin(om * h));
                self.sums[k] = [0.0; 4];
            }
            if k == 0 {
                self.w = self.taper.at(t0 + j as f64 * h);
            }
            let w = self.w;
            let (c, s) = self.phasor[k];
            let acc = &mut self.sums[k];
            acc[0] += w.w0_dd * c * h;
            acc[1] += w.w0_dd * s * h;
            acc[2] += w.w1_dd * c * h;
            acc[3] += w.w1_dd * s * h;
            let (cd, sd) = self.step[k];
            self.phasor[k] = (c * cd - s * sd, s * cd + c * sd);
            self.phase = if k + 1 < LEAK_FREQUENCIES {
                Phase::At { ramp, j, k: k + 1 }
            } else if j + 1 < LEAK_STEPS {
                Phase::At {
                    ramp,
                    j: j + 1,
                    k: 0,
                }
            } else {
                for (p, a) in self.power.iter_mut().zip(&self.sums) {
                    p.0 += a[0] * a[0] + a[1] * a[1];
                    p.1 += a[2] * a[2] + a[3] * a[3];
                }
                if ramp == 0 {
                    Phase::At {
                        ramp: 1,
                        j: 0,
                        k: 0,
                    }
                } else {
                    Phase::Done
                }
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A share at a time, in uneven shares, gives [`Taper::ramp_power`] to the bit; nothing
    /// before it is complete.
    #[test]
    fn in_shares_it_is_the_spectrum_computed_at_once() {
        let taper = Taper {
            window: 40.0,
            ramp: 10.0,
        };
        let omega = super::super::leak_omegas(core::f64::consts::TAU / 8.0);
        let direct = taper.ramp_power(&omega);
        let mut shares = RampPower::new(taper, omega);
        let mut dt = 0.0025;
        let mut steps = 0;
        while shares.power().is_none() {
            shares.advance(dt);
            // 400 Hz, then 100 Hz, then a gap: shares of different sizes.
            dt = match steps {
                0..=999 => 0.0025,
                1000..=1499 => 0.01,
                _ => 0.7,
            };
            steps += 1;
            assert!(steps < 100_000);
        }
        assert_eq!(shares.power(), Some(&direct));
        // Half the window's increments at 400 Hz do it all; fewer leave it to `finish`.
        let mut part = RampPower::new(taper, omega);
        for _ in 0..4000 {
            part.advance(0.0025);
        }
        assert!(part.power().is_none());
        part.finish();
        assert_eq!(part.power(), Some(&direct));
    }
}
