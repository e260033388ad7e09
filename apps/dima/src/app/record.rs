//! What the realtime loop hands to the other threads: one fixed-size [`CycleRecord`] per cycle
//! to the logger (through a ring), and the latest [`Snapshot`] to telemetry (latest value).

use dima_sensorboard::{InfoFrame, RawPacket, SensorPacket};

use crate::control::{Actuation, Nanos, SafetyState, SensorValues, ServoTargets};
use crate::metrics::Counters;
use crate::rt::Tick;

/// Event bits of a cycle record.
pub mod events {
    /// The sensor board was (re)connected this cycle.
    pub const SENSOR_CONNECTED: u16 = 1 << 0;
    /// The sensor board failed this cycle and was handed back for reopening.
    pub const SENSOR_LOST: u16 = 1 << 1;
    /// The Maestro was (re)connected this cycle.
    pub const SERVO_CONNECTED: u16 = 1 << 2;
    /// The Maestro failed this cycle and was handed back for reopening.
    pub const SERVO_LOST: u16 = 1 << 3;
    /// The mode changed this cycle.
    pub const MODE_CHANGED: u16 = 1 << 4;
    /// Last record: shutdown with safe outputs.
    pub const SHUTDOWN: u16 = 1 << 5;
}

/// Everything about one cycle, fixed size, `Copy`: no allocation to produce or hand over.
#[derive(Debug, Clone, Copy)]
pub struct CycleRecord {
    /// Cycle number from 0.
    pub cycle: u64,
    /// Deadline, wake time, latency and missed periods.
    pub tick: Tick,
    /// Request line raised (0: no request this cycle).
    pub t_request_ns: Nanos,
    /// Packet complete (0: none).
    pub t_packet_ns: Nanos,
    /// State machine and controller done.
    pub t_compute_ns: Nanos,
    /// Servo write done (0: nothing written).
    pub t_write_ns: Nanos,
    /// The raw packet, CRC-checked, for replay through the real decoder.
    pub packet: Option<RawPacket>,
    /// An info frame that arrived this cycle.
    pub info: Option<InfoFrame>,
    /// Controller inputs from the packet (held from the last good packet when missing).
    pub values: SensorValues,
    /// Controller output.
    pub action: Actuation,
    /// Outputs for this cycle.
    pub targets: ServoTargets,
    /// Safety state after this cycle.
    pub safety: SafetyState,
    /// Counters after this cycle.
    pub counters: Counters,
    /// [`events`] bits.
    pub events: u16,
}

/// The latest state, for the telemetry thread's display frames.
#[derive(Debug, Clone, Copy, Default)]
pub struct Snapshot {
    /// Last valid packet, decoded.
    pub packet: Option<SensorPacket>,
    /// Safety state.
    pub safety: SafetyState,
    /// Outputs.
    pub targets: ServoTargets,
    /// Monotonic time of this snapshot.
    pub time_ns: Nanos,
}
