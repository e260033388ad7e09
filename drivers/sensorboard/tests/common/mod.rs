//! Strategies and helpers shared by the integration tests.
#![allow(dead_code)]

use dima_sensorboard::{GnssFrame, InfoFrame, SensorPacket, SensorStatus};
use proptest::prelude::*;

/// The UBX Fletcher checksum, written out independently of the crate.
pub fn fletcher(bytes: &[u8]) -> [u8; 2] {
    let (mut a, mut b) = (0u8, 0u8);
    for &byte in bytes {
        a = a.wrapping_add(byte);
        b = b.wrapping_add(a);
    }
    [a, b]
}

/// A NAV-PVT frame around `payload`, with the checksum of the specification.
pub fn nav_pvt_frame(payload: [u8; 92]) -> [u8; 100] {
    let mut frame = [0u8; 100];
    frame[..6].copy_from_slice(&[0xB5, 0x62, 0x01, 0x07, 92, 0]);
    frame[6..98].copy_from_slice(&payload);
    let ck = fletcher(&frame[2..98]);
    frame[98..].copy_from_slice(&ck);
    frame
}

fn bytes<const N: usize>() -> impl Strategy<Value = [u8; N]> {
    proptest::collection::vec(any::<u8>(), N).prop_map(|v| {
        let mut out = [0u8; N];
        out.copy_from_slice(&v);
        out
    })
}

/// A GNSS area: absent, a valid NAV-PVT frame, or arbitrary bytes.
pub fn gnss_frame() -> impl Strategy<Value = GnssFrame> {
    prop_oneof![
        Just(GnssFrame::ABSENT),
        bytes::<92>().prop_map(|p| GnssFrame::from_bytes(nav_pvt_frame(p))),
        bytes::<100>().prop_map(GnssFrame::from_bytes),
    ]
}

/// A packet whose every field is inside its wire width.
pub fn sensor_packet() -> impl Strategy<Value = SensorPacket> {
    (
        [-2048i16..=2047, -2048i16..=2047, -2048i16..=2047],
        any::<[i16; 3]>(),
        [-4096i16..=4095, -4096i16..=4095, -16384i16..=16383],
        0u16..=0x3FFF,
        0u32..=0xF_FFFF,
        0u32..=0xF_FFFF,
        gnss_frame(),
    )
        .prop_map(
            |(accel, gyro, mag, rhall, press_raw, temp_raw, gnss)| SensorPacket {
                accel,
                gyro,
                mag,
                rhall,
                press_raw,
                temp_raw,
                gnss,
            },
        )
}

/// A version 1 info frame with arbitrary contents.
pub fn info_frame() -> impl Strategy<Value = InfoFrame> {
    (
        any::<[u8; 3]>(),
        any::<u8>(),
        bytes::<24>(),
        bytes::<16>(),
        any::<u32>(),
        any::<u32>(),
    )
        .prop_map(
            |(firmware, status, bmp280_calibration, bmm150_trim, uptime_ms, requests_skipped)| {
                InfoFrame {
                    version: 1,
                    firmware,
                    status: SensorStatus::from_bits_retain(status),
                    bmp280_calibration,
                    bmm150_trim,
                    uptime_ms,
                    requests_skipped,
                    ..InfoFrame::default()
                }
            },
        )
}
