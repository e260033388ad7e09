//! The 132-byte sensor packet, version 1: layout, field codecs, [`SensorPacket`] and
//! [`RawPacket`].
//!
//! | offset | content |
//! |---|---|
//! | 0-1 | `$$` start token (in the CRC) |
//! | 2-7 | accel X, Y, Z: 12-bit two's complement left-justified in an i16 LE |
//! | 8-13 | gyro X, Y, Z: i16 LE |
//! | 14-19 | mag X, Y (13-bit `<< 3`), Z (15-bit `<< 1`), i16 LE |
//! | 20-21 | mag RHALL, 14-bit unsigned `<< 2`, u16 LE |
//! | 22-24 | BMP280 pressure registers 0xF7..=0xF9 (MSB, LSB, XLSB) |
//! | 25-27 | BMP280 temperature registers 0xFA..=0xFC |
//! | 28-127 | the UBX NAV-PVT frame, 100 bytes ([`GnssFrame`]) |
//! | 128-131 | sensor CRC ([`crate::crc`]) over bytes 0-127, u32 LE |

use crate::crc::{SensorCrc, Stm32Crc};
use crate::gnss::{GnssFrame, NavPvt, GNSS_FRAME_LEN};

/// Total packet length on the wire.
pub const PACKET_LEN: usize = 132;

/// The start token, the first two bytes of every packet.
pub const PACKET_START: [u8; 2] = *b"$$";

/// Number of bytes the CRC covers (everything before the CRC).
pub const PACKET_CRC_COVERED: usize = 128;

/// Offset of the accelerometer X LSB.
pub const ACCEL_OFFSET: usize = 2;
/// Offset of the gyroscope X LSB.
pub const GYRO_OFFSET: usize = 8;
/// Offset of the magnetometer X LSB.
pub const MAG_OFFSET: usize = 14;
/// Offset of the magnetometer RHALL LSB.
pub const RHALL_OFFSET: usize = 20;
/// Offset of the BMP280 pressure MSB (register 0xF7).
pub const PRESSURE_OFFSET: usize = 22;
/// Offset of the BMP280 temperature MSB (register 0xFA).
pub const TEMPERATURE_OFFSET: usize = 25;
/// Offset of the 100-byte GNSS area.
pub const GNSS_OFFSET: usize = 28;
/// Offset of the CRC.
pub const CRC_OFFSET: usize = 128;

/// Smallest and largest accelerometer count (12-bit signed).
pub const ACCEL_RANGE: (i16, i16) = (-2048, 2047);
/// Smallest and largest magnetometer X/Y count (13-bit signed).
pub const MAG_XY_RANGE: (i16, i16) = (-4096, 4095);
/// Smallest and largest magnetometer Z count (15-bit signed).
pub const MAG_Z_RANGE: (i16, i16) = (-16384, 16383);
/// Largest RHALL count (14-bit unsigned).
pub const RHALL_MAX: u16 = 0x3FFF;
/// Largest raw BMP280 ADC value (20-bit unsigned).
pub const ADC20_MAX: u32 = 0xF_FFFF;

/// Why 132 bytes are not a valid packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PacketError {
    /// The first two bytes are not `$$`.
    StartToken,
    /// The CRC in bytes 128..=131 does not match the CRC of bytes 0..=127.
    Checksum {
        /// CRC computed over bytes 0..=127.
        computed: u32,
        /// CRC carried in the packet.
        received: u32,
    },
}

impl core::fmt::Display for PacketError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::StartToken => f.write_str("sensor packet does not start with `$$`"),
            Self::Checksum { computed, received } => write!(
                f,
                "sensor packet CRC mismatch: computed {computed:#010x}, received {received:#010x}"
            ),
        }
    }
}

impl core::error::Error for PacketError {}

/// One decoded sensor packet: every sensor value as the raw signed or unsigned count the chips
/// deliver (after the arithmetic shifts that undo the left justification), plus the GNSS area.
///
/// No physical units are applied here; see [`crate::units`] for the configured ranges and the
/// BMP280/BMM150 crates for compensation with the calibration from the info frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorPacket {
    /// Accelerometer X, Y, Z, signed 12-bit counts (-2048..=2047).
    pub accel: [i16; 3],
    /// Gyroscope X, Y, Z, signed 16-bit counts.
    pub gyro: [i16; 3],
    /// Magnetometer X, Y (13-bit, -4096..=4095) and Z (15-bit, -16384..=16383), signed counts.
    pub mag: [i16; 3],
    /// Magnetometer hall resistance, 14-bit unsigned count.
    pub rhall: u16,
    /// BMP280 raw pressure `adc_P`, 20 bits.
    pub press_raw: u32,
    /// BMP280 raw temperature `adc_T`, 20 bits.
    pub temp_raw: u32,
    /// The GNSS area (a NAV-PVT frame or zeros), exactly as on the wire.
    pub gnss: GnssFrame,
}

impl SensorPacket {
    /// Checks the start token and the CRC (software table CRC), then decodes the fields.
    ///
    /// # Errors
    /// [`PacketError::StartToken`] or [`PacketError::Checksum`]. A bad or empty GNSS area is not
    /// an error: [`SensorPacket::nav_pvt`] then returns `None`.
    pub fn decode(bytes: &[u8; PACKET_LEN]) -> Result<Self, PacketError> {
        RawPacket::new(*bytes).map(|raw| raw.decode())
    }

    /// Decodes the fields without checking the start token or the CRC.
    ///
    /// Every 132-byte input gives a packet; use this only on bytes that were validated already
    /// (for instance a [`RawPacket`]).
    #[must_use]
    pub fn decode_unchecked(bytes: &[u8; PACKET_LEN]) -> Self {
        let word = |at: usize| i16::from_le_bytes([bytes[at], bytes[at + 1]]);
        let axes = |base: usize, shift: [u32; 3]| {
            [
                word(base) >> shift[0],
                word(base + 2) >> shift[1],
                word(base + 4) >> shift[2],
            ]
        };
        let mut gnss = [0u8; GNSS_FRAME_LEN];
        gnss.copy_from_slice(&bytes[GNSS_OFFSET..GNSS_OFFSET + GNSS_FRAME_LEN]);
        Self {
            accel: axes(ACCEL_OFFSET, [4, 4, 4]),
            gyro: axes(GYRO_OFFSET, [0, 0, 0]),
            mag: axes(MAG_OFFSET, [3, 3, 1]),
            rhall: u16::from_le_bytes([bytes[RHALL_OFFSET], bytes[RHALL_OFFSET + 1]]) >> 2,
            press_raw: decode_adc20([
                bytes[PRESSURE_OFFSET],
                bytes[PRESSURE_OFFSET + 1],
                bytes[PRESSURE_OFFSET + 2],
            ]),
            temp_raw: decode_adc20([
                bytes[TEMPERATURE_OFFSET],
                bytes[TEMPERATURE_OFFSET + 1],
                bytes[TEMPERATURE_OFFSET + 2],
            ]),
            gnss: GnssFrame::from_bytes(gnss),
        }
    }

    /// Encodes the packet with the software CRC.
    ///
    /// Values outside a field's width saturate to the nearest representable count (see
    /// [`ACCEL_RANGE`], [`MAG_XY_RANGE`], [`MAG_Z_RANGE`], [`RHALL_MAX`], [`ADC20_MAX`]).
    #[must_use]
    pub fn encode(&self) -> [u8; PACKET_LEN] {
        self.encode_with(&mut Stm32Crc)
    }

    /// Encodes the packet, computing the CRC with `crc` (the hardware unit on the board).
    #[must_use]
    pub fn encode_with(&self, crc: &mut impl SensorCrc) -> [u8; PACKET_LEN] {
        let mut builder = crate::PacketBuilder::new();
        builder
            .accel(self.accel)
            .gyro(self.gyro)
            .mag(self.mag, self.rhall)
            .pressure_raw(self.press_raw)
            .temperature_raw(self.temp_raw)
            .gnss_frame(self.gnss.as_bytes());
        *builder.build(crc)
    }

    /// The typed NAV-PVT message, or `None` when the GNSS area is all zeros or not a valid
    /// NAV-PVT frame. Parses the 100 bytes on each call.
    #[must_use]
    pub fn nav_pvt(&self) -> Option<NavPvt> {
        self.gnss.nav_pvt()
    }
}

/// Decodes a BMP280 20-bit ADC value from its three registers (MSB, LSB, XLSB).
#[must_use]
pub const fn decode_adc20(registers: [u8; 3]) -> u32 {
    ((registers[0] as u32) << 12) | ((registers[1] as u32) << 4) | ((registers[2] as u32) >> 4)
}

/// Encodes a 20-bit ADC value as the BMP280's three registers (MSB, LSB, XLSB; the low nibble
/// of XLSB is zero). Values above [`ADC20_MAX`] saturate.
#[must_use]
pub const fn encode_adc20(value: u32) -> [u8; 3] {
    let value = if value > ADC20_MAX { ADC20_MAX } else { value };
    [
        (value >> 12) as u8,
        ((value >> 4) & 0xFF) as u8,
        ((value & 0x0F) << 4) as u8,
    ]
}

/// A 132-byte packet whose start token and CRC have been checked.
///
/// This is what the stream decoder hands out: the exact bytes (for logging and replay) with
/// a cheap, infallible [`RawPacket::decode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RawPacket([u8; PACKET_LEN]);

impl RawPacket {
    /// Validates `bytes` (start token and software CRC).
    ///
    /// # Errors
    /// [`PacketError::StartToken`] or [`PacketError::Checksum`].
    pub fn new(bytes: [u8; PACKET_LEN]) -> Result<Self, PacketError> {
        Self::new_with(bytes, &mut Stm32Crc)
    }

    /// Validates `bytes`, computing the CRC with `crc`.
    ///
    /// # Errors
    /// [`PacketError::StartToken`] or [`PacketError::Checksum`].
    pub fn new_with(
        bytes: [u8; PACKET_LEN],
        crc: &mut impl SensorCrc,
    ) -> Result<Self, PacketError> {
        if bytes[..2] != PACKET_START {
            return Err(PacketError::StartToken);
        }
        let computed = crc.checksum(&bytes[..PACKET_CRC_COVERED]);
        let received = u32::from_le_bytes([
            bytes[CRC_OFFSET],
            bytes[CRC_OFFSET + 1],
            bytes[CRC_OFFSET + 2],
            bytes[CRC_OFFSET + 3],
        ]);
        if computed == received {
            Ok(Self(bytes))
        } else {
            Err(PacketError::Checksum { computed, received })
        }
    }

    /// The 132 bytes exactly as received.
    #[must_use]
    pub const fn as_bytes(&self) -> &[u8; PACKET_LEN] {
        &self.0
    }

    /// The 132 bytes, by value.
    #[must_use]
    pub const fn into_bytes(self) -> [u8; PACKET_LEN] {
        self.0
    }

    /// The CRC carried in bytes 128..=131.
    #[must_use]
    pub const fn crc(&self) -> u32 {
        u32::from_le_bytes([
            self.0[CRC_OFFSET],
            self.0[CRC_OFFSET + 1],
            self.0[CRC_OFFSET + 2],
            self.0[CRC_OFFSET + 3],
        ])
    }

    /// Decodes the fields (never fails: the bytes were validated).
    #[must_use]
    pub fn decode(&self) -> SensorPacket {
        SensorPacket::decode_unchecked(&self.0)
    }
}

impl AsRef<[u8]> for RawPacket {
    fn as_ref(&self) -> &[u8] {
        &self.0
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for RawPacket {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "RawPacket({=[u8]:02x})", &self.0[..]);
    }
}
