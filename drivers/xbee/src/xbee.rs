//! The driver: one [`XBee`] type whose mode is a type parameter, [`Transparent`] or [`Api`].
//!
//! The mode follows the module's `AP` setting. Switching is typed: set `AP` through the
//! transparent driver's command session, then [`XBee::into_api`]; back with
//! [`XBee::into_transparent`]. Each mode's state is private to its module.

mod api;
#[cfg(feature = "async")]
mod api_async;
#[cfg(feature = "async")]
mod io_async;
mod port;
mod transparent;

pub use api::{Api, DEFAULT_WRITE_POLLS_PER_BYTE, MAX_AT_PARAMETER_LEN};
#[cfg(feature = "async")]
pub use transparent::AsyncCommandSession;
pub use transparent::{
    CommandOutcome, CommandSession, CommandTiming, Mode, Transparent, POLL_STEP_US,
};

use crate::types::ApiEscaping;

crate::blocking_and_async! {
/// A Digi XBee module on a serial port, in transparent mode (`XBee<S, Transparent>`, from
/// [`XBee::new`]) or API mode (`XBee<S, Api>`, from [`XBee::new_api`]).
///
/// In transparent mode: the module as a byte pipe, with guarded AT command mode.
///
/// A thin wrapper: the serial port, the command-mode state and one 48-byte line buffer; no
/// allocation. It implements embedded-hal-nb [`Read<u8>`](embedded_hal_nb::serial::Read) and [`Write<u8>`](embedded_hal_nb::serial::Write) (and, with the
/// `embedded-io` feature, `embedded_io::Read`/`Write`), so framed protocols run over it as over
/// the bare port.
///
/// Command mode is a state machine driven by the caller's clock
/// ([`start_command_mode`](XBee::start_command_mode), [`start_command`](XBee::start_command),
/// [`start_exit`](XBee::start_exit), then [`poll`](XBee::poll) until it is not `WouldBlock`),
/// or blocking with a `DelayNs` through [`command_mode`](XBee::command_mode). Use one of the two
/// per driver: they count time on different clocks.
///
/// `XBeeAsync` (feature `async`) is the same driver over an `embedded-io-async` 0.7 port, with
/// the I/O methods `async`: in transparent mode it implements `embedded_io_async::{Read, Write}`
/// and enters command mode with `command_mode(&mut delay).await`, the guard times awaited on an
/// embedded-hal-async `DelayNs`; in API mode it has `send`, `transmit`, `send_at_command` and
/// `read_frame`. (The paragraphs above describe `XBee`.)
#[derive(Debug)]
pub struct XBee<S, M> {
    serial: S,
    mode: M,
}

impl<S, M> XBee<S, M> {
    const fn from_parts(serial: S, mode: M) -> Self {
        Self { serial, mode }
    }

    /// Gives the serial port back.
    pub fn release(self) -> S {
        self.serial
    }

    /// The serial port, for port settings such as its baud rate after a `BD` change. Bytes
    /// written through it bypass the driver (the command-mode guard, the frame encoder).
    pub fn serial_mut(&mut self) -> &mut S {
        &mut self.serial
    }
}
}

crate::blocking_and_async! {
impl<S> XBee<S, Transparent> {
    /// API mode with the default 256-byte receive buffer, after the module was switched there:
    /// `AP` set to `escaping`'s mode in a `command_mode` session that has been left (the
    /// session's `exit`). Keeps the port; no bytes are sent.
    pub fn into_api(self, escaping: ApiEscaping) -> XBee<S, Api> {
        XBee::new_api(self.serial, escaping)
    }
}
}
