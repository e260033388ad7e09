//! `dima-ground`: parses the command line and opens the station (or, as `dima-ground
//! sim-robot`, runs the simulated robot behind `--sim`).

use std::process::ExitCode;

use clap::Parser;
use dima_ground::cli::Cli;

fn main() -> ExitCode {
    #[cfg(feature = "sim")]
    {
        use dima_ground::sim_robot::{run_robot, SIM_ROBOT_ARG};
        let args: Vec<String> = std::env::args().collect();
        if args.get(1).map(String::as_str) == Some(SIM_ROBOT_ARG) {
            return run_robot(&args[1..]);
        }
    }
    let cli = Cli::parse();
    if let Err(e) = cli.validate() {
        eprintln!("error: {e:#}");
        return ExitCode::from(2);
    }
    dima_ground::ui::run(&cli)
}
