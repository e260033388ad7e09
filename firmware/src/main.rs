//! Firmware of the DIMA sensor board (STM32F405/407).
//!
//! Tasks, highest priority first:
//! - `request` (EXTI15_10, PD10 rising edge) and `link_done` (DMA1 stream 3): answer a request
//!   with the latest complete packet, then one info piece while a snapshot is going out
//!   (`dima_firmware_logic::TxLink`); never tear a transfer.
//! - `gnss_bytes` / `gnss_dma` (USART1 idle line, DMA2 stream 2): feed the UBX reader.
//! - `sample` (TIM2 at [`board::SAMPLE_RATE_HZ`]): read the sensors on schedule, assemble the
//!   next packet, compute its CRC on the CRC unit, publish it, feed the watchdog when the
//!   supervisor (`dima_firmware_logic::Supervisor`) finds the link alive; every 250 ms, cut
//!   a new info snapshot into pieces (CRCs from the CRC unit) for the link.
//! - `gnss_setup` (software task, once at boot): configures the NEO-M8T through USART1 TX
//!   (PB6) with `neo_m8t::Configurator`, polled every millisecond; its replies come from
//!   `gnss_bytes` through a byte queue. Never blocks; ends configured, NAK'd or timed out.
//! - `status_led` (software task): the status LED pattern on PD12. DESIGN names no LED pin;
//!   PD12 is the STM32F4-Discovery's green LED.
//!
//! Under the `qemu` feature `host_byte` (USART3 receive) stands in for the request edge.
//!
//! The decisions live in the host-tested `dima-firmware-logic` crate; this file wires them to
//! the peripherals.
#![no_std]
#![no_main]

mod board;
mod delay;
mod gnss;
mod hw_crc;
mod link;
mod reset_record;

use panic_halt as _;
use rtic_monotonics::systick::prelude::*;

systick_monotonic!(Mono, board::MONO_HZ);

#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true, dispatchers = [SPI2, SPI3])]
mod app {
    use super::*;
    use crate::board::*;
    use crate::delay::CycleDelay;
    use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
    use dima_firmware_logic::gnss_setup::REPLY_QUEUE_LEN;
    use dima_firmware_logic::reset_record::BootFault;
    use dima_firmware_logic::{
        blink as led_pattern, CheckedCrc, GnssSetupOutcome, LatestPacket, LinkProgress, ReplyPort,
        ReplyTap, SetupStatus, Supervisor, SupervisorConfig,
    };
    use dima_firmware_logic::{Schedule, ScheduleConfig};
    use dima_sensorboard::{
        BoardHealth, InfoFrame, PacketBuilder, SensorStatus, GNSS_FRAME_LEN, INFO_PIECE_LEN,
        INFO_SNAPSHOT_MS, INFO_VERSION, PACKET_LEN,
    };
    use embedded_hal_bus::spi::AtomicDevice;
    use embedded_hal_bus::util::AtomicCell;
    use stm32f4xx_hal::gpio::{self, Edge, Input, Output, PushPull};
    use stm32f4xx_hal::pac::{self, SPI1, TIM2};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Config;
    use stm32f4xx_hal::serial::{self, config::StopBits};
    use stm32f4xx_hal::spi::{Mode, Phase, Polarity, Spi};
    use stm32f4xx_hal::timer::{CounterHz, Event, Flag};
    use stm32f4xx_hal::watchdog::IndependentWatchdog;

    /// Set once the first checksum-valid NAV-PVT frame has arrived (info frame status bit 4).
    static GNSS_SEEN: AtomicBool = AtomicBool::new(false);

    /// Outcome of the NEO-M8T configuration at boot (a `GnssSetupOutcome` code: 0 running,
    /// 1 configured, 2 ACK-NAK, 3 timeout, 4 port failure). The info frame has no bit for it;
    /// it shows on the status LED and can be read with a debugger.
    static GNSS_SETUP: SetupStatus = SetupStatus::new();
    /// Receiver protocol version from MON-VER's `PROTVER` (major << 8 | minor; 0 = unknown).
    #[cfg(feature = "gnss-setup")]
    static GNSS_PROTVER: core::sync::atomic::AtomicU16 = core::sync::atomic::AtomicU16::new(0);
    /// Receiver software version from MON-VER (ASCII, zero-padded; all zeros = no answer).
    #[cfg(feature = "gnss-setup")]
    static GNSS_SOFTWARE: [core::sync::atomic::AtomicU8; 30] =
        [const { core::sync::atomic::AtomicU8::new(0) }; 30];
    /// Resends the configurator needed (an unanswered message is sent again, up to 3 times).
    #[cfg(feature = "gnss-setup")]
    static GNSS_SETUP_RETRIES: AtomicU32 = AtomicU32::new(0);
    /// Requests skipped because a transfer was still running (the request task's count, for
    /// the info frame the sampling task encodes).
    static REQUESTS_SKIPPED: AtomicU32 = AtomicU32::new(0);
    /// Requests before the first packet existed (request task's count).
    static REQUESTS_EARLY: AtomicU32 = AtomicU32::new(0);
    /// A transfer is running on the link (link tasks' state, for the supervisor).
    static LINK_BUSY: AtomicBool = AtomicBool::new(false);
    /// Transfers completed on the link since boot (link tasks' count, for the supervisor).
    static LINK_COMPLETED: AtomicU32 = AtomicU32::new(0);
    /// GNSS bytes received since boot (GNSS task's count, for the supervisor).
    static GNSS_BYTES: AtomicU32 = AtomicU32::new(0);
    /// DMA transfer errors on the link (link tasks' count).
    static DMA_ERRORS: AtomicU32 = AtomicU32::new(0);
    /// GNSS bytes outside valid UBX frames, and frames with a bad checksum (GNSS task's count).
    static GNSS_BYTES_DROPPED: AtomicU32 = AtomicU32::new(0);
    static GNSS_FRAME_ERRORS: AtomicU32 = AtomicU32::new(0);
    /// The fault that made the previous boot reset the board (a `BootFault` code: 1 link
    /// USART3, 2 GNSS USART1, 3 sampling timer; 0 none). It also counts as a watchdog reset
    /// (status bit 5, `watchdog_resets`), since the watchdog performs it; this static, for a
    /// debugger, says which step failed.
    #[used]
    static BOOT_FAULT: core::sync::atomic::AtomicU8 = core::sync::atomic::AtomicU8::new(0);
    /// Received bytes the configurator's reply queue had no room for.
    static GNSS_REPLY_DROPPED: AtomicU32 = AtomicU32::new(0);

    /// SPI1, shared by the four chip selects.
    type SensorBus = Spi<SPI1>;
    /// A chip select on port E, its pin number kept at run time: the four devices share one
    /// type, so their driver code exists once in flash instead of four times.
    type ChipSelect = gpio::PartiallyErasedPin<'E', Output<PushPull>>;
    /// One sensor die on SPI1 behind its chip select on port E.
    pub type SensorSpi = AtomicDevice<'static, SensorBus, ChipSelect, CycleDelay>;

    /// The CRC unit if it passed its boot-time self-check, else the small software CRC.
    /// (QEMU does not model the unit: there the check fails and the fallback runs.)
    type Crc = CheckedCrc<crate::hw_crc::HwCrc>;

    /// The sensors, one SPI device per die.
    pub type Sensors = dima_firmware_logic::Sensors<SensorSpi, SensorSpi, SensorSpi, SensorSpi>;

    /// Everything the sampling tick owns: the back half of the packet double buffer.
    pub struct Sampler {
        timer: CounterHz<TIM2>,
        watchdog: IndependentWatchdog,
        schedule: Schedule,
        builder: PacketBuilder,
        crc: Crc,
        sensors: Sensors,
        /// Calibration, status and health for the info frame, a snapshot every
        /// `INFO_SNAPSHOT_MS` of the monotonic clock (its `uptime_ms`: when it was taken).
        info: InfoFrame,
        /// Counter of the snapshots taken (info piece byte 2); 0 before the first.
        snapshot: u8,
        /// Decides whether this tick feeds the watchdog; notices a silent receiver.
        supervisor: Supervisor,
        /// The supervisor's latest word on the receiver (info frame status bit 7).
        gnss_silent: bool,
    }

    /// The supervisor's thresholds at `SAMPLE_RATE_HZ`: the link is stuck after 20 ms of
    /// sending without a completion, the receiver silent after 1 s without a byte.
    const SUPERVISOR: SupervisorConfig = SupervisorConfig {
        link_stuck_ticks: 20 * SAMPLE_RATE_HZ / 1_000,
        gnss_silent_ticks: SAMPLE_RATE_HZ,
    };

    /// Resynchronising UBX reader; 256 bytes hold the largest message the board expects. With
    /// `gnss-setup` it takes the configurator's 512 so both share one framer in flash (372
    /// bytes of code for 256 of RAM).
    type GnssReader = neo_m8t::GnssStream<{ GNSS_READER_LEN }>;
    const GNSS_READER_LEN: usize = if cfg!(feature = "gnss-setup") {
        512
    } else {
        256
    };

    /// The configurator's serial port: USART1 TX, replies from the receive task's queue.
    type GnssPort = ReplyPort<'static, serial::Tx<pac::USART1>>;

    /// The latest checksum-valid NAV-PVT frame (all zeros until the first one).
    pub struct GnssLatest {
        frame: [u8; GNSS_FRAME_LEN],
        fresh: bool,
    }

    #[shared]
    struct Shared {
        /// Front half of the double buffer: the latest complete packet.
        latest: LatestPacket<PACKET_LEN>,
        /// The transmitter: request state, buffers, info pieces (the sampling task publishes
        /// a snapshot, encoded outside the lock, every 250 ms).
        link: link::Link,
        /// Hand-over of NAV-PVT frames from the GNSS task to the sampling tick.
        gnss_latest: GnssLatest,
    }

    #[local]
    struct Local {
        request_pin: gpio::PD10<Input>,
        sampler: Sampler,
        gnss_rx: gnss::GnssRx,
        reader: GnssReader,
        reply_tap: ReplyTap<'static>,
        gnss_port: GnssPort,
        led: gpio::PD12<Output<PushPull>>,
        #[cfg(feature = "qemu")]
        host_rx: serial::Rx<pac::USART3>,
    }

    #[init(local = [
        packet_a: [u8; PACKET_LEN] = [0; PACKET_LEN],
        packet_b: [u8; PACKET_LEN] = [0; PACKET_LEN],
        piece_buffer: [u8; INFO_PIECE_LEN] = [0; INFO_PIECE_LEN],
        gnss_a: [u8; GNSS_DMA_LEN] = [0; GNSS_DMA_LEN],
        gnss_b: [u8; GNSS_DMA_LEN] = [0; GNSS_DMA_LEN],
        gnss_replies: heapless::spsc::Queue<u8, REPLY_QUEUE_LEN> = heapless::spsc::Queue::new(),
        spi_cell: Option<AtomicCell<SensorBus>> = None,
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let mut dp = cx.device;

        // Why did we reset? Read the flags before anything else, then clear them.
        let csr = dp.RCC.csr().read();
        let watchdog_reset = csr.wdgrstf().bit_is_set();
        let reset_report =
            crate::reset_record::after_reset(csr.porrstf().bit_is_set(), watchdog_reset);
        if let Some(cause) = reset_report.boot_fault {
            BOOT_FAULT.store(cause as u8, Ordering::Relaxed);
        }
        dp.RCC.csr().modify(|_, w| w.rmvf().set_bit());

        // QEMU models no RCC: HSE and PLL would never report ready there.
        #[cfg(not(feature = "qemu"))]
        let clock_config = Config::hse(HSE_HZ.Hz()).sysclk(SYSCLK_HZ.Hz());
        #[cfg(feature = "qemu")]
        let clock_config = Config::hsi();
        let mut rcc = dp.RCC.freeze(clock_config);
        let sysclk_hz = rcc.clocks.sysclk().raw();
        // QEMU's netduinoplus2 clocks the core at a fixed 168 MHz whatever RCC says.
        let mut core = cx.core;
        // SysTick (the monotonic's tick) runs below the link tasks, so it can never hold off a
        // request edge; it stays above sampling so a long tick cannot lose a counter wrap.
        set_systick_priority(&mut core.SCB, SYSTICK_PRIORITY);
        #[cfg(not(feature = "qemu"))]
        Mono::start(core.SYST, sysclk_hz);
        #[cfg(feature = "qemu")]
        Mono::start(core.SYST, QEMU_CORE_HZ);

        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpiod = dp.GPIOD.split(&mut rcc);
        let gpioe = dp.GPIOE.split(&mut rcc);

        // SPI1 mode 3, one device per chip select (high = deselected).
        let mode = Mode {
            polarity: Polarity::IdleHigh,
            phase: Phase::CaptureOnSecondTransition,
        };
        let spi = dp.SPI1.spi(
            (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
            mode,
            SPI_HZ.Hz(),
            &mut rcc,
        );
        let bus: &'static AtomicCell<SensorBus> = cx.local.spi_cell.insert(AtomicCell::new(spi));
        let mut delay = CycleDelay::new(sysclk_hz);
        let (sensors, report) = Sensors::init(
            spi_device(bus, gpioe.pe7.into_push_pull_output(), delay),
            spi_device(bus, gpioe.pe8.into_push_pull_output(), delay),
            spi_device(bus, gpioe.pe9.into_push_pull_output(), delay),
            spi_device(bus, gpioe.pe10.into_push_pull_output(), delay),
            &mut delay,
        );

        // Link to the host: USART3 TX on PD8, 8N2.
        let link_config = serial::Config::default()
            .baudrate(LINK_BAUD.bps())
            .wordlength_8()
            .parity_none()
            .stopbits(StopBits::STOP2);
        #[cfg(not(feature = "qemu"))]
        let link = {
            use stm32f4xx_hal::dma::{config::DmaConfig, StreamsTuple, Transfer};
            let tx = dp
                .USART3
                .tx(
                    gpiod.pd8,
                    link_config.dma(serial::config::DmaConfig::Tx),
                    &mut rcc,
                )
                .unwrap_or_else(|_| fault(BootFault::LinkSerial));
            let streams = StreamsTuple::new(dp.DMA1, &mut rcc);
            let piece_buffer: &'static mut [u8] = cx.local.piece_buffer;
            let transfer = Transfer::init_memory_to_peripheral(
                streams.3,
                tx,
                piece_buffer,
                None,
                DmaConfig::default()
                    .memory_increment(true)
                    .transfer_complete_interrupt(true)
                    .transfer_error_interrupt(true),
            );
            link::Link::new(
                link::LinkDma(transfer),
                cx.local.packet_a,
                cx.local.packet_b,
            )
        };
        // Under QEMU a byte on USART3's receive side stands in for the request edge.
        #[cfg(feature = "qemu")]
        let (link, host_rx) = {
            let serial = dp
                .USART3
                .serial((gpiod.pd8, gpiod.pd9), link_config, &mut rcc)
                .unwrap_or_else(|_| fault(BootFault::LinkSerial));
            let (tx, mut rx) = serial.split();
            rx.listen();
            let dma = link::LinkDma::new(tx, cx.local.piece_buffer);
            let link = link::Link::new(dma, cx.local.packet_a, cx.local.packet_b);
            (link, rx)
        };

        // GNSS: USART1 RX on PB7, TX on PB6 (configuration messages only).
        let gnss_config = serial::Config::default().baudrate(GNSS_BAUD.bps());
        #[cfg(not(feature = "qemu"))]
        let (gnss_rx, gnss_tx) = {
            use stm32f4xx_hal::dma::{config::DmaConfig, StreamsTuple, Transfer};
            let (gnss_tx, mut rx) = dp
                .USART1
                .serial(
                    (gpiob.pb6, gpiob.pb7),
                    gnss_config.dma(serial::config::DmaConfig::Rx),
                    &mut rcc,
                )
                .unwrap_or_else(|_| fault(BootFault::GnssSerial))
                .split();
            rx.listen_idle();
            let streams = StreamsTuple::new(dp.DMA2, &mut rcc);
            let mut transfer = Transfer::init_peripheral_to_memory(
                streams.2,
                rx,
                cx.local.gnss_a,
                None,
                DmaConfig::default()
                    .memory_increment(true)
                    .transfer_complete_interrupt(true),
            );
            transfer.start(|_| {});
            (gnss::GnssRx::new(transfer, cx.local.gnss_b), gnss_tx)
        };
        #[cfg(feature = "qemu")]
        let (gnss_rx, gnss_tx) = {
            let _ = (cx.local.gnss_a, cx.local.gnss_b);
            let (gnss_tx, mut rx) = dp
                .USART1
                .serial((gpiob.pb6, gpiob.pb7), gnss_config, &mut rcc)
                .unwrap_or_else(|_| fault(BootFault::GnssSerial))
                .split();
            rx.listen();
            (gnss::GnssRx::new(rx), gnss_tx)
        };
        let (reply_producer, reply_consumer) = cx.local.gnss_replies.split();

        // Request line: PD10, rising edge.
        let mut syscfg = dp.SYSCFG.constrain(&mut rcc);
        let mut request_pin = gpiod.pd10.into_pull_down_input();
        request_pin.make_interrupt_source(&mut syscfg);
        request_pin.trigger_on_edge(&mut dp.EXTI, Edge::Rising);
        request_pin.enable_interrupt(&mut dp.EXTI);

        // The sampling tick, and the watchdog it feeds.
        let mut timer = dp.TIM2.counter_hz(&mut rcc);
        // The HAL sets the prescalers for its idea of the timer clock; QEMU runs the timer at
        // a fixed 1 GHz, so ask for a rate that lands on SAMPLE_RATE_HZ there.
        #[cfg(not(feature = "qemu"))]
        let tick_request_hz = SAMPLE_RATE_HZ;
        #[cfg(feature = "qemu")]
        let tick_request_hz =
            (u64::from(SAMPLE_RATE_HZ) * u64::from(HSI_HZ) / u64::from(QEMU_TIMER_HZ)) as u32;
        timer
            .start(tick_request_hz.Hz())
            .unwrap_or_else(|_| fault(BootFault::SampleTimer));
        timer.listen(Event::Update);
        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.start(WATCHDOG_MS.millis());

        let crc = CheckedCrc::check(crate::hw_crc::HwCrc(stm32f4xx_hal::crc32::Crc32::new(
            dp.CRC, &mut rcc,
        )));

        let mut status = report.status;
        status.set(SensorStatus::WATCHDOG_RESET, watchdog_reset);
        status.set(SensorStatus::CRC_UNIT_FAILED, !crc.unit_ok());
        let info = InfoFrame {
            version: INFO_VERSION,
            firmware: FIRMWARE_VERSION,
            status,
            bmp280_calibration: report.bmp280_calibration,
            bmm150_trim: report.bmm150_trim,
            uptime_ms: 0,
            requests_skipped: 0,
            health: BoardHealth {
                watchdog_resets: reset_report.watchdog_resets,
                ..BoardHealth::default()
            },
        };

        let led = gpiod.pd12.into_push_pull_output();
        status_led::spawn(status.bits()).ok();
        gnss_setup::spawn().ok();

        // The exception priorities as the core holds them (QEMU models SCB and NVIC), for the
        // smoke test: SysTick must be below the request interrupt (a larger value).
        #[cfg(feature = "qemu")]
        cortex_m_semihosting::hprintln!(
            "priorities: systick {:#04x}, request {:#04x}",
            cortex_m::peripheral::SCB::get_priority(
                cortex_m::peripheral::scb::SystemHandler::SysTick
            ),
            cortex_m::peripheral::NVIC::get_priority(pac::Interrupt::EXTI15_10)
        );
        #[cfg(feature = "qemu")]
        cortex_m_semihosting::hprintln!("ready");

        (
            Shared {
                latest: LatestPacket::new(),
                link,
                gnss_latest: GnssLatest {
                    frame: [0; GNSS_FRAME_LEN],
                    fresh: false,
                },
            },
            Local {
                request_pin,
                sampler: Sampler {
                    timer,
                    watchdog,
                    schedule: Schedule::new(ScheduleConfig {
                        period_us: 1_000_000 / SAMPLE_RATE_HZ,
                        ..ScheduleConfig::DEFAULT
                    }),
                    builder: PacketBuilder::new(),
                    crc,
                    sensors,
                    info,
                    snapshot: 0,
                    supervisor: Supervisor::new(SUPERVISOR),
                    gnss_silent: false,
                },
                gnss_rx,
                reader: GnssReader::with_capacity(),
                reply_tap: ReplyTap::new(reply_producer),
                gnss_port: ReplyPort::new(gnss_tx, reply_consumer),
                led,
                #[cfg(feature = "qemu")]
                host_rx,
            },
        )
    }

    /// RTIC priority of the SysTick exception: below `request` and `link_done` (3), equal to
    /// the GNSS tasks (2), above sampling (1).
    const SYSTICK_PRIORITY: u8 = 2;

    /// Sets SysTick's exception priority to the RTIC (logical) priority `logical`.
    fn set_systick_priority(scb: &mut cortex_m::peripheral::SCB, logical: u8) {
        use cortex_m::peripheral::scb::SystemHandler;
        // RTIC's mapping: logical 1 is the lowest hardware level, higher numbers preempt.
        let hardware = ((1u8 << pac::NVIC_PRIO_BITS) - logical) << (8 - pac::NVIC_PRIO_BITS);
        // SAFETY: called from `init` with interrupts disabled; no RTIC lock depends on
        // SysTick's priority (its handler only runs the monotonic's timer queue).
        #[allow(unsafe_code)]
        unsafe {
            scb.set_priority(SystemHandler::SysTick, hardware)
        };
    }

    /// One SPI device on the shared bus; the chip select starts high (deselected).
    fn spi_device<const N: u8>(
        bus: &'static AtomicCell<SensorBus>,
        cs: gpio::Pin<'E', N, Output<PushPull>>,
        delay: CycleDelay,
    ) -> SensorSpi {
        match AtomicDevice::new(bus, cs.erase_number(), delay) {
            Ok(device) => device,
            Err(never) => match never {},
        }
    }

    /// A configuration the hardware rejected at boot: record the cause for the next boot and
    /// let the watchdog reset the board.
    ///
    /// Starting the IWDG with its reset values (prescaler /4, reload 0xFFF) gives a reset
    /// after 4096 × 4 LSI periods: 512 ms at the nominal 32 kHz, 350-960 ms over the LSI's
    /// 17-47 kHz range. If `init` already started it, the start key changes nothing. The next
    /// boot sees a watchdog reset (status bit 5, `watchdog_resets`) and the cause in the
    /// reset record (`BOOT_FAULT`). QEMU models no IWDG: there this waits for ever.
    fn fault(cause: BootFault) -> ! {
        /// The IWDG key register's start key (RM0090 19.4.1).
        const KEY_START: u16 = 0xCCCC;
        crate::reset_record::record_fault(cause);
        // SAFETY: the key register is write-only and nothing else writes it during `init`
        // (the `IndependentWatchdog` is created after every call of `fault`); the start key
        // only starts the counter (a running watchdog stays as it is). `fault` never
        // returns, so nothing relies on the watchdog being stopped afterwards.
        #[allow(unsafe_code)]
        unsafe {
            (*pac::IWDG::ptr()).kr().write(|w| w.key().bits(KEY_START))
        };
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// A request edge: start the answer and return.
    #[task(binds = EXTI15_10, priority = 3, local = [request_pin], shared = [link, latest])]
    fn request(cx: request::Context) {
        use stm32f4xx_hal::gpio::ExtiPin;
        cx.local.request_pin.clear_interrupt_pending_bit();
        let now_ms = Mono::now().ticks();
        (cx.shared.link, cx.shared.latest).lock(|link, latest| {
            link.on_request(now_ms, latest.get());
            publish_link_state(link);
        });
    }

    /// The running transfer has ended: send the info piece or go idle.
    #[task(binds = DMA1_STREAM3, priority = 3, shared = [link])]
    fn link_done(mut cx: link_done::Context) {
        cx.shared.link.lock(|link| {
            // A DMA error counted here reaches the info frame with the next snapshot.
            if link.on_dma_interrupt() {
                publish_link_state(link);
            }
        });
    }

    /// The link's state and counters for the sampling task (supervisor and info frame).
    /// Only the two priority-3 link tasks write them.
    fn publish_link_state(link: &link::Link) {
        LINK_BUSY.store(link.is_busy(), Ordering::Relaxed);
        LINK_COMPLETED.store(link.completed(), Ordering::Relaxed);
        REQUESTS_SKIPPED.store(link.skipped(), Ordering::Relaxed);
        REQUESTS_EARLY.store(link.not_ready(), Ordering::Relaxed);
        DMA_ERRORS.store(link.dma_errors(), Ordering::Relaxed);
    }

    /// Under QEMU: a byte from the host on USART3 is a request.
    #[cfg(feature = "qemu")]
    #[task(binds = USART3, priority = 3, local = [host_rx])]
    fn host_byte(cx: host_byte::Context) {
        while embedded_hal_nb::serial::Read::read(cx.local.host_rx).is_ok() {
            rtic::pend(pac::Interrupt::EXTI15_10);
        }
    }

    /// GNSS bytes (idle line, or under QEMU a received byte).
    /// While the receiver is being configured, the same bytes also go to the configurator.
    #[task(binds = USART1, priority = 2, local = [gnss_rx, reader, reply_tap], shared = [gnss_latest])]
    fn gnss_bytes(mut cx: gnss_bytes::Context) {
        let reader = cx.local.reader;
        let tap = cx.local.reply_tap;
        cx.local.gnss_rx.drain(|bytes| {
            // The only writer: a plain load and store suffice.
            let received = GNSS_BYTES
                .load(Ordering::Relaxed)
                .wrapping_add(bytes.len() as u32);
            GNSS_BYTES.store(received, Ordering::Relaxed);
            reader.push_slice(bytes);
            if GNSS_SETUP.is_pending() {
                tap.push_slice(bytes);
                GNSS_REPLY_DROPPED.store(tap.dropped(), Ordering::Relaxed);
            }
        });
        let stats = reader.stats();
        GNSS_BYTES_DROPPED.store(stats.bytes_skipped, Ordering::Relaxed);
        GNSS_FRAME_ERRORS.store(stats.checksum_errors, Ordering::Relaxed);
        if let Some(frame) = reader.take_nav_pvt() {
            cx.shared.gnss_latest.lock(|gnss| {
                gnss.frame = *frame.as_bytes();
                gnss.fresh = true;
            });
            GNSS_SEEN.store(true, Ordering::Relaxed);
        }
    }

    /// GNSS DMA buffer full before the line went idle.
    #[cfg(not(feature = "qemu"))]
    #[task(binds = DMA2_STREAM2, priority = 2)]
    fn gnss_dma(_cx: gnss_dma::Context) {
        rtic::pend(pac::Interrupt::USART1);
    }

    /// One sampling tick: read what the schedule says, publish the packet, feed the watchdog.
    #[task(binds = TIM2, priority = 1, local = [sampler], shared = [latest, link, gnss_latest])]
    fn sample(mut cx: sample::Context) {
        let sampler = cx.local.sampler;
        sampler.timer.clear_flags(Flag::Update);
        // Fed only while this tick runs, the link is not stuck sending and (reported, not
        // a reset) the receiver talks.
        let verdict = sampler.supervisor.on_tick(
            LinkProgress {
                busy: LINK_BUSY.load(Ordering::Relaxed),
                completed: LINK_COMPLETED.load(Ordering::Relaxed),
            },
            GNSS_BYTES.load(Ordering::Relaxed),
        );
        if verdict.feed_watchdog {
            sampler.watchdog.feed();
        }
        sampler.gnss_silent = verdict.gnss_silent;
        let plan = sampler.schedule.next_tick();
        sampler
            .sensors
            .tick(plan, &mut sampler.schedule, &mut sampler.builder);

        let builder = &mut sampler.builder;
        cx.shared.gnss_latest.lock(|gnss| {
            if core::mem::take(&mut gnss.fresh) {
                builder.gnss_frame(&gnss.frame);
            }
        });
        // The info snapshot first, so one exists whenever a packet does.
        let now_ms = Mono::now().ticks();
        if sampler.snapshot == 0 || now_ms.wrapping_sub(sampler.info.uptime_ms) >= INFO_SNAPSHOT_MS
        {
            let info = &mut sampler.info;
            info.uptime_ms = now_ms;
            info.requests_skipped = REQUESTS_SKIPPED.load(Ordering::Relaxed);
            info.status
                .set(SensorStatus::GNSS_SEEN, GNSS_SEEN.load(Ordering::Relaxed));
            info.status
                .set(SensorStatus::GNSS_SILENT, sampler.gnss_silent);
            let [accel_errors, gyro_errors, mag_errors, bmp280_errors] = sampler.sensors.errors();
            let [accel_age_ms, gyro_age_ms, mag_age_ms, bmp280_age_ms] =
                sampler.sensors.ages_ms(sampler.schedule.config().period_us);
            info.health = BoardHealth {
                accel_errors,
                gyro_errors,
                mag_errors,
                bmp280_errors,
                mag_timeout_errors: sampler.schedule.mag_timeouts(),
                dma_errors: DMA_ERRORS.load(Ordering::Relaxed),
                requests_early: REQUESTS_EARLY.load(Ordering::Relaxed),
                gnss_bytes_dropped: GNSS_BYTES_DROPPED.load(Ordering::Relaxed),
                gnss_frame_errors: GNSS_FRAME_ERRORS.load(Ordering::Relaxed),
                watchdog_resets: info.health.watchdog_resets,
                accel_age_ms,
                gyro_age_ms,
                mag_age_ms,
                bmp280_age_ms,
            };
            // Never 0 again after the first: 0 means "none taken yet".
            sampler.snapshot = sampler.snapshot.checked_add(1).unwrap_or(1);
            // Ten CRCs on the CRC unit, outside the lock; only the copy holds off requests.
            let pieces = info.encode_v2_pieces_with(sampler.snapshot, &mut sampler.crc);
            cx.shared.link.lock(|link| link.publish_pieces(&pieces));
        }
        let packet = sampler.builder.build(&mut sampler.crc);
        cx.shared.latest.lock(|latest| latest.publish(packet));
    }

    /// With the `gnss-setup` feature: configures the NEO-M8T once at boot (10 Hz NAV-PVT on UART1, UBX only, automotive
    /// model: `neo_m8t::Config::default()`), one poll per millisecond, then ends. The baud
    /// rate stays `GNSS_BAUD`, so the configurator never asks for a switch. Without a receiver
    /// (or under QEMU) the MON-VER poll times out after its retries (about 2 s); sampling and
    /// requests carry on meanwhile. Without the feature it only records `Skipped`.
    #[task(priority = 1, local = [gnss_port])]
    async fn gnss_setup(cx: gnss_setup::Context) {
        #[cfg(not(feature = "gnss-setup"))]
        {
            // Built without boot-time configuration: the receiver keeps what it has stored.
            let _ = cx.local.gnss_port;
            GNSS_SETUP.set(GnssSetupOutcome::Skipped);
        }
        #[cfg(feature = "gnss-setup")]
        {
            let port = cx.local.gnss_port;
            let mut configurator =
                neo_m8t::Configurator::<512>::with_capacity(gnss_receiver_config(), GNSS_BAUD);
            let outcome = loop {
                match configurator.poll(port, Mono::now().ticks()) {
                    Ok(neo_m8t::Progress::Pending) => {}
                    Ok(neo_m8t::Progress::Done) => break GnssSetupOutcome::Configured,
                    // Only asked for when the configured rate differs from GNSS_BAUD.
                    Ok(neo_m8t::Progress::SetBaudRate(_)) => break GnssSetupOutcome::Failed,
                    Err(error) => break GnssSetupOutcome::from_error(&error),
                }
                Mono::delay(1.millis()).await;
            };
            if let Some(version) = configurator.version() {
                for (slot, byte) in GNSS_SOFTWARE.iter().zip(version.software.bytes()) {
                    slot.store(byte, Ordering::Relaxed);
                }
                if let Some(protocol) = version.protocol {
                    GNSS_PROTVER.store(
                        u16::from(protocol.major) << 8 | u16::from(protocol.minor),
                        Ordering::Relaxed,
                    );
                }
            }
            GNSS_SETUP_RETRIES.store(configurator.retries(), Ordering::Relaxed);
            GNSS_SETUP.set(outcome);
            #[cfg(feature = "qemu")]
            cortex_m_semihosting::hprintln!(
                "gnss setup: {:?}, {} retries, PROTVER {:#06x}",
                outcome,
                configurator.retries(),
                GNSS_PROTVER.load(Ordering::Relaxed)
            );
        }
    }

    /// What the board needs from the receiver: 10 Hz NAV-PVT on UART1, UBX only, automotive
    /// model, at `GNSS_BAUD`. TIMEPULSE (CFG-TP5) and the timing mode (CFG-TMODE2) are left as
    /// stored in the receiver: the board does not use them.
    #[cfg(feature = "gnss-setup")]
    fn gnss_receiver_config() -> neo_m8t::Config {
        neo_m8t::Config::default()
            .with_baud_rate(GNSS_BAUD)
            .with_time_pulse(None)
            .with_time_mode(None)
    }

    /// The status LED: see `dima_firmware_logic::blink` (sensor group, then GNSS group).
    #[task(priority = 1, local = [led])]
    async fn status_led(cx: status_led::Context, status: u8) {
        loop {
            let gnss = led_pattern::gnss(GNSS_SETUP.get());
            for step in led_pattern::pattern(status).into_iter().chain(gnss) {
                if step.on_ms > 0 {
                    cx.local.led.set_high();
                    Mono::delay(step.on_ms.millis()).await;
                    cx.local.led.set_low();
                }
                if step.off_ms > 0 {
                    Mono::delay(step.off_ms.millis()).await;
                }
            }
        }
    }
}
