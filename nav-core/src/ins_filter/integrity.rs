//! Integrity of the GNSS position fixes beyond the per-fix gate: a windowed innovation test for
//! slow faults and the refusal of a consistent cluster of wrong fixes.
//!
//! **A gross refusal ends NAV at once** [Groves, ch. 17: fault detection]. A fix refused far
//! beyond the gate ([`SUSPECT_NIS_FACTOR`]) says that the fixes or the solution are faulty,
//! and one fix cannot tell which: a GNSS spike or jump, or an IMU fault (an axis stuck in a
//! turn, a spike in the rates) that left the solution hundreds of its sigma off. The status
//! is DEGRADED from that fix until a fix of the same aid (position or velocity) is taken
//! again, or for [`super::FilterConfig::refused_time_to_degrade_s`] without a fix of it,
//! where the refusals in a row take over. Before, such rows stayed NAV until the refusals in
//! a row spanned that time.
//!
//! **Velocity fixes that share a bias end NAV** [Groves, ch. 17; Teunissen, 1990, the local
//! test]. The whitened innovations of the last [`VELOCITY_WINDOW`] velocity fixes taken (each
//! within the gate) are summed as the windowed test's local statistic, `|sum w_k|^2 / n ~
//! chi^2(3)` under no fault; beyond [`INCONSISTENT_GATE_FACTOR`] gates (the 99.99 % point,
//! so that a consistent filter fed 10 Hz fixes for minutes seldom passes it) the solution is
//! off by more than its covariance allows and the status is DEGRADED (`AidingRejected`)
//! until the window is consistent again. A sensor that changed beyond its error model does
//! that: after a gyro bias step of 50 deg/h, the velocity rows were 4-9 sigma off for 25 s,
//! NAV, while every fix was taken. Only a status, as the gross refusal's: the fixes are taken
//! (they are right when the sensor changed) and nothing is added to the covariance. Over
//! 36 clean velocity-aided runs (land and flight, FOG to consumer MEMS, 1 and 10 Hz, 300 s
//! each), no row said DEGRADED by it; with the position windowed test's 10 fixes and gate
//! (99.9 %), 14 runs had DEGRADED rows (78 of 108,000).
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
//! per-fix gate and the cluster rule judge as usual.
//!
//! The window's earlier fixes were used before the test could see the bias: the sum `d` of the
//! corrections they applied to the error state is now doubtful, and at the detection it is
//! added to the covariance as the rank-one term `P <- P + d d^T` (fault recovery by covariance
//! increase [Groves, ch. 17]): the filter's sigma covers what the fault may have pulled it
//! by, and the same corrections are not added twice.
//!
//! **A restart's doubt** [Groves, ch. 17, fault recovery by covariance increase;
//! Bar-Shalom et al., ch. 11, the moments of a Gaussian mixture; reported, not gated]. The
//! restart takes fixes of the kind the window refused, and the filter cannot tell what they
//! are: its own drift (the fixes are right) or a fault that is still growing (a multipath
//! ramp: its refused innovations drift linearly, as the filter's own velocity error would
//! make them, at a rate a filter a few times optimistic could have). It takes them, and a
//! FOG filter that restarted inside a 5 m ramp followed its last fixes by metres with a
//! sigma of decimetres (11–17 sigma in the outlier bench). So until [`WINDOW`] fixes taken
//! since the restart confirm it, the reported position covariance is that of the two
//! hypotheses, equally likely, about the solution ([`Restart::doubt`]): the fixes are right
//! (the filter's own `P`), or the solution belongs where the restart found it, `d` away
//! with the covariance `P_0` it had then, `(P + P_0) / 2 + d d^T / 2`. `d` sums what the
//! fixes since the restart moved the solution by: their position corrections, each carried
//! on by the velocity corrections applied before it (`d_p + d_v dt`, the transition's
//! position-velocity block to first order). A restarted window that fails again ends it
//! (its fixes' corrections then join the covariance as `d d^T`, above), and so does the
//! recovery of a DEGRADED filter (below), whose own covariance increase takes its place.
//! The doubt does not bound what the filter follows before the window sees a fault (the
//! window needs its fixes: the ramp's first 10 s pull a FOG filter to 3–4 of its 0.2 m
//! sigma), nor a fault that grows on for a full window after the restart: that one is taken
//! as the filter's own error, as the MEMS filter takes the ramp.
//!
//! **A refused cluster** [Teunissen, 1990, adaptation]. While fixes are being refused, the
//! next one whose innovation agrees with the previous refused fix's (their difference within
//! `chi^2(3)` at 99.9 % of both fixes' noise and the filter's drift between them, and closer
//! to it in that measure than to the filter's prediction by its own normalised innovation
//! squared) belongs to the same consistent cluster, and is refused even
//! when the growing covariance would let it pass the gate: the filter refused that cluster while
//! it still knew its own position, and a wider covariance is no evidence for it. Under a
//! declared correlated GNSS error only a gross cluster (below) claims fixes the gate passes:
//! consecutive fixes share that error, so they agree with a refused one whether or not they
//! are faulty (a chance refusal made the next 51 true fixes members, with the filter's
//! innovation covariance right). A fix that
//! leaves the cluster (the fault ended) is judged by the gate alone: that is the re-acquisition
//! from the filter's own growing sigma. A cluster needs a filter that knew its position: none
//! starts before a full window of fixes has passed the tests since the filter's start (a start
//! in motion on a consumer part, during a take-off run, had its first fix refused at a
//! normalised square of 16.6 against the 16.3 gate, then its next 19 fixes as that fix's
//! cluster while its own drift grew to 200 m: DEGRADED for 20 s, pitch 8 sigma off for
//! the rest of the flight); until then a refused fix is refused alone, and the refused fixes
//! are followed as a cluster that claims nothing (a fix the gate passes is taken). Their
//! offset is the position's doubt, as a cluster's (below), and once the filter is DEGRADED
//! (`rejections_to_degrade` refusals in a row) a refused fix that continues them
//! ([`RefusedCluster::continued_by`]) re-acquires as a drifted cluster does (below): the
//! filter never knew its position, and the fixes agree among themselves (a given start 100 m
//! off under a declared 1 m took no fix in 300 s, its sigma 1 m). Only refusals by the
//! per-fix gate start a cluster (the
//! windowed test's refusals do not: after a slow fault the true fixes are refused by it for a
//! while, and must not become a cluster). The cluster is released when its offset has become a
//! typical error of the filter (its normalised square within the median of `chi^2(3)`): the
//! filter can then no longer tell which of the two is wrong, and a filter that was itself
//! pulled off by a fault the window could not see (a MEMS filter follows a slow ramp with small
//! innovations) re-acquires the true fixes from its own growing sigma. A cluster that is not
//! gross claims fixes the gate passes for at most [`WINDOW_REFUSALS_MAX`] members, for the
//! window's reason: the members' offsets are not white (they share the filter's drift since
//! its last fix), and a filter a little optimistic drifts beyond its sigma while it refuses,
//! so its offset never becomes typical (an RTK car leaving a stop, its vertical 3 sigma off
//! its 1 cm: a chance refusal, then 27-67 true fixes within 2.6 sigma claimed as its members
//! while the solution drifted to 0.3-1 m). Past that count a fix the gate passes is taken,
//! with the doubt below. A gross cluster claims on its chain for as long as it lasts (a jump
//! of 50 m is no drift of the filter's). The first fix taken
//! after a cluster adds its own offset `z z^T` to the position's covariance (fault recovery by
//! covariance increase [Groves, ch. 17], as the window does): the filter had refused fixes
//! that agree with it again, so its position is doubtful by that offset, a step it followed
//! rather than a drift of its velocity, and the fix moves the position, not the velocity (a
//! MEMS filter that followed a ramp otherwise turned the step back into a velocity error and
//! lost the fixes again); after a lone refused fix, a fix that agrees with the filter rather
//! than with it (the refused one was the gate's false alarm) adds nothing. A cluster that
//! is not gross holds, there and in its reported doubt, only the part of its offset beyond the
//! gate of the evidence its members give ([`RefusedCluster::weight`]: a lone fix's own, or
//! their common offset's), which grows with the members: the gate refuses one fault-free fix in
//! a thousand, the next fix joins such a false alarm often enough, and one (4.3 sigma, 2 m
//! fixes at 10 Hz) had widened the covariance by the next fix's whole offset, which then moved
//! the solution by 8 m.
//!
//! **A DEGRADED filter that drifted recovers** [Groves, ch. 17, fault recovery by covariance
//! increase]. A filter that followed part of a fault (a FOG filter pulled by a ramp the window
//! saw late) can be off in velocity by decimetres per second while its covariance claims
//! centimetres: the true fixes then move away from it steadily, each refused by the gate, and
//! its own sigma never grows to meet them (seed 5 of the outlier bench: 50 m off after 170 s,
//! and then it took a held 30 m offset as its position). So once the filter is DEGRADED
//! (`rejections_to_degrade` refusals in a row), a refused cluster that is not gross and whose
//! offset has moved since its first member by more than the filter's position covariance
//! explains ([`RefusedCluster::drifted`]: the normalised square of `z - z_1` against
//! `R + R_1 + P_pos` beyond the gate) is taken as the filter's own drift: the drift's rate
//! `v` joins the velocity covariance as `v v^T`, the offset joins the position's as after any
//! cluster, the window restarts, and the fix is used. A held offset does not move (it stays
//! refused until it is typical, above), and a gross cluster is never taken this way; nor a
//! drift whose rate the filter's own velocity could not have
//! ([`RefusedCluster::drift_is_plausible`]: beyond [`GROSS_NIS_FACTOR`] times the gate of its
//! velocity covariance, the optimism a jump is allowed): then the fixes are the ones moving,
//! a multipath ramp the filter refused from its start.
//!
//! **A DEGRADED filter that a fault pulled recovers** [Groves, ch. 17, fault recovery by
//! covariance increase]. Under a declared correlated GNSS error the position may move with
//! the fixes while velocity fixes hold the velocity, and a filter followed a 15 m multipath
//! ramp that way; when the ramp ended the true fixes lay 14 m from it, a held offset that no
//! rule above releases (it does not move, and the filter's covariance does not grow to it):
//! DEGRADED to the end. So the position corrections of the accepted fixes are remembered
//! over minutes ([`Pull`]), and once the filter is DEGRADED by refusals, a refused fix that
//! agrees with the solution as it was before that pull, the pull itself beyond the fixes'
//! noise ([`Pull::explains`]), re-acquires: the pull `d` joins the position's covariance as
//! `d d^T` (what those fixes moved it by is doubtful), and the fix is judged again. A held
//! offset seen while nothing pulled the filter is not explained, and stays refused. The
//! pull's velocity and attitude join their covariances with it: those fixes moved them as
//! well.
//!
//! **A pull that is a fault** [Groves, ch. 17; Teunissen, 1990, the test of a sum of
//! corrections]. A fix's correction `K z` is, under no fault, a zero-mean vector of
//! covariance `K S K^T = P^- - P^+`, what the update took away, and the corrections of
//! successive fixes are independent (their innovations are white). So the pull's position
//! sum, and its velocity sum, whitened with the sum of what the fixes took away (the same
//! weights, squared), is `chi^2(3)`; beyond the gate ([`Pull::is_fault`]) the fixes moved the
//! solution more, and further one way, than its own noise does: a fault the windowed test
//! cannot see because the filter follows it (a FOG car at 10 Hz followed a 5 m multipath
//! ramp through its velocity, 80 sigma north with a 0.06 m sigma; its window of 10 fixes
//! spans 1 s). The pull's sums then join the reported covariances as `d d^T` (position,
//! velocity, attitude), the doubt of what those fixes moved it by, in the part beyond the
//! gate ([`Pull::reported_doubt`], as a refused cluster's): nearly all of an 80-sigma pull,
//! little of one just beyond the gate (a filter whose noise model is a little optimistic
//! crosses it now and then with fault-free fixes). Reported,
//! not gated, and not under a declared correlated GNSS error, whose fixes' corrections are
//! not independent. The test needs its evidence: the first 15 s of that ramp stay beyond
//! 4 sigma, a ramp as slow as a tactical MEMS filter's own drift is not seen at all, and
//! where the covariance added for a refused fix or a window detection is taken away again
//! by the next fixes, that shrink hides the pull (most 5 and 10 Hz ramps, README). The
//! coasting test of [`super::coast`] does not depend on that shrink.
//!
//! **A gross cluster** is not released that way. Its first fix was beyond
//! [`GROSS_NIS_FACTOR`] times the gate, a jump no plausible optimism of the filter's own
//! covariance explains (a 30 m offset against a 0.3 m sigma), at a time the filter's position
//! had been confirmed by a full window of fixes (a wrong initial position is not confirmed:
//! the rule above re-acquires from it). The filter knew its position then, and its later
//! drift, however large, is no evidence for the jump: a MEMS filter whose sigma grows to 10 m
//! in 40 s of refusals would otherwise take a held 30 m offset as its position with a sigma of
//! centimetres. A gate refusal that the cluster contains, or that lies closer to it than to
//! the filter's prediction ([`RefusedCluster::continued_by`]: one member's chance excursion
//! must not restart it as a cluster that is not gross), continues it (its start is kept).
//! Its members are refused for as long as the chain of members tells
//! the jump apart from the filter's own drift: the next member must lie on the line through
//! the last two (the filter's drift is smooth: between fixes its error departs from a straight
//! line by its acceleration error times `dt^2`, centimetres), within [`CHAIN_GATE_FACTOR`]
//! times the gate of that extrapolation's noise, which the jump must exceed
//! ([`RefusedCluster::extrapolation`]; with one member, the distance of [`RefusedCluster::contains`]
//! and the gate). When the fault ends, the next fix leaves the line by the jump and is judged
//! by the gate alone, against the sigma the filter's drift has grown to. A filter so poor that
//! its acceleration error blurs the jump between fixes can no longer tell, and the rule above
//! applies. The price: a filter that an unseen fault pulled off by such a gross amount stays
//! DEGRADED (refusing) until the fixes leave the line or its drift blurs the jump, unless
//! its offset has moved since the jump by more than [`GROSS_NIS_FACTOR`] times the gate of its
//! own position variance ([`RefusedCluster::moved`]), or by more than the gate once the
//! filter is DEGRADED by refusals ([`RefusedCluster::judged`]; an RLG flight that had
//! followed a ramp through its velocity drifted away from the true fixes after it with its
//! own covariance growing as fast: 950 m off under 94 m): then the filter, not the fixes,
//! ran away, its reported sigma carries their offset (below), and once its own 1-sigma is
//! beyond the limit the sequencer re-aligns it ([`super::ErrorFilter::diverged`]).
//!
//! **A re-acquisition is checked by the next fix** [Groves, ch. 17, adaptation]. After a gap
//! (an outage, a wide start) the prediction is far wider than a fix, so the gate cannot see a
//! bad first fix (a 20 m spike inside a 36 m sigma) and the update takes it (limited to a
//! [`super::background::MAX_SHRINK`] shrink of the variance). The next true fix then lies
//! beyond the gate of the shrunk covariance: refused, it would start a cluster of true fixes
//! that a filter held by velocity fixes never releases. So when the fix after such a
//! re-acquisition fails the gate, the re-acquisition is undone in the covariance
//! ([`Reacquisition::undo`]: the position variance it removed comes back, and the correction
//! `d` it applied joins as `P <- P + d d^T`, fault recovery by covariance increase as the
//! window does), and the fix is judged again: the two fixes disagree, and the filter no
//! longer pretends to know which. A fix taken that way is itself a re-acquisition, checked by
//! the next one. Until that next fix, the reported position covariance carries
//! `d_p d_p^T / 4` of the correction's position part (the doubt below: unconfirmed, the
//! position it left stays within 2 sigma).
//!
//! **The doubt a refusal leaves** (reported, not gated). A cluster that is not gross is a
//! disagreement the filter cannot settle from the fixes: after a slow ramp that a MEMS filter
//! followed (its innovations stay white: the ramp is as fast as its own drift), the true fixes
//! come back as a step and are refused while the filter is the one that is wrong. Its
//! covariance knows nothing of that, so the reported position covariance adds the cluster's
//! offset `z` as `z z^T / 4` ([`RefusedCluster::doubt`]): the refused fixes stay within
//! 2 sigma of the solution, which does not claim to exclude what it cannot tell from its own
//! error. Only the reported covariance carries it (the gate, the cluster rules and the
//! updates use the filter's own, so what the filter refuses is unchanged); a gross cluster
//! adds none (the filter knew its position when the jump came) until it has run away
//! ([`RefusedCluster::ran_away`]: its offset moved since the jump by more than
//! [`GROSS_NIS_FACTOR`] times the gate of the filter's own position variance, latched): then
//! the filter, not the fixes, is moving, and it cannot claim to exclude them (a given start's
//! heading 90 deg off under a declared 0.1 deg: the fixes ran away at the car's 15 m/s, and
//! the rows were hundreds of metres off with a 3 m sigma). Where the offset is a doubt, the
//! rate at which it moves is one on the velocity ([`RefusedCluster::velocity_doubt`]): the
//! filter's velocity error is what moves a true offset (those rows were 15 m/s off under a
//! velocity 1-sigma of 1 cm/s), and the angle between the solution's track and the refused
//! fixes' is one on the heading ([`RefusedCluster::heading_doubt`]: the heading 1-sigma of
//! those rows was 0.1 deg). A cluster that starts while
//! another is refused carries the other's doubt ([`RefusedCluster::replacing`]): a held offset
//! that begins while the filter refuses the true fixes it may have drifted from (after a ramp
//! it followed) leaves that doubt standing.

use super::motion::MIN_DIFFERENCE_INTERVAL_S;
use super::states::{ATT, BA, BG, Covariance, POS, StateVector, VEL};
use crate::Scalar;
use nalgebra::{Matrix3, Vector3};

/// Fixes in the window [-] (10 s at 1 Hz).
pub const WINDOW: usize = 10;

/// Consecutive refused fixes [-] after which a failing window no longer refuses: by then it
/// holds the filter's own drift since it stopped using fixes (module docs).
pub const WINDOW_REFUSALS_MAX: u32 = WINDOW as u32;

/// 99.9 % point of chi-square with `3 * WINDOW` = 30 degrees of freedom: the global test.
pub const CHI2_30DOF_999: f64 = 59.703;

/// 99.9 % point of chi-square with `3 * (WINDOW - 1)` = 27 degrees of freedom: the global
/// test about the window's mean, under a declared correlated GNSS error.
pub const CHI2_27DOF_999: f64 = 55.476;

/// Velocity fixes in the window of the inconsistency test [-] (20 s at 1 Hz; module docs).
pub const VELOCITY_WINDOW: usize = 20;

/// The inconsistency test's threshold on the velocity window's local statistic, in gates
/// [-]: 21.1 for the default gate, the chi-square(3) 99.99 % point (module docs).
pub const INCONSISTENT_GATE_FACTOR: f64 = 1.3;

/// The horizontal speed below which a track has no direction to compare
/// ([`RefusedCluster::heading_doubt`]) [m/s].
pub const HEADING_DOUBT_MIN_SPEED_M_S: f64 = 2.0;

/// A cluster whose first fix's normalised innovation squared exceeds the gate by this factor
/// [-] is gross (module docs): beyond what a filter whose 1-sigma were up to 4 times
/// optimistic (16 in variance) could see from its own error.
pub const GROSS_NIS_FACTOR: f64 = 16.0;

/// A GNSS fix refused with a normalised innovation squared beyond this factor times the gate
/// [-] (65 for 3 dof: 8 sigma, a chance of 1e-13 for a consistent filter and honest fix) is a
/// gross disagreement between the fixes and the solution: one of them is faulty, and until a
/// fix of that aid is taken again the status is not NAV
/// ([`super::FilterStatus::AidingRejected`], module docs). An IMU fault (an axis stuck in a turn, a spike) made the velocity fixes'
/// innovations 100-150,000 at the first refusal, while the rows stayed NAV for the 5 s the
/// refusals in a row took, 100-600 sigma off [Groves, ch. 17: fault detection].
pub const SUSPECT_NIS_FACTOR: f64 = 4.0;

/// The horizontal position error [m] a heading error of 3 sigma (`yaw_sigma_rad` [rad], at
/// most half a turn) leaves beyond its small-angle model over `distance_m` [m] travelled since
/// the last fix taken: `d |exp(i psi) - 1 - i psi|`, the first-order term `d psi` being the
/// filter's [Groves, ch. 14: a heading error beyond the small-angle model]. A prediction
/// blurred by it cannot tell a jump from its own error (module docs, a gross cluster).
pub fn heading_blur_m<T: Scalar>(distance_m: T, yaw_sigma_rad: T) -> T {
    let psi = (yaw_sigma_rad * T::c(3.0)).min(T::c(core::f64::consts::PI));
    let (sin, cos) = (psi.psin(), psi.pcos());
    distance_m * ((T::one() - cos) * (T::one() - cos) + (psi - sin) * (psi - sin)).sqrt()
}

/// The fastest a GNSS position fault shared by consecutive fixes moves [m/s]: code multipath
/// and the atmosphere change the fixes by metres over tens of seconds (the outlier bench's
/// ramp, 5 m over 30 s, moves at 0.17 m/s). A refused jump whose offset runs away faster than
/// this, and faster than the filter's own velocity covariance allows, is the filter's fault
/// [Groves, ch. 17] (`ErrorFilter::diverged`).
pub const FAULT_RATE_MAX_M_S: f64 = 2.0;

/// The chain of a gross cluster is judged against this factor times the gate [-]: chi-square
/// with 3 degrees of freedom at about 65, which a member on the chain exceeds with a
/// probability of 1e-13 (a false release would capture the cluster).
pub const CHAIN_GATE_FACTOR: f64 = 4.0;

/// Median of chi-square with 3 degrees of freedom: a refused cluster whose offset is this
/// typical of the filter's own error is released (module docs).
pub const CHI2_3DOF_MEDIAN: f64 = 2.366;

/// The part of a difference whose statistic is `stat` that lies beyond the gate's ellipsoid,
/// as a fraction of it: `1 - sqrt(gate / stat)`, zero within the gate. The fault a test that
/// fails can claim is at least that part: the rest is what the noise it is judged against
/// explains. A difference just beyond the gate claims next to nothing; one ten times its
/// 1-sigma nearly all of it.
pub(crate) fn beyond_gate<T: Scalar>(stat: T, gate: T) -> T {
    if stat > gate {
        T::one() - (gate / stat).sqrt()
    } else {
        T::zero()
    }
}

/// `L^-1 z` for `S = L L^T` (the whitened innovation); `None` when `S` is not positive
/// definite.
pub fn whiten<T: Scalar>(s: &Matrix3<T>, z: &Vector3<T>) -> Option<Vector3<T>> {
    let l = s.cholesky()?;
    l.l().solve_lower_triangular(z)
}

/// A position fix taken as a re-acquisition (its update's shrink limited by
/// [`super::background::MAX_SHRINK`]), until the next fix confirms it (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reacquisition<T: Scalar> {
    /// The correction it applied to the error state.
    pub correction: StateVector<T>,
    /// The position variance it removed, NED (prior minus posterior) [m^2].
    pub position_shrink: Matrix3<T>,
}

impl<T: Scalar> Reacquisition<T> {
    /// Undoes it in the covariance `p`: the removed position variance back, and the
    /// correction `d` as `d d^T` (both positive semi-definite).
    pub fn undo(&self, p: &mut Covariance<T>) {
        let d = &self.correction;
        *p += d * d.transpose();
        let mut pos = p.fixed_view_mut::<3, 3>(POS, POS);
        pos += self.position_shrink;
    }

    /// The reported doubt while unconfirmed: `d_p d_p^T / 4` of the correction's position
    /// part [m^2].
    pub fn doubt(&self) -> Matrix3<T> {
        let d = self.correction.fixed_rows::<3>(POS);
        d * d.transpose() * T::c(0.25)
    }
}

/// What the fixes taken since the window restarted after [`WINDOW_REFUSALS_MAX`] refusals
/// moved the solution by, until [`WINDOW`] of them confirm the restart (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Restart<T: Scalar> {
    /// Their position corrections, each carried to the last fix by the velocity corrections
    /// before it, NED [m].
    pub position_ned_m: Vector3<T>,
    /// Their velocity corrections, NED [m/s].
    pub velocity_ned_m_s: Vector3<T>,
    /// Fixes taken since the restart [-].
    pub fixes: usize,
    /// The filter's position covariance before the restart, NED [m^2].
    pub before_m2: Matrix3<T>,
}

impl<T: Scalar> Restart<T> {
    /// At the restart, the filter's position covariance `before_m2` [m^2]: nothing moved
    /// yet.
    pub fn new(before_m2: Matrix3<T>) -> Self {
        Self {
            position_ned_m: Vector3::zeros(),
            velocity_ned_m_s: Vector3::zeros(),
            fixes: 0,
            before_m2,
        }
    }

    /// Carried `dt_s` [s] on: the velocity corrections move the position by `dv dt`
    /// (the position-velocity block of the transition, to first order).
    pub fn carried(&self, dt_s: T) -> Self {
        Self {
            position_ned_m: self.position_ned_m + self.velocity_ned_m_s * dt_s,
            ..*self
        }
    }

    /// With the correction `x` of the next fix taken.
    pub fn taken(&self, x: &StateVector<T>) -> Self {
        Self {
            position_ned_m: self.position_ned_m + x.fixed_rows::<3>(POS),
            velocity_ned_m_s: self.velocity_ned_m_s + x.fixed_rows::<3>(VEL),
            fixes: self.fixes + 1,
            ..*self
        }
    }

    /// True once [`WINDOW`] fixes have been taken since the restart.
    pub fn is_confirmed(&self) -> bool {
        self.fixes >= WINDOW
    }

    /// The doubt on the position `dt_s` [s] after the last fix, when the filter's position
    /// covariance is `p_pos_m2` [m^2] (module docs): the covariance of the two hypotheses,
    /// equally likely, about the solution, `(P_0 + P) / 2 + d d^T / 2` with `d` what the
    /// fixes moved it by and `P_0` [`Self::before_m2`], less `P` [m^2].
    pub fn doubt(&self, dt_s: T, p_pos_m2: &Matrix3<T>) -> Matrix3<T> {
        let d = self.carried(dt_s).position_ned_m;
        (self.before_m2 - p_pos_m2 + d * d.transpose()) * T::c(0.5)
    }
}

/// How long the accepted fixes' corrections are remembered by [`Pull`] [s] (their weight
/// falls to about a half after it: a minute-long fault followed is still there when it ends).
pub const PULL_MEMORY_S: f64 = 120.0;

/// What the accepted position fixes of the last minutes moved the solution by (module
/// docs): their position, velocity, attitude and sensor-bias corrections, each summed as it
/// was applied
/// (the velocity corrections are not carried into the position: carried on over minutes,
/// the small corrections of a consistent filter's velocity added up to metres, and a held
/// offset passed for them), and the position and velocity covariance the fixes took away,
/// all with a memory of [`PULL_MEMORY_S`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pull<T: Scalar> {
    /// The position corrections (error state: the solution moved by minus this), NED [m].
    pub position_ned_m: Vector3<T>,
    /// The velocity corrections, NED [m/s].
    pub velocity_ned_m_s: Vector3<T>,
    /// The attitude corrections, NED [rad].
    pub attitude_rad: Vector3<T>,
    /// The position covariance the fixes took away, with the squared weights [m^2].
    pub position_shrink_m2: Matrix3<T>,
    /// The velocity covariance the fixes took away, with the squared weights [m^2/s^2].
    pub velocity_shrink: Matrix3<T>,
    /// The gyro bias corrections, body frame [rad/s].
    pub gyro_bias_rad_s: Vector3<T>,
    /// The accelerometer bias corrections, body frame [m/s^2].
    pub accel_bias_mps2: Vector3<T>,
}

impl<T: Scalar> Pull<T> {
    /// Nothing pulled.
    pub fn none() -> Self {
        Self {
            position_ned_m: Vector3::zeros(),
            velocity_ned_m_s: Vector3::zeros(),
            attitude_rad: Vector3::zeros(),
            position_shrink_m2: Matrix3::zeros(),
            velocity_shrink: Matrix3::zeros(),
            gyro_bias_rad_s: Vector3::zeros(),
            accel_bias_mps2: Vector3::zeros(),
        }
    }

    /// Forgotten over `dt_s` [s] by `1 / (1 + x + x^2 / 2)`, `x = dt / PULL_MEMORY_S` (the
    /// consider states' decay, to second order).
    pub fn carried(&self, dt_s: T) -> Self {
        let x = dt_s / T::c(PULL_MEMORY_S);
        let k = T::one() / (T::one() + x + x * x * T::c(0.5));
        Self {
            position_ned_m: self.position_ned_m * k,
            velocity_ned_m_s: self.velocity_ned_m_s * k,
            attitude_rad: self.attitude_rad * k,
            position_shrink_m2: self.position_shrink_m2 * (k * k),
            velocity_shrink: self.velocity_shrink * (k * k),
            gyro_bias_rad_s: self.gyro_bias_rad_s * k,
            accel_bias_mps2: self.accel_bias_mps2 * k,
        }
    }

    /// With the correction `x` of a fix taken, and the position and velocity covariance it
    /// took away.
    pub fn taken(
        &self,
        x: &StateVector<T>,
        shrink_pos: &Matrix3<T>,
        shrink_vel: &Matrix3<T>,
    ) -> Self {
        Self {
            position_ned_m: self.position_ned_m + x.fixed_rows::<3>(POS),
            velocity_ned_m_s: self.velocity_ned_m_s + x.fixed_rows::<3>(VEL),
            attitude_rad: self.attitude_rad + x.fixed_rows::<3>(ATT),
            position_shrink_m2: self.position_shrink_m2 + shrink_pos,
            velocity_shrink: self.velocity_shrink + shrink_vel,
            gyro_bias_rad_s: self.gyro_bias_rad_s + x.fixed_rows::<3>(BG),
            accel_bias_mps2: self.accel_bias_mps2 + x.fixed_rows::<3>(BA),
        }
    }

    /// What is left once the velocity, attitude and sensor-bias sums have joined the
    /// filter's covariance (a re-acquisition): the position's, still what a later fault test
    /// and the pull's recovery compare fixes with. Kept, the sums joined the covariance again
    /// when the filter was DEGRADED a second time within [`PULL_MEMORY_S`], and the reported
    /// doubt counted them beside the covariance that held them.
    pub fn position_only(&self) -> Self {
        Self {
            position_ned_m: self.position_ned_m,
            position_shrink_m2: self.position_shrink_m2,
            ..Self::none()
        }
    }

    /// True when the pull is more than the fixes' own corrections explain: the position's or
    /// the velocity's, whitened with the covariance the fixes took away, beyond `gate_3dof`
    /// (module docs).
    pub fn is_fault(&self, gate_3dof: T) -> bool {
        self.weight(gate_3dof) > T::zero()
    }

    /// The part of the pull a fault holds [-]: of the position's and the velocity's sums,
    /// whitened with the covariance the fixes took away, the larger part beyond `gate_3dof`
    /// (`beyond_gate`, as a refused cluster's [`RefusedCluster::weight`]); zero within it.
    pub fn weight(&self, gate_3dof: T) -> T {
        let part = |d: &Vector3<T>, c: &Matrix3<T>| {
            whiten(c, d).map_or_else(T::zero, |w| beyond_gate(w.norm_squared(), gate_3dof))
        };
        part(&self.position_ned_m, &self.position_shrink_m2)
            .max(part(&self.velocity_ned_m_s, &self.velocity_shrink))
    }

    /// The reported doubt of a pull that is a fault ([`Self::is_fault`]): [`Self::doubt`] of
    /// the part [`Self::weight`] of each sum. Whole, a pull just beyond the gate (clean RTK
    /// fixes on a car leaving a stop, the sums of 2 min of corrections 10 cm against a
    /// filter's 6 mm 1-sigma, their statistic 17 against the gate's 16.3) widened the
    /// reported 1-sigma ten times for 15 s, the error staying below 6 mm.
    pub fn reported_doubt(&self, gate_3dof: T) -> [Matrix3<T>; 3] {
        let w = self.weight(gate_3dof);
        self.doubt().map(|d| d * (w * w))
    }

    /// The doubt on the position [m^2], velocity [m^2/s^2] and attitude [rad^2] of what the
    /// fixes pulled the solution by: `d d^T` of each.
    pub fn doubt(&self) -> [Matrix3<T>; 3] {
        [
            self.position_ned_m,
            self.velocity_ned_m_s,
            self.attitude_rad,
        ]
        .map(|d| d * d.transpose())
    }

    /// The doubt on the gyro biases [rad^2/s^2] and the accelerometer biases [m^2/s^4] of
    /// what the fixes moved them by: `d d^T` of each (taken at a recovery, not reported).
    pub fn sensor_doubt(&self) -> [Matrix3<T>; 2] {
        [self.gyro_bias_rad_s, self.accel_bias_mps2].map(|d| d * d.transpose())
    }

    /// True when a fix of innovation `z` (predicted minus measured) [m] and innovation
    /// covariance `s` [m^2], refused by the gate, agrees with the solution as it was before
    /// this pull (`z + d` within `gate_3dof`), and the pull `d` is itself beyond what the
    /// fix's noise explains (`d` beyond `gate_3dof`): the fixes that pulled it were a fault
    /// that has ended (a multipath ramp the filter followed under a declared correlated
    /// error, then refused the true fixes as a jump, DEGRADED to the end 14 m off).
    pub fn explains(&self, z: &Vector3<T>, s: &Matrix3<T>, gate_3dof: T) -> bool {
        let d = &self.position_ned_m;
        let beyond = whiten(s, d).is_some_and(|w| w.norm_squared() > gate_3dof);
        beyond && whiten(s, &(z + d)).is_some_and(|w| w.norm_squared() <= gate_3dof)
    }
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
    w: BiasWindow<T, WINDOW>,
    /// The correction each fix applied, in the slot of its innovation.
    corrections: [StateVector<T>; WINDOW],
}

impl<T: Scalar> Default for InnovationWindow<T> {
    fn default() -> Self {
        Self {
            w: BiasWindow::default(),
            corrections: [StateVector::zeros(); WINDOW],
        }
    }
}

impl<T: Scalar> InnovationWindow<T> {
    /// Adds a whitened innovation `w` [-], dropping the oldest when full.
    pub fn push(&mut self, w: Vector3<T>) {
        let slot = self.w.push(w);
        self.corrections[slot] = StateVector::zeros();
    }

    /// Records the correction `x` the last pushed fix applied to the error state.
    pub fn set_last_correction(&mut self, x: &StateVector<T>) {
        if let Some(slot) = self.w.last_slot() {
            self.corrections[slot] = *x;
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
        self.w.len
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.w.len == 0
    }

    /// The local statistic `|sum w|^2 / n` [-] (`chi^2(3)` under no fault; 0 when empty).
    pub fn bias_statistic(&self) -> T {
        self.w.mean_statistic()
    }

    /// The global statistic `sum |w|^2` [-] (`chi^2(3 n)` under no fault).
    pub fn spread_statistic(&self) -> T {
        self.w
            .held()
            .iter()
            .fold(T::zero(), |a, w| a + w.norm_squared())
    }

    /// The global statistic about the window's mean, `sum |w - mean|^2 = sum |w|^2 - |sum
    /// w|^2 / n` [-] (`chi^2(3 (n - 1))` for independent `w`; fewer for `w` that share a
    /// common part, which it removes).
    pub fn spread_about_mean_statistic(&self) -> T {
        (self.spread_statistic() - self.bias_statistic()).max(T::zero())
    }

    /// Both tests at 99.9 %: the local one against `gate_3dof` (the per-fix gate's point), the
    /// global one against [`CHI2_30DOF_999`] once the window is full. `correlated`, under a
    /// declared time-correlated GNSS error (a consider state, [`super::consider`]), leaves the
    /// local test out and takes the global one about the window's mean
    /// ([`Self::spread_about_mean_statistic`] against [`CHI2_27DOF_999`]): a bias common to the
    /// window is what the receiver was declared to have, the innovations share it and are not
    /// independent, and the per-fix gate (whose innovation covariance holds that error's
    /// variance) judges its size. Taken about zero, a declared error drawn at 2.5 sigma made
    /// every whitened innovation of the window about 2.5 long and failed the global test as
    /// well (a tactical MEMS filter then refused the true fixes at rest and drifted 2 km).
    pub fn verdict(&self, gate_3dof: T, correlated: bool) -> WindowVerdict {
        let spread = if correlated {
            self.spread_about_mean_statistic() > T::c(CHI2_27DOF_999)
        } else {
            self.spread_statistic() > T::c(CHI2_30DOF_999)
        };
        if !correlated && self.bias_statistic() > gate_3dof {
            WindowVerdict::Bias
        } else if self.w.len == WINDOW && spread {
            WindowVerdict::Spread
        } else {
            WindowVerdict::Consistent
        }
    }
}

/// The last `L` whitened innovations of an aid and their local statistic, a ring of fixed size
/// (the velocity fixes' inconsistency test; [`InnovationWindow`] keeps the position fixes'
/// in one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasWindow<T: Scalar, const L: usize> {
    w: [Vector3<T>; L],
    len: usize,
    next: usize,
}

impl<T: Scalar, const L: usize> Default for BiasWindow<T, L> {
    fn default() -> Self {
        Self {
            w: [Vector3::zeros(); L],
            len: 0,
            next: 0,
        }
    }
}

impl<T: Scalar, const L: usize> BiasWindow<T, L> {
    /// Adds a whitened innovation `w` [-], dropping the oldest when full; the slot it took.
    pub fn push(&mut self, w: Vector3<T>) -> usize {
        let slot = self.next;
        self.w[slot] = w;
        self.next = (self.next + 1) % L;
        self.len = (self.len + 1).min(L);
        slot
    }

    /// The slot of the last innovation pushed, if any.
    fn last_slot(&self) -> Option<usize> {
        (self.len > 0).then(|| (self.next + L - 1) % L)
    }

    /// The innovations held (in slot order).
    fn held(&self) -> &[Vector3<T>] {
        &self.w[..self.len]
    }

    /// The local statistic `|sum w|^2 / n` [-] over the `n` held (`chi^2(3)` under no fault;
    /// 0 when empty).
    fn mean_statistic(&self) -> T {
        if self.len == 0 {
            return T::zero();
        }
        let sum = self.held().iter().fold(Vector3::zeros(), |a, w| a + w);
        sum.norm_squared() / T::c(self.len as f64)
    }

    /// The local statistic `|sum w|^2 / L` [-] once full (`chi^2(3)` under no fault), else
    /// `None`.
    pub fn bias_statistic(&self) -> Option<T> {
        (self.len == L).then(|| self.mean_statistic())
    }
}

/// The filter's own drift between two fixes, as the cluster tests need it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixDrift<T: Scalar> {
    /// Interval since the previous fix [s].
    pub dt_s: T,
    /// Variance of the position drift over it, per NED axis: the velocity variance times
    /// `dt^2`, plus the change of a declared correlated GNSS error over `dt` [m^2].
    pub var_m2: Vector3<T>,
    /// Variance of the drift's departure from a straight line over it, per NED axis: a bound
    /// of the acceleration error's variance times `dt^4` [m^2].
    pub curvature_var_m2: Vector3<T>,
}

/// The last refused position fixes' innovations and noise variances, and the jump that
/// started the cluster (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefusedCluster<T: Scalar> {
    /// The last member's innovation, predicted minus measured, NED [m].
    pub z_ned_m: Vector3<T>,
    /// Its noise variance, NED [m^2].
    pub r_ned_m2: Vector3<T>,
    /// The member before it (innovation [m], noise variance [m^2]) and the interval between
    /// the two [s]; `None` while the cluster has one member.
    pub previous: Option<(Vector3<T>, Vector3<T>, T)>,
    /// The innovation of the fix that started the cluster, NED [m]: the jump the filter saw
    /// while it still knew its position.
    pub jump_ned_m: Vector3<T>,
    /// The start was gross: its normalised innovation squared beyond [`GROSS_NIS_FACTOR`]
    /// times the gate.
    pub gross: bool,
    /// The first member's innovation as the last one's is taken (corrected alike), NED [m],
    /// and its noise variance [m^2]: how far the offset has moved since.
    pub first: (Vector3<T>, Vector3<T>),
    /// Time from the first member to the last [s].
    pub age_s: T,
    /// Members so far [-].
    pub members: u32,
    /// The part of the first member's innovation beyond the gate, `1 - sqrt(gate / NIS)` of
    /// its normalised square `NIS` [-]: all a lone refused fix claims ([`Self::weight`]).
    pub beyond: T,
    /// The sum of the members' innovations, NED [m], corrected as the last one's is
    /// ([`Self::corrected`]): the evidence of their common offset ([`Self::weight`]).
    pub sum_z_ned_m: Vector3<T>,
    /// The sum of their noise variances, NED [m^2].
    pub sum_r_ned_m2: Vector3<T>,
    /// The gate the cluster was started against [-].
    pub gate_3dof: T,
    /// The doubt of a cluster this one replaced while it was still refused [m^2] (module
    /// docs: a held offset that starts while the true fixes are refused does not clear the
    /// filter's doubt about them).
    pub carried_doubt: Matrix3<T>,
    /// A gross cluster whose offset moved away from the jump beyond what the filter's own
    /// position variance allows, as last [`Self::judged`] (latched): the filter, not the
    /// fixes, ran away (module docs).
    pub ran_away: bool,
    /// For a lone refused fix, the refused fix just before it that it did not continue
    /// (innovation [m], noise variance [m^2], the interval [s]): their offsets' rate is a
    /// doubt on the velocity ([`Self::velocity_doubt`]).
    pub refused_before: Option<(Vector3<T>, Vector3<T>, T)>,
}

impl<T: Scalar> RefusedCluster<T> {
    /// A cluster started by a fix refused by the gate (innovation `z` [m], noise variance `r`
    /// [m^2], normalised innovation squared `nis` [-] against the gate `gate_3dof`);
    /// `confirmed` when the filter's position had been confirmed by fixes (a full window of
    /// them passed the gate): only then can the start be gross.
    pub fn start(z: Vector3<T>, r: Vector3<T>, nis: T, gate_3dof: T, confirmed: bool) -> Self {
        Self {
            z_ned_m: z,
            r_ned_m2: r,
            previous: None,
            jump_ned_m: z,
            gross: confirmed && nis > gate_3dof * T::c(GROSS_NIS_FACTOR),
            first: (z, r),
            age_s: T::zero(),
            members: 1,
            beyond: beyond_gate(nis, gate_3dof),
            sum_z_ned_m: z,
            sum_r_ned_m2: r,
            gate_3dof,
            carried_doubt: Matrix3::zeros(),
            ran_away: false,
            refused_before: None,
        }
    }

    /// This cluster, started while `previous` was refused: it carries `previous`'s doubt.
    pub fn replacing(self, previous: Option<&Self>) -> Self {
        Self {
            carried_doubt: previous
                .and_then(Self::doubt)
                .unwrap_or_else(Matrix3::zeros),
            ..self
        }
    }

    /// This lone refused fix, `dt_s` [s] after `previous`, a lone refused fix it did not
    /// continue ([`Self::refused_before`]); not after a cluster of several, nor a gross one:
    /// the rate from their offset to this fix's is a fault's ending, not the solution's
    /// drift (the true fixes after a 50 m jump).
    pub fn after(self, previous: Option<&Self>, dt_s: T) -> Self {
        Self {
            refused_before: previous
                .filter(|p| p.is_lone() && !p.gross)
                .map(|p| (p.z_ned_m, p.r_ned_m2, dt_s)),
            ..self
        }
    }

    /// The cluster with its next refused member (innovation `z` [m], noise variance `r`
    /// [m^2], `dt_s` [s] after the last one); its start is kept.
    pub fn followed_by(&self, z: Vector3<T>, r: Vector3<T>, dt_s: T) -> Self {
        Self {
            z_ned_m: z,
            r_ned_m2: r,
            previous: Some((self.z_ned_m, self.r_ned_m2, dt_s)),
            age_s: self.age_s + dt_s,
            members: self.members.saturating_add(1),
            sum_z_ned_m: self.sum_z_ned_m + z,
            sum_r_ned_m2: self.sum_r_ned_m2 + r,
            ..*self
        }
    }

    /// The cluster after a correction `dr_ned_m` [m] of the solution's position by another
    /// aid (a stop's zero-velocity update moves a drifted position by metres): its members'
    /// innovations, predicted minus measured, are taken against the corrected solution, so
    /// the next member stays on the chain the correction would otherwise break (and the
    /// cluster released and taken).
    pub fn corrected(&self, dr_ned_m: &Vector3<T>) -> Self {
        Self {
            z_ned_m: self.z_ned_m - dr_ned_m,
            previous: self.previous.map(|(z, r, dt)| (z - dr_ned_m, r, dt)),
            refused_before: self.refused_before.map(|(z, r, dt)| (z - dr_ned_m, r, dt)),
            first: (self.first.0 - dr_ned_m, self.first.1),
            sum_z_ned_m: self.sum_z_ned_m - dr_ned_m * T::c(f64::from(self.members)),
            ..*self
        }
    }

    /// True when the filter's own drift shows in this cluster (module docs, the recovery of a
    /// DEGRADED filter): its offset has moved since the first member by more than the
    /// filter's position variances `p_pos_m2` [m^2] explain, the normalised square of
    /// `z - z_1` against `R + R_1 + P_pos` beyond the gate. Never for a gross cluster.
    pub fn drifted(&self, p_pos_m2: &Vector3<T>, gate_3dof: T) -> bool {
        !self.gross && self.moved(p_pos_m2) > gate_3dof
    }

    /// True when the cluster's drift rate ([`Self::drift_rate`]) is one the filter's own
    /// velocity could have: its normalised square against the velocity covariance `p_vel`
    /// [m^2/s^2] within [`GROSS_NIS_FACTOR`] times the gate, the optimism a jump is allowed
    /// (module docs). Beyond it the fixes, not the filter, are moving: a multipath ramp of
    /// 0.5 m/s that an RLG filter (velocity 1-sigma 5 mm/s) refused from its start would
    /// otherwise be taken as the filter's own drift once DEGRADED, and the filter captured
    /// by it (13 m off with a 0.4 m 1-sigma, then the true fixes refused as a jump).
    pub fn drift_is_plausible(&self, p_vel: &Matrix3<T>, gate_3dof: T) -> bool {
        let v = self.drift_rate();
        let Some(inv) = p_vel.try_inverse() else {
            return false;
        };
        (v.transpose() * inv * v)[(0, 0)] <= gate_3dof * T::c(GROSS_NIS_FACTOR)
    }

    /// How far the offset has moved since the first member against the filter's position
    /// variances `p_pos_m2` [m^2]: the normalised square [-] of `z - z_1` against
    /// `R + R_1 + P_pos`.
    pub fn moved(&self, p_pos_m2: &Vector3<T>) -> T {
        let (z1, r1) = self.first;
        normalised_square(&(self.z_ned_m - z1), &(self.r_ned_m2 + r1 + p_pos_m2))
    }

    /// The rate at which the offset moved from the first member to the last [m/s]; zero
    /// with one member.
    pub fn drift_rate(&self) -> Vector3<T> {
        if self.age_s > T::zero() {
            (self.z_ned_m - self.first.0) / self.age_s
        } else {
            Vector3::zeros()
        }
    }

    /// True when a fix with innovation `z` [m] and noise variance `r` [m^2] agrees with the
    /// last member: [`Self::distance`] within `gate_3dof` (chi-square with 3 degrees of
    /// freedom).
    pub fn contains(
        &self,
        z: &Vector3<T>,
        r: &Vector3<T>,
        drift: &FixDrift<T>,
        gate_3dof: T,
    ) -> bool {
        self.distance(z, r, drift) <= gate_3dof
    }

    /// True when a fix refused by the gate (innovation `z` [m], noise variance `r` [m^2],
    /// normalised innovation squared `nis` [-]) continues this cluster rather than starting
    /// one: [`Self::contains`] it, or, for a gross cluster, it lies closer to the last member
    /// ([`Self::distance`]) than to the filter's prediction (`nis`). Held to the gate alone, a
    /// gross cluster of 150 fixes broke on a chance excursion of one member (1 in 1000 per
    /// fix at 99.9 %), and the fix that broke it started a cluster that was not gross (the
    /// filter's covariance had grown by then): released as typical, it was taken (a 30 m
    /// offset followed with a sigma of 2 m). The filter has taken no fix since the jump, so
    /// the jump is what it knew when it last knew its position.
    pub fn continued_by(
        &self,
        z: &Vector3<T>,
        r: &Vector3<T>,
        drift: &FixDrift<T>,
        nis: T,
        gate_3dof: T,
    ) -> bool {
        let q = self.distance(z, r, drift);
        q <= gate_3dof || (self.gross && q < nis)
    }

    /// The normalised square `(z - z_c)^T (R + R_c + D)^-1 (z - z_c)` [-] of a fix's
    /// innovation `z` [m] against the last member's `z_c`, `D` the filter's drift between
    /// them ([`FixDrift::var_m2`]).
    pub fn distance(&self, z: &Vector3<T>, r: &Vector3<T>, drift: &FixDrift<T>) -> T {
        let den = r + self.r_ned_m2 + drift.var_m2;
        normalised_square(&(z - self.z_ned_m), &den)
    }

    /// The chain test of a gross cluster with two members or more (module docs): the
    /// normalised squares [-] of a fix's departure from the line through the last two
    /// members, and of the start's jump, against the noise of that extrapolation
    /// `R + (1 + a)^2 R_1 + a^2 R_2 + K` (`a` the ratio of the two intervals, `K`
    /// [`FixDrift::curvature_var_m2`]); `None` with one member.
    pub fn extrapolation(
        &self,
        z: &Vector3<T>,
        r: &Vector3<T>,
        drift: &FixDrift<T>,
    ) -> Option<(T, T)> {
        let (z2, r2, dt2) = self.previous?;
        if !(dt2 > T::zero()) {
            return None;
        }
        let a = drift.dt_s / dt2;
        let predicted = self.z_ned_m + (self.z_ned_m - z2) * a;
        let b = T::one() + a;
        let den = r + self.r_ned_m2 * (b * b) + r2 * (a * a) + drift.curvature_var_m2;
        Some((
            normalised_square(&(z - predicted), &den),
            normalised_square(&self.jump_ned_m, &den),
        ))
    }

    /// True when a fix (innovation `z` [m], noise variance `r` [m^2], normalised innovation
    /// squared `nis` [-] against the innovation covariance `s` [m^2]) is refused as a member
    /// (module docs). A gross cluster whose chain still tells its jump from the filter's
    /// drift (the jump's [`Self::extrapolation`] beyond [`CHAIN_GATE_FACTOR`] times the gate,
    /// or with one member its [`Self::distance`] beyond the gate) claims every fix that stays
    /// on the chain. Otherwise a member is within [`Self::contains`], agrees better with the
    /// cluster than with the filter's prediction, and the cluster is not yet
    /// [`Self::is_typical`], nor, if not gross, [`WINDOW_REFUSALS_MAX`] members long.
    pub fn claims(
        &self,
        z: &Vector3<T>,
        r: &Vector3<T>,
        drift: &FixDrift<T>,
        nis: T,
        s: &Matrix3<T>,
        gate_3dof: T,
    ) -> bool {
        let q = self.distance(z, r, drift);
        if self.gross {
            let chain_gate = gate_3dof * T::c(CHAIN_GATE_FACTOR);
            match self.extrapolation(z, r, drift) {
                Some((q_line, q_jump)) if q_jump > chain_gate => return q_line <= chain_gate,
                None if normalised_square(
                    &self.jump_ned_m,
                    &(r + self.r_ned_m2 + drift.var_m2),
                ) > gate_3dof =>
                {
                    return q <= gate_3dof;
                }
                _ => {}
            }
        }
        // Not gross: held for at most a window of members (module docs).
        let holds = self.gross || self.members < WINDOW_REFUSALS_MAX;
        holds && q <= gate_3dof && q < nis && !self.is_typical(s)
    }

    /// The cluster judged against the filter's own position variances `p_pos_m2` [m^2] with
    /// the gate `gate_3dof`: it has run away ([`Self::ran_away`], latched) once it is gross
    /// and its offset has moved since the jump by more than [`GROSS_NIS_FACTOR`] times the
    /// gate ([`Self::moved`]), or by more than the gate once the filter is `degraded` by
    /// refusals ([`super::FilterConfig::rejections_to_degrade`] in a row): after that many,
    /// a jump is no longer held against fixes that move away from the filter beyond its own
    /// variance (an RLG flight that had followed a multipath ramp through its velocity
    /// refused the true fixes after it as a jump, and drifted to 950 m off under a 94 m
    /// 1-sigma, its own covariance growing as fast as the fixes moved away).
    pub fn judged(self, p_pos_m2: &Vector3<T>, gate_3dof: T, degraded: bool) -> Self {
        let factor = if degraded {
            T::one()
        } else {
            T::c(GROSS_NIS_FACTOR)
        };
        Self {
            ran_away: self.ran_away || (self.gross && self.moved(p_pos_m2) > gate_3dof * factor),
            ..self
        }
    }

    /// The doubt on the solution's position while this cluster is refused (module docs):
    /// `z z^T / 4` of the last member's innovation `z` [m^2] times [`Self::weight`] squared,
    /// none for a gross cluster that has not run away ([`Self::ran_away`]), plus the doubt
    /// it carries from a cluster it replaced; `None` when both are none.
    pub fn doubt(&self) -> Option<Matrix3<T>> {
        let w = self.weight();
        let own = (!self.gross || self.ran_away)
            .then(|| self.z_ned_m * self.z_ned_m.transpose() * (T::c(0.25) * w * w));
        let carried = (self.carried_doubt != Matrix3::zeros()).then_some(self.carried_doubt);
        match (own, carried) {
            (Some(a), Some(b)) => Some(a + b),
            (a, b) => a.or(b),
        }
    }

    /// True while the cluster is one refused fix.
    pub fn is_lone(&self) -> bool {
        self.members < 2
    }

    /// The part of the offset the cluster holds against the filter [-]: the part of the
    /// evidence beyond the gate. For a lone refused fix, its own ([`Self::beyond`]); for more
    /// members, that of their common offset, the sum of their innovations against the sum of
    /// their noise variances (the members' noise is independent; the filter's own error, which
    /// they share, is what the cluster stands for), so that the evidence and the part grow
    /// with the members; all of it for a gross cluster, which only holds a doubt once it ran
    /// away. The gate refuses fault-free fixes at its false-alarm rate (one in a thousand),
    /// and the next ordinary fix lies closer to such an outlier than to the prediction often
    /// enough to join it: a 4.3-sigma fix of 2 m at 10 Hz, taken whole as the solution's
    /// doubt, had the next ordinary fix move the solution by 8 m, and a chance pair by 3 m. A
    /// fix far beyond the gate (the true fixes after a fault the filter followed) still
    /// claims nearly all of its offset.
    pub fn weight(&self) -> T {
        if self.gross {
            T::one()
        } else if self.is_lone() {
            self.beyond
        } else {
            let evidence = normalised_square(&self.sum_z_ned_m, &self.sum_r_ned_m2);
            beyond_gate(evidence, self.gate_3dof)
        }
    }

    /// The doubt on the solution's velocity while this cluster is refused [m^2/s^2], where
    /// its offset is a doubt on the position ([`Self::doubt`]: not a gross jump that stayed
    /// put); with one member, only the rate since the refused fix before it
    /// ([`Self::refused_before`]); `None` while the members of a cluster that has not run
    /// away span less than [`MIN_DIFFERENCE_INTERVAL_S`] (the fixes' noise over a tenth of a
    /// second is tens of metres per second). The filter's velocity error is what moves a true
    /// offset (a given start's heading 90 deg off: the rows' velocity 15 m/s off under a
    /// 1-sigma of 1 cm/s): the rate `v` at which the offset moved since the first member
    /// ([`Self::drift_rate`]) as `v v^T / 4`, and for a cluster that ran away, whose error
    /// turns with the vehicle, also the rate `u` since the member before (the fixes' noise
    /// is small beside it) as `u u^T / 4`.
    pub fn velocity_doubt(&self) -> Option<Matrix3<T>> {
        let (v, u) = self.doubted_rates()?;
        let u = u.map_or_else(Matrix3::zeros, |u| u * u.transpose());
        Some((v * v.transpose() + u) * T::c(0.25))
    }

    /// The rates of [`Self::velocity_doubt`] [m/s]: since the first member, and for a cluster
    /// that ran away since the member before; `None` where the offset is no doubt, and
    /// before the members span [`MIN_DIFFERENCE_INTERVAL_S`] unless the cluster ran away
    /// (its offsets dwarf the fixes' noise): two fixes of 2 m a tenth of a second apart
    /// differ at 28 m/s of noise, and a chance pair of refusals at 10 Hz reported 36 m/s of
    /// velocity doubt and 60 deg of heading doubt on a solution 1 cm/s off.
    fn doubted_rates(&self) -> Option<(Vector3<T>, Option<Vector3<T>>)> {
        if self.gross && !self.ran_away {
            return None;
        }
        if self.is_lone() {
            return self.rate_since_refused_before().map(|u| (u, None));
        }
        if self.age_s <= T::zero() {
            return None;
        }
        if !self.ran_away && self.age_s < T::c(MIN_DIFFERENCE_INTERVAL_S) {
            return None;
        }
        let u = self
            .previous
            .filter(|&(_, _, dt)| self.ran_away && dt > T::zero())
            .map(|(z, _, dt)| (self.z_ned_m - z) / dt);
        Some((self.drift_rate(), u))
    }

    /// For a lone refused fix after another it did not continue ([`Self::refused_before`]),
    /// the rate at which their offsets moved [m/s], only its part beyond the gate of their
    /// two noises ([`beyond_gate`], as [`Self::weight`]): a solution whose velocity is off
    /// sees each fix refused on its own, the offset moving faster than the fixes' noise
    /// explains (a given start at rest beside a car at 11 m/s: each RTK fix 12 m from the
    /// one before, a new lone refusal each second, the velocity's 1-sigma 1 cm/s for 6 min).
    fn rate_since_refused_before(&self) -> Option<Vector3<T>> {
        let (z, r, dt) = self.refused_before?;
        if !(dt > T::zero()) {
            return None;
        }
        let d = self.z_ned_m - z;
        let w = beyond_gate(normalised_square(&d, &(self.r_ned_m2 + r)), self.gate_3dof);
        (w > T::zero()).then(|| d * (w / dt))
    }

    /// The doubt on the solution's heading while this cluster is refused [rad^2], at the
    /// solution's velocity `v_eb_n` [m/s], where its offset's rate is a doubt on the velocity
    /// ([`Self::velocity_doubt`]): the refused fixes move over the ground at `v_eb_n - rate`
    /// (the offset is the solution's position minus the fix's), and a heading error turns
    /// the solution's track from theirs by itself (a given start's heading 90 deg off under
    /// a declared 0.1 deg: the fixes' track 90 deg from the solution's). The larger angle `a`
    /// between the two horizontal tracks of the two rates, as `a^2 / 4`. Where either track
    /// is slower than [`HEADING_DOUBT_MIN_SPEED_M_S`] (no direction to compare: a stop) the
    /// doubt `held` from the fix before stands; without a doubt on the velocity, the doubt
    /// this cluster carries from one it replaced ([`Self::replacing`]) keeps `held` as well,
    /// and otherwise there is none.
    pub fn heading_doubt(&self, v_eb_n: &Vector3<T>, held: T) -> T {
        let Some((v, u)) = self.doubted_rates() else {
            let carried = self.carried_doubt != Matrix3::zeros();
            return if carried { held } else { T::zero() };
        };
        let min2 = T::c(HEADING_DOUBT_MIN_SPEED_M_S * HEADING_DOUBT_MIN_SPEED_M_S);
        let angle2 = |rate: Vector3<T>| {
            let fixes = v_eb_n - rate;
            let (a, b) = ((v_eb_n.x, v_eb_n.y), (fixes.x, fixes.y));
            let slow = |(n, e): (T, T)| n * n + e * e < min2;
            if slow(a) || slow(b) {
                return None;
            }
            let angle = (a.0 * b.1 - a.1 * b.0).patan2(a.0 * b.0 + a.1 * b.1);
            Some(angle * angle)
        };
        match (angle2(v), u.and_then(angle2)) {
            (Some(a), Some(b)) => a.max(b) * T::c(0.25),
            (Some(a), None) | (None, Some(a)) => a * T::c(0.25),
            (None, None) => held,
        }
    }

    /// True when this cluster's offset is a typical error of the filter: its normalised
    /// square against the innovation covariance `s` [m^2] within the median of `chi^2(3)`.
    pub fn is_typical(&self, s: &Matrix3<T>) -> bool {
        whiten(s, &self.z_ned_m).is_some_and(|w| w.norm_squared() <= T::c(CHI2_3DOF_MEDIAN))
    }
}

/// `sum d_i^2 / den_i` [-].
fn normalised_square<T: Scalar>(d: &Vector3<T>, den: &Vector3<T>) -> T {
    (0..3).fold(T::zero(), |a, i| a + d[i] * d[i] / den[i])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ins_filter::VEL;

    #[test]
    fn a_heading_blur_is_second_order_when_small_and_bounded_at_half_a_turn() {
        // 3 sigma = 0.003 rad: (1 - cos) ~ psi^2 / 2 dominates, psi - sin ~ psi^3 / 6.
        let small = heading_blur_m(1000.0, 0.001);
        assert!(
            (small / (1000.0 * 0.003f64.powi(2) / 2.0) - 1.0).abs() < 1e-3,
            "{small}"
        );
        // Beyond 60 deg the 3 sigma is half a turn: the solution runs backwards.
        let pi = core::f64::consts::PI;
        for sigma in [1.1, 2.0, 10.0] {
            let b = heading_blur_m(10.0, sigma);
            assert!((b - 10.0 * (4.0 + pi * pi).sqrt()).abs() < 1e-9, "{b}");
        }
        assert_eq!(heading_blur_m(0.0, 1.0), 0.0);
    }

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

    /// Each fix refused on its own, its offset 12 m from the refused one a second before (a
    /// given start at rest beside a car at 12 m/s, RTK fixes): the velocity is doubtful by
    /// that rate, `u u^T / 4`. Two 2 m fixes a tenth of a second apart whose offsets differ
    /// within their noise leave no doubt (28 m/s of noise in their rate).
    #[test]
    fn a_lone_refusal_after_another_doubts_the_velocity_by_their_rate() {
        let gate = crate::ins_filter::CHI2_3DOF_999;
        let rtk = Vector3::repeat(1e-4);
        let first = RefusedCluster::start(Vector3::new(200.0, 100.0, 0.0), rtk, 1e8, gate, false);
        assert!(first.velocity_doubt().is_none());
        let next = RefusedCluster::start(Vector3::new(200.0, 112.0, 0.0), rtk, 1e8, gate, false)
            .after(Some(&first), 1.0);
        let v = next.velocity_doubt().expect("a rate far beyond its noise");
        assert!((v[(1, 1)].sqrt() - 6.0).abs() < 0.05, "{v}");
        assert!(v[(0, 0)].abs() < 1e-6, "{v}");
        let code = Vector3::repeat(4.0);
        let a = RefusedCluster::start(Vector3::new(10.0, 0.0, 0.0), code, 20.0, gate, false);
        let b = RefusedCluster::start(Vector3::new(13.0, 0.0, 0.0), code, 20.0, gate, false)
            .after(Some(&a), 0.1);
        assert!(b.velocity_doubt().is_none(), "{:?}", b.velocity_doubt());
        // After a cluster of several refused fixes (a jump held), the next lone refusal's
        // distance from it is the fault's end, not a rate of the solution.
        let jump = first.followed_by(Vector3::new(200.0, 100.5, 0.0), rtk, 1.0);
        let after_jump = RefusedCluster::start(Vector3::new(0.5, 0.0, 0.0), rtk, 1e4, gate, false)
            .after(Some(&jump), 1.0);
        assert!(after_jump.velocity_doubt().is_none());
    }

    /// A correction of the solution moves the members' innovations with it: a member taken
    /// after it stays on the chain it would otherwise leave.
    #[test]
    fn a_cluster_follows_a_correction_of_the_solution() {
        let gate = crate::ins_filter::CHI2_3DOF_999;
        let r = Vector3::repeat(0.25);
        let drift = FixDrift {
            dt_s: 1.0,
            var_m2: Vector3::repeat(0.01),
            curvature_var_m2: Vector3::repeat(1e-4),
        };
        let c = RefusedCluster::start(Vector3::new(0.0, -30.0, 0.0), r, 3600.0, gate, true)
            .followed_by(Vector3::new(0.0, -29.9, 0.0), r, 1.0);
        assert!(c.gross);
        // A stop's update moves the position by 10 m east: the next innovation is 10 m less.
        let dr = Vector3::new(0.0, 10.0, 0.0);
        let next = Vector3::new(0.0, -39.8, 0.0);
        let (q_line, _) = c.extrapolation(&next, &r, &drift).unwrap();
        assert!(q_line > CHAIN_GATE_FACTOR * gate, "{q_line}");
        let moved = c.corrected(&dr);
        let (q_line, q_jump) = moved.extrapolation(&next, &r, &drift).unwrap();
        assert!(q_line < gate, "{q_line}");
        assert!(q_jump > CHAIN_GATE_FACTOR * gate, "{q_jump}");
        assert_eq!(moved.jump_ned_m, c.jump_ned_m);
        assert!(moved.claims(&next, &r, &drift, 1.0, &Matrix3::identity(), gate));
        assert!(!c.claims(&next, &r, &drift, 1.0, &Matrix3::identity(), gate));
    }

    /// A member of a gross cluster that strays beyond the gate from the last one, but stays
    /// far closer to the cluster than to the prediction, continues it; a cluster that is not
    /// gross needs the gate.
    #[test]
    fn a_stray_member_continues_a_gross_cluster() {
        let gate = crate::ins_filter::CHI2_3DOF_999;
        let r = Vector3::new(0.25, 0.25, 1.0);
        let drift = FixDrift {
            dt_s: 1.0,
            var_m2: Vector3::repeat(0.04),
            curvature_var_m2: Vector3::repeat(1e-3),
        };
        let first = Vector3::new(-3.8, -27.7, -6.9);
        let stray = Vector3::new(-5.1, -29.9, -3.9);
        let gross = RefusedCluster::start(first, r, 1380.0, gate, true);
        assert!(gross.gross);
        let q = gross.distance(&stray, &r, &drift);
        assert!(q > gate && q < 74.0, "{q}");
        assert!(!gross.contains(&stray, &r, &drift, gate));
        assert!(gross.continued_by(&stray, &r, &drift, 74.0, gate));
        // Closer to the prediction than to the cluster: a fix of its own.
        assert!(!gross.continued_by(&stray, &r, &drift, q * 0.9, gate));
        let plain = RefusedCluster::start(first, r, 74.0, gate, true);
        assert!(!plain.gross);
        assert!(!plain.continued_by(&stray, &r, &drift, 74.0, gate));
        assert!(plain.continued_by(&first, &r, &drift, 74.0, gate));
    }

    /// The velocity window's statistic: none until full; the mean of the last
    /// [`VELOCITY_WINDOW`] alone (the oldest dropped); a bias of 1.1 sigma on one axis
    /// (each fix's NIS 1.2) beyond the threshold over the window, 0.9 sigma within it.
    #[test]
    fn the_velocity_window_judges_its_last_fixes_mean() {
        let threshold = crate::ins_filter::CHI2_3DOF_999 * INCONSISTENT_GATE_FACTOR;
        let mut w = BiasWindow::<f64, VELOCITY_WINDOW>::default();
        let biased = |b: f64| Vector3::new(0.0, b, 0.0);
        for _ in 1..VELOCITY_WINDOW {
            w.push(biased(5.0));
        }
        assert_eq!(w.bias_statistic(), None);
        let n = VELOCITY_WINDOW as f64;
        for b in [1.1, 0.9] {
            for _ in 0..VELOCITY_WINDOW {
                w.push(biased(b));
            }
            let stat = w.bias_statistic().unwrap();
            assert!((stat - n * b * b).abs() < 1e-9, "{stat}");
            assert_eq!(stat > threshold, b > 1.0, "{b}: {stat} against {threshold}");
        }
        // Alternating signs: no mean.
        for k in 0..VELOCITY_WINDOW {
            w.push(biased(if k % 2 == 0 { 3.0 } else { -3.0 }));
        }
        assert!(w.bias_statistic().unwrap() < 1e-9);
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
        assert_eq!(white.verdict(gate, false), WindowVerdict::Consistent);
        // A bias of 1.3 sigma on one axis on every fix: each fix's NIS 1.7 passes any gate,
        // the window's mean 10 * 1.69 = 16.9 does not.
        let mut biased = InnovationWindow::<f64>::default();
        for _ in 0..WINDOW {
            biased.push(Vector3::new(0.0, 1.3, 0.0));
        }
        assert_eq!(biased.verdict(gate, false), WindowVerdict::Bias);
        assert_eq!(biased.verdict(gate, true), WindowVerdict::Consistent);
        // Large alternating innovations: no mean, too much spread (10 * 3 * 4 = 120 > 59.7).
        let mut wide = InnovationWindow::<f64>::default();
        for k in 0..WINDOW {
            let s = if k % 2 == 0 { 2.0 } else { -2.0 };
            wide.push(Vector3::repeat(s));
        }
        assert_eq!(wide.verdict(gate, false), WindowVerdict::Spread);
        assert_eq!(wide.verdict(gate, true), WindowVerdict::Spread);
        // A declared correlated error drawn at 2.5 sigma, common to the window, with white
        // noise about it: each |w|^2 about 3 * 2.5^2 = 18.75, 187 in all, fails the global
        // test about zero; about the mean, 10 * 3 * 0.25 = 7.5 passes.
        let mut common = InnovationWindow::<f64>::default();
        for k in 0..WINDOW {
            let s = if k % 2 == 0 { 0.5 } else { -0.5 };
            common.push(Vector3::repeat(2.5 + s));
        }
        assert_eq!(common.verdict(gate, false), WindowVerdict::Bias);
        assert!(common.spread_statistic() > CHI2_30DOF_999);
        assert!((common.spread_about_mean_statistic() - 7.5).abs() < 1e-9);
        assert_eq!(common.verdict(gate, true), WindowVerdict::Consistent);
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
        assert_eq!(wide.verdict(gate, false), WindowVerdict::Consistent);
    }

    #[test]
    fn an_undone_reacquisition_gives_back_what_it_removed_and_its_correction() {
        let mut x = StateVector::<f64>::zeros();
        x[POS + 1] = 19.0;
        x[VEL] = 0.5;
        let shrink = Matrix3::from_diagonal(&Vector3::new(25.0, 25.0, 4.0));
        let r = Reacquisition {
            correction: x,
            position_shrink: shrink,
        };
        let mut p = Covariance::<f64>::identity();
        r.undo(&mut p);
        assert_eq!(p[(POS + 1, POS + 1)], 1.0 + 25.0 + 361.0);
        assert_eq!(p[(POS, POS)], 1.0 + 25.0);
        assert_eq!(p[(VEL, VEL)], 1.25);
        assert_eq!(p[(POS + 1, VEL)], 9.5);
        assert!(p.cholesky().is_some());
        // Unconfirmed, the 19 m it moved the position by is 2 sigma of the reported doubt.
        let d = r.doubt();
        assert!((d[(1, 1)].sqrt() * 2.0 - 19.0).abs() < 1e-12);
        assert_eq!(d[(0, 0)], 0.0);
    }

    /// The fixes taken after a restart moved the solution 1 m east and by 0.1 m/s east,
    /// then 0.5 m east a second later: 2 s after that, 1.5 m plus 3 s of the velocity, 1.8 m,
    /// is the offset of the other hypothesis; confirmed after a window of fixes.
    #[test]
    fn a_restarts_doubt_carries_its_velocity_corrections() {
        let mut x1 = StateVector::<f64>::zeros();
        x1[POS + 1] = 1.0;
        x1[VEL + 1] = 0.1;
        let mut x2 = StateVector::<f64>::zeros();
        x2[POS + 1] = 0.5;
        let before = Matrix3::from_diagonal_element(0.25);
        let r = Restart::new(before).taken(&x1).carried(1.0).taken(&x2);
        assert!((r.position_ned_m - Vector3::new(0.0, 1.6, 0.0)).norm() < 1e-12);
        // The filter's own 1-sigma shrank from 0.5 to 0.1 m: the mixture's variance east is
        // (0.25 + 0.01) / 2 + 1.8^2 / 2.
        let p = Matrix3::from_diagonal_element(0.01);
        let reported = p + r.doubt(2.0, &p);
        assert!(
            (reported[(1, 1)] - (0.13 + 1.62)).abs() < 1e-12,
            "{reported}"
        );
        assert!((reported[(0, 0)] - 0.13).abs() < 1e-12, "{reported}");
        assert!(reported.cholesky().is_some());
        assert!(!r.is_confirmed());
        let mut full = r;
        for _ in 2..WINDOW {
            full = full.carried(1.0).taken(&StateVector::zeros());
        }
        assert!(full.is_confirmed());
        // Nothing moved and nothing learnt: no doubt.
        assert_eq!(Restart::new(before).doubt(5.0, &before), Matrix3::zeros());
    }

    /// A drift of velocity variance `v` [m^2/s^2] and curvature variance `k` [m^2] over 1 s.
    fn drift(v: f64, k: f64) -> FixDrift<f64> {
        FixDrift {
            dt_s: 1.0,
            var_m2: Vector3::repeat(v),
            curvature_var_m2: Vector3::repeat(k),
        }
    }

    /// A cluster that is not gross claims a fix the gate passes with fewer than a window of
    /// members, and not with a window of them; a gross one still does.
    #[test]
    fn a_cluster_that_is_not_gross_claims_at_most_a_window_of_members() {
        let r = Vector3::repeat(1e-4);
        let gate = crate::ins_filter::CHI2_3DOF_999;
        let still = drift(0.0, 0.0);
        let z = Vector3::new(0.0, 0.05, 0.0);
        let s = Matrix3::from_diagonal_element(2e-4);
        let nis = z.norm_squared() / 2e-4;
        let start = |nis0: f64| RefusedCluster::start(z, r, nis0, gate, true);
        let grow = |c: RefusedCluster<f64>, n: u32| (1..n).fold(c, |c, _| c.followed_by(z, r, 1.0));
        let plain = start(2.0 * gate);
        assert!(!plain.gross && nis < gate);
        let claims = |c: &RefusedCluster<f64>| c.claims(&z, &r, &still, nis, &s, gate);
        assert!(claims(&grow(plain, WINDOW_REFUSALS_MAX - 1)));
        assert!(!claims(&grow(plain, WINDOW_REFUSALS_MAX)));
        let gross = start(20.0 * gate);
        assert!(gross.gross && claims(&grow(gross, WINDOW_REFUSALS_MAX)));
    }

    #[test]
    fn a_cluster_holds_its_own_fixes_until_typical() {
        let r = Vector3::new(0.25, 0.25, 1.0);
        let gate = crate::ins_filter::CHI2_3DOF_999;
        let still = drift(0.0, 0.0);
        // Started by a fix just beyond the gate: not gross.
        let c = RefusedCluster::start(Vector3::new(0.0, 30.0, 0.0), r, 2.0 * gate, gate, true);
        assert!(!c.gross);
        assert!(c.contains(&Vector3::new(0.3, 29.5, 0.5), &r, &still, gate));
        // The fault ended: the fix is back near the filter's prediction.
        assert!(!c.contains(&Vector3::new(0.3, 1.0, 0.5), &r, &still, gate));
        // After a refused fix 4 sigma off (RTK: 2 cm noise, innovation 1-sigma 2.4 cm), a fix
        // at the prediction agrees better with the filter than with it: not a member.
        let rtk = Vector3::repeat(4e-4);
        let c4 = RefusedCluster::start(Vector3::new(0.096, 0.0, 0.0), rtk, 16.0, gate, true);
        let z = Vector3::new(0.01, 0.005, 0.0);
        let nis = z.norm_squared() / 5.8e-4;
        assert!(c4.contains(&z, &rtk, &still, gate));
        assert!(c4.distance(&z, &rtk, &still) > nis);
        assert!(!c4.claims(
            &z,
            &rtk,
            &still,
            nis,
            &Matrix3::from_diagonal_element(5.8e-4),
            gate
        ));
        // One refused fix, at twice the gate, holds the part of its offset beyond the gate
        // (the rest may be the gate's false alarm); refusing a second 30 m off it cannot
        // tell from its own error, the solution reports a doubt that puts the fixes at 2
        // sigma.
        let lone = c.doubt().unwrap()[(1, 1)].sqrt() * 2.0;
        assert!(c.is_lone() && (lone - 30.0 * (1.0 - 0.5_f64.sqrt())).abs() < 1e-9);
        // Two members: their common offset, 60 m against 0.5 m^2, nearly all of it.
        let c = c.followed_by(Vector3::new(0.0, 30.0, 0.0), r, 1.0);
        let d = c.doubt().unwrap();
        let part = 1.0 - (gate / (3600.0 / 0.5)).sqrt();
        assert!((d[(1, 1)].sqrt() * 2.0 - 30.0 * part).abs() < 1e-9);
        assert_eq!(d[(0, 1)], 0.0);
        // 30 m is not typical of a 5 m 1-sigma, it is of a 30 m one.
        assert!(!c.is_typical(&Matrix3::from_diagonal_element(25.0)));
        assert!(c.is_typical(&Matrix3::from_diagonal_element(900.0)));
    }

    /// A held 30 m offset that jumped from a filter of 0.3 m sigma stays refused while the
    /// filter's sigma grows to make it typical and its velocity sigma grows to 8 m/s (which
    /// blurs the jump between two fixes, not the line through three); the fix after the
    /// fault ends leaves the chain.
    #[test]
    fn a_gross_cluster_is_not_released_by_the_growing_sigma() {
        let gate = crate::ins_filter::CHI2_3DOF_999;
        let r = Vector3::new(0.25, 0.25, 1.0);
        let jump = Vector3::new(0.0, -30.0, 0.0);
        // Innovation covariance at the jump: 0.3 m sigma plus the fix noise.
        let nis0 = 900.0 / (0.09 + 0.25);
        let start = RefusedCluster::start(jump, r, nis0, gate, true);
        assert!(start.gross);
        // The filter knew its position when the jump came: no doubt.
        assert!(start.doubt().is_none());
        // A filter whose position no fix has confirmed yet (a wrong initial position) has no
        // gross clusters: its own growing sigma re-acquires the fixes.
        assert!(!RefusedCluster::start(jump, r, nis0, gate, false).gross);
        // One member: judged by the distance while it resolves the jump.
        let slow = drift(0.25, 1e-2);
        let near = Vector3::new(0.3, -29.6, 0.2);
        assert!(start.claims(
            &near,
            &r,
            &slow,
            1.0,
            &Matrix3::from_diagonal_element(1e4),
            gate
        ));
        // Later, the filter drifting at 3 m/s north-east with a sigma of 50 m (the offset is
        // typical of it) and of 8 m/s in velocity: two members on that line.
        let fast = drift(64.0, 1e-2);
        let c = start
            .followed_by(Vector3::new(-20.0, -10.0, 0.1), r, 1.0)
            .followed_by(Vector3::new(-23.0, -7.0, -0.1), r, 1.0);
        let s = Matrix3::from_diagonal(&Vector3::new(2500.0, 2500.0, 400.0));
        assert!(c.is_typical(&s));
        // One interval's drift blurs the jump between two fixes.
        assert!(normalised_square(&c.jump_ned_m, &(r + r + fast.var_m2)) < gate);
        let z = Vector3::new(-26.3, -4.2, 0.3);
        let nis = (z.x * z.x + z.y * z.y) / 2500.0 + z.z * z.z / 400.0;
        assert!(c.claims(&z, &r, &fast, nis, &s, gate));
        // The same fixes in a cluster that started just beyond the gate are released.
        let mild = RefusedCluster { gross: false, ..c };
        assert!(!mild.claims(&z, &r, &fast, nis, &s, gate));
        // The fault ends: the fix is 30 m off the line, out of the chain.
        let back = z + Vector3::new(0.0, 30.0, 0.0);
        assert!(!c.claims(&back, &r, &fast, 1.0, &s, gate));
        // A curvature of 10 m per interval blurs the jump: the chain can no longer tell.
        assert!(!c.claims(&z, &r, &drift(64.0, 100.0), nis, &s, gate));
    }

    /// The recovery test: a cluster whose offset moved 20 m in 100 s against a filter that
    /// claims 1 m has drifted (rate 0.2 m/s east); one whose offset held has not, nor a gross
    /// one, nor the same drift against a filter whose covariance allows it.
    #[test]
    fn a_cluster_moving_away_faster_than_the_covariance_allows_has_drifted() {
        let gate = 16.27;
        let r = Vector3::repeat(0.25);
        let start = RefusedCluster::start(Vector3::new(0.0, 5.0, 0.0), r, 60.0, gate, false);
        assert_eq!(start.drift_rate(), Vector3::zeros());
        let mut moving = start;
        let mut held = start;
        for k in 1..=100 {
            moving = moving.followed_by(Vector3::new(0.0, 5.0 + 0.2 * k as f64, 0.0), r, 1.0);
            held = held.followed_by(Vector3::new(0.1, 5.0, -0.1), r, 1.0);
        }
        assert!((moving.age_s - 100.0).abs() < 1e-9);
        assert!((moving.drift_rate() - Vector3::new(0.0, 0.2, 0.0)).norm() < 1e-9);
        let p_small = Vector3::repeat(1.0);
        assert!(moving.drifted(&p_small, gate));
        assert!(!held.drifted(&p_small, gate));
        assert!(!moving.drifted(&Vector3::repeat(400.0), gate));
        let gross = RefusedCluster {
            gross: true,
            ..moving
        };
        assert!(!gross.drifted(&p_small, gate));
        // A correction by another aid moves every member alike: the drift is unchanged.
        let dr = Vector3::new(0.0, 3.0, 0.0);
        assert!((moving.corrected(&dr).drift_rate() - moving.drift_rate()).norm() < 1e-12);
        // 0.2 m/s is 4 sigma of a velocity known to 5 cm/s (a filter that may be that
        // optimistic), 40 sigma of one known to 5 mm/s (beyond the gross factor's 16): only
        // the first could be the filter's own drift.
        let p_vel = |sigma: f64| Matrix3::from_diagonal_element(sigma * sigma);
        assert!(moving.drift_is_plausible(&p_vel(0.05), gate));
        assert!(!moving.drift_is_plausible(&p_vel(0.005), gate));
        assert!(!moving.drift_is_plausible(&Matrix3::zeros(), gate));
    }

    /// Fixes that moved the solution 12 m north over 24 s (error-state corrections of -12 m,
    /// 11 m of it remembered) explain a refused fix 11.5 m south of it (the ramp ended), not one further north (the ramp goes
    /// on); a pull within the fixes' noise explains nothing; the pull is forgotten over
    /// minutes.
    #[test]
    fn a_pull_explains_the_fix_that_undoes_it() {
        let gate = 16.27;
        let s = Matrix3::from_diagonal_element(1.2 * 1.2);
        let mut x = StateVector::<f64>::zeros();
        x[POS] = -0.1;
        let none = Matrix3::zeros();
        let pull = (0..120).fold(Pull::none(), |p, _| p.carried(0.2).taken(&x, &none, &none));
        assert!(pull.position_ned_m.x < -10.5, "{:?}", pull.position_ned_m);
        // Predicted minus measured: the true fix south of the pulled solution, +12 m.
        assert!(pull.explains(&Vector3::new(11.5, 0.0, 0.0), &s, gate));
        assert!(!pull.explains(&Vector3::new(-6.0, 0.0, 0.0), &s, gate));
        let small = Pull {
            position_ned_m: Vector3::new(-2.0, 0.0, 0.0),
            ..Pull::none()
        };
        assert!(!small.explains(&Vector3::new(6.0, 0.0, 0.0), &s, gate));
        let later = pull.carried(600.0);
        assert!(later.position_ned_m.norm() < 0.1 * pull.position_ned_m.norm());
    }

    /// Corrections whose sum the covariance they took away explains are no fault; the same
    /// corrections all one way (a ramp the filter follows: 0.02 m north per fix against a
    /// shrink of (0.02 m)^2 per fix) are, and their sums are the doubt.
    #[test]
    fn a_pull_beyond_what_its_fixes_took_away_is_a_fault() {
        let gate = 16.27;
        let shrink_pos = Matrix3::from_diagonal_element(0.02 * 0.02);
        let shrink_vel = Matrix3::from_diagonal_element(0.001 * 0.001);
        let mut x = StateVector::<f64>::zeros();
        let mut random = Pull::none();
        for k in 0..100 {
            // Alternating signs: the sum stays within one correction.
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            x[POS] = 0.02 * sign;
            x[VEL] = 0.001 * sign;
            random = random.carried(0.1).taken(&x, &shrink_pos, &shrink_vel);
        }
        assert!(!random.is_fault(gate), "{random:?}");
        x[VEL] = 0.0;
        x[ATT + 1] = 1e-5;
        let mut ramp = Pull::none();
        for _ in 0..100 {
            x[POS] = -0.02;
            ramp = ramp.carried(0.1).taken(&x, &shrink_pos, &shrink_vel);
        }
        assert!(ramp.is_fault(gate), "{ramp:?}");
        let [p, v, a] = ramp.doubt();
        assert!((p[(0, 0)].sqrt() - ramp.position_ned_m.x.abs()).abs() < 1e-12);
        assert!(p[(0, 0)].sqrt() > 1.9, "{p}");
        assert_eq!(v, Matrix3::zeros());
        assert!((a[(1, 1)].sqrt() - 1e-3).abs() < 1e-4, "{a}");
        // The velocity alone: 0.005 m/s a fix against a shrink of (0.001 m/s)^2.
        x[POS] = 0.0;
        x[VEL + 2] = 0.005;
        let vel = (0..20).fold(Pull::none(), |p, _| {
            p.carried(0.1).taken(&x, &shrink_pos, &shrink_vel)
        });
        assert!(vel.is_fault(gate), "{vel:?}");
        // Taken into the covariance at a re-acquisition, the velocity, attitude and bias sums
        // leave the pull; the position's stays, still a fault.
        x[BG] = 1e-6;
        x[BA + 1] = 1e-4;
        let all = ramp.taken(&x, &shrink_pos, &shrink_vel);
        let kept = all.position_only();
        assert_eq!(kept.position_ned_m, all.position_ned_m);
        assert!(kept.is_fault(gate), "{kept:?}");
        let [_, v, a] = kept.doubt();
        assert_eq!((v, a), (Matrix3::zeros(), Matrix3::zeros()));
        assert_eq!(kept.sensor_doubt(), [Matrix3::zeros(); 2]);
        assert_ne!(all.sensor_doubt(), [Matrix3::zeros(); 2]);
    }

    /// A pull just beyond the gate reports only its part beyond it (a few percent of its
    /// sums: it was a whole 10 cm on clean RTK fixes against a 6 mm 1-sigma); a pull 80
    /// sigma out, nearly all of it.
    #[test]
    fn a_pull_reports_its_part_beyond_the_gate() {
        let gate = 16.27;
        let shrink = Matrix3::from_diagonal_element(1e-4);
        let pull = |east_m: f64| {
            let mut x = StateVector::<f64>::zeros();
            x[POS + 1] = east_m;
            x[VEL + 1] = 1e-3;
            x[ATT] = 1e-5;
            Pull::none().taken(&x, &shrink, &Matrix3::from_diagonal_element(1.0))
        };
        let just = pull(0.0425);
        let w = 1.0 - (gate / 18.0625_f64).sqrt();
        assert!(just.is_fault(gate) && (just.weight(gate) - w).abs() < 1e-9);
        let [p, v, a] = just.reported_doubt(gate);
        assert!((p[(1, 1)].sqrt() - 0.0425 * w).abs() < 1e-12, "{p}");
        assert!(p[(1, 1)].sqrt() < 0.003, "{p}");
        assert!((v[(1, 1)].sqrt() - 1e-3 * w).abs() < 1e-12 && a[(0, 0)] > 0.0);
        let far = pull(0.8);
        let [p, _, _] = far.reported_doubt(gate);
        assert!(p[(1, 1)].sqrt() > 0.75, "{p}");
        let within = pull(0.04);
        assert!(!within.is_fault(gate));
        assert_eq!(within.reported_doubt(gate), [Matrix3::zeros(); 3]);
    }

    /// A gross cluster whose offset runs away from the jump faster than the filter's own
    /// position variance could (a given start's heading 90 deg off under a declared
    /// 0.1 deg: the refused fixes 15 m further off each second) reports it as doubt; a held
    /// jump does not.
    #[test]
    fn a_gross_cluster_that_runs_away_reports_its_offset_as_doubt() {
        let (gate, r) = (
            crate::ins_filter::CHI2_3DOF_999,
            Vector3::new(0.25, 0.25, 1.0),
        );
        let p_pos = Vector3::repeat(0.12_f64 * 0.12);
        let jump = Vector3::new(-11.4, 12.2, 0.0);
        let start = RefusedCluster::start(jump, r, 2000.0, gate, true).judged(&p_pos, gate, false);
        assert!(start.gross && !start.ran_away);
        let held = start
            .followed_by(jump + Vector3::new(0.2, -0.1, 0.3), r, 1.0)
            .judged(&p_pos, gate, true);
        assert!(!held.ran_away && held.doubt().is_none());
        let z = Vector3::new(-20.7, 20.6, -0.5);
        // Against a filter whose own variance covers the move, it has not run away.
        assert!(
            !start
                .followed_by(z, r, 1.0)
                .judged(&Vector3::repeat(100.0), gate, false)
                .ran_away
        );
        let away = start.followed_by(z, r, 1.0).judged(&p_pos, gate, false);
        assert!(away.ran_away);
        let d = away.doubt().expect("the doubt of a filter that ran away");
        assert!((d[(0, 0)].sqrt() * 2.0 - 20.7).abs() < 1e-9, "{d}");
        // Its velocity is doubtful by the rate of the run away (9.3 m/s north since the
        // first member, which was also the one before); a held jump's is not.
        let dv = away.velocity_doubt().expect("the velocity doubt");
        assert!(
            (dv[(0, 0)].sqrt() * 2.0 - 9.3 * 2f64.sqrt()).abs() < 1e-9,
            "{dv}"
        );
        assert!(held.velocity_doubt().is_none() && start.velocity_doubt().is_none());
        // Latched: the filter's own variance growing later (free inertial, or set aside for
        // a re-alignment) does not make the run-away offset its own error.
        let later = away
            .followed_by(z * 10.0, r, 10.0)
            .judged(&Vector3::repeat(1e4), gate, false);
        assert!(later.ran_away && later.doubt().is_some());
        // Once DEGRADED by refusals, a move beyond the gate of the filter's own variance is
        // enough: 4 m against a 0.5 m 1-sigma (the held jump above moved 0.4 m).
        let slow = start.followed_by(jump + Vector3::new(4.0, 0.0, 0.0), r, 10.0);
        assert!(!slow.judged(&Vector3::repeat(0.25), gate, false).ran_away);
        assert!(slow.judged(&Vector3::repeat(0.25), gate, true).ran_away);
        assert!(!held.ran_away);
    }

    /// A cluster that ran away because the solution's heading is 90 deg off: the fixes move
    /// east at 15 m/s while the solution moves north, and the heading's doubt is that angle
    /// as 2 sigma; held through a stop, none for a held jump.
    #[test]
    fn a_cluster_that_runs_away_across_the_track_doubts_the_heading() {
        let (gate, r) = (
            crate::ins_filter::CHI2_3DOF_999,
            Vector3::new(0.25, 0.25, 1.0),
        );
        let p_pos = Vector3::repeat(0.12_f64 * 0.12);
        let v_eb_n = Vector3::new(15.0, 0.0, 0.0);
        // Offset = solution minus fix: north at 15 m/s, less east at 15 m/s each second.
        let rate = Vector3::new(15.0, -15.0, 0.0);
        let jump = Vector3::new(30.0, -30.0, 0.0);
        let start = RefusedCluster::start(jump, r, 2000.0, gate, true).judged(&p_pos, gate, false);
        assert_eq!(start.heading_doubt(&v_eb_n, 0.7), 0.0);
        let away = start
            .followed_by(jump + rate, r, 1.0)
            .judged(&p_pos, gate, false);
        assert!(away.ran_away);
        let sigma = away.heading_doubt(&v_eb_n, 0.0).sqrt();
        assert!(
            (sigma * 2.0 - core::f64::consts::FRAC_PI_2).abs() < 1e-9,
            "{sigma}"
        );
        // At a stop the tracks have no direction: the doubt from the fix before stands.
        let stopped = away.followed_by(jump + rate, r, 1.0);
        assert_eq!(stopped.heading_doubt(&Vector3::zeros(), 0.6), 0.6);
        // Fixes that move with the solution leave no heading doubt, whatever the offset.
        let along = RefusedCluster::start(Vector3::new(5.0, 0.0, 0.0), r, 30.0, gate, true)
            .followed_by(Vector3::new(5.1, 0.0, 0.0), r, 1.0);
        assert!(!along.gross && along.heading_doubt(&v_eb_n, 0.6) < 1e-4);
        // A held gross jump is no doubt on anything.
        let held = start
            .followed_by(jump + Vector3::new(0.2, -0.1, 0.3), r, 1.0)
            .judged(&p_pos, gate, true);
        assert_eq!(held.heading_doubt(&v_eb_n, 0.6), 0.0);
    }

    /// Two refused fixes of 2 m a tenth of a second apart, 3.6 m from each other (their
    /// noise): no rate of the offset is doubted until the members span a second (was 36 m/s
    /// of velocity doubt and tens of degrees of heading doubt on a solution 1 cm/s off);
    /// over a second the same difference is a rate of 3.6 m/s.
    #[test]
    fn a_rate_is_doubted_only_over_a_second_of_members() {
        let (gate, r) = (16.27_f64, Vector3::new(4.0, 4.0, 16.0));
        let first = RefusedCluster::start(Vector3::new(4.6, 7.1, -1.0), r, 18.0, gate, true);
        let v_eb_n = Vector3::new(10.0, 0.0, 0.0);
        let pair = first.followed_by(Vector3::new(4.6, 3.5, -1.0), r, 0.1);
        assert!(!pair.gross && pair.velocity_doubt().is_none());
        assert_eq!(pair.heading_doubt(&v_eb_n, 0.0), 0.0);
        let slow = first.followed_by(Vector3::new(4.6, 3.5, -1.0), r, 1.0);
        let d = slow.velocity_doubt().expect("a rate over a second");
        assert!((d[(1, 1)].sqrt() * 2.0 - 3.6).abs() < 1e-9, "{d}");
        assert!(slow.heading_doubt(&v_eb_n, 0.0) > 0.0);
    }

    /// A gross cluster that starts while a cluster of 3 m was refused keeps its doubt; one
    /// started afresh has none.
    #[test]
    fn a_cluster_started_while_another_was_refused_carries_its_doubt() {
        let (gate, r) = (16.27_f64, Vector3::repeat(0.25));
        let before = RefusedCluster::start(Vector3::new(0.0, 3.0, 0.0), r, 40.0, gate, false)
            .followed_by(Vector3::new(0.0, 3.0, 0.0), r, 1.0);
        let jump = Vector3::new(0.0, -30.0, 0.0);
        let fresh = RefusedCluster::start(jump, r, 3600.0, gate, true);
        assert!(fresh.gross && fresh.doubt().is_none());
        let held = fresh.replacing(Some(&before));
        let d = held.doubt().expect("the carried doubt");
        // Its part of 3 m: two members' common offset, 6 m against 0.5 m^2.
        let part = 1.0 - (gate / 72.0).sqrt();
        assert!((d[(1, 1)] - 2.25 * part * part).abs() < 1e-12, "{d}");
        // Carried through its members.
        let next = held.followed_by(jump, r, 1.0);
        assert_eq!(next.doubt(), Some(d));
        assert!(fresh.replacing(None).doubt().is_none());
    }
}
