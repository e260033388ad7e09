//! The randomised operator: what a person at the ground station does, at random intervals
//! (100 ms to 3 s, log-uniform: quick successions too), drawn from the seed. Revives (often again and again), kills, one-off manual
//! values, values held on a key or slider (and released), speed and heading setpoints, all of
//! it also while the robot is KILLED or in FAILSAFE, and held keys kept across failsafes.

use crate::rng::SimRng;
use dima_core::Nanos;
use dima_groundlink::station::ManualChannel;
use dima_groundlink::v2::RobotMode;
use dima_groundlink::{Command, Percent, HEADING_FULL_TURN_DEG_E5};

/// Shortest time between two operator actions, ns.
pub const MIN_INTERVAL_NS: Nanos = 100_000_000;
/// Longest time between two operator actions, ns.
pub const MAX_INTERVAL_NS: Nanos = 3_000_000_000;

/// One thing the operator does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// A one-off request: revive, kill, a manual value or a setpoint.
    Request(Command),
    /// A value held on a channel (a key or a slider), repeated until released.
    Hold(ManualChannel, Command),
    /// The key or slider on a channel let go.
    Release(ManualChannel),
}

/// The operator's random choices.
#[derive(Debug, Clone)]
pub struct Operator {
    rng: SimRng,
    next_ns: Nanos,
    max_speed_mm_s: i32,
}

impl Operator {
    /// An operator whose first action comes after `start_ns`.
    pub fn new(mut rng: SimRng, start_ns: Nanos, max_speed_mm_s: i32) -> Operator {
        let next_ns = start_ns + interval(&mut rng);
        Operator {
            rng,
            next_ns,
            max_speed_mm_s,
        }
    }

    /// When the operator acts next.
    pub fn next_at(&self) -> Nanos {
        self.next_ns
    }

    /// The action due now, given the mode the station shows (`None`: nothing shown yet); the
    /// next one is scheduled.
    pub fn act(&mut self, shown: Option<RobotMode>) -> Action {
        self.next_ns += interval(&mut self.rng);
        let safe = !matches!(shown, Some(RobotMode::Manual | RobotMode::Auto));
        let r = &mut self.rng;
        // An operator looking at a KILLED or FAILSAFE robot mostly revives it, but also
        // moves sliders and keys before doing so.
        let revive_weight = if safe { 30 } else { 3 };
        let weights = [revive_weight, 2, 12, 6, 10, 14, 8];
        let total: u64 = weights.iter().sum();
        let mut pick = r.below(total);
        let mut kind = 0;
        for (i, w) in weights.iter().enumerate() {
            if pick < *w {
                kind = i;
                break;
            }
            pick -= w;
        }
        let channel = ManualChannel::ALL[r.below(3) as usize];
        let percent = Percent::new(r.below(101) as u8).unwrap_or(Percent::HALF);
        match kind {
            0 => Action::Request(Command::Revive),
            1 => Action::Request(Command::Kill),
            2 => Action::Request(channel.command(percent)),
            3 => Action::Hold(channel, channel.command(percent)),
            4 => Action::Release(channel),
            5 => {
                // Mostly forward speeds, sometimes a stop, rarely an invalid reverse speed.
                let mm_s = match r.below(10) {
                    0 | 1 => 0,
                    2 => -(r.below(3_000) as i32) - 1,
                    _ => r.below(self.max_speed_mm_s as u64 + 1) as i32,
                };
                Action::Request(Command::SpeedSetpoint { mm_s })
            }
            _ => Action::Request(Command::HeadingSetpoint {
                deg_e5: r.below(HEADING_FULL_TURN_DEG_E5 as u64) as i32,
            }),
        }
    }
}

/// Log-uniform between the bounds: quick successions of actions are as likely as slow ones.
fn interval(rng: &mut SimRng) -> Nanos {
    let (lo, hi) = (MIN_INTERVAL_NS as f64, MAX_INTERVAL_NS as f64);
    let t = lo * (hi / lo).powf(rng.uniform());
    (t as Nanos).clamp(MIN_INTERVAL_NS, MAX_INTERVAL_NS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acts_at_random_intervals_within_bounds_and_does_everything() {
        let mut op = Operator::new(SimRng::new(3), 0, 5_000);
        let mut last = 0;
        let mut seen = [false; 4];
        for _ in 0..2_000 {
            let at = op.next_at();
            assert!((MIN_INTERVAL_NS..=MAX_INTERVAL_NS).contains(&(at - last)));
            last = at;
            match op.act(Some(RobotMode::Killed)) {
                Action::Request(Command::Revive) => seen[0] = true,
                Action::Request(Command::Kill) => seen[1] = true,
                Action::Hold(..) => seen[2] = true,
                Action::Release(_) => seen[3] = true,
                _ => {}
            }
        }
        assert_eq!(seen, [true; 4]);
    }
}
