//! Every JSON message of a simulated run's MCAP log validates against the JSON schema its
//! channel declares, checked by an independent validator: the Python `jsonschema` package
//! (Draft 2020-12), reading the file with the Python `mcap` package. The run has faults that
//! leave fields empty: cycles without a packet (sensor silent), cycles without a servo write
//! (Maestro unplugged), GNSS without a fix.
//!
//! `.ci/run` installs both packages into a virtualenv; outside CI the test says what it skips
//! when they are missing, under CI (`CI` set) it fails.

use std::process::Command;

use dima_e2e::run_app;
use dima_groundlink::Command as Ground;
use dima_sim::runner::{run_simulation, SimOptions, StatusMode};
use dima_sim::scenario::{pct, send, Scenario};

const VALIDATE: &str = r#"
import json, sys
from jsonschema import Draft202012Validator
from mcap.reader import make_reader

counts, nulls, errors = {}, {"sensor": 0, "servo_write_us": 0, "request_to_packet_us": 0}, []
with open(sys.argv[1], "rb") as f:
    for schema, channel, message in make_reader(f).iter_messages():
        if channel.message_encoding != "json":
            continue
        assert schema is not None and schema.encoding == "jsonschema", channel.topic
        validator = Draft202012Validator(json.loads(schema.data))
        value = json.loads(message.data)
        for e in validator.iter_errors(value):
            errors.append(f"{channel.topic} ({schema.name}): {e.message} at {list(e.path)}")
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
        if channel.topic == "/dima/cycle":
            for key in nulls:
                nulls[key] += value[key] is None
print(json.dumps({"counts": counts, "nulls": nulls, "errors": errors[:20], "n_errors": len(errors)}))
"#;

fn python() -> Option<String> {
    let python = std::env::var("DIMA_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&python)
        .args(["-c", "import mcap, jsonschema"])
        .status()
        .is_ok_and(|s| s.success());
    if ok {
        return Some(python);
    }
    let why =
        format!("`{python} -c \"import mcap, jsonschema\"` failed (pip install mcap jsonschema)");
    assert!(std::env::var_os("CI").is_none(), "{why}");
    eprintln!("skipping the schema validation: {why}");
    None
}

#[test]
fn every_logged_message_validates_against_its_channel_schema() {
    let Some(python) = python() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("dima-e2e-schema-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut s = Scenario::custom("schema", 6.0);
    s.script.push(send(0.5, Ground::Revive));
    s.script.push(send(1.0, Ground::Throttle(pct(60))));
    s.script.push(send(4.6, Ground::Revive));
    let mut o = SimOptions::new(s);
    o.run_dir = dir.join("dev");
    o.log_dir = dir.join("logs");
    o.status = StatusMode::Quiet;
    for fault in [
        "sensor:silence=2+0.3",
        "maestro:disconnect=3+1",
        "gnss:loss=4+1",
    ] {
        o.faults.apply_arg(fault).unwrap();
    }
    let r = run_simulation(&o, run_app).expect("the simulation runs");
    let log = r.app.log_path.expect("a log");
    let out = Command::new(&python)
        .args(["-c", VALIDATE])
        .arg(&log)
        .output()
        .expect("python runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    eprintln!("jsonschema: {report}");
    assert_eq!(report["n_errors"], 0, "{report}");
    let counts = &report["counts"];
    assert!(counts["/dima/cycle"].as_u64().unwrap() >= 1_000, "{report}");
    assert!(counts["/dima/state"].as_u64().unwrap() >= 3, "{report}");
    assert!(counts["/sensor/info"].as_u64().unwrap() >= 1, "{report}");
    // The faults really produced the fields that can be empty.
    for key in ["sensor", "servo_write_us", "request_to_packet_us"] {
        assert!(
            report["nulls"][key].as_u64().unwrap() > 0,
            "{key}: {report}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
