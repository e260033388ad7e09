//! Info pieces: the wire layout against an independent CRC, the board's piece cycle, and the
//! stream decoder putting records back together (in order, with lost, bad and foreign pieces,
//! between packets, in any chunking).

mod common;

use dima_sensorboard::{
    BoardFaults, BoardHealth, DecoderStats, Frame, InfoFrame, InfoPiece, InfoPieceCycle,
    InfoPieceError, SensorPacket, SensorStatus, Stm32Crc, StreamDecoder, INFO_PIECE_LEN,
    INFO_PIECE_MAX_COUNT, INFO_V2_LEN, INFO_V2_PIECES, INFO_V3_PIECES, PACKET_LEN,
};
use proptest::prelude::*;

/// The sensor CRC computed by the `crc` crate's CRC-32/MPEG-2 over the stream in which every
/// byte `b` becomes the word `00 00 00 b` (as the board feeds its CRC unit), independently of
/// this crate.
fn independent_crc(bytes: &[u8]) -> u32 {
    let mpeg2 = crc::Crc::<u32>::new(&crc::CRC_32_MPEG_2);
    let mut digest = mpeg2.digest();
    for &b in bytes {
        digest.update(&[0, 0, 0, b]);
    }
    digest.finalize()
}

/// Piece 2 of 9 of snapshot 7, written byte by byte from the layout in the crate docs.
fn hand_piece() -> [u8; 21] {
    let mut p = [0u8; 21];
    p[..2].copy_from_slice(b"$H");
    p[2] = 7;
    p[3] = 2;
    p[4] = 9;
    for (i, b) in p[5..17].iter_mut().enumerate() {
        *b = 0xA0 + i as u8;
    }
    let crc = independent_crc(&p[..17]);
    p[17..].copy_from_slice(&crc.to_le_bytes());
    p
}

fn info(uptime_ms: u32) -> InfoFrame {
    InfoFrame {
        version: 2,
        firmware: [0, 1, 0],
        status: SensorStatus::ACCEL_OK | SensorStatus::GNSS_SEEN,
        bmp280_calibration: [0x24; 24],
        bmm150_trim: [0x48; 16],
        uptime_ms,
        requests_skipped: 3,
        health: BoardHealth {
            dma_errors: 2,
            gnss_bytes_dropped: 0x2448_2449,
            mag_age_ms: 17,
            ..BoardHealth::default()
        },
        faults: BoardFaults::default(),
    }
}

fn pieces(uptime_ms: u32, snapshot: u8) -> [[u8; INFO_PIECE_LEN]; INFO_V2_PIECES] {
    info(uptime_ms).encode_v2_pieces_with(snapshot, &mut Stm32Crc)
}

fn packet(gyro_x: i16) -> [u8; PACKET_LEN] {
    SensorPacket {
        gyro: [gyro_x, 2, 3],
        ..SensorPacket::default()
    }
    .encode()
}

fn decode_all(bytes: &[u8]) -> (Vec<Frame>, DecoderStats) {
    let mut decoder = StreamDecoder::new();
    let frames = decoder.frames(bytes).collect();
    (frames, decoder.stats())
}

fn infos(frames: &[Frame]) -> Vec<InfoFrame> {
    frames
        .iter()
        .filter_map(|f| match f {
            Frame::Info(i) => Some(*i),
            Frame::Packet(_) => None,
        })
        .collect()
}

#[test]
fn hand_written_piece_decodes_and_encodes() {
    let bytes = hand_piece();
    let piece = InfoPiece::decode_with(&bytes, &mut Stm32Crc).expect("valid");
    assert_eq!(
        piece,
        InfoPiece {
            snapshot: 7,
            index: 2,
            count: 9,
            payload: core::array::from_fn(|i| 0xA0 + i as u8),
        }
    );
    assert_eq!(piece.encode_with(&mut Stm32Crc), bytes);
    assert_eq!(INFO_PIECE_LEN, 21);
    assert_eq!(INFO_V2_PIECES, 9);
}

#[test]
fn piece_errors() {
    let good = hand_piece();
    assert_eq!(
        InfoPiece::decode_with(&good[..20], &mut Stm32Crc),
        Err(InfoPieceError::Truncated)
    );
    let mut bad = good;
    bad[1] = b'I';
    assert_eq!(
        InfoPiece::decode_with(&bad, &mut Stm32Crc),
        Err(InfoPieceError::StartToken)
    );
    for (index, count) in [(9, 9), (0, 0), (0, INFO_PIECE_MAX_COUNT + 1)] {
        let mut bad = good;
        bad[3] = index;
        bad[4] = count;
        assert_eq!(
            InfoPiece::decode_with(&bad, &mut Stm32Crc),
            Err(InfoPieceError::Header { index, count })
        );
    }
    for byte in 0..good.len() {
        for bit in 0..8 {
            let mut bad = good;
            bad[byte] ^= 1 << bit;
            assert!(InfoPiece::decode_with(&bad, &mut Stm32Crc).is_err());
        }
    }
}

#[test]
fn the_pieces_of_a_v2_frame_carry_it_in_order_each_with_its_crc() {
    let set = pieces(1234, 5);
    let mut carried = Vec::new();
    for (i, p) in set.iter().enumerate() {
        assert_eq!(&p[..5], &[b'$', b'H', 5, i as u8, 9]);
        assert_eq!(
            independent_crc(&p[..17]).to_le_bytes(),
            [p[17], p[18], p[19], p[20]]
        );
        carried.extend_from_slice(&p[5..17]);
    }
    assert_eq!(carried.len(), INFO_V2_LEN);
    // The carried bytes are a complete v2 info frame: its own CRC checked independently.
    assert_eq!(&carried[..4], &[b'$', b'I', 2, 100]);
    assert_eq!(
        independent_crc(&carried[..104]).to_le_bytes(),
        [carried[104], carried[105], carried[106], carried[107]]
    );
    let (decoded, _) = InfoFrame::decode(&carried).unwrap();
    assert_eq!(decoded, info(1234));
}

#[test]
fn eleven_pieces_make_one_version_3_record() {
    let info = InfoFrame {
        version: 3,
        faults: BoardFaults {
            gnss_overrun_errors: 5,
            sample_overruns: 6,
            reset_fault: 4,
            ..BoardFaults::default()
        },
        ..info(20)
    };
    let set = info.encode_v3_pieces_with(4, &mut Stm32Crc);
    assert_eq!(set.len(), INFO_V3_PIECES);
    assert_eq!(INFO_V3_PIECES, 11);
    for (i, p) in set.iter().enumerate() {
        assert_eq!(&p[..5], &[b'$', b'H', 4, i as u8, 11]);
    }
    let (frames, stats) = decode_all(&set.concat());
    assert_eq!(frames, vec![Frame::Info(info)]);
    assert_eq!(stats.info_pieces, 11);
    assert_eq!(stats.info_records_dropped, 0);
}

#[test]
fn the_cycle_sends_a_version_3_set_whole_then_a_version_2_set() {
    let v3 = InfoFrame {
        version: 3,
        ..info(1)
    }
    .encode_v3_pieces_with(1, &mut Stm32Crc);
    let v2 = pieces(2, 2);
    let mut cycle = InfoPieceCycle::new();
    cycle.publish(&v3);
    cycle.publish(&v3);
    let mut sent = Vec::new();
    while let Some(piece) = cycle.next(false) {
        sent.push(*piece);
        if sent.len() == INFO_V3_PIECES {
            cycle.publish(&v2);
        }
    }
    assert_eq!(sent.len(), INFO_V3_PIECES + INFO_V2_PIECES);
    assert_eq!(sent[..INFO_V3_PIECES], v3);
    assert_eq!(sent[INFO_V3_PIECES..], v2);
}

#[test]
fn nine_pieces_make_one_record() {
    let (frames, stats) = decode_all(&pieces(10, 1).concat());
    assert_eq!(frames, vec![Frame::Info(info(10))]);
    assert_eq!(stats.info_pieces, 9);
    assert_eq!(stats.info_frames, 1);
    assert_eq!(stats.info_records_dropped, 0);
    assert_eq!(stats.bytes_skipped, 0);
}

#[test]
fn interleaved_with_packets_as_the_board_answers() {
    let mut stream = Vec::new();
    for (i, p) in pieces(500, 2)
        .iter()
        .chain(pieces(750, 3).iter())
        .enumerate()
    {
        stream.extend_from_slice(&packet(i as i16));
        stream.extend_from_slice(p);
    }
    let mut decoder = StreamDecoder::new();
    let mut seen = Vec::new();
    for chunk in stream.chunks(153) {
        seen.push(decoder.frames(chunk).collect::<Vec<_>>());
    }
    // Each answer gives its packet; answers 9 and 18 also give the completed record.
    for (i, frames) in seen.iter().enumerate() {
        assert!(matches!(frames[0], Frame::Packet(_)), "answer {i}");
        let expected = match i {
            8 => vec![info(500)],
            17 => vec![info(750)],
            _ => vec![],
        };
        assert_eq!(infos(frames), expected, "answer {i}");
    }
    let s = decoder.stats();
    assert_eq!((s.packets, s.info_frames, s.info_pieces), (18, 2, 18));
    assert_eq!(
        (s.crc_errors, s.bytes_skipped, s.info_records_dropped),
        (0, 0, 0)
    );
}

#[test]
fn a_lost_piece_drops_its_record_only() {
    for lost in 0..INFO_V2_PIECES {
        let mut stream = Vec::new();
        for (i, p) in pieces(1, 1).iter().enumerate() {
            if i != lost {
                stream.extend_from_slice(p);
            }
        }
        stream.extend_from_slice(&pieces(2, 2).concat());
        let (frames, stats) = decode_all(&stream);
        assert_eq!(frames, vec![Frame::Info(info(2))], "lost piece {lost}");
        assert_eq!(stats.info_records_dropped, 1, "lost piece {lost}");
        assert_eq!(stats.info_pieces, 17);
    }
}

#[test]
fn a_bad_piece_drops_its_record_and_counts_a_crc_error() {
    let mut set = pieces(1, 1);
    set[4][9] ^= 0x10;
    let mut stream = set.concat();
    stream.extend_from_slice(&pieces(2, 2).concat());
    let (frames, stats) = decode_all(&stream);
    assert_eq!(frames, vec![Frame::Info(info(2))]);
    assert_eq!(stats.crc_errors, 1);
    assert_eq!(stats.info_records_dropped, 1);
    assert_eq!(stats.bytes_skipped, INFO_PIECE_LEN as u64);
}

#[test]
fn a_piece_from_another_snapshot_drops_the_record() {
    let a = pieces(1, 1);
    let b = pieces(2, 2);
    let mut stream = Vec::new();
    for p in &a[..4] {
        stream.extend_from_slice(p);
    }
    // Piece 4 of another snapshot, then the rest of the first: nothing can be put together.
    stream.extend_from_slice(&b[4]);
    for p in &a[5..] {
        stream.extend_from_slice(p);
    }
    stream.extend_from_slice(&pieces(3, 3).concat());
    let (frames, stats) = decode_all(&stream);
    assert_eq!(frames, vec![Frame::Info(info(3))]);
    assert_eq!(stats.info_records_dropped, 1, "{stats:?}");
}

#[test]
fn a_record_joined_late_is_dropped_once_and_the_next_one_comes_out() {
    let mut stream = pieces(1, 1)[3..].concat();
    stream.extend_from_slice(&pieces(2, 2).concat());
    let (frames, stats) = decode_all(&stream);
    assert_eq!(frames, vec![Frame::Info(info(2))]);
    assert_eq!(stats.info_records_dropped, 1);
}

#[test]
fn a_new_piece_zero_replaces_an_unfinished_record() {
    let mut stream = pieces(1, 1)[..5].concat();
    stream.extend_from_slice(&pieces(2, 2).concat());
    let (frames, stats) = decode_all(&stream);
    assert_eq!(frames, vec![Frame::Info(info(2))]);
    assert_eq!(stats.info_records_dropped, 1);
}

#[test]
fn valid_pieces_that_are_not_an_info_frame_are_a_dropped_record() {
    let set: Vec<u8> = (0..9u8)
        .flat_map(|index| {
            InfoPiece {
                snapshot: 4,
                index,
                count: 9,
                payload: [index; 12],
            }
            .encode_with(&mut Stm32Crc)
        })
        .collect();
    let (frames, stats) = decode_all(&set);
    assert!(frames.is_empty());
    assert_eq!((stats.info_pieces, stats.info_records_dropped), (9, 1));
}

#[test]
fn a_piece_inside_a_false_info_start_comes_out_at_once() {
    // `$I` with a valid header announcing 192 bytes, then the nine pieces: every piece is
    // found when its last byte arrives, not after the false start's 192 bytes.
    let mut stream = vec![b'$', b'I', 2, 184];
    stream.extend_from_slice(&pieces(9, 9).concat());
    let mut decoder = StreamDecoder::new();
    let mut at = None;
    for (i, &b) in stream.iter().enumerate() {
        if let Some(frame) = decoder.push(b) {
            assert_eq!(frame, Frame::Info(info(9)));
            at = Some(i + 1);
        }
    }
    assert_eq!(at, Some(stream.len()));
    assert_eq!(decoder.stats().bytes_skipped, 4);
}

// --- the board's piece cycle ---

fn sent(cycle: &mut InfoPieceCycle, restart: bool) -> Option<(u8, u8)> {
    cycle.next(restart).map(|p| (p[2], p[3]))
}

#[test]
fn cycle_sends_nothing_before_the_first_snapshot() {
    let mut cycle = InfoPieceCycle::new();
    assert_eq!(sent(&mut cycle, true), None);
    assert_eq!(sent(&mut cycle, false), None);
}

#[test]
fn cycle_sends_each_snapshot_once_in_order() {
    let mut cycle = InfoPieceCycle::new();
    cycle.publish(&pieces(0, 1));
    for i in 0..9 {
        assert_eq!(sent(&mut cycle, false), Some((1, i)));
    }
    assert_eq!(sent(&mut cycle, false), None, "sent once");
    assert_eq!(sent(&mut cycle, false), None);
    cycle.publish(&pieces(250, 2));
    assert_eq!(sent(&mut cycle, false), Some((2, 0)));
}

#[test]
fn cycle_finishes_a_snapshot_before_starting_a_newer_one() {
    let mut cycle = InfoPieceCycle::new();
    cycle.publish(&pieces(0, 1));
    for i in 0..4 {
        assert_eq!(sent(&mut cycle, false), Some((1, i)));
    }
    cycle.publish(&pieces(250, 2));
    cycle.publish(&pieces(500, 3));
    for i in 4..9 {
        assert_eq!(sent(&mut cycle, false), Some((1, i)));
    }
    // Only the newest waiting snapshot is kept.
    assert_eq!(sent(&mut cycle, false), Some((3, 0)));
}

#[test]
fn cycle_restarts_from_piece_zero_when_the_host_restarts() {
    let mut cycle = InfoPieceCycle::new();
    cycle.publish(&pieces(0, 1));
    for i in 0..5 {
        assert_eq!(sent(&mut cycle, false), Some((1, i)));
    }
    assert_eq!(sent(&mut cycle, true), Some((1, 0)), "same snapshot again");
    for _ in 1..9 {
        sent(&mut cycle, false);
    }
    assert_eq!(
        sent(&mut cycle, true),
        Some((1, 0)),
        "even after it was out"
    );
    cycle.publish(&pieces(250, 2));
    assert_eq!(
        sent(&mut cycle, true),
        Some((2, 0)),
        "the newest one if one waits"
    );
}

#[test]
fn the_cycle_output_decodes_to_the_records_published() {
    let mut cycle = InfoPieceCycle::new();
    let mut decoder = StreamDecoder::new();
    let mut records = Vec::new();
    for answer in 0..200u32 {
        // A snapshot every 62 answers (250 ms at 250 Hz).
        if answer % 62 == 0 {
            cycle.publish(&pieces(answer, (answer / 62) as u8));
        }
        let mut bytes = packet(answer as i16).to_vec();
        if let Some(p) = cycle.next(false) {
            bytes.extend_from_slice(p);
        }
        records.extend(infos(&decoder.frames(&bytes).collect::<Vec<_>>()));
    }
    assert_eq!(records, vec![info(0), info(62), info(124), info(186)]);
    assert_eq!(decoder.stats().info_records_dropped, 0);
}

// --- any chunking ---

/// A board-like stream: answers (packet + piece) of two snapshots, then noise, torn frames
/// and a whole info frame.
fn board_stream() -> impl Strategy<Value = Vec<u8>> {
    (
        any::<u8>(),
        proptest::collection::vec(0u8..4, 18),
        proptest::collection::vec(any::<u8>(), 0..8),
    )
        .prop_map(|(snapshot, faults, noise)| {
            let sets = [pieces(1, snapshot), pieces(2, snapshot.wrapping_add(1))];
            let mut stream = Vec::new();
            for (i, fault) in faults.iter().enumerate() {
                stream.extend_from_slice(&packet(i as i16));
                let piece = sets[i / 9][i % 9];
                match fault {
                    0 => {}
                    1 => stream.extend_from_slice(&piece[..10]),
                    _ => stream.extend_from_slice(&piece),
                }
                if *fault == 3 {
                    stream.extend_from_slice(&noise);
                }
            }
            stream.extend_from_slice(&info(3).encode_v2_with(&mut Stm32Crc));
            stream
        })
}

proptest! {
    #[test]
    fn records_come_out_the_same_in_any_chunking(
        stream in board_stream(),
        cuts in proptest::collection::vec(1usize..200, 1..40),
    ) {
        let (whole, whole_stats) = decode_all(&stream);
        let mut decoder = StreamDecoder::new();
        let mut frames = Vec::new();
        let mut rest = &stream[..];
        for cut in cuts.iter().cycle() {
            if rest.is_empty() {
                break;
            }
            let (chunk, tail) = rest.split_at((*cut).min(rest.len()));
            frames.extend(decoder.frames(chunk));
            rest = tail;
        }
        prop_assert_eq!(&frames, &whole);
        prop_assert_eq!(decoder.stats(), whole_stats);
        // The whole frame at the end always comes out.
        prop_assert_eq!(whole.last(), Some(&Frame::Info(info(3))));
    }
}
