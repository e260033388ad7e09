//! `dima sim` as a stand-alone program for the end-to-end tests (a test cannot build another
//! package's binary): the same flags and the same function as the `dima` binary's `sim`.

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
    dima::sim::main(&cli.sim)
}
