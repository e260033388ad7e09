//! The boot-time set-up steps `init` calls, one per peripheral, in the order it calls them.
//! The sensors, the link and the GNSS receiver have theirs in their own modules
//! (`sensors::set_up`, `link::set_up`, `gnss::set_up`).
//!
//! Where QEMU's `netduinoplus2` differs from the board (`qemu` feature), the step has an
//! emulator twin right beside it, with the same signature, so `init` never branches on the
//! build.

use crate::board::*;
use crate::hw_crc::HwCrc;
use dima_firmware_logic::reset_record::{BootFault, ResetReport};
use dima_firmware_logic::{BootReport, CheckedCrc};
use dima_sensorboard::{BoardFaults, BoardHealth, InfoFrame, SensorStatus, INFO_VERSION};
use stm32f4xx_hal::gpio::{self, Edge, Input};
use stm32f4xx_hal::pac::{self, CRC, EXTI, IWDG, SYSCFG, TIM2};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{Config, Rcc};
use stm32f4xx_hal::timer::{self, CounterHz, Event};
use stm32f4xx_hal::watchdog::IndependentWatchdog;

/// The CRC unit if it passed its boot-time self-check, else the small software CRC.
/// (QEMU does not model the unit: there the check fails and the fallback runs.)
pub type Crc = CheckedCrc<HwCrc>;

/// Why this boot happened, as read from RCC's reset flags and the reset record.
pub struct ResetCause {
    /// The independent watchdog reset the board (RCC_CSR `WDGRSTF`).
    pub by_watchdog: bool,
    /// What the reset record says: watchdog resets since power-on, the previous boot's fault.
    pub report: ResetReport,
}

/// Reads RCC's reset flags, updates the reset record with them, then clears the flags. Call
/// it before anything else: the flags say why we reset.
pub fn reset_cause(rcc: &pac::RCC) -> ResetCause {
    let csr = rcc.csr().read();
    let by_watchdog = csr.wdgrstf().bit_is_set();
    let report = crate::reset_record::after_reset(csr.porrstf().bit_is_set(), by_watchdog);
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    ResetCause {
        by_watchdog,
        report,
    }
}

/// The board's clocks: the 8 MHz crystal through the PLL to [`SYSCLK_HZ`].
#[cfg(not(feature = "qemu"))]
pub fn clock_config() -> Config {
    Config::hse(HSE_HZ.Hz()).sysclk(SYSCLK_HZ.Hz())
}

/// Emulator twin: QEMU models no RCC, so HSE and PLL would never report ready: the internal
/// oscillator, untouched.
#[cfg(feature = "qemu")]
pub fn clock_config() -> Config {
    Config::hsi()
}

/// RTIC priority of the SysTick exception: below `request` and `link_done` (3), equal to
/// the GNSS tasks (2), above sampling (1).
const SYSTICK_PRIORITY: u8 = 2;

/// Freezes the clock tree to [`clock_config`] (the HAL waits for the crystal and the PLL with
/// no time-out: start the watchdog first), then starts the monotonic clock at the resulting
/// system clock. Returns the clocks and the system clock in Hz.
pub fn start_clocks(rcc: pac::RCC, mut core: cortex_m::Peripherals) -> (Rcc, u32) {
    let rcc = rcc.freeze(clock_config());
    let sysclk_hz = rcc.clocks.sysclk().raw();
    start_monotonic(&mut core.SCB, core.SYST, sysclk_hz);
    (rcc, sysclk_hz)
}

/// Starts the monotonic clock on SysTick, whose exception priority it sets first: below the
/// link tasks, so it can never hold off a request edge; above sampling, so a long tick cannot
/// lose a counter wrap.
pub fn start_monotonic(
    scb: &mut cortex_m::peripheral::SCB,
    syst: cortex_m::peripheral::SYST,
    sysclk_hz: u32,
) {
    set_systick_priority(scb, SYSTICK_PRIORITY);
    crate::Mono::start(syst, core_clock_hz(sysclk_hz));
}

/// The clock SysTick counts: the system clock the HAL set up.
#[cfg(not(feature = "qemu"))]
fn core_clock_hz(sysclk_hz: u32) -> u32 {
    sysclk_hz
}

/// Emulator twin: QEMU's netduinoplus2 clocks the core at a fixed 168 MHz whatever RCC says.
#[cfg(feature = "qemu")]
fn core_clock_hz(_sysclk_hz: u32) -> u32 {
    QEMU_CORE_HZ
}

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

/// The request line: PD10, pulled down, interrupting (EXTI15_10) on a rising edge.
pub fn request_line(
    syscfg: SYSCFG,
    exti: &mut EXTI,
    pin: gpio::PD10,
    rcc: &mut Rcc,
) -> gpio::PD10<Input> {
    let mut syscfg = syscfg.constrain(rcc);
    let mut request_pin = pin.into_pull_down_input();
    request_pin.make_interrupt_source(&mut syscfg);
    request_pin.trigger_on_edge(exti, Edge::Rising);
    request_pin.enable_interrupt(exti);
    request_pin
}

/// The sampling tick: TIM2 at [`SAMPLE_RATE_HZ`], interrupting on update. Fails if the
/// timer cannot reach the rate.
pub fn sample_timer(tim2: TIM2, rcc: &mut Rcc) -> Result<CounterHz<TIM2>, timer::Error> {
    let mut timer = tim2.counter_hz(rcc);
    timer.start(SAMPLE_TIMER_REQUEST_HZ.Hz())?;
    #[cfg(feature = "qemu")]
    align_emulated_timer();
    timer.listen(Event::Update);
    Ok(timer)
}

/// Emulator twin only: QEMU's timer model (`stm32f2xx_timer`, QEMU 7.2) schedules each
/// update at `now + (ARR + offset)` ticks, where `offset` is the emulator's time, in timer
/// ticks, of the last write to CNT, PSC or EGR: a timer started `t` after reset interrupts
/// every `t` + one period, so the longer `init` takes (it waits for the host's sensor
/// images), the slower the sampling tick. Writing CNT with the emulator's current time in
/// ticks makes that offset zero and the period the one asked for. TIM5, never written, counts
/// the emulator's nanoseconds since reset (prescaler 1 at reset); good for the first 4.29 s.
#[cfg(feature = "qemu")]
fn align_emulated_timer() {
    // SAFETY: reads of TIM5_CNT (unused by the firmware) and TIM2_PSC, and a write of TIM2_CNT
    // right after the HAL started TIM2, in `init` (interrupts off); the count it writes only
    // moves the next update of an emulated timer.
    #[allow(unsafe_code)]
    unsafe {
        let now_ns = (*pac::TIM5::ptr()).cnt().read().bits();
        let tim2 = &*pac::TIM2::ptr();
        let prescaler = tim2.psc().read().bits() + 1;
        tim2.cnt().write(|w| w.bits(now_ns / prescaler));
    }
}

/// The rate asked of the HAL for the sampling timer: the sampling rate itself.
#[cfg(not(feature = "qemu"))]
const SAMPLE_TIMER_REQUEST_HZ: u32 = SAMPLE_RATE_HZ;

/// Emulator twin: the HAL sets the prescalers for its idea of the timer clock (HSI), but
/// QEMU runs the timer at a fixed 1 GHz, so ask for a rate that lands on [`SAMPLE_RATE_HZ`]
/// there.
#[cfg(feature = "qemu")]
const SAMPLE_TIMER_REQUEST_HZ: u32 =
    (SAMPLE_RATE_HZ as u64 * HSI_HZ as u64 / QEMU_TIMER_HZ as u64) as u32;

/// Starts the independent watchdog with a [`WATCHDOG_MS`] timeout; the sampling tick feeds it.
/// Call it first in `init`: the IWDG runs from the LSI, so it also ends a clock set-up that
/// waits for a crystal that never starts.
pub fn watchdog(iwdg: IWDG) -> IndependentWatchdog {
    let mut watchdog = IndependentWatchdog::new(iwdg);
    watchdog.start(WATCHDOG_MS.millis());
    watchdog
}

/// The CRC unit, checked against a known vector (see [`Crc`]).
pub fn crc(crc: CRC, rcc: &mut Rcc) -> Crc {
    CheckedCrc::check(HwCrc(stm32f4xx_hal::crc32::Crc32::new(crc, rcc)))
}

/// The info frame as it stands at boot: what the sensors reported, the reset cause (the
/// watchdog bit, and the fault that reset the previous boot) and the CRC unit's self-check,
/// no uptime and no counts yet.
pub fn boot_info(sensors: &BootReport, reset: &ResetCause, crc_unit_ok: bool) -> InfoFrame {
    let mut status = sensors.status;
    status.set(SensorStatus::WATCHDOG_RESET, reset.by_watchdog);
    status.set(SensorStatus::CRC_UNIT_FAILED, !crc_unit_ok);
    InfoFrame {
        version: INFO_VERSION,
        firmware: FIRMWARE_VERSION,
        status,
        bmp280_calibration: sensors.bmp280_calibration,
        bmm150_trim: sensors.bmm150_trim,
        uptime_ms: 0,
        requests_skipped: 0,
        health: BoardHealth {
            watchdog_resets: reset.report.watchdog_resets,
            ..BoardHealth::default()
        },
        faults: BoardFaults {
            reset_fault: reset.report.boot_fault.map_or(0, |fault| fault as u8),
            ..BoardFaults::default()
        },
    }
}

/// A step of `init` is about to start (`watchdog`, `clocks`, `sensors`, ...). Nothing to
/// announce on the board.
#[cfg(not(feature = "qemu"))]
pub fn boot_step(_step: &str) {}

/// Emulator twin: tells the smoke test, over semihosting, which step of `init` starts next
/// (`boot: clocks`), so it can check their order: the watchdog must run before anything that
/// can wait for ever (the HAL waits for the crystal and the PLL without a time-out).
#[cfg(feature = "qemu")]
pub fn boot_step(step: &str) {
    cortex_m_semihosting::hprintln!("boot: {}", step);
}

/// The end of the set-up. Nothing to announce on the board.
#[cfg(not(feature = "qemu"))]
pub fn announce_ready(_pclk2_hz: u32, _boot_fault: Option<BootFault>) {}

/// Emulator twin: tells the smoke test, over semihosting, SPI1_CR1 as the HAL wrote it with
/// the APB2 clock `pclk2_hz` it computed the divider for (QEMU keeps the register), the
/// exception priorities as the core holds them (QEMU models SCB and NVIC; SysTick must be
/// below the request interrupt, a larger value), the fault that reset the previous boot
/// (`reset: fault Panic`, or `none`), then `ready`.
#[cfg(feature = "qemu")]
pub fn announce_ready(pclk2_hz: u32, boot_fault: Option<BootFault>) {
    match boot_fault {
        Some(fault) => cortex_m_semihosting::hprintln!("reset: fault {:?}", fault),
        None => cortex_m_semihosting::hprintln!("reset: fault none"),
    }
    // SAFETY: a read of SPI1_CR1, which the sensor set-up has written; no side effect.
    #[allow(unsafe_code)]
    let spi1_cr1 = unsafe { (*pac::SPI1::ptr()).cr1().read().bits() };
    cortex_m_semihosting::hprintln!("spi1: cr1 {:#06x}, pclk2 {} Hz", spi1_cr1, pclk2_hz);
    cortex_m_semihosting::hprintln!(
        "priorities: systick {:#04x}, request {:#04x}",
        cortex_m::peripheral::SCB::get_priority(cortex_m::peripheral::scb::SystemHandler::SysTick),
        cortex_m::peripheral::NVIC::get_priority(pac::Interrupt::EXTI15_10)
    );
    cortex_m_semihosting::hprintln!("ready");
}

/// A configuration the hardware rejected at boot: record the cause for the next boot and
/// let the watchdog reset the board.
///
/// `init` starts the IWDG first ([`WATCHDOG_MS`], 68-188 ms over the LSI's 17-47 kHz range),
/// so it is already running here and the start key changes nothing. Should it not be (a
/// future `init` calling `fault` earlier), the start key starts it with its reset values
/// (prescaler /4, reload 0xFFF): 512 ms at the nominal 32 kHz, 350-960 ms over the LSI's
/// range. The next boot sees a watchdog reset (status bit 5, `watchdog_resets`) and the cause
/// in the reset record (`BOOT_FAULT`). QEMU models no IWDG: there this waits for ever.
pub fn fault(cause: BootFault) -> ! {
    /// The IWDG key register's start key (RM0090 19.4.1).
    const KEY_START: u16 = 0xCCCC;
    crate::reset_record::record_fault(cause);
    // SAFETY: the key register is write-only; the start key only starts the counter (a
    // running watchdog stays as it is, its prescaler and reload untouched). `fault` never
    // returns, so nothing relies on the watchdog being stopped or fed afterwards.
    #[allow(unsafe_code)]
    unsafe {
        (*pac::IWDG::ptr()).kr().write(|w| w.key().bits(KEY_START))
    };
    loop {
        cortex_m::asm::wfi();
    }
}
