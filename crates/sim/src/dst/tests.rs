//! Tests of the simulator itself: determinism, the trace, and the invariants' teeth on
//! hand-made cycles.

use std::path::PathBuf;

use dima_core::config::Config;
use dima_core::step::CycleOutputs;
use dima_core::{Command, Core, CoreState, Mode};
use dima_log::schema;

use dima_core::config::{FenceCircle, FenceConfig};
use dima_core::mission::{AutoSource, MissionStatus};
use dima_sensorboard::GnssFrame;

use super::intent::Intent;
use super::invariants::{Applied, Checker, CycleView, Invariant};
use super::navigation::{start_offset, Navigation};
use super::operator::Action;
use super::runner::{Simulation, START_NS};
use super::{run_seed, run_traced};
use dima_log::LoggedRun;
use dima_tools::logtools::replay::replay;

/// A fresh directory for one test.
fn test_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dima-dst-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The `/dima/cycle` messages of a trace, with their log times.
fn cycle_messages(path: &std::path::Path) -> Vec<(u64, Vec<u8>)> {
    let bytes = std::fs::read(path).unwrap();
    dima_log::reader::messages(&bytes)
        .unwrap()
        .into_iter()
        .filter(|m| m.channel.topic == schema::CYCLE.topic)
        .map(|m| (m.log_time, m.data))
        .collect()
}

#[test]
fn the_same_seed_gives_byte_identical_cycle_messages() {
    let dir = test_dir("determinism");
    let (a, b) = (dir.join("a.mcap"), dir.join("b.mcap"));
    let first = run_traced(7, 20.0, &a, false).unwrap();
    // Something else in between: nothing of one run may leak into the next.
    run_seed(8, 5.0);
    let second = run_traced(7, 20.0, &b, false).unwrap();
    let (ma, mb) = (cycle_messages(&a), cycle_messages(&b));
    assert!(ma.len() > 4_900, "{} cycle messages", ma.len());
    assert!(ma == mb, "the two runs of seed 7 differ");
    assert_eq!(first.violations, second.violations);
    assert_eq!(first.checks, second.checks);
    // Another seed is another run.
    let c = dir.join("c.mcap");
    run_traced(9, 20.0, &c, false).unwrap();
    assert!(cycle_messages(&c) != ma);
    let _ = std::fs::remove_dir_all(&dir);
}

/// An even seed whose robot follows its mission in AUTO within two minutes.
const MISSION_SEED: u64 = 2;

#[test]
fn a_trace_is_a_robot_log_that_replays_identically() {
    let dir = test_dir("replay");
    let path = dir.join("trace.mcap");
    let report = run_traced(3, 30.0, &path, false).unwrap();
    let run = LoggedRun::read(&path).unwrap();
    assert_eq!(run.cycles.len() as u64, report.cycles);
    let config = run
        .config
        .clone()
        .expect("the trace carries its configuration");
    let replayed = replay(&run, &config).unwrap();
    assert_eq!(replayed.first_difference, None);
    assert!(run.raw.len() > 1_000, "{} raw packets", run.raw.len());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_mission_seeds_trace_replays_identically_with_the_mission_it_records() {
    let dir = test_dir("replay-mission");
    let path = dir.join("trace.mcap");
    run_traced(MISSION_SEED, 120.0, &path, false).unwrap();
    let run = LoggedRun::read(&path).unwrap();
    let navigation = run.navigation.clone().expect("the navigation record");
    assert!(navigation.mission.is_some());
    let following = run
        .cycles
        .iter()
        .filter(|c| c.msg.auto_source == Some(dima_core::mission::AutoSource::Mission))
        .count();
    assert!(
        following > 1_000,
        "{following} cycles following the mission"
    );
    let config = run.config.clone().unwrap();
    let replayed = replay(&run, &config).unwrap();
    assert_eq!(replayed.first_difference, None);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Outputs of the real step in `mode` for the checker's hand-made cycles.
fn outputs(mode: Mode, pulses: [u16; 3]) -> CycleOutputs {
    let mut core = Core::new(&Config::default()).unwrap();
    let mut out = core.step(
        &mut CoreState::new(),
        &dima_core::CycleInputs {
            missed_periods: 0,
            commands: &[],
            sensor: dima_core::SensorInput::NotRequested,
            stale_packets: 0,
        },
        START_NS,
    );
    out.mode = mode;
    out.targets.pulse_us = pulses;
    out
}

fn check(
    checker: &mut Checker,
    intent: &Intent,
    cycle: u64,
    before: Mode,
    out: &CycleOutputs,
    commands: &[Applied],
) {
    check_with_fix(checker, intent, cycle, before, out, commands, None);
}

/// A valid 3-D fix `north_m` north of the car's start point, with time of week `itow_ms`.
fn fix_north(itow_ms: u32, north_m: f64) -> neo_m8t::NavPvt {
    let [lat, lon] = start_offset(north_m, 0.0);
    neo_m8t::NavPvt {
        itow_ms,
        fix_type: 3,
        flags: neo_m8t::nav_pvt::FLAG_GNSS_FIX_OK,
        lat_deg_e7: (lat * 1e7).round() as i32,
        lon_deg_e7: (lon * 1e7).round() as i32,
        s_acc_mm_s: 150,
        ..Default::default()
    }
}

/// As [`check`], the packet carrying `fix` in its GNSS area.
fn check_with_fix(
    checker: &mut Checker,
    intent: &Intent,
    cycle: u64,
    before: Mode,
    out: &CycleOutputs,
    commands: &[Applied],
    fix: Option<neo_m8t::NavPvt>,
) {
    // A good packet whose IMU words change every cycle.
    let w = cycle as i16;
    let packet = dima_sensorboard::SensorPacket {
        accel: [w, 0, 1_000],
        gyro: [0, w, 0],
        gnss: fix.map_or_else(Default::default, |f| GnssFrame::from_nav_pvt(&f)),
        ..Default::default()
    };
    checker.check_cycle(
        &CycleView {
            cycle,
            now: START_NS + cycle * 4_000_000,
            missed: 0,
            mode_before: before,
            out,
            commands,
            packet: Some(&packet),
        },
        intent,
    );
}

#[test]
fn the_checker_catches_motion_and_revives_nobody_asked_for() {
    let config = Config::default();
    let mut checker = Checker::new(&config);
    let mut intent = Intent::default();
    let throttle = Command::Throttle(dima_groundlink::Percent::new(80).unwrap());
    // Throttle 80 % asked while KILLED, then a revive: the throttle is not asked after it.
    intent.note(super::operator::Action::Request(throttle), START_NS);
    intent.note(
        super::operator::Action::Request(Command::Revive),
        START_NS + 10,
    );
    let revive = Applied {
        command: Command::Revive,
        asked_at: Some(START_NS + 10),
        arrival_ns: START_NS,
    };
    let manual = outputs(Mode::Manual, [1500, 1545, 1500]);
    check(&mut checker, &intent, 1, Mode::Killed, &manual, &[revive]);
    assert!(
        checker.violations().is_empty(),
        "{:?}",
        checker.violations()
    );
    let moving = outputs(Mode::Manual, [1800, 1545, 1500]);
    check(&mut checker, &intent, 2, Mode::Manual, &moving, &[]);
    assert_eq!(
        checker.violations()[0].invariant,
        Invariant::NoUnaskedMotion
    );
    // Asked after the revive: fine.
    intent.note(super::operator::Action::Request(throttle), START_NS + 20);
    check(&mut checker, &intent, 3, Mode::Manual, &moving, &[]);
    assert_eq!(checker.violations().len(), 1);
    // A kill that leaves the outputs moving, and a revive used twice.
    let kill = Applied {
        command: Command::Kill,
        asked_at: None,
        arrival_ns: START_NS,
    };
    check(&mut checker, &intent, 4, Mode::Manual, &moving, &[kill]);
    assert_eq!(
        checker.violations()[1].invariant,
        Invariant::KillIsImmediate
    );
    check(&mut checker, &intent, 5, Mode::Killed, &manual, &[revive]);
    let names: Vec<_> = checker.violations().iter().map(|v| v.invariant).collect();
    assert!(names.contains(&Invariant::NoUnaskedRevive), "{names:?}");
    // AUTO below neutral.
    let reverse = outputs(Mode::Auto, [1400, 1545, 1500]);
    check(&mut checker, &intent, 6, Mode::Auto, &reverse, &[]);
    let names: Vec<_> = checker.violations().iter().map(|v| v.invariant).collect();
    assert!(names.contains(&Invariant::AutoForwardOnly), "{names:?}");
}

#[test]
fn the_checker_demands_a_failsafe_after_comms_loss() {
    let config = Config::default();
    let mut checker = Checker::new(&config);
    let intent = Intent::default();
    let manual = outputs(Mode::Manual, [1500, 1545, 1500]);
    let heartbeat = Applied {
        command: Command::Heartbeat,
        asked_at: None,
        arrival_ns: START_NS,
    };
    check(
        &mut checker,
        &intent,
        0,
        Mode::Manual,
        &manual,
        &[heartbeat],
    );
    // comms_timeout_ms = 1000 at 4 ms a cycle: 251 cycles are within the bound plus a period.
    for cycle in 1..=251 {
        check(&mut checker, &intent, cycle, Mode::Manual, &manual, &[]);
    }
    assert!(
        checker.violations().is_empty(),
        "{:?}",
        checker.violations()
    );
    check(&mut checker, &intent, 252, Mode::Manual, &manual, &[]);
    assert_eq!(checker.violations()[0].invariant, Invariant::FailsafeInTime);
}

#[test]
fn the_help_lists_every_invariant() {
    for i in Invariant::ALL {
        assert!(super::INVARIANTS_HELP.contains(i.name()), "{}", i.name());
    }
}

/// How many violations of `invariant` the checker found.
fn count(checker: &Checker, invariant: Invariant) -> usize {
    checker
        .violations()
        .iter()
        .filter(|v| v.invariant == invariant)
        .count()
}

/// The default configuration with `fence`.
fn fenced(fence: FenceConfig) -> Config {
    let mut config = Config::default();
    config.navigation.fence = fence;
    config
}

/// A circle of `radius_m` around the car's start point.
fn circle(radius_m: f64) -> FenceConfig {
    let [lat_deg, lon_deg] = start_offset(0.0, 0.0);
    FenceConfig {
        circles: vec![FenceCircle {
            lat_deg,
            lon_deg,
            radius_m,
        }],
        ..FenceConfig::default()
    }
}

/// An applied revive the operator asked for at `asked`.
fn revive(asked: u64) -> Applied {
    Applied {
        command: Command::Revive,
        asked_at: Some(asked),
        arrival_ns: START_NS,
    }
}

/// KILLED with a fix at `start_m` north, revived on it, then MANUAL with one fix at `away_m`
/// north at cycle 2 and none after it, up to cycle `last` (in FAILSAFE from cycle
/// `failsafe_at`, if given): the fence violations the checker found.
fn drive_out(
    config: &Config,
    start_m: f64,
    away_m: f64,
    last: u64,
    failsafe_at: Option<u64>,
) -> Checker {
    let mut checker = Checker::new(config);
    let mut intent = Intent::default();
    intent.note(Action::Request(Command::Revive), START_NS);
    let killed = outputs(
        Mode::Killed,
        Core::new(config).unwrap().safe_targets().pulse_us,
    );
    let failsafe = CycleOutputs {
        mode: Mode::Failsafe,
        ..killed
    };
    let manual = outputs(Mode::Manual, [1500, 1545, 1500]);
    let fix = Some(fix_north(1_000, start_m));
    check_with_fix(&mut checker, &intent, 0, Mode::Killed, &killed, &[], fix);
    check(
        &mut checker,
        &intent,
        1,
        Mode::Killed,
        &manual,
        &[revive(START_NS)],
    );
    let mut before = Mode::Manual;
    for cycle in 2..=last {
        let out = if failsafe_at.is_some_and(|f| cycle >= f) {
            &failsafe
        } else {
            &manual
        };
        let fix = (cycle == 2).then(|| fix_north(1_100, away_m));
        check_with_fix(&mut checker, &intent, cycle, before, out, &[], fix);
        before = out.mode;
    }
    checker
}

#[test]
fn fence_failsafe_in_time_fires_on_a_fix_outside_left_unanswered() {
    // A circle of 20 m: 30 m north is outside. The bound: one GNSS period (100 ms) plus one
    // period (4 ms) after the fix at cycle 2, i.e. up to cycle 28 at 4 ms a cycle.
    let config = fenced(circle(20.0));
    let quiet = drive_out(&config, 0.0, 30.0, 28, None);
    assert!(quiet.violations().is_empty(), "{:?}", quiet.violations());
    let late = drive_out(&config, 0.0, 30.0, 29, None);
    assert_eq!(
        count(&late, Invariant::FenceFailsafeInTime),
        1,
        "{:?}",
        late.violations()
    );
    // A FAILSAFE in time, or a fix inside, is silent.
    let answered = drive_out(&config, 0.0, 30.0, 60, Some(20));
    assert!(
        answered.violations().is_empty(),
        "{:?}",
        answered.violations()
    );
    let inside = drive_out(&config, 0.0, 15.0, 60, None);
    assert!(inside.violations().is_empty(), "{:?}", inside.violations());
    // The largest distance counts from the revive point: revived 10 m north, 25 m north is
    // within 20 m of it, 35 m north is not (and there is no inclusion area to leave).
    let far = fenced(FenceConfig {
        max_distance_m: Some(20.0),
        ..FenceConfig::default()
    });
    let near = drive_out(&far, 10.0, 25.0, 60, None);
    assert!(near.violations().is_empty(), "{:?}", near.violations());
    let gone = drive_out(&far, 10.0, 35.0, 60, None);
    assert!(
        count(&gone, Invariant::FenceFailsafeInTime) > 0,
        "{:?}",
        gone.violations()
    );
    // Without a fence nothing is outside.
    let open = drive_out(&Config::default(), 0.0, 300.0, 60, None);
    assert!(open.violations().is_empty(), "{:?}", open.violations());
}

#[test]
fn no_revive_outside_fence_fires_on_a_revive_outside_or_without_a_fix() {
    let config = fenced(circle(20.0));
    // Revived on a fix 30 m north: outside the circle.
    let outside = drive_out(&config, 30.0, 30.0, 2, Some(2));
    assert_eq!(
        count(&outside, Invariant::NoReviveOutsideFence),
        1,
        "{:?}",
        outside.violations()
    );
    // Revived on a fix 10 m north: inside.
    let inside = drive_out(&config, 10.0, 10.0, 2, None);
    assert!(inside.violations().is_empty(), "{:?}", inside.violations());
    // Revived before any fix.
    let mut checker = Checker::new(&config);
    let mut intent = Intent::default();
    intent.note(Action::Request(Command::Revive), START_NS);
    let manual = outputs(Mode::Manual, [1500, 1545, 1500]);
    check(
        &mut checker,
        &intent,
        0,
        Mode::Killed,
        &manual,
        &[revive(START_NS)],
    );
    assert_eq!(count(&checker, Invariant::NoReviveOutsideFence), 1);
    // Without a fence any revive is fine.
    let open = drive_out(&Config::default(), 300.0, 300.0, 2, None);
    assert!(open.violations().is_empty(), "{:?}", open.violations());
}

/// A mission status on waypoint `waypoint`, `along_m` along its leg.
fn status(waypoint: u32, along_m: f32) -> MissionStatus {
    MissionStatus {
        waypoint,
        cross_track_m: 0.0,
        along_track_m: along_m,
        leg_length_m: 30.0,
        to_go_m: 30.0 - along_m,
        heading_deg: 90.0,
        speed_m_s: 2.0,
        finished: false,
    }
}

#[test]
fn mission_stops_on_kill_fires_on_a_mission_kept_across_a_kill() {
    let config = Config::default();
    let safe = Core::new(&config).unwrap().safe_targets().pulse_us;
    let killed = outputs(Mode::Killed, safe);
    let manual = outputs(Mode::Manual, [1500, 1545, 1500]);
    let following = |s: MissionStatus| CycleOutputs {
        auto_source: Some(AutoSource::Mission),
        mission: Some(s),
        ..outputs(Mode::Auto, [1500, 1545, 1500])
    };
    let kill = Applied {
        command: Command::Kill,
        asked_at: None,
        arrival_ns: START_NS,
    };
    let speed = Applied {
        command: Command::SpeedSetpoint { mm_s: 0 },
        asked_at: None,
        arrival_ns: START_NS,
    };
    let mut intent = Intent::default();
    intent.note(Action::Request(Command::Revive), START_NS);
    // (cycle, mode before, outputs, commands, violations of mission_stops_on_kill so far).
    let steps: Vec<(Mode, CycleOutputs, Vec<Applied>, usize)> = vec![
        (Mode::Killed, manual, vec![revive(START_NS)], 0),
        // AUTO entered: the mission starts where the car is, and goes on.
        (Mode::Manual, following(status(0, 0.0)), vec![speed], 0),
        (Mode::Auto, following(status(0, 3.0)), vec![], 0),
        (Mode::Auto, following(status(1, 1.0)), vec![], 0),
        // Killed: nothing of the mission is left, and it stays so in MANUAL after a revive.
        (Mode::Auto, killed, vec![kill], 0),
        (Mode::Killed, manual, vec![revive(START_NS)], 0),
        (Mode::Manual, manual, vec![], 0),
        // AUTO entered again: afresh.
        (Mode::Manual, following(status(0, 0.0)), vec![speed], 0),
        // A kill whose mission status lingers on.
        (
            Mode::Auto,
            CycleOutputs {
                mission: Some(status(1, 2.0)),
                ..killed
            },
            vec![kill],
            1,
        ),
        // Revived into MANUAL, still reporting the mission.
        (
            Mode::Killed,
            CycleOutputs {
                mission: Some(status(1, 2.5)),
                auto_source: None,
                ..manual
            },
            vec![revive(START_NS)],
            2,
        ),
        // AUTO entered again, but the progress carried over from before the kill.
        (Mode::Manual, following(status(0, 12.0)), vec![speed], 3),
        (Mode::Auto, following(status(0, 14.0)), vec![], 3),
    ];
    let mut checker = Checker::new(&config).with_mission(true);
    for (cycle, (before, out, commands, expected)) in steps.iter().enumerate() {
        check(&mut checker, &intent, cycle as u64, *before, out, commands);
        assert_eq!(
            count(&checker, Invariant::MissionStopsOnKill),
            *expected,
            "cycle {cycle}: {:?}",
            checker.violations()
        );
    }
}

#[test]
fn auto_on_a_mission_steers_only_after_the_setpoint_that_entered_it() {
    let config = Config::default();
    let steering = outputs(Mode::Auto, [1500, 1700, 1500]);
    let judge = |mission: bool, setpoint_after_revive: bool| {
        let mut checker = Checker::new(&config).with_mission(mission);
        let mut intent = Intent::default();
        let speed = Action::Request(Command::SpeedSetpoint { mm_s: 0 });
        if !setpoint_after_revive {
            intent.note(speed, START_NS);
        }
        intent.note(Action::Request(Command::Revive), START_NS + 10);
        if setpoint_after_revive {
            intent.note(speed, START_NS + 20);
        }
        let manual = outputs(Mode::Manual, [1500, 1545, 1500]);
        check(
            &mut checker,
            &intent,
            0,
            Mode::Killed,
            &manual,
            &[revive(START_NS + 10)],
        );
        check(&mut checker, &intent, 1, Mode::Manual, &steering, &[]);
        count(&checker, Invariant::NoUnaskedMotion)
    };
    assert_eq!(judge(true, true), 0, "the mission's steering was asked for");
    assert_eq!(
        judge(true, false),
        1,
        "a setpoint before the revive asks for nothing"
    );
    assert_eq!(
        judge(false, true),
        1,
        "a speed of 0 without a mission does not steer"
    );
}

/// A tight fence for the real runs: a circle of 3 m around the start and a mission.
fn tight_navigation(seed: u64) -> Navigation {
    let drawn = super::navigation::draw(crate::rng::SimRng::new(seed));
    Navigation {
        mission: drawn.mission,
        fence: circle(3.0),
    }
}

#[test]
fn a_robot_that_ignores_its_fence_breaks_fence_failsafe_in_time() {
    let end = START_NS + 120_000_000_000;
    let mut ignoring = Simulation::with_fence_unknown_to_robot(2, end, tight_navigation(2));
    ignoring.run_until(end, None, None);
    let names: Vec<Invariant> = ignoring.violations().iter().map(|v| v.invariant).collect();
    assert!(names.contains(&Invariant::FenceFailsafeInTime), "{names:?}");
    assert_eq!(ignoring.fence_failsafes(), 0);
    // The same run with the robot knowing its fence holds every invariant, and the fence
    // does trip.
    let mut knowing = Simulation::with_navigation(2, end, true, Some(tight_navigation(2)));
    knowing.run_until(end, None, None);
    assert!(
        knowing.violations().is_empty(),
        "{:?}",
        knowing.violations()
    );
    assert!(knowing.fence_failsafes() > 0);
}

#[test]
fn seeds_1_to_20_follow_missions_and_trip_the_fence() {
    let (mut mission_cycles, mut fence_failsafes, mut fence_exits, mut seeds) = (0, 0, 0, 0);
    for seed in 1..=20 {
        let report = run_seed(seed, 200.0);
        assert!(
            report.violations.is_empty(),
            "seed {seed}: {:?}",
            report.first()
        );
        println!(
            "seed {seed}: {} mission cycles, {} fence failsafes, {} fixes outside the fence",
            report.mission_cycles, report.fence_failsafes, report.fence_exits
        );
        mission_cycles += report.mission_cycles;
        fence_failsafes += report.fence_failsafes;
        fence_exits += report.fence_exits;
        seeds += u64::from(report.mission_cycles > 0 && report.fence_failsafes > 0);
        if !super::navigation::seed_has_navigation(seed) {
            let counts = (
                report.mission_cycles,
                report.fence_failsafes,
                report.fence_exits,
            );
            assert_eq!(counts, (0, 0, 0));
        }
    }
    assert!(mission_cycles > 10_000, "{mission_cycles} mission cycles");
    assert!(fence_failsafes >= 5, "{fence_failsafes} fence failsafes");
    // The harness's own judgement of the fence found the car outside too (and each time the
    // robot was safe in time, or the run would have a violation).
    assert!(fence_exits >= 5, "{fence_exits} fixes outside the fence");
    assert!(
        seeds >= 3,
        "{seeds} seeds both follow a mission and trip the fence"
    );
}
