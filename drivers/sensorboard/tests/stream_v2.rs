//! The v2 stream decoder: any chunking gives the same output, every byte is accounted for,
//! NAV-PVT frames come back whole and never mixed across epochs, damage is refused.

mod common;

use dima_sensorboard::imu::ImuPacketWords;
use dima_sensorboard::{
    AnswerCycleV2, DecoderStatsV2, FrameV2, GnssFrame, InfoFrame, LinkFlags, PacketV2, RawPacketV2,
    SensorPacket, Stm32Crc, StreamDecoder, StreamDecoderV2, Trailer, GNSS_PIECE_LEN,
    INFO_PIECE_LEN, PACKET_V2_LEN,
};
use proptest::prelude::*;

fn packet(count: u32) -> [u8; PACKET_V2_LEN] {
    PacketV2 {
        request_count: count,
        sample_time_us: count.wrapping_mul(500),
        imu: ImuPacketWords::from_le_bytes(&[count as u8; 20]),
        press_raw: 415_148,
        temp_raw: 519_888,
        ..PacketV2::default()
    }
    .encode(&mut Stm32Crc)
}

fn gnss(seed: u8) -> GnssFrame {
    GnssFrame::from_bytes(core::array::from_fn(|i| seed.wrapping_add(i as u8)))
}

fn info_pieces() -> [[u8; INFO_PIECE_LEN]; 9] {
    InfoFrame {
        version: 2,
        uptime_ms: 777,
        ..InfoFrame::default()
    }
    .encode_v2_pieces_with(5, &mut Stm32Crc)
}

/// Feeds `stream` in chunks of the given sizes (cycled) and returns the frames.
fn decode_chunked(decoder: &mut StreamDecoderV2, stream: &[u8], sizes: &[usize]) -> Vec<FrameV2> {
    let mut frames = Vec::new();
    let mut rest = stream;
    let mut i = 0;
    while !rest.is_empty() {
        let size = sizes[i % sizes.len()].max(1);
        let (chunk, tail) = rest.split_at(size.min(rest.len()));
        frames.extend(decoder.frames(chunk));
        rest = tail;
        i += 1;
    }
    frames
}

type Output = (Vec<FrameV2>, DecoderStatsV2, usize);

fn split_decode(stream: &[u8], cuts: &[usize]) -> Output {
    let mut decoder = StreamDecoderV2::new();
    let frames = decode_chunked(&mut decoder, stream, cuts);
    (frames, decoder.stats(), decoder.buffered_len())
}

fn push_decode(stream: &[u8]) -> Output {
    let mut decoder = StreamDecoderV2::new();
    let mut frames = Vec::new();
    for &b in stream {
        frames.extend(decoder.push(b));
        frames.extend(std::iter::from_fn(|| decoder.next_buffered()));
    }
    (frames, decoder.stats(), decoder.buffered_len())
}

/// Frames + skipped + held bytes = input.
fn assert_accounted(output: &Output, fed: usize) {
    let (_, s, held) = output;
    assert_eq!(
        fed as u64,
        s.packets * PACKET_V2_LEN as u64
            + s.gnss_pieces * GNSS_PIECE_LEN as u64
            + s.info_pieces * INFO_PIECE_LEN as u64
            + s.bytes_skipped
            + *held as u64,
        "{s:?}"
    );
}

fn packets_of(frames: &[FrameV2]) -> Vec<[u8; PACKET_V2_LEN]> {
    frames
        .iter()
        .filter_map(|f| match f {
            FrameV2::Packet(raw) => Some(raw.into_bytes()),
            _ => None,
        })
        .collect()
}

fn gnss_of(frames: &[FrameV2]) -> Vec<GnssFrame> {
    frames
        .iter()
        .filter_map(|f| match f {
            FrameV2::Gnss(g) => Some(*g),
            _ => None,
        })
        .collect()
}

#[test]
fn the_board_answer_cycle_end_to_end() {
    // 40 requests: a NAV-PVT frame at request 3 and 20, an info snapshot at request 0; each
    // answer is the packet, flagged with what follows, then that trailer.
    let mut cycle = AnswerCycleV2::new();
    let info = InfoFrame {
        version: 2,
        uptime_ms: 777,
        ..InfoFrame::default()
    };
    let mut stream = Vec::new();
    for request in 0..40u32 {
        if request == 0 {
            cycle.publish_info(&info_pieces());
        }
        if request == 3 || request == 20 {
            cycle.publish_gnss(&gnss(request as u8), &mut Stm32Crc);
        }
        let trailer = cycle.next(request == 0);
        let flags = trailer.map_or(LinkFlags::empty(), |t| t.flag());
        let p = PacketV2 {
            request_count: request,
            flags,
            ..PacketV2::default()
        };
        stream.extend(p.encode(&mut Stm32Crc));
        stream.extend(trailer.as_ref().map_or(&[][..], Trailer::as_bytes));
    }
    let whole = split_decode(&stream, &[stream.len()]);
    let (frames, stats, held) = &whole;
    assert_eq!(packets_of(frames).len(), 40);
    assert_eq!(gnss_of(frames), vec![gnss(3), gnss(20)]);
    assert!(frames.contains(&FrameV2::Info(info)));
    assert_eq!(stats.gnss_frames_dropped, 0);
    assert_eq!(stats.info_records_dropped, 0);
    assert_eq!(stats.bytes_skipped, 0);
    assert_eq!(*held, 0);
    assert_accounted(&whole, stream.len());
    // The NAV-PVT frame comes out right after the packet its last piece follows.
    let position = frames
        .iter()
        .position(|f| *f == FrameV2::Gnss(gnss(3)))
        .unwrap();
    match frames[position - 1] {
        FrameV2::Packet(raw) => assert_eq!(raw.decode().request_count, 6),
        other => panic!("{other:?}"),
    }
    for size in [1, 5, 33, 41, 42, 77] {
        assert_eq!(split_decode(&stream, &[size]), whole, "chunks of {size}");
    }
    assert_eq!(push_decode(&stream), whole);
}

#[test]
fn pieces_of_two_epochs_never_make_a_mixed_frame() {
    let a = gnss(0).encode_pieces_with(7, &mut Stm32Crc);
    let b = gnss(100).encode_pieces_with(8, &mut Stm32Crc);
    // A0 A1 B2 B3: no frame; B0 B1 A2 A3: no frame; then B whole.
    let mut stream = Vec::new();
    for piece in [a[0], a[1], b[2], b[3], b[0], b[1], a[2], a[3]] {
        stream.extend(packet(1));
        stream.extend(piece);
    }
    stream.extend(b.concat());
    let out = split_decode(&stream, &[stream.len()]);
    assert_eq!(gnss_of(&out.0), vec![gnss(100)]);
    assert_eq!(out.1.gnss_pieces, 12);
    assert_eq!(
        out.1.gnss_frames_dropped, 2,
        "A when B2 came, the first B when A2 came; the stray B3 and A3 count no more"
    );
    assert_accounted(&out, stream.len());
}

#[test]
fn a_missing_piece_drops_the_frame_and_counts_it() {
    let a = gnss(1).encode_pieces_with(1, &mut Stm32Crc);
    let b = gnss(2).encode_pieces_with(2, &mut Stm32Crc);
    // A without its last piece, then B: A is dropped when B's piece 0 arrives.
    let mut stream = [a[0], a[1], a[2]].concat();
    stream.extend(b.concat());
    let out = split_decode(&stream, &[10]);
    assert_eq!(gnss_of(&out.0), vec![gnss(2)]);
    assert_eq!(out.1.gnss_frames_dropped, 1);
    // A damaged piece is a CRC error, and its frame is lost.
    let mut damaged = a;
    damaged[1][10] ^= 1;
    let out = split_decode(&damaged.concat(), &[7]);
    assert!(gnss_of(&out.0).is_empty());
    assert_eq!(out.1.crc_errors, 1);
    assert_eq!(out.1.gnss_frames_dropped, 1);
    assert_accounted(&out, 4 * GNSS_PIECE_LEN);
}

#[test]
fn a_wrong_crc_is_refused_and_the_next_packet_found() {
    let good = packet(9);
    for bit in 0..PACKET_V2_LEN * 8 {
        let mut bad = packet(8);
        bad[bit / 8] ^= 1 << (bit % 8);
        let mut stream = bad.to_vec();
        stream.extend(good);
        let out = split_decode(&stream, &[stream.len()]);
        assert_eq!(packets_of(&out.0), vec![good], "bit {bit}");
        assert_eq!(out.0.len(), 1, "bit {bit}");
        assert_accounted(&out, stream.len());
    }
}

#[test]
fn v1_and_v2_frames_are_not_confused() {
    let v1 = SensorPacket::default().encode();
    let v2 = packet(3);
    let mut stream = v1.to_vec();
    stream.extend(v2);
    stream.extend(InfoFrame::default().encode());
    // The v2 decoder skips the v1 packet and the whole info frame.
    let out = split_decode(&stream, &[stream.len()]);
    assert_eq!(out.0, vec![FrameV2::Packet(RawPacketV2::new(&v2).unwrap())]);
    assert_eq!(out.1.bytes_skipped, (stream.len() - PACKET_V2_LEN) as u64);
    // The v1 decoder, as it was, skips the v2 packet.
    let mut v1_decoder = StreamDecoder::new();
    let v1_frames: Vec<_> = v1_decoder.frames(&stream).collect();
    assert_eq!(v1_frames.len(), 2, "the v1 packet and the info frame");
    assert_eq!(v1_decoder.stats().bytes_skipped, PACKET_V2_LEN as u64);
}

#[test]
fn a_torn_packet_then_a_piece_inside_its_window() {
    // The torn packet's `$P` claims 42 bytes; the info piece that follows lies inside them and
    // must come out at once, not after the window is rejected.
    let pieces = info_pieces();
    let mut stream = packet(1)[..5].to_vec();
    stream.extend(pieces.concat());
    stream.extend(packet(2));
    let whole = split_decode(&stream, &[stream.len()]);
    assert_eq!(packets_of(&whole.0), vec![packet(2)]);
    assert_eq!(whole.1.info_frames, 1);
    assert_eq!(whole.1.bytes_skipped, 5);
    assert_accounted(&whole, stream.len());
    for cut in 1..stream.len() {
        assert_eq!(split_decode(&stream, &[cut]), whole, "chunks of {cut}");
    }
    // The first piece completes while `$P`'s window is open: no byte after it is needed.
    let mut decoder = StreamDecoderV2::new();
    let mut upto = packet(1)[..5].to_vec();
    upto.extend(pieces.concat());
    let frames: Vec<_> = decoder.frames(&upto).collect();
    assert_eq!(frames.len(), 1);
}

#[test]
fn garbage_only_is_skipped_without_buffering() {
    let mut decoder = StreamDecoderV2::new();
    assert_eq!(decoder.frames(&[0x55u8; 10_000]).count(), 0);
    assert_eq!(decoder.stats().bytes_skipped, 10_000);
    assert_eq!(decoder.buffered_len(), 0);
    assert_eq!(decoder.frames(&packet(1)[..30]).count(), 0);
    decoder.clear();
    assert_eq!(decoder.stats().bytes_skipped, 10_030);
}

/// Anything a v2 link can carry: packets, GNSS pieces of a few epochs, info pieces, torn
/// frames, v1 frames, false starts and noise.
fn any_segment() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        4 => any::<u32>().prop_map(|c| packet(c).to_vec()),
        3 => (0u8..3, 0usize..4).prop_map(|(e, i)| {
            gnss(e * 50).encode_pieces_with(e, &mut Stm32Crc)[i].to_vec()
        }),
        2 => (0u8..3).prop_map(|e| gnss(e * 50).encode_pieces_with(e, &mut Stm32Crc).concat()),
        2 => (0usize..9).prop_map(|i| info_pieces()[i].to_vec()),
        1 => Just(info_pieces().concat()),
        2 => (any::<u32>(), 1usize..PACKET_V2_LEN).prop_map(|(c, cut)| packet(c)[..cut].to_vec()),
        1 => Just(SensorPacket::default().encode().to_vec()),
        3 => proptest::collection::vec(
            prop_oneof![any::<u8>(), Just(b'$'), Just(b'P'), Just(b'G'), Just(b'H')],
            0..24,
        ),
    ]
}

proptest! {
    #[test]
    fn any_split_of_the_same_bytes_gives_the_same_output(
        segments in proptest::collection::vec(any_segment(), 1..16),
        cuts in proptest::collection::vec(1usize..100, 1..24),
    ) {
        let stream = segments.concat();
        let one = split_decode(&stream, &[stream.len()]);
        prop_assert_eq!(&split_decode(&stream, &cuts), &one);
        prop_assert_eq!(&push_decode(&stream), &one);
        assert_accounted(&one, stream.len());
        prop_assert!(one.2 < StreamDecoderV2::CAPACITY);
        // Every NAV-PVT frame out is one that was sent, never a mix.
        for frame in gnss_of(&one.0) {
            prop_assert!((0u8..3).any(|e| frame == gnss(e * 50)), "mixed frame {:?}", frame);
        }
        let s = one.1;
        prop_assert_eq!(
            s.packets + s.gnss_frames + s.info_frames,
            one.0.len() as u64
        );
    }

    #[test]
    fn noisy_stream_yields_exactly_the_frames(
        items in proptest::collection::vec(
            (proptest::collection::vec(any::<u8>(), 0..30), any::<u32>(), any::<bool>()), 0..8),
        sizes in proptest::collection::vec(1usize..100, 1..8),
    ) {
        let mut stream = Vec::new();
        let mut expected = Vec::new();
        for (i, (noise, count, with_gnss)) in items.iter().enumerate() {
            stream.extend(noise);
            stream.extend(packet(*count));
            expected.push(FrameV2::Packet(RawPacketV2::new(&packet(*count)).unwrap()));
            if *with_gnss {
                stream.extend(gnss(i as u8).encode_pieces_with(i as u8, &mut Stm32Crc).concat());
                expected.push(FrameV2::Gnss(gnss(i as u8)));
            }
        }
        let out = split_decode(&stream, &sizes);
        // Noise may complete no frame of its own (a random CRC match is 2^-32 per candidate).
        prop_assert_eq!(&out.0, &expected);
        assert_accounted(&out, stream.len());
    }

    #[test]
    fn random_bytes_never_panic_and_stay_bounded(
        data in proptest::collection::vec(
            prop_oneof![any::<u8>(), Just(b'$'), Just(b'P'), Just(b'G'), Just(b'H'), Just(4u8)],
            0..2000),
        sizes in proptest::collection::vec(1usize..300, 1..8),
    ) {
        let out = split_decode(&data, &sizes);
        prop_assert!(out.2 < StreamDecoderV2::CAPACITY);
        assert_accounted(&out, data.len());
    }

    #[test]
    fn interleaved_epochs_never_yield_a_mixed_frame(
        order in proptest::collection::vec((any::<bool>(), 0usize..4), 0..24),
    ) {
        let a = gnss(0).encode_pieces_with(10, &mut Stm32Crc);
        let b = gnss(128).encode_pieces_with(11, &mut Stm32Crc);
        let stream: Vec<u8> = order
            .iter()
            .flat_map(|&(from_a, i)| if from_a { a[i] } else { b[i] })
            .collect();
        let out = split_decode(&stream, &[stream.len()]);
        for frame in gnss_of(&out.0) {
            prop_assert!(frame == gnss(0) || frame == gnss(128));
        }
        // A frame comes out exactly when its four pieces are consecutive in order.
        let runs = order
            .windows(4)
            .filter(|w| {
                w.iter().enumerate().all(|(k, &(from_a, i))| from_a == w[0].0 && i == k)
            })
            .count();
        prop_assert_eq!(out.1.gnss_frames as usize, runs);
    }
}
