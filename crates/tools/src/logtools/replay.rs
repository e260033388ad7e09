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

use super::read::LoggedRun;

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

/// Replays `run` through the step configured by `config`.
pub fn replay(run: &LoggedRun, config: &Config) -> anyhow::Result<Replay> {
    let mut core = Core::new(config)?;
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

/// Writes the recorded cycles (`/dima/cycle`) and the replayed ones (`/replay/cycle`) to a new
/// MCAP file at `path`, on the recorded time axis.
pub fn write_mcap(run: &LoggedRun, replay: &Replay, path: &Path) -> anyhow::Result<()> {
    let channels = [&schema::CYCLE, &schema::REPLAY].map(|spec| Channel {
        spec: *spec,
        schema: schema::schema_of(spec),
    });
    let mut w = McapLog::create_with_channels(path, channels.to_vec())?;
    // The times given are log times already.
    w.set_time_offset(0);
    for c in &run.cycles {
        w.message_on(&schema::CYCLE, c.t_ns, &serde_json::to_vec(&c.msg)?)?;
    }
    for r in &replay.cycles {
        w.message_on(&schema::REPLAY, r.t_ns, &serde_json::to_vec(&r.message)?)?;
    }
    w.finish()?;
    Ok(())
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
}
