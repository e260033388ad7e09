//! The controller plug-ins against a drive recorded by the hard-wired PID loops they replaced
//! (`tests/fixtures/auto-pid-before-plugins.mcap`: the simulator's default tour to 9 s, AUTO
//! from 6 s, written by DIMA-RS 0.1 with its configuration in the 0.1 layout).

use std::path::Path;

use dima_core::config::EstimatorConfig;
use dima_core::Mode;
use dima_log::LoggedRun;
use dima_tools::logtools::replay;

fn recorded() -> LoggedRun {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/auto-pid-before-plugins.mcap");
    LoggedRun::read(&path).expect("the fixture reads")
}

#[test]
fn speed_pid_and_heading_pid_replay_the_hard_wired_loops_bit_for_bit() {
    let run = recorded();
    let config = run.config.clone().expect("the 0.1 configuration is read");
    assert_eq!(
        (
            config.control.throttle.kind.as_str(),
            config.control.steering.kind.as_str(),
            config.control.tail.kind.as_str()
        ),
        ("speed_pid", "heading_pid", "none")
    );
    let r = replay::replay(&run, &config).unwrap();
    assert_eq!(r.first_difference, None);
    // Every cycle but the shutdown record is replayed.
    assert_eq!(r.cycles.len() + 1, run.cycles.len());
    let mut auto = 0;
    for now in &r.cycles {
        let then = run
            .cycles
            .iter()
            .find(|c| c.msg.cycle == now.message.cycle)
            .expect("the recorded cycle");
        let (a, b) = (&then.msg.action, &now.message.action);
        assert_eq!(
            [a.throttle, a.steering, a.tail].map(f32::to_bits),
            [b.throttle, b.steering, b.tail].map(f32::to_bits),
            "cycle {}",
            then.msg.cycle
        );
        if then.msg.mode == Mode::Auto && a.throttle != 0.0 {
            auto += 1;
        }
    }
    println!(
        "{} cycles, {auto} in AUTO with a throttle output: bit-identical",
        r.cycles.len()
    );
    assert!(auto > 500, "the fixture drives in AUTO: {auto} cycles");
}

#[test]
fn the_fused_estimate_changes_only_what_auto_does() {
    let run = recorded();
    let mut config = run.config.clone().unwrap();
    config.estimator = EstimatorConfig {
        gyro_yaw_sign: config.estimator.gyro_yaw_sign,
        min_heading_speed_mm_s: config.estimator.min_heading_speed_mm_s,
        ..EstimatorConfig::default()
    };
    let r = replay::replay(&run, &config).unwrap();
    let d = r
        .first_difference
        .expect("a different estimate steers differently");
    assert_eq!(
        (d.recorded.0, d.replayed.0),
        (Mode::Auto, Mode::Auto),
        "{d:?}"
    );
    println!(
        "default estimator: {} of {} cycles differ, first at {:.2} s",
        r.differing,
        r.cycles.len(),
        d.t_s
    );
}
