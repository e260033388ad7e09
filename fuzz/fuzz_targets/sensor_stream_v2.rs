//! `dima_sensorboard::StreamDecoderV2` on any bytes: v2 packets, GNSS pieces and info pieces.
//!
//! Beyond "no panic":
//! - the same bytes read whole, one byte at a time ([`StreamDecoderV2::push`]) and in reads of
//!   random sizes give the same frames and the same counters;
//! - every byte is accounted for: packets x 42 + GNSS pieces x 34 + info pieces x 21 + skipped
//!   + held bytes = input, and the buffer never holds more than one packet;
//! - a frame is handed out for each packet, reassembled NAV-PVT frame and info record, and for
//!   nothing else;
//! - a decoded packet encodes back to a packet with the same values;
//! - a reassembled NAV-PVT frame is the payloads of valid pieces 0, 1, 2, 3 of one epoch that
//!   appear in the input in that order (a reference scan for valid pieces at every offset):
//!   never a mix of two epochs, never out of order.
#![no_main]

use dima_fuzz::chunks;
use dima_sensorboard::{
    DecoderStatsV2, FrameV2, GnssFrame, GnssPiece, PacketV2, Stm32Crc, StreamDecoderV2,
    GNSS_PIECE_LEN, GNSS_PIECE_START, INFO_PIECE_LEN, PACKET_V2_LEN,
};
use libfuzzer_sys::fuzz_target;

/// What one way of reading the input produced.
#[derive(Debug, PartialEq)]
struct Run {
    frames: Vec<FrameV2>,
    stats: DecoderStatsV2,
    held: usize,
}

fn finish(mut decoder: StreamDecoderV2, frames: Vec<FrameV2>, input_len: usize) -> Run {
    assert!(
        decoder.next_buffered().is_none(),
        "a complete frame was left in the buffer"
    );
    let held = decoder.buffered_len();
    assert!(held <= StreamDecoderV2::CAPACITY);
    assert_eq!(StreamDecoderV2::CAPACITY, PACKET_V2_LEN);
    let s = decoder.stats();
    assert_eq!(
        s.packets * PACKET_V2_LEN as u64
            + s.gnss_pieces * GNSS_PIECE_LEN as u64
            + s.info_pieces * INFO_PIECE_LEN as u64
            + s.bytes_skipped
            + held as u64,
        input_len as u64,
        "{s:?}"
    );
    assert_eq!(
        s.packets + s.gnss_frames + s.info_frames,
        frames.len() as u64
    );
    Run {
        frames,
        stats: s,
        held,
    }
}

fn by_reads(reads: &[&[u8]], input_len: usize) -> Run {
    let mut decoder = StreamDecoderV2::new();
    let mut frames = Vec::new();
    for read in reads {
        let mut input: &[u8] = read;
        while let Some(frame) = decoder.feed(&mut input) {
            frames.push(frame);
        }
        assert!(
            input.is_empty(),
            "feed returned None before the read was used up"
        );
    }
    finish(decoder, frames, input_len)
}

fn by_bytes(data: &[u8]) -> Run {
    let mut decoder = StreamDecoderV2::new();
    let mut frames = Vec::new();
    for &byte in data {
        let mut frame = decoder.push(byte);
        while let Some(f) = frame {
            frames.push(f);
            frame = decoder.next_buffered();
        }
    }
    finish(decoder, frames, data.len())
}

/// Every valid GNSS piece anywhere in `data`, in order of position (including pieces the
/// decoder never saw because they lie inside other frames).
fn valid_pieces(data: &[u8]) -> Vec<GnssPiece> {
    (0..data.len())
        .filter(|&at| data[at..].starts_with(&GNSS_PIECE_START))
        .filter_map(|at| GnssPiece::decode_with(&data[at..], &mut Stm32Crc).ok())
        .collect()
}

/// Whether `frame` is the payloads of pieces 0, 1, 2, 3 of one epoch that appear in `pieces`
/// in that order.
fn made_of_one_epoch(frame: &GnssFrame, pieces: &[GnssPiece]) -> bool {
    let part = |k: usize| &frame.as_bytes()[25 * k..25 * k + 25];
    pieces.iter().enumerate().any(|(start, first)| {
        if first.index != 0 || first.payload != part(0) {
            return false;
        }
        let mut next = 1;
        for p in &pieces[start + 1..] {
            if next < 4
                && p.epoch == first.epoch
                && usize::from(p.index) == next
                && p.payload == part(next)
            {
                next += 1;
            }
        }
        next == 4
    })
}

fuzz_target!(|data: &[u8]| {
    let whole = by_reads(&[data], data.len());
    assert_eq!(by_bytes(data), whole, "one byte at a time");
    assert_eq!(
        by_reads(&chunks(data, 100, 2), data.len()),
        whole,
        "random reads"
    );
    let mut pieces = None;
    for frame in &whole.frames {
        match frame {
            FrameV2::Packet(raw) => {
                let packet = raw.decode();
                assert_eq!(PacketV2::decode(&packet.encode(&mut Stm32Crc)), Ok(packet));
            }
            FrameV2::Gnss(frame) => {
                let pieces = pieces.get_or_insert_with(|| valid_pieces(data));
                assert!(
                    made_of_one_epoch(frame, pieces),
                    "a NAV-PVT frame not made of pieces 0-3 of one epoch"
                );
            }
            FrameV2::Info(_) => {}
        }
    }
    let _ = whole.held;
});
