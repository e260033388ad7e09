//! End to end under X: `dima-ground --sim` (the simulated robot of `dima sim --ground-pty`,
//! requiring ground link v2 with the key the station made for it), driven with real key events
//! (XTEST through `xdotool`): R held to revive, Up held to drive, Space to kill while R is held
//! again (a revive due while the kill is still being repeated, which the robot would refuse
//! within `safety.revive_min_interval_ms` of a kill frame), Space again. The robot's own MCAP log must show
//! MANUAL, a throttle target above neutral while Up was held, KILLED within 0.5 s of each Space,
//! MANUAL again after the second revive, the commands it accepted and only authenticated ones;
//! the station's session recording must show the robot's acknowledged mode and acknowledged
//! revives; its `--screenshot` must exist.
//!
//! What the station showed is checked against what the robot did: every servo target the
//! station received in a display frame v3 (what its sliders' text shows) is one the robot logged
//! in the second before, a throttle above neutral among them while Up was held; after each
//! Space the station raised the KILLED alert and greyed its drive controls (its recording's
//! `/ground/link` events). The station saves a screenshot per state (`--state-screenshots`) in
//! a directory the test prints; they are kept after the run.
//!
//! Needs an X display (`xvfb-run`, with `LIBGL_ALWAYS_SOFTWARE=1` for Mesa's software GL) and
//! `xdotool`. Without them the test says why and passes, except under `CI=true`, where it
//! must run and fails instead.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use dima_core::{Mode, ReviveRefusal};
use dima_ground::recording::{
    CommandRecord, DeliveryRecord, DisplayRecord, LinkRecord, TOPIC_ACK, TOPIC_COMMAND,
    TOPIC_DISPLAY, TOPIC_LINK,
};
use dima_log::schema::{CycleMessage, StateMessage, CYCLE, STATE};

/// The throttle's neutral pulse width in the robot's (default) channel table, µs.
const THROTTLE_NEUTRAL_US: u16 = 1500;

/// Waits until the station has saved a state screenshot whose name contains `state`.
fn wait_for_state_shot(dir: &Path, state: &str, timeout: Duration) {
    let t0 = Instant::now();
    loop {
        let seen = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .flatten()
            .any(|e| e.file_name().to_string_lossy().contains(state));
        if seen {
            return;
        }
        assert!(
            t0.elapsed() < timeout,
            "the station showed no `{state}` state within {timeout:?}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64
}

/// `None` when the test can run here; the reason otherwise (a failure under CI).
fn missing_prerequisite() -> Option<String> {
    if std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
        return Some("no X display (DISPLAY is unset; run under xvfb-run)".into());
    }
    let xdotool = Command::new("xdotool")
        .arg("version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
    if !xdotool.is_ok_and(|s| s.success()) {
        return Some("xdotool is missing (Debian: apt-get install xdotool)".into());
    }
    None
}

fn xdotool(args: &[&str]) -> String {
    let out = Command::new("xdotool")
        .args(args)
        .output()
        .expect("xdotool runs");
    assert!(
        out.status.success() || args[0] == "search",
        "xdotool {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).trim().to_owned()
}

/// Gives `window` the keyboard focus, trying again while it is not yet viewable (a busy
/// machine maps the window late), for at most 30 s.
fn focus(window: &str) {
    let t0 = Instant::now();
    loop {
        let ok = Command::new("xdotool")
            .args(["windowfocus", "--sync", window])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if ok && xdotool(&["getwindowfocus"]) == window {
            return;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "window {window} never took the focus"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// Kills the station if the test fails before it exits by itself.
struct Station(Child);

impl Drop for Station {
    fn drop(&mut self) {
        if self.0.try_wait().ok().flatten().is_none() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// What the test did, in Unix-epoch nanoseconds.
struct Timeline {
    up_pressed: u64,
    up_released: u64,
    space: u64,
    second_r_down: u64,
    second_space: u64,
}

fn newest_mcap(dir: &Path) -> PathBuf {
    dima_ground::sim::newest_log(dir).unwrap_or_else(|| panic!("no MCAP file in {}", dir.display()))
}

#[test]
fn keys_drive_the_simulated_robot_and_the_log_shows_it() {
    if let Some(reason) = missing_prerequisite() {
        if std::env::var("CI").is_ok_and(|v| v == "true") {
            panic!("CI=true but the GUI test cannot run: {reason}");
        }
        eprintln!("skipping the GUI end-to-end test: {reason}");
        return;
    }
    let dir = std::env::temp_dir().join(format!("dima-ground-e2e-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let screenshot = dir.join("station.png");
    // Kept after the run, to be looked at.
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR")).join("gui-e2e-screenshots");
    let _ = std::fs::remove_dir_all(&shots);

    // The robot's loop at 100 Hz (its default is 250 Hz): what this test judges is the
    // station's path from keys to the robot and back, and with software GL drawing the window
    // on a busy machine a 4 ms loop can fall behind and trip its own `Overrun` protection
    // (a revive refused, a FAILSAFE) for reasons that are not the station's. The loop's timing
    // has its own tests; the protection stays on here, at the limit for 100 Hz.
    let robot_config = dir.join("robot.toml");
    std::fs::write(
        &robot_config,
        "[realtime]\nloop_rate_hz = 100\n\n[safety]\noverrun_limit = 10\n",
    )
    .unwrap();
    let station = Command::new(env!("CARGO_BIN_EXE_dima-ground"))
        .arg("--sim")
        .arg("--robot-config")
        .arg(&robot_config)
        .arg("--sim-log-dir")
        .arg(dir.join("robot"))
        .arg("--log-dir")
        .arg(dir.join("ground"))
        .arg("--screenshot")
        .arg(&screenshot)
        .arg("--state-screenshots")
        .arg(&shots)
        .args(["--after", "24", "--window-size", "1400x900"])
        .env("LIBGL_ALWAYS_SOFTWARE", "1")
        .spawn()
        .expect("dima-ground starts");
    let mut station = Station(station);

    // The window, by its title.
    let t0 = Instant::now();
    let window = loop {
        let found = xdotool(&["search", "--name", "^DIMA ground station$"]);
        if let Some(w) = found.lines().next() {
            break w.to_owned();
        }
        assert!(
            station.0.try_wait().unwrap().is_none(),
            "dima-ground exited before its window appeared"
        );
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "no window after 30 s"
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    // Let the robot start and the link connect (the robot needs good sensor packets before
    // it accepts a revive).
    std::thread::sleep(Duration::from_secs(4));
    // Real key events: focus, then XTEST (synthetic XSendEvent events never reach winit).
    focus(&window);
    xdotool(&["keydown", "r"]);
    std::thread::sleep(Duration::from_millis(1_600));
    xdotool(&["keyup", "r"]);
    // Drive once the station shows the robot live (MANUAL in a fresh report: its state
    // screenshot is named so), not after a fixed pause: on a busy machine the revive and the
    // report that shows it can take seconds, and a key held before the revive is
    // acknowledged does not drive until it is pressed again (by design).
    wait_for_state_shot(&shots, "-live-", Duration::from_secs(15));
    let up_pressed = now_ns();
    xdotool(&["keydown", "Up"]);
    std::thread::sleep(Duration::from_millis(2_500));
    xdotool(&["keyup", "Up"]);
    let up_released = now_ns();
    std::thread::sleep(Duration::from_millis(400));
    // Kill, and revive right away: R goes down just before Space and is held, so the revive
    // comes due 0.7 s after the kill, while the station still repeats the kill.
    let second_r_down = now_ns();
    xdotool(&["keydown", "r"]);
    std::thread::sleep(Duration::from_millis(300));
    let space = now_ns();
    xdotool(&["key", "space"]);
    // Held 1.9 s in all: the revive comes due after 1 s of holding, at the first frame the
    // station draws after that, and the frame after a kill can be late (it saves a state
    // screenshot with software GL).
    std::thread::sleep(Duration::from_millis(1_600));
    xdotool(&["keyup", "r"]);
    std::thread::sleep(Duration::from_millis(2_500));
    let second_space = now_ns();
    xdotool(&["key", "space"]);
    let timeline = Timeline {
        up_pressed,
        up_released,
        space,
        second_r_down,
        second_space,
    };

    // The station takes its screenshot and exits 0, stopping the robot.
    let t1 = Instant::now();
    let status = loop {
        if let Some(s) = station.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            t1.elapsed() < Duration::from_secs(60),
            "dima-ground did not exit"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(status.success(), "dima-ground exited with {status}");

    let robot = robot_log(&newest_mcap(&dir.join("robot")));
    check_robot_log(&newest_mcap(&dir.join("robot")), &timeline);
    check_session_recording(&newest_mcap(&dir.join("ground")));
    check_truth_and_alerts(&newest_mcap(&dir.join("ground")), &robot, &timeline);
    check_screenshot(&screenshot);
    let kept = shots.join("final.png");
    std::fs::copy(&screenshot, &kept).unwrap();
    let mut saved: Vec<_> = std::fs::read_dir(&shots)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    saved.sort();
    eprintln!(
        "station screenshots, one per state, in {}:",
        shots.display()
    );
    for path in &saved {
        eprintln!("  {}", path.display());
    }
    assert!(
        saved
            .iter()
            .any(|p| p.to_string_lossy().contains("killed-greyed")),
        "no screenshot of the KILLED banner with greyed controls: {saved:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// What the robot logged: its cycles and what it did with the commands.
struct RobotLog {
    /// (log time ns, mode, throttle target µs) per cycle.
    cycles: Vec<(u64, Mode, u16)>,
    /// (log time ns, targets µs: throttle, steering, tail) per cycle.
    targets: Vec<(u64, [u16; 3])>,
    /// Commands accepted over the run, per type byte.
    accepted: [u32; 8],
    /// Its ground-link counters at the end.
    link: serde_json::Value,
    /// The revive refusals it logged.
    refusals: Vec<ReviveRefusal>,
}

fn robot_log(path: &Path) -> RobotLog {
    let bytes = std::fs::read(path).unwrap();
    let mut cycles = Vec::new();
    let mut targets = Vec::new();
    let mut accepted = [0u32; 8];
    let mut link = serde_json::Value::Null;
    let mut refusals = Vec::new();
    for m in dima_log::reader::messages(&bytes).unwrap() {
        if m.channel.topic == STATE.topic {
            let s: StateMessage = serde_json::from_slice(&m.data).unwrap();
            refusals.extend(s.refused);
        }
        if m.channel.topic == CYCLE.topic {
            let c: CycleMessage = serde_json::from_slice(&m.data).unwrap();
            cycles.push((m.log_time, c.mode, c.targets_us[0]));
            targets.push((m.log_time, c.targets_us));
            for command in &c.commands {
                accepted[usize::from(command.kind).min(7)] += 1;
            }
            let raw: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            link = raw["link"].clone();
        }
    }
    RobotLog {
        cycles,
        targets,
        accepted,
        link,
        refusals,
    }
}

/// The first cycle at or after `from` in `mode`, and how long after `from` it came, ms.
fn first_in(cycles: &[(u64, Mode, u16)], from: u64, mode: Mode) -> Option<f64> {
    cycles
        .iter()
        .find(|c| c.0 >= from && c.1 == mode)
        .map(|c| (c.0 - from) as f64 / 1e6)
}

fn check_robot_log(path: &Path, t: &Timeline) {
    let RobotLog {
        cycles,
        accepted,
        link,
        refusals,
        ..
    } = robot_log(path);
    assert!(
        cycles.len() > 1_000,
        "{} cycles in {}",
        cycles.len(),
        path.display()
    );
    let manual: Vec<&(u64, Mode, u16)> = cycles.iter().filter(|c| c.1 == Mode::Manual).collect();
    assert!(
        !manual.is_empty(),
        "the robot never went MANUAL: {}",
        path.display()
    );
    let max_while_up = cycles
        .iter()
        .filter(|c| c.0 >= t.up_pressed && c.0 <= t.up_released + 200_000_000)
        .map(|c| c.2)
        .max()
        .unwrap_or(0);
    assert!(
        max_while_up > THROTTLE_NEUTRAL_US,
        "throttle target while Up was held: at most {max_while_up} µs"
    );
    // MANUAL until Space, KILLED within 0.5 s after it.
    let before = cycles.iter().rev().find(|c| c.0 < t.space).unwrap();
    assert_eq!(before.1, Mode::Manual, "the mode when Space was pressed");
    let after_ms = first_in(&cycles, t.space, Mode::Killed).expect("KILLED after Space");
    assert!(after_ms < 500.0, "KILLED {after_ms:.1} ms after Space");
    // R held right after the kill: the revive still works (MANUAL again before the second
    // Space), and the second Space kills within 0.5 s too.
    let killed_at = t.space + (after_ms * 1e6) as u64;
    let revived_at = cycles
        .iter()
        .find(|c| c.0 >= killed_at && c.1 == Mode::Manual)
        .expect("MANUAL again after the second revive")
        .0;
    let revived_ms = (revived_at as f64 - t.second_r_down as f64) / 1e6;
    assert!(
        (1_000.0..3_000.0).contains(&revived_ms),
        "MANUAL {revived_ms:.0} ms after R went down (held 1 s to revive)"
    );
    let before = cycles.iter().rev().find(|c| c.0 < t.second_space).unwrap();
    assert_eq!(
        before.1,
        Mode::Manual,
        "the mode when Space was pressed again"
    );
    let second_ms =
        first_in(&cycles, t.second_space, Mode::Killed).expect("KILLED after the second Space");
    assert!(
        second_ms < 500.0,
        "KILLED {second_ms:.1} ms after the second Space"
    );
    eprintln!(
        "robot: MANUAL for {} cycles, throttle up to {max_while_up} µs while Up was held, \
         KILLED {after_ms:.1} ms after Space, MANUAL {revived_ms:.0} ms after R went down \
         again, KILLED {second_ms:.1} ms after the second Space; accepted per type {accepted:?}; \
         revive refusals {refusals:?}; link {link}",
        manual.len()
    );
    // The station waited long enough after the kill (a revive sooner than
    // safety.revive_min_interval_ms after it is refused).
    assert!(
        !refusals.contains(&ReviveRefusal::TooSoon),
        "revive refusals: {refusals:?}"
    );
    // The commands the robot accepted, all of them authenticated.
    assert!(accepted[1] >= 2, "kills accepted: {accepted:?}");
    assert!(accepted[2] >= 2, "revives accepted: {accepted:?}");
    assert!(accepted[3] >= 10, "throttle frames accepted: {accepted:?}");
    let count = |k: &str| {
        link[k]
            .as_u64()
            .unwrap_or_else(|| panic!("link.{k} in {link}"))
    };
    assert!(count("v2_accepted") > 50, "{link}");
    assert_eq!(count("v1_accepted"), 0, "{link}");
    // Every frame has a new number in the robot's session (kills before the session was known
    // count as kills outside the window, not as stale). Bad tags are not checked: the
    // simulation's radio drops what the robot does not read in time, which tears frames on a
    // loaded machine.
    assert_eq!(count("replayed"), 0, "{link}");
    assert_eq!(count("stale_session"), 0, "{link}");
}

fn check_session_recording(path: &Path) {
    let bytes = std::fs::read(path).unwrap();
    let mut kinds = [0u32; 8];
    let mut throttle_up = 0;
    let mut last_seq = 0;
    let mut modes: Vec<String> = Vec::new();
    let mut max_ack = 0;
    let mut revives_acknowledged = 0;
    for m in dima_log::reader::messages(&bytes).unwrap() {
        match m.channel.topic.as_str() {
            TOPIC_COMMAND => {
                let c: CommandRecord = serde_json::from_slice(&m.data).unwrap();
                kinds[usize::from(c.kind)] += 1;
                throttle_up += u32::from(c.kind == 3 && c.data > 50);
                // Ground link v2: 28-byte frames, every one with a new sequence number, and a
                // session (0 only for a kill before the robot's first frame).
                assert_eq!(
                    c.frame_hex.len(),
                    2 * dima_groundlink::v2::COMMAND_FRAME_LEN,
                    "{c:?}"
                );
                let seq = c.seq.expect("v2 frames have a sequence number");
                assert!(seq > last_seq, "sequence {seq} after {last_seq}");
                last_seq = seq;
                assert!(c.session.is_some_and(|s| s != 0 || c.kind == 1), "{c:?}");
            }
            TOPIC_DISPLAY => {
                let d: DisplayRecord = serde_json::from_slice(&m.data).unwrap();
                let robot = d.robot.expect("v2 display frames carry the robot's report");
                max_ack = max_ack.max(robot.ack_seq);
                if modes.last() != Some(&robot.mode) {
                    modes.push(robot.mode);
                }
            }
            TOPIC_ACK => {
                let a: DeliveryRecord = serde_json::from_slice(&m.data).unwrap();
                revives_acknowledged += u32::from(a.kind == 2 && a.outcome == "acknowledged");
            }
            _ => {}
        }
    }
    eprintln!(
        "station: sent per type {kinds:?}, the robot's modes {modes:?}, acknowledged up to \
         {max_ack} of {last_seq}, revives acknowledged {revives_acknowledged}"
    );
    let modes: Vec<&str> = modes.iter().map(String::as_str).collect();
    assert!(
        modes
            .windows(4)
            .any(|w| w == ["MANUAL", "KILLED", "MANUAL", "KILLED"]),
        "the robot's reported modes: {modes:?}"
    );
    assert!(
        max_ack > 0 && max_ack <= last_seq,
        "{max_ack} of {last_seq}"
    );
    assert_eq!(revives_acknowledged, 2);
    assert!(kinds[0] > 20, "heartbeats {kinds:?}");
    assert!(kinds[2] >= 2, "revives {kinds:?}");
    assert!(
        throttle_up >= 10,
        "throttle held over 2.5 s: {throttle_up} frames"
    );
    assert!(kinds[1] >= 10, "kills repeated: {kinds:?}");

    // The independent reader (the `mcap` Python package) sees the same commands.
    let python = std::env::var("DIMA_PYTHON").unwrap_or_else(|_| "python3".into());
    let has_mcap = Command::new(&python)
        .args(["-c", "import mcap"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !has_mcap {
        if std::env::var("CI").is_ok_and(|v| v == "true") {
            panic!("CI=true but `{python} -c \"import mcap\"` fails");
        }
        eprintln!(
            "skipping the Python reader: `{python} -c \"import mcap\"` failed (pip install mcap)"
        );
        return;
    }
    let script = r#"
import json, sys
from mcap.reader import make_reader
kinds = [0] * 8
topics = set()
with open(sys.argv[1], "rb") as f:
    for schema, channel, message in make_reader(f).iter_messages():
        topics.add(channel.topic)
        if channel.topic == "/ground/command":
            kinds[json.loads(message.data)["kind"]] += 1
print(" ".join(map(str, kinds)), ",".join(sorted(topics)))
"#;
    let out = Command::new(&python)
        .args(["-c", script])
        .arg(path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let mut words = text.split_whitespace();
    let python_kinds: Vec<u32> = (0..8)
        .map(|_| words.next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(
        python_kinds,
        kinds.to_vec(),
        "Python reads the same commands"
    );
    let topics = words.next().unwrap_or_default();
    for t in [
        "/ground/ack",
        "/ground/command",
        "/ground/display",
        "/ground/link",
        "/ground/rx_bytes",
    ] {
        assert!(topics.contains(t), "{t} missing from {topics}");
    }
}

/// What the station received as the robot's outputs is what the robot logged; after each
/// kill it raised the KILLED alert and greyed the drive controls.
fn check_truth_and_alerts(path: &Path, robot: &RobotLog, t: &Timeline) {
    let bytes = std::fs::read(path).unwrap();
    let mut shown: Vec<(u64, String, [u16; 3])> = Vec::new();
    let mut events: Vec<(u64, LinkRecord)> = Vec::new();
    for m in dima_log::reader::messages(&bytes).unwrap() {
        match m.channel.topic.as_str() {
            TOPIC_DISPLAY => {
                let d: DisplayRecord = serde_json::from_slice(&m.data).unwrap();
                let robot = d
                    .robot
                    .expect("v2/v3 display frames carry the robot's report");
                let servo = robot
                    .servo_us
                    .expect("the robot sends display frames v3 with its servo targets");
                shown.push((m.log_time, robot.mode, servo));
            }
            TOPIC_LINK => {
                let l: LinkRecord = serde_json::from_slice(&m.data).unwrap();
                events.push((m.log_time, l));
            }
            _ => {}
        }
    }
    assert!(shown.len() > 10, "{} display frames", shown.len());
    // Every servo target shown is one the robot commanded in the second before (the frame is
    // built from the loop's latest cycle, then crosses a 9600-baud link).
    for (at, mode, servo) in &shown {
        if *servo == [0; 3] {
            // Sent before the robot's first cycle: nothing commanded yet.
            continue;
        }
        let commanded = robot
            .targets
            .iter()
            .any(|(ct, targets)| *ct <= *at && *ct + 1_500_000_000 >= *at && targets == servo);
        assert!(
            commanded,
            "the station was shown {servo:?} µs ({mode}) at {at} that the robot did not command"
        );
    }
    let driving: Vec<u16> = shown
        .iter()
        .filter(|(at, mode, _)| {
            mode == "MANUAL" && *at >= t.up_pressed && *at <= t.up_released + 500_000_000
        })
        .map(|(_, _, servo)| servo[0])
        .collect();
    assert!(
        driving.iter().any(|&us| us > THROTTLE_NEUTRAL_US),
        "throttle shown while Up was held: {driving:?}"
    );
    // After each Space: the KILLED alert within 2 s, and the controls greyed.
    let within = |from: u64, event: &str, detail: &str| {
        events.iter().any(|(at, l)| {
            *at >= from
                && *at <= from + 2_000_000_000
                && l.event == event
                && l.detail.as_deref().is_some_and(|d| d.contains(detail))
        })
    };
    for (name, space) in [("first", t.space), ("second", t.second_space)] {
        assert!(
            within(space, "alert", "killed"),
            "no KILLED alert after the {name} Space: {events:?}"
        );
        // Greyed by the kill: the controls' state as the KILLED alert was raised (their change
        // is recorded right after the alert's). A revive held right after the kill may turn
        // them live again within seconds, so a later state says nothing about the kill.
        let alert_at = events
            .iter()
            .find(|(at, l)| {
                *at >= space
                    && l.event == "alert"
                    && l.detail.as_deref().is_some_and(|d| d.contains("killed"))
            })
            .map(|(at, _)| *at)
            .unwrap_or(space);
        let controls = events
            .iter()
            .filter(|(at, l)| *at <= alert_at + 100_000_000 && l.event == "controls")
            .filter_map(|(_, l)| l.detail.as_deref())
            .next_back();
        assert!(
            controls.is_some_and(|d| d.starts_with("drive controls off")),
            "drive controls not greyed after the {name} Space: {events:?}"
        );
    }
    // Live while it drove.
    assert!(
        within(
            t.up_pressed.saturating_sub(1_500_000_000),
            "controls",
            "live"
        ),
        "drive controls not live after the revive: {events:?}"
    );
    let alerts: Vec<&str> = events
        .iter()
        .filter(|(_, l)| l.event == "alert" || l.event == "controls")
        .filter_map(|(_, l)| l.detail.as_deref())
        .collect();
    eprintln!(
        "station: {} display frames with the robot's outputs, throttle shown while Up was held \
         up to {} µs; alerts and controls: {alerts:?}",
        shown.len(),
        driving.iter().max().unwrap()
    );
}

fn check_screenshot(path: &Path) {
    let file = std::fs::File::open(path).expect("the screenshot exists");
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert!(info.width >= 800 && info.height >= 500, "{info:?}");
    let pixels = &buf[..info.buffer_size()];
    let step = info.color_type.samples();
    let mut colours = std::collections::HashSet::new();
    for px in pixels.chunks(step) {
        colours.insert(px.to_vec());
    }
    assert!(
        colours.len() > 100,
        "{} colours: a blank window?",
        colours.len()
    );
}
