//! Rollover: the direction of gravity in the accelerometer's reading, tilted from the car's up
//! axis by more than the configured angle for longer than the configured time, means the car
//! lies on its side or on its roof.
//!
//! The accelerometer measures the specific force: standing level it reads 1 g along the up
//! axis, whatever the car's heading. The tilt is the angle between the reading and that axis:
//! 0° level, 90° on its side, 180° upside down. A bump tilts the reading for a few packets
//! only; the car must stay tilted for the hold time to count as rolled over.
//!
//! Only a reading of about 1 g is judged (`GRAVITY_BAND_MG`): a car lying on its side or
//! roof reads gravity alone, while a reading tilted as far by a corner or a bump carries the
//! car's own acceleration as well (a corner that tilts the reading by 60° pulls 1.7 g
//! sideways: 2 g in all), and an airborne car reads almost nothing. Such readings say nothing
//! about a rollover, like a missing packet.
//!
//! Missing packets: the monitor judges only packets. A gap in the packets neither ends a tilt
//! nor starts one: the tilt is timed from the first tilted packet, so when the packets on both
//! sides of a gap are tilted the gap counts as tilted (a car does not right itself and roll
//! back within a few missing packets), and when the packet after the gap is level the tilt has
//! ended. A rollover is declared only on a packet that shows the tilt (a gap long enough to
//! matter trips `SensorLoss` anyway), and once declared it lasts until a packet shows the car
//! within the angle.

use core::ops::RangeInclusive;

use crate::Nanos;

/// The magnitudes of an accelerometer reading, mg, that are judged for a rollover: about 1 g,
/// what a car at rest in any attitude reads.
pub const GRAVITY_BAND_MG: RangeInclusive<f32> = 500.0..=1_500.0;

/// The rollover thresholds, in the units the monitor uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RolloverRule {
    /// Cosine of the largest tilt that is not a rollover: a reading whose component along the
    /// up axis, over its magnitude, is below this is tilted.
    pub cos_max_tilt: f32,
    /// How long the car must stay tilted to be rolled over, ns.
    pub hold_ns: Nanos,
    /// `1.0` when the accelerometer's +Z axis points up on a level car, `-1.0` when it points
    /// down.
    pub up_sign: f32,
}

impl RolloverRule {
    /// Tilted beyond `max_tilt_deg` for `hold_ms`, with the up axis `up_sign` (the sign of the
    /// accelerometer's Z reading on a level car).
    pub fn new(max_tilt_deg: f32, hold_ms: u32, up_sign: f32) -> RolloverRule {
        RolloverRule {
            cos_max_tilt: max_tilt_deg.to_radians().cos(),
            hold_ns: u64::from(hold_ms) * 1_000_000,
            up_sign: if up_sign < 0.0 { -1.0 } else { 1.0 },
        }
    }

    /// Whether an accelerometer reading (mg, X, Y, Z) is tilted beyond the angle. A reading
    /// outside `GRAVITY_BAND_MG` (about 1 g: a corner, a bump, a jump, not finite: not
    /// gravity alone)
    /// says nothing and is `None`.
    pub fn is_tilted(&self, accel: [f32; 3]) -> Option<bool> {
        let norm = (accel[0] * accel[0] + accel[1] * accel[1] + accel[2] * accel[2]).sqrt();
        if !norm.is_finite() || !GRAVITY_BAND_MG.contains(&norm) {
            return None;
        }
        Some(self.up_sign * accel[2] / norm < self.cos_max_tilt)
    }
}

/// The tilt of the last judged packet and since when it has lasted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RolloverMonitor {
    /// Time of the first packet of the current run of tilted packets.
    tilted_since: Option<Nanos>,
    /// Declared rolled over: tilted for at least the hold time, up to the last judged packet.
    rolled_over: bool,
}

impl RolloverMonitor {
    /// Looks at one valid packet's accelerometer reading at `now`; returns whether the car is
    /// rolled over.
    pub fn update(&mut self, accel: [f32; 3], now: Nanos, rule: &RolloverRule) -> bool {
        match rule.is_tilted(accel) {
            Some(true) => {
                let since = *self.tilted_since.get_or_insert(now);
                if now.saturating_sub(since) >= rule.hold_ns {
                    self.rolled_over = true;
                }
            }
            Some(false) => {
                self.tilted_since = None;
                self.rolled_over = false;
            }
            None => {}
        }
        self.rolled_over
    }

    /// Whether the car is rolled over, as of the last judged packet.
    pub fn is_rolled_over(&self) -> bool {
        self.rolled_over
    }

    /// Whether the last judged packet showed the car tilted beyond the angle (for however
    /// short a time): the car is not upright, so a revive is refused.
    pub fn is_tilted(&self) -> bool {
        self.tilted_since.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Nanos = 1_000_000;
    /// 4 ms packets (250 Hz).
    const PERIOD: Nanos = 4 * MS;
    const LEVEL: [f32; 3] = [0.0, 0.0, 1_000.0];

    fn rule() -> RolloverRule {
        RolloverRule::new(60.0, 500, 1.0)
    }

    /// 1 g tilted by `deg` about the car's X axis (rolling onto its side).
    fn tilted(deg: f32) -> [f32; 3] {
        let r = deg.to_radians();
        [0.0, 1_000.0 * r.sin(), 1_000.0 * r.cos()]
    }

    /// Feeds `reading` every period from `from` for `duration`; returns the time after the
    /// last packet and whether the last packet left the car rolled over.
    fn hold(
        m: &mut RolloverMonitor,
        reading: [f32; 3],
        from: Nanos,
        duration: Nanos,
    ) -> (Nanos, bool) {
        let mut t = from;
        let mut rolled = false;
        while t < from + duration {
            rolled = m.update(reading, t, &rule());
            t += PERIOD;
        }
        (t, rolled)
    }

    #[test]
    fn a_hard_corner_or_a_jump_is_not_a_rollover() {
        let mut m = RolloverMonitor::default();
        // Full lock at speed: 1.9 g sideways with the ±2 g range's 1 g up, a reading tilted by
        // 62° for two seconds (2.1 g in all).
        let (_, rolled) = hold(&mut m, [0.0, 1_900.0, 1_000.0], 0, 2_000 * MS);
        assert!(!rolled && !m.is_tilted());
        // Airborne for a second: almost nothing, in no direction that means anything.
        let (_, rolled) = hold(&mut m, [30.0, 40.0, -20.0], 0, 1_000 * MS);
        assert!(!rolled && !m.is_tilted());
        // A car on its side after the corner is still found.
        let (_, rolled) = hold(&mut m, tilted(90.0), 3_000 * MS, 600 * MS);
        assert!(rolled);
    }

    #[test]
    fn a_level_car_never_rolls_over() {
        let mut m = RolloverMonitor::default();
        let (_, rolled) = hold(&mut m, LEVEL, 0, 10_000 * MS);
        assert!(!rolled && !m.is_tilted());
        // Cornering and braking at 0.8 g tilt the reading by 39° at most: no rollover.
        let (_, rolled) = hold(&mut m, [800.0, -800.0, 1_000.0], 0, 10_000 * MS);
        assert!(!rolled && !m.is_tilted());
    }

    #[test]
    fn seventy_degrees_for_400_ms_is_not_a_rollover_for_600_ms_it_is() {
        let mut m = RolloverMonitor::default();
        let (t, rolled) = hold(&mut m, tilted(70.0), 0, 400 * MS);
        assert!(!rolled && m.is_tilted());
        // Level again: the tilt ended, the next one is timed from its own start.
        let (t, rolled) = hold(&mut m, LEVEL, t, 100 * MS);
        assert!(!rolled && !m.is_tilted());
        let (_, rolled) = hold(&mut m, tilted(70.0), t, 600 * MS);
        assert!(rolled && m.is_rolled_over());
    }

    #[test]
    fn it_trips_at_the_hold_time_not_a_packet_sooner() {
        let mut m = RolloverMonitor::default();
        assert!(!m.update(tilted(70.0), 1_000 * MS, &rule()));
        assert!(!m.update(tilted(70.0), 1_499 * MS, &rule()));
        assert!(m.update(tilted(70.0), 1_500 * MS, &rule()));
    }

    #[test]
    fn upside_down_and_on_its_side_are_rollovers_fifty_degrees_is_not() {
        for (deg, rolls) in [
            (180.0, true),
            (120.0, true),
            (90.0, true),
            (61.0, true),
            (59.0, false),
            (50.0, false),
        ] {
            let mut m = RolloverMonitor::default();
            let (_, rolled) = hold(&mut m, tilted(deg), 0, 600 * MS);
            assert_eq!(rolled, rolls, "{deg}°");
        }
        // Pitching over the nose is the same as rolling onto the side.
        let mut m = RolloverMonitor::default();
        let (_, rolled) = hold(&mut m, [1_000.0, 0.0, -100.0], 0, 600 * MS);
        assert!(rolled);
    }

    #[test]
    fn the_up_axis_follows_the_mounting() {
        // Board mounted upside down: a level car reads -1 g on Z.
        let down = RolloverRule::new(60.0, 500, -1.0);
        let mut m = RolloverMonitor::default();
        for i in 0..200 {
            assert!(!m.update([0.0, 0.0, -1_000.0], i * PERIOD, &down));
        }
        let mut m = RolloverMonitor::default();
        assert!(!m.update(LEVEL, 0, &down));
        assert!(m.update(LEVEL, 600 * MS, &down));
    }

    #[test]
    fn a_short_spike_from_a_bump_is_not_a_rollover() {
        let mut m = RolloverMonitor::default();
        let mut t = 0;
        // Every 300 ms a bump throws the reading past 90° for 40 ms.
        for _ in 0..20 {
            let (after, rolled) = hold(&mut m, [300.0, 2_000.0, -500.0], t, 40 * MS);
            assert!(!rolled);
            let (after, rolled) = hold(&mut m, LEVEL, after, 260 * MS);
            assert!(!rolled);
            t = after;
        }
    }

    #[test]
    fn a_missing_packet_neither_ends_nor_times_a_tilt_on_its_own() {
        // Tilted 0..300 ms, no packets 300..450 ms, tilted again from 450 ms: the tilt is
        // timed from 0, so the packet at 500 ms declares the rollover.
        let mut m = RolloverMonitor::default();
        let (_, rolled) = hold(&mut m, tilted(90.0), 0, 300 * MS);
        assert!(!rolled);
        assert!(!m.update(tilted(90.0), 450 * MS, &rule()));
        assert!(m.update(tilted(90.0), 500 * MS, &rule()));
        // A gap after a tilt that ends level: no rollover, however long the gap.
        let mut m = RolloverMonitor::default();
        let (_, rolled) = hold(&mut m, tilted(90.0), 0, 300 * MS);
        assert!(!rolled);
        assert!(!m.update(LEVEL, 5_000 * MS, &rule()));
        assert!(!m.is_tilted());
        // A reading without a direction (zero: free fall or a broken word) changes nothing.
        let mut m = RolloverMonitor::default();
        assert!(!m.update(tilted(90.0), 0, &rule()));
        assert!(!m.update([0.0; 3], 600 * MS, &rule()));
        assert!(m.is_tilted() && !m.is_rolled_over());
        assert!(m.update(tilted(90.0), 600 * MS, &rule()));
        // Once rolled over it lasts until a packet shows the car upright.
        assert!(m.update([0.0; 3], 700 * MS, &rule()));
        assert!(!m.update(LEVEL, 800 * MS, &rule()));
    }
}
