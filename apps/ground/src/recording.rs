//! Session recording: everything the station sends and receives, timestamped, in an MCAP file
//! (readable by Foxglove and the `mcap` Python package).
//!
//! | topic | encoding | content |
//! |---|---|---|
//! | `/ground/command` | json ([`CommandRecord`]) | every command frame sent (v2: session and sequence number) |
//! | `/ground/display` | json ([`DisplayRecord`]) | every valid display frame, raw fields and SI (v2: the robot's mode, acknowledgement and counters) |
//! | `/ground/ack` | json ([`DeliveryRecord`]) | v2: what became of each requested command (acknowledged, given up, dropped) |
//! | `/ground/rx_bytes` | `dima-ground-bytes` | every chunk of bytes read, as read (replayable) |
//! | `/ground/link` | json ([`LinkRecord`]) | connects, disconnects, errors |
//!
//! Log and publish times are Unix-epoch nanoseconds of the moment the link thread sent or read
//! the bytes. The writer runs on its own thread, so a slow disk never delays the link; the
//! current chunk is closed every second, so a crash loses at most the last second.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use anyhow::Context;
use dima_groundlink::station::{Delivery, Settled};
use dima_groundlink::v2::{self, CommandFrame, FailsafeCause, ReviveRefusal, RobotMode};
use dima_groundlink::{Command, DisplayFrame};
use dima_log::schema::ChannelSpec;
use dima_log::writer::{Channel, McapLog};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::units::{Baro, MagField, Physical};

/// Topic of the commands sent.
pub const TOPIC_COMMAND: &str = "/ground/command";
/// Topic of the display frames received.
pub const TOPIC_DISPLAY: &str = "/ground/display";
/// Topic of the raw bytes received.
pub const TOPIC_RX_BYTES: &str = "/ground/rx_bytes";
/// Topic of link events.
pub const TOPIC_LINK: &str = "/ground/link";
/// Topic of command deliveries (v2).
pub const TOPIC_ACK: &str = "/ground/ack";

/// One command frame as sent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima_ground.Command")]
pub struct CommandRecord {
    /// Command type (0 heartbeat, 1 kill, 2 revive, 3-5 throttle/steering/tail, 6 speed,
    /// 7 heading).
    pub kind: u8,
    /// The type's name.
    pub name: String,
    /// The data field (percent, mm/s or 1e-5 degrees).
    pub data: i32,
    /// The frame as sent, hexadecimal (v1: 10 bytes, v2: 24 bytes).
    pub frame_hex: String,
    /// v2: the session id the frame carries (0 before the station knew it); null for v1.
    #[serde(default)]
    pub session: Option<u32>,
    /// v2: the frame's sequence number; null for v1.
    #[serde(default)]
    pub seq: Option<u32>,
}

impl CommandRecord {
    /// The record of a v1 `command`.
    pub fn new(command: Command) -> CommandRecord {
        CommandRecord {
            kind: command.command_type() as u8,
            name: format!("{:?}", command.command_type()),
            data: command.data(),
            frame_hex: hex(&command.encode()),
            session: None,
            seq: None,
        }
    }

    /// The record of a v2 `frame`, sent as `bytes`.
    pub fn v2(frame: &CommandFrame, bytes: &[u8]) -> CommandRecord {
        CommandRecord {
            frame_hex: hex(bytes),
            session: Some(frame.session),
            seq: Some(frame.seq),
            ..CommandRecord::new(frame.command)
        }
    }
}

/// What became of a requested command (v2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima_ground.Delivery")]
pub struct DeliveryRecord {
    /// Command type.
    pub kind: u8,
    /// The type's name.
    pub name: String,
    /// The data field.
    pub data: i32,
    /// `acknowledged`, `unacknowledged` (given up), `superseded`, `cancelled` (by a kill),
    /// `robot_restarted`, `cancelled_by_revive` (a manual value or setpoint asked for before a
    /// revive) or `cancelled_robot_safe` (a manual value or setpoint dropped when the robot
    /// reported KILLED or FAILSAFE).
    pub outcome: String,
    /// The acknowledged sequence number (null unless acknowledged).
    pub ack_seq: Option<u32>,
    /// Frames sent with the command.
    pub transmissions: u32,
    /// Sequence numbers of its first and latest frame (null before it went out).
    pub first_seq: Option<u32>,
    /// Sequence number of its latest frame.
    pub last_seq: Option<u32>,
    /// From the request to the outcome, ms.
    pub latency_ms: f64,
    /// A revive the robot accepted while it still reported KILLED or FAILSAFE (refused then).
    pub accepted_but_refused: bool,
}

impl DeliveryRecord {
    /// The record of a settled command.
    pub fn new(settled: &Settled) -> DeliveryRecord {
        let s = &settled.status;
        let (outcome, ack_seq) = match s.delivery {
            Delivery::Acknowledged { seq } => ("acknowledged", Some(seq)),
            Delivery::Pending => ("pending", None),
            Delivery::Unacknowledged => ("unacknowledged", None),
            Delivery::Superseded => ("superseded", None),
            Delivery::Cancelled => ("cancelled", None),
            Delivery::RobotRestarted => ("robot_restarted", None),
            Delivery::CancelledByRevive => ("cancelled_by_revive", None),
            Delivery::CancelledRobotSafe => ("cancelled_robot_safe", None),
        };
        DeliveryRecord {
            kind: s.command.command_type() as u8,
            name: format!("{:?}", s.command.command_type()),
            data: s.command.data(),
            outcome: outcome.into(),
            ack_seq,
            transmissions: s.transmissions,
            first_seq: s.first_seq,
            last_seq: s.last_seq,
            latency_ms: settled.at.saturating_sub(s.requested_at).as_secs_f64() * 1e3,
            accepted_but_refused: s.accepted_but_refused,
        }
    }
}

/// The robot's own report in a display frame v2 or v3.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima_ground.Robot")]
pub struct RobotRecord {
    /// `KILLED`, `MANUAL`, `AUTO` or `FAILSAFE`.
    pub mode: String,
    /// Why it is (or last was) in FAILSAFE (null: not since the last revive).
    pub failsafe_cause: Option<String>,
    /// Why it refused the last revive (null: it did not).
    pub revive_refusal: Option<String>,
    /// Its session id.
    pub session: u32,
    /// The frame's downlink sequence number.
    pub seq: u32,
    /// The last command sequence number it accepted (the acknowledgement).
    pub ack_seq: u32,
    /// Loop periods missed.
    pub missed_periods: u32,
    /// Sensor packets rejected.
    pub sensor_bad: u32,
    /// Cycles without a sensor packet.
    pub sensor_missing: u32,
    /// Commands it accepted.
    pub commands: u32,
    /// Command frames it rejected: tag did not match.
    pub rejected_bad_tag: u32,
    /// Command frames it rejected: sequence number not newer than the last accepted one.
    pub rejected_replayed: u32,
    /// Command frames it rejected: another session.
    pub rejected_stale_session: u32,
    /// Command frames it rejected: malformed.
    pub rejected_malformed: u32,
    /// Version 1 command frames it ignored.
    pub v1_ignored: u32,
    /// Display frames the station rejected so far for a bad tag.
    pub station_bad_tag: u64,
    /// Display frame v3: the servo targets the robot commanded (throttle, steering, tail),
    /// microseconds (null: a display frame v2, which does not carry them).
    #[serde(default)]
    pub servo_us: Option<[u16; 3]>,
    /// Display frame v3: the AUTO speed setpoint in force, mm/s (null: none, or a v2 frame).
    #[serde(default)]
    pub speed_setpoint_mm_s: Option<i32>,
    /// Display frame v3: the AUTO heading setpoint in force, 1e-5 degrees (null: none, or a
    /// v2 frame).
    #[serde(default)]
    pub heading_setpoint_deg_e5: Option<i32>,
}

impl RobotRecord {
    /// The record of a display frame v2 or v3; `station_bad_tag` is the station's own count.
    pub fn from_downlink(downlink: &v2::Downlink, station_bad_tag: u64) -> RobotRecord {
        let mut record = RobotRecord::new(downlink.status(), station_bad_tag);
        if let Some(a) = downlink.actuation() {
            record.servo_us = Some(a.servo_us());
            record.speed_setpoint_mm_s = a.speed_setpoint_mm_s;
            record.heading_setpoint_deg_e5 = a.heading_setpoint_deg_e5;
        }
        record
    }

    /// The record of `frame`; `station_bad_tag` is the station's own count.
    pub fn new(frame: &v2::DisplayFrame, station_bad_tag: u64) -> RobotRecord {
        let h = frame.health;
        RobotRecord {
            mode: mode_name(frame.mode).into(),
            failsafe_cause: frame.failsafe_cause.map(cause_name),
            revive_refusal: frame.revive_refusal.map(refusal_name),
            session: frame.session,
            seq: frame.seq,
            ack_seq: frame.ack_seq,
            missed_periods: h.missed_periods,
            sensor_bad: h.sensor_bad,
            sensor_missing: h.sensor_missing,
            commands: h.commands,
            rejected_bad_tag: h.bad_tag,
            rejected_replayed: h.replayed,
            rejected_stale_session: h.stale_session,
            rejected_malformed: h.malformed,
            v1_ignored: h.v1_ignored,
            station_bad_tag,
            servo_us: None,
            speed_setpoint_mm_s: None,
            heading_setpoint_deg_e5: None,
        }
    }
}

/// The robot's name for `mode`.
pub fn mode_name(mode: RobotMode) -> &'static str {
    match mode {
        RobotMode::Killed => "KILLED",
        RobotMode::Manual => "MANUAL",
        RobotMode::Auto => "AUTO",
        RobotMode::Failsafe => "FAILSAFE",
    }
}

/// A failsafe cause in words.
pub fn cause_name(cause: FailsafeCause) -> String {
    match cause {
        FailsafeCause::CommsLoss => "comms loss".into(),
        FailsafeCause::SensorLoss => "sensor loss".into(),
        FailsafeCause::ImuStuck => "IMU stuck".into(),
        FailsafeCause::Overrun => "loop overruns".into(),
        FailsafeCause::GnssStale => "GNSS stale".into(),
        FailsafeCause::Rollover => "rolled over".into(),
        FailsafeCause::Geofence => "left the geofence".into(),
        FailsafeCause::Other(code) => format!("cause {code}"),
    }
}

/// A revive refusal in words.
pub fn refusal_name(refusal: ReviveRefusal) -> String {
    match refusal {
        ReviveRefusal::SensorLoss => "sensor loss".into(),
        ReviveRefusal::ImuStuck => "IMU stuck".into(),
        ReviveRefusal::Overrun => "loop overruns".into(),
        ReviveRefusal::RealtimeSetup => "realtime setup failed".into(),
        ReviveRefusal::TooSoon => "too soon after a kill or revive".into(),
        ReviveRefusal::RolledOver => "not on its wheels".into(),
        ReviveRefusal::OutsideFence => "outside the geofence, or no GNSS fix".into(),
        ReviveRefusal::Other(code) => format!("refusal {code}"),
    }
}

/// What the operator should know beyond the name when the robot's loop overran (a FAILSAFE
/// `Overrun` or a revive refused for it): the robot's computer, not the car, fell behind; for
/// a simulated robot that computer is this one. `None` for every other cause.
pub fn overrun_advice(
    cause: Option<FailsafeCause>,
    refusal: Option<ReviveRefusal>,
) -> Option<&'static str> {
    let overrun = cause == Some(FailsafeCause::Overrun) || refusal == Some(ReviveRefusal::Overrun);
    overrun.then_some(
        "the robot's computer did not run the control loop on time (too busy); with --sim that \
         is this machine: a lower --loop-rate, a larger safety.overrun_limit or realtime \
         priority helps",
    )
}

/// One display frame: the values on the wire and in physical units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima_ground.Display")]
pub struct DisplayRecord {
    /// Accelerometer counts X, Y, Z.
    pub acc: [i16; 3],
    /// Gyroscope counts X, Y, Z.
    pub gyro: [i16; 3],
    /// Magnetometer counts X, Y, Z (before trim compensation).
    pub mag: [i16; 3],
    /// Magnetometer hall resistance.
    pub mag_hall: u16,
    /// BMP280 raw pressure.
    pub baro_press: u32,
    /// BMP280 raw temperature.
    pub baro_temp: u32,
    /// Acceleration, m/s².
    pub acc_m_s2: [f32; 3],
    /// Angular rate, °/s.
    pub gyro_dps: [f32; 3],
    /// Magnetic field, µT (null without the trim).
    pub mag_ut: Option<[f32; 3]>,
    /// Pressure, Pa (null without the calibration).
    pub pressure_pa: Option<f32>,
    /// Temperature, °C (null without the calibration).
    pub temperature_c: Option<f32>,
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Velocity north, east, down, m/s.
    pub vel_ned_m_s: [f64; 3],
    /// Height above the ellipsoid, m.
    pub height_m: f64,
    /// Height above mean sea level, m.
    pub h_msl_m: f64,
    /// Ground speed, m/s.
    pub ground_speed_m_s: f64,
    /// Heading of motion, degrees.
    pub heading_deg: f64,
    /// v2: the robot's mode, acknowledgement and counters (null for v1).
    #[serde(default)]
    pub robot: Option<RobotRecord>,
}

impl DisplayRecord {
    /// The record of `frame`, converted as `physical`.
    pub fn new(frame: &DisplayFrame, physical: &Physical) -> DisplayRecord {
        let (pressure_pa, temperature_c) = match physical.baro {
            Baro::Compensated {
                pressure_pa,
                temperature_c,
            } => (pressure_pa, Some(temperature_c)),
            Baro::Raw { .. } => (None, None),
        };
        DisplayRecord {
            acc: frame.acc,
            gyro: frame.gyro,
            mag: frame.mag,
            mag_hall: frame.mag_hall,
            baro_press: frame.baro_press,
            baro_temp: frame.baro_temp,
            acc_m_s2: physical.acc_m_s2,
            gyro_dps: physical.gyro_dps,
            mag_ut: match physical.mag {
                MagField::MicroTesla(v) => Some(v),
                MagField::Raw(..) => None,
            },
            pressure_pa,
            temperature_c,
            lat_deg: physical.lat_deg,
            lon_deg: physical.lon_deg,
            vel_ned_m_s: physical.vel_ned_m_s,
            height_m: physical.height_m,
            h_msl_m: physical.h_msl_m,
            ground_speed_m_s: physical.ground_speed_m_s,
            heading_deg: physical.heading_deg,
            robot: None,
        }
    }
}

/// A link event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(title = "dima_ground.Link")]
pub struct LinkRecord {
    /// What happened: `connected`, `disconnected`, `lost`, `error`; and the station's own
    /// `alert` (an alert raised: its name and text in `detail`) and `controls` (the drive
    /// controls became live or greyed, and why, in `detail`).
    pub event: String,
    /// The port, when there is one.
    pub port: Option<String>,
    /// Baud rate, when connected.
    pub baud: Option<u32>,
    /// Details (the error text).
    pub detail: Option<String>,
}

/// Something to record, with its time (Unix-epoch ns).
#[derive(Debug, Clone)]
pub enum RecordEvent {
    /// A command frame was written.
    Sent(u64, CommandRecord),
    /// A requested command was settled (v2).
    Delivery(u64, DeliveryRecord),
    /// Bytes were read.
    Received(u64, Vec<u8>),
    /// A display frame was decoded from them.
    Display(u64, Box<DisplayRecord>),
    /// A link event.
    Link(u64, LinkRecord),
}

/// Now, as Unix-epoch nanoseconds.
pub fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A JSON channel of the recording.
const fn json_channel(topic: &'static str, schema_name: &'static str) -> ChannelSpec {
    ChannelSpec {
        topic,
        encoding: "json",
        schema_name,
    }
}

const COMMAND: ChannelSpec = json_channel(TOPIC_COMMAND, "dima_ground.Command");
const DISPLAY: ChannelSpec = json_channel(TOPIC_DISPLAY, "dima_ground.Display");
const LINK: ChannelSpec = json_channel(TOPIC_LINK, "dima_ground.Link");
const ACK: ChannelSpec = json_channel(TOPIC_ACK, "dima_ground.Delivery");
const RX_BYTES: ChannelSpec = ChannelSpec {
    topic: TOPIC_RX_BYTES,
    encoding: "dima-ground-bytes",
    schema_name: "",
};

/// The recording's channels, in the order they are declared.
fn channels() -> Vec<Channel> {
    vec![
        Channel::json::<CommandRecord>(COMMAND),
        Channel::json::<DisplayRecord>(DISPLAY),
        Channel::json::<LinkRecord>(LINK),
        Channel::json::<DeliveryRecord>(ACK),
        Channel {
            spec: RX_BYTES,
            schema: None,
        },
    ]
}

/// The MCAP file being written (log times are the events' own Unix-epoch times).
struct SessionFile {
    log: McapLog,
}

impl SessionFile {
    fn create(path: &Path) -> anyhow::Result<SessionFile> {
        let mut log = McapLog::create_with_channels(path, channels())
            .with_context(|| format!("recording: cannot start {}", path.display()))?;
        log.set_time_offset(0);
        Ok(SessionFile { log })
    }

    fn write(&mut self, spec: &ChannelSpec, t_ns: u64, data: &[u8]) -> anyhow::Result<()> {
        self.log.message_on(spec, t_ns, data)
    }

    fn record(&mut self, event: &RecordEvent) -> anyhow::Result<()> {
        match event {
            RecordEvent::Sent(t, c) => self.write(&COMMAND, *t, &serde_json::to_vec(c)?),
            RecordEvent::Delivery(t, d) => self.write(&ACK, *t, &serde_json::to_vec(d)?),
            RecordEvent::Received(t, bytes) => self.write(&RX_BYTES, *t, bytes),
            RecordEvent::Display(t, d) => self.write(&DISPLAY, *t, &serde_json::to_vec(d)?),
            RecordEvent::Link(t, l) => self.write(&LINK, *t, &serde_json::to_vec(l)?),
        }
    }
}

/// The recording: a writer thread and the sender that feeds it. Dropping it (or
/// [`finish`](Self::finish)) writes the summary and closes the file.
pub struct Recorder {
    sender: Option<Sender<RecordEvent>>,
    thread: Option<JoinHandle<anyhow::Result<u64>>>,
    path: PathBuf,
}

impl Recorder {
    /// Starts a recording in `dir` (created if missing), named by the UTC time it started as
    /// the robot's logs are: `dima-ground-YYYYMMDDTHHMMSSZ.mcap`
    /// ([`dima_log::naming::ground_session_name`]); a second session within the same second
    /// gets `-1`, `-2`, ...
    pub fn start(dir: &Path) -> anyhow::Result<Recorder> {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("recording: cannot create {}", dir.display()))?;
        let first = dir.join(dima_log::naming::ground_session_name(SystemTime::now()));
        let mut path = first.clone();
        let mut n = 1;
        while path.exists() {
            path = dima_log::naming::numbered_name(&first, n);
            n += 1;
        }
        let file = SessionFile::create(&path)?;
        let (sender, receiver) = mpsc::channel();
        let thread = std::thread::Builder::new()
            .name("recorder".into())
            .spawn(move || write_loop(file, receiver))
            .context("recording: starting the writer thread")?;
        Ok(Recorder {
            sender: Some(sender),
            thread: Some(thread),
            path,
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A sender for the link thread.
    pub fn sender(&self) -> Sender<RecordEvent> {
        self.sender
            .clone()
            .expect("the sender lives until finish or drop")
    }

    /// Closes the file; returns the number of messages written.
    pub fn finish(mut self) -> anyhow::Result<u64> {
        self.close()
    }

    fn close(&mut self) -> anyhow::Result<u64> {
        self.sender.take();
        match self.thread.take() {
            Some(t) => t
                .join()
                .map_err(|_| anyhow::anyhow!("recording: the writer thread panicked"))?,
            None => Ok(0),
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if let Err(e) = self.close() {
            eprintln!("dima-ground: {e:#}");
        }
    }
}

/// Writes until every sender is gone; closes the chunk every second.
fn write_loop(mut file: SessionFile, events: Receiver<RecordEvent>) -> anyhow::Result<u64> {
    let mut written = 0u64;
    let mut dirty = false;
    loop {
        match events.recv_timeout(Duration::from_secs(1)) {
            Ok(event) => {
                file.record(&event)?;
                written += 1;
                dirty = true;
            }
            Err(RecvTimeoutError::Timeout) => {
                if std::mem::take(&mut dirty) {
                    file.log.flush()?;
                }
            }
            Err(RecvTimeoutError::Disconnected) => break,
        }
    }
    file.log.finish()?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_groundlink::Percent;

    #[test]
    fn an_overrun_is_explained_as_the_computer_falling_behind() {
        let advice = overrun_advice(Some(FailsafeCause::Overrun), None).expect("advice");
        assert!(
            advice.contains("computer") && advice.contains("--loop-rate"),
            "{advice}"
        );
        assert!(overrun_advice(None, Some(ReviveRefusal::Overrun)).is_some());
        assert_eq!(overrun_advice(Some(FailsafeCause::CommsLoss), None), None);
        assert_eq!(
            overrun_advice(
                Some(FailsafeCause::SensorLoss),
                Some(ReviveRefusal::TooSoon)
            ),
            None
        );
    }

    #[test]
    fn a_session_is_named_like_the_robots_logs_by_its_utc_start() {
        let dir = std::env::temp_dir().join(format!("dima-ground-name-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let before = SystemTime::now();
        let recorder = Recorder::start(&dir).unwrap();
        let after = SystemTime::now();
        let name = recorder
            .path()
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        // `dima-ground-` and the name the robot's log gets for the same second.
        let robot_names = [before, after].map(dima_log::naming::log_file_name);
        assert!(
            robot_names
                .iter()
                .any(|robot| name == robot.replacen("dima-", "dima-ground-", 1)),
            "{name} vs {robot_names:?}"
        );
        recorder.finish().unwrap();
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn rollover_and_geofence_are_told_in_words() {
        assert_eq!(cause_name(FailsafeCause::Rollover), "rolled over");
        assert_eq!(cause_name(FailsafeCause::Geofence), "left the geofence");
        assert_eq!(refusal_name(ReviveRefusal::RolledOver), "not on its wheels");
        assert!(refusal_name(ReviveRefusal::OutsideFence).contains("geofence"));
        // The codes an older robot cannot send still read as their number.
        assert_eq!(cause_name(FailsafeCause::Other(9)), "cause 9");
    }

    #[test]
    fn a_session_reads_back_with_every_topic() {
        let dir = std::env::temp_dir().join(format!("dima-ground-rec-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let recorder = Recorder::start(&dir).unwrap();
        let path = recorder.path().to_owned();
        let tx = recorder.sender();
        let frame = DisplayFrame {
            acc: [1, -2, 1000],
            lat_e7: 473_769_000,
            lon_e7: 85_417_000,
            ..DisplayFrame::default()
        };
        let physical = Physical::from_frame(&frame, None);
        tx.send(RecordEvent::Link(
            10,
            LinkRecord {
                event: "connected".into(),
                port: Some("/dev/pts/3".into()),
                baud: Some(9600),
                detail: None,
            },
        ))
        .unwrap();
        tx.send(RecordEvent::Sent(
            20,
            CommandRecord::new(Command::Throttle(Percent::new(70).unwrap())),
        ))
        .unwrap();
        tx.send(RecordEvent::Received(30, frame.encode().to_vec()))
            .unwrap();
        tx.send(RecordEvent::Display(
            30,
            Box::new(DisplayRecord::new(&frame, &physical)),
        ))
        .unwrap();
        // Version 2: the robot's report inside the display record, and a delivery.
        let report = v2::DisplayFrame {
            mode: RobotMode::Failsafe,
            failsafe_cause: Some(FailsafeCause::CommsLoss),
            session: 0xABCD,
            seq: 9,
            ack_seq: 77,
            health: dima_groundlink::v2::Health {
                replayed: 3,
                ..Default::default()
            },
            sensors: frame,
            ..v2::DisplayFrame::default()
        };
        let mut record = DisplayRecord::new(&frame, &physical);
        record.robot = Some(RobotRecord::new(&report, 2));
        tx.send(RecordEvent::Display(40, Box::new(record))).unwrap();
        let t = dima_groundlink::station::StationTime::from_secs(90);
        let status = dima_groundlink::station::CommandStatus {
            command: Command::Revive,
            requested_at: t,
            transmissions: 4,
            first_seq: Some(74),
            last_seq: Some(77),
            settled_at: None,
            delivery: Delivery::Acknowledged { seq: 77 },
            accepted_but_refused: true,
        };
        tx.send(RecordEvent::Delivery(
            50,
            DeliveryRecord::new(&Settled {
                status,
                at: t + Duration::from_millis(420),
            }),
        ))
        .unwrap();
        drop(tx);
        assert_eq!(recorder.finish().unwrap(), 6);

        let bytes = std::fs::read(&path).unwrap();
        let mut seen = Vec::new();
        for m in dima_log::reader::messages(&bytes).unwrap() {
            seen.push((m.channel.topic.clone(), m.log_time));
            match m.channel.topic.as_str() {
                TOPIC_COMMAND => {
                    let c: CommandRecord = serde_json::from_slice(&m.data).unwrap();
                    assert_eq!((c.kind, c.data), (3, 70));
                    assert_eq!(c.frame_hex.len(), 20);
                    assert!(c.frame_hex.starts_with("2403"));
                }
                TOPIC_DISPLAY => {
                    let d: DisplayRecord = serde_json::from_slice(&m.data).unwrap();
                    assert_eq!(d.acc, [1, -2, 1000]);
                    if let Some(r) = d.robot {
                        assert_eq!(r.mode, "FAILSAFE");
                        assert_eq!(r.failsafe_cause.as_deref(), Some("comms loss"));
                        assert_eq!((r.session, r.seq, r.ack_seq), (0xABCD, 9, 77));
                        assert_eq!((r.rejected_replayed, r.station_bad_tag), (3, 2));
                    }
                    assert!((d.lat_deg - 47.3769).abs() < 1e-9);
                    assert_eq!(d.pressure_pa, None);
                }
                TOPIC_RX_BYTES => assert_eq!(m.data, frame.encode().as_slice()),
                TOPIC_LINK => assert!(String::from_utf8_lossy(&m.data).contains("connected")),
                TOPIC_ACK => {
                    let d: DeliveryRecord = serde_json::from_slice(&m.data).unwrap();
                    assert_eq!((d.kind, d.outcome.as_str()), (2, "acknowledged"));
                    assert_eq!((d.ack_seq, d.transmissions), (Some(77), 4));
                    assert!((d.latency_ms - 420.0).abs() < 1e-6);
                    assert!(d.accepted_but_refused);
                }
                other => panic!("unexpected topic {other}"),
            }
            if m.channel.message_encoding == "json" {
                assert!(
                    !m.channel.schema.is_empty(),
                    "json channels declare a schema"
                );
                assert_eq!(m.channel.schema_encoding, "jsonschema");
            }
        }
        assert_eq!(seen.len(), 6, "{seen:?}");
        assert_eq!(seen[1], (TOPIC_COMMAND.to_string(), 20));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
