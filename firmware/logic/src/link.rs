//! The transmit side of the link to the host, above the DMA stream.
//!
//! [`TxLink`] answers request edges and transfer-complete interrupts: it keeps the request
//! state machine ([`RequestHandler`]), the three transmit buffers and the info pieces waiting
//! to go out ([`InfoPieceCycle`]), and drives a DMA stream through the [`TxDma`] trait. The
//! firmware implements [`TxDma`] for DMA1 stream 3 (and, under QEMU, for blocking writes);
//! the host tests below implement it with a recording mock.
//!
//! **Buffers.** Two packet buffers and one piece buffer take turns. The stream always holds one
//! buffer (the one it sends or sent last) and gives it back when the next transfer starts, so
//! the request interrupt only ever fills a buffer the stream is not reading.
//!
//! **Errors.** A transfer error, a start the stream refuses, or no free buffer ends the answer
//! at once (the link never stays busy) and counts in [`TxLink::dma_errors`].

use dima_sensorboard::{InfoPieceCycle, INFO_PIECE_LEN, PACKET_LEN};

use crate::request::{AfterTransfer, Answer, RequestHandler};

/// A DMA stream that sends one buffer at a time to the transmitter.
pub trait TxDma {
    /// A buffer the stream can own while it sends it (`&'static mut [u8]` on the board).
    type Buffer: core::ops::DerefMut<Target = [u8]>;

    /// Starts sending all of `buffer`. `Ok` gives back the buffer the stream held before (free
    /// to fill again); `Err` gives back `buffer` when the stream refused to start.
    ///
    /// # Errors
    /// The refused buffer.
    fn start(&mut self, buffer: Self::Buffer) -> Result<Self::Buffer, Self::Buffer>;

    /// The stream's transfer-complete flag.
    fn is_done(&self) -> bool;

    /// The stream's transfer-error flag.
    fn error(&self) -> bool;

    /// Clears the stream's interrupt flags.
    fn clear(&mut self);
}

/// The link's transmit side: request state, buffer rotation and info pieces over a
/// [`TxDma`].
#[derive(Debug)]
pub struct TxLink<D: TxDma> {
    dma: D,
    handler: RequestHandler,
    spare_packets: [Option<D::Buffer>; 2],
    spare_piece: Option<D::Buffer>,
    pieces: InfoPieceCycle,
    dma_errors: u32,
    completed: u32,
}

impl<D: TxDma> TxLink<D> {
    /// Takes the stream (holding the piece buffer, not started) and the two packet buffers
    /// ([`PACKET_LEN`] bytes each; the piece buffer is [`INFO_PIECE_LEN`]).
    pub fn new(dma: D, packet_a: D::Buffer, packet_b: D::Buffer) -> Self {
        Self {
            dma,
            handler: RequestHandler::new(),
            spare_packets: [Some(packet_a), Some(packet_b)],
            spare_piece: None,
            pieces: InfoPieceCycle::new(),
            dma_errors: 0,
            completed: 0,
        }
    }

    /// A request edge at `now_ms` with the latest complete packet, if one exists: starts
    /// sending it, or skips (a transfer is running) or ignores (no packet yet) the request.
    pub fn on_request(&mut self, now_ms: u32, packet: Option<&[u8; PACKET_LEN]>) -> Answer {
        let answer = self.handler.on_request(now_ms, packet.is_some());
        if let (Answer::Send, Some(packet)) = (answer, packet) {
            let spare = self.spare_packets.iter_mut().find_map(Option::take);
            if !self.send(spare, packet) {
                self.handler.end_answer();
            }
        }
        answer
    }

    /// The stream's interrupt: true if a transfer ended (completed or failed). After a packet
    /// the next info piece goes out, if one is due.
    pub fn on_dma_interrupt(&mut self) -> bool {
        let (done, error) = (self.dma.is_done(), self.dma.error());
        self.dma.clear();
        if error {
            self.count_error();
            self.handler.end_answer();
            return true;
        }
        if !done {
            return false;
        }
        match self.handler.on_transfer_complete() {
            AfterTransfer::SendPiece { restart } => {
                self.completed = self.completed.wrapping_add(1);
                let started = match self.pieces.next(restart) {
                    Some(piece) => {
                        let piece = *piece;
                        let spare = self.spare_piece.take();
                        self.send(spare, &piece)
                    }
                    None => false,
                };
                if started {
                    self.handler.piece_started();
                } else {
                    self.handler.end_answer();
                }
            }
            AfterTransfer::Idle => self.completed = self.completed.wrapping_add(1),
            AfterTransfer::Spurious => return false,
        }
        true
    }

    /// A new info snapshot (sent once the current one is out): from the sampling task. The
    /// pieces of a version 2 or 3 info frame.
    pub fn publish_pieces(&mut self, set: &[[u8; INFO_PIECE_LEN]]) {
        self.pieces.publish(set);
    }

    /// True while a packet or piece is going out.
    #[must_use]
    pub fn is_busy(&self) -> bool {
        self.handler.is_busy()
    }

    /// Requests skipped because a transfer was still running.
    #[must_use]
    pub fn skipped(&self) -> u32 {
        self.handler.skipped()
    }

    /// Requests that came before the first complete packet existed.
    #[must_use]
    pub fn not_ready(&self) -> u32 {
        self.handler.not_ready()
    }

    /// Transfer errors, refused starts and answers without a free buffer.
    #[must_use]
    pub fn dma_errors(&self) -> u32 {
        self.dma_errors
    }

    /// Transfers completed (packets and pieces).
    #[must_use]
    pub fn completed(&self) -> u32 {
        self.completed
    }

    /// The stream, e.g. to read its registers in a test.
    pub fn dma(&self) -> &D {
        &self.dma
    }

    /// Copies `bytes` into `buffer` and starts it; false (counted) when there is no buffer or
    /// the stream refuses.
    fn send(&mut self, buffer: Option<D::Buffer>, bytes: &[u8]) -> bool {
        let Some(mut buffer) = buffer else {
            self.count_error();
            return false;
        };
        if buffer.len() != bytes.len() {
            self.put_back(buffer);
            self.count_error();
            return false;
        }
        buffer.copy_from_slice(bytes);
        match self.dma.start(buffer) {
            Ok(previous) => {
                self.put_back(previous);
                true
            }
            Err(refused) => {
                self.put_back(refused);
                self.count_error();
                false
            }
        }
    }

    fn put_back(&mut self, buffer: D::Buffer) {
        if buffer.len() == INFO_PIECE_LEN {
            self.spare_piece = Some(buffer);
        } else if let Some(slot) = self.spare_packets.iter_mut().find(|slot| slot.is_none()) {
            *slot = Some(buffer);
        }
    }

    fn count_error(&mut self) {
        self.dma_errors = self.dma_errors.wrapping_add(1);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec;
    use std::vec::Vec;

    use super::*;
    use dima_sensorboard::{InfoFrame, Stm32Crc, StreamDecoder, INFO_V2_PIECES};

    /// A DMA stream that records what it sent. It holds one buffer, like the real one.
    #[derive(Debug, Default)]
    struct MockDma {
        held: Option<Vec<u8>>,
        /// Copies of the buffers the stream was started on, in order.
        sent: Vec<Vec<u8>>,
        done: bool,
        error: bool,
        refuse: bool,
    }

    impl TxDma for MockDma {
        type Buffer = Vec<u8>;

        fn start(&mut self, buffer: Vec<u8>) -> Result<Vec<u8>, Vec<u8>> {
            if self.refuse {
                return Err(buffer);
            }
            self.sent.push(buffer.clone());
            let previous = self.held.replace(buffer);
            Ok(previous.expect("the stream always holds a buffer"))
        }
        fn is_done(&self) -> bool {
            self.done
        }
        fn error(&self) -> bool {
            self.error
        }
        fn clear(&mut self) {
            self.done = false;
            self.error = false;
        }
    }

    fn link() -> TxLink<MockDma> {
        let dma = MockDma {
            held: Some(vec![0; INFO_PIECE_LEN]),
            ..MockDma::default()
        };
        TxLink::new(dma, vec![0; PACKET_LEN], vec![0; PACKET_LEN])
    }

    fn packet(n: u8) -> [u8; PACKET_LEN] {
        [n; PACKET_LEN]
    }

    fn complete(link: &mut TxLink<MockDma>) -> bool {
        link.dma.done = true;
        link.on_dma_interrupt()
    }

    fn snapshot(n: u8) -> dima_sensorboard::InfoPieceSet {
        InfoFrame {
            uptime_ms: u32::from(n),
            ..InfoFrame::default()
        }
        .encode_v2_pieces_with(n, &mut Stm32Crc)
    }

    #[test]
    fn buffers_take_turns_and_the_stream_never_gets_the_one_it_holds() {
        let mut link = link();
        link.publish_pieces(&snapshot(1));
        let mut previous: Option<*const u8> = None;
        for n in 0..20u8 {
            assert_eq!(
                link.on_request(u32::from(n) * 4, Some(&packet(n))),
                Answer::Send
            );
            let held = link.dma.held.as_ref().unwrap().as_ptr();
            assert_ne!(
                Some(held),
                previous,
                "answer {n}: a buffer refilled while held"
            );
            assert!(complete(&mut link));
            if link.is_busy() {
                assert!(complete(&mut link), "piece");
            }
            previous = Some(link.dma.held.as_ref().unwrap().as_ptr());
            assert!(!link.is_busy());
        }
        let packets: Vec<&Vec<u8>> = link
            .dma
            .sent
            .iter()
            .filter(|b| b.len() == PACKET_LEN)
            .collect();
        assert_eq!(packets.len(), 20);
        for (n, sent) in packets.iter().enumerate() {
            assert_eq!(sent.as_slice(), &packet(n as u8)[..]);
        }
        assert_eq!(link.dma_errors(), 0);
        assert_eq!(link.completed(), 20 + INFO_V2_PIECES as u32);
    }

    #[test]
    fn the_host_gets_one_record_per_snapshot_behind_its_packets() {
        let mut link = link();
        let mut decoder = StreamDecoder::new();
        let mut records = 0;
        for n in 0..40u8 {
            if n % 20 == 0 {
                link.publish_pieces(&snapshot(n));
            }
            let real = dima_sensorboard::SensorPacket::default().encode();
            link.on_request(u32::from(n) * 4, Some(&real));
            complete(&mut link);
            if link.is_busy() {
                complete(&mut link);
            }
        }
        for sent in &link.dma.sent {
            records += decoder
                .frames(sent)
                .filter(|f| matches!(f, dima_sensorboard::Frame::Info(_)))
                .count();
        }
        assert_eq!(records, 2);
        assert_eq!(decoder.stats().packets, 40);
        assert_eq!(decoder.stats().info_records_dropped, 0);
    }

    #[test]
    fn a_request_during_a_transfer_is_skipped_and_counted() {
        let mut link = link();
        link.publish_pieces(&snapshot(1));
        assert_eq!(link.on_request(0, Some(&packet(1))), Answer::Send);
        assert_eq!(link.on_request(1, Some(&packet(2))), Answer::Skip);
        complete(&mut link);
        assert!(link.is_busy(), "the piece is going out");
        assert_eq!(link.on_request(3, Some(&packet(3))), Answer::Skip);
        complete(&mut link);
        assert_eq!(link.skipped(), 2);
        assert_eq!(
            link.dma.sent.len(),
            2,
            "packet 1 and its piece, nothing torn"
        );
        assert_eq!(link.on_request(4, Some(&packet(4))), Answer::Send);
    }

    #[test]
    fn nothing_goes_out_before_a_packet_exists() {
        let mut link = link();
        assert_eq!(link.on_request(0, None), Answer::NotReady);
        assert_eq!(link.not_ready(), 1);
        assert!(link.dma.sent.is_empty());
        assert!(!link.is_busy());
    }

    #[test]
    fn without_a_snapshot_the_answer_is_the_packet_alone() {
        let mut link = link();
        link.on_request(0, Some(&packet(1)));
        assert!(complete(&mut link));
        assert!(!link.is_busy());
        assert_eq!(link.dma.sent.len(), 1);
    }

    #[test]
    fn a_transfer_error_is_counted_and_ends_the_answer() {
        let mut link = link();
        link.publish_pieces(&snapshot(1));
        link.on_request(0, Some(&packet(1)));
        link.dma.error = true;
        assert!(link.on_dma_interrupt());
        assert_eq!(link.dma_errors(), 1);
        assert!(!link.is_busy(), "the link never stays busy");
        assert_eq!(link.completed(), 0);
        // The next request is served.
        assert_eq!(link.on_request(4, Some(&packet(2))), Answer::Send);
        assert!(complete(&mut link));
        assert!(link.is_busy(), "and its piece follows");
    }

    #[test]
    fn a_refused_start_is_counted_and_ends_the_answer() {
        let mut link = link();
        link.publish_pieces(&snapshot(1));
        link.dma.refuse = true;
        assert_eq!(link.on_request(0, Some(&packet(1))), Answer::Send);
        assert_eq!(link.dma_errors(), 1);
        assert!(!link.is_busy());
        // The refused buffer came back: the rotation still has both packet buffers.
        link.dma.refuse = false;
        for n in 0..4u8 {
            assert_eq!(
                link.on_request(4 + u32::from(n), Some(&packet(n))),
                Answer::Send
            );
            complete(&mut link);
            complete(&mut link);
        }
        assert_eq!(link.dma_errors(), 1);
        // A refused piece ends that answer after its packet.
        link.on_request(100, Some(&packet(9)));
        link.dma.refuse = true;
        assert!(complete(&mut link));
        assert_eq!(link.dma_errors(), 2);
        assert!(!link.is_busy());
    }

    #[test]
    fn a_spurious_interrupt_is_not_a_completion() {
        let mut link = link();
        assert!(!link.on_dma_interrupt(), "no flag");
        assert!(!complete(&mut link), "done flag while idle");
        assert_eq!(link.completed(), 0);
    }
}
