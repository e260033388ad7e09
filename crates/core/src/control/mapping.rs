//! From modes, percentages and controller fractions to pulse widths, per the channel table.

use dima_groundlink::Percent;

use super::Actuation;
use crate::config::{ChannelConfig, ChannelsConfig};
use crate::safety::{Mode, Setpoints};

/// Pulse widths for throttle, steering and tail, in microseconds; 0 means "no pulses".
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ServoTargets {
    /// Throttle, steering, tail.
    pub pulse_us: [u16; 3],
}

impl ServoTargets {
    /// In the Maestro's unit (quarter-microseconds).
    pub fn quarter_us(&self) -> [u16; 3] {
        self.pulse_us.map(|us| us.saturating_mul(4))
    }
}

/// The channel table in the form the loop uses.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputMap {
    channels: [ChannelConfig; 3],
}

impl OutputMap {
    /// From the configuration (validated: min < max, neutral and safe within).
    pub fn new(config: &ChannelsConfig) -> OutputMap {
        OutputMap {
            channels: [
                config.throttle.clone(),
                config.steering.clone(),
                config.tail.clone(),
            ],
        }
    }

    /// Maestro channel numbers, throttle, steering, tail.
    pub fn channel_numbers(&self) -> [u8; 3] {
        [
            self.channels[0].channel,
            self.channels[1].channel,
            self.channels[2].channel,
        ]
    }

    /// Manual mapping: `min + (max - min) * d / 100`, rounded to the nearest microsecond
    /// (the original's integer division made the tail on/off only). `None` is neutral.
    pub fn manual(ch: &ChannelConfig, percent: Option<Percent>) -> u16 {
        match percent {
            None => ch.neutral_us,
            Some(p) => {
                let span = u32::from(ch.max_us - ch.min_us);
                let offset = (span * u32::from(p.get()) + 50) / 100;
                ch.min_us + offset as u16
            }
        }
    }

    /// Controller mapping: `fraction` in -1..=1 around neutral (+1 = max, -1 = min).
    pub fn fraction(ch: &ChannelConfig, fraction: f32) -> u16 {
        let f = if fraction.is_finite() {
            fraction.clamp(-1.0, 1.0)
        } else {
            0.0
        };
        let neutral = f32::from(ch.neutral_us);
        let us = if f >= 0.0 {
            neutral + f * f32::from(ch.max_us - ch.neutral_us)
        } else {
            neutral + f * f32::from(ch.neutral_us - ch.min_us)
        };
        (us.round() as u16).clamp(ch.min_us, ch.max_us)
    }

    /// The configured safe outputs.
    pub fn safe(&self) -> ServoTargets {
        ServoTargets {
            pulse_us: self.channels.each_ref().map(|c| c.safe.pulse_us()),
        }
    }

    /// Outputs for a mode: safe values, manual percentages or the controller's action.
    pub fn outputs(&self, mode: Mode, setpoints: &Setpoints, action: &Actuation) -> ServoTargets {
        let [t, s, l] = &self.channels;
        match mode {
            Mode::Killed | Mode::Failsafe => self.safe(),
            Mode::Manual => ServoTargets {
                pulse_us: [
                    Self::manual(t, setpoints.throttle),
                    Self::manual(s, setpoints.steering),
                    Self::manual(l, setpoints.tail),
                ],
            },
            Mode::Auto => ServoTargets {
                pulse_us: [
                    Self::fraction(t, action.throttle),
                    Self::fraction(s, action.steering),
                    Self::fraction(l, action.tail),
                ],
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::SafeOutput;

    fn pct(v: u8) -> Option<Percent> {
        Percent::new(v)
    }

    #[test]
    fn manual_mapping_matches_the_documented_formulas() {
        let c = ChannelsConfig::default();
        for d in 0..=100u8 {
            let d32 = u32::from(d);
            // docs/wire-formats.md, "Servo controller: Pololu Maestro": throttle 1000 + 10 d,
            // steering 1250 + 590 d / 100, tail 1000 + 10 d.
            assert_eq!(OutputMap::manual(&c.throttle, pct(d)), 1000 + 10 * d as u16);
            let steering = 1250.0 + 590.0 * f64::from(d32) / 100.0;
            assert_eq!(
                OutputMap::manual(&c.steering, pct(d)),
                steering.round() as u16
            );
            assert_eq!(OutputMap::manual(&c.tail, pct(d)), 1000 + 10 * d as u16);
        }
        assert_eq!(OutputMap::manual(&c.steering, None), 1545);
    }

    #[test]
    fn fraction_mapping_is_asymmetric_around_neutral() {
        let c = ChannelsConfig::default();
        assert_eq!(OutputMap::fraction(&c.steering, 0.0), 1545);
        assert_eq!(OutputMap::fraction(&c.steering, 1.0), 1840);
        assert_eq!(OutputMap::fraction(&c.steering, -1.0), 1250);
        assert_eq!(OutputMap::fraction(&c.steering, 7.0), 1840);
        assert_eq!(OutputMap::fraction(&c.steering, f32::NAN), 1545);
        assert_eq!(OutputMap::fraction(&c.throttle, 0.5), 1750);
    }

    #[test]
    fn safe_outputs_by_mode() {
        let mut c = ChannelsConfig::default();
        c.tail.safe = SafeOutput::OFF;
        let map = OutputMap::new(&c);
        let sp = Setpoints {
            throttle: pct(100),
            ..Setpoints::default()
        };
        let act = Actuation {
            throttle: 1.0,
            ..Actuation::default()
        };
        for mode in [Mode::Killed, Mode::Failsafe] {
            assert_eq!(map.outputs(mode, &sp, &act).pulse_us, [1500, 1545, 0]);
        }
        assert_eq!(
            map.outputs(Mode::Manual, &sp, &act).pulse_us,
            [2000, 1545, 1500]
        );
        assert_eq!(
            map.outputs(Mode::Auto, &sp, &act).pulse_us,
            [2000, 1545, 1500]
        );
        assert_eq!(map.safe().quarter_us(), [6000, 6180, 0]);
    }
}
