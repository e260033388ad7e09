//! `dima_sensorboard::StreamDecoder` on any bytes: sensor packets and info frames.
//!
//! Beyond "no panic":
//! - the same bytes read whole, one byte at a time ([`StreamDecoder::push`]) and in reads of
//!   random sizes give the same frames and the same packet and info-frame counts;
//! - every byte is accounted for: each frame's length on the wire (what the decoder consumed
//!   for it) is 132 for a packet and a valid info-frame length, and frames + skipped + held
//!   bytes add up to the input;
//! - a decoded packet encodes back to the same values, a version 1 or 2 info frame to bytes
//!   that decode to the same frame, and a NAV-PVT frame in the GNSS area to the same 100 bytes.
#![no_main]

use dima_fuzz::chunks;
use dima_sensorboard::{
    Frame, InfoFrame, SensorPacket, Stm32Crc, StreamDecoder, INFO_MAX_LEN, INFO_V1_LEN,
    INFO_V2_LEN, PACKET_LEN,
};
use libfuzzer_sys::fuzz_target;

/// What one way of reading the input produced.
#[derive(Debug, PartialEq)]
struct Run {
    /// Each frame with its length on the wire.
    frames: Vec<(Frame, usize)>,
    packets: u64,
    info_frames: u64,
    /// Skipped and still buffered bytes: every input byte that is in no frame.
    unframed: u64,
}

/// Measures frames as they come out: a frame's length is what was consumed since the previous
/// frame, less what was skipped or is still held.
struct Meter {
    decoder: StreamDecoder,
    consumed: u64,
    in_frames: u64,
    frames: Vec<(Frame, usize)>,
}

impl Meter {
    fn new() -> Meter {
        Meter {
            decoder: StreamDecoder::new(),
            consumed: 0,
            in_frames: 0,
            frames: Vec::new(),
        }
    }

    fn record(&mut self, frame: Frame) {
        let held = self.decoder.stats().bytes_skipped + self.decoder.buffered_len() as u64;
        let len = self.consumed - self.in_frames - held;
        self.in_frames += len;
        self.frames.push((frame, len as usize));
    }

    fn finish(mut self, input_len: usize) -> Run {
        assert_eq!(self.consumed, input_len as u64);
        assert!(
            self.decoder.next_buffered().is_none(),
            "a complete frame was left in the buffer"
        );
        assert!(self.decoder.buffered_len() <= StreamDecoder::CAPACITY);
        let stats = self.decoder.stats();
        let unframed = stats.bytes_skipped + self.decoder.buffered_len() as u64;
        assert_eq!(self.in_frames + unframed, input_len as u64);
        Run {
            frames: self.frames,
            packets: stats.packets,
            info_frames: stats.info_frames,
            unframed,
        }
    }
}

/// Reads given to [`StreamDecoder::feed`] one after the other.
fn by_reads(reads: &[&[u8]], input_len: usize) -> Run {
    let mut m = Meter::new();
    for read in reads {
        let mut input: &[u8] = read;
        loop {
            let before = input.len();
            let frame = m.decoder.feed(&mut input);
            m.consumed += (before - input.len()) as u64;
            match frame {
                Some(frame) => m.record(frame),
                None => break,
            }
        }
        assert!(
            input.is_empty(),
            "feed returned None before the read was used up"
        );
    }
    m.finish(input_len)
}

/// One byte at a time through [`StreamDecoder::push`], draining with `next_buffered`.
fn by_bytes(data: &[u8]) -> Run {
    let mut m = Meter::new();
    for &byte in data {
        let mut frame = m.decoder.push(byte);
        m.consumed += 1;
        while let Some(f) = frame {
            m.record(f);
            frame = m.decoder.next_buffered();
        }
    }
    m.finish(data.len())
}

fn check_frame(frame: &Frame, len: usize) {
    match frame {
        Frame::Packet(raw) => {
            assert_eq!(len, PACKET_LEN);
            let packet = raw.decode();
            assert_eq!(SensorPacket::decode_unchecked(&packet.encode()), packet);
            if let Some(pvt) = packet.nav_pvt() {
                assert_eq!(pvt.to_frame().as_bytes(), packet.gnss.as_bytes());
            }
        }
        Frame::Info(info) => {
            assert!(
                (INFO_V1_LEN..=INFO_MAX_LEN).contains(&len),
                "info frame of {len} bytes"
            );
            if len == INFO_V1_LEN {
                assert_eq!(InfoFrame::decode(&info.encode()), Ok((*info, INFO_V1_LEN)));
            } else if len == INFO_V2_LEN && info.version == 2 {
                let bytes = info.encode_v2_with(&mut Stm32Crc);
                assert_eq!(InfoFrame::decode(&bytes), Ok((*info, INFO_V2_LEN)));
            }
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let whole = by_reads(&[data], data.len());
    for (frame, len) in &whole.frames {
        check_frame(frame, *len);
    }
    assert_eq!(whole.packets + whole.info_frames, whole.frames.len() as u64);
    assert_eq!(by_bytes(data), whole, "one byte at a time");
    assert_eq!(
        by_reads(&chunks(data, 200, 1), data.len()),
        whole,
        "random reads"
    );
});
