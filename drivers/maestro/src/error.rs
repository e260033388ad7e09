//! Errors of the driver and of the value constructors.

use core::fmt;

use crate::targets::TargetError;

/// A value given to a constructor or encoder is outside what the Maestro protocol accepts.
///
/// Returned by the checked constructors ([`QuarterMicros::new`](crate::QuarterMicros::new),
/// [`Channel::new`](crate::Channel::new), ...) and converted into [`TargetError::InvalidInput`] by the
/// driver, so that no out-of-range value can ever be encoded on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InvalidInput;

impl fmt::Display for InvalidInput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("value out of the range the Maestro protocol accepts")
    }
}

impl core::error::Error for InvalidInput {}

/// What the Maestro did wrong on the link, independent of the transport; [`Error::Device`]
/// carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DeviceError {
    /// A reply did not arrive completely before the caller's deadline, or the transmitter stayed
    /// busy for the whole write budget. A partial reply is discarded, never returned.
    Timeout,
    /// The Maestro answered with a byte the protocol does not define (e.g. a moving state other
    /// than 0 or 1).
    InvalidReply(u8),
    /// Bytes kept arriving unasked before a query (more than the driver discards), so a reply
    /// could not be told apart from them; the query was not sent.
    UnexpectedData,
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeviceError::Timeout => f.write_str("Maestro did not answer before the deadline"),
            DeviceError::InvalidReply(b) => {
                write!(f, "Maestro sent an undefined reply byte 0x{b:02X}")
            }
            DeviceError::UnexpectedData => {
                f.write_str("unexpected bytes keep arriving from the Maestro; query not sent")
            }
        }
    }
}

impl core::error::Error for DeviceError {}

/// Errors of the Maestro driver: the transport's error `E`, a refused target (nothing was
/// sent), or a [`DeviceError`], each nested whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error<E> {
    /// The serial transport failed.
    Comm(E),
    /// A target, channel or value was refused before anything was sent (see [`TargetError`]).
    Target(TargetError),
    /// The Maestro answered wrongly, late or not at all.
    Device(DeviceError),
}

impl<E> From<InvalidInput> for Error<E> {
    fn from(_: InvalidInput) -> Self {
        Error::Target(TargetError::InvalidInput)
    }
}

impl<E> From<TargetError> for Error<E> {
    fn from(e: TargetError) -> Self {
        Error::Target(e)
    }
}

impl<E> From<DeviceError> for Error<E> {
    fn from(e: DeviceError) -> Self {
        Error::Device(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Comm(e) => write!(f, "Maestro serial transport error: {e:?}"),
            Error::Target(e) => fmt::Display::fmt(e, f),
            Error::Device(e) => fmt::Display::fmt(e, f),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Error::Comm(_) => None,
            Error::Target(e) => Some(e),
            Error::Device(e) => Some(e),
        }
    }
}
