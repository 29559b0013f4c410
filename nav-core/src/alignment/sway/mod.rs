//! Base-motion-model fine alignment (`--align-method sway`): the general filter
//! ([`super::fine`]) and, as an [`Extension`] of it, a model of how the base turns — still, or
//! swaying about a fixed mean attitude.
//!
//! **Why it beats the general floor.** The general filter knows nothing of how the body turns:
//! the heading shows only as the east tilt drift `W psi` (`W = Omega cos(lat)`), found from the
//! accelerometers' noisy view of the tilt, so its floor has the term
//! `sqrt(12) N_a / (g W T^1.5)`. If the body is known to sway about a *fixed* mean attitude,
//! the gyro-integrated attitude itself shows the drift: its roll and pitch, once the modelled
//! sway is removed, should be constant, and every change is the attitude error drifting with
//! the Earth-rate error. Only the gyro noise limits the estimate then: the motion-known floor
//! `N_g / (W sqrt(T))` [Titterton & Weston, §10.3.2].
//!
//! **Model.** The integrated roll and pitch (of the general filter's strapdown, in its level
//! frame `c`) are measured against `mean + s(t) - A phi` (`A` the Euler-angle Jacobian,
//! [`euler_jacobian`]), every [`SwayConfig::sample_period_s`], noise
//! [`SwayConfig::euler_sigma_rad`] (what the oscillators do not describe). States past the
//! general filter's ([`MEAN`], [`OSC`], [`FREQ`]): mean roll and pitch, a phasor `(s, c)` per
//! axis (`ds/dt = w c`, `dc/dt = -w s`, amplitude random walk), and a frequency error per axis
//! (EKF Jacobian `(c dt, -s dt)`, folded into the frequency after every update). Yaw sway
//! needs no model: it only enters through `A`. A lever arm and the centre's heave and
//! translation are the general filter's: the level comes from the IMU's position there.
//!
//! **Identification.** For [`SwayConfig::identify_s`] the roll and pitch are kept; then each
//! axis's period is found by least squares (line plus one sinusoid, [`search`]), a few fits
//! per filter step so the firmware's alignment task never stalls; an axis whose sinusoid is
//! below [`SwayConfig::min_amplitude_rad`] is still (its oscillator stays off: a still base
//! is the special case). The states start from the fit at the current time; the general
//! filter runs throughout.
//!
//! **Honesty.** The roll/pitch innovations' mean normalised square must stay below
//! [`MAX_EULER_NIS`]: roll or pitch that is not one sinusoid (irregular waves, several
//! periods) is refused, not answered with a gyro-noise sigma it does not have. A yaw sway beyond
//! [`MAX_YAW_SWAY_RAD`] at the identification switches the model off ([`SwayPhase::Off`]): the
//! general filter then answers alone, and [`SwayAlignment::model_off`] says so.

pub mod search;

use super::AttitudeEstimate;
use super::fine::bank::Bank;
use super::fine::model::{self, FINE_STATES};
use super::fine::{
    Blank, Extension, FineConfig, FineCore, FineOutcome, FineRefusal, euler_jacobian,
};
use crate::coning::ConingSculling;
use crate::scalar::zeros;
use crate::strapdown::{kahan_add, small_rotation};
use crate::{ImuIncrement, InputError, Position, Scalar, attitude};
use nalgebra::{Matrix3, Quaternion, SMatrix, SVector, UnitQuaternion, Vector3};
use search::Search;
pub use search::{SinusoidFit, identify};

/// Offset of the mean roll and pitch [rad].
pub const MEAN: usize = FINE_STATES;
/// Offset of the roll phasor `(s, c)` [rad]; the pitch phasor follows at `OSC + 2`.
pub const OSC: usize = FINE_STATES + 2;
/// Offset of the roll and pitch sway frequency errors [rad/s].
pub const FREQ: usize = FINE_STATES + 6;
/// Number of states.
pub const SWAY_STATES: usize = FINE_STATES + 8;

/// Largest yaw sway the model is applied to [rad] (0.5 deg). The model's heading 1-sigma was
/// 4 to 12 times too small on the alignment family's members with a yaw sway of 0.6 to 1.4 deg
/// and roll sway of several degrees (an effect of the yaw sway on the drift that the model
/// does not describe; `nav align-bench family --ablate yaw` removes it). A yaw sway beyond
/// this envelope at the identification switches the model off ([`SwayPhase::Off`]): the
/// general filter answers alone, as `fine` would. One that grows beyond it after the model's
/// measurements started is refused ([`FineRefusal::YawSwayBeyondModel`]): they are in the
/// estimate.
pub const MAX_YAW_SWAY_RAD: f64 = 0.5 * core::f64::consts::PI / 180.0;

/// Largest mean normalised square of the roll and pitch innovations accepted.
pub const MAX_EULER_NIS: f64 = 3.0;

/// A fitted period is accepted once the window holds this many of it.
pub const IDENTIFY_PERIODS: f64 = 1.25;

/// Interval between identification attempts [s].
pub const IDENTIFY_RETRY_S: f64 = 4.0;

/// The open-loop attitude starts from the general filter's this long after its start [s]:
/// by then the tilt has converged from the coarse levelling's degree to a few 1e-5 rad, so the
/// second-order terms of the open-loop error (`2 phi phi'`, 1.3e-6 rad/s at 0.7 deg) stay
/// below the drift's noise.
pub const OPEN_LOOP_START_S: f64 = 2.0;

/// A roll or pitch innovation beyond this many sigma inflates that axis's phasor covariance
/// by what it exceeds (the sway's amplitude changed: the end of a rocking), counted in
/// [`SwayStatus::relocks`].
pub const RELOCK_SIGMAS: f64 = 3.0;

/// Settings of [`SwayAlignment`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwayConfig<T: Scalar> {
    /// The general filter's settings.
    pub fine: FineConfig<T>,
    /// 1-sigma of what the sway model leaves in the integrated roll and pitch [rad] (default
    /// 1e-5; it must stay well below the gyro noise's walk over a sway period, `N_g sqrt(P)`,
    /// or the drift is lost in it).
    pub euler_sigma_rad: T,
    /// Random walk of each phasor component [rad/sqrt(s)] (default 1e-6).
    pub amplitude_walk: T,
    /// Random walk of each sway frequency [rad/s/sqrt(s)] (default 1e-6).
    pub frequency_walk: T,
    /// First identification attempt after this much sway data [s] (default 14); while an
    /// axis's fitted period is not held [`IDENTIFY_PERIODS`] times by the window, another
    /// attempt follows every [`IDENTIFY_RETRY_S`], the last at [`Self::identify_s`].
    pub first_identify_s: T,
    /// Longest identification window [s] (default 25).
    pub identify_s: T,
    /// Roll/pitch measurement interval [s] (default 0.2: the 25 s window in
    /// [`search::BUFFER_LEN`] samples).
    pub sample_period_s: T,
    /// Shortest sway period searched [s] (default 2).
    pub min_period_s: T,
    /// Longest sway period searched [s] (default 20).
    pub max_period_s: T,
    /// Smallest sinusoid amplitude taken as sway [rad] (default 1e-4).
    pub min_amplitude_rad: T,
    /// Least-squares fits per filter step during the identification (default 16: a search of
    /// about 260 fits takes 1.7 s; each fit over the 128 samples costs some 500 000
    /// instructions on the MCU, whose `f64` is software, and the three filters of the bank
    /// search at once: some 25 M per filter step, more than a 168 MHz core's 0.1 s, so the
    /// method is not yet real-time there; 4 would fit, but the later identification cost one
    /// family member its 60 s heading, 4.4 sigma off).
    pub fits_per_step: u32,
}

impl<T: Scalar> Default for SwayConfig<T> {
    fn default() -> Self {
        Self {
            fine: FineConfig::default(),
            euler_sigma_rad: T::c(3e-6),
            amplitude_walk: T::c(3e-7),
            frequency_walk: T::c(1e-6),
            first_identify_s: T::c(14.0),
            identify_s: T::c(25.0),
            sample_period_s: T::c(0.2),
            min_period_s: T::c(2.0),
            max_period_s: T::c(20.0),
            min_amplitude_rad: T::c(1e-4),
            fits_per_step: 16,
        }
    }
}

impl<T: Scalar> SwayConfig<T> {
    /// Every non-finite or out-of-range value replaced by its default.
    pub fn sanitized(&self) -> Self {
        let d = Self::default();
        let pos = |v: T, dv: T| if v.finite() && v > T::zero() { v } else { dv };
        let nonneg = |v: T, dv: T| if v.finite() && v >= T::zero() { v } else { dv };
        let mut c = Self {
            fine: self.fine.sanitized(),
            euler_sigma_rad: pos(self.euler_sigma_rad, d.euler_sigma_rad),
            amplitude_walk: nonneg(self.amplitude_walk, d.amplitude_walk),
            frequency_walk: nonneg(self.frequency_walk, d.frequency_walk),
            first_identify_s: pos(self.first_identify_s, d.first_identify_s),
            identify_s: pos(self.identify_s, d.identify_s),
            sample_period_s: pos(self.sample_period_s, d.sample_period_s),
            min_period_s: pos(self.min_period_s, d.min_period_s),
            max_period_s: pos(self.max_period_s, d.max_period_s),
            min_amplitude_rad: pos(self.min_amplitude_rad, d.min_amplitude_rad),
            fits_per_step: self.fits_per_step.max(1),
        };
        if c.max_period_s <= c.min_period_s {
            c.min_period_s = d.min_period_s;
            c.max_period_s = d.max_period_s;
        }
        let longest = c.sample_period_s * T::c(search::BUFFER_LEN as f64 - 1.0);
        c.identify_s = c.identify_s.min(longest);
        c.first_identify_s = c.first_identify_s.min(c.identify_s);
        c
    }
}

/// Where the sway model is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SwayPhase {
    /// Keeping roll and pitch for the identification.
    Identifying,
    /// Fitting the periods.
    Searching,
    /// Sway identified, measurements running.
    Running,
    /// Yaw sway beyond [`MAX_YAW_SWAY_RAD`] at the identification: no sway measurement is
    /// applied, the general filter answers alone.
    Off,
}

/// The identified sway of one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwayAxis<T: Scalar> {
    /// Period [s] (NaN: no sway found on this axis).
    pub period_s: T,
    /// Amplitude [rad].
    pub amplitude_rad: T,
}

/// Counters and the identification result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwayStatus<T: Scalar> {
    /// Phase.
    pub phase: SwayPhase,
    /// Roll and pitch measurements applied.
    pub euler_updates: u32,
    /// Mean normalised square of their innovations (1 when the model holds).
    pub euler_mean_nis: f64,
    /// Innovations beyond [`RELOCK_SIGMAS`] that inflated a phasor covariance.
    pub relocks: u32,
    /// Identification attempts.
    pub attempts: u32,
    /// Roll sway.
    pub roll: SwayAxis<T>,
    /// Pitch sway.
    pub pitch: SwayAxis<T>,
    /// Amplitude of the yaw sway [rad]: half the range of the filter's yaw so far, or
    /// `sqrt(2)` times the RMS of the identification window's open-loop yaw about its
    /// least-squares line, whichever is larger.
    pub yaw_amplitude_rad: f64,
}

/// The sway model: the [`Extension`] of the general filter (module docs).
#[derive(Clone, Debug)]
pub struct SwayModel<T: Scalar> {
    config: SwayConfig<T>,
    search: Search<2>,
    /// The open-loop attitude (gyros and the vertical Earth rate only, no correction) whose
    /// roll and pitch are kept for the identification, and its summation carry; `None` before
    /// [`OPEN_LOOP_START_S`].
    open: bool,
    q_open: Quaternion<T>,
    q_open_carry: Quaternion<T>,
    coning: ConingSculling<T>,
    /// Vertical Earth rate in `c` [rad/s].
    omega_down: T,
    /// Yaw [rad] and pitch-independent part of each kept sample's attitude: its yaw, for the
    /// Euler Jacobian of the drift measurement.
    yaw: [f64; search::BUFFER_LEN],
    /// `sum C_b_c dt` [s] and time [s] over the identification window.
    sum_c: Matrix3<T>,
    sum_t: f64,
    /// Sway frequencies [rad/s]; `None`: no sway on that axis (or not identified yet).
    omega: [Option<T>; 2],
    /// Time of the last roll/pitch sample [s].
    last_sample_s: f64,
    nis_sum: f64,
    /// The filter's first yaw [rad] and the range of its yaw since, about it [rad].
    yaw_first: Option<f64>,
    yaw_range: (f64, f64),
    status: SwayStatus<T>,
}

impl<T: Scalar> SwayModel<T> {
    /// A model before its identification, the body at `q_b_c` at latitude `lat` [rad] (the
    /// attitude is replaced by the filter's at [`OPEN_LOOP_START_S`]).
    pub fn new(config: &SwayConfig<T>, q_b_c: &UnitQuaternion<T>, lat: T) -> Self {
        let mut model = Self::BLANK;
        model.init_in(config, q_b_c, lat);
        model
    }

    /// (Re)starts the model in place as [`Self::new`] does: every field through `&mut`, the
    /// identification buffers filled where they live.
    pub fn init_in(&mut self, config: &SwayConfig<T>, q_b_c: &UnitQuaternion<T>, lat: T) {
        let c = config.sanitized();
        let tau = core::f64::consts::TAU;
        let axis = SwayAxis {
            period_s: T::c(f64::NAN),
            amplitude_rad: T::zero(),
        };
        // Every field by name (a field added later must be started here too).
        let Self {
            config: config_in,
            search,
            open,
            q_open,
            q_open_carry,
            coning,
            omega_down,
            yaw,
            sum_c,
            sum_t,
            omega,
            last_sample_s,
            nis_sum,
            yaw_first,
            yaw_range,
            status,
        } = self;
        *config_in = c;
        search.init_in(tau / c.max_period_s.to_f64(), tau / c.min_period_s.to_f64());
        *open = false;
        *q_open = *q_b_c.quaternion();
        *q_open_carry = Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero());
        coning.reset();
        *omega_down = -T::c(crate::earth::OMEGA_IE) * lat.psin();
        yaw.fill(0.0);
        *sum_c = Matrix3::zeros();
        *sum_t = 0.0;
        *omega = [None; 2];
        *last_sample_s = f64::NEG_INFINITY;
        *nis_sum = 0.0;
        *yaw_first = None;
        *yaw_range = (0.0, 0.0);
        *status = SwayStatus {
            phase: SwayPhase::Identifying,
            euler_updates: 0,
            euler_mean_nis: 0.0,
            relocks: 0,
            attempts: 0,
            roll: axis,
            pitch: axis,
            yaw_amplitude_rad: 0.0,
        };
    }

    /// Counters and the identified sway.
    pub fn status(&self) -> SwayStatus<T> {
        self.status
    }

    /// The open-loop attitude.
    fn open_loop(&self) -> UnitQuaternion<T> {
        UnitQuaternion::new_normalize(self.q_open)
    }

    /// Every axis's fit is a still axis or holds [`IDENTIFY_PERIODS`] periods in the window.
    fn resolved(&self) -> bool {
        let window = self.search.window();
        (0..2).all(|axis| {
            self.search.result(axis).is_none_or(|f| {
                !(f.omega.is_finite() && f.amplitude() >= self.config.min_amplitude_rad.to_f64())
                    || window >= IDENTIFY_PERIODS * core::f64::consts::TAU / f.omega
            })
        })
    }

    /// The roll and pitch measurement rows [SI] of axis `axis` at attitude `q_b_c`.
    fn euler_row(q_b_c: &UnitQuaternion<T>, axis: usize) -> SVector<T, SWAY_STATES> {
        let jac = euler_jacobian(q_b_c);
        let mut h = SVector::<T, SWAY_STATES>::zeros();
        for k in 0..3 {
            h[super::fine::model::ATT + k] = -jac[(axis, k)];
        }
        h[MEAN + axis] = T::one();
        h[OSC + 2 * axis] = T::one();
        h
    }

    /// The identification window's drift as one measurement of the horizontal Earth rate and
    /// the gyro bias (module docs, **Identification**). The open-loop attitude (no horizontal
    /// Earth rate, no bias compensation) drifts at `phi' = -(e + C b) - omega x phi`
    /// ([`model`] with `omega_hat - omega = -e`); its roll and pitch, less the fitted
    /// sinusoids, are `mean - A_h(t) (phi_0 + s (t - t_m))` per sample, `A_h(t)` the horizontal
    /// columns of the roll and pitch rows of [`euler_jacobian`] at that sample's pitch and yaw
    /// (the yaw sway turns them: a single Euler-space trend would read 1e-5 rad of a 1e-3 rad
    /// tilt error through a 0.6 deg yaw sway as drift). The least-squares `s` (six unknowns:
    /// two means, `phi_0`, `s`) is then, with the filter's `e = e_hat - de`,
    /// `b = b_hat + b_res` and `phi = phi_core + delta` (`delta` the known rotation from the
    /// filter's attitude to the open-loop one, carried back to the window's middle):
    /// `s + (e_hat + C b_hat + omega x phi_known)_h = de_h - (C b_res)_h - ([omega x] phi)_h`.
    /// Noise per axis: the least-squares slope of the gyros' attitude random walk,
    /// `(6/5) N_g^2 / T` over the window `T` (as the inertial-frame heading's,
    /// [`super::inertial`]), times the fits' [`SinusoidFit::trend_inflation`] (the slope shares
    /// the window with a sinusoid of about its length).
    fn apply_drift(&mut self, core: &mut FineCore<T, SWAY_STATES>, now_s: f64) {
        let window = self.search.window();
        let n = self.search.len();
        if !(window > 0.0 && self.sum_t > 0.0 && n >= 8) {
            return;
        }
        let (times, t0) = (self.search.times(), self.search.t0());
        let t_mid = t0 + 0.5 * window;
        let min_amp = self.config.min_amplitude_rad.to_f64();
        let fits = [self.search.result(0), self.search.result(1)];
        let sinusoid = |axis: usize, tau: f64| {
            fits[axis]
                .filter(|f| f.omega.is_finite() && f.amplitude() >= min_amp)
                .map_or(0.0, |f| {
                    f.cos * libm::cos(f.omega * tau) + f.sin * libm::sin(f.omega * tau)
                })
        };
        // Normal equations of y_k = m - A_h(t_k) (phi_0 + s tau_k), unknowns (m_r, m_p, phi_0, s).
        let mut ata = SMatrix::<f64, 6, 6>::zeros();
        let mut atb = SVector::<f64, 6>::zeros();
        for (k, &t_k) in times.iter().enumerate().take(n) {
            let (tau0, tau) = (t_k - t0, t_k - t_mid);
            let pitch = self.search.values(1)[k];
            let q = attitude::from_euler(0.0, pitch, self.yaw[k]);
            let a = euler_jacobian(&q);
            for axis in 0..2 {
                let y = self.search.values(axis)[k] - sinusoid(axis, tau0);
                let mut row = SVector::<f64, 6>::zeros();
                row[axis] = 1.0;
                for j in 0..2 {
                    row[2 + j] = -a[(axis, j)];
                    row[4 + j] = -a[(axis, j)] * tau;
                }
                ata += row * row.transpose();
                atb += row * y;
            }
        }
        let Some(sol) = ata.cholesky().map(|c| c.solve(&atb)) else {
            return;
        };
        let slope = [sol[4], sol[5]];
        let inflation = fits
            .iter()
            .flatten()
            .map(|f| f.trend_inflation)
            .filter(|v| v.is_finite())
            .fold(1.0_f64, f64::max);
        let q_open = self.open_loop();
        let c_mean = self.sum_c / T::c(self.sum_t);
        let [e_n, e_e] = core.strapdown().e_h();
        let (b_hat, _) = core.strapdown().biases();
        let omega = core.strapdown().omega_ie_c();
        let delta = -attitude::rotation_vector_of(&(q_open * core.strapdown().q_b_c().inverse()));
        let drift = Vector3::new(e_n, e_e, T::zero()) + c_mean * b_hat;
        let phi_mid = delta + drift * T::c(now_s - t_mid);
        let known = drift + omega.cross(&phi_mid);
        let n_g = self.config.fine.noise.arw_rad_per_sqrt_s;
        let r = T::c(1.2 * inflation / window) * n_g * n_g;
        let wx = omega.cross_matrix();
        for (k, &s_k) in slope.iter().enumerate() {
            let mut h = SVector::<T, SWAY_STATES>::zeros();
            h[model::EARTH + k] = T::one();
            for j in 0..3 {
                h[model::GYRO_BIAS + j] = -c_mean[(k, j)];
                h[model::ATT + j] = -wx[(k, j)];
            }
            let z = T::c(s_k) + known[k];
            let innovation = z - core.predict(&h);
            core.update(&h, innovation, r, T::c(1e6));
        }
    }

    /// Widens the range of the filter's yaw seen so far with `q_b_c`'s (unwrapped about the
    /// first), and the status's yaw amplitude with half of it.
    fn track_yaw(&mut self, q_b_c: &UnitQuaternion<T>) {
        let (_, _, yaw) = attitude::euler(q_b_c);
        let yaw = yaw.to_f64();
        let first = *self.yaw_first.get_or_insert(yaw);
        let d = wrap_pi(yaw - first);
        self.yaw_range = (self.yaw_range.0.min(d), self.yaw_range.1.max(d));
        let half = 0.5 * (self.yaw_range.1 - self.yaw_range.0);
        self.status.yaw_amplitude_rad = self.status.yaw_amplitude_rad.max(half);
    }

    /// `sqrt(2)` times the RMS of the kept open-loop yaw about its least-squares line [rad].
    fn yaw_amplitude(&self) -> f64 {
        let n = self.search.len().min(search::BUFFER_LEN);
        if n < 3 {
            return 0.0;
        }
        let times = &self.search.times()[..n];
        // Unwrapped about the first sample.
        let y0 = self.yaw[0];
        let yaw = |k: usize| wrap_pi(self.yaw[k] - y0);
        let nf = n as f64;
        let (mut st, mut sy, mut stt, mut sty) = (0.0, 0.0, 0.0, 0.0);
        for (k, &t) in times.iter().enumerate() {
            let y = yaw(k);
            st += t;
            sy += y;
            stt += t * t;
            sty += t * y;
        }
        let den = nf * stt - st * st;
        if !(den > 0.0) {
            return 0.0;
        }
        let b = (nf * sty - st * sy) / den;
        let a = (sy - b * st) / nf;
        let ss: f64 = times
            .iter()
            .enumerate()
            .map(|(k, &t)| {
                let r = yaw(k) - a - b * t;
                r * r
            })
            .sum();
        libm::sqrt(2.0 * ss / nf)
    }

    /// Starts the states from the fits, at time `now_s` [s] and attitude `q_b_c`.
    fn start(
        &mut self,
        core: &mut FineCore<T, SWAY_STATES>,
        q_b_c: &UnitQuaternion<T>,
        now_s: f64,
    ) {
        self.status.yaw_amplitude_rad = self.status.yaw_amplitude_rad.max(self.yaw_amplitude());
        if !(self.status.yaw_amplitude_rad <= MAX_YAW_SWAY_RAD) {
            self.status.phase = SwayPhase::Off;
            return;
        }
        self.apply_drift(core, now_s);
        let (roll, pitch, _) = attitude::euler(q_b_c);
        let var = |s: f64| s * s;
        for axis in 0..2 {
            let fit = self.search.result(axis);
            let z = if axis == 0 { roll } else { pitch };
            let sway = fit.filter(|f| {
                f.omega.is_finite() && f.amplitude() >= self.config.min_amplitude_rad.to_f64()
            });
            // Mean: what the measurement says now, less the sway; its prior covers the tilt.
            let (s, c, r) = match sway {
                Some(f) => {
                    let a = f.omega * (now_s - self.search.t0());
                    let (sn, cs) = (libm::sin(a), libm::cos(a));
                    // y = cos_coef cos(a) + sin_coef sin(a): s = y, c = dy/da.
                    let s = f.cos * cs + f.sin * sn;
                    let c = -f.cos * sn + f.sin * cs;
                    (s, c, var(f.residual_rms.max(1e-5)) * 4.0)
                }
                None => (0.0, 0.0, 0.0),
            };
            core.init_states_si::<1>(
                MEAN + axis,
                &SVector::from([z - T::c(s)]),
                &SMatrix::from([[T::c(var(0.01) + r)]]),
            );
            let info = if axis == 0 {
                &mut self.status.roll
            } else {
                &mut self.status.pitch
            };
            match sway {
                Some(f) => {
                    self.omega[axis] = Some(T::c(f.omega));
                    info.period_s = T::c(core::f64::consts::TAU / f.omega);
                    info.amplitude_rad = T::c(f.amplitude());
                    let xs = SVector::<T, 2>::new(T::c(s), T::c(c));
                    let ps = SMatrix::<T, 2, 2>::from_diagonal_element(T::c(r));
                    core.init_states_si::<2>(OSC + 2 * axis, &xs, &ps);
                    core.init_states_si::<1>(
                        FREQ + axis,
                        &SVector::from([T::zero()]),
                        &SMatrix::from([[T::c(var(1e-3 * f.omega))]]),
                    );
                }
                None => self.omega[axis] = None,
            }
        }
        self.status.phase = SwayPhase::Running;
    }
}

impl<T: Scalar> Blank for SwayModel<T> {
    /// A model not started, all zero: the storage [`SwayModel::init_in`] starts in place.
    const BLANK: Self = Self {
        config: SwayConfig {
            fine: FineConfig::ZERO,
            euler_sigma_rad: T::ZERO,
            amplitude_walk: T::ZERO,
            frequency_walk: T::ZERO,
            first_identify_s: T::ZERO,
            identify_s: T::ZERO,
            sample_period_s: T::ZERO,
            min_period_s: T::ZERO,
            max_period_s: T::ZERO,
            min_amplitude_rad: T::ZERO,
            fits_per_step: 0,
        },
        search: Search::BLANK,
        open: false,
        q_open: Quaternion::from_vector(zeros()),
        q_open_carry: Quaternion::from_vector(zeros()),
        coning: ConingSculling::new(),
        omega_down: T::ZERO,
        yaw: [0.0; search::BUFFER_LEN],
        sum_c: zeros(),
        sum_t: 0.0,
        omega: [None; 2],
        last_sample_s: 0.0,
        nis_sum: 0.0,
        yaw_first: None,
        yaw_range: (0.0, 0.0),
        status: SwayStatus {
            phase: SwayPhase::Identifying,
            euler_updates: 0,
            euler_mean_nis: 0.0,
            relocks: 0,
            attempts: 0,
            roll: SwayAxis {
                period_s: T::ZERO,
                amplitude_rad: T::ZERO,
            },
            pitch: SwayAxis {
                period_s: T::ZERO,
                amplitude_rad: T::ZERO,
            },
            yaw_amplitude_rad: 0.0,
        },
    };
}

impl<T: Scalar> Extension<T, SWAY_STATES> for SwayModel<T> {
    fn transition(
        &mut self,
        x: &mut SVector<T, SWAY_STATES>,
        phi: &mut SMatrix<T, SWAY_STATES, SWAY_STATES>,
        q_c: &mut SVector<T, SWAY_STATES>,
        dt: T,
    ) -> bool {
        for axis in 0..2 {
            let Some(w) = self.omega[axis] else { continue };
            let (s, c, f) = (OSC + 2 * axis, OSC + 2 * axis + 1, FREQ + axis);
            let (sn, cs) = ((w * dt).psin(), (w * dt).pcos());
            let (s1, c1) = (cs * x[s] + sn * x[c], -sn * x[s] + cs * x[c]);
            phi[(s, s)] = cs;
            phi[(s, c)] = sn;
            phi[(c, s)] = -sn;
            phi[(c, c)] = cs;
            phi[(s, f)] = c1 * dt;
            phi[(c, f)] = -s1 * dt;
            x[s] = s1;
            x[c] = c1;
            let a = self.config.amplitude_walk * self.config.amplitude_walk;
            q_c[s] = a;
            q_c[c] = a;
            q_c[f] = self.config.frequency_walk * self.config.frequency_walk;
        }
        true
    }

    fn increment(&mut self, inc: &ImuIncrement<T>, c_b_c: &Matrix3<T>) {
        if matches!(self.status.phase, SwayPhase::Running | SwayPhase::Off) || !self.open {
            return;
        }
        // The open-loop attitude: q <- q(-zeta) q q(phi_b), zeta the vertical Earth rate only
        // [Savage, 7.1.2-14].
        let c = self
            .coning
            .compensate(&inc.delta_theta_ib_b, &inc.delta_v_ib_b, inc.dt, true);
        let zeta = Vector3::new(T::zero(), T::zero(), self.omega_down * inc.dt);
        let p = small_rotation(&c.phi_b);
        let z = small_rotation(&(-zeta));
        let qp = self.q_open * p;
        let delta = qp + z * self.q_open + z * qp;
        kahan_add(
            self.q_open.coords.as_mut_slice(),
            self.q_open_carry.coords.as_mut_slice(),
            delta.coords.as_slice(),
        );
        let n2 = self.q_open.norm_squared();
        if (n2 - T::one()).abs() > T::c(1e-4) {
            self.q_open /= n2.sqrt();
            self.q_open_carry = Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero());
        }
        if self.status.phase == SwayPhase::Identifying {
            self.sum_c += c_b_c * inc.dt;
            self.sum_t += inc.dt.to_f64();
        }
    }

    fn update(&mut self, core: &mut FineCore<T, SWAY_STATES>, elapsed_s: f64) {
        // At the filter step nearest each sample period.
        let half_step = 0.5 * core.config().update_period_s.to_f64();
        if elapsed_s + half_step < self.last_sample_s + self.config.sample_period_s.to_f64() {
            return;
        }
        self.last_sample_s = elapsed_s;
        let q = core.strapdown().q_b_c();
        self.track_yaw(&q);
        if !self.open {
            if elapsed_s + half_step < OPEN_LOOP_START_S {
                return;
            }
            // The open-loop attitude from the filter's, now that its tilt has converged.
            self.open = true;
            self.q_open = *q.quaternion();
            self.q_open_carry = Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero());
            self.coning.reset();
        }
        match self.status.phase {
            SwayPhase::Identifying => {
                let (roll, pitch, yaw) = attitude::euler(&self.open_loop());
                let k = self.search.len();
                let full = !self.search.push(elapsed_s, [roll.to_f64(), pitch.to_f64()]);
                if k < search::BUFFER_LEN {
                    self.yaw[k] = yaw.to_f64();
                }
                let first = if self.search.is_empty() {
                    elapsed_s
                } else {
                    self.search.t0()
                };
                let window = elapsed_s - first + 1e-9;
                let next_try = self.config.first_identify_s.to_f64()
                    + IDENTIFY_RETRY_S * f64::from(self.status.attempts);
                let last = self.config.identify_s.to_f64();
                if full || window >= next_try.min(last) {
                    self.search.start();
                    self.status.attempts += 1;
                    self.status.phase = SwayPhase::Searching;
                }
            }
            SwayPhase::Searching => {
                if self.search.run(self.config.fits_per_step) {
                    let window = self.search.window();
                    let last = window + 1e-9 >= self.config.identify_s.to_f64();
                    if self.resolved() || last || self.search.len() >= search::BUFFER_LEN {
                        self.start(core, &q, elapsed_s);
                    } else {
                        // A period too long for the window: keep buffering.
                        self.status.phase = SwayPhase::Identifying;
                        let (roll, pitch, yaw) = attitude::euler(&self.open_loop());
                        let k = self.search.len();
                        if self.search.push(elapsed_s, [roll.to_f64(), pitch.to_f64()]) {
                            self.yaw[k] = yaw.to_f64();
                        }
                    }
                }
            }
            SwayPhase::Off => {}
            SwayPhase::Running => {
                let (roll, pitch, _) = attitude::euler(&q);
                let r = self.config.euler_sigma_rad * self.config.euler_sigma_rad;
                for axis in 0..2 {
                    let h = Self::euler_row(&q, axis);
                    let z = if axis == 0 { roll } else { pitch };
                    let innovation = wrap_pi(z - core.predict(&h));
                    let mut s = core.innovation_variance(&h, r);
                    if self.omega[axis].is_some()
                        && innovation * innovation > T::c(RELOCK_SIGMAS * RELOCK_SIGMAS) * s
                    {
                        let extra = innovation * innovation - s;
                        core.inflate_si(OSC + 2 * axis, extra);
                        core.inflate_si(OSC + 2 * axis + 1, extra);
                        s += extra;
                        self.status.relocks += 1;
                    }
                    // Never gated: a gap would lose the drift; judged by the mean NIS.
                    core.update(&h, innovation, r, T::c(1e6));
                    self.nis_sum += (innovation * innovation / s).to_f64();
                    self.status.euler_updates += 1;
                }
                self.status.euler_mean_nis =
                    self.nis_sum / f64::from(self.status.euler_updates.max(1));
                // Frequency errors folded into the frequencies.
                for axis in 0..2 {
                    if let Some(w) = &mut self.omega[axis] {
                        *w += core.state_si(FREQ + axis);
                        core.set_state_si(FREQ + axis, T::zero());
                        let info = if axis == 0 {
                            &mut self.status.roll
                        } else {
                            &mut self.status.pitch
                        };
                        info.period_s = T::c(core::f64::consts::TAU) / *w;
                        let (s, c) = (
                            core.state_si(OSC + 2 * axis),
                            core.state_si(OSC + 2 * axis + 1),
                        );
                        info.amplitude_rad = (s * s + c * c).sqrt();
                    }
                }
            }
        }
    }
}

/// The base-motion-model fine alignment (module docs): the general filter's two-model bank
/// with the sway model in each.
#[derive(Clone, Debug)]
pub struct SwayAlignment<T: Scalar> {
    bank: Bank<T, SWAY_STATES, SwayModel<T>>,
}

impl<T: Scalar> SwayAlignment<T> {
    /// Starts as [`FineCore::new`] with the sway model.
    pub fn new(
        q_b_c: UnitQuaternion<T>,
        omega_eb_b: Vector3<T>,
        position: Position,
        config: SwayConfig<T>,
    ) -> Self {
        let mut sway = Self::BLANK;
        sway.init_in(q_b_c, omega_eb_b, position, config);
        sway
    }

    /// (Re)starts in place as [`Self::new`] does ([`Bank::init_in`], [`SwayModel::init_in`]):
    /// no bank-sized temporary is built, so an MCU task can start it (some 30 KB in `f32`).
    pub fn init_in(
        &mut self,
        q_b_c: UnitQuaternion<T>,
        omega_eb_b: Vector3<T>,
        position: Position,
        config: SwayConfig<T>,
    ) {
        let config = config.sanitized();
        let lat = position.lat::<T>();
        self.bank
            .init_in(q_b_c, omega_eb_b, position, config.fine, |model| {
                model.init_in(&config, &q_b_c, lat)
            });
    }

    /// Adds one increment.
    pub fn add(&mut self, inc: &ImuIncrement<T>) -> Result<(), InputError> {
        self.bank.add(inc)
    }

    /// The current attitude estimate.
    pub fn estimate(&self) -> AttitudeEstimate<T> {
        self.bank.estimate()
    }

    /// The best filter's sway status.
    pub fn status(&self) -> SwayStatus<T> {
        self.bank.best().1.status()
    }

    /// The filters (for inspection).
    pub fn bank(&self) -> &Bank<T, SWAY_STATES, SwayModel<T>> {
        &self.bank
    }

    /// The yaw sway amplitude [rad] when it switched the model off ([`SwayPhase::Off`]): the
    /// result is then the general filter's.
    pub fn model_off(&self) -> Option<f64> {
        let status = self.status();
        (status.phase == SwayPhase::Off).then_some(status.yaw_amplitude_rad)
    }

    /// Whether any filter still applies its sway model (or has yet to decide): once none does,
    /// the bank is the general one and need not be run (no weights computed: cheap per sample).
    pub fn model_in_use(&self) -> bool {
        self.bank
            .members()
            .1
            .iter()
            .any(|e| e.status().phase != SwayPhase::Off)
    }

    /// The result, or why there is none: the general filter's refusals, and a sway model that
    /// does not hold (roll/pitch innovations beyond [`MAX_EULER_NIS`], a yaw sway grown beyond
    /// [`MAX_YAW_SWAY_RAD`] after its measurements started). With the model off
    /// ([`Self::model_off`]), the general filter's result.
    pub fn outcome(&self) -> Result<FineOutcome<T>, FineRefusal> {
        let status = self.status();
        if status.phase == SwayPhase::Off {
            return self.bank.outcome();
        }
        if !(status.yaw_amplitude_rad <= MAX_YAW_SWAY_RAD) {
            return Err(FineRefusal::YawSwayBeyondModel {
                amplitude_rad: status.yaw_amplitude_rad,
            });
        }
        if status.euler_mean_nis > MAX_EULER_NIS {
            return Err(FineRefusal::MotionNotModelled {
                mean_nis: status.euler_mean_nis,
            });
        }
        self.bank.outcome()
    }
}

impl<T: Scalar> Blank for SwayAlignment<T> {
    /// Filters that have not started (the [`Bank`]'s and [`SwayModel`]'s blanks): the storage
    /// [`SwayAlignment::init_in`] starts in place.
    const BLANK: Self = Self { bank: Bank::BLANK };
}

/// `a` [rad] wrapped to (-pi, pi].
fn wrap_pi<T: Scalar>(a: T) -> T {
    let pi = T::c(core::f64::consts::PI);
    if a > pi {
        a - pi - pi
    } else if a <= -pi {
        a + pi + pi
    } else {
        a
    }
}
