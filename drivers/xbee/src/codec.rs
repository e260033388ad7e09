//! API frame codec (pure, no I/O): checksum, encoder into a caller buffer or any byte sink, and
//! a push-byte decoder that resynchronises on the start delimiter.
//!
//! On the wire a frame is `7E`, a 16-bit big-endian length, the frame data (frame type first)
//! and a checksum: 0xFF minus the low byte of the sum of the frame data. In API 2 everything
//! after the delimiter is escaped (see [`crate::escape`]); length and checksum always describe
//! the unescaped frame data.

use crate::escape::{needs_escape, ESCAPE, ESCAPE_XOR, START_DELIMITER, XOFF, XON};
use crate::frames::Frame;
use crate::types::{ApiEscaping, FrameError};

/// Somewhere to put bytes one at a time: a buffer, a serial port, a counter.
pub trait ByteSink {
    /// Error when the byte cannot be taken.
    type Error;
    /// Takes one byte.
    fn put(&mut self, byte: u8) -> Result<(), Self::Error>;
}

/// A [`ByteSink`] over a caller's slice.
#[derive(Debug)]
pub struct SliceSink<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl<'a> SliceSink<'a> {
    /// Starts writing at the beginning of `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Self { buf, len: 0 }
    }
    /// Number of bytes written so far.
    pub fn len(&self) -> usize {
        self.len
    }
    /// Whether nothing was written yet.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl ByteSink for SliceSink<'_> {
    type Error = FrameError;
    fn put(&mut self, byte: u8) -> Result<(), FrameError> {
        let slot = self
            .buf
            .get_mut(self.len)
            .ok_or(FrameError::BufferTooSmall)?;
        *slot = byte;
        self.len += 1;
        Ok(())
    }
}

/// A [`ByteSink`] that only counts, to size a buffer before encoding.
#[derive(Debug, Default, Clone, Copy)]
pub struct CountingSink(pub usize);

impl ByteSink for CountingSink {
    type Error = core::convert::Infallible;
    fn put(&mut self, _byte: u8) -> Result<(), Self::Error> {
        self.0 += 1;
        Ok(())
    }
}

/// Checksum of frame data: 0xFF minus the low byte of the sum of the bytes.
pub fn checksum(frame_data: &[u8]) -> u8 {
    0xFF - frame_data.iter().fold(0u8, |sum, &b| sum.wrapping_add(b))
}

/// Wraps a sink: escapes (API 2) and sums the frame data for the checksum.
struct FrameSink<'s, K> {
    sink: &'s mut K,
    escaping: ApiEscaping,
    sum: u8,
}

impl<K: ByteSink> FrameSink<'_, K> {
    fn raw(&mut self, byte: u8) -> Result<(), K::Error> {
        if self.escaping == ApiEscaping::Escaped && needs_escape(byte) {
            self.sink.put(ESCAPE)?;
            self.sink.put(byte ^ ESCAPE_XOR)
        } else {
            self.sink.put(byte)
        }
    }
}

impl<K: ByteSink> ByteSink for FrameSink<'_, K> {
    type Error = K::Error;
    fn put(&mut self, byte: u8) -> Result<(), K::Error> {
        self.sum = self.sum.wrapping_add(byte);
        self.raw(byte)
    }
}

/// Errors of [`write_frame`]: the frame is too long, or the sink failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WriteError<E> {
    /// The frame data exceeds the 16-bit length field.
    TooLong,
    /// The sink refused a byte.
    Sink(E),
}

/// Writes a complete frame (delimiter, length, data, checksum) to `sink`, escaping it for API 2.
pub fn write_frame<K: ByteSink>(
    frame: &Frame<'_>,
    escaping: ApiEscaping,
    sink: &mut K,
) -> Result<(), WriteError<K::Error>> {
    let len = u16::try_from(frame.data_len()).map_err(|_| WriteError::TooLong)?;
    sink.put(START_DELIMITER).map_err(WriteError::Sink)?;
    let mut w = FrameSink {
        sink,
        escaping,
        sum: 0,
    };
    for b in len.to_be_bytes() {
        w.raw(b).map_err(WriteError::Sink)?;
    }
    frame.emit(&mut w).map_err(WriteError::Sink)?;
    let check = 0xFF - w.sum;
    w.raw(check).map_err(WriteError::Sink)
}

/// Encodes `frame` into `out`; returns the number of bytes written.
pub fn encode(
    frame: &Frame<'_>,
    escaping: ApiEscaping,
    out: &mut [u8],
) -> Result<usize, FrameError> {
    let mut sink = SliceSink::new(out);
    write_frame(frame, escaping, &mut sink).map_err(|e| match e {
        WriteError::TooLong => FrameError::TooLong,
        WriteError::Sink(e) => e,
    })?;
    Ok(sink.len())
}

/// A sink that keeps only the encoded bytes from `skip` on, until `out` is full.
struct WindowSink<'a> {
    skip: usize,
    out: &'a mut [u8],
    len: usize,
}

/// `out` of a [`WindowSink`] is full: the rest of the frame belongs to a later chunk.
struct WindowFull;

impl ByteSink for WindowSink<'_> {
    type Error = WindowFull;
    fn put(&mut self, byte: u8) -> Result<(), WindowFull> {
        if self.skip > 0 {
            self.skip -= 1;
            return Ok(());
        }
        let slot = self.out.get_mut(self.len).ok_or(WindowFull)?;
        *slot = byte;
        self.len += 1;
        Ok(())
    }
}

/// Encodes the part of `frame` that starts `offset` bytes into its encoded form, as much as
/// fits `out`; returns the number of bytes written (0 once the whole frame was handed out).
///
/// A frame of any length goes out through a small buffer this way: the blocking and the async
/// driver both write chunk after chunk, and differ only in how they wait for the port.
pub(crate) fn encode_chunk(
    frame: &Frame<'_>,
    escaping: ApiEscaping,
    offset: usize,
    out: &mut [u8],
) -> Result<usize, FrameError> {
    let mut sink = WindowSink {
        skip: offset,
        out,
        len: 0,
    };
    match write_frame(frame, escaping, &mut sink) {
        Ok(()) | Err(WriteError::Sink(WindowFull)) => Ok(sink.len),
        Err(WriteError::TooLong) => Err(FrameError::TooLong),
    }
}

/// Number of bytes [`encode`] will write for `frame` (escape bytes included).
pub fn encoded_len(frame: &Frame<'_>, escaping: ApiEscaping) -> usize {
    let mut count = CountingSink::default();
    match write_frame(frame, escaping, &mut count) {
        Ok(()) => count.0,
        // Too long to encode at all: report what the data alone would need.
        Err(_) => frame.data_len().saturating_add(4),
    }
}

/// Encodes raw frame data (frame type first) into `out`: for frames built by hand.
pub fn encode_raw(
    frame_data: &[u8],
    escaping: ApiEscaping,
    out: &mut [u8],
) -> Result<usize, FrameError> {
    let (&frame_type, data) = frame_data.split_first().ok_or(FrameError::Empty)?;
    encode(&Frame::Unknown { frame_type, data }, escaping, out)
}

/// Frame data handed out by the decoder: frame type first, checksum verified.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawFrame<'a>(&'a [u8]);

impl<'a> RawFrame<'a> {
    /// The frame type byte.
    pub fn frame_type(&self) -> u8 {
        self.0.first().copied().unwrap_or_default()
    }
    /// The whole frame data, frame type first.
    pub fn data(&self) -> &'a [u8] {
        self.0
    }
    /// Reads it as a typed frame.
    pub fn parse(&self) -> Result<Frame<'a>, FrameError> {
        Frame::parse(self.0)
    }
}

/// What the decoder has seen since it was created (saturating counters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecoderStats {
    /// Frames delivered.
    pub frames: u32,
    /// Frames dropped because the checksum did not match.
    pub checksum_errors: u32,
    /// Frames dropped because the length was 0 or larger than the decoder's buffer.
    pub length_errors: u32,
    /// Frames cut short by a new start delimiter (API 2) or an invalid escape.
    pub truncated: u32,
    /// Bytes thrown away: garbage between frames, XON/XOFF, and the bytes of dropped frames.
    pub discarded_bytes: u32,
}

/// Push-byte API frame decoder with a buffer of `N` bytes.
///
/// `N` bounds the whole unescaped frame: delimiter, length, frame data and checksum, so the
/// longest frame data accepted is `N - 4` bytes. Longer frames are dropped and counted.
///
/// Resynchronisation: in API 2 a raw 0x7E always starts a new frame, so a truncated frame costs
/// nothing more. In API 1 a 0x7E inside data is legal; after a bad length or checksum the
/// decoder rescans the bytes it buffered for the next 0x7E, so a good frame hidden behind a
/// truncated one is still found.
#[derive(Debug, Clone)]
pub struct FrameDecoder<const N: usize = 256> {
    buf: [u8; N],
    len: usize,
    /// Bytes at the start of `buf` that belong to the frame handed out last.
    consumed: usize,
    escaping: ApiEscaping,
    escape_next: bool,
    stats: DecoderStats,
}

impl<const N: usize> FrameDecoder<N> {
    const MIN_SIZE: () = assert!(N >= 8, "FrameDecoder needs at least 8 bytes of buffer");

    /// Creates a decoder for the module's `AP` setting.
    pub const fn new(escaping: ApiEscaping) -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::MIN_SIZE;
        Self {
            buf: [0; N],
            len: 0,
            consumed: 0,
            escaping,
            escape_next: false,
            stats: DecoderStats {
                frames: 0,
                checksum_errors: 0,
                length_errors: 0,
                truncated: 0,
                discarded_bytes: 0,
            },
        }
    }

    /// The escaping this decoder expects.
    pub const fn escaping(&self) -> ApiEscaping {
        self.escaping
    }

    /// Counters of delivered and dropped frames.
    pub const fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Longest frame data (frame type included) this decoder accepts.
    pub const fn max_frame_data_len(&self) -> usize {
        N - 4
    }

    /// Forgets any partial frame (counters are kept).
    pub fn reset(&mut self) {
        self.len = 0;
        self.consumed = 0;
        self.escape_next = false;
    }

    /// Feeds one byte from the serial line; returns a frame when this byte completes one.
    ///
    /// The frame borrows the decoder's buffer until the next call.
    pub fn push(&mut self, byte: u8) -> Option<RawFrame<'_>> {
        if self.advance(byte) {
            self.frame()
        } else {
            None
        }
    }

    /// Returns a frame that is already complete in the buffer, without a new byte.
    ///
    /// Only API 1 rescanning can leave one behind (a good frame found inside the bytes of a
    /// dropped one, followed by another complete frame); call this after [`push`](Self::push)
    /// returned a frame to drain such a backlog.
    pub fn next_buffered(&mut self) -> Option<RawFrame<'_>> {
        self.compact();
        if self.scan() {
            self.frame()
        } else {
            None
        }
    }

    /// Feeds one byte; `true` when a frame is ready in [`frame`](Self::frame).
    pub(crate) fn advance(&mut self, byte: u8) -> bool {
        self.compact();
        match self.escaping {
            ApiEscaping::Unescaped => self.store(byte),
            ApiEscaping::Escaped => {
                if byte == START_DELIMITER {
                    if self.len > 0 {
                        self.stats.truncated = self.stats.truncated.saturating_add(1);
                        self.drop_buffer();
                    }
                    self.escape_next = false;
                    self.store(byte);
                    return false;
                }
                if self.len == 0 || byte == XON || byte == XOFF {
                    self.count_discarded(1);
                    return false;
                }
                if byte == ESCAPE {
                    if self.escape_next {
                        self.stats.truncated = self.stats.truncated.saturating_add(1);
                        self.drop_buffer();
                        self.count_discarded(1);
                        return false;
                    }
                    self.escape_next = true;
                    return false;
                }
                let value = if self.escape_next {
                    self.escape_next = false;
                    byte ^ ESCAPE_XOR
                } else {
                    byte
                };
                self.store(value);
            }
        }
        self.scan()
    }

    /// The frame found by the last successful `advance`/`scan`.
    pub(crate) fn frame(&self) -> Option<RawFrame<'_>> {
        if self.consumed >= 4 {
            self.buf.get(3..self.consumed - 1).map(RawFrame)
        } else {
            None
        }
    }

    fn store(&mut self, byte: u8) {
        if self.len >= N {
            // Unreachable while `scan` rejects lengths above N; kept so no input can panic.
            self.stats.length_errors = self.stats.length_errors.saturating_add(1);
            self.drop_buffer();
        }
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = byte;
            self.len += 1;
        }
    }

    /// Removes the frame handed out last from the front of the buffer.
    fn compact(&mut self) {
        if self.consumed > 0 {
            self.discard_front(self.consumed);
            self.consumed = 0;
        }
    }

    fn discard_front(&mut self, n: usize) {
        let n = n.min(self.len);
        self.buf.copy_within(n..self.len, 0);
        self.len -= n;
    }

    fn drop_buffer(&mut self) {
        self.count_discarded(self.len);
        self.len = 0;
        self.escape_next = false;
    }

    fn count_discarded(&mut self, n: usize) {
        let n = u32::try_from(n).unwrap_or(u32::MAX);
        self.stats.discarded_bytes = self.stats.discarded_bytes.saturating_add(n);
    }

    /// Drops the frame that starts the buffer after a length or checksum error.
    fn reject(&mut self) {
        match self.escaping {
            // Only a raw 0x7E can start the next frame; wait for it.
            ApiEscaping::Escaped => self.drop_buffer(),
            // The next frame may hide in what we buffered: drop the delimiter and rescan.
            ApiEscaping::Unescaped => {
                self.count_discarded(1);
                self.discard_front(1);
            }
        }
    }

    /// Looks for a complete, valid frame at the front of the buffer.
    fn scan(&mut self) -> bool {
        loop {
            let Some(&first) = self.buf.get(..self.len).and_then(|b| b.first()) else {
                return false;
            };
            if first != START_DELIMITER {
                let buffered = self.buf.get(..self.len).unwrap_or_default();
                let skip = buffered
                    .iter()
                    .position(|&b| b == START_DELIMITER)
                    .unwrap_or(self.len);
                self.count_discarded(skip);
                self.discard_front(skip);
                continue;
            }
            if self.len < 3 {
                return false;
            }
            let (Some(&hi), Some(&lo)) = (self.buf.get(1), self.buf.get(2)) else {
                return false;
            };
            let data_len = usize::from(u16::from_be_bytes([hi, lo]));
            let total = data_len + 4;
            if data_len == 0 || total > N {
                self.stats.length_errors = self.stats.length_errors.saturating_add(1);
                self.reject();
                continue;
            }
            if self.len < total {
                return false;
            }
            let sum = self
                .buf
                .get(3..total)
                .unwrap_or_default()
                .iter()
                .fold(0u8, |s, &b| s.wrapping_add(b));
            if sum != 0xFF {
                self.stats.checksum_errors = self.stats.checksum_errors.saturating_add(1);
                self.reject();
                continue;
            }
            self.stats.frames = self.stats.frames.saturating_add(1);
            self.consumed = total;
            return true;
        }
    }
}

impl<const N: usize> Default for FrameDecoder<N> {
    fn default() -> Self {
        Self::new(ApiEscaping::Unescaped)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checksum_of_digi_example() {
        // 7E 00 04 08 01 4E 49 5F (digi-xbee, AT NI query).
        assert_eq!(checksum(&[0x08, 0x01, 0x4E, 0x49]), 0x5F);
    }

    #[test]
    fn chunks_put_together_are_the_whole_frame() {
        let frame = Frame::Unknown {
            frame_type: 0x10,
            data: &[0x7E, 0x7D, 0x11, 0x13, 0x00, 0x42, 0x7E, 0x01, 0x02],
        };
        for escaping in [ApiEscaping::Unescaped, ApiEscaping::Escaped] {
            let mut whole = [0u8; 32];
            let n = encode(&frame, escaping, &mut whole).unwrap();
            for chunk_len in 1..=n + 1 {
                let mut joined = [0u8; 32];
                let mut offset = 0;
                let mut chunk = [0u8; 32];
                loop {
                    let got =
                        encode_chunk(&frame, escaping, offset, &mut chunk[..chunk_len]).unwrap();
                    if got == 0 {
                        break;
                    }
                    joined[offset..offset + got].copy_from_slice(&chunk[..got]);
                    offset += got;
                }
                assert_eq!(
                    &joined[..offset],
                    &whole[..n],
                    "{escaping:?}, chunks of {chunk_len}"
                );
            }
        }
    }

    #[test]
    fn zero_length_frame_is_a_length_error() {
        let mut d = FrameDecoder::<16>::new(ApiEscaping::Unescaped);
        for b in [0x7E, 0x00, 0x00, 0xFF] {
            assert!(d.push(b).is_none());
        }
        assert_eq!(d.stats().length_errors, 1);
    }

    #[test]
    fn oversized_frame_is_a_length_error() {
        let mut d = FrameDecoder::<16>::new(ApiEscaping::Escaped);
        for b in [0x7E, 0x00, 0x0D] {
            assert!(d.push(b).is_none());
        }
        assert_eq!(d.stats().length_errors, 1);
        assert_eq!(d.max_frame_data_len(), 12);
    }
}
