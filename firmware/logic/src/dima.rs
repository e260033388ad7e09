//! The DIMA sensor board's sensor settings (the configuration the original board intended), kept
//! here rather than in the general-purpose driver crates.

use bosch_bmp280::{Config as BaroConfig, Filter, Resolution, Standby};

/// BMP280: normal mode, pressure and temperature x1, filter off, standby 0.5 ms, 4-wire SPI:
/// `ctrl_meas` 0xF4 = 0x27, `config` 0xF5 = 0x00. A new sample about every 6 ms, so the 250 Hz
/// control loop always finds a fresh one.
pub const BAROMETER: BaroConfig =
    BaroConfig::normal(Resolution::UltraLowPower, Standby::Ms0_5, Filter::Off);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barometer_registers() {
        assert_eq!(BAROMETER.ctrl_meas(), 0x27);
        assert_eq!(BAROMETER.config_register(), 0x00);
    }
}
