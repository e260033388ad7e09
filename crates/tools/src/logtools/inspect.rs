//! `dima inspect sensor|command|display [FILE] [--key-file KEY]`: decodes a raw byte capture of
//! one link (a logic analyser export, `cat /dev/ttyTHS1 > file`) into JSON lines with the
//! project's own resynchronising decoders; counts of errors and skipped bytes go to stderr.
//!
//! The ground link's frames are version 1 (10-byte commands, 68-byte display frames) without
//! a key, and the authenticated link (the default: 28-byte commands; 126-byte display frames
//! v2 and the 156-byte display frames v3 the robot sends) with `--key-file`: each tag is verified, and a frame whose tag does not
//! match (forged, corrupt, another key) is a line `{"error": "bad tag"}`.

use std::io::Write;

use dima_groundlink::{v2, CommandDecoder, DisplayDecoder, DisplayFrame};
use dima_log::schema::{CommandMessage, SensorInfoMessage};
use dima_sensorboard::{Frame, SensorPacket, StreamDecoder};
use serde_json::{json, Value};

/// Which link the capture is from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Link {
    /// Sensor board -> host: 132-byte packets and info frames.
    Sensor,
    /// Ground station -> robot: command frames (v1: 10 bytes; v2 with --key-file: 28 bytes).
    Command,
    /// Robot -> ground station: display frames (v1: 68 bytes; with --key-file v2: 126 bytes and v3: 156 bytes).
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

/// Counts of a version 2 capture, for stderr.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct AuthenticatedStats {
    /// Authentic, valid frames decoded.
    pub frames: u64,
    /// Candidate frames whose tag did not match the key (forged, corrupt, another key).
    pub bad_tag: u64,
    /// Authentic frames with invalid content, and start tokens with a wrong length byte.
    pub malformed: u64,
    /// Bytes skipped while resynchronising.
    pub skipped_bytes: u64,
}

fn error_json(error: &v2::FrameError) -> Value {
    match error {
        v2::FrameError::BadTag => json!({ "error": "bad tag" }),
        other => json!({ "error": other.to_string() }),
    }
}

fn v2_display_json(f: &v2::DisplayFrame) -> Value {
    json!({
        "version": 2,
        "mode": format!("{:?}", f.mode),
        "failsafe_cause": f.failsafe_cause.map(|c| format!("{c:?}")),
        "revive_refusal": f.revive_refusal.map(|r| format!("{r:?}")),
        "session": f.session,
        "seq": f.seq,
        "ack_seq": f.ack_seq,
        "health": {
            "missed_periods": f.health.missed_periods,
            "sensor_bad": f.health.sensor_bad,
            "sensor_missing": f.health.sensor_missing,
            "commands": f.health.commands,
            "bad_tag": f.health.bad_tag,
            "replayed": f.health.replayed,
            "stale_session": f.health.stale_session,
            "malformed": f.health.malformed,
            "v1_ignored": f.health.v1_ignored,
        },
        "sensors": display_json(&f.sensors),
    })
}

/// A display frame v3: the version 2 fields and what the robot does (outputs in µs, the
/// setpoints and estimates in SI units, `null` where the robot has none).
fn v3_display_json(f: &v2::DisplayFrameV3) -> Value {
    let a = &f.actuation;
    let scaled = |v: Option<i32>, per_unit: f64| v.map(|v| f64::from(v) / per_unit);
    let mut json = v2_display_json(&f.status);
    json["version"] = json!(3);
    json["actuation"] = json!({
        "servo_us": a.servo_us(),
        "speed_setpoint_m_s": scaled(a.speed_setpoint_mm_s, 1e3),
        "heading_setpoint_deg": scaled(a.heading_setpoint_deg_e5, 1e5),
        "speed_estimate_m_s": scaled(a.speed_estimate_mm_s, 1e3),
        "heading_estimate_deg": scaled(a.heading_estimate_deg_e5, 1e5),
        "speed_error_m_s": scaled(a.speed_error_mm_s, 1e3),
        "controllers": a.controllers.map(|c| c.name().unwrap_or("unknown")),
    });
    json
}

/// Decodes the version 2 (authenticated) frames of `link` in `bytes` under `key`, one JSON
/// line per frame into `out`, and one `{"error": ...}` line per rejected candidate (`"bad
/// tag"`: the tag does not match). The sensor link has no version 2: `InvalidInput`.
pub fn inspect_authenticated(
    link: Link,
    bytes: &[u8],
    key: &v2::LinkKey,
    out: &mut impl Write,
) -> std::io::Result<AuthenticatedStats> {
    let stats = match link {
        Link::Sensor => {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "the sensor link has no key: --key-file is for the command and display links",
            ))
        }
        Link::Command => {
            let mut d = v2::CommandDecoder::new(key.clone());
            for result in d.feed(bytes) {
                let line = match result {
                    Ok(f) => {
                        let m = CommandMessage::from(f.command);
                        json!({
                            "version": 2,
                            "command": format!("{:?}", f.command),
                            "type": m.kind,
                            "data": m.data,
                            "session": f.session,
                            "seq": f.seq,
                            "request": f.request,
                        })
                    }
                    Err(e) => error_json(&e),
                };
                writeln!(out, "{line}")?;
            }
            d.stats()
        }
        Link::Display => {
            let mut d = v2::DownlinkDecoder::new(key.clone());
            for result in d.feed(bytes) {
                let line = match result {
                    Ok(v2::Downlink::V2(f)) => v2_display_json(&f),
                    Ok(v2::Downlink::V3(f)) => v3_display_json(&f),
                    Err(e) => error_json(&e),
                };
                writeln!(out, "{line}")?;
            }
            d.stats()
        }
    };
    Ok(AuthenticatedStats {
        frames: u64::from(stats.frames),
        bad_tag: u64::from(stats.bad_tag),
        malformed: u64::from(stats.malformed),
        skipped_bytes: u64::from(stats.skipped_bytes),
    })
}

/// Version 2 start tokens (with their length byte) of `link` in `bytes`: a hint that a capture
/// decoded without a key holds authenticated frames.
pub fn v2_candidates(link: Link, bytes: &[u8]) -> usize {
    let (start, len) = match link {
        Link::Sensor => return 0,
        Link::Command => (v2::COMMAND_START, v2::COMMAND_FRAME_LEN),
        Link::Display => {
            return candidates(bytes, v2::DISPLAY_START, v2::DISPLAY_FRAME_LEN)
                + candidates(bytes, v2::DISPLAY_V3_START, v2::DISPLAY_V3_FRAME_LEN)
        }
    };
    candidates(bytes, start, len)
}

/// Occurrences of `start` followed by the length byte `len` in `bytes`.
fn candidates(bytes: &[u8], start: [u8; 2], len: usize) -> usize {
    bytes
        .windows(3)
        .filter(|w| w[..2] == start && usize::from(w[2]) == len)
        .count()
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

    #[test]
    fn authenticated_frames_are_decoded_and_verified_with_the_key() {
        let key = v2::LinkKey::parse_hex("000102030405060708090a0b0c0d0e0f").unwrap();
        let throttle = Command::Throttle(Percent::new(60).unwrap());
        let mut command = noise(5, 1);
        command.extend(v2::CommandFrame::new(Command::Revive, 0x1234, 1).encode(&key));
        command.extend(v2::CommandFrame::repeat(throttle, 0x1234, 2, 2).encode(&key));
        let mut tampered = v2::CommandFrame::repeat(throttle, 0x1234, 3, 3).encode(&key);
        tampered[7] = 100; // throttle 100 %, tag unchanged
        command.extend(tampered);
        command.extend(v2::CommandFrame::new(Command::Kill, 0x1234, 4).encode(&key));

        // Without a key: nothing (the v1 decoder finds no frame), and a hint.
        let (_, v1) = count_lines(Link::Command, &command);
        assert_eq!(v1.frames, 0);
        assert_eq!(v2_candidates(Link::Command, &command), 4);

        let mut out = Vec::new();
        let stats = inspect_authenticated(Link::Command, &command, &key, &mut out).unwrap();
        assert_eq!((stats.frames, stats.bad_tag), (3, 1), "{stats:?}");
        let lines: Vec<Value> = String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(lines.len(), 4);
        assert_eq!(lines[0]["command"], "Revive");
        assert_eq!(lines[1]["data"], 60);
        assert_eq!(lines[1]["seq"], 2);
        assert_eq!(lines[1]["session"], 0x1234);
        assert_eq!(lines[2], json!({ "error": "bad tag" }));
        assert_eq!(lines[3]["command"], "Kill");

        // Under another key every frame is a bad tag.
        let other = v2::LinkKey::from_bytes([7; 16]);
        let stats = inspect_authenticated(Link::Command, &command, &other, &mut Vec::new());
        assert_eq!(stats.unwrap().frames, 0);

        // Display frames: decoded with their mode, sequence and sensor values.
        let frame = v2::DisplayFrame {
            mode: v2::RobotMode::Auto,
            session: 0x1234,
            seq: 9,
            ack_seq: 4,
            sensors: DisplayFrame {
                g_speed_mm_s: 2_500,
                ..DisplayFrame::default()
            },
            ..v2::DisplayFrame::default()
        };
        let mut display = frame.encode(&key).to_vec();
        let mut bad = frame.encode(&key);
        bad[20] ^= 1;
        display.extend(bad);
        let mut out = Vec::new();
        let stats = inspect_authenticated(Link::Display, &display, &key, &mut out).unwrap();
        assert_eq!((stats.frames, stats.bad_tag), (1, 1), "{stats:?}");
        let text = String::from_utf8(out).unwrap();
        let first: Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
        assert_eq!(first["mode"], "Auto");
        assert_eq!(first["seq"], 9);
        assert_eq!(first["sensors"]["gspeed_mm_s"], 2_500);
        assert!(text.lines().nth(1).unwrap().contains("bad tag"), "{text}");
        assert!(inspect_authenticated(Link::Sensor, &display, &key, &mut Vec::new()).is_err());

        // Display frames v3 (what the robot sends): also its outputs and setpoints, `null`
        // where it has none.
        let v3 = v2::DisplayFrameV3 {
            status: frame,
            actuation: v2::Actuation {
                servo_quarter_us: [6_000, 6_240, 6_000],
                speed_setpoint_mm_s: Some(1_500),
                ..v2::Actuation::default()
            },
        };
        let capture = v3.encode(&key);
        assert_eq!(v2_candidates(Link::Display, &capture), 1);
        let mut out = Vec::new();
        let stats = inspect_authenticated(Link::Display, &capture, &key, &mut out).unwrap();
        assert_eq!((stats.frames, stats.bad_tag), (1, 0), "{stats:?}");
        let line: Value =
            serde_json::from_slice(out.split(|&b| b == b'\n').next().unwrap()).unwrap();
        assert_eq!(line["version"], 3);
        assert_eq!(line["seq"], 9);
        assert_eq!(line["actuation"]["servo_us"], json!([1500, 1560, 1500]));
        assert_eq!(line["actuation"]["speed_setpoint_m_s"], 1.5);
        assert_eq!(line["actuation"]["heading_setpoint_deg"], Value::Null);
    }
}
