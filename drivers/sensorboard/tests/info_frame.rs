//! The info frame v1: layout written by hand from the contract, round trips, bit flips and
//! frames from a future version.

mod common;

use dima_sensorboard::{crc32_bitwise, info_frame_len, INFO_MAX_LEN};
use dima_sensorboard::{
    BoardFaults, BoardHealth, InfoError, InfoFrame, SensorStatus, Stm32Crc, INFO_V1_LEN,
    INFO_V2_LEN, INFO_V3_LEN,
};
use proptest::prelude::*;

/// BMP280 calibration registers 0x88..=0x9F, datasheet example (golden vector).
const BMP280_CALIB: [u8; 24] = [
    0x70, 0x6B, 0x43, 0x67, 0x18, 0xFC, 0x7D, 0x8E, 0x43, 0xD6, 0xD0, 0x0B, 0x27, 0x0B, 0x8C, 0x00,
    0xF9, 0xFF, 0x8C, 0x3C, 0xF8, 0xC6, 0x70, 0x17,
];

/// BMM150 trim bursts, Bosch SensorAPI vector: 0x5D `00 00`; 0x62 `00 00 1A 1A`;
/// 0x68 `FB 02 AB 60 8D 1B 00 00 FD 1D`.
const BMM150_TRIM: [u8; 16] = [
    0x00, 0x00, 0x00, 0x00, 0x1A, 0x1A, 0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D,
];

/// Firmware 1.2.3, all sensors ok and GNSS seen, uptime 0x01020304 ms, 7 skipped requests;
/// CRC by the bitwise reference model.
fn hand_frame() -> [u8; 60] {
    let mut f = [0u8; 60];
    f[..4].copy_from_slice(&[0x24, 0x49, 1, 52]);
    f[4..8].copy_from_slice(&[1, 2, 3, 0b0001_1111]);
    f[8..32].copy_from_slice(&BMP280_CALIB);
    f[32..48].copy_from_slice(&BMM150_TRIM);
    f[48..52].copy_from_slice(&[0x04, 0x03, 0x02, 0x01]);
    f[52..56].copy_from_slice(&[7, 0, 0, 0]);
    let crc = crc32_bitwise(&f[..56]);
    f[56..].copy_from_slice(&crc.to_le_bytes());
    f
}

fn hand_info() -> InfoFrame {
    InfoFrame {
        version: 1,
        firmware: [1, 2, 3],
        status: SensorStatus::ACCEL_OK
            | SensorStatus::GYRO_OK
            | SensorStatus::MAG_OK
            | SensorStatus::BMP280_OK
            | SensorStatus::GNSS_SEEN,
        bmp280_calibration: BMP280_CALIB,
        bmm150_trim: BMM150_TRIM,
        uptime_ms: 0x0102_0304,
        requests_skipped: 7,
        ..InfoFrame::default()
    }
}

/// The version 2 frame of `hand_info` with every health field set to a distinct value, written
/// byte by byte from the layout in the crate docs; CRC by the bitwise reference model.
fn hand_frame_v2() -> [u8; 108] {
    let mut f = [0u8; 108];
    f[..56].copy_from_slice(&hand_frame()[..56]);
    f[2] = 2;
    f[3] = 100;
    for (i, counter) in [1u32, 2, 3, 4, 5, 6, 7, 8, 9, 10].iter().enumerate() {
        f[56 + 4 * i] = *counter as u8;
    }
    // The last counter spans all four bytes: 0x0A0B0C0D, little-endian.
    f[92..96].copy_from_slice(&[0x0D, 0x0C, 0x0B, 0x0A]);
    f[96..104].copy_from_slice(&[0x10, 0x00, 0x00, 0x01, 0xFF, 0xFF, 0x34, 0x12]);
    let crc = crc32_bitwise(&f[..104]);
    f[104..].copy_from_slice(&crc.to_le_bytes());
    f
}

fn hand_health() -> BoardHealth {
    BoardHealth {
        accel_errors: 1,
        gyro_errors: 2,
        mag_errors: 3,
        bmp280_errors: 4,
        mag_timeout_errors: 5,
        dma_errors: 6,
        requests_early: 7,
        gnss_bytes_dropped: 8,
        gnss_frame_errors: 9,
        watchdog_resets: 0x0A0B_0C0D,
        accel_age_ms: 16,
        gyro_age_ms: 256,
        mag_age_ms: u16::MAX,
        bmp280_age_ms: 0x1234,
    }
}

#[test]
fn hand_written_version_2_frame_decodes_with_its_health() {
    let (info, len) = InfoFrame::decode(&hand_frame_v2()).expect("valid");
    assert_eq!(len, INFO_V2_LEN);
    assert_eq!(
        info,
        InfoFrame {
            version: 2,
            health: hand_health(),
            ..hand_info()
        }
    );
}

#[test]
fn version_2_encoder_writes_the_hand_written_bytes() {
    let info = InfoFrame {
        health: hand_health(),
        ..hand_info()
    };
    assert_eq!(info.encode_v2_with(&mut Stm32Crc), hand_frame_v2());
}

/// Version 3 by hand: the version 2 bytes with header 3 / 120, then the faults
/// (104-119 four u32 counters, 120 the reset fault, 121-123 reserved), CRC at 124.
fn hand_frame_v3() -> [u8; 128] {
    let mut f = [0u8; 128];
    f[..104].copy_from_slice(&hand_frame_v2()[..104]);
    f[2] = 3;
    f[3] = 120;
    f[104..124].copy_from_slice(&[
        0x01, 0x00, 0x00, 0x00, 0x02, 0x01, 0x00, 0x00, 0x03, 0x00, 0x00, 0x80, 0x04, 0x00, 0x00,
        0x00, 0x04, 0x00, 0x00, 0x00,
    ]);
    let crc = crc32_bitwise(&f[..124]);
    f[124..].copy_from_slice(&crc.to_le_bytes());
    f
}

fn hand_faults() -> BoardFaults {
    BoardFaults {
        gnss_overrun_errors: 1,
        gnss_framing_errors: 0x0102,
        gnss_noise_errors: 0x8000_0003,
        sample_overruns: 4,
        reset_fault: 4,
    }
}

#[test]
fn hand_written_version_3_frame_decodes_with_health_and_faults() {
    let (info, len) = InfoFrame::decode(&hand_frame_v3()).expect("valid");
    assert_eq!(len, INFO_V3_LEN);
    assert_eq!(
        info,
        InfoFrame {
            version: 3,
            health: hand_health(),
            faults: hand_faults(),
            ..hand_info()
        }
    );
}

#[test]
fn version_3_encoder_writes_the_hand_written_bytes() {
    let info = InfoFrame {
        health: hand_health(),
        faults: hand_faults(),
        ..hand_info()
    };
    assert_eq!(info.encode_v3_with(&mut Stm32Crc), hand_frame_v3());
}

#[test]
fn version_2_frames_carry_no_faults_and_keep_decoding_exactly() {
    let (info, _) = InfoFrame::decode(&hand_frame_v2()).expect("valid");
    assert_eq!(info.faults, BoardFaults::default());
    // A version 2 encoder ignores the faults: the original board's bytes are unchanged.
    let with_faults = InfoFrame {
        health: hand_health(),
        faults: hand_faults(),
        ..hand_info()
    };
    assert_eq!(with_faults.encode_v2_with(&mut Stm32Crc), hand_frame_v2());
}

#[test]
fn a_version_3_frame_starts_with_what_a_version_2_decoder_reads() {
    let v3 = hand_frame_v3();
    let v2 = hand_frame_v2();
    assert_eq!(v3[4..104], v2[4..104]);
    let (info, _) = InfoFrame::decode(&v3).expect("valid");
    assert_eq!(info.health, hand_health());
}

#[test]
fn version_1_frames_carry_no_health() {
    let (info, _) = InfoFrame::decode(&hand_frame()).expect("valid");
    assert_eq!(info.health, BoardHealth::default());
}

#[test]
fn stream_decoder_finds_a_version_2_frame_between_packets() {
    let packet = dima_sensorboard::SensorPacket::default().encode();
    let mut bytes = packet.to_vec();
    bytes.extend_from_slice(&hand_frame_v2());
    bytes.extend_from_slice(&packet);
    let mut decoder = dima_sensorboard::StreamDecoder::new();
    let infos: Vec<_> = decoder
        .frames(&bytes)
        .filter_map(|f| match f {
            dima_sensorboard::Frame::Info(info) => Some(info),
            dima_sensorboard::Frame::Packet(_) => None,
        })
        .collect();
    assert_eq!(infos.len(), 1);
    assert_eq!(infos[0].health, hand_health());
    assert_eq!(decoder.stats().packets, 2);
    assert_eq!(decoder.stats().bytes_skipped, 0);
}

#[test]
fn hand_written_frame_decodes() {
    let (info, len) = InfoFrame::decode(&hand_frame()).expect("valid");
    assert_eq!(len, INFO_V1_LEN);
    assert_eq!(info, hand_info());
    assert!(!info.status.contains(SensorStatus::WATCHDOG_RESET));
}

#[test]
fn encoder_writes_the_hand_frame() {
    assert_eq!(hand_info().encode(), hand_frame());
    assert_eq!(INFO_V1_LEN, 60);
}

#[test]
fn status_bit_positions() {
    assert_eq!(SensorStatus::ACCEL_OK.bits(), 1 << 0);
    assert_eq!(SensorStatus::GYRO_OK.bits(), 1 << 1);
    assert_eq!(SensorStatus::MAG_OK.bits(), 1 << 2);
    assert_eq!(SensorStatus::BMP280_OK.bits(), 1 << 3);
    assert_eq!(SensorStatus::GNSS_SEEN.bits(), 1 << 4);
    assert_eq!(SensorStatus::WATCHDOG_RESET.bits(), 1 << 5);
}

#[test]
fn every_single_bit_flip_is_rejected() {
    let frame = hand_frame();
    for bit in 0..frame.len() * 8 {
        let mut bad = frame;
        bad[bit / 8] ^= 1 << (bit % 8);
        assert!(InfoFrame::decode(&bad).is_err(), "bit {bit} not detected");
    }
}

#[test]
fn a_default_frame_is_a_valid_version_1_frame() {
    // `..InfoFrame::default()` is how a board fills the fields it does not know yet: what it
    // sends must be accepted by every decoder (version 0 is not a valid version).
    let info = InfoFrame {
        uptime_ms: 42,
        ..InfoFrame::default()
    };
    assert_eq!(info.version, 1);
    let bytes = info.encode();
    assert_eq!(&bytes[..4], &[0x24, 0x49, 1, 52]);
    assert_eq!(InfoFrame::decode(&bytes), Ok((info, INFO_V1_LEN)));
}

#[test]
fn future_version_with_longer_payload() {
    // Version 2 with 8 more payload bytes: the known fields are read, the rest skipped, the
    // CRC covers header + all 60 payload bytes.
    let mut f = vec![0x24, 0x49, 2, 60];
    f.extend_from_slice(&hand_frame()[4..56]);
    f.extend_from_slice(&[0xAA; 8]);
    let crc = crc32_bitwise(&f);
    f.extend_from_slice(&crc.to_le_bytes());
    f.extend_from_slice(b"trailing");
    let (info, len) = InfoFrame::decode(&f).expect("valid");
    assert_eq!(len, 68);
    assert_eq!(
        info,
        InfoFrame {
            version: 2,
            ..hand_info()
        }
    );
}

#[test]
fn header_limits() {
    assert_eq!(info_frame_len([0x24, 0x49, 1, 52]), Ok(60));
    assert_eq!(info_frame_len([0x24, 0x49, 3, 200]), Ok(INFO_MAX_LEN));
    assert_eq!(
        info_frame_len([0x24, 0x49, 1, 201]),
        Err(InfoError::Header {
            version: 1,
            payload_len: 201
        })
    );
    assert_eq!(
        info_frame_len([0x24, 0x49, 1, 51]),
        Err(InfoError::Header {
            version: 1,
            payload_len: 51
        })
    );
    assert_eq!(
        info_frame_len([0x24, 0x49, 0, 52]),
        Err(InfoError::Header {
            version: 0,
            payload_len: 52
        })
    );
    assert_eq!(
        info_frame_len([0x24, 0x24, 1, 52]),
        Err(InfoError::StartToken)
    );
}

#[test]
fn truncated_input() {
    let frame = hand_frame();
    assert_eq!(
        InfoFrame::decode(&frame[..59]),
        Err(InfoError::Truncated { needed: 60 })
    );
    assert_eq!(
        InfoFrame::decode(&frame[..3]),
        Err(InfoError::Truncated { needed: 4 })
    );
    assert_eq!(InfoFrame::decode(b"$$xx"), Err(InfoError::StartToken));
    assert_eq!(InfoFrame::decode(b"ab"), Err(InfoError::StartToken));
}

proptest! {
    #[test]
    fn round_trip(info in common::info_frame()) {
        let bytes = info.encode();
        prop_assert_eq!(InfoFrame::decode(&bytes), Ok((info, INFO_V1_LEN)));
        prop_assert_eq!(crc32_bitwise(&bytes[..56]).to_le_bytes(), [bytes[56], bytes[57], bytes[58], bytes[59]]);
    }

    #[test]
    fn decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = InfoFrame::decode(&bytes);
        let mut with_start = b"$I".to_vec();
        with_start.extend_from_slice(&bytes);
        let _ = InfoFrame::decode(&with_start);
    }
}
