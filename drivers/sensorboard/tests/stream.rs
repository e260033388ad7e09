//! The stream decoder: any chunking, noise between frames, torn frames, bit flips, and no
//! panic on any input.

mod common;

use dima_sensorboard::{
    DecoderStats, Frame, InfoFrame, RawPacket, SensorPacket, Stm32Crc, StreamDecoder,
    INFO_PIECE_LEN, PACKET_LEN,
};
use proptest::prelude::*;

/// Feeds `stream` in chunks of the given sizes (cycled) and returns the frames.
fn decode_chunked(decoder: &mut StreamDecoder, stream: &[u8], sizes: &[usize]) -> Vec<Frame> {
    let mut frames = Vec::new();
    let mut rest = stream;
    let mut i = 0;
    while !rest.is_empty() {
        let size = sizes
            .get(i % sizes.len().max(1))
            .copied()
            .unwrap_or(1)
            .max(1);
        let (chunk, tail) = rest.split_at(size.min(rest.len()));
        frames.extend(decoder.frames(chunk));
        rest = tail;
        i += 1;
    }
    frames
}

fn packet(gyro_x: i16) -> [u8; PACKET_LEN] {
    SensorPacket {
        gyro: [gyro_x, 2, 3],
        ..SensorPacket::default()
    }
    .encode()
}

fn packets_of(frames: &[Frame]) -> Vec<[u8; PACKET_LEN]> {
    frames
        .iter()
        .filter_map(|f| match f {
            Frame::Packet(raw) => Some(raw.into_bytes()),
            Frame::Info(_) => None,
        })
        .collect()
}

/// Every byte fed is in a frame, was skipped, or is still buffered.
fn assert_accounted(decoder: &StreamDecoder, fed: usize, frames: &[Frame]) {
    let in_frames: usize = frames
        .iter()
        .map(|f| match f {
            Frame::Packet(_) => PACKET_LEN,
            Frame::Info(_) => 60,
        })
        .sum();
    let stats = decoder.stats();
    assert_eq!(
        fed as u64,
        in_frames as u64
            + stats.bytes_skipped
            + stats.info_pieces * INFO_PIECE_LEN as u64
            + decoder.buffered_len() as u64,
        "{stats:?}"
    );
}

#[test]
fn back_to_back_packets_in_one_chunk() {
    let mut stream = Vec::new();
    for i in 0..5 {
        stream.extend_from_slice(&packet(i));
    }
    let mut decoder = StreamDecoder::new();
    let frames: Vec<Frame> = decoder.frames(&stream).collect();
    assert_eq!(packets_of(&frames), (0..5).map(packet).collect::<Vec<_>>());
    assert_eq!(
        decoder.stats(),
        DecoderStats {
            packets: 5,
            info_frames: 0,
            crc_errors: 0,
            bytes_skipped: 0,
            ..DecoderStats::default()
        }
    );
}

#[test]
fn torn_packet_followed_by_a_good_one() {
    for cut in 1..PACKET_LEN {
        let mut stream = packet(111)[..cut].to_vec();
        stream.extend_from_slice(&packet(222));
        let mut decoder = StreamDecoder::new();
        let frames: Vec<Frame> = decoder.frames(&stream).collect();
        assert_eq!(packets_of(&frames), vec![packet(222)], "cut at {cut}");
        assert_eq!(decoder.stats().bytes_skipped, cut as u64, "cut at {cut}");
        assert_eq!(decoder.buffered_len(), 0);
        // The torn start, and at most one false `$$` made of its last byte and the good
        // packet's first, fail their CRC.
        assert!(decoder.stats().crc_errors <= 2, "cut at {cut}");
    }
}

#[test]
fn torn_packet_then_info_frame_then_packet() {
    // The info frame is shorter than a packet, so it lies wholly inside the bytes the torn
    // candidate swallowed: it must still come out, before the packet.
    let info = InfoFrame {
        version: 1,
        uptime_ms: 1234,
        ..InfoFrame::default()
    };
    let mut stream = packet(1)[..10].to_vec();
    stream.extend_from_slice(&info.encode());
    stream.extend_from_slice(&packet(2));
    for size in [1, 7, 64, 500] {
        let mut decoder = StreamDecoder::new();
        let frames = decode_chunked(&mut decoder, &stream, &[size]);
        assert_eq!(frames.len(), 2, "chunk size {size}");
        assert_eq!(frames[0], Frame::Info(info));
        assert_eq!(packets_of(&frames), vec![packet(2)]);
        assert_accounted(&decoder, stream.len(), &frames);
    }
}

#[test]
fn false_start_in_noise_does_not_delay_the_packet() {
    // A stray `$I` header claiming a long payload, or a stray `$` glued to the packet's start,
    // must not hold the packet back until more bytes arrive.
    for noise in [&b"$I\x01\x9b"[..], b"$", b"xx$I\x01\xc8$", b"$$"] {
        let mut stream = noise.to_vec();
        stream.extend_from_slice(&packet(8));
        for size in [1, 3, 200] {
            let mut decoder = StreamDecoder::new();
            let frames = decode_chunked(&mut decoder, &stream, &[size]);
            assert_eq!(packets_of(&frames), vec![packet(8)], "{noise:?} / {size}");
            assert_eq!(decoder.buffered_len(), 0, "{noise:?} / {size}");
            assert_accounted(&decoder, stream.len(), &frames);
        }
    }
}

#[test]
fn many_false_starts_in_noise_do_not_delay_the_info_frame() {
    // Noise before an info frame: a `$$` false packet start, then four `$I` headers that
    // announce 73-byte payloads (81-byte frames that never complete). However many false
    // starts wait in the buffer (here all five headers arrive in one read, before the frame's
    // end), the info frame comes out as soon as its last byte is in.
    let info = InfoFrame {
        firmware: [0, 2, 0],
        ..InfoFrame::default()
    };
    let noise = b"$$I$I\x01I$I$I\x01I";
    let mut stream = noise.to_vec();
    stream.extend_from_slice(&info.encode());
    for sizes in [&[1][..], &[2], &[7], &[20, 200], &[40, 200], &[200]] {
        let mut decoder = StreamDecoder::new();
        let frames = decode_chunked(&mut decoder, &stream, sizes);
        assert_eq!(frames, vec![Frame::Info(info)], "chunks of {sizes:?}");
        assert_accounted(&decoder, stream.len(), &frames);
    }
}

#[test]
fn packet_then_info_frame_as_the_board_answers() {
    let info = InfoFrame {
        version: 1,
        firmware: [0, 1, 0],
        ..InfoFrame::default()
    };
    let mut stream = packet(5).to_vec();
    stream.extend_from_slice(&info.encode());
    let mut decoder = StreamDecoder::new();
    let frames: Vec<Frame> = decoder.frames(&stream).collect();
    assert_eq!(
        frames,
        vec![
            Frame::Packet(RawPacket::new(packet(5)).unwrap()),
            Frame::Info(info)
        ]
    );
    assert_eq!(decoder.stats().info_frames, 1);
}

#[test]
fn every_single_bit_flip_of_a_packet_is_rejected() {
    let good = packet(-77);
    for bit in 0..PACKET_LEN * 8 {
        let mut bad = good;
        bad[bit / 8] ^= 1 << (bit % 8);
        assert!(RawPacket::new(bad).is_err(), "bit {bit}");
        assert!(SensorPacket::decode(&bad).is_err(), "bit {bit}");

        // In a stream, the damaged packet is dropped and the next one is found.
        let mut stream = bad.to_vec();
        stream.extend_from_slice(&packet(9));
        let mut decoder = StreamDecoder::new();
        let frames: Vec<Frame> = decoder.frames(&stream).collect();
        assert_eq!(packets_of(&frames), vec![packet(9)], "bit {bit}");
        assert_eq!(frames.len(), 1, "bit {bit}");
    }
}

#[test]
fn every_single_bit_flip_of_an_info_frame_is_rejected_in_a_stream() {
    let good = InfoFrame {
        version: 1,
        firmware: [1, 0, 0],
        uptime_ms: 99,
        ..InfoFrame::default()
    }
    .encode();
    for bit in 0..good.len() * 8 {
        let mut bad = good;
        bad[bit / 8] ^= 1 << (bit % 8);
        let mut stream = bad.to_vec();
        stream.extend_from_slice(&packet(4));
        let mut decoder = StreamDecoder::new();
        let frames: Vec<Frame> = decoder.frames(&stream).collect();
        assert_eq!(frames.len(), 1, "bit {bit}: {frames:?}");
        assert_eq!(packets_of(&frames), vec![packet(4)], "bit {bit}");
    }
}

#[test]
fn info_frame_from_a_future_version() {
    // Version 2, L = 60: 8 unknown payload bytes are skipped, the CRC covers all of them.
    let mut frame = vec![b'$', b'I', 2, 60];
    frame.extend_from_slice(&InfoFrame::default().encode()[4..56]);
    frame[4..7].copy_from_slice(&[3, 2, 1]);
    frame.extend_from_slice(&[0x24; 8]);
    let crc = dima_sensorboard::crc32_bitwise(&frame);
    frame.extend_from_slice(&crc.to_le_bytes());
    let mut stream = frame.clone();
    stream.extend_from_slice(&packet(6));

    let mut decoder = StreamDecoder::new();
    let frames = decode_chunked(&mut decoder, &stream, &[5]);
    match frames.as_slice() {
        [Frame::Info(info), Frame::Packet(raw)] => {
            assert_eq!(info.version, 2);
            assert_eq!(info.firmware, [3, 2, 1]);
            assert_eq!(raw.into_bytes(), packet(6));
        }
        other => panic!("unexpected {other:?}"),
    }
    assert_eq!(decoder.stats().bytes_skipped, 0);
}

#[test]
fn oversized_info_length_is_a_bad_header() {
    // L = 201 is above the cap: the header is dropped at once, nothing waits for 209 bytes.
    let mut stream = vec![b'$', b'I', 1, 201];
    stream.extend_from_slice(&packet(6));
    let mut decoder = StreamDecoder::new();
    let frames = decode_chunked(&mut decoder, &stream, &[1]);
    assert_eq!(packets_of(&frames), vec![packet(6)]);
    assert_eq!(decoder.stats().bytes_skipped, 4);
    assert_eq!(decoder.stats().crc_errors, 0);
}

#[test]
fn push_byte_by_byte() {
    let mut stream = b"$$$I\x01\x34garbage$".to_vec();
    stream.extend_from_slice(&packet(1));
    stream.extend_from_slice(&packet(2));
    let mut decoder = StreamDecoder::new();
    let mut frames = Vec::new();
    for &b in &stream {
        frames.extend(decoder.push(b));
        frames.extend(std::iter::from_fn(|| decoder.next_buffered()));
    }
    assert_eq!(packets_of(&frames), vec![packet(1), packet(2)]);
    assert_accounted(&decoder, stream.len(), &frames);
}

#[test]
fn clear_drops_and_counts_buffered_bytes() {
    let mut decoder = StreamDecoder::new();
    assert_eq!(decoder.frames(&packet(3)[..50]).count(), 0);
    assert_eq!(decoder.buffered_len(), 50);
    decoder.clear();
    assert_eq!(decoder.buffered_len(), 0);
    assert_eq!(decoder.stats().bytes_skipped, 50);
}

#[test]
fn garbage_only_is_skipped_without_buffering() {
    let mut decoder = StreamDecoder::new();
    let garbage = [0x55u8; 10_000];
    assert_eq!(decoder.frames(&garbage).count(), 0);
    assert_eq!(decoder.stats().bytes_skipped, 10_000);
    assert_eq!(decoder.buffered_len(), 0);
}

fn noise() -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec(
        prop_oneof![any::<u8>(), Just(b'$'), Just(b'I'), Just(52u8), Just(1u8)],
        0..48,
    )
}

fn item() -> impl Strategy<Value = (Frame, Vec<u8>)> {
    prop_oneof![
        4 => common::sensor_packet().prop_map(|p| {
            let bytes = p.encode();
            (Frame::Packet(RawPacket::new(bytes).unwrap()), bytes.to_vec())
        }),
        1 => common::info_frame().prop_map(|i| (Frame::Info(i), i.encode().to_vec())),
    ]
}

proptest! {
    #[test]
    fn noisy_stream_in_random_chunks_yields_exactly_the_frames(
        items in proptest::collection::vec((noise(), item()), 0..8),
        tail in noise(),
        sizes in proptest::collection::vec(1usize..200, 1..16),
    ) {
        let mut stream = Vec::new();
        let mut expected = Vec::new();
        for (noise, (frame, bytes)) in &items {
            stream.extend_from_slice(noise);
            stream.extend_from_slice(bytes);
            expected.push(*frame);
        }
        stream.extend_from_slice(&tail);
        let mut decoder = StreamDecoder::new();
        let frames = decode_chunked(&mut decoder, &stream, &sizes);
        prop_assert_eq!(&frames, &expected);
        assert_accounted(&decoder, stream.len(), &frames);
        let stats = decoder.stats();
        prop_assert_eq!(stats.packets + stats.info_frames, expected.len() as u64);
    }

    #[test]
    fn each_frame_comes_out_as_soon_as_its_last_byte_is_in(
        items in proptest::collection::vec((noise(), item()), 1..6),
        sizes in proptest::collection::vec(1usize..200, 1..16),
    ) {
        // The board answers only when asked: a frame held back until more bytes arrive would
        // be a whole request period late.
        let mut decoder = StreamDecoder::new();
        let mut fed = 0;
        let mut frames = Vec::new();
        for (i, (noise, (frame, bytes))) in items.iter().enumerate() {
            let mut answer = noise.clone();
            answer.extend_from_slice(bytes);
            frames.extend(decode_chunked(&mut decoder, &answer, &sizes));
            fed += answer.len();
            prop_assert_eq!(frames.len(), i + 1, "frame {} held back", i);
            prop_assert_eq!(frames[i], *frame);
        }
        assert_accounted(&decoder, fed, &frames);
    }

    #[test]
    fn never_panics_and_stays_bounded(
        data in proptest::collection::vec(
            prop_oneof![any::<u8>(), Just(b'$'), Just(b'I'), Just(52u8)], 0..2000),
        sizes in proptest::collection::vec(1usize..300, 1..8),
    ) {
        let mut decoder = StreamDecoder::new();
        let frames = decode_chunked(&mut decoder, &data, &sizes);
        prop_assert!(decoder.buffered_len() < StreamDecoder::CAPACITY);
        assert_accounted(&decoder, data.len(), &frames);
    }

    #[test]
    fn packet_round_trip_through_the_stream(p in common::sensor_packet()) {
        let mut decoder = StreamDecoder::new();
        let frames: Vec<Frame> = decoder.frames(&p.encode()).collect();
        match frames.as_slice() {
            [Frame::Packet(raw)] => prop_assert_eq!(raw.decode(), p),
            other => prop_assert!(false, "unexpected frames {:?}", other),
        }
    }
}

// --- the output does not depend on how the bytes are split ---

/// Pieces of one info record (snapshot 5), as the board sends them.
fn piece_set() -> [[u8; INFO_PIECE_LEN]; 9] {
    InfoFrame {
        version: 2,
        uptime_ms: 777,
        ..InfoFrame::default()
    }
    .encode_v2_pieces_with(5, &mut Stm32Crc)
}

/// Anything the link can carry: valid frames, pieces, torn frames, false starts, noise.
fn any_segment() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        3 => common::sensor_packet().prop_map(|p| p.encode().to_vec()),
        1 => common::info_frame().prop_map(|i| i.encode().to_vec()),
        1 => common::info_frame().prop_map(|i| i.encode_v2_with(&mut Stm32Crc).to_vec()),
        3 => (0usize..9).prop_map(|i| piece_set()[i].to_vec()),
        1 => Just(piece_set().concat()),
        2 => (common::sensor_packet(), 1usize..PACKET_LEN)
            .prop_map(|(p, cut)| p.encode()[..cut].to_vec()),
        // A false info start whose announced length swallows what follows.
        2 => (1u8..4, 52u8..=200).prop_map(|(v, l)| vec![b'$', b'I', v, l]),
        2 => proptest::collection::vec(
            prop_oneof![any::<u8>(), Just(b'$'), Just(b'I'), Just(b'H'), Just(b'$')],
            0..24,
        ),
    ]
}

/// Decodes `stream` split at `cuts` (cycled); frames and counters.
fn split_decode(stream: &[u8], cuts: &[usize]) -> (Vec<Frame>, DecoderStats, usize) {
    let mut decoder = StreamDecoder::new();
    let frames = decode_chunked(&mut decoder, stream, cuts);
    (frames, decoder.stats(), decoder.buffered_len())
}

fn push_decode(stream: &[u8]) -> (Vec<Frame>, DecoderStats, usize) {
    let mut decoder = StreamDecoder::new();
    let frames = stream.iter().filter_map(|&b| decoder.push(b)).collect();
    (frames, decoder.stats(), decoder.buffered_len())
}

#[test]
fn a_packet_inside_a_false_info_window_comes_out_the_same_in_any_chunking() {
    // `$I` announcing 196 bytes, noise, then a complete packet inside that window, then the
    // rest of the window filled by a second packet: the same frames and counters whether the
    // bytes come in one read, byte by byte, or split anywhere.
    let mut stream = vec![b'$', b'I', 2, 188, 0x11, 0x22, b'$', 0x33];
    stream.extend_from_slice(&packet(7));
    stream.extend_from_slice(&packet(8));
    stream.extend_from_slice(&piece_set().concat());
    let one = split_decode(&stream, &[stream.len()]);
    assert_eq!(packets_of(&one.0), vec![packet(7), packet(8)]);
    assert_eq!(one.0.len(), 3, "two packets and the record");
    assert_eq!(
        one.1.crc_errors, 0,
        "the false start is settled by the packet inside it"
    );
    assert_eq!(one.1.bytes_skipped, 8);
    assert_eq!(push_decode(&stream), one);
    for cut in 1..stream.len() {
        assert_eq!(
            split_decode(&stream, &[cut, stream.len()]),
            one,
            "cut at {cut}"
        );
        assert_eq!(split_decode(&stream, &[cut]), one, "chunks of {cut}");
    }
}

proptest! {
    #[test]
    fn any_split_of_the_same_bytes_gives_the_same_output(
        segments in proptest::collection::vec(any_segment(), 1..14),
        cuts in proptest::collection::vec(1usize..250, 1..24),
    ) {
        let stream = segments.concat();
        let one = split_decode(&stream, &[stream.len()]);
        prop_assert_eq!(&split_decode(&stream, &cuts), &one);
        prop_assert_eq!(&push_decode(&stream), &one);
        let (_, stats, buffered) = one;
        // Every valid frame or piece the stream holds was looked at: none is counted twice.
        prop_assert!(stats.packets + stats.info_pieces <= segments.len() as u64 * 9);
        prop_assert!(buffered < StreamDecoder::CAPACITY);
    }
}
