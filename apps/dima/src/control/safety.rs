//! The safety state machine: KILLED (start-up), MANUAL, AUTO, FAILSAFE.
//!
//! Two pure transition functions: [`SafetyState::on_command`] for every command event (in
//! arrival order) and [`SafetyState::on_cycle`] once per loop cycle, after the commands. Time is
//! an argument, so tests drive it like a table.
//!
//! Rules (DESIGN 4):
//! - any valid command frame is link activity;
//! - kill -> KILLED from any state, immediately;
//! - revive leaves KILLED or FAILSAFE for MANUAL, only while the sensor link and the loop are
//!   healthy; a revive in MANUAL or AUTO changes nothing;
//! - a manual command switches AUTO to MANUAL, a setpoint switches MANUAL to AUTO; in KILLED or
//!   FAILSAFE they are remembered but change no mode;
//! - in MANUAL or AUTO: no command for longer than the comms timeout, K consecutive bad or
//!   missing packets, or M consecutive overruns -> FAILSAFE, which latches until a revive;
//! - entering KILLED or FAILSAFE forgets every manual value and setpoint, so a revive starts
//!   from neutral.

use dima_groundlink::{Command, Percent};

use super::Nanos;
use crate::config::SafetyConfig;

/// Operating mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum Mode {
    /// Start-up and after a kill: safe outputs.
    Killed,
    /// Outputs follow the ground station's percentages.
    Manual,
    /// Outputs from the speed and heading controllers.
    Auto,
    /// Safe outputs after comms loss, sensor loss or overruns; latched until a revive.
    Failsafe,
}

impl Mode {
    /// Outputs are the configured safe values in this mode.
    pub fn is_safe(self) -> bool {
        matches!(self, Mode::Killed | Mode::Failsafe)
    }

    /// A small number for logs and plots (0 KILLED, 1 MANUAL, 2 AUTO, 3 FAILSAFE).
    pub fn code(self) -> u8 {
        self as u8
    }
}

/// Why FAILSAFE was entered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum FailsafeCause {
    /// No valid command frame within the comms timeout.
    CommsLoss,
    /// K consecutive bad or missing sensor packets.
    SensorLoss,
    /// M consecutive overrun periods.
    Overruns,
}

/// Thresholds, in the units the transition functions use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SafetyLimits {
    /// Comms timeout, ns.
    pub comms_timeout_ns: Nanos,
    /// K: consecutive bad packets that trip FAILSAFE.
    pub sensor_loss_packets: u32,
    /// M: consecutive overruns that trip FAILSAFE.
    pub overrun_limit: u32,
}

impl From<&SafetyConfig> for SafetyLimits {
    fn from(c: &SafetyConfig) -> SafetyLimits {
        SafetyLimits {
            comms_timeout_ns: u64::from(c.comms_timeout_ms) * 1_000_000,
            sensor_loss_packets: c.sensor_loss_packets.max(1),
            overrun_limit: c.overrun_limit.max(1),
        }
    }
}

/// What the ground station asked for. `None`: not given since the last reset (neutral for
/// manual channels, no setpoint for the controllers).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Setpoints {
    /// Manual throttle.
    pub throttle: Option<Percent>,
    /// Manual steering.
    pub steering: Option<Percent>,
    /// Manual tail.
    pub tail: Option<Percent>,
    /// AUTO ground speed, mm/s.
    pub speed_mm_s: Option<i32>,
    /// AUTO heading, 1e-5 degrees.
    pub heading_deg_e5: Option<i32>,
}

/// One cycle's health inputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CycleHealth {
    /// A valid packet arrived in time this cycle.
    pub packet_ok: bool,
    /// The previous period overran (the clock skipped at least one period).
    pub overrun: bool,
}

/// The whole state of the safety logic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SafetyState {
    /// Current mode.
    pub mode: Mode,
    /// Why the last FAILSAFE was entered (kept until a revive).
    pub cause: Option<FailsafeCause>,
    /// Time of the last valid command frame.
    pub last_link_ns: Option<Nanos>,
    /// Consecutive bad or missing packets.
    pub bad_packets: u32,
    /// Consecutive overruns.
    pub overruns: u32,
    /// Current manual values and setpoints.
    pub setpoints: Setpoints,
}

impl Default for SafetyState {
    fn default() -> Self {
        SafetyState::new()
    }
}

impl SafetyState {
    /// Start-up: KILLED, no link seen yet.
    pub const fn new() -> SafetyState {
        SafetyState {
            mode: Mode::Killed,
            cause: None,
            last_link_ns: None,
            bad_packets: 0,
            overruns: 0,
            setpoints: Setpoints {
                throttle: None,
                steering: None,
                tail: None,
                speed_mm_s: None,
                heading_deg_e5: None,
            },
        }
    }

    fn healthy(&self, limits: &SafetyLimits) -> bool {
        self.bad_packets < limits.sensor_loss_packets && self.overruns < limits.overrun_limit
    }

    fn enter_safe(mut self, mode: Mode, cause: Option<FailsafeCause>) -> SafetyState {
        self.mode = mode;
        self.cause = cause;
        self.setpoints = Setpoints::default();
        self
    }

    /// A setpoint switches MANUAL to AUTO and leaves every other mode alone.
    fn auto_from(mode: Mode) -> Mode {
        if mode == Mode::Manual {
            Mode::Auto
        } else {
            mode
        }
    }

    /// A valid command arrived at `now`.
    pub fn on_command(mut self, limits: &SafetyLimits, command: Command, now: Nanos) -> Self {
        self.last_link_ns = Some(now);
        let sp = &mut self.setpoints;
        match command {
            Command::Heartbeat => {}
            Command::Kill => return self.enter_safe(Mode::Killed, None),
            Command::Revive => {
                if self.mode.is_safe() && self.healthy(limits) {
                    self.mode = Mode::Manual;
                    self.cause = None;
                    self.setpoints = Setpoints::default();
                }
            }
            Command::Throttle(p) | Command::Steering(p) | Command::Tail(p) => {
                match command {
                    Command::Throttle(_) => sp.throttle = Some(p),
                    Command::Steering(_) => sp.steering = Some(p),
                    _ => sp.tail = Some(p),
                }
                if self.mode == Mode::Auto {
                    self.mode = Mode::Manual;
                }
            }
            Command::SpeedSetpoint { mm_s } => {
                sp.speed_mm_s = Some(mm_s);
                self.mode = Self::auto_from(self.mode);
            }
            Command::HeadingSetpoint { deg_e5 } => {
                sp.heading_deg_e5 = Some(deg_e5);
                self.mode = Self::auto_from(self.mode);
            }
        }
        self
    }

    /// End of the command phase of a cycle at `now`.
    pub fn on_cycle(mut self, limits: &SafetyLimits, health: CycleHealth, now: Nanos) -> Self {
        self.bad_packets = if health.packet_ok {
            0
        } else {
            self.bad_packets.saturating_add(1)
        };
        self.overruns = if health.overrun {
            self.overruns.saturating_add(1)
        } else {
            0
        };
        if self.mode.is_safe() {
            return self;
        }
        let link_lost = match self.last_link_ns {
            Some(t) => now.saturating_sub(t) > limits.comms_timeout_ns,
            None => true,
        };
        if link_lost {
            self.enter_safe(Mode::Failsafe, Some(FailsafeCause::CommsLoss))
        } else if self.bad_packets >= limits.sensor_loss_packets {
            self.enter_safe(Mode::Failsafe, Some(FailsafeCause::SensorLoss))
        } else if self.overruns >= limits.overrun_limit {
            self.enter_safe(Mode::Failsafe, Some(FailsafeCause::Overruns))
        } else {
            self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Mode::*;

    const MS: Nanos = 1_000_000;
    const LIMITS: SafetyLimits = SafetyLimits {
        comms_timeout_ns: 1_000 * MS,
        sensor_loss_packets: 3,
        overrun_limit: 2,
    };
    const OK: CycleHealth = CycleHealth {
        packet_ok: true,
        overrun: false,
    };
    const BAD: CycleHealth = CycleHealth {
        packet_ok: false,
        overrun: false,
    };
    const OVERRUN: CycleHealth = CycleHealth {
        packet_ok: true,
        overrun: true,
    };

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    /// One step of a scripted run.
    enum Ev {
        Cmd(Command),
        Cycle(CycleHealth),
    }

    /// Runs `(time_ms, event, expected mode after it)` rows from the start-up state.
    fn run_table(rows: &[(u64, Ev, Mode)]) -> SafetyState {
        let mut s = SafetyState::new();
        for (i, (t, ev, want)) in rows.iter().enumerate() {
            s = match ev {
                Ev::Cmd(c) => s.on_command(&LIMITS, *c, t * MS),
                Ev::Cycle(h) => s.on_cycle(&LIMITS, *h, t * MS),
            };
            assert_eq!(s.mode, *want, "row {i} at {t} ms: {s:?}");
        }
        s
    }

    use Ev::{Cmd, Cycle};

    #[test]
    fn starts_killed_and_stays_killed_without_a_revive() {
        run_table(&[
            (0, Cycle(OK), Killed),
            (10, Cmd(Command::Heartbeat), Killed),
            (20, Cmd(Command::Throttle(pct(80))), Killed),
            (5_000, Cycle(OK), Killed),
        ]);
    }

    #[test]
    fn revive_manual_auto_manual_kill() {
        let s = run_table(&[
            (0, Cmd(Command::Revive), Manual),
            (4, Cycle(OK), Manual),
            (8, Cmd(Command::Throttle(pct(60))), Manual),
            (12, Cmd(Command::SpeedSetpoint { mm_s: 2000 }), Auto),
            (
                16,
                Cmd(Command::HeadingSetpoint { deg_e5: 9_000_000 }),
                Auto,
            ),
            (20, Cycle(OK), Auto),
            (24, Cmd(Command::Steering(pct(50))), Manual),
            (28, Cmd(Command::Revive), Manual),
            (32, Cmd(Command::Kill), Killed),
        ]);
        assert_eq!(s.setpoints, Setpoints::default(), "kill forgets setpoints");
    }

    #[test]
    fn comms_loss_trips_within_one_period_of_the_deadline() {
        let period = 4;
        let mut rows = vec![(0, Cmd(Command::Revive), Manual)];
        // Cycles every 4 ms; the link is silent after t = 0.
        let mut t = period;
        while t <= 1_000 {
            rows.push((t, Cycle(OK), Manual));
            t += period;
        }
        rows.push((t, Cycle(OK), Failsafe));
        let s = run_table(&rows);
        assert!(t <= 1_000 + period);
        assert_eq!(s.cause, Some(FailsafeCause::CommsLoss));
    }

    #[test]
    fn failsafe_latches_until_revive() {
        let s = run_table(&[
            (0, Cmd(Command::Revive), Manual),
            (1_001, Cycle(OK), Failsafe),
            (1_010, Cmd(Command::Heartbeat), Failsafe),
            (1_014, Cycle(OK), Failsafe),
            (1_018, Cmd(Command::Throttle(pct(90))), Failsafe),
            (1_019, Cmd(Command::SpeedSetpoint { mm_s: 1 }), Failsafe),
            (1_022, Cycle(OK), Failsafe),
            (1_026, Cmd(Command::Revive), Manual),
            (1_030, Cycle(OK), Manual),
        ]);
        assert_eq!(s.cause, None);
        assert_eq!(s.setpoints, Setpoints::default());
    }

    #[test]
    fn sensor_loss_after_k_consecutive_bad_packets() {
        let s = run_table(&[
            (0, Cmd(Command::Revive), Manual),
            (4, Cycle(BAD), Manual),
            (8, Cycle(BAD), Manual),
            (12, Cycle(OK), Manual), // the run is broken: count restarts
            (16, Cycle(BAD), Manual),
            (20, Cycle(BAD), Manual),
            (24, Cycle(BAD), Failsafe),
            // A revive is refused while the sensor link is still down...
            (25, Cmd(Command::Revive), Failsafe),
            (28, Cycle(OK), Failsafe),
            // ...and accepted once it is healthy again.
            (29, Cmd(Command::Revive), Manual),
        ]);
        assert_eq!(s.bad_packets, 0);
    }

    #[test]
    fn overruns_after_m_consecutive() {
        let s = run_table(&[
            (0, Cmd(Command::Revive), Manual),
            (4, Cycle(OVERRUN), Manual),
            (8, Cycle(OK), Manual),
            (12, Cycle(OVERRUN), Manual),
            (16, Cycle(OVERRUN), Failsafe),
        ]);
        assert_eq!(s.cause, Some(FailsafeCause::Overruns));
    }

    #[test]
    fn kill_wins_from_every_mode() {
        for start in [Killed, Manual, Auto, Failsafe] {
            let s = SafetyState {
                mode: start,
                ..SafetyState::new()
            };
            assert_eq!(s.on_command(&LIMITS, Command::Kill, 0).mode, Killed);
        }
    }

    #[test]
    fn killed_does_not_become_failsafe() {
        run_table(&[(0, Cycle(BAD), Killed), (2_000, Cycle(BAD), Killed)]);
    }

    #[test]
    fn setpoints_are_kept_in_auto() {
        let s = run_table(&[
            (0, Cmd(Command::Revive), Manual),
            (1, Cmd(Command::HeadingSetpoint { deg_e5: 123 }), Auto),
            (2, Cmd(Command::SpeedSetpoint { mm_s: -500 }), Auto),
        ]);
        assert_eq!(s.setpoints.heading_deg_e5, Some(123));
        assert_eq!(s.setpoints.speed_mm_s, Some(-500));
    }
}
