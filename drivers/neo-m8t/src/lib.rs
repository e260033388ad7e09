//! u-blox NEO-M8T GNSS driver on top of the [`ublox`] crate: `no_std`, no allocation.
//!
//! The `ublox` crate parses and builds UBX messages; this crate makes a device driver of it:
//!
//! - **Acknowledged configuration** ([`Configurator`]): MON-VER poll (software, firmware and
//!   protocol version are reported, never assumed: [`ReceiverVersion`]), CFG-PRT (UART1 baud
//!   rate, UBX only in and out), CFG-MSG (NAV-PVT at every solution, default NMEA off,
//!   optional TIM-TP / TIM-TM2), CFG-RATE (100 ms, GPS time), CFG-NAV5 (dynamic model),
//!   CFG-TP5 (time pulse) and optionally CFG-TMODE2. Each message waits for its ACK-ACK;
//!   ACK-NAK and silence after bounded retries are errors ([`Error`]). The baud-rate switch
//!   survives the receiver answering at either rate. It is a state machine the caller polls
//!   with the current time ([`Configurator::poll`]); [`Configurator::run_blocking`] wraps it
//!   with a `DelayNs`.
//! - **Streaming reader, sans-IO** ([`GnssStream`], [`UbxFramer`]): push bytes or DMA chunks
//!   from anywhere (an interrupt, a `read`), get checksum-verified frames; the latest NAV-PVT
//!   is kept as the exact 100-byte frame ([`NavPvtFrame`]) that the DIMA sensor packet
//!   carries, plus TIM-TP and TIM-TM2. After garbage, lost or corrupted bytes the framer
//!   rescans from the byte after a rejected sync, so the next real frame is found; counters
//!   say what was dropped ([`FramerStats`]).
//! - **Serial driver** ([`NeoM8t`]): the two above on an embedded-hal-nb
//!   `serial::Read<u8> + Write<u8>` port (linux-embedded-hal, stm32f4xx-hal, ...); with the
//!   `embedded-io` feature, `IoSerial` adapts embedded-io 0.7 ports.
//! - **Async driver** (`NeoM8tAsync`, feature `async`): the same driver on an
//!   `embedded-io-async` 0.7 port (an Embassy UART, ...): awaits messages, awaits each ACK with
//!   a deadline raced against an embedded-hal-async `DelayNs`, and runs the same configuration
//!   sequence.
//! - **NAV-PVT both ways** ([`NavPvt`]): every field as the integer on the wire (Cortex-M4F has
//!   no double-precision FPU), encoded to the identical frame ([`NavPvt::to_frame`]) for
//!   simulators and tests, decoded through `ublox`'s integer `*_raw` accessors.
//!
//! Protocol 23 ([`ublox::proto23::Proto23`]) is named explicitly everywhere, so enabling other
//! `ublox` protocol features elsewhere in a build cannot change how frames decode. M8
//! receivers are configured with the CFG-* messages above; CFG-VALSET is for M9 and later.
//!
//! # Example: configure, with the caller's clock
//!
//! The caller owns time: [`Configurator::poll`] takes the current time in milliseconds and
//! never waits. Here an embedded-hal-mock port plays a receiver that acknowledges everything.
//!
//! ```
//! # use embedded_hal_mock::eh1::serial::{Mock, Transaction};
//! # use neo_m8t::commands;
//! # fn ack(cmd: &[u8]) -> Vec<u8> {
//! #     let mut out = vec![0u8; 10];
//! #     neo_m8t::encode_frame(0x05, 0x01, &cmd[2..4], &mut out).unwrap();
//! #     out
//! # }
//! # let mut ver_payload = [0u8; 70];
//! # ver_payload[..22].copy_from_slice(b"ROM CORE 3.01 (107888)");
//! # ver_payload[30..38].copy_from_slice(b"00080000");
//! # ver_payload[40..53].copy_from_slice(b"PROTVER=18.00");
//! # let mut mon_ver = vec![0u8; 78];
//! # neo_m8t::encode_frame(0x0A, 0x04, &ver_payload, &mut mon_ver).unwrap();
//! # let config = neo_m8t::Config::default();
//! # let mut script = vec![
//! #     Transaction::write_many(commands::poll_mon_ver().as_bytes()),
//! #     Transaction::read_many(mon_ver),
//! #     Transaction::write_many(commands::cfg_prt_uart1(115_200).as_bytes()),
//! #     Transaction::read_many(ack(commands::cfg_prt_uart1(115_200).as_bytes())),
//! # ];
//! # let mut cmds = vec![commands::cfg_msg_uart1(1, 7, 1)];
//! # for (c, i) in commands::DEFAULT_NMEA { cmds.push(commands::cfg_msg_uart1(c, i, 0)); }
//! # cmds.push(commands::cfg_msg_uart1(0x0D, 0x01, 0));
//! # cmds.push(commands::cfg_msg_uart1(0x0D, 0x03, 0));
//! # cmds.push(commands::cfg_rate(100, 1, neo_m8t::AlignmentToReferenceTime::Gps));
//! # cmds.push(commands::cfg_nav5(neo_m8t::NavDynamicModel::Automotive));
//! # cmds.push(commands::cfg_tp5(&neo_m8t::TimePulse::default()));
//! # for c in &cmds {
//! #     script.push(Transaction::write_many(c.as_bytes()));
//! #     script.push(Transaction::read_many(ack(c.as_bytes())));
//! # }
//! # let mut serial = Mock::new(&script);
//! # let mut clock_ms = 0u32;
//! # let mut now_ms = || { clock_ms += 1; clock_ms };
//! use neo_m8t::{Config, Configurator, Progress};
//!
//! // UART1 of the receiver is at 115200 already; DIMA's defaults: 10 Hz NAV-PVT, UBX only.
//! let mut cfg = Configurator::<512>::with_capacity(Config::default(), 115_200);
//! loop {
//!     match cfg.poll(&mut serial, now_ms())? {
//!         Progress::Pending => { /* do other work, or sleep a millisecond */ }
//!         Progress::SetBaudRate(baud) => { /* switch the host UART to `baud` */ }
//!         Progress::Done => break,
//!     }
//! }
//! let version = cfg.version().unwrap();
//! assert_eq!(version.protocol.unwrap().to_string(), "18.00");
//! # serial.done();
//! # Ok::<(), neo_m8t::Error<embedded_hal_nb::serial::ErrorKind>>(())
//! ```
//!
//! # Example: latest fix from DMA chunks
//!
//! ```
//! use neo_m8t::{GnssStream, NavPvt};
//!
//! // What a receiver would send: a NAV-PVT frame (built here from fields).
//! let sent = NavPvt { itow_ms: 28_548_000, fix_type: 3, num_sv: 11, ..NavPvt::default() };
//! let wire = sent.to_frame();
//!
//! // Feed it in two chunks, as a UART DMA would deliver it.
//! let mut stream = GnssStream::<100>::with_capacity();
//! stream.push_slice(&wire.as_bytes()[..64]);
//! stream.push_slice(&wire.as_bytes()[64..]);
//!
//! // Copy the frame into the sensor packet (bytes 28-127), or decode it.
//! let mut packet = [0u8; 132];
//! let gnss: &mut [u8; 100] = (&mut packet[28..128]).try_into().unwrap();
//! assert!(stream.copy_latest_nav_pvt(gnss));
//! let fix = stream.take_nav_pvt().unwrap().to_nav_pvt();
//! assert_eq!((fix.itow_ms, fix.num_sv), (28_548_000, 11));
//! assert_eq!(stream.stats().frames_ok, 1);
//! ```
//!
//! # Features
//!
//! - `embedded-io` (default): `IoSerial`, an adapter for embedded-io 0.7 `Read + ReadReady + Write +
//!   WriteReady` ports.
//! - `async`: `NeoM8tAsync`, the async twin of [`NeoM8t`] over `embedded-io-async` 0.7 ports
//!   with embedded-hal-async deadlines; the blocking API stays as it is.
//! - `defmt`: `defmt::Format` for the data and error types.
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![deny(unsafe_code)]
#![deny(missing_docs)]

/// Generates each item twice from one source: as written, minus `async` and `.await`, for the
/// blocking [`NeoM8t`], and as written for `NeoM8tAsync` (feature `async`).
macro_rules! blocking_and_async {
    ($($item:item)*) => {
        $(
            #[maybe_async_cfg::maybe(
                sync(),
                async(feature = "async"),
                idents(NeoM8t(sync, async = "NeoM8tAsync"))
            )]
            $item
        )*
    };
}
pub(crate) use blocking_and_async;

pub mod commands;
mod config;
mod configure;
mod driver;
#[cfg(feature = "async")]
mod driver_async;
mod error;
mod frame;
mod int_commands;
mod interface;
pub mod nav_pvt;
mod stream;
mod timing;
mod version;

pub use config::{
    tp5_flags, AlignmentToReferenceTime, Config, NavDynamicModel, TimeMode, TimePulse,
};
pub use configure::{
    Configurator, Progress, DEFAULT_RETRIES, DEFAULT_SWITCH_SETTLE_MS, DEFAULT_TIMEOUT_MS,
    MAX_READ_PER_POLL,
};
#[cfg(feature = "async")]
pub use driver::NeoM8tAsync;
pub use driver::{NeoM8t, MAX_MESSAGES_PER_POLL};
pub use error::{DeviceError, Error};
pub use frame::{checksum, encode_frame, Frame, FramerStats, UbxFramer, FRAME_OVERHEAD};
#[cfg(feature = "embedded-io")]
pub use interface::{IoError, IoSerial};
pub use nav_pvt::{FixType, NavPvt, NavPvtFrame};
pub use stream::{GnssStream, Message};
pub use timing::{TimTm2, TimTp};
pub use ublox;
pub use version::{ProtocolVersion, ReceiverVersion};

/// The README's code blocks, compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

/// `nb`, re-exported for `nb::block!` and matching `nb::Error::WouldBlock` on the reading calls.
pub use nb;
