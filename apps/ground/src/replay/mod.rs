//! `--replay FILE.mcap`: a station session log or a robot log played back through the
//! station's panels and plots, with a timeline, pause and speed. Nothing is sent anywhere.
//!
//! - [`clock`]: the replay clock (play, pause, seek, speed) in virtual time;
//! - [`source`]: the log as events in log time (the bytes a station read; the reports a
//!   robot would have sent);
//! - [`state`]: the link status and telemetry the panels show, built from the events as the
//!   live link builds them.
//!
//! [`Replay`] ties them: each frame the window hands it the wall time, it applies the events up
//! to the clock's log time; seeking backwards rebuilds the state from the last checkpoint
//! before the target (a copy of the state kept every [`CHECKPOINT_INTERVAL`] of log time on
//! the way forward), or from the start of the log.

pub mod clock;
pub mod source;
pub mod state;

use std::path::Path;
use std::time::{Duration, Instant};

use dima_groundlink::v2::LinkKey;

use crate::units::SensorCalibration;
use clock::ReplayClock;
use source::ReplayLog;
use state::ReplayState;

/// Log time between checkpoints of the state.
pub const CHECKPOINT_INTERVAL: Duration = Duration::from_secs(60);

/// A log being replayed.
pub struct Replay {
    log: ReplayLog,
    clock: ReplayClock,
    state: ReplayState,
    /// Events applied to `state`, from the start.
    applied: usize,
    base: Instant,
    key: Option<LinkKey>,
    calibration: Option<SensorCalibration>,
    /// Times the state was rebuilt from the start (a seek backwards).
    rebuilds: u64,
    /// Pause once the log time reaches this (`--replay-pause-at`).
    pause_at: Option<Duration>,
    /// Counts the changes of the state (events applied, rebuilds).
    revision: u64,
    /// Checkpoint `k` is the state after the events before `(k + 1) * checkpoint_interval`,
    /// with how many events that is.
    checkpoints: Vec<(usize, ReplayState)>,
    checkpoint_interval: Duration,
}

impl Replay {
    /// Reads `path` (see [`ReplayLog::open`]).
    ///
    /// # Errors
    /// The log cannot be read.
    pub fn open(
        path: &Path,
        key: Option<LinkKey>,
        calibration: Option<SensorCalibration>,
    ) -> anyhow::Result<Replay> {
        Ok(Replay::new(ReplayLog::open(path)?, key, calibration))
    }

    /// A replay of `log` at its start, paused. `key` decodes a station log of ground link v2.
    pub fn new(
        log: ReplayLog,
        key: Option<LinkKey>,
        calibration: Option<SensorCalibration>,
    ) -> Replay {
        let base = Instant::now();
        let state = ReplayState::new(base, log.kind, key.clone(), calibration.clone());
        let mut replay = Replay {
            clock: ReplayClock::new(log.duration),
            log,
            state,
            applied: 0,
            base,
            key,
            calibration,
            rebuilds: 0,
            pause_at: None,
            revision: 0,
            checkpoints: Vec::new(),
            checkpoint_interval: CHECKPOINT_INTERVAL,
        };
        replay.catch_up();
        replay
    }

    /// The log.
    pub fn log(&self) -> &ReplayLog {
        &self.log
    }

    /// The clock (read).
    pub fn clock(&self) -> &ReplayClock {
        &self.clock
    }

    /// The clock, to play, pause or change the speed; a seek is [`seek`](Self::seek).
    pub fn clock_mut(&mut self) -> &mut ReplayClock {
        &mut self.clock
    }

    /// What the station shows now.
    pub fn state(&self) -> &ReplayState {
        &self.state
    }

    /// The instant standing for the current log time: the panels' "now".
    pub fn now(&self) -> Instant {
        self.state.instant(self.clock.position())
    }

    /// Times the state was rebuilt from the start.
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }

    /// The calibration the sensor values are shown with.
    pub fn calibration(&self) -> Option<&SensorCalibration> {
        self.calibration.as_ref()
    }

    /// Shows the sensor values with `calibration` from now on (the state is rebuilt).
    pub fn set_calibration(&mut self, calibration: Option<SensorCalibration>) {
        self.calibration = calibration;
        self.checkpoints.clear();
        self.restore(0);
        self.catch_up();
    }

    /// Keeps a checkpoint every `interval` of log time (from now on; the ones kept are
    /// dropped).
    pub fn set_checkpoint_interval(&mut self, interval: Duration) {
        self.checkpoint_interval = interval.max(Duration::from_millis(1));
        self.checkpoints.clear();
    }

    /// How many checkpoints are kept.
    pub fn checkpoints(&self) -> usize {
        self.checkpoints.len()
    }

    /// Changes when the state changes (the window copies the state then).
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Pauses once playback reaches log time `at`.
    pub fn pause_at(&mut self, at: Duration) {
        self.pause_at = Some(at);
    }

    /// Advances the clock to wall time `wall` and applies the events up to its log time.
    /// Returns whether the state changed.
    pub fn update(&mut self, wall: Duration) -> bool {
        let t = self.clock.tick(wall);
        if let Some(at) = self.pause_at.filter(|at| t >= *at) {
            self.clock.seek(at);
            self.clock.pause();
            self.pause_at = None;
        }
        self.catch_up()
    }

    /// Jumps to log time `to` and shows the state there. Returns whether it changed.
    pub fn seek(&mut self, to: Duration) -> bool {
        self.clock.seek(to);
        self.catch_up()
    }

    /// Goes back to the last checkpoint with at most `events` events applied, or to the
    /// log's start.
    fn restore(&mut self, events: usize) {
        match self.checkpoints.iter().rposition(|(n, _)| *n <= events) {
            Some(k) => {
                let (n, state) = &self.checkpoints[k];
                self.applied = *n;
                self.state = state.clone();
            }
            None => {
                self.state = ReplayState::new(
                    self.base,
                    self.log.kind,
                    self.key.clone(),
                    self.calibration.clone(),
                );
                self.applied = 0;
            }
        }
        self.rebuilds += 1;
        self.revision += 1;
    }

    /// Applies the events up to the clock's log time; backwards, from the start again.
    fn catch_up(&mut self) -> bool {
        let target = self.log.events_until(self.clock.position());
        let mut changed = false;
        if target < self.applied {
            self.restore(target);
            changed = true;
        }
        while self.applied < target {
            let e = &self.log.events[self.applied];
            let next_checkpoint = self
                .checkpoint_interval
                .saturating_mul(self.checkpoints.len() as u32 + 1);
            if e.at >= next_checkpoint {
                self.checkpoints.push((self.applied, self.state.clone()));
                continue;
            }
            self.state.apply(e.at, &e.event);
            self.applied += 1;
            changed = true;
        }
        if changed {
            self.revision += 1;
        }
        changed
    }
}

#[cfg(test)]
mod tests;
