//! The DIMA sensor board's sensor settings (the configuration the original board intended), kept
//! here rather than in the general-purpose driver crates.

use bosch_bmp280::{Config as BaroConfig, Filter, Resolution, Standby};
use bosch_bmx055::accel::{AccelBandwidth, AccelConfig, AccelPowerMode, AccelRange};
use bosch_bmx055::gyro::{GyroBandwidth, GyroConfig, GyroPowerMode, GyroRange};
use bosch_bmx055::mag::{MagConfig, MagPreset};

/// BMX055 accelerometer: ±2 g (0x0F = 0x03), 1000 Hz bandwidth (0x10 = 0x0F), normal mode.
pub const ACCEL: AccelConfig = AccelConfig {
    range: AccelRange::G2,
    bandwidth: AccelBandwidth::Hz1000,
    power: AccelPowerMode::Normal,
};

/// BMX055 gyroscope: ±2000 °/s (0x0F = 0x00), 2000 Hz with the 230 Hz filter (0x10 = 0x81),
/// normal mode.
pub const GYRO: GyroConfig = GyroConfig {
    range: GyroRange::Dps2000,
    bandwidth: GyroBandwidth::Odr2000Bw230,
    power: GyroPowerMode::Normal,
};

/// BMX055 magnetometer: low-power preset (0x51 = 0x01, 0x52 = 0x02), forced mode.
pub const MAG: MagConfig = MagConfig::forced(MagPreset::LowPower);

/// BMP280: normal mode, pressure and temperature x1, filter off, standby 0.5 ms, 4-wire SPI:
/// `ctrl_meas` 0xF4 = 0x27, `config` 0xF5 = 0x00. A new sample about every 6 ms, so the 250 Hz
/// control loop always finds a fresh one.
pub const BAROMETER: BaroConfig =
    BaroConfig::normal(Resolution::UltraLowPower, Standby::Ms0_5, Filter::Off);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn imu_registers() {
        assert_eq!(
            ACCEL.register_writes(),
            [(0x0F, 0x03), (0x10, 0x0F), (0x11, 0x00)]
        );
        assert!(GYRO.register_writes().contains(&(0x0F, 0x00)));
        assert!(GYRO.register_writes().contains(&(0x10, 0x81)));
        let mag = MAG.register_writes();
        assert!(mag.contains(&(0x51, 0x01)) && mag.contains(&(0x52, 0x02)));
    }

    #[test]
    fn barometer_registers() {
        assert_eq!(BAROMETER.ctrl_meas(), 0x27);
        assert_eq!(BAROMETER.config_register(), 0x00);
    }
}
