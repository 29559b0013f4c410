//! The `stm32f405` board: an STM32F405RG module on `stm32f4xx-hal`, all its pins and its IMU
//! here.
//!
//! | function | peripheral | pins |
//! |---|---|---|
//! | clocks | 8 MHz HSE, PLL to 168 MHz SYSCLK (APB1 42 MHz, timers 84 MHz) | PH0, PH1 |
//! | IMU: ADIS16505 ([`Device::BOARD`]) | SPI1, mode 3, 1 MHz (the burst's limit) | SCK PA5, MISO PA6, MOSI PA7 |
//! | IMU chip select | GPIO through `embedded-hal-bus`'s `ExclusiveDevice` (stall delays: TIM5) | PA4 |
//! | IMU data ready | EXTI0, rising edge, bound to the app's `data_ready` task | PB0 |
//! | timestamps | TIM2, 32-bit, 1 MHz: the RTIC monotonic (`rtic-monotonics`' `stm32_tim2`) | - |
//! | output stream, configuration input | USART1, 460 800 Bd, TX on DMA2 stream 7, RX on DMA2 stream 2 | TX PA9, RX PA10 |
//! | watchdog | IWDG, [`WATCHDOG_MS`], fed by `navigate` at every sample | - |
//! | cost figures | DWT cycle counter (core cycles) | - |
//!
//! At start the board is in standby for [`STANDBY_US`]: a configuration frame from the host
//! over the USART ([`ConfigInput`]), decoded, checked and acknowledged by `navigate`, gives the
//! run's configuration; without one the compiled-in run ([`default_run`]) runs, flagged to the
//! host (`DEFAULT_CONFIG`). The configuration is not stored across a restart. The output
//! protocol's frames leave on the USART ([`Output`]); defmt goes out over RTT (probe-rs).

use super::{Board, DataReady, pac};
use crate::ExitCode;
use crate::imu::Device;
use cortex_m::peripheral::{DCB, DWT, SCB};
use defmt_rtt as _; // global defmt logger over RTT
use embedded_dma::ReadBuffer;
use embedded_hal_bus::spi::ExclusiveDevice;
use hal_adapters::drivers::adis16505::{self as adis, Adis16505};
use hal_adapters::drivers::{Health, Mounting};
use hal_adapters::protocol::config::{BoardIdentity, ImuModel};
use nav_core::navigator::{RunConfig, Setup};
use rtic_monotonics::stm32::prelude::*;
use stm32f4xx_hal::dma::config::DmaConfig;
use stm32f4xx_hal::dma::{
    DMAError, MemoryToPeripheral, PeripheralToMemory, Stream2, Stream7, StreamsTuple, Transfer,
};
use stm32f4xx_hal::gpio::{Edge, ExtiPin, Input, Output as Pin, PA4, PB0};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config as ClockConfig;
use stm32f4xx_hal::serial::{self, Rx, Serial, Tx};
use stm32f4xx_hal::spi::{Mode, Phase, Polarity, Spi};
use stm32f4xx_hal::timer::Delay;
use stm32f4xx_hal::watchdog::IndependentWatchdog;

stm32_tim2_monotonic!(Mono, 1_000_000);

/// The IMU's output rate [Hz] (the ADIS16505 decimated to 400 Hz by its driver's `init`).
const IMU_RATE_HZ: f64 = 400.0;
/// The IMU's mounting: its axes are the body's.
const MOUNTING: Mounting = Mounting::IDENTITY;
/// The watchdog's period [ms]: longer than `navigate`'s longest wait for the background (the
/// alignment's answer after its queued increments).
pub const WATCHDOG_MS: u32 = 500;
/// USART1's rate [Bd].
const BAUD: u32 = 460_800;
/// Bytes per output DMA transfer (two buffers: one sent, one filled).
const TX_LEN: usize = 512;
/// Bytes per configuration DMA transfer.
const RX_LEN: usize = 64;

/// No BMI088 device to share on this board.
pub type ImuSlot = ();
/// The empty [`ImuSlot`].
pub const IMU_SLOT: ImuSlot = ();

/// How long the board waits for the host's configuration frame at start [us] (5 s): time for
/// a host that resets the board to send its frame.
pub const STANDBY_US: u64 = 5_000_000;

/// The board's compiled-in run: a static alignment of 60 s at the site below, the ADIS16505's
/// datasheet noise. The host's configuration frame in the standby window replaces it.
pub fn default_run() -> RunConfig {
    let noise = crate::config::sensor_noise(&Device::Adis16505.noise());
    RunConfig::new(45.0, 7.5, 250.0, 60.0, noise)
}

type Spi1 = ExclusiveDevice<Spi<pac::SPI1>, PA4<Pin>, Delay<pac::TIM5, 1_000_000>>;
type TxTransfer = Transfer<Stream7<pac::DMA2>, 4, Tx<pac::USART1>, MemoryToPeripheral, Chunk>;
type RxTransfer =
    Transfer<Stream2<pac::DMA2>, 4, Rx<pac::USART1>, PeripheralToMemory, &'static mut [u8; RX_LEN]>;

/// Brings the board up: clocks, the monotonic, the cycle counter, SPI1 and the IMU, its
/// data-ready interrupt, USART1 with DMA, the watchdog. A failed IMU start ends the run
/// ([`exit`]).
pub fn init(mut core: cortex_m::Peripherals, dp: pac::Peripherals, _slot: &mut ImuSlot) -> Board {
    let mut rcc = dp.RCC.freeze(ClockConfig::hse(8.MHz()).sysclk(168.MHz()));
    Mono::start(rcc.clocks.timclk1().raw(), Priority::rtic_default());
    core.DCB.enable_trace();
    core.DWT.enable_cycle_counter();

    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let mode = Mode {
        polarity: Polarity::IdleHigh,
        phase: Phase::CaptureOnSecondTransition,
    };
    let spi = dp.SPI1.spi(
        (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
        mode,
        1.MHz(),
        &mut rcc,
    );
    let cs = gpioa.pa4.into_push_pull_output_in_state(true.into());
    let stall = dp.TIM5.delay_us(&mut rcc);
    // A GPIO chip select cannot fail.
    let Ok(bus) = ExclusiveDevice::new(spi, cs, stall);
    let config = adis::Config::new(Device::ADIS_MODEL).with_mounting(MOUNTING);
    let mut driver = Adis16505::new(bus, config);
    let mut delay = dp.TIM3.delay_us(&mut rcc);
    if let Err(e) = driver.init(&mut delay) {
        defmt::error!("IMU ADIS16505 init failed: {}", without_bus(&e));
        exit(ExitCode::Recording)
    }
    defmt::info!("IMU: ADIS16505 on SPI1");
    let mut syscfg = dp.SYSCFG.constrain(&mut rcc);
    let mut exti = dp.EXTI;
    let mut data_ready = gpiob.pb0.into_floating_input();
    data_ready.make_interrupt_source(&mut syscfg);
    data_ready.trigger_on_edge(&mut exti, Edge::Rising);
    data_ready.enable_interrupt(&mut exti);

    let serial_config = serial::Config::default()
        .baudrate(BAUD.bps())
        .dma(serial::config::DmaConfig::TxRx);
    let Ok(serial) = Serial::new(dp.USART1, (gpioa.pa9, gpioa.pa10), serial_config, &mut rcc)
    else {
        defmt::error!("USART1 configuration refused");
        exit(ExitCode::Output)
    };
    let (tx, rx) = serial.split();
    let dma2 = StreamsTuple::new(dp.DMA2, &mut rcc);
    let (Some(a), Some(b), Some(rx_a), Some(rx_b)) = (
        cortex_m::singleton!(: [u8; TX_LEN] = [0; TX_LEN]),
        cortex_m::singleton!(: [u8; TX_LEN] = [0; TX_LEN]),
        cortex_m::singleton!(: [u8; RX_LEN] = [0; RX_LEN]),
        cortex_m::singleton!(: [u8; RX_LEN] = [0; RX_LEN]),
    ) else {
        defmt::panic!("board buffers taken twice")
    };
    let dma = DmaConfig::default().memory_increment(true);
    let tx = Transfer::init_memory_to_peripheral(dma2.7, tx, Chunk { buf: a, len: 0 }, None, dma);
    let mut rx = Transfer::init_peripheral_to_memory(dma2.2, rx, rx_a, None, dma);
    rx.start(|_| {});

    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.start(WATCHDOG_MS.millis());

    let run = default_run();
    if let Err(e) = Setup::<f32>::new(&run, IMU_RATE_HZ) {
        defmt::error!("invalid configuration: {}", crate::errors::Config(&e));
        exit(ExitCode::Config)
    }
    Board {
        imu: Imu {
            driver,
            data_ready,
            missed: 0,
        },
        out: Output {
            tx,
            pending: Some(Chunk { buf: b, len: 0 }),
            busy: false,
            dropped: 0,
        },
        config_in: ConfigInput {
            rx,
            spare: Some(rx_b),
        },
        watchdog: Watchdog(watchdog),
        gnss: None,
        run,
        identity: BoardIdentity {
            imu_model: ImuModel::Adis16505,
            imu_rate_hz: IMU_RATE_HZ,
            mounting: MOUNTING,
            gnss: false,
        },
    }
}

/// The data-ready task's latency: not measured on this board (the pin's edge has no time
/// stamp before the task runs; the qemu board measures it from its pacer).
pub fn since_data_ready() -> Option<u32> {
    None
}

/// Board time since start [us]: the TIM2 monotonic.
pub fn now_us() -> u64 {
    Mono::now().as_ticks()
}

/// The core's cycle counter (32 bits, wraps every 25.6 s at 168 MHz).
pub fn counts() -> u64 {
    u64::from(DWT::cycle_count())
}

/// Core cycles since the [`counts`] reading `start` (spans shorter than a wrap).
pub fn instructions_since(start: u64) -> u64 {
    u64::from(DWT::cycle_count().wrapping_sub(start as u32))
}

/// Data-ready edges lost: the line was pending again when a read ended (counted by
/// [`Imu::read`]; an atomic so the summary can read it from another task).
pub fn missed_data_ready() -> u32 {
    MISSED.load(core::sync::atomic::Ordering::Relaxed)
}

static MISSED: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

/// The IMU: the ADIS16505 driver on SPI1 and its data-ready pin.
pub struct Imu {
    driver: Adis16505<Spi1>,
    data_ready: PB0<Input>,
    missed: u32,
}

impl Imu {
    /// Reads one sample at data-ready time `t_ready_us` [us]; `None` when there is nothing to
    /// hand on (a corrupt frame, counted in the driver's health and logged).
    pub fn read(&mut self, t_ready_us: u64) -> Option<DataReady> {
        self.data_ready.clear_interrupt_pending_bit();
        let c0 = counts();
        let bus = self.driver.read_burst();
        let c1 = counts();
        let result = bus.and_then(|()| self.driver.decode_burst(t_ready_us));
        let decode_instr = instructions_since(c1) as u32;
        let bus_instr = (c1 - c0) as u32;
        if self.data_ready.check_interrupt() {
            self.missed += 1;
            MISSED.store(self.missed, core::sync::atomic::Ordering::Relaxed);
        }
        match result {
            Ok(sample) => Some(DataReady::Sample {
                sample,
                t_ready_us,
                bus_instr,
                decode_instr,
            }),
            Err(e) if e.is_transient() => {
                let n = self.driver.health().checksum_errors;
                if n <= 10 || n.is_multiple_of(1000) {
                    defmt::warn!("IMU frame rejected: {} ({=u32} so far)", without_bus(&e), n);
                }
                None
            }
            Err(e) => {
                defmt::error!("IMU failed: {}", without_bus(&e));
                Some(DataReady::SourceError)
            }
        }
    }

    /// Nothing to stop: a real IMU has no end.
    pub fn ended(&mut self) {}

    /// The driver's counters.
    pub fn health(&self) -> Health {
        self.driver.health()
    }
}

/// The driver's error with the bus's error left out (the SPI peripheral's error has no defmt
/// format; a bus failure's kind is all the log needs).
fn without_bus<B>(e: &hal_adapters::drivers::Error<B>) -> hal_adapters::drivers::Error<()> {
    use hal_adapters::drivers::Error as E;
    match *e {
        E::Spi(_) => E::Spi(()),
        E::WrongId { expected, found } => E::WrongId { expected, found },
        E::Checksum { received, computed } => E::Checksum { received, computed },
        E::ZeroFrame => E::ZeroFrame,
        E::BadFrame => E::BadFrame,
        E::NotReady => E::NotReady,
        E::DeviceFault(code) => E::DeviceFault(code),
        E::FifoOverflow => E::FifoOverflow,
        E::Timeout => E::Timeout,
    }
}

/// A DMA buffer and the length of its bytes to send.
pub struct Chunk {
    buf: &'static mut [u8; TX_LEN],
    len: usize,
}

// SAFETY: the buffer is `'static` and owned by the chunk, so its address is stable and nothing
// else writes it while the DMA reads the `len` bytes it reports (`len <= TX_LEN`).
#[allow(unsafe_code)]
unsafe impl ReadBuffer for Chunk {
    type Word = u8;
    unsafe fn read_buffer(&self) -> (*const u8, usize) {
        (self.buf.as_ptr(), self.len)
    }
}

/// The output stream: USART1 TX through DMA, two buffers (one on the wire, one filling).
/// Bytes written while a transfer runs wait in the filling buffer and leave with the next
/// write after it ends. A write that does not fit is dropped whole, counted and logged (a
/// stream has no end record to lose; the host sees the gap in the rows' times).
pub struct Output {
    tx: TxTransfer,
    pending: Option<Chunk>,
    busy: bool,
    dropped: u32,
}

/// No solution log on this board: the solution leaves as the protocol's frames.
pub const CSV_LOG: bool = false;

impl Output {
    /// The solution log: none on this board ([`CSV_LOG`]); the bytes are not sent.
    pub fn write(&mut self, _bytes: &[u8]) -> Result<(), OutputError> {
        Ok(())
    }

    /// Sends what is queued (the queue leaves with each write; nothing to wait for).
    pub fn flush(&mut self) -> Result<(), OutputError> {
        self.write_frame(&[])
    }

    /// Queues the frame `bytes` and starts a transfer if none runs; `Err` when the DMA refuses
    /// one.
    pub fn write_frame(&mut self, bytes: &[u8]) -> Result<(), OutputError> {
        use stm32f4xx_hal::dma::traits::StreamISR as _;
        let chunk = self.pending.as_mut().ok_or(OutputError)?;
        if chunk.len + bytes.len() <= TX_LEN {
            chunk.buf[chunk.len..chunk.len + bytes.len()].copy_from_slice(bytes);
            chunk.len += bytes.len();
        } else {
            self.dropped += 1;
            let n = self.dropped;
            if n <= 10 || n.is_multiple_of(1000) {
                defmt::warn!("output stream full: a write dropped ({=u32} so far)", n);
            }
        }
        if self.busy && !self.tx.is_transfer_complete() {
            return Ok(());
        }
        let next = self.pending.take().ok_or(OutputError)?;
        match self.tx.next_transfer(next) {
            Ok((mut sent, _)) => {
                sent.len = 0;
                self.pending = Some(sent);
                self.busy = true;
                Ok(())
            }
            Err(
                DMAError::NotReady(back) | DMAError::SmallBuffer(back) | DMAError::Overrun(back),
            ) => {
                // The bytes stay queued for the next write.
                self.pending = Some(back);
                defmt::error!("output DMA refused a transfer");
                Err(OutputError)
            }
        }
    }

    /// Writes that did not fit and were dropped.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
}

/// The output stream refused bytes.
#[derive(Debug, defmt::Format)]
pub struct OutputError;

/// Configuration bytes from the host: USART1 RX through DMA, a buffer handed over when the
/// line goes idle (the end of the host's frame; a frame longer than the buffer, [`RX_LEN`],
/// may lose the bytes that arrive while the buffers are swapped).
pub struct ConfigInput {
    rx: RxTransfer,
    spare: Option<&'static mut [u8; RX_LEN]>,
}

impl ConfigInput {
    /// The standby window ended without an accepted configuration frame: the compiled-in
    /// configuration runs (flagged DEFAULT_CONFIG), as designed for a board with no host.
    #[inline(always)]
    pub fn none_taken(&self) {}

    /// Copies the bytes received up to the last idle line into `buf`; their number.
    pub fn read(&mut self, buf: &mut [u8]) -> usize {
        use stm32f4xx_hal::dma::traits::StreamISR as _;
        use stm32f4xx_hal::serial::RxISR as _;
        if !self.rx.is_idle() && !self.rx.is_transfer_complete() {
            return 0;
        }
        self.rx.clear_idle_interrupt();
        let received = RX_LEN - usize::from(self.rx.number_of_transfers());
        let Some(spare) = self.spare.take() else {
            return 0;
        };
        match self.rx.next_transfer(spare) {
            Ok((full, _)) => {
                let n = received.min(buf.len());
                buf[..n].copy_from_slice(&full[..n]);
                self.spare = Some(full);
                n
            }
            Err(
                DMAError::NotReady(back) | DMAError::SmallBuffer(back) | DMAError::Overrun(back),
            ) => {
                self.spare = Some(back);
                0
            }
        }
    }
}

/// The independent watchdog.
pub struct Watchdog(IndependentWatchdog);

impl Watchdog {
    /// Restarts its count.
    pub fn feed(&mut self) {
        self.0.feed();
    }
}

/// No GNSS receiver on this board yet: a source that has no fixes.
pub enum Fixes {}

impl Fixes {
    /// The next fix due at a sample ending at `t_us` over `dt_s` (never any).
    pub fn due(
        &mut self,
        _t_us: u64,
        _dt_s: f32,
    ) -> Result<Option<nav_core::ins_filter::sequencer::GnssFixInput<f32>>, core::convert::Infallible>
    {
        match *self {}
    }

    /// Fixes left after the data (none).
    pub fn remaining(&self, _count: u32) -> u32 {
        match *self {}
    }
}

/// Ends the run: under a debugger (probe-rs) a breakpoint stops the core where it is;
/// otherwise the core resets.
pub fn exit(code: ExitCode) -> ! {
    defmt::error!("run ended: {}", code);
    defmt::flush();
    if DCB::is_debugger_attached() {
        loop {
            cortex_m::asm::bkpt();
        }
    }
    SCB::sys_reset()
}
