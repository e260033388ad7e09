//! What the realtime loop hands to the other threads: one fixed-size [`CycleRecord`] per cycle
//! to the logger (through a ring), and the latest [`Snapshot`] to telemetry (latest value).

use dima_core::counters::Counters;
use dima_core::safety::Setpoints;
use dima_core::step::CycleOutputs;
use dima_core::{FailsafeCause, Mode, Nanos, ReceivedCommand, ReviveRefusal};
use dima_log::schema::{Event, GroundLinkCounters};
use dima_sensorboard::{InfoFrame, RawPacket, SensorPacket};

use super::rt_loop::MAX_COMMANDS_PER_CYCLE;
use crate::control::ServoTargets;
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
    /// A revive was refused.
    pub const REVIVE_REFUSED: u16 = 1 << 6;
    /// A speed setpoint was rejected.
    pub const SETPOINT_REJECTED: u16 = 1 << 7;
    /// The required realtime setup failed (first record of the run).
    pub const REALTIME_SETUP_FAILED: u16 = 1 << 8;

    use dima_log::schema::Event;

    /// Each bit with the log's event name for it.
    pub const ALL: [(u16, Event); 9] = [
        (SENSOR_CONNECTED, Event::SensorConnected),
        (SENSOR_LOST, Event::SensorLost),
        (SERVO_CONNECTED, Event::ServoConnected),
        (SERVO_LOST, Event::ServoLost),
        (MODE_CHANGED, Event::ModeChanged),
        (REVIVE_REFUSED, Event::ReviveRefused),
        (SETPOINT_REJECTED, Event::SetpointRejected),
        (REALTIME_SETUP_FAILED, Event::RealtimeSetupFailed),
        (SHUTDOWN, Event::Shutdown),
    ];
}

/// The log events of a record's event bits, in a fixed order.
pub fn event_list(bits: u16) -> impl Iterator<Item = Event> {
    events::ALL
        .into_iter()
        .filter(move |(bit, _)| bits & bit != 0)
        .map(|(_, e)| e)
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
    /// The CRC-valid packet received this cycle (whatever its verdict), for replay through
    /// the real decoder.
    pub raw: Option<RawPacket>,
    /// An info frame that arrived this cycle.
    pub info: Option<InfoFrame>,
    /// What the control step decided.
    pub outputs: CycleOutputs,
    /// Manual values and setpoints in force after the cycle.
    pub setpoints: Setpoints,
    /// Commands handed to the step this cycle, with their arrival times: the first
    /// `n_commands`.
    pub commands: [ReceivedCommand; MAX_COMMANDS_PER_CYCLE],
    /// How many of `commands` are real.
    pub n_commands: u8,
    /// Packets passed over as stale while waiting.
    pub stale_passed: u32,
    /// Counters after this cycle.
    pub counters: Counters,
    /// Ground-link counters as the telemetry thread last published them.
    pub link: GroundLinkCounters,
    /// [`events`] bits.
    pub events: u16,
}

impl CycleRecord {
    /// The commands handed to the step this cycle.
    pub fn commands(&self) -> &[ReceivedCommand] {
        &self.commands[..usize::from(self.n_commands)]
    }
}

/// The latest state, for the telemetry thread's display frames.
#[derive(Debug, Clone, Copy)]
pub struct Snapshot {
    /// Last valid packet, decoded.
    pub packet: Option<SensorPacket>,
    /// Mode.
    pub mode: Mode,
    /// Why the robot is or last was in FAILSAFE, until a revive succeeds (a kill keeps it).
    pub cause: Option<FailsafeCause>,
    /// Why the last revive was refused, until a revive succeeds.
    pub refusal: Option<ReviveRefusal>,
    /// Outputs: the servo targets the step commanded this cycle.
    pub targets: ServoTargets,
    /// Manual values and AUTO setpoints in force after the cycle.
    pub setpoints: Setpoints,
    /// Estimated ground speed, mm/s (`None`: no valid estimate).
    pub speed_mm_s: Option<f32>,
    /// Estimated heading, degrees clockwise from north (`None`: no valid estimate).
    pub heading_deg: Option<f32>,
    /// The loop's counters.
    pub counters: Counters,
    /// Monotonic time of this snapshot.
    pub time_ns: Nanos,
}

impl Default for Snapshot {
    fn default() -> Self {
        Snapshot {
            packet: None,
            mode: Mode::Killed,
            cause: None,
            refusal: None,
            targets: ServoTargets::default(),
            setpoints: Setpoints::default(),
            speed_mm_s: None,
            heading_deg: None,
            counters: Counters::default(),
            time_ns: 0,
        }
    }
}
