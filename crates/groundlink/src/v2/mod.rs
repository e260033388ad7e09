//! Ground link version 2: authenticated frames with a per-boot session id and sequence numbers.
//!
//! Version 1 frames carry no authentication and no sequence: any radio on the PAN can revive
//! and drive the robot, and a lost command is never known to be lost. Version 2 fixes both:
//!
//! - [`CommandFrame`] (ground station -> robot, 28 bytes): start token `A5 32`, length, type and
//!   data as in version 1, the robot's session id, a sequence number, the operator request the
//!   frame belongs to (the sequence number of the request's first frame), and a 64-bit
//!   SipHash-2-4 tag under a pre-shared 128-bit [`LinkKey`] over every byte before it.
//! - [`DisplayFrame`] (robot -> ground station, 126 bytes): start token `A5 44`, the robot's
//!   mode, failsafe cause and last revive refusal, session id, downlink sequence number, the
//!   sequence number of the last accepted command (the acknowledgement), [`Health`] counters,
//!   the version 1 display payload (sensor values and GNSS), and the tag.
//! - [`DisplayFrameV3`] (robot -> ground station, 156 bytes): start token `A5 46`, the fields
//!   of a display frame v2, then what the robot does ([`Actuation`]): the servo targets it
//!   commanded, the AUTO setpoints in force or none, its speed and heading estimates, the speed
//!   error and the configured controller kinds. [`DownlinkDecoder`] finds both versions in one
//!   stream.
//! - [`CommandGate`]: the robot's side of the command link. It holds the key, the session id and
//!   the last accepted sequence number, and accepts a command only when its tag is valid, its
//!   session is current and its sequence number is newer than the last accepted one. A kill
//!   with a valid tag is always accepted. It acts on a revive request once, and not on a manual
//!   command or setpoint requested before the last revive it acted on.
//! - [`CommandDecoder`] and [`DisplayDecoder`]: resynchronising stream decoders that verify the
//!   tag before they trust a frame, so a forged or corrupt frame never hides a good one that
//!   follows it.
//!
//! The start tokens' first byte `0xA5` is neither `$` (the version 1 command start) nor a byte
//! a version 1 decoder looks for, so both versions can share one byte stream.
//!
//! ```
//! use dima_groundlink::v2::{CommandFrame, CommandGate, LinkKey, Rejection};
//! use dima_groundlink::{Command, Percent};
//!
//! let key = LinkKey::parse_hex("000102030405060708090a0b0c0d0e0f").unwrap();
//! let session = 0x1234_5678;
//! let mut robot = CommandGate::new(key.clone(), session);
//!
//! let throttle = Command::Throttle(Percent::new(60).unwrap());
//! let frame = CommandFrame::new(throttle, session, 1).encode(&key);
//! assert_eq!(robot.check(&frame), Ok(throttle));
//! assert_eq!(robot.last_accepted(), 1);
//!
//! // The same bytes again are a replay; a frame under another key is a forgery.
//! assert_eq!(robot.check(&frame), Err(Rejection::Replayed));
//! let forged = CommandFrame::new(throttle, session, 2)
//!     .encode(&LinkKey::from_bytes([7; 16]));
//! assert_eq!(robot.check(&forged), Err(Rejection::BadTag));
//!
//! // A kill with a valid tag stops the robot even from a station that does not know the
//! // session yet (session 0).
//! let kill = CommandFrame::new(Command::Kill, 0, 1).encode(&key);
//! assert_eq!(robot.check(&kill), Ok(Command::Kill));
//! assert_eq!(robot.stats().bad_tag, 1);
//! ```

use core::fmt;
use core::hash::Hasher;

use siphasher::sip::SipHasher24;

use crate::command::CommandError;
use crate::display::DisplayError;

mod command;
mod decoder;
mod display;
mod display_v3;
mod gate;
mod scanner;

pub use command::{CommandDecoder, CommandFrame, CommandStats, COMMAND_FRAME_LEN, COMMAND_START};
pub use decoder::{AuthenticFrame, FrameDecoder, StreamStats};
pub use display::{
    DisplayDecoder, DisplayFrame, DisplayStats, FailsafeCause, Health, ReviveRefusal, RobotMode,
    DISPLAY_FRAME_LEN, DISPLAY_START,
};
pub use display_v3::{
    Actuation, ControllerCode, DisplayFrameV3, DisplayV3Decoder, Downlink, DownlinkDecoder,
    DISPLAY_V3_FRAME_LEN, DISPLAY_V3_START,
};
pub use gate::{CommandGate, GateStats, Rejection};

/// Length of the authentication tag at the end of every version 2 frame, in bytes.
pub const TAG_LEN: usize = 8;

/// The pre-shared 128-bit key of the link (SipHash-2-4 key).
///
/// `Debug` never prints the key.
#[derive(Clone, PartialEq, Eq)]
pub struct LinkKey([u8; LinkKey::LEN]);

impl LinkKey {
    /// Key length in bytes.
    pub const LEN: usize = 16;
    /// Length of the key written as hexadecimal text (the key file format).
    pub const HEX_LEN: usize = 2 * LinkKey::LEN;

    /// A key from its 16 bytes.
    pub const fn from_bytes(bytes: [u8; LinkKey::LEN]) -> LinkKey {
        LinkKey(bytes)
    }

    /// The key's bytes.
    pub const fn as_bytes(&self) -> &[u8; LinkKey::LEN] {
        &self.0
    }

    /// Parses 32 hexadecimal characters (either case); surrounding whitespace is ignored.
    pub fn parse_hex(text: &str) -> Result<LinkKey, KeyParseError> {
        let text = text.trim().as_bytes();
        if text.len() != LinkKey::HEX_LEN {
            return Err(KeyParseError::Length { found: text.len() });
        }
        let nibble = |at: usize| -> Result<u8, KeyParseError> {
            let c = text[at];
            match c {
                b'0'..=b'9' => Ok(c - b'0'),
                b'a'..=b'f' => Ok(c - b'a' + 10),
                b'A'..=b'F' => Ok(c - b'A' + 10),
                _ => Err(KeyParseError::NotHex { at }),
            }
        };
        let mut key = [0u8; LinkKey::LEN];
        for (i, byte) in key.iter_mut().enumerate() {
            *byte = (nibble(2 * i)? << 4) | nibble(2 * i + 1)?;
        }
        Ok(LinkKey(key))
    }

    /// The key as 32 lower-case hexadecimal ASCII characters (the key file format).
    pub fn to_hex(&self) -> [u8; LinkKey::HEX_LEN] {
        const DIGITS: &[u8; 16] = b"0123456789abcdef";
        let mut out = [0u8; LinkKey::HEX_LEN];
        for (i, byte) in self.0.iter().enumerate() {
            out[2 * i] = DIGITS[usize::from(byte >> 4)];
            out[2 * i + 1] = DIGITS[usize::from(byte & 0x0F)];
        }
        out
    }

    /// The SipHash-2-4 tag of `bytes`: the 64-bit result in little-endian byte order, as the
    /// reference implementation outputs it.
    pub fn tag(&self, bytes: &[u8]) -> [u8; TAG_LEN] {
        let mut hasher = SipHasher24::new_with_key(&self.0);
        hasher.write(bytes);
        hasher.finish().to_le_bytes()
    }

    /// Whether `tag` is the tag of `bytes`, compared without an early exit.
    pub fn verify(&self, bytes: &[u8], tag: &[u8; TAG_LEN]) -> bool {
        let expected = self.tag(bytes);
        expected
            .iter()
            .zip(tag)
            .fold(0u8, |diff, (a, b)| diff | (a ^ b))
            == 0
    }
}

impl fmt::Debug for LinkKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("LinkKey(..)")
    }
}

/// Why a text is not a link key.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum KeyParseError {
    /// Not 32 characters after trimming whitespace.
    Length {
        /// Characters found.
        found: usize,
    },
    /// A character that is not a hexadecimal digit.
    NotHex {
        /// Its offset in the trimmed text.
        at: usize,
    },
}

impl fmt::Display for KeyParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KeyParseError::Length { found } => write!(
                f,
                "a link key is {} hexadecimal characters, found {found}",
                LinkKey::HEX_LEN
            ),
            KeyParseError::NotHex { at } => {
                write!(
                    f,
                    "character {at} of the link key is not a hexadecimal digit"
                )
            }
        }
    }
}

impl core::error::Error for KeyParseError {}

/// Why a version 2 frame was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// Bytes 0-1 are not the frame's start token.
    BadStart,
    /// Byte 2 is not the frame's length.
    BadLength {
        /// The length byte found.
        found: u8,
    },
    /// The tag does not match the frame under the key: forged, corrupt or another key.
    BadTag,
    /// An authentic command frame with an unknown type or out-of-range data.
    Command(CommandError),
    /// An authentic command frame (not a kill) whose operator request is not between 1 and its
    /// own sequence number.
    BadRequest {
        /// The request field.
        request: u32,
        /// The frame's sequence number.
        seq: u32,
    },
    /// An authentic display frame with an unknown robot mode.
    UnknownMode {
        /// The mode byte.
        found: u8,
    },
    /// An authentic display frame whose sensor payload is out of range.
    Display(DisplayError),
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::BadStart => f.write_str("frame does not start with its v2 start token"),
            FrameError::BadLength { found } => write!(f, "frame length byte {found} is wrong"),
            FrameError::BadTag => f.write_str(
                "frame tag does not match: forged, corrupt, or sent with another link key",
            ),
            FrameError::Command(error) => write!(f, "authentic frame rejected: {error}"),
            FrameError::BadRequest { request, seq } => write!(
                f,
                "authentic frame rejected: request {request} is not between 1 and its \
                 sequence number {seq}"
            ),
            FrameError::UnknownMode { found } => write!(f, "unknown robot mode {found}"),
            FrameError::Display(error) => write!(f, "authentic frame rejected: {error}"),
        }
    }
}

impl core::error::Error for FrameError {}

/// A nonzero random session id for this boot, from the operating system's random source.
#[cfg(feature = "std")]
pub fn random_session_id() -> Result<u32, getrandom::Error> {
    loop {
        let id = getrandom::u32()?;
        if id != 0 {
            return Ok(id);
        }
    }
}

/// Big-endian u32 at `at` (offsets are layout constants, always within the frame).
fn be_u32(bytes: &[u8], at: usize) -> u32 {
    u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

/// Checks start token, length byte and tag of a complete frame.
fn check_envelope<const N: usize>(
    frame: &[u8; N],
    start: [u8; 2],
    key: &LinkKey,
) -> Result<(), FrameError> {
    if frame[..2] != start {
        return Err(FrameError::BadStart);
    }
    if usize::from(frame[2]) != N {
        return Err(FrameError::BadLength { found: frame[2] });
    }
    let mut tag = [0u8; TAG_LEN];
    tag.copy_from_slice(&frame[N - TAG_LEN..]);
    if key.verify(&frame[..N - TAG_LEN], &tag) {
        Ok(())
    } else {
        Err(FrameError::BadTag)
    }
}

/// Writes start token, length byte and tag around a frame whose body is filled in.
fn seal<const N: usize>(frame: &mut [u8; N], start: [u8; 2], key: &LinkKey) {
    frame[..2].copy_from_slice(&start);
    frame[2] = N as u8;
    let tag = key.tag(&frame[..N - TAG_LEN]);
    frame[N - TAG_LEN..].copy_from_slice(&tag);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_round_trip_and_errors() {
        let key = LinkKey::parse_hex(" 00112233445566778899AABBCCDDEEFF\n").unwrap();
        assert_eq!(key.as_bytes()[15], 0xFF);
        assert_eq!(&key.to_hex(), b"00112233445566778899aabbccddeeff");
        assert_eq!(
            LinkKey::parse_hex("0011"),
            Err(KeyParseError::Length { found: 4 })
        );
        assert_eq!(
            LinkKey::parse_hex("0g112233445566778899aabbccddeeff"),
            Err(KeyParseError::NotHex { at: 1 })
        );
    }

    #[test]
    fn debug_hides_the_key() {
        let key = LinkKey::from_bytes([0xAB; 16]);
        let mut text = heapless_string();
        core::fmt::write(&mut text, format_args!("{key:?}")).unwrap();
        assert_eq!(text.as_str(), "LinkKey(..)");
    }

    /// A tiny fixed buffer for formatting in a `no_std` test.
    fn heapless_string() -> Buf {
        Buf([0; 64], 0)
    }

    struct Buf([u8; 64], usize);
    impl Buf {
        fn as_str(&self) -> &str {
            core::str::from_utf8(&self.0[..self.1]).unwrap()
        }
    }
    impl core::fmt::Write for Buf {
        fn write_str(&mut self, s: &str) -> core::fmt::Result {
            let end = self.1 + s.len();
            self.0.get_mut(self.1..end).ok_or(core::fmt::Error)?;
            self.0[self.1..end].copy_from_slice(s.as_bytes());
            self.1 = end;
            Ok(())
        }
    }
}
