//! The receiver on a serial port: configuration and the streaming reader together.

use crate::config::Config;
use crate::configure::{Configurator, MAX_READ_PER_POLL};
use crate::error::Error;
use crate::interface::{read_byte, Received};
use crate::nav_pvt::NavPvtFrame;
use crate::stream::{GnssStream, Message};
use crate::version::ReceiverVersion;
use embedded_hal::delay::DelayNs;
use embedded_hal_nb::serial::{Read, Write};

/// Most messages one [`NeoM8t::poll_nav_pvt`] call reads: over a second of 10 Hz NAV-PVT, with
/// margin, so a backlog is caught up in one call, yet the call always ends.
pub const MAX_MESSAGES_PER_POLL: usize = 16;

crate::blocking_and_async! {
    /// A NEO-M8T (or any M8) on an embedded-hal-nb serial port; `NeoM8tAsync` (feature
    /// `async`) is the same driver on an `embedded-io-async` 0.7 port, whose reading and
    /// configuring calls wait (`async`) instead of returning `WouldBlock`.
    ///
    /// Owns the port and a [`GnssStream`] with an `N`-byte frame buffer (512 holds MON-VER;
    /// 100 is enough once only NAV-PVT and TIM messages arrive). Reading `NeoM8t` never blocks:
    /// each call takes what the port has (at most [`MAX_READ_PER_POLL`] bytes) and returns.
    #[derive(Debug)]
    pub struct NeoM8t<S, const N: usize = 512> {
        serial: S,
        stream: GnssStream<N>,
        line_errors: u32,
    }
}

crate::blocking_and_async! {
    impl<S> NeoM8t<S> {
        /// Takes the port, with the default 512-byte frame buffer; nothing is sent.
        pub fn new(serial: S) -> Self {
            Self::with_capacity(serial)
        }
    }

    impl<S, const N: usize> NeoM8t<S, N> {
        /// Takes the port, with an `N`-byte frame buffer (`with_capacity::<100>(port)` is
        /// enough once only NAV-PVT and TIM messages arrive); nothing is sent.
        pub fn with_capacity(serial: S) -> Self {
            Self {
                serial,
                stream: GnssStream::with_capacity(),
                line_errors: 0,
            }
        }

        /// Gives the port back.
        pub fn release(self) -> S {
            self.serial
        }

        /// The port, e.g. to change the host baud rate.
        pub fn serial_mut(&mut self) -> &mut S {
            &mut self.serial
        }

        /// The stream state: latest NAV-PVT, TIM messages, counters.
        pub fn stream(&self) -> &GnssStream<N> {
            &self.stream
        }

        /// Mutable stream state (e.g. to take the latest NAV-PVT).
        pub fn stream_mut(&mut self) -> &mut GnssStream<N> {
            &mut self.stream
        }

        /// Overrun, framing, parity and noise errors reported by the port.
        pub fn line_errors(&self) -> u32 {
            self.line_errors
        }

        /// Counts a gap in the byte stream and drops the partial frame it spoiled.
        pub(crate) fn note_line_error(&mut self) {
            self.line_errors = self.line_errors.wrapping_add(1);
            self.stream.clear_partial();
        }
    }
}

impl<S, const N: usize> NeoM8t<S, N>
where
    S: Read<u8> + Write<u8>,
{
    /// Reads until one message is complete; `WouldBlock` when the port has no more bytes (or
    /// after [`MAX_READ_PER_POLL`] bytes without a message, so one call stays short).
    pub fn read_message(&mut self) -> nb::Result<Message, Error<S::Error>> {
        if let Some(message) = self.stream.poll_pending() {
            return Ok(message);
        }
        for _ in 0..MAX_READ_PER_POLL {
            match read_byte(&mut self.serial).map_err(Error::Comm)? {
                Received::Byte(byte) => {
                    if let Some(message) = self.stream.push(byte) {
                        return Ok(message);
                    }
                }
                Received::Idle => break,
                Received::LineError => self.note_line_error(),
            }
        }
        Err(nb::Error::WouldBlock)
    }

    /// Reads what the port has and returns the newest NAV-PVT frame that arrived, if any.
    ///
    /// One call reads at most [`MAX_MESSAGES_PER_POLL`] messages (each read is itself bounded
    /// by [`MAX_READ_PER_POLL`] bytes), so a port that never runs dry cannot hold the caller;
    /// the rest is read by the next call.
    pub fn poll_nav_pvt(&mut self) -> Result<Option<NavPvtFrame>, Error<S::Error>> {
        for _ in 0..MAX_MESSAGES_PER_POLL {
            match self.read_message() {
                Ok(_) => {}
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(e)) => return Err(e),
            }
        }
        Ok(self.stream.take_nav_pvt())
    }

    /// Applies `config` to a receiver whose UART1 is at `current_baud_rate`, blocking with
    /// `delay` (1 ms steps) until every message is acknowledged; see [`Configurator`] for the
    /// sequence, timeouts and the caller-polled variant. `set_baud_rate` must switch the
    /// host port. Returns what MON-VER reported.
    pub fn configure_blocking<D: DelayNs>(
        &mut self,
        config: Config,
        current_baud_rate: u32,
        delay: &mut D,
        set_baud_rate: impl FnMut(&mut S, u32),
    ) -> Result<ReceiverVersion, Error<S::Error>> {
        let mut configurator = Configurator::<512>::with_capacity(config, current_baud_rate);
        configurator.run_blocking(&mut self.serial, delay, set_baud_rate)?;
        self.stream.clear_partial();
        Ok(configurator.version().cloned().unwrap_or_default())
    }
}
