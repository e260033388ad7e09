//! Command frames v2: 28 bytes, ground station -> robot.
//!
//! | offset | content |
//! |---|---|
//! | 0-1 | start token `A5 32` |
//! | 2 | length, 28 |
//! | 3 | command type (version 1 types) |
//! | 4-7 | data, i32 big-endian (version 1 ranges: 0 for a heartbeat and a revive) |
//! | 8-11 | session id, u32 big-endian (0: the station does not know it yet) |
//! | 12-15 | sequence number, u32 big-endian (starts at 1, increases by one per frame) |
//! | 16-19 | operator request, u32 big-endian: the sequence number of the request's first frame, 1 to the frame's own (a kill: any value, ignored) |
//! | 20-27 | SipHash-2-4 tag over bytes 0-19 |
//!
//! A station repeats a command until the robot acknowledges it, each time with a new sequence
//! number. Every frame says which operator request it belongs to, so the robot can tell a
//! repetition of an old request from a new one ([`CommandGate`](super::CommandGate)): it acts
//! on each revive request once, so a repetition that arrives after the robot failed safe again
//! (the radio faded, a sensor was lost) cannot lift that failsafe; and it does not act on a
//! manual command or setpoint requested before the last revive it acted on, so a value the
//! operator gave while the robot was stopped cannot move it after the revive.
//!
//! A kill's request is never checked: an authentic kill is never refused.

use super::decoder::{AuthenticFrame, FrameDecoder, StreamStats};
use super::{be_u32, check_envelope, seal, FrameError, LinkKey};
use crate::command::{Command, CommandType};

/// Length of a command frame v2 on the wire, in bytes.
pub const COMMAND_FRAME_LEN: usize = 28;
/// Start token of a command frame v2.
pub const COMMAND_START: [u8; 2] = [0xA5, 0x32];

/// One authenticated command: what the ground station sends, with its session and sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CommandFrame {
    /// The command (version 1 types and ranges).
    pub command: Command,
    /// The robot's session id as the station knows it, 0 when it does not know it yet.
    pub session: u32,
    /// Sequence number, increasing by one per frame sent (the robot accepts each number once).
    pub seq: u32,
    /// The operator request the frame belongs to: the sequence number of the request's first
    /// frame (repetitions carry the same), 1 to `seq`. Any value in a kill.
    pub request: u32,
}

impl CommandFrame {
    /// The first frame of a request (`request` = `seq`).
    pub const fn new(command: Command, session: u32, seq: u32) -> CommandFrame {
        CommandFrame {
            command,
            session,
            seq,
            request: seq,
        }
    }

    /// A repetition of the request whose first frame had sequence number `request`, under the
    /// new sequence number `seq`.
    pub const fn repeat(command: Command, session: u32, seq: u32, request: u32) -> CommandFrame {
        CommandFrame {
            command,
            session,
            seq,
            request,
        }
    }

    /// The 28-byte frame, tagged with `key`.
    pub fn encode(&self, key: &LinkKey) -> [u8; COMMAND_FRAME_LEN] {
        let mut frame = [0u8; COMMAND_FRAME_LEN];
        frame[3] = self.command.command_type() as u8;
        frame[4..8].copy_from_slice(&self.command.data().to_be_bytes());
        frame[8..12].copy_from_slice(&self.session.to_be_bytes());
        frame[12..16].copy_from_slice(&self.seq.to_be_bytes());
        frame[16..20].copy_from_slice(&self.request.to_be_bytes());
        seal(&mut frame, COMMAND_START, key);
        frame
    }

    /// Decodes one complete frame: start token, length, tag, then type, data range, and the
    /// request (1 to the sequence number, except in a kill).
    pub fn decode(
        frame: &[u8; COMMAND_FRAME_LEN],
        key: &LinkKey,
    ) -> Result<CommandFrame, FrameError> {
        check_envelope(frame, COMMAND_START, key)?;
        let kind = CommandType::from_byte(frame[3]).ok_or(FrameError::Command(
            crate::CommandError::UnknownType { found: frame[3] },
        ))?;
        let data = i32::from_be_bytes([frame[4], frame[5], frame[6], frame[7]]);
        let command = Command::from_parts(kind, data).map_err(FrameError::Command)?;
        let seq = be_u32(frame, 12);
        let request = be_u32(frame, 16);
        if command != Command::Kill && !(1..=seq).contains(&request) {
            return Err(FrameError::BadRequest { request, seq });
        }
        Ok(CommandFrame {
            command,
            session: be_u32(frame, 8),
            seq,
            request,
        })
    }
}

/// What a [`CommandDecoder`] has seen since it was created.
pub type CommandStats = StreamStats;

/// Finds authentic command frames v2 in a byte stream, whatever the read boundaries are
/// (see [`FrameDecoder`] for how it resynchronises and what it counts).
pub type CommandDecoder = FrameDecoder<CommandFrame, COMMAND_FRAME_LEN>;

impl AuthenticFrame<COMMAND_FRAME_LEN> for CommandFrame {
    const START: [u8; 2] = COMMAND_START;

    fn decode_frame(
        frame: &[u8; COMMAND_FRAME_LEN],
        key: &LinkKey,
    ) -> Result<CommandFrame, FrameError> {
        CommandFrame::decode(frame, key)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Percent;

    const KEY: LinkKey =
        LinkKey::from_bytes([0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15]);

    #[test]
    fn layout_offsets() {
        let frame = CommandFrame::repeat(
            Command::Steering(Percent::new(42).unwrap()),
            0x0102_0304,
            0xA0B0_C0D0,
            0x0A0B_0C0D,
        );
        let bytes = frame.encode(&KEY);
        assert_eq!(&bytes[..4], &[0xA5, 0x32, 28, 4]);
        assert_eq!(&bytes[4..8], &[0, 0, 0, 42]);
        assert_eq!(&bytes[8..12], &[1, 2, 3, 4]);
        assert_eq!(&bytes[12..16], &[0xA0, 0xB0, 0xC0, 0xD0]);
        assert_eq!(&bytes[16..20], &[0x0A, 0x0B, 0x0C, 0x0D]);
        assert_eq!(&bytes[20..], &KEY.tag(&bytes[..20]));
        assert_eq!(CommandFrame::decode(&bytes, &KEY), Ok(frame));
    }

    #[test]
    fn every_command_carries_its_request() {
        let revive = CommandFrame::repeat(Command::Revive, 7, 0x0102_0310, 0x0102_0304);
        let bytes = revive.encode(&KEY);
        assert_eq!(&bytes[3..8], &[2, 0, 0, 0, 0]);
        assert_eq!(&bytes[16..20], &[1, 2, 3, 4]);
        assert_eq!(CommandFrame::decode(&bytes, &KEY), Ok(revive));
        let tail = CommandFrame::repeat(Command::Tail(Percent::new(9).unwrap()), 7, 20, 3);
        let bytes = tail.encode(&KEY);
        assert_eq!(&bytes[4..8], &[0, 0, 0, 9]);
        assert_eq!(&bytes[16..20], &[0, 0, 0, 3]);
        assert_eq!(CommandFrame::decode(&bytes, &KEY), Ok(tail));
    }

    #[test]
    fn a_request_of_0_or_from_the_future_is_malformed_except_in_a_kill() {
        let throttle = Command::Throttle(Percent::new(80).unwrap());
        for command in [Command::Revive, throttle, Command::Heartbeat] {
            for (seq, request) in [(5, 0), (5, 6), (0, 1), (0, 0), (7, u32::MAX)] {
                let bytes = CommandFrame::repeat(command, 7, seq, request).encode(&KEY);
                assert_eq!(
                    CommandFrame::decode(&bytes, &KEY),
                    Err(FrameError::BadRequest { request, seq }),
                    "{command:?}, seq {seq}, request {request}"
                );
            }
        }
        // An authentic kill is never refused, whatever its request says.
        for (seq, request) in [(5, 0), (5, 6), (0, 0), (0, u32::MAX)] {
            let kill = CommandFrame::repeat(Command::Kill, 7, seq, request);
            assert_eq!(CommandFrame::decode(&kill.encode(&KEY), &KEY), Ok(kill));
        }
    }

    #[test]
    fn a_revive_with_data_is_malformed() {
        let mut bytes = [0u8; COMMAND_FRAME_LEN];
        bytes[3] = CommandType::Revive as u8;
        bytes[7] = 3;
        bytes[15] = 3;
        bytes[19] = 3;
        seal(&mut bytes, COMMAND_START, &KEY);
        assert!(matches!(
            CommandFrame::decode(&bytes, &KEY),
            Err(FrameError::Command(crate::CommandError::OutOfRange { .. }))
        ));
    }

    #[test]
    fn every_single_bit_flip_is_rejected() {
        let bytes = CommandFrame::new(Command::Revive, 9, 3).encode(&KEY);
        for bit in 0..COMMAND_FRAME_LEN * 8 {
            let mut flipped = bytes;
            flipped[bit / 8] ^= 1 << (bit % 8);
            assert!(CommandFrame::decode(&flipped, &KEY).is_err(), "bit {bit}");
        }
    }

    #[test]
    fn authentic_unknown_type_is_malformed_not_a_heartbeat() {
        let mut bytes = [0u8; COMMAND_FRAME_LEN];
        bytes[3] = 9;
        seal(&mut bytes, COMMAND_START, &KEY);
        let mut decoder = CommandDecoder::new(KEY);
        let got: heapless_vec::Results = decoder.feed(&bytes).collect();
        assert_eq!(got.0, 1);
        assert_eq!(decoder.stats().malformed, 1);
        assert_eq!(decoder.stats().skipped_bytes, 28);
    }

    /// Counts results without allocating (`no_std` unit tests).
    mod heapless_vec {
        use super::*;
        pub struct Results(pub usize);
        impl FromIterator<Result<CommandFrame, FrameError>> for Results {
            fn from_iter<I: IntoIterator<Item = Result<CommandFrame, FrameError>>>(i: I) -> Self {
                Results(i.into_iter().filter(|r| r.is_err()).count())
            }
        }
    }
}
