//! One run: the real parts composed in virtual time, one cycle of the robot after another,
//! with the ground station, the radio, the operator and the telemetry's display frames as
//! events between the cycles, and the invariants checked after every cycle.

use std::collections::VecDeque;
use std::time::Duration;

use crate::model::{Inputs, Vehicle, VehicleParams, DIMA_PULSE_MAPS};
use crate::rng::SimRng;
use dima_core::config::Config;
use dima_core::step::{CycleInputs, CycleOutputs, SensorInput};
use dima_core::{Command, Core, CoreState, FailsafeCause, Mode, Nanos, ReviveRefusal};
use dima_groundlink::station::{Station, StationTime};
use dima_groundlink::v2::{DisplayDecoder, LinkKey, RobotMode};
use dima_sensorboard::SensorPacket;

use super::faults::{Fault, FaultPlan};
use super::host::Host;
use super::intent::Intent;
use super::invariants::{Applied, Checker, CycleView, Violation};
use super::navigation::{self, Navigation};
use super::operator::{Action, Operator};
use super::radio::{Channel, ChannelParams};
use super::sensor::Sensor;
use dima_robot::app::record::{CycleRecord, Snapshot};
use dima_robot::app::rt_loop::MAX_COMMANDS_PER_CYCLE;
use dima_robot::rt::{PeriodicClock, Tick};
use dima_robot::telemetry::{display_frame_v2, CommandLink, LinkSecurity, ReceivedCommand};

/// Virtual time of the first deadline, ns (any fixed value: the clock is virtual).
pub const START_NS: Nanos = 1_000_000_000;

/// What a frame on the uplink carried, for the invariants.
#[derive(Debug, Clone, Copy)]
struct UplinkMeta {
    command: Command,
    asked_at: Option<Nanos>,
}

/// What the robot put into a display frame, for the invariants.
#[derive(Debug, Clone, Copy)]
struct DownlinkMeta {
    mode: RobotMode,
}

/// Receives each cycle's record (the trace).
pub type RecordSink<'a> = &'a mut dyn FnMut(&CycleRecord);

/// The composed system of one seed.
pub struct Simulation {
    config: Config,
    key: LinkKey,
    session: u32,
    // Ground.
    operator: Operator,
    intent: Intent,
    station: Station,
    display_decoder: DisplayDecoder,
    shown: Option<RobotMode>,
    /// Time of the last ground or radio event, ns.
    ground_now: Nanos,
    // Radio.
    uplink: Channel<UplinkMeta>,
    downlink: Channel<DownlinkMeta>,
    // Robot.
    link: CommandLink,
    /// Commands handed to the loop, with when the telemetry thread handed each over.
    handed_over: VecDeque<(Nanos, Applied)>,
    /// The telemetry thread's hold-ups (it runs below the loop's priority): per frame the
    /// chance that it is held up, and until when it is.
    telemetry_rng: SimRng,
    telemetry_stall: f64,
    telemetry_busy_until: Nanos,
    display_period_ns: Nanos,
    next_display_ns: Nanos,
    display_seq: u32,
    snapshot: Snapshot,
    core: Core,
    state: CoreState,
    clock: PeriodicClock,
    host: Host,
    sensor: Sensor,
    plan: FaultPlan,
    vehicle: Vehicle,
    cycle: u64,
    /// The mission and fence the robot runs with.
    navigation: Option<Navigation>,
    /// Cycles in which AUTO followed the mission.
    mission_cycles: u64,
    /// Entries into FAILSAFE with the cause `Geofence`.
    fence_failsafes: u64,
    // Judge.
    checker: Checker,
}

impl Simulation {
    /// The system for `seed`, running until `end_ns` of virtual time (for the fault plan).
    pub fn new(seed: u64, end_ns: Nanos) -> Simulation {
        Simulation::with(seed, end_ns, true)
    }

    /// The system for `seed`; without `faults` the radio, the board and the host behave. Even
    /// seeds carry a mission and a geofence ([`navigation::for_seed`]).
    pub fn with(seed: u64, end_ns: Nanos, faults: bool) -> Simulation {
        let navigation = navigation::for_seed(seed, SimRng::new(seed).fork(10));
        Simulation::with_navigation(seed, end_ns, faults, navigation)
    }

    /// The system for `seed` with `navigation` (none: no mission, no fence).
    pub fn with_navigation(
        seed: u64,
        end_ns: Nanos,
        faults: bool,
        navigation: Option<Navigation>,
    ) -> Simulation {
        let mut sim = Simulation::build(seed, end_ns, faults, navigation.as_ref());
        sim.navigation = navigation;
        sim
    }

    /// The system for `seed` whose robot does not know of `navigation`'s fence, while the
    /// invariants judge against it: a robot that never trips the fence (for the invariants'
    /// tests).
    #[cfg(test)]
    pub(crate) fn with_fence_unknown_to_robot(
        seed: u64,
        end_ns: Nanos,
        navigation: Navigation,
    ) -> Simulation {
        let mut sim = Simulation::with_navigation(seed, end_ns, true, Some(navigation));
        let mut robot_config = sim.config.clone();
        robot_config.navigation.fence = Default::default();
        sim.core = Core::new(&robot_config).expect("a valid configuration");
        if let Some(mission) = sim.navigation.as_ref().and_then(|n| n.mission.as_ref()) {
            sim.core.set_mission(mission);
        }
        sim.config = robot_config;
        sim
    }

    fn build(
        seed: u64,
        end_ns: Nanos,
        faults: bool,
        navigation: Option<&Navigation>,
    ) -> Simulation {
        let mut config = Config::default();
        if let Some(n) = navigation {
            config.navigation.fence = n.fence.clone();
        }
        let mission = navigation.and_then(|n| n.mission.as_ref());
        let mut core = Core::new(&config).expect("the configuration is valid");
        if let Some(mission) = mission {
            core.set_mission(mission);
        }
        let root = SimRng::new(seed);
        let mut draw = root.fork(0);
        let key = LinkKey::from_bytes(core::array::from_fn(|_| draw.below(256) as u8));
        let session = (draw.next_u64() as u32).max(1);
        let baud = config.xbee.baud;
        let (up, down) = if faults {
            (
                ChannelParams::draw(&mut draw, baud),
                ChannelParams::draw(&mut draw, baud),
            )
        } else {
            let clean = ChannelParams {
                byte_ns: super::radio::byte_time_ns(baud),
                loss: 0.0,
                burst_start: 0.0,
                burst_max_ns: 0,
                corruption: 0.0,
                delay_ns: (5_000_000, 5_000_000),
            };
            (clean, clean)
        };
        let period_ns = config.period_ns();
        let plan = if faults {
            FaultPlan::draw(&root.fork(1), START_NS, end_ns)
        } else {
            FaultPlan::none()
        };
        let host = if faults {
            Host::new(root.fork(2), period_ns)
        } else {
            Host::quiet(root.fork(2), period_ns)
        };
        let security = LinkSecurity {
            key: Some(key.clone()),
            require_auth: config.xbee.require_auth,
            session,
        };
        let display_period_ns = (1e9 / config.xbee.display_rate_hz) as Nanos;
        let heading = root.fork(3).uniform() * 360.0;
        Simulation {
            operator: Operator::new(root.fork(4), START_NS, config.control.max_speed_mm_s),
            intent: Intent::default(),
            station: Station::new(),
            display_decoder: DisplayDecoder::new(key.clone()),
            shown: None,
            ground_now: START_NS,
            uplink: Channel::new(up, root.fork(5)),
            downlink: Channel::new(down, root.fork(6)),
            link: CommandLink::new(&security),
            handed_over: VecDeque::new(),
            telemetry_stall: if faults {
                0.005 + root.fork(8).uniform() * 0.025
            } else {
                0.0
            },
            telemetry_rng: root.fork(9),
            telemetry_busy_until: 0,
            display_period_ns,
            next_display_ns: START_NS,
            display_seq: 0,
            snapshot: Snapshot::default(),
            core,
            state: CoreState::new(),
            clock: PeriodicClock::new(period_ns, START_NS - period_ns),
            host,
            sensor: Sensor::new(&config, root.fork(7), START_NS),
            plan,
            vehicle: Vehicle::new(VehicleParams::default(), heading),
            cycle: 0,
            checker: Checker::new(&config).with_mission(mission.is_some()),
            navigation: None,
            mission_cycles: 0,
            fence_failsafes: 0,
            config,
            key,
            session,
        }
    }

    /// The configuration the robot runs.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The mission and the fence the robot runs with (`None`: neither).
    pub fn navigation(&self) -> Option<&Navigation> {
        self.navigation.as_ref()
    }

    /// Cycles so far in which AUTO followed the mission (a mission status was reported).
    pub fn mission_cycles(&self) -> u64 {
        self.mission_cycles
    }

    /// Fresh fixes the harness found outside the geofence in cycles that began in MANUAL or
    /// AUTO, so far.
    pub fn fence_exits(&self) -> u64 {
        self.checker.fence_exits()
    }

    /// Entries into FAILSAFE with the cause `Geofence` so far.
    pub fn fence_failsafes(&self) -> u64 {
        self.fence_failsafes
    }

    /// Virtual time run so far: up to the next deadline, ns.
    pub fn elapsed_ns(&self) -> Nanos {
        self.clock.next_deadline_ns().saturating_sub(START_NS)
    }

    /// Cycles run so far.
    pub fn cycles(&self) -> u64 {
        self.cycle
    }

    /// Invariant checks so far.
    pub fn checks(&self) -> u64 {
        self.checker.checks()
    }

    /// Violations so far.
    pub fn violations(&self) -> &[Violation] {
        self.checker.violations()
    }

    /// Runs cycles until the next deadline is past `end_ns`, handing each cycle's record to
    /// `sink`; stops early after a violation when `stop_after_violation_ns` is given, that
    /// long after the first one.
    pub fn run_until(
        &mut self,
        end_ns: Nanos,
        stop_after_violation_ns: Option<Nanos>,
        mut sink: Option<RecordSink>,
    ) {
        while self.clock.next_deadline_ns() <= end_ns {
            if let (Some(after), Some(first)) = (stop_after_violation_ns, self.violations().first())
            {
                if self.clock.next_deadline_ns() > first.t_ns + after {
                    break;
                }
            }
            let record = self.step();
            if let Some(sink) = sink.as_mut() {
                sink(&record);
            }
        }
    }

    /// One cycle of the robot, after the events before its wake-up.
    pub fn step(&mut self) -> CycleRecord {
        let deadline = self.clock.next_deadline_ns();
        let wake = self.host.wake(deadline);
        self.events_until(wake);
        let tick = self.clock.advance(wake);

        // Acquire: commands in arrival order (at most a cycle's worth), then the packet.
        let ready = self
            .handed_over
            .iter()
            .take_while(|(at, _)| *at <= wake)
            .count();
        let n = ready.min(MAX_COMMANDS_PER_CYCLE);
        let applied: Vec<Applied> = self.handed_over.drain(..n).map(|(_, a)| a).collect();
        let mut commands = [ReceivedCommand::new(Command::Heartbeat, 0); MAX_COMMANDS_PER_CYCLE];
        for (slot, a) in commands.iter_mut().zip(&applied) {
            *slot = ReceivedCommand::new(a.command, a.arrival_ns);
        }
        self.vehicle.advance_to(secs(wake));
        let sensor = self
            .sensor
            .cycle(wake, self.vehicle.state(), &mut self.plan);

        // Decide.
        let mode_before = self.state.safety.mode;
        let out = self.core.step(
            &mut self.state,
            &CycleInputs {
                missed_periods: tick.missed,
                commands: &commands[..n],
                sensor: sensor.input,
                stale_packets: sensor.stale,
            },
            wake,
        );

        // Actuate.
        let pulses = out.targets.pulse_us.map(f64::from);
        self.vehicle.set_inputs(Inputs {
            throttle: DIMA_PULSE_MAPS[0].fraction(pulses[0]),
            steering: DIMA_PULSE_MAPS[1].fraction(pulses[1]),
            tail: DIMA_PULSE_MAPS[2].fraction(pulses[2]),
        });

        // Judge.
        self.checker.check_cycle(
            &CycleView {
                cycle: self.cycle,
                now: wake,
                missed: tick.missed,
                mode_before,
                out: &out,
                commands: &applied,
                packet: sensor.packet.as_ref(),
            },
            &self.intent,
        );

        if out.mission.is_some() {
            self.mission_cycles += 1;
        }
        if out.mode == Mode::Failsafe
            && out.cause == Some(FailsafeCause::Geofence)
            && mode_before != Mode::Failsafe
        {
            self.fence_failsafes += 1;
        }

        // Publish.
        self.publish(&out, wake);
        let record = self.record(tick, &out, sensor.input, sensor.stale, commands, n);
        self.cycle += 1;
        record
    }

    /// The snapshot telemetry's display frames are built from, as the loop publishes it.
    fn publish(&mut self, out: &CycleOutputs, now: Nanos) {
        let driving = matches!(out.mode, Mode::Manual | Mode::Auto);
        let s = &mut self.snapshot;
        if out.refused.is_some() {
            s.refusal = out.refused;
        } else if driving {
            s.refusal = None::<ReviveRefusal>;
        }
        if out.cause.is_some() {
            s.cause = out.cause;
        } else if driving {
            s.cause = None::<FailsafeCause>;
        }
        if out.packet.is_some() {
            s.packet = out.packet;
        }
        s.mode = out.mode;
        s.targets = out.targets;
        s.counters = self.state.counters;
        s.time_ns = now;
    }

    fn record(
        &self,
        tick: Tick,
        out: &CycleOutputs,
        sensor: SensorInput,
        stale: u32,
        commands: [ReceivedCommand; MAX_COMMANDS_PER_CYCLE],
        n: usize,
    ) -> CycleRecord {
        let (t_request, t_packet, raw) = match sensor {
            SensorInput::Packet {
                raw,
                t_request_ns,
                t_complete_ns,
            } => (t_request_ns, t_complete_ns, Some(raw)),
            SensorInput::NoAnswer { t_request_ns } => (t_request_ns, 0, None),
            _ => (0, 0, None),
        };
        let t_compute = t_packet.max(tick.wake_ns) + 20_000;
        let ev = dima_robot::app::rt_loop::decision_events(out, false);
        CycleRecord {
            cycle: self.cycle,
            tick,
            t_request_ns: t_request,
            t_packet_ns: t_packet,
            t_compute_ns: t_compute,
            t_write_ns: t_compute + 150_000,
            raw,
            info: None,
            outputs: *out,
            setpoints: self.state.safety.setpoints,
            commands,
            n_commands: n as u8,
            stale_passed: stale,
            counters: self.state.counters,
            link: self.link.counters(),
            events: ev,
        }
    }

    /// Everything on the ground and in the air up to `until`, in time order.
    fn events_until(&mut self, until: Nanos) {
        loop {
            let now = self.ground_now;
            let station_due = station_ns(self.station.next_due(station_time(now))).max(now);
            let next = [
                self.operator.next_at(),
                station_due,
                self.next_display_ns,
                self.uplink.next_arrival().unwrap_or(Nanos::MAX),
                self.downlink.next_arrival().unwrap_or(Nanos::MAX),
            ];
            let t = next.iter().copied().min().unwrap_or(Nanos::MAX);
            if t > until {
                return;
            }
            self.ground_now = t;
            if self.operator.next_at() == t {
                let action = self.operator.act(self.shown);
                self.operate(action, t);
            } else if station_due == t {
                self.send_commands(t);
            } else if self.next_display_ns == t {
                self.send_display(t);
                self.next_display_ns += self.display_period_ns;
            } else if self.uplink.next_arrival() == Some(t) {
                self.receive_commands(t);
            } else {
                self.receive_display(t);
            }
        }
    }

    fn operate(&mut self, action: Action, t: Nanos) {
        self.intent.note(action, t);
        let now = station_time(t);
        match action {
            Action::Request(command) => self.station.request(command, now),
            Action::Hold(channel, command) => self.station.hold(channel, Some(command)),
            Action::Release(channel) => self.station.hold(channel, None),
        }
    }

    fn send_commands(&mut self, t: Nanos) {
        for frame in self.station.poll(station_time(t)) {
            let meta = UplinkMeta {
                command: frame.command,
                asked_at: self.intent.asked_at(frame.command, t),
            };
            self.uplink.send(&frame.encode(&self.key), meta, t);
        }
        // The station keeps its settled list for a GUI; nobody reads it here.
        self.station.take_settled();
    }

    fn receive_commands(&mut self, t: Nanos) {
        let Some(frame) = self.uplink.receive(t) else {
            return;
        };
        if self.telemetry_rng.chance(self.telemetry_stall) {
            self.telemetry_busy_until = t + 20_000_000 + self.telemetry_rng.below(400_000_000);
        }
        let handed_at = t.max(self.telemetry_busy_until);
        let mut got = Vec::new();
        for &b in &frame.bytes {
            self.link.push(b, &mut |c| got.push(c));
        }
        for command in got {
            // The tag cannot be forged: an accepted command is this frame's (a revive the gate
            // acted on before comes out as a heartbeat).
            let asked_at = (command == frame.meta.command || command == Command::Heartbeat)
                .then_some(frame.meta.asked_at)
                .flatten();
            // Its arrival: when its last byte reached the robot's port.
            let applied = Applied {
                command,
                asked_at,
                arrival_ns: t,
            };
            self.handed_over.push_back((handed_at, applied));
        }
    }

    fn send_display(&mut self, t: Nanos) {
        self.display_seq = self.display_seq.wrapping_add(1).max(1);
        let frame = display_frame_v2(
            &self.snapshot,
            self.session,
            self.display_seq,
            self.link.last_accepted(),
            &self.link.counters(),
        );
        let meta = DownlinkMeta { mode: frame.mode };
        self.downlink.send(&frame.encode(&self.key), meta, t);
    }

    fn receive_display(&mut self, t: Nanos) {
        let Some(frame) = self.downlink.receive(t) else {
            return;
        };
        for &b in &frame.bytes {
            let Some(Ok(display)) = self.display_decoder.push(b) else {
                continue;
            };
            let verdict = self.station.on_display(&display, station_time(t));
            if verdict != dima_groundlink::station::DownlinkVerdict::Old {
                self.shown = Some(display.mode);
                self.checker
                    .check_display(self.cycle, t, display.mode, frame.meta.mode);
            }
        }
    }

    /// Debug.
    pub fn intent_debug(&self) -> String {
        format!("{:?}", self.intent)
    }

    /// The sensor faults on at `t_ns` (to tell which one a violation follows).
    pub fn faults_at(&self, t_ns: Nanos) -> Vec<Fault> {
        Fault::ALL
            .into_iter()
            .filter(|&f| {
                self.plan
                    .windows(f)
                    .iter()
                    .any(|&(a, b)| a <= t_ns && t_ns < b)
            })
            .collect()
    }

    /// The robot's decoded packet of the last cycle (for tests).
    pub fn last_packet(&self) -> Option<SensorPacket> {
        self.snapshot.packet
    }
}

fn secs(t: Nanos) -> f64 {
    t.saturating_sub(START_NS) as f64 * 1e-9
}

fn station_time(t: Nanos) -> StationTime {
    Duration::from_nanos(t)
}

fn station_ns(t: StationTime) -> Nanos {
    t.as_nanos().min(u128::from(Nanos::MAX)) as Nanos
}
