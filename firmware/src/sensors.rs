//! The four sensor dies on SPI1 (mode 3): the shared bus, one chip select per die on port E
//! (PE7 accelerometer, PE8 gyroscope, PE9 magnetometer, PE10 BMP280) and their bring-up.
//!
//! What the dies are asked and when lives in `dima_firmware_logic::Sensors`; this module only
//! builds the devices it drives.

use crate::delay::CycleDelay;
use dima_firmware_logic::spi_clock::sensor_request_hz;
use dima_firmware_logic::BootReport;
#[cfg(not(feature = "qemu"))]
use embedded_hal_bus::spi::AtomicDevice;
use embedded_hal_bus::util::AtomicCell;
#[cfg(not(feature = "qemu"))]
use stm32f4xx_hal::gpio::{self, Output, PushPull};
use stm32f4xx_hal::gpio::{gpioa, gpioe};
use stm32f4xx_hal::pac::SPI1;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Rcc;
use stm32f4xx_hal::spi::{Mode, Phase, Polarity, Spi};

/// SPI1, shared by the four chip selects.
pub type SensorBus = Spi<SPI1>;
/// A chip select on port E, its pin number kept at run time: the four devices share one
/// type, so their driver code exists once in flash instead of four times.
#[cfg(not(feature = "qemu"))]
type ChipSelect = gpio::PartiallyErasedPin<'E', Output<PushPull>>;
/// One sensor die on SPI1 behind its chip select on port E.
#[cfg(not(feature = "qemu"))]
pub type SensorSpi = AtomicDevice<'static, SensorBus, ChipSelect, CycleDelay>;
/// Emulator twin: one sensor die as a register image the host feeds (QEMU has no dies on
/// SPI1; `crate::sensor_images`).
#[cfg(feature = "qemu")]
pub type SensorSpi = crate::sensor_images::ImageSpi;

/// The sensors, one SPI device per die.
pub type Sensors = dima_firmware_logic::Sensors<SensorSpi, SensorSpi, SensorSpi, SensorSpi>;

/// Brings up SPI1 on PA5/PA6/PA7 (mode 3, the fastest clock within the sensors' 10 MHz that
/// APB2 allows: `dima_firmware_logic::spi_clock::sensor_request_hz`), makes the four chip selects outputs
/// (deselected, PE7 to PE10 in that order) and starts the dies. `bus` is the static home of
/// the shared bus; `sysclk_hz` times the start-up waits.
pub fn set_up(
    spi1: SPI1,
    gpioa: gpioa::Parts,
    gpioe: gpioe::Parts,
    bus: &'static mut Option<AtomicCell<SensorBus>>,
    rcc: &mut Rcc,
    sysclk_hz: u32,
) -> (Sensors, BootReport) {
    let mode = Mode {
        polarity: Polarity::IdleHigh,
        phase: Phase::CaptureOnSecondTransition,
    };
    // From the APB2 clock the HAL actually set up, not an assumed one: the HAL rounds the
    // request to the nearest divider, which may be faster than asked.
    let request_hz = sensor_request_hz(rcc.clocks.pclk2().raw());
    let spi = spi1.spi(
        (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
        mode,
        request_hz.Hz(),
        rcc,
    );
    let bus: &'static AtomicCell<SensorBus> = bus.insert(AtomicCell::new(spi));
    let mut delay = CycleDelay::new(sysclk_hz);
    #[cfg(not(feature = "qemu"))]
    let dies = (
        spi_device(bus, gpioe.pe7.into_push_pull_output(), delay),
        spi_device(bus, gpioe.pe8.into_push_pull_output(), delay),
        spi_device(bus, gpioe.pe9.into_push_pull_output(), delay),
        spi_device(bus, gpioe.pe10.into_push_pull_output(), delay),
    );
    // Emulator twin: the dies answer from register images, which `init` first waits for on
    // USART2 (`crate::sensor_images::wait_for_boot_images`); SPI1 is set up all the same.
    #[cfg(feature = "qemu")]
    let dies = {
        let _ = (bus, gpioe);
        crate::sensor_images::wait_for_boot_images();
        let [accel, gyro, mag, baro] = crate::sensor_images::devices();
        (accel, gyro, mag, baro)
    };
    Sensors::init(dies.0, dies.1, dies.2, dies.3, &mut delay)
}

/// One SPI device on the shared bus; the chip select starts high (deselected).
#[cfg(not(feature = "qemu"))]
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
