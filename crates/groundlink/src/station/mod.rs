//! The ground station's side of the link, without I/O: which command frames go out when, and
//! (ground link v2) how they are numbered, repeated and acknowledged.
//!
//! - [`scheduler`]: the slot rhythm: a heartbeat every [`HEARTBEAT_PERIOD`], pending commands
//!   in its place, held values repeated, a kill at once and repeated for [`KILL_REPEAT`], a
//!   revive no sooner than [`REVIVE_AFTER_KILL`] after the last kill frame. Ground link v1
//!   sends its slots as they are.
//! - [`uplink`]: ground link v2: the robot's session, sequence numbers, and requested commands
//!   repeated until the robot acknowledges them (or [`CONFIRM_TIMEOUT`] passes).
//! - [`Station`]: both composed the way a v2 station runs them: requests and held values in,
//!   numbered [`CommandFrame`]s out, display frames back.
//!
//! **Nothing asked for before a revive drives after it.** A revive (when it is requested and
//! when it goes out) and every authentic display frame reporting KILLED or FAILSAFE cancel
//! every manual value and setpoint: pending in the scheduler, held, or waiting in the uplink
//! for its acknowledgement. Each is settled as [`Delivery::CancelledByRevive`] or
//! [`Delivery::CancelledRobotSafe`], so the session recording shows it. A revived robot
//! starts at neutral in MANUAL; a key, stick or slider still held when the robot went safe
//! or the revive was sent must be let go and moved again to drive
//! ([`driving_cancellations`](Station::driving_cancellations) tells the user interface when
//! to reset its controls).
//!
//! Nothing here reads a clock: every call takes the time as a [`StationTime`], so a simulator
//! can drive a station in virtual time and every rule is tested without sleeping. The caller
//! frames, tags and writes the frames itself.

use std::vec::Vec;

use crate::v2::{CommandFrame, DisplayFrame};
use crate::Command;

pub mod scheduler;
pub mod uplink;

pub use scheduler::{
    CommandScheduler, ManualChannel, Origin, Scheduled, HEARTBEAT_PERIOD, KILL_REPEAT,
    REVIVE_AFTER_KILL,
};
pub use uplink::{
    frames_per_slot, CommandStatus, Delivery, DownlinkVerdict, Settled, Uplink, UplinkStats,
    CONFIRM_TIMEOUT, DEFAULT_LINK_BAUD, SLOT_BUDGET_PERCENT,
};

/// A point in time on the station's clock: the time since an arbitrary fixed epoch on a
/// monotonic clock (a real station: an `Instant` captured once at start; a simulator: its
/// virtual time). Only differences between two values mean anything, and one station must be
/// given times from one clock, never going back.
pub type StationTime = core::time::Duration;

/// A ground link v2 station: the [`CommandScheduler`]'s slots numbered by the [`Uplink`].
///
/// The caller requests commands and holds values as the operator acts, calls
/// [`poll`](Self::poll) at or after [`next_due`](Self::next_due) and sends the frames it
/// returns (tagged with the link key), and hands every authenticated display frame to
/// [`on_display`](Self::on_display). [`take_settled`](Self::take_settled) says what became
/// of each requested command.
///
/// ```
/// use core::time::Duration;
/// use dima_groundlink::station::{Delivery, Station, StationTime, HEARTBEAT_PERIOD};
/// use dima_groundlink::v2::{DisplayFrame, LinkKey, RobotMode};
/// use dima_groundlink::Command;
///
/// let key = LinkKey::parse_hex("000102030405060708090a0b0c0d0e0f").unwrap();
/// let mut station = Station::new();
/// let t0 = StationTime::from_secs(10);
///
/// // Until an authenticated display frame tells the robot's session only a kill goes out.
/// assert!(station.poll(t0).is_empty());
/// let killed = DisplayFrame {
///     mode: RobotMode::Killed,
///     session: 0x5EED_0001,
///     seq: 1,
///     ack_seq: 0,
///     ..DisplayFrame::default()
/// };
/// station.on_display(&killed, t0 + Duration::from_millis(40));
///
/// // The operator revives: the revive replaces the next slot's heartbeat.
/// station.request(Command::Revive, t0 + Duration::from_millis(50));
/// let frames = station.poll(t0 + HEARTBEAT_PERIOD);
/// assert_eq!(frames.len(), 1);
/// assert_eq!((frames[0].command, frames[0].session, frames[0].seq), (Command::Revive, 0x5EED_0001, 1));
/// let _bytes = frames[0].encode(&key); // to the radio
///
/// // The robot accepted frame 1 and reports MANUAL: the revive is acknowledged.
/// let manual = DisplayFrame { mode: RobotMode::Manual, seq: 2, ack_seq: 1, ..killed };
/// station.on_display(&manual, t0 + Duration::from_millis(400));
/// let settled = station.take_settled();
/// assert_eq!(settled[0].status.delivery, Delivery::Acknowledged { seq: 1 });
/// ```
#[derive(Debug, Clone, Default)]
pub struct Station {
    scheduler: CommandScheduler,
    uplink: Uplink,
    /// Requests the scheduler dropped before they went out, settled.
    settled: Vec<Settled>,
}

impl Station {
    /// A station with the protocol's slot period ([`HEARTBEAT_PERIOD`]), no session known,
    /// numbering from 1.
    pub fn new() -> Station {
        Station::default()
    }

    /// Queues `command` for the next slot (a kill goes out at once); see
    /// [`CommandScheduler::request`]. A revive cancels the manual values and setpoints asked
    /// for before it (see the module docs).
    pub fn request(&mut self, command: Command, now: StationTime) {
        self.scheduler.request(command, now);
        let reason = if command == Command::Kill {
            Delivery::Cancelled
        } else {
            Delivery::CancelledByRevive
        };
        self.settle_dropped(reason, now);
    }

    /// Fits every slot within its share of the wire at the radio link's `baud` (8N1), so
    /// bytes never queue up from one slot to the next; see [`uplink::frames_per_slot`]. The
    /// default assumes the XBee's 9600 baud.
    pub fn set_link_baud(&mut self, baud: u32) {
        self.uplink
            .set_frames_per_slot(uplink::frames_per_slot(baud, HEARTBEAT_PERIOD));
    }

    /// How many times the station dropped the pending and held manual values and setpoints
    /// (kills, revives, the robot reporting KILLED or FAILSAFE). When it changes a user
    /// interface shows its controls at neutral and waits for a held key, stick or slider to
    /// be let go before it drives again.
    pub fn driving_cancellations(&self) -> u64 {
        self.scheduler.cancellations()
    }

    /// Settles the requests the scheduler dropped before they went out.
    fn settle_dropped(&mut self, delivery: Delivery, now: StationTime) {
        for (command, requested_at) in self.scheduler.take_dropped() {
            let mut status = CommandStatus::new(command, requested_at);
            status.delivery = delivery;
            status.settled_at = Some(now);
            self.settled.push(Settled { status, at: now });
        }
    }

    /// Holds `command` on `channel` (repeated in every slot) or, with `None`, stops holding it;
    /// see [`CommandScheduler::hold`].
    pub fn hold(&mut self, channel: ManualChannel, command: Option<Command>) {
        self.scheduler.hold(channel, command);
    }

    /// The value held on `channel`, if any.
    pub fn held(&self, channel: ManualChannel) -> Option<Command> {
        self.scheduler.held(channel)
    }

    /// Whether a kill is still being repeated at `now`.
    pub fn killing(&self, now: StationTime) -> bool {
        self.scheduler.killing(now)
    }

    /// When [`poll`](Self::poll) next has a slot to send (`now` if it has already).
    pub fn next_due(&self, now: StationTime) -> StationTime {
        self.scheduler.next_due(now)
    }

    /// The numbered frames of the slot due at `now`, in the order to send them: the
    /// scheduler's slot with the repetitions of what waits for an acknowledgement (empty
    /// between slots, and for anything but a kill while the session is unknown). Call it
    /// even when nothing is due: it also gives up what waited too long.
    pub fn poll(&mut self, now: StationTime) -> Vec<CommandFrame> {
        let slot = self.scheduler.poll_slot(now);
        // Only a revive going out drops requests here.
        self.settle_dropped(Delivery::CancelledByRevive, now);
        self.uplink.frames(&slot, now)
    }

    /// Takes an authenticated display frame received at `now`; see [`Uplink::on_display`].
    /// A report of KILLED or FAILSAFE cancels the manual values and setpoints (see the module
    /// docs).
    pub fn on_display(&mut self, frame: &DisplayFrame, now: StationTime) -> DownlinkVerdict {
        let before = self.uplink.stats().safe_reports;
        let verdict = self.uplink.on_display(frame, now);
        if self.uplink.stats().safe_reports != before {
            self.scheduler.cancel_driving();
            self.settle_dropped(Delivery::CancelledRobotSafe, now);
        }
        verdict
    }

    /// Commands settled since the last call (acknowledged, given up, dropped or cancelled),
    /// in the order they were settled.
    pub fn take_settled(&mut self) -> Vec<Settled> {
        let mut settled = core::mem::take(&mut self.settled);
        settled.extend(self.uplink.take_settled());
        settled.sort_by_key(|s| s.at);
        settled
    }

    /// Forgets the slot rhythm (after a reconnect the first slot is immediate); requests,
    /// held values and the session stay. See [`CommandScheduler::restart`].
    pub fn restart(&mut self) {
        self.scheduler.restart();
    }

    /// The slot schedule.
    pub fn scheduler(&self) -> &CommandScheduler {
        &self.scheduler
    }

    /// Session, numbering and acknowledgements.
    pub fn uplink(&self) -> &Uplink {
        &self.uplink
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::v2::RobotMode;
    use crate::Percent;
    use core::time::Duration;

    fn ms(t0: StationTime, n: u64) -> StationTime {
        t0 + Duration::from_millis(n)
    }

    #[test]
    fn a_station_sends_the_schedulers_slots_numbered_by_the_uplink() {
        let t0 = StationTime::from_secs(1_000);
        let mut station = Station::new();
        let mut scheduler = CommandScheduler::default();
        let mut uplink = Uplink::new();
        let throttle = Command::Throttle(Percent::new(70).unwrap());
        let mut sent = 0;
        for t in 0..=3_000 {
            let now = ms(t0, t);
            if t == 120 || t == 1_650 {
                let frame = DisplayFrame {
                    mode: RobotMode::Killed,
                    session: 0x5EED_0001,
                    seq: 1 + t as u32,
                    ack_seq: uplink.next_seq().saturating_sub(1),
                    ..DisplayFrame::default()
                };
                assert_eq!(
                    station.on_display(&frame, now),
                    uplink.on_display(&frame, now)
                );
                // A report of KILLED cancels what is held and pending in the schedule too.
                scheduler.cancel_driving();
            }
            let request = match t {
                5 => Some(Command::Kill),
                450 => Some(Command::Revive),
                900 => Some(Command::SpeedSetpoint { mm_s: 800 }),
                _ => None,
            };
            if let Some(command) = request {
                station.request(command, now);
                scheduler.request(command, now);
            }
            if t == 1_200 {
                station.hold(ManualChannel::Throttle, Some(throttle));
                scheduler.hold(ManualChannel::Throttle, Some(throttle));
            }
            assert_eq!(station.next_due(now), scheduler.next_due(now));
            let frames = station.poll(now);
            let expected = uplink.frames(&scheduler.poll_slot(now), now);
            assert_eq!(frames, expected, "at {t} ms");
            sent += frames.len();
            assert_eq!(station.killing(now), scheduler.killing(now));
            assert_eq!(station.take_settled(), uplink.take_settled());
        }
        assert!(sent > 20, "{sent} frames");
        assert_eq!(
            station.held(ManualChannel::Throttle),
            None,
            "cancelled at 1650 ms"
        );
        assert_eq!(station.uplink().stats(), uplink.stats());
        assert_eq!(station.uplink().session(), Some(0x5EED_0001));
    }
}

#[cfg(test)]
mod driving_after_a_revive {
    //! Manual values and setpoints asked for before a revive (or while the robot was safe) must
    //! not reach the revived robot.
    use super::*;
    use crate::v2::RobotMode;
    use crate::Percent;
    use core::time::Duration;
    use std::vec;

    const SESSION: u32 = 0x5EED_0001;

    fn ms(n: u64) -> StationTime {
        StationTime::from_secs(1_000) + Duration::from_millis(n)
    }

    fn report(seq: u32, ack_seq: u32, mode: RobotMode) -> DisplayFrame {
        DisplayFrame {
            mode,
            session: SESSION,
            seq,
            ack_seq,
            ..DisplayFrame::default()
        }
    }

    /// A station that knows the session of a KILLED robot which accepted up to `ack`.
    fn killed_robot(ack: u32) -> Station {
        let mut station = Station::new();
        station.on_display(&report(1, ack, RobotMode::Killed), ms(0));
        station
    }

    fn is_driving(c: Command) -> bool {
        matches!(
            c,
            Command::Throttle(_)
                | Command::Steering(_)
                | Command::Tail(_)
                | Command::SpeedSetpoint { .. }
                | Command::HeadingSetpoint { .. }
        )
    }

    /// Every frame polled each millisecond over `from..=to`.
    fn run(station: &mut Station, from: u64, to: u64) -> Vec<(u64, CommandFrame)> {
        (from..=to)
            .flat_map(|t| station.poll(ms(t)).into_iter().map(move |f| (t, f)))
            .collect()
    }

    #[test]
    fn a_slider_value_sent_in_the_revives_slot_is_not_repeated_into_manual() {
        let mut station = killed_robot(10);
        assert_eq!(station.poll(ms(0)).len(), 1); // the slot rhythm starts
                                                  // The slider is put at 80 % while KILLED, and the operator revives in the same slot.
        station.request(Command::Throttle(Percent::new(80).unwrap()), ms(20));
        station.request(Command::Revive, ms(60));
        let slot = run(&mut station, 1, 100);
        assert!(slot.iter().any(|(_, f)| f.command == Command::Revive));
        let revive = slot
            .iter()
            .find(|(_, f)| f.command == Command::Revive)
            .unwrap()
            .1;
        // The robot acted on the revive: MANUAL, at neutral.
        station.on_display(&report(2, revive.seq, RobotMode::Manual), ms(150));
        let after = run(&mut station, 101, 3_000);
        let driving: Vec<_> = after
            .iter()
            .filter(|(_, f)| is_driving(f.command))
            .collect();
        assert!(driving.is_empty(), "unasked after the revive: {driving:?}");
        // The recording says what became of the 80 %: never sent, cancelled by the revive.
        let settled = station.take_settled();
        let throttle = settled
            .iter()
            .find(|s| s.status.command == Command::Throttle(Percent::new(80).unwrap()))
            .unwrap();
        assert_eq!(throttle.status.delivery, Delivery::CancelledByRevive);
        assert_eq!(throttle.status.requested_at, ms(20));
        assert_eq!((throttle.status.transmissions, throttle.at), (0, ms(60)));
        assert_eq!(Delivery::CancelledByRevive.label(), "cancelled by revive");
    }

    #[test]
    fn a_setpoint_sent_while_killed_does_not_switch_the_revived_robot_to_auto() {
        let mut station = killed_robot(10);
        station.request(Command::SpeedSetpoint { mm_s: 3_000 }, ms(0));
        let first = station.poll(ms(0));
        assert_eq!(first[0].command, Command::SpeedSetpoint { mm_s: 3_000 });
        // Its frame was lost. The operator revives.
        run(&mut station, 1, 149);
        station.request(Command::Revive, ms(150));
        let slot = run(&mut station, 150, 200);
        let revive = slot
            .iter()
            .find(|(_, f)| f.command == Command::Revive)
            .unwrap()
            .1;
        station.on_display(&report(2, revive.seq, RobotMode::Manual), ms(250));
        let after = run(&mut station, 201, 3_000);
        let setpoints: Vec<_> = after
            .iter()
            .filter(|(_, f)| is_driving(f.command))
            .collect();
        assert!(setpoints.is_empty(), "AUTO after the revive: {setpoints:?}");
        let settled = station.take_settled();
        let speed = settled
            .iter()
            .find(|s| s.status.command == Command::SpeedSetpoint { mm_s: 3_000 })
            .unwrap();
        assert_eq!(speed.status.delivery, Delivery::CancelledByRevive);
        assert_eq!(speed.status.first_seq, Some(first[0].seq));
        assert!(speed.status.transmissions >= 1);
    }

    #[test]
    fn a_value_held_while_killed_does_not_drive_after_the_revive() {
        let mut station = killed_robot(10);
        let throttle = Command::Throttle(Percent::new(80).unwrap());
        station.hold(ManualChannel::Throttle, Some(throttle));
        let before = run(&mut station, 0, 150);
        assert!(before.iter().any(|(_, f)| f.command == throttle));
        let cancellations = station.driving_cancellations();
        station.request(Command::Revive, ms(160));
        assert_eq!(station.held(ManualChannel::Throttle), None);
        assert!(station.driving_cancellations() > cancellations);
        let after = run(&mut station, 151, 1_000);
        assert!(
            after.iter().all(|(_, f)| !is_driving(f.command)),
            "{after:?}"
        );
        // The held value's record: its frames, and the revive that ended it.
        let held_frames: Vec<u32> = before
            .iter()
            .filter(|(_, f)| f.command == throttle)
            .map(|(_, f)| f.seq)
            .collect();
        let settled = station.take_settled();
        let held = settled
            .iter()
            .find(|s| s.status.command == throttle)
            .unwrap();
        assert_eq!(held.status.delivery, Delivery::CancelledByRevive);
        assert_eq!(held.status.transmissions as usize, held_frames.len());
        assert_eq!(held.status.first_seq, held_frames.first().copied());
        assert_eq!(held.status.last_seq, held_frames.last().copied());
    }

    #[test]
    fn values_asked_for_before_a_comms_loss_failsafe_do_not_drive_after_the_revive() {
        let mut station = killed_robot(10);
        station.request(Command::Revive, ms(0));
        let revive = station.poll(ms(0))[0];
        station.on_display(&report(2, revive.seq, RobotMode::Manual), ms(50));
        // Driving: the slider's 80 % goes out and is lost, the radio fades, the robot fails
        // safe with an acknowledgement of a later heartbeat.
        station.request(Command::Throttle(Percent::new(80).unwrap()), ms(90));
        let lost = station.poll(ms(100));
        assert!(is_driving(lost[0].command));
        station.hold(
            ManualChannel::Steering,
            Some(Command::Steering(Percent::new(30).unwrap())),
        );
        station.on_display(&report(3, lost[0].seq + 1, RobotMode::Failsafe), ms(400));
        assert_eq!(station.held(ManualChannel::Steering), None);
        let cancelled: Vec<Command> = station
            .take_settled()
            .iter()
            .filter(|s| s.status.delivery == Delivery::CancelledRobotSafe)
            .map(|s| s.status.command)
            .collect();
        assert_eq!(cancelled, vec![lost[0].command]);
        // The radio is back: the operator revives at 700 ms.
        let during = run(&mut station, 101, 699);
        assert!(
            during.iter().all(|(_, f)| !is_driving(f.command)),
            "repeated to a FAILSAFE robot: {during:?}"
        );
        station.request(Command::Revive, ms(700));
        let slot = run(&mut station, 700, 800);
        let revive = slot
            .iter()
            .find(|(_, f)| f.command == Command::Revive)
            .unwrap()
            .1;
        station.on_display(&report(4, revive.seq, RobotMode::Manual), ms(850));
        let after = run(&mut station, 801, 3_000);
        assert!(
            after.iter().all(|(_, f)| !is_driving(f.command)),
            "{after:?}"
        );
    }

    #[test]
    fn a_report_built_before_the_revive_cancels_nothing_asked_for_after_it() {
        let mut station = killed_robot(10);
        station.request(Command::Revive, ms(0));
        let revive = station.poll(ms(0))[0];
        assert_eq!(revive.seq, 11);
        // After the revive went out the operator holds a key.
        let throttle = Command::Throttle(Percent::new(70).unwrap());
        station.hold(ManualChannel::Throttle, Some(throttle));
        let cancellations = station.driving_cancellations();
        // A frame built before the robot saw the revive (acknowledgement 10) still says KILLED.
        station.on_display(&report(2, 10, RobotMode::Killed), ms(150));
        assert_eq!(station.held(ManualChannel::Throttle), Some(throttle));
        assert_eq!(station.driving_cancellations(), cancellations);
        // A later frame acknowledges the revive and still says KILLED: refused, and what was
        // held is cancelled.
        let sent = run(&mut station, 1, 250);
        let last = sent.last().unwrap().1.seq;
        station.on_display(&report(3, last, RobotMode::Killed), ms(300));
        station.on_display(&report(4, last, RobotMode::Killed), ms(800));
        assert_eq!(station.held(ManualChannel::Throttle), None);
        assert!(station.driving_cancellations() > cancellations);
        let settled = station.take_settled();
        let held = settled
            .iter()
            .find(|s| s.status.command == throttle)
            .unwrap();
        assert_eq!(held.status.delivery, Delivery::CancelledRobotSafe);
        assert_eq!(
            Delivery::CancelledRobotSafe.label(),
            "cancelled: robot KILLED or FAILSAFE"
        );
    }

    #[test]
    fn every_frame_names_its_request() {
        let mut station = killed_robot(10);
        station.request(Command::Revive, ms(0));
        let revive = station.poll(ms(0))[0];
        station.on_display(&report(2, revive.seq, RobotMode::Manual), ms(50));
        station.request(Command::Throttle(Percent::new(65).unwrap()), ms(60));
        station.hold(
            ManualChannel::Steering,
            Some(Command::Steering(Percent::new(40).unwrap())),
        );
        let frames: Vec<CommandFrame> = run(&mut station, 100, 450)
            .into_iter()
            .map(|(_, f)| f)
            .collect();
        let throttle: Vec<&CommandFrame> = frames
            .iter()
            .filter(|f| matches!(f.command, Command::Throttle(_)))
            .collect();
        assert!(throttle.len() >= 3, "{frames:?}");
        // A repeated request: every frame names its first; a held value: each frame itself.
        assert!(throttle.iter().all(|f| f.request == throttle[0].seq));
        assert!(frames
            .iter()
            .filter(|f| matches!(f.command, Command::Steering(_)))
            .all(|f| f.request == f.seq));
    }

    #[test]
    fn a_request_made_during_the_kills_repetition_is_dropped_by_the_revive() {
        let mut station = killed_robot(10);
        station.request(Command::Kill, ms(0));
        assert_eq!(station.poll(ms(0))[0].command, Command::Kill);
        let mut sent = run(&mut station, 1, 199);
        station.request(Command::Throttle(Percent::new(80).unwrap()), ms(200));
        sent.extend(run(&mut station, 200, 449));
        station.request(Command::Revive, ms(450));
        sent.extend(run(&mut station, 450, 3_000));
        assert!(sent.iter().any(|(_, f)| f.command == Command::Revive));
        assert!(sent.iter().all(|(_, f)| !is_driving(f.command)), "{sent:?}");
    }
}
