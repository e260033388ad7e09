//! Tests of the simulator itself: determinism, the trace, and the invariants' teeth on
//! hand-made cycles.

use std::path::PathBuf;

use dima_core::config::Config;
use dima_core::step::CycleOutputs;
use dima_core::{Command, Core, CoreState, Mode};
use dima_log::schema;

use super::intent::Intent;
use super::invariants::{Applied, Checker, CycleView, Invariant};
use super::runner::START_NS;
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
    // A good packet whose IMU words change every cycle.
    let w = cycle as i16;
    let packet = dima_sensorboard::SensorPacket {
        accel: [w, 0, 1_000],
        gyro: [0, w, 0],
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
