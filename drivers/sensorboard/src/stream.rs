//! Finding packets and info frames in a byte stream (sans-IO).
//!
//! The decoder keeps at most one frame's worth of bytes ([`StreamDecoder::CAPACITY`]) and no
//! other state than its counters. A candidate starts at a `$` followed by `$` (packet) or `I`
//! (info frame). When a candidate fails its CRC or header check, only its first byte is
//! dropped and the search restarts at the next `$` **inside** the rejected bytes, so a good
//! frame right behind a torn one is still found.

use crate::crc::Stm32Crc;
use crate::info::{info_frame_len, InfoFrame, INFO_MAX_LEN, INFO_START, INFO_V1_LEN};
use crate::packet::{RawPacket, PACKET_LEN, PACKET_START};

/// One complete, CRC-checked frame from the sensor board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Frame {
    /// A 132-byte sensor packet.
    Packet(RawPacket),
    /// An info frame (calibration and health).
    Info(InfoFrame),
}

/// What the decoder has seen since it was created. All counters wrap on overflow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecoderStats {
    /// Packets that passed the CRC.
    pub packets: u64,
    /// Info frames that passed the header check and the CRC.
    pub info_frames: u64,
    /// Candidates (packet or info frame) whose CRC did not match.
    ///
    /// A false start in noise is counted when its announced end arrives before a real frame
    /// behind it settles it, so this count can depend on how the bytes were chunked; the frames
    /// found and the packet and info-frame counts do not.
    pub crc_errors: u64,
    /// Bytes dropped because they were not part of a valid frame.
    pub bytes_skipped: u64,
}

/// The largest of the two frames: the buffer never holds more.
const BUFFER_LEN: usize = if INFO_MAX_LEN > PACKET_LEN {
    INFO_MAX_LEN
} else {
    PACKET_LEN
};

const DOLLAR: u8 = b'$';

/// The shortest frame: a version 1 info frame.
const MIN_FRAME_LEN: usize = INFO_V1_LEN;

/// What the bytes at the front of the buffer are.
enum Step {
    /// The front is a valid frame of this many bytes.
    Frame(Frame, usize),
    /// Drop this many bytes from the front (counted as skipped).
    Reject(usize),
    /// The candidate at the front failed its CRC: drop its first byte.
    CrcError,
    /// The candidate at the front needs this many more bytes.
    NeedMore(usize),
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
            stats: DecoderStats {
                packets: 0,
                info_frames: 0,
                crc_errors: 0,
                bytes_skipped: 0,
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
            match self.examine() {
                Step::Frame(frame, len) => return Some(self.take_frame(frame, len)),
                Step::Reject(count) => self.skip(count),
                Step::CrcError => {
                    self.stats.crc_errors = self.stats.crc_errors.wrapping_add(1);
                    self.skip(1);
                }
                Step::NeedMore(count) => {
                    if let Some((start, frame, len)) = self.nested_frame() {
                        self.skip(start);
                        return Some(self.take_frame(frame, len));
                    }
                    if input.is_empty() {
                        return None;
                    }
                    if self.len == 0 {
                        // Nothing buffered: jump straight to the next start byte.
                        let start = input
                            .iter()
                            .position(|&b| b == DOLLAR)
                            .unwrap_or(input.len());
                        self.count_skipped(start);
                        *input = &input[start..];
                        if input.is_empty() {
                            return None;
                        }
                    }
                    let take = count.min(input.len()).min(BUFFER_LEN - self.len);
                    if take == 0 {
                        // Cannot happen (a candidate never needs more than the buffer holds),
                        // but progress must not depend on that: drop the front byte.
                        self.skip(1);
                        continue;
                    }
                    let (head, rest) = input.split_at(take);
                    self.buf[self.len..self.len + take].copy_from_slice(head);
                    self.len += take;
                    *input = rest;
                }
            }
        }
    }

    /// Feeds one byte; returns a frame if one completed.
    ///
    /// The byte is always consumed. Rarely (after a rejected candidate) more than one frame can
    /// become complete at once; the next call, or [`StreamDecoder::next_buffered`], returns it.
    pub fn push(&mut self, byte: u8) -> Option<Frame> {
        // A complete frame can only be waiting if at least the shortest frame is buffered.
        if self.len < MIN_FRAME_LEN {
            return self.feed(&mut core::slice::from_ref(&byte));
        }
        if let Some(frame) = self.next_buffered() {
            // Keep the byte: the buffer has room, since a frame was just taken out of it.
            self.append_one(byte);
            return Some(frame);
        }
        self.feed(&mut core::slice::from_ref(&byte))
    }

    /// Returns a frame that is already complete in the buffer, without new input.
    pub fn next_buffered(&mut self) -> Option<Frame> {
        self.feed(&mut &[][..])
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

    fn append_one(&mut self, byte: u8) {
        if self.len == BUFFER_LEN {
            self.skip(1);
        }
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = byte;
            self.len += 1;
        }
    }

    fn take_frame(&mut self, frame: Frame, len: usize) -> Frame {
        self.drain(len);
        match frame {
            Frame::Packet(_) => self.stats.packets = self.stats.packets.wrapping_add(1),
            Frame::Info(_) => self.stats.info_frames = self.stats.info_frames.wrapping_add(1),
        }
        frame
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
    fn nested_frame(&mut self) -> Option<(usize, Frame, usize)> {
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
            [] => Step::NeedMore(1),
            [first, rest @ ..] if *first != DOLLAR => {
                Step::Reject(1 + rest.iter().position(|&b| b == DOLLAR).unwrap_or(rest.len()))
            }
            [_] => Step::NeedMore(1),
            _ => Self::examine_candidate(buf),
        }
    }

    /// Examines a candidate that starts with `$` and has at least two bytes.
    fn examine_candidate(buf: &[u8]) -> Step {
        match buf {
            [_, second, ..] if *second == PACKET_START[1] => Self::examine_packet(buf),
            [_, second, ..] if *second == INFO_START[1] => Self::examine_info(buf),
            _ => Step::Reject(1),
        }
    }

    fn examine_packet(buf: &[u8]) -> Step {
        let Some(candidate) = buf.get(..PACKET_LEN) else {
            return Step::NeedMore(PACKET_LEN - buf.len());
        };
        let mut bytes = [0u8; PACKET_LEN];
        bytes.copy_from_slice(candidate);
        match RawPacket::new_with(bytes, &mut Stm32Crc) {
            Ok(raw) => Step::Frame(Frame::Packet(raw), PACKET_LEN),
            Err(_) => Step::CrcError,
        }
    }

    fn examine_info(buf: &[u8]) -> Step {
        let header = match buf {
            [a, b, c, d, ..] => [*a, *b, *c, *d],
            _ => return Step::NeedMore(4 - buf.len()),
        };
        let Ok(total) = info_frame_len(header) else {
            return Step::Reject(1);
        };
        if buf.len() < total {
            return Step::NeedMore(total - buf.len());
        }
        match InfoFrame::decode_with(buf, &mut Stm32Crc) {
            Ok((info, len)) => Step::Frame(Frame::Info(info), len),
            Err(_) => Step::CrcError,
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
