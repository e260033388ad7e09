//! The info frame: calibration and health, sent next to the unchanged v1 packet.
//!
//! Layout of version 1 (60 bytes, multi-byte fields little-endian):
//!
//! | offset | size | content |
//! |---|---|---|
//! | 0-1 | 2 | start token `$I` (0x24 0x49) |
//! | 2 | 1 | format version = 1 |
//! | 3 | 1 | payload length L = 52 |
//! | 4-6 | 3 | firmware version major, minor, patch |
//! | 7 | 1 | sensor status bits ([`SensorStatus`]) |
//! | 8-31 | 24 | BMP280 calibration registers 0x88..=0x9F as read |
//! | 32-47 | 16 | BMM150 trim registers 0x5D..=0x5E, 0x62..=0x65, 0x68..=0x71 as read |
//! | 48-51 | 4 | uptime, ms (u32) |
//! | 52-55 | 4 | requests skipped because a transfer was still running (u32) |
//! | 56-59 | 4 | sensor CRC ([`crate::crc`]) over bytes 0-55, u32 LE |
//!
//! **Trigger.** Boards before info pieces appended an info frame right after the packet (same
//! answer, packet first) in answer to the first request after boot, and to any request that
//! arrives 500 ms or more after the previous one. At 250 Hz a version 2 frame behind a packet
//! outlasts the period and costs the next request, so the current firmware sends it cut into
//! info pieces instead ([`crate::InfoPiece`]). No board sends anything unrequested.
//!
//! **Version 2** (108 bytes, L = 100) is version 1 with the board's health after byte 55 (the
//! CRC moves to bytes 104-107), every counter wrapping, ages saturating:
//!
//! | offset | size | content ([`BoardHealth`]) |
//! |---|---|---|
//! | 56-71 | 4 x 4 | SPI errors after boot: accelerometer, gyroscope, magnetometer, BMP280 (u32 each) |
//! | 72-75 | 4 | magnetometer measurements that never became ready (u32) |
//! | 76-79 | 4 | DMA transfer errors on the link (u32) |
//! | 80-83 | 4 | requests that came before the first packet existed (u32) |
//! | 84-87 | 4 | GNSS bytes dropped outside a valid UBX frame (u32) |
//! | 88-91 | 4 | GNSS frames with a bad checksum (u32) |
//! | 92-95 | 4 | watchdog resets since power-on (u32) |
//! | 96-103 | 4 x 2 | ms since the last good read: accelerometer, gyroscope, magnetometer, BMP280 (u16, 65535 = never or longer) |
//!
//! **Version 3** (128 bytes, L = 120) is version 2 with the board's faults after byte 103 (the
//! CRC moves to bytes 124-127), counters wrapping:
//!
//! | offset | size | content ([`BoardFaults`]) |
//! |---|---|---|
//! | 104-107 | 4 | GNSS UART overrun errors (u32) |
//! | 108-111 | 4 | GNSS UART framing errors (u32) |
//! | 112-115 | 4 | GNSS UART noise errors (u32) |
//! | 116-119 | 4 | sampling ticks that ran into the next period (u32) |
//! | 120 | 1 | the fault that reset the previous boot: 0 none, 1 link USART, 2 GNSS USART, 3 sampling timer, 4 panic |
//! | 121-123 | 3 | reserved, zero |
//!
//! A version 1 frame decodes with every health field zero, a version 1 or 2 frame with every
//! fault field zero. A version 2 decoder reads a version 3 frame's first 104 bytes as
//! version 2 and skips the rest.
//!
//! **Future versions.** Decoders accept a version other than 1 with a larger L: the CRC covers
//! the 4 header bytes and all L payload bytes, the first 52 payload bytes are read as above and
//! the rest are skipped. L is capped at [`INFO_MAX_PAYLOAD_LEN`] so memory stays bounded.

use bitflags::bitflags;

use crate::crc::{SensorCrc, Stm32Crc};

/// The start token of an info frame.
pub const INFO_START: [u8; 2] = *b"$I";

/// The format version this crate writes.
pub const INFO_VERSION: u8 = 1;

/// Payload length L of a version 1 frame (bytes 4..=55).
pub const INFO_V1_PAYLOAD_LEN: u8 = 52;

/// Total length of a version 1 frame.
pub const INFO_V1_LEN: usize = 4 + INFO_V1_PAYLOAD_LEN as usize + 4;

/// Payload length L of a version 2 frame (version 1 plus [`BoardHealth`]).
pub const INFO_V2_PAYLOAD_LEN: u8 = INFO_V1_PAYLOAD_LEN + BoardHealth::LEN as u8;

/// Total length of a version 2 frame.
pub const INFO_V2_LEN: usize = 4 + INFO_V2_PAYLOAD_LEN as usize + 4;

/// Payload length L of a version 3 frame (version 2 plus [`BoardFaults`]).
pub const INFO_V3_PAYLOAD_LEN: u8 = INFO_V2_PAYLOAD_LEN + BoardFaults::LEN as u8;

/// Total length of a version 3 frame.
pub const INFO_V3_LEN: usize = 4 + INFO_V3_PAYLOAD_LEN as usize + 4;

/// Largest payload length L a decoder accepts (from a future version). Longer claims are
/// treated as a corrupt header.
pub const INFO_MAX_PAYLOAD_LEN: u8 = 200;

/// Largest info frame a decoder accepts, in bytes.
pub const INFO_MAX_LEN: usize = 4 + INFO_MAX_PAYLOAD_LEN as usize + 4;

bitflags! {
    /// Health of the board's sensors, info frame byte 7.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
    pub struct SensorStatus: u8 {
        /// The accelerometer answered with its chip id and was configured.
        const ACCEL_OK = 1 << 0;
        /// The gyroscope answered with its chip id and was configured.
        const GYRO_OK = 1 << 1;
        /// The magnetometer answered with its chip id and was configured.
        const MAG_OK = 1 << 2;
        /// The BMP280 answered with its chip id and was configured.
        const BMP280_OK = 1 << 3;
        /// At least one valid NAV-PVT frame arrived from the GNSS receiver.
        const GNSS_SEEN = 1 << 4;
        /// The last reset was caused by the independent watchdog.
        const WATCHDOG_RESET = 1 << 5;
        /// The STM32 CRC unit failed its boot-time self-check (the reference vector
        /// `0x6557DE1A`): the board computes CRCs in software instead.
        const CRC_UNIT_FAILED = 1 << 6;
        /// No byte from the GNSS receiver for a second (a silent receiver is reported, not a
        /// reason to reset the board).
        const GNSS_SILENT = 1 << 7;
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for SensorStatus {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "SensorStatus({=u8:#04x})", self.bits());
    }
}

/// Why bytes are not a valid info frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InfoError {
    /// The first two bytes are not `$I`.
    StartToken,
    /// Version 0, or L smaller than the version 1 payload or above [`INFO_MAX_PAYLOAD_LEN`].
    Header {
        /// Format version byte.
        version: u8,
        /// Payload length byte.
        payload_len: u8,
    },
    /// Fewer bytes than the header announces.
    Truncated {
        /// Bytes the frame needs in total.
        needed: usize,
    },
    /// The CRC does not match.
    Checksum {
        /// CRC computed over the header and payload.
        computed: u32,
        /// CRC carried in the frame.
        received: u32,
    },
}

impl core::fmt::Display for InfoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::StartToken => f.write_str("info frame does not start with `$I`"),
            Self::Header {
                version,
                payload_len,
            } => write!(
                f,
                "info frame header not accepted: version {version}, payload length {payload_len}"
            ),
            Self::Truncated { needed } => write!(f, "info frame truncated: needs {needed} bytes"),
            Self::Checksum { computed, received } => write!(
                f,
                "info frame CRC mismatch: computed {computed:#010x}, received {received:#010x}"
            ),
        }
    }
}

impl core::error::Error for InfoError {}

/// Checks the 4 header bytes of an info frame and returns its total length.
///
/// # Errors
/// [`InfoError::StartToken`] or [`InfoError::Header`].
pub fn info_frame_len(header: [u8; 4]) -> Result<usize, InfoError> {
    if header[..2] != INFO_START {
        return Err(InfoError::StartToken);
    }
    let (version, payload_len) = (header[2], header[3]);
    if version == 0 || !(INFO_V1_PAYLOAD_LEN..=INFO_MAX_PAYLOAD_LEN).contains(&payload_len) {
        return Err(InfoError::Header {
            version,
            payload_len,
        });
    }
    Ok(4 + usize::from(payload_len) + 4)
}

/// Calibration and health of the sensor board.
///
/// `Default` is a version 1 frame ([`INFO_VERSION`]) with every other field zero, so a frame
/// built with `..InfoFrame::default()` is one every decoder accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InfoFrame {
    /// Format version of the frame as received (1 for frames this crate writes).
    pub version: u8,
    /// Firmware version: major, minor, patch.
    pub firmware: [u8; 3],
    /// Sensor status bits. Bits this crate does not know are kept.
    pub status: SensorStatus,
    /// BMP280 calibration registers 0x88..=0x9F, exactly as read (dig_T1..dig_P9, LE).
    pub bmp280_calibration: [u8; 24],
    /// BMM150 trim registers as read: 0x5D..=0x5E (2 bytes), 0x62..=0x65 (4), 0x68..=0x71 (10).
    pub bmm150_trim: [u8; 16],
    /// Time since the board's last reset, ms (wraps after about 49.7 days).
    pub uptime_ms: u32,
    /// Requests the board ignored because the previous transfer was still running.
    pub requests_skipped: u32,
    /// Health counters (version 2 frames; zero in version 1 frames).
    pub health: BoardHealth,
    /// Fault counters and the last reset's fault (version 3 frames; zero before).
    pub faults: BoardFaults,
}

/// What the board counts beyond [`BoardHealth`] (info frame version 3): errors on the GNSS
/// UART, sampling ticks that overran, and the fault that reset the previous boot. Counters
/// wrap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BoardFaults {
    /// Bytes the GNSS UART lost because the previous one had not been read (overrun).
    pub gnss_overrun_errors: u32,
    /// GNSS bytes with a framing error (no stop bit where one belongs).
    pub gnss_framing_errors: u32,
    /// GNSS bytes with noise detected on the line.
    pub gnss_noise_errors: u32,
    /// Sampling ticks that were still running when the next period began (the next tick
    /// ran late, or was lost if it overran again).
    pub sample_overruns: u32,
    /// The fault that reset the previous boot, reported once after it: 0 none, 1 link USART
    /// rejected its settings, 2 GNSS USART, 3 sampling timer, 4 panic.
    pub reset_fault: u8,
}

impl BoardFaults {
    /// Encoded length, bytes (3 of them reserved).
    pub const LEN: usize = 4 * 4 + 4;

    /// The wire bytes (info frame version 3, bytes 104..124).
    #[must_use]
    pub fn to_bytes(&self) -> [u8; Self::LEN] {
        let mut bytes = [0u8; Self::LEN];
        let counters = [
            self.gnss_overrun_errors,
            self.gnss_framing_errors,
            self.gnss_noise_errors,
            self.sample_overruns,
        ];
        for (slot, value) in bytes.chunks_exact_mut(4).zip(counters) {
            slot.copy_from_slice(&value.to_le_bytes());
        }
        bytes[16] = self.reset_fault;
        bytes
    }

    /// Reads the wire bytes (the reserved ones are ignored).
    #[must_use]
    pub fn from_bytes(bytes: &[u8; Self::LEN]) -> Self {
        let u32_at = |i: usize| {
            u32::from_le_bytes([
                bytes[4 * i],
                bytes[4 * i + 1],
                bytes[4 * i + 2],
                bytes[4 * i + 3],
            ])
        };
        Self {
            gnss_overrun_errors: u32_at(0),
            gnss_framing_errors: u32_at(1),
            gnss_noise_errors: u32_at(2),
            sample_overruns: u32_at(3),
            reset_fault: bytes[16],
        }
    }
}

/// What went wrong on the board after boot, and how fresh each sensor's data are (info frame
/// version 2). Counters wrap; ages saturate at `u16::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BoardHealth {
    /// Failed SPI transfers with the accelerometer.
    pub accel_errors: u32,
    /// Failed SPI transfers with the gyroscope.
    pub gyro_errors: u32,
    /// Failed SPI transfers with the magnetometer.
    pub mag_errors: u32,
    /// Failed SPI transfers with the BMP280.
    pub bmp280_errors: u32,
    /// Magnetometer measurements that never became ready (retriggered).
    pub mag_timeout_errors: u32,
    /// DMA transfer errors on the link to the host.
    pub dma_errors: u32,
    /// Requests that came before the first packet existed (answered with nothing).
    pub requests_early: u32,
    /// GNSS bytes dropped because they were not part of a valid UBX frame.
    pub gnss_bytes_dropped: u32,
    /// GNSS UBX frames with a bad checksum.
    pub gnss_frame_errors: u32,
    /// Resets by the watchdog since power-on.
    pub watchdog_resets: u32,
    /// Time since the accelerometer was last read successfully, ms.
    pub accel_age_ms: u16,
    /// Time since the gyroscope was last read successfully, ms.
    pub gyro_age_ms: u16,
    /// Time since the magnetometer data were last read successfully, ms.
    pub mag_age_ms: u16,
    /// Time since the BMP280 was last read successfully, ms.
    pub bmp280_age_ms: u16,
}

impl BoardHealth {
    /// Encoded length, bytes.
    pub const LEN: usize = 10 * 4 + 4 * 2;

    fn counters(&self) -> [u32; 10] {
        [
            self.accel_errors,
            self.gyro_errors,
            self.mag_errors,
            self.bmp280_errors,
            self.mag_timeout_errors,
            self.dma_errors,
            self.requests_early,
            self.gnss_bytes_dropped,
            self.gnss_frame_errors,
            self.watchdog_resets,
        ]
    }

    fn ages(&self) -> [u16; 4] {
        [
            self.accel_age_ms,
            self.gyro_age_ms,
            self.mag_age_ms,
            self.bmp280_age_ms,
        ]
    }

    /// The wire bytes (info frame version 2, bytes 56..104).
    #[must_use]
    pub fn to_bytes(&self) -> [u8; Self::LEN] {
        let mut bytes = [0u8; Self::LEN];
        for (slot, value) in bytes.chunks_exact_mut(4).zip(self.counters()) {
            slot.copy_from_slice(&value.to_le_bytes());
        }
        for (slot, value) in bytes[40..].chunks_exact_mut(2).zip(self.ages()) {
            slot.copy_from_slice(&value.to_le_bytes());
        }
        bytes
    }

    /// Reads the wire bytes.
    #[must_use]
    pub fn from_bytes(bytes: &[u8; Self::LEN]) -> Self {
        let u32_at = |i: usize| {
            u32::from_le_bytes([
                bytes[4 * i],
                bytes[4 * i + 1],
                bytes[4 * i + 2],
                bytes[4 * i + 3],
            ])
        };
        let u16_at = |i: usize| u16::from_le_bytes([bytes[40 + 2 * i], bytes[41 + 2 * i]]);
        Self {
            accel_errors: u32_at(0),
            gyro_errors: u32_at(1),
            mag_errors: u32_at(2),
            bmp280_errors: u32_at(3),
            mag_timeout_errors: u32_at(4),
            dma_errors: u32_at(5),
            requests_early: u32_at(6),
            gnss_bytes_dropped: u32_at(7),
            gnss_frame_errors: u32_at(8),
            watchdog_resets: u32_at(9),
            accel_age_ms: u16_at(0),
            gyro_age_ms: u16_at(1),
            mag_age_ms: u16_at(2),
            bmp280_age_ms: u16_at(3),
        }
    }
}

impl Default for InfoFrame {
    fn default() -> Self {
        Self {
            version: INFO_VERSION,
            firmware: [0; 3],
            status: SensorStatus::empty(),
            bmp280_calibration: [0; 24],
            bmm150_trim: [0; 16],
            uptime_ms: 0,
            requests_skipped: 0,
            health: BoardHealth {
                accel_errors: 0,
                gyro_errors: 0,
                mag_errors: 0,
                bmp280_errors: 0,
                mag_timeout_errors: 0,
                dma_errors: 0,
                requests_early: 0,
                gnss_bytes_dropped: 0,
                gnss_frame_errors: 0,
                watchdog_resets: 0,
                accel_age_ms: 0,
                gyro_age_ms: 0,
                mag_age_ms: 0,
                bmp280_age_ms: 0,
            },
            faults: BoardFaults::default(),
        }
    }
}

impl InfoFrame {
    /// Encodes a 60-byte frame with L = 52 and the software CRC. The `version` field is written
    /// as it is; frames meant for the wire use [`INFO_VERSION`].
    #[must_use]
    pub fn encode(&self) -> [u8; INFO_V1_LEN] {
        self.encode_with(&mut Stm32Crc)
    }

    /// Encodes the frame, computing the CRC with `crc` (the hardware unit on the board).
    #[must_use]
    pub fn encode_with(&self, crc: &mut impl SensorCrc) -> [u8; INFO_V1_LEN] {
        let mut bytes = [0u8; INFO_V1_LEN];
        bytes[..2].copy_from_slice(&INFO_START);
        bytes[2] = self.version;
        bytes[3] = INFO_V1_PAYLOAD_LEN;
        bytes[4..7].copy_from_slice(&self.firmware);
        bytes[7] = self.status.bits();
        bytes[8..32].copy_from_slice(&self.bmp280_calibration);
        bytes[32..48].copy_from_slice(&self.bmm150_trim);
        bytes[48..52].copy_from_slice(&self.uptime_ms.to_le_bytes());
        bytes[52..56].copy_from_slice(&self.requests_skipped.to_le_bytes());
        let value = crc.checksum(&bytes[..56]);
        bytes[56..].copy_from_slice(&value.to_le_bytes());
        bytes
    }

    /// Encodes a 108-byte version 2 frame (L = 100: version 1 plus [`BoardHealth`]) with the
    /// CRC from `crc`. The `version` field is ignored: the frame says 2.
    #[must_use]
    pub fn encode_v2_with(&self, crc: &mut impl SensorCrc) -> [u8; INFO_V2_LEN] {
        let mut bytes = [0u8; INFO_V2_LEN];
        let v1 = Self {
            version: 2,
            ..*self
        }
        .encode_with(&mut NoCrc);
        bytes[..56].copy_from_slice(&v1[..56]);
        bytes[3] = INFO_V2_PAYLOAD_LEN;
        bytes[56..INFO_V2_LEN - 4].copy_from_slice(&self.health.to_bytes());
        let value = crc.checksum(&bytes[..INFO_V2_LEN - 4]);
        bytes[INFO_V2_LEN - 4..].copy_from_slice(&value.to_le_bytes());
        bytes
    }

    /// Encodes a 128-byte version 3 frame (L = 120: version 2 plus [`BoardFaults`]) with the
    /// CRC from `crc`. The `version` field is ignored: the frame says 3.
    #[must_use]
    pub fn encode_v3_with(&self, crc: &mut impl SensorCrc) -> [u8; INFO_V3_LEN] {
        let mut bytes = [0u8; INFO_V3_LEN];
        let v2 = self.encode_v2_with(&mut NoCrc);
        bytes[..INFO_V2_LEN - 4].copy_from_slice(&v2[..INFO_V2_LEN - 4]);
        bytes[2] = 3;
        bytes[3] = INFO_V3_PAYLOAD_LEN;
        bytes[INFO_V2_LEN - 4..INFO_V3_LEN - 4].copy_from_slice(&self.faults.to_bytes());
        let value = crc.checksum(&bytes[..INFO_V3_LEN - 4]);
        bytes[INFO_V3_LEN - 4..].copy_from_slice(&value.to_le_bytes());
        bytes
    }

    /// Decodes the frame at the start of `bytes` and returns it with its length on the wire.
    /// Bytes after the frame are ignored.
    ///
    /// # Errors
    /// Any [`InfoError`].
    pub fn decode(bytes: &[u8]) -> Result<(Self, usize), InfoError> {
        Self::decode_with(bytes, &mut Stm32Crc)
    }

    /// Like [`InfoFrame::decode`], computing the CRC with `crc`.
    ///
    /// # Errors
    /// Any [`InfoError`].
    pub fn decode_with(bytes: &[u8], crc: &mut impl SensorCrc) -> Result<(Self, usize), InfoError> {
        let header = match bytes.get(..4) {
            Some(&[a, b, c, d]) => [a, b, c, d],
            _ => {
                return Err(if bytes.len() >= 2 && bytes[..2] != INFO_START {
                    InfoError::StartToken
                } else {
                    InfoError::Truncated { needed: 4 }
                })
            }
        };
        let len = info_frame_len(header)?;
        let frame = bytes
            .get(..len)
            .ok_or(InfoError::Truncated { needed: len })?;
        let (covered, tail) = frame.split_at(len - 4);
        let received = u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]);
        let computed = crc.checksum(covered);
        if computed != received {
            return Err(InfoError::Checksum { computed, received });
        }
        Ok((Self::from_checked(frame), len))
    }

    /// Reads the fields of a frame whose header and CRC were checked (`frame.len() >= 60`).
    pub(crate) fn from_checked(frame: &[u8]) -> Self {
        let mut out = Self {
            version: frame.get(2).copied().unwrap_or_default(),
            ..Self::default()
        };
        if let Some(payload) = frame.get(4..56) {
            out.firmware.copy_from_slice(&payload[0..3]);
            out.status = SensorStatus::from_bits_retain(payload[3]);
            out.bmp280_calibration.copy_from_slice(&payload[4..28]);
            out.bmm150_trim.copy_from_slice(&payload[28..44]);
            out.uptime_ms =
                u32::from_le_bytes([payload[44], payload[45], payload[46], payload[47]]);
            out.requests_skipped =
                u32::from_le_bytes([payload[48], payload[49], payload[50], payload[51]]);
        }
        // Version 2 and later carry the health right after the version 1 payload.
        if out.version >= 2 {
            if let Some(Ok(health)) = frame
                .get(56..56 + BoardHealth::LEN)
                .map(<&[u8; BoardHealth::LEN]>::try_from)
            {
                if frame.len() >= INFO_V2_LEN {
                    out.health = BoardHealth::from_bytes(health);
                }
            }
        }
        // Version 3 and later carry the faults right after the health.
        if out.version >= 3 && frame.len() >= INFO_V3_LEN {
            if let Some(Ok(faults)) = frame
                .get(INFO_V2_LEN - 4..INFO_V3_LEN - 4)
                .map(<&[u8; BoardFaults::LEN]>::try_from)
            {
                out.faults = BoardFaults::from_bytes(faults);
            }
        }
        out
    }
}

/// Stands in for the CRC while the version 2 encoder borrows the version 1 layout (its CRC
/// bytes are overwritten).
struct NoCrc;

impl SensorCrc for NoCrc {
    fn checksum(&mut self, _bytes: &[u8]) -> u32 {
        0
    }
}
