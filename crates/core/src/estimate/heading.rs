//! Heading: the gyro between fixes, the GNSS heading of motion at each fix, blended by a
//! complementary filter.
//!
//! Between fixes the heading advances by the bias-corrected yaw rate. At a fix (only those
//! faster than `min_heading_speed_mm_s`: slower, the heading of motion is noise) the estimate
//! moves towards the GNSS heading by `alpha = 1 - exp(-dt / tau)` of the (short-way) difference,
//! with `dt` the time since the last correction. For a constant gyro error this is a first-order
//! low-pass on the GNSS heading with time constant `tau` and a high-pass on the gyro: GNSS noise
//! (about 1° at 2 m/s) is averaged over `tau`, gyro drift cannot build up beyond `tau`'s worth.
//! `tau = 0` takes each GNSS heading as it is.
//!
//! The gyro alone carries the heading for a limited time only (the GNSS timeout): once the last
//! correction is older, the heading is forgotten ([`HeadingFilter::expire`]) and the next GNSS
//! heading of motion is taken as it is. Below `min_heading_speed_mm_s` no fix corrects it, so a
//! slow car has no heading after that time, however fresh its fixes: an unlearnt gyro bias of
//! 2 °/s would otherwise turn it by 40° in 20 s.
//!
//! A complementary filter rather than a Kalman filter: two sensors, one state, noise levels that
//! change with speed in ways a fixed covariance would not capture better, and a single number
//! to tune that a user can reason about.

use crate::Nanos;

/// Wraps an angle difference into `-180..180` degrees.
pub fn wrap_180(deg: f32) -> f32 {
    (deg + 180.0).rem_euclid(360.0) - 180.0
}

/// The heading estimate and the time of its last GNSS correction.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HeadingFilter {
    heading: Option<(f32, Nanos)>,
}

impl HeadingFilter {
    /// Advances by `rate_dps` over `dt_s`, then corrects with `gnss_deg` (a GNSS heading of
    /// motion this cycle) at `now`.
    pub fn update(
        &mut self,
        rate_dps: f32,
        dt_s: f32,
        gnss_deg: Option<f32>,
        tau_s: f32,
        now: Nanos,
    ) {
        let propagated = self
            .heading
            .map(|(h, at)| ((h + rate_dps * dt_s).rem_euclid(360.0), at));
        self.heading = match (gnss_deg, propagated) {
            (Some(g), Some((h, at))) if tau_s > 0.0 => {
                let since_s = now.saturating_sub(at) as f32 * 1e-9;
                let alpha = 1.0 - (-since_s / tau_s).exp();
                Some(((h + alpha * wrap_180(g - h)).rem_euclid(360.0), now))
            }
            (Some(g), _) => Some((g, now)),
            (None, p) => p,
        };
    }

    /// Forgets the heading when GNSS last corrected it more than `limit_ns` before `now`.
    pub fn expire(&mut self, now: Nanos, limit_ns: Nanos) {
        self.heading = self
            .heading
            .filter(|&(_, at)| now.saturating_sub(at) <= limit_ns);
    }

    /// The heading, degrees clockwise from north, and when GNSS last corrected it.
    pub fn heading_deg(&self) -> Option<(f32, Nanos)> {
        self.heading
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Nanos = 1_000_000;

    #[test]
    fn wrap() {
        assert_eq!(wrap_180(350.0 - 10.0), -20.0);
        assert_eq!(wrap_180(10.0 - 350.0), 20.0);
        assert_eq!(wrap_180(180.0), -180.0);
        assert_eq!(wrap_180(-190.0), 170.0);
    }

    #[test]
    fn tau_zero_takes_the_gnss_heading_and_the_gyro_between() {
        let mut f = HeadingFilter::default();
        f.update(0.0, 0.0, Some(90.0), 0.0, 0);
        assert_eq!(f.heading_deg(), Some((90.0, 0)));
        for i in 1..=25 {
            f.update(50.0, 0.004, None, 0.0, i * 4 * MS);
        }
        assert!((f.heading_deg().unwrap().0 - 95.0).abs() < 1e-3);
        f.update(50.0, 0.004, Some(92.0), 0.0, 104 * MS);
        assert_eq!(f.heading_deg(), Some((92.0, 104 * MS)));
    }

    #[test]
    fn the_gyro_carries_the_heading_only_within_the_limit() {
        let mut f = HeadingFilter::default();
        f.update(0.0, 0.0, Some(90.0), 0.5, 0);
        f.expire(500 * MS, 500 * MS);
        assert_eq!(f.heading_deg(), Some((90.0, 0)), "at the limit");
        f.expire(501 * MS, 500 * MS);
        assert_eq!(f.heading_deg(), None, "past it");
        // The next GNSS heading is taken as it is, not blended with a forgotten one.
        f.update(0.0, 0.004, Some(120.0), 0.5, 600 * MS);
        assert_eq!(f.heading_deg(), Some((120.0, 600 * MS)));
    }

    #[test]
    fn a_correction_moves_by_alpha_the_short_way_round() {
        let mut f = HeadingFilter::default();
        f.update(0.0, 0.0, Some(355.0), 0.5, 0);
        // 0.1 s later the GNSS says 5°: 10° clockwise, across north.
        f.update(0.0, 0.1, Some(5.0), 0.5, 100 * MS);
        let alpha = 1.0 - (-0.2f32).exp();
        let want = (355.0 + alpha * 10.0) % 360.0;
        assert!((f.heading_deg().unwrap().0 - want).abs() < 1e-4);
    }
}
