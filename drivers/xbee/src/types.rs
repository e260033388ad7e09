//! Public value types shared by every part of the driver: addresses, the API escaping choice
//! and the driver error.

use core::fmt;

/// A 64-bit IEEE extended address (the module's serial number, `SH` + `SL`).
///
/// Digi radios print it as `0013A200xxxxxxxx`; it goes on the wire big-endian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Address64(pub u64);

impl Address64 {
    /// The coordinator of a Zigbee network (all zeros).
    pub const COORDINATOR: Self = Self(0);
    /// Broadcast to every node of the PAN.
    pub const BROADCAST: Self = Self(0xFFFF);

    /// The address as eight big-endian bytes, wire order.
    pub const fn to_be_bytes(self) -> [u8; 8] {
        self.0.to_be_bytes()
    }
}

impl From<u64> for Address64 {
    fn from(value: u64) -> Self {
        Self(value)
    }
}

/// A 16-bit network address (`MY`), assigned by the network on Zigbee.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Address16(pub u16);

impl Address16 {
    /// "Unknown": use this when addressing by the 64-bit address only.
    pub const UNKNOWN: Self = Self(0xFFFE);
    /// Broadcast network address.
    pub const BROADCAST: Self = Self(0xFFFF);
}

impl From<u16> for Address16 {
    fn from(value: u16) -> Self {
        Self(value)
    }
}

/// How API frames are delimited on the serial line (the module's `AP` setting).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ApiEscaping {
    /// `AP = 1`: bytes go out as they are. A 0x7E inside a frame is data, so a decoder can only
    /// resynchronise by length and checksum.
    #[default]
    Unescaped,
    /// `AP = 2`: 0x7E, 0x7D, 0x11 and 0x13 after the start delimiter are sent as 0x7D followed
    /// by the byte XOR 0x20. A raw 0x7E always starts a frame, which makes resynchronisation
    /// immediate, and XON/XOFF flow control stays usable.
    Escaped,
}

/// Why an API frame could not be read as one of the typed frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The frame has no bytes at all (not even a frame type).
    Empty,
    /// The frame length does not fit its type: shorter than its fixed fields, or longer than a
    /// fixed-size frame (modem status, transmit status).
    InvalidLength {
        /// The frame type byte.
        frame_type: u8,
        /// Number of frame-data bytes received, frame type included.
        len: usize,
    },
    /// The output buffer cannot hold the encoded frame.
    BufferTooSmall,
    /// The frame data is longer than the 16-bit length field allows (65 535 bytes).
    TooLong,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Empty => f.write_str("empty API frame"),
            Self::InvalidLength { frame_type, len } => write!(
                f,
                "API frame 0x{frame_type:02X} has an invalid length ({len} bytes)"
            ),
            Self::BufferTooSmall => f.write_str("buffer too small for the API frame"),
            Self::TooLong => f.write_str("API frame longer than 65535 bytes"),
        }
    }
}

impl core::error::Error for FrameError {}

/// Failures of the module or of the driver's protocol, independent of the serial port;
/// [`Error::Device`] carries them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceError {
    /// Data was written while the module is (or may still be) in command mode. It was not sent:
    /// the module would have read it as AT command text. Wait for the driver to report
    /// transparent mode again.
    CommandModeActive,
    /// An AT command was requested while the module is not in command mode (enter it first, or
    /// the command-mode timeout `CT` has run out).
    NotInCommandMode,
    /// Another command-mode operation is still in progress: keep polling it first.
    Busy,
    /// The module did not answer (or the serial port did not accept bytes) within the deadline.
    Timeout,
    /// The module answered `ERROR`: unknown command or invalid parameter.
    AtError,
    /// The module's reply could not be understood (not the expected hexadecimal number, or a
    /// line longer than the reply buffer).
    InvalidReply,
    /// A parameter is out of range or contains characters command mode cannot carry.
    InvalidInput,
    /// An API frame could not be decoded or encoded.
    Frame(FrameError),
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::CommandModeActive => {
                f.write_str("XBee is in command mode: data not sent, wait for transparent mode")
            }
            Self::NotInCommandMode => f.write_str("XBee is not in command mode: enter it first"),
            Self::Busy => f.write_str("XBee command-mode operation already in progress"),
            Self::Timeout => {
                f.write_str("XBee did not answer in time (check baud rate and wiring)")
            }
            Self::AtError => f.write_str("XBee answered ERROR to the AT command"),
            Self::InvalidReply => f.write_str("XBee reply not understood"),
            Self::InvalidInput => f.write_str("invalid XBee parameter"),
            Self::Frame(e) => write!(f, "XBee API frame: {e}"),
        }
    }
}

impl core::error::Error for DeviceError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Frame(e) => Some(e),
            _ => None,
        }
    }
}

/// Errors of the driver: the serial port's error `E`, or a [`DeviceError`] nested whole (the
/// shape of every driver crate of this project: `Comm` for the bus, `Device` for the rest,
/// `Device(DeviceError::Timeout)` for a deadline).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The serial port failed.
    Comm(E),
    /// The module, or the driver's protocol with it, failed.
    Device(DeviceError),
}

impl<E> From<DeviceError> for Error<E> {
    fn from(e: DeviceError) -> Self {
        Self::Device(e)
    }
}

impl<E> From<FrameError> for Error<E> {
    fn from(e: FrameError) -> Self {
        Self::Device(DeviceError::Frame(e))
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Comm(e) => write!(f, "XBee serial port error: {e:?}"),
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

impl<E: embedded_hal_nb::serial::Error> embedded_hal_nb::serial::Error for Error<E> {
    fn kind(&self) -> embedded_hal_nb::serial::ErrorKind {
        match self {
            Self::Comm(e) => e.kind(),
            _ => embedded_hal_nb::serial::ErrorKind::Other,
        }
    }
}

// embedded-io-async 0.7 re-exports embedded-io's error traits: one impl serves both features.
#[cfg(feature = "embedded-io")]
use embedded_io as io;
#[cfg(all(feature = "async", not(feature = "embedded-io")))]
use embedded_io_async as io;

#[cfg(any(feature = "embedded-io", feature = "async"))]
impl<E: fmt::Debug> io::Error for Error<E> {
    fn kind(&self) -> io::ErrorKind {
        match self {
            Self::Device(DeviceError::Timeout) => io::ErrorKind::TimedOut,
            Self::Device(DeviceError::InvalidInput) => io::ErrorKind::InvalidInput,
            _ => io::ErrorKind::Other,
        }
    }
}
