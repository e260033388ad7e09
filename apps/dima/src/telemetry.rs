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
use embedded_hal_nb::serial::{Read, Write};
use xbee_driver::Transparent;

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
        frame.h_msl_mm = pvt.h_msl_mm;
        frame.g_speed_mm_s = pvt.g_speed_mm_s;
        frame.head_mot_deg_e5 = pvt.head_mot_deg_e5;
    }
    frame
}

/// Why a radio operation failed: the port is then reopened.
#[derive(Debug)]
struct RadioFailed;

/// Reads what the radio has (bounded) into the decoder.
fn receive(
    radio: &mut Transparent<SerialPort>,
    decoder: &mut CommandDecoder,
    mut deliver: impl FnMut(Command),
) -> Result<(), RadioFailed> {
    for _ in 0..1024 {
        match radio.read() {
            Ok(byte) => match decoder.push(byte) {
                Some(Ok(command)) => deliver(command),
                Some(Err(e)) => tracing::debug!("ground link: rejected: {e}"),
                None => {}
            },
            Err(nb::Error::WouldBlock) => return Ok(()),
            Err(nb::Error::Other(_)) => return Err(RadioFailed),
        }
    }
    Ok(())
}

/// Sends `bytes` through the radio, waiting for room until `deadline_ns`; `Ok(false)` when the
/// deadline passed first (the rest of the frame is not sent; the receiver resynchronises).
fn send(
    radio: &mut Transparent<SerialPort>,
    bytes: &[u8],
    deadline_ns: u64,
) -> Result<bool, RadioFailed> {
    for &b in bytes {
        loop {
            match radio.write(b) {
                Ok(()) => break,
                Err(nb::Error::WouldBlock) => match radio.serial_mut().wait_output(deadline_ns) {
                    Ok(true) => {}
                    Ok(false) => return Ok(false),
                    Err(_) => return Err(RadioFailed),
                },
                Err(nb::Error::Other(_)) => return Err(RadioFailed),
            }
        }
    }
    Ok(true)
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

impl TelemetryStats {
    /// One line for the exit summary.
    pub fn summary(&self) -> String {
        let c = &self.commands;
        format!(
            "ground link: frames {} crc-errors {} unknown-type {} out-of-range {} skipped-bytes {} \
             | display frames {} | port errors {}",
            c.frames,
            c.crc_errors,
            c.unknown_type,
            c.out_of_range,
            c.skipped_bytes,
            self.display_frames,
            self.port_errors
        )
    }
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
            let mut radio: Option<Transparent<SerialPort>> = None;
            let mut decoder = CommandDecoder::new();
            let mut pending: VecDeque<Command> = VecDeque::new();
            let mut last_open: Option<Instant> = None;
            let mut failures = 0u64;
            let mut next_display = Instant::now() + settings.display_period;
            while !stop.load(Ordering::Relaxed) {
                let now = Instant::now();
                if radio.is_none() && last_open.is_none_or(|t| now - t >= settings.reopen_interval)
                {
                    last_open = Some(now);
                    match open() {
                        Ok(port) => {
                            tracing::info!("XBee: connected");
                            failures = 0;
                            decoder.reset();
                            radio = Some(Transparent::new(port));
                        }
                        Err(e) => {
                            failures += 1;
                            if failures == 1 || failures.is_multiple_of(60) {
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
                let Some(r) = radio.as_mut() else {
                    std::thread::sleep(Duration::from_millis(20));
                    continue;
                };
                let wait = next_display
                    .saturating_duration_since(now)
                    .min(Duration::from_millis(20));
                let mut result = match r
                    .serial_mut()
                    .wait_input(monotonic_ns() + wait.as_nanos() as u64)
                {
                    Ok(_) => receive(r, &mut decoder, |c| {
                        if matches!(c, Command::Kill | Command::Revive) {
                            tracing::info!("ground link: {c:?}");
                        }
                        if !pending.is_empty() || commands.push(c).is_err() {
                            pending.push_back(c);
                        }
                    }),
                    Err(_) => Err(RadioFailed),
                };
                if result.is_ok() && Instant::now() >= next_display {
                    next_display += settings.display_period;
                    if next_display < Instant::now() {
                        next_display = Instant::now() + settings.display_period;
                    }
                    let snap = *snapshot.read();
                    let frame = display_frame(snap.packet.as_ref()).encode();
                    result = match send(r, &frame, monotonic_ns() + 200_000_000) {
                        Ok(true) => {
                            stats.display_frames += 1;
                            Ok(())
                        }
                        Ok(false) => {
                            tracing::debug!("XBee: display frame not sent in time");
                            Ok(())
                        }
                        Err(e) => Err(e),
                    };
                }
                if result.is_err() {
                    stats.port_errors += 1;
                    tracing::warn!("XBee: port failed; reopening");
                    radio = None;
                    decoder.reset();
                }
            }
            stats.commands = decoder.stats();
            stats
        })
}
