//! Crafted sensor and command sequences under which the robot must not move, driven through
//! `Core::step` with a manual clock: a gyro carrying the heading long after its last GNSS
//! correction, a GNSS time of week that steps backwards, a negative ground speed, a mode
//! round trip inside one cycle, one IMU die frozen while the other stays alive, and commands
//! that reach the step long after they arrived.

use dima_core::config::{Config, FenceCircle, FenceConfig};
use dima_core::step::{CycleInputs, CycleOutputs, SensorInput};
use dima_core::{
    Command, Core, CoreState, FailsafeCause, Mode, Nanos, ReceivedCommand, ReviveRefusal,
};
use dima_groundlink::Percent;
use dima_sensorboard::nav_pvt::FLAG_GNSS_FIX_OK;
use dima_sensorboard::{GnssFrame, NavPvt, RawPacket, SensorPacket};

const MS: Nanos = 1_000_000;
const PERIOD: Nanos = 4 * MS;
/// Cycles per GNSS epoch (10 Hz at 250 Hz).
const EPOCH_CYCLES: u64 = 25;
/// Request to packet complete for a healthy link: just over the 3.151 ms wire time.
const ANSWER: Nanos = 3_300_000;
/// Gyroscope counts per °/s at ±2000 °/s.
const GYRO_COUNTS_PER_DPS: f32 = 16.4;

fn pct(v: u8) -> Percent {
    Percent::new(v).unwrap()
}

/// The board's words: GNSS, and each IMU die's base words plus, while it is alive, a little
/// noise that changes every packet.
#[derive(Debug, Clone, Copy)]
struct Board {
    itow_ms: u32,
    speed_mm_s: i32,
    head_deg_e5: i32,
    accel: [i16; 3],
    gyro: [i16; 3],
    accel_alive: bool,
    gyro_alive: bool,
    packets: u32,
    lat_deg_e7: i32,
    lon_deg_e7: i32,
}

impl Board {
    fn new() -> Board {
        Board {
            itow_ms: 1_000,
            speed_mm_s: 0,
            head_deg_e5: 0,
            accel: [0, 0, 1_020],
            gyro: [0, 0, 0],
            accel_alive: true,
            gyro_alive: true,
            packets: 0,
            lat_deg_e7: 480_000_000,
            lon_deg_e7: 110_000_000,
        }
    }

    /// The next packet: noise on the X and Y words of each live die (the gyro's Z word, the
    /// yaw rate, stays exactly what the test set).
    fn next_raw(&mut self) -> RawPacket {
        self.packets = self.packets.wrapping_add(1);
        let n = self.packets as i16;
        let mut accel = self.accel;
        let mut gyro = self.gyro;
        if self.accel_alive {
            accel[0] += n % 7 - 3;
            accel[1] += n % 3 - 1;
        }
        if self.gyro_alive {
            gyro[0] += n % 5 - 2;
            gyro[1] += n % 3 - 1;
        }
        let pvt = NavPvt {
            itow_ms: self.itow_ms,
            fix_type: 3,
            flags: FLAG_GNSS_FIX_OK,
            g_speed_mm_s: self.speed_mm_s,
            head_mot_deg_e5: self.head_deg_e5,
            s_acc_mm_s: 150,
            lat_deg_e7: self.lat_deg_e7,
            lon_deg_e7: self.lon_deg_e7,
            ..NavPvt::default()
        };
        let p = SensorPacket {
            accel,
            gyro,
            gnss: GnssFrame::from_nav_pvt(&pvt),
            ..SensorPacket::default()
        };
        RawPacket::new(p.encode()).expect("a valid packet")
    }
}

/// The loop around the step: a manual clock and the board.
struct Rig {
    core: Core,
    state: CoreState,
    config: Config,
    now: Nanos,
    cycles: u64,
    board: Board,
    /// A new GNSS epoch (iTOW + 100 ms) every 100 ms; false: the test sets the iTOW.
    gnss_running: bool,
    /// The board answers each request in time; false: no answer.
    answering: bool,
}

impl Rig {
    fn new() -> Rig {
        Rig::with_config(Config::default())
    }

    fn with_config(config: Config) -> Rig {
        config.validate().expect("valid test configuration");
        let mut rig = Rig {
            core: Core::new(&config).expect("a valid configuration"),
            state: CoreState::new(),
            config,
            now: 1_000 * MS,
            cycles: 0,
            board: Board::new(),
            gnss_running: true,
            answering: true,
        };
        for _ in 0..rig.config.safety.revive_good_packets {
            rig.cycle(&[]);
        }
        rig
    }

    /// One cycle with `commands`, arrived at the cycle's time.
    fn cycle(&mut self, commands: &[Command]) -> CycleOutputs {
        let now = self.next_cycle_ns();
        let received: Vec<ReceivedCommand> = commands
            .iter()
            .map(|&c| ReceivedCommand::new(c, now))
            .collect();
        self.cycle_received(&received)
    }

    /// The time of the next cycle.
    fn next_cycle_ns(&self) -> Nanos {
        self.now + PERIOD
    }

    /// One cycle with `commands` and their own arrival times.
    fn cycle_received(&mut self, commands: &[ReceivedCommand]) -> CycleOutputs {
        self.now += PERIOD;
        self.cycles += 1;
        if self.gnss_running && self.epoch_starts() {
            self.board.itow_ms += 100;
        }
        let sensor = if self.answering {
            SensorInput::Packet {
                raw: self.board.next_raw(),
                t_request_ns: self.now,
                t_complete_ns: self.now + ANSWER,
            }
        } else {
            SensorInput::NoAnswer {
                t_request_ns: self.now,
            }
        };
        let inputs = CycleInputs {
            missed_periods: 0,
            commands,
            sensor,
            stale_packets: 0,
        };
        self.core.step(&mut self.state, &inputs, self.now)
    }

    /// The loop stalls: the next cycle comes `ns` later than its period would bring it.
    fn stall(&mut self, ns: Nanos) {
        self.now += ns;
    }

    /// Cycles without commands while the mode stays `mode` (at most 10 s); the time and outputs
    /// of the first cycle in another mode.
    fn silent_while(&mut self, mode: Mode) -> (Nanos, CycleOutputs) {
        for _ in 0..2_500 {
            let out = self.cycle(&[]);
            if out.mode != mode {
                return (self.now, out);
            }
        }
        panic!("still {mode:?} after 10 s without commands");
    }

    fn comms_timeout_ns(&self) -> Nanos {
        u64::from(self.config.safety.comms_timeout_ms) * MS
    }

    /// This cycle is the first of a GNSS epoch.
    fn epoch_starts(&self) -> bool {
        self.cycles.is_multiple_of(EPOCH_CYCLES)
    }

    /// A cycle with a heartbeat every 100 ms (well within the comms timeout).
    fn quiet_cycle(&mut self) -> CycleOutputs {
        let hb: &[Command] = if self.epoch_starts() {
            &[Command::Heartbeat]
        } else {
            &[]
        };
        self.cycle(hb)
    }

    /// `n` quiet cycles; the last outputs.
    fn run(&mut self, n: usize) -> CycleOutputs {
        let mut out = self.cycle(&[Command::Heartbeat]);
        for _ in 1..n {
            out = self.quiet_cycle();
        }
        out
    }

    /// Revived and in AUTO with `speed_mm_s` and heading 90°, driving at 2 m/s on 90°.
    fn in_auto(&mut self, speed_mm_s: i32) {
        self.board.speed_mm_s = 2_000;
        self.board.head_deg_e5 = 9_000_000;
        assert_eq!(self.cycle(&[Command::Revive]).mode, Mode::Manual);
        self.run(50);
        let out = self.cycle(&[
            Command::SpeedSetpoint { mm_s: speed_mm_s },
            Command::HeadingSetpoint { deg_e5: 9_000_000 },
        ]);
        assert_eq!(out.mode, Mode::Auto);
        let out = self.run(100);
        assert_eq!(out.mode, Mode::Auto, "{out:?}");
    }

    fn neutral_us(&self) -> [u16; 3] {
        let ch = &self.config.channels;
        [
            ch.throttle.neutral_us,
            ch.steering.neutral_us,
            ch.tail.neutral_us,
        ]
    }
}

#[test]
fn below_the_heading_speed_the_gyro_alone_does_not_steer_past_the_gnss_timeout() {
    let mut rig = Rig::new();
    // An unlearnt gyro bias of 2 °/s (the car never stood still).
    rig.board.gyro[2] = (2.0 * GYRO_COUNTS_PER_DPS).round() as i16;
    rig.in_auto(2_000);
    // Too slow for a GNSS heading of motion; fixes keep coming (the GNSS stays fresh).
    rig.board.speed_mm_s = rig.config.estimator.min_heading_speed_mm_s - 200;
    let slowed_at = rig.now;
    let timeout = u64::from(rig.config.safety.gnss_timeout_ms) * MS;
    let neutral = rig.neutral_us()[1];
    // The steering pulse furthest from neutral, and the last heading, past the timeout.
    let mut worst: Option<(u16, Nanos)> = None;
    let mut heading_past_timeout = None;
    for _ in 0..5_000 {
        let out = rig.quiet_cycle();
        assert_eq!(out.mode, Mode::Auto, "{out:?}");
        // The last GNSS correction is at most one epoch before the slow-down.
        let since = rig.now - slowed_at;
        if since > timeout + 100 * MS + PERIOD {
            let us = out.targets.pulse_us[1];
            if worst.is_none_or(|(w, _)| us.abs_diff(neutral) > w.abs_diff(neutral)) {
                worst = Some((us, since));
            }
            heading_past_timeout = heading_past_timeout.or(out.estimate.heading_deg);
        }
    }
    let (worst_us, at) = worst.expect("cycles past the timeout");
    assert!(
        worst_us.abs_diff(neutral) <= 5 && heading_past_timeout.is_none(),
        "steering {worst_us} µs (neutral {neutral}) {} ms after the slow-down; heading past \
         the GNSS timeout: {heading_past_timeout:?}",
        at / MS
    );
    // Back above the heading speed: the next GNSS heading is taken afresh.
    rig.board.speed_mm_s = 2_000;
    let out = rig.run(50);
    let heading = out.estimate.heading_deg.expect("a GNSS heading again");
    assert!((heading.value - 90.0).abs() < 2.0, "{heading:?}");
}

#[test]
fn a_gnss_time_of_week_stepping_back_and_forth_goes_stale_in_auto() {
    let mut rig = Rig::new();
    rig.in_auto(2_000);
    rig.gnss_running = false;
    let fixes_before = rig.state.counters.gnss_fixes;
    let started = rig.now;
    let high = rig.board.itow_ms;
    let low = high - 100;
    let timeout = u64::from(rig.config.safety.gnss_timeout_ms) * MS;
    let mut tripped = None;
    for _ in 0..2_500 {
        if rig.epoch_starts() {
            rig.board.itow_ms = if rig.board.itow_ms == high { low } else { high };
        }
        let out = rig.quiet_cycle();
        if out.mode != Mode::Auto {
            tripped = Some((rig.now - started, out));
            break;
        }
    }
    let fixes = rig.state.counters.gnss_fixes - fixes_before;
    let (after, out) = tripped.unwrap_or_else(|| panic!("still AUTO after 10 s, {fixes} fixes"));
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::GnssStale))
    );
    assert!(after <= timeout + PERIOD, "{} ms", after / MS);
    assert_eq!(fixes, 0, "no epoch of the alternation is fresh");
    assert!(
        rig.state.counters.gnss_backwards >= 2,
        "{:?}",
        rig.state.counters
    );
}

#[test]
fn a_negative_ground_speed_never_drives_forward() {
    let mut config = Config::default();
    config.estimator.accel_bridging = false;
    let mut rig = Rig::with_config(config);
    rig.in_auto(2_000);
    let out = rig.cycle(&[Command::SpeedSetpoint { mm_s: 0 }]);
    assert_eq!(out.mode, Mode::Auto);
    rig.board.speed_mm_s = -3_000;
    let neutral = rig.neutral_us()[0];
    let (mut most_us, mut least_speed) = (0u16, f32::INFINITY);
    for _ in 0..500 {
        let out = rig.quiet_cycle();
        most_us = most_us.max(out.targets.pulse_us[0]);
        if let Some(speed) = out.estimate.speed_mm_s {
            least_speed = least_speed.min(speed.value);
        }
    }
    assert!(
        most_us <= neutral && least_speed >= 0.0,
        "setpoint 0, gSpeed -3000: throttle up to {most_us} µs (neutral {neutral}), speed \
         estimate down to {least_speed} mm/s"
    );
}

#[test]
fn auto_to_manual_to_auto_in_one_cycle_resets_the_controllers_and_the_held_action() {
    let mut rig = Rig::new();
    rig.in_auto(5_000);
    // Far below the setpoint: the speed loop drives hard.
    rig.board.speed_mm_s = 1_000;
    let out = rig.run(250);
    let neutral = rig.neutral_us()[0];
    assert!(out.targets.pulse_us[0] > neutral + 200, "{:?}", out.targets);
    // Manual, then AUTO again with setpoint 0, in one cycle whose packet is missing, and a few
    // more without packets (fewer than trip the sensor-loss failsafe): the held action.
    rig.answering = false;
    let out = rig.cycle(&[
        Command::Throttle(pct(50)),
        Command::SpeedSetpoint { mm_s: 0 },
    ]);
    assert_eq!(out.mode, Mode::Auto);
    let mut throttle = vec![out.targets.pulse_us[0]];
    for _ in 0..10 {
        throttle.push(rig.quiet_cycle().targets.pulse_us[0]);
    }
    rig.answering = true;
    for _ in 0..50 {
        let out = rig.quiet_cycle();
        assert_eq!(out.mode, Mode::Auto);
        throttle.push(out.targets.pulse_us[0]);
    }
    assert!(
        throttle.iter().all(|&us| us <= neutral + 10),
        "throttle after the round trip (setpoint 0): {throttle:?}"
    );
}

/// Runs AUTO with one die frozen and returns the packets until FAILSAFE and its outputs.
fn freeze_one_die(gyro_frozen: bool) -> (u32, CycleOutputs) {
    let mut rig = Rig::new();
    rig.in_auto(2_000);
    if gyro_frozen {
        // A gyro frozen mid-turn at 40 °/s, the accelerometer still noisy.
        rig.board.gyro = [-3, 7, (40.0 * GYRO_COUNTS_PER_DPS) as i16];
        rig.board.gyro_alive = false;
    } else {
        rig.board.accel = [55, -12, 990];
        rig.board.accel_alive = false;
    }
    let limit = rig.config.safety.imu_stuck_packets;
    for packets in 1..=2_500 {
        let out = rig.quiet_cycle();
        if out.mode != Mode::Auto {
            return (packets, out);
        }
    }
    panic!("still AUTO after 10 s with a frozen die (stuck limit {limit} packets)");
}

#[test]
fn a_frozen_gyro_beside_a_live_accelerometer_is_a_stuck_imu() {
    let (packets, out) = freeze_one_die(true);
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::ImuStuck))
    );
    assert!(
        packets <= Config::default().safety.imu_stuck_packets,
        "{packets}"
    );
}

#[test]
fn a_frozen_accelerometer_beside_a_live_gyro_is_a_stuck_imu() {
    let (packets, out) = freeze_one_die(false);
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::ImuStuck))
    );
    assert!(
        packets <= Config::default().safety.imu_stuck_packets,
        "{packets}"
    );
}

#[test]
fn a_command_that_waited_keeps_the_link_only_from_its_arrival() {
    let mut rig = Rig::new();
    let timeout = rig.comms_timeout_ns();
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
    // A heartbeat arrives 50 ms after the revive, then the radio goes silent; the heartbeat
    // reaches the step only 750 ms after it arrived (the reader or the ring fell behind).
    let arrival = rig.now + 50 * MS;
    while rig.next_cycle_ns() < arrival + 750 * MS {
        assert_eq!(rig.cycle(&[]).mode, Mode::Manual);
    }
    let out = rig.cycle_received(&[ReceivedCommand::new(Command::Heartbeat, arrival)]);
    assert_eq!(out.mode, Mode::Manual);
    assert_eq!(rig.state.safety.last_link_ns, Some(arrival));
    // The link ends one comms timeout after the heartbeat arrived, not after the step took it.
    let (at, out) = rig.silent_while(Mode::Manual);
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::CommsLoss))
    );
    assert!(
        at > arrival + timeout && at <= arrival + timeout + PERIOD,
        "comms loss {} ms after the heartbeat arrived (timeout {} ms)",
        (at - arrival) / MS,
        timeout / MS
    );
}

#[test]
fn commands_older_than_the_comms_timeout_do_not_act_but_a_kill_does() {
    let full = pct(100);

    // The link is alive (a heartbeat in the same cycle), but a throttle that waited longer
    // than the comms timeout is no instruction the operator still stands by: counted, not
    // acted on. One exactly as old as the timeout still acts.
    let mut rig = Rig::new();
    let timeout = rig.comms_timeout_ns();
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
    rig.run(300);
    let neutral = rig.neutral_us()[0];
    let now = rig.next_cycle_ns();
    let out = rig.cycle_received(&[
        ReceivedCommand::new(Command::Throttle(full), now - timeout - 1),
        ReceivedCommand::new(Command::Heartbeat, now),
    ]);
    assert_eq!((out.mode, out.targets.pulse_us[0]), (Mode::Manual, neutral));
    assert_eq!(rig.state.safety.setpoints.throttle, None);
    assert_eq!(rig.state.counters.commands_stale, 1);
    let now = rig.next_cycle_ns();
    let out = rig.cycle_received(&[ReceivedCommand::new(Command::Throttle(full), now - timeout)]);
    assert_eq!(rig.state.safety.setpoints.throttle, Some(full));
    assert!(out.targets.pulse_us[0] > neutral, "{:?}", out.targets);
    assert_eq!(rig.state.counters.commands_stale, 1);

    // The loop stalls for longer than the comms timeout after the revive; a throttle that
    // arrived just after the revive reaches the step only then. It is no link activity: the
    // link was lost, and nothing drives.
    let mut rig = Rig::new();
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
    let arrival = rig.now + MS;
    rig.stall(timeout + 200 * MS);
    let out = rig.cycle_received(&[ReceivedCommand::new(Command::Throttle(full), arrival)]);
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::CommsLoss))
    );
    assert_eq!(out.targets, rig.core.safe_targets());
    assert_eq!(rig.state.counters.commands_stale, 1);

    // A revive that waited as long does not revive (the sensor link is healthy and nothing
    // else blocks a revive, so only its age can refuse it).
    let mut rig = Rig::new();
    let now = rig.next_cycle_ns();
    let out = rig.cycle_received(&[ReceivedCommand::new(Command::Revive, now - timeout - MS)]);
    assert_eq!((out.mode, out.refused), (Mode::Killed, None));
    assert_eq!(rig.state.counters.commands_stale, 1);
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);

    // A kill is honoured however old.
    let mut rig = Rig::new();
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
    rig.run(300);
    let now = rig.next_cycle_ns();
    let out = rig.cycle_received(&[
        ReceivedCommand::new(Command::Kill, now - timeout - 200 * MS),
        ReceivedCommand::new(Command::Heartbeat, now),
    ]);
    assert_eq!((out.mode, out.cause), (Mode::Killed, None));
    assert_eq!(rig.state.counters.commands_stale, 0);
}

#[test]
fn fresh_commands_act_and_keep_the_link_from_their_arrival() {
    let mut rig = Rig::new();
    let timeout = rig.comms_timeout_ns();
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
    let neutral = rig.neutral_us()[0];
    for _ in 0..5 {
        rig.cycle(&[]);
    }
    // A throttle that arrived 10 ms before the cycle that takes it (after the revive).
    let arrival = rig.next_cycle_ns() - 10 * MS;
    let out = rig.cycle_received(&[ReceivedCommand::new(Command::Throttle(pct(100)), arrival)]);
    assert_eq!(out.mode, Mode::Manual);
    assert!(out.targets.pulse_us[0] > neutral, "{:?}", out.targets);
    assert_eq!(rig.state.safety.last_link_ns, Some(arrival));
    let (at, out) = rig.silent_while(Mode::Manual);
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::CommsLoss))
    );
    assert!(
        at > arrival + timeout && at <= arrival + timeout + PERIOD,
        "comms loss {} ms after the throttle arrived (timeout {} ms)",
        (at - arrival) / MS,
        timeout / MS
    );
}

/// The car rolls onto its side (the accelerometer reads 1 g along its Y axis) in `mode` and
/// stays there: the cycles it took to leave `mode`, and the outputs then.
fn roll_onto_the_side(rig: &mut Rig, mode: Mode) -> (u64, CycleOutputs) {
    rig.board.accel = [10, 1_020, 15];
    for cycles in 1..=2_500 {
        let out = rig.quiet_cycle();
        if out.mode != mode {
            return (cycles, out);
        }
    }
    panic!("still {mode:?} after 10 s on its side");
}

#[test]
fn a_car_on_its_side_trips_rollover_in_manual_and_auto_and_cannot_be_revived() {
    let hold_cycles = u64::from(Config::default().navigation.rollover_ms) * MS / PERIOD;
    for auto in [false, true] {
        let mut rig = Rig::new();
        if auto {
            rig.in_auto(2_000);
        } else {
            assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
            rig.cycle(&[Command::Throttle(pct(80))]);
        }
        let mode = if auto { Mode::Auto } else { Mode::Manual };
        let (cycles, out) = roll_onto_the_side(&mut rig, mode);
        assert_eq!(
            (out.mode, out.cause),
            (Mode::Failsafe, Some(FailsafeCause::Rollover)),
            "auto {auto}"
        );
        assert_eq!(out.targets, rig.core.safe_targets(), "auto {auto}");
        // Not a packet before the hold time, and within a cycle of it.
        assert!(
            (hold_cycles..=hold_cycles + 1).contains(&cycles),
            "auto {auto}: tripped after {cycles} cycles, hold {hold_cycles}"
        );
        // Still on its side: a revive is refused.
        rig.run(100);
        let out = rig.cycle(&[Command::Revive]);
        assert_eq!(
            (out.mode, out.refused),
            (Mode::Failsafe, Some(ReviveRefusal::RolledOver))
        );
        // Back on its wheels: the revive goes through.
        rig.board.accel = [0, 0, 1_020];
        rig.run(10);
        assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
    }
}

#[test]
fn a_bump_that_tilts_the_reading_for_a_few_packets_is_not_a_rollover() {
    let mut rig = Rig::new();
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
    for _ in 0..20 {
        rig.board.accel = [300, 1_500, -600];
        assert_eq!(rig.run(10).mode, Mode::Manual);
        rig.board.accel = [0, 0, 1_020];
        assert_eq!(rig.run(50).mode, Mode::Manual);
    }
}

/// The default configuration with `[navigation.fence]` set by `fence`.
fn fenced(fence: impl FnOnce(&mut FenceConfig)) -> Rig {
    let mut config = Config::default();
    fence(&mut config.navigation.fence);
    Rig::with_config(config)
}

/// Cycles without commands but heartbeats while the mode stays `mode` (at most 10 s): the
/// cycles it took, and the outputs of the first cycle in another mode.
fn quiet_while(rig: &mut Rig, mode: Mode) -> (u64, CycleOutputs) {
    for cycles in 1..=2_500 {
        let out = rig.quiet_cycle();
        if out.mode != mode {
            return (cycles, out);
        }
    }
    panic!("still {mode:?} after 10 s");
}

#[test]
fn leaving_the_fence_trips_geofence_in_manual_and_auto_within_a_gnss_period() {
    for auto in [false, true] {
        // 50 m from the revive point.
        let mut rig = fenced(|f| f.max_distance_m = Some(50.0));
        let mode = if auto {
            rig.in_auto(2_000);
            Mode::Auto
        } else {
            assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
            rig.cycle(&[Command::Throttle(pct(80))]);
            Mode::Manual
        };
        // 44 m north: still inside.
        rig.board.lat_deg_e7 += 4_000;
        assert_eq!(rig.run(100).mode, mode, "auto {auto}");
        // 56 m north: outside from the next fix on.
        rig.board.lat_deg_e7 += 1_000;
        let (cycles, out) = quiet_while(&mut rig, mode);
        assert_eq!(
            (out.mode, out.cause),
            (Mode::Failsafe, Some(FailsafeCause::Geofence)),
            "auto {auto}"
        );
        assert_eq!(out.targets, rig.core.safe_targets());
        assert!(cycles <= EPOCH_CYCLES + 1, "auto {auto}: {cycles} cycles");
        // A revive out there is a new revive point (no inclusion area is given): it is taken.
        rig.run(100);
        assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
        assert_eq!(rig.run(100).mode, Mode::Manual);
    }
}

#[test]
fn a_revive_outside_the_inclusion_areas_is_refused_inside_it_is_taken() {
    // A circle of 100 m round a point 200 m south of the car.
    let mut rig = fenced(|f| {
        f.circles = vec![FenceCircle {
            lat_deg: 47.998,
            lon_deg: 11.0,
            radius_m: 100.0,
        }]
    });
    rig.run(30);
    let out = rig.cycle(&[Command::Revive]);
    assert_eq!(
        (out.mode, out.refused),
        (Mode::Killed, Some(ReviveRefusal::OutsideFence))
    );
    // Carried into the circle.
    rig.board.lat_deg_e7 -= 15_000;
    rig.run(100);
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
    assert_eq!(rig.run(100).mode, Mode::Manual);
    // Driven out of it: FAILSAFE.
    rig.board.lat_deg_e7 += 10_000;
    let (_, out) = quiet_while(&mut rig, Mode::Manual);
    assert_eq!(out.cause, Some(FailsafeCause::Geofence));
}

#[test]
fn with_a_fence_stale_gnss_trips_in_manual_too_without_one_it_does_not() {
    for fence in [false, true] {
        let mut rig = if fence {
            fenced(|f| f.max_distance_m = Some(50.0))
        } else {
            Rig::new()
        };
        assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
        rig.run(50);
        rig.gnss_running = false;
        if fence {
            let (cycles, out) = quiet_while(&mut rig, Mode::Manual);
            assert_eq!(out.cause, Some(FailsafeCause::GnssStale));
            let timeout_cycles = u64::from(rig.config.safety.gnss_timeout_ms) * MS / PERIOD;
            assert!(cycles <= timeout_cycles + 1, "{cycles}");
            // No fresh fix: the fence cannot be judged, a revive is refused.
            rig.run(100);
            let out = rig.cycle(&[Command::Revive]);
            assert_eq!(out.refused, Some(ReviveRefusal::OutsideFence));
        } else {
            assert_eq!(rig.run(1_000).mode, Mode::Manual);
        }
    }
}

#[test]
fn without_a_fence_the_car_drives_anywhere() {
    let mut rig = Rig::new();
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
    for _ in 0..20 {
        rig.board.lat_deg_e7 += 100_000;
        rig.board.lon_deg_e7 -= 100_000;
        assert_eq!(rig.run(50).mode, Mode::Manual);
    }
}
