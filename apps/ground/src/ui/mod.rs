//! The window: a thin layer that reads input, hands it to the plain modules and draws their
//! state. Each frame: frames from the link into [`Telemetry`], keys and gamepad through
//! [`KeyboardDriver`] and [`ManualControl`] to the link, then the panels.

mod alert;
mod charts;
mod connection;
mod drive;
mod input;
mod joystick;
mod map;
mod replay;
mod status;

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use dima_groundlink::station::ManualChannel;
use dima_groundlink::Command;
use eframe::egui;

use crate::alerts::{Alert, Alerts, Observation};
use crate::channels::ChannelTable;
use crate::cli::Cli;
use crate::control::{ManualControl, ManualInputs};
use crate::downlink::DownlinkHealth;
use crate::keys::KeyboardDriver;
use crate::link::{LinkControl, LinkEvent, LinkHandle, LinkStatus};
use crate::map::plan::{PlanOverlay, PlanSource};
use crate::recording::{now_ns, LinkRecord, RecordEvent, Recorder};
use crate::replay::Replay;
use crate::robot_view::Liveness;
use crate::sim::{SimLaunch, SimRobot};
use crate::sound::Sounder;
use crate::telemetry::Telemetry;
use crate::units::SensorCalibration;

/// Repaint at least this often (link health and ages move without input; frames come at
/// 2 Hz, and software-rendered frames cost the robot simulation CPU time).
const REPAINT: Duration = Duration::from_millis(100);

/// The outcome of a `--screenshot` run, written by the screenshot callback.
type ScreenshotResult = Arc<Mutex<Option<Result<PathBuf, String>>>>;

/// The `--screenshot FILE --after SECONDS` plan.
struct ScreenshotPlan {
    path: PathBuf,
    after: Duration,
    requested: bool,
    result: ScreenshotResult,
}

/// `--state-screenshots DIR`: one screenshot per state of the banner and the controls.
struct StateShots {
    dir: PathBuf,
    /// The state last seen, and when it was first seen.
    state: Option<(String, Instant)>,
    /// The state last saved.
    saved: Option<String>,
    /// Screenshots requested so far.
    count: u32,
    /// The state of the frame last drawn: the screenshot, taken later, is named after it.
    drawn: Arc<Mutex<String>>,
}

/// A state is saved once it has been drawn for this long (the frame shows it).
const STATE_SETTLE: Duration = Duration::from_millis(400);

/// The connection bar's editable state.
struct ConnectionForm {
    ports: Vec<PathBuf>,
    path_text: String,
    baud: u32,
    auto_reconnect: bool,
}

/// Control-mode setpoints as typed.
struct SetpointForm {
    speed_m_s: f64,
    heading_deg: f64,
    message: Option<String>,
}

/// The ground station's window.
pub struct GroundApp {
    started: Instant,
    link: LinkHandle,
    status: LinkStatus,
    recorder: Option<Recorder>,
    recording_note: String,
    /// Which ground link version, and the key file.
    link_note: String,
    sim: Option<SimRobot>,
    sim_note: Option<String>,
    table: ChannelTable,
    table_source: String,
    keyboard: KeyboardDriver,
    manual: ManualControl,
    /// The link's count of dropped manual values last acted on.
    seen_cancellations: u64,
    joystick: joystick::JoystickState,
    revive_progress: f32,
    confirm_revive: bool,
    /// Sliders being dragged in the last frame, with their value.
    slider_dragged: [Option<dima_groundlink::Percent>; 3],
    telemetry: Telemetry,
    connection: ConnectionForm,
    setpoints: SetpointForm,
    map: map::MapPanel,
    screenshot: Option<ScreenshotPlan>,
    state_shots: Option<StateShots>,
    /// The alert state and the banner.
    alerts: Alerts,
    sounder: Sounder,
    /// Whether the drive controls were live last frame (changes are recorded).
    controls_live: Option<bool>,
    /// Set by SIGINT/SIGTERM: close the window (stopping the robot and closing the recording)
    /// instead of dying with the recording open.
    stop_requested: Arc<AtomicBool>,
    /// `--replay`: the log played back (the link is inert, the drive controls disabled).
    replay: Option<Replay>,
    /// The replay's revision last copied into `status` and `telemetry`.
    replay_shown: Option<u64>,
}

impl GroundApp {
    /// Sets everything up from the command line (starting the simulated robot with --sim).
    fn new(cli: &Cli, screenshot_result: ScreenshotResult) -> anyhow::Result<GroundApp> {
        // A key given on the command line is checked before anything starts.
        let (mut key, mut link_note) = cli.link_key()?;
        let joystick = cli.joystick_config()?;
        let (table, table_source) = channel_table(cli)?;
        let calibration = sensor_calibration(cli)?;
        let replay = open_replay(cli, &key, &calibration)?;
        // A robot log's own sensor-board info frame calibrates its values.
        let calibration = match &replay {
            Some(r) if calibration.is_none() => r.calibration().cloned(),
            _ => calibration,
        };
        if let Some(r) = &replay {
            if r.log().kind == crate::replay::source::LogKind::Robot {
                link_note = "robot log: the robot's reports rebuilt from its cycles".to_owned();
            }
        }
        let (recorder, recording_note) = match &replay {
            Some(_) => (None, "not recording (replay)".to_owned()),
            None => start_recorder(cli)?,
        };
        let sim = start_sim(cli)?;
        if let Some(robot) = &sim {
            // The simulated robot requires ground link v2 with this key.
            key = Some(dima_groundlink::key_file::load(robot.key_file())?);
            link_note = format!(
                "ground link v2, authenticated (key {})",
                robot.key_file().display()
            );
        }
        let link = match &replay {
            // A replay sends nothing anywhere: no link thread at all.
            Some(_) => LinkHandle::inert(),
            None => LinkHandle::spawn(
                recorder.as_ref().map(Recorder::sender),
                calibration.clone(),
                key,
            )?,
        };
        let port = sim.as_ref().map(SimRobot::ground_pty).or(cli.port.clone());
        if let Some(path) = &port {
            link.send(LinkControl::Connect {
                path: path.clone(),
                baud: cli.baud,
            });
        }
        let plan = match (&cli.plan, &replay) {
            (Some(path), _) => Some(PlanOverlay::load(path)?),
            (None, Some(r)) => r
                .log()
                .navigation
                .as_ref()
                .map(|n| PlanOverlay::of(n, PlanSource::RobotLog)),
            (None, None) => None,
        };
        let stop_requested = stop_on_signals()?;
        let started = Instant::now();
        Ok(GroundApp {
            stop_requested,
            started,
            status: link.status(),
            link,
            recorder,
            recording_note,
            link_note,
            sim_note: sim.as_ref().map(|s| {
                format!(
                    "simulated robot (pid {}), its log in {}",
                    s.pid(),
                    cli.sim_log_dir.display()
                )
            }),
            sim,
            keyboard: KeyboardDriver::new(&table, cli.key_step),
            manual: ManualControl::new(&table),
            seen_cancellations: 0,
            table,
            table_source,
            joystick: joystick::JoystickState::new(joystick, cli.calibrate_joystick),
            revive_progress: 0.0,
            confirm_revive: false,
            slider_dragged: [None; 3],
            telemetry: Telemetry::new(started, calibration),
            connection: ConnectionForm {
                ports: crate::serial::list_ports(),
                path_text: port.map(|p| p.display().to_string()).unwrap_or_default(),
                baud: cli.baud,
                auto_reconnect: true,
            },
            setpoints: SetpointForm {
                speed_m_s: 1.0,
                heading_deg: 0.0,
                message: None,
            },
            state_shots: cli.state_screenshots.clone().map(|dir| StateShots {
                dir,
                state: None,
                saved: None,
                count: 0,
                drawn: Arc::default(),
            }),
            alerts: Alerts::default(),
            sounder: Sounder::new(cli.mute || replay.is_some()),
            controls_live: None,
            map: map::MapPanel::new(cli.panel, cli.map_tiles.clone(), plan),
            screenshot: cli.screenshot.clone().map(|path| ScreenshotPlan {
                path,
                after: Duration::from_secs_f64(cli.after),
                requested: false,
                result: screenshot_result,
            }),
            replay,
            replay_shown: None,
        })
    }

    /// The station's "now": the instant of the replay's log time in replay mode.
    fn now(&self) -> Instant {
        self.replay.as_ref().map_or_else(Instant::now, Replay::now)
    }

    /// Replay mode's frame: the replay keys, the clock to the wall time, the state shown, the
    /// alerts at the log's time.
    fn replay_logic(&mut self, ctx: &egui::Context) {
        let Some(replay) = self.replay.as_mut() else {
            return;
        };
        replay::keys(ctx, replay);
        let rebuilds = replay.rebuilds();
        replay.update(self.started.elapsed());
        self.show_replay(rebuilds);
        self.update_alerts(self.now());
    }

    /// Copies the replay's state when it changed; after a rebuild the alerts start over.
    fn show_replay(&mut self, rebuilds_before: u64) {
        let Some(replay) = self.replay.as_ref() else {
            return;
        };
        if replay.rebuilds() != rebuilds_before {
            self.alerts = Alerts::default();
            self.controls_live = None;
        }
        if self.replay_shown != Some(replay.revision()) {
            self.replay_shown = Some(replay.revision());
            self.status = replay.state().status.clone();
            self.telemetry = replay.state().telemetry.clone();
        }
    }

    /// A kill from any source: at once, and the manual sources must be let go.
    fn kill(&mut self) {
        self.link.send(LinkControl::Request(Command::Kill));
        self.manual.killed();
    }

    /// A revive: nothing asked for before it drives after it (the link drops it too), so
    /// the manual sources must be let go and moved again.
    fn revive(&mut self) {
        for request in self.manual.cancelled() {
            self.link.send(request);
        }
        self.link.send(LinkControl::Request(Command::Revive));
    }

    /// Frames in, input to the link.
    fn logic(&mut self, ctx: &egui::Context) {
        if self.replay.is_some() {
            self.replay_logic(ctx);
            return;
        }
        let now = Instant::now();
        for event in self.link.drain_events() {
            let LinkEvent::Frame(at, frame) = event;
            self.telemetry.ingest(at, frame);
        }
        self.status = self.link.status();
        if self.status.driving_cancellations != self.seen_cancellations {
            // The station dropped the manual values (a revive went out, the robot reported
            // KILLED or FAILSAFE): the sliders show neutral, held sources must be let go.
            self.seen_cancellations = self.status.driving_cancellations;
            for request in self.manual.cancelled() {
                self.link.send(request);
            }
        }

        self.update_alerts(now);

        let keys = input::read_keys(ctx);
        let actions = self.keyboard.update(keys, now);
        self.revive_progress = actions.revive_progress;
        let neutral = ManualChannel::ALL.map(|c| self.manual.neutral(c));
        let gamepad = self.joystick.poll(neutral, now - self.started).clone();
        if actions.kill || gamepad.kill {
            self.kill();
        }
        if actions.revive {
            self.revive();
        }
        let inputs = ManualInputs {
            keys: actions.axes,
            gamepad: gamepad.sticks,
            slider_dragged: self.slider_dragged,
        };
        for request in self.manual.update(&inputs) {
            self.link.send(request);
        }
    }

    /// The alerts from the link's status: raised ones sound (the most urgent) and are
    /// recorded, as are changes of the drive controls' state.
    fn update_alerts(&mut self, now: Instant) {
        let report = self.status.fresh_report(now);
        let observation = Observation {
            reports_fresh: matches!(
                self.status.downlink(now),
                DownlinkHealth::Authentic | DownlinkHealth::V1NoReport
            ),
            mode: report.map(|r| r.mode),
            cause: report.and_then(|r| r.failsafe_cause),
            refusal: report.and_then(|r| r.revive_refusal),
        };
        let raised = self.alerts.update(&observation, now);
        if let Some(first) = raised.first() {
            self.sounder.play(first);
        }
        for alert in &raised {
            self.record_event("alert", format!("{}: {}", alert.name(), alert.text()));
        }
        let liveness = Liveness::of(&self.status, now);
        if self.controls_live != Some(liveness.is_live()) {
            self.controls_live = Some(liveness.is_live());
            let detail = liveness
                .why_greyed()
                .unwrap_or_else(|| "drive controls live".into());
            self.record_event("controls", detail);
        }
    }

    /// Records a station event on the link topic.
    fn record_event(&self, event: &str, detail: String) {
        if let Some(r) = &self.recorder {
            let _ = r.sender().send(RecordEvent::Link(
                now_ns(),
                LinkRecord {
                    event: event.into(),
                    port: None,
                    baud: None,
                    detail: Some(detail),
                },
            ));
        }
    }

    /// The banner's alert now.
    fn banner(&self) -> Option<Alert> {
        self.alerts.banner()
    }

    /// `--state-screenshots`: a screenshot once a new state of the banner and the controls
    /// has been drawn for [`STATE_SETTLE`].
    fn take_state_screenshots(&mut self, ctx: &egui::Context) {
        let banner = self.banner().map_or("no-alert", |a| a.name());
        let controls = if self.controls_live == Some(true) {
            "live"
        } else {
            "greyed"
        };
        // The robot's reported throttle target too, so driving shows as its own state.
        let throttle = self
            .status
            .robot
            .and_then(|r| r.actuation)
            .map_or("unknown".to_owned(), |a| format!("{}us", a.servo_us()[0]));
        let Some(shots) = self.state_shots.as_mut() else {
            return;
        };
        let now = Instant::now();
        let state = format!("{banner}-{controls}-throttle-{throttle}");
        state.clone_into(&mut shots.drawn.lock().unwrap_or_else(|e| e.into_inner()));
        match &shots.state {
            Some((s, _)) if *s == state => {}
            _ => shots.state = Some((state.clone(), now)),
        }
        let Some((state, since)) = &shots.state else {
            return;
        };
        if shots.saved.as_ref() == Some(state) || now.duration_since(*since) < STATE_SETTLE {
            return;
        }
        shots.saved = Some(state.clone());
        shots.count += 1;
        let (dir, count, drawn) = (shots.dir.clone(), shots.count, shots.drawn.clone());
        let _ = std::fs::create_dir_all(&dir);
        ctx.request_screenshot(move |image| {
            // Named after the state of the frame it shows (it may have changed since the
            // request).
            let state = drawn.lock().unwrap_or_else(|e| e.into_inner()).clone();
            let path = dir.join(format!("{count:02}-{state}.png"));
            match save_png(&path, &image) {
                Ok(()) => eprintln!("dima-ground: state screenshot {}", path.display()),
                Err(e) => eprintln!("dima-ground: state screenshot failed: {e}"),
            }
        });
    }

    fn take_screenshot_when_due(&mut self, ctx: &egui::Context) {
        let Some(plan) = self.screenshot.as_mut() else {
            return;
        };
        if let Some(done) = plan
            .result
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_ref()
        {
            if let Err(e) = done {
                eprintln!("dima-ground: screenshot failed: {e}");
            }
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            return;
        }
        if !plan.requested && self.started.elapsed() >= plan.after {
            plan.requested = true;
            let (path, result) = (plan.path.clone(), plan.result.clone());
            ctx.request_screenshot(move |image| {
                let outcome = save_png(&path, &image).map(|()| path.clone());
                *result.lock().unwrap_or_else(|e| e.into_inner()) = Some(outcome);
            });
        }
    }
}

/// The channel table (`--robot-config`, else dima's defaults) and where it came from.
fn channel_table(cli: &Cli) -> anyhow::Result<(ChannelTable, String)> {
    Ok(match &cli.robot_config {
        Some(path) => (
            ChannelTable::from_robot_config(path)?,
            path.display().to_string(),
        ),
        None => (ChannelTable::default(), "dima's defaults".to_owned()),
    })
}

/// The sensor calibration: from a robot log (`--sensor-info`), the simulated board's with
/// `--sim`, else unknown.
fn sensor_calibration(cli: &Cli) -> anyhow::Result<Option<SensorCalibration>> {
    Ok(match (&cli.sensor_info, cli.sim) {
        (Some(path), _) => Some(SensorCalibration::from_robot_log(path)?),
        (None, true) => Some(SensorCalibration::simulated_board()),
        (None, false) => None,
    })
}

/// Starts recording the session (unless `--no-record`); the recorder and a note for the bar.
fn start_recorder(cli: &Cli) -> anyhow::Result<(Option<Recorder>, String)> {
    if cli.no_record {
        return Ok((None, "not recording (--no-record)".to_owned()));
    }
    let r = Recorder::start(&cli.log_dir)?;
    let note = format!("recording to {}", r.path().display());
    Ok((Some(r), note))
}

/// Opens the `--replay` log, at the `--replay-speed`, playing up to `--replay-pause-at`.
fn open_replay(
    cli: &Cli,
    key: &Option<dima_groundlink::v2::LinkKey>,
    calibration: &Option<SensorCalibration>,
) -> anyhow::Result<Option<Replay>> {
    let Some(path) = &cli.replay else {
        return Ok(None);
    };
    let mut replay = Replay::open(path, key.clone(), calibration.clone())?;
    if calibration.is_none() && replay.log().kind == crate::replay::source::LogKind::Robot {
        // The robot's own board info, when the log has it.
        if let Ok(c) = SensorCalibration::from_robot_log(path) {
            replay.set_calibration(Some(c));
        }
    }
    replay.clock_mut().set_speed(cli.replay_speed);
    if let Some(at) = cli.replay_pause_at {
        replay.pause_at(Duration::from_secs_f64(at));
        replay.clock_mut().play();
    }
    Ok(Some(replay))
}

/// Starts the simulated robot with `--sim`.
fn start_sim(cli: &Cli) -> anyhow::Result<Option<SimRobot>> {
    if !cli.sim {
        return Ok(None);
    }
    Ok(Some(SimRobot::start(&SimLaunch {
        log_dir: cli.sim_log_dir.clone(),
        robot_config: cli.robot_config.clone(),
        duration_s: cli.sim_duration,
        key_file: cli.key_file.clone(),
        firmware: cli.firmware.clone(),
    })?))
}

/// A flag SIGINT and SIGTERM set.
fn stop_on_signals() -> anyhow::Result<Arc<AtomicBool>> {
    let stop_requested = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, stop_requested.clone())?;
    }
    Ok(stop_requested)
}

impl eframe::App for GroundApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.logic(&ctx);
        if self.replay.is_some() {
            replay::top_bar(ui, self);
        } else {
            connection::top_bar(ui, self);
        }
        alert::banner(ui, self);
        let rebuilds = self.replay.as_ref().map_or(0, Replay::rebuilds);
        replay::timeline(ui, self);
        // A seek on the timeline shows at once.
        self.show_replay(rebuilds);
        status::bottom_bar(ui, self);
        drive::left_panel(ui, self);
        status::right_panel(ui, self);
        egui::CentralPanel::default().show(ui, |ui| map::central_panel(ui, self));
        drive::revive_confirmation(&ctx, self);
        self.take_state_screenshots(&ctx);
        joystick::calibration_window(&ctx, &mut self.joystick);
        self.take_screenshot_when_due(&ctx);
        if self.stop_requested.load(Ordering::Relaxed) {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        ctx.request_repaint_after(REPAINT);
    }

    fn on_exit(&mut self, _gl: Option<&eframe::glow::Context>) {
        // Stop the robot first (it goes safe), then close the recording.
        if let Some(mut sim) = self.sim.take() {
            sim.stop(Duration::from_secs(5));
        }
        // The link thread holds a sender of the recording: end it first.
        self.link.shutdown();
        if let Some(r) = self.recorder.take() {
            match r.finish() {
                Ok(n) => eprintln!("dima-ground: session recording closed ({n} messages)"),
                Err(e) => eprintln!("dima-ground: {e:#}"),
            }
        }
    }
}

/// Writes an egui screenshot as an RGBA PNG.
fn save_png(path: &std::path::Path, image: &egui::ColorImage) -> Result<(), String> {
    let [w, h] = image.size;
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), w as u32, h as u32);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    let rgba: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
    writer.write_image_data(&rgba).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())
}

/// Runs the station until its window closes. Exit status 0; with --screenshot, 0 only when
/// the PNG was written.
pub fn run(cli: &Cli) -> ExitCode {
    let result: ScreenshotResult = Arc::new(Mutex::new(None));
    let app = match GroundApp::new(cli, result.clone()) {
        Ok(app) => app,
        Err(e) => {
            eprintln!("error: {e:#}");
            return ExitCode::from(2);
        }
    };
    let title = match &cli.replay {
        Some(path) => format!("DIMA ground station — REPLAY {}", path.display()),
        None => "DIMA ground station".to_owned(),
    };
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title(title)
            .with_inner_size([cli.window_size.0, cli.window_size.1]),
        ..Default::default()
    };
    let outcome = eframe::run_native(
        "dima-ground",
        options,
        Box::new(move |_cc| Ok(Box::new(app))),
    );
    if let Err(e) = outcome {
        eprintln!(
            "dima-ground: cannot open the window: {e} (an X11 display is needed: DISPLAY set? \
             Under Xvfb use LIBGL_ALWAYS_SOFTWARE=1)"
        );
        return ExitCode::from(2);
    }
    if cli.screenshot.is_some() {
        match result.lock().unwrap_or_else(|e| e.into_inner()).take() {
            Some(Ok(path)) => {
                eprintln!("dima-ground: screenshot {}", path.display());
                ExitCode::SUCCESS
            }
            Some(Err(e)) => {
                eprintln!("dima-ground: screenshot failed: {e}");
                ExitCode::FAILURE
            }
            None => {
                eprintln!("dima-ground: the window closed before the screenshot");
                ExitCode::FAILURE
            }
        }
    } else {
        ExitCode::SUCCESS
    }
}
