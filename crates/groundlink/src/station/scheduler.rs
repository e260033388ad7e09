//! Which command frames go out when (ground link v1 and v2).
//!
//! - One slot every [`HEARTBEAT_PERIOD`]: the pending commands go out in it (coalesced: only the
//!   latest value per command type), and the values the operator holds (a key, a stick, a
//!   slider being dragged) are repeated in every slot; with nothing to say the slot carries a
//!   heartbeat. So a pending command replaces the heartbeat once.
//! - A kill goes out at once, outside the slot rhythm, and then in every slot for
//!   [`KILL_REPEAT`], ahead of everything else. Everything pending and every held value is
//!   dropped when a kill is requested.
//! - A revive ends the repetition of an earlier kill (the operator's latest decision wins),
//!   and goes out no sooner than [`REVIVE_AFTER_KILL`] after the last kill frame: the robot
//!   refuses a revive that follows a kill too closely (`safety.revive_min_interval_ms`,
//!   250 ms by default), so a revive right after the kill's repetition would be refused.
//! - **Nothing asked for before a revive drives after it**: pending manual values and
//!   setpoints and every held value are dropped when a revive is requested, and again when it
//!   goes out (what was asked for while it waited). A revived robot starts at neutral in
//!   MANUAL; a key, stick or slider still held must be let go and moved again to drive.
//!   [`cancel_driving`](CommandScheduler::cancel_driving) drops the same on demand (a v2
//!   station does when the robot reports KILLED or FAILSAFE), and
//!   [`cancellations`](CommandScheduler::cancellations) counts these drops so that a user
//!   interface can reset its controls.
//!
//! [`poll_slot`](CommandScheduler::poll_slot) says where each frame comes from
//! ([`Origin`]): ground link v2 repeats a requested command until the robot acknowledges
//! it (see [`super::uplink`]), and needs to tell it from a held value or a heartbeat.
//!
//! Time is an input ([`StationTime`] arguments), so every rule is tested without sleeping.

use core::time::Duration;
use std::vec::Vec;

use super::StationTime;
use crate::{Command, CommandType};

/// The slot period: one frame (at least a heartbeat) every 100 ms.
pub const HEARTBEAT_PERIOD: Duration = Duration::from_millis(100);
/// How long a kill is repeated after it was requested.
pub const KILL_REPEAT: Duration = Duration::from_secs(1);
/// The shortest time between the last kill frame and a revive (longer than the robot's
/// default `safety.revive_min_interval_ms`, 250 ms).
pub const REVIVE_AFTER_KILL: Duration = Duration::from_millis(300);
/// Dropped requests kept for [`CommandScheduler::take_dropped`] (the oldest go first).
const DROPPED_KEPT: usize = 64;

/// Why a frame is in a slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Origin {
    /// A kill: at once, then repeated for [`KILL_REPEAT`].
    Kill,
    /// A requested command (revive, a one-off manual value, a setpoint), once.
    Request,
    /// A value the operator holds, repeated in every slot.
    Held,
    /// Nothing else to say.
    Heartbeat,
}

/// One frame of a slot and why it is there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scheduled {
    /// The command.
    pub command: Command,
    /// Why it goes out.
    pub origin: Origin,
}

/// The manual channels an operator can hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ManualChannel {
    /// Throttle (command type 3).
    Throttle,
    /// Steering (command type 4).
    Steering,
    /// Tail (command type 5).
    Tail,
}

impl ManualChannel {
    /// All three, in wire order.
    pub const ALL: [ManualChannel; 3] = [
        ManualChannel::Throttle,
        ManualChannel::Steering,
        ManualChannel::Tail,
    ];

    fn index(self) -> usize {
        self as usize
    }

    /// The command carrying `percent` on this channel.
    pub fn command(self, percent: crate::Percent) -> Command {
        match self {
            ManualChannel::Throttle => Command::Throttle(percent),
            ManualChannel::Steering => Command::Steering(percent),
            ManualChannel::Tail => Command::Tail(percent),
        }
    }

    /// A short lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            ManualChannel::Throttle => "throttle",
            ManualChannel::Steering => "steering",
            ManualChannel::Tail => "tail",
        }
    }
}

/// The command schedule of one link session.
#[derive(Debug, Clone)]
pub struct CommandScheduler {
    period: Duration,
    next_slot: Option<StationTime>,
    kill_until: Option<StationTime>,
    kill_now: bool,
    /// When the last kill frame went out.
    last_kill: Option<StationTime>,
    /// Pending commands in request order, at most one per type, with their request time.
    pending: Vec<(Command, StationTime)>,
    held: [Option<Command>; 3],
    /// Pending requests dropped by a kill, a revive or `cancel_driving`, not yet taken.
    dropped: Vec<(Command, StationTime)>,
    /// Times manual values and setpoints were dropped.
    cancellations: u64,
}

impl Default for CommandScheduler {
    fn default() -> Self {
        CommandScheduler::new(HEARTBEAT_PERIOD)
    }
}

impl CommandScheduler {
    /// A schedule with slots every `period` (the protocol's is [`HEARTBEAT_PERIOD`]).
    pub fn new(period: Duration) -> CommandScheduler {
        CommandScheduler {
            period,
            next_slot: None,
            kill_until: None,
            kill_now: false,
            last_kill: None,
            pending: Vec::new(),
            held: [None; 3],
            dropped: Vec::new(),
            cancellations: 0,
        }
    }

    /// Queues `command` for the next slot (a kill goes out at once: see the module docs).
    pub fn request(&mut self, command: Command, now: StationTime) {
        match command {
            Command::Kill => {
                self.kill_now = true;
                self.kill_until = Some(now + KILL_REPEAT);
                let all = core::mem::take(&mut self.pending);
                self.note_dropped(all);
                self.held = [None; 3];
                self.cancellations = self.cancellations.saturating_add(1);
            }
            Command::Heartbeat => {}
            other => {
                if other == Command::Revive {
                    self.kill_until = None;
                    self.kill_now = false;
                    self.cancel_driving();
                }
                let kind = other.command_type();
                self.pending.retain(|(c, _)| c.command_type() != kind);
                self.pending.push((other, now));
            }
        }
    }

    /// Drops every pending manual value and setpoint and every held value (the robot went
    /// safe, or a revive was asked for: see the module docs).
    pub fn cancel_driving(&mut self) {
        let (driving, rest): (Vec<_>, Vec<_>) = core::mem::take(&mut self.pending)
            .into_iter()
            .partition(|(c, _)| c.drives());
        self.pending = rest;
        self.note_dropped(driving);
        self.held = [None; 3];
        self.cancellations = self.cancellations.saturating_add(1);
    }

    /// How many times pending and held manual values and setpoints were dropped (by kills,
    /// revives and [`cancel_driving`](Self::cancel_driving)): a user interface that sees it
    /// change resets its controls to neutral and waits for them to be let go.
    pub fn cancellations(&self) -> u64 {
        self.cancellations
    }

    /// Pending requests dropped (by a kill, a revive or
    /// [`cancel_driving`](Self::cancel_driving)) since the last call, with the time each was
    /// requested. Held values are not listed.
    pub fn take_dropped(&mut self) -> Vec<(Command, StationTime)> {
        core::mem::take(&mut self.dropped)
    }

    fn note_dropped(&mut self, commands: Vec<(Command, StationTime)>) {
        for c in commands {
            if self.dropped.len() == DROPPED_KEPT {
                self.dropped.remove(0);
            }
            self.dropped.push(c);
        }
    }

    /// Holds `command` on `channel` (repeated in every slot) or, with `None`, stops holding it.
    /// A new held value is also sent in the next slot like any pending command.
    pub fn hold(&mut self, channel: ManualChannel, command: Option<Command>) {
        self.held[channel.index()] = command;
    }

    /// The value held on `channel`, if any.
    pub fn held(&self, channel: ManualChannel) -> Option<Command> {
        self.held[channel.index()]
    }

    /// Whether a kill is still being repeated at `now`.
    pub fn killing(&self, now: StationTime) -> bool {
        self.kill_until.is_some_and(|until| now < until)
    }

    /// When [`poll`](Self::poll) next has something to send (`now` if it has already).
    pub fn next_due(&self, now: StationTime) -> StationTime {
        if self.kill_now {
            return now;
        }
        self.next_slot.unwrap_or(now)
    }

    /// The frames due at `now`, in the order to send them (empty between slots).
    pub fn poll(&mut self, now: StationTime) -> Vec<Command> {
        self.poll_slot(now).into_iter().map(|s| s.command).collect()
    }

    /// The frames due at `now` with their [`Origin`], in the order to send them.
    pub fn poll_slot(&mut self, now: StationTime) -> Vec<Scheduled> {
        let mut out = Vec::new();
        let kill = Scheduled {
            command: Command::Kill,
            origin: Origin::Kill,
        };
        if core::mem::take(&mut self.kill_now) {
            out.push(kill);
            self.last_kill = Some(now);
            // The immediate kill counts as this slot's frame; the rhythm restarts from it.
            self.next_slot = Some(now + self.period);
            return out;
        }
        let slot = self.next_slot.unwrap_or(now);
        if now < slot {
            return out;
        }
        // Catch up without bursts: the next slot is one period after this one, or after now
        // when the caller was late by more than a period.
        let next = slot + self.period;
        self.next_slot = Some(if next <= now { now + self.period } else { next });
        if self.killing(now) {
            out.push(kill);
            self.last_kill = Some(now);
            return out;
        }
        let revive_waits = self
            .last_kill
            .is_some_and(|k| now.saturating_sub(k) < REVIVE_AFTER_KILL);
        if !revive_waits && self.pending.iter().any(|(c, _)| *c == Command::Revive) {
            // What was asked for while the revive waited does not go out with it.
            self.cancel_driving();
        }
        let mut waiting = Vec::new();
        for (command, at) in core::mem::take(&mut self.pending) {
            if command == Command::Revive && revive_waits {
                waiting.push((command, at));
            } else {
                out.push(Scheduled {
                    command,
                    origin: Origin::Request,
                });
            }
        }
        self.pending = waiting;
        for held in self.held.iter().flatten() {
            let kind: CommandType = held.command_type();
            if !out.iter().any(|s| s.command.command_type() == kind) {
                out.push(Scheduled {
                    command: *held,
                    origin: Origin::Held,
                });
            }
        }
        if out.is_empty() {
            out.push(Scheduled {
                command: Command::Heartbeat,
                origin: Origin::Heartbeat,
            });
        }
        out
    }

    /// Forgets the slot rhythm (after a reconnect the first slot is immediate); requests and
    /// held values stay.
    pub fn restart(&mut self) {
        self.next_slot = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Percent;
    use std::vec;

    fn ms(t0: StationTime, n: u64) -> StationTime {
        t0 + Duration::from_millis(n)
    }

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    /// Everything sent over `0..=end_ms`, polled every millisecond, with the time it went out.
    fn run(s: &mut CommandScheduler, t0: StationTime, end_ms: u64) -> Vec<(u64, Command)> {
        let mut sent = Vec::new();
        for t in 0..=end_ms {
            for c in s.poll(ms(t0, t)) {
                sent.push((t, c));
            }
        }
        sent
    }

    #[test]
    fn a_heartbeat_every_100_ms_when_idle() {
        let t0 = StationTime::from_secs(1_000);
        let mut s = CommandScheduler::default();
        let sent = run(&mut s, t0, 1_000);
        let times: Vec<u64> = sent.iter().map(|(t, _)| *t).collect();
        assert_eq!(times, (0..=10).map(|k| k * 100).collect::<Vec<_>>());
        assert!(sent.iter().all(|(_, c)| *c == Command::Heartbeat));
    }

    #[test]
    fn a_pending_command_replaces_the_heartbeat_once() {
        let t0 = StationTime::from_secs(1_000);
        let mut s = CommandScheduler::default();
        assert_eq!(s.poll(t0), vec![Command::Heartbeat]);
        s.request(Command::Throttle(pct(60)), ms(t0, 30));
        s.request(Command::Throttle(pct(70)), ms(t0, 40));
        s.request(Command::Steering(pct(20)), ms(t0, 50));
        assert!(s.poll(ms(t0, 99)).is_empty());
        assert_eq!(
            s.poll(ms(t0, 100)),
            vec![Command::Throttle(pct(70)), Command::Steering(pct(20))],
            "coalesced per type, in request order, instead of the heartbeat"
        );
        assert_eq!(s.poll(ms(t0, 200)), vec![Command::Heartbeat]);
    }

    #[test]
    fn held_values_repeat_every_slot_until_released() {
        let t0 = StationTime::from_secs(1_000);
        let mut s = CommandScheduler::default();
        s.hold(ManualChannel::Throttle, Some(Command::Throttle(pct(80))));
        let sent = run(&mut s, t0, 350);
        assert_eq!(sent.len(), 4);
        assert!(sent.iter().all(|(_, c)| *c == Command::Throttle(pct(80))));
        s.hold(ManualChannel::Throttle, None);
        s.request(Command::Throttle(pct(50)), ms(t0, 360));
        assert_eq!(s.poll(ms(t0, 400)), vec![Command::Throttle(pct(50))]);
        assert_eq!(s.poll(ms(t0, 500)), vec![Command::Heartbeat]);
    }

    #[test]
    fn kill_goes_out_at_once_and_repeats_for_one_second() {
        let t0 = StationTime::from_secs(1_000);
        let mut s = CommandScheduler::default();
        s.hold(ManualChannel::Throttle, Some(Command::Throttle(pct(90))));
        assert_eq!(s.poll(t0), vec![Command::Throttle(pct(90))]);
        s.request(Command::Steering(pct(10)), ms(t0, 20));
        s.request(Command::Kill, ms(t0, 37));
        assert_eq!(s.next_due(ms(t0, 37)), ms(t0, 37));
        assert_eq!(
            s.poll(ms(t0, 37)),
            vec![Command::Kill],
            "not at the next slot"
        );
        let sent: Vec<(u64, Command)> = (38..=1_400)
            .flat_map(|t| s.poll(ms(t0, t)).into_iter().map(move |c| (t, c)))
            .collect();
        let kills: Vec<u64> = sent
            .iter()
            .filter(|(_, c)| *c == Command::Kill)
            .map(|(t, _)| *t)
            .collect();
        assert_eq!(kills, vec![137, 237, 337, 437, 537, 637, 737, 837, 937]);
        // After the second: heartbeats only; the held throttle and pending steering were dropped.
        assert!(sent
            .iter()
            .filter(|(t, _)| *t > 1_037)
            .all(|(_, c)| *c == Command::Heartbeat));
        assert_eq!(s.held(ManualChannel::Throttle), None);
    }

    #[test]
    fn revive_ends_the_kill_repetition() {
        let t0 = StationTime::from_secs(1_000);
        let mut s = CommandScheduler::default();
        s.request(Command::Kill, t0);
        assert_eq!(s.poll(t0), vec![Command::Kill]);
        assert_eq!(s.poll(ms(t0, 100)), vec![Command::Kill]);
        s.request(Command::Revive, ms(t0, 150));
        assert!(!s.killing(ms(t0, 150)));
        let sent: Vec<Command> = (151..=1_500).flat_map(|t| s.poll(ms(t0, t))).collect();
        assert!(!sent.contains(&Command::Kill), "{sent:?}");
        assert_eq!(sent.iter().filter(|c| **c == Command::Revive).count(), 1);
    }

    #[test]
    fn a_revive_waits_until_the_kill_is_old_enough() {
        let t0 = StationTime::from_secs(1_000);
        let mut s = CommandScheduler::default();
        s.request(Command::Kill, t0);
        assert_eq!(s.poll(t0), vec![Command::Kill]);
        assert_eq!(s.poll(ms(t0, 100)), vec![Command::Kill]);
        // R held: the revive ends the repetition, but the last kill left 50 ms ago.
        s.request(Command::Revive, ms(t0, 150));
        assert_eq!(s.poll(ms(t0, 200)), vec![Command::Heartbeat]);
        assert_eq!(s.poll(ms(t0, 300)), vec![Command::Heartbeat]);
        assert!(s.poll(ms(t0, 399)).is_empty());
        assert_eq!(
            s.poll_slot(ms(t0, 400)),
            vec![Scheduled {
                command: Command::Revive,
                origin: Origin::Request
            }],
            "300 ms after the last kill frame"
        );
        assert_eq!(s.poll(ms(t0, 500)), vec![Command::Heartbeat]);
    }

    #[test]
    fn nothing_asked_for_before_a_revive_goes_out_with_or_after_it() {
        let t0 = StationTime::from_secs(1_000);
        let mut s = CommandScheduler::default();
        s.request(Command::Kill, t0);
        assert_eq!(s.poll(t0), vec![Command::Kill]);
        // While the kill repeats: a one-off throttle, a setpoint, a held steering value.
        s.request(Command::Throttle(pct(80)), ms(t0, 20));
        s.request(Command::SpeedSetpoint { mm_s: 3_000 }, ms(t0, 30));
        s.hold(ManualChannel::Steering, Some(Command::Steering(pct(30))));
        let before = s.cancellations();
        s.request(Command::Revive, ms(t0, 50));
        assert_eq!(s.held(ManualChannel::Steering), None);
        assert_eq!(
            s.take_dropped(),
            vec![
                (Command::Throttle(pct(80)), ms(t0, 20)),
                (Command::SpeedSetpoint { mm_s: 3_000 }, ms(t0, 30))
            ]
        );
        assert_eq!(s.cancellations(), before + 1);
        // The revive waits for the kill to be 300 ms old; what is asked for meanwhile does not
        // go out with it.
        assert_eq!(s.poll(ms(t0, 100)), vec![Command::Heartbeat]);
        s.request(Command::Tail(pct(90)), ms(t0, 150));
        s.hold(ManualChannel::Throttle, Some(Command::Throttle(pct(70))));
        // Before the revive: they go out (to a KILLED robot, which ignores them).
        assert_eq!(
            s.poll(ms(t0, 200)),
            vec![Command::Tail(pct(90)), Command::Throttle(pct(70))]
        );
        s.request(Command::Tail(pct(90)), ms(t0, 250));
        assert_eq!(s.poll(ms(t0, 300)), vec![Command::Revive]);
        assert_eq!(
            s.take_dropped(),
            vec![(Command::Tail(pct(90)), ms(t0, 250))]
        );
        assert_eq!(s.held(ManualChannel::Throttle), None);
        assert_eq!(s.cancellations(), before + 2);
        assert_eq!(s.poll(ms(t0, 400)), vec![Command::Heartbeat]);
    }

    #[test]
    fn slots_say_where_each_frame_comes_from() {
        let t0 = StationTime::from_secs(1_000);
        let mut s = CommandScheduler::default();
        s.hold(ManualChannel::Steering, Some(Command::Steering(pct(30))));
        s.request(Command::SpeedSetpoint { mm_s: 800 }, t0);
        let origins: Vec<Origin> = s.poll_slot(t0).iter().map(|f| f.origin).collect();
        assert_eq!(origins, vec![Origin::Request, Origin::Held]);
        s.hold(ManualChannel::Steering, None);
        assert_eq!(s.poll_slot(ms(t0, 100))[0].origin, Origin::Heartbeat);
        s.request(Command::Kill, ms(t0, 150));
        assert_eq!(s.poll_slot(ms(t0, 150))[0].origin, Origin::Kill);
        assert_eq!(s.poll_slot(ms(t0, 250))[0].origin, Origin::Kill);
    }

    #[test]
    fn late_polls_do_not_burst() {
        let t0 = StationTime::from_secs(1_000);
        let mut s = CommandScheduler::default();
        assert_eq!(s.poll(t0).len(), 1);
        // The caller stalled for 550 ms: one frame, then the rhythm resumes from there.
        assert_eq!(s.poll(ms(t0, 550)).len(), 1);
        assert!(s.poll(ms(t0, 600)).is_empty());
        assert_eq!(s.poll(ms(t0, 650)).len(), 1);
    }
}
