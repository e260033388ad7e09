//! Inverse compensation for simulators: the raw ADC values whose compensated result is closest
//! to a given temperature and pressure, so a simulated sensor board can send raw packets that
//! the real host code decodes to the intended values.
//!
//! The integer formulas are monotonic in the raw value for real calibrations (temperature rises
//! with `adc_T`, pressure falls with `adc_P`), so each search is a bisection over the 20-bit
//! range: at most 20 steps of one formula evaluation each, with a fixed bound whatever the
//! input. Targets outside the representable range give the nearest end of the range.
//!
//! ```
//! use bosch_bmp280::{compensation, Calibration};
//!
//! let cal = Calibration::from_bytes(&Calibration::DATASHEET_EXAMPLE_BYTES);
//! // Raw values that compensate to 21.50 °C and 95 000 Pa.
//! let sample = compensation::inverse::raw_for_centi_celsius_pascal(&cal, 2150, 95_000);
//! let m = compensation::compensate(&cal, sample).unwrap();
//! assert_eq!((m.temperature_centi_celsius, m.pressure_pa()), (2150, 95_000));
//! ```

use super::{pressure_q24_8, t_fine, temperature_centi_celsius};
use crate::calibration::Calibration;
use crate::raw::{RawSample, ADC_MAX};

/// Bisection steps: enough to narrow 0..=2^20-1 to two neighbours.
const MAX_STEPS: u32 = 20;

/// The `x` in 0..=[`ADC_MAX`] whose `key(x)` is closest to `target`, for a `key` monotonic in
/// either direction (ties go to the smaller `x`).
fn closest_raw(target: i64, key: impl Fn(u32) -> i64) -> u32 {
    let (mut lo, mut hi) = (0u32, ADC_MAX);
    let rising = key(hi) >= key(lo);
    // Orient so that `g` rises: then find the last x with g(x) <= target.
    let g = |x: u32| {
        if rising {
            key(x)
        } else {
            key(x).saturating_neg()
        }
    };
    let target = if rising {
        target
    } else {
        target.saturating_neg()
    };
    if g(lo) >= target {
        return lo;
    }
    if g(hi) <= target {
        return hi;
    }
    // Invariant: g(lo) < target < g(hi).
    let mut steps = 0;
    while hi - lo > 1 && steps < MAX_STEPS {
        let mid = lo + (hi - lo) / 2;
        if g(mid) <= target {
            lo = mid;
        } else {
            hi = mid;
        }
        steps += 1;
    }
    if target.abs_diff(g(lo)) <= target.abs_diff(g(hi)) {
        lo
    } else {
        hi
    }
}

/// The 64-bit pressure as a signed search key. Near the top of the ADC range the formula goes
/// below 0 Pa and the datasheet's `u32` result wraps; read as `i32` (any real pressure is far
/// below 2^31 / 256 Pa) the function stays monotonic over the whole range.
fn pressure_key(cal: &Calibration, t_fine: i32, adc_p: u32) -> i64 {
    i64::from(pressure_q24_8(cal, t_fine, adc_p).unwrap_or(0) as i32)
}

/// Raw `adc_T` whose integer temperature (0.01 °C) is closest to `centi_celsius`.
pub fn adc_t_for_centi_celsius(cal: &Calibration, centi_celsius: i32) -> u32 {
    closest_raw(i64::from(centi_celsius), |x| {
        i64::from(temperature_centi_celsius(t_fine(cal, x)))
    })
}

/// Raw `adc_T` whose `t_fine` is closest to `celsius` (`t_fine / 5120` °C): finer than 0.01 °C.
pub fn adc_t_for_celsius_f32(cal: &Calibration, celsius: f32) -> u32 {
    // Saturating float-to-int cast: out-of-range targets land on an end of the range.
    let target = (celsius * 5120.0) as i64;
    closest_raw(target, |x| i64::from(t_fine(cal, x)))
}

/// Raw `adc_P` whose 64-bit compensated pressure (Q24.8 Pa) is closest to `pressure_q24_8`,
/// at the temperature given by `t_fine` (from [`t_fine`] of the simulated
/// `adc_T`).
pub fn adc_p_for_pressure_q24_8(cal: &Calibration, t_fine: i32, pressure_q24_8: u32) -> u32 {
    closest_raw(i64::from(pressure_q24_8), |x| pressure_key(cal, t_fine, x))
}

/// Raw `adc_P` whose compensated pressure in whole Pa (Q24.8 truncated) is closest to
/// `pascal`.
pub fn adc_p_for_pascal(cal: &Calibration, t_fine: i32, pascal: u32) -> u32 {
    // Aim at the middle of the Q24.8 interval that truncates to `pascal`.
    let target = (u64::from(pascal) << 8) + 128;
    closest_raw(target as i64, |x| pressure_key(cal, t_fine, x))
}

/// Raw `adc_P` whose compensated pressure is closest to `pascal` (`f32` Pa).
pub fn adc_p_for_pascal_f32(cal: &Calibration, t_fine: i32, pascal: f32) -> u32 {
    let target = (pascal * 256.0) as i64;
    closest_raw(target, |x| pressure_key(cal, t_fine, x))
}

/// The raw sample a sensor at `centi_celsius` (0.01 °C) and `pascal` (Pa) would report, as
/// close as the integer formulas allow.
pub fn raw_for_centi_celsius_pascal(
    cal: &Calibration,
    centi_celsius: i32,
    pascal: u32,
) -> RawSample {
    let adc_t = adc_t_for_centi_celsius(cal, centi_celsius);
    let adc_p = adc_p_for_pascal(cal, t_fine(cal, adc_t), pascal);
    RawSample { adc_p, adc_t }
}

/// The raw sample a sensor at `celsius` (°C) and `pascal` (Pa) would report, as close as the
/// integer formulas allow.
pub fn raw_for_celsius_pascal_f32(cal: &Calibration, celsius: f32, pascal: f32) -> RawSample {
    let adc_t = adc_t_for_celsius_f32(cal, celsius);
    let adc_p = adc_p_for_pascal_f32(cal, t_fine(cal, adc_t), pascal);
    RawSample { adc_p, adc_t }
}
