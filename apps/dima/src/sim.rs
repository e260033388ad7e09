//! `dima sim`: the application against the simulated devices of `dima-sim` on pseudo-terminals.
//!
//! The threads, the loop, the drivers, the decoders and the logger are the production ones:
//! only the device openers differ. The configuration's ports become the simulation's pty
//! links, the sensor board is opened with the production serial code and given the simulated
//! request line, and the logger's record observer feeds the simulation's status line.

use std::process::ExitCode;
use std::sync::atomic::Ordering;

use crate::app::{self, Devices, RunOptions};
use crate::config::Config;
use crate::devices::sensor::{open_sensor_port, SensorDevice};
use anyhow::Context;
pub use dima_sim::cli::SimArgs;
use dima_sim::runner::{AppCounters, AppLaunch, AppOutcome};

/// The application's configuration for a simulation run.
pub fn sim_config(launch: &AppLaunch) -> anyhow::Result<Config> {
    let mut config = match &launch.config {
        Some(path) => Config::load(path)?,
        None => Config::default(),
    };
    config.sensor.port = launch.sensor_port.clone();
    config.maestro.port = launch.maestro_port.clone();
    config.xbee.port = launch.xbee_port.clone();
    config.realtime.loop_rate_hz = launch.loop_rate_hz;
    let period_us = 1_000_000 / launch.loop_rate_hz.max(1);
    config.sensor.packet_deadline_us = config.sensor.packet_deadline_us.min(period_us * 9 / 10);
    config.maestro.servo_refresh_hz = config.maestro.servo_refresh_hz.min(launch.loop_rate_hz);
    for interval in [
        &mut config.sensor.reopen_interval_ms,
        &mut config.maestro.reopen_interval_ms,
        &mut config.xbee.reopen_interval_ms,
    ] {
        *interval = (*interval).min(200);
    }
    if !launch.realtime {
        // SCHED_FIFO where the system allows it (it falls back by itself), nothing that needs
        // a dedicated machine.
        config.realtime.cpus = Vec::new();
        config.realtime.lock_memory = false;
        config.realtime.cpu_dma_latency = false;
    }
    config.log.enabled = true;
    config.log.directory = launch.log_dir.clone();
    config.validate()?;
    Ok(config)
}

/// Runs the application against the simulation until `launch.stop` is set.
pub fn run_app(launch: AppLaunch) -> anyhow::Result<AppOutcome> {
    let config = sim_config(&launch)?;
    let hardware = app::hardware_devices(&config);
    let sensor = config.sensor.clone();
    let pin = launch.request.clone();
    let devices = Devices {
        sensor: Box::new(move || {
            let port = open_sensor_port(&sensor)?;
            SensorDevice::new(port, pin.clone()).context("sensor board: duplicating the port")
        }),
        servo: hardware.servo,
        ground: hardware.ground,
    };
    let status = launch.status.clone();
    let observer: app::run::Observer = Box::new(move |r| {
        status.mode.store(r.safety.mode.code(), Ordering::Relaxed);
        status.cycles.store(r.counters.cycles, Ordering::Relaxed);
        status
            .packets_ok
            .store(r.counters.packets_ok, Ordering::Relaxed);
        status
            .crc_errors
            .store(r.counters.packet_crc_errors, Ordering::Relaxed);
        status
            .packets_missing
            .store(r.counters.packets_missing, Ordering::Relaxed);
    });
    let options = RunOptions {
        duration: None,
        observer: Some(observer),
    };
    let summary = app::run(&config, devices, options, launch.stop.clone())?;
    let c = &summary.metrics.counters;
    Ok(AppOutcome {
        log_path: summary.log_path,
        summary: summary.metrics.summary(),
        counters: AppCounters {
            cycles: c.cycles,
            missed_periods: c.missed_periods,
            packets_ok: c.packets_ok,
            packets_missing: c.packets_missing,
            packet_crc_errors: c.packet_crc_errors,
            packet_bytes_skipped: c.packet_bytes_skipped,
            info_frames: c.info_frames,
            failsafes: c.failsafes,
            device_connects: c.device_connects,
            commands: c.commands,
            ground_frames: u64::from(summary.telemetry.commands.frames),
            ground_rejected: u64::from(summary.telemetry.commands.rejected()),
        },
    })
}

/// Runs `dima sim` with these flags; SIGINT/SIGTERM stop it early with safe outputs. Exit
/// status 0 when the scenario's expectations held, 1 when one did not, 2 on an error.
pub fn main(args: &SimArgs) -> ExitCode {
    dima_sim::cli::run(args, |launch| {
        app::install_signal_handlers(&launch.stop)?;
        run_app(launch)
    })
}
