//! Resynchronising framer and stream: golden frames, corruption, random chunking and noise.

use neo_m8t::{checksum, encode_frame};
use neo_m8t::{Frame, GnssStream, Message, NavPvt, UbxFramer};
use proptest::prelude::*;

/// Golden UBX frames on which the ublox 0.10 builders and pyubx2 agree, verbatim.
const CFG_RATE_200MS: [u8; 14] = [
    0xB5, 0x62, 0x06, 0x08, 0x06, 0x00, 0xC8, 0x00, 0x01, 0x00, 0x01, 0x00, 0xDE, 0x6A,
];
const CFG_MSG_NAV_PVT_UART1: [u8; 16] = [
    0xB5, 0x62, 0x06, 0x01, 0x08, 0x00, 0x01, 0x07, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x18, 0xE1,
];
const CFG_PRT_UART1_115200: [u8; 28] = [
    0xB5, 0x62, 0x06, 0x00, 0x14, 0x00, 0x01, 0x00, 0x00, 0x00, 0xC0, 0x08, 0x00, 0x00, 0x00, 0xC2,
    0x01, 0x00, 0x01, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0xA8, 0x42,
];
const MON_VER_POLL: [u8; 8] = [0xB5, 0x62, 0x0A, 0x04, 0x00, 0x00, 0x0E, 0x34];

fn collect<const N: usize>(framer: &mut UbxFramer<N>, bytes: &[u8]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    framer.push_slice(bytes, |f| out.push(f.as_bytes().to_vec()));
    out
}

fn nav_pvt(itow_ms: u32) -> [u8; 100] {
    *NavPvt {
        itow_ms,
        num_sv: 9,
        lat_deg_e7: 473_769_000,
        ..NavPvt::default()
    }
    .to_frame()
    .as_bytes()
}

#[test]
fn golden_frames_have_valid_checksums_and_are_found() {
    let golden: [&[u8]; 4] = [
        &CFG_RATE_200MS,
        &CFG_MSG_NAV_PVT_UART1,
        &CFG_PRT_UART1_115200,
        &MON_VER_POLL,
    ];
    let mut stream = Vec::new();
    for g in golden {
        let frame = Frame::new(g).expect("golden frame must verify");
        assert_eq!(frame.as_bytes(), g);
        let (a, b) = checksum(&g[2..g.len() - 2]);
        assert_eq!([a, b], g[g.len() - 2..]);
        stream.extend_from_slice(g);
    }
    let mut framer = UbxFramer::<512>::with_capacity();
    let found = collect(&mut framer, &stream);
    assert_eq!(found, golden.iter().map(|g| g.to_vec()).collect::<Vec<_>>());
    assert_eq!(framer.stats().frames_ok, 4);
    assert_eq!(framer.stats().bytes_skipped, 0);
}

#[test]
fn encode_frame_reproduces_golden_frames() {
    let mut out = [0u8; 32];
    let n = encode_frame(0x06, 0x08, &CFG_RATE_200MS[6..12], &mut out).unwrap();
    assert_eq!(&out[..n], &CFG_RATE_200MS);
    let n = encode_frame(0x0A, 0x04, &[], &mut out).unwrap();
    assert_eq!(&out[..n], &MON_VER_POLL);
    assert_eq!(encode_frame(0x06, 0x08, &[0; 30], &mut out), None);
}

#[test]
fn decode_classifies_ack_nak_and_nav_pvt() {
    // ACK-ACK and ACK-NAK for CFG-PRT (06 00); checksums from the Fletcher definition.
    let ack = [0xB5, 0x62, 0x05, 0x01, 0x02, 0x00, 0x06, 0x00, 0x0E, 0x37];
    let nak = [0xB5, 0x62, 0x05, 0x00, 0x02, 0x00, 0x06, 0x00, 0x0D, 0x32];
    assert_eq!(
        Message::from_frame(&Frame::new(&ack).unwrap()),
        Message::Ack { class: 6, id: 0 }
    );
    assert_eq!(
        Message::from_frame(&Frame::new(&nak).unwrap()),
        Message::Nak { class: 6, id: 0 }
    );
    let pvt = nav_pvt(5);
    assert!(matches!(
        Message::from_frame(&Frame::new(&pvt).unwrap()),
        Message::NavPvt(f) if f.as_bytes() == &pvt
    ));
}

#[test]
fn flipped_byte_is_rejected_and_next_frame_found() {
    let a = nav_pvt(1000);
    let b = nav_pvt(1100);
    let mut bad = a;
    bad[50] ^= 0x40;
    let mut framer = UbxFramer::<512>::with_capacity();
    let found = collect(&mut framer, &[&bad[..], &b[..]].concat());
    assert_eq!(found, vec![b.to_vec()]);
    let stats = framer.stats();
    assert_eq!(stats.checksum_errors, 1);
    assert_eq!(stats.bytes_skipped, 100);
    assert_eq!(stats.frames_ok, 1);
}

#[test]
fn corrupted_length_that_swallows_the_next_frame_still_finds_it() {
    // Length 0x5C -> 0xDC: the false candidate (228 bytes) spans the next two frames.
    let mut bad = nav_pvt(1000);
    bad[4] = 0xDC;
    let b = nav_pvt(1100);
    let c = nav_pvt(1200);
    let mut framer = UbxFramer::<512>::with_capacity();
    let found = collect(&mut framer, &[&bad[..], &b[..], &c[..]].concat());
    assert_eq!(found, vec![b.to_vec(), c.to_vec()]);
    assert_eq!(framer.stats().bytes_skipped, 100);
    assert_eq!(framer.buffered(), 0);
}

#[test]
fn shortened_length_and_oversized_length_resynchronise() {
    let b = nav_pvt(1100);
    // Shorter: candidate ends inside the payload with a wrong checksum.
    let mut short = nav_pvt(1000);
    short[4] = 0x1C;
    // Longer than the 100-byte buffer: rejected at the header.
    let mut long = nav_pvt(1000);
    long[5] = 0x01;
    for bad in [short, long] {
        let mut framer = UbxFramer::<100>::with_capacity();
        let found = collect(&mut framer, &[&bad[..], &b[..]].concat());
        assert_eq!(found, vec![b.to_vec()]);
        assert_eq!(framer.stats().bytes_skipped, 100);
    }
    let mut framer = UbxFramer::<100>::with_capacity();
    collect(&mut framer, &long);
    assert_eq!(framer.stats().oversized, 1);
}

#[test]
fn lost_bytes_drop_only_the_damaged_frame() {
    let a = nav_pvt(1000);
    let b = nav_pvt(1100);
    let c = nav_pvt(1200);
    // Ten bytes of `b` lost in the middle.
    let stream = [&a[..], &b[..40], &b[50..], &c[..]].concat();
    let mut framer = UbxFramer::<100>::with_capacity();
    let found = collect(&mut framer, &stream);
    assert_eq!(found, vec![a.to_vec(), c.to_vec()]);
    assert_eq!(framer.stats().bytes_skipped, 90);
}

#[test]
fn false_sync_in_noise_is_skipped() {
    let a = nav_pvt(1000);
    let noise = [0xB5, 0x62, 0xB5, 0xB5, 0x62, 0x01, 0x07, 0x5C];
    let mut framer = UbxFramer::<100>::with_capacity();
    let found = collect(&mut framer, &[&noise[..], &a[..]].concat());
    assert_eq!(found, vec![a.to_vec()]);
    assert_eq!(framer.stats().bytes_skipped, noise.len() as u32);
}

#[test]
fn clear_drops_a_partial_frame() {
    let a = nav_pvt(1000);
    let mut framer = UbxFramer::<100>::with_capacity();
    assert!(collect(&mut framer, &a[..30]).is_empty());
    assert_eq!(framer.buffered(), 30);
    framer.clear();
    assert_eq!(framer.buffered(), 0);
    assert_eq!(framer.stats().bytes_skipped, 30);
    assert_eq!(collect(&mut framer, &a), vec![a.to_vec()]);
}

#[test]
fn stream_keeps_latest_nav_pvt_and_copies_it_out() {
    let mut stream = GnssStream::<100>::with_capacity();
    let mut out = [0u8; 100];
    assert!(!stream.copy_latest_nav_pvt(&mut out));
    assert_eq!(stream.push_slice(&[nav_pvt(1), nav_pvt(2)].concat()), 2);
    assert!(stream.copy_latest_nav_pvt(&mut out));
    assert_eq!(out, nav_pvt(2));
    assert_eq!(
        stream.take_nav_pvt().map(|f| *f.as_bytes()),
        Some(nav_pvt(2))
    );
    assert_eq!(stream.take_nav_pvt(), None);
    assert_eq!(
        stream.latest_nav_pvt().map(|f| *f.as_bytes()),
        Some(nav_pvt(2))
    );
    assert_eq!(stream.nav_pvt_count(), 2);
}

#[test]
fn stream_keeps_timing_messages() {
    // TIM-TP: towMS 1000, towSubMS 0x80000000, qErr -250 ps, week 2393, flags 0x03, refInfo 0.
    let mut payload = Vec::new();
    payload.extend_from_slice(&1000u32.to_le_bytes());
    payload.extend_from_slice(&0x8000_0000u32.to_le_bytes());
    payload.extend_from_slice(&(-250i32).to_le_bytes());
    payload.extend_from_slice(&2393u16.to_le_bytes());
    payload.extend_from_slice(&[0x03, 0x00]);
    let mut frame = [0u8; 24];
    encode_frame(0x0D, 0x01, &payload, &mut frame).unwrap();
    let mut stream = GnssStream::<100>::with_capacity();
    stream.push_slice(&frame);
    let tp = stream.latest_tim_tp().expect("TIM-TP");
    assert_eq!(
        (tp.tow_ms, tp.tow_sub_ms, tp.q_err_ps, tp.week, tp.flags),
        (1000, 0x8000_0000, -250, 2393, 0x03)
    );
}

#[test]
fn stream_keeps_tim_tm2() {
    // TIM-TM2: ch 0, flags 0x6D, count 3, wnR 2393, wnF 2393, towMsR 1000, towSubMsR 250 ns,
    // towMsF 1100, towSubMsF 500 ns, accEst 20 ns.
    let mut payload = vec![0x00, 0x6D];
    payload.extend_from_slice(&3u16.to_le_bytes());
    payload.extend_from_slice(&2393u16.to_le_bytes());
    payload.extend_from_slice(&2393u16.to_le_bytes());
    for v in [1000u32, 250, 1100, 500, 20] {
        payload.extend_from_slice(&v.to_le_bytes());
    }
    let mut frame = [0u8; 36];
    encode_frame(0x0D, 0x03, &payload, &mut frame).unwrap();
    let mut stream = GnssStream::<100>::with_capacity();
    stream.push_slice(&frame);
    let tm = stream.latest_tim_tm2().expect("TIM-TM2");
    assert_eq!(
        (
            tm.channel,
            tm.flags,
            tm.count,
            tm.wn_r,
            tm.tow_ms_r,
            tm.tow_sub_ms_r_ns
        ),
        (0, 0x6D, 3, 2393, 1000, 250)
    );
    assert_eq!(
        (tm.tow_ms_f, tm.tow_sub_ms_f_ns, tm.acc_est_ns),
        (1100, 500, 20)
    );
}

/// Noise without the first sync character, so it cannot start a false frame.
fn noise() -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(any::<u8>().prop_filter("no sync", |b| *b != 0xB5), 0..40)
}

proptest! {
    /// A NAV-PVT stream with noise between frames, chopped into random chunks, yields every
    /// frame exactly once, and every byte is either in a frame or counted as skipped.
    #[test]
    fn chopped_noisy_stream_yields_every_frame(
        gaps in prop::collection::vec(noise(), 1..12),
        cuts in prop::collection::vec(1usize..150, 1..40),
    ) {
        let frames: Vec<[u8; 100]> = (0..gaps.len() as u32).map(|i| nav_pvt(i * 100)).collect();
        let mut wire = Vec::new();
        for (gap, frame) in gaps.iter().zip(&frames) {
            wire.extend_from_slice(gap);
            wire.extend_from_slice(frame);
        }
        let mut stream = GnssStream::<100>::with_capacity();
        let mut got = Vec::new();
        let mut rest = &wire[..];
        let mut cut = cuts.iter().cycle();
        while !rest.is_empty() {
            let n = (*cut.next().unwrap()).min(rest.len());
            let (chunk, tail) = rest.split_at(n);
            for &byte in chunk {
                let mut next = stream.push(byte);
                while let Some(message) = next {
                    if let Message::NavPvt(f) = message {
                        got.push(*f.as_bytes());
                    }
                    next = stream.poll_pending();
                }
            }
            rest = tail;
        }
        prop_assert_eq!(&got, &frames);
        let stats = stream.stats();
        let noise_len: usize = gaps.iter().map(Vec::len).sum();
        prop_assert_eq!(stats.bytes_skipped as usize, noise_len);
        prop_assert_eq!(stats.frames_ok as usize, frames.len());
    }

    /// One corrupted byte (outside the length field) loses exactly that frame.
    #[test]
    fn one_corrupted_frame_loses_only_itself(
        count in 2usize..8,
        victim in 0usize..8,
        at in prop::sample::select((0usize..100).filter(|i| *i != 4 && *i != 5).collect::<Vec<_>>()),
        xor in 1u8..=255,
    ) {
        let victim = victim % count;
        let frames: Vec<[u8; 100]> = (0..count as u32).map(|i| nav_pvt(i * 100)).collect();
        let mut wire = Vec::new();
        for (i, f) in frames.iter().enumerate() {
            let mut f = *f;
            if i == victim {
                f[at] ^= xor;
            }
            wire.extend_from_slice(&f);
        }
        let mut framer = UbxFramer::<100>::with_capacity();
        let got = collect(&mut framer, &wire);
        let expected: Vec<Vec<u8>> = frames
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != victim)
            .map(|(_, f)| f.to_vec())
            .collect();
        prop_assert_eq!(got, expected);
        prop_assert_eq!(framer.stats().bytes_skipped, 100);
    }

    /// Arbitrary bytes in arbitrary chunks never panic, and the byte accounting holds.
    #[test]
    fn arbitrary_bytes_never_panic(
        bytes in prop::collection::vec(
            prop_oneof![any::<u8>(), Just(0xB5u8), Just(0x62u8), Just(0x00u8)], 0..2000),
    ) {
        let mut small = UbxFramer::<16>::with_capacity();
        let mut big = GnssStream::<512>::with_capacity();
        let mut in_frames = 0usize;
        small.push_slice(&bytes, |f| in_frames += f.as_bytes().len());
        big.push_slice(&bytes);
        let s = small.stats();
        prop_assert_eq!(in_frames + s.bytes_skipped as usize + small.buffered(), bytes.len());
    }

    /// Any checksum-valid frame of any class and id decodes without panicking.
    #[test]
    fn any_valid_frame_classifies_without_panic(
        class in prop_oneof![any::<u8>(), prop::sample::select(vec![0x01u8, 0x02, 0x05, 0x06, 0x0A, 0x0D])],
        id in any::<u8>(),
        payload in prop::collection::vec(any::<u8>(), 0..120),
    ) {
        let mut buf = [0u8; 128];
        let n = encode_frame(class, id, &payload, &mut buf).unwrap();
        let frame = Frame::new(&buf[..n]).unwrap();
        let _ = Message::from_frame(&frame);
        let _ = frame.decode();
    }
}

/// Noise that looks like UBX: stray sync characters and false headers with any length, so
/// false candidates swallow the real frames behind them and must be rejected and rescanned.
fn ubx_like_noise() -> impl Strategy<Value = Vec<u8>> {
    let piece = prop_oneof![
        3 => any::<u8>().prop_map(|b| vec![b]),
        1 => Just(vec![0xB5]),
        1 => Just(vec![0xB5, 0x62]),
        2 => (any::<u8>(), any::<u8>(), 0u8..=120).prop_map(|(class, id, len)| {
            vec![0xB5, 0x62, class, id, len, 0]
        }),
    ];
    prop::collection::vec(piece, 0..8).prop_map(|pieces| pieces.concat())
}

proptest! {
    // A false candidate whose checksum matches by chance (1 in 65536) is a valid frame and
    // would legitimately swallow a real one; a fixed seed keeps this test reproducible.
    #![proptest_config(ProptestConfig {
        rng_seed: prop::test_runner::RngSeed::Fixed(0x00D1_3A55),
        ..ProptestConfig::default()
    })]

    /// NAV-PVT frames behind UBX-like noise, in random chunks: every frame comes out, in
    /// order, and every other byte is counted as skipped.
    #[test]
    fn frames_behind_false_headers_are_all_found(
        gaps in prop::collection::vec(ubx_like_noise(), 1..10),
        cuts in prop::collection::vec(1usize..150, 1..20),
    ) {
        let frames: Vec<[u8; 100]> = (0..gaps.len() as u32).map(|i| nav_pvt(i * 100)).collect();
        let mut wire = Vec::new();
        for (gap, frame) in gaps.iter().zip(&frames) {
            wire.extend_from_slice(gap);
            wire.extend_from_slice(frame);
        }
        // Idle line after the last frame: lets a false candidate that started in the last
        // gap reach its announced end and be rejected.
        wire.extend_from_slice(&[0u8; 128]);
        let mut framer = UbxFramer::<100>::with_capacity();
        let mut got = Vec::new();
        let mut rest = &wire[..];
        let mut cut = cuts.iter().cycle();
        while !rest.is_empty() {
            let (chunk, tail) = rest.split_at((*cut.next().unwrap()).min(rest.len()));
            framer.push_slice(chunk, |f| got.push(f.as_bytes().to_vec()));
            rest = tail;
        }
        let expected: Vec<Vec<u8>> = frames.iter().map(|f| f.to_vec()).collect();
        prop_assert_eq!(&got, &expected);
        prop_assert_eq!(framer.buffered(), 0);
        prop_assert_eq!(framer.stats().bytes_skipped as usize, wire.len() - 100 * frames.len());
    }
}
