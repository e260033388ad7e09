//! Overruns: late wake-ups within a sliding second, and the time they lost.
//!
//! A wake-up later than a whole period skips the periods it missed. Two things trip FAILSAFE:
//! - sustained overload: more than `limit` late wake-ups within any sliding second. Counting
//!   consecutive late cycles cannot see it (with 6 ms of work in a 4 ms period the clock
//!   alternates between a wake-up that skips a period and one that does not), and counting
//!   missed periods would let one short stall of the host, which skips many periods at once,
//!   trip it; so each late wake-up counts once, however many periods it missed;
//! - stalls: the periods missed within the sliding second, in time, longer than
//!   `max_stall_ns`, whether in one stall or in shorter ones that add up.
//!
//! The window keeps the time and missed periods of the last `limit + 1` late wake-ups in fixed
//! arrays: nothing is allocated.

use crate::safety::MAX_OVERRUN_LIMIT;
use crate::Nanos;

const WINDOW_NS: Nanos = 1_000_000_000;
const CAPACITY: usize = MAX_OVERRUN_LIMIT as usize + 1;

/// When overruns trip FAILSAFE.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OverrunRule {
    /// More late wake-ups than this within a sliding second trip (clamped to
    /// 1..=[`MAX_OVERRUN_LIMIT`]).
    pub limit: u32,
    /// Missed periods adding up to more than this within a sliding second trip, ns.
    pub max_stall_ns: Nanos,
    /// The loop period, ns (the time one missed period lost).
    pub period_ns: Nanos,
}

/// The most recent late wake-ups: when, and how many periods each missed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OverrunWindow {
    times: [Nanos; CAPACITY],
    missed: [u32; CAPACITY],
    /// Index of the next slot to write.
    next: usize,
    /// Slots written so far (saturates at the capacity).
    len: usize,
}

impl Default for OverrunWindow {
    fn default() -> Self {
        OverrunWindow {
            times: [0; CAPACITY],
            missed: [0; CAPACITY],
            next: 0,
            len: 0,
        }
    }
}

impl OverrunWindow {
    /// Records a wake-up at `now` that skipped `missed` periods (0: on time) and returns
    /// whether the loop is overrunning by `rule`.
    pub fn record(&mut self, missed: u32, now: Nanos, rule: &OverrunRule) -> bool {
        if missed > 0 {
            self.times[self.next] = now;
            self.missed[self.next] = missed;
            self.next = (self.next + 1) % CAPACITY;
            self.len = (self.len + 1).min(CAPACITY);
        }
        self.exceeded(now, rule)
    }

    /// Whether, within the second up to `now`, more than `rule.limit` wake-ups were late or
    /// the periods they missed add up to more than `rule.max_stall_ns`.
    pub fn exceeded(&self, now: Nanos, rule: &OverrunRule) -> bool {
        let limit = rule.limit.clamp(1, MAX_OVERRUN_LIMIT) as usize;
        let mut late = 0;
        let mut lost_ns: Nanos = 0;
        // Newest first; the first one older than the window ends the count.
        for i in 0..self.len {
            let slot = (self.next + CAPACITY - 1 - i) % CAPACITY;
            if now.saturating_sub(self.times[slot]) >= WINDOW_NS {
                break;
            }
            late += 1;
            lost_ns =
                lost_ns.saturating_add(u64::from(self.missed[slot]).saturating_mul(rule.period_ns));
            if late > limit || lost_ns > rule.max_stall_ns {
                return true;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Nanos = 1_000_000;
    /// 250 Hz, 10 late wake-ups a second, 250 ms of stalls.
    const RULE: OverrunRule = OverrunRule {
        limit: 10,
        max_stall_ns: 250 * MS,
        period_ns: 4 * MS,
    };

    #[test]
    fn alternating_skips_under_sustained_overload_trip_within_a_second() {
        // 6 ms of work per 4 ms period: wakes every 6 ms, every other one skips a period.
        let mut w = OverrunWindow::default();
        let mut tripped_at = None;
        for k in 0..500u64 {
            let now = k * 6 * MS;
            let missed = (k % 2) as u32;
            if w.record(missed, now, &RULE) {
                tripped_at = Some(now);
                break;
            }
        }
        let t = tripped_at.expect("trips");
        assert!(t < 1_000 * MS, "{t}");
    }

    #[test]
    fn sparse_late_wake_ups_never_trip() {
        // Ten late wake-ups a second (the limit) forever: not more than the limit.
        let mut w = OverrunWindow::default();
        for k in 0..10_000u64 {
            assert!(!w.record(1, k * 100 * MS + 1, &RULE), "late wake-up {k}");
        }
    }

    #[test]
    fn late_wake_ups_above_the_limit_trip_and_expire() {
        let mut w = OverrunWindow::default();
        for k in 0..10 {
            assert!(!w.record(1, k * MS, &RULE));
        }
        assert!(w.record(1, 999 * MS, &RULE));
        assert!(!w.exceeded(1_000 * MS, &RULE));
    }

    #[test]
    fn one_stall_counts_once_and_trips_only_past_the_stall_bound() {
        // 62 periods (248 ms) at once: one late wake-up, within the stall bound.
        let mut w = OverrunWindow::default();
        assert!(!w.record(62, 5 * MS, &RULE));
        for k in 1..10 {
            assert!(!w.record(0, 5 * MS + k * 4 * MS, &RULE));
        }
        // 63 periods (252 ms): past it.
        let mut w = OverrunWindow::default();
        assert!(w.record(63, 5 * MS, &RULE));
        // A second later it has expired (a revive is no longer refused for it).
        assert!(!w.exceeded(1_005 * MS, &RULE));
        // Any count, however large, saturates and trips.
        let mut w = OverrunWindow::default();
        assert!(w.record(u32::MAX, 6 * MS, &RULE));
    }

    #[test]
    fn stalls_that_add_up_past_the_bound_within_a_second_trip() {
        // 30 periods (120 ms) three times within a second: 360 ms lost.
        let mut w = OverrunWindow::default();
        assert!(!w.record(30, 100 * MS, &RULE));
        assert!(!w.record(30, 400 * MS, &RULE));
        assert!(w.record(30, 700 * MS, &RULE));
        // The same stalls a second apart never add up.
        let mut w = OverrunWindow::default();
        for k in 0..20 {
            assert!(!w.record(30, k * 1_000 * MS, &RULE), "stall {k}");
        }
    }

    #[test]
    fn the_limit_is_clamped_to_what_the_window_holds() {
        let rule = OverrunRule {
            limit: u32::MAX,
            max_stall_ns: Nanos::MAX,
            ..RULE
        };
        let mut w = OverrunWindow::default();
        let mut tripped = false;
        for k in 0..=u64::from(MAX_OVERRUN_LIMIT) {
            tripped = w.record(1, k * MS, &rule);
        }
        assert!(tripped, "the {}-th late wake-up", MAX_OVERRUN_LIMIT + 1);
    }
}
