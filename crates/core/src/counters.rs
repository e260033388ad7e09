//! Every counter of the realtime loop, in one fixed-size struct that is logged with each cycle
//! and in the summary. The control step counts its decisions; the application counts I/O.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Counters since start-up.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Counters {
    /// Cycles run.
    pub cycles: u64,
    /// Periods missed (cyclictest semantics: wake-ups later than a whole period).
    pub missed_periods: u64,
    /// Packets used: valid, paired with their request, in time.
    pub packets_ok: u64,
    /// Cycles where a request got no valid packet by the deadline (or none was made).
    pub packets_missing: u64,
    /// Valid packets that completed sooner than their wire time after the request: an earlier
    /// request's answer (treated as missing).
    pub packets_stale: u64,
    /// Valid packets that completed after the deadline (treated as missing).
    pub packets_late: u64,
    /// Packets rejected by the decoder (CRC or start token), from its stats.
    pub packet_crc_errors: u64,
    /// Bytes the packet decoder skipped.
    pub packet_bytes_skipped: u64,
    /// Info frames received.
    pub info_frames: u64,
    /// Sensor port or request-line errors.
    pub sensor_errors: u64,
    /// New GNSS fixes used (valid, iTOW advancing).
    pub gnss_fixes: u64,
    /// GNSS epochs whose time of week changed but did not advance past the newest fix used
    /// (stepped back, or jumped half a week or more ahead): not used. Absent in older logs.
    #[serde(default)]
    pub gnss_backwards: u64,
    /// Maestro writes done.
    pub servo_writes: u64,
    /// Maestro write errors.
    pub servo_errors: u64,
    /// Cycles where outputs could not be written because the Maestro was missing.
    pub servo_missing: u64,
    /// Commands applied.
    pub commands: u64,
    /// Commands not acted on because they arrived longer than the comms timeout before the
    /// cycle that took them (a kill always acts). Absent in older logs.
    #[serde(default)]
    pub commands_stale: u64,
    /// Setpoints rejected as out of range: speed below 0 or above `control.max_speed_mm_s`,
    /// heading outside 0..36 000 000 (1e-5 degrees).
    pub setpoints_rejected: u64,
    /// Revives refused (sensor loss, stuck IMU, overruns, a failed realtime setup, or too
    /// soon after a kill or revive).
    pub revives_refused: u64,
    /// Log records dropped because the logger ring was full.
    pub log_dropped: u64,
    /// Devices (re)connected.
    pub device_connects: u64,
    /// FAILSAFE entries.
    pub failsafes: u64,
}
