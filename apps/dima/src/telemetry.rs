//! The telemetry thread (below the loop's priority): command frames in from the XBee, display
//! frames out.
//!
//! Commands go to the loop as events through a ring, never as a latest value, so a kill or a
//! revive cannot be overwritten; if the ring is ever full they wait here, in order. The
//! comms-loss decision is not taken here but in the loop, so a dead telemetry thread still
//! trips the failsafe.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use dima_groundlink::{Command, CommandDecoder, CommandStats, DisplayFrame};
use dima_sensorboard::SensorPacket;

use crate::app::record::Snapshot;
use crate::devices::serial::SerialPort;
use crate::devices::Opener;
use crate::rt::monotonic_ns;

/// The display frame for the last packet: decoded signed values, raw BMP280 ADC values,
/// latitude then longitude (the original swapped them), velocities and heading from NAV-PVT.
pub fn display_frame(packet: Option<&SensorPacket>) -> DisplayFrame {
    let Some(p) = packet else {
        return DisplayFrame::default();
    };
    let mut frame = DisplayFrame {
        acc: p.accel,
        gyro: p.gyro,
        mag: p.mag,
        mag_hall: p.rhall,
        baro_press: p.press_raw,
        baro_temp: p.temp_raw,
        ..DisplayFrame::default()
    };
    if let Some(pvt) = p.nav_pvt() {
        frame.lat_e7 = pvt.lat_deg_e7;
        frame.lon_e7 = pvt.lon_deg_e7;
        frame.vel_n_mm_s = pvt.vel_n_mm_s;
        frame.vel_e_mm_s = pvt.vel_e_mm_s;
        frame.vel_d_mm_s = pvt.vel_d_mm_s;
        frame.height_mm = pvt.height_mm;
        frame.h_msl_mm = pvt.hmsl_mm;
        frame.g_speed_mm_s = pvt.g_speed_mm_s;
        frame.head_mot_deg_e5 = pvt.head_mot_deg_e5;
    }
    frame
}

/// Telemetry settings.
pub struct TelemetrySettings {
    /// Time between display frames.
    pub display_period: Duration,
    /// Pause between reopen attempts.
    pub reopen_interval: Duration,
    /// SCHED_FIFO priority (0: SCHED_OTHER).
    pub priority: u8,
}

/// What the telemetry thread counted.
#[derive(Debug, Clone, Copy, Default)]
pub struct TelemetryStats {
    /// Command decoder counters.
    pub commands: CommandStats,
    /// Display frames sent.
    pub display_frames: u64,
    /// Port errors (each followed by a reopen).
    pub port_errors: u64,
}

/// Spawns the telemetry thread.
pub fn spawn_telemetry(
    mut open: Opener<SerialPort>,
    mut commands: rtrb::Producer<Command>,
    mut snapshot: triple_buffer::Output<Snapshot>,
    settings: TelemetrySettings,
    stop: Arc<AtomicBool>,
) -> std::io::Result<std::thread::JoinHandle<TelemetryStats>> {
    std::thread::Builder::new()
        .name("dima-telemetry".into())
        .spawn(move || {
            if let Err(e) = crate::rt::setup::set_fifo(settings.priority) {
                tracing::warn!(
                    "telemetry: SCHED_FIFO {} refused ({e}); running SCHED_OTHER",
                    settings.priority
                );
            }
            let mut stats = TelemetryStats::default();
            let mut port: Option<SerialPort> = None;
            let mut decoder = CommandDecoder::new();
            let mut pending: VecDeque<Command> = VecDeque::new();
            let mut last_open: Option<Instant> = None;
            let mut failures = 0u64;
            let mut next_display = Instant::now() + settings.display_period;
            let mut buf = [0u8; 256];
            while !stop.load(Ordering::Relaxed) {
                let now = Instant::now();
                if port.is_none() && last_open.map_or(true, |t| now - t >= settings.reopen_interval)
                {
                    last_open = Some(now);
                    match open() {
                        Ok(p) => {
                            tracing::info!("XBee: connected");
                            failures = 0;
                            decoder.reset();
                            port = Some(p);
                        }
                        Err(e) => {
                            failures += 1;
                            if failures == 1 || failures % 60 == 0 {
                                tracing::warn!("{e:#} (attempt {failures}; retrying)");
                            }
                        }
                    }
                }
                // Commands still waiting for room in the ring go first, in order.
                while let Some(&c) = pending.front() {
                    if commands.push(c).is_err() {
                        break;
                    }
                    pending.pop_front();
                }
                let Some(p) = port.as_mut() else {
                    std::thread::sleep(Duration::from_millis(20));
                    continue;
                };
                let wait_until = monotonic_ns()
                    + (next_display.saturating_duration_since(now))
                        .min(Duration::from_millis(20))
                        .as_nanos() as u64;
                let mut failed = false;
                match p.wait_input(wait_until) {
                    Ok(true) => match p.read_available(&mut buf) {
                        Ok(n) => {
                            for result in decoder.feed(&buf[..n]) {
                                match result {
                                    Ok(c) => {
                                        if matches!(c, Command::Kill | Command::Revive) {
                                            tracing::info!("ground link: {c:?}");
                                        }
                                        if !pending.is_empty() || commands.push(c).is_err() {
                                            pending.push_back(c);
                                        }
                                    }
                                    Err(e) => tracing::debug!("ground link: rejected: {e}"),
                                }
                            }
                        }
                        Err(_) => failed = true,
                    },
                    Ok(false) => {}
                    Err(_) => failed = true,
                }
                if !failed && Instant::now() >= next_display {
                    next_display += settings.display_period;
                    if next_display < Instant::now() {
                        next_display = Instant::now() + settings.display_period;
                    }
                    let snap = *snapshot.read();
                    let frame = display_frame(snap.packet.as_ref()).encode();
                    match p.write_all(&frame, monotonic_ns() + 200_000_000) {
                        Ok(()) => stats.display_frames += 1,
                        Err(crate::devices::serial::SerialError::Timeout) => {
                            tracing::debug!("XBee: display frame not sent in time")
                        }
                        Err(_) => failed = true,
                    }
                }
                if failed {
                    stats.port_errors += 1;
                    tracing::warn!("XBee: port failed; reopening");
                    port = None;
                    decoder.reset();
                }
            }
            stats.commands = decoder.stats();
            stats
        })
}
