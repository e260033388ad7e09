//! Driver for the Bosch BMP280 barometric pressure and temperature sensor, generic over
//! embedded-hal 1.0, `no_std` and without allocation.
//!
//! # Features
//! - Both buses: SPI ([`Bmp280::new_spi`], one [`SpiDevice`](embedded_hal::spi::SpiDevice)
//!   per chip select, read = `register | 0x80`, write = `register & 0x7F`) and I2C
//!   ([`Bmp280::new_i2c`] with [`I2cAddress::SdoLow`] 0x76 or [`I2cAddress::SdoHigh`] 0x77).
//! - Bring-up in one call, [`Bmp280::init`]: soft reset with the datasheet's 2 ms start-up wait,
//!   chip id check (0x58, early samples 0x56/0x57; a BME280 only with
//!   [`Bmp280::accept_bme280`]), bounded wait for the NVM copy, one read of the calibration.
//! - One typed [`Config`] (power mode, oversampling, IIR filter, standby, 3-wire SPI) applied by
//!   [`Bmp280::configure`], with the datasheet presets ([`Config::forced`], [`Config::normal`],
//!   [`Config::indoor_navigation`], ...); [`Config::default`] is normal mode at x1/x1 with
//!   0.5 ms standby (`ctrl_meas` 0x27). The measurement time follows from it: [`Config::measurement_time_typ_us`],
//!   [`Config::measurement_time_max_us`].
//! - Forced mode without fixed sleeps: [`Bmp280::start_forced`] then [`Bmp280::poll_forced`]
//!   (`nb`, `WouldBlock` while `status.measuring` is set or `ctrl_meas` still reads forced
//!   mode), or [`Bmp280::measure_forced`] with a
//!   borrowed delay and a deadline.
//! - Normal mode: [`Bmp280::measure`] (one burst read, compensated, raw values kept; an error,
//!   [`DeviceError::NoConversion`], while the data registers still hold their reset value) and
//!   [`Bmp280::measure_when_ready`] (waits for the first conversion after `configure`),
//!   [`Bmp280::read_raw`] and [`Bmp280::read_raw_bytes`] (the register bytes, for a board that
//!   forwards raw samples; [`RawSample::from_register_bytes`] and
//!   [`RawSample::to_register_bytes`] convert).
//! - [`compensation`]: the datasheet formulas as pure functions (integer temperature in 0.01 °C,
//!   64-bit pressure in Q24.8 Pa, the 32-bit pressure variant, `f32` helpers), for hosts that
//!   receive raw samples and the [`Calibration`] bytes; `compensation::inverse` (feature `sim`)
//!   finds the raw values for a temperature and pressure, for simulators.
//! - [`Error`] with the bus error and device errors, `Display`, `core::error::Error`;
//!   `defmt::Format` with the `defmt` feature.
//! - Feature `async`: `Bmp280Async`, the same driver on embedded-hal-async, generated from the
//!   same source as [`Bmp280`] (so the two cannot drift). The blocking API stays available.
//!
//! Bus sharing (several chip selects on one SPI bus) is the job of `embedded-hal-bus`.
//!
//! # Usage
//! ```
//! # use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as T};
//! # use embedded_hal_mock::eh1::delay::NoopDelay;
//! use bosch_bmp280::{Bmp280, Config};
//! # // Registers 0x88..=0x9F and 0xF7..=0xFC of the datasheet's calculation example.
//! # const CALIB: [u8; 24] = [
//! #     0x70, 0x6B, 0x43, 0x67, 0x18, 0xFC, 0x7D, 0x8E, 0x43, 0xD6, 0xD0, 0x0B,
//! #     0x27, 0x0B, 0x8C, 0x00, 0xF9, 0xFF, 0x8C, 0x3C, 0xF8, 0xC6, 0x70, 0x17,
//! # ];
//! # let read = |reg: u8, data: Vec<u8>| vec![T::transaction_start(), T::write_vec(vec![reg]), T::read_vec(data), T::transaction_end()];
//! # let write = |reg: u8, v: u8| vec![T::transaction_start(), T::write_vec(vec![reg, v]), T::transaction_end()];
//! # let expectations: Vec<T<u8>> = [
//! #     write(0x60, 0xB6), read(0xD0, vec![0x58]), read(0xF3, vec![0x00]), read(0x88, CALIB.to_vec()),
//! #     write(0x74, 0x24), write(0x75, 0x00), write(0x74, 0x27),
//! #     read(0xF7, vec![0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00]),
//! # ].concat();
//! # let spi = SpiMock::new(&expectations);
//! # let mut delay = NoopDelay::new();
//! // `spi` is an embedded-hal 1.0 SpiDevice, `delay` a DelayNs.
//! let mut bmp = Bmp280::new_spi(spi);
//! bmp.init(&mut delay)?;
//! bmp.configure(Config::default())?; // normal mode, x1/x1, t_sb 0.5 ms, filter off
//! // Waits for the first conversion (up to 5.5 ms after `configure`); `measure()` reads the
//! // latest one afterwards and refuses registers that hold no conversion yet.
//! let m = bmp.measure_when_ready(&mut delay)?;
//! assert_eq!(m.temperature_centi_celsius, 2508); // 25.08 °C
//! assert_eq!(m.pressure_pa(), 100_653);
//! assert_eq!(m.raw.to_register_bytes(), [0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00]);
//! # bmp.release().done();
//! # Ok::<(), bosch_bmp280::Error<embedded_hal::spi::ErrorKind>>(())
//! ```
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![deny(unsafe_code)]
#![deny(missing_docs)]

/// Writes each driver item once for the blocking `Bmp280` and, with the `async` feature, once
/// more for `Bmp280Async` (`.await` on the bus and delay calls), through `maybe-async-cfg`.
macro_rules! blocking_and_async {
    ($($item:item)*) => {
        $(
            #[maybe_async_cfg::maybe(
                sync(),
                async(feature = "async"),
                idents(
                    Bmp280(sync, async = "Bmp280Async"),
                    Interface(sync, async = "AsyncInterface"),
                    DelayNs(sync, async = "AsyncDelayNs")
                )
            )]
            $item
        )*
    };
}
pub(crate) use blocking_and_async;

mod calibration;
pub mod compensation;
mod config;
mod device;
mod interface;
mod raw;
mod register;
#[cfg(test)]
mod register_tests;
mod sequence;
mod types;

pub use calibration::Calibration;
pub use compensation::Measurement;
pub use config::{Config, Filter, Oversampling, PowerMode, Resolution, Standby};
pub use device::Bmp280;
pub use interface::{I2cInterface, Interface, SpiInterface};
pub use raw::RawSample;
pub use register::Status;
pub use types::{Chip, DeviceError, Error, I2cAddress};

#[cfg(feature = "async")]
pub use device::Bmp280Async;
#[cfg(feature = "async")]
pub use interface::AsyncInterface;
/// `nb`, re-exported for `nb::block!` around [`Bmp280::poll_forced`] and for matching
/// `nb::Error::WouldBlock`.
pub use nb;

/// The README's code blocks, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
