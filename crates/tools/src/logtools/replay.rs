//! `dima log replay FILE [--config CONFIG] [-o OUT.mcap]`: the recorded inputs of every cycle
//! (commands with their arrival times, raw packets with their request and completion times, missed periods) fed through
//! the real decoder and the pure control step, pull-driven: no pacing, no threads, no devices.
//! With the recorded configuration the modes and servo targets must come out identical; with
//! another one (new gains) the replayed outputs are written beside the recorded ones.

use std::collections::BTreeSet;
use std::path::Path;

use anyhow::Context;
use dima_core::config::Config;
use dima_core::monitor::PacketVerdict;
use dima_core::step::{CycleInputs, SensorInput};
use dima_core::{Core, CoreState, Mode, ReceivedCommand};
use dima_log::schema::{self, ActionMessage, CycleMessage, Event, ReplayMessage};
use dima_log::writer::{Channel, McapLog};
use dima_sensorboard::RawPacket;

use super::read::{LoggedRun, Timed};

/// One replayed cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayedCycle {
    /// Log time of the recorded cycle, ns.
    pub t_ns: u64,
    /// What the step decided now, beside what it decided then.
    pub message: ReplayMessage,
}

/// The first cycle where the replay differs from the recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Difference {
    /// Cycle number.
    pub cycle: u64,
    /// Seconds since the first cycle.
    pub t_s: f64,
    /// Recorded mode and targets.
    pub recorded: (Mode, [u16; 3]),
    /// Replayed mode and targets.
    pub replayed: (Mode, [u16; 3]),
}

/// What a replay found.
#[derive(Debug, Clone)]
pub struct Replay {
    /// Every replayed cycle.
    pub cycles: Vec<ReplayedCycle>,
    /// The first difference, if any.
    pub first_difference: Option<Difference>,
    /// Cycles that differ.
    pub differing: usize,
}

/// What the sensor phase of a recorded cycle brought in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecordedSensor {
    /// A packet as received, with its request and completion times.
    Packet {
        /// The 132 bytes.
        bytes: [u8; 132],
        /// Request line raised, ns.
        t_request_ns: u64,
        /// Packet complete, ns.
        t_complete_ns: u64,
    },
    /// Requested at `t_request_ns`, nothing by the deadline.
    NoAnswer {
        /// Request line raised, ns.
        t_request_ns: u64,
    },
    /// No request.
    NotRequested,
    /// The port failed.
    DeviceError,
}

/// One cycle's inputs as recorded, and what the step decided then.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedCycle {
    /// Log time, ns.
    pub t_ns: u64,
    /// Cycle number.
    pub cycle: u64,
    /// Wake-up time (the step's `now`), ns.
    pub wake_ns: u64,
    /// Periods missed before the wake-up.
    pub missed_periods: u32,
    /// Commands handed to the step, with their arrival times.
    pub commands: Vec<ReceivedCommand>,
    /// The sensor phase.
    pub sensor: RecordedSensor,
    /// Stale packets passed over.
    pub stale_packets: u32,
    /// Recorded mode.
    pub mode: Mode,
    /// Recorded servo targets, µs.
    pub targets_us: [u16; 3],
}

impl RecordedCycle {
    /// The sensor input, through the real decoder (the CRC is checked again).
    pub fn sensor_input(&self) -> anyhow::Result<SensorInput> {
        Ok(match self.sensor {
            RecordedSensor::Packet {
                bytes,
                t_request_ns,
                t_complete_ns,
            } => SensorInput::Packet {
                raw: RawPacket::new(bytes)
                    .map_err(|e| anyhow::anyhow!("cycle {}: raw packet: {e:?}", self.cycle))?,
                t_request_ns,
                t_complete_ns,
            },
            RecordedSensor::NoAnswer { t_request_ns } => SensorInput::NoAnswer { t_request_ns },
            RecordedSensor::NotRequested => SensorInput::NotRequested,
            RecordedSensor::DeviceError => SensorInput::DeviceError,
        })
    }
}

/// The recorded cycles of `run` in order (the shutdown record left out), and whether the run
/// started with a failed required realtime setup.
pub fn recorded_cycles(run: &LoggedRun) -> anyhow::Result<(Vec<RecordedCycle>, bool)> {
    let events_of = |event: Event| -> BTreeSet<u64> {
        run.states
            .iter()
            .filter(|s| s.msg.events.contains(&event))
            .map(|s| s.msg.cycle)
            .collect()
    };
    let shutdown = events_of(Event::Shutdown);
    let realtime_fault = !events_of(Event::RealtimeSetupFailed).is_empty();
    let mut out = Vec::with_capacity(run.cycles.len());
    for c in &run.cycles {
        let m = &c.msg;
        if shutdown.contains(&m.cycle) && m.packet == PacketVerdict::NotRequested {
            continue; // the shutdown record, not a cycle of the loop
        }
        anyhow::ensure!(
            m.cycle == out.len() as u64,
            "cycle {} after {} cycles: replay needs every cycle logged (log.decoded_every = 1)",
            m.cycle,
            out.len()
        );
        out.push(RecordedCycle {
            t_ns: c.t_ns,
            cycle: m.cycle,
            wake_ns: m.wake_ns,
            missed_periods: m.missed_periods,
            commands: m
                .commands
                .iter()
                .filter_map(|c| c.received(m.wake_ns))
                .collect(),
            sensor: recorded_sensor(m, run.raw.get(&c.t_ns))?,
            stale_packets: m.stale_passed,
            mode: m.mode,
            targets_us: m.targets_us,
        });
    }
    Ok((out, realtime_fault))
}

fn recorded_sensor(c: &CycleMessage, raw: Option<&[u8; 132]>) -> anyhow::Result<RecordedSensor> {
    Ok(match c.packet {
        PacketVerdict::Ok | PacketVerdict::Stale | PacketVerdict::Late => RecordedSensor::Packet {
            bytes: *raw.with_context(|| format!("cycle {}: raw packet missing", c.cycle))?,
            t_request_ns: c.t_request_ns.unwrap_or(0),
            t_complete_ns: c.t_complete_ns.unwrap_or(0),
        },
        PacketVerdict::Missing => match c.t_request_ns {
            Some(t_request_ns) => RecordedSensor::NoAnswer { t_request_ns },
            None => RecordedSensor::NotRequested,
        },
        PacketVerdict::NotRequested => RecordedSensor::NotRequested,
        PacketVerdict::DeviceError => RecordedSensor::DeviceError,
    })
}

/// Replays `run` through the step configured by `config`, with the mission and the fence the
/// robot ran with (the log's `navigation` record; logs written before it: the configured
/// fence and no mission).
pub fn replay(run: &LoggedRun, config: &Config) -> anyhow::Result<Replay> {
    let mut core = Core::new(config)?;
    if let Some(navigation) = &run.navigation {
        core.set_navigation(navigation);
    }
    let (cycles, realtime_fault) = recorded_cycles(run)?;
    let mut state = CoreState {
        realtime_fault,
        ..CoreState::new()
    };
    let mut out = Replay {
        cycles: Vec::with_capacity(cycles.len()),
        first_difference: None,
        differing: 0,
    };
    for c in &cycles {
        let inputs = CycleInputs {
            missed_periods: c.missed_periods,
            commands: &c.commands,
            sensor: c.sensor_input()?,
            stale_packets: c.stale_packets,
        };
        let o = core.step(&mut state, &inputs, c.wake_ns);
        let message = ReplayMessage {
            cycle: c.cycle,
            mode: o.mode,
            cause: o.cause,
            action: ActionMessage {
                throttle: o.action.throttle,
                steering: o.action.steering,
                tail: o.action.tail,
            },
            estimate: o.estimate,
            targets_us: o.targets.pulse_us,
            recorded_mode: c.mode,
            recorded_targets_us: c.targets_us,
        };
        if (o.mode, o.targets.pulse_us) != (c.mode, c.targets_us) {
            out.differing += 1;
            out.first_difference.get_or_insert(Difference {
                cycle: c.cycle,
                t_s: run.seconds(c.t_ns),
                recorded: (c.mode, c.targets_us),
                replayed: (o.mode, o.targets.pulse_us),
            });
        }
        out.cycles.push(ReplayedCycle {
            t_ns: c.t_ns,
            message,
        });
    }
    Ok(out)
}

/// Name of the metadata record that holds the configuration a comparison file was replayed
/// with (key `config`, TOML), beside the recorded one in [`schema::METADATA_DIMA`].
pub const METADATA_REPLAY: &str = "replay";

/// Writes a comparison file at `path`: the recorded log (cycles on `/dima/cycle`, states,
/// sensor info frames, raw packets, the recorded `dima` metadata with its configuration and
/// the `navigation` record)
/// and the replayed cycles on `/replay/cycle`, on the recorded time axis, with the
/// configuration of the replay in the metadata record [`METADATA_REPLAY`]. `dima log info`,
/// `export`, `plot` and `config` read it as a log; `--channel replay` reads the replayed
/// cycles.
pub fn write_mcap(
    run: &LoggedRun,
    replay: &Replay,
    config: &Config,
    path: &Path,
) -> anyhow::Result<()> {
    let specs = [
        &schema::SENSOR_RAW,
        &schema::CYCLE,
        &schema::STATE,
        &schema::SENSOR_INFO,
        &schema::REPLAY,
    ];
    let channels = specs.map(|spec| Channel {
        spec: *spec,
        schema: schema::schema_of(spec),
    });
    let mut w = McapLog::create_with_channels(path, channels.to_vec())?;
    // The times given are log times already.
    w.set_time_offset(0);
    for name in [schema::METADATA_DIMA, schema::METADATA_NAVIGATION] {
        if let Some(m) = run.metadata.iter().find(|m| m.name == name) {
            let pairs: Vec<(&str, String)> = m
                .pairs
                .iter()
                .map(|(k, v)| (k.as_str(), v.clone()))
                .collect();
            w.metadata(name, &pairs)?;
        }
    }
    w.metadata(METADATA_REPLAY, &[("config", toml::to_string(config)?)])?;
    for (t_ns, packet) in &run.raw {
        w.message_on(&schema::SENSOR_RAW, *t_ns, packet)?;
    }
    for c in &run.cycles {
        w.message_on(&schema::CYCLE, c.t_ns, &serde_json::to_vec(&c.msg)?)?;
    }
    for s in &run.states {
        w.message_on(&schema::STATE, s.t_ns, &serde_json::to_vec(&s.msg)?)?;
    }
    for i in &run.infos {
        w.message_on(&schema::SENSOR_INFO, i.t_ns, &serde_json::to_vec(&i.msg)?)?;
    }
    for r in &replay.cycles {
        w.message_on(&schema::REPLAY, r.t_ns, &serde_json::to_vec(&r.message)?)?;
    }
    w.finish()?;
    Ok(())
}

/// The replayed cycles (`/replay/cycle`) of the files `run` was read from, in order: what a
/// comparison file from [`write_mcap`] holds beside the recorded cycles. Empty for a robot's
/// own log (and for a run read from bytes, which has no files).
///
/// # Errors
/// A file cannot be read again, or a replayed cycle does not parse.
pub fn read_replayed(run: &LoggedRun) -> anyhow::Result<Vec<Timed<ReplayMessage>>> {
    let mut out = Vec::new();
    for file in &run.files {
        let bytes =
            std::fs::read(file).with_context(|| format!("cannot read {}", file.display()))?;
        // A cut file is read as far as it goes, as the rest of the run was.
        let _ = dima_log::reader::for_each_message(&bytes, |m| {
            if m.channel.topic == schema::REPLAY.topic {
                let msg = serde_json::from_slice(&m.data).with_context(|| {
                    format!("{}: {} at {}", file.display(), m.channel.topic, m.log_time)
                })?;
                out.push(Timed {
                    t_ns: m.log_time,
                    msg,
                });
            }
            Ok(())
        });
    }
    Ok(out)
}

/// The configuration text a log recorded: the `config` of its `dima` metadata record (what
/// the robot ran), or with `replayed` the configuration a comparison file was replayed with.
pub fn recorded_config_text(run: &LoggedRun, replayed: bool) -> Option<&str> {
    let name = if replayed {
        METADATA_REPLAY
    } else {
        schema::METADATA_DIMA
    };
    run.metadata
        .iter()
        .filter(|m| m.name == name)
        .find_map(|m| m.pairs.get("config"))
        .map(String::as_str)
}

/// `steering 1560 -> 1545 µs, mode AUTO -> FAILSAFE`: what differs in `d`, output by output.
pub fn describe(d: &Difference) -> String {
    let mut parts = Vec::new();
    if d.recorded.0 != d.replayed.0 {
        parts.push(format!("mode {} -> {}", d.recorded.0, d.replayed.0));
    }
    for (i, name) in ["throttle", "steering", "tail"].iter().enumerate() {
        if d.recorded.1[i] != d.replayed.1[i] {
            parts.push(format!(
                "{name} {} -> {} µs",
                d.recorded.1[i], d.replayed.1[i]
            ));
        }
    }
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use dima_core::Command;

    use super::*;

    /// A drive logged before commands carried their arrival times.
    fn old_log() -> LoggedRun {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/fixtures/auto-pid-before-plugins.mcap"
        );
        LoggedRun::read(Path::new(path)).unwrap()
    }

    #[test]
    fn commands_replay_with_their_logged_arrival_or_else_the_cycle_time() {
        let mut run = old_log();
        let config = run.config.clone().unwrap();
        let i = run
            .cycles
            .iter()
            .position(|c| {
                c.msg
                    .commands
                    .iter()
                    .any(|m| m.command() == Some(Command::Revive))
            })
            .unwrap();
        let wake_ns = run.cycles[i].msg.wake_ns;
        let (cycles, _) = recorded_cycles(&run).unwrap();
        assert!(!cycles[i].commands.is_empty());
        assert!(cycles[i].commands.iter().all(|c| c.arrival_ns == wake_ns));
        assert_eq!(replay(&run, &config).unwrap().differing, 0);

        // The same drive with the revive's cycle taking its commands 2 s after they arrived:
        // the replay reads those times, and the step does not act on them.
        for m in &mut run.cycles[i].msg.commands {
            m.arrival_ns = Some(wake_ns - 2_000_000_000);
        }
        let (cycles, _) = recorded_cycles(&run).unwrap();
        assert!(cycles[i]
            .commands
            .iter()
            .all(|c| c.arrival_ns == wake_ns - 2_000_000_000));
        let replayed = replay(&run, &config).unwrap();
        let first = replayed
            .first_difference
            .expect("a stale revive does not revive");
        assert_eq!(first.cycle, cycles[i].cycle);
        assert_eq!(first.replayed.0, Mode::Killed);
    }

    /// The recorded configuration of `run` with the speed controller's gain `kp`.
    fn with_throttle_kp(run: &LoggedRun, kp: f64) -> Config {
        let mut v = toml::Value::try_from(run.config.as_ref().unwrap()).unwrap();
        v["control"]["throttle"]["kp"] = toml::Value::Float(kp);
        Config::from_toml(&toml::to_string(&v).unwrap(), "test").unwrap()
    }

    fn temp_path(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!(
            "dima-replay-unit-{}-{name}-{:?}.mcap",
            std::process::id(),
            std::thread::current().id()
        ))
    }

    #[test]
    fn a_comparison_file_holds_the_replayed_cycles_and_both_configurations() {
        let run = old_log();
        let tuned = with_throttle_kp(&run, 0.9);
        let result = replay(&run, &tuned).unwrap();
        assert!(
            result.differing > 0,
            "a new gain changes the outputs in AUTO"
        );
        let path = temp_path("compare");
        write_mcap(&run, &result, &tuned, &path).unwrap();
        let compare = dima_log::run::read_run(&path).unwrap();
        let replayed = read_replayed(&compare).unwrap();

        // The replayed cycles, as replayed; the recorded log beside them.
        assert_eq!(replayed.len(), result.cycles.len());
        assert_eq!(replayed[1500].msg, result.cycles[1500].message);
        assert_eq!(compare.cycles.len(), run.cycles.len());
        assert_eq!(compare.states.len(), run.states.len());
        assert_eq!(compare.raw.len(), run.raw.len());
        // Both configurations: the recorded one as the robot wrote it, and the replayed one.
        assert_eq!(
            recorded_config_text(&compare, false),
            recorded_config_text(&run, false)
        );
        let replayed_config =
            Config::from_toml(recorded_config_text(&compare, true).unwrap(), "replay").unwrap();
        assert_eq!(replayed_config, tuned);
        assert_eq!(recorded_config_text(&run, true), None);

        // `--channel replay` exports them beside the recorded outputs and setpoints.
        use crate::logtools::export::{rows, Channel};
        let rows = rows(&compare, Channel::Replay, 0.0, f64::INFINITY);
        assert_eq!(rows.len(), result.cycles.len());
        let cell = |row: &Vec<(&'static str, serde_json::Value)>, name: &str| {
            row.iter().find(|(k, _)| *k == name).unwrap().1.clone()
        };
        let d = result.first_difference.as_ref().unwrap();
        let row = &rows[usize::try_from(d.cycle).unwrap()];
        assert_eq!(cell(row, "cycle"), serde_json::json!(d.cycle));
        assert_eq!(
            cell(row, "target_throttle_us"),
            serde_json::json!(d.replayed.1[0])
        );
        assert_eq!(
            cell(row, "recorded_target_throttle_us"),
            serde_json::json!(d.recorded.1[0])
        );
        assert!(cell(row, "speed_setpoint_mm_s").is_i64(), "{row:?}");
        std::fs::remove_file(&path).unwrap();
        // A robot's own log has no replayed cycles.
        assert!(
            crate::logtools::export::rows(&run, Channel::Replay, 0.0, f64::INFINITY).is_empty()
        );
    }

    #[test]
    fn replay_names_the_changed_configuration_before_the_outputs() {
        let run = old_log();
        let recorded = run.config.clone().unwrap();
        // A configuration written from the defaults with the gain changed: the steering's safe
        // position (and more) differ too, and the report says so first.
        let mut from_defaults = with_throttle_kp(&run, 0.9);
        from_defaults.channels = Config::default().channels;
        from_defaults.sensor.port = "/dev/ttyTHS1".into();
        let result = replay(&run, &from_defaults).unwrap();
        let path = Path::new("drive.mcap");
        let (text, code) = crate::logtools::replay_report(&run, &from_defaults, &result, path);
        assert_eq!(code, std::process::ExitCode::from(1));
        let lines: Vec<&str> = text.lines().collect();
        assert!(
            lines[0].starts_with("configuration: ") && lines[0].contains("differ"),
            "{text}"
        );
        let kp = text.find("control.throttle.kp").expect("the gain is named");
        let outputs = text.find("differs:").unwrap();
        assert!(kp < outputs, "{text}");
        if recorded.channels != Config::default().channels {
            assert!(text.find("channels.").unwrap() < outputs, "{text}");
        }
        assert!(text.contains("sensor.port"), "{text}");
        assert!(text.contains("dima log config drive.mcap"), "{text}");

        // With the recorded configuration nothing differs and nothing is listed.
        let same = replay(&run, &recorded).unwrap();
        let (text, code) = crate::logtools::replay_report(&run, &recorded, &same, path);
        assert_eq!(code, std::process::ExitCode::SUCCESS);
        assert!(text.contains("every value the control step reads is as recorded"));
        assert!(text.contains("identical"), "{text}");
    }
}
