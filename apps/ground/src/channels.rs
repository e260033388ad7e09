//! The robot's channel table as the station needs it: the pulse width a manual percentage
//! becomes on the robot, and each channel's neutral as a percentage.
//!
//! The mapping is the robot's own ([`OutputMap::manual`] in `dima-core`), read from the same
//! TOML file the robot runs with (`--robot-config`), so what the station shows is what the
//! Maestro gets.

use std::path::Path;

use dima_core::config::{ChannelConfig, ChannelsConfig, Config};
use dima_core::control::mapping::OutputMap;
use dima_groundlink::station::ManualChannel;
use dima_groundlink::Percent;

/// The channel table (limits, neutral and safe pulse widths per channel), with the AUTO speed
/// limit from the same configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelTable {
    /// Throttle, steering and tail as the robot's configuration has them.
    pub channels: ChannelsConfig,
    /// The fastest speed setpoint the robot accepts, mm/s (`control.max_speed_mm_s`; AUTO is
    /// forward-only, so 0 is the slowest).
    pub max_speed_mm_s: i32,
}

impl Default for ChannelTable {
    fn default() -> Self {
        ChannelTable {
            channels: ChannelsConfig::default(),
            max_speed_mm_s: dima_core::config::ControlConfig::default().max_speed_mm_s,
        }
    }
}

impl ChannelTable {
    /// The table of a robot configuration file (`dima`'s TOML), validated as the robot does.
    pub fn from_robot_config(path: &Path) -> anyhow::Result<ChannelTable> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            anyhow::anyhow!(
                "cannot read the robot configuration {}: {e} (the TOML file `dima run --config` uses)",
                path.display()
            )
        })?;
        let config = Config::from_toml(&text, &path.display().to_string())?;
        Ok(ChannelTable {
            channels: config.channels,
            max_speed_mm_s: config.control.max_speed_mm_s,
        })
    }

    /// The configuration of `channel`.
    pub fn channel(&self, channel: ManualChannel) -> &ChannelConfig {
        match channel {
            ManualChannel::Throttle => &self.channels.throttle,
            ManualChannel::Steering => &self.channels.steering,
            ManualChannel::Tail => &self.channels.tail,
        }
    }

    /// The pulse width, µs, the robot drives for `percent` on `channel` in MANUAL.
    pub fn pulse_us(&self, channel: ManualChannel, percent: Percent) -> u16 {
        OutputMap::manual(self.channel(channel), Some(percent))
    }

    /// The percentage nearest to the channel's neutral pulse width.
    pub fn neutral_percent(&self, channel: ManualChannel) -> Percent {
        let c = self.channel(channel);
        let span = u32::from(c.max_us.saturating_sub(c.min_us)).max(1);
        let above = u32::from(c.neutral_us.saturating_sub(c.min_us));
        let p = ((above * 100 + span / 2) / span).min(100) as u8;
        Percent::new(p).unwrap_or(Percent::HALF)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    #[test]
    fn defaults_match_the_documented_mapping() {
        // docs/wire-formats.md, "Servo controller: Pololu Maestro": throttle 1000 + 10 d,
        // steering 1250 + 590 d / 100, tail 1000 + 10 d.
        let t = ChannelTable::default();
        assert_eq!(t.pulse_us(ManualChannel::Throttle, pct(75)), 1750);
        assert_eq!(t.pulse_us(ManualChannel::Steering, pct(50)), 1545);
        assert_eq!(t.pulse_us(ManualChannel::Steering, pct(100)), 1840);
        assert_eq!(t.pulse_us(ManualChannel::Tail, pct(1)), 1010);
        for c in ManualChannel::ALL {
            assert_eq!(t.neutral_percent(c), pct(50));
        }
    }

    #[test]
    fn a_robot_config_file_sets_the_table() {
        let dir = std::env::temp_dir().join(format!("dima-ground-channels-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("robot.toml");
        std::fs::write(
            &path,
            "[channels.throttle]\nchannel = 0\nmin_us = 1100\nmax_us = 1900\nneutral_us = 1300\nsafe = 1300\n",
        )
        .unwrap();
        let t = ChannelTable::from_robot_config(&path).unwrap();
        assert_eq!(t.pulse_us(ManualChannel::Throttle, pct(50)), 1500);
        assert_eq!(t.max_speed_mm_s, ChannelTable::default().max_speed_mm_s);
        assert_eq!(t.neutral_percent(ManualChannel::Throttle), pct(25));
        std::fs::write(&path, "[channels.throttle]\nmin_us = 2100\n").unwrap();
        let e = ChannelTable::from_robot_config(&path).unwrap_err();
        assert!(e.to_string().contains("robot.toml"), "{e}");
        assert!(ChannelTable::from_robot_config(&dir.join("missing.toml")).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
