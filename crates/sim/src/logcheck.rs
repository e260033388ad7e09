//! Reading the application's MCAP log back: mode changes, per-cycle records and raw packets, so
//! a run can be judged on what the application itself recorded (in its own clock).

use std::collections::BTreeSet;
use std::path::Path;

use anyhow::Context;
use dima_core::config::Config;
use dima_core::{FailsafeCause, Mode, ReviveRefusal};
use dima_log::schema::{CycleMessage, Event};
use dima_log::LoggedRun;

/// One `/dima/state` message, with its log time.
#[derive(Debug, Clone, PartialEq)]
pub struct StateChange {
    /// Log time, ns since the Unix epoch.
    pub t_ns: u64,
    /// Mode after the change.
    pub mode: Mode,
    /// Failsafe cause, if any.
    pub cause: Option<FailsafeCause>,
    /// Why a revive was refused in the cycle, if one was.
    pub refused: Option<ReviveRefusal>,
    /// What happened in the cycle.
    pub events: Vec<Event>,
}

/// One `/dima/cycle` message, the fields the checks use.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleEntry {
    /// Log time (the cycle's wake-up), ns since the Unix epoch.
    pub t_ns: u64,
    /// Mode after the cycle.
    pub mode: Mode,
    /// Whether a valid packet, paired with the cycle's request, arrived in time.
    pub packet_ok: bool,
    /// Valid command frames applied so far.
    pub commands: u64,
    /// Periods missed before this cycle's wake-up.
    pub missed: u64,
    /// Outputs, µs.
    pub targets_us: [u16; 3],
    /// When the newest command frame handed to this cycle's step arrived, on the log's clock
    /// (its arrival before the wake-up taken off `t_ns`); `None` without commands. Logs
    /// without arrival times give the cycle's own time.
    pub link_ns: Option<u64>,
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
    /// The configuration that ran, from the `dima` metadata record.
    pub config: Option<Config>,
    /// The loop's realtime setup report as text (metadata `rt_setup`), if logged.
    pub rt_setup: Option<String>,
}

impl LogSummary {
    /// Reads a finished MCAP file: every message through the typed schema, the configuration
    /// from its metadata. A message that does not match its schema is an error.
    pub fn read(path: &Path) -> anyhow::Result<LogSummary> {
        let mut out = LogSummary::default();
        out.read_file(path)?;
        Ok(out)
    }

    /// Reads every file of the run `last` belongs to, in order: a run split by
    /// `[log] max_file_duration_s` or resumed after a disk fault goes on in `NAME-1.mcap`,
    /// `NAME-2.mcap`, ... (see [`dima_log::naming`]). A missing file of the run is an error.
    pub fn read_run(last: &Path) -> anyhow::Result<LogSummary> {
        let mut out = LogSummary::default();
        for path in dima_log::naming::run_files(last)? {
            out.read_file(&path)?;
        }
        Ok(out)
    }

    /// Adds one file's messages, metadata and attachments to what was read before. A message
    /// that does not match its schema, or a damaged record, is an error.
    fn read_file(&mut self, path: &Path) -> anyhow::Result<()> {
        let run =
            LoggedRun::read(path).with_context(|| format!("reading the log {}", path.display()))?;
        if let Some(w) = run.warnings.first() {
            anyhow::bail!("{}: {w}", path.display());
        }
        self.add(run);
        Ok(())
    }

    /// Adds what one file holds.
    fn add(&mut self, run: LoggedRun) {
        self.raw_packets
            .extend(run.raw.values().map(|p| crate::devices::fingerprint(p)));
        self.states
            .extend(run.states.into_iter().map(|s| StateChange {
                t_ns: s.t_ns,
                mode: s.msg.mode,
                cause: s.msg.cause,
                refused: s.msg.refused,
                events: s.msg.events,
            }));
        self.cycles
            .extend(run.cycles.iter().map(|c| cycle_entry(c.t_ns, &c.msg)));
        self.metadata
            .extend(run.metadata.into_iter().map(|m| m.name));
        self.attachments.extend(run.attachments);
        if self.config.is_none() {
            self.config = run.config;
        }
        if self.rt_setup.is_none() {
            self.rt_setup = run.rt_setup;
        }
    }

    /// The mode in force at `t_ns` by the cycle records (`None` before the first).
    pub fn mode_at(&self, t_ns: u64) -> Option<Mode> {
        self.cycles
            .iter()
            .take_while(|c| c.t_ns <= t_ns)
            .last()
            .map(|c| c.mode)
    }

    /// The modes entered, in order, without repeats.
    pub fn mode_sequence(&self) -> Vec<Mode> {
        let mut seq: Vec<Mode> = Vec::new();
        for s in &self.states {
            if seq.last() != Some(&s.mode) {
                seq.push(s.mode);
            }
        }
        seq
    }

    /// Entries into FAILSAFE: time and cause.
    pub fn failsafes(&self) -> Vec<(u64, Option<FailsafeCause>)> {
        let mut out = Vec::new();
        let mut before = None;
        for s in &self.states {
            if s.mode == Mode::Failsafe && before != Some(Mode::Failsafe) {
                out.push((s.t_ns, s.cause));
            }
            before = Some(s.mode);
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

    /// When the newest command frame handed to a cycle at or before `t_ns` arrived (the time
    /// the robot's comms timeout runs from), on the log's clock.
    pub fn last_link_before(&self, t_ns: u64) -> Option<u64> {
        self.cycles
            .iter()
            .take_while(|c| c.t_ns <= t_ns)
            .filter_map(|c| c.link_ns)
            .max()
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

/// The fields the checks use of a `/dima/cycle` message logged at `t_ns`.
fn cycle_entry(t_ns: u64, v: &CycleMessage) -> CycleEntry {
    CycleEntry {
        t_ns,
        mode: v.mode,
        packet_ok: v.packet_ok,
        commands: v.counters.commands,
        missed: u64::from(v.missed_periods),
        targets_us: v.targets_us,
        link_ns: v
            .commands
            .iter()
            .map(|c| c.arrival_ns.unwrap_or(v.wake_ns).min(v.wake_ns))
            .max()
            .map(|arrival| t_ns.saturating_sub(v.wake_ns - arrival)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(t_ns: u64, mode: Mode, cause: Option<FailsafeCause>) -> StateChange {
        StateChange {
            t_ns,
            mode,
            cause,
            refused: None,
            events: vec![Event::ModeChanged],
        }
    }

    fn cycle(t_ns: u64, commands: u64, missed: u64) -> CycleEntry {
        CycleEntry {
            t_ns,
            mode: Mode::Manual,
            packet_ok: true,
            commands,
            missed,
            targets_us: [1500, 1545, 1500],
            link_ns: None,
        }
    }

    #[test]
    fn modes_failsafes_and_command_times() {
        let log = LogSummary {
            states: vec![
                state(10, Mode::Manual, None),
                state(20, Mode::Manual, None),
                state(30, Mode::Failsafe, Some(FailsafeCause::CommsLoss)),
                state(35, Mode::Failsafe, Some(FailsafeCause::CommsLoss)),
                state(40, Mode::Manual, None),
                state(50, Mode::Failsafe, Some(FailsafeCause::SensorLoss)),
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
            [Mode::Manual, Mode::Failsafe, Mode::Manual, Mode::Failsafe]
        );
        assert_eq!(
            log.failsafes(),
            vec![
                (30, Some(FailsafeCause::CommsLoss)),
                (50, Some(FailsafeCause::SensorLoss))
            ]
        );
        assert_eq!(log.mode_at(0), None);
        assert_eq!(log.mode_at(4), Some(Mode::Manual));
        assert_eq!(log.last_command_before(3), Some(2));
        assert_eq!(log.last_command_before(5), Some(4));
        assert_eq!(log.last_command_before(1), None);
        assert_eq!(log.missed_between(2, 5), 3);
    }

    #[test]
    fn the_link_time_is_the_newest_arrival_not_the_cycle_that_took_it() {
        let with_link = |t_ns, link_ns| CycleEntry {
            link_ns,
            ..cycle(t_ns, 0, 0)
        };
        let log = LogSummary {
            cycles: vec![
                with_link(100, Some(90)),
                with_link(200, None),
                // Taken late: a frame that arrived at 150 in the cycle of 300.
                with_link(300, Some(150)),
                with_link(400, Some(380)),
            ],
            ..LogSummary::default()
        };
        assert_eq!(log.last_link_before(50), None);
        assert_eq!(log.last_link_before(299), Some(90));
        assert_eq!(log.last_link_before(300), Some(150));
        assert_eq!(log.last_link_before(1_000), Some(380));
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

    #[test]
    fn a_missing_file_of_the_run_is_an_error() {
        let dir = std::env::temp_dir().join(format!("dima-sim-gap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let second = dir.join("dima-20261126T170000Z-1.mcap");
        std::fs::write(&second, b"").unwrap();
        let e = LogSummary::read_run(&second).unwrap_err();
        assert!(
            format!("{e:#}").contains("dima-20261126T170000Z.mcap"),
            "{e:#}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
