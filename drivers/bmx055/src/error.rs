//! The crate's error type, shared by the three dies.

use core::fmt;

/// What a die can do wrong, independent of the bus; [`Error::Device`] carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceError {
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

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeviceError::InvalidChipId { found } => write!(
                f,
                "BMX055: unexpected chip id 0x{found:02X} (check chip select / address and power)"
            ),
            DeviceError::Timeout => f.write_str("BMX055: timed out waiting for the sensor"),
            DeviceError::SelfTestFailed => f.write_str("BMX055: sensor self-test failed"),
            DeviceError::InvalidInput => {
                f.write_str("BMX055: argument outside the range the sensor accepts")
            }
        }
    }
}

impl core::error::Error for DeviceError {}

/// Everything a BMX055 driver call can fail with: the bus error `E` (`SpiDevice::Error` or
/// `I2c::Error`), or a [`DeviceError`] nested whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The SPI or I2C transfer failed.
    Comm(E),
    /// The die answered, but not as a working one does.
    Device(DeviceError),
}

impl<E> From<DeviceError> for Error<E> {
    fn from(e: DeviceError) -> Self {
        Error::Device(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Comm(e) => write!(f, "BMX055 bus error: {e:?}"),
            Error::Device(e) => fmt::Display::fmt(e, f),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Error::Comm(_) => None,
            Error::Device(e) => Some(e),
        }
    }
}
