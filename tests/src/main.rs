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
    // Warnings and errors on stderr, as `dima sim` prints them.
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(dima_robot::terminal::StderrBelowStatus::default)
        .with_ansi(false)
        .init();
    dima_sim::robot::main(&cli.sim)
}
