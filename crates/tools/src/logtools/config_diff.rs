//! The configuration values two configurations disagree on, key by key, so that
//! `dima log replay --config` names what differs from the recorded configuration before it
//! names an output that differs: a replay with a configuration written from the defaults (or
//! for another car) differs in more than the gain the user changed.

use dima_core::config::Config;
use toml::Value;

/// One configuration value that differs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigDifference {
    /// Dotted key, as in the TOML file (`control.steering.kp`, `channels.steering.safe_us`).
    pub key: String,
    /// The recorded value, as TOML (`-`: absent).
    pub recorded: String,
    /// The value given, as TOML (`-`: absent).
    pub given: String,
    /// Whether the control step reads it, so it can change the replayed outputs.
    pub read_by_step: bool,
}

/// Sections and keys the control step reads (`dima_core::Core::new`): the safety limits, the
/// channels' output mapping, the controllers, the estimator, the loop period and the sensor
/// link's timing. Everything else (device ports, reopen intervals, realtime scheduling, the
/// log, the live view, the servo board) only matters on the robot.
const READ_BY_STEP: &[&str] = &[
    "safety.",
    "channels.",
    "control.",
    "estimator.",
    "realtime.loop_rate_hz",
    "sensor.baud",
    "sensor.stop_bits",
    "sensor.wire_tolerance_us",
    "sensor.packet_deadline_us",
    "sensor.request_ahead",
];

/// Whether the control step reads `key`: the safety limits, channels, controllers, estimator,
/// loop rate and sensor link timing.
pub fn read_by_step(key: &str) -> bool {
    READ_BY_STEP.iter().any(|p| {
        if p.ends_with('.') {
            key.starts_with(p)
        } else {
            key == *p || key.starts_with(&format!("{p}."))
        }
    })
}

/// Every key whose value differs between `recorded` and `given`: first those the control step
/// reads, then the others, each group in key order.
pub fn differences(recorded: &Config, given: &Config) -> Vec<ConfigDifference> {
    let flat = |c: &Config| {
        let mut out = Vec::new();
        if let Ok(v) = Value::try_from(c) {
            flatten("", &v, &mut out);
        }
        out.into_iter()
            .collect::<std::collections::BTreeMap<_, _>>()
    };
    let (a, b) = (flat(recorded), flat(given));
    let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    let mut out: Vec<ConfigDifference> = keys
        .into_iter()
        .filter(|k| a.get(*k) != b.get(*k))
        .map(|k| ConfigDifference {
            key: k.clone(),
            recorded: a.get(k).map_or("-".to_owned(), Value::to_string),
            given: b.get(k).map_or("-".to_owned(), Value::to_string),
            read_by_step: read_by_step(k),
        })
        .collect();
    out.sort_by(|x, y| (!x.read_by_step, &x.key).cmp(&(!y.read_by_step, &y.key)));
    out
}

/// Leaves of `value` as `(dotted key, value)`; arrays are leaves.
fn flatten(prefix: &str, value: &Value, out: &mut Vec<(String, Value)>) {
    match value {
        Value::Table(t) => {
            for (k, v) in t {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, v, out);
            }
        }
        leaf => out.push((prefix.to_owned(), leaf.clone())),
    }
}

/// The lines `dima log replay` prints before the outputs: each value the step reads that
/// differs, then one line naming the values that differ but do not change a replay.
pub fn report(differences: &[ConfigDifference]) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let (read, unread): (Vec<_>, Vec<_>) = differences.iter().partition(|d| d.read_by_step);
    if read.is_empty() {
        out += "configuration: every value the control step reads is as recorded\n";
    } else {
        let _ = writeln!(
            out,
            "configuration: {} value{} the control step reads differ{} from the recorded one:",
            read.len(),
            if read.len() == 1 { "" } else { "s" },
            if read.len() == 1 { "s" } else { "" },
        );
        let width = read.iter().map(|d| d.key.len()).max().unwrap_or(0);
        for d in &read {
            let _ = writeln!(
                out,
                "  {:<width$}  recorded {}, replayed {}",
                d.key, d.recorded, d.given
            );
        }
    }
    if !unread.is_empty() {
        let keys: Vec<&str> = unread.iter().map(|d| d.key.as_str()).collect();
        let _ = writeln!(
            out,
            "  ({} more differ{} that the replay does not read: {})",
            unread.len(),
            if unread.len() == 1 { "s" } else { "" },
            keys.join(", ")
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_changed_gain_comes_before_device_settings_and_equal_values_are_not_listed() {
        let recorded = Config::default();
        let mut given = recorded.clone();
        given.sensor.port = "/dev/ttyUSB7".into();
        given.realtime.priority = 10;
        given.safety.gnss_timeout_ms += 100;
        let d = differences(&recorded, &given);
        let keys: Vec<&str> = d.iter().map(|d| d.key.as_str()).collect();
        assert_eq!(
            keys,
            ["safety.gnss_timeout_ms", "realtime.priority", "sensor.port"]
        );
        assert!(d[0].read_by_step && !d[1].read_by_step && !d[2].read_by_step);
        assert_eq!(
            d[0].given,
            (recorded.safety.gnss_timeout_ms + 100).to_string()
        );
        let text = report(&d);
        assert!(
            text.starts_with("configuration: 1 value the control step reads differs"),
            "{text}"
        );
        assert!(
            text.contains(
                "2 more differ that the replay does not read: realtime.priority, sensor.port"
            ),
            "{text}"
        );
        assert!(differences(&recorded, &recorded).is_empty());
        assert!(report(&[]).contains("every value the control step reads is as recorded"));
    }

    #[test]
    fn the_keys_the_step_reads() {
        for key in [
            "channels.steering.safe_us",
            "control.steering.kp",
            "realtime.loop_rate_hz",
            "sensor.baud",
        ] {
            assert!(read_by_step(key), "{key}");
        }
        for key in [
            "sensor.port",
            "realtime.priority",
            "log.directory",
            "xbee.key_file",
        ] {
            assert!(!read_by_step(key), "{key}");
        }
    }
}
