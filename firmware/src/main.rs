//! The navigation firmware: an RTIC 2 app for an STM32F405 IMU board, its tasks written once
//! against the board layer (`firmware::board`: `qemu`, QEMU's netduinoplus2, or `stm32f405`, a
//! real board, chosen by cargo feature).
//!
//! At start `navigate` is in standby until the run's configuration is decided
//! (`firmware::run_config`: the host's configuration frame, or the compiled-in configuration
//! when none comes in the board's standby window); then it builds the navigator and hands the
//! run's settings to `align`, which waits for them to build the background.
//!
//! A sample's way: data-ready interrupt (`data_ready`, highest priority) -> `rtic_sync` channel ->
//! `navigate` (nav-core's navigator: gate, calibration, strapdown; writes the solution log) ->
//! what it forwards to `align` (lowest priority: the navigator's background, the alignment) ->
//! the answer back to `navigate`, which starts navigating from the aligned state. `navigate`
//! also sends the output protocol's stream (`firmware::stream`: raw increments, alignment
//! progress, health with the protocol's status model, solution rows, aiding events, the end of
//! run) and answers configuration frames from the board's configuration input. With GNSS
//! fixes (`--gnss FILE` on the qemu board) the navigation after the alignment is aided:
//! `navigate` hands each fix to the navigator before the first sample at or after its time,
//! runs the filter's mechanization, and forwards the filter's work (covariance propagations,
//! GNSS and stop updates, reports for rows) to `align`, which runs the filter's covariance;
//! `navigate` waits for each update's answer before its next sample (the sample channel fills
//! meanwhile). The rules are all in `nav_core::navigator`; these tasks only carry samples,
//! fixes, messages and rows.
//!
//! The data-ready line is `EXTI0` on both boards: a pin on the real board, pended every 2.5 ms
//! by the `pace` task (`board::emulate_data_ready`) on the qemu board.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use firmware as _; // logger, panic and HardFault handlers

// The firmware's aided phase (its awaits) is there exactly when nav-core's filter is.
const _: () = assert!(
    nav_core::navigator::AIDED_COMPILED_IN == cfg!(feature = "aided"),
    "firmware feature `aided` and nav-core's `aided` differ"
);

#[rtic::app(device = firmware::board::pac, peripherals = true, dispatchers = [USART2, USART3, UART4])]
mod app {
    use core::sync::atomic::{AtomicU32, Ordering};
    use firmware::board::{
        self, ConfigInput, DataReady, Fixes, Imu, ImuSlot, Output, Watchdog, instructions_since,
    };
    use firmware::run_config::RunState;
    use firmware::stream::{BoardCounters, Telemetry};
    use firmware::{
        ALIGN_CAP, ExitCode, FILTER_CAP, FilterCosts, SAMPLE_CAP, StepCost, errors, exit, line, log,
    };
    use hal_adapters::drivers::Health;
    use hal_adapters::protocol::config::DeviceConfig;
    use hal_adapters::protocol::messages::ConfigAck;
    use hal_adapters::protocol::status::{NavigatorState, RunSource};
    use hal_adapters::protocol::{Decoder, Message, Received};
    use nav_core::ImuIncrement;
    use nav_core::alignment::{AlignOutcome, Stage};
    use nav_core::navigator::{
        AIDED_COMPILED_IN, Background, FromBackground, NavError, Navigator, Setup, Step, Summary,
        ToBackground,
    };
    use nav_core::output::{AIDED_CSV_HEADER, CSV_HEADER, Row, Solution};
    use rtic_sync::channel::{Receiver, Sender};
    use rtic_sync::make_channel;

    /// Samples lost because the channel to `navigate` was full.
    static OVERRUNS: AtomicU32 = AtomicU32::new(0);
    /// The longest time from the data-ready line to the sample queued for `navigate`
    /// [instructions] (boards that can measure it: `board::since_data_ready`).
    static READY_LATENCY_MAX: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {
        /// The background's filter work costs (written by `align`, read by `navigate` at the
        /// end).
        costs: FilterCosts,
        /// The alignment's stage and samples used (written by `align`, read by `navigate`
        /// for the status and the progress frames).
        alignment: (Stage, u32),
        /// The IMU driver's counters (written by `data_ready`, read by `navigate` for the
        /// health frames).
        driver_health: Health,
    }

    /// The outputs of `navigate`: the board's output (the solution log, where the board
    /// keeps one, and the protocol stream) and the stream's state.
    pub struct Outputs {
        out: Output,
        tele: Telemetry,
        /// Instructions of the stream's work per sample (raw, progress and health frames,
        /// the vibration metric), and of the solution rows' frames.
        cost: StepCost,
        row_cost: StepCost,
    }

    impl Outputs {
        /// A solution row: to the solution log and as a solution frame.
        #[inline(never)]
        fn row(&mut self, row: Row) {
            if board::CSV_LOG {
                write_line(&mut self.out, row);
            }
            let start = board::counts();
            self.tele.row(&mut self.out, row);
            self.row_cost.add(instructions_since(start));
        }
    }

    #[local]
    struct Local {
        imu: Imu,
        samples_tx: Sender<'static, DataReady, SAMPLE_CAP>,
        /// The navigator's foreground, for `navigate` (built once the run's configuration is
        /// decided).
        navigator: Option<Navigator<f32>>,
        /// The run's configuration (standby, then decided), for `navigate`.
        run: RunState,
        /// The outputs, for `navigate`.
        out: Outputs,
        /// The configuration frames' decoder, for `navigate`.
        config_decoder: Decoder,
        /// The watchdog, fed by `navigate`.
        watchdog: Watchdog,
        /// Configuration bytes from the host, for `navigate`.
        config_in: ConfigInput,
        /// The GNSS fixes and their number, for `navigate` (an aided run).
        gnss: Option<(Fixes, u32)>,
        /// The run's settings from `navigate` once decided, for `align` (which builds the
        /// background from them).
        setup_rx: Receiver<'static, Setup<f32>, 1>,
        /// The alignment increments from `navigate`, for `align`.
        from_navigate_align: Receiver<'static, ImuIncrement<f32>, ALIGN_CAP>,
        /// The aided phase's filter work from `navigate`, for `align`.
        from_navigate: Receiver<'static, ToBackground<f32>, FILTER_CAP>,
        /// The background's answers, from `align`.
        to_navigate: Sender<'static, FromBackground<f32>, 1>,
    }

    #[init(local = [imu_slot: ImuSlot = board::IMU_SLOT])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let board = board::init(cx.core, cx.device, cx.local.imu_slot);
        let out = board.out;

        let (samples_tx, samples_rx) = make_channel!(DataReady, SAMPLE_CAP);
        let (to_align, from_navigate_align) = make_channel!(ImuIncrement<f32>, ALIGN_CAP);
        let (to_filter, from_navigate) = make_channel!(ToBackground<f32>, FILTER_CAP);
        let (to_navigate, from_background) = make_channel!(FromBackground<f32>, 1);
        let (setup_tx, setup_rx) = make_channel!(Setup<f32>, 1);
        if navigate::spawn(samples_rx, to_align, to_filter, from_background, setup_tx).is_err()
            || spawn_pace().is_err()
        {
            defmt::panic!("task spawn failed");
        }
        let tele = Telemetry::new(&DeviceConfig::default().rates);
        (
            Shared {
                costs: FilterCosts::default(),
                alignment: (Stage::Coarse, 0),
                driver_health: Health::default(),
            },
            Local {
                imu: board.imu,
                samples_tx,
                navigator: None,
                run: RunState::new(board.run, board.identity),
                out: Outputs {
                    out,
                    tele,
                    cost: StepCost::default(),
                    row_cost: StepCost::default(),
                },
                config_decoder: Decoder::new(),
                watchdog: board.watchdog,
                config_in: board.config_in,
                gnss: board.gnss,
                setup_rx,
                from_navigate_align,
                from_navigate,
                to_navigate,
            },
        )
    }

    /// The qemu board's emulated data-ready line.
    #[cfg(feature = "qemu")]
    fn spawn_pace() -> Result<(), ()> {
        pace::spawn()
    }

    /// A real board's data-ready line is a pin: nothing to spawn.
    #[cfg(not(feature = "qemu"))]
    fn spawn_pace() -> Result<(), ()> {
        Ok(())
    }

    /// The qemu board's data-ready line: `EXTI0` pended every 2.5 ms.
    #[cfg(feature = "qemu")]
    #[task(priority = 3)]
    async fn pace(_: pace::Context) {
        board::emulate_data_ready().await
    }

    /// IMU data ready: timestamp, read one sample through the driver, hand it on. Never blocks.
    #[task(binds = EXTI0, priority = 4, local = [imu, samples_tx, done: bool = false], shared = [driver_health])]
    fn data_ready(mut cx: data_ready::Context) {
        let t_ready_us = board::now_us();
        if *cx.local.done {
            return;
        }
        let Some(msg) = cx.local.imu.read(t_ready_us) else {
            return;
        };
        let last = msg.is_last();
        let health = cx.local.imu.health();
        cx.shared.driver_health.lock(|h| *h = health);
        match cx.local.samples_tx.try_send(msg) {
            Ok(()) if last => {
                *cx.local.done = true;
                cx.local.imu.ended();
            }
            Ok(()) => {
                if let Some(latency) = board::since_data_ready() {
                    READY_LATENCY_MAX.fetch_max(latency, Ordering::Relaxed);
                }
            }
            // A lost end marker is sent again at the next data-ready (the source stays ended).
            Err(_) => {
                OVERRUNS.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// The IMU read's costs and the driver's final counters.
    #[derive(Default)]
    struct ImuStats {
        bus: StepCost,
        decode: StepCost,
        health: Health,
    }

    /// The foreground's costs of the aided phase: the filter's mechanization per sample, and
    /// the work for the background taken and answered per sample (messages, feedback, rows).
    #[derive(Default)]
    struct AidedCosts {
        step: StepCost,
        messages: StepCost,
    }

    /// Navigation: in standby until the run's configuration is decided ([`standby`]), then
    /// carries every sample (and, aided, every GNSS fix) through nav-core's navigator,
    /// forwards what it asks to the background (`align`), hands it the answers, and writes the
    /// rows it produces.
    #[task(priority = 2, local = [navigator, run, out, watchdog, config_in, config_decoder, gnss], shared = [costs, alignment, driver_health])]
    async fn navigate(
        mut cx: navigate::Context,
        mut samples_rx: Receiver<'static, DataReady, SAMPLE_CAP>,
        mut to_align: Sender<'static, ImuIncrement<f32>, ALIGN_CAP>,
        #[cfg_attr(not(feature = "aided"), allow(unused_variables, unused_mut))]
        mut to_filter: Sender<'static, ToBackground<f32>, FILTER_CAP>,
        mut from_background: Receiver<'static, FromBackground<f32>, 1>,
        mut setup_tx: Sender<'static, Setup<f32>, 1>,
    ) {
        let out = cx.local.out;
        let watchdog = cx.local.watchdog;
        let config_in = cx.local.config_in;
        let config_decoder = cx.local.config_decoder;
        let run_state = cx.local.run;
        let in_standby = standby(
            &mut samples_rx,
            watchdog,
            config_in,
            config_decoder,
            out,
            run_state,
            &mut cx.shared.driver_health,
        )
        .await;
        let navigator = start_run(
            run_state,
            in_standby,
            out,
            cx.local.navigator,
            &mut setup_tx,
        );
        let source = run_state.source();
        // The time of the latest fix handed to the navigator [us] (its aiding events' time).
        let mut last_fix_us = 0_u64;
        // By reference: the task's future holds no second copy of the reader.
        let gnss = cx.local.gnss;
        // Steps without a row, and steps with one (the row's f64 output conversion included).
        let (mut cost, mut row_cost) = (StepCost::default(), StepCost::default());
        let mut aided = AidedCosts::default();
        let mut imu = ImuStats::default();
        let mut last_ready_us = 0_u64;
        // The recording's time of the last sample [us] (the qemu board's fix-file check).
        // The last sample's time: the stream's clock (a recording's may jump over a gap in its
        // data where the data-ready clock does not).
        let mut last_sample_us = 0_u64;
        loop {
            let Ok(msg) = samples_rx.recv().await else {
                defmt::panic!("sample channel closed");
            };
            watchdog.feed();
            take_config(config_in, config_decoder, out, run_state);
            let (sample, t_ready_us) = match msg {
                DataReady::Sample {
                    sample,
                    t_ready_us,
                    bus_instr,
                    decode_instr,
                } => {
                    imu.bus.add(bus_instr.into());
                    imu.decode.add(decode_instr.into());
                    (sample, t_ready_us)
                }
                DataReady::SourceError => stop(out, ExitCode::Recording),
                DataReady::End { health } => {
                    imu.health = health;
                    break;
                }
            };
            last_ready_us = t_ready_us;
            last_sample_us = sample.t_us;
            // An early failure of the alignment (its success comes when awaited, below).
            if navigator.is_aligning()
                && let Ok(answer) = from_background.try_recv()
            {
                answer_from_background(navigator, answer, out, &imu);
            }
            // The GNSS fixes due at this sample first.
            if let Some((fixes, _)) = gnss.as_mut() {
                loop {
                    match fixes.due(sample.t_us, sample.dt_s) {
                        Ok(Some(fix)) => {
                            last_fix_us = fix.t_us;
                            navigator.push_fix(fix);
                        }
                        Ok(None) => break,
                        Err(e) => {
                            defmt::error!("GNSS file: {}", defmt::Display2Format(&e));
                            stop(out, ExitCode::Recording)
                        }
                    }
                }
            }
            let start = board::counts();
            let sample = match run_state.remount() {
                Some(r) => sample.remounted(r),
                None => sample,
            };
            let step = navigator.push(&sample.nav_input());
            let spent = instructions_since(start);
            // A free-inertial solution lost in an IMU gap carries on and looks valid: the
            // log says where, before the sample's row (as the harness's).
            if board::CSV_LOG
                && let Some(lost) = navigator.take_lost_record()
            {
                write_line(&mut out.out, lost);
            }
            match step {
                Step::Navigated(None) => cost.add(spent),
                Step::Navigated(Some(row)) => {
                    row_cost.add(spent);
                    out.row(Row::Free(row));
                }
                Step::Forward {
                    increment,
                    await_reply,
                } => {
                    if to_align.send(increment).await.is_err() {
                        defmt::panic!("alignment channel closed");
                    }
                    if await_reply {
                        let Ok(answer) = from_background.recv().await else {
                            defmt::panic!("alignment result channel closed");
                        };
                        answer_from_background(navigator, answer, out, &imu);
                    }
                }
                Step::Flagged(cause) => {
                    let n = navigator.counters().flagged;
                    // The first ten, then every thousandth: a failing sensor must not flood the log.
                    if n <= 10 || n.is_multiple_of(1000) {
                        defmt::warn!(
                            "sample {=u32} flagged {=str}: not navigated ({=u32} so far)",
                            sample.seq,
                            cause.name(),
                            n
                        );
                    }
                }
                // The aided phase's work (a board without nav-core's filter never has it; its
                // awaits are left out of the task's state machine there, `cfg`).
                Step::Aided => {
                    aided.step.add(spent);
                    #[cfg(feature = "aided")]
                    aided.messages.add(
                        background_work(navigator, &mut to_filter, &mut from_background, out, &imu)
                            .await,
                    );
                    if let Some(report) = navigator.filter_report() {
                        out.tele.aiding(&mut out.out, last_fix_us, &report.counters);
                    }
                }
                Step::Rejected(_) => {}
                Step::Failed(e) => failed(&e, &imu, out),
                // Not reached: every answer is awaited before the next sample.
                Step::NotReady => defmt::panic!("navigator not ready"),
            }
            let nav = nav_state(navigator, source, &mut cx.shared.alignment);
            let align = navigator
                .is_aligning()
                .then(|| (cx.shared.alignment.lock(|a| a.1), navigator.n_align()));
            let health = &mut cx.shared.driver_health;
            let start = board::counts();
            out.tele.sample(&mut out.out, &sample, nav, align, || {
                let filter = navigator.filter_report().map(|r| r.counters);
                (health.lock(|h| *h), board_counters(), filter)
            });
            out.cost.add(instructions_since(start));
        }

        // End of the recording: the last row (aided: with the filter's report), then the end
        // record (only a complete run has it).
        navigator.end_of_data();
        #[cfg(feature = "aided")]
        background_work(navigator, &mut to_filter, &mut from_background, out, &imu).await;
        let summary = navigator.finish().unwrap_or_else(|e| {
            log::health(&imu.health);
            failed(&e, &imu, out)
        });
        if let Some(row) = summary.final_row {
            out.row(row);
        }
        // Fixes on another clock than the recording's: refused, as the harness does (no end
        // record: the log does not look complete). A fix file is the qemu board's.
        #[cfg(feature = "qemu")]
        if let Some([fixes, data]) = gnss
            .as_ref()
            .and_then(|(f, _)| f.none_in_span(last_sample_us))
        {
            log::no_fix_in_span(fixes, data);
            stop(out, ExitCode::Recording)
        }
        if board::CSV_LOG {
            write_line(&mut out.out, summary.end_record());
        }
        // The run's last health frame: the final counters (the summary's), then the end.
        let nav = nav_state(navigator, source, &mut cx.shared.alignment);
        let filter = summary.filter.as_ref().map(|f| f.counters);
        if let Some(f) = &filter {
            out.tele.aiding(&mut out.out, last_fix_us, f);
        }
        out.tele.health_frame(
            &mut out.out,
            last_sample_us,
            nav,
            &imu.health,
            board_counters(),
            filter.as_ref(),
        );
        out.tele.end(&mut out.out, summary.counters.rows);
        if out.out.flush().is_err() {
            defmt::error!("cannot write the output stream");
            exit(ExitCode::Output);
        }
        let (frames, bytes) = out.tele.sent();
        defmt::info!(
            "stream: {=u32} frames, {=u64} bytes; health counters {}",
            frames,
            bytes,
            out.tele.counters()
        );
        let c = summary.counters;
        defmt::info!(
            "summary: samples {=u32}, flagged {=u32} ({}), rejected {=u32}, navigated {=u32}, missed {=u32}, channel overruns {=u32}, last data-ready at {=u64} us",
            c.samples,
            c.flagged,
            errors::Flagged(&c.flagged_by),
            c.rejected,
            c.nav_steps,
            board::missed_data_ready(),
            OVERRUNS.load(Ordering::Relaxed),
            last_ready_us
        );
        if c.gaps.bridged > 0 || c.gaps.lost > 0 {
            defmt::warn!(
                "IMU data gaps while navigating: {=u32} bridged, {=u32} beyond the bridge (solution lost), {=u64} us in all, the longest {=u64} us",
                c.gaps.bridged,
                c.gaps.lost,
                c.gaps.time_us,
                c.gaps.longest_us
            );
        }
        let mut aided_per_sample = None;
        if AIDED_COMPILED_IN && let Some(filter) = &summary.filter {
            let after_data = gnss.as_ref().map_or(0, |(f, n)| f.remaining(*n));
            log::filter(
                filter,
                &summary.fixes,
                &summary.realignments,
                c.fixes_unused,
                after_data,
            );
            let costs = cx.shared.costs.lock(|c| *c);
            aided_per_sample = Some(log_aided_costs(&aided, &costs, &summary));
        }
        log_cycle(&cost, &row_cost, aided_per_sample, &imu, out);
        report(
            &cost,
            &row_cost,
            &imu,
            &summary.alignment,
            &summary.last_solution,
        );
        exit(ExitCode::Success)
    }

    /// The navigator's state for the status model: the alignment's stage (from `align`)
    /// while aligning, then aligned; in the aided phase the filter's last reported status
    /// (nominal, as the filter starts, until its first report).
    fn nav_state(
        navigator: &Navigator<f32>,
        config: RunSource,
        alignment: &mut impl rtic::Mutex<T = (Stage, u32)>,
    ) -> NavigatorState {
        let stage = if navigator.is_aligning() {
            alignment.lock(|a| a.0)
        } else {
            Stage::Aligned
        };
        NavigatorState {
            stage,
            filter: navigator.filter_status(),
            config,
        }
    }

    /// The board's own counters.
    fn board_counters() -> BoardCounters {
        BoardCounters {
            missed_data_ready: board::missed_data_ready(),
            channel_overruns: OVERRUNS.load(Ordering::Relaxed),
        }
    }

    /// Standby: takes the host's configuration frames and counts the samples (sent as raw
    /// increments and health frames with the status STANDBY, not navigated) until a frame is
    /// accepted or the board's standby window ([`board::STANDBY_US`], from the task's start)
    /// ends, when the compiled-in configuration runs. Returns the samples that arrived in
    /// standby.
    async fn standby(
        samples_rx: &mut Receiver<'static, DataReady, SAMPLE_CAP>,
        watchdog: &mut Watchdog,
        config_in: &mut ConfigInput,
        decoder: &mut Decoder,
        out: &mut Outputs,
        run: &mut RunState,
        health: &mut impl rtic::Mutex<T = Health>,
    ) -> u32 {
        let end_us = board::now_us().saturating_add(board::STANDBY_US);
        let mut samples = 0_u32;
        loop {
            take_config(config_in, decoder, out, run);
            if run.running().is_some() {
                return samples;
            }
            if board::now_us() >= end_us {
                config_in.none_taken();
                run.use_default();
                return samples;
            }
            let Ok(msg) = samples_rx.recv().await else {
                defmt::panic!("sample channel closed");
            };
            watchdog.feed();
            match msg {
                DataReady::Sample { sample, .. } => {
                    samples += 1;
                    let nav = NavigatorState {
                        stage: Stage::Coarse,
                        filter: None,
                        config: RunSource::Waiting,
                    };
                    out.tele.sample(&mut out.out, &sample, nav, None, || {
                        (health.lock(|h| *h), board_counters(), None)
                    });
                }
                DataReady::SourceError => exit(ExitCode::Recording),
                DataReady::End { .. } => {
                    defmt::error!(
                        "the IMU data ended in standby, before the run's configuration ({=u32} samples)",
                        samples
                    );
                    exit(ExitCode::Alignment)
                }
            }
        }
    }

    /// Starts the run on its decided configuration: logs where it came from (loudly when the
    /// compiled-in one runs) and what it is, builds the navigator in `slot`, hands the settings
    /// to `align` and writes the solution log's header.
    #[inline(never)]
    fn start_run<'a>(
        run: &RunState,
        in_standby: u32,
        out: &mut Outputs,
        slot: &'a mut Option<Navigator<f32>>,
        setup_tx: &mut Sender<'static, Setup<f32>, 1>,
    ) -> &'a mut Navigator<f32> {
        let Some((config, source)) = run.running() else {
            defmt::panic!("the run's configuration is not decided");
        };
        if *source == RunSource::Host {
            defmt::info!(
                "run configuration: the host's configuration frame ({=u32} samples in standby, not navigated)",
                in_standby
            );
        } else {
            defmt::warn!(
                "no configuration frame in the {=u64} ms standby window: the compiled-in run configuration runs (status flag DEFAULT_CONFIG; {=u32} samples in standby, not navigated)",
                board::STANDBY_US / 1000,
                in_standby
            );
        }
        log::config(config);
        if run.remount().is_some() {
            defmt::info!("mounting: the host's (each sample turned from the driver's axes)");
        }
        let setup = Setup::<f32>::new(config, run.identity().imu_rate_hz).unwrap_or_else(|e| {
            defmt::error!("invalid configuration: {}", errors::Config(&e));
            exit(ExitCode::Config)
        });
        if board::CSV_LOG {
            let header = if config.aiding.is_some() {
                AIDED_CSV_HEADER
            } else {
                CSV_HEADER
            };
            write_line(&mut out.out, header);
        }
        if setup_tx.try_send(setup).is_err() {
            defmt::panic!("settings channel closed");
        }
        slot.insert(Navigator::new(&setup))
    }

    /// Takes the configuration bytes the host sent, through the protocol's decoder: a
    /// configuration frame is checked ([`RunState::take`]) and answered with an
    /// acknowledgement (accepted, or refused with its reason code). An accepted frame's output
    /// rates apply at once; in standby its run configuration becomes the run's, during a run
    /// it must be the running one (refused otherwise: run in progress).
    #[inline(never)]
    fn take_config(
        config_in: &mut ConfigInput,
        decoder: &mut Decoder,
        out: &mut Outputs,
        run: &mut RunState,
    ) {
        let mut buf = [0_u8; 64];
        loop {
            let n = config_in.read(&mut buf);
            if n == 0 {
                return;
            }
            decoder.push_config(&buf[..n], |frame| match frame {
                Ok(Received {
                    seq,
                    message: Message::Config(config),
                }) => {
                    let taken = run.take(&config);
                    if taken.is_ok() {
                        out.tele.set_rates(&config.rates);
                    }
                    match &taken {
                        Ok(true) => defmt::info!(
                            "configuration frame {=u16} accepted: the run's configuration and output rates",
                            seq
                        ),
                        Ok(false) => defmt::info!(
                            "configuration frame {=u16} accepted: output rates applied (the run's configuration unchanged)",
                            seq
                        ),
                        Err(e) => defmt::warn!(
                            "configuration frame {=u16} refused (reason {=u8}): {}",
                            seq,
                            e.code() as u8,
                            errors::Refusal(e)
                        ),
                    }
                    let ack = ConfigAck {
                        config_seq: seq,
                        refused: taken.err().map(|e| e.code()),
                    };
                    out.tele.config_ack(&mut out.out, ack);
                }
                Ok(other) => defmt::warn!(
                    "{=str} frame on the configuration input ignored",
                    other.message.id().name()
                ),
                Err(e) => defmt::warn!("configuration input: frame refused: {}", e),
            });
        }
    }

    /// Forwards the navigator's work for the background ([`Navigator::next_message`]) and
    /// waits for each answered message's answer, writing the row an answer completes; returns
    /// the foreground's instructions in it (the waits for the background not counted).
    #[cfg(feature = "aided")]
    async fn background_work(
        navigator: &mut Navigator<f32>,
        to_background: &mut Sender<'static, ToBackground<f32>, FILTER_CAP>,
        from_background: &mut Receiver<'static, FromBackground<f32>, 1>,
        out: &mut Outputs,
        imu: &ImuStats,
    ) -> u64 {
        let mut spent = 0;
        loop {
            let start = board::counts();
            let message = navigator.next_message();
            spent += instructions_since(start);
            let Some(message) = message else {
                return spent;
            };
            let answered = message.is_answered();
            if to_background.send(message).await.is_err() {
                defmt::panic!("background channel closed");
            }
            if !answered {
                continue;
            }
            let Ok(answer) = from_background.recv().await else {
                defmt::panic!("background answer channel closed");
            };
            let start = board::counts();
            let row = navigator.on_background(answer);
            spent += instructions_since(start);
            match row {
                Ok(Some(row)) => out.row(row),
                Ok(None) => {}
                Err(e) => failed(&e, imu, out),
            }
        }
    }

    /// Logs the aided phase's costs: per propagation and update (the background), and the
    /// total per sample amortised over the aided samples.
    /// Returns the amortised instructions per aided sample.
    #[inline(never)]
    fn log_aided_costs(aided: &AidedCosts, costs: &FilterCosts, summary: &Summary<f32>) -> u64 {
        let steps = aided.step.n.max(1);
        let background =
            costs.propagation.sum + costs.gnss.sum + costs.zero_motion.sum + costs.report.sum;
        let total = aided.step.sum + aided.messages.sum + background;
        defmt::info!(
            "instructions per covariance propagation: max {=u64}, mean {=u64} ({=u64}); per GNSS update (position or velocity): max {=u64}, mean {=u64} ({=u64}); per stop update: max {=u64}, mean {=u64} ({=u64}); per report: max {=u64}, mean {=u64}",
            costs.propagation.max,
            costs.propagation.mean(),
            costs.propagation.n,
            costs.gnss.max,
            costs.gnss.mean(),
            costs.gnss.n,
            costs.zero_motion.max,
            costs.zero_motion.mean(),
            costs.zero_motion.n,
            costs.report.max,
            costs.report.mean()
        );
        defmt::info!(
            "instructions per aided sample: mechanization max {=u64}, mean {=u64}; the sample's filter messages (foreground) max {=u64}, mean {=u64}; amortised total {=u64} over {=u64} samples (rows: {=u32})",
            aided.step.max,
            aided.step.mean(),
            aided.messages.max,
            aided.messages.mean(),
            total / steps,
            steps,
            summary.counters.rows
        );
        total / steps
    }

    /// Hands the background's `answer` to the navigator: the aligned row is logged; a failure
    /// ends the run.
    #[inline(never)]
    fn answer_from_background(
        navigator: &mut Navigator<f32>,
        answer: FromBackground<f32>,
        out: &mut Outputs,
        imu: &ImuStats,
    ) {
        match navigator.on_background(answer) {
            Ok(Some(row)) => {
                if let Some(outcome) = navigator.alignment() {
                    log::aligned(outcome);
                }
                out.row(row);
            }
            Ok(None) => {}
            Err(e) => failed(&e, imu, out),
        }
    }

    /// Exits with `code` after sending the frames the qemu board's stream still queues: an error
    /// exit lost up to a chunk of them (the decoded stream ended a row before the log's last).
    /// The real board's UART sends as it goes.
    fn stop(out: &mut Outputs, code: ExitCode) -> ! {
        #[cfg(feature = "qemu")]
        if out.out.flush().is_err() {
            defmt::error!("cannot write the output stream");
        }
        #[cfg(not(feature = "qemu"))]
        let _ = out;
        exit(code)
    }

    /// Logs why the run could not navigate (with the counts by cause) and exits with
    /// [`ExitCode::NothingNavigated`] or [`ExitCode::Alignment`]. The solution log is left
    /// without its end record.
    #[inline(never)]
    fn failed(e: &NavError, imu: &ImuStats, out: &mut Outputs) -> ! {
        defmt::error!("{}", errors::Nav(e));
        log_imu_costs(imu);
        stop(
            out,
            match e {
                NavError::NothingNavigated { .. } => ExitCode::NothingNavigated,
                NavError::Alignment { .. }
                | NavError::EndedDuringAlignment { .. }
                | NavError::GapDuringAlignment { .. }
                | NavError::Filter(_) => ExitCode::Alignment,
            },
        )
    }

    /// Alignment, below navigation (RTIC's idle, the lowest priority): the navigator's
    /// background on the forwarded increments; logs its stage changes and cost, and answers.
    /// After the alignment, in an aided run, the navigation filter's covariance: propagations
    /// and updates, their costs kept for `navigate`'s summary.
    ///
    /// The background (the alignment filters, some 55 KB in `f32`) lives on this task's
    /// stack: idle never returns, so its frame is as permanent as a static, and the board's
    /// static RAM stays small (the stack's peak is what counts; the qemu board reports it).
    /// Idle sleeps (`wfi`) when no message waits.
    #[idle(local = [setup_rx, from_navigate_align, from_navigate, to_navigate], shared = [costs, alignment])]
    fn align(mut cx: align::Context) -> ! {
        // The run's settings, once `navigate` has decided them (standby).
        let setup = receive(cx.local.setup_rx);
        let mut slot = None;
        let background = start_background(&mut slot, &setup);
        let (from_navigate_align, from_navigate, to_navigate) = (
            cx.local.from_navigate_align,
            cx.local.from_navigate,
            cx.local.to_navigate,
        );
        let settings = *background.settings();
        defmt::info!(
            "aligning: {=str}, {=u32} samples; stage COARSE",
            settings.method.name(),
            settings.samples
        );
        let mut stage = background.stage();
        let mut cost = StepCost::default();
        loop {
            let inc = receive(from_navigate_align);
            let start = board::counts();
            let answer = background.handle(ToBackground::Align(inc));
            cost.add(instructions_since(start));
            let progress = (background.stage(), background.samples());
            cx.shared.alignment.lock(|a| *a = progress);
            if background.stage() != stage {
                stage = background.stage();
                if stage == Stage::Fine {
                    defmt::info!(
                        "alignment stage FINE after {=u32} samples",
                        background.samples()
                    );
                }
            }
            let Some(answer) = answer else { continue };
            // Preemption by sampling and navigation counts in too: an upper bound.
            defmt::info!(
                "instructions per alignment sample ({=str}): max {=u64}, mean {=u64}",
                settings.method.name(),
                cost.max,
                cost.mean()
            );
            let aligned = matches!(answer, FromBackground::Aligned(_));
            answer_navigate(to_navigate, answer);
            if aligned {
                break;
            }
        }
        // An aided run: the navigation filter's covariance, on the aided phase's messages
        // (none without nav-core's filter: nothing left to do).
        if !AIDED_COMPILED_IN {
            loop {
                cortex_m::asm::wfi();
            }
        }
        loop {
            let message = receive(from_navigate);
            let kind = FilterCosts::kind(&message);
            let start = board::counts();
            let answer = background.handle(message);
            let spent = instructions_since(start);
            cx.shared.costs.lock(|c| kind(c).add(spent));
            if let Some(answer) = answer {
                answer_navigate(to_navigate, answer);
            }
        }
    }

    /// The next message on `rx`, sleeping until an interrupt while there is none. The check
    /// and the `wfi` run with interrupts masked, so a message sent in between cannot be
    /// missed: a pending interrupt wakes `wfi` even when masked, and runs once they are
    /// unmasked.
    fn receive<T, const N: usize>(rx: &mut Receiver<'static, T, N>) -> T {
        loop {
            match rx.try_recv() {
                Ok(value) => return value,
                Err(rtic_sync::channel::ReceiveError::Empty) => {
                    cortex_m::interrupt::free(|_| {
                        if rx.is_empty() {
                            cortex_m::asm::wfi();
                        }
                    });
                }
                Err(_) => defmt::panic!("background channel closed"),
            }
        }
    }

    /// Hands `answer` to `navigate`, sleeping while its one-message channel is full.
    fn answer_navigate(
        to_navigate: &mut Sender<'static, FromBackground<f32>, 1>,
        mut answer: FromBackground<f32>,
    ) {
        loop {
            match to_navigate.try_send(answer) {
                Ok(()) => return,
                Err(rtic_sync::channel::TrySendError::Full(back)) => {
                    answer = back;
                    cortex_m::interrupt::free(|_| {
                        if to_navigate.is_full() {
                            cortex_m::asm::wfi();
                        }
                    });
                }
                Err(_) => defmt::panic!("background answer channel closed"),
            }
        }
    }

    /// Builds the background in `slot` (idle's stack). Not inlined: building it takes a
    /// temporary of some 19 KB, which must not stay in idle's frame under the fine
    /// alignment's deepest path.
    #[inline(never)]
    fn start_background<'a>(
        slot: &'a mut Option<Background<f32>>,
        setup: &Setup<f32>,
    ) -> &'a mut Background<f32> {
        slot.insert(Background::new(setup))
    }

    #[inline(never)]
    fn write_line(out: &mut Output, value: impl core::fmt::Display) {
        let ok = line(value).is_some_and(|l| out.write(l.as_bytes()).is_ok());
        if !ok {
            defmt::error!("cannot write the solution log");
            exit(ExitCode::Output);
        }
    }

    /// Logs the instructions of one 400 Hz cycle: the data-ready latency, the output stream's
    /// work per sample, and the mean cycle (IMU read, navigation step with its rows, output
    /// stream with the rows' frames amortised) against the budget: 5 % of a 168 MHz core at
    /// 400 Hz, 21,000 instructions (one instruction taken as one cycle). The navigation of an
    /// aided run is its aided phase's amortised total (`aided_per_sample`: mechanization and
    /// filter), else the free-inertial step's mean.
    #[inline(never)]
    fn log_cycle(
        cost: &StepCost,
        row_cost: &StepCost,
        aided_per_sample: Option<u64>,
        imu: &ImuStats,
        out: &Outputs,
    ) {
        let samples = out.cost.n.max(1);
        let stream = (out.cost.sum + out.row_cost.sum) / samples;
        let nav_steps = (cost.n + row_cost.n).max(1);
        let nav = aided_per_sample.unwrap_or((cost.sum + row_cost.sum) / nav_steps);
        let read = imu.bus.mean() + imu.decode.mean();
        defmt::info!(
            "data-ready latency (line to sample queued, the bus transaction included): max {=u32} instructions",
            READY_LATENCY_MAX.load(Ordering::Relaxed)
        );
        defmt::info!(
            "instructions per sample of the output stream: max {=u64}, mean {=u64}; per solution row frame: max {=u64}, mean {=u64}",
            out.cost.max,
            out.cost.mean(),
            out.row_cost.max,
            out.row_cost.mean()
        );
        defmt::info!(
            "instructions per 400 Hz cycle (mean): IMU read {=u64} + navigation {=u64} + output stream {=u64} = {=u64} of 21000 (5 % of 168 MHz)",
            read,
            nav,
            stream,
            read + nav + stream
        );
    }

    #[inline(never)]
    fn log_imu_costs(imu: &ImuStats) {
        defmt::info!(
            "instructions per IMU read: decode + conversion max {=u64}, mean {=u64}; bus transaction (simulated device included) max {=u64}, mean {=u64}",
            imu.decode.max,
            imu.decode.mean(),
            imu.bus.max,
            imu.bus.mean()
        );
    }

    #[inline(never)]
    fn report(
        cost: &StepCost,
        row_cost: &StepCost,
        imu: &ImuStats,
        aligned: &AlignOutcome<f32>,
        last: &Solution,
    ) {
        // The gate, the calibration and the mechanization; a logged step adds its row's
        // conversion to output units.
        defmt::info!(
            "instructions per navigation step: max {=u64}, mean {=u64}; with a solution row: max {=u64}, mean {=u64}",
            cost.max,
            cost.mean(),
            row_cost.max,
            row_cost.mean()
        );
        log::health(&imu.health);
        log_imu_costs(imu);
        log::end(aligned, last);
    }
}
