//! The serial transport under the driver, and deadlines for replies.
//!
//! Two transports: [`NbSerial`] over embedded-hal-nb 1.0 `serial::Write<u8>` (+ `Read<u8>` for
//! queries), implemented by linux-embedded-hal 0.5 and the MCU HALs, and `IoSerial` over
//! embedded-io 0.7 (feature `embedded-io`).

use crate::error::Error;

#[maybe_async_cfg::maybe(
    sync(),
    async(feature = "async"),
    idents(WriteInterface(sync, async = "AsyncWriteInterface"))
)]
/// Writing whole packets: [`WriteInterface`], and `AsyncWriteInterface` with the same methods,
/// each `async` (feature `async`).
#[allow(async_fn_in_trait)] // as embedded-hal-async: the caller's executor decides on Send
pub trait WriteInterface {
    /// The transport's error.
    type Error;

    /// Write all of `bytes`, in order. Implementations bound every wait (see [`NbSerial`]).
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), Error<Self::Error>>;

    /// Wait until everything written has left the transport, within a bounded wait.
    /// The default does nothing (for transports without a transmit buffer).
    async fn flush(&mut self) -> Result<(), Error<Self::Error>> {
        Ok(())
    }
}

/// Reading reply bytes without blocking.
pub trait ReadInterface: WriteInterface {
    /// One received byte, or `WouldBlock` if none is available yet.
    fn read_byte(&mut self) -> nb::Result<u8, Self::Error>;
}

/// Reads a whole reply for the blocking driver: polls `iface`, and each time no byte is there
/// asks `deadline` whether to stop ([`DeviceError::Timeout`](crate::DeviceError::Timeout)).
pub(crate) fn read_reply<I: ReadInterface>(
    iface: &mut I,
    reply: &mut [u8],
    deadline: &mut impl Deadline,
) -> Result<(), Error<I::Error>> {
    for slot in reply.iter_mut() {
        loop {
            match iface.read_byte() {
                Ok(byte) => {
                    *slot = byte;
                    break;
                }
                Err(nb::Error::WouldBlock) => {
                    if deadline.expired() {
                        return Err(Error::Device(crate::DeviceError::Timeout));
                    }
                }
                Err(nb::Error::Other(e)) => return Err(Error::Comm(e)),
            }
        }
    }
    Ok(())
}

/// A byte already received, if any, without waiting (for discarding stale bytes).
pub(crate) fn take_pending<I: ReadInterface>(iface: &mut I) -> Result<Option<u8>, Error<I::Error>> {
    match iface.read_byte() {
        Ok(byte) => Ok(Some(byte)),
        Err(nb::Error::WouldBlock) => Ok(None),
        Err(nb::Error::Other(e)) => Err(Error::Comm(e)),
    }
}

/// When to give up waiting for a reply. Polled once each time no byte is available.
///
/// Implemented by [`PollBudget`], [`DelayDeadline`] and by any `FnMut() -> bool` closure
/// (return `true` once the deadline has passed), e.g. one comparing `std::time::Instant`s.
pub trait Deadline {
    /// True once waiting must stop.
    fn expired(&mut self) -> bool;
}

impl<F: FnMut() -> bool> Deadline for F {
    fn expired(&mut self) -> bool {
        self()
    }
}

/// A deadline counted in polls: tolerates `n` empty polls of the transport; the next one ends
/// the wait.
///
/// Without a clock this is the only honest bound; pick `n` from the poll cost of your
/// transport (or use [`DelayDeadline`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PollBudget(pub u32);

impl Deadline for PollBudget {
    fn expired(&mut self) -> bool {
        if self.0 == 0 {
            true
        } else {
            self.0 -= 1;
            false
        }
    }
}

/// A deadline in microseconds measured with an embedded-hal `DelayNs`: each empty poll sleeps
/// `step_us` and counts it against `timeout_us`.
pub struct DelayDeadline<'a, D> {
    delay: &'a mut D,
    step_us: u32,
    remaining_us: u32,
}

impl<'a, D: embedded_hal::delay::DelayNs> DelayDeadline<'a, D> {
    /// Wait at most `timeout_us`, sleeping `step_us` (at least 1) between polls.
    ///
    /// At 115200 baud a two-byte reply takes about 175 µs on the wire, plus the Maestro's
    /// processing; a few milliseconds is a generous timeout.
    pub fn new(delay: &'a mut D, timeout_us: u32, step_us: u32) -> Self {
        Self {
            delay,
            step_us: step_us.max(1),
            remaining_us: timeout_us,
        }
    }
}

impl<D: embedded_hal::delay::DelayNs> Deadline for DelayDeadline<'_, D> {
    fn expired(&mut self) -> bool {
        if self.remaining_us == 0 {
            return true;
        }
        let step = self.step_us.min(self.remaining_us);
        self.delay.delay_us(step);
        self.remaining_us -= step;
        false
    }
}

/// Default number of `WouldBlock` polls tolerated per written byte before a write gives up
/// with [`DeviceError::Timeout`](crate::DeviceError::Timeout).
pub const DEFAULT_WRITE_POLLS_PER_BYTE: u32 = 1_000_000;

/// Transport over embedded-hal-nb 1.0 serial.
///
/// A byte the transmitter refuses (`WouldBlock`) `write_polls_per_byte` times in a row ends
/// the write with [`DeviceError::Timeout`](crate::DeviceError::Timeout), so a wedged UART cannot hang the caller.
#[derive(Debug)]
pub struct NbSerial<S> {
    serial: S,
    write_polls_per_byte: u32,
}

impl<S> NbSerial<S> {
    /// Wrap `serial` with [`DEFAULT_WRITE_POLLS_PER_BYTE`].
    pub fn new(serial: S) -> Self {
        Self {
            serial,
            write_polls_per_byte: DEFAULT_WRITE_POLLS_PER_BYTE,
        }
    }

    /// Set the per-byte write poll budget (at least 1).
    pub fn with_write_polls_per_byte(mut self, polls: u32) -> Self {
        self.write_polls_per_byte = polls.max(1);
        self
    }

    /// The wrapped serial port.
    pub fn inner(&mut self) -> &mut S {
        &mut self.serial
    }

    /// Give the serial port back.
    pub fn release(self) -> S {
        self.serial
    }
}

impl<S: embedded_hal_nb::serial::Write<u8>> WriteInterface for NbSerial<S> {
    type Error = S::Error;

    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Error<S::Error>> {
        for &byte in bytes {
            let mut polls = self.write_polls_per_byte;
            loop {
                match self.serial.write(byte) {
                    Ok(()) => break,
                    Err(nb::Error::WouldBlock) => {
                        polls = polls.saturating_sub(1);
                        if polls == 0 {
                            return Err(Error::Device(crate::DeviceError::Timeout));
                        }
                    }
                    Err(nb::Error::Other(e)) => return Err(Error::Comm(e)),
                }
            }
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), Error<S::Error>> {
        let mut polls = self.write_polls_per_byte;
        loop {
            match self.serial.flush() {
                Ok(()) => return Ok(()),
                Err(nb::Error::WouldBlock) => {
                    polls = polls.saturating_sub(1);
                    if polls == 0 {
                        return Err(Error::Device(crate::DeviceError::Timeout));
                    }
                }
                Err(nb::Error::Other(e)) => return Err(Error::Comm(e)),
            }
        }
    }
}

impl<S> ReadInterface for NbSerial<S>
where
    S: embedded_hal_nb::serial::Write<u8> + embedded_hal_nb::serial::Read<u8>,
{
    fn read_byte(&mut self) -> nb::Result<u8, S::Error> {
        self.serial.read()
    }
}

#[cfg(feature = "embedded-io")]
mod io {
    use super::{ReadInterface, WriteInterface, DEFAULT_WRITE_POLLS_PER_BYTE};
    use crate::error::Error;

    /// Transport over embedded-io 0.7 (`Write`, plus `Read + ReadReady` for queries).
    ///
    /// A whole packet goes to `write` in as few calls as the port accepts. `write` returning
    /// `Ok(0)` is retried within a poll budget and then reported as [`DeviceError::Timeout`](crate::DeviceError::Timeout)
    /// (embedded-io's own `write_all` would panic). Reads only happen when `read_ready()` says
    /// a byte is there, so they never block.
    #[derive(Debug)]
    pub struct IoSerial<T> {
        io: T,
        write_polls: u32,
    }

    impl<T> IoSerial<T> {
        /// Wrap `io`.
        pub fn new(io: T) -> Self {
            Self {
                io,
                write_polls: DEFAULT_WRITE_POLLS_PER_BYTE,
            }
        }

        /// The wrapped port.
        pub fn inner(&mut self) -> &mut T {
            &mut self.io
        }

        /// Give the port back.
        pub fn release(self) -> T {
            self.io
        }
    }

    impl<T: embedded_io::Write> WriteInterface for IoSerial<T> {
        type Error = T::Error;

        fn write_all(&mut self, mut bytes: &[u8]) -> Result<(), Error<T::Error>> {
            let mut polls = self.write_polls;
            while !bytes.is_empty() {
                match self.io.write(bytes) {
                    Ok(0) => {
                        polls = polls.saturating_sub(1);
                        if polls == 0 {
                            return Err(Error::Device(crate::DeviceError::Timeout));
                        }
                    }
                    Ok(n) => bytes = bytes.get(n..).unwrap_or(&[]),
                    Err(e) => return Err(Error::Comm(e)),
                }
            }
            Ok(())
        }

        fn flush(&mut self) -> Result<(), Error<T::Error>> {
            self.io.flush().map_err(Error::Comm)
        }
    }

    impl<T> ReadInterface for IoSerial<T>
    where
        T: embedded_io::Write + embedded_io::Read + embedded_io::ReadReady,
    {
        fn read_byte(&mut self) -> nb::Result<u8, T::Error> {
            if !self.io.read_ready().map_err(nb::Error::Other)? {
                return Err(nb::Error::WouldBlock);
            }
            let mut byte = [0u8; 1];
            match self.io.read(&mut byte) {
                Ok(1) => Ok(byte[0]),
                Ok(_) => Err(nb::Error::WouldBlock),
                Err(e) => Err(nb::Error::Other(e)),
            }
        }
    }
}

#[cfg(feature = "embedded-io")]
pub use io::IoSerial;
