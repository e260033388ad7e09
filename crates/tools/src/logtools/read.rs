//! Reading a DIMA MCAP log into the typed messages of [`dima_core::schema`], up to the last
//! complete record: a file cut anywhere (a crash mid-write, a partial copy) is read as far as
//! it goes, with a warning.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Context;
use dima_core::config::Config;
use dima_core::schema::{self, CycleMessage, SensorInfoMessage, StateMessage, SummaryRecord};
use dima_sensorboard::PACKET_LEN;
use mcap::records::Record;

use super::records::{for_each_record, Scope};

/// A message with its log time (Unix-epoch ns).
#[derive(Debug, Clone, PartialEq)]
pub struct Timed<T> {
    /// Log time, ns since the Unix epoch.
    pub t_ns: u64,
    /// The message.
    pub msg: T,
}

/// Everything a log holds, typed.
#[derive(Debug, Clone, Default)]
pub struct LoggedRun {
    /// `/dima/cycle` messages, in order.
    pub cycles: Vec<Timed<CycleMessage>>,
    /// `/dima/state` messages, in order.
    pub states: Vec<Timed<StateMessage>>,
    /// `/sensor/info` messages, in order.
    pub infos: Vec<Timed<SensorInfoMessage>>,
    /// `/sensor/raw` packets by log time.
    pub raw: BTreeMap<u64, [u8; PACKET_LEN]>,
    /// The configuration that ran (metadata `dima`).
    pub config: Option<Config>,
    /// The application's version (metadata `dima`).
    pub version: Option<String>,
    /// The realtime setup report, as text (metadata `rt_setup`).
    pub rt_setup: Option<String>,
    /// The totals at exit (metadata `summary`; absent in a cut file).
    pub summary: Option<SummaryRecord>,
    /// The ground link's counts at exit, as text (metadata `summary`).
    pub ground_link: Option<String>,
    /// The wake-up latency histogram in cyclictest's format (attachment).
    pub histogram: Option<String>,
    /// What could not be read, for a warning.
    pub warnings: Vec<String>,
}

impl LoggedRun {
    /// Reads `path`. Errors only when nothing at all can be read.
    pub fn read(path: &Path) -> anyhow::Result<LoggedRun> {
        let bytes =
            std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
        LoggedRun::from_bytes(&bytes).with_context(|| format!("{}", path.display()))
    }

    /// Parses the bytes of an MCAP file written by `dima`.
    ///
    /// Any bytes give a result or an error: no length field in the file can size an allocation
    /// (see [`records`](super::records)).
    pub fn from_bytes(bytes: &[u8]) -> anyhow::Result<LoggedRun> {
        let mut run = LoggedRun::default();
        let mut topics = BTreeMap::new();
        let mut messages = 0u64;
        let read = for_each_record(bytes, Scope::InsideChunks, |record| {
            match record {
                Record::Channel(channel) => {
                    topics.insert(channel.id, channel.topic);
                }
                Record::Message { header, data } => {
                    let topic = topics.get(&header.channel_id).with_context(|| {
                        format!(
                            "message on channel {} before its channel",
                            header.channel_id
                        )
                    })?;
                    messages += 1;
                    if let Err(e) = run.add_message(topic, header.log_time, &data) {
                        run.warnings
                            .push(format!("{topic} message at {}: {e}", header.log_time));
                    }
                }
                _ => {}
            }
            Ok(())
        });
        if let Err(e) = read {
            run.warnings
                .push(format!("read up to message {messages}, then: {e:#}"));
        }
        run.read_records(bytes);
        if messages == 0 && run.config.is_none() {
            let reason = run
                .warnings
                .first()
                .map_or(String::new(), |w| format!(" ({w})"));
            anyhow::bail!(
                "no complete message or metadata record{reason}: not a DIMA MCAP log, or cut \
                 before its first record"
            );
        }
        Ok(run)
    }

    fn add_message(&mut self, topic: &str, t_ns: u64, data: &[u8]) -> anyhow::Result<()> {
        if topic == schema::CYCLE.topic {
            let msg = serde_json::from_slice(data)?;
            self.cycles.push(Timed { t_ns, msg });
        } else if topic == schema::STATE.topic {
            let msg = serde_json::from_slice(data)?;
            self.states.push(Timed { t_ns, msg });
        } else if topic == schema::SENSOR_INFO.topic {
            let msg = serde_json::from_slice(data)?;
            self.infos.push(Timed { t_ns, msg });
        } else if topic == schema::SENSOR_RAW.topic {
            let packet: [u8; PACKET_LEN] = data
                .try_into()
                .map_err(|_| anyhow::anyhow!("{} bytes, not {PACKET_LEN}", data.len()))?;
            self.raw.insert(t_ns, packet);
        }
        Ok(())
    }

    /// Metadata and attachments, from the records themselves (a cut file has no summary
    /// section to index them). Chunks are skipped without decompressing them, so a damaged
    /// chunk does not hide the metadata after it.
    fn read_records(&mut self, bytes: &[u8]) {
        let _ = for_each_record(bytes, Scope::TopLevel, |record| {
            match record {
                Record::Metadata(m) => self.add_metadata(&m.name, &m.metadata),
                Record::Attachment { header, data, .. }
                    if header.name == schema::ATTACHMENT_HISTOGRAM =>
                {
                    self.histogram = Some(String::from_utf8_lossy(&data).into_owned());
                }
                _ => {}
            }
            Ok(())
        });
    }

    fn add_metadata(&mut self, name: &str, pairs: &BTreeMap<String, String>) {
        match name {
            schema::METADATA_DIMA => {
                self.version = pairs.get("version").cloned();
                if let Some(text) = pairs.get("config") {
                    match Config::from_toml(text, "the log's configuration") {
                        Ok(c) => self.config = Some(c),
                        Err(e) => self.warnings.push(e.to_string()),
                    }
                }
            }
            schema::METADATA_RT_SETUP => self.rt_setup = pairs.get("report").cloned(),
            schema::METADATA_SUMMARY => {
                self.ground_link = pairs.get("ground_link").cloned();
                if let Some(json) = pairs.get("json") {
                    match serde_json::from_str(json) {
                        Ok(s) => self.summary = Some(s),
                        Err(e) => self.warnings.push(format!("summary record: {e}")),
                    }
                }
            }
            _ => {}
        }
    }

    /// Log time of the first cycle, ns (the origin of the time axes).
    pub fn start_ns(&self) -> u64 {
        self.cycles.first().map_or(0, |c| c.t_ns)
    }

    /// Seconds since the first cycle.
    pub fn seconds(&self, t_ns: u64) -> f64 {
        t_ns.saturating_sub(self.start_ns()) as f64 * 1e-9
    }

    /// Prints the warnings to stderr.
    pub fn warn(&self, path: &Path) {
        for w in &self.warnings {
            eprintln!("warning: {}: {w}", path.display());
        }
    }
}
