//! The invariants, checked every cycle against what the harness itself knows: the operator's
//! intent, the commands it delivered, the packets it delivered and when, the periods it made
//! the host miss. None of them reads the robot's internal state to excuse the robot.

use std::collections::VecDeque;

use dima_core::config::{ChannelConfig, Config, FenceConfig};
use dima_core::geo::{distance_m, Circle, LatLon, Polygon};
use dima_core::mission::AutoSource;
use dima_core::step::CycleOutputs;
use dima_core::{Command, Mode, Nanos};
use dima_groundlink::station::ManualChannel;
use dima_groundlink::v2::RobotMode;
use dima_sensorboard::{FixType, SensorPacket};

use super::intent::Intent;
use crate::board::BoardConfig;

/// Time the heading controller may take to let go of the steering once its heading is no
/// longer backed by GNSS, ns.
pub const HEADING_RELEASE_NS: Nanos = 250_000_000;

/// One invariant, by its stable name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Invariant {
    /// `outputs_in_limits`: every channel's pulse width is within the channel's `min_us ..=
    /// max_us`, or is exactly the channel's configured safe output.
    OutputsInLimits,
    /// `no_unasked_motion`: KILLED and FAILSAFE give exactly the safe outputs. In MANUAL each
    /// channel is at neutral or at the manual mapping of a value the operator asked for on
    /// that channel (a one-off request or a held value) after the operator's revive request
    /// that the robot accepted last (T_R). In AUTO the throttle is at neutral unless the
    /// operator asked for a speed setpoint above 0 (within `0..=max_speed_mm_s`) after both
    /// T_R and the request behind the latest manual value the robot applied while driving;
    /// the steering is at neutral unless the operator asked for a heading setpoint after the
    /// same two; the tail is at neutral unless one of those two was asked for. With a mission
    /// loaded, AUTO entered by a setpoint follows the mission: there the steering and the tail
    /// may also leave neutral after any valid setpoint (a speed within `0..=max_speed_mm_s`
    /// or a heading) asked after the same two (entering AUTO is the request); the throttle's
    /// rule stays (the mission's speed is capped by the operator's speed setpoint).
    NoUnaskedMotion,
    /// `kill_is_immediate`: a cycle whose commands include a kill ends KILLED with exactly the
    /// safe outputs.
    KillIsImmediate,
    /// `failsafe_in_time`: the robot is KILLED or in FAILSAFE whenever a failsafe condition,
    /// judged by the harness, has lasted its bound: no command frame that arrived at the
    /// robot's port (and was handed to the core) for more than `comms_timeout_ms` plus one
    /// period; `sensor_loss_packets` consecutive cycles
    /// without a packet completed inside its answer window; `imu_stuck_packets` consecutive
    /// good packets with identical accelerometer words, or with identical gyroscope words
    /// (either die alone); more than `overrun_limit` late wake-ups (each that missed one or
    /// more periods) within the last second, or missed periods adding up to more than
    /// `max_stall_ms` within it;
    /// in AUTO, no fresh GNSS fix (gnssFixOK, a 2D/3D/dead-reckoning fix, sAcc within
    /// `max_speed_accuracy_mm_s`, a ground speed of at least 0 and a time of week beyond
    /// every one delivered before) for more than `gnss_timeout_ms` plus one period; the same
    /// in MANUAL when a geofence is configured.
    FailsafeInTime,
    /// `no_unasked_revive`: the robot leaves KILLED or FAILSAFE only in a cycle that applied a
    /// revive whose operator request was issued after the operator's latest kill the robot
    /// applied, and that no earlier revive of the robot was due to. The revive judged is the
    /// one that revived the robot: of several in one cycle, the first after the robot was
    /// last made safe (before the cycle or by a kill in it) when no revive was refused in the
    /// cycle, else the latest fresh one.
    NoUnaskedRevive,
    /// `auto_forward_only`: in AUTO the throttle pulse is never below neutral.
    AutoForwardOnly,
    /// `station_shows_robot_mode`: whenever the station takes a display frame as current, the
    /// mode it now shows is the mode the robot put into that frame.
    StationShowsRobotMode,
    /// `heading_needs_fresh_gnss`: in AUTO the steering leaves neutral only while the last
    /// fresh GNSS fix with a ground speed of at least `estimator.min_heading_speed_mm_s` (a
    /// heading of motion the robot can correct its heading with) is at most `gnss_timeout_ms`
    /// plus [`HEADING_RELEASE_NS`] old.
    HeadingNeedsFreshGnss,
    /// `fence_failsafe_in_time`: after a fresh GNSS fix (as `failsafe_in_time` judges it) that
    /// the harness finds outside the configured geofence while the robot ends its cycle in
    /// MANUAL or AUTO, the robot is KILLED or in FAILSAFE within one GNSS period plus one
    /// period. Outside: outside every inclusion circle and polygon (when any are given), or
    /// farther than `max_distance_m` from the revive point, which is the position of the
    /// newest fresh fix delivered before the cycle that revived the robot.
    FenceFailsafeInTime,
    /// `no_revive_outside_fence`: with a geofence configured, a cycle that revives the robot
    /// (it ends MANUAL or AUTO after starting KILLED or FAILSAFE, or after applying a kill)
    /// never does so while the newest fresh fix delivered before it, at most `gnss_timeout_ms`
    /// old, is outside the inclusion areas, nor before any fresh fix was delivered at all.
    NoReviveOutsideFence,
    /// `mission_stops_on_kill`: while KILLED or in FAILSAFE the outputs are the safe ones and
    /// no mission status and no AUTO source are reported; after a kill or failsafe, and in
    /// MANUAL, no mission status nor the mission as AUTO's source appears until AUTO is
    /// entered again; and the first mission status after AUTO is entered starts afresh: on
    /// the first waypoint, its leg begins where the car is (along-track 0 m).
    MissionStopsOnKill,
}

impl Invariant {
    /// Every invariant, in a fixed order.
    pub const ALL: [Invariant; 11] = [
        Invariant::OutputsInLimits,
        Invariant::NoUnaskedMotion,
        Invariant::KillIsImmediate,
        Invariant::FailsafeInTime,
        Invariant::NoUnaskedRevive,
        Invariant::AutoForwardOnly,
        Invariant::StationShowsRobotMode,
        Invariant::HeadingNeedsFreshGnss,
        Invariant::FenceFailsafeInTime,
        Invariant::NoReviveOutsideFence,
        Invariant::MissionStopsOnKill,
    ];

    /// The stable name.
    pub fn name(self) -> &'static str {
        match self {
            Invariant::OutputsInLimits => "outputs_in_limits",
            Invariant::NoUnaskedMotion => "no_unasked_motion",
            Invariant::KillIsImmediate => "kill_is_immediate",
            Invariant::FailsafeInTime => "failsafe_in_time",
            Invariant::NoUnaskedRevive => "no_unasked_revive",
            Invariant::AutoForwardOnly => "auto_forward_only",
            Invariant::StationShowsRobotMode => "station_shows_robot_mode",
            Invariant::HeadingNeedsFreshGnss => "heading_needs_fresh_gnss",
            Invariant::FenceFailsafeInTime => "fence_failsafe_in_time",
            Invariant::NoReviveOutsideFence => "no_revive_outside_fence",
            Invariant::MissionStopsOnKill => "mission_stops_on_kill",
        }
    }
}

/// A broken invariant.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Violation {
    /// Which.
    pub invariant: Invariant,
    /// The robot's cycle number (from 0).
    pub cycle: u64,
    /// Virtual time, ns.
    pub t_ns: Nanos,
    /// What was seen.
    pub detail: String,
}

/// A command the core applied, with where it came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Applied {
    /// The command as the gate yielded it.
    pub command: Command,
    /// When the operator asked for what the frame carried (`None`: a heartbeat).
    pub asked_at: Option<Nanos>,
    /// When its frame reached the robot's port, ns.
    pub arrival_ns: Nanos,
}

/// One cycle as the checker sees it.
#[derive(Debug, Clone, Copy)]
pub struct CycleView<'a> {
    /// Cycle number.
    pub cycle: u64,
    /// Wake-up time, ns.
    pub now: Nanos,
    /// Periods the host missed before this wake-up.
    pub missed: u32,
    /// Mode at the end of the previous cycle.
    pub mode_before: Mode,
    /// What the step decided.
    pub out: &'a CycleOutputs,
    /// The commands it was given.
    pub commands: &'a [Applied],
    /// The packet the harness delivered inside its answer window this cycle, if any.
    pub packet: Option<&'a SensorPacket>,
}

/// The thresholds, from the configuration.
#[derive(Debug, Clone)]
struct Limits {
    channels: [ChannelConfig; 3],
    period_ns: Nanos,
    comms_timeout_ns: Nanos,
    sensor_loss_packets: u32,
    imu_stuck_packets: u32,
    overrun_limit: u32,
    max_stall_ns: Nanos,
    gnss_timeout_ns: Nanos,
    max_speed_mm_s: i32,
    max_speed_accuracy_mm_s: u32,
    min_heading_speed_mm_s: i32,
    /// The geofence, when one is configured.
    fence: Option<Fence>,
    /// Time between two epochs of the simulated receiver, ns.
    gnss_period_ns: Nanos,
}

/// The geofence as the harness judges it: the configuration, with the pure geometry of
/// `dima_core::geo` (not the robot's fence monitor).
#[derive(Debug, Clone)]
struct Fence {
    max_distance_m: Option<f64>,
    circles: Vec<Circle>,
    polygons: Vec<Polygon>,
}

impl Fence {
    fn new(config: &FenceConfig) -> Option<Fence> {
        let fence = Fence {
            max_distance_m: config.max_distance_m,
            circles: config
                .circles
                .iter()
                .map(|c| Circle {
                    centre: LatLon::new(c.lat_deg, c.lon_deg),
                    radius_m: c.radius_m,
                })
                .collect(),
            polygons: config
                .polygons
                .iter()
                .map(|p| {
                    let v: Vec<LatLon> = p.iter().map(|&[a, b]| LatLon::new(a, b)).collect();
                    Polygon::new(&v)
                })
                .collect(),
        };
        let any = fence.max_distance_m.is_some()
            || !fence.circles.is_empty()
            || !fence.polygons.is_empty();
        any.then_some(fence)
    }

    /// Within an inclusion area (true when none are given).
    fn in_areas(&self, p: LatLon) -> bool {
        (self.circles.is_empty() && self.polygons.is_empty())
            || self.circles.iter().any(|c| c.contains(p))
            || self.polygons.iter().any(|poly| poly.contains(p))
    }

    /// Why `p` is outside for a robot revived at `revive_point`, if it is.
    fn outside(&self, p: LatLon, revive_point: Option<LatLon>) -> Option<String> {
        if !self.in_areas(p) {
            return Some("outside every inclusion area".to_owned());
        }
        let (max, home) = (self.max_distance_m?, revive_point?);
        let d = distance_m(home, p);
        (d > max).then(|| format!("{d:.1} m from the revive point (max {max} m)"))
    }
}

/// A fresh fix as the harness saw it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Fix {
    at_ns: Nanos,
    position: LatLon,
}

/// Identical words packet after packet.
#[derive(Debug, Clone, Copy, Default)]
struct Run {
    last: Option<[i16; 3]>,
    length: u32,
}

impl Run {
    fn update(&mut self, words: [i16; 3]) -> u32 {
        if self.last == Some(words) {
            self.length += 1;
        } else {
            self.last = Some(words);
            self.length = 1;
        }
        self.length
    }
}

/// The harness's trackers and the violations found so far.
#[derive(Debug, Clone)]
pub struct Checker {
    limits: Limits,
    /// Operator time of the revive request the robot accepted last (T_R).
    revived_by: Option<Nanos>,
    /// Operator times of the revive requests that revived the robot.
    used_revives: Vec<Nanos>,
    /// Operator time of the latest kill the robot applied.
    killed_by: Option<Nanos>,
    /// Operator time behind the latest manual value applied while driving.
    manual_by: Option<Nanos>,
    last_command_ns: Option<Nanos>,
    bad_run: u32,
    accel: Run,
    gyro: Run,
    /// The late wake-ups within the last second: when, and how many periods each missed.
    late_wakes: VecDeque<(Nanos, u32)>,
    max_itow: Option<u32>,
    last_fix_ns: Option<Nanos>,
    last_heading_fix_ns: Option<Nanos>,
    /// The newest fresh fix.
    fix: Option<Fix>,
    /// The fresh fix this cycle brought.
    new_fix: Option<LatLon>,
    /// Where the robot was last revived (the newest fresh fix before that cycle).
    revive_point: Option<LatLon>,
    /// A fix outside the fence: by when the robot must be KILLED or in FAILSAFE, and what.
    fence_due: Option<(Nanos, String)>,
    /// Fresh fixes outside the fence in cycles that began in MANUAL or AUTO.
    fence_exits: u64,
    /// A mission is loaded.
    mission: bool,
    /// AUTO was entered since the robot was last safe or in MANUAL.
    auto_entered: bool,
    /// The first mission status after AUTO was entered is still to come.
    first_status_due: bool,
    checks: u64,
    violations: Vec<Violation>,
}

const SECOND_NS: Nanos = 1_000_000_000;

impl Checker {
    /// A checker for `config`.
    pub fn new(config: &Config) -> Checker {
        let ms = |v: u32| u64::from(v) * 1_000_000;
        let c = &config.channels;
        Checker {
            limits: Limits {
                channels: [c.throttle.clone(), c.steering.clone(), c.tail.clone()],
                period_ns: config.period_ns(),
                comms_timeout_ns: ms(config.safety.comms_timeout_ms),
                sensor_loss_packets: config.safety.sensor_loss_packets,
                imu_stuck_packets: config.safety.imu_stuck_packets,
                overrun_limit: config.safety.overrun_limit,
                max_stall_ns: ms(config.safety.max_stall_ms),
                gnss_timeout_ns: ms(config.safety.gnss_timeout_ms),
                max_speed_mm_s: config.control.max_speed_mm_s,
                max_speed_accuracy_mm_s: config.control.max_speed_accuracy_mm_s,
                min_heading_speed_mm_s: config.estimator.min_heading_speed_mm_s,
                fence: Fence::new(&config.navigation.fence),
                gnss_period_ns: (1e9 / BoardConfig::default().gnss_rate_hz) as Nanos,
            },
            revived_by: None,
            used_revives: Vec::new(),
            killed_by: None,
            manual_by: None,
            last_command_ns: None,
            bad_run: 0,
            accel: Run::default(),
            gyro: Run::default(),
            late_wakes: VecDeque::new(),
            max_itow: None,
            last_fix_ns: None,
            last_heading_fix_ns: None,
            fix: None,
            new_fix: None,
            revive_point: None,
            fence_due: None,
            fence_exits: 0,
            mission: false,
            auto_entered: false,
            first_status_due: false,
            checks: 0,
            violations: Vec::new(),
        }
    }

    /// The checker for a robot with a mission loaded (`mission`), or without.
    pub fn with_mission(mut self, mission: bool) -> Checker {
        self.mission = mission;
        self
    }

    /// Fresh fixes the harness found outside the geofence in cycles that began in MANUAL or
    /// AUTO (each must end in a failsafe in time).
    pub fn fence_exits(&self) -> u64 {
        self.fence_exits
    }

    /// Invariant checks made so far.
    pub fn checks(&self) -> u64 {
        self.checks
    }

    /// Violations found so far, in the order found.
    pub fn violations(&self) -> &[Violation] {
        &self.violations
    }

    fn judge(
        &mut self,
        ok: bool,
        invariant: Invariant,
        cycle: u64,
        now: Nanos,
        detail: impl FnOnce() -> String,
    ) {
        self.checks += 1;
        if !ok {
            self.violations.push(Violation {
                invariant,
                cycle,
                t_ns: now,
                detail: detail(),
            });
        }
    }

    /// A display frame the station took as current: it shows `shown`; the robot sent `sent`.
    pub fn check_display(&mut self, cycle: u64, now: Nanos, shown: RobotMode, sent: RobotMode) {
        self.judge(
            shown == sent,
            Invariant::StationShowsRobotMode,
            cycle,
            now,
            || format!("the station shows {shown:?}, the robot sent {sent:?}"),
        );
    }

    /// Updates the trackers with one cycle, then checks every per-cycle invariant.
    pub fn check_cycle(&mut self, v: &CycleView, intent: &Intent) {
        let fix_before = self.fix;
        self.track(v);
        let pulses = v.out.targets.pulse_us;
        let safe: [u16; 3] = self.limits.channels.each_ref().map(|c| c.safe.pulse_us());
        let neutral: [u16; 3] = self.limits.channels.each_ref().map(|c| c.neutral_us);
        self.check_outputs_in_limits(v, safe);
        self.check_kill_is_immediate(v, safe);
        self.check_no_unasked_revive(v);
        let unasked = self.unasked_motion(v.out.mode, pulses, safe, neutral, intent);
        self.judge(
            unasked.is_none(),
            Invariant::NoUnaskedMotion,
            v.cycle,
            v.now,
            || unasked.unwrap_or_default(),
        );
        self.check_auto_forward_only(v, neutral);
        self.check_failsafe_in_time(v);
        self.check_heading_needs_fresh_gnss(v, neutral);
        self.check_no_revive_outside_fence(v, fix_before);
        self.check_fence_failsafe_in_time(v);
        self.check_mission_stops_on_kill(v, safe);
    }

    /// Whether this cycle revived the robot: it ends driving after starting safe, or after a
    /// kill it applied (a kill and a revive in one cycle).
    fn revived(v: &CycleView) -> bool {
        !v.out.mode.is_safe()
            && (v.mode_before.is_safe() || v.commands.iter().any(|c| c.command == Command::Kill))
    }

    /// `no_revive_outside_fence`; notes the revive point.
    fn check_no_revive_outside_fence(&mut self, v: &CycleView, fix_before: Option<Fix>) {
        if !Self::revived(v) {
            return;
        }
        self.revive_point = fix_before.map(|f| f.position);
        let Some(fence) = &self.limits.fence else {
            return;
        };
        let refused = match fix_before {
            None => Some("before any fresh fix".to_owned()),
            Some(f) if v.now.saturating_sub(f.at_ns) <= self.limits.gnss_timeout_ns => {
                (!fence.in_areas(f.position)).then(|| {
                    format!(
                        "with the newest fresh fix ({:.7}, {:.7}) outside every inclusion area",
                        f.position.lat_deg, f.position.lon_deg
                    )
                })
            }
            Some(_) => None,
        };
        self.judge(
            refused.is_none(),
            Invariant::NoReviveOutsideFence,
            v.cycle,
            v.now,
            || {
                format!(
                    "{} -> {} {}",
                    v.mode_before,
                    v.out.mode,
                    refused.unwrap_or_default()
                )
            },
        );
    }

    /// `fence_failsafe_in_time`.
    fn check_fence_failsafe_in_time(&mut self, v: &CycleView) {
        let Some(fence) = &self.limits.fence else {
            return;
        };
        let outside = self
            .new_fix
            .and_then(|p| Some((p, fence.outside(p, self.revive_point)?)));
        if outside.is_some() && !v.mode_before.is_safe() {
            self.fence_exits += 1;
        }
        if v.out.mode.is_safe() {
            self.fence_due = None;
            return;
        }
        if let Some((p, why)) = outside.filter(|_| self.fence_due.is_none()) {
            let by = v.now + self.limits.gnss_period_ns + self.limits.period_ns;
            let what = format!(
                "a fix at {} ms ({:.7}, {:.7}) {why}",
                ms_since_start(v.now),
                p.lat_deg,
                p.lon_deg
            );
            self.fence_due = Some((by, what));
        }
        let Some((by, what)) = self.fence_due.clone() else {
            return;
        };
        let ok = v.now <= by;
        self.judge(ok, Invariant::FenceFailsafeInTime, v.cycle, v.now, || {
            format!("still {} after {what}", v.out.mode)
        });
    }

    /// `mission_stops_on_kill`.
    fn check_mission_stops_on_kill(&mut self, v: &CycleView, safe: [u16; 3]) {
        let out = v.out;
        if out.mode.is_safe() {
            self.auto_entered = false;
            self.first_status_due = false;
            let ok =
                out.targets.pulse_us == safe && out.auto_source.is_none() && out.mission.is_none();
            self.judge(ok, Invariant::MissionStopsOnKill, v.cycle, v.now, || {
                format!(
                    "{} with pulses {:?}, AUTO source {:?}, mission {:?}",
                    out.mode, out.targets.pulse_us, out.auto_source, out.mission
                )
            });
            return;
        }
        let transition = v.commands.iter().any(|c| {
            matches!(
                c.command,
                Command::Kill | Command::Throttle(_) | Command::Steering(_) | Command::Tail(_)
            )
        });
        if out.mode == Mode::Auto && (v.mode_before != Mode::Auto || transition) {
            self.auto_entered = true;
            self.first_status_due = true;
        } else if out.mode != Mode::Auto {
            self.auto_entered = false;
            self.first_status_due = false;
        }
        let following = out.mission.is_some() || out.auto_source == Some(AutoSource::Mission);
        if following && !self.auto_entered {
            self.judge(false, Invariant::MissionStopsOnKill, v.cycle, v.now, || {
                format!(
                    "{} follows the mission (status {:?}) without AUTO entered since the last \
                     kill, failsafe or MANUAL",
                    out.mode, out.mission
                )
            });
            return;
        }
        let Some(status) = out.mission.filter(|_| self.first_status_due) else {
            return;
        };
        self.first_status_due = false;
        let afresh = status.waypoint > 0 || status.along_track_m.abs() < 1e-3;
        self.judge(
            afresh,
            Invariant::MissionStopsOnKill,
            v.cycle,
            v.now,
            || {
                format!(
                    "the first mission status after AUTO was entered carries progress over: \
                 waypoint {} at {:.2} m along its leg",
                    status.waypoint, status.along_track_m
                )
            },
        );
    }

    /// `outputs_in_limits`.
    fn check_outputs_in_limits(&mut self, v: &CycleView, safe: [u16; 3]) {
        let pulses = v.out.targets.pulse_us;
        let in_limits = (0..3).all(|i| {
            let c = &self.limits.channels[i];
            (c.min_us..=c.max_us).contains(&pulses[i]) || pulses[i] == safe[i]
        });
        self.judge(
            in_limits,
            Invariant::OutputsInLimits,
            v.cycle,
            v.now,
            || format!("pulses {pulses:?} outside the channels' limits"),
        );
    }

    /// `kill_is_immediate`.
    fn check_kill_is_immediate(&mut self, v: &CycleView, safe: [u16; 3]) {
        if !v.commands.iter().any(|c| c.command == Command::Kill) {
            return;
        }
        let (mode, pulses) = (v.out.mode, v.out.targets.pulse_us);
        let ok = mode == Mode::Killed && pulses == safe;
        self.judge(ok, Invariant::KillIsImmediate, v.cycle, v.now, || {
            format!("a kill reached the core; mode {mode} pulses {pulses:?}")
        });
    }

    /// `no_unasked_revive`: a way out of KILLED or FAILSAFE needs a revive the operator asked
    /// for after the last kill, not used by an earlier revive.
    fn check_no_unasked_revive(&mut self, v: &CycleView) {
        let revived = v.mode_before.is_safe() && !v.out.mode.is_safe();
        if !revived {
            return;
        }
        let is_fresh = |c: &Applied| {
            let t = c.asked_at?;
            let fresh = c.command == Command::Revive
                && self.killed_by.is_none_or(|k| t > k)
                && !self.used_revives.contains(&t);
            fresh.then_some(t)
        };
        let fresh = if v.out.refused.is_none() {
            // No revive was refused this cycle: the first revive after the robot was last
            // made safe within it (by a kill, or before the cycle) is the one that revived it;
            // later ones found it driving and did nothing.
            let after_kill = v
                .commands
                .iter()
                .rposition(|c| c.command == Command::Kill)
                .map_or(0, |i| i + 1);
            v.commands[after_kill..]
                .iter()
                .find(|c| c.command == Command::Revive)
                .and_then(is_fresh)
        } else {
            // Which revive was refused is not known: the latest fresh one (the strictest).
            v.commands.iter().rev().find_map(is_fresh)
        };
        self.judge(
            fresh.is_some(),
            Invariant::NoUnaskedRevive,
            v.cycle,
            v.now,
            || {
                format!(
                    "{} -> {} without a fresh operator revive (commands {:?})",
                    v.mode_before, v.out.mode, v.commands
                )
            },
        );
        if let Some(t) = fresh {
            self.used_revives.push(t);
        }
        self.revived_by = fresh.or(self.revived_by);
    }

    /// `auto_forward_only`.
    fn check_auto_forward_only(&mut self, v: &CycleView, neutral: [u16; 3]) {
        if v.out.mode != Mode::Auto {
            return;
        }
        let throttle = v.out.targets.pulse_us[0];
        self.judge(
            throttle >= neutral[0],
            Invariant::AutoForwardOnly,
            v.cycle,
            v.now,
            || format!("AUTO throttle {throttle} µs below neutral {}", neutral[0]),
        );
    }

    /// `failsafe_in_time`.
    fn check_failsafe_in_time(&mut self, v: &CycleView) {
        let condition = self.failsafe_condition(v);
        if v.out.mode.is_safe() {
            return;
        }
        self.judge(
            condition.is_none(),
            Invariant::FailsafeInTime,
            v.cycle,
            v.now,
            || {
                format!(
                    "still {} with {}",
                    v.out.mode,
                    condition.unwrap_or_default()
                )
            },
        );
    }

    /// `heading_needs_fresh_gnss`.
    fn check_heading_needs_fresh_gnss(&mut self, v: &CycleView, neutral: [u16; 3]) {
        let steering = v.out.targets.pulse_us[1];
        if v.out.mode != Mode::Auto || steering == neutral[1] {
            return;
        }
        let now = v.now;
        let bound = self.limits.gnss_timeout_ns + HEADING_RELEASE_NS;
        let ok = self
            .last_heading_fix_ns
            .is_some_and(|t| now.saturating_sub(t) <= bound);
        let age = self.last_heading_fix_ns.map(|t| (now - t) / 1_000_000);
        self.judge(ok, Invariant::HeadingNeedsFreshGnss, v.cycle, now, || {
            format!("AUTO steering {steering} µs with the last GNSS heading fix {age:?} ms old")
        });
    }

    /// Why the outputs move without the operator having asked, if they do.
    fn unasked_motion(
        &self,
        mode: Mode,
        pulses: [u16; 3],
        safe: [u16; 3],
        neutral: [u16; 3],
        intent: &Intent,
    ) -> Option<String> {
        match mode {
            Mode::Killed | Mode::Failsafe => {
                (pulses != safe).then(|| format!("{mode} with pulses {pulses:?}, safe {safe:?}"))
            }
            Mode::Manual => {
                let after = self.revived_by.unwrap_or(0);
                ManualChannel::ALL.iter().enumerate().find_map(|(i, &ch)| {
                    let c = &self.limits.channels[i];
                    let asked = pulses[i] == neutral[i]
                        || intent
                            .manual_after(ch, after)
                            .any(|p| manual_pulse(c, p.get()) == pulses[i]);
                    (!asked).then(|| {
                        format!(
                            "MANUAL {} at {} µs: not asked after the revive request at {} ms",
                            ch.name(),
                            pulses[i],
                            ms_since_start(after)
                        )
                    })
                })
            }
            Mode::Auto => {
                let revived = self.revived_by.unwrap_or(0);
                let after = revived.max(self.manual_by.unwrap_or(0));
                let since = if after == revived {
                    "the revive request"
                } else {
                    "the last manual value, asked"
                };
                let speed = intent.positive_speed_after(after, self.limits.max_speed_mm_s);
                let heading = intent.heading_after(after);
                // With a mission, entering AUTO (any valid setpoint) asks for its heading.
                let mission =
                    self.mission && intent.setpoint_after(after, self.limits.max_speed_mm_s);
                let asked = [speed, heading || mission, speed || heading || mission];
                (0..3).find_map(|i| {
                    (pulses[i] != neutral[i] && !asked[i]).then(|| {
                        format!(
                            "AUTO {} at {} µs: no {} asked after {since} at {} ms",
                            ManualChannel::ALL[i].name(),
                            pulses[i],
                            [
                                "speed setpoint above 0",
                                if self.mission {
                                    "setpoint entering the mission"
                                } else {
                                    "heading setpoint"
                                },
                                "setpoint",
                            ][i],
                            ms_since_start(after)
                        )
                    })
                })
            }
        }
    }

    /// Updates the trackers with what this cycle brought.
    fn track(&mut self, v: &CycleView) {
        let driving = !v.mode_before.is_safe() || !v.out.mode.is_safe();
        for c in v.commands {
            match c.command {
                Command::Kill => self.killed_by = c.asked_at.or(self.killed_by),
                Command::Throttle(_) | Command::Steering(_) | Command::Tail(_) if driving => {
                    self.manual_by = self.manual_by.max(c.asked_at);
                }
                _ => {}
            }
        }
        if let Some(arrival) = v.commands.iter().map(|c| c.arrival_ns).max() {
            self.last_command_ns = self.last_command_ns.max(Some(arrival));
        }
        if v.missed > 0 {
            self.late_wakes.push_back((v.now, v.missed));
        }
        while self
            .late_wakes
            .front()
            .is_some_and(|&(t, _)| v.now.saturating_sub(t) >= SECOND_NS)
        {
            self.late_wakes.pop_front();
        }
        self.new_fix = None;
        let Some(p) = v.packet else {
            self.bad_run = self.bad_run.saturating_add(1);
            return;
        };
        self.bad_run = 0;
        self.accel.update(p.accel);
        self.gyro.update(p.gyro);
        let Some(pvt) = p.nav_pvt() else {
            return;
        };
        let l = &self.limits;
        let valid = pvt.gnss_fix_ok()
            && matches!(
                pvt.fix(),
                FixType::Fix2D | FixType::Fix3D | FixType::GnssDeadReckoning
            )
            && pvt.s_acc_mm_s <= l.max_speed_accuracy_mm_s
            && pvt.g_speed_mm_s >= 0;
        let advanced = self.max_itow.is_none_or(|m| pvt.itow_ms > m);
        self.max_itow = self.max_itow.max(Some(pvt.itow_ms));
        if valid && advanced {
            self.last_fix_ns = Some(v.now);
            let position = LatLon::from_deg_e7(pvt.lat_deg_e7, pvt.lon_deg_e7);
            self.new_fix = Some(position);
            self.fix = Some(Fix {
                at_ns: v.now,
                position,
            });
            if pvt.g_speed_mm_s >= l.min_heading_speed_mm_s {
                self.last_heading_fix_ns = Some(v.now);
            }
        }
    }

    /// The failsafe condition that has lasted its bound, if one has.
    fn failsafe_condition(&self, v: &CycleView) -> Option<String> {
        let l = &self.limits;
        let now = v.now;
        let silent = self
            .last_command_ns
            .map_or(u64::MAX, |t| now.saturating_sub(t));
        if silent > l.comms_timeout_ns + l.period_ns {
            return Some(format!("no command for {} ms", silent / 1_000_000));
        }
        if self.bad_run >= l.sensor_loss_packets {
            return Some(format!("{} cycles without a good packet", self.bad_run));
        }
        if self.accel.length >= l.imu_stuck_packets {
            return Some(format!(
                "accelerometer words frozen for {} packets",
                self.accel.length
            ));
        }
        if self.gyro.length >= l.imu_stuck_packets {
            return Some(format!(
                "gyroscope words frozen for {} packets",
                self.gyro.length
            ));
        }
        if self.late_wakes.len() > l.overrun_limit as usize {
            return Some(format!(
                "{} late wake-ups within a second",
                self.late_wakes.len()
            ));
        }
        let missed: u64 = self.late_wakes.iter().map(|&(_, m)| u64::from(m)).sum();
        if missed * l.period_ns > l.max_stall_ns {
            return Some(format!("{missed} periods missed within a second"));
        }
        if v.out.mode == Mode::Auto || l.fence.is_some() {
            let age = self.last_fix_ns.map_or(u64::MAX, |t| now.saturating_sub(t));
            if age > l.gnss_timeout_ns + l.period_ns {
                return Some(format!(
                    "no fresh GNSS fix for {} ms in {}{}",
                    age.min(u64::MAX / 2) / 1_000_000,
                    v.out.mode,
                    if l.fence.is_some() {
                        " with a fence"
                    } else {
                        ""
                    }
                ));
            }
        }
        None
    }
}

/// Milliseconds of virtual time since the run's first deadline.
fn ms_since_start(t: Nanos) -> u64 {
    t.saturating_sub(super::runner::START_NS) / 1_000_000
}

/// The manual mapping as docs/wire-formats.md ("Servo controller: Pololu Maestro") gives it:
/// `min + (max - min) * percent / 100`, to the nearest µs.
fn manual_pulse(c: &ChannelConfig, percent: u8) -> u16 {
    let span = u32::from(c.max_us - c.min_us);
    c.min_us + ((span * u32::from(percent) + 50) / 100) as u16
}
