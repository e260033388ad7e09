//! The DIMA ground link: the frames exchanged between the robot and its ground station over
//! the XBee radio link (transparent mode).
//!
//! Version 1 (the crate root) is bit-compatible with the original ground station; it carries no
//! authentication. Version 2 ([`v2`]) adds a SipHash-2-4 tag under a pre-shared key, a per-boot
//! session id and sequence numbers, and a downlink that reports the robot's mode, failsafe
//! cause, health counters and the acknowledgement of the last accepted command.
//!
//! - [`Command`]: 10-byte command frames, ground station -> robot (`$`, type, i32 big-endian data,
//!   CRC-32/ISO-HDLC over type and data). [`Command::encode`], [`Command::decode`], and the
//!   resynchronising [`CommandDecoder`] that finds frames in a byte stream by `$` and CRC.
//! - [`DisplayFrame`]: 68-byte display frames, robot -> ground station (sensor values and the GNSS
//!   solution, CRC-32/ISO-HDLC, no start token). [`DisplayFrame::encode`],
//!   [`DisplayFrame::decode`], and the sliding-window [`DisplayDecoder`].
//!
//! Both decoders are total: they take any bytes in any chunking, never panic, reject CRC-valid
//! frames with unknown types or out-of-range data, and count everything they drop
//! ([`CommandStats`], [`DisplayStats`]). The frames are bit-compatible with the original DIMA
//! ground station; speed and heading setpoints (types 6 and 7) are new in this implementation.
//!
//! With the `station` feature, module `station` is the ground station's side of the link
//! without I/O: the command schedule, and ground link v2's numbering, repetition until
//! acknowledged and acknowledgements, with the clock passed in (`station::Station`).
//!
//! ```
//! use dima_groundlink::{Command, CommandDecoder, Percent};
//!
//! // The original ground station's heartbeat, byte for byte.
//! let heartbeat = [0x24, 0x00, 0x00, 0x00, 0x00, 0x00, 0xC6, 0x22, 0xF7, 0x1D];
//! assert_eq!(Command::Heartbeat.encode(), heartbeat);
//!
//! // Reads split anywhere, with garbage in between, still yield every frame.
//! let throttle = Command::Throttle(Percent::new(75).unwrap()).encode();
//! let mut decoder = CommandDecoder::new();
//! let mut seen = 0;
//! for chunk in [&heartbeat[..3], &heartbeat[3..], &[0x55, b'$', 0x01][..], &throttle[..]] {
//!     for command in decoder.feed(chunk) {
//!         assert!(command.is_ok());
//!         seen += 1;
//!     }
//! }
//! assert_eq!(seen, 2);
//! ```
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

#[cfg(feature = "std")]
extern crate std;

pub mod checksum;
pub mod command;
pub mod display;
#[cfg(feature = "std")]
pub mod key_file;
#[cfg(feature = "station")]
pub mod station;
pub mod v2;

pub use command::{
    Command, CommandDecoder, CommandError, CommandStats, CommandType, Percent, COMMAND_FRAME_LEN,
    COMMAND_START, HEADING_FULL_TURN_DEG_E5, MAX_SPEED_MM_S,
};
pub use display::{DisplayDecoder, DisplayError, DisplayFrame, DisplayStats, DISPLAY_FRAME_LEN};
