//! A stuck IMU: the board keeps the last accelerometer and gyroscope words when a read fails,
//! under a valid CRC, so a dead sensor looks like a perfectly still one. Real sensors always
//! show some noise in the 12-bit accelerometer and 16-bit gyroscope words, so many identical
//! packets in a row are a fault.

/// Counts consecutive packets with identical accelerometer and gyroscope words.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ImuStuckDetector {
    last: Option<([i16; 3], [i16; 3])>,
    run: u32,
}

impl ImuStuckDetector {
    /// Looks at one valid packet's words; returns whether the IMU is stuck, i.e. the last
    /// `threshold` packets (this one included) carried identical words.
    pub fn update(&mut self, accel: [i16; 3], gyro: [i16; 3], threshold: u32) -> bool {
        if self.last == Some((accel, gyro)) {
            self.run = self.run.saturating_add(1);
        } else {
            self.last = Some((accel, gyro));
            self.run = 1;
        }
        self.is_stuck(threshold)
    }

    /// Whether the current run of identical packets has reached `threshold`.
    pub fn is_stuck(&self, threshold: u32) -> bool {
        self.run >= threshold
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fifty_identical_packets_are_stuck_forty_nine_are_not() {
        let mut d = ImuStuckDetector::default();
        for i in 1..50 {
            assert!(!d.update([1, 2, 3], [4, 5, 6], 50), "packet {i}");
        }
        assert!(d.update([1, 2, 3], [4, 5, 6], 50));
        // One changed word ends it.
        assert!(!d.update([1, 2, 3], [4, 5, 7], 50));
    }

    #[test]
    fn noise_in_any_word_keeps_it_healthy() {
        let mut d = ImuStuckDetector::default();
        for i in 0..1_000i16 {
            assert!(!d.update([0, 0, 16], [0, i % 2, 0], 50));
        }
    }
}
