//! The telemetry thread (below the loop's priority): command frames in from the XBee, display
//! frames out.
//!
//! Commands go to the loop as events through a ring, never as a latest value, so a kill or a
//! revive cannot be overwritten; if the ring is ever full they wait here, in order, in a
//! bounded queue ([`CommandHandOff`]). A kill goes first: it is pushed before anything else is
//! done with it, and it supersedes every command still waiting. The comms-loss decision is not
//! taken here but in the loop, so a dead telemetry thread still trips the failsafe.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use dima_groundlink::{Command, CommandDecoder, CommandStats, DisplayFrame};
use dima_sensorboard::SensorPacket;
use embedded_hal_nb::serial::{Read, Write};
use xbee_driver::{Transparent, XBee};

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

/// Commands waiting for room in the ring to the loop, at most this many.
pub const PENDING_COMMANDS: usize = 64;

/// Hands commands to the loop in arrival order through the ring, with a bounded queue for when
/// the ring is full.
pub struct CommandHandOff {
    ring: rtrb::Producer<Command>,
    pending: VecDeque<Command>,
    dropped: u64,
}

impl CommandHandOff {
    /// Around the ring to the loop.
    pub fn new(ring: rtrb::Producer<Command>) -> CommandHandOff {
        CommandHandOff {
            ring,
            pending: VecDeque::with_capacity(PENDING_COMMANDS),
            dropped: 0,
        }
    }

    /// Hands `command` over: a kill at once, ahead of (and instead of) anything still
    /// waiting; anything else after what is waiting. A full queue drops the new command and
    /// counts it.
    pub fn push(&mut self, command: Command) {
        if command == Command::Kill {
            if self.ring.push(command).is_err() {
                self.dropped += self.pending.len() as u64;
                self.pending.clear();
                self.pending.push_back(command);
            } else {
                // Whatever was waiting came before the kill and is void after it.
                self.dropped += self.pending.len() as u64;
                self.pending.clear();
            }
            return;
        }
        self.flush();
        if self.pending.is_empty() && self.ring.push(command).is_ok() {
            return;
        }
        if self.pending.len() < PENDING_COMMANDS {
            self.pending.push_back(command);
        } else {
            self.dropped += 1;
        }
    }

    /// Moves waiting commands into the ring while it has room.
    pub fn flush(&mut self) {
        while let Some(&c) = self.pending.front() {
            if self.ring.push(c).is_err() {
                break;
            }
            self.pending.pop_front();
        }
    }

    /// Commands dropped: a full queue, or superseded by a kill.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}

/// Why a radio operation failed: the port is then reopened.
#[derive(Debug)]
struct RadioFailed;

/// Reads what the radio has (bounded) into the decoder.
fn receive(
    radio: &mut XBee<SerialPort, Transparent>,
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
    radio: &mut XBee<SerialPort, Transparent>,
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
    /// Commands dropped before the loop saw them (queue full, or superseded by a kill).
    pub commands_dropped: u64,
}

impl TelemetryStats {
    /// One line for the exit summary.
    pub fn summary(&self) -> String {
        let c = &self.commands;
        format!(
            "ground link: frames {} crc-errors {} unknown-type {} out-of-range {} skipped-bytes {} \
             | commands dropped {} | display frames {} | port errors {}",
            c.frames,
            c.crc_errors,
            c.unknown_type,
            c.out_of_range,
            c.skipped_bytes,
            self.commands_dropped,
            self.display_frames,
            self.port_errors
        )
    }
}

/// Spawns the telemetry thread.
pub fn spawn_telemetry(
    mut open: Opener<SerialPort>,
    commands: rtrb::Producer<Command>,
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
            let mut radio: Option<XBee<SerialPort, Transparent>> = None;
            let mut decoder = CommandDecoder::new();
            let mut hand_off = CommandHandOff::new(commands);
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
                            radio = Some(XBee::new(port));
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
                hand_off.flush();
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
                        // Hand over first (a kill goes straight to the loop), then report.
                        hand_off.push(c);
                        if matches!(c, Command::Kill | Command::Revive) {
                            tracing::info!("ground link: {c:?}");
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
            stats.commands_dropped = hand_off.dropped();
            stats
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_groundlink::Percent;

    fn drain(ring: &mut rtrb::Consumer<Command>) -> Vec<Command> {
        std::iter::from_fn(|| ring.pop().ok()).collect()
    }

    #[test]
    fn commands_keep_their_order_through_a_full_ring() {
        let (tx, mut rx) = rtrb::RingBuffer::new(2);
        let mut h = CommandHandOff::new(tx);
        let t = |p| Command::Throttle(Percent::new(p).unwrap());
        for p in 0..5 {
            h.push(t(p));
        }
        assert_eq!(drain(&mut rx), [t(0), t(1)]);
        h.flush();
        assert_eq!(drain(&mut rx), [t(2), t(3)]);
        h.push(t(5));
        assert_eq!(drain(&mut rx), [t(4), t(5)]);
        assert_eq!(h.dropped(), 0);
    }

    #[test]
    fn a_kill_goes_first_and_voids_what_waits() {
        let (tx, mut rx) = rtrb::RingBuffer::new(2);
        let mut h = CommandHandOff::new(tx);
        // A revive waiting behind a full ring must not come after the kill.
        h.push(Command::Heartbeat);
        h.push(Command::Heartbeat);
        h.push(Command::Revive);
        h.push(Command::Kill);
        assert_eq!(drain(&mut rx), [Command::Heartbeat, Command::Heartbeat]);
        h.flush();
        assert_eq!(drain(&mut rx), [Command::Kill]);
        assert_eq!(h.dropped(), 1);
        // With room in the ring the kill is pushed at once, before anything else.
        h.push(Command::Kill);
        assert_eq!(drain(&mut rx), [Command::Kill]);
    }

    #[test]
    fn the_queue_is_bounded_and_counts_drops() {
        let (tx, _rx) = rtrb::RingBuffer::new(1);
        let mut h = CommandHandOff::new(tx);
        for _ in 0..(1 + PENDING_COMMANDS + 10) {
            h.push(Command::Heartbeat);
        }
        assert_eq!(h.dropped(), 10);
        assert_eq!(h.pending.len(), PENDING_COMMANDS);
    }
}
