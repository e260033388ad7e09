//! `dima inspect sensor|command|display [FILE]`: decodes a raw byte capture of one link (a
//! logic analyser export, `cat /dev/ttyTHS1 > file`) into JSON lines with the project's own
//! resynchronising decoders; counts of errors and skipped bytes go to stderr.

use std::io::Write;

use dima_groundlink::{CommandDecoder, DisplayDecoder, DisplayFrame};
use dima_log::schema::{CommandMessage, SensorInfoMessage};
use dima_sensorboard::{Frame, SensorPacket, StreamDecoder};
use serde_json::{json, Value};

/// Which link the capture is from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Link {
    /// Sensor board -> host: 132-byte packets and info frames.
    Sensor,
    /// Ground station -> robot: 10-byte command frames.
    Command,
    /// Robot -> ground station: 68-byte display frames.
    Display,
}

/// A sensor packet with the keys of `dima-sensorboard`'s `decode` example.
pub fn packet_json(packet: &SensorPacket) -> Value {
    let gnss = packet.nav_pvt().map_or(Value::Null, |pvt| {
        json!({
            "itow_ms": pvt.itow_ms,
            "fix_type": pvt.fix_type,
            "num_sv": pvt.num_sv,
            "lat_deg": pvt.lat_deg(),
            "lon_deg": pvt.lon_deg(),
            "height_mm": pvt.height_mm,
            "hmsl_mm": pvt.h_msl_mm,
            "vel_n_mm_s": pvt.vel_n_mm_s,
            "vel_e_mm_s": pvt.vel_e_mm_s,
            "vel_d_mm_s": pvt.vel_d_mm_s,
            "gspeed_mm_s": pvt.g_speed_mm_s,
            "head_mot_deg": pvt.head_mot_deg(),
        })
    });
    json!({
        "acc": packet.accel,
        "gyro": packet.gyro,
        "mag": packet.mag,
        "rhall": packet.rhall,
        "press_raw": packet.press_raw,
        "temp_raw": packet.temp_raw,
        "gnss": gnss,
    })
}

fn display_json(f: &DisplayFrame) -> Value {
    json!({
        "acc": f.acc, "gyro": f.gyro, "mag": f.mag, "mag_hall": f.mag_hall,
        "baro_press": f.baro_press, "baro_temp": f.baro_temp,
        "lat_deg": f64::from(f.lat_e7) * 1e-7, "lon_deg": f64::from(f.lon_e7) * 1e-7,
        "vel_n_mm_s": f.vel_n_mm_s, "vel_e_mm_s": f.vel_e_mm_s, "vel_d_mm_s": f.vel_d_mm_s,
        "height_mm": f.height_mm, "hmsl_mm": f.h_msl_mm, "gspeed_mm_s": f.g_speed_mm_s,
        "head_mot_deg": f64::from(f.head_mot_deg_e5) * 1e-5,
    })
}

/// Counts for stderr.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InspectStats {
    /// Frames decoded.
    pub frames: u64,
    /// Frames rejected (CRC, range, type).
    pub errors: u64,
    /// Bytes skipped while resynchronising.
    pub skipped_bytes: u64,
}

/// Decodes `bytes` from `link`, one JSON line per frame into `out`.
pub fn inspect(link: Link, bytes: &[u8], out: &mut impl Write) -> std::io::Result<InspectStats> {
    let mut stats = InspectStats::default();
    match link {
        Link::Sensor => {
            let mut d = StreamDecoder::new();
            for frame in d.frames(bytes) {
                let line = match frame {
                    Frame::Packet(raw) => packet_json(&raw.decode()),
                    Frame::Info(info) => {
                        json!({ "info": SensorInfoMessage::from(&info) })
                    }
                };
                writeln!(out, "{line}")?;
            }
            let s = d.stats();
            stats.frames = s.packets + s.info_frames;
            stats.errors = s.crc_errors;
            stats.skipped_bytes = s.bytes_skipped;
        }
        Link::Command => {
            let mut d = CommandDecoder::new();
            for command in d.feed(bytes).flatten() {
                let m = CommandMessage::from(command);
                writeln!(
                    out,
                    "{}",
                    json!({ "command": format!("{command:?}"), "type": m.kind, "data": m.data })
                )?;
            }
            let s = d.stats();
            stats.frames = u64::from(s.frames);
            stats.errors = u64::from(s.rejected());
            stats.skipped_bytes = u64::from(s.skipped_bytes);
        }
        Link::Display => {
            let mut d = DisplayDecoder::new();
            for frame in d.feed(bytes).flatten() {
                writeln!(out, "{}", display_json(&frame))?;
            }
            let s = d.stats();
            stats.frames = u64::from(s.frames);
            stats.errors = u64::from(s.out_of_range);
            stats.skipped_bytes = u64::from(s.skipped_bytes);
        }
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_groundlink::{Command, Percent};

    /// A deterministic byte generator for noise.
    fn noise(n: usize, seed: u64) -> Vec<u8> {
        let mut x = seed;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x as u8
            })
            .collect()
    }

    fn count_lines(link: Link, bytes: &[u8]) -> (usize, InspectStats) {
        let mut out = Vec::new();
        let stats = inspect(link, bytes, &mut out).unwrap();
        (String::from_utf8(out).unwrap().lines().count(), stats)
    }

    #[test]
    fn every_frame_is_found_in_a_noisy_capture_of_each_link() {
        let (mut sensor, mut command, mut display) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..50u8 {
            sensor.extend(noise(usize::from(i % 7) * 9, u64::from(i) + 1));
            let p = SensorPacket {
                accel: [i16::from(i), -3, 1_000],
                ..SensorPacket::default()
            };
            sensor.extend(p.encode());
            command.extend(noise(usize::from(i % 5) * 3, u64::from(i) + 100));
            command.extend(Command::Throttle(Percent::new(i.min(100)).unwrap()).encode());
            display.extend(noise(usize::from(i % 3) * 11, u64::from(i) + 200));
            display.extend(
                DisplayFrame {
                    g_speed_mm_s: i32::from(i),
                    ..DisplayFrame::default()
                }
                .encode(),
            );
        }
        let (lines, stats) = count_lines(Link::Sensor, &sensor);
        assert_eq!((lines, stats.frames), (50, 50), "{stats:?}");
        assert!(stats.skipped_bytes > 0);
        let (lines, stats) = count_lines(Link::Command, &command);
        assert_eq!((lines, stats.frames), (50, 50), "{stats:?}");
        let (lines, stats) = count_lines(Link::Display, &display);
        assert_eq!(lines, 50, "{stats:?}");
    }
}
