//! The estimator: reference generator with its phase-locked loop, the per-period fit, the rate
//! the fit is rotated back with, and the checks ([Oscillator INS, eqs. 2.16–2.18]).

use super::ellipse::Ellipse;
use super::window::{Window, WindowFit};
use super::{OscillatorConfig, OscillatorConfigError, OscillatorEpoch, OscillatorFault};
use crate::Scalar;
use crate::attitude::rotation_vector_of;
use core::f64::consts::PI;
use nalgebra::{Rotation3, UnitQuaternion, Vector3};

/// Fewest readouts in a period for a fit (4 unknowns per axis, and some redundancy).
const MIN_SAMPLES: u32 = 8;
/// The generator's frequency stays within this fraction of the nominal one.
const PULL_RANGE: f64 = 0.2;
/// The kept epochs are dropped after this many periods without a good one.
const STALE_PERIODS: f64 = 4.0;
/// A phase error beyond this after lock means the loop was thrown off [rad].
const SLIP_RAD: f64 = PI / 4.0;

/// A good epoch kept for the rate estimate.
#[derive(Clone, Copy, Debug)]
struct Past<T: Scalar> {
    t_s: f64,
    q_b_e: UnitQuaternion<T>,
    /// Rate and its derivative at `t_s` [rad/s, rad/s^2].
    omega: Vector3<T>,
    omega_dot: Vector3<T>,
}

/// The reference generator within a period: `cos`, `sin` of its phase and the time `u` in
/// periods from the reference instant, advanced by recurrence (a rotation by the phase step per
/// readout: no trigonometry and no `f64` on the readout path; the error grows by about one
/// rounding per readout, 50 per period, and each period restarts exactly).
#[derive(Clone, Copy, Debug)]
struct Generator<T: Scalar> {
    cos: T,
    sin: T,
    u: T,
    step_cos: T,
    step_sin: T,
    du: T,
}

impl<T: Scalar> Generator<T> {
    /// Starting at phase `phi` [rad] with `step` [rad] per readout.
    fn new(phi: f64, step: f64) -> Self {
        Self {
            cos: T::c(phi).pcos(),
            sin: T::c(phi).psin(),
            u: T::c(phi / (2.0 * PI)),
            step_cos: T::c(step).pcos(),
            step_sin: T::c(step).psin(),
            du: T::c(step / (2.0 * PI)),
        }
    }

    /// The next readout's values.
    #[inline]
    fn step(&mut self) {
        let (c, s) = (self.cos, self.sin);
        self.cos = c * self.step_cos - s * self.step_sin;
        self.sin = s * self.step_cos + c * self.step_sin;
        self.u += self.du;
    }
}

/// Counts of what the estimator met.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OscillatorCounters {
    /// Readouts taken (including missing ones).
    pub readouts: u64,
    /// Readouts that were not finite.
    pub non_finite: u64,
    /// Readouts reported missing.
    pub missing: u64,
    /// Periods completed.
    pub periods: u64,
    /// Epochs given out.
    pub epochs: u64,
    /// Times the loop locked onto the other apse and the estimator switched back.
    pub slips: u64,
}

/// Gyro-free attitude and specific force from oscillator readouts, one epoch per period.
#[derive(Clone, Debug)]
pub struct OscillatorEstimator<T: Scalar> {
    cfg: OscillatorConfig<T>,
    dt_s: f64,
    omega_nominal: f64,
    /// Loop integrator: the measured natural frequency [rad/s].
    omega_int: f64,
    /// The generator's frequency this period (integrator plus the phase correction) [rad/s].
    omega_run: f64,
    /// Generator phase of the period's first readout [rad], in `[-pi, pi)`.
    phi: f64,
    /// Readouts left in the running period.
    left: u32,
    /// The generator's cosine, sine and time within the period, by recurrence.
    reference: Generator<T>,
    /// Reference instant of the running period (generator phase 0) [s].
    t_ref: f64,
    window: Window<T>,
    started: bool,
    locked_periods: u32,
    locked: bool,
    /// The loop has acted at least once.
    steered: bool,
    /// The apse the estimator reads as `+p` is the loop's opposite one.
    flip: bool,
    past: [Option<Past<T>>; 2],
    counters: OscillatorCounters,
}

impl<T: Scalar> OscillatorEstimator<T> {
    /// An estimator with the settings `cfg`.
    pub fn new(cfg: OscillatorConfig<T>) -> Result<Self, OscillatorConfigError> {
        cfg.validate()?;
        let omega = 2.0 * PI * cfg.f0_hz;
        Ok(Self {
            cfg,
            dt_s: 1.0 / cfg.sample_rate_hz,
            omega_nominal: omega,
            omega_int: omega,
            omega_run: omega,
            phi: -PI,
            left: 0,
            reference: Generator::new(-PI, 0.0),
            t_ref: 0.0,
            window: Window::default(),
            started: false,
            locked_periods: 0,
            locked: false,
            steered: false,
            flip: false,
            past: [None; 2],
            counters: OscillatorCounters::default(),
        })
    }

    /// The settings.
    pub fn config(&self) -> &OscillatorConfig<T> {
        &self.cfg
    }

    /// What the estimator met so far.
    pub fn counters(&self) -> OscillatorCounters {
        self.counters
    }

    /// The measured natural frequency [Hz].
    pub fn frequency_hz(&self) -> f64 {
        self.omega_int / (2.0 * PI)
    }

    /// `true` while the loop is locked.
    pub fn locked(&self) -> bool {
        self.locked
    }

    /// Takes the next readout `r_b` [m] (displacement in body axes); at the end of a period
    /// returns its epoch or why there is none. A non-finite readout spoils its period.
    pub fn add(&mut self, r_b: &Vector3<T>) -> Option<Result<OscillatorEpoch<T>, OscillatorFault>> {
        let finite = r_b.iter().all(|x| x.finite());
        self.counters.non_finite += u64::from(!finite);
        self.take(finite.then_some(r_b))
    }

    /// Records that the next readout is missing (its period is spoilt).
    pub fn missing(&mut self) -> Option<Result<OscillatorEpoch<T>, OscillatorFault>> {
        self.counters.missing += 1;
        self.take(None)
    }

    fn take(
        &mut self,
        r_b: Option<&Vector3<T>>,
    ) -> Option<Result<OscillatorEpoch<T>, OscillatorFault>> {
        let index = self.counters.readouts;
        self.counters.readouts += 1;
        let mut out = None;
        if !self.started {
            self.started = true;
            self.start_period(index);
        } else if self.left == 0 {
            // This readout's phase, carried on from the period's first one.
            let n = self.window.samples_seen();
            self.phi += f64::from(n) * self.omega_run * self.dt_s - 2.0 * PI;
            out = Some(self.finish());
            self.start_period(index);
        }
        match r_b {
            Some(r) => self
                .window
                .add(self.reference.u, self.reference.cos, self.reference.sin, r),
            None => self.window.break_off(),
        }
        self.reference.step();
        self.left -= 1;
        out
    }

    /// A new period starts with readout `index` at the current phase: the reference instant,
    /// the readouts it holds (those with phase below `pi`), and the generator's recurrence.
    fn start_period(&mut self, index: u64) {
        let t = self.cfg.start_s + index as f64 * self.dt_s;
        self.window = Window::default();
        self.t_ref = t - self.phi / self.omega_run;
        let step = self.omega_run * self.dt_s;
        // phi + k step < pi for k = 0 .. left - 1.
        self.left = libm::ceil((PI - self.phi) / step).max(1.0) as u32;
        self.reference = Generator::new(self.phi, step);
    }

    /// Rate and its derivative at `t` from the kept epochs, `q_now` being the attitude just
    /// estimated at `t` (if any) [rad/s, rad/s^2].
    fn rate_at(&self, t: f64, q_now: Option<&UnitQuaternion<T>>) -> (Vector3<T>, Vector3<T>) {
        let zero = (Vector3::zeros(), Vector3::zeros());
        let Some(last) = self.past[0] else {
            return zero;
        };
        let Some(q_now) = q_now else {
            // Predicted from the last epoch's rate and its derivative.
            return (
                last.omega + last.omega_dot * T::c(t - last.t_s),
                last.omega_dot,
            );
        };
        // Mean rate over [last, now], at the middle (body axes: the rotation vector of a turn
        // is the same in the axes at either end).
        let span = t - last.t_s;
        let omega_b = rotation_vector_of(&(last.q_b_e.inverse() * q_now)) * T::c(1.0 / span);
        match self.past[1] {
            Some(before) => {
                let span_a = last.t_s - before.t_s;
                let omega_a =
                    rotation_vector_of(&(before.q_b_e.inverse() * last.q_b_e)) * T::c(1.0 / span_a);
                let omega_dot = (omega_b - omega_a) * T::c(2.0 / (span + span_a));
                (omega_b + omega_dot * T::c(0.5 * span), omega_dot)
            }
            None => (omega_b, Vector3::zeros()),
        }
    }

    /// The fit of the period, rotated back with `omega`, `omega_dot` [rad/s, rad/s^2].
    fn fit(&self, omega: &Vector3<T>, omega_dot: &Vector3<T>) -> Option<WindowFit<T>> {
        let period = 2.0 * PI / self.omega_run;
        self.window.fit(
            &(omega * T::c(period)),
            &(omega_dot * T::c(period * period)),
            self.cfg.compensate,
        )
    }

    /// The ellipse of a fit, read from the apse the estimator keeps.
    fn ellipse(&self, fit: &WindowFit<T>) -> Ellipse<T> {
        let e = Ellipse::from_components(&fit.a, &fit.b);
        if self.flip { e.flipped() } else { e }
    }

    /// Ends the period: fit, loop update, checks, epoch.
    fn finish(&mut self) -> Result<OscillatorEpoch<T>, OscillatorFault> {
        self.counters.periods += 1;
        let t = self.t_ref;
        if !self.window.intact() {
            return Err(OscillatorFault::Broken);
        }
        if self.window.samples() < MIN_SAMPLES {
            return Err(OscillatorFault::Singular);
        }
        let compensate = self.cfg.compensate;
        if self.past[0].is_some_and(|p| t - p.t_s > STALE_PERIODS * 2.0 * PI / self.omega_run) {
            // Too long since the last good period for its rate to hold.
            self.forget();
        }
        let (mut omega, mut omega_dot) = if compensate {
            self.rate_at(t, None)
        } else {
            (Vector3::zeros(), Vector3::zeros())
        };
        let mut fit = self
            .fit(&omega, &omega_dot)
            .ok_or(OscillatorFault::Singular)?;
        let mut ellipse = self.ellipse(&fit);
        if compensate && self.past[0].is_some() {
            // Second pass with the rate measured up to this period's own attitude.
            let q = c_b_e_of(&ellipse);
            (omega, omega_dot) = self.rate_at(t, Some(&q));
            fit = self
                .fit(&omega, &omega_dot)
                .ok_or(OscillatorFault::Singular)?;
            ellipse = self.ellipse(&fit);
        }

        let ratio = ellipse.axis_ratio();
        let sigma = ellipse.sigma_rad(
            fit.residual_rms * fit.cos_gain,
            fit.residual_rms * fit.sin_gain,
        );
        let delta = ellipse.delta.to_f64();
        let shape = if ratio < self.cfg.min_axis_ratio {
            Err(OscillatorFault::NearLine {
                axis_ratio: ratio.to_f64(),
            })
        } else if ratio > self.cfg.max_axis_ratio {
            Err(OscillatorFault::NearCircle {
                axis_ratio: ratio.to_f64(),
            })
        } else {
            Ok(())
        };
        let worst = sigma.x.max(sigma.y).max(sigma.z);
        // NaN counts as noisy.
        let noisy = worst.partial_cmp(&self.cfg.max_sigma_rad) != Some(core::cmp::Ordering::Less);
        // The loop follows the apse only where it exists (eq. 2.17); once locked, not through a
        // noisy period either. While acquiring, the misfit of a mistuned generator is what
        // makes a period look noisy, so the loop must act on it.
        let near_circle = matches!(shape, Err(OscillatorFault::NearCircle { .. }));
        if !near_circle && (!noisy || !self.locked) {
            self.steer(delta);
        }
        shape?;
        if noisy {
            self.forget();
            return Err(OscillatorFault::Noisy {
                sigma_rad: worst.to_f64(),
            });
        }
        if self.locked && delta.abs() > SLIP_RAD {
            self.forget();
            return Err(OscillatorFault::LostLock { delta_rad: delta });
        }

        // Keep the apse: the body turns far less than a quarter turn per period, so the new
        // major axis must point the way the last one did.
        if let Some(last) = self.past[0] {
            let e1_last = last.q_b_e.inverse() * Vector3::x();
            if e1_last.dot(&ellipse.p) < T::zero() {
                self.flip = !self.flip;
                self.counters.slips += 1;
                ellipse = ellipse.flipped();
            }
        }
        let q_b_e = c_b_e_of(&ellipse);
        // The rate history is kept while acquiring too, so the first epoch out has it.
        let (omega_end, omega_dot_end) = if compensate && self.past[0].is_some() {
            self.rate_at(t, Some(&q_b_e))
        } else {
            (Vector3::zeros(), Vector3::zeros())
        };
        self.past[1] = self.past[0];
        self.past[0] = Some(Past {
            t_s: t,
            q_b_e,
            omega: omega_end,
            omega_dot: omega_dot_end,
        });

        if delta.abs() < self.cfg.lock_rad.to_f64() {
            self.locked_periods = self.locked_periods.saturating_add(1);
        } else if !self.locked {
            self.locked_periods = 0;
        }
        let warm = !compensate || self.past[1].is_some();
        if self.locked_periods < self.cfg.lock_periods || !warm {
            return Err(OscillatorFault::Acquiring { delta_rad: delta });
        }
        self.locked = true;
        let w0_2 = T::c(self.omega_int * self.omega_int);
        let f_ib_b = -fit.centre * w0_2;
        let limit = crate::increment::InputLimits::<T>::default().max_specific_force;
        if !(f_ib_b.amax() <= limit) {
            return Err(OscillatorFault::ForceBeyondRange {
                f_mps2: f_ib_b.amax().to_f64(),
            });
        }
        let epoch = OscillatorEpoch {
            t_s: t,
            q_b_e,
            f_ib_b,
            omega_ib_b: omega,
            sigma_rad: sigma,
            sigma_f_mps2: fit.residual_rms * fit.centre_gain * w0_2,
            semi_axes_m: (ellipse.major(), ellipse.minor()),
            delta_rad: ellipse.delta,
            frequency_hz: self.frequency_hz(),
        };
        self.counters.epochs += 1;
        Ok(epoch)
    }

    /// Phase-locked loop step on the phase error `delta` [rad] (eq. 2.17): the integrator learns
    /// the frequency, the proportional part is spread over the next period.
    fn steer(&mut self, delta: f64) {
        // A period whose fit overflowed (an absurd readout) measures nothing: a NaN taken in
        // here would stay in the loop for good.
        if !delta.is_finite() {
            return;
        }
        let period = 2.0 * PI / self.omega_run;
        if !self.steered {
            // First measurement: move the phase, learn nothing about the frequency yet (an
            // integral kick from an arbitrary starting phase would throw the loop off).
            self.steered = true;
            self.omega_run = self.omega_int + delta / period;
            return;
        }
        let (lo, hi) = (
            self.omega_nominal * (1.0 - PULL_RANGE),
            self.omega_nominal * (1.0 + PULL_RANGE),
        );
        self.omega_int = (self.omega_int + self.cfg.pll_ki * delta / period).clamp(lo, hi);
        self.omega_run = (self.omega_int + self.cfg.pll_kp * delta / period).clamp(lo, hi);
    }

    /// Drops the kept epochs and the lock (after a disturbance).
    fn forget(&mut self) {
        self.past = [None; 2];
        self.locked = false;
        self.locked_periods = 0;
    }
}

/// `C_b_e` of an ellipse (the transpose of eq. 2.18's matrix of axes in body coordinates).
fn c_b_e_of<T: Scalar>(e: &Ellipse<T>) -> UnitQuaternion<T> {
    let c_e_b = e.c_e_b();
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(c_e_b.transpose()))
}
