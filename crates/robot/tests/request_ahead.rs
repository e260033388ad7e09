//! Request-ahead mode: the request goes out at the end of cycle k and the answer is read at the
//! start of cycle k+1, so the packet's transfer overlaps the sleep.

mod common;

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use common::*;
use dima_robot::app::{self, Devices, RunOptions};

#[test]
fn request_ahead_reads_the_previous_cycles_answer() {
    let dir = temp_dir("ahead");
    let mut config = test_config(&dir);
    config.log.enabled = false;
    config.sensor.request_ahead = true;
    let (sensor_pty, maestro_pty, ground_pty) = (pty(), pty(), pty());
    let board = FakeBoard::spawn(sensor_pty.master);
    let _maestro = FakeMaestro::spawn(maestro_pty.master);
    let pin = Mutex::new(Some(board.pin()));
    let (sp, mp, gp) = (
        sensor_pty.path.clone(),
        maestro_pty.path.clone(),
        ground_pty.path.clone(),
    );
    let devices = Devices {
        sensor: Box::new(move || sensor_device(&sp, pin.lock().unwrap().take().expect("once"))),
        servo: Box::new(move || maestro_port(&mp)),
        ground: Box::new(move || open_port(&gp, 9_600, 1)),
    };
    let options = RunOptions {
        duration: Some(Duration::from_millis(1_500)),
        observer: None,
        busy: None,
        log_faults: Default::default(),
    };
    let summary = app::run(&config, devices, options, Arc::new(AtomicBool::new(false))).unwrap();
    let m = &summary.metrics;
    let c = m.counters;
    assert!(c.cycles > 50, "{c:?}");
    // All but the first cycle(s) after the connect have a packet waiting.
    assert!(c.packets_ok * 10 >= c.cycles * 9, "{c:?}");
    // Requested one cycle earlier: request to packet is about one period (4 ms), where an
    // immediate request on a pseudo-terminal takes well under a millisecond.
    let mean_us = m.request_to_packet.mean_ns() / 1_000;
    assert!(mean_us >= 2_000, "mean request->packet {mean_us} µs");
    drop(board);
    std::fs::remove_dir_all(&dir).unwrap();
}
