//! The simulation runner: builds the simulated devices on pseudo-terminals, hands their paths
//! and the request line to the application, shows a live status line, and judges the run.
//!
//! The runner does not start the application itself: the caller passes a function that runs
//! the real application against an [`AppLaunch`] (its configuration with the pty paths, the
//! request pin, the stop flag) and reports an [`AppOutcome`]. `dima sim` passes the one that
//! calls the application's `run` with its production device layer. Both sides share
//! `dima-core`: the configuration, the modes, the counters and the log schema.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use anyhow::Context;
use dima_core::config::{bits_per_byte, Config};
use dima_core::control::OutputMap;
use dima_core::counters::Counters;
use dima_core::Mode;
use dima_groundlink::key_file;
use dima_groundlink::v2::LinkKey;

use crate::app_config::{app_config, SimPorts};
use crate::board::BoardConfig;
use crate::devices::{
    lock, spawn_board, spawn_ground, spawn_maestro, spawn_relay, BoardSetup, BoardStats,
    GroundProtocol, GroundStats, LinkPort, MaestroStats,
};
use crate::faults::{AppFaults, FaultWindow, Faults, LoopBusy};
use crate::firmware::{
    boot_firmware, firmware_checks, spawn_firmware_board, BootedFirmware, FirmwareStats,
};
use crate::host_load::{host_overload_hint, HostLoad};
use crate::logcheck::LogSummary;
use crate::model::VehicleParams;
use crate::pty::{LinePace, SimPty};
use crate::request::{RequestLine, RequestPin};
use crate::rng::SimRng;
use crate::scenario::{evaluate, Evidence, Scenario};
use crate::world::World;

/// The application's live state as its logger thread sees it, for the status line.
#[derive(Debug, Default)]
pub struct AppStatus {
    /// Mode; `None` before the first cycle.
    pub mode: Mutex<Option<Mode>>,
    /// Cycles run.
    pub cycles: AtomicU64,
    /// Valid packets.
    pub packets_ok: AtomicU64,
    /// Packets rejected by the CRC.
    pub crc_errors: AtomicU64,
    /// Cycles without a valid packet.
    pub packets_missing: AtomicU64,
    /// Revives seen: changes from KILLED or FAILSAFE to MANUAL.
    pub revives: AtomicU64,
    /// What the cycles showed of the mission (`--scenario mission`).
    pub mission: Mutex<crate::mission::MissionTrack>,
}

impl AppStatus {
    /// The mode's name.
    pub fn mode_name(&self) -> &'static str {
        lock(&self.mode).map_or("starting", Mode::name)
    }
}

/// What the application gets to run against.
#[derive(Debug)]
pub struct AppLaunch {
    /// The configuration to run with: ports are the simulation's pty links (see
    /// [`crate::app_config`]).
    pub config: Config,
    /// The request line (clone it for every open of the sensor board).
    pub request: RequestPin,
    /// Extra work inside the realtime cycle (the `loop:busy` fault), from the loop's start.
    pub busy: Option<LoopBusy>,
    /// The log disk and Maestro-write faults, windows from the start.
    pub app_faults: AppFaults,
    /// Where the application reports its live state (optional: the status line shows what
    /// it gets).
    pub status: Arc<AppStatus>,
    /// Set to stop the application (the runner sets it at the end of the scenario; signal
    /// handlers may set it earlier).
    pub stop: Arc<AtomicBool>,
}

/// What the application reports after its run.
#[derive(Debug, Clone, Default)]
pub struct AppOutcome {
    /// The MCAP log, if one was written.
    pub log_path: Option<PathBuf>,
    /// The application's own one-line summary.
    pub summary: String,
    /// The loop's counters at the end.
    pub counters: Counters,
    /// Command frames the telemetry thread decoded.
    pub ground_frames: u64,
    /// Command frames it rejected (CRC, range, unknown type).
    pub ground_rejected: u64,
    /// The safe targets were written at the end.
    pub outputs_safe: bool,
}

/// How the status is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StatusMode {
    /// A live line on a terminal, plain lines otherwise.
    #[default]
    Auto,
    /// Plain lines, one per second.
    Plain,
    /// Nothing until the summary.
    Quiet,
}

/// Everything a run needs.
#[derive(Debug, Clone)]
pub struct SimOptions {
    /// The scenario.
    pub scenario: Scenario,
    /// Stop after this long instead of the scenario's length, s.
    pub duration_s: Option<f64>,
    /// Seed of every random choice (noise, faults).
    pub seed: u64,
    /// Faults per link.
    pub faults: Faults,
    /// Give the ground link to a GUI on a second pty instead of the scripted station.
    pub ground_pty: bool,
    /// Directory for the pty links (created; removed at the end).
    pub run_dir: PathBuf,
    /// Directory for the MCAP log.
    pub log_dir: PathBuf,
    /// Loop rate, Hz.
    pub loop_rate_hz: u32,
    /// Sensor board settings.
    pub board: BoardConfig,
    /// Vehicle parameters.
    pub vehicle: VehicleParams,
    /// Status display.
    pub status: StatusMode,
    /// The application's configuration file.
    pub app_config: Option<PathBuf>,
    /// Keep the configuration's realtime settings.
    pub realtime: bool,
    /// The ground-link key file (mode 0600). `None`: the configuration's `[xbee] key_file`,
    /// else a fresh key in `<run_dir>/link.key` (unless `require_auth` ends up false, when the
    /// robot runs with the v1 link only).
    pub key_file: Option<PathBuf>,
    /// Overrides `[xbee] require_auth` (`None`: the configuration's, true by default). A v1
    /// ground station (a v1 GUI on the ground pty, raw v1 frames) needs `Some(false)`.
    pub require_auth: Option<bool>,
    /// The random fault windows of a soak (already in `faults`), to report.
    pub random_faults: Vec<FaultWindow>,
    /// Keep counts only, not every packet's fingerprint or the model's track: memory stays
    /// flat however long the run (a soak); the check of logged packets against the board's
    /// intact ones is skipped.
    pub bounded_evidence: bool,
    /// Where the simulated robot serves its live view (`[foxglove] listen`); `None`: the
    /// configuration's.
    pub foxglove: Option<String>,
    /// The sensor board's firmware (its `qemu` build, an ELF) to run under `qemu-system-arm`
    /// in place of the simulated board ([`crate::firmware`]); `None`: the Rust board.
    pub firmware: Option<PathBuf>,
    /// The mission (`--mission FILE.plan`): the robot's `[navigation] mission_file`, and its
    /// waypoints in the model's frame (metres north and east of the start).
    pub mission: Option<(PathBuf, Vec<(f64, f64)>)>,
}

impl SimOptions {
    /// Defaults for `scenario`: seed 1, no faults, links under the temp directory, log in
    /// `./dima-logs`.
    pub fn new(scenario: Scenario) -> SimOptions {
        SimOptions {
            scenario,
            duration_s: None,
            seed: 1,
            faults: Faults::default(),
            ground_pty: false,
            run_dir: std::env::temp_dir().join(format!("dima-sim-{}", std::process::id())),
            log_dir: PathBuf::from("dima-logs"),
            loop_rate_hz: 250,
            board: BoardConfig::default(),
            vehicle: VehicleParams::default(),
            status: StatusMode::Auto,
            app_config: None,
            realtime: false,
            key_file: None,
            require_auth: None,
            random_faults: Vec::new(),
            bounded_evidence: false,
            foxglove: None,
            firmware: None,
            mission: None,
        }
    }

    /// How long the run lasts, s (None: until stopped, with a GUI).
    pub fn run_length_s(&self) -> Option<f64> {
        if self.ground_pty {
            self.duration_s
        } else {
            Some(self.duration_s.unwrap_or(self.scenario.duration_s))
        }
    }
}

/// The ground-link key of a run, written into `config`: `--key-file`, else the
/// configuration's `[xbee] key_file`, else (unless `require_auth` is false) a fresh key in
/// `<run_dir>/link.key`. `None`: the robot runs with the v1 link only.
fn link_key(o: &SimOptions, config: &mut Config) -> anyhow::Result<Option<LinkKey>> {
    if let Some(require) = o.require_auth {
        config.xbee.require_auth = require;
    }
    if let Some(path) = &o.key_file {
        config.xbee.key_file = Some(path.clone());
    }
    let key = match &config.xbee.key_file {
        Some(path) => key_file::load(path)?,
        None if !config.xbee.require_auth => return Ok(None),
        None => {
            let path = o.run_dir.join("link.key");
            // A key left by an earlier run in this directory is this simulation's own.
            let _ = std::fs::remove_file(&path);
            let key = key_file::create(&path)?;
            config.xbee.key_file = Some(path);
            key
        }
    };
    Ok(Some(key))
}

/// A copy of what the simulated devices counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DeviceCounts {
    /// Request edges seen by the board.
    pub requests: u64,
    /// Answers sent.
    pub answers: u64,
    /// Packets sent unchanged.
    pub packets_intact: u64,
    /// Packets sent damaged.
    pub packets_damaged: u64,
    /// Requests not answered (silent, unplugged, busy).
    pub unanswered: u64,
    /// Info frames sent.
    pub info_frames: u64,
    /// Answers complete later than the default packet deadline after their request.
    pub late_answers: u64,
    /// Sensor pty opens.
    pub sensor_opens: u64,
    /// Maestro commands decoded.
    pub maestro_commands: u64,
    /// Maestro pty opens.
    pub maestro_opens: u64,
    /// Maestro commands since its last reopen.
    pub maestro_commands_since_open: u64,
    /// Ground frames sent.
    pub ground_frames: u64,
    /// Outputs at the Maestro at the end, µs (None: never set).
    pub final_outputs_us: Option<[u16; 3]>,
    /// Display frames received intact.
    pub displays: u64,
    /// Display frames rejected.
    pub display_errors: u64,
}

/// The result of a run.
#[derive(Debug, Clone)]
pub struct SimReport {
    /// The safe outputs of the configuration that ran, µs.
    pub safe_us: [u16; 3],
    /// Every check held (skipped ones aside).
    pub passed: bool,
    /// Check results: description and failure reason.
    pub checks: Vec<(String, Option<Result<(), String>>)>,
    /// The application's outcome.
    pub app: AppOutcome,
    /// Device-side counts.
    pub devices: DeviceCounts,
    /// Logged raw packets that the board did not send intact (must be 0).
    pub false_accepts: u64,
    /// Logged raw packets that the board sent intact.
    pub logged_intact: u64,
    /// The log, read back.
    pub log: Option<LogSummary>,
    /// Evidence the checks used.
    pub evidence: Evidence,
    /// Run length, s.
    pub ran_s: f64,
    /// Stopped early by a signal.
    pub interrupted: bool,
    /// Revives the application reported (KILLED or FAILSAFE to MANUAL).
    pub revives: u64,
    /// The run kept counts only ([`SimOptions::bounded_evidence`]: a soak).
    pub evidence_bounded: bool,
    /// The random fault windows of a soak.
    pub random_faults: usize,
    /// With `--firmware`: what the emulated firmware was fed and sent, one line.
    pub firmware: Option<String>,
    /// When the loop's own `Overrun` protection tripped or refused revives: that the host
    /// was too busy, what the log saw and the ways out ([`host_overload_hint`]).
    pub host_hint: Option<String>,
    /// The ground link was left to an external station (`--ground-pty`): the scripted one
    /// did not run.
    pub ground_external: bool,
    /// With `--mission`: waypoints, cross-track error and lap time.
    pub mission: Option<String>,
}

/// The summary's ground-link part: the scripted station's counts, or, when an external
/// station drove the link (`--ground-pty`), the command frames the robot decoded from it.
fn ground_summary(devices: &DeviceCounts, external_commands: Option<u64>) -> String {
    match external_commands {
        Some(n) => {
            format!("ground: external station on a pty, {n} command frames decoded by the robot")
        }
        None => format!(
            "ground: {} frames sent, {} display frames back",
            devices.ground_frames, devices.displays
        ),
    }
}

impl SimReport {
    /// A short human summary (several lines).
    pub fn summary(&self) -> String {
        let d = &self.devices;
        let c = &self.app.counters;
        let mut s =
            format!(
            "ran {:.1} s{}: {} cycles, {} packets ok, {} CRC errors, {} missing, {} failsafe(s)\n\
             board: {} requests, {} answers ({} damaged by faults, {} late), {} info frames; \
             maestro: {} commands, {} opens; {}\n",
            self.ran_s,
            if self.interrupted { " (interrupted)" } else { "" },
            c.cycles,
            c.packets_ok,
            c.packet_crc_errors,
            c.packets_missing,
            c.failsafes,
            d.requests,
            d.answers,
            d.packets_damaged,
            d.late_answers,
            d.info_frames,
            d.maestro_commands,
            d.maestro_opens,
            ground_summary(d, self.ground_external.then_some(self.app.ground_frames)),
        );
        if let Some(line) = &self.firmware {
            s.push_str(line);
            s.push('\n');
        }
        if let Some(lines) = &self.mission {
            s.push_str(lines);
            s.push('\n');
        }
        if self.evidence_bounded {
            s.push_str(&format!(
                "soak: {} fault windows, {} failsafe(s), {} revive(s), {} cycles, {} missed periods, {} log records dropped\n",
                self.random_faults, c.failsafes, self.revives, c.cycles, c.missed_periods, c.log_dropped
            ));
        }
        if let Some(o) = d.final_outputs_us {
            s.push_str(&format!(
                "final outputs at the Maestro: {}/{}/{} µs{}\n",
                o[0],
                o[1],
                o[2],
                if o == self.safe_us { " (safe)" } else { "" }
            ));
        }
        for (name, result) in &self.checks {
            let mark = match result {
                None => "skip".to_owned(),
                Some(Ok(())) => "ok  ".to_owned(),
                Some(Err(e)) => format!("FAIL {e}\n       "),
            };
            s.push_str(&format!("  {mark} {name}\n"));
        }
        s
    }

    /// The first failure, if any.
    pub fn failure(&self) -> Option<String> {
        if self.false_accepts > 0 {
            return Some(format!(
                "{} logged packets were not sent intact by the board",
                self.false_accepts
            ));
        }
        self.checks.iter().find_map(|(name, r)| match r {
            Some(Err(e)) => Some(format!("{name}: {e}")),
            _ => None,
        })
    }
}

fn describe(check: &crate::scenario::Check) -> String {
    use crate::scenario::Check::*;
    match check {
        OutputsReach {
            from_s, targets_us, ..
        } => format!("outputs {targets_us:?} µs after {from_s} s"),
        SafeThroughout { from_s, to_s } => format!("safe outputs {from_s}-{to_s} s"),
        SafeHeld { from_s, to_s } => format!("safe outputs held {from_s}-{to_s} s"),
        NeverSafe { from_s, to_s } => format!("no failsafe {from_s}-{to_s} s"),
        Drives { from_s, to_s } => format!("drives {from_s}-{to_s} s"),
        Tracks {
            speed_m_s,
            heading_deg,
            from_s,
            to_s,
            ..
        } => format!("AUTO holds {speed_m_s} m/s and {heading_deg}° {from_s}-{to_s} s"),
        CommsFailsafe { after_s, .. } => format!("comms-loss FAILSAFE in time after {after_s} s"),
        ModesInOrder(m) => format!(
            "modes {}",
            m.iter().map(|m| m.name()).collect::<Vec<_>>().join(" -> ")
        ),
        FailsafeFor {
            cause,
            from_s,
            to_s,
        } => format!("FAILSAFE ({cause:?}) {from_s}-{to_s} s"),
        Failsafes(n) => format!("{n} failsafe(s) in the log"),
    }
}

/// The random stream of the sensor board (the Rust board's or the firmware's feeder).
const BOARD_STREAM: u64 = 10;

/// Runs the scenario with the application started by `app` on the calling thread.
pub fn run_simulation<F>(options: &SimOptions, app: F) -> anyhow::Result<SimReport>
where
    F: FnOnce(AppLaunch) -> anyhow::Result<AppOutcome>,
{
    // The firmware boots first: the simulation's clock starts once it is ready.
    let firmware = match &options.firmware {
        Some(elf) => Some(
            boot_firmware(
                &crate::firmware::qemu_elf(elf),
                options.board,
                &SimRng::new(options.seed).fork(BOARD_STREAM),
                &World::new(options.vehicle, options.scenario.start_heading_deg),
            )
            .context("the sensor board's firmware under QEMU")?,
        ),
        None => None,
    };
    let (mut run, config, key) = SimRun::prepare(options)?;
    if let Some(booted) = &firmware {
        run.firmware_stats = booted.stats.clone();
    }
    let devices = run.start_devices(&config, key, firmware)?;
    let monitor = run.start_monitor()?;
    let outcome = app(run.launch(config));
    let ran_s = run.world.now_s();
    run.stop(monitor, devices);
    run.judge(outcome?, ran_s)
}

/// What the steps of one run share: the model, the device statistics and the stop flags.
struct SimRun<'a> {
    o: &'a SimOptions,
    world: Arc<World>,
    line: Arc<RequestLine>,
    /// Wall-clock time at the start, ns since the Unix epoch.
    start_wall_ns: u64,
    stop_devices: Arc<AtomicBool>,
    stop_app: Arc<AtomicBool>,
    /// Set when the monitor ended the run at its length (not a signal).
    ended_by_runner: Arc<AtomicBool>,
    board_stats: Arc<BoardStats>,
    /// What the firmware board was fed and sent (with `--firmware`).
    firmware_stats: Arc<FirmwareStats>,
    maestro_stats: Arc<MaestroStats>,
    ground_stats: Arc<GroundStats>,
    app_status: Arc<AppStatus>,
    /// The throttle, steering and tail channel numbers.
    channels: [u8; 3],
    /// The safe outputs, µs.
    safe_us: [u16; 3],
}

impl<'a> SimRun<'a> {
    /// Creates the run directory, the application's configuration (with the simulation's pty
    /// links and the ground-link key) and the shared state.
    fn prepare(o: &'a SimOptions) -> anyhow::Result<(SimRun<'a>, Config, Option<LinkKey>)> {
        std::fs::create_dir_all(&o.run_dir)
            .with_context(|| format!("creating {}", o.run_dir.display()))?;
        let world = Arc::new(World::new(o.vehicle, o.scenario.start_heading_deg));
        let start_wall_ns = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_nanos() as u64)
            .unwrap_or(0);
        let mut config = app_config(
            o.app_config.as_deref(),
            SimPorts {
                sensor: &o.run_dir.join("sensor"),
                maestro: &o.run_dir.join("maestro"),
                xbee: &o.run_dir.join("xbee"),
            },
            o.loop_rate_hz,
            o.realtime,
            &o.log_dir,
        )?;
        crate::app_config::set_live_view(&mut config, o.foxglove.as_deref())?;
        if let Some((plan, _)) = &o.mission {
            config.navigation.mission_file = plan.clone();
        }
        let key = link_key(o, &mut config)?;
        let outputs = OutputMap::new(&config.channels);
        let run = SimRun {
            o,
            world,
            line: RequestLine::new(),
            start_wall_ns,
            stop_devices: Arc::new(AtomicBool::new(false)),
            stop_app: Arc::new(AtomicBool::new(false)),
            ended_by_runner: Arc::new(AtomicBool::new(false)),
            board_stats: Arc::new(BoardStats {
                counts_only: o.bounded_evidence,
                ..BoardStats::default()
            }),
            firmware_stats: Arc::new(FirmwareStats::default()),
            maestro_stats: Arc::new(MaestroStats {
                safe_transitions_only: o.bounded_evidence.then(|| outputs.safe().pulse_us),
                ..MaestroStats::default()
            }),
            ground_stats: Arc::new(GroundStats {
                counts_only: o.bounded_evidence,
                ..GroundStats::default()
            }),
            app_status: Arc::new(AppStatus::default()),
            channels: outputs.channel_numbers(),
            safe_us: outputs.safe().pulse_us,
        };
        Ok((run, config, key))
    }

    /// Starts the simulated sensor board, the Maestro and the ground side of the radio link
    /// (the scripted station, or a relay to a GUI's pty).
    fn start_devices(
        &self,
        config: &Config,
        key: Option<LinkKey>,
        firmware: Option<BootedFirmware>,
    ) -> anyhow::Result<Vec<JoinHandle<()>>> {
        let o = self.o;
        let rng = SimRng::new(o.seed);
        let setup = BoardSetup {
            config: o.board,
            link_faults: o.faults.sensor.clone(),
            sensor_faults: o.faults.sensors.clone(),
            pace: LinePace::new(config.sensor.baud, bits_per_byte(config.sensor.stop_bits)),
        };
        let port = LinkPort::open(&o.run_dir.join("sensor")).context("sensor-board pty")?;
        let mut threads = match firmware {
            Some(booted) => spawn_firmware_board(
                booted,
                self.world.clone(),
                self.line.clone(),
                port,
                setup,
                rng.fork(BOARD_STREAM),
                self.board_stats.clone(),
                Duration::from_secs_f64(1.0 / f64::from(o.loop_rate_hz.max(1))),
                self.stop_devices.clone(),
            )?,
            None => vec![spawn_board(
                self.world.clone(),
                self.line.clone(),
                port,
                setup,
                rng.fork(BOARD_STREAM),
                self.board_stats.clone(),
                self.stop_devices.clone(),
            )?],
        };
        let maestro = spawn_maestro(
            self.world.clone(),
            LinkPort::open(&o.run_dir.join("maestro")).context("Maestro pty")?,
            self.channels,
            o.faults.maestro.clone(),
            rng.fork(11),
            self.maestro_stats.clone(),
            self.stop_devices.clone(),
        )?;
        let ground = self.start_ground(config, key, &rng)?;
        threads.extend([maestro, ground]);
        Ok(threads)
    }

    /// Starts the ground side of the radio link: a relay to a second pty for a GUI, or the
    /// scripted station (v2 with `key`, else v1).
    fn start_ground(
        &self,
        config: &Config,
        key: Option<LinkKey>,
        rng: &SimRng,
    ) -> anyhow::Result<JoinHandle<()>> {
        let o = self.o;
        let xbee = LinkPort::open(&o.run_dir.join("xbee")).context("XBee pty")?;
        let radio_pace = LinePace::new(config.xbee.baud, bits_per_byte(1));
        if o.ground_pty {
            let station = SimPty::open(&o.run_dir.join("ground-station")).context("ground pty")?;
            eprintln!(
                "ground station: connect the GUI to {} (9600 8N1); the robot starts KILLED",
                station.device_path().display()
            );
            return Ok(spawn_relay(
                self.world.clone(),
                xbee,
                station,
                o.faults.ground.clone(),
                radio_pace,
                rng.fork(12),
                self.stop_devices.clone(),
            )?);
        }
        let protocol = match key {
            Some(key) => GroundProtocol::V2 { key },
            None => GroundProtocol::V1 {
                heartbeat: o.scenario.heartbeat,
            },
        };
        Ok(spawn_ground(
            self.world.clone(),
            xbee,
            o.scenario.script.clone(),
            protocol,
            o.faults.ground.clone(),
            radio_pace,
            rng.fork(13),
            self.ground_stats.clone(),
            self.stop_devices.clone(),
        )?)
    }

    /// Starts the monitor: the status line, and the end of the run at its length.
    fn start_monitor(&self) -> std::io::Result<JoinHandle<()>> {
        let monitor = StatusMonitor {
            world: self.world.clone(),
            stop_app: self.stop_app.clone(),
            ended: self.ended_by_runner.clone(),
            board: self.board_stats.clone(),
            maestro: self.maestro_stats.clone(),
            ground: self.ground_stats.clone(),
            scenario: self.o.scenario.clone(),
            app: self.app_status.clone(),
            run_length: self.o.run_length_s(),
            channels: self.channels,
            tty: match self.o.status {
                StatusMode::Auto => Some(std::io::stderr().is_terminal()),
                StatusMode::Plain => Some(false),
                StatusMode::Quiet => None,
            },
        };
        std::thread::Builder::new()
            .name("sim-status".into())
            .spawn(move || monitor.run())
    }

    /// What the application runs against: `config`, the request line, its faults, the
    /// status it reports to and its stop flag.
    fn launch(&self, config: Config) -> AppLaunch {
        AppLaunch {
            config,
            request: RequestPin::new(self.line.clone()),
            busy: self.o.faults.loop_busy,
            app_faults: self.o.faults.app.clone(),
            status: self.app_status.clone(),
            stop: self.stop_app.clone(),
        }
    }

    /// Stops the monitor, then (once the Maestro saw the final safe write) the devices, and
    /// removes the run directory.
    fn stop(&self, monitor: JoinHandle<()>, devices: Vec<JoinHandle<()>>) {
        self.stop_app.store(true, Ordering::Relaxed);
        let _ = monitor.join();
        // Let the Maestro thread see the final safe write before the devices stop.
        std::thread::sleep(Duration::from_millis(50));
        self.stop_devices.store(true, Ordering::Relaxed);
        for t in devices {
            let _ = t.join();
        }
        let _ = std::fs::remove_dir_all(&self.o.run_dir);
    }

    /// Reads the log back, evaluates the scenario's checks against the evidence and reports.
    fn judge(&self, app: AppOutcome, ran_s: f64) -> anyhow::Result<SimReport> {
        let o = self.o;
        let mission = lock(&self.app_status.mission).clone();
        let interrupted = !self.ended_by_runner.load(Ordering::Relaxed)
            && o.run_length_s().is_some()
            && !mission.ended();
        let log = match &app.log_path {
            Some(p) => Some(LogSummary::read_run(p)?),
            None => None,
        };
        let (false_accepts, logged_intact) = self.match_logged_packets(log.as_ref());
        let evidence = Evidence {
            outputs: self.maestro_stats.history(),
            truth: lock(&self.ground_stats.truth).clone(),
            log: log.clone(),
            start_wall_ns: self.start_wall_ns,
            safe_us: self.safe_us,
            ran_s,
            // Cut short by a signal or by a --duration below the scenario's length: checks
            // past the end are skipped.
            complete: !interrupted && ran_s + 0.5 >= o.scenario.duration_s,
            period_s: 1.0 / f64::from(o.loop_rate_hz.max(1)),
        };
        let mut checks: Vec<(String, Option<Result<(), String>>)> = if o.ground_pty {
            Vec::new()
        } else {
            o.scenario
                .checks
                .iter()
                .map(|c| (describe(c), evaluate(c, &evidence)))
                .collect()
        };
        if let (Some(_), Some(path)) = (&o.firmware, &app.log_path) {
            checks.push((
                "firmware: every logged packet is one the emulated firmware sent".to_owned(),
                (!o.bounded_evidence).then(|| {
                    if logged_intact > 0 && false_accepts == 0 {
                        Ok(())
                    } else {
                        Err(format!(
                            "{logged_intact} logged packets sent by it, {false_accepts} not"
                        ))
                    }
                }),
            ));
            let s = &o.faults.sensor;
            checks.extend(firmware_checks(
                path,
                &self.firmware_stats,
                self.start_wall_ns,
                app.counters.packet_crc_errors,
                s.ber > 0.0 || s.drop_rate > 0.0 || s.insert_rate > 0.0,
                o.bounded_evidence,
            ));
        }
        let mission_summary = o.mission.as_ref().map(|(_, waypoints)| {
            checks.push((
                "mission: the last waypoint is reached".to_owned(),
                Some(mission.verdict(waypoints.len(), ran_s)),
            ));
            let mut s = mission.summary(waypoints.len());
            if let Some((rms, max)) = crate::mission::true_straights(&evidence.truth, waypoints) {
                s += &format!(
                    "\nmission: the model's true distance from the legs on the straights: RMS \
                     {rms:.3} m, max {max:.3} m"
                );
            }
            s
        });
        let passed = false_accepts == 0 && checks.iter().all(|(_, r)| !matches!(r, Some(Err(_))));
        let host_hint = log
            .as_ref()
            .map(|l| {
                HostLoad::from_log(l, o.loop_rate_hz, o.realtime, o.faults.loop_busy.is_some())
            })
            .and_then(|load| host_overload_hint(&load));
        Ok(SimReport {
            safe_us: self.safe_us,
            passed,
            checks,
            app,
            devices: self.device_counts(),
            false_accepts,
            logged_intact,
            log,
            evidence,
            ran_s,
            interrupted,
            revives: self.app_status.revives.load(Ordering::Relaxed),
            evidence_bounded: o.bounded_evidence,
            random_faults: o.random_faults.len(),
            firmware: o
                .firmware
                .as_ref()
                .map(|_| self.firmware_stats.summary(logged_intact)),
            host_hint,
            ground_external: o.ground_pty,
            mission: mission_summary,
        })
    }

    /// The logged raw packets the board did not send intact (false accepts) and those it did;
    /// (0, 0) with bounded evidence (the board kept no fingerprints).
    fn match_logged_packets(&self, log: Option<&LogSummary>) -> (u64, u64) {
        let (mut false_accepts, mut logged_intact) = (0, 0);
        if let Some(l) = log.filter(|_| !self.o.bounded_evidence) {
            let intact = lock(&self.board_stats.intact);
            for fp in &l.raw_packets {
                if intact.contains(fp) {
                    logged_intact += 1;
                } else {
                    false_accepts += 1;
                }
            }
        }
        (false_accepts, logged_intact)
    }

    /// A copy of what the simulated devices counted.
    fn device_counts(&self) -> DeviceCounts {
        let load = |a: &AtomicU64| a.load(Ordering::Relaxed);
        let (board, maestro, ground) = (&self.board_stats, &self.maestro_stats, &self.ground_stats);
        DeviceCounts {
            requests: load(&board.requests),
            answers: load(&board.answers),
            packets_intact: load(&board.packets_intact),
            packets_damaged: load(&board.packets_damaged),
            unanswered: load(&board.unanswered),
            info_frames: load(&board.info_frames),
            late_answers: load(&board.late_answers),
            sensor_opens: load(&board.opens),
            maestro_commands: load(&maestro.commands),
            maestro_opens: load(&maestro.opens),
            maestro_commands_since_open: load(&maestro.commands_since_open),
            ground_frames: load(&ground.frames_sent),
            final_outputs_us: Some(maestro.targets_of(self.channels))
                .filter(|t| !t.contains(&0xFFFF))
                .map(|t| t.map(|q| q / 4)),
            displays: load(&ground.displays),
            display_errors: load(&ground.display_errors),
        }
    }
}

/// The status thread: prints the status line and ends the run at its length.
struct StatusMonitor {
    world: Arc<World>,
    stop_app: Arc<AtomicBool>,
    /// Set when this thread ended the run.
    ended: Arc<AtomicBool>,
    board: Arc<BoardStats>,
    maestro: Arc<MaestroStats>,
    ground: Arc<GroundStats>,
    scenario: Scenario,
    app: Arc<AppStatus>,
    /// How long the run lasts, s (None: until stopped).
    run_length: Option<f64>,
    channels: [u8; 3],
    /// Some(true): a live line on a terminal; Some(false): plain lines; None: quiet.
    tty: Option<bool>,
}

impl StatusMonitor {
    /// Watches the run every 100 ms until the application stops, or stops it at its length.
    fn run(self) {
        let mut last_print = -1.0f64;
        let mut last_cycles = 0u64;
        let mut last_t = 0.0f64;
        let mut rate = 0.0f64;
        while !self.stop_app.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(100));
            let t = self.world.now_s();
            if self.run_length.is_some_and(|d| t >= d) {
                self.ended.store(true, Ordering::Relaxed);
                self.stop_app.store(true, Ordering::Relaxed);
                break;
            }
            let Some(tty) = self.tty else { continue };
            let interval = if tty { 0.25 } else { 1.0 };
            if t - last_print < interval {
                continue;
            }
            let cycles = self.app.cycles.load(Ordering::Relaxed);
            if t > last_t {
                rate = cycles.saturating_sub(last_cycles) as f64 / (t - last_t);
            }
            last_cycles = cycles;
            last_t = t;
            last_print = t;
            self.print(t, rate, tty);
        }
        if self.tty == Some(true) {
            dima_robot::terminal::finish_status();
        }
    }

    /// Prints the status at `t` with the loop's `rate_hz`: one line redrawn in place on a
    /// terminal, fitted to its width, a new line otherwise.
    fn print(&self, t: f64, rate_hz: f64, tty: bool) {
        let columns = if tty { terminal_columns() } else { usize::MAX };
        let fields = status_fields(
            StatusInputs {
                t,
                run_length: self.run_length,
                phase: self.scenario.phase_at(t),
                rate_hz,
                channels: self.channels,
                progress_bar: tty,
            },
            &self.app,
            &self.board,
            &self.maestro,
            &self.ground,
            &self.world,
        );
        if tty {
            // One line that never wraps, or the redraw would leave the rest behind.
            dima_robot::terminal::draw_status(&fit_status_line(&fields, columns - 1));
        } else {
            let mut err = std::io::stderr().lock();
            let _ = writeln!(err, "{}", fit_status_line(&fields, usize::MAX));
            let _ = err.flush();
        }
    }
}

/// Width of the terminal on stderr (80 when unknown).
fn terminal_columns() -> usize {
    let mut size = nix::libc::winsize {
        ws_row: 0,
        ws_col: 0,
        ws_xpixel: 0,
        ws_ypixel: 0,
    };
    // SAFETY: TIOCGWINSZ writes one `winsize` through the valid pointer.
    let rc = unsafe { nix::libc::ioctl(2, nix::libc::TIOCGWINSZ, &mut size) };
    if rc == 0 && size.ws_col >= 20 {
        usize::from(size.ws_col)
    } else {
        80
    }
}

/// What the status line shows besides the devices' and the application's state.
struct StatusInputs<'a> {
    t: f64,
    run_length: Option<f64>,
    phase: &'a str,
    rate_hz: f64,
    channels: [u8; 3],
    /// Show the run's progress as a bar (on a terminal, where it fits).
    progress_bar: bool,
}

/// One part of the status line.
#[derive(Debug, Clone, PartialEq)]
struct StatusField {
    /// What goes before it when a field precedes it (`" "` or `" | "`).
    separator: &'static str,
    /// Lower numbers are dropped last when the line does not fit.
    priority: u8,
    /// The text.
    text: String,
}

/// The status line's fields, in display order, each with its priority: time and mode first,
/// then where the car is going, the scenario's phase, the loop's rate (it falls when the host
/// is too busy), the outputs, the link, the packet counts (in the summary at the end anyway)
/// and last the progress bar.
fn status_fields(
    inputs: StatusInputs<'_>,
    app: &AppStatus,
    board: &BoardStats,
    maestro: &MaestroStats,
    ground: &GroundStats,
    world: &World,
) -> Vec<StatusField> {
    let StatusInputs {
        t,
        run_length,
        phase,
        rate_hz,
        channels,
        progress_bar,
    } = inputs;
    let bar = run_length.filter(|_| progress_bar).map(|d| {
        let width = 10usize;
        let filled = ((t / d).clamp(0.0, 1.0) * width as f64) as usize;
        format!("[{}{}]", "#".repeat(filled), ".".repeat(width - filled))
    });
    let time = match run_length {
        Some(d) => format!("{t:4.1}/{d:.0}s"),
        None => format!("{t:5.1}s"),
    };
    let out = maestro.targets_of(channels);
    let outputs = if out.contains(&0xFFFF) {
        "-".to_owned()
    } else {
        format!("{}/{}/{}", out[0] / 4, out[1] / 4, out[2] / 4)
    };
    // The ground station's view of the radio link: how long since it last sent a frame (the
    // robot's failsafe watches this direction) and since it last received a display frame.
    let now = world.now_s();
    let uplink_age = age_text(now, *lock(&ground.last_sent_s));
    let downlink_age = age_text(now, lock(&ground.last_display).map(|(at, _)| at));
    let s = world.state();
    let damaged = board.packets_damaged.load(Ordering::Relaxed);
    let field = |separator, priority, text: String| StatusField {
        separator,
        priority,
        text,
    };
    let mut fields: Vec<StatusField> = bar.map(|b| field(" ", 7, b)).into_iter().collect();
    fields.extend([
        field(" ", 0, time),
        field(" ", 0, format!("{:<8}", app.mode_name())),
        field(" ", 3, format!("{rate_hz:3.0} Hz")),
        field(
            " | ",
            6,
            format!(
                "pkt {} ok {} bad{}",
                app.packets_ok.load(Ordering::Relaxed),
                app.packets_missing.load(Ordering::Relaxed),
                if damaged > 0 {
                    format!(" ({damaged} hit)")
                } else {
                    String::new()
                }
            ),
        ),
        field(" | ", 4, format!("out {outputs}")),
        field(
            " | ",
            5,
            format!("link up {uplink_age} down {downlink_age}"),
        ),
        field(
            " | ",
            1,
            format!(
                "car {:.1} m/s {}°",
                s.speed_m_s,
                heading_text(s.heading_deg)
            ),
        ),
    ]);
    if !phase.is_empty() {
        fields.push(field(" | ", 2, phase.to_owned()));
    }
    fields
}

/// The fields that fit in `columns`, in their order: the lowest-priority ones (highest
/// number) are left out first, the last of them first; a line still too long with only the
/// first priority is cut.
fn fit_status_line(fields: &[StatusField], columns: usize) -> String {
    let join = |keep: &dyn Fn(&StatusField) -> bool| {
        let mut line = String::new();
        for f in fields.iter().filter(|f| keep(f)) {
            if !line.is_empty() {
                // A padded field (the mode) loses its padding before a ` | `.
                if f.separator == " | " {
                    line.truncate(line.trim_end().len());
                }
                line.push_str(f.separator);
            }
            line.push_str(&f.text);
        }
        line
    };
    let mut dropped: Vec<usize> = Vec::new();
    let mut order: Vec<usize> = (0..fields.len()).collect();
    // Drop order: highest priority number first; among equals, the later field first.
    order.sort_by_key(|&i| (std::cmp::Reverse(fields[i].priority), std::cmp::Reverse(i)));
    let mut line = join(&|_| true);
    for i in order {
        if line.chars().count() <= columns || fields[i].priority == 0 {
            break;
        }
        dropped.push(i);
        line = join(&|f: &StatusField| !dropped.iter().any(|&d| std::ptr::eq(f, &fields[d])));
    }
    line.trim_end().chars().take(columns).collect()
}

/// A heading in whole degrees, 000..=359: 359.6° reads 000, never 360.
fn heading_text(heading_deg: f64) -> String {
    let whole = heading_deg.rem_euclid(360.0).round() as u32 % 360;
    format!("{whole:03}")
}

/// The age of an event at `at_s` seen at `now_s`: "-" before it happened, milliseconds below one
/// second, seconds above.
fn age_text(now_s: f64, at_s: Option<f64>) -> String {
    match at_s {
        None => "-".to_owned(),
        Some(at) => {
            let age = (now_s - at).max(0.0);
            if age < 1.0 {
                format!("{:.0} ms", age * 1e3)
            } else {
                format!("{age:.1} s")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The status line of a run 12.3 s into 20 s, in AUTO, with a heading of 359.7°.
    fn fields(progress_bar: bool) -> Vec<StatusField> {
        let app = AppStatus::default();
        *lock(&app.mode) = Some(Mode::Auto);
        app.packets_ok.store(3_668, Ordering::Relaxed);
        app.packets_missing.store(144, Ordering::Relaxed);
        let world = World::new(VehicleParams::default(), 359.7);
        status_fields(
            StatusInputs {
                t: 12.3,
                run_length: Some(20.0),
                phase: "AUTO 2.5 m/s, 120°",
                rate_hz: 250.0,
                channels: [0, 1, 2],
                progress_bar,
            },
            &app,
            &BoardStats::default(),
            &MaestroStats::default(),
            &GroundStats::default(),
            &world,
        )
    }

    #[test]
    fn the_status_line_fits_the_terminal_dropping_the_least_useful_fields_first() {
        let full = fit_status_line(&fields(false), usize::MAX);
        assert_eq!(
            full,
            "12.3/20s AUTO     250 Hz | pkt 3668 ok 144 bad | out - | link up - down - | \
             car 0.0 m/s 000° | AUTO 2.5 m/s, 120°"
        );
        // 80 columns (79 usable): the car and the phase stay, the counts go first.
        let at_80 = fit_status_line(&fields(false), 79);
        assert_eq!(
            at_80,
            "12.3/20s AUTO     250 Hz | out - | car 0.0 m/s 000° | AUTO 2.5 m/s, 120°"
        );
        assert!(at_80.chars().count() <= 79, "{at_80}");
        for kept in [
            "12.3/20s",
            "AUTO ",
            "car 0.0 m/s 000°",
            "AUTO 2.5 m/s, 120°",
        ] {
            assert!(at_80.contains(kept), "{kept:?} in {at_80:?}");
        }
        assert!(!at_80.contains("pkt"), "{at_80}");
        // 60 columns: time, mode, car and phase.
        let at_60 = fit_status_line(&fields(false), 59);
        assert_eq!(
            at_60,
            "12.3/20s AUTO | car 0.0 m/s 000° | AUTO 2.5 m/s, 120°"
        );
        // 120 columns: every field; the progress bar only where it fits as well.
        assert_eq!(fit_status_line(&fields(true), 119), full);
        assert_eq!(
            fit_status_line(&fields(true), 140),
            format!("[######....] {full}")
        );
        // Narrower than time and mode: cut, never wrapped.
        assert_eq!(fit_status_line(&fields(false), 10), "12.3/20s A");
    }

    #[test]
    fn with_an_external_station_the_summary_does_not_count_the_scripted_one() {
        let devices = DeviceCounts {
            ground_frames: 197,
            displays: 41,
            ..DeviceCounts::default()
        };
        assert_eq!(
            ground_summary(&devices, None),
            "ground: 197 frames sent, 41 display frames back"
        );
        let external = ground_summary(&DeviceCounts::default(), Some(12));
        assert_eq!(
            external,
            "ground: external station on a pty, 12 command frames decoded by the robot"
        );
        assert!(!external.contains("0 frames sent"));
    }

    #[test]
    fn headings_read_000_to_359() {
        assert_eq!(heading_text(359.7), "000");
        assert_eq!(heading_text(359.4), "359");
        assert_eq!(heading_text(360.0), "000");
        assert_eq!(heading_text(-0.2), "000");
        assert_eq!(heading_text(-90.0), "270");
        assert_eq!(heading_text(42.0), "042");
    }

    #[test]
    fn ages_read_in_milliseconds_below_a_second_and_seconds_above() {
        assert_eq!(age_text(5.0, None), "-");
        assert_eq!(age_text(5.0, Some(4.9)), "100 ms");
        assert_eq!(age_text(5.0, Some(1.8)), "3.2 s");
        // A clock read just before the event was stamped is not a negative age.
        assert_eq!(age_text(5.0, Some(5.001)), "0 ms");
    }
}
