//! Ground link v2, the station's side: the robot's session, sequence numbers, and which
//! commands the robot has acknowledged.
//!
//! The robot accepts a command frame v2 only with its per-boot session id and a sequence
//! number above the last one it accepted, and reports that last accepted number (the
//! acknowledgement) in every display frame. This module turns the slots of the
//! [`CommandScheduler`](super::scheduler::CommandScheduler) into numbered [`CommandFrame`]s
//! and reads the acknowledgements back:
//!
//! - **Session**: learned from authenticated display frames. Until it is known only a kill
//!   goes out (with session 0, which the robot accepts for a kill and nothing else); every
//!   other frame is held back and counted. A new session id (the robot rebooted) starts the
//!   numbering again and drops what was waiting for the old boot.
//! - **Numbering**: every frame gets a new number, never one used before: `next = max(next,
//!   ack + 1)` on every display frame, so neither a station restart nor a robot reboot gets
//!   stuck below the robot's window.
//! - **Acknowledgement**: a display frame says only which number the robot accepted last, so
//!   `ack >= seq` does not prove that frame `seq` arrived (a later heartbeat may have been
//!   accepted while it was lost). A requested command (a revive, a one-off manual value, a
//!   setpoint) is therefore repeated in every slot, last in the slot and in place of the
//!   heartbeat, each time with a new number, until the acknowledgement is exactly one of its
//!   numbers (or, for a revive, the robot reports MANUAL or AUTO after one of them). It is
//!   given up after [`CONFIRM_TIMEOUT`] and counted as unacknowledged. Every frame of a
//!   request carries the number of its first frame (its request; a held value's frames each
//!   their own number), so the robot can tell how old a request is: it acts on one revive
//!   request once (a repetition that arrives after the robot failed safe again does not lift
//!   that failsafe). Once the robot acknowledged a revive it is not sent again; if a later
//!   display frame still shows KILLED or FAILSAFE the robot refused it (the frame says why)
//!   and the operator decides whether to revive again.
//! - **Nothing asked for before a revive drives after it**: a repeated manual value or
//!   setpoint is not harmless across a revive (an acknowledgement of the revive's frame is
//!   not one of its own, so it would be repeated into MANUAL or AUTO). Manual values and
//!   setpoints waiting for their acknowledgement, and the values held, are therefore
//!   cancelled when a revive goes out ([`Delivery::CancelledByRevive`]) and whenever an
//!   authentic display frame reports KILLED or FAILSAFE ([`Delivery::CancelledRobotSafe`]),
//!   except a frame built before an outstanding revive's first frame could have been
//!   accepted (its acknowledgement is older): what the operator asked for after that revive
//!   went out is meant for the revived robot.
//! - **Conflicts**: a newer command of the same type replaces a waiting one; a manual value
//!   (sent or held) replaces waiting setpoints and a setpoint replaces waiting manual values, so
//!   a repetition never switches the robot back to a mode the operator has left. A kill drops
//!   everything waiting.
//! - **Downlink order**: a display frame of the current session whose downlink sequence
//!   number is not newer than the last one is ignored and counted (a replay or a reordering),
//!   and so is a frame of a session that an earlier boot's frames were replaced by (a robot
//!   draws a new random session id at every boot and never goes back to an old one).
//!
//! Pure: time is a [`StationTime`] argument, and nothing here does I/O.

use core::time::Duration;
use std::vec::Vec;

use super::scheduler::{Origin, Scheduled, HEARTBEAT_PERIOD};
use super::StationTime;
use crate::v2::{CommandFrame, DisplayFrame, RobotMode, COMMAND_FRAME_LEN};
use crate::{Command, CommandType};

/// How long a requested command is repeated without its acknowledgement before it is given up
/// (five display periods at the robot's default 2 Hz).
pub const CONFIRM_TIMEOUT: Duration = Duration::from_millis(2_500);
/// Session ids of earlier boots remembered, so that their replayed frames are refused.
const RETIRED_KEPT: usize = 32;
/// Numbers of one command remembered for matching acknowledgements (a command repeated every
/// 100 ms for [`CONFIRM_TIMEOUT`] uses 25).
const SEQS_KEPT: usize = 64;

/// What became of a requested command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delivery {
    /// Not yet acknowledged: being repeated (or held back while the session is unknown).
    Pending,
    /// The robot acknowledged one of its frames (a revive: and reported MANUAL or AUTO).
    Acknowledged {
        /// The acknowledged sequence number.
        seq: u32,
    },
    /// No acknowledgement within [`CONFIRM_TIMEOUT`]: given up.
    Unacknowledged,
    /// Replaced by a newer command before it was acknowledged.
    Superseded,
    /// Dropped by a kill.
    Cancelled,
    /// Dropped because the robot restarted (new session id).
    RobotRestarted,
    /// A manual value or setpoint (requested or held) dropped because a revive went out: what
    /// was asked for before a revive never drives the revived robot.
    CancelledByRevive,
    /// A manual value or setpoint (requested or held) dropped because the robot reported
    /// KILLED or FAILSAFE.
    CancelledRobotSafe,
}

impl Delivery {
    /// A short description for the operator.
    pub fn label(self) -> &'static str {
        match self {
            Delivery::Pending => "pending",
            Delivery::Acknowledged { .. } => "acknowledged",
            Delivery::Unacknowledged => "NOT acknowledged",
            Delivery::Superseded => "superseded",
            Delivery::Cancelled => "cancelled by kill",
            Delivery::RobotRestarted => "dropped: robot restarted",
            Delivery::CancelledByRevive => "cancelled by revive",
            Delivery::CancelledRobotSafe => "cancelled: robot KILLED or FAILSAFE",
        }
    }
}

/// The station's view of one requested command (or kill).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CommandStatus {
    /// The command.
    pub command: Command,
    /// When it was requested.
    pub requested_at: StationTime,
    /// Frames sent with it (each with its own sequence number).
    pub transmissions: u32,
    /// Sequence number of its first and latest frame (`None` before it went out).
    pub first_seq: Option<u32>,
    /// Sequence number of its latest frame.
    pub last_seq: Option<u32>,
    /// When it was acknowledged, given up or dropped.
    pub settled_at: Option<StationTime>,
    /// What became of it.
    pub delivery: Delivery,
    /// A revive the robot accepted (one of its frames was acknowledged) while still reporting
    /// KILLED or FAILSAFE: refused for now (the display frame says why).
    pub accepted_but_refused: bool,
}

impl CommandStatus {
    pub(super) fn new(command: Command, now: StationTime) -> CommandStatus {
        CommandStatus {
            command,
            requested_at: now,
            transmissions: 0,
            first_seq: None,
            last_seq: None,
            settled_at: None,
            delivery: Delivery::Pending,
            accepted_but_refused: false,
        }
    }
}

/// A requested command waiting for its acknowledgement.
#[derive(Debug, Clone)]
struct Outstanding {
    status: CommandStatus,
    /// Its sequence numbers, oldest first (at most [`SEQS_KEPT`]).
    seqs: Vec<u32>,
    /// A revive: the downlink sequence number of the display frame that first acknowledged
    /// one of its frames while the robot still reported KILLED or FAILSAFE.
    accepted_in: Option<u32>,
    /// A revive: the number of its frame the robot acknowledged; from then on it is not sent
    /// again, only its outcome awaited.
    acted_on: Option<u32>,
}

/// Counters since the station started (each saturates).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UplinkStats {
    /// Command frames numbered.
    pub frames: u64,
    /// Frames of a requested command beyond its first (repetitions until acknowledged).
    pub resends: u64,
    /// Requested commands acknowledged.
    pub acknowledged: u64,
    /// Requested commands given up after [`CONFIRM_TIMEOUT`].
    pub unacknowledged: u64,
    /// Frames not sent because the session was not known yet (everything but kills).
    pub held_back: u64,
    /// Display frames ignored: current session with a downlink number not newer than the
    /// last, or the session of an earlier boot.
    pub old_display_frames: u64,
    /// Session ids seen (more than one: the robot restarted while the station ran).
    pub sessions: u32,
    /// Authentic display frames reporting KILLED or FAILSAFE that cancelled manual values and
    /// setpoints (see the module docs).
    pub safe_reports: u64,
}

/// A requested command that was settled (for the session recording).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Settled {
    /// Its final status.
    pub status: CommandStatus,
    /// When it was settled.
    pub at: StationTime,
}

/// What [`Uplink::on_display`] made of a display frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DownlinkVerdict {
    /// A newer frame of the current session.
    Current,
    /// The first frame of a session: the first contact, or the robot restarted.
    NewSession {
        /// The previous session id, if there was one (the robot restarted).
        previous: Option<u32>,
    },
    /// Not newer than the last frame of this session, or from an earlier boot: ignored.
    Old,
}

/// The station's side of ground link v2.
#[derive(Debug, Clone)]
pub struct Uplink {
    session: Option<u32>,
    /// Sessions replaced by a newer one, oldest first.
    retired: Vec<u32>,
    next_seq: u32,
    last_ack: Option<u32>,
    last_downlink_seq: u32,
    mode: Option<RobotMode>,
    outstanding: Vec<Outstanding>,
    /// The values held in the last slot (one per command type), with their frames.
    held: Vec<CommandStatus>,
    /// The latest kill, while it is the station's latest decision about the robot's mode.
    kill: Option<CommandStatus>,
    /// The last slot was a kill slot (a repetition is not a new kill).
    killing: bool,
    last_command: Option<CommandStatus>,
    settled: Vec<Settled>,
    stats: UplinkStats,
    /// Most frames one slot may carry (see [`frames_per_slot`]).
    frames_per_slot: usize,
    /// Where the held values' turn starts when a slot cannot carry them all.
    held_turn: usize,
}

/// The baud rate the station's budget assumes unless told otherwise: the XBee's default.
pub const DEFAULT_LINK_BAUD: u32 = 9_600;

/// Share of a slot's time on the wire the station fills at most, in percent. The rest is room
/// for the radio's own overhead and for a kill sent between slots, so bytes never queue up
/// from one slot to the next (a queue would delay every later kill by its length).
pub const SLOT_BUDGET_PERCENT: u64 = 80;

/// Most command frames v2 one slot of `period` may carry at `baud` (8N1: ten bits a byte) within
/// [`SLOT_BUDGET_PERCENT`] of the slot; at least one, so a heartbeat always goes out. At the
/// XBee's default 9600 baud a 100 ms slot carries two 28-byte frames (58 ms).
pub fn frames_per_slot(baud: u32, period: Duration) -> usize {
    let bytes = u128::from(baud) / 10 * period.as_micros() / 1_000_000;
    let budget = bytes * u128::from(SLOT_BUDGET_PERCENT) / 100;
    (budget / COMMAND_FRAME_LEN as u128).clamp(1, 64) as usize
}

impl Default for Uplink {
    fn default() -> Self {
        Uplink::new()
    }
}

impl Uplink {
    /// No session known, numbering from 1.
    pub fn new() -> Uplink {
        Uplink {
            session: None,
            retired: Vec::new(),
            next_seq: 1,
            last_ack: None,
            last_downlink_seq: 0,
            mode: None,
            outstanding: Vec::new(),
            held: Vec::new(),
            kill: None,
            killing: false,
            last_command: None,
            settled: Vec::new(),
            stats: UplinkStats::default(),
            frames_per_slot: frames_per_slot(DEFAULT_LINK_BAUD, HEARTBEAT_PERIOD),
            held_turn: 0,
        }
    }

    /// The same, with slots of at most `frames` frames (at least one); see
    /// [`frames_per_slot`].
    pub fn with_frames_per_slot(mut self, frames: usize) -> Uplink {
        self.frames_per_slot = frames.max(1);
        self
    }

    /// Slots of at most `frames` frames from now on (at least one); see [`frames_per_slot`].
    pub fn set_frames_per_slot(&mut self, frames: usize) {
        self.frames_per_slot = frames.max(1);
    }

    /// Most frames one slot carries.
    pub fn slot_frames(&self) -> usize {
        self.frames_per_slot
    }

    /// The robot's session id, once an authenticated display frame told it.
    pub fn session(&self) -> Option<u32> {
        self.session
    }

    /// The sequence number the next frame gets.
    pub fn next_seq(&self) -> u32 {
        self.next_seq
    }

    /// The robot's last acknowledgement (the last sequence number it accepted).
    pub fn last_ack(&self) -> Option<u32> {
        self.last_ack
    }

    /// Counters.
    pub fn stats(&self) -> UplinkStats {
        self.stats
    }

    /// The latest command the operator asked for (kills included), and what became of it.
    pub fn last_command(&self) -> Option<&CommandStatus> {
        self.last_command.as_ref()
    }

    /// Requested commands still waiting for their acknowledgement.
    pub fn pending(&self) -> impl Iterator<Item = &CommandStatus> {
        self.outstanding.iter().map(|o| &o.status)
    }

    /// Commands settled since the last call (acknowledged, given up or dropped).
    pub fn take_settled(&mut self) -> Vec<Settled> {
        core::mem::take(&mut self.settled)
    }

    /// Takes an authenticated display frame received at `now`: session, numbering,
    /// acknowledgements. Frames judged [`DownlinkVerdict::Old`] change nothing.
    pub fn on_display(&mut self, frame: &DisplayFrame, now: StationTime) -> DownlinkVerdict {
        let old = match self.session {
            Some(s) if s == frame.session => frame.seq <= self.last_downlink_seq,
            _ => self.retired.contains(&frame.session),
        };
        if old {
            self.stats.old_display_frames = self.stats.old_display_frames.saturating_add(1);
            return DownlinkVerdict::Old;
        }
        let verdict = match self.session {
            Some(s) if s == frame.session => DownlinkVerdict::Current,
            previous => {
                self.stats.sessions = self.stats.sessions.saturating_add(1);
                if let Some(previous) = previous {
                    // A new boot: its window starts afresh, and what waited was meant for the
                    // old one.
                    if self.retired.len() == RETIRED_KEPT {
                        self.retired.remove(0);
                    }
                    self.retired.push(previous);
                    self.next_seq = 1;
                    self.settle_all(Delivery::RobotRestarted, now);
                    self.held.clear();
                }
                self.session = Some(frame.session);
                DownlinkVerdict::NewSession { previous }
            }
        };
        self.last_downlink_seq = frame.seq;
        self.last_ack = Some(frame.ack_seq);
        self.mode = Some(frame.mode);
        self.next_seq = self.next_seq.max(frame.ack_seq.saturating_add(1));
        self.confirm(frame, now);
        if self.reports_safe(frame) {
            self.stats.safe_reports = self.stats.safe_reports.saturating_add(1);
            self.cancel_driving(Delivery::CancelledRobotSafe, now);
        }
        verdict
    }

    /// Whether `frame` reports the robot KILLED or FAILSAFE after the last revive that went
    /// out could have been acted on (a frame whose acknowledgement is older than an
    /// outstanding revive's first frame was built before it).
    fn reports_safe(&self, frame: &DisplayFrame) -> bool {
        let safe = matches!(frame.mode, RobotMode::Killed | RobotMode::Failsafe);
        let predates_revive = self.outstanding.iter().any(|o| {
            o.status.command == Command::Revive
                && o.status.first_seq.is_none_or(|first| frame.ack_seq < first)
        });
        safe && !predates_revive
    }

    /// Cancels every manual value and setpoint waiting for its acknowledgement and every held
    /// value, settling them as `delivery` (see the module docs).
    pub fn cancel_driving(&mut self, delivery: Delivery, now: StationTime) {
        let mut i = 0;
        while i < self.outstanding.len() {
            if self.outstanding[i].status.command.drives() {
                let o = self.outstanding.remove(i);
                self.settle(o.status, delivery, now);
            } else {
                i += 1;
            }
        }
        for held in core::mem::take(&mut self.held) {
            self.settle(held, delivery, now);
        }
    }

    /// Acknowledgements in `frame` for what is waiting.
    fn confirm(&mut self, frame: &DisplayFrame, now: StationTime) {
        let ack = frame.ack_seq;
        let revived = matches!(frame.mode, RobotMode::Manual | RobotMode::Auto);
        let mut i = 0;
        while i < self.outstanding.len() {
            let o = &mut self.outstanding[i];
            let exact = o.seqs.contains(&ack);
            let done = if o.status.command == Command::Revive {
                if exact && o.acted_on.is_none() {
                    o.acted_on = Some(ack);
                }
                if !revived {
                    // The frame that acknowledges a revive may have been built before the
                    // loop acted on it: only a later frame still in KILLED or FAILSAFE shows
                    // a refusal.
                    match o.accepted_in {
                        Some(first) if frame.seq > first => o.status.accepted_but_refused = true,
                        None if exact => o.accepted_in = Some(frame.seq),
                        _ => {}
                    }
                }
                o.status.accepted_but_refused
                    || (revived && o.seqs.first().is_some_and(|&first| ack >= first))
            } else {
                exact
            };
            if done {
                let o = self.outstanding.remove(i);
                let seq = o.acted_on.unwrap_or(ack);
                self.stats.acknowledged = self.stats.acknowledged.saturating_add(1);
                self.settle(o.status, Delivery::Acknowledged { seq }, now);
            } else {
                i += 1;
            }
        }
        if let Some(mut kill) = self.kill.take() {
            if kill.delivery == Delivery::Pending && frame.mode == RobotMode::Killed {
                kill.delivery = Delivery::Acknowledged { seq: ack };
                kill.settled_at = Some(now);
                self.note_last(&kill);
                self.settled.push(Settled {
                    status: kill.clone(),
                    at: now,
                });
            }
            self.kill = Some(kill);
        }
    }

    /// Numbers the frames of one slot of the [`CommandScheduler`](super::scheduler::CommandScheduler),
    /// taken at `now`, adding the repetitions of what waits for an acknowledgement.
    pub fn frames(&mut self, slot: &[Scheduled], now: StationTime) -> Vec<CommandFrame> {
        self.expire(now);
        let mut out = Vec::new();
        if slot.is_empty() {
            return out;
        }
        let mut held = Vec::new();
        for s in slot {
            match s.origin {
                Origin::Kill => {
                    let frame = self.number(Command::Kill, self.session.unwrap_or(0));
                    self.kill_sent(frame.seq, now);
                    out.push(frame);
                }
                Origin::Request => self.track(s.command, now),
                Origin::Held => {
                    self.supersede_for(s.command, now);
                    held.push(s.command);
                }
                Origin::Heartbeat => {}
            }
        }
        if !out.is_empty() {
            // A kill slot carries nothing else.
            return out;
        }
        self.killing = false;
        let Some(session) = self.session else {
            let waiting = (held.len() + self.outstanding.len()).max(1);
            self.stats.held_back = self.stats.held_back.saturating_add(waiting as u64);
            return out;
        };
        // A value no longer in the slot was let go (or replaced by a request of its type).
        self.held.retain(|h| {
            let kind = h.command.command_type();
            slot.iter().any(|s| s.command.command_type() == kind)
        });
        // The slot's budget: what waits for an acknowledgement first (in request order), then
        // the held values.
        let waiting = self
            .outstanding
            .iter()
            .filter(|o| o.acted_on.is_none())
            .count()
            .min(self.frames_per_slot);
        for command in self.held_in_turn(held, self.frames_per_slot - waiting) {
            let frame = self.number(command, session);
            self.held_sent(command, frame.seq, now);
            out.push(frame);
        }
        self.repeat_outstanding(session, waiting, &mut out);
        if out.is_empty() {
            out.push(self.number(Command::Heartbeat, session));
        }
        out
    }

    /// The held values that fit in `room` frames, in the slot's channel order; when they do
    /// not all fit they take turns from slot to slot (the robot keeps a manual value between
    /// its frames).
    fn held_in_turn(&mut self, mut held: Vec<Command>, room: usize) -> Vec<Command> {
        if held.len() <= room {
            return held;
        }
        let turn = self.held_turn % held.len();
        self.held_turn = self.held_turn.wrapping_add(room.max(1));
        let mut chosen: Vec<Command> = held[turn..].iter().chain(&held[..turn]).copied().collect();
        chosen.truncate(room);
        held.retain(|c| chosen.contains(c));
        held
    }

    /// One more frame, into `out`, for each of the first `limit` requests still waiting for
    /// their acknowledgement (not a revive the robot already acted on). Every frame of a
    /// request names its first frame: the robot acts on a revive request once and refuses a
    /// value requested before its last revive.
    fn repeat_outstanding(&mut self, session: u32, limit: usize, out: &mut Vec<CommandFrame>) {
        let mut sent = 0;
        for i in 0..self.outstanding.len() {
            if sent == limit {
                break;
            }
            if self.outstanding[i].acted_on.is_some() {
                continue;
            }
            sent += 1;
            let command = self.outstanding[i].status.command;
            let mut frame = self.number(command, session);
            let o = &mut self.outstanding[i];
            frame.request = o.status.first_seq.unwrap_or(frame.seq);
            if o.seqs.len() == SEQS_KEPT {
                o.seqs.remove(0);
            }
            o.seqs.push(frame.seq);
            let status = &mut o.status;
            status.transmissions = status.transmissions.saturating_add(1);
            if status.transmissions > 1 {
                self.stats.resends = self.stats.resends.saturating_add(1);
            }
            status.first_seq.get_or_insert(frame.seq);
            status.last_seq = Some(frame.seq);
            let status = status.clone();
            self.note_last(&status);
            out.push(frame);
        }
    }

    /// Notes a frame of a held value: the same value again, or a new one.
    fn held_sent(&mut self, command: Command, seq: u32, now: StationTime) {
        let kind = command.command_type();
        let same = self.held.iter().position(|h| h.command == command);
        let i = match same {
            Some(i) => i,
            None => {
                self.held.retain(|h| h.command.command_type() != kind);
                let mut status = CommandStatus::new(command, now);
                status.first_seq = Some(seq);
                self.held.push(status);
                self.held.len() - 1
            }
        };
        let status = &mut self.held[i];
        status.transmissions = status.transmissions.saturating_add(1);
        status.last_seq = Some(seq);
    }

    /// Notes a kill frame: the first of a kill (not a repetition) drops everything waiting.
    fn kill_sent(&mut self, seq: u32, now: StationTime) {
        if !self.killing {
            self.killing = true;
            self.settle_all(Delivery::Cancelled, now);
            for held in core::mem::take(&mut self.held) {
                self.settle(held, Delivery::Cancelled, now);
            }
            self.kill = Some(CommandStatus::new(Command::Kill, now));
        }
        let Some(mut kill) = self.kill.take() else {
            return;
        };
        kill.transmissions = kill.transmissions.saturating_add(1);
        kill.first_seq.get_or_insert(seq);
        kill.last_seq = Some(seq);
        self.note_last(&kill);
        self.kill = Some(kill);
    }

    /// A frame with the next sequence number.
    fn number(&mut self, command: Command, session: u32) -> CommandFrame {
        let seq = self.next_seq;
        // 2^32 frames at 10 Hz take 13 years; past that the robot would refuse everything,
        // which is safe.
        self.next_seq = self.next_seq.saturating_add(1);
        self.stats.frames = self.stats.frames.saturating_add(1);
        CommandFrame::new(command, session, seq)
    }

    /// A requested command starts waiting for its acknowledgement (a revive first cancels the
    /// manual values and setpoints asked for before it).
    fn track(&mut self, command: Command, now: StationTime) {
        if command == Command::Heartbeat {
            return;
        }
        if command == Command::Revive {
            self.cancel_driving(Delivery::CancelledByRevive, now);
        }
        self.supersede_for(command, now);
        let status = CommandStatus::new(command, now);
        self.note_last(&status);
        self.outstanding.push(Outstanding {
            status,
            seqs: Vec::new(),
            accepted_in: None,
            acted_on: None,
        });
    }

    /// Drops what `command` replaces: the same type, and the other driving mode's commands.
    fn supersede_for(&mut self, command: Command, now: StationTime) {
        let kind = command.command_type();
        let replaced = |waiting: CommandType| {
            waiting == kind
                || (is_manual(kind) && is_setpoint(waiting))
                || (is_setpoint(kind) && is_manual(waiting))
        };
        let mut i = 0;
        while i < self.outstanding.len() {
            if replaced(self.outstanding[i].status.command.command_type()) {
                let o = self.outstanding.remove(i);
                self.settle(o.status, Delivery::Superseded, now);
            } else {
                i += 1;
            }
        }
    }

    /// Gives up what waited longer than [`CONFIRM_TIMEOUT`].
    fn expire(&mut self, now: StationTime) {
        let mut i = 0;
        while i < self.outstanding.len() {
            let age = now.saturating_sub(self.outstanding[i].status.requested_at);
            if age > CONFIRM_TIMEOUT {
                let o = self.outstanding.remove(i);
                if let Some(seq) = o.acted_on {
                    // Acknowledged, but no later display frame showed what became of it.
                    self.stats.acknowledged = self.stats.acknowledged.saturating_add(1);
                    self.settle(o.status, Delivery::Acknowledged { seq }, now);
                    continue;
                }
                self.stats.unacknowledged = self.stats.unacknowledged.saturating_add(1);
                self.settle(o.status, Delivery::Unacknowledged, now);
            } else {
                i += 1;
            }
        }
        if let Some(mut kill) = self.kill.take() {
            let age = now.saturating_sub(kill.requested_at);
            if kill.delivery == Delivery::Pending && age > CONFIRM_TIMEOUT {
                kill.delivery = Delivery::Unacknowledged;
                kill.settled_at = Some(now);
                self.note_last(&kill);
                self.settled.push(Settled {
                    status: kill.clone(),
                    at: now,
                });
            }
            self.kill = Some(kill);
        }
    }

    fn settle_all(&mut self, delivery: Delivery, now: StationTime) {
        for o in core::mem::take(&mut self.outstanding) {
            self.settle(o.status, delivery, now);
        }
    }

    fn settle(&mut self, mut status: CommandStatus, delivery: Delivery, now: StationTime) {
        status.delivery = delivery;
        status.settled_at = Some(now);
        self.note_last(&status);
        self.settled.push(Settled { status, at: now });
    }

    /// Updates the operator's "last command" when `status` is about it (or newer).
    fn note_last(&mut self, status: &CommandStatus) {
        let newer = self.last_command.as_ref().is_none_or(|last| {
            status.requested_at > last.requested_at
                || (status.requested_at == last.requested_at && status.command == last.command)
        });
        if newer {
            self.last_command = Some(status.clone());
        }
    }
}

fn is_manual(kind: CommandType) -> bool {
    matches!(
        kind,
        CommandType::Throttle | CommandType::Steering | CommandType::Tail
    )
}

fn is_setpoint(kind: CommandType) -> bool {
    matches!(
        kind,
        CommandType::SpeedSetpoint | CommandType::HeadingSetpoint
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Percent;
    use std::vec;

    const SESSION: u32 = 0x5EED_0001;

    fn ms(t0: StationTime, n: u64) -> StationTime {
        t0 + Duration::from_millis(n)
    }

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    fn at(command: Command, origin: Origin) -> Scheduled {
        Scheduled { command, origin }
    }

    fn heartbeat() -> Vec<Scheduled> {
        vec![at(Command::Heartbeat, Origin::Heartbeat)]
    }

    fn display(session: u32, seq: u32, ack_seq: u32, mode: RobotMode) -> DisplayFrame {
        DisplayFrame {
            mode,
            session,
            seq,
            ack_seq,
            ..DisplayFrame::default()
        }
    }

    /// An uplink that knows `SESSION`, whose robot acknowledged `ack`.
    fn connected(ack: u32, t0: StationTime) -> Uplink {
        let mut u = Uplink::new();
        u.on_display(&display(SESSION, 1, ack, RobotMode::Killed), t0);
        u
    }

    fn commands(frames: &[CommandFrame]) -> Vec<Command> {
        frames.iter().map(|f| f.command).collect()
    }

    #[test]
    fn a_slot_fits_its_share_of_the_wire_and_held_values_take_turns() {
        // Three held channels and a setpoint waiting for its acknowledgement: four 28-byte
        // frames are 117 ms at 9600 baud, more than the 100 ms slot, so bytes would queue up
        // slot after slot and delay every later kill by the queue.
        let t0 = StationTime::from_secs(1_000);
        let mut u = connected(0, t0);
        let held = [
            Command::Throttle(pct(70)),
            Command::Steering(pct(30)),
            Command::Tail(pct(60)),
        ];
        let slot: Vec<Scheduled> = held.iter().map(|&c| at(c, Origin::Held)).collect();
        let mut with_request = slot.clone();
        with_request.push(at(Command::Tail(pct(60)), Origin::Request));
        let budget_bytes = 9_600 / 10 * 100 / 1_000 * SLOT_BUDGET_PERCENT as usize / 100;
        let mut seen = [0u32; 3];
        for k in 0..30u64 {
            let s = if k == 0 { &with_request } else { &slot };
            let frames = u.frames(s, ms(t0, 100 * k));
            let bytes = frames.len() * COMMAND_FRAME_LEN;
            assert!(
                bytes <= budget_bytes,
                "slot {k}: {bytes} bytes, budget {budget_bytes}: {:?}",
                commands(&frames)
            );
            for f in &frames {
                if let Some(i) = held.iter().position(|&c| c == f.command) {
                    seen[i] += 1;
                }
            }
        }
        // Every held value goes out in turn (two of three per slot).
        for (i, n) in seen.iter().enumerate() {
            assert!(*n >= 18, "{:?} went out {n} times in 30 slots", held[i]);
        }
        assert_eq!(frames_per_slot(9_600, HEARTBEAT_PERIOD), 2);
        assert_eq!(frames_per_slot(115_200, HEARTBEAT_PERIOD), 32);
        assert_eq!(frames_per_slot(1_200, HEARTBEAT_PERIOD), 1);
    }

    #[test]
    fn a_request_waiting_for_its_acknowledgement_goes_out_in_every_slot_within_the_budget() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = connected(0, t0);
        let slot = [
            at(Command::Throttle(pct(70)), Origin::Held),
            at(Command::Steering(pct(30)), Origin::Held),
        ];
        let speed = Command::SpeedSetpoint { mm_s: 900 };
        let mut first = slot.to_vec();
        first.push(at(Command::Revive, Origin::Request));
        let f = u.frames(&first, t0);
        assert_eq!(f.len(), 2);
        assert!(commands(&f).contains(&Command::Revive));
        for k in 1..5u64 {
            let f = u.frames(&slot, ms(t0, 100 * k));
            assert!(commands(&f).contains(&Command::Revive), "slot {k}");
            assert_eq!(f.len(), 2, "slot {k}");
        }
        // A larger budget carries everything.
        let mut wide = connected(0, t0).with_frames_per_slot(8);
        let mut all = slot.to_vec();
        all.push(at(Command::Revive, Origin::Request));
        assert_eq!(wide.frames(&all, t0).len(), 3);
        // A budget of one: the request alone, then the held values in turn once it is
        // acknowledged.
        let mut narrow = connected(0, t0).with_frames_per_slot(1);
        let mut with_speed = slot.to_vec();
        with_speed.push(at(speed, Origin::Request));
        let f = narrow.frames(&with_speed, t0);
        assert_eq!(commands(&f), vec![speed]);
        narrow.on_display(&display(SESSION, 2, f[0].seq, RobotMode::Auto), ms(t0, 50));
        let a = commands(&narrow.frames(&slot, ms(t0, 100)));
        let b = commands(&narrow.frames(&slot, ms(t0, 200)));
        assert_eq!((a.len(), b.len()), (1, 1));
        assert_ne!(a, b, "the held values take turns");
    }

    #[test]
    fn before_the_session_is_known_only_kills_go_out_with_session_0() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = Uplink::new();
        assert!(u.frames(&heartbeat(), t0).is_empty());
        assert!(u
            .frames(&[at(Command::Revive, Origin::Request)], ms(t0, 100))
            .is_empty());
        assert_eq!(u.stats().held_back, 2);
        let kill = u.frames(&[at(Command::Kill, Origin::Kill)], ms(t0, 150));
        assert_eq!(kill, vec![CommandFrame::new(Command::Kill, 0, 1)]);
        // The kill dropped the revive that waited for the session.
        assert_eq!(u.pending().count(), 0);
        assert_eq!(u.last_command().unwrap().command, Command::Kill);
        assert_eq!(u.last_command().unwrap().delivery, Delivery::Pending);
    }

    #[test]
    fn numbering_follows_the_acknowledgement_and_never_goes_back() {
        let t0 = StationTime::from_secs(1_000);
        // A station (re)started while the robot had accepted up to 41.
        let mut u = Uplink::new();
        let verdict = u.on_display(&display(SESSION, 7, 41, RobotMode::Manual), t0);
        assert_eq!(verdict, DownlinkVerdict::NewSession { previous: None });
        assert_eq!(u.session(), Some(SESSION));
        let f = u.frames(&heartbeat(), t0);
        assert_eq!(f, vec![CommandFrame::new(Command::Heartbeat, SESSION, 42)]);
        // A later frame with an older acknowledgement (ours still on the way) changes nothing.
        u.on_display(&display(SESSION, 8, 30, RobotMode::Manual), ms(t0, 500));
        assert_eq!(u.frames(&heartbeat(), ms(t0, 600))[0].seq, 43);
        // Someone else with the key went further: jump past it.
        u.on_display(&display(SESSION, 9, 90, RobotMode::Manual), ms(t0, 1_000));
        assert_eq!(u.frames(&heartbeat(), ms(t0, 1_100))[0].seq, 91);
        assert_eq!(u.last_ack(), Some(90));
    }

    #[test]
    fn a_request_is_repeated_with_new_numbers_until_exactly_acknowledged() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = connected(0, t0);
        let steer = at(Command::Steering(pct(30)), Origin::Held);
        let throttle = Command::Throttle(pct(60));
        let s1 = u.frames(&[at(throttle, Origin::Request), steer], t0);
        assert_eq!(commands(&s1), vec![Command::Steering(pct(30)), throttle]);
        let s2 = u.frames(&[steer], ms(t0, 100));
        assert_eq!(commands(&s2), vec![Command::Steering(pct(30)), throttle]);
        let seqs: Vec<u32> = s1.iter().chain(&s2).map(|f| f.seq).collect();
        assert_eq!(seqs, vec![1, 2, 3, 4], "a new number for every frame");
        // The robot acknowledges the held steering of the second slot (3): the throttle's
        // first frame (2) may have been lost, so the throttle still waits.
        u.on_display(&display(SESSION, 2, 3, RobotMode::Manual), ms(t0, 150));
        assert_eq!(u.pending().count(), 1);
        let s3 = u.frames(&[steer], ms(t0, 200));
        assert_eq!(commands(&s3), vec![Command::Steering(pct(30)), throttle]);
        assert_eq!(s3[1].seq, 6);
        // Now its own frame: acknowledged, and no longer repeated.
        u.on_display(&display(SESSION, 3, 6, RobotMode::Manual), ms(t0, 250));
        assert_eq!(u.pending().count(), 0);
        let last = u.last_command().unwrap();
        assert_eq!(last.command, throttle);
        assert_eq!(last.delivery, Delivery::Acknowledged { seq: 6 });
        assert_eq!(last.transmissions, 3);
        assert_eq!((last.first_seq, last.last_seq), (Some(2), Some(6)));
        assert_eq!(
            commands(&u.frames(&[steer], ms(t0, 300))),
            vec![steer.command]
        );
        assert_eq!(u.stats().resends, 2);
        assert_eq!(u.stats().acknowledged, 1);
        let settled = u.take_settled();
        assert_eq!(settled.len(), 1);
        assert_eq!(
            settled[0].status.delivery,
            Delivery::Acknowledged { seq: 6 }
        );
    }

    #[test]
    fn a_request_replaces_the_heartbeat_and_is_given_up_after_the_timeout() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = connected(0, t0);
        let speed = Command::SpeedSetpoint { mm_s: 1_200 };
        assert_eq!(
            commands(&u.frames(&[at(speed, Origin::Request)], t0)),
            vec![speed]
        );
        let mut sent = 1;
        let mut t = 100;
        while t <= 2_500 {
            assert_eq!(commands(&u.frames(&heartbeat(), ms(t0, t))), vec![speed]);
            sent += 1;
            t += 100;
        }
        assert_eq!(
            commands(&u.frames(&heartbeat(), ms(t0, 2_600))),
            vec![Command::Heartbeat]
        );
        let last = u.last_command().unwrap();
        assert_eq!(last.delivery, Delivery::Unacknowledged);
        assert_eq!(last.transmissions, sent);
        assert_eq!(u.stats().unacknowledged, 1);
        assert_eq!(u.stats().resends, u64::from(sent) - 1);
    }

    #[test]
    fn a_revive_is_repeated_until_acknowledged_and_settled_by_the_robots_mode() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = connected(10, t0);
        let first = u.frames(&[at(Command::Revive, Origin::Request)], t0);
        assert_eq!((first[0].seq, first[0].request), (11, 11));
        // An acknowledgement older than the revive proves nothing, even in MANUAL: repeated,
        // with a new number and the same request.
        u.on_display(&display(SESSION, 2, 10, RobotMode::Manual), ms(t0, 50));
        let again = u.frames(&heartbeat(), ms(t0, 100));
        assert_eq!(commands(&again), vec![Command::Revive]);
        assert_eq!((again[0].seq, again[0].request), (12, 11));
        // The robot acknowledged 12. The frame may predate the loop's decision: not refused
        // yet, but not sent again either.
        u.on_display(&display(SESSION, 3, 12, RobotMode::Killed), ms(t0, 150));
        assert!(!u.pending().next().unwrap().accepted_but_refused);
        assert_eq!(
            commands(&u.frames(&heartbeat(), ms(t0, 200))),
            vec![Command::Heartbeat]
        );
        // A later frame still says KILLED: refused (e.g. too soon after a kill), and settled.
        u.on_display(&display(SESSION, 4, 13, RobotMode::Killed), ms(t0, 250));
        assert_eq!(u.pending().count(), 0);
        let last = u.last_command().unwrap();
        assert_eq!(last.delivery, Delivery::Acknowledged { seq: 12 });
        assert!(last.accepted_but_refused);
        // The operator revives again: a new request, and MANUAL settles it.
        let f = u.frames(&[at(Command::Revive, Origin::Request)], ms(t0, 300));
        assert_eq!((f[0].seq, f[0].request), (14, 14));
        u.on_display(&display(SESSION, 5, 14, RobotMode::Manual), ms(t0, 350));
        let last = u.last_command().unwrap();
        assert_eq!(last.delivery, Delivery::Acknowledged { seq: 14 });
        assert!(!last.accepted_but_refused);
        assert_eq!(u.stats().acknowledged, 2);
        // Acknowledged, but no display frame afterwards: still acknowledged after the timeout.
        let mut u = connected(10, t0);
        u.frames(&[at(Command::Revive, Origin::Request)], t0);
        u.on_display(&display(SESSION, 2, 11, RobotMode::Killed), ms(t0, 50));
        u.frames(&heartbeat(), ms(t0, 2_600));
        assert_eq!(
            u.last_command().unwrap().delivery,
            Delivery::Acknowledged { seq: 11 }
        );
    }

    #[test]
    fn a_revive_the_robot_acted_on_is_not_repeated() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = connected(10, t0);
        let first = u.frames(&[at(Command::Revive, Origin::Request)], t0);
        assert_eq!(first[0].seq, 11);
        // The robot accepted frame 11 (it revived, and failed safe again before this frame was
        // built: the radio faded, a sensor was lost). Another revive now would lift a failsafe
        // nobody asked to lift.
        u.on_display(&display(SESSION, 2, 11, RobotMode::Failsafe), ms(t0, 50));
        let throttle = at(Command::Throttle(pct(70)), Origin::Held);
        for t in (100..=3_000).step_by(100) {
            let sent = commands(&u.frames(&[throttle], ms(t0, t)));
            assert!(!sent.contains(&Command::Revive), "at {t} ms: {sent:?}");
        }
    }

    #[test]
    fn a_new_session_restarts_numbering_and_drops_what_waited() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = connected(500, t0);
        u.frames(
            &[at(
                Command::HeadingSetpoint { deg_e5: 9_000_000 },
                Origin::Request,
            )],
            t0,
        );
        assert_eq!(u.next_seq(), 502);
        // The robot rebooted: a new session, nothing accepted yet.
        let verdict = u.on_display(&display(0xABCD, 1, 0, RobotMode::Killed), ms(t0, 400));
        assert_eq!(
            verdict,
            DownlinkVerdict::NewSession {
                previous: Some(SESSION)
            }
        );
        assert_eq!(u.next_seq(), 1);
        assert_eq!(u.pending().count(), 0);
        assert_eq!(u.last_command().unwrap().delivery, Delivery::RobotRestarted);
        let f = u.frames(&heartbeat(), ms(t0, 500));
        assert_eq!((f[0].session, f[0].seq), (0xABCD, 1));
        assert_eq!(u.stats().sessions, 2);
        // A replayed frame of the earlier boot does not take the station back to it.
        let replay = display(SESSION, 99, 800, RobotMode::Manual);
        assert_eq!(u.on_display(&replay, ms(t0, 600)), DownlinkVerdict::Old);
        assert_eq!(u.session(), Some(0xABCD));
        assert_eq!(u.next_seq(), 2);
        assert_eq!(u.stats().old_display_frames, 1);
    }

    #[test]
    fn old_display_frames_are_ignored() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = Uplink::new();
        u.on_display(&display(SESSION, 20, 5, RobotMode::Manual), t0);
        // A replay of an older frame (or one overtaken): no effect on numbering or acks.
        let verdict = u.on_display(&display(SESSION, 20, 900, RobotMode::Auto), ms(t0, 10));
        assert_eq!(verdict, DownlinkVerdict::Old);
        assert_eq!(
            u.on_display(&display(SESSION, 3, 900, RobotMode::Auto), ms(t0, 20)),
            DownlinkVerdict::Old
        );
        assert_eq!(u.last_ack(), Some(5));
        assert_eq!(u.next_seq(), 6);
        assert_eq!(u.stats().old_display_frames, 2);
    }

    #[test]
    fn driving_modes_replace_each_others_waiting_commands() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = connected(0, t0);
        let speed = Command::SpeedSetpoint { mm_s: 900 };
        u.frames(&[at(speed, Origin::Request)], t0);
        // The operator drives by hand: the setpoint must not switch back to AUTO.
        let held = Command::Throttle(pct(70));
        let f = u.frames(&[at(held, Origin::Held)], ms(t0, 100));
        assert_eq!(commands(&f), vec![held]);
        assert_eq!(u.last_command().unwrap().delivery, Delivery::Superseded);
        // A one-off manual value, then a setpoint: the manual value stops.
        u.frames(&[at(Command::Tail(pct(40)), Origin::Request)], ms(t0, 200));
        let f = u.frames(&[at(speed, Origin::Request)], ms(t0, 300));
        assert_eq!(commands(&f), vec![speed]);
        // The same type: the newer value only.
        let f = u.frames(
            &[at(Command::SpeedSetpoint { mm_s: 500 }, Origin::Request)],
            ms(t0, 400),
        );
        assert_eq!(commands(&f), vec![Command::SpeedSetpoint { mm_s: 500 }]);
    }

    #[test]
    fn a_kill_goes_out_alone_drops_what_waited_and_is_confirmed_by_the_mode() {
        let t0 = StationTime::from_secs(1_000);
        let mut u = connected(3, t0);
        u.frames(&[at(Command::Revive, Origin::Request)], t0);
        let kill = [at(Command::Kill, Origin::Kill)];
        let k1 = u.frames(&kill, ms(t0, 30));
        assert_eq!(k1, vec![CommandFrame::new(Command::Kill, SESSION, 5)]);
        assert_eq!(u.pending().count(), 0, "the revive was dropped");
        let k2 = u.frames(&kill, ms(t0, 130));
        assert_eq!(k2[0].seq, 6);
        let status = u.last_command().unwrap();
        assert_eq!((status.command, status.transmissions), (Command::Kill, 2));
        // A frame built before the kill arrived still says MANUAL.
        u.on_display(&display(SESSION, 2, 4, RobotMode::Manual), ms(t0, 140));
        assert_eq!(u.last_command().unwrap().delivery, Delivery::Pending);
        u.on_display(&display(SESSION, 3, 6, RobotMode::Killed), ms(t0, 600));
        assert_eq!(
            u.last_command().unwrap().delivery,
            Delivery::Acknowledged { seq: 6 }
        );
        let settled = u.take_settled();
        assert_eq!(
            settled
                .iter()
                .map(|s| s.status.delivery)
                .collect::<Vec<_>>(),
            vec![Delivery::Cancelled, Delivery::Acknowledged { seq: 6 }]
        );
    }
}
