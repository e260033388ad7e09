//! End to end: a capture like a logic analyser records it (garbage before the first packet,
//! packets with and without GNSS, info frames, a torn answer, stray start bytes) decoded in
//! arbitrary reads, as `examples/decode.rs` does.

#[path = "common/capture.rs"]
mod capture;

use capture::{Capture, Noise};
use dima_sensorboard::{Frame, StreamDecoder};

#[test]
fn generated_capture_decodes_to_exactly_the_sent_packets() {
    let mut noise = Noise(0x1234_5678);
    let Capture {
        bytes: capture,
        sent,
        info,
        garbage,
    } = capture::generated(&mut noise);

    let mut decoder = StreamDecoder::new();
    let mut packets = Vec::new();
    let mut infos = 0;
    let mut rest = &capture[..];
    while !rest.is_empty() {
        let n = (noise.next() as usize % 300 + 1).min(rest.len());
        let (chunk, tail) = rest.split_at(n);
        for frame in decoder.frames(chunk) {
            match frame {
                Frame::Packet(raw) => packets.push(raw.decode()),
                Frame::Info(got) => {
                    assert_eq!(got, info);
                    infos += 1;
                }
            }
        }
        rest = tail;
    }

    assert_eq!(packets, sent);
    assert_eq!(infos, 2);
    assert!(packets[..50].iter().all(|p| p.nav_pvt().is_none()));
    let pvt = packets[150].nav_pvt().expect("GNSS present");
    assert_eq!(pvt.itow_ms, 150_000);
    assert!((pvt.lat_deg() - 47.397_654_3).abs() < 1e-12);
    let stats = decoder.stats();
    assert_eq!(stats.packets, 200);
    assert_eq!(stats.info_frames, 2);
    assert_eq!(decoder.buffered_len(), 0);
    assert_eq!(stats.bytes_skipped, garbage);
}
