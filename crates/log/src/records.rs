//! The records of an MCAP file held in memory, read with bounded allocations: the one walk
//! over a file's records that every reader in [`reader`](crate::reader) builds on.
//!
//! Two length fields could otherwise size an allocation from a damaged file: a record's own
//! length (a chunk's records are decompressed into a buffer of that size), and the u32 length
//! prefix of a string, which the `mcap` crate's parser reserves before reading the string. Here
//! no record may be longer than [`MAX_RECORD_LEN`], every length prefix of the records the log
//! tools read is checked against the record before it is parsed, other records are never
//! parsed at all, and every record inside an uncompressed chunk must fit the chunk before the
//! reader descends into it (the `mcap` reader's bookkeeping overflows otherwise).

use mcap::records::{op, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// The longest record read from a log, bytes (a decompressed record inside a chunk included).
/// `dima` writes records of a few KB; a longer length field is damage, not data.
pub const MAX_RECORD_LEN: usize = 64 << 20;

/// Which records [`for_each_record`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// Schemas, channels and messages: the chunks are decompressed and the records inside
    /// them read.
    InsideChunks,
    /// Metadata and attachments: the chunks are skipped whole, without decompressing them.
    TopLevel,
}

impl Scope {
    fn reads(self, opcode: u8) -> bool {
        match self {
            Scope::InsideChunks => matches!(opcode, op::SCHEMA | op::CHANNEL | op::MESSAGE),
            Scope::TopLevel => matches!(opcode, op::METADATA | op::ATTACHMENT),
        }
    }
}

/// Calls `on_record` with each record of the MCAP file in `bytes` that `scope` reads, in file
/// order, up to its data end record or the end of a cut file.
///
/// # Errors
/// The first damaged record (or what `on_record` returns); `on_record` has seen every record
/// before it.
pub fn for_each_record(
    bytes: &[u8],
    scope: Scope,
    mut on_record: impl FnMut(Record<'_>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    if scope == Scope::InsideChunks {
        // Before the reader descends into the chunks: `mcap` 0.26's reader subtracts a record's
        // length from what is left of its uncompressed chunk unchecked, and overflows when a
        // damaged record is longer than the chunk.
        uncompressed_chunks_fit(bytes)?;
    }
    walk(bytes, scope == Scope::TopLevel, |opcode, data| {
        if !scope.reads(opcode) {
            return Ok(());
        }
        if !length_prefixes_fit(opcode, data) {
            anyhow::bail!(
                "record {opcode:#04x} of {} bytes: a length field runs past its end",
                data.len()
            );
        }
        on_record(mcap::parse_record(opcode, data)?)
    })
}

/// Hands each record's opcode and body to `on_record` in file order, up to the data end record
/// or the end of a cut file; with `emit_chunks` chunks are records of their own, without it
/// the records inside them are.
fn walk(
    bytes: &[u8],
    emit_chunks: bool,
    mut on_record: impl FnMut(u8, &[u8]) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_end_magic(true)
            .with_emit_chunks(emit_chunks)
            .with_record_length_limit(MAX_RECORD_LEN),
    );
    let mut rest = bytes;
    while let Some(event) = reader.next_event() {
        match event? {
            LinearReadEvent::ReadRequest(need) => {
                let (now, later) = rest.split_at(need.min(rest.len()));
                reader.insert(now.len()).copy_from_slice(now);
                reader.notify_read(now.len());
                rest = later;
            }
            LinearReadEvent::Record {
                opcode: op::DATA_END,
                ..
            } => break,
            LinearReadEvent::Record { opcode, data } => on_record(opcode, data)?,
        }
    }
    Ok(())
}

/// Whether every record inside each uncompressed chunk of the file lies within its chunk's
/// declared records length (a compressed chunk's records are bounded by the reader's own checks
/// of the decompressed size). Walks the top-level records by their length fields, as the reader
/// does, and a chunk cut short by the end of the file as far as it goes.
fn uncompressed_chunks_fit(bytes: &[u8]) -> anyhow::Result<()> {
    const MAGIC_LEN: usize = 8;
    let mut file = Body(bytes.get(MAGIC_LEN..).unwrap_or_default());
    while let (Some(opcode), Some(len)) = (file.take(1), file.u64_len()) {
        let body = file.take(len).unwrap_or_else(|| file.rest());
        match opcode[0] {
            op::DATA_END => break,
            op::CHUNK if !chunk_records_fit(body) => {
                anyhow::bail!("chunk of {len} bytes: a record inside it runs past the chunk's end")
            }
            _ => {}
        }
    }
    Ok(())
}

/// Whether the records of an uncompressed chunk (`chunk`: its body, maybe cut short) fit in its
/// declared records length; `true` for a compressed chunk.
fn chunk_records_fit(chunk: &[u8]) -> bool {
    let mut body = Body(chunk);
    // Message start and end time, uncompressed size, uncompressed CRC, then the compression.
    if !body.skip(28) {
        return true;
    }
    match body.prefixed() {
        Some([]) => {}
        _ => return true,
    }
    let Some(mut declared) = body.u64_len() else {
        return true;
    };
    while let (Some(_opcode), Some(len)) = (body.take(1), body.u64_len()) {
        match declared.checked_sub(len.saturating_add(9)) {
            Some(left) => declared = left,
            None => return false,
        }
        if declared == 0 || body.take(len).is_none() {
            break;
        }
    }
    true
}

/// Whether every length-prefixed string and map in the record's body lies within the body
/// (record layouts of the MCAP specification).
fn length_prefixes_fit(opcode: u8, body: &[u8]) -> bool {
    let mut body = Body(body);
    match opcode {
        // id; name, encoding, data.
        op::SCHEMA => body.skip(2) && body.string() && body.string() && body.string(),
        // id, schema id; topic, message encoding, metadata.
        op::CHANNEL => body.skip(4) && body.string() && body.string() && body.string_map(),
        // name, metadata.
        op::METADATA => body.string() && body.string_map(),
        // log time, create time; name, media type (the data's u64 length is checked by `mcap`).
        op::ATTACHMENT => body.skip(16) && body.string() && body.string(),
        // A message has a fixed header and its data is the rest of the record.
        _ => true,
    }
}

/// The unread part of a record's body.
struct Body<'a>(&'a [u8]);

impl<'a> Body<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let (head, tail) = self.0.split_at_checked(n)?;
        self.0 = tail;
        Some(head)
    }

    fn skip(&mut self, n: usize) -> bool {
        self.take(n).is_some()
    }

    /// Everything left.
    fn rest(&mut self) -> &'a [u8] {
        core::mem::take(&mut self.0)
    }

    /// A little-endian u64 length that fits a `usize`.
    fn u64_len(&mut self) -> Option<usize> {
        usize::try_from(u64::from_le_bytes(self.take(8)?.try_into().ok()?)).ok()
    }

    /// A u32 length prefix and that many bytes.
    fn prefixed(&mut self) -> Option<&'a [u8]> {
        let len = u32::from_le_bytes(self.take(4)?.try_into().ok()?);
        self.take(usize::try_from(len).ok()?)
    }

    fn string(&mut self) -> bool {
        self.prefixed().is_some()
    }

    /// A u32 byte length, then key and value strings within it.
    fn string_map(&mut self) -> bool {
        let Some(map) = self.prefixed() else {
            return false;
        };
        let mut entries = Body(map);
        while !entries.0.is_empty() {
            if !(entries.string() && entries.string()) {
                return false;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn string(s: &str) -> Vec<u8> {
        let mut out = (s.len() as u32).to_le_bytes().to_vec();
        out.extend(s.as_bytes());
        out
    }

    #[test]
    fn prefixes_within_the_record_fit_and_one_byte_more_does_not() {
        let mut map = string("version");
        map.extend(string("0.1.0"));
        let mut metadata = string("dima");
        metadata.extend((map.len() as u32).to_le_bytes());
        metadata.extend(&map);
        assert!(length_prefixes_fit(op::METADATA, &metadata));
        assert!(!length_prefixes_fit(
            op::METADATA,
            &metadata[..metadata.len() - 1]
        ));
        // A map whose byte length cuts its last value short.
        let mut short = string("dima");
        short.extend((map.len() as u32 - 1).to_le_bytes());
        short.extend(&map);
        assert!(!length_prefixes_fit(op::METADATA, &short));
        let mut channel = vec![1, 0, 0, 0];
        channel.extend(string("/dima/cycle"));
        channel.extend(string("json"));
        channel.extend(0u32.to_le_bytes());
        assert!(length_prefixes_fit(op::CHANNEL, &channel));
        assert!(!length_prefixes_fit(
            op::CHANNEL,
            &channel[..channel.len() - 1]
        ));
    }
}
