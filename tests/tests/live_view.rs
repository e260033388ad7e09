//! The live view seen by a client that is not ours: `dima sim --foxglove ADDR` (built as the
//! `dima-e2e-sim` program) and a Foxglove WebSocket protocol client written from the protocol's
//! specification in Python (`fixtures/foxglove_client.py`, the `websockets` package only). The
//! client subscribes to `/dima/cycle` and `/dima/location`; the test checks that it decoded
//! cycle messages whose JSON parses, in increasing cycle order, and GNSS fixes where the
//! simulated receiver puts the car, with the covariance of its accuracy estimates.
//!
//! `.ci/run` installs `websockets` into its virtualenv; outside CI the test says what it skips
//! when Python or the package is missing, under CI (`CI` set) it fails.

use std::net::TcpListener;
use std::process::{Command, Stdio};

/// The client, from the protocol's specification.
const CLIENT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/foxglove_client.py");

/// A Python with the `websockets` package (`DIMA_PYTHON`, else `python3`).
fn python() -> Option<String> {
    let python = std::env::var("DIMA_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&python)
        .args(["-c", "import websockets.sync.client"])
        .status()
        .is_ok_and(|s| s.success());
    if ok {
        return Some(python);
    }
    let why =
        format!("`{python} -c \"import websockets.sync.client\"` failed (pip install websockets)");
    assert!(std::env::var_os("CI").is_none(), "{why}");
    eprintln!("skipping the live view test: {why}");
    None
}

/// A port nobody listens on now.
fn free_port() -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    listener.local_addr().unwrap().port()
}

#[test]
fn a_foxglove_client_receives_cycles_and_the_gnss_position_live() {
    let Some(python) = python() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("dima-e2e-live-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let addr = format!("127.0.0.1:{}", free_port());
    let sim = Command::new(env!("CARGO_BIN_EXE_dima-e2e-sim"))
        .args(["--scenario", "manual", "--duration", "12", "--quiet"])
        .args(["--foxglove", &addr, "--log-dir"])
        .arg(dir.join("logs"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("dima-e2e-sim starts");
    // The client waits for the server to listen, then reads for up to 8 s.
    let client = Command::new(&python)
        .arg(CLIENT)
        .arg(format!("ws://{addr}"))
        .args(["8", "200"])
        .output()
        .expect("the client runs");
    let sim = sim.wait_with_output().unwrap();
    let sim_err = String::from_utf8_lossy(&sim.stderr);
    assert!(sim.status.success(), "dima sim: {sim_err}");
    let client_err = String::from_utf8_lossy(&client.stderr);
    assert!(
        client.status.success(),
        "client: {client_err}\nsim: {sim_err}"
    );
    let seen: serde_json::Value = serde_json::from_slice(&client.stdout)
        .unwrap_or_else(|e| panic!("client output: {e}: {client_err}"));

    assert_eq!(
        seen["server"].as_str().map(|s| s.starts_with("dima")),
        Some(true)
    );
    let channels = &seen["channels"];
    assert_eq!(channels["/dima/cycle"]["encoding"], "json");
    assert_eq!(channels["/dima/cycle"]["schemaName"], "dima.Cycle");
    assert_eq!(channels["/dima/state"]["encoding"], "json");
    assert_eq!(channels["/sensor/raw"]["encoding"], "dima-sensor-v1");
    assert_eq!(
        channels["/dima/location"]["schemaName"],
        "foxglove.LocationFix"
    );
    assert_eq!(channels["/dima/location"]["encoding"], "protobuf");

    assert_eq!(
        seen["bad_json"], 0,
        "cycle messages whose JSON did not parse"
    );
    let cycles: Vec<u64> = seen["cycles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_u64().unwrap())
        .collect();
    assert!(cycles.len() >= 200, "{} cycle messages", cycles.len());
    assert!(
        cycles.windows(2).all(|w| w[0] < w[1]),
        "cycle numbers do not increase: {cycles:?}"
    );
    let times: Vec<u64> = seen["log_times"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_u64().unwrap())
        .collect();
    assert!(
        times.windows(2).all(|w| w[0] < w[1]),
        "log times: {times:?}"
    );

    let locations = seen["locations"].as_array().unwrap();
    assert!(!locations.is_empty(), "no LocationFix");
    for fix in locations {
        // The simulated receiver starts the car at 34.0885 S, 18.4750 E and reports 1.2 m
        // horizontal and 1.9 m vertical accuracy.
        let lat = fix["latitude"].as_f64().unwrap();
        let lon = fix["longitude"].as_f64().unwrap();
        assert!((lat + 34.0885).abs() < 0.01, "latitude {lat}");
        assert!((lon - 18.4750).abs() < 0.01, "longitude {lon}");
        let covariance: Vec<f64> = fix["covariance"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_f64().unwrap())
            .collect();
        assert_eq!(covariance.len(), 9, "{fix}");
        for (i, want) in [(0, 1.2f64 * 1.2), (4, 1.2 * 1.2), (8, 1.9 * 1.9)] {
            assert!((covariance[i] - want).abs() < 1e-9, "{covariance:?}");
        }
        assert_eq!(fix["covariance_type"], 2, "DIAGONAL_KNOWN");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
