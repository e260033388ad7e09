//! The generated capture of `capture.rs`: what a logic analyser records on the link (garbage
//! before the first packet, packets with and without GNSS, info frames, torn answers, stray
//! start bytes, line noise), with the packets and info frame that went into it.

use dima_sensorboard::nav_pvt;
use dima_sensorboard::{GnssFrame, InfoFrame, NavPvt, SensorPacket};

/// A small deterministic generator for garbage and read sizes (xorshift32).
pub struct Noise(pub u32);

impl Noise {
    pub fn next(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        self.0
    }

    pub fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.next() as u8).collect()
    }
}

pub fn fix(itow_ms: u32) -> NavPvt {
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

/// The capture and what went into it.
pub struct Capture {
    /// The bytes on the wire.
    pub bytes: Vec<u8>,
    /// The 200 packets sent, in order.
    pub sent: Vec<SensorPacket>,
    /// The info frame sent after packets 0 and 120.
    pub info: InfoFrame,
    /// Bytes the decoder must skip: 300 leading bytes, 10 torn answers of 60, 10 stray `$`,
    /// 10 noise bursts of 17.
    pub garbage: u64,
}

/// Builds the capture; `noise` goes on to choose read sizes afterwards.
pub fn generated(noise: &mut Noise) -> Capture {
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

    Capture {
        bytes: capture,
        sent,
        info,
        garbage: 300 + 10 * 60 + 10 + 10 * 17,
    }
}
