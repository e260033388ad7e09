//! The DIMA sensor-board link: the 132-byte v1 sensor packet, the info frame, the STM32 CRC
//! that protects both, a resynchronising stream decoder and a host driver.
//!
//! The sensor board (an STM32F4 with a BMX055 IMU, a BMP280 barometer and a u-blox M8 GNSS
//! receiver) answers each rising edge on a request line with one packet on a UART. This crate
//! is the single codec for that link, shared by the firmware, the realtime app, the simulator
//! and the tools.
//!
//! # Features
//! - Packet v1, bit-exact with the original board: [`SensorPacket::encode`] /
//!   [`SensorPacket::decode`], raw signed counts after the arithmetic shifts, raw 20-bit BMP280
//!   values, and the NAV-PVT frame kept verbatim ([`GnssFrame`]) and parsed into the NEO-M8T
//!   driver's typed fields ([`NavPvt`], decoded by the `ublox` crate). An all-zero or damaged
//!   GNSS area means "no GNSS", never a bad packet.
//! - The STM32 CRC (each byte as a zero-extended 32-bit word, CRC-32/MPEG-2): a bitwise
//!   reference model [`crc::crc32_bitwise`], a table-driven [`Stm32Crc`], and the [`SensorCrc`]
//!   trait through which the firmware plugs in the hardware CRC unit.
//! - Board side: [`PacketBuilder`] assembles a packet from register bytes or counts and the
//!   latest NAV-PVT frame, and fills the CRC through [`SensorCrc`].
//! - The info frame ([`InfoFrame`], start token `$I`): firmware version, sensor status, BMP280
//!   calibration and BMM150 trim registers, uptime and skipped requests; its layout and trigger
//!   are documented on [`InfoFrame`].
//! - Info pieces ([`InfoPiece`], start token `$H`, 21 bytes): the info frame cut into 12-byte
//!   pieces so that one fits behind every packet in a 4 ms period; [`InfoPieceCycle`] decides
//!   on the board which piece goes next, and the stream decoder puts the record back together.
//! - A sans-IO [`StreamDecoder`]: any chunking, no allocation, bounded buffer, resynchronises
//!   inside rejected bytes, reassembles info pieces, counts what it drops ([`DecoderStats`]),
//!   gives the same output for any split of the same bytes; yields [`Frame`]s.
//! - Packet v2 for a 2 kHz loop ([`PacketV2`], start token `$P`, 42 bytes): request count,
//!   board sample time, the IMU words and BMP280 values as v1, sensor status and link flags,
//!   the same CRC; the NAV-PVT frame travels in four [`GnssPiece`]s (`$G`, 34 bytes) behind
//!   packets when a new one arrives; [`AnswerCycleV2`] decides on the board what follows each
//!   packet (a GNSS piece, else an info piece), and [`StreamDecoderV2`] finds packets and
//!   reassembles NAV-PVT frames and info records with the v1 decoder's guarantees.
//! - A host driver [`SensorBoard`], generic over an embedded-hal [`OutputPin`] (request line)
//!   and an embedded-hal-nb serial [`Read`] (works with linux-embedded-hal's `Serial` and
//!   `CdevPin`): [`SensorBoard::request`], [`SensorBoard::end_request`],
//!   [`SensorBoard::poll`]. It never sleeps.
//! - With the `async` feature, `SensorBoardAsync`: the same host driver on an
//!   `embedded-io-async` 0.7 port, generated from the same source; its `read_frame` awaits the
//!   next frame through the same stream decoder, raced against an embedded-hal-async `DelayNs`
//!   deadline. The request line stays an embedded-hal [`OutputPin`]: setting a GPIO completes
//!   at once, there is nothing to wait for (embedded-hal-async has no output-pin trait).
//! - The BMX055 part of the packet as words ([`imu::ImuPacketWords`]: left-justified, status
//!   bits masked, both directions, built from a `bosch-bmx055` sample), and with the `sim`
//!   feature the simulator direction from physical values.
//! - Physical units for the configured ranges in [`units`] (kept out of the decoder).
//! - `defmt` feature: `defmt::Format` for the public types.
//!
//! # Usage
//! ```
//! use dima_sensorboard::{Frame, SensorBoard, SensorPacket};
//! use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as PinTx};
//! use embedded_hal_mock::eh1::serial::{Mock as SerialMock, Transaction as SerialTx};
//!
//! // What the board would answer.
//! let answer = SensorPacket { accel: [10, -20, 1000], ..SensorPacket::default() }.encode();
//!
//! let pin = PinMock::new(&[PinTx::set(State::High), PinTx::set(State::Low)]);
//! let serial = SerialMock::new(&[SerialTx::read_many(answer)]);
//! let mut board = SensorBoard::new(pin, serial);
//!
//! board.request().unwrap();
//! board.end_request().unwrap();
//! // In a real loop, poll until a deadline; here the whole answer is already there.
//! let frame = nb::block!(board.poll()).unwrap();
//! let Frame::Packet(raw) = frame else { panic!("expected a packet") };
//! let packet = raw.decode();
//! assert_eq!(packet.accel, [10, -20, 1000]);
//! assert!(packet.nav_pvt().is_none()); // no GNSS frame yet
//! assert_eq!(board.stats().packets, 1);
//!
//! let (mut pin, mut serial) = board.release();
//! pin.done();
//! serial.done();
//! ```
//!
//! [`OutputPin`]: embedded_hal::digital::OutputPin
//! [`Read`]: embedded_hal_nb::serial::Read
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![deny(unsafe_code)]
#![deny(missing_docs)]

/// Generates each item twice from one source: as written, minus `async` and `.await`, for the
/// blocking [`SensorBoard`], and as written for `SensorBoardAsync` (feature `async`).
macro_rules! blocking_and_async {
    ($($item:item)*) => {
        $(
            #[maybe_async_cfg::maybe(
                sync(),
                async(feature = "async"),
                idents(
                    SensorBoard(sync, async = "SensorBoardAsync"),
                    SerialPort(sync, async = "AsyncSerialPort")
                )
            )]
            $item
        )*
    };
}
pub(crate) use blocking_and_async;

mod builder;
mod crc;
mod driver;
#[cfg(feature = "async")]
mod driver_async;
mod gnss;
mod gnss_piece;
pub mod imu;
mod info;
mod packet;
mod packet_v2;
mod piece;
mod stream;
mod stream_v2;
pub mod units;

pub use builder::PacketBuilder;
#[cfg(feature = "slice16")]
pub use crc::update_slice16;
pub use crc::{
    crc32_bitwise, update_byte, update_slice4, update_word_bitwise, SensorCrc, Stm32Crc, INITIAL,
    POLYNOMIAL,
};
#[cfg(feature = "async")]
pub use driver::SensorBoardAsync;
pub use driver::{DeviceError, Error, SensorBoard, MAX_BYTES_PER_POLL};
pub use gnss::{nav_pvt, FixType, GnssFrame, NavPvt, NavPvtFrame, GNSS_FRAME_LEN};
pub use gnss_piece::{
    AnswerCycleV2, GnssPiece, GnssPieceError, GnssPieceSet, Trailer, GNSS_PIECE_COUNT,
    GNSS_PIECE_LEN, GNSS_PIECE_PAYLOAD_LEN, GNSS_PIECE_START,
};
pub use info::{
    info_frame_len, BoardFaults, BoardHealth, InfoError, InfoFrame, SensorStatus, INFO_MAX_LEN,
    INFO_MAX_PAYLOAD_LEN, INFO_START, INFO_V1_LEN, INFO_V1_PAYLOAD_LEN, INFO_V2_LEN,
    INFO_V2_PAYLOAD_LEN, INFO_V3_LEN, INFO_V3_PAYLOAD_LEN, INFO_VERSION,
};
pub use packet::{
    decode_adc20, encode_adc20, PacketError, RawPacket, SensorPacket, ACCEL_OFFSET, ACCEL_RANGE,
    ADC20_MAX, CRC_OFFSET, GNSS_OFFSET, GYRO_OFFSET, MAG_OFFSET, MAG_XY_RANGE, MAG_Z_RANGE,
    PACKET_CRC_COVERED, PACKET_LEN, PACKET_START, PRESSURE_OFFSET, RHALL_MAX, RHALL_OFFSET,
    TEMPERATURE_OFFSET,
};
pub use packet_v2::{
    AnswerMatch, LinkFlags, PacketV2, PacketV2Error, RawPacketV2, RequestTracker, SampleClock,
    PACKET_V2_LEN, PACKET_V2_START, V2_CRC_OFFSET, V2_FLAGS_OFFSET, V2_IMU_OFFSET,
    V2_PRESSURE_OFFSET, V2_REQUEST_COUNT_OFFSET, V2_SAMPLE_TIME_OFFSET, V2_STATUS_OFFSET,
    V2_TEMPERATURE_OFFSET,
};
pub use piece::{
    InfoPiece, InfoPieceCycle, InfoPieceError, InfoPieceSet, InfoPieceSetV3, INFO_GAP_MS,
    INFO_PIECE_LEN, INFO_PIECE_MAX_COUNT, INFO_PIECE_PAYLOAD_LEN, INFO_PIECE_START,
    INFO_SNAPSHOT_MS, INFO_V2_PIECES, INFO_V3_PIECES,
};
pub use stream::{DecoderStats, Frame, Frames, StreamDecoder};
pub use stream_v2::{DecoderStatsV2, FrameV2, FramesV2, StreamDecoderV2};

/// Compiles and runs the README's examples as doctests, so the quick start stays true.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

/// `nb`, re-exported for `nb::block!` around [`SensorBoard::poll`] and for matching
/// `nb::Error::WouldBlock`.
pub use nb;
