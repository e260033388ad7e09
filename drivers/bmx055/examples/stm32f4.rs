//! The three BMX055 dies on an STM32F4 with stm32f4xx-hal 0.23: SPI1 (PA5 SCK, PA6 MISO,
//! PA7 MOSI, mode 3) shared through embedded-hal-bus's `RefCellDevice`, chip selects PE7
//! (accelerometer), PE8 (gyroscope) and PE9 (magnetometer). Samples every millisecond.
//!
//! Build: `cargo build --release --example stm32f4 --target thumbv7em-none-eabihf` in a
//! project with `stm32f4xx-hal` (feature `stm32f407`), `cortex-m-rt`, `embedded-hal-bus` and
//! `panic-halt`, and a `memory.x` for the chip; flash with `probe-rs run`.
#![no_std]
#![no_main]

use core::cell::RefCell;

use bosch_bmx055::accel::{AccelBandwidth, AccelConfig};
use bosch_bmx055::gyro::{GyroBandwidth, GyroConfig};
use bosch_bmx055::mag::{MagConfig, MagPreset};
use bosch_bmx055::{Bmx055, Bmx055Config, ImuSample};
use cortex_m_rt::entry;
use embedded_hal::delay::DelayNs;
use embedded_hal_bus::spi::{NoDelay, RefCellDevice};
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
    let bus = RefCell::new(dp.SPI1.spi(
        (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
        mode,
        1.MHz(),
        &mut rcc,
    ));
    // A push-pull output cannot fail: the error type is `Infallible`.
    let device = |cs| RefCellDevice::new(&bus, cs, NoDelay).unwrap_or_else(|never| match never {});
    let accel = device(gpioe.pe7.into_push_pull_output().erase());
    let gyro = device(gpioe.pe8.into_push_pull_output().erase());
    let mag = device(gpioe.pe9.into_push_pull_output().erase());

    let mut imu = Bmx055::new_spi(accel, gyro, mag);
    // ±2 g at 250 Hz bandwidth, ±2000 °/s at 2000 Hz / 230 Hz, magnetometer on request.
    let config = Bmx055Config {
        accel: AccelConfig::default().with_bandwidth(AccelBandwidth::Hz250),
        gyro: GyroConfig {
            bandwidth: GyroBandwidth::Odr2000Bw230,
            ..GyroConfig::default()
        },
        mag: MagConfig::forced(MagPreset::LowPower),
    };
    let ready = imu.init(&mut delay, &config).is_ok();
    let mut latest = ImuSample::default();
    loop {
        if ready {
            if let Ok(sample) = imu.sample() {
                latest = sample; // raw words, left-justified with the status bits masked
            }
        }
        let _ = latest;
        delay.delay_ms(1);
    }
}
