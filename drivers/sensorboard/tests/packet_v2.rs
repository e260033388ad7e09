//! Packet v2 and GNSS pieces: the byte tables, round trips, the CRC through `SensorCrc`,
//! refused damage, and the board's answer cycle.

mod common;

use dima_sensorboard::imu::{ImuPacketWords, IMU_LEN};
use dima_sensorboard::{
    crc32_bitwise, AnswerCycleV2, GnssFrame, GnssPiece, GnssPieceError, InfoFrame, LinkFlags,
    PacketBuilder, PacketV2, PacketV2Error, RawPacketV2, SampleClock, SensorCrc, SensorPacket,
    SensorStatus, Stm32Crc, Trailer, GNSS_PIECE_COUNT, GNSS_PIECE_LEN, GNSS_PIECE_START,
    INFO_PIECE_START, INFO_START, PACKET_START, PACKET_V2_LEN, PACKET_V2_START,
};
use proptest::prelude::*;

/// IMU words as the board sends them (status bits masked), from any 20 bytes.
fn imu_words() -> impl Strategy<Value = ImuPacketWords> {
    proptest::array::uniform20(any::<u8>()).prop_map(|b| ImuPacketWords::from_le_bytes(&b))
}

fn packet_v2() -> impl Strategy<Value = PacketV2> {
    (
        any::<u32>(),
        any::<u32>(),
        imu_words(),
        0u32..=0xF_FFFF,
        0u32..=0xF_FFFF,
        any::<u8>(),
        0u8..4,
    )
        .prop_map(
            |(request_count, sample_time_us, imu, p, t, status, flags)| PacketV2 {
                request_count,
                sample_time_us,
                imu,
                press_raw: p,
                temp_raw: t,
                status: SensorStatus::from_bits_retain(status),
                flags: LinkFlags::from_bits_truncate(flags),
            },
        )
}

fn sample() -> PacketV2 {
    let imu_bytes: [u8; IMU_LEN] = core::array::from_fn(|i| 0x10 + 0x10 * (i as u8 % 8));
    PacketV2 {
        request_count: 0x0403_0201,
        sample_time_us: 0x0807_0605,
        imu: ImuPacketWords::from_le_bytes(&imu_bytes),
        press_raw: 0xA_BCDE,
        temp_raw: 0x1_2345,
        status: SensorStatus::ACCEL_OK | SensorStatus::GNSS_SILENT,
        flags: LinkFlags::GNSS_PIECE_FOLLOWS,
    }
}

#[test]
fn layout_matches_the_byte_table() {
    let p = sample();
    let b = p.encode(&mut Stm32Crc);
    assert_eq!(b.len(), 42);
    assert_eq!(&b[0..2], b"$P");
    assert_eq!(&b[2..6], &[0x01, 0x02, 0x03, 0x04], "request count, u32 LE");
    assert_eq!(&b[6..10], &[0x05, 0x06, 0x07, 0x08], "sample time, u32 LE");
    assert_eq!(
        &b[10..30],
        &p.imu.to_le_bytes(),
        "the IMU words as v1 lays them out"
    );
    // adc_P = 0xABCDE: MSB 0xAB, LSB 0xCD, XLSB 0xE0 (BMP280 registers 0xF7..=0xF9).
    assert_eq!(&b[30..33], &[0xAB, 0xCD, 0xE0]);
    assert_eq!(&b[33..36], &[0x12, 0x34, 0x50]);
    assert_eq!(b[36], 0b1000_0001, "status: accel ok, GNSS silent");
    assert_eq!(b[37], 0b0000_0001, "flags: GNSS piece follows");
    assert_eq!(&b[38..42], &crc32_bitwise(&b[..38]).to_le_bytes());
}

#[test]
fn imu_area_is_v1s_bytes_2_to_21() {
    // The same words in a v1 packet and in a v2 packet: the same 20 bytes, and the same counts.
    let p = sample();
    let mut builder = PacketBuilder::new();
    builder.imu_words(&p.imu);
    let v1 = *builder.build(&mut Stm32Crc);
    let v2 = p.encode(&mut Stm32Crc);
    assert_eq!(&v1[2..22], &v2[10..30]);
    let old = SensorPacket::decode(&v1).unwrap();
    assert_eq!(
        PacketV2::decode(&v2).unwrap().imu_counts(),
        (old.accel, old.gyro, old.mag, old.rhall)
    );
}

/// Records what it was given and returns a fixed value, as a hardware unit would return its
/// register.
struct RecordingCrc {
    seen: Vec<u8>,
    value: u32,
}

impl SensorCrc for RecordingCrc {
    fn checksum(&mut self, bytes: &[u8]) -> u32 {
        self.seen = bytes.to_vec();
        self.value
    }
}

#[test]
fn crc_goes_through_the_sensor_crc_trait() {
    let mut crc = RecordingCrc {
        seen: Vec::new(),
        value: 0x1556_F485,
    };
    let b = sample().encode(&mut crc);
    assert_eq!(crc.seen, b[..38].to_vec(), "the CRC covers bytes 0-37");
    assert_eq!(&b[38..], &[0x85, 0xF4, 0x56, 0x15], "stored LE");
    // The unit's value is what the host checks against: the software CRC refuses this one.
    assert!(matches!(
        PacketV2::decode(&b),
        Err(PacketV2Error::Checksum {
            received: 0x1556_F485,
            ..
        })
    ));
    assert_eq!(PacketV2::decode_with(&b, &mut crc), Ok(sample()));
}

#[test]
fn crc_is_the_stm32_rule() {
    // The golden vector of the CRC tests: the same algorithm protects v2.
    assert_eq!(crc32_bitwise(b"123456789"), 0x1556_F485);
    let b = sample().encode(&mut Stm32Crc);
    assert_eq!(
        u32::from_le_bytes([b[38], b[39], b[40], b[41]]),
        crc32_bitwise(&b[..38])
    );
}

#[test]
fn damage_is_refused() {
    let good = sample().encode(&mut Stm32Crc);
    for bit in 0..PACKET_V2_LEN * 8 {
        let mut bad = good;
        bad[bit / 8] ^= 1 << (bit % 8);
        assert!(PacketV2::decode(&bad).is_err(), "bit {bit}");
    }
    assert_eq!(PacketV2::decode(&good[..41]), Err(PacketV2Error::Truncated));
    let mut v1_start = good;
    v1_start[1] = b'$';
    assert_eq!(PacketV2::decode(&v1_start), Err(PacketV2Error::StartToken));
    let mut wrong_crc = good;
    wrong_crc[41] ^= 0x80;
    assert!(matches!(
        PacketV2::decode(&wrong_crc),
        Err(PacketV2Error::Checksum { .. })
    ));
}

#[test]
fn start_tokens_cannot_be_confused() {
    let seconds = [
        PACKET_START[1],
        INFO_START[1],
        INFO_PIECE_START[1],
        PACKET_V2_START[1],
        GNSS_PIECE_START[1],
    ];
    for (i, a) in seconds.iter().enumerate() {
        for b in &seconds[i + 1..] {
            assert_ne!(a, b);
        }
    }
    for token in [PACKET_V2_START, GNSS_PIECE_START] {
        assert_eq!(token[0], b'$', "found by the same `$` search");
    }
}

#[test]
fn sample_clock_extends_across_the_wrap() {
    let mut clock = SampleClock::new();
    assert_eq!(clock.extend(0xFFFF_FE00), 0xFFFF_FE00);
    assert_eq!(clock.extend(0xFFFF_FF00), 0xFFFF_FF00);
    assert_eq!(
        clock.extend(0x0000_0100),
        0x1_0000_0100,
        "500 µs after the wrap"
    );
    assert_eq!(
        clock.extend(0xFFFF_FF80),
        0xFFFF_FF80,
        "a late answer steps back"
    );
    assert_eq!(clock.extend(0x0000_0300), 0x1_0000_0300);
}

proptest! {
    #[test]
    fn round_trip(p in packet_v2()) {
        let bytes = p.encode(&mut Stm32Crc);
        prop_assert_eq!(PacketV2::decode(&bytes), Ok(p));
        let raw = RawPacketV2::new(&bytes).unwrap();
        prop_assert_eq!(raw.into_bytes(), bytes);
        prop_assert_eq!(raw.decode(), p);
    }

    #[test]
    fn decode_is_total(bytes in proptest::collection::vec(any::<u8>(), 0..100)) {
        if let Ok(p) = PacketV2::decode(&bytes) {
            // Valid bytes decode to a packet that encodes back to a packet with the same values.
            prop_assert_eq!(PacketV2::decode(&p.encode(&mut Stm32Crc)), Ok(p));
        }
        let _ = GnssPiece::decode_with(&bytes, &mut Stm32Crc);
    }

    #[test]
    fn gnss_pieces_carry_the_frame(frame in common::gnss_frame(), epoch in any::<u8>()) {
        let set = frame.encode_pieces_with(epoch, &mut Stm32Crc);
        let mut joined = Vec::new();
        for (index, bytes) in set.iter().enumerate() {
            let piece = GnssPiece::decode_with(bytes, &mut Stm32Crc).unwrap();
            prop_assert_eq!(piece.epoch, epoch);
            prop_assert_eq!(usize::from(piece.index), index);
            joined.extend_from_slice(&piece.payload);
        }
        prop_assert_eq!(joined.as_slice(), &frame.as_bytes()[..]);
    }
}

#[test]
fn gnss_piece_layout_matches_the_byte_table() {
    let frame = GnssFrame::from_bytes(core::array::from_fn(|i| i as u8));
    let set = frame.encode_pieces_with(0x5A, &mut Stm32Crc);
    assert_eq!(set.len(), 4);
    for (index, b) in set.iter().enumerate() {
        assert_eq!(b.len(), 34);
        assert_eq!(&b[0..2], b"$G");
        assert_eq!(b[2], 0x5A, "epoch");
        assert_eq!(usize::from(b[3]), index, "index");
        assert_eq!(b[4], 4, "count");
        let first = 25 * index as u8;
        let expected: Vec<u8> = (first..first + 25).collect();
        assert_eq!(&b[5..30], expected.as_slice(), "frame bytes 25 x index ..");
        assert_eq!(&b[30..34], &crc32_bitwise(&b[..30]).to_le_bytes());
    }
}

#[test]
fn gnss_piece_damage_and_bad_headers_are_refused() {
    let set = GnssFrame::default().encode_pieces_with(1, &mut Stm32Crc);
    for bit in 0..GNSS_PIECE_LEN * 8 {
        let mut bad = set[2];
        bad[bit / 8] ^= 1 << (bit % 8);
        assert!(
            GnssPiece::decode_with(&bad, &mut Stm32Crc).is_err(),
            "bit {bit}"
        );
    }
    // A header the encoder never writes, with a valid CRC, is still refused.
    for (index, count) in [(4, 4), (0, 5), (0, 0), (2, 3)] {
        let mut bytes = set[0];
        bytes[3] = index;
        bytes[4] = count;
        let crc = crc32_bitwise(&bytes[..30]);
        bytes[30..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(
            GnssPiece::decode_with(&bytes, &mut Stm32Crc),
            Err(GnssPieceError::Header { index, count })
        );
    }
    assert_eq!(
        GnssPiece::decode_with(&set[0][..33], &mut Stm32Crc),
        Err(GnssPieceError::Truncated)
    );
}

fn info_set() -> Vec<[u8; 21]> {
    InfoFrame {
        version: 2,
        uptime_ms: 42,
        ..InfoFrame::default()
    }
    .encode_v2_pieces_with(3, &mut Stm32Crc)
    .to_vec()
}

/// What the cycle sends in the next `n` answers: `G<epoch>.<index>`, `I<index>` or `-`.
fn answers(cycle: &mut AnswerCycleV2, n: usize, restart_at: Option<usize>) -> Vec<String> {
    (0..n)
        .map(|i| match cycle.next(restart_at == Some(i)) {
            Some(Trailer::Gnss(b)) => {
                assert_eq!(Trailer::Gnss(b).flag(), LinkFlags::GNSS_PIECE_FOLLOWS);
                format!("G{}.{}", b[2], b[3])
            }
            Some(Trailer::Info(b)) => {
                assert_eq!(Trailer::Info(b).flag(), LinkFlags::INFO_PIECE_FOLLOWS);
                assert_eq!(Trailer::Info(b).as_bytes(), &b[..]);
                format!("I{}", b[3])
            }
            None => "-".to_string(),
        })
        .collect()
}

#[test]
fn answer_cycle_sends_gnss_first_then_info() {
    let mut cycle = AnswerCycleV2::new();
    assert_eq!(answers(&mut cycle, 2, None), ["-", "-"]);
    cycle.publish_info(&info_set());
    assert_eq!(cycle.publish_gnss(&GnssFrame::default(), &mut Stm32Crc), 0);
    assert!(cycle.gnss_pending());
    assert_eq!(
        answers(&mut cycle, 7, None),
        ["G0.0", "G0.1", "G0.2", "G0.3", "I0", "I1", "I2"]
    );
    assert!(!cycle.gnss_pending());
    // A new NAV-PVT frame interrupts the info record between pieces; the record resumes.
    assert_eq!(cycle.publish_gnss(&GnssFrame::default(), &mut Stm32Crc), 1);
    assert_eq!(
        answers(&mut cycle, 6, None),
        ["G1.0", "G1.1", "G1.2", "G1.3", "I3", "I4"]
    );
}

#[test]
fn a_newer_gnss_frame_waits_for_the_current_one() {
    let mut cycle = AnswerCycleV2::new();
    cycle.publish_gnss(&GnssFrame::default(), &mut Stm32Crc);
    assert_eq!(answers(&mut cycle, 2, None), ["G0.0", "G0.1"]);
    cycle.publish_gnss(&GnssFrame::default(), &mut Stm32Crc);
    cycle.publish_gnss(&GnssFrame::default(), &mut Stm32Crc);
    assert_eq!(
        answers(&mut cycle, 7, None),
        ["G0.2", "G0.3", "G2.0", "G2.1", "G2.2", "G2.3", "-"],
        "the current epoch finishes, then only the newest waiting one"
    );
}

#[test]
fn a_restart_during_gnss_pieces_restarts_the_info_record() {
    let mut cycle = AnswerCycleV2::new();
    cycle.publish_info(&info_set());
    assert_eq!(answers(&mut cycle, 3, None), ["I0", "I1", "I2"]);
    cycle.publish_gnss(&GnssFrame::default(), &mut Stm32Crc);
    assert_eq!(
        answers(&mut cycle, 6, Some(1)),
        ["G0.0", "G0.1", "G0.2", "G0.3", "I0", "I1"]
    );
    assert_eq!(usize::from(GNSS_PIECE_COUNT), 4);
}

#[test]
fn the_longest_answer_fits_the_wire_time_budget() {
    // The README's table: bytes x 10 bits (8N1) / baud, against the 500 µs period at 2 kHz.
    let longest = PACKET_V2_LEN + GNSS_PIECE_LEN.max(dima_sensorboard::INFO_PIECE_LEN);
    assert_eq!(longest, 76);
    let micros = |baud: u64| longest as u64 * 10 * 1_000_000 / baud;
    assert_eq!(
        micros(2_000_000),
        380,
        "2 Mbaud: three quarters of the period"
    );
    assert!(micros(3_000_000) * 100 <= 51 * 500, "3 Mbaud: about half");
    assert_eq!(micros(4_000_000), 190);
    // v1 would not fit at any of these rates with room to spare.
    assert_eq!(
        dima_sensorboard::PACKET_LEN as u64 * 10 * 1_000_000 / 3_000_000,
        440
    );
}

mod request_tracker {
    use dima_sensorboard::{AnswerMatch, RequestTracker};

    #[test]
    fn the_first_answer_sets_the_offset() {
        let mut t = RequestTracker::new();
        assert_eq!(t.classify(1000, 7), AnswerMatch::Current);
        assert_eq!(t.end_cycle(), 0);
        assert_eq!(t.classify(1001, 8), AnswerMatch::Current);
        assert_eq!(t.end_cycle(), 0);
    }

    #[test]
    fn a_late_answer_is_followed_by_the_current_one() {
        let mut t = RequestTracker::new();
        t.classify(u32::MAX - 1, 5);
        t.end_cycle();
        // Cycle u32::MAX: nothing came. Cycle 0 (the host's count wrapped): the late answer to
        // the previous request, then this one's.
        assert_eq!(t.end_cycle(), 0);
        assert_eq!(t.classify(0, 6), AnswerMatch::Behind(1));
        assert_eq!(t.classify(0, 7), AnswerMatch::Current);
        assert_eq!(t.end_cycle(), 0);
        // A late answer in each of two cycles is still only late.
        assert_eq!(t.classify(1, 7), AnswerMatch::Behind(1));
        assert_eq!(t.classify(1, 8), AnswerMatch::Current);
        assert_eq!(t.end_cycle(), 0);
        assert_eq!(t.classify(2, 8), AnswerMatch::Behind(1));
        assert_eq!(t.classify(2, 9), AnswerMatch::Current);
        assert_eq!(t.end_cycle(), 0);
        assert_eq!(t.missed_edges(), 0);
    }

    #[test]
    fn a_missed_edge_shows_as_answers_staying_behind() {
        let mut t = RequestTracker::new();
        t.classify(10, 100);
        t.end_cycle();
        // The board misses edge 11: no answer; from then on its count is one behind.
        assert_eq!(t.end_cycle(), 0);
        assert_eq!(t.classify(12, 101), AnswerMatch::Behind(1));
        assert_eq!(
            t.end_cycle(),
            0,
            "one cycle behind could still be a late answer"
        );
        assert_eq!(t.classify(13, 102), AnswerMatch::Behind(1));
        assert_eq!(
            t.end_cycle(),
            1,
            "two cycles behind by the same count: a missed edge"
        );
        assert_eq!(t.missed_edges(), 1);
        assert_eq!(t.classify(14, 103), AnswerMatch::Current);
        assert_eq!(t.end_cycle(), 0);
    }

    #[test]
    fn a_board_reset_resyncs() {
        let mut t = RequestTracker::new();
        t.classify(500, 500_000);
        t.end_cycle();
        assert_eq!(
            t.classify(501, 1),
            AnswerMatch::Resynced,
            "far behind: a reset"
        );
        t.end_cycle();
        assert_eq!(t.classify(502, 2), AnswerMatch::Current);
        assert_eq!(
            t.classify(503, 10),
            AnswerMatch::Resynced,
            "ahead of the requests"
        );
        assert_eq!(t.classify(504, 11), AnswerMatch::Current);
        assert_eq!(t.missed_edges(), 0);
    }
}
