//! Bus abstraction: register reads and writes over SPI or I2C.
//!
//! The driver takes one embedded-hal 1.0 [`SpiDevice`] (which owns the chip select; share a bus
//! with `embedded-hal-bus`) or an [`I2c`] bus plus the [`I2cAddress`] strap. Both interface
//! types implement [`Interface`] and, with the `async` feature, `AsyncInterface` over the
//! embedded-hal-async traits, from one source (`maybe_async_cfg`).

use embedded_hal::i2c::I2c;
use embedded_hal::spi::{Operation, SpiDevice};
#[cfg(feature = "async")]
use embedded_hal_async::{
    i2c::I2c as AsyncI2c,
    spi::{Operation as AsyncOperation, SpiDevice as AsyncSpiDevice},
};

use crate::register::{SPI_READ, SPI_WRITE_MASK};
use crate::types::I2cAddress;

#[maybe_async_cfg::maybe(
    sync(),
    async(feature = "async"),
    idents(
        Interface(sync, async = "AsyncInterface"),
        SpiDevice(sync, async = "AsyncSpiDevice"),
        Operation(sync, async = "AsyncOperation"),
        I2c(sync, async = "AsyncI2c")
    )
)]
/// Register access to a BMP280: implemented by [`SpiInterface`] and [`I2cInterface`] over the
/// embedded-hal traits, and as `AsyncInterface` over the embedded-hal-async ones (feature
/// `async`). Implement it for another transport (a simulator, a bus driven by DMA).
#[allow(async_fn_in_trait)] // as embedded-hal-async: the caller's executor decides on Send
pub trait Interface {
    /// Bus error type.
    type Error;

    /// Reads `buf.len()` consecutive registers starting at `register` in one bus transaction
    /// (the device auto-increments the address, so a burst keeps a sample consistent).
    async fn read_registers(&mut self, register: u8, buf: &mut [u8]) -> Result<(), Self::Error>;

    /// Writes one register.
    async fn write_register(&mut self, register: u8, value: u8) -> Result<(), Self::Error>;
}

/// SPI access (4-wire, or 3-wire with `Config::spi_3wire`), mode 0 or mode 3.
///
/// A read is one transaction: the control byte `register | 0x80`, then the data. A write is one
/// transaction of two bytes: `register & 0x7F` and the value.
#[derive(Debug)]
pub struct SpiInterface<SPI> {
    spi: SPI,
}

impl<SPI> SpiInterface<SPI> {
    /// Wraps an SPI device (one chip select).
    pub const fn new(spi: SPI) -> Self {
        Self { spi }
    }

    /// Gives the SPI device back.
    pub fn release(self) -> SPI {
        self.spi
    }
}

#[maybe_async_cfg::maybe(
    sync(keep_self),
    async(feature = "async", keep_self),
    idents(
        Interface(sync, async = "AsyncInterface"),
        SpiDevice(sync, async = "AsyncSpiDevice"),
        Operation(sync, async = "AsyncOperation"),
        I2c(sync, async = "AsyncI2c")
    )
)]
impl<SPI: SpiDevice> Interface for SpiInterface<SPI> {
    type Error = SPI::Error;

    async fn read_registers(&mut self, register: u8, buf: &mut [u8]) -> Result<(), Self::Error> {
        self.spi
            .transaction(&mut [
                Operation::Write(&[register | SPI_READ]),
                Operation::Read(buf),
            ])
            .await
    }

    async fn write_register(&mut self, register: u8, value: u8) -> Result<(), Self::Error> {
        self.spi.write(&[register & SPI_WRITE_MASK, value]).await
    }
}

/// I2C access at 0x76 or 0x77.
///
/// A read is a write of the register address followed by a repeated-start read; a write is the
/// register address and the value in one write.
#[derive(Debug)]
pub struct I2cInterface<I2C> {
    i2c: I2C,
    address: u8,
}

impl<I2C> I2cInterface<I2C> {
    /// Wraps an I2C bus with the device's address strap.
    pub const fn new(i2c: I2C, address: I2cAddress) -> Self {
        Self {
            i2c,
            address: address.addr(),
        }
    }

    /// The 7-bit address in use.
    pub const fn address(&self) -> u8 {
        self.address
    }

    /// Gives the I2C bus back.
    pub fn release(self) -> I2C {
        self.i2c
    }
}

#[maybe_async_cfg::maybe(
    sync(keep_self),
    async(feature = "async", keep_self),
    idents(
        Interface(sync, async = "AsyncInterface"),
        SpiDevice(sync, async = "AsyncSpiDevice"),
        Operation(sync, async = "AsyncOperation"),
        I2c(sync, async = "AsyncI2c")
    )
)]
impl<I2C: I2c> Interface for I2cInterface<I2C> {
    type Error = I2C::Error;

    async fn read_registers(&mut self, register: u8, buf: &mut [u8]) -> Result<(), Self::Error> {
        self.i2c.write_read(self.address, &[register], buf).await
    }

    async fn write_register(&mut self, register: u8, value: u8) -> Result<(), Self::Error> {
        self.i2c.write(self.address, &[register, value]).await
    }
}
