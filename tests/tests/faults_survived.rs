//! End-to-end tests of faults the robot must survive without stopping: a stalled log disk, a
//! full log disk, failing writes to the Maestro, and a wall clock that jumps; and a run longer
//! than the longest log file, split into complete files. The real
//! application runs against the simulated devices on pseudo-terminals (`dima sim --fault`),
//! and every test reads what an outside observer sees: the outputs at the simulated Maestro,
//! the application's counters and messages, and its MCAP files (also with the Python `mcap`
//! reader, when it is installed).

use std::path::{Path, PathBuf};
use std::process::{Command as Process, Stdio};

use dima_core::config::{Config, SafeOutput};
use dima_e2e::{assert_passed, simulate, simulate_with, temp_dir, ONE_AT_A_TIME};
use dima_groundlink::Command;
use dima_robot::rt::{monotonic_ns, PeriodicClock};
use dima_sim::scenario::{manual_us, pct, send, Check, Scenario};
use nix::time::{clock_gettime, ClockId};

/// Revive at 0.5 s (and again at 0.8 s), then MANUAL 60/40/50 from 1 s.
fn drive(s: &mut Scenario) {
    s.script.push(send(0.5, Command::Revive));
    // Again at 0.8 s, as an operator does when the robot refused the first: on a busy machine
    // the application can start late enough that at 0.5 s the sensor link has not yet
    // delivered the good packets a revive needs. A revive in MANUAL changes nothing.
    s.script.push(send(0.8, Command::Revive));
    s.script.push(send(1.0, Command::Throttle(pct(60))));
    s.script.push(send(1.0, Command::Steering(pct(40))));
    s.script.push(send(1.0, Command::Tail(pct(50))));
}

/// Messages of every kind in an MCAP file: (topic, JSON or raw bytes) in order, and the
/// metadata record names.
fn read_mcap(path: &Path) -> (Vec<(String, Vec<u8>)>, Vec<String>) {
    let bytes = std::fs::read(path).unwrap();
    let messages = dima_log::reader::messages(&bytes)
        .unwrap_or_else(|e| panic!("{}: {e:#}", path.display()))
        .into_iter()
        .map(|m| (m.channel.topic.clone(), m.data))
        .collect();
    let metadata = dima_log::reader::metadata(&bytes)
        .0
        .into_iter()
        .map(|m| m.name)
        .collect();
    (messages, metadata)
}

/// The Python `mcap` reader's count of messages in each file, or `None` when it is not
/// installed (`.ci/run` installs it into a virtualenv; DIMA_PYTHON names the interpreter).
fn python_counts(paths: &[PathBuf]) -> Option<Vec<u64>> {
    let python = std::env::var("DIMA_PYTHON").unwrap_or_else(|_| "python3".into());
    let has_mcap = Process::new(&python)
        .args(["-c", "import mcap"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !has_mcap {
        eprintln!("skipping the Python check: `{python} -c \"import mcap\"` failed");
        return None;
    }
    let script = r#"
import sys
from mcap.reader import make_reader
for path in sys.argv[1:]:
    with open(path, "rb") as f:
        print(sum(1 for _ in make_reader(f).iter_messages()))
"#;
    let out = Process::new(&python)
        .args(["-c", script])
        .args(paths)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "python mcap: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(
        String::from_utf8_lossy(&out.stdout)
            .split_whitespace()
            .map(|n| n.parse().unwrap())
            .collect(),
    )
}

/// The simulation's configuration (steering safe at 1560 µs) with a loop -> logger ring of
/// one second (250 records), so a stall of a few seconds overflows it.
fn small_ring_config() -> Config {
    let mut c = Config::default();
    c.channels.steering.safe = SafeOutput::PulseUs(1560);
    c.realtime.log_ring_records = 250;
    c
}

#[test]
fn a_stalled_log_disk_drops_counted_records_and_the_loop_keeps_its_period() {
    let mut s = Scenario::custom("log-stall", 10.0);
    drive(&mut s);
    s.checks = vec![
        Check::OutputsReach {
            from_s: 1.0,
            to_s: 2.0,
            targets_us: manual_us(60, 40, 50),
        },
        // Driving on throughout the stall and after it.
        Check::NeverSafe {
            from_s: 1.5,
            to_s: 10.0,
        },
        Check::Failsafes(0),
    ];
    let r = simulate_with(
        "log-stall",
        s,
        &["log:stall=3+5"],
        21,
        Some(&small_ring_config()),
    );
    assert_passed(&r);
    let c = r.app.counters;
    // 5 s at 250 Hz into a ring of 250: about 1000 records dropped, all counted.
    assert!(
        (700..=1_250).contains(&c.log_dropped),
        "log_dropped {}",
        c.log_dropped
    );
    // The loop kept its period: as many cycles as the run had periods, few missed.
    let periods = (r.ran_s * 250.0) as u64;
    assert!(
        c.cycles + c.missed_periods >= periods * 95 / 100,
        "{} cycles + {} missed in {} periods",
        c.cycles,
        c.missed_periods,
        periods
    );
    assert!(c.missed_periods <= c.cycles / 100, "{c:?}");
    // The log says so too: the cycle records after the stall carry the drop count.
    let log = r.app.log_path.as_ref().expect("a log");
    let (messages, _) = read_mcap(log);
    let last = messages
        .iter()
        .rev()
        .find(|(topic, _)| topic == "/dima/cycle")
        .expect("cycle messages");
    let v: serde_json::Value = serde_json::from_slice(&last.1).unwrap();
    assert_eq!(v["counters"]["log_dropped"].as_u64(), Some(c.log_dropped));
    // Records were dropped, not the cycles: the logged cycle numbers skip, the loop's did not.
    let logged = messages.iter().filter(|(t, _)| t == "/dima/cycle").count() as u64;
    assert!(logged + c.log_dropped >= c.cycles - 5, "{logged} logged");
}

#[test]
fn a_full_log_disk_stops_logging_once_and_resumes_in_a_new_file() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = temp_dir("log-full");
    let out = Process::new(env!("CARGO_BIN_EXE_dima-e2e-sim"))
        .args(["--scenario", "manual", "--duration", "10", "--quiet"])
        .args(["--fault", "log:full=3+3", "--log-dir"])
        .arg(dir.join("logs"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{stdout}\n{stderr}");
    // The robot kept running: the scenario (drive, no failsafe) passed.
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("logs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    files.sort_by_key(|p| p.as_os_str().len());
    assert_eq!(files.len(), 2, "{files:?}");
    let (first, resumed) = (&files[0], &files[1]);
    let stem = first.file_stem().unwrap().to_string_lossy().into_owned();
    assert_eq!(
        resumed.file_name().unwrap().to_string_lossy(),
        format!("{stem}-1.mcap")
    );
    // Exactly one message when logging stops, naming the file and the error; one when it
    // resumes.
    let stops: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("logging stops"))
        .collect();
    assert_eq!(stops.len(), 1, "{stderr}");
    assert!(
        stops[0].contains(&*first.to_string_lossy()) && stops[0].contains("No space left"),
        "{}",
        stops[0]
    );
    let resumes: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("logging resumed"))
        .collect();
    assert_eq!(resumes.len(), 1, "{stderr}");
    assert!(resumes[0].contains(&*resumed.to_string_lossy()));
    assert!(
        stdout.contains(&*resumed.to_string_lossy()),
        "the summary names the file written last"
    );
    // Both files are valid MCAP: the first ends at its last complete chunk, the second
    // starts with the configuration, the navigation record and a note, and both hold driving.
    let (a, meta_a) = read_mcap(first);
    let (b, meta_b) = read_mcap(resumed);
    assert!(meta_a.contains(&"dima".to_owned()), "{meta_a:?}");
    assert_eq!(
        meta_b[..3],
        ["dima", "navigation", "log_resumed"].map(String::from)
    );
    let cycles = |m: &[(String, Vec<u8>)]| m.iter().filter(|(t, _)| t == "/dima/cycle").count();
    // About 2-3 s before the disk filled; about 4 s after it came back (within a second).
    assert!((250..=800).contains(&cycles(&a)), "{}", cycles(&a));
    assert!((500..=1_100).contains(&cycles(&b)), "{}", cycles(&b));
    if let Some(counts) = python_counts(&files) {
        assert_eq!(counts, vec![a.len() as u64, b.len() as u64]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn maestro_write_errors_are_counted_and_a_kill_reaches_the_servos_when_writes_work_again() {
    let mut s = Scenario::custom("maestro-write-error", 9.0);
    drive(&mut s);
    // The kill comes while every write fails: the mode changes at once, the servos get it
    // as soon as the Maestro takes writes again.
    s.script.push(send(6.5, Command::Kill));
    s.checks = vec![
        Check::OutputsReach {
            from_s: 1.0,
            to_s: 2.0,
            targets_us: manual_us(60, 40, 50),
        },
        // Write errors change no mode: driving on before the kill, no failsafe.
        Check::NeverSafe {
            from_s: 1.5,
            to_s: 6.5,
        },
        Check::SafeHeld {
            from_s: 7.0,
            to_s: 9.0,
        },
        Check::ModesInOrder(vec![dima_core::Mode::Manual, dima_core::Mode::Killed]),
        Check::Failsafes(0),
    ];
    let r = simulate("maestro-write-error", s, &["maestro:write_error=3+4"], 22);
    assert_passed(&r);
    let c = r.app.counters;
    assert!(c.servo_errors >= 3, "{c:?}");
    assert!(c.servo_missing > 0, "{c:?}");
    // The simulated Maestro saw the safe targets after the window, and no driving after it.
    let safe = r.safe_us;
    let after: Vec<[u16; 3]> = r
        .evidence
        .outputs
        .iter()
        .filter(|o| o.t_s > 7.0)
        .map(|o| o.targets_qus.map(|q| q / 4))
        .collect();
    assert!(after.iter().all(|o| *o == safe), "{after:?}");
}

#[test]
fn the_loop_and_the_safety_timers_run_on_the_monotonic_clock() {
    let ts_ns = |id| {
        let t = clock_gettime(id).unwrap();
        t.tv_sec() as u64 * 1_000_000_000 + t.tv_nsec() as u64
    };
    // The loop's time source (the `now` of every safety decision and every log time) is
    // CLOCK_MONOTONIC: read between two readings of it...
    let before = ts_ns(ClockId::CLOCK_MONOTONIC);
    let loop_now = monotonic_ns();
    let after = ts_ns(ClockId::CLOCK_MONOTONIC);
    assert!(before <= loop_now && loop_now <= after);
    // ...and nowhere near the wall clock (seconds since 1970, not since boot).
    let wall = ts_ns(ClockId::CLOCK_REALTIME);
    assert!(
        wall.abs_diff(loop_now) > 1_000_000_000 * 86_400,
        "{wall} {loop_now}"
    );
    // The periodic clock sleeps to absolute CLOCK_MONOTONIC deadlines: a deadline 20 ms
    // ahead on that clock is met, neither early (it would be, at once, on CLOCK_REALTIME,
    // where that time lies decades in the past) nor a second late.
    let mut clock = PeriodicClock::new(20_000_000, monotonic_ns());
    let deadline = clock.next_deadline_ns();
    let tick = clock.wait();
    let woke = ts_ns(ClockId::CLOCK_MONOTONIC);
    assert!(woke >= deadline, "woke {} ns early", deadline - woke);
    assert!(tick.wake_ns >= deadline && tick.wake_ns - deadline < 1_000_000_000);
}

#[test]
fn a_wall_clock_jump_trips_no_failsafe() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = temp_dir("wall-clock-jump");
    // The wall clock of the simulated robot only (LD_PRELOAD, no privileges): ten years
    // behind from the start, then at 3 s another ten years back, while it drives.
    let shim = dir.join("wall_clock_jump.so");
    let built = Process::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()))
        .args(["-shared", "-fPIC", "-o"])
        .arg(&shim)
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/wall_clock_jump.c"
        ))
        .arg("-ldl")
        .status()
        .expect("a C compiler (cc) for the clock shim");
    assert!(built.success());
    const TEN_YEARS_S: i64 = 10 * 365 * 86_400;
    let out = Process::new(env!("CARGO_BIN_EXE_dima-e2e-sim"))
        .args(["--scenario", "manual", "--duration", "8", "--quiet"])
        .arg("--log-dir")
        .arg(dir.join("logs"))
        .env("LD_PRELOAD", &shim)
        .env("DIMA_WALL_OFFSET_S", (-TEN_YEARS_S).to_string())
        .env("DIMA_WALL_JUMP_AFTER_S", "3")
        .env("DIMA_WALL_JUMP_S", (-2 * TEN_YEARS_S).to_string())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    // The shim reached the application's wall clock: its log is named ten years back.
    let log: Vec<String> = std::fs::read_dir(dir.join("logs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".mcap"))
        .collect();
    let year_now: u32 = dima_log::naming::log_file_name(std::time::SystemTime::now())[5..9]
        .parse()
        .unwrap();
    assert!(
        log.len() == 1 && log[0][5..9].parse::<u32>().unwrap() + 10 <= year_now + 1,
        "{log:?}"
    );
    // Driving on, no failsafe: the comms-loss timer never saw the jump (the manual
    // scenario's checks: outputs reached, no FAILSAFE in the log).
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("0 failsafe(s)"), "{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_run_longer_than_max_file_duration_continues_in_numbered_complete_files() {
    let mut s = Scenario::custom("log-split", 23.0);
    drive(&mut s);
    s.checks = vec![
        Check::OutputsReach {
            from_s: 1.0,
            to_s: 2.0,
            targets_us: manual_us(60, 40, 50),
        },
        // Driving on across both splits.
        Check::NeverSafe {
            from_s: 1.5,
            to_s: 22.5,
        },
    ];
    let mut config = small_ring_config();
    config.realtime.log_ring_records = 4_096;
    config.log.max_file_duration_s = 10;
    let r = simulate_with("log-split", s, &[], 23, Some(&config));
    assert_passed(&r);
    assert_eq!(
        r.app.counters.log_dropped, 0,
        "records dropped: not a split test"
    );
    let last = r.app.log_path.clone().expect("a log");
    let last_name = last.file_name().unwrap().to_string_lossy().into_owned();
    // 23 s in files of 10 s: NAME.mcap, NAME-1.mcap and NAME-2.mcap, the last one open at
    // the end (the summary goes there).
    let stem = last_name
        .strip_suffix("-2.mcap")
        .unwrap_or_else(|| panic!("last file {last_name}, expected NAME-2.mcap"));
    let files: Vec<PathBuf> = ["".to_owned(), "-1".to_owned(), "-2".to_owned()]
        .iter()
        .map(|n| last.with_file_name(format!("{stem}{n}.mcap")))
        .collect();
    let mut cycles = Vec::new();
    let mut counts = Vec::new();
    for (k, path) in files.iter().enumerate() {
        let (messages, metadata) = read_mcap(path);
        // Complete and indexed: the summary section is there.
        let bytes = std::fs::read(path).unwrap();
        let summary = dima_log::reader::summary(&bytes).unwrap();
        assert!(summary.is_some(), "{}: no summary", path.display());
        assert_eq!(
            metadata[..2],
            ["dima", "navigation"].map(String::from),
            "{}",
            path.display()
        );
        if k > 0 {
            assert_eq!(
                metadata[2],
                "log_continued",
                "{}: {metadata:?}",
                path.display()
            );
        }
        counts.push(messages.len() as u64);
        for (topic, data) in &messages {
            if topic == "/dima/cycle" {
                let v: serde_json::Value = serde_json::from_slice(data).unwrap();
                cycles.push(v["cycle"].as_u64().unwrap());
            }
        }
    }
    // Every cycle logged once, in order, across the files.
    let first = cycles[0];
    let expected: Vec<u64> = (first..first + cycles.len() as u64).collect();
    assert!(
        cycles == expected,
        "cycle numbers lost or repeated at a split"
    );
    assert!(
        cycles.len() as u64 + 5 >= r.app.counters.cycles,
        "{}",
        cycles.len()
    );
    if let Some(python) = python_counts(&files) {
        assert_eq!(python, counts);
    }
    let _ = std::fs::remove_dir_all(last.parent().unwrap().parent().unwrap());
}
