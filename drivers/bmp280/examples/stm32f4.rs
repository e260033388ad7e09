//! A BMP280 on an STM32F4 with stm32f4xx-hal 0.23: SPI1 (PA5 SCK, PA6 MISO, PA7 MOSI, mode 3)
//! with the chip select on PE10, through embedded-hal-bus (use its shared devices when other
//! chips sit on the same bus). Normal mode; the raw register bytes and the compensated values
//! are read every 10 ms.
//!
//! Build: `cargo build --release --example stm32f4 --target thumbv7em-none-eabihf` in a
//! project with `stm32f4xx-hal` (feature `stm32f407`), `cortex-m-rt`, `embedded-hal-bus` and
//! `panic-halt`, and a `memory.x` for the chip; flash with `probe-rs run`.
#![no_std]
#![no_main]

use bosch_bmp280::{Bmp280, Config};
use cortex_m_rt::entry;
use embedded_hal::delay::DelayNs;
use embedded_hal_bus::spi::ExclusiveDevice;
use panic_halt as _;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config as ClockConfig;
use stm32f4xx_hal::spi::{Mode, Phase, Polarity};

#[entry]
fn main() -> ! {
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        panic!("set-up failed: peripherals already taken, or a configuration the HAL rejects");
    };
    let mut rcc = dp.RCC.freeze(ClockConfig::hsi());
    let mut delay = cp.SYST.delay(&rcc.clocks);
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpioe = dp.GPIOE.split(&mut rcc);

    let mode = Mode {
        polarity: Polarity::IdleHigh,
        phase: Phase::CaptureOnSecondTransition,
    };
    let bus = dp.SPI1.spi(
        (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
        mode,
        1.MHz(),
        &mut rcc,
    );
    // A push-pull output cannot fail: the error type is `Infallible`.
    let spi = ExclusiveDevice::new_no_delay(bus, gpioe.pe10.into_push_pull_output())
        .unwrap_or_else(|never| match never {});

    let mut bmp = Bmp280::new_spi(spi);
    // Normal mode, x1/x1, 0.5 ms standby: a new sample about every 6 ms.
    // `measure_when_ready` waits for the first conversion (up to 5.5 ms after `configure`);
    // before it the data registers hold their reset value, which `measure` refuses.
    let ready = bmp.init(&mut delay).is_ok()
        && bmp.configure(Config::default()).is_ok()
        && bmp.measure_when_ready(&mut delay).is_ok();
    let mut latest_raw = [0u8; 6];
    let mut latest_centi_celsius = 0;
    loop {
        if ready {
            if let Ok(bytes) = bmp.read_raw_bytes() {
                latest_raw = bytes; // what a board that forwards raw samples would send
            }
            if let Ok(m) = bmp.measure() {
                latest_centi_celsius = m.temperature_centi_celsius;
            }
        }
        let _ = (latest_raw, latest_centi_celsius);
        delay.delay_ms(10);
    }
}
