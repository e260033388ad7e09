//! The heading setpoint the map draws as an arrow from the car.
//!
//! A robot that sends display frames v3 reports the setpoint it follows: the arrow is that
//! one ([`shown_heading_setpoint_deg`]), and none while the report is stale. From a robot that
//! sends display frames v2 the station knows only what it sent itself
//! ([`heading_setpoint_deg`]): the last heading setpoint, while nothing sent since took the
//! robot out of AUTO.

use std::time::Instant;

use dima_groundlink::v2::RobotMode;

use crate::robot_view::Truth;
use dima_groundlink::{Command, CommandType};

/// The heading setpoint to draw, degrees clockwise from north: the robot's own (`truth`, a
/// fresh display frame v3), none when its report is stale or there is none, and only from a
/// robot whose frames do not carry its setpoints (v2) what the station sent (`sent`).
pub fn shown_heading_setpoint_deg(
    truth: Truth<'_>,
    sent: impl FnOnce() -> Option<f64>,
) -> Option<f64> {
    match truth {
        Truth::Fresh(a) => a.heading_setpoint_deg_e5.map(|v| f64::from(v) / 1e5),
        Truth::Stale(..) | Truth::Unknown => None,
        Truth::NotReported => sent(),
    }
}

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
    use dima_groundlink::v2::Actuation;

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

    #[test]
    fn the_arrow_is_the_robots_setpoint_when_it_reports_one() {
        let reported = |deg_e5: Option<i32>| Actuation {
            heading_setpoint_deg_e5: deg_e5,
            ..Actuation::default()
        };
        let sent = || Some(60.0);
        let with = reported(Some(9_000_000));
        assert_eq!(
            shown_heading_setpoint_deg(Truth::Fresh(&with), sent),
            Some(90.0)
        );
        // The robot follows no heading (a speed setpoint alone): no arrow, whatever was sent.
        let without = reported(None);
        assert_eq!(
            shown_heading_setpoint_deg(Truth::Fresh(&without), sent),
            None
        );
        let age = std::time::Duration::from_secs(3);
        assert_eq!(
            shown_heading_setpoint_deg(Truth::Stale(&with, age), sent),
            None
        );
        assert_eq!(shown_heading_setpoint_deg(Truth::Unknown, sent), None);
        assert_eq!(
            shown_heading_setpoint_deg(Truth::NotReported, sent),
            Some(60.0)
        );
    }
}
