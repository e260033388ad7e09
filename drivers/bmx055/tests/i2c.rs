//! The three dies over I2C at their strapped addresses.

mod common;

use bosch_bmx055::accel::AccelAddress;
use bosch_bmx055::accel::Accelerometer;
use bosch_bmx055::gyro::GyroAddress;
use bosch_bmx055::gyro::Gyroscope;
use bosch_bmx055::mag::MagAddress;
use bosch_bmx055::mag::Magnetometer;
use bosch_bmx055::Xyz;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock as I2cMock, Transaction as T};

#[test]
fn accel_at_0x19() {
    let a = 0x19;
    let mut i2c = I2cMock::new(&[
        T::write(a, vec![0x14, 0xB6]),
        T::write_read(a, vec![0x00], vec![0xFA]),
        T::write(a, vec![0x0F, 0x03]),
        T::write(a, vec![0x10, 0x0F]),
        T::write(a, vec![0x11, 0x00]),
        T::write_read(a, vec![0x02], vec![0x00, 0x40, 0x00, 0x00, 0x00, 0xC0]),
    ]);
    let mut acc = Accelerometer::new_i2c(i2c.clone(), AccelAddress::Sdo1High);
    acc.init(&mut NoopDelay, &common::DIMA_ACCEL).unwrap();
    let raw = acc.read_raw().unwrap();
    assert_eq!(raw.counts(), Xyz::new(1024, 0, -1024));
    acc.release();
    i2c.done();
}

#[test]
fn gyro_at_0x68() {
    let a = 0x68;
    let mut i2c = I2cMock::new(&[
        T::write(a, vec![0x14, 0xB6]),
        T::write_read(a, vec![0x00], vec![0x0F]),
        T::write(a, vec![0x0F, 0x00]),
        T::write(a, vec![0x10, 0x81]),
        T::write(a, vec![0x11, 0x00]),
    ]);
    let mut gyro = Gyroscope::new_i2c(i2c.clone(), GyroAddress::Sdo2Low);
    gyro.init(&mut NoopDelay, &common::DIMA_GYRO).unwrap();
    i2c.done();
}

#[test]
fn mag_at_0x13_reads_trim_and_packet_words() {
    let a = 0x13;
    let mut i2c = I2cMock::new(&[
        T::write(a, vec![0x4B, 0x01]),
        T::write(a, vec![0x4B, 0x83]),
        T::write_read(a, vec![0x40], vec![0x32]),
        T::write_read(a, vec![0x5D], vec![0x00, 0x00]),
        T::write_read(a, vec![0x62], vec![0x00, 0x00, 0x1A, 0x1A]),
        T::write_read(
            a,
            vec![0x68],
            vec![0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D],
        ),
        T::write(a, vec![0x51, 0x01]),
        T::write(a, vec![0x52, 0x02]),
        T::write(a, vec![0x4C, 0x02]),
        // Status bits set in every LSB: the packet words must mask them.
        T::write_read(
            a,
            vec![0x42],
            vec![0x87, 0x02, 0x27, 0xFE, 0xF5, 0xFE, 0x63, 0x6D],
        ),
    ]);
    let mut mag = Magnetometer::new_i2c(i2c.clone(), MagAddress::Csb3HighSdo3High);
    mag.init(&mut NoopDelay, &common::DIMA_MAG).unwrap();
    let w = mag.read_packet_words().unwrap();
    assert_eq!(w.xyz, Xyz::new(0x0280, 0xFE20u16 as i16, 0xFEF4u16 as i16));
    assert_eq!(w.rhall, 0x6D60);
    assert_eq!(
        w.to_le_bytes(),
        [0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x60, 0x6D]
    );
    i2c.done();
}
