//! A Pololu Maestro on an STM32F4 with stm32f4xx-hal 0.23: USART2 (PA2 TX to the Maestro's RX,
//! PA3 RX from its TX) at 115200 baud, compact protocol. Sweeps channel 0 between 1000 and
//! 2000 µs within its limits, then reads the error register.
//!
//! Build: `cargo build --release --example stm32f4 --target thumbv7em-none-eabihf` in a
//! project with `stm32f4xx-hal` (feature `stm32f407`), `cortex-m-rt` and `panic-halt`, and a
//! `memory.x` for the chip; flash with `probe-rs run`.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use embedded_hal::delay::DelayNs;
use panic_halt as _;
use pololu_maestro::{
    Channel, ChannelLimits, Framing, Limits, Maestro, Micro6, PollBudget, QuarterMicros,
};
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
    let gpioa = dp.GPIOA.split(&mut rcc);
    let config = serial::Config::default().baudrate(115_200.bps());
    let (Ok(port), Ok(channel), Ok(limits)) = (
        dp.USART2.serial((gpioa.pa2, gpioa.pa3), config, &mut rcc),
        Channel::new::<Micro6>(0),
        ChannelLimits::from_micros(1000, 2000, 1500),
    ) else {
        panic!("set-up failed: peripherals already taken, or a configuration the HAL rejects");
    };

    let mut maestro = Maestro::new_serial(port, Micro6, Framing::COMPACT)
        .with_limits(Limits::new().with(channel, limits));
    let mut step: u16 = 0;
    loop {
        let micros = 1000 + 50 * (step % 21);
        if let Ok(target) = QuarterMicros::from_micros(micros) {
            let _ = maestro.set_target(channel, target);
        }
        if step % 21 == 20 {
            // About 90 µs per byte at 115200 baud: a few thousand polls are plenty.
            let _ = maestro.get_errors(&mut PollBudget(5_000));
        }
        step = step.wrapping_add(1);
        delay.delay_ms(50);
    }
}
