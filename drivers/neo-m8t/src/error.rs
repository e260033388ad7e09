//! Driver errors.

use core::fmt;

/// What the receiver did wrong, independent of the serial port; [`Error::Device`] carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceError {
    /// The receiver rejected a configuration message (ACK-NAK); retrying would not help.
    Nak {
        /// Class of the rejected message.
        class: u8,
        /// Id of the rejected message.
        id: u8,
    },
    /// No ACK (or, for a poll, no answer) within the timeout, after every retry.
    Timeout {
        /// Class of the unanswered message.
        class: u8,
        /// Id of the unanswered message.
        id: u8,
    },
    /// After every retry, the receiver did not answer at the new baud rate.
    BaudSwitchFailed {
        /// The rate that was asked for, baud.
        baud_rate: u32,
    },
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Nak { class, id } => write!(
                f,
                "receiver rejected UBX message {class:#04x}/{id:#04x} (ACK-NAK)"
            ),
            Self::Timeout { class, id } => write!(
                f,
                "no answer from the receiver to UBX message {class:#04x}/{id:#04x}: check wiring and baud rate"
            ),
            Self::BaudSwitchFailed { baud_rate } => write!(
                f,
                "receiver did not answer at {baud_rate} baud after the port change"
            ),
        }
    }
}

impl core::error::Error for DeviceError {}

/// Errors of the configuration and reading operations: the serial port's error `E`, or a
/// [`DeviceError`] nested whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The serial port failed.
    Comm(E),
    /// The receiver answered wrongly or not at all.
    Device(DeviceError),
}

impl<E> From<DeviceError> for Error<E> {
    fn from(e: DeviceError) -> Self {
        Self::Device(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Comm(e) => write!(f, "serial port error: {e:?}"),
            Self::Device(e) => fmt::Display::fmt(e, f),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Comm(_) => None,
            Self::Device(e) => Some(e),
        }
    }
}
