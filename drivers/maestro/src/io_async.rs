//! The async transport under `MaestroAsync` (feature `async`): reading replies over
//! `embedded-io-async` 0.7, and reply deadlines raced against an embedded-hal-async `DelayNs`.
//!
//! The driver itself is generated from the blocking source (see `device.rs`); this module holds
//! only what waiting asynchronously needs.

use core::future::{poll_fn, Future};
use core::pin::pin;
use core::task::Poll;

use crate::device::MaestroAsync;
use crate::error::Error;
use crate::interface::AsyncWriteInterface;
use crate::model::Model;
use crate::DeviceError;

/// Reading reply bytes asynchronously: the async counterpart of
/// [`ReadInterface`](crate::ReadInterface).
#[allow(async_fn_in_trait)] // as embedded-hal-async: the caller's executor decides on Send
pub trait AsyncReadInterface: AsyncWriteInterface {
    /// Waits for one received byte.
    ///
    /// Must be side-effect-free on cancel: a call dropped before it completes consumes no byte
    /// (the driver drops it when the deadline wins the race, and polls it once to see whether a
    /// stale byte is waiting).
    async fn read_byte(&mut self) -> Result<u8, Error<Self::Error>>;
}

/// When to give up waiting for a reply, asynchronously: the counterpart of
/// [`Deadline`](crate::Deadline). The driver races one whole reply against
/// [`AsyncDeadline::expire`].
#[allow(async_fn_in_trait)] // as embedded-hal-async: the caller's executor decides on Send
pub trait AsyncDeadline {
    /// Completes once waiting must stop.
    async fn expire(&mut self);
}

/// A deadline in microseconds measured with an embedded-hal-async `DelayNs`: each query waits
/// at most `timeout_us` for its whole reply.
pub struct AsyncDelayDeadline<'a, D> {
    delay: &'a mut D,
    timeout_us: u32,
}

impl<'a, D: embedded_hal_async::delay::DelayNs> AsyncDelayDeadline<'a, D> {
    /// Wait at most `timeout_us` for each reply.
    ///
    /// At 115200 baud a two-byte reply takes about 175 µs on the wire, plus the Maestro's
    /// processing; a few milliseconds is a generous timeout.
    pub fn new(delay: &'a mut D, timeout_us: u32) -> Self {
        Self { delay, timeout_us }
    }
}

impl<D: embedded_hal_async::delay::DelayNs> AsyncDeadline for AsyncDelayDeadline<'_, D> {
    async fn expire(&mut self) {
        self.delay.delay_us(self.timeout_us).await;
    }
}

/// Transport over `embedded-io-async` 0.7 (`Write`, plus `Read` for queries), e.g. an Embassy
/// buffered UART.
///
/// `write` returning `Ok(0)` for a non-empty packet (the port will never take it) is
/// [`DeviceError::Timeout`] (embedded-io-async's own `write_all` would panic); a read returning
/// `Ok(0)` (end of stream) is [`DeviceError::Timeout`] as well: no reply will come.
#[derive(Debug)]
pub struct AsyncIoSerial<T> {
    io: T,
}

impl<T> AsyncIoSerial<T> {
    /// Wrap `io`.
    pub fn new(io: T) -> Self {
        Self { io }
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

impl<T: embedded_io_async::Write> AsyncWriteInterface for AsyncIoSerial<T> {
    type Error = T::Error;

    async fn write_all(&mut self, mut bytes: &[u8]) -> Result<(), Error<T::Error>> {
        while !bytes.is_empty() {
            let written = self.io.write(bytes).await.map_err(Error::Comm)?;
            if written == 0 {
                return Err(Error::Device(DeviceError::Timeout));
            }
            bytes = bytes.get(written..).unwrap_or(&[]);
        }
        Ok(())
    }

    async fn flush(&mut self) -> Result<(), Error<T::Error>> {
        self.io.flush().await.map_err(Error::Comm)
    }
}

impl<T> AsyncReadInterface for AsyncIoSerial<T>
where
    T: embedded_io_async::Write + embedded_io_async::Read,
{
    async fn read_byte(&mut self) -> Result<u8, Error<T::Error>> {
        let mut byte = [0u8; 1];
        match self.io.read(&mut byte).await {
            Ok(0) => Err(Error::Device(DeviceError::Timeout)),
            Ok(_) => Ok(byte[0]),
            Err(e) => Err(Error::Comm(e)),
        }
    }
}

impl<T: embedded_io_async::Write, M: Model> MaestroAsync<AsyncIoSerial<T>, M> {
    /// A driver on an `embedded-io-async` 0.7 port, without limits.
    pub fn new_io(io: T, model: M, framing: crate::Framing) -> Self {
        Self::new(AsyncIoSerial::new(io), model, framing)
    }

    /// Gives the port back (what [`MaestroAsync::new_io`] was given).
    pub fn release(self) -> T {
        self.into_interface().release()
    }
}

/// Which of two raced futures finished first.
enum Raced<A, B> {
    First(A),
    Second(B),
}

/// Polls `first`, then `second`, until one completes; the other is dropped.
async fn race<A: Future, B: Future>(first: A, second: B) -> Raced<A::Output, B::Output> {
    let mut first = pin!(first);
    let mut second = pin!(second);
    poll_fn(|cx| {
        if let Poll::Ready(out) = first.as_mut().poll(cx) {
            return Poll::Ready(Raced::First(out));
        }
        if let Poll::Ready(out) = second.as_mut().poll(cx) {
            return Poll::Ready(Raced::Second(out));
        }
        Poll::Pending
    })
    .await
}

/// Reads a whole reply for the async driver, raced against `deadline`: if it expires first the
/// partial reply is dropped and the query fails with [`DeviceError::Timeout`].
pub(crate) async fn read_reply<I: AsyncReadInterface>(
    iface: &mut I,
    reply: &mut [u8],
    deadline: &mut impl AsyncDeadline,
) -> Result<(), Error<I::Error>> {
    let read_all = async {
        for slot in reply.iter_mut() {
            *slot = iface.read_byte().await?;
        }
        Ok(())
    };
    match race(read_all, deadline.expire()).await {
        Raced::First(result) => result,
        Raced::Second(()) => Err(Error::Device(DeviceError::Timeout)),
    }
}

/// A byte already received, if any: polls one read once and drops it if it would wait.
pub(crate) async fn take_pending<I: AsyncReadInterface>(
    iface: &mut I,
) -> Result<Option<u8>, Error<I::Error>> {
    let mut read = pin!(iface.read_byte());
    poll_fn(|cx| match read.as_mut().poll(cx) {
        // End of stream: nothing is waiting (the reply read will time out the same way).
        Poll::Ready(Err(Error::Device(DeviceError::Timeout))) => Poll::Ready(Ok(None)),
        Poll::Ready(result) => Poll::Ready(result.map(Some)),
        Poll::Pending => Poll::Ready(Ok(None)),
    })
    .await
}
