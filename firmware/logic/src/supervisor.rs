//! Supervision: may the sampling tick feed the watchdog, and is the GNSS receiver silent?
//!
//! The sampling tick calls [`Supervisor::on_tick`] once per tick, so a sampling task that
//! stops running stops feeding the watchdog by itself. On top of that the supervisor watches
//! the two other paths:
//!
//! - the link: a transfer that has been running for more than
//!   [`SupervisorConfig::link_stuck_ticks`] without completing means the transmitter is stuck
//!   "sending", which would skip every request for ever. The watchdog is then no longer fed
//!   and resets the board. A busy link that keeps completing transfers (a host asking faster
//!   than the answers take) is alive.
//! - the GNSS receiver: no byte for [`SupervisorConfig::gnss_silent_ticks`] sets
//!   [`Verdict::gnss_silent`]. It is reported, never a reset: the board cannot tell an
//!   unplugged or unpowered receiver from a broken receive path, and resetting would not
//!   bring a receiver back.

/// Thresholds, in sampling ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SupervisorConfig {
    /// Ticks a transfer may run without completing before the link counts as stuck.
    pub link_stuck_ticks: u32,
    /// Ticks without a received GNSS byte before the receiver counts as silent.
    pub gnss_silent_ticks: u32,
}

impl SupervisorConfig {
    /// For a 1 kHz tick: the link is stuck after 20 ms (the longest answer, packet plus info
    /// frame, takes 5.73 ms at 460 800 baud 8N2; 20 ms is five 250 Hz request periods), the
    /// receiver silent after 1 s (ten 10 Hz NAV-PVT solutions).
    pub const DEFAULT: Self = Self {
        link_stuck_ticks: 20,
        gnss_silent_ticks: 1_000,
    };
}

/// What the link looks like from the sampling tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkProgress {
    /// A transfer (packet or info frame) is running.
    pub busy: bool,
    /// Transfers completed since boot (wrapping).
    pub completed: u32,
}

/// The supervisor's answer for one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Verdict {
    /// Feed the watchdog this tick (false once the link is stuck).
    pub feed_watchdog: bool,
    /// The link has been sending without completing for too long.
    pub link_stuck: bool,
    /// No GNSS byte for too long (a status bit, not a reset).
    pub gnss_silent: bool,
}

/// Decides, tick by tick, whether the board is alive enough to feed the watchdog.
#[derive(Debug, Clone)]
pub struct Supervisor {
    config: SupervisorConfig,
    /// Ticks the link has been busy with no transfer completing.
    link_stalled_ticks: u32,
    last_completed: u32,
    /// Ticks since the GNSS byte count last moved.
    gnss_quiet_ticks: u32,
    last_gnss_bytes: u32,
}

impl Supervisor {
    /// Nothing seen yet: the link idle, no GNSS byte (silent only after the threshold).
    #[must_use]
    pub const fn new(config: SupervisorConfig) -> Self {
        Self {
            config,
            link_stalled_ticks: 0,
            last_completed: 0,
            gnss_quiet_ticks: 0,
            last_gnss_bytes: 0,
        }
    }

    /// One sampling tick: the link's state and the GNSS bytes received since boot (wrapping).
    pub fn on_tick(&mut self, link: LinkProgress, gnss_bytes: u32) -> Verdict {
        if !link.busy || link.completed != self.last_completed {
            self.link_stalled_ticks = 0;
        } else {
            self.link_stalled_ticks = self.link_stalled_ticks.saturating_add(1);
        }
        self.last_completed = link.completed;

        if gnss_bytes != self.last_gnss_bytes {
            self.gnss_quiet_ticks = 0;
        } else {
            self.gnss_quiet_ticks = self.gnss_quiet_ticks.saturating_add(1);
        }
        self.last_gnss_bytes = gnss_bytes;

        let link_stuck = self.link_stalled_ticks > self.config.link_stuck_ticks;
        Verdict {
            feed_watchdog: !link_stuck,
            link_stuck,
            gnss_silent: self.gnss_quiet_ticks >= self.config.gnss_silent_ticks,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CONFIG: SupervisorConfig = SupervisorConfig {
        link_stuck_ticks: 20,
        gnss_silent_ticks: 1_000,
    };

    fn idle(completed: u32) -> LinkProgress {
        LinkProgress {
            busy: false,
            completed,
        }
    }

    fn busy(completed: u32) -> LinkProgress {
        LinkProgress {
            busy: true,
            completed,
        }
    }

    #[test]
    fn an_idle_link_and_a_talking_receiver_feed_the_watchdog() {
        let mut supervisor = Supervisor::new(CONFIG);
        for tick in 0..5_000u32 {
            let verdict = supervisor.on_tick(idle(0), tick / 100 + 1);
            assert!(verdict.feed_watchdog, "tick {tick}");
            assert!(!verdict.link_stuck && !verdict.gnss_silent, "tick {tick}");
        }
    }

    #[test]
    fn the_real_answer_pattern_is_never_stuck() {
        // 250 Hz requests on a 1 kHz tick: 6 ticks of packet plus info frame after a pause,
        // then 4 busy ticks out of every 4 (a packet takes 3.15 ms, the next request comes
        // as it ends) for a long time.
        let mut supervisor = Supervisor::new(CONFIG);
        let mut completed = 0;
        for _ in 0..6 {
            assert!(supervisor.on_tick(busy(completed), 1).feed_watchdog);
        }
        completed += 2;
        for tick in 0..10_000u32 {
            if tick % 4 == 3 {
                completed += 1;
            }
            let verdict = supervisor.on_tick(busy(completed), tick);
            assert!(verdict.feed_watchdog, "tick {tick}");
        }
    }

    #[test]
    fn a_link_stuck_sending_stops_feeding_after_the_threshold() {
        let mut supervisor = Supervisor::new(CONFIG);
        assert!(supervisor.on_tick(idle(3), 1).feed_watchdog);
        // The transfer starts and never completes.
        for tick in 0..CONFIG.link_stuck_ticks {
            let verdict = supervisor.on_tick(busy(3), 1);
            assert!(verdict.feed_watchdog, "tick {tick}: too early");
        }
        let verdict = supervisor.on_tick(busy(3), 1);
        assert!(!verdict.feed_watchdog);
        assert!(verdict.link_stuck);
        // It stays stuck for as long as nothing completes (until the watchdog resets).
        for _ in 0..1_000 {
            assert!(!supervisor.on_tick(busy(3), 1).feed_watchdog);
        }
    }

    #[test]
    fn a_completion_or_an_idle_tick_clears_a_stall() {
        let mut supervisor = Supervisor::new(CONFIG);
        for _ in 0..CONFIG.link_stuck_ticks {
            supervisor.on_tick(busy(0), 1);
        }
        // A completion just before the threshold: the count starts again.
        supervisor.on_tick(busy(1), 1);
        for _ in 0..CONFIG.link_stuck_ticks {
            assert!(supervisor.on_tick(busy(1), 1).feed_watchdog);
        }
        supervisor.on_tick(idle(1), 1);
        for _ in 0..CONFIG.link_stuck_ticks {
            assert!(supervisor.on_tick(busy(1), 1).feed_watchdog);
        }
    }

    #[test]
    fn the_completion_counter_may_wrap() {
        let mut supervisor = Supervisor::new(CONFIG);
        supervisor.on_tick(busy(u32::MAX), 1);
        for _ in 0..100 {
            // Alternating u32::MAX and 0: each tick sees a completion.
            assert!(supervisor.on_tick(busy(0), 1).feed_watchdog);
            assert!(supervisor.on_tick(busy(u32::MAX), 1).feed_watchdog);
        }
    }

    #[test]
    fn a_silent_receiver_is_reported_but_never_stops_the_feed() {
        let mut supervisor = Supervisor::new(CONFIG);
        supervisor.on_tick(idle(0), 500);
        for tick in 1..CONFIG.gnss_silent_ticks {
            let verdict = supervisor.on_tick(idle(0), 500);
            assert!(!verdict.gnss_silent, "tick {tick}: too early");
        }
        for _ in 0..5_000 {
            let verdict = supervisor.on_tick(idle(0), 500);
            assert!(verdict.gnss_silent);
            assert!(verdict.feed_watchdog);
        }
        // One byte and it is alive again.
        assert!(!supervisor.on_tick(idle(0), 501).gnss_silent);
    }

    #[test]
    fn a_receiver_that_never_talked_turns_silent_after_the_threshold() {
        let mut supervisor = Supervisor::new(CONFIG);
        let verdicts = (0..=CONFIG.gnss_silent_ticks).map(|_| supervisor.on_tick(idle(0), 0));
        let silent_from = verdicts.take_while(|verdict| !verdict.gnss_silent).count();
        assert_eq!(silent_from as u32, CONFIG.gnss_silent_ticks - 1);
    }
}
