//! The typed log schema: one struct per MCAP message and record, used by the logger to write,
//! by the simulator's checks and the log tools to read, and to generate the JSON schema each
//! channel declares (so the schema can never drift from what is written).
//!
//! Channels (topics), their message encodings and schema names are in [`CHANNELS`]. Log times
//! are Unix-epoch nanoseconds. A field that can be absent is an `Option`, written as `null`,
//! and declared so in the schema.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use dima_core::counters::Counters;
use dima_core::estimate::StateEstimate;
use dima_core::mission::AutoSource;
use dima_core::monitor::PacketVerdict;
use dima_core::safety::{FailsafeCause, Mode, ReceivedCommand, ReviveRefusal};

/// One MCAP channel of the log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChannelSpec {
    /// Topic.
    pub topic: &'static str,
    /// Message encoding.
    pub encoding: &'static str,
    /// Schema name (empty: no schema).
    pub schema_name: &'static str,
}

/// Every valid 132-byte sensor packet exactly as received, for replay through the decoder.
pub const SENSOR_RAW: ChannelSpec = ChannelSpec {
    topic: "/sensor/raw",
    encoding: "dima-sensor-v1",
    schema_name: "",
};
/// One [`CycleMessage`] per cycle (or every n-th).
pub const CYCLE: ChannelSpec = ChannelSpec {
    topic: "/dima/cycle",
    encoding: "json",
    schema_name: "dima.Cycle",
};
/// A [`StateMessage`] on every mode change and event.
pub const STATE: ChannelSpec = ChannelSpec {
    topic: "/dima/state",
    encoding: "json",
    schema_name: "dima.State",
};
/// A [`SensorInfoMessage`] per info frame from the sensor board.
pub const SENSOR_INFO: ChannelSpec = ChannelSpec {
    topic: "/sensor/info",
    encoding: "json",
    schema_name: "dima.SensorInfo",
};

/// All channels, in the order the logger declares them.
pub const CHANNELS: [ChannelSpec; 4] = [SENSOR_RAW, CYCLE, STATE, SENSOR_INFO];

/// Metadata record holding the version and the configuration that ran (`config`: TOML).
pub const METADATA_DIMA: &str = "dima";
/// Metadata record holding the mission and the fence the robot ran with (key `json`: a
/// `dima_core::mission::Navigation`), so that a replay and a plot use what the robot used,
/// not whatever the plan file holds today.
pub const METADATA_NAVIGATION: &str = "navigation";
/// Metadata record holding the realtime setup report.
pub const METADATA_RT_SETUP: &str = "rt_setup";
/// Metadata record holding the [`SummaryRecord`] (key `json`) at exit.
pub const METADATA_SUMMARY: &str = "summary";
/// Attachment holding the wake-up latency histogram in cyclictest's format.
pub const ATTACHMENT_HISTOGRAM: &str = "wake_latency_histogram.txt";

/// The JSON schema (draft 2020-12) of `T`, as the channel declares it.
pub fn json_schema<T: JsonSchema>() -> String {
    serde_json::to_string_pretty(&schemars::schema_for!(T)).unwrap_or_default()
}

/// The schema of a JSON channel by its spec (`None` for a channel without schema).
pub fn schema_of(channel: &ChannelSpec) -> Option<String> {
    match channel.schema_name {
        "dima.Cycle" => Some(json_schema::<CycleMessage>()),
        "dima.State" => Some(json_schema::<StateMessage>()),
        "dima.SensorInfo" => Some(json_schema::<SensorInfoMessage>()),
        "dima.Replay" => Some(json_schema::<ReplayMessage>()),
        _ => None,
    }
}

/// One control cycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima.Cycle")]
pub struct CycleMessage {
    /// Cycle number from 0.
    pub cycle: u64,
    /// Wake-up time on the monotonic clock, ns (the time the step decided with).
    pub wake_ns: u64,
    /// Mode after the cycle.
    pub mode: Mode,
    /// Why FAILSAFE was entered, while in FAILSAFE.
    pub cause: Option<FailsafeCause>,
    /// Wake-up latency: deadline to wake-up, µs.
    pub wake_latency_us: f64,
    /// Whole periods the clock skipped before this wake-up.
    pub missed_periods: u32,
    /// What became of this cycle's sensor packet.
    pub packet: PacketVerdict,
    /// A valid packet, paired with this cycle's request, arrived in time (`packet` is `ok`).
    pub packet_ok: bool,
    /// Request line raised to packet complete, µs; null when no packet arrived.
    pub request_to_packet_us: Option<f64>,
    /// Request line raised, monotonic clock, ns; null without a request.
    pub t_request_ns: Option<u64>,
    /// Packet complete, monotonic clock, ns; null without a packet (the packet itself is on
    /// `/sensor/raw` at the same log time).
    pub t_complete_ns: Option<u64>,
    /// Packets that completed too soon after the request to answer it, passed over.
    pub stale_passed: u32,
    /// Command frames handed to the step this cycle, in arrival order, with their arrival
    /// times (one that arrived longer than the comms timeout before the cycle was not acted on
    /// unless it was a kill: see `counters.commands_stale`).
    pub commands: Vec<CommandMessage>,
    /// Packet (or wake-up, without one) to outputs computed, µs.
    pub compute_us: f64,
    /// Servo write time, µs; null in cycles without a write.
    pub servo_write_us: Option<f64>,
    /// The packet used this cycle, decoded; null without one.
    pub sensor: Option<SensorMessage>,
    /// Age of the newest fresh GNSS fix, ms; null before the first.
    pub gnss_age_ms: Option<f64>,
    /// What the ground station asked for.
    pub setpoints: SetpointsMessage,
    /// Controller output, fractions of travel around neutral (-1..=1).
    pub action: ActionMessage,
    /// Servo targets: throttle, steering, tail, µs (0: no pulses).
    pub targets_us: [u16; 3],
    /// Counters since start-up.
    pub counters: Counters,
    /// Ground-link frame counters since start-up, as the telemetry thread last published them
    /// (absent from logs written before ground link v2: read as zeros).
    #[serde(default)]
    pub link: GroundLinkCounters,
    /// Where AUTO's heading and speed setpoints came from: `setpoints` (the operator's) or
    /// `mission` (the path follower, along `navigation.mission_file`); null outside AUTO (and
    /// in logs written before missions).
    #[serde(default)]
    pub auto_source: Option<AutoSource>,
    /// Index of the mission's current waypoint while AUTO follows a mission (the last one once
    /// it is finished); null otherwise.
    #[serde(default)]
    pub waypoint: Option<u32>,
    /// Distance from the mission's current leg, m, positive right of the track, while AUTO
    /// follows a mission; null otherwise.
    #[serde(default)]
    pub cross_track_m: Option<f64>,
}

/// What the telemetry thread did with the command frames it received since start-up.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(default)]
pub struct GroundLinkCounters {
    /// Authenticated v2 commands accepted (kills included).
    pub v2_accepted: u64,
    /// v2 frames rejected: the tag did not match (forged, corrupt, another key).
    pub bad_tag: u64,
    /// v2 frames rejected: sequence number not newer than the last accepted one.
    pub replayed: u64,
    /// v2 frames rejected: authentic but for another session.
    pub stale_session: u64,
    /// v2 frames rejected: wrong length, unknown type or out-of-range data.
    pub malformed: u64,
    /// Authentic v2 kills accepted from another session or with an old sequence number.
    pub kills_outside_window: u64,
    /// v2 revives accepted but not acted on: repetitions of an operator request the robot
    /// already acted on (taken as heartbeats; included in `v2_accepted`).
    pub revive_repeats: u64,
    /// v2 manual commands and setpoints accepted but not acted on: their operator request is
    /// older than the last revive the robot acted on, a value given while the robot was KILLED
    /// or in FAILSAFE that the station kept repeating (taken as heartbeats; included in
    /// `v2_accepted`; absent from older logs: read as 0).
    pub pre_revive_requests: u64,
    /// v1 commands accepted (only with `xbee.require_auth = false`).
    pub v1_accepted: u64,
    /// Valid v1 commands ignored because `xbee.require_auth = true`.
    pub v1_ignored: u64,
    /// v1 frames with a valid CRC rejected (unknown type, out-of-range data).
    pub v1_rejected: u64,
    /// v1 candidates (a `$` and nine bytes) whose CRC did not match: line noise, and `$` bytes
    /// inside v2 frames while both versions are decoded; not counted in [`rejected`](Self::rejected).
    pub v1_crc_errors: u64,
}

impl GroundLinkCounters {
    /// Every command frame rejected or ignored, whatever the reason.
    pub fn rejected(&self) -> u64 {
        self.bad_tag
            + self.replayed
            + self.stale_session
            + self.malformed
            + self.v1_ignored
            + self.v1_rejected
    }
}

/// One ground-link command as on the wire (type byte and data field).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct CommandMessage {
    /// Command type: 0 heartbeat, 1 kill, 2 revive, 3 throttle, 4 steering, 5 tail (percent),
    /// 6 speed setpoint (mm/s), 7 heading setpoint (1e-5 degrees).
    #[serde(rename = "type")]
    pub kind: u8,
    /// The data field.
    pub data: i32,
    /// When the frame arrived, monotonic clock, ns (the earliest time it can have been
    /// complete at the port); absent from logs written before it (and from commands not
    /// logged by a cycle): taken as the cycle's `wake_ns`.
    #[serde(default)]
    pub arrival_ns: Option<u64>,
}

impl From<dima_groundlink::Command> for CommandMessage {
    /// The command alone, without an arrival time.
    fn from(c: dima_groundlink::Command) -> Self {
        CommandMessage {
            kind: c.command_type() as u8,
            data: c.data(),
            arrival_ns: None,
        }
    }
}

impl From<ReceivedCommand> for CommandMessage {
    fn from(r: ReceivedCommand) -> Self {
        CommandMessage {
            arrival_ns: Some(r.arrival_ns),
            ..CommandMessage::from(r.command)
        }
    }
}

impl CommandMessage {
    /// The command, if the type is known and the data in range.
    pub fn command(&self) -> Option<dima_groundlink::Command> {
        let kind = dima_groundlink::CommandType::from_byte(self.kind)?;
        dima_groundlink::Command::from_parts(kind, self.data).ok()
    }

    /// The command with its arrival time, as the step of a cycle at `cycle_wake_ns` took it
    /// (a command logged without an arrival time arrived at `cycle_wake_ns`).
    pub fn received(&self, cycle_wake_ns: u64) -> Option<ReceivedCommand> {
        let arrival_ns = self.arrival_ns.unwrap_or(cycle_wake_ns);
        Some(ReceivedCommand::new(self.command()?, arrival_ns))
    }
}

/// One decoded sensor packet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SensorMessage {
    /// Accelerometer X, Y, Z, raw 12-bit counts (±2 g: 2 g over 2048 counts, 1000/1024 mg per count).
    pub accel: [i16; 3],
    /// Gyroscope X, Y, Z, raw counts (±2000 °/s: 1/16.4 °/s per count).
    pub gyro: [i16; 3],
    /// Magnetometer X, Y, Z, raw counts.
    pub mag: [i16; 3],
    /// Magnetometer Hall resistance, raw.
    pub rhall: u16,
    /// BMP280 raw 20-bit pressure ADC value.
    pub press_raw: u32,
    /// BMP280 raw 20-bit temperature ADC value.
    pub temp_raw: u32,
    /// Gyroscope Z rate, °/s.
    pub gyro_z_dps: f32,
    /// The NAV-PVT carried is a valid position fix (gnssFixOK, 2-D/3-D).
    pub gnss_fix_ok: bool,
    /// GNSS time of week, ms; null without NAV-PVT.
    pub itow_ms: Option<u32>,
    /// Latitude, degrees; null without NAV-PVT.
    pub lat_deg: Option<f64>,
    /// Longitude, degrees; null without NAV-PVT.
    pub lon_deg: Option<f64>,
    /// Ground speed, mm/s; null without NAV-PVT.
    pub g_speed_mm_s: Option<i32>,
    /// Heading of motion, degrees; null without NAV-PVT.
    pub head_mot_deg: Option<f64>,
    /// Satellites used; null without NAV-PVT.
    pub num_sv: Option<u8>,
}

/// The ground station's manual values and setpoints in force.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SetpointsMessage {
    /// Manual throttle, percent; null: neutral.
    pub throttle_pct: Option<u8>,
    /// Manual steering, percent; null: neutral.
    pub steering_pct: Option<u8>,
    /// Manual tail, percent; null: neutral.
    pub tail_pct: Option<u8>,
    /// AUTO ground speed setpoint, mm/s; null: none.
    pub speed_mm_s: Option<i32>,
    /// AUTO heading setpoint, degrees clockwise from north; null: none.
    pub heading_deg: Option<f64>,
}

/// Controller output.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ActionMessage {
    /// Throttle, fraction of travel around neutral (+ forward).
    pub throttle: f32,
    /// Steering, fraction of travel around neutral.
    pub steering: f32,
    /// Tail, fraction of travel around neutral.
    pub tail: f32,
}

/// Something that happened in a cycle. In logs in snake case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Event {
    /// The sensor board was (re)connected.
    SensorConnected,
    /// The sensor board failed and was handed back for reopening.
    SensorLost,
    /// The Maestro was (re)connected.
    ServoConnected,
    /// The Maestro failed and was handed back for reopening.
    ServoLost,
    /// The mode changed.
    ModeChanged,
    /// A revive was refused (see `refused`).
    ReviveRefused,
    /// A speed setpoint was rejected as out of range.
    SetpointRejected,
    /// The required realtime setup failed: KILLED for the whole run.
    RealtimeSetupFailed,
    /// Last record: shutdown with safe outputs.
    Shutdown,
}

/// A mode change or device event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima.State")]
pub struct StateMessage {
    /// Cycle number.
    pub cycle: u64,
    /// Mode after the cycle.
    pub mode: Mode,
    /// Why FAILSAFE was entered, while in FAILSAFE.
    pub cause: Option<FailsafeCause>,
    /// Why a revive was refused this cycle.
    pub refused: Option<ReviveRefusal>,
    /// What happened.
    pub events: Vec<Event>,
}

/// A sensor-board info frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima.SensorInfo")]
pub struct SensorInfoMessage {
    /// Info frame layout version.
    pub version: u8,
    /// Firmware version, major, minor, patch.
    pub firmware: [u8; 3],
    /// Status bits (accel, gyro, mag, BMP280 found; GNSS seen).
    pub status: u8,
    /// BMP280 calibration registers 0x88..0xA1 as read.
    pub bmp280_calibration: Vec<u8>,
    /// BMM150 trim registers as read.
    pub bmm150_trim: Vec<u8>,
    /// Board uptime, ms.
    pub uptime_ms: u32,
    /// Requests the board skipped because an answer was still going out.
    pub requests_skipped: u32,
    /// The board's health counters (version 2 frames; zero from version 1).
    pub health: BoardHealthMessage,
}

/// The board's health since boot, as its info frame reports it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct BoardHealthMessage {
    /// Failed SPI transfers with the accelerometer.
    pub accel_errors: u32,
    /// Failed SPI transfers with the gyroscope.
    pub gyro_errors: u32,
    /// Failed SPI transfers with the magnetometer.
    pub mag_errors: u32,
    /// Failed SPI transfers with the BMP280.
    pub bmp280_errors: u32,
    /// Magnetometer measurements that never became ready.
    pub mag_timeout_errors: u32,
    /// DMA transfer errors on the link to the host.
    pub dma_errors: u32,
    /// Requests that came before the first packet existed.
    pub requests_early: u32,
    /// GNSS bytes dropped outside valid UBX frames.
    pub gnss_bytes_dropped: u32,
    /// GNSS UBX frames with a bad checksum.
    pub gnss_frame_errors: u32,
    /// Resets by the watchdog since power-on.
    pub watchdog_resets: u32,
    /// Time since each sensor's last good read, ms: accelerometer, gyroscope, magnetometer,
    /// BMP280.
    pub last_good_read_age_ms: [u16; 4],
}

impl From<&dima_sensorboard::BoardHealth> for BoardHealthMessage {
    fn from(h: &dima_sensorboard::BoardHealth) -> Self {
        BoardHealthMessage {
            accel_errors: h.accel_errors,
            gyro_errors: h.gyro_errors,
            mag_errors: h.mag_errors,
            bmp280_errors: h.bmp280_errors,
            mag_timeout_errors: h.mag_timeout_errors,
            dma_errors: h.dma_errors,
            requests_early: h.requests_early,
            gnss_bytes_dropped: h.gnss_bytes_dropped,
            gnss_frame_errors: h.gnss_frame_errors,
            watchdog_resets: h.watchdog_resets,
            last_good_read_age_ms: [h.accel_age_ms, h.gyro_age_ms, h.mag_age_ms, h.bmp280_age_ms],
        }
    }
}

impl From<&dima_sensorboard::InfoFrame> for SensorInfoMessage {
    fn from(info: &dima_sensorboard::InfoFrame) -> Self {
        SensorInfoMessage {
            version: info.version,
            firmware: info.firmware,
            status: info.status.bits(),
            bmp280_calibration: info.bmp280_calibration.to_vec(),
            bmm150_trim: info.bmm150_trim.to_vec(),
            uptime_ms: info.uptime_ms,
            requests_skipped: info.requests_skipped,
            health: (&info.health).into(),
        }
    }
}

/// Topic of the replayed outputs in a file written by `dima log replay`.
pub const REPLAY: ChannelSpec = ChannelSpec {
    topic: "/replay/cycle",
    encoding: "json",
    schema_name: "dima.Replay",
};

/// One cycle replayed through the control step, beside what was recorded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima.Replay")]
pub struct ReplayMessage {
    /// Cycle number.
    pub cycle: u64,
    /// Replayed mode.
    pub mode: Mode,
    /// Replayed failsafe cause.
    pub cause: Option<FailsafeCause>,
    /// Replayed controller output, fractions of travel around neutral.
    pub action: ActionMessage,
    /// The state estimate the controllers read in this cycle (what a new controller or
    /// estimator setting would have seen on the recorded drive).
    pub estimate: StateEstimate,
    /// Replayed servo targets: throttle, steering, tail, µs.
    pub targets_us: [u16; 3],
    /// Recorded mode.
    pub recorded_mode: Mode,
    /// Recorded servo targets, µs.
    pub recorded_targets_us: [u16; 3],
}

/// Minimum, mean and maximum of a duration, µs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct DurationStats {
    /// Samples.
    pub count: u64,
    /// Smallest, µs.
    pub min_us: f64,
    /// Mean, µs.
    pub mean_us: f64,
    /// Largest, µs.
    pub max_us: f64,
}

/// The run's totals, in the `summary` metadata record (key `json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima.Summary")]
pub struct SummaryRecord {
    /// Counters at exit.
    pub counters: Counters,
    /// Wake-up latency.
    pub wake_latency: DurationStats,
    /// Request to packet complete.
    pub request_to_packet: DurationStats,
    /// Packet (or wake-up) to outputs computed.
    pub compute: DurationStats,
    /// Maestro write.
    pub servo_write: DurationStats,
    /// Ground-link frame counters at exit (absent from logs written before ground link v2).
    #[serde(default)]
    pub link: GroundLinkCounters,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rollover_and_geofence_are_logged_by_name_and_in_the_schema() {
        let state = StateMessage {
            cycle: 7,
            mode: Mode::Failsafe,
            cause: Some(FailsafeCause::Geofence),
            refused: Some(ReviveRefusal::OutsideFence),
            events: Vec::new(),
        };
        let json = serde_json::to_value(&state).unwrap();
        assert_eq!(json["cause"], "Geofence");
        assert_eq!(json["refused"], "OutsideFence");
        let back: StateMessage = serde_json::from_value(json).unwrap();
        assert_eq!(back, state);
        let rolled = serde_json::json!({
            "cycle": 8, "mode": "FAILSAFE", "cause": "Rollover", "refused": "RolledOver",
            "events": [],
        });
        let rolled: StateMessage = serde_json::from_value(rolled).unwrap();
        assert_eq!(
            (rolled.cause, rolled.refused),
            (
                Some(FailsafeCause::Rollover),
                Some(ReviveRefusal::RolledOver)
            )
        );
        let schema = json_schema::<StateMessage>();
        for name in ["Rollover", "Geofence", "RolledOver", "OutsideFence"] {
            assert!(schema.contains(&format!("\"{name}\"")), "{name}");
        }
    }

    #[test]
    fn schemas_carry_the_contract_names_and_units() {
        let cycle: serde_json::Value =
            serde_json::from_str(&json_schema::<CycleMessage>()).unwrap();
        assert_eq!(cycle["title"], "dima.Cycle");
        assert_eq!(
            cycle["$schema"],
            "https://json-schema.org/draft/2020-12/schema"
        );
        let latency = &cycle["properties"]["request_to_packet_us"];
        assert!(latency["description"].as_str().unwrap().contains("µs"));
        assert_eq!(latency["type"], serde_json::json!(["number", "null"]));
        for name in ["dima.Cycle", "dima.State", "dima.SensorInfo"] {
            let spec = CHANNELS.iter().find(|c| c.schema_name == name).unwrap();
            let schema: serde_json::Value =
                serde_json::from_str(&schema_of(spec).unwrap()).unwrap();
            assert_eq!(schema["title"], name);
        }
        assert_eq!(schema_of(&SENSOR_RAW), None);
    }

    #[test]
    fn command_arrival_times_and_stale_counts_are_optional_for_older_logs() {
        let cycle: serde_json::Value =
            serde_json::from_str(&json_schema::<CycleMessage>()).unwrap();
        let command = &cycle["$defs"]["CommandMessage"];
        let required = command["required"].as_array().unwrap();
        assert!(required.iter().any(|k| k == "type"));
        assert!(!required.iter().any(|k| k == "arrival_ns"));
        assert!(command["properties"]["arrival_ns"]["description"]
            .as_str()
            .unwrap()
            .contains("ns"));
        let counters = &cycle["$defs"]["Counters"];
        assert!(counters["properties"]["commands_stale"].is_object());
        assert!(!counters["required"]
            .as_array()
            .unwrap()
            .iter()
            .any(|k| k == "commands_stale"));

        let revive = dima_groundlink::Command::Revive;
        let old: CommandMessage = serde_json::from_str(r#"{"type": 2, "data": 0}"#).unwrap();
        assert_eq!(old.arrival_ns, None);
        assert_eq!(
            old.received(7_000),
            Some(ReceivedCommand::new(revive, 7_000))
        );
        let logged = CommandMessage::from(ReceivedCommand::new(revive, 5_000));
        let text = serde_json::to_string(&logged).unwrap();
        assert_eq!(text, r#"{"type":2,"data":0,"arrival_ns":5000}"#);
        let read: CommandMessage = serde_json::from_str(&text).unwrap();
        assert_eq!(
            read.received(7_000),
            Some(ReceivedCommand::new(revive, 5_000))
        );
        let counters: Counters = serde_json::from_value(serde_json::json!({
            "cycles": 1, "missed_periods": 0, "packets_ok": 0, "packets_missing": 0,
            "packets_stale": 0, "packets_late": 0, "packet_crc_errors": 0,
            "packet_bytes_skipped": 0, "info_frames": 0, "sensor_errors": 0, "gnss_fixes": 0,
            "servo_writes": 0, "servo_errors": 0, "servo_missing": 0, "commands": 3,
            "setpoints_rejected": 0, "revives_refused": 0, "log_dropped": 0,
            "device_connects": 0, "failsafes": 0,
        }))
        .unwrap();
        assert_eq!((counters.commands, counters.commands_stale), (3, 0));
    }

    #[test]
    fn link_counters_are_optional_for_older_logs() {
        let cycle: serde_json::Value =
            serde_json::from_str(&json_schema::<CycleMessage>()).unwrap();
        let required = cycle["required"].as_array().unwrap();
        assert!(required.iter().any(|k| k == "counters"));
        assert!(!required.iter().any(|k| k == "link"));
        assert!(cycle["properties"]["link"].is_object());
        let summary: SummaryRecord = serde_json::from_value(serde_json::json!({
            "counters": Counters::default(),
            "wake_latency": DurationStats::default(),
            "request_to_packet": DurationStats::default(),
            "compute": DurationStats::default(),
            "servo_write": DurationStats::default(),
        }))
        .unwrap();
        assert_eq!(summary.link, GroundLinkCounters::default());
    }

    #[test]
    fn link_counters_of_older_logs_read_new_fields_as_zero() {
        let link = &serde_json::from_str::<serde_json::Value>(&json_schema::<CycleMessage>())
            .unwrap()["$defs"]["GroundLinkCounters"];
        let properties = link["properties"].as_object().unwrap();
        assert!(properties.contains_key("revive_repeats"));
        assert!(properties["pre_revive_requests"]["description"]
            .as_str()
            .unwrap()
            .contains("older than the last revive"));
        assert!(link.get("required").is_none(), "{link}");
        // Written before the counter existed.
        let old: GroundLinkCounters =
            serde_json::from_value(serde_json::json!({ "v2_accepted": 5, "revive_repeats": 2 }))
                .unwrap();
        assert_eq!((old.revive_repeats, old.pre_revive_requests), (2, 0));
        let new = GroundLinkCounters {
            pre_revive_requests: 3,
            ..GroundLinkCounters::default()
        };
        let json = serde_json::to_value(new).unwrap();
        assert_eq!(json["pre_revive_requests"], 3);
        assert_eq!(
            serde_json::from_value::<GroundLinkCounters>(json).unwrap(),
            new
        );
    }
}
