//! An XBee in API mode (`AP = 2`) on an STM32F4 with stm32f4xx-hal 0.23: USART2 (PA2 TX, PA3 RX)
//! at 9600 baud. Sends a frame to the coordinator once a second and keeps the last delivery
//! status and the length of the last received payload.
//!
//! Build: `cargo build --release --example stm32f4 --target thumbv7em-none-eabihf` in a
//! project with `stm32f4xx-hal` (feature `stm32f407`), `cortex-m-rt` and `panic-halt`, and a
//! `memory.x` for the chip; flash with `probe-rs run`.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use embedded_hal::delay::DelayNs;
use panic_halt as _;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config as ClockConfig;
use stm32f4xx_hal::serial;
use xbee_driver::{Address64, ApiEscaping, Frame, XBee};

#[entry]
fn main() -> ! {
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        panic!("set-up failed: peripherals already taken, or a configuration the HAL rejects");
    };
    let mut rcc = dp.RCC.freeze(ClockConfig::hsi());
    let mut delay = cp.SYST.delay(&rcc.clocks);
    let gpioa = dp.GPIOA.split(&mut rcc);
    let config = serial::Config::default().baudrate(9_600.bps());
    let Ok(port) = dp.USART2.serial((gpioa.pa2, gpioa.pa3), config, &mut rcc) else {
        panic!("set-up failed: peripherals already taken, or a configuration the HAL rejects");
    };

    let mut xbee = XBee::new_api(port, ApiEscaping::Escaped);
    let mut delivery_status = 0xFF;
    let mut received_len = 0;
    let mut ms: u32 = 0;
    loop {
        if ms.is_multiple_of(1000) {
            let _ = xbee.transmit(Address64::COORDINATOR, b"hello");
        }
        match xbee.poll_frame() {
            Ok(Frame::TransmitStatus(status)) => delivery_status = status.delivery_status,
            Ok(Frame::ReceivePacket(rx)) => received_len = rx.data.len(),
            _ => {}
        }
        let _ = (delivery_status, received_len);
        delay.delay_ms(1);
        ms = ms.wrapping_add(1);
    }
}
