//! The facade: DIMA initialisation of all three dies and non-blocking sampling.

mod common;

use bosch_bmx055::mag::{compensate_f32, MagTrim};
use bosch_bmx055::{Bmx055, Xyz};
use common::{
    accel_deflection, accel_dima_init, gyro_dima_init, mag_dima_init, read, script, write, TRIM_1,
    TRIM_2, TRIM_3,
};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;

fn vector_trim() -> MagTrim {
    MagTrim::from_bursts(&TRIM_1, &TRIM_2, &TRIM_3)
}

#[test]
fn dima_init_then_sample_keeps_stale_mag_and_retriggers_on_fresh() {
    let acc_regs = [0x11, 0x00, 0xF1, 0xFF, 0x01, 0x40];
    let gyro_regs = [0x90, 0x02, 0x70, 0xFD, 0x00, 0x00];
    let mut acc = SpiMock::new(&script(vec![
        accel_dima_init(),
        read(0x02, &acc_regs),
        read(0x02, &acc_regs),
    ]));
    let mut gyro = SpiMock::new(&script(vec![
        gyro_dima_init(),
        read(0x02, &gyro_regs),
        read(0x02, &gyro_regs),
    ]));
    let mut mag = SpiMock::new(&script(vec![
        mag_dima_init(),
        // First sample: measurement still running.
        read(0x42, &[0, 0, 0, 0, 0, 0, 0x00, 0x00]),
        // Second sample: fresh (shared vector row 1), next forced measurement started.
        read(0x42, &[0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x61, 0x6D]),
        write(0x4C, 0x02),
    ]));
    let mut imu = Bmx055::new_spi(acc.clone(), gyro.clone(), mag.clone());
    let trim = imu.init(&mut NoopDelay, &common::DIMA_IMU).unwrap();
    assert_eq!(trim, vector_trim());

    let first = imu.sample().unwrap();
    assert!(!first.mag_fresh);
    assert_eq!(first.mag.xyz, Xyz::new(0, 0, 0));

    let second = imu.sample().unwrap();
    assert!(second.mag_fresh);
    // Accelerometer status nibble and magnetometer DRDY masked.
    assert_eq!(second.accel.words, Xyz::new(0x0010, -16, 0x4000));
    assert_eq!(second.gyro.words, Xyz::new(0x0290, -656, 0));
    assert_eq!(second.mag.rhall, 0x6D60);
    assert_eq!(compensate_f32(&second.mag.to_raw(), &trim).x.round(), 29.0);
    acc.done();
    gyro.done();
    mag.done();
}

#[test]
fn self_test_reports_a_failing_die_and_reconfigures() {
    // Accel deflections of 1000 mg on every axis (512 counts at ±4 g) pass.
    let mut acc_script = vec![write(0x0F, 0x05)];
    for axis in 0..3u8 {
        // axis | sign (0x04) | self_test_amp high (0x10), Bosch BMA2 SensorAPI.
        acc_script.push(write(0x32, (axis + 1) | 0x04 | 0x10));
        acc_script.push(read(0x02, &accel_deflection(axis.into(), 256)));
        acc_script.push(write(0x32, (axis + 1) | 0x10));
        acc_script.push(read(0x02, &accel_deflection(axis.into(), -256)));
    }
    acc_script.extend([
        write(0x32, 0x00),
        write(0x14, 0xB6),
        write(0x0F, 0x03),
        write(0x10, 0x0F),
        write(0x11, 0x00),
    ]);
    let mut acc = SpiMock::new(&script(acc_script));
    // Gyro BIST passes.
    let mut gyro = SpiMock::new(&script(vec![
        read(0x3C, &[0x10]),
        write(0x3C, 0x01),
        read(0x3C, &[0x12]),
    ]));
    // Magnetometer self-test: Z axis fails.
    let mut mag = SpiMock::new(&script(vec![
        write(0x4C, 0x06),
        write(0x4C, 0x07),
        read(0x4C, &[0x06]),
        read(0x42, &[0x01, 0x00, 0x01, 0x00, 0x00, 0x00]),
        write(0x51, 0x01),
        write(0x52, 0x02),
        write(0x4C, 0x02),
    ]));
    let mut imu = Bmx055::new_spi(acc.clone(), gyro.clone(), mag.clone());
    assert_eq!(
        imu.self_test(&mut NoopDelay, &common::DIMA_IMU),
        Err(bosch_bmx055::Error::Device(
            bosch_bmx055::DeviceError::SelfTestFailed
        ))
    );
    acc.done();
    gyro.done();
    mag.done();
}
