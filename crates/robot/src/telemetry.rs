//! The telemetry thread (below the loop's priority): command frames in from the XBee, display
//! frames out.
//!
//! Command frames v2 pass through a [`CommandGate`] (tag, session, sequence); v1 frames are
//! acted on only with `xbee.require_auth = false`, and counted as ignored otherwise. Display
//! frames v3 (mode, failsafe cause, health, the acknowledgement of the last accepted command,
//! and what the robot does: servo targets, setpoints, estimates, controllers; encoded from one
//! [`RobotReport`]) go out whenever a key is configured, v1 display frames whenever v1
//! commands are accepted.
//!
//! Commands go to the loop as events through a ring, never as a latest value, so a kill or a
//! revive cannot be overwritten; each carries the earliest time it can have arrived at the port
//! ([`ArrivalBound`]), so a command that waited (in the port, in this thread or in the ring)
//! is not taken for fresh link activity; if the ring is ever full they wait here, in order, in a
//! bounded queue ([`CommandHandOff`]). A kill goes first: it is pushed before anything else is
//! done with it, and it supersedes every command still waiting. The comms-loss decision is not
//! taken here but in the loop, so a dead telemetry thread still trips the failsafe.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use dima_core::config::XbeeConfig;
use dima_core::control::ServoTargets;
use dima_core::{FailsafeCause, Mode, ReviveRefusal};
use dima_groundlink::v2::{self, CommandGate, LinkKey};
use dima_groundlink::{key_file, Command, CommandDecoder, CommandStats, DisplayFrame};
use dima_log::schema::GroundLinkCounters;
use dima_sensorboard::SensorPacket;
use embedded_hal_nb::serial::{Read, Write};
use xbee_driver::{Transparent, XBee};

use crate::app::record::Snapshot;
use crate::devices::serial::SerialPort;
use crate::devices::Opener;
use crate::rt::monotonic_ns;
use dima_core::Nanos;

/// The display frame for the last packet: decoded signed values, raw BMP280 ADC values,
/// latitude then longitude (the original swapped them), velocities and heading from NAV-PVT.
pub fn display_frame(packet: Option<&SensorPacket>) -> DisplayFrame {
    let Some(p) = packet else {
        return DisplayFrame::default();
    };
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
    frame
}

/// Commands waiting for room in the ring to the loop, at most this many.
pub const PENDING_COMMANDS: usize = 64;

/// A command as it travels to the loop: what, and when it arrived (`arrival_ns`: the earliest
/// time its frame can have been complete at the port, CLOCK_MONOTONIC, never later than its
/// real arrival; see [`ArrivalBound`]). The control step judges its age.
pub use dima_core::ReceivedCommand;

/// The earliest time the bytes read from the port now can have arrived: the last time the
/// reader found the port empty. A byte read after the port was seen empty at `t` arrived after
/// `t`, however long the reader then took to come back (a stalled thread, a display frame
/// being sent): the bound is never later than the arrival, and at most one pass of the reader
/// earlier while it keeps up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArrivalBound {
    empty_ns: Nanos,
    drained: bool,
}

impl ArrivalBound {
    /// For a port opened (and flushed) after `opened_ns`: nothing read from it is older.
    pub fn new(opened_ns: Nanos) -> ArrivalBound {
        ArrivalBound {
            empty_ns: opened_ns,
            drained: true,
        }
    }

    /// A read that started at `before_read_ns` found nothing.
    pub fn found_empty(&mut self, before_read_ns: Nanos) {
        self.empty_ns = self.empty_ns.max(before_read_ns);
        self.drained = true;
    }

    /// A byte was read (the reader may stop before the port is empty).
    pub fn byte_read(&mut self) {
        self.drained = false;
    }

    /// A wait for input until `deadline_ns` ended with nothing readable: if everything read
    /// before was drained, the port was empty up to the deadline.
    pub fn wait_timed_out(&mut self, deadline_ns: Nanos) {
        if self.drained {
            self.empty_ns = self.empty_ns.max(deadline_ns);
        }
    }

    /// The earliest arrival time of a byte read now, ns.
    pub fn earliest_ns(&self) -> Nanos {
        self.empty_ns
    }
}

/// Hands commands to the loop in arrival order through the ring, with a bounded queue for when
/// the ring is full.
pub struct CommandHandOff {
    ring: rtrb::Producer<ReceivedCommand>,
    pending: VecDeque<ReceivedCommand>,
    dropped: u64,
}

impl CommandHandOff {
    /// Around the ring to the loop.
    pub fn new(ring: rtrb::Producer<ReceivedCommand>) -> CommandHandOff {
        CommandHandOff {
            ring,
            pending: VecDeque::with_capacity(PENDING_COMMANDS),
            dropped: 0,
        }
    }

    /// Hands `command` over: a kill at once, ahead of (and instead of) anything still
    /// waiting; anything else after what is waiting. A full queue drops the new command and
    /// counts it.
    pub fn push(&mut self, command: ReceivedCommand) {
        if command.command == Command::Kill {
            if self.ring.push(command).is_err() {
                self.dropped += self.pending.len() as u64;
                self.pending.clear();
                self.pending.push_back(command);
            } else {
                // Whatever was waiting came before the kill and is void after it.
                self.dropped += self.pending.len() as u64;
                self.pending.clear();
            }
            return;
        }
        self.flush();
        if self.pending.is_empty() && self.ring.push(command).is_ok() {
            return;
        }
        if self.pending.len() < PENDING_COMMANDS {
            self.pending.push_back(command);
        } else {
            self.dropped += 1;
        }
    }

    /// Moves waiting commands into the ring while it has room.
    pub fn flush(&mut self) {
        while let Some(&c) = self.pending.front() {
            if self.ring.push(c).is_err() {
                break;
            }
            self.pending.pop_front();
        }
    }

    /// Commands dropped: a full queue, or superseded by a kill.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}

/// How the ground link authenticates commands, fixed for a run.
#[derive(Debug, Clone)]
pub struct LinkSecurity {
    /// The pre-shared key (`None`: no key file, v1 only).
    pub key: Option<LinkKey>,
    /// Ignore v1 command frames (count them, never act on them).
    pub require_auth: bool,
    /// This boot's session id (nonzero; command frames v2 must carry it).
    pub session: u32,
}

impl LinkSecurity {
    /// From the `[xbee]` section: loads the key file (refusing one that others can read) and
    /// draws a random session id. `require_auth = true` without a key file is an error that
    /// says how to fix it.
    pub fn from_config(xbee: &XbeeConfig) -> anyhow::Result<LinkSecurity> {
        let key = match xbee.key_file_needed()? {
            Some(path) => Some(key_file::load(path)?),
            None => None,
        };
        let session = v2::random_session_id()
            .map_err(|e| anyhow::anyhow!("drawing the ground-link session id: {e}"))?;
        Ok(LinkSecurity {
            key,
            require_auth: xbee.require_auth,
            session,
        })
    }

    /// Whether display frames v1 go out (the v1 ground station is allowed to drive).
    pub fn sends_v1_display(&self) -> bool {
        !self.require_auth
    }
}

/// Ground-link counters shared with the realtime loop, which copies them into its records
/// with relaxed loads (no lock). Each counter only grows; a record may mix counters of two
/// consecutive publications.
#[derive(Debug, Default)]
pub struct LinkCounters {
    counters: [AtomicU64; 12],
}

impl LinkCounters {
    /// The counters as last published.
    pub fn load(&self) -> GroundLinkCounters {
        let c = |i: usize| self.counters[i].load(Ordering::Relaxed);
        GroundLinkCounters {
            v2_accepted: c(0),
            bad_tag: c(1),
            replayed: c(2),
            stale_session: c(3),
            malformed: c(4),
            kills_outside_window: c(5),
            v1_accepted: c(6),
            v1_ignored: c(7),
            v1_rejected: c(8),
            v1_crc_errors: c(9),
            revive_repeats: c(10),
            pre_revive_requests: c(11),
        }
    }

    /// Publishes `counters`.
    pub fn store(&self, counters: &GroundLinkCounters) {
        let values = [
            counters.v2_accepted,
            counters.bad_tag,
            counters.replayed,
            counters.stale_session,
            counters.malformed,
            counters.kills_outside_window,
            counters.v1_accepted,
            counters.v1_ignored,
            counters.v1_rejected,
            counters.v1_crc_errors,
            counters.revive_repeats,
            counters.pre_revive_requests,
        ];
        for (slot, value) in self.counters.iter().zip(values) {
            slot.store(value, Ordering::Relaxed);
        }
    }
}

/// The command side of the ground link: both decoders over the same byte stream, the v2 gate,
/// and the rule for v1 frames.
#[derive(Debug, Clone)]
pub struct CommandLink {
    v1: CommandDecoder,
    gate: Option<CommandGate>,
    require_auth: bool,
    v1_accepted: u64,
    v1_ignored: u64,
}

impl CommandLink {
    /// The command link for these settings.
    pub fn new(security: &LinkSecurity) -> CommandLink {
        CommandLink {
            v1: CommandDecoder::new(),
            gate: security
                .key
                .clone()
                .map(|key| CommandGate::new(key, security.session)),
            require_auth: security.require_auth,
            v1_accepted: 0,
            v1_ignored: 0,
        }
    }

    /// Feeds one received byte; `deliver` gets every command to act on, at once.
    pub fn push(&mut self, byte: u8, deliver: &mut impl FnMut(Command)) {
        if let Some(gate) = self.gate.as_mut() {
            match gate.push(byte) {
                Some(Ok(command)) => deliver(command),
                Some(Err(rejection)) => tracing::debug!("ground link v2: rejected: {rejection}"),
                None => {}
            }
        }
        match self.v1.push(byte) {
            Some(Ok(command)) if self.require_auth => {
                self.v1_ignored += 1;
                tracing::debug!("ground link v1: {command:?} ignored (require_auth = true)");
            }
            Some(Ok(command)) => {
                self.v1_accepted += 1;
                deliver(command);
            }
            Some(Err(e)) => tracing::debug!("ground link v1: rejected: {e}"),
            None => {}
        }
    }

    /// Forgets partial frames (the port was reopened).
    pub fn reset(&mut self) {
        self.v1.reset();
        if let Some(gate) = self.gate.as_mut() {
            gate.reset_stream();
        }
    }

    /// Sequence number of the last accepted v2 command of this session (0: none).
    pub fn last_accepted(&self) -> u32 {
        self.gate.as_ref().map_or(0, CommandGate::last_accepted)
    }

    /// The v1 decoder's counters.
    pub fn v1_stats(&self) -> CommandStats {
        self.v1.stats()
    }

    /// Every counter of both versions.
    pub fn counters(&self) -> GroundLinkCounters {
        let v1 = self.v1.stats();
        let v2 = self
            .gate
            .as_ref()
            .map(CommandGate::stats)
            .unwrap_or_default();
        GroundLinkCounters {
            v2_accepted: u64::from(v2.accepted),
            bad_tag: u64::from(v2.bad_tag),
            replayed: u64::from(v2.replayed),
            stale_session: u64::from(v2.stale_session),
            malformed: u64::from(v2.malformed),
            kills_outside_window: u64::from(v2.kills_outside_window),
            revive_repeats: u64::from(v2.revive_repeats),
            pre_revive_requests: u64::from(v2.pre_revive_requests),
            v1_accepted: self.v1_accepted,
            v1_ignored: self.v1_ignored,
            v1_rejected: u64::from(v1.unknown_type) + u64::from(v1.out_of_range),
            v1_crc_errors: u64::from(v1.crc_errors),
        }
    }
}

/// Saturating narrowing for the display frame's 32-bit counters.
fn c32(value: u64) -> u32 {
    u32::try_from(value).unwrap_or(u32::MAX)
}

/// The display frame v2 for the loop's latest snapshot and the link's state.
pub fn display_frame_v2(
    snap: &Snapshot,
    session: u32,
    seq: u32,
    ack_seq: u32,
    link: &GroundLinkCounters,
) -> v2::DisplayFrame {
    RobotReport::new(
        snap,
        session,
        seq,
        ack_seq,
        link,
        [v2::ControllerCode::Neutral; 3],
    )
    .display_v2()
}

/// What the robot reports about itself each display period: what it is (mode, cause, refusal,
/// health, sensors) and what it does (the servo targets it commanded, the AUTO setpoints in
/// force, its estimates, its controllers). One report, whatever the encoding: display frames
/// v2 and v3 are encoded from it, and so can any other downlink.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotReport {
    /// Mode after the last cycle.
    pub mode: Mode,
    /// Why the robot is or last was in FAILSAFE, until a revive succeeds.
    pub cause: Option<FailsafeCause>,
    /// Why the last revive was refused, until a revive succeeds.
    pub refusal: Option<ReviveRefusal>,
    /// This boot's session id.
    pub session: u32,
    /// Downlink sequence number of this report.
    pub seq: u32,
    /// Sequence number of the last accepted command (0: none yet).
    pub ack_seq: u32,
    /// Health and link counters (saturated to 32 bits).
    pub health: v2::Health,
    /// Sensor values and the GNSS solution of the last packet.
    pub sensors: DisplayFrame,
    /// The servo targets the step commanded in the last cycle (safe ones in KILLED and
    /// FAILSAFE).
    pub targets: ServoTargets,
    /// AUTO speed setpoint in force, mm/s.
    pub speed_setpoint_mm_s: Option<i32>,
    /// AUTO heading setpoint in force, 1e-5 degrees.
    pub heading_setpoint_deg_e5: Option<i32>,
    /// Estimated ground speed, mm/s.
    pub speed_estimate_mm_s: Option<f32>,
    /// Estimated heading, degrees clockwise from north.
    pub heading_estimate_deg: Option<f32>,
    /// Configured controller kinds: throttle, steering, tail.
    pub controllers: [v2::ControllerCode; 3],
}

impl RobotReport {
    /// The report for the loop's latest snapshot, the link's state and the configured
    /// controller kinds.
    pub fn new(
        snap: &Snapshot,
        session: u32,
        seq: u32,
        ack_seq: u32,
        link: &GroundLinkCounters,
        controllers: [v2::ControllerCode; 3],
    ) -> RobotReport {
        let c = &snap.counters;
        RobotReport {
            mode: snap.mode,
            cause: snap.cause,
            refusal: snap.refusal,
            session,
            seq,
            ack_seq,
            health: v2::Health {
                missed_periods: c32(c.missed_periods),
                sensor_bad: c32(c.packet_crc_errors + c.packets_stale + c.packets_late),
                sensor_missing: c32(c.packets_missing),
                commands: c32(c.commands),
                bad_tag: c32(link.bad_tag),
                replayed: c32(link.replayed),
                stale_session: c32(link.stale_session),
                malformed: c32(link.malformed),
                v1_ignored: c32(link.v1_ignored),
            },
            sensors: display_frame(snap.packet.as_ref()),
            targets: snap.targets,
            speed_setpoint_mm_s: snap.setpoints.speed_mm_s,
            heading_setpoint_deg_e5: snap.setpoints.heading_deg_e5,
            speed_estimate_mm_s: snap.speed_mm_s.filter(|v| v.is_finite()),
            heading_estimate_deg: snap.heading_deg.filter(|v| v.is_finite()),
            controllers,
        }
    }

    /// Speed setpoint minus estimated speed, mm/s, when both are known.
    pub fn speed_error_mm_s(&self) -> Option<i32> {
        let setpoint = self.speed_setpoint_mm_s?;
        let estimate = self.speed_estimate_mm_s?;
        Some(round_i32(setpoint as f32 - estimate))
    }

    /// The display frame v2: what the robot is.
    pub fn display_v2(&self) -> v2::DisplayFrame {
        v2::DisplayFrame {
            mode: self.mode.into(),
            failsafe_cause: self.cause.map(Into::into),
            revive_refusal: self.refusal.map(Into::into),
            session: self.session,
            seq: self.seq,
            ack_seq: self.ack_seq,
            health: self.health,
            sensors: self.sensors,
        }
    }

    /// The display frame v3: what the robot is and what it does.
    pub fn display_v3(&self) -> v2::DisplayFrameV3 {
        v2::DisplayFrameV3 {
            status: self.display_v2(),
            actuation: v2::Actuation {
                servo_quarter_us: self.targets.quarter_us(),
                speed_setpoint_mm_s: self.speed_setpoint_mm_s,
                heading_setpoint_deg_e5: self.heading_setpoint_deg_e5,
                speed_estimate_mm_s: self.speed_estimate_mm_s.map(round_i32),
                heading_estimate_deg_e5: self.heading_estimate_deg.map(|d| round_i32(d * 1e5)),
                speed_error_mm_s: self.speed_error_mm_s(),
                controllers: self.controllers,
            },
        }
    }
}

/// Rounds to the nearest i32 (saturating; the inputs are finite).
fn round_i32(value: f32) -> i32 {
    value.round() as i32
}

/// Why a radio operation failed: the port is then reopened.
#[derive(Debug)]
struct RadioFailed;

/// Reads what the radio has (bounded) into the command link; `deliver` gets each command with
/// the earliest time it can have arrived.
fn receive(
    radio: &mut XBee<SerialPort, Transparent>,
    link: &mut CommandLink,
    arrival: &mut ArrivalBound,
    mut deliver: impl FnMut(ReceivedCommand),
) -> Result<(), RadioFailed> {
    for _ in 0..1024 {
        let before_read_ns = monotonic_ns();
        match radio.read() {
            Ok(byte) => {
                arrival.byte_read();
                let arrival_ns = arrival.earliest_ns();
                link.push(byte, &mut |command| {
                    deliver(ReceivedCommand {
                        command,
                        arrival_ns,
                    })
                });
            }
            Err(nb::Error::WouldBlock) => {
                arrival.found_empty(before_read_ns);
                return Ok(());
            }
            Err(nb::Error::Other(_)) => return Err(RadioFailed),
        }
    }
    Ok(())
}

/// Sends `bytes` through the radio, waiting for room until `deadline_ns`; `Ok(false)` when the
/// deadline passed first (the rest of the frame is not sent; the receiver resynchronises).
fn send(
    radio: &mut XBee<SerialPort, Transparent>,
    bytes: &[u8],
    deadline_ns: u64,
) -> Result<bool, RadioFailed> {
    for &b in bytes {
        loop {
            match radio.write(b) {
                Ok(()) => break,
                Err(nb::Error::WouldBlock) => match radio.serial_mut().wait_output(deadline_ns) {
                    Ok(true) => {}
                    Ok(false) => return Ok(false),
                    Err(_) => return Err(RadioFailed),
                },
                Err(nb::Error::Other(_)) => return Err(RadioFailed),
            }
        }
    }
    Ok(true)
}

/// Telemetry settings.
pub struct TelemetrySettings {
    /// Time between display frames.
    pub display_period: Duration,
    /// Pause between reopen attempts.
    pub reopen_interval: Duration,
    /// SCHED_FIFO priority (0: SCHED_OTHER).
    pub priority: u8,
    /// Key, session and the v1 rule.
    pub security: LinkSecurity,
    /// Configured controller kinds (throttle, steering, tail), for display frames v3.
    pub controllers: [v2::ControllerCode; 3],
}

/// What the telemetry thread counted.
#[derive(Debug, Clone, Copy, Default)]
pub struct TelemetryStats {
    /// v1 command decoder counters.
    pub commands: CommandStats,
    /// Both versions' command counters.
    pub link: GroundLinkCounters,
    /// Display frames sent (v1 and v2).
    pub display_frames: u64,
    /// Port errors (each followed by a reopen).
    pub port_errors: u64,
    /// Commands dropped before the loop saw them (queue full, or superseded by a kill).
    pub commands_dropped: u64,
}

impl TelemetryStats {
    /// One line for the exit summary.
    pub fn summary(&self) -> String {
        let l = &self.link;
        format!(
            "ground link: v2 accepted {} rejected: bad-tag {} replayed {} stale-session {} \
             malformed {} not acted on: revive-repeats {} pre-revive-requests {} | v1 accepted {} \
             ignored {} rejected {} crc-errors {} | commands dropped {} | display frames {} | \
             port errors {}",
            l.v2_accepted,
            l.bad_tag,
            l.replayed,
            l.stale_session,
            l.malformed,
            l.revive_repeats,
            l.pre_revive_requests,
            l.v1_accepted,
            l.v1_ignored,
            l.v1_rejected,
            l.v1_crc_errors,
            self.commands_dropped,
            self.display_frames,
            self.port_errors
        )
    }
}

/// The display frames due now, v1 and/or v3, as one burst of bytes.
struct Downlink {
    security: LinkSecurity,
    controllers: [v2::ControllerCode; 3],
    seq: u32,
    bytes: Vec<u8>,
}

impl Downlink {
    fn new(security: LinkSecurity, controllers: [v2::ControllerCode; 3]) -> Downlink {
        Downlink {
            security,
            controllers,
            seq: 0,
            bytes: Vec::with_capacity(
                v2::DISPLAY_V3_FRAME_LEN + dima_groundlink::DISPLAY_FRAME_LEN,
            ),
        }
    }

    /// The frames for `snap`; returns how many.
    fn frames(&mut self, snap: &Snapshot, link: &CommandLink) -> u64 {
        self.bytes.clear();
        let mut n = 0;
        if self.security.sends_v1_display() {
            self.bytes
                .extend_from_slice(&display_frame(snap.packet.as_ref()).encode());
            n += 1;
        }
        if let Some(key) = &self.security.key {
            self.seq = self.seq.wrapping_add(1).max(1);
            let report = RobotReport::new(
                snap,
                self.security.session,
                self.seq,
                link.last_accepted(),
                &link.counters(),
                self.controllers,
            );
            self.bytes
                .extend_from_slice(&report.display_v3().encode(key));
            n += 1;
        }
        n
    }
}

/// Spawns the telemetry thread.
pub fn spawn_telemetry(
    open: Opener<SerialPort>,
    commands: rtrb::Producer<ReceivedCommand>,
    snapshot: triple_buffer::Output<Snapshot>,
    settings: TelemetrySettings,
    shared: Arc<LinkCounters>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<std::thread::JoinHandle<TelemetryStats>> {
    std::thread::Builder::new()
        .name("dima-telemetry".into())
        .spawn(move || TelemetryWorker::new(open, commands, snapshot, settings, shared, stop).run())
}

/// The telemetry thread's state.
struct TelemetryWorker {
    open: Opener<SerialPort>,
    snapshot: triple_buffer::Output<Snapshot>,
    settings: TelemetrySettings,
    /// The link's counters for the realtime loop.
    shared: Arc<LinkCounters>,
    stop: Arc<AtomicBool>,
    stats: TelemetryStats,
    /// The XBee, while its port is open.
    radio: Option<XBee<SerialPort, Transparent>>,
    link: CommandLink,
    downlink: Downlink,
    hand_off: CommandHandOff,
    /// The last attempt to open the port.
    last_open: Option<Instant>,
    arrival: ArrivalBound,
    /// Failed opens in a row.
    failures: u64,
    /// When the next display frame is due.
    next_display: Instant,
}

impl TelemetryWorker {
    /// The thread's state before its first open.
    fn new(
        open: Opener<SerialPort>,
        commands: rtrb::Producer<ReceivedCommand>,
        snapshot: triple_buffer::Output<Snapshot>,
        settings: TelemetrySettings,
        shared: Arc<LinkCounters>,
        stop: Arc<AtomicBool>,
    ) -> TelemetryWorker {
        TelemetryWorker {
            open,
            snapshot,
            link: CommandLink::new(&settings.security),
            downlink: Downlink::new(settings.security.clone(), settings.controllers),
            hand_off: CommandHandOff::new(commands),
            next_display: Instant::now() + settings.display_period,
            settings,
            shared,
            stop,
            stats: TelemetryStats::default(),
            radio: None,
            last_open: None,
            arrival: ArrivalBound::new(monotonic_ns()),
            failures: 0,
        }
    }

    /// Opens the radio, hands its commands to the loop and sends display frames until
    /// `stop`; returns what it counted.
    fn run(mut self) -> TelemetryStats {
        if let Err(e) = crate::rt::setup::set_fifo(self.settings.priority) {
            tracing::warn!(
                "telemetry: SCHED_FIFO {} refused ({e}); running SCHED_OTHER",
                self.settings.priority
            );
        }
        while !self.stop.load(Ordering::Relaxed) {
            let now = Instant::now();
            if self.radio.is_none()
                && self
                    .last_open
                    .is_none_or(|t| now - t >= self.settings.reopen_interval)
            {
                self.try_open(now);
            }
            // Commands still waiting for room in the ring go first, in order.
            self.hand_off.flush();
            if self.radio.is_none() {
                std::thread::sleep(Duration::from_millis(20));
                continue;
            }
            let mut result = self.receive_until(now);
            self.shared.store(&self.link.counters());
            if result.is_ok() && Instant::now() >= self.next_display {
                result = self.send_display();
            }
            if result.is_err() {
                self.stats.port_errors += 1;
                tracing::warn!("XBee: port failed; reopening");
                self.radio = None;
                self.link.reset();
            }
        }
        self.stats.commands = self.link.v1_stats();
        self.stats.link = self.link.counters();
        self.stats.commands_dropped = self.hand_off.dropped();
        self.stats
    }

    /// Tries to open the port at `now` (warning on the first failure and every 60th).
    fn try_open(&mut self, now: Instant) {
        self.last_open = Some(now);
        let opened_ns = monotonic_ns();
        match (self.open)() {
            Ok(port) => {
                tracing::info!("XBee: connected");
                self.failures = 0;
                self.link.reset();
                self.arrival = ArrivalBound::new(opened_ns);
                self.radio = Some(XBee::new(port));
                if self.settings.security.key.is_some() {
                    // The station learns the session from the first display frame.
                    self.next_display = now;
                }
            }
            Err(e) => {
                self.failures += 1;
                let failures = self.failures;
                if failures == 1 || failures.is_multiple_of(60) {
                    tracing::warn!("{e:#} (attempt {failures}; retrying)");
                }
            }
        }
    }

    /// Waits for input until the next display frame is due (at most 20 ms from `now`) and
    /// hands each command received to the loop.
    fn receive_until(&mut self, now: Instant) -> Result<(), RadioFailed> {
        let Some(r) = self.radio.as_mut() else {
            return Ok(());
        };
        let wait = self
            .next_display
            .saturating_duration_since(now)
            .min(Duration::from_millis(20));
        let deadline_ns = monotonic_ns() + wait.as_nanos() as u64;
        match r.serial_mut().wait_input(deadline_ns) {
            Ok(readable) => {
                if !readable {
                    self.arrival.wait_timed_out(deadline_ns);
                }
                let hand_off = &mut self.hand_off;
                receive(r, &mut self.link, &mut self.arrival, |c| {
                    // Hand over first (a kill goes straight to the loop), then report.
                    hand_off.push(c);
                    if matches!(c.command, Command::Kill | Command::Revive) {
                        tracing::info!("ground link: {:?}", c.command);
                    }
                })
            }
            Err(_) => Err(RadioFailed),
        }
    }

    /// Sends the display frames of the latest snapshot (within 200 ms) and schedules the
    /// next ones.
    fn send_display(&mut self) -> Result<(), RadioFailed> {
        self.next_display += self.settings.display_period;
        if self.next_display < Instant::now() {
            self.next_display = Instant::now() + self.settings.display_period;
        }
        let Some(r) = self.radio.as_mut() else {
            return Ok(());
        };
        let snap = *self.snapshot.read();
        let frames = self.downlink.frames(&snap, &self.link);
        match send(r, &self.downlink.bytes, monotonic_ns() + 200_000_000) {
            Ok(true) => {
                self.stats.display_frames += frames;
                Ok(())
            }
            Ok(false) => {
                tracing::debug!("XBee: display frame not sent in time");
                Ok(())
            }
            Err(e) => Err(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_groundlink::Percent;

    fn link(require_auth: bool, key: Option<LinkKey>) -> CommandLink {
        CommandLink::new(&LinkSecurity {
            key,
            require_auth,
            session: 77,
        })
    }

    fn fed(link: &mut CommandLink, bytes: &[u8]) -> Vec<Command> {
        let mut got = Vec::new();
        for &b in bytes {
            link.push(b, &mut |c| got.push(c));
        }
        got
    }

    #[test]
    fn v1_frames_act_only_without_require_auth() {
        let key = LinkKey::from_bytes([3; 16]);
        let v1: Vec<u8> = [Command::Revive, Command::Throttle(Percent::MAX)]
            .iter()
            .flat_map(|c| c.encode())
            .collect();
        let mut strict = link(true, Some(key.clone()));
        assert!(fed(&mut strict, &v1).is_empty());
        assert_eq!(strict.counters().v1_ignored, 2);
        let mut open = link(false, None);
        assert_eq!(fed(&mut open, &v1).len(), 2);
        assert_eq!(open.counters().v1_accepted, 2);

        // With a key and require_auth = false, both versions act.
        let mut both = link(false, Some(key.clone()));
        let v2 = v2::CommandFrame::new(Command::Kill, 77, 9).encode(&key);
        let mut stream = v1.clone();
        stream.extend_from_slice(&v2);
        assert_eq!(fed(&mut both, &stream).len(), 3);
        assert_eq!(both.last_accepted(), 9);
        assert_eq!(both.counters().v2_accepted, 1);
    }

    #[test]
    fn a_throttle_requested_before_the_revive_is_counted_and_reaches_the_loop_as_a_heartbeat() {
        let key = LinkKey::from_bytes([3; 16]);
        let mut strict = link(true, Some(key.clone()));
        let throttle = Command::Throttle(Percent::new(80).unwrap());
        let mut stream = Vec::new();
        for (command, seq, request) in [
            (throttle, 1, 1),
            (Command::Revive, 2, 2),
            (throttle, 3, 1),
            (Command::Revive, 4, 2),
        ] {
            stream.extend(v2::CommandFrame::repeat(command, 77, seq, request).encode(&key));
        }
        assert_eq!(
            fed(&mut strict, &stream),
            [
                throttle,
                Command::Revive,
                Command::Heartbeat,
                Command::Heartbeat
            ]
        );
        let counters = strict.counters();
        assert_eq!(
            (
                counters.v2_accepted,
                counters.pre_revive_requests,
                counters.revive_repeats
            ),
            (4, 1, 1)
        );
        assert_eq!(strict.last_accepted(), 4);
    }

    #[test]
    fn shared_link_counters_carry_every_field() {
        let counters = GroundLinkCounters {
            v2_accepted: 1,
            bad_tag: 2,
            replayed: 3,
            stale_session: 4,
            malformed: 5,
            kills_outside_window: 6,
            revive_repeats: 7,
            pre_revive_requests: 8,
            v1_accepted: 9,
            v1_ignored: 10,
            v1_rejected: 11,
            v1_crc_errors: 12,
        };
        let shared = LinkCounters::default();
        shared.store(&counters);
        assert_eq!(shared.load(), counters);
    }

    #[test]
    fn display_v2_carries_mode_cause_counters_and_ack() {
        let snap = Snapshot {
            mode: Mode::Failsafe,
            cause: Some(FailsafeCause::SensorLoss),
            refusal: Some(ReviveRefusal::TooSoon),
            counters: dima_core::counters::Counters {
                missed_periods: 3,
                packet_crc_errors: 1,
                packets_late: 2,
                packets_missing: 5,
                commands: u64::MAX,
                ..Default::default()
            },
            ..Snapshot::default()
        };
        let counters = GroundLinkCounters {
            bad_tag: 4,
            v1_ignored: 6,
            ..Default::default()
        };
        let frame = display_frame_v2(&snap, 11, 12, 13, &counters);
        assert_eq!(frame.mode, v2::RobotMode::Failsafe);
        assert_eq!(frame.failsafe_cause, Some(v2::FailsafeCause::SensorLoss));
        assert_eq!(frame.revive_refusal, Some(v2::ReviveRefusal::TooSoon));
        assert_eq!((frame.session, frame.seq, frame.ack_seq), (11, 12, 13));
        let h = frame.health;
        assert_eq!(
            (h.missed_periods, h.sensor_bad, h.sensor_missing),
            (3, 3, 5)
        );
        assert_eq!(h.commands, u32::MAX);
        assert_eq!((h.bad_tag, h.v1_ignored), (4, 6));
    }

    #[test]
    fn display_v3_carries_the_outputs_and_setpoints_the_robot_has() {
        // AUTO after "send speed" alone: a speed setpoint, no heading setpoint.
        let snap = Snapshot {
            mode: Mode::Auto,
            targets: ServoTargets {
                pulse_us: [1700, 1545, 1500],
            },
            setpoints: dima_core::safety::Setpoints {
                speed_mm_s: Some(1500),
                ..Default::default()
            },
            speed_mm_s: Some(1200.4),
            heading_deg: Some(359.5),
            ..Snapshot::default()
        };
        let kinds = [
            v2::ControllerCode::SpeedPid,
            v2::ControllerCode::HeadingPid,
            v2::ControllerCode::Neutral,
        ];
        let report = RobotReport::new(&snap, 1, 2, 3, &GroundLinkCounters::default(), kinds);
        let frame = report.display_v3();
        assert_eq!(frame.status, report.display_v2());
        assert_eq!(frame.status.mode, v2::RobotMode::Auto);
        let a = frame.actuation;
        assert_eq!(a.servo_quarter_us, [6800, 6180, 6000]);
        assert_eq!(a.speed_setpoint_mm_s, Some(1500));
        assert_eq!(a.heading_setpoint_deg_e5, None);
        assert_eq!(a.speed_estimate_mm_s, Some(1200));
        assert_eq!(a.heading_estimate_deg_e5, Some(35_950_000));
        assert_eq!(a.speed_error_mm_s, Some(300));
        assert_eq!(a.controllers, kinds);

        // FAILSAFE: the safe targets the loop commanded, whatever was asked before.
        let failsafe = Snapshot {
            mode: Mode::Failsafe,
            cause: Some(FailsafeCause::CommsLoss),
            targets: ServoTargets {
                pulse_us: [1500, 1545, 1500],
            },
            speed_mm_s: None,
            ..snap
        };
        let a = RobotReport::new(&failsafe, 1, 3, 3, &GroundLinkCounters::default(), kinds)
            .display_v3()
            .actuation;
        assert_eq!(a.servo_quarter_us, [6000, 6180, 6000]);
        assert_eq!(a.speed_error_mm_s, None);
    }

    fn drain(ring: &mut rtrb::Consumer<ReceivedCommand>) -> Vec<Command> {
        std::iter::from_fn(|| ring.pop().ok().map(|c| c.command)).collect()
    }

    /// `command` as received at time 0.
    fn received(command: Command) -> ReceivedCommand {
        ReceivedCommand {
            command,
            arrival_ns: 0,
        }
    }

    #[test]
    fn commands_keep_their_order_through_a_full_ring() {
        let (tx, mut rx) = rtrb::RingBuffer::new(2);
        let mut h = CommandHandOff::new(tx);
        let t = |p| Command::Throttle(Percent::new(p).unwrap());
        for p in 0..5 {
            h.push(received(t(p)));
        }
        assert_eq!(drain(&mut rx), [t(0), t(1)]);
        h.flush();
        assert_eq!(drain(&mut rx), [t(2), t(3)]);
        h.push(received(t(5)));
        assert_eq!(drain(&mut rx), [t(4), t(5)]);
        assert_eq!(h.dropped(), 0);
    }

    #[test]
    fn a_kill_goes_first_and_voids_what_waits() {
        let (tx, mut rx) = rtrb::RingBuffer::new(2);
        let mut h = CommandHandOff::new(tx);
        // A revive waiting behind a full ring must not come after the kill.
        h.push(received(Command::Heartbeat));
        h.push(received(Command::Heartbeat));
        h.push(received(Command::Revive));
        h.push(received(Command::Kill));
        assert_eq!(drain(&mut rx), [Command::Heartbeat, Command::Heartbeat]);
        h.flush();
        assert_eq!(drain(&mut rx), [Command::Kill]);
        assert_eq!(h.dropped(), 1);
        // With room in the ring the kill is pushed at once, before anything else.
        h.push(received(Command::Kill));
        assert_eq!(drain(&mut rx), [Command::Kill]);
    }

    #[test]
    fn the_queue_is_bounded_and_counts_drops() {
        let (tx, _rx) = rtrb::RingBuffer::new(1);
        let mut h = CommandHandOff::new(tx);
        for _ in 0..(1 + PENDING_COMMANDS + 10) {
            h.push(received(Command::Heartbeat));
        }
        assert_eq!(h.dropped(), 10);
        assert_eq!(h.pending.len(), PENDING_COMMANDS);
    }

    const MS: Nanos = 1_000_000;

    #[test]
    fn arrival_is_the_last_time_the_port_was_seen_empty() {
        // Opened at 10 ms; a frame read at 30 ms after a wait that began at 12 ms arrived
        // after 10 ms, the last time anything showed the port empty.
        let mut a = ArrivalBound::new(10 * MS);
        a.byte_read();
        assert_eq!(a.earliest_ns(), 10 * MS);
        a.found_empty(31 * MS);
        // A wait until 51 ms saw nothing: bytes read afterwards arrived after 51 ms.
        a.wait_timed_out(51 * MS);
        assert_eq!(a.earliest_ns(), 51 * MS);
    }

    #[test]
    fn a_stalled_reader_does_not_make_old_bytes_look_new() {
        // The port was last seen empty at 100 ms; the reader then stalls for 800 ms and reads
        // a backlog at 900 ms: the backlog is dated 100 ms, not 900 ms.
        let mut a = ArrivalBound::new(0);
        a.found_empty(100 * MS);
        a.byte_read();
        assert_eq!(a.earliest_ns(), 100 * MS);
        // A batch cut short (bytes left in the port): a timed-out wait does not move the
        // bound past bytes still waiting to be read.
        a.wait_timed_out(920 * MS);
        assert_eq!(a.earliest_ns(), 100 * MS);
        a.found_empty(930 * MS);
        assert_eq!(a.earliest_ns(), 930 * MS);
        // Never backwards.
        a.found_empty(925 * MS);
        assert_eq!(a.earliest_ns(), 930 * MS);
    }
}
