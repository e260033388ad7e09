//! Transparent mode over an embedded-io-async port (feature `async`): the byte pipe
//! (`embedded_io_async::{Read, Write}` for `XBeeAsync<S, Transparent>`) and AT command mode with
//! the guard times awaited on an embedded-hal-async `DelayNs`.
//!
//! The async session is straight-line code instead of the polled state machine of the blocking
//! driver, but keeps the same state, so [`XBeeAsync::mode`] and the guard on data mean the same:
//! reply lines, their judgement, and the `CT` window are the shared bookkeeping of
//! [`Transparent`].
//!
//! Time is counted on two clocks, both from the delay. The time surely waited (completed
//! delays only) stamps every command-mode input and decides when data may flow again: `CT`
//! plus the reply timeout must have passed on it. The time that may have passed (every raced
//! wait at its full length, even when the reply came first) stamps the start of each command
//! the module accepted and decides whether the next one still reaches the module before `CT`.
//! As in the blocking driver, that window is halved because a delay may run long, and calls on
//! a session must follow each other without long pauses (time between them is not counted).

use embedded_hal_async::delay::DelayNs;
use embedded_io_async::{ErrorType, Read, Write};

use super::{ReplyEnd, State, Transparent};
use crate::at::{format_line, is_ok, AtCommand, AtRequest, MAX_LINE_LEN};
use crate::settings;
use crate::types::{DeviceError, Error};
use crate::xbee::io_async::{read_byte, take_pending, within, write_all, Raced};
use crate::xbee::XBeeAsync;

impl<S: ErrorType> ErrorType for XBeeAsync<S, Transparent> {
    type Error = Error<S::Error>;
}

impl<S: Read> Read for XBeeAsync<S, Transparent> {
    /// Waits for received bytes. Outside transparent mode the incoming bytes are the module's
    /// replies: [`DeviceError::CommandModeActive`] instead of waiting. Cancel-safe if the port's
    /// `read` is.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        if !self.reads_pass_through() {
            return Err(Error::Device(DeviceError::CommandModeActive));
        }
        self.serial.read(buf).await.map_err(Error::Comm)
    }
}

impl<S: Write> Write for XBeeAsync<S, Transparent> {
    /// Sends bytes; [`DeviceError::CommandModeActive`] (nothing sent) while the module is, or
    /// may still be, in command mode. A port that takes none of a non-empty buffer (`Ok(0)`)
    /// is [`DeviceError::Timeout`], so `write_all` reports it instead of panicking.
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        if self.mode.state != State::Transparent {
            return Err(Error::Device(DeviceError::CommandModeActive));
        }
        match self.serial.write(buf).await {
            Ok(0) if !buf.is_empty() => Err(Error::Device(DeviceError::Timeout)),
            Ok(n) => Ok(n),
            Err(e) => Err(Error::Comm(e)),
        }
    }

    async fn flush(&mut self) -> Result<(), Self::Error> {
        self.serial.flush().await.map_err(Error::Comm)
    }
}

/// Reads into the line buffer until a `\r` ends the line. Every byte read is in the buffer
/// before the next read starts, so a dropped call loses nothing it read.
async fn read_line<T: Read>(io: &mut T, mode: &mut Transparent) -> Result<(), Error<T::Error>> {
    while !mode.push_line_byte(read_byte(io).await?) {}
    Ok(())
}

/// Reads lines until the `OK` of `+++`; lines before it are radio data that arrived before the
/// module switched, counted as discarded.
async fn read_until_ok<T: Read>(io: &mut T, mode: &mut Transparent) -> Result<(), Error<T::Error>> {
    loop {
        read_line(io, mode).await?;
        if mode.line_is_ok() {
            return Ok(());
        }
        mode.count_discarded(mode.line().len() + 1);
        mode.clear_line();
    }
}

impl<S> XBeeAsync<S, Transparent> {
    /// Time surely waited (completed delays), in ms.
    fn waited_ms(&self) -> u32 {
        (self.mode.clock_us / 1000) as u32
    }

    /// Time that may have passed, in ms: ahead of [`waited_ms`](Self::waited_ms) by every raced
    /// wait that ended early.
    fn bound_ms(&self) -> u32 {
        (self.mode.bound_us / 1000) as u32
    }

    /// Counts a wait on both clocks: `waited_ms` surely passed, `bound_ms` may have.
    fn count_wait(&mut self, waited_ms: u32, bound_ms: u32) {
        let us = |ms: u32| u64::from(ms) * 1000;
        self.mode.clock_us = self.mode.clock_us.wrapping_add(us(waited_ms));
        self.mode.bound_us = self.mode.bound_us.wrapping_add(us(bound_ms));
    }

    async fn sleep<D: DelayNs>(&mut self, delay: &mut D, ms: u32) {
        delay.delay_ms(ms).await;
        self.count_wait(ms, ms);
    }

    /// Counts a raced wait (see [`within`]) and gives its outcome: running out of time is
    /// [`DeviceError::Timeout`].
    fn settle<T, E>(&mut self, raced: Raced<Result<T, Error<E>>>) -> Result<T, Error<E>> {
        self.count_wait(raced.waited_ms, raced.bound_ms);
        raced
            .output
            .unwrap_or(Err(Error::Device(DeviceError::Timeout)))
    }

    /// Sleeps until `CT` has surely run out since the last command-mode input.
    async fn wait_out_command_timeout<D: DelayNs>(&mut self, delay: &mut D) {
        let since = self.waited_ms().wrapping_sub(self.mode.input_ms);
        let rest = self.mode.leave_after_ms().saturating_sub(since);
        if rest > 0 {
            self.sleep(delay, rest).await;
        }
    }

    fn fall_back<T, E>(&mut self, state: State, error: Error<E>) -> Result<T, Error<E>> {
        self.mode.go(state);
        Err(error)
    }

    /// Waits until data may flow again: if the module may still be in command mode (a session
    /// dropped without [`exit`](AsyncCommandSession::exit), a failed entry or `ATCN`, an
    /// operation whose future was dropped), until `CT` plus the reply timeout have surely passed
    /// since the last command-mode input (11 s by default), counted on `delay`.
    pub async fn wait_until_transparent<D: DelayNs>(&mut self, delay: &mut D) {
        match self.mode.state {
            State::Transparent => return,
            // Nothing of the command sequence has gone out.
            State::EnterFlush | State::EnterGuard => {}
            _ => {
                self.mode.go(State::Leaving);
                self.wait_out_command_timeout(delay).await;
            }
        }
        self.mode.clear_line();
        self.mode.go(State::Transparent);
    }
}

impl<S: Read + Write> XBeeAsync<S, Transparent> {
    /// Enters command mode: flush, `GT` (plus the margin) of silence awaited on `delay`, `+++`,
    /// then the module's `OK` within `GT` plus the reply timeout (about two guard times, 2 s by
    /// default). From the start, writes to the pipe are refused.
    ///
    /// If entering fails, the module may still have switched: data stays refused until
    /// [`wait_until_transparent`](Self::wait_until_transparent) returns. If the module is still
    /// in command mode from a session dropped without `exit` and well within `CT`, the session
    /// opens at once.
    pub async fn command_mode<'a, D: DelayNs>(
        &'a mut self,
        delay: &'a mut D,
    ) -> Result<AsyncCommandSession<'a, S, D>, Error<S::Error>> {
        self.enter(delay).await?;
        Ok(AsyncCommandSession { xbee: self, delay })
    }

    async fn enter<D: DelayNs>(&mut self, delay: &mut D) -> Result<(), Error<S::Error>> {
        // Time here is counted from delays, which may run long: halve the `CT` window.
        self.mode.delay_clock = true;
        match self.mode.state {
            State::Transparent => {}
            State::Ready if self.mode.fresh(self.bound_ms()) => return Ok(()),
            State::Ready => {
                self.mode.go(State::EnterWaitExit);
                self.wait_out_command_timeout(delay).await;
            }
            _ => return Err(Error::Device(DeviceError::Busy)),
        }
        let timing = self.mode.timing;
        self.mode.go(State::EnterFlush);
        let flushed = within(delay, timing.reply_timeout_ms, async {
            self.serial.flush().await.map_err(Error::Comm)
        })
        .await;
        if let Err(e) = self.settle(flushed) {
            // Nothing of the command sequence went out: still transparent.
            return self.fall_back(State::Transparent, e);
        }
        self.mode.go(State::EnterGuard);
        let silence = timing.guard_time_ms.saturating_add(timing.guard_margin_ms);
        self.sleep(delay, silence).await;

        // From the first character on, the module may switch: cautious until `CT` has passed.
        self.mode.go(State::EnterPlus { sent: 0 });
        self.mode.input_ms = self.waited_ms();
        self.mode.confirmed_ms = None;
        let sent_at = self.bound_ms();
        let sequence = [timing.command_character; 3];
        let sent = within(
            delay,
            timing.reply_timeout_ms,
            write_all(&mut self.serial, &sequence),
        )
        .await;
        if let Err(e) = self.settle(sent) {
            self.mode.input_ms = self.waited_ms();
            return self.fall_back(State::Ready, e);
        }
        self.mode.input_ms = self.waited_ms();
        self.mode.clear_line();
        self.mode.go(State::EnterAwaitOk);

        // The module answers after its own guard time of silence.
        let deadline = timing.guard_time_ms.saturating_add(timing.reply_timeout_ms);
        let answered = within(
            delay,
            deadline,
            read_until_ok(&mut self.serial, &mut self.mode),
        )
        .await;
        match self.settle(answered) {
            Ok(()) => {
                self.mode.confirmed_ms = Some(sent_at);
                self.mode.go(State::Ready);
                Ok(())
            }
            Err(e) => {
                self.mode.count_discarded(self.mode.line().len());
                self.mode.clear_line();
                // The module may have switched without being heard.
                self.fall_back(State::Ready, e)
            }
        }
    }

    /// Sends one command line and awaits its reply line; `exit` for `ATCN`.
    async fn command<D: DelayNs>(
        &mut self,
        delay: &mut D,
        request: &AtRequest<'_>,
        exit: bool,
    ) -> Result<ReplyEnd, Error<S::Error>> {
        match self.mode.state {
            State::Ready => {}
            State::Transparent => return Err(Error::Device(DeviceError::NotInCommandMode)),
            _ => return Err(Error::Device(DeviceError::Busy)),
        }
        self.mode.clear_line();
        let Some(len) = format_line(request, &mut self.mode.line) else {
            self.mode.clear_line();
            return Err(Error::Device(DeviceError::InvalidInput));
        };
        if !self.mode.fresh(self.bound_ms()) {
            // The line might reach a module that has left: it would be radio data.
            self.mode.clear_line();
            if !exit {
                return Err(Error::Device(DeviceError::NotInCommandMode));
            }
            self.mode.go(State::Leaving);
            self.wait_out_command_timeout(delay).await;
            self.mode.go(State::Transparent);
            return Ok(ReplyEnd::Exited);
        }
        if self.mode.stale_input {
            // A late reply to a timed-out command must not be taken for this one's.
            self.mode.stale_input = false;
            for _ in 0..2 * MAX_LINE_LEN {
                match take_pending(&mut self.serial).await {
                    Ok(Some(_)) => self.mode.count_discarded(1),
                    Ok(None) => break,
                    Err(e) => {
                        self.mode.clear_line();
                        return Err(e);
                    }
                }
            }
        }

        let timeout = self.mode.timing.reply_timeout_ms;
        self.mode.go(State::Sending { pos: 0, exit });
        // Once part of the line is out the module's `CT` timer may restart.
        self.mode.input_ms = self.waited_ms();
        let sent_at = self.bound_ms();
        let line = self.mode.line.get(..len).unwrap_or_default();
        let sent = within(delay, timeout, write_all(&mut self.serial, line)).await;
        let sent = self.settle(sent);
        self.mode.clear_line();
        self.mode.input_ms = self.waited_ms();
        if let Err(e) = sent {
            return self.fall_back(State::Ready, e);
        }

        self.mode.go(State::AwaitReply { exit });
        let replied = within(delay, timeout, read_line(&mut self.serial, &mut self.mode)).await;
        match self.settle(replied) {
            Ok(()) => self.mode.end_reply(exit, sent_at).map_err(Error::Device),
            Err(e) => {
                // A late answer must not be taken for the next command's reply.
                self.mode.stale_input = true;
                self.fall_back(State::Ready, e)
            }
        }
    }
}

/// An open command-mode session over an async port. Obtained from
/// [`XBeeAsync::command_mode`].
///
/// Leave with [`exit`](Self::exit)`.await`. A session cannot leave by itself when it is dropped
/// (an async drop does not exist): the module then stays in command mode until its `CT` runs
/// out, and the driver keeps refusing data with [`DeviceError::CommandModeActive`] until
/// [`XBeeAsync::wait_until_transparent`] has waited that out (or a new session is left with
/// `exit`). The same holds when a call's future is dropped before it completes; the session's
/// further calls are then refused with [`DeviceError::Busy`], since the module may or may not
/// have seen that command.
///
/// Settings are changed and read with the request builders and reply parsers of [`settings`]
/// (the same the blocking session's helpers use), e.g.
/// `session.set(&settings::set_pan_id(0x1234)).await` and
/// `session.query(AtCommand::CH, settings::parse_channel).await`.
pub struct AsyncCommandSession<'a, S, D> {
    xbee: &'a mut XBeeAsync<S, Transparent>,
    delay: &'a mut D,
}

impl<S: Read + Write, D: DelayNs> AsyncCommandSession<'_, S, D> {
    /// Sends any AT command and returns the reply line (without `\r`). `ATCN` leaves command
    /// mode and then reports [`DeviceError::InvalidReply`], as in the blocking session: use
    /// [`exit`](Self::exit).
    pub async fn send(&mut self, request: &AtRequest<'_>) -> Result<&[u8], Error<S::Error>> {
        let exit = *request == AtRequest::query(AtCommand::CN);
        match self.xbee.command(self.delay, request, exit).await? {
            ReplyEnd::Reply => Ok(self.xbee.mode.line()),
            ReplyEnd::Exited => Err(Error::Device(DeviceError::InvalidReply)),
        }
    }

    /// Sends a command that must be answered `OK` (a setting, `WR`, `AC`).
    pub async fn set(&mut self, request: &AtRequest<'_>) -> Result<(), Error<S::Error>> {
        let reply = self.send(request).await?;
        is_ok(reply)
            .then_some(())
            .ok_or(Error::Device(DeviceError::InvalidReply))
    }

    /// Queries a setting and reads the reply with `parse`, one of the parsers of [`settings`]
    /// (e.g. `session.query(AtCommand::CH, settings::parse_channel).await`); a reply it does
    /// not accept is [`DeviceError::InvalidReply`].
    pub async fn query<T>(
        &mut self,
        command: AtCommand,
        parse: fn(&[u8]) -> Option<T>,
    ) -> Result<T, Error<S::Error>> {
        let reply = self.send(&AtRequest::query(command)).await?;
        parse(reply).ok_or(Error::Device(DeviceError::InvalidReply))
    }

    /// Queries a numeric setting (the module answers in hexadecimal).
    pub async fn query_number(&mut self, command: AtCommand) -> Result<u64, Error<S::Error>> {
        self.query(command, settings::parse_number).await
    }

    /// Leaves command mode (`ATCN`); data passes again afterwards. If `CT` is too close for
    /// `ATCN`, it waits until the module has surely left instead. On an error the module may
    /// still be in command mode: data stays refused until
    /// [`XBeeAsync::wait_until_transparent`] returns.
    pub async fn exit(self) -> Result<(), Error<S::Error>> {
        let request = AtRequest::query(AtCommand::CN);
        match self.xbee.command(self.delay, &request, true).await? {
            ReplyEnd::Exited => Ok(()),
            ReplyEnd::Reply => Err(Error::Device(DeviceError::InvalidReply)),
        }
    }
}
