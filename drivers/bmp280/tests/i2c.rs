//! Exact I2C transactions of every driver operation (embedded-hal-mock), at both addresses.

mod common;

use bosch_bmp280::{Bmp280, Chip, Config, DeviceError, Error, I2cAddress, Resolution};
use common::*;
use embedded_hal::i2c::ErrorKind;
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as D};
use embedded_hal_mock::eh1::i2c::Mock;

#[test]
fn init_at_sdo_low() {
    let mut bmp = Bmp280::new_i2c(Mock::new(&i2c_init(I2C_ADDR_LOW)), I2cAddress::SdoLow);
    let mut delay = CheckedDelay::new(&[D::delay_us(2000)]);
    assert_eq!(bmp.init(&mut delay), Ok(Chip::Bmp280));
    assert_eq!(bmp.calibration(), Some(&DATASHEET_CALIB));
    delay.done();
    bmp.release().done();
}

#[test]
fn init_at_sdo_high() {
    let mut bmp = Bmp280::new_i2c(Mock::new(&i2c_init(I2C_ADDR_HIGH)), I2cAddress::SdoHigh);
    assert_eq!(bmp.init(&mut NoopDelay::new()), Ok(Chip::Bmp280));
    bmp.release().done();
}

#[test]
fn bme280_is_rejected_unless_accepted() {
    let a = I2C_ADDR_LOW;
    let expectations = [i2c_write(a, 0xE0, 0xB6), i2c_read(a, 0xD0, &[0x60])];
    let mut bmp = Bmp280::new_i2c(Mock::new(&expectations), I2cAddress::SdoLow);
    assert_eq!(
        bmp.init(&mut NoopDelay::new()),
        Err(Error::Device(DeviceError::Bme280NotAccepted))
    );
    bmp.release().done();

    let expectations = [
        i2c_write(a, 0xE0, 0xB6),
        i2c_read(a, 0xD0, &[0x60]),
        i2c_read(a, 0xF3, &[0x00]),
        i2c_read(a, 0x88, &DATASHEET_CALIB_BYTES),
    ];
    let mut bmp = Bmp280::new_i2c(Mock::new(&expectations), I2cAddress::SdoLow).accept_bme280(true);
    assert_eq!(bmp.init(&mut NoopDelay::new()), Ok(Chip::Bme280));
    bmp.release().done();
}

#[test]
fn default_config_writes_plain_register_addresses() {
    let a = I2C_ADDR_HIGH;
    let expectations = [
        i2c_write(a, 0xF4, 0x24),
        i2c_write(a, 0xF5, 0x00),
        i2c_write(a, 0xF4, 0x27),
    ];
    let mut bmp = Bmp280::new_i2c(Mock::new(&expectations), I2cAddress::SdoHigh);
    bmp.configure(Config::default()).unwrap();
    bmp.release().done();
}

#[test]
fn measure_reads_one_burst() {
    let a = I2C_ADDR_LOW;
    let mut expectations = i2c_init(a);
    expectations.push(i2c_read(a, 0xF7, &DATASHEET_DATA_BYTES));
    let mut bmp = Bmp280::new_i2c(Mock::new(&expectations), I2cAddress::SdoLow);
    bmp.init(&mut NoopDelay::new()).unwrap();
    let m = bmp.measure().unwrap();
    assert_eq!(m.temperature_centi_celsius, DATASHEET_T_CENTI);
    assert_eq!(m.pressure_q24_8, DATASHEET_P_Q24_8);
    bmp.release().done();
}

#[test]
fn forced_measurement_polls_measuring() {
    let a = I2C_ADDR_LOW;
    let mut expectations = i2c_init(a);
    expectations.extend([
        i2c_write(a, 0xF4, 0x24),
        i2c_write(a, 0xF5, 0x00),
        i2c_write(a, 0xF4, 0x25),
        i2c_write(a, 0xF4, 0x25),
        i2c_read(a, 0xF3, &[0x08, 0x25]),
        i2c_read(a, 0xF3, &[0x00, 0x24]),
        i2c_read(a, 0xF7, &DATASHEET_DATA_BYTES),
    ]);
    let mut bmp = Bmp280::new_i2c(Mock::new(&expectations), I2cAddress::SdoLow);
    bmp.init(&mut NoopDelay::new()).unwrap();
    bmp.configure(Config::forced(Resolution::UltraLowPower))
        .unwrap();
    bmp.start_forced().unwrap();
    assert_eq!(bmp.poll_forced(), Err(nb::Error::WouldBlock));
    assert_eq!(bmp.poll_forced().unwrap().pressure_pa(), DATASHEET_P_PA);
    bmp.release().done();
}

#[test]
fn bus_errors_are_passed_through() {
    let a = I2C_ADDR_LOW;
    let expectations = [
        i2c_write(a, 0xE0, 0xB6).with_error(ErrorKind::Other),
        i2c_read(a, 0xF7, &DATASHEET_DATA_BYTES).with_error(ErrorKind::Bus),
    ];
    let mut bmp = Bmp280::new_i2c(Mock::new(&expectations), I2cAddress::SdoLow);
    assert_eq!(
        bmp.init(&mut NoopDelay::new()),
        Err(Error::Comm(ErrorKind::Other))
    );
    assert_eq!(bmp.read_raw(), Err(Error::Comm(ErrorKind::Bus)));
    bmp.release().done();
}

#[test]
fn error_messages_name_the_device_and_the_cause() {
    let e: Error<ErrorKind> = Error::Device(DeviceError::InvalidChipId { found: 0xFF });
    let text = e.to_string();
    assert!(text.contains("0xff") && text.contains("0x58"), "{text}");
    let e: Error<ErrorKind> = Error::Device(DeviceError::NotCalibrated);
    assert!(e.to_string().contains("init"));
    let e: &dyn core::error::Error = &Error::<ErrorKind>::Device(DeviceError::Timeout);
    assert!(e.to_string().contains("BMP280"));
}
