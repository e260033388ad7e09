//! Serial transport: embedded-hal-nb byte ports, and an adapter for embedded-io ports.

use embedded_hal_nb::serial::{Error as _, ErrorKind, Read};

/// Result of one non-blocking byte read.
pub(crate) enum Received {
    /// A byte arrived.
    Byte(u8),
    /// Nothing to read now.
    Idle,
    /// Overrun, framing, parity or noise error: the byte stream has a gap.
    LineError,
}

/// Reads one byte without blocking; line errors are reported, not raised, because a baud
/// switch or a busy interrupt produces them and the framer resynchronises anyway.
pub(crate) fn read_byte<S: Read<u8>>(serial: &mut S) -> Result<Received, S::Error> {
    match serial.read() {
        Ok(byte) => Ok(Received::Byte(byte)),
        Err(nb::Error::WouldBlock) => Ok(Received::Idle),
        Err(nb::Error::Other(e)) => match e.kind() {
            ErrorKind::Overrun | ErrorKind::FrameFormat | ErrorKind::Parity | ErrorKind::Noise => {
                Ok(Received::LineError)
            }
            _ => Err(e),
        },
    }
}

#[cfg(feature = "embedded-io")]
pub use io::{IoError, IoSerial};

#[cfg(feature = "embedded-io")]
mod io {
    use embedded_hal_nb::serial::{self, ErrorKind};

    /// Adapts an embedded-io 0.7 port (`Read + ReadReady + Write + WriteReady`) to the
    /// byte-wise, non-blocking embedded-hal-nb serial traits the driver uses.
    ///
    /// `read` and `write` only touch the port when `read_ready` / `write_ready` say they will
    /// not block, and return `WouldBlock` otherwise. `flush` is the port's (blocking) flush.
    #[derive(Debug)]
    pub struct IoSerial<T>(pub T);

    impl<T> IoSerial<T> {
        /// Gives the port back.
        pub fn into_inner(self) -> T {
            self.0
        }
    }

    /// An embedded-io error seen through the embedded-hal-nb serial error trait.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct IoError<E>(pub E);

    impl<E: embedded_io::Error> serial::Error for IoError<E> {
        fn kind(&self) -> ErrorKind {
            ErrorKind::Other
        }
    }

    impl<T: embedded_io::ErrorType> serial::ErrorType for IoSerial<T> {
        type Error = IoError<T::Error>;
    }

    impl<T: embedded_io::Read + embedded_io::ReadReady> serial::Read<u8> for IoSerial<T> {
        fn read(&mut self) -> nb::Result<u8, Self::Error> {
            if !self
                .0
                .read_ready()
                .map_err(|e| nb::Error::Other(IoError(e)))?
            {
                return Err(nb::Error::WouldBlock);
            }
            let mut byte = [0u8; 1];
            match self.0.read(&mut byte) {
                Ok(1) => Ok(byte[0]),
                Ok(_) => Err(nb::Error::WouldBlock),
                Err(e) => Err(nb::Error::Other(IoError(e))),
            }
        }
    }

    impl<T: embedded_io::Write + embedded_io::WriteReady> serial::Write<u8> for IoSerial<T> {
        fn write(&mut self, word: u8) -> nb::Result<(), Self::Error> {
            if !self
                .0
                .write_ready()
                .map_err(|e| nb::Error::Other(IoError(e)))?
            {
                return Err(nb::Error::WouldBlock);
            }
            match self.0.write(&[word]) {
                Ok(1) => Ok(()),
                // Some ports report a busy register as a zero-length write.
                Ok(_) => Err(nb::Error::WouldBlock),
                Err(e) => Err(nb::Error::Other(IoError(e))),
            }
        }

        fn flush(&mut self) -> nb::Result<(), Self::Error> {
            self.0.flush().map_err(|e| nb::Error::Other(IoError(e)))
        }
    }
}
