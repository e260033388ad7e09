//! The robot's mode as the station last knew it, from what it sent.
//!
//! Ground link v1 carries no mode and no acknowledgement back: the station can only infer
//! the mode from its own commands and the robot's rules (it starts KILLED; a kill always
//! kills; a revive goes to MANUAL unless the robot refuses; a setpoint switches MANUAL to
//! AUTO; a manual command switches AUTO back to MANUAL). The display shows this as what was
//! sent, next to what came back.

use std::time::Instant;

use dima_groundlink::{Command, CommandType};

/// The mode the robot should be in, judging by the commands sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExpectedMode {
    /// Nothing but heartbeats sent: the robot's start-up state.
    KilledAtStart,
    /// The last decision was a kill.
    Killed,
    /// Revived, driven manually.
    Manual,
    /// Revived, then a setpoint was sent.
    Auto,
}

impl ExpectedMode {
    /// The robot's name for it.
    pub fn label(self) -> &'static str {
        match self {
            ExpectedMode::KilledAtStart | ExpectedMode::Killed => "KILLED",
            ExpectedMode::Manual => "MANUAL",
            ExpectedMode::Auto => "AUTO",
        }
    }
}

/// The expected mode from the last command of each type sent (index: type byte).
pub fn expected_mode(last_sent: &[Option<(Instant, Command)>; 8]) -> ExpectedMode {
    let at = |kinds: &[CommandType]| {
        kinds
            .iter()
            .filter_map(|k| last_sent[*k as usize].map(|(t, _)| t))
            .max()
    };
    let kill = at(&[CommandType::Kill]);
    let revive = at(&[CommandType::Revive]);
    let setpoint = at(&[CommandType::SpeedSetpoint, CommandType::HeadingSetpoint]);
    let manual = at(&[
        CommandType::Throttle,
        CommandType::Steering,
        CommandType::Tail,
    ]);
    match (kill, revive) {
        (None, None) => ExpectedMode::KilledAtStart,
        (Some(_), None) => ExpectedMode::Killed,
        (Some(k), Some(r)) if k >= r => ExpectedMode::Killed,
        (_, Some(r)) => match setpoint {
            Some(s) if s > r && manual.is_none_or(|m| s > m) => ExpectedMode::Auto,
            _ => ExpectedMode::Manual,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_groundlink::Percent;
    use std::time::Duration;

    fn sent(events: &[(u64, Command)]) -> [Option<(Instant, Command)>; 8] {
        let t0 = Instant::now();
        let mut out = [None; 8];
        for (ms, c) in events {
            out[c.command_type() as usize] = Some((t0 + Duration::from_millis(*ms), *c));
        }
        out
    }

    #[test]
    fn follows_the_robots_rules() {
        let p = Command::Throttle(Percent::HALF);
        assert_eq!(expected_mode(&sent(&[])), ExpectedMode::KilledAtStart);
        assert_eq!(
            expected_mode(&sent(&[(0, Command::Heartbeat)])),
            ExpectedMode::KilledAtStart
        );
        assert_eq!(
            expected_mode(&sent(&[(0, Command::Revive), (5, p)])),
            ExpectedMode::Manual
        );
        let speed = Command::SpeedSetpoint { mm_s: 1000 };
        assert_eq!(
            expected_mode(&sent(&[(0, Command::Revive), (5, p), (9, speed)])),
            ExpectedMode::Auto
        );
        assert_eq!(
            expected_mode(&sent(&[(0, Command::Revive), (9, speed), (12, p)])),
            ExpectedMode::Manual
        );
        assert_eq!(
            expected_mode(&sent(&[
                (0, Command::Revive),
                (9, speed),
                (12, Command::Kill)
            ])),
            ExpectedMode::Killed
        );
        assert_eq!(
            expected_mode(&sent(&[(0, Command::Kill), (12, Command::Revive)])),
            ExpectedMode::Manual
        );
        // A setpoint sent while killed does not count once revived.
        assert_eq!(
            expected_mode(&sent(&[
                (0, speed),
                (3, Command::Kill),
                (12, Command::Revive)
            ])),
            ExpectedMode::Manual
        );
    }
}
