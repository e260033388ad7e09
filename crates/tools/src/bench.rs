//! `dima bench cycle LOG.mcap`: a recorded log through the cycle's compute path, in ns per
//! cycle (and, under callgrind, in instructions: `bench/cycle-instructions.sh`).
//!
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

use dima_core::step::{CycleInputs, SensorInput};
use dima_core::{Command, Core, CoreState, ReceivedCommand};

use crate::logtools::read::LoggedRun;
use crate::logtools::replay::{recorded_cycles, RecordedCycle};
use dima_robot::app::record::CycleRecord;
use dima_robot::app::rt_loop::{HISTOGRAM_US, MAX_COMMANDS_PER_CYCLE};
use dima_robot::devices::servo::encode_targets;
use dima_robot::metrics::LatencyHistogram;
use dima_robot::rt::{monotonic_ns, PeriodicClock, RtSettings, RtSetup, Tick};

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
    /// Two or more cyclictest-format histograms side by side in one PNG (e.g. dima and
    /// cyclictest from `bench/wakeup-vs-cyclictest.sh`).
    PlotHistograms {
        /// Histogram files (`-h` format); the legend shows their file names.
        #[arg(required = true, num_args = 2..)]
        files: Vec<PathBuf>,
        /// Output PNG.
        #[arg(short, long, value_name = "OUT.png")]
        output: PathBuf,
        /// Title.
        #[arg(long, default_value = "wake-up latency")]
        title: String,
    },
    /// Compute cost per cycle: a recorded log through the cycle's compute path (decode with
    /// CRC, pairing, safety, controller, Maestro encode, log record), in ns per cycle.
    Cycle {
        /// The MCAP log to replay.
        log: PathBuf,
        /// Passes over the log.
        #[arg(long, default_value_t = 20)]
        repeat: u32,
    },
}

/// The compute path of every cycle of `cycles`, as the loop runs it between acquiring and
/// writing: the packet decoded through its CRC, the control step, the Maestro packets encoded
/// and the logger's record built. Returns a value that depends on every output (so nothing is
/// optimised away). `#[inline(never)]`: `bench/cycle-instructions.sh` counts the instructions
/// inside it with callgrind.
#[inline(never)]
pub fn measured_cycles(
    core: &mut Core,
    state: &mut CoreState,
    cycles: &[RecordedCycle],
    channels: [u8; 3],
) -> u64 {
    let mut sink = 0u64;
    for c in cycles {
        let sensor = c.sensor_input().unwrap_or(SensorInput::DeviceError);
        let out = core.step(
            state,
            &CycleInputs {
                missed_periods: c.missed_periods,
                commands: &c.commands,
                sensor,
                stale_packets: c.stale_packets,
            },
            c.wake_ns,
        );
        if let Ok(frame) = encode_targets(&channels, &out.targets.quarter_us()) {
            sink = sink.wrapping_add(frame.as_bytes().len() as u64);
        }
        let mut commands = [ReceivedCommand::new(Command::Heartbeat, 0); MAX_COMMANDS_PER_CYCLE];
        let n = c.commands.len().min(MAX_COMMANDS_PER_CYCLE);
        commands[..n].copy_from_slice(&c.commands[..n]);
        let record = CycleRecord {
            cycle: c.cycle,
            tick: Tick {
                deadline_ns: c.wake_ns,
                wake_ns: c.wake_ns,
                latency_ns: 0,
                missed: c.missed_periods,
            },
            t_request_ns: 0,
            t_packet_ns: 0,
            t_compute_ns: c.wake_ns,
            t_write_ns: 0,
            raw: match sensor {
                SensorInput::Packet { raw, .. } => Some(raw),
                _ => None,
            },
            info: None,
            outputs: out,
            setpoints: state.safety.setpoints,
            commands,
            n_commands: n as u8,
            stale_passed: c.stale_packets,
            counters: state.counters,
            link: Default::default(),
            events: 0,
        };
        sink = sink.wrapping_add(std::hint::black_box(&record).outputs.targets.pulse_us[0] as u64);
    }
    sink
}

/// `dima bench cycle`: ns per cycle over `repeat` passes of the log.
pub fn cycle_cost(log: &std::path::Path, repeat: u32) -> anyhow::Result<(usize, f64)> {
    let run = LoggedRun::read(log)?;
    run.warn(log);
    let config = run.config.clone().context("the log has no configuration")?;
    let (cycles, realtime_fault) = recorded_cycles(&run)?;
    // A fresh core (and its controllers) per pass, built before the clock starts.
    let passes = (0..repeat.max(1))
        .map(|_| Core::new(&config))
        .collect::<Result<Vec<_>, _>>()?;
    let channels = Core::new(&config)?.outputs().channel_numbers();
    let mut sink = 0u64;
    let start = std::time::Instant::now();
    for mut core in passes {
        let mut state = CoreState {
            realtime_fault,
            ..CoreState::new()
        };
        sink = sink.wrapping_add(measured_cycles(&mut core, &mut state, &cycles, channels));
    }
    let elapsed = start.elapsed();
    std::hint::black_box(sink);
    let n = cycles.len() * repeat.max(1) as usize;
    Ok((n, elapsed.as_nanos() as f64 / n.max(1) as f64))
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

/// Runs `dima bench ...`. A closed stdout (`dima bench wakeup | head`) ends it with success
/// and nothing on stderr.
pub fn bench(args: BenchArgs) -> anyhow::Result<()> {
    match run_bench(args) {
        Err(e) if crate::logtools::is_broken_pipe(&e) => Ok(()),
        other => other,
    }
}

/// Writes `text` to stdout and flushes it.
fn write_stdout(text: &str) -> std::io::Result<()> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()
}

fn run_bench(args: BenchArgs) -> anyhow::Result<()> {
    match args.command {
        BenchCommand::PlotHistograms {
            files,
            output,
            title,
        } => {
            let mut series = Vec::new();
            for f in &files {
                let text = std::fs::read_to_string(f)
                    .with_context(|| format!("cannot read {}", f.display()))?;
                let name = f
                    .file_name()
                    .map_or(String::new(), |n| n.to_string_lossy().into_owned());
                series.push((name, crate::logtools::plot::parse_histogram(&text)));
            }
            crate::logtools::plot::histograms(&series, &title, &output, (1280, 720))?;
            eprintln!("wrote {}", output.display());
            Ok(())
        }
        BenchCommand::Cycle { log, repeat } => {
            let (n, ns) = cycle_cost(&log, repeat)?;
            write_stdout(&format!("{n} cycles, {ns:.0} ns per cycle\n"))?;
            Ok(())
        }
        BenchCommand::Wakeup(w) => {
            let result = wakeup(&w)?;
            let text = result.histogram.cyclictest_format();
            match &w.histfile {
                Some(path) => std::fs::write(path, &text)
                    .with_context(|| format!("writing {}", path.display()))?,
                None => write_stdout(&text)?,
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
        // 200 deadlines before the end: each one is either a wake-up in the histogram or a
        // missed period, whatever else the machine is doing (a late last wake-up may also count
        // periods past the end as missed).
        let (woken, missed) = (r.histogram.count(), r.missed);
        assert!(woken <= 200, "{woken} wake-ups recorded for 200 periods");
        assert!(
            woken + missed >= 200,
            "{woken} wake-ups and {missed} missed periods account for fewer than 200 periods"
        );
        let text = r.histogram.cyclictest_format();
        assert!(text.starts_with("# Histogram\n000000 "), "{}", &text[..40]);
        assert!(text.contains("# Total: "));
        assert!(text.contains("# Histogram Overflows: "));
    }
}
