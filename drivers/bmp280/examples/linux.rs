//! Reads a BMP280 on Linux (Raspberry Pi, Jetson) with linux-embedded-hal.
//!
//! ```text
//! cargo run -p bosch-bmp280 --example linux -- i2c /dev/i2c-1 0x76
//! cargo run -p bosch-bmp280 --example linux -- spi /dev/spidev0.0
//! ```
//! Prints one compensated sample (and its raw register bytes) about every 100 ms in the default
//! configuration, then one forced measurement.

use std::error::Error as StdError;
use std::{env, thread, time::Duration};

use bosch_bmp280::{Bmp280, Config, I2cAddress, Interface, Resolution};
use linux_embedded_hal::spidev::{SpiModeFlags, SpidevOptions};
use linux_embedded_hal::{Delay, I2cdev, SpidevDevice};

fn main() -> Result<(), Box<dyn StdError>> {
    let args: Vec<String> = env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("spi") => {
            let path = args.get(1).map_or("/dev/spidev0.0", String::as_str);
            let mut spi = SpidevDevice::open(path)?;
            // Mode 3 (mode 0 works too), 1 MHz; the BMP280 allows up to 10 MHz.
            spi.0.configure(
                &SpidevOptions::new()
                    .mode(SpiModeFlags::SPI_MODE_3)
                    .max_speed_hz(1_000_000)
                    .build(),
            )?;
            run(Bmp280::new_spi(spi))
        }
        Some("i2c") | None => {
            let path = args.get(1).map_or("/dev/i2c-1", String::as_str);
            let address = match args.get(2).map(String::as_str) {
                Some("0x77") | Some("119") => I2cAddress::SdoHigh,
                _ => I2cAddress::SdoLow,
            };
            run(Bmp280::new_i2c(I2cdev::new(path)?, address))
        }
        Some(other) => Err(format!("unknown bus {other:?}: use i2c or spi").into()),
    }
}

fn run<I>(mut bmp: Bmp280<I>) -> Result<(), Box<dyn StdError>>
where
    I: Interface,
    I::Error: std::fmt::Debug + 'static,
{
    let mut delay = Delay;
    let chip = bmp.init(&mut delay)?;
    println!("found {chip:?}, calibration {:?}", bmp.calibration());

    bmp.configure(Config::default())?;
    // The first conversion ends up to 5.5 ms after `configure`; later ones every 6 ms.
    bmp.measure_when_ready(&mut delay)?;
    for _ in 0..10 {
        thread::sleep(Duration::from_millis(100));
        let m = bmp.measure()?;
        println!(
            "{:.2} °C  {:.2} Pa  raw {:02X?}",
            m.temperature_celsius_f32(),
            m.pressure_pa_f32(),
            m.raw.to_register_bytes()
        );
    }

    bmp.configure(Config::forced(Resolution::UltraHigh))?;
    let m = bmp.measure_forced(&mut delay)?;
    println!(
        "forced x16: {:.2} °C  {:.2} Pa",
        m.temperature_celsius_f32(),
        m.pressure_pa_f32()
    );
    Ok(())
}
