//! Integrity of the GNSS position fixes beyond the per-fix gate: a windowed innovation test for
//! slow faults and the refusal of a consistent cluster of wrong fixes.
//!
//! **Windowed test** [Groves, ch. 17; Teunissen, 1990]. A multipath bias that grows slowly
//! passes the per-fix chi-square gate on every fix while the filter follows it. Over the last
//! [`WINDOW`] position fixes that passed the gate, each innovation `z_k` is whitened with its
//! own covariance, `w_k = L_k^-1 z_k` (`S_k = L_k L_k^T`): under no fault the `w_k` are
//! independent `N(0, I_3)` (the innovation sequence of a consistent filter is white). Two
//! statistics follow from that, each against its 99.9 % point:
//! - the local (mean) test `|sum w_k|^2 / n ~ chi^2(3)` for a bias common to the window;
//! - the global (variance) test `sum |w_k|^2 ~ chi^2(3 n)` for a window whose spread is too
//!   large (tested when the window is full).
//!
//! A fix that fails either is refused and counted ([`super::AidCounters::window_rejected`]); it
//! stays in the window, so the fixes of a bias that keeps growing keep failing, and the test
//! passes again once the bias is gone or the filter's own growing covariance covers it. That
//! lasts at most [`WINDOW_REFUSALS_MAX`] consecutive refused fixes: the innovations of fixes
//! the filter did not use are not white (they share its drift since the last used one), and
//! a filter whose noise model is a little optimistic drifts beyond its sigma while it refuses,
//! which kept the window failing for ever (RTK fixes refused for minutes, metres of error).
//! Past that count a failing window is emptied and restarted with the current fix, which the
//! per-fix gate and the cluster rule judge as usual. The
//! window's earlier fixes were used before the test could see the bias: the sum `d` of the
//! corrections they applied to the error state is now doubtful, and at the detection it is
//! added to the covariance as the rank-one term `P <- P + d d^T` (fault recovery by covariance
//! increase [Groves, ch. 17]): the filter's sigma covers what the fault may have pulled it
//! by, and the same corrections are not added twice.
//!
//! **A refused cluster** [Teunissen, 1990, adaptation]. While fixes are being refused, the
//! next one whose innovation agrees with the previous refused fix's (their difference within
//! `chi^2(3)` at 99.9 % of both fixes' noise and the filter's drift between them, and closer
//! to it in that measure than to the filter's prediction by its own normalised innovation
//! squared) belongs to the same consistent cluster, and is refused even
//! when the growing covariance would let it pass the gate: the filter refused that cluster while
//! it still knew its own position, and a wider covariance is no evidence for it. A fix that
//! leaves the cluster (the fault ended) is judged by the gate alone: that is the re-acquisition
//! from the filter's own growing sigma. Only refusals by the per-fix gate start a cluster (the
//! windowed test's refusals do not: after a slow fault the true fixes are refused by it for a
//! while, and must not become a cluster). The cluster is released when its offset has become a
//! typical error of the filter (its normalised square within the median of `chi^2(3)`): the
//! filter can then no longer tell which of the two is wrong, and a filter that was itself
//! pulled off by a fault the window could not see (a MEMS filter follows a slow ramp with small
//! innovations) re-acquires the true fixes from its own growing sigma.

use super::states::StateVector;
use crate::Scalar;
use nalgebra::{Matrix3, Vector3};

/// Fixes in the window [-] (10 s at 1 Hz).
pub const WINDOW: usize = 10;

/// Consecutive refused fixes [-] after which a failing window no longer refuses: by then it
/// holds the filter's own drift since it stopped using fixes (module docs).
pub const WINDOW_REFUSALS_MAX: u32 = WINDOW as u32;

/// 99.9 % point of chi-square with `3 * WINDOW` = 30 degrees of freedom: the global test.
pub const CHI2_30DOF_999: f64 = 59.703;

/// Median of chi-square with 3 degrees of freedom: a refused cluster whose offset is this
/// typical of the filter's own error is released (module docs).
pub const CHI2_3DOF_MEDIAN: f64 = 2.366;

/// `L^-1 z` for `S = L L^T` (the whitened innovation); `None` when `S` is not positive
/// definite.
pub fn whiten<T: Scalar>(s: &Matrix3<T>, z: &Vector3<T>) -> Option<Vector3<T>> {
    let l = s.cholesky()?;
    l.l().solve_lower_triangular(z)
}

/// What the windowed test found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WindowVerdict {
    /// Both statistics within their 99.9 % points.
    Consistent,
    /// The local test failed: a bias common to the window.
    Bias,
    /// The global test failed: the window's spread is too large.
    Spread,
}

/// The last [`WINDOW`] whitened position innovations (module docs); fixed-size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InnovationWindow<T: Scalar> {
    w: [Vector3<T>; WINDOW],
    corrections: [StateVector<T>; WINDOW],
    len: usize,
    next: usize,
}

impl<T: Scalar> Default for InnovationWindow<T> {
    fn default() -> Self {
        Self {
            w: [Vector3::zeros(); WINDOW],
            corrections: [StateVector::zeros(); WINDOW],
            len: 0,
            next: 0,
        }
    }
}

impl<T: Scalar> InnovationWindow<T> {
    /// Adds a whitened innovation `w` [-], dropping the oldest when full.
    pub fn push(&mut self, w: Vector3<T>) {
        self.w[self.next] = w;
        self.corrections[self.next] = StateVector::zeros();
        self.next = (self.next + 1) % WINDOW;
        self.len = (self.len + 1).min(WINDOW);
    }

    /// Records the correction `x` the last pushed fix applied to the error state.
    pub fn set_last_correction(&mut self, x: &StateVector<T>) {
        if self.len > 0 {
            self.corrections[(self.next + WINDOW - 1) % WINDOW] = *x;
        }
    }

    /// The sum of the corrections the window's fixes applied, forgotten once taken (module
    /// docs: the covariance inflation after a detection).
    pub fn take_corrections(&mut self) -> StateVector<T> {
        let mut sum = StateVector::zeros();
        for c in &mut self.corrections {
            sum += *c;
            *c = StateVector::zeros();
        }
        sum
    }

    /// Empties the window.
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// Fixes held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The local statistic `|sum w|^2 / n` [-] (`chi^2(3)` under no fault; 0 when empty).
    pub fn bias_statistic(&self) -> T {
        if self.len == 0 {
            return T::zero();
        }
        let sum = self.w[..self.len]
            .iter()
            .fold(Vector3::zeros(), |a, w| a + w);
        sum.norm_squared() / T::c(self.len as f64)
    }

    /// The global statistic `sum |w|^2` [-] (`chi^2(3 n)` under no fault).
    pub fn spread_statistic(&self) -> T {
        self.w[..self.len]
            .iter()
            .fold(T::zero(), |a, w| a + w.norm_squared())
    }

    /// Both tests at 99.9 %: the local one against `gate_3dof` (the per-fix gate's point), the
    /// global one against [`CHI2_30DOF_999`] once the window is full.
    pub fn verdict(&self, gate_3dof: T) -> WindowVerdict {
        if self.bias_statistic() > gate_3dof {
            WindowVerdict::Bias
        } else if self.len == WINDOW && self.spread_statistic() > T::c(CHI2_30DOF_999) {
            WindowVerdict::Spread
        } else {
            WindowVerdict::Consistent
        }
    }
}

/// The last refused position fix's innovation and noise variance (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefusedCluster<T: Scalar> {
    /// Its innovation, predicted minus measured, NED [m].
    pub z_ned_m: Vector3<T>,
    /// Its noise variance, NED [m^2].
    pub r_ned_m2: Vector3<T>,
}

impl<T: Scalar> RefusedCluster<T> {
    /// True when a fix with innovation `z` [m] and noise variance `r` [m^2] agrees with this
    /// one: `(z - z_c)^T (R + R_c + D)^-1 (z - z_c) <= gate` (chi-square with 3 degrees of
    /// freedom), `D` [m^2] the variance of the filter's own drift since that fix (its velocity
    /// variance times the interval squared).
    pub fn contains(
        &self,
        z: &Vector3<T>,
        r: &Vector3<T>,
        drift_var_m2: &Vector3<T>,
        gate_3dof: T,
    ) -> bool {
        self.distance(z, r, drift_var_m2) <= gate_3dof
    }

    /// The normalised square `(z - z_c)^T (R + R_c + D)^-1 (z - z_c)` [-] of
    /// [`Self::contains`].
    pub fn distance(&self, z: &Vector3<T>, r: &Vector3<T>, drift_var_m2: &Vector3<T>) -> T {
        let d = z - self.z_ned_m;
        (0..3).fold(T::zero(), |a, i| {
            a + d[i] * d[i] / (r[i] + self.r_ned_m2[i] + drift_var_m2[i])
        })
    }

    /// True when a fix (innovation `z` [m], noise variance `r` [m^2], normalised innovation
    /// squared `nis` [-] against the innovation covariance `s` [m^2]) is refused as a member
    /// (module docs): [`Self::contains`] it, agrees better with it than with the filter's
    /// prediction, and the cluster is not yet [`Self::is_typical`].
    pub fn claims(
        &self,
        z: &Vector3<T>,
        r: &Vector3<T>,
        drift_var_m2: &Vector3<T>,
        nis: T,
        s: &Matrix3<T>,
        gate_3dof: T,
    ) -> bool {
        let q = self.distance(z, r, drift_var_m2);
        q <= gate_3dof && q < nis && !self.is_typical(s)
    }

    /// True when this cluster's offset is a typical error of the filter: its normalised
    /// square against the innovation covariance `s` [m^2] within the median of `chi^2(3)`.
    pub fn is_typical(&self, s: &Matrix3<T>) -> bool {
        whiten(s, &self.z_ned_m).is_some_and(|w| w.norm_squared() <= T::c(CHI2_3DOF_MEDIAN))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whitening_makes_the_covariance_the_identity() {
        let s = Matrix3::<f64>::new(4.0, 1.0, 0.0, 1.0, 9.0, 2.0, 0.0, 2.0, 16.0);
        let z = Vector3::new(1.0, -2.0, 3.0);
        let w = whiten(&s, &z).unwrap();
        // |w|^2 = z^T S^-1 z.
        let nis = (z.transpose() * s.try_inverse().unwrap() * z)[(0, 0)];
        assert!((w.norm_squared() - nis).abs() < 1e-12);
        assert!(whiten(&(-s), &z).is_none());
    }

    #[test]
    fn a_common_bias_fails_the_local_test_and_white_noise_passes() {
        let gate = crate::ins_filter::CHI2_3DOF_999;
        let mut white = InnovationWindow::<f64>::default();
        // Alternating unit innovations: spread 3 per fix, no mean.
        for k in 0..WINDOW {
            let s = if k % 2 == 0 { 1.0 } else { -1.0 };
            white.push(Vector3::repeat(s));
        }
        assert_eq!(white.verdict(gate), WindowVerdict::Consistent);
        // A bias of 1.3 sigma on one axis on every fix: each fix's NIS 1.7 passes any gate,
        // the window's mean 10 * 1.69 = 16.9 does not.
        let mut biased = InnovationWindow::<f64>::default();
        for _ in 0..WINDOW {
            biased.push(Vector3::new(0.0, 1.3, 0.0));
        }
        assert_eq!(biased.verdict(gate), WindowVerdict::Bias);
        // Large alternating innovations: no mean, too much spread (10 * 3 * 4 = 120 > 59.7).
        let mut wide = InnovationWindow::<f64>::default();
        for k in 0..WINDOW {
            let s = if k % 2 == 0 { 2.0 } else { -2.0 };
            wide.push(Vector3::repeat(s));
        }
        assert_eq!(wide.verdict(gate), WindowVerdict::Spread);
        // The corrections are summed once.
        let mut x = StateVector::<f64>::zeros();
        x[0] = 0.5;
        wide.set_last_correction(&x);
        wide.push(Vector3::zeros());
        wide.set_last_correction(&x);
        assert_eq!(wide.take_corrections()[0], 1.0);
        assert_eq!(wide.take_corrections()[0], 0.0);
        wide.clear();
        assert!(wide.is_empty());
        assert_eq!(wide.verdict(gate), WindowVerdict::Consistent);
    }

    #[test]
    fn a_cluster_holds_its_own_fixes_until_typical() {
        let r = Vector3::new(0.25, 0.25, 1.0);
        let c = RefusedCluster {
            z_ned_m: Vector3::new(0.0, 30.0, 0.0),
            r_ned_m2: r,
        };
        let gate = crate::ins_filter::CHI2_3DOF_999;
        assert!(c.contains(&Vector3::new(0.3, 29.5, 0.5), &r, &Vector3::zeros(), gate));
        // The fault ended: the fix is back near the filter's prediction.
        assert!(!c.contains(&Vector3::new(0.3, 1.0, 0.5), &r, &Vector3::zeros(), gate));
        // After a refused fix 4 sigma off (RTK: 2 cm noise, innovation 1-sigma 2.4 cm), a fix
        // at the prediction agrees better with the filter than with it: not a member.
        let rtk = Vector3::repeat(4e-4);
        let c4 = RefusedCluster {
            z_ned_m: Vector3::new(0.096, 0.0, 0.0),
            r_ned_m2: rtk,
        };
        let z = Vector3::new(0.01, 0.005, 0.0);
        let nis = z.norm_squared() / 5.8e-4;
        assert!(c4.contains(&z, &rtk, &Vector3::zeros(), gate));
        assert!(c4.distance(&z, &rtk, &Vector3::zeros()) > nis);
        // 30 m is not typical of a 5 m 1-sigma, it is of a 30 m one.
        assert!(!c.is_typical(&Matrix3::from_diagonal_element(25.0)));
        assert!(c.is_typical(&Matrix3::from_diagonal_element(900.0)));
    }
}
