//! Hardware self-test of the DIMA sensor board, reported over RTT.
//!
//! Checks, on the real board, what neither the host tests nor QEMU can: the CRC unit, the four
//! sensor dies on SPI1 and the SPI clock read back from SPI1_CR1, one DMA packet transfer on
//! USART3, GNSS bytes on USART1 and the watchdog reset record. Prints the reset cause first. One line per check, `ok` or `FAILED`, then a summary line.
//!
//! ```text
//! cd firmware
//! cargo run --release --example hwtest    # probe-rs run --chip STM32F407VGTx, RTT to the terminal
//! ```
//!
//! The watchdog check takes two boots: the first one (after power-on, no watchdog reset
//! recorded) starts the IWDG and stops feeding it, so the board resets about 100 ms after the
//! summary; the second boot reports the recorded watchdog reset and then feeds the watchdog
//! for ever. See the firmware README, "Hardware test", for what each line means.
#![no_std]
#![no_main]

#[path = "../src/board.rs"]
#[allow(dead_code)]
mod board;
#[path = "../src/reset_record.rs"]
#[allow(dead_code)]
mod reset_record;

use cortex_m_rt::entry;
use dima_firmware_logic::reset_record::ResetReport;
use dima_firmware_logic::spi_clock;
use dima_sensorboard::{PacketBuilder, SensorCrc, PACKET_LEN};
use rtt_target::{rprintln, rtt_init_print};
use stm32f4xx_hal::dma::{config::DmaConfig, StreamsTuple, Transfer};
use stm32f4xx_hal::gpio::{self, gpioa, gpioe, Output, PartiallyErasedPin, PushPull};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{Config, Rcc};
use stm32f4xx_hal::serial::{self, config::StopBits};
use stm32f4xx_hal::spi::{Mode, Phase, Polarity, Spi};
use stm32f4xx_hal::timer::SysDelay;
use stm32f4xx_hal::watchdog::IndependentWatchdog;

/// The sensor CRC's reference vector (docs/wire-formats.md): bytes 0x00..=0x7F, one
/// zero-extended byte per 32-bit word.
const CRC_VECTOR: u32 = 0x6557_DE1A;

/// How long to listen for GNSS bytes, in busy-wait milliseconds.
const GNSS_LISTEN_MS: u32 = 2_000;

/// Tallies the checks.
struct Report {
    passed: u32,
    failed: u32,
}

impl Report {
    fn check(&mut self, ok: bool, line: core::fmt::Arguments<'_>) {
        if ok {
            self.passed += 1;
            rprintln!("ok      {}", line);
        } else {
            self.failed += 1;
            rprintln!("FAILED  {}", line);
        }
    }
}

/// The CRC unit fed the firmware's way (see `src/hw_crc.rs`).
struct HwCrc(stm32f4xx_hal::crc32::Crc32);

impl SensorCrc for HwCrc {
    fn checksum(&mut self, bytes: &[u8]) -> u32 {
        self.0.init();
        let mut value = 0xFFFF_FFFF;
        for &byte in bytes {
            value = self.0.update(&[u32::from(byte)]);
        }
        value
    }
}

type ChipSelect = PartiallyErasedPin<'E', Output<PushPull>>;

/// A chip select, deselected (high).
fn select(mut pin: ChipSelect) -> ChipSelect {
    pin.set_high();
    pin
}

/// Reads one register of a die: address with the read bit, then one byte (SPI mode 3).
fn read_register(spi: &mut Spi<pac::SPI1>, cs: &mut ChipSelect, register: u8) -> Option<u8> {
    let mut frame = [register | 0x80, 0];
    cs.set_low();
    let result = spi.transfer_in_place(&mut frame);
    cs.set_high();
    result.ok().map(|()| frame[1])
}

fn write_register(spi: &mut Spi<pac::SPI1>, cs: &mut ChipSelect, register: u8, value: u8) {
    cs.set_low();
    let _ = spi.write(&[register & 0x7F, value]);
    cs.set_high();
}

#[entry]
fn main() -> ! {
    rtt_init_print!();
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        panic!("peripherals already taken");
    };
    let reset = read_reset_cause(&dp.RCC);
    let mut rcc = dp
        .RCC
        .freeze(Config::hse(board::HSE_HZ.Hz()).sysclk(board::SYSCLK_HZ.Hz()));
    let sysclk_hz = rcc.clocks.sysclk().raw();
    let mut delay = cp.SYST.delay(&rcc.clocks);
    rprintln!(
        "dima hwtest {}: sysclk {} Hz",
        env!("CARGO_PKG_VERSION"),
        sysclk_hz
    );
    print_reset_cause(&reset);
    let mut report = Report {
        passed: 0,
        failed: 0,
    };

    let mut crc = HwCrc(stm32f4xx_hal::crc32::Crc32::new(dp.CRC, &mut rcc));
    check_crc_unit(&mut report, &mut crc);
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let gpiod = dp.GPIOD.split(&mut rcc);
    let gpioe = dp.GPIOE.split(&mut rcc);
    check_chip_ids(&mut report, dp.SPI1, gpioa, gpioe, &mut rcc, &mut delay);
    check_dma_packet(
        &mut report,
        dp.USART3,
        dp.DMA1,
        gpiod.pd8,
        &mut crc,
        &mut rcc,
        &mut delay,
    );
    check_gnss_bytes(&mut report, dp.USART1, gpiob.pb7, &mut rcc, &mut delay);
    let second_boot = check_reset_record(&mut report, &reset);

    rprintln!("{} passed, {} failed", report.passed, report.failed);

    // The watchdog check's boot half: the first boot stops feeding (the board resets, the
    // next boot reports it), the second feeds for ever.
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.start(board::WATCHDOG_MS.millis());
    if second_boot {
        rprintln!("watchdog check done: feeding the watchdog from now on");
        loop {
            watchdog.feed();
            delay.delay_ms(10);
        }
    }
    rprintln!(
        "watchdog armed ({} ms) and not fed: the board resets, the next boot reports it",
        board::WATCHDOG_MS
    );
    loop {
        cortex_m::asm::wfi();
    }
}

/// Why this boot happened: RCC's reset flags, read before anything else and then cleared, and
/// the reset record they update.
struct ResetCause {
    /// The watchdog reset the board (RCC_CSR `WDGRSTF`).
    by_watchdog: bool,
    /// RCC_CSR as read at boot, before the flags were cleared.
    csr: u32,
    /// What the reset record says (watchdog resets since power-on).
    record: ResetReport,
}

/// Reads RCC's reset flags, updates the reset record with them and clears the flags.
fn read_reset_cause(rcc: &pac::RCC) -> ResetCause {
    let csr = rcc.csr().read();
    let by_watchdog = csr.wdgrstf().bit_is_set();
    let record = reset_record::after_reset(csr.porrstf().bit_is_set(), by_watchdog);
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    ResetCause {
        by_watchdog,
        csr: csr.bits(),
        record,
    }
}

/// Prints why this boot happened: RCC_CSR's reset flags (RM0090 7.3.21) and the fault the
/// reset record holds for it (a panic or a step of `init` in the firmware; the self-test
/// itself records none).
fn print_reset_cause(reset: &ResetCause) {
    const FLAGS: [(u32, &str); 7] = [
        (1 << 25, "brown-out"),
        (1 << 26, "pin"),
        (1 << 27, "power-on"),
        (1 << 28, "software"),
        (1 << 29, "independent watchdog"),
        (1 << 30, "window watchdog"),
        (1 << 31, "low power"),
    ];
    rprintln!("reset cause: RCC_CSR {:#010x}", reset.csr);
    for (bit, name) in FLAGS {
        if reset.csr & bit != 0 {
            rprintln!("  {} reset", name);
        }
    }
    match reset.record.boot_fault {
        Some(fault) => rprintln!("  fault recorded by the previous boot: {:?}", fault),
        None => rprintln!("  no fault recorded by the previous boot"),
    }
}

/// Check 1: the CRC unit against the reference vector.
fn check_crc_unit(report: &mut Report, crc: &mut HwCrc) {
    let ascending: [u8; 128] = core::array::from_fn(|i| i as u8);
    let value = crc.checksum(&ascending);
    report.check(
        value == CRC_VECTOR,
        format_args!("crc unit: bytes 0x00..=0x7F -> {value:#010x} (want {CRC_VECTOR:#010x})"),
    );
}

/// Check 2: the four chip ids on SPI1 (mode 3, PA5/PA6/PA7), chip selects PE7..PE10.
fn check_chip_ids(
    report: &mut Report,
    spi1: pac::SPI1,
    gpioa: gpioa::Parts,
    gpioe: gpioe::Parts,
    rcc: &mut Rcc,
    delay: &mut SysDelay,
) {
    let pclk2_hz = rcc.clocks.pclk2().raw();
    let mut spi = spi1.spi(
        (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
        Mode {
            polarity: Polarity::IdleHigh,
            phase: Phase::CaptureOnSecondTransition,
        },
        spi_clock::sensor_request_hz(pclk2_hz).Hz(),
        rcc,
    );
    check_spi_clock(report, pclk2_hz);
    let mut accel = select(gpioe.pe7.into_push_pull_output().erase_number());
    let mut gyro = select(gpioe.pe8.into_push_pull_output().erase_number());
    let mut mag = select(gpioe.pe9.into_push_pull_output().erase_number());
    let mut bmp280 = select(gpioe.pe10.into_push_pull_output().erase_number());
    // The magnetometer answers only after its power control bit is set (BMM150 0x4B bit 0).
    write_register(&mut spi, &mut mag, 0x4B, 0x01);
    delay.delay_ms(3);
    for (name, cs, register, want) in [
        ("accelerometer (BMX055, PE7)", &mut accel, 0x00, 0xFA),
        ("gyroscope (BMX055, PE8)", &mut gyro, 0x00, 0x0F),
        ("magnetometer (BMX055, PE9)", &mut mag, 0x40, 0x32),
        ("BMP280 (PE10)", &mut bmp280, 0xD0, 0x58),
    ] {
        let id = read_register(&mut spi, cs, register);
        report.check(
            id == Some(want),
            format_args!("chip id {name}: {id:02x?} (want {want:#04x})"),
        );
    }
}

/// Check 2a: the SPI1 clock as programmed (SPI1_CR1's baud-rate bits read back) is within
/// the sensors' 10 MHz.
fn check_spi_clock(report: &mut Report, pclk2_hz: u32) {
    // SAFETY: a read of SPI1_CR1, which the HAL has just written; no side effect.
    #[allow(unsafe_code)]
    let cr1 = unsafe { (*pac::SPI1::ptr()).cr1().read().bits() };
    let divider = spi_clock::divider_of_br(((cr1 >> 3) & 0b111) as u8);
    let spi_hz = pclk2_hz / divider;
    report.check(
        spi_hz <= spi_clock::SENSOR_SPI_MAX_HZ,
        format_args!(
            "spi clock: SPI1_CR1 {cr1:#06x}, APB2 {pclk2_hz} Hz / {divider} = {spi_hz} Hz (at most {} Hz)",
            spi_clock::SENSOR_SPI_MAX_HZ
        ),
    );
}

/// Check 3: one 132-byte packet by DMA1 stream 3 to USART3 (PD8, the host link, 8N2).
fn check_dma_packet(
    report: &mut Report,
    usart3: pac::USART3,
    dma1: pac::DMA1,
    tx_pin: gpio::PD8,
    crc: &mut HwCrc,
    rcc: &mut Rcc,
    delay: &mut SysDelay,
) {
    let link_config = serial::Config::default()
        .baudrate(board::LINK_BAUD.bps())
        .stopbits(StopBits::STOP2)
        .dma(serial::config::DmaConfig::Tx);
    let Ok(tx) = usart3.tx(tx_pin, link_config, rcc) else {
        report.check(
            false,
            format_args!("dma packet: USART3 rejected its configuration"),
        );
        return;
    };
    let Some(buffer) = cortex_m::singleton!(: [u8; PACKET_LEN] = [0; PACKET_LEN]) else {
        panic!("packet buffer taken twice");
    };
    *buffer = *PacketBuilder::new().build(crc);
    let streams = StreamsTuple::new(dma1, rcc);
    let mut transfer = Transfer::init_memory_to_peripheral(
        streams.3,
        tx,
        buffer,
        None,
        DmaConfig::default().memory_increment(true),
    );
    transfer.start(|_| {});
    // 3.15 ms on the wire at 460 800 baud: allow 20 ms.
    let mut waited_us = 0u32;
    while !transfer.is_transfer_complete() && waited_us < 20_000 {
        delay.delay_us(10);
        waited_us += 10;
    }
    let done = transfer.is_transfer_complete();
    let error = transfer.is_transfer_error();
    report.check(
        done && !error,
        format_args!(
            "dma packet: 132 bytes on USART3 by DMA1 stream 3, complete after ~{waited_us} us \
             (3151 us on the wire), transfer error {error}"
        ),
    );
}

/// Check 4: GNSS bytes on USART1 (PB7, 115 200 baud) within [`GNSS_LISTEN_MS`].
fn check_gnss_bytes(
    report: &mut Report,
    usart1: pac::USART1,
    rx_pin: gpio::PB7,
    rcc: &mut Rcc,
    delay: &mut SysDelay,
) {
    let gnss_config = serial::Config::default().baudrate(board::GNSS_BAUD.bps());
    let Ok(mut rx) = usart1.rx(rx_pin, gnss_config, rcc) else {
        report.check(
            false,
            format_args!("gnss: USART1 rejected its configuration"),
        );
        return;
    };
    let (mut bytes, mut ubx_sync) = (0u32, 0u32);
    let mut previous = 0u8;
    for _ in 0..GNSS_LISTEN_MS * 100 {
        while let Ok(byte) = embedded_hal_nb::serial::Read::read(&mut rx) {
            bytes += 1;
            ubx_sync += u32::from(previous == 0xB5 && byte == 0x62);
            previous = byte;
        }
        delay.delay_us(10);
    }
    report.check(
        bytes > 0,
        format_args!(
            "gnss: {bytes} bytes in {GNSS_LISTEN_MS} ms on USART1, {ubx_sync} UBX frame starts"
        ),
    );
}

/// Check 5: the watchdog reset record (kept in `.uninit` RAM across resets, as the firmware
/// does). Returns whether this is the second boot of the watchdog check (a watchdog reset
/// is on record).
fn check_reset_record(report: &mut Report, reset: &ResetCause) -> bool {
    let second_boot = reset.record.watchdog_resets > 0;
    report.check(
        !reset.by_watchdog || second_boot,
        format_args!(
            "reset record: watchdog resets since power-on {}, this boot by the watchdog {}",
            reset.record.watchdog_resets, reset.by_watchdog
        ),
    );
    second_boot
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    rprintln!("panic: {}", info);
    loop {
        cortex_m::asm::bkpt();
    }
}
