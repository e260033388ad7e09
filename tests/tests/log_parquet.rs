//! Logs at fleet scale: two simulated runs exported with `dima log export --format parquet`
//! read back as one table by an independent engine (DuckDB, from Python), one group per run
//! with as many rows as `dima log info` counts cycles and the CSV export has rows.

use std::path::{Path, PathBuf};
use std::process::Command as Process;

use clap::Parser;
use dima_e2e::{run_app, ONE_AT_A_TIME};
use dima_groundlink::Command;
use dima_sim::runner::{run_simulation, SimOptions, StatusMode};
use dima_sim::scenario::{pct, send, Scenario};
use dima_tools::logtools::export::{self, Channel, Format};
use dima_tools::logtools::read::LoggedRun;
use dima_tools::logtools::{info, log, parquet, LogArgs};

/// `dima log ...` as the command line gives it.
#[derive(Debug, Parser)]
struct Cli {
    #[command(flatten)]
    log: LogArgs,
}

/// Runs `dima log ARGS...`; the error as `dima` prints it.
fn dima_log(args: &[&str]) -> Result<std::process::ExitCode, String> {
    let cli = Cli::try_parse_from(std::iter::once("dima-log").chain(args.iter().copied()))
        .map_err(|e| e.to_string())?;
    log(cli.log).map_err(|e| format!("{e:#}"))
}

/// A short drive of `seconds`: revive, manual throttle, kill. Returns the log.
fn drive(dir: &Path, name: &'static str, seconds: f64) -> PathBuf {
    let mut s = Scenario::custom(name, seconds);
    s.script.push(send(0.3, Command::Revive));
    s.script.push(send(0.6, Command::Throttle(pct(55))));
    s.script.push(send(seconds - 0.5, Command::Kill));
    let mut o = SimOptions::new(s);
    o.run_dir = dir.join(name).join("dev");
    o.log_dir = dir.join(name).join("logs");
    o.status = StatusMode::Quiet;
    let r = run_simulation(&o, run_app).expect("the simulation runs");
    r.app.log_path.clone().expect("a log")
}

/// The cycle count `dima log info` reports.
fn info_cycles(run: &LoggedRun) -> u64 {
    let report = info::report(run);
    let (before, _) = report
        .split_once(" cycles")
        .unwrap_or_else(|| panic!("no cycle count in {report}"));
    before.rsplit(' ').next().unwrap().parse().unwrap()
}

fn path_str(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 temporary path")
}

#[test]
fn two_runs_exported_to_parquet_read_as_one_table_in_duckdb() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = dima_e2e::temp_dir("log-parquet");
    let out = dir.join("parquet");
    let other_channels = dir.join("other-channels");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::create_dir_all(&other_channels).unwrap();

    // Two runs of different lengths (log names are UTC seconds: the second starts later).
    let logs = [drive(&dir, "first", 2.5), drive(&dir, "second", 3.5)];
    let mut expected = Vec::new();
    for log_file in &logs {
        let id = parquet::run_id(log_file);
        let run = LoggedRun::read(log_file).unwrap();
        assert!(run.warnings.is_empty(), "{:?}", run.warnings);
        let cycles = info_cycles(&run);
        assert!(cycles > 100, "{cycles} cycles");
        let rows = export::rows(&run, Channel::Cycle, 0.0, f64::INFINITY);
        let mut csv = Vec::new();
        export::write(&rows, Format::Csv, &mut csv).unwrap();
        let csv_rows = String::from_utf8(csv).unwrap().lines().count() as u64 - 1;
        let last_cycle = run.cycles.last().unwrap().msg.cycle;

        let target = out.join(format!("{id}.parquet"));
        dima_log(&[
            "export",
            path_str(log_file),
            "--format",
            "parquet",
            "-o",
            path_str(&target),
        ])
        .unwrap();
        assert_eq!(&std::fs::read(&target).unwrap()[..4], b"PAR1");
        // The other channels write too (every column they have is in the schema).
        for channel in ["gnss", "state"] {
            let target = other_channels.join(format!("{id}-{channel}.parquet"));
            dima_log(&[
                "export",
                path_str(log_file),
                "--format",
                "parquet",
                "--channel",
                channel,
                "-o",
                path_str(&target),
            ])
            .unwrap();
        }
        expected.push((id, cycles, csv_rows, last_cycle));
    }
    assert_ne!(expected[0].0, expected[1].0, "two runs, two ids");
    expected.sort();

    // Parquet is binary: without -o, a clear error.
    let e = dima_log(&["export", path_str(&logs[0]), "--format", "parquet"]).unwrap_err();
    assert!(e.contains("-o FILE.parquet"), "{e}");

    // An independent engine reads both files as one table.
    let python = std::env::var("DIMA_PYTHON").unwrap_or_else(|_| "python3".into());
    let has_duckdb = Process::new(&python)
        .args(["-c", "import duckdb"])
        .status()
        .is_ok_and(|s| s.success());
    if !has_duckdb {
        assert!(
            std::env::var_os("CI").is_none(),
            "python duckdb missing ({python}); .ci/run installs it"
        );
        eprintln!("skipping the DuckDB check: no `duckdb` module for {python}");
        let _ = std::fs::remove_dir_all(&dir);
        return;
    }
    let query = format!(
        "SELECT run, count(*), max(cycle), \
         typeof(any_value(cycle)), typeof(any_value(accel_z_m_s2)), typeof(any_value(mode)) \
         FROM '{}/*.parquet' GROUP BY run ORDER BY run",
        path_str(&out)
    );
    let script = "import sys, duckdb\n\
                  for row in duckdb.sql(sys.argv[1]).fetchall():\n    \
                  print(' '.join(str(v) for v in row))";
    let result = Process::new(&python)
        .args(["-c", script, &query])
        .output()
        .unwrap();
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let text = String::from_utf8(result.stdout).unwrap();
    let groups: Vec<Vec<&str>> = text.lines().map(|l| l.split(' ').collect()).collect();
    assert_eq!(groups.len(), 2, "one group per run: {text}");
    for (group, (id, cycles, csv_rows, last_cycle)) in groups.iter().zip(&expected) {
        assert_eq!(group[0], id, "{text}");
        let count: u64 = group[1].parse().unwrap();
        assert_eq!(count, *cycles, "rows of {id} vs dima log info");
        assert_eq!(count, *csv_rows, "rows of {id} vs the CSV export");
        assert_eq!(group[2], last_cycle.to_string(), "{text}");
        assert_eq!(group[3..], ["BIGINT", "DOUBLE", "VARCHAR"], "{text}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
