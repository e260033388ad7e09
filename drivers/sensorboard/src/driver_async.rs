//! What only the async host driver does (feature `async`): waiting for answer bytes on an
//! `embedded-io-async` 0.7 port, raced against an embedded-hal-async `DelayNs`.
//!
//! The driver type, the request pulse and the accessors are generated from the blocking source
//! (see `driver.rs`), and the bytes go through the same [`StreamDecoder`](crate::StreamDecoder).
//! The request line stays an embedded-hal `OutputPin`: setting a GPIO completes at once.
//!
//! **Cancel safety.** Bytes are read one at a time and pushed into the decoder before the next
//! `.await`, so a [`SensorBoardAsync::read_frame`] dropped at any point (by a `select`, the
//! caller's own timeout) loses no byte it took: the next call goes on with the same partial
//! frame.

use core::future::{poll_fn, Future};
use core::pin::pin;
use core::task::Poll;

use embedded_hal::digital::OutputPin;
use embedded_hal_async::delay::DelayNs;
use embedded_io_async::Read;

use crate::driver::{DeviceError, Error, SensorBoardAsync};
use crate::stream::Frame;

/// Polls `wait` until it completes or `deadline` does first (then `None`); the other is
/// dropped.
async fn before<T>(wait: impl Future<Output = T>, deadline: impl Future<Output = ()>) -> Option<T> {
    let mut wait = pin!(wait);
    let mut deadline = pin!(deadline);
    poll_fn(|cx| {
        if let Poll::Ready(out) = wait.as_mut().poll(cx) {
            return Poll::Ready(Some(out));
        }
        if deadline.as_mut().poll(cx).is_ready() {
            return Poll::Ready(None);
        }
        Poll::Pending
    })
    .await
}

impl<PIN, SERIAL> SensorBoardAsync<PIN, SERIAL>
where
    PIN: OutputPin,
    SERIAL: Read,
{
    /// Waits for the next complete frame (a packet or an info frame) for at most `timeout_us`
    /// measured with `delay`.
    ///
    /// Cancel-safe: bytes already read stay in the decoder (see the module docs). After a
    /// timeout, [`discard_buffered`](Self::discard_buffered) drops a late half answer before
    /// the next request.
    ///
    /// # Errors
    /// `Error::Device(DeviceError::Timeout)` if no frame completed in time, or if the port
    /// reports the end of its stream (a read of `Ok(0)`: nothing more will come);
    /// [`Error::Comm`] when the port reports an error (the decoder resynchronises on its own
    /// afterwards).
    pub async fn read_frame<D: DelayNs>(
        &mut self,
        delay: &mut D,
        timeout_us: u32,
    ) -> Result<Frame, Error<PIN::Error, SERIAL::Error>> {
        let wait = async {
            loop {
                if let Some(frame) = self.decoder.next_buffered() {
                    return Ok(frame);
                }
                let mut byte = [0u8; 1];
                if self.serial.read(&mut byte).await.map_err(Error::Comm)? == 0 {
                    return Err(DeviceError::Timeout.into());
                }
                if let Some(frame) = self.decoder.push(byte[0]) {
                    return Ok(frame);
                }
            }
        };
        before(wait, delay.delay_us(timeout_us))
            .await
            .unwrap_or(Err(DeviceError::Timeout.into()))
    }
}
