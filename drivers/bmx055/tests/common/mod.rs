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

/// `Accelerometer::init` with `AccelConfig::DIMA` (DESIGN section 3): soft reset, chip id
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

/// `Gyroscope::init` with `GyroConfig::DIMA` (DESIGN section 3): soft reset, chip id 0x0F,
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
