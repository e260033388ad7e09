//! AT command mode as a state machine driven by the caller's clock.
//!
//! Entering: flush, `GT` (plus a small margin) of silence, `+++` (the `CC` character three times), `GT` of silence
//! on the module's side, then `OK\r`. Each command is `AT<cmd><param>\r`, answered by one
//! line: a value, `OK` or `ERROR`. `ATCN` leaves; the module also leaves by itself `CT` after
//! the last valid command, and the driver tracks that deadline on both sides: it never sends
//! a command that might arrive after the module has left (it would be radio data), and never
//! sends data while the module might still be listening for commands.

use embedded_hal_nb::serial::{Read, Write};

use super::{State, Transparent};
use crate::at::{format_line, is_error, is_ok, AtCommand, AtRequest};
use crate::types::{DeviceError, Error};
use crate::xbee::XBee;

/// `None`: the state changed, evaluate the new one in the same poll. `Some`: the poll's result.
type Step<E> = Option<nb::Result<CommandOutcome, Error<E>>>;

/// What a completed [`XBee::poll`] reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandOutcome {
    /// Nothing in progress (transparent mode, or command mode waiting for a command).
    Idle,
    /// The module answered `OK` to `+++`: command mode is open.
    Entered,
    /// The module answered the command; the line is in [`XBee::reply`].
    Reply,
    /// The module is back in transparent mode after `ATCN` (or after `CT` ran out while
    /// leaving).
    Exited,
    /// The module left command mode by itself (`CT` ran out); data passes again.
    AutoExited,
}

impl<S, E> XBee<S, Transparent>
where
    S: Read<u8, Error = E> + Write<u8, Error = E>,
{
    /// Starts entering command mode; then [`poll`](Self::poll) until it returns
    /// [`CommandOutcome::Entered`] (about two guard times) or an error.
    ///
    /// From this call on, writes are refused. If the module is already in command mode and
    /// well within `CT`, the next poll reports `Entered` at once; if it may be about to leave,
    /// the driver first waits until it surely has.
    pub fn start_command_mode(&mut self) -> Result<(), Error<E>> {
        match self.mode.state {
            State::Transparent => self.go(State::EnterFlush),
            State::Ready => self.go(State::EnterWaitExit),
            _ => return Err(Error::Device(DeviceError::Busy)),
        }
        Ok(())
    }

    /// Starts an AT command; then [`poll`](Self::poll) until it returns
    /// [`CommandOutcome::Reply`] or an error.
    ///
    /// Commands whose reply spans several lines (`ND`, `AS`) are not supported. A plain `CN`
    /// is the same as [`start_exit`](Self::start_exit) (its poll ends with
    /// [`CommandOutcome::Exited`]).
    pub fn start_command(&mut self, request: &AtRequest<'_>) -> Result<(), Error<E>> {
        if *request == AtRequest::query(AtCommand::CN) {
            return self.start_exit();
        }
        match self.mode.state {
            State::Ready => {}
            State::Transparent => return Err(Error::Device(DeviceError::NotInCommandMode)),
            _ => return Err(Error::Device(DeviceError::Busy)),
        }
        self.clear_line();
        let Some(n) = format_line(request, &mut self.mode.line) else {
            self.clear_line();
            return Err(Error::Device(DeviceError::InvalidInput));
        };
        self.mode.line_len = n;
        self.go(State::Sending {
            pos: 0,
            exit: false,
        });
        Ok(())
    }

    /// Starts leaving command mode with `ATCN`; then [`poll`](Self::poll) until it returns
    /// [`CommandOutcome::Exited`].
    pub fn start_exit(&mut self) -> Result<(), Error<E>> {
        match self.mode.state {
            State::Ready => {}
            State::Transparent => return Err(Error::Device(DeviceError::NotInCommandMode)),
            _ => return Err(Error::Device(DeviceError::Busy)),
        }
        self.clear_line();
        let n = format_line(&AtRequest::query(AtCommand::CN), &mut self.mode.line)
            .ok_or(Error::Device(DeviceError::InvalidInput))?;
        self.mode.line_len = n;
        self.go(State::Sending { pos: 0, exit: true });
        Ok(())
    }

    /// The last reply line, without its `\r` (valid after [`CommandOutcome::Reply`] and
    /// [`DeviceError::AtError`]).
    pub fn reply(&self) -> &[u8] {
        match self.mode.state {
            State::Sending { .. } => &[],
            _ => self.mode.line.get(..self.mode.line_len).unwrap_or_default(),
        }
    }

    /// Advances command mode. `now_ms` is the caller's monotonic clock in milliseconds; it may
    /// wrap around. Returns `WouldBlock` while an operation is in progress.
    ///
    /// Every waiting state has a deadline, so polling always ends. Call it at least every few
    /// milliseconds while an operation is in progress (each call reads what has arrived), and
    /// now and then while in command mode so that a `CT` expiry is noticed.
    pub fn poll(&mut self, now_ms: u32) -> nb::Result<CommandOutcome, Error<E>> {
        self.mode.delay_clock = false;
        self.advance(now_ms)
    }

    /// [`poll`](Self::poll) on the blocking API's clock, which is counted from delays.
    pub(crate) fn poll_delay_clock(&mut self, now_ms: u32) -> nb::Result<CommandOutcome, Error<E>> {
        self.mode.delay_clock = true;
        self.advance(now_ms)
    }

    fn advance(&mut self, now_ms: u32) -> nb::Result<CommandOutcome, Error<E>> {
        loop {
            let since = *self.mode.state_since.get_or_insert(now_ms);
            let elapsed = now_ms.wrapping_sub(since);
            let step = match self.mode.state {
                State::Transparent => Some(Ok(CommandOutcome::Idle)),
                State::Ready => Some(self.step_ready(now_ms)),
                State::Leaving => Some(self.step_leaving(now_ms)),
                State::EnterWaitExit => self.step_wait_exit(now_ms),
                State::EnterFlush => self.step_flush(elapsed),
                State::EnterGuard => self.step_guard(elapsed),
                State::EnterPlus { sent } => self.step_plus(sent, now_ms, elapsed),
                State::EnterAwaitOk => Some(self.step_await_ok(elapsed)),
                State::Sending { pos, exit } => self.step_sending(pos, exit, now_ms, elapsed),
                State::AwaitReply { exit } => Some(self.step_await_reply(exit, elapsed)),
            };
            if let Some(result) = step {
                return result;
            }
        }
    }

    // Each step returns `None` after a state change to be evaluated in the same poll, or the
    // poll's result.

    fn step_ready(&mut self, now_ms: u32) -> nb::Result<CommandOutcome, Error<E>> {
        if self.surely_left(now_ms) {
            self.go(State::Transparent);
            return Ok(CommandOutcome::AutoExited);
        }
        Ok(CommandOutcome::Idle)
    }

    fn step_leaving(&mut self, now_ms: u32) -> nb::Result<CommandOutcome, Error<E>> {
        if self.surely_left(now_ms) {
            self.go(State::Transparent);
            return Ok(CommandOutcome::Exited);
        }
        Err(nb::Error::WouldBlock)
    }

    fn step_wait_exit(&mut self, now_ms: u32) -> Step<E> {
        if self.fresh(now_ms) {
            self.go(State::Ready);
            return Some(Ok(CommandOutcome::Entered));
        }
        if !self.surely_left(now_ms) {
            return Some(Err(nb::Error::WouldBlock));
        }
        self.go(State::EnterFlush);
        None
    }

    fn step_flush(&mut self, elapsed: u32) -> Step<E> {
        match self.serial.flush() {
            Ok(()) => {
                self.go(State::EnterGuard);
                None
            }
            Err(nb::Error::WouldBlock) if elapsed < self.mode.timing.reply_timeout_ms => {
                Some(Err(nb::Error::WouldBlock))
            }
            // Nothing of the command sequence went out: still transparent.
            Err(nb::Error::WouldBlock) => {
                Some(self.fail(State::Transparent, Error::Device(DeviceError::Timeout)))
            }
            Err(nb::Error::Other(e)) => Some(self.fail(State::Transparent, Error::Comm(e))),
        }
    }

    fn step_guard(&mut self, elapsed: u32) -> Step<E> {
        let silence = self
            .mode
            .timing
            .guard_time_ms
            .saturating_add(self.mode.timing.guard_margin_ms);
        if elapsed < silence {
            return Some(Err(nb::Error::WouldBlock));
        }
        self.go(State::EnterPlus { sent: 0 });
        None
    }

    fn step_plus(&mut self, sent: u8, now_ms: u32, elapsed: u32) -> Step<E> {
        if sent >= 3 {
            self.mode.input_ms = now_ms;
            self.mode.confirmed_ms = None;
            self.clear_line();
            self.go(State::EnterAwaitOk);
            return None;
        }
        let error = match self.serial.write(self.mode.timing.command_character) {
            Ok(()) => {
                // Same state, same deadline: the three characters must go out together.
                self.mode.state = State::EnterPlus { sent: sent + 1 };
                return None;
            }
            Err(nb::Error::WouldBlock) if elapsed < self.mode.timing.reply_timeout_ms => {
                return Some(Err(nb::Error::WouldBlock))
            }
            Err(nb::Error::WouldBlock) => Error::Device(DeviceError::Timeout),
            Err(nb::Error::Other(e)) => Error::Comm(e),
        };
        // Part of `+++` may be out: stay cautious until `CT` has passed.
        self.mode.input_ms = now_ms;
        self.mode.confirmed_ms = None;
        Some(self.fail(State::Ready, error))
    }

    fn step_await_ok(&mut self, elapsed: u32) -> nb::Result<CommandOutcome, Error<E>> {
        loop {
            match self.read_line() {
                Ok(Some(())) if self.mode.line_is_ok() => {
                    self.mode.confirmed_ms = Some(self.mode.input_ms);
                    self.go(State::Ready);
                    return Ok(CommandOutcome::Entered);
                }
                Ok(Some(())) => {
                    // Radio data that arrived before the switch.
                    self.count_discarded(self.mode.line_len + 1);
                    self.clear_line();
                }
                Ok(None) => break,
                Err(e) => return self.fail(State::Ready, Error::Comm(e)),
            }
        }
        let deadline = self
            .mode
            .timing
            .guard_time_ms
            .saturating_add(self.mode.timing.reply_timeout_ms);
        if elapsed >= deadline {
            self.count_discarded(self.mode.line_len);
            self.clear_line();
            // The module may have switched without us hearing the `OK`.
            return self.fail(State::Ready, Error::Device(DeviceError::Timeout));
        }
        Err(nb::Error::WouldBlock)
    }

    fn step_sending(&mut self, pos: usize, exit: bool, now_ms: u32, elapsed: u32) -> Step<E> {
        if pos == 0 {
            if !self.fresh(now_ms) {
                self.clear_line();
                if exit {
                    self.go(State::Leaving);
                    return None;
                }
                return Some(self.fail(State::Ready, Error::Device(DeviceError::NotInCommandMode)));
            }
            if self.mode.stale_input {
                if let Err(e) = self.drain() {
                    self.clear_line();
                    return Some(self.fail(State::Ready, Error::Comm(e)));
                }
            }
        }
        let Some(&byte) = self
            .mode
            .line
            .get(..self.mode.line_len)
            .and_then(|l| l.get(pos))
        else {
            self.mode.input_ms = now_ms;
            self.clear_line();
            self.go(State::AwaitReply { exit });
            return None;
        };
        let error = match self.serial.write(byte) {
            Ok(()) => {
                self.mode.state = State::Sending { pos: pos + 1, exit };
                return None;
            }
            Err(nb::Error::WouldBlock) if elapsed < self.mode.timing.reply_timeout_ms => {
                return Some(Err(nb::Error::WouldBlock))
            }
            Err(nb::Error::WouldBlock) => Error::Device(DeviceError::Timeout),
            Err(nb::Error::Other(e)) => Error::Comm(e),
        };
        if pos > 0 {
            // Part of the line is out: the module's `CT` timer may have restarted.
            self.mode.input_ms = now_ms;
        }
        self.clear_line();
        Some(self.fail(State::Ready, error))
    }

    fn step_await_reply(
        &mut self,
        exit: bool,
        elapsed: u32,
    ) -> nb::Result<CommandOutcome, Error<E>> {
        match self.read_line() {
            Ok(Some(())) => return self.finish_reply(exit),
            Ok(None) => {}
            Err(e) => return self.fail(State::Ready, Error::Comm(e)),
        }
        if elapsed >= self.mode.timing.reply_timeout_ms {
            // A late answer must not be taken for the next command's reply.
            self.mode.stale_input = true;
            return self.fail(State::Ready, Error::Device(DeviceError::Timeout));
        }
        Err(nb::Error::WouldBlock)
    }

    fn finish_reply(&mut self, exit: bool) -> nb::Result<CommandOutcome, Error<E>> {
        let sent_at = self.mode.input_ms;
        match self.mode.end_reply(exit, sent_at) {
            Ok(ReplyEnd::Exited) => Ok(CommandOutcome::Exited),
            Ok(ReplyEnd::Reply) => Ok(CommandOutcome::Reply),
            Err(e) => Err(nb::Error::Other(Error::Device(e))),
        }
    }

    /// Throws away whatever has arrived (a late reply after a timeout).
    fn drain(&mut self) -> Result<(), E> {
        self.mode.stale_input = false;
        // Bounded: a late reply is one short line, not a stream.
        for _ in 0..2 * crate::at::MAX_LINE_LEN {
            match self.serial.read() {
                Ok(_) => self.count_discarded(1),
                Err(nb::Error::WouldBlock) => return Ok(()),
                Err(nb::Error::Other(e)) => return Err(e),
            }
        }
        Ok(())
    }

    /// Reads what has arrived into the line buffer; `Some` when a `\r` ended the line.
    fn read_line(&mut self) -> Result<Option<()>, E> {
        loop {
            match self.serial.read() {
                Ok(byte) => {
                    if self.mode.push_line_byte(byte) {
                        return Ok(Some(()));
                    }
                }
                Err(nb::Error::WouldBlock) => return Ok(None),
                Err(nb::Error::Other(e)) => return Err(e),
            }
        }
    }
}

impl<S> XBee<S, Transparent> {
    pub(crate) fn go(&mut self, state: State) {
        self.mode.go(state);
    }

    fn fail<T, E>(&mut self, state: State, error: Error<E>) -> nb::Result<T, Error<E>> {
        self.go(state);
        Err(nb::Error::Other(error))
    }

    pub(crate) fn clear_line(&mut self) {
        self.mode.clear_line();
    }

    fn count_discarded(&mut self, n: usize) {
        self.mode.count_discarded(n);
    }

    fn fresh(&self, now_ms: u32) -> bool {
        self.mode.fresh(now_ms)
    }

    fn surely_left(&self, now_ms: u32) -> bool {
        self.mode.surely_left(now_ms)
    }
}

/// How a command's reply line ended the command, when it was not an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ReplyEnd {
    /// A reply to a command: back to [`State::Ready`].
    Reply,
    /// `OK` to `ATCN`: back to [`State::Transparent`].
    Exited,
}

/// The command-mode bookkeeping both drivers share: the state, the clocks' stamps, the line
/// buffer. Pure: no I/O, no waiting.
impl Transparent {
    pub(crate) fn go(&mut self, state: State) {
        self.state = state;
        self.state_since = None;
    }

    /// Zeroes the line buffer, so a key sent with `KY` does not linger in memory.
    pub(crate) fn clear_line(&mut self) {
        self.line = [0; crate::at::MAX_LINE_LEN];
        self.line_len = 0;
        self.line_overflow = false;
    }

    pub(crate) fn count_discarded(&mut self, n: usize) {
        let n = u32::try_from(n).unwrap_or(u32::MAX);
        self.discarded = self.discarded.saturating_add(n);
    }

    /// Adds a received byte to the reply line; `true` when a `\r` ended the line. `\n` is
    /// ignored; bytes beyond the buffer are counted and mark the line as overlong.
    pub(crate) fn push_line_byte(&mut self, byte: u8) -> bool {
        match byte {
            b'\r' => return true,
            b'\n' => {}
            _ => match self.line.get_mut(self.line_len) {
                Some(slot) => {
                    *slot = byte;
                    self.line_len += 1;
                }
                None => {
                    self.line_overflow = true;
                    self.count_discarded(1);
                }
            },
        }
        false
    }

    /// The reply line received so far, without its `\r`.
    pub(crate) fn line(&self) -> &[u8] {
        self.line.get(..self.line_len).unwrap_or_default()
    }

    /// Whether the completed line is the `OK` that opens command mode.
    pub(crate) fn line_is_ok(&self) -> bool {
        is_ok(self.line()) && !self.line_overflow
    }

    /// Judges a command's completed reply line and moves on: an overlong line is
    /// [`DeviceError::InvalidReply`], `ERROR` is [`DeviceError::AtError`] (both back to
    /// [`State::Ready`]); otherwise the module accepted the command, sent at `sent_at` on the
    /// clock [`fresh`](Self::fresh) is asked with (its `CT` restarted then), and for `ATCN`
    /// anything but `OK` is [`DeviceError::InvalidReply`].
    pub(crate) fn end_reply(&mut self, exit: bool, sent_at: u32) -> Result<ReplyEnd, DeviceError> {
        let judged = if self.line_overflow {
            Err(DeviceError::InvalidReply)
        } else if is_error(self.line()) {
            Err(DeviceError::AtError)
        } else {
            self.confirmed_ms = Some(sent_at);
            match (exit, is_ok(self.line())) {
                (false, _) => Ok(ReplyEnd::Reply),
                (true, true) => Ok(ReplyEnd::Exited),
                (true, false) => Err(DeviceError::InvalidReply),
            }
        };
        self.go(match judged {
            Ok(ReplyEnd::Exited) => State::Transparent,
            _ => State::Ready,
        });
        judged
    }

    /// The module accepted a command recently enough that another one arrives before `CT`.
    ///
    /// On a clock counted from delays the window is halved: a `DelayNs` sleeps at least as long
    /// as asked, often longer, so that clock runs slow, and here that errs on the unsafe side.
    /// Halving allows the delays to take up to twice their nominal time.
    pub(crate) fn fresh(&self, now_ms: u32) -> bool {
        let mut limit = self
            .timing
            .command_timeout_ms
            .saturating_sub(self.timing.reply_timeout_ms);
        if self.delay_clock {
            limit /= 2;
        }
        self.confirmed_ms
            .is_some_and(|t| now_ms.wrapping_sub(t) < limit)
    }

    /// How long after the last command-mode input the module has surely left command mode:
    /// `CT` plus the reply timeout.
    pub(crate) fn leave_after_ms(&self) -> u32 {
        self.timing
            .command_timeout_ms
            .saturating_add(self.timing.reply_timeout_ms)
    }

    /// `CT` has surely run out since the last command-mode input.
    pub(crate) fn surely_left(&self, now_ms: u32) -> bool {
        now_ms.wrapping_sub(self.input_ms) >= self.leave_after_ms()
    }
}
