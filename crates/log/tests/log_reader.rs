//! `dima log` reads any bytes as a log: a clear error or a result, never a panic, an abort on
//! allocation or a hang. The damaged files here are built by hand from the MCAP specification
//! (records: opcode, u64 LE length, body) and RFC 8878 (a zstd frame with one raw block), so
//! they do not depend on our own writer.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use dima_log::LoggedRun;

/// Records the largest single allocation a thread asks for while it is measuring.
struct LargestAllocation;

thread_local! {
    static MEASURING: Cell<bool> = const { Cell::new(false) };
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = MEASURING.try_with(|on| {
        if on.get() {
            let _ = LARGEST.try_with(|largest| largest.set(largest.get().max(size)));
        }
    });
}

// SAFETY: forwards to the system allocator; the bookkeeping touches only const-initialised
// thread-locals without destructors (no allocation, no re-entry).
unsafe impl GlobalAlloc for LargestAllocation {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: LargestAllocation = LargestAllocation;

/// Runs `f` and returns its result with the largest allocation it made on this thread.
fn largest_allocation<T>(f: impl FnOnce() -> T) -> (T, usize) {
    LARGEST.with(|largest| largest.set(0));
    MEASURING.with(|on| on.set(true));
    let out = f();
    MEASURING.with(|on| on.set(false));
    (out, LARGEST.with(Cell::get))
}

const MAGIC: &[u8] = b"\x89MCAP0\r\n";

fn record(opcode: u8, body: &[u8]) -> Vec<u8> {
    let mut bytes = vec![opcode];
    bytes.extend((body.len() as u64).to_le_bytes());
    bytes.extend(body);
    bytes
}

/// Magic and a Header record with an empty profile and library.
fn file_start() -> Vec<u8> {
    let mut bytes = MAGIC.to_vec();
    bytes.extend(record(0x01, &[0; 8]));
    bytes
}

fn error_text(bytes: &[u8]) -> String {
    match LoggedRun::from_bytes(bytes) {
        Ok(run) => panic!("read as a log: {run:?}"),
        Err(e) => format!("{e:#}"),
    }
}

#[test]
fn a_record_length_near_u64_max_is_an_error() {
    let mut bytes = file_start();
    // A Message record whose length field says almost 2^64 bytes follow.
    bytes.push(0x05);
    bytes.extend((u64::MAX - 4).to_le_bytes());
    bytes.extend([0u8; 32]);
    let text = error_text(&bytes);
    assert!(text.contains("no complete message"), "{text}");
    assert!(text.contains("exceeds limit"), "{text}");
}

#[test]
fn a_huge_record_inside_a_compressed_chunk_is_an_error_not_an_allocation() {
    // Inside the chunk: a Message record header announcing 2^60 bytes.
    let inner = [0x05, 0, 0, 0, 0, 0, 0, 0, 0x10];
    // zstd frame: magic, descriptor 0x20 (single segment, 1-byte content size), content size,
    // one raw block (last block, type raw, size 9), the bytes.
    let mut zstd = vec![
        0x28,
        0xB5,
        0x2F,
        0xFD,
        0x20,
        inner.len() as u8,
        0x49,
        0x00,
        0x00,
    ];
    zstd.extend(inner);
    let mut chunk = Vec::new();
    chunk.extend(0u64.to_le_bytes()); // message start time
    chunk.extend(0u64.to_le_bytes()); // message end time
    chunk.extend(((1u64 << 60) + 9).to_le_bytes()); // uncompressed size
    chunk.extend(0u32.to_le_bytes()); // uncompressed CRC (0: not checked)
    chunk.extend(4u32.to_le_bytes());
    chunk.extend(b"zstd");
    chunk.extend((zstd.len() as u64).to_le_bytes());
    chunk.extend(&zstd);
    let mut bytes = file_start();
    bytes.extend(record(0x06, &chunk));
    let text = error_text(&bytes);
    assert!(text.contains("no complete message"), "{text}");
    assert!(text.contains("exceeds limit"), "{text}");
}

#[test]
fn a_record_longer_than_its_uncompressed_chunk_is_an_error() {
    // Inside an uncompressed chunk of 9 record bytes: a Message record header announcing 16
    // bytes, which lie beyond the chunk (found by fuzzing: the reader's bookkeeping overflowed).
    let inner = [0x05, 16, 0, 0, 0, 0, 0, 0, 0];
    let mut chunk = Vec::new();
    chunk.extend(0u64.to_le_bytes()); // message start time
    chunk.extend(0u64.to_le_bytes()); // message end time
    chunk.extend((inner.len() as u64).to_le_bytes()); // uncompressed size
    chunk.extend(0u32.to_le_bytes()); // uncompressed CRC (0: not checked)
    chunk.extend(0u32.to_le_bytes()); // compression: none
    chunk.extend((inner.len() as u64).to_le_bytes());
    chunk.extend(inner);
    let mut bytes = file_start();
    bytes.extend(record(0x06, &chunk));
    // Bytes after the chunk for the overlong record to run into.
    bytes.extend(record(0x0F, &[0; 32]));
    let text = error_text(&bytes);
    assert!(text.contains("runs past the chunk's end"), "{text}");

    // The same chunk cut short by the end of the file (its record says 100 more bytes follow),
    // with the overlong record's 16 bytes the last ones of the file.
    let mut cut = file_start();
    cut.push(0x06);
    cut.extend((chunk.len() as u64 + 100).to_le_bytes());
    cut.extend(&chunk);
    cut.extend([0u8; 16]);
    let text = error_text(&cut);
    assert!(text.contains("runs past the chunk's end"), "{text}");
}

#[test]
fn a_string_length_beyond_its_record_does_not_size_an_allocation() {
    // A string's u32 length prefix says 3.75 GiB; four bytes follow.
    let mut huge_string = 0xF000_0000u32.to_le_bytes().to_vec();
    huge_string.extend(b"dima");
    // Metadata: name, then the map. Channel: id, schema id, then the topic.
    let mut channel = vec![1, 0, 0, 0];
    channel.extend(&huge_string);
    for (opcode, body) in [(0x0C, huge_string.clone()), (0x04, channel)] {
        let mut bytes = file_start();
        bytes.extend(record(opcode, &body));
        let (result, largest) = largest_allocation(|| LoggedRun::from_bytes(&bytes));
        assert!(
            largest < 1 << 20,
            "opcode {opcode:#04x}: an allocation of {largest} bytes"
        );
        let text = format!("{:#}", result.unwrap_err());
        assert!(text.contains("no complete message"), "{text}");
    }
}

#[test]
fn bytes_that_are_not_mcap_are_a_clear_error() {
    let text = error_text(b"this is a text file, not a log\n");
    assert!(text.contains("no complete message"), "{text}");
    assert!(text.to_lowercase().contains("magic"), "{text}");
}
