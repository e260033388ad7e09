//! The crate's error type, shared by the three dies.

use core::fmt;

/// Everything a BMX055 driver call can fail with.
///
/// `E` is the bus error (`SpiDevice::Error` or `I2c::Error`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The SPI or I2C transfer failed.
    Comm(E),
    /// The chip-id register did not hold the die's id (wrong chip select or address, die
    /// still in suspend, or wiring fault). `found` is the last value read.
    InvalidChipId {
        /// Value read from the chip-id register.
        found: u8,
    },
    /// A bounded wait (data ready, offset calibration, built-in self-test) ran out of attempts.
    Timeout,
    /// The self-test ran and the die reported, or the measured deflection showed, a failure.
    SelfTestFailed,
    /// An argument was outside what the hardware accepts (for example a FIFO watermark above
    /// the FIFO depth).
    InvalidInput,
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Error::Comm(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Comm(e) => write!(f, "bus error: {e:?}"),
            Error::InvalidChipId { found } => {
                write!(
                    f,
                    "unexpected chip id 0x{found:02X} (check chip select / address and power)"
                )
            }
            Error::Timeout => f.write_str("timed out waiting for the sensor"),
            Error::SelfTestFailed => f.write_str("sensor self-test failed"),
            Error::InvalidInput => f.write_str("argument outside the range the sensor accepts"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
