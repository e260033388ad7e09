//! Datasheet compensation formulas (section 3.11.3 and 8.1/8.2): pure functions of the
//! calibration and raw ADC values, with no I/O, usable on the host for packets that carry raw
//! data.
//!
//! The integer formulas reproduce the datasheet's C code bit for bit for every calibration a
//! real device holds. They use wrapping arithmetic where the C code relies on the values staying
//! in range, so arbitrary calibration words and raw values (a corrupted packet, a test) give a
//! meaningless number instead of a panic. The one division the datasheet guards (divisor zero)
//! returns `None` here.
//!
//! `inverse` (feature `sim`) goes the other way for simulators: from a temperature and
//! pressure to the raw values that compensate closest to them.

#[cfg(feature = "sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "sim")))]
pub mod inverse;

use crate::calibration::Calibration;
use crate::raw::{RawSample, ADC_MAX};
use crate::types::DeviceError;

/// Fine-resolution temperature `t_fine` from a raw temperature (datasheet
/// `bmp280_compensate_T_int32`). It carries the temperature into the pressure formula; in °C it
/// is `t_fine / 5120`. Bits of `adc_t` above the 20th are ignored.
pub fn t_fine(cal: &Calibration, adc_t: u32) -> i32 {
    let adc_t = (adc_t & ADC_MAX) as i32;
    let t1 = i32::from(cal.dig_t1);
    let var1 = ((adc_t >> 3) - (t1 << 1)).wrapping_mul(i32::from(cal.dig_t2)) >> 11;
    let d = (adc_t >> 4) - t1;
    let var2 = (d.wrapping_mul(d) >> 12).wrapping_mul(i32::from(cal.dig_t3)) >> 14;
    var1.wrapping_add(var2)
}

/// Temperature in 0.01 °C from `t_fine`: `(t_fine * 5 + 128) >> 8` (5123 means 51.23 °C).
pub fn temperature_centi_celsius(t_fine: i32) -> i32 {
    t_fine.wrapping_mul(5).wrapping_add(128) >> 8
}

/// Pressure in Pa as unsigned Q24.8 (24 integer and 8 fractional bits: 24674867 means
/// 24674867 / 256 = 96386.2 Pa), the datasheet's 64-bit formula
/// (`bmp280_compensate_P_int64`). `None` where the datasheet returns 0 to avoid dividing by
/// zero (a calibration with `dig_P1` = 0).
pub fn pressure_q24_8(cal: &Calibration, t_fine: i32, adc_p: u32) -> Option<u32> {
    let adc_p = i64::from(adc_p & ADC_MAX);
    let mut var1 = i64::from(t_fine) - 128_000;
    let mut var2 = var1.wrapping_mul(var1).wrapping_mul(i64::from(cal.dig_p6));
    var2 = var2.wrapping_add(var1.wrapping_mul(i64::from(cal.dig_p5)) << 17);
    var2 = var2.wrapping_add(i64::from(cal.dig_p4) << 35);
    var1 = (var1.wrapping_mul(var1).wrapping_mul(i64::from(cal.dig_p3)) >> 8)
        .wrapping_add(var1.wrapping_mul(i64::from(cal.dig_p2)) << 12);
    var1 = ((1i64 << 47).wrapping_add(var1)).wrapping_mul(i64::from(cal.dig_p1)) >> 33;
    if var1 == 0 {
        return None;
    }
    let mut p: i64 = 1_048_576 - adc_p;
    p = ((p << 31).wrapping_sub(var2))
        .wrapping_mul(3125)
        .wrapping_div(var1);
    var1 = i64::from(cal.dig_p9)
        .wrapping_mul(p >> 13)
        .wrapping_mul(p >> 13)
        >> 25;
    var2 = i64::from(cal.dig_p8).wrapping_mul(p) >> 19;
    p = (p.wrapping_add(var1).wrapping_add(var2) >> 8).wrapping_add(i64::from(cal.dig_p7) << 4);
    Some(p as u32)
}

/// Pressure in whole Pa with the datasheet's 32-bit formula (`bmp280_compensate_P_int32`), for
/// targets without fast 64-bit multiplication. Resolution 1 Pa; its truncated intermediate terms
/// put it a few Pa from the 64-bit result (+3 Pa on the datasheet example), so prefer
/// [`pressure_q24_8`] where 64-bit arithmetic is affordable. `None` where the datasheet returns 0 to avoid dividing by zero.
pub fn pressure_pa_32bit(cal: &Calibration, t_fine: i32, adc_p: u32) -> Option<u32> {
    let adc_p = (adc_p & ADC_MAX) as i32;
    let mut var1: i32 = (t_fine >> 1).wrapping_sub(64_000);
    let q = (var1 >> 2).wrapping_mul(var1 >> 2);
    let mut var2: i32 = (q >> 11).wrapping_mul(i32::from(cal.dig_p6));
    var2 = var2.wrapping_add(var1.wrapping_mul(i32::from(cal.dig_p5)) << 1);
    var2 = (var2 >> 2).wrapping_add(i32::from(cal.dig_p4) << 16);
    var1 = ((i32::from(cal.dig_p3).wrapping_mul(q >> 13) >> 3)
        .wrapping_add(i32::from(cal.dig_p2).wrapping_mul(var1) >> 1))
        >> 18;
    var1 = (32_768i32.wrapping_add(var1)).wrapping_mul(i32::from(cal.dig_p1)) >> 15;
    if var1 == 0 {
        return None;
    }
    let divisor = var1 as u32;
    let mut p: u32 =
        (((1_048_576 - adc_p) as u32).wrapping_sub((var2 >> 12) as u32)).wrapping_mul(3125);
    p = if p < 0x8000_0000 {
        (p << 1) / divisor
    } else {
        (p / divisor).wrapping_mul(2)
    };
    let var1 =
        i32::from(cal.dig_p9).wrapping_mul((((p >> 3).wrapping_mul(p >> 3)) >> 13) as i32) >> 12;
    let var2 = ((p >> 2) as i32).wrapping_mul(i32::from(cal.dig_p8)) >> 13;
    Some(
        (p as i32).wrapping_add(var1.wrapping_add(var2).wrapping_add(i32::from(cal.dig_p7)) >> 4)
            as u32,
    )
}

/// Temperature in °C with the datasheet's floating-point formula (8.1), in `f32`, and the
/// integer `t_fine` that formula hands to [`pressure_pa_f32`].
pub fn temperature_celsius_f32(cal: &Calibration, adc_t: u32) -> (f32, i32) {
    let adc_t = (adc_t & ADC_MAX) as f32;
    let t1 = f32::from(cal.dig_t1);
    let var1 = (adc_t / 16384.0 - t1 / 1024.0) * f32::from(cal.dig_t2);
    let d = adc_t / 131_072.0 - t1 / 8192.0;
    let var2 = d * d * f32::from(cal.dig_t3);
    ((var1 + var2) / 5120.0, (var1 + var2) as i32)
}

/// Pressure in Pa with the datasheet's floating-point formula (8.1), in `f32`. `t_fine` comes
/// from [`temperature_celsius_f32`] or [`t_fine`]. `None` where the datasheet guards the
/// division by zero.
pub fn pressure_pa_f32(cal: &Calibration, t_fine: i32, adc_p: u32) -> Option<f32> {
    let mut var1 = t_fine as f32 / 2.0 - 64_000.0;
    let mut var2 = var1 * var1 * f32::from(cal.dig_p6) / 32_768.0;
    var2 += var1 * f32::from(cal.dig_p5) * 2.0;
    var2 = var2 / 4.0 + f32::from(cal.dig_p4) * 65_536.0;
    var1 = (f32::from(cal.dig_p3) * var1 * var1 / 524_288.0 + f32::from(cal.dig_p2) * var1)
        / 524_288.0;
    var1 = (1.0 + var1 / 32_768.0) * f32::from(cal.dig_p1);
    if var1 == 0.0 {
        return None;
    }
    let mut p = 1_048_576.0 - (adc_p & ADC_MAX) as f32;
    p = (p - var2 / 4096.0) * 6250.0 / var1;
    let var1 = f32::from(cal.dig_p9) * p * p / 2_147_483_648.0;
    let var2 = p * f32::from(cal.dig_p8) / 32_768.0;
    Some(p + (var1 + var2 + f32::from(cal.dig_p7)) / 16.0)
}

/// A compensated sample with the integer datasheet formulas, and the raw values it came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Measurement {
    /// The raw ADC values of this sample.
    pub raw: RawSample,
    /// Fine temperature, the input of the pressure formula (`t_fine / 5120` °C).
    pub t_fine: i32,
    /// Temperature in 0.01 °C.
    pub temperature_centi_celsius: i32,
    /// Pressure in Pa, unsigned Q24.8 (divide by 256 for Pa).
    pub pressure_q24_8: u32,
}

impl Measurement {
    /// Pressure in whole Pa (the Q24.8 value truncated, as the datasheet does).
    pub const fn pressure_pa(&self) -> u32 {
        self.pressure_q24_8 >> 8
    }

    /// Pressure in Pa as `f32`, with the 8 fractional bits.
    pub fn pressure_pa_f32(&self) -> f32 {
        self.pressure_q24_8 as f32 / 256.0
    }

    /// Temperature in °C as `f32`.
    pub fn temperature_celsius_f32(&self) -> f32 {
        self.temperature_centi_celsius as f32 / 100.0
    }
}

/// Compensates one raw sample with the integer formulas (temperature 32-bit, pressure 64-bit).
///
/// Fails with [`DeviceError::InvalidCalibration`] where the datasheet guards a division by zero.
/// It compensates any raw values, the registers' reset value included; the driver's reads check
/// [`RawSample::holds_no_conversion`] first (see [`DeviceError::NoConversion`]).
pub fn compensate(cal: &Calibration, raw: RawSample) -> Result<Measurement, DeviceError> {
    let t_fine = t_fine(cal, raw.adc_t);
    let pressure_q24_8 =
        pressure_q24_8(cal, t_fine, raw.adc_p).ok_or(DeviceError::InvalidCalibration)?;
    Ok(Measurement {
        raw,
        t_fine,
        temperature_centi_celsius: temperature_centi_celsius(t_fine),
        pressure_q24_8,
    })
}
