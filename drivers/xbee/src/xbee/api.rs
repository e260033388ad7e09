//! API mode (`AP = 1` or `2`): typed frames over an embedded-hal-nb serial port.

use embedded_hal_nb::serial::{Read, Write};

use super::port::{send_frame, FramePort};
use super::transparent::Transparent;
use super::XBee;
#[cfg(feature = "async")]
use super::XBeeAsync;
use crate::at::{AtCommand, Parameter};
use crate::codec::{DecoderStats, FrameDecoder};
use crate::frame_id::FrameIdAllocator;
use crate::frames::{AtCommandFrame, Frame, TransmitRequest};
use crate::types::{Address16, Address64, ApiEscaping, DeviceError, Error, FrameError};

/// Longest binary AT parameter [`XBee::send_at_command`] carries (a 16-byte key, a 20-byte
/// node identifier fit).
pub const MAX_AT_PARAMETER_LEN: usize = 32;

/// Default number of `WouldBlock` answers tolerated per written byte (and for the final
/// flush) before [`XBee::send`] gives up with [`DeviceError::Timeout`].
pub const DEFAULT_WRITE_POLLS_PER_BYTE: u32 = 1_000_000;

/// Mode state of an [`XBee`] in API mode (`AP = 1` or `2`): the frame decoder with its
/// `N`-byte receive buffer (the longest whole frame accepted; the default of 256 bytes holds any
/// frame with the largest Zigbee payload), the frame-id allocator and the write budget. Only
/// this module touches it.
#[derive(Debug)]
pub struct Api<const N: usize = 256> {
    decoder: FrameDecoder<N>,
    frame_ids: FrameIdAllocator,
    write_polls_per_byte: u32,
}

/// Why a frame could not be put on the serial port.
enum SinkError<E> {
    /// The port kept answering `WouldBlock` for the whole poll budget.
    Timeout,
    /// The port failed.
    Comm(E),
}

/// Polls a non-blocking serial operation until it completes, at most `polls` times, so a
/// wedged UART ends in a timeout instead of hanging the caller.
fn poll_bounded<E>(
    polls: u32,
    mut op: impl FnMut() -> nb::Result<(), E>,
) -> Result<(), SinkError<E>> {
    for _ in 0..polls {
        match op() {
            Ok(()) => return Ok(()),
            Err(nb::Error::WouldBlock) => {}
            Err(nb::Error::Other(e)) => return Err(SinkError::Comm(e)),
        }
    }
    Err(SinkError::Timeout)
}

/// The serial port with the poll budget of one byte (and of the final flush).
struct NbPort<'s, S> {
    serial: &'s mut S,
    polls: u32,
}

impl<S: Write<u8>> FramePort for NbPort<'_, S> {
    type Error = S::Error;

    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Error<S::Error>> {
        for &byte in bytes {
            poll_bounded(self.polls, || self.serial.write(byte))?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), Error<S::Error>> {
        Ok(poll_bounded(self.polls, || self.serial.flush())?)
    }
}

impl<E> From<SinkError<E>> for Error<E> {
    fn from(e: SinkError<E>) -> Self {
        match e {
            SinkError::Timeout => Error::Device(DeviceError::Timeout),
            SinkError::Comm(e) => Error::Comm(e),
        }
    }
}

crate::blocking_and_async! {
    impl<S> XBee<S, Api> {
        /// Wraps a serial port connected to a module in API mode with the given escaping (its
        /// `AP` setting), with the default 256-byte receive buffer.
        pub fn new_api(serial: S, escaping: ApiEscaping) -> Self {
            Self::api_with_capacity(serial, escaping)
        }
    }

    impl<S, const N: usize> XBee<S, Api<N>> {
        /// As [`XBee::new_api`], with an `N`-byte receive buffer
        /// (`XBee::<_, Api<64>>::api_with_capacity(serial, escaping)`).
        pub fn api_with_capacity(serial: S, escaping: ApiEscaping) -> Self {
            XBee::from_parts(
                serial,
                Api {
                    decoder: FrameDecoder::new(escaping),
                    frame_ids: FrameIdAllocator::new(),
                    write_polls_per_byte: DEFAULT_WRITE_POLLS_PER_BYTE,
                },
            )
        }

        /// Back to transparent mode with the factory command-mode timing, after the module was
        /// switched there (an `AP = 0` AT command frame, then `WR`/`AC` as needed). Keeps the
        /// port.
        pub fn into_transparent(self) -> XBee<S, Transparent> {
            XBee::new(self.serial)
        }

        /// The next frame id for a request that wants a response (never 0).
        pub fn next_frame_id(&mut self) -> u8 {
            self.mode.frame_ids.next_id()
        }

        /// Counters of received and dropped frames.
        pub fn stats(&self) -> DecoderStats {
            self.mode.decoder.stats()
        }
    }
}

impl<S, const N: usize> XBee<S, Api<N>> {
    /// Sets how many `WouldBlock` answers a written byte (or the final flush) may get before
    /// [`send`](XBee::send) gives up with [`DeviceError::Timeout`] (at least 1; default
    /// [`DEFAULT_WRITE_POLLS_PER_BYTE`]).
    pub fn with_write_polls_per_byte(mut self, polls: u32) -> Self {
        self.mode.write_polls_per_byte = polls.max(1);
        self
    }
}

impl<const N: usize> Api<N> {
    /// The escaping the module uses (its `AP` setting).
    pub(crate) fn escaping(&self) -> ApiEscaping {
        self.decoder.escaping()
    }

    /// Feeds one received byte to the decoder; `true` when it completes a frame.
    pub(crate) fn advance(&mut self, byte: u8) -> bool {
        self.decoder.advance(byte)
    }

    /// Whether a complete frame already waits in the decoder (API 1 rescanning can leave one):
    /// then no byte needs to be read for it.
    pub(crate) fn buffered(&mut self) -> bool {
        self.decoder.next_buffered().is_some()
    }

    /// The frame completed by the last [`advance`](Self::advance) or found by
    /// [`buffered`](Self::buffered), typed.
    pub(crate) fn parsed_frame(&self) -> Option<Result<Frame<'_>, FrameError>> {
        self.decoder.frame().map(|raw| raw.parse())
    }

    /// Encodes a local AT command's parameter (frame 0x08) into `bytes`; the frame id comes
    /// after, so a refused parameter costs no id.
    pub(crate) fn at_parameter<'b>(
        parameter: Parameter<'_>,
        bytes: &'b mut [u8; MAX_AT_PARAMETER_LEN],
    ) -> Result<&'b [u8], DeviceError> {
        let len = parameter
            .to_api_bytes(bytes)
            .ok_or(DeviceError::InvalidInput)?;
        Ok(bytes.get(..len).unwrap_or_default())
    }
}

/// A local AT command frame (0x08).
pub(crate) fn at_command_frame<'a>(
    frame_id: u8,
    command: AtCommand,
    parameter: &'a [u8],
) -> Frame<'a> {
    Frame::AtCommand(AtCommandFrame {
        frame_id,
        command,
        parameter,
    })
}

/// A transmit request (0x10) of `data` to `destination`, 16-bit address unknown, default
/// radius and options.
pub(crate) fn transmit_frame(frame_id: u8, destination: Address64, data: &[u8]) -> Frame<'_> {
    Frame::TransmitRequest(TransmitRequest {
        frame_id,
        destination,
        destination_16: Address16::UNKNOWN,
        broadcast_radius: 0,
        options: 0,
        data,
    })
}

impl<S, E, const N: usize> XBee<S, Api<N>>
where
    S: Read<u8, Error = E> + Write<u8, Error = E>,
{
    /// Sends one frame and flushes, polling the port while it answers `WouldBlock`.
    ///
    /// Fails with [`DeviceError::Timeout`] if one byte (or the flush) is refused for the whole poll
    /// budget ([`with_write_polls_per_byte`](XBee::with_write_polls_per_byte)); the frame
    /// may then be partly sent, which the module drops by its length and checksum.
    pub fn send(&mut self, frame: &Frame<'_>) -> Result<(), Error<E>> {
        let escaping = self.mode.escaping();
        let mut port = NbPort {
            serial: &mut self.serial,
            polls: self.mode.write_polls_per_byte,
        };
        send_frame(&mut port, frame, escaping)
    }

    /// Sends a local AT command (frame 0x08) with a fresh frame id; returns the id, which the
    /// [`AtResponse`](crate::frames::AtResponse) will carry.
    pub fn send_at_command(
        &mut self,
        command: AtCommand,
        parameter: Parameter<'_>,
    ) -> Result<u8, Error<E>> {
        let mut bytes = [0u8; MAX_AT_PARAMETER_LEN];
        let parameter = Api::<N>::at_parameter(parameter, &mut bytes).map_err(Error::Device)?;
        let frame_id = self.next_frame_id();
        self.send(&at_command_frame(frame_id, command, parameter))?;
        Ok(frame_id)
    }

    /// Sends `data` to `destination` (frame 0x10) with a fresh frame id; returns the id, which
    /// the [`TransmitStatus`](crate::frames::TransmitStatus) will carry.
    pub fn transmit(&mut self, destination: Address64, data: &[u8]) -> Result<u8, Error<E>> {
        let frame_id = self.next_frame_id();
        self.send(&transmit_frame(frame_id, destination, data))?;
        Ok(frame_id)
    }

    /// Reads what has arrived and returns the next complete frame, or `WouldBlock`.
    ///
    /// Garbage, bad checksums and oversized frames are skipped and counted in
    /// [`stats`](Self::stats). A frame of a known type with an invalid length is returned as
    /// [`DeviceError::Frame`].
    pub fn poll_frame(&mut self) -> nb::Result<Frame<'_>, Error<E>> {
        if !self.mode.buffered() {
            loop {
                let byte = self.serial.read().map_err(|e| e.map(Error::Comm))?;
                if self.mode.advance(byte) {
                    break;
                }
            }
        }
        match self.mode.parsed_frame() {
            Some(frame) => frame.map_err(|e| nb::Error::Other(Error::from(e))),
            None => Err(nb::Error::WouldBlock),
        }
    }
}
