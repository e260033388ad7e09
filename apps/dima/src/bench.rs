//! `dima bench wakeup`: the realtime loop's skeleton (the same thread setup, absolute-deadline
//! clock and latency histogram as `dima run`, with no devices) timed against the operating
//! system, in cyclictest's `-h` histogram format so the two can be compared side by side.
//!
//! By default the first wake-up is at the next whole second of CLOCK_MONOTONIC plus half a
//! period: run beside `cyclictest -p P -a C -i N -m -q -h 5000 --secaligned 0` on the same CPU,
//! the two threads take turns instead of waking at the same instant.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use clap::{Args, Subcommand};

use crate::app::rt_loop::HISTOGRAM_US;
use crate::metrics::LatencyHistogram;
use crate::rt::{monotonic_ns, PeriodicClock, RtSettings, RtSetup};

/// `dima bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// What to measure.
    #[command(subcommand)]
    pub command: BenchCommand,
}

/// `dima bench` subcommands.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Wake-up latency of the loop skeleton, in cyclictest's histogram format.
    Wakeup(WakeupArgs),
}

/// `dima bench wakeup`.
#[derive(Debug, Clone, Args)]
pub struct WakeupArgs {
    /// Period, µs (cyclictest's `-i`).
    #[arg(long, default_value_t = 4_000, value_name = "N")]
    pub interval_us: u64,
    /// How long, s.
    #[arg(long, default_value_t = 10.0, value_name = "S")]
    pub duration: f64,
    /// SCHED_FIFO priority (cyclictest's `-p`); 0 keeps SCHED_OTHER.
    #[arg(long, default_value_t = 80, value_name = "P")]
    pub priority: u8,
    /// CPU to pin the thread to (cyclictest's `-a`).
    #[arg(long, default_value_t = 0, value_name = "C")]
    pub cpu: usize,
    /// Write the histogram here (default: stdout).
    #[arg(long, value_name = "F")]
    pub histfile: Option<PathBuf>,
    /// Offset of the first wake-up after the next whole second, µs (default: half a period).
    #[arg(long, value_name = "US")]
    pub offset_us: Option<u64>,
}

/// What a wake-up run measured.
#[derive(Debug, Clone)]
pub struct WakeupResult {
    /// Latency histogram, 1 µs buckets.
    pub histogram: LatencyHistogram,
    /// Periods missed.
    pub missed: u64,
}

/// Runs the skeleton on its own thread, set up as `dima run` sets up the loop.
pub fn wakeup(args: &WakeupArgs) -> anyhow::Result<WakeupResult> {
    anyhow::ensure!(
        (50..=1_000_000).contains(&args.interval_us),
        "--interval-us {}: expected 50..=1000000",
        args.interval_us
    );
    anyhow::ensure!(
        args.duration > 0.0 && args.duration <= 86_400.0,
        "--duration {}: expected (0, 86400] seconds",
        args.duration
    );
    let settings = RtSettings {
        priority: args.priority,
        cpus: vec![args.cpu],
        lock_memory: true,
        prefault_stack_kib: 256,
        cpu_dma_latency: true,
        required: false,
    };
    let period_ns = args.interval_us * 1_000;
    let offset_ns = args.offset_us.map_or(period_ns / 2, |us| us * 1_000);
    let duration = Duration::from_secs_f64(args.duration);
    let handle = std::thread::Builder::new()
        .name("dima-bench".into())
        .stack_size(512 * 1024)
        .spawn(move || {
            let setup = RtSetup::apply(&settings);
            if let Some(failed) = setup.report.failures() {
                eprintln!("warning: realtime setup: {failed}");
            }
            let mut histogram = LatencyHistogram::new(HISTOGRAM_US);
            let next_second = (monotonic_ns() / 1_000_000_000 + 1) * 1_000_000_000;
            let first = next_second + offset_ns;
            let mut clock = PeriodicClock::new(period_ns, first - period_ns);
            let end = first + duration.as_nanos() as u64;
            loop {
                let tick = clock.wait();
                if tick.deadline_ns >= end {
                    break;
                }
                histogram.record(tick.latency_ns);
            }
            WakeupResult {
                histogram,
                missed: clock.missed_total(),
            }
        })
        .context("starting the benchmark thread")?;
    handle
        .join()
        .map_err(|_| anyhow::anyhow!("the benchmark thread panicked"))
}

/// Runs `dima bench ...`.
pub fn bench(args: BenchArgs) -> anyhow::Result<()> {
    match args.command {
        BenchCommand::Wakeup(w) => {
            let result = wakeup(&w)?;
            let text = result.histogram.cyclictest_format();
            match &w.histfile {
                Some(path) => std::fs::write(path, &text)
                    .with_context(|| format!("writing {}", path.display()))?,
                None => print!("{text}"),
            }
            let h = &result.histogram;
            eprintln!(
                "dima bench wakeup: {} wake-ups every {} µs on CPU {} at priority {}: min/avg/max \
                 {}/{}/{} µs, {} overflows, {} missed periods",
                h.count(),
                w.interval_us,
                w.cpu,
                w.priority,
                h.min_ns() / 1_000,
                h.avg_ns() / 1_000,
                h.max_ns() / 1_000,
                h.overflows(),
                result.missed
            );
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_short_run_wakes_at_the_period_and_writes_the_histogram() {
        let args = WakeupArgs {
            interval_us: 1_000,
            duration: 0.2,
            priority: 0,
            cpu: 0,
            histfile: None,
            offset_us: Some(0),
        };
        let r = wakeup(&args).unwrap();
        let n = r.histogram.count() + r.missed;
        assert!((190..=201).contains(&n), "{n} wake-ups for 200 periods");
        let text = r.histogram.cyclictest_format();
        assert!(text.starts_with("# Histogram\n000000 "), "{}", &text[..40]);
        assert!(text.contains("# Total: "));
        assert!(text.contains("# Histogram Overflows: "));
    }
}
