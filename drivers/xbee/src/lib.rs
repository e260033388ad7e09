//! Driver for Digi XBee radio modules (XBee 3, XBee S2C and compatible), `no_std` and
//! allocation-free, over any embedded-hal-nb 1.0 serial port.
//!
//! # Transparent mode (a byte pipe)
//!
//! One type, [`XBee`], with the module's mode as a type parameter: `XBee<S, Transparent>`
//! ([`XBee::new`]) or `XBee<S, Api>` ([`XBee::new_api`]); [`XBee::into_api`] and
//! [`XBee::into_transparent`] switch between them once the module's `AP` setting was changed.
//!
//! `XBee<S, Transparent>` wraps the serial port and passes bytes through. It implements
//! embedded-hal-nb [`Read<u8>`](embedded_hal_nb::serial::Read) and
//! [`Write<u8>`](embedded_hal_nb::serial::Write) (and `embedded_io::{Read, Write}` with the
//! `embedded-io` feature), so a framed protocol runs over the radio exactly as over a cable.
//!
//! AT command mode is guarded so it can never corrupt the data stream: the guard times
//! (`GT`) are respected, data written while the module is (or may still be) in command mode is
//! refused with [`DeviceError::CommandModeActive`] instead of being sent as AT text, and the
//! command-mode timeout (`CT`) is tracked on both sides. It runs either
//!
//! - driven by the caller's clock: [`XBee::start_command_mode`],
//!   [`XBee::start_command`], [`XBee::start_exit`], then
//!   [`XBee::poll`]`(now_ms)` until it stops returning `WouldBlock`; requests come from
//!   [`settings`] and replies are read with [`XBee::reply`]; or
//! - blocking with a `DelayNs`: [`XBee::command_mode`] returns a [`CommandSession`]
//!   with helpers for PAN id ([`CommandSession::set_pan_id`]), channel
//!   ([`CommandSession::set_channel`]), node identifier
//!   ([`CommandSession::set_node_identifier`]), baud rate ([`CommandSession::set_baud_rate`]),
//!   API mode ([`CommandSession::set_api_mode`]), power level
//!   ([`CommandSession::set_power_level`]), encryption ([`CommandSession::set_encryption`],
//!   [`CommandSession::set_encryption_key`], write-only), role ([`CommandSession::set_role`]),
//!   versions ([`CommandSession::firmware_version`]), [`CommandSession::write_settings`]
//!   (`WR`), [`CommandSession::apply_changes`] (`AC`) and [`CommandSession::exit`] (`CN`);
//!   [`XBee::wait_until_transparent`] waits out `CT` after a failed entry.
//!
//! [`XBee::mode`] tells where the driver believes the module is;
//! [`XBee::release`] gives the port back.
//!
//! # API mode (frames)
//!
//! The frame codec without I/O: [`encode`] into a caller buffer (API 1 or API 2
//! escaping), and [`FrameDecoder`], a push-byte decoder that resynchronises on 0x7E, checks
//! length and checksum, bounds the frame size and counts what it drops. [`Frame`] types the
//! frames 0x08, 0x09, 0x10, 0x11, 0x17, 0x88, 0x8A, 0x8B, 0x90, 0x91 and 0x97, with
//! [`Frame::Unknown`] for the rest. [`XBee<S, Api>`](XBee) puts them on a serial port
//! ([`send`](XBee::send), [`send_at_command`](XBee::send_at_command), [`transmit`](XBee::transmit),
//! [`poll_frame`](XBee::poll_frame)), with a [`FrameIdAllocator`].
//!
//! # Async (feature `async`)
//!
//! `XBeeAsync` is the same driver over an `embedded-io-async` 0.7 port, generated from the same
//! source as [`XBee`] for its constructors and accessors and sharing its frame codec and
//! command-mode bookkeeping; the blocking API stays. `XBeeAsync<S, Api>` sends frames (a write
//! returning `Ok(0)` is [`DeviceError::Timeout`], never a panic) and reads them with a
//! cancel-safe `read_frame().await`; `XBeeAsync<S, Transparent>` implements
//! `embedded_io_async::{Read, Write}` and enters AT command mode with the guard times awaited on
//! an embedded-hal-async `DelayNs` (`command_mode(&mut delay).await` returns an
//! `AsyncCommandSession`, left with `exit().await`: dropped without it, the driver refuses data
//! until `wait_until_transparent` has waited `CT` out).
//!
//! # Example: the byte pipe, and a setting changed in between
//!
//! ```
//! # use embedded_hal_mock::eh1::serial::{Mock as SerialMock, Transaction};
//! # use embedded_hal_mock::eh1::delay::NoopDelay;
//! use embedded_hal_nb::serial::Write;
//! use xbee_driver::{PowerLevel, XBee};
//!
//! # let mut expected = vec![Transaction::write(b'$')];
//! # expected.push(Transaction::flush());
//! # expected.push(Transaction::write_many(b"+++"));
//! # expected.push(Transaction::read_many(b"OK\r"));
//! # expected.push(Transaction::write_many(b"ATPL2\r"));
//! # expected.push(Transaction::read_many(b"OK\r"));
//! # expected.push(Transaction::write_many(b"ATCN\r"));
//! # expected.push(Transaction::read_many(b"OK\r"));
//! # expected.push(Transaction::write(b'$'));
//! # let serial = SerialMock::new(&expected);
//! # let mut delay = NoopDelay::new();
//! let mut radio = XBee::new(serial);
//! nb::block!(radio.write(b'$'))?; // data goes straight through
//!
//! let mut session = radio.command_mode(&mut delay)?; // GT, +++, GT, OK
//! session.set_power_level(PowerLevel::Medium)?;      // ATPL2 -> OK
//! session.exit()?;                                   // ATCN -> OK
//!
//! nb::block!(radio.write(b'$'))?; // transparent again
//! # radio.release().done();
//! # Ok::<(), xbee_driver::Error<embedded_hal_nb::serial::ErrorKind>>(())
//! ```
//!
//! # Features
//!
//! - `embedded-io`: `embedded_io::{Read, Write}` for `XBee<S, Transparent>`.
//! - `async`: `XBeeAsync` and `AsyncCommandSession` over `embedded-io-async` 0.7 and
//!   embedded-hal-async (see above).
//! - `defmt`: `defmt::Format` for the public types.
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![deny(unsafe_code)]
#![deny(missing_docs)]

/// Writes each driver item once for the blocking `XBee` and, with the `async` feature, once more
/// for `XBeeAsync` (`.await` on the transport calls), through `maybe-async-cfg`.
macro_rules! blocking_and_async {
    ($($item:item)*) => {
        $(
            #[maybe_async_cfg::maybe(
                sync(),
                async(feature = "async"),
                idents(
                    XBee(sync, async = "XBeeAsync"),
                    FramePort(sync, async = "AsyncFramePort"),
                    send_frame(sync, async = "send_frame_async")
                )
            )]
            $item
        )*
    };
}
pub(crate) use blocking_and_async;

mod at;
mod codec;
mod escape;
mod frame_id;
mod frames;
mod setting_types;
pub mod settings;
mod types;
mod xbee;

pub use at::{format_line, parse_hex, AtCommand, AtRequest, Parameter, MAX_LINE_LEN};
pub use codec::{
    checksum, encode, encode_raw, encoded_len, write_frame, ByteSink, DecoderStats, FrameDecoder,
    RawFrame, SliceSink, WriteError,
};
pub use escape::{escape, needs_escape, unescape, EscapeError};
pub use frame_id::FrameIdAllocator;
pub use frames::{
    frame_type, AtCommandFrame, AtResponse, CommandStatus, ExplicitAddressing, ExplicitRx, Frame,
    ModemStatus, ReceivePacket, RemoteAtCommand, RemoteAtResponse, TransmitRequest, TransmitStatus,
};
/// `nb`, re-exported for `nb::block!` and matching `nb::Error::WouldBlock`.
pub use nb;
pub use setting_types::{
    ApiMode, BaudRate, PowerLevel, Role, MAX_CHANNEL, MAX_NODE_IDENTIFIER_LEN, MIN_CHANNEL,
};
pub use types::{Address16, Address64, ApiEscaping, DeviceError, Error, FrameError};
pub use xbee::{
    Api, CommandOutcome, CommandSession, CommandTiming, Mode, Transparent, XBee,
    DEFAULT_WRITE_POLLS_PER_BYTE, MAX_AT_PARAMETER_LEN, POLL_STEP_US,
};
#[cfg(feature = "async")]
pub use xbee::{AsyncCommandSession, XBeeAsync};

/// The README's code blocks, compiled as doctests so they keep matching the API.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
