//! What waiting asynchronously needs (feature `async`): the port under `XBeeAsync`, writes that
//! cannot panic, and waits raced against an embedded-hal-async `DelayNs`.
//!
//! The port's `read` must be side-effect-free on cancel, as embedded-io-async asks of
//! cancel-safe readers: a read dropped before it completes consumes no byte. The driver drops
//! one when a deadline wins a race.

use core::future::{poll_fn, Future};
use core::pin::pin;
use core::task::Poll;

use embedded_hal_async::delay::DelayNs;

use super::port::AsyncFramePort;
use crate::types::{DeviceError, Error};

/// Writes all of `bytes` to `io`. A `write` returning `Ok(0)` for a non-empty buffer (the port
/// will never take the bytes) is [`DeviceError::Timeout`]; embedded-io-async's own `write_all`
/// would panic.
pub(crate) async fn write_all<T: embedded_io_async::Write>(
    io: &mut T,
    mut bytes: &[u8],
) -> Result<(), Error<T::Error>> {
    while !bytes.is_empty() {
        match io.write(bytes).await {
            Ok(0) => return Err(Error::Device(DeviceError::Timeout)),
            Ok(n) => bytes = bytes.get(n..).unwrap_or_default(),
            Err(e) => return Err(Error::Comm(e)),
        }
    }
    Ok(())
}

/// Reads one byte. End of stream (`Ok(0)`) is [`DeviceError::Timeout`]: nothing more will come.
pub(crate) async fn read_byte<T: embedded_io_async::Read>(
    io: &mut T,
) -> Result<u8, Error<T::Error>> {
    let mut byte = [0u8; 1];
    match io.read(&mut byte).await {
        Ok(0) => Err(Error::Device(DeviceError::Timeout)),
        Ok(_) => Ok(byte[0]),
        Err(e) => Err(Error::Comm(e)),
    }
}

/// A byte already received, if any: polls one read once and drops it if it would wait.
pub(crate) async fn take_pending<T: embedded_io_async::Read>(
    io: &mut T,
) -> Result<Option<u8>, Error<T::Error>> {
    let mut read = pin!(read_byte(io));
    poll_fn(|cx| match read.as_mut().poll(cx) {
        // End of stream: nothing is waiting.
        Poll::Ready(Err(Error::Device(DeviceError::Timeout))) => Poll::Ready(Ok(None)),
        Poll::Ready(result) => Poll::Ready(result.map(Some)),
        Poll::Pending => Poll::Ready(Ok(None)),
    })
    .await
}

/// The frame port of the async API driver: an embedded-io-async writer.
pub(crate) struct IoPort<'s, T> {
    pub(crate) io: &'s mut T,
}

impl<T: embedded_io_async::Write> AsyncFramePort for IoPort<'_, T> {
    type Error = T::Error;

    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), Error<T::Error>> {
        write_all(self.io, bytes).await
    }

    async fn flush(&mut self) -> Result<(), Error<T::Error>> {
        self.io.flush().await.map_err(Error::Comm)
    }
}

/// Length of one delay while racing a wait, in ms: the resolution of the async command mode's
/// clocks (a reply that comes within a step counts as a whole step on the clock of time that
/// may have passed, and not at all on the clock of time surely waited).
pub(crate) const WAIT_STEP_MS: u32 = 10;

/// How a raced wait ended.
pub(crate) struct Raced<T> {
    /// What `work` gave, or `None` if `timeout_ms` ran out first.
    pub(crate) output: Option<T>,
    /// Delay steps completed meanwhile, in ms: time surely waited.
    pub(crate) waited_ms: u32,
    /// Time that may have passed, in ms: `waited_ms` plus the step in progress when `work`
    /// completed.
    pub(crate) bound_ms: u32,
}

/// Runs `work` for at most `timeout_ms`, raced against delays of [`WAIT_STEP_MS`]: each poll
/// polls `work` first, so a result already there wins even against a delay that completes at
/// once. `work` is dropped if the time runs out; it is never restarted in between.
pub(crate) async fn within<D: DelayNs, F: Future>(
    delay: &mut D,
    timeout_ms: u32,
    work: F,
) -> Raced<F::Output> {
    let mut work = pin!(work);
    let mut waited_ms = 0;
    loop {
        // A zero timeout still polls `work` once.
        let step = WAIT_STEP_MS.min(timeout_ms.saturating_sub(waited_ms));
        let mut expire = pin!(delay.delay_ms(step));
        let output = poll_fn(|cx| {
            if let Poll::Ready(out) = work.as_mut().poll(cx) {
                return Poll::Ready(Some(out));
            }
            expire.as_mut().poll(cx).map(|()| None)
        })
        .await;
        if output.is_some() {
            return Raced {
                output,
                waited_ms,
                bound_ms: waited_ms + step,
            };
        }
        waited_ms += step;
        if waited_ms >= timeout_ms {
            return Raced {
                output: None,
                waited_ms,
                bound_ms: waited_ms,
            };
        }
    }
}
