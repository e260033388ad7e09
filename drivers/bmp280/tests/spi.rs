//! Exact SPI transactions of every driver operation (embedded-hal-mock).
//!
//! Control bytes are written out by hand from the datasheet (5.3): read = register | 0x80,
//! write = register & 0x7F.

mod common;

use bosch_bmp280::{Bmp280, Chip, Config, DeviceError, Error, Oversampling, PowerMode, Resolution};
use common::*;
use embedded_hal::spi::ErrorKind;
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as D};
use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};

type Driver = Bmp280<bosch_bmp280::SpiInterface<Mock<u8>>>;

fn driver(expectations: &[T<u8>]) -> Driver {
    Bmp280::new_spi(Mock::new(expectations))
}

fn initialised(rest: &[T<u8>]) -> Driver {
    let mut all = spi_init();
    all.extend_from_slice(rest);
    let mut bmp = driver(&all);
    bmp.init(&mut NoopDelay::new()).unwrap();
    bmp
}

#[test]
fn init_resets_waits_checks_id_and_reads_calibration_once() {
    let mut bmp = driver(&spi_init());
    let mut delay = CheckedDelay::new(&[D::delay_us(2000)]);
    assert_eq!(bmp.init(&mut delay), Ok(Chip::Bmp280));
    assert_eq!(bmp.calibration(), Some(&DATASHEET_CALIB));
    assert_eq!(bmp.config().mode, PowerMode::Sleep);
    delay.done();
    bmp.release().done();
}

#[test]
fn init_waits_for_im_update_with_a_bound() {
    let expectations = [
        spi_write(0x60, 0xB6),
        spi_read(0xD0, &[0x58]),
        spi_read(0xF3, &[0x01]),
        spi_read(0xF3, &[0x09]), // im_update still set (measuring ignored)
        spi_read(0xF3, &[0x00]),
        spi_read(0x88, &DATASHEET_CALIB_BYTES),
    ]
    .concat();
    let mut bmp = driver(&expectations);
    let mut delay = CheckedDelay::new(&[D::delay_us(2000), D::delay_us(1000), D::delay_us(1000)]);
    assert_eq!(bmp.init(&mut delay), Ok(Chip::Bmp280));
    delay.done();
    bmp.release().done();
}

#[test]
fn init_times_out_when_im_update_never_clears() {
    let mut expectations = [spi_write(0x60, 0xB6), spi_read(0xD0, &[0x58])].concat();
    for _ in 0..5 {
        expectations.extend(spi_read(0xF3, &[0x01]));
    }
    let mut bmp = driver(&expectations);
    let mut delay = CheckedDelay::new(&[
        D::delay_us(2000),
        D::delay_us(1000),
        D::delay_us(1000),
        D::delay_us(1000),
        D::delay_us(1000),
        D::delay_us(1000),
    ]);
    assert_eq!(
        bmp.init(&mut delay),
        Err(Error::Device(DeviceError::Timeout))
    );
    assert_eq!(bmp.calibration(), None);
    delay.done();
    bmp.release().done();
}

fn init_with_id(id: u8, accept_bme280: bool) -> (Result<Chip, Error<ErrorKind>>, Mock<u8>) {
    let rest_ok = id == 0x58 || id == 0x56 || id == 0x57 || (id == 0x60 && accept_bme280);
    let mut expectations = [spi_write(0x60, 0xB6), spi_read(0xD0, &[id])].concat();
    if rest_ok {
        expectations.extend(spi_read(0xF3, &[0x00]));
        expectations.extend(spi_read(0x88, &DATASHEET_CALIB_BYTES));
    }
    let mut bmp = driver(&expectations).accept_bme280(accept_bme280);
    let result = bmp.init(&mut NoopDelay::new());
    (result, bmp.release())
}

#[test]
fn chip_ids_are_classified() {
    for (id, accept, expected) in [
        (0x58, false, Ok(Chip::Bmp280)),
        (0x56, false, Ok(Chip::Bmp280Sample(0x56))),
        (0x57, false, Ok(Chip::Bmp280Sample(0x57))),
        (
            0x60,
            false,
            Err(Error::Device(DeviceError::Bme280NotAccepted)),
        ),
        (0x60, true, Ok(Chip::Bme280)),
        (
            0x00,
            false,
            Err(Error::Device(DeviceError::InvalidChipId { found: 0x00 })),
        ),
        (
            0xFF,
            true,
            Err(Error::Device(DeviceError::InvalidChipId { found: 0xFF })),
        ),
        (
            0x55,
            false,
            Err(Error::Device(DeviceError::InvalidChipId { found: 0x55 })),
        ),
    ] {
        let (result, mut mock) = init_with_id(id, accept);
        assert_eq!(result, expected, "id {id:#04x}");
        mock.done();
    }
}

#[test]
fn a_calibration_that_divides_by_zero_is_rejected() {
    let mut calib = DATASHEET_CALIB_BYTES;
    calib[6] = 0; // dig_P1 LSB (0x8E)
    calib[7] = 0; // dig_P1 MSB (0x8F)
    let expectations = [
        spi_write(0x60, 0xB6),
        spi_read(0xD0, &[0x58]),
        spi_read(0xF3, &[0x00]),
        spi_read(0x88, &calib),
    ]
    .concat();
    let mut bmp = driver(&expectations);
    assert_eq!(
        bmp.init(&mut NoopDelay::new()),
        Err(Error::Device(DeviceError::InvalidCalibration))
    );
    assert_eq!(bmp.calibration(), None);
    bmp.release().done();
}

#[test]
fn default_config_is_three_exact_writes() {
    // ctrl_meas with sleep mode (x1/x1 = 0x24), config 0x00 (t_sb 0.5 ms, filter off, 4-wire),
    // then ctrl_meas 0x27 (x1/x1, normal). Register 0xF4 -> 0x74, 0xF5 -> 0x75 on SPI.
    let expectations = [
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x27),
    ]
    .concat();
    let mut bmp = driver(&expectations);
    bmp.configure(Config::default()).unwrap();
    assert_eq!(bmp.config(), Config::default());
    bmp.release().done();
}

#[test]
fn indoor_navigation_preset_writes() {
    // osrs_t x2 = 010, osrs_p x16 = 101, normal = 11 -> 0b010_101_11 = 0x57 (sleep: 0x54);
    // t_sb 0.5 ms = 000, filter 16 = 100, spi3w 0 -> 0b000_100_00 = 0x10.
    let expectations = [
        spi_write(0x74, 0x54),
        spi_write(0x75, 0x10),
        spi_write(0x74, 0x57),
    ]
    .concat();
    let mut bmp = driver(&expectations);
    bmp.configure(Config::indoor_navigation()).unwrap();
    bmp.release().done();
}

#[test]
fn spi_3wire_and_long_standby_reach_the_config_register() {
    // t_sb 4 s = 111, filter off, spi3w_en = 1 -> 0b111_000_01 = 0xE1.
    let config = Config::default()
        .with_standby(bosch_bmp280::Standby::Ms4000)
        .with_spi_3wire(true);
    let expectations = [
        spi_write(0x74, 0x24),
        spi_write(0x75, 0xE1),
        spi_write(0x74, 0x27),
    ]
    .concat();
    let mut bmp = driver(&expectations);
    bmp.configure(config).unwrap();
    bmp.release().done();
}

#[test]
fn read_config_decodes_both_registers() {
    let mut bmp = driver(&spi_read(0xF4, &[0x27, 0x00]));
    assert_eq!(bmp.read_config(), Ok(Config::default()));
    bmp.release().done();
}

#[test]
fn status_and_chip_id_reads() {
    let expectations = [spi_read(0xF3, &[0x09]), spi_read(0xD0, &[0x58])].concat();
    let mut bmp = driver(&expectations);
    let status = bmp.status().unwrap();
    assert!(status.contains(bosch_bmp280::Status::MEASURING));
    assert!(status.contains(bosch_bmp280::Status::IM_UPDATE));
    assert_eq!(bmp.chip_id(), Ok(0x58));
    bmp.release().done();
}

#[test]
fn raw_bytes_are_one_burst_in_register_order() {
    let mut bmp = driver(&spi_read(0xF7, &DATASHEET_DATA_BYTES));
    assert_eq!(bmp.read_raw_bytes(), Ok(DATASHEET_DATA_BYTES));
    bmp.release().done();
}

#[test]
fn raw_sample_needs_no_calibration() {
    let mut bmp = driver(&spi_read(0xF7, &DATASHEET_DATA_BYTES));
    let raw = bmp.read_raw().unwrap();
    assert_eq!((raw.adc_p, raw.adc_t), (DATASHEET_ADC_P, DATASHEET_ADC_T));
    bmp.release().done();
}

#[test]
fn normal_mode_measurement_is_compensated_with_the_datasheet_result() {
    let mut bmp = initialised(&spi_read(0xF7, &DATASHEET_DATA_BYTES));
    let m = bmp.measure().unwrap();
    assert_eq!(m.temperature_centi_celsius, DATASHEET_T_CENTI);
    assert_eq!(m.pressure_q24_8, DATASHEET_P_Q24_8);
    assert_eq!(m.raw.to_register_bytes(), DATASHEET_DATA_BYTES);
    bmp.release().done();
}

#[test]
fn compensated_reads_before_init_fail_without_bus_traffic() {
    let mut bmp = driver(&[]);
    assert_eq!(
        bmp.measure(),
        Err(Error::Device(DeviceError::NotCalibrated))
    );
    assert_eq!(
        bmp.poll_forced(),
        Err(nb::Error::Other(Error::Device(DeviceError::NotCalibrated)))
    );
    assert_eq!(
        bmp.measure_forced(&mut NoopDelay::new()),
        Err(Error::Device(DeviceError::NotCalibrated))
    );
    bmp.release().done();
}

#[test]
fn set_calibration_replaces_the_read() {
    let mut bmp = driver(&spi_read(0xF7, &DATASHEET_DATA_BYTES));
    bmp.set_calibration(DATASHEET_CALIB);
    assert_eq!(bmp.measure().unwrap().pressure_pa(), DATASHEET_P_PA);
    bmp.release().done();
}

#[test]
fn forced_measurement_polls_the_measuring_bit() {
    // Forced, ultra low power: osrs_t x1 = 001, osrs_p x1 = 001, forced = 01 -> 0x25.
    // Each poll reads status (0xF3) and ctrl_meas (0xF4) in one burst.
    let expectations = [
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x25),
        spi_write(0x74, 0x25), // start_forced
        spi_read(0xF3, &[0x08, 0x25]),
        spi_read(0xF3, &[0x08, 0x25]),
        spi_read(0xF3, &[0x00, 0x24]), // done: measuring clear, back in sleep mode
        spi_read(0xF7, &DATASHEET_DATA_BYTES),
    ]
    .concat();
    let mut bmp = initialised(&expectations);
    bmp.configure(Config::forced(Resolution::UltraLowPower))
        .unwrap();
    bmp.start_forced().unwrap();
    assert_eq!(bmp.poll_forced(), Err(nb::Error::WouldBlock));
    assert_eq!(bmp.poll_forced(), Err(nb::Error::WouldBlock));
    let m = bmp.poll_forced().unwrap();
    assert_eq!(m.temperature_centi_celsius, DATASHEET_T_CENTI);
    assert_eq!(m.pressure_pa(), DATASHEET_P_PA);
    bmp.release().done();
}

#[test]
fn a_forced_poll_waits_while_the_mode_bits_still_read_forced() {
    // Just after the start the measuring bit can still read 0 while ctrl_meas holds forced
    // mode (01 or 10): the sample in the data registers is then the previous one.
    let expectations = [
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x25),
        spi_write(0x74, 0x25), // start_forced
        spi_read(0xF3, &[0x00, 0x25]),
        spi_read(0xF3, &[0x00, 0x26]),
        spi_read(0xF3, &[0x08, 0x25]),
        spi_read(0xF3, &[0x00, 0x24]),
        spi_read(0xF7, &DATASHEET_DATA_BYTES),
    ]
    .concat();
    let mut bmp = driver(&expectations);
    bmp.set_calibration(DATASHEET_CALIB);
    bmp.configure(Config::forced(Resolution::UltraLowPower))
        .unwrap();
    bmp.start_forced().unwrap();
    for _ in 0..3 {
        assert_eq!(bmp.poll_forced(), Err(nb::Error::WouldBlock));
    }
    assert_eq!(bmp.poll_forced().unwrap().pressure_pa(), DATASHEET_P_PA);
    bmp.release().done();
}

#[test]
fn the_im_update_bit_alone_does_not_block_a_forced_poll() {
    let expectations = [
        spi_read(0xF3, &[0x01, 0x00]),
        spi_read(0xF7, &DATASHEET_DATA_BYTES),
    ]
    .concat();
    let mut bmp = driver(&expectations);
    let raw = bmp.poll_forced_raw().unwrap();
    assert_eq!(raw.adc_t, DATASHEET_ADC_T);
    bmp.release().done();
}

#[test]
fn measure_forced_waits_the_typical_time_then_polls() {
    // x1/x1: typical 5.5 ms, then 0.5 ms between polls.
    let expectations = [
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x25),
        spi_write(0x74, 0x25),
        spi_read(0xF3, &[0x08, 0x25]),
        spi_read(0xF3, &[0x00, 0x24]),
        spi_read(0xF7, &DATASHEET_DATA_BYTES),
    ]
    .concat();
    let mut bmp = initialised(&expectations);
    bmp.configure(Config::forced(Resolution::UltraLowPower))
        .unwrap();
    let mut delay = CheckedDelay::new(&[D::delay_us(5500), D::delay_us(500)]);
    let m = bmp.measure_forced(&mut delay).unwrap();
    assert_eq!(m.pressure_pa(), DATASHEET_P_PA);
    delay.done();
    bmp.release().done();
}

#[test]
fn measure_forced_gives_up_after_the_maximum_time() {
    // x1/x1: typical 5.5 ms, maximum 6.425 ms; with 2 ms slack that is 2.925 ms of polling at
    // 0.5 ms: 6 polls, 6 waits.
    let mut expectations = [
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x25),
        spi_write(0x74, 0x25),
    ]
    .concat();
    let mut delays = vec![D::delay_us(5500)];
    for i in 0..6 {
        // Measuring, or measuring already clear but the mode bits still forced.
        let status = if i % 2 == 0 { 0x08 } else { 0x00 };
        expectations.extend(spi_read(0xF3, &[status, 0x25]));
        delays.push(D::delay_us(500));
    }
    let mut bmp = initialised(&expectations);
    bmp.configure(Config::forced(Resolution::UltraLowPower))
        .unwrap();
    let mut delay = CheckedDelay::new(&delays);
    assert_eq!(
        bmp.measure_forced(&mut delay),
        Err(Error::Device(DeviceError::Timeout))
    );
    delay.done();
    bmp.release().done();
}

#[test]
fn forced_start_keeps_the_configured_oversampling() {
    // Pressure x16, temperature x2, forced: 0b010_101_01 = 0x55.
    let expectations = [
        spi_write(0x74, 0x54),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x55),
        spi_write(0x74, 0x55),
    ]
    .concat();
    let mut bmp = driver(&expectations);
    let config = Config::forced(Resolution::UltraHigh);
    assert_eq!(config.pressure_oversampling, Oversampling::X16);
    bmp.configure(config).unwrap();
    bmp.start_forced().unwrap();
    bmp.release().done();
}

#[test]
fn a_forced_start_from_normal_mode_is_reported_by_config() {
    // The default configuration (normal, x1/x1: 0x27), then one forced measurement with the same
    // oversampling (0x25): the device sleeps afterwards, and `config()` must not claim normal.
    let expectations = [
        spi_write(0x74, 0x24),
        spi_write(0x75, 0x00),
        spi_write(0x74, 0x27),
        spi_write(0x74, 0x25),
    ]
    .concat();
    let mut bmp = driver(&expectations);
    bmp.configure(Config::default()).unwrap();
    assert_eq!(bmp.config().mode, PowerMode::Normal);
    bmp.start_forced().unwrap();
    assert_eq!(bmp.config(), Config::default().with_mode(PowerMode::Forced));
    bmp.release().done();
}

#[test]
fn soft_reset_alone() {
    let mut bmp = driver(&spi_write(0x60, 0xB6));
    let mut delay = CheckedDelay::new(&[D::delay_us(2000)]);
    bmp.soft_reset(&mut delay).unwrap();
    delay.done();
    bmp.release().done();
}

#[test]
fn into_interface_gives_back_what_new_was_given() {
    let bmp = Bmp280::new(bosch_bmp280::SpiInterface::new(Mock::<u8>::new(&[])));
    let mut spi: Mock<u8> = bmp.into_interface().release();
    spi.done();
}
