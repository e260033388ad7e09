//! The realtime loop: one cycle per period, everything preallocated, no locks, no allocation,
//! no printing, every wait bounded by a deadline.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use dima_groundlink::Command;
use dima_sensorboard::{units, DecoderStats, FixType, Frame, InfoFrame, RawPacket, SensorPacket};
use embedded_hal::digital::OutputPin;

use super::record::{events, CycleRecord, Snapshot};
use crate::config::Config;
use crate::control::{
    Actuation, AutoController, AutoState, Controller, CycleHealth, Mode, Nanos, OutputMap,
    SafetyLimits, SafetyState, SensorValues, ServoTargets,
};
use crate::devices::sensor::SensorDevice;
use crate::devices::servo::{ServoError, ServoOutput};
use crate::devices::{DeviceLink, LinkEvent};
use crate::metrics::LoopMetrics;
use crate::rt::{monotonic_ns, PeriodicClock, Tick};

/// Most command events applied per cycle (the rest wait for the next cycle).
const MAX_COMMANDS_PER_CYCLE: usize = 64;
/// Most stale frames drained before a request.
const MAX_STALE_POLLS: usize = 8;
/// Time allowed for the final safe-output write at shutdown, ns.
const SHUTDOWN_WRITE_NS: Nanos = 50_000_000;
/// Wake-up latency histogram range (cyclictest `-h`), µs.
pub const HISTOGRAM_US: usize = 10_000;

/// Settings of the loop, derived from the configuration before it starts.
#[derive(Debug, Clone)]
pub struct LoopParams {
    /// Period, ns.
    pub period_ns: Nanos,
    /// Packet deadline after the request, ns.
    pub packet_deadline_ns: Nanos,
    /// Request at the end of the cycle, read at the start of the next.
    pub request_ahead: bool,
    /// Servo targets written every n-th cycle (and whenever they change).
    pub servo_every: u64,
    /// Failsafe thresholds.
    pub limits: SafetyLimits,
    /// Channel table.
    pub outputs: OutputMap,
    /// AUTO controller.
    pub controller: AutoController,
}

impl LoopParams {
    /// From a validated configuration.
    pub fn from_config(config: &Config) -> LoopParams {
        let rate = config.realtime.loop_rate_hz.max(1);
        LoopParams {
            period_ns: config.period_ns(),
            packet_deadline_ns: u64::from(config.sensor.packet_deadline_us) * 1_000,
            request_ahead: config.sensor.request_ahead,
            servo_every: u64::from((rate / config.maestro.servo_refresh_hz.max(1)).max(1)),
            limits: SafetyLimits::from(&config.safety),
            outputs: OutputMap::new(&config.channels),
            controller: AutoController::new(&config.control),
        }
    }
}

/// The loop's connections to the other threads.
pub struct LoopEnds {
    /// Command events from telemetry.
    pub commands: rtrb::Consumer<Command>,
    /// Records to the logger.
    pub log: rtrb::Producer<CycleRecord>,
    /// Latest state to telemetry.
    pub snapshot: triple_buffer::Input<Snapshot>,
    /// Set by the signal handler (or a test) to stop.
    pub stop: Arc<AtomicBool>,
}

enum Acquired {
    Packet(RawPacket, Nanos),
    Missing,
    DeviceError,
}

/// The realtime loop and all its state.
pub struct RealtimeLoop<P, S> {
    params: LoopParams,
    ends: LoopEnds,
    sensor: DeviceLink<SensorDevice<P>>,
    servo: DeviceLink<S>,
    safety: SafetyState,
    auto: AutoState,
    action: Actuation,
    values: SensorValues,
    last_packet: Option<SensorPacket>,
    last_written: Option<ServoTargets>,
    pending_request_ns: Option<Nanos>,
    last_step_ns: Option<Nanos>,
    info: Option<InfoFrame>,
    decoder_base: DecoderStats,
    cycle: u64,
    metrics: LoopMetrics,
}

fn values_from(packet: &SensorPacket) -> SensorValues {
    let gyro_z_dps = units::gyro_dps_2000(packet.gyro[2]);
    match packet.nav_pvt() {
        Some(pvt) => SensorValues {
            gyro_z_dps,
            gnss_fix_ok: pvt.gnss_fix_ok()
                && matches!(
                    pvt.fix(),
                    FixType::Fix2D | FixType::Fix3D | FixType::GnssDeadReckoning
                ),
            gnss_itow_ms: pvt.itow_ms,
            g_speed_mm_s: pvt.g_speed_mm_s,
            head_mot_deg_e5: pvt.head_mot_deg_e5,
        },
        None => SensorValues {
            gyro_z_dps,
            ..SensorValues::default()
        },
    }
}

impl<P: OutputPin, S: ServoOutput> RealtimeLoop<P, S> {
    /// Everything the loop will touch is allocated here.
    pub fn new(
        params: LoopParams,
        ends: LoopEnds,
        sensor: DeviceLink<SensorDevice<P>>,
        servo: DeviceLink<S>,
    ) -> RealtimeLoop<P, S> {
        RealtimeLoop {
            params,
            ends,
            sensor,
            servo,
            safety: SafetyState::new(),
            auto: AutoState::default(),
            action: Actuation::default(),
            values: SensorValues::default(),
            last_packet: None,
            last_written: None,
            pending_request_ns: None,
            last_step_ns: None,
            info: None,
            decoder_base: DecoderStats::default(),
            cycle: 0,
            metrics: LoopMetrics::new(HISTOGRAM_US),
        }
    }

    /// Metrics so far.
    pub fn metrics(&self) -> &LoopMetrics {
        &self.metrics
    }

    /// Runs until the stop flag is set (or `max_cycles`), then writes safe outputs. Returns the
    /// number of cycles run.
    pub fn run(&mut self, clock: &mut PeriodicClock, max_cycles: Option<u64>) -> u64 {
        while !self.ends.stop.load(Ordering::Relaxed)
            && max_cycles.is_none_or(|max| self.cycle < max)
        {
            let tick = clock.wait();
            self.cycle(tick);
        }
        self.shutdown();
        self.cycle
    }

    /// Drains stale frames (a late answer to an earlier request) before a new request.
    fn drain_stale(&mut self) -> bool {
        let Some(dev) = self.sensor.get() else {
            return true;
        };
        for _ in 0..MAX_STALE_POLLS {
            match dev.board.poll() {
                Ok(Frame::Info(info)) => self.info = Some(info),
                Ok(Frame::Packet(_)) => {}
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(_)) => return false,
            }
        }
        dev.board.discard_buffered();
        true
    }

    fn request(&mut self) -> Option<Nanos> {
        let dev = self.sensor.get()?;
        let t = monotonic_ns();
        let ok = dev.board.request().is_ok() && dev.board.end_request().is_ok();
        if ok {
            Some(t)
        } else {
            None
        }
    }

    fn wait_packet(&mut self, deadline_ns: Nanos) -> Acquired {
        let Some(dev) = self.sensor.get() else {
            return Acquired::Missing;
        };
        loop {
            match dev.board.poll() {
                Ok(Frame::Packet(raw)) => return Acquired::Packet(raw, monotonic_ns()),
                Ok(Frame::Info(info)) => self.info = Some(info),
                Err(nb::Error::WouldBlock) => match dev.wait_readable(deadline_ns) {
                    Ok(true) => {}
                    Ok(false) => return Acquired::Missing,
                    Err(_) => return Acquired::DeviceError,
                },
                Err(nb::Error::Other(_)) => return Acquired::DeviceError,
            }
        }
    }

    fn sensor_failed(&mut self, events: &mut u16) {
        self.metrics.counters.sensor_errors += 1;
        let c = &self.metrics.counters;
        self.decoder_base = DecoderStats {
            packets: 0,
            info_frames: c.info_frames,
            crc_errors: c.packet_crc_errors,
            bytes_skipped: c.packet_bytes_skipped,
        };
        self.sensor.fail();
        self.pending_request_ns = None;
        *events |= events::SENSOR_LOST;
    }

    /// One cycle after the clock woke the thread.
    pub fn cycle(&mut self, tick: Tick) {
        let mut ev = 0u16;
        self.metrics.counters.cycles += 1;
        self.metrics.counters.missed_periods += u64::from(tick.missed);
        self.metrics.wake_latency.record(tick.latency_ns);

        if self.sensor.refresh() == LinkEvent::Connected {
            ev |= events::SENSOR_CONNECTED;
            self.metrics.counters.device_connects += 1;
            self.pending_request_ns = None;
        }
        if self.servo.refresh() == LinkEvent::Connected {
            ev |= events::SERVO_CONNECTED;
            self.metrics.counters.device_connects += 1;
            self.last_written = None;
        }

        // Commands, in arrival order.
        let mode_before = self.safety.mode;
        for _ in 0..MAX_COMMANDS_PER_CYCLE {
            let Ok(command) = self.ends.commands.pop() else {
                break;
            };
            self.safety = self
                .safety
                .on_command(&self.params.limits, command, tick.wake_ns);
            self.metrics.counters.commands += 1;
        }

        // The packet: requested now, or (request-ahead) at the end of the last cycle.
        self.info = None;
        let (t_request, acquired) = if self.params.request_ahead {
            match self.pending_request_ns.take() {
                Some(t) => (t, self.wait_packet(t + self.params.packet_deadline_ns)),
                None => (0, Acquired::Missing),
            }
        } else if !self.sensor.is_connected() {
            (0, Acquired::Missing)
        } else if !self.drain_stale() {
            (0, Acquired::DeviceError)
        } else {
            match self.request() {
                Some(t) => (t, self.wait_packet(t + self.params.packet_deadline_ns)),
                None => (0, Acquired::DeviceError),
            }
        };
        let (packet, t_packet) = match acquired {
            Acquired::Packet(raw, t) => (Some(raw), t),
            Acquired::Missing => (None, 0),
            Acquired::DeviceError => {
                self.sensor_failed(&mut ev);
                (None, 0)
            }
        };
        if let Some(s) = self.sensor.get().map(|d| d.board.stats()) {
            // The decoder's counters restart with each (re)opened device; keep totals.
            let c = &mut self.metrics.counters;
            c.packet_crc_errors = self.decoder_base.crc_errors + s.crc_errors;
            c.packet_bytes_skipped = self.decoder_base.bytes_skipped + s.bytes_skipped;
            c.info_frames = self.decoder_base.info_frames + s.info_frames;
        }
        if let Some(raw) = &packet {
            self.metrics.counters.packets_ok += 1;
            self.metrics
                .request_to_packet
                .record(t_packet.saturating_sub(t_request));
            let decoded = raw.decode();
            self.values = values_from(&decoded);
            self.last_packet = Some(decoded);
        } else {
            self.metrics.counters.packets_missing += 1;
        }

        // Safety, then control. A missing packet holds the previous action.
        let health = CycleHealth {
            packet_ok: packet.is_some(),
            overrun: tick.missed > 0,
        };
        self.safety = self
            .safety
            .on_cycle(&self.params.limits, health, tick.wake_ns);
        if self.safety.mode != mode_before {
            ev |= events::MODE_CHANGED;
            if self.safety.mode == Mode::Failsafe {
                self.metrics.counters.failsafes += 1;
            }
        }
        if self.safety.mode == Mode::Auto {
            if packet.is_some() {
                let dt_s = self
                    .last_step_ns
                    .map_or(self.params.period_ns, |t| tick.wake_ns.saturating_sub(t))
                    as f32
                    * 1e-9;
                let (state, action) = self.params.controller.step(
                    self.auto,
                    &self.safety.setpoints,
                    &self.values,
                    dt_s,
                );
                self.auto = state;
                self.action = action;
                self.last_step_ns = Some(tick.wake_ns);
            }
        } else {
            self.auto = AutoState::default();
            self.action = Actuation::default();
            self.last_step_ns = None;
        }
        let targets =
            self.params
                .outputs
                .outputs(self.safety.mode, &self.safety.setpoints, &self.action);
        let t_compute = monotonic_ns();
        let compute_from = if t_packet != 0 {
            t_packet
        } else {
            tick.wake_ns
        };
        self.metrics
            .compute
            .record(t_compute.saturating_sub(compute_from));

        // Outputs: at the servo refresh rate, and at once whenever they change.
        let due = self.cycle.is_multiple_of(self.params.servo_every)
            || self.last_written != Some(targets);
        let t_write = if due {
            self.write_targets(targets, t_compute + self.params.period_ns / 2, &mut ev)
        } else {
            0
        };

        if self.params.request_ahead && self.sensor.is_connected() {
            if self.drain_stale() {
                self.pending_request_ns = self.request();
            } else {
                self.sensor_failed(&mut ev);
            }
        }

        self.publish(CycleRecord {
            cycle: self.cycle,
            tick,
            t_request_ns: t_request,
            t_packet_ns: t_packet,
            t_compute_ns: t_compute,
            t_write_ns: t_write,
            packet,
            info: self.info,
            values: self.values,
            action: self.action,
            targets,
            safety: self.safety,
            counters: self.metrics.counters,
            events: ev,
        });
        self.cycle += 1;
    }

    fn write_targets(&mut self, targets: ServoTargets, deadline_ns: Nanos, ev: &mut u16) -> Nanos {
        let channels = self.params.outputs.channel_numbers();
        let Some(servo) = self.servo.get() else {
            self.metrics.counters.servo_missing += 1;
            return 0;
        };
        let t0 = monotonic_ns();
        match servo.write_targets(&channels, &targets.quarter_us(), deadline_ns) {
            Ok(()) => {
                let t = monotonic_ns();
                self.metrics.servo_write.record(t - t0);
                self.metrics.counters.servo_writes += 1;
                self.last_written = Some(targets);
                t
            }
            Err(ServoError::Timeout | ServoError::InvalidInput) => {
                // Still there, just slow to take bytes (or a target the configuration should
                // have refused): counted, resent next cycle.
                self.metrics.counters.servo_errors += 1;
                self.last_written = None;
                0
            }
            Err(ServoError::Device) => {
                self.metrics.counters.servo_errors += 1;
                self.servo.fail();
                self.last_written = None;
                *ev |= events::SERVO_LOST;
                0
            }
        }
    }

    fn publish(&mut self, record: CycleRecord) {
        self.ends.snapshot.write(Snapshot {
            packet: self.last_packet,
            safety: record.safety,
            targets: record.targets,
            time_ns: record.tick.wake_ns,
        });
        if self.ends.log.push(record).is_err() {
            self.metrics.counters.log_dropped += 1;
        }
    }

    /// Safe outputs, written whatever the refresh schedule, and a last record.
    fn shutdown(&mut self) {
        let mut ev = events::SHUTDOWN;
        let targets = self.params.outputs.safe();
        let now = monotonic_ns();
        let t_write = self.write_targets(targets, now + SHUTDOWN_WRITE_NS, &mut ev);
        self.safety = SafetyState {
            mode: Mode::Killed,
            ..self.safety
        };
        self.publish(CycleRecord {
            cycle: self.cycle,
            tick: Tick {
                deadline_ns: now,
                wake_ns: now,
                latency_ns: 0,
                missed: 0,
            },
            t_request_ns: 0,
            t_packet_ns: 0,
            t_compute_ns: now,
            t_write_ns: t_write,
            packet: None,
            info: None,
            values: self.values,
            action: Actuation::default(),
            targets,
            safety: self.safety,
            counters: self.metrics.counters,
            events: ev,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::values_from;
    use dima_sensorboard::gnss::nav_pvt::FLAG_GNSS_FIX_OK;
    use dima_sensorboard::{GnssFrame, NavPvt, SensorPacket};

    fn packet_with_fix(fix_type: u8, flags: u8) -> SensorPacket {
        SensorPacket {
            gnss: GnssFrame::from_nav_pvt(&NavPvt {
                itow_ms: 1_000,
                fix_type,
                flags,
                g_speed_mm_s: 2_500,
                ..NavPvt::default()
            }),
            ..SensorPacket::default()
        }
    }

    #[test]
    fn a_fix_counts_only_when_flagged_ok_and_positional() {
        // 2-D, 3-D and GNSS + dead reckoning are position fixes.
        for fix_type in [2, 3, 4] {
            let v = values_from(&packet_with_fix(fix_type, FLAG_GNSS_FIX_OK));
            assert!(v.gnss_fix_ok, "fix type {fix_type}");
            assert_eq!((v.gnss_itow_ms, v.g_speed_mm_s), (1_000, 2_500));
        }
        // No fix, dead reckoning only, time only, reserved: not a position fix.
        for fix_type in [0, 1, 5, 6] {
            let v = values_from(&packet_with_fix(fix_type, FLAG_GNSS_FIX_OK));
            assert!(!v.gnss_fix_ok, "fix type {fix_type}");
        }
        // A 3-D fix outside the receiver's masks (gnssFixOK clear).
        assert!(!values_from(&packet_with_fix(3, 0)).gnss_fix_ok);
        // No NAV-PVT in the packet yet.
        assert!(!values_from(&SensorPacket::default()).gnss_fix_ok);
    }
}
