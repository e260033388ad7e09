//! A periodic clock on absolute deadlines (`clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME)`),
//! with cyclictest's semantics: the wake-up latency is the time from the deadline to the wake,
//! and a wake later than a whole period skips the periods that were missed and counts them.

use nix::sys::time::TimeSpec;
use nix::time::{clock_gettime, clock_nanosleep, ClockId, ClockNanosleepFlags};

use dima_core::Nanos;

/// CLOCK_MONOTONIC now, in nanoseconds.
pub fn monotonic_ns() -> Nanos {
    // CLOCK_MONOTONIC cannot fail on Linux; a zero would only make one latency look large.
    clock_gettime(ClockId::CLOCK_MONOTONIC)
        .map(|t| to_ns(&t))
        .unwrap_or(0)
}

fn to_ns(t: &TimeSpec) -> Nanos {
    (t.tv_sec() as u64)
        .saturating_mul(1_000_000_000)
        .saturating_add(t.tv_nsec() as u64)
}

fn to_timespec(ns: Nanos) -> TimeSpec {
    TimeSpec::new((ns / 1_000_000_000) as _, (ns % 1_000_000_000) as _)
}

/// One wake-up of the clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tick {
    /// The deadline this wake-up was for, ns.
    pub deadline_ns: Nanos,
    /// When the thread actually ran, ns.
    pub wake_ns: Nanos,
    /// `wake_ns - deadline_ns`.
    pub latency_ns: Nanos,
    /// Whole periods skipped because this wake-up came too late.
    pub missed: u32,
}

/// Periodic absolute-deadline clock.
#[derive(Debug, Clone)]
pub struct PeriodicClock {
    period_ns: Nanos,
    next_ns: Nanos,
    missed_total: u64,
}

impl PeriodicClock {
    /// First deadline one period after `start_ns`.
    pub fn new(period_ns: Nanos, start_ns: Nanos) -> PeriodicClock {
        PeriodicClock {
            period_ns: period_ns.max(1),
            next_ns: start_ns + period_ns.max(1),
            missed_total: 0,
        }
    }

    /// The period, ns.
    pub fn period_ns(&self) -> Nanos {
        self.period_ns
    }

    /// The next deadline, ns.
    pub fn next_deadline_ns(&self) -> Nanos {
        self.next_ns
    }

    /// Missed periods since creation.
    pub fn missed_total(&self) -> u64 {
        self.missed_total
    }

    /// Sleeps until the next deadline (retrying on EINTR), then advances it.
    pub fn wait(&mut self) -> Tick {
        let deadline = to_timespec(self.next_ns);
        while clock_nanosleep(
            ClockId::CLOCK_MONOTONIC,
            ClockNanosleepFlags::TIMER_ABSTIME,
            &deadline,
        ) == Err(nix::errno::Errno::EINTR)
        {}
        self.advance(monotonic_ns())
    }

    /// Advances the schedule for a wake-up at `wake_ns` (the arithmetic of [`wait`](Self::wait),
    /// testable without sleeping).
    pub fn advance(&mut self, wake_ns: Nanos) -> Tick {
        let deadline_ns = self.next_ns;
        let latency_ns = wake_ns.saturating_sub(deadline_ns);
        let missed = latency_ns / self.period_ns;
        self.next_ns = deadline_ns + self.period_ns * (missed + 1);
        self.missed_total += missed;
        Tick {
            deadline_ns,
            wake_ns,
            latency_ns,
            missed: missed.min(u64::from(u32::MAX)) as u32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn on_time_wakes_advance_one_period() {
        let mut c = PeriodicClock::new(4_000_000, 0);
        let t = c.advance(4_000_050);
        assert_eq!((t.deadline_ns, t.latency_ns, t.missed), (4_000_000, 50, 0));
        assert_eq!(c.next_deadline_ns(), 8_000_000);
    }

    #[test]
    fn late_wakes_skip_and_count_missed_periods() {
        let mut c = PeriodicClock::new(4_000_000, 0);
        // Deadline 4 ms, woke at 13 ms: the 8 ms and 12 ms deadlines were missed.
        let t = c.advance(13_000_000);
        assert_eq!(t.missed, 2);
        assert_eq!(c.next_deadline_ns(), 16_000_000);
        assert_eq!(c.missed_total(), 2);
        // Exactly one period late: one missed.
        let t = c.advance(20_000_000);
        assert_eq!(t.missed, 1);
        assert_eq!(c.next_deadline_ns(), 24_000_000);
    }

    #[test]
    fn early_wake_is_zero_latency() {
        let mut c = PeriodicClock::new(1_000, 0);
        assert_eq!(c.advance(999).latency_ns, 0);
    }

    #[test]
    fn really_sleeps_to_absolute_deadlines() {
        let start = monotonic_ns();
        let mut c = PeriodicClock::new(1_000_000, start);
        for _ in 0..20 {
            let t = c.wait();
            assert!(
                t.wake_ns >= t.deadline_ns,
                "woke before the deadline: {t:?}"
            );
        }
        assert!(monotonic_ns() - start >= 20_000_000);
    }
}
