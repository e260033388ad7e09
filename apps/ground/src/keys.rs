//! The keyboard contract, as a pure function of the keys held and the time.
//!
//! | keys | effect |
//! |---|---|
//! | Up / W held, Down / S held | throttle neutral + step / neutral − step; released: neutral |
//! | Right / D, Left / A | steering neutral + step / − step; released: neutral |
//! | E, Q | tail neutral + step / − step; released: neutral |
//! | Space | kill (always, whatever has focus) |
//! | R held for [`REVIVE_HOLD`] | revive (once per press) |
//!
//! Both directions of one axis held at once cancel out to neutral, as if neither were held.

use std::time::{Duration, Instant};

use dima_groundlink::station::ManualChannel;
use dima_groundlink::Percent;

use crate::channels::ChannelTable;

/// How long R must be held to revive.
pub const REVIVE_HOLD: Duration = Duration::from_secs(1);

/// The keys that drive, as held in one frame of the user interface.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct KeysHeld {
    /// Up or W.
    pub throttle_up: bool,
    /// Down or S.
    pub throttle_down: bool,
    /// Right or D.
    pub steer_right: bool,
    /// Left or A.
    pub steer_left: bool,
    /// E.
    pub tail_right: bool,
    /// Q.
    pub tail_left: bool,
    /// R.
    pub revive: bool,
    /// Space was pressed since the last frame.
    pub kill_pressed: bool,
}

/// What one axis does in this frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisChange {
    /// Keys of this axis are held: hold this value.
    Held(Percent),
    /// The keys were just released: send neutral once, hold nothing.
    Released(Percent),
    /// Nothing held, nothing changed.
    Idle,
}

/// What the keyboard asks for in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeyActions {
    /// Throttle, steering, tail.
    pub axes: [AxisChange; 3],
    /// Space: kill now.
    pub kill: bool,
    /// R has just been held long enough: revive now.
    pub revive: bool,
    /// How far the R hold is, 0..=1 (for a progress bar).
    pub revive_progress: f32,
}

/// The keyboard driver: turns held keys into axis values, kills and revives.
#[derive(Debug, Clone)]
pub struct KeyboardDriver {
    neutral: [Percent; 3],
    step: u8,
    last: [Option<Percent>; 3],
    r_since: Option<Instant>,
    revived_this_hold: bool,
}

impl KeyboardDriver {
    /// A driver moving each axis `step` percent from the channel table's neutral.
    pub fn new(table: &ChannelTable, step: u8) -> KeyboardDriver {
        KeyboardDriver {
            neutral: ManualChannel::ALL.map(|c| table.neutral_percent(c)),
            step: step.min(100),
            last: [None; 3],
            r_since: None,
            revived_this_hold: false,
        }
    }

    /// The step, percent.
    pub fn step(&self) -> u8 {
        self.step
    }

    /// Changes the step (takes effect for the next held value).
    pub fn set_step(&mut self, step: u8) {
        self.step = step.min(100);
    }

    fn axis_value(&self, axis: usize, minus: bool, plus: bool) -> Option<Percent> {
        let n = i16::from(self.neutral[axis].get());
        let s = i16::from(self.step);
        let v = match (minus, plus) {
            (false, true) => n + s,
            (true, false) => n - s,
            _ => return None,
        };
        Percent::new(v.clamp(0, 100) as u8)
    }

    /// The actions for the keys held at `now`.
    pub fn update(&mut self, keys: KeysHeld, now: Instant) -> KeyActions {
        let wanted = [
            self.axis_value(0, keys.throttle_down, keys.throttle_up),
            self.axis_value(1, keys.steer_left, keys.steer_right),
            self.axis_value(2, keys.tail_left, keys.tail_right),
        ];
        let mut axes = [AxisChange::Idle; 3];
        for i in 0..3 {
            axes[i] = match (self.last[i], wanted[i]) {
                (_, Some(v)) => AxisChange::Held(v),
                (Some(_), None) => AxisChange::Released(self.neutral[i]),
                (None, None) => AxisChange::Idle,
            };
        }
        self.last = wanted;

        let mut revive = false;
        let mut revive_progress = 0.0;
        if keys.revive {
            let since = *self.r_since.get_or_insert(now);
            let held = now.saturating_duration_since(since);
            revive_progress = (held.as_secs_f32() / REVIVE_HOLD.as_secs_f32()).min(1.0);
            if held >= REVIVE_HOLD && !self.revived_this_hold {
                self.revived_this_hold = true;
                revive = true;
            }
        } else {
            self.r_since = None;
            self.revived_this_hold = false;
        }
        KeyActions {
            axes,
            kill: keys.kill_pressed,
            revive,
            revive_progress,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn driver(step: u8) -> KeyboardDriver {
        KeyboardDriver::new(&ChannelTable::default(), step)
    }

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    #[test]
    fn held_keys_step_from_neutral_and_release_to_neutral() {
        let t = Instant::now();
        let mut d = driver(20);
        let up = KeysHeld {
            throttle_up: true,
            ..KeysHeld::default()
        };
        assert_eq!(d.update(up, t).axes[0], AxisChange::Held(pct(70)));
        assert_eq!(d.update(up, t).axes[0], AxisChange::Held(pct(70)));
        let none = KeysHeld::default();
        assert_eq!(d.update(none, t).axes[0], AxisChange::Released(pct(50)));
        assert_eq!(d.update(none, t).axes[0], AxisChange::Idle);
        let left = KeysHeld {
            steer_left: true,
            tail_right: true,
            throttle_down: true,
            ..KeysHeld::default()
        };
        let a = d.update(left, t);
        assert_eq!(
            a.axes,
            [
                AxisChange::Held(pct(30)),
                AxisChange::Held(pct(30)),
                AxisChange::Held(pct(70))
            ]
        );
    }

    #[test]
    fn opposite_keys_cancel_and_steps_saturate() {
        let t = Instant::now();
        let mut d = driver(80);
        let both = KeysHeld {
            throttle_up: true,
            throttle_down: true,
            ..KeysHeld::default()
        };
        assert_eq!(d.update(both, t).axes[0], AxisChange::Idle);
        let up = KeysHeld {
            throttle_up: true,
            ..KeysHeld::default()
        };
        assert_eq!(d.update(up, t).axes[0], AxisChange::Held(Percent::MAX));
    }

    #[test]
    fn steering_neutral_comes_from_the_channel_table() {
        // Steering 1250..1840 µs with neutral 1545: neutral is 50 %.
        let d = driver(10);
        assert_eq!(d.neutral, [pct(50); 3]);
        let mut table = ChannelTable::default();
        table.channels.steering.neutral_us = 1309; // 10 % of 590 µs above 1250
        let d = KeyboardDriver::new(&table, 10);
        assert_eq!(d.neutral[1], pct(10));
    }

    #[test]
    fn r_revives_once_after_a_full_second() {
        let t0 = Instant::now();
        let mut d = driver(20);
        let r = KeysHeld {
            revive: true,
            ..KeysHeld::default()
        };
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        assert!(!d.update(r, at(0)).revive);
        let half = d.update(r, at(500));
        assert!(!half.revive);
        assert!((half.revive_progress - 0.5).abs() < 1e-3);
        assert!(!d.update(r, at(999)).revive);
        assert!(d.update(r, at(1_000)).revive);
        assert!(!d.update(r, at(1_500)).revive, "once per press");
        // Released early: no revive, and the count starts again.
        assert!(!d.update(KeysHeld::default(), at(1_600)).revive);
        assert!(!d.update(r, at(1_700)).revive);
        assert!(!d.update(KeysHeld::default(), at(2_600)).revive);
        assert!(!d.update(r, at(2_700)).revive);
        assert!(d.update(r, at(3_700)).revive);
    }

    #[test]
    fn space_kills() {
        let mut d = driver(20);
        let k = KeysHeld {
            kill_pressed: true,
            throttle_up: true,
            ..KeysHeld::default()
        };
        assert!(d.update(k, Instant::now()).kill);
    }
}
