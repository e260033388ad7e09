//! Sensor biases learnt while the car stands still.
//!
//! Standing still (GNSS ground speed under `still_speed_mm_s` and a yaw rate under
//! `still_rate_dps`), the true yaw rate is zero and the longitudinal acceleration is zero, so
//! what the gyro and the accelerometer's forward axis read is their bias (for the accelerometer
//! including the part of gravity a tilted mount projects on it). Each still sample moves the
//! estimate by `dt / tau` towards the reading: a first-order low-pass with time constant `tau`.

/// Gyro and forward-accelerometer biases.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StillBias {
    gyro_dps: f32,
    accel_x_m_s2: f32,
}

impl StillBias {
    /// Learns from one still sample: `yaw_rate_dps` (clockwise, raw) and `accel_x_m_s2`.
    pub fn learn(&mut self, yaw_rate_dps: f32, accel_x_m_s2: f32, dt_s: f32, tau_s: f32) {
        if !(dt_s > 0.0 && tau_s > 0.0 && yaw_rate_dps.is_finite() && accel_x_m_s2.is_finite()) {
            return;
        }
        let alpha = (dt_s / tau_s).min(1.0);
        self.gyro_dps += alpha * (yaw_rate_dps - self.gyro_dps);
        self.accel_x_m_s2 += alpha * (accel_x_m_s2 - self.accel_x_m_s2);
    }

    /// A raw clockwise yaw rate with the bias removed.
    pub fn yaw_rate_dps(&self, raw_dps: f32) -> f32 {
        raw_dps - self.gyro_dps
    }

    /// A raw forward acceleration with the bias removed.
    pub fn accel_long_m_s2(&self, raw_m_s2: f32) -> f32 {
        raw_m_s2 - self.accel_x_m_s2
    }

    /// The gyro bias, degrees per second clockwise.
    pub fn gyro_dps(&self) -> f32 {
        self.gyro_dps
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn converges_to_the_still_reading_with_its_time_constant() {
        let mut b = StillBias::default();
        // One time constant of samples at 250 Hz: 1 - 1/e of the way.
        for _ in 0..250 {
            b.learn(0.4, 0.1, 0.004, 1.0);
        }
        let reached = b.gyro_dps() / 0.4;
        assert!(
            (reached - (1.0 - (-1.0f32).exp())).abs() < 0.01,
            "{reached}"
        );
        assert!((b.yaw_rate_dps(0.4) - 0.4 * (1.0 - reached)).abs() < 1e-6);
        assert!((b.accel_long_m_s2(0.1) - 0.1 * (1.0 - reached)).abs() < 1e-3);
    }

    #[test]
    fn without_learning_the_raw_values_pass_unchanged() {
        let b = StillBias::default();
        for raw in [-0.0f32, 1.5, -123.25] {
            assert_eq!(b.yaw_rate_dps(raw).to_bits(), raw.to_bits());
        }
    }
}
