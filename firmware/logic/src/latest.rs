//! The front half of the packet double buffer.
//!
//! The sampling task assembles each packet in its own back buffer and, once the packet is
//! complete (CRC included), publishes it here in one short copy. The request interrupt copies
//! the front buffer into the transmit buffer. Because the request interrupt has the higher
//! priority, it can preempt the assembly of the next packet but never a publish, so what it
//! sends is always one complete packet.

/// The latest complete packet of `N` bytes, or none yet.
#[derive(Debug, Clone)]
pub struct LatestPacket<const N: usize> {
    bytes: [u8; N],
    ready: bool,
    published: u32,
}

impl<const N: usize> Default for LatestPacket<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> LatestPacket<N> {
    /// No packet yet.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            bytes: [0; N],
            ready: false,
            published: 0,
        }
    }

    /// Replaces the latest packet with a complete one.
    pub fn publish(&mut self, packet: &[u8; N]) {
        self.bytes = *packet;
        self.ready = true;
        self.published = self.published.wrapping_add(1);
    }

    /// The latest complete packet, or `None` before the first publish (so nothing is ever sent
    /// at boot).
    #[must_use]
    pub fn get(&self) -> Option<&[u8; N]> {
        self.ready.then_some(&self.bytes)
    }

    /// Packets published so far (wraps around).
    #[must_use]
    pub fn published(&self) -> u32 {
        self.published
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_until_the_first_publish() {
        let mut latest = LatestPacket::<4>::new();
        assert_eq!(latest.get(), None);
        latest.publish(&[1, 2, 3, 4]);
        assert_eq!(latest.get(), Some(&[1, 2, 3, 4]));
        latest.publish(&[5, 6, 7, 8]);
        assert_eq!(latest.get(), Some(&[5, 6, 7, 8]));
        assert_eq!(latest.published(), 2);
    }
}
