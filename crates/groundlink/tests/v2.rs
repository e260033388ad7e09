//! Ground link v2: the MAC against the SipHash reference vectors, frame round trips, and the
//! stream properties of both decoders and the command gate.

use dima_groundlink::v2::{
    CommandDecoder, CommandFrame, CommandGate, DisplayDecoder, DisplayFrame, FailsafeCause,
    FrameError, Health, LinkKey, Rejection, ReviveRefusal, RobotMode, COMMAND_FRAME_LEN,
    DISPLAY_FRAME_LEN,
};
use dima_groundlink::{
    Command, DisplayFrame as SensorPayload, Percent, HEADING_FULL_TURN_DEG_E5, MAX_SPEED_MM_S,
};
use proptest::prelude::*;

/// The key of the SipHash paper's test vectors: bytes 00..0f.
fn reference_key() -> LinkKey {
    LinkKey::from_bytes(core::array::from_fn(|i| i as u8))
}

/// Vectors from the SipHash reference implementation (`vectors.h`, `vectors_sip64`, and the
/// paper's appendix for 15 bytes): key 00..0f, message 00..(n-1), output bytes in order.
#[test]
fn siphash_2_4_reference_vectors() {
    let key = reference_key();
    let message: Vec<u8> = (0u8..64).collect();
    let vectors: [(usize, [u8; 8]); 4] = [
        (0, [0x31, 0x0e, 0x0e, 0xdd, 0x47, 0xdb, 0x6f, 0x72]),
        (1, [0xfd, 0x67, 0xdc, 0x93, 0xc5, 0x39, 0xf8, 0x74]),
        (8, [0x62, 0x24, 0x93, 0x9a, 0x79, 0xf5, 0xf5, 0x93]),
        (15, [0xe5, 0x45, 0xbe, 0x49, 0x61, 0xca, 0x29, 0xa1]),
    ];
    for (len, expected) in vectors {
        assert_eq!(key.tag(&message[..len]), expected, "message length {len}");
        assert!(key.verify(&message[..len], &expected));
    }
}

fn key() -> impl Strategy<Value = LinkKey> {
    any::<[u8; 16]>().prop_map(LinkKey::from_bytes)
}

fn command() -> impl Strategy<Value = Command> {
    let percent = (0u8..=100).prop_map(|p| Percent::new(p).unwrap());
    prop_oneof![
        Just(Command::Heartbeat),
        Just(Command::Kill),
        Just(Command::Revive),
        percent.clone().prop_map(Command::Throttle),
        percent.clone().prop_map(Command::Steering),
        percent.prop_map(Command::Tail),
        (-MAX_SPEED_MM_S..=MAX_SPEED_MM_S).prop_map(|mm_s| Command::SpeedSetpoint { mm_s }),
        (0..HEADING_FULL_TURN_DEG_E5).prop_map(|deg_e5| Command::HeadingSetpoint { deg_e5 }),
    ]
}

/// Any valid frame: the request from 1 to the sequence number; a kill's anything.
fn command_frame() -> impl Strategy<Value = CommandFrame> {
    (command(), any::<u32>(), 1..=u32::MAX, any::<u32>()).prop_map(
        |(command, session, seq, back)| {
            let request = match command {
                Command::Kill => back,
                _ => seq - back % seq,
            };
            CommandFrame::repeat(command, session, seq, request)
        },
    )
}

/// A manual command or a setpoint: a value the operator gives.
fn is_manual_or_setpoint(command: Command) -> bool {
    matches!(
        command,
        Command::Throttle(_)
            | Command::Steering(_)
            | Command::Tail(_)
            | Command::SpeedSetpoint { .. }
            | Command::HeadingSetpoint { .. }
    )
}

fn sensors() -> impl Strategy<Value = SensorPayload> {
    (
        prop::array::uniform3(-2048i16..=2047),
        prop::array::uniform3(any::<i16>()),
        0u32..(1 << 20),
        -900_000_000i32..=900_000_000,
        0i32..=i32::MAX,
    )
        .prop_map(|(acc, gyro, press, lat, gs)| SensorPayload {
            acc,
            gyro,
            baro_press: press,
            lat_e7: lat,
            g_speed_mm_s: gs,
            ..SensorPayload::default()
        })
}

fn display_frame() -> impl Strategy<Value = DisplayFrame> {
    (
        0u8..4,
        any::<u8>(),
        any::<u8>(),
        prop::array::uniform3(any::<u32>()),
        prop::array::uniform9(any::<u32>()),
        sensors(),
    )
        .prop_map(
            |(mode, cause, refusal, [session, seq, ack], c, sensors)| DisplayFrame {
                mode: RobotMode::from_byte(mode).unwrap(),
                failsafe_cause: FailsafeCause::from_code(cause),
                revive_refusal: ReviveRefusal::from_code(refusal),
                session,
                seq,
                ack_seq: ack,
                health: Health {
                    missed_periods: c[0],
                    sensor_bad: c[1],
                    sensor_missing: c[2],
                    commands: c[3],
                    bad_tag: c[4],
                    replayed: c[5],
                    stale_session: c[6],
                    malformed: c[7],
                    v1_ignored: c[8],
                },
                sensors,
            },
        )
}

/// Splits `bytes` at the given cut points (taken modulo the length).
fn chunks(bytes: &[u8], cuts: &[usize]) -> Vec<Vec<u8>> {
    let mut points: Vec<usize> = cuts.iter().map(|c| c % (bytes.len() + 1)).collect();
    points.push(0);
    points.push(bytes.len());
    points.sort_unstable();
    points
        .windows(2)
        .map(|w| bytes[w[0]..w[1]].to_vec())
        .collect()
}

/// Bytes that look like frame starts to a v2 decoder, to make garbage hard.
fn garbage() -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(
        prop_oneof![
            any::<u8>(),
            Just(0xA5),
            Just(0x32),
            Just(0x44),
            Just(COMMAND_FRAME_LEN as u8),
            Just(DISPLAY_FRAME_LEN as u8)
        ],
        0..60,
    )
}

proptest! {
    #[test]
    fn command_round_trip(key in key(), frame in command_frame()) {
        prop_assert_eq!(CommandFrame::decode(&frame.encode(&key), &key), Ok(frame));
    }

    #[test]
    fn display_round_trip(key in key(), frame in display_frame()) {
        prop_assert_eq!(DisplayFrame::decode(&frame.encode(&key), &key), Ok(frame));
    }

    #[test]
    fn another_key_never_verifies(a in key(), b in key(), frame in command_frame()) {
        prop_assume!(a != b);
        prop_assert_eq!(CommandFrame::decode(&frame.encode(&a), &b), Err(FrameError::BadTag));
    }

    /// Garbage, forged frames (another key) and truncated frames between good frames never
    /// cost a good frame, and every rejected candidate is counted.
    #[test]
    fn command_stream_survives_garbage_forgeries_and_truncation(
        items in prop::collection::vec(
            (command_frame(), garbage(), 0..COMMAND_FRAME_LEN, any::<bool>()),
            0..12,
        ),
    ) {
        let key = reference_key();
        let forger = LinkKey::from_bytes([0xEE; 16]);
        let mut stream = Vec::new();
        for (frame, junk, cut, forge) in &items {
            stream.extend_from_slice(junk);
            if *forge {
                stream.extend_from_slice(&frame.encode(&forger));
            }
            // A truncated copy of the frame, then the frame itself.
            stream.extend_from_slice(&frame.encode(&key)[..*cut]);
            stream.extend_from_slice(&frame.encode(&key));
        }
        let mut decoder = CommandDecoder::new(key);
        let got: Vec<CommandFrame> = decoder.feed(&stream).filter_map(Result::ok).collect();
        let mut it = got.iter();
        for (frame, ..) in &items {
            prop_assert!(it.any(|g| g == frame), "lost {:?}", frame);
        }
        let forged = items.iter().filter(|i| i.3).count() as u32;
        prop_assert!(decoder.stats().bad_tag >= forged);
        let stats = decoder.stats();
        prop_assert_eq!(
            stream.len(),
            COMMAND_FRAME_LEN * stats.frames as usize + stats.skipped_bytes as usize + decoder.pending()
        );
    }

    /// The same bytes in any split give the same frames, rejections and counters.
    #[test]
    fn command_stream_is_independent_of_chunking(
        bytes in prop::collection::vec(any::<u8>(), 0..400),
        frames in prop::collection::vec(command_frame(), 0..6),
        cuts in prop::collection::vec(any::<usize>(), 0..40),
    ) {
        let key = reference_key();
        let mut stream = bytes.clone();
        for (i, frame) in frames.iter().enumerate() {
            let at = (i * 37) % (stream.len() + 1);
            let encoded = frame.encode(&key);
            stream.splice(at..at, encoded);
        }
        let mut whole = CommandGate::new(key.clone(), 7);
        let expected: Vec<_> = whole.feed(&stream).collect();
        let mut split = CommandGate::new(key, 7);
        let mut got = Vec::new();
        for chunk in chunks(&stream, &cuts) {
            got.extend(split.feed(&chunk));
        }
        prop_assert_eq!(got, expected);
        prop_assert_eq!(split.stats(), whole.stats());
        prop_assert_eq!(split.last_accepted(), whole.last_accepted());
    }

    #[test]
    fn display_stream_survives_garbage_and_chunking(
        items in prop::collection::vec((display_frame(), garbage(), 0..DISPLAY_FRAME_LEN), 0..6),
        cuts in prop::collection::vec(any::<usize>(), 0..30),
    ) {
        let key = reference_key();
        let mut stream = Vec::new();
        for (frame, junk, cut) in &items {
            stream.extend_from_slice(junk);
            stream.extend_from_slice(&frame.encode(&key)[..*cut]);
            stream.extend_from_slice(&frame.encode(&key));
        }
        let mut whole = DisplayDecoder::new(key.clone());
        let expected: Vec<_> = whole.feed(&stream).collect();
        let mut split = DisplayDecoder::new(key);
        let mut got = Vec::new();
        for chunk in chunks(&stream, &cuts) {
            got.extend(split.feed(&chunk));
        }
        prop_assert_eq!(&got, &expected);
        prop_assert_eq!(split.stats(), whole.stats());
        let good: Vec<DisplayFrame> = got.into_iter().filter_map(Result::ok).collect();
        let mut it = good.iter();
        for (frame, ..) in &items {
            prop_assert!(it.any(|g| g == frame), "lost {:?}", frame);
        }
        let stats = split.stats();
        prop_assert_eq!(
            stream.len(),
            DISPLAY_FRAME_LEN * stats.frames as usize + stats.skipped_bytes as usize + split.pending()
        );
    }

    #[test]
    fn decoders_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..3000)) {
        let key = reference_key();
        let mut gate = CommandGate::new(key.clone(), 1);
        let accepted = gate.feed(&bytes).filter(|r| r.is_ok()).count();
        prop_assert_eq!(accepted, 0);
        prop_assert!(gate.pending() < COMMAND_FRAME_LEN);
        let mut display = DisplayDecoder::new(key);
        prop_assert_eq!(display.feed(&bytes).filter(|r| r.is_ok()).count(), 0);
        prop_assert!(display.pending() < DISPLAY_FRAME_LEN);
    }

    /// The gate accepts each authentic (session, sequence) once, in increasing order only;
    /// kills always; it acts on a revive only for a request newer than the last one it acted
    /// on, and on a manual command or setpoint only for a request not older than that revive
    /// request (otherwise a heartbeat).
    #[test]
    fn gate_accepts_each_sequence_number_once(
        seqs in prop::collection::vec((1u32..50, command(), any::<bool>(), 0u32..12), 0..60),
    ) {
        let key = reference_key();
        let session = 0xABCD;
        let mut gate = CommandGate::new(key.clone(), session);
        let (mut last, mut last_request, mut repeats, mut pre_revive) = (0, 0, 0, 0);
        for (seq, command, stale, back) in seqs {
            let frame_session = if stale { 0 } else { session };
            let request = seq.saturating_sub(back).max(1);
            let bytes = CommandFrame::repeat(command, frame_session, seq, request).encode(&key);
            let result = gate.check(&bytes);
            if command == Command::Kill {
                prop_assert_eq!(result, Ok(Command::Kill));
            } else if stale {
                prop_assert_eq!(result, Err(Rejection::StaleSession));
            } else if seq <= last {
                prop_assert_eq!(result, Err(Rejection::Replayed));
            } else if command == Command::Revive && request <= last_request {
                prop_assert_eq!(result, Ok(Command::Heartbeat));
                repeats += 1;
            } else if is_manual_or_setpoint(command) && request < last_request {
                prop_assert_eq!(result, Ok(Command::Heartbeat));
                pre_revive += 1;
            } else {
                prop_assert_eq!(result, Ok(command));
                if command == Command::Revive {
                    last_request = request;
                }
            }
            if !stale && seq > last {
                last = seq;
            }
            prop_assert_eq!(gate.last_accepted(), last);
        }
        prop_assert_eq!(gate.stats().revive_repeats, repeats);
        prop_assert_eq!(gate.stats().pre_revive_requests, pre_revive);
    }
}

#[test]
fn a_v1_stream_yields_nothing_from_the_v2_gate() {
    let key = reference_key();
    let mut gate = CommandGate::new(key, 1);
    let mut stream = Vec::new();
    for command in [
        Command::Revive,
        Command::Throttle(Percent::MAX),
        Command::Kill,
    ] {
        stream.extend_from_slice(&command.encode());
    }
    assert_eq!(gate.feed(&stream).count(), 0);
    assert_eq!(gate.stats().accepted, 0);
    assert_eq!(gate.stats().skipped_bytes as usize, stream.len());
}
