//! A reader that closes the pipe early (`dima log export FILE | head`) ends the tools quietly
//! and successfully: no `error: Broken pipe`, exit code 0.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

use dima_groundlink::{Command as LinkCommand, Percent};

const FIXTURE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/fixtures/auto-pid-before-plugins.mcap"
);

/// Runs `dima args`, reads one line of its stdout, closes the pipe, and returns the exit
/// status and stderr.
fn first_line_then_close(args: &[&str]) -> (std::process::ExitStatus, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_dima"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    // The reader is dropped here: the pipe is closed while the tool still has much to write.
    let out = child.wait_with_output().unwrap();
    (
        out.status,
        line,
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

#[test]
fn log_export_into_a_closed_pipe_ends_quietly_with_success() {
    let (status, first, stderr) = first_line_then_close(&["log", "export", FIXTURE]);
    assert!(first.starts_with("t_s,log_time_ns,cycle,"), "{first}");
    assert!(status.success(), "{status:?}: {stderr}");
    // Only what the export says anyway (the files it read, the fixture's old info frame).
    for line in stderr.lines() {
        assert!(
            line.starts_with("read 1 file of run") || line.starts_with("warning:"),
            "unexpected stderr: {stderr}"
        );
    }
    assert!(!stderr.to_lowercase().contains("broken pipe"), "{stderr}");
    assert!(!stderr.contains("error"), "{stderr}");
}

#[test]
fn inspect_into_a_closed_pipe_ends_quietly_with_success_and_nothing_on_stderr() {
    let capture = std::env::temp_dir().join(format!("dima-closed-pipe-{}.bin", std::process::id()));
    let frame = LinkCommand::Throttle(Percent::new(40).unwrap()).encode();
    // 20 000 frames: far more JSON than a pipe holds.
    std::fs::write(&capture, frame.repeat(20_000)).unwrap();
    let (status, first, stderr) =
        first_line_then_close(&["inspect", "command", capture.to_str().unwrap()]);
    std::fs::remove_file(&capture).unwrap();
    assert!(first.contains("\"command\""), "{first}");
    assert!(status.success(), "{status:?}: {stderr}");
    assert_eq!(stderr, "");
}

#[test]
fn bench_wakeup_into_a_closed_pipe_ends_quietly_with_success() {
    // About 140 kB of histogram: more than a pipe holds.
    let args = [
        "bench",
        "wakeup",
        "--duration",
        "0.3",
        "--priority",
        "0",
        "--interval-us",
        "1000",
    ];
    let (status, first, stderr) = first_line_then_close(&args);
    assert!(first.starts_with('#'), "{first}");
    assert!(status.success(), "{status:?}: {stderr}");
    assert_eq!(stderr, "");
}
