//! The GNSS area of the packet: a complete UBX NAV-PVT frame, copied verbatim by the board.
//!
//! The board forwards the last NAV-PVT frame its u-blox receiver sent, byte for byte, in
//! packet bytes 28..=127. Until the first frame arrives the area is all zeros. This module
//! keeps those 100 bytes as they are ([`GnssFrame`]), parses them with the `ublox` crate
//! (protocol 23, fixed buffer, integer accessors) into [`NavPvt`], and writes a [`NavPvt`] back
//! into a frame (for simulators and tests).

use bitflags::bitflags;
use ublox::proto23::{PacketRef, Proto23};
use ublox::{FixedBuffer, Parser, UbxPacket};

/// Length of the GNSS area: a UBX frame with a 92-byte NAV-PVT payload (6 header bytes,
/// payload, 2 checksum bytes).
pub const GNSS_FRAME_LEN: usize = 100;

/// Length of the NAV-PVT payload in bytes.
pub const NAV_PVT_PAYLOAD_LEN: usize = 92;

/// The six bytes every NAV-PVT frame starts with: sync `B5 62`, class `01`, id `07`, length 92
/// (little-endian).
pub const NAV_PVT_HEADER: [u8; 6] = [0xB5, 0x62, 0x01, 0x07, 0x5C, 0x00];

/// Parser buffer size. A NAV-PVT frame is 100 bytes; the parser needs the whole frame.
const PARSER_BUFFER_LEN: usize = 128;

/// The UBX checksum (8-bit Fletcher, RFC 1145) over `bytes`, as `(CK_A, CK_B)`.
///
/// UBX frames carry it over class, id, length and payload (everything but the sync bytes).
#[must_use]
pub fn ubx_checksum(bytes: &[u8]) -> (u8, u8) {
    bytes.iter().fold((0u8, 0u8), |(a, b), &byte| {
        let a = a.wrapping_add(byte);
        (a, b.wrapping_add(a))
    })
}

/// The 100-byte GNSS area exactly as it travels in the packet.
///
/// The board copies its receiver's NAV-PVT frame here without touching it, so keeping the raw
/// bytes lets a log be replayed bit for bit. [`GnssFrame::nav_pvt`] gives the typed view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GnssFrame([u8; GNSS_FRAME_LEN]);

impl GnssFrame {
    /// The area the board sends before its receiver produced a NAV-PVT frame: all zeros.
    pub const ABSENT: Self = Self([0; GNSS_FRAME_LEN]);

    /// Wraps 100 bytes as received or as they should be sent, whatever they contain.
    #[must_use]
    pub const fn from_bytes(bytes: [u8; GNSS_FRAME_LEN]) -> Self {
        Self(bytes)
    }

    /// The 100 bytes exactly as they are on the wire.
    #[must_use]
    pub const fn as_bytes(&self) -> &[u8; GNSS_FRAME_LEN] {
        &self.0
    }

    /// The 100 bytes, by value.
    #[must_use]
    pub const fn into_bytes(self) -> [u8; GNSS_FRAME_LEN] {
        self.0
    }

    /// Builds a well-formed NAV-PVT frame (header, payload, checksum) from `pvt`.
    #[must_use]
    pub fn from_nav_pvt(pvt: &NavPvt) -> Self {
        Self(pvt.to_frame())
    }

    /// Whether the area is all zeros (the board has not seen a NAV-PVT frame yet).
    #[must_use]
    pub fn is_zero(&self) -> bool {
        self.0.iter().all(|&b| b == 0)
    }

    /// Parses the area as a NAV-PVT frame.
    ///
    /// `None` when the area is all zeros, does not start with the NAV-PVT header, or fails its
    /// UBX checksum: the GNSS part of the packet is then absent, the rest of the packet is not
    /// affected.
    #[must_use]
    pub fn nav_pvt(&self) -> Option<NavPvt> {
        NavPvt::from_frame(&self.0)
    }
}

impl Default for GnssFrame {
    fn default() -> Self {
        Self::ABSENT
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for GnssFrame {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "GnssFrame({=[u8]:02x})", &self.0[..]);
    }
}

/// GNSS fix type, NAV-PVT `fixType`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FixType {
    /// No fix (0).
    NoFix,
    /// Dead reckoning only (1).
    DeadReckoningOnly,
    /// 2-D fix (2).
    Fix2D,
    /// 3-D fix (3).
    Fix3D,
    /// GNSS combined with dead reckoning (4).
    GnssDeadReckoning,
    /// Time-only fix (5).
    TimeOnly,
    /// A value the protocol reserves (6..=255), kept so the frame can be written back.
    Reserved(u8),
}

impl From<u8> for FixType {
    fn from(value: u8) -> Self {
        match value {
            0 => Self::NoFix,
            1 => Self::DeadReckoningOnly,
            2 => Self::Fix2D,
            3 => Self::Fix3D,
            4 => Self::GnssDeadReckoning,
            5 => Self::TimeOnly,
            other => Self::Reserved(other),
        }
    }
}

impl From<FixType> for u8 {
    fn from(value: FixType) -> Self {
        match value {
            FixType::NoFix => 0,
            FixType::DeadReckoningOnly => 1,
            FixType::Fix2D => 2,
            FixType::Fix3D => 3,
            FixType::GnssDeadReckoning => 4,
            FixType::TimeOnly => 5,
            FixType::Reserved(other) => other,
        }
    }
}

bitflags! {
    /// NAV-PVT `valid`: which parts of the UTC date and time can be trusted.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
    pub struct ValidFlags: u8 {
        /// The UTC date is valid.
        const VALID_DATE = 0x01;
        /// The UTC time of day is valid.
        const VALID_TIME = 0x02;
        /// The UTC time of day is fully resolved (no seconds uncertainty).
        const FULLY_RESOLVED = 0x04;
        /// The magnetic declination is valid.
        const VALID_MAG = 0x08;
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ValidFlags {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "ValidFlags({=u8:#04x})", self.bits());
    }
}

/// The fields of a UBX NAV-PVT message (u-blox M8, protocol 23), as integers in the units the
/// receiver sends.
///
/// Field names carry their unit: `_deg_e7` is 1e-7 degree, `_deg_e5` 1e-5 degree, `_mm` and
/// `_mm_s` millimetres and millimetres per second, `_e2` hundredths.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NavPvt {
    /// GPS time of week of the navigation epoch, ms.
    pub itow_ms: u32,
    /// UTC year.
    pub year: u16,
    /// UTC month, 1..=12.
    pub month: u8,
    /// UTC day of month, 1..=31.
    pub day: u8,
    /// UTC hour, 0..=23.
    pub hour: u8,
    /// UTC minute, 0..=59.
    pub min: u8,
    /// UTC second, 0..=60.
    pub sec: u8,
    /// Validity of the UTC date and time.
    pub valid: ValidFlags,
    /// UTC time accuracy estimate, ns.
    pub t_acc_ns: u32,
    /// Fraction of the UTC second, ns (-1e9..=1e9).
    pub nano_ns: i32,
    /// Fix type.
    pub fix_type: FixType,
    /// Fix status flags (bit 0 gnssFixOK, bit 1 diffSoln, bits 2-4 psmState, bit 5
    /// headVehValid, bits 6-7 carrSoln), as sent.
    pub flags: u8,
    /// Additional flags (confirmed date/time), as sent.
    pub flags2: u8,
    /// Number of satellites used in the solution.
    pub num_sv: u8,
    /// Longitude, 1e-7 degree.
    pub lon_deg_e7: i32,
    /// Latitude, 1e-7 degree.
    pub lat_deg_e7: i32,
    /// Height above the ellipsoid, mm.
    pub height_mm: i32,
    /// Height above mean sea level, mm.
    pub hmsl_mm: i32,
    /// Horizontal accuracy estimate, mm.
    pub h_acc_mm: u32,
    /// Vertical accuracy estimate, mm.
    pub v_acc_mm: u32,
    /// NED north velocity, mm/s.
    pub vel_n_mm_s: i32,
    /// NED east velocity, mm/s.
    pub vel_e_mm_s: i32,
    /// NED down velocity, mm/s.
    pub vel_d_mm_s: i32,
    /// Ground speed (2-D), mm/s.
    pub g_speed_mm_s: i32,
    /// Heading of motion (2-D), 1e-5 degree.
    pub head_mot_deg_e5: i32,
    /// Speed accuracy estimate, mm/s.
    pub s_acc_mm_s: u32,
    /// Heading accuracy estimate (motion and vehicle), 1e-5 degree.
    pub head_acc_deg_e5: u32,
    /// Position dilution of precision, 0.01.
    pub pdop_e2: u16,
    /// Payload bytes 78..=79 (bit 0 invalidLlh; the rest reserved), little-endian, as sent.
    pub flags3: u16,
    /// Heading of vehicle (2-D), 1e-5 degree.
    pub head_veh_deg_e5: i32,
    /// Magnetic declination, 0.01 degree.
    pub mag_dec_deg_e2: i16,
    /// Magnetic declination accuracy, 0.01 degree.
    pub mag_acc_deg_e2: u16,
}

impl NavPvt {
    /// Parses a 100-byte NAV-PVT frame with the `ublox` crate (protocol 23).
    ///
    /// `None` unless the frame starts with [`NAV_PVT_HEADER`] and its UBX checksum matches, so
    /// an all-zero area (no fix message yet) or a damaged frame is reported as absent.
    #[must_use]
    pub fn from_frame(frame: &[u8; GNSS_FRAME_LEN]) -> Option<Self> {
        if frame[..NAV_PVT_HEADER.len()] != NAV_PVT_HEADER {
            return None;
        }
        let mut parser = Parser::<FixedBuffer<PARSER_BUFFER_LEN>, Proto23>::with_fixed_buffer();
        let mut packets = parser.consume_ubx(frame);
        while let Some(result) = packets.next() {
            if let Ok(UbxPacket::Proto23(PacketRef::NavPvt(pvt))) = result {
                return Some(Self {
                    itow_ms: pvt.itow(),
                    year: pvt.year(),
                    month: pvt.month(),
                    day: pvt.day(),
                    hour: pvt.hour(),
                    min: pvt.min(),
                    sec: pvt.sec(),
                    valid: ValidFlags::from_bits_retain(pvt.valid_raw()),
                    t_acc_ns: pvt.time_accuracy(),
                    nano_ns: pvt.nanosec(),
                    fix_type: FixType::from(pvt.fix_type_raw()),
                    flags: pvt.flags_raw(),
                    flags2: pvt.flags2_raw(),
                    num_sv: pvt.num_satellites(),
                    lon_deg_e7: pvt.longitude_raw(),
                    lat_deg_e7: pvt.latitude_raw(),
                    height_mm: pvt.height_above_ellipsoid_raw(),
                    hmsl_mm: pvt.height_msl_raw(),
                    h_acc_mm: pvt.horizontal_accuracy_raw(),
                    v_acc_mm: pvt.vertical_accuracy_raw(),
                    vel_n_mm_s: pvt.vel_north_raw(),
                    vel_e_mm_s: pvt.vel_east_raw(),
                    vel_d_mm_s: pvt.vel_down_raw(),
                    g_speed_mm_s: pvt.ground_speed_2d_raw(),
                    head_mot_deg_e5: pvt.heading_motion_raw(),
                    s_acc_mm_s: pvt.speed_accuracy_raw(),
                    head_acc_deg_e5: pvt.heading_accuracy_raw(),
                    pdop_e2: pvt.pdop_raw(),
                    flags3: pvt.flags3_raw(),
                    head_veh_deg_e5: pvt.heading_vehicle_raw(),
                    mag_dec_deg_e2: pvt.magnetic_declination_raw(),
                    mag_acc_deg_e2: pvt.magnetic_declination_accuracy_raw(),
                });
            }
        }
        None
    }

    /// Writes the message as a complete 100-byte UBX frame: header, 92-byte payload (reserved
    /// bytes 80..=83 zero), Fletcher checksum over class, id, length and payload.
    #[must_use]
    pub fn to_frame(&self) -> [u8; GNSS_FRAME_LEN] {
        let mut frame = [0u8; GNSS_FRAME_LEN];
        frame[..NAV_PVT_HEADER.len()].copy_from_slice(&NAV_PVT_HEADER);
        {
            let mut payload = PayloadWriter {
                bytes: &mut frame[6..6 + NAV_PVT_PAYLOAD_LEN],
                at: 0,
            };
            payload.put(&self.itow_ms.to_le_bytes());
            payload.put(&self.year.to_le_bytes());
            payload.put(&[
                self.month,
                self.day,
                self.hour,
                self.min,
                self.sec,
                self.valid.bits(),
            ]);
            payload.put(&self.t_acc_ns.to_le_bytes());
            payload.put(&self.nano_ns.to_le_bytes());
            payload.put(&[
                u8::from(self.fix_type),
                self.flags,
                self.flags2,
                self.num_sv,
            ]);
            payload.put(&self.lon_deg_e7.to_le_bytes());
            payload.put(&self.lat_deg_e7.to_le_bytes());
            payload.put(&self.height_mm.to_le_bytes());
            payload.put(&self.hmsl_mm.to_le_bytes());
            payload.put(&self.h_acc_mm.to_le_bytes());
            payload.put(&self.v_acc_mm.to_le_bytes());
            payload.put(&self.vel_n_mm_s.to_le_bytes());
            payload.put(&self.vel_e_mm_s.to_le_bytes());
            payload.put(&self.vel_d_mm_s.to_le_bytes());
            payload.put(&self.g_speed_mm_s.to_le_bytes());
            payload.put(&self.head_mot_deg_e5.to_le_bytes());
            payload.put(&self.s_acc_mm_s.to_le_bytes());
            payload.put(&self.head_acc_deg_e5.to_le_bytes());
            payload.put(&self.pdop_e2.to_le_bytes());
            payload.put(&self.flags3.to_le_bytes());
            payload.put(&[0; 4]);
            payload.put(&self.head_veh_deg_e5.to_le_bytes());
            payload.put(&self.mag_dec_deg_e2.to_le_bytes());
            payload.put(&self.mag_acc_deg_e2.to_le_bytes());
        }
        let (ck_a, ck_b) = ubx_checksum(&frame[2..6 + NAV_PVT_PAYLOAD_LEN]);
        frame[GNSS_FRAME_LEN - 2] = ck_a;
        frame[GNSS_FRAME_LEN - 1] = ck_b;
        frame
    }

    /// Latitude in degrees.
    #[must_use]
    pub fn lat_deg(&self) -> f64 {
        f64::from(self.lat_deg_e7) / 1e7
    }

    /// Longitude in degrees.
    #[must_use]
    pub fn lon_deg(&self) -> f64 {
        f64::from(self.lon_deg_e7) / 1e7
    }

    /// Heading of motion in degrees.
    #[must_use]
    pub fn head_mot_deg(&self) -> f64 {
        f64::from(self.head_mot_deg_e5) / 1e5
    }

    /// Whether the receiver flags the fix as valid (`gnssFixOK`, bit 0 of `flags`): position
    /// and velocity are within the configured DOP and accuracy masks.
    #[must_use]
    pub fn gnss_fix_ok(&self) -> bool {
        self.flags & 0x01 != 0
    }
}

/// Appends byte slices to a fixed payload buffer in order.
struct PayloadWriter<'a> {
    bytes: &'a mut [u8],
    at: usize,
}

impl PayloadWriter<'_> {
    fn put(&mut self, data: &[u8]) {
        let end = self.at + data.len();
        if let Some(target) = self.bytes.get_mut(self.at..end) {
            target.copy_from_slice(data);
        }
        self.at = end;
    }
}
