//! The async twins produce the same bus transactions as the blocking drivers.
#![cfg(feature = "async")]

mod common;

use bosch_bmx055::accel::AsyncAccelerometer;
use bosch_bmx055::gyro::AsyncGyroscope;
use bosch_bmx055::mag::AsyncMagnetometer;
use bosch_bmx055::Xyz;
use common::{
    accel_deflection, accel_dima_init, gyro_dima_init, mag_dima_init, read, script, write,
};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;
use std::future::Future;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

/// Minimal executor: the mocks complete immediately, so polling in a loop terminates.
fn block_on<F: Future>(fut: F) -> F::Output {
    struct Noop;
    impl Wake for Noop {
        fn wake(self: Arc<Self>) {}
    }
    let waker = Waker::from(Arc::new(Noop));
    let mut cx = Context::from_waker(&waker);
    let mut fut = std::pin::pin!(fut);
    for _ in 0..1_000_000 {
        if let Poll::Ready(v) = fut.as_mut().poll(&mut cx) {
            return v;
        }
    }
    panic!("future did not complete");
}

#[test]
fn async_dima_configuration_and_reads() {
    let mut acc_spi = SpiMock::new(&script(vec![
        accel_dima_init(),
        read(0x02, &[0x01, 0x40, 0x00, 0x00, 0x00, 0x00]),
    ]));
    let mut gyro_spi = SpiMock::new(&script(vec![gyro_dima_init()]));
    let mut mag_spi = SpiMock::new(&script(vec![
        mag_dima_init(),
        write(0x4C, 0x02),
        read(0x42, &[0, 0, 0, 0, 0, 0, 0x34, 0x6E]),
        // Shared vector row 2 (Bosch SensorAPI): 120, -90, -1538 µT.
        read(0x42, &[0x68, 0x0A, 0x30, 0xF8, 0x45, 0xDC, 0x35, 0x6E]),
    ]));
    let mut acc = AsyncAccelerometer::new_spi(acc_spi.clone());
    let mut gyro = AsyncGyroscope::new_spi(gyro_spi.clone());
    let mut mag = AsyncMagnetometer::new_spi(mag_spi.clone());
    block_on(async {
        acc.init(&mut NoopDelay, &common::DIMA_ACCEL).await.unwrap();
        assert_eq!(acc.read_raw().await.unwrap().counts().x, 1024);
        gyro.init(&mut NoopDelay, &common::DIMA_GYRO).await.unwrap();
        mag.init(&mut NoopDelay, &common::DIMA_MAG).await.unwrap();
        assert_eq!(
            mag.read_forced_ut(&mut NoopDelay).await.unwrap(),
            Xyz::new(120, -90, -1538)
        );
    });
    acc_spi.done();
    gyro_spi.done();
    mag_spi.done();
}

#[test]
fn async_i2c_gyro_and_forced_timeout() {
    use bosch_bmx055::gyro::{GyroAddress, GyroRange};
    use bosch_bmx055::mag::{MagAddress, FORCED_POLL_ATTEMPTS};
    use bosch_bmx055::Error;
    use embedded_hal_mock::eh1::i2c::{Mock as I2cMock, Transaction as I};

    let mut i2c = I2cMock::new(&[
        I::write(0x69, vec![0x0F, 0x04]),
        I::write_read(0x69, vec![0x02], vec![0x06, 0x01, 0x00, 0x00, 0xFA, 0xFE]),
    ]);
    let mut gyro = AsyncGyroscope::new_i2c(i2c.clone(), GyroAddress::Sdo2High);
    block_on(async {
        gyro.set_range(GyroRange::Dps125).await.unwrap();
        // 262 counts = 0.9985 °/s at ±125 °/s (262.4 LSB per °/s).
        let dps = gyro.read_dps().await.unwrap();
        assert!((dps.x - 262.0 / 262.4).abs() < 1e-4);
        assert!((dps.z + 262.0 / 262.4).abs() < 1e-4);
    });
    i2c.done();

    let mut script = vec![I::write(0x10, vec![0x4C, 0x02])];
    for _ in 0..FORCED_POLL_ATTEMPTS {
        script.push(I::write_read(0x10, vec![0x42], vec![0; 8]));
    }
    let mut i2c = I2cMock::new(&script);
    let mut mag = AsyncMagnetometer::new_i2c(i2c.clone(), MagAddress::Csb3LowSdo3Low);
    let result = block_on(mag.read_forced(&mut NoopDelay));
    assert_eq!(
        result.map(|r| r.x),
        Err(Error::Device(bosch_bmx055::DeviceError::Timeout))
    );
    i2c.done();
}

#[test]
fn async_facade_samples_without_waiting() {
    use bosch_bmx055::AsyncBmx055;
    let mut acc = SpiMock::new(&script(vec![
        accel_dima_init(),
        read(0x02, &[0x01, 0x40, 0x00, 0x00, 0x00, 0x00]),
    ]));
    let mut gyro = SpiMock::new(&script(vec![gyro_dima_init(), read(0x02, &[0; 6])]));
    let mut mag = SpiMock::new(&script(vec![
        mag_dima_init(),
        read(0x42, &[0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x61, 0x6D]),
        write(0x4C, 0x02),
    ]));
    let mut imu = AsyncBmx055::new_spi(acc.clone(), gyro.clone(), mag.clone());
    let sample = block_on(async {
        imu.init(&mut NoopDelay, &common::DIMA_IMU).await.unwrap();
        imu.sample().await.unwrap()
    });
    assert!(sample.mag_fresh);
    assert_eq!(sample.accel.counts().x, 1024);
    assert_eq!(sample.mag.xyz.x, 0x0280);
    acc.done();
    gyro.done();
    mag.done();
}

#[test]
fn async_accel_self_test_writes_the_documented_bytes() {
    // ±4 g (0x0F = 0x05), then per axis PMU_SELF_TEST = axis | sign (0x04) | self_test_amp
    // high (0x10), as Bosch's BMA2 SensorAPI `selftest_config` sets it; a 1000 mg deflection
    // (512 counts at ±4 g, split +-256) on every axis passes the 800/800/400 mg limits.
    let mut parts = vec![write(0x0F, 0x05)];
    for (axis, (pos, neg)) in [(0x15, 0x11), (0x16, 0x12), (0x17, 0x13)]
        .into_iter()
        .enumerate()
    {
        parts.push(write(0x32, pos));
        parts.push(read(0x02, &accel_deflection(axis, 256)));
        parts.push(write(0x32, neg));
        parts.push(read(0x02, &accel_deflection(axis, -256)));
    }
    parts.push(write(0x32, 0x00));
    parts.push(write(0x14, 0xB6));
    let mut spi = SpiMock::new(&script(parts));
    let mut acc = AsyncAccelerometer::new_spi(spi.clone());
    let r = block_on(acc.self_test(&mut NoopDelay)).unwrap();
    assert!(r.passed());
    assert!((r.difference_mg.y - 1000.0).abs() < 0.1);
    spi.done();
}
