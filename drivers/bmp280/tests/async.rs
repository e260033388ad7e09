//! The async driver issues the same transactions with the same waits as the blocking one.
#![cfg(feature = "async")]

mod common;

use std::future::Future;
use std::pin::pin;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use bosch_bmp280::{Bmp280Async, Chip, Config, DeviceError, Error, I2cAddress, Resolution};
use common::*;
use embedded_hal_mock::eh1::delay::{CheckedDelay, Transaction as D};
use embedded_hal_mock::eh1::i2c::Mock as I2cMock;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;

struct NoopWake;
impl Wake for NoopWake {
    fn wake(self: Arc<Self>) {}
}

/// Runs a future that never waits on anything outside the mocks (they complete at once).
fn block_on<F: Future>(fut: F) -> F::Output {
    let waker = Waker::from(Arc::new(NoopWake));
    let mut cx = Context::from_waker(&waker);
    let mut fut = pin!(fut);
    for _ in 0..1000 {
        if let Poll::Ready(out) = fut.as_mut().poll(&mut cx) {
            return out;
        }
    }
    panic!("future did not complete");
}

#[test]
fn spi_init_configure_measure() {
    let expectations = [
        spi_init(),
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x27),
        spi_read(0xF7, &DATASHEET_DATA_BYTES),
    ]
    .concat();
    let mut bmp = Bmp280Async::new_spi(SpiMock::new(&expectations));
    let mut delay = CheckedDelay::new(&[D::async_delay_us(2000)]);
    block_on(async {
        assert_eq!(bmp.init(&mut delay).await, Ok(Chip::Bmp280));
        bmp.configure(Config::default()).await.unwrap();
        let m = bmp.measure().await.unwrap();
        assert_eq!(m.temperature_centi_celsius, DATASHEET_T_CENTI);
        assert_eq!(m.pressure_q24_8, DATASHEET_P_Q24_8);
    });
    delay.done();
    bmp.release().done();
}

#[test]
fn spi_raw_bytes() {
    let mut bmp = Bmp280Async::new_spi(SpiMock::new(&spi_read(0xF7, &DATASHEET_DATA_BYTES)));
    assert_eq!(block_on(bmp.read_raw_bytes()), Ok(DATASHEET_DATA_BYTES));
    bmp.release().done();
}

#[test]
fn i2c_forced_measurement_waits_then_polls() {
    let a = I2C_ADDR_HIGH;
    let mut expectations = i2c_init(a);
    expectations.extend([
        i2c_write(a, 0xF4, 0x24),
        i2c_write(a, 0xF5, 0x00),
        i2c_write(a, 0xF4, 0x25),
        i2c_write(a, 0xF4, 0x25),
        i2c_read(a, 0xF3, &[0x00, 0x25]),
        i2c_read(a, 0xF3, &[0x00, 0x24]),
        i2c_read(a, 0xF7, &DATASHEET_DATA_BYTES),
    ]);
    let mut bmp = Bmp280Async::new_i2c(I2cMock::new(&expectations), I2cAddress::SdoHigh);
    let mut delay = CheckedDelay::new(&[
        D::async_delay_us(2000),
        D::async_delay_us(5500),
        D::async_delay_us(500),
    ]);
    block_on(async {
        bmp.init(&mut delay).await.unwrap();
        bmp.configure(Config::forced(Resolution::UltraLowPower))
            .await
            .unwrap();
        let m = bmp.measure_forced(&mut delay).await.unwrap();
        assert_eq!(m.pressure_pa(), DATASHEET_P_PA);
    });
    delay.done();
    bmp.release().done();
}

#[test]
fn i2c_wrong_chip_and_uncalibrated() {
    let a = I2C_ADDR_LOW;
    let expectations = [i2c_write(a, 0xE0, 0xB6), i2c_read(a, 0xD0, &[0x60])];
    let mut bmp = Bmp280Async::new_i2c(I2cMock::new(&expectations), I2cAddress::SdoLow);
    let mut delay = CheckedDelay::new(&[D::async_delay_us(2000)]);
    block_on(async {
        assert_eq!(
            bmp.init(&mut delay).await,
            Err(Error::Device(DeviceError::Bme280NotAccepted))
        );
        assert_eq!(
            bmp.measure().await,
            Err(Error::Device(DeviceError::NotCalibrated))
        );
        assert_eq!(
            bmp.measure_forced(&mut delay).await,
            Err(Error::Device(DeviceError::NotCalibrated))
        );
    });
    delay.done();
    bmp.release().done();
}

#[test]
fn spi_start_then_poll_forced() {
    // The same transactions and datasheet vector as the blocking driver's forced-mode poll.
    let expectations = [
        spi_init(),
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x25),
        spi_write(0x74, 0x25),
        spi_read(0xF3, &[0x08, 0x25]),
        spi_read(0xF3, &[0x00, 0x24]),
        spi_read(0xF7, &DATASHEET_DATA_BYTES),
    ]
    .concat();
    let mut bmp = Bmp280Async::new_spi(SpiMock::new(&expectations));
    let mut delay = CheckedDelay::new(&[D::async_delay_us(2000)]);
    block_on(async {
        bmp.init(&mut delay).await.unwrap();
        bmp.configure(Config::forced(Resolution::UltraLowPower))
            .await
            .unwrap();
        bmp.start_forced().await.unwrap();
        assert_eq!(bmp.poll_forced().await, Err(nb::Error::WouldBlock));
        let m = bmp.poll_forced().await.unwrap();
        assert_eq!(m.temperature_centi_celsius, DATASHEET_T_CENTI);
        assert_eq!(m.pressure_q24_8, DATASHEET_P_Q24_8);
    });
    delay.done();
    bmp.release().done();
}

#[test]
fn measure_right_after_configure_waits_for_the_first_conversion() {
    let reset = [0x80, 0x00, 0x00, 0x80, 0x00, 0x00];
    let expectations = [
        spi_init(),
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x27),
        spi_read(0xF7, &reset),
        spi_read(0xF7, &reset),
        spi_read(0xF7, &DATASHEET_DATA_BYTES),
    ]
    .concat();
    let mut bmp = Bmp280Async::new_spi(SpiMock::new(&expectations));
    let mut delay = CheckedDelay::new(&[D::async_delay_us(2000), D::async_delay_us(500)]);
    block_on(async {
        bmp.init(&mut delay).await.unwrap();
        bmp.configure(Config::default()).await.unwrap();
        assert_eq!(
            bmp.measure().await,
            Err(Error::Device(DeviceError::NoConversion))
        );
        let m = bmp.measure_when_ready(&mut delay).await.unwrap();
        assert_eq!(m.temperature_centi_celsius, DATASHEET_T_CENTI);
    });
    delay.done();
    bmp.release().done();
}
