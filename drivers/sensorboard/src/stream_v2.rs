//! Finding version 2 packets, GNSS pieces and info pieces in a byte stream (sans-IO).
//!
//! A separate decoder from the v1 [`crate::StreamDecoder`], which stays as it is: a link
//! speaks one protocol, and the v2 decoder's buffer is one v2 packet (42 bytes), not a v1
//! packet or a whole info frame. It accepts three frames, each starting with `$`:
//! `$P` a [`PacketV2`](crate::PacketV2) (42 bytes), `$G` a [`crate::GnssPiece`] (34 bytes),
//! `$H` an [`crate::InfoPiece`] (21 bytes). v1 packets (`$$`) and whole info frames (`$I`) are
//! not v2 frames: their bytes are skipped.
//!
//! The search works as in the v1 decoder: when a candidate fails its CRC or header check only
//! its first byte is dropped and the search restarts at the next `$` inside the rejected
//! bytes; while the front candidate is incomplete, a complete valid frame later in the buffer
//! is taken out at once; and the decoder settles every byte before it looks at the next, so
//! the frames, their order and every counter are the same for any split of the same bytes.

use crate::crc::Stm32Crc;
use crate::gnss::GnssFrame;
use crate::gnss_piece::{
    GnssPiece, GnssPieceError, GnssReassembler, GNSS_PIECE_LEN, GNSS_PIECE_START,
};
use crate::info::InfoFrame;
use crate::packet_v2::{RawPacketV2, PACKET_V2_LEN, PACKET_V2_START};
use crate::piece::{InfoPiece, InfoPieceError, Reassembler, INFO_PIECE_LEN, INFO_PIECE_START};

/// One complete, CRC-checked item from a version 2 link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameV2 {
    /// A 42-byte version 2 packet.
    Packet(RawPacketV2),
    /// A NAV-PVT frame reassembled from its four GNSS pieces (the same 100 bytes v1 carries).
    Gnss(GnssFrame),
    /// An info record reassembled from its info pieces.
    Info(InfoFrame),
}

/// What the v2 decoder has seen since it was created. All counters wrap on overflow.
///
/// Every input byte is in a packet, a GNSS piece or an info piece, was skipped, or is still
/// held: `packets * 42 + gnss_pieces * 34 + info_pieces * 21 + bytes_skipped + held = input`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecoderStatsV2 {
    /// Packets that passed the CRC.
    pub packets: u64,
    /// GNSS pieces that passed the header check and the CRC.
    pub gnss_pieces: u64,
    /// NAV-PVT frames handed out.
    pub gnss_frames: u64,
    /// NAV-PVT frames lost: a piece missing or bad, a piece of another epoch or out of order.
    pub gnss_frames_dropped: u64,
    /// Info pieces that passed the header check and the CRC.
    pub info_pieces: u64,
    /// Info records handed out.
    pub info_frames: u64,
    /// Info records lost, as [`crate::DecoderStats::info_records_dropped`].
    pub info_records_dropped: u64,
    /// Candidates (packet, GNSS piece or info piece) whose CRC did not match.
    pub crc_errors: u64,
    /// Bytes dropped because they were not part of a valid frame.
    pub bytes_skipped: u64,
}

/// The longest frame: a packet.
const BUFFER_LEN: usize = PACKET_V2_LEN;

/// The shortest frame: an info piece.
const MIN_FRAME_LEN: usize = INFO_PIECE_LEN;

const DOLLAR: u8 = b'$';

/// A valid frame found in the buffer.
enum Found {
    Packet(RawPacketV2),
    Gnss(GnssPiece),
    Info(InfoPiece),
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

/// Sans-IO decoder for a version 2 link: push bytes in any chunking, get [`FrameV2`]s out.
///
/// ```
/// use dima_sensorboard::{FrameV2, PacketV2, Stm32Crc, StreamDecoderV2};
///
/// let packet = PacketV2 { request_count: 7, sample_time_us: 3_500, ..PacketV2::default() };
/// let bytes = packet.encode(&mut Stm32Crc);
///
/// let mut decoder = StreamDecoderV2::new();
/// let mut found = 0;
/// for chunk in [&b"noise$"[..], &bytes[..20], &bytes[20..]] {
///     for frame in decoder.frames(chunk) {
///         if let FrameV2::Packet(raw) = frame {
///             assert_eq!(raw.decode(), packet);
///             found += 1;
///         }
///     }
/// }
/// assert_eq!(found, 1);
/// assert_eq!(decoder.stats().bytes_skipped, 6);
/// ```
#[derive(Debug, Clone)]
pub struct StreamDecoderV2 {
    buf: [u8; BUFFER_LEN],
    len: usize,
    /// Candidates after the front that end at or before this length were already checked.
    nested_checked: usize,
    gnss: GnssReassembler,
    info: Reassembler,
    stats: DecoderStatsV2,
}

impl Default for StreamDecoderV2 {
    fn default() -> Self {
        Self::new()
    }
}

impl StreamDecoderV2 {
    /// Bytes the decoder can hold: the longest frame it accepts.
    pub const CAPACITY: usize = BUFFER_LEN;

    /// An empty decoder with zeroed counters.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            buf: [0; BUFFER_LEN],
            len: 0,
            nested_checked: 0,
            gnss: GnssReassembler::new(),
            info: Reassembler::new(),
            stats: DecoderStatsV2 {
                packets: 0,
                gnss_pieces: 0,
                gnss_frames: 0,
                gnss_frames_dropped: 0,
                info_pieces: 0,
                info_frames: 0,
                info_records_dropped: 0,
                crc_errors: 0,
                bytes_skipped: 0,
            },
        }
    }

    /// The counters.
    #[must_use]
    pub const fn stats(&self) -> DecoderStatsV2 {
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
    pub fn feed(&mut self, input: &mut &[u8]) -> Option<FrameV2> {
        loop {
            if let Some(frame) = self.settle() {
                return Some(frame);
            }
            if self.len == 0 {
                let start = input
                    .iter()
                    .position(|&b| b == DOLLAR)
                    .unwrap_or(input.len());
                self.count_skipped(start);
                *input = &input[start..];
            }
            let (&byte, rest) = input.split_first()?;
            *input = rest;
            self.append_one(byte);
        }
    }

    /// Feeds one byte; returns a frame if one completed. The byte is always consumed.
    pub fn push(&mut self, byte: u8) -> Option<FrameV2> {
        if let Some(frame) = self.settle() {
            self.append_one(byte);
            return Some(frame);
        }
        self.feed(&mut core::slice::from_ref(&byte))
    }

    /// Returns a frame that is already complete in the buffer, without new input.
    pub fn next_buffered(&mut self) -> Option<FrameV2> {
        self.settle()
    }

    /// Iterates over the frames in `data`, consuming it as the iteration goes. Bytes after the
    /// last complete frame stay buffered for the next call.
    pub fn frames<'d, 'a>(&'d mut self, data: &'a [u8]) -> FramesV2<'d, 'a> {
        FramesV2 {
            decoder: self,
            input: data,
        }
    }

    fn settle(&mut self) -> Option<FrameV2> {
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

    /// Counts a frame taken out of the buffer; pieces go to their reassemblers and yield a
    /// frame only when they complete one.
    fn take_found(&mut self, found: Found) -> Option<FrameV2> {
        let stats = &mut self.stats;
        match found {
            Found::Packet(raw) => {
                stats.packets = stats.packets.wrapping_add(1);
                Some(FrameV2::Packet(raw))
            }
            Found::Gnss(piece) => {
                stats.gnss_pieces = stats.gnss_pieces.wrapping_add(1);
                let outcome = self.gnss.push(&piece);
                stats.gnss_frames_dropped = stats
                    .gnss_frames_dropped
                    .wrapping_add(u64::from(outcome.dropped));
                let frame = outcome.frame?;
                stats.gnss_frames = stats.gnss_frames.wrapping_add(1);
                Some(FrameV2::Gnss(frame))
            }
            Found::Info(piece) => {
                stats.info_pieces = stats.info_pieces.wrapping_add(1);
                let outcome = self.info.push(&piece, &mut Stm32Crc);
                stats.info_records_dropped = stats
                    .info_records_dropped
                    .wrapping_add(u64::from(outcome.dropped));
                let record = outcome.record?;
                stats.info_frames = stats.info_frames.wrapping_add(1);
                Some(FrameV2::Info(record))
            }
        }
    }

    /// While the candidate at the front is incomplete, looks for a complete, valid frame that
    /// starts later in the buffer (its start, the frame and its length). Only candidates whose
    /// last byte arrived since the previous call are checked; the first one found wins.
    fn nested_frame(&mut self) -> Option<(usize, Found, usize)> {
        let (checked, len) = (self.nested_checked, self.len);
        if checked >= len {
            return None;
        }
        let lowest = (checked + 1).saturating_sub(BUFFER_LEN).max(1);
        for start in lowest..=len.saturating_sub(MIN_FRAME_LEN) {
            let Some(end) = candidate_len(&self.buf[start..len]).map(|l| start + l) else {
                continue;
            };
            if end <= checked || end > len {
                continue;
            }
            if let Step::Frame(frame, frame_len) = examine_candidate(&self.buf[start..len]) {
                return Some((start, frame, frame_len));
            }
        }
        self.nested_checked = len;
        None
    }

    fn examine(&self) -> Step {
        let buf = &self.buf[..self.len];
        match buf {
            [] => Step::NeedMore,
            [first, rest @ ..] if *first != DOLLAR => {
                Step::Reject(1 + rest.iter().position(|&b| b == DOLLAR).unwrap_or(rest.len()))
            }
            [_] => Step::NeedMore,
            _ => examine_candidate(buf),
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

/// The length of the frame that starts at the front of `buf`; `None` when no v2 frame starts
/// there.
fn candidate_len(buf: &[u8]) -> Option<usize> {
    match buf {
        [DOLLAR, second, ..] if *second == PACKET_V2_START[1] => Some(PACKET_V2_LEN),
        [DOLLAR, second, ..] if *second == GNSS_PIECE_START[1] => Some(GNSS_PIECE_LEN),
        [DOLLAR, second, ..] if *second == INFO_PIECE_START[1] => Some(INFO_PIECE_LEN),
        _ => None,
    }
}

/// Examines a candidate that starts with `$` and has at least two bytes.
fn examine_candidate(buf: &[u8]) -> Step {
    let Some(len) = candidate_len(buf) else {
        return Step::Reject(1);
    };
    if buf.len() < len {
        return Step::NeedMore;
    }
    match buf[1] {
        b if b == PACKET_V2_START[1] => match RawPacketV2::new_with(buf, &mut Stm32Crc) {
            Ok(raw) => Step::Frame(Found::Packet(raw), len),
            Err(_) => Step::CrcError,
        },
        b if b == GNSS_PIECE_START[1] => match GnssPiece::decode_with(buf, &mut Stm32Crc) {
            Ok(piece) => Step::Frame(Found::Gnss(piece), len),
            Err(GnssPieceError::Checksum { .. }) => Step::CrcError,
            Err(_) => Step::Reject(1),
        },
        _ => match InfoPiece::decode_with(buf, &mut Stm32Crc) {
            Ok(piece) => Step::Frame(Found::Info(piece), len),
            Err(InfoPieceError::Checksum { .. }) => Step::CrcError,
            Err(_) => Step::Reject(1),
        },
    }
}

/// Iterator over the frames in one chunk of input; see [`StreamDecoderV2::frames`].
#[derive(Debug)]
pub struct FramesV2<'d, 'a> {
    decoder: &'d mut StreamDecoderV2,
    input: &'a [u8],
}

impl<'a> FramesV2<'_, 'a> {
    /// Input bytes not consumed yet.
    #[must_use]
    pub fn remaining(&self) -> &'a [u8] {
        self.input
    }
}

impl Iterator for FramesV2<'_, '_> {
    type Item = FrameV2;

    fn next(&mut self) -> Option<FrameV2> {
        self.decoder.feed(&mut self.input)
    }
}
