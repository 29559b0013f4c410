//! The navigation firmware: an RTIC 2 app for an STM32F405 IMU board (QEMU netduinoplus2 for now).
//!
//! A sample's way: data-ready interrupt (`data_ready`, highest priority) -> `rtic_sync` channel ->
//! `navigate` (nav-core's navigator: gate, calibration, strapdown; writes the solution log) ->
//! what it forwards to `align` (lowest priority: the navigator's background, the alignment) ->
//! the answer back to `navigate`, which starts navigating from the aligned state. With `--gnss
//! FILE` the navigation after the alignment is aided: `navigate` reads the fixes from the host
//! file (`firmware::gnss`), hands each to the navigator before the first sample at or after its
//! time, runs the filter's mechanization, and forwards the filter's work (covariance
//! propagations, GNSS and stop updates, reports for rows) to `align`, which runs the filter's
//! covariance; `navigate` waits for each update's answer before its next sample (the sample
//! channel fills meanwhile). The rules are all in `nav_core::navigator`; these tasks only carry
//! samples, fixes, messages and rows.
//!
//! On the `qemu` board the IMU's data-ready line is emulated: the `pace` task pends `EXTI0` (the
//! line a real data-ready pin uses) every 2.5 ms of SysTick time, and `data_ready` reads the next
//! sample of a recording through semihosting. Under QEMU's `-icount shift=0` one guest instruction
//! takes exactly 1 ns of virtual time, so SysTick timing is exact and the instruction counts this
//! firmware prints are repeatable.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

#[cfg(not(feature = "qemu"))]
compile_error!(
    "only the `qemu` board exists until the SPI IMU drivers land; build with --features qemu"
);

use firmware as _; // logger, panic and HardFault handlers

defmt::timestamp!("{=u64:us}", app::now_us());

#[rtic::app(device = stm32f4::stm32f405, peripherals = true, dispatchers = [USART1, USART2, USART3])]
mod app {
    use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
    use cortex_m::peripheral::{NVIC, SYST};
    use embedded_io::Write as _;
    use firmware::gnss::{self, Fixes};
    use firmware::imu::{BoardImu, nav_input};
    use firmware::{
        ExitCode, FilterCosts, StepCost,
        config::{Args, USAGE},
        exit, line, log,
    };
    use hal_adapters::ImuSample;
    use hal_adapters::drivers::{Error as ImuError, Health};
    use hal_adapters::io::{Buffered, SemihostingFile};
    use hal_adapters::recording::Replay;
    use hal_adapters::sim::{SimBmi088, SimError, health_at_end};
    use nav_core::ImuIncrement;
    use nav_core::alignment::{AlignOutcome, Stage};
    use nav_core::calibration::ImuCalibration;
    use nav_core::navigator::{
        Background, FromBackground, NavError, Navigator, Setup, Step, Summary, ToBackground,
    };
    use nav_core::output::{AIDED_CSV_HEADER, CSV_HEADER, Solution};
    use rtic_monotonics::systick::prelude::*;
    use rtic_sync::channel::{Receiver, Sender};
    use rtic_sync::make_channel;
    use stm32f4::stm32f405::Interrupt;

    /// Core clock [Hz]: 168 MHz on the real board and in QEMU's netduinoplus2.
    const SYSCLK_HZ: u32 = 168_000_000;
    /// SysTick monotonic rate [Hz]: one tick (and one SysTick interrupt) per data-ready period;
    /// finer times read the SysTick counter (`systick_counts`). Under QEMU every timer interrupt
    /// costs host time, so fewer ticks make the replay 2.5x faster than 2 kHz ticks did.
    const TICK_HZ: u32 = 400;
    systick_monotonic!(Mono, 400);
    /// SysTick counts per monotonic tick.
    const COUNTS_PER_TICK: u64 = (SYSCLK_HZ / TICK_HZ) as u64;
    /// The IMU's data-ready period: 400 Hz.
    const DATA_READY_TICKS: u64 = (TICK_HZ / 400) as u64;
    /// A duration in monotonic ticks.
    type MonoDuration = fugit::Duration<u64, 1, 400>;

    const SAMPLE_CAP: usize = 16;
    /// Alignment increments queued for `align` (its fine stage's fits lag behind).
    const ALIGN_CAP: usize = 32;
    /// The aided phase's messages queued for `align`: propagations, then an update or report
    /// `navigate` waits for (a separate channel: its messages are 6 times an increment's
    /// size).
    const FILTER_CAP: usize = 2;
    /// Bytes read from the host per semihosting call.
    const READ_CHUNK: usize = 512;

    /// The recording the simulated IMU answers from.
    type Recording = Replay<Buffered<SemihostingFile, READ_CHUNK>>;

    /// What the data-ready interrupt hands to navigation.
    pub enum DataReady {
        /// A sample, its data-ready time on the board's clock [us], and the guest instructions
        /// of its bus transaction and of its decoding.
        Sample {
            sample: ImuSample,
            t_ready_us: u64,
            bus_instr: u32,
            decode_instr: u32,
        },
        /// The recording ended; the driver's final counters.
        End { health: Health },
        /// The source failed (already logged).
        SourceError,
    }

    /// Samples lost because the channel to `navigate` was full.
    static OVERRUNS: AtomicU32 = AtomicU32::new(0);
    /// Data-ready edges lost because the previous one was still pending.
    static MISSED: AtomicU32 = AtomicU32::new(0);
    /// Set once the end of the recording has been delivered: the pacer stops.
    static STOP: AtomicBool = AtomicBool::new(false);

    #[shared]
    struct Shared {
        /// The background's filter work costs (written by `align`, read by `navigate` at the
        /// end).
        costs: FilterCosts,
    }

    #[local]
    struct Local {
        imu: BoardImu<Recording>,
        samples_tx: Sender<'static, DataReady, SAMPLE_CAP>,
        /// The navigator's foreground, for `navigate`.
        navigator: Navigator<f32>,
        /// The solution log, for `navigate`.
        out: SemihostingFile,
        /// The GNSS fixes and their number, for `navigate` (an aided run).
        gnss: Option<(Fixes, u32)>,
        /// The run's settings, for `align` (which builds the background from them).
        setup: Setup<f32>,
    }

    #[init(local = [bmi_sim: Option<SimBmi088<Recording>> = None])]
    fn init(cx: init::Context) -> (Shared, Local) {
        // The qemu board has no RCC model: clock set-up would hang, so it is skipped and the
        // core runs at QEMU's fixed 168 MHz.
        Mono::start(cx.core.SYST, SYSCLK_HZ);
        let mut args = read_args();
        if let Err(e) = args.run.validate() {
            bad_config(&e)
        }
        args.run.calibration = read_calibration(&args);
        let run = args.run;
        log::config(&run);
        let file = SemihostingFile::open(args.imu_cstr()).unwrap_or_else(|_| {
            defmt::error!(
                "cannot open the recording {=[u8]:a}",
                args.imu_path.as_slice()
            );
            exit(ExitCode::Recording)
        });
        let source = Replay::new(Buffered::new(file)).unwrap_or_else(|e| {
            defmt::error!(
                "recording {=[u8]:a}: {}",
                args.imu_path.as_slice(),
                defmt::Display2Format(&e)
            );
            exit(ExitCode::Recording)
        });
        let header = *source.header();
        defmt::info!(
            "recording: {=u32} samples at {=f64} Hz",
            header.sample_count,
            header.rate_hz
        );
        let setup = Setup::<f32>::new(&run, header.rate_hz).unwrap_or_else(|e| bad_config(&e));
        let device = args.device;
        let imu = BoardImu::new(device, source, cx.local.bmi_sim).unwrap_or_else(|e| {
            defmt::error!("IMU {} init failed: {}", device, e);
            exit(ExitCode::Recording)
        });
        defmt::info!("IMU: {} over a simulated SPI device", device);
        let mut out = SemihostingFile::create(args.out_cstr()).unwrap_or_else(|_| {
            defmt::error!(
                "cannot create the solution log {=[u8]:a}",
                args.out_path.as_slice()
            );
            exit(ExitCode::Output)
        });
        let gnss = args.gnss_cstr().map(|path| {
            let fail = |e: &dyn core::fmt::Display| -> ! {
                let name = args.gnss_path.as_deref().unwrap_or_default();
                let name = name.strip_suffix(&[0]).unwrap_or(name);
                defmt::error!(
                    "GNSS file {=str}: {}",
                    core::str::from_utf8(name).unwrap_or("(not UTF-8)"),
                    defmt::Display2Format(e)
                );
                exit(ExitCode::Recording)
            };
            // Checked whole before anything is navigated, then read as the samples come.
            let count = gnss::check(path).unwrap_or_else(|e| fail(&e));
            let fixes = Fixes::open(path).unwrap_or_else(|e| fail(&e));
            log::gnss(count, &run, FILTER_CAP);
            (fixes, count)
        });
        let header = if run.aiding.is_some() {
            AIDED_CSV_HEADER
        } else {
            CSV_HEADER
        };
        write_line(&mut out, header);

        let (samples_tx, samples_rx) = make_channel!(DataReady, SAMPLE_CAP);
        let (to_align, from_navigate_align) = make_channel!(ImuIncrement<f32>, ALIGN_CAP);
        let (to_filter, from_navigate) = make_channel!(ToBackground<f32>, FILTER_CAP);
        let (to_navigate, from_background) = make_channel!(FromBackground<f32>, 1);
        if navigate::spawn(samples_rx, to_align, to_filter, from_background).is_err()
            || align::spawn(from_navigate_align, from_navigate, to_navigate).is_err()
            || pace::spawn().is_err()
        {
            defmt::panic!("task spawn failed");
        }
        let navigator = Navigator::new(&setup);
        (
            Shared {
                costs: FilterCosts::default(),
            },
            Local {
                imu,
                samples_tx,
                navigator,
                out,
                gnss,
                setup,
            },
        )
    }

    /// Sleeps between interrupts (under QEMU's `sleep=off` the idle time then costs no host time).
    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// Parses the semihosting command line into the firmware's [`Args`]; exits with
    /// [`ExitCode::Config`] on error.
    fn read_args() -> Args {
        let args = semihosting::experimental::env::args::<512>().unwrap_or_else(|_| {
            defmt::error!("no semihosting command line: run through firmware/qemu-run.sh");
            exit(ExitCode::Config)
        });
        let mut words = (&args).map(|a| a.unwrap_or("")).skip(1).peekable();
        // Diagnostics: `--crash panic|hardfault` checks that failures reach the exit status.
        if words.peek() == Some(&"--crash") {
            match words.nth(1) {
                Some("panic") => panic!("crash test requested"),
                Some("hardfault") => cortex_m::asm::udf(),
                _ => {}
            }
        }
        // Benchmark: the gyro-free oscillator estimator ([Oscillator INS]) on synthetic readouts.
        if words.peek() == Some(&"--osc-bench") {
            firmware::osc_bench::run();
            exit(ExitCode::Success)
        }
        Args::parse(words).unwrap_or_else(|e| {
            defmt::error!(
                "bad arguments ({}); usage: {=str}",
                defmt::Display2Format(&e),
                USAGE
            );
            exit(ExitCode::Config)
        })
    }

    /// Logs a refused run configuration and exits with [`ExitCode::Config`].
    fn bad_config(e: &dyn core::fmt::Display) -> ! {
        defmt::error!("invalid configuration: {}", defmt::Display2Format(e));
        exit(ExitCode::Config)
    }

    /// Loads the sensor calibration (identity without a file); exits with
    /// [`ExitCode::Config`] when it cannot be read or parsed.
    fn read_calibration(args: &Args) -> ImuCalibration {
        let Some(path) = args.cal_cstr() else {
            return ImuCalibration::default();
        };
        let fail = |what: &dyn core::fmt::Display| -> ! {
            defmt::error!(
                "calibration {=[u8]:a}: {}",
                args.cal_path.as_deref().unwrap_or_default(),
                defmt::Display2Format(what)
            );
            exit(ExitCode::Config)
        };
        let mut file = SemihostingFile::open(path).unwrap_or_else(|_| fail(&"cannot open"));
        let mut text = [0_u8; 2048];
        let mut len = 0;
        loop {
            match embedded_io::Read::read(&mut file, &mut text[len..]) {
                Ok(0) => break,
                Ok(n) => len += n,
                Err(_) => fail(&"read error"),
            }
            if len == text.len() {
                fail(&"longer than 2048 bytes");
            }
        }
        let text = core::str::from_utf8(&text[..len]).unwrap_or_else(|_| fail(&"not UTF-8 text"));
        let calibration = ImuCalibration::parse(text).unwrap_or_else(|e| fail(&e));
        if let Err(e) = calibration.compensation::<f32>() {
            fail(&e)
        }
        defmt::info!("calibration loaded: {=usize} bytes", len);
        calibration
    }

    /// SysTick counts since start (monotonic ticks plus the counter's progress in this tick).
    fn systick_counts() -> u64 {
        loop {
            let before = Mono::now().as_ticks();
            let current = u64::from(SYST::get_current());
            if Mono::now().as_ticks() == before {
                return before * COUNTS_PER_TICK + (COUNTS_PER_TICK - 1 - current);
            }
        }
    }

    /// Board time since start [us] (also the defmt timestamp).
    pub fn now_us() -> u64 {
        systick_counts() / u64::from(SYSCLK_HZ / 1_000_000)
    }

    /// Guest instructions in `counts` SysTick counts: 1 ns per instruction under QEMU's
    /// `-icount shift=0`, 168 counts per us.
    fn counts_to_instructions(counts: u64) -> u64 {
        counts * 1_000_000_000 / u64::from(SYSCLK_HZ)
    }

    /// Emulated data-ready line: pends `EXTI0` every 2.5 ms, exactly.
    #[task(priority = 3)]
    async fn pace(_: pace::Context) {
        let mut next = Mono::now();
        while !STOP.load(Ordering::Relaxed) {
            next += MonoDuration::from_ticks(DATA_READY_TICKS);
            Mono::delay_until(next).await;
            if NVIC::is_pending(Interrupt::EXTI0) {
                MISSED.fetch_add(1, Ordering::Relaxed);
            }
            rtic::pend(Interrupt::EXTI0);
        }
    }

    /// IMU data ready: timestamp, read one sample through the driver, hand it on. Never blocks.
    #[task(binds = EXTI0, priority = 4, local = [imu, samples_tx, done: bool = false])]
    fn data_ready(cx: data_ready::Context) {
        let t_ready_us = now_us();
        if *cx.local.done {
            return;
        }
        let imu = cx.local.imu;
        let read = imu.read(t_ready_us, systick_counts);
        let (msg, last) = match read.result {
            Ok(sample) => (
                DataReady::Sample {
                    sample,
                    t_ready_us,
                    bus_instr: counts_to_instructions(read.bus_counts) as u32,
                    decode_instr: counts_to_instructions(read.decode_counts) as u32,
                },
                false,
            ),
            Err(ImuError::Spi(SimError::End)) => {
                // The simulated device ends the recording by failing the bus: not a bus error.
                let health = health_at_end(imu.health());
                (DataReady::End { health }, true)
            }
            Err(ImuError::Spi(SimError::Source(e))) => {
                defmt::error!("recording: {}", defmt::Display2Format(&e));
                (DataReady::SourceError, true)
            }
            Err(e) if e.is_transient() => {
                // A corrupt frame: counted in the driver's health, nothing to navigate.
                let n = imu.health().checksum_errors;
                if n <= 10 || n.is_multiple_of(1000) {
                    defmt::warn!("IMU frame rejected: {} ({=u32} so far)", e, n);
                }
                return;
            }
            Err(e) => {
                defmt::error!("IMU failed: {}", e);
                (DataReady::SourceError, true)
            }
        };
        match cx.local.samples_tx.try_send(msg) {
            Ok(()) if last => {
                *cx.local.done = true;
                STOP.store(true, Ordering::Relaxed);
            }
            Ok(()) => {}
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

    /// Navigation: carries every sample (and, aided, every GNSS fix) through nav-core's
    /// navigator, forwards what it asks to the background (`align`), hands it the answers, and
    /// writes the rows it produces.
    #[task(priority = 2, local = [navigator, out, gnss], shared = [costs])]
    async fn navigate(
        mut cx: navigate::Context,
        mut samples_rx: Receiver<'static, DataReady, SAMPLE_CAP>,
        mut to_align: Sender<'static, ImuIncrement<f32>, ALIGN_CAP>,
        mut to_filter: Sender<'static, ToBackground<f32>, FILTER_CAP>,
        mut from_background: Receiver<'static, FromBackground<f32>, 1>,
    ) {
        let navigator = cx.local.navigator;
        let out = cx.local.out;
        // By reference: the task's future holds no second copy of the reader.
        let gnss = cx.local.gnss;
        // Steps without a row, and steps with one (the row's f64 output conversion included).
        let (mut cost, mut row_cost) = (StepCost::default(), StepCost::default());
        let mut aided = AidedCosts::default();
        let mut imu = ImuStats::default();
        let mut last_ready_us = 0_u64;
        loop {
            let Ok(msg) = samples_rx.recv().await else {
                defmt::panic!("sample channel closed");
            };
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
                DataReady::SourceError => exit(ExitCode::Recording),
                DataReady::End { health } => {
                    imu.health = health;
                    break;
                }
            };
            last_ready_us = t_ready_us;
            // An early failure of the alignment (its success comes when awaited, below).
            if navigator.is_aligning()
                && let Ok(answer) = from_background.try_recv()
            {
                answer_from_background(navigator, answer, out, &imu);
            }
            // The GNSS fixes due at this sample first.
            if let Some((fixes, _)) = gnss.as_mut() {
                loop {
                    match fixes.due(sample.t_us) {
                        Ok(Some(fix)) => {
                            navigator.push_fix(fix);
                        }
                        Ok(None) => break,
                        Err(e) => {
                            defmt::error!("GNSS file: {}", defmt::Display2Format(&e));
                            exit(ExitCode::Recording)
                        }
                    }
                }
            }
            let start = systick_counts();
            let step = navigator.push(&nav_input(&sample));
            let spent = counts_to_instructions(systick_counts() - start);
            match step {
                Step::Navigated(None) => cost.add(spent),
                Step::Navigated(Some(row)) => {
                    row_cost.add(spent);
                    write_line(out, row);
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
                Step::Flagged => {
                    let n = navigator.counters().flagged;
                    // The first ten, then every thousandth: a failing sensor must not flood the log.
                    if n <= 10 || n.is_multiple_of(1000) {
                        defmt::warn!(
                            "sample {=u32} flagged {}: not navigated ({=u32} so far)",
                            sample.seq,
                            sample.flags,
                            n
                        );
                    }
                }
                Step::Aided => {
                    aided.step.add(spent);
                    let work =
                        background_work(navigator, &mut to_filter, &mut from_background, out, &imu)
                            .await;
                    aided.messages.add(work);
                }
                Step::Rejected(_) => {}
                // Not reached: every answer is awaited before the next sample.
                Step::NotReady => defmt::panic!("navigator not ready"),
            }
        }

        // End of the recording: the last row (aided: with the filter's report), then the end
        // record (only a complete run has it).
        navigator.end_of_data();
        background_work(navigator, &mut to_filter, &mut from_background, out, &imu).await;
        let summary = navigator.finish().unwrap_or_else(|e| {
            log::health(&imu.health);
            failed(&e, &imu)
        });
        if let Some(row) = summary.final_row {
            write_line(out, row);
        }
        write_line(out, summary.end_record());
        let c = summary.counters;
        defmt::info!(
            "summary: samples {=u32}, flagged {=u32} ({}), rejected {=u32}, navigated {=u32}, missed {=u32}, channel overruns {=u32}, last data-ready at {=u64} us",
            c.samples,
            c.flagged,
            defmt::Display2Format(&c.flagged_by),
            c.rejected,
            c.nav_steps,
            MISSED.load(Ordering::Relaxed),
            OVERRUNS.load(Ordering::Relaxed),
            last_ready_us
        );
        if let Some(filter) = &summary.filter {
            let after_data = gnss.as_ref().map_or(0, |(f, n)| f.remaining(*n));
            log::filter(filter, &summary.fixes, c.fixes_unused, after_data);
            let costs = cx.shared.costs.lock(|c| *c);
            log_aided_costs(&aided, &costs, &summary);
        }
        report(
            &cost,
            &row_cost,
            &imu,
            &summary.alignment,
            &summary.last_solution,
        );
        exit(ExitCode::Success)
    }

    /// Forwards the navigator's work for the background ([`Navigator::next_message`]) and
    /// waits for each answered message's answer, writing the row an answer completes; returns
    /// the foreground's instructions in it (the waits for the background not counted).
    async fn background_work(
        navigator: &mut Navigator<f32>,
        to_background: &mut Sender<'static, ToBackground<f32>, FILTER_CAP>,
        from_background: &mut Receiver<'static, FromBackground<f32>, 1>,
        out: &mut SemihostingFile,
        imu: &ImuStats,
    ) -> u64 {
        let mut spent = 0;
        loop {
            let start = systick_counts();
            let message = navigator.next_message();
            spent += counts_to_instructions(systick_counts() - start);
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
            let start = systick_counts();
            let row = navigator.on_background(answer);
            spent += counts_to_instructions(systick_counts() - start);
            match row {
                Ok(Some(row)) => write_line(out, row),
                Ok(None) => {}
                Err(e) => failed(&e, imu),
            }
        }
    }

    /// Logs the aided phase's costs: per propagation and update (the background), and the
    /// total per sample amortised over the aided samples.
    #[inline(never)]
    fn log_aided_costs(aided: &AidedCosts, costs: &FilterCosts, summary: &Summary<f32>) {
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
    }

    /// Hands the background's `answer` to the navigator: the aligned row is logged; a failure
    /// ends the run.
    #[inline(never)]
    fn answer_from_background(
        navigator: &mut Navigator<f32>,
        answer: FromBackground<f32>,
        out: &mut SemihostingFile,
        imu: &ImuStats,
    ) {
        match navigator.on_background(answer) {
            Ok(Some(row)) => {
                if let Some(outcome) = navigator.alignment() {
                    log::aligned(outcome);
                }
                write_line(out, row);
            }
            Ok(None) => {}
            Err(e) => failed(&e, imu),
        }
    }

    /// Logs why the run could not navigate (with the counts by cause) and exits with
    /// [`ExitCode::NothingNavigated`] or [`ExitCode::Alignment`]. The solution log is left
    /// without its end record.
    #[inline(never)]
    fn failed(e: &NavError, imu: &ImuStats) -> ! {
        defmt::error!("{}", defmt::Display2Format(e));
        log_imu_costs(imu);
        exit(match e {
            NavError::NothingNavigated { .. } => ExitCode::NothingNavigated,
            NavError::Alignment { .. }
            | NavError::EndedDuringAlignment { .. }
            | NavError::Filter(_) => ExitCode::Alignment,
        })
    }

    /// Alignment, below navigation: the navigator's background on the forwarded increments;
    /// logs its stage changes and cost, and answers.
    /// The background (the alignment filters, some 45 KB in `f32`) lives in the task's static
    /// slot, not on its stack; the fine stage's filters (`sway` included) are started there in
    /// place (`nav_core::alignment::fine::Blank`), never built on the stack.
    /// After the alignment, in an aided run, the navigation filter's covariance: propagations
    /// and updates, their costs kept for `navigate`'s summary.
    #[task(priority = 1, local = [setup, background: Option<Background<f32>> = None], shared = [costs])]
    async fn align(
        mut cx: align::Context,
        mut from_navigate_align: Receiver<'static, ImuIncrement<f32>, ALIGN_CAP>,
        mut from_navigate: Receiver<'static, ToBackground<f32>, FILTER_CAP>,
        mut to_navigate: Sender<'static, FromBackground<f32>, 1>,
    ) {
        let background = start_background(cx.local.background, cx.local.setup);
        let settings = *background.settings();
        defmt::info!(
            "aligning: {=str}, {=u32} samples; stage COARSE",
            settings.method.name(),
            settings.samples
        );
        let mut stage = background.stage();
        let mut cost = StepCost::default();
        while let Ok(inc) = from_navigate_align.recv().await {
            let start = systick_counts();
            let answer = background.handle(ToBackground::Align(inc));
            cost.add(counts_to_instructions(systick_counts() - start));
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
            if to_navigate.send(answer).await.is_err() {
                defmt::panic!("alignment result channel closed");
            }
            if aligned {
                break;
            }
        }
        // An aided run: the navigation filter's covariance, on the aided phase's messages.
        while let Ok(message) = from_navigate.recv().await {
            let kind = FilterCosts::kind(&message);
            let start = systick_counts();
            let answer = background.handle(message);
            let spent = counts_to_instructions(systick_counts() - start);
            cx.shared.costs.lock(|c| kind(c).add(spent));
            if let Some(answer) = answer
                && to_navigate.send(answer).await.is_err()
            {
                defmt::panic!("background answer channel closed");
            }
        }
    }

    /// Builds the background in the `align` task's static slot. Not inlined: building it
    /// takes a temporary of some 19 KB, which must not stay in the task's frame under the fine
    /// alignment's deepest path (there it left 3 KB of the stack free).
    #[inline(never)]
    fn start_background<'a>(
        slot: &'a mut Option<Background<f32>>,
        setup: &Setup<f32>,
    ) -> &'a mut Background<f32> {
        slot.insert(Background::new(setup))
    }

    #[inline(never)]
    fn write_line(out: &mut SemihostingFile, value: impl core::fmt::Display) {
        let ok = line(value).is_some_and(|l| out.write_all(l.as_bytes()).is_ok());
        if !ok {
            defmt::error!("cannot write the solution log");
            exit(ExitCode::Output);
        }
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
