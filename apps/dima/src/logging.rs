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

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::Context;
use dima_core::schema::{self, ChannelSpec};
use dima_core::Mode;

use crate::app::record::{events, CycleRecord};
use crate::log_messages::{cycle_message, info_message, state_message};
use crate::rt::{monotonic_ns, RtSetupReport};

/// The MCAP file being written.
pub struct McapLog {
    writer: mcap::Writer<BufWriter<File>>,
    path: PathBuf,
    raw: u16,
    cycle: u16,
    state: u16,
    info: u16,
    sequence: u32,
    /// Added to CLOCK_MONOTONIC to get wall-clock ns for log times.
    epoch_offset_ns: i128,
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
        std::fs::create_dir_all(dir)
            .with_context(|| format!("log: cannot create directory {}", dir.display()))?;
        let path = dir.join(log_file_name(SystemTime::now()));
        McapLog::create_file(&path)
    }

    /// Creates the file at `path`.
    pub fn create_file(path: &Path) -> anyhow::Result<McapLog> {
        let file = File::create(path)
            .with_context(|| format!("log: cannot create {} (writable?)", path.display()))?;
        let mut writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .chunk_size(Some(4 * 1024 * 1024))
            .profile("")
            .create(BufWriter::new(file))
            .context("log: starting the MCAP file")?;
        let none = BTreeMap::new();
        let mut add = |spec: &ChannelSpec| -> anyhow::Result<u16> {
            let schema_id = match schema::schema_of(spec) {
                Some(text) => writer.add_schema(spec.schema_name, "jsonschema", text.as_bytes())?,
                None => 0,
            };
            Ok(writer.add_channel(schema_id, spec.topic, spec.encoding, &none)?)
        };
        let raw = add(&schema::SENSOR_RAW)?;
        let cycle = add(&schema::CYCLE)?;
        let state = add(&schema::STATE)?;
        let info = add(&schema::SENSOR_INFO)?;
        let wall = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as i128);
        Ok(McapLog {
            writer,
            path: path.to_owned(),
            raw,
            cycle,
            state,
            info,
            sequence: 0,
            epoch_offset_ns: wall - i128::from(monotonic_ns()),
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn log_time(&self, mono_ns: u64) -> u64 {
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
        Ok(())
    }

    /// Ends the current chunk and flushes it to the file.
    pub fn flush(&mut self) -> anyhow::Result<()> {
        self.writer.flush()?;
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

    /// Writes the summary and index and closes the file.
    pub fn finish(mut self) -> anyhow::Result<PathBuf> {
        self.writer.finish()?;
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
    mut log: Option<McapLog>,
    mut records: rtrb::Consumer<CycleRecord>,
    rt_reports: mpsc::Receiver<RtSetupReport>,
    settings: LoggerSettings,
    stop: Arc<AtomicBool>,
    mut observer: Option<crate::app::run::Observer>,
) -> std::io::Result<std::thread::JoinHandle<LoggerOutcome>> {
    std::thread::Builder::new()
        .name("dima-logger".into())
        .spawn(move || {
            let mut written = 0u64;
            let mut last_flush = Instant::now();
            let mut last_mode = Mode::Killed;
            let decoded_every = settings.decoded_every.max(1);
            loop {
                let stopping = stop.load(Ordering::Acquire);
                if let Ok(report) = rt_reports.try_recv() {
                    if let Some(l) = log.as_mut() {
                        if let Err(e) = l.rt_setup(&report) {
                            tracing::error!("log: {e:#}");
                        }
                    }
                }
                let mut n = 0;
                while let Ok(r) = records.pop() {
                    report_events(&r, &mut last_mode);
                    if let Some(observe) = observer.as_mut() {
                        observe(&r);
                    }
                    if let Some(l) = log.as_mut() {
                        let decoded = r.cycle % decoded_every == 0 || r.events != 0;
                        if let Err(e) = l.record(&r, decoded) {
                            tracing::error!("log: {e:#}; logging stops, the loop goes on");
                            log = None;
                        }
                    }
                    written += 1;
                    n += 1;
                }
                if last_flush.elapsed() >= settings.flush_interval {
                    if let Some(l) = log.as_mut() {
                        if let Err(e) = l.flush() {
                            tracing::error!("log: flush: {e:#}; logging stops");
                            log = None;
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
                log,
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
}
