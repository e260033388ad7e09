//! Command frames v1: 10 bytes, ground station -> robot.
//!
//! | offset | content |
//! |---|---|
//! | 0 | `$` (0x24) |
//! | 1 | type |
//! | 2-5 | data, i32 big-endian |
//! | 6-9 | CRC-32/ISO-HDLC over bytes 1-5, u32 big-endian |

use core::fmt;

use crate::checksum::crc32;

/// Length of a command frame on the wire, in bytes.
pub const COMMAND_FRAME_LEN: usize = 10;
/// Start token of a command frame (`$`).
pub const COMMAND_START: u8 = b'$';
/// Largest speed setpoint magnitude accepted, in mm/s (100 m/s: anything above is a corrupt or
/// malicious frame, not a command for a small car).
pub const MAX_SPEED_MM_S: i32 = 100_000;
/// Heading setpoints are in `0..HEADING_FULL_TURN_DEG_E5` (1e-5 degrees; 360 degrees excluded).
pub const HEADING_FULL_TURN_DEG_E5: i32 = 36_000_000;

/// A percentage `0..=100` of a channel's configured pulse range (manual mode).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Percent(u8);

impl Percent {
    /// The low end of the range.
    pub const MIN: Percent = Percent(0);
    /// The middle of the range.
    pub const HALF: Percent = Percent(50);
    /// The high end of the range.
    pub const MAX: Percent = Percent(100);

    /// `Some` when `value` is within `0..=100`.
    pub const fn new(value: u8) -> Option<Percent> {
        if value <= 100 {
            Some(Percent(value))
        } else {
            None
        }
    }

    /// The value, `0..=100`.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// The type byte (offset 1) of a command frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum CommandType {
    /// Keeps the link alive; data 0.
    Heartbeat = 0,
    /// Outputs to their safe values at once; data ignored (a kill is never refused).
    Kill = 1,
    /// Leave KILLED or FAILSAFE; data 0.
    Revive = 2,
    /// Manual throttle, percent.
    Throttle = 3,
    /// Manual steering, percent.
    Steering = 4,
    /// Manual tail, percent.
    Tail = 5,
    /// Control-mode ground speed setpoint, mm/s.
    SpeedSetpoint = 6,
    /// Control-mode heading setpoint, 1e-5 degrees.
    HeadingSetpoint = 7,
}

impl CommandType {
    /// The type for a wire byte, `None` for types version 1 does not define.
    pub const fn from_byte(byte: u8) -> Option<CommandType> {
        Some(match byte {
            0 => CommandType::Heartbeat,
            1 => CommandType::Kill,
            2 => CommandType::Revive,
            3 => CommandType::Throttle,
            4 => CommandType::Steering,
            5 => CommandType::Tail,
            6 => CommandType::SpeedSetpoint,
            7 => CommandType::HeadingSetpoint,
            _ => return None,
        })
    }
}

/// One decoded, validated command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// Link activity, nothing else.
    Heartbeat,
    /// Safe outputs now; the robot stays KILLED until a revive.
    Kill,
    /// Leave KILLED or FAILSAFE.
    Revive,
    /// Manual throttle.
    Throttle(Percent),
    /// Manual steering.
    Steering(Percent),
    /// Manual tail.
    Tail(Percent),
    /// Ground speed setpoint for the controller, mm/s (negative is reverse).
    SpeedSetpoint {
        /// Millimetres per second, `-MAX_SPEED_MM_S..=MAX_SPEED_MM_S`.
        mm_s: i32,
    },
    /// Heading setpoint for the controller.
    HeadingSetpoint {
        /// 1e-5 degrees clockwise from north, `0..HEADING_FULL_TURN_DEG_E5`.
        deg_e5: i32,
    },
}

impl Command {
    /// Whether the command drives the robot: a manual value (throttle, steering, tail) or a
    /// controller setpoint (speed, heading), the values an operator gives.
    pub fn drives(self) -> bool {
        matches!(
            self,
            Command::Throttle(_)
                | Command::Steering(_)
                | Command::Tail(_)
                | Command::SpeedSetpoint { .. }
                | Command::HeadingSetpoint { .. }
        )
    }

    /// The type byte of this command.
    pub const fn command_type(self) -> CommandType {
        match self {
            Command::Heartbeat => CommandType::Heartbeat,
            Command::Kill => CommandType::Kill,
            Command::Revive => CommandType::Revive,
            Command::Throttle(_) => CommandType::Throttle,
            Command::Steering(_) => CommandType::Steering,
            Command::Tail(_) => CommandType::Tail,
            Command::SpeedSetpoint { .. } => CommandType::SpeedSetpoint,
            Command::HeadingSetpoint { .. } => CommandType::HeadingSetpoint,
        }
    }

    /// The data field (offsets 2-5) of this command.
    pub const fn data(self) -> i32 {
        match self {
            Command::Heartbeat | Command::Kill | Command::Revive => 0,
            Command::Throttle(p) | Command::Steering(p) | Command::Tail(p) => p.get() as i32,
            Command::SpeedSetpoint { mm_s } => mm_s,
            Command::HeadingSetpoint { deg_e5 } => deg_e5,
        }
    }

    /// Validates `data` for a frame of type `kind`.
    pub fn from_parts(kind: CommandType, data: i32) -> Result<Command, CommandError> {
        let out_of_range = CommandError::OutOfRange { kind, data };
        let percent = || {
            u8::try_from(data)
                .ok()
                .and_then(Percent::new)
                .ok_or(out_of_range)
        };
        Ok(match kind {
            CommandType::Heartbeat if data == 0 => Command::Heartbeat,
            CommandType::Revive if data == 0 => Command::Revive,
            CommandType::Heartbeat | CommandType::Revive => return Err(out_of_range),
            CommandType::Kill => Command::Kill,
            CommandType::Throttle => Command::Throttle(percent()?),
            CommandType::Steering => Command::Steering(percent()?),
            CommandType::Tail => Command::Tail(percent()?),
            CommandType::SpeedSetpoint if (-MAX_SPEED_MM_S..=MAX_SPEED_MM_S).contains(&data) => {
                Command::SpeedSetpoint { mm_s: data }
            }
            CommandType::HeadingSetpoint if (0..HEADING_FULL_TURN_DEG_E5).contains(&data) => {
                Command::HeadingSetpoint { deg_e5: data }
            }
            CommandType::SpeedSetpoint | CommandType::HeadingSetpoint => return Err(out_of_range),
        })
    }

    /// The 10-byte frame for this command.
    pub fn encode(self) -> [u8; COMMAND_FRAME_LEN] {
        let mut frame = [0u8; COMMAND_FRAME_LEN];
        frame[0] = COMMAND_START;
        frame[1] = self.command_type() as u8;
        frame[2..6].copy_from_slice(&self.data().to_be_bytes());
        let crc = crc32(&frame[1..6]);
        frame[6..10].copy_from_slice(&crc.to_be_bytes());
        frame
    }

    /// Decodes one complete frame: start token, CRC, type and data range are all checked.
    pub fn decode(frame: &[u8; COMMAND_FRAME_LEN]) -> Result<Command, CommandError> {
        if frame[0] != COMMAND_START {
            return Err(CommandError::BadStart { found: frame[0] });
        }
        let computed = crc32(&frame[1..6]);
        let received = u32::from_be_bytes([frame[6], frame[7], frame[8], frame[9]]);
        if computed != received {
            return Err(CommandError::Crc { computed, received });
        }
        let kind = CommandType::from_byte(frame[1])
            .ok_or(CommandError::UnknownType { found: frame[1] })?;
        let data = i32::from_be_bytes([frame[2], frame[3], frame[4], frame[5]]);
        Command::from_parts(kind, data)
    }
}

/// Why a command frame was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandError {
    /// Byte 0 was not `$`.
    BadStart {
        /// The byte found instead.
        found: u8,
    },
    /// The CRC over bytes 1-5 did not match bytes 6-9.
    Crc {
        /// CRC computed over the received bytes 1-5.
        computed: u32,
        /// CRC carried by the frame.
        received: u32,
    },
    /// A CRC-valid frame of a type version 1 does not define (never taken as a heartbeat).
    UnknownType {
        /// The type byte.
        found: u8,
    },
    /// A CRC-valid frame whose data is outside the range of its type.
    OutOfRange {
        /// The frame's type.
        kind: CommandType,
        /// The rejected data.
        data: i32,
    },
}

impl fmt::Display for CommandError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CommandError::BadStart { found } => {
                write!(f, "command frame starts with {found:#04x}, not '$'")
            }
            CommandError::Crc { computed, received } => write!(
                f,
                "command frame CRC mismatch: computed {computed:#010x}, received {received:#010x}"
            ),
            CommandError::UnknownType { found } => write!(f, "unknown command type {found}"),
            CommandError::OutOfRange { kind, data } => {
                write!(f, "command {kind:?} with out-of-range data {data}")
            }
        }
    }
}

impl core::error::Error for CommandError {}

/// What a [`CommandDecoder`] has seen since it was created.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CommandStats {
    /// Valid commands delivered.
    pub frames: u32,
    /// Candidate frames (a `$` and nine more bytes) whose CRC did not match.
    pub crc_errors: u32,
    /// CRC-valid frames of an unknown type.
    pub unknown_type: u32,
    /// CRC-valid frames with out-of-range data.
    pub out_of_range: u32,
    /// Bytes discarded while looking for a frame.
    pub skipped_bytes: u32,
}

impl CommandStats {
    /// Every rejected frame, whatever the reason.
    pub fn rejected(&self) -> u32 {
        self.crc_errors
            .saturating_add(self.unknown_type)
            .saturating_add(self.out_of_range)
    }
}

/// Finds command frames in a byte stream: by `$` and CRC, whatever the read boundaries are.
///
/// Total: any byte sequence is accepted; a lost or inserted byte costs at most the frame it
/// touched, and the decoder is back in step at the next intact frame.
#[derive(Debug, Clone, Default)]
pub struct CommandDecoder {
    window: [u8; COMMAND_FRAME_LEN],
    len: usize,
    stats: CommandStats,
}

impl CommandDecoder {
    /// An empty decoder.
    pub const fn new() -> CommandDecoder {
        CommandDecoder {
            window: [0; COMMAND_FRAME_LEN],
            len: 0,
            stats: CommandStats {
                frames: 0,
                crc_errors: 0,
                unknown_type: 0,
                out_of_range: 0,
                skipped_bytes: 0,
            },
        }
    }

    /// Counters since creation.
    pub fn stats(&self) -> CommandStats {
        self.stats
    }

    /// Bytes held while waiting for the rest of a frame.
    pub fn pending(&self) -> usize {
        self.len
    }

    /// Forgets a partial frame (e.g. after the port was reopened).
    pub fn reset(&mut self) {
        self.stats.skipped_bytes = self.stats.skipped_bytes.saturating_add(self.len as u32);
        self.len = 0;
    }

    /// Feeds one byte. Returns `Some(Ok(_))` for a valid command, `Some(Err(_))` for a
    /// CRC-valid frame that was rejected (unknown type, out-of-range data); CRC mismatches are
    /// resynchronisation noise and only counted.
    pub fn push(&mut self, byte: u8) -> Option<Result<Command, CommandError>> {
        if self.len == 0 && byte != COMMAND_START {
            self.stats.skipped_bytes = self.stats.skipped_bytes.saturating_add(1);
            return None;
        }
        self.window[self.len] = byte;
        self.len += 1;
        if self.len < COMMAND_FRAME_LEN {
            return None;
        }
        match Command::decode(&self.window) {
            Ok(command) => {
                self.len = 0;
                self.stats.frames = self.stats.frames.saturating_add(1);
                Some(Ok(command))
            }
            Err(error @ CommandError::UnknownType { .. }) => {
                self.len = 0;
                self.stats.unknown_type = self.stats.unknown_type.saturating_add(1);
                Some(Err(error))
            }
            Err(error @ CommandError::OutOfRange { .. }) => {
                self.len = 0;
                self.stats.out_of_range = self.stats.out_of_range.saturating_add(1);
                Some(Err(error))
            }
            Err(CommandError::Crc { .. } | CommandError::BadStart { .. }) => {
                self.stats.crc_errors = self.stats.crc_errors.saturating_add(1);
                self.resync();
                None
            }
        }
    }

    /// Feeds a chunk of bytes, yielding what [`push`](Self::push) yields for each of them.
    pub fn feed<'a>(
        &'a mut self,
        bytes: &'a [u8],
    ) -> impl Iterator<Item = Result<Command, CommandError>> + 'a {
        bytes.iter().filter_map(move |&b| self.push(b))
    }

    /// Drops the first byte of a rejected window and restarts at the next `$` in it.
    fn resync(&mut self) {
        let next = self.window[1..self.len]
            .iter()
            .position(|&b| b == COMMAND_START)
            .map_or(self.len, |i| i + 1);
        self.window.copy_within(next..self.len, 0);
        self.len -= next;
        self.stats.skipped_bytes = self.stats.skipped_bytes.saturating_add(next as u32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_bounds() {
        assert_eq!(Percent::new(100), Some(Percent::MAX));
        assert_eq!(Percent::new(101), None);
    }

    #[test]
    fn type_bytes_are_pinned() {
        for byte in 0..=255u8 {
            match CommandType::from_byte(byte) {
                Some(kind) => assert_eq!(kind as u8, byte),
                None => assert!(byte > 7),
            }
        }
    }

    #[test]
    fn range_checks() {
        use CommandType::*;
        assert!(Command::from_parts(Throttle, 101).is_err());
        assert!(Command::from_parts(Throttle, -1).is_err());
        assert_eq!(
            Command::from_parts(Steering, 100),
            Ok(Command::Steering(Percent::MAX))
        );
        assert!(Command::from_parts(HeadingSetpoint, 36_000_000).is_err());
        assert!(Command::from_parts(HeadingSetpoint, -1).is_err());
        assert!(Command::from_parts(SpeedSetpoint, MAX_SPEED_MM_S + 1).is_err());
        assert!(Command::from_parts(Heartbeat, 1).is_err());
        assert_eq!(Command::from_parts(Kill, 7), Ok(Command::Kill));
    }

    #[test]
    fn crc_error_resynchronises_on_a_later_start_token() {
        let mut decoder = CommandDecoder::new();
        let mut bad = Command::Revive.encode();
        bad[9] ^= 1;
        bad[4] = b'$';
        assert_eq!(decoder.feed(&bad).count(), 0);
        let good = Command::Kill.encode();
        let mut delivered = 0;
        for result in decoder.feed(&good) {
            assert_eq!(result, Ok(Command::Kill));
            delivered += 1;
        }
        assert_eq!(delivered, 1);
        assert_eq!(decoder.stats().frames, 1);
        assert!(decoder.stats().crc_errors >= 1);
    }
}
