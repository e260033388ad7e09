//! `measure()` never hands out the data registers' reset value as a reading: straight after
//! `configure()` (or in sleep mode) the registers hold 0x80000 until the first conversion ends,
//! and the datasheet calibration would turn that into a believable 26.46 °C and 82 044 Pa.

mod common;

use bosch_bmp280::{Bmp280, Config, DeviceError, Error, RawSample};
use common::*;
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as D};
use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};

/// Registers 0xF7..=0xFC after power-on or soft reset (datasheet memory map: 0x80, 0x00, 0x00
/// for both the pressure and the temperature registers).
const RESET_DATA_BYTES: [u8; 6] = [0x80, 0x00, 0x00, 0x80, 0x00, 0x00];

/// `init`, then `configure(Config::default())` (normal mode, `ctrl_meas` 0x27), then `rest`.
fn configured(rest: &[T<u8>]) -> Bmp280<bosch_bmp280::SpiInterface<Mock<u8>>> {
    let all = [
        spi_init(),
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x27),
        rest.to_vec(),
    ]
    .concat();
    let mut bmp = Bmp280::new_spi(Mock::new(&all));
    bmp.init(&mut NoopDelay::new()).unwrap();
    bmp.configure(Config::default()).unwrap();
    bmp
}

#[test]
fn the_reset_value_is_recognised_as_no_conversion() {
    let raw = RawSample::from_register_bytes(&RESET_DATA_BYTES);
    assert!(raw.holds_no_conversion());
    assert!(!RawSample::from_register_bytes(&DATASHEET_DATA_BYTES).holds_no_conversion());
}

#[test]
fn measure_straight_after_configure_is_an_error_not_a_reading() {
    let mut bmp = configured(&spi_read(0xF7, &RESET_DATA_BYTES));
    assert_eq!(bmp.measure(), Err(Error::Device(DeviceError::NoConversion)));
    bmp.release().done();
}

#[test]
fn measure_when_ready_waits_for_the_first_conversion() {
    let mut bmp = configured(
        &[
            spi_read(0xF7, &RESET_DATA_BYTES),
            spi_read(0xF7, &RESET_DATA_BYTES),
            spi_read(0xF7, &DATASHEET_DATA_BYTES),
        ]
        .concat(),
    );
    let mut delay = CheckedDelay::new(&[D::delay_us(500), D::delay_us(500)]);
    let m = bmp.measure_when_ready(&mut delay).unwrap();
    assert_eq!(m.temperature_centi_celsius, DATASHEET_T_CENTI);
    assert_eq!(m.pressure_q24_8, DATASHEET_P_Q24_8);
    delay.done();
    bmp.release().done();
}

#[test]
fn measure_when_ready_gives_up_after_the_maximum_measurement_time() {
    let config = Config::default();
    // The first conversion of normal mode ends within the maximum measurement time; 2 ms of
    // slack for the caller's delay, polled every 0.5 ms.
    let polls = (config.measurement_time_max_us() + 2000) / 500 + 1;
    let reads: Vec<T<u8>> = (0..polls)
        .flat_map(|_| spi_read(0xF7, &RESET_DATA_BYTES))
        .collect();
    let mut bmp = configured(&reads);
    let delays: Vec<D> = (0..polls).map(|_| D::delay_us(500)).collect();
    let mut delay = CheckedDelay::new(&delays);
    assert_eq!(
        bmp.measure_when_ready(&mut delay),
        Err(Error::Device(DeviceError::Timeout))
    );
    delay.done();
    bmp.release().done();
}

#[test]
fn measure_in_sleep_mode_without_a_conversion_is_an_error_without_waiting() {
    let all = [spi_init(), spi_read(0xF7, &RESET_DATA_BYTES)].concat();
    let mut bmp = Bmp280::new_spi(Mock::new(&all));
    bmp.init(&mut NoopDelay::new()).unwrap();
    let mut delay = CheckedDelay::new(&[]);
    assert_eq!(
        bmp.measure_when_ready(&mut delay),
        Err(Error::Device(DeviceError::NoConversion))
    );
    delay.done();
    bmp.release().done();
}

#[test]
fn a_forced_poll_before_any_conversion_is_an_error() {
    // Without a started measurement the device is idle in sleep mode; the registers still hold
    // their reset value.
    let all = [
        spi_init(),
        spi_read(0xF3, &[0x00, 0x00]),
        spi_read(0xF7, &RESET_DATA_BYTES),
    ]
    .concat();
    let mut bmp = Bmp280::new_spi(Mock::new(&all));
    bmp.init(&mut NoopDelay::new()).unwrap();
    assert_eq!(
        bmp.poll_forced(),
        Err(bosch_bmp280::nb::Error::Other(Error::Device(
            DeviceError::NoConversion
        )))
    );
    bmp.release().done();
}
