//! Frame id allocation for requests that expect a response.

/// Hands out API frame ids 1 to 255 in turn.
///
/// Id 0 tells the module not to answer, so it is never returned. With 255 ids in flight at
/// most, a response can be matched to its request by id alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameIdAllocator {
    next: u8,
}

impl FrameIdAllocator {
    /// Starts at id 1.
    pub const fn new() -> Self {
        Self { next: 1 }
    }

    /// The next id (1..=255, wrapping back to 1).
    pub fn next_id(&mut self) -> u8 {
        let id = self.next;
        self.next = if id == u8::MAX { 1 } else { id + 1 };
        id
    }
}

impl Default for FrameIdAllocator {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn never_zero_and_wraps() {
        let mut ids = FrameIdAllocator::new();
        assert_eq!(ids.next_id(), 1);
        for expected in 2..=255u8 {
            assert_eq!(ids.next_id(), expected);
        }
        assert_eq!(ids.next_id(), 1);
        assert!((0..1000).all(|_| ids.next_id() != 0));
    }
}
