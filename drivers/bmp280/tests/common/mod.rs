//! Vectors and mock helpers shared by the integration tests.
#![allow(dead_code)]

use bosch_bmp280::Calibration;
use embedded_hal_mock::eh1::i2c::Transaction as I2cT;
use embedded_hal_mock::eh1::spi::Transaction as SpiT;

// Source: BMP280 datasheet, compensation calculation example.
/// Registers 0x88..=0x9F of the datasheet calculation example.
pub const DATASHEET_CALIB_BYTES: [u8; 24] = [
    0x70, 0x6B, 0x43, 0x67, 0x18, 0xFC, 0x7D, 0x8E, 0x43, 0xD6, 0xD0, 0x0B, 0x27, 0x0B, 0x8C, 0x00,
    0xF9, 0xFF, 0x8C, 0x3C, 0xF8, 0xC6, 0x70, 0x17,
];
/// The datasheet calculation example's calibration words.
pub const DATASHEET_CALIB: Calibration = Calibration {
    dig_t1: 27504,
    dig_t2: 26435,
    dig_t3: -1000,
    dig_p1: 36477,
    dig_p2: -10685,
    dig_p3: 3024,
    dig_p4: 2855,
    dig_p5: 140,
    dig_p6: -7,
    dig_p7: 15500,
    dig_p8: -14600,
    dig_p9: 6000,
};
/// Registers 0xF7..=0xFC of the datasheet calculation example.
pub const DATASHEET_DATA_BYTES: [u8; 6] = [0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00];
pub const DATASHEET_ADC_T: u32 = 519888;
pub const DATASHEET_ADC_P: u32 = 415148;
pub const DATASHEET_T_FINE: i32 = 128422;
pub const DATASHEET_T_CENTI: i32 = 2508;
pub const DATASHEET_P_Q24_8: u32 = 25767233;
pub const DATASHEET_P_PA: u32 = 100653;
pub const DATASHEET_T_DOUBLE: f64 = 25.0825;
pub const DATASHEET_P_DOUBLE: f64 = 100653.258;

// Source: calibration parse vector of another real device, from an independent implementation's
// test data.
pub const OTHER_CALIB_BYTES: [u8; 24] = [
    0xEF, 0x6B, 0xAE, 0x65, 0x18, 0xFC, 0x98, 0x93, 0x15, 0xD6, 0xD0, 0x0B, 0xEA, 0x15, 0x92, 0x00,
    0xF9, 0xFF, 0x8C, 0x3C, 0xF8, 0xC6, 0x70, 0x17,
];
pub const OTHER_CALIB: Calibration = Calibration {
    dig_t1: 27631,
    dig_t2: 26030,
    dig_t3: -1000,
    dig_p1: 37784,
    dig_p2: -10731,
    dig_p3: 3024,
    dig_p4: 5610,
    dig_p5: 146,
    dig_p6: -7,
    dig_p7: 15500,
    dig_p8: -14600,
    dig_p9: 6000,
};

/// SPI read: one transaction, control byte `addr | 0x80` written by the test author by hand.
pub fn spi_read(control: u8, data: &[u8]) -> Vec<SpiT<u8>> {
    vec![
        SpiT::transaction_start(),
        SpiT::write_vec(vec![control]),
        SpiT::read_vec(data.to_vec()),
        SpiT::transaction_end(),
    ]
}

/// SPI write: one transaction of `[control, value]`.
pub fn spi_write(control: u8, value: u8) -> Vec<SpiT<u8>> {
    vec![
        SpiT::transaction_start(),
        SpiT::write_vec(vec![control, value]),
        SpiT::transaction_end(),
    ]
}

/// The SPI transactions of `init` on a healthy BMP280 with the datasheet calibration.
pub fn spi_init() -> Vec<SpiT<u8>> {
    [
        spi_write(0x60, 0xB6),                  // reset 0xE0 & 0x7F
        spi_read(0xD0, &[0x58]),                // id 0xD0 | 0x80
        spi_read(0xF3, &[0x00]),                // status
        spi_read(0x88, &DATASHEET_CALIB_BYTES), // calib 0x88 | 0x80
    ]
    .concat()
}

pub const I2C_ADDR_LOW: u8 = 0x76;
pub const I2C_ADDR_HIGH: u8 = 0x77;

pub fn i2c_read(addr: u8, reg: u8, data: &[u8]) -> I2cT {
    I2cT::write_read(addr, vec![reg], data.to_vec())
}

pub fn i2c_write(addr: u8, reg: u8, value: u8) -> I2cT {
    I2cT::write(addr, vec![reg, value])
}

pub fn i2c_init(addr: u8) -> Vec<I2cT> {
    vec![
        i2c_write(addr, 0xE0, 0xB6),
        i2c_read(addr, 0xD0, &[0x58]),
        i2c_read(addr, 0xF3, &[0x00]),
        i2c_read(addr, 0x88, &DATASHEET_CALIB_BYTES),
    ]
}

/// Largest 20-bit ADC value.
pub const ADC_MAX: u32 = bosch_bmp280::RawSample::ADC_MAX;

/// Register bytes 0xF7..=0xFC to `(adc_P, adc_T)` through the public sample type.
pub fn adc_from_bytes(bytes: &[u8; 6]) -> (u32, u32) {
    let raw = bosch_bmp280::RawSample::from_register_bytes(bytes);
    (raw.adc_p, raw.adc_t)
}

/// `(adc_P, adc_T)` to register bytes 0xF7..=0xFC through the public sample type.
pub fn bytes_from_adc(adc_p: u32, adc_t: u32) -> [u8; 6] {
    bosch_bmp280::RawSample { adc_p, adc_t }.to_register_bytes()
}
