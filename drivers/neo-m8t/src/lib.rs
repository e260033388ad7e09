//! u-blox NEO-M8T GNSS driver on top of the [`ublox`] crate: `no_std`, no allocation.
//!
//! - **Streaming reader (sans-IO)**: [`GnssStream`] takes bytes from anywhere (a DMA chunk in
//!   an interrupt, a serial `read`) and keeps the latest NAV-PVT as the exact 100-byte frame
//!   ([`NavPvtFrame`], what the DIMA sensor packet carries), plus TIM-TP and TIM-TM2.
//!   Frames are checksum-verified; after garbage, lost or corrupted bytes the
//!   [`UbxFramer`] resynchronises on the next real frame and counts what it dropped
//!   ([`FramerStats`]).
//! - **NAV-PVT both ways**: [`NavPvt`] holds every field as the integer on the wire (no
//!   floating point: Cortex-M4F has no double-precision FPU) and encodes the identical frame
//!   ([`NavPvt::to_frame`]) for simulators and tests.
//!
//! All message definitions come from `ublox` with protocol 23 ([`ublox::proto23::Proto23`])
//! named explicitly, so enabling other protocol features elsewhere in a build cannot change
//! how frames are decoded.
//!
//! # Example: latest fix from a byte stream
//!
//! ```
//! use neo_m8t::{GnssStream, NavPvt};
//!
//! // What a receiver would send: a NAV-PVT frame (built here from fields).
//! let sent = NavPvt { itow_ms: 28_548_000, fix_type: 3, num_sv: 11, ..NavPvt::default() };
//! let wire = sent.to_frame();
//!
//! // Feed it in two chunks, as a UART DMA would deliver it.
//! let mut stream = GnssStream::<100>::new();
//! stream.push_slice(&wire.as_bytes()[..64]);
//! stream.push_slice(&wire.as_bytes()[64..]);
//!
//! // Copy the frame into the sensor packet, or decode it.
//! let mut packet = [0u8; 132];
//! let gnss: &mut [u8; 100] = (&mut packet[28..128]).try_into().unwrap();
//! assert!(stream.copy_latest_nav_pvt(gnss));
//! let fix = stream.take_nav_pvt().unwrap().to_nav_pvt();
//! assert_eq!((fix.itow_ms, fix.num_sv), (28_548_000, 11));
//! assert_eq!(stream.stats().frames_ok, 1);
//! ```
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

pub mod commands;
pub mod config;
pub mod configure;
pub mod error;
pub mod frame;
pub mod nav_pvt;
pub mod stream;
pub mod timing;
pub mod version;

pub use config::{Config, NavDynamicModel, TimeMode, TimePulse};
pub use configure::{Configurator, Progress};
pub use error::Error;
pub use frame::{Frame, FramerStats, UbxFramer};
pub use nav_pvt::{FixType, NavPvt, NavPvtFrame};
pub use stream::{GnssStream, Message};
pub use timing::{TimTm2, TimTp};
pub use ublox;
pub use version::{ProtocolVersion, ReceiverVersion};
