//! Golden frames, never produced by this crate: v1 frames from the original DIMA ground station
//! (Java GUI), as recorded in the project's test-vector list, copied verbatim; v2 command frames
//! computed by `tools/command-v2-vectors.py`, a SipHash-2-4 written from the SipHash paper and
//! checked against its vectors.

use dima_groundlink::v2::{self, CommandFrame, CommandGate, LinkKey};
use dima_groundlink::{Command, CommandDecoder, CommandError, Percent};

/// Heartbeat frame sent by the original ground station every 100 ms.
const HEARTBEAT: [u8; 10] = [0x24, 0x00, 0x00, 0x00, 0x00, 0x00, 0xC6, 0x22, 0xF7, 0x1D];
/// Kill frame sent by the original ground station.
const KILL: [u8; 10] = [0x24, 0x01, 0x00, 0x00, 0x00, 0x00, 0xFB, 0x42, 0xDE, 0xAD];

#[test]
fn heartbeat_encodes_byte_for_byte() {
    assert_eq!(Command::Heartbeat.encode(), HEARTBEAT);
}

#[test]
fn kill_encodes_byte_for_byte() {
    assert_eq!(Command::Kill.encode(), KILL);
}

#[test]
fn original_frames_decode() {
    assert_eq!(Command::decode(&HEARTBEAT), Ok(Command::Heartbeat));
    assert_eq!(Command::decode(&KILL), Ok(Command::Kill));
}

#[test]
fn original_frames_back_to_back_in_one_read() {
    let mut stream = [0u8; 20];
    stream[..10].copy_from_slice(&KILL);
    stream[10..].copy_from_slice(&HEARTBEAT);
    let mut decoder = CommandDecoder::new();
    let got: Vec<_> = decoder.feed(&stream).collect();
    assert_eq!(got, vec![Ok(Command::Kill), Ok(Command::Heartbeat)]);
    assert_eq!(decoder.stats().rejected(), 0);
    assert_eq!(decoder.stats().skipped_bytes, 0);
}

#[test]
fn every_single_bit_flip_of_the_kill_frame_is_rejected() {
    for bit in 0..80 {
        let mut frame = KILL;
        frame[bit / 8] ^= 1 << (bit % 8);
        let decoded = Command::decode(&frame);
        assert!(
            matches!(
                decoded,
                Err(CommandError::Crc { .. } | CommandError::BadStart { .. })
            ),
            "bit {bit}: {decoded:?}"
        );
    }
}

#[test]
fn unknown_type_with_valid_crc_is_not_a_heartbeat() {
    // Type 8 with a CRC computed the way the original ground station does (bytes 1..=5).
    let mut frame = HEARTBEAT;
    frame[1] = 8;
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&frame[1..6]);
    frame[6..].copy_from_slice(&crc.to_be_bytes());
    let mut decoder = CommandDecoder::new();
    let got: Vec<_> = decoder.feed(&frame).collect();
    assert_eq!(got, vec![Err(CommandError::UnknownType { found: 8 })]);
    assert_eq!(decoder.stats().unknown_type, 1);
    assert_eq!(decoder.stats().frames, 0);
}

/// Key of the v2 vectors: bytes 00..0f (the SipHash paper's key).
const V2_KEY: [u8; 16] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15];
/// Session of the revive and throttle vectors.
const V2_SESSION: u32 = 0x5EED_0001;
/// Revive, session 0x5EED0001, sequence 10, request 10.
const V2_REVIVE: [u8; 28] = [
    0xA5, 0x32, 0x1C, 0x02, 0x00, 0x00, 0x00, 0x00, 0x5E, 0xED, 0x00, 0x01, 0x00, 0x00, 0x00, 0x0A,
    0x00, 0x00, 0x00, 0x0A, 0x22, 0x43, 0x4B, 0xFF, 0x08, 0x8A, 0x52, 0x53,
];
/// Throttle 80 %, session 0x5EED0001, sequence 12, request 8 (a repetition of an older request).
const V2_THROTTLE_80: [u8; 28] = [
    0xA5, 0x32, 0x1C, 0x03, 0x00, 0x00, 0x00, 0x50, 0x5E, 0xED, 0x00, 0x01, 0x00, 0x00, 0x00, 0x0C,
    0x00, 0x00, 0x00, 0x08, 0xF1, 0x1A, 0x49, 0x59, 0x86, 0x44, 0x58, 0x18,
];
/// Kill, session 0 (a station that does not know the session), sequence 1, request 1.
const V2_KILL: [u8; 28] = [
    0xA5, 0x32, 0x1C, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01,
    0x00, 0x00, 0x00, 0x01, 0x81, 0xE2, 0xAD, 0x5E, 0x28, 0x58, 0x8F, 0xD3,
];
/// Speed setpoint -1500 mm/s, session 0xC0FFEE00, sequence 0x01020304, request 0x01020300.
const V2_SPEED: [u8; 28] = [
    0xA5, 0x32, 0x1C, 0x06, 0xFF, 0xFF, 0xFA, 0x24, 0xC0, 0xFF, 0xEE, 0x00, 0x01, 0x02, 0x03, 0x04,
    0x01, 0x02, 0x03, 0x00, 0x5E, 0x59, 0xE9, 0x1B, 0x1D, 0xD3, 0xF6, 0x1D,
];

fn v2_vectors() -> [(CommandFrame, [u8; 28]); 4] {
    let throttle = Command::Throttle(Percent::new(80).unwrap());
    [
        (
            CommandFrame::new(Command::Revive, V2_SESSION, 10),
            V2_REVIVE,
        ),
        (
            CommandFrame::repeat(throttle, V2_SESSION, 12, 8),
            V2_THROTTLE_80,
        ),
        (CommandFrame::new(Command::Kill, 0, 1), V2_KILL),
        (
            CommandFrame::repeat(
                Command::SpeedSetpoint { mm_s: -1500 },
                0xC0FF_EE00,
                0x0102_0304,
                0x0102_0300,
            ),
            V2_SPEED,
        ),
    ]
}

#[test]
fn v2_command_frames_encode_and_decode_byte_for_byte() {
    let key = LinkKey::from_bytes(V2_KEY);
    assert_eq!(v2::COMMAND_FRAME_LEN, 28);
    for (frame, bytes) in v2_vectors() {
        assert_eq!(frame.encode(&key), bytes, "{frame:?}");
        assert_eq!(CommandFrame::decode(&bytes, &key), Ok(frame));
    }
}

#[test]
fn v2_throttle_requested_before_the_revive_is_not_acted_on() {
    let mut gate = CommandGate::new(LinkKey::from_bytes(V2_KEY), V2_SESSION);
    let mut stream = V2_REVIVE.to_vec();
    stream.extend(V2_THROTTLE_80);
    stream.extend(V2_KILL);
    let got: Vec<_> = gate.feed(&stream).collect();
    assert_eq!(
        got,
        vec![
            Ok(Command::Revive),
            Ok(Command::Heartbeat),
            Ok(Command::Kill)
        ]
    );
    assert_eq!(gate.last_accepted(), 12);
    assert_eq!(gate.stats().pre_revive_requests, 1);
}
