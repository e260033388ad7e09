//! The application's configuration: one TOML file, every setting with a documented default.
//!
//! [`DEFAULT_TOML`] is the commented default file printed by `dima config --print-default`; a test
//! pins that it parses back to [`Config::default`].

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::control::registry::kind_names;
use crate::control::{Channel, ControllerSet, ParamError};

/// The whole configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Sensor-board link.
    pub sensor: SensorConfig,
    /// Which board drives the servos.
    pub servo: ServoConfig,
    /// Pololu Maestro servo controller (`servo.kind = "maestro"`).
    pub maestro: MaestroConfig,
    /// PCA9685 PWM board on I2C (`servo.kind = "pca9685"`).
    pub pca9685: Pca9685Config,
    /// XBee ground link.
    pub xbee: XbeeConfig,
    /// Realtime loop and thread settings.
    pub realtime: RealtimeConfig,
    /// Failsafe thresholds.
    pub safety: SafetyConfig,
    /// Output channels.
    pub channels: ChannelsConfig,
    /// AUTO-mode controllers, one per channel.
    pub control: ControlConfig,
    /// The state estimate the controllers read.
    pub estimator: EstimatorConfig,
    /// Navigation: the protections that judge where the car is and how it lies (rollover,
    /// geofence), and the waypoint mission AUTO follows.
    pub navigation: NavigationConfig,
    /// MCAP log.
    pub log: LogConfig,
    /// Live view of the log's channels over the Foxglove WebSocket protocol.
    pub foxglove: FoxgloveConfig,
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
    /// a `late` packet, treated as missing. With the servo write budget it must fit in the
    /// period.
    pub packet_deadline_us: u32,
    /// A packet that completes sooner after its request than its time on the wire (132 bytes
    /// at `baud` with `stop_bits`) less this tolerance cannot be the answer to it: it is counted
    /// `stale` and treated as missing. In microseconds.
    pub wire_tolerance_us: u32,
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
            wire_tolerance_us: 100,
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
    /// Time the loop allows for writing the servo targets, in microseconds; the packet
    /// deadline plus this budget must fit in the period.
    pub write_budget_us: u32,
    /// Pause between attempts to reopen a missing device, in milliseconds.
    pub reopen_interval_ms: u32,
}

impl Default for MaestroConfig {
    fn default() -> Self {
        MaestroConfig {
            port: "/dev/ttyACM0".into(),
            baud: 115_200,
            servo_refresh_hz: 50,
            write_budget_us: 300,
            reopen_interval_ms: 1_000,
        }
    }
}

/// The servo outputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct ServoConfig {
    /// The board: `maestro` (USB serial) or `pca9685` (I2C).
    pub kind: ServoKind,
}

/// A servo board.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum ServoKind {
    /// Pololu Maestro on its USB command port (`[maestro]`).
    #[default]
    Maestro,
    /// NXP PCA9685 16-channel PWM board on an I2C bus (`[pca9685]`).
    Pca9685,
}

/// PCA9685 PWM board on the Jetson's I2C bus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Pca9685Config {
    /// I2C bus device.
    pub device: PathBuf,
    /// 7-bit I2C address (0x40 with no address jumper set).
    pub address: u8,
    /// PWM frequency, Hz (24..=1526, the chip's range with its 25 MHz oscillator); the servo
    /// refresh rate. Every channel's `max_us` must fit in its period.
    pub pwm_frequency_hz: u32,
    /// Oscillator frequency, Hz (25 MHz internal; trim it to a measured value for accurate
    /// pulse widths).
    pub oscillator_hz: u32,
    /// Time the loop allows for writing the servo targets, in microseconds (three register
    /// writes on the bus); the packet deadline plus this budget must fit in the period.
    pub write_budget_us: u32,
    /// Pause between attempts to reopen a missing device, in milliseconds.
    pub reopen_interval_ms: u32,
}

impl Default for Pca9685Config {
    fn default() -> Self {
        Pca9685Config {
            device: "/dev/i2c-1".into(),
            address: 0x40,
            pwm_frequency_hz: 50,
            oscillator_hz: 25_000_000,
            write_budget_us: 250,
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
    /// Display frames sent per second, 1..=100: they carry the acknowledgements the ground
    /// station waits for (2.5 s before it gives a command up), so fewer than one a second would
    /// leave it no room for a lost frame.
    pub display_rate_hz: f64,
    /// Pause between attempts to reopen a missing device, in milliseconds.
    pub reopen_interval_ms: u32,
    /// Accept only authenticated ground link v2 commands; v1 frames are ignored and counted.
    /// `false` lets the unauthenticated v1 ground station drive the robot (and v2 commands
    /// too when `key_file` is set).
    pub require_auth: bool,
    /// File holding the pre-shared ground-link key (one line of 32 hex characters, mode 0600;
    /// `dima keygen PATH` writes one). Needed when `require_auth` is true.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub key_file: Option<PathBuf>,
}

impl Default for XbeeConfig {
    fn default() -> Self {
        XbeeConfig {
            port: "/dev/ttyUSB0".into(),
            baud: 9_600,
            display_rate_hz: 2.0,
            reopen_interval_ms: 1_000,
            require_auth: true,
            key_file: None,
        }
    }
}

impl XbeeConfig {
    /// The ground-link key file to load, `None` when the robot runs without one (v1 only).
    /// `require_auth = true` without a key file is an error that says how to fix it.
    pub fn key_file_needed(&self) -> Result<Option<&std::path::Path>, ConfigError> {
        match (&self.key_file, self.require_auth) {
            (Some(path), _) => Ok(Some(path)),
            (None, false) => Ok(None),
            (None, true) => Err(invalid(
                "xbee.key_file",
                "(not set)",
                "required by xbee.require_auth = true: create a key with \
                 `dima keygen /etc/dima/link.key`, set key_file = \"/etc/dima/link.key\" in [xbee] \
                 and give the same key to the ground station (or set require_auth = false to let \
                 the unauthenticated v1 ground station drive the robot)",
            )),
        }
    }
}

/// The realtime thread and its neighbours.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RealtimeConfig {
    /// Control-loop rate, in Hz, 10..=10000: the failsafes that count packets and periods
    /// must trip within a second, which they cannot below 10 Hz.
    pub loop_rate_hz: u32,
    /// The realtime setup (SCHED_FIFO at `priority`, pinning to `cpus`, `mlockall`) must
    /// succeed: if any part fails the robot stays KILLED, says why, and refuses every revive.
    /// `dima sim` sets it to false unless given `--realtime`.
    pub required: bool,
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
            required: true,
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
    /// This many consecutive missing or bad sensor packets trip FAILSAFE: 1..=250, and at most
    /// a second of packets at `realtime.loop_rate_hz`.
    pub sensor_loss_packets: u32,
    /// More than this many late wake-ups (each one that missed one or more periods, however
    /// many) within any sliding second trip FAILSAFE: 1..=250, and at most one in ten periods
    /// (`realtime.loop_rate_hz / 10`), so that sustained overload trips within a second.
    pub overrun_limit: u32,
    /// Periods missed within any sliding second adding up to more than this, in one stall or
    /// several, trip FAILSAFE (`Overrun`), in milliseconds (measured in whole missed periods).
    /// 10..=400 and at least two periods: one missed period is an ordinary late wake-up, for
    /// `overrun_limit`; and stalls just shorter than this, back to back, must add up past it
    /// within a second.
    pub max_stall_ms: u32,
    /// In AUTO, no fresh GNSS fix (valid, with an advancing iTOW) for this long trips
    /// FAILSAFE; heading may be carried on the gyro alone only this long. In milliseconds.
    pub gnss_timeout_ms: u32,
    /// This many consecutive packets with identical accelerometer words, or with identical
    /// gyroscope words (each die judged on its own), are a stuck IMU: FAILSAFE, and revives are refused while it lasts. 2..=10000, and at most a
    /// second of packets at `realtime.loop_rate_hz`.
    pub imu_stuck_packets: u32,
    /// A revive needs this many good sensor packets since the link was last lost
    /// (`sensor_loss_packets` bad ones in a row) or since start-up.
    pub revive_good_packets: u32,
    /// A revive sooner than this after the previous kill or revive is refused (`TooSoon`):
    /// kill/revive toggling is rate-limited, a kill never is. In milliseconds.
    pub revive_min_interval_ms: u32,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        SafetyConfig {
            comms_timeout_ms: 1_000,
            sensor_loss_packets: 25,
            overrun_limit: 10,
            max_stall_ms: 250,
            gnss_timeout_ms: 500,
            imu_stuck_packets: 50,
            revive_good_packets: 25,
            revive_min_interval_ms: 250,
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
    /// Output channel on the servo board (Maestro 0..=23, PCA9685 0..=15).
    pub channel: u8,
    /// Pulse width at 0 %, in microseconds.
    pub min_us: u16,
    /// Pulse width at 100 %, in microseconds.
    pub max_us: u16,
    /// Neutral (stopped / centred) pulse width, in microseconds.
    pub neutral_us: u16,
    /// Output when KILLED or in FAILSAFE.
    pub safe: SafeOutput,
    /// `safe = "off"` (no pulses) is accepted only with this set: an ESC or servo without
    /// pulses holds whatever it last did, so "off" is never the default for the throttle.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub allow_off: bool,
    /// A throttle `safe` pulse other than `neutral_us` is accepted only with this set: the
    /// ESC runs the motor at whatever the safe pulse says, so FAILSAFE and KILLED would drive
    /// the car. Steering and tail hold a position, not a speed; it changes nothing there.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub allow_safe_not_neutral: bool,
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
                allow_off: false,
                allow_safe_not_neutral: false,
            },
            steering: ChannelConfig {
                channel: 1,
                min_us: 1250,
                max_us: 1840,
                neutral_us: 1545,
                safe: SafeOutput::PulseUs(1545),
                allow_off: false,
                allow_safe_not_neutral: false,
            },
            tail: ChannelConfig {
                channel: 2,
                min_us: 1000,
                max_us: 2000,
                neutral_us: 1500,
                safe: SafeOutput::PulseUs(1500),
                allow_off: false,
                allow_safe_not_neutral: false,
            },
        }
    }
}

impl ChannelsConfig {
    /// The channels in output order: throttle, steering, tail.
    pub fn all(&self) -> [&ChannelConfig; 3] {
        [&self.throttle, &self.steering, &self.tail]
    }

    /// The channels with their names, in output order.
    pub fn named(&self) -> [(&'static str, &ChannelConfig); 3] {
        [
            ("throttle", &self.throttle),
            ("steering", &self.steering),
            ("tail", &self.tail),
        ]
    }
}

/// PID gains and limits (the parameters of `speed_pid` and `heading_pid`). Output is a fraction
/// of the channel's travel, -1..=1 around neutral.
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

impl PidConfig {
    /// The default parameters of `speed_pid` (throttle per m/s of speed error).
    pub const SPEED_PID: PidConfig = PidConfig {
        kp: 0.15,
        ki: 0.10,
        kd: 0.0,
        output_limit: 0.5,
        rate_limit_per_s: 2.0,
    };

    /// The default parameters of `heading_pid` (steering per degree of heading error).
    pub const HEADING_PID: PidConfig = PidConfig {
        kp: 0.02,
        ki: 0.0,
        kd: 0.002,
        output_limit: 1.0,
        rate_limit_per_s: 8.0,
    };

    /// Checks gains (finite, >= 0) and limits; the error names the parameter.
    pub fn check(&self) -> Result<(), ParamError> {
        for (field, gain) in [("kp", self.kp), ("ki", self.ki), ("kd", self.kd)] {
            if !(gain.is_finite() && gain >= 0.0) {
                return Err(ParamError::invalid(
                    field,
                    gain,
                    "expected a finite gain >= 0",
                ));
            }
        }
        if !(0.0..=1.0).contains(&self.output_limit) {
            return Err(ParamError::invalid(
                "output_limit",
                self.output_limit,
                "expected 0..=1 (a fraction of the channel's travel)",
            ));
        }
        if !(self.rate_limit_per_s.is_finite() && self.rate_limit_per_s > 0.0) {
            return Err(ParamError::invalid(
                "rate_limit_per_s",
                self.rate_limit_per_s,
                "expected a finite rate > 0",
            ));
        }
        Ok(())
    }
}

/// One channel's AUTO-mode controller: `kind` names it (see `dima_core::control::KINDS`), the
/// other keys of the section are its parameters. Read from a file, the parameters the section
/// leaves out are filled in from the kind's defaults, so `dima config --check` prints them all.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "ControllerSection")]
pub struct ControllerConfig {
    /// The controller, e.g. `speed_pid`, `heading_pid`, `yaw_rate` or `none`.
    pub kind: String,
    /// Its parameters.
    #[serde(flatten)]
    pub params: toml::Table,
}

/// A `[control.*]` section as written in the file.
#[derive(Deserialize)]
struct ControllerSection {
    kind: String,
    #[serde(flatten)]
    params: toml::Table,
}

impl From<ControllerSection> for ControllerConfig {
    fn from(section: ControllerSection) -> ControllerConfig {
        // An unknown kind keeps its parameters as given; validation names it.
        let params = match crate::control::registry::kind(&section.kind) {
            Ok(kind) => crate::control::registry::with_defaults(kind, &section.params),
            Err(_) => section.params,
        };
        ControllerConfig {
            kind: section.kind,
            params,
        }
    }
}

impl ControllerConfig {
    /// A controller without parameters (`none`).
    pub fn none() -> ControllerConfig {
        ControllerConfig {
            kind: "none".into(),
            params: toml::Table::new(),
        }
    }

    /// A PID-based controller of `kind`.
    pub fn pid(kind: &str, pid: PidConfig) -> ControllerConfig {
        ControllerConfig {
            kind: kind.into(),
            params: crate::control::registry::params_table(&pid),
        }
    }
}

/// AUTO mode: the controller of each channel and the limits on setpoints and fixes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ControlConfig {
    /// Largest speed setpoint accepted, in mm/s; setpoints below 0 (AUTO is forward-only) or
    /// above this are rejected, counted and change nothing.
    pub max_speed_mm_s: i32,
    /// A GNSS fix is used only while its speed accuracy estimate (`sAcc`, the receiver's
    /// estimate of its speed error) is at most this, in mm/s, 1..=2000: beyond 2 m/s the speed
    /// and heading of motion are noise at the car's speeds.
    pub max_speed_accuracy_mm_s: u32,
    /// Throttle controller.
    pub throttle: ControllerConfig,
    /// Steering controller.
    pub steering: ControllerConfig,
    /// Tail controller.
    pub tail: ControllerConfig,
}

impl ControlConfig {
    /// The parameters of the channel named `name`, without `kind`.
    fn channel_table(&self, name: &str) -> toml::Table {
        Channel::ALL
            .into_iter()
            .find(|c| c.name() == name)
            .map(|c| self.channel(c).params.clone())
            .unwrap_or_default()
    }

    /// The controller of `channel`.
    pub fn channel(&self, channel: Channel) -> &ControllerConfig {
        match channel {
            Channel::Throttle => &self.throttle,
            Channel::Steering => &self.steering,
            Channel::Tail => &self.tail,
        }
    }
}

impl Default for ControlConfig {
    fn default() -> Self {
        ControlConfig {
            max_speed_mm_s: 5_000,
            max_speed_accuracy_mm_s: 1_000,
            throttle: ControllerConfig::pid("speed_pid", PidConfig::SPEED_PID),
            steering: ControllerConfig::pid("heading_pid", PidConfig::HEADING_PID),
            tail: ControllerConfig::none(),
        }
    }
}

/// The state estimate (see `dima_core::estimate`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EstimatorConfig {
    /// Sign from gyro Z to heading rate (clockwise positive): -1 when the board's Z axis
    /// points up. The accelerometer's X axis points forward and Y to the left.
    pub gyro_yaw_sign: f32,
    /// Below this ground speed the GNSS heading of motion is not trusted, in mm/s,
    /// 200..=20000: the heading of motion is the direction of the velocity, and below
    /// 200 mm/s a receiver's speed error of a few hundred mm/s makes it noise.
    pub min_heading_speed_mm_s: i32,
    /// Time constant of the complementary filter pulling the gyro heading towards the GNSS
    /// heading of motion, in seconds; 0 takes each GNSS heading as it is.
    pub heading_tau_s: f32,
    /// Time constant with which the gyro and forward-accelerometer biases are learnt while
    /// standing still, in seconds; 0 learns none.
    pub gyro_bias_tau_s: f32,
    /// Standing still: GNSS ground speed below this (mm/s)...
    pub still_speed_mm_s: i32,
    /// ...and a yaw rate below this (°/s).
    pub still_rate_dps: f32,
    /// Bridge the ground speed between GNSS fixes with the forward acceleration (false: the
    /// last fix's speed until the next).
    pub accel_bridging: bool,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        EstimatorConfig {
            gyro_yaw_sign: -1.0,
            min_heading_speed_mm_s: 500,
            heading_tau_s: 0.5,
            gyro_bias_tau_s: 1.0,
            still_speed_mm_s: 100,
            still_rate_dps: 5.0,
            accel_bridging: true,
        }
    }
}

/// `[navigation]`: the protections that judge where the car is and how it lies, and the
/// waypoint mission (see `dima_core::mission`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NavigationConfig {
    /// The accelerometer's reading tilted from the car's up axis by more than this, in
    /// degrees (20..=90), is a car on its side or roof (`Rollover`). The up axis is the board's
    /// Z axis, its sign from `estimator.gyro_yaw_sign` (-1: Z points up).
    pub rollover_tilt_deg: f32,
    /// ...for at least this long, in milliseconds (100..=1000): a bump or a hard corner tilts
    /// the reading for a few packets only.
    pub rollover_ms: u32,
    /// The geofence (`[navigation.fence]`); none by default.
    pub fence: FenceConfig,
    /// QGroundControl plan file (`.plan`) the robot reads at start-up; a file that cannot be
    /// read or followed refuses the start. Empty: no mission (AUTO holds the operator's
    /// setpoints).
    pub mission_file: PathBuf,
    /// Ground speed where the plan sets none (`DO_CHANGE_SPEED`), m/s, 0.1..=20.
    pub mission_speed_m_s: f64,
    /// Acceptance radius where a waypoint sets none, m, 0.1..=50.
    pub mission_acceptance_m: f64,
    /// Shortest lookahead distance of the path follower, m, 0.5..=50 (the lookahead is 1 s
    /// of travel, at least this).
    pub mission_lookahead_m: f64,
    /// Lateral acceleration allowed in a corner, m/s², 0.5..=20.
    pub mission_lateral_accel_m_s2: f64,
    /// Deceleration allowed before a corner or the last waypoint, m/s², 0.2..=10.
    pub mission_decel_m_s2: f64,
}

/// `[navigation.fence]`: where the car may drive. Leaving it in MANUAL or AUTO trips FAILSAFE
/// (`Geofence`) on the first fix outside; a revive outside it is refused (`OutsideFence`). With
/// nothing configured there is no fence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct FenceConfig {
    /// Largest distance from the point where the robot was last revived, m (1..=100000);
    /// absent: no limit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_distance_m: Option<f64>,
    /// Inclusion circles (at most 16). When any circle or polygon is given, the car must be
    /// inside at least one of them.
    pub circles: Vec<FenceCircle>,
    /// Inclusion polygons (at most 16), each `[[lat_deg, lon_deg], ...]`: 3..=256 vertices in
    /// either order, within 50 km of its first vertex.
    pub polygons: Vec<Vec<[f64; 2]>>,
}

/// One inclusion circle of the geofence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FenceCircle {
    /// Centre latitude, degrees (-90..=90).
    pub lat_deg: f64,
    /// Centre longitude, degrees (-180..=180).
    pub lon_deg: f64,
    /// Radius, m (1..=100000).
    pub radius_m: f64,
}

/// `navigation.fence.max_distance_m` and a circle's `radius_m`, m.
pub const FENCE_DISTANCE_M: std::ops::RangeInclusive<f64> = 1.0..=100_000.0;
/// Most circles, and most polygons, in the fence.
pub const FENCE_MAX_AREAS: usize = 16;
/// Vertices of a fence polygon.
pub const FENCE_POLYGON_VERTICES: std::ops::RangeInclusive<usize> = 3..=256;
/// Farthest a polygon's vertex may be from its first, m: the polygon is flattened onto the
/// plane tangent at its first vertex.
pub const FENCE_POLYGON_SPAN_M: f64 = 50_000.0;

impl Default for NavigationConfig {
    fn default() -> Self {
        let f = crate::mission::FollowerParams::default();
        NavigationConfig {
            rollover_tilt_deg: 60.0,
            rollover_ms: 500,
            fence: FenceConfig::default(),
            mission_file: PathBuf::new(),
            mission_speed_m_s: f.default_speed_m_s,
            mission_acceptance_m: f.default_acceptance_m,
            mission_lookahead_m: f.lookahead_min_m,
            mission_lateral_accel_m_s2: f.lateral_accel_m_s2,
            mission_decel_m_s2: f.decel_m_s2,
        }
    }
}

/// `navigation.rollover_tilt_deg`, degrees.
pub const ROLLOVER_TILT_DEG: std::ops::RangeInclusive<f32> = 20.0..=90.0;
/// `navigation.rollover_ms`, ms: a rollover trips within a second, like every protection.
pub const ROLLOVER_MS: std::ops::RangeInclusive<u32> = 100..=1_000;

impl NavigationConfig {
    /// The path follower's settings.
    pub fn follower_params(&self) -> crate::mission::FollowerParams {
        crate::mission::FollowerParams {
            default_speed_m_s: self.mission_speed_m_s,
            default_acceptance_m: self.mission_acceptance_m,
            lookahead_min_m: self.mission_lookahead_m,
            lateral_accel_m_s2: self.mission_lateral_accel_m_s2,
            decel_m_s2: self.mission_decel_m_s2,
            ..crate::mission::FollowerParams::default()
        }
    }

    /// The mission file, if one is configured.
    pub fn mission_file(&self) -> Option<&std::path::Path> {
        (!self.mission_file.as_os_str().is_empty()).then_some(self.mission_file.as_path())
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
    /// Longest time between chunk flushes, in milliseconds (what a crash can lose),
    /// 100..=60000.
    pub flush_interval_ms: u32,
    /// Decoded values are logged every n-th cycle (raw packets and timings every cycle).
    pub decoded_every: u32,
    /// Longest time one file covers, in seconds: the logger then finishes the file (summary
    /// and index written) and the run continues in `NAME-1.mcap`, `NAME-2.mcap`, ... The
    /// writer holds an index entry per chunk until its file is finished, so this bounds the
    /// logger's memory on a long run. 0 never splits; else 10..=86400.
    pub max_file_duration_s: u32,
}

impl Default for LogConfig {
    fn default() -> Self {
        LogConfig {
            enabled: true,
            directory: "/var/log/dima".into(),
            flush_interval_ms: 1_000,
            decoded_every: 1,
            max_file_duration_s: 600,
        }
    }
}

/// Live view: the logger thread also serves the log's channels, and the GNSS position as
/// `foxglove.LocationFix` on `/dima/location`, over the Foxglove WebSocket protocol.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct FoxgloveConfig {
    /// Address the server listens on, `IP:PORT` (e.g. `127.0.0.1:8765`; port 0 picks a free
    /// one); empty: no live view.
    pub listen: String,
}

impl FoxgloveConfig {
    /// The address to listen on; `None` when the live view is off; an error naming the key
    /// when the text is not an `IP:PORT` address.
    pub fn listen_addr(&self) -> Result<Option<std::net::SocketAddr>, ConfigError> {
        let text = self.listen.trim();
        if text.is_empty() {
            return Ok(None);
        }
        text.parse().map(Some).map_err(|_| {
            invalid(
                "foxglove.listen",
                format!("\"{}\"", self.listen),
                "expected IP:PORT, e.g. \"127.0.0.1:8765\" (\"0.0.0.0:8765\" on every \
                 interface, \"[::1]:8765\" for IPv6), or \"\" for no live view",
            )
        })
    }
}

/// Shortest `log.flush_interval_ms`, ms.
pub const MIN_FLUSH_INTERVAL_MS: u32 = 100;
/// Longest `log.flush_interval_ms`, ms (what a crash may lose).
pub const MAX_FLUSH_INTERVAL_MS: u32 = 60_000;

/// Shortest `log.max_file_duration_s` other than 0 (never split), s.
pub const MIN_FILE_DURATION_S: u32 = 10;
/// Longest `log.max_file_duration_s`, s (a day).
pub const MAX_FILE_DURATION_S: u32 = 86_400;

/// Longest time a failsafe that counts packets or periods may take to trip, ns: at any
/// `realtime.loop_rate_hz` its count must amount to at most this.
pub const MAX_TRIP_NS: u64 = 1_000_000_000;

/// Slowest `realtime.loop_rate_hz`: below it the counted failsafes cannot trip within
/// [`MAX_TRIP_NS`] (the stuck-IMU rule needs two packets, the overrun rule a tenth of a
/// second's periods).
pub const MIN_LOOP_RATE_HZ: u32 = 10;

/// `safety.max_stall_ms`, ms: at most 400, so that two stalls just shorter than it, back to
/// back, add up past it within a second even at the slowest loop rate.
pub const STALL_MS: std::ops::RangeInclusive<u32> = 10..=400;

/// Fastest `realtime.loop_rate_hz`.
pub const MAX_LOOP_RATE_HZ: u32 = 10_000;

/// Largest `control.max_speed_accuracy_mm_s`: a fix whose speed may be 2 m/s off says
/// nothing about a car driving at a few m/s.
pub const MAX_SPEED_ACCURACY_MM_S: u32 = 2_000;

/// Smallest `estimator.min_heading_speed_mm_s`: slower, the heading of motion is noise.
pub const MIN_HEADING_SPEED_MM_S: i32 = 200;

/// Display frames per second (`xbee.display_rate_hz`): at least one a second, as the ground
/// station gives a command up after 2.5 s without an acknowledgement.
pub const DISPLAY_RATE_HZ: std::ops::RangeInclusive<f64> = 1.0..=100.0;

/// The commented default configuration file.
pub const DEFAULT_TOML: &str = include_str!("default-config.toml");

/// Baud rates a Linux serial port (termios `B*` constants) can be set to.
pub const STANDARD_BAUD_RATES: [u32; 26] = [
    50, 75, 110, 134, 150, 200, 300, 600, 1_200, 1_800, 2_400, 4_800, 9_600, 19_200, 38_400,
    57_600, 115_200, 230_400, 460_800, 500_000, 576_000, 921_600, 1_000_000, 1_500_000, 2_000_000,
    3_000_000,
];

/// A configuration problem a user can fix.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The text is not valid TOML for this configuration.
    #[error("config file {origin}: {reason}")]
    Parse {
        /// Where the text came from (a path).
        origin: String,
        /// Where and why (the TOML parser's message).
        reason: String,
    },
    /// A value is out of its allowed range.
    #[error("config: {key} = {value}: {allowed}")]
    Invalid {
        /// The key, e.g. `safety.comms_timeout_ms`.
        key: String,
        /// The value found.
        value: String,
        /// What is allowed, e.g. `expected 100..=5000`.
        allowed: String,
    },
}

fn invalid(key: impl Into<String>, value: impl std::fmt::Display, allowed: &str) -> ConfigError {
    ConfigError::Invalid {
        key: key.into(),
        value: value.to_string(),
        allowed: allowed.to_owned(),
    }
}

/// A fence coordinate pair `[lat_deg, lon_deg]` as a point, or the error naming `key`.
fn fence_point(key: &str, lat_deg: f64, lon_deg: f64) -> Result<crate::geo::LatLon, ConfigError> {
    let p = crate::geo::LatLon::new(lat_deg, lon_deg);
    if p.is_valid() {
        Ok(p)
    } else {
        Err(invalid(
            key,
            format!("[{lat_deg}, {lon_deg}]"),
            "expected a finite latitude -90..=90 and longitude -180..=180, in degrees",
        ))
    }
}

impl FenceConfig {
    /// Checks the fence's bounds; an error names the offending key under `prefix` (e.g.
    /// `navigation.fence`, or `geoFence` for a plan file's fence).
    pub fn validate_at(&self, prefix: &str) -> Result<(), ConfigError> {
        validate_fence(self, prefix)
    }

    /// This fence's inclusion areas and `other`'s (the car may be in any of them), and the
    /// smaller of the two largest distances from the revive point.
    pub fn joined(&self, other: &FenceConfig) -> FenceConfig {
        FenceConfig {
            max_distance_m: match (self.max_distance_m, other.max_distance_m) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            },
            circles: self.circles.iter().chain(&other.circles).cloned().collect(),
            polygons: self
                .polygons
                .iter()
                .chain(&other.polygons)
                .cloned()
                .collect(),
        }
    }
}

/// Checks a fence; errors name keys under `prefix`.
fn validate_fence(fence: &FenceConfig, prefix: &str) -> Result<(), ConfigError> {
    if let Some(max) = fence.max_distance_m {
        within(&format!("{prefix}.max_distance_m"), max, FENCE_DISTANCE_M)?;
    }
    for (key, count) in [
        (format!("{prefix}.circles"), fence.circles.len()),
        (format!("{prefix}.polygons"), fence.polygons.len()),
    ] {
        within(&key, count, 0..=FENCE_MAX_AREAS)?;
    }
    for (i, c) in fence.circles.iter().enumerate() {
        fence_point(&format!("{prefix}.circles[{i}]"), c.lat_deg, c.lon_deg)?;
        within(
            &format!("{prefix}.circles[{i}].radius_m"),
            c.radius_m,
            FENCE_DISTANCE_M,
        )?;
    }
    for (i, polygon) in fence.polygons.iter().enumerate() {
        let key = format!("{prefix}.polygons[{i}]");
        within_because(
            &format!("{key} vertices"),
            polygon.len(),
            FENCE_POLYGON_VERTICES,
            "a polygon needs three vertices to enclose an area",
        )?;
        let first = fence_point(&format!("{key}[0]"), polygon[0][0], polygon[0][1])?;
        for (j, &[lat, lon]) in polygon.iter().enumerate() {
            let p = fence_point(&format!("{key}[{j}]"), lat, lon)?;
            if crate::geo::distance_m(first, p) > FENCE_POLYGON_SPAN_M {
                return Err(invalid(
                    format!("{key}[{j}]"),
                    format!("[{lat}, {lon}]"),
                    "more than 50 km from the polygon's first vertex",
                ));
            }
        }
    }
    Ok(())
}

/// `Ok` when `value` is within `range`, else the error naming `key` and the range.
fn within<T>(key: &str, value: T, range: std::ops::RangeInclusive<T>) -> Result<(), ConfigError>
where
    T: PartialOrd + std::fmt::Display + Copy,
{
    if range.contains(&value) {
        Ok(())
    } else {
        Err(invalid(
            key,
            value,
            &format!("expected {}..={}", range.start(), range.end()),
        ))
    }
}

/// As [`within`], with the reason for the range after it.
fn within_because<T>(
    key: &str,
    value: T,
    range: std::ops::RangeInclusive<T>,
    reason: &str,
) -> Result<(), ConfigError>
where
    T: PartialOrd + std::fmt::Display + Copy,
{
    within(key, value, range).map_err(|e| match e {
        ConfigError::Invalid {
            key,
            value,
            allowed,
        } => ConfigError::Invalid {
            key,
            value,
            allowed: format!("{allowed}: {reason}"),
        },
        other => other,
    })
}

/// `seconds` as text, to the millisecond: `25 s`, `0.2 s`.
fn seconds_text(ns: u64) -> String {
    format!("{} s", (ns as f64 / 1e6).round() / 1e3)
}

/// Bits one byte takes on an 8-data-bit, no-parity UART line: start, data and stop bits.
pub fn bits_per_byte(stop_bits: u8) -> u64 {
    1 + 8 + u64::from(stop_bits)
}

/// The most packets (or periods) that take at most `ns` at `rate_hz`.
pub fn most_packets_within(rate_hz: u32, ns: u64) -> u32 {
    (u64::from(rate_hz) * ns / 1_000_000_000).min(u64::from(u32::MAX)) as u32
}

/// Largest `safety.overrun_limit` at `rate_hz`: one late wake-up in ten periods, and no more
/// than the overrun window holds.
pub fn max_overrun_limit(rate_hz: u32) -> u32 {
    (rate_hz / 10).min(crate::safety::MAX_OVERRUN_LIMIT)
}

impl Config {
    /// Parses and validates a configuration from TOML text; `origin` names it in errors.
    ///
    /// A file in the layout of DIMA-RS 0.1 (hard-wired `[control.speed]` and `[control.heading]`
    /// PIDs) is read as what it meant: those PIDs as `speed_pid` and `heading_pid`, no tail
    /// controller, and the estimate they used (`heading_tau_s = 0`, `gyro_bias_tau_s = 0`,
    /// `accel_bridging = false`), so its logs replay identically.
    pub fn from_toml(text: &str, origin: &str) -> Result<Config, ConfigError> {
        let parse_error = |e: toml::de::Error| ConfigError::Parse {
            origin: origin.to_owned(),
            reason: e.to_string().trim_end().to_owned(),
        };
        let config: Config = match toml::from_str(text) {
            Ok(config) => config,
            Err(e) => {
                let mut table = toml::from_str::<toml::Table>(text).map_err(parse_error)?;
                if !migrate_v0_1(&mut table) {
                    return Err(parse_error(e));
                }
                toml::Value::Table(table).try_into().map_err(parse_error)?
            }
        };
        config.validate()?;
        Ok(config)
    }

    /// Loop period in nanoseconds.
    pub fn period_ns(&self) -> u64 {
        1_000_000_000 / u64::from(self.realtime.loop_rate_hz.max(1))
    }

    /// Time a 132-byte sensor packet takes on the wire at the configured line settings, in
    /// nanoseconds (3.15 ms at 460 800 baud 8N2).
    pub fn packet_wire_ns(&self) -> u64 {
        let bits = dima_sensorboard::PACKET_LEN as u64 * bits_per_byte(self.sensor.stop_bits);
        bits * 1_000_000_000 / u64::from(self.sensor.baud.max(1))
    }

    /// Latest completion of a packet after its request, ns: the packet deadline, plus one
    /// period in request-ahead mode (the request goes out at the end of a cycle and the answer
    /// is read, with the deadline, in the next one).
    pub fn packet_deadline_after_request_ns(&self) -> u64 {
        let deadline = u64::from(self.sensor.packet_deadline_us) * 1_000;
        if self.sensor.request_ahead {
            deadline + self.period_ns()
        } else {
            deadline
        }
    }

    /// Checks every value against its allowed range and the rules across fields; the error
    /// names the key and what is allowed.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.validate_realtime()?;
        self.validate_links()?;
        self.validate_safety()?;
        self.validate_channels()?;
        self.validate_control()?;
        self.validate_estimator()?;
        self.validate_navigation()?;
        self.validate_log()?;
        self.validate_foxglove()
    }

    fn validate_navigation(&self) -> Result<(), ConfigError> {
        let n = &self.navigation;
        within(
            "navigation.rollover_tilt_deg",
            n.rollover_tilt_deg,
            ROLLOVER_TILT_DEG,
        )?;
        within("navigation.rollover_ms", n.rollover_ms, ROLLOVER_MS)?;
        validate_fence(&n.fence, "navigation.fence")?;
        self.validate_mission()
    }

    fn validate_foxglove(&self) -> Result<(), ConfigError> {
        if self.foxglove.listen_addr()?.is_some() && !self.log.enabled {
            return Err(invalid(
                "foxglove.listen",
                format!("\"{}\"", self.foxglove.listen),
                "the live view serves the log's channels: it needs log.enabled = true",
            ));
        }
        Ok(())
    }

    fn validate_mission(&self) -> Result<(), ConfigError> {
        let n = &self.navigation;
        within(
            "navigation.mission_speed_m_s",
            n.mission_speed_m_s,
            0.1..=20.0,
        )?;
        let max_m_s = f64::from(self.control.max_speed_mm_s) * 1e-3;
        if n.mission_speed_m_s > max_m_s {
            return Err(invalid(
                "navigation.mission_speed_m_s",
                n.mission_speed_m_s,
                &format!("expected at most control.max_speed_mm_s ({max_m_s} m/s)"),
            ));
        }
        within(
            "navigation.mission_acceptance_m",
            n.mission_acceptance_m,
            0.1..=50.0,
        )?;
        within(
            "navigation.mission_lookahead_m",
            n.mission_lookahead_m,
            0.5..=50.0,
        )?;
        within(
            "navigation.mission_lateral_accel_m_s2",
            n.mission_lateral_accel_m_s2,
            0.5..=20.0,
        )?;
        within(
            "navigation.mission_decel_m_s2",
            n.mission_decel_m_s2,
            0.2..=10.0,
        )
    }

    fn validate_log(&self) -> Result<(), ConfigError> {
        within("log.decoded_every", self.log.decoded_every, 1..=u32::MAX)?;
        // A chunk per flush, and the writer keeps an index entry per chunk until its file is
        // finished: flushing every cycle would grow the logger's memory a hundred times
        // faster than the default.
        within(
            "log.flush_interval_ms",
            self.log.flush_interval_ms,
            MIN_FLUSH_INTERVAL_MS..=MAX_FLUSH_INTERVAL_MS,
        )?;
        let split = self.log.max_file_duration_s;
        if split != 0 && !(MIN_FILE_DURATION_S..=MAX_FILE_DURATION_S).contains(&split) {
            return Err(invalid(
                "log.max_file_duration_s",
                split,
                &format!(
                    "expected 0 (never split) or {MIN_FILE_DURATION_S}..={MAX_FILE_DURATION_S}"
                ),
            ));
        }
        Ok(())
    }

    fn validate_realtime(&self) -> Result<(), ConfigError> {
        let rt = &self.realtime;
        within_because(
            "realtime.loop_rate_hz",
            rt.loop_rate_hz,
            MIN_LOOP_RATE_HZ..=MAX_LOOP_RATE_HZ,
            "the failsafes count packets and periods, and below 10 Hz they cannot trip within a \
             second",
        )?;
        within("realtime.priority", rt.priority, 0..=99)?;
        within("realtime.telemetry_priority", rt.telemetry_priority, 0..=99)?;
        if rt.priority != 0 && rt.telemetry_priority >= rt.priority {
            return Err(invalid(
                "realtime.telemetry_priority",
                rt.telemetry_priority,
                &format!("must be below realtime.priority ({})", rt.priority),
            ));
        }
        within(
            "realtime.log_ring_records",
            rt.log_ring_records,
            1..=1 << 20,
        )?;
        within("realtime.command_ring", rt.command_ring, 1..=1 << 16)
    }

    fn validate_links(&self) -> Result<(), ConfigError> {
        for (key, baud) in [
            ("sensor.baud", self.sensor.baud),
            ("maestro.baud", self.maestro.baud),
            ("xbee.baud", self.xbee.baud),
        ] {
            if !STANDARD_BAUD_RATES.contains(&baud) {
                return Err(invalid(
                    key,
                    baud,
                    "expected a standard rate (9600, 19200, 38400, 57600, 115200, 230400, \
                     460800, 921600, 1000000, 2000000, ...)",
                ));
            }
        }
        within("sensor.stop_bits", self.sensor.stop_bits, 1..=2)?;
        let period_us = self.period_ns() / 1_000;
        let wire_us = self.packet_wire_ns() / 1_000;
        let deadline_us = u64::from(self.sensor.packet_deadline_us);
        if deadline_us <= wire_us {
            return Err(invalid(
                "sensor.packet_deadline_us",
                deadline_us,
                &format!(
                    "must exceed the packet's {wire_us} µs on the wire at sensor.baud = {}",
                    self.sensor.baud
                ),
            ));
        }
        let budget_us = u64::from(self.servo_write_budget_us());
        if deadline_us + budget_us > period_us {
            return Err(invalid(
                "sensor.packet_deadline_us",
                deadline_us,
                &format!(
                    "plus {}.write_budget_us ({budget_us}) must fit in the period \
                     ({period_us} µs at realtime.loop_rate_hz = {})",
                    self.servo_section(),
                    self.realtime.loop_rate_hz
                ),
            ));
        }
        within(
            "sensor.wire_tolerance_us",
            self.sensor.wire_tolerance_us,
            0..=1_000,
        )?;
        within(
            "maestro.write_budget_us",
            self.maestro.write_budget_us,
            1..=100_000,
        )?;
        within(
            "maestro.servo_refresh_hz",
            self.maestro.servo_refresh_hz,
            1..=self.realtime.loop_rate_hz,
        )?;
        self.validate_pca9685()?;
        let rate = self.xbee.display_rate_hz;
        if !DISPLAY_RATE_HZ.contains(&rate) {
            return Err(invalid(
                "xbee.display_rate_hz",
                rate,
                &format!(
                    "expected {}..={}: display frames carry the acknowledgements the ground \
                     station gives a command up without after 2.5 s",
                    DISPLAY_RATE_HZ.start(),
                    DISPLAY_RATE_HZ.end()
                ),
            ));
        }
        Ok(())
    }

    fn validate_safety(&self) -> Result<(), ConfigError> {
        let s = &self.safety;
        within("safety.comms_timeout_ms", s.comms_timeout_ms, 100..=5_000)?;
        within("safety.sensor_loss_packets", s.sensor_loss_packets, 1..=250)?;
        self.packets_within_a_second("safety.sensor_loss_packets", s.sensor_loss_packets)?;
        within(
            "safety.overrun_limit",
            s.overrun_limit,
            1..=crate::safety::MAX_OVERRUN_LIMIT,
        )?;
        let rate = self.realtime.loop_rate_hz;
        let most = max_overrun_limit(rate);
        if s.overrun_limit > most {
            return Err(invalid(
                "safety.overrun_limit",
                s.overrun_limit,
                &format!(
                    "lets the loop at realtime.loop_rate_hz = {rate} wake late {} times a second \
                     without a failsafe; at most {most} (one in ten periods), so that sustained \
                     overload trips within a second",
                    s.overrun_limit
                ),
            ));
        }
        within_because(
            "safety.max_stall_ms",
            s.max_stall_ms,
            STALL_MS,
            "stalls just shorter than it, back to back, must add up past it within a second",
        )?;
        let two_periods_ms = 2_000 / u64::from(rate.max(1));
        if u64::from(s.max_stall_ms) < two_periods_ms {
            return Err(invalid(
                "safety.max_stall_ms",
                s.max_stall_ms,
                &format!(
                    "must be at least two periods ({two_periods_ms} ms at realtime.loop_rate_hz = \
                     {rate}): one missed period is an ordinary late wake-up, counted by \
                     safety.overrun_limit"
                ),
            ));
        }
        within("safety.gnss_timeout_ms", s.gnss_timeout_ms, 100..=5_000)?;
        within("safety.imu_stuck_packets", s.imu_stuck_packets, 2..=10_000)?;
        self.packets_within_a_second("safety.imu_stuck_packets", s.imu_stuck_packets)?;
        within("safety.revive_good_packets", s.revive_good_packets, 1..=250)?;
        within(
            "safety.revive_min_interval_ms",
            s.revive_min_interval_ms,
            100..=5_000,
        )
    }

    /// `Ok` when `packets` loop periods take at most [`MAX_TRIP_NS`] at the loop rate, else the
    /// error naming `key`, the loop rate and the time the count amounts to.
    fn packets_within_a_second(&self, key: &str, packets: u32) -> Result<(), ConfigError> {
        let rate = self.realtime.loop_rate_hz;
        let most = most_packets_within(rate, MAX_TRIP_NS);
        if packets <= most {
            return Ok(());
        }
        Err(invalid(
            key,
            packets,
            &format!(
                "{} at realtime.loop_rate_hz = {rate}, and a failsafe must trip within a \
                 second: at most {} ({most} packets)",
                seconds_text(u64::from(packets) * 1_000_000_000 / u64::from(rate.max(1))),
                seconds_text(MAX_TRIP_NS),
            ),
        ))
    }

    fn validate_pca9685(&self) -> Result<(), ConfigError> {
        let p = &self.pca9685;
        within("pca9685.address", p.address, 0x40..=0x7F)?;
        within("pca9685.pwm_frequency_hz", p.pwm_frequency_hz, 24..=1_526)?;
        within(
            "pca9685.oscillator_hz",
            p.oscillator_hz,
            20_000_000..=50_000_000,
        )?;
        within("pca9685.write_budget_us", p.write_budget_us, 1..=100_000)?;
        if self.servo.kind == ServoKind::Pca9685 {
            let period_us = 1_000_000 / p.pwm_frequency_hz;
            for (name, ch) in self.channels.named() {
                if u32::from(ch.max_us) >= period_us {
                    return Err(invalid(
                        format!("channels.{name}.max_us"),
                        ch.max_us,
                        &format!(
                            "must be shorter than the PWM period ({period_us} µs at \
                             pca9685.pwm_frequency_hz = {})",
                            p.pwm_frequency_hz
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The section of the servo board in use: `maestro` or `pca9685`.
    pub fn servo_section(&self) -> &'static str {
        match self.servo.kind {
            ServoKind::Maestro => "maestro",
            ServoKind::Pca9685 => "pca9685",
        }
    }

    /// Time the loop allows for writing the servo targets, µs, for the board in use.
    pub fn servo_write_budget_us(&self) -> u32 {
        match self.servo.kind {
            ServoKind::Maestro => self.maestro.write_budget_us,
            ServoKind::Pca9685 => self.pca9685.write_budget_us,
        }
    }

    /// How often the servo targets are written, Hz: the Maestro's refresh rate, or the
    /// PCA9685's PWM frequency (no more often than the loop runs).
    pub fn servo_write_hz(&self) -> u32 {
        match self.servo.kind {
            ServoKind::Maestro => self.maestro.servo_refresh_hz,
            ServoKind::Pca9685 => self.pca9685.pwm_frequency_hz,
        }
        .clamp(1, self.realtime.loop_rate_hz.max(1))
    }

    fn validate_channels(&self) -> Result<(), ConfigError> {
        let c = &self.channels;
        let highest_channel = match self.servo.kind {
            ServoKind::Maestro => 23,
            ServoKind::Pca9685 => 15,
        };
        for (name, ch) in c.named() {
            let key = |field: &str| format!("channels.{name}.{field}");
            within(&key("channel"), ch.channel, 0..=highest_channel)?;
            within(&key("max_us"), ch.max_us, 1..=4_000)?;
            within(&key("min_us"), ch.min_us, 1..=ch.max_us.saturating_sub(1))?;
            within(&key("neutral_us"), ch.neutral_us, ch.min_us..=ch.max_us)?;
            match ch.safe {
                SafeOutput::PulseUs(us) => {
                    within(&key("safe"), us, ch.min_us..=ch.max_us)?;
                    if name == "throttle" && us != ch.neutral_us && !ch.allow_safe_not_neutral {
                        return Err(invalid(
                            key("safe"),
                            us,
                            &format!(
                                "differs from neutral_us ({}): the ESC would run the motor in \
                                 FAILSAFE and KILLED; give the neutral pulse, or set {} = true \
                                 if this ESC stops at another pulse",
                                ch.neutral_us,
                                key("allow_safe_not_neutral")
                            ),
                        ));
                    }
                }
                SafeOutput::Off(_) if !ch.allow_off => {
                    return Err(invalid(
                        key("safe"),
                        "\"off\"",
                        &format!(
                            "no pulses leave the {name} where it was; give a pulse width, or \
                             set {} = true if this output is safe without pulses",
                            key("allow_off")
                        ),
                    ))
                }
                SafeOutput::Off(_) => {}
            }
        }
        if c.throttle.channel == c.steering.channel
            || c.throttle.channel == c.tail.channel
            || c.steering.channel == c.tail.channel
        {
            return Err(invalid(
                "channels.*.channel",
                format!(
                    "{}, {}, {}",
                    c.throttle.channel, c.steering.channel, c.tail.channel
                ),
                "throttle, steering and tail need distinct channels",
            ));
        }
        Ok(())
    }

    /// The channels' controllers, built from `[control.*]`; the error names the key at fault.
    pub fn controllers(&self) -> Result<ControllerSet, ConfigError> {
        ControllerSet::new(&self.control).map_err(|(channel, e)| controller_error(channel, e))
    }

    fn validate_control(&self) -> Result<(), ConfigError> {
        let c = &self.control;
        self.controllers()?;
        within("control.max_speed_mm_s", c.max_speed_mm_s, 1..=50_000)?;
        within_because(
            "control.max_speed_accuracy_mm_s",
            c.max_speed_accuracy_mm_s,
            1..=MAX_SPEED_ACCURACY_MM_S,
            "the receiver's speed accuracy estimate (sAcc); a fix whose speed may be more than \
             2 m/s off says nothing about a car driving at a few m/s",
        )
    }

    fn validate_estimator(&self) -> Result<(), ConfigError> {
        let e = &self.estimator;
        if e.gyro_yaw_sign != 1.0 && e.gyro_yaw_sign != -1.0 {
            return Err(invalid(
                "estimator.gyro_yaw_sign",
                e.gyro_yaw_sign,
                "expected 1 or -1 (-1 when the board's Z axis points up)",
            ));
        }
        within_because(
            "estimator.min_heading_speed_mm_s",
            e.min_heading_speed_mm_s,
            MIN_HEADING_SPEED_MM_S..=20_000,
            "the heading of motion is the direction of the GNSS velocity; below 200 mm/s the \
             receiver's speed error makes it noise",
        )?;
        within("estimator.heading_tau_s", e.heading_tau_s, 0.0..=60.0)?;
        within("estimator.gyro_bias_tau_s", e.gyro_bias_tau_s, 0.0..=600.0)?;
        within("estimator.still_speed_mm_s", e.still_speed_mm_s, 0..=1_000)?;
        within("estimator.still_rate_dps", e.still_rate_dps, 0.0..=90.0)
    }
}

/// Rewrites a DIMA-RS 0.1 `[control]` section in place; false if `table` is not one.
fn migrate_v0_1(table: &mut toml::Table) -> bool {
    let Some(toml::Value::Table(control)) = table.get_mut("control") else {
        return false;
    };
    if !control.contains_key("speed") && !control.contains_key("heading") {
        return false;
    }
    let mut estimator = toml::Table::new();
    for key in ["gyro_yaw_sign", "min_heading_speed_mm_s"] {
        if let Some(v) = control.remove(key) {
            estimator.insert(key.into(), v);
        }
    }
    estimator.insert("heading_tau_s".into(), toml::Value::Float(0.0));
    estimator.insert("gyro_bias_tau_s".into(), toml::Value::Float(0.0));
    estimator.insert("accel_bridging".into(), toml::Value::Boolean(false));
    for (old, new, kind) in [
        ("speed", "throttle", "speed_pid"),
        ("heading", "steering", "heading_pid"),
    ] {
        let mut params = match control.remove(old) {
            Some(toml::Value::Table(t)) => t,
            _ => ControlConfig::default().channel_table(new),
        };
        params.insert("kind".into(), toml::Value::String(kind.into()));
        control.insert(new.into(), toml::Value::Table(params));
    }
    control.insert(
        "tail".into(),
        toml::Value::Table(toml::Table::from_iter([(
            "kind".to_owned(),
            toml::Value::String("none".into()),
        )])),
    );
    table.insert("estimator".into(), toml::Value::Table(estimator));
    true
}

/// A controller's parameter error as a configuration error naming `control.<channel>.<key>`.
fn controller_error(channel: Channel, e: ParamError) -> ConfigError {
    let section = format!("control.{}", channel.name());
    match e {
        ParamError::Invalid {
            field,
            value,
            allowed,
        } => invalid(format!("{section}.{field}"), value, &allowed),
        ParamError::UnknownKind(kind) => invalid(
            format!("{section}.kind"),
            format!("\"{kind}\""),
            &format!("expected one of: {}", kind_names()),
        ),
        ParamError::Parse(reason) => invalid(section, "{ .. }", &format!("parameters: {reason}")),
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
    fn the_live_view_is_off_by_default_and_its_address_is_checked() {
        assert_eq!(Config::default().foxglove.listen_addr().unwrap(), None);
        let parse = |text: &str| Config::from_toml(text, "test.toml");
        let on = parse("[foxglove]\nlisten = \"127.0.0.1:8765\"\n").unwrap();
        assert_eq!(
            on.foxglove.listen_addr().unwrap(),
            Some("127.0.0.1:8765".parse().unwrap())
        );
        assert_eq!(
            parse("[foxglove]\nlisten = \"\"\n").unwrap().foxglove,
            FoxgloveConfig::default()
        );
        for bad in ["localhost:8765", "127.0.0.1", "127.0.0.1:99999", ":8765"] {
            let message = parse(&format!("[foxglove]\nlisten = \"{bad}\"\n"))
                .unwrap_err()
                .to_string();
            assert!(message.contains("foxglove.listen"), "{message}");
            assert!(message.contains("expected IP:PORT"), "{message}");
        }
        let message = parse("[log]\nenabled = false\n[foxglove]\nlisten = \"127.0.0.1:8765\"\n")
            .unwrap_err()
            .to_string();
        assert!(message.contains("log.enabled = true"), "{message}");
    }

    #[test]
    fn require_auth_without_a_key_file_says_how_to_fix_it() {
        let mut x = XbeeConfig::default();
        assert!(x.require_auth);
        let message = x.key_file_needed().unwrap_err().to_string();
        assert!(message.contains("xbee.key_file"), "{message}");
        assert!(message.contains("dima keygen"), "{message}");
        x.require_auth = false;
        assert_eq!(x.key_file_needed().unwrap(), None);
        x.key_file = Some("/etc/dima/link.key".into());
        assert_eq!(
            x.key_file_needed().unwrap(),
            Some(std::path::Path::new("/etc/dima/link.key"))
        );
        let parsed: Config =
            toml::from_str("[xbee]\nrequire_auth = false\nkey_file = \"k\"\n").unwrap();
        assert!(!parsed.xbee.require_auth);
        assert_eq!(parsed.xbee.key_file, Some("k".into()));
    }

    #[test]
    fn naming_a_controller_kind_is_enough_and_check_prints_its_parameters() {
        let c = Config::from_toml(
            "[control.tail]\nkind = \"yaw_rate\"\n[control.throttle]\nkind = \"speed_pid\"\n\
             kp = 0.3\n",
            "test.toml",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let tail = &c.control.tail.params;
        assert_eq!(tail["max_yaw_rate_dps"], toml::Value::Float(600.0));
        assert_eq!(tail["min_speed_mm_s"], toml::Value::Float(1500.0));
        let throttle = &c.control.throttle.params;
        assert_eq!(
            throttle["kp"],
            toml::Value::Float(0.3),
            "given values override"
        );
        assert_eq!(throttle["output_limit"], toml::Value::Float(0.5));
        // What `dima config --check` prints parses back to the same configuration.
        let printed = toml::to_string(&c).unwrap();
        assert!(printed.contains("max_yaw_rate_dps = 600.0"), "{printed}");
        assert_eq!(Config::from_toml(&printed, "printed").unwrap(), c);
        // Only the kind, for the default kinds: the defaults.
        let kinds_only = "[control.throttle]\nkind = \"speed_pid\"\n\
                          [control.steering]\nkind = \"heading_pid\"\n";
        assert_eq!(
            Config::from_toml(kinds_only, "t").unwrap(),
            Config::default()
        );
        assert!(
            error_for("[control.tail]\nkind = \"yaw_rate\"\nmin_speed_mm_s = -1.0")
                .contains("control.tail.min_speed_mm_s = -1")
        );
    }

    #[test]
    fn the_default_files_commented_tail_controller_is_the_yaw_rate_default() {
        let commented: String = DEFAULT_TOML
            .lines()
            .filter_map(|l| l.strip_prefix("#   "))
            .map(|l| format!("{l}\n"))
            .collect();
        let mut table: toml::Table = toml::from_str(&commented).expect("the commented section");
        assert_eq!(
            table.remove("kind"),
            Some(toml::Value::String("yaw_rate".into()))
        );
        let kind = crate::control::registry::kind("yaw_rate").unwrap();
        assert_eq!(table, (kind.defaults)());
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

    #[test]
    fn a_fence_parses_and_its_bounds_are_checked() {
        let c = Config::from_toml(
            "[navigation.fence]\nmax_distance_m = 80.0\n\
             circles = [{ lat_deg = 48.1, lon_deg = 11.5, radius_m = 50.0 }]\n\
             polygons = [[[48.0, 11.0], [48.0, 11.01], [48.01, 11.01]]]\n",
            "test.toml",
        )
        .expect("a valid fence");
        assert_eq!(c.navigation.fence.max_distance_m, Some(80.0));
        assert_eq!(c.navigation.fence.circles[0].radius_m, 50.0);
        assert_eq!(c.navigation.fence.polygons[0].len(), 3);
        // Written out (as `dima sim` hands a configuration to the robot) it reads back the same.
        let text = toml::to_string(&c).expect("serialises");
        assert_eq!(Config::from_toml(&text, "written.toml").unwrap(), c);
        for (toml, key) in [
            (
                "polygons = [[[48.0, 11.0], [48.0, 11.01]]]",
                "navigation.fence.polygons[0] vertices",
            ),
            (
                "polygons = [[[48.0, 11.0], [48.0, 11.01], [91.0, 11.0]]]",
                "navigation.fence.polygons[0][2]",
            ),
            (
                "polygons = [[[48.0, 11.0], [48.0, 11.01], [48.0, nan]]]",
                "navigation.fence.polygons[0][2]",
            ),
            (
                "polygons = [[[48.0, 11.0], [48.0, 11.01], [49.0, 11.0]]]",
                "navigation.fence.polygons[0][2]",
            ),
            (
                "circles = [{ lat_deg = 48.0, lon_deg = 181.0, radius_m = 5.0 }]",
                "navigation.fence.circles[0]",
            ),
            (
                "circles = [{ lat_deg = 48.0, lon_deg = 11.0, radius_m = 0.0 }]",
                "navigation.fence.circles[0].radius_m",
            ),
            ("max_distance_m = inf", "navigation.fence.max_distance_m"),
            ("max_distance_m = 0.5", "navigation.fence.max_distance_m"),
        ] {
            let err = error_for(&format!("[navigation.fence]\n{toml}\n"));
            assert!(
                err.starts_with(&format!("config: {key} = ")),
                "{toml}: {err}"
            );
        }
        assert!(error_for("[navigation]\nrollover_tilt_deg = 10.0\n")
            .contains("navigation.rollover_tilt_deg"));
        assert!(error_for("[navigation]\nrollover_ms = 2000\n").contains("navigation.rollover_ms"));
    }

    /// The error for `toml` (parsed over the defaults), as text.
    fn error_for(toml: &str) -> String {
        Config::from_toml(toml, "test.toml")
            .expect_err(toml)
            .to_string()
    }

    #[test]
    fn a_pca9685_takes_16_channels_and_pulses_shorter_than_its_period() {
        let key_of = |c: &Config| match c.validate() {
            Err(ConfigError::Invalid { key, .. }) => key,
            other => panic!("{other:?}"),
        };
        let mut c = Config::default();
        c.servo.kind = ServoKind::Pca9685;
        c.validate()
            .expect("the default channels fit a PCA9685 at 50 Hz");
        c.channels.tail.channel = 16;
        assert_eq!(key_of(&c), "channels.tail.channel");
        c.channels.tail.channel = 15;
        c.pca9685.pwm_frequency_hz = 500; // a 2000 µs period
        assert_eq!(key_of(&c), "channels.throttle.max_us");
        c.pca9685.pwm_frequency_hz = 250;
        c.validate().expect("250 Hz servo refresh");
        assert_eq!(c.servo_write_hz(), 250);
        c.pca9685.pwm_frequency_hz = 1_527;
        assert_eq!(key_of(&c), "pca9685.pwm_frequency_hz");
    }

    #[test]
    fn settings_that_disable_protections_are_refused_naming_key_and_range() {
        for (toml, key, range) in [
            ("[safety]\ncomms_timeout_ms = 0", "safety.comms_timeout_ms", "100..=5000"),
            ("[safety]\ncomms_timeout_ms = 3600000", "safety.comms_timeout_ms", "100..=5000"),
            ("[safety]\nsensor_loss_packets = 0", "safety.sensor_loss_packets", "1..=250"),
            ("[safety]\nsensor_loss_packets = 251", "safety.sensor_loss_packets", "1..=250"),
            ("[safety]\noverrun_limit = 0", "safety.overrun_limit", "1..=250"),
            ("[safety]\noverrun_limit = 100000", "safety.overrun_limit", "1..=250"),
            ("[safety]\nmax_stall_ms = 9", "safety.max_stall_ms", "10..=400"),
            ("[safety]\nmax_stall_ms = 401", "safety.max_stall_ms", "10..=400"),
            (
                "[realtime]\nloop_rate_hz = 100\n[safety]\nmax_stall_ms = 10",
                "safety.max_stall_ms",
                "at least two periods (20 ms at realtime.loop_rate_hz = 100)",
            ),
            ("[estimator]\ngyro_yaw_sign = 0", "estimator.gyro_yaw_sign", "1 or -1"),
            ("[estimator]\ngyro_yaw_sign = 0.5", "estimator.gyro_yaw_sign", "1 or -1"),
            ("[estimator]\nheading_tau_s = -1", "estimator.heading_tau_s", "0..=60"),
            (
                "[control.tail]\nkind = \"lqr\"",
                "control.tail.kind",
                "none, speed_pid, heading_pid, yaw_rate",
            ),
            ("[sensor]\nbaud = 12345", "sensor.baud", "standard rate"),
            ("[xbee]\nbaud = 9601", "xbee.baud", "standard rate"),
            ("[maestro]\nbaud = 0", "maestro.baud", "standard rate"),
            (
                "[control.throttle]\nkind = \"speed_pid\"\nkp = -1\nki = 0\nkd = 0\noutput_limit = 0.5\nrate_limit_per_s = 1",
                "control.throttle.kp",
                ">= 0",
            ),
            (
                "[control.throttle]\nkind = \"speed_pid\"\nkp = nan\nki = 0\nkd = 0\noutput_limit = 0.5\nrate_limit_per_s = 1",
                "control.throttle.kp",
                "finite",
            ),
            (
                "[control.steering]\nkind = \"heading_pid\"\nkp = 1\nki = 0\nkd = inf\noutput_limit = 0.5\nrate_limit_per_s = 1",
                "control.steering.kd",
                "finite",
            ),
            (
                "[control.throttle]\nkind = \"speed_pid\"\nkp = 1\nki = 0\nkd = 0\noutput_limit = 1.5\nrate_limit_per_s = 1",
                "control.throttle.output_limit",
                "0..=1",
            ),
            (
                "[control.throttle]\nkind = \"speed_pid\"\nkp = 1\nki = 0\nkd = 0\noutput_limit = 0.5\nrate_limit_per_s = 0",
                "control.throttle.rate_limit_per_s",
                "> 0",
            ),
            (
                "[channels.throttle]\nchannel = 0\nmin_us = 1000\nmax_us = 2000\nneutral_us = 1500\nsafe = \"off\"",
                "channels.throttle.safe",
                "channels.throttle.allow_off = true",
            ),
            ("[sensor]\npacket_deadline_us = 3000", "sensor.packet_deadline_us", "on the wire"),
            ("[log]\nmax_file_duration_s = 9", "log.max_file_duration_s", "0 (never split) or 10..=86400"),
            ("[log]\nmax_file_duration_s = 86401", "log.max_file_duration_s", "10..=86400"),
            ("[log]\nflush_interval_ms = 0", "log.flush_interval_ms", "100..=60000"),
            ("[log]\nflush_interval_ms = 60001", "log.flush_interval_ms", "100..=60000"),
            (
                "[maestro]\nwrite_budget_us = 400",
                "sensor.packet_deadline_us",
                "must fit in the period",
            ),
        ] {
            let e = error_for(toml);
            assert!(e.contains(key), "{toml}: {e}");
            assert!(e.contains(range), "{toml}: {e}");
        }
    }

    #[test]
    fn protections_counted_in_packets_or_periods_are_bounded_in_time_at_the_loop_rate() {
        let slow = "[realtime]\nloop_rate_hz = 10\n[maestro]\nservo_refresh_hz = 10\n\
                    [safety]\nimu_stuck_packets = 10\noverrun_limit = 1\n";
        for (toml, needles) in [
            (
                "[safety]\nimu_stuck_packets = 10000".to_owned(),
                &[
                    "safety.imu_stuck_packets = 10000",
                    "40 s at realtime.loop_rate_hz = 250",
                    "at most 1 s (250 packets)",
                ][..],
            ),
            (
                format!("{slow}sensor_loss_packets = 250"),
                &[
                    "safety.sensor_loss_packets = 250",
                    "25 s at realtime.loop_rate_hz = 10",
                    "at most 1 s (10 packets)",
                ],
            ),
            (
                "[safety]\noverrun_limit = 250".to_owned(),
                &[
                    "safety.overrun_limit = 250",
                    "realtime.loop_rate_hz = 250",
                    "at most 25",
                ],
            ),
            (
                "[realtime]\nloop_rate_hz = 5".to_owned(),
                &["realtime.loop_rate_hz = 5", "10..=10000"],
            ),
        ] {
            let e = error_for(&toml);
            for needle in needles {
                assert!(e.contains(needle), "{toml}: {e}");
            }
        }
        // The most lenient values at 10 Hz are accepted.
        Config::from_toml(&format!("{slow}sensor_loss_packets = 10"), "t").unwrap();
    }

    #[test]
    fn a_throttle_safe_pulse_other_than_neutral_needs_allow_safe_not_neutral() {
        let throttle = "[channels.throttle]\nchannel = 0\nmin_us = 1000\nmax_us = 2000\n\
                        neutral_us = 1500\n";
        let e = error_for(&format!("{throttle}safe = 2000"));
        for needle in [
            "channels.throttle.safe = 2000",
            "neutral_us (1500)",
            "channels.throttle.allow_safe_not_neutral = true",
        ] {
            assert!(e.contains(needle), "{e}");
        }
        let c = Config::from_toml(
            &format!("{throttle}safe = 1450\nallow_safe_not_neutral = true"),
            "t",
        )
        .unwrap();
        assert_eq!(c.channels.throttle.safe, SafeOutput::PulseUs(1450));
        assert!(c.channels.throttle.allow_safe_not_neutral);
        // Written back, the key stays (and is left out where it is false).
        let written = toml::to_string(&c).unwrap();
        assert_eq!(
            written.matches("allow_safe_not_neutral").count(),
            1,
            "{written}"
        );
        // Steering and tail hold a position, not a speed: their safe pulse is theirs to choose.
        Config::from_toml(
            "[channels.steering]\nchannel = 1\nmin_us = 1250\nmax_us = 1840\nneutral_us = 1545\n\
             safe = 1600\n",
            "t",
        )
        .unwrap();
    }

    #[test]
    fn gnss_heading_and_display_settings_that_defeat_their_purpose_are_refused() {
        for (toml, key, range, reason) in [
            (
                "[control]\nmax_speed_accuracy_mm_s = 100000",
                "control.max_speed_accuracy_mm_s",
                "1..=2000",
                "sAcc",
            ),
            (
                "[control]\nmax_speed_accuracy_mm_s = 0",
                "control.max_speed_accuracy_mm_s",
                "1..=2000",
                "sAcc",
            ),
            (
                "[estimator]\nmin_heading_speed_mm_s = 0",
                "estimator.min_heading_speed_mm_s",
                "200..=20000",
                "heading of motion",
            ),
            (
                "[estimator]\nmin_heading_speed_mm_s = 199",
                "estimator.min_heading_speed_mm_s",
                "200..=20000",
                "heading of motion",
            ),
            (
                "[xbee]\ndisplay_rate_hz = 0.01",
                "xbee.display_rate_hz",
                "1..=100",
                "2.5 s",
            ),
            (
                "[xbee]\ndisplay_rate_hz = 101",
                "xbee.display_rate_hz",
                "1..=100",
                "2.5 s",
            ),
            (
                "[xbee]\ndisplay_rate_hz = nan",
                "xbee.display_rate_hz",
                "1..=100",
                "2.5 s",
            ),
        ] {
            let e = error_for(toml);
            for needle in [key, range, reason] {
                assert!(e.contains(needle), "{toml}: {e}");
            }
        }
        for ok in [
            "[control]\nmax_speed_accuracy_mm_s = 2000",
            "[estimator]\nmin_heading_speed_mm_s = 200",
            "[xbee]\ndisplay_rate_hz = 1.0",
            "[xbee]\ndisplay_rate_hz = 100.0",
        ] {
            Config::from_toml(ok, "t").unwrap_or_else(|e| panic!("{ok}: {e}"));
        }
    }

    #[test]
    fn off_is_accepted_where_the_channel_allows_it() {
        let c = Config::from_toml(
            "[channels.tail]\nchannel = 2\nmin_us = 1000\nmax_us = 2000\nneutral_us = 1500\n\
             safe = \"off\"\nallow_off = true\n",
            "test.toml",
        )
        .unwrap();
        assert_eq!(c.channels.tail.safe, SafeOutput::OFF);
    }

    #[test]
    fn a_parse_error_says_where_once() {
        let e = error_for("[safety]\ncomms_timeout_ms = \"soon\"");
        assert!(e.starts_with("config file test.toml: "), "{e}");
        assert_eq!(e.matches("comms_timeout_ms").count(), 1, "{e}");
        // Nothing is chained below it that would print the same text again.
        let parse = Config::from_toml("x = 1", "t").unwrap_err();
        assert!(std::error::Error::source(&parse).is_none());
    }

    #[test]
    fn log_files_split_after_ten_minutes_by_default_or_never_with_zero() {
        assert_eq!(Config::default().log.max_file_duration_s, 600);
        for ok in [0, 10, 60, 86_400] {
            let c = Config::from_toml(&format!("[log]\nmax_file_duration_s = {ok}"), "t")
                .unwrap_or_else(|e| panic!("{ok}: {e}"));
            assert_eq!(c.log.max_file_duration_s, ok);
        }
        for bad in [1, 9, 86_401, u32::MAX] {
            let mut c = Config::default();
            c.log.max_file_duration_s = bad;
            assert!(c.validate().is_err(), "{bad} accepted");
        }
    }

    #[test]
    fn packet_wire_time_follows_the_line_settings() {
        let mut c = Config::default();
        // 132 bytes x 11 bits / 460800 baud = 3.151 ms.
        assert_eq!(c.packet_wire_ns(), 3_151_041);
        c.sensor.stop_bits = 1;
        c.sensor.baud = 921_600;
        assert_eq!(c.packet_wire_ns(), 1_432_291);
    }
}
