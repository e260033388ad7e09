//! The heading setpoint the map draws as an arrow from the car.
//!
//! For now the station knows only what it sent itself: the last heading setpoint, while
//! nothing sent since took the robot out of AUTO. When the robot's display frames report its
//! active setpoints, [`heading_setpoint_deg`] is the one place to switch to the robot's
//! report (what the robot follows rather than what was asked).

use std::time::Instant;

use dima_groundlink::v2::RobotMode;
use dima_groundlink::{Command, CommandType};

/// Commands that end AUTO (a kill or revive resets the robot's mode, a manual command
/// switches to MANUAL): a heading setpoint sent before one of these is no longer followed.
const ENDS_AUTO: [CommandType; 5] = [
    CommandType::Kill,
    CommandType::Revive,
    CommandType::Throttle,
    CommandType::Steering,
    CommandType::Tail,
];

/// The heading setpoint in force, degrees clockwise from north, from the last command of
/// each type the station sent (`last_sent`, indexed by type byte, as the link reports it)
/// and the robot's reported mode (ground link v2; `None` with v1): the last heading
/// setpoint sent, unless a command that ends AUTO went out after it, or the robot reported a
/// mode other than AUTO in a frame that came after it.
pub fn heading_setpoint_deg(
    last_sent: &[Option<(Instant, Command)>; 8],
    robot_mode: Option<(Instant, RobotMode)>,
) -> Option<f64> {
    let (sent_at, command) = last_sent[CommandType::HeadingSetpoint as usize]?;
    let Command::HeadingSetpoint { deg_e5 } = command else {
        return None;
    };
    let ended = ENDS_AUTO
        .iter()
        .filter_map(|&kind| last_sent[kind as usize])
        .any(|(at, _)| at >= sent_at);
    let left_auto = robot_mode.is_some_and(|(at, mode)| at > sent_at && mode != RobotMode::Auto);
    (!ended && !left_auto).then_some(f64::from(deg_e5) / 1e5)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_groundlink::Percent;
    use std::time::Duration;

    #[test]
    fn the_setpoint_holds_until_something_ends_auto() {
        let t0 = Instant::now();
        let at = |s: u64| t0 + Duration::from_secs(s);
        let mut sent: [Option<(Instant, Command)>; 8] = [None; 8];
        assert_eq!(heading_setpoint_deg(&sent, None), None);
        sent[CommandType::Revive as usize] = Some((at(1), Command::Revive));
        sent[CommandType::HeadingSetpoint as usize] =
            Some((at(2), Command::HeadingSetpoint { deg_e5: 9_000_000 }));
        assert_eq!(heading_setpoint_deg(&sent, None), Some(90.0));
        // The robot still reports MANUAL from before the setpoint arrived: still shown.
        assert_eq!(
            heading_setpoint_deg(&sent, Some((at(1), RobotMode::Manual))),
            Some(90.0)
        );
        assert_eq!(
            heading_setpoint_deg(&sent, Some((at(3), RobotMode::Auto))),
            Some(90.0)
        );
        assert_eq!(
            heading_setpoint_deg(&sent, Some((at(3), RobotMode::Failsafe))),
            None
        );
        let throttle = Command::Throttle(Percent::new(10).unwrap());
        sent[CommandType::Throttle as usize] = Some((at(4), throttle));
        assert_eq!(heading_setpoint_deg(&sent, None), None, "manual took over");
        sent[CommandType::HeadingSetpoint as usize] =
            Some((at(5), Command::HeadingSetpoint { deg_e5: 27_050_000 }));
        assert_eq!(heading_setpoint_deg(&sent, None), Some(270.5));
        sent[CommandType::Kill as usize] = Some((at(6), Command::Kill));
        assert_eq!(heading_setpoint_deg(&sent, None), None, "killed");
    }
}
