//! The application's configuration: one TOML file, every setting with a documented default.
//!
//! [`DEFAULT_TOML`] is the commented default file printed by `dima config --print-default`; a test
//! pins that it parses back to [`Config::default`].

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// The whole configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Sensor-board link.
    pub sensor: SensorConfig,
    /// Pololu Maestro servo controller.
    pub maestro: MaestroConfig,
    /// XBee ground link.
    pub xbee: XbeeConfig,
    /// Realtime loop and thread settings.
    pub realtime: RealtimeConfig,
    /// Failsafe thresholds.
    pub safety: SafetyConfig,
    /// Output channels.
    pub channels: ChannelsConfig,
    /// AUTO-mode controllers.
    pub control: ControlConfig,
    /// MCAP log.
    pub log: LogConfig,
}

/// Sensor-board link: UART and request line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorConfig {
    /// Serial device of the sensor board.
    pub port: PathBuf,
    /// Baud rate (must match the board's firmware).
    pub baud: u32,
    /// Stop bits, 1 or 2 (the v1 link uses 2).
    pub stop_bits: u8,
    /// GPIO character device of the request line.
    pub request_chip: PathBuf,
    /// Line offset of the request line on `request_chip`.
    pub request_line: u32,
    /// Request at the end of cycle k and read the answer at the start of k+1 (hides the
    /// 3.15 ms transfer at 460800 baud behind the period; data is one period older).
    pub request_ahead: bool,
    /// Latest time after the request at which a packet still counts, in microseconds; later is
    /// a missing packet. Must fit in the period.
    pub packet_deadline_us: u32,
    /// Pause between attempts to reopen a missing device, in milliseconds.
    pub reopen_interval_ms: u32,
}

impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig {
            port: "/dev/ttyTHS1".into(),
            baud: 460_800,
            stop_bits: 2,
            request_chip: "/dev/gpiochip0".into(),
            request_line: 216,
            request_ahead: false,
            packet_deadline_us: 3_700,
            reopen_interval_ms: 1_000,
        }
    }
}

/// Pololu Maestro: USB serial command port.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MaestroConfig {
    /// Serial device of the Maestro's command port.
    pub port: PathBuf,
    /// Baud rate (ignored by the USB command port, used on a TTL UART).
    pub baud: u32,
    /// How often servo targets are written, in Hz (hobby ESCs want 50 Hz pulses; the Maestro
    /// repeats the last target by itself). Safe outputs are written in the next cycle whatever
    /// this rate.
    pub servo_refresh_hz: u32,
    /// Pause between attempts to reopen a missing device, in milliseconds.
    pub reopen_interval_ms: u32,
}

impl Default for MaestroConfig {
    fn default() -> Self {
        MaestroConfig {
            port: "/dev/ttyACM0".into(),
            baud: 115_200,
            servo_refresh_hz: 50,
            reopen_interval_ms: 1_000,
        }
    }
}

/// XBee radio in transparent mode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct XbeeConfig {
    /// Serial device of the XBee.
    pub port: PathBuf,
    /// Baud rate (the XBee's `BD` setting).
    pub baud: u32,
    /// Display frames sent per second.
    pub display_rate_hz: f64,
    /// Pause between attempts to reopen a missing device, in milliseconds.
    pub reopen_interval_ms: u32,
}

impl Default for XbeeConfig {
    fn default() -> Self {
        XbeeConfig {
            port: "/dev/ttyUSB0".into(),
            baud: 9_600,
            display_rate_hz: 2.0,
            reopen_interval_ms: 1_000,
        }
    }
}

/// The realtime thread and its neighbours.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RealtimeConfig {
    /// Control-loop rate, in Hz.
    pub loop_rate_hz: u32,
    /// SCHED_FIFO priority of the loop (1-99); 0 keeps SCHED_OTHER.
    pub priority: u8,
    /// SCHED_FIFO priority of the telemetry thread (below the loop); 0 keeps SCHED_OTHER.
    pub telemetry_priority: u8,
    /// CPUs the loop is pinned to (e.g. the one isolated with `isolcpus`); empty: not pinned.
    pub cpus: Vec<usize>,
    /// `mlockall(MCL_CURRENT | MCL_FUTURE)` before the loop starts.
    pub lock_memory: bool,
    /// Stack prefaulted by the loop thread before its first cycle, in KiB.
    pub prefault_stack_kib: usize,
    /// Hold `/dev/cpu_dma_latency` at 0 while running (keeps CPUs out of deep idle states).
    pub cpu_dma_latency: bool,
    /// Records the logger ring holds (drop and count when full).
    pub log_ring_records: usize,
    /// Command events the telemetry -> loop ring holds.
    pub command_ring: usize,
}

impl Default for RealtimeConfig {
    fn default() -> Self {
        RealtimeConfig {
            loop_rate_hz: 250,
            priority: 80,
            telemetry_priority: 40,
            cpus: vec![3],
            lock_memory: true,
            prefault_stack_kib: 256,
            cpu_dma_latency: true,
            log_ring_records: 4_096,
            command_ring: 256,
        }
    }
}

/// Failsafe thresholds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SafetyConfig {
    /// No valid command frame for this long trips FAILSAFE, in milliseconds.
    pub comms_timeout_ms: u32,
    /// This many consecutive missing or bad sensor packets trip FAILSAFE.
    pub sensor_loss_packets: u32,
    /// This many consecutive overrun periods trip FAILSAFE.
    pub overrun_limit: u32,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        SafetyConfig {
            comms_timeout_ms: 1_000,
            sensor_loss_packets: 25,
            overrun_limit: 10,
        }
    }
}

/// What a channel outputs when the robot is KILLED or in FAILSAFE.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SafeOutput {
    /// A pulse width, in microseconds.
    PulseUs(u16),
    /// `"off"`: no pulses (Maestro target 0).
    Off(OffKeyword),
}

/// The keyword `"off"` in the configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OffKeyword {
    /// No pulses.
    Off,
}

impl SafeOutput {
    /// No pulses.
    pub const OFF: SafeOutput = SafeOutput::Off(OffKeyword::Off);

    /// The pulse width in microseconds, 0 for "off" (the Maestro's "stop pulses" target).
    pub fn pulse_us(self) -> u16 {
        match self {
            SafeOutput::PulseUs(us) => us,
            SafeOutput::Off(_) => 0,
        }
    }
}

/// One output channel on the Maestro.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelConfig {
    /// Maestro channel number.
    pub channel: u8,
    /// Pulse width at 0 %, in microseconds.
    pub min_us: u16,
    /// Pulse width at 100 %, in microseconds.
    pub max_us: u16,
    /// Neutral (stopped / centred) pulse width, in microseconds.
    pub neutral_us: u16,
    /// Output when KILLED or in FAILSAFE.
    pub safe: SafeOutput,
}

/// The three outputs of the DIMA car.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChannelsConfig {
    /// Throttle ESC.
    pub throttle: ChannelConfig,
    /// Steering servo.
    pub steering: ChannelConfig,
    /// Active tail servo.
    pub tail: ChannelConfig,
}

impl Default for ChannelsConfig {
    fn default() -> Self {
        ChannelsConfig {
            throttle: ChannelConfig {
                channel: 0,
                min_us: 1000,
                max_us: 2000,
                neutral_us: 1500,
                safe: SafeOutput::PulseUs(1500),
            },
            steering: ChannelConfig {
                channel: 1,
                min_us: 1250,
                max_us: 1840,
                neutral_us: 1545,
                safe: SafeOutput::PulseUs(1545),
            },
            tail: ChannelConfig {
                channel: 2,
                min_us: 1000,
                max_us: 2000,
                neutral_us: 1500,
                safe: SafeOutput::PulseUs(1500),
            },
        }
    }
}

impl ChannelsConfig {
    /// The channels in output order: throttle, steering, tail.
    pub fn all(&self) -> [&ChannelConfig; 3] {
        [&self.throttle, &self.steering, &self.tail]
    }
}

/// PID gains and limits. Output is a fraction of the channel's travel, -1..=1 around neutral.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PidConfig {
    /// Proportional gain, output per unit of error.
    pub kp: f32,
    /// Integral gain, output per unit of error-second.
    pub ki: f32,
    /// Derivative gain (on the measurement), output per unit of measurement rate.
    pub kd: f32,
    /// Output limit, fraction of travel (0..=1).
    pub output_limit: f32,
    /// Largest output change, fraction of travel per second.
    pub rate_limit_per_s: f32,
}

/// AUTO-mode controllers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ControlConfig {
    /// Speed controller: error in m/s -> throttle.
    pub speed: PidConfig,
    /// Heading controller: error in degrees -> steering.
    pub heading: PidConfig,
    /// Sign from gyro Z to heading rate (clockwise positive): -1 when the board's Z axis
    /// points up.
    pub gyro_yaw_sign: f32,
    /// Below this ground speed the GNSS heading of motion is not trusted, in mm/s.
    pub min_heading_speed_mm_s: i32,
}

impl Default for ControlConfig {
    fn default() -> Self {
        ControlConfig {
            speed: PidConfig {
                kp: 0.15,
                ki: 0.10,
                kd: 0.0,
                output_limit: 0.5,
                rate_limit_per_s: 2.0,
            },
            heading: PidConfig {
                kp: 0.02,
                ki: 0.0,
                kd: 0.002,
                output_limit: 1.0,
                rate_limit_per_s: 8.0,
            },
            gyro_yaw_sign: -1.0,
            min_heading_speed_mm_s: 500,
        }
    }
}

/// MCAP log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LogConfig {
    /// Write a log at all.
    pub enabled: bool,
    /// Directory for `dima-YYYYMMDDTHHMMSSZ.mcap` files (created if missing).
    pub directory: PathBuf,
    /// Longest time between chunk flushes, in milliseconds (what a crash can lose).
    pub flush_interval_ms: u32,
    /// Decoded values are logged every n-th cycle (raw packets and timings every cycle).
    pub decoded_every: u32,
}

impl Default for LogConfig {
    fn default() -> Self {
        LogConfig {
            enabled: true,
            directory: "/var/log/dima".into(),
            flush_interval_ms: 1_000,
            decoded_every: 1,
        }
    }
}

/// The commented default configuration file.
pub const DEFAULT_TOML: &str = include_str!("default-config.toml");

/// A configuration problem a user can fix.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read config file {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file is not valid TOML for this configuration.
    #[error("config file {path}: {source}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where and why.
        source: toml::de::Error,
    },
    /// A value is out of range.
    #[error("config: {0}")]
    Invalid(String),
}

impl Config {
    /// Reads and validates a configuration file.
    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_owned(),
            source,
        })?;
        let config: Config = toml::from_str(&text).map_err(|source| ConfigError::Parse {
            path: path.to_owned(),
            source,
        })?;
        config.validate()?;
        Ok(config)
    }

    /// Loop period in nanoseconds.
    pub fn period_ns(&self) -> u64 {
        1_000_000_000 / u64::from(self.realtime.loop_rate_hz.max(1))
    }

    /// Checks cross-field rules that TOML types cannot express.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let bad = |m: String| Err(ConfigError::Invalid(m));
        let rt = &self.realtime;
        if !(1..=10_000).contains(&rt.loop_rate_hz) {
            return bad(format!(
                "realtime.loop_rate_hz = {} (expected 1..=10000)",
                rt.loop_rate_hz
            ));
        }
        if rt.priority > 99 || rt.telemetry_priority > 99 {
            return bad("realtime priorities must be 0..=99".into());
        }
        if rt.priority != 0 && rt.telemetry_priority >= rt.priority {
            return bad("realtime.telemetry_priority must be below realtime.priority".into());
        }
        if rt.log_ring_records == 0 || rt.command_ring == 0 {
            return bad("realtime ring sizes must be at least 1".into());
        }
        let period_us = self.period_ns() / 1_000;
        if u64::from(self.sensor.packet_deadline_us) >= period_us {
            return bad(format!(
                "sensor.packet_deadline_us = {} must be below the period ({period_us} µs)",
                self.sensor.packet_deadline_us
            ));
        }
        if !(1..=2).contains(&self.sensor.stop_bits) {
            return bad("sensor.stop_bits must be 1 or 2".into());
        }
        let m = &self.maestro;
        if m.servo_refresh_hz == 0 || m.servo_refresh_hz > rt.loop_rate_hz {
            return bad("maestro.servo_refresh_hz must be 1..=realtime.loop_rate_hz".into());
        }
        if !(self.xbee.display_rate_hz > 0.0 && self.xbee.display_rate_hz <= 100.0) {
            return bad("xbee.display_rate_hz must be in (0, 100]".into());
        }
        for (name, ch) in [
            ("throttle", &self.channels.throttle),
            ("steering", &self.channels.steering),
            ("tail", &self.channels.tail),
        ] {
            if !(ch.min_us < ch.max_us && (ch.min_us..=ch.max_us).contains(&ch.neutral_us)) {
                return bad(format!(
                    "channels.{name}: need min_us < max_us and neutral_us within them"
                ));
            }
            if ch.max_us > 4_000 || ch.channel > 23 {
                return bad(format!(
                    "channels.{name}: channel 0..=23, pulses up to 4000 µs"
                ));
            }
            if let SafeOutput::PulseUs(us) = ch.safe {
                if !(ch.min_us..=ch.max_us).contains(&us) {
                    return bad(format!("channels.{name}.safe = {us} is outside min..max"));
                }
            }
        }
        let c = &self.channels;
        if c.throttle.channel == c.steering.channel
            || c.throttle.channel == c.tail.channel
            || c.steering.channel == c.tail.channel
        {
            return bad("channels: throttle, steering and tail need distinct channels".into());
        }
        if self.safety.sensor_loss_packets == 0 || self.safety.overrun_limit == 0 {
            return bad("safety thresholds must be at least 1".into());
        }
        if self.log.decoded_every == 0 {
            return bad("log.decoded_every must be at least 1".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_file_parses_back_to_the_defaults() {
        let parsed: Config = toml::from_str(DEFAULT_TOML).expect("default file parses");
        assert_eq!(parsed, Config::default());
        parsed.validate().expect("defaults are valid");
    }

    #[test]
    fn default_file_mentions_every_setting() {
        // Every key the serialiser writes must appear in the commented file.
        let serialised = toml::to_string(&Config::default()).unwrap();
        for line in serialised.lines() {
            if let Some((key, _)) = line.split_once(" = ") {
                let found = DEFAULT_TOML
                    .lines()
                    .any(|l| l.trim_start().starts_with(&format!("{key} =")));
                assert!(found, "default-config.toml lacks {key}");
            }
        }
    }

    #[test]
    fn empty_file_is_the_defaults() {
        assert_eq!(toml::from_str::<Config>("").unwrap(), Config::default());
    }

    #[test]
    fn safe_output_off_or_pulse() {
        let c: Config = toml::from_str(
            "[channels.tail]\nchannel = 2\nmin_us = 1000\nmax_us = 2000\nneutral_us = 1500\nsafe = \"off\"\n",
        )
        .unwrap();
        assert_eq!(c.channels.tail.safe, SafeOutput::OFF);
        assert_eq!(c.channels.tail.safe.pulse_us(), 0);
        assert_eq!(c.channels.throttle.safe.pulse_us(), 1500);
    }

    #[test]
    fn unknown_keys_are_errors() {
        assert!(toml::from_str::<Config>("[sensor]\nbaudrate = 9600\n").is_err());
    }

    #[test]
    fn validation_rejects_bad_values() {
        let mut c = Config::default();
        c.sensor.packet_deadline_us = 5_000;
        assert!(c.validate().is_err());
        let mut c = Config::default();
        c.channels.tail.channel = 0;
        assert!(c.validate().is_err());
        let mut c = Config::default();
        c.realtime.telemetry_priority = 90;
        assert!(c.validate().is_err());
        let mut c = Config::default();
        c.channels.steering.safe = SafeOutput::PulseUs(900);
        assert!(c.validate().is_err());
    }
}
