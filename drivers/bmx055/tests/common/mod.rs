//! Transaction builders shared by the SPI integration tests.
//!
//! Each test binary uses a different subset, hence the `dead_code` allowance.
#![allow(dead_code)]

use embedded_hal_mock::eh1::spi::Transaction as T;

/// One register write as the dies see it on SPI: address with bit 7 clear, then the value.
pub fn write(reg: u8, value: u8) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(vec![reg, value]),
        T::transaction_end(),
    ]
}

/// One burst read on SPI: address with bit 7 set, then `response` clocked back.
pub fn read(reg: u8, response: &[u8]) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(vec![reg | 0x80]),
        T::read_vec(response.to_vec()),
        T::transaction_end(),
    ]
}

/// Concatenate transaction groups into one expectation list.
pub fn script(parts: Vec<Vec<T<u8>>>) -> Vec<T<u8>> {
    parts.into_iter().flatten().collect()
}

/// `Accelerometer::init` with the DIMA configuration (`DIMA_ACCEL`): soft reset, chip id
/// 0xFA, range ±2 g, bandwidth 1000 Hz, normal mode.
pub fn accel_dima_init() -> Vec<T<u8>> {
    script(vec![
        write(0x14, 0xB6),
        read(0x00, &[0xFA]),
        write(0x0F, 0x03),
        write(0x10, 0x0F),
        write(0x11, 0x00),
    ])
}

/// `Gyroscope::init` with the DIMA configuration (`DIMA_GYRO`): soft reset, chip id 0x0F,
/// range ±2000 °/s, bandwidth 0x81, normal mode.
pub fn gyro_dima_init() -> Vec<T<u8>> {
    script(vec![
        write(0x14, 0xB6),
        read(0x00, &[0x0F]),
        write(0x0F, 0x00),
        write(0x10, 0x81),
        write(0x11, 0x00),
    ])
}

/// Magnetometer trim bursts (0x5D, 0x62, 0x68) from the shared BMM150 vectors (Bosch
/// SensorAPI section).
pub const TRIM_1: [u8; 2] = [0x00, 0x00];
/// Second trim burst, see [`TRIM_1`].
pub const TRIM_2: [u8; 4] = [0x00, 0x00, 0x1A, 0x1A];
/// Third trim burst, see [`TRIM_1`].
pub const TRIM_3: [u8; 10] = [0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D];

/// `Magnetometer::init` with the DIMA configuration (`DIMA_MAG`) on a die that answers at
/// once: power on, soft reset, chip id 0x32, the three trim bursts, low-power preset
/// (repetitions 0x01 / 0x02), forced mode.
pub fn mag_dima_init() -> Vec<T<u8>> {
    script(vec![
        write(0x4B, 0x01),
        write(0x4B, 0x83),
        read(0x40, &[0x32]),
        read(0x5D, &TRIM_1),
        read(0x62, &TRIM_2),
        read(0x68, &TRIM_3),
        write(0x51, 0x01),
        write(0x52, 0x02),
        write(0x4C, 0x02),
    ])
}

/// Accelerometer data registers (0x02..0x07) holding `counts` on `axis` (0 = X) and zero on
/// the others: 12-bit counts sit in the upper bits of each little-endian word.
pub fn accel_deflection(axis: usize, counts: i16) -> [u8; 6] {
    let mut b = [0u8; 6];
    let w = (counts << 4).to_le_bytes();
    b[2 * axis] = w[0];
    b[2 * axis + 1] = w[1];
    b
}

/// A worked configuration used across the tests: ±2 g, 1000 Hz, normal mode.
pub const DIMA_ACCEL: bosch_bmx055::accel::AccelConfig = bosch_bmx055::accel::AccelConfig {
    range: bosch_bmx055::accel::AccelRange::G2,
    bandwidth: bosch_bmx055::accel::AccelBandwidth::Hz1000,
    power: bosch_bmx055::accel::AccelPowerMode::Normal,
};
/// ±2000 °/s, 2000 Hz / 230 Hz (0x81), normal mode.
pub const DIMA_GYRO: bosch_bmx055::gyro::GyroConfig = bosch_bmx055::gyro::GyroConfig {
    range: bosch_bmx055::gyro::GyroRange::Dps2000,
    bandwidth: bosch_bmx055::gyro::GyroBandwidth::Odr2000Bw230,
    power: bosch_bmx055::gyro::GyroPowerMode::Normal,
};
/// Low-power preset, forced mode.
pub const DIMA_MAG: bosch_bmx055::mag::MagConfig =
    bosch_bmx055::mag::MagConfig::forced(bosch_bmx055::mag::MagPreset::LowPower);
/// The three together.
pub const DIMA_IMU: bosch_bmx055::Bmx055Config = bosch_bmx055::Bmx055Config {
    accel: DIMA_ACCEL,
    gyro: DIMA_GYRO,
    mag: DIMA_MAG,
};
