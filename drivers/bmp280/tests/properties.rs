//! Property tests: compensation never panics, codecs round-trip, the inverse compensation lands
//! within one output step of its target.

mod common;

// The inverse compensation is the simulator's, behind the `sim` feature.
#[cfg(feature = "sim")]
use bosch_bmp280::compensation::inverse::*;
use bosch_bmp280::compensation::*;
use bosch_bmp280::{Calibration, Config, RawSample};
use common::{adc_from_bytes, bytes_from_adc, ADC_MAX};
use common::{DATASHEET_CALIB, OTHER_CALIB};
use proptest::prelude::*;

fn any_calibration() -> impl Strategy<Value = Calibration> {
    (any::<[u16; 2]>(), any::<[i16; 10]>()).prop_map(|([t1, p1], r)| Calibration {
        dig_t1: t1,
        dig_t2: r[0],
        dig_t3: r[1],
        dig_p1: p1,
        dig_p2: r[2],
        dig_p3: r[3],
        dig_p4: r[4],
        dig_p5: r[5],
        dig_p6: r[6],
        dig_p7: r[7],
        dig_p8: r[8],
        dig_p9: r[9],
    })
}

fn real_calibration() -> impl Strategy<Value = Calibration> {
    prop_oneof![Just(DATASHEET_CALIB), Just(OTHER_CALIB)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn compensation_never_panics(cal in any_calibration(), adc_t in any::<u32>(), adc_p in any::<u32>(), t_fine_any in any::<i32>()) {
        let tf = t_fine(&cal, adc_t);
        let _ = temperature_centi_celsius(tf);
        let _ = temperature_centi_celsius(t_fine_any);
        let _ = pressure_q24_8(&cal, tf, adc_p);
        let _ = pressure_q24_8(&cal, t_fine_any, adc_p);
        let _ = pressure_pa_32bit(&cal, tf, adc_p);
        let _ = pressure_pa_32bit(&cal, t_fine_any, adc_p);
        let (_, tf32) = temperature_celsius_f32(&cal, adc_t);
        let _ = pressure_pa_f32(&cal, tf32, adc_p);
        let _ = pressure_pa_f32(&cal, t_fine_any, adc_p);
        let _ = compensate(&cal, RawSample { adc_p, adc_t });
    }

    #[cfg(feature = "sim")]
    #[test]
    fn inverse_never_panics(cal in any_calibration(), centi in any::<i32>(), pa in any::<u32>(), c in any::<f32>(), p in any::<f32>()) {
        let raw = raw_for_centi_celsius_pascal(&cal, centi, pa);
        prop_assert!(raw.adc_t <= ADC_MAX && raw.adc_p <= ADC_MAX);
        let raw = raw_for_celsius_pascal_f32(&cal, c, p);
        prop_assert!(raw.adc_t <= ADC_MAX && raw.adc_p <= ADC_MAX);
    }

    #[test]
    fn the_raw_adc_values_of_a_real_device_stay_in_range(cal in real_calibration(), adc_t in 0u32..=ADC_MAX, adc_p in 0u32..=ADC_MAX) {
        // The integer formulas must not wrap for genuine calibrations anywhere in the 20-bit
        // range: the 64-bit pressure agrees with the f32 formula to 0.1 %.
        let tf = t_fine(&cal, adc_t);
        if let (Some(q), Some(f)) = (pressure_q24_8(&cal, tf, adc_p), pressure_pa_f32(&cal, tf, adc_p)) {
            let p = f64::from(q) / 256.0;
            if f > 1000.0 && f < 2.0e5 {
                prop_assert!((p - f64::from(f)).abs() < f64::from(f) * 1e-3, "{} vs {}", p, f);
            }
        }
    }

    #[test]
    fn register_bytes_round_trip(adc_p in 0u32..=ADC_MAX, adc_t in 0u32..=ADC_MAX) {
        let bytes = bytes_from_adc(adc_p, adc_t);
        prop_assert_eq!(adc_from_bytes(&bytes), (adc_p, adc_t));
        let raw = RawSample { adc_p, adc_t };
        prop_assert_eq!(RawSample::from_register_bytes(&raw.to_register_bytes()), raw);
    }

    #[test]
    fn register_bytes_decode_keeps_all_used_bits(bytes in any::<[u8; 6]>()) {
        let (p, t) = adc_from_bytes(&bytes);
        prop_assert!(p <= ADC_MAX && t <= ADC_MAX);
        let mut masked = bytes;
        masked[2] &= 0xF0;
        masked[5] &= 0xF0;
        prop_assert_eq!(bytes_from_adc(p, t), masked);
    }

    #[test]
    fn calibration_bytes_round_trip(bytes in any::<[u8; 24]>()) {
        prop_assert_eq!(Calibration::from_bytes(&bytes).to_bytes(), bytes);
    }

    #[test]
    fn config_registers_round_trip(ctrl in any::<u8>(), cfg in any::<u8>()) {
        let c = Config::from_registers(ctrl, cfg);
        prop_assert_eq!(Config::from_registers(c.ctrl_meas(), c.config_register()), c);
    }

    #[cfg(feature = "sim")]
    #[test]
    fn inverse_temperature_lands_within_one_step(cal in real_calibration(), centi in -4000i32..=8500) {
        let adc_t = adc_t_for_centi_celsius(&cal, centi);
        let got = temperature_centi_celsius(t_fine(&cal, adc_t));
        let step = local_step(adc_t, |x| i64::from(temperature_centi_celsius(t_fine(&cal, x))));
        prop_assert!(i64::from(got).abs_diff(i64::from(centi)) <= step.max(1), "{} -> {} (step {})", centi, got, step);
    }

    #[cfg(feature = "sim")]
    #[test]
    fn inverse_temperature_f32_lands_within_one_step(cal in real_calibration(), celsius in -40.0f32..=85.0) {
        let adc_t = adc_t_for_celsius_f32(&cal, celsius);
        let target = (celsius * 5120.0) as i64;
        let got = i64::from(t_fine(&cal, adc_t));
        let step = local_step(adc_t, |x| i64::from(t_fine(&cal, x)));
        prop_assert!(got.abs_diff(target) <= step.max(1), "{} -> t_fine {} (step {})", celsius, got, step);
    }

    #[cfg(feature = "sim")]
    #[test]
    fn inverse_pressure_lands_within_one_step(cal in real_calibration(), centi in -4000i32..=8500, pa in 30_000u32..=110_000) {
        let raw = raw_for_centi_celsius_pascal(&cal, centi, pa);
        let tf = t_fine(&cal, raw.adc_t);
        let m = compensate(&cal, raw).unwrap();
        // Pa: one step of adc_P is below 1 Pa, so the whole-Pa value is met exactly or by 1.
        prop_assert!(m.pressure_pa().abs_diff(pa) <= 1, "{} Pa -> {} Pa", pa, m.pressure_pa());
        let target = u64::from(pa) * 256;
        let adc_p = adc_p_for_pressure_q24_8(&cal, tf, target as u32);
        let got = pressure_q24_8(&cal, tf, adc_p).unwrap();
        let step = local_step(adc_p, |x| i64::from(pressure_q24_8(&cal, tf, x).unwrap()));
        prop_assert!(u64::from(got).abs_diff(target) <= step, "{} -> {} (step {})", target, got, step);
    }

    #[cfg(feature = "sim")]
    #[test]
    fn inverse_f32_lands_within_one_step(cal in real_calibration(), celsius in -40.0f32..=85.0, pa in 30_000.0f32..=110_000.0) {
        let raw = raw_for_celsius_pascal_f32(&cal, celsius, pa);
        let m = compensate(&cal, raw).unwrap();
        prop_assert!((m.temperature_celsius_f32() - celsius).abs() <= 0.011, "{} -> {}", celsius, m.temperature_celsius_f32());
        let tf = t_fine(&cal, raw.adc_t);
        let step = local_step(raw.adc_p, |x| i64::from(pressure_q24_8(&cal, tf, x).unwrap()));
        let target = (pa * 256.0) as i64;
        prop_assert!(i64::from(m.pressure_q24_8).abs_diff(target) <= step, "{} -> {} (step {})", target, m.pressure_q24_8, step);
    }

    #[cfg(feature = "sim")]
    #[test]
    fn inverse_of_a_compensated_sample_compensates_the_same(cal in real_calibration(), adc_t in 300_000u32..=700_000, adc_p in 100_000u32..=700_000) {
        let m = compensate(&cal, RawSample { adc_p, adc_t }).unwrap();
        let adc_t2 = adc_t_for_centi_celsius(&cal, m.temperature_centi_celsius);
        prop_assert_eq!(temperature_centi_celsius(t_fine(&cal, adc_t2)), m.temperature_centi_celsius);
        let adc_p2 = adc_p_for_pressure_q24_8(&cal, m.t_fine, m.pressure_q24_8);
        prop_assert_eq!(pressure_q24_8(&cal, m.t_fine, adc_p2), Some(m.pressure_q24_8));
    }
}

/// The larger output change between `x` and its two neighbours: one "LSB step" of the formula.
#[cfg(feature = "sim")]
fn local_step(x: u32, f: impl Fn(u32) -> i64) -> u64 {
    let here = f(x);
    let below = if x > 0 { f(x - 1).abs_diff(here) } else { 0 };
    let above = if x < ADC_MAX {
        f(x + 1).abs_diff(here)
    } else {
        0
    };
    below.max(above)
}

#[cfg(feature = "sim")]
#[test]
fn realistic_range_is_inside_the_20_bit_range() {
    // -40 °C / 300 hPa and 85 °C / 1100 hPa must not clamp to an end of the ADC range.
    for cal in [DATASHEET_CALIB, OTHER_CALIB] {
        for (centi, pa) in [
            (-4000, 30_000),
            (8500, 110_000),
            (-4000, 110_000),
            (8500, 30_000),
        ] {
            let raw = raw_for_centi_celsius_pascal(&cal, centi, pa);
            assert!(raw.adc_t > 0 && raw.adc_t < ADC_MAX, "{raw:?}");
            assert!(raw.adc_p > 0 && raw.adc_p < ADC_MAX, "{raw:?}");
            let m = compensate(&cal, raw).unwrap();
            assert!(m.temperature_centi_celsius.abs_diff(centi) <= 1);
            assert!(m.pressure_pa().abs_diff(pa) <= 1);
        }
    }
}
