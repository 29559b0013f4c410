//! The status model: the wire status ([`NavStatus`]) and flags ([`StatusFlags`]) of the
//! navigator's stage, the filter's status and the sensor's health, and the health counters
//! ([`HealthCounters`]) the health frame carries.
//!
//! **The rule** ([`StatusModel::update`], the one place it lives; the firmware only feeds it):
//! - FAULT: the alignment failed, or since the previous evaluation the sensor reported a
//!   device fault or a bus error (sensor failure);
//! - else STANDBY while the board waits for the host's configuration (no navigation);
//! - else ALIGN_COARSE / ALIGN_FINE while the alignment is in its coarse / fine stage;
//! - else DEGRADED when the filter reports anything but nominal (fixes refused beyond its
//!   limit, horizontal 1-sigma above its limit, covariance fault:
//!   [`nav_core::ins_filter::FilterStatus`]), or when the aided phase has had no fix accepted
//!   for longer than its timeout ([`DEFAULT_AIDING_TIMEOUT_S`]: aiding lost);
//! - else NAV (aided and nominal, or free inertial, flagged [`StatusFlags::FREE_INERTIAL`]).
//!
//! The flags say why, and report what did not change the status: checksum errors, clipped
//! axes, missed data-ready, channel overruns and watchdog resets since the previous evaluation,
//! and a run on the compiled-in configuration (no configuration frame in the standby window).

use crate::drivers::Health;
use bitflags::bitflags;
use nav_core::alignment::machine::Stage;
use nav_core::ins_filter::FilterStatus;
use nav_core::ins_filter::aiding::{AidCounters, FilterCounters};

/// The navigator's status on the wire (one byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum NavStatus {
    /// Coarse alignment (levelling, gyrocompassing): no solution yet.
    AlignCoarse = 0,
    /// Fine alignment (the alignment filter): no solution yet.
    AlignFine = 1,
    /// Navigating, within limits.
    Nav = 2,
    /// Navigating with aiding refused beyond its limit, or 1-sigma above its limit.
    Degraded = 3,
    /// Sensor failure or failed alignment: the solution is not to be used.
    Fault = 4,
    /// Waiting for the host's configuration frame (the standby window): no navigation.
    Standby = 5,
}

impl NavStatus {
    /// Every status, in code order.
    pub const ALL: [Self; 6] = [
        Self::AlignCoarse,
        Self::AlignFine,
        Self::Nav,
        Self::Degraded,
        Self::Fault,
        Self::Standby,
    ];

    /// The status of a wire code.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(usize::from(code)).copied()
    }

    /// Why a solution row's status and flags are not what [`StatusModel::update`]'s rule gives
    /// a board that navigates (`None` when they are): a stage that gives no solution (STANDBY,
    /// ALIGN_*), FAULT without a failure flag or a failure flag without FAULT, DEGRADED
    /// without a flag that degrades, or NAV with one (IMU_LOST, NEAR_POLE: the solution not
    /// to be trusted). The decoder refuses such rows: no board writes them.
    pub fn solution_contradiction(self, flags: StatusFlags) -> Option<&'static str> {
        let failed = flags.intersects(StatusFlags::FAILED);
        let degraded = flags.intersects(StatusFlags::DEGRADED);
        match self {
            Self::Standby | Self::AlignCoarse | Self::AlignFine => {
                Some("a status that gives no solution")
            }
            Self::Fault if !failed => Some("FAULT without a failure flag"),
            Self::Nav | Self::Degraded if failed => Some("a failure flag without FAULT"),
            Self::Degraded if !degraded => Some("DEGRADED without a flag that degrades"),
            Self::Nav if degraded => Some("NAV with a flag that makes it DEGRADED"),
            _ => None,
        }
    }

    /// Upper-case name (docs, logs).
    pub fn name(self) -> &'static str {
        match self {
            Self::AlignCoarse => "ALIGN_COARSE",
            Self::AlignFine => "ALIGN_FINE",
            Self::Nav => "NAV",
            Self::Degraded => "DEGRADED",
            Self::Fault => "FAULT",
            Self::Standby => "STANDBY",
        }
    }
}

bitflags! {
    /// Why the status is what it is, and events since the previous evaluation (two bytes).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct StatusFlags: u16 {
        /// No aiding: free inertial after the alignment.
        const FREE_INERTIAL = 1 << 0;
        /// The filter refused position fixes in a row beyond its limit, or found them lagging
        /// their time tags (nav-core's `ins_filter::latency`).
        const AIDING_REJECTED = 1 << 1;
        /// The filter's horizontal position 1-sigma is above its limit.
        const SIGMA_ABOVE_LIMIT = 1 << 2;
        /// The filter's covariance lost a positive variance (reset to its diagonal).
        const COVARIANCE_FAULT = 1 << 3;
        /// The alignment failed.
        const ALIGN_FAILED = 1 << 4;
        /// The sensor reported a device fault.
        const DEVICE_FAULT = 1 << 5;
        /// Bus (SPI) errors.
        const BUS_ERRORS = 1 << 6;
        /// Frames refused by the sensor's integrity checks (checksum).
        const CHECKSUM_ERRORS = 1 << 7;
        /// An axis at or beyond its measurement range.
        const CLIPPING = 1 << 8;
        /// Data-ready interrupts missed (or device samples lost).
        const MISSED_SAMPLES = 1 << 9;
        /// Samples dropped because the channel to navigation was full.
        const OVERRUNS = 1 << 10;
        /// The watchdog reset the board.
        const WATCHDOG_RESET = 1 << 11;
        /// No fix accepted for longer than the aiding timeout (aided phase).
        const AIDING_LOST = 1 << 12;
        /// The run's configuration is the compiled-in one: no configuration frame was
        /// accepted in the standby window.
        const DEFAULT_CONFIG = 1 << 13;
        /// A gap in the IMU data too long to bridge: the solution is lost for the rest of
        /// the run (nav-core's `gap`).
        const IMU_LOST = 1 << 14;
        /// The solution came so near a pole that the filter's NED error model does not hold:
        /// not trusted for the rest of the run (nav-core's `ins_filter::model::near_pole`).
        const NEAR_POLE = 1 << 15;
    }
}

impl StatusFlags {
    /// The flags that make the status FAULT ([`StatusModel::update`]).
    pub const FAILED: Self = Self::ALIGN_FAILED
        .union(Self::DEVICE_FAULT)
        .union(Self::BUS_ERRORS);
    /// The flags that make a navigating status DEGRADED ([`StatusModel::update`]).
    pub const DEGRADED: Self = Self::AIDING_REJECTED
        .union(Self::AIDING_LOST)
        .union(Self::SIGMA_ABOVE_LIMIT)
        .union(Self::COVARIANCE_FAULT)
        .union(Self::IMU_LOST)
        .union(Self::NEAR_POLE);
}

/// Accepted and refused measurements of one aid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AidCount {
    /// Used by the filter.
    pub accepted: u32,
    /// Refused (gate, invalid, late or out of order).
    pub rejected: u32,
}

impl AidCount {
    /// The count of the filter's counters of one aid: the gate's refusals and the invalid
    /// measurements are both refused.
    pub fn of(c: &AidCounters) -> Self {
        Self {
            accepted: c.accepted,
            rejected: c.rejected.saturating_add(c.invalid),
        }
    }
}

/// The counters of the health frame, since power-up (each saturates at `u32::MAX`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthCounters {
    /// Samples delivered by the sensor.
    pub samples: u32,
    /// Data-ready interrupts missed, and device samples the driver saw lost.
    pub missed_data_ready: u32,
    /// Samples dropped because the channel to the navigation task was full.
    pub channel_overruns: u32,
    /// SPI operations that failed.
    pub bus_errors: u32,
    /// Sensor frames refused by their integrity checks (checksum, FIFO header).
    pub checksum_errors: u32,
    /// Samples the device flagged as faulty (its own diagnostics).
    pub device_faults: u32,
    /// Samples with a gyro axis clipped, per sensor axis x, y, z.
    pub gyro_clips: [u32; 3],
    /// Samples with an accelerometer axis clipped, per sensor axis x, y, z.
    pub accel_clips: [u32; 3],
    /// GNSS position fixes.
    pub position_aiding: AidCount,
    /// GNSS velocity fixes.
    pub velocity_aiding: AidCount,
    /// Watchdog resets since the board was powered (kept across resets by the board).
    pub watchdog_resets: u32,
}

impl HealthCounters {
    /// Takes the driver's counters (samples, missed device samples, bus and checksum errors,
    /// device faults, clips); the board's own ones (overruns, missed data-ready, watchdog
    /// resets) and the aiding counts are set by their owners.
    pub fn set_driver(&mut self, h: &Health, missed_data_ready: u32) {
        self.samples = h.samples;
        self.missed_data_ready = h.missed.saturating_add(missed_data_ready);
        self.bus_errors = h.bus_errors;
        self.checksum_errors = h.checksum_errors;
        self.device_faults = h.device_faults;
        self.gyro_clips = h.gyro_clips;
        self.accel_clips = h.accel_clips;
    }
}

impl HealthCounters {
    /// Takes the filter's GNSS position and velocity counts (refused fixes the sequencer
    /// dropped as late or out of order are the board's to add).
    pub fn set_aiding(&mut self, c: &FilterCounters) {
        self.position_aiding = AidCount::of(&c.position);
        self.velocity_aiding = AidCount::of(&c.velocity);
    }
}

/// Where the run's configuration comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RunSource {
    /// Not decided: the board waits for the host's configuration frame (standby).
    Waiting,
    /// The host's configuration frame.
    Host,
    /// The compiled-in configuration: no frame came in the standby window.
    Default,
}

/// What the status rule reads of the navigator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NavigatorState {
    /// The alignment's stage ([`Stage::Aligned`] once navigating).
    pub stage: Stage,
    /// The aided filter's status (`None`: no filter, free inertial or still aligning).
    pub filter: Option<FilterStatus>,
    /// Where the run's configuration comes from.
    pub config: RunSource,
}

/// How long the aided phase may go without an accepted fix before it is DEGRADED, by default
/// [s] (five fixes missed at 1 Hz).
pub const DEFAULT_AIDING_TIMEOUT_S: f64 = 5.0;

/// The status rule with the counters of its previous evaluation (to see what happened since)
/// and the time of the last accepted fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StatusModel {
    previous: HealthCounters,
    aiding_timeout_us: u64,
    /// Time of the last accepted fix (or of the start of the aided phase) [us].
    last_fix_us: Option<u64>,
}

impl Default for StatusModel {
    /// With [`DEFAULT_AIDING_TIMEOUT_S`].
    fn default() -> Self {
        Self::new(DEFAULT_AIDING_TIMEOUT_S)
    }
}

impl StatusModel {
    /// A model that calls the aided phase DEGRADED after `aiding_timeout_s` [s] without an
    /// accepted fix.
    pub fn new(aiding_timeout_s: f64) -> Self {
        Self {
            previous: HealthCounters::default(),
            aiding_timeout_us: (aiding_timeout_s.max(0.0) * 1e6) as u64,
            last_fix_us: None,
        }
    }

    /// The status and flags at time `t_us` [us] of `nav` and `health` (the module's rule);
    /// remembers `health` for the next evaluation.
    pub fn update(
        &mut self,
        t_us: u64,
        nav: NavigatorState,
        health: &HealthCounters,
    ) -> (NavStatus, StatusFlags) {
        let mut flags = nav_flags(nav) | event_flags(&self.previous, health);
        flags.set(
            StatusFlags::AIDING_LOST,
            self.aiding_lost(t_us, nav, health),
        );
        self.previous = *health;
        let status = if flags.intersects(StatusFlags::FAILED) {
            NavStatus::Fault
        } else {
            match nav.stage {
                _ if nav.config == RunSource::Waiting => NavStatus::Standby,
                Stage::Coarse => NavStatus::AlignCoarse,
                Stage::Fine => NavStatus::AlignFine,
                Stage::Aligned | Stage::Failed if flags.intersects(StatusFlags::DEGRADED) => {
                    NavStatus::Degraded
                }
                Stage::Aligned | Stage::Failed => NavStatus::Nav,
            }
        };
        (status, flags)
    }

    /// The aided phase has gone longer than the timeout without an accepted fix (its clock
    /// starts with the aided phase, and again at every accepted fix).
    fn aiding_lost(&mut self, t_us: u64, nav: NavigatorState, health: &HealthCounters) -> bool {
        if nav.filter.is_none() {
            self.last_fix_us = None;
            return false;
        }
        let accepted = |h: &HealthCounters| {
            h.position_aiding
                .accepted
                .saturating_add(h.velocity_aiding.accepted)
        };
        let last = self.last_fix_us.get_or_insert(t_us);
        if accepted(health) > accepted(&self.previous) {
            *last = t_us;
        }
        t_us.saturating_sub(*last) > self.aiding_timeout_us
    }
}

/// The flags of the navigator's stage and filter.
fn nav_flags(nav: NavigatorState) -> StatusFlags {
    let mut f = StatusFlags::empty();
    f.set(StatusFlags::ALIGN_FAILED, nav.stage == Stage::Failed);
    f.set(
        StatusFlags::DEFAULT_CONFIG,
        nav.config == RunSource::Default,
    );
    match nav.filter {
        None => f.set(StatusFlags::FREE_INERTIAL, nav.stage == Stage::Aligned),
        Some(FilterStatus::Nominal) => {}
        // The fixes are refused, or lag their time tags: either way the aiding is not taken
        // as it comes (the health frame's flags have no spare bit).
        Some(FilterStatus::AidingRejected | FilterStatus::GnssLate) => {
            f |= StatusFlags::AIDING_REJECTED
        }
        Some(FilterStatus::SigmaAboveLimit) => f |= StatusFlags::SIGMA_ABOVE_LIMIT,
        Some(FilterStatus::CovarianceFault) => f |= StatusFlags::COVARIANCE_FAULT,
        Some(FilterStatus::ImuLost) => f |= StatusFlags::IMU_LOST,
        Some(FilterStatus::NearPole) => f |= StatusFlags::NEAR_POLE,
    }
    f
}

/// The flags of the counters that grew from `before` to `now`.
fn event_flags(before: &HealthCounters, now: &HealthCounters) -> StatusFlags {
    let grew = |a: u32, b: u32| b > a;
    let clipped = (0..3).any(|i| {
        grew(before.gyro_clips[i], now.gyro_clips[i])
            || grew(before.accel_clips[i], now.accel_clips[i])
    });
    let mut f = StatusFlags::empty();
    for (flag, a, b) in [
        (
            StatusFlags::DEVICE_FAULT,
            before.device_faults,
            now.device_faults,
        ),
        (StatusFlags::BUS_ERRORS, before.bus_errors, now.bus_errors),
        (
            StatusFlags::CHECKSUM_ERRORS,
            before.checksum_errors,
            now.checksum_errors,
        ),
        (
            StatusFlags::MISSED_SAMPLES,
            before.missed_data_ready,
            now.missed_data_ready,
        ),
        (
            StatusFlags::OVERRUNS,
            before.channel_overruns,
            now.channel_overruns,
        ),
        (
            StatusFlags::WATCHDOG_RESET,
            before.watchdog_resets,
            now.watchdog_resets,
        ),
    ] {
        f.set(flag, grew(a, b));
    }
    f.set(StatusFlags::CLIPPING, clipped);
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(stage: Stage, filter: Option<FilterStatus>) -> NavigatorState {
        NavigatorState {
            stage,
            filter,
            config: RunSource::Host,
        }
    }

    #[test]
    fn stages_and_filter_map_to_the_wire_status() {
        let h = HealthCounters::default();
        let cases = [
            (
                state(Stage::Coarse, None),
                NavStatus::AlignCoarse,
                StatusFlags::empty(),
            ),
            (
                state(Stage::Fine, None),
                NavStatus::AlignFine,
                StatusFlags::empty(),
            ),
            (
                state(Stage::Aligned, None),
                NavStatus::Nav,
                StatusFlags::FREE_INERTIAL,
            ),
            (
                state(Stage::Aligned, Some(FilterStatus::Nominal)),
                NavStatus::Nav,
                StatusFlags::empty(),
            ),
            (
                state(Stage::Aligned, Some(FilterStatus::AidingRejected)),
                NavStatus::Degraded,
                StatusFlags::AIDING_REJECTED,
            ),
            (
                state(Stage::Aligned, Some(FilterStatus::SigmaAboveLimit)),
                NavStatus::Degraded,
                StatusFlags::SIGMA_ABOVE_LIMIT,
            ),
            (
                state(Stage::Aligned, Some(FilterStatus::CovarianceFault)),
                NavStatus::Degraded,
                StatusFlags::COVARIANCE_FAULT,
            ),
            (
                state(Stage::Aligned, Some(FilterStatus::ImuLost)),
                NavStatus::Degraded,
                StatusFlags::IMU_LOST,
            ),
            (
                state(Stage::Aligned, Some(FilterStatus::NearPole)),
                NavStatus::Degraded,
                StatusFlags::NEAR_POLE,
            ),
            (
                state(Stage::Aligned, Some(FilterStatus::GnssLate)),
                NavStatus::Degraded,
                StatusFlags::AIDING_REJECTED,
            ),
            (
                state(Stage::Failed, None),
                NavStatus::Fault,
                StatusFlags::ALIGN_FAILED,
            ),
        ];
        for (nav, status, flags) in cases {
            assert_eq!(
                StatusModel::default().update(0, nav, &h),
                (status, flags),
                "{nav:?}"
            );
        }
    }

    #[test]
    fn sensor_failures_fault_and_other_events_only_flag() {
        let nav = state(Stage::Aligned, Some(FilterStatus::Nominal));
        let mut model = StatusModel::default();
        let mut h = HealthCounters::default();
        assert_eq!(model.update(0, nav, &h).0, NavStatus::Nav);
        h.checksum_errors = 1;
        h.accel_clips[2] = 4;
        h.channel_overruns = 1;
        assert_eq!(
            model.update(0, nav, &h),
            (
                NavStatus::Nav,
                StatusFlags::CHECKSUM_ERRORS | StatusFlags::CLIPPING | StatusFlags::OVERRUNS
            )
        );
        // Nothing new since: no event flags.
        assert_eq!(
            model.update(0, nav, &h),
            (NavStatus::Nav, StatusFlags::empty())
        );
        h.bus_errors = 1;
        assert_eq!(
            model.update(0, nav, &h),
            (NavStatus::Fault, StatusFlags::BUS_ERRORS)
        );
        h.device_faults = 1;
        let aligning = state(Stage::Coarse, None);
        assert_eq!(
            model.update(0, aligning, &h),
            (NavStatus::Fault, StatusFlags::DEVICE_FAULT)
        );
        // The failure over, the status recovers.
        assert_eq!(model.update(0, aligning, &h).0, NavStatus::AlignCoarse);
    }

    /// Every status and flags the rule gives a board with a solution (aligned, free or aided,
    /// any filter status, any sensor event, aiding lost or not) passes the decoder's check
    /// ([`NavStatus::solution_contradiction`]); the alignment's and standby's stages do not.
    #[test]
    fn the_rules_solution_rows_never_contradict_it() {
        let filters = [
            None,
            Some(FilterStatus::Nominal),
            Some(FilterStatus::AidingRejected),
            Some(FilterStatus::GnssLate),
            Some(FilterStatus::SigmaAboveLimit),
            Some(FilterStatus::CovarianceFault),
            Some(FilterStatus::ImuLost),
            Some(FilterStatus::NearPole),
        ];
        for filter in filters {
            for events in 0u32..64 {
                for t_s in [0u64, 100] {
                    let mut model = StatusModel::new(5.0);
                    let nav = state(Stage::Aligned, filter);
                    model.update(0, nav, &HealthCounters::default());
                    let bit = |k: u32| u32::from(events & (1 << k) != 0);
                    let mut h = HealthCounters {
                        device_faults: bit(0),
                        bus_errors: bit(1),
                        checksum_errors: bit(2),
                        missed_data_ready: bit(3),
                        channel_overruns: bit(4),
                        ..HealthCounters::default()
                    };
                    h.gyro_clips[1] = bit(5);
                    let (status, flags) = model.update(t_s * 1_000_000, nav, &h);
                    assert_eq!(
                        status.solution_contradiction(flags),
                        None,
                        "{filter:?} events {events:#b} at {t_s} s: {status:?} {flags:?}"
                    );
                }
            }
        }
        let aligning = state(Stage::Coarse, None);
        let (status, flags) =
            StatusModel::default().update(0, aligning, &HealthCounters::default());
        assert!(status.solution_contradiction(flags).is_some());
    }

    #[test]
    fn aiding_lost_after_the_timeout_without_an_accepted_fix() {
        let aided = state(Stage::Aligned, Some(FilterStatus::Nominal));
        let mut model = StatusModel::new(5.0);
        let mut h = HealthCounters::default();
        let s = |m: &mut StatusModel, t_s: f64, h: &HealthCounters| {
            m.update((t_s * 1e6) as u64, aided, h)
        };
        // The clock starts with the aided phase.
        assert_eq!(s(&mut model, 100.0, &h).0, NavStatus::Nav);
        assert_eq!(s(&mut model, 105.0, &h).0, NavStatus::Nav);
        assert_eq!(
            s(&mut model, 105.5, &h),
            (NavStatus::Degraded, StatusFlags::AIDING_LOST)
        );
        // A fix accepted: back to NAV, and the clock restarts.
        h.position_aiding.accepted = 1;
        assert_eq!(s(&mut model, 106.0, &h).0, NavStatus::Nav);
        assert_eq!(s(&mut model, 110.9, &h).0, NavStatus::Nav);
        assert_eq!(s(&mut model, 111.1, &h).0, NavStatus::Degraded);
        // Free inertial: no aiding expected, never lost.
        let free = state(Stage::Aligned, None);
        assert_eq!(model.update(200_000_000, free, &h).0, NavStatus::Nav);
    }

    #[test]
    fn aiding_counts_take_invalid_fixes_as_refused() {
        let c = FilterCounters {
            position: AidCounters {
                accepted: 10,
                rejected: 2,
                invalid: 1,
                ..AidCounters::default()
            },
            velocity: AidCounters {
                accepted: 4,
                ..AidCounters::default()
            },
            ..FilterCounters::default()
        };
        let mut h = HealthCounters::default();
        h.set_aiding(&c);
        assert_eq!(
            (h.position_aiding, h.velocity_aiding),
            (
                AidCount {
                    accepted: 10,
                    rejected: 3
                },
                AidCount {
                    accepted: 4,
                    rejected: 0
                }
            )
        );
    }

    #[test]
    fn codes_round_trip() {
        for s in NavStatus::ALL {
            assert_eq!(NavStatus::from_code(s as u8), Some(s));
        }
        assert_eq!(NavStatus::from_code(6), None);
    }
}
