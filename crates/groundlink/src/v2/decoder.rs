//! The resynchronising stream decoder that both version 2 frame kinds share: a [`Scanner`]
//! finds candidates, the frame type judges them (envelope, tag, fields), and the decoder
//! consumes, rejects or discards each candidate and counts what it did.

use core::marker::PhantomData;

use super::scanner::Scanner;
use super::{FrameError, LinkKey};

/// A fixed-length (`N` bytes) authenticated frame of ground link v2.
pub trait AuthenticFrame<const N: usize>: Sized {
    /// The two bytes every frame of this kind starts with.
    const START: [u8; 2];

    /// Decodes one complete candidate: start token, length, tag, then the fields.
    fn decode_frame(frame: &[u8; N], key: &LinkKey) -> Result<Self, FrameError>;
}

/// What a [`FrameDecoder`] has seen since it was created (each counter saturates).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StreamStats {
    /// Authentic, valid frames delivered.
    pub frames: u32,
    /// Candidate frames whose tag did not match (forged, corrupt, other key).
    pub bad_tag: u32,
    /// Start tokens with a wrong length byte, and authentic frames with invalid content
    /// (an unknown type or mode, out-of-range data).
    pub malformed: u32,
    /// Bytes dropped: outside any frame, the first byte of each rejected candidate, and
    /// authentic frames with invalid content. Bytes fed = frame length x `frames` +
    /// `skipped_bytes` + pending bytes.
    pub skipped_bytes: u32,
}

/// Finds authentic frames of one kind in a byte stream, whatever the read boundaries are.
///
/// Total: any byte sequence is accepted. A candidate (start token and length byte) whose tag
/// does not match costs only its first byte: the search resumes inside it, so garbage or a
/// forged frame never hides a good frame that follows. Use it through
/// [`CommandDecoder`](super::CommandDecoder) and [`DisplayDecoder`](super::DisplayDecoder).
#[derive(Debug, Clone)]
pub struct FrameDecoder<F, const N: usize> {
    key: LinkKey,
    scanner: Scanner<N>,
    frames: u32,
    bad_tag: u32,
    malformed: u32,
    kind: PhantomData<fn() -> F>,
}

impl<F: AuthenticFrame<N>, const N: usize> FrameDecoder<F, N> {
    /// An empty decoder that checks tags with `key`.
    pub const fn new(key: LinkKey) -> Self {
        FrameDecoder {
            key,
            scanner: Scanner::new(F::START),
            frames: 0,
            bad_tag: 0,
            malformed: 0,
            kind: PhantomData,
        }
    }

    /// Counters since creation.
    pub fn stats(&self) -> StreamStats {
        StreamStats {
            frames: self.frames,
            bad_tag: self.bad_tag,
            malformed: self.malformed.saturating_add(self.scanner.bad_length()),
            skipped_bytes: self.scanner.skipped(),
        }
    }

    /// Bytes held while waiting for the rest of a frame.
    pub fn pending(&self) -> usize {
        self.scanner.pending()
    }

    /// Forgets a partial frame (e.g. after the port was reopened); its bytes count as skipped.
    pub fn reset(&mut self) {
        self.scanner.reset();
    }

    /// Feeds one byte. `Some(Ok(_))` for an authentic valid frame, `Some(Err(BadTag))` for a
    /// candidate whose tag does not match, `Some(Err(_))` for an authentic frame with invalid
    /// content. Wrong length bytes are only counted.
    pub fn push(&mut self, byte: u8) -> Option<Result<F, FrameError>> {
        if !self.scanner.push(byte) {
            return None;
        }
        match F::decode_frame(self.scanner.frame(), &self.key) {
            Ok(frame) => {
                self.scanner.consume();
                self.frames = self.frames.saturating_add(1);
                Some(Ok(frame))
            }
            Err(FrameError::BadTag) => {
                self.scanner.reject();
                self.bad_tag = self.bad_tag.saturating_add(1);
                Some(Err(FrameError::BadTag))
            }
            Err(error) => {
                self.scanner.discard();
                self.malformed = self.malformed.saturating_add(1);
                Some(Err(error))
            }
        }
    }

    /// Feeds a chunk of bytes, yielding what [`push`](Self::push) yields for each of them.
    pub fn feed<'a>(
        &'a mut self,
        bytes: &'a [u8],
    ) -> impl Iterator<Item = Result<F, FrameError>> + 'a {
        bytes.iter().filter_map(move |&b| self.push(b))
    }
}
