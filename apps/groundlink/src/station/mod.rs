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
    CommandStatus, Delivery, DownlinkVerdict, Settled, Uplink, UplinkStats, CONFIRM_TIMEOUT,
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
}

impl Station {
    /// A station with the protocol's slot period ([`HEARTBEAT_PERIOD`]), no session known,
    /// numbering from 1.
    pub fn new() -> Station {
        Station::default()
    }

    /// Queues `command` for the next slot (a kill goes out at once); see
    /// [`CommandScheduler::request`].
    pub fn request(&mut self, command: Command, now: StationTime) {
        self.scheduler.request(command, now);
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
        self.uplink.frames(&slot, now)
    }

    /// Takes an authenticated display frame received at `now`; see [`Uplink::on_display`].
    pub fn on_display(&mut self, frame: &DisplayFrame, now: StationTime) -> DownlinkVerdict {
        self.uplink.on_display(frame, now)
    }

    /// Commands settled since the last call (acknowledged, given up or dropped).
    pub fn take_settled(&mut self) -> Vec<Settled> {
        self.uplink.take_settled()
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
        assert_eq!(station.held(ManualChannel::Throttle), Some(throttle));
        assert_eq!(station.uplink().stats(), uplink.stats());
        assert_eq!(station.uplink().session(), Some(0x5EED_0001));
    }
}
