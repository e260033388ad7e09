//! Finds fixed-length version 2 frames in a byte stream: start token, length byte, then the
//! rest of the frame. The caller judges each candidate (tag, fields) and either consumes it or
//! rejects it; a rejected candidate costs only its first byte, and the scan resumes inside it,
//! so a corrupt or forged frame never hides a good frame that starts within it.

/// A window of `N` bytes that fills up with a candidate frame.
#[derive(Debug, Clone)]
pub(crate) struct Scanner<const N: usize> {
    start: [u8; 2],
    window: [u8; N],
    len: usize,
    /// Bytes dropped (outside any frame or the first byte of a rejected candidate).
    skipped: u32,
    /// Start tokens followed by a wrong length byte.
    bad_length: u32,
}

impl<const N: usize> Scanner<N> {
    /// An empty scanner for frames that start with `start` and are `N` bytes long.
    pub(crate) const fn new(start: [u8; 2]) -> Scanner<N> {
        Scanner {
            start,
            window: [0; N],
            len: 0,
            skipped: 0,
            bad_length: 0,
        }
    }

    /// Feeds one byte; `true` when [`frame`](Self::frame) holds a candidate, which the caller
    /// must then [`consume`](Self::consume) or [`reject`](Self::reject).
    pub(crate) fn push(&mut self, byte: u8) -> bool {
        if self.len == N {
            // The caller did neither: treat the candidate as consumed.
            self.len = 0;
        }
        self.window[self.len] = byte;
        self.len += 1;
        match self.len {
            1 if byte != self.start[0] => self.rescan(),
            2 if byte != self.start[1] => self.rescan(),
            3 if usize::from(byte) != N => {
                self.bad_length = self.bad_length.saturating_add(1);
                self.rescan();
            }
            len => return len == N,
        }
        false
    }

    /// The candidate frame (meaningful after [`push`](Self::push) returned `true`).
    pub(crate) fn frame(&self) -> &[u8; N] {
        &self.window
    }

    /// The candidate was a frame: start afresh after it.
    pub(crate) fn consume(&mut self) {
        self.len = 0;
    }

    /// The candidate was not a frame: drop its first byte and scan the rest again.
    pub(crate) fn reject(&mut self) {
        self.rescan();
    }

    /// Counts the candidate's bytes as dropped (an authentic frame with invalid content).
    pub(crate) fn discard(&mut self) {
        self.skipped = self.skipped.saturating_add(self.len as u32);
        self.len = 0;
    }

    /// Forgets a partial frame, counting its bytes as dropped.
    pub(crate) fn reset(&mut self) {
        self.discard();
    }

    /// Bytes held while waiting for the rest of a frame.
    pub(crate) fn pending(&self) -> usize {
        if self.len == N {
            0
        } else {
            self.len
        }
    }

    /// Bytes dropped so far.
    pub(crate) fn skipped(&self) -> u32 {
        self.skipped
    }

    /// Start tokens followed by a wrong length byte so far.
    pub(crate) fn bad_length(&self) -> u32 {
        self.bad_length
    }

    /// Drops the window's first byte and feeds the others again. They are fewer than `N`, so
    /// no candidate can complete during the rescan; the recursion is at most three deep (only
    /// windows of up to three bytes rescan while being refilled).
    fn rescan(&mut self) {
        let held = self.window;
        let end = self.len;
        self.len = 0;
        self.skipped = self.skipped.saturating_add(1);
        for &byte in &held[1..end] {
            let complete = self.push(byte);
            debug_assert!(!complete);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_a_frame_after_a_false_start_inside_a_rejected_candidate() {
        let mut scanner = Scanner::<6>::new([0xA5, 0x32]);
        // A candidate whose body holds the start of the real frame.
        let stream = [0xA5, 0x32, 6, 0xA5, 0x32, 6, 1, 2, 3];
        let mut found = 0;
        for &b in &stream {
            if scanner.push(b) {
                found += 1;
                if found == 1 {
                    assert_eq!(scanner.frame(), &[0xA5, 0x32, 6, 0xA5, 0x32, 6]);
                    scanner.reject();
                } else {
                    assert_eq!(scanner.frame(), &[0xA5, 0x32, 6, 1, 2, 3]);
                    scanner.consume();
                }
            }
        }
        assert_eq!(found, 2);
        assert_eq!(scanner.skipped(), 3);
        assert_eq!(scanner.pending(), 0);
    }

    #[test]
    fn wrong_length_byte_is_counted_and_skipped() {
        let mut scanner = Scanner::<6>::new([0xA5, 0x32]);
        for &b in &[0xA5, 0x32, 7, 0xA5, 0xA5, 0x32] {
            assert!(!scanner.push(b));
        }
        assert_eq!(scanner.bad_length(), 1);
        assert_eq!(scanner.pending(), 2);
        assert_eq!(scanner.skipped(), 4);
    }
}
