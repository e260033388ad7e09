//! The accelerometer scale against the datasheet's range table.
//!
//! BMX055 datasheet, accelerometer: sensitivity 1024/512/256/128 LSB/g and resolution
//! 0.98/1.95/3.91/7.81 mg/LSB for ±2/±4/±8/±16 g. The sensitivity is the truth (full scale over
//! 2048 counts); the resolution column is it rounded to two decimals.

use bosch_bmx055::accel::{accel_count_to_mg, accel_word_to_mg, AccelRange};

const TABLE: [(AccelRange, f32, f32); 4] = [
    (AccelRange::G2, 1024.0, 0.98),
    (AccelRange::G4, 512.0, 1.95),
    (AccelRange::G8, 256.0, 3.91),
    (AccelRange::G16, 128.0, 7.81),
];

#[test]
fn sensitivity_is_the_datasheet_table() {
    for (range, lsb_per_g, _) in TABLE {
        assert_eq!(range.counts_per_g(), lsb_per_g, "{range:?}");
        assert_eq!(range.mg_per_count(), 1000.0 / lsb_per_g, "{range:?}");
    }
}

#[test]
fn the_rounded_resolution_column_is_the_exact_scale_within_its_last_digit() {
    for (range, _, table_mg_per_lsb) in TABLE {
        let exact = range.mg_per_count();
        assert!(
            (exact - table_mg_per_lsb).abs() <= 0.005 + f32::EPSILON,
            "{range:?}: exact {exact} vs table {table_mg_per_lsb}"
        );
    }
}

#[test]
fn full_scale_counts_read_the_range() {
    for (range, lsb_per_g, _) in TABLE {
        let one_g = lsb_per_g as i16;
        assert_eq!(accel_count_to_mg(one_g, range), 1000.0, "{range:?}");
        assert_eq!(
            accel_count_to_mg(-2048, range),
            -2048.0 * 1000.0 / lsb_per_g
        );
        assert_eq!(accel_word_to_mg(one_g << 4, range), 1000.0, "{range:?}");
    }
}
