//! Firmware of the DIMA sensor board (STM32F405/407).
//!
//! Tasks, highest priority first:
//! - `request` (EXTI15_10, PD10 rising edge) and `link_done` (DMA1 stream 3): answer a request
//!   with the latest complete packet, then one info piece while a snapshot is going out
//!   (`dima_firmware_logic::TxLink`); never tear a transfer.
//! - `gnss_bytes` / `gnss_dma` (USART1 idle line, DMA2 stream 2): feed the UBX reader; each
//!   clears its own flags (`dima_firmware_logic::gnss_rx`).
//! - `sample` (TIM2 at [`board::SAMPLE_RATE_HZ`]): read the sensors on schedule, assemble the
//!   next packet, compute its CRC on the CRC unit, publish it, feed the watchdog when the
//!   supervisor (`dima_firmware_logic::Supervisor`) finds the link alive; every 250 ms, cut
//!   a new info snapshot into pieces (CRCs from the CRC unit) for the link.
//! - `gnss_setup` (software task, once at boot): configures the NEO-M8T through USART1 TX
//!   (PB6) with `neo_m8t::Configurator`, polled every millisecond; its replies come from
//!   `gnss_bytes` through a byte queue. Never blocks; ends configured, NAK'd or timed out.
//! - `status_led` (software task): the status LED pattern on PD12. The board's wiring names no
//!   LED pin; PD12 is the STM32F4-Discovery's green LED.
//!
//! Under the `qemu` feature `host_byte` (USART3 receive) stands in for the request edge, and
//! the USART2 handler in `sensor_images` updates the sensor dies' register images the host
//! feeds (outside the RTIC app, so that the board build's interrupt set-up stays as it is).
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
mod panic;
mod reset_record;
#[cfg(feature = "qemu")]
mod sensor_images;
mod sensors;
mod setup;

use rtic_monotonics::systick::prelude::*;

systick_monotonic!(Mono, board::MONO_HZ);

#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true, dispatchers = [SPI2, SPI3])]
mod app {
    use super::*;
    use crate::board::*;
    use crate::sensors::{SensorBus, Sensors};
    use crate::setup::Crc;
    use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
    use dima_firmware_logic::gnss_setup::REPLY_QUEUE_LEN;
    use dima_firmware_logic::reset_record::BootFault;
    use dima_firmware_logic::uart_errors::UartErrors;
    use dima_firmware_logic::{
        blink as led_pattern, GnssSetupOutcome, LatestPacket, LinkProgress, ReplyPort, ReplyTap,
        SetupStatus, Supervisor, SupervisorConfig,
    };
    use dima_firmware_logic::{Schedule, ScheduleConfig};
    use dima_sensorboard::{
        BoardFaults, BoardHealth, InfoFrame, InfoPieceSetV3, PacketBuilder, SensorStatus,
        GNSS_FRAME_LEN, INFO_PIECE_LEN, INFO_SNAPSHOT_MS, PACKET_LEN,
    };
    use embedded_hal_bus::util::AtomicCell;
    use stm32f4xx_hal::gpio::{self, Input, Output, PushPull};
    use stm32f4xx_hal::pac::{self, TIM2};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::serial;
    use stm32f4xx_hal::timer::{CounterHz, Flag};
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
    /// GNSS UART overrun, framing and noise errors (GNSS task's counts).
    static GNSS_OVERRUN_ERRORS: AtomicU32 = AtomicU32::new(0);
    static GNSS_FRAMING_ERRORS: AtomicU32 = AtomicU32::new(0);
    static GNSS_NOISE_ERRORS: AtomicU32 = AtomicU32::new(0);
    /// The fault that made the previous boot reset the board (a `BootFault` code: 1 link
    /// USART3, 2 GNSS USART1, 3 sampling timer, 4 panic; 0 none). A fault in `init` also
    /// counts as a watchdog reset (status bit 5, `watchdog_resets`), since the watchdog
    /// performs it; a panic resets by software and does not. For a debugger (and under QEMU
    /// the boot message): which fault it was.
    #[used]
    static BOOT_FAULT: core::sync::atomic::AtomicU8 = core::sync::atomic::AtomicU8::new(0);
    /// Received bytes the configurator's reply queue had no room for.
    static GNSS_REPLY_DROPPED: AtomicU32 = AtomicU32::new(0);

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
        /// Ticks still running when the next period began (info frame `sample_overruns`).
        overruns: u32,
    }

    impl Sampler {
        /// The sampling tick's state at boot: a fresh schedule at [`SAMPLE_RATE_HZ`], an
        /// empty packet, no snapshot taken yet, the receiver not (yet) silent.
        fn new(
            timer: CounterHz<TIM2>,
            watchdog: IndependentWatchdog,
            crc: Crc,
            sensors: Sensors,
            info: InfoFrame,
        ) -> Self {
            Self {
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
                overruns: 0,
            }
        }
    }

    impl Sampler {
        /// Asks the supervisor about this tick: the watchdog is fed only while this tick runs,
        /// the link is not stuck sending and (reported, not a reset) the receiver talks.
        fn supervise(&mut self) {
            let verdict = self.supervisor.on_tick(
                LinkProgress {
                    busy: LINK_BUSY.load(Ordering::Relaxed),
                    completed: LINK_COMPLETED.load(Ordering::Relaxed),
                },
                GNSS_BYTES.load(Ordering::Relaxed),
            );
            if verdict.feed_watchdog {
                self.watchdog.feed();
            }
            self.gnss_silent = verdict.gnss_silent;
        }

        /// A new info snapshot is due: none taken yet, or `INFO_SNAPSHOT_MS` since the last.
        fn snapshot_due(&self, now_ms: u32) -> bool {
            self.snapshot == 0 || now_ms.wrapping_sub(self.info.uptime_ms) >= INFO_SNAPSHOT_MS
        }

        /// Takes the next info snapshot at `now_ms` and cuts it into pieces (ten CRCs on the
        /// CRC unit), for the caller to hand to the link.
        fn take_snapshot(&mut self, now_ms: u32) -> InfoPieceSetV3 {
            self.refresh_info(now_ms);
            // Never 0 again after the first: 0 means "none taken yet".
            self.snapshot = self.snapshot.checked_add(1).unwrap_or(1);
            self.info
                .encode_v3_pieces_with(self.snapshot, &mut self.crc)
        }

        /// Brings the info frame up to date: the time, the status bits the tasks report, the
        /// counters and sensor ages.
        fn refresh_info(&mut self, now_ms: u32) {
            self.info.uptime_ms = now_ms;
            self.info.requests_skipped = REQUESTS_SKIPPED.load(Ordering::Relaxed);
            self.info
                .status
                .set(SensorStatus::GNSS_SEEN, GNSS_SEEN.load(Ordering::Relaxed));
            self.info
                .status
                .set(SensorStatus::GNSS_SILENT, self.gnss_silent);
            self.info.health = self.health();
            self.info.faults = self.faults();
        }

        /// The health counters and sensor ages now (the watchdog resets as at boot).
        fn health(&self) -> BoardHealth {
            let [accel_errors, gyro_errors, mag_errors, bmp280_errors] = self.sensors.errors();
            let [accel_age_ms, gyro_age_ms, mag_age_ms, bmp280_age_ms] =
                self.sensors.ages_ms(self.schedule.config().period_us);
            BoardHealth {
                accel_errors,
                gyro_errors,
                mag_errors,
                bmp280_errors,
                mag_timeout_errors: self.schedule.mag_timeouts(),
                dma_errors: DMA_ERRORS.load(Ordering::Relaxed),
                requests_early: REQUESTS_EARLY.load(Ordering::Relaxed),
                gnss_bytes_dropped: GNSS_BYTES_DROPPED.load(Ordering::Relaxed),
                gnss_frame_errors: GNSS_FRAME_ERRORS.load(Ordering::Relaxed),
                watchdog_resets: self.info.health.watchdog_resets,
                accel_age_ms,
                gyro_age_ms,
                mag_age_ms,
                bmp280_age_ms,
            }
        }

        /// The fault counters now (the reset fault as at boot).
        fn faults(&self) -> BoardFaults {
            BoardFaults {
                gnss_overrun_errors: GNSS_OVERRUN_ERRORS.load(Ordering::Relaxed),
                gnss_framing_errors: GNSS_FRAMING_ERRORS.load(Ordering::Relaxed),
                gnss_noise_errors: GNSS_NOISE_ERRORS.load(Ordering::Relaxed),
                sample_overruns: self.overruns,
                reset_fault: self.info.faults.reset_fault,
            }
        }

        /// Counts an overrun when the next period began while this tick ran: that tick starts
        /// late (and, should it overrun too, one is lost). Counted, not hidden.
        fn count_overrun(&mut self) {
            if self.timer.flags().contains(Flag::Update) {
                self.overruns = self.overruns.wrapping_add(1);
            }
        }
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

    impl GnssLatest {
        /// No frame yet.
        const NONE: Self = Self {
            frame: [0; GNSS_FRAME_LEN],
            fresh: false,
        };
    }

    /// The GNSS receive path: the receiver, the UBX reader, and the configurator's tap.
    pub struct GnssIn {
        rx: gnss::GnssRx,
        reader: GnssReader,
        tap: ReplyTap<'static>,
        errors: UartErrors,
    }

    impl GnssIn {
        /// The receive path at boot: an empty reader, no line errors counted, replies for the
        /// configurator going to `replies`.
        fn new(rx: gnss::GnssRx, replies: heapless::spsc::Producer<'static, u8>) -> Self {
            Self {
                rx,
                reader: GnssReader::with_capacity(),
                tap: ReplyTap::new(replies),
                errors: UartErrors::new(),
            }
        }

        /// Drains the receiver into the reader (and, while the receiver is being configured,
        /// into the configurator's queue) and updates the GNSS counters; returns the NAV-PVT
        /// frame that completed, if any.
        fn receive(&mut self) -> Option<[u8; GNSS_FRAME_LEN]> {
            let reader = &mut self.reader;
            let tap = &mut self.tap;
            // Before the drain: the error flags of the bytes about to be handed on.
            let line_status = gnss::line_status();
            let mut received = 0;
            self.rx.drain(|bytes| {
                received = bytes.len();
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
            self.errors.count(line_status, received);
            GNSS_OVERRUN_ERRORS.store(self.errors.overrun, Ordering::Relaxed);
            GNSS_FRAMING_ERRORS.store(self.errors.framing, Ordering::Relaxed);
            GNSS_NOISE_ERRORS.store(self.errors.noise, Ordering::Relaxed);
            let stats = reader.stats();
            GNSS_BYTES_DROPPED.store(stats.bytes_skipped, Ordering::Relaxed);
            GNSS_FRAME_ERRORS.store(stats.checksum_errors, Ordering::Relaxed);
            let frame = *reader.take_nav_pvt()?.as_bytes();
            GNSS_SEEN.store(true, Ordering::Relaxed);
            Some(frame)
        }
    }

    /// Hands a new NAV-PVT frame to the sampling tick.
    fn publish_nav_pvt(
        mut latest: impl rtic::Mutex<T = GnssLatest>,
        frame: Option<[u8; GNSS_FRAME_LEN]>,
    ) {
        if let Some(frame) = frame {
            latest.lock(|gnss| {
                gnss.frame = frame;
                gnss.fresh = true;
            });
        }
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
        /// The GNSS receive path, driven by both GNSS interrupts (same priority: no lock).
        #[lock_free]
        gnss_in: GnssIn,
    }

    #[local]
    struct Local {
        request_pin: gpio::PD10<Input>,
        sampler: Sampler,
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
        let reset = record_reset_cause(&dp.RCC);
        // First, before anything that can wait for ever: the HAL waits for the crystal (and
        // the PLL) with no time-out. The IWDG runs from the LSI, whatever HSE does; a crystal
        // that never starts resets the board after WATCHDOG_MS instead of hanging it.
        setup::boot_step("watchdog");
        let mut watchdog = setup::watchdog(dp.IWDG);
        setup::boot_step("clocks");
        let (mut rcc, sysclk_hz) = setup::start_clocks(dp.RCC, cx.core);

        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpiod = dp.GPIOD.split(&mut rcc);
        let gpioe = dp.GPIOE.split(&mut rcc);

        setup::boot_step("sensors");
        let (sensors, sensor_report) = sensors::set_up(
            dp.SPI1,
            gpioa,
            gpioe,
            cx.local.spi_cell,
            &mut rcc,
            sysclk_hz,
        );
        let link_buffers = link::Buffers {
            piece: cx.local.piece_buffer,
            packet_a: cx.local.packet_a,
            packet_b: cx.local.packet_b,
        };
        let link = link::set_up(
            dp.USART3,
            dp.DMA1,
            (gpiod.pd8, gpiod.pd9),
            link_buffers,
            &mut rcc,
        )
        .unwrap_or_else(|_| setup::fault(BootFault::LinkSerial));
        let (gnss_rx, gnss_tx) = gnss::set_up(
            dp.USART1,
            dp.DMA2,
            (gpiob.pb6, gpiob.pb7),
            [cx.local.gnss_a, cx.local.gnss_b],
            &mut rcc,
        )
        .unwrap_or_else(|_| setup::fault(BootFault::GnssSerial));
        let (reply_producer, reply_consumer) = cx.local.gnss_replies.split();
        let request_pin = setup::request_line(dp.SYSCFG, &mut dp.EXTI, gpiod.pd10, &mut rcc);
        let timer = setup::sample_timer(dp.TIM2, &mut rcc)
            .unwrap_or_else(|_| setup::fault(BootFault::SampleTimer));
        let crc = setup::crc(dp.CRC, &mut rcc);
        let info = setup::boot_info(&sensor_report, &reset, crc.unit_ok());

        let led = gpiod.pd12.into_push_pull_output();
        finish_boot(&mut watchdog, &info, &rcc, &reset);

        (
            shared_at_boot(link.link, gnss_rx, reply_producer),
            Local {
                request_pin,
                sampler: Sampler::new(timer, watchdog, crc, sensors, info),
                gnss_port: ReplyPort::new(gnss_tx, reply_consumer),
                led,
                #[cfg(feature = "qemu")]
                host_rx: link.host_rx,
            },
        )
    }

    /// Reads why the board reset (see [`setup::reset_cause`]) and keeps the previous boot's
    /// fault in [`BOOT_FAULT`] for a debugger.
    fn record_reset_cause(rcc: &pac::RCC) -> setup::ResetCause {
        let reset = setup::reset_cause(rcc);
        if let Some(cause) = reset.report.boot_fault {
            BOOT_FAULT.store(cause as u8, Ordering::Relaxed);
        }
        reset
    }

    /// The end of `init`: starts the status LED and GNSS set-up tasks, feeds the watchdog (the
    /// rest of its timeout belongs to the first sampling tick, not to `init`) and says the
    /// board is ready.
    fn finish_boot(
        watchdog: &mut IndependentWatchdog,
        info: &InfoFrame,
        rcc: &stm32f4xx_hal::rcc::Rcc,
        reset: &setup::ResetCause,
    ) {
        status_led::spawn(info.status.bits()).ok();
        gnss_setup::spawn().ok();
        watchdog.feed();
        setup::announce_ready(rcc.clocks.pclk2().raw(), reset.report.boot_fault);
    }

    /// The shared resources at boot: no packet yet, the link set up and idle, no NAV-PVT
    /// frame yet, the GNSS receive path ready. Always inlined: the resources are built in
    /// place, not built on the stack and copied.
    #[inline(always)]
    fn shared_at_boot(
        link: link::Link,
        gnss_rx: gnss::GnssRx,
        gnss_replies: heapless::spsc::Producer<'static, u8>,
    ) -> Shared {
        Shared {
            latest: LatestPacket::new(),
            link,
            gnss_latest: GnssLatest::NONE,
            gnss_in: GnssIn::new(gnss_rx, gnss_replies),
        }
    }

    /// Between interrupts. On the board the core spins (as RTIC's default idle does); under
    /// QEMU it waits for the next interrupt, so the emulator does not take a whole host core
    /// while the firmware has nothing to do.
    #[idle]
    // The board's spin is RTIC's own default idle, kept as it was.
    #[cfg_attr(not(feature = "qemu"), allow(clippy::empty_loop))]
    fn idle(_: idle::Context) -> ! {
        loop {
            #[cfg(feature = "qemu")]
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
        while let Ok(byte) = embedded_hal_nb::serial::Read::read(cx.local.host_rx) {
            if byte == PANIC_BYTE {
                PANIC_REQUESTED.store(true, Ordering::Relaxed);
            } else if byte == SLOW_TICK_BYTE {
                SLOW_TICK_REQUESTED.store(true, Ordering::Relaxed);
            } else {
                rtic::pend(pac::Interrupt::EXTI15_10);
            }
        }
    }

    /// Under QEMU: this byte from the host makes the next sampling tick panic (the smoke
    /// test's check of the panic handler); any other byte is a request.
    #[cfg(feature = "qemu")]
    const PANIC_BYTE: u8 = b'!';

    /// Under QEMU: the host asked for a panic (see [`PANIC_BYTE`]).
    #[cfg(feature = "qemu")]
    static PANIC_REQUESTED: AtomicBool = AtomicBool::new(false);

    /// Under QEMU: this byte from the host makes the next sampling tick run until the next
    /// period has begun (the smoke test's check of the overrun count).
    #[cfg(feature = "qemu")]
    const SLOW_TICK_BYTE: u8 = b'~';

    /// Under QEMU: the host asked for a slow tick (see [`SLOW_TICK_BYTE`]).
    #[cfg(feature = "qemu")]
    static SLOW_TICK_REQUESTED: AtomicBool = AtomicBool::new(false);

    /// GNSS bytes (idle line, or under QEMU a received byte).
    /// While the receiver is being configured, the same bytes also go to the configurator.
    #[task(binds = USART1, priority = 2, shared = [gnss_in, gnss_latest])]
    fn gnss_bytes(cx: gnss_bytes::Context) {
        let frame = cx.shared.gnss_in.receive();
        publish_nav_pvt(cx.shared.gnss_latest, frame);
    }

    /// GNSS DMA buffer full before the line went idle: the same drain, which clears this
    /// stream's own flags (transfer complete and the rest) first. It must not count on
    /// USART1's handler (interrupt 37, before this one's 58 when both are pending) to clear
    /// them: with another stream or USART the line would stay pending and this handler
    /// re-enter for ever.
    #[cfg(not(feature = "qemu"))]
    #[task(binds = DMA2_STREAM2, priority = 2, shared = [gnss_in, gnss_latest])]
    fn gnss_dma(cx: gnss_dma::Context) {
        let frame = cx.shared.gnss_in.receive();
        publish_nav_pvt(cx.shared.gnss_latest, frame);
    }

    /// One sampling tick: read what the schedule says, publish the packet, feed the watchdog.
    #[task(binds = TIM2, priority = 1, local = [sampler], shared = [latest, link, gnss_latest])]
    fn sample(mut cx: sample::Context) {
        let sampler = cx.local.sampler;
        sampler.timer.clear_flags(Flag::Update);
        // A panic in the lowest-priority task, as the request task still preempts it.
        #[cfg(feature = "qemu")]
        if PANIC_REQUESTED.load(Ordering::Relaxed) {
            panic!("panic requested by the host");
        }
        sampler.supervise();
        let plan = sampler.schedule.next_tick();
        sampler
            .sensors
            .tick(plan, &mut sampler.schedule, &mut sampler.builder);
        take_nav_pvt(cx.shared.gnss_latest, &mut sampler.builder);
        // The info snapshot first, so one exists whenever a packet does.
        let now_ms = Mono::now().ticks();
        if sampler.snapshot_due(now_ms) {
            let pieces = sampler.take_snapshot(now_ms);
            // Only the copy holds off requests.
            cx.shared.link.lock(|link| link.publish_pieces(&pieces));
        }
        let packet = sampler.builder.build(&mut sampler.crc);
        cx.shared.latest.lock(|latest| latest.publish(packet));
        #[cfg(feature = "qemu")]
        slow_tick_if_requested(&sampler.timer);
        sampler.count_overrun();
    }

    /// Puts the NAV-PVT frame the GNSS task handed over since the last tick, if any, into the
    /// next packet.
    fn take_nav_pvt(mut latest: impl rtic::Mutex<T = GnssLatest>, builder: &mut PacketBuilder) {
        latest.lock(|gnss| {
            if core::mem::take(&mut gnss.fresh) {
                builder.gnss_frame(&gnss.frame);
            }
        });
    }

    /// Under QEMU: when the host asked for it (see [`SLOW_TICK_BYTE`]), runs until the next
    /// period has begun (20 ms of the board's clock at most).
    #[cfg(feature = "qemu")]
    fn slow_tick_if_requested(timer: &CounterHz<TIM2>) {
        if SLOW_TICK_REQUESTED.swap(false, Ordering::Relaxed) {
            let start = Mono::now().ticks();
            while !timer.flags().contains(Flag::Update)
                && Mono::now().ticks().wrapping_sub(start) < 20
            {}
        }
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
