//! The `dima` binary's configuration commands, run as a user would.

use std::process::Command;

use dima::config::Config;

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
    assert!(err.contains("loop_rate_hz"), "{err}");

    let missing = dir.join("missing.toml");
    let out = dima()
        .args(["run", "--config", missing.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.toml"));
    std::fs::remove_dir_all(&dir).unwrap();
}
