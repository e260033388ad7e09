//! Overruns by rate: more than `limit` missed periods within any sliding second.
//!
//! Counting consecutive late cycles cannot see sustained overload: with 6 ms of work in a 4 ms
//! period the clock alternates between a late wake-up that skips a period and one that does
//! not. The window keeps the times of the last `limit + 1` missed periods in a fixed array.

use crate::safety::MAX_OVERRUN_LIMIT;
use crate::Nanos;

const WINDOW_NS: Nanos = 1_000_000_000;
const CAPACITY: usize = MAX_OVERRUN_LIMIT as usize + 1;

/// Times of the most recent missed periods.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OverrunWindow {
    times: [Nanos; CAPACITY],
    /// Index of the next slot to write.
    next: usize,
    /// Slots written so far (saturates at the capacity).
    len: usize,
}

impl Default for OverrunWindow {
    fn default() -> Self {
        OverrunWindow {
            times: [0; CAPACITY],
            next: 0,
            len: 0,
        }
    }
}

impl OverrunWindow {
    /// Records `missed` periods at `now` and returns whether more than `limit` (at most
    /// [`MAX_OVERRUN_LIMIT`]) fell within the last second.
    pub fn record(&mut self, missed: u32, now: Nanos, limit: u32) -> bool {
        let keep = limit.clamp(1, MAX_OVERRUN_LIMIT) as usize + 1;
        for _ in 0..(missed as usize).min(keep) {
            self.times[self.next] = now;
            self.next = (self.next + 1) % CAPACITY;
            self.len = (self.len + 1).min(CAPACITY);
        }
        self.exceeded(now, limit)
    }

    /// Whether more than `limit` missed periods fell within the second up to `now`.
    pub fn exceeded(&self, now: Nanos, limit: u32) -> bool {
        let n = limit.clamp(1, MAX_OVERRUN_LIMIT) as usize + 1;
        if self.len < n {
            return false;
        }
        // The n-th most recent miss.
        let oldest = self.times[(self.next + CAPACITY - n) % CAPACITY];
        now.saturating_sub(oldest) < WINDOW_NS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Nanos = 1_000_000;

    #[test]
    fn alternating_skips_under_sustained_overload_trip_within_a_second() {
        // 6 ms of work per 4 ms period: wakes every 6 ms, every other one skips a period.
        let mut w = OverrunWindow::default();
        let mut tripped_at = None;
        for k in 0..500u64 {
            let now = k * 6 * MS;
            let missed = (k % 2) as u32;
            if w.record(missed, now, 10) {
                tripped_at = Some(now);
                break;
            }
        }
        let t = tripped_at.expect("trips");
        assert!(t < 1_000 * MS, "{t}");
    }

    #[test]
    fn sparse_misses_never_trip() {
        // Ten misses a second (the limit) forever: not more than the limit.
        let mut w = OverrunWindow::default();
        for k in 0..10_000u64 {
            assert!(!w.record(1, k * 100 * MS + 1, 10), "miss {k}");
        }
    }

    #[test]
    fn a_burst_above_the_limit_trips_and_expires() {
        let mut w = OverrunWindow::default();
        assert!(!w.record(10, 0, 10));
        assert!(w.record(1, 999 * MS, 10));
        assert!(!w.exceeded(1_000 * MS, 10));
        // One long stall that skips many periods at once.
        let mut w = OverrunWindow::default();
        assert!(w.record(40, 5 * MS, 10));
        assert!(w.record(u32::MAX, 6 * MS, MAX_OVERRUN_LIMIT));
    }
}
