//! The logger thread: drains the loop's record ring and writes an MCAP file.
//!
//! Channels (topics):
//! - `/sensor/raw`: every valid 132-byte packet exactly as received (message encoding
//!   `dima-sensor-v1`, no schema) for replay through the sensor-board decoder;
//! - `/dima/cycle`: one JSON message per cycle (or every n-th) with timings, decoded values,
//!   controller output, servo targets, mode and counters, under a JSON schema Foxglove plots;
//! - `/dima/state`: a JSON message on every mode change and device event;
//! - `/sensor/info`: sensor-board info frames (calibration, firmware, health) as JSON;
//! - metadata `dima` (version, configuration), `rt_setup` (the RT setup report), `summary`
//!   (metrics at exit), and the wake-up latency histogram as an attachment.
//!
//! Chunks are zstd-compressed and flushed at least every `flush_interval_ms`, so a crash loses
//! at most that much. The thread also prints state transitions and device events: the loop
//! itself never prints.
//!
//! A write that fails (a full disk: ENOSPC, or any I/O error) stops logging with one error
//! message naming the file and the error; the robot keeps running, and the logger keeps
//! draining the ring (counting what it cannot log). Every second it tries again: it ends the
//! failed file at its last complete chunk (so it stays a valid MCAP file) and resumes in a new
//! one beside it (`NAME-1.mcap`, `NAME-2.mcap`, ...) that starts with the `dima` metadata and
//! a `log_resumed` note.
//!
//! A run is also split by duration (`max_file_duration_s`, as rosbag2's `max_bag_duration`):
//! when the current file is older than that, the logger finishes it (summary and index
//! written: a complete, indexed MCAP file) and continues in the next file of the same
//! numbering, which starts with the same metadata and a `log_continued` note. The MCAP writer
//! keeps one chunk index per flushed chunk in memory until its file is finished, so this is
//! what keeps a long run's memory flat. Every record goes to exactly one file: the old file's
//! last chunk is flushed before the next file takes the following records.
//!
//! The writing itself (files, rotation, resume, disk-full handling) is `dima_log`'s
//! [`RunWriter`]; this module is the thread that drains the ring into it. For the simulation,
//! [`LogFaults`] stalls the thread (it stops draining the ring) or makes every write fail with
//! ENOSPC during time windows; the fault sits under the MCAP writer, so the code above it is
//! the production path.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

use dima_core::Mode;
pub use dima_log::naming::log_file_name;
use dima_log::schema;
pub use dima_log::writer::{
    McapLog, RunWriter, CHUNK_BYTES, METADATA_LOG_CONTINUED, METADATA_LOG_RESUMED,
};

use crate::app::record::{events, CycleRecord};
use crate::live::{LiveTap, LiveView};
use crate::log_messages::{cycle_message, info_message, state_message};
use crate::rt::{monotonic_ns, RtSetupReport};

/// A time window, ns from the logger's start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NsWindow {
    /// Start, ns.
    pub start_ns: u64,
    /// Length, ns.
    pub duration_ns: u64,
}

impl NsWindow {
    /// Whether `t_ns` falls inside.
    pub fn contains(&self, t_ns: u64) -> bool {
        t_ns >= self.start_ns && t_ns - self.start_ns < self.duration_ns
    }
}

/// Faults of the log disk, for the simulation (`log:stall`, `log:full`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LogFaults {
    /// The logger thread stops draining the ring.
    pub stalls: Vec<NsWindow>,
    /// Every write fails as on a full disk (ENOSPC).
    pub full: Vec<NsWindow>,
}

/// Writing the robot's records to a log file.
pub trait CycleLog {
    /// Writes one cycle: raw packet, info frame, state change, and the decoded cycle (if
    /// `with_decoded`).
    ///
    /// # Errors
    /// A write failed.
    fn record(&mut self, r: &CycleRecord, with_decoded: bool) -> anyhow::Result<()>;

    /// The RT setup report as metadata.
    ///
    /// # Errors
    /// The write failed.
    fn rt_setup(&mut self, report: &RtSetupReport) -> anyhow::Result<()>;
}

impl CycleLog for McapLog {
    fn record(&mut self, r: &CycleRecord, with_decoded: bool) -> anyhow::Result<()> {
        let t = r.tick.wake_ns;
        if let Some(raw) = &r.raw {
            self.message_on(&schema::SENSOR_RAW, t, raw.as_ref())?;
        }
        if let Some(info) = &r.info {
            let json = serde_json::to_vec(&info_message(info))?;
            self.message_on(&schema::SENSOR_INFO, t, &json)?;
        }
        if r.events != 0 {
            self.message_on(&schema::STATE, t, &serde_json::to_vec(&state_message(r))?)?;
        }
        if with_decoded {
            self.message_on(&schema::CYCLE, t, &serde_json::to_vec(&cycle_message(r))?)?;
        }
        Ok(())
    }

    fn rt_setup(&mut self, report: &RtSetupReport) -> anyhow::Result<()> {
        self.metadata(
            schema::METADATA_RT_SETUP,
            &[
                ("report", report.to_string()),
                ("json", serde_json::to_string(report)?),
            ],
        )
    }
}

/// What the logger thread did.
pub struct LoggerOutcome {
    /// The log, still open, for the summary and histogram; `None` when logging is off or the
    /// file failed.
    pub log: Option<McapLog>,
    /// Records written.
    pub records: u64,
}

/// Logger thread settings.
pub struct LoggerSettings {
    /// Chunk flush interval.
    pub flush_interval: Duration,
    /// Decoded values every n-th cycle.
    pub decoded_every: u64,
    /// Metadata records a resumed file starts with (the `dima` record: version and
    /// configuration).
    pub header: Vec<(String, Vec<(&'static str, String)>)>,
    /// Longest time one file covers before the run continues in the next file (`None`:
    /// never split).
    pub max_file_duration: Option<Duration>,
    /// Injected disk faults (the simulation's; none on the robot).
    pub faults: LogFaults,
    /// The live view (`[foxglove] listen`): served every channel and message the log writes,
    /// and each new GNSS fix.
    pub live: Option<Arc<LiveView>>,
}

impl Default for LoggerSettings {
    fn default() -> Self {
        LoggerSettings {
            flush_interval: Duration::from_secs(1),
            decoded_every: 1,
            header: Vec::new(),
            max_file_duration: Some(Duration::from_secs(600)),
            faults: LogFaults::default(),
            live: None,
        }
    }
}

/// Prints what a record says happened (mode changes, refusals, device events).
fn report_events(r: &CycleRecord, last_mode: &mut Mode) {
    let out = &r.outputs;
    if out.mode != *last_mode {
        match out.cause {
            Some(cause) if out.mode == Mode::Failsafe => tracing::warn!(
                "mode {last_mode} -> FAILSAFE ({cause:?}) at cycle {}",
                r.cycle
            ),
            _ => tracing::info!("mode {last_mode} -> {} at cycle {}", out.mode, r.cycle),
        }
        *last_mode = out.mode;
    }
    if let Some(why) = out.refused {
        tracing::warn!("revive refused ({why:?}) at cycle {}", r.cycle);
    }
    if out.setpoints_rejected > 0 {
        tracing::warn!(
            "setpoint rejected (speed allowed 0..=control.max_speed_mm_s mm/s, heading \
             0..36000000 x 1e-5 deg) at cycle {}",
            r.cycle
        );
    }
    if r.events & events::SENSOR_LOST != 0 {
        tracing::warn!("sensor board: I/O error in cycle {}, reopening", r.cycle);
    }
    if r.events & events::SERVO_LOST != 0 {
        tracing::warn!("Maestro: write failed in cycle {}, reopening", r.cycle);
    }
}

/// Spawns the logger thread (normal priority). It drains `records` until `stop` is set and
/// the ring is empty, and writes `rt_setup` reports as they arrive.
pub fn spawn_logger(
    log: Option<McapLog>,
    records: rtrb::Consumer<CycleRecord>,
    rt_reports: mpsc::Receiver<RtSetupReport>,
    settings: LoggerSettings,
    stop: Arc<AtomicBool>,
    observer: Option<crate::app::run::Observer>,
) -> std::io::Result<std::thread::JoinHandle<LoggerOutcome>> {
    let mut run = RunWriter::new(log, settings.header, settings.max_file_duration);
    if let Some(live) = &settings.live {
        run.set_tap(Box::new(LiveTap(Arc::clone(live))));
    }
    let worker = Logger {
        run,
        live: settings.live,
        records,
        rt_reports,
        faults: settings.faults,
        flush_interval: settings.flush_interval,
        decoded_every: settings.decoded_every.max(1),
        stop,
        observer,
        last_mode: Mode::Killed,
        stalled: false,
        written: 0,
    };
    std::thread::Builder::new()
        .name("dima-logger".into())
        .spawn(move || worker.run())
}

/// The logger thread's state: the run being written and the ring it drains.
struct Logger {
    run: RunWriter,
    /// The live view, for the GNSS fixes (the log's messages reach it through the tap).
    live: Option<Arc<LiveView>>,
    records: rtrb::Consumer<CycleRecord>,
    rt_reports: mpsc::Receiver<RtSetupReport>,
    faults: LogFaults,
    flush_interval: Duration,
    decoded_every: u64,
    stop: Arc<AtomicBool>,
    observer: Option<crate::app::run::Observer>,
    last_mode: Mode,
    /// The simulated stall is on.
    stalled: bool,
    /// Records taken from the ring.
    written: u64,
}

impl Logger {
    /// Drains the ring until stopped and the ring is empty.
    fn run(mut self) -> LoggerOutcome {
        let started_ns = monotonic_ns();
        let mut last_flush = Instant::now();
        loop {
            let stopping = self.stop.load(Ordering::Acquire);
            let t_ns = monotonic_ns().saturating_sub(started_ns);
            if self.stalls(t_ns, stopping) {
                std::thread::sleep(Duration::from_millis(10));
                continue;
            }
            self.write_rt_report();
            self.run.retry(Instant::now());
            self.run.split(Instant::now());
            let n = self.drain();
            if last_flush.elapsed() >= self.flush_interval {
                self.run.flush();
                last_flush = Instant::now();
            }
            if stopping && n == 0 && self.records.is_empty() {
                break;
            }
            if n == 0 {
                std::thread::sleep(Duration::from_millis(10));
            }
        }
        LoggerOutcome {
            records: self.written,
            log: self.run.finish(),
        }
    }

    /// Applies the injected faults at `t_ns` from the start: the full disk, and whether the
    /// thread stalls now (never while stopping).
    fn stalls(&mut self, t_ns: u64, stopping: bool) -> bool {
        let full = self.faults.full.iter().any(|w| w.contains(t_ns));
        self.run.set_disk_full(full);
        let stall = self.faults.stalls.iter().any(|w| w.contains(t_ns)) && !stopping;
        if stall && !self.stalled {
            tracing::warn!("log: the logger stalls (simulated slow disk)");
        } else if !stall && self.stalled {
            tracing::warn!("log: the logger drains again");
        }
        self.stalled = stall;
        stall
    }

    /// Writes a realtime setup report that arrived.
    fn write_rt_report(&mut self) {
        if let Ok(report) = self.rt_reports.try_recv() {
            self.run.write(|l| l.rt_setup(&report));
        }
    }

    /// Sends the record's new GNSS fix to the live view, at the log time the log gives it.
    fn serve_location(&mut self, r: &CycleRecord) {
        if let (Some(live), Some(log)) = (&self.live, self.run.log_mut()) {
            live.cycle(r, log.log_time(r.tick.wake_ns));
        }
    }

    /// Writes every record in the ring; returns how many.
    fn drain(&mut self) -> u64 {
        let mut n = 0;
        while let Ok(r) = self.records.pop() {
            report_events(&r, &mut self.last_mode);
            self.serve_location(&r);
            if let Some(observe) = self.observer.as_mut() {
                observe(&r);
            }
            let decoded = r.cycle % self.decoded_every == 0 || r.events != 0;
            self.run.write_record(|l| l.record(&r, decoded));
            self.written += 1;
            n += 1;
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};

    use dima_log::naming::numbered_name;
    use dima_log::reader;

    use dima_core::config::Config;
    use dima_core::step::{CycleInputs, SensorInput};
    use dima_core::{Command, Core, CoreState, ReceivedCommand};

    use crate::app::rt_loop::MAX_COMMANDS_PER_CYCLE;
    use crate::rt::Tick;

    /// A record of cycle `cycle` at `now_ns`, from the real control step (no sensor).
    fn record(core: &mut Core, state: &mut CoreState, cycle: u64) -> CycleRecord {
        let now_ns = monotonic_ns();
        let outputs = core.step(
            state,
            &CycleInputs {
                missed_periods: 0,
                commands: &[],
                sensor: SensorInput::DeviceError,
                stale_packets: 0,
            },
            now_ns,
        );
        CycleRecord {
            cycle,
            tick: Tick {
                deadline_ns: now_ns,
                wake_ns: now_ns,
                latency_ns: 0,
                missed: 0,
            },
            t_request_ns: 0,
            t_packet_ns: 0,
            t_compute_ns: now_ns,
            t_write_ns: 0,
            raw: None,
            info: None,
            outputs,
            setpoints: state.safety.setpoints,
            commands: [ReceivedCommand::new(Command::Heartbeat, 0); MAX_COMMANDS_PER_CYCLE],
            n_commands: 0,
            stale_passed: 0,
            counters: state.counters,
            link: Default::default(),
            events: 0,
        }
    }

    /// A fresh directory for one test.
    fn test_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("dima-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Runs the logger on `dir/run.mcap`, files of at most `max_file`, flushing every 20 ms,
    /// over `n` records 2 ms apart; `during(i)` runs before record `i`. Returns the run's
    /// files in order (`run.mcap`, `run-1.mcap`, ...).
    fn log_run(
        dir: &Path,
        max_file: Duration,
        n: u64,
        mut during: impl FnMut(u64),
    ) -> Vec<PathBuf> {
        log_run_with(dir, Some(max_file), LogFaults::default(), n, &mut during)
    }

    /// [`log_run`] with injected faults, and no split when `max_file` is `None`.
    fn log_run_with(
        dir: &Path,
        max_file: Option<Duration>,
        faults: LogFaults,
        n: u64,
        during: &mut dyn FnMut(u64),
    ) -> Vec<PathBuf> {
        let first = dir.join("run.mcap");
        let mut log = McapLog::create_file(&first).unwrap();
        let header = vec![("dima".to_owned(), vec![("version", "test".to_owned())])];
        for (name, pairs) in &header {
            log.metadata(name, pairs).unwrap();
        }
        let (mut tx, rx) = rtrb::RingBuffer::new(64);
        let (_reports, report_rx) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let logger = spawn_logger(
            Some(log),
            rx,
            report_rx,
            LoggerSettings {
                flush_interval: Duration::from_millis(20),
                decoded_every: 1,
                header,
                max_file_duration: max_file,
                faults,
                live: None,
            },
            Arc::clone(&stop),
            None,
        )
        .unwrap();
        let mut core = Core::new(&Config::default()).unwrap();
        let mut state = CoreState::new();
        for i in 0..n {
            during(i);
            let mut r = record(&mut core, &mut state, i);
            while let Err(rtrb::PushError::Full(back)) = tx.push(r) {
                r = back;
                std::thread::sleep(Duration::from_millis(1));
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        stop.store(true, Ordering::Release);
        let outcome = logger.join().unwrap();
        assert_eq!(outcome.records, n);
        let last = outcome.log.unwrap().finish().unwrap();
        let mut files = vec![first.clone()];
        while numbered_name(&first, files.len() as u32).is_file() {
            files.push(numbered_name(&first, files.len() as u32));
        }
        assert_eq!(
            files.last(),
            Some(&last),
            "the last file is the one still open"
        );
        files
    }

    /// Metadata records in file order: name and pairs.
    type MetadataRecords = Vec<(String, BTreeMap<String, String>)>;

    /// The `/dima/cycle` numbers and the metadata records of a complete, indexed MCAP file,
    /// and its number of chunks.
    fn read_file(path: &Path) -> (Vec<u64>, MetadataRecords, usize) {
        let bytes = std::fs::read(path).unwrap();
        let summary = reader::summary(&bytes)
            .unwrap()
            .unwrap_or_else(|| panic!("{}: no summary", path.display()));
        let cycles = cycle_numbers(&bytes);
        assert_eq!(
            summary.message_count,
            cycles.len() as u64,
            "{}",
            path.display()
        );
        let metadata = reader::metadata(&bytes)
            .0
            .into_iter()
            .map(|m| (m.name, m.pairs))
            .collect();
        (cycles, metadata, summary.chunk_count)
    }

    /// The `/dima/cycle` numbers of a file, in order.
    fn cycle_numbers(bytes: &[u8]) -> Vec<u64> {
        reader::messages(bytes)
            .unwrap()
            .into_iter()
            .filter(|m| m.channel.topic == "/dima/cycle")
            .map(|m| {
                let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
                v["cycle"].as_u64().unwrap()
            })
            .collect()
    }

    #[test]
    fn a_run_split_by_duration_loses_and_repeats_no_record() {
        let dir = test_dir("log-split");
        let n = 700;
        let files = log_run(&dir, Duration::from_millis(300), n, |_| {});
        // About 1.5 s or more of records in files of 0.3 s.
        assert!(files.len() >= 4, "{files:?}");
        let mut all = Vec::new();
        let mut total_chunks = 0;
        for (k, path) in files.iter().enumerate() {
            let (cycles, metadata, chunks) = read_file(path);
            assert!(!cycles.is_empty(), "{}", path.display());
            all.extend(cycles);
            total_chunks += chunks;
            // What the writer holds until a file is finished stays bounded: a file's chunks
            // (one per 20 ms flush, over 0.3 s and the time a loaded machine adds), not the
            // run's.
            assert!(chunks <= 40, "{}: {chunks} chunks", path.display());
            assert_eq!(metadata[0].0, "dima", "{}", path.display());
            if k > 0 {
                assert_eq!(metadata[1].0, METADATA_LOG_CONTINUED);
                assert_eq!(
                    metadata[1].1.get("previous_file"),
                    Some(&files[k - 1].display().to_string())
                );
            }
        }
        assert!(total_chunks > 40, "{total_chunks} chunks in the run");
        assert_eq!(all, (0..n).collect::<Vec<_>>(), "records lost or repeated");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_full_disk_counts_every_record_it_loses() {
        let dir = test_dir("log-full");
        // About 2.5 s of records: the logger tries again a second after the failure.
        let n = 1_100;
        // Full from 0.4 s for 0.3 s: the current chunk (up to 20 ms of records) is cut with
        // the file, the records after it are not written until logging resumes.
        let full = NsWindow {
            start_ns: 400_000_000,
            duration_ns: 300_000_000,
        };
        let faults = LogFaults {
            stalls: Vec::new(),
            full: vec![full],
        };
        let files = log_run_with(&dir, None, faults, n, &mut |_| {});
        assert_eq!(files.len(), 2, "{files:?}");
        let mut logged = Vec::new();
        let mut not_logged = None;
        for path in &files {
            let bytes = std::fs::read(path).unwrap();
            logged.extend(cycle_numbers(&bytes));
            for m in reader::metadata(&bytes).0 {
                if m.name == METADATA_LOG_RESUMED {
                    not_logged = m.pairs["records_not_logged"].parse::<u64>().ok();
                }
            }
        }
        let not_logged = not_logged.expect("a log_resumed record");
        assert!(logged.windows(2).all(|w| w[0] < w[1]), "in order, once");
        assert!(not_logged > 0);
        assert_eq!(
            logged.len() as u64 + not_logged,
            n,
            "{} logged + {not_logged} counted as not logged",
            logged.len()
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_split_that_cannot_open_the_next_file_goes_on_in_the_current_one() {
        let dir = test_dir("log-split-blocked");
        // A directory where the next file should go: it cannot be created until it is gone.
        let blocker = dir.join("run-1.mcap");
        std::fs::create_dir(&blocker).unwrap();
        let files = log_run(&dir, Duration::from_millis(200), 600, |i| {
            if i == 150 {
                std::fs::remove_dir(&blocker).unwrap();
            }
        });
        assert!(files.len() >= 2, "{files:?}");
        let mut all = Vec::new();
        for (k, path) in files.iter().enumerate() {
            let (cycles, _, _) = read_file(path);
            if k == 0 {
                // The first file went on past 0.2 s until the next one could be opened.
                assert!(cycles.len() > 150, "{} in the first file", cycles.len());
            }
            all.extend(cycles);
        }
        assert_eq!(
            all,
            (0..600).collect::<Vec<_>>(),
            "records lost or repeated"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
