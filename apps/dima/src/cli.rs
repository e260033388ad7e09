//! Command-line interface.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use dima_robot::config::Config;

/// The DIMA robot's realtime control application.
#[derive(Debug, Parser)]
#[command(name = "dima", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the control loop on the real hardware.
    Run(RunArgs),
    /// Configuration helpers.
    Config(ConfigArgs),
    /// Run against simulated devices on pseudo-terminals: no hardware needed.
    #[cfg(feature = "sim")]
    Sim(dima_sim::robot::SimArgs),
    /// Deterministic simulation testing: the real parts in virtual time, seeded operator and
    /// faults, invariants checked every cycle.
    #[cfg(feature = "sim")]
    Dst(dima_sim::dst::DstArgs),
    /// What happened in a run: info, export, plot and replay of an MCAP log.
    #[cfg(feature = "tools")]
    Log(dima_tools::logtools::LogArgs),
    /// Decode a raw byte capture of a link into JSON lines.
    #[cfg(feature = "tools")]
    Inspect(dima_tools::logtools::InspectArgs),
    /// Measure the loop against the operating system (wake-up latency, cyclictest's format).
    #[cfg(feature = "tools")]
    Bench(dima_tools::bench::BenchArgs),
    /// Write a new random ground-link key (mode 0600; never overwrites a file).
    Keygen(KeygenArgs),
}

/// `dima keygen`.
#[derive(Debug, Args)]
#[command(
    long_about = "Write a new random ground-link key: 32 hexadecimal characters (a 128-bit \
SipHash-2-4 key) on one line, in a new file created with mode 0600. An existing file is never \
overwritten. Point [xbee] key_file at it on the robot and give the same key to the ground \
station over a trusted channel (not the radio): whoever holds it can drive the robot."
)]
pub struct KeygenArgs {
    /// The key file to create.
    #[arg(value_name = "PATH")]
    pub path: PathBuf,
}

/// `dima run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Configuration file (TOML); `dima config --print-default` writes a commented one.
    #[arg(long, short, value_name = "FILE")]
    pub config: PathBuf,
    /// Flags that override the file.
    #[command(flatten)]
    pub overrides: Overrides,
}

/// Flags that override the configuration file.
#[derive(Debug, Args, Default)]
pub struct Overrides {
    /// Sensor-board serial device.
    #[arg(long, value_name = "PATH")]
    pub sensor_port: Option<PathBuf>,
    /// Maestro serial device.
    #[arg(long, value_name = "PATH")]
    pub maestro_port: Option<PathBuf>,
    /// XBee serial device.
    #[arg(long, value_name = "PATH")]
    pub xbee_port: Option<PathBuf>,
    /// Control-loop rate in Hz.
    #[arg(long, value_name = "HZ")]
    pub loop_rate: Option<u32>,
    /// SCHED_FIFO priority of the loop (0 = SCHED_OTHER).
    #[arg(long, value_name = "PRIO")]
    pub priority: Option<u8>,
    /// Directory for the MCAP log.
    #[arg(long, value_name = "DIR")]
    pub log_dir: Option<PathBuf>,
    /// Do not write an MCAP log.
    #[arg(long)]
    pub no_log: bool,
    /// Stop after this many seconds (default: run until SIGINT/SIGTERM).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
}

impl Overrides {
    /// Applies the flags that were given.
    pub fn apply(&self, config: &mut Config) {
        if let Some(p) = &self.sensor_port {
            config.sensor.port = p.clone();
        }
        if let Some(p) = &self.maestro_port {
            config.maestro.port = p.clone();
        }
        if let Some(p) = &self.xbee_port {
            config.xbee.port = p.clone();
        }
        if let Some(hz) = self.loop_rate {
            config.realtime.loop_rate_hz = hz;
        }
        if let Some(prio) = self.priority {
            config.realtime.priority = prio;
            if prio == 0 {
                config.realtime.telemetry_priority = 0;
            }
        }
        if let Some(dir) = &self.log_dir {
            config.log.directory = dir.clone();
        }
        if self.no_log {
            config.log.enabled = false;
        }
    }
}

/// `dima config`.
#[derive(Debug, Args)]
pub struct ConfigArgs {
    /// Print the commented default configuration.
    #[arg(long)]
    pub print_default: bool,
    /// Check a configuration file and print it with every default filled in.
    #[arg(long, value_name = "FILE", conflicts_with = "print_default")]
    pub check: Option<PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn run_with_overrides() {
        let cli = Cli::try_parse_from([
            "dima",
            "run",
            "--config",
            "x.toml",
            "--maestro-port",
            "/dev/pts/7",
            "--loop-rate",
            "100",
            "--no-log",
        ])
        .unwrap();
        let Command::Run(args) = cli.command else {
            panic!("not run")
        };
        let mut config = Config::default();
        args.overrides.apply(&mut config);
        assert_eq!(config.maestro.port, PathBuf::from("/dev/pts/7"));
        assert_eq!(config.realtime.loop_rate_hz, 100);
        assert!(!config.log.enabled);
    }

    #[test]
    fn keygen_takes_a_path() {
        let cli = Cli::try_parse_from(["dima", "keygen", "/etc/dima/link.key"]).unwrap();
        let Command::Keygen(args) = cli.command else {
            panic!("not keygen")
        };
        assert_eq!(args.path, PathBuf::from("/etc/dima/link.key"));
        assert!(Cli::try_parse_from(["dima", "keygen"]).is_err());
    }

    #[test]
    fn run_needs_a_config() {
        assert!(Cli::try_parse_from(["dima", "run"]).is_err());
    }
}
