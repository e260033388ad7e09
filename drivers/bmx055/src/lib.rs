//! Driver for the Bosch BMX055 9-axis IMU: accelerometer, gyroscope and magnetometer, over
//! embedded-hal 1.0 SPI or I2C, `no_std` and without allocation.
//!
//! The BMX055 is three dies in one package, each with its own chip select (or I2C address):
//! so this crate has three drivers, each owning its own [`SpiDevice`] or [`I2c`] bus handle,
//! and an optional [`Bmx055`] facade that owns all three. Share one SPI bus between the dies
//! with `embedded-hal-bus`; this crate never drives a chip-select pin.
//!
//! [`SpiDevice`]: embedded_hal::spi::SpiDevice
//! [`I2c`]: embedded_hal::i2c::I2c
//!
//! ## Features
//! - [`Accelerometer`](accel::Accelerometer) (chip id 0xFA): [`init`](accel::Accelerometer::init),
//!   [`configure`](accel::Accelerometer::configure) range ±2..±16 g, bandwidth 7.81..1000 Hz and
//!   power mode, [`read_raw`](accel::Accelerometer::read_raw) (packet words with new-data flags),
//!   [`read_mg`](accel::Accelerometer::read_mg), [`read_m_s2`](accel::Accelerometer::read_m_s2),
//!   [`temperature_celsius`](accel::Accelerometer::temperature_celsius), data-ready and slope
//!   interrupts ([`configure_interrupts`](accel::Accelerometer::configure_interrupts)), FIFO
//!   ([`configure_fifo`](accel::Accelerometer::configure_fifo), [`read_fifo`](accel::Accelerometer::read_fifo)),
//!   [`self_test`](accel::Accelerometer::self_test),
//!   [`fast_offset_compensation`](accel::Accelerometer::fast_offset_compensation) and manual offsets.
//! - [`Gyroscope`](gyro::Gyroscope) (chip id 0x0F): [`init`](gyro::Gyroscope::init), range ±125..±2000 °/s, data
//!   rate / filter (including 0x81 = 2000 Hz / 230 Hz), power modes,
//!   [`read_raw`](gyro::Gyroscope::read_raw), [`read_dps`](gyro::Gyroscope::read_dps),
//!   [`read_rad_s`](gyro::Gyroscope::read_rad_s), data-ready and FIFO interrupts, FIFO, built-in
//!   [`self_test`](gyro::Gyroscope::self_test).
//! - [`Magnetometer`](mag::Magnetometer) (chip id 0x32): [`power_on`](mag::Magnetometer::power_on) from suspend with
//!   the start-up wait, [`init`](mag::Magnetometer::init), trim read in three bursts
//!   ([`MagTrim`](mag::MagTrim) with Bosch's exact types), the four Bosch presets, normal and
//!   forced mode, [`read_forced`](mag::Magnetometer::read_forced) which waits (bounded) for data
//!   ready instead of returning the previous sample, [`poll_data`](mag::Magnetometer::poll_data)
//!   (`nb`), overflow detection, normal [`self_test`](mag::Magnetometer::self_test).
//! - Bosch's compensation as pure functions of raw values
//!   ([`mag::compensate`] integer µT with -32768 for overflow, [`mag::compensate_f32`]),
//!   reproducing C's narrowing casts with wrapping arithmetic: no input panics. Golden
//!   vectors from Bosch's SensorAPI are in the tests.
//! - Raw words in both directions: [`accel::accel_mg_to_word`] and
//!   [`gyro::gyro_dps_to_word`] for physical values to words, and with the `sim` feature a
//!   best-effort inverse of the magnetometer compensation (`mag::raw_x_for_ut` and its
//!   siblings), for simulators.
//! - `async` feature: `AsyncAccelerometer`, `AsyncGyroscope`, `AsyncMagnetometer` and
//!   `AsyncBmx055` over embedded-hal-async, next to the blocking API and generated from the same
//!   source (`maybe_async_cfg`), so the two cannot drift. `defmt` feature: `defmt::Format` on the
//!   public types.
//!
//! Every wait is bounded (a number of polls with a delay) or left to the caller (`nb`).
//!
//! ## Usage
//! ```
//! # use embedded_hal_mock::eh1::{delay::NoopDelay, spi::{Mock, Transaction as T}};
//! # let w = |r: u8, v: u8| vec![T::transaction_start(), T::write_vec(vec![r, v]), T::transaction_end()];
//! # let rd = |r: u8, d: &[u8]| vec![T::transaction_start(), T::write_vec(vec![r | 0x80]),
//! #     T::read_vec(d.to_vec()), T::transaction_end()];
//! # let script = [w(0x14, 0xB6), rd(0x00, &[0xFA]), w(0x0F, 0x03), w(0x10, 0x0F), w(0x11, 0x00),
//! #     rd(0x02, &[0x00, 0x00, 0x00, 0x00, 0x00, 0x40])].concat();
//! # let spi = Mock::new(&script);
//! # let mut delay = NoopDelay;
//! use bosch_bmx055::accel::{AccelConfig, Accelerometer};
//!
//! // `spi` is the accelerometer's own `SpiDevice` (chip select CSB1).
//! let mut accel = Accelerometer::new_spi(spi);
//! accel.init(&mut delay, &AccelConfig::default())?; // ±2 g, 1000 Hz, normal mode
//! let raw = accel.read_raw()?;
//! let mg = raw.mg(accel.range());
//! assert_eq!(raw.words.z, 0x4000); // the packet word, status bits masked
//! assert!((mg.z - 1000.0).abs() < 1.0);
//! # accel.release().done();
//! # Ok::<(), bosch_bmx055::Error<embedded_hal::spi::ErrorKind>>(())
//! ```
//!
//! Compensating packet data on the host needs only the trim and the raw words:
//! ```
//! use bosch_bmx055::mag::{compensate, MagPacketWords, MagTrim};
//! let trim = MagTrim::from_bursts(
//!     &[0x00, 0x00],
//!     &[0x00, 0x00, 0x1A, 0x1A],
//!     &[0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D],
//! );
//! let words = MagPacketWords::from_registers(&[0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x61, 0x6D]);
//! let ut = compensate(&words.to_raw(), &trim);
//! assert_eq!((ut.x, ut.y, ut.z), (29, -21, -45));
//! ```
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![deny(unsafe_code)]
#![deny(missing_docs)]

/// Writes each item once for the blocking drivers and, with the `async` feature, once more for
/// the async ones (`Accelerometer` -> `AsyncAccelerometer`, `.await` on the bus calls), through
/// `maybe-async-cfg`.
macro_rules! blocking_and_async {
    ($($item:item)*) => {
        $(
            #[maybe_async_cfg::maybe(
                sync(keep_self),
                async(feature = "async", keep_self),
                idents(
                    Accelerometer(sync, async = "AsyncAccelerometer"),
                    Gyroscope(sync, async = "AsyncGyroscope"),
                    Magnetometer(sync, async = "AsyncMagnetometer"),
                    Bmx055(sync, async = "AsyncBmx055"),
                    RegisterInterface(sync, async = "AsyncRegisterInterface"),
                    Registers(sync, async = "AsyncRegisters"),
                    DelayNs(sync, async = "AsyncDelayNs")
                )
            )]
            $item
        )*
    };
}
pub(crate) use blocking_and_async;

pub mod accel;
mod access;
mod error;
mod facade;
pub mod gyro;
mod interface;
pub mod mag;
mod maths;
#[cfg(test)]
mod register_tests;
mod types;

pub use error::{DeviceError, Error};
#[cfg(feature = "async")]
pub use facade::AsyncBmx055;
pub use facade::{Bmx055, Bmx055Config, ImuSample};
#[cfg(feature = "async")]
pub use interface::AsyncRegisterInterface;
pub use interface::{I2cInterface, RegisterInterface, SpiInterface};
pub use types::{FifoData, FifoMode, FifoStatus, InterruptPin, PinConfig, Xyz};

/// The README's code blocks, compiled (and run where they need no hardware) as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
