//! The `dima` binary's configuration commands, run as a user would.

use std::process::Command;

use dima_robot::config::Config;

fn dima() -> Command {
    Command::new(env!("CARGO_BIN_EXE_dima"))
}

#[test]
fn print_default_parses_back_to_the_defaults() {
    let out = dima().args(["config", "--print-default"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.lines().filter(|l| l.starts_with('#')).count() > 10,
        "commented"
    );
    let parsed: Config = toml::from_str(&text).unwrap();
    assert_eq!(parsed, Config::default());
}

#[test]
fn check_reports_the_file_and_the_problem() {
    let dir = std::env::temp_dir().join(format!("dima-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.toml");
    std::fs::write(&path, "[realtime]\nloop_rate_hz = 0\n").unwrap();
    let out = dima()
        .args(["config", "--check", path.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("realtime.loop_rate_hz = 0"), "{err}");
    assert!(err.contains("10..=10000"), "the allowed range: {err}");
    assert_eq!(
        err.matches("loop_rate_hz").count(),
        1,
        "printed once: {err}"
    );
    // Into a pipe: no colour escape sequences.
    assert!(!err.contains('\x1b'), "{err:?}");

    // A count that would switch a protection off at the loop rate: both keys and the time.
    std::fs::write(&path, "[safety]\nimu_stuck_packets = 10000\n").unwrap();
    let out = dima()
        .args(["config", "--check", path.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    for needle in [
        "safety.imu_stuck_packets = 10000",
        "40 s at realtime.loop_rate_hz = 250",
        "at most 1 s (250 packets)",
    ] {
        assert!(err.contains(needle), "{err}");
    }

    // A parse error, also printed once.
    std::fs::write(&path, "[safety]\ncomms_timeout_ms = \"soon\"\n").unwrap();
    let out = dima()
        .args(["config", "--check", path.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        err.matches("invalid type").count(),
        1,
        "printed once: {err}"
    );

    let missing = dir.join("missing.toml");
    let out = dima()
        .args(["run", "--config", missing.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.toml"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sigterm_writes_safe_outputs_and_exits_zero() {
    use std::os::fd::AsFd;
    let dir = std::env::temp_dir().join(format!("dima-sigterm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut config = Config::default();
    config.realtime.priority = 0;
    config.realtime.telemetry_priority = 0;
    config.realtime.cpus = vec![];
    config.realtime.lock_memory = false;
    config.realtime.cpu_dma_latency = false;
    config.xbee.require_auth = false;
    config.log.directory = dir.clone();
    let path = dir.join("dima.toml");
    std::fs::write(&path, toml::to_string(&config).unwrap()).unwrap();

    // The Maestro on a pseudo-terminal; the sensor board and XBee are absent.
    let maestro = nix::pty::openpty(None, None).unwrap();
    let mut t = nix::sys::termios::tcgetattr(&maestro.master).unwrap();
    nix::sys::termios::cfmakeraw(&mut t);
    nix::sys::termios::tcsetattr(&maestro.master, nix::sys::termios::SetArg::TCSANOW, &t).unwrap();
    let maestro_path = nix::unistd::ttyname(&maestro.slave).unwrap();
    let child = dima()
        .args(["run", "--config", path.to_str().unwrap()])
        .args(["--maestro-port", maestro_path.to_str().unwrap()])
        .args(["--sensor-port", "/dev/dima-test-absent-sensor"])
        .args(["--xbee-port", "/dev/dima-test-absent-xbee"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1_500));
    // Drain what the Maestro got so far, then stop the app.
    let mut buf = [0u8; 4096];
    let read_all = |buf: &mut [u8]| {
        let mut got = Vec::new();
        let t0 = std::time::Instant::now();
        loop {
            if t0.elapsed() > std::time::Duration::from_secs(3) {
                break got;
            }
            let mut fds = [nix::poll::PollFd::new(
                maestro.master.as_fd(),
                nix::poll::PollFlags::POLLIN,
            )];
            if nix::poll::poll(&mut fds, nix::poll::PollTimeout::from(200u16)).unwrap_or(0) == 0 {
                break got;
            }
            match nix::unistd::read(&maestro.master, buf) {
                Ok(n) if n > 0 => got.extend_from_slice(&buf[..n]),
                _ => break got,
            }
        }
    };
    let before = read_all(&mut buf);
    std::thread::sleep(std::time::Duration::from_millis(100));
    // Safe targets (compact Set Target, 1500/1545/1500 µs) were sent while KILLED.
    assert!(
        before.windows(4).any(|w| w == [0x84, 0x00, 0x70, 0x2E]),
        "{before:02X?}"
    );
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}\n{stderr}", out.status);
    // The last write is the safe outputs, in one write: throttle, steering, tail.
    let after = read_all(&mut buf);
    let safe = [
        0x84, 0x00, 0x70, 0x2E, 0x84, 0x01, 0x24, 0x30, 0x84, 0x02, 0x70, 0x2E,
    ];
    assert!(after.ends_with(&safe), "{after:02X?}");
    assert!(stderr.contains("RT setup report"), "{stderr}");
    assert!(stderr.contains("sensor board: cannot open"), "{stderr}");
    let logs: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "mcap"))
        .collect();
    assert_eq!(logs.len(), 1);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn log_and_inspect_tools_answer_with_exit_codes_and_counts() {
    use std::io::Write;
    let dir = std::env::temp_dir().join(format!("dima-cli-tools-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Not an MCAP file: nothing can be read, a clear error and exit 1.
    let bogus = dir.join("bogus.mcap");
    std::fs::write(&bogus, b"not a log").unwrap();
    let out = dima()
        .args(["log", "info", bogus.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bogus.mcap") && err.contains("MCAP"), "{err}");

    // A command capture on stdin: two frames between noise.
    let mut capture = vec![0x55, 0x24, 0x01];
    capture.extend(dima_groundlink::Command::Revive.encode());
    capture.extend([0x24, 0x24]);
    capture.extend(dima_groundlink::Command::Kill.encode());
    let mut child = dima()
        .args(["inspect", "command"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(&capture).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    let lines: Vec<String> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(str::to_owned)
        .collect();
    assert_eq!(lines.len(), 2, "{lines:?}");
    assert!(lines[0].contains("\"Revive\"") && lines[1].contains("\"Kill\""));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("frames 2"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn keygen_writes_an_owner_only_key_once() {
    use std::os::unix::fs::PermissionsExt;
    let dir = std::env::temp_dir().join(format!("dima-keygen-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let key = dir.join("link.key");
    let out = dima()
        .args(["keygen", key.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let mode = std::fs::metadata(&key).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o600);
    let first = std::fs::read_to_string(&key).unwrap();
    assert!(dima_groundlink::v2::LinkKey::parse_hex(&first).is_ok());
    // Never over an existing key.
    let again = dima()
        .args(["keygen", key.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("exists"));
    assert_eq!(std::fs::read_to_string(&key).unwrap(), first);

    // `dima run` refuses require_auth = true without a key file, and a readable key file.
    let config = dir.join("dima.toml");
    std::fs::write(&config, "[xbee]\nrequire_auth = true\n").unwrap();
    let out = dima()
        .args(["run", "--config", config.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("key_file") && stderr.contains("dima keygen"),
        "{stderr}"
    );
    std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o644)).unwrap();
    let text = format!("[xbee]\nkey_file = \"{}\"\n", key.display());
    std::fs::write(&config, text).unwrap();
    let out = dima()
        .args(["run", "--config", config.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("chmod 600"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The recorded drive of the fixture, written again by the log writer as a run of three files
/// (split twice); returns the files in order and the number of cycles.
fn split_run(dir: &std::path::Path) -> (Vec<std::path::PathBuf>, usize) {
    use dima_log::schema::{self, METADATA_DIMA};
    use dima_log::writer::{McapLog, RunWriter};
    let fixture = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/fixtures/auto-pid-before-plugins.mcap"
    );
    let recorded = dima_log::LoggedRun::read(std::path::Path::new(fixture)).unwrap();
    let dima = recorded
        .metadata
        .iter()
        .find(|m| m.name == METADATA_DIMA)
        .unwrap();
    let pairs: Vec<(&'static str, String)> = ["version", "config"]
        .into_iter()
        .filter_map(|k| Some((k, dima.pairs.get(k)?.clone())))
        .collect();
    let first = dir.join(dima_log::naming::log_file_name(std::time::SystemTime::now()));
    let mut log = McapLog::create_file(&first).unwrap();
    log.set_time_offset(0);
    log.metadata(METADATA_DIMA, &pairs).unwrap();
    let mut run = RunWriter::new(Some(log), vec![(METADATA_DIMA.into(), pairs)], None);
    let n = recorded.cycles.len();
    for (i, c) in recorded.cycles.iter().enumerate() {
        if i == n / 3 || i == 2 * n / 3 {
            run.split_now(std::time::Instant::now());
        }
        let json = serde_json::to_vec(&c.msg).unwrap();
        run.write_record(|l| l.message_on(&schema::CYCLE, c.t_ns, &json));
    }
    run.finish().unwrap().finish().unwrap();
    (dima_log::naming::run_files(&first).unwrap(), n)
}

#[test]
fn log_tools_read_every_file_of_a_run_given_any_of_them() {
    let dir = std::env::temp_dir().join(format!("dima-cli-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (files, cycles) = split_run(&dir);
    assert_eq!(files.len(), 3, "{files:?}");
    let names: Vec<String> = files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    let run_name = names[0].trim_end_matches(".mcap");
    for given in [&files[0], &files[2]] {
        let out = dima()
            .args(["log", "info", given.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
        let text = String::from_utf8_lossy(&out.stdout);
        let line = format!("files: 3 ({})", names.join(", "));
        assert!(text.contains(&line), "given {}: {text}", given.display());
        assert!(
            text.contains(&format!("| {cycles} cycles |")),
            "given {}: {text}",
            given.display()
        );

        let out = dima()
            .args(["log", "export", given.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
        let csv = String::from_utf8_lossy(&out.stdout);
        // A header line, then one row per cycle of the whole run.
        assert_eq!(csv.lines().count(), cycles + 1, "given {}", given.display());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(&format!("read 3 files of run {run_name}")),
            "{err}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The fatal error of `dima ARGS`, which must fail: its stderr.
fn fatal_stderr(args: &[&str]) -> String {
    let out = dima().args(args).env_remove("RUST_LOG").output().unwrap();
    assert!(!out.status.success(), "{args:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Whether `line` holds something like an RFC 3339 timestamp (`2026-11-27T14:30:56`).
fn has_timestamp(line: &str) -> bool {
    let b = line.as_bytes();
    b.windows(19).any(|w| {
        let digits = |r: std::ops::Range<usize>| w[r].iter().all(u8::is_ascii_digit);
        digits(0..4)
            && w[4] == b'-'
            && digits(5..7)
            && w[7] == b'-'
            && digits(8..10)
            && w[10] == b'T'
            && digits(11..13)
            && w[13] == b':'
    })
}

#[test]
fn every_subcommand_reports_a_fatal_error_the_same_way() {
    let dir = std::env::temp_dir().join(format!("dima-cli-errors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[realtime]\nloop_rate_hz = 0\n").unwrap();
    let missing = dir.join("missing.mcap");
    let cases: [(&[&str], &str); 3] = [
        (
            &["config", "--check", bad.to_str().unwrap()],
            "realtime.loop_rate_hz = 0",
        ),
        (&["log", "info", missing.to_str().unwrap()], "missing.mcap"),
        (&["sim", "--scenario", "nope"], "unknown scenario `nope`"),
    ];
    for (args, cause) in cases {
        let err = fatal_stderr(args);
        assert!(err.starts_with("error: "), "{args:?}: {err:?}");
        assert!(err.contains(cause), "{args:?}: the cause: {err:?}");
        assert!(!has_timestamp(&err), "{args:?}: a timestamp in {err:?}");
        assert!(!err.contains("ERROR"), "{args:?}: {err:?}");
        // Into a pipe: no colour.
        assert!(!err.contains('\x1b'), "{args:?}: {err:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
