//! The host's timing: when the loop's thread wakes after each deadline. Mostly within tens of
//! microseconds; sometimes a wake-up whole periods late (short stalls, alone or in bursts
//! that overrun the loop), and rarely a long one.

use crate::rng::SimRng;
use dima_core::Nanos;

/// Stall probabilities of one run (drawn from the seed).
#[derive(Debug, Clone)]
pub struct Host {
    rng: SimRng,
    period_ns: Nanos,
    /// Per cycle: a short stall (1 to 3 periods).
    short: f64,
    /// Per cycle: a burst of short stalls starts.
    burst_start: f64,
    /// Per cycle inside a burst: a short stall.
    burst_short: f64,
    /// Per cycle: a long stall (10 to 150 periods).
    long: f64,
    burst_until_ns: Nanos,
}

impl Host {
    /// A host for loop period `period_ns`.
    pub fn new(mut rng: SimRng, period_ns: Nanos) -> Host {
        Host {
            short: rng.uniform() * 1e-3,
            burst_start: rng.uniform() * 5e-5,
            burst_short: 0.02 + rng.uniform() * 0.1,
            long: rng.uniform() * 3e-5,
            rng,
            period_ns,
            burst_until_ns: 0,
        }
    }

    /// A host that never stalls (wake-ups a few microseconds late).
    pub fn quiet(rng: SimRng, period_ns: Nanos) -> Host {
        Host {
            short: 0.0,
            burst_start: 0.0,
            burst_short: 0.0,
            long: 0.0,
            ..Host::new(rng, period_ns)
        }
    }

    /// When the thread wakes for `deadline_ns`.
    pub fn wake(&mut self, deadline_ns: Nanos) -> Nanos {
        let r = &mut self.rng;
        let jitter = 2_000 + r.below(60_000);
        if r.chance(self.burst_start) {
            self.burst_until_ns = deadline_ns + 500_000_000 + r.below(2_500_000_000);
        }
        let in_burst = deadline_ns < self.burst_until_ns;
        let periods = if r.chance(self.long) {
            10 + r.below(141)
        } else if r.chance(self.short) || (in_burst && r.chance(self.burst_short)) {
            1 + r.below(3)
        } else {
            0
        };
        deadline_ns + periods * self.period_ns + jitter
    }
}
