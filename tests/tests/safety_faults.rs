//! End-to-end tests of the failsafes behind the device faults of `dima sim --fault`: frozen and
//! lost GNSS, a stuck IMU, an overloaded loop and late sensor answers. The real application runs
//! against the simulated devices on pseudo-terminals (serial links paced at their baud rates);
//! every check reads both the outputs at the simulated Maestro and the application's MCAP log.
//! The simulation's configuration puts the steering's safe position at 1560 µs, so FAILSAFE
//! cannot be mistaken for MANUAL at neutral.

use dima_core::config::{Config, SafeOutput};
use dima_core::{FailsafeCause, Mode};
use dima_e2e::{assert_passed, simulate, simulate_with};
use dima_groundlink::Command;
use dima_sim::app_config::SIM_STEERING_SAFE_US;
use dima_sim::scenario::{manual_us, pct, send, Check, Scenario};

/// Revive at 0.5 s (and again at 0.8 s), drive in MANUAL from 1 s, AUTO (2.5 m/s, 90°) from 2 s.
fn drive_to_auto(s: &mut Scenario) {
    s.script.push(send(0.5, Command::Revive));
    // Again at 0.8 s, as an operator does when the robot refused the first: on a busy machine
    // the application can start late enough that at 0.5 s the sensor link has not yet
    // delivered the good packets a revive needs. A revive in MANUAL changes nothing.
    s.script.push(send(0.8, Command::Revive));
    s.script.push(send(1.0, Command::Throttle(pct(60))));
    s.script
        .push(send(2.0, Command::SpeedSetpoint { mm_s: 2_500 }));
    s.script
        .push(send(2.0, Command::HeadingSetpoint { deg_e5: 9_000_000 }));
}

/// In AUTO, GNSS gone bad at 4 s: FAILSAFE (GnssStale) within the 0.5 s GNSS timeout plus
/// one 100 ms epoch and the loop's reaction, latched with safe outputs.
fn gnss_fault_trips_gnss_stale(name: &str, fault: &str, seed: u64) {
    let mut s = Scenario::custom("gnss", 7.0);
    drive_to_auto(&mut s);
    s.checks = vec![
        Check::NeverSafe {
            from_s: 1.0,
            to_s: 4.0,
        },
        Check::FailsafeFor {
            cause: FailsafeCause::GnssStale,
            from_s: 4.0,
            to_s: 4.75,
        },
        Check::SafeHeld {
            from_s: 4.0,
            to_s: 7.0,
        },
        Check::ModesInOrder(vec![Mode::Manual, Mode::Auto, Mode::Failsafe]),
        Check::Failsafes(1),
    ];
    let r = simulate(name, s, &[fault], seed);
    assert_passed(&r);
}

#[test]
fn frozen_gnss_in_auto_trips_gnss_stale() {
    gnss_fault_trips_gnss_stale("gnss-freeze", "gnss:freeze=4+3", 12);
}

#[test]
fn lost_gnss_fix_in_auto_trips_gnss_stale() {
    gnss_fault_trips_gnss_stale("gnss-loss", "gnss:loss=4+3", 13);
}

#[test]
fn stuck_imu_trips_failsafe_and_blocks_revive_while_stuck() {
    let mut s = Scenario::custom("imu", 6.0);
    s.script.push(send(0.5, Command::Revive));
    s.script.push(send(1.0, Command::Throttle(pct(60))));
    // Stuck from 2 s to 4 s: 50 identical packets take 0.2 s.
    s.script.push(send(3.0, Command::Revive)); // refused: still stuck
    s.script.push(send(4.5, Command::Revive));
    s.script.push(send(4.8, Command::Throttle(pct(58))));
    s.checks = vec![
        Check::FailsafeFor {
            cause: FailsafeCause::ImuStuck,
            from_s: 2.0,
            to_s: 2.5,
        },
        Check::SafeHeld {
            from_s: 2.0,
            to_s: 4.5,
        },
        Check::OutputsReach {
            from_s: 4.8,
            to_s: 6.0,
            targets_us: manual_us(58, 50, 50),
        },
        Check::Failsafes(1),
    ];
    let r = simulate("imu-stuck", s, &["imu:stuck=2+2"], 14);
    assert_passed(&r);
    assert!(r.app.counters.revives_refused >= 1, "{:?}", r.app.counters);
}

#[test]
fn sustained_loop_overload_trips_the_overrun_failsafe_within_a_second() {
    let mut s = Scenario::custom("busy", 5.0);
    s.script.push(send(0.5, Command::Revive));
    s.script.push(send(1.0, Command::Throttle(pct(60))));
    s.checks = vec![
        Check::NeverSafe {
            from_s: 1.2,
            to_s: 2.0,
        },
        // 6 ms of work in every 4 ms period from 2 s.
        Check::FailsafeFor {
            cause: FailsafeCause::Overrun,
            from_s: 2.0,
            to_s: 3.0,
        },
        Check::SafeHeld {
            from_s: 2.0,
            to_s: 5.0,
        },
    ];
    let r = simulate("loop-busy", s, &["loop:busy=2+2,busy_ms=6"], 15);
    assert_passed(&r);
    assert!(r.app.counters.missed_periods >= 11, "{:?}", r.app.counters);
}

#[test]
fn answers_later_than_a_period_never_make_the_link_look_healthy() {
    // Every answer 5 ms late at a 4 ms period: none belongs to the request before it.
    let mut s = Scenario::custom("stale", 4.0);
    s.script.push(send(0.5, Command::Revive));
    s.script.push(send(1.0, Command::Throttle(pct(70))));
    s.script.push(send(2.0, Command::Revive));
    s.checks = vec![
        Check::SafeThroughout {
            from_s: 0.0,
            to_s: 4.0,
        },
        Check::Failsafes(0),
    ];
    let r = simulate("sensor-delay", s, &["sensor:delay=5"], 16);
    assert_passed(&r);
    let c = &r.app.counters;
    // Without a sequence number in the packet, an answer that a host stall pushes into the
    // window after a later request cannot be told from a fresh one; that can happen now and
    // then on a loaded machine, never often enough to make the link look healthy (a revive
    // needs `revive_good_packets` good packets with no loss between them, and none was
    // accepted above).
    assert!(c.packets_ok <= c.cycles / 100, "{c:?}");
    assert!(c.packets_stale + c.packets_late + c.packets_missing >= c.cycles - 1);
    assert!(c.revives_refused >= 2, "{c:?}");
}

#[test]
fn a_car_on_its_side_trips_rollover_and_is_not_revived_until_upright() {
    let mut s = Scenario::custom("rollover", 6.0);
    s.script.push(send(0.5, Command::Revive));
    s.script.push(send(0.8, Command::Revive));
    s.script.push(send(1.0, Command::Throttle(pct(60))));
    // On its side from 2 s to 4 s: tilted for 500 ms trips.
    s.script.push(send(3.0, Command::Revive)); // refused: still on its side
    s.script.push(send(4.5, Command::Revive));
    s.script.push(send(4.8, Command::Throttle(pct(58))));
    s.checks = vec![
        Check::NeverSafe {
            from_s: 1.2,
            to_s: 2.4,
        },
        Check::FailsafeFor {
            cause: FailsafeCause::Rollover,
            from_s: 2.4,
            to_s: 2.75,
        },
        Check::SafeHeld {
            from_s: 2.5,
            to_s: 4.5,
        },
        Check::OutputsReach {
            from_s: 4.8,
            to_s: 6.0,
            targets_us: manual_us(58, 50, 50),
        },
        Check::Failsafes(1),
    ];
    let r = simulate("rollover", s, &["vehicle:rollover=2+2"], 16);
    assert_passed(&r);
    assert!(r.app.counters.revives_refused >= 1, "{:?}", r.app.counters);
}

#[test]
fn driving_out_of_the_fence_trips_geofence() {
    let mut config = Config::default();
    config.channels.steering.safe = SafeOutput::PulseUs(SIM_STEERING_SAFE_US);
    // 6 m from the revive point: at 60 % throttle the car is past it within a few seconds.
    config.navigation.fence.max_distance_m = Some(6.0);
    let mut s = Scenario::custom("fence", 8.0);
    s.script.push(send(0.5, Command::Revive));
    s.script.push(send(0.8, Command::Revive));
    s.script.push(send(1.0, Command::Throttle(pct(60))));
    s.checks = vec![
        Check::NeverSafe {
            from_s: 1.2,
            to_s: 1.5,
        },
        Check::FailsafeFor {
            cause: FailsafeCause::Geofence,
            from_s: 1.5,
            to_s: 7.0,
        },
        Check::SafeHeld {
            from_s: 1.5,
            to_s: 8.0,
        },
        Check::ModesInOrder(vec![Mode::Manual, Mode::Failsafe]),
        Check::Failsafes(1),
    ];
    let r = simulate_with("fence", s, &[], 17, Some(&config));
    assert_passed(&r);
    // The model, driven by the outputs, really did get farther than 6 m from where it
    // started.
    let start = r.evidence.truth.first().expect("model samples");
    let farthest = r
        .evidence
        .truth
        .iter()
        .map(|v| (v.north_m - start.north_m).hypot(v.east_m - start.east_m))
        .fold(0.0, f64::max);
    assert!(farthest > 6.0, "{farthest} m");
}
