//! Physical units for the ranges the board configures.
//!
//! The packet carries raw counts; these helpers apply the scale factors of the BMX055 ranges
//! the firmware sets (accelerometer ±2 g, gyroscope ±2000 °/s). They are separate from the
//! decoder so a board configured differently only needs different factors. The accelerometer
//! scale is the BMX055 driver's ([`AccelRange::mg_per_count`]), so a count means the same here
//! and there.

use bosch_bmx055::accel::{accel_count_to_mg, AccelRange};

/// Accelerometer sensitivity at ±2 g: 1000 / 1024 = 0.9765625 mg per count, the BMX055
/// driver's [`AccelRange::G2`] scale (the datasheet's table rounds it to 0.98).
pub const ACCEL_MG_PER_COUNT_2G: f32 = AccelRange::G2.mg_per_count();

/// Gyroscope sensitivity at ±2000 °/s: 16.4 counts per °/s (BMX055 datasheet), i.e.
/// 1/16.4 °/s per count.
pub const GYRO_COUNTS_PER_DPS_2000: f32 = 16.4;

/// Standard gravity, m/s², for converting g to SI units.
pub const STANDARD_GRAVITY: f32 = 9.806_65;

/// Accelerometer count at ±2 g to milli-g.
#[must_use]
pub fn accel_mg_2g(count: i16) -> f32 {
    accel_count_to_mg(count, AccelRange::G2)
}

/// Accelerometer count at ±2 g to m/s².
#[must_use]
pub fn accel_m_s2_2g(count: i16) -> f32 {
    accel_mg_2g(count) * 1e-3 * STANDARD_GRAVITY
}

/// Gyroscope count at ±2000 °/s to degrees per second.
#[must_use]
pub fn gyro_dps_2000(count: i16) -> f32 {
    f32::from(count) / GYRO_COUNTS_PER_DPS_2000
}

/// Gyroscope count at ±2000 °/s to radians per second.
#[must_use]
pub fn gyro_rad_s_2000(count: i16) -> f32 {
    gyro_dps_2000(count).to_radians()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() < 1e-4 * b.abs().max(1.0)
    }

    #[test]
    fn accelerometer_scale() {
        // BMX055 datasheet: ±2 g range, 1024 LSB/g (0.98 mg/LSB rounded).
        assert!(close(accel_mg_2g(1024), 1000.0));
        assert!(close(accel_mg_2g(-2048), -2000.0));
        assert!(close(accel_m_s2_2g(1024), 9.806_65));
        // The rounded table value is the exact one within its last digit.
        assert!((ACCEL_MG_PER_COUNT_2G - 0.98).abs() <= 0.005);
    }

    #[test]
    fn gyroscope_scale() {
        // BMX055 datasheet: ±2000 °/s range, 16.4 LSB per °/s.
        assert!(close(gyro_dps_2000(164), 10.0));
        assert!(close(gyro_dps_2000(-32768), -1998.049));
        assert!(close(gyro_rad_s_2000(164), 10.0f32.to_radians()));
    }
}
