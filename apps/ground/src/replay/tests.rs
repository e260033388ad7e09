use std::fs::File;
use std::io::Write;
use std::path::PathBuf;

use dima_core::counters::Counters;
use dima_core::monitor::PacketVerdict;
use dima_core::safety::{FailsafeCause, Mode, ReviveRefusal};
use dima_groundlink::v2::{self, Actuation, RobotMode};
use dima_log::schema::{
    self, ActionMessage, CycleMessage, Event, GroundLinkCounters, SensorMessage, SetpointsMessage,
    StateMessage,
};
use dima_log::writer::McapLog;

use super::source::{LogKind, ReplayEvent};
use super::*;
use crate::link::{LinkControl, LinkHandle, LinkState, RobotReport};
use crate::recording::{DisplayRecord, Recorder};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dima-ground-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const CYCLE_NS: u64 = 100_000_000;
const T0_NS: u64 = 1_700_000_000_000_000_000;

/// Cycle `n` of the test robot: KILLED for 5 cycles, MANUAL driving for 15, then FAILSAFE
/// (comms loss), the steering moving every cycle.
fn cycle(n: u64) -> CycleMessage {
    let (mode, cause) = match n {
        0..5 => (Mode::Killed, None),
        5..20 => (Mode::Manual, None),
        _ => (Mode::Failsafe, Some(FailsafeCause::CommsLoss)),
    };
    let throttle = if mode == Mode::Manual { 1600 } else { 1500 };
    CycleMessage {
        cycle: n,
        wake_ns: n * CYCLE_NS,
        mode,
        cause,
        wake_latency_us: 10.0,
        missed_periods: 0,
        packet: PacketVerdict::Ok,
        packet_ok: true,
        request_to_packet_us: None,
        t_request_ns: None,
        t_complete_ns: None,
        stale_passed: 0,
        commands: Vec::new(),
        compute_us: 5.0,
        servo_write_us: None,
        sensor: Some(SensorMessage {
            accel: [0, 0, 1020],
            gyro: [0; 3],
            mag: [0; 3],
            rhall: 0,
            press_raw: 0,
            temp_raw: 0,
            gyro_z_dps: 0.0,
            gnss_fix_ok: true,
            itow_ms: Some(0),
            lat_deg: Some(47.3769 + n as f64 * 1e-5),
            lon_deg: Some(8.5417),
            g_speed_mm_s: Some(n as i32 * 100),
            head_mot_deg: Some(0.0),
            num_sv: Some(9),
        }),
        gnss_age_ms: Some(10.0),
        setpoints: SetpointsMessage {
            throttle_pct: None,
            steering_pct: None,
            tail_pct: None,
            speed_mm_s: (mode == Mode::Manual).then_some(1_500),
            heading_deg: None,
        },
        action: ActionMessage {
            throttle: 0.0,
            steering: 0.0,
            tail: 0.0,
        },
        targets_us: [throttle, 1400 + n as u16, 1500],
        counters: Counters {
            cycles: n + 1,
            ..Counters::default()
        },
        link: GroundLinkCounters::default(),
        auto_source: None,
        waypoint: None,
        cross_track_m: None,
    }
}

/// A robot log of `cycles` cycles at 10 Hz, with a revive refused at cycle 25.
fn write_robot_log(path: &std::path::Path, cycles: u64) {
    let mut log = McapLog::create_file(path).unwrap();
    log.set_time_offset(0);
    for n in 0..cycles {
        let t = T0_NS + n * CYCLE_NS;
        let json = serde_json::to_vec(&cycle(n)).unwrap();
        log.message_on(&schema::CYCLE, t, &json).unwrap();
        if n == 25 {
            let state = StateMessage {
                cycle: n,
                mode: Mode::Failsafe,
                cause: Some(FailsafeCause::CommsLoss),
                refused: Some(ReviveRefusal::TooSoon),
                events: vec![Event::ReviveRefused],
            };
            let json = serde_json::to_vec(&state).unwrap();
            log.message_on(&schema::STATE, t, &json).unwrap();
        }
        if n % 10 == 9 {
            // A chunk a second, as the robot's logger closes them.
            log.flush().unwrap();
        }
    }
    log.finish().unwrap();
}

fn secs(s: f64) -> Duration {
    Duration::from_secs_f64(s)
}

#[test]
fn a_robot_log_replayed_to_the_end_shows_its_final_mode_and_outputs() {
    let dir = temp_dir("replay-robot");
    let path = dir.join("robot.mcap");
    write_robot_log(&path, 30);
    let mut replay = Replay::open(&path, None, None).unwrap();
    assert_eq!(replay.log().kind, LogKind::Robot);
    assert_eq!(replay.clock().duration(), secs(2.9));
    assert_eq!(
        replay.log().modes,
        [
            (secs(0.0), RobotMode::Killed),
            (secs(0.5), RobotMode::Manual),
            (secs(2.0), RobotMode::Failsafe)
        ],
        "the timeline's mode changes, as reported"
    );

    replay.clock_mut().set_speed(8.0);
    replay.clock_mut().play();
    replay.update(secs(0.0));
    assert!(replay.update(secs(100.0)));
    assert!(replay.clock().at_end() && !replay.clock().is_playing());

    // The reference: what the log itself says about its last cycle.
    let run = dima_log::run::read_run(&path).unwrap();
    let last = &run.cycles.last().unwrap().msg;
    let state = replay.state();
    let report = state.status.robot.unwrap();
    assert_eq!(report.mode, RobotMode::Failsafe);
    assert_eq!(last.mode, Mode::Failsafe);
    assert_eq!(report.failsafe_cause, Some(v2::FailsafeCause::CommsLoss));
    assert_eq!(report.revive_refusal, Some(v2::ReviveRefusal::TooSoon));
    let actuation = report.actuation.unwrap();
    assert_eq!(actuation.servo_us(), last.targets_us);
    assert_eq!(actuation.speed_setpoint_mm_s, last.setpoints.speed_mm_s);
    // 2 Hz over 2.9 s (0, 0.5, ... 2.5) and the last cycle.
    assert_eq!(state.status.frames_in, 7);
    assert_eq!(
        report.at,
        replay.now(),
        "the last report is the last cycle's"
    );
    assert_eq!(
        state.status.fresh_report(replay.now()).map(|r| r.mode),
        Some(RobotMode::Failsafe),
        "fresh at the log's own time"
    );
    let (_, frame, _) = state.telemetry.latest.unwrap();
    assert_eq!(
        frame.g_speed_mm_s,
        last.sensor.as_ref().unwrap().g_speed_mm_s.unwrap()
    );
    assert_eq!(state.telemetry.track.points().len(), 7);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn seek_lands_on_the_report_of_that_time_and_backwards_rebuilds_from_the_start() {
    let dir = temp_dir("replay-seek");
    let path = dir.join("robot.mcap");
    write_robot_log(&path, 30);
    let mut replay = Replay::open(&path, None, None).unwrap();
    let mode = |r: &Replay| r.state().status.robot.map(|r| (r.mode, r.seq));
    // Reports at 0.0, 0.5, 1.0, ...: the one at 1.0 s is the third.
    let third = replay.log().events[2].at;
    assert_eq!(third, secs(1.0));
    replay.seek(third - Duration::from_nanos(1));
    assert_eq!(mode(&replay), Some((RobotMode::Manual, 2)));
    replay.seek(third);
    assert_eq!(mode(&replay), Some((RobotMode::Manual, 3)));
    let servo = replay.state().status.robot.unwrap().actuation.unwrap();
    assert_eq!(servo.servo_us(), cycle(10).targets_us);
    assert_eq!(replay.rebuilds(), 0);

    replay.seek(secs(2.5));
    assert_eq!(mode(&replay), Some((RobotMode::Failsafe, 6)));
    replay.seek(secs(0.2));
    assert_eq!(replay.rebuilds(), 1, "backwards: rebuilt");
    assert_eq!(mode(&replay), Some((RobotMode::Killed, 1)));
    assert_eq!(replay.state().status.frames_in, 1);
    assert_eq!(replay.state().telemetry.speed.points().len(), 1);

    // Paused: the wall time moves, the log time and the state do not.
    replay.update(secs(50.0));
    assert!(!replay.update(secs(60.0)));
    assert_eq!(replay.clock().position(), secs(0.2));
    // --replay-pause-at: playing stops there.
    replay.pause_at(secs(1.2));
    replay.clock_mut().play();
    replay.update(secs(61.0));
    assert!(!replay.clock().is_playing());
    assert_eq!(replay.clock().position(), secs(1.2));
    assert_eq!(mode(&replay), Some((RobotMode::Manual, 3)));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_robot_log_cut_short_replays_up_to_the_cut() {
    let dir = temp_dir("replay-cut");
    let path = dir.join("robot.mcap");
    write_robot_log(&path, 30);
    let whole = Replay::open(&path, None, None).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    // A crash: the file ends part-way through a chunk. Every cut that keeps a whole chunk
    // replays that chunk's cycles.
    let mut partial = 0;
    for tenth in 1..10 {
        std::fs::write(&path, &bytes[..bytes.len() * tenth / 10]).unwrap();
        if let Ok(cut) = Replay::open(&path, None, None) {
            assert!(cut.log().duration <= whole.log().duration);
            assert!(!cut.log().events.is_empty());
            if cut.log().duration < whole.log().duration {
                partial += 1;
            }
        }
    }
    assert!(partial > 0, "no cut file replayed part of the log");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_backward_seek_from_a_checkpoint_shows_what_a_replay_from_the_start_shows() {
    let dir = temp_dir("replay-checkpoints");
    let path = dir.join("robot.mcap");
    write_robot_log(&path, 30);
    let mut with = Replay::open(&path, None, None).unwrap();
    with.set_checkpoint_interval(secs(0.7));
    with.seek(secs(2.9));
    // Checkpoints before 0.7, 1.4, 2.1 and 2.8 s.
    assert_eq!(with.checkpoints(), 4);
    for t in [2.6, 1.5, 0.69, 0.7, 0.0, 2.2] {
        with.seek(secs(t));
        let mut fresh = Replay::open(&path, None, None).unwrap();
        fresh.seek(secs(t));
        let (a, b) = (&with.state().status, &fresh.state().status);
        // Each replay has its own instants: the report's age, and the rest as is.
        let dummy = Instant::now();
        let report = |r: &Replay| {
            r.state().status.robot.map(|report| {
                let age = r.now().duration_since(report.at);
                (
                    age,
                    RobotReport {
                        at: dummy,
                        ..report
                    },
                )
            })
        };
        assert_eq!(report(&with), report(&fresh), "at {t} s");
        assert_eq!(
            (a.frames_in, a.bytes_in),
            (b.frames_in, b.bytes_in),
            "at {t} s"
        );
        assert_eq!(
            with.state().telemetry.speed.points(),
            fresh.state().telemetry.speed.points(),
            "at {t} s"
        );
        assert_eq!(
            with.state().telemetry.track.points(),
            fresh.state().telemetry.track.points()
        );
    }
    assert_eq!(with.checkpoints(), 4, "kept, not taken again");
    let _ = std::fs::remove_dir_all(&dir);
}

fn wait_for(what: &str, mut f: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !f() {
        assert!(t0.elapsed() < Duration::from_secs(10), "timed out: {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_station_session_replayed_shows_what_the_live_session_showed() {
    const KEY: v2::LinkKey = v2::LinkKey::from_bytes([0x3C; 16]);
    let dir = temp_dir("replay-session");
    let recorder = Recorder::start(&dir).unwrap();
    let path = recorder.path().to_owned();

    // A live session: the robot's end of a pty writes display frames v3, one damaged.
    let pair = nix::pty::openpty(None, None).unwrap();
    let mut t = nix::sys::termios::tcgetattr(&pair.master).unwrap();
    nix::sys::termios::cfmakeraw(&mut t);
    nix::sys::termios::tcsetattr(&pair.master, nix::sys::termios::SetArg::TCSANOW, &t).unwrap();
    let port = nix::unistd::ttyname(&pair.slave).unwrap();
    let mut robot = File::from(pair.master);
    let mut link = LinkHandle::spawn(Some(recorder.sender()), None, Some(KEY.clone())).unwrap();
    link.send(LinkControl::Connect {
        path: port,
        baud: 9600,
    });
    wait_for("connected", || link.status().state == LinkState::Connected);
    let frame = |seq: u32, mode| v2::DisplayFrameV3 {
        status: v2::DisplayFrame {
            mode,
            session: 0xBEEF,
            seq,
            sensors: dima_groundlink::DisplayFrame {
                g_speed_mm_s: seq as i32 * 250,
                lat_e7: 473_769_000 + seq as i32 * 100,
                lon_e7: 85_417_000,
                ..Default::default()
            },
            ..v2::DisplayFrame::default()
        },
        actuation: Actuation {
            servo_quarter_us: [6000 + seq as u16 * 4, 6000, 6000],
            ..Actuation::default()
        },
    };
    let mut sent = 0;
    for seq in 1..=8 {
        let mode = if seq < 6 {
            RobotMode::Manual
        } else {
            RobotMode::Killed
        };
        let mut bytes = frame(seq, mode).encode(&KEY).to_vec();
        if seq == 4 {
            bytes[40] ^= 0xFF; // a bad tag: counted, never shown
        } else {
            sent += 1;
        }
        robot.write_all(&bytes).unwrap();
        std::thread::sleep(Duration::from_millis(30));
    }
    wait_for("the frames", || link.status().frames_in == sent);
    link.shutdown();
    // Its final state (the thread publishes it as it ends).
    let live = link.status();
    drop(pair.slave);
    recorder.finish().unwrap();

    // Replayed with the key, event by event: after each frame the state shows what the live
    // session recorded for it.
    let mut replay = Replay::open(&path, Some(KEY), None).unwrap();
    assert_eq!(replay.log().kind, LogKind::Station);
    let reference = replay.log().displays.clone();
    assert_eq!(reference.len(), sent as usize);
    let events: Vec<Duration> = replay.log().events.iter().map(|e| e.at).collect();
    assert!(events.len() > 1);
    assert!(replay
        .log()
        .events
        .iter()
        .any(|e| matches!(e.event, ReplayEvent::Bytes(_))));
    let mut compared = 0;
    for at in events {
        replay.seek(at);
        let shown = replay.state().status.frames_in as usize;
        if shown > 0 {
            // As recorded: through JSON, as the reference went.
            let json = serde_json::to_vec(replay.state().last_display.as_ref().unwrap()).unwrap();
            let shown_record: DisplayRecord = serde_json::from_slice(&json).unwrap();
            assert_eq!(shown_record, reference[shown - 1].1, "frame {shown}");
            compared = shown;
        }
    }
    assert_eq!(compared, sent as usize);
    let end = &replay.state().status;
    assert_eq!(end.frames_in, live.frames_in);
    assert_eq!(end.bad_tag, live.bad_tag);
    assert_eq!(end.bad_tag, 1);
    assert_eq!(end.loss, live.loss);
    let (replayed, live_report) = (end.robot.unwrap(), live.robot.unwrap());
    assert_eq!(replayed.mode, RobotMode::Killed);
    assert_eq!(
        (replayed.mode, replayed.seq, replayed.actuation),
        (live_report.mode, live_report.seq, live_report.actuation)
    );
    assert_eq!(replayed.actuation.unwrap().servo_us()[0], 1508);
    let modes: Vec<RobotMode> = replay.log().modes.iter().map(|m| m.1).collect();
    assert_eq!(modes, [RobotMode::Manual, RobotMode::Killed]);

    assert_eq!(end.bytes_in, live.bytes_in);
    // The commands the session sent (heartbeats at least), counted as live.
    assert!(live.frames_out > 0);
    assert_eq!(
        (end.frames_out, end.bytes_out),
        (live.frames_out, live.bytes_out)
    );
    let sent_kinds = |s: &crate::link::LinkStatus| s.last_sent.map(|sent| sent.map(|(_, c)| c));
    assert_eq!(sent_kinds(end), sent_kinds(&live));

    // Without the key nothing of it is shown: every byte read, no frame, no robot report.
    let mut keyless = Replay::open(&path, None, None).unwrap();
    keyless.seek(keyless.clock().duration());
    let status = &keyless.state().status;
    assert_eq!((status.frames_in, status.bytes_in), (0, live.bytes_in));
    assert!(status.robot.is_none() && !status.authenticated);
    let _ = std::fs::remove_dir_all(&dir);
}
