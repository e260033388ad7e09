//! `dima`: parses the command line and the configuration, then hands over to the libraries:
//! `dima-robot` for `dima run`, and behind the default features `dima-sim` for `dima sim` and
//! `dima dst` (feature `sim`) and `dima-tools` for `dima log`, `dima inspect` and `dima bench`
//! (feature `tools`). `cargo build -p dima --no-default-features` builds the robot alone.

mod cli;
mod config_check;

use std::io::Write;
use std::process::ExitCode;

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use clap::Parser;
use cli::{Cli, Command};
use dima_robot::config::{self, DEFAULT_TOML};
use dima_robot::{app, terminal};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let level = if quiet_by_default(&cli.command) {
        "warn"
    } else {
        "info"
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level)),
        )
        // Log lines clear `dima sim`'s status line and draw it again below them.
        .with_writer(terminal::StderrBelowStatus::default)
        // Colour codes only for a terminal, never into files and pipes, and not with NO_COLOR.
        .with_ansi(terminal::stderr_colour())
        .init();
    let command = match cli.command {
        #[cfg(feature = "sim")]
        Command::Sim(args) => return dima_sim::robot::main(&args),
        #[cfg(feature = "sim")]
        Command::Dst(args) => return dima_sim::dst::main(&args),
        #[cfg(feature = "tools")]
        Command::Log(args) => return exit_code(dima_tools::logtools::log(args)),
        #[cfg(feature = "tools")]
        Command::Inspect(args) => return exit_code(dima_tools::logtools::inspect(args)),
        other => other,
    };
    match run(command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            terminal::report_fatal(&error);
            ExitCode::FAILURE
        }
    }
}

/// In a simulation the status line is the live view: only warnings unless `RUST_LOG` says so.
fn quiet_by_default(command: &Command) -> bool {
    match command {
        #[cfg(feature = "sim")]
        Command::Sim(_) | Command::Dst(_) => true,
        _ => false,
    }
}

/// The exit code of a tool: its own, or 1 with the error on stderr.
#[cfg(feature = "tools")]
fn exit_code(result: anyhow::Result<ExitCode>) -> ExitCode {
    result.unwrap_or_else(|error| {
        terminal::report_fatal(&error);
        ExitCode::FAILURE
    })
}

fn run(command: Command) -> anyhow::Result<()> {
    match command {
        #[cfg(feature = "tools")]
        Command::Bench(args) => dima_tools::bench::bench(args),
        Command::Keygen(args) => {
            dima_groundlink::key_file::create(&args.path)?;
            println!(
                "wrote a new ground-link key to {} (mode 0600): set [xbee] key_file = \"{}\" \
                 and give the same key to the ground station over a trusted channel",
                args.path.display(),
                args.path.display()
            );
            Ok(())
        }
        #[cfg(feature = "sim")]
        Command::Sim(_) | Command::Dst(_) => unreachable!("handled in main"),
        #[cfg(feature = "tools")]
        Command::Log(_) | Command::Inspect(_) => unreachable!("handled in main"),
        Command::Config(args) => {
            if let Some(path) = args.check {
                let text = config_check::check(&path)?;
                std::io::stdout().write_all(text.as_bytes())?;
            } else if args.print_default {
                std::io::stdout().write_all(DEFAULT_TOML.as_bytes())?;
            } else {
                anyhow::bail!("dima config: give --print-default or --check FILE");
            }
            Ok(())
        }
        Command::Run(args) => {
            let mut config = config::load(&args.config)?;
            args.overrides.apply(&mut config);
            config.validate()?;
            let stop = Arc::new(AtomicBool::new(false));
            app::install_signal_handlers(&stop)?;
            let options = app::RunOptions {
                duration: args.overrides.duration.map(Duration::from_secs_f64),
                observer: None,
                busy: None,
                log_faults: Default::default(),
            };
            tracing::info!("starting: KILLED until a revive from the ground station");
            let summary = app::run(&config, app::hardware_devices(&config), options, stop)?;
            if summary.outputs_safe {
                tracing::info!("outputs safe; {}", summary.metrics.summary());
            } else {
                tracing::error!(
                    "safe outputs NOT confirmed (the servo board was missing or its last \
                     write failed): check the car; {}",
                    summary.metrics.summary()
                );
            }
            tracing::info!("{}", summary.telemetry.summary());
            if let Some(path) = &summary.log_path {
                tracing::info!("log: {}", path.display());
            }
            match summary.realtime_fault {
                Some(why) => anyhow::bail!("the run stayed KILLED: realtime setup failed ({why})"),
                None => Ok(()),
            }
        }
    }
}
