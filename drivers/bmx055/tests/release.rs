//! `release()` gives back what the constructor was given: the bus, not the interface wrapper.

mod common;

use bosch_bmx055::accel::{AccelAddress, Accelerometer};
use bosch_bmx055::gyro::{GyroAddress, Gyroscope};
use bosch_bmx055::mag::{MagAddress, Magnetometer};
use bosch_bmx055::{Bmx055, SpiInterface};
use common::read;
use embedded_hal_mock::eh1::i2c::Mock as I2cMock;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;

#[test]
fn each_die_gives_its_spi_device_back() {
    let mut acc = Accelerometer::new_spi(SpiMock::new(&read(0x00, &[0xFA])));
    assert_eq!(acc.chip_id().unwrap(), 0xFA);
    let mut spi: SpiMock<u8> = acc.release();
    spi.done();

    let mut gyro = Gyroscope::new_spi(SpiMock::new(&read(0x00, &[0x0F])));
    assert_eq!(gyro.chip_id().unwrap(), 0x0F);
    let mut spi: SpiMock<u8> = gyro.release();
    spi.done();

    let mut mag: SpiMock<u8> = Magnetometer::new_spi(SpiMock::new(&[])).release();
    mag.done();
}

#[test]
fn each_die_gives_its_i2c_bus_back() {
    let acc = Accelerometer::new_i2c(I2cMock::new(&[]), AccelAddress::Sdo1High);
    let mut i2c: I2cMock = acc.release();
    i2c.done();
    let gyro = Gyroscope::new_i2c(I2cMock::new(&[]), GyroAddress::Sdo2Low);
    let mut i2c: I2cMock = gyro.release();
    i2c.done();
    let mag = Magnetometer::new_i2c(I2cMock::new(&[]), MagAddress::Csb3LowSdo3Low);
    let mut i2c: I2cMock = mag.release();
    i2c.done();
}

#[test]
fn a_driver_made_with_new_gives_the_interface_back() {
    let acc = Accelerometer::new(SpiInterface::new(SpiMock::<u8>::new(&[])));
    let mut spi = acc.into_interface().release();
    spi.done();
}

#[test]
fn the_facade_gives_the_three_spi_devices_back() {
    let imu = Bmx055::new_spi(SpiMock::new(&[]), SpiMock::new(&[]), SpiMock::new(&[]));
    let (mut a, mut g, mut m): (SpiMock<u8>, SpiMock<u8>, SpiMock<u8>) = imu.release();
    a.done();
    g.done();
    m.done();
}
