//! Decodes a raw byte capture of the sensor-board link (a logic-analyser or serial dump).
//!
//! Reads the capture from stdin (any chunking, any garbage between packets), prints one JSON
//! object per valid packet on stdout, and one line with the decoder's counters on stderr.
//!
//! ```text
//! cargo run --example decode < capture.bin
//! ```

use std::io::{self, BufWriter, Read, Write};

use dima_sensorboard::{Frame, SensorPacket, StreamDecoder};
use serde_json::{json, Value};

/// The JSON object for one packet: raw counts, and the GNSS fields or `null`.
fn packet_json(packet: &SensorPacket) -> Value {
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

fn main() -> io::Result<()> {
    let mut stdin = io::stdin().lock();
    let mut out = BufWriter::new(io::stdout().lock());
    let mut decoder = StreamDecoder::new();
    let mut chunk = [0u8; 4096];
    loop {
        let n = match stdin.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        for frame in decoder.frames(&chunk[..n]) {
            if let Frame::Packet(raw) = frame {
                writeln!(out, "{}", packet_json(&raw.decode()))?;
            }
        }
    }
    out.flush()?;
    let stats = decoder.stats();
    eprintln!(
        "packets {} info_frames {} crc_errors {} bytes_skipped {} bytes_pending {}",
        stats.packets,
        stats.info_frames,
        stats.crc_errors,
        stats.bytes_skipped,
        decoder.buffered_len()
    );
    Ok(())
}
