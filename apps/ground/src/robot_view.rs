//! What the station shows as the robot's state, as a pure function of what the link received:
//! the robot's actual outputs and setpoints (never the station's own intent), whether the
//! drive controls can do anything ([`Liveness`]), and the downlink's loss measured from its
//! sequence numbers ([`SequenceLoss`]).

use std::time::{Duration, Instant};

use dima_groundlink::v2::{Actuation, ControllerCode, RobotMode};

use crate::downlink::DownlinkHealth;
use crate::link::{LinkStatus, RobotReport};
use crate::recording::mode_name;

/// Whether the drive controls (sliders, setpoints) can do anything now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Liveness {
    /// A fresh report says MANUAL or AUTO (v1: fresh frames arrive).
    Live,
    /// No fresh downlink: the robot's state is unknown.
    NoFreshReport(DownlinkHealth),
    /// The robot reports a mode in which drive commands do nothing (KILLED, FAILSAFE).
    NotDriving(RobotMode),
}

impl Liveness {
    /// From the link's status at `now`.
    pub fn of(status: &LinkStatus, now: Instant) -> Liveness {
        let health = status.downlink(now);
        match health {
            DownlinkHealth::Authentic => match status.fresh_report(now).map(|r| r.mode) {
                Some(RobotMode::Manual | RobotMode::Auto) => Liveness::Live,
                Some(mode) => Liveness::NotDriving(mode),
                None => Liveness::NoFreshReport(health),
            },
            // Version 1 carries no mode: fresh frames are all the station can know.
            DownlinkHealth::V1NoReport => Liveness::Live,
            other => Liveness::NoFreshReport(other),
        }
    }

    /// The drive controls are enabled.
    pub fn is_live(self) -> bool {
        self == Liveness::Live
    }

    /// Why the drive controls are greyed, for a tooltip or a line under them.
    pub fn why_greyed(self) -> Option<String> {
        match self {
            Liveness::Live => None,
            Liveness::NoFreshReport(health) => Some(format!(
                "drive controls off: no fresh report from the robot ({})",
                health.short()
            )),
            Liveness::NotDriving(mode) => Some(format!(
                "drive controls off: the robot is {} (revive first)",
                mode_name(mode)
            )),
        }
    }
}

/// What the station knows of the robot's outputs and setpoints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Truth<'a> {
    /// A fresh report with the robot's outputs (display frame v3).
    Fresh(&'a Actuation),
    /// The last report with outputs is this old: not the robot's state now.
    Stale(&'a Actuation, Duration),
    /// The robot's reports do not carry its outputs (display frame v2).
    NotReported,
    /// No report at all.
    Unknown,
}

impl<'a> Truth<'a> {
    /// From the link's status at `now`.
    pub fn of(status: &'a LinkStatus, now: Instant) -> Truth<'a> {
        let Some(report) = status.robot.as_ref() else {
            return Truth::Unknown;
        };
        let Some(actuation) = report.actuation.as_ref() else {
            return Truth::NotReported;
        };
        if status.fresh_report(now).is_some() {
            Truth::Fresh(actuation)
        } else {
            Truth::Stale(actuation, now.saturating_duration_since(report.at))
        }
    }

    /// The text next to a drive slider (`channel`: 0 throttle, 1 steering, 2 tail): the
    /// servo target the robot commanded, in microseconds, never the station's own.
    pub fn output_text(self, channel: usize) -> String {
        match self {
            // 0: the robot has commanded nothing yet (its loop has not run a cycle).
            Truth::Fresh(a) | Truth::Stale(a, _) if a.servo_quarter_us[channel] == 0 => {
                "robot: nothing commanded yet".to_owned()
            }
            Truth::Fresh(a) => format!("robot {} µs", a.servo_us()[channel]),
            Truth::Stale(a, age) => format!(
                "robot {} µs, {:.1} s ago",
                a.servo_us()[channel],
                age.as_secs_f64()
            ),
            Truth::NotReported => "robot: not reported (v2)".to_owned(),
            Truth::Unknown => "robot: unknown".to_owned(),
        }
    }

    /// The robot's speed setpoint, or "none".
    pub fn speed_setpoint_text(self) -> String {
        self.field(|a| a.speed_setpoint_mm_s, speed_text)
    }

    /// The robot's heading setpoint, or "none".
    pub fn heading_setpoint_text(self) -> String {
        self.field(|a| a.heading_setpoint_deg_e5, heading_text)
    }

    /// The robot's speed estimate, or "none".
    pub fn speed_estimate_text(self) -> String {
        self.field(|a| a.speed_estimate_mm_s, speed_text)
    }

    /// The robot's heading estimate, or "none".
    pub fn heading_estimate_text(self) -> String {
        self.field(|a| a.heading_estimate_deg_e5, heading_text)
    }

    /// The robot's speed error (setpoint minus estimate), or "none".
    pub fn speed_error_text(self) -> String {
        self.field(
            |a| a.speed_error_mm_s,
            |v| format!("{:+.2} m/s", v as f64 / 1000.0),
        )
    }

    /// The configured controller kinds: throttle, steering, tail.
    pub fn controllers_text(self) -> String {
        match self {
            Truth::Fresh(a) | Truth::Stale(a, _) => {
                let name = |c: ControllerCode| match c.name() {
                    Some(n) => n.to_owned(),
                    None => format!("kind {}", c.code()),
                };
                format!(
                    "{} / {} / {}",
                    name(a.controllers[0]),
                    name(a.controllers[1]),
                    name(a.controllers[2])
                )
            }
            Truth::NotReported => "not reported (v2)".to_owned(),
            Truth::Unknown => "unknown".to_owned(),
        }
    }

    fn field(self, get: fn(&Actuation) -> Option<i32>, show: fn(i32) -> String) -> String {
        let shown = |a: &Actuation| get(a).map_or_else(|| "none".to_owned(), show);
        match self {
            Truth::Fresh(a) => shown(a),
            Truth::Stale(a, age) => format!("{}, {:.1} s ago", shown(a), age.as_secs_f64()),
            Truth::NotReported => "not reported (v2)".to_owned(),
            Truth::Unknown => "unknown".to_owned(),
        }
    }
}

fn speed_text(mm_s: i32) -> String {
    format!("{:.2} m/s", mm_s as f64 / 1000.0)
}

fn heading_text(deg_e5: i32) -> String {
    format!("{:.1}°", deg_e5 as f64 / 1e5)
}

/// Display frames lost on the downlink, from the gaps in their sequence numbers (the robot
/// numbers them one by one from 1 each boot).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SequenceLoss {
    session: Option<u32>,
    last_seq: Option<u32>,
    /// Frames received in sequence (the first of a session included).
    pub received: u64,
    /// Frames missing between received ones.
    pub lost: u64,
    /// Received and lost over the last [`SequenceLoss::RECENT`] sequence numbers, for a
    /// figure that recovers.
    recent: [u64; 2],
}

impl SequenceLoss {
    /// Sequence numbers over which the recent loss is measured (about 10 s at 2 Hz).
    pub const RECENT: u64 = 20;

    /// A fresh report with `seq` in `session`. A new session or a number that goes back (a
    /// reboot) starts counting afresh from it; a repeated number is ignored.
    pub fn on_report(&mut self, session: u32, seq: u32) {
        match (self.session, self.last_seq) {
            (Some(s), Some(last)) if s == session && seq > last => {
                let gap = u64::from(seq - last - 1);
                self.lost += gap;
                self.received += 1;
                self.recent = [self.recent[0] + 1, self.recent[1] + gap];
                let span = self.recent[0] + self.recent[1];
                if span > Self::RECENT {
                    // Keep the ratio, forget the weight of old numbers.
                    let keep = Self::RECENT as f64 / span as f64;
                    self.recent = self.recent.map(|n| (n as f64 * keep).round() as u64);
                }
            }
            (Some(s), Some(last)) if s == session && seq <= last => return,
            _ => {
                self.received += 1;
                self.recent = [1, 0];
            }
        }
        self.session = Some(session);
        self.last_seq = Some(seq);
    }

    /// Lost fraction since the station started, `None` before two frames.
    pub fn total_fraction(&self) -> Option<f64> {
        let n = self.received + self.lost;
        (self.received >= 2).then(|| self.lost as f64 / n as f64)
    }

    /// Lost fraction over the recent sequence numbers.
    pub fn recent_fraction(&self) -> Option<f64> {
        let n = self.recent[0] + self.recent[1];
        (self.recent[0] >= 2).then(|| self.recent[1] as f64 / n as f64)
    }
}

/// The text next to a drive slider (`channel`: 0 throttle, 1 steering, 2 tail). The slider
/// holds what the operator asks for; the text is what the robot commanded its servo, never
/// the pulse width of the operator's request, which the robot may not follow (KILLED,
/// FAILSAFE, AUTO, a lost frame).
pub fn slider_text(truth: Truth<'_>, channel: usize) -> String {
    truth.output_text(channel)
}

/// The report's age at `now`, for a label.
pub fn report_age(report: &RobotReport, now: Instant) -> Duration {
    now.saturating_duration_since(report.at)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::LinkStatus;
    use dima_groundlink::v2::{FailsafeCause, Health};

    /// A station connected for a while that got `report` `age` ago.
    fn status_with(report: RobotReport, now: Instant, age: Duration) -> LinkStatus {
        let at = now - age;
        LinkStatus {
            authenticated: true,
            robot: Some(RobotReport { at, ..report }),
            connected_at: Some(now - Duration::from_secs(30)),
            last_byte_at: Some(at),
            last_frame_at: Some(at),
            ..LinkStatus::default()
        }
    }

    fn report(mode: RobotMode, actuation: Option<Actuation>) -> RobotReport {
        RobotReport {
            at: Instant::now(),
            mode,
            failsafe_cause: (mode == RobotMode::Failsafe).then_some(FailsafeCause::CommsLoss),
            revive_refusal: None,
            session: 7,
            seq: 40,
            ack_seq: 12,
            health: Health::default(),
            actuation,
        }
    }

    /// The safe outputs in quarter-microseconds (1500, 1545, 1500 µs).
    const SAFE_QUS: [u16; 3] = [6000, 6180, 6000];

    #[test]
    fn failsafe_shows_the_robots_safe_outputs_and_greys_the_controls() {
        let now = Instant::now() + Duration::from_secs(60);
        let safe = Actuation {
            servo_quarter_us: SAFE_QUS,
            ..Actuation::default()
        };
        let s = status_with(
            report(RobotMode::Failsafe, Some(safe)),
            now,
            Duration::from_millis(200),
        );
        // The operator's sliders still hold 70 % (1700 µs): what is shown is the robot's.
        let shown = slider_text(Truth::of(&s, now), 0);
        assert_eq!(shown, "robot 1500 µs");
        assert!(!shown.contains("1700"), "{shown}");
        assert_eq!(
            Liveness::of(&s, now),
            Liveness::NotDriving(RobotMode::Failsafe)
        );
        assert!(Liveness::of(&s, now)
            .why_greyed()
            .unwrap()
            .contains("FAILSAFE"));
    }

    #[test]
    fn auto_with_a_speed_setpoint_only_shows_no_heading_setpoint() {
        let now = Instant::now() + Duration::from_secs(60);
        let auto = Actuation {
            servo_quarter_us: [6800, 6180, 6000],
            speed_setpoint_mm_s: Some(1500),
            speed_estimate_mm_s: Some(1200),
            speed_error_mm_s: Some(300),
            controllers: [
                ControllerCode::SpeedPid,
                ControllerCode::HeadingPid,
                ControllerCode::Neutral,
            ],
            ..Actuation::default()
        };
        let s = status_with(
            report(RobotMode::Auto, Some(auto)),
            now,
            Duration::from_millis(100),
        );
        let t = Truth::of(&s, now);
        assert_eq!(t.output_text(0), "robot 1700 µs");
        assert_eq!(t.speed_setpoint_text(), "1.50 m/s");
        assert_eq!(t.heading_setpoint_text(), "none");
        assert_eq!(t.speed_error_text(), "+0.30 m/s");
        assert_eq!(t.controllers_text(), "speed_pid / heading_pid / none");
        assert_eq!(Liveness::of(&s, now), Liveness::Live);
    }

    #[test]
    fn an_old_report_is_not_the_robots_state_and_greys_the_controls() {
        let now = Instant::now() + Duration::from_secs(60);
        let driving = Actuation {
            servo_quarter_us: [6800, 6180, 6000],
            ..Actuation::default()
        };
        let s = status_with(
            report(RobotMode::Manual, Some(driving)),
            now,
            Duration::from_secs(5),
        );
        assert_eq!(
            Truth::of(&s, now).output_text(0),
            "robot 1700 µs, 5.0 s ago"
        );
        assert!(matches!(
            Liveness::of(&s, now),
            Liveness::NoFreshReport(DownlinkHealth::Silent)
        ));
        // A v2 robot: its outputs are not known, whatever the station sent.
        let s = status_with(report(RobotMode::Manual, None), now, Duration::ZERO);
        assert_eq!(
            Truth::of(&s, now).output_text(1),
            "robot: not reported (v2)"
        );
        assert_eq!(
            Truth::of(&LinkStatus::default(), now).output_text(2),
            "robot: unknown"
        );
    }

    #[test]
    fn loss_counts_gaps_and_restarts_with_a_new_session() {
        let mut loss = SequenceLoss::default();
        assert_eq!(loss.total_fraction(), None);
        for seq in [1, 2, 3, 5, 6, 10] {
            loss.on_report(9, seq);
        }
        assert_eq!((loss.received, loss.lost), (6, 4));
        assert_eq!(loss.total_fraction(), Some(0.4));
        // A repeated number changes nothing; a reboot (new session) starts afresh.
        loss.on_report(9, 10);
        loss.on_report(4, 1);
        loss.on_report(4, 2);
        assert_eq!((loss.received, loss.lost), (8, 4));
        assert_eq!(loss.recent_fraction(), Some(0.0));
        // Recent loss recovers once frames arrive in sequence again.
        for seq in 3..60 {
            loss.on_report(4, seq);
        }
        assert_eq!(loss.recent_fraction(), Some(0.0));
        loss.on_report(4, 70);
        assert!(loss.recent_fraction().unwrap() >= 0.25, "{loss:?}");
    }
}
