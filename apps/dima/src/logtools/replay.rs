//! `dima log replay FILE [--config CONFIG] [-o OUT.mcap]`: the recorded inputs of every cycle
//! (commands, raw packets with their request and completion times, missed periods) fed through
//! the real decoder and the pure control step, pull-driven: no pacing, no threads, no devices.
//! With the recorded configuration the modes and servo targets must come out identical; with
//! another one (new gains) the replayed outputs are written beside the recorded ones.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use anyhow::Context;
use dima_core::config::Config;
use dima_core::monitor::PacketVerdict;
use dima_core::schema::{self, ActionMessage, CycleMessage, Event, ReplayMessage};
use dima_core::step::{CycleInputs, SensorInput};
use dima_core::{Command, Core, CoreState, Mode};
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

/// The step's inputs of one recorded cycle.
fn sensor_input(c: &CycleMessage, raw: Option<&[u8; 132]>) -> anyhow::Result<SensorInput> {
    let packet = |raw: Option<&[u8; 132]>| -> anyhow::Result<SensorInput> {
        let bytes = raw.with_context(|| format!("cycle {}: raw packet missing", c.cycle))?;
        Ok(SensorInput::Packet {
            raw: RawPacket::new(*bytes)
                .map_err(|e| anyhow::anyhow!("cycle {}: raw packet: {e:?}", c.cycle))?,
            t_request_ns: c.t_request_ns.unwrap_or(0),
            t_complete_ns: c.t_complete_ns.unwrap_or(0),
        })
    };
    Ok(match c.packet {
        PacketVerdict::Ok | PacketVerdict::Stale | PacketVerdict::Late => packet(raw)?,
        PacketVerdict::Missing => match c.t_request_ns {
            Some(t_request_ns) => SensorInput::NoAnswer { t_request_ns },
            None => SensorInput::NotRequested,
        },
        PacketVerdict::NotRequested => SensorInput::NotRequested,
        PacketVerdict::DeviceError => SensorInput::DeviceError,
    })
}

/// Replays `run` through the step configured by `config`.
pub fn replay(run: &LoggedRun, config: &Config) -> anyhow::Result<Replay> {
    config.validate()?;
    let core = Core::new(config);
    let mut state = CoreState::new();
    let events_of = |event: Event| -> BTreeSet<u64> {
        run.states
            .iter()
            .filter(|s| s.msg.events.contains(&event))
            .map(|s| s.msg.cycle)
            .collect()
    };
    let shutdown = events_of(Event::Shutdown);
    state.realtime_fault = !events_of(Event::RealtimeSetupFailed).is_empty();
    let mut expected_cycle = 0u64;
    let mut out = Replay {
        cycles: Vec::with_capacity(run.cycles.len()),
        first_difference: None,
        differing: 0,
    };
    for c in &run.cycles {
        let m = &c.msg;
        if shutdown.contains(&m.cycle) && m.packet == PacketVerdict::NotRequested {
            continue; // the shutdown record, not a cycle of the loop
        }
        anyhow::ensure!(
            m.cycle == expected_cycle,
            "cycle {} follows cycle {}: replay needs every cycle logged (log.decoded_every = 1)",
            m.cycle,
            expected_cycle.wrapping_sub(1)
        );
        expected_cycle += 1;
        let commands: Vec<Command> = m.commands.iter().filter_map(|c| c.command()).collect();
        let inputs = CycleInputs {
            missed_periods: m.missed_periods,
            commands: &commands,
            sensor: sensor_input(m, run.raw.get(&c.t_ns))?,
            stale_packets: m.stale_passed,
        };
        let o = core.step(&mut state, &inputs, m.wake_ns);
        let message = ReplayMessage {
            cycle: m.cycle,
            mode: o.mode,
            cause: o.cause,
            action: ActionMessage {
                throttle: o.action.throttle,
                steering: o.action.steering,
                tail: o.action.tail,
            },
            targets_us: o.targets.pulse_us,
            recorded_mode: m.mode,
            recorded_targets_us: m.targets_us,
        };
        if (o.mode, o.targets.pulse_us) != (m.mode, m.targets_us) {
            out.differing += 1;
            out.first_difference.get_or_insert(Difference {
                cycle: m.cycle,
                t_s: run.seconds(c.t_ns),
                recorded: (m.mode, m.targets_us),
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
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .profile("")
        .create(BufWriter::new(file))?;
    let none = BTreeMap::new();
    let mut add = |spec: &schema::ChannelSpec| -> anyhow::Result<u16> {
        let text = schema::schema_of(spec).unwrap_or_default();
        let id = w.add_schema(spec.schema_name, "jsonschema", text.as_bytes())?;
        Ok(w.add_channel(id, spec.topic, spec.encoding, &none)?)
    };
    let recorded = add(&schema::CYCLE)?;
    let replayed = add(&schema::REPLAY)?;
    let mut sequence = 0u32;
    let mut message = |w: &mut mcap::Writer<BufWriter<File>>, channel_id, t, data: &[u8]| {
        sequence = sequence.wrapping_add(1);
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id,
                sequence,
                log_time: t,
                publish_time: t,
            },
            data,
        )
    };
    for c in &run.cycles {
        message(&mut w, recorded, c.t_ns, &serde_json::to_vec(&c.msg)?)?;
    }
    for r in &replay.cycles {
        message(&mut w, replayed, r.t_ns, &serde_json::to_vec(&r.message)?)?;
    }
    w.finish()?;
    Ok(())
}
