//! Bus abstraction: one register interface over SPI (4-wire) or I2C.
//!
//! Each die sits behind its own [`SpiDevice`] (its own chip select) or at its own I2C address.
//! Sharing one SPI bus between the three dies (and other chips) is the job of
//! `embedded-hal-bus`; this crate never drives a chip-select pin itself.
//!
//! On SPI all three dies use the same framing: the first byte is the register address with
//! bit 7 set for a read (`addr | 0x80`) and cleared for a write; reads auto-increment the
//! address (except on the FIFO data registers, which stay put and pop frames).

use embedded_hal::i2c::I2c;
use embedded_hal::spi::{Operation, SpiDevice};
#[cfg(feature = "async")]
use embedded_hal_async::{
    i2c::I2c as AsyncI2c,
    spi::{Operation as AsyncOperation, SpiDevice as AsyncSpiDevice},
};

/// SPI read flag: bit 7 of the address byte.
pub const SPI_READ: u8 = 0x80;

#[maybe_async_cfg::maybe(
    sync(keep_self),
    async(feature = "async", keep_self),
    idents(
        RegisterInterface(sync, async = "AsyncRegisterInterface"),
        SpiDevice(sync, async = "AsyncSpiDevice"),
        Operation(sync, async = "AsyncOperation"),
        I2c(sync, async = "AsyncI2c")
    )
)]
/// Register access as the drivers need it: implemented by [`SpiInterface`] and
/// [`I2cInterface`] over embedded-hal, and as `AsyncRegisterInterface` over embedded-hal-async
/// (feature `async`). Implement it for another transport.
#[allow(async_fn_in_trait)] // as embedded-hal-async: the caller's executor decides on Send
pub trait RegisterInterface {
    /// Bus error type.
    type Error;
    /// Write one register.
    async fn write_register(&mut self, register: u8, value: u8) -> Result<(), Self::Error>;
    /// Burst read starting at `register` into `buf`.
    async fn read_registers(&mut self, register: u8, buf: &mut [u8]) -> Result<(), Self::Error>;
    /// Read one register.
    async fn read_register(&mut self, register: u8) -> Result<u8, Self::Error> {
        let mut b = [0u8];
        self.read_registers(register, &mut b).await?;
        Ok(b[0])
    }
}

/// A die behind its own SPI chip select.
#[derive(Debug)]
pub struct SpiInterface<SPI> {
    pub(crate) spi: SPI,
}

impl<SPI> SpiInterface<SPI> {
    /// Wrap an SPI device (mode 0 or 3, up to 10 MHz).
    pub fn new(spi: SPI) -> Self {
        Self { spi }
    }
    /// Give the SPI device back.
    pub fn release(self) -> SPI {
        self.spi
    }
}

/// A die on an I2C bus at a 7-bit address.
#[derive(Debug)]
pub struct I2cInterface<I2C> {
    pub(crate) i2c: I2C,
    pub(crate) address: u8,
}

impl<I2C> I2cInterface<I2C> {
    /// Wrap an I2C bus and the die's 7-bit address.
    pub fn new(i2c: I2C, address: u8) -> Self {
        Self { i2c, address }
    }
    /// The 7-bit address in use.
    pub fn address(&self) -> u8 {
        self.address
    }
    /// Give the I2C bus back.
    pub fn release(self) -> I2C {
        self.i2c
    }
}

#[maybe_async_cfg::maybe(
    sync(keep_self),
    async(feature = "async", keep_self),
    idents(
        RegisterInterface(sync, async = "AsyncRegisterInterface"),
        SpiDevice(sync, async = "AsyncSpiDevice"),
        Operation(sync, async = "AsyncOperation"),
        I2c(sync, async = "AsyncI2c")
    )
)]
impl<SPI: SpiDevice> RegisterInterface for SpiInterface<SPI> {
    type Error = SPI::Error;
    async fn write_register(&mut self, register: u8, value: u8) -> Result<(), Self::Error> {
        self.spi.write(&[register & !SPI_READ, value]).await
    }
    async fn read_registers(&mut self, register: u8, buf: &mut [u8]) -> Result<(), Self::Error> {
        self.spi
            .transaction(&mut [
                Operation::Write(&[register | SPI_READ]),
                Operation::Read(buf),
            ])
            .await
    }
}

#[maybe_async_cfg::maybe(
    sync(keep_self),
    async(feature = "async", keep_self),
    idents(
        RegisterInterface(sync, async = "AsyncRegisterInterface"),
        SpiDevice(sync, async = "AsyncSpiDevice"),
        Operation(sync, async = "AsyncOperation"),
        I2c(sync, async = "AsyncI2c")
    )
)]
impl<I2C: I2c> RegisterInterface for I2cInterface<I2C> {
    type Error = I2C::Error;
    async fn write_register(&mut self, register: u8, value: u8) -> Result<(), Self::Error> {
        self.i2c.write(self.address, &[register, value]).await
    }
    async fn read_registers(&mut self, register: u8, buf: &mut [u8]) -> Result<(), Self::Error> {
        self.i2c.write_read(self.address, &[register], buf).await
    }
}
