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
//! For the simulation, [`LogFaults`] stalls the thread (it stops draining the ring) or makes
//! every write fail with ENOSPC during time windows; the fault sits in the file wrapper
//! [`LogFile`], so the code above it is the production path.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::Context;
use dima_core::schema::{self, ChannelSpec};
use dima_core::Mode;

use crate::app::record::{events, CycleRecord};
use crate::live::LiveView;
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

/// The log file under the MCAP writer: the file itself, and an injected full disk for the
/// simulation (`None` on the robot, so every write goes straight to the file).
pub struct LogFile {
    file: File,
    full: Arc<AtomicBool>,
}

/// An injected full disk: ENOSPC while `full` is set.
fn check_disk(full: &AtomicBool) -> std::io::Result<()> {
    if full.load(Ordering::Relaxed) {
        Err(std::io::Error::from_raw_os_error(libc::ENOSPC))
    } else {
        Ok(())
    }
}

impl LogFile {
    fn check(&self) -> std::io::Result<()> {
        check_disk(&self.full)
    }
}

impl Write for LogFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.check()?;
        self.file.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.check()?;
        self.file.flush()
    }
}

impl Seek for LogFile {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.file.seek(pos)
    }
}

/// The MCAP file being written.
pub struct McapLog {
    writer: mcap::Writer<BufWriter<LogFile>>,
    /// Length of the file at the last successful flush: complete records only.
    flushed_len: u64,
    /// Cycle records written since the last successful flush: lost if the file has to be cut
    /// back to `flushed_len`.
    unflushed_records: u64,
    /// Set: writes fail as on a full disk (the simulation's `log:full`).
    disk_full: Arc<AtomicBool>,
    path: PathBuf,
    raw: u16,
    cycle: u16,
    state: u16,
    info: u16,
    sequence: u32,
    /// When the file was created (for the split by duration).
    opened: Instant,
    /// Added to CLOCK_MONOTONIC to get wall-clock ns for log times.
    epoch_offset_ns: i128,
    /// The live view: sent every channel and message written here.
    live: Option<Arc<LiveView>>,
}

/// `dima-YYYYMMDDTHHMMSSZ.mcap` for `now`.
pub fn log_file_name(now: SystemTime) -> String {
    let secs = now.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "dima-{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z.mcap",
        rem / 3_600,
        rem % 3_600 / 60,
        rem % 60
    )
}

impl McapLog {
    /// Creates `dir` if needed and a new timestamped file in it.
    pub fn create(dir: &Path) -> anyhow::Result<McapLog> {
        McapLog::create_live(dir, None)
    }

    /// As [`McapLog::create`], also serving the log's channels and messages on `live`; the
    /// files the run continues in serve them too.
    pub fn create_live(dir: &Path, live: Option<Arc<LiveView>>) -> anyhow::Result<McapLog> {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("log: cannot create directory {}", dir.display()))?;
        let path = dir.join(log_file_name(SystemTime::now()));
        McapLog::create_file_with(&path, Arc::new(AtomicBool::new(false)), live)
    }

    /// Creates the file at `path`.
    pub fn create_file(path: &Path) -> anyhow::Result<McapLog> {
        McapLog::create_file_with(path, Arc::new(AtomicBool::new(false)), None)
    }

    /// Creates the file at `path`, its writes failing with ENOSPC while `full` is set.
    fn create_file_with(
        path: &Path,
        full: Arc<AtomicBool>,
        live: Option<Arc<LiveView>>,
    ) -> anyhow::Result<McapLog> {
        check_disk(&full).with_context(|| format!("log: cannot create {}", path.display()))?;
        let file = LogFile {
            file: File::create(path)
                .with_context(|| format!("log: cannot create {} (writable?)", path.display()))?,
            full: Arc::clone(&full),
        };
        file.check()
            .with_context(|| format!("log: cannot write {}", path.display()))?;
        let mut writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            // Compressed on the logger thread itself. `mcap` would otherwise start a zstd
            // worker per CPU with buffers of about 40 MB, whose pages the process touches
            // bit by bit over a long run; a few tens of KB a second need no workers, and on
            // the robot they would compete with the control loop for the cores.
            .compression_threads(0)
            .chunk_size(Some(CHUNK_BYTES))
            .profile("")
            .create(BufWriter::new(file))
            .context("log: starting the MCAP file")?;
        let none = BTreeMap::new();
        let mut add = |spec: &ChannelSpec| -> anyhow::Result<u16> {
            let schema = schema::schema_of(spec);
            let schema_id = match &schema {
                Some(text) => writer.add_schema(spec.schema_name, "jsonschema", text.as_bytes())?,
                None => 0,
            };
            let id = writer.add_channel(schema_id, spec.topic, spec.encoding, &none)?;
            if let Some(v) = &live {
                let (name, encoding) = match schema {
                    Some(_) => (spec.schema_name, "jsonschema"),
                    None => ("", ""),
                };
                let text = schema.unwrap_or_default();
                v.add_channel(
                    id,
                    spec.topic,
                    name,
                    encoding,
                    text.as_bytes(),
                    spec.encoding,
                );
            }
            Ok(id)
        };
        let raw = add(&schema::SENSOR_RAW)?;
        let cycle = add(&schema::CYCLE)?;
        let state = add(&schema::STATE)?;
        let info = add(&schema::SENSOR_INFO)?;
        let wall = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as i128);
        let mut log = McapLog {
            writer,
            flushed_len: 0,
            unflushed_records: 0,
            disk_full: full,
            path: path.to_owned(),
            raw,
            cycle,
            state,
            info,
            sequence: 0,
            opened: Instant::now(),
            epoch_offset_ns: wall - i128::from(monotonic_ns()),
            live,
        };
        // The header, schemas and channels on the disk at once: a file that fails later can
        // be cut back to complete records.
        log.flush()?;
        Ok(log)
    }

    /// Log times from now on are `mono_ns + offset_ns` instead of the wall clock's reading of
    /// CLOCK_MONOTONIC: a simulation in virtual time passes a fixed offset, so the file does
    /// not depend on when it was written.
    pub fn set_time_offset(&mut self, offset_ns: i128) {
        self.epoch_offset_ns = offset_ns;
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    pub(crate) fn log_time(&self, mono_ns: u64) -> u64 {
        (i128::from(mono_ns) + self.epoch_offset_ns).max(0) as u64
    }

    fn message(&mut self, channel_id: u16, mono_ns: u64, data: &[u8]) -> anyhow::Result<()> {
        self.sequence = self.sequence.wrapping_add(1);
        let t = self.log_time(mono_ns);
        self.writer.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id,
                sequence: self.sequence,
                log_time: t,
                publish_time: t,
            },
            data,
        )?;
        if let Some(live) = &self.live {
            live.publish(channel_id, t, data);
        }
        Ok(())
    }

    /// A metadata record of string pairs.
    pub fn metadata(&mut self, name: &str, pairs: &[(&str, String)]) -> anyhow::Result<()> {
        self.writer.write_metadata(&mcap::records::Metadata {
            name: name.to_owned(),
            metadata: pairs
                .iter()
                .map(|(k, v)| ((*k).to_owned(), v.clone()))
                .collect(),
        })?;
        Ok(())
    }

    /// The RT setup report as metadata.
    pub fn rt_setup(&mut self, report: &RtSetupReport) -> anyhow::Result<()> {
        self.metadata(
            "rt_setup",
            &[
                ("report", report.to_string()),
                ("json", serde_json::to_string(report)?),
            ],
        )
    }

    /// Writes one cycle: raw packet, info frame, state change, and the decoded cycle (if
    /// `with_decoded`).
    pub fn record(&mut self, r: &CycleRecord, with_decoded: bool) -> anyhow::Result<()> {
        let t = r.tick.wake_ns;
        if let Some(raw) = &r.raw {
            self.message(self.raw, t, raw.as_ref())?;
        }
        if let Some(info) = &r.info {
            self.message(self.info, t, &serde_json::to_vec(&info_message(info))?)?;
        }
        if r.events != 0 {
            self.message(self.state, t, &serde_json::to_vec(&state_message(r))?)?;
        }
        if with_decoded {
            self.message(self.cycle, t, &serde_json::to_vec(&cycle_message(r))?)?;
        }
        self.unflushed_records += 1;
        Ok(())
    }

    /// Ends the current chunk and flushes it to the file.
    pub fn flush(&mut self) -> anyhow::Result<()> {
        self.writer.flush()?;
        self.flushed_len = std::fs::metadata(&self.path)?.len();
        self.unflushed_records = 0;
        Ok(())
    }

    /// Adds an attachment (e.g. the latency histogram).
    pub fn attach(&mut self, name: &str, media_type: &str, data: &[u8]) -> anyhow::Result<()> {
        let t = self.log_time(monotonic_ns());
        self.writer.attach(&mcap::Attachment {
            log_time: t,
            create_time: t,
            name: name.to_owned(),
            media_type: media_type.to_owned(),
            data: std::borrow::Cow::Borrowed(data),
        })?;
        Ok(())
    }

    /// Writes the summary and index and closes the file; an error when any of it did not
    /// reach the file.
    pub fn finish(mut self) -> anyhow::Result<PathBuf> {
        self.writer.finish()?;
        self.writer
            .into_inner()
            .flush()
            .with_context(|| format!("log: finishing {}", self.path.display()))?;
        Ok(self.path)
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
}

impl Default for LoggerSettings {
    fn default() -> Self {
        LoggerSettings {
            flush_interval: Duration::from_secs(1),
            decoded_every: 1,
            header: Vec::new(),
            max_file_duration: Some(Duration::from_secs(600)),
            faults: LogFaults::default(),
        }
    }
}

/// Metadata record at the start of a resumed file: `previous_file`, `error`,
/// `records_not_logged`.
pub const METADATA_LOG_RESUMED: &str = "log_resumed";

/// Metadata record at the start of a file that continues the previous one after the split by
/// duration: `previous_file`.
pub const METADATA_LOG_CONTINUED: &str = "log_continued";

/// How often a failed log, or a split that could not open the next file, is retried.
const LOG_RETRY: Duration = Duration::from_secs(1);

/// A chunk is ended once this many uncompressed bytes went into it, even before the next
/// flush. zstd compresses each chunk as one frame through an input buffer of its 2 MiB window,
/// and the process's resident memory keeps the largest part of that buffer a chunk ever
/// filled: a second of 250 Hz records is about 400 KB, but the backlog after a stalled disk
/// would fill more. Bounded here, a long run's memory stays flat.
pub const CHUNK_BYTES: u64 = 512 * 1024;

/// The MCAP end of a file cut at `len` bytes (a complete record boundary): Data End and a
/// Footer without a summary section, then the magic.
fn end_of_mcap() -> Vec<u8> {
    let mut v = Vec::with_capacity(9 + 4 + 9 + 20 + 8);
    v.push(0x0F); // Data End
    v.extend_from_slice(&4u64.to_le_bytes());
    v.extend_from_slice(&0u32.to_le_bytes()); // data section CRC not computed
    v.push(0x02); // Footer
    v.extend_from_slice(&20u64.to_le_bytes());
    v.extend_from_slice(&0u64.to_le_bytes()); // no summary section
    v.extend_from_slice(&0u64.to_le_bytes()); // no summary offsets
    v.extend_from_slice(&0u32.to_le_bytes()); // summary CRC not computed
    v.extend_from_slice(b"\x89MCAP0\r\n");
    v
}

/// Ends `path` at its last complete chunk (`len` bytes) as a valid MCAP file.
fn close_failed_file(path: &Path, len: u64, full: &AtomicBool) -> std::io::Result<()> {
    check_disk(full)?;
    let mut file = std::fs::OpenOptions::new().write(true).open(path)?;
    file.set_len(len)?;
    file.seek(SeekFrom::End(0))?;
    file.write_all(&end_of_mcap())?;
    file.sync_data()
}

/// `dir/NAME-n.mcap` for `dir/NAME.mcap`.
fn resumed_name(first: &Path, n: u32) -> PathBuf {
    let stem = first
        .file_stem()
        .map_or_else(|| "dima".to_owned(), |s| s.to_string_lossy().into_owned());
    first.with_file_name(format!("{stem}-{n}.mcap"))
}

/// A log file that failed, waiting for the disk.
struct FailedLog {
    path: PathBuf,
    flushed_len: u64,
    error: String,
    next_try: Instant,
    not_logged: u64,
}

/// Logging of one run, across failed, resumed and continued files.
struct LogState {
    log: Option<McapLog>,
    failed: Option<FailedLog>,
    /// The run's first file (the following files are named after it).
    first: Option<PathBuf>,
    /// Files after the first so far, whatever the reason (a disk fault or the split by
    /// duration): one numbering for the run.
    numbered: u32,
    disk_full: Arc<AtomicBool>,
    /// The live view the run's files serve.
    live: Option<Arc<LiveView>>,
    header: Vec<(String, Vec<(&'static str, String)>)>,
    /// Split the run into files of at most this duration.
    max_file_duration: Option<Duration>,
    /// A split that could not open the next file waits until then (the current file goes on).
    next_split_try: Option<Instant>,
    /// A file that could not be finished at a split, with its length at its last flush: it is
    /// ended there as soon as the disk allows.
    unfinished: Option<(PathBuf, u64)>,
}

impl LogState {
    fn new(
        log: Option<McapLog>,
        header: Vec<(String, Vec<(&'static str, String)>)>,
        max_file_duration: Option<Duration>,
    ) -> LogState {
        LogState {
            first: log.as_ref().map(|l| l.path().to_owned()),
            disk_full: log.as_ref().map_or_else(
                || Arc::new(AtomicBool::new(false)),
                |l| Arc::clone(&l.disk_full),
            ),
            live: log.as_ref().and_then(|l| l.live.clone()),
            log,
            failed: None,
            numbered: 0,
            header,
            max_file_duration: max_file_duration.filter(|d| !d.is_zero()),
            next_split_try: None,
            unfinished: None,
        }
    }

    /// Opens the run's next file (`NAME-n.mcap`): the header metadata, then `note`, flushed.
    /// A file that cannot be started is removed again.
    fn open_next(
        &self,
        note: &str,
        pairs: &[(&str, String)],
    ) -> (PathBuf, anyhow::Result<McapLog>) {
        let Some(first) = &self.first else {
            return (
                PathBuf::new(),
                Err(anyhow::anyhow!("log: no file to continue")),
            );
        };
        let path = resumed_name(first, self.numbered + 1);
        let next = McapLog::create_file_with(&path, Arc::clone(&self.disk_full), self.live.clone())
            .and_then(|mut l| {
                for (name, pairs) in &self.header {
                    l.metadata(name, pairs)?;
                }
                l.metadata(note, pairs)?;
                l.flush()?;
                Ok(l)
            });
        if next.is_err() {
            let _ = std::fs::remove_file(&path);
        }
        (path, next)
    }

    /// A write failed: logging stops with one message, the file is kept for closing.
    fn fail(&mut self, error: &anyhow::Error) {
        let Some(log) = self.log.take() else { return };
        let path = log.path.clone();
        let flushed_len = log.flushed_len;
        // The records since the last flush go with the file's unflushed end.
        let not_logged = log.unflushed_records;
        tracing::error!(
            "log: writing {} failed: {error:#}; logging stops, the robot keeps running \
             (retrying every {} s in a new file)",
            path.display(),
            LOG_RETRY.as_secs()
        );
        // Dropping the writer tries to finish the file; on a full disk that fails quietly,
        // and the file is cut back to `flushed_len` when the disk works again.
        drop(log);
        self.failed = Some(FailedLog {
            path,
            flushed_len,
            error: format!("{error:#}"),
            next_try: Instant::now() + LOG_RETRY,
            not_logged,
        });
    }

    /// While failed: counts a record that could not be logged, and every second tries to
    /// close the failed file and resume in a new one. Also ends a file a split could not
    /// finish.
    fn retry(&mut self, now: Instant) {
        self.end_unfinished();
        let Some(failed) = self.failed.as_ref() else {
            return;
        };
        if now < failed.next_try {
            return;
        }
        if let Some(f) = self.failed.as_mut() {
            f.next_try = now + LOG_RETRY;
        }
        let Some(failed) = self.failed.as_ref() else {
            return;
        };
        if close_failed_file(&failed.path, failed.flushed_len, &self.disk_full).is_err() {
            return;
        }
        let (path, resumed) = self.open_next(
            METADATA_LOG_RESUMED,
            &[
                ("previous_file", failed.path.display().to_string()),
                ("error", failed.error.clone()),
                ("records_not_logged", failed.not_logged.to_string()),
            ],
        );
        if let Ok(l) = resumed {
            tracing::warn!(
                "log: logging resumed in {} ({} records not logged; {} ends at its last \
                 complete chunk)",
                path.display(),
                failed.not_logged,
                failed.path.display()
            );
            self.numbered += 1;
            self.failed = None;
            self.log = Some(l);
        }
    }

    /// Whether the current file is due to be split at `now`.
    fn split_due(&self, now: Instant) -> bool {
        match (&self.log, self.max_file_duration) {
            (Some(l), Some(max)) => {
                now.saturating_duration_since(l.opened) >= max
                    && self.next_split_try.is_none_or(|t| now >= t)
            }
            _ => false,
        }
    }

    /// When the current file is older than the longest file duration: flushes its last
    /// chunk, opens the next file with the header and a `log_continued` note, and finishes
    /// the old file (summary and index). The records go on in exactly one file: all before
    /// the split in the old one, all after it in the new one. When the next file cannot be
    /// opened, the current one goes on and the split is tried again a second later.
    fn split(&mut self, now: Instant) {
        if !self.split_due(now) {
            return;
        }
        let Some(log) = self.log.as_mut() else { return };
        if let Err(e) = log.flush() {
            self.fail(&e);
            return;
        }
        let previous = log.path.clone();
        let (path, next) = self.open_next(
            METADATA_LOG_CONTINUED,
            &[("previous_file", previous.display().to_string())],
        );
        let next = match next {
            Ok(l) => l,
            Err(e) => {
                tracing::warn!(
                    "log: cannot start {} ({e:#}); {} goes on, trying again in {} s",
                    path.display(),
                    previous.display(),
                    LOG_RETRY.as_secs()
                );
                self.next_split_try = Some(now + LOG_RETRY);
                return;
            }
        };
        self.next_split_try = None;
        self.numbered += 1;
        let Some(old) = self.log.replace(next) else {
            return;
        };
        let flushed_len = old.flushed_len;
        match old.finish() {
            Ok(_) => tracing::info!(
                "log: {} finished, the run continues in {}",
                previous.display(),
                path.display()
            ),
            Err(e) => {
                tracing::warn!(
                    "log: finishing {} failed ({e:#}); it will end at its last complete chunk, \
                     the run continues in {}",
                    previous.display(),
                    path.display()
                );
                self.unfinished = Some((previous, flushed_len));
                self.end_unfinished();
            }
        }
    }

    /// Ends a file that a split could not finish at its last complete chunk, once the disk
    /// allows (all its records are in that chunk: it was flushed before the split).
    fn end_unfinished(&mut self) {
        if let Some((path, len)) = &self.unfinished {
            if close_failed_file(path, *len, &self.disk_full).is_ok() {
                self.unfinished = None;
            }
        }
    }

    /// At the end of the run: a file still failed is closed at its last complete chunk if
    /// the disk allows.
    fn finish(mut self) -> Option<McapLog> {
        self.end_unfinished();
        if let Some(failed) = self.failed.take() {
            if close_failed_file(&failed.path, failed.flushed_len, &self.disk_full).is_ok() {
                tracing::warn!(
                    "log: {} ends at its last complete chunk; {} records were not logged",
                    failed.path.display(),
                    failed.not_logged
                );
            }
        }
        self.log
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
    mut records: rtrb::Consumer<CycleRecord>,
    rt_reports: mpsc::Receiver<RtSetupReport>,
    settings: LoggerSettings,
    stop: Arc<AtomicBool>,
    mut observer: Option<crate::app::run::Observer>,
) -> std::io::Result<std::thread::JoinHandle<LoggerOutcome>> {
    std::thread::Builder::new()
        .name("dima-logger".into())
        .spawn(move || {
            let mut state = LogState::new(log, settings.header, settings.max_file_duration);
            let faults = settings.faults;
            let started_ns = monotonic_ns();
            let mut written = 0u64;
            let mut last_flush = Instant::now();
            let mut last_mode = Mode::Killed;
            let decoded_every = settings.decoded_every.max(1);
            let mut stalled = false;
            loop {
                let stopping = stop.load(Ordering::Acquire);
                let t_ns = monotonic_ns().saturating_sub(started_ns);
                state.disk_full.store(
                    faults.full.iter().any(|w| w.contains(t_ns)),
                    Ordering::Relaxed,
                );
                if faults.stalls.iter().any(|w| w.contains(t_ns)) && !stopping {
                    if !stalled {
                        tracing::warn!("log: the logger stalls (simulated slow disk)");
                        stalled = true;
                    }
                    std::thread::sleep(Duration::from_millis(10));
                    continue;
                }
                if stalled {
                    tracing::warn!("log: the logger drains again");
                    stalled = false;
                }
                if let Ok(report) = rt_reports.try_recv() {
                    if let Some(l) = state.log.as_mut() {
                        if let Err(e) = l.rt_setup(&report) {
                            state.fail(&e);
                        }
                    }
                }
                state.retry(Instant::now());
                state.split(Instant::now());
                let mut n = 0;
                while let Ok(r) = records.pop() {
                    report_events(&r, &mut last_mode);
                    if let (Some(v), Some(l)) = (&state.live, &state.log) {
                        v.cycle(&r, l.log_time(r.tick.wake_ns));
                    }
                    if let Some(observe) = observer.as_mut() {
                        observe(&r);
                    }
                    if let Some(l) = state.log.as_mut() {
                        let decoded = r.cycle % decoded_every == 0 || r.events != 0;
                        if let Err(e) = l.record(&r, decoded) {
                            state.fail(&e);
                        }
                    }
                    if let Some(f) = state.failed.as_mut() {
                        f.not_logged += 1;
                    }
                    written += 1;
                    n += 1;
                }
                if last_flush.elapsed() >= settings.flush_interval {
                    if let Some(l) = state.log.as_mut() {
                        if let Err(e) = l.flush() {
                            state.fail(&e);
                        }
                    }
                    last_flush = Instant::now();
                }
                if stopping && n == 0 && records.is_empty() {
                    break;
                }
                if n == 0 {
                    std::thread::sleep(Duration::from_millis(10));
                }
            }
            LoggerOutcome {
                log: state.finish(),
                records: written,
            }
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_names_are_utc_timestamps() {
        let t = UNIX_EPOCH + Duration::from_secs(1_795_000_000);
        // `date -u -d @1795000000`: 2026-11-18 11:06:40 UTC.
        assert_eq!(log_file_name(t), "dima-20261118T110640Z.mcap");
        assert_eq!(log_file_name(UNIX_EPOCH), "dima-19700101T000000Z.mcap");
        let leap = UNIX_EPOCH + Duration::from_secs(951_825_600); // 2000-02-29 12:00:00
        assert_eq!(log_file_name(leap), "dima-20000229T120000Z.mcap");
    }

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
        while resumed_name(&first, files.len() as u32).is_file() {
            files.push(resumed_name(&first, files.len() as u32));
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
        let summary = mcap::Summary::read(&bytes)
            .unwrap()
            .unwrap_or_else(|| panic!("{}: no summary", path.display()));
        let mut cycles = Vec::new();
        for m in mcap::MessageStream::new(&bytes).unwrap() {
            let m = m.unwrap();
            if m.channel.topic == "/dima/cycle" {
                let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
                cycles.push(v["cycle"].as_u64().unwrap());
            }
        }
        let stats = summary.stats.expect("statistics");
        assert_eq!(
            stats.message_count,
            cycles.len() as u64,
            "{}",
            path.display()
        );
        let mut metadata = Vec::new();
        for record in mcap::read::LinearReader::new(&bytes).unwrap() {
            if let mcap::records::Record::Metadata(m) = record.unwrap() {
                metadata.push((m.name, m.metadata));
            }
        }
        (cycles, metadata, summary.chunk_indexes.len())
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
            for m in mcap::MessageStream::new(&bytes).unwrap() {
                let m = m.unwrap();
                if m.channel.topic == "/dima/cycle" {
                    let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
                    logged.push(v["cycle"].as_u64().unwrap());
                }
            }
            for record in mcap::read::LinearReader::new(&bytes).unwrap() {
                if let mcap::records::Record::Metadata(m) = record.unwrap() {
                    if m.name == METADATA_LOG_RESUMED {
                        not_logged = m.metadata["records_not_logged"].parse::<u64>().ok();
                    }
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
