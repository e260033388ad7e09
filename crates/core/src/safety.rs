//! The safety state machine: KILLED (start-up), MANUAL, AUTO, FAILSAFE.
//!
//! Two pure transition functions: [`SafetyState::on_command`] for every command event (in
//! arrival order) and [`SafetyState::on_cycle`] once per loop cycle, after the commands. Time is
//! an argument, so tests drive it like a table.
//!
//! Rules:
//! - any valid command frame is link activity, as of when it arrived (a command the step takes
//!   later, after waiting in the port, a thread or a ring, proves the link only up to its
//!   arrival);
//! - a command that arrived longer than the comms timeout before the cycle that takes it is
//!   stale: no link activity and no instruction the operator still stands by, so it is not acted
//!   on (a kill always is);
//! - kill -> KILLED from any state, immediately;
//! - revive leaves KILLED or FAILSAFE for MANUAL at neutral, only while nothing blocks it (see
//!   [`ReviveRefusal`]: among others, enough good packets since the sensor link was last lost,
//!   and at least `revive_min_interval_ms` since the last kill or revive: toggling is
//!   rate-limited, a kill never is); a revive in MANUAL or AUTO changes nothing;
//! - a heading setpoint outside 0..36 000 000 (1e-5 degrees) is rejected like an out-of-range
//!   speed, whatever built the command (the ground-link decoder checks it too);
//! - a manual command in AUTO switches to MANUAL with every channel at neutral except the one
//!   just commanded, and forgets the AUTO setpoints;
//! - a speed or heading setpoint switches MANUAL to AUTO and forgets the manual values; a speed
//!   setpoint below 0 or above the configured maximum is rejected and changes nothing (AUTO is
//!   forward-only);
//! - in KILLED or FAILSAFE manual values and setpoints change no mode and are not kept;
//! - in MANUAL or AUTO: no command for longer than the comms timeout, K consecutive bad or
//!   missing packets, a stuck IMU (the accelerometer's or the gyroscope's words frozen, each
//!   die judged on its own), or an overrunning loop (too many late wake-ups within a second, or
//!   too long a stall), or a car rolled over (see [`crate::monitor::RolloverMonitor`]) ->
//!   FAILSAFE, and so does a new GNSS fix outside the geofence (see
//!   [`crate::monitor::Geofence`]); in AUTO also GNSS older than its timeout (a fix counts only
//!   while it is valid and its time of week advances past the newest fix used: a repeated or
//!   backward iTOW is old data), and in MANUAL too when a geofence is configured (without a
//!   fresh fix the fence cannot be judged). FAILSAFE latches until a revive;
//! - entering KILLED or FAILSAFE forgets every manual value and setpoint, so a revive starts
//!   from neutral;
//! - every mode transition is counted ([`SafetyState::mode_transitions`]), also those that come
//!   back to the mode the cycle started in (AUTO -> MANUAL -> AUTO from two commands in one
//!   cycle): the step resets the controllers and drops the held action on any of them.

use dima_groundlink::{Command, Percent, HEADING_FULL_TURN_DEG_E5};

use crate::config::{ControlConfig, SafetyConfig};
use crate::Nanos;

/// Largest `safety.overrun_limit` (the overrun window keeps that many late wake-ups).
pub const MAX_OVERRUN_LIMIT: u32 = 250;

/// Operating mode. In logs: `KILLED`, `MANUAL`, `AUTO`, `FAILSAFE`.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Mode {
    /// Start-up and after a kill: safe outputs.
    Killed,
    /// Outputs follow the ground station's percentages.
    Manual,
    /// Outputs from the speed and heading controllers.
    Auto,
    /// Safe outputs after a failure; latched until a revive.
    Failsafe,
}

impl Mode {
    /// Outputs are the configured safe values in this mode.
    pub fn is_safe(self) -> bool {
        matches!(self, Mode::Killed | Mode::Failsafe)
    }

    /// The name used in logs, status lines and on the ground link.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Killed => "KILLED",
            Mode::Manual => "MANUAL",
            Mode::Auto => "AUTO",
            Mode::Failsafe => "FAILSAFE",
        }
    }
}

impl core::fmt::Display for Mode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// Why FAILSAFE was entered. In logs by its variant name, e.g. `CommsLoss`.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
pub enum FailsafeCause {
    /// No valid command frame within the comms timeout.
    CommsLoss,
    /// K consecutive bad, missing, stale or late sensor packets.
    SensorLoss,
    /// Identical accelerometer words, or identical gyroscope words, for many packets.
    ImuStuck,
    /// The loop overran: more late wake-ups within a second than `safety.overrun_limit`, or
    /// periods missed within a second adding up to more than `safety.max_stall_ms`.
    Overrun,
    /// In AUTO, no fresh GNSS fix within the GNSS timeout; in MANUAL too when a geofence is
    /// configured (without a fix the fence cannot be judged).
    GnssStale,
    /// The accelerometer's reading tilted beyond `navigation.rollover_tilt_deg` for
    /// `navigation.rollover_ms`: the car lies on its side or its roof.
    Rollover,
    /// In MANUAL or AUTO, a new GNSS fix outside the geofence (`[navigation.fence]`).
    Geofence,
}

/// Why a revive was refused. In logs by its variant name.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
pub enum ReviveRefusal {
    /// The sensor link is down, or not yet back: fewer than `revive_good_packets` good packets
    /// since it was last lost (K bad in a row) or since start-up.
    SensorLoss,
    /// The IMU is stuck.
    ImuStuck,
    /// The loop is overrunning.
    Overrun,
    /// The required realtime setup failed (`realtime.required`).
    RealtimeSetup,
    /// Less than `safety.revive_min_interval_ms` since the last kill or revive.
    TooSoon,
    /// The last packet shows the car tilted beyond `navigation.rollover_tilt_deg`: it is not
    /// on its wheels.
    RolledOver,
    /// A geofence is configured and the newest fix is outside its inclusion areas, or there is
    /// no fresh fix to tell.
    OutsideFence,
}

/// Thresholds, in the units the transition functions use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SafetyLimits {
    /// Comms timeout, ns.
    pub comms_timeout_ns: Nanos,
    /// K: consecutive bad packets that trip FAILSAFE.
    pub sensor_loss_packets: u32,
    /// Good packets since the last loss that a revive needs.
    pub revive_good_packets: u32,
    /// Largest speed setpoint accepted, mm/s.
    pub max_speed_mm_s: i32,
    /// Shortest time from a kill or revive to the next revive, ns.
    pub revive_min_interval_ns: Nanos,
}

impl SafetyLimits {
    /// From the (validated) configuration.
    pub fn new(safety: &SafetyConfig, control: &ControlConfig) -> SafetyLimits {
        SafetyLimits {
            comms_timeout_ns: u64::from(safety.comms_timeout_ms) * 1_000_000,
            sensor_loss_packets: safety.sensor_loss_packets.max(1),
            revive_good_packets: safety.revive_good_packets.max(1),
            max_speed_mm_s: control.max_speed_mm_s,
            revive_min_interval_ns: u64::from(safety.revive_min_interval_ms) * 1_000_000,
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
    /// AUTO ground speed, mm/s (0..=max, forward only).
    pub speed_mm_s: Option<i32>,
    /// AUTO heading, 1e-5 degrees.
    pub heading_deg_e5: Option<i32>,
}

/// One cycle's health, as the monitors of the step judged it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CycleHealth {
    /// A valid packet, paired with this cycle's request, arrived in time.
    pub packet_ok: bool,
    /// The loop overran (see [`FailsafeCause::Overrun`]).
    pub overrunning: bool,
    /// One IMU die's words (the accelerometer's or the gyroscope's) have not changed for the
    /// stuck threshold.
    pub imu_stuck: bool,
    /// No fresh GNSS fix within the GNSS timeout.
    pub gnss_stale: bool,
    /// The car has been tilted beyond the rollover angle for the rollover time.
    pub rolled_over: bool,
    /// The newest valid GNSS fix was outside the geofence.
    pub outside_fence: bool,
    /// A geofence is configured: GNSS must be fresh in MANUAL as well as in AUTO, or the
    /// fence cannot be judged.
    pub fenced: bool,
}

impl CycleHealth {
    /// Everything fine.
    pub const GOOD: CycleHealth = CycleHealth {
        packet_ok: true,
        overrunning: false,
        imu_stuck: false,
        gnss_stale: false,
        rolled_over: false,
        outside_fence: false,
        fenced: false,
    };
}

/// A command as a cycle takes it: what, and when its frame arrived.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReceivedCommand {
    /// The command.
    pub command: Command,
    /// When its frame arrived, ns, on the clock of the cycle's time (the application takes the
    /// earliest time the frame can have been complete at the port).
    pub arrival_ns: Nanos,
}

impl ReceivedCommand {
    /// `command`, arrived at `arrival_ns`.
    pub const fn new(command: Command, arrival_ns: Nanos) -> ReceivedCommand {
        ReceivedCommand {
            command,
            arrival_ns,
        }
    }

    /// It arrived longer than `comms_timeout_ns` before `now`.
    pub fn is_stale(&self, now: Nanos, comms_timeout_ns: Nanos) -> bool {
        now.saturating_sub(self.arrival_ns) > comms_timeout_ns
    }
}

/// What a command did besides changing the state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CommandEffect {
    /// A setpoint was out of range and ignored.
    pub rejected: bool,
    /// A revive was refused, and why.
    pub refused: Option<ReviveRefusal>,
    /// The command arrived longer than the comms timeout before the cycle: not acted on.
    pub stale: bool,
}

/// The whole state of the safety logic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SafetyState {
    /// Current mode.
    pub mode: Mode,
    /// Why FAILSAFE was entered, while in FAILSAFE (a revive or a kill clears it; the
    /// application keeps the last cause for the operator until a revive).
    pub cause: Option<FailsafeCause>,
    /// Arrival time of the newest valid command frame acted on (never later than the cycle
    /// that took it).
    pub last_link_ns: Option<Nanos>,
    /// Consecutive bad or missing packets (`u32::MAX` until the first good packet: the
    /// sensor link is not healthy before it has delivered anything).
    pub bad_packets: u32,
    /// Good packets since the sensor link was last lost (`sensor_loss_packets` bad ones in a
    /// row). A revive needs `revive_good_packets` of them, so a lone packet amid a loss (a late
    /// answer that happened to land in the answer window) does not make the link look
    /// healthy, while an odd bad packet in a working link does not block a revive.
    pub good_packets: u32,
    /// Current manual values and setpoints.
    pub setpoints: Setpoints,
    /// Time of the last kill or accepted revive (the next revive waits
    /// `revive_min_interval_ns` from it).
    pub last_toggle_ns: Option<Nanos>,
    /// Mode transitions since start-up (wrapping). Commands can leave a mode and come back to
    /// it within one cycle (AUTO -> MANUAL -> AUTO); comparing this count, not just the mode,
    /// before and after a cycle sees every transition.
    pub mode_transitions: u32,
}

impl Default for SafetyState {
    fn default() -> Self {
        SafetyState::new()
    }
}

impl SafetyState {
    /// Start-up: KILLED, no link seen yet, no packet yet.
    pub const fn new() -> SafetyState {
        SafetyState {
            mode: Mode::Killed,
            cause: None,
            last_link_ns: None,
            bad_packets: u32::MAX,
            good_packets: 0,
            setpoints: Setpoints {
                throttle: None,
                steering: None,
                tail: None,
                speed_mm_s: None,
                heading_deg_e5: None,
            },
            last_toggle_ns: None,
            mode_transitions: 0,
        }
    }

    /// Why a revive would be refused now: the sensor link, then `blocked` (a stuck IMU, an
    /// overrunning loop or a failed realtime setup, as the step knows them).
    pub fn revive_refusal(
        &self,
        limits: &SafetyLimits,
        blocked: Option<ReviveRefusal>,
    ) -> Option<ReviveRefusal> {
        let lost = self.bad_packets >= limits.sensor_loss_packets;
        if lost || self.good_packets < limits.revive_good_packets {
            Some(ReviveRefusal::SensorLoss)
        } else {
            blocked
        }
    }

    /// Switches to `mode`, counting the transition when it is one.
    fn switch_to(&mut self, mode: Mode) {
        if self.mode != mode {
            self.mode = mode;
            self.mode_transitions = self.mode_transitions.wrapping_add(1);
        }
    }

    fn enter_safe(&mut self, mode: Mode, cause: Option<FailsafeCause>) {
        self.switch_to(mode);
        self.cause = cause;
        self.setpoints = Setpoints::default();
    }

    /// A manual value: in AUTO it switches to MANUAL from neutral; only MANUAL keeps it.
    fn manual(&mut self, command: Command) {
        match self.mode {
            Mode::Manual => {}
            Mode::Auto => {
                self.switch_to(Mode::Manual);
                self.setpoints = Setpoints::default();
            }
            Mode::Killed | Mode::Failsafe => return,
        }
        let sp = &mut self.setpoints;
        match command {
            Command::Throttle(p) => sp.throttle = Some(p),
            Command::Steering(p) => sp.steering = Some(p),
            Command::Tail(p) => sp.tail = Some(p),
            _ => {}
        }
    }

    /// A setpoint: in MANUAL it switches to AUTO without the manual values; only AUTO keeps it.
    fn setpoint(&mut self, command: Command) {
        match self.mode {
            Mode::Auto => {}
            Mode::Manual => {
                self.switch_to(Mode::Auto);
                self.setpoints = Setpoints::default();
            }
            Mode::Killed | Mode::Failsafe => return,
        }
        let sp = &mut self.setpoints;
        match command {
            Command::SpeedSetpoint { mm_s } => sp.speed_mm_s = Some(mm_s),
            Command::HeadingSetpoint { deg_e5 } => sp.heading_deg_e5 = Some(deg_e5),
            _ => {}
        }
    }

    /// A valid command, taken by a cycle at `now`; `blocked` says what besides the sensor link
    /// would refuse a revive.
    ///
    /// The link was last seen when the command arrived (an arrival after `now` counts as
    /// `now`; the link time never moves back). A command other than a kill that arrived longer
    /// than the comms timeout before `now` is stale: it changes nothing, not even the link
    /// time. Kills and revives are dated `now` for the revive rate limit: the time the robot
    /// acted on them.
    pub fn on_command(
        &mut self,
        limits: &SafetyLimits,
        received: ReceivedCommand,
        now: Nanos,
        blocked: Option<ReviveRefusal>,
    ) -> CommandEffect {
        let command = received.command;
        let mut effect = CommandEffect::default();
        if command != Command::Kill && received.is_stale(now, limits.comms_timeout_ns) {
            effect.stale = true;
            return effect;
        }
        let seen_ns = received.arrival_ns.min(now);
        self.last_link_ns = Some(self.last_link_ns.map_or(seen_ns, |t| t.max(seen_ns)));
        match command {
            Command::Heartbeat => {}
            Command::Kill => {
                self.enter_safe(Mode::Killed, None);
                self.last_toggle_ns = Some(now);
            }
            Command::Revive => {
                let too_soon = self
                    .last_toggle_ns
                    .is_some_and(|t| now.saturating_sub(t) < limits.revive_min_interval_ns);
                if self.mode.is_safe() {
                    let refusal = if too_soon {
                        Some(ReviveRefusal::TooSoon)
                    } else {
                        self.revive_refusal(limits, blocked)
                    };
                    match refusal {
                        Some(why) => effect.refused = Some(why),
                        None => {
                            self.switch_to(Mode::Manual);
                            self.cause = None;
                            self.setpoints = Setpoints::default();
                            self.last_toggle_ns = Some(now);
                        }
                    }
                }
            }
            Command::Throttle(_) | Command::Steering(_) | Command::Tail(_) => self.manual(command),
            Command::SpeedSetpoint { mm_s } if !(0..=limits.max_speed_mm_s).contains(&mm_s) => {
                effect.rejected = true;
            }
            Command::HeadingSetpoint { deg_e5 }
                if !(0..HEADING_FULL_TURN_DEG_E5).contains(&deg_e5) =>
            {
                effect.rejected = true;
            }
            Command::SpeedSetpoint { .. } | Command::HeadingSetpoint { .. } => {
                self.setpoint(command)
            }
        }
        effect
    }

    /// End of the command phase of a cycle at `now`.
    pub fn on_cycle(&mut self, limits: &SafetyLimits, health: CycleHealth, now: Nanos) {
        if health.packet_ok {
            self.bad_packets = 0;
            self.good_packets = self.good_packets.saturating_add(1);
        } else {
            self.bad_packets = self.bad_packets.saturating_add(1);
            if self.bad_packets >= limits.sensor_loss_packets {
                self.good_packets = 0;
            }
        }
        if self.mode.is_safe() {
            return;
        }
        let link_lost = match self.last_link_ns {
            Some(t) => now.saturating_sub(t) > limits.comms_timeout_ns,
            None => true,
        };
        let cause = if link_lost {
            Some(FailsafeCause::CommsLoss)
        } else if self.bad_packets >= limits.sensor_loss_packets {
            Some(FailsafeCause::SensorLoss)
        } else if health.imu_stuck {
            Some(FailsafeCause::ImuStuck)
        } else if health.overrunning {
            Some(FailsafeCause::Overrun)
        } else if health.rolled_over {
            Some(FailsafeCause::Rollover)
        } else if health.outside_fence {
            Some(FailsafeCause::Geofence)
        } else if health.gnss_stale && (self.mode == Mode::Auto || health.fenced) {
            Some(FailsafeCause::GnssStale)
        } else {
            None
        };
        if let Some(cause) = cause {
            self.enter_safe(Mode::Failsafe, Some(cause));
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
        revive_good_packets: 3,
        max_speed_mm_s: 5_000,
        revive_min_interval_ns: 250 * MS,
    };
    const OK: CycleHealth = CycleHealth::GOOD;
    const BAD: CycleHealth = CycleHealth {
        packet_ok: false,
        ..CycleHealth::GOOD
    };

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    /// One step of a scripted run.
    enum Ev {
        Cmd(Command),
        Cycle(CycleHealth),
    }

    /// `command`, taken by a cycle at `now`, the time it arrived.
    fn fresh(
        s: &mut SafetyState,
        command: Command,
        now: Nanos,
        blocked: Option<ReviveRefusal>,
    ) -> CommandEffect {
        s.on_command(&LIMITS, ReceivedCommand::new(command, now), now, blocked)
    }

    /// After start-up, as many good packets as a revive needs.
    fn healthy() -> SafetyState {
        let mut s = SafetyState::new();
        for _ in 0..LIMITS.revive_good_packets {
            s.on_cycle(&LIMITS, OK, 0);
        }
        s
    }

    /// Runs `(time_ms, event, expected mode after it)` rows from a healthy sensor link.
    fn run_table(rows: &[(u64, Ev, Mode)]) -> SafetyState {
        let mut s = healthy();
        for (i, (t, ev, want)) in rows.iter().enumerate() {
            match ev {
                Ev::Cmd(c) => {
                    fresh(&mut s, *c, t * MS, None);
                }
                Ev::Cycle(h) => s.on_cycle(&LIMITS, *h, t * MS),
            }
            assert_eq!(s.mode, *want, "row {i} at {t} ms: {s:?}");
        }
        s
    }

    use Ev::{Cmd, Cycle};

    #[test]
    fn starts_killed_and_stays_killed_without_a_revive() {
        let s = run_table(&[
            (0, Cycle(OK), Killed),
            (10, Cmd(Command::Heartbeat), Killed),
            (20, Cmd(Command::Throttle(pct(80))), Killed),
            (5_000, Cycle(OK), Killed),
        ]);
        assert_eq!(
            s.setpoints,
            Setpoints::default(),
            "nothing kept while KILLED"
        );
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
    fn entering_auto_forgets_the_manual_values() {
        let s = run_table(&[
            (0, Cmd(Command::Revive), Manual),
            (8, Cmd(Command::Throttle(pct(80))), Manual),
            (9, Cmd(Command::Tail(pct(10))), Manual),
            (12, Cmd(Command::SpeedSetpoint { mm_s: 2000 }), Auto),
        ]);
        assert_eq!(
            s.setpoints,
            Setpoints {
                speed_mm_s: Some(2000),
                ..Setpoints::default()
            }
        );
    }

    #[test]
    fn leaving_auto_keeps_only_the_channel_just_commanded() {
        // Throttle 80 % before AUTO must not come back when a steering command leaves AUTO.
        let s = run_table(&[
            (0, Cmd(Command::Revive), Manual),
            (8, Cmd(Command::Throttle(pct(80))), Manual),
            (12, Cmd(Command::SpeedSetpoint { mm_s: 2000 }), Auto),
            (16, Cmd(Command::HeadingSetpoint { deg_e5: 100 }), Auto),
            (20, Cmd(Command::Steering(pct(30))), Manual),
        ]);
        assert_eq!(
            s.setpoints,
            Setpoints {
                steering: Some(pct(30)),
                ..Setpoints::default()
            }
        );
    }

    #[test]
    fn speed_setpoints_outside_zero_to_max_are_rejected_and_change_nothing() {
        let mut s = healthy();
        fresh(&mut s, Command::Revive, 0, None);
        fresh(&mut s, Command::Throttle(pct(55)), 1, None);
        let before = s;
        for mm_s in [-1, -1000, 5_001, i32::MAX, i32::MIN] {
            let effect = fresh(&mut s, Command::SpeedSetpoint { mm_s }, 2, None);
            assert!(effect.rejected, "{mm_s}");
            assert_eq!(s.mode, Manual, "{mm_s}: no mode change");
            assert_eq!(s.setpoints, before.setpoints, "{mm_s}");
        }
        for mm_s in [0, 5_000] {
            let mut t = before;
            let effect = fresh(&mut t, Command::SpeedSetpoint { mm_s }, 3, None);
            assert!(!effect.rejected, "{mm_s}");
            assert_eq!((t.mode, t.setpoints.speed_mm_s), (Auto, Some(mm_s)));
        }
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
            // (The loss comes later than `revive_min_interval_ns` after that revive, so only
            // the sensor link can refuse the next ones.)
            (304, Cycle(BAD), Manual),
            (308, Cycle(BAD), Manual),
            (312, Cycle(OK), Manual), // the run is broken: count restarts
            (316, Cycle(BAD), Manual),
            (320, Cycle(BAD), Manual),
            (324, Cycle(BAD), Failsafe),
            // A revive is refused while the sensor link is still down...
            (325, Cmd(Command::Revive), Failsafe),
            (328, Cycle(OK), Failsafe),
            (329, Cycle(OK), Failsafe),
            // ...and while it is not yet healthy for as long as it took to trip...
            (330, Cmd(Command::Revive), Failsafe),
            (332, Cycle(OK), Failsafe),
            // ...and accepted once it is.
            (333, Cmd(Command::Revive), Manual),
        ]);
        assert_eq!(s.bad_packets, 0);
    }

    #[test]
    fn revive_toggling_is_rate_limited_and_kill_never_is() {
        let mut s = healthy();
        let revive =
            |s: &mut SafetyState, t_ms: u64| fresh(s, Command::Revive, t_ms * MS, None).refused;
        assert_eq!(
            revive(&mut s, 0),
            None,
            "the first revive has nothing to wait for"
        );
        assert_eq!(s.mode, Manual);
        // A kill right after the revive: never delayed.
        fresh(&mut s, Command::Kill, MS, None);
        assert_eq!(s.mode, Killed);
        // A revive 249 ms after the kill: refused; at 250 ms: accepted.
        assert_eq!(revive(&mut s, 250), Some(ReviveRefusal::TooSoon));
        assert_eq!(s.mode, Killed);
        assert_eq!(revive(&mut s, 251), None);
        assert_eq!(s.mode, Manual);
        // A failsafe, then a kill: the wait starts at the kill; a refused revive does not
        // restart it.
        s.on_cycle(&LIMITS, OK, 300 * MS);
        s.on_cycle(&LIMITS, OK, 1_400 * MS); // comms loss: no command since 251 ms
        assert_eq!(s.mode, Failsafe);
        fresh(&mut s, Command::Kill, 1_400 * MS, None);
        assert_eq!(revive(&mut s, 1_500), Some(ReviveRefusal::TooSoon));
        assert_eq!(revive(&mut s, 1_649), Some(ReviveRefusal::TooSoon));
        assert_eq!(revive(&mut s, 1_650), None);
        // Kills repeated for a second (as the ground station sends them) each restart the
        // wait; each of them kills.
        for t in (1_700..2_700).step_by(100) {
            fresh(&mut s, Command::Kill, t * MS, None);
            assert_eq!(s.mode, Killed);
        }
        assert_eq!(revive(&mut s, 2_700), Some(ReviveRefusal::TooSoon));
        assert_eq!(revive(&mut s, 2_850), None);
        // A revive while driving changes nothing and is not refused.
        assert_eq!(revive(&mut s, 2_860), None);
        assert_eq!(s.mode, Manual);
    }

    #[test]
    fn out_of_range_heading_setpoints_are_rejected_in_the_core() {
        let mut s = run_table(&[(0, Cmd(Command::Revive), Manual)]);
        for deg_e5 in [-1, i32::MIN, HEADING_FULL_TURN_DEG_E5, i32::MAX] {
            let effect = fresh(&mut s, Command::HeadingSetpoint { deg_e5 }, MS, None);
            assert!(effect.rejected, "{deg_e5}");
            assert_eq!((s.mode, s.setpoints.heading_deg_e5), (Manual, None));
        }
        for deg_e5 in [0, HEADING_FULL_TURN_DEG_E5 - 1] {
            let effect = fresh(&mut s, Command::HeadingSetpoint { deg_e5 }, MS, None);
            assert!(!effect.rejected);
            assert_eq!((s.mode, s.setpoints.heading_deg_e5), (Auto, Some(deg_e5)));
        }
    }

    #[test]
    fn a_blocked_revive_is_refused_with_its_reason() {
        for why in [
            ReviveRefusal::ImuStuck,
            ReviveRefusal::Overrun,
            ReviveRefusal::RealtimeSetup,
            ReviveRefusal::RolledOver,
            ReviveRefusal::OutsideFence,
        ] {
            let mut s = healthy();
            let effect = fresh(&mut s, Command::Revive, 0, Some(why));
            assert_eq!((s.mode, effect.refused), (Killed, Some(why)));
        }
    }

    #[test]
    fn monitors_trip_failsafe_with_their_cause() {
        for (health, cause) in [
            (
                CycleHealth {
                    imu_stuck: true,
                    ..OK
                },
                FailsafeCause::ImuStuck,
            ),
            (
                CycleHealth {
                    overrunning: true,
                    ..OK
                },
                FailsafeCause::Overrun,
            ),
            (
                CycleHealth {
                    rolled_over: true,
                    ..OK
                },
                FailsafeCause::Rollover,
            ),
            (
                CycleHealth {
                    outside_fence: true,
                    ..OK
                },
                FailsafeCause::Geofence,
            ),
            (
                CycleHealth {
                    gnss_stale: true,
                    fenced: true,
                    ..OK
                },
                FailsafeCause::GnssStale,
            ),
        ] {
            let mut s = healthy();
            fresh(&mut s, Command::Revive, 0, None);
            s.on_cycle(&LIMITS, health, 4 * MS);
            assert_eq!((s.mode, s.cause), (Failsafe, Some(cause)));
        }
    }

    #[test]
    fn stale_gnss_trips_only_in_auto() {
        let stale = CycleHealth {
            gnss_stale: true,
            ..OK
        };
        let mut s = healthy();
        fresh(&mut s, Command::Revive, 0, None);
        s.on_cycle(&LIMITS, stale, MS);
        assert_eq!(s.mode, Manual, "manual driving needs no GNSS");
        fresh(&mut s, Command::HeadingSetpoint { deg_e5: 0 }, 2 * MS, None);
        s.on_cycle(&LIMITS, stale, 3 * MS);
        assert_eq!(
            (s.mode, s.cause),
            (Failsafe, Some(FailsafeCause::GnssStale))
        );
    }

    #[test]
    fn no_revive_before_the_first_good_packet() {
        let mut s = SafetyState::new();
        let effect = fresh(&mut s, Command::Revive, 0, None);
        assert_eq!(
            (s.mode, effect.refused),
            (Killed, Some(ReviveRefusal::SensorLoss))
        );
        s.on_cycle(&LIMITS, BAD, MS);
        fresh(&mut s, Command::Revive, 2 * MS, None);
        assert_eq!(s.mode, Killed);
        for _ in 0..LIMITS.revive_good_packets {
            s.on_cycle(&LIMITS, OK, 3 * MS);
        }
        fresh(&mut s, Command::Revive, 4 * MS, None);
        assert_eq!(s.mode, Manual);
    }

    #[test]
    fn lone_good_packets_amid_a_loss_do_not_allow_a_revive() {
        // A late answer can, once in a while, land inside the answer window and pass for
        // fresh. Such packets between runs of missing ones must not open the door to a revive.
        let k = LIMITS.sensor_loss_packets;
        let mut s = SafetyState::new();
        let mut t = 0;
        for _ in 0..4 {
            for health in std::iter::repeat_n(BAD, k as usize).chain([OK]) {
                t += 4 * MS;
                s.on_cycle(&LIMITS, health, t);
            }
            let effect = fresh(&mut s, Command::Revive, t + 1, None);
            assert_eq!(
                (s.mode, effect.refused),
                (Killed, Some(ReviveRefusal::SensorLoss))
            );
        }
        for _ in 1..LIMITS.revive_good_packets {
            t += 4 * MS;
            s.on_cycle(&LIMITS, OK, t);
        }
        fresh(&mut s, Command::Revive, t + 1, None);
        assert_eq!(s.mode, Manual);
    }

    #[test]
    fn an_odd_bad_packet_in_a_healthy_link_does_not_block_a_revive() {
        // Shorter runs of bad packets than trip the failsafe do not undo the good ones.
        let mut s = SafetyState::new();
        for (i, health) in [OK, BAD, OK, BAD, BAD, OK].into_iter().enumerate() {
            s.on_cycle(&LIMITS, health, i as Nanos * 4 * MS);
        }
        fresh(&mut s, Command::Revive, 30 * MS, None);
        assert_eq!(s.mode, Manual);
    }

    #[test]
    fn kill_wins_from_every_mode() {
        for start in [Killed, Manual, Auto, Failsafe] {
            let mut s = SafetyState {
                mode: start,
                ..SafetyState::new()
            };
            fresh(&mut s, Command::Kill, 0, Some(ReviveRefusal::ImuStuck));
            assert_eq!(s.mode, Killed);
        }
    }

    #[test]
    fn every_transition_is_counted_even_back_to_the_same_mode() {
        let mut s = run_table(&[
            (0, Cmd(Command::Revive), Manual),
            (4, Cmd(Command::SpeedSetpoint { mm_s: 1_000 }), Auto),
        ]);
        let before = s.mode_transitions;
        fresh(&mut s, Command::Throttle(pct(50)), 8 * MS, None);
        fresh(&mut s, Command::SpeedSetpoint { mm_s: 0 }, 8 * MS, None);
        assert_eq!((s.mode, s.mode_transitions - before), (Auto, 2));
        // Commands that change no mode count nothing.
        fresh(&mut s, Command::SpeedSetpoint { mm_s: 10 }, 9 * MS, None);
        fresh(&mut s, Command::Revive, 9 * MS, None);
        fresh(&mut s, Command::Kill, 9 * MS, None);
        fresh(&mut s, Command::Kill, 9 * MS, None);
        assert_eq!((s.mode, s.mode_transitions - before), (Killed, 3));
    }

    #[test]
    fn the_link_is_seen_when_a_command_arrived_never_later_than_the_cycle_never_back() {
        let heartbeat = |s: &mut SafetyState, arrival_ms: u64, now_ms: u64| {
            let received = ReceivedCommand::new(Command::Heartbeat, arrival_ms * MS);
            s.on_command(&LIMITS, received, now_ms * MS, None)
        };
        let mut s = run_table(&[(0, Cmd(Command::Revive), Manual)]);
        heartbeat(&mut s, 500, 600);
        assert_eq!(s.last_link_ns, Some(500 * MS));
        // An earlier arrival taken later does not move the link time back.
        heartbeat(&mut s, 400, 600);
        assert_eq!(s.last_link_ns, Some(500 * MS));
        // An arrival after the cycle's time counts as the cycle's time.
        heartbeat(&mut s, 900, 700);
        assert_eq!(s.last_link_ns, Some(700 * MS));
    }

    #[test]
    fn a_stale_command_changes_nothing_and_a_stale_kill_still_kills() {
        let mut s = run_table(&[(0, Cmd(Command::Revive), Manual)]);
        let before = s;
        for command in [
            Command::Heartbeat,
            Command::Throttle(pct(90)),
            Command::SpeedSetpoint { mm_s: 1_000 },
            Command::Revive,
        ] {
            let received = ReceivedCommand::new(command, 700 * MS);
            // 1 000 ms old acts; 1 000 ms and 1 ns old does not.
            let mut t = s;
            let effect = t.on_command(&LIMITS, received, 1_700 * MS, None);
            assert!(!effect.stale, "{command:?}");
            assert_eq!(t.last_link_ns, Some(700 * MS), "{command:?}");
            let effect = s.on_command(&LIMITS, received, 1_700 * MS + 1, None);
            assert!(effect.stale, "{command:?}");
            assert_eq!(s, before, "{command:?}");
        }
        let received = ReceivedCommand::new(Command::Kill, 0);
        let effect = s.on_command(&LIMITS, received, 5_000 * MS, None);
        assert_eq!((s.mode, effect.stale), (Killed, false));
    }

    #[test]
    fn killed_does_not_become_failsafe() {
        run_table(&[(0, Cycle(BAD), Killed), (2_000, Cycle(BAD), Killed)]);
    }

    #[test]
    fn mode_names_are_the_log_contract() {
        for (mode, name) in [
            (Killed, "KILLED"),
            (Manual, "MANUAL"),
            (Auto, "AUTO"),
            (Failsafe, "FAILSAFE"),
        ] {
            assert_eq!(mode.name(), name);
            assert_eq!(serde_json::to_string(&mode).unwrap(), format!("\"{name}\""));
        }
        assert_eq!(
            serde_json::to_string(&FailsafeCause::GnssStale).unwrap(),
            "\"GnssStale\""
        );
    }
}
