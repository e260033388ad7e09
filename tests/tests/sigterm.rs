//! SIGTERM to a running `dima sim` process (the same run as `dima sim`, built as the
//! `dima-e2e-sim` program): safe outputs at the Maestro, exit status 0, and a complete MCAP log
//! that the `mcap` crate (and the Python `mcap` package, when installed) reads back.

use std::io::Read;
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use nix::sys::signal::{kill, Signal};
use nix::unistd::Pid;

/// One simulation at a time: each wants the machine's cores for its loop and devices.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

#[test]
fn sigterm_safe_outputs_exit_0_complete_log() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = std::env::temp_dir().join(format!("dima-e2e-sigterm-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_dima-e2e-sim"))
        .args([
            "--scenario",
            "manual",
            "--duration",
            "60",
            "--plain",
            "--log-dir",
        ])
        .arg(dir.join("logs"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("dima-e2e-sim starts");
    // Driving in MANUAL from 1 s; terminate at 3 s.
    std::thread::sleep(Duration::from_secs(3));
    kill(Pid::from_raw(child.id() as i32), Signal::SIGTERM).unwrap();
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "no exit 10 s after SIGTERM"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut out = String::new();
    child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut out)
        .unwrap();
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    eprintln!("{err}\n{out}");
    assert!(status.success(), "exit status {status:?}");
    assert!(out.contains("(interrupted)"), "{out}");
    // Safe outputs at the Maestro after the signal (the simulation's steering is at 1560 µs
    // when safe).
    assert!(
        out.contains("final outputs at the Maestro: 1500/1560/1500 µs (safe)"),
        "{out}"
    );
    assert!(out.contains("PASS"), "{out}");

    // The log is complete: summary section, metadata, histogram, last record a shutdown with
    // safe outputs.
    let path = out
        .lines()
        .find_map(|l| l.strip_prefix("MCAP log: "))
        .and_then(|l| l.split(" (").next())
        .expect("log path printed")
        .to_owned();
    let bytes = std::fs::read(&path).unwrap();
    let summary = dima_log::reader::summary(&bytes)
        .unwrap()
        .expect("summary section");
    let names: Vec<_> = summary.metadata_names.iter().map(String::as_str).collect();
    for name in ["dima", "navigation", "rt_setup", "summary"] {
        assert!(names.contains(&name), "{name} missing from {names:?}");
    }
    assert!(summary
        .attachment_names
        .iter()
        .any(|a| a == "wake_latency_histogram.txt"));
    let mut last_state = None;
    let mut raw = 0u64;
    for m in dima_log::reader::messages(&bytes).unwrap() {
        match m.channel.topic.as_str() {
            "/dima/state" => last_state = Some(String::from_utf8(m.data.to_vec()).unwrap()),
            "/sensor/raw" => {
                let packet: &[u8; 132] = m.data.as_slice().try_into().unwrap();
                dima_sensorboard::SensorPacket::decode(packet).expect("replays");
                raw += 1;
            }
            _ => {}
        }
    }
    assert!(raw > 500, "{raw} raw packets");
    let last = last_state.expect("state messages");
    assert!(
        last.contains("shutdown") && last.contains("KILLED"),
        "{last}"
    );

    // The Python reader, when available (.ci/run installs it into a virtualenv).
    let python = std::env::var("DIMA_PYTHON").unwrap_or_else(|_| "python3".into());
    let has_mcap = Command::new(&python)
        .args(["-c", "import mcap"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !has_mcap {
        eprintln!(
            "skipping the Python check: `{python} -c \"import mcap\"` failed (pip install mcap)"
        );
    } else {
        let script = r#"
import sys
from mcap.reader import make_reader
counts = {}
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f)
    for schema, channel, message in reader.iter_messages():
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
    summary = reader.get_summary()
    assert summary is not None, "no summary section"
    assert len(summary.metadata_indexes) >= 3, "metadata missing"
print(counts.get("/sensor/raw", 0), counts.get("/dima/cycle", 0), counts.get("/dima/state", 0))
"#;
        let output = Command::new(&python)
            .args(["-c", script, &path])
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "python mcap: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        let text = String::from_utf8_lossy(&output.stdout);
        let counts: Vec<u64> = text
            .split_whitespace()
            .map(|n| n.parse().unwrap())
            .collect();
        eprintln!("Python mcap reads {counts:?} (raw, cycle, state messages)");
        assert_eq!(counts[0], raw, "Python reads as many raw packets");
        assert!(counts[1] > 500 && counts[2] >= 2, "{counts:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn failed_expectation_exits_1_with_the_reason() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = std::env::temp_dir().join(format!("dima-e2e-exit1-{}", std::process::id()));
    let out = Command::new(env!("CARGO_BIN_EXE_dima-e2e-sim"))
        .args(["--scenario", "manual", "--duration", "3", "--quiet"])
        .args(["--fault", "sensor:silence=1.5+1", "--log-dir"])
        .arg(dir.join("logs"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(
        stdout.contains("FAIL: ") && stdout.contains("SensorLoss"),
        "{stdout}"
    );
    let bad = Command::new(env!("CARGO_BIN_EXE_dima-e2e-sim"))
        .args(["--fault", "sensor:ber=2"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}
