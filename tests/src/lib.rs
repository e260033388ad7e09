//! End-to-end tests of the DIMA application: the real application (threads, loop, drivers,
//! decoders, logger) against the simulated devices of `dima-sim` on pseudo-terminals.
//!
//! [`run_app`] starts the application for a simulation exactly as `dima sim` does (it is the
//! same function); [`simulate`] runs a scenario with faults and prints its report.

use std::path::PathBuf;
use std::sync::Mutex;

use dima_core::config::Config;

pub use dima::sim::run_app;
pub use dima_sim::app_config::app_config;
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
    let report = run_simulation(&o, run_app).expect("the simulation runs");
    eprintln!(
        "[{name}]\n{}\napp: {}",
        report.summary(),
        report.app.summary
    );
    report
}

/// Every check held and nothing was accepted that the board did not send intact.
pub fn assert_passed(r: &SimReport) {
    assert!(r.passed, "{}", r.failure().unwrap_or_default());
    assert_eq!(r.false_accepts, 0);
}
