//! The DIMA sensor-board configuration as exact SPI transactions (±2 g / 1000 Hz, ±2000 °/s / 0x81, magnetometer low-power preset in forced mode):
//! accel ±2 g / 1000 Hz / normal, gyro ±2000 °/s / 0x81 / normal, magnetometer low-power
//! preset in forced mode, and a forced magnetometer read that polls data ready.

mod common;

use bosch_bmx055::accel::Accelerometer;
use bosch_bmx055::gyro::Gyroscope;
use bosch_bmx055::mag::Magnetometer;
use bosch_bmx055::{Error, Xyz};
use common::{
    accel_dima_init, gyro_dima_init, mag_dima_init, read, script, write, TRIM_1, TRIM_2, TRIM_3,
};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;

#[test]
fn accel_dima_configuration() {
    let mut spi = SpiMock::new(&script(vec![accel_dima_init()]));
    let mut acc = Accelerometer::new_spi(spi.clone());
    acc.init(&mut NoopDelay, &common::DIMA_ACCEL).unwrap();
    spi.done();
}

#[test]
fn gyro_dima_configuration() {
    let mut spi = SpiMock::new(&script(vec![gyro_dima_init()]));
    let mut gyro = Gyroscope::new_spi(spi.clone());
    gyro.init(&mut NoopDelay, &common::DIMA_GYRO).unwrap();
    spi.done();
}

#[test]
fn mag_dima_configuration_powers_on_before_the_chip_id() {
    let mut spi = SpiMock::new(&script(vec![
        write(0x4B, 0x01),
        write(0x4B, 0x83),
        // Still starting: chip id reads 0 once, then 0x32 (bounded retries).
        read(0x40, &[0x00]),
        read(0x40, &[0x32]),
        read(0x5D, &TRIM_1),
        read(0x62, &TRIM_2),
        read(0x68, &TRIM_3),
        write(0x51, 0x01),
        write(0x52, 0x02),
        write(0x4C, 0x02),
    ]));
    let mut mag = Magnetometer::new_spi(spi.clone());
    let trim = mag.init(&mut NoopDelay, &common::DIMA_MAG).unwrap();
    assert_eq!(trim.dig_xyz1, 7053);
    spi.done();
}

#[test]
fn forced_read_polls_data_ready_and_compensates() {
    let mut parts = vec![mag_dima_init()];
    parts.extend(vec![
        write(0x4C, 0x02),
        // Previous sample still in the registers, data-ready clear: must not be returned.
        read(0x42, &[0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x34, 0x6E]),
        read(0x42, &[0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x34, 0x6E]),
        // Fresh sample (vector row 1), data ready set.
        read(0x42, &[0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x61, 0x6D]),
    ]);
    let mut spi = SpiMock::new(&script(parts));
    let mut mag = Magnetometer::new_spi(spi.clone());
    mag.init(&mut NoopDelay, &common::DIMA_MAG).unwrap();
    let ut = mag.read_forced_ut(&mut NoopDelay).unwrap();
    assert_eq!(ut, Xyz::new(29, -21, -45));
    spi.done();
}

#[test]
fn forced_read_times_out_instead_of_spinning() {
    let mut parts = vec![write(0x4C, 0x02)];
    for _ in 0..bosch_bmx055::mag::FORCED_POLL_ATTEMPTS {
        parts.push(read(0x42, &[0, 0, 0, 0, 0, 0, 0x00, 0x00]));
    }
    let mut spi = SpiMock::new(&script(parts));
    let mut mag = Magnetometer::new_spi(spi.clone());
    assert_eq!(
        mag.read_forced(&mut NoopDelay),
        Err(Error::Device(bosch_bmx055::DeviceError::Timeout))
    );
    spi.done();
}

#[test]
fn wrong_chip_id_is_reported_after_bounded_retries() {
    let mut spi = SpiMock::new(&script(vec![
        write(0x14, 0xB6),
        read(0x00, &[0x00]),
        read(0x00, &[0x00]),
        read(0x00, &[0xFB]),
    ]));
    let mut acc = Accelerometer::new_spi(spi.clone());
    assert_eq!(
        acc.init(&mut NoopDelay, &common::DIMA_ACCEL),
        Err(Error::Device(bosch_bmx055::DeviceError::InvalidChipId {
            found: 0xFB
        }))
    );
    spi.done();
}

#[test]
fn accel_raw_read_masks_status_bits_into_packet_words() {
    // X = +1 count with new_data set, Y = -1 count, Z = 1024 counts (1 g at ±2 g).
    let mut spi = SpiMock::new(&script(vec![read(
        0x02,
        &[0x11, 0x00, 0xF1, 0xFF, 0x01, 0x40],
    )]));
    let mut acc = Accelerometer::new_spi(spi.clone());
    let raw = acc.read_raw().unwrap();
    assert_eq!(raw.words, Xyz::new(0x0010, -16, 0x4000));
    assert_eq!(raw.counts(), Xyz::new(1, -1, 1024));
    assert_eq!(raw.new_data, Xyz::new(true, true, true));
    let mg = raw.mg(acc.range());
    assert!((mg.z - 1000.0).abs() < 1e-3);
    spi.done();
}

#[test]
fn gyro_raw_read_is_the_packet_word() {
    // 0x0290 = 656 counts = 40 °/s at ±2000 °/s (16.4 LSB per °/s).
    let mut spi = SpiMock::new(&script(vec![read(
        0x02,
        &[0x90, 0x02, 0x70, 0xFD, 0x00, 0x00],
    )]));
    let mut gyro = Gyroscope::new_spi(spi.clone());
    let raw = gyro.read_raw().unwrap();
    assert_eq!(raw.words, Xyz::new(656, -656, 0));
    let dps = raw.dps(gyro.range());
    assert!((dps.x - 40.0).abs() < 1e-4 && (dps.y + 40.0).abs() < 1e-4);
    spi.done();
}
