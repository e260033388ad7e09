//! The log tools on a simulated run: export matches what the simulator produced, replay is
//! identical with the recorded configuration and differs (and says where) with new gains, a
//! log cut at any offset still reads, plots are PNGs of the asked size, and the replay's MCAP
//! file reads back with the Python `mcap` package.

use std::path::{Path, PathBuf};
use std::process::Command as Process;

use dima_core::mission::AutoSource;
use dima_core::Mode;
use dima_e2e::{run_app, ONE_AT_A_TIME};
use dima_groundlink::Command;
use dima_log::LoggedRun;
use dima_sim::runner::{run_simulation, SimOptions, SimReport, StatusMode};
use dima_sim::scenario::{pct, send, Scenario};
use dima_tools::logtools::export::{self, Channel, Format};
use dima_tools::logtools::plot::{self, What};
use dima_tools::logtools::replay;

/// A 7 s drive: revive, manual, AUTO at 2 m/s and 90°, kill. Returns the report and the log.
fn drive(dir: &Path) -> (SimReport, PathBuf) {
    let mut s = Scenario::custom("log-tools", 7.0);
    s.script.push(send(0.5, Command::Revive));
    s.script.push(send(1.0, Command::Throttle(pct(60))));
    s.script.push(send(1.0, Command::Steering(pct(40))));
    s.script
        .push(send(2.5, Command::SpeedSetpoint { mm_s: 2_000 }));
    s.script
        .push(send(2.5, Command::HeadingSetpoint { deg_e5: 9_000_000 }));
    s.script.push(send(6.5, Command::Kill));
    let mut o = SimOptions::new(s);
    o.run_dir = dir.join("dev");
    o.log_dir = dir.join("logs");
    o.status = StatusMode::Quiet;
    let r = run_simulation(&o, run_app).expect("the simulation runs");
    let log = r.app.log_path.clone().expect("a log");
    (r, log)
}

fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "a PNG signature");
    assert_eq!(&b[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

#[test]
fn export_replay_cut_files_plots_and_the_python_reader() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = std::env::temp_dir().join(format!("dima-e2e-logtools-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (r, log) = drive(&dir);
    let run = LoggedRun::read(&log).unwrap();
    assert!(run.warnings.is_empty(), "{:?}", run.warnings);

    // Export: every target the Maestro received is in the export, and the physical values are
    // those of the simulated board (1 g up, BMP280 at 12 m and 22 °C).
    let rows = export::rows(&run, Channel::Cycle, 0.0, f64::INFINITY);
    assert_eq!(rows.len(), run.cycles.len());
    let cell = |row: &[(&str, serde_json::Value)], key: &str| {
        row.iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| v.clone())
            .unwrap()
    };
    let exported: std::collections::HashSet<[u64; 3]> = rows
        .iter()
        .map(|row| {
            ["target_throttle_us", "target_steering_us", "target_tail_us"]
                .map(|k| cell(row, k).as_u64().unwrap())
        })
        .collect();
    for change in &r.evidence.outputs {
        let us = change.targets_qus.map(|q| u64::from(q / 4));
        assert!(
            exported.contains(&us),
            "Maestro saw {us:?}, not in the export"
        );
    }
    let mean = |key: &str| {
        let v: Vec<f64> = rows
            .iter()
            .filter_map(|row| cell(row, key).as_f64())
            .collect();
        assert!(v.len() > rows.len() / 2, "{key}: {} values", v.len());
        v.iter().sum::<f64>() / v.len() as f64
    };
    assert!(
        (mean("accel_z_m_s2") - 9.807).abs() < 0.3,
        "{}",
        mean("accel_z_m_s2")
    );
    // 101 325 Pa at sea level, 12 m up: 101 181 Pa (barometric formula).
    assert!(
        (mean("pressure_pa") - 101_181.0).abs() < 30.0,
        "{}",
        mean("pressure_pa")
    );
    assert!(
        (mean("temperature_c") - 22.0).abs() < 0.2,
        "{}",
        mean("temperature_c")
    );
    let mut csv = Vec::new();
    export::write(&rows, Format::Csv, &mut csv).unwrap();
    let csv = String::from_utf8(csv).unwrap();
    assert!(csv.starts_with("t_s,log_time_ns,cycle,mode,"));
    assert_eq!(csv.lines().count(), rows.len() + 1);
    let gnss = export::rows(&run, Channel::Gnss, 0.0, f64::INFINITY);
    assert!(
        (60..=75).contains(&gnss.len()),
        "10 Hz fixes over 7 s: {}",
        gnss.len()
    );

    // Replay with the recorded configuration: identical.
    let config = run.config.clone().expect("the configuration is in the log");
    let same = replay::replay(&run, &config).unwrap();
    assert_eq!(same.first_difference, None);
    assert!(same.cycles.len() + 2 >= run.cycles.len());
    // With three times the speed gain: different, first in AUTO.
    let mut tuned = config.clone();
    let kp = tuned.control.throttle.params["kp"].as_float().unwrap();
    tuned
        .control
        .throttle
        .params
        .insert("kp".into(), toml::Value::Float(kp * 3.0));
    let other = replay::replay(&run, &tuned).unwrap();
    let d = other
        .first_difference
        .clone()
        .expect("new gains change the outputs");
    assert_eq!((d.recorded.0, d.replayed.0), (Mode::Auto, Mode::Auto));
    assert_ne!(d.recorded.1[0], d.replayed.1[0], "{d:?}");
    assert!(d.t_s >= 2.0, "{d:?}");
    let replay_file = dir.join("replay.mcap");
    replay::write_mcap(&run, &other, &tuned, &replay_file).unwrap();
    let back = LoggedRun::read(&replay_file).unwrap();
    assert_eq!(back.cycles.len(), run.cycles.len());

    // Cut anywhere: never a panic; past the first chunk something is read.
    let bytes = std::fs::read(&log).unwrap();
    let mut readable = 0;
    for cut in (0..bytes.len()).step_by(bytes.len() / 97 + 1) {
        if let Ok(part) = LoggedRun::from_bytes(&bytes[..cut]) {
            readable += 1;
            assert!(part.cycles.len() <= run.cycles.len());
        }
    }
    assert!(readable > 0);

    // Plots: PNGs of the asked size.
    for what in [
        What::Imu,
        What::Gnss,
        What::Outputs,
        What::Latency,
        What::Track,
    ] {
        let png = dir.join(format!("{what:?}.png"));
        plot::plot(&run, what, &png, (1024, 600)).unwrap();
        assert_eq!(png_size(&png), (1024, 600), "{what:?}");
    }

    // The Python reader, when available (.ci/run installs it; under CI it must be there).
    let python = std::env::var("DIMA_PYTHON").unwrap_or_else(|_| "python3".into());
    let has_mcap = Process::new(&python)
        .args(["-c", "import mcap"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        has_mcap || std::env::var_os("CI").is_none(),
        "python mcap missing"
    );
    if has_mcap {
        let out = Process::new(&python)
            .args([
                "-c",
                "import sys\nfrom mcap.reader import make_reader\n\
                 n = {}\n\
                 for _, c, _ in make_reader(open(sys.argv[1], 'rb')).iter_messages():\n    \
                 n[c.topic] = n.get(c.topic, 0) + 1\n\
                 print(n.get('/dima/cycle', 0), n.get('/replay/cycle', 0))",
            ])
            .arg(&replay_file)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let counts = String::from_utf8(out.stdout).unwrap();
        assert_eq!(
            counts.trim(),
            format!("{} {}", run.cycles.len(), other.cycles.len())
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The square mission with a fence polygon 10 m outside it.
const FENCED_SQUARE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../crates/core/tests/fixtures/square-40m-fenced.plan"
);

#[test]
fn a_mission_run_logs_its_mission_and_fence_replays_with_them_and_plots_its_track() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = std::env::temp_dir().join(format!("dima-e2e-mission-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // Eight seconds of the mission: revive, AUTO, the first leg (then the timeout).
    let args = dima_sim::cli::SimArgs {
        scenario: "mission".into(),
        mission: Some(PathBuf::from(FENCED_SQUARE)),
        duration: Some(8.0),
        ..Default::default()
    };
    let mut o = args.options().unwrap();
    o.run_dir = dir.join("dev");
    o.log_dir = dir.join("logs");
    o.status = StatusMode::Quiet;
    let r = run_simulation(&o, run_app).expect("the simulation runs");
    let log = r.app.log_path.clone().expect("a log");
    let run = LoggedRun::read(&log).unwrap();
    assert!(run.warnings.is_empty(), "{:?}", run.warnings);

    // The log holds the mission and the plan's fence the robot ran with.
    let navigation = run.navigation.clone().expect("the navigation record");
    assert_eq!(navigation.mission.map(|m| m.waypoints.len()), Some(5));
    assert_eq!(navigation.fence.polygons.len(), 1);
    let following = run
        .cycles
        .iter()
        .filter(|c| c.msg.auto_source == Some(AutoSource::Mission))
        .count();
    assert!(following > 250, "{following} cycles following the mission");

    // Replay with the recorded configuration: identical, the mission included (the plan
    // file is not read again).
    let config = run.config.clone().expect("the configuration is in the log");
    let same = replay::replay(&run, &config).unwrap();
    assert_eq!(same.first_difference, None);

    // The track plot draws it.
    let png = dir.join("track.png");
    plot::plot(&run, What::Track, &png, (800, 600)).unwrap();
    assert_eq!(png_size(&png), (800, 600));
    let _ = std::fs::remove_dir_all(&dir);
}
