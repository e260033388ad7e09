//! `dima sim` as a stand-alone program for the end-to-end tests: the same flags and the same
//! run as the `dima` binary's `sim` subcommand.

use std::process::ExitCode;

use clap::Parser;

/// Runs the DIMA application against simulated devices.
#[derive(Parser)]
#[command(name = "dima-e2e-sim", version, about)]
struct Cli {
    #[command(flatten)]
    sim: dima_sim::cli::SimArgs,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    dima_sim::cli::run(&cli.sim, |launch| {
        dima::app::install_signal_handlers(&launch.stop)?;
        dima_e2e::run_app(launch)
    })
}
