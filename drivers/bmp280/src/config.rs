//! Typed measurement configuration: power mode, oversampling, IIR filter, standby time, and the
//! measurement time the datasheet derives from them.
//!
//! A [`Config`] maps one-to-one onto the `ctrl_meas` (0xF4) and `config` (0xF5) registers and is
//! applied by the driver in one call. Presets follow the datasheet (section 3.4, tables 4 and 7).

use crate::register;

/// Power mode, `ctrl_meas` bits 1:0 (datasheet 3.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PowerMode {
    /// No measurements, lowest current; the only mode in which `config` writes always apply.
    Sleep = 0b00,
    /// One measurement, then back to sleep. Start it with the driver's `start_forced`.
    Forced = 0b01,
    /// Continuous measurements separated by the standby time.
    Normal = 0b11,
}

impl PowerMode {
    /// Decodes the two mode bits; both 0b01 and 0b10 mean forced mode (datasheet table 10).
    pub const fn from_bits(bits: u8) -> Self {
        match bits & register::MODE_MASK {
            0b00 => PowerMode::Sleep,
            0b11 => PowerMode::Normal,
            _ => PowerMode::Forced,
        }
    }
}

/// Oversampling of one measurement (`osrs_t` or `osrs_p`, datasheet tables 21 and 22).
///
/// More samples give lower noise and more resolution (16 bits at x1 up to 20 bits at x16 for
/// pressure) at the cost of measurement time and current.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Oversampling {
    /// Measurement skipped; its data register then reads 0x80000.
    Skip = 0b000,
    /// One sample.
    X1 = 0b001,
    /// Two samples.
    X2 = 0b010,
    /// Four samples.
    X4 = 0b011,
    /// Eight samples.
    X8 = 0b100,
    /// Sixteen samples.
    X16 = 0b101,
}

impl Oversampling {
    /// Decodes a 3-bit field; the codes 0b110 and 0b111 also mean x16 (datasheet table 21).
    pub const fn from_bits(bits: u8) -> Self {
        match bits & register::FIELD3_MASK {
            0b000 => Oversampling::Skip,
            0b001 => Oversampling::X1,
            0b010 => Oversampling::X2,
            0b011 => Oversampling::X4,
            0b100 => Oversampling::X8,
            _ => Oversampling::X16,
        }
    }

    /// Number of samples taken (0 when skipped), the factor in the measurement-time formula.
    pub const fn samples(self) -> u32 {
        match self {
            Oversampling::Skip => 0,
            Oversampling::X1 => 1,
            Oversampling::X2 => 2,
            Oversampling::X4 => 4,
            Oversampling::X8 => 8,
            Oversampling::X16 => 16,
        }
    }
}

/// IIR filter coefficient, `config` bits 4:2 (datasheet 3.3.3, table 6).
///
/// The filter smooths short pressure disturbances (slamming doors, wind); with coefficient `c`
/// the step response needs several samples to settle, so leave it off for fast control loops.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Filter {
    /// Filter off: every sample stands alone.
    Off = 0b000,
    /// Coefficient 2.
    X2 = 0b001,
    /// Coefficient 4.
    X4 = 0b010,
    /// Coefficient 8.
    X8 = 0b011,
    /// Coefficient 16.
    X16 = 0b100,
}

impl Filter {
    /// Decodes a 3-bit field; the codes above 0b100 also mean coefficient 16.
    pub const fn from_bits(bits: u8) -> Self {
        match bits & register::FIELD3_MASK {
            0b000 => Filter::Off,
            0b001 => Filter::X2,
            0b010 => Filter::X4,
            0b011 => Filter::X8,
            _ => Filter::X16,
        }
    }
}

/// Inactive time between two measurements in normal mode, `config` bits 7:5 (datasheet table 11).
///
/// The BME280 reads the codes of [`Standby::Ms2000`] and [`Standby::Ms4000`] as 10 ms and 20 ms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Standby {
    /// 0.5 ms.
    Ms0_5 = 0b000,
    /// 62.5 ms.
    Ms62_5 = 0b001,
    /// 125 ms.
    Ms125 = 0b010,
    /// 250 ms.
    Ms250 = 0b011,
    /// 500 ms.
    Ms500 = 0b100,
    /// 1 s.
    Ms1000 = 0b101,
    /// 2 s.
    Ms2000 = 0b110,
    /// 4 s.
    Ms4000 = 0b111,
}

impl Standby {
    /// Decodes the 3-bit `t_sb` field.
    pub const fn from_bits(bits: u8) -> Self {
        match bits & register::FIELD3_MASK {
            0b000 => Standby::Ms0_5,
            0b001 => Standby::Ms62_5,
            0b010 => Standby::Ms125,
            0b011 => Standby::Ms250,
            0b100 => Standby::Ms500,
            0b101 => Standby::Ms1000,
            0b110 => Standby::Ms2000,
            _ => Standby::Ms4000,
        }
    }

    /// Standby time in microseconds.
    pub const fn micros(self) -> u32 {
        match self {
            Standby::Ms0_5 => 500,
            Standby::Ms62_5 => 62_500,
            Standby::Ms125 => 125_000,
            Standby::Ms250 => 250_000,
            Standby::Ms500 => 500_000,
            Standby::Ms1000 => 1_000_000,
            Standby::Ms2000 => 2_000_000,
            Standby::Ms4000 => 4_000_000,
        }
    }
}

/// The datasheet's oversampling presets (table 4), from fastest to finest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Resolution {
    /// Pressure x1, temperature x1: 16 bit / 2.62 Pa.
    UltraLowPower,
    /// Pressure x2, temperature x1: 17 bit / 1.31 Pa.
    LowPower,
    /// Pressure x4, temperature x1: 18 bit / 0.66 Pa.
    Standard,
    /// Pressure x8, temperature x1: 19 bit / 0.33 Pa.
    High,
    /// Pressure x16, temperature x2: 20 bit / 0.16 Pa.
    UltraHigh,
}

impl Resolution {
    /// `(pressure, temperature)` oversampling of this preset.
    pub const fn oversampling(self) -> (Oversampling, Oversampling) {
        match self {
            Resolution::UltraLowPower => (Oversampling::X1, Oversampling::X1),
            Resolution::LowPower => (Oversampling::X2, Oversampling::X1),
            Resolution::Standard => (Oversampling::X4, Oversampling::X1),
            Resolution::High => (Oversampling::X8, Oversampling::X1),
            Resolution::UltraHigh => (Oversampling::X16, Oversampling::X2),
        }
    }
}

/// Everything the `ctrl_meas` and `config` registers hold, applied in one driver call.
///
/// [`Default`] is normal mode at ultra low power (pressure and temperature x1), filter off,
/// standby 0.5 ms, 4-wire SPI: `ctrl_meas` = 0x27 and `config` = 0x00, a new sample about every
/// 6 ms, so a control loop at up to 160 Hz always finds a fresh one.
///
/// A worked example, fast pressure for altitude hold (datasheet table 7, "handheld device
/// dynamic", with a shorter filter):
/// ```
/// use bosch_bmp280::{Config, Filter, Resolution, Standby};
///
/// let config = Config::normal(Resolution::Standard, Standby::Ms0_5, Filter::X4);
/// assert_eq!(config.ctrl_meas(), 0x2F); // temperature x1, pressure x4, normal mode
/// assert_eq!(config.config_register(), 0x08); // t_sb 0.5 ms, filter 4
/// assert_eq!(Config::default().ctrl_meas(), 0x27);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Power mode written to `ctrl_meas`.
    pub mode: PowerMode,
    /// Temperature oversampling. Pressure compensation needs a temperature, so skipping it only
    /// makes sense when raw pressure alone is wanted.
    pub temperature_oversampling: Oversampling,
    /// Pressure oversampling.
    pub pressure_oversampling: Oversampling,
    /// IIR filter coefficient.
    pub filter: Filter,
    /// Standby time between measurements in normal mode.
    pub standby: Standby,
    /// Enables the 3-wire SPI interface (`spi3w_en`); leave off for 4-wire SPI and for I2C.
    pub spi_3wire: bool,
}

impl Default for Config {
    fn default() -> Self {
        Self::normal(Resolution::UltraLowPower, Standby::Ms0_5, Filter::Off)
    }
}

impl Config {
    /// An oversampling preset (datasheet table 4) in forced mode, filter off, standby 0.5 ms:
    /// one measurement per `start_forced`.
    pub const fn forced(resolution: Resolution) -> Self {
        let (pressure, temperature) = resolution.oversampling();
        Self {
            mode: PowerMode::Forced,
            temperature_oversampling: temperature,
            pressure_oversampling: pressure,
            filter: Filter::Off,
            standby: Standby::Ms0_5,
            spi_3wire: false,
        }
    }

    /// Datasheet table 7, "weather monitoring": ultra low power, forced mode, filter off.
    pub const fn weather_monitoring() -> Self {
        Self::forced(Resolution::UltraLowPower)
    }

    /// Datasheet table 7, "handheld device low-power": ultra high resolution, normal mode,
    /// standby 62.5 ms, filter 4.
    pub const fn handheld_low_power() -> Self {
        Self::normal(Resolution::UltraHigh, Standby::Ms62_5, Filter::X4)
    }

    /// Datasheet table 7, "handheld device dynamic": standard resolution, normal mode, standby
    /// 0.5 ms, filter 16.
    pub const fn handheld_dynamic() -> Self {
        Self::normal(Resolution::Standard, Standby::Ms0_5, Filter::X16)
    }

    /// Datasheet table 7, "elevator / floor change detection": standard resolution, normal
    /// mode, standby 125 ms, filter 4.
    pub const fn elevator() -> Self {
        Self::normal(Resolution::Standard, Standby::Ms125, Filter::X4)
    }

    /// Datasheet table 7, "drop detection": low power, normal mode, standby 0.5 ms, filter off.
    pub const fn drop_detection() -> Self {
        Self::normal(Resolution::LowPower, Standby::Ms0_5, Filter::Off)
    }

    /// Datasheet table 7, "indoor navigation": ultra high resolution, normal mode, standby
    /// 0.5 ms, filter 16.
    pub const fn indoor_navigation() -> Self {
        Self::normal(Resolution::UltraHigh, Standby::Ms0_5, Filter::X16)
    }

    /// An oversampling preset in normal mode with the given standby time and filter.
    pub const fn normal(resolution: Resolution, standby: Standby, filter: Filter) -> Self {
        let (pressure, temperature) = resolution.oversampling();
        Self {
            mode: PowerMode::Normal,
            temperature_oversampling: temperature,
            pressure_oversampling: pressure,
            filter,
            standby,
            spi_3wire: false,
        }
    }

    /// Replaces the power mode.
    pub const fn with_mode(mut self, mode: PowerMode) -> Self {
        self.mode = mode;
        self
    }

    /// Replaces the temperature oversampling.
    pub const fn with_temperature_oversampling(mut self, oversampling: Oversampling) -> Self {
        self.temperature_oversampling = oversampling;
        self
    }

    /// Replaces the pressure oversampling.
    pub const fn with_pressure_oversampling(mut self, oversampling: Oversampling) -> Self {
        self.pressure_oversampling = oversampling;
        self
    }

    /// Replaces both oversamplings by a datasheet preset.
    pub const fn with_resolution(mut self, resolution: Resolution) -> Self {
        let (pressure, temperature) = resolution.oversampling();
        self.pressure_oversampling = pressure;
        self.temperature_oversampling = temperature;
        self
    }

    /// Replaces the IIR filter coefficient.
    pub const fn with_filter(mut self, filter: Filter) -> Self {
        self.filter = filter;
        self
    }

    /// Replaces the normal-mode standby time.
    pub const fn with_standby(mut self, standby: Standby) -> Self {
        self.standby = standby;
        self
    }

    /// Enables or disables the 3-wire SPI interface.
    pub const fn with_spi_3wire(mut self, enabled: bool) -> Self {
        self.spi_3wire = enabled;
        self
    }

    /// The `ctrl_meas` (0xF4) value: `osrs_t[7:5] | osrs_p[4:2] | mode[1:0]`.
    pub const fn ctrl_meas(&self) -> u8 {
        ((self.temperature_oversampling as u8) << register::OSRS_T_SHIFT)
            | ((self.pressure_oversampling as u8) << register::OSRS_P_SHIFT)
            | self.mode as u8
    }

    /// The `config` (0xF5) value: `t_sb[7:5] | filter[4:2] | spi3w_en[0]`.
    pub const fn config_register(&self) -> u8 {
        ((self.standby as u8) << register::T_SB_SHIFT)
            | ((self.filter as u8) << register::FILTER_SHIFT)
            | if self.spi_3wire {
                register::SPI3W_EN
            } else {
                0
            }
    }

    /// Decodes register values read back from the device (bit 1 of `config` is ignored).
    pub const fn from_registers(ctrl_meas: u8, config: u8) -> Self {
        Self {
            mode: PowerMode::from_bits(ctrl_meas),
            temperature_oversampling: Oversampling::from_bits(ctrl_meas >> register::OSRS_T_SHIFT),
            pressure_oversampling: Oversampling::from_bits(ctrl_meas >> register::OSRS_P_SHIFT),
            filter: Filter::from_bits(config >> register::FILTER_SHIFT),
            standby: Standby::from_bits(config >> register::T_SB_SHIFT),
            spi_3wire: config & register::SPI3W_EN != 0,
        }
    }

    /// Typical time of one measurement in microseconds (datasheet appendix, 9.1):
    /// `1 + 2·osrs_t + (2·osrs_p + 0.5)` ms, each term only when that measurement is enabled.
    pub const fn measurement_time_typ_us(&self) -> u32 {
        let t = self.temperature_oversampling.samples();
        let p = self.pressure_oversampling.samples();
        1000 + 2000 * t + if p > 0 { 2000 * p + 500 } else { 0 }
    }

    /// Maximum time of one measurement in microseconds (datasheet appendix, 9.1):
    /// `1.25 + 2.3·osrs_t + (2.3·osrs_p + 0.575)` ms. Schedule reads after this to never catch
    /// a conversion in progress.
    pub const fn measurement_time_max_us(&self) -> u32 {
        let t = self.temperature_oversampling.samples();
        let p = self.pressure_oversampling.samples();
        1250 + 2300 * t + if p > 0 { 2300 * p + 575 } else { 0 }
    }

    /// Typical time between two normal-mode samples in microseconds: measurement plus standby
    /// (datasheet 3.8.2). The output data rate in Hz is `1e6 / period`.
    pub const fn normal_mode_period_typ_us(&self) -> u32 {
        self.measurement_time_typ_us() + self.standby.micros()
    }
}
