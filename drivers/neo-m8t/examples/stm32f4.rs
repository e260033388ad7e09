//! A NEO-M8T on an STM32F4 with stm32f4xx-hal 0.23: USART1 (PB6 TX, PB7 RX) at the receiver's
//! factory 9600 baud. Configures it (acknowledged, blocking with a delay), then keeps the latest
//! NAV-PVT frame.
//!
//! Build: `cargo build --release --example stm32f4 --target thumbv7em-none-eabihf` in a
//! project with `stm32f4xx-hal` (feature `stm32f407`), `cortex-m-rt` and `panic-halt`, and a
//! `memory.x` for the chip; flash with `probe-rs run`.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use neo_m8t::{Config, NeoM8t};
use panic_halt as _;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config as ClockConfig;
use stm32f4xx_hal::serial;

#[entry]
fn main() -> ! {
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        panic!("set-up failed: peripherals already taken, or a configuration the HAL rejects");
    };
    let mut rcc = dp.RCC.freeze(ClockConfig::hsi());
    let mut delay = cp.SYST.delay(&rcc.clocks);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let config = serial::Config::default().baudrate(9_600.bps());
    let Ok(port) = dp.USART1.serial((gpiob.pb6, gpiob.pb7), config, &mut rcc) else {
        panic!("set-up failed: peripherals already taken, or a configuration the HAL rejects");
    };

    // 100 bytes hold a NAV-PVT frame; MON-VER during configuration needs the default 512.
    let mut gnss = NeoM8t::new(port);
    // The receiver stays at 9600 baud here (`Config::default()` asks for another rate: the
    // callback would switch the host UART, which this sketch keeps fixed).
    let configured = gnss
        .configure_blocking(
            Config::default().with_baud_rate(9_600),
            9_600,
            &mut delay,
            |_, _| {},
        )
        .is_ok();
    let mut latest_itow_ms = 0;
    loop {
        if let Ok(Some(frame)) = gnss.poll_nav_pvt() {
            latest_itow_ms = frame.to_nav_pvt().itow_ms;
        }
        let _ = (configured, latest_itow_ms);
    }
}
