//! Ground-link display stream on any bytes: `dima_groundlink::DisplayDecoder` (v1), the v2
//! `DisplayDecoder` with a fixed key, and the `DownlinkDecoder` of display frames v2 and v3.
//!
//! Beyond "no panic", for v1:
//! - the same bytes fed whole, one byte at a time and in reads of random sizes give the same
//!   results and the same counters;
//! - every byte is accounted for: 68 bytes per frame delivered or rejected for its range, plus
//!   the bytes slid past (after `reset`, which counts the partial window as skipped);
//! - a delivered frame passes its range checks and re-encodes to bytes that decode to it.
//!
//! For v2 (key [`LINK_KEY`]): the decoder delivers exactly the authentic frames a reference scan
//! finds (every offset tried, an authentic frame taken whole, anything else costing one byte);
//! 126 bytes per frame, plus skipped and pending bytes, add up to the input; a delivered frame
//! re-encodes to bytes that decode to it.
//!
//! For v2 and v3 together (`v2::DownlinkDecoder`, key [`LINK_KEY`]): its v2 frames are exactly
//! those of the v2 decoder; frames (126 or 156 bytes each), skipped and pending bytes add up
//! to the input; a delivered v3 frame re-encodes to bytes that decode to it.
#![no_main]

use dima_fuzz::{chunks, LINK_KEY};
use dima_groundlink::v2::{self, FrameError, LinkKey};
use dima_groundlink::{
    DisplayDecoder, DisplayError, DisplayFrame, DisplayStats, DISPLAY_FRAME_LEN,
};
use libfuzzer_sys::fuzz_target;

type Results = Vec<Result<DisplayFrame, DisplayError>>;

fn by_reads(reads: &[&[u8]]) -> (Results, DisplayStats) {
    let mut decoder = DisplayDecoder::new();
    let mut results = Vec::new();
    for read in reads {
        results.extend(decoder.feed(read));
    }
    decoder.reset();
    (results, decoder.stats())
}

fn by_bytes(data: &[u8]) -> (Results, DisplayStats) {
    let mut decoder = DisplayDecoder::new();
    let results = data.iter().filter_map(|&b| decoder.push(b)).collect();
    decoder.reset();
    (results, decoder.stats())
}

fn check_v1(data: &[u8]) {
    let whole = by_reads(&[data]);
    let (results, stats) = &whole;
    let framed = (stats.frames + stats.out_of_range) as usize;
    assert_eq!(
        framed * DISPLAY_FRAME_LEN + stats.skipped_bytes as usize,
        data.len(),
        "{stats:?}"
    );
    assert_eq!(results.len(), framed);
    for result in results {
        match result {
            Ok(frame) => {
                assert_eq!(frame.validate(), Ok(()));
                assert_eq!(DisplayFrame::decode(&frame.encode()), Ok(*frame));
            }
            Err(DisplayError::OutOfRange { .. }) => {}
            Err(error) => panic!("the decoder handed out {error:?}"),
        }
    }
    assert_eq!(by_bytes(data), whole, "one byte at a time");
    assert_eq!(by_reads(&chunks(data, 100, 1)), whole, "random reads");
}

/// The authentic v2 frames in `data`, by trying every offset.
fn reference_v2(data: &[u8], key: &LinkKey) -> Vec<Result<v2::DisplayFrame, FrameError>> {
    let mut found = Vec::new();
    let mut at = 0;
    while let Some(window) = data.get(at..at + v2::DISPLAY_FRAME_LEN) {
        let window: &[u8; v2::DISPLAY_FRAME_LEN] = window.try_into().unwrap();
        match v2::DisplayFrame::decode(window, key) {
            Err(FrameError::BadStart | FrameError::BadLength { .. } | FrameError::BadTag) => {
                at += 1;
                continue;
            }
            authentic => found.push(authentic),
        }
        at += v2::DISPLAY_FRAME_LEN;
    }
    found
}

fn check_v2(data: &[u8]) {
    let key = LinkKey::from_bytes(LINK_KEY);
    let mut decoder = v2::DisplayDecoder::new(key.clone());
    let results: Vec<_> = decoder.feed(data).collect();
    let stats = decoder.stats();
    let bad_tags = results
        .iter()
        .filter(|r| **r == Err(FrameError::BadTag))
        .count();
    assert_eq!(bad_tags, stats.bad_tag as usize);
    let authentic: Vec<_> = results
        .into_iter()
        .filter(|r| *r != Err(FrameError::BadTag))
        .collect();
    assert_eq!(authentic, reference_v2(data, &key));
    assert_eq!(
        stats.frames as usize * v2::DISPLAY_FRAME_LEN
            + stats.skipped_bytes as usize
            + decoder.pending(),
        data.len(),
        "{stats:?}"
    );
    for frame in authentic.iter().flatten() {
        assert_eq!(
            v2::DisplayFrame::decode(&frame.encode(&key), &key),
            Ok(*frame)
        );
    }
}

fn check_downlink(data: &[u8]) {
    let key = LinkKey::from_bytes(LINK_KEY);
    let mut decoder = v2::DownlinkDecoder::new(key.clone());
    let results: Vec<_> = decoder.feed(data).collect();
    let mut v2_only = v2::DisplayDecoder::new(key.clone());
    let v2_frames: Vec<_> = v2_only.feed(data).filter_map(Result::ok).collect();
    let from_downlink: Vec<_> = results
        .iter()
        .filter_map(|r| match r {
            Ok(v2::Downlink::V2(frame)) => Some(*frame),
            _ => None,
        })
        .collect();
    assert_eq!(from_downlink, v2_frames);
    let stats = decoder.stats();
    let (mut n2, mut n3) = (0, 0);
    for frame in results.iter().flatten() {
        match frame {
            v2::Downlink::V2(_) => n2 += 1,
            v2::Downlink::V3(frame) => {
                n3 += 1;
                assert_eq!(
                    v2::DisplayFrameV3::decode(&frame.encode(&key), &key),
                    Ok(*frame)
                );
            }
        }
    }
    assert_eq!(n2 + n3, stats.frames as usize);
    assert_eq!(
        n2 * v2::DISPLAY_FRAME_LEN
            + n3 * v2::DISPLAY_V3_FRAME_LEN
            + stats.skipped_bytes as usize
            + decoder.pending(),
        data.len(),
        "{stats:?}"
    );
}

fuzz_target!(|data: &[u8]| {
    check_v1(data);
    check_v2(data);
    check_downlink(data);
});
