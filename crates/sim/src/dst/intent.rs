//! What the operator asked for and when: the harness's record, against which the robot's
//! outputs and revives are judged (never the robot's own state).

use dima_core::Nanos;
use dima_groundlink::station::ManualChannel;
use dima_groundlink::{Command, Percent};

use super::operator::Action;

/// Every operator action that asks for something, in time order.
#[derive(Debug, Clone, Default)]
pub struct Intent {
    revives: Vec<Nanos>,
    kills: Vec<Nanos>,
    manual: [Vec<(Nanos, Percent)>; 3],
    speeds: Vec<(Nanos, i32)>,
    headings: Vec<(Nanos, i32)>,
}

fn index(channel: ManualChannel) -> usize {
    match channel {
        ManualChannel::Throttle => 0,
        ManualChannel::Steering => 1,
        ManualChannel::Tail => 2,
    }
}

/// The manual channel a command drives, and its value.
pub fn manual_value(command: Command) -> Option<(ManualChannel, Percent)> {
    match command {
        Command::Throttle(p) => Some((ManualChannel::Throttle, p)),
        Command::Steering(p) => Some((ManualChannel::Steering, p)),
        Command::Tail(p) => Some((ManualChannel::Tail, p)),
        _ => None,
    }
}

/// The latest time in `times` at or before `at`.
fn latest_at(times: impl DoubleEndedIterator<Item = Nanos>, at: Nanos) -> Option<Nanos> {
    times.rev().find(|&t| t <= at)
}

impl Intent {
    /// Notes an operator action at `now`.
    pub fn note(&mut self, action: Action, now: Nanos) {
        let command = match action {
            Action::Request(c) | Action::Hold(_, c) => c,
            Action::Release(_) => return,
        };
        match command {
            Command::Revive => self.revives.push(now),
            Command::Kill => self.kills.push(now),
            Command::SpeedSetpoint { mm_s } => self.speeds.push((now, mm_s)),
            Command::HeadingSetpoint { deg_e5 } => self.headings.push((now, deg_e5)),
            other => {
                if let Some((channel, p)) = manual_value(other) {
                    self.manual[index(channel)].push((now, p));
                }
            }
        }
    }

    /// When the operator asked for `command` (the latest such action at or before `at`): the
    /// origin of a frame the station sent at `at`.
    pub fn asked_at(&self, command: Command, at: Nanos) -> Option<Nanos> {
        match command {
            Command::Heartbeat => None,
            Command::Revive => latest_at(self.revives.iter().copied(), at),
            Command::Kill => latest_at(self.kills.iter().copied(), at),
            Command::SpeedSetpoint { mm_s } => {
                latest_at(self.speeds.iter().filter(|s| s.1 == mm_s).map(|s| s.0), at)
            }
            Command::HeadingSetpoint { deg_e5 } => latest_at(
                self.headings.iter().filter(|s| s.1 == deg_e5).map(|s| s.0),
                at,
            ),
            other => {
                let (channel, p) = manual_value(other)?;
                latest_at(
                    self.manual[index(channel)]
                        .iter()
                        .filter(|v| v.1 == p)
                        .map(|v| v.0),
                    at,
                )
            }
        }
    }

    /// Values the operator asked for on `channel` after `after`.
    pub fn manual_after(
        &self,
        channel: ManualChannel,
        after: Nanos,
    ) -> impl Iterator<Item = Percent> + '_ {
        self.manual[index(channel)]
            .iter()
            .filter(move |v| v.0 > after)
            .map(|v| v.1)
    }

    /// Whether the operator asked for a speed setpoint in `1..=max` after `after`.
    pub fn positive_speed_after(&self, after: Nanos, max_mm_s: i32) -> bool {
        self.speeds
            .iter()
            .any(|s| s.0 > after && (1..=max_mm_s).contains(&s.1))
    }

    /// Whether the operator asked for a valid setpoint (a speed in `0..=max`, or a heading)
    /// after `after`: one that enters AUTO from MANUAL.
    pub fn setpoint_after(&self, after: Nanos, max_mm_s: i32) -> bool {
        self.heading_after(after)
            || self
                .speeds
                .iter()
                .any(|s| s.0 > after && (0..=max_mm_s).contains(&s.1))
    }

    /// Whether the operator asked for a heading setpoint after `after`.
    pub fn heading_after(&self, after: Nanos) -> bool {
        self.headings.iter().any(|s| s.0 > after)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_trace_back_to_the_latest_matching_action() {
        let mut i = Intent::default();
        let p = |v| Percent::new(v).unwrap();
        i.note(Action::Request(Command::Throttle(p(60))), 10);
        i.note(
            Action::Hold(ManualChannel::Throttle, Command::Throttle(p(70))),
            20,
        );
        i.note(Action::Request(Command::Throttle(p(60))), 30);
        i.note(Action::Request(Command::Revive), 40);
        assert_eq!(i.asked_at(Command::Throttle(p(60)), 25), Some(10));
        assert_eq!(i.asked_at(Command::Throttle(p(60)), 35), Some(30));
        assert_eq!(i.asked_at(Command::Throttle(p(70)), 15), None);
        assert_eq!(i.asked_at(Command::Revive, 50), Some(40));
        let after: Vec<_> = i.manual_after(ManualChannel::Throttle, 15).collect();
        assert_eq!(after, [p(70), p(60)]);
        assert!(!i.positive_speed_after(0, 5_000));
    }
}
