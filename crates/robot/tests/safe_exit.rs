//! Safe on every exit: a panic of the realtime thread or of another thread stops the run with
//! the safe targets written to the Maestro first, and the run reports the failure; "outputs
//! safe" is claimed only after a write that succeeded.

mod common;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use common::*;
use dima_core::Nanos;
use dima_groundlink::{Command, Percent};
use dima_robot::app::{self, Devices, RunOptions};
use dima_robot::devices::servo::{MaestroPort, ServoError, ServoOutput};

const SAFE: [u16; 3] = [6000, 6180, 6000]; // 1500, 1545, 1500 µs in quarter-µs
const DRIVING: [u16; 3] = [1800 * 4, 1545 * 4, 1500 * 4];

/// The Maestro behind a fault: panics in the write that would take the servos to the targets
/// in `panic_on`, once.
struct PanicOnTargets {
    inner: MaestroPort,
    panic_on: [u16; 3],
    armed: Arc<AtomicBool>,
}

impl ServoOutput for PanicOnTargets {
    fn write_targets(
        &mut self,
        channels: &[u8; 3],
        targets_qus: &[u16; 3],
        deadline_ns: Nanos,
    ) -> Result<(), ServoError> {
        if *targets_qus == self.panic_on && self.armed.swap(false, Ordering::SeqCst) {
            panic!("simulated fault in the realtime cycle");
        }
        self.inner.write_targets(channels, targets_qus, deadline_ns)
    }
}

/// A rig: fake board, Maestro and ground station on ptys.
struct Rig {
    board: FakeBoard,
    maestro: FakeMaestro,
    ground_pty: Pty,
    sensor_path: std::path::PathBuf,
    maestro_path: std::path::PathBuf,
}

impl Rig {
    fn new() -> Rig {
        let (sensor_pty, maestro_pty, ground_pty) = (pty(), pty(), pty());
        Rig {
            sensor_path: sensor_pty.path.clone(),
            maestro_path: maestro_pty.path.clone(),
            board: FakeBoard::spawn(sensor_pty.master),
            maestro: FakeMaestro::spawn(maestro_pty.master),
            ground_pty,
        }
    }

    fn sensor_opener(
        &self,
    ) -> dima_robot::devices::Opener<dima_robot::devices::sensor::SensorDevice<RequestPin>> {
        let pin = Mutex::new(Some(self.board.pin()));
        let sp = self.sensor_path.clone();
        Box::new(move || sensor_device(&sp, pin.lock().unwrap().take().expect("opened once")))
    }
}

/// One run at a time: each wants the machine's cores for its loop and devices.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Revives and drives at 80 % throttle, again until the Maestro shows it (a revive is refused
/// until the sensor board has answered), for at most 5 s.
fn drive(ground: &FakeGround, maestro: &FakeMaestro) -> bool {
    for _ in 0..25 {
        ground.send(Command::Revive);
        ground.send(Command::Throttle(Percent::new(80).unwrap()));
        if maestro
            .wait_for(DRIVING, Duration::from_millis(200))
            .is_some()
        {
            return true;
        }
    }
    false
}

#[test]
fn a_panic_in_the_realtime_cycle_still_writes_the_safe_targets() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = temp_dir("panic-rt");
    let config = test_config(&dir);
    let rig = Rig::new();
    let armed = Arc::new(AtomicBool::new(true));
    let (mp, a) = (rig.maestro_path.clone(), armed.clone());
    let gp = rig.ground_pty.path.clone();
    let devices = Devices {
        sensor: rig.sensor_opener(),
        // Drives at 80 % first, then the cycle that would steer as well panics.
        servo: Box::new(move || {
            Ok(PanicOnTargets {
                inner: maestro_port(&mp)?,
                panic_on: [1800 * 4, 1840 * 4, 1500 * 4],
                armed: a.clone(),
            })
        }),
        ground: Box::new(move || open_port(&gp, 9_600, 1)),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    // A time limit, so that a failure cannot hang the test.
    let options = RunOptions {
        duration: Some(Duration::from_secs(15)),
        ..RunOptions::default()
    };
    let runner = std::thread::spawn(move || app::run(&config, devices, options, s).map(|_| ()));
    let ground = FakeGround::spawn(rig.ground_pty.master);
    assert!(drive(&ground, &rig.maestro), "{:?}", rig.maestro.first3());
    ground.send(Command::Steering(Percent::new(100).unwrap()));
    let result = runner.join().expect("run returns");
    let error = result.expect_err("the panic is reported");
    assert!(
        error.to_string().contains("realtime thread panicked"),
        "{error:#}"
    );
    assert!(!armed.load(Ordering::SeqCst), "the fault fired");
    assert_eq!(rig.maestro.first3(), SAFE, "safe targets after the panic");
    drop(ground);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_panic_in_another_thread_stops_the_loop_with_safe_targets() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = temp_dir("panic-logger");
    let config = test_config(&dir);
    let rig = Rig::new();
    let (mp, gp) = (rig.maestro_path.clone(), rig.ground_pty.path.clone());
    let devices = Devices {
        sensor: rig.sensor_opener(),
        servo: Box::new(move || maestro_port(&mp)),
        ground: Box::new(move || open_port(&gp, 9_600, 1)),
    };
    // The observer runs on the logger thread: it fails once the robot drives.
    let options = RunOptions {
        observer: Some(Box::new(|r| {
            if r.outputs.targets.pulse_us[0] == 1800 {
                panic!("simulated fault in the logger thread");
            }
        })),
        // A time limit, so that a failure cannot hang the test.
        duration: Some(Duration::from_secs(15)),
        ..RunOptions::default()
    };
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let runner = std::thread::spawn(move || app::run(&config, devices, options, s).map(|_| ()));
    let ground = FakeGround::spawn(rig.ground_pty.master);
    for _ in 0..25 {
        if runner.is_finished() {
            break;
        }
        ground.send(Command::Revive);
        ground.send(Command::Throttle(Percent::new(80).unwrap()));
        std::thread::sleep(Duration::from_millis(200));
    }
    let result = runner.join().expect("run returns");
    let error = result.expect_err("the panic is reported");
    assert!(
        error.to_string().contains("logger thread panicked"),
        "{error:#}"
    );
    assert_eq!(rig.maestro.first3(), SAFE, "safe targets after the panic");
    drop(ground);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn outputs_are_not_claimed_safe_without_a_successful_write() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = temp_dir("no-maestro");
    let config = test_config(&dir);
    let rig = Rig::new();
    let gp = rig.ground_pty.path.clone();
    let attempts = Arc::new(AtomicU64::new(0));
    let a = attempts.clone();
    let devices = Devices {
        sensor: rig.sensor_opener(),
        servo: Box::new(move || -> anyhow::Result<MaestroPort> {
            a.fetch_add(1, Ordering::Relaxed);
            anyhow::bail!("Maestro: not plugged in")
        }),
        ground: Box::new(move || open_port(&gp, 9_600, 1)),
    };
    let options = RunOptions {
        duration: Some(Duration::from_millis(600)),
        ..RunOptions::default()
    };
    let summary = app::run(&config, devices, options, Arc::new(AtomicBool::new(false)))
        .expect("the run itself succeeds");
    assert!(attempts.load(Ordering::Relaxed) >= 1);
    assert!(!summary.outputs_safe);
    assert!(summary.metrics.counters.servo_missing > 0);
    std::fs::remove_dir_all(&dir).unwrap();
}
