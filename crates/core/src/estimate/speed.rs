//! Ground speed: the GNSS fix's, carried between fixes by the longitudinal acceleration.
//!
//! At 10 Hz a fix is up to 100 ms old; at 4 m/s² of acceleration that is 0.4 m/s the speed loop
//! would not see. Integrating the accelerometer's forward axis (bias removed while standing
//! still) over at most one fix interval bridges that gap; each fix resets the integral, so the
//! accelerometer's errors never accumulate for longer.

/// The bridged speed.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SpeedBridge {
    mm_s: Option<f32>,
}

impl SpeedBridge {
    /// A GNSS fix: its ground speed replaces the estimate.
    pub fn fix(&mut self, g_speed_mm_s: i32) {
        self.mm_s = Some(g_speed_mm_s.max(0) as f32);
    }

    /// Integrates `accel_m_s2` (forward) over `dt_s`; the speed never goes below 0 (GNSS
    /// ground speed is a magnitude).
    pub fn bridge(&mut self, accel_m_s2: f32, dt_s: f32) {
        if let Some(v) = self.mm_s.as_mut() {
            let next = *v + accel_m_s2 * 1e3 * dt_s;
            if next.is_finite() {
                *v = next.max(0.0);
            }
        }
    }

    /// The speed, mm/s, once a fix has set it.
    pub fn mm_s(&self) -> Option<f32> {
        self.mm_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bridges_from_the_fix_and_resets_at_the_next() {
        let mut s = SpeedBridge::default();
        s.bridge(2.0, 0.004);
        assert_eq!(s.mm_s(), None, "nothing to bridge from before a fix");
        s.fix(1_000);
        for _ in 0..25 {
            s.bridge(2.0, 0.004);
        }
        assert!((s.mm_s().unwrap() - 1_200.0).abs() < 0.1);
        s.fix(1_150);
        assert_eq!(s.mm_s(), Some(1_150.0));
        for _ in 0..100 {
            s.bridge(-20.0, 0.004);
        }
        assert_eq!(s.mm_s(), Some(0.0));
    }
}
