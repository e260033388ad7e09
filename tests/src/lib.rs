//! End-to-end tests of the DIMA application: the real application (threads, loop, drivers,
//! decoders, logger) against the simulated devices of `dima-sim` on pseudo-terminals.
//!
//! [`run_app`] starts the application for a simulation exactly as `dima sim` does (it is the
//! same function); [`simulate`] runs a scenario with faults and prints its report.

use std::path::PathBuf;
use std::sync::Mutex;

use dima_core::config::Config;
use dima_core::monitor::{OverrunRule, OverrunWindow};
use dima_core::FailsafeCause;
use dima_sim::logcheck::LogSummary;

pub use dima_sim::app_config::app_config;
pub use dima_sim::robot::run_app;
use dima_sim::runner::{run_simulation, SimOptions, SimReport, StatusMode};
use dima_sim::scenario::Scenario;

/// One simulation at a time: each wants the machine's cores for its loop and devices.
pub static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// A fresh directory for the test `name` under the system's temporary directory.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("dima-e2e-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("a temporary directory");
    d
}

/// Runs `scenario` with `faults` (the `--fault` syntax) and `seed`, one run at a time, quiet,
/// and prints the report.
pub fn simulate(name: &str, scenario: Scenario, faults: &[&str], seed: u64) -> SimReport {
    simulate_with(name, scenario, faults, seed, None)
}

/// [`simulate`] with the application's configuration `config` (as `dima sim --config`).
pub fn simulate_with(
    name: &str,
    scenario: Scenario,
    faults: &[&str],
    seed: u64,
    config: Option<&Config>,
) -> SimReport {
    simulate_options(name, scenario, faults, seed, config, |_| {})
}

/// [`simulate`] over ground link v1: `[xbee] require_auth = false`, no key, and a scripted
/// ground station that sends v1 frames (the scenario's heartbeat and raw frames as they are).
pub fn simulate_v1(name: &str, scenario: Scenario, faults: &[&str], seed: u64) -> SimReport {
    simulate_options(name, scenario, faults, seed, None, |o| {
        o.require_auth = Some(false)
    })
}

/// Runs a scenario may take on a busy machine: a run in which the host held the loop up
/// past the overrun rule (by the log's own account) is run again, up to this many runs.
pub const RUNS_ON_A_BUSY_HOST: usize = 3;

/// When the host held the loop up past the overrun rule: the log time (ns) of the first
/// cycle at which the late wake-ups and missed periods the log records, fed through the
/// configuration's overrun rule, exceed it. `None` when they never do, or without a log or
/// its configuration.
pub fn overload_at(log: &LogSummary) -> Option<u64> {
    let config = log.config.as_ref()?;
    let rule = OverrunRule {
        limit: config.safety.overrun_limit,
        max_stall_ns: u64::from(config.safety.max_stall_ms) * 1_000_000,
        period_ns: config.period_ns(),
    };
    let mut window = OverrunWindow::default();
    log.cycles.iter().find_map(|c| {
        let missed = u32::try_from(c.missed).unwrap_or(u32::MAX);
        window.record(missed, c.t_ns, &rule).then_some(c.t_ns)
    })
}

/// An `Overrun` failsafe in the log must be one the host's stalls explain: the late
/// wake-ups the log records exceed the overrun rule by the cycle that entered it.
pub fn assert_overruns_explained(r: &SimReport) {
    let Some(log) = &r.log else { return };
    let overload = overload_at(log);
    for (t, cause) in log.failsafes() {
        if cause == Some(FailsafeCause::Overrun) {
            assert!(
                overload.is_some_and(|o| o <= t),
                "FAILSAFE (Overrun) at {:.3} s that the logged wake-ups do not explain \
                 (first overload by the log: {:?})",
                r.evidence.sim_s(t),
                overload.map(|o| r.evidence.sim_s(o))
            );
        }
    }
}

/// Runs `run` until it passes `passed`, or the host did not overload the loop during it, up
/// to [`RUNS_ON_A_BUSY_HOST`] runs; returns the last run. A run that fails while the log shows
/// the host held the loop up past the overrun rule says nothing about the scenario (the loop
/// could not keep its period): only such runs are repeated, and each is reported. Every run's
/// `Overrun` failsafes must be explained by its log.
pub fn run_until_the_host_lets_it(
    name: &str,
    mut run: impl FnMut() -> SimReport,
    passed: impl Fn(&SimReport) -> bool,
) -> SimReport {
    for attempt in 1..=RUNS_ON_A_BUSY_HOST {
        let report = run();
        assert_overruns_explained(&report);
        if passed(&report) || attempt == RUNS_ON_A_BUSY_HOST {
            return report;
        }
        let Some(t) = report.log.as_ref().and_then(overload_at) else {
            return report;
        };
        eprintln!(
            "[{name}] run {attempt} failed, and the host held the loop up past the overrun rule \
             at {:.3} s (by the log): running it again",
            report.evidence.sim_s(t)
        );
    }
    unreachable!("the last run returns")
}

/// [`simulate_with`], with `adjust` applied to the simulation's options last.
pub fn simulate_options(
    name: &str,
    scenario: Scenario,
    faults: &[&str],
    seed: u64,
    config: Option<&Config>,
    adjust: impl FnOnce(&mut SimOptions),
) -> SimReport {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let o = sim_options(name, scenario, faults, seed, config, adjust);
    run_until_the_host_lets_it(
        name,
        || {
            let report = run_simulation(&o, run_app).expect("the simulation runs");
            eprintln!(
                "[{name}]\n{}\napp: {}",
                report.summary(),
                report.app.summary
            );
            report
        },
        |r| r.passed && r.false_accepts == 0,
    )
}

/// The options of [`simulate_options`].
fn sim_options(
    name: &str,
    scenario: Scenario,
    faults: &[&str],
    seed: u64,
    config: Option<&Config>,
    adjust: impl FnOnce(&mut SimOptions),
) -> SimOptions {
    let dir = temp_dir(name);
    let mut o = SimOptions::new(scenario);
    if let Some(config) = config {
        let path = dir.join("app.toml");
        let text = toml::to_string(config).expect("a configuration serialises");
        std::fs::write(&path, text).expect("the configuration is written");
        o.app_config = Some(path);
    }
    o.run_dir = dir.join("dev");
    o.log_dir = dir.join("logs");
    o.status = StatusMode::Quiet;
    o.seed = seed;
    for f in faults {
        o.faults.apply_arg(f).expect("a valid fault");
    }
    adjust(&mut o);
    o
}

/// Every check held and nothing was accepted that the board did not send intact.
pub fn assert_passed(r: &SimReport) {
    assert!(r.passed, "{}", r.failure().unwrap_or_default());
    assert_eq!(r.false_accepts, 0);
}
