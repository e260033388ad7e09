//! The realtime loop: one cycle per period, everything preallocated, no locks, no allocation,
//! no printing, every wait bounded by a deadline.
//!
//! Each cycle is acquire (commands from the ground link; request, wait for and decode the
//! sensor packet, with its timestamps) -> decide ([`Core::step`], pure) -> actuate (write the
//! servo targets) -> publish (a record to the logger, a snapshot to telemetry).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use dima_core::step::{CycleInputs, CycleOutputs, SensorInput};
use dima_core::{Command, Core, CoreState, FailsafeCause, Mode, Nanos, ReviveRefusal};
use dima_sensorboard::{DecoderStats, Frame, InfoFrame, SensorPacket};
use embedded_hal::digital::OutputPin;

use super::record::{events, CycleRecord, Snapshot};
use crate::config::Config;
use crate::control::ServoTargets;
use crate::devices::sensor::SensorDevice;
use crate::devices::servo::{ServoError, ServoOutput};
use crate::devices::{DeviceLink, LinkEvent};
use crate::metrics::LoopMetrics;
use crate::rt::{monotonic_ns, PeriodicClock, Tick};
use crate::telemetry::{LinkCounters, ReceivedCommand};

/// Most command events applied per cycle (the rest wait for the next cycle).
pub const MAX_COMMANDS_PER_CYCLE: usize = 64;
/// Most stale frames drained before a request.
const MAX_STALE_POLLS: usize = 8;
/// Time allowed for the final safe-output write at shutdown, ns.
const SHUTDOWN_WRITE_NS: Nanos = 50_000_000;
/// Wake-up latency histogram range (cyclictest `-h`), µs.
pub const HISTOGRAM_US: usize = 10_000;

/// Extra work inside the realtime cycle during a window of the run, to show what an overload
/// does. Only a simulation sets it (`dima sim --fault loop:busy=START+DURATION,busy_ms=MS`);
/// the configuration file cannot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusyFault {
    /// Window start after the loop's first cycle, ns.
    pub start_ns: Nanos,
    /// Window length, ns.
    pub duration_ns: Nanos,
    /// Work added to every cycle in the window, ns (a busy wait: the CPU is really used).
    pub busy_ns: Nanos,
}

/// Settings of the loop, derived from the configuration before it starts.
#[derive(Debug)]
pub struct LoopParams {
    /// Period, ns.
    pub period_ns: Nanos,
    /// Packet deadline after the request, ns (one period more in request-ahead mode).
    pub packet_deadline_ns: Nanos,
    /// Time allowed for the servo write, ns.
    pub write_budget_ns: Nanos,
    /// Request at the end of the cycle, read at the start of the next.
    pub request_ahead: bool,
    /// Servo targets written every n-th cycle (and whenever they change).
    pub servo_every: u64,
    /// The decisions.
    pub core: Core,
    /// Maestro channel numbers: throttle, steering, tail.
    pub channels: [u8; 3],
    /// Simulated overload, if any.
    pub busy: Option<BusyFault>,
}

impl LoopParams {
    /// From a configuration (refused as `dima config --check` would refuse it).
    pub fn from_config(config: &Config) -> Result<LoopParams, dima_core::config::ConfigError> {
        let rate = config.realtime.loop_rate_hz.max(1);
        let core = Core::new(config)?;
        Ok(LoopParams {
            period_ns: config.period_ns(),
            packet_deadline_ns: config.packet_deadline_after_request_ns(),
            write_budget_ns: u64::from(config.servo_write_budget_us()) * 1_000,
            request_ahead: config.sensor.request_ahead,
            servo_every: u64::from((rate / config.servo_write_hz()).max(1)),
            channels: core.outputs().channel_numbers(),
            core,
            busy: None,
        })
    }
}

/// The loop's connections to the other threads.
pub struct LoopEnds {
    /// Command events from telemetry, with their arrival times.
    pub commands: rtrb::Consumer<ReceivedCommand>,
    /// Records to the logger.
    pub log: rtrb::Producer<CycleRecord>,
    /// Latest state to telemetry.
    pub snapshot: triple_buffer::Input<Snapshot>,
    /// Ground-link counters from telemetry (atomics: read without a lock), for the records.
    pub link: Arc<LinkCounters>,
    /// Set by the signal handler (or a test) to stop.
    pub stop: Arc<AtomicBool>,
}

/// What a cycle's acquire phase took in (on the stack: the realtime path never allocates).
struct Acquired {
    /// Commands in arrival order; the first `n_commands` are this cycle's.
    commands: [ReceivedCommand; MAX_COMMANDS_PER_CYCLE],
    n_commands: usize,
    sensor: SensorInput,
    /// Stale packets passed over in this cycle's wait.
    stale_packets: u32,
}

/// When the cycle's packet was requested and complete (0: none) and when the step ended, ns.
#[derive(Clone, Copy)]
struct Times {
    t_request_ns: Nanos,
    t_packet_ns: Nanos,
    t_compute_ns: Nanos,
}

/// The realtime loop and all its state.
pub struct RealtimeLoop<P: OutputPin, S: ServoOutput> {
    params: LoopParams,
    ends: LoopEnds,
    sensor: DeviceLink<SensorDevice<P>>,
    servo: DeviceLink<S>,
    state: CoreState,
    last_packet: Option<SensorPacket>,
    /// Why the last revive was refused, until a revive succeeds (for the display frames).
    last_refusal: Option<ReviveRefusal>,
    /// Why the robot last entered FAILSAFE, until a revive succeeds (for the display frames:
    /// a kill while in FAILSAFE does not hide the cause from the operator).
    last_cause: Option<FailsafeCause>,
    last_written: Option<ServoTargets>,
    pending_request_ns: Option<Nanos>,
    /// An info frame that arrived since the last record.
    info: Option<InfoFrame>,
    /// Stale packets passed over in this cycle's wait.
    stale_packets: u32,
    decoder_base: DecoderStats,
    first_wake_ns: Option<Nanos>,
    cycle: u64,
    metrics: LoopMetrics,
    outputs_safe: bool,
    shut_down: bool,
}

impl<P: OutputPin, S: ServoOutput> RealtimeLoop<P, S> {
    /// Everything the loop will touch is allocated here. `realtime_fault`: the required
    /// realtime setup failed, so every revive is refused.
    pub fn new(
        params: LoopParams,
        ends: LoopEnds,
        sensor: DeviceLink<SensorDevice<P>>,
        servo: DeviceLink<S>,
        realtime_fault: bool,
    ) -> RealtimeLoop<P, S> {
        let state = CoreState {
            realtime_fault,
            ..CoreState::new()
        };
        RealtimeLoop {
            params,
            ends,
            sensor,
            servo,
            state,
            last_packet: None,
            last_refusal: None,
            last_cause: None,
            last_written: None,
            pending_request_ns: None,
            info: None,
            stale_packets: 0,
            decoder_base: DecoderStats::default(),
            first_wake_ns: None,
            cycle: 0,
            metrics: LoopMetrics::new(HISTOGRAM_US),
            outputs_safe: false,
            shut_down: false,
        }
    }

    /// Metrics so far.
    pub fn metrics(&self) -> &LoopMetrics {
        &self.metrics
    }

    /// Whether the last write of safe targets at shutdown succeeded.
    pub fn outputs_safe(&self) -> bool {
        self.outputs_safe
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

    /// Drains complete frames that arrived since the last cycle (a late answer to an earlier
    /// request; an info frame) before a new request. A frame still arriving stays buffered:
    /// an answer that completes too soon after the next request is recognised by its timing.
    fn drain_stale(&mut self) -> bool {
        let Some(dev) = self.sensor.get() else {
            return true;
        };
        for _ in 0..MAX_STALE_POLLS {
            match dev.board.poll() {
                Ok(Frame::Info(frame)) => self.info = Some(frame),
                Ok(Frame::Packet(_)) => {}
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(_)) => return false,
            }
        }
        true
    }

    fn request(&mut self) -> Option<Nanos> {
        let dev = self.sensor.get()?;
        let t = monotonic_ns();
        let ok = dev.board.request().is_ok() && dev.board.end_request().is_ok();
        ok.then_some(t)
    }

    /// Waits for a packet until `t_request + deadline`. Packets that complete sooner than
    /// their wire time after the request cannot answer it: they are counted and passed over.
    fn wait_packet(&mut self, t_request: Nanos) -> SensorInput {
        let give_up = t_request + self.params.packet_deadline_ns;
        let earliest = t_request + self.params.core.answer_window().earliest_ns;
        let Some(dev) = self.sensor.get() else {
            return SensorInput::NotRequested;
        };
        loop {
            match dev.board.poll() {
                Ok(Frame::Packet(raw)) => {
                    let t_complete = monotonic_ns();
                    if t_complete < earliest && self.stale_packets < MAX_STALE_POLLS as u32 {
                        self.stale_packets += 1;
                        continue;
                    }
                    return SensorInput::Packet {
                        raw,
                        t_request_ns: t_request,
                        t_complete_ns: t_complete,
                    };
                }
                Ok(Frame::Info(frame)) => self.info = Some(frame),
                Err(nb::Error::WouldBlock) => match dev.wait_readable(give_up) {
                    Ok(true) => {}
                    Ok(false) => {
                        return SensorInput::NoAnswer {
                            t_request_ns: t_request,
                        }
                    }
                    Err(_) => return SensorInput::DeviceError,
                },
                Err(nb::Error::Other(_)) => return SensorInput::DeviceError,
            }
        }
    }

    fn sensor_failed(&mut self, events: &mut u16) {
        self.state.counters.sensor_errors += 1;
        let c = &self.state.counters;
        self.decoder_base = DecoderStats {
            packets: 0,
            info_frames: c.info_frames,
            crc_errors: c.packet_crc_errors,
            bytes_skipped: c.packet_bytes_skipped,
            ..DecoderStats::default()
        };
        self.sensor.fail();
        self.pending_request_ns = None;
        *events |= events::SENSOR_LOST;
    }

    /// The sensor phase: the packet requested now, or (request-ahead) at the end of the last
    /// cycle.
    fn acquire_sensor(&mut self, ev: &mut u16) -> SensorInput {
        let sensor = if self.params.request_ahead {
            match self.pending_request_ns.take() {
                Some(t) => self.wait_packet(t),
                None => SensorInput::NotRequested,
            }
        } else if !self.sensor.is_connected() {
            SensorInput::NotRequested
        } else if !self.drain_stale() {
            SensorInput::DeviceError
        } else {
            match self.request() {
                Some(t) => self.wait_packet(t),
                None => SensorInput::DeviceError,
            }
        };
        if sensor == SensorInput::DeviceError {
            self.sensor_failed(ev);
        }
        if let Some(s) = self.sensor.get().map(|d| d.board.stats()) {
            // The decoder's counters restart with each (re)opened device; keep totals.
            let c = &mut self.state.counters;
            c.packet_crc_errors = self.decoder_base.crc_errors + s.crc_errors;
            c.packet_bytes_skipped = self.decoder_base.bytes_skipped + s.bytes_skipped;
            c.info_frames = self.decoder_base.info_frames + s.info_frames;
        }
        sensor
    }

    /// Busy-waits inside the cycle while a simulated overload window is active.
    fn simulated_work(&mut self, wake_ns: Nanos) {
        let Some(busy) = self.params.busy else {
            return;
        };
        let since = wake_ns.saturating_sub(*self.first_wake_ns.get_or_insert(wake_ns));
        if (busy.start_ns..busy.start_ns + busy.duration_ns).contains(&since) {
            let until = monotonic_ns() + busy.busy_ns;
            while monotonic_ns() < until {
                std::hint::spin_loop();
            }
        }
    }

    /// One cycle after the clock woke the thread: acquire, decide, actuate, publish.
    pub fn cycle(&mut self, tick: Tick) {
        self.metrics.wake_latency.record(tick.latency_ns);
        let mut ev = self.refresh_devices();
        self.simulated_work(tick.wake_ns);
        let input = self.acquire(&mut ev);
        let (out, times) = self.decide(&tick, &input, &mut ev);
        let t_write = self.actuate(out.targets, times.t_compute_ns, &mut ev);
        self.request_ahead(&mut ev);
        self.publish_cycle(tick, &input, out, times, t_write, ev);
        self.cycle += 1;
    }

    /// Takes over a device the supervisor (re)opened; the cycle's device events.
    fn refresh_devices(&mut self) -> u16 {
        let mut ev = 0u16;
        if self.sensor.refresh() == LinkEvent::Connected {
            ev |= events::SENSOR_CONNECTED;
            self.state.counters.device_connects += 1;
            self.pending_request_ns = None;
        }
        if self.servo.refresh() == LinkEvent::Connected {
            ev |= events::SERVO_CONNECTED;
            self.state.counters.device_connects += 1;
            self.last_written = None;
        }
        ev
    }

    /// Acquire: commands in arrival order, with their arrival times (the step judges their
    /// age), then the packet.
    fn acquire(&mut self, ev: &mut u16) -> Acquired {
        let mut commands = [ReceivedCommand::new(Command::Heartbeat, 0); MAX_COMMANDS_PER_CYCLE];
        let mut n = 0;
        while n < MAX_COMMANDS_PER_CYCLE {
            let Ok(received) = self.ends.commands.pop() else {
                break;
            };
            commands[n] = received;
            n += 1;
        }
        let sensor = self.acquire_sensor(ev);
        let stale_packets = std::mem::take(&mut self.stale_packets);
        Acquired {
            commands,
            n_commands: n,
            sensor,
            stale_packets,
        }
    }

    /// Decide: one step of the core on what was acquired; records the request-to-packet and
    /// compute times.
    fn decide(&mut self, tick: &Tick, input: &Acquired, ev: &mut u16) -> (CycleOutputs, Times) {
        let out = self.params.core.step(
            &mut self.state,
            &CycleInputs {
                missed_periods: tick.missed,
                commands: &input.commands[..input.n_commands],
                sensor: input.sensor,
                stale_packets: input.stale_packets,
            },
            tick.wake_ns,
        );
        *ev |= decision_events(&out, self.state.realtime_fault && self.cycle == 0);
        if let Some(p) = out.packet {
            self.last_packet = Some(p);
        }
        let t_compute_ns = monotonic_ns();
        let (t_request_ns, t_packet_ns) = match input.sensor {
            SensorInput::Packet {
                t_request_ns,
                t_complete_ns,
                ..
            } => (t_request_ns, t_complete_ns),
            SensorInput::NoAnswer { t_request_ns } => (t_request_ns, 0),
            _ => (0, 0),
        };
        if let Some(ns) = out.request_to_packet_ns {
            self.metrics.request_to_packet.record(ns);
        }
        let compute_from = if t_packet_ns != 0 {
            t_packet_ns
        } else {
            tick.wake_ns
        };
        self.metrics
            .compute
            .record(t_compute_ns.saturating_sub(compute_from));
        let times = Times {
            t_request_ns,
            t_packet_ns,
            t_compute_ns,
        };
        (out, times)
    }

    /// Actuate: at the servo refresh rate, and at once whenever the targets change; the time
    /// of the write (0: none).
    fn actuate(&mut self, targets: ServoTargets, t_compute_ns: Nanos, ev: &mut u16) -> Nanos {
        let due = self.cycle.is_multiple_of(self.params.servo_every)
            || self.last_written != Some(targets);
        if due {
            self.write_targets(targets, t_compute_ns + self.params.write_budget_ns, ev)
        } else {
            0
        }
    }

    /// With request-ahead, requests the next cycle's packet now (after passing over stale
    /// bytes; a sensor that fails there counts as failed).
    fn request_ahead(&mut self, ev: &mut u16) {
        if self.params.request_ahead && self.sensor.is_connected() {
            if self.drain_stale() {
                self.pending_request_ns = self.request();
            } else {
                self.sensor_failed(ev);
            }
        }
    }

    /// Publish: the cycle's record to the logger and the snapshot to telemetry.
    fn publish_cycle(
        &mut self,
        tick: Tick,
        input: &Acquired,
        out: CycleOutputs,
        times: Times,
        t_write_ns: Nanos,
        ev: u16,
    ) {
        self.metrics.counters = self.state.counters;
        let raw = match input.sensor {
            SensorInput::Packet { raw, .. } => Some(raw),
            _ => None,
        };
        let info = self.info.take();
        self.publish(CycleRecord {
            cycle: self.cycle,
            tick,
            t_request_ns: times.t_request_ns,
            t_packet_ns: times.t_packet_ns,
            t_compute_ns: times.t_compute_ns,
            t_write_ns,
            raw,
            info,
            outputs: out,
            setpoints: self.state.safety.setpoints,
            commands: input.commands,
            n_commands: input.n_commands as u8,
            stale_passed: input.stale_packets,
            counters: self.state.counters,
            link: self.ends.link.load(),
            events: ev,
        });
    }

    fn write_targets(&mut self, targets: ServoTargets, deadline_ns: Nanos, ev: &mut u16) -> Nanos {
        let channels = self.params.channels;
        let Some(servo) = self.servo.get() else {
            self.state.counters.servo_missing += 1;
            return 0;
        };
        let t0 = monotonic_ns();
        match servo.write_targets(&channels, &targets.quarter_us(), deadline_ns) {
            Ok(()) => {
                let t = monotonic_ns();
                self.metrics.servo_write.record(t - t0);
                self.state.counters.servo_writes += 1;
                self.last_written = Some(targets);
                t
            }
            Err(ServoError::Timeout | ServoError::InvalidInput) => {
                // Still there, just slow to take bytes (or a target the configuration should
                // have refused): counted, resent next cycle.
                self.state.counters.servo_errors += 1;
                self.last_written = None;
                0
            }
            Err(ServoError::Device) => {
                self.state.counters.servo_errors += 1;
                self.servo.fail();
                self.last_written = None;
                *ev |= events::SERVO_LOST;
                0
            }
        }
    }

    fn publish(&mut self, record: CycleRecord) {
        if record.outputs.refused.is_some() {
            self.last_refusal = record.outputs.refused;
        } else if matches!(record.outputs.mode, Mode::Manual | Mode::Auto) {
            self.last_refusal = None;
        }
        if record.outputs.cause.is_some() {
            self.last_cause = record.outputs.cause;
        } else if matches!(record.outputs.mode, Mode::Manual | Mode::Auto) {
            self.last_cause = None;
        }
        self.ends.snapshot.write(Snapshot {
            packet: self.last_packet,
            mode: record.outputs.mode,
            cause: self.last_cause,
            refusal: self.last_refusal,
            targets: record.outputs.targets,
            setpoints: record.setpoints,
            speed_mm_s: record.outputs.estimate.speed_mm_s.map(|m| m.value),
            heading_deg: record.outputs.estimate.heading_deg.map(|m| m.value),
            counters: record.counters,
            time_ns: record.tick.wake_ns,
        });
        if self.ends.log.push(record).is_err() {
            self.state.counters.log_dropped += 1;
        }
    }

    /// Safe outputs, written whatever the refresh schedule, and a last record. Runs once: at
    /// the end of [`run`](Self::run), or from `Drop` when the loop unwinds from a panic.
    fn shutdown(&mut self) {
        if self.shut_down {
            return;
        }
        self.shut_down = true;
        let mut ev = events::SHUTDOWN;
        let targets = self.params.core.safe_targets();
        let now = monotonic_ns();
        let t_write = self.write_targets(targets, now + SHUTDOWN_WRITE_NS, &mut ev);
        self.outputs_safe = t_write != 0;
        self.state.safety.mode = Mode::Killed;
        self.metrics.counters = self.state.counters;
        let outputs = CycleOutputs {
            targets,
            mode: Mode::Killed,
            cause: None,
            mode_changed: false,
            verdict: dima_core::monitor::PacketVerdict::NotRequested,
            request_to_packet_ns: None,
            packet: None,
            refused: None,
            setpoints_rejected: 0,
            gnss_new: false,
            gnss_age_ns: None,
            action: Default::default(),
            values: self.state.values,
            estimate: self.state.estimate,
            auto_source: None,
            mission: None,
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
            raw: None,
            info: None,
            outputs,
            setpoints: Default::default(),
            commands: [ReceivedCommand::new(Command::Heartbeat, 0); MAX_COMMANDS_PER_CYCLE],
            n_commands: 0,
            stale_passed: 0,
            counters: self.state.counters,
            link: self.ends.link.load(),
            events: ev,
        });
    }
}

impl<P: OutputPin, S: ServoOutput> Drop for RealtimeLoop<P, S> {
    /// A panic inside the loop unwinds through here: the servos still get their safe targets.
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// The event bits of what the step decided (the loop's, and any simulation of it).
pub fn decision_events(out: &CycleOutputs, realtime_fault_reported: bool) -> u16 {
    let mut ev = 0;
    if out.mode_changed {
        ev |= events::MODE_CHANGED;
    }
    if out.refused.is_some() {
        ev |= events::REVIVE_REFUSED;
    }
    if out.setpoints_rejected > 0 {
        ev |= events::SETPOINT_REJECTED;
    }
    if realtime_fault_reported {
        ev |= events::REALTIME_SETUP_FAILED;
    }
    ev
}

#[cfg(test)]
mod tests {
    //! The loop in-process: no sensor board (never connected), a recording servo output,
    //! commands pushed into the ring with explicit arrival times, and cycles driven with
    //! explicit wake-up times. The step judges everything at the tick's time; the loop's part
    //! is to hand each command to it, and to the log, with its arrival time.

    use std::sync::Mutex;
    use std::time::Duration;

    use embedded_hal_mock::eh1::digital::Mock as Pin;

    use super::*;
    use crate::devices::{device_link, Supervisor};

    const MS: Nanos = 1_000_000;

    /// A servo output that records every write, or fails while told to.
    #[derive(Clone, Default)]
    struct Servo {
        writes: Arc<Mutex<Vec<[u16; 3]>>>,
        fail: Arc<Mutex<Option<ServoError>>>,
    }

    impl ServoOutput for Servo {
        fn write_targets(
            &mut self,
            _channels: &[u8; 3],
            targets_qus: &[u16; 3],
            _deadline_ns: Nanos,
        ) -> Result<(), ServoError> {
            if let Some(e) = *self.fail.lock().unwrap() {
                return Err(e);
            }
            self.writes.lock().unwrap().push(*targets_qus);
            Ok(())
        }
    }

    struct Harness {
        rt: RealtimeLoop<Pin, Servo>,
        commands: rtrb::Producer<ReceivedCommand>,
        servo: Servo,
        servo_sup: Supervisor<Servo>,
        _sensor_sup: Supervisor<SensorDevice<Pin>>,
        log: rtrb::Consumer<CycleRecord>,
    }

    impl Harness {
        fn new() -> Harness {
            let config = Config::default();
            let params = LoopParams::from_config(&config).unwrap();
            let (commands, commands_rx) = rtrb::RingBuffer::new(config.realtime.command_ring);
            let (log_tx, log) = rtrb::RingBuffer::new(4);
            let (snapshot, _) = triple_buffer::triple_buffer(&Snapshot::default());
            let (sensor_sup, sensor) = device_link(
                "sensor board",
                Box::new(|| anyhow::bail!("absent")),
                Duration::from_secs(1),
            );
            let servo = Servo::default();
            let opened = servo.clone();
            let (servo_sup, servo_link) = device_link(
                "servo",
                Box::new(move || Ok(opened.clone())),
                Duration::from_millis(1_000),
            );
            let ends = LoopEnds {
                commands: commands_rx,
                log: log_tx,
                snapshot,
                link: Arc::new(LinkCounters::default()),
                stop: Arc::new(AtomicBool::new(false)),
            };
            Harness {
                rt: RealtimeLoop::new(params, ends, sensor, servo_link, false),
                commands,
                servo,
                servo_sup,
                _sensor_sup: sensor_sup,
                log,
            }
        }

        /// MANUAL with a healthy sensor link and a link seen at `link_ns` (the board is not
        /// connected in these tests: its health is set, and holds for fewer than
        /// `sensor_loss_packets` cycles).
        fn manual(&mut self, link_ns: Nanos) {
            let s = &mut self.rt.state.safety;
            s.mode = Mode::Manual;
            s.bad_packets = 0;
            s.good_packets = 1_000;
            s.last_link_ns = Some(link_ns);
        }

        fn send(&mut self, command: Command, arrival_ns: Nanos) {
            self.commands
                .push(ReceivedCommand {
                    command,
                    arrival_ns,
                })
                .unwrap();
        }

        fn cycle_at(&mut self, wake_ns: Nanos) {
            self.rt.cycle(Tick {
                deadline_ns: wake_ns,
                wake_ns,
                latency_ns: 0,
                missed: 0,
            });
        }

        fn mode(&self) -> (Mode, Option<FailsafeCause>) {
            (self.rt.state.safety.mode, self.rt.state.safety.cause)
        }
    }

    #[test]
    fn a_command_that_waited_keeps_the_link_only_from_its_arrival() {
        // Comms timeout 1 s. A heartbeat arrived at 150 ms, then the radio went silent; the
        // heartbeat reached the loop only at 900 ms (the reader or the ring fell behind). The
        // link ends 1 s after 150 ms, not 1 s after 900 ms.
        let mut h = Harness::new();
        h.manual(100 * MS);
        h.send(Command::Heartbeat, 150 * MS);
        h.cycle_at(900 * MS);
        assert_eq!(h.mode(), (Mode::Manual, None));
        h.cycle_at(1_148 * MS);
        assert_eq!(h.mode(), (Mode::Manual, None));
        h.cycle_at(1_152 * MS);
        assert_eq!(h.mode(), (Mode::Failsafe, Some(FailsafeCause::CommsLoss)));
    }

    #[test]
    fn each_command_reaches_the_step_and_the_record_with_its_arrival_time() {
        let mut h = Harness::new();
        h.manual(100 * MS);
        let sent = [
            ReceivedCommand::new(Command::Throttle(dima_groundlink::Percent::MAX), 0),
            ReceivedCommand::new(Command::Heartbeat, 150 * MS),
            ReceivedCommand::new(Command::Steering(dima_groundlink::Percent::MIN), 890 * MS),
        ];
        for r in sent {
            h.send(r.command, r.arrival_ns);
        }
        h.cycle_at(1_050 * MS);
        let record = h.log.pop().unwrap();
        assert_eq!(record.commands(), sent);
        // The step judged each by its own age: the throttle (1.05 s old) did not act.
        assert_eq!(h.rt.state.counters.commands_stale, 1);
        assert_eq!(h.rt.state.safety.last_link_ns, Some(890 * MS));
        let sp = h.rt.state.safety.setpoints;
        assert_eq!(
            (sp.throttle, sp.steering),
            (None, Some(dima_groundlink::Percent::MIN))
        );
    }

    #[test]
    fn commands_older_than_the_comms_timeout_do_not_act_but_a_kill_does() {
        // A throttle that arrived at 0 and reaches the loop 1.2 s later is no link activity
        // and no instruction: the link was lost at 1 s.
        let mut h = Harness::new();
        h.manual(0);
        h.send(Command::Throttle(dima_groundlink::Percent::MAX), 0);
        h.cycle_at(1_200 * MS);
        assert_eq!(h.mode(), (Mode::Failsafe, Some(FailsafeCause::CommsLoss)));
        assert_eq!(h.rt.state.safety.setpoints.throttle, None);
        assert_eq!(h.rt.state.counters.commands_stale, 1);

        // A revive that waited as long does not revive (the sensor link is healthy here, so
        // only its age can refuse it).
        let mut h = Harness::new();
        h.manual(0);
        h.rt.state.safety.mode = Mode::Killed;
        h.send(Command::Revive, 0);
        h.cycle_at(1_200 * MS);
        assert_eq!(h.mode(), (Mode::Killed, None));

        // A kill is honoured however old.
        let mut h = Harness::new();
        h.manual(1_100 * MS);
        h.send(Command::Kill, 0);
        h.cycle_at(1_200 * MS);
        assert_eq!(h.mode(), (Mode::Killed, None));
        assert_eq!(h.rt.state.counters.commands_stale, 0);
    }

    #[test]
    fn fresh_commands_act_and_keep_the_link_from_their_arrival() {
        let mut h = Harness::new();
        h.manual(0);
        h.send(Command::Throttle(dima_groundlink::Percent::MAX), 990 * MS);
        h.cycle_at(1_000 * MS);
        assert_eq!(h.mode(), (Mode::Manual, None));
        assert_eq!(
            h.rt.state.safety.setpoints.throttle,
            Some(dima_groundlink::Percent::MAX)
        );
        h.cycle_at(1_988 * MS);
        assert_eq!(h.mode(), (Mode::Manual, None));
        h.cycle_at(1_992 * MS);
        assert_eq!(h.mode(), (Mode::Failsafe, Some(FailsafeCause::CommsLoss)));
    }

    #[test]
    fn a_kill_during_a_servo_outage_is_the_first_write_after_the_reopen() {
        let mut h = Harness::new();
        let t0 = std::time::Instant::now();
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        assert!(h.servo_sup.service(at(0)));
        h.manual(0);
        h.send(Command::Throttle(dima_groundlink::Percent::MAX), 0);
        h.cycle_at(4 * MS);
        let safe = h.rt.params.core.safe_targets().quarter_us();
        let driving = h.servo.writes.lock().unwrap().clone();
        assert_eq!(driving.len(), 1);
        assert_ne!(driving[0], safe);

        // The board fails: it is handed back and nothing more reaches it.
        *h.servo.fail.lock().unwrap() = Some(ServoError::Device);
        h.send(Command::Throttle(dima_groundlink::Percent::MIN), 6 * MS);
        h.cycle_at(8 * MS);
        assert!(!h.rt.servo.is_connected());
        *h.servo.fail.lock().unwrap() = None;
        h.send(Command::Kill, 10 * MS);
        h.cycle_at(12 * MS);
        assert_eq!(h.mode(), (Mode::Killed, None));
        assert_eq!(h.servo.writes.lock().unwrap().len(), 1);
        assert_eq!(h.rt.state.counters.servo_errors, 1);
        assert_eq!(h.rt.state.counters.servo_missing, 1);

        // The supervisor closes it and reopens one reopen interval later; the cycle that
        // adopts it writes the safe targets, whatever the refresh schedule.
        assert!(!h.servo_sup.service(at(20)));
        assert!(!h.servo_sup.service(at(1_010)));
        assert!(h.servo_sup.service(at(1_020)));
        h.cycle_at(1_024 * MS);
        assert_eq!(h.servo.writes.lock().unwrap()[1..], [safe]);
    }

    #[test]
    fn a_write_timeout_keeps_the_board_and_resends_the_next_cycle() {
        let mut h = Harness::new();
        assert!(h.servo_sup.service(std::time::Instant::now()));
        *h.servo.fail.lock().unwrap() = Some(ServoError::Timeout);
        h.cycle_at(4 * MS); // cycle 0: due, times out
        assert!(h.rt.servo.is_connected());
        assert_eq!(h.rt.state.counters.servo_errors, 1);
        *h.servo.fail.lock().unwrap() = None;
        h.cycle_at(8 * MS); // cycle 1: not on the refresh schedule, resent anyway
        assert_eq!(h.servo.writes.lock().unwrap().len(), 1);
        h.cycle_at(12 * MS); // written and unchanged: waits for the schedule
        assert_eq!(h.servo.writes.lock().unwrap().len(), 1);
    }
}
