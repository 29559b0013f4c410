//! Bridging a gap in the IMU data.
//!
//! Time that no navigated sample covers (samples lost on the bus, or skipped as unusable) is a
//! hole in the integration. Left out, the solution stands still while the vehicle moves on (a
//! car at 20 m/s: 20 m per lost second), and a filter whose covariance does not know it then
//! refuses the true fixes. So the lost time is integrated with the mean of the rates measured
//! either side of it (the rates interpolated linearly across the gap), in steps of at most
//! [`MAX_STEP_S`] ([`ImuGap::step`]), and the navigation filter widens its covariance for what
//! the interpolation cannot know ([`GapDynamics`]). A gap longer than [`MAX_BRIDGED_S`] is not
//! integrated: over seconds the interpolation says nothing of the motion, and the solution is
//! lost ([`ImuGap::bridged`]: the filter then reports itself degraded,
//! [`FilterStatus::ImuLost`](crate::ins_filter::FilterStatus::ImuLost), from the first sample
//! after the gap). Its position is carried across the gap at the velocity before it, and the
//! filter's covariance takes [`GapDynamics`] over the whole gap at once
//! ([`crate::ins_filter::LostGap`]), so that the lost solution's 1-sigma still tells its error.
//! An aided run (the sequencer, [`crate::ins_filter::sequencer`], and the navigator's aided
//! phase, the firmware's, [`crate::navigator`]) re-aligns in motion on the GNSS fixes after
//! it and restarts the filter with the sensor errors it had estimated; without fixes it stays
//! degraded to the end of the run.
//!
//! **A clock that steps back.** A sample whose time is not after the last navigated one's is
//! out of order ([`GapDetector::out_of_order`]): its increment is real, but its time is not,
//! and the GNSS fixes are matched by time, so it is not navigated (the caller flags it). A
//! single late or repeated time tag costs that sample; a clock that stepped back for good
//! (a logger's clock reset, a timer that wrapped) costs every sample until its time passes
//! the last navigated one, and the time those samples covered, the sum of their measured
//! intervals, is lost time the clock cannot show: the next navigated sample's gap is at least
//! that ([`GapDetector::note`]), bridged or lost as any other. Navigating them under a clock
//! that runs behind would put the solution's rows out of time order and apply the fixes to
//! the wrong samples.
//!
//! The rule is the same in every run: [`GapDetector`] sees every navigated sample, in the
//! firmware's navigator and in the harness's sequencer alike.
//!
//! **Fixes outside the data.** A GNSS file none of whose fixes lies in the time the IMU data
//! cover ([`data_span_us`]) is refused by the firmware and the harness alike; it is on another
//! clock ([`on_another_clock`]) only when its fixes are far from the data.

use crate::{ImuIncrement, Scalar};
use nalgebra::Vector3;

/// Longest step of a bridge [s]: rates held over it integrate exactly, and 250 steps bridge
/// the longest gap (a few samples' time of the MCU's navigation task).
pub const MAX_STEP_S: f64 = 0.02;

/// Longest gap bridged [s]; a longer one is lost.
pub const MAX_BRIDGED_S: f64 = 5.0;

/// Time between two navigated samples that neither covers, below which nothing is lost: half
/// the later sample's interval (time-tag jitter), and at least this [s].
const TOLERANCE_S: f64 = 1e-4;

/// Lost time before a navigated sample, and the rates either side of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuGap<T: Scalar> {
    /// Time no sample covers [s].
    pub lost_s: T,
    /// Body rate of the last sample before the gap [rad/s].
    pub omega_before_ib_b: Vector3<T>,
    /// Body rate of the first sample after it [rad/s].
    pub omega_after_ib_b: Vector3<T>,
    /// Specific force before the gap [m/s^2].
    pub f_before_ib_b: Vector3<T>,
    /// Specific force after it [m/s^2].
    pub f_after_ib_b: Vector3<T>,
}

impl<T: Scalar> ImuGap<T> {
    /// True when the gap is short enough to be integrated ([`MAX_BRIDGED_S`]).
    pub fn bridged(&self) -> bool {
        self.lost_s <= T::c(MAX_BRIDGED_S + TOLERANCE_S)
    }

    /// The bridge as `n` equal steps: `(n, step)`, each step the mean rates over
    /// `lost_s / n <=` [`MAX_STEP_S`]; `n = 0` when the gap is not bridged.
    pub fn step(&self) -> (u32, ImuIncrement<T>) {
        let n = if self.bridged() {
            // lost_s <= MAX_BRIDGED_S: a small count (core has no f64::ceil).
            let q = self.lost_s.to_f64() / MAX_STEP_S;
            let n = q as u32;
            if f64::from(n) < q { n + 1 } else { n.max(1) }
        } else {
            0
        };
        let half = T::c(0.5);
        let dt = self.lost_s / T::c(f64::from(n.max(1)));
        let omega = (self.omega_before_ib_b + self.omega_after_ib_b) * half;
        let f = (self.f_before_ib_b + self.f_after_ib_b) * half;
        (
            n,
            ImuIncrement {
                delta_theta_ib_b: omega * dt,
                delta_v_ib_b: f * dt,
                dt,
            },
        )
    }

    /// Integrates the bridge ([`Self::step`]) with `step_once`, stopping at its first refusal
    /// (the mean of two checked samples' rates passes the same limits: not expected).
    pub fn integrate<E>(&self, mut step_once: impl FnMut(&ImuIncrement<T>) -> Result<(), E>) {
        let (n, step) = self.step();
        for _ in 0..n {
            if step_once(&step).is_err() {
                break;
            }
        }
    }
}

/// The motion a bridge cannot know: the body rate and specific force are taken to differ from
/// the interpolated ones by a random constant over the gap, whose 1-sigma is the vehicle's
/// (`omega_sigma_rad_s`, `f_sigma_mps2`, every axis), plus what a step between the two sides at
/// an unknown time inside the gap leaves (`|after - before| / sqrt(12)`: the step's time
/// uniform over the gap), plus a turn that starts and ends unseen inside the gap: a rate
/// pulse rising and falling at `omega_accel_rad_s2` peaks at `alpha L / 2` and turns the body
/// by `alpha L^2 / 4`, a mean rate of `alpha L / 4` (a car's turn at 21 deg/s whose peak fell
/// in a 4.9 s gap turned it by 38 deg that both edges missed). Over a gap of `L` seconds the
/// attitude is then off by `sigma_omega L` and the velocity by `sigma_f L` (1-sigma per axis),
/// which the filter adds to its covariance as extra driving noise over the propagation
/// interval that holds the gap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GapDynamics<T: Scalar> {
    /// Body rate the interpolation may miss, 1-sigma per axis [rad/s].
    pub omega_sigma_rad_s: T,
    /// Specific force the interpolation may miss, 1-sigma per axis [m/s^2].
    pub f_sigma_mps2: T,
    /// Angular acceleration of a turn the gap may hide, 1-sigma [rad/s^2].
    pub omega_accel_rad_s2: T,
}

impl<T: Scalar> Default for GapDynamics<T> {
    /// 1 deg/s, 0.5 m/s^2 and 5 deg/s^2: a land vehicle's or an aircraft's manoeuvre
    /// starting and ending unseen within a gap (a change seen across it is the `|after -
    /// before|` term). `nav bench gaps` measures the errors against this: on the simulated
    /// land vehicle's gentle stretches they are a fraction of it.
    fn default() -> Self {
        Self {
            omega_sigma_rad_s: T::c(1.0f64.to_radians()),
            f_sigma_mps2: T::c(0.5),
            omega_accel_rad_s2: T::c(5.0f64.to_radians()),
        }
    }
}

/// Largest attitude variance a gap adds per axis [rad^2]: 1 rad of doubt, beyond which the
/// linear error model says nothing more (a lost gap's, [`ImuGap::bridged`]; a bridged gap
/// stays below it, about 0.55 rad at [`MAX_BRIDGED_S`]).
pub const MAX_ATTITUDE_VAR_RAD2: f64 = 1.0;

impl<T: Scalar> GapDynamics<T> {
    /// The variances a gap leaves per axis: attitude [rad^2], at most
    /// [`MAX_ATTITUDE_VAR_RAD2`], and velocity [m^2/s^2] (doc above), over the whole gap,
    /// bridged or lost.
    pub fn variances(&self, gap: &ImuGap<T>) -> (T, T) {
        let l = gap.lost_s;
        let l2 = l * l;
        let twelfth = T::c(1.0 / 12.0);
        let d_omega = (gap.omega_after_ib_b - gap.omega_before_ib_b).norm_squared();
        let d_f = (gap.f_after_ib_b - gap.f_before_ib_b).norm_squared();
        let turn = self.omega_accel_rad_s2 * l * T::c(0.25);
        let omega2 =
            self.omega_sigma_rad_s * self.omega_sigma_rad_s + d_omega * twelfth + turn * turn;
        let f2 = self.f_sigma_mps2 * self.f_sigma_mps2 + d_f * twelfth;
        ((omega2 * l2).min(T::c(MAX_ATTITUDE_VAR_RAD2)), f2 * l2)
    }
}

/// Gaps found while navigating.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GapCounters {
    /// Gaps bridged.
    pub bridged: u32,
    /// Gaps too long to bridge ([`MAX_BRIDGED_S`]).
    pub lost: u32,
    /// Time the gaps spanned, bridged or not [us].
    pub time_us: u64,
    /// The longest [us].
    pub longest_us: u64,
}

impl GapCounters {
    /// Counts `gap`; returns its length [us] (in the run's precision: an hour's gap in f32 is
    /// within a millisecond).
    pub fn add<T: Scalar>(&mut self, gap: &ImuGap<T>) -> u64 {
        if gap.bridged() {
            self.bridged = self.bridged.saturating_add(1);
        } else {
            self.lost = self.lost.saturating_add(1);
        }
        let us = (gap.lost_s.to_f64() * 1e6) as u64;
        self.time_us = self.time_us.saturating_add(us);
        self.longest_us = self.longest_us.max(us);
        us
    }
}

/// Finds the time lost before each navigated sample (module docs). Per sample it keeps the
/// sample's time and increment; the rates are taken only when time was lost (the MCU's
/// navigation task pays a subtraction and a comparison, in the run's precision).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GapDetector<T: Scalar> {
    last: Option<(u64, ImuIncrement<T>)>,
    /// Intervals of the out-of-order samples since the last navigated one [s].
    skipped_s: T,
}

impl<T: Scalar> GapDetector<T> {
    /// Nothing seen yet.
    pub fn new() -> Self {
        Self {
            last: None,
            skipped_s: T::zero(),
        }
    }

    /// True when a sample ending at `t_us` [us] is out of order: its time is not after the
    /// last navigated sample's (module docs). It is then not to be navigated, and its
    /// interval `dt` [s] counts as time lost before the next navigated sample.
    pub fn out_of_order(&mut self, t_us: u64, dt: T) -> bool {
        let behind = self.last.is_some_and(|(last_us, _)| t_us <= last_us);
        if behind {
            self.skipped_s += dt;
        }
        behind
    }

    /// A navigated sample ending at `t_us` [us] with the increment `inc` (as navigated): the
    /// gap before it, if time was lost since the previous one: the time its tags show, or the
    /// intervals of the out-of-order samples skipped since, whichever is longer.
    pub fn note(&mut self, t_us: u64, inc: &ImuIncrement<T>) -> Option<ImuGap<T>> {
        let skipped_s = core::mem::replace(&mut self.skipped_s, T::zero());
        let (prev_us, before) = self.last.replace((t_us, *inc))?;
        // The count of microseconds is exact in f32 up to 2^24 (16 s), within 1 us beyond.
        let span_s = T::of_f32(t_us.saturating_sub(prev_us) as f32) * T::c(1e-6);
        let lost_s = (span_s - inc.dt).max(skipped_s);
        let tolerance_s = (inc.dt * T::c(0.5)).max(T::c(TOLERANCE_S));
        (lost_s > tolerance_s).then(|| ImuGap {
            lost_s,
            omega_before_ib_b: before.delta_theta_ib_b / before.dt,
            omega_after_ib_b: inc.delta_theta_ib_b / inc.dt,
            f_before_ib_b: before.delta_v_ib_b / before.dt,
            f_after_ib_b: inc.delta_v_ib_b / inc.dt,
        })
    }
}

/// The time the IMU data cover [us]: from the start of the first sample's interval (its end
/// `first_end_us` [us] less its interval `first_dt_s` [s], at most [`InputLimits::max_dt`]'s
/// default) to the end of the last, `last_end_us` [us]. A fix at the start of the first
/// interval lies in the data (one at the recording's first tick, 2.5 ms before the first
/// sample's end, was said to be on another clock).
///
/// [`InputLimits::max_dt`]: crate::increment::InputLimits::max_dt
pub fn data_span_us(first_end_us: u64, first_dt_s: f64, last_end_us: u64) -> (u64, u64) {
    let max_dt_s = crate::increment::InputLimits::<f64>::default().max_dt;
    let dt_s = if first_dt_s.is_finite() {
        first_dt_s.clamp(0.0, max_dt_s)
    } else {
        0.0
    };
    (
        // Rounded (core has no f64::round): an f32 interval of 2.5 ms is 2499.99 us.
        first_end_us.saturating_sub((dt_s * 1e6 + 0.5) as u64),
        last_end_us,
    )
}

/// Whether GNSS fixes spanning `fixes_us` (first and last [us]), none of them within the IMU
/// data's span `data_us` ([`data_span_us`]), look like time tags on another clock (GNSS
/// seconds of week against a recording that starts at 0, milliseconds for seconds) rather
/// than a receiver that missed the data by little: the nearest fix is further from the data
/// than the data's own length. Fixes on both sides of the data are on its clock.
pub fn on_another_clock(fixes_us: (u64, u64), data_us: (u64, u64)) -> bool {
    let (a, b) = data_us;
    let distance_us = if fixes_us.1 < a {
        a - fixes_us.1
    } else {
        fixes_us.0.saturating_sub(b)
    };
    distance_us > b.saturating_sub(a)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inc(omega: [f64; 3], f: [f64; 3], dt: f64) -> ImuIncrement<f64> {
        ImuIncrement {
            delta_theta_ib_b: Vector3::from(omega) * dt,
            delta_v_ib_b: Vector3::from(f) * dt,
            dt,
        }
    }

    #[test]
    fn a_sample_on_time_or_jittered_loses_nothing() {
        let mut d = GapDetector::new();
        assert_eq!(d.note(1_000_000, &inc([0.0; 3], [0.0; 3], 0.0025)), None);
        assert_eq!(d.note(1_002_500, &inc([0.0; 3], [0.0; 3], 0.0025)), None);
        // A late tag by 40 % of an interval is jitter.
        assert_eq!(d.note(1_006_000, &inc([0.0; 3], [0.0; 3], 0.0025)), None);
    }

    #[test]
    fn a_lost_second_is_found_with_the_rates_either_side() {
        let mut d = GapDetector::new();
        d.note(1_000_000, &inc([0.1, 0.0, 0.0], [0.0, 0.0, -9.8], 0.0025));
        let g = d
            .note(2_002_500, &inc([0.3, 0.0, 0.0], [1.0, 0.0, -9.8], 0.0025))
            .unwrap();
        assert!((g.lost_s - 1.0).abs() < 1e-9);
        assert!(g.bridged());
        let (n, step) = g.step();
        assert_eq!(n, 50);
        assert!((step.dt * f64::from(n) - 1.0).abs() < 1e-12);
        // The mean rates: 0.2 rad/s and 0.5 m/s^2 forward.
        assert!((step.delta_theta_ib_b.x / step.dt - 0.2).abs() < 1e-12);
        assert!((step.delta_v_ib_b.x / step.dt - 0.5).abs() < 1e-12);
        // The step between the sides widens the variances beyond the vehicle's own.
        let dynamics = GapDynamics::<f64>::default();
        let (att, vel) = dynamics.variances(&g);
        let (s_omega, s_f) = (dynamics.omega_sigma_rad_s, dynamics.f_sigma_mps2);
        let turn = dynamics.omega_accel_rad_s2 * 0.25;
        assert!((att - (s_omega * s_omega + 0.04 / 12.0 + turn * turn)).abs() < 1e-12);
        assert!((vel - (s_f * s_f + 1.0 / 12.0)).abs() < 1e-12);
    }

    #[test]
    fn a_gap_beyond_the_limit_is_not_bridged() {
        let mut d = GapDetector::new();
        d.note(0, &inc([0.0; 3], [0.0; 3], 0.01));
        let g = d.note(6_000_000, &inc([0.0; 3], [0.0; 3], 0.01)).unwrap();
        assert!(!g.bridged());
        assert_eq!(g.step().0, 0);
        // Time going backwards is not a gap (the source flags it).
        assert_eq!(d.note(1_000_000, &inc([0.0; 3], [0.0; 3], 0.01)), None);
        // 5 s are bridged, in steps of at most 20 ms.
        d.note(0, &inc([0.0; 3], [0.0; 3], 0.01));
        let g = d.note(5_010_000, &inc([0.0; 3], [0.0; 3], 0.01)).unwrap();
        assert!(g.bridged());
        assert_eq!(g.step().0, 250);
    }

    #[test]
    fn fixes_far_from_the_data_are_on_another_clock() {
        // 60 s of 400 Hz data from 0: a fix at 0 is in it; one 1 s before is near it.
        let data = data_span_us(2500, f64::from(0.0025_f32), 60_000_000);
        assert_eq!(data, (0, 60_000_000));
        assert_eq!(data_span_us(2500, f64::NAN, 9).0, 2500);
        assert_eq!(data_span_us(20_000_000, 1e9, 9).0, 19_900_000);
        assert!(!on_another_clock((0, 0), (2500, 60_000_000)));
        assert!(!on_another_clock((61_000_000, 70_000_000), data));
        // GNSS seconds of week against a recording from 0; fixes on both sides of it.
        assert!(on_another_clock((345_600_000_000, 345_660_000_000), data));
        assert!(on_another_clock((0, 1_000), (5_000_000, 6_000_000)));
        assert!(!on_another_clock((0, 10_000_000), (4_000_000, 4_500_000)));
    }

    #[test]
    fn a_sample_not_after_the_last_navigated_one_is_out_of_order() {
        let mut d = GapDetector::new();
        let still = inc([0.0; 3], [0.0; 3], 0.0025);
        // Nothing navigated yet: nothing is out of order.
        assert!(!d.out_of_order(1_000_000, 0.0025));
        assert_eq!(d.note(1_000_000, &still), None);
        // A repeated and an earlier time tag.
        assert!(d.out_of_order(1_000_000, 0.0025));
        assert!(d.out_of_order(999_000, 0.0025));
        assert!(!d.out_of_order(1_002_500, 0.0025));
    }

    #[test]
    fn a_clock_that_stepped_back_loses_the_time_its_samples_covered() {
        let mut d = GapDetector::new();
        let still = inc([0.0; 3], [0.0; 3], 0.0025);
        d.note(50_000_000, &still);
        // The clock steps back by 10 s: its samples until it passes 50 s are out of order,
        // 10 s of data the clock does not show.
        let mut skipped = 0;
        let mut t_us = 40_002_500;
        while d.out_of_order(t_us, 0.0025) {
            skipped += 1;
            t_us += 2_500;
        }
        assert_eq!((skipped, t_us), (4_000, 50_002_500));
        // The first sample after it is on time by its tag, and 10 s are lost: not bridged.
        let g = d.note(t_us, &still).unwrap();
        assert!((g.lost_s - 10.0).abs() < 1e-9, "{}", g.lost_s);
        assert!(!g.bridged());
        // The skipped time is counted once.
        assert_eq!(d.note(t_us + 2_500, &still), None);
        // One late tag costs its own interval, bridged as a gap of one sample.
        assert!(d.out_of_order(t_us, 0.0025));
        let g = d.note(t_us + 5_000, &still).unwrap();
        assert!((g.lost_s - 0.0025).abs() < 1e-9 && g.bridged());
    }
}
