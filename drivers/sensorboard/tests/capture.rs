//! End to end: a capture like a logic analyser records it (garbage before the first packet,
//! packets with and without GNSS, info frames, a torn answer, stray start bytes) decoded in
//! arbitrary reads, as `examples/decode.rs` does.

use dima_sensorboard::nav_pvt;
use dima_sensorboard::{Frame, GnssFrame, InfoFrame, NavPvt, SensorPacket, StreamDecoder};

/// A small deterministic generator for garbage and read sizes (xorshift32).
struct Noise(u32);

impl Noise {
    fn next(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        self.0
    }

    fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.next() as u8).collect()
    }
}

fn fix(itow_ms: u32) -> NavPvt {
    NavPvt {
        itow_ms,
        year: 2026,
        month: 11,
        day: 22,
        hour: 8,
        min: 0,
        sec: 0,
        valid: nav_pvt::VALID_DATE | nav_pvt::VALID_TIME,
        t_acc_ns: 30,
        nano_ns: 0,
        fix_type: 3,
        flags: 1,
        flags2: 0,
        num_sv: 9,
        lon_deg_e7: 85_465_123,
        lat_deg_e7: 473_976_543,
        height_mm: 500_000,
        h_msl_mm: 452_000,
        h_acc_mm: 1500,
        v_acc_mm: 2500,
        vel_n_mm_s: 1000,
        vel_e_mm_s: -1000,
        vel_d_mm_s: 0,
        g_speed_mm_s: 1414,
        head_mot_deg_e5: 13_500_000,
        s_acc_mm_s: 200,
        head_acc_deg_e5: 1_000_000,
        p_dop_e2: 150,
        reserved1: [0; 6],
        head_veh_deg_e5: 0,
        mag_dec_deg_e2: 0,
        mag_acc_deg_e2: 0,
    }
}

#[test]
fn generated_capture_decodes_to_exactly_the_sent_packets() {
    let mut noise = Noise(0x1234_5678);
    let mut capture = noise.bytes(300);
    let mut sent = Vec::new();
    let info = InfoFrame {
        version: 1,
        firmware: [0, 1, 0],
        uptime_ms: 5,
        ..InfoFrame::default()
    };
    for i in 0..200i16 {
        let packet = SensorPacket {
            accel: [i, -i, 1000],
            gyro: [i * 100, 0, -i],
            mag: [i, 2 * i, -3 * i],
            rhall: 6000 + i as u16,
            press_raw: 415_148 + i as u32,
            temp_raw: 519_888,
            gnss: if i < 50 {
                GnssFrame::ABSENT
            } else {
                GnssFrame::from_nav_pvt(&fix(1000 * i as u32))
            },
        };
        let bytes = packet.encode();
        match i % 20 {
            // A torn answer: the next one must be found in the bytes the torn one swallowed.
            7 => capture.extend_from_slice(&bytes[..60]),
            // A stray start byte glued to the packet.
            11 => capture.push(b'$'),
            // A burst of line noise.
            13 => capture.extend(noise.bytes(17)),
            _ => {}
        }
        capture.extend_from_slice(&bytes);
        sent.push(packet);
        if i == 0 || i == 120 {
            capture.extend_from_slice(&info.encode());
        }
    }

    let mut decoder = StreamDecoder::new();
    let mut packets = Vec::new();
    let mut infos = 0;
    let mut rest = &capture[..];
    while !rest.is_empty() {
        let n = (noise.next() as usize % 300 + 1).min(rest.len());
        let (chunk, tail) = rest.split_at(n);
        for frame in decoder.frames(chunk) {
            match frame {
                Frame::Packet(raw) => packets.push(raw.decode()),
                Frame::Info(got) => {
                    assert_eq!(got, info);
                    infos += 1;
                }
            }
        }
        rest = tail;
    }

    assert_eq!(packets, sent);
    assert_eq!(infos, 2);
    assert!(packets[..50].iter().all(|p| p.nav_pvt().is_none()));
    let pvt = packets[150].nav_pvt().expect("GNSS present");
    assert_eq!(pvt.itow_ms, 150_000);
    assert!((pvt.lat_deg() - 47.397_654_3).abs() < 1e-12);
    let stats = decoder.stats();
    assert_eq!(stats.packets, 200);
    assert_eq!(stats.info_frames, 2);
    assert_eq!(decoder.buffered_len(), 0);
    // 300 leading bytes, 10 torn answers of 60, 10 stray `$`, 10 noise bursts of 17.
    assert_eq!(stats.bytes_skipped, 300 + 10 * 60 + 10 + 10 * 17);
}
