//! Every register address and bit position against the datasheet (section 4, tables 18-26),
//! the configuration encodings, and the measurement times of datasheet table 13.

// Unit tests, because the register map is private: the public API speaks in typed values.
#![allow(clippy::unusual_byte_groupings)] // literals grouped by register field: osrs_t, osrs_p, mode
use crate::register::*;
use crate::{Config, Filter, I2cAddress, Oversampling, PowerMode, Resolution, Standby, Status};

#[test]
fn register_addresses() {
    assert_eq!(CALIB_START, 0x88);
    assert_eq!(CALIB_LEN, 24); // 0x88..=0x9F
    assert_eq!(CHIP_ID, 0xD0);
    assert_eq!(RESET, 0xE0);
    assert_eq!(RESET_COMMAND, 0xB6);
    assert_eq!(STATUS, 0xF3);
    assert_eq!(CTRL_MEAS, 0xF4);
    assert_eq!(CONFIG, 0xF5);
    assert_eq!(DATA_START, 0xF7);
    assert_eq!(DATA_LEN, 6); // 0xF7..=0xFC
    assert_eq!(TEMP_START, 0xFA);
}

#[test]
fn spi_control_bits() {
    assert_eq!(SPI_READ, 0b1000_0000);
    assert_eq!(SPI_WRITE_MASK, 0b0111_1111);
}

#[test]
fn status_bits() {
    // status: bit 3 measuring, bit 0 im_update (datasheet table 19).
    assert_eq!(Status::MEASURING.bits(), 0b0000_1000);
    assert_eq!(Status::IM_UPDATE.bits(), 0b0000_0001);
}

#[test]
fn ctrl_meas_fields() {
    assert_eq!(OSRS_T_SHIFT, 5);
    assert_eq!(OSRS_P_SHIFT, 2);
    assert_eq!(MODE_MASK, 0b11);
    let only = |t, p, m| {
        Config::default()
            .with_temperature_oversampling(t)
            .with_pressure_oversampling(p)
            .with_mode(m)
            .ctrl_meas()
    };
    assert_eq!(
        only(Oversampling::Skip, Oversampling::Skip, PowerMode::Sleep),
        0x00
    );
    assert_eq!(
        only(Oversampling::Skip, Oversampling::Skip, PowerMode::Forced),
        0b01
    );
    assert_eq!(
        only(Oversampling::Skip, Oversampling::Skip, PowerMode::Normal),
        0b11
    );
    assert_eq!(
        only(Oversampling::X16, Oversampling::Skip, PowerMode::Sleep),
        0b101_000_00
    );
    assert_eq!(
        only(Oversampling::Skip, Oversampling::X16, PowerMode::Sleep),
        0b000_101_00
    );
    assert_eq!(
        only(Oversampling::X1, Oversampling::X1, PowerMode::Normal),
        0x27
    );
}

#[test]
fn oversampling_codes() {
    // Datasheet tables 21 and 22.
    for (o, code) in [
        (Oversampling::Skip, 0b000),
        (Oversampling::X1, 0b001),
        (Oversampling::X2, 0b010),
        (Oversampling::X4, 0b011),
        (Oversampling::X8, 0b100),
        (Oversampling::X16, 0b101),
    ] {
        assert_eq!(o as u8, code);
        assert_eq!(Oversampling::from_bits(code), o);
    }
    assert_eq!(Oversampling::from_bits(0b110), Oversampling::X16);
    assert_eq!(Oversampling::from_bits(0b111), Oversampling::X16);
}

#[test]
fn mode_codes() {
    // Datasheet table 10: 00 sleep, 01 and 10 forced, 11 normal.
    assert_eq!(PowerMode::from_bits(0b00), PowerMode::Sleep);
    assert_eq!(PowerMode::from_bits(0b01), PowerMode::Forced);
    assert_eq!(PowerMode::from_bits(0b10), PowerMode::Forced);
    assert_eq!(PowerMode::from_bits(0b11), PowerMode::Normal);
}

#[test]
fn config_fields() {
    assert_eq!(T_SB_SHIFT, 5);
    assert_eq!(FILTER_SHIFT, 2);
    assert_eq!(SPI3W_EN, 0b1);
    // Datasheet table 11 (t_sb) and table 6 (filter).
    for (s, code) in [
        (Standby::Ms0_5, 0b000),
        (Standby::Ms62_5, 0b001),
        (Standby::Ms125, 0b010),
        (Standby::Ms250, 0b011),
        (Standby::Ms500, 0b100),
        (Standby::Ms1000, 0b101),
        (Standby::Ms2000, 0b110),
        (Standby::Ms4000, 0b111),
    ] {
        assert_eq!(
            Config::default().with_standby(s).config_register(),
            code << 5
        );
        assert_eq!(Standby::from_bits(code), s);
    }
    for (f, code) in [
        (Filter::Off, 0b000),
        (Filter::X2, 0b001),
        (Filter::X4, 0b010),
        (Filter::X8, 0b011),
        (Filter::X16, 0b100),
    ] {
        assert_eq!(
            Config::default().with_filter(f).config_register(),
            code << 2
        );
        assert_eq!(Filter::from_bits(code), f);
    }
    assert_eq!(
        Config::default().with_spi_3wire(true).config_register(),
        0b1
    );
}

#[test]
fn default_config_registers() {
    // Normal mode, x1/x1: ctrl_meas 0xF4 = 0x27, t_sb 0.5 ms, filter off.
    assert_eq!(Config::default().ctrl_meas(), 0x27);
    assert_eq!(Config::default().config_register(), 0x00);
}

#[test]
fn every_config_round_trips_through_its_registers() {
    for ctrl in 0u8..=255 {
        for cfg in [0x00u8, 0x10, 0x25, 0xE1, 0x5C] {
            let c = Config::from_registers(ctrl, cfg);
            let back = Config::from_registers(c.ctrl_meas(), c.config_register());
            assert_eq!(back, c);
        }
    }
}

#[test]
fn i2c_addresses() {
    assert_eq!(I2cAddress::SdoLow.addr(), 0x76);
    assert_eq!(I2cAddress::SdoHigh.addr(), 0x77);
}

#[test]
fn measurement_times_of_datasheet_table_13() {
    // Datasheet table 13: typical / maximum measurement time in ms per preset.
    for (resolution, typ_us, max_us) in [
        (Resolution::UltraLowPower, 5500, 6400),
        (Resolution::LowPower, 7500, 8700),
        (Resolution::Standard, 11500, 13300),
        (Resolution::High, 19500, 22500),
        (Resolution::UltraHigh, 37500, 43200),
    ] {
        let c = Config::forced(resolution);
        assert_eq!(c.measurement_time_typ_us(), typ_us, "{resolution:?}");
        // The table rounds the formula's maximum to 0.1 ms.
        let max = c.measurement_time_max_us();
        assert!(max.abs_diff(max_us) <= 50, "{resolution:?}: {max}");
    }
}

#[test]
fn skipped_measurements_take_no_time() {
    let c = Config::default()
        .with_temperature_oversampling(Oversampling::Skip)
        .with_pressure_oversampling(Oversampling::Skip);
    assert_eq!(c.measurement_time_typ_us(), 1000);
    assert_eq!(c.measurement_time_max_us(), 1250);
}

#[test]
fn use_case_presets_of_datasheet_table_7() {
    // Datasheet table 7: mode, standby, filter, and the typical output data rate in Hz.
    for (config, mode, filter, odr_hz) in [
        (
            Config::handheld_low_power(),
            PowerMode::Normal,
            Filter::X4,
            10.0,
        ),
        (
            Config::handheld_dynamic(),
            PowerMode::Normal,
            Filter::X16,
            83.3,
        ),
        (Config::elevator(), PowerMode::Normal, Filter::X4, 7.3),
        (
            Config::drop_detection(),
            PowerMode::Normal,
            Filter::Off,
            125.0,
        ),
        (
            Config::indoor_navigation(),
            PowerMode::Normal,
            Filter::X16,
            26.3,
        ),
    ] {
        assert_eq!(config.mode, mode);
        assert_eq!(config.filter, filter);
        let odr = 1e6 / f64::from(config.normal_mode_period_typ_us());
        assert!((odr - odr_hz).abs() < 0.1, "{config:?}: {odr} Hz");
    }
    let weather = Config::weather_monitoring();
    assert_eq!(weather.mode, PowerMode::Forced);
    assert_eq!(weather.filter, Filter::Off);
    assert_eq!(weather.pressure_oversampling, Oversampling::X1);
}

#[test]
fn resolution_presets_of_datasheet_table_4() {
    use Oversampling::*;
    assert_eq!(Resolution::UltraLowPower.oversampling(), (X1, X1));
    assert_eq!(Resolution::LowPower.oversampling(), (X2, X1));
    assert_eq!(Resolution::Standard.oversampling(), (X4, X1));
    assert_eq!(Resolution::High.oversampling(), (X8, X1));
    assert_eq!(Resolution::UltraHigh.oversampling(), (X16, X2));
}
