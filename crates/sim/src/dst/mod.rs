//! `dima dst`: deterministic simulation testing. The robot's real parts (the control step, the
//! command gate and the telemetry's display frames), the ground station's real protocol logic,
//! `dima-sim`'s car and sensor board, composed in one thread in virtual time, driven by a
//! seeded random operator and seeded faults, with the invariants checked after every cycle.
//! The same seed replays the same run exactly, on any machine and under any load.
//!
//! - [`operator`] and [`intent`]: what the operator does, and the record of what was asked;
//! - [`radio`]: the radio channel both ways (baud rate, delay, loss, bursts, damaged bytes);
//! - [`faults`], [`sensor`], [`host`]: the sensor board's faults, the board as the loop sees
//!   it, and the host's late wake-ups;
//! - [`navigation`]: the mission and the geofence of the even seeds;
//! - [`invariants`]: the invariants, by name;
//! - [`runner`]: one run, cycle by cycle; [`trace`]: its MCAP file.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Args;
use dima_core::Nanos;

pub mod faults;
pub mod host;
pub mod intent;
pub mod invariants;
pub mod navigation;
pub mod operator;
pub mod radio;
#[cfg(test)]
mod regressions;
pub mod runner;
pub mod sensor;
#[cfg(test)]
mod tests;
pub mod trace;

use invariants::{Invariant, Violation};
use runner::{Simulation, START_NS};

/// How long a trace written for a violation goes on after the first one, ns.
pub const TRACE_AFTER_VIOLATION_NS: Nanos = 2_000_000_000;

/// `dima dst --help`'s list of the invariants (a test keeps it complete).
pub const INVARIANTS_HELP: &str = "\
Invariants (checked after every cycle; see docs/dst.md):
  outputs_in_limits         every pulse within its channel's min..max, or the safe output
  no_unasked_motion         safe outputs when KILLED/FAILSAFE; in MANUAL only values the
                            operator asked for after the accepted revive; in AUTO only with
                            setpoints asked for after it and after the last manual value
                            (with a mission, the setpoint entering AUTO asks for its heading)
  kill_is_immediate         a cycle that applies a kill ends KILLED with the safe outputs
  failsafe_in_time          FAILSAFE within its bound: comms loss, sensor loss, a frozen
                            accelerometer or gyroscope, overruns, stale GNSS in AUTO (and in
                            MANUAL with a geofence)
  no_unasked_revive         leaving KILLED/FAILSAFE needs a fresh operator revive request
  auto_forward_only         AUTO throttle never below neutral
  station_shows_robot_mode  the station shows the mode the robot put into the frame
  heading_needs_fresh_gnss  AUTO steers only with a GNSS heading fix within the GNSS timeout
  fence_failsafe_in_time    a fresh fix outside the geofence in MANUAL/AUTO: KILLED or
                            FAILSAFE within one GNSS period plus one cycle
  no_revive_outside_fence   no revive while the newest fresh fix is outside the inclusion
                            areas (nor before any fix) when a geofence is configured
  mission_stops_on_kill     KILLED/FAILSAFE: safe outputs, no mission; the mission is followed
                            only after AUTO is entered again, and restarts from its beginning";

/// Flags of `dima dst`.
#[derive(Debug, Clone, Args)]
#[command(
    long_about = "Deterministic simulation testing: the robot's control step, command gate \
and display frames, the ground station's protocol logic, the simulated car and sensor board, \
composed in one thread in virtual time, driven by a random operator and random faults of the \
radio, the sensor board and the host, all drawn from the seed. Every invariant is checked \
after every cycle. One line per run; on a violation the run's trace is written as \
dst-seed-N.mcap (readable by `dima log info|plot|replay`) and the exit status is 1. The same \
seed replays the same run exactly.",
    after_long_help = INVARIANTS_HELP
)]
pub struct DstArgs {
    /// Seed of the first run (the runs take seed, seed + 1, ...).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of runs.
    #[arg(long, default_value_t = 1)]
    pub runs: u64,
    /// Virtual seconds per run.
    #[arg(long, default_value_t = 60.0, value_name = "S")]
    pub duration: f64,
    /// Write every run's trace into DIR (violation or not); by default only a run with a
    /// violation is written, into the current directory.
    #[arg(long, value_name = "DIR")]
    pub log_dir: Option<PathBuf>,
}

/// What one run did.
#[derive(Debug, Clone)]
pub struct RunReport {
    /// Its seed.
    pub seed: u64,
    /// Virtual time run, ns.
    pub virtual_ns: Nanos,
    /// Wall time it took.
    pub wall: Duration,
    /// Cycles of the robot.
    pub cycles: u64,
    /// Invariant checks.
    pub checks: u64,
    /// Violations, in the order found.
    pub violations: Vec<Violation>,
    /// Cycles in which AUTO followed the mission.
    pub mission_cycles: u64,
    /// Entries into FAILSAFE with the cause `Geofence`.
    pub fence_failsafes: u64,
    /// Fresh fixes the harness found outside the geofence in cycles that began in MANUAL or
    /// AUTO.
    pub fence_exits: u64,
}

impl RunReport {
    /// `seed N: S s virtual in W s wall, C cycles, I invariant checks, V violations`, and on a
    /// seed with a mission or a fence `, M mission cycles, F fence failsafes`.
    pub fn line(&self) -> String {
        let nav = if navigation::seed_has_navigation(self.seed) {
            format!(
                ", {} mission cycles, {} fence failsafes",
                self.mission_cycles, self.fence_failsafes
            )
        } else {
            String::new()
        };
        format!(
            "seed {}: {:.0} s virtual in {:.2} s wall, {} cycles, {} invariant checks, {} violations{nav}",
            self.seed,
            self.virtual_ns as f64 * 1e-9,
            self.wall.as_secs_f64(),
            self.cycles,
            self.checks,
            self.violations.len()
        )
    }

    /// The first violation, if any.
    pub fn first(&self) -> Option<&Violation> {
        self.violations.first()
    }
}

/// Virtual nanoseconds of `duration_s` seconds.
fn duration_ns(duration_s: f64) -> Nanos {
    (duration_s.max(0.0) * 1e9) as Nanos
}

/// Runs `seed` for `duration_s` virtual seconds without a trace.
pub fn run_seed(seed: u64, duration_s: f64) -> RunReport {
    let end = START_NS + duration_ns(duration_s);
    let wall = Instant::now();
    let mut sim = Simulation::new(seed, end);
    sim.run_until(end, None, None);
    report(seed, &sim, wall.elapsed())
}

fn report(seed: u64, sim: &Simulation, wall: Duration) -> RunReport {
    RunReport {
        seed,
        virtual_ns: sim.elapsed_ns(),
        wall,
        cycles: sim.cycles(),
        checks: sim.checks(),
        violations: sim.violations().to_vec(),
        mission_cycles: sim.mission_cycles(),
        fence_failsafes: sim.fence_failsafes(),
        fence_exits: sim.fence_exits(),
    }
}

/// Runs `seed` again and writes its trace to `path`, up to [`TRACE_AFTER_VIOLATION_NS`] after
/// the first violation when `cut` is set, else the whole run.
pub fn run_traced(seed: u64, duration_s: f64, path: &Path, cut: bool) -> anyhow::Result<RunReport> {
    let end = START_NS + duration_ns(duration_s);
    let wall = Instant::now();
    let mut sim = Simulation::new(seed, end);
    let stop = cut.then_some(TRACE_AFTER_VIOLATION_NS);
    trace::write(path, seed, duration_s, &mut sim, end, stop)?;
    Ok(report(seed, &sim, wall.elapsed()))
}

/// The trace file of `seed`.
pub fn trace_name(seed: u64) -> String {
    format!("dst-seed-{seed}.mcap")
}

/// Runs `dima dst`: exit status 0 when every invariant held in every run, 1 on a violation,
/// 2 on an error.
pub fn main(args: &DstArgs) -> ExitCode {
    match run_all(args) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(error) => {
            dima_robot::terminal::report_fatal(&error);
            ExitCode::from(2)
        }
    }
}

fn run_all(args: &DstArgs) -> anyhow::Result<bool> {
    if let Some(dir) = &args.log_dir {
        std::fs::create_dir_all(dir)?;
    }
    let mut all_held = true;
    for seed in args.seed..args.seed.saturating_add(args.runs) {
        let report = match &args.log_dir {
            Some(dir) => run_traced(seed, args.duration, &dir.join(trace_name(seed)), false)?,
            None => run_seed(seed, args.duration),
        };
        println!("{}", report.line());
        let Some(first) = report.first() else {
            continue;
        };
        all_held = false;
        let path = match &args.log_dir {
            Some(dir) => dir.join(trace_name(seed)),
            None => {
                let path = PathBuf::from(trace_name(seed));
                run_traced(seed, args.duration, &path, true)?;
                path
            }
        };
        println!(
            "seed {seed}: VIOLATED {} at cycle {} (t = {:.3} s): {}; trace: {}",
            first.invariant.name(),
            first.cycle,
            first.t_ns.saturating_sub(START_NS) as f64 * 1e-9,
            first.detail,
            path.display()
        );
        for name in distinct(&report.violations) {
            println!("seed {seed}:   also violated: {name}");
        }
    }
    Ok(all_held)
}

/// The names of the invariants violated after the first one's, each once.
fn distinct(violations: &[Violation]) -> Vec<&'static str> {
    let first = violations.first().map(|v| v.invariant);
    let mut seen: Vec<Invariant> = Vec::new();
    for v in violations {
        if Some(v.invariant) != first && !seen.contains(&v.invariant) {
            seen.push(v.invariant);
        }
    }
    seen.sort();
    seen.into_iter().map(Invariant::name).collect()
}
