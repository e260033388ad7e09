//! Transparent mode: the module as a byte pipe over an embedded-hal-nb serial port.
//!
//! [`Transparent`] forwards every byte while the module is in transparent mode. While it is in
//! (or may still be in) AT command mode, writes are refused with
//! [`DeviceError::CommandModeActive`] instead of being sent as AT text, and reads return
//! `WouldBlock` because the incoming bytes are the module's replies.

use embedded_hal_nb::serial::{ErrorType, Read, Write};

use super::XBee;
#[cfg(feature = "async")]
use super::XBeeAsync;
use crate::at::MAX_LINE_LEN;
use crate::types::{DeviceError, Error};

mod command;
mod session;
#[cfg(feature = "async")]
mod session_async;

pub use command::CommandOutcome;
#[cfg(feature = "async")]
use command::ReplyEnd;
pub use session::{CommandSession, POLL_STEP_US};
#[cfg(feature = "async")]
pub use session_async::AsyncCommandSession;

/// Timing of the module's command mode. Must match the module's `GT`, `CT` and `CC` settings;
/// the defaults are the factory values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CommandTiming {
    /// `GT`: silence required before and after the command sequence, in ms (default 1000).
    pub guard_time_ms: u32,
    /// Extra silence kept before `+++`, in ms (default 50): bytes can still be leaving a USB
    /// serial adapter's FIFO after the host's flush returns, and a millisecond clock may be
    /// up to 1 ms short. Waiting longer than `GT` is harmless.
    pub guard_margin_ms: u32,
    /// `CT` × 100: the module leaves command mode after this long without a valid command,
    /// in ms (default 10 000).
    pub command_timeout_ms: u32,
    /// How long to wait for a reply line, in ms (default 1000). Also the safety margin kept
    /// around `CT`: no command is sent later than `CT - reply_timeout` after the last valid one,
    /// and no data earlier than `CT + reply_timeout` after the last command line.
    pub reply_timeout_ms: u32,
    /// `CC`: the command sequence character, sent three times (default `+`).
    pub command_character: u8,
}

impl CommandTiming {
    /// Sets the guard time (`GT`), in ms.
    pub const fn with_guard_time_ms(mut self, ms: u32) -> Self {
        self.guard_time_ms = ms;
        self
    }
    /// Sets the extra silence kept before `+++`, in ms.
    pub const fn with_guard_margin_ms(mut self, ms: u32) -> Self {
        self.guard_margin_ms = ms;
        self
    }
    /// Sets the command-mode timeout (`CT` × 100), in ms.
    pub const fn with_command_timeout_ms(mut self, ms: u32) -> Self {
        self.command_timeout_ms = ms;
        self
    }
    /// Sets the reply timeout, in ms.
    pub const fn with_reply_timeout_ms(mut self, ms: u32) -> Self {
        self.reply_timeout_ms = ms;
        self
    }
    /// Sets the command sequence character (`CC`).
    pub const fn with_command_character(mut self, c: u8) -> Self {
        self.command_character = c;
        self
    }
}

impl Default for CommandTiming {
    fn default() -> Self {
        Self {
            guard_time_ms: 1000,
            guard_margin_ms: 50,
            command_timeout_ms: 10_000,
            reply_timeout_ms: 1000,
            command_character: b'+',
        }
    }
}

/// Where the driver believes the module is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Transparent: bytes pass through.
    Transparent,
    /// Entering command mode: waiting out the guard times, sending `+++`, waiting for `OK`.
    /// Reads still pass through until `+++` is sent; writes are refused.
    Entering,
    /// In command mode (or possibly still in it, until `CT` has surely run out): ready for an
    /// AT command; data is refused.
    Command,
    /// An AT command is being sent or its reply awaited.
    Busy,
    /// Leaving command mode: `ATCN` sent, or waiting for `CT` to run out.
    Leaving,
}

/// Internal state of the command-mode machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum State {
    Transparent,
    /// Possibly in command mode but too close to `CT` to send: wait until surely out.
    EnterWaitExit,
    EnterFlush,
    EnterGuard,
    EnterPlus {
        sent: u8,
    },
    EnterAwaitOk,
    Ready,
    Sending {
        pos: usize,
        exit: bool,
    },
    AwaitReply {
        exit: bool,
    },
    Leaving,
}

/// Mode state of an [`XBee`] in transparent mode (`AP = 0`): the command-mode machine and its
/// line buffer. Only this module touches it.
#[derive(Debug)]
pub struct Transparent {
    timing: CommandTiming,
    state: State,
    /// Clock value at the first poll in the current state.
    state_since: Option<u32>,
    /// When the last command the module accepted was sent (its `CT` timer restarted then). The
    /// async driver stamps it on its clock of time that may have passed (`bound_us`).
    confirmed_ms: Option<u32>,
    /// When the last command-mode input (`+++` or a command line) was completed.
    input_ms: u32,
    /// Outgoing command line, then the reply line.
    line: [u8; MAX_LINE_LEN],
    line_len: usize,
    line_overflow: bool,
    /// Virtual clock of the blocking API, in µs.
    clock_us: u64,
    discarded: u32,
    /// A reply timed out: drain the input before the next command.
    stale_input: bool,
    /// The last poll came from the blocking API (its clock is counted from delays).
    delay_clock: bool,
    /// Async command mode: `clock_us` counts only the time surely waited (completed delays);
    /// this clock also counts every wait that ended early (a reply that came before its
    /// deadline) at its full length, so it runs ahead of the real time waited.
    #[cfg(feature = "async")]
    bound_us: u64,
}

impl Transparent {
    fn new(timing: CommandTiming) -> Self {
        Self {
            timing,
            state: State::Transparent,
            state_since: None,
            confirmed_ms: None,
            input_ms: 0,
            line: [0; MAX_LINE_LEN],
            line_len: 0,
            line_overflow: false,
            clock_us: 0,
            discarded: 0,
            stale_input: false,
            delay_clock: false,
            #[cfg(feature = "async")]
            bound_us: 0,
        }
    }

    /// Where the driver believes the module is.
    fn mode(&self) -> Mode {
        match self.state {
            State::Transparent => Mode::Transparent,
            State::EnterWaitExit
            | State::EnterFlush
            | State::EnterGuard
            | State::EnterPlus { .. }
            | State::EnterAwaitOk => Mode::Entering,
            State::Ready => Mode::Command,
            State::Sending { .. } | State::AwaitReply { .. } => Mode::Busy,
            State::Leaving => Mode::Leaving,
        }
    }

    /// Whether received bytes are still radio data (the module has not seen `+++` yet).
    fn reads_pass_through(&self) -> bool {
        matches!(
            self.state,
            State::Transparent | State::EnterFlush | State::EnterGuard
        )
    }
}

crate::blocking_and_async! {
    /// The module in transparent mode, with guarded AT command mode.
    impl<S> XBee<S, Transparent> {
        /// Wraps a serial port connected to a module in transparent mode (`AP = 0`), with the
        /// factory command-mode timing.
        pub fn new(serial: S) -> Self {
            Self::with_timing(serial, CommandTiming::default())
        }

        /// Wraps a serial port, with the module's own `GT`, `CT` and `CC`.
        pub fn with_timing(serial: S, timing: CommandTiming) -> Self {
            XBee::from_parts(serial, Transparent::new(timing))
        }

        /// The command-mode timing in use.
        pub fn timing(&self) -> CommandTiming {
            self.mode.timing
        }

        /// Where the driver believes the module is.
        pub fn mode(&self) -> Mode {
            self.mode.mode()
        }

        /// Whether data passes through right now.
        pub fn is_transparent(&self) -> bool {
            self.mode.state == State::Transparent
        }

        /// Bytes thrown away in command mode: radio data that arrived just before the module
        /// switched (before the `OK` of `+++`), late replies, overlong reply lines.
        pub fn discarded_bytes(&self) -> u32 {
            self.mode.discarded
        }

        /// Whether received bytes are still radio data (the module has not seen `+++` yet).
        fn reads_pass_through(&self) -> bool {
            self.mode.reads_pass_through()
        }
    }
}

impl<S: ErrorType> ErrorType for XBee<S, Transparent> {
    type Error = Error<S::Error>;
}

impl<S: Read<u8>> Read<u8> for XBee<S, Transparent> {
    /// Reads one received byte; `WouldBlock` while the module is in command mode.
    fn read(&mut self) -> nb::Result<u8, Self::Error> {
        if self.reads_pass_through() {
            self.serial.read().map_err(|e| e.map(Error::Comm))
        } else {
            Err(nb::Error::WouldBlock)
        }
    }
}

impl<S: Write<u8>> Write<u8> for XBee<S, Transparent> {
    /// Sends one byte; [`DeviceError::CommandModeActive`] (not sent) outside transparent mode.
    fn write(&mut self, word: u8) -> nb::Result<(), Self::Error> {
        if self.mode.state != State::Transparent {
            return Err(nb::Error::Other(Error::Device(
                DeviceError::CommandModeActive,
            )));
        }
        self.serial.write(word).map_err(|e| e.map(Error::Comm))
    }

    fn flush(&mut self) -> nb::Result<(), Self::Error> {
        self.serial.flush().map_err(|e| e.map(Error::Comm))
    }
}

#[cfg(feature = "embedded-io")]
mod io {
    //! embedded-io adapters. Their blocking contract ("wait for at least one byte") is met by
    //! retrying the serial port's `WouldBlock`, as any embedded-io wrapper of a non-blocking port
    //! must; use the embedded-hal-nb traits for non-blocking use.

    use super::XBee;
    use super::{Read, Transparent, Write};
    use crate::types::{DeviceError, Error};

    impl<S: embedded_hal_nb::serial::ErrorType> embedded_io::ErrorType for XBee<S, Transparent> {
        type Error = Error<S::Error>;
    }

    impl<S: Read<u8>> embedded_io::Read for XBee<S, Transparent> {
        /// Blocks until one byte arrives, then returns it with any that are already waiting.
        /// Outside transparent mode it returns [`DeviceError::CommandModeActive`] instead of blocking.
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
            let Some((first, rest)) = buf.split_first_mut() else {
                return Ok(0);
            };
            *first = loop {
                if !self.reads_pass_through() {
                    return Err(Error::Device(DeviceError::CommandModeActive));
                }
                match self.serial.read() {
                    Ok(b) => break b,
                    Err(nb::Error::WouldBlock) => continue,
                    Err(nb::Error::Other(e)) => return Err(Error::Comm(e)),
                }
            };
            let mut n = 1;
            for slot in rest {
                match self.serial.read() {
                    Ok(b) => {
                        *slot = b;
                        n += 1;
                    }
                    Err(nb::Error::WouldBlock) => break,
                    Err(nb::Error::Other(e)) => return Err(Error::Comm(e)),
                }
            }
            Ok(n)
        }
    }

    impl<S: Write<u8>> embedded_io::Write for XBee<S, Transparent> {
        /// Sends the whole buffer; [`DeviceError::CommandModeActive`] outside transparent mode.
        fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
            for &b in buf {
                nb::block!(Write::write(self, b))?;
            }
            Ok(buf.len())
        }

        fn flush(&mut self) -> Result<(), Self::Error> {
            nb::block!(Write::flush(self))
        }
    }
}
