//! AUTO's `MISSION` sub-mode through `Core::step`: with a mission loaded, AUTO entered by a
//! speed setpoint follows it; a kill, a failsafe or a manual command stops it and forgets its
//! progress.

use dima_core::config::Config;
use dima_core::mission::{parse_plan, parse_plan_file, AutoSource, LocalPoint, Navigation};
use dima_core::step::{CycleInputs, CycleOutputs, SensorInput};
use dima_core::FailsafeCause;
use dima_core::{Command, Core, CoreState, Mode, Nanos, ReceivedCommand};
use dima_groundlink::Percent;
use dima_sensorboard::nav_pvt::FLAG_GNSS_FIX_OK;
use dima_sensorboard::{GnssFrame, NavPvt, RawPacket, SensorPacket};

const MS: Nanos = 1_000_000;
const PERIOD: Nanos = 4 * MS;
const SQUARE: &str = include_str!("fixtures/square-40m.plan");
const SQUARE_FENCED: &str = include_str!("fixtures/square-40m-fenced.plan");

/// The step with a board whose GNSS puts the car at `at` (local frame of the mission).
struct Rig {
    core: Core,
    state: CoreState,
    now: Nanos,
    itow_ms: u32,
    at: LocalPoint,
    speed_mm_s: i32,
    head_deg_e5: i32,
    noise: i16,
}

impl Rig {
    fn new(with_mission: bool) -> Rig {
        let config = Config::default();
        let mut core = Core::new(&config).unwrap();
        if with_mission {
            core.set_mission(&parse_plan(SQUARE).unwrap());
        }
        Rig::settled(core, &config)
    }

    /// With the mission and the fence of the square plan with a `geoFence` polygon 10 m
    /// outside the square.
    fn fenced() -> Rig {
        let config = Config::default();
        let mut core = Core::new(&config).unwrap();
        let plan = parse_plan_file(SQUARE_FENCED).unwrap();
        core.set_navigation(&Navigation::with_plan(&config.navigation, plan).unwrap());
        Rig::settled(core, &config)
    }

    /// After enough good packets for a revive.
    fn settled(core: Core, config: &Config) -> Rig {
        let mut rig = Rig {
            core,
            state: CoreState::new(),
            now: 1_000 * MS,
            itow_ms: 1_000,
            at: LocalPoint::default(),
            speed_mm_s: 2_000,
            head_deg_e5: 0,
            noise: 0,
        };
        for _ in 0..config.safety.revive_good_packets {
            rig.cycle(&[]);
        }
        rig
    }

    fn raw(&self) -> RawPacket {
        let mission = parse_plan(SQUARE).unwrap();
        let frame = dima_core::mission::Follower::new(&mission, Default::default())
            .frame()
            .to_owned();
        let (lat, lon) = frame.to_geodetic(self.at);
        let pvt = NavPvt {
            itow_ms: self.itow_ms,
            fix_type: 3,
            flags: FLAG_GNSS_FIX_OK,
            g_speed_mm_s: self.speed_mm_s,
            head_mot_deg_e5: self.head_deg_e5,
            lat_deg_e7: (lat * 1e7).round() as i32,
            lon_deg_e7: (lon * 1e7).round() as i32,
            s_acc_mm_s: 150,
            ..NavPvt::default()
        };
        let p = SensorPacket {
            accel: [self.noise % 7, -3, 1_000],
            gyro: [1, self.noise % 5, -2],
            gnss: GnssFrame::from_nav_pvt(&pvt),
            ..SensorPacket::default()
        };
        RawPacket::new(p.encode()).unwrap()
    }

    fn cycle(&mut self, commands: &[Command]) -> CycleOutputs {
        self.now += PERIOD;
        if self.now % (100 * MS) < PERIOD {
            self.itow_ms += 100;
        }
        self.noise = self.noise.wrapping_add(1);
        let commands: Vec<ReceivedCommand> = commands
            .iter()
            .map(|&c| ReceivedCommand::new(c, self.now))
            .collect();
        let inputs = CycleInputs {
            missed_periods: 0,
            commands: &commands,
            sensor: SensorInput::Packet {
                raw: self.raw(),
                t_request_ns: self.now,
                t_complete_ns: self.now + 3_300_000,
            },
            stale_packets: 0,
        };
        self.core.step(&mut self.state, &inputs, self.now)
    }

    /// `n` cycles with a heartbeat each; the last outputs.
    fn run(&mut self, n: usize) -> CycleOutputs {
        let mut out = self.cycle(&[Command::Heartbeat]);
        for _ in 1..n {
            out = self.cycle(&[Command::Heartbeat]);
        }
        out
    }

    /// Revive, then AUTO by a speed setpoint.
    fn enter_auto(&mut self) -> CycleOutputs {
        assert_eq!(self.cycle(&[Command::Revive]).mode, Mode::Manual);
        let out = self.cycle(&[Command::SpeedSetpoint { mm_s: 3_000 }]);
        assert_eq!(out.mode, Mode::Auto);
        out
    }
}

#[test]
fn without_a_mission_auto_holds_the_operators_setpoints() {
    let mut rig = Rig::new(false);
    let out = rig.enter_auto();
    assert_eq!(out.auto_source, Some(AutoSource::Setpoints));
    assert_eq!(out.mission, None);
}

#[test]
fn with_a_mission_auto_follows_it_and_a_kill_forgets_its_progress() {
    let mut rig = Rig::new(true);
    let out = rig.enter_auto();
    assert_eq!(out.auto_source, Some(AutoSource::Mission));
    // At the first waypoint: it is reached, the second (40 m north) is current.
    let status = out.mission.expect("a mission status");
    assert_eq!(status.waypoint, 1);
    assert!(
        status.heading_deg < 1.0 || status.heading_deg > 359.0,
        "{status:?}"
    );
    assert!((status.speed_m_s - 3.0).abs() < 1e-3, "{status:?}");
    // Near the second corner, right of the track: the third waypoint is current.
    rig.at = LocalPoint {
        north_m: 39.5,
        east_m: 0.5,
    };
    let status = rig.run(30).mission.unwrap();
    assert_eq!(status.waypoint, 2, "{status:?}");
    assert!(
        status.heading_deg > 45.0 && status.heading_deg < 135.0,
        "{status:?}"
    );
    // A kill stops it...
    let out = rig.cycle(&[Command::Kill]);
    assert_eq!(
        (out.mode, out.auto_source, out.mission),
        (Mode::Killed, None, None)
    );
    assert_eq!(rig.state.mission, Default::default());
    // ...and the next AUTO (after the revive interval) starts again from the first waypoint,
    // 40 m behind.
    rig.run(100);
    let status = rig.enter_auto().mission.unwrap();
    assert_eq!(status.waypoint, 0, "{status:?}");
    assert!(
        status.heading_deg > 135.0 && status.heading_deg < 225.0,
        "{status:?}"
    );
}

#[test]
fn a_manual_command_stops_the_mission() {
    let mut rig = Rig::new(true);
    rig.enter_auto();
    rig.run(10);
    let out = rig.cycle(&[Command::Steering(Percent::new(50).unwrap())]);
    assert_eq!(
        (out.mode, out.auto_source, out.mission),
        (Mode::Manual, None, None)
    );
    assert!(!rig.state.mission.active);
}

#[test]
fn a_failsafe_stops_the_mission() {
    let mut rig = Rig::new(true);
    rig.enter_auto();
    // No heartbeat: the link times out.
    let mut out = rig.cycle(&[]);
    for _ in 0..500 {
        out = rig.cycle(&[]);
        if out.mode == Mode::Failsafe {
            break;
        }
    }
    assert_eq!(
        (out.mode, out.auto_source, out.mission),
        (Mode::Failsafe, None, None)
    );
    assert!(!rig.state.mission.active);
}

#[test]
fn the_plans_fence_trips_geofence_within_a_gnss_period_and_refuses_a_revive_outside() {
    let mut rig = Rig::fenced();
    let out = rig.enter_auto();
    assert_eq!(out.auto_source, Some(AutoSource::Mission));
    // 9 m beyond the square's north side: inside the polygon (10 m margin).
    rig.at = LocalPoint {
        north_m: 49.0,
        east_m: 20.0,
    };
    assert_eq!(rig.run(50).mode, Mode::Auto);
    // 12 m beyond it: outside. FAILSAFE within one GNSS period (100 ms) and one cycle.
    rig.at.north_m = 52.0;
    let mut cycles = 0;
    let out = loop {
        let out = rig.cycle(&[Command::Heartbeat]);
        cycles += 1;
        if out.mode != Mode::Auto || cycles > 100 {
            break out;
        }
    };
    assert_eq!(
        (out.mode, out.cause),
        (Mode::Failsafe, Some(FailsafeCause::Geofence))
    );
    assert!(
        cycles as Nanos * PERIOD <= 100 * MS + PERIOD,
        "{cycles} cycles"
    );
    assert_eq!(out.mission, None);
    // No revive while outside; back inside, the revive is accepted.
    rig.run(300);
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Failsafe);
    rig.at.north_m = 20.0;
    rig.run(30);
    assert_eq!(rig.cycle(&[Command::Revive]).mode, Mode::Manual);
}
