//! The request-handling state machine.
//!
//! The host raises the request line; the board answers with the latest complete packet, by DMA,
//! never from inside the interrupt's own work, and then, while an info snapshot is going out,
//! with one info piece (docs/wire-formats.md on the request line and the info pieces, and the
//! info piece contract of `dima-sensorboard`):
//!
//! - a request that arrives while a transfer (packet or piece) is still running is skipped
//!   and counted: the packet in flight is never torn or restarted;
//! - nothing is ever sent unrequested, and nothing before the first complete packet exists
//!   (such an early request is counted apart, see [`RequestHandler::not_ready`]);
//! - a request [`INFO_GAP_MS`] or more after the previous request (or the first after boot)
//!   means the host has just (re)started: its answer starts the info snapshot from piece 0.
//!   If such a request cannot be served, the restart stays due for the next answer.
//!
//! No whole `$I` info frame is sent any more: behind a packet it takes 5.73 ms, more than the
//! 4 ms period at 250 Hz, and cost the next request; a piece takes 0.50 ms (packet + piece
//! 3.65 ms).

pub use dima_sensorboard::INFO_GAP_MS;

/// What the request interrupt must do now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Answer {
    /// Start sending the latest packet.
    Send,
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
    /// The packet is out: send an info piece if one is due (then
    /// [`RequestHandler::piece_started`]), else end the answer
    /// ([`RequestHandler::end_answer`]).
    SendPiece {
        /// The host has just (re)started: begin the info snapshot from piece 0.
        restart: bool,
    },
    /// The answer is complete; the link is idle.
    Idle,
    /// A completion arrived while no transfer was running (spurious interrupt): ignore it.
    Spurious,
}

/// Where the outgoing link is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LinkState {
    Idle,
    SendingPacket,
    /// The packet is out; the piece is being chosen and started.
    PacketSent,
    SendingPiece,
}

/// The request-handling state machine. Times are milliseconds since boot and may wrap.
#[derive(Debug, Clone)]
pub struct RequestHandler {
    state: LinkState,
    last_request_ms: Option<u32>,
    restart_due: bool,
    restart_answer: bool,
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
            restart_due: false,
            restart_answer: false,
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
            self.restart_due = true;
        }

        if self.state != LinkState::Idle {
            self.skipped = self.skipped.wrapping_add(1);
            return Answer::Skip;
        }
        if !packet_ready {
            self.not_ready = self.not_ready.wrapping_add(1);
            return Answer::NotReady;
        }
        self.restart_answer = core::mem::take(&mut self.restart_due);
        self.state = LinkState::SendingPacket;
        self.answered = self.answered.wrapping_add(1);
        Answer::Send
    }

    /// The running transfer has completed (the last byte left the transmitter).
    pub fn on_transfer_complete(&mut self) -> AfterTransfer {
        match self.state {
            LinkState::SendingPacket => {
                self.state = LinkState::PacketSent;
                AfterTransfer::SendPiece {
                    restart: self.restart_answer,
                }
            }
            LinkState::SendingPiece | LinkState::PacketSent => {
                self.state = LinkState::Idle;
                AfterTransfer::Idle
            }
            LinkState::Idle => AfterTransfer::Spurious,
        }
    }

    /// The piece asked for by [`AfterTransfer::SendPiece`] is going out.
    pub fn piece_started(&mut self) {
        if self.state == LinkState::PacketSent {
            self.state = LinkState::SendingPiece;
        }
    }

    /// The answer ends here: no piece was due, or a transfer could not be started or failed.
    pub fn end_answer(&mut self) {
        self.state = LinkState::Idle;
    }

    /// True while a packet or piece is being sent.
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

    const PIECE: AfterTransfer = AfterTransfer::SendPiece { restart: false };
    const PIECE_RESTART: AfterTransfer = AfterTransfer::SendPiece { restart: true };

    /// Packet, then a piece, then idle.
    fn answer_with_piece(handler: &mut RequestHandler) -> AfterTransfer {
        let after = handler.on_transfer_complete();
        handler.piece_started();
        assert_eq!(handler.on_transfer_complete(), AfterTransfer::Idle);
        after
    }

    #[test]
    fn nothing_is_sent_before_a_packet_exists() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(3, false), Answer::NotReady);
        assert!(!handler.is_busy());
        assert_eq!(handler.not_ready(), 1);
        assert_eq!(handler.answered(), 0);
    }

    #[test]
    fn first_request_after_boot_restarts_the_info_snapshot() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(10, true), Answer::Send);
        assert_eq!(answer_with_piece(&mut handler), PIECE_RESTART);
        // The next request 4 ms later continues the snapshot.
        assert_eq!(handler.on_request(14, true), Answer::Send);
        assert_eq!(answer_with_piece(&mut handler), PIECE);
    }

    #[test]
    fn an_early_request_keeps_the_restart_due() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(0, false), Answer::NotReady);
        assert_eq!(handler.on_request(4, true), Answer::Send);
        assert_eq!(handler.on_transfer_complete(), PIECE_RESTART);
    }

    #[test]
    fn request_during_a_transfer_is_skipped_and_counted() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(0, true), Answer::Send);
        // Still sending the packet, then the piece: both requests are skipped.
        assert_eq!(handler.on_request(1, true), Answer::Skip);
        assert_eq!(handler.on_transfer_complete(), PIECE_RESTART);
        assert_eq!(
            handler.on_request(2, true),
            Answer::Skip,
            "choosing the piece"
        );
        handler.piece_started();
        assert_eq!(
            handler.on_request(3, true),
            Answer::Skip,
            "sending the piece"
        );
        assert_eq!(handler.on_transfer_complete(), AfterTransfer::Idle);
        assert_eq!(handler.skipped(), 3);
        assert_eq!(handler.answered(), 1);
        assert_eq!(handler.on_request(4, true), Answer::Send);
    }

    #[test]
    fn an_answer_without_a_piece_ends_after_the_packet() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_request(0, true), Answer::Send);
        assert_eq!(handler.on_transfer_complete(), PIECE_RESTART);
        handler.end_answer();
        assert!(!handler.is_busy());
        assert_eq!(handler.on_request(1, true), Answer::Send);
    }

    #[test]
    fn a_pause_of_the_info_gap_restarts_the_snapshot() {
        let mut handler = RequestHandler::new();
        handler.on_request(0, true);
        answer_with_piece(&mut handler);
        assert_eq!(handler.on_request(INFO_GAP_MS - 1, true), Answer::Send);
        assert_eq!(answer_with_piece(&mut handler), PIECE);
        // Exactly the gap after the previous request.
        assert_eq!(handler.on_request(2 * INFO_GAP_MS - 1, true), Answer::Send);
        assert_eq!(answer_with_piece(&mut handler), PIECE_RESTART);
    }

    #[test]
    fn the_gap_is_measured_from_skipped_requests_too() {
        let mut handler = RequestHandler::new();
        handler.on_request(0, true);
        assert_eq!(handler.on_request(300, true), Answer::Skip);
        answer_with_piece(&mut handler);
        // 600 ms after the first request but only 300 ms after the skipped one.
        assert_eq!(handler.on_request(600, true), Answer::Send);
        assert_eq!(answer_with_piece(&mut handler), PIECE);
    }

    #[test]
    fn a_restart_during_a_transfer_goes_with_the_next_answer() {
        let mut handler = RequestHandler::new();
        handler.on_request(0, true);
        answer_with_piece(&mut handler);
        assert_eq!(handler.on_request(10, true), Answer::Send);
        // A stalled transfer: the host restarts and requests 1 s later.
        assert_eq!(handler.on_request(1010, true), Answer::Skip);
        assert_eq!(answer_with_piece(&mut handler), PIECE);
        assert_eq!(handler.on_request(1014, true), Answer::Send);
        assert_eq!(answer_with_piece(&mut handler), PIECE_RESTART);
    }

    #[test]
    fn time_wraps_around() {
        let mut handler = RequestHandler::new();
        handler.on_request(u32::MAX - 2, true);
        answer_with_piece(&mut handler);
        assert_eq!(handler.on_request(2, true), Answer::Send);
        assert_eq!(answer_with_piece(&mut handler), PIECE);
        assert_eq!(handler.on_request(2 + INFO_GAP_MS, true), Answer::Send);
        assert_eq!(answer_with_piece(&mut handler), PIECE_RESTART);
    }

    #[test]
    fn spurious_completion_is_ignored() {
        let mut handler = RequestHandler::new();
        assert_eq!(handler.on_transfer_complete(), AfterTransfer::Spurious);
        assert!(!handler.is_busy());
        assert_eq!(handler.on_request(0, true), Answer::Send);
        assert!(handler.is_busy());
    }

    #[test]
    fn a_long_run_never_starts_a_transfer_while_busy() {
        // Requests every 1 ms, packets lasting 3 ms and pieces 1 ms: every answer starts
        // only when idle.
        let mut handler = RequestHandler::new();
        let mut busy_until = None;
        let mut started = 0u32;
        for now in 0..1000u32 {
            if busy_until == Some(now) {
                match handler.on_transfer_complete() {
                    AfterTransfer::SendPiece { .. } => {
                        handler.piece_started();
                        busy_until = Some(now + 1);
                    }
                    AfterTransfer::Idle => busy_until = None,
                    AfterTransfer::Spurious => panic!("spurious completion"),
                }
            }
            let was_busy = handler.is_busy();
            match handler.on_request(now, true) {
                Answer::Send => {
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
