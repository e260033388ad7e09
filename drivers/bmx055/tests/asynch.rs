//! The async twins produce the same bus transactions as the blocking drivers.
#![cfg(feature = "async")]

use bosch_bmx055::accel::AccelConfig;
use bosch_bmx055::gyro::GyroConfig;
use bosch_bmx055::mag::MagConfig;
use bosch_bmx055::{AsyncAccelerometer, AsyncGyroscope, AsyncMagnetometer, Xyz};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as T};
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

fn write(reg: u8, value: u8) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(vec![reg, value]),
        T::transaction_end(),
    ]
}

fn read(reg: u8, response: &[u8]) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(vec![reg | 0x80]),
        T::read_vec(response.to_vec()),
        T::transaction_end(),
    ]
}

fn script(parts: Vec<Vec<T<u8>>>) -> Vec<T<u8>> {
    parts.into_iter().flatten().collect()
}

#[test]
fn async_dima_configuration_and_reads() {
    let mut acc_spi = SpiMock::new(&script(vec![
        write(0x14, 0xB6),
        read(0x00, &[0xFA]),
        write(0x0F, 0x03),
        write(0x10, 0x0F),
        write(0x11, 0x00),
        read(0x02, &[0x01, 0x40, 0x00, 0x00, 0x00, 0x00]),
    ]));
    let mut gyro_spi = SpiMock::new(&script(vec![
        write(0x14, 0xB6),
        read(0x00, &[0x0F]),
        write(0x0F, 0x00),
        write(0x10, 0x81),
        write(0x11, 0x00),
    ]));
    let mut mag_spi = SpiMock::new(&script(vec![
        write(0x4B, 0x01),
        write(0x4B, 0x83),
        read(0x40, &[0x32]),
        read(0x5D, &[0x00, 0x00]),
        read(0x62, &[0x00, 0x00, 0x1A, 0x1A]),
        read(
            0x68,
            &[0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D],
        ),
        write(0x51, 0x01),
        write(0x52, 0x02),
        write(0x4C, 0x02),
        write(0x4C, 0x02),
        read(0x42, &[0, 0, 0, 0, 0, 0, 0x34, 0x6E]),
        // Shared vector row 2 (Bosch SensorAPI): 120, -90, -1538 µT.
        read(0x42, &[0x68, 0x0A, 0x30, 0xF8, 0x45, 0xDC, 0x35, 0x6E]),
    ]));
    let mut acc = AsyncAccelerometer::new_spi(acc_spi.clone());
    let mut gyro = AsyncGyroscope::new_spi(gyro_spi.clone());
    let mut mag = AsyncMagnetometer::new_spi(mag_spi.clone());
    block_on(async {
        acc.init(&mut NoopDelay, &AccelConfig::DIMA).await.unwrap();
        assert_eq!(acc.read_raw().await.unwrap().counts().x, 1024);
        gyro.init(&mut NoopDelay, &GyroConfig::DIMA).await.unwrap();
        mag.init(&mut NoopDelay, &MagConfig::DIMA).await.unwrap();
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
    assert_eq!(result.map(|r| r.x), Err(Error::Timeout));
    i2c.done();
}

#[test]
fn async_facade_samples_without_waiting() {
    use bosch_bmx055::{AsyncBmx055, Bmx055Config};
    let mut acc = SpiMock::new(&script(vec![
        write(0x14, 0xB6),
        read(0x00, &[0xFA]),
        write(0x0F, 0x03),
        write(0x10, 0x0F),
        write(0x11, 0x00),
        read(0x02, &[0x01, 0x40, 0x00, 0x00, 0x00, 0x00]),
    ]));
    let mut gyro = SpiMock::new(&script(vec![
        write(0x14, 0xB6),
        read(0x00, &[0x0F]),
        write(0x0F, 0x00),
        write(0x10, 0x81),
        write(0x11, 0x00),
        read(0x02, &[0; 6]),
    ]));
    let mut mag = SpiMock::new(&script(vec![
        write(0x4B, 0x01),
        write(0x4B, 0x83),
        read(0x40, &[0x32]),
        read(0x5D, &[0x00, 0x00]),
        read(0x62, &[0x00, 0x00, 0x1A, 0x1A]),
        read(
            0x68,
            &[0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D],
        ),
        write(0x51, 0x01),
        write(0x52, 0x02),
        write(0x4C, 0x02),
        read(0x42, &[0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x61, 0x6D]),
        write(0x4C, 0x02),
    ]));
    let mut imu = AsyncBmx055::new_spi(acc.clone(), gyro.clone(), mag.clone());
    let sample = block_on(async {
        imu.init(&mut NoopDelay, &Bmx055Config::DIMA).await.unwrap();
        imu.sample().await.unwrap()
    });
    assert!(sample.mag_fresh);
    assert_eq!(sample.accel.counts().x, 1024);
    assert_eq!(sample.mag.xyz.x, 0x0280);
    acc.done();
    gyro.done();
    mag.done();
}
