//! The order of an aided run, shared by the firmware and the harness: IMU samples and GNSS
//! fixes arrive on their own clocks; a fix is held until the first sample at or after its time
//! tag and applied there with its lag ([`super::AidedIns::aid_position`]); before the filter
//! runs, the fixes and samples feed the in-motion start ([`super::motion`]) when the run starts
//! that way.

use super::aiding::{AidResult, GnssPosition, GnssVelocity};
use super::motion::{MotionAlign, MotionAlignConfig, MotionStart};
use super::{AidedIns, FilterConfig, FilterError, InitialSigma, SensorErrors};
use crate::gap::{GapCounters, GapDetector};
use crate::{ImuIncrement, InputError, NavState, Scalar};
use nalgebra::Vector3;

/// One GNSS fix with its receiver time tag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFixInput<T: Scalar> {
    /// Time of the fix on the IMU's clock [us].
    pub t_us: u64,
    /// The antenna's position.
    pub position: GnssPosition<T>,
    /// The antenna's velocity, when the receiver gives one.
    pub velocity: Option<GnssVelocity<T>>,
}

/// Fixes held at once (1-10 Hz fixes against 100-1000 Hz samples need one).
const QUEUE: usize = 4;

/// Largest lag between a fix and the sample that applies it [us]; older fixes are late.
pub const MAX_LAG_US: u64 = 100_000;

/// How the run starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Start<T: Scalar> {
    /// A known state (an alignment's, or a user's: KF-GINS's `initpos`, `initvel`,
    /// `initatt`) with its 1-sigma and the sensor errors known at the start.
    Given {
        /// The state at the first sample.
        state: NavState<T>,
        /// Sensor errors compensated from the start.
        sensors: SensorErrors<T>,
        /// The 1-sigma of everything.
        sigma: InitialSigma<T>,
    },
    /// In motion from GNSS.
    Motion(MotionAlignConfig<T>),
}

/// What the sequencer did with one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// Waiting for the in-motion start (level and heading).
    Starting,
    /// The filter runs.
    Navigating,
}

/// Fix-level counters of the sequencer (the filter counts its updates itself).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FixCounters {
    /// Fixes received.
    pub received: u32,
    /// Refused: not later than the previous fix.
    pub out_of_order: u32,
    /// Dropped from a full queue, the oldest first (more fixes due than it holds before the
    /// next sample: fixes denser than the samples, or a gap in the IMU data; the oldest would
    /// be late first).
    pub queue_full: u32,
    /// Refused: applied later than [`MAX_LAG_US`] after their time.
    pub late: u32,
    /// Used by the in-motion start.
    pub for_start: u32,
}

/// Fixes held until the first sample at or after their time tag (the rule of the module
/// docs), oldest first; the one implementation of that rule, for the [`Sequencer`] and the
/// navigator's aided phase ([`crate::navigator`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixQueue<T: Scalar> {
    queue: [Option<GnssFixInput<T>>; QUEUE],
    last_fix_us: Option<u64>,
    counters: FixCounters,
}

impl<T: Scalar> Default for FixQueue<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Scalar> FixQueue<T> {
    /// An empty queue.
    pub const fn new() -> Self {
        Self {
            queue: [None; QUEUE],
            last_fix_us: None,
            counters: FixCounters {
                received: 0,
                out_of_order: 0,
                queue_full: 0,
                late: 0,
                for_start: 0,
            },
        }
    }

    /// The fix counters.
    pub fn counters(&self) -> &FixCounters {
        &self.counters
    }

    /// Holds a fix until its sample. Fixes must come in time order; a fix not later than the
    /// previous one is refused (counted in [`FixCounters::out_of_order`]) and `false`
    /// returned. A full queue drops its oldest fix for the new one
    /// ([`FixCounters::queue_full`]).
    pub fn push(&mut self, fix: GnssFixInput<T>) -> bool {
        self.counters.received = self.counters.received.saturating_add(1);
        if self.last_fix_us.is_some_and(|t| fix.t_us <= t) {
            self.counters.out_of_order = self.counters.out_of_order.saturating_add(1);
            return false;
        }
        let slot = match self.queue.iter().position(|s| s.is_none()) {
            Some(i) => i,
            None => {
                self.counters.queue_full = self.counters.queue_full.saturating_add(1);
                // Full: every slot holds a fix; the oldest goes.
                self.queue
                    .iter()
                    .enumerate()
                    .min_by_key(|(_, f)| f.map_or(0, |f| f.t_us))
                    .map_or(0, |(i, _)| i)
            }
        };
        self.queue[slot] = Some(fix);
        self.last_fix_us = Some(fix.t_us);
        true
    }

    /// The oldest fix due at the sample ending at `t_us` [us] (its time tag at or before it),
    /// with its lag `t_us - t_fix` [s]; a fix due more than [`MAX_LAG_US`] ago is dropped and
    /// counted in [`FixCounters::late`]. `None`: no fix is due.
    pub fn pop_due(&mut self, t_us: u64) -> Option<(GnssFixInput<T>, T)> {
        loop {
            let i = self
                .queue
                .iter()
                .enumerate()
                .filter_map(|(i, f)| f.filter(|f| f.t_us <= t_us).map(|f| (i, f.t_us)))
                .min_by_key(|(_, t)| *t)
                .map(|(i, _)| i)?;
            let fix = self.queue[i].take()?;
            let lag_us = t_us - fix.t_us;
            if lag_us > MAX_LAG_US {
                self.counters.late = self.counters.late.saturating_add(1);
                continue;
            }
            return Some((fix, T::c(lag_us as f64 * 1e-6)));
        }
    }
}

/// A fix applied at a sample: its time [us], the position update's result and the velocity
/// update's, when the fix had a velocity.
pub type FixResult<T> = (u64, AidResult<T>, Option<AidResult<T>>);

/// The aided run's sequencer (module docs).
#[derive(Clone, Debug)]
pub struct Sequencer<T: Scalar> {
    config: FilterConfig<T>,
    start: Start<T>,
    motion: Option<MotionAlign<T>>,
    ins: Option<AidedIns<T>>,
    fixes: FixQueue<T>,
    gaps: GapDetector<T>,
    gap_counters: GapCounters,
    /// Results of the fixes applied at the last sample (position, velocity).
    last_results: [Option<FixResult<T>>; QUEUE],
}

impl<T: Scalar> Sequencer<T> {
    /// A run with `config` starting as `start` (a given start is checked at once).
    pub fn new(config: FilterConfig<T>, start: Start<T>) -> Result<Self, FilterError> {
        let (motion, ins) = match start {
            Start::Given {
                state,
                sensors,
                sigma,
            } => (None, Some(AidedIns::new(state, sensors, &sigma, config)?)),
            Start::Motion(m) => {
                // Checked now, not at the start in motion.
                let probe = InitialSigma {
                    position_ned_m: Vector3::repeat(T::one()),
                    velocity_ned_m_s: Vector3::repeat(T::one()),
                    attitude_rad: Vector3::repeat(T::one()),
                    gyro_bias_rad_s: Vector3::repeat(config.noise.gyro_bias_rad_s),
                    accel_bias_mps2: Vector3::repeat(config.noise.accel_bias_mps2),
                    gyro_scale: Vector3::repeat(config.noise.gyro_scale),
                    accel_scale: Vector3::repeat(config.noise.accel_scale),
                };
                let state = NavState::at_rest(
                    crate::Position::from_radians(0.0, 0.0, 0.0),
                    nalgebra::UnitQuaternion::identity(),
                );
                AidedIns::new(state, SensorErrors::default(), &probe, config)?;
                (
                    Some(MotionAlign::new(m, config.antenna_lever_arm_b_m)),
                    None,
                )
            }
        };
        Ok(Self {
            config,
            start,
            motion,
            ins,
            fixes: FixQueue::new(),
            gaps: GapDetector::new(),
            gap_counters: GapCounters::default(),
            last_results: [None; QUEUE],
        })
    }

    /// The filter, once it runs.
    pub fn filter(&self) -> Option<&AidedIns<T>> {
        self.ins.as_ref()
    }

    /// How the run started.
    pub fn start(&self) -> &Start<T> {
        &self.start
    }

    /// The phase.
    pub fn phase(&self) -> Phase {
        if self.ins.is_some() {
            Phase::Navigating
        } else {
            Phase::Starting
        }
    }

    /// The fix counters.
    pub fn fix_counters(&self) -> &FixCounters {
        self.fixes.counters()
    }

    /// The gaps in the IMU data found while the filter ran ([`crate::gap`]).
    pub fn gap_counters(&self) -> &GapCounters {
        &self.gap_counters
    }

    /// The fixes applied at the last sample: their time [us] and the position and velocity
    /// results.
    pub fn last_results(&self) -> impl Iterator<Item = &FixResult<T>> + '_ {
        self.last_results.iter().flatten()
    }

    /// Hands over a fix; it is applied at the first sample at or after its time. Fixes must
    /// come in time order; a fix older than the previous one is refused (counted) and `false`
    /// returned; a full queue drops its oldest ([`FixQueue::push`]).
    pub fn push_fix(&mut self, fix: GnssFixInput<T>) -> bool {
        self.fixes.push(fix)
    }

    /// Restarts the two-sample history after a gap in the data.
    pub fn restart_increments(&mut self) {
        if let Some(ins) = &mut self.ins {
            ins.restart_increments();
        }
    }

    /// One IMU sample ending at `t_us` [us]: the time lost since the previous one bridged
    /// ([`crate::gap`]), the sample integrated (or given to the in-motion start), then every
    /// held fix due at it applied. A refused increment is returned as the error (the fixes
    /// wait for the next sample).
    pub fn on_sample(&mut self, t_us: u64, inc: &ImuIncrement<T>) -> Result<Phase, InputError> {
        self.last_results = [None; QUEUE];
        inc.check(&self.config.mechanization.limits)?;
        let gap = self.gaps.note(t_us, inc);
        match &mut self.ins {
            Some(ins) => {
                if let Some(gap) = &gap {
                    ins.bridge(gap);
                    self.gap_counters.add(gap);
                }
                ins.step(inc)?;
            }
            None => {
                if let Some(m) = &mut self.motion {
                    m.add_imu(inc);
                }
            }
        }
        // Due fixes, oldest first.
        let mut k = 0;
        while let Some((fix, lag)) = self.fixes.pop_due(t_us) {
            match &mut self.ins {
                Some(ins) => {
                    let p = ins.aid_position(&fix.position, lag);
                    let v = fix.velocity.map(|v| ins.aid_velocity(&v, lag));
                    self.last_results[k] = Some((fix.t_us, p, v));
                    k += 1;
                }
                None => {
                    let n = &mut self.fixes.counters.for_start;
                    *n = n.saturating_add(1);
                    let found = self.motion.as_mut().and_then(|m| {
                        m.add_fix(fix.t_us as f64 * 1e-6, &fix.position, fix.velocity.as_ref())
                    });
                    if let Some(s) = found {
                        self.start_in_motion(s, lag);
                    }
                }
            }
        }
        Ok(self.phase())
    }

    fn start_in_motion(&mut self, s: MotionStart<T>, lag: T) {
        let n = &self.config.noise;
        let mut sigma = s.sigma;
        sigma.gyro_bias_rad_s = Vector3::repeat(n.gyro_bias_rad_s);
        sigma.accel_bias_mps2 = Vector3::repeat(n.accel_bias_mps2);
        sigma.gyro_scale = Vector3::repeat(n.gyro_scale);
        sigma.accel_scale = Vector3::repeat(n.accel_scale);
        let mut state = s.state;
        // From the fix's time to the current sample's.
        let d = state.v_eb_n * lag;
        state.position = state
            .position
            .offset_ned([d.x.to_f64(), d.y.to_f64(), d.z.to_f64()]);
        // Checked at construction: only the start's own values can fail here (not finite).
        if let Ok(ins) = AidedIns::new(state, SensorErrors::default(), &sigma, self.config) {
            self.ins = Some(ins);
            self.motion = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fix(t_us: u64) -> GnssFixInput<f64> {
        GnssFixInput {
            t_us,
            position: GnssPosition {
                lat_rad: 0.7,
                lon_rad: 0.1,
                h_m: 100.0,
                sigma_ned_m: Vector3::repeat(0.5),
            },
            velocity: None,
        }
    }

    /// A repeated time is out of order; a full queue drops its oldest fix for the new one,
    /// counted apart (fixes due faster than samples come, e.g. across a gap in the IMU data:
    /// the oldest would be late first, the newest is the one the next sample can use).
    #[test]
    fn a_full_queue_drops_its_oldest_fix() {
        let mut q = FixQueue::<f64>::new();
        for k in 1..=QUEUE as u64 {
            assert!(q.push(fix(k * 100_000)));
        }
        assert!(!q.push(fix(QUEUE as u64 * 100_000)));
        assert!(q.push(fix(10_000_000)));
        let c = q.counters();
        assert_eq!((c.received, c.out_of_order, c.queue_full), (6, 1, 1));
        // The oldest (0.1 s) is gone: at 10 s the due fixes are 0.2 s onwards, the late
        // ones dropped, the newest applied.
        let (f, lag) = q.pop_due(10_000_000).unwrap();
        assert_eq!((f.t_us, lag), (10_000_000, 0.0));
        assert_eq!(q.counters().late, 3);
    }
}
