//! Host side: request a packet on the request line, collect the answer from the serial port.

use embedded_hal::digital::OutputPin;
use embedded_hal_nb::serial::{ErrorType as SerialPort, Read};
#[cfg(feature = "async")]
use embedded_io_async::ErrorType as AsyncSerialPort;

use crate::stream::{DecoderStats, Frame, StreamDecoder};

/// Most bytes one [`SensorBoard::poll`] call reads before giving control back: a little more
/// than a packet plus a full-size info frame, so one call can finish an answer but never loops
/// for long on a flooding port.
pub const MAX_BYTES_PER_POLL: usize = 512;

/// What went wrong on the board's side of the link, as opposed to an error a port reported:
/// the `Device` part of the errors of every driver crate of this family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DeviceError {
    /// No complete frame arrived before the deadline, or the port ended its stream (nothing
    /// more will come). Only the async driver waits; the blocking one returns
    /// `nb::Error::WouldBlock` and leaves the deadline to the caller.
    Timeout,
}

/// Errors of the host driver, in the shape of the other driver crates' errors: `Comm` for the
/// serial port's own error, `Device` for what the board did (a timeout is
/// `Error::Device(DeviceError::Timeout)`, as everywhere), plus `Pin` for the request line. The
/// driver owns two peripherals whose errors have types of their own, and keeps both rather than
/// drop one to a kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<PinE, SerialE> {
    /// The serial port reported an error (overrun, framing, parity, I/O).
    Comm(SerialE),
    /// The board did not answer as the link requires.
    Device(DeviceError),
    /// The request line could not be driven.
    Pin(PinE),
}

impl<PinE, SerialE> From<DeviceError> for Error<PinE, SerialE> {
    fn from(e: DeviceError) -> Self {
        Error::Device(e)
    }
}

impl core::fmt::Display for DeviceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DeviceError::Timeout => {
                f.write_str("no frame from the sensor board before the deadline")
            }
        }
    }
}

impl<PinE: core::fmt::Debug, SerialE: core::fmt::Debug> core::fmt::Display
    for Error<PinE, SerialE>
{
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Comm(e) => write!(f, "sensor board serial error: {e:?}"),
            Self::Device(e) => write!(f, "sensor board: {e}"),
            Self::Pin(e) => write!(f, "sensor board request line error: {e:?}"),
        }
    }
}

impl<PinE: core::fmt::Debug, SerialE: core::fmt::Debug> core::error::Error
    for Error<PinE, SerialE>
{
}

crate::blocking_and_async! {
    /// The sensor board seen from the host: a request line (GPIO output) and the serial port the
    /// answers arrive on. `SensorBoardAsync` (feature `async`) is the same driver on an
    /// `embedded-io-async` 0.7 port, whose reading call waits (`async`) with a deadline.
    ///
    /// **Request pulse.** The board starts a transfer on a *rising* edge of the request line.
    /// [`SensorBoard::request`] raises the line; lower it with [`SensorBoard::end_request`] before
    /// the next request (any time after the raise: the board's edge detector needs no minimum
    /// width). If the line is still high, `request` lowers it first so every call makes an edge.
    ///
    /// **Time.** Nothing in `SensorBoard` sleeps or waits. [`SensorBoard::poll`] reads what the port has
    /// (bounded by [`MAX_BYTES_PER_POLL`]) and returns [`nb::Error::WouldBlock`] until a frame is
    /// complete; the caller owns the deadline.
    #[derive(Debug)]
    pub struct SensorBoard<PIN, SERIAL> {
        request_pin: PIN,
        pub(crate) serial: SERIAL,
        pub(crate) decoder: StreamDecoder,
        line_high: bool,
    }
}

crate::blocking_and_async! {
    impl<PIN, SERIAL> SensorBoard<PIN, SERIAL>
    where
        PIN: OutputPin,
        SERIAL: SerialPort,
    {
        /// Takes the request line and the serial port. The line is assumed low (as configured by
        /// the caller); nothing is written to it until the first request.
        pub fn new(request_pin: PIN, serial: SERIAL) -> Self {
            Self {
                request_pin,
                serial,
                decoder: StreamDecoder::new(),
                line_high: false,
            }
        }

        /// Raises the request line (a rising edge asks the board for one packet).
        ///
        /// # Errors
        /// [`Error::Pin`] if the line cannot be driven.
        pub fn request(&mut self) -> Result<(), Error<PIN::Error, SERIAL::Error>> {
            if self.line_high {
                self.end_request()?;
            }
            self.request_pin.set_high().map_err(Error::Pin)?;
            self.line_high = true;
            Ok(())
        }

        /// Lowers the request line, completing the pulse started by [`SensorBoard::request`].
        ///
        /// # Errors
        /// [`Error::Pin`] if the line cannot be driven.
        pub fn end_request(&mut self) -> Result<(), Error<PIN::Error, SERIAL::Error>> {
            self.request_pin.set_low().map_err(Error::Pin)?;
            self.line_high = false;
            Ok(())
        }

        /// The stream decoder's counters.
        pub fn stats(&self) -> DecoderStats {
            self.decoder.stats()
        }

        /// Drops bytes buffered from an earlier answer (counted as skipped), e.g. after a timeout,
        /// so a late half packet cannot be mistaken for the start of the next answer.
        pub fn discard_buffered(&mut self) {
            self.decoder.clear();
        }

        /// Gives the request line and the serial port back.
        pub fn release(self) -> (PIN, SERIAL) {
            (self.request_pin, self.serial)
        }
    }
}

impl<PIN, SERIAL> SensorBoard<PIN, SERIAL>
where
    PIN: OutputPin,
    SERIAL: Read<u8>,
{
    /// Reads the bytes the port has into the stream decoder and returns the next complete
    /// frame (a packet or an info frame).
    ///
    /// # Errors
    /// [`nb::Error::WouldBlock`] while no frame is complete (after at most
    /// [`MAX_BYTES_PER_POLL`] bytes); [`Error::Comm`] when the port reports an error (the
    /// decoder resynchronises on its own afterwards).
    pub fn poll(&mut self) -> nb::Result<Frame, Error<PIN::Error, SERIAL::Error>> {
        if let Some(frame) = self.decoder.next_buffered() {
            return Ok(frame);
        }
        for _ in 0..MAX_BYTES_PER_POLL {
            let byte = self.serial.read().map_err(|e| e.map(Error::Comm))?;
            if let Some(frame) = self.decoder.push(byte) {
                return Ok(frame);
            }
        }
        Err(nb::Error::WouldBlock)
    }
}
