//! The UBX reader of the NEO-M8T driver on any bytes: `UbxFramer` (512- and 100-byte buffers),
//! the `ublox` crate's protocol 23 parser behind `Frame::decode`, and `GnssStream`.
//!
//! Beyond "no panic":
//! - every frame handed out is one checksum-valid UBX frame (`Frame::new` accepts its bytes);
//! - every byte is accounted for: frames + skipped + buffered bytes = input;
//! - the framer gives the same frames fed byte by byte or through `push_slice` in reads of
//!   random sizes;
//! - a NAV-PVT frame decodes to fields that encode back to the same 100 bytes;
//! - `GnssStream` counts exactly the NAV-PVT frames its framer finds, whatever the reads.
#![no_main]

use dima_fuzz::chunks;
use libfuzzer_sys::fuzz_target;
use neo_m8t::ublox::proto23::PacketRef;
use neo_m8t::{Frame, GnssStream, Message, NavPvtFrame, ReceiverVersion, UbxFramer};

fn by_bytes<const N: usize>(data: &[u8]) -> (Vec<Vec<u8>>, UbxFramer<N>) {
    let mut framer = UbxFramer::<N>::with_capacity();
    let mut frames = Vec::new();
    for &byte in data {
        if let Some(frame) = framer.push(byte) {
            frames.push(frame.as_bytes().to_vec());
            while let Some(frame) = framer.poll_pending() {
                frames.push(frame.as_bytes().to_vec());
            }
        }
    }
    (frames, framer)
}

fn by_slices<const N: usize>(data: &[u8]) -> Vec<Vec<u8>> {
    let mut framer = UbxFramer::<N>::with_capacity();
    let mut frames = Vec::new();
    for read in chunks(data, 64, 1) {
        framer.push_slice(read, |frame| frames.push(frame.as_bytes().to_vec()));
    }
    frames
}

fn check_frame(bytes: &[u8]) {
    let frame = Frame::new(bytes).expect("the framer handed out an invalid frame");
    let message = Message::from_frame(&frame);
    match frame.decode() {
        Ok(PacketRef::NavPvt(_)) => {
            let pvt = NavPvtFrame::from_frame(&frame).expect("a NAV-PVT frame");
            assert_eq!(message, Message::NavPvt(pvt));
            assert_eq!(pvt.to_nav_pvt().to_frame().as_bytes(), bytes);
        }
        Ok(PacketRef::MonVer(ver)) => {
            let _ = ReceiverVersion::from_mon_ver(&ver);
        }
        _ => {}
    }
}

fn check<const N: usize>(data: &[u8]) -> usize {
    let (frames, framer) = by_bytes::<N>(data);
    let stats = framer.stats();
    assert_eq!(frames.len(), stats.frames_ok as usize);
    let in_frames: usize = frames.iter().map(Vec::len).sum();
    assert!(frames.iter().all(|f| f.len() <= N));
    assert_eq!(
        in_frames + stats.bytes_skipped as usize + framer.buffered(),
        data.len(),
        "{stats:?}"
    );
    for frame in &frames {
        check_frame(frame);
    }
    assert_eq!(by_slices::<N>(data), frames, "push_slice in random reads");
    frames
        .iter()
        .filter(|f| NavPvtFrame::from_bytes(f).is_some())
        .count()
}

fuzz_target!(|data: &[u8]| {
    check::<512>(data);
    let nav_pvt_frames = check::<100>(data);
    let mut stream = GnssStream::<100>::with_capacity();
    let counted: usize = chunks(data, 64, 2)
        .into_iter()
        .map(|read| stream.push_slice(read))
        .sum();
    assert_eq!(counted, nav_pvt_frames);
    assert_eq!(stream.nav_pvt_count() as usize, nav_pvt_frames);
});
