//! A stuck IMU: the board keeps each die's last words when its read fails, under a valid CRC,
//! so a dead sensor looks like a perfectly still one, and a dead gyroscope beside a live
//! accelerometer (or the reverse) looks like a car turning at a constant rate. Real sensors
//! always show some noise in the 12-bit accelerometer and 16-bit gyroscope words, so many
//! identical words in a row from either die are a fault: each die has its own run, and the
//! other die's noise does not end it.

/// Consecutive packets with identical words from one die.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct DieRun {
    last: Option<[i16; 3]>,
    run: u32,
}

impl DieRun {
    fn update(&mut self, words: [i16; 3]) {
        if self.last == Some(words) {
            self.run = self.run.saturating_add(1);
        } else {
            self.last = Some(words);
            self.run = 1;
        }
    }
}

/// Counts, for the accelerometer and the gyroscope separately, consecutive packets with
/// identical words.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ImuStuckDetector {
    accel: DieRun,
    gyro: DieRun,
}

impl ImuStuckDetector {
    /// Looks at one valid packet's words; returns whether the IMU is stuck, i.e. the last
    /// `threshold` packets (this one included) carried identical accelerometer words or
    /// identical gyroscope words.
    pub fn update(&mut self, accel: [i16; 3], gyro: [i16; 3], threshold: u32) -> bool {
        self.accel.update(accel);
        self.gyro.update(gyro);
        self.is_stuck(threshold)
    }

    /// Whether either die's current run of identical words has reached `threshold`.
    pub fn is_stuck(&self, threshold: u32) -> bool {
        self.accel.run.max(self.gyro.run) >= threshold
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
        // A changed gyroscope word ends only the gyroscope's run: the accelerometer is still
        // stuck, until one of its words changes too.
        assert!(d.update([1, 2, 3], [4, 5, 7], 50));
        assert!(!d.update([1, 2, 4], [4, 5, 8], 50));
    }

    #[test]
    fn noise_in_a_word_of_each_die_keeps_it_healthy() {
        let mut d = ImuStuckDetector::default();
        for i in 0..1_000i16 {
            assert!(!d.update([0, 0, 16 + i % 3], [0, i % 2, 0], 50));
        }
    }

    #[test]
    fn one_frozen_die_is_stuck_whatever_the_other_does() {
        let mut gyro_frozen = ImuStuckDetector::default();
        let mut accel_frozen = ImuStuckDetector::default();
        for i in 1..=50i16 {
            let noisy = [i % 7, -i % 3, 1_000 + i % 2];
            let stuck = i == 50;
            assert_eq!(gyro_frozen.update(noisy, [0, 0, 656], 50), stuck, "{i}");
            assert_eq!(accel_frozen.update([3, -5, 990], noisy, 50), stuck, "{i}");
        }
        // A change in the frozen die's words ends its run.
        assert!(!gyro_frozen.update([1, 1, 1], [0, 0, 657], 50));
    }
}
