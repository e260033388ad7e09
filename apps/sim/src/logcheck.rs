//! Reading the application's MCAP log back: mode changes, per-cycle records and raw packets, so
//! a run can be judged on what the application itself recorded (in its own clock).

use std::collections::BTreeSet;
use std::path::Path;

use anyhow::Context;

/// One `/dima/state` message.
#[derive(Debug, Clone, PartialEq)]
pub struct StateChange {
    /// Log time, ns since the Unix epoch.
    pub t_ns: u64,
    /// Mode after the change (`KILLED`, `MANUAL`, `AUTO`, `FAILSAFE`).
    pub mode: String,
    /// Failsafe cause, if any (`CommsLoss`, `SensorLoss`, `Overruns`).
    pub cause: Option<String>,
    /// Event names of the cycle.
    pub events: Vec<String>,
}

/// One `/dima/cycle` message, the fields the checks use.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleEntry {
    /// Log time (the cycle's wake-up), ns since the Unix epoch.
    pub t_ns: u64,
    /// Mode after the cycle.
    pub mode: String,
    /// Whether a valid packet arrived this cycle.
    pub packet_ok: bool,
    /// Valid command frames applied so far.
    pub commands: u64,
    /// Periods missed before this cycle's wake-up.
    pub missed: u64,
    /// Outputs, µs.
    pub targets_us: [u16; 3],
}

/// What a log holds.
#[derive(Debug, Clone, Default)]
pub struct LogSummary {
    /// Mode changes and device events, in order.
    pub states: Vec<StateChange>,
    /// Cycle records, in order.
    pub cycles: Vec<CycleEntry>,
    /// Fingerprints of every raw packet logged, in order.
    pub raw_packets: Vec<u64>,
    /// Metadata record names.
    pub metadata: BTreeSet<String>,
    /// Attachment names.
    pub attachments: BTreeSet<String>,
}

impl LogSummary {
    /// Reads a finished MCAP file.
    pub fn read(path: &Path) -> anyhow::Result<LogSummary> {
        let bytes =
            std::fs::read(path).with_context(|| format!("reading the log {}", path.display()))?;
        let mut out = LogSummary::default();
        let stream = mcap::MessageStream::new(&bytes)
            .with_context(|| format!("{}: not an MCAP file", path.display()))?;
        for message in stream {
            let m = message.with_context(|| format!("{}: damaged message", path.display()))?;
            match m.channel.topic.as_str() {
                "/sensor/raw" => out.raw_packets.push(crate::devices::fingerprint(&m.data)),
                "/dima/state" => {
                    let v: serde_json::Value = serde_json::from_slice(&m.data)?;
                    out.states.push(StateChange {
                        t_ns: m.log_time,
                        mode: v["mode"].as_str().unwrap_or_default().to_owned(),
                        cause: v["cause"].as_str().map(str::to_owned),
                        events: v["events"]
                            .as_array()
                            .map(|a| {
                                a.iter()
                                    .filter_map(|e| e.as_str().map(str::to_owned))
                                    .collect()
                            })
                            .unwrap_or_default(),
                    });
                }
                "/dima/cycle" => {
                    let v: serde_json::Value = serde_json::from_slice(&m.data)?;
                    let t = &v["targets_us"];
                    let target = |i: usize| t[i].as_u64().unwrap_or(0) as u16;
                    out.cycles.push(CycleEntry {
                        t_ns: m.log_time,
                        mode: v["mode"].as_str().unwrap_or_default().to_owned(),
                        packet_ok: v["packet_ok"].as_bool().unwrap_or(false),
                        commands: v["counters"]["commands"].as_u64().unwrap_or(0),
                        missed: v["missed_periods"].as_u64().unwrap_or(0),
                        targets_us: [target(0), target(1), target(2)],
                    });
                }
                _ => {}
            }
        }
        if let Some(summary) = mcap::Summary::read(&bytes)? {
            out.metadata = summary
                .metadata_indexes
                .iter()
                .map(|m| m.name.clone())
                .collect();
            out.attachments = summary
                .attachment_indexes
                .iter()
                .map(|a| a.name.clone())
                .collect();
        }
        Ok(out)
    }

    /// The modes entered, in order, without repeats.
    pub fn mode_sequence(&self) -> Vec<String> {
        let mut seq: Vec<String> = Vec::new();
        for s in &self.states {
            if seq.last() != Some(&s.mode) {
                seq.push(s.mode.clone());
            }
        }
        seq
    }

    /// Entries into FAILSAFE: time and cause.
    pub fn failsafes(&self) -> Vec<(u64, Option<String>)> {
        let mut out = Vec::new();
        let mut before = String::new();
        for s in &self.states {
            if s.mode == "FAILSAFE" && before != "FAILSAFE" {
                out.push((s.t_ns, s.cause.clone()));
            }
            before = s.mode.clone();
        }
        out
    }

    /// Periods the loop missed in cycles after `from_ns` up to and including `to_ns`.
    pub fn missed_between(&self, from_ns: u64, to_ns: u64) -> u64 {
        self.cycles
            .iter()
            .filter(|c| c.t_ns > from_ns && c.t_ns <= to_ns)
            .map(|c| c.missed)
            .sum()
    }

    /// Time of the last cycle at or before `t_ns` in which a command was applied.
    pub fn last_command_before(&self, t_ns: u64) -> Option<u64> {
        let mut last = None;
        let mut count = None;
        for c in self.cycles.iter().take_while(|c| c.t_ns <= t_ns) {
            if count.is_some_and(|n| c.commands > n) {
                last = Some(c.t_ns);
            }
            count = Some(c.commands);
        }
        last
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(t_ns: u64, mode: &str, cause: Option<&str>) -> StateChange {
        StateChange {
            t_ns,
            mode: mode.into(),
            cause: cause.map(Into::into),
            events: vec!["mode_changed".into()],
        }
    }

    fn cycle(t_ns: u64, commands: u64, missed: u64) -> CycleEntry {
        CycleEntry {
            t_ns,
            mode: "MANUAL".into(),
            packet_ok: true,
            commands,
            missed,
            targets_us: [1500, 1545, 1500],
        }
    }

    #[test]
    fn modes_failsafes_and_command_times() {
        let log = LogSummary {
            states: vec![
                state(10, "MANUAL", None),
                state(20, "MANUAL", None),
                state(30, "FAILSAFE", Some("CommsLoss")),
                state(35, "FAILSAFE", Some("CommsLoss")),
                state(40, "MANUAL", None),
                state(50, "FAILSAFE", Some("SensorLoss")),
            ],
            cycles: vec![
                cycle(1, 0, 0),
                cycle(2, 1, 0),
                cycle(3, 1, 2),
                cycle(4, 2, 0),
                cycle(5, 2, 1),
            ],
            ..LogSummary::default()
        };
        assert_eq!(
            log.mode_sequence(),
            ["MANUAL", "FAILSAFE", "MANUAL", "FAILSAFE"]
        );
        assert_eq!(
            log.failsafes(),
            vec![
                (30, Some("CommsLoss".to_owned())),
                (50, Some("SensorLoss".to_owned()))
            ]
        );
        assert_eq!(log.last_command_before(3), Some(2));
        assert_eq!(log.last_command_before(5), Some(4));
        assert_eq!(log.last_command_before(1), None);
        assert_eq!(log.missed_between(2, 5), 3);
    }

    #[test]
    fn a_missing_or_foreign_file_is_an_error_naming_it() {
        let e = LogSummary::read(Path::new("/nonexistent/x.mcap")).unwrap_err();
        assert!(format!("{e:#}").contains("/nonexistent/x.mcap"));
        let p = std::env::temp_dir().join(format!("dima-sim-not-mcap-{}", std::process::id()));
        std::fs::write(&p, b"not an mcap file").unwrap();
        assert!(LogSummary::read(&p).is_err());
        std::fs::remove_file(&p).unwrap();
    }
}
