//! UBX NAV-PVT (class 0x01, id 0x07): typed integer fields and the exact 100-byte frame.
//!
//! The DIMA sensor packet carries the receiver's NAV-PVT frame verbatim (packet bytes
//! 28-127), so the frame is kept as bytes ([`NavPvtFrame`]) and decoded only where the values
//! are needed. [`NavPvt`] holds every payload field as the integer the receiver sends
//! (Cortex-M4F has no double-precision FPU) and encodes back to the identical frame, which a
//! simulator needs. Layout: u-blox M8 receiver description (protocol 15-23), UBX-NAV-PVT,
//! 92-byte payload, little-endian.

use crate::frame::{encode_frame, Frame, FRAME_OVERHEAD};
use ublox::proto23::PacketRef;

/// NAV-PVT message class.
pub const CLASS: u8 = 0x01;
/// NAV-PVT message id.
pub const ID: u8 = 0x07;
/// NAV-PVT payload length in bytes.
pub const PAYLOAD_LEN: usize = 92;
/// Whole NAV-PVT frame length (`B5 62 01 07 5C 00`, payload, CK_A, CK_B).
pub const FRAME_LEN: usize = PAYLOAD_LEN + FRAME_OVERHEAD;

/// `valid` bit: UTC date is valid.
pub const VALID_DATE: u8 = 0x01;
/// `valid` bit: UTC time of day is valid.
pub const VALID_TIME: u8 = 0x02;
/// `valid` bit: UTC time of day has been fully resolved (no seconds uncertainty).
pub const VALID_FULLY_RESOLVED: u8 = 0x04;
/// `valid` bit: magnetic declination is valid.
pub const VALID_MAG: u8 = 0x08;
/// `flags` bit: valid fix (within DOP and accuracy masks).
pub const FLAG_GNSS_FIX_OK: u8 = 0x01;
/// `flags` bit: differential corrections were applied.
pub const FLAG_DIFF_SOLN: u8 = 0x02;
/// `flags` bit: heading of vehicle is valid.
pub const FLAG_HEAD_VEH_VALID: u8 = 0x20;

/// GNSS fix type (`fixType`), as the receiver reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FixType {
    /// 0: no fix.
    NoFix,
    /// 1: dead reckoning only.
    DeadReckoning,
    /// 2: 2D fix.
    Fix2D,
    /// 3: 3D fix.
    Fix3D,
    /// 4: GNSS and dead reckoning combined.
    GnssDeadReckoning,
    /// 5: time only fix (timing receivers in fixed-position mode).
    TimeOnly,
    /// Any other value (reserved).
    Reserved(u8),
}

impl From<u8> for FixType {
    fn from(raw: u8) -> Self {
        match raw {
            0 => Self::NoFix,
            1 => Self::DeadReckoning,
            2 => Self::Fix2D,
            3 => Self::Fix3D,
            4 => Self::GnssDeadReckoning,
            5 => Self::TimeOnly,
            other => Self::Reserved(other),
        }
    }
}

impl From<FixType> for u8 {
    fn from(fix: FixType) -> Self {
        match fix {
            FixType::NoFix => 0,
            FixType::DeadReckoning => 1,
            FixType::Fix2D => 2,
            FixType::Fix3D => 3,
            FixType::GnssDeadReckoning => 4,
            FixType::TimeOnly => 5,
            FixType::Reserved(raw) => raw,
        }
    }
}

/// Every NAV-PVT payload field, as the integer on the wire (units in the names).
///
/// `Default` is all zeros (no fix); set the fields you need, then [`to_frame`](Self::to_frame).
///
/// ```
/// use neo_m8t::{nav_pvt, NavPvt};
///
/// let fix = NavPvt {
///     itow_ms: 28_548_000,
///     fix_type: 3,
///     flags: nav_pvt::FLAG_GNSS_FIX_OK,
///     num_sv: 11,
///     lat_deg_e7: 473_769_000,
///     lon_deg_e7: 85_417_000,
///     ..NavPvt::default()
/// };
/// let frame = fix.to_frame();
/// assert_eq!(&frame.as_bytes()[..6], &[0xB5, 0x62, 0x01, 0x07, 0x5C, 0x00]);
/// assert_eq!(frame.to_nav_pvt(), fix);
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NavPvt {
    /// GPS time of week of the navigation epoch, ms (`iTOW`); identifies the epoch.
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
    /// UTC second, 0..=60 (leap second).
    pub sec: u8,
    /// Validity bits (`valid`): [`VALID_DATE`], [`VALID_TIME`], [`VALID_FULLY_RESOLVED`],
    /// [`VALID_MAG`].
    pub valid: u8,
    /// Time accuracy estimate, ns (`tAcc`).
    pub t_acc_ns: u32,
    /// Fraction of second, ns, -1e9..=1e9 (`nano`); may be negative.
    pub nano_ns: i32,
    /// GNSS fix type (`fixType`), see [`FixType`].
    pub fix_type: u8,
    /// Fix status bits (`flags`): [`FLAG_GNSS_FIX_OK`], [`FLAG_DIFF_SOLN`], bits 2-4 power save
    /// state, [`FLAG_HEAD_VEH_VALID`], bits 6-7 carrier phase solution.
    pub flags: u8,
    /// Additional bits (`flags2`): bit 5 confirmedAvai, 6 confirmedDate, 7 confirmedTime.
    pub flags2: u8,
    /// Satellites used in the solution (`numSV`).
    pub num_sv: u8,
    /// Longitude, 1e-7 degrees (`lon`).
    pub lon_deg_e7: i32,
    /// Latitude, 1e-7 degrees (`lat`).
    pub lat_deg_e7: i32,
    /// Height above the ellipsoid, mm (`height`).
    pub height_mm: i32,
    /// Height above mean sea level, mm (`hMSL`).
    pub h_msl_mm: i32,
    /// Horizontal accuracy estimate, mm (`hAcc`).
    pub h_acc_mm: u32,
    /// Vertical accuracy estimate, mm (`vAcc`).
    pub v_acc_mm: u32,
    /// NED north velocity, mm/s (`velN`).
    pub vel_n_mm_s: i32,
    /// NED east velocity, mm/s (`velE`).
    pub vel_e_mm_s: i32,
    /// NED down velocity, mm/s (`velD`).
    pub vel_d_mm_s: i32,
    /// Ground speed (2-D), mm/s (`gSpeed`).
    pub g_speed_mm_s: i32,
    /// Heading of motion (2-D), 1e-5 degrees (`headMot`).
    pub head_mot_deg_e5: i32,
    /// Speed accuracy estimate, mm/s (`sAcc`).
    pub s_acc_mm_s: u32,
    /// Heading accuracy estimate (motion and vehicle), 1e-5 degrees (`headAcc`).
    pub head_acc_deg_e5: u32,
    /// Position DOP, 0.01 (`pDOP`).
    pub p_dop_e2: u16,
    /// Payload bytes 78-83, kept verbatim: reserved on early M8 firmware; newer protocol
    /// versions (and the `ublox` crate's protocol 23 view) read bytes 78-79 as `flags3`
    /// (bit 0 invalidLlh: lon, lat, height and hMSL are not valid).
    pub reserved1: [u8; 6],
    /// Heading of vehicle (2-D), 1e-5 degrees (`headVeh`); valid with [`FLAG_HEAD_VEH_VALID`].
    pub head_veh_deg_e5: i32,
    /// Magnetic declination, 0.01 degrees (`magDec`).
    pub mag_dec_deg_e2: i16,
    /// Magnetic declination accuracy, 0.01 degrees (`magAcc`).
    pub mag_acc_deg_e2: u16,
}

impl NavPvt {
    /// The fix type as an enum.
    pub fn fix(&self) -> FixType {
        FixType::from(self.fix_type)
    }

    /// `gnssFixOk`: the receiver considers the fix valid (within its masks).
    pub fn gnss_fix_ok(&self) -> bool {
        self.flags & FLAG_GNSS_FIX_OK != 0
    }

    /// `flags3` (payload bytes 78-79, little-endian): bit 0 invalidLlh, the rest reserved.
    pub fn flags3(&self) -> u16 {
        u16::from_le_bytes([self.reserved1[0], self.reserved1[1]])
    }

    /// Latitude in degrees (`f64`: software floating point on a Cortex-M4F, meant for hosts).
    pub fn lat_deg(&self) -> f64 {
        f64::from(self.lat_deg_e7) / 1e7
    }

    /// Longitude in degrees (`f64`, as [`lat_deg`](Self::lat_deg)).
    pub fn lon_deg(&self) -> f64 {
        f64::from(self.lon_deg_e7) / 1e7
    }

    /// Heading of motion in degrees (`f64`, as [`lat_deg`](Self::lat_deg)).
    pub fn head_mot_deg(&self) -> f64 {
        f64::from(self.head_mot_deg_e5) / 1e5
    }

    /// The 92-byte payload in wire order.
    pub fn to_payload(&self) -> [u8; PAYLOAD_LEN] {
        let mut p = [0u8; PAYLOAD_LEN];
        let mut at = 0;
        let mut put = |bytes: &[u8]| {
            p[at..at + bytes.len()].copy_from_slice(bytes);
            at += bytes.len();
        };
        put(&self.itow_ms.to_le_bytes());
        put(&self.year.to_le_bytes());
        put(&[
            self.month, self.day, self.hour, self.min, self.sec, self.valid,
        ]);
        put(&self.t_acc_ns.to_le_bytes());
        put(&self.nano_ns.to_le_bytes());
        put(&[self.fix_type, self.flags, self.flags2, self.num_sv]);
        put(&self.lon_deg_e7.to_le_bytes());
        put(&self.lat_deg_e7.to_le_bytes());
        put(&self.height_mm.to_le_bytes());
        put(&self.h_msl_mm.to_le_bytes());
        put(&self.h_acc_mm.to_le_bytes());
        put(&self.v_acc_mm.to_le_bytes());
        put(&self.vel_n_mm_s.to_le_bytes());
        put(&self.vel_e_mm_s.to_le_bytes());
        put(&self.vel_d_mm_s.to_le_bytes());
        put(&self.g_speed_mm_s.to_le_bytes());
        put(&self.head_mot_deg_e5.to_le_bytes());
        put(&self.s_acc_mm_s.to_le_bytes());
        put(&self.head_acc_deg_e5.to_le_bytes());
        put(&self.p_dop_e2.to_le_bytes());
        put(&self.reserved1);
        put(&self.head_veh_deg_e5.to_le_bytes());
        put(&self.mag_dec_deg_e2.to_le_bytes());
        put(&self.mag_acc_deg_e2.to_le_bytes());
        p
    }

    /// The complete 100-byte UBX frame with its checksum.
    pub fn to_frame(&self) -> NavPvtFrame {
        let mut bytes = [0u8; FRAME_LEN];
        // Cannot fail: the buffer is exactly payload + 8 bytes.
        let _ = encode_frame(CLASS, ID, &self.to_payload(), &mut bytes);
        NavPvtFrame(bytes)
    }

    /// Reads the fields from the `ublox` crate's NAV-PVT view (its integer `*_raw` accessors).
    pub fn from_ublox(p: &ublox::nav_pvt::proto23::NavPvtRef<'_>) -> Self {
        let flags3 = p.flags3_raw().to_le_bytes();
        let rest = p.reserved1();
        Self {
            itow_ms: p.itow(),
            year: p.year(),
            month: p.month(),
            day: p.day(),
            hour: p.hour(),
            min: p.min(),
            sec: p.sec(),
            valid: p.valid_raw(),
            t_acc_ns: p.time_accuracy(),
            nano_ns: p.nanosec(),
            fix_type: p.fix_type_raw(),
            flags: p.flags_raw(),
            flags2: p.flags2_raw(),
            num_sv: p.num_satellites(),
            lon_deg_e7: p.longitude_raw(),
            lat_deg_e7: p.latitude_raw(),
            height_mm: p.height_above_ellipsoid_raw(),
            h_msl_mm: p.height_msl_raw(),
            h_acc_mm: p.horizontal_accuracy_raw(),
            v_acc_mm: p.vertical_accuracy_raw(),
            vel_n_mm_s: p.vel_north_raw(),
            vel_e_mm_s: p.vel_east_raw(),
            vel_d_mm_s: p.vel_down_raw(),
            g_speed_mm_s: p.ground_speed_2d_raw(),
            head_mot_deg_e5: p.heading_motion_raw(),
            s_acc_mm_s: p.speed_accuracy_raw(),
            head_acc_deg_e5: p.heading_accuracy_raw(),
            p_dop_e2: p.pdop_raw(),
            reserved1: [flags3[0], flags3[1], rest[0], rest[1], rest[2], rest[3]],
            head_veh_deg_e5: p.heading_vehicle_raw(),
            mag_dec_deg_e2: p.magnetic_declination_raw(),
            mag_acc_deg_e2: p.magnetic_declination_accuracy_raw(),
        }
    }
}

/// A checksum-verified NAV-PVT frame, exactly the 100 bytes the receiver sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NavPvtFrame([u8; FRAME_LEN]);

impl NavPvtFrame {
    /// Accepts `bytes` only if it is one complete NAV-PVT frame with a valid checksum.
    pub fn from_bytes(bytes: &[u8]) -> Option<Self> {
        Self::from_frame(&Frame::new(bytes)?)
    }

    /// Copies a received frame if it is NAV-PVT with the 92-byte payload.
    pub fn from_frame(frame: &Frame<'_>) -> Option<Self> {
        if frame.class() != CLASS || frame.id() != ID {
            return None;
        }
        let bytes: [u8; FRAME_LEN] = frame.as_bytes().try_into().ok()?;
        Some(Self(bytes))
    }

    /// The 100 bytes, for the DIMA sensor packet (offsets 28-127).
    pub fn as_bytes(&self) -> &[u8; FRAME_LEN] {
        &self.0
    }

    /// The 92-byte payload.
    pub fn payload(&self) -> &[u8] {
        &self.0[6..FRAME_LEN - 2]
    }

    /// The `ublox` crate's view of the payload.
    pub fn as_ublox(&self) -> Option<ublox::nav_pvt::proto23::NavPvtRef<'_>> {
        let frame = Frame::new(&self.0)?;
        match frame.decode() {
            Ok(PacketRef::NavPvt(p)) => Some(p),
            _ => None,
        }
    }

    /// Decodes every field to integers.
    pub fn to_nav_pvt(&self) -> NavPvt {
        // The frame was checked on construction, so the view always exists; the fallback
        // keeps this total.
        self.as_ublox()
            .map(|p| NavPvt::from_ublox(&p))
            .unwrap_or_default()
    }
}

impl From<NavPvtFrame> for [u8; FRAME_LEN] {
    fn from(frame: NavPvtFrame) -> Self {
        frame.0
    }
}

impl AsRef<[u8]> for NavPvtFrame {
    fn as_ref(&self) -> &[u8] {
        &self.0
    }
}
