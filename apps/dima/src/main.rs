//! `dima`: parses the command line and the configuration, then hands over to the library.

use std::io::{IsTerminal, Write};
use std::process::ExitCode;

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use clap::Parser;
use dima::app;
use dima::cli::{Cli, Command};
use dima::config::{self, DEFAULT_TOML};

fn main() -> ExitCode {
    let cli = Cli::parse();
    // In a simulation the status line is the live view: only warnings unless RUST_LOG says so.
    let level = if matches!(cli.command, Command::Sim(_) | Command::Dst(_)) {
        "warn"
    } else {
        "info"
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level)),
        )
        .with_writer(std::io::stderr)
        // Colour codes only for a terminal, never into files and pipes.
        .with_ansi(std::io::stderr().is_terminal())
        .init();
    let command = match cli.command {
        Command::Sim(args) => return dima::sim::main(&args),
        Command::Dst(args) => return dima::dst::main(&args),
        Command::Log(args) => return exit_code(dima::logtools::log(args)),
        Command::Inspect(args) => return exit_code(dima::logtools::inspect(args)),
        other => other,
    };
    match run(command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            tracing::error!("{error:#}");
            ExitCode::FAILURE
        }
    }
}

/// The exit code of a tool: its own, or 1 with the error on stderr.
fn exit_code(result: anyhow::Result<ExitCode>) -> ExitCode {
    result.unwrap_or_else(|error| {
        eprintln!("error: {error:#}");
        ExitCode::FAILURE
    })
}

fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Bench(args) => dima::bench::bench(args),
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
        Command::Sim(_) | Command::Dst(_) | Command::Log(_) | Command::Inspect(_) => {
            unreachable!("handled in main")
        }
        Command::Config(args) => {
            if let Some(path) = args.check {
                let config = config::load(&path)?;
                let text = toml::to_string(&config).context("serialising the configuration")?;
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
