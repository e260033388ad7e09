//! Writing a log: [`McapLog`], one MCAP file with its channels declared up front, and
//! [`RunWriter`], a run across files: split by duration, resumed in a new file after a write
//! failed (a full disk: ENOSPC, or any I/O error), with every record that could not be logged
//! counted.
//!
//! Chunks are zstd-compressed on the writing thread itself and end at every
//! [`flush`](McapLog::flush) or after [`CHUNK_BYTES`]. A file whose writes fail is ended at
//! its last complete chunk (Data End and a footer without summary), so it stays a valid MCAP
//! file, and the run goes on in `NAME-1.mcap`, `NAME-2.mcap`, ... (see
//! [`naming`](crate::naming)), which start with the run's header metadata and a
//! [`METADATA_LOG_RESUMED`] or [`METADATA_LOG_CONTINUED`] note.
//!
//! A [`Tap`] attached to the writer sees every channel it declares and every message it
//! writes, on the writing thread: the seam for a live view.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::Context;

use crate::naming::log_file_name;
use crate::schema::{self, ChannelSpec};

/// Metadata record at the start of a resumed file: `previous_file`, `error`,
/// `records_not_logged`.
pub const METADATA_LOG_RESUMED: &str = "log_resumed";

/// Metadata record at the start of a file that continues the previous one after the split by
/// duration: `previous_file`.
pub const METADATA_LOG_CONTINUED: &str = "log_continued";

/// How often a failed log, or a split that could not open the next file, is retried.
pub const LOG_RETRY: Duration = Duration::from_secs(1);

/// A chunk is ended once this many uncompressed bytes went into it, even before the next
/// flush. zstd compresses each chunk as one frame through an input buffer of its 2 MiB window,
/// and the process's resident memory keeps the largest part of that buffer a chunk ever
/// filled: a second of 250 Hz records is about 400 KB, but the backlog after a stalled disk
/// would fill more. Bounded here, a long run's memory stays flat.
pub const CHUNK_BYTES: u64 = 512 * 1024;

/// Metadata pairs by record name: what every file of a run starts with.
pub type Header = Vec<(String, Vec<(&'static str, String)>)>;

/// Receives what a writer writes, on the writing thread, as it writes it: the seam for a live
/// view of the log.
///
/// [`channel`](Tap::channel) is called for every channel of every file, before any message
/// on it (a run's next file declares its channels again, with the same ids);
/// [`message`](Tap::message) for every message that went to the writer. Messages written
/// while a run's file has failed do not reach the tap. A tap must not block: it runs between
/// the writer's records.
pub trait Tap: Send {
    /// A channel was declared: its id, topic, schema (name, encoding and text; all empty for
    /// a channel without schema) and message encoding.
    fn channel(
        &mut self,
        id: u16,
        topic: &str,
        schema_name: &str,
        schema_encoding: &str,
        schema: &[u8],
        message_encoding: &str,
    );

    /// A message was written on channel `channel_id` at `log_time_ns` (Unix-epoch ns).
    fn message(&mut self, channel_id: u16, log_time_ns: u64, data: &[u8]);
}

/// A channel to declare: its spec, and its JSON schema when it has one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Channel {
    /// Topic, message encoding and schema name.
    pub spec: ChannelSpec,
    /// The schema text (`jsonschema`); `None` for a channel without schema.
    pub schema: Option<String>,
}

impl Channel {
    /// A JSON channel whose schema is generated from `T`.
    pub fn json<T: schemars::JsonSchema>(spec: ChannelSpec) -> Channel {
        Channel {
            spec,
            schema: Some(schema::json_schema::<T>()),
        }
    }

    /// The robot's channels ([`schema::CHANNELS`]), with their schemas.
    pub fn robot() -> Vec<Channel> {
        schema::CHANNELS
            .iter()
            .map(|spec| Channel {
                spec: *spec,
                schema: schema::schema_of(spec),
            })
            .collect()
    }
}

/// Wall-clock ns minus CLOCK_MONOTONIC ns now: what turns a monotonic time into a log time.
pub fn wall_minus_monotonic_ns() -> i128 {
    let wall = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as i128);
    wall - i128::from(monotonic_ns())
}

/// CLOCK_MONOTONIC, ns.
pub fn monotonic_ns() -> u64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec to write to; CLOCK_MONOTONIC exists on every Linux.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut t) } == 0;
    if ok {
        (t.tv_sec as u64)
            .saturating_mul(1_000_000_000)
            .saturating_add(t.tv_nsec as u64)
    } else {
        0
    }
}

/// The file under the MCAP writer: the file itself, and an injected full disk (for a
/// simulation: ENOSPC while the flag is set; never set on the robot).
struct LogFile {
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

impl Write for LogFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        check_disk(&self.full)?;
        self.file.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        check_disk(&self.full)?;
        self.file.flush()
    }
}

impl Seek for LogFile {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.file.seek(pos)
    }
}

/// How a file is opened: its channels, the injected full disk, the clock.
#[derive(Clone)]
struct FileSetup {
    channels: Vec<Channel>,
    full: Arc<AtomicBool>,
    epoch_offset_ns: i128,
}

/// One MCAP file being written, its channels declared when it is created.
pub struct McapLog {
    writer: mcap::Writer<BufWriter<LogFile>>,
    /// Length of the file at the last successful flush: complete records only.
    flushed_len: u64,
    /// Records counted since the last successful flush: lost if the file has to be cut back
    /// to `flushed_len`.
    unflushed_records: u64,
    setup: FileSetup,
    /// Channel ids, in the order of `setup.channels`.
    ids: Vec<u16>,
    path: PathBuf,
    sequence: u32,
    /// When the file was created (for the split by duration).
    opened: Instant,
    tap: Option<Box<dyn Tap>>,
}

impl McapLog {
    /// Creates `dir` if needed and a new file named for the time now
    /// ([`log_file_name`]) with the robot's channels.
    ///
    /// # Errors
    /// The directory or the file cannot be created or written.
    pub fn create(dir: &Path) -> anyhow::Result<McapLog> {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("log: cannot create directory {}", dir.display()))?;
        McapLog::create_file(&dir.join(log_file_name(SystemTime::now())))
    }

    /// Creates the file at `path` with the robot's channels.
    ///
    /// # Errors
    /// The file cannot be created or written.
    pub fn create_file(path: &Path) -> anyhow::Result<McapLog> {
        McapLog::create_with_channels(path, Channel::robot())
    }

    /// Creates the file at `path` declaring `channels`, in order.
    ///
    /// # Errors
    /// The file cannot be created or written.
    pub fn create_with_channels(path: &Path, channels: Vec<Channel>) -> anyhow::Result<McapLog> {
        McapLog::open(
            path,
            FileSetup {
                channels,
                full: Arc::new(AtomicBool::new(false)),
                epoch_offset_ns: wall_minus_monotonic_ns(),
            },
            None,
        )
    }

    fn open(path: &Path, setup: FileSetup, tap: Option<Box<dyn Tap>>) -> anyhow::Result<McapLog> {
        check_disk(&setup.full)
            .with_context(|| format!("log: cannot create {}", path.display()))?;
        let file = LogFile {
            file: File::create(path)
                .with_context(|| format!("log: cannot create {} (writable?)", path.display()))?,
            full: Arc::clone(&setup.full),
        };
        check_disk(&file.full).with_context(|| format!("log: cannot write {}", path.display()))?;
        let writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            // Compressed on the writing thread itself. `mcap` would otherwise start a zstd
            // worker per CPU with buffers of about 40 MB, whose pages the process touches
            // bit by bit over a long run; a few tens of KB a second need no workers, and on
            // the robot they would compete with the control loop for the cores.
            .compression_threads(0)
            .chunk_size(Some(CHUNK_BYTES))
            .profile("")
            .create(BufWriter::new(file))
            .context("log: starting the MCAP file")?;
        let mut log = McapLog {
            writer,
            flushed_len: 0,
            unflushed_records: 0,
            setup,
            ids: Vec::new(),
            path: path.to_owned(),
            sequence: 0,
            opened: Instant::now(),
            tap,
        };
        log.declare_channels()?;
        // The header, schemas and channels on the disk at once: a file that fails later can
        // be cut back to complete records.
        log.flush()?;
        Ok(log)
    }

    fn declare_channels(&mut self) -> anyhow::Result<()> {
        let none = BTreeMap::new();
        for c in &self.setup.channels {
            let schema_id = match &c.schema {
                Some(text) => {
                    self.writer
                        .add_schema(c.spec.schema_name, "jsonschema", text.as_bytes())?
                }
                None => 0,
            };
            let id = self
                .writer
                .add_channel(schema_id, c.spec.topic, c.spec.encoding, &none)?;
            self.ids.push(id);
        }
        self.announce_channels();
        Ok(())
    }

    /// Tells the tap every channel of the file.
    fn announce_channels(&mut self) {
        let Some(tap) = self.tap.as_mut() else { return };
        for (c, &id) in self.setup.channels.iter().zip(&self.ids) {
            let (encoding, text) = match &c.schema {
                Some(text) => ("jsonschema", text.as_bytes()),
                None => ("", &[][..]),
            };
            tap.channel(
                id,
                c.spec.topic,
                c.spec.schema_name,
                encoding,
                text,
                c.spec.encoding,
            );
        }
    }

    /// Attaches `tap`: it is told the file's channels at once, then every message.
    pub fn set_tap(&mut self, tap: Box<dyn Tap>) {
        self.tap = Some(tap);
        self.announce_channels();
    }

    /// Detaches the tap.
    pub fn take_tap(&mut self) -> Option<Box<dyn Tap>> {
        self.tap.take()
    }

    /// Log times from now on are `mono_ns + offset_ns` instead of the wall clock's reading of
    /// CLOCK_MONOTONIC: a simulation in virtual time passes a fixed offset, so the file does
    /// not depend on when it was written (the files a run continues in keep it).
    pub fn set_time_offset(&mut self, offset_ns: i128) {
        self.setup.epoch_offset_ns = offset_ns;
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The log time of monotonic time `mono_ns`, Unix-epoch ns.
    pub fn log_time(&self, mono_ns: u64) -> u64 {
        (i128::from(mono_ns) + self.setup.epoch_offset_ns).max(0) as u64
    }

    /// The id of the channel declared for `spec`'s topic.
    pub fn channel_id(&self, spec: &ChannelSpec) -> Option<u16> {
        self.setup
            .channels
            .iter()
            .position(|c| c.spec.topic == spec.topic)
            .map(|i| self.ids[i])
    }

    /// Writes a message on the channel of `spec` at monotonic time `mono_ns`.
    ///
    /// # Errors
    /// The channel was not declared, or the write failed.
    pub fn message_on(
        &mut self,
        spec: &ChannelSpec,
        mono_ns: u64,
        data: &[u8],
    ) -> anyhow::Result<()> {
        let id = self
            .channel_id(spec)
            .with_context(|| format!("log: no channel {}", spec.topic))?;
        self.message(id, mono_ns, data)
    }

    /// Writes a message on channel `channel_id` at monotonic time `mono_ns`.
    ///
    /// # Errors
    /// The write failed.
    pub fn message(&mut self, channel_id: u16, mono_ns: u64, data: &[u8]) -> anyhow::Result<()> {
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
        if let Some(tap) = self.tap.as_mut() {
            tap.message(channel_id, t, data);
        }
        Ok(())
    }

    /// Counts one record (of one or more messages) as written: it is lost, and counted so, if
    /// the file has to be cut back to its last flush.
    pub fn count_record(&mut self) {
        self.unflushed_records += 1;
    }

    /// A metadata record of string pairs.
    ///
    /// # Errors
    /// The write failed.
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

    /// Ends the current chunk and flushes it to the file.
    ///
    /// # Errors
    /// The write failed.
    pub fn flush(&mut self) -> anyhow::Result<()> {
        self.writer.flush()?;
        self.flushed_len = std::fs::metadata(&self.path)?.len();
        self.unflushed_records = 0;
        Ok(())
    }

    /// Adds an attachment (e.g. the latency histogram), at the time now.
    ///
    /// # Errors
    /// The write failed.
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
    ///
    /// # Errors
    /// Any of it did not reach the file.
    pub fn finish(mut self) -> anyhow::Result<PathBuf> {
        self.writer.finish()?;
        self.writer
            .into_inner()
            .flush()
            .with_context(|| format!("log: finishing {}", self.path.display()))?;
        Ok(self.path)
    }
}

/// The MCAP end of a file cut at a complete record boundary: Data End and a Footer without a
/// summary section, then the magic.
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

mod run_writer;

pub use run_writer::RunWriter;
