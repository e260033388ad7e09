//! Sans-IO UBX framing: checksum, frame view and a resynchronising byte-stream framer.
//!
//! A UBX frame is `B5 62 class id len_lo len_hi payload... CK_A CK_B`, where the two
//! checksum bytes are the 8-bit Fletcher sum over class, id, length and payload.
//! [`UbxFramer`] finds frames in any byte stream, one byte at a time, with a fixed buffer
//! and no allocation. When a candidate turns out to be false (bad second sync byte, a length
//! that does not fit the buffer, a checksum mismatch), only its first byte is dropped and the
//! rest is scanned again, so a real frame hidden behind garbage or a corrupted length field
//! is still found.

use ublox::proto23::{PacketRef, Proto23};
use ublox::{ParserError, UbxProtocol};

/// First UBX sync character.
pub const SYNC_1: u8 = 0xB5;
/// Second UBX sync character.
pub const SYNC_2: u8 = 0x62;
/// Sync (2) + class + id + length (2): bytes before the payload.
pub const HEADER_LEN: usize = 6;
/// Header and checksum: a frame is `FRAME_OVERHEAD + payload length` bytes long.
pub const FRAME_OVERHEAD: usize = 8;

/// 8-bit Fletcher checksum of the UBX protocol over `data` (class, id, length and payload).
///
/// Returns `(CK_A, CK_B)`.
pub fn checksum(data: &[u8]) -> (u8, u8) {
    let mut a = 0u8;
    let mut b = 0u8;
    for &byte in data {
        a = a.wrapping_add(byte);
        b = b.wrapping_add(a);
    }
    (a, b)
}

/// Writes a complete UBX frame (sync, class, id, length, payload, checksum) into `out`.
///
/// Returns the frame length, or `None` if `out` is shorter than `payload.len() + 8` or the
/// payload is longer than 65535 bytes.
pub fn encode_frame(class: u8, id: u8, payload: &[u8], out: &mut [u8]) -> Option<usize> {
    let len = u16::try_from(payload.len()).ok()?;
    let total = payload.len() + FRAME_OVERHEAD;
    let out = out.get_mut(..total)?;
    let [lo, hi] = len.to_le_bytes();
    out[..HEADER_LEN].copy_from_slice(&[SYNC_1, SYNC_2, class, id, lo, hi]);
    out[HEADER_LEN..total - 2].copy_from_slice(payload);
    let (a, b) = checksum(&out[2..total - 2]);
    out[total - 2] = a;
    out[total - 1] = b;
    Some(total)
}

/// A complete, checksum-verified UBX frame borrowed from a framer's buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    bytes: &'a [u8],
}

impl<'a> Frame<'a> {
    /// Checks that `bytes` is exactly one UBX frame with a valid checksum.
    pub fn new(bytes: &'a [u8]) -> Option<Self> {
        if bytes.len() < FRAME_OVERHEAD || bytes[0] != SYNC_1 || bytes[1] != SYNC_2 {
            return None;
        }
        let len = usize::from(u16::from_le_bytes([bytes[4], bytes[5]]));
        if bytes.len() != len + FRAME_OVERHEAD {
            return None;
        }
        let (a, b) = checksum(&bytes[2..bytes.len() - 2]);
        if bytes[bytes.len() - 2] != a || bytes[bytes.len() - 1] != b {
            return None;
        }
        Some(Self { bytes })
    }

    /// The message class (e.g. 0x01 NAV, 0x05 ACK, 0x06 CFG).
    pub fn class(&self) -> u8 {
        self.bytes[2]
    }

    /// The message id within its class (e.g. 0x07 for NAV-PVT).
    pub fn id(&self) -> u8 {
        self.bytes[3]
    }

    /// The payload, without header and checksum.
    pub fn payload(&self) -> &'a [u8] {
        &self.bytes[HEADER_LEN..self.bytes.len() - 2]
    }

    /// The whole frame, sync characters and checksum included, exactly as received.
    pub fn as_bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// Decodes the payload with the `ublox` crate's protocol-23 definitions (M8 receivers).
    ///
    /// Unknown messages come back as `PacketRef::Unknown`; a payload of the wrong length for a
    /// known message is an error.
    pub fn decode(&self) -> Result<PacketRef<'a>, ParserError> {
        Proto23::match_packet(self.class(), self.id(), self.payload())
    }
}

/// Counters kept by a [`UbxFramer`]; they wrap around at `u32::MAX`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FramerStats {
    /// Frames with a valid checksum handed out.
    pub frames_ok: u32,
    /// Candidates whose checksum did not match (corrupted or false sync).
    pub checksum_errors: u32,
    /// Candidates whose length field announced a frame longer than the buffer.
    pub oversized: u32,
    /// Bytes that were not part of any valid frame.
    pub bytes_skipped: u32,
}

/// What one processing step decided about the candidate in the buffer.
enum Step {
    /// Need more bytes.
    More,
    /// `buf[..len]` is a valid frame.
    Frame,
    /// The candidate is false: drop its first byte, rescan the rest.
    Reject,
}

/// Resynchronising UBX framer over a fixed buffer of `N` bytes (sans-IO: push bytes in,
/// get frames out).
///
/// `N` bounds the longest frame that can be received: at least 100 for NAV-PVT
/// (92-byte payload); MON-VER of an M8T is about 40 + 30 x 8 = 280 bytes, so the default of
/// 512 holds every message this crate configures. Longer frames are skipped and counted in
/// [`FramerStats::oversized`].
///
/// Cost: a clean stream costs a few operations per byte. A rejected candidate is rescanned,
/// so adversarial input (a false header with a plausible length at every position) costs
/// up to O(`N`) per byte; a small `N` keeps the worst case small in an interrupt handler.
///
/// ```
/// use neo_m8t::UbxFramer;
///
/// // ACK-ACK for CFG-RATE, split across two chunks with noise in front.
/// let chunks: [&[u8]; 2] = [&[0x00, 0xB5, 0x62, 0x05, 0x01], &[0x02, 0x00, 0x06, 0x08, 0x16, 0x3F]];
/// let mut framer = UbxFramer::<512>::with_capacity();
/// let mut found = 0;
/// for chunk in chunks {
///     for &byte in chunk {
///         if let Some(frame) = framer.push(byte) {
///             assert_eq!((frame.class(), frame.id()), (0x05, 0x01));
///             found += 1;
///         }
///     }
/// }
/// assert_eq!(found, 1);
/// assert_eq!(framer.stats().bytes_skipped, 1);
/// ```
#[derive(Debug, Clone)]
pub struct UbxFramer<const N: usize = 512> {
    buf: [u8; N],
    /// Bytes of the current candidate frame, at `buf[..len]`.
    len: usize,
    /// Bytes still to be rescanned after a rejected candidate, at `buf[pend_start..pend_end]`.
    /// Invariant: `len <= pend_start` whenever the range is not empty.
    pend_start: usize,
    pend_end: usize,
    /// `buf[..len]` was handed out as a frame by the previous call.
    emitted: bool,
    stats: FramerStats,
}

impl<const N: usize> Default for UbxFramer<N> {
    fn default() -> Self {
        Self::with_capacity()
    }
}

impl UbxFramer {
    /// An empty framer with the default 512-byte buffer and zeroed counters.
    pub const fn new() -> Self {
        Self::with_capacity()
    }
}

impl<const N: usize> UbxFramer<N> {
    const MIN_CAPACITY: () = assert!(N >= FRAME_OVERHEAD, "a UBX framer needs at least 8 bytes");

    /// An empty framer with an `N`-byte buffer (`UbxFramer::<100>::with_capacity()`) and zeroed
    /// counters.
    pub const fn with_capacity() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::MIN_CAPACITY;
        Self {
            buf: [0; N],
            len: 0,
            pend_start: 0,
            pend_end: 0,
            emitted: false,
            stats: FramerStats {
                frames_ok: 0,
                checksum_errors: 0,
                oversized: 0,
                bytes_skipped: 0,
            },
        }
    }

    /// Counters since creation (or the last [`reset_stats`](Self::reset_stats)).
    pub fn stats(&self) -> FramerStats {
        self.stats
    }

    /// Bytes held (a partial frame and bytes waiting to be rescanned), not yet counted as
    /// either frame or skipped.
    pub fn buffered(&self) -> usize {
        let candidate = if self.emitted { 0 } else { self.len };
        candidate + (self.pend_end - self.pend_start)
    }

    /// Zeroes the counters.
    pub fn reset_stats(&mut self) {
        self.stats = FramerStats::default();
    }

    /// Drops any partial frame and pending bytes (e.g. after a baud-rate change); the dropped
    /// bytes are counted as skipped.
    pub fn clear(&mut self) {
        if !self.emitted {
            self.skip(self.len);
        }
        self.skip(self.pend_end - self.pend_start);
        self.len = 0;
        self.pend_start = 0;
        self.pend_end = 0;
        self.emitted = false;
    }

    /// Feeds one byte; returns a frame when this byte (or bytes held back from an earlier
    /// rejected candidate) completes one.
    ///
    /// At most one frame is returned per call. When a byte completes more than one frame
    /// (possible only after a corrupted candidate hid a real frame), the next frame comes out
    /// of the next call, or of [`poll_pending`](Self::poll_pending).
    pub fn push(&mut self, byte: u8) -> Option<Frame<'_>> {
        self.release_emitted();
        if self.pend_start == self.pend_end {
            self.pend_start = self.len;
            self.pend_end = self.len;
        } else if self.pend_end == N {
            self.compact_pending();
        }
        // Space is guaranteed: between calls the buffer holds at most N - 1 bytes.
        if let Some(slot) = self.buf.get_mut(self.pend_end) {
            *slot = byte;
            self.pend_end += 1;
        } else {
            self.skip(1);
        }
        self.run()
    }

    /// Returns a frame still held back from an earlier call, without new input.
    ///
    /// Useful after a call that returned a frame, to drain frames that were found behind a
    /// rejected candidate before the caller waits for more bytes.
    pub fn poll_pending(&mut self) -> Option<Frame<'_>> {
        self.release_emitted();
        self.run()
    }

    /// Feeds a slice, calling `on_frame` for every frame found, in order.
    pub fn push_slice(&mut self, bytes: &[u8], mut on_frame: impl FnMut(Frame<'_>)) {
        for &byte in bytes {
            if let Some(frame) = self.push(byte) {
                on_frame(frame);
                while let Some(frame) = self.poll_pending() {
                    on_frame(frame);
                }
            }
        }
    }

    fn release_emitted(&mut self) {
        if self.emitted {
            self.emitted = false;
            self.len = 0;
        }
    }

    fn skip(&mut self, count: usize) {
        self.stats.bytes_skipped = self
            .stats
            .bytes_skipped
            .wrapping_add(u32::try_from(count).unwrap_or(u32::MAX));
    }

    /// Moves the pending bytes down to `buf[len..]`.
    fn compact_pending(&mut self) {
        let count = self.pend_end - self.pend_start;
        move_down(&mut self.buf, self.pend_start..self.pend_end, self.len);
        self.pend_start = self.len;
        self.pend_end = self.len + count;
    }

    /// Moves pending bytes into the candidate until a frame completes or nothing is left.
    fn run(&mut self) -> Option<Frame<'_>> {
        while self.pend_start < self.pend_end {
            // len <= pend_start: the write never overtakes the read.
            self.buf[self.len] = self.buf[self.pend_start];
            self.len += 1;
            self.pend_start += 1;
            match self.step() {
                Step::More => {}
                Step::Frame => {
                    self.stats.frames_ok = self.stats.frames_ok.wrapping_add(1);
                    self.emitted = true;
                    return Some(Frame {
                        bytes: &self.buf[..self.len],
                    });
                }
                Step::Reject => self.reject(),
            }
        }
        self.pend_start = 0;
        self.pend_end = 0;
        None
    }

    fn step(&mut self) -> Step {
        match self.len {
            1 => {
                if self.buf[0] != SYNC_1 {
                    self.skip(1);
                    self.len = 0;
                }
                Step::More
            }
            2 if self.buf[1] != SYNC_2 => Step::Reject,
            0..HEADER_LEN => Step::More,
            _ => {
                let payload = usize::from(u16::from_le_bytes([self.buf[4], self.buf[5]]));
                let total = payload + FRAME_OVERHEAD;
                if total > N {
                    self.stats.oversized = self.stats.oversized.wrapping_add(1);
                    Step::Reject
                } else if self.len < total {
                    Step::More
                } else {
                    let (a, b) = checksum(&self.buf[2..total - 2]);
                    if self.buf[total - 2] == a && self.buf[total - 1] == b {
                        Step::Frame
                    } else {
                        self.stats.checksum_errors = self.stats.checksum_errors.wrapping_add(1);
                        Step::Reject
                    }
                }
            }
        }
    }

    /// Drops the candidate's first byte and queues the rest, ahead of any pending bytes,
    /// for rescanning.
    fn reject(&mut self) {
        self.skip(1);
        let rest = self.len - 1;
        let pending = self.pend_end - self.pend_start;
        // Close the gap between the candidate and the pending bytes, then drop byte 0.
        move_down(&mut self.buf, self.pend_start..self.pend_end, self.len);
        move_down(&mut self.buf, 1..self.len + pending, 0);
        self.len = 0;
        self.pend_start = 0;
        self.pend_end = rest + pending;
    }
}

/// Moves `buf[from]` down to start at `dest` (`dest <= from.start`), one byte at a time, first
/// byte first: right for overlapping ranges moving down. `copy_within` would do the same
/// through `memmove`, which costs a flash-constrained board about 1.5 KiB.
fn move_down(buf: &mut [u8], from: core::ops::Range<usize>, dest: usize) {
    for (offset, source) in from.enumerate() {
        if let Some(&byte) = buf.get(source) {
            if let Some(slot) = buf.get_mut(dest + offset) {
                *slot = byte;
            }
        }
    }
}
