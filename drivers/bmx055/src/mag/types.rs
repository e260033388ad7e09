//! Magnetometer configuration enums and samples (no I/O).

use super::register as reg;
use crate::types::Xyz;

/// Raw X/Y value the die reports on overflow (13-bit minimum).
pub const OVERFLOW_XY: i16 = -4096;
/// Raw Z value Bosch's compensation treats as overflow (the Hall-resistance overflow code).
pub const OVERFLOW_Z: i16 = -16384;

/// Output data rate in normal mode (`OP_MODE` bits 5:3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MagDataRate {
    /// 10 Hz (reset value).
    #[default]
    Hz10 = 0,
    /// 2 Hz.
    Hz2 = 1,
    /// 6 Hz.
    Hz6 = 2,
    /// 8 Hz.
    Hz8 = 3,
    /// 15 Hz.
    Hz15 = 4,
    /// 20 Hz.
    Hz20 = 5,
    /// 25 Hz.
    Hz25 = 6,
    /// 30 Hz.
    Hz30 = 7,
}

/// Operation mode (`OP_MODE` bits 2:1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MagOpMode {
    /// Continuous measurement at the data rate.
    Normal = 0,
    /// One measurement, then back to sleep.
    Forced = 1,
    /// Sleep (registers readable, no measurement).
    Sleep = 3,
}

/// `OP_MODE` value for a mode and data rate (self-test bits clear).
pub const fn op_mode_bits(mode: MagOpMode, rate: MagDataRate) -> u8 {
    ((rate as u8) << reg::ODR_SHIFT) | ((mode as u8) << reg::OP_MODE_SHIFT)
}

/// Repetition presets recommended by Bosch (datasheet table "recommended presets").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MagPreset {
    /// nXY = 3, nZ = 3, 10 Hz (REP_XY 0x01, REP_Z 0x02): the DIMA setting.
    #[default]
    LowPower,
    /// nXY = 9, nZ = 15, 10 Hz (0x04, 0x0E).
    Regular,
    /// nXY = 15, nZ = 27, 10 Hz (0x07, 0x1A).
    EnhancedRegular,
    /// nXY = 47, nZ = 83, 20 Hz (0x17, 0x52).
    HighAccuracy,
}

impl MagPreset {
    /// `REP_XY` register value.
    pub const fn rep_xy(self) -> u8 {
        match self {
            MagPreset::LowPower => 0x01,
            MagPreset::Regular => 0x04,
            MagPreset::EnhancedRegular => 0x07,
            MagPreset::HighAccuracy => 0x17,
        }
    }
    /// `REP_Z` register value.
    pub const fn rep_z(self) -> u8 {
        match self {
            MagPreset::LowPower => 0x02,
            MagPreset::Regular => 0x0E,
            MagPreset::EnhancedRegular => 0x1A,
            MagPreset::HighAccuracy => 0x52,
        }
    }
    /// The preset's data rate.
    pub const fn data_rate(self) -> MagDataRate {
        match self {
            MagPreset::HighAccuracy => MagDataRate::Hz20,
            _ => MagDataRate::Hz10,
        }
    }
}

/// Longest forced-measurement time in µs for the given repetition register values
/// (datasheet: 145 µs · nXY + 500 µs · nZ + 980 µs, with nXY = 1 + 2·REP_XY, nZ = 1 + REP_Z).
pub const fn measurement_time_us(rep_xy: u8, rep_z: u8) -> u32 {
    let n_xy = 1 + 2 * rep_xy as u32;
    let n_z = 1 + rep_z as u32;
    145 * n_xy + 500 * n_z + 980
}

/// One magnetometer sample as read from `DATA_X_LSB..=RHALL_MSB`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagRaw {
    /// X (13-bit signed, -4096..=4095; -4096 = overflow).
    pub x: i16,
    /// Y (13-bit signed).
    pub y: i16,
    /// Z (15-bit signed, -16384..=16383).
    pub z: i16,
    /// Hall resistance (14-bit unsigned).
    pub rhall: u16,
    /// Data-ready bit (`RHALL_LSB` bit 0) at the time of the read.
    pub data_ready: bool,
}

impl MagRaw {
    /// Decode the eight data registers 0x42..=0x49.
    pub const fn from_registers(b: &[u8; 8]) -> Self {
        let w = MagPacketWords::from_registers(b);
        let mut raw = w.to_raw();
        raw.data_ready = b[6] & reg::DATA_READY != 0;
        raw
    }
    /// The packet words of this sample (the inverse of [`MagPacketWords::to_raw`]).
    pub const fn packet_words(&self) -> MagPacketWords {
        MagPacketWords {
            xyz: Xyz::new(
                (self.x as u16).wrapping_shl(3) as i16,
                (self.y as u16).wrapping_shl(3) as i16,
                (self.z as u16).wrapping_shl(1) as i16,
            ),
            rhall: self.rhall.wrapping_shl(2),
        }
    }
    /// X or Y overflowed (raw -4096), or Z holds the overflow code.
    pub const fn is_overflow(&self) -> bool {
        self.x == OVERFLOW_XY || self.y == OVERFLOW_XY || self.z == OVERFLOW_Z
    }
}

/// Magnetometer data as the DIMA packet carries it: register pairs as read, left-justified,
/// status bits masked (X/Y `& 0xF8`, Z `& 0xFE`, RHALL `& 0xFC`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagPacketWords {
    /// X, Y (13 bit `<< 3`) and Z (15 bit `<< 1`) as i16.
    pub xyz: Xyz<i16>,
    /// RHALL (14 bit `<< 2`) as u16.
    pub rhall: u16,
}

impl MagPacketWords {
    /// Mask the eight data registers 0x42..=0x49 into packet words.
    pub const fn from_registers(b: &[u8; 8]) -> Self {
        Self {
            xyz: Xyz::new(
                i16::from_le_bytes([b[0] & reg::XY_LSB_MASK, b[1]]),
                i16::from_le_bytes([b[2] & reg::XY_LSB_MASK, b[3]]),
                i16::from_le_bytes([b[4] & reg::Z_LSB_MASK, b[5]]),
            ),
            rhall: u16::from_le_bytes([b[6] & reg::RHALL_LSB_MASK, b[7]]),
        }
    }
    /// Right-justify with arithmetic shifts (what the host does with packet data before
    /// compensating it). `data_ready` is not carried by the packet and reads `false`.
    pub const fn to_raw(&self) -> MagRaw {
        MagRaw {
            x: self.xyz.x >> 3,
            y: self.xyz.y >> 3,
            z: self.xyz.z >> 1,
            rhall: self.rhall >> 2,
            data_ready: false,
        }
    }
    /// The 8 packet bytes (X, Y, Z, RHALL; each little-endian), DIMA packet offsets 14..=21.
    pub const fn to_le_bytes(&self) -> [u8; 8] {
        let x = self.xyz.x.to_le_bytes();
        let y = self.xyz.y.to_le_bytes();
        let z = self.xyz.z.to_le_bytes();
        let r = self.rhall.to_le_bytes();
        [x[0], x[1], y[0], y[1], z[0], z[1], r[0], r[1]]
    }
}

/// Magnetometer configuration, applied in one call.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagConfig {
    /// Repetition preset.
    pub preset: MagPreset,
    /// Data rate; for normal mode (forced mode measures on demand).
    pub data_rate: MagDataRate,
    /// `true`: forced mode (measure on request); `false`: normal mode.
    pub forced: bool,
}

impl MagConfig {
    /// A preset in forced mode: each measurement starts on request (`start_forced`); the rate
    /// field keeps its 10 Hz reset value.
    pub const fn forced(preset: MagPreset) -> Self {
        Self {
            preset,
            data_rate: MagDataRate::Hz10,
            forced: true,
        }
    }
    /// A preset with its own data rate, in normal mode.
    pub const fn normal(preset: MagPreset) -> Self {
        Self {
            preset,
            data_rate: preset.data_rate(),
            forced: false,
        }
    }
    /// The register writes: repetitions XY, Z, then the operation mode. In forced mode the
    /// last write starts the first measurement.
    pub const fn register_writes(&self) -> [(u8, u8); 3] {
        let mode = if self.forced {
            MagOpMode::Forced
        } else {
            MagOpMode::Normal
        };
        [
            (reg::REP_XY, self.preset.rep_xy()),
            (reg::REP_Z, self.preset.rep_z()),
            (reg::OP_MODE, op_mode_bits(mode, self.data_rate)),
        ]
    }
}
