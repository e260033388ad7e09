//! Devices that are missing at start-up or disappear at run time: reported, retried, outputs
//! safe while they are gone, and back in service after a reopen.

mod common;

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use common::*;
use dima_groundlink::{Command, Percent};
use dima_robot::app::{self, Devices, RunOptions};

#[test]
fn sensor_unplugged_and_back_maestro_late() {
    let dir = temp_dir("devices");
    let mut config = test_config(&dir);
    config.log.enabled = false;
    config.safety.sensor_loss_packets = 25;

    // Each sensor open makes a fresh pty and board: the old cable is gone for good.
    let boards: Arc<Mutex<Vec<FakeBoard>>> = Arc::new(Mutex::new(Vec::new()));
    let b = boards.clone();
    let sensor_opens = Arc::new(AtomicU32::new(0));
    let so = sensor_opens.clone();
    // The Maestro is missing for its first two attempts.
    let maestro_pty = pty();
    let maestro = FakeMaestro::spawn(maestro_pty.master);
    let mp = maestro_pty.path.clone();
    let maestro_attempts = Arc::new(AtomicU32::new(0));
    let ma = maestro_attempts.clone();
    let ground_pty = pty();
    let gp = ground_pty.path.clone();
    let devices = Devices {
        sensor: Box::new(move || {
            so.fetch_add(1, Ordering::SeqCst);
            let p = pty();
            let board = FakeBoard::spawn(p.master);
            let device = sensor_device(&p.path, board.pin());
            b.lock().unwrap().push(board);
            device
        }),
        servo: Box::new(move || {
            if ma.fetch_add(1, Ordering::SeqCst) < 2 {
                anyhow::bail!("Maestro: /dev/ttyACM0 not there (test)")
            }
            maestro_port(&mp)
        }),
        ground: Box::new(move || open_port(&gp, 9_600, 1)),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let (watch, observer) = LoopWatch::new(&config);
    let options = RunOptions {
        observer: Some(observer),
        ..RunOptions::default()
    };
    let runner = std::thread::spawn(move || app::run(&config, devices, options, s).expect("run"));
    let ground = FakeGround::spawn(ground_pty.master);

    // The Maestro comes up on its third attempt and gets the safe outputs.
    let safe = [6000, 6180, 6000];
    assert!(maestro.wait_for(safe, Duration::from_secs(3)).is_some());
    assert!(maestro_attempts.load(Ordering::SeqCst) >= 3);

    assert!(
        revive_until_driving(
            &ground,
            &watch,
            &[Command::Throttle(Percent::new(75).unwrap())],
            Duration::from_secs(5)
        ),
        "{:?}",
        watch.mode()
    );
    let driving = [1750 * 4, 1545 * 4, 1500 * 4];
    assert!(maestro.wait_for(driving, Duration::from_secs(1)).is_some());
    std::thread::sleep(Duration::from_millis(200));

    // Pull the sensor cable: the loop reports it, sensor loss trips FAILSAFE (safe outputs).
    boards.lock().unwrap()[0].unplug();
    assert!(
        maestro.wait_for(safe, Duration::from_secs(2)).is_some(),
        "{:?}",
        maestro.first3()
    );

    // The supervisor reopens (a new cable); packets flow again, and a revive is accepted.
    let t0 = std::time::Instant::now();
    while sensor_opens.load(Ordering::SeqCst) < 2 && t0.elapsed() < Duration::from_secs(3) {
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(300));
    assert!(
        revive_until_driving(
            &ground,
            &watch,
            &[Command::Throttle(Percent::new(60).unwrap())],
            Duration::from_secs(5)
        ),
        "{:?}",
        watch.mode()
    );
    assert!(maestro
        .wait_for([1600 * 4, 1545 * 4, 1500 * 4], Duration::from_secs(1))
        .is_some());

    stop.store(true, Ordering::Relaxed);
    let summary = runner.join().unwrap();
    let c = summary.metrics.counters;
    assert!(c.sensor_errors >= 1, "{c:?}");
    assert!(c.device_connects >= 3, "{c:?}");
    assert!(c.failsafes >= 1, "{c:?}");
    assert!(
        c.servo_missing > 0,
        "outputs were due while the Maestro was missing: {c:?}"
    );
    assert!(sensor_opens.load(Ordering::SeqCst) >= 2);
    drop(ground);
    boards.lock().unwrap().clear();
    std::fs::remove_dir_all(&dir).unwrap();
}
