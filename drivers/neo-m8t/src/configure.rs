//! Acknowledged configuration as a caller-polled state machine.
//!
//! [`Configurator::poll`] never blocks and never reads a clock: the caller passes the
//! current time in milliseconds and calls again until it returns [`Progress::Done`] or an
//! error. Every wait has a deadline (`timeout_ms`) and every message a bounded number of
//! retries.

use crate::commands::{
    self, Command, CLASS_ACK, CLASS_CFG, CLASS_MON, ID_ACK_ACK, ID_ACK_NAK, ID_CFG_PRT, ID_MON_VER,
};
use crate::config::Config;
use crate::error::Error;
use crate::frame::{Frame, UbxFramer};
use crate::int_commands;
use crate::interface::{read_byte, Received};
use crate::version::ReceiverVersion;
use core::ops::ControlFlow;
use embedded_hal::delay::DelayNs;
use embedded_hal_nb::serial::{Read, Write};
use ublox::proto23::PacketRef;

/// Default wait for an ACK or answer, ms. The receiver answers within a few ms at 10 Hz.
pub const DEFAULT_TIMEOUT_MS: u32 = 500;
/// Default number of resends after the first attempt.
pub const DEFAULT_RETRIES: u8 = 3;
/// Default wait after switching the host UART before polling at the new rate, ms.
pub const DEFAULT_SWITCH_SETTLE_MS: u32 = 100;
/// Most bytes one [`Configurator::poll`] reads, so one call stays short.
pub const MAX_READ_PER_POLL: usize = 256;

/// What the caller should do after a [`Configurator::poll`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Progress {
    /// Still working: call `poll` again (after a short sleep, if you like).
    Pending,
    /// Set the host UART to this baud rate now, then keep polling.
    SetBaudRate(u32),
    /// The receiver is configured.
    Done,
}

/// Configuration steps, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Step {
    MonVer,
    Port,
    /// Index into the CFG-MSG list (see [`msg_entry`]).
    Msg(u8),
    Rate,
    Nav5,
    Tp5,
    Tmode2,
    Done,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Phase {
    /// Build the command of the current step.
    Start,
    /// Writing `tx`.
    Sending,
    /// Waiting until the CFG-PRT frame has left the host UART before switching.
    Flushing,
    /// Waiting for ACK / answer until `deadline_ms`.
    Awaiting,
    /// At the new baud rate: letting the receiver switch (any valid frame confirms it).
    Settling,
    /// At the new baud rate: writing the CFG-PRT poll.
    SwitchedSending,
    /// At the new baud rate: waiting for any valid frame.
    SwitchedAwaiting,
}

/// How a received frame affects the current step.
enum Outcome {
    None,
    Advance,
    Nak { class: u8, id: u8 },
}

/// CFG-MSG list: NAV-PVT on, default NMEA off, TIM-TP and TIM-TM2 as configured.
fn msg_entry(index: u8, config: &Config) -> Option<(u8, u8, u8)> {
    let nmea = commands::DEFAULT_NMEA.len() as u8;
    match index {
        0 => Some((0x01, 0x07, 1)),
        i if i <= nmea => {
            let (class, id) = commands::DEFAULT_NMEA[usize::from(i - 1)];
            Some((class, id, 0))
        }
        i if i == nmea + 1 => Some((0x0D, 0x01, u8::from(config.tim_tp))),
        i if i == nmea + 2 => Some((0x0D, 0x03, u8::from(config.tim_tm2))),
        _ => None,
    }
}

/// The command `step` sends for `config`; `None` past the last step. The integer builders:
/// the same bytes as `commands`, without floating point.
pub(crate) fn step_command(step: Step, config: &Config) -> Option<Command> {
    let c = config;
    match step {
        Step::MonVer => int_commands::poll_mon_ver(),
        Step::Port => int_commands::cfg_prt_uart1(c.baud_rate),
        Step::Msg(i) => {
            let (class, id, rate) = msg_entry(i, c)?;
            int_commands::cfg_msg_uart1(class, id, rate)
        }
        Step::Rate => int_commands::cfg_rate(c.measurement_period_ms, c.nav_rate, c.time_ref),
        Step::Nav5 => int_commands::cfg_nav5(c.dynamic_model),
        Step::Tp5 => int_commands::cfg_tp5(c.time_pulse.as_ref()?),
        Step::Tmode2 => int_commands::cfg_tmode2(c.time_mode.as_ref()?),
        Step::Done => None,
    }
}

/// The step after `step` for `config`, skipping the time pulse and time mode when they are
/// not configured.
pub(crate) fn next_step(step: Step, config: &Config) -> Step {
    let c = config;
    let mut next = step;
    loop {
        next = match next {
            Step::MonVer => Step::Port,
            Step::Port => Step::Msg(0),
            Step::Msg(i) if msg_entry(i + 1, c).is_some() => Step::Msg(i + 1),
            Step::Msg(_) => Step::Rate,
            Step::Rate => Step::Nav5,
            Step::Nav5 => Step::Tp5,
            Step::Tp5 => Step::Tmode2,
            Step::Tmode2 | Step::Done => Step::Done,
        };
        let skip = match next {
            Step::Tp5 => c.time_pulse.is_none(),
            Step::Tmode2 => c.time_mode.is_none(),
            _ => false,
        };
        if !skip {
            return next;
        }
    }
}

fn expired(now_ms: u32, deadline_ms: u32) -> bool {
    now_ms.wrapping_sub(deadline_ms) as i32 >= 0
}

/// Applies a [`Config`] to an M8 receiver over UART1, checking every ACK.
///
/// Sequence: MON-VER poll (software and protocol version are recorded, not assumed);
/// CFG-PRT (UART1 baud rate, UBX only in and out); CFG-MSG (NAV-PVT every solution on UART1,
/// default NMEA off, TIM-TP / TIM-TM2 as configured); CFG-RATE; CFG-NAV5 (dynamic model);
/// CFG-TP5 and CFG-TMODE2 when configured. Each CFG message waits for the ACK-ACK with its
/// class and id; ACK-NAK is an error; silence is retried, then an error.
///
/// **Baud-rate switch.** When the rate changes, the configurator waits until the CFG-PRT
/// frame has left the host UART (`flush`) and returns [`Progress::SetBaudRate`] so the
/// caller switches its UART. Any valid frame at the new rate then confirms the switch: the
/// ACK, if the receiver sends it at the new rate, or else the answer to a CFG-PRT poll sent
/// after `settle_ms` (the ACK sent at the old rate is lost). Without one before the timeout
/// it asks to go back to the old rate and sends CFG-PRT again. An ACK-NAK of CFG-PRT is not
/// a confirmation: the receiver kept its old rate, [`Configurator::baud_rate`] goes back to
/// it and the result is [`DeviceError::Nak`](crate::DeviceError::Nak).
///
/// `N` is the receive buffer; MON-VER needs about 280 bytes on an M8T.
///
/// # Example
///
/// ```
/// use embedded_hal_mock::eh1::serial::{Mock, Transaction};
/// use neo_m8t::{Config, Configurator, Progress};
///
/// # let mut transactions = vec![Transaction::write_many(neo_m8t::commands::poll_mon_ver().as_bytes())];
/// # transactions.push(Transaction::read_error(nb::Error::WouldBlock));
/// # let mut serial = Mock::new(&transactions);
/// // The receiver is at 115200 baud already: no switch needed.
/// let mut cfg = Configurator::<512>::with_capacity(Config::default(), 115_200);
/// let mut now_ms = 0u32;
/// # for _ in 0..1 {
/// match cfg.poll(&mut serial, now_ms) {
///     Ok(Progress::Pending) => now_ms += 1, // sleep 1 ms, read the clock again
///     Ok(Progress::SetBaudRate(baud)) => { /* switch the host UART to `baud` */ }
///     Ok(Progress::Done) => { /* cfg.version() has MON-VER */ }
///     Err(e) => panic!("{e}"),
/// }
/// # }
/// # serial.done();
/// ```
#[derive(Debug, Clone)]
pub struct Configurator<const N: usize = 512> {
    framer: UbxFramer<N>,
    config: Config,
    timeout_ms: u32,
    settle_ms: u32,
    max_retries: u8,
    step: Step,
    phase: Phase,
    attempt: u8,
    tx: Command,
    tx_pos: usize,
    deadline_ms: u32,
    baud_rate: u32,
    previous_baud_rate: u32,
    version: Option<ReceiverVersion>,
    retries: u32,
    line_errors: u32,
}

impl Configurator {
    /// A configurator for `config`, talking to a receiver whose UART1 is at
    /// `current_baud_rate` (the host UART must be at that rate too), with the default 512-byte
    /// reply buffer.
    pub fn new(config: Config, current_baud_rate: u32) -> Self {
        Self::with_capacity(config, current_baud_rate)
    }
}

impl<const N: usize> Configurator<N> {
    /// As [`Configurator::new`], with an `N`-byte reply buffer
    /// (`Configurator::<128>::with_capacity(config, baud)`; MON-VER needs up to 512).
    pub fn with_capacity(config: Config, current_baud_rate: u32) -> Self {
        Self {
            framer: UbxFramer::with_capacity(),
            config,
            timeout_ms: DEFAULT_TIMEOUT_MS,
            settle_ms: DEFAULT_SWITCH_SETTLE_MS,
            max_retries: DEFAULT_RETRIES,
            step: Step::MonVer,
            phase: Phase::Start,
            attempt: 0,
            tx: commands::poll_mon_ver(),
            tx_pos: 0,
            deadline_ms: 0,
            baud_rate: current_baud_rate,
            previous_baud_rate: current_baud_rate,
            version: None,
            retries: 0,
            line_errors: 0,
        }
    }

    /// Sets the wait for each ACK or answer, ms.
    pub fn with_timeout_ms(mut self, timeout_ms: u32) -> Self {
        self.timeout_ms = timeout_ms;
        self
    }

    /// Sets the wait after a baud-rate switch before the receiver is polled at the new rate,
    /// ms (an answer that arrives earlier is accepted at once).
    pub fn with_switch_settle_ms(mut self, settle_ms: u32) -> Self {
        self.settle_ms = settle_ms;
        self
    }

    /// Sets how often a message is resent after the first attempt.
    pub fn with_retries(mut self, retries: u8) -> Self {
        self.max_retries = retries;
        self
    }

    /// What MON-VER reported (available once the first step is done).
    pub fn version(&self) -> Option<&ReceiverVersion> {
        self.version.as_ref()
    }

    /// The baud rate the host UART should be at now.
    pub fn baud_rate(&self) -> u32 {
        self.baud_rate
    }

    /// Resends so far (all steps).
    pub fn retries(&self) -> u32 {
        self.retries
    }

    /// Overrun, framing, parity and noise errors reported by the port (expected around a
    /// baud-rate switch; they only drop the partial frame).
    pub fn line_errors(&self) -> u32 {
        self.line_errors
    }

    /// Receive framing counters.
    pub fn framer_stats(&self) -> crate::FramerStats {
        self.framer.stats()
    }

    /// `true` once every step was acknowledged.
    pub fn is_done(&self) -> bool {
        self.step == Step::Done
    }

    /// Advances the configuration: writes what can be written, reads what has arrived,
    /// checks deadlines against `now_ms` (any monotonic millisecond clock; wrapping is fine).
    ///
    /// Every phase has a deadline, including writing (a transmitter that never drains ends
    /// in [`DeviceError::Timeout`](crate::DeviceError::Timeout)). After an error, start again with a new `Configurator`.
    pub fn poll<S>(&mut self, serial: &mut S, now_ms: u32) -> Result<Progress, Error<S::Error>>
    where
        S: Read<u8> + Write<u8>,
    {
        // Each phase either answers the caller or moves to a later phase, so this ends in a
        // few rounds.
        for _ in 0..8 {
            let round = match self.phase {
                Phase::Start => self.start_step(now_ms),
                Phase::Sending | Phase::SwitchedSending => self.send(serial, now_ms)?,
                Phase::Flushing => self.flush_then_switch(serial, now_ms)?,
                Phase::Settling => self.settle(serial, now_ms)?,
                Phase::Awaiting | Phase::SwitchedAwaiting => self.await_reply(serial, now_ms)?,
            };
            if let ControlFlow::Break(progress) = round {
                return Ok(progress);
            }
        }
        Ok(Progress::Pending)
    }

    /// [`Phase::Start`]: builds the current step's command and starts sending it, or, past
    /// the last step, reports [`Progress::Done`].
    fn start_step(&mut self, now_ms: u32) -> ControlFlow<Progress> {
        match self.command() {
            Some(command) => self.tx = command,
            None => {
                self.step = Step::Done;
                return ControlFlow::Break(Progress::Done);
            }
        }
        self.tx_pos = 0;
        self.deadline_ms = now_ms.wrapping_add(self.timeout_ms);
        self.phase = Phase::Sending;
        ControlFlow::Continue(())
    }

    /// [`Phase::Sending`] and [`Phase::SwitchedSending`]: writes what the port takes; once
    /// all of `tx` is out, waits for the answer, or first for the port change to leave the
    /// host UART.
    fn send<S>(
        &mut self,
        serial: &mut S,
        now_ms: u32,
    ) -> Result<ControlFlow<Progress>, Error<S::Error>>
    where
        S: Write<u8>,
    {
        if !self.write_pending(serial)? {
            // A transmitter that never drains is a timeout too.
            return if expired(now_ms, self.deadline_ms) {
                Err(self.timeout_error())
            } else {
                Ok(ControlFlow::Break(Progress::Pending))
            };
        }
        self.deadline_ms = now_ms.wrapping_add(self.timeout_ms);
        self.phase = if self.phase == Phase::SwitchedSending {
            Phase::SwitchedAwaiting
        } else if self.step == Step::Port && self.config.baud_rate != self.baud_rate {
            Phase::Flushing
        } else {
            Phase::Awaiting
        };
        Ok(ControlFlow::Continue(()))
    }

    /// [`Phase::Flushing`]: once CFG-PRT has left the host UART, asks the caller to switch
    /// to the new baud rate and lets the receiver settle there.
    fn flush_then_switch<S>(
        &mut self,
        serial: &mut S,
        now_ms: u32,
    ) -> Result<ControlFlow<Progress>, Error<S::Error>>
    where
        S: Write<u8>,
    {
        match serial.flush() {
            Ok(()) => {}
            Err(nb::Error::WouldBlock) if expired(now_ms, self.deadline_ms) => {
                return Err(self.timeout_error())
            }
            Err(nb::Error::WouldBlock) => return Ok(ControlFlow::Break(Progress::Pending)),
            Err(nb::Error::Other(e)) => return Err(Error::Comm(e)),
        }
        self.previous_baud_rate = self.baud_rate;
        self.baud_rate = self.config.baud_rate;
        self.framer.clear();
        self.tx = commands::poll_cfg_prt_uart1();
        self.tx_pos = 0;
        self.deadline_ms = now_ms.wrapping_add(self.settle_ms);
        self.phase = Phase::Settling;
        Ok(ControlFlow::Break(Progress::SetBaudRate(self.baud_rate)))
    }

    /// [`Phase::Settling`]: any valid frame at the new rate confirms the switch; after
    /// `settle_ms` without one, polls CFG-PRT at the new rate.
    fn settle<S>(
        &mut self,
        serial: &mut S,
        now_ms: u32,
    ) -> Result<ControlFlow<Progress>, Error<S::Error>>
    where
        S: Read<u8>,
    {
        match self.receive(serial)? {
            Outcome::Advance => {
                self.advance();
                return Ok(ControlFlow::Continue(()));
            }
            Outcome::Nak { class, id } => return Err(self.port_change_rejected(class, id)),
            Outcome::None => {}
        }
        if !expired(now_ms, self.deadline_ms) {
            return Ok(ControlFlow::Break(Progress::Pending));
        }
        self.deadline_ms = now_ms.wrapping_add(self.timeout_ms);
        self.phase = Phase::SwitchedSending;
        Ok(ControlFlow::Continue(()))
    }

    /// [`Phase::Awaiting`] and [`Phase::SwitchedAwaiting`]: an answer settles the step, an
    /// ACK-NAK ends the configuration, silence past the deadline resends.
    fn await_reply<S>(
        &mut self,
        serial: &mut S,
        now_ms: u32,
    ) -> Result<ControlFlow<Progress>, Error<S::Error>>
    where
        S: Read<u8>,
    {
        match self.receive(serial)? {
            Outcome::Advance => {
                self.advance();
                return Ok(ControlFlow::Continue(()));
            }
            Outcome::Nak { class, id } if self.phase == Phase::SwitchedAwaiting => {
                return Err(self.port_change_rejected(class, id))
            }
            Outcome::Nak { class, id } => {
                return Err(Error::Device(crate::error::DeviceError::Nak { class, id }))
            }
            Outcome::None => {}
        }
        if !expired(now_ms, self.deadline_ms) {
            return Ok(ControlFlow::Break(Progress::Pending));
        }
        self.resend_after_silence()
    }

    /// No answer before the deadline: starts the step again, or fails once the retries are
    /// used up. After a baud-rate switch the step starts again from the old rate, which the
    /// caller is asked to switch back to.
    fn resend_after_silence<E>(&mut self) -> Result<ControlFlow<Progress>, Error<E>> {
        self.attempt = self.attempt.saturating_add(1);
        let switched = self.phase == Phase::SwitchedAwaiting;
        if self.attempt > self.max_retries {
            return Err(if switched {
                Error::Device(crate::error::DeviceError::BaudSwitchFailed {
                    baud_rate: self.config.baud_rate,
                })
            } else {
                self.timeout_error()
            });
        }
        self.retries = self.retries.wrapping_add(1);
        self.phase = Phase::Start;
        // A false candidate (noise with a sync pair and a long length) would otherwise hold
        // back the answer to the resend.
        self.framer.clear();
        if switched {
            // Back to the old rate, and send CFG-PRT again from there.
            self.baud_rate = self.previous_baud_rate;
            return Ok(ControlFlow::Break(Progress::SetBaudRate(self.baud_rate)));
        }
        Ok(ControlFlow::Continue(()))
    }

    /// Runs [`poll`](Self::poll) to completion, sleeping 1 ms between polls and counting
    /// those sleeps as the clock. `set_baud_rate` must switch the host UART; if it cannot,
    /// the check at the new rate fails and the switch is retried, then reported as
    /// [`DeviceError::BaudSwitchFailed`](crate::DeviceError::BaudSwitchFailed).
    ///
    /// Elapsed time is under-estimated by the time the polls themselves take, so real
    /// timeouts are at least the configured ones; the total is still bounded.
    pub fn run_blocking<S, D>(
        &mut self,
        serial: &mut S,
        delay: &mut D,
        mut set_baud_rate: impl FnMut(&mut S, u32),
    ) -> Result<(), Error<S::Error>>
    where
        S: Read<u8> + Write<u8>,
        D: DelayNs,
    {
        let mut now_ms = 0u32;
        loop {
            match self.poll(serial, now_ms)? {
                Progress::Done => return Ok(()),
                Progress::SetBaudRate(baud) => set_baud_rate(serial, baud),
                Progress::Pending => {
                    delay.delay_ms(1);
                    now_ms = now_ms.wrapping_add(1);
                }
            }
        }
    }

    /// The receiver answered the port change with ACK-NAK, so it stays at the old rate:
    /// [`baud_rate`](Self::baud_rate) goes back to it, for the caller to switch the host UART.
    fn port_change_rejected<E>(&mut self, class: u8, id: u8) -> Error<E> {
        self.baud_rate = self.previous_baud_rate;
        Error::Device(crate::error::DeviceError::Nak { class, id })
    }

    fn timeout_error<E>(&self) -> Error<E> {
        Error::Device(crate::error::DeviceError::Timeout {
            class: self.tx.class(),
            id: self.tx.id(),
        })
    }

    fn command(&self) -> Option<Command> {
        step_command(self.step, &self.config)
    }

    fn advance(&mut self) {
        self.step = next_step(self.step, &self.config);
        self.attempt = 0;
        self.phase = Phase::Start;
    }

    /// Writes the rest of `tx`; `Ok(true)` when all of it is out.
    fn write_pending<S>(&mut self, serial: &mut S) -> Result<bool, Error<S::Error>>
    where
        S: Write<u8>,
    {
        while let Some(&byte) = self.tx.as_bytes().get(self.tx_pos) {
            match serial.write(byte) {
                Ok(()) => self.tx_pos += 1,
                Err(nb::Error::WouldBlock) => return Ok(false),
                Err(nb::Error::Other(e)) => return Err(Error::Comm(e)),
            }
        }
        Ok(true)
    }

    /// Reads what has arrived (bounded) and reports whether a frame settles the step.
    fn receive<S>(&mut self, serial: &mut S) -> Result<Outcome, Error<S::Error>>
    where
        S: Read<u8>,
    {
        for _ in 0..MAX_READ_PER_POLL {
            let byte = match read_byte(serial).map_err(Error::Comm)? {
                Received::Byte(byte) => byte,
                Received::Idle => break,
                Received::LineError => {
                    self.line_errors = self.line_errors.wrapping_add(1);
                    self.framer.clear();
                    continue;
                }
            };
            let mut frame = self.framer.push(byte);
            while let Some(f) = frame {
                match judge(self.step, self.phase, &self.tx, &f) {
                    Judgement::Pass => {}
                    Judgement::Nak { class, id } => return Ok(Outcome::Nak { class, id }),
                    Judgement::Advance => return Ok(Outcome::Advance),
                    Judgement::Version(v) => {
                        self.version = Some(v);
                        return Ok(Outcome::Advance);
                    }
                }
                frame = self.framer.poll_pending();
            }
        }
        Ok(Outcome::None)
    }
}

/// What a received frame means for the step in progress.
pub(crate) enum Judgement {
    Pass,
    Advance,
    Version(ReceiverVersion),
    Nak { class: u8, id: u8 },
}

/// Decides what a received frame means for the step in progress.
pub(crate) fn judge(step: Step, phase: Phase, sent: &Command, frame: &Frame<'_>) -> Judgement {
    if matches!(phase, Phase::Settling | Phase::SwitchedAwaiting) {
        return match (frame.class(), frame.id(), frame.payload()) {
            // The port change was rejected (the NAK may have been queued before the host
            // switched): the receiver is still at the old rate.
            (CLASS_ACK, ID_ACK_NAK, &[CLASS_CFG, ID_CFG_PRT]) => Judgement::Nak {
                class: CLASS_CFG,
                id: ID_CFG_PRT,
            },
            // Any other valid frame at the new rate proves the switch.
            _ => Judgement::Advance,
        };
    }
    if step == Step::MonVer {
        return match frame.decode() {
            Ok(PacketRef::MonVer(ver))
                if (frame.class(), frame.id()) == (CLASS_MON, ID_MON_VER) =>
            {
                Judgement::Version(ReceiverVersion::from_mon_ver(&ver))
            }
            _ => Judgement::Pass,
        };
    }
    match (frame.class(), frame.id(), frame.payload()) {
        (CLASS_ACK, ID_ACK_ACK, &[class, id]) if (class, id) == (sent.class(), sent.id()) => {
            Judgement::Advance
        }
        (CLASS_ACK, ID_ACK_NAK, &[class, id]) if (class, id) == (sent.class(), sent.id()) => {
            Judgement::Nak { class, id }
        }
        _ => Judgement::Pass,
    }
}
