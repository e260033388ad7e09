//! Driver for the Pololu Maestro servo controllers (Micro Maestro 6, Mini Maestro 12/18/24)
//! over their serial interface.
//!
//! - A sans-IO codec for all three protocols: compact, Pololu (0xAA + device number) and
//!   Mini SSC, with the optional CRC-7 byte: [`encode`], [`encode_set_target`],
//!   [`encode_set_targets`], [`crc7()`], and the reply helpers in [`reply`].
//! - Checked values: [`QuarterMicros`], [`Channel`], [`Speed`], [`Acceleration`], [`PwmTiming`],
//!   [`Subroutine`], [`ScriptParameter`], [`DeviceNumber`], [`MiniSscServo`], [`MiniSscValue`].
//! - Models as marker types ([`Micro6`], [`Mini12`], [`Mini18`], [`Mini24`]): the Mini-only
//!   commands exist only for [`MiniModel`]s, so Set PWM on a Micro Maestro does not compile.
//! - The blocking driver [`Maestro`] over embedded-hal-nb serial ([`NbSerial`]) or, with the
//!   `embedded-io` feature, embedded-io 0.7 (`IoSerial`):
//!   [`set_target`](Maestro::set_target), [`set_targets`](Maestro::set_targets) (several
//!   channels, one write), [`encode_targets`](Maestro::encode_targets) (the same bytes, checked,
//!   without I/O), [`stop_pulses`](Maestro::stop_pulses), [`set_neutral`](Maestro::set_neutral),
//!   [`set_speed`](Maestro::set_speed), [`set_acceleration`](Maestro::set_acceleration),
//!   [`set_multiple_targets`](Maestro::set_multiple_targets) and
//!   [`encode_multiple_targets`](Maestro::encode_multiple_targets) (Mini Maestros),
//!   [`set_pwm`](Maestro::set_pwm) (Mini Maestros), [`go_home`](Maestro::go_home), [`stop_script`](Maestro::stop_script),
//!   [`restart_script`](Maestro::restart_script),
//!   [`restart_script_with_parameter`](Maestro::restart_script_with_parameter),
//!   [`mini_ssc_set`](Maestro::mini_ssc_set), [`flush`](Maestro::flush), and the queries
//!   [`get_position`](Maestro::get_position), [`get_errors`](Maestro::get_errors),
//!   [`get_moving_state`](Maestro::get_moving_state),
//!   [`get_script_status`](Maestro::get_script_status).
//! - A device-side streaming [`CommandDecoder`] (sans-IO, resynchronising, CRC-checking,
//!   counting what it drops) for simulating a Maestro.
//! - A sans-IO [`TargetEncoder`]: the checked per-cycle target bytes without a driver, for an
//!   application that writes them itself with its own deadline.
//! - Per-channel [`Limits`]: an out-of-range target is an error ([`TargetError::OutOfRange`]) and
//!   nothing is sent; clamping is a separate, explicit call ([`Limits::clamp`]).
//! - Feature `async`: `MaestroAsync`, the same driver over `embedded-io-async` 0.7
//!   (`AsyncIoSerial`), generated from the same source as [`Maestro`] (so the two cannot
//!   drift); queries race the reply against an `AsyncDeadline` (`AsyncDelayDeadline` over an
//!   embedded-hal-async `DelayNs`). The blocking API stays available.
//! - Replies are read against a caller-given [`Deadline`] ([`PollBudget`], [`DelayDeadline`] or a
//!   closure); a missing or short reply is [`DeviceError::Timeout`], never a hang or stale data.
//!
//! # Example
//!
//! ```
//! use embedded_hal_mock::eh1::serial::{Mock, Transaction};
//! use pololu_maestro::{
//!     Channel, ChannelLimits, Framing, Limits, Maestro, Micro6, PollBudget, QuarterMicros,
//! };
//!
//! # fn main() -> Result<(), pololu_maestro::Error<embedded_hal_nb::serial::ErrorKind>> {
//! let steering = Channel::new::<Micro6>(1)?;
//! let expected = [
//!     // Set Target, channel 1, 1840 µs.
//!     Transaction::write_many([0x84, 0x01, 0x40, 0x39]),
//!     // Get Position, channel 1: the Maestro answers 7360 (1840 µs).
//!     Transaction::read_error(nb::Error::WouldBlock),
//!     Transaction::write_many([0x90, 0x01]),
//!     Transaction::read_many([0xC0, 0x1C]),
//! ];
//! # let mut serial = Mock::new(&expected);
//! let limits = Limits::new().with(steering, ChannelLimits::from_micros(1250, 1840, 1545).unwrap());
//! let mut maestro = Maestro::new_serial(serial.clone(), Micro6, Framing::COMPACT).with_limits(limits);
//!
//! maestro.set_target(steering, QuarterMicros::from_micros(1840)?)?;
//! // Beyond the steering limits: refused, nothing is written.
//! assert!(maestro.set_target(steering, QuarterMicros::from_micros(2000)?).is_err());
//!
//! let position = maestro.get_position(steering, &mut PollBudget(1000))?;
//! assert_eq!(position.get(), 7360); // 1840 µs
//! # serial.done();
//! # Ok(())
//! # }
//! ```
//!
//! Set PWM exists only on the Mini Maestros:
//!
//! ```compile_fail
//! # use embedded_hal_mock::eh1::serial::Mock;
//! # use pololu_maestro::{Framing, Maestro, Micro6, PwmTiming};
//! # let serial = Mock::new(&[]);
//! let mut maestro = Maestro::new_serial(serial, Micro6, Framing::COMPACT);
//! maestro.set_pwm(PwmTiming::new(100, 200).unwrap());
//! ```
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![deny(unsafe_code)]
#![deny(missing_docs)]

/// Writes each driver item once for the blocking `Maestro` and, with the `async` feature, once
/// more for `MaestroAsync` (`.await` on the transport calls), through `maybe-async-cfg`.
macro_rules! blocking_and_async {
    ($($item:item)*) => {
        $(
            #[maybe_async_cfg::maybe(
                sync(),
                async(feature = "async"),
                idents(
                    Maestro(sync, async = "MaestroAsync"),
                    WriteInterface(sync, async = "AsyncWriteInterface"),
                    ReadInterface(sync, async = "AsyncReadInterface"),
                    Deadline(sync, async = "AsyncDeadline"),
                    transport(sync, async = "async_transport")
                )
            )]
            $item
        )*
    };
}
pub(crate) use blocking_and_async;

mod codec;
mod command;
mod crc7;
mod decoder;
mod device;
mod error;
mod interface;
#[cfg(feature = "async")]
mod io_async;
mod limits;
mod model;
pub mod reply;
mod status;
mod targets;
mod types;

pub use codec::{
    encode, encode_set_target, encode_set_targets, join_14, split_14, Bytes, Framing, Packet,
    Protocol, TargetFrame, MAX_PACKET_LEN, MAX_SET_TARGET_LEN, MAX_TARGET_FRAME_LEN,
};
pub use command::{opcode, Command, MultiTargets};
pub use crc7::{crc7, MAESTRO_CRC7};
pub use decoder::{CommandDecoder, Decoded, DecoderConfig, DecoderStats};
pub use device::Maestro;
#[cfg(feature = "async")]
pub use device::MaestroAsync;
pub use error::{DeviceError, Error, InvalidInput};
#[cfg(feature = "async")]
pub use interface::AsyncWriteInterface;
#[cfg(feature = "embedded-io")]
pub use interface::IoSerial;
pub use interface::{
    Deadline, DelayDeadline, NbSerial, PollBudget, ReadInterface, WriteInterface,
    DEFAULT_WRITE_POLLS_PER_BYTE,
};
#[cfg(feature = "async")]
pub use io_async::{AsyncDeadline, AsyncDelayDeadline, AsyncIoSerial, AsyncReadInterface};
pub use limits::{ChannelLimits, LimitViolation, Limits};
pub use model::{Micro6, Mini12, Mini18, Mini24, MiniModel, Model};
pub use status::ErrorFlags;
pub use targets::{TargetEncoder, TargetError};
pub use types::{
    Acceleration, Channel, DeviceNumber, MiniSscServo, MiniSscValue, PwmTiming, QuarterMicros,
    ScriptParameter, ScriptStatus, Speed, Subroutine, MAX_14_BIT, MAX_CHANNELS,
};

/// The README's examples, compiled as doctests so they keep matching the API.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
