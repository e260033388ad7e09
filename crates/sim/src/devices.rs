//! The simulated devices as threads on the device side of their pseudo-terminals: the sensor
//! board, the Maestro, the scripted ground station, and the relay that gives a GUI its own pty.
//!
//! Each thread applies its link's [`FaultSpec`]: disconnect windows close the pty (the
//! application sees a hang-up) and reopen it at the end, silent windows send nothing, and
//! every frame passes through a [`FaultInjector`].

use std::collections::hash_map::DefaultHasher;
use std::collections::HashSet;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU16, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use dima_groundlink::station::{Station, StationTime};
use dima_groundlink::v2::{self, LinkKey};
use dima_groundlink::{Command, DisplayDecoder, DisplayFrame};
use pololu_maestro::{CommandDecoder, DecoderConfig};

use crate::board::{BoardConfig, BoardSim, SensorFaultState};
use crate::faults::{FaultInjector, FaultSpec, FaultStats, SensorFaults};
use crate::model::VehicleState;
use crate::pty::{LinePace, SimPty};
use crate::request::RequestLine;
use crate::rng::SimRng;
use crate::world::World;

/// Locks a mutex whatever a panicked thread left behind.
pub(crate) fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// A 64-bit fingerprint of a frame's bytes.
pub fn fingerprint(bytes: &[u8]) -> u64 {
    let mut h = DefaultHasher::new();
    bytes.hash(&mut h);
    h.finish()
}

/// A device's pty and link path, closed and reopened by the link's disconnect windows.
#[derive(Debug)]
pub struct LinkPort {
    link: PathBuf,
    pty: Option<SimPty>,
    /// Times the pty was (re)opened.
    pub opens: u64,
}

impl LinkPort {
    /// Opens the first pty behind `link`.
    pub fn open(link: &Path) -> std::io::Result<LinkPort> {
        Ok(LinkPort {
            link: link.to_owned(),
            pty: Some(SimPty::open(link)?),
            opens: 1,
        })
    }

    /// Closes or reopens according to `spec` at `t_s`; the pty when connected.
    pub fn update(&mut self, spec: &FaultSpec, t_s: f64) -> Option<&SimPty> {
        let unplugged = spec.disconnected_at(t_s);
        if unplugged && self.pty.is_some() {
            self.pty = None;
        } else if !unplugged && self.pty.is_none() {
            if let Ok(p) = SimPty::open(&self.link) {
                self.pty = Some(p);
                self.opens += 1;
            }
        }
        self.pty.as_ref()
    }

    /// The pty, if connected.
    pub fn pty(&self) -> Option<&SimPty> {
        self.pty.as_ref()
    }
}

/// What the simulated sensor board saw and did.
#[derive(Debug, Default)]
pub struct BoardStats {
    /// Rising edges of the request line.
    pub requests: AtomicU64,
    /// Answers written (packet, maybe with an info frame).
    pub answers: AtomicU64,
    /// Packets that went out unchanged.
    pub packets_intact: AtomicU64,
    /// Packets that went out damaged by the fault injector.
    pub packets_damaged: AtomicU64,
    /// Info pieces sent (one behind a packet while a snapshot goes out).
    pub info_frames: AtomicU64,
    /// Answers that were complete later than [`LATE_ANSWER`] after their request (the board
    /// thread was held up by the machine): the application may count them missing.
    pub late_answers: AtomicU64,
    /// Requests not answered: silent window, unplugged, or a request while busy.
    pub unanswered: AtomicU64,
    /// Fingerprints of the packets sent unchanged.
    pub intact: Mutex<HashSet<u64>>,
    /// Fingerprints of the damaged packets as sent.
    pub damaged: Mutex<HashSet<u64>>,
    /// What the fault injector did.
    pub faults: Mutex<FaultStats>,
    /// Times the pty was (re)opened.
    pub opens: AtomicU64,
    /// Count only: keep no fingerprints (a long run's memory stays flat).
    pub counts_only: bool,
}

/// An answer written this long after its request edge misses the application's default packet
/// deadline (3.7 ms).
pub const LATE_ANSWER: Duration = Duration::from_micros(3_700);

/// The simulated sensor board's settings for a run.
#[derive(Debug, Clone)]
pub struct BoardSetup {
    /// Where and how the board starts.
    pub config: BoardConfig,
    /// Faults of its link to the application.
    pub link_faults: FaultSpec,
    /// Faults of its sensors.
    pub sensor_faults: SensorFaults,
    /// Its UART's pace towards the application.
    pub pace: LinePace,
}

/// Runs the simulated sensor board until `stop`. Like the firmware, it answers a request
/// only when its line is idle: requests that arrive while an answer is still going out are
/// skipped (and counted as unanswered).
pub fn spawn_board(
    world: Arc<World>,
    line: Arc<RequestLine>,
    port: LinkPort,
    setup: BoardSetup,
    rng: SimRng,
    stats: Arc<BoardStats>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<JoinHandle<()>> {
    let BoardSetup {
        config,
        link_faults: spec,
        sensor_faults,
        pace,
    } = setup;
    let worker = BoardWorker {
        world,
        line,
        port,
        board: BoardSim::new(config, rng.fork(1)),
        injector: FaultInjector::new(spec.clone(), rng.fork(2)),
        spec,
        sensor_faults,
        pace,
        stats,
        stop,
        seen: 0,
        out: Vec::with_capacity(512),
        wire: Vec::with_capacity(512),
    };
    std::thread::Builder::new()
        .name("sim-board".into())
        .spawn(move || worker.run())
}

/// The sensor board thread's state.
struct BoardWorker {
    world: Arc<World>,
    line: Arc<RequestLine>,
    port: LinkPort,
    board: BoardSim,
    injector: FaultInjector,
    spec: FaultSpec,
    sensor_faults: SensorFaults,
    pace: LinePace,
    stats: Arc<BoardStats>,
    stop: Arc<AtomicBool>,
    /// Request edges taken so far.
    seen: u64,
    /// One frame as the fault injector left it.
    out: Vec<u8>,
    /// The whole answer as it goes out.
    wire: Vec<u8>,
}

impl BoardWorker {
    /// Answers request edges until `stop`.
    fn run(mut self) {
        self.line.listen();
        // Answer requests promptly on a busy machine when the system allows it.
        let _ = set_fifo(70);
        self.seen = self.line.edges();
        while !self.stop.load(Ordering::Relaxed) {
            let now = self.line.wait_edge(self.seen, Duration::from_millis(5));
            let t = self.world.now_s();
            let connected = self.maintain_port(t);
            if now == self.seen {
                continue;
            }
            let edge_at = self.take_edges(now);
            if !connected || self.spec.silent_at(t) {
                self.stats.unanswered.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            self.answer(t, edge_at);
            self.count_late_answer();
            self.skip_requests_during_answer();
            self.stats.answers.fetch_add(1, Ordering::Relaxed);
            *lock(&self.stats.faults) = self.injector.stats();
        }
    }

    /// Opens or closes the pty by the link's disconnect windows at `t` and drains what the
    /// host sent; true when connected.
    fn maintain_port(&mut self, t: f64) -> bool {
        let connected = self.port.update(&self.spec, t).is_some();
        self.stats.opens.store(self.port.opens, Ordering::Relaxed);
        if let Some(pty) = self.port.pty() {
            // The host sends nothing on this link; drop whatever arrives.
            let mut junk = [0u8; 256];
            let _ = pty.read(&mut junk, Duration::ZERO);
        }
        connected
    }

    /// Takes the edges up to `now` (all but the last skipped: they came while the previous
    /// answer was still going out) and returns when the last one came.
    fn take_edges(&mut self, now: u64) -> std::time::Instant {
        let edges = now - self.seen;
        self.seen = now;
        // The board's DMA starts sending within microseconds of the edge.
        let edge_at = std::time::Instant::now()
            .checked_sub(self.line.since_last_edge())
            .unwrap_or_else(std::time::Instant::now);
        self.stats.requests.fetch_add(edges, Ordering::Relaxed);
        if edges > 1 {
            // Requests while the previous answer was still going out.
            for _ in 1..edges {
                self.board.skip_request();
            }
            self.stats
                .unanswered
                .fetch_add(edges - 1, Ordering::Relaxed);
        }
        edge_at
    }

    /// Builds the answer at `t` to the request that came at `edge_at`, passes it through the
    /// fault injector and writes it at the line's pace.
    fn answer(&mut self, t: f64, edge_at: std::time::Instant) {
        let state: VehicleState = self.world.state();
        let faults = SensorFaultState {
            gnss_frozen: self.sensor_faults.gnss_frozen_at(t),
            gnss_lost: self.sensor_faults.gnss_lost_at(t),
            imu_stuck: self.sensor_faults.imu_stuck_at(t),
            rolled_over: self.sensor_faults.rolled_over_at(t),
        };
        let answer = self.board.answer_with(t, &state, faults);
        // A delay fault postpones the whole transmission.
        let start = edge_at + self.injector.delay();
        self.wire.clear();
        self.injector.mangle(&answer.packet, &mut self.out);
        self.wire.extend_from_slice(&self.out);
        self.count_packet(&answer.packet);
        if let Some(info) = answer.info {
            self.injector.mangle(&info, &mut self.out);
            self.wire.extend_from_slice(&self.out);
            self.stats.info_frames.fetch_add(1, Ordering::Relaxed);
        }
        if let Some(pty) = self.port.pty() {
            let _ = pty.write_paced_from(start, &self.wire, self.pace, Duration::from_millis(50));
        }
    }

    /// Counts `packet` as intact or damaged by what the fault injector made of it (in `out`).
    fn count_packet(&self, packet: &[u8]) {
        let stats = &self.stats;
        // Intact: the packet's bytes arrive unchanged and in one piece (garbage inserted
        // before its first byte does not damage it).
        let intact = self.out.windows(packet.len()).any(|w| w == packet);
        if intact {
            stats.packets_intact.fetch_add(1, Ordering::Relaxed);
            if !stats.counts_only {
                lock(&stats.intact).insert(fingerprint(packet));
            }
        } else {
            stats.packets_damaged.fetch_add(1, Ordering::Relaxed);
            if !stats.counts_only {
                lock(&stats.damaged).insert(fingerprint(&self.out));
            }
        }
    }

    /// Counts the answer late when it was complete after the deadline, or after the next
    /// request already came.
    fn count_late_answer(&self) {
        if self.line.edges() != self.seen || self.line.since_last_edge() > LATE_ANSWER {
            self.stats.late_answers.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Skips the requests that came while the answer was going out: they are not answered.
    fn skip_requests_during_answer(&mut self) {
        let during = self.line.edges() - self.seen;
        if during > 0 {
            self.seen += during;
            self.stats.requests.fetch_add(during, Ordering::Relaxed);
            self.stats.unanswered.fetch_add(during, Ordering::Relaxed);
            for _ in 0..during {
                self.board.skip_request();
            }
        }
    }
}

/// SCHED_FIFO for the calling thread when permitted (ignored otherwise).
pub(crate) fn set_fifo(priority: i32) -> std::io::Result<()> {
    let param = nix::libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: pthread_self() is the calling thread and `param` a valid sched_param.
    let rc = unsafe {
        nix::libc::pthread_setschedparam(nix::libc::pthread_self(), nix::libc::SCHED_FIFO, &param)
    };
    if rc == 0 {
        Ok(())
    } else {
        Err(std::io::Error::from_raw_os_error(rc))
    }
}

/// One change of the Maestro's outputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputChange {
    /// Simulation time, s.
    pub t_s: f64,
    /// Targets of the throttle, steering and tail channels, quarter-µs (0: no pulses).
    pub targets_qus: [u16; 3],
}

/// What the simulated Maestro received.
#[derive(Debug)]
pub struct MaestroStats {
    /// Current target of every channel, quarter-µs (0xFFFF: never set).
    pub targets: [AtomicU16; 24],
    /// Set Target commands decoded.
    pub commands: AtomicU64,
    /// Bytes the decoder could not use.
    pub dropped_bytes: AtomicU64,
    /// Every change of the three DIMA channels, in order (see
    /// [`MaestroStats::safe_transitions_only`]).
    pub history: Mutex<Vec<OutputChange>>,
    /// Times the pty was (re)opened.
    pub opens: AtomicU64,
    /// Commands received since the last (re)open.
    pub commands_since_open: AtomicU64,
    /// When set (the safe outputs, µs), `history` keeps only the changes from these outputs to
    /// any others and back, so it stays small however long the run (a soak: its checks only
    /// ask whether the car was safe or drove). `None`: every change.
    pub safe_transitions_only: Option<[u16; 3]>,
}

impl Default for MaestroStats {
    fn default() -> Self {
        MaestroStats {
            targets: std::array::from_fn(|_| AtomicU16::new(0xFFFF)),
            commands: AtomicU64::new(0),
            dropped_bytes: AtomicU64::new(0),
            history: Mutex::new(Vec::new()),
            opens: AtomicU64::new(0),
            commands_since_open: AtomicU64::new(0),
            safe_transitions_only: None,
        }
    }
}

impl MaestroStats {
    /// Targets of `channels`, quarter-µs.
    pub fn targets_of(&self, channels: [u8; 3]) -> [u16; 3] {
        channels.map(|c| self.targets[usize::from(c) % 24].load(Ordering::Relaxed))
    }

    /// The outputs in force at simulation time `t_s` (None before the first command).
    pub fn outputs_at(&self, t_s: f64) -> Option<[u16; 3]> {
        lock(&self.history)
            .iter()
            .take_while(|c| c.t_s <= t_s)
            .last()
            .map(|c| c.targets_qus)
    }

    /// A copy of the history.
    pub fn history(&self) -> Vec<OutputChange> {
        lock(&self.history).clone()
    }

    /// Adds a change of the outputs to the history (all of them, or with
    /// [`MaestroStats::safe_transitions_only`] only those between safe and other outputs).
    pub fn record(&self, change: OutputChange) {
        let mut history = lock(&self.history);
        if let Some(safe_us) = self.safe_transitions_only {
            let is_safe = |targets_qus: [u16; 3]| targets_qus.map(|q| q / 4) == safe_us;
            if history
                .last()
                .is_some_and(|last| is_safe(last.targets_qus) == is_safe(change.targets_qus))
            {
                return;
            }
        }
        history.push(change);
    }
}

/// Runs the simulated Maestro until `stop`; `channels` are the throttle, steering and tail
/// channel numbers whose pulses drive the model.
pub fn spawn_maestro(
    world: Arc<World>,
    port: LinkPort,
    channels: [u8; 3],
    spec: FaultSpec,
    rng: SimRng,
    stats: Arc<MaestroStats>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<JoinHandle<()>> {
    let worker = MaestroWorker {
        world,
        port,
        channels,
        decoder: CommandDecoder::new(DecoderConfig::default()),
        injector: FaultInjector::new(spec.clone(), rng.fork(3)),
        spec,
        stats,
        stop,
        mangled: Vec::with_capacity(512),
        last: [0xFFFF; 3],
        opens: 0,
    };
    std::thread::Builder::new()
        .name("sim-maestro".into())
        .spawn(move || worker.run())
}

/// The Maestro thread's state.
struct MaestroWorker {
    world: Arc<World>,
    port: LinkPort,
    /// The throttle, steering and tail channel numbers.
    channels: [u8; 3],
    decoder: CommandDecoder,
    injector: FaultInjector,
    spec: FaultSpec,
    stats: Arc<MaestroStats>,
    stop: Arc<AtomicBool>,
    /// The bytes received as the fault injector left them.
    mangled: Vec<u8>,
    /// The outputs last handed to the model, quarter-µs (0xFFFF: not set).
    last: [u16; 3],
    /// The port's open count when last seen.
    opens: u64,
}

impl MaestroWorker {
    /// Decodes commands and drives the model until `stop`.
    fn run(mut self) {
        let mut buf = [0u8; 512];
        while !self.stop.load(Ordering::Relaxed) {
            let t = self.world.now_s();
            let connected = self.port.update(&self.spec, t).is_some();
            if self.port.opens != self.opens {
                self.reopened();
            }
            let (true, Some(pty)) = (connected, self.port.pty()) else {
                std::thread::sleep(Duration::from_millis(5));
                continue;
            };
            let n = pty.read(&mut buf, Duration::from_millis(5)).unwrap_or(0);
            if n == 0 {
                continue;
            }
            self.receive(&buf[..n]);
            self.publish_outputs();
        }
    }

    /// The port was reopened: a Maestro that was unplugged lost its targets, and the host
    /// must send them again.
    fn reopened(&mut self) {
        self.opens = self.port.opens;
        self.decoder.reset();
        for t in &self.stats.targets {
            t.store(0xFFFF, Ordering::Relaxed);
        }
        self.last = [0xFFFF; 3];
        self.stats.opens.store(self.opens, Ordering::Relaxed);
        self.stats.commands_since_open.store(0, Ordering::Relaxed);
    }

    /// Decodes `bytes` (through the link's faults) and sets the targets they command.
    fn receive(&mut self, bytes: &[u8]) {
        // Errors on the way in (the USB link) are applied to what the device receives.
        self.injector.mangle(bytes, &mut self.mangled);
        let stats = &self.stats;
        let set = |ch: u8, qus: u16| {
            if let Some(slot) = stats.targets.get(usize::from(ch)) {
                slot.store(qus, Ordering::Relaxed);
            }
            stats.commands.fetch_add(1, Ordering::Relaxed);
            stats.commands_since_open.fetch_add(1, Ordering::Relaxed);
        };
        for &b in &self.mangled {
            let Some(command) = self.decoder.push(b) else {
                continue;
            };
            match command {
                pololu_maestro::Command::SetTarget { channel, target } => {
                    set(channel.index(), target.get())
                }
                pololu_maestro::Command::SetMultipleTargets(m) => {
                    for (ch, target) in m.iter() {
                        set(ch, target.get());
                    }
                }
                _ => {}
            }
        }
        stats.dropped_bytes.store(
            u64::from(self.decoder.stats().dropped_bytes),
            Ordering::Relaxed,
        );
    }

    /// Records a change of the three channels' outputs and hands the pulses to the model,
    /// once all three are set.
    fn publish_outputs(&mut self) {
        let now = self.stats.targets_of(self.channels);
        if now != self.last && now.iter().all(|&q| q != 0xFFFF) {
            self.last = now;
            self.stats.record(OutputChange {
                t_s: self.world.now_s(),
                targets_qus: now,
            });
            self.world.set_pulses(now.map(|q| f64::from(q) / 4.0));
        }
    }
}

/// One step of a ground-station script.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GroundAction {
    /// Send a command. Version 1: once, in place of the heartbeat of its 100 ms slot.
    /// Version 2: requested from the ground station's [`Station`] at its time, which sends it
    /// the way the ground station does (a kill at once and repeated, a revive no sooner than
    /// its wait after a kill, the others in the next slot, repeated until acknowledged).
    Send(Command),
    /// Stop sending anything (the operator's radio is off).
    Silence,
    /// Resume heartbeats.
    Resume,
    /// Send these exact bytes (a frame captured from another ground station).
    Raw([u8; 10]),
}

/// A ground-station action at a time of the run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScriptStep {
    /// When, s from the start.
    pub at_s: f64,
    /// What.
    pub action: GroundAction,
}

/// What the scripted ground station sent and received.
#[derive(Debug, Default)]
pub struct GroundStats {
    /// Frames sent (heartbeats and commands).
    pub frames_sent: AtomicU64,
    /// The command of every frame sent other than a heartbeat (v2: every repetition too),
    /// with the time it went out, s: when a kill or a revive actually reached the link.
    pub commands: Mutex<Vec<(f64, Command)>>,
    /// Time of the last frame sent, s (NaN before the first).
    pub last_sent_s: Mutex<Option<f64>>,
    /// Display frames received intact.
    pub displays: AtomicU64,
    /// Display frames rejected by the decoder (CRC or range; v2: tag, mode or range).
    pub display_errors: AtomicU64,
    /// The sensor values of the last display frame and its arrival time, s.
    pub last_display: Mutex<Option<(f64, DisplayFrame)>>,
    /// The last display frame v2, or the v2 fields of a v3 one (mode, health,
    /// acknowledgement), and its arrival time, s.
    pub last_status: Mutex<Option<(f64, v2::DisplayFrame)>>,
    /// Samples of the model: time and state, once per 100 ms.
    pub truth: Mutex<Vec<VehicleState>>,
    /// Count only: keep no model samples and no list of commands (a long run's memory
    /// stays flat).
    pub counts_only: bool,
}

/// The frame period of the ground station: one frame every 100 ms, as
/// `dima_groundlink::station` sends them (docs/wire-formats.md, the ground link).
pub const GROUND_PERIOD_S: f64 = 0.1;

/// Which ground link the scripted station speaks.
#[derive(Debug, Clone)]
pub enum GroundProtocol {
    /// Version 1: unauthenticated frames, this heartbeat in idle slots.
    V1 {
        /// The heartbeat frame.
        heartbeat: [u8; 10],
    },
    /// Version 2 with this key, run by the ground station's own [`Station`]: it learns the
    /// robot's session from its display frames and sends nothing but kills (with session 0)
    /// before it knows it; what was asked for before then waits.
    V2 {
        /// The pre-shared key.
        key: LinkKey,
    },
}

/// One frame the scripted station sends: the command it carries (none for heartbeats and
/// captured frames) and its bytes.
struct Outgoing {
    command: Option<Command>,
    bytes: Vec<u8>,
}

/// The scripted station's side of the link: display frames in, command frames out.
enum StationSide {
    /// Ground link v1: each command of the script goes out once, in the slot it falls due in;
    /// an idle slot carries the heartbeat.
    V1 {
        heartbeat: [u8; 10],
        decoder: DisplayDecoder,
        /// Start of the next 100 ms slot, s.
        next_slot: f64,
    },
    /// Ground link v2: the ground station's own [`Station`] decides what goes out when.
    V2 {
        key: LinkKey,
        /// Display frames v2 and v3 (the robot sends v3).
        decoder: Box<v2::DownlinkDecoder>,
        station: Box<Station>,
    },
}

/// The scripted ground station: its script and its side of the link.
struct ScriptedStation {
    side: StationSide,
    script: Vec<ScriptStep>,
    /// The next script step to take.
    step: usize,
    /// False from a [`GroundAction::Silence`] to the next [`GroundAction::Resume`].
    sending: bool,
}

/// Simulation time `t_s` on the station clock (the epoch is the start of the run).
fn station_time(t_s: f64) -> StationTime {
    StationTime::from_secs_f64(t_s.max(0.0))
}

impl ScriptedStation {
    /// A station speaking `protocol` on a radio link of `pace`.
    fn new(protocol: GroundProtocol, script: Vec<ScriptStep>, pace: LinePace) -> ScriptedStation {
        let side = match protocol {
            GroundProtocol::V1 { heartbeat } => StationSide::V1 {
                heartbeat,
                decoder: DisplayDecoder::new(),
                next_slot: 0.0,
            },
            GroundProtocol::V2 { key } => {
                let mut station = Box::new(Station::new());
                station.set_link_baud(pace.baud_8n1());
                StationSide::V2 {
                    decoder: Box::new(v2::DownlinkDecoder::new(key.clone())),
                    key,
                    station,
                }
            }
        };
        ScriptedStation {
            side,
            script,
            step: 0,
            sending: true,
        }
    }

    /// Takes the bytes received at `at` (s): display frames to the statistics (v2: and to the
    /// station).
    fn receive(&mut self, bytes: &[u8], at: f64, stats: &GroundStats) {
        let count = |ok: bool| {
            let counter = if ok {
                &stats.displays
            } else {
                &stats.display_errors
            };
            counter.fetch_add(1, Ordering::Relaxed);
        };
        match &mut self.side {
            StationSide::V2 {
                decoder, station, ..
            } => {
                for result in decoder.feed(bytes) {
                    count(result.is_ok());
                    if let Ok(downlink) = result {
                        let frame = *downlink.status();
                        station.on_display(&frame, station_time(at));
                        *lock(&stats.last_display) = Some((at, frame.sensors));
                        *lock(&stats.last_status) = Some((at, frame));
                    }
                }
                // Nothing here records what became of each request.
                station.take_settled();
            }
            StationSide::V1 { decoder, .. } => {
                for result in decoder.feed(bytes) {
                    count(result.is_ok());
                    if let Ok(frame) = result {
                        *lock(&stats.last_display) = Some((at, frame));
                    }
                }
            }
        }
    }

    /// The time something falls due at the latest, s: the next script step or slot (`t_s`
    /// when one is due already).
    fn next_due_s(&self, t_s: f64) -> f64 {
        let slot = match &self.side {
            StationSide::V1 { next_slot, .. } => *next_slot,
            StationSide::V2 { station, .. } => station.next_due(station_time(t_s)).as_secs_f64(),
        };
        let step = self.script.get(self.step).map_or(f64::INFINITY, |s| s.at_s);
        slot.min(step)
    }

    /// The port was reopened: the first slot is immediate.
    fn reconnected(&mut self) {
        if let StationSide::V2 { station, .. } = &mut self.side {
            station.restart();
        }
    }

    /// Takes the script steps due at `t_s` and returns the frames due. Version 1 takes the
    /// steps at its slots; version 2 hands each command to the station at its time, and
    /// polls the station only while the port is `connected` (a closed port sends nothing,
    /// and the station keeps what was asked for).
    fn due(&mut self, t_s: f64, connected: bool) -> Vec<Outgoing> {
        let mut frames = Vec::new();
        match &mut self.side {
            StationSide::V1 {
                heartbeat,
                next_slot,
                ..
            } => {
                if t_s < *next_slot {
                    return frames;
                }
                *next_slot += GROUND_PERIOD_S;
                if *next_slot < t_s {
                    *next_slot = t_s + GROUND_PERIOD_S;
                }
                while let Some(s) = self.script.get(self.step).filter(|s| s.at_s <= t_s) {
                    match s.action {
                        GroundAction::Send(c) => frames.push(Outgoing {
                            command: Some(c),
                            bytes: c.encode().to_vec(),
                        }),
                        GroundAction::Raw(bytes) => frames.push(Outgoing {
                            command: None,
                            bytes: bytes.to_vec(),
                        }),
                        GroundAction::Silence => self.sending = false,
                        GroundAction::Resume => self.sending = true,
                    }
                    self.step += 1;
                }
                if frames.is_empty() {
                    frames.push(Outgoing {
                        command: None,
                        bytes: heartbeat.to_vec(),
                    });
                }
            }
            StationSide::V2 { key, station, .. } => {
                let now = station_time(t_s);
                let mut polled = Vec::new();
                while let Some(s) = self.script.get(self.step).filter(|s| s.at_s <= t_s) {
                    match s.action {
                        GroundAction::Send(c) => {
                            station.request(c, now);
                            // A kill goes out at once, whatever follows it.
                            if c == Command::Kill && connected {
                                polled.extend(station.poll(now));
                            }
                        }
                        GroundAction::Raw(bytes) => frames.push(Outgoing {
                            command: None,
                            bytes: bytes.to_vec(),
                        }),
                        GroundAction::Silence => self.sending = false,
                        GroundAction::Resume => self.sending = true,
                    }
                    self.step += 1;
                }
                if connected {
                    polled.extend(station.poll(now));
                }
                station.take_settled();
                frames.extend(polled.iter().map(|f| Outgoing {
                    command: (f.command != Command::Heartbeat).then_some(f.command),
                    bytes: f.encode(key).to_vec(),
                }));
            }
        }
        frames
    }
}

/// Runs the scripted ground station until `stop`. `pace` is the radio link's: the station
/// sends at its pace and (v2) fits each slot's frames within it.
#[allow(clippy::too_many_arguments)]
pub fn spawn_ground(
    world: Arc<World>,
    port: LinkPort,
    script: Vec<ScriptStep>,
    protocol: GroundProtocol,
    spec: FaultSpec,
    pace: LinePace,
    rng: SimRng,
    stats: Arc<GroundStats>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<JoinHandle<()>> {
    let worker = GroundWorker {
        world,
        opens: port.opens,
        port,
        ground: ScriptedStation::new(protocol, script, pace),
        injector: FaultInjector::new(spec.clone(), rng.fork(4)),
        spec,
        pace,
        stats,
        stop,
        next_sample: 0.0,
        out: Vec::with_capacity(64),
        wire: Vec::with_capacity(256),
    };
    std::thread::Builder::new()
        .name("sim-ground".into())
        .spawn(move || worker.run())
}

/// The scripted ground station thread's state.
struct GroundWorker {
    world: Arc<World>,
    port: LinkPort,
    /// The port's open count when last seen.
    opens: u64,
    ground: ScriptedStation,
    injector: FaultInjector,
    spec: FaultSpec,
    pace: LinePace,
    stats: Arc<GroundStats>,
    stop: Arc<AtomicBool>,
    /// When the model is sampled next, s.
    next_sample: f64,
    /// One frame as the fault injector left it.
    out: Vec<u8>,
    /// The slot's frames as they go out.
    wire: Vec<u8>,
}

impl GroundWorker {
    /// Receives, samples the model and sends the frames due until `stop`.
    fn run(mut self) {
        let mut buf = [0u8; 512];
        while !self.stop.load(Ordering::Relaxed) {
            let t = self.world.now_s();
            let connected = self.port.update(&self.spec, t).is_some();
            if self.port.opens != self.opens {
                self.opens = self.port.opens;
                self.ground.reconnected();
            }
            self.receive(t, &mut buf);
            let t = self.world.now_s();
            self.sample_model(t);
            let frames = self.ground.due(t, connected);
            // Silent: the frames are lost on the way (the station does not know).
            if frames.is_empty() || !self.ground.sending || !connected || self.spec.silent_at(t) {
                continue;
            }
            self.send(&frames);
        }
    }

    /// Reads what the robot sent until something falls due (at most 10 ms) and hands it to
    /// the station; waits 5 ms while unplugged.
    fn receive(&mut self, t: f64, buf: &mut [u8]) {
        if let Some(pty) = self.port.pty() {
            let wait = (self.ground.next_due_s(t).min(self.next_sample) - t).clamp(0.0, 0.01);
            let n = pty.read(buf, Duration::from_secs_f64(wait)).unwrap_or(0);
            self.ground
                .receive(&buf[..n], self.world.now_s(), &self.stats);
        } else {
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Keeps a sample of the model once per ground period.
    fn sample_model(&mut self, t: f64) {
        if t >= self.next_sample {
            self.next_sample += GROUND_PERIOD_S;
            if self.next_sample < t {
                self.next_sample = t + GROUND_PERIOD_S;
            }
            if !self.stats.counts_only {
                lock(&self.stats.truth).push(self.world.state());
            }
        }
    }

    /// Sends `frames` through the link's faults at the radio's pace, and records them when
    /// they all went out.
    fn send(&mut self, frames: &[Outgoing]) {
        self.wire.clear();
        for frame in frames {
            self.injector.mangle(&frame.bytes, &mut self.out);
            self.wire.extend_from_slice(&self.out);
        }
        let delay = self.injector.delay();
        if !delay.is_zero() {
            std::thread::sleep(delay);
        }
        let Some(pty) = self.port.pty() else {
            return;
        };
        let written = pty
            .write_paced(&self.wire, self.pace, Duration::from_millis(50))
            .unwrap_or(0);
        if written == self.wire.len() {
            let stats = &self.stats;
            let sent_at = self.world.now_s();
            stats
                .frames_sent
                .fetch_add(frames.len() as u64, Ordering::Relaxed);
            *lock(&stats.last_sent_s) = Some(sent_at);
            if !stats.counts_only {
                let mut log = lock(&stats.commands);
                for c in frames.iter().filter_map(|f| f.command) {
                    log.push((sent_at, c));
                }
            }
        }
    }
}

/// Copies bytes (towards the robot at the radio's pace) both ways between the application's XBee pty and a second pty a ground-station
/// GUI opens (a null-modem cable), applying the ground link's faults towards the robot.
pub fn spawn_relay(
    world: Arc<World>,
    mut robot: LinkPort,
    station: SimPty,
    spec: FaultSpec,
    pace: LinePace,
    rng: SimRng,
    stop: Arc<AtomicBool>,
) -> std::io::Result<JoinHandle<()>> {
    std::thread::Builder::new()
        .name("sim-relay".into())
        .spawn(move || {
            let mut injector = FaultInjector::new(spec.clone(), rng.fork(5));
            let mut buf = [0u8; 512];
            let mut out = Vec::with_capacity(512);
            while !stop.load(Ordering::Relaxed) {
                let t = world.now_s();
                let robot_pty = robot.update(&spec, t);
                let n = station
                    .read(&mut buf, Duration::from_millis(2))
                    .unwrap_or(0);
                if let Some(r) = robot_pty {
                    if n > 0 && !spec.silent_at(t) {
                        injector.mangle(&buf[..n], &mut out);
                        let _ = r.write_paced(&out, pace, Duration::from_millis(20));
                    }
                    let m = r.read(&mut buf, Duration::from_millis(2)).unwrap_or(0);
                    if m > 0 {
                        let _ = station.write(&buf[..m], Duration::from_millis(20));
                    }
                } else {
                    std::thread::sleep(Duration::from_millis(2));
                }
            }
        })
}
