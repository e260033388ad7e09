//! The device threads on real pseudo-terminals, driven from the application's side of the link
//! with plain file I/O and the project's codecs.

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use dima_groundlink::v2::{self, LinkKey};
use dima_groundlink::{Command, CommandDecoder, DisplayFrame};
use dima_sensorboard::{Frame, StreamDecoder};
use dima_sim::board::BoardConfig;
use dima_sim::devices::*;
use dima_sim::faults::{FaultSpec, SensorFaults};
use dima_sim::model::VehicleParams;
use dima_sim::pty::{LinePace, SimPty};
use dima_sim::request::{RequestLine, RequestPin};
use dima_sim::rng::SimRng;
use dima_sim::scenario::send;
use dima_sim::world::World;
use embedded_hal::digital::OutputPin;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("dima-sim-dev-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn open_app_side(path: &Path) -> File {
    OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(nix::libc::O_NONBLOCK)
        .open(path)
        .unwrap()
}

/// Reads until `want` bytes or the timeout.
fn read_for(f: &mut File, want: usize, timeout: Duration) -> Vec<u8> {
    let t0 = Instant::now();
    let mut out = Vec::new();
    let mut buf = [0u8; 512];
    while out.len() < want && t0.elapsed() < timeout {
        match f.read(&mut buf) {
            Ok(n) if n > 0 => out.extend_from_slice(&buf[..n]),
            _ => std::thread::sleep(Duration::from_millis(1)),
        }
    }
    out
}

fn world() -> Arc<World> {
    Arc::new(World::new(VehicleParams::default(), 0.0))
}

#[test]
fn board_answers_each_rising_edge_with_a_packet_and_an_info_piece() {
    let d = dir("board");
    let link = d.join("sensor");
    let line = RequestLine::new();
    let stats = Arc::new(BoardStats::default());
    let stop = Arc::new(AtomicBool::new(false));
    let board = spawn_board(
        world(),
        line.clone(),
        LinkPort::open(&link).unwrap(),
        BoardSetup {
            config: BoardConfig::default(),
            link_faults: FaultSpec::default(),
            sensor_faults: SensorFaults::default(),
            pace: LinePace::new(460_800, 11),
        },
        SimRng::new(1),
        stats.clone(),
        stop.clone(),
    )
    .unwrap();
    let mut app = open_app_side(&link);
    let mut pin = RequestPin::new(line);
    // Nothing unrequested.
    assert!(read_for(&mut app, 1, Duration::from_millis(100)).is_empty());
    let mut decoder = StreamDecoder::new();
    let mut frames = Vec::new();
    // Nine answers carry the nine info pieces of the first snapshot.
    for _ in 0..9 {
        let requested = Instant::now();
        pin.set_high().unwrap();
        let bytes = read_for(&mut app, 132, Duration::from_secs(2));
        // Paced like the UART: 132 bytes x 11 bits at 460 800 baud take 3 151 µs.
        let took = requested.elapsed();
        assert!(took >= Duration::from_micros(3_151), "{took:?}");
        pin.set_low().unwrap();
        let mut input = bytes.as_slice();
        std::thread::sleep(Duration::from_millis(20));
        let more = read_for(&mut app, 1_000, Duration::from_millis(20));
        let mut rest = more.as_slice();
        while let Some(f) = decoder.feed(&mut input) {
            frames.push(f);
        }
        while let Some(f) = decoder.feed(&mut rest) {
            frames.push(f);
        }
    }
    stop.store(true, Ordering::Relaxed);
    board.join().unwrap();
    let packets = frames
        .iter()
        .filter(|f| matches!(f, Frame::Packet(_)))
        .count();
    let infos = frames
        .iter()
        .filter(|f| matches!(f, Frame::Info(_)))
        .count();
    assert_eq!((packets, infos), (9, 1), "{frames:?}");
    assert!(
        matches!(frames[9], Frame::Info(_)),
        "the record right after the ninth packet"
    );
    assert_eq!(decoder.stats().info_pieces, 9);
    assert_eq!(stats.requests.load(Ordering::Relaxed), 9);
    assert_eq!(stats.packets_intact.load(Ordering::Relaxed), 9);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn maestro_decodes_targets_and_drives_the_model() {
    let d = dir("maestro");
    let link = d.join("maestro");
    let w = world();
    let stats = Arc::new(MaestroStats::default());
    let stop = Arc::new(AtomicBool::new(false));
    let t = spawn_maestro(
        w.clone(),
        LinkPort::open(&link).unwrap(),
        [0, 1, 2],
        FaultSpec::default(),
        SimRng::new(1),
        stats.clone(),
        stop.clone(),
    )
    .unwrap();
    let mut app = open_app_side(&link);
    // Compact Set Target, three channels in one write (what the application sends):
    // throttle 1750 µs, steering 1545 µs, tail 1500 µs, plus a stray byte in between.
    let mut bytes = Vec::new();
    for (ch, us) in [(0u8, 1750u16), (1, 1545), (2, 1500)] {
        let q = us * 4;
        bytes.extend_from_slice(&[0x84, ch, (q & 0x7F) as u8, (q >> 7) as u8]);
        bytes.push(0x11);
    }
    app.write_all(&bytes).unwrap();
    let t0 = Instant::now();
    while stats.targets_of([0, 1, 2]) != [7000, 6180, 6000] && t0.elapsed() < Duration::from_secs(2)
    {
        std::thread::sleep(Duration::from_millis(5));
    }
    assert_eq!(stats.targets_of([0, 1, 2]), [7000, 6180, 6000]);
    assert_eq!(stats.commands.load(Ordering::Relaxed), 3);
    assert!(stats.dropped_bytes.load(Ordering::Relaxed) >= 3);
    std::thread::sleep(Duration::from_millis(500));
    // Throttle +0.5 of travel: the car accelerates towards 5 m/s.
    assert!(w.state().speed_m_s > 2.0, "{:?}", w.state());
    stop.store(true, Ordering::Relaxed);
    t.join().unwrap();
    assert_eq!(stats.history().len(), 1);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn ground_station_sends_script_and_heartbeats_and_reads_display_frames() {
    let d = dir("ground");
    let link = d.join("xbee");
    let stats = Arc::new(GroundStats::default());
    let stop = Arc::new(AtomicBool::new(false));
    let t = spawn_ground(
        world(),
        LinkPort::open(&link).unwrap(),
        vec![
            send(0.0, Command::Revive),
            ScriptStep {
                at_s: 0.5,
                action: GroundAction::Silence,
            },
        ],
        GroundProtocol::V1 {
            heartbeat: Command::Heartbeat.encode(),
        },
        FaultSpec::default(),
        LinePace::new(9_600, 10),
        SimRng::new(1),
        stats.clone(),
        stop.clone(),
    )
    .unwrap();
    let mut app = open_app_side(&link);
    app.write_all(&DisplayFrame::default().encode()).unwrap();
    let bytes = read_for(&mut app, 10_000, Duration::from_millis(900));
    let mut decoder = CommandDecoder::new();
    let commands: Vec<Command> = decoder.feed(&bytes).map(|c| c.unwrap()).collect();
    stop.store(true, Ordering::Relaxed);
    t.join().unwrap();
    assert_eq!(commands[0], Command::Revive);
    // One frame per 100 ms until the silence at 0.5 s.
    assert!((4..=6).contains(&commands.len()), "{commands:?}");
    assert!(commands[1..].iter().all(|c| *c == Command::Heartbeat));
    assert_eq!(stats.displays.load(Ordering::Relaxed), 1);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn v2_ground_station_learns_the_session_then_sends_authenticated_frames() {
    let key = LinkKey::from_bytes([0x42; 16]);
    let d = dir("ground-v2");
    let link = d.join("xbee");
    let stats = Arc::new(GroundStats::default());
    let stop = Arc::new(AtomicBool::new(false));
    let t = spawn_ground(
        world(),
        LinkPort::open(&link).unwrap(),
        vec![send(0.0, Command::Kill), send(0.0, Command::Revive)],
        GroundProtocol::V2 { key: key.clone() },
        FaultSpec::default(),
        LinePace::new(9_600, 10),
        SimRng::new(1),
        stats.clone(),
        stop.clone(),
    )
    .unwrap();
    let mut app = open_app_side(&link);
    // Before the station knows the session only the kill goes out, with session 0.
    let early = read_for(&mut app, 10_000, Duration::from_millis(350));
    let mut decoder = v2::CommandDecoder::new(key.clone());
    let frames: Vec<v2::CommandFrame> = decoder.feed(&early).map(|f| f.unwrap()).collect();
    assert_eq!(frames.len(), 1, "{frames:?}");
    assert_eq!((frames[0].command, frames[0].session), (Command::Kill, 0));
    let display = v2::DisplayFrame {
        session: 0xDEAD_BEEF,
        seq: 1,
        ..v2::DisplayFrame::default()
    };
    app.write_all(&display.encode(&key)).unwrap();
    let later = read_for(&mut app, 10_000, Duration::from_millis(450));
    let frames: Vec<v2::CommandFrame> = decoder.feed(&later).map(|f| f.unwrap()).collect();
    // The revive, repeated in every slot until the robot acknowledges it, every frame naming
    // the first; numbered on from the kill's 1.
    assert!(frames.len() >= 3, "{frames:?}");
    assert!(frames
        .iter()
        .all(|f| (f.command, f.request) == (Command::Revive, 2)));
    assert!(frames.iter().all(|f| f.session == 0xDEAD_BEEF));
    let seqs: Vec<u32> = frames.iter().map(|f| f.seq).collect();
    assert_eq!(seqs, (2..2 + frames.len() as u32).collect::<Vec<_>>());
    // The robot acts on it: heartbeats from then on.
    let manual = v2::DisplayFrame {
        mode: v2::RobotMode::Manual,
        seq: 2,
        ack_seq: 2,
        ..display
    };
    app.write_all(&manual.encode(&key)).unwrap();
    let _ = read_for(&mut app, 10_000, Duration::from_millis(150));
    let after = read_for(&mut app, 10_000, Duration::from_millis(350));
    let frames: Vec<v2::CommandFrame> = decoder.feed(&after).map(|f| f.unwrap()).collect();
    stop.store(true, Ordering::Relaxed);
    t.join().unwrap();
    assert!(frames.len() >= 2, "{frames:?}");
    assert!(
        frames.iter().all(|f| f.command == Command::Heartbeat),
        "{frames:?}"
    );
    assert_eq!(stats.displays.load(Ordering::Relaxed), 2);
    let status = lock_status(&stats);
    assert_eq!(status.map(|s| s.session), Some(0xDEAD_BEEF));
    // Every frame's command other than the heartbeats went out on record.
    let sent: Vec<Command> = stats.commands.lock().unwrap().iter().map(|c| c.1).collect();
    assert_eq!(sent[0], Command::Kill);
    assert!(sent.len() >= 4 && sent[1..].iter().all(|c| *c == Command::Revive));
    std::fs::remove_dir_all(&d).unwrap();
}

fn lock_status(stats: &GroundStats) -> Option<v2::DisplayFrame> {
    stats
        .last_status
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .map(|(_, frame)| frame)
}

#[test]
fn relay_joins_the_application_and_a_gui_pty() {
    let d = dir("relay");
    let robot_link = d.join("xbee");
    let station = SimPty::open(&d.join("station")).unwrap();
    let station_path = station.device_path().to_owned();
    let stop = Arc::new(AtomicBool::new(false));
    let t = spawn_relay(
        world(),
        LinkPort::open(&robot_link).unwrap(),
        station,
        FaultSpec::default(),
        LinePace::new(9_600, 10),
        SimRng::new(1),
        stop.clone(),
    )
    .unwrap();
    let mut robot = open_app_side(&robot_link);
    let mut gui = open_app_side(&station_path);
    gui.write_all(&Command::Kill.encode()).unwrap();
    assert_eq!(
        read_for(&mut robot, 10, Duration::from_secs(2)),
        Command::Kill.encode()
    );
    robot.write_all(&[1, 2, 3]).unwrap();
    assert_eq!(read_for(&mut gui, 3, Duration::from_secs(2)), [1, 2, 3]);
    stop.store(true, Ordering::Relaxed);
    t.join().unwrap();
    std::fs::remove_dir_all(&d).unwrap();
}
