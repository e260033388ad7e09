//! The tail's yaw-rate controller against no tail controller, in the same AUTO scenario: at
//! 5 m/s, a 120° heading step. The simulator's car has a tail whose yaw moment grows with
//! deflection and speed squared; the heading it really had (the model's truth, 10 Hz) is what
//! is measured.

use dima_core::config::{Config, ControllerConfig};
use dima_e2e::simulate_with;
use dima_groundlink::Command;
use dima_sim::model::VehicleState;
use dima_sim::scenario::{send, Scenario};

/// When the heading step is commanded, s.
const STEP_AT_S: f64 = 4.0;
/// The heading asked for after the step, degrees.
const TARGET_DEG: f64 = 120.0;

/// Settling time (to within 5° for good), overshoot and integrated absolute heading error of
/// a heading step, with `tail` as the tail's controller.
fn heading_step(name: &str, tail: ControllerConfig) -> (f64, f64, f64) {
    let mut s = Scenario::custom("tail", 8.0);
    s.script.push(send(0.5, Command::Revive));
    s.script
        .push(send(1.0, Command::SpeedSetpoint { mm_s: 5_000 }));
    s.script
        .push(send(1.0, Command::HeadingSetpoint { deg_e5: 0 }));
    s.script.push(send(
        STEP_AT_S,
        Command::HeadingSetpoint {
            deg_e5: (TARGET_DEG * 1e5) as i32,
        },
    ));
    let mut config = Config::default();
    config.control.tail = tail;
    let r = simulate_with(name, s, &[], 21, Some(&config));
    assert_eq!(r.app.counters.failsafes, 0, "{:?}", r.app.counters);
    let after: Vec<&VehicleState> = r
        .evidence
        .truth
        .iter()
        .filter(|t| t.t_s >= STEP_AT_S)
        .collect();
    assert!(after.len() > 30, "{} samples", after.len());
    let error = |t: &VehicleState| (t.heading_deg - TARGET_DEG + 540.0).rem_euclid(360.0) - 180.0;
    let last_outside = after
        .iter()
        .filter(|t| error(t).abs() > 5.0)
        .map(|t| t.t_s)
        .fold(STEP_AT_S, f64::max);
    let overshoot = after.iter().map(|t| error(t)).fold(0.0, f64::max);
    let iae: f64 = after
        .windows(2)
        .map(|w| error(w[0]).abs() * (w[1].t_s - w[0].t_s))
        .sum();
    (last_outside - STEP_AT_S, overshoot, iae)
}

#[test]
fn the_tail_settles_a_heading_step_faster_than_no_tail_controller() {
    let without = heading_step("tail-none", ControllerConfig::none());
    let params: toml::Table = toml::from_str(
        "kp = 0.02\nki = 0.0\noutput_limit = 1.0\nrate_limit_per_s = 50.0\n\
         max_yaw_rate_dps = 600.0\nmin_speed_mm_s = 1500.0",
    )
    .unwrap();
    let with = heading_step(
        "tail-yaw-rate",
        ControllerConfig {
            kind: "yaw_rate".into(),
            params,
        },
    );
    println!(
        "120° step at 5 m/s: settling (±5°) {:.1} s without the tail controller, {:.1} s with; \
         overshoot {:.1}° / {:.1}°; integrated |heading error| {:.1} / {:.1} °·s",
        without.0, with.0, without.1, with.1, without.2, with.2
    );
    assert!(with.2 < without.2, "{with:?} vs {without:?}");
    assert!(with.0 <= without.0, "{with:?} vs {without:?}");
}
