//! The simulated robot behind `--sim`, as the child process runs it (`dima-ground sim-robot`):
//! `dima sim --ground-pty` (the runner from `dima-sim`, the application from `dima-robot`) with
//! the run directory and key the station chose. Behind the default feature `sim`; without it
//! the station refuses `--sim`.

#[cfg(feature = "sim")]
use std::path::PathBuf;
#[cfg(feature = "sim")]
use std::process::ExitCode;

#[cfg(feature = "sim")]
use clap::Parser;
#[cfg(feature = "sim")]
use dima_sim::cli::SimArgs;
#[cfg(feature = "sim")]
use dima_sim::runner::{run_simulation, StatusMode};
#[cfg(feature = "sim")]
use nix::sys::signal::Signal;

/// First argument that turns this binary into the simulated robot.
pub const SIM_ROBOT_ARG: &str = "sim-robot";

#[cfg(feature = "sim")]
/// Flags of the simulated robot (the child process).
#[derive(Debug, Parser)]
#[command(
    name = "dima-ground sim-robot",
    about = "The simulated robot behind `dima-ground --sim`"
)]
pub struct SimRobotArgs {
    /// Directory for the pty links; the ground station's is `<DIR>/ground-station`.
    #[arg(long, value_name = "DIR")]
    pub run_dir: PathBuf,
    /// The flags of `dima sim`.
    #[command(flatten)]
    pub sim: SimArgs,
}

#[cfg(feature = "sim")]
/// The child process: `dima sim --ground-pty` with the run directory the station chose.
pub fn run_robot(args: &[String]) -> ExitCode {
    let args = match SimRobotArgs::try_parse_from(args) {
        Ok(a) => a,
        Err(e) => e.exit(),
    };
    // Stop with the station, even if it is killed before it can stop us.
    let parent = nix::unistd::getppid();
    if nix::sys::prctl::set_pdeathsig(Signal::SIGTERM).is_err() || parent.as_raw() == 1 {
        eprintln!("dima-ground sim-robot: not started by a station; stopping");
        return ExitCode::from(2);
    }
    let mut options = match args.sim.options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e:#}");
            return ExitCode::from(2);
        }
    };
    options.ground_pty = true;
    // The station speaks ground link v2 with the key it gave us (`--key-file`).
    options.require_auth = Some(true);
    options.run_dir = args.run_dir.clone();
    options.status = StatusMode::Quiet;
    let result = run_simulation(&options, |launch| {
        dima_robot::app::install_signal_handlers(&launch.stop)?;
        dima_sim::robot::run_app(launch)
    });
    match result {
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
        Ok(report) => {
            eprintln!("simulated robot: {}", report.summary().trim_end());
            if let Some(p) = &report.app.log_path {
                eprintln!("simulated robot: MCAP log {}", p.display());
            }
            ExitCode::SUCCESS
        }
    }
}

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;

    #[test]
    fn robot_flags_are_dima_sims() {
        let a = SimRobotArgs::try_parse_from([
            SIM_ROBOT_ARG,
            "--run-dir",
            "/tmp/x",
            "--key-file",
            "/tmp/x/link.key",
            "--ground-pty",
            "--quiet",
            "--log-dir",
            "/tmp/logs",
            "--duration",
            "2.5",
        ])
        .unwrap();
        assert_eq!(a.run_dir, PathBuf::from("/tmp/x"));
        let o = a.sim.options().unwrap();
        assert!(o.ground_pty);
        assert_eq!(o.log_dir, PathBuf::from("/tmp/logs"));
        assert_eq!(o.run_length_s(), Some(2.5));
        assert_eq!(o.scenario.name, "default");
        assert_eq!(o.key_file, Some(PathBuf::from("/tmp/x/link.key")));
    }
}
