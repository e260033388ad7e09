//! The board side of the sensor link on an STM32F4 with stm32f4xx-hal 0.23: assembles a v1
//! packet with `PacketBuilder` (here from fixed register bytes; a real board copies what its
//! sensor drivers read) and sends it on USART3 (PD8 TX, PD9 RX) at 460800 baud, 8N2, whenever a
//! request byte arrives. The full board (request line on an EXTI edge, DMA, double buffer) is a
//! larger program; this is the codec's part of it.
//!
//! Build: `cargo build --release --example stm32f4 --target thumbv7em-none-eabihf` in a
//! project with `stm32f4xx-hal` (feature `stm32f407`), `cortex-m-rt` and `panic-halt`, and a
//! `memory.x` for the chip; flash with `probe-rs run`.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use dima_sensorboard::{nb, PacketBuilder, Stm32Crc};
use embedded_hal_nb::serial::{Read, Write};
use panic_halt as _;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config as ClockConfig;
use stm32f4xx_hal::serial::{self, config::StopBits};

#[entry]
fn main() -> ! {
    let Some(dp) = pac::Peripherals::take() else {
        panic!("set-up failed: peripherals already taken, or a configuration the HAL rejects");
    };
    let mut rcc = dp.RCC.freeze(ClockConfig::hsi());
    let gpiod = dp.GPIOD.split(&mut rcc);
    let config = serial::Config::default()
        .baudrate(460_800.bps())
        .stopbits(StopBits::STOP2);
    let Ok(mut link) = dp
        .USART3
        .serial::<u8>((gpiod.pd8, gpiod.pd9), config, &mut rcc)
    else {
        panic!("set-up failed: a configuration the HAL rejects");
    };

    let mut crc = Stm32Crc;
    let mut builder = PacketBuilder::new();
    builder
        .accel_registers([0x01, 0x00, 0x02, 0x00, 0x03, 0x40])
        .gyro_registers([0x10, 0x00, 0x20, 0x00, 0x30, 0x00])
        .bmp280_registers([0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00]);
    loop {
        if link.read().is_ok() {
            for &byte in builder.build(&mut crc) {
                let _ = nb::block!(link.write(byte));
            }
        }
    }
}
