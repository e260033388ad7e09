//! Finding packets, info frames and info pieces in a byte stream (sans-IO).
//!
//! The decoder keeps at most one frame's worth of bytes ([`StreamDecoder::CAPACITY`]), the
//! record being reassembled from info pieces, and its counters. A candidate starts at a `$`
//! followed by `$` (packet), `I` (info frame) or `H` (info piece). When a candidate fails its
//! CRC or header check, only its first byte is dropped and the search restarts at the next `$`
//! **inside** the rejected bytes, so a good frame right behind a torn one is still found.
//!
//! **Independent of chunking.** The decoder decides only at byte boundaries: after every byte
//! it settles what that byte completes (the front candidate, or a valid frame that ends at
//! this byte inside the front candidate's bytes) before it looks at the next byte. So the
//! frames, their order and every counter are the same for any split of the same bytes into
//! reads (and for [`StreamDecoder::push`] byte by byte). At most one frame completes per byte.

use crate::crc::Stm32Crc;
use crate::info::{info_frame_len, InfoFrame, INFO_MAX_LEN, INFO_START};
use crate::packet::{RawPacket, PACKET_LEN, PACKET_START};
use crate::piece::{InfoPiece, Reassembler, INFO_PIECE_LEN, INFO_PIECE_START};

/// One complete, CRC-checked frame from the sensor board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Frame {
    /// A 132-byte sensor packet.
    Packet(RawPacket),
    /// An info record (calibration and health): a whole `$I` frame, or one reassembled from
    /// its `$H` pieces.
    Info(InfoFrame),
}

/// What the decoder has seen since it was created. All counters wrap on overflow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecoderStats {
    /// Packets that passed the CRC.
    pub packets: u64,
    /// Info records handed out: whole info frames that passed the header check and the CRC,
    /// and records reassembled from info pieces.
    pub info_frames: u64,
    /// Candidates (packet, info frame or info piece) whose CRC did not match.
    pub crc_errors: u64,
    /// Bytes dropped because they were not part of a valid frame.
    pub bytes_skipped: u64,
    /// Info pieces that passed the header check and the CRC.
    pub info_pieces: u64,
    /// Info records lost because a piece was missing or bad, came from another snapshot, or
    /// the reassembled bytes were not a valid info frame.
    pub info_records_dropped: u64,
}

/// The largest of the two frames: the buffer never holds more.
const BUFFER_LEN: usize = if INFO_MAX_LEN > PACKET_LEN {
    INFO_MAX_LEN
} else {
    PACKET_LEN
};

const DOLLAR: u8 = b'$';

/// The shortest frame: an info piece.
const MIN_FRAME_LEN: usize = INFO_PIECE_LEN;

/// A valid frame found in the buffer.
enum Found {
    /// A packet or a whole info frame.
    Frame(Frame),
    /// An info piece, for the reassembler.
    Piece(InfoPiece),
}

/// What the bytes at the front of the buffer are.
enum Step {
    /// The front is a valid frame of this many bytes.
    Frame(Found, usize),
    /// Drop this many bytes from the front (counted as skipped).
    Reject(usize),
    /// The candidate at the front failed its CRC: drop its first byte.
    CrcError,
    /// The candidate at the front needs more bytes.
    NeedMore,
}

/// Sans-IO decoder for the board's byte stream: push bytes in any chunking, get frames out.
///
/// ```
/// use dima_sensorboard::{Frame, SensorPacket, StreamDecoder};
///
/// let packet = SensorPacket { gyro: [1, -2, 3], ..SensorPacket::default() };
/// let bytes = packet.encode();
///
/// let mut decoder = StreamDecoder::new();
/// let mut found = 0;
/// // Garbage, then the packet split in two reads.
/// for chunk in [&b"noise$"[..], &bytes[..50], &bytes[50..]] {
///     for frame in decoder.frames(chunk) {
///         if let Frame::Packet(raw) = frame {
///             assert_eq!(raw.decode(), packet);
///             found += 1;
///         }
///     }
/// }
/// assert_eq!(found, 1);
/// assert_eq!(decoder.stats().bytes_skipped, 6);
/// ```
#[derive(Debug, Clone)]
pub struct StreamDecoder {
    buf: [u8; BUFFER_LEN],
    len: usize,
    /// Candidates after the front that end at or before this length were already checked.
    nested_checked: usize,
    /// The info record being put back together from its pieces.
    pieces: Reassembler,
    stats: DecoderStats,
}

impl Default for StreamDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl StreamDecoder {
    /// Bytes the decoder can hold: the longest frame it accepts.
    pub const CAPACITY: usize = BUFFER_LEN;

    /// An empty decoder with zeroed counters.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            buf: [0; BUFFER_LEN],
            len: 0,
            nested_checked: 0,
            pieces: Reassembler::new(),
            stats: DecoderStats {
                packets: 0,
                info_frames: 0,
                crc_errors: 0,
                bytes_skipped: 0,
                info_pieces: 0,
                info_records_dropped: 0,
            },
        }
    }

    /// The counters.
    #[must_use]
    pub const fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Bytes held that may still become part of a frame.
    #[must_use]
    pub const fn buffered_len(&self) -> usize {
        self.len
    }

    /// Drops the buffered bytes (counted as skipped), e.g. after reopening the port.
    pub fn clear(&mut self) {
        self.skip(self.len);
    }

    /// Takes bytes from the front of `input` until a frame completes and returns it; `input` is
    /// advanced past what was consumed. Call again with the same `input` for further frames.
    ///
    /// `None` means every byte of `input` was consumed and no complete frame is buffered.
    pub fn feed(&mut self, input: &mut &[u8]) -> Option<Frame> {
        loop {
            if let Some(frame) = self.settle() {
                return Some(frame);
            }
            if self.len == 0 {
                // Nothing buffered: jump straight to the next start byte (the bytes before it
                // would each be skipped on their own).
                let start = input
                    .iter()
                    .position(|&b| b == DOLLAR)
                    .unwrap_or(input.len());
                self.count_skipped(start);
                *input = &input[start..];
            }
            // One byte at a time: what a byte completes is settled before the next is looked
            // at, so the outcome cannot depend on how the input was split.
            let (&byte, rest) = input.split_first()?;
            *input = rest;
            self.append_one(byte);
        }
    }

    /// Feeds one byte; returns a frame if one completed.
    ///
    /// The byte is always consumed. Equivalent to [`StreamDecoder::feed`] with a one-byte
    /// input.
    pub fn push(&mut self, byte: u8) -> Option<Frame> {
        // A frame is only ever complete right after the byte that ends it, and at most one per
        // byte, so nothing is waiting here; should one be, it goes first and the byte is kept.
        if let Some(frame) = self.settle() {
            self.append_one(byte);
            return Some(frame);
        }
        self.feed(&mut core::slice::from_ref(&byte))
    }

    /// Returns a frame that is already complete in the buffer, without new input.
    pub fn next_buffered(&mut self) -> Option<Frame> {
        self.settle()
    }

    /// Iterates over the frames in `data`, consuming it as the iteration goes. Bytes after the
    /// last complete frame stay buffered for the next call. Dropping the iterator early leaves
    /// the bytes it has not reached unconsumed (see [`Frames::remaining`]).
    pub fn frames<'d, 'a>(&'d mut self, data: &'a [u8]) -> Frames<'d, 'a> {
        Frames {
            decoder: self,
            input: data,
        }
    }

    /// Settles the buffered bytes: rejects what cannot be a frame, takes out complete frames,
    /// and returns the first packet or info record that results.
    fn settle(&mut self) -> Option<Frame> {
        loop {
            match self.examine() {
                Step::Frame(found, len) => {
                    self.drain(len);
                    if let Some(frame) = self.take_found(found) {
                        return Some(frame);
                    }
                }
                Step::Reject(count) => self.skip(count),
                Step::CrcError => {
                    self.stats.crc_errors = self.stats.crc_errors.wrapping_add(1);
                    self.skip(1);
                }
                Step::NeedMore => {
                    let (start, found, len) = self.nested_frame()?;
                    self.skip(start);
                    self.drain(len);
                    if let Some(frame) = self.take_found(found) {
                        return Some(frame);
                    }
                }
            }
        }
    }

    fn append_one(&mut self, byte: u8) {
        if self.len == BUFFER_LEN {
            // Cannot happen (a candidate never needs more than the buffer holds), but progress
            // must not depend on that: drop the front byte.
            self.skip(1);
        }
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = byte;
            self.len += 1;
        }
    }

    /// Counts a frame taken out of the buffer; a piece goes to the reassembler and yields a
    /// frame only when it completes a record.
    fn take_found(&mut self, found: Found) -> Option<Frame> {
        let frame = match found {
            Found::Frame(frame) => frame,
            Found::Piece(piece) => {
                self.stats.info_pieces = self.stats.info_pieces.wrapping_add(1);
                let outcome = self.pieces.push(&piece, &mut Stm32Crc);
                self.stats.info_records_dropped = self
                    .stats
                    .info_records_dropped
                    .wrapping_add(u64::from(outcome.dropped));
                Frame::Info(outcome.record?)
            }
        };
        match frame {
            Frame::Packet(_) => self.stats.packets = self.stats.packets.wrapping_add(1),
            Frame::Info(_) => self.stats.info_frames = self.stats.info_frames.wrapping_add(1),
        }
        Some(frame)
    }

    /// While the candidate at the front is still incomplete, looks for a complete, valid frame
    /// that starts later in the buffer (its start, the frame and its length).
    ///
    /// A false start in noise (a stray `$$`, or `$I` with a large length) would otherwise hold
    /// a real frame behind it until enough further bytes arrive to reject it: with a board that
    /// only answers requests, that is a whole request period late. A valid CRC inside the
    /// buffer settles it at once.
    ///
    /// The work is incremental: only candidates whose last byte arrived since the previous
    /// call are checked (a CRC at most once per candidate), however many false starts the
    /// buffer holds. Of the frames found, the one that starts first wins; the candidates after
    /// it are looked at again once it is taken out.
    fn nested_frame(&mut self) -> Option<(usize, Found, usize)> {
        let (checked, len) = (self.nested_checked, self.len);
        if checked >= len {
            return None;
        }
        // No frame is longer than the buffer, so a candidate ending after `checked` starts
        // less than a buffer length before it.
        let lowest = (checked + 1).saturating_sub(BUFFER_LEN).max(1);
        for start in lowest..=len.saturating_sub(MIN_FRAME_LEN) {
            let Some(end) = self.candidate_end(start) else {
                continue;
            };
            if end <= checked || end > len {
                continue;
            }
            if let Step::Frame(frame, frame_len) = Self::examine_candidate(&self.buf[start..len]) {
                return Some((start, frame, frame_len));
            }
        }
        self.nested_checked = len;
        None
    }

    /// Where the candidate starting at `start` ends: a packet after [`PACKET_LEN`] bytes, an
    /// info frame after the length its header announces; `None` when no frame starts there.
    fn candidate_end(&self, start: usize) -> Option<usize> {
        match self.buf.get(start..start + 2)? {
            [DOLLAR, second] if *second == PACKET_START[1] => Some(start + PACKET_LEN),
            [DOLLAR, second] if *second == INFO_START[1] => self.info_end(start),
            [DOLLAR, second] if *second == INFO_PIECE_START[1] => Some(start + INFO_PIECE_LEN),
            _ => None,
        }
    }

    /// Where the info candidate starting at `start` ends, if it has a valid header.
    fn info_end(&self, start: usize) -> Option<usize> {
        match self.buf.get(start..start + 4)? {
            &[DOLLAR, second, version, payload_len] if second == INFO_START[1] => {
                info_frame_len([DOLLAR, second, version, payload_len])
                    .ok()
                    .map(|total| start + total)
            }
            _ => None,
        }
    }

    fn examine(&self) -> Step {
        let buf = &self.buf[..self.len];
        match buf {
            [] => Step::NeedMore,
            [first, rest @ ..] if *first != DOLLAR => {
                Step::Reject(1 + rest.iter().position(|&b| b == DOLLAR).unwrap_or(rest.len()))
            }
            [_] => Step::NeedMore,
            _ => Self::examine_candidate(buf),
        }
    }

    /// Examines a candidate that starts with `$` and has at least two bytes.
    fn examine_candidate(buf: &[u8]) -> Step {
        match buf {
            [_, second, ..] if *second == PACKET_START[1] => Self::examine_packet(buf),
            [_, second, ..] if *second == INFO_START[1] => Self::examine_info(buf),
            [_, second, ..] if *second == INFO_PIECE_START[1] => Self::examine_piece(buf),
            _ => Step::Reject(1),
        }
    }

    fn examine_packet(buf: &[u8]) -> Step {
        let Some(candidate) = buf.get(..PACKET_LEN) else {
            return Step::NeedMore;
        };
        let mut bytes = [0u8; PACKET_LEN];
        bytes.copy_from_slice(candidate);
        match RawPacket::new_with(bytes, &mut Stm32Crc) {
            Ok(raw) => Step::Frame(Found::Frame(Frame::Packet(raw)), PACKET_LEN),
            Err(_) => Step::CrcError,
        }
    }

    fn examine_info(buf: &[u8]) -> Step {
        let header = match buf {
            [a, b, c, d, ..] => [*a, *b, *c, *d],
            _ => return Step::NeedMore,
        };
        let Ok(total) = info_frame_len(header) else {
            return Step::Reject(1);
        };
        if buf.len() < total {
            return Step::NeedMore;
        }
        match InfoFrame::decode_with(buf, &mut Stm32Crc) {
            Ok((info, len)) => Step::Frame(Found::Frame(Frame::Info(info)), len),
            Err(_) => Step::CrcError,
        }
    }

    fn examine_piece(buf: &[u8]) -> Step {
        if buf.len() < INFO_PIECE_LEN {
            return Step::NeedMore;
        }
        match InfoPiece::decode_with(buf, &mut Stm32Crc) {
            Ok(piece) => Step::Frame(Found::Piece(piece), INFO_PIECE_LEN),
            Err(crate::piece::InfoPieceError::Checksum { .. }) => Step::CrcError,
            Err(_) => Step::Reject(1),
        }
    }

    fn count_skipped(&mut self, count: usize) {
        self.stats.bytes_skipped = self.stats.bytes_skipped.wrapping_add(count as u64);
    }

    /// Drops `count` bytes from the front, counted as skipped.
    fn skip(&mut self, count: usize) {
        let count = count.min(self.len);
        self.count_skipped(count);
        self.drain(count);
    }

    fn drain(&mut self, count: usize) {
        let count = count.min(self.len);
        self.buf.copy_within(count..self.len, 0);
        self.len -= count;
        self.nested_checked = self.nested_checked.saturating_sub(count);
    }
}

/// Iterator over the frames in one chunk of input; see [`StreamDecoder::frames`].
#[derive(Debug)]
pub struct Frames<'d, 'a> {
    decoder: &'d mut StreamDecoder,
    input: &'a [u8],
}

impl<'a> Frames<'_, 'a> {
    /// Input bytes not consumed yet.
    #[must_use]
    pub fn remaining(&self) -> &'a [u8] {
        self.input
    }
}

impl Iterator for Frames<'_, '_> {
    type Item = Frame;

    fn next(&mut self) -> Option<Frame> {
        self.decoder.feed(&mut self.input)
    }
}
