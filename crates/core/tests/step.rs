//! The safety behaviours of the control step, in-process: thousands of cycles per second with
//! a manual clock, no devices and no threads. Each test drives `Core::step` the way the
//! realtime loop does (commands, then a packet with its request and completion times).

use dima_core::config::Config;
use dima_core::monitor::PacketVerdict;
use dima_core::step::{CycleInputs, CycleOutputs, SensorInput};
use dima_core::{
    Command, Core, CoreState, FailsafeCause, Mode, Nanos, ReceivedCommand, ReviveRefusal,
};
use dima_groundlink::Percent;
use dima_sensorboard::nav_pvt::FLAG_GNSS_FIX_OK;
use dima_sensorboard::{GnssFrame, NavPvt, RawPacket, SensorPacket};

const MS: Nanos = 1_000_000;
const PERIOD: Nanos = 4 * MS;
/// Request to packet complete for a healthy link: just over the 3.151 ms wire time.
const ANSWER: Nanos = 3_300_000;

fn pct(v: u8) -> Percent {
    Percent::new(v).unwrap()
}

/// The car's sensors as the board would report them.
#[derive(Debug, Clone, Copy)]
struct Board {
    /// GNSS time of week of the current epoch, ms.
    itow_ms: u32,
    /// GNSS ground speed, mm/s.
    speed_mm_s: i32,
    /// GNSS heading of motion, 1e-5 degrees.
    head_deg_e5: i32,
    /// Fix type (3: 3-D).
    fix_type: u8,
    /// A counter that changes the IMU words every packet (sensor noise).
    noise: i16,
}

impl Board {
    fn new() -> Board {
        Board {
            itow_ms: 1_000,
            speed_mm_s: 0,
            head_deg_e5: 0,
            fix_type: 3,
            noise: 0,
        }
    }

    fn raw(&self) -> RawPacket {
        let pvt = NavPvt {
            itow_ms: self.itow_ms,
            fix_type: self.fix_type,
            flags: if self.fix_type == 0 {
                0
            } else {
                FLAG_GNSS_FIX_OK
            },
            g_speed_mm_s: self.speed_mm_s,
            head_mot_deg_e5: self.head_deg_e5,
            s_acc_mm_s: 150,
            ..NavPvt::default()
        };
        let p = SensorPacket {
            accel: [self.noise % 7, -3, 1_000],
            gyro: [1, self.noise % 5, -2],
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
    now: Nanos,
    board: Board,
    /// New GNSS epochs every 100 ms (false: the receiver is frozen).
    gnss_running: bool,
    /// IMU words change every packet (false: stuck).
    imu_running: bool,
    /// Time from request to packet complete (None: no answer).
    answer_after: Option<Nanos>,
}

impl Rig {
    fn new() -> Rig {
        Rig::with_config(Config::default())
    }

    fn with_config(config: Config) -> Rig {
        config.validate().expect("valid test configuration");
        let healthy_after = config.safety.revive_good_packets;
        let mut rig = Rig {
            core: Core::new(&config).expect("a valid configuration"),
            state: CoreState::new(),
            now: 1_000 * MS,
            board: Board::new(),
            gnss_running: true,
            imu_running: true,
            answer_after: Some(ANSWER),
        };
        // The board has answered long enough for a revive before the operator does anything.
        for _ in 0..healthy_after {
            rig.cycle(&[]);
        }
        rig
    }

    /// One cycle with `commands` (arrived at the cycle's time), `missed` periods skipped
    /// before it.
    fn cycle_with(&mut self, commands: &[Command], missed: u32) -> CycleOutputs {
        self.now += PERIOD * (1 + u64::from(missed));
        if self.gnss_running && self.now % (100 * MS) < PERIOD {
            self.board.itow_ms += 100;
        }
        if self.imu_running {
            self.board.noise = self.board.noise.wrapping_add(1);
        }
        let sensor = match self.answer_after {
            Some(dt) => SensorInput::Packet {
                raw: self.board.raw(),
                t_request_ns: self.now,
                t_complete_ns: self.now + dt,
            },
            None => SensorInput::NoAnswer {
                t_request_ns: self.now,
            },
        };
        let commands: Vec<ReceivedCommand> = commands
            .iter()
            .map(|&c| ReceivedCommand::new(c, self.now))
            .collect();
        let inputs = CycleInputs {
            missed_periods: missed,
            commands: &commands,
            sensor,
            stale_packets: 0,
        };
        self.core.step(&mut self.state, &inputs, self.now)
    }

    fn cycle(&mut self, commands: &[Command]) -> CycleOutputs {
        self.cycle_with(commands, 0)
    }

    /// `n` quiet cycles with a heartbeat every 25 (100 ms); the last outputs.
    fn run(&mut self, n: usize) -> CycleOutputs {
        let mut out = self.cycle(&[Command::Heartbeat]);
        for i in 1..n {
            let hb: &[Command] = if i % 25 == 0 {
                &[Command::Heartbeat]
            } else {
                &[]
            };
            out = self.cycle(hb);
        }
        out
    }

    /// Revived and driving straight at 2 m/s, heading 90°, in AUTO with those setpoints.
    fn in_auto(&mut self) {
        self.board.speed_mm_s = 2_000;
        self.board.head_deg_e5 = 9_000_000;
        assert_eq!(self.cycle(&[Command::Revive]).mode, Mode::Manual);
        self.run(50);
        let out = self.cycle(&[
            Command::SpeedSetpoint { mm_s: 2_000 },
            Command::HeadingSetpoint { deg_e5: 9_000_000 },
        ]);
        assert_eq!(out.mode, Mode::Auto);
        self.run(50);
    }
}

#[test]
fn leaving_auto_does_not_bring_back_an_old_manual_throttle() {
    let mut rig = Rig::new();
    rig.cycle(&[Command::Revive]);
    let out = rig.cycle(&[Command::Throttle(pct(80))]);
    assert_eq!(out.targets.pulse_us[0], 1_800);
    rig.in_auto();
    let out = rig.cycle(&[Command::Steering(pct(20))]);
    assert_eq!(out.mode, Mode::Manual);
    // Throttle and tail at neutral; only the steering just commanded (1250 + 5.9 * 20).
    assert_eq!(out.targets.pulse_us, [1_500, 1_368, 1_500]);
    assert_eq!(rig.run(100).targets.pulse_us, [1_500, 1_368, 1_500]);
}

#[test]
fn a_negative_or_too_fast_speed_setpoint_is_rejected_and_changes_nothing() {
    let mut rig = Rig::new();
    rig.cycle(&[Command::Revive]);
    rig.cycle(&[Command::Throttle(pct(60))]);
    for mm_s in [-1_000, 5_001] {
        let out = rig.cycle(&[Command::SpeedSetpoint { mm_s }]);
        assert_eq!(out.mode, Mode::Manual, "{mm_s}");
        assert_eq!(out.setpoints_rejected, 1);
        assert_eq!(out.targets.pulse_us, [1_600, 1_545, 1_500]);
    }
    assert_eq!(rig.state.counters.setpoints_rejected, 2);
}

#[test]
fn auto_never_drives_in_reverse() {
    let mut rig = Rig::new();
    rig.in_auto();
    // Far faster than the setpoint: the throttle goes to neutral, never below it.
    rig.board.speed_mm_s = 4_500;
    for _ in 0..1_000 {
        let out = rig.cycle(&[Command::Heartbeat]);
        assert!(out.targets.pulse_us[0] >= 1_500, "{out:?}");
    }
}

#[test]
fn frozen_gnss_trips_gnss_stale_within_its_timeout_and_the_throttle_does_not_run_away() {
    let mut rig = Rig::new();
    rig.board.speed_mm_s = 1_000; // below the 2 m/s setpoint: the integrator wants more
    rig.in_auto();
    let before = rig.cycle(&[Command::Heartbeat]).targets.pulse_us[0];
    // The board repeats its last NAV-PVT from now on.
    rig.gnss_running = false;
    let frozen_at = rig.now;
    let mut tripped = None;
    for _ in 0..500 {
        let out = rig.cycle(&[Command::Heartbeat]);
        if out.mode == Mode::Failsafe {
            tripped = Some((rig.now - frozen_at, out));
            break;
        }
        // Within the timeout the loop works on the last fix as between two epochs.
        assert!(out.targets.pulse_us[0] <= before + 100, "{out:?}");
    }
    let (after, out) = tripped.expect("FAILSAFE");
    assert_eq!(out.cause, Some(FailsafeCause::GnssStale));
    // The last fresh fix is at most one epoch (100 ms) before the freeze.
    assert!(after <= 500 * MS + PERIOD, "{after}");
    assert_eq!(out.targets.pulse_us, [1_500, 1_545, 1_500], "safe outputs");
}

#[test]
fn lost_gnss_trips_gnss_stale_in_auto_but_not_in_manual() {
    let mut rig = Rig::new();
    rig.cycle(&[Command::Revive]);
    rig.board.fix_type = 0;
    assert_eq!(
        rig.run(500).mode,
        Mode::Manual,
        "manual driving needs no GNSS"
    );
    rig.board.fix_type = 3;
    rig.in_auto();
    rig.board.fix_type = 0;
    let out = rig.run(200);
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::GnssStale))
    );
}

#[test]
fn answers_sooner_than_their_wire_time_are_stale_and_never_revive_the_robot() {
    // Every answer 5 ms late at a 4 ms period completes 1 ms after the next request.
    let mut rig = Rig::new();
    rig.state = CoreState::new(); // from start-up: no good packet ever
    rig.answer_after = Some(MS);
    for _ in 0..100 {
        let out = rig.cycle(&[Command::Revive]);
        assert_eq!(out.verdict, PacketVerdict::Stale);
        assert_eq!(out.mode, Mode::Killed);
    }
    assert_eq!(rig.state.counters.packets_ok, 0);
    assert_eq!(rig.state.counters.packets_stale, 100);
    assert_eq!(rig.state.counters.revives_refused, 100);
}

#[test]
fn late_answers_count_as_missing_and_trip_sensor_loss() {
    let mut rig = Rig::new();
    rig.cycle(&[Command::Revive]);
    rig.answer_after = Some(3_800_000); // after the 3.7 ms deadline
    let out = rig.run(25);
    assert_eq!(out.verdict, PacketVerdict::Late);
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::SensorLoss))
    );
    assert_eq!(rig.state.counters.packets_late, 25);
}

#[test]
fn a_stuck_imu_trips_failsafe_and_blocks_revive_while_it_lasts() {
    let mut rig = Rig::new();
    rig.cycle(&[Command::Revive]);
    let revived_at = rig.now;
    rig.imu_running = false;
    let mut packets = 0;
    let out = loop {
        packets += 1;
        let out = rig.cycle(&[Command::Heartbeat]);
        if out.mode != Mode::Manual {
            break out;
        }
        assert!(packets < 100);
    };
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::ImuStuck))
    );
    // The identical run started with the packet before the freeze: 50 identical in all.
    assert_eq!(packets, 49);
    // Past `safety.revive_min_interval_ms` since the revive above (the failsafe came sooner),
    // so only the stuck IMU can refuse the next one.
    let interval = u64::from(Config::default().safety.revive_min_interval_ms) * MS;
    while rig.now < revived_at + interval {
        rig.cycle(&[Command::Heartbeat]);
    }
    let out = rig.cycle(&[Command::Revive]);
    assert_eq!(
        (out.mode, out.refused),
        (Mode::Failsafe, Some(ReviveRefusal::ImuStuck))
    );
    rig.imu_running = true;
    rig.cycle(&[]);
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
}

#[test]
fn sustained_overload_trips_the_overrun_failsafe_within_a_second() {
    // 6 ms of work per 4 ms period: the clock alternates between a wake-up that skips a
    // period and one that does not, so no two overruns are ever consecutive.
    let mut rig = Rig::new();
    rig.cycle(&[Command::Revive]);
    let start = rig.now;
    let mut k = 0u32;
    let out = loop {
        k += 1;
        let out = rig.cycle_with(&[Command::Heartbeat], k % 2);
        if out.mode != Mode::Manual {
            break out;
        }
        assert!(rig.now - start < 2_000 * MS, "never tripped");
    };
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::Overrun))
    );
    assert!(rig.now - start < 1_000 * MS);
}

#[test]
fn a_failed_required_realtime_setup_keeps_the_robot_killed() {
    let mut rig = Rig::new();
    rig.state.realtime_fault = true;
    for _ in 0..10 {
        let out = rig.cycle(&[Command::Revive, Command::Throttle(pct(90))]);
        assert_eq!(out.mode, Mode::Killed);
        assert_eq!(out.refused, Some(ReviveRefusal::RealtimeSetup));
        assert_eq!(out.targets.pulse_us, [1_500, 1_545, 1_500]);
    }
}

#[test]
fn the_same_inputs_give_the_same_outputs_bit_for_bit() {
    let run = || {
        let mut rig = Rig::new();
        let mut outs = Vec::new();
        rig.cycle(&[Command::Revive]);
        rig.board.speed_mm_s = 1_500;
        rig.board.head_deg_e5 = 4_500_000;
        rig.cycle(&[
            Command::SpeedSetpoint { mm_s: 2_500 },
            Command::HeadingSetpoint { deg_e5: 12_000_000 },
        ]);
        for i in 0..5_000u32 {
            let hb: &[Command] = if i % 25 == 0 {
                &[Command::Heartbeat]
            } else {
                &[]
            };
            outs.push(rig.cycle(hb));
        }
        outs
    };
    let (a, b) = (run(), run());
    assert_eq!(a, b);
    assert!(
        a.iter().any(|o| o.action.steering != 0.0),
        "the controller ran"
    );
}
