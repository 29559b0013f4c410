//! The output protocol's stream (`hal_adapters::protocol`, `docs/protocol.md`) as the
//! `navigate` task sends it through the board's `Output`: raw increments, alignment progress
//! and health at their configured rates ([`OutputRates`]), every solution row the solution log
//! has, an aiding event per fix the filter accepted or refused, and the end of the run.
//!
//! No rule of its own: the status and flags are the protocol's [`StatusModel`], the vibration
//! metric its [`Vibration`], the frames its [`Encoder`]; this module only gathers the counters
//! and calls them. Status changes are logged (defmt) as well as sent.

use crate::board::Output;
use crate::{ExitCode, exit};
use hal_adapters::ImuSample;
use hal_adapters::drivers::Health;
use hal_adapters::protocol::config::OutputRates;
use hal_adapters::protocol::messages::{
    Aid, AidOutcome, AidingEvent, AlignProgress, ConfigAck, EndOfRun, HealthReport, NavSolution,
    RawIncrements,
};
use hal_adapters::protocol::rate::RateDivider;
use hal_adapters::protocol::status::{
    HealthCounters, NavStatus, NavigatorState, StatusFlags, StatusModel,
};
use hal_adapters::protocol::vibration::Vibration;
use hal_adapters::protocol::{Encoder, MAX_FRAME, Message};
use nav_core::ins_filter::aiding::{AidCounters, FilterCounters};
use nav_core::output::Row;

/// The board's own counters beside the driver's.
#[derive(Clone, Copy, Debug, Default)]
pub struct BoardCounters {
    /// Data-ready edges lost (the previous one still pending).
    pub missed_data_ready: u32,
    /// Samples dropped because the channel to `navigate` was full.
    pub channel_overruns: u32,
}

/// The stream's state: the encoder, the status model and the rate dividers.
pub struct Telemetry {
    encoder: Encoder,
    model: StatusModel,
    raw: RateDivider,
    health: RateDivider,
    progress: RateDivider,
    vibration: Vibration,
    counters: HealthCounters,
    /// The status and flags of the last evaluation (the solution frames carry them).
    status: Option<(NavStatus, StatusFlags)>,
    /// The filter's aid counters already reported as aiding events.
    aiding: FilterCounters,
    /// Frames and bytes sent.
    sent: (u32, u64),
}

impl Telemetry {
    /// A stream at `rates` (the vibration window is the health frame's period).
    pub fn new(rates: &OutputRates) -> Self {
        Self {
            encoder: Encoder::new(),
            model: StatusModel::default(),
            raw: RateDivider::new(rates.raw_every),
            health: RateDivider::new(rates.health_every),
            progress: RateDivider::new(rates.align_progress_every),
            vibration: Vibration::new(u32::from(rates.health_every)),
            counters: HealthCounters::default(),
            status: None,
            aiding: FilterCounters::default(),
            sent: (0, 0),
        }
    }

    /// Takes new output rates (an accepted configuration frame).
    pub fn set_rates(&mut self, rates: &OutputRates) {
        self.raw = RateDivider::new(rates.raw_every);
        self.health = RateDivider::new(rates.health_every);
        self.progress = RateDivider::new(rates.align_progress_every);
        self.vibration = Vibration::new(u32::from(rates.health_every));
    }

    /// Frames and bytes sent so far.
    pub fn sent(&self) -> (u32, u64) {
        self.sent
    }

    /// The counters of the last health evaluation.
    pub fn counters(&self) -> &HealthCounters {
        &self.counters
    }

    /// Encodes `message` and writes its frame. A message that cannot be encoded is logged and
    /// left out (the decoder then finds the rows short of the end record's count); an output
    /// that refuses bytes ends the run.
    pub fn send(&mut self, out: &mut Output, message: &Message) {
        let mut buf = [0_u8; MAX_FRAME];
        let n = match self.encoder.encode(message, &mut buf) {
            Ok(n) => n,
            Err(e) => {
                defmt::error!("{=str} frame not sent: {}", message.id().name(), e);
                return;
            }
        };
        if out.write_frame(&buf[..n]).is_err() {
            defmt::error!("cannot write the output stream");
            exit(ExitCode::Output);
        }
        self.sent.0 += 1;
        self.sent.1 += n as u64;
    }

    /// One sample taken by `navigate`: its raw increments and the vibration metric; the
    /// alignment's progress while aligning (`align`: stage, samples used, samples of the
    /// window); and the health frame when due (`health`: the counters, read only then).
    pub fn sample(
        &mut self,
        out: &mut Output,
        sample: &ImuSample,
        nav: NavigatorState,
        align: Option<(u32, u32)>,
        health: impl FnOnce() -> (Health, BoardCounters, Option<FilterCounters>),
    ) {
        if self.raw.tick() {
            self.send(
                out,
                &Message::RawIncrements(RawIncrements { sample: *sample }),
            );
        }
        if sample.flags.usable() && sample.dt_s > 0.0 {
            let (dtheta, dv) = sample.increments();
            let per_s = |x: [f32; 3]| x.map(|v| v / sample.dt_s);
            self.vibration.push(per_s(dv), per_s(dtheta), sample.dt_s);
        }
        if let Some((samples, samples_total)) = align
            && self.progress.tick()
        {
            let progress = AlignProgress {
                t_us: sample.t_us,
                stage: nav.stage,
                samples,
                samples_total,
            };
            self.send(out, &Message::AlignProgress(progress));
        }
        if self.health.tick() {
            let (driver, board, filter) = health();
            self.health_frame(out, sample.t_us, nav, &driver, board, filter.as_ref());
        }
    }

    /// Evaluates the status model at `t_us` [us] on the counters and sends the health frame;
    /// a change of status is logged.
    pub fn health_frame(
        &mut self,
        out: &mut Output,
        t_us: u64,
        nav: NavigatorState,
        driver: &Health,
        board: BoardCounters,
        filter: Option<&FilterCounters>,
    ) {
        let c = &mut self.counters;
        c.set_driver(driver, board.missed_data_ready);
        c.channel_overruns = board.channel_overruns;
        if let Some(f) = filter {
            c.set_aiding(f);
        }
        let (status, flags) = self.model.update(t_us, nav, c);
        if self.status.is_none_or(|(s, _)| s != status) {
            defmt::info!(
                "status {=str} at {=u64} us (flags {=u16:#x})",
                status.name(),
                t_us,
                flags.bits()
            );
        }
        self.status = Some((status, flags));
        let report = HealthReport {
            t_us,
            status,
            flags,
            counters: self.counters,
            vibration: self.vibration.levels(),
        };
        self.send(out, &Message::Health(report));
    }

    /// A solution row (the one the solution log has), with the last evaluated status
    /// (navigating, before the first health evaluation since the alignment: `NAV`, free
    /// inertial unless aided; the first row once said the alignment's `ALIGN_COARSE`).
    pub fn row(&mut self, out: &mut Output, row: Row) {
        let navigating = |s: &NavStatus| {
            !matches!(
                s,
                NavStatus::Standby | NavStatus::AlignCoarse | NavStatus::AlignFine
            )
        };
        let (status, flags) = self.status.filter(|(s, _)| navigating(s)).unwrap_or((
            NavStatus::Nav,
            match row {
                Row::Free(_) => StatusFlags::FREE_INERTIAL,
                Row::Aided(..) => StatusFlags::empty(),
            },
        ));
        let m = NavSolution { row, status, flags };
        self.send(out, &Message::NavSolution(m));
    }

    /// An aiding event for each GNSS position and velocity fix the filter's counters
    /// `filter` show used or refused since the previous call, time-tagged `t_us` [us] (the
    /// time of the latest fix handed over). The counters carry no innovation: NIS is NaN.
    pub fn aiding(&mut self, out: &mut Output, t_us: u64, filter: &FilterCounters) {
        let before = self.aiding;
        self.aiding = *filter;
        for (aid, was, now) in [
            (Aid::Position, before.position, filter.position),
            (Aid::Velocity, before.velocity, filter.velocity),
        ] {
            for (outcome, n) in outcomes(&was, &now) {
                for _ in 0..n {
                    let event = AidingEvent {
                        t_us,
                        aid,
                        outcome,
                        nis: f32::NAN,
                    };
                    self.send(out, &Message::AidingEvent(event));
                }
            }
        }
    }

    /// The answer to a configuration frame.
    pub fn config_ack(&mut self, out: &mut Output, ack: ConfigAck) {
        self.send(out, &Message::ConfigAck(ack));
    }

    /// The end of a complete run: `rows` solution rows were sent.
    pub fn end(&mut self, out: &mut Output, rows: u32) {
        self.send(out, &Message::EndOfRun(EndOfRun { rows }));
    }
}

/// Accepted and refused (gate or invalid) measurements between two counts of one aid.
fn outcomes(was: &AidCounters, now: &AidCounters) -> [(AidOutcome, u32); 3] {
    [
        (
            AidOutcome::Accepted,
            now.accepted.saturating_sub(was.accepted),
        ),
        (
            AidOutcome::RejectedGate,
            now.rejected.saturating_sub(was.rejected),
        ),
        (AidOutcome::Invalid, now.invalid.saturating_sub(was.invalid)),
    ]
}
