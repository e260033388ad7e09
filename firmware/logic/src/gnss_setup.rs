//! Boot-time configuration of the NEO-M8T receiver.
//!
//! The firmware runs `neo_m8t::Configurator` as a caller-polled state machine from a
//! low-priority task while the GNSS receive path keeps running. The configurator wants one
//! serial port for both directions, but the receive side already belongs to the DMA + UBX
//! reader. So the receive task copies every byte it gets into a single-producer,
//! single-consumer queue ([`ReplyTap`]) while configuration is under way, and the
//! configurator reads its MON-VER answer and ACK/NAK frames from the other end
//! ([`ReplyPort`]), which writes straight to the USART1 transmitter. The NAV-PVT path is
//! untouched: it sees the same bytes as before.
//!
//! The result ([`Outcome`]) is kept in a [`SetupStatus`] (an atomic byte a debugger can read)
//! and shown on the status LED (see [`crate::blink`]).

use core::sync::atomic::{AtomicU8, Ordering};
use embedded_hal_nb::serial::{ErrorType, Read, Write};
use heapless::spsc::{Consumer, Producer};

/// Bytes the reply queue holds: a MON-VER answer (about 280 bytes on an M8T) plus a few
/// NAV-PVT frames arriving meanwhile. The configurator is polled every few milliseconds and
/// reads up to 256 bytes per poll, far faster than 115 200 baud delivers them.
///
/// Without the `gnss-setup` feature nothing is configured and the queue shrinks to the
/// smallest the queue type allows.
pub const REPLY_QUEUE_LEN: usize = if cfg!(feature = "gnss-setup") { 512 } else { 2 };

/// How the boot-time configuration ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Outcome {
    /// Still running.
    Pending = 0,
    /// Every message was acknowledged: 10 Hz NAV-PVT on UART1, UBX only, automotive model.
    Configured = 1,
    /// The receiver rejected a message (ACK-NAK).
    Nak = 2,
    /// No answer within the deadline after every retry (no receiver, or a broken line).
    Timeout = 3,
    /// The serial port failed, or the baud-rate switch failed.
    Failed = 4,
    /// Not attempted: the firmware was built without boot-time configuration and relies on
    /// the configuration stored in the receiver.
    Skipped = 5,
}

impl Outcome {
    /// The outcome of a finished `Configurator::poll` error.
    #[must_use]
    pub fn from_error<E>(error: &neo_m8t::Error<E>) -> Self {
        match error {
            neo_m8t::Error::Device(neo_m8t::DeviceError::Nak { .. }) => Self::Nak,
            neo_m8t::Error::Device(neo_m8t::DeviceError::Timeout { .. }) => Self::Timeout,
            neo_m8t::Error::Comm(_)
            | neo_m8t::Error::Device(neo_m8t::DeviceError::BaudSwitchFailed { .. }) => Self::Failed,
        }
    }

    /// The outcome stored as `code` (see the discriminants); unknown codes are `Failed`.
    #[must_use]
    pub fn from_code(code: u8) -> Self {
        match code {
            0 => Self::Pending,
            1 => Self::Configured,
            2 => Self::Nak,
            3 => Self::Timeout,
            5 => Self::Skipped,
            _ => Self::Failed,
        }
    }
}

/// The configuration outcome shared between tasks (and readable by a debugger: one byte,
/// the [`Outcome`] discriminant).
#[derive(Debug)]
pub struct SetupStatus(AtomicU8);

impl SetupStatus {
    /// Pending.
    #[must_use]
    pub const fn new() -> Self {
        Self(AtomicU8::new(Outcome::Pending as u8))
    }

    /// The current outcome.
    pub fn get(&self) -> Outcome {
        Outcome::from_code(self.0.load(Ordering::Relaxed))
    }

    /// Records the outcome.
    pub fn set(&self, outcome: Outcome) {
        self.0.store(outcome as u8, Ordering::Relaxed);
    }

    /// Whether the configurator is still running (and so wants the received bytes).
    pub fn is_pending(&self) -> bool {
        self.get() == Outcome::Pending
    }
}

impl Default for SetupStatus {
    fn default() -> Self {
        Self::new()
    }
}

/// The receive task's end of the reply queue.
pub struct ReplyTap<'a> {
    producer: Producer<'a, u8>,
    dropped: u32,
}

impl<'a> ReplyTap<'a> {
    /// Wraps the producer half of the reply queue.
    pub fn new(producer: Producer<'a, u8>) -> Self {
        Self {
            producer,
            dropped: 0,
        }
    }

    /// Copies `bytes` into the queue; bytes that do not fit are dropped and counted (the
    /// configurator's framer resynchronises and its retry asks again).
    pub fn push_slice(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            if self.producer.enqueue(byte).is_err() {
                self.dropped = self.dropped.wrapping_add(1);
            }
        }
    }

    /// Bytes dropped because the queue was full.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
}

/// The configurator's serial port: reads from the reply queue, writes to `tx`.
pub struct ReplyPort<'a, W> {
    tx: W,
    rx: Consumer<'a, u8>,
}

impl<'a, W> ReplyPort<'a, W> {
    /// Combines the transmitter with the consumer half of the reply queue.
    pub fn new(tx: W, rx: Consumer<'a, u8>) -> Self {
        Self { tx, rx }
    }

    /// The transmitter (to inspect it, or to release it once configuration is over).
    pub fn tx(&mut self) -> &mut W {
        &mut self.tx
    }
}

impl<W: ErrorType> ErrorType for ReplyPort<'_, W> {
    type Error = W::Error;
}

impl<W: ErrorType> Read<u8> for ReplyPort<'_, W> {
    fn read(&mut self) -> nb::Result<u8, Self::Error> {
        self.rx.dequeue().ok_or(nb::Error::WouldBlock)
    }
}

impl<W: Write<u8>> Write<u8> for ReplyPort<'_, W> {
    fn write(&mut self, word: u8) -> nb::Result<(), Self::Error> {
        self.tx.write(word)
    }

    fn flush(&mut self) -> nb::Result<(), Self::Error> {
        self.tx.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::convert::Infallible;
    use heapless::spsc::Queue;
    use heapless::Vec;
    use neo_m8t::{Config, Configurator, Progress};

    /// A transmitter that takes `per_call` bytes between `WouldBlock`s (like a UART polled
    /// every millisecond) and records them.
    struct SlowTx {
        sent: Vec<u8, 1024>,
        budget: usize,
    }

    impl ErrorType for SlowTx {
        type Error = Infallible;
    }

    impl Write<u8> for SlowTx {
        fn write(&mut self, word: u8) -> nb::Result<(), Infallible> {
            if self.budget == 0 {
                return Err(nb::Error::WouldBlock);
            }
            self.budget -= 1;
            let _ = self.sent.push(word);
            Ok(())
        }

        fn flush(&mut self) -> nb::Result<(), Infallible> {
            Ok(())
        }
    }

    fn slow_tx() -> SlowTx {
        SlowTx {
            sent: Vec::new(),
            budget: 0,
        }
    }

    /// Polls every millisecond, letting `per_ms` bytes out each time, until the configurator
    /// finishes or `limit_ms` passes; `on_ms` may feed the tap.
    fn run(
        port: &mut ReplyPort<'_, SlowTx>,
        cfg: &mut Configurator<512>,
        limit_ms: u32,
        mut on_ms: impl FnMut(u32, &[u8]),
    ) -> (Outcome, u32) {
        for now_ms in 0..limit_ms {
            port.tx().budget = 2;
            let result = cfg.poll(port, now_ms);
            on_ms(now_ms, &port.tx().sent);
            match result {
                Ok(Progress::Pending) => {}
                Ok(Progress::Done) => return (Outcome::Configured, now_ms),
                Ok(Progress::SetBaudRate(_)) => panic!("no baud switch at 115 200"),
                Err(e) => return (Outcome::from_error(&e), now_ms),
            }
        }
        (Outcome::Pending, limit_ms)
    }

    #[test]
    fn outcome_codes_round_trip() {
        for outcome in [
            Outcome::Pending,
            Outcome::Configured,
            Outcome::Nak,
            Outcome::Timeout,
            Outcome::Failed,
            Outcome::Skipped,
        ] {
            assert_eq!(Outcome::from_code(outcome as u8), outcome);
        }
        assert_eq!(Outcome::from_code(200), Outcome::Failed);
        let status = SetupStatus::new();
        assert!(status.is_pending());
        status.set(Outcome::Nak);
        assert_eq!(status.get(), Outcome::Nak);
        assert!(!status.is_pending());
    }

    #[test]
    fn error_kinds_map_to_outcomes() {
        let nak: neo_m8t::Error<()> =
            neo_m8t::Error::Device(neo_m8t::DeviceError::Nak { class: 6, id: 1 });
        let timeout: neo_m8t::Error<()> =
            neo_m8t::Error::Device(neo_m8t::DeviceError::Timeout { class: 10, id: 4 });
        let comm: neo_m8t::Error<()> = neo_m8t::Error::Comm(());
        let baud: neo_m8t::Error<()> =
            neo_m8t::Error::Device(neo_m8t::DeviceError::BaudSwitchFailed { baud_rate: 9600 });
        assert_eq!(Outcome::from_error(&nak), Outcome::Nak);
        assert_eq!(Outcome::from_error(&timeout), Outcome::Timeout);
        assert_eq!(Outcome::from_error(&comm), Outcome::Failed);
        assert_eq!(Outcome::from_error(&baud), Outcome::Failed);
    }

    #[test]
    fn tap_bytes_reach_the_port_in_order_and_overflow_is_counted() {
        let mut queue: Queue<u8, 8> = Queue::new();
        let (producer, consumer) = queue.split();
        let mut tap = ReplyTap::new(producer);
        let mut port = ReplyPort::new(slow_tx(), consumer);
        tap.push_slice(&[1, 2, 3]);
        assert_eq!(port.read(), Ok(1));
        assert_eq!(port.read(), Ok(2));
        assert_eq!(port.read(), Ok(3));
        assert_eq!(port.read(), Err(nb::Error::WouldBlock));
        // Capacity is N - 1 = 7: three of these ten are dropped.
        tap.push_slice(&[0; 10]);
        assert_eq!(tap.dropped(), 3);
        assert_eq!(tap.dropped() as usize + 7, 10);
    }

    #[test]
    fn silent_receiver_times_out_after_the_retries() {
        let mut queue: Queue<u8, 512> = Queue::new();
        let (_producer, consumer) = queue.split();
        let mut port = ReplyPort::new(slow_tx(), consumer);
        let mut cfg = Configurator::<512>::with_capacity(Config::default(), 115_200);
        let (outcome, at_ms) = run(&mut port, &mut cfg, 10_000, |_, _| {});
        assert_eq!(outcome, Outcome::Timeout);
        // MON-VER poll sent four times (first try + 3 retries), 500 ms each.
        let poll = neo_m8t::commands::poll_mon_ver();
        assert_eq!(port.tx().sent.len(), 4 * poll.as_bytes().len());
        assert_eq!(&port.tx().sent[..poll.as_bytes().len()], poll.as_bytes());
        assert!((1_900..=2_100).contains(&at_ms), "timed out at {at_ms} ms");
    }

    #[test]
    fn replies_go_through_the_tap_and_a_nak_is_no_answer_to_a_poll() {
        // MON-VER poll as on the wire: /work/shared/vectors/README.md (pyubx2).
        const MON_VER_POLL: [u8; 8] = [0xB5, 0x62, 0x0A, 0x04, 0x00, 0x00, 0x0E, 0x34];
        // UBX-ACK-NAK for UBX-MON-VER (class 0x0A, id 0x04); checksum by the 8-bit Fletcher
        // algorithm of the u-blox M8 protocol specification, worked by hand over 05 00 02 00 0A 04.
        const NAK_MON_VER: [u8; 10] = [0xB5, 0x62, 0x05, 0x00, 0x02, 0x00, 0x0A, 0x04, 0x15, 0x3E];
        let mut queue: Queue<u8, 512> = Queue::new();
        let (producer, consumer) = queue.split();
        let mut tap = ReplyTap::new(producer);
        let mut port = ReplyPort::new(slow_tx(), consumer);
        let mut cfg = Configurator::<512>::with_capacity(Config::default(), 115_200);
        let mut answered = false;
        let (outcome, at_ms) = run(&mut port, &mut cfg, 10_000, |_, sent| {
            if !answered && sent.len() == MON_VER_POLL.len() {
                // Noise, then the NAK, as the receive task would copy them.
                tap.push_slice(&[0x00, 0xB5, 0x13]);
                tap.push_slice(&NAK_MON_VER);
                answered = true;
            }
        });
        assert!(answered);
        assert_eq!(&port.tx().sent[..8], &MON_VER_POLL);
        // The configurator consumed the bytes (the queue is empty again) but waits for the
        // MON-VER answer itself: a poll is never acknowledged.
        assert_eq!(port.read(), Err(nb::Error::WouldBlock));
        assert_eq!(outcome, Outcome::Timeout);
        assert!(at_ms >= 1_900);
    }
}
