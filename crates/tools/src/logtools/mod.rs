//! Tools around a run: `dima log info|export|plot|replay` on MCAP logs and `dima inspect` on
//! raw captures of each link.

pub mod config_diff;
pub mod export;
pub mod info;
pub mod inspect;
pub mod parquet;
pub mod plot;
pub mod plot_math;
pub mod plot_track;
pub mod replay;

/// The log reader, from `dima-log`.
pub use dima_log::reader as read;

use std::io::{Read, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Subcommand};

use read::LoggedRun;

/// `dima log`.
#[derive(Debug, Args)]
pub struct LogArgs {
    /// What to do with the log.
    #[command(subcommand)]
    pub command: LogCommand,
}

/// `dima log` subcommands.
#[derive(Debug, Subcommand)]
pub enum LogCommand {
    /// Duration, loop rate, mode changes, packet and link counts, timing percentiles, the
    /// realtime setup and the configuration of a run.
    Info {
        /// The MCAP log (any file of a run: the run's files are read in order).
        file: PathBuf,
    },
    /// Every cycle (or GNSS fix, or state change) as CSV, JSON lines or Parquet, in physical
    /// units.
    #[command(after_long_help = FLEET_HELP)]
    Export {
        /// The MCAP log (any file of a run: the run's files are read in order).
        file: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value = "csv")]
        format: export::Format,
        /// Output file (default: stdout; required for Parquet).
        #[arg(short, long, value_name = "OUT")]
        output: Option<PathBuf>,
        /// The run's id in the Parquet `run` column (default: the name of the run's first file
        /// without `.mcap`).
        #[arg(long, value_name = "ID")]
        run: Option<String>,
        /// Rows of this channel (`replay`: the replayed cycles of a file written by
        /// `dima log replay --config NEW -o FILE`).
        #[arg(long, value_enum, default_value = "cycle", value_name = "NAME")]
        channel: export::Channel,
        /// From this many seconds after the first cycle.
        #[arg(long, value_name = "S", default_value_t = 0.0)]
        from: f64,
        /// Up to this many seconds after the first cycle.
        #[arg(long, value_name = "S", default_value_t = f64::INFINITY)]
        to: f64,
    },
    /// A PNG plot with a real time axis, units and mode changes marked.
    Plot {
        /// The MCAP log (any file of a run: the run's files are read in order).
        file: PathBuf,
        /// Output PNG.
        #[arg(short, long, value_name = "OUT.png")]
        output: PathBuf,
        /// What to plot.
        #[arg(long, value_enum, default_value = "outputs")]
        what: plot::What,
        /// The recorded cycles, or the replayed ones of a file written by
        /// `dima log replay --config NEW -o FILE` beside the recorded ones (`outputs`, `gnss`).
        #[arg(long, value_enum, default_value = "cycle", value_name = "NAME")]
        channel: plot::Source,
        /// Width in pixels.
        #[arg(long, default_value_t = 1280)]
        width: u32,
        /// Height in pixels.
        #[arg(long, default_value_t = 720)]
        height: u32,
    },
    /// The configuration the run recorded (TOML, as the robot ran it): the starting point for
    /// `dima log replay --config`, so that a new file differs only in what you change.
    Config {
        /// The MCAP log (any file of a run: the first file's configuration is printed).
        file: PathBuf,
        /// The configuration a comparison file (from `dima log replay -o`) was replayed with.
        #[arg(long)]
        replayed: bool,
    },
    /// Feed the recorded inputs through the control step: identical outputs (exit 0) or the
    /// first difference (exit 1); with another configuration, the outputs beside the recorded
    /// ones in a new MCAP file.
    Replay {
        /// The MCAP log (any file of a run: the run's files are read in order).
        file: PathBuf,
        /// Replay with this configuration instead of the recorded one (e.g. new gains).
        #[arg(long, value_name = "CONFIG")]
        config: Option<PathBuf>,
        /// Write the recorded and replayed cycles to this MCAP file.
        #[arg(short, long, value_name = "OUT.mcap")]
        output: Option<PathBuf>,
    },
}

/// The fleet workflow, after `dima log export --help`.
const FLEET_HELP: &str = "\
Fleet analysis: export each run to Parquet, then query all of them at once.
Every row holds the run's id in its first column, `run`; the other columns
are the CSV's, with one type each (INT64, DOUBLE, BOOLEAN or UTF8 strings;
nullable where the CSV may leave a cell empty), the same in every file.

  for f in logs/dima-*Z.mcap; do   # each run's first file; the rest is read with it
    dima log export \"$f\" --format parquet -o \"parquet/$(basename \"$f\" .mcap).parquet\"
  done
  duckdb -c \"SELECT run, count(*) AS cycles, max(cycle) FROM 'parquet/*.parquet' GROUP BY run\"

Spark, pandas, polars and any other Parquet reader read the same files.";

/// `dima inspect`.
#[derive(Debug, Args)]
pub struct InspectArgs {
    /// Which link the capture is from.
    #[arg(value_enum)]
    pub link: inspect::Link,
    /// The capture (default: stdin).
    pub file: Option<PathBuf>,
    /// Decode and verify authenticated command frames (v2) or display frames (v2 and v3) with
    /// this link key file (from `dima keygen`; the default link); without it, version 1 frames.
    #[arg(long, value_name = "KEY")]
    pub key_file: Option<PathBuf>,
}

/// Reads every file of the run `file` belongs to, in order (see [`dima_log::run`]), and
/// prints the warnings.
fn open_log(file: &std::path::Path) -> anyhow::Result<LoggedRun> {
    let run = dima_log::run::read_run(file)?;
    run.warn(file);
    Ok(run)
}

/// [`open_log`], saying on stderr how many files it read.
fn open_run(file: &std::path::Path) -> anyhow::Result<LoggedRun> {
    let run = open_log(file)?;
    let first = run.files.first().map_or(file, |f| f.as_path());
    let name = first.file_stem().unwrap_or_default().to_string_lossy();
    let n = run.files.len();
    eprintln!(
        "read {n} file{} of run {name}",
        if n == 1 { "" } else { "s" }
    );
    Ok(run)
}

/// Writes `bytes` to stdout and flushes it.
fn write_stdout(bytes: &[u8]) -> std::io::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(bytes)?;
    out.flush()
}

/// Whether `error` is, or was caused by, a write to a closed pipe (`dima log export | head`).
pub fn is_broken_pipe(error: &anyhow::Error) -> bool {
    error.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// `result`, except that a closed stdout ends the tool quietly and successfully: the reader
/// (`head`, `grep -m1`, a pager quit early) took all it wanted.
fn quiet_on_closed_pipe(result: anyhow::Result<ExitCode>) -> anyhow::Result<ExitCode> {
    match result {
        Err(e) if is_broken_pipe(&e) => Ok(ExitCode::SUCCESS),
        other => other,
    }
}

/// Runs `dima log ...`. A closed stdout ends it with success and nothing on stderr.
pub fn log(args: LogArgs) -> anyhow::Result<ExitCode> {
    quiet_on_closed_pipe(run_log(args))
}

fn run_log(args: LogArgs) -> anyhow::Result<ExitCode> {
    match args.command {
        LogCommand::Info { file } => {
            let run = open_log(&file)?;
            let text = if run.cycles.is_empty() && run.config.is_none() {
                // Not a robot log: a ground station session (or any MCAP file).
                session_info(&file)?
            } else {
                info::report(&run)
            };
            write_stdout(text.as_bytes())?;
        }
        LogCommand::Export {
            file,
            format,
            output,
            run: run_id,
            channel,
            from,
            to,
        } => {
            let run = open_run(&file)?;
            if format == export::Format::Parquet {
                let path = output.context(
                    "--format parquet writes a binary file: give it with -o FILE.parquet",
                )?;
                let id = run_id.unwrap_or_else(|| parquet::run_id(&file));
                if channel == export::Channel::Replay
                    && export::rows(&run, channel, from, to).is_empty()
                {
                    anyhow::bail!(no_replay(&file));
                }
                parquet::export_file(&run, channel, (from, to), &id, &path)?;
                eprintln!("wrote {} (run {id})", path.display());
                return Ok(ExitCode::SUCCESS);
            }
            let rows = export::rows(&run, channel, from, to);
            if channel == export::Channel::Replay && rows.is_empty() {
                anyhow::bail!(no_replay(&file));
            }
            match output {
                Some(path) => {
                    let f = std::fs::File::create(&path)
                        .with_context(|| format!("cannot create {}", path.display()))?;
                    let mut w = std::io::BufWriter::new(f);
                    export::write(&rows, format, &mut w)?;
                    w.flush()?;
                }
                None => export::write(&rows, format, &mut std::io::stdout().lock())?,
            }
        }
        LogCommand::Plot {
            file,
            output,
            what,
            channel,
            width,
            height,
        } => {
            let run = open_run(&file)?;
            let size = (width.max(320), height.max(200));
            match channel {
                plot::Source::Cycle => plot::plot(&run, what, &output, size)?,
                plot::Source::Replay => {
                    let replayed = replay::read_replayed(&run)?;
                    if replayed.is_empty() {
                        anyhow::bail!(no_replay(&file));
                    }
                    plot::plot_replay(&run, &replayed, what, &output, size)?;
                }
            }
            eprintln!("wrote {}", output.display());
        }
        LogCommand::Config { file, replayed } => {
            let run = open_log(&file)?;
            let text = replay::recorded_config_text(&run, replayed).with_context(|| {
                if replayed {
                    format!(
                        "{} holds no replayed configuration: only a file written by `dima log \
                         replay --config NEW -o FILE` does",
                        file.display()
                    )
                } else {
                    format!(
                        "{} holds no configuration (metadata record `dima`)",
                        file.display()
                    )
                }
            })?;
            write_stdout(text.as_bytes())?;
        }
        LogCommand::Replay {
            file,
            config,
            output,
        } => return replay_command(&file, config.as_deref(), output.as_deref()),
    }
    Ok(ExitCode::SUCCESS)
}

/// `dima log info` on an MCAP file without control cycles (a ground station session): its
/// channels, duration and message counts, over every file of its run.
fn session_info(file: &std::path::Path) -> anyhow::Result<String> {
    let files = dima_log::naming::run_files(file).unwrap_or_else(|_| vec![file.to_path_buf()]);
    let mut contents = Vec::new();
    for f in &files {
        contents.push(std::fs::read(f).with_context(|| format!("cannot read {}", f.display()))?);
    }
    let slices: Vec<&[u8]> = contents.iter().map(Vec::as_slice).collect();
    let (channels, warnings) = info::channel_summaries(&slices);
    for w in &warnings {
        eprintln!("warning: {}: {w}", file.display());
    }
    let (metadata, _) = slices.iter().map(|b| read::metadata(b)).fold(
        (Vec::new(), Vec::<String>::new()),
        |mut acc, (m, _)| {
            acc.0.extend(m.into_iter().map(|m| m.name));
            acc
        },
    );
    anyhow::ensure!(
        !channels.is_empty() || !metadata.is_empty(),
        "{}: no complete message or metadata record: not an MCAP log, or cut before its first \
         record",
        file.display()
    );
    let names: Vec<String> = files
        .iter()
        .map(|f| {
            f.file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    Ok(info::session_report(&names, &channels, &metadata))
}

/// The error of `--channel replay` on a file without replayed cycles.
fn no_replay(file: &std::path::Path) -> String {
    format!(
        "{} has no replayed cycles (/replay/cycle): write a comparison file with `dima log \
         replay {} --config NEW.toml -o compare.mcap` and give that",
        file.display(),
        file.display()
    )
}

fn replay_command(
    file: &std::path::Path,
    config: Option<&std::path::Path>,
    output: Option<&std::path::Path>,
) -> anyhow::Result<ExitCode> {
    let run = open_run(file)?;
    let config = match config {
        Some(path) => dima_robot::config::load(path)?,
        None => run
            .config
            .clone()
            .context("the log has no configuration; give --config")?,
    };
    let result = replay::replay(&run, &config)?;
    if let Some(path) = output {
        replay::write_mcap(&run, &result, &config, path)?;
        eprintln!("wrote {}", path.display());
    }
    let (text, code) = replay_report(&run, &config, &result, file);
    write_stdout(text.as_bytes())?;
    Ok(code)
}

/// What `dima log replay` prints, and its exit code: the configuration values that differ
/// from the recorded ones (those the control step reads first), then whether the outputs are
/// identical or the first cycle where they differ, output by output.
pub fn replay_report(
    run: &LoggedRun,
    config: &dima_core::config::Config,
    result: &replay::Replay,
    file: &std::path::Path,
) -> (String, ExitCode) {
    use std::fmt::Write as _;
    let mut text = String::new();
    if let Some(recorded) = &run.config {
        // What the user changed, before what it changed: a configuration written from the
        // defaults differs from a recorded one in more than the gain being tuned.
        text += &config_diff::report(&config_diff::differences(recorded, config));
    }
    let code = match &result.first_difference {
        None => {
            let _ = writeln!(
                text,
                "identical: {} cycles replayed, modes and servo targets as recorded",
                result.cycles.len()
            );
            ExitCode::SUCCESS
        }
        Some(d) => {
            let _ = writeln!(
                text,
                "differs: {} of {} cycles; first at cycle {} ({:.3} s): {} (recorded {} {:?} µs, \
                 replayed {} {:?} µs)",
                result.differing,
                result.cycles.len(),
                d.cycle,
                d.t_s,
                replay::describe(d),
                d.recorded.0,
                d.recorded.1,
                d.replayed.0,
                d.replayed.1
            );
            if run.config.is_some() {
                let _ = writeln!(
                    text,
                    "(to change only what you mean to, start from the recorded configuration: \
                     dima log config {} > new.toml)",
                    file.display()
                );
            }
            ExitCode::from(1)
        }
    };
    (text, code)
}

/// Runs `dima inspect ...`. A closed stdout ends it with success and nothing on stderr.
pub fn inspect(args: InspectArgs) -> anyhow::Result<ExitCode> {
    quiet_on_closed_pipe(run_inspect(args))
}

fn run_inspect(args: InspectArgs) -> anyhow::Result<ExitCode> {
    let bytes = match &args.file {
        Some(path) => {
            std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?
        }
        None => {
            let mut v = Vec::new();
            std::io::stdin().lock().read_to_end(&mut v)?;
            v
        }
    };
    if let Some(path) = &args.key_file {
        let key = dima_groundlink::key_file::load(path)?;
        let stats =
            inspect::inspect_authenticated(args.link, &bytes, &key, &mut std::io::stdout().lock())?;
        eprintln!(
            "frames {} bad-tag {} malformed {} skipped-bytes {}",
            stats.frames, stats.bad_tag, stats.malformed, stats.skipped_bytes
        );
        return Ok(ExitCode::SUCCESS);
    }
    let stats = inspect::inspect(args.link, &bytes, &mut std::io::stdout().lock())?;
    eprintln!(
        "frames {} errors {} skipped-bytes {}",
        stats.frames, stats.errors, stats.skipped_bytes
    );
    let v2 = inspect::v2_candidates(args.link, &bytes);
    if v2 > 0 {
        eprintln!(
            "the capture holds {v2} authenticated (version 2 or 3) frame start{}: decode them with \
             --key-file KEY",
            if v2 == 1 { "" } else { "s" }
        );
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    /// `dima log ...` and `dima inspect ...` as the program parses them.
    #[derive(Debug, Parser)]
    enum Tools {
        Log(LogArgs),
        Inspect(InspectArgs),
    }

    fn log(args: &[&str]) -> LogCommand {
        let argv = ["dima", "log"].iter().chain(args).copied();
        match Tools::try_parse_from(argv).unwrap() {
            Tools::Log(l) => l.command,
            Tools::Inspect(_) => unreachable!(),
        }
    }

    #[test]
    fn the_tuning_workflow_parses() {
        let LogCommand::Config { file, replayed } = log(&["config", "drive.mcap"]) else {
            panic!("not config")
        };
        assert_eq!((file, replayed), (PathBuf::from("drive.mcap"), false));
        let LogCommand::Config { replayed, .. } = log(&["config", "c.mcap", "--replayed"]) else {
            panic!("not config")
        };
        assert!(replayed);
        let LogCommand::Export { channel, .. } = log(&["export", "c.mcap", "--channel", "replay"])
        else {
            panic!("not export")
        };
        assert_eq!(channel, export::Channel::Replay);
        let LogCommand::Plot { channel, .. } = log(&["plot", "c.mcap", "-o", "p.png"]) else {
            panic!("not plot")
        };
        assert_eq!(channel, plot::Source::Cycle, "the default");
        let LogCommand::Plot { channel, .. } =
            log(&["plot", "c.mcap", "-o", "p.png", "--channel", "replay"])
        else {
            panic!("not plot")
        };
        assert_eq!(channel, plot::Source::Replay);
        let argv = [
            "dima",
            "inspect",
            "command",
            "cap.bin",
            "--key-file",
            "link.key",
        ];
        let Tools::Inspect(i) = Tools::try_parse_from(argv).unwrap() else {
            panic!("not inspect")
        };
        assert_eq!(i.key_file, Some(PathBuf::from("link.key")));
    }

    #[test]
    fn a_closed_pipe_is_recognised_through_the_context() {
        let closed = anyhow::Error::from(std::io::Error::from(std::io::ErrorKind::BrokenPipe))
            .context("writing the export");
        assert!(is_broken_pipe(&closed));
        assert_eq!(
            quiet_on_closed_pipe(Err(closed)).unwrap(),
            ExitCode::SUCCESS
        );
        let other = anyhow::anyhow!("cannot read drive.mcap");
        assert!(!is_broken_pipe(&other));
        assert!(quiet_on_closed_pipe(Err(other)).is_err());
    }
}
