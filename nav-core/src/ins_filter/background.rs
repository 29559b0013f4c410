//! The filter's background half: the covariance, its propagation and the measurement updates.
//! It sees the navigation solution only through [`Snapshot`]s and answers each accepted update
//! with the [`Correction`] the foreground feeds back. Position fixes pass the per-fix
//! chi-square gate and then the tests of [`super::integrity`] (a windowed innovation test for
//! slow faults, the refusal of a consistent cluster refused before).

use super::aiding::{AidCounters, AidResult, FilterCounters, GnssPosition, GnssVelocity};
use super::coast::{Coast, Motion};
use super::consider::{self, ConsiderModel, CrossCovariance};
use super::covariance::{self, Transition};
use super::foreground::{ClipDoubt, LostGap, Propagation};
use super::integrity::{
    self, BiasWindow, InnovationWindow, Pull, Reacquisition, RefusedCluster, Restart,
    WindowVerdict, whiten,
};
use super::latency::{LatencyEstimate, LatencyFix, LatencyMonitor};
use super::limits;
use super::model;
use super::noise_scale::NoiseScale;
use super::stationarity::{StillWindow, Uncertainty};
use super::{
    ATT, BA, BG, Covariance, FilterConfig, FilterError, FilterStatus, InitialSigma, N, POS, SA, SG,
    StateVector, VEL,
};
use crate::alignment::fine::euler_sigma;
use crate::alignment::fine::kalman::{ConsiderError, ScalarUpdate, update_scalar_correlated};
use crate::earth::LocalEarth;
use crate::{NavState, Position, Scalar};
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

/// Largest reduction of a measured quantity's variance by one update [-] (see
/// `ErrorFilter::update`): a fix shrinks a 100 m prediction to 25 m, not to its own 0.5 m; the
/// following fixes finish the convergence (each shrinking by up to 16x).
pub const MAX_SHRINK: f64 = 16.0;

/// Smallest attitude correction [rad] whose reset of the covariance is applied
/// (`ErrorFilter::reset_attitude`): below it the reset changes the covariance by less than
/// 5e-5 of itself, which a settled filter's near-singular attitude–bias block in `f32` does not
/// survive (rounding, at every fix, left it not positive definite).
pub const RESET_MIN_RAD: f64 = 1e-4;

/// What retiming a fix by `late_s` [s] ([`LatencyMonitor::applied`]) moves its predicted
/// antenna position by (subtracted), the fix taken `lag_s` [s] before the snapshot's sample:
/// the solution carried back to `lag_s + late_s` rather than `lag_s`, to second order, `v
/// late_s - a ((lag_s + late_s)^2 - lag_s^2) / 2` [m].
fn retiming<T: Scalar>(snap: &Snapshot<T>, lag_s: T, late_s: T) -> Vector3<T> {
    let to = lag_s + late_s;
    snap.state.v_eb_n * late_s - snap.a_eb_n * ((to * to - lag_s * lag_s) * T::c(0.5))
}

/// The noise variance an update uses for a row of innovation variance `s` and noise variance
/// `r` [same unit^2]: `r`, raised so the predicted variance `s - r` shrinks at most
/// [`MAX_SHRINK`] times (a re-acquisition, [`integrity`] module docs, when raised).
fn effective_noise<T: Scalar>(s: T, r: T) -> T {
    r.max((s - r) / T::c(MAX_SHRINK - 1.0))
}

/// What the updates need of one sample: the solution, the Earth at it, the compensated rate
/// [rad/s] and the solution's acceleration [m/s^2].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Snapshot<T: Scalar> {
    /// The navigation solution.
    pub state: NavState<T>,
    /// Earth quantities at its position.
    pub earth: LocalEarth<T>,
    /// Compensated `omega_ib_b` of the sample [rad/s].
    pub omega_ib_b: Vector3<T>,
    /// `d v_eb_n / dt` over the sample [m/s^2].
    pub a_eb_n: Vector3<T>,
}

/// The error estimate to feed back ("computed minus true"; [`super::states`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correction<T: Scalar> {
    /// The error state.
    pub x: StateVector<T>,
    /// The filter's gyro-bias and tilt 1-sigmas after the update (the stop detector's
    /// allowance, [`Uncertainty`]).
    pub uncertainty: Uncertainty<T>,
}

/// A measurement `z = H x + v`, `v ~ N(0, diag(r))`, `z` predicted minus measured; row `i`
/// also sees consider state `gnss_error + i` (`Some` for a position fix: the receiver's
/// correlated error, [`consider::GP`], with [`consider::POSITION_SENSITIVITY`]).
struct Measurement<T: Scalar, const M: usize> {
    z: SVector<T, M>,
    h: SMatrix<T, M, N>,
    r: SVector<T, M>,
    gnss_error: Option<usize>,
}

impl<T: Scalar, const M: usize> Measurement<T, M> {
    /// A measurement of the error states alone.
    fn of_states(z: SVector<T, M>, h: SMatrix<T, M, N>, r: SVector<T, M>) -> Self {
        Self {
            z,
            h,
            r,
            gnss_error: None,
        }
    }

    /// The consider state row `i` sees.
    fn seen(&self, i: usize) -> Option<consider::Seen<T>> {
        self.gnss_error.map(|at| consider::Seen {
            at: at + i,
            sensitivity: T::c(consider::POSITION_SENSITIVITY),
        })
    }
}

/// The background half (module docs).
#[derive(Clone, Debug)]
pub struct ErrorFilter<T: Scalar> {
    p: Covariance<T>,
    x: StateVector<T>,
    config: FilterConfig<T>,
    counters: FilterCounters,
    covariance_faults: u32,
    fault_latched: bool,
    /// A gap in the IMU data was too long to bridge (latched).
    imu_lost: bool,
    /// The solution came near a pole, where the NED error model does not hold
    /// ([`model::near_pole`]; latched).
    near_pole: bool,
    window: InnovationWindow<T>,
    /// The whitened innovations of the last velocity fixes taken ([`Self::inconsistent`]).
    velocity_window: BiasWindow<T, { integrity::VELOCITY_WINDOW }>,
    cluster: Option<RefusedCluster<T>>,
    /// The fixes refused in a row before the filter was confirmed, as a cluster that claims
    /// nothing: followed only to tell when a DEGRADED filter that never knew its position
    /// re-acquires ([`integrity`] module docs).
    refused_unconfirmed: Option<RefusedCluster<T>>,
    /// Propagated time since the last position fix [s].
    since_fix_s: T,
    /// Per aid ([`POSITION_AID`], [`VELOCITY_AID`]): propagated time since its last fix,
    /// when that fix was refused as a gross disagreement ([`integrity::SUSPECT_NIS_FACTOR`])
    /// [s]; `None` once a fix of the aid is taken.
    suspect_s: [Option<T>; 2],
    /// Propagated time from the first to the last of the position fixes refused in a row
    /// [s] (zero with fewer than two).
    refused_for_s: T,
    /// The doubt a refused cluster leaves on the heading at the last position fix [rad^2]
    /// ([`RefusedCluster::heading_doubt`]).
    heading_doubt_rad2: T,
    /// The correction of the last position fix when it was a re-acquisition (taken alone
    /// against a much wider prediction; [`integrity`] module docs), until the next fix.
    reacquired: Option<Reacquisition<T>>,
    /// What the fixes moved the solution by since the window restarted after
    /// [`integrity::WINDOW_REFUSALS_MAX`] refusals, until confirmed ([`integrity`] module
    /// docs).
    restart: Option<Restart<T>>,
    /// What the accepted position fixes of the last minutes moved the solution by
    /// ([`integrity`] module docs).
    pull: Pull<T>,
    /// A full window of fixes has passed the tests since the start: the position is the
    /// filter's own, and a fix the gate refuses may start a refused cluster ([`integrity`]).
    confirmed: bool,
    /// The last position fix's place (latitude, longitude [rad], height [m]), and how many
    /// fixes in a row repeated the one before exactly ([`Self::diverged`]).
    last_fix_llh: Option<[f64; 3]>,
    repeated_fixes: u32,
    /// The consider states' model and cross-covariance `P_ac` ([`consider`]).
    consider: ConsiderModel<T>,
    p_ac: CrossCovariance<T>,
    /// The last propagation's attitude, specific force and rate (the stop detector's
    /// allowance, [`Self::uncertainty`]; the coasting test's error equations).
    motion: Motion<T>,
    /// The coasting test ([`coast`] module docs).
    coast: Coast<T>,
    /// The test of the fixes' time tags ([`super::latency`]).
    latency: LatencyMonitor<T>,
    /// The learnt scales of the position and velocity fixes' declared noise
    /// ([`super::noise_scale`]).
    position_noise: NoiseScale<T, 3>,
    velocity_noise: NoiseScale<T, 3>,
}

/// The GNSS position fixes' index in the per-aid arrays.
const POSITION_AID: usize = 0;
/// The GNSS velocity fixes' index in the per-aid arrays.
const VELOCITY_AID: usize = 1;

impl<T: Scalar> ErrorFilter<T> {
    /// The filter at its start: covariance from `sigma` at heading `yaw` [rad].
    pub fn new(
        sigma: &InitialSigma<T>,
        yaw: T,
        config: FilterConfig<T>,
    ) -> Result<Self, FilterError> {
        if let Some(why) = limits::noise_out_of_range(&config.noise) {
            return Err(FilterError::BadNoise(why));
        }
        if let Some(why) = limits::initial_sigma_out_of_range(sigma) {
            return Err(FilterError::BadInitialSigma(why));
        }
        let l = &config.antenna_lever_arm_b_m;
        if !(l.iter().all(|v| v.finite()) && l.norm() <= T::c(100.0)) {
            return Err(FilterError::BadLeverArm);
        }
        if let Some(why) = config
            .gnss_correlated_error
            .as_ref()
            .and_then(limits::gnss_error_out_of_range)
        {
            return Err(FilterError::BadGnssError(why));
        }
        let consider = ConsiderModel::of(&config.noise, config.gnss_correlated_error.as_ref());
        let mut p = sigma.covariance(yaw, config.scale_factors);
        let mut p_ac = CrossCovariance::zeros();
        consider::start(&mut p, &mut p_ac, &consider);
        Ok(Self {
            p,
            x: StateVector::zeros(),
            config,
            counters: FilterCounters::default(),
            covariance_faults: 0,
            fault_latched: false,
            imu_lost: false,
            near_pole: false,
            window: InnovationWindow::default(),
            velocity_window: BiasWindow::default(),
            cluster: None,
            refused_unconfirmed: None,
            since_fix_s: T::zero(),
            suspect_s: [None; 2],
            refused_for_s: T::zero(),
            heading_doubt_rad2: T::zero(),
            reacquired: None,
            restart: None,
            pull: Pull::none(),
            confirmed: false,
            last_fix_llh: None,
            repeated_fixes: 0,
            consider,
            p_ac,
            motion: Motion {
                c_b_n: *nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), yaw).matrix(),
                f_ib_b: Vector3::new(T::zero(), T::zero(), -T::c(crate::earth::GAMMA_EQUATOR)),
                omega_ib_b: Vector3::zeros(),
            },
            coast: Coast::none(),
            latency: LatencyMonitor::default(),
            position_noise: NoiseScale::default(),
            velocity_noise: NoiseScale::default(),
        })
    }

    /// The filter's own covariance (its gate and updates use it; the reported position's is
    /// [`Self::position_covariance`]).
    pub fn covariance(&self) -> &Covariance<T> {
        &self.p
    }

    /// The consider states' cross-covariance `P_ac` ([`consider`]).
    pub fn consider_covariance(&self) -> &CrossCovariance<T> {
        &self.p_ac
    }

    /// The settings.
    pub fn config(&self) -> &FilterConfig<T> {
        &self.config
    }

    /// The aids' counters.
    pub fn counters(&self) -> &FilterCounters {
        &self.counters
    }

    /// Times the covariance lost a positive variance and was reset to its diagonal.
    pub fn covariance_faults(&self) -> u32 {
        self.covariance_faults
    }

    /// 1-sigma of the state's block at `at` (one of the offsets), per axis; the position's
    /// is that of [`Self::position_covariance`], the velocity's carries
    /// [`Self::velocity_doubt`].
    pub fn sigma(&self, at: usize) -> Vector3<T> {
        let doubt = match at {
            POS => self.position_doubt().diagonal(),
            VEL => self.velocity_doubt().diagonal(),
            _ => Vector3::zeros(),
        };
        Vector3::from_fn(|k, _| self.p[(at + k, at + k)] + doubt[k])
            .map(|v| v.max(T::zero()).sqrt())
    }

    /// What the stop detector allows for ([`Uncertainty`]): the largest gyro-bias 1-sigma, and
    /// the largest 1-sigma of the north and east specific-force errors, the velocity error's
    /// rate `[f_n x] phi + C_b_n b_a` of the system matrix ([`model::system_matrix`]) at the
    /// last propagation, with the tilt and bias correlations the stops have built.
    pub fn uncertainty(&self) -> Uncertainty<T> {
        let mut h = SMatrix::<T, 2, 6>::zeros();
        let skew_f = model::skew(&(self.motion.c_b_n * self.motion.f_ib_b));
        h.fixed_view_mut::<2, 3>(0, 0)
            .copy_from(&skew_f.fixed_rows::<2>(0));
        h.fixed_view_mut::<2, 3>(0, 3)
            .copy_from(&self.motion.c_b_n.fixed_rows::<2>(0));
        let mut p = SMatrix::<T, 6, 6>::zeros();
        for (i, a) in [ATT, ATT + 1, ATT + 2, BA, BA + 1, BA + 2]
            .into_iter()
            .enumerate()
        {
            for (j, b) in [ATT, ATT + 1, ATT + 2, BA, BA + 1, BA + 2]
                .into_iter()
                .enumerate()
            {
                p[(i, j)] = self.p[(a, b)];
            }
        }
        let var = (h * p * h.transpose()).diagonal();
        Uncertainty {
            gyro_bias_rad_s: self.sigma(BG).max(),
            horizontal_force_mps2: var.max().max(T::zero()).sqrt(),
        }
    }

    /// The doubt on the position, NED [m^2]: of a refused cluster that is not gross
    /// ([`RefusedCluster::doubt`]; the fixes refused before the filter was confirmed are
    /// one), of a re-acquisition not yet confirmed by the next fix
    /// ([`Reacquisition::doubt`]), of a window restart not yet confirmed
    /// ([`Restart::doubt`]) and of a pull that is a fault ([`Pull::is_fault`]) or that the
    /// coasting test refuses ([`Coast::doubt`]); zero otherwise.
    pub fn position_doubt(&self) -> Matrix3<T> {
        let cluster = self
            .cluster
            .as_ref()
            .or(self.refused_unconfirmed.as_ref())
            .and_then(RefusedCluster::doubt);
        let reacquired = self.reacquired.as_ref().map(Reacquisition::doubt);
        let p_pos = self.p.fixed_view::<3, 3>(POS, POS).into_owned();
        let restarted = self.restart.map(|r| r.doubt(self.since_fix_s, &p_pos));
        cluster.unwrap_or_else(Matrix3::zeros)
            + reacquired.unwrap_or_else(Matrix3::zeros)
            + restarted.unwrap_or_else(Matrix3::zeros)
            + self
                .fault_doubt()
                .map_or_else(Matrix3::zeros, |[p, _, _]| p)
            + self.latency.doubt().map_or_else(Matrix3::zeros, |(p, _)| p)
    }

    /// The doubt on the position, velocity and attitude of a [`Pull`] that is a fault
    /// ([`Pull::is_fault`], [`Pull::doubt`]) and of the coasting test ([`Coast::doubt`]), but
    /// not under a declared correlated GNSS error (its fixes' corrections are not independent,
    /// and the solution follows the error it declares).
    fn fault_doubt(&self) -> Option<[Matrix3<T>; 3]> {
        if self.consider.has_gnss_error() {
            return None;
        }
        let pull = self.pull.carried(self.since_fix_s);
        let gate = self.config.gate_nis;
        let pulled = pull.is_fault(gate).then(|| pull.reported_doubt(gate));
        match (pulled, self.coast.doubt()) {
            (Some(p), Some(c)) => Some(core::array::from_fn(|i| p[i] + c[i])),
            (p, c) => p.or(c),
        }
    }

    /// The doubt on the velocity, NED [m^2/s^2]: the rate of a refused cluster's offset whose
    /// offset is a doubt on the position ([`RefusedCluster::velocity_doubt`]) and a pull that
    /// is a fault ([`Pull::is_fault`]); zero otherwise (reported, not gated, as the
    /// position's).
    pub fn velocity_doubt(&self) -> Matrix3<T> {
        self.cluster
            .as_ref()
            .or(self.refused_unconfirmed.as_ref())
            .and_then(RefusedCluster::velocity_doubt)
            .unwrap_or_else(Matrix3::zeros)
            + self
                .fault_doubt()
                .map_or_else(Matrix3::zeros, |[_, v, _]| v)
            + self.latency.doubt().map_or_else(Matrix3::zeros, |(_, v)| v)
    }

    /// The reported position covariance, NED [m^2]: the filter's own ([`Self::covariance`],
    /// which its gate and updates use) plus [`Self::position_doubt`].
    pub fn position_covariance(&self) -> Matrix3<T> {
        self.p.fixed_view::<3, 3>(POS, POS) + self.position_doubt()
    }

    /// 1-sigma of roll, pitch, yaw [rad] of the attitude `q_b_n`: the NED attitude error's
    /// covariance, with the doubt of a pull that is a fault ([`Pull::is_fault`]) and the doubt
    /// a refused cluster leaves on the heading ([`RefusedCluster::heading_doubt`], as at the
    /// last position fix; reported, not gated, as the position's), mapped to the Euler angles
    /// ([`euler_sigma`]): roll and yaw grow as `1 / cos(pitch)` towards pitch +-90 deg, where
    /// they are not defined (at 75-89 deg of pitch the NED tilt's 1-sigma reported as roll's
    /// and yaw's was 5-46 times below their errors), and stop at 180 deg.
    pub fn attitude_sigma_rad(&self, q_b_n: &UnitQuaternion<T>) -> Vector3<T> {
        let mut att = self.p.fixed_view::<3, 3>(ATT, ATT)
            + self
                .fault_doubt()
                .map_or_else(Matrix3::zeros, |[_, _, a]| a);
        att[(2, 2)] += self.heading_doubt_rad2;
        euler_sigma(q_b_n, &att).map(|s| s.min(T::c(core::f64::consts::PI)))
    }

    /// True once the solution came so near a pole that the NED error model does not hold
    /// ([`model::near_pole`]; latched: status [`FilterStatus::NearPole`]).
    pub fn near_pole(&self) -> bool {
        self.near_pole
    }

    /// The test of the fixes' time tags ([`super::latency`]): the fixes' lag behind their
    /// tags, its 1-sigma, and whether it is detected (status [`FilterStatus::GnssLate`]).
    pub fn gnss_latency(&self) -> LatencyEstimate<T> {
        self.latency.estimate()
    }

    /// The health: a latched covariance fault, a lost IMU gap, the vicinity of a pole
    /// ([`Self::near_pole`]), [`FilterConfig::rejections_to_degrade`] position fixes refused
    /// in a row or refusals in a row over [`FilterConfig::refused_time_to_degrade_s`], a fix
    /// refused as a gross disagreement ([`integrity::SUSPECT_NIS_FACTOR`]), velocity fixes
    /// that share a bias ([`integrity::INCONSISTENT_GATE_FACTOR`]), or a horizontal 1-sigma beyond
    /// [`FilterConfig::max_horizontal_sigma_m`].
    pub fn status(&self) -> FilterStatus {
        if self.fault_latched {
            FilterStatus::CovarianceFault
        } else if self.imu_lost {
            FilterStatus::ImuLost
        } else if self.near_pole {
            FilterStatus::NearPole
        } else if self.degraded_by_refusals()
            || self.refused_for_s >= self.config.refused_time_to_degrade_s
            || self.suspect()
            || self.inconsistent()
        {
            FilterStatus::AidingRejected
        } else if self.latency.estimate().detected {
            FilterStatus::GnssLate
        } else if self.position_covariance().fixed_view::<2, 2>(0, 0).trace()
            > self.config.max_horizontal_sigma_m * self.config.max_horizontal_sigma_m
        {
            FilterStatus::SigmaAboveLimit
        } else {
            FilterStatus::Nominal
        }
    }

    /// The last fix of an aid was refused as a gross disagreement with the solution, within
    /// [`FilterConfig::refused_time_to_degrade_s`] (the data contradict the solution, whichever
    /// is wrong: [`integrity::SUSPECT_NIS_FACTOR`]).
    fn suspect(&self) -> bool {
        self.suspect_s
            .iter()
            .flatten()
            .any(|&s| s < self.config.refused_time_to_degrade_s)
    }

    /// The last [`integrity::VELOCITY_WINDOW`] velocity fixes taken share a bias beyond
    /// [`integrity::INCONSISTENT_GATE_FACTOR`] gates (their whitened innovations' local
    /// statistic, [`integrity`] module docs): each passed the gate, yet together they say the
    /// solution is off by more than its covariance allows, which the filter's error model did
    /// not foresee (a sensor that changed beyond its Gauss–Markov model: after a gyro bias
    /// step of 50 deg/h, NAV rows 4-9 sigma off in velocity for 25 s while such fixes were
    /// taken). Only a status: the fixes are taken, as they may be right (one cannot tell
    /// whether the fixes or the solution are off).
    fn inconsistent(&self) -> bool {
        let threshold = self.config.gate_nis * T::c(integrity::INCONSISTENT_GATE_FACTOR);
        self.velocity_window
            .bias_statistic()
            .is_some_and(|b| b > threshold)
    }

    /// Notes the outcome of a fix of aid `aid` ([`POSITION_AID`], [`VELOCITY_AID`]) for
    /// [`Self::suspect`].
    fn note_suspect(&mut self, aid: usize, result: &AidResult<T>) {
        let gross = self.config.gate_nis * T::c(integrity::SUSPECT_NIS_FACTOR);
        match result {
            AidResult::Accepted { .. } => self.suspect_s[aid] = None,
            AidResult::Rejected { nis } if *nis > gross => self.suspect_s[aid] = Some(T::zero()),
            _ => {}
        }
    }

    /// [`FilterConfig::rejections_to_degrade`] position fixes refused in a row: the
    /// recovery rules of [`integrity`] apply.
    fn degraded_by_refusals(&self) -> bool {
        self.counters.position.consecutive_rejected >= self.config.rejections_to_degrade
    }

    /// The filter's own position variances, NED [m^2] (its covariance, without the doubt).
    fn own_position_variances(&self) -> Vector3<T> {
        Vector3::from_fn(|k, _| self.p[(POS + k, POS + k)])
    }

    /// True when the innovation of `m` (covariance `s` [m^2]) is gross even against `s` plus
    /// the blur a 3-sigma heading error leaves beyond the small-angle model over the track
    /// since the last fix taken ([`integrity::heading_blur_m`]; at `v_eb_n` [m/s] for the `dt`
    /// [s] since the previous fix and the refusals before it): only then can it start a gross
    /// cluster (a consumer part's heading 108 deg off under a 60 deg 1-sigma, confirmed at
    /// rest, refused every true fix once it drove off as a jump, and ended 21 km off).
    fn beyond_heading_blur(
        &self,
        m: &Measurement<T, 3>,
        s: &Matrix3<T>,
        v_eb_n: &Vector3<T>,
        dt: T,
    ) -> bool {
        let distance_m = v_eb_n.x.hypot(v_eb_n.y) * (dt + self.refused_for_s);
        let blur = integrity::heading_blur_m(distance_m, self.p[(ATT + 2, ATT + 2)].sqrt());
        let mut wide = *s;
        wide[(0, 0)] += blur * blur;
        wide[(1, 1)] += blur * blur;
        integrity::whiten(&wide, &m.z).is_none_or(|w| {
            w.norm_squared() > self.config.gate_nis * T::c(integrity::GROSS_NIS_FACTOR)
        })
    }

    /// `cluster` judged against the filter's own position variances and the gate, as
    /// DEGRADED by refusals or not ([`RefusedCluster::judged`]).
    fn judged(&self, cluster: RefusedCluster<T>) -> RefusedCluster<T> {
        let p_pos = self.own_position_variances();
        cluster.judged(&p_pos, self.config.gate_nis, self.degraded_by_refusals())
    }

    /// True when the filter has diverged beyond what its fixes can bring back (the sequencer
    /// then re-aligns in motion, [`super::sequencer`]): DEGRADED by refusals
    /// ([`FilterConfig::rejections_to_degrade`] in a row), at least the last
    /// [`integrity::WINDOW`] of them one refused cluster that is not gross (fixes that agree
    /// among themselves, not a jump seen while the filter knew its position), and the
    /// filter's own horizontal 1-sigma (its covariance, without the doubt) beyond
    /// [`FilterConfig::max_horizontal_sigma_m`] (before any full window of fixes confirmed
    /// it, refusals each alone are enough: below). A filter pulled a few sigma off in a
    /// direction its covariance holds tight (a start drawn in the tails: a tactical filter at
    /// rest took a 0.11 deg/s gyro bias, 3.6 sigma wrong, from its first 13 fixes) drifts as
    /// fast as its 1-sigma grows: the fixes' normalised squares stay just above the gate
    /// (17-30) while the 1-sigma grows to kilometres, so neither the typical release nor the
    /// drifted cluster re-acquires, and every fix of the run was refused. By then its sensor
    /// estimates are as doubtful as its solution [Groves, ch. 17, re-initialisation]. A
    /// filter that no full window of fixes has confirmed yet has no clusters: there, the
    /// refusals in a row with its own 1-sigma beyond the limit are enough, and whatever its
    /// own 1-sigma once the last of them was refused alone (it continued no refused fix
    /// before it: the fixes move away from a solution that never knew its position; refused
    /// fixes that agree among themselves re-acquire instead, [`integrity`]) (a given start 111 m off under a declared 1 m, on a MEMS model: it
    /// re-acquired once, then drifted away from fixes moving 11 m/s relative to it, each
    /// refused alone, and was 2.2 km off at the end of the run, never re-aligned; a KF-GINS
    /// `starttime` 100 s after its static start state, the car 240 m away at 11 m/s: its
    /// own 1-sigma passed the limit only after 361 s, the solution 10 km off by then). A
    /// confirmed filter whose last two refused fixes were each refused alone has the fixes
    /// moving away from it as well: with its own 1-sigma beyond the limit, that is enough once
    /// a window ([`integrity::WINDOW`]) of fixes was refused in a row, without waiting for the
    /// count that makes it DEGRADED (a consumer part's heading 74 deg off under a declared 30
    /// deg, confirmed at rest, drove off refusing every fix, each 12 m from the one before,
    /// and ended 12 km off; at 100 refusals, re-aligned after 100 s of kilometres). Fixes
    /// refused alone beyond the limit of a filter's own 1-sigma are kilometres from it or
    /// wild: the start in motion takes only fixes that agree with the IMU. A window of fixes
    /// refused in a row as a jump that ran away ([`RefusedCluster::ran_away`]) faster than
    /// [`integrity::FAULT_RATE_MAX_M_S`] and than the filter's own velocity covariance allows
    /// ([`RefusedCluster::drift_is_plausible`]) is the filter's fault, whatever its own
    /// 1-sigma: no GNSS fault shared by the fixes moves that fast (a tactical part's yaw gyro
    /// stuck at zero for 5 s in a turn left it 79 deg off in heading; it refused the fixes as a
    /// jump running away at 15 m/s for 99 s, 3.8 km off at the 100th, where it re-aligned). A
    /// jump that stays put, or moves as the filter's own drift could, is held as before; so
    /// are fixes that repeat one place exactly, a window of them in a row: a receiver that
    /// stopped and sends its last record again runs away from a moving solution as fast
    /// (a car's receiver frozen for 30 s at 15 m/s: the filter re-aligned on the frozen
    /// place, 195 m off, and refused the true fixes after it for 80 s).
    pub fn diverged(&self) -> bool {
        let max = self.config.max_horizontal_sigma_m;
        let p_pos = self.own_position_variances();
        let clustered = self
            .cluster
            .as_ref()
            .is_some_and(|c| c.members as usize >= integrity::WINDOW && (!c.gross || c.ran_away));
        let unconfirmed = self
            .refused_unconfirmed
            .as_ref()
            .filter(|_| !self.confirmed);
        let alone = unconfirmed.is_some_and(RefusedCluster::is_lone);
        // Refused alone after a fix refused alone: the fixes move away from the solution.
        let moving_away = self
            .cluster
            .as_ref()
            .is_some_and(|c| c.is_lone() && c.refused_before.is_some());
        let beyond = p_pos.x + p_pos.y > max * max;
        let refused = clustered || moving_away || unconfirmed.is_some();
        let long = self.counters.position.consecutive_rejected as usize >= integrity::WINDOW;
        let p_vel = self.p.fixed_view::<3, 3>(VEL, VEL).into_owned();
        // Fixes that repeat one place exactly are a receiver that stopped (its last record
        // sent again), whose offset runs away at the vehicle's speed: the fixes' fault.
        let stale = self.repeated_fixes as usize >= integrity::WINDOW;
        let filter_fault = !stale
            && self.cluster.as_ref().is_some_and(|c| {
                c.members as usize >= integrity::WINDOW
                    && c.gross
                    && c.ran_away
                    && c.drift_rate().norm() > T::c(integrity::FAULT_RATE_MAX_M_S)
                    && !c.drift_is_plausible(&p_vel, self.config.gate_nis)
            });
        (self.degraded_by_refusals() && (alone || (refused && beyond)))
            || (moving_away && long && beyond)
            || (filter_fault && long)
    }

    /// Takes the counters of `diverged`, a filter of the same settings this one restarts
    /// after ([`Self::diverged`]); its refusals in a row end with it.
    pub fn take_counters_from(&mut self, diverged: &Self) {
        self.counters = diverged.counters;
        self.take_noise_scales_from(diverged);
        self.counters.position.consecutive_rejected = 0;
        self.covariance_faults = diverged.covariance_faults;
    }

    /// Takes over from `lost`, a filter of the same settings whose solution a gap in the IMU
    /// data too long to bridge destroyed ([`crate::gap`]), what the gap did not destroy, at a
    /// re-alignment in motion ([`super::sequencer`]): the sensor errors' block of the
    /// covariance and their cross-covariance with the consider states (the sensors are the
    /// same; their estimates go with it, [`super::AidedIns::resume`]), and the counters. The
    /// navigation block stays this filter's start, uncorrelated with the sensors (the gap left
    /// nothing of the old position, velocity and attitude). Over the `elapsed_s` [s] that
    /// `lost` did not propagate (the lost time and the re-alignment), the sensor variances grow
    /// by their driving noise `q elapsed` (at least the Gauss–Markov growth `(sigma^2 - P)(1 -
    /// exp(-2 t / tau))`), and the correlations with a decaying consider state decay.
    pub fn take_sensors_from(&mut self, lost: &Self, elapsed_s: T) {
        let elapsed_s = elapsed_s.max(T::zero());
        let q = model::noise_density(&self.config.noise, self.config.scale_factors);
        for i in BG..N {
            for j in BG..N {
                self.p[(i, j)] = lost.p[(i, j)];
            }
            self.p[(i, i)] += q[i] * elapsed_s;
            for c in 0..consider::NC {
                self.p_ac[(i, c)] = lost.p_ac[(i, c)] * self.consider.decay_over(c, elapsed_s);
            }
        }
        self.counters = lost.counters;
        self.take_noise_scales_from(lost);
        self.covariance_faults = lost.covariance_faults;
        self.fault_latched = lost.fault_latched;
        self.check_covariance();
    }

    /// The start's position is a GNSS fix's (a start in motion, [`super::motion`]): its error
    /// holds, besides the fix's white part (the start's 1-sigma), the receiver's declared
    /// correlated error `b` ([`consider::GP`]): the position error is `b + w`, so
    /// its variance gains `P_bb` and its cross-covariance with `b` is `P_bb` (the fixes see
    /// `-b`, [`consider::POSITION_SENSITIVITY`]; the first one's innovation is then `w0 - w1`,
    /// as it is). Without it the start claimed the white part alone and the fixes, sharing
    /// `b`, never showed otherwise: the position error stayed at `b`, 2-6 sigma, for minutes.
    /// Nothing without a declared correlated error.
    pub fn start_position_from_fix(&mut self) {
        if !self.consider.has_gnss_error() {
            return;
        }
        for i in 0..3 {
            let var_b = self.consider.variance()[consider::GP + i];
            self.p[(POS + i, POS + i)] += var_b;
            self.p_ac[(POS + i, consider::GP + i)] = var_b;
        }
        self.check_covariance();
    }

    /// The start's level was found from the accelerometers (a start in motion,
    /// [`super::motion`]) at attitude `c_b_n`: the level zeroes the velocity error's rate
    /// `[f_n x] phi + C_b_n b_a` ([`model::system_matrix`]) at the span's mean specific force
    /// `f_n = (0, 0, -g)` [m/s^2] but for the span's mean acceleration `a` (1-sigma
    /// `acceleration_sigma_mps2` per axis), so `phi_N = ((C_b_n b_a)_E + a_E) / g`,
    /// `phi_E = -((C_b_n b_a)_N + a_N) / g`: the tilt is `J b_a + e`, `J = [[0, 1/g], [-1/g,
    /// 0]] C_h` (the north and east rows of `C_b_n`). Its covariance with every state `k` is
    /// then `J P[b_a, k]` (with the consider states too), its own `J P_bb J^T + (sigma_a /
    /// g)^2 I`. Taken as independent of the bias, the tilt let the fixes, which see only the
    /// sum, split it between the two: a consumer part's 52 mg bias left its roll 3.8 deg off
    /// against a 0.3 deg 1-sigma on a straight flight.
    pub fn level_on_accelerometers(
        &mut self,
        c_b_n: &Matrix3<T>,
        g: T,
        acceleration_sigma_mps2: T,
    ) {
        let inv_g = T::one() / g;
        let m = nalgebra::Matrix2::new(T::zero(), inv_g, -inv_g, T::zero());
        let j = m * c_b_n.fixed_rows::<2>(0);
        let with_states = j * self.p.fixed_rows::<3>(BA);
        for k in (0..N).filter(|k| !(ATT..ATT + 2).contains(k)) {
            for r in 0..2 {
                self.p[(ATT + r, k)] = with_states[(r, k)];
                self.p[(k, ATT + r)] = with_states[(r, k)];
            }
        }
        let e = acceleration_sigma_mps2 * inv_g;
        let p_bb = self.p.fixed_view::<3, 3>(BA, BA).into_owned();
        let tilt = j * p_bb * j.transpose() + nalgebra::Matrix2::identity() * (e * e);
        self.p.fixed_view_mut::<2, 2>(ATT, ATT).copy_from(&tilt);
        let with_consider = j * self.p_ac.fixed_rows::<3>(BA);
        self.p_ac.fixed_rows_mut::<2>(ATT).copy_from(&with_consider);
        self.motion.c_b_n = *c_b_n;
        self.coast.clear();
        self.check_covariance();
    }

    fn last_state(&self) -> usize {
        if self.config.scale_factors { N } else { SG }
    }

    /// `P <- Phi P Phi^T + Q_d` over the propagation ([`model`], computed by its blocks:
    /// [`covariance`]).
    pub fn propagate(&mut self, prop: &Propagation<T>) {
        self.near_pole |= model::near_pole(&prop.lin.earth, &prop.lin.v_eb_n);
        let mut f = model::system_matrix(&prop.lin, &self.config.noise, self.config.scale_factors);
        let vrw = self.config.noise.vrw_mps_per_sqrt_s;
        model::couple_significant_specific_force(&mut f, &self.p, &prop.lin, vrw * vrw / prop.dt);
        let phi = Transition::new(&f, prop.dt);
        self.motion = Motion {
            c_b_n: prop.lin.c_b_n,
            f_ib_b: prop.lin.f_ib_b,
            omega_ib_b: prop.lin.omega_ib_b,
        };
        let mut q = model::noise_density(&self.config.noise, self.config.scale_factors);
        // A bridged gap's unknown motion, spread as driving noise over the interval
        // ([`crate::gap::GapDynamics`]).
        let sf = self.config.scale_factors;
        let second_order_v = model::second_order_velocity_density(&self.p, &prop.lin.f_ib_b, sf);
        let second_order_a =
            model::second_order_attitude_density(&self.p, &prop.lin.omega_ib_b, sf);
        let b = &prop.bridged;
        for k in 0..3 {
            q[ATT + k] += b.attitude_var_rad2 / prop.dt + second_order_a;
            q[VEL + k] += b.velocity_var_m2_s2 / prop.dt + second_order_v;
        }
        if let Some(lost) = &b.lost {
            self.lose(lost);
            self.imu_lost = true;
        }
        let phi_ac = self
            .consider
            .is_active()
            .then(|| consider::transition_columns(&f, &prop.lin, &self.consider, prop.dt));
        covariance::propagate(&mut self.p, &phi, &q, prop.dt);
        if prop.clipped.any() {
            self.add_clip_doubt(&prop.clipped, &prop.lin.c_b_n);
        }
        if let Some(phi_ac) = &phi_ac {
            consider::propagate(
                &mut self.p,
                &mut self.p_ac,
                &phi,
                phi_ac,
                &self.consider,
                prop.dt,
            );
        }
        self.counters.propagations = self.counters.propagations.wrapping_add(1);
        self.since_fix_s += prop.dt;
        for s in self.suspect_s.iter_mut().flatten() {
            *s += prop.dt;
        }
        self.check_covariance();
        // A gap's unknown motion is not in the coasting test's error model.
        let unknown_motion = b.attitude_var_rad2 > T::zero() || b.velocity_var_m2_s2 > T::zero();
        if b.lost.is_some() || unknown_motion || prop.clipped.any() {
            self.coast.clear();
        }
        let sf = self.config.scale_factors;
        self.coast
            .carried(prop.dt, &self.motion, &self.p, &self.config.noise, sf);
    }

    /// Adds what clipped samples could have missed ([`ClipDoubt`], per body axis) to the
    /// attitude and velocity covariance, turned into the navigation frame by `c_b_n`:
    /// `P += C_b_n diag(var_b) C_b_n^T`.
    #[cold]
    #[inline(never)]
    fn add_clip_doubt(&mut self, doubt: &ClipDoubt<T>, c_b_n: &Matrix3<T>) {
        for (at, var_b) in [
            (ATT, &doubt.attitude_var_b_rad2),
            (VEL, &doubt.velocity_var_b_m2_s2),
        ] {
            let add = c_b_n * Matrix3::from_diagonal(var_b) * c_b_n.transpose();
            let mut block = self.p.fixed_view_mut::<3, 3>(at, at);
            block += (add + add.transpose()) * T::c(0.5);
        }
    }

    /// The covariance across a gap too long to bridge ([`LostGap`]): the position carried at
    /// the velocity over `L` (`Phi = I + L` from velocity to position, `P <- Phi P Phi^T`),
    /// then an unknown constant acceleration over it, whose velocity variance `s2` gives the
    /// position `s2 L^2 / 4` and their covariance `s2 L / 2`, and the attitude's variance.
    /// The sensor states are not propagated over the gap (the sequencer adds their growth at
    /// a re-alignment).
    fn lose(&mut self, lost: &LostGap<T>) {
        let l = lost.lost_s;
        for k in 0..3 {
            let (r, v) = (POS + k, VEL + k);
            for j in 0..N {
                let p_vj = self.p[(v, j)];
                self.p[(r, j)] += l * p_vj;
            }
            for i in 0..N {
                let p_iv = self.p[(i, v)];
                self.p[(i, r)] += l * p_iv;
            }
            for c in 0..self.p_ac.ncols() {
                let p_vc = self.p_ac[(v, c)];
                self.p_ac[(r, c)] += l * p_vc;
            }
        }
        let s2 = lost.velocity_var_m2_s2;
        let half = T::c(0.5);
        for k in 0..3 {
            let (r, v, a) = (POS + k, VEL + k, ATT + k);
            self.p[(v, v)] += s2;
            self.p[(r, r)] += s2 * l * l * half * half;
            self.p[(r, v)] += s2 * l * half;
            self.p[(v, r)] += s2 * l * half;
            self.p[(a, a)] += lost.attitude_var_rad2;
        }
    }

    /// A variance that is not positive and finite (rounding in `f32` after a long
    /// unobservable stretch) is a fault: counted, latched in the status, and the covariance
    /// reset to its diagonal (the correlations are lost, the variances kept or floored).
    fn check_covariance(&mut self) {
        let last = self.last_state();
        let bad = (0..last).any(|i| !(self.p[(i, i)].finite() && self.p[(i, i)] > T::zero()))
            || !model::all_finite(&self.p);
        if bad {
            self.covariance_faults = self.covariance_faults.saturating_add(1);
            self.fault_latched = true;
            self.p_ac = CrossCovariance::zeros();
            for i in 0..N {
                for j in 0..N {
                    if i != j {
                        self.p[(i, j)] = T::zero();
                    }
                }
                let v = self.p[(i, i)];
                self.p[(i, i)] = if i >= last {
                    T::zero()
                } else if v.finite() && v > T::zero() {
                    v
                } else {
                    T::c(1e-12)
                };
            }
        }
    }

    /// True when the covariance is positive definite: the Cholesky factorisation of its
    /// correlation matrix exists (the variances span 20 orders of magnitude between states).
    /// With the scale factors off only the 15 modelled states are checked.
    pub fn is_positive_definite(&self) -> bool {
        let last = self.last_state();
        let mut d = [T::zero(); N];
        for (i, di) in d.iter_mut().enumerate().take(last) {
            let v = self.p[(i, i)];
            if !(v.finite() && v > T::zero()) {
                return false;
            }
            *di = T::one() / v.sqrt();
        }
        let mut l = Covariance::<T>::zeros();
        for j in 0..last {
            let mut s = T::one();
            for k in 0..j {
                s -= l[(j, k)] * l[(j, k)];
            }
            if !(s > T::zero()) {
                return false;
            }
            let ljj = s.sqrt();
            l[(j, j)] = ljj;
            for i in (j + 1)..last {
                let mut v = self.p[(i, j)] * d[i] * d[j];
                for k in 0..j {
                    v -= l[(i, k)] * l[(j, k)];
                }
                l[(i, j)] = v / ljj;
            }
        }
        true
    }

    /// The innovation covariance `S = H P H^T + diag(r)` and the normalised innovation
    /// squared `z^T S^-1 z` of a measurement; `None` when `S` is singular or the NIS not
    /// finite. With a consider error `e = H_c c` ([`consider`]), `S += H P_ac H_c^T + H_c
    /// P_ca H^T + H_c P_cc H_c^T`.
    fn innovation<const M: usize>(&self, m: &Measurement<T, M>) -> Option<(SMatrix<T, M, M>, T)> {
        let mut s = m.h * self.p * m.h.transpose();
        for i in 0..M {
            s[(i, i)] += m.r[i];
            if let Some(e) = consider::consider_error(&self.p_ac, &self.consider, m.seen(i)) {
                // Column i of H P_ac H_c^T, and its mirror.
                let hu = m.h * e.u;
                for j in 0..M {
                    s[(j, i)] += hu[j];
                    s[(i, j)] += hu[j];
                }
                s[(i, i)] += e.var;
            }
        }
        let s_inv = s.try_inverse()?;
        let nis = (m.z.transpose() * s_inv * m.z)[(0, 0)];
        (nis.finite() && nis >= T::zero()).then_some((s, nis))
    }

    /// `noise` having learnt from the measurement `m` before its update
    /// ([`super::noise_scale`]), and `m`'s innovation covariance and NIS
    /// ([`Self::innovation`]), for the update to take.
    fn learnt<const M: usize>(
        &self,
        mut noise: NoiseScale<T, M>,
        m: &Measurement<T, M>,
    ) -> (NoiseScale<T, M>, Option<(SMatrix<T, M, M>, T)>) {
        let innovation = self.innovation(m);
        if let Some((s, _)) = &innovation {
            noise.learn(&m.z, s, &m.r, self.config.gate_nis);
        }
        (noise, innovation)
    }

    /// The learnt scales of the position and the velocity fixes' declared noise variances
    /// now and their largest so far [-] ([`super::noise_scale`]): `[[now, peak]; 2]`.
    pub fn noise_scales(&self) -> [[T; 2]; 2] {
        [self.position_noise, self.velocity_noise].map(|n| [n.scale(), n.peak()])
    }

    /// Takes the learnt noise scales of `other`, a filter of the same fixes this one
    /// restarts after (the receiver is the same).
    fn take_noise_scales_from(&mut self, other: &Self) {
        self.position_noise = other.position_noise;
        self.velocity_noise = other.velocity_noise;
    }

    /// A vector measurement `z = H x + v`, `v ~ N(0, diag(r))`, `z` "predicted minus
    /// measured": the chi-square gate on the whole vector, then scalar Joseph updates in
    /// sequence [Groves, eq. 3.58], and the estimate handed out for the feedback.
    fn update<const M: usize>(
        &mut self,
        m: &Measurement<T, M>,
    ) -> (AidResult<T>, Option<Correction<T>>) {
        self.update_with(m, self.innovation(m))
    }

    /// [`Self::update`] of `m` whose innovation covariance and NIS are `innovation`
    /// ([`Self::innovation`], computed before by the caller).
    fn update_with<const M: usize>(
        &mut self,
        m: &Measurement<T, M>,
        innovation: Option<(SMatrix<T, M, M>, T)>,
    ) -> (AidResult<T>, Option<Correction<T>>) {
        let Some((s, nis)) = innovation else {
            return (AidResult::Invalid, None);
        };
        if nis > self.config.gate_nis {
            return (AidResult::Rejected { nis }, None);
        }
        self.apply(m, &self.shrink_basis(m, &s), nis)
    }

    /// Per row, the variance the shrink limit ([`effective_noise`]) judges, from the
    /// measurement's innovation covariance `s`: its diagonal, `p + r` of the predicted
    /// variance `p = h^T P h` and the noise `r`. A fix that also sees the declared GNSS error
    /// `e` (variance `v`, covariance `c = h^T u` with the error states,
    /// [`consider::consider_error`]) shrinks `p` to `p - (p + c)^2 / (p + r + v + 2 c)`, at
    /// most [`MAX_SHRINK`] times when `r >= 16 (p + c)^2 / (15 p) - p - v - 2 c`: its basis is
    /// the one that gives that bound, `r + 16 (p + c)^2 / p - 15 (p + v + 2 c)` (`p + r`
    /// without the error). Judged on `p + r` alone, the limit held back every fix whose own
    /// noise was small against the declared error (a code receiver's 0.5 m white part under
    /// its 2 m correlated one: the filter's innovations 3 % smaller than it predicted, at
    /// 0.1 m a third).
    fn shrink_basis<const M: usize>(
        &self,
        m: &Measurement<T, M>,
        s: &SMatrix<T, M, M>,
    ) -> SVector<T, M> {
        if m.gnss_error.is_none() {
            return s.diagonal();
        }
        SVector::<T, M>::from_fn(|i, _| {
            let hi = m.h.row(i).transpose();
            let (p, r) = (hi.dot(&(self.p * hi)), m.r[i]);
            match consider::consider_error(&self.p_ac, &self.consider, m.seen(i)) {
                Some(e) if p > T::zero() => {
                    let c = hi.dot(&e.u);
                    let shrink = T::c(MAX_SHRINK);
                    r + shrink * (p + c) * (p + c) / p
                        - (shrink - T::one()) * (p + e.var + T::c(2.0) * c)
                }
                _ => p + r,
            }
        })
    }

    /// The scalar Joseph updates of a measurement that passed its tests, with the per-row
    /// variances its shrink limit judges, `basis` ([`Self::shrink_basis`]).
    fn apply<const M: usize>(
        &mut self,
        m: &Measurement<T, M>,
        basis: &SVector<T, M>,
        nis: T,
    ) -> (AidResult<T>, Option<Correction<T>>) {
        for i in 0..M {
            let hi = m.h.row(i).transpose();
            let innovation = m.z[i] - hi.dot(&self.x);
            // Re-acquisition after a gap: one fix may not shrink the predicted variance more
            // than MAX_SHRINK times (its noise variance is raised to the prediction's share):
            // a fix far inside a wide prediction can still be an outlier the gate cannot see,
            // and the next fixes must be able to pull the solution back.
            let r_eff = effective_noise(basis[i], m.r[i]);
            let seen = m.seen(i);
            let e = consider::consider_error(&self.p_ac, &self.consider, seen);
            // The gain, for the consider states' cross-covariance ([`consider::update`]).
            let gain = self
                .consider
                .is_active()
                .then(|| ConsiderError::gain(e.as_ref(), &self.p, &hi, r_eff))
                .flatten();
            if update_scalar_correlated(
                &mut self.x,
                &mut self.p,
                &hi,
                e.as_ref(),
                innovation,
                r_eff,
                T::c(1e15),
            ) != ScalarUpdate::Accepted
            {
                // The vector test passed, so this is rounding: keep what was used.
                break;
            }
            if let Some(k) = &gain {
                consider::update(&mut self.p_ac, k, &hi, seen, &self.consider);
            }
        }
        let correction = Correction {
            x: self.x,
            uncertainty: self.uncertainty(),
        };
        // Another aid's correction while fixes are refused (a position fix's ends the
        // cluster before its update).
        let dr = self.x.fixed_rows::<3>(POS).into_owned();
        for c in [&mut self.cluster, &mut self.refused_unconfirmed] {
            *c = c.map(|c| c.corrected(&dr));
        }
        let l_n = self.motion.c_b_n * self.config.antenna_lever_arm_b_m;
        let dphi = self.x.fixed_rows::<3>(ATT).into_owned();
        let dv = self.x.fixed_rows::<3>(VEL).into_owned();
        let (c_b_n, f_ib_b) = (&self.motion.c_b_n, &self.motion.f_ib_b);
        let scaled = self.x.fixed_rows::<3>(SA).component_mul(f_ib_b);
        let da = (c_b_n * f_ib_b).cross(&dphi) + c_b_n * (self.x.fixed_rows::<3>(BA) + scaled);
        self.latency
            .corrected(&(dr + model::skew(&l_n) * dphi), &dv, &da, self.since_fix_s);
        self.coast.taken(&self.x);
        self.reset_attitude(&self.x.fixed_rows::<3>(ATT).into_owned());
        self.x = StateVector::zeros();
        self.check_covariance();
        (AidResult::Accepted { nis }, Some(correction))
    }

    /// The error state's reset for the attitude `phi` [rad] fed back (`C_b_n <- Exp(phi)
    /// C_b_n`). Split the error as `Exp(phi_e) = R_z(psi) Exp(tau)`: the accelerometers see the
    /// tilt `tau` (gravity in the computed frame is `Exp(-tau) g`), the heading `psi` turns it.
    /// The heading fed back, `R_z(phi_D)`, leaves `R_z(psi - phi_D) Exp(R_z(phi_D) tau)`: the
    /// tilt turned by the whole heading correction, and a tilt fed back only subtracts. So the
    /// attitude rows and columns of `P`, and of the consider cross-covariance, go through the
    /// rotation `G = R_z(phi_D)`. It replaces [Sola, 2017, §7.2]'s `I + [phi x] / 2`, whose
    /// half turn of the tilt (and whose tilt feedback mixed into the heading) the linear model,
    /// which takes the tilt as what gravity sees, cannot follow: a still consumer part's heading
    /// 1-sigma fell from 30 to 16 deg in 5 min, where the gyros can tell nothing. A no-op for
    /// the microradians of a settled filter (skipped below [`RESET_MIN_RAD`]); at a start in
    /// motion a heading fed back by tens of degrees turns the tilt's correlation with the
    /// accelerometer biases with it (without it, the filter took the turned correlation for
    /// information on the biases: a consumer part's lateral bias 9 sigma off on a straight
    /// flight). The rows and columns are set as mirrors, the block symmetrised: `P` stays
    /// exactly symmetric in `f32`.
    fn reset_attitude(&mut self, phi: &Vector3<T>) {
        if phi.z.abs() < T::c(RESET_MIN_RAD) {
            return;
        }
        let (sin, cos) = (phi.z.sin(), phi.z.cos());
        let z = T::zero();
        let g = Matrix3::new(cos, -sin, z, sin, cos, z, z, z, T::one());
        for k in (0..N).filter(|k| !(ATT..ATT + 3).contains(k)) {
            let column = g * self.p.fixed_view::<3, 1>(ATT, k);
            for r in 0..3 {
                self.p[(ATT + r, k)] = column[r];
                self.p[(k, ATT + r)] = column[r];
            }
        }
        let block = g * self.p.fixed_view::<3, 3>(ATT, ATT) * g.transpose();
        let symmetric = (block + block.transpose()) * T::c(0.5);
        self.p
            .fixed_view_mut::<3, 3>(ATT, ATT)
            .copy_from(&symmetric);
        let consider = g * self.p_ac.fixed_rows::<3>(ATT);
        self.p_ac.fixed_rows_mut::<3>(ATT).copy_from(&consider);
    }

    /// Adds the covariance `q` to the 3 x 3 block of the states from `at` (`P` stays
    /// symmetric: `q` is).
    fn add_doubt(&mut self, at: usize, q: &Matrix3<T>) {
        let mut block = self.p.fixed_view_mut::<3, 3>(at, at);
        block += q;
    }

    fn counted(
        counters: &mut AidCounters,
        out: (AidResult<T>, Option<Correction<T>>),
    ) -> (AidResult<T>, Option<Correction<T>>) {
        counters.count(&out.0);
        out
    }

    /// A GNSS position fix of the antenna taken `lag_s` [s] before the snapshot's sample: the
    /// per-fix gate, then the refused-cluster rule and the windowed innovation test
    /// ([`super::integrity`]).
    pub fn position(
        &mut self,
        snap: &Snapshot<T>,
        fix: &GnssPosition<T>,
        lag_s: T,
    ) -> (AidResult<T>, Option<Correction<T>>) {
        let since_last_s = self.since_fix_s;
        let llh = [fix.lat_rad, fix.lon_rad, fix.h_m];
        self.repeated_fixes = match self.last_fix_llh {
            Some(last) if last == llh => self.repeated_fixes.saturating_add(1),
            _ => 0,
        };
        self.last_fix_llh = Some(llh);
        if let Some((p, v, a)) = self.latency.retime() {
            self.add_doubt(POS, &p);
            self.add_doubt(VEL, &v);
            self.add_doubt(ATT, &a);
            // The innovations so far were of fixes taken at other epochs: a cluster of them
            // refused, or the window's test of them, says nothing of the retimed ones (a FOG
            // car's fixes, refused as a cluster before the latency was found, stayed refused
            // within 2 of their gate after it, the solution free-inertial). What the cluster
            // left doubtful (reported, not gated) joins the covariance the gate uses.
            let unconfirmed = self.refused_unconfirmed.take();
            if let Some(c) = self.cluster.take().or(unconfirmed) {
                let zero = Matrix3::zeros;
                self.add_doubt(POS, &c.doubt().unwrap_or_else(zero));
                self.add_doubt(VEL, &c.velocity_doubt().unwrap_or_else(zero));
            }
            self.window.clear();
            // The retimed fixes' first pull, and the corrections the anchors of the coasting
            // test set before see, are the latency's doubt, taken above: no fault.
            self.pull = Pull::none();
            self.coast = Coast::none();
        }
        let (late_s, late_sigma_s) = self.latency.applied();
        let retimed = retiming(snap, lag_s, late_s);
        let scale = self.position_noise.scale();
        let m = self.position_measurement(snap, fix, lag_s).map(|mut m| {
            let v = &snap.state.v_eb_n;
            m.z -= retimed;
            m.r = m.r * scale + v.component_mul(v) * (late_sigma_s * late_sigma_s);
            m
        });
        let mut innovation = None;
        if let Some(m) = &m {
            (self.position_noise, innovation) = self.learnt(self.position_noise, m);
        }
        let corrections = self.latency.take_corrections();
        let accel_var = self.accel_error_variance(snap.earth.g);
        let out = match &m {
            Some(m) => {
                self.screened_position_update(m, innovation, snap.earth.g, &snap.state.v_eb_n)
            }
            None => (AidResult::Invalid, None),
        };
        match (&m, &out.0) {
            (Some(m), AidResult::Accepted { .. } | AidResult::Rejected { .. }) => {
                let f = LatencyFix {
                    // As the fix's tag gives it, whatever the retiming; its noise as the update
                    // takes it.
                    z_m: m.z + retimed,
                    r_m2: fix.sigma_ned_m.component_mul(&fix.sigma_ned_m) * scale,
                    accel_var,
                    correlated: self
                        .config
                        .gnss_correlated_error
                        .filter(|g| g.correlation_time_s > T::zero())
                        .map(|g| {
                            (
                                g.sigma_ned_m.component_mul(&g.sigma_ned_m),
                                g.correlation_time_s,
                            )
                        }),
                    v_eb_n: snap.state.v_eb_n - snap.a_eb_n * lag_s,
                    dt_s: since_last_s,
                    corrections,
                };
                let omega_n = snap.state.q_b_n * snap.omega_ib_b;
                self.latency.fix(&f, &snap.a_eb_n, &omega_n);
            }
            _ => self.latency.broken(),
        }
        let out = Self::counted(&mut self.counters.position, out);
        self.note_suspect(POSITION_AID, &out.0);
        self.refused_for_s = match (&out.0, self.counters.position.consecutive_rejected) {
            (AidResult::Rejected { .. }, 1) | (AidResult::Accepted { .. }, _) => T::zero(),
            (AidResult::Rejected { .. }, _) => self.refused_for_s + since_last_s,
            (AidResult::Invalid, _) => self.refused_for_s,
        };
        self.coast.judged(&self.p, &self.config.noise);
        let held = self.heading_doubt_rad2;
        self.heading_doubt_rad2 = self
            .cluster
            .as_ref()
            .or(self.refused_unconfirmed.as_ref())
            .map_or_else(T::zero, |c| c.heading_doubt(&snap.state.v_eb_n, held));
        out
    }

    /// The position update of `m` (its innovation covariance and NIS `innovation`,
    /// [`Self::innovation`]) with the integrity tests of [`super::integrity`]; `g` [m/s^2] the
    /// gravity at the solution, `v_eb_n` [m/s] its velocity.
    fn screened_position_update(
        &mut self,
        m: &Measurement<T, 3>,
        innovation: Option<(Matrix3<T>, T)>,
        g: T,
        v_eb_n: &Vector3<T>,
    ) -> (AidResult<T>, Option<Correction<T>>) {
        let Some((mut s, mut nis)) = innovation else {
            return (AidResult::Invalid, None);
        };
        let gate = self.config.gate_nis;
        // The previous fix was taken alone after a gap and this one disagrees with it: that
        // fix may have been the outlier, and what it pulled the filter by is doubtful
        // ([`integrity`] module docs).
        if let Some(r) = self.reacquired.take()
            && nis > gate
        {
            r.undo(&mut self.p);
            self.check_covariance();
            let Some(again) = self.innovation(m) else {
                return (AidResult::Invalid, None);
            };
            (s, nis) = again;
        }
        // Time since the previous fix (the cluster's last member, if refused) [s].
        let dt = core::mem::replace(&mut self.since_fix_s, T::zero());
        let drift = self.fix_drift(dt, g);
        self.restart = self.restart.map(|r| r.carried(dt));
        self.pull = self.pull.carried(dt);
        let mut recovered = false;
        // DEGRADED by refusals, and this one refused but where the solution would be had the
        // fixes of the last minutes not pulled it: a fault it followed has ended, and the
        // pull is doubtful ([`integrity`] module docs, [Groves, ch. 17]).
        if nis > gate && self.degraded_by_refusals() && self.pull.explains(&m.z, &s, gate) {
            let doubts = self
                .pull
                .doubt()
                .into_iter()
                .chain(self.pull.sensor_doubt());
            for (at, d) in [POS, VEL, ATT, BG, BA].into_iter().zip(doubts) {
                self.add_doubt(at, &d);
            }
            self.check_covariance();
            self.pull = Pull::none();
            let Some(again) = self.innovation(m) else {
                return (AidResult::Invalid, None);
            };
            (s, nis) = again;
            recovered = nis <= gate;
            if recovered {
                self.cluster = None;
                self.window.clear();
                self.restart = None;
            }
        }
        let refused_unconfirmed = self.refused_unconfirmed.take();
        if nis > gate && self.cluster.is_none() && !self.confirmed {
            // Refused by the gate, but no cluster: a full window has not yet confirmed the
            // filter's position since its start ([`integrity`] module docs). Once DEGRADED,
            // a fix that continues the refused ones re-acquires: the filter never knew its
            // position, and the fixes agree among themselves.
            let tracked = match refused_unconfirmed {
                Some(c) if c.continued_by(&m.z, &m.r, &drift, nis, gate) => {
                    c.followed_by(m.z, m.r, dt)
                }
                previous => {
                    RefusedCluster::start(m.z, m.r, nis, gate, false).after(previous.as_ref(), dt)
                }
            };
            if !self.degraded_by_refusals() || tracked.previous.is_none() {
                self.refused_unconfirmed = Some(tracked);
                return (AidResult::Rejected { nis }, None);
            }
            // Taken as a drifted cluster is (below): the drift's rate joins the velocity's
            // covariance, the offset the position's [Groves, ch. 17].
            self.cluster = Some(tracked);
            recovered = true;
            let v = tracked.drift_rate();
            let mut vel = self.p.fixed_view_mut::<3, 3>(VEL, VEL);
            vel += v * v.transpose();
            self.window.clear();
            self.restart = None;
        }
        if nis > gate && !recovered {
            // Continues the cluster it agrees with, or starts one.
            let cluster = match &self.cluster {
                Some(c) if c.continued_by(&m.z, &m.r, &drift, nis, gate) => {
                    c.followed_by(m.z, m.r, dt)
                }
                previous => RefusedCluster::start(
                    m.z,
                    m.r,
                    nis,
                    gate,
                    self.window.len() == integrity::WINDOW
                        && self.beyond_heading_blur(m, &s, v_eb_n, dt),
                )
                .replacing(previous.as_ref())
                .after(previous.as_ref(), dt),
            };
            let cluster = self.judged(cluster);
            self.cluster = Some(cluster);
            // DEGRADED, and the refused fixes moved away from the filter faster than its own
            // covariance allows: the filter is the one drifting ([`integrity`] module docs).
            let p_pos = self.own_position_variances();
            let p_vel = self.p.fixed_view::<3, 3>(VEL, VEL).into_owned();
            recovered = self.degraded_by_refusals()
                && cluster.drifted(&p_pos, gate)
                && cluster.drift_is_plausible(&p_vel, gate);
            if !recovered {
                return (AidResult::Rejected { nis }, None);
            }
            // Its velocity is doubtful by the rate of that drift; its position by the
            // cluster's offset (added below as after any cluster) [Groves, ch. 17].
            let v = cluster.drift_rate();
            let mut vel = self.p.fixed_view_mut::<3, 3>(VEL, VEL);
            vel += v * v.transpose();
            self.window.clear();
            self.restart = None;
        }
        // A member of the cluster refused before. Under a declared correlated GNSS error
        // the fixes share that error, so a fix that passes the gate agrees with the one
        // refused before it whether or not they are faulty: only a gross cluster claims it
        // ([`integrity`] module docs).
        let correlated = self.consider.has_gnss_error();
        if !recovered
            && let Some(c) = &self.cluster
            && (c.gross || !correlated)
            && c.claims(&m.z, &m.r, &drift, nis, &s, gate)
        {
            self.cluster = Some(self.judged(c.followed_by(m.z, m.r, dt)));
            let n = &mut self.counters.position.cluster_rejected;
            *n = n.saturating_add(1);
            return (AidResult::Rejected { nis }, None);
        }
        let Some(w) = whiten(&s, &m.z) else {
            return (AidResult::Invalid, None);
        };
        // The recovered fix starts nothing in the window: its innovation is the drift the
        // filter did not see.
        if !recovered {
            self.window.push(w);
            self.confirmed |= self.window.len() == integrity::WINDOW;
        }
        if !recovered && self.window.verdict(gate, correlated) != WindowVerdict::Consistent {
            if self.counters.position.consecutive_rejected < integrity::WINDOW_REFUSALS_MAX {
                // What the window's earlier fixes pulled the filter by is now doubtful.
                let d = self.window.take_corrections();
                self.p += d * d.transpose();
                self.check_covariance();
                self.restart = None;
                let n = &mut self.counters.position.window_rejected;
                *n = n.saturating_add(1);
                return (AidResult::Rejected { nis }, None);
            }
            // Refused so long that the window holds the filter's own drift while it was
            // refusing (module docs of `integrity`): this fix starts a new window.
            self.window.clear();
            self.window.push(w);
            // Until a full window confirms it, what its fixes move the solution by is
            // doubtful ([`integrity`] module docs).
            self.restart = Some(Restart::new(
                self.p.fixed_view::<3, 3>(POS, POS).into_owned(),
            ));
        }
        if let Some(c) = self.cluster.take() {
            // The first fix after a refused cluster: its offset joins the position's
            // covariance, in the part the cluster held ([`RefusedCluster::weight`]:
            // [`integrity`] module docs, [Groves, ch. 17]); after a lone refused fix, only
            // where it agrees with that fix rather than with the filter (one that agrees with
            // the filter says the refused one was the outlier).
            let agrees = recovered || !c.is_lone() || c.distance(&m.z, &m.r, &drift) < nis;
            let z = if agrees {
                m.z * c.weight()
            } else {
                Vector3::zeros()
            };
            let mut pos = self.p.fixed_view_mut::<3, 3>(POS, POS);
            pos += z * z.transpose();
            if agrees {
                // And the heading's by the angle between the solution's track and the
                // refused fixes' ([`RefusedCluster::heading_doubt`]), which the reported
                // covariance alone carried: re-acquired without it, a tactical filter
                // whose heading was 8 deg off under a 0.6 deg 1-sigma refused the fixes of
                // each turn, re-acquired their offset and velocity, and kept the heading
                // for 150 s, NAV.
                self.p[(ATT + 2, ATT + 2)] += self.heading_doubt_rad2;
            }
            let Some(again) = self.innovation(m) else {
                return (AidResult::Invalid, None);
            };
            (s, nis) = again;
        }
        if recovered || self.degraded_by_refusals() {
            self.reacquire_from_degraded();
            let Some(again) = self.innovation(m) else {
                return (AidResult::Invalid, None);
            };
            (s, nis) = again;
        }
        let p_pos_before = self.p.fixed_view::<3, 3>(POS, POS).into_owned();
        let p_vel_before = self.p.fixed_view::<3, 3>(VEL, VEL).into_owned();
        let basis = self.shrink_basis(m, &s);
        let out = self.apply(m, &basis, nis);
        if let Some(c) = &out.1 {
            let pos_shrink = p_pos_before - self.p.fixed_view::<3, 3>(POS, POS);
            let vel_shrink = p_vel_before - self.p.fixed_view::<3, 3>(VEL, VEL);
            self.pull = self.pull.taken(&c.x, &pos_shrink, &vel_shrink);
            self.window.set_last_correction(&c.x);
            self.restart = self
                .restart
                .map(|r| r.taken(&c.x))
                .filter(|r| !r.is_confirmed());
            let limited = (0..3).any(|i| effective_noise(basis[i], m.r[i]) > m.r[i]);
            self.reacquired = limited.then_some(Reacquisition {
                correction: c.x,
                position_shrink: pos_shrink,
            });
        }
        out
    }

    /// A DEGRADED filter re-acquires: the fixes it takes again re-anchor its position, so the
    /// coasting test across that jump says nothing more of its error and its anchors end
    /// ([`coast`] module docs). What the accepted fixes of the last minutes turned and
    /// accelerated the solution by ([`Pull::doubt`]; nothing once a recovery by the pull took
    /// it; taken once, [`Pull::position_only`]), and what the anchor that failed found the
    /// corrections had, join the velocity's and attitude's covariance (`d d^T`, the fault
    /// recovery by covariance increase of [Groves, ch. 17]): a FOG car that had followed a
    /// ramp held its pitch 12 s beyond 4 sigma after re-acquiring (up to 6.6).
    fn reacquire_from_degraded(&mut self) {
        if !self.consider.has_gnss_error() {
            let [_, pv, pa] = self.pull.doubt();
            let [pg, pb] = self.pull.sensor_doubt();
            let [_, cv, ca] = self.coast.doubt().unwrap_or([Matrix3::zeros(); 3]);
            for (at, d) in [(VEL, pv + cv), (ATT, pa + ca), (BG, pg), (BA, pb)] {
                let mut block = self.p.fixed_view_mut::<3, 3>(at, at);
                block += d;
            }
            self.check_covariance();
            self.pull = self.pull.position_only();
        }
        self.coast.clear();
    }

    /// The filter's own drift over the `dt` [s] since the previous fix
    /// ([`integrity::FixDrift`]): the velocity variance times `dt^2` plus the change of a
    /// declared correlated GNSS error over `dt` (two fixes of one offset differ by it as
    /// well), and a bound of the acceleration error's variance, `g^2` [m/s^2] times the
    /// attitude variances plus the accelerometer bias variances (isotropic: a tilt or a
    /// heading error times the specific force, a bias in any axis), times `dt^4`.
    fn fix_drift(&self, dt: T, g: T) -> integrity::FixDrift<T> {
        let accel_var = self.accel_error_variance(g);
        let dt2 = dt * dt;
        integrity::FixDrift {
            dt_s: dt,
            var_m2: Vector3::from_fn(|k, _| self.p[(VEL + k, VEL + k)]) * dt2
                + self.consider.gnss_error_change_variance(dt),
            curvature_var_m2: Vector3::repeat(accel_var * dt2 * dt2),
        }
    }

    /// A bound of the acceleration error's variance [m^2/s^4] at gravity `g` [m/s^2]: `g^2`
    /// times the attitude variances plus the accelerometer bias variances (isotropic: a tilt
    /// or a heading error times the specific force, a bias in any axis).
    fn accel_error_variance(&self, g: T) -> T {
        let var = |at: usize| (0..3).fold(T::zero(), |a, k| a + self.p[(at + k, at + k)]);
        g * g * var(ATT) + var(BA)
    }

    /// The measurement of a position fix: predicted minus measured, the INS position's NED
    /// offset from the fix (metres, at the fix) plus the lever arm, moved back to the fix
    /// time; `None` for an invalid fix.
    fn position_measurement(
        &self,
        snap: &Snapshot<T>,
        fix: &GnssPosition<T>,
        lag_s: T,
    ) -> Option<Measurement<T, 3>> {
        if !(fix.is_valid() && lag_s.finite()) {
            return None;
        }
        let st = &snap.state;
        let c_b_n = st.q_b_n.to_rotation_matrix().into_inner();
        let l_n = c_b_n * self.config.antenna_lever_arm_b_m;
        let measured = Position::from_radians(fix.lat_rad, fix.lon_rad, fix.h_m);
        let d = measured.ned_to(&st.position);
        let z = Vector3::new(T::c(d[0]), T::c(d[1]), T::c(d[2])) + l_n - st.v_eb_n * lag_s;
        let mut h = SMatrix::<T, 3, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, POS)
            .copy_from(&Matrix3::identity());
        // r~_ant = r + C~ l = r_ant + dr + [(C l) x] phi.
        h.fixed_view_mut::<3, 3>(0, ATT)
            .copy_from(&model::skew(&l_n));
        let r = fix.sigma_ned_m.component_mul(&fix.sigma_ned_m);
        Some(Measurement {
            z,
            h,
            r,
            gnss_error: self.consider.has_gnss_error().then_some(consider::GP),
        })
    }

    /// A GNSS velocity of the antenna taken `lag_s` [s] before the snapshot's sample.
    pub fn velocity(
        &mut self,
        snap: &Snapshot<T>,
        fix: &GnssVelocity<T>,
        lag_s: T,
    ) -> (AidResult<T>, Option<Correction<T>>) {
        let (late_s, late_sigma_s) = self.latency.applied();
        let scale = self.velocity_noise.scale();
        let m = self
            .velocity_measurement(snap, fix, lag_s + late_s)
            .map(|mut m| {
                let a = &snap.a_eb_n;
                m.r = m.r * scale + a.component_mul(a) * (late_sigma_s * late_sigma_s);
                m
            });
        let mut innovation = None;
        if let Some(m) = &m {
            // As the fix's tag gives it, whatever the retiming; before its update (whose
            // correction the test would undo). Its noise as the update takes it.
            let z = m.z + snap.a_eb_n * late_s;
            let r = fix.sigma_ned_m_s.component_mul(&fix.sigma_ned_m_s) * scale;
            self.latency.velocity(&z, &r);
            (self.velocity_noise, innovation) = self.learnt(self.velocity_noise, m);
        }
        if let (Some(m), Some((s, nis))) = (&m, &innovation)
            && *nis <= self.config.gate_nis
            && let Some(w) = whiten(s, &m.z)
        {
            self.velocity_window.push(w);
        }
        let out = match m {
            Some(m) => self.update_with(&m, innovation),
            None => (AidResult::Invalid, None),
        };
        let out = Self::counted(&mut self.counters.velocity, out);
        self.note_suspect(VELOCITY_AID, &out.0);
        out
    }

    /// The measurement of a velocity fix: `v_ant = v + C (omega_ib_b x l) - omega_ie_n x (C l)`
    /// (the lever arm's velocity relative to the Earth) minus the fix, moved back to the fix
    /// time; `None` for an invalid fix.
    fn velocity_measurement(
        &self,
        snap: &Snapshot<T>,
        fix: &GnssVelocity<T>,
        lag_s: T,
    ) -> Option<Measurement<T, 3>> {
        if !(fix.is_valid() && lag_s.finite()) {
            return None;
        }
        let st = &snap.state;
        let c_b_n = st.q_b_n.to_rotation_matrix().into_inner();
        let l_b = self.config.antenna_lever_arm_b_m;
        let l_n = c_b_n * l_b;
        let omega_ie_n = snap.earth.omega_ie_n();
        let rot_n = c_b_n * snap.omega_ib_b.cross(&l_b);
        let v_ant = st.v_eb_n + rot_n - omega_ie_n.cross(&l_n) - snap.a_eb_n * lag_s;
        let z = v_ant - fix.v_ned_m_s;
        let mut h = SMatrix::<T, 3, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, VEL)
            .copy_from(&Matrix3::identity());
        h.fixed_view_mut::<3, 3>(0, ATT)
            .copy_from(&model::skew(&rot_n));
        // C (d_omega x l) = -C [l x] d_omega, d_omega = b_g + diag(omega) s_g.
        let c_l = -(c_b_n * model::skew(&l_b));
        h.fixed_view_mut::<3, 3>(0, BG).copy_from(&c_l);
        if self.config.scale_factors {
            h.fixed_view_mut::<3, 3>(0, SG)
                .copy_from(&(c_l * Matrix3::from_diagonal(&snap.omega_ib_b)));
        }
        let r = fix.sigma_ned_m_s.component_mul(&fix.sigma_ned_m_s);
        Some(Measurement::of_states(z, h, r))
    }

    /// Zero-velocity and zero-rate updates over a still window: both results and the
    /// combined correction.
    pub fn zero_motion(
        &mut self,
        snap: &Snapshot<T>,
        w: &StillWindow<T>,
    ) -> (AidResult<T>, AidResult<T>, Option<Correction<T>>) {
        let Some(zm) = self.config.zero_motion else {
            return (AidResult::Invalid, AidResult::Invalid, None);
        };
        // Zero velocity of the IMU, if the solution is slow enough to be stopped and knows
        // its horizontal velocity to within that speed (after a gap in the IMU data, a
        // cruise the detector takes for a stop would pass the gate).
        let z = snap.state.v_eb_n;
        let max2 = zm.max_speed_m_s * zm.max_speed_m_s;
        let known = self.p[(VEL, VEL)] <= max2 && self.p[(VEL + 1, VEL + 1)] <= max2;
        if !(z.norm() <= zm.max_speed_m_s && known) {
            self.counters.zero_velocity.count(&AidResult::<T>::Invalid);
            return (AidResult::Invalid, AidResult::Invalid, None);
        }
        let mut h = SMatrix::<T, 3, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, VEL)
            .copy_from(&Matrix3::identity());
        let r = Vector3::repeat(zm.velocity_sigma_m_s * zm.velocity_sigma_m_s);
        let (rv, cv) = self.update(&Measurement::of_states(z, h, r));
        self.counters.zero_velocity.count(&rv);
        // The rate only at a stop the velocity confirms: a gentle curve driven at constant
        // speed also passes the detector, and its rate taken for a gyro bias would turn the
        // heading.
        if !matches!(rv, AidResult::Accepted { .. }) {
            return (rv, AidResult::Invalid, None);
        }
        // Zero rate relative to the Earth: the window's mean rate minus the Earth rate in body
        // axes the attitude predicts. With `C~_n_b = C_n_b (I + [phi x])` (`model`) it is
        // `b_g + C_n_b [omega_ie_n x] phi` (diag(omega) s_g neglected at rest): the Earth
        // rate's projection turns with the heading error, by `Omega cos(lat) sin(psi)`, 7.5
        // deg/h for 30 deg at 45 deg latitude. Without that term a stop took the heading's
        // share for bias, and the heading's 1-sigma fell below what a stop can tell when the
        // gyro bias is near the Earth rate (6.1 deg against 9.4; a consumer part at rest was
        // 5-10 sigma off in heading) [Groves, §14.2.1, §15.3].
        let c_n_b = snap
            .state
            .q_b_n
            .to_rotation_matrix()
            .into_inner()
            .transpose();
        let omega_ie_n = snap.earth.omega_ie_n();
        let mut h = SMatrix::<T, 3, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, BG)
            .copy_from(&Matrix3::identity());
        h.fixed_view_mut::<3, 3>(0, ATT)
            .copy_from(&(c_n_b * model::skew(&omega_ie_n)));
        // Relative to the state the zero-velocity update left.
        let mut z = w.omega_ib_b - c_n_b * omega_ie_n;
        if let Some(c) = &cv {
            z -= h * c.x;
        }
        let arw = self.config.noise.arw_rad_per_sqrt_s;
        // The bias instability is a consider state the measurement sees: its variance is
        // given to the measurement noise (the window is shorter than its correlation time).
        let var = arw * arw / w.duration_s
            + zm.rate_sigma_rad_s * zm.rate_sigma_rad_s
            + self.consider.gyro_bias_instability_variance();
        let r = Vector3::repeat(var);
        let (rr, cr) = self.update(&Measurement::of_states(z, h, r));
        self.counters.zero_rate.count(&rr);
        let c = match (cv, cr) {
            (Some(a), Some(b)) => Some(Correction {
                x: a.x + b.x,
                uncertainty: b.uncertainty,
            }),
            (a, b) => a.or(b),
        };
        (rv, rr, c)
    }
}
