//! Display frames v1: 68 bytes, robot -> ground station, no start token.
//!
//! All fields little-endian, in this order: acc X/Y/Z, gyro X/Y/Z, mag X/Y/Z (i16, decoded
//! signed sensor values), mag hall (u16), baro pressure and temperature (u32, raw 20-bit ADC),
//! then i32 lat, lon (1e-7 deg), velN, velE, velD (mm/s), height, hMSL (mm), gSpeed (mm/s),
//! headMot (1e-5 deg), then CRC-32/ISO-HDLC of bytes 0-63 (u32 LE). Receivers find frames by
//! sliding a 68-byte window until the CRC matches.

use core::fmt;

use crate::checksum::crc32;

/// Length of a display frame on the wire, in bytes.
pub const DISPLAY_FRAME_LEN: usize = 68;
/// Bytes covered by the CRC.
pub(crate) const PAYLOAD_LEN: usize = DISPLAY_FRAME_LEN - 4;
/// Largest raw BMP280 ADC value (20 bits).
pub const MAX_BARO_ADC: u32 = (1 << 20) - 1;

/// The robot's state as shown by the ground station: sensor values and the GNSS solution.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DisplayFrame {
    /// Accelerometer X, Y, Z, signed 12-bit counts (±2 g: 2 g over 2048 counts, 1000/1024 mg per count).
    pub acc: [i16; 3],
    /// Gyroscope X, Y, Z, signed counts (±2000 °/s: 1/16.4 °/s per count).
    pub gyro: [i16; 3],
    /// Magnetometer X, Y (13-bit) and Z (15-bit), signed counts before trim compensation.
    pub mag: [i16; 3],
    /// Magnetometer hall resistance, 14-bit unsigned.
    pub mag_hall: u16,
    /// BMP280 raw pressure ADC value (20 bits).
    pub baro_press: u32,
    /// BMP280 raw temperature ADC value (20 bits).
    pub baro_temp: u32,
    /// Latitude, 1e-7 degrees (positive north).
    pub lat_e7: i32,
    /// Longitude, 1e-7 degrees (positive east).
    pub lon_e7: i32,
    /// Velocity north, mm/s.
    pub vel_n_mm_s: i32,
    /// Velocity east, mm/s.
    pub vel_e_mm_s: i32,
    /// Velocity down, mm/s.
    pub vel_d_mm_s: i32,
    /// Height above the ellipsoid, mm.
    pub height_mm: i32,
    /// Height above mean sea level, mm.
    pub h_msl_mm: i32,
    /// Ground speed, mm/s.
    pub g_speed_mm_s: i32,
    /// Heading of motion, 1e-5 degrees.
    pub head_mot_deg_e5: i32,
}

/// Why a display frame was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DisplayError {
    /// The CRC over bytes 0-63 did not match bytes 64-67.
    Crc {
        /// CRC computed over the received bytes.
        computed: u32,
        /// CRC carried by the frame.
        received: u32,
    },
    /// A CRC-valid frame with a value no robot can send (named field).
    OutOfRange {
        /// Which field.
        field: &'static str,
    },
}

impl fmt::Display for DisplayError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DisplayError::Crc { computed, received } => write!(
                f,
                "display frame CRC mismatch: computed {computed:#010x}, received {received:#010x}"
            ),
            DisplayError::OutOfRange { field } => {
                write!(f, "display frame field {field} out of range")
            }
        }
    }
}

impl core::error::Error for DisplayError {}

/// Little-endian field writer over a fixed buffer (offsets are compile-time facts of the layout).
struct Writer<'a> {
    buf: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn put<const N: usize>(&mut self, bytes: [u8; N]) {
        self.buf[self.at..self.at + N].copy_from_slice(&bytes);
        self.at += N;
    }
}

/// Little-endian field reader over a fixed buffer.
struct Reader<'a> {
    buf: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        out.copy_from_slice(&self.buf[self.at..self.at + N]);
        self.at += N;
        out
    }
    fn i16(&mut self) -> i16 {
        i16::from_le_bytes(self.take())
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
}

impl DisplayFrame {
    /// The 68-byte frame.
    pub fn encode(&self) -> [u8; DISPLAY_FRAME_LEN] {
        let mut buf = [0u8; DISPLAY_FRAME_LEN];
        buf[..PAYLOAD_LEN].copy_from_slice(&self.payload());
        let crc = crc32(&buf[..PAYLOAD_LEN]);
        buf[PAYLOAD_LEN..].copy_from_slice(&crc.to_le_bytes());
        buf
    }

    /// Bytes 0-63 of the frame (everything but the CRC); display frames v2 carry them as is.
    pub(crate) fn payload(&self) -> [u8; PAYLOAD_LEN] {
        let mut buf = [0u8; PAYLOAD_LEN];
        let mut w = Writer {
            buf: &mut buf,
            at: 0,
        };
        for v in self.acc.iter().chain(&self.gyro).chain(&self.mag) {
            w.put(v.to_le_bytes());
        }
        w.put(self.mag_hall.to_le_bytes());
        w.put(self.baro_press.to_le_bytes());
        w.put(self.baro_temp.to_le_bytes());
        for v in [
            self.lat_e7,
            self.lon_e7,
            self.vel_n_mm_s,
            self.vel_e_mm_s,
            self.vel_d_mm_s,
            self.height_mm,
            self.h_msl_mm,
            self.g_speed_mm_s,
            self.head_mot_deg_e5,
        ] {
            w.put(v.to_le_bytes());
        }
        debug_assert_eq!(w.at, PAYLOAD_LEN);
        buf
    }

    /// Decodes and validates one complete frame.
    pub fn decode(frame: &[u8; DISPLAY_FRAME_LEN]) -> Result<DisplayFrame, DisplayError> {
        let computed = crc32(&frame[..PAYLOAD_LEN]);
        let received = u32::from_le_bytes([frame[64], frame[65], frame[66], frame[67]]);
        if computed != received {
            return Err(DisplayError::Crc { computed, received });
        }
        let mut payload = [0u8; PAYLOAD_LEN];
        payload.copy_from_slice(&frame[..PAYLOAD_LEN]);
        DisplayFrame::from_payload(&payload)
    }

    /// Decodes and validates bytes 0-63 of a frame (the CRC is the caller's business).
    pub(crate) fn from_payload(payload: &[u8; PAYLOAD_LEN]) -> Result<DisplayFrame, DisplayError> {
        let mut r = Reader {
            buf: payload,
            at: 0,
        };
        let out = DisplayFrame {
            acc: [r.i16(), r.i16(), r.i16()],
            gyro: [r.i16(), r.i16(), r.i16()],
            mag: [r.i16(), r.i16(), r.i16()],
            mag_hall: r.u16(),
            baro_press: r.u32(),
            baro_temp: r.u32(),
            lat_e7: r.i32(),
            lon_e7: r.i32(),
            vel_n_mm_s: r.i32(),
            vel_e_mm_s: r.i32(),
            vel_d_mm_s: r.i32(),
            height_mm: r.i32(),
            h_msl_mm: r.i32(),
            g_speed_mm_s: r.i32(),
            head_mot_deg_e5: r.i32(),
        };
        out.validate()?;
        Ok(out)
    }

    /// Checks the fields whose range the sensors and NAV-PVT define.
    pub fn validate(&self) -> Result<(), DisplayError> {
        let check = |ok: bool, field| {
            if ok {
                Ok(())
            } else {
                Err(DisplayError::OutOfRange { field })
            }
        };
        check(self.acc.iter().all(|v| (-2048..=2047).contains(v)), "acc")?;
        check(
            self.mag[..2].iter().all(|v| (-4096..=4095).contains(v)),
            "mag",
        )?;
        check((-16384..=16383).contains(&self.mag[2]), "mag")?;
        check(self.mag_hall < (1 << 14), "mag_hall")?;
        check(self.baro_press <= MAX_BARO_ADC, "baro_press")?;
        check(self.baro_temp <= MAX_BARO_ADC, "baro_temp")?;
        check((-900_000_000..=900_000_000).contains(&self.lat_e7), "lat")?;
        check(
            (-1_800_000_000..=1_800_000_000).contains(&self.lon_e7),
            "lon",
        )?;
        check(self.g_speed_mm_s >= 0, "g_speed")?;
        check(
            (-36_000_000..=36_000_000).contains(&self.head_mot_deg_e5),
            "head_mot",
        )
    }
}

/// What a [`DisplayDecoder`] has seen since it was created.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DisplayStats {
    /// Valid frames delivered.
    pub frames: u32,
    /// CRC-valid frames with out-of-range fields.
    pub out_of_range: u32,
    /// Bytes slid past without a CRC match (a lost byte costs up to 67 of them).
    pub skipped_bytes: u32,
}

/// Finds display frames in a byte stream by sliding a 68-byte window until the CRC matches.
///
/// Total: any byte sequence is accepted; garbage only costs the bytes it spans.
#[derive(Debug, Clone)]
pub struct DisplayDecoder {
    window: [u8; DISPLAY_FRAME_LEN],
    len: usize,
    stats: DisplayStats,
}

impl Default for DisplayDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl DisplayDecoder {
    /// An empty decoder.
    pub const fn new() -> DisplayDecoder {
        DisplayDecoder {
            window: [0; DISPLAY_FRAME_LEN],
            len: 0,
            stats: DisplayStats {
                frames: 0,
                out_of_range: 0,
                skipped_bytes: 0,
            },
        }
    }

    /// Counters since creation.
    pub fn stats(&self) -> DisplayStats {
        self.stats
    }

    /// Forgets a partial frame.
    pub fn reset(&mut self) {
        self.stats.skipped_bytes = self.stats.skipped_bytes.saturating_add(self.len as u32);
        self.len = 0;
    }

    /// Feeds one byte. `Some(Ok(_))` for a valid frame, `Some(Err(_))` for a CRC-valid frame
    /// with out-of-range data; windows without a CRC match are only counted as skipped bytes.
    pub fn push(&mut self, byte: u8) -> Option<Result<DisplayFrame, DisplayError>> {
        if self.len == DISPLAY_FRAME_LEN {
            self.window.copy_within(1.., 0);
            self.len -= 1;
            self.stats.skipped_bytes = self.stats.skipped_bytes.saturating_add(1);
        }
        self.window[self.len] = byte;
        self.len += 1;
        if self.len < DISPLAY_FRAME_LEN {
            return None;
        }
        match DisplayFrame::decode(&self.window) {
            Ok(frame) => {
                self.len = 0;
                self.stats.frames = self.stats.frames.saturating_add(1);
                Some(Ok(frame))
            }
            Err(DisplayError::Crc { .. }) => None,
            Err(error) => {
                self.len = 0;
                self.stats.out_of_range = self.stats.out_of_range.saturating_add(1);
                Some(Err(error))
            }
        }
    }

    /// Feeds a chunk of bytes, yielding what [`push`](Self::push) yields for each of them.
    pub fn feed<'a>(
        &'a mut self,
        bytes: &'a [u8],
    ) -> impl Iterator<Item = Result<DisplayFrame, DisplayError>> + 'a {
        bytes.iter().filter_map(move |&b| self.push(b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_offsets() {
        let frame = DisplayFrame {
            acc: [-1, 2, -3],
            gyro: [4, -5, 6],
            mag: [-7, 8, -9],
            mag_hall: 0x1234,
            baro_press: 0x000A_BCDE,
            baro_temp: 0x0001_2345,
            lat_e7: -340_885_000,
            lon_e7: 184_750_000,
            vel_n_mm_s: -10,
            vel_e_mm_s: 11,
            vel_d_mm_s: -12,
            height_mm: 13,
            h_msl_mm: 14,
            g_speed_mm_s: 15,
            head_mot_deg_e5: 16,
        };
        let bytes = frame.encode();
        assert_eq!(&bytes[0..2], &[0xFF, 0xFF]);
        assert_eq!(&bytes[16..18], &(-9i16).to_le_bytes());
        assert_eq!(&bytes[18..20], &[0x34, 0x12]);
        assert_eq!(&bytes[20..24], &[0xDE, 0xBC, 0x0A, 0x00]);
        // Latitude first, then longitude: the original swapped them.
        assert_eq!(&bytes[28..32], &(-340_885_000i32).to_le_bytes());
        assert_eq!(&bytes[32..36], &184_750_000i32.to_le_bytes());
        assert_eq!(&bytes[60..64], &16i32.to_le_bytes());
        assert_eq!(
            u32::from_le_bytes([bytes[64], bytes[65], bytes[66], bytes[67]]),
            crc32(&bytes[..64])
        );
        assert_eq!(DisplayFrame::decode(&bytes), Ok(frame));
    }

    #[test]
    fn out_of_range_is_counted() {
        let frame = DisplayFrame {
            baro_press: MAX_BARO_ADC + 1,
            ..DisplayFrame::default()
        };
        let mut decoder = DisplayDecoder::new();
        let errors = decoder.feed(&frame.encode()).filter(|r| r.is_err()).count();
        assert_eq!(errors, 1);
        assert_eq!(decoder.stats().out_of_range, 1);
    }
}
