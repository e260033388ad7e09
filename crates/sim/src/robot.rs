//! `dima sim`: the application against the simulated devices of `dima-sim` on pseudo-terminals.
//!
//! The threads, the loop, the drivers, the decoders and the logger are the production ones:
//! only the device openers differ. The configuration's ports become the simulation's pty
//! links, the sensor board is opened with the production serial code and given the simulated
//! request line, and the logger's record observer feeds the simulation's status line.

use std::process::ExitCode;

use std::time::Instant;

pub use crate::cli::SimArgs;
use crate::faults::{AppFaults, LoopBusy, Window};
use crate::runner::{AppLaunch, AppOutcome};
use anyhow::Context;
use dima_core::Nanos;
use dima_robot::app::{self, BusyFault, Devices, RunOptions};
use dima_robot::devices::sensor::{open_sensor_port, SensorDevice};
use dima_robot::devices::servo::{ServoError, ServoOutput};
use dima_robot::logging::{LogFaults, NsWindow};

/// The simulation's `loop:busy` fault as the loop takes it.
fn busy_fault(busy: LoopBusy) -> BusyFault {
    let ns = |s: f64| (s * 1e9) as u64;
    BusyFault {
        start_ns: ns(busy.window.start_s),
        duration_ns: ns(busy.window.duration_s),
        busy_ns: ns(busy.busy_ms * 1e-3),
    }
}

fn ns_window(w: &Window) -> NsWindow {
    let ns = |s: f64| (s * 1e9) as u64;
    NsWindow {
        start_ns: ns(w.start_s),
        duration_ns: ns(w.duration_s),
    }
}

/// The simulation's `log:stall` and `log:full` faults as the logger takes them.
fn log_faults(f: &AppFaults) -> LogFaults {
    LogFaults {
        stalls: f.log_stalls.iter().map(ns_window).collect(),
        full: f.log_full.iter().map(ns_window).collect(),
    }
}

/// The servo board with the simulation's `maestro:write_error` fault: in its windows every
/// write fails as an I/O error of the port would (the loop counts it, closes the board and
/// reopens it).
struct FaultyServo<S> {
    inner: S,
    start: Instant,
    windows: Vec<Window>,
}

impl<S: ServoOutput> ServoOutput for FaultyServo<S> {
    fn write_targets(
        &mut self,
        channels: &[u8; 3],
        targets_qus: &[u16; 3],
        deadline_ns: Nanos,
    ) -> Result<(), ServoError> {
        let t = self.start.elapsed().as_secs_f64();
        if self.windows.iter().any(|w| w.contains(t)) {
            return Err(ServoError::Device);
        }
        self.inner.write_targets(channels, targets_qus, deadline_ns)
    }
}

/// Runs the application against the simulation until `launch.stop` is set.
pub fn run_app(launch: AppLaunch) -> anyhow::Result<AppOutcome> {
    let config = launch.config;
    let hardware = app::hardware_devices(&config);
    let sensor = config.sensor.clone();
    let pin = launch.request.clone();
    let start = Instant::now();
    let write_errors = launch.app_faults.maestro_write_errors.clone();
    let mut open_servo = hardware.servo;
    let devices = Devices {
        sensor: Box::new(move || {
            let port = open_sensor_port(&sensor)?;
            SensorDevice::new(port, pin.clone()).context("sensor board: duplicating the port")
        }),
        servo: Box::new(move || {
            Ok(FaultyServo {
                inner: open_servo()?,
                start,
                windows: write_errors.clone(),
            })
        }),
        ground: hardware.ground,
    };
    let status = launch.status.clone();
    let mut last_mode = dima_core::Mode::Killed;
    let stop_at_mission_end = launch.stop.clone();
    let observer: app::run::Observer = Box::new(move |r| {
        use std::sync::atomic::Ordering::Relaxed;
        *status.mode.lock().unwrap_or_else(|e| e.into_inner()) = Some(r.outputs.mode);
        if last_mode.is_safe() && r.outputs.mode == dima_core::Mode::Manual {
            status.revives.fetch_add(1, Relaxed);
        }
        last_mode = r.outputs.mode;
        status.cycles.store(r.counters.cycles, Relaxed);
        status.packets_ok.store(r.counters.packets_ok, Relaxed);
        status
            .crc_errors
            .store(r.counters.packet_crc_errors, Relaxed);
        let missing =
            r.counters.packets_missing + r.counters.packets_stale + r.counters.packets_late;
        status.packets_missing.store(missing, Relaxed);
        let mut mission = status.mission.lock().unwrap_or_else(|e| e.into_inner());
        if mission.record(&r.outputs, r.tick.wake_ns) {
            // The mission finished or a failsafe stopped it: the run ends here.
            stop_at_mission_end.store(true, Relaxed);
        }
    });
    let options = RunOptions {
        duration: None,
        observer: Some(observer),
        busy: launch.busy.map(busy_fault),
        log_faults: log_faults(&launch.app_faults),
    };
    let summary = app::run(&config, devices, options, launch.stop.clone())?;
    Ok(AppOutcome {
        log_path: summary.log_path,
        summary: summary.metrics.summary(),
        counters: summary.metrics.counters,
        ground_frames: summary.telemetry.link.v1_accepted + summary.telemetry.link.v2_accepted,
        ground_rejected: summary.telemetry.link.rejected(),
        outputs_safe: summary.outputs_safe,
    })
}

/// Runs `dima sim` with these flags; SIGINT/SIGTERM stop it early with safe outputs. Exit
/// status 0 when the scenario's expectations held, 1 when one did not, 2 on an error.
pub fn main(args: &SimArgs) -> ExitCode {
    crate::cli::run(args, |launch| {
        app::install_signal_handlers(&launch.stop)?;
        run_app(launch)
    })
}
