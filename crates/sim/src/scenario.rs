//! Scenarios: what the ground station does when, and what must be observed for the run to
//! pass. Checks look only at what an outside observer sees: the outputs at the Maestro pty, the
//! model driven by them, the frames at the ground pty, and the application's MCAP log.

use dima_core::{FailsafeCause, Mode};
use dima_groundlink::{Command, Percent};

use crate::devices::{GroundAction, OutputChange, ScriptStep};
use crate::faults::FaultWindow;
use crate::logcheck::LogSummary;
use crate::model::VehicleState;

/// How long outputs must hold the expected values for [`Check::OutputsReach`], s: a value seen
/// for one cycle on the way to another is not reached.
pub const OUTPUTS_HOLD_S: f64 = 0.2;

/// The soak's revive, s after the end of a fault window: the links are back and the sensor
/// link has delivered the good packets a revive needs.
pub const SOAK_REVIVE_AFTER_S: f64 = 2.0;

/// How often the soak's operator revives while no fault is on, s.
pub const SOAK_REVIVE_EVERY_S: f64 = 1.0;

/// Longest `--scenario mission` without `--duration`, s.
pub const MISSION_TIMEOUT_S: f64 = 300.0;

/// The speed setpoint that starts a mission, mm/s: the cap on the plan's speeds.
pub const MISSION_SPEED_CAP_MM_S: i32 = 5_000;

/// Length of `--scenario soak` without `--duration`, s.
pub const SOAK_DEFAULT_S: f64 = 60.0;

/// Manual mapping of percentages to µs (docs/wire-formats.md, "Servo controller: Pololu
/// Maestro"): throttle 1000 + 10 d, steering 1250 + 590 d / 100, tail 1000 + 10 d, rounded to
/// the nearest µs.
pub fn manual_us(throttle: u8, steering: u8, tail: u8) -> [u16; 3] {
    let map = |min: u32, span: u32, d: u8| (min + (span * u32::from(d) + 50) / 100) as u16;
    [
        map(1000, 1000, throttle),
        map(1250, 590, steering),
        map(1000, 1000, tail),
    ]
}

/// Something that must hold.
#[derive(Debug, Clone, PartialEq)]
pub enum Check {
    /// The Maestro shows `targets_us` for at least [`OUTPUTS_HOLD_S`] without a break,
    /// starting in `from_s..to_s` (or until `to_s`, when the window ends first).
    OutputsReach {
        /// Window start, s.
        from_s: f64,
        /// Window end, s.
        to_s: f64,
        /// Expected outputs, µs.
        targets_us: [u16; 3],
    },
    /// The Maestro shows safe outputs throughout `from_s..to_s`, and the log shows KILLED or
    /// FAILSAFE there (safe outputs differ from MANUAL at neutral only by configuration).
    SafeThroughout {
        /// Window start, s.
        from_s: f64,
        /// Window end, s.
        to_s: f64,
    },
    /// The Maestro shows safe outputs at some time in `from_s..to_s`, and from then on only
    /// safe outputs until `to_s` (a kill or a failsafe that stays latched), whatever the
    /// machine's scheduling delays; the log shows KILLED or FAILSAFE at `to_s`.
    SafeHeld {
        /// Window start, s.
        from_s: f64,
        /// Window end, s.
        to_s: f64,
    },
    /// The Maestro never shows safe outputs in `from_s..to_s` (no unexpected failsafe).
    NeverSafe {
        /// Window start, s.
        from_s: f64,
        /// Window end, s.
        to_s: f64,
    },
    /// The car (the model driven by the Maestro's pulses) holds a speed and heading.
    Tracks {
        /// Window start, s.
        from_s: f64,
        /// Window end, s.
        to_s: f64,
        /// Speed setpoint, m/s.
        speed_m_s: f64,
        /// Allowed speed error, m/s.
        speed_tol_m_s: f64,
        /// Heading setpoint, degrees clockwise from north.
        heading_deg: f64,
        /// Allowed heading error, degrees.
        heading_tol_deg: f64,
    },
    /// The log shows FAILSAFE for comms loss no earlier than the timeout and no later than the
    /// timeout plus two periods after the last command the loop applied before `after_s`.
    CommsFailsafe {
        /// The ground station fell silent at about this time, s.
        after_s: f64,
        /// Comms timeout, s.
        timeout_s: f64,
    },
    /// The Maestro shows outputs other than the safe ones, unbroken for at least
    /// [`OUTPUTS_HOLD_S`], starting in `from_s..to_s`: the car drives (after a fault, it
    /// recovered).
    Drives {
        /// Window start, s.
        from_s: f64,
        /// Window end, s.
        to_s: f64,
    },
    /// The log's mode changes contain these modes in this order.
    ModesInOrder(Vec<Mode>),
    /// The log has a FAILSAFE entry with this cause in `from_s..to_s`.
    FailsafeFor {
        /// The cause.
        cause: FailsafeCause,
        /// Window start, s.
        from_s: f64,
        /// Window end, s.
        to_s: f64,
    },
    /// The log has this many FAILSAFE entries.
    Failsafes(usize),
}

/// A scripted run.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Name.
    pub name: &'static str,
    /// Length, s.
    pub duration_s: f64,
    /// Initial heading of the car, degrees clockwise from north.
    pub start_heading_deg: f64,
    /// The ground station's script.
    pub script: Vec<ScriptStep>,
    /// The heartbeat frame the ground station sends in idle slots.
    pub heartbeat: [u8; 10],
    /// Phase names shown in the status line, from their start time.
    pub phases: Vec<(f64, &'static str)>,
    /// What must hold.
    pub checks: Vec<Check>,
}

/// A percentage (clamped to 100).
pub fn pct(v: u8) -> Percent {
    Percent::new(v.min(100)).unwrap_or(Percent::HALF)
}

/// A script step sending `c` at `at_s`.
pub fn send(at_s: f64, c: Command) -> ScriptStep {
    ScriptStep {
        at_s,
        action: GroundAction::Send(c),
    }
}

impl Scenario {
    /// The phase at `t_s`.
    pub fn phase_at(&self, t_s: f64) -> &'static str {
        self.phases
            .iter()
            .take_while(|(t, _)| *t <= t_s)
            .last()
            .map_or("", |(_, n)| n)
    }

    /// About 20 s: revive, manual driving, AUTO tracking a speed and a heading, a comms loss
    /// that trips the failsafe (latched while the link is back), a revive, manual, kill.
    pub fn default_tour() -> Scenario {
        Scenario {
            name: "default",
            duration_s: 20.0,
            start_heading_deg: 0.0,
            heartbeat: Command::Heartbeat.encode(),
            script: Scenario::tour_script(),
            phases: Scenario::tour_phases(),
            checks: Scenario::tour_checks(),
        }
    }

    /// The default tour's ground-station script.
    fn tour_script() -> Vec<ScriptStep> {
        vec![
            send(1.0, Command::Revive),
            send(1.5, Command::Throttle(pct(60))),
            send(1.5, Command::Steering(pct(50))),
            send(1.5, Command::Tail(pct(50))),
            send(3.0, Command::Steering(pct(60))),
            send(4.5, Command::Steering(pct(50))),
            send(6.0, Command::SpeedSetpoint { mm_s: 2_500 }),
            send(6.0, Command::HeadingSetpoint { deg_e5: 12_000_000 }),
            ScriptStep {
                at_s: 14.0,
                action: GroundAction::Silence,
            },
            ScriptStep {
                at_s: 16.0,
                action: GroundAction::Resume,
            },
            send(16.5, Command::Throttle(pct(70))),
            send(17.0, Command::Revive),
            send(17.3, Command::Throttle(pct(55))),
            send(19.0, Command::Kill),
        ]
    }

    /// The default tour's phases, for the status line.
    fn tour_phases() -> Vec<(f64, &'static str)> {
        vec![
            (0.0, "KILLED (start-up)"),
            (1.0, "revive"),
            (1.5, "MANUAL driving"),
            (6.0, "AUTO 2.5 m/s, 120°"),
            (14.0, "comms loss"),
            (16.0, "link back, latched"),
            (17.0, "revive, MANUAL"),
            (19.0, "kill"),
        ]
    }

    /// What must hold during the default tour.
    fn tour_checks() -> Vec<Check> {
        let manual = manual_us(60, 50, 50);
        let turn = manual_us(60, 60, 50);
        let after = manual_us(55, 50, 50);
        vec![
            Check::SafeThroughout {
                from_s: 0.0,
                to_s: 0.9,
            },
            Check::OutputsReach {
                from_s: 1.5,
                to_s: 3.0,
                targets_us: manual,
            },
            Check::OutputsReach {
                from_s: 3.0,
                to_s: 4.5,
                targets_us: turn,
            },
            Check::NeverSafe {
                from_s: 2.0,
                to_s: 14.0,
            },
            Check::Tracks {
                from_s: 12.0,
                to_s: 14.0,
                speed_m_s: 2.5,
                speed_tol_m_s: 0.4,
                heading_deg: 120.0,
                heading_tol_deg: 10.0,
            },
            Check::CommsFailsafe {
                after_s: 14.0,
                timeout_s: 1.0,
            },
            Check::SafeHeld {
                from_s: 14.0,
                to_s: 17.0,
            },
            Check::OutputsReach {
                from_s: 17.3,
                to_s: 19.0,
                targets_us: after,
            },
            Check::SafeHeld {
                from_s: 19.0,
                to_s: 20.0,
            },
            Check::ModesInOrder(vec![
                Mode::Manual,
                Mode::Auto,
                Mode::Failsafe,
                Mode::Manual,
                Mode::Killed,
            ]),
            Check::Failsafes(1),
        ]
    }

    /// Revive and hold a manual setting for `duration_s`; no failsafe allowed.
    pub fn manual_drive(duration_s: f64) -> Scenario {
        let manual = manual_us(60, 40, 50);
        Scenario {
            name: "manual",
            duration_s,
            start_heading_deg: 0.0,
            heartbeat: Command::Heartbeat.encode(),
            script: vec![
                send(0.5, Command::Revive),
                send(1.0, Command::Throttle(pct(60))),
                send(1.0, Command::Steering(pct(40))),
                send(1.0, Command::Tail(pct(50))),
            ],
            phases: vec![(0.0, "KILLED"), (0.5, "revive"), (1.0, "MANUAL")],
            checks: vec![
                Check::OutputsReach {
                    from_s: 1.0,
                    to_s: duration_s,
                    targets_us: manual,
                },
                Check::Failsafes(0),
            ],
        }
    }

    /// Runs until `duration_s`, driving (alternately MANUAL and AUTO between fault windows)
    /// around every fault window (from `--random-faults`, or none). The operator watches the
    /// car: outside the fault windows, from [`SOAK_REVIVE_AFTER_S`] after each one, it sends a
    /// revive every [`SOAK_REVIVE_EVERY_S`] and drives again after it (a revive while driving
    /// changes nothing), so every failsafe is revived, whether a fault or the machine caused
    /// it. Checks: safe until the first revive; after every window the car drives again (not
    /// safe for at least [`OUTPUTS_HOLD_S`] before the next window); safe after the final
    /// kill.
    pub fn soak(duration_s: f64, windows: &[FaultWindow]) -> Scenario {
        let tenths = |t: f64| (t * 10.0).round() / 10.0;
        let mut script = Vec::new();
        let mut checks = vec![Check::SafeThroughout {
            from_s: 0.0,
            to_s: 0.9,
        }];
        let mut phases = vec![(0.0, "KILLED (start-up)"), (1.0, "revive, driving")];
        let kill_s = tenths(duration_s - 1.0);
        // Driving stretches: from the start and after every window, each until the next window
        // (or the kill).
        let mut stretches = vec![(1.0, false)];
        for (i, w) in windows.iter().enumerate() {
            let end = w.window.start_s + w.window.duration_s;
            phases.push((w.window.start_s, "fault"));
            phases.push((end, "recovering"));
            phases.push((tenths(end + SOAK_REVIVE_AFTER_S), "revive, driving"));
            stretches.push((tenths(end + SOAK_REVIVE_AFTER_S), i % 2 == 0));
        }
        let next_starts = windows.iter().map(|w| w.window.start_s).chain([kill_s]);
        for ((from_s, auto), to_s) in stretches.into_iter().zip(next_starts) {
            let mut t = from_s;
            while t + 0.3 < to_s {
                script.push(send(t, Command::Revive));
                let at_s = tenths(t + 0.3);
                if auto {
                    script.push(send(at_s, Command::SpeedSetpoint { mm_s: 2_000 }));
                    script.push(send(at_s, Command::HeadingSetpoint { deg_e5: 9_000_000 }));
                } else {
                    script.push(send(at_s, Command::Throttle(pct(60))));
                    script.push(send(at_s, Command::Steering(pct(55))));
                    script.push(send(at_s, Command::Tail(pct(50))));
                }
                t = tenths(t + SOAK_REVIVE_EVERY_S);
            }
            if from_s + 0.3 < to_s {
                checks.push(Check::Drives { from_s, to_s });
            }
        }
        script.push(send(kill_s, Command::Kill));
        phases.push((kill_s, "kill"));
        checks.push(Check::SafeHeld {
            from_s: kill_s,
            to_s: tenths(duration_s - 0.1),
        });
        script.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        phases.sort_by(|a, b| a.0.total_cmp(&b.0));
        Scenario {
            name: "soak",
            duration_s,
            start_heading_deg: 0.0,
            heartbeat: Command::Heartbeat.encode(),
            script,
            phases,
            checks,
        }
    }

    /// `--scenario mission`: the station revives at 1, 2 and 3 s and enters AUTO at 4 s (again
    /// at 5 s) with a speed setpoint of `speed_cap_mm_s` (the mission's speeds are capped by
    /// it), then only sends heartbeats; the car starts heading `start_heading_deg`. The run ends when the robot
    /// reports the last waypoint reached or a failsafe, else after `timeout_s`; its verdict is
    /// [`crate::mission::MissionTrack::verdict`].
    pub fn mission(timeout_s: f64, start_heading_deg: f64, speed_cap_mm_s: i32) -> Scenario {
        let speed = Command::SpeedSetpoint {
            mm_s: speed_cap_mm_s,
        };
        Scenario {
            name: "mission",
            duration_s: timeout_s,
            start_heading_deg,
            // A revive the robot refuses (its sensor link not yet healthy on a loaded machine)
            // is repeated; a revive in MANUAL and a speed setpoint in AUTO change nothing.
            script: vec![
                send(1.0, Command::Revive),
                send(2.0, Command::Revive),
                send(3.0, Command::Revive),
                send(4.0, speed),
                send(5.0, speed),
            ],
            heartbeat: Command::Heartbeat.encode(),
            phases: vec![(0.0, "standing"), (1.0, "reviving"), (4.0, "mission")],
            checks: Vec::new(),
        }
    }

    /// An empty scenario of `duration_s` (build the script and checks yourself).
    pub fn custom(name: &'static str, duration_s: f64) -> Scenario {
        Scenario {
            name,
            duration_s,
            start_heading_deg: 0.0,
            heartbeat: Command::Heartbeat.encode(),
            script: Vec::new(),
            phases: vec![(0.0, name)],
            checks: Vec::new(),
        }
    }

    /// A scenario by name: `default`, `manual` or `soak` (without fault windows: see
    /// [`Scenario::soak`]; `mission` is [`Scenario::mission`] with a start heading of north
    /// and a 300 s timeout: `dima sim --mission` sets both from the plan).
    pub fn by_name(name: &str, duration_s: Option<f64>) -> Option<Scenario> {
        match name {
            "default" | "tour" => Some(Scenario::default_tour()),
            "manual" => Some(Scenario::manual_drive(duration_s.unwrap_or(10.0))),
            "soak" => Some(Scenario::soak(duration_s.unwrap_or(SOAK_DEFAULT_S), &[])),
            "mission" => Some(Scenario::mission(
                duration_s.unwrap_or(MISSION_TIMEOUT_S),
                0.0,
                MISSION_SPEED_CAP_MM_S,
            )),
            _ => None,
        }
    }
}

/// What a run left behind, for the checks.
#[derive(Debug, Clone, Default)]
pub struct Evidence {
    /// Output changes at the Maestro.
    pub outputs: Vec<OutputChange>,
    /// Model samples (10 Hz).
    pub truth: Vec<VehicleState>,
    /// The application's log, when one was written.
    pub log: Option<LogSummary>,
    /// Wall-clock ns at simulation time 0 (to place log times on the simulation clock).
    pub start_wall_ns: u64,
    /// Safe outputs, µs.
    pub safe_us: [u16; 3],
    /// How long the run lasted, s.
    pub ran_s: f64,
    /// The scenario ran to its end (false: interrupted; checks past the end are skipped).
    pub complete: bool,
    /// Loop period, s.
    pub period_s: f64,
}

impl Evidence {
    fn outputs_at(&self, t_s: f64) -> Option<[u16; 3]> {
        self.outputs
            .iter()
            .take_while(|c| c.t_s <= t_s)
            .last()
            .map(|c| c.targets_qus.map(|q| q / 4))
    }

    /// Outputs in force at `from_s` and every change until `to_s`.
    fn outputs_in(&self, from_s: f64, to_s: f64) -> Vec<[u16; 3]> {
        let mut v: Vec<[u16; 3]> = self.outputs_at(from_s).into_iter().collect();
        v.extend(
            self.outputs
                .iter()
                .filter(|c| c.t_s > from_s && c.t_s < to_s)
                .map(|c| c.targets_qus.map(|q| q / 4)),
        );
        v
    }

    /// A log time (ns since the Unix epoch) on the simulation's clock, s.
    pub fn sim_s(&self, log_ns: u64) -> f64 {
        (log_ns as f64 - self.start_wall_ns as f64) * 1e-9
    }

    fn log_ns(&self, sim_s: f64) -> u64 {
        (self.start_wall_ns as f64 + sim_s * 1e9).max(0.0) as u64
    }

    /// The longest stretch in which the outputs showed `targets` without a break, starting in
    /// `from_s..to_s`, s (a stretch still going at the end of the run lasts until then).
    fn longest_hold(&self, targets: [u16; 3], from_s: f64, to_s: f64) -> f64 {
        let us = |c: &OutputChange| c.targets_qus.map(|q| q / 4);
        let mut best: f64 = 0.0;
        let mut since: Option<f64> = (self.outputs_at(from_s) == Some(targets)).then_some(from_s);
        for c in self.outputs.iter().filter(|c| c.t_s > from_s) {
            match (since, us(c) == targets) {
                (Some(t0), false) => {
                    best = best.max(c.t_s - t0);
                    since = None;
                }
                (None, true) if c.t_s < to_s => since = Some(c.t_s),
                _ => {}
            }
        }
        if let Some(t0) = since {
            best = best.max(self.ran_s - t0);
        }
        best
    }

    /// The longest stretch of outputs other than the safe ones, starting in `from_s..to_s`
    /// and lasting until the next safe outputs (or the run's end), s.
    fn longest_unsafe(&self, from_s: f64, to_s: f64) -> f64 {
        let safe = |c: &OutputChange| c.targets_qus.map(|q| q / 4) == self.safe_us;
        let mut best: f64 = 0.0;
        let mut since: Option<f64> = self
            .outputs_at(from_s)
            .filter(|o| *o != self.safe_us)
            .map(|_| from_s);
        for c in self.outputs.iter().filter(|c| c.t_s > from_s) {
            match (since, safe(c)) {
                (Some(t0), true) => {
                    best = best.max(c.t_s - t0);
                    since = None;
                }
                (None, false) if c.t_s < to_s => since = Some(c.t_s),
                _ => {}
            }
        }
        if let Some(t0) = since {
            best = best.max(self.ran_s - t0);
        }
        best
    }

    /// Modes the log shows in `from_s..=to_s` that are not safe ones (none without a log).
    fn unsafe_modes_in(&self, from_s: f64, to_s: f64) -> Vec<Mode> {
        let Some(log) = &self.log else {
            return Vec::new();
        };
        let (from, to) = (self.log_ns(from_s), self.log_ns(to_s));
        let mut modes: Vec<Mode> = log
            .cycles
            .iter()
            .filter(|c| c.t_ns >= from && c.t_ns <= to && !c.mode.is_safe())
            .map(|c| c.mode)
            .collect();
        modes.dedup();
        modes
    }
}

/// The latest time a check looks at, s.
fn check_end(check: &Check) -> f64 {
    match check {
        Check::OutputsReach { to_s, .. }
        | Check::SafeThroughout { to_s, .. }
        | Check::SafeHeld { to_s, .. }
        | Check::NeverSafe { to_s, .. }
        | Check::Drives { to_s, .. }
        | Check::Tracks { to_s, .. } => *to_s,
        Check::CommsFailsafe {
            after_s, timeout_s, ..
        } => after_s + timeout_s + 0.5,
        Check::FailsafeFor { to_s, .. } => *to_s,
        Check::ModesInOrder(_) | Check::Failsafes(_) => f64::INFINITY,
    }
}

/// Evaluates one check: `None` when the run ended before the check's window (skipped),
/// otherwise `Ok` or the reason it failed.
pub fn evaluate(check: &Check, e: &Evidence) -> Option<Result<(), String>> {
    if !e.complete && check_end(check) > e.ran_s {
        return None;
    }
    Some(match check {
        Check::OutputsReach {
            from_s,
            to_s,
            targets_us,
        } => e.outputs_reach(*targets_us, *from_s, *to_s),
        Check::SafeThroughout { from_s, to_s } => e.safe_throughout(*from_s, *to_s),
        Check::SafeHeld { from_s, to_s } => e.safe_held(*from_s, *to_s),
        Check::NeverSafe { from_s, to_s } => e.never_safe(*from_s, *to_s),
        Check::Drives { from_s, to_s } => e.drives(*from_s, *to_s),
        Check::Tracks {
            from_s,
            to_s,
            speed_m_s,
            speed_tol_m_s,
            heading_deg,
            heading_tol_deg,
        } => e.tracks(
            (*from_s, *to_s),
            (*speed_m_s, *speed_tol_m_s),
            (*heading_deg, *heading_tol_deg),
        ),
        Check::CommsFailsafe { after_s, timeout_s } => e.comms_failsafe(*after_s, *timeout_s),
        Check::ModesInOrder(modes) => e.modes_in_order(modes),
        Check::FailsafeFor {
            cause,
            from_s,
            to_s,
        } => e.failsafe_for(*cause, *from_s, *to_s),
        Check::Failsafes(n) => e.failsafe_count(*n),
    })
}

/// The checks, one method each (see [`Check`] for what each one asks).
impl Evidence {
    /// [`Check::OutputsReach`].
    fn outputs_reach(&self, targets_us: [u16; 3], from_s: f64, to_s: f64) -> Result<(), String> {
        let held = self.longest_hold(targets_us, from_s, to_s);
        let needed = OUTPUTS_HOLD_S.min(to_s - from_s);
        if held >= needed {
            Ok(())
        } else {
            Err(format!(
                "outputs {targets_us:?} µs expected for {needed} s from {from_s} s to {to_s} s; \
                 held {held:.3} s; saw {:?}",
                self.outputs_in(from_s, to_s)
            ))
        }
    }

    /// [`Check::SafeThroughout`].
    fn safe_throughout(&self, from_s: f64, to_s: f64) -> Result<(), String> {
        let seen = self.outputs_in(from_s, to_s);
        let modes = self.unsafe_modes_in(from_s, to_s);
        match seen.iter().find(|o| **o != self.safe_us) {
            None if !modes.is_empty() => Err(format!(
                "safe outputs but the log shows {modes:?} between {from_s} s and {to_s} s"
            )),
            None if !seen.is_empty() => Ok(()),
            None => Err(format!("no outputs at all by {from_s} s")),
            Some(o) => Err(format!(
                "outputs {o:?} µs between {from_s} s and {to_s} s; expected safe {:?}",
                self.safe_us
            )),
        }
    }

    /// [`Check::SafeHeld`].
    fn safe_held(&self, from_s: f64, to_s: f64) -> Result<(), String> {
        let seen = self.outputs_in(from_s, to_s);
        match seen.iter().position(|o| *o == self.safe_us) {
            None => Err(format!(
                "no safe outputs between {from_s} s and {to_s} s; saw {seen:?}"
            )),
            Some(i) => match seen[i..].iter().find(|o| **o != self.safe_us) {
                None if !self.unsafe_modes_in(to_s - self.period_s, to_s).is_empty() => Err(
                    format!("safe outputs but the log shows no KILLED or FAILSAFE at {to_s} s"),
                ),
                None => Ok(()),
                Some(o) => Err(format!(
                    "outputs {o:?} µs after the safe ones before {to_s} s (not latched)"
                )),
            },
        }
    }

    /// [`Check::NeverSafe`].
    fn never_safe(&self, from_s: f64, to_s: f64) -> Result<(), String> {
        let seen = self.outputs_in(from_s, to_s);
        if seen.contains(&self.safe_us) {
            Err(format!(
                "unexpected safe outputs (failsafe or kill) between {from_s} s and {to_s} s"
            ))
        } else {
            Ok(())
        }
    }

    /// [`Check::Drives`].
    fn drives(&self, from_s: f64, to_s: f64) -> Result<(), String> {
        let held = self.longest_unsafe(from_s, to_s);
        let needed = OUTPUTS_HOLD_S.min(to_s - from_s);
        if held >= needed {
            Ok(())
        } else {
            Err(format!(
                "no driving between {from_s} s and {to_s} s (outputs other than safe for \
                 {held:.3} s at most, {needed} s needed); saw {:?}",
                self.outputs_in(from_s, to_s)
            ))
        }
    }

    /// [`Check::Tracks`]: the model's speed and heading, each as (target, tolerance), held
    /// through the window `(from_s, to_s)`.
    fn tracks(
        &self,
        (from_s, to_s): (f64, f64),
        (speed_m_s, speed_tol_m_s): (f64, f64),
        (heading_deg, heading_tol_deg): (f64, f64),
    ) -> Result<(), String> {
        let samples: Vec<&VehicleState> = self
            .truth
            .iter()
            .filter(|s| s.t_s >= from_s && s.t_s <= to_s)
            .collect();
        if samples.is_empty() {
            return Err(format!("no model samples between {from_s} and {to_s} s"));
        }
        let worst_speed = samples
            .iter()
            .map(|s| (s.speed_m_s - speed_m_s).abs())
            .fold(0.0, f64::max);
        let worst_heading = samples
            .iter()
            .map(|s| ((s.heading_deg - heading_deg + 540.0).rem_euclid(360.0) - 180.0).abs())
            .fold(0.0, f64::max);
        if worst_speed <= speed_tol_m_s && worst_heading <= heading_tol_deg {
            Ok(())
        } else {
            Err(format!(
                "AUTO tracking between {from_s} and {to_s} s: worst speed error {worst_speed:.2} m/s (allowed {speed_tol_m_s}), worst heading error {worst_heading:.1}° (allowed {heading_tol_deg})"
            ))
        }
    }

    /// [`Check::CommsFailsafe`].
    fn comms_failsafe(&self, after_s: f64, timeout_s: f64) -> Result<(), String> {
        let Some(log) = &self.log else {
            return Err("no log to check the failsafe timing".into());
        };
        let entry = log.failsafes().into_iter().find(|(t, cause)| {
            self.sim_s(*t) > after_s && *cause == Some(FailsafeCause::CommsLoss)
        });
        let Some((t_fs, _)) = entry else {
            return Err(format!(
                "no FAILSAFE for comms loss after {after_s} s in the log"
            ));
        };
        // The timeout runs from the newest frame's arrival (a log without arrival times:
        // the cycle that applied it).
        let last = log
            .last_link_before(t_fs)
            .or_else(|| log.last_command_before(t_fs));
        let Some(t_cmd) = last else {
            return Err("no command before the failsafe in the log".into());
        };
        let waited = t_fs.saturating_sub(t_cmd) as f64 * 1e-9;
        // The loop decides once per cycle: between the timeout and the timeout plus two
        // periods after the last frame arrived, plus any periods the loop itself counted
        // as missed in between (a stalled machine).
        let missed = log.missed_between(t_cmd, t_fs) as f64;
        let (lo, hi) = (
            timeout_s - self.period_s,
            timeout_s + (2.0 + missed) * self.period_s,
        );
        if waited >= lo && waited <= hi {
            Ok(())
        } else {
            Err(format!(
                "FAILSAFE {waited:.4} s after the last command arrived; expected {lo:.4}..{hi:.4} s"
            ))
        }
    }

    /// [`Check::ModesInOrder`].
    fn modes_in_order(&self, modes: &[Mode]) -> Result<(), String> {
        let Some(log) = &self.log else {
            return Err("no log to check the modes".into());
        };
        let seq = log.mode_sequence();
        let mut it = seq.iter();
        match modes.iter().find(|m| !it.any(|s| s == *m)) {
            None => Ok(()),
            Some(m) => Err(format!(
                "mode {m} missing from the order {modes:?}; log has {seq:?}"
            )),
        }
    }

    /// [`Check::FailsafeFor`].
    fn failsafe_for(&self, cause: FailsafeCause, from_s: f64, to_s: f64) -> Result<(), String> {
        let Some(log) = &self.log else {
            return Err("no log to check the failsafe".into());
        };
        let all = log.failsafes();
        let found = all
            .iter()
            .any(|(t, c)| *c == Some(cause) && (from_s..=to_s).contains(&self.sim_s(*t)));
        if found {
            Ok(())
        } else {
            Err(format!(
                "no FAILSAFE ({cause:?}) between {from_s} s and {to_s} s; log has {:?}",
                all.iter()
                    .map(|(t, c)| format!("{:.2} s {c:?}", self.sim_s(*t)))
                    .collect::<Vec<_>>()
            ))
        }
    }

    /// [`Check::Failsafes`].
    fn failsafe_count(&self, n: usize) -> Result<(), String> {
        let Some(log) = &self.log else {
            return Err("no log to count failsafes".into());
        };
        let got = log.failsafes();
        if got.len() == n {
            Ok(())
        } else {
            Err(format!(
                "{} FAILSAFE entries in the log, expected {n}: {:?}",
                got.len(),
                got.iter()
                    .map(|(t, c)| format!("{:.2} s {c:?}", self.sim_s(*t)))
                    .collect::<Vec<_>>()
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAFE_US: [u16; 3] = [1500, 1560, 1500];

    #[test]
    fn manual_mapping_matches_the_documented_formulas() {
        assert_eq!(manual_us(80, 0, 100), [1800, 1250, 2000]);
        assert_eq!(manual_us(50, 50, 50), [1500, 1545, 1500]);
        assert_eq!(manual_us(0, 100, 0), [1000, 1840, 1000]);
    }

    fn change(t_s: f64, us: [u16; 3]) -> OutputChange {
        OutputChange {
            t_s,
            targets_qus: us.map(|u| u * 4),
        }
    }

    fn evidence(outputs: Vec<OutputChange>) -> Evidence {
        Evidence {
            outputs,
            safe_us: SAFE_US,
            ran_s: 10.0,
            complete: false,
            period_s: 0.004,
            ..Evidence::default()
        }
    }

    #[test]
    fn the_soak_checks_judge_a_history_of_safe_transitions_as_the_whole_history() {
        use crate::devices::MaestroStats;
        use crate::rng::SimRng;
        let coarse = MaestroStats {
            safe_transitions_only: Some(SAFE_US),
            ..MaestroStats::default()
        };
        let mut full = Vec::new();
        let mut rng = SimRng::new(5);
        let mut t_s = 0.0;
        // Stretches of safe outputs and of outputs changing every period (AUTO), of random
        // lengths, with single odd periods in between.
        while t_s < 10.0 {
            let driving = rng.chance(0.5);
            let periods = 1 + rng.below(100);
            for _ in 0..periods {
                t_s += 0.004;
                let us = if driving {
                    [
                        1500 + rng.below(300) as u16,
                        1400 + rng.below(300) as u16,
                        1500,
                    ]
                } else {
                    SAFE_US
                };
                let c = change(t_s, us);
                coarse.record(c);
                full.push(c);
            }
        }
        let coarse = evidence(coarse.history());
        let full = evidence(full);
        assert!(coarse.outputs.len() * 10 < full.outputs.len());
        let mut judged = [0usize; 2];
        for _ in 0..2000 {
            let from_s = rng.uniform() * 10.0;
            let to_s = from_s + rng.uniform() * 2.0;
            for check in [
                Check::Drives { from_s, to_s },
                Check::SafeThroughout { from_s, to_s },
                Check::SafeHeld { from_s, to_s },
            ] {
                let verdict = |e: &Evidence| evaluate(&check, e).map(|r| r.is_ok());
                assert_eq!(verdict(&coarse), verdict(&full), "{check:?}");
                if let Some(ok) = verdict(&full) {
                    judged[usize::from(ok)] += 1;
                }
            }
        }
        // Both verdicts were seen many times.
        assert!(judged.iter().all(|&n| n > 500), "{judged:?}");
    }

    #[test]
    fn output_checks_follow_the_history() {
        let e = evidence(vec![
            change(0.1, SAFE_US),
            change(1.2, [1600, 1545, 1500]),
            change(5.0, SAFE_US),
        ]);
        let ok = |c: Check| evaluate(&c, &e).unwrap().is_ok();
        assert!(ok(Check::SafeThroughout {
            from_s: 0.2,
            to_s: 1.0
        }));
        assert!(!ok(Check::SafeThroughout {
            from_s: 0.2,
            to_s: 1.3
        }));
        assert!(ok(Check::OutputsReach {
            from_s: 1.0,
            to_s: 1.5,
            targets_us: [1600, 1545, 1500]
        }));
        assert!(ok(Check::OutputsReach {
            from_s: 3.0,
            to_s: 3.5,
            targets_us: [1600, 1545, 1500]
        }));
        assert!(!ok(Check::OutputsReach {
            from_s: 0.0,
            to_s: 1.0,
            targets_us: [1600, 1545, 1500]
        }));
        // Starting right at the window's end but lasting: reached.
        assert!(ok(Check::OutputsReach {
            from_s: 0.0,
            to_s: 1.25,
            targets_us: [1600, 1545, 1500]
        }));
        assert!(ok(Check::NeverSafe {
            from_s: 1.3,
            to_s: 4.9
        }));
        assert!(!ok(Check::NeverSafe {
            from_s: 1.3,
            to_s: 5.1
        }));
        // Beyond the end of the run: skipped.
        assert!(evaluate(
            &Check::NeverSafe {
                from_s: 9.0,
                to_s: 12.0
            },
            &e
        )
        .is_none());
    }

    #[test]
    fn a_value_passed_through_for_one_cycle_is_not_reached() {
        let e = evidence(vec![
            change(0.1, SAFE_US),
            change(1.000, [1600, 1545, 1500]),
            change(1.004, [1700, 1545, 1500]),
        ]);
        let reach = |targets_us| {
            evaluate(
                &Check::OutputsReach {
                    from_s: 0.5,
                    to_s: 2.0,
                    targets_us,
                },
                &e,
            )
            .unwrap()
        };
        assert!(reach([1600, 1545, 1500]).is_err());
        assert!(reach([1700, 1545, 1500]).is_ok());
    }

    #[test]
    fn safe_outputs_need_a_safe_mode_in_the_log() {
        use crate::logcheck::{CycleEntry, LogSummary};
        // MANUAL at outputs that look safe: a configuration whose safe values equal neutral
        // could not tell them apart by outputs alone.
        let mut e = evidence(vec![change(0.1, SAFE_US)]);
        e.start_wall_ns = 1_000_000_000;
        let start = e.start_wall_ns;
        let cycle = |t_s: f64, mode| CycleEntry {
            t_ns: start + (t_s * 1e9) as u64,
            mode,
            packet_ok: true,
            commands: 0,
            missed: 0,
            targets_us: SAFE_US,
            link_ns: None,
        };
        let check = Check::SafeThroughout {
            from_s: 0.2,
            to_s: 1.0,
        };
        e.log = Some(LogSummary {
            cycles: vec![cycle(0.3, Mode::Killed), cycle(0.5, Mode::Killed)],
            ..LogSummary::default()
        });
        assert!(evaluate(&check, &e).unwrap().is_ok());
        e.log = Some(LogSummary {
            cycles: vec![cycle(0.3, Mode::Killed), cycle(0.5, Mode::Manual)],
            ..LogSummary::default()
        });
        assert!(evaluate(&check, &e).unwrap().is_err());
    }

    #[test]
    fn the_comms_failsafe_is_timed_from_the_last_frames_arrival() {
        use crate::logcheck::{CycleEntry, LogSummary, StateChange};
        let mut e = evidence(vec![change(0.1, SAFE_US)]);
        e.complete = true;
        let ms = |n: u64| 1_000_000_000 + n * 1_000_000;
        let cycle = |t_ns, commands, link_ns| CycleEntry {
            t_ns,
            mode: Mode::Manual,
            packet_ok: true,
            commands,
            missed: 0,
            targets_us: [1600, 1545, 1500],
            link_ns,
        };
        let failsafe_at = |t_ns| StateChange {
            t_ns,
            mode: Mode::Failsafe,
            cause: Some(FailsafeCause::CommsLoss),
            refused: None,
            events: Vec::new(),
        };
        let check = Check::CommsFailsafe {
            after_s: 0.0,
            timeout_s: 1.0,
        };
        // The last frame arrived at 100 ms and the loop took it in its cycle of 116 ms.
        let log = |failsafe_ms| LogSummary {
            cycles: vec![
                cycle(ms(4), 1, Some(ms(2))),
                cycle(ms(116), 2, Some(ms(100))),
            ],
            states: vec![failsafe_at(ms(failsafe_ms))],
            ..LogSummary::default()
        };
        e.log = Some(log(1_102));
        assert!(evaluate(&check, &e).unwrap().is_ok());
        // Later than the timeout plus two periods after the arrival: too late.
        e.log = Some(log(1_116));
        assert!(evaluate(&check, &e).unwrap().is_err());
        // Sooner than the timeout after the arrival: too soon.
        e.log = Some(log(1_090));
        assert!(evaluate(&check, &e).unwrap().is_err());
    }

    #[test]
    fn tracking_uses_the_model_samples() {
        let mut e = evidence(vec![]);
        e.truth = (0..20)
            .map(|i| VehicleState {
                t_s: f64::from(i) * 0.1,
                speed_m_s: 2.4,
                heading_deg: 359.0,
                ..VehicleState::default()
            })
            .collect();
        let check = |heading_deg| Check::Tracks {
            from_s: 0.5,
            to_s: 1.5,
            speed_m_s: 2.5,
            speed_tol_m_s: 0.2,
            heading_deg,
            heading_tol_deg: 5.0,
        };
        assert!(
            evaluate(&check(3.0), &e).unwrap().is_ok(),
            "wraps through north"
        );
        assert!(evaluate(&check(10.0), &e).unwrap().is_err());
    }

    #[test]
    fn soak_revives_after_every_window() {
        use crate::faults::{FaultKind, Window};
        let w = |start_s, duration_s| FaultWindow {
            kind: FaultKind::GroundSilence,
            window: Window {
                start_s,
                duration_s,
            },
        };
        let s = Scenario::soak(30.0, &[w(5.0, 2.0), w(15.0, 1.0)]);
        let revives: Vec<f64> = s
            .script
            .iter()
            .filter(|st| st.action == GroundAction::Send(Command::Revive))
            .map(|st| st.at_s)
            .collect();
        // Every second outside the windows, from 2 s after each.
        assert_eq!(
            revives,
            vec![
                1.0, 2.0, 3.0, 4.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 18.0, 19.0, 20.0, 21.0,
                22.0, 23.0, 24.0, 25.0, 26.0, 27.0, 28.0
            ]
        );
        // No command inside a window (a revive there would test nothing).
        assert!(!s
            .script
            .iter()
            .any(|st| (5.0..7.0).contains(&st.at_s) || (15.0..16.0).contains(&st.at_s)));
        // The second stretch drives in AUTO, the others in MANUAL.
        let auto: Vec<f64> = s
            .script
            .iter()
            .filter(|st| matches!(st.action, GroundAction::Send(Command::SpeedSetpoint { .. })))
            .map(|st| st.at_s)
            .collect();
        assert_eq!(auto, vec![9.3, 10.3, 11.3, 12.3, 13.3, 14.3]);
        let drives: Vec<(f64, f64)> = s
            .checks
            .iter()
            .filter_map(|c| match c {
                Check::Drives { from_s, to_s } => Some((*from_s, *to_s)),
                _ => None,
            })
            .collect();
        assert_eq!(drives, vec![(1.0, 5.0), (9.0, 15.0), (18.0, 29.0)]);
        assert_eq!(
            s.script.last().map(|st| st.action),
            Some(GroundAction::Send(Command::Kill))
        );
        assert!(s.script.windows(2).all(|p| p[0].at_s <= p[1].at_s));
        assert!(Scenario::by_name("soak", Some(12.0)).is_some_and(|s| s.duration_s == 12.0));
    }

    #[test]
    fn drives_needs_a_stretch_of_outputs_other_than_safe() {
        let e = evidence(vec![
            change(0.1, SAFE_US),
            change(1.0, [1600, 1545, 1500]),
            change(1.1, SAFE_US),
            change(2.0, [1600, 1545, 1500]),
            change(2.1, [1650, 1545, 1500]),
            change(2.3, SAFE_US),
        ]);
        let drives = |from_s, to_s| evaluate(&Check::Drives { from_s, to_s }, &e).unwrap();
        assert!(drives(0.5, 1.5).is_err(), "0.1 s is not driving");
        assert!(drives(1.5, 2.5).is_ok(), "0.3 s across two values is");
        assert!(drives(2.5, 3.0).is_err());
    }

    #[test]
    fn default_tour_is_consistent() {
        let s = Scenario::default_tour();
        assert!(s.script.windows(2).all(|w| w[0].at_s <= w[1].at_s));
        assert!(s
            .checks
            .iter()
            .all(|c| check_end(c) <= s.duration_s + 0.5 || !check_end(c).is_finite()));
        assert_eq!(s.phase_at(7.0), "AUTO 2.5 m/s, 120°");
        assert_eq!(s.phase_at(0.0), "KILLED (start-up)");
    }
}
