//! Two filters that differ only in whether the base's centre translates horizontally, weighted
//! by the likelihood of their innovations (a static multiple-model filter, [Bar-Shalom et
//! al., §11.6.2]).
//!
//! Why two: the heading's signature in the IMU's position is a slow cubic ([`super`]); a
//! stationary model of horizontal translation (surge, sway) has power at those slow
//! frequencies however it is shaped, and costs the heading of a 60 s alignment 17 % already at
//! 1 cm (2.5x at 0.1 m; vertical heave costs nothing: it does not reach the heading). A base
//! that does not translate horizontally should not pay for one that might. So one filter
//! assumes no horizontal translation, the other the configured one; each accumulates the log
//! likelihood of its scalar innovations, `-(ln S + nu^2 / S) / 2`, and the result is their
//! mixture: weights `w_i ∝ exp(L_i)`, mean `sum w_i x_i`, variance `sum w_i (P_i + (x_i -
//! x)^2)` per angle and axis. When the base does translate, the first filter's innovations
//! grow with it and its weight vanishes within seconds; when it does not, the second's
//! extra freedom only widens its innovation variances and the first wins by Occam's factor.

use super::{Extension, FineConfig, FineCore, FineOutcome, FineRefusal};
use crate::alignment::AttitudeEstimate;
use crate::{ImuIncrement, InputError, NavState, Position, Scalar, attitude};
use nalgebra::{UnitQuaternion, Vector3};

/// The two filters and their extensions.
#[derive(Clone, Debug)]
pub struct Bank<T: Scalar, const N: usize, E: Extension<T, N> + Clone> {
    filters: [FineCore<T, N>; 2],
    ext: [E; 2],
    /// `false` when the configuration has no horizontal translation: one filter only.
    two: bool,
}

impl<T: Scalar, const N: usize, E: Extension<T, N> + Clone> Bank<T, N, E> {
    /// The bank for `config` (its horizontal translation 1-sigma is the second filter's; the
    /// first has none) started as [`FineCore::new`].
    pub fn new(
        q_b_c: UnitQuaternion<T>,
        omega_eb_b: Vector3<T>,
        position: Position,
        config: FineConfig<T>,
        ext: E,
    ) -> Self {
        let mut still = config;
        still.translation.horizontal_sigma_m = T::zero();
        let two = config.translation.horizontal_sigma_m > T::zero();
        Self {
            filters: [
                FineCore::new(q_b_c, omega_eb_b, position, still),
                FineCore::new(q_b_c, omega_eb_b, position, config),
            ],
            ext: [ext.clone(), ext],
            two,
        }
    }

    /// Adds one increment to both filters.
    pub fn add(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        let [a, b] = &mut self.filters;
        let [ea, eb] = &mut self.ext;
        let r = a.add_with(inc, ea);
        if self.two {
            let _ = b.add_with(inc, eb);
        }
        r
    }

    /// A gap in the data.
    pub fn restart_increments(&mut self) {
        for f in &mut self.filters {
            f.restart_increments();
        }
    }

    /// The filters' weights (sum 1).
    pub fn weights(&self) -> [f64; 2] {
        if !self.two {
            return [1.0, 0.0];
        }
        let (la, lb) = (
            self.filters[0].log_likelihood(),
            self.filters[1].log_likelihood(),
        );
        let m = la.max(lb);
        let (ea, eb) = (libm::exp(la - m), libm::exp(lb - m));
        [ea / (ea + eb), eb / (ea + eb)]
    }

    /// The filter with the larger weight, and its extension.
    pub fn best(&self) -> (&FineCore<T, N>, &E) {
        let w = self.weights();
        let k = usize::from(w[1] > w[0]);
        (&self.filters[k], &self.ext[k])
    }

    /// The filters and their extensions.
    pub fn members(&self) -> (&[FineCore<T, N>; 2], &[E; 2]) {
        (&self.filters, &self.ext)
    }

    /// The mixture's attitude estimate (while aligning: the best filter's).
    pub fn estimate(&self) -> AttitudeEstimate<T> {
        self.best().0.estimate()
    }

    /// The mixture's outcome, or the best filter's refusal. With one filter refusing, the
    /// other's outcome alone (weights renormalised).
    pub fn outcome(&self) -> Result<FineOutcome<T>, FineRefusal> {
        let w = self.weights();
        let k = usize::from(w[1] > w[0]);
        let best = self.filters[k].outcome()?;
        if !self.two {
            return Ok(best);
        }
        let Ok(other) = self.filters[1 - k].outcome() else {
            return Ok(best);
        };
        Ok(mix(&best, w[k], &other, w[1 - k]))
    }
}

/// The mixture of two outcomes with weights `wa + wb = 1`: attitude as a small rotation about
/// `a`'s, velocity and position as vectors; variances `sum w (sigma^2 + (x - mean)^2)`.
fn mix<T: Scalar>(a: &FineOutcome<T>, wa: f64, b: &FineOutcome<T>, wb: f64) -> FineOutcome<T> {
    let (wa_t, wb_t) = (T::c(wa), T::c(wb));
    // Euler angles of b relative to a's (wrapped), mixed.
    let (ra, pa, ya) = attitude::euler(&a.estimate.q_b_n);
    let (rb, pb, yb) = attitude::euler(&b.estimate.q_b_n);
    let wrap = |x: T| {
        let pi = T::c(core::f64::consts::PI);
        if x > pi {
            x - pi - pi
        } else if x < -pi {
            x + pi + pi
        } else {
            x
        }
    };
    let d = Vector3::new(wrap(rb - ra), wrap(pb - pa), wrap(yb - ya));
    let mean_d = d * wb_t;
    let q_b_n = attitude::from_euler(ra + mean_d.x, pa + mean_d.y, ya + mean_d.z);
    let sig = |sa: &Vector3<T>, sb: &Vector3<T>, xa: &Vector3<T>, xb: &Vector3<T>| {
        let m = xa * wa_t + xb * wb_t;
        Vector3::from_fn(|i, _| {
            let va = sa[i] * sa[i] + (xa[i] - m[i]) * (xa[i] - m[i]);
            let vb = sb[i] * sb[i] + (xb[i] - m[i]) * (xb[i] - m[i]);
            (va * wa_t + vb * wb_t).sqrt()
        })
    };
    let zero = Vector3::zeros();
    let sigma_rad = sig(&a.estimate.sigma_rad, &b.estimate.sigma_rad, &zero, &d);
    let (_, va) = a.state.ned();
    let (_, vb) = b.state.ned();
    let v = va * wa_t + vb * wb_t;
    let velocity_sigma_m_s = sig(&a.velocity_sigma_m_s, &b.velocity_sigma_m_s, &va, &vb);
    // Positions as north, east, down offsets of b from a.
    let dp = Vector3::from(a.state.position.ned_to(&b.state.position)).map(T::c);
    let position_sigma_m = sig(&a.position_sigma_m, &b.position_sigma_m, &zero, &dp);
    let position = a
        .state
        .position
        .offset_ned((dp * wb_t).map(T::to_f64).into());
    let estimate = AttitudeEstimate {
        q_b_n,
        sigma_rad,
        elapsed_s: a.estimate.elapsed_s,
    };
    FineOutcome {
        state: NavState {
            q_b_n,
            v_eb_n: v,
            position,
        },
        estimate,
        velocity_sigma_m_s,
        position_sigma_m,
    }
}
