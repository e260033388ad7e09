//! One accelerometer scale: a count means the same acceleration here as in the BMX055 driver.

use bosch_bmx055::accel::{accel_word_to_mg, AccelRange};
use dima_sensorboard::units::{accel_m_s2_2g, accel_mg_2g, STANDARD_GRAVITY};

#[test]
fn a_count_scales_as_in_the_bmx055_driver() {
    for count in [-2048i16, -1024, -1, 0, 1, 512, 1000, 1024, 2047] {
        // The driver scales the left-justified register word; the packet carries the count.
        let driver_mg = accel_word_to_mg(count << 4, AccelRange::G2);
        assert_eq!(accel_mg_2g(count), driver_mg, "count {count}");
    }
}

#[test]
fn one_g_is_1024_counts_at_2g() {
    // BMX055 datasheet: ±2 g, 1024 LSB/g.
    assert_eq!(accel_mg_2g(1024), 1000.0);
    assert_eq!(accel_m_s2_2g(1024), STANDARD_GRAVITY);
}
