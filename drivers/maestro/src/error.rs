//! Errors of the driver and of the value constructors.

use core::fmt;

/// A value given to a constructor or encoder is outside what the Maestro protocol accepts.
///
/// Returned by the checked constructors ([`QuarterMicros::new`](crate::QuarterMicros::new),
/// [`Channel::new`](crate::Channel::new), ...) and converted into [`Error::InvalidInput`] by the
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

/// Errors of the Maestro driver.
///
/// `E` is the error of the serial transport.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error<E> {
    /// The serial transport failed.
    Comm(E),
    /// A reply did not arrive completely before the caller's deadline, or the transmitter stayed
    /// busy for the whole write budget. A partial reply is discarded, never returned.
    Timeout,
    /// A value is outside the protocol's range (see [`InvalidInput`]).
    InvalidInput,
    /// The channel number does not exist on this Maestro model.
    InvalidChannel {
        /// The requested channel number.
        channel: u8,
        /// The number of channels of the model (valid channels are `0..channels`).
        channels: u8,
    },
    /// The target is outside the limits configured for the channel
    /// (see [`Limits`](crate::Limits)); nothing was sent.
    OutOfRange {
        /// The channel number.
        channel: u8,
        /// The rejected target in quarter-microseconds.
        target: u16,
        /// The lowest allowed target in quarter-microseconds.
        min: u16,
        /// The highest allowed target in quarter-microseconds.
        max: u16,
    },
    /// The Maestro answered with a byte the protocol does not define (e.g. a moving state other
    /// than 0 or 1).
    InvalidReply(u8),
    /// Bytes kept arriving unasked before a query (more than the driver discards), so a reply
    /// could not be told apart from them; the query was not sent.
    UnexpectedData,
}

impl<E> From<InvalidInput> for Error<E> {
    fn from(_: InvalidInput) -> Self {
        Error::InvalidInput
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Comm(e) => write!(f, "Maestro serial transport error: {e:?}"),
            Error::Timeout => f.write_str("Maestro did not answer before the deadline"),
            Error::InvalidInput => f.write_str("value out of the range the Maestro protocol accepts"),
            Error::InvalidChannel { channel, channels } => write!(
                f,
                "channel {channel} does not exist on this Maestro (it has {channels} channels)"
            ),
            Error::OutOfRange {
                channel,
                target,
                min,
                max,
            } => write!(
                f,
                "target {target} (quarter-µs) on channel {channel} is outside the configured limits {min}..={max}"
            ),
            Error::InvalidReply(b) => write!(f, "Maestro sent an undefined reply byte 0x{b:02X}"),
            Error::UnexpectedData => {
                f.write_str("unexpected bytes keep arriving from the Maestro; query not sent")
            }
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
