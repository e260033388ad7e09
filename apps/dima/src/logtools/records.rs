//! The records of an MCAP file held in memory, read with bounded allocations.
//!
//! Two length fields could otherwise size an allocation from a damaged file: a record's own
//! length (a chunk's records are decompressed into a buffer of that size), and the u32 length
//! prefix of a string, which the `mcap` crate's parser reserves before reading the string. Here
//! no record may be longer than [`MAX_RECORD_LEN`], every length prefix of the records the log
//! tools read is checked against the record before it is parsed, and other records are never
//! parsed at all.

use mcap::records::{op, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// The longest record read from a log, bytes (a decompressed record inside a chunk included).
/// `dima` writes records of a few KB; a longer length field is damage, not data.
pub const MAX_RECORD_LEN: usize = 64 << 20;

/// Which records [`for_each_record`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// Channels and messages: the chunks are decompressed and the records inside them read.
    InsideChunks,
    /// Metadata and attachments: the chunks are skipped whole, without decompressing them.
    TopLevel,
}

impl Scope {
    fn reads(self, opcode: u8) -> bool {
        match self {
            Scope::InsideChunks => matches!(opcode, op::CHANNEL | op::MESSAGE),
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
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_end_magic(true)
            .with_emit_chunks(scope == Scope::TopLevel)
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
            LinearReadEvent::Record { opcode, data } => {
                if !scope.reads(opcode) {
                    continue;
                }
                if !length_prefixes_fit(opcode, data) {
                    anyhow::bail!(
                        "record {opcode:#04x} of {} bytes: a length field runs past its end",
                        data.len()
                    );
                }
                on_record(mcap::parse_record(opcode, data)?)?;
            }
        }
    }
    Ok(())
}

/// Whether every length-prefixed string and map in the record's body lies within the body
/// (record layouts of the MCAP specification).
fn length_prefixes_fit(opcode: u8, body: &[u8]) -> bool {
    let mut body = Body(body);
    match opcode {
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
