//! API mode over an embedded-io-async port (feature `async`): the I/O of `XBeeAsync<S, Api>`.
//! Constructors, frame ids and counters are generated with the blocking driver's (`api.rs`); the
//! frame is encoded by the shared codec and written by the same `send_frame` source.

use embedded_io_async::{Read, Write};

use super::api::{at_command_frame, transmit_frame, Api, MAX_AT_PARAMETER_LEN};
use super::io_async::{read_byte, IoPort};
use super::port::send_frame_async;
use super::XBeeAsync;
use crate::at::{AtCommand, Parameter};
use crate::frames::Frame;
use crate::types::{Address64, Error};

impl<S: Write, const N: usize> XBeeAsync<S, Api<N>> {
    /// Encodes one frame into a small buffer, chunk by chunk, writes it all and flushes.
    ///
    /// A port whose `write` returns `Ok(0)` (it will never take the bytes) is
    /// [`DeviceError::Timeout`](crate::DeviceError::Timeout), never a panic; the frame may then
    /// be partly sent, which the module drops by its length and checksum. The same holds if
    /// this future is dropped before it completes.
    pub async fn send(&mut self, frame: &Frame<'_>) -> Result<(), Error<S::Error>> {
        let escaping = self.mode.escaping();
        let mut port = IoPort {
            io: &mut self.serial,
        };
        send_frame_async(&mut port, frame, escaping).await
    }

    /// Sends a local AT command (frame 0x08) with a fresh frame id; returns the id, which the
    /// [`AtResponse`](crate::frames::AtResponse) will carry. A parameter longer than
    /// [`MAX_AT_PARAMETER_LEN`] is refused before any I/O, and costs no id.
    pub async fn send_at_command(
        &mut self,
        command: AtCommand,
        parameter: Parameter<'_>,
    ) -> Result<u8, Error<S::Error>> {
        let mut buf = [0u8; MAX_AT_PARAMETER_LEN];
        let bytes = Api::<N>::at_parameter(parameter, &mut buf).map_err(Error::Device)?;
        let id = self.next_frame_id();
        self.send(&at_command_frame(id, command, bytes)).await?;
        Ok(id)
    }

    /// Sends `data` to `destination` (frame 0x10) with a fresh frame id; returns the id, which
    /// the [`TransmitStatus`](crate::frames::TransmitStatus) will carry.
    pub async fn transmit(
        &mut self,
        destination: Address64,
        data: &[u8],
    ) -> Result<u8, Error<S::Error>> {
        let id = self.next_frame_id();
        self.send(&transmit_frame(id, destination, data)).await?;
        Ok(id)
    }
}

impl<S: Read, const N: usize> XBeeAsync<S, Api<N>> {
    /// Waits for the next complete frame.
    ///
    /// Reads one byte at a time into the frame decoder: garbage, bad checksums and oversized
    /// frames are skipped and counted in [`stats`](Self::stats), as in
    /// [`XBee::poll_frame`](crate::XBee::poll_frame). A frame of a known type with an invalid
    /// length is [`DeviceError::Frame`](crate::DeviceError::Frame); end of stream (`read`
    /// returning `Ok(0)`) is [`DeviceError::Timeout`](crate::DeviceError::Timeout).
    ///
    /// Cancel-safe if the port's `read` is: every byte read is in the decoder before the next
    /// read starts, so dropping this future (e.g. when a timeout wins a `select`) loses no byte
    /// and the next call goes on with the partial frame.
    pub async fn read_frame(&mut self) -> Result<Frame<'_>, Error<S::Error>> {
        if !self.mode.buffered() {
            while !self.mode.advance(read_byte(&mut self.serial).await?) {}
        }
        match self.mode.parsed_frame() {
            Some(parsed) => parsed.map_err(Error::from),
            // `advance` or `buffered` said a frame is there.
            None => Err(Error::Device(crate::DeviceError::InvalidReply)),
        }
    }
}
