//! What only the async driver does (feature `async`): waiting for bytes on an
//! `embedded-io-async` 0.7 port and racing each answer against an embedded-hal-async `DelayNs`.
//!
//! The driver type and its accessors are generated from the blocking source (see `driver.rs`);
//! the framer, the message classification, the configuration plan (which command each step
//! sends, what comes next) and the judgement of each answer are the same plain functions the
//! blocking driver and [`Configurator`](crate::Configurator) use. Only the waiting is here.
//!
//! **Cancel safety.** Bytes are read one at a time and pushed into the framer before the next
//! `.await`, so a read future dropped at any point (by a `select`, a timeout) has consumed no
//! byte that is not already in the framer; a dropped [`NeoM8tAsync::read_message`] loses nothing,
//! the next call goes on with the same partial frame. A dropped configuration or command
//! exchange loses only its own progress (start it again).

use core::future::{poll_fn, Future};
use core::pin::pin;
use core::task::Poll;

use embedded_hal_async::delay::DelayNs;
use embedded_io_async::{Read, Write};

use crate::commands::{self, Command, CLASS_CFG, ID_CFG_PRT};
use crate::config::Config;
use crate::configure::{
    judge, next_step, step_command, Judgement, Phase, Step, DEFAULT_RETRIES,
    DEFAULT_SWITCH_SETTLE_MS, DEFAULT_TIMEOUT_MS,
};
use crate::driver::NeoM8tAsync;
use crate::error::{DeviceError, Error};
use crate::frame::UbxFramer;
use crate::nav_pvt::NavPvtFrame;
use crate::stream::Message;
use crate::version::ReceiverVersion;

/// Class and id named by a timeout while no command is outstanding: the stream waits for
/// NAV-PVT.
const NAV_PVT: (u8, u8) = (0x01, 0x07);

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

fn timeout<E>((class, id): (u8, u8)) -> Error<E> {
    Error::Device(DeviceError::Timeout { class, id })
}

/// What an exchange with the receiver ended in, short of an error.
enum Answer {
    /// The step is settled (ACK-ACK, the polled answer, or any frame after a port change).
    Settled,
    /// Nothing before the deadline.
    Silence,
}

impl<T, const N: usize> NeoM8tAsync<T, N>
where
    T: Read + Write,
{
    /// Waits for one byte. `Ok(0)` (end of stream: nothing will come) is a timeout naming
    /// `waiting_for`; a read error drops the partial frame, counts as a line error and is
    /// returned as [`Error::Comm`].
    async fn next_byte(&mut self, waiting_for: (u8, u8)) -> Result<u8, Error<T::Error>> {
        let mut byte = [0u8; 1];
        match self.serial_mut().read(&mut byte).await {
            Ok(0) => Err(timeout(waiting_for)),
            Ok(_) => Ok(byte[0]),
            Err(e) => {
                self.note_line_error();
                Err(Error::Comm(e))
            }
        }
    }

    /// Writes all of `command`; a port that takes nothing (`write` returning `Ok(0)`) is a
    /// timeout naming `command`, never a panic.
    async fn write_command(&mut self, command: &Command) -> Result<(), Error<T::Error>> {
        let mut bytes = command.as_bytes();
        while !bytes.is_empty() {
            let written = self.serial_mut().write(bytes).await.map_err(Error::Comm)?;
            if written == 0 {
                return Err(timeout((command.class(), command.id())));
            }
            bytes = bytes.get(written..).unwrap_or(&[]);
        }
        Ok(())
    }

    /// Waits until one message is complete and returns it (the stream's latest values are
    /// updated too). Garbage, corrupted frames and lost bytes are skipped and counted in
    /// [`stream().stats()`](crate::GnssStream::stats). A port that ends its stream (`read`
    /// returning `Ok(0)`: nothing more will come) is [`DeviceError::Timeout`] naming NAV-PVT
    /// (0x01/0x07), never a hang.
    ///
    /// Cancel-safe: dropping the future loses no byte already read (see the module docs).
    pub async fn read_message(&mut self) -> Result<Message, Error<T::Error>> {
        self.next_message(NAV_PVT).await
    }

    /// [`read_message`](Self::read_message), naming `waiting_for` if the stream ends.
    async fn next_message(&mut self, waiting_for: (u8, u8)) -> Result<Message, Error<T::Error>> {
        loop {
            if let Some(message) = self.stream_mut().poll_pending() {
                return Ok(message);
            }
            let byte = self.next_byte(waiting_for).await?;
            if let Some(message) = self.stream_mut().push(byte) {
                return Ok(message);
            }
        }
    }

    /// Waits for the next NAV-PVT frame; other messages only update the stream's latest
    /// values. Cancel-safe like [`read_message`](Self::read_message). Race it against a
    /// `DelayNs` (or use the caller's timeout) to bound the wait.
    pub async fn read_nav_pvt(&mut self) -> Result<NavPvtFrame, Error<T::Error>> {
        loop {
            if let Message::NavPvt(frame) = self.read_message().await? {
                // The stream recorded it as fresh; it has been handed out now.
                let _ = self.stream_mut().take_nav_pvt();
                return Ok(frame);
            }
        }
    }

    /// Sends `command` and waits for its ACK-ACK, at most `timeout_ms` measured with `delay`
    /// (write and answer together). ACK-NAK is [`DeviceError::Nak`], silence
    /// [`DeviceError::Timeout`], both naming the command; no retry. Messages arriving
    /// meanwhile go into the stream as usual.
    pub async fn send_and_await_ack<D: DelayNs>(
        &mut self,
        command: &Command,
        delay: &mut D,
        timeout_ms: u32,
    ) -> Result<(), Error<T::Error>> {
        let sent = (command.class(), command.id());
        let exchange = async {
            self.write_command(command).await?;
            loop {
                match self.next_message(sent).await? {
                    Message::Ack { class, id } if (class, id) == sent => return Ok(()),
                    Message::Nak { class, id } if (class, id) == sent => {
                        return Err(Error::Device(DeviceError::Nak { class, id }))
                    }
                    _ => {}
                }
            }
        };
        match race(exchange, delay.delay_ms(timeout_ms)).await {
            Raced::First(result) => result,
            Raced::Second(()) => Err(timeout(sent)),
        }
    }

    /// Applies `config` to a receiver whose UART1 is at `current_baud_rate`: the sequence of
    /// [`Configurator`](crate::Configurator) (MON-VER, CFG-PRT, CFG-MSG, CFG-RATE, CFG-NAV5,
    /// CFG-TP5, CFG-TMODE2), each message awaiting its ACK within
    /// [`DEFAULT_TIMEOUT_MS`](crate::DEFAULT_TIMEOUT_MS) raced against `delay` and resent
    /// [`DEFAULT_RETRIES`](crate::DEFAULT_RETRIES) times after silence. `set_baud_rate` must
    /// switch the host port; after an ACK-NAK of the port change it is called again with the
    /// old rate, which the receiver kept. Returns what MON-VER reported.
    ///
    /// Frames received during the configuration go through a 512-byte framer of their own, as
    /// in [`NeoM8t::configure_blocking`](crate::NeoM8t::configure_blocking); the stream's
    /// partial frame is dropped at the end.
    pub async fn configure<D: DelayNs>(
        &mut self,
        config: Config,
        current_baud_rate: u32,
        delay: &mut D,
        mut set_baud_rate: impl FnMut(&mut T, u32),
    ) -> Result<ReceiverVersion, Error<T::Error>> {
        let mut run = Run {
            framer: UbxFramer::with_capacity(),
            version: None,
            baud_rate: current_baud_rate,
        };
        let mut step = Step::MonVer;
        while let Some(command) = step_command(step, &config) {
            let switching = step == Step::Port && config.baud_rate != run.baud_rate;
            let mut attempt = 0u8;
            loop {
                let answer = if switching {
                    self.switch_port(
                        &mut run,
                        &command,
                        config.baud_rate,
                        delay,
                        &mut set_baud_rate,
                    )
                    .await?
                } else {
                    self.exchange(
                        &mut run,
                        step,
                        Phase::Awaiting,
                        &command,
                        delay,
                        DEFAULT_TIMEOUT_MS,
                    )
                    .await?
                };
                if let Answer::Settled = answer {
                    break;
                }
                attempt = attempt.saturating_add(1);
                if attempt > DEFAULT_RETRIES {
                    return Err(if switching {
                        Error::Device(DeviceError::BaudSwitchFailed {
                            baud_rate: config.baud_rate,
                        })
                    } else {
                        timeout((command.class(), command.id()))
                    });
                }
                // A false candidate (noise with a sync pair and a long length) would otherwise
                // hold back the answer to the resend.
                run.framer.clear();
            }
            step = next_step(step, &config);
        }
        self.stream_mut().clear_partial();
        Ok(run.version.unwrap_or_default())
    }

    /// Sends `command` (not while settling after a port change: then it only listens) and
    /// reads frames, judged for `step` in `phase`, until one settles the step, or `timeout_ms`
    /// passes.
    async fn exchange<D: DelayNs>(
        &mut self,
        run: &mut Run,
        step: Step,
        phase: Phase,
        command: &Command,
        delay: &mut D,
        timeout_ms: u32,
    ) -> Result<Answer, Error<T::Error>> {
        let sent = (command.class(), command.id());
        let listen = async {
            if phase != Phase::Settling {
                self.write_command(command).await?;
            }
            loop {
                let byte = self.next_byte(sent).await?;
                let mut frame = run.framer.push(byte);
                while let Some(f) = frame {
                    match judge(step, phase, command, &f) {
                        Judgement::Pass => {}
                        Judgement::Advance => return Ok(Answer::Settled),
                        Judgement::Version(v) => {
                            run.version = Some(v);
                            return Ok(Answer::Settled);
                        }
                        Judgement::Nak { class, id } => {
                            return Err(Error::Device(DeviceError::Nak { class, id }))
                        }
                    }
                    frame = run.framer.poll_pending();
                }
            }
        };
        match race(listen, delay.delay_ms(timeout_ms)).await {
            Raced::First(result) => result,
            Raced::Second(()) => Ok(Answer::Silence),
        }
    }

    /// CFG-PRT with a new baud rate: sends it, waits until it has left the host port, switches
    /// the host to `new_rate`, and takes any valid frame there as the confirmation (the ACK, or
    /// the answer to a CFG-PRT poll after the settle time). Silence switches the host back.
    async fn switch_port<D: DelayNs>(
        &mut self,
        run: &mut Run,
        command: &Command,
        new_rate: u32,
        delay: &mut D,
        set_baud_rate: &mut impl FnMut(&mut T, u32),
    ) -> Result<Answer, Error<T::Error>> {
        let sent = async {
            self.write_command(command).await?;
            self.serial_mut().flush().await.map_err(Error::Comm)
        };
        match race(sent, delay.delay_ms(DEFAULT_TIMEOUT_MS)).await {
            Raced::First(result) => result?,
            Raced::Second(()) => return Err(timeout((CLASS_CFG, ID_CFG_PRT))),
        }
        let old_rate = run.baud_rate;
        set_baud_rate(self.serial_mut(), new_rate);
        run.baud_rate = new_rate;
        run.framer.clear();
        let poll = commands::poll_cfg_prt_uart1();
        let mut answer = self
            .exchange(
                run,
                Step::Port,
                Phase::Settling,
                &poll,
                delay,
                DEFAULT_SWITCH_SETTLE_MS,
            )
            .await;
        if let Ok(Answer::Silence) = answer {
            answer = self
                .exchange(
                    run,
                    Step::Port,
                    Phase::SwitchedAwaiting,
                    &poll,
                    delay,
                    DEFAULT_TIMEOUT_MS,
                )
                .await;
        }
        if !matches!(answer, Ok(Answer::Settled)) {
            // Rejected or unanswered: the receiver is (still) at the old rate.
            set_baud_rate(self.serial_mut(), old_rate);
            run.baud_rate = old_rate;
        }
        answer
    }
}

/// State of one [`NeoM8tAsync::configure`] run.
struct Run {
    framer: UbxFramer<512>,
    version: Option<ReceiverVersion>,
    /// The rate the host port is at now.
    baud_rate: u32,
}
