//! The one reader of an MCAP file: [`LoggedRun`] reads a DIMA log into the typed messages of
//! [`crate::schema`]; [`messages`] and [`metadata`] read any MCAP file's messages and
//! metadata records as they are. All read up to the last complete record: a file cut anywhere
//! (a crash mid-write, a partial copy) is read as far as it goes, and no length field in a
//! file can size an allocation (see [`records`](crate::records)).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context;
use dima_core::config::Config;
use dima_core::mission::Navigation;
use dima_sensorboard::PACKET_LEN;
use mcap::records::Record;

use crate::records::{for_each_record, Scope};
use crate::schema::{self, CycleMessage, SensorInfoMessage, StateMessage, SummaryRecord};

/// A channel as a file declares it, with its schema.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ChannelInfo {
    /// Channel id in its file.
    pub id: u16,
    /// Topic.
    pub topic: String,
    /// Message encoding.
    pub message_encoding: String,
    /// Schema name (empty: no schema).
    pub schema_name: String,
    /// Schema encoding (empty: no schema).
    pub schema_encoding: String,
    /// The schema itself.
    pub schema: Vec<u8>,
}

/// One message as written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Message {
    /// Its channel.
    pub channel: Arc<ChannelInfo>,
    /// Sequence number.
    pub sequence: u32,
    /// Log time, ns since the Unix epoch.
    pub log_time: u64,
    /// The message's bytes.
    pub data: Vec<u8>,
}

/// One metadata record: its name and its pairs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Metadata {
    /// Record name.
    pub name: String,
    /// Key and value pairs.
    pub pairs: BTreeMap<String, String>,
}

/// Every message of the MCAP file in `bytes`, in file order.
///
/// # Errors
/// The first damaged record, or a message before its channel.
pub fn messages(bytes: &[u8]) -> anyhow::Result<Vec<Message>> {
    let mut out = Vec::new();
    for_each_message(bytes, |m| {
        out.push(m);
        Ok(())
    })?;
    Ok(out)
}

/// Calls `on_message` with every message of the MCAP file in `bytes`, in file order.
///
/// # Errors
/// The first damaged record, a message before its channel, or what `on_message` returns;
/// `on_message` has seen every message before it.
pub fn for_each_message(
    bytes: &[u8],
    mut on_message: impl FnMut(Message) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut schemas: BTreeMap<u16, (String, String, Vec<u8>)> = BTreeMap::new();
    let mut channels: BTreeMap<u16, Arc<ChannelInfo>> = BTreeMap::new();
    for_each_record(bytes, Scope::InsideChunks, |record| {
        match record {
            Record::Schema { header, data } => {
                schemas.insert(header.id, (header.name, header.encoding, data.into_owned()));
            }
            Record::Channel(c) => {
                let (schema_name, schema_encoding, schema) =
                    schemas.get(&c.schema_id).cloned().unwrap_or_default();
                let info = ChannelInfo {
                    id: c.id,
                    topic: c.topic,
                    message_encoding: c.message_encoding,
                    schema_name,
                    schema_encoding,
                    schema,
                };
                channels.insert(c.id, Arc::new(info));
            }
            Record::Message { header, data } => {
                let channel = channels.get(&header.channel_id).with_context(|| {
                    format!(
                        "message on channel {} before its channel",
                        header.channel_id
                    )
                })?;
                on_message(Message {
                    channel: Arc::clone(channel),
                    sequence: header.sequence,
                    log_time: header.log_time,
                    data: data.into_owned(),
                })?;
            }
            _ => {}
        }
        Ok(())
    })
}

/// What a finished file's summary section says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileSummary {
    /// Messages in the file.
    pub message_count: u64,
    /// Chunks in the file.
    pub chunk_count: usize,
    /// The names of the metadata records the summary indexes.
    pub metadata_names: Vec<String>,
    /// The names of the attachments the summary indexes.
    pub attachment_names: Vec<String>,
}

/// The summary section of the finished MCAP file in `bytes` (`None`: the file has none, as
/// a file cut at its last complete chunk).
///
/// # Errors
/// The summary section is damaged.
pub fn summary(bytes: &[u8]) -> anyhow::Result<Option<FileSummary>> {
    let Some(s) = mcap::Summary::read(bytes)? else {
        return Ok(None);
    };
    Ok(Some(FileSummary {
        message_count: s.stats.map_or(0, |st| st.message_count),
        chunk_count: s.chunk_indexes.len(),
        metadata_names: s.metadata_indexes.iter().map(|m| m.name.clone()).collect(),
        attachment_names: s
            .attachment_indexes
            .iter()
            .map(|a| a.name.clone())
            .collect(),
    }))
}

/// The metadata records and the names of the attachments of the MCAP file in `bytes`, in file
/// order, read from the records themselves (a cut file has no summary section to index them).
/// Chunks are skipped without decompressing them, so a damaged chunk does not hide what
/// follows it; a damaged record ends the list.
pub fn metadata(bytes: &[u8]) -> (Vec<Metadata>, Vec<String>) {
    let mut records = Vec::new();
    let mut attachments = Vec::new();
    let _ = for_each_record(bytes, Scope::TopLevel, |record| {
        match record {
            Record::Metadata(m) => records.push(Metadata {
                name: m.name,
                pairs: m.metadata,
            }),
            Record::Attachment { header, .. } => attachments.push(header.name),
            _ => {}
        }
        Ok(())
    });
    (records, attachments)
}

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
    /// The mission and the fence the robot ran with (metadata `navigation`; absent in logs
    /// written before it).
    pub navigation: Option<Navigation>,
    /// The realtime setup report, as text (metadata `rt_setup`).
    pub rt_setup: Option<String>,
    /// The totals at exit (metadata `summary`; absent in a cut file).
    pub summary: Option<SummaryRecord>,
    /// The ground link's counts at exit, as text (metadata `summary`).
    pub ground_link: Option<String>,
    /// The wake-up latency histogram in cyclictest's format (attachment).
    pub histogram: Option<String>,
    /// Every metadata record, in order.
    pub metadata: Vec<Metadata>,
    /// The names of the attachments, in order.
    pub attachments: Vec<String>,
    /// The files read, in order (empty when read from bytes).
    pub files: Vec<PathBuf>,
    /// What could not be read, for a warning.
    pub warnings: Vec<String>,
}

impl LoggedRun {
    /// Reads `path`. Errors only when nothing at all can be read.
    pub fn read(path: &Path) -> anyhow::Result<LoggedRun> {
        let bytes =
            std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
        let mut run =
            LoggedRun::from_bytes(&bytes).with_context(|| format!("{}", path.display()))?;
        run.files.push(path.to_path_buf());
        Ok(run)
    }

    /// Parses the bytes of an MCAP file written by `dima`.
    ///
    /// Any bytes give a result or an error: no length field in the file can size an allocation
    /// (see [`records`](crate::records)).
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
                Record::Metadata(m) => {
                    self.add_metadata(&m.name, &m.metadata);
                    self.metadata.push(Metadata {
                        name: m.name,
                        pairs: m.metadata,
                    });
                }
                Record::Attachment { header, data, .. } => {
                    if header.name == schema::ATTACHMENT_HISTOGRAM {
                        self.histogram = Some(String::from_utf8_lossy(&data).into_owned());
                    }
                    self.attachments.push(header.name);
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
            schema::METADATA_NAVIGATION => {
                if let Some(json) = pairs.get("json") {
                    match serde_json::from_str(json) {
                        Ok(n) => self.navigation = Some(n),
                        Err(e) => self.warnings.push(format!("navigation record: {e}")),
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
