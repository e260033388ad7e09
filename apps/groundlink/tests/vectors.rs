//! Golden frames from the original DIMA ground station (Java GUI), as recorded in the project's
//! test-vector list: copied verbatim, never produced by this crate.

use dima_groundlink::{Command, CommandDecoder, CommandError};

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
