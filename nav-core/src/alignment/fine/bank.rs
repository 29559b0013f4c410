//! Filters that differ only in how far the base's centre translates horizontally, weighted by
//! the likelihood of their innovations (a static multiple-model filter, [Bar-Shalom et al.,
//! §11.6.2]).
//!
//! Why several: the heading's signature in the IMU's position is a slow cubic ([`super`]); a
//! stationary model of horizontal translation (surge, sway) has power at those slow
//! frequencies however it is shaped, and costs the heading of a 60 s alignment 17 % already at
//! 1 cm (2.5x at 0.1 m; vertical heave costs nothing: it does not reach the heading). A base
//! that does not translate horizontally should not pay for one that might. So one filter
//! assumes no horizontal translation, one a quarter of the configured 1-sigma and one the
//! configured one ([`TRANSLATION_FRACTIONS`]); each accumulates the log likelihood of its
//! scalar innovations, `-(ln S + nu^2 / S) / 2` (the gated ones too: a model that gates what it
//! cannot explain must not win on what it keeps), and the result is their mixture: weights
//! `w_i ∝ exp(L_i)`, mean `sum w_i x_i`, variance `sum w_i (P_i + (x_i - x)^2)` per angle and
//! axis. When the base translates, the smaller models' innovations grow with it and their
//! weight vanishes within seconds; when it does not, the larger models' extra freedom only
//! widens their innovation variances and the smallest wins by Occam's factor. The middle one
//! is there for the common case between: a few centimetres of sway, which the still model
//! would otherwise explain by a wrong lever arm and heading (and win), and which the
//! configured model pays for with a heading 1-sigma near the limit at 60 s. A smaller model
//! the general one refutes is dropped ([`REFUTE_SIGMAS`]).

use super::{Blank, Extension, FineConfig, FineCore, FineOutcome, FineRefusal};
use crate::alignment::{AttitudeEstimate, LeverArm};
use crate::{ImuIncrement, InputError, NavState, Position, Scalar, attitude};
use nalgebra::{UnitQuaternion, Vector3};

/// Models in the bank: no horizontal translation, a quarter of the configured one, the
/// configured one.
pub const MODELS: usize = 3;

/// Each model's horizontal translation 1-sigma, as a fraction of the configured one.
pub const TRANSLATION_FRACTIONS: [f64; MODELS] = [0.0, 0.25, 1.0];

/// The most general model (the configured translation): the one the others are tested against.
const GENERAL: usize = MODELS - 1;

/// The filters and their extensions.
#[derive(Clone, Debug)]
pub struct Bank<T: Scalar, const N: usize, E: Extension<T, N> + Clone> {
    filters: [FineCore<T, N>; MODELS],
    ext: [E; MODELS],
    /// `false` when the configuration has no horizontal translation: one filter only.
    several: bool,
}

impl<T: Scalar, const N: usize, E: Extension<T, N> + Clone> Bank<T, N, E> {
    /// The bank for `config` (model `k`'s horizontal translation 1-sigma is
    /// [`TRANSLATION_FRACTIONS`]`[k]` of the configuration's) started as [`FineCore::new`].
    pub fn new(
        q_b_c: UnitQuaternion<T>,
        omega_eb_b: Vector3<T>,
        position: Position,
        config: FineConfig<T>,
        ext: E,
    ) -> Self {
        let mut bank = Self {
            filters: [FineCore::BLANK, FineCore::BLANK, FineCore::BLANK],
            ext: core::array::from_fn(|_| ext.clone()),
            several: false,
        };
        bank.init_in(q_b_c, omega_eb_b, position, config, |_| {});
        bank
    }

    /// (Re)starts the bank in place as [`Self::new`] does ([`FineCore::init_in`] per filter),
    /// `init_ext` (re)starting each filter's extension where it lives.
    pub fn init_in(
        &mut self,
        q_b_c: UnitQuaternion<T>,
        omega_eb_b: Vector3<T>,
        position: Position,
        config: FineConfig<T>,
        mut init_ext: impl FnMut(&mut E),
    ) {
        self.several = config.translation.horizontal_sigma_m > T::zero();
        for (k, (f, e)) in self.filters.iter_mut().zip(&mut self.ext).enumerate() {
            let mut c = config;
            c.translation.horizontal_sigma_m *= T::c(TRANSLATION_FRACTIONS[k]);
            f.init_in(q_b_c, omega_eb_b, position, c);
            init_ext(e);
        }
    }

    /// Adds one increment to every filter (the first's result).
    pub fn add(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        let n = if self.several { MODELS } else { 1 };
        let mut first = Ok(());
        for (k, (f, e)) in self
            .filters
            .iter_mut()
            .zip(&mut self.ext)
            .take(n)
            .enumerate()
        {
            let r = f.add_with(inc, e);
            if k == 0 {
                first = r;
            }
        }
        first
    }

    /// A gap in the data.
    pub fn restart_increments(&mut self) {
        for f in &mut self.filters {
            f.restart_increments();
        }
    }

    /// The filters' weights (sum 1) among those `allowed`.
    fn weights_among(&self, allowed: [bool; MODELS]) -> [f64; MODELS] {
        let mut w = [0.0; MODELS];
        if !self.several {
            w[0] = 1.0;
            return w;
        }
        let l: [f64; MODELS] = core::array::from_fn(|k| self.filters[k].log_likelihood());
        let m = (0..MODELS)
            .filter(|&k| allowed[k])
            .map(|k| l[k])
            .fold(f64::NEG_INFINITY, f64::max);
        for k in 0..MODELS {
            if allowed[k] {
                w[k] = libm::exp(l[k] - m);
            }
        }
        let sum: f64 = w.iter().sum();
        if !(sum > 0.0 && sum.is_finite()) {
            let mut only = [0.0; MODELS];
            only[GENERAL] = 1.0;
            return only;
        }
        w.map(|x| x / sum)
    }

    /// The filters' weights (sum 1).
    pub fn weights(&self) -> [f64; MODELS] {
        self.weights_among([true; MODELS])
    }

    /// The filter with the largest weight, and its extension.
    pub fn best(&self) -> (&FineCore<T, N>, &E) {
        let k = argmax(&self.weights());
        (&self.filters[k], &self.ext[k])
    }

    /// The filters and their extensions.
    pub fn members(&self) -> (&[FineCore<T, N>; MODELS], &[E; MODELS]) {
        (&self.filters, &self.ext)
    }

    /// The mixture's attitude estimate (while aligning: the best filter's).
    pub fn estimate(&self) -> AttitudeEstimate<T> {
        self.best().0.estimate()
    }

    /// The mixture's outcome, or the best filter's refusal. A model the most general one
    /// refutes (a Hausman test, [`REFUTE_SIGMAS`]; its state tests the others even where it
    /// cannot answer itself) is dropped, whatever its likelihood; the best of the rest decides
    /// (its refusal is the bank's), and the rest that answer are mixed, weights renormalised.
    pub fn outcome(&self) -> Result<FineOutcome<T>, FineRefusal> {
        if !self.several {
            return self.filters[0].outcome();
        }
        let general = self.filters[GENERAL].solution();
        let outcomes: [Result<FineOutcome<T>, FineRefusal>; MODELS] =
            core::array::from_fn(|k| self.filters[k].outcome());
        let allowed: [bool; MODELS] = core::array::from_fn(|k| {
            k == GENERAL
                || match (&general, &outcomes[k]) {
                    (Ok(g), Ok(o)) => !refutes(g, o),
                    _ => true,
                }
        });
        let w = self.weights_among(allowed);
        let k = argmax(&w);
        let mut mixed = outcomes[k]?;
        let mut weight = w[k];
        for j in (0..MODELS).filter(|&j| j != k && w[j] > 0.0) {
            if let Ok(o) = &outcomes[j] {
                let total = weight + w[j];
                mixed = mix(&mixed, weight / total, o, w[j] / total);
                weight = total;
            }
        }
        // With the lever arm unknown the IMU's position rests on telling the lever arm from the
        // centre's translation, and a translation coherent with the sway (a ship's sway and
        // roll are driven by the same waves) reads as a lever arm in the smaller models: on
        // the alignment family their down position was 4-7 of its 1-sigma off at 120-300 s
        // with a vertical lever arm 1.6 m off. Only the general model's translation covers
        // it: its position 1-sigma is the least the hand-over carries.
        let unknown = matches!(
            self.filters[GENERAL].config().lever_arm,
            LeverArm::Unknown { .. }
        );
        if let (true, Ok(g)) = (unknown, &general) {
            mixed.position_sigma_m = mixed.position_sigma_m.sup(&g.position_sigma_m);
        }
        Ok(mixed)
    }
}

impl<T: Scalar, const N: usize, E: Extension<T, N> + Clone + Blank> Blank for Bank<T, N, E> {
    /// Filters that have not started ([`FineCore::BLANK`]) and blank extensions: the storage
    /// [`Bank::init_in`] starts in place.
    const BLANK: Self = Self {
        filters: [FineCore::BLANK, FineCore::BLANK, FineCore::BLANK],
        ext: [E::BLANK, E::BLANK, E::BLANK],
        several: false,
    };
}

/// The index of the largest of `w` (the first of equals).
fn argmax(w: &[f64; MODELS]) -> usize {
    (0..MODELS).fold(0, |best, k| if w[k] > w[best] { k } else { best })
}

/// A difference between two filters beyond this many of its 1-sigma refutes the less general.
pub const REFUTE_SIGMAS: f64 = 3.0;

/// Whether the most general filter's outcome `general` refutes a smaller model's, `still` (a
/// Hausman test [Hausman, 1978]): the general model nests the smaller one, so where the base
/// translates no more than the smaller model allows both are right and their difference has
/// the variance `sigma_g^2 - sigma_s^2` (the smaller one is the efficient estimator); a
/// difference in roll, pitch, heading, velocity or position beyond [`REFUTE_SIGMAS`] of that
/// (at least half of `sigma_g`) means the smaller model explained the base's translation by
/// something else (a lever arm, a velocity, a heading) and its likelihood, exact only for a
/// linear model, cannot be trusted. On the alignment family the still model otherwise wins
/// with a 17 m lever-arm estimate from a 5 m prior and a heading 6 of its sigma off.
fn refutes<T: Scalar>(general: &FineOutcome<T>, still: &FineOutcome<T>) -> bool {
    let f = |v: &Vector3<T>| v.map(|x| x.to_f64());
    let (rg, pg, yg) = attitude::euler(&general.estimate.q_b_n);
    let (rs, ps, ys) = attitude::euler(&still.estimate.q_b_n);
    let wrap = |x: f64| libm::remainder(x, core::f64::consts::TAU);
    let d_att = Vector3::new(
        wrap((rg - rs).to_f64()),
        wrap((pg - ps).to_f64()),
        wrap((yg - ys).to_f64()),
    );
    let d_v = f(&(general.state.ned().1 - still.state.ned().1));
    let d_p = Vector3::from(still.state.position.ned_to(&general.state.position));
    let beyond = |d: &Vector3<f64>, sg: &Vector3<T>, ss: &Vector3<T>| {
        let (sg, ss) = (f(sg), f(ss));
        (0..3).any(|i| {
            let var = (sg[i] * sg[i] - ss[i] * ss[i]).max(0.25 * sg[i] * sg[i]);
            !(d[i] * d[i] <= REFUTE_SIGMAS * REFUTE_SIGMAS * var)
        })
    };
    beyond(
        &d_att,
        &general.estimate.sigma_rad,
        &still.estimate.sigma_rad,
    ) || beyond(&d_v, &general.velocity_sigma_m_s, &still.velocity_sigma_m_s)
        || beyond(&d_p, &general.position_sigma_m, &still.position_sigma_m)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Position;

    /// An outcome at `heading` [rad] with velocity `v_n` [m/s], its 1-sigma `s_att` [rad] per
    /// axis, `s_v` [m/s], 1 m of position 1-sigma.
    fn outcome(heading: f64, v_n: Vector3<f64>, s_att: f64, s_v: f64) -> FineOutcome<f64> {
        let q_b_n = attitude::from_euler(0.01, -0.02, heading);
        FineOutcome {
            state: NavState {
                q_b_n,
                v_eb_n: v_n,
                position: Position::from_degrees(45.0, 7.0, 100.0),
            },
            estimate: AttitudeEstimate {
                q_b_n,
                sigma_rad: Vector3::repeat(s_att),
                elapsed_s: 120.0,
            },
            velocity_sigma_m_s: Vector3::repeat(s_v),
            position_sigma_m: Vector3::repeat(1.0),
        }
    }

    #[test]
    fn the_general_filter_refutes_a_still_one_only_beyond_its_sigmas() {
        let deg = core::f64::consts::PI / 180.0;
        let general = outcome(1.0, Vector3::zeros(), 2.0 * deg, 0.05);
        // Within: 1 deg of heading against 3 x sqrt(2^2 - 1^2) deg; 0.1 m/s against 3 x
        // sqrt(0.05^2 - 0.01^2) = 0.147 m/s.
        let close = outcome(1.0 + deg, Vector3::new(0.1, 0.0, 0.0), deg, 0.01);
        assert!(!refutes(&general, &close));
        // Heading 6 deg apart: beyond 3 sigma of sqrt(2^2 - 1^2) = 1.7 deg.
        let far = outcome(1.0 + 6.0 * deg, Vector3::zeros(), deg, 0.01);
        assert!(refutes(&general, &far));
        // A velocity 0.2 m/s apart: beyond 3 x 0.049 m/s.
        let fast = outcome(1.0, Vector3::new(0.0, 0.2, 0.0), deg, 0.01);
        assert!(refutes(&general, &fast));
        // Both equally precise: the difference's 1-sigma floor is half the general's, so 1.2
        // of its sigma passes and 2 does not.
        let same = outcome(1.0 + 2.4 * deg, Vector3::zeros(), 2.0 * deg, 0.05);
        assert!(!refutes(&general, &same));
        let same_far = outcome(1.0 + 4.0 * deg, Vector3::zeros(), 2.0 * deg, 0.05);
        assert!(refutes(&general, &same_far));
    }
}
