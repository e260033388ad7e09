//! The request-handling state machine.
//!
//! The host raises the request line; the board answers with the latest complete packet, by DMA,
//! never from inside the interrupt's own work. The rules (DESIGN 3 and the info frame contract):
//!
//! - a request that arrives while a transfer (packet or info frame) is still running is
//!   skipped and counted: the packet in flight is never torn or restarted;
//! - nothing is ever sent unrequested, and nothing before the first complete packet exists
//!   (such an early request is counted apart, see [`RequestHandler::not_ready`]);
//! - an info frame follows the packet in the same answer for the first request after boot and
//!   for any request that comes [`INFO_GAP_MS`] or more after the previous request (the host
//!   has just started or restarted). If such a request cannot be served, the info frame stays
//!   due and goes out with the next answer.

/// A request this long after the previous one (milliseconds) gets an info frame appended.
pub const INFO_GAP_MS: u32 = 500;

/// What the request interrupt must do now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Answer {
    /// Start sending the latest packet; if `info` is true, an info frame follows it as soon as
    /// the packet transfer completes.
    Send {
        /// An info frame follows the packet.
        info: bool,
    },
    /// A transfer is still running: leave it alone. The request was counted in
    /// [`RequestHandler::skipped`].
    Skip,
    /// No complete packet exists yet (the board has just booted): send nothing. Counted in
    /// [`RequestHandler::not_ready`].
    NotReady,
}

/// What the transfer-complete interrupt must do now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AfterTransfer {
    /// The packet is out and an info frame was asked for: start sending it.
    SendInfo,
    /// The answer is complete; the link is idle.
    Idle,
    /// A completion arrived while no transfer was running (spurious interrupt): ignore it.
    Spurious,
}

/// Where the outgoing link is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LinkState {
    Idle,
    SendingPacket { info_follows: bool },
    SendingInfo,
}

/// The request-handling state machine. Times are milliseconds since boot and may wrap.
#[derive(Debug, Clone)]
pub struct RequestHandler {
    state: LinkState,
    last_request_ms: Option<u32>,
    info_due: bool,
    skipped: u32,
    not_ready: u32,
    answered: u32,
}

impl Default for RequestHandler {
    fn default() -> Self {
        Self::new()
    }
}

impl RequestHandler {
    /// A handler right after boot: idle, no request seen yet.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            state: LinkState::Idle,
            last_request_ms: None,
            info_due: false,
            skipped: 0,
            not_ready: 0,
            answered: 0,
        }
    }

    /// A request edge at `now_ms`. `packet_ready` tells whether a complete packet exists.
    pub fn on_request(&mut self, now_ms: u32, packet_ready: bool) -> Answer {
        let restart = match self.last_request_ms {
            None => true,
            Some(last) => now_ms.wrapping_sub(last) >= INFO_GAP_MS,
        };
        self.last_request_ms = Some(now_ms);
        if restart {
            self.info_due = true;
        }

        if self.state != LinkState::Idle {
            self.skipped = self.skipped.wrapping_add(1);
            return Answer::Skip;
        }
        if !packet_ready {
            self.not_ready = self.not_ready.wrapping_add(1);
            return Answer::NotReady;
        }
        let info = core::mem::take(&mut self.info_due);
        self.state = LinkState::SendingPacket { info_follows: info };
        self.answered = self.answered.wrapping_add(1);
        Answer::Send { info }
    }

    /// The running transfer has completed (the last byte left the transmitter).
    pub fn on_transfer_complete(&mut self) -> AfterTransfer {
        match self.state {
            LinkState::SendingPacket { info_follows: true } => {
                self.state = LinkState::SendingInfo;
                AfterTransfer::SendInfo
            }
            LinkState::SendingPacket {
                info_follows: false,
            }
            | LinkState::SendingInfo => {
                self.state = LinkState::Idle;
                AfterTransfer::Idle
            }
            LinkState::Idle => AfterTransfer::Spurious,
        }
    }

    /// True while a packet or info frame is being sent.
    #[must_use]
    pub fn is_busy(&self) -> bool {
        self.state != LinkState::Idle
    }

    /// Requests skipped because a transfer was still running (goes into the info frame).
    #[must_use]
    pub fn skipped(&self) -> u32 {
        self.skipped
    }

    /// Requests that came before the first complete packet existed.
    #[must_use]
    pub fn not_ready(&self) -> u32 {
        self.not_ready
    }

    /// Requests answered with a packet.
    #[must_use]
    pub fn answered(&self) -> u32 {
        self.answered
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SEND: Answer = Answer::Send { info: false };
    const SEND_INFO: Answer = Answer::Send { info: true };

    #[test]
    fn nothing_is_sent_before_a_packet_exists() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(3, false), Answer::NotReady);
        assert!(!handler.is_busy());
        assert_eq!(handler.not_ready(), 1);
        assert_eq!(handler.answered(), 0);
    }

    #[test]
    fn first_request_after_boot_gets_the_info_frame() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(10, true), SEND_INFO);
        assert_eq!(handler.on_transfer_complete(), AfterTransfer::SendInfo);
        assert_eq!(handler.on_transfer_complete(), AfterTransfer::Idle);
        // The next request 4 ms later is a plain packet.
        assert_eq!(handler.on_request(14, true), SEND);
        assert_eq!(handler.on_transfer_complete(), AfterTransfer::Idle);
    }

    #[test]
    fn an_early_request_keeps_the_info_frame_due() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(0, false), Answer::NotReady);
        assert_eq!(handler.on_request(4, true), SEND_INFO);
    }

    #[test]
    fn request_during_a_transfer_is_skipped_and_counted() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(0, true), SEND_INFO);
        // Still sending the packet, then the info frame: both requests are skipped.
        assert_eq!(handler.on_request(1, true), Answer::Skip);
        assert_eq!(handler.on_transfer_complete(), AfterTransfer::SendInfo);
        assert_eq!(handler.on_request(2, true), Answer::Skip);
        assert_eq!(handler.on_transfer_complete(), AfterTransfer::Idle);
        assert_eq!(handler.skipped(), 2);
        assert_eq!(handler.answered(), 1);
        assert_eq!(handler.on_request(4, true), SEND);
    }

    #[test]
    fn a_pause_of_the_info_gap_triggers_an_info_frame() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(0, true), SEND_INFO);
        handler.on_transfer_complete();
        handler.on_transfer_complete();
        assert_eq!(handler.on_request(INFO_GAP_MS - 1, true), SEND);
        handler.on_transfer_complete();
        // Exactly the gap after the previous request.
        assert_eq!(handler.on_request(2 * INFO_GAP_MS - 1, true), SEND_INFO);
    }

    #[test]
    fn the_gap_is_measured_from_skipped_requests_too() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(0, true), SEND_INFO);
        assert_eq!(handler.on_request(300, true), Answer::Skip);
        handler.on_transfer_complete();
        handler.on_transfer_complete();
        // 600 ms after the first request but only 300 ms after the skipped one.
        assert_eq!(handler.on_request(600, true), SEND);
    }

    #[test]
    fn info_due_during_a_transfer_goes_out_with_the_next_answer() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(0, true), SEND_INFO);
        handler.on_transfer_complete();
        handler.on_transfer_complete();
        assert_eq!(handler.on_request(10, true), SEND);
        // A stalled transfer: the host restarts and requests 1 s later.
        assert_eq!(handler.on_request(1010, true), Answer::Skip);
        handler.on_transfer_complete();
        assert_eq!(handler.on_request(1014, true), SEND_INFO);
    }

    #[test]
    fn time_wraps_around() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(u32::MAX - 2, true), SEND_INFO);
        handler.on_transfer_complete();
        handler.on_transfer_complete();
        assert_eq!(handler.on_request(2, true), SEND);
        handler.on_transfer_complete();
        assert_eq!(handler.on_request(2 + INFO_GAP_MS, true), SEND_INFO);
    }

    #[test]
    fn spurious_completion_is_ignored() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_transfer_complete(), AfterTransfer::Spurious);
        assert!(!handler.is_busy());
        assert_eq!(handler.on_request(0, true), SEND_INFO);
        assert!(handler.is_busy());
    }

    #[test]
    fn a_long_run_never_starts_a_transfer_while_busy() {
        // Requests every 1 ms, transfers lasting 3 ms: every answer starts only when idle.
        let mut handler = RequestHandler::new();
        let mut busy_until = None;
        let mut started = 0u32;
        for now in 0..1000u32 {
            if busy_until == Some(now) {
                match handler.on_transfer_complete() {
                    AfterTransfer::SendInfo => busy_until = Some(now + 1),
                    AfterTransfer::Idle => busy_until = None,
                    AfterTransfer::Spurious => panic!("spurious completion"),
                }
            }
            let was_busy = handler.is_busy();
            match handler.on_request(now, true) {
                Answer::Send { .. } => {
                    assert!(!was_busy);
                    started += 1;
                    busy_until = Some(now + 3);
                }
                Answer::Skip => assert!(was_busy),
                Answer::NotReady => panic!("packet was ready"),
            }
        }
        assert_eq!(started + handler.skipped(), 1000);
        assert_eq!(handler.answered(), started);
    }
}
