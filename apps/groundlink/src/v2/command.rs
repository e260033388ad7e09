//! Command frames v2: 24 bytes, ground station -> robot.
//!
//! | offset | content |
//! |---|---|
//! | 0-1 | start token `A5 32` |
//! | 2 | length, 24 |
//! | 3 | command type (version 1 types) |
//! | 4-7 | data, i32 big-endian (version 1 ranges); a revive: its request, u32 big-endian |
//! | 8-11 | session id, u32 big-endian (0: the station does not know it yet) |
//! | 12-15 | sequence number, u32 big-endian (starts at 1, increases by one per frame) |
//! | 16-23 | SipHash-2-4 tag over bytes 0-15 |
//!
//! A station repeats a command until the robot acknowledges it, each time with a new sequence
//! number. A revive says which operator request it belongs to: the sequence number of the
//! request's first frame (1 to the frame's own number). The robot acts on each request once
//! ([`CommandGate`](super::CommandGate)), so a repetition that arrives after the robot failed
//! safe again (the radio faded, a sensor was lost) cannot lift that failsafe; only a new
//! request from the operator can.

use super::decoder::{AuthenticFrame, FrameDecoder, StreamStats};
use super::{be_u32, check_envelope, seal, FrameError, LinkKey};
use crate::command::{Command, CommandType};

/// Length of a command frame v2 on the wire, in bytes.
pub const COMMAND_FRAME_LEN: usize = 24;
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
    /// frame (repetitions carry the same). On the wire only for a revive (its data field);
    /// decoded as `seq` for every other command.
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

    /// The 24-byte frame, tagged with `key`.
    pub fn encode(&self, key: &LinkKey) -> [u8; COMMAND_FRAME_LEN] {
        let mut frame = [0u8; COMMAND_FRAME_LEN];
        frame[3] = self.command.command_type() as u8;
        let data = match self.command {
            Command::Revive => self.request.to_be_bytes(),
            command => command.data().to_be_bytes(),
        };
        frame[4..8].copy_from_slice(&data);
        frame[8..12].copy_from_slice(&self.session.to_be_bytes());
        frame[12..16].copy_from_slice(&self.seq.to_be_bytes());
        seal(&mut frame, COMMAND_START, key);
        frame
    }

    /// Decodes one complete frame: start token, length, tag, then type and data range (a
    /// revive's request from 1 to its sequence number).
    pub fn decode(
        frame: &[u8; COMMAND_FRAME_LEN],
        key: &LinkKey,
    ) -> Result<CommandFrame, FrameError> {
        check_envelope(frame, COMMAND_START, key)?;
        let kind = CommandType::from_byte(frame[3]).ok_or(FrameError::Command(
            crate::CommandError::UnknownType { found: frame[3] },
        ))?;
        let data = i32::from_be_bytes([frame[4], frame[5], frame[6], frame[7]]);
        let seq = be_u32(frame, 12);
        let (command, request) = if kind == CommandType::Revive {
            let request = be_u32(frame, 4);
            if request == 0 || request > seq {
                return Err(FrameError::Command(crate::CommandError::OutOfRange {
                    kind,
                    data,
                }));
            }
            (Command::Revive, request)
        } else {
            let command = Command::from_parts(kind, data).map_err(FrameError::Command)?;
            (command, seq)
        };
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
        let frame = CommandFrame::new(
            Command::Steering(Percent::new(42).unwrap()),
            0x0102_0304,
            0xA0B0_C0D0,
        );
        let bytes = frame.encode(&KEY);
        assert_eq!(&bytes[..4], &[0xA5, 0x32, 24, 4]);
        assert_eq!(&bytes[4..8], &[0, 0, 0, 42]);
        assert_eq!(&bytes[8..12], &[1, 2, 3, 4]);
        assert_eq!(&bytes[12..16], &[0xA0, 0xB0, 0xC0, 0xD0]);
        assert_eq!(&bytes[16..], &KEY.tag(&bytes[..16]));
        assert_eq!(CommandFrame::decode(&bytes, &KEY), Ok(frame));
    }

    #[test]
    fn a_revive_carries_its_request_and_other_commands_do_not() {
        let revive = CommandFrame::repeat(Command::Revive, 7, 0x0102_0310, 0x0102_0304);
        let bytes = revive.encode(&KEY);
        assert_eq!(&bytes[3..8], &[2, 1, 2, 3, 4]);
        assert_eq!(CommandFrame::decode(&bytes, &KEY), Ok(revive));
        // Not on the wire for other commands: decoded as the frame's own number.
        let tail = CommandFrame::repeat(Command::Tail(Percent::new(9).unwrap()), 7, 20, 3);
        let decoded = CommandFrame::decode(&tail.encode(&KEY), &KEY).unwrap();
        assert_eq!(&tail.encode(&KEY)[4..8], &[0, 0, 0, 9]);
        assert_eq!(decoded, CommandFrame::new(tail.command, 7, 20));
        // A request of 0 or from the future is malformed, even with a valid tag.
        for (seq, request) in [(5, 0), (5, 6), (0, 1)] {
            let bytes = CommandFrame::repeat(Command::Revive, 7, seq, request).encode(&KEY);
            assert!(
                matches!(
                    CommandFrame::decode(&bytes, &KEY),
                    Err(FrameError::Command(crate::CommandError::OutOfRange { .. }))
                ),
                "seq {seq}, request {request}"
            );
        }
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
        assert_eq!(decoder.stats().skipped_bytes, 24);
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
