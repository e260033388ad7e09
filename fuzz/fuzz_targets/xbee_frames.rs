//! The XBee API frame decoder (`xbee_driver::FrameDecoder`) in API mode 1 and 2 (escaped), and
//! the typed frame parser (`Frame::parse`), on any bytes.
//!
//! Beyond "no panic":
//! - every delivered frame re-encodes (`encode_raw`) to bytes that a fresh decoder reads back
//!   as exactly that frame, with nothing dropped;
//! - a frame that parses as a typed frame encodes back to the same bytes, and its length field
//!   matches;
//! - bytes are accounted for: frames (with delimiter, length and checksum) plus discarded bytes
//!   never exceed the input, and in API 1 what is left is no more than the decoder holds.
#![no_main]

use libfuzzer_sys::fuzz_target;
use xbee_driver::{encode, encode_raw, ApiEscaping, DecoderStats, Frame, FrameDecoder};

const N: usize = 256;

fn decode(data: &[u8], escaping: ApiEscaping) -> (Vec<Vec<u8>>, DecoderStats) {
    let mut decoder = FrameDecoder::<N>::new(escaping);
    let mut frames = Vec::new();
    for &byte in data {
        if let Some(frame) = decoder.push(byte) {
            frames.push(frame.data().to_vec());
            while let Some(frame) = decoder.next_buffered() {
                frames.push(frame.data().to_vec());
            }
        }
    }
    (frames, decoder.stats())
}

/// A typed frame writes the bytes it was parsed from.
fn check_typed(frame_data: &[u8]) {
    let Ok(frame) = Frame::parse(frame_data) else {
        return;
    };
    if frame_data.len() > usize::from(u16::MAX) {
        return; // longer than the length field: not a frame on the wire
    }
    assert_eq!(frame.data_len(), frame_data.len());
    assert_eq!(frame.frame_type(), frame_data[0]);
    let _ = frame.frame_id();
    if let Frame::AtResponse(r) = &frame {
        let _ = r.number();
    }
    for escaping in [ApiEscaping::Unescaped, ApiEscaping::Escaped] {
        let mut typed = vec![0u8; 2 * frame_data.len() + 8];
        let mut raw = vec![0u8; 2 * frame_data.len() + 8];
        let n = encode(&frame, escaping, &mut typed).expect("encode a parsed frame");
        let m = encode_raw(frame_data, escaping, &mut raw).expect("encode its bytes");
        assert_eq!(typed[..n], raw[..m]);
    }
}

fn check_mode(data: &[u8], escaping: ApiEscaping) {
    let (frames, stats) = decode(data, escaping);
    assert_eq!(frames.len(), stats.frames as usize);
    let mut in_frames = 0usize;
    for frame_data in &frames {
        assert!(!frame_data.is_empty() && frame_data.len() <= N - 4);
        in_frames += frame_data.len() + 4;
        let mut wire = vec![0u8; 2 * N + 8];
        let n = encode_raw(frame_data, escaping, &mut wire).expect("re-encode");
        let (again, again_stats) = decode(&wire[..n], escaping);
        assert_eq!(again, [frame_data.clone()]);
        assert_eq!(
            again_stats,
            DecoderStats {
                frames: 1,
                ..DecoderStats::default()
            }
        );
        check_typed(frame_data);
    }
    let accounted = in_frames + stats.discarded_bytes as usize;
    assert!(
        accounted <= data.len(),
        "{stats:?}, {in_frames} bytes in frames"
    );
    if escaping == ApiEscaping::Unescaped {
        assert!(
            data.len() - accounted <= N,
            "{stats:?}, {in_frames} bytes in frames"
        );
    }
}

fuzz_target!(|data: &[u8]| {
    check_mode(data, ApiEscaping::Unescaped);
    check_mode(data, ApiEscaping::Escaped);
    check_typed(data);
});
