//! Golden vectors from the BMP280 datasheet's calculation example and a real device's
//! calibration (an independent implementation's test data), never values produced by this crate.

mod common;

use bosch_bmp280::compensation::{
    compensate, pressure_pa_32bit, pressure_pa_f32, pressure_q24_8, t_fine,
    temperature_celsius_f32, temperature_centi_celsius,
};
use bosch_bmp280::{Calibration, RawSample};
use common::*;
use common::{adc_from_bytes, bytes_from_adc};

#[test]
fn datasheet_calibration_bytes_parse_to_the_datasheet_words() {
    assert_eq!(
        Calibration::from_bytes(&DATASHEET_CALIB_BYTES),
        DATASHEET_CALIB
    );
    assert_eq!(DATASHEET_CALIB.to_bytes(), DATASHEET_CALIB_BYTES);
}

#[test]
fn other_device_calibration_parses() {
    assert_eq!(Calibration::from_bytes(&OTHER_CALIB_BYTES), OTHER_CALIB);
    assert_eq!(OTHER_CALIB.to_bytes(), OTHER_CALIB_BYTES);
}

#[test]
fn datasheet_data_registers_give_the_raw_adc_values() {
    assert_eq!(
        adc_from_bytes(&DATASHEET_DATA_BYTES),
        (DATASHEET_ADC_P, DATASHEET_ADC_T)
    );
    assert_eq!(
        bytes_from_adc(DATASHEET_ADC_P, DATASHEET_ADC_T),
        DATASHEET_DATA_BYTES
    );
    let raw = RawSample::from_register_bytes(&DATASHEET_DATA_BYTES);
    assert_eq!(raw.adc_p, DATASHEET_ADC_P);
    assert_eq!(raw.adc_t, DATASHEET_ADC_T);
}

#[test]
fn datasheet_integer_temperature() {
    let tf = t_fine(&DATASHEET_CALIB, DATASHEET_ADC_T);
    assert_eq!(tf, DATASHEET_T_FINE);
    assert_eq!(temperature_centi_celsius(tf), DATASHEET_T_CENTI);
}

#[test]
fn datasheet_64bit_pressure() {
    let p = pressure_q24_8(&DATASHEET_CALIB, DATASHEET_T_FINE, DATASHEET_ADC_P);
    assert_eq!(p, Some(DATASHEET_P_Q24_8));
    assert_eq!(DATASHEET_P_Q24_8 >> 8, DATASHEET_P_PA);
}

#[test]
fn datasheet_compensate_in_one_call() {
    let raw = RawSample {
        adc_p: DATASHEET_ADC_P,
        adc_t: DATASHEET_ADC_T,
    };
    let m = compensate(&DATASHEET_CALIB, raw).unwrap();
    assert_eq!(m.raw, raw);
    assert_eq!(m.t_fine, DATASHEET_T_FINE);
    assert_eq!(m.temperature_centi_celsius, DATASHEET_T_CENTI);
    assert_eq!(m.pressure_q24_8, DATASHEET_P_Q24_8);
    assert_eq!(m.pressure_pa(), DATASHEET_P_PA);
    assert!((f64::from(m.temperature_celsius_f32()) - 25.08).abs() < 1e-4);
    assert!((f64::from(m.pressure_pa_f32()) - DATASHEET_P_Q24_8 as f64 / 256.0).abs() < 0.01);
}

#[test]
fn thirty_two_bit_pressure_is_within_a_few_pascal_of_the_double_formula() {
    // The vector list gives no 32-bit result: compare against the double-precision value. The
    // 32-bit formula truncates intermediate terms; its error stays within a few Pa.
    let p = pressure_pa_32bit(&DATASHEET_CALIB, DATASHEET_T_FINE, DATASHEET_ADC_P).unwrap();
    assert!(
        (f64::from(p) - DATASHEET_P_DOUBLE).abs() <= 5.0,
        "32-bit pressure {p} Pa"
    );
}

#[test]
fn f32_formulas_match_the_double_precision_results() {
    let (celsius, tf) = temperature_celsius_f32(&DATASHEET_CALIB, DATASHEET_ADC_T);
    assert!(
        (f64::from(celsius) - DATASHEET_T_DOUBLE).abs() < 0.001,
        "{celsius} °C"
    );
    let pa = pressure_pa_f32(&DATASHEET_CALIB, tf, DATASHEET_ADC_P).unwrap();
    assert!((f64::from(pa) - DATASHEET_P_DOUBLE).abs() < 0.1, "{pa} Pa");
}

#[test]
fn the_guarded_division_by_zero_returns_none() {
    let cal = Calibration {
        dig_p1: 0,
        ..DATASHEET_CALIB
    };
    assert_eq!(
        pressure_q24_8(&cal, DATASHEET_T_FINE, DATASHEET_ADC_P),
        None
    );
    assert_eq!(
        pressure_pa_32bit(&cal, DATASHEET_T_FINE, DATASHEET_ADC_P),
        None
    );
    assert_eq!(
        pressure_pa_f32(&cal, DATASHEET_T_FINE, DATASHEET_ADC_P),
        None
    );
    let raw = RawSample {
        adc_p: DATASHEET_ADC_P,
        adc_t: DATASHEET_ADC_T,
    };
    assert_eq!(
        compensate(&cal, raw),
        Err(bosch_bmp280::DeviceError::InvalidCalibration)
    );
}
