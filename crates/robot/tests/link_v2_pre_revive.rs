//! A value the operator gave while the robot was KILLED, which the ground station keeps repeating
//! until it sees it acknowledged, never moves the robot after a revive. In-process with a
//! virtual clock: the robot's command link (`dima_robot::telemetry::CommandLink`, the real v2 gate)
//! feeds the control step (`dima_core::Core::step`) cycle by cycle, the way the telemetry thread
//! and the realtime loop do; the station repeats every outstanding request once per 100 ms slot
//! and never hears an acknowledgement (a downlink that fades is enough).

use dima_core::config::Config;
use dima_core::{
    Command, Core, CoreState, CycleInputs, CycleOutputs, Mode, Nanos, ReceivedCommand, SensorInput,
};
use dima_groundlink::v2::{CommandFrame, LinkKey};
use dima_groundlink::Percent;
use dima_robot::telemetry::{CommandLink, LinkSecurity};
use dima_sensorboard::nav_pvt::FLAG_GNSS_FIX_OK;
use dima_sensorboard::{GnssFrame, NavPvt, RawPacket, SensorPacket};

const MS: Nanos = 1_000_000;
const SLOT: Nanos = 100 * MS;
/// Request to packet complete for a healthy sensor link.
const ANSWER: Nanos = 3_300_000;
const KEY: LinkKey = LinkKey::from_bytes([0x3C; 16]);
const SESSION: u32 = 0x5EED_0001;
/// Manual throttle neutral and 80 %, µs (channel range 1000-2000).
const NEUTRAL_US: u16 = 1_500;
const THROTTLE_80_US: u16 = 1_800;

fn pct(v: u8) -> Percent {
    Percent::new(v).unwrap()
}

/// A ground station that repeats each request every slot, under a new sequence number and with
/// the number of the request's first frame, and never hears an acknowledgement.
struct Station {
    seq: u32,
    /// (command, request) of every request still repeated.
    outstanding: Vec<(Command, u32)>,
}

impl Station {
    fn new() -> Station {
        Station {
            seq: 0,
            outstanding: Vec::new(),
        }
    }

    /// The operator asks for `command`; returns the request's number.
    fn request(&mut self, command: Command) -> u32 {
        let request = self.seq + 1;
        self.outstanding.push((command, request));
        request
    }

    /// The bytes of one slot: every outstanding request once, or a heartbeat.
    fn slot(&mut self) -> Vec<u8> {
        let mut frames = self.outstanding.clone();
        if frames.is_empty() {
            frames.push((Command::Heartbeat, self.seq + 1));
        }
        let mut bytes = Vec::new();
        for (command, request) in frames {
            self.seq += 1;
            bytes.extend(CommandFrame::repeat(command, SESSION, self.seq, request).encode(&KEY));
        }
        bytes
    }
}

/// The robot: the command link and the control step, a healthy sensor board with a GNSS fix.
struct Robot {
    link: CommandLink,
    core: Core,
    state: CoreState,
    period: Nanos,
    now: Nanos,
    itow_ms: u32,
    noise: i16,
}

impl Robot {
    fn new() -> Robot {
        let config = Config::default();
        let mut robot = Robot {
            link: CommandLink::new(&LinkSecurity {
                key: Some(KEY),
                require_auth: true,
                session: SESSION,
            }),
            core: Core::new(&config).expect("the default configuration"),
            state: CoreState::new(),
            period: config.period_ns(),
            now: 1_000 * MS,
            itow_ms: 1_000,
            noise: 0,
        };
        // The board has answered long enough for a revive.
        for _ in 0..config.safety.revive_good_packets {
            robot.cycle(&[]);
        }
        robot
    }

    /// A sensor packet: IMU words that change (not stuck), a fresh 3-D fix at 2 m/s.
    fn packet(&mut self) -> RawPacket {
        self.noise = self.noise.wrapping_add(1);
        if self.now % SLOT < self.period {
            self.itow_ms += 100;
        }
        let pvt = NavPvt {
            itow_ms: self.itow_ms,
            fix_type: 3,
            flags: FLAG_GNSS_FIX_OK,
            g_speed_mm_s: 2_000,
            s_acc_mm_s: 150,
            ..NavPvt::default()
        };
        let packet = SensorPacket {
            accel: [self.noise % 7, -3, 1_000],
            gyro: [1, self.noise % 5, -2],
            gnss: GnssFrame::from_nav_pvt(&pvt),
            ..SensorPacket::default()
        };
        RawPacket::new(packet.encode()).expect("a valid packet")
    }

    fn cycle(&mut self, commands: &[Command]) -> CycleOutputs {
        self.now += self.period;
        let sensor = SensorInput::Packet {
            raw: self.packet(),
            t_request_ns: self.now,
            t_complete_ns: self.now + ANSWER,
        };
        // Every command arrived just before this cycle.
        let received: Vec<ReceivedCommand> = commands
            .iter()
            .map(|&c| ReceivedCommand::new(c, self.now))
            .collect();
        let inputs = CycleInputs {
            missed_periods: 0,
            commands: &received,
            sensor,
            stale_packets: 0,
        };
        self.core.step(&mut self.state, &inputs, self.now)
    }

    /// One 100 ms slot: the station's bytes reach the gate, its commands the next cycle, then
    /// quiet cycles to the end of the slot. Every cycle's outputs.
    fn slot(&mut self, station: &mut Station) -> Vec<CycleOutputs> {
        let mut commands = Vec::new();
        for byte in station.slot() {
            self.link.push(byte, &mut |c| commands.push(c));
        }
        let cycles = SLOT / self.period;
        let mut out = vec![self.cycle(&commands)];
        out.extend((1..cycles).map(|_| self.cycle(&[])));
        out
    }
}

#[test]
fn a_throttle_given_while_killed_and_repeated_after_the_revive_does_not_move_the_robot() {
    let mut robot = Robot::new();
    let mut station = Station::new();
    // The operator pushes the throttle slider to 80 % while the robot is KILLED.
    station.request(Command::Throttle(pct(80)));
    for _ in 0..3 {
        for out in robot.slot(&mut station) {
            assert_eq!(out.mode, Mode::Killed);
            assert_eq!(out.targets.pulse_us[0], NEUTRAL_US);
        }
    }
    // Then revives; the station goes on repeating both requests for two seconds.
    station.request(Command::Revive);
    let mut slots = Vec::new();
    for _ in 0..20 {
        slots.push(robot.slot(&mut station));
    }
    for (i, slot) in slots.iter().enumerate() {
        for out in slot {
            assert_eq!(out.mode, Mode::Manual, "slot {i}");
            assert_eq!(
                out.targets.pulse_us[0], NEUTRAL_US,
                "slot {i}: the throttle given before the revive moved the robot"
            );
        }
    }
    let counters = robot.link.counters();
    // Every throttle repetition after the revive (in the revive's first slot the throttle
    // went first, to a KILLED robot), and every revive repetition, taken as a heartbeat;
    // nothing rejected.
    assert_eq!(counters.pre_revive_requests, 19, "{counters:?}");
    assert_eq!(counters.revive_repeats, 19, "{counters:?}");
    assert_eq!(counters.rejected(), 0, "{counters:?}");
    assert_eq!(robot.link.last_accepted(), station.seq);

    // The operator gives the throttle again: now it drives.
    station.outstanding.clear();
    station.request(Command::Throttle(pct(80)));
    let out = robot.slot(&mut station);
    assert_eq!(out[0].mode, Mode::Manual);
    assert_eq!(out[0].targets.pulse_us[0], THROTTLE_80_US);
}

#[test]
fn a_speed_setpoint_given_while_killed_and_repeated_after_the_revive_does_not_start_auto() {
    let mut robot = Robot::new();
    let mut station = Station::new();
    station.request(Command::SpeedSetpoint { mm_s: 3_000 });
    for _ in 0..3 {
        let out = robot.slot(&mut station);
        assert_eq!(out[0].mode, Mode::Killed);
    }
    station.request(Command::Revive);
    for i in 0..20 {
        for out in robot.slot(&mut station) {
            assert_eq!(
                out.mode,
                Mode::Manual,
                "slot {i}: the old setpoint started AUTO"
            );
            assert_eq!(out.targets.pulse_us[0], NEUTRAL_US, "slot {i}");
        }
    }
    assert_eq!(robot.link.counters().pre_revive_requests, 19);

    // A setpoint given after the revive is acted on.
    station.outstanding.clear();
    station.request(Command::SpeedSetpoint { mm_s: 3_000 });
    let out = robot.slot(&mut station);
    assert_eq!(out[0].mode, Mode::Auto);
    assert_eq!(robot.link.counters().pre_revive_requests, 19);
}
