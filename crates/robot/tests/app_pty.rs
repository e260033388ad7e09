//! The whole application (`dima_robot::app::run`: supervisors, realtime loop, telemetry, logger)
//! against devices on real pseudo-terminals: manual driving, comms loss, latching, kill,
//! shutdown, and the MCAP log read back.

mod common;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::*;
use dima_groundlink::{Command, Percent};
use dima_robot::app::{self, Devices, RunOptions};

const SAFE: [u16; 3] = [6000, 6180, 6000]; // 1500, 1545, 1500 µs in quarter-µs

fn pct(v: u8) -> Percent {
    Percent::new(v).unwrap()
}

#[test]
fn manual_failsafe_latch_kill_shutdown_and_log() {
    let dir = temp_dir("app");
    let config = test_config(&dir);
    let (sensor_pty, maestro_pty, ground_pty) = (pty(), pty(), pty());
    let board = FakeBoard::spawn(sensor_pty.master);
    let maestro = FakeMaestro::spawn(maestro_pty.master);
    let pin = Mutex::new(Some(board.pin()));
    let (sp, mp, gp) = (
        sensor_pty.path.clone(),
        maestro_pty.path.clone(),
        ground_pty.path.clone(),
    );
    let devices = Devices {
        sensor: Box::new(move || {
            let p = pin.lock().unwrap().take().expect("opened once");
            sensor_device(&sp, p)
        }),
        servo: Box::new(move || maestro_port(&mp)),
        ground: Box::new(move || open_port(&gp, 9_600, 1)),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let observed = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let o = observed.clone();
    let (watch, mut watched) = LoopWatch::new(&config);
    let comms_timeout_ns = u64::from(config.safety.comms_timeout_ms) * 1_000_000;
    let period_ns = config.period_ns();
    let options = RunOptions {
        duration: None,
        observer: Some(Box::new(move |record| {
            o.fetch_add(1, Ordering::Relaxed);
            watched(record);
        })),
        busy: None,
        log_faults: Default::default(),
    };
    let runner = std::thread::spawn(move || app::run(&config, devices, options, s).expect("run"));

    // Start-up: KILLED, safe outputs at the Maestro.
    assert!(
        maestro.wait_for(SAFE, Duration::from_secs(3)).is_some(),
        "{:?}",
        maestro.first3()
    );
    let ground = FakeGround::spawn(ground_pty.master);
    std::thread::sleep(Duration::from_millis(200));

    // Revive, then manual throttle 80 %, steering 0 %, tail 100 %: the documented mapping.
    let drive = [
        Command::Throttle(pct(80)),
        Command::Steering(pct(0)),
        Command::Tail(pct(100)),
    ];
    assert!(
        revive_until_driving(&ground, &watch, &drive, Duration::from_secs(5)),
        "{:?}",
        watch.mode()
    );
    let manual = [1800 * 4, 1250 * 4, 2000 * 4];
    assert!(
        maestro.wait_for(manual, Duration::from_secs(1)).is_some(),
        "{:?}",
        maestro.first3()
    );

    // Display frames reach the ground station with the board's signed values, latitude and
    // longitude in their own slots.
    std::thread::sleep(Duration::from_millis(300));
    {
        let frames = ground.displays.lock().unwrap();
        let last = frames.last().expect("display frames");
        assert_eq!(&last.acc[1..], &[-512, 1000]);
        assert_eq!(&last.gyro[1..], &[-2, -164]);
        assert_eq!(last.mag, [-300, 200, -1000]);
        assert_eq!(last.lat_e7, -340_885_000);
        assert_eq!(last.lon_e7, 184_750_000);
        assert_eq!(last.head_mot_deg_e5, 34_870_000);
    }

    // Comms loss: no frame for 1 s -> FAILSAFE, safe outputs. When, relative to the last
    // frame's arrival, is judged from the log below.
    ground.heartbeats.store(false, Ordering::Relaxed);
    maestro
        .wait_for(SAFE, Duration::from_secs(3))
        .expect("failsafe");

    // Latched: the link comes back, manual commands change nothing...
    ground.heartbeats.store(true, Ordering::Relaxed);
    ground.send(Command::Throttle(pct(90)));
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(maestro.first3(), SAFE);
    // ...until a revive; manual values start from neutral again.
    assert!(revive_until_driving(
        &ground,
        &watch,
        &[Command::Throttle(pct(70))],
        Duration::from_secs(5)
    ));
    assert!(maestro
        .wait_for([1700 * 4, 1545 * 4, 1500 * 4], Duration::from_secs(1))
        .is_some());

    // Kill: safe outputs in the next cycle (4 ms; generous bound for CI).
    let t_kill = Instant::now();
    ground.send(Command::Kill);
    maestro
        .wait_for(SAFE, Duration::from_secs(1))
        .expect("kill");
    assert!(
        t_kill.elapsed() < Duration::from_millis(500),
        "{:?}",
        t_kill.elapsed()
    );

    // Revive (once `safety.revive_min_interval_ms` has passed since the kill: a revive
    // sooner is refused) and drive again, then stop as SIGTERM would: outputs go safe, log
    // is complete.
    let interval = dima_core::config::Config::default()
        .safety
        .revive_min_interval_ms;
    std::thread::sleep(Duration::from_millis(u64::from(interval) + 50));
    assert!(revive_until_driving(
        &ground,
        &watch,
        &[Command::Throttle(pct(100))],
        Duration::from_secs(5)
    ));
    maestro
        .wait_for([2000 * 4, 1545 * 4, 1500 * 4], Duration::from_secs(1))
        .expect("drive");
    stop.store(true, Ordering::Relaxed);
    let summary = runner.join().unwrap();
    assert!(maestro.wait_for(SAFE, Duration::from_secs(1)).is_some());
    drop(ground);

    let m = &summary.metrics.counters;
    assert_eq!(observed.load(Ordering::Relaxed), summary.records_logged);
    // Counts, not latencies: a busy machine misses periods, but every cycle it runs gets its
    // packet.
    assert!(m.cycles > 100, "{m:?}");
    assert!(m.packets_ok * 10 >= m.cycles * 9, "{m:?}");
    assert_eq!(m.packet_crc_errors, 0);
    assert!(m.failsafes >= 1);
    assert!(summary.telemetry.commands.frames > 10);
    assert_eq!(summary.telemetry.commands.rejected(), 0);

    // The MCAP log: raw packets for every good cycle, state messages, metadata, histogram.
    let path = summary.log_path.expect("log written");
    let bytes = std::fs::read(&path).unwrap();
    let mut raw = 0u64;
    let mut states = Vec::new();
    let mut cycles = Vec::new();
    for message in dima_log::reader::messages(&bytes).unwrap() {
        match message.channel.topic.as_str() {
            "/sensor/raw" => {
                assert_eq!(message.data.len(), 132);
                let p = dima_sensorboard::SensorPacket::decode(
                    message.data.as_slice().try_into().unwrap(),
                )
                .expect("raw packets replay through the decoder");
                assert_eq!(p.accel[1], -512);
                raw += 1;
            }
            "/dima/state" => {
                let v: serde_json::Value = serde_json::from_slice(&message.data).unwrap();
                states.push(v["mode"].as_str().unwrap().to_owned());
            }
            "/dima/cycle" => {
                let v: dima_log::schema::CycleMessage =
                    serde_json::from_slice(&message.data).unwrap();
                cycles.push(v);
            }
            _ => {}
        }
    }
    // Every packet the step saw is logged for replay, also a late one (stale ones passed
    // over while waiting for the answer are counted, not logged).
    assert!(raw >= m.packets_ok + m.packets_late, "{m:?}");
    assert!(
        raw <= m.packets_ok + m.packets_late + m.packets_stale,
        "{m:?}"
    );
    assert!(cycles.len() as u64 >= m.cycles);
    assert_comms_loss_on_time(&cycles, comms_timeout_ns, period_ns);
    for mode in ["MANUAL", "FAILSAFE", "KILLED"] {
        assert!(
            states.iter().any(|s| s == mode),
            "{mode} missing from {states:?}"
        );
    }
    let (metadata, attachments) = dima_log::reader::metadata(&bytes);
    assert!(attachments
        .iter()
        .any(|a| a == "wake_latency_histogram.txt"));
    let names: Vec<_> = metadata.iter().map(|m| m.name.clone()).collect();
    for name in ["dima", "rt_setup", "summary"] {
        assert!(
            names.iter().any(|n| n == name),
            "{name} missing from {names:?}"
        );
    }
    let hist = std::fs::read_to_string(path.with_extension("latency.txt")).unwrap();
    assert!(hist.contains("# Histogram Overflows:"));
    drop(board);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The first FAILSAFE in the log is a comms loss, entered at the first cycle that woke more
/// than `comms_timeout_ns` after the last command frame's logged arrival: not sooner, and no
/// later than two periods past the timeout plus the periods the log says were missed since.
fn assert_comms_loss_on_time(
    cycles: &[dima_log::schema::CycleMessage],
    comms_timeout_ns: u64,
    period_ns: u64,
) {
    let i = cycles
        .iter()
        .position(|c| c.mode == dima_core::Mode::Failsafe)
        .expect("a FAILSAFE cycle in the log");
    let failsafe = &cycles[i];
    assert_eq!(
        failsafe.cause,
        Some(dima_core::FailsafeCause::CommsLoss),
        "cycle {}",
        failsafe.cycle
    );
    let last_arrival = cycles[..=i]
        .iter()
        .flat_map(|c| c.commands.iter().map(|m| m.arrival_ns.expect("logged")))
        .max()
        .expect("commands before the failsafe");
    let missed: u64 = cycles[..=i]
        .iter()
        .filter(|c| c.wake_ns > last_arrival)
        .map(|c| u64::from(c.missed_periods))
        .sum();
    let after = failsafe.wake_ns - last_arrival;
    let ms = |ns: u64| ns as f64 / 1e6;
    // The product's rule: the link is lost once a cycle wakes more than the timeout after the
    // last frame arrived. Sooner would be a defect, not a busy host.
    assert!(
        after > comms_timeout_ns,
        "FAILSAFE (CommsLoss) too early: {:.1} ms after the last frame's arrival",
        ms(after)
    );
    let latest = comms_timeout_ns + (2 + missed) * period_ns;
    assert!(
        after <= latest,
        "FAILSAFE (CommsLoss) too late: {:.1} ms after the last frame's arrival \
         ({missed} periods missed between; at most {:.1} ms)",
        ms(after),
        ms(latest)
    );
}

#[test]
fn auto_tracks_setpoints_and_holds_the_action_through_missing_packets() {
    let dir = temp_dir("auto");
    let mut config = test_config(&dir);
    config.log.enabled = false;
    config.safety.sensor_loss_packets = 250; // 1 s at 250 Hz
    let (sensor_pty, maestro_pty, ground_pty) = (pty(), pty(), pty());
    let board = FakeBoard::spawn(sensor_pty.master);
    let maestro = FakeMaestro::spawn(maestro_pty.master);
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
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let (watch, observer) = LoopWatch::new(&config);
    let options = RunOptions {
        observer: Some(observer),
        ..RunOptions::default()
    };
    let runner = std::thread::spawn(move || app::run(&config, devices, options, s).expect("run"));
    assert!(maestro.wait_for(SAFE, Duration::from_secs(3)).is_some());
    let ground = FakeGround::spawn(ground_pty.master);
    std::thread::sleep(Duration::from_millis(200));

    // The board reports 1.02 m/s heading 348.7°; ask for 3 m/s towards 90°: the speed
    // controller opens the throttle to its 0.5 limit, the heading controller steers clockwise
    // (the short way round) to full travel.
    let setpoints = [
        Command::SpeedSetpoint { mm_s: 3_000 },
        Command::HeadingSetpoint { deg_e5: 9_000_000 },
    ];
    assert!(
        revive_until_driving(&ground, &watch, &setpoints, Duration::from_secs(5)),
        "{:?}",
        watch.mode()
    );
    let tracking = [1750 * 4, 1840 * 4, 1500 * 4];
    assert!(
        maestro.wait_for(tracking, Duration::from_secs(3)).is_some(),
        "{:?}",
        maestro.first3()
    );

    // Packets stop for less than the sensor-loss threshold: the action is held, no failsafe.
    board.silent.store(true, Ordering::Relaxed);
    let writes_before = maestro.commands.load(Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(maestro.first3(), tracking);
    assert!(
        maestro.commands.load(Ordering::Relaxed) > writes_before,
        "still refreshed"
    );
    // Past the threshold: FAILSAFE, safe outputs.
    assert!(maestro.wait_for(SAFE, Duration::from_secs(3)).is_some());

    stop.store(true, Ordering::Relaxed);
    let summary = runner.join().unwrap();
    assert_eq!(summary.metrics.counters.failsafes, 1);
    drop(ground);
    drop(board);
    std::fs::remove_dir_all(&dir).unwrap();
}
