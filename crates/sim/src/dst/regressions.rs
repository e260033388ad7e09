//! Seeds that found a defect, replayed: each run must hold every invariant.
//!
//! Each test names the defect its seed found and the first violation it showed before the
//! fix (invariant and cycle). They failed on the code before the fixes (the station dropping
//! manual values and setpoints on revive, KILLED and FAILSAFE; the core's GNSS freshness,
//! ground speed, heading and stuck-IMU fixes) and pass with them; they are not ignored, so a
//! regression shows at once. After a fix the seed's run takes another course (the robot and
//! the station act differently), and the whole run must hold.
//!
//! | Defect | Seed | Invariant | Cycle |
//! | --- | --- | --- | --- |
//! | A manual value given while KILLED is repeated after the revive and moves the robot | 8 | `no_unasked_motion` | 525 |
//! | A speed setpoint given while KILLED is repeated after the revive: AUTO drives | 28 | `no_unasked_motion` | 233 |
//! | The heading on the gyro alone at low speed beyond the GNSS timeout | 27 | `heading_needs_fresh_gnss` | 1313 |
//! | GNSS time of week going back and forth counted as fresh fixes | 20 | `failsafe_in_time` | 2701 |
//! | A negative ground speed counted as a valid fix | 32 | `failsafe_in_time` | 1391 |
//! | A frozen gyroscope beside a live accelerometer never trips ImuStuck | 35 | `failsafe_in_time` | 1286 |
//! | A frozen accelerometer beside a live gyroscope never trips ImuStuck | 22 | `failsafe_in_time` | 419 |
//! | GNSS epochs received but not used (negative ground speed), then replayed valid, counted as fresh | 4 | `failsafe_in_time` | 30797 |
//! | The harness's own: of two revives handed over in one cycle (after a held-up telemetry thread), it took the later one, a no-op in MANUAL, for the revive that revived the robot, and judged a manual value asked between the two as unasked | 243 | `no_unasked_motion` | 25142 |
//! | The same, on the steering | 41 | `no_unasked_motion` | 143964 |

use super::run_seed;

/// Runs `seed` for `duration_s` and fails with every distinct violation.
fn holds(seed: u64, duration_s: f64) {
    let report = run_seed(seed, duration_s);
    let mut seen: Vec<String> = Vec::new();
    for v in &report.violations {
        let line = format!(
            "{} (first at cycle {}: {})",
            v.invariant.name(),
            v.cycle,
            v.detail
        );
        if !seen.iter().any(|s| s.starts_with(v.invariant.name())) {
            seen.push(line);
        }
    }
    assert!(
        seen.is_empty(),
        "seed {seed}: {} violations: {}",
        report.violations.len(),
        seen.join("; ")
    );
}

/// Found: a throttle, steering or tail value given while KILLED was still repeated by the
/// station after the revive and moved the robot (`no_unasked_motion` at cycle 525).
#[test]
fn seed_8_revive_repeats_a_manual_value_given_while_killed() {
    holds(8, 20.0);
}

/// Found: a speed setpoint given while KILLED was repeated after the revive and AUTO drove
/// (`no_unasked_motion` at cycle 233).
#[test]
fn seed_28_revive_repeats_a_setpoint_given_while_killed() {
    holds(28, 20.0);
}

/// Found: below the heading speed the gyro alone kept the heading, and the heading controller
/// steered on it, long past the GNSS timeout (`heading_needs_fresh_gnss` at cycle 1313).
#[test]
fn seed_27_gyro_heading_beyond_the_gnss_timeout() {
    holds(27, 20.0);
}

/// Found: a receiver replaying its last two epochs (time of week back and forth) counted as
/// fresh fixes, so AUTO never saw stale GNSS (`failsafe_in_time` at cycle 2701).
#[test]
fn seed_20_gnss_time_of_week_going_back_counted_as_fresh() {
    holds(20, 20.0);
}

/// Found: epochs with a negative ground speed counted as valid fixes in AUTO
/// (`failsafe_in_time` at cycle 1391).
#[test]
fn seed_32_negative_ground_speed_counted_as_a_fix() {
    holds(32, 20.0);
}

/// Found: a frozen gyroscope beside a live accelerometer never tripped ImuStuck
/// (`failsafe_in_time` at cycle 1286).
#[test]
fn seed_35_frozen_gyroscope_never_stuck() {
    holds(35, 20.0);
}

/// Found: a frozen accelerometer beside a live gyroscope never tripped ImuStuck (and the
/// robot revived with it: `failsafe_in_time` at cycle 419).
#[test]
fn seed_22_frozen_accelerometer_never_stuck() {
    holds(22, 20.0);
}

/// Found (in the harness, not the robot): after the telemetry thread was held up, one cycle
/// took a revive, a throttle value asked after it, and a second revive (a no-op in MANUAL);
/// the checker took the second for the revive that revived the robot and judged the throttle
/// unasked (`no_unasked_motion` at cycle 25142).
#[test]
fn seed_243_the_first_of_two_revives_in_a_cycle_revives() {
    holds(243, 110.0);
}

/// Found: the same on the steering, late in a long run (`no_unasked_motion` at cycle 143964).
#[test]
fn seed_41_the_first_of_two_revives_in_a_cycle_revives() {
    holds(41, 600.0);
}

/// A few short runs of the first seeds hold every invariant.
#[test]
fn a_few_short_runs_hold_every_invariant() {
    for seed in 1..=3 {
        holds(seed, 30.0);
    }
}

/// Found: epochs that arrived with a negative ground speed (received, not used) and were then
/// replayed with valid data passed for fresh fixes, because they were newer than the newest
/// fix used though older than epochs already received: AUTO ran on 2.4 s old data
/// (`failsafe_in_time` at cycle 30797, 600 s run).
#[test]
fn seed_4_replayed_epochs_older_than_one_received_are_not_fresh() {
    holds(4, 130.0);
}
