//! [`RunWriter`]: one run across files, split by duration and resumed after a failed write.

use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use super::{close_failed_file, FileSetup, Header, McapLog, Tap, LOG_RETRY};
use super::{METADATA_LOG_CONTINUED, METADATA_LOG_RESUMED};
use crate::naming::numbered_name;

/// A log file that failed, waiting for the disk.
struct FailedLog {
    path: PathBuf,
    flushed_len: u64,
    error: String,
    next_try: Instant,
    not_logged: u64,
}

/// Logging of one run, across failed, resumed and continued files.
///
/// A write that fails stops logging with one error message naming the file and the error;
/// the records given while it is stopped are counted. Every [`LOG_RETRY`] it tries again: it
/// ends the failed file at its last complete chunk and resumes in the run's next file, which
/// starts with the header metadata and a [`METADATA_LOG_RESUMED`] note. A run is also split by
/// duration (as rosbag2's `max_bag_duration`): the current file is finished (summary and
/// index) and the run continues in the next file with a [`METADATA_LOG_CONTINUED`] note;
/// every record goes to exactly one file.
pub struct RunWriter {
    log: Option<McapLog>,
    failed: Option<FailedLog>,
    /// The run's first file (the following files are named after it).
    first: Option<PathBuf>,
    /// How the run's files are opened (taken from the first).
    setup: Option<FileSetup>,
    /// The tap while no file is open.
    parked_tap: Option<Box<dyn Tap>>,
    /// Files after the first so far, whatever the reason: one numbering for the run.
    numbered: u32,
    header: Header,
    /// Split the run into files of at most this duration.
    max_file_duration: Option<Duration>,
    /// A split that could not open the next file waits until then (the current file goes on).
    next_split_try: Option<Instant>,
    /// A file that could not be finished at a split, with its length at its last flush: it is
    /// ended there as soon as the disk allows.
    unfinished: Option<(PathBuf, u64)>,
}

impl RunWriter {
    /// A run starting in `log` (`None`: logging off), whose next files start with `header`,
    /// split every `max_file_duration` (`None` or zero: never). The next files declare the
    /// same channels, keep the same clock and the same injected full disk.
    pub fn new(log: Option<McapLog>, header: Header, max_file_duration: Option<Duration>) -> Self {
        RunWriter {
            first: log.as_ref().map(|l| l.path().to_owned()),
            setup: log.as_ref().map(|l| l.setup.clone()),
            log,
            failed: None,
            parked_tap: None,
            numbered: 0,
            header,
            max_file_duration: max_file_duration.filter(|d| !d.is_zero()),
            next_split_try: None,
            unfinished: None,
        }
    }

    /// Attaches `tap` to the run: to the open file now, and to every file after it.
    pub fn set_tap(&mut self, tap: Box<dyn Tap>) {
        match self.log.as_mut() {
            Some(l) => l.set_tap(tap),
            None => self.parked_tap = Some(tap),
        }
    }

    /// Makes every write fail as on a full disk while `full` is set (a simulation's fault).
    pub fn set_disk_full(&mut self, full: bool) {
        if let Some(s) = &self.setup {
            s.full.store(full, Ordering::Relaxed);
        }
    }

    /// The file open now (`None` while logging is off or failed).
    pub fn log_mut(&mut self) -> Option<&mut McapLog> {
        self.log.as_mut()
    }

    /// Whether logging has failed and waits for the disk.
    pub fn is_failed(&self) -> bool {
        self.failed.is_some()
    }

    /// Writes with `write` to the open file; a failure stops logging (see [`fail`](Self::fail)).
    pub fn write(&mut self, write: impl FnOnce(&mut McapLog) -> anyhow::Result<()>) {
        if let Some(l) = self.log.as_mut() {
            if let Err(e) = write(l) {
                self.fail(&e);
            }
        }
    }

    /// Writes one record with `write` and counts it: as written (lost with the file's unflushed
    /// end if the file fails before its next flush), or as not logged while logging is stopped.
    pub fn write_record(&mut self, write: impl FnOnce(&mut McapLog) -> anyhow::Result<()>) {
        self.write(|l| {
            write(l)?;
            l.count_record();
            Ok(())
        });
        if let Some(f) = self.failed.as_mut() {
            f.not_logged += 1;
        }
    }

    /// Ends the current chunk and flushes it; a failure stops logging.
    pub fn flush(&mut self) {
        self.write(McapLog::flush);
    }

    /// Opens the run's next file (`NAME-n.mcap`): the header metadata, then `note`, flushed.
    /// A file that cannot be started is removed again.
    fn open_next(
        &mut self,
        note: &str,
        pairs: &[(&str, String)],
    ) -> (PathBuf, anyhow::Result<McapLog>) {
        let (Some(first), Some(setup)) = (&self.first, &self.setup) else {
            return (
                PathBuf::new(),
                Err(anyhow::anyhow!("log: no file to continue")),
            );
        };
        let path = numbered_name(first, self.numbered + 1);
        let next = McapLog::open(&path, setup.clone(), None).and_then(|mut l| {
            for (name, pairs) in &self.header {
                l.metadata(name, pairs)?;
            }
            l.metadata(note, pairs)?;
            l.flush()?;
            Ok(l)
        });
        match next {
            Ok(mut l) => {
                if let Some(tap) = self.parked_tap.take() {
                    l.set_tap(tap);
                }
                (path, Ok(l))
            }
            Err(e) => {
                let _ = std::fs::remove_file(&path);
                (path, Err(e))
            }
        }
    }

    /// A write failed: logging stops with one message, the file is kept for closing.
    pub fn fail(&mut self, error: &anyhow::Error) {
        let Some(mut log) = self.log.take() else {
            return;
        };
        let path = log.path.clone();
        let flushed_len = log.flushed_len;
        // The records since the last flush go with the file's unflushed end.
        let not_logged = log.unflushed_records;
        self.parked_tap = log.take_tap();
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

    fn disk_full_now(&self) -> &std::sync::atomic::AtomicBool {
        static NEVER: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
        self.setup.as_ref().map_or(&NEVER, |s| &s.full)
    }

    fn close_at(&self, path: &Path, len: u64) -> bool {
        close_failed_file(path, len, self.disk_full_now()).is_ok()
    }

    /// While failed: every [`LOG_RETRY`] tries to close the failed file and resume in a new
    /// one. Also ends a file a split could not finish.
    pub fn retry(&mut self, now: Instant) {
        self.end_unfinished();
        let Some(failed) = self.failed.as_mut() else {
            return;
        };
        if now < failed.next_try {
            return;
        }
        failed.next_try = now + LOG_RETRY;
        let (path, flushed_len) = (failed.path.clone(), failed.flushed_len);
        if !self.close_at(&path, flushed_len) {
            return;
        }
        let Some(failed) = self.failed.as_ref() else {
            return;
        };
        let pairs = [
            ("previous_file", failed.path.display().to_string()),
            ("error", failed.error.clone()),
            ("records_not_logged", failed.not_logged.to_string()),
        ];
        let not_logged = failed.not_logged;
        let (next_path, resumed) = self.open_next(METADATA_LOG_RESUMED, &pairs);
        if let Ok(l) = resumed {
            tracing::warn!(
                "log: logging resumed in {} ({not_logged} records not logged; {} ends at \
                 its last complete chunk)",
                next_path.display(),
                path.display()
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

    /// When the current file is older than the longest file duration: [`split_now`](Self::split_now).
    pub fn split(&mut self, now: Instant) {
        if self.split_due(now) {
            self.split_now(now);
        }
    }

    /// Flushes the current file's last chunk, opens the next file with the header and a
    /// `log_continued` note, and finishes the old file (summary and index). The records go on
    /// in exactly one file: all before the split in the old one, all after it in the new one.
    /// When the next file cannot be opened, the current one goes on and a split by duration
    /// is tried again [`LOG_RETRY`] later.
    pub fn split_now(&mut self, now: Instant) {
        let Some(log) = self.log.as_mut() else { return };
        if let Err(e) = log.flush() {
            self.fail(&e);
            return;
        }
        let previous = log.path.clone();
        self.parked_tap = log.take_tap();
        let (path, next) = self.open_next(
            METADATA_LOG_CONTINUED,
            &[("previous_file", previous.display().to_string())],
        );
        let next = match next {
            Ok(l) => l,
            Err(e) => {
                if let Some(l) = self.log.as_mut() {
                    l.tap = self.parked_tap.take();
                }
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
        self.finish_split_file(old, &previous, &path);
    }

    /// Finishes the file a split left (`previous`, continued in `next`).
    fn finish_split_file(&mut self, old: McapLog, previous: &Path, next: &Path) {
        let flushed_len = old.flushed_len;
        match old.finish() {
            Ok(_) => tracing::info!(
                "log: {} finished, the run continues in {}",
                previous.display(),
                next.display()
            ),
            Err(e) => {
                tracing::warn!(
                    "log: finishing {} failed ({e:#}); it will end at its last complete chunk, \
                     the run continues in {}",
                    previous.display(),
                    next.display()
                );
                self.unfinished = Some((previous.to_path_buf(), flushed_len));
                self.end_unfinished();
            }
        }
    }

    /// Ends a file that a split could not finish at its last complete chunk, once the disk
    /// allows (all its records are in that chunk: it was flushed before the split).
    fn end_unfinished(&mut self) {
        if let Some((path, len)) = &self.unfinished {
            if self.close_at(path, *len) {
                self.unfinished = None;
            }
        }
    }

    /// At the end of the run: a file still failed is closed at its last complete chunk if
    /// the disk allows. Returns the file still open, for the summary and attachments.
    pub fn finish(mut self) -> Option<McapLog> {
        self.end_unfinished();
        if let Some(failed) = self.failed.take() {
            if self.close_at(&failed.path, failed.flushed_len) {
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
