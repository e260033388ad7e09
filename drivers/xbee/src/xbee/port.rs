//! Putting an API frame on the port, written once: `maybe_async_cfg` generates the blocking
//! `send_frame` (over [`FramePort`]) from this async source and, with the `async` feature, keeps
//! `send_frame_async` (over `AsyncFramePort`). The codec is shared; only waiting for the port
//! differs (a poll budget per byte, or awaiting the write).

use crate::codec::encode_chunk;
use crate::frames::Frame;
use crate::types::{ApiEscaping, DeviceError, Error};

/// Bytes encoded per write: a short frame goes out in one write, a long one in a few.
const CHUNK_LEN: usize = 64;

#[maybe_async_cfg::maybe(
    sync(),
    async(feature = "async"),
    idents(FramePort(sync, async = "AsyncFramePort"))
)]
/// Writing frame bytes to the port, each write bounded: [`FramePort`], and `AsyncFramePort` with
/// the same methods, each `async` (feature `async`).
pub(crate) trait FramePort {
    /// The port's error.
    type Error;

    /// Writes all of `bytes`, in order; a port that stops taking bytes is
    /// [`DeviceError::Timeout`], never a hang or a panic.
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), Error<Self::Error>>;

    /// Waits until everything written has left the port, within a bounded wait.
    async fn flush(&mut self) -> Result<(), Error<Self::Error>>;
}

crate::blocking_and_async! {
    /// Encodes `frame` chunk by chunk (API 1 or API 2 `escaping`), writes each chunk and then
    /// flushes. A frame too long for the 16-bit length field is refused before any byte is
    /// written; a failed write may leave part of the frame sent, which the module drops by its
    /// length and checksum.
    pub(crate) async fn send_frame<P: FramePort>(
        port: &mut P,
        frame: &Frame<'_>,
        escaping: ApiEscaping,
    ) -> Result<(), Error<P::Error>> {
        let mut chunk = [0u8; CHUNK_LEN];
        let mut offset = 0;
        loop {
            let len = encode_chunk(frame, escaping, offset, &mut chunk)
                .map_err(|e| Error::Device(DeviceError::Frame(e)))?;
            let Some(bytes) = chunk.get(..len).filter(|b| !b.is_empty()) else {
                break;
            };
            port.write_all(bytes).await?;
            offset += len;
        }
        port.flush().await
    }
}
