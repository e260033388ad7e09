//! The log being replayed, as events in log time: a station session log gives the bytes the
//! link read (decoded again by [`ReplayState`](super::ReplayState) as the live link decodes
//! them) and its link events; a robot log gives the reports the robot would have sent, one
//! per display period, built from its `/dima/cycle` and `/dima/state` messages.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;
use dima_core::safety::{FailsafeCause, Mode, ReviveRefusal};
use dima_groundlink::v2::{self, Actuation, ControllerCode, Downlink, Health, RobotMode};
use dima_groundlink::DisplayFrame;
use dima_log::reader::{LoggedRun, Message};
use dima_log::schema::CycleMessage;
use dima_sensorboard::{SensorPacket, PACKET_LEN};

use crate::recording::{
    CommandRecord, DisplayRecord, LinkRecord, TOPIC_COMMAND, TOPIC_DISPLAY, TOPIC_LINK,
    TOPIC_RX_BYTES,
};

/// The display rate of a robot log whose configuration does not say (the robot's default).
pub const DEFAULT_DISPLAY_RATE_HZ: f64 = 2.0;

/// What kind of log is replayed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogKind {
    /// A station session log (`/ground/...`): the bytes the station read, decoded again.
    Station,
    /// A robot log (`/dima/cycle`, `/dima/state`): the reports the robot would have sent.
    Robot,
}

/// One thing that happened, replayed through the station's state.
#[derive(Debug, Clone, PartialEq)]
pub enum ReplayEvent {
    /// A chunk of bytes the station read, as read.
    Bytes(Vec<u8>),
    /// A link event of the session (`connected`, `disconnected`, `lost`, ...).
    Link(LinkRecord),
    /// A command frame the station sent (shown as sent; nothing is sent again).
    Sent(CommandRecord),
    /// A report the robot would have sent (robot logs), as a display frame v3 carries it.
    Report(Box<Downlink>),
}

/// An event at its log time.
#[derive(Debug, Clone, PartialEq)]
pub struct TimedEvent {
    /// Time since the log's start.
    pub at: Duration,
    /// What happened.
    pub event: ReplayEvent,
}

/// A log ready to replay: its events in time order.
#[derive(Debug, Clone)]
pub struct ReplayLog {
    /// The file given.
    pub path: PathBuf,
    /// Station or robot log.
    pub kind: LogKind,
    /// The events, in time order.
    pub events: Vec<TimedEvent>,
    /// From the first to the last message.
    pub duration: Duration,
    /// Log time of the start, Unix-epoch ns.
    pub start_ns: u64,
    /// Station logs: the display frames the live session showed (`/ground/display`), the
    /// reference a replay must match.
    pub displays: Vec<(Duration, DisplayRecord)>,
    /// The robot's reported mode from each change on, for the timeline.
    pub modes: Vec<(Duration, RobotMode)>,
    /// Robot logs: the mission and the fence the robot ran with, for the map.
    pub navigation: Option<dima_core::mission::Navigation>,
}

impl ReplayLog {
    /// Reads `path`: a station session log if it has `/ground/` topics, else a robot log (every
    /// file of its run).
    ///
    /// # Errors
    /// The file cannot be read, or is neither kind of log.
    pub fn open(path: &Path) -> anyhow::Result<ReplayLog> {
        let bytes =
            std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
        // The first message tells the kind (a file is one or the other); a file cut short (a
        // crash) is read up to its first damaged record.
        let mut messages = Vec::new();
        let mut station = None;
        let read = dima_log::reader::for_each_message(&bytes, |m| {
            let is_station = *station.get_or_insert(m.channel.topic.starts_with("/ground/"));
            anyhow::ensure!(is_station, "a robot log");
            messages.push(m);
            Ok(())
        });
        if station == Some(true) {
            if let Err(e) = read {
                eprintln!(
                    "warning: {}: read up to message {}, then: {e:#}",
                    path.display(),
                    messages.len()
                );
            }
            return ReplayLog::from_station_messages(path, &messages);
        }
        drop(bytes);
        let run = dima_log::run::read_run(path)?;
        run.warn(path);
        ReplayLog::from_robot_run(path, &run)
    }

    /// A station session log from its messages.
    ///
    /// # Errors
    /// A link or display record that does not parse.
    pub fn from_station_messages(path: &Path, messages: &[Message]) -> anyhow::Result<ReplayLog> {
        let start_ns = messages.iter().map(|m| m.log_time).min().unwrap_or(0);
        let end_ns = messages.iter().map(|m| m.log_time).max().unwrap_or(0);
        let at = |t: u64| Duration::from_nanos(t.saturating_sub(start_ns));
        let mut events = Vec::new();
        let mut displays = Vec::new();
        for m in messages {
            match m.channel.topic.as_str() {
                TOPIC_RX_BYTES => events.push(TimedEvent {
                    at: at(m.log_time),
                    event: ReplayEvent::Bytes(m.data.clone()),
                }),
                TOPIC_LINK => {
                    let record: LinkRecord = serde_json::from_slice(&m.data)
                        .with_context(|| format!("{TOPIC_LINK} at {}", m.log_time))?;
                    events.push(TimedEvent {
                        at: at(m.log_time),
                        event: ReplayEvent::Link(record),
                    });
                }
                TOPIC_COMMAND => {
                    let record: CommandRecord = serde_json::from_slice(&m.data)
                        .with_context(|| format!("{TOPIC_COMMAND} at {}", m.log_time))?;
                    events.push(TimedEvent {
                        at: at(m.log_time),
                        event: ReplayEvent::Sent(record),
                    });
                }
                TOPIC_DISPLAY => {
                    let record: DisplayRecord = serde_json::from_slice(&m.data)
                        .with_context(|| format!("{TOPIC_DISPLAY} at {}", m.log_time))?;
                    displays.push((at(m.log_time), record));
                }
                _ => {}
            }
        }
        // Stable: events at the same time keep the order they were written in.
        events.sort_by_key(|e| e.at);
        displays.sort_by_key(|d| d.0);
        let reported = displays.iter().filter_map(|(at, d)| {
            let name = d.robot.as_ref()?.mode.as_str();
            let mode = [
                RobotMode::Killed,
                RobotMode::Manual,
                RobotMode::Auto,
                RobotMode::Failsafe,
            ]
            .into_iter()
            .find(|m| crate::recording::mode_name(*m) == name)?;
            Some((*at, mode))
        });
        let modes = changes(reported);
        Ok(ReplayLog {
            path: path.to_owned(),
            kind: LogKind::Station,
            events,
            duration: at(end_ns),
            start_ns,
            displays,
            modes,
            navigation: None,
        })
    }

    /// A robot log: a report per display period of its configuration (2 Hz without one), and
    /// one for the last cycle.
    ///
    /// # Errors
    /// The log has no `/dima/cycle` message.
    pub fn from_robot_run(path: &Path, run: &LoggedRun) -> anyhow::Result<ReplayLog> {
        anyhow::ensure!(
            !run.cycles.is_empty(),
            "{}: no /dima/cycle message and no /ground/ topic: nothing to replay",
            path.display()
        );
        let rate = run
            .config
            .as_ref()
            .map_or(DEFAULT_DISPLAY_RATE_HZ, |c| c.xbee.display_rate_hz);
        let period = Duration::from_secs_f64(1.0 / rate.clamp(0.1, 1000.0));
        let controllers = run
            .config
            .as_ref()
            .map_or([ControllerCode::Neutral; 3], |c| {
                dima_core::control::Channel::ALL
                    .map(|ch| ControllerCode::from_name(&c.control.channel(ch).kind))
            });
        let start_ns = run.start_ns();
        let at = |t: u64| Duration::from_nanos(t.saturating_sub(start_ns));
        let mut reporter = RobotReporter::new(controllers);
        let mut states = run.states.iter().peekable();
        let mut events = Vec::new();
        let mut next_report = Duration::ZERO;
        let last = run.cycles.len() - 1;
        for (i, timed) in run.cycles.iter().enumerate() {
            let cycle = &timed.msg;
            reporter.cycle(cycle);
            while let Some(state) = states.next_if(|s| s.msg.cycle <= cycle.cycle) {
                reporter.refused(state.msg.refused);
            }
            let t = at(timed.t_ns);
            if t >= next_report || i == last {
                let packet = run.raw.get(&timed.t_ns);
                events.push(TimedEvent {
                    at: t,
                    event: ReplayEvent::Report(Box::new(reporter.report(cycle, packet))),
                });
                while next_report <= t {
                    next_report += period;
                }
            }
        }
        let end_ns = run.cycles[last]
            .t_ns
            .max(run.states.last().map_or(0, |s| s.t_ns));
        let modes = changes(events.iter().filter_map(|e| match &e.event {
            ReplayEvent::Report(downlink) => Some((e.at, downlink.status().mode)),
            _ => None,
        }));
        Ok(ReplayLog {
            path: path.to_owned(),
            kind: LogKind::Robot,
            events,
            duration: at(end_ns),
            start_ns,
            displays: Vec::new(),
            modes,
            navigation: run.navigation.clone(),
        })
    }

    /// How many events happen at or before `t`.
    pub fn events_until(&self, t: Duration) -> usize {
        self.events.partition_point(|e| e.at <= t)
    }
}

/// The first mode and each change of it.
fn changes(modes: impl Iterator<Item = (Duration, RobotMode)>) -> Vec<(Duration, RobotMode)> {
    let mut out: Vec<(Duration, RobotMode)> = Vec::new();
    for (at, mode) in modes {
        if out.last().is_none_or(|(_, last)| *last != mode) {
            out.push((at, mode));
        }
    }
    out
}

/// Builds the reports a robot sends from its logged cycles, as its telemetry thread builds
/// them from its loop's snapshots: the cause and the refusal are kept until a revive succeeds.
struct RobotReporter {
    cause: Option<FailsafeCause>,
    refusal: Option<ReviveRefusal>,
    seq: u32,
    controllers: [ControllerCode; 3],
}

impl RobotReporter {
    fn new(controllers: [ControllerCode; 3]) -> RobotReporter {
        RobotReporter {
            cause: None,
            refusal: None,
            seq: 0,
            controllers,
        }
    }

    /// Follows the cause and the refusal through one cycle.
    fn cycle(&mut self, cycle: &CycleMessage) {
        if matches!(cycle.mode, Mode::Manual | Mode::Auto) {
            self.cause = None;
            self.refusal = None;
        }
        if cycle.cause.is_some() {
            self.cause = cycle.cause;
        }
    }

    /// A revive refused in a `/dima/state` message.
    fn refused(&mut self, refusal: Option<ReviveRefusal>) {
        if refusal.is_some() {
            self.refusal = refusal;
        }
    }

    /// The report of `cycle` (with its sensor packet, when logged). The log holds no session
    /// id, acknowledgement or estimates: they are 0 and absent.
    fn report(&mut self, cycle: &CycleMessage, packet: Option<&[u8; PACKET_LEN]>) -> Downlink {
        self.seq += 1;
        let c = &cycle.counters;
        let saturate = |v: u64| u32::try_from(v).unwrap_or(u32::MAX);
        let status = v2::DisplayFrame {
            mode: cycle.mode.into(),
            failsafe_cause: self.cause.map(Into::into),
            revive_refusal: self.refusal.map(Into::into),
            session: 0,
            seq: self.seq,
            ack_seq: 0,
            health: Health {
                missed_periods: saturate(c.missed_periods),
                sensor_bad: saturate(c.packet_crc_errors + c.packets_stale + c.packets_late),
                sensor_missing: saturate(c.packets_missing),
                commands: saturate(c.commands),
                bad_tag: saturate(cycle.link.bad_tag),
                replayed: saturate(cycle.link.replayed),
                stale_session: saturate(cycle.link.stale_session),
                malformed: saturate(cycle.link.malformed),
                v1_ignored: saturate(cycle.link.v1_ignored),
            },
            sensors: sensors(cycle, packet),
        };
        let setpoints = &cycle.setpoints;
        Downlink::V3(v2::DisplayFrameV3 {
            status,
            actuation: Actuation {
                servo_quarter_us: cycle.targets_us.map(|us| us.saturating_mul(4)),
                speed_setpoint_mm_s: setpoints.speed_mm_s,
                heading_setpoint_deg_e5: setpoints.heading_deg.map(|d| (d * 1e5).round() as i32),
                speed_estimate_mm_s: None,
                heading_estimate_deg_e5: None,
                speed_error_mm_s: None,
                controllers: self.controllers,
            },
        })
    }
}

/// The sensor values a display frame carries: from the raw packet when it was logged (as the
/// robot builds them), else from the cycle's decoded packet.
fn sensors(cycle: &CycleMessage, packet: Option<&[u8; PACKET_LEN]>) -> DisplayFrame {
    if let Some(p) = packet.and_then(|b| SensorPacket::decode(b).ok()) {
        let mut frame = DisplayFrame {
            acc: p.accel,
            gyro: p.gyro,
            mag: p.mag,
            mag_hall: p.rhall,
            baro_press: p.press_raw,
            baro_temp: p.temp_raw,
            ..DisplayFrame::default()
        };
        if let Some(pvt) = p.nav_pvt() {
            frame.lat_e7 = pvt.lat_deg_e7;
            frame.lon_e7 = pvt.lon_deg_e7;
            frame.vel_n_mm_s = pvt.vel_n_mm_s;
            frame.vel_e_mm_s = pvt.vel_e_mm_s;
            frame.vel_d_mm_s = pvt.vel_d_mm_s;
            frame.height_mm = pvt.height_mm;
            frame.h_msl_mm = pvt.h_msl_mm;
            frame.g_speed_mm_s = pvt.g_speed_mm_s;
            frame.head_mot_deg_e5 = pvt.head_mot_deg_e5;
        }
        return frame;
    }
    let Some(s) = &cycle.sensor else {
        return DisplayFrame::default();
    };
    let e7 = |d: Option<f64>| d.map_or(0, |d| (d * 1e7).round() as i32);
    DisplayFrame {
        acc: s.accel,
        gyro: s.gyro,
        mag: s.mag,
        mag_hall: s.rhall,
        baro_press: s.press_raw,
        baro_temp: s.temp_raw,
        lat_e7: e7(s.lat_deg),
        lon_e7: e7(s.lon_deg),
        g_speed_mm_s: s.g_speed_mm_s.unwrap_or(0),
        head_mot_deg_e5: s.head_mot_deg.map_or(0, |d| (d * 1e5).round() as i32),
        ..DisplayFrame::default()
    }
}
