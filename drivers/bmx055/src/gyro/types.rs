//! Gyroscope configuration enums, samples and scaling (no I/O).

use super::register as reg;
use crate::types::Xyz;

/// Measurement range (`RANGE`, 0x0F).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroRange {
    /// ±2000 °/s, 16.4 LSB per °/s.
    #[default]
    Dps2000 = 0x00,
    /// ±1000 °/s, 32.8 LSB per °/s.
    Dps1000 = 0x01,
    /// ±500 °/s, 65.6 LSB per °/s.
    Dps500 = 0x02,
    /// ±250 °/s, 131.2 LSB per °/s.
    Dps250 = 0x03,
    /// ±125 °/s, 262.4 LSB per °/s.
    Dps125 = 0x04,
}

impl GyroRange {
    /// Register value.
    pub const fn bits(self) -> u8 {
        self as u8
    }
    /// Sensitivity in LSB per °/s (datasheet).
    pub const fn lsb_per_dps(self) -> f32 {
        match self {
            GyroRange::Dps2000 => 16.4,
            GyroRange::Dps1000 => 32.8,
            GyroRange::Dps500 => 65.6,
            GyroRange::Dps250 => 131.2,
            GyroRange::Dps125 => 262.4,
        }
    }
}

/// Output data rate and filter bandwidth (`BW`, 0x10).
///
/// The values carry bit 7 set, as the register reads back (bit 7 is read-only) and as the
/// DIMA configuration writes it (0x81 = 2000 Hz / 230 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroBandwidth {
    /// 2000 Hz, 523 Hz filter (unfiltered).
    #[default]
    Odr2000Bw523 = 0x80,
    /// 2000 Hz, 230 Hz filter.
    Odr2000Bw230 = 0x81,
    /// 1000 Hz, 116 Hz filter.
    Odr1000Bw116 = 0x82,
    /// 400 Hz, 47 Hz filter.
    Odr400Bw47 = 0x83,
    /// 200 Hz, 23 Hz filter.
    Odr200Bw23 = 0x84,
    /// 100 Hz, 12 Hz filter.
    Odr100Bw12 = 0x85,
    /// 200 Hz, 64 Hz filter.
    Odr200Bw64 = 0x86,
    /// 100 Hz, 32 Hz filter.
    Odr100Bw32 = 0x87,
}

impl GyroBandwidth {
    /// Register value.
    pub const fn bits(self) -> u8 {
        self as u8
    }
    /// Output data rate in Hz.
    pub const fn odr_hz(self) -> u16 {
        match self {
            GyroBandwidth::Odr2000Bw523 | GyroBandwidth::Odr2000Bw230 => 2000,
            GyroBandwidth::Odr1000Bw116 => 1000,
            GyroBandwidth::Odr400Bw47 => 400,
            GyroBandwidth::Odr200Bw23 | GyroBandwidth::Odr200Bw64 => 200,
            GyroBandwidth::Odr100Bw12 | GyroBandwidth::Odr100Bw32 => 100,
        }
    }
}

/// Power mode (`LPM1`, 0x11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroPowerMode {
    /// Continuous measurement.
    #[default]
    Normal,
    /// Registers kept, no measurement.
    Suspend,
    /// Lowest current; leave with a soft reset.
    DeepSuspend,
}

impl GyroPowerMode {
    /// Register value of `LPM1`.
    pub const fn bits(self) -> u8 {
        match self {
            GyroPowerMode::Normal => 0x00,
            GyroPowerMode::Suspend => reg::SUSPEND,
            GyroPowerMode::DeepSuspend => reg::DEEP_SUSPEND,
        }
    }
}

/// Gyroscope configuration, applied in one call.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroConfig {
    /// Measurement range.
    pub range: GyroRange,
    /// Data rate and filter.
    pub bandwidth: GyroBandwidth,
    /// Power mode.
    pub power: GyroPowerMode,
}

impl GyroConfig {
    /// With another range.
    pub const fn with_range(mut self, range: GyroRange) -> Self {
        self.range = range;
        self
    }
    /// With another data rate / filter.
    pub const fn with_bandwidth(mut self, bandwidth: GyroBandwidth) -> Self {
        self.bandwidth = bandwidth;
        self
    }
    /// With another power mode.
    pub const fn with_power(mut self, power: GyroPowerMode) -> Self {
        self.power = power;
        self
    }
    /// The register writes that apply this configuration (range, bandwidth, power mode).
    pub const fn register_writes(&self) -> [(u8, u8); 3] {
        [
            (reg::RANGE, self.range.bits()),
            (reg::BW, self.bandwidth.bits()),
            (reg::LPM1, self.power.bits()),
        ]
    }
}

/// One gyroscope sample: the three 16-bit rate words, exactly as the DIMA packet carries them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroRaw {
    /// Rate words (two's complement counts).
    pub words: Xyz<i16>,
}

impl GyroRaw {
    /// Decode the six data registers (X LSB, X MSB, ...).
    pub const fn from_registers(b: &[u8; 6]) -> Self {
        Self {
            words: Xyz::new(
                i16::from_le_bytes([b[0], b[1]]),
                i16::from_le_bytes([b[2], b[3]]),
                i16::from_le_bytes([b[4], b[5]]),
            ),
        }
    }
    /// Rate in °/s for the range the sample was taken with.
    pub fn dps(&self, range: GyroRange) -> Xyz<f32> {
        self.words.map(|w| gyro_word_to_dps(w, range))
    }
    /// Rate in rad/s for the range the sample was taken with.
    pub fn rad_s(&self, range: GyroRange) -> Xyz<f32> {
        self.dps(range).map(|d| d * (core::f32::consts::PI / 180.0))
    }
}

/// Rate word to °/s.
pub fn gyro_word_to_dps(word: i16, range: GyroRange) -> f32 {
    f32::from(word) / range.lsb_per_dps()
}

/// °/s to the rate word (inverse of [`gyro_word_to_dps`]): rounded to the nearest count and
/// saturated to `i16`; NaN gives 0.
pub fn gyro_dps_to_word(dps: f32, range: GyroRange) -> i16 {
    let counts = dps * range.lsb_per_dps();
    if counts.is_nan() {
        return 0;
    }
    crate::maths::round(counts).clamp(-32768.0, 32767.0) as i16
}
