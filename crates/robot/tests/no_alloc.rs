//! The realtime thread never allocates: a counting global allocator counts, per thread, every
//! allocation, reallocation and deallocation, and the loop thread must make none over thousands
//! of cycles with real devices on pseudo-terminals, commands arriving through the real telemetry
//! thread, packets decoded through the sensor-board crate, the AUTO controller running, servo
//! targets written through the Maestro crate's encoder, records going to the real MCAP logger,
//! and the shutdown write at the end.

mod common;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::time::Duration;

use common::counting_alloc::{CountingAllocator, COUNTING, EVENTS};
use common::*;
use dima_groundlink::{Command, Percent};
use dima_robot::app::{LoopEnds, LoopParams, RealtimeLoop};
use dima_robot::devices::{device_link, spawn_supervisors};
use dima_robot::logging::{spawn_logger, LoggerSettings, McapLog};
use dima_robot::rt::{monotonic_ns, PeriodicClock, RtSettings, RtSetup};
use dima_robot::telemetry::{spawn_telemetry, LinkCounters, LinkSecurity, TelemetrySettings};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[test]
fn the_allocator_counts() {
    COUNTING.with(|c| c.set(true));
    let v = std::hint::black_box(vec![1u8; 10]);
    drop(v);
    COUNTING.with(|c| c.set(false));
    assert_eq!(EVENTS.with(|n| n.get()), 2);
}

#[test]
fn realtime_thread_never_allocates() {
    const CYCLES: u64 = 3_000;
    let dir = temp_dir("noalloc");
    let mut config = test_config(&dir);
    config.realtime.loop_rate_hz = 500;
    // 132 bytes x 11 bits at 1.5 Mbaud: 968 µs on the wire.
    config.sensor.baud = 1_500_000;
    config.sensor.packet_deadline_us = 1_700;
    config.maestro.servo_refresh_hz = 50;
    config.validate().unwrap();

    let (sensor_pty, maestro_pty, ground_pty) = (pty(), pty(), pty());
    let board = FakeBoard::spawn_with_wire_time(
        sensor_pty.master,
        Duration::from_nanos(config.packet_wire_ns()),
    );
    let maestro = FakeMaestro::spawn(maestro_pty.master);
    let pin = Mutex::new(Some(board.pin()));
    let (sp, mp, gp) = (
        sensor_pty.path.clone(),
        maestro_pty.path.clone(),
        ground_pty.path.clone(),
    );

    let (mut sensor_sup, sensor_link) = device_link(
        "sensor board",
        Box::new(move || sensor_device(&sp, pin.lock().unwrap().take().expect("once"))),
        Duration::from_millis(100),
    );
    let (mut servo_sup, servo_link) = device_link(
        "Maestro",
        Box::new(move || maestro_port(&mp)),
        Duration::from_millis(100),
    );
    let aux_stop = Arc::new(AtomicBool::new(false));
    let supervisors = spawn_supervisors(
        vec![
            Box::new(move |now| sensor_sup.service(now)),
            Box::new(move |now| servo_sup.service(now)),
        ],
        aux_stop.clone(),
    )
    .unwrap();
    let (commands_tx, commands_rx) = rtrb::RingBuffer::new(config.realtime.command_ring);
    let (log_tx, log_rx) = rtrb::RingBuffer::new(config.realtime.log_ring_records);
    let (snap_in, snap_out) = triple_buffer::triple_buffer(&Default::default());
    let (_report_tx, report_rx) = mpsc::channel();
    let logger_stop = Arc::new(AtomicBool::new(false));
    let logger = spawn_logger(
        Some(McapLog::create(&dir).unwrap()),
        log_rx,
        report_rx,
        LoggerSettings {
            flush_interval: Duration::from_millis(200),
            decoded_every: 1,
            ..LoggerSettings::default()
        },
        logger_stop.clone(),
        None,
    )
    .unwrap();
    let link_counters = Arc::new(LinkCounters::default());
    let telemetry = spawn_telemetry(
        Box::new(move || open_port(&gp, 9_600, 1)),
        commands_tx,
        snap_out,
        TelemetrySettings {
            display_period: Duration::from_millis(100),
            reopen_interval: Duration::from_millis(100),
            priority: 0,
            security: LinkSecurity::from_config(&config.xbee).unwrap(),
            controllers: Default::default(),
        },
        link_counters.clone(),
        aux_stop.clone(),
    )
    .unwrap();
    // Devices connected before the loop starts, so every cycle does the full work.
    std::thread::sleep(Duration::from_millis(300));
    let ground = FakeGround::spawn(ground_pty.master);

    let params = LoopParams::from_config(&config).expect("a valid configuration");
    let period = params.period_ns;
    let stop = Arc::new(AtomicBool::new(false));
    let ends = LoopEnds {
        commands: commands_rx,
        log: log_tx,
        snapshot: snap_in,
        link: link_counters,
        stop: stop.clone(),
    };
    let settings = RtSettings::from(&config.realtime);
    let rt = std::thread::spawn(move || {
        let _setup = RtSetup::apply(&settings);
        let mut rt_loop = RealtimeLoop::new(params, ends, sensor_link, servo_link, false);
        let mut clock = PeriodicClock::new(period, monotonic_ns());
        COUNTING.with(|c| c.set(true));
        let cycles = rt_loop.run(&mut clock, Some(CYCLES));
        COUNTING.with(|c| c.set(false));
        (cycles, EVENTS.with(|n| n.get()), rt_loop.metrics().clone())
    });

    // Drive the robot meanwhile: revive, manual, AUTO (the controller runs), kill, revive.
    std::thread::sleep(Duration::from_millis(300));
    ground.send(Command::Revive);
    ground.send(Command::Throttle(Percent::new(60).unwrap()));
    std::thread::sleep(Duration::from_millis(1_000));
    ground.send(Command::SpeedSetpoint { mm_s: 3_000 });
    ground.send(Command::HeadingSetpoint { deg_e5: 9_000_000 });
    std::thread::sleep(Duration::from_millis(2_000));
    ground.send(Command::Kill);
    std::thread::sleep(Duration::from_millis(200));
    ground.send(Command::Revive);

    let (cycles, allocations, metrics) = rt.join().unwrap();
    aux_stop.store(true, Ordering::Relaxed);
    telemetry.join().unwrap();
    supervisors.join().unwrap();
    logger_stop.store(true, Ordering::Release);
    let outcome = logger.join().unwrap();
    outcome.log.unwrap().finish().unwrap();

    let c = metrics.counters;
    eprintln!("{}", metrics.summary());
    assert_eq!(cycles, CYCLES);
    assert_eq!(
        allocations, 0,
        "the realtime thread allocated {allocations} times"
    );
    // The work really happened.
    assert!(c.packets_ok > CYCLES / 2, "{c:?}");
    assert!(c.servo_writes > 100, "{c:?}");
    assert!(c.commands >= 6, "{c:?}");
    assert_eq!(c.log_dropped, 0);
    assert!(maestro.commands.load(Ordering::Relaxed) > 100);
    assert!(outcome.records >= CYCLES);
    drop(ground);
    drop(board);
    std::fs::remove_dir_all(&dir).unwrap();
}
