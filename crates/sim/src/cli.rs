//! `dima sim`: the command-line flags and the whole command, given the function that runs the
//! application.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;

use crate::faults::{random_windows, Faults};
use crate::rng::SimRng;
use crate::runner::{run_simulation, AppLaunch, AppOutcome, SimOptions, StatusMode};
use crate::scenario::Scenario;

/// Flags of `dima sim`.
#[derive(Debug, Clone, Args, Default)]
pub struct SimArgs {
    /// Scenario: `default` (about 20 s: revive, manual, AUTO, comms loss, revive, kill),
    /// `manual` (revive and drive), `soak` (drive until --duration, default 60 s, reviving
    /// after every fault window; with --random-faults) or `mission` (with --mission: revive,
    /// AUTO, follow the plan until its last waypoint; --duration is the timeout, default
    /// 300 s).
    #[arg(long, default_value = "default", value_name = "NAME")]
    pub scenario: String,
    /// Stop after this many seconds (default: the scenario's length; with --ground-pty: run
    /// until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Seed for sensor noise and faults (same seed, same noise).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// A fault on a link, repeatable: LINK:KEY=VALUE[,KEY=VALUE...] with LINK sensor, ground
    /// or maestro and KEY ber, drop, insert (probabilities), delay, jitter (ms), silence,
    /// disconnect (START+DURATION s); device and application faults in windows: gnss:freeze,
    /// gnss:loss, imu:stuck, vehicle:rollover, loop:busy (with busy_ms), log:stall, log:full,
    /// maestro:write_error. Example: --fault sensor:ber=1e-4 --fault maestro:disconnect=5+1
    #[arg(long = "fault", value_name = "LINK:KEY=VALUE")]
    pub faults: Vec<String>,
    /// With `--scenario soak`: random fault windows one after another (every kind of
    /// `--fault` window, drawn from --seed), each followed by a revive and driving.
    #[arg(long)]
    pub random_faults: bool,
    /// Leave the ground link to a ground-station GUI: print the pty path to connect it to,
    /// instead of running the scripted ground station.
    #[arg(long)]
    pub ground_pty: bool,
    /// Configuration file of the application (its device ports are replaced by the
    /// simulation's).
    #[arg(long, short, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Directory for the MCAP log.
    #[arg(long, default_value = "dima-logs", value_name = "DIR")]
    pub log_dir: PathBuf,
    /// Control-loop rate in Hz (default: `realtime.loop_rate_hz` of --config, else 250).
    #[arg(long, value_name = "HZ")]
    pub loop_rate: Option<u32>,
    /// Require the configuration's whole realtime setup (without it, SCHED_FIFO is still
    /// tried).
    ///
    /// With --realtime: SCHED_FIFO at `realtime.priority`, CPU pinning (`realtime.cpus`),
    /// mlockall and cpu_dma_latency, with `realtime.required`: if any of it is refused (no root
    /// or CAP_SYS_NICE, no such CPU) the robot stays KILLED and the run fails. Without it: the
    /// loop still asks for SCHED_FIFO and, when that is refused, runs under the normal
    /// scheduler (the log's RT setup says which), unpinned and unlocked; on a busy machine it
    /// may then miss periods and trip its own `Overrun` failsafe.
    #[arg(long)]
    pub realtime: bool,
    /// Plain status lines even on a terminal.
    #[arg(long, conflicts_with = "quiet")]
    pub plain: bool,
    /// No status line, only the summary.
    #[arg(long)]
    pub quiet: bool,
    /// Ground-link key file (mode 0600, from `dima keygen`) for the robot and the scripted
    /// ground station; default: the configuration's `[xbee] key_file`, else a fresh key in the
    /// run directory.
    #[arg(long, value_name = "PATH")]
    pub key_file: Option<PathBuf>,
    /// Serve the robot's live view over the Foxglove WebSocket protocol on IP:PORT (as
    /// `[foxglove] listen`), e.g. 127.0.0.1:8765: in Foxglove, open ws://IP:PORT.
    #[arg(long, value_name = "IP:PORT")]
    pub foxglove: Option<String>,
    /// Run the sensor board's own firmware instead of the simulated board: its `qemu` build
    /// (`cd firmware && cargo build --profile qemu --features qemu`; the ELF, or the firmware
    /// directory) under qemu-system-arm, fed by the same vehicle model.
    #[arg(long, value_name = "ELF")]
    pub firmware: Option<PathBuf>,
    /// With `--scenario mission`: the QGroundControl plan file the robot follows (its
    /// `[navigation] mission_file`); the car starts at its first waypoint, heading for the
    /// second.
    #[arg(long, value_name = "FILE.plan")]
    pub mission: Option<PathBuf>,
}

impl SimArgs {
    /// The run these flags describe.
    pub fn options(&self) -> anyhow::Result<SimOptions> {
        let mut scenario = Scenario::by_name(&self.scenario, self.duration).ok_or_else(|| {
            anyhow::anyhow!(
                "unknown scenario `{}` (default, manual, soak, mission)",
                self.scenario
            )
        })?;
        let mut faults = Faults::default();
        for f in &self.faults {
            faults.apply_arg(f)?;
        }
        let mut random = Vec::new();
        if self.random_faults {
            if scenario.name != "soak" {
                anyhow::bail!("--random-faults needs --scenario soak");
            }
            let mut rng = SimRng::new(self.seed).fork(RANDOM_FAULTS_STREAM);
            random = random_windows(&mut rng, 3.0, scenario.duration_s);
            for w in &random {
                faults.add_window(*w)?;
            }
            scenario = Scenario::soak(scenario.duration_s, &random);
        }
        if let Some(d) = self.duration {
            if !(d > 0.0 && d.is_finite()) {
                anyhow::bail!("--duration must be a positive number of seconds");
            }
        }
        let mission = match (&self.mission, scenario.name) {
            (Some(plan), "mission") => Some(mission_start(plan)?),
            (None, "mission") => anyhow::bail!("--scenario mission needs --mission FILE.plan"),
            (Some(_), _) => anyhow::bail!("--mission needs --scenario mission"),
            (None, _) => None,
        };
        let mut o = SimOptions::new(scenario);
        if let (Some(start), Some(plan)) = (mission, &self.mission) {
            o.board.start_lat_deg = start.lat_deg;
            o.board.start_lon_deg = start.lon_deg;
            o.scenario.start_heading_deg = start.heading_deg;
            o.mission = Some((plan.clone(), start.waypoints));
        }
        o.duration_s = self.duration;
        o.seed = self.seed;
        o.faults = faults;
        o.random_faults = random;
        // A soak must show whether the application's memory grows: the simulation keeps
        // counts, not a record of every packet.
        o.bounded_evidence = o.scenario.name == "soak";
        o.ground_pty = self.ground_pty;
        o.log_dir = self.log_dir.clone();
        o.loop_rate_hz = self.loop_rate_hz()?;
        o.app_config = self.config.clone();
        o.realtime = self.realtime;
        o.key_file = self.key_file.clone();
        o.foxglove = self.foxglove.clone();
        o.firmware = self.firmware.clone();
        o.status = if self.quiet {
            StatusMode::Quiet
        } else if self.plain {
            StatusMode::Plain
        } else {
            StatusMode::Auto
        };
        Ok(o)
    }
}

impl SimArgs {
    /// The loop rate: `--loop-rate`, else the configuration file's, else 250 Hz.
    fn loop_rate_hz(&self) -> anyhow::Result<u32> {
        if let Some(hz) = self.loop_rate {
            return Ok(hz);
        }
        let Some(path) = &self.config else {
            return Ok(DEFAULT_LOOP_RATE_HZ);
        };
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read config file {}", path.display()))?;
        let config = dima_core::config::Config::from_toml(&text, &path.display().to_string())?;
        Ok(config.realtime.loop_rate_hz)
    }
}

/// The loop rate without `--loop-rate` or a configuration file, Hz.
pub const DEFAULT_LOOP_RATE_HZ: u32 = 250;

/// Where a mission's car starts: at the first waypoint, heading for the second.
#[derive(Debug, Clone, PartialEq)]
struct MissionStart {
    lat_deg: f64,
    lon_deg: f64,
    heading_deg: f64,
    /// The waypoints in the model's frame: metres north and east of the first.
    waypoints: Vec<(f64, f64)>,
}

/// Reads and checks the plan as the robot will, and where the car starts.
fn mission_start(plan: &std::path::Path) -> anyhow::Result<MissionStart> {
    use anyhow::Context;
    use dima_core::mission::{parse_plan_file, Follower, FollowerParams, Navigation};
    let text = std::fs::read_to_string(plan)
        .with_context(|| format!("--mission {}: cannot be read", plan.display()))?;
    // Checked with the plan's own fence before anything starts (the robot checks it again,
    // joined with its configuration's fence).
    let mission = parse_plan_file(&text)
        .and_then(|p| Navigation::with_plan(&Default::default(), p))
        .with_context(|| format!("--mission {}", plan.display()))?
        .mission
        .with_context(|| format!("--mission {}: no mission", plan.display()))?;
    let follower = Follower::new(&mission, FollowerParams::default());
    let first = mission.waypoints[0];
    let heading_deg = match (follower.waypoint(0), follower.waypoint(1)) {
        (Some(a), Some(b)) => a.bearing_to(b),
        _ => 0.0,
    };
    Ok(MissionStart {
        lat_deg: first.lat_deg,
        lon_deg: first.lon_deg,
        heading_deg,
        waypoints: mission
            .waypoints
            .iter()
            .map(|w| {
                crate::mission::model_frame(first.lat_deg, first.lon_deg, w.lat_deg, w.lon_deg)
            })
            .collect(),
    })
}

/// The random stream of `--random-faults` (apart from the devices' noise).
const RANDOM_FAULTS_STREAM: u64 = 20;

/// Runs `dima sim`: the simulation with the application started by `app`; prints the summary
/// and the log path; exit code 0 when the scenario's checks held, 1 with the reason when one
/// failed, 2 when the simulation could not run.
pub fn run<F>(args: &SimArgs, app: F) -> ExitCode
where
    F: FnOnce(AppLaunch) -> anyhow::Result<AppOutcome>,
{
    let options = match args.options() {
        Ok(o) => o,
        Err(e) => {
            dima_robot::terminal::report_fatal(&e);
            return ExitCode::from(2);
        }
    };
    eprintln!(
        "dima sim: scenario `{}`, {} Hz loop, seed {}; simulated sensor board, Maestro and {} on pseudo-terminals",
        options.scenario.name,
        options.loop_rate_hz,
        options.seed,
        if options.ground_pty {
            "a ground-station pty"
        } else {
            "scripted ground station"
        }
    );
    for w in &options.random_faults {
        eprintln!("dima sim: random fault --fault {}", w.kind.arg(w.window));
    }
    match run_simulation(&options, app) {
        Err(e) => {
            dima_robot::terminal::report_fatal(&e);
            ExitCode::from(2)
        }
        Ok(report) => {
            println!("{}", report.summary().trim_end());
            if !report.app.summary.is_empty() {
                println!("app: {}", report.app.summary);
            }
            if let Some(p) = &report.app.log_path {
                println!("MCAP log: {} (open it in Foxglove Studio)", p.display());
            }
            match report.failure() {
                None if report.ground_external => {
                    // The scenario's checks assume its scripted station: none were run.
                    println!("done: an external station drove the link; no scenario checks");
                    ExitCode::SUCCESS
                }
                None => {
                    println!("PASS: every expectation of the scenario held");
                    ExitCode::SUCCESS
                }
                Some(reason) => {
                    println!("FAIL: {reason}");
                    if let Some(hint) = &report.host_hint {
                        println!("{}", indented(hint, "  ", HINT_COLUMNS));
                    }
                    ExitCode::from(1)
                }
            }
        }
    }
}

/// The width the FAIL line's explanation is wrapped to.
const HINT_COLUMNS: usize = 80;

/// `text` wrapped at word boundaries to lines of at most `columns` characters (a longer word
/// gets a line of its own), each line starting with `indent`.
fn indented(text: &str, indent: &str, columns: usize) -> String {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty()
            && indent.len() + line.chars().count() + 1 + word.chars().count() > columns
        {
            lines.push(format!("{indent}{line}"));
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(format!("{indent}{line}"));
    }
    lines.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrapper {
        #[command(flatten)]
        sim: SimArgs,
    }

    #[test]
    fn the_loop_rate_is_the_flags_else_the_configuration_files_else_250_hz() {
        let file = std::env::temp_dir().join(format!("dima-sim-rate-{}.toml", std::process::id()));
        std::fs::write(
            &file,
            "[realtime]\nloop_rate_hz = 50\n\n[safety]\noverrun_limit = 5\n",
        )
        .unwrap();
        let rate = |args: &[&str]| {
            let w =
                Wrapper::try_parse_from(std::iter::once("dima-sim").chain(args.iter().copied()))
                    .unwrap();
            w.sim.options().unwrap().loop_rate_hz
        };
        let path = file.to_str().unwrap();
        assert_eq!(rate(&[]), DEFAULT_LOOP_RATE_HZ);
        assert_eq!(rate(&["--config", path]), 50);
        assert_eq!(rate(&["--config", path, "--loop-rate", "100"]), 100);
        std::fs::remove_file(&file).ok();
    }

    #[test]
    fn the_explanation_is_wrapped_and_indented() {
        let text = "the host, not the robot: this machine kept the 250 Hz loop from running on \
                    time (57 periods missed)";
        let out = indented(text, "  ", 30);
        assert!(
            out.lines()
                .all(|l| l.starts_with("  ") && l.chars().count() <= 30),
            "{out}"
        );
        assert_eq!(out.split_whitespace().collect::<Vec<_>>().join(" "), text);
    }

    #[test]
    fn flags_become_options() {
        let w = Wrapper::try_parse_from([
            "sim",
            "--duration",
            "5",
            "--seed",
            "9",
            "--fault",
            "sensor:ber=1e-4",
            "--fault",
            "maestro:disconnect=2+1",
            "--plain",
        ])
        .unwrap();
        let o = w.sim.options().unwrap();
        assert_eq!(o.duration_s, Some(5.0));
        assert_eq!(o.run_length_s(), Some(5.0));
        assert_eq!(o.seed, 9);
        assert_eq!(o.faults.sensor.ber, 1e-4);
        assert_eq!(o.faults.maestro.disconnects.len(), 1);
        assert_eq!(o.status, StatusMode::Plain);
        assert_eq!(o.scenario.name, "default");

        let bad = Wrapper::try_parse_from(["sim", "--fault", "usb:ber=1"]).unwrap();
        assert!(bad.sim.options().is_err());
        let bad = Wrapper::try_parse_from(["sim", "--scenario", "nope"]).unwrap();
        assert!(bad.sim.options().is_err());
        let soak = |args: &[&str]| Wrapper::try_parse_from(args).unwrap().sim.options();
        let o = soak(&[
            "sim",
            "--scenario",
            "soak",
            "--duration",
            "120",
            "--random-faults",
        ])
        .unwrap();
        assert!(o.bounded_evidence);
        assert!(o.random_faults.len() > 5, "{:?}", o.random_faults);
        assert!(o.faults.sensor.silences.len() + o.faults.ground.silences.len() > 0);
        assert!(soak(&["sim", "--random-faults"]).is_err());
        let gui = Wrapper::try_parse_from(["sim", "--ground-pty"]).unwrap();
        assert_eq!(gui.sim.options().unwrap().run_length_s(), None);
    }

    #[test]
    fn a_mission_run_starts_at_the_plans_first_waypoint_heading_for_the_second() {
        let args = |a: &[&str]| Wrapper::try_parse_from(a).unwrap().sim.options();
        let plan = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../core/tests/fixtures/square-40m.plan"
        );
        let o = args(&["sim", "--scenario", "mission", "--mission", plan]).unwrap();
        assert_eq!((o.board.start_lat_deg, o.board.start_lon_deg), (48.1, 11.5));
        assert!(
            o.scenario.start_heading_deg.abs() < 0.01,
            "{}",
            o.scenario.start_heading_deg
        );
        let waypoints = &o.mission.as_ref().unwrap().1;
        assert_eq!(waypoints.len(), 5);
        assert!((waypoints[2].0 - 40.0).abs() < 0.2 && (waypoints[2].1 - 40.0).abs() < 0.2);
        assert_eq!(o.scenario.duration_s, 300.0);
        let err = args(&["sim", "--scenario", "mission"]).unwrap_err();
        assert!(err.to_string().contains("needs --mission"), "{err}");
        assert!(args(&["sim", "--mission", plan]).is_err());
        let err = args(&[
            "sim",
            "--scenario",
            "mission",
            "--mission",
            "/nonexistent.plan",
        ])
        .unwrap_err();
        assert!(format!("{err:#}").contains("cannot be read"), "{err:#}");
    }
}
