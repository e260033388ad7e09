//! The 42-byte sensor packet, version 2, for a 2 kHz loop: [`PacketV2`] and [`RawPacketV2`].
//!
//! Version 1 carries the 100-byte NAV-PVT area in every packet (132 bytes); at 2 kHz that does
//! not fit the wire. Version 2 carries what changes every period, plus the request count and
//! the board's sample time, and sends the NAV-PVT frame in [`crate::GnssPiece`]s behind packets
//! only when a new one arrived. Layout (little-endian):
//!
//! | offset | size | content |
//! |---|---|---|
//! | 0-1 | 2 | start token `$P` (0x24 0x50) |
//! | 2-5 | 4 | request count: rising edges of the request line since boot, this answer's edge included (u32, wraps) |
//! | 6-9 | 4 | sample time: µs since boot when the IMU sample was read (u32, wraps after 71.6 min) |
//! | 10-29 | 20 | accelerometer, gyroscope, magnetometer X/Y/Z, RHALL words as in v1 ([`ImuPacketWords::to_le_bytes`]) |
//! | 30-32 | 3 | BMP280 pressure registers 0xF7..=0xF9 (MSB, LSB, XLSB), as in v1 |
//! | 33-35 | 3 | BMP280 temperature registers 0xFA..=0xFC, as in v1 |
//! | 36 | 1 | sensor status ([`SensorStatus`], the info frame's byte 7) |
//! | 37 | 1 | link flags ([`LinkFlags`]): bit 0 a GNSS piece follows, bit 1 an info piece follows; bits 2-7 zero |
//! | 38-41 | 4 | sensor CRC ([`crate::crc`], each byte a zero-extended word) over bytes 0-37, u32 |
//!
//! **Request count (u32).** The host counts the requests it sends, the board the edges it
//! sees; their difference (the offset) is fixed at the first answer, so the answer to this
//! cycle's edge carries the host's count minus the offset. An answer with a smaller count
//! that the expected one follows in the same cycle was late (an answer to an earlier edge:
//! stale). When the expected count does not come and the next cycles' answers stay behind by
//! the same m, the board missed m edges: the offset grows by m (the host counts them and
//! takes the new offset; [`RequestTracker`] does this). A count that restarts near zero means
//! the board reset. A u16 would wrap every 32.8 s at 2 kHz, which wrapping comparisons survive
//! but which makes a reset indistinguishable from a wrap in a log; a u32 wraps after 24.8
//! days for two more bytes (7 µs at 3 Mbaud).
//!
//! **Sample time (u32 µs).** Wraps every 2³² µs = 71.6 min. The host extends it to 64 bits by
//! adding the signed wrapping difference to the previous sample ([`SampleClock`]): correct
//! as long as two packets are less than 2³¹ µs (35.8 min) apart, which a 2 kHz loop always
//! is, and a late answer's older time steps back instead of forward by 71 min.
//!
//! **CRC.** The same 32-bit STM32 CRC as every other frame, through [`SensorCrc`], so the
//! board's hardware unit computes it; over 38 bytes it costs the board nothing a shorter CRC
//! would save, and the Hamming distance stays what v1 has.

use bitflags::bitflags;
use bosch_bmx055::mag::MagPacketWords;
use bosch_bmx055::Xyz;

use crate::crc::{SensorCrc, Stm32Crc};
use crate::imu::{ImuPacketWords, IMU_LEN};
use crate::info::SensorStatus;
use crate::packet::{decode_adc20, encode_adc20};

/// Total length of a version 2 packet on the wire.
pub const PACKET_V2_LEN: usize = 42;

/// The start token of a version 2 packet.
pub const PACKET_V2_START: [u8; 2] = *b"$P";

/// Offset of the request count.
pub const V2_REQUEST_COUNT_OFFSET: usize = 2;
/// Offset of the sample time.
pub const V2_SAMPLE_TIME_OFFSET: usize = 6;
/// Offset of the first BMX055 byte (accelerometer X LSB).
pub const V2_IMU_OFFSET: usize = 10;
/// Offset of the BMP280 pressure MSB.
pub const V2_PRESSURE_OFFSET: usize = V2_IMU_OFFSET + IMU_LEN;
/// Offset of the BMP280 temperature MSB.
pub const V2_TEMPERATURE_OFFSET: usize = V2_PRESSURE_OFFSET + 3;
/// Offset of the sensor status byte.
pub const V2_STATUS_OFFSET: usize = V2_TEMPERATURE_OFFSET + 3;
/// Offset of the link flags byte.
pub const V2_FLAGS_OFFSET: usize = V2_STATUS_OFFSET + 1;
/// Offset of the CRC (also the number of bytes it covers).
pub const V2_CRC_OFFSET: usize = V2_FLAGS_OFFSET + 1;

bitflags! {
    /// What the board sends behind this packet, packet v2 byte 37.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
    pub struct LinkFlags: u8 {
        /// A GNSS piece ([`crate::GnssPiece`]) follows this packet.
        const GNSS_PIECE_FOLLOWS = 1 << 0;
        /// An info piece ([`crate::InfoPiece`]) follows this packet.
        const INFO_PIECE_FOLLOWS = 1 << 1;
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for LinkFlags {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "LinkFlags({=u8:#04x})", self.bits());
    }
}

/// Why bytes are not a valid version 2 packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PacketV2Error {
    /// Fewer than [`PACKET_V2_LEN`] bytes.
    Truncated,
    /// The first two bytes are not `$P`.
    StartToken,
    /// The CRC in bytes 38-41 does not match the CRC of bytes 0-37.
    Checksum {
        /// CRC computed over bytes 0-37.
        computed: u32,
        /// CRC carried in the packet.
        received: u32,
    },
}

impl core::fmt::Display for PacketV2Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Truncated => write!(f, "packet v2 truncated: needs {PACKET_V2_LEN} bytes"),
            Self::StartToken => f.write_str("packet v2 does not start with `$P`"),
            Self::Checksum { computed, received } => write!(
                f,
                "packet v2 CRC mismatch: computed {computed:#010x}, received {received:#010x}"
            ),
        }
    }
}

impl core::error::Error for PacketV2Error {}

/// One version 2 sensor packet.
///
/// Sensor values are the words and raw ADC values v1 carries; see [`crate::units`] and the
/// BMX055/BMP280 crates for physical units.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PacketV2 {
    /// Rising edges of the request line the board has seen since boot (wraps).
    pub request_count: u32,
    /// µs since the board's boot when the IMU sample was read (wraps after 71.6 min).
    pub sample_time_us: u32,
    /// Accelerometer, gyroscope and magnetometer words, as v1 carries them.
    pub imu: ImuPacketWords,
    /// BMP280 raw pressure `adc_P`, 20 bits (larger values saturate when encoded).
    pub press_raw: u32,
    /// BMP280 raw temperature `adc_T`, 20 bits (larger values saturate when encoded).
    pub temp_raw: u32,
    /// Sensor health, the info frame's status bits.
    pub status: SensorStatus,
    /// What follows this packet on the wire.
    pub flags: LinkFlags,
}

/// Reads a little-endian u32 at `at` (the caller checked the length).
fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

impl PacketV2 {
    /// The wire bytes, the CRC computed by `crc` (the hardware unit on the board).
    ///
    /// The IMU words are written as given ([`ImuPacketWords::to_le_bytes`]); words built from
    /// register reads or by [`ImuPacketWords::from_le_bytes`] have their status bits masked
    /// already.
    #[must_use]
    pub fn encode(&self, crc: &mut impl SensorCrc) -> [u8; PACKET_V2_LEN] {
        let mut bytes = [0u8; PACKET_V2_LEN];
        bytes[..2].copy_from_slice(&PACKET_V2_START);
        bytes[V2_REQUEST_COUNT_OFFSET..V2_REQUEST_COUNT_OFFSET + 4]
            .copy_from_slice(&self.request_count.to_le_bytes());
        bytes[V2_SAMPLE_TIME_OFFSET..V2_SAMPLE_TIME_OFFSET + 4]
            .copy_from_slice(&self.sample_time_us.to_le_bytes());
        bytes[V2_IMU_OFFSET..V2_IMU_OFFSET + IMU_LEN].copy_from_slice(&self.imu.to_le_bytes());
        bytes[V2_PRESSURE_OFFSET..V2_PRESSURE_OFFSET + 3]
            .copy_from_slice(&encode_adc20(self.press_raw));
        bytes[V2_TEMPERATURE_OFFSET..V2_TEMPERATURE_OFFSET + 3]
            .copy_from_slice(&encode_adc20(self.temp_raw));
        bytes[V2_STATUS_OFFSET] = self.status.bits();
        bytes[V2_FLAGS_OFFSET] = self.flags.bits();
        let value = crc.checksum(&bytes[..V2_CRC_OFFSET]);
        bytes[V2_CRC_OFFSET..].copy_from_slice(&value.to_le_bytes());
        bytes
    }

    /// Checks the length, start token and CRC (software CRC) of the packet at the start of
    /// `bytes` (bytes after it are ignored) and decodes it. Total: any bytes give a packet or
    /// an error.
    ///
    /// # Errors
    /// Any [`PacketV2Error`].
    pub fn decode(bytes: &[u8]) -> Result<Self, PacketV2Error> {
        Self::decode_with(bytes, &mut Stm32Crc)
    }

    /// [`PacketV2::decode`] with the CRC computed by `crc`.
    ///
    /// # Errors
    /// Any [`PacketV2Error`].
    pub fn decode_with(bytes: &[u8], crc: &mut impl SensorCrc) -> Result<Self, PacketV2Error> {
        RawPacketV2::new_with(bytes, crc).map(|raw| raw.decode())
    }

    /// Decodes the fields of `bytes` without checking the start token or the CRC. Status bits
    /// in the IMU words and the BMP280 XLSB low nibbles are masked, unknown flag bits dropped.
    #[must_use]
    pub fn decode_unchecked(bytes: &[u8; PACKET_V2_LEN]) -> Self {
        let mut imu = [0u8; IMU_LEN];
        imu.copy_from_slice(&bytes[V2_IMU_OFFSET..V2_IMU_OFFSET + IMU_LEN]);
        let adc = |at: usize| decode_adc20([bytes[at], bytes[at + 1], bytes[at + 2]]);
        Self {
            request_count: u32_at(bytes, V2_REQUEST_COUNT_OFFSET),
            sample_time_us: u32_at(bytes, V2_SAMPLE_TIME_OFFSET),
            imu: ImuPacketWords::from_le_bytes(&imu),
            press_raw: adc(V2_PRESSURE_OFFSET),
            temp_raw: adc(V2_TEMPERATURE_OFFSET),
            status: SensorStatus::from_bits_retain(bytes[V2_STATUS_OFFSET]),
            flags: LinkFlags::from_bits_truncate(bytes[V2_FLAGS_OFFSET]),
        }
    }

    /// Accelerometer, gyroscope and magnetometer as the signed counts v1's [`SensorPacket`]
    /// gives (accelerometer `>> 4`, magnetometer X/Y `>> 3`, Z `>> 1`) and RHALL `>> 2`.
    ///
    /// [`SensorPacket`]: crate::SensorPacket
    #[must_use]
    pub fn imu_counts(&self) -> ([i16; 3], [i16; 3], [i16; 3], u16) {
        let Xyz { x, y, z } = self.imu.accel;
        let gyro = self.imu.gyro;
        let MagPacketWords { xyz, rhall } = self.imu.mag;
        (
            [x >> 4, y >> 4, z >> 4],
            [gyro.x, gyro.y, gyro.z],
            [xyz.x >> 3, xyz.y >> 3, xyz.z >> 1],
            rhall >> 2,
        )
    }
}

/// A version 2 packet whose start token and CRC have been checked: the exact bytes (for
/// logging and replay) with an infallible [`RawPacketV2::decode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RawPacketV2([u8; PACKET_V2_LEN]);

impl RawPacketV2 {
    /// Validates the packet at the start of `bytes` (length, start token, software CRC).
    ///
    /// # Errors
    /// Any [`PacketV2Error`].
    pub fn new(bytes: &[u8]) -> Result<Self, PacketV2Error> {
        Self::new_with(bytes, &mut Stm32Crc)
    }

    /// Validates the packet at the start of `bytes`, computing the CRC with `crc`.
    ///
    /// # Errors
    /// Any [`PacketV2Error`].
    pub fn new_with(bytes: &[u8], crc: &mut impl SensorCrc) -> Result<Self, PacketV2Error> {
        let bytes = bytes.get(..PACKET_V2_LEN).ok_or(PacketV2Error::Truncated)?;
        if bytes[..2] != PACKET_V2_START {
            return Err(PacketV2Error::StartToken);
        }
        let computed = crc.checksum(&bytes[..V2_CRC_OFFSET]);
        let received = u32_at(bytes, V2_CRC_OFFSET);
        if computed != received {
            return Err(PacketV2Error::Checksum { computed, received });
        }
        let mut out = [0u8; PACKET_V2_LEN];
        out.copy_from_slice(bytes);
        Ok(Self(out))
    }

    /// The 42 bytes exactly as received.
    #[must_use]
    pub const fn as_bytes(&self) -> &[u8; PACKET_V2_LEN] {
        &self.0
    }

    /// The 42 bytes, by value.
    #[must_use]
    pub const fn into_bytes(self) -> [u8; PACKET_V2_LEN] {
        self.0
    }

    /// Decodes the fields (never fails: the bytes were validated).
    #[must_use]
    pub fn decode(&self) -> PacketV2 {
        PacketV2::decode_unchecked(&self.0)
    }
}

impl AsRef<[u8]> for RawPacketV2 {
    fn as_ref(&self) -> &[u8] {
        &self.0
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for RawPacketV2 {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "RawPacketV2({=[u8]:02x})", &self.0[..]);
    }
}

/// Host side: extends the board's wrapping 32-bit sample time to 64 bits.
///
/// Each sample adds the signed wrapping difference to the previous one, so the result is right
/// as long as consecutive samples are less than 2³¹ µs (35.8 min) apart; a sample older than
/// the previous one (a late answer) steps back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SampleClock {
    last: Option<(u32, u64)>,
}

impl SampleClock {
    /// No sample seen yet: the first one is taken as it is.
    #[must_use]
    pub const fn new() -> Self {
        Self { last: None }
    }

    /// The 64-bit µs since boot of a packet's `sample_time_us`.
    pub fn extend(&mut self, sample_time_us: u32) -> u64 {
        let extended = match self.last {
            None => u64::from(sample_time_us),
            Some((raw, extended)) => {
                // The signed wrapping difference: a step back (a late answer) stays small.
                let step = sample_time_us.wrapping_sub(raw) as i32;
                extended.wrapping_add_signed(i64::from(step))
            }
        };
        self.last = Some((sample_time_us, extended));
        extended
    }
}

/// How an answer's request count relates to the request the host raised this cycle
/// ([`RequestTracker::classify`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AnswerMatch {
    /// The answer to this cycle's request.
    Current,
    /// A count this many edges behind: a late answer to an earlier request, or, when the
    /// following cycles stay behind by as much, a board that missed edges
    /// ([`RequestTracker::end_cycle`] tells which).
    Behind(u32),
    /// A count ahead of the requests sent, or more than [`RequestTracker::MAX_BEHIND`]
    /// behind: the board reset (or the link was down for long); the tracker takes this
    /// answer's count as the new reference.
    Resynced,
}

/// Host side: matches answers to the requests sent, by the packet's request count.
///
/// The host numbers its requests (any wrapping u32, one more per request) and gives each
/// answer's count to [`classify`](Self::classify) with the number of this cycle's request,
/// then calls [`end_cycle`](Self::end_cycle) once per cycle. The offset between the two
/// counts is taken at the first answer (and again after a [`AnswerMatch::Resynced`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RequestTracker {
    offset: Option<u32>,
    current_seen: bool,
    /// How far behind the last answer of this cycle was, if it was behind.
    last_behind: Option<u32>,
    /// The same for the previous cycle that ended without a current answer.
    previous_behind: Option<u32>,
    missed_edges: u64,
}

impl RequestTracker {
    /// Counts further behind than this are taken as a board reset.
    pub const MAX_BEHIND: u32 = 1 << 16;

    /// No answer seen yet.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            offset: None,
            current_seen: false,
            last_behind: None,
            previous_behind: None,
            missed_edges: 0,
        }
    }

    /// Classifies an answer with request count `count` received while `sent` is the number of
    /// the request the host raised this cycle.
    pub fn classify(&mut self, sent: u32, count: u32) -> AnswerMatch {
        let offset = *self.offset.get_or_insert(sent.wrapping_sub(count));
        let behind = sent.wrapping_sub(offset).wrapping_sub(count);
        let matched = match behind {
            0 => AnswerMatch::Current,
            1..=Self::MAX_BEHIND => AnswerMatch::Behind(behind),
            _ => {
                self.offset = Some(sent.wrapping_sub(count));
                self.previous_behind = None;
                AnswerMatch::Resynced
            }
        };
        self.current_seen |= matches!(matched, AnswerMatch::Current | AnswerMatch::Resynced);
        self.last_behind = match matched {
            AnswerMatch::Behind(m) => Some(m),
            AnswerMatch::Current | AnswerMatch::Resynced => None,
        };
        matched
    }

    /// Ends the cycle; returns the edges the board is now known to have missed.
    ///
    /// A cycle whose last answer was `m` behind, with no current answer, after a cycle that
    /// ended the same way with the same `m`, means the board missed `m` edges: they are
    /// counted and the offset moves by `m`, so the next answer is current again. A cycle
    /// with a current answer clears the suspicion (the answers behind it were late); a cycle
    /// with no answer at all leaves it as it was.
    pub fn end_cycle(&mut self) -> u32 {
        let mut missed = 0;
        if self.current_seen {
            self.previous_behind = None;
        } else if let Some(m) = self.last_behind {
            if self.previous_behind == Some(m) {
                self.offset = self.offset.map(|offset| offset.wrapping_add(m));
                self.missed_edges = self.missed_edges.wrapping_add(u64::from(m));
                self.previous_behind = None;
                missed = m;
            } else {
                self.previous_behind = Some(m);
            }
        }
        self.current_seen = false;
        self.last_behind = None;
        missed
    }

    /// Edges the board missed since the tracker was created (wraps).
    #[must_use]
    pub const fn missed_edges(&self) -> u64 {
        self.missed_edges
    }
}
