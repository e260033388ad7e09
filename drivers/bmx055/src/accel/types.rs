//! Accelerometer configuration enums, samples and scaling (no I/O).

use super::register as reg;
use crate::types::Xyz;

/// Standard gravity, m/s² per g, used for the m/s² outputs.
pub const STANDARD_GRAVITY: f32 = 9.806_65;

/// Measurement range (`PMU_RANGE`, 0x0F).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelRange {
    /// ±2 g, 1024 LSB/g (0.9765625 mg/LSB; the datasheet's table rounds it to 0.98).
    #[default]
    G2 = 0x03,
    /// ±4 g, 512 LSB/g (1.953125 mg/LSB; table 1.95).
    G4 = 0x05,
    /// ±8 g, 256 LSB/g (3.90625 mg/LSB; table 3.91).
    G8 = 0x08,
    /// ±16 g, 128 LSB/g (7.8125 mg/LSB; table 7.81).
    G16 = 0x0C,
}

impl AccelRange {
    /// Register value.
    pub const fn bits(self) -> u8 {
        self as u8
    }
    /// Sensitivity in counts (of the 12-bit value) per g, from the datasheet: the full scale
    /// (2, 4, 8 or 16 g) over 2048 counts.
    pub const fn counts_per_g(self) -> f32 {
        match self {
            AccelRange::G2 => 1024.0,
            AccelRange::G4 => 512.0,
            AccelRange::G8 => 256.0,
            AccelRange::G16 => 128.0,
        }
    }
    /// Resolution in mg per count: exactly `1000 / counts_per_g` (0.9765625 mg at ±2 g).
    ///
    /// This is the one accelerometer scale of the driver and of the DIMA sensor-board crate.
    /// The exact sensitivity (full scale / 2048) is the truth: the datasheet's resolution table
    /// (0.98, 1.95, 3.91, 7.81 mg/LSB) is this value rounded to two decimals. Scaling by the
    /// rounded 0.98 would read 1024 counts as 1003.52 mg instead of 1 g.
    pub const fn mg_per_count(self) -> f32 {
        1000.0 / self.counts_per_g()
    }
}

/// Filter bandwidth (`PMU_BW`, 0x10); the data rate is twice the bandwidth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelBandwidth {
    /// 7.81 Hz.
    Hz7_81 = 0x08,
    /// 15.63 Hz.
    Hz15_63 = 0x09,
    /// 31.25 Hz.
    Hz31_25 = 0x0A,
    /// 62.5 Hz.
    Hz62_5 = 0x0B,
    /// 125 Hz.
    Hz125 = 0x0C,
    /// 250 Hz.
    Hz250 = 0x0D,
    /// 500 Hz.
    Hz500 = 0x0E,
    /// 1000 Hz (2 kHz update rate).
    #[default]
    Hz1000 = 0x0F,
}

impl AccelBandwidth {
    /// Register value.
    pub const fn bits(self) -> u8 {
        self as u8
    }
    /// Bandwidth in Hz.
    pub fn hz(self) -> f32 {
        match self {
            AccelBandwidth::Hz7_81 => 7.81,
            AccelBandwidth::Hz15_63 => 15.63,
            AccelBandwidth::Hz31_25 => 31.25,
            AccelBandwidth::Hz62_5 => 62.5,
            AccelBandwidth::Hz125 => 125.0,
            AccelBandwidth::Hz250 => 250.0,
            AccelBandwidth::Hz500 => 500.0,
            AccelBandwidth::Hz1000 => 1000.0,
        }
    }
    /// The smallest bandwidth at or above `hz` (1000 Hz if `hz` is larger than all).
    pub fn at_least(hz: f32) -> Self {
        const ALL: [AccelBandwidth; 8] = [
            AccelBandwidth::Hz7_81,
            AccelBandwidth::Hz15_63,
            AccelBandwidth::Hz31_25,
            AccelBandwidth::Hz62_5,
            AccelBandwidth::Hz125,
            AccelBandwidth::Hz250,
            AccelBandwidth::Hz500,
            AccelBandwidth::Hz1000,
        ];
        for bw in ALL {
            if bw.hz() >= hz {
                return bw;
            }
        }
        AccelBandwidth::Hz1000
    }
}

/// Sleep phase length in low-power mode (`PMU_LPW` bits 4:1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelSleepDuration {
    /// 0.5 ms.
    Ms0_5 = 5,
    /// 1 ms.
    Ms1 = 6,
    /// 2 ms.
    Ms2 = 7,
    /// 4 ms.
    Ms4 = 8,
    /// 6 ms.
    Ms6 = 9,
    /// 10 ms.
    Ms10 = 10,
    /// 25 ms.
    Ms25 = 11,
    /// 50 ms.
    Ms50 = 12,
    /// 100 ms.
    Ms100 = 13,
    /// 500 ms.
    Ms500 = 14,
    /// 1 s.
    S1 = 15,
}

/// Power mode (`PMU_LPW`, 0x11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelPowerMode {
    /// Continuous measurement.
    #[default]
    Normal,
    /// Duty-cycled: wake, measure, sleep for the given duration (low-power mode 1).
    LowPower(AccelSleepDuration),
    /// Registers kept, no measurement; wake-up in about 1.3 ms.
    Suspend,
    /// Lowest current; registers lost, leave with a soft reset.
    DeepSuspend,
}

impl AccelPowerMode {
    /// Register value of `PMU_LPW`.
    pub const fn bits(self) -> u8 {
        match self {
            AccelPowerMode::Normal => 0x00,
            AccelPowerMode::DeepSuspend => 0b001 << reg::POWER_MODE_SHIFT,
            AccelPowerMode::LowPower(d) => (0b010 << reg::POWER_MODE_SHIFT) | ((d as u8) << 1),
            AccelPowerMode::Suspend => 0b100 << reg::POWER_MODE_SHIFT,
        }
    }
}

/// Accelerometer configuration, applied in one call.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelConfig {
    /// Measurement range.
    pub range: AccelRange,
    /// Filter bandwidth.
    pub bandwidth: AccelBandwidth,
    /// Power mode.
    pub power: AccelPowerMode,
}

impl AccelConfig {
    /// With another range.
    pub const fn with_range(mut self, range: AccelRange) -> Self {
        self.range = range;
        self
    }
    /// With another bandwidth.
    pub const fn with_bandwidth(mut self, bandwidth: AccelBandwidth) -> Self {
        self.bandwidth = bandwidth;
        self
    }
    /// With another power mode.
    pub const fn with_power(mut self, power: AccelPowerMode) -> Self {
        self.power = power;
        self
    }
    /// The register writes that apply this configuration, in order
    /// (range, bandwidth, power mode).
    pub const fn register_writes(&self) -> [(u8, u8); 3] {
        [
            (reg::PMU_RANGE, self.range.bits()),
            (reg::PMU_BW, self.bandwidth.bits()),
            (reg::PMU_LPW, self.power.bits()),
        ]
    }
}

/// One accelerometer sample as read from `ACCD_X_LSB..=ACCD_Z_MSB`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelRaw {
    /// Left-justified 12-bit words with the status nibble masked (`LSB & 0xF0`), exactly as
    /// the DIMA sensor packet carries them.
    pub words: Xyz<i16>,
    /// `new_data_*` flags: the axis was updated since it was last read.
    pub new_data: Xyz<bool>,
}

impl AccelRaw {
    /// Decode the six data registers (X LSB, X MSB, Y LSB, ...).
    pub const fn from_registers(b: &[u8; 6]) -> Self {
        Self {
            words: Xyz::new(
                i16::from_le_bytes([b[0] & reg::LSB_DATA_MASK, b[1]]),
                i16::from_le_bytes([b[2] & reg::LSB_DATA_MASK, b[3]]),
                i16::from_le_bytes([b[4] & reg::LSB_DATA_MASK, b[5]]),
            ),
            new_data: Xyz::new(
                b[0] & reg::NEW_DATA != 0,
                b[2] & reg::NEW_DATA != 0,
                b[4] & reg::NEW_DATA != 0,
            ),
        }
    }
    /// Signed 12-bit counts (-2048..=2047): the words shifted right arithmetically by 4.
    pub fn counts(&self) -> Xyz<i16> {
        self.words.map(|w| w >> 4)
    }
    /// Acceleration in mg for the range the sample was taken with.
    pub fn mg(&self, range: AccelRange) -> Xyz<f32> {
        self.words.map(|w| accel_word_to_mg(w, range))
    }
    /// Acceleration in m/s² for the range the sample was taken with.
    pub fn m_s2(&self, range: AccelRange) -> Xyz<f32> {
        self.mg(range).map(|g| g * STANDARD_GRAVITY / 1000.0)
    }
}

/// Packet word (left-justified 12-bit) to mg.
pub fn accel_word_to_mg(word: i16, range: AccelRange) -> f32 {
    accel_count_to_mg(word >> 4, range)
}

/// Signed 12-bit count (right-justified, -2048..=2047) to mg: `count * range.mg_per_count()`.
pub fn accel_count_to_mg(count: i16, range: AccelRange) -> f32 {
    f32::from(count) * range.mg_per_count()
}

/// mg to the packet's left-justified 12-bit word (the inverse of [`accel_word_to_mg`]):
/// rounded to the nearest count and saturated to the range's full scale; NaN gives 0.
pub fn accel_mg_to_word(mg: f32, range: AccelRange) -> i16 {
    let counts = mg / range.mg_per_count();
    let counts = if counts.is_nan() {
        0.0
    } else {
        crate::maths::round(counts).clamp(-2048.0, 2047.0)
    };
    (counts as i16) << 4
}

/// Temperature in °C from `ACCD_TEMP` (0.5 K/LSB, 0 = 23 °C).
pub fn accel_temperature_celsius(raw: u8) -> f32 {
    23.0 + f32::from(raw as i8) * 0.5
}
