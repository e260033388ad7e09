//! The robot's side of the command link: which authentic frames become commands.

use core::fmt;

use super::command::{CommandDecoder, CommandFrame, COMMAND_FRAME_LEN};
use super::{FrameError, LinkKey};
use crate::command::Command;

/// Why the [`CommandGate`] refused a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rejection {
    /// The tag does not match: forged, corrupt, or sent with another key.
    BadTag,
    /// Authentic, but its sequence number is not newer than the last accepted one (a replay,
    /// or a frame overtaken by a newer one).
    Replayed,
    /// Authentic, but for another session (an earlier boot, or a station that does not know
    /// the session yet). Only a kill is accepted from another session.
    StaleSession,
    /// Wrong start token or length, or an authentic frame with an unknown type, out-of-range
    /// data or a request outside 1 to its sequence number.
    Malformed,
}

impl fmt::Display for Rejection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Rejection::BadTag => "tag does not match (forged, corrupt or another link key)",
            Rejection::Replayed => "sequence number not newer than the last accepted one",
            Rejection::StaleSession => "frame for another session",
            Rejection::Malformed => "malformed frame",
        })
    }
}

impl core::error::Error for Rejection {}

impl From<FrameError> for Rejection {
    fn from(error: FrameError) -> Rejection {
        match error {
            FrameError::BadTag => Rejection::BadTag,
            _ => Rejection::Malformed,
        }
    }
}

/// What a [`CommandGate`] has decided since it was created (each counter saturates).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GateStats {
    /// Commands accepted (kills included).
    pub accepted: u32,
    /// Kills accepted from another session or with an old sequence number (included in
    /// `accepted`).
    pub kills_outside_window: u32,
    /// Revives accepted as frames but not acted on: repetitions of a request the robot already
    /// acted on (included in `accepted`, yielded as heartbeats).
    pub revive_repeats: u32,
    /// Manual commands and setpoints accepted as frames but not acted on: their operator
    /// request is older than the last revive acted on (included in `accepted`, yielded as
    /// heartbeats).
    pub pre_revive_requests: u32,
    /// Frames rejected: tag did not match.
    pub bad_tag: u32,
    /// Frames rejected: sequence number not newer than the last accepted one.
    pub replayed: u32,
    /// Frames rejected: another session.
    pub stale_session: u32,
    /// Frames rejected: wrong length, unknown type, out-of-range data or request.
    pub malformed: u32,
    /// Bytes the stream decoder dropped.
    pub skipped_bytes: u32,
}

impl GateStats {
    /// Every rejected frame, whatever the reason.
    pub fn rejected(&self) -> u32 {
        self.bad_tag
            .saturating_add(self.replayed)
            .saturating_add(self.stale_session)
            .saturating_add(self.malformed)
    }
}

/// Accepts a command only when its tag is valid, its session is the robot's and its sequence
/// number is newer than the last accepted one; counts every refusal.
///
/// The exception is a kill: with a valid tag it is always accepted, whatever its session and
/// sequence number, because stopping must work from a ground station that does not know the
/// session yet (it sends session 0) and a replayed kill can only stop the robot. A kill moves
/// the sequence window only when it is in the current session and newer.
///
/// A revive is acted on once per operator request ([`CommandFrame::request`]): a station
/// repeats a revive until it sees it acknowledged, and a repetition that arrives after the
/// robot failed safe again must not lift that failsafe. A revive of a request not newer than
/// the last one acted on is accepted (its sequence number moves the window, it shows the link
/// is alive) and yielded as a [`Command::Heartbeat`], and counted in
/// [`GateStats::revive_repeats`].
///
/// A manual command (throttle, steering, tail) or a setpoint (speed, heading) whose request is
/// older than the last revive request acted on is not acted on either: a station repeats a
/// value the operator gave while the robot was KILLED or in FAILSAFE until it sees it
/// acknowledged, and that value must not move the robot after the revive. Such a frame is
/// accepted (its sequence number moves the window, it shows the link is alive), yielded as a
/// [`Command::Heartbeat`] and counted in [`GateStats::pre_revive_requests`]. Kills and
/// heartbeats are taken whatever their request.
///
/// Pure and `no_std`: [`check`](Self::check) takes one complete frame, [`push`](Self::push) and
/// [`feed`](Self::feed) take a byte stream (through a resynchronising [`CommandDecoder`]).
#[derive(Debug, Clone)]
pub struct CommandGate {
    key: LinkKey,
    session: u32,
    last_seq: u32,
    /// The request of the last revive acted on (0: none yet).
    last_revive_request: u32,
    decoder: CommandDecoder,
    accepted: u32,
    kills_outside_window: u32,
    revive_repeats: u32,
    pre_revive_requests: u32,
    replayed: u32,
    stale_session: u32,
    /// Rejections of frames given to `check` (the decoder counts the stream's).
    bad_tag: u32,
    malformed: u32,
}

impl CommandGate {
    /// A gate for the robot's `session` (nonzero: 0 is what a station that does not know the
    /// session sends) that checks tags with `key`.
    pub fn new(key: LinkKey, session: u32) -> CommandGate {
        CommandGate {
            decoder: CommandDecoder::new(key.clone()),
            key,
            session,
            last_seq: 0,
            last_revive_request: 0,
            accepted: 0,
            kills_outside_window: 0,
            revive_repeats: 0,
            pre_revive_requests: 0,
            replayed: 0,
            stale_session: 0,
            bad_tag: 0,
            malformed: 0,
        }
    }

    /// The robot's session id.
    pub fn session(&self) -> u32 {
        self.session
    }

    /// Sequence number of the last command accepted in this session (0: none yet); the
    /// acknowledgement the display frames carry.
    pub fn last_accepted(&self) -> u32 {
        self.last_seq
    }

    /// Counters since creation, the stream decoder's included.
    pub fn stats(&self) -> GateStats {
        let stream = self.decoder.stats();
        GateStats {
            accepted: self.accepted,
            kills_outside_window: self.kills_outside_window,
            revive_repeats: self.revive_repeats,
            pre_revive_requests: self.pre_revive_requests,
            bad_tag: self.bad_tag.saturating_add(stream.bad_tag),
            replayed: self.replayed,
            stale_session: self.stale_session,
            malformed: self.malformed.saturating_add(stream.malformed),
            skipped_bytes: stream.skipped_bytes,
        }
    }

    /// Bytes held by the stream decoder while waiting for the rest of a frame.
    pub fn pending(&self) -> usize {
        self.decoder.pending()
    }

    /// Forgets a partial frame of the stream (e.g. after the port was reopened).
    pub fn reset_stream(&mut self) {
        self.decoder.reset();
    }

    /// Judges one complete frame.
    pub fn check(&mut self, frame: &[u8; COMMAND_FRAME_LEN]) -> Result<Command, Rejection> {
        match CommandFrame::decode(frame, &self.key) {
            Ok(frame) => self.admit(frame),
            Err(error) => {
                let rejection = Rejection::from(error);
                match rejection {
                    Rejection::BadTag => self.bad_tag = self.bad_tag.saturating_add(1),
                    _ => self.malformed = self.malformed.saturating_add(1),
                }
                Err(rejection)
            }
        }
    }

    /// Feeds one byte of the command stream; `Some` when it completed a frame or a rejected
    /// candidate. Wrong length bytes are only counted.
    pub fn push(&mut self, byte: u8) -> Option<Result<Command, Rejection>> {
        Some(match self.decoder.push(byte)? {
            Ok(frame) => self.admit(frame),
            Err(error) => Err(Rejection::from(error)),
        })
    }

    /// Feeds a chunk of the command stream, yielding what [`push`](Self::push) yields.
    pub fn feed<'a>(
        &'a mut self,
        bytes: &'a [u8],
    ) -> impl Iterator<Item = Result<Command, Rejection>> + 'a {
        bytes.iter().filter_map(move |&b| self.push(b))
    }

    /// Session and sequence rules for an authentic frame.
    fn admit(&mut self, frame: CommandFrame) -> Result<Command, Rejection> {
        let current = frame.session == self.session;
        let newer = frame.seq > self.last_seq;
        if current && newer {
            self.last_seq = frame.seq;
            self.accepted = self.accepted.saturating_add(1);
            if frame.command == Command::Revive {
                if frame.request <= self.last_revive_request {
                    self.revive_repeats = self.revive_repeats.saturating_add(1);
                    return Ok(Command::Heartbeat);
                }
                self.last_revive_request = frame.request;
            } else if frame.command.drives() && frame.request < self.last_revive_request {
                self.pre_revive_requests = self.pre_revive_requests.saturating_add(1);
                return Ok(Command::Heartbeat);
            }
            return Ok(frame.command);
        }
        if frame.command == Command::Kill {
            self.accepted = self.accepted.saturating_add(1);
            self.kills_outside_window = self.kills_outside_window.saturating_add(1);
            return Ok(Command::Kill);
        }
        if current {
            self.replayed = self.replayed.saturating_add(1);
            Err(Rejection::Replayed)
        } else {
            self.stale_session = self.stale_session.saturating_add(1);
            Err(Rejection::StaleSession)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Percent;

    const KEY: LinkKey = LinkKey::from_bytes([0x11; 16]);
    const SESSION: u32 = 0xC0FF_EE00;

    fn frame(command: Command, session: u32, seq: u32) -> [u8; COMMAND_FRAME_LEN] {
        CommandFrame::new(command, session, seq).encode(&KEY)
    }

    #[test]
    fn sequence_window() {
        let mut gate = CommandGate::new(KEY, SESSION);
        let throttle = Command::Throttle(Percent::new(80).unwrap());
        // Sequence number 0 is not newer than "none yet" (and leaves no room for a request).
        assert_eq!(
            gate.check(&CommandFrame::repeat(throttle, SESSION, 0, 1).encode(&KEY)),
            Err(Rejection::Malformed)
        );
        assert_eq!(
            gate.check(&frame(Command::Kill, SESSION, 0)),
            Ok(Command::Kill)
        );
        assert_eq!(gate.last_accepted(), 0);
        assert_eq!(gate.check(&frame(throttle, SESSION, 5)), Ok(throttle));
        assert_eq!(
            gate.check(&frame(throttle, SESSION, 4)),
            Err(Rejection::Replayed)
        );
        assert_eq!(
            gate.check(&frame(throttle, SESSION, 5)),
            Err(Rejection::Replayed)
        );
        assert_eq!(gate.check(&frame(throttle, SESSION, 6)), Ok(throttle));
        assert_eq!(
            gate.check(&frame(throttle, SESSION ^ 1, 7)),
            Err(Rejection::StaleSession)
        );
        assert_eq!(gate.last_accepted(), 6);
        let stats = gate.stats();
        assert_eq!(
            (
                stats.accepted,
                stats.replayed,
                stats.stale_session,
                stats.malformed,
                stats.kills_outside_window
            ),
            (3, 2, 1, 1, 1)
        );
    }

    #[test]
    fn kill_is_always_accepted_but_moves_the_window_only_in_session() {
        let mut gate = CommandGate::new(KEY, SESSION);
        assert_eq!(gate.check(&frame(Command::Kill, 0, 900)), Ok(Command::Kill));
        assert_eq!(gate.last_accepted(), 0);
        assert_eq!(
            gate.check(&frame(Command::Revive, SESSION, 1)),
            Ok(Command::Revive)
        );
        assert_eq!(
            gate.check(&frame(Command::Kill, SESSION, 1)),
            Ok(Command::Kill)
        );
        assert_eq!(gate.last_accepted(), 1);
        assert_eq!(
            gate.check(&frame(Command::Kill, SESSION, 3)),
            Ok(Command::Kill)
        );
        assert_eq!(gate.last_accepted(), 3);
        // The revive before the kill, replayed, does not revive.
        assert_eq!(
            gate.check(&frame(Command::Revive, SESSION, 1)),
            Err(Rejection::Replayed)
        );
        assert_eq!(gate.stats().kills_outside_window, 2);
    }

    #[test]
    fn a_revive_request_is_acted_on_once() {
        let mut gate = CommandGate::new(KEY, SESSION);
        let revive = |seq, request| CommandFrame::repeat(Command::Revive, SESSION, seq, request);
        assert_eq!(gate.check(&revive(4, 4).encode(&KEY)), Ok(Command::Revive));
        // Its repetitions: new sequence numbers, accepted (the acknowledgement moves), but
        // heartbeats; so is a repetition of a still older request.
        assert_eq!(
            gate.check(&revive(5, 4).encode(&KEY)),
            Ok(Command::Heartbeat)
        );
        assert_eq!(
            gate.check(&revive(9, 2).encode(&KEY)),
            Ok(Command::Heartbeat)
        );
        assert_eq!(gate.last_accepted(), 9);
        // A kill in between does not make an old request new.
        assert_eq!(
            gate.check(&frame(Command::Kill, SESSION, 10)),
            Ok(Command::Kill)
        );
        assert_eq!(
            gate.check(&revive(11, 4).encode(&KEY)),
            Ok(Command::Heartbeat)
        );
        // The operator's next request, first frame lost: its repetition is acted on.
        assert_eq!(
            gate.check(&revive(13, 12).encode(&KEY)),
            Ok(Command::Revive)
        );
        assert_eq!(
            gate.check(&revive(14, 12).encode(&KEY)),
            Ok(Command::Heartbeat)
        );
        let stats = gate.stats();
        assert_eq!((stats.accepted, stats.revive_repeats), (7, 4));
    }

    #[test]
    fn a_manual_command_or_setpoint_requested_before_the_last_revive_is_not_acted_on() {
        let mut gate = CommandGate::new(KEY, SESSION);
        let throttle = Command::Throttle(Percent::new(80).unwrap());
        let speed = Command::SpeedSetpoint { mm_s: 3_000 };
        let repeat = |command, seq, request| {
            CommandFrame::repeat(command, SESSION, seq, request).encode(&KEY)
        };
        // The operator asks for 80 % throttle while the robot is KILLED (request 8), then
        // revives (request 10, acted on).
        assert_eq!(gate.check(&repeat(throttle, 8, 8)), Ok(throttle));
        assert_eq!(gate.check(&repeat(Command::Kill, 9, 9)), Ok(Command::Kill));
        assert_eq!(
            gate.check(&repeat(Command::Revive, 10, 10)),
            Ok(Command::Revive)
        );
        // The station still repeats the throttle request: accepted as a frame (the
        // acknowledgement moves) but taken as a heartbeat; so is an older setpoint.
        assert_eq!(gate.check(&repeat(throttle, 12, 8)), Ok(Command::Heartbeat));
        assert_eq!(gate.last_accepted(), 12);
        assert_eq!(gate.check(&repeat(speed, 13, 2)), Ok(Command::Heartbeat));
        // A kill and a heartbeat of an old request are what they are.
        assert_eq!(
            gate.check(&repeat(Command::Heartbeat, 14, 3)),
            Ok(Command::Heartbeat)
        );
        assert_eq!(gate.check(&repeat(Command::Kill, 15, 5)), Ok(Command::Kill));
        // Requests made after the revive are acted on, first frame or repetition.
        assert_eq!(gate.check(&repeat(throttle, 16, 11)), Ok(throttle));
        assert_eq!(gate.check(&repeat(speed, 17, 17)), Ok(speed));
        let stats = gate.stats();
        assert_eq!(
            (
                stats.accepted,
                stats.pre_revive_requests,
                stats.revive_repeats
            ),
            (9, 2, 0)
        );
        assert_eq!(stats.rejected(), 0);
    }

    #[test]
    fn forged_kill_is_refused() {
        let mut gate = CommandGate::new(KEY, SESSION);
        let forged =
            CommandFrame::new(Command::Kill, SESSION, 1).encode(&LinkKey::from_bytes([0x12; 16]));
        assert_eq!(gate.check(&forged), Err(Rejection::BadTag));
        assert_eq!(gate.stats().bad_tag, 1);
        assert_eq!(gate.stats().accepted, 0);
    }
}
