//! The deterministic control step: everything the robot decides in one cycle, as a pure
//! function of the previous [`CoreState`], the cycle's [`CycleInputs`], the time and the
//! configuration ([`Core`]).
//!
//! The realtime loop is acquire (I/O: commands from the ground link, the sensor packet and its
//! timestamps) -> [`Core::step`] -> actuate (write the targets) -> publish (log, telemetry).
//! Tests and replays call the step directly, thousands of cycles per second, with no devices,
//! threads or clocks.

use dima_sensorboard::{units, RawPacket, SensorPacket};

use crate::config::{Config, ConfigError};
use crate::control::{
    Actuation, ControlInput, ControllerSet, OutputMap, SensorValues, ServoTargets,
};
use crate::counters::Counters;
use crate::estimate::{Estimator, EstimatorState, ImuSample, StateEstimate};
use crate::geo::LatLon;
use crate::mission::{
    AutoSource, Follower, FollowerParams, LocalPoint, Mission, MissionProgress, MissionStatus,
    Navigation,
};
use crate::monitor::{
    AnswerWindow, FenceMonitor, Geofence, GnssEpoch, GnssFreshness, ImuStuckDetector, OverrunRule,
    OverrunWindow, PacketVerdict, RolloverMonitor, RolloverRule,
};
use crate::safety::{
    CycleHealth, FailsafeCause, Mode, ReceivedCommand, ReviveRefusal, SafetyLimits, SafetyState,
    Setpoints,
};
use crate::Nanos;

/// What the acquire phase got from the sensor board this cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorInput {
    /// No request was made: the board is not connected (or, in request-ahead mode, nothing
    /// was pending).
    NotRequested,
    /// The port or the request line failed.
    DeviceError,
    /// Requested at `t_request_ns`; no valid packet by the deadline.
    NoAnswer {
        /// When the request line was raised, ns.
        t_request_ns: Nanos,
    },
    /// A CRC-valid packet, completed at `t_complete_ns`, after a request at `t_request_ns`.
    Packet {
        /// The packet as received.
        raw: RawPacket,
        /// When the request line was raised, ns.
        t_request_ns: Nanos,
        /// When its last byte was read, ns.
        t_complete_ns: Nanos,
    },
}

/// Everything one cycle brings in.
#[derive(Debug, Clone, Copy)]
pub struct CycleInputs<'a> {
    /// Whole periods the clock skipped before this cycle's wake-up.
    pub missed_periods: u32,
    /// Valid command frames from the ground link, in arrival order, each with its arrival
    /// time.
    pub commands: &'a [ReceivedCommand],
    /// The sensor packet, or why there is none.
    pub sensor: SensorInput,
    /// Valid packets that completed too soon after this cycle's request to answer it (an
    /// earlier request's answer), passed over while waiting for the real one.
    pub stale_packets: u32,
}

/// What one cycle decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleOutputs {
    /// Servo targets for this cycle.
    pub targets: ServoTargets,
    /// Mode after the cycle.
    pub mode: Mode,
    /// Why FAILSAFE was entered (while in FAILSAFE).
    pub cause: Option<FailsafeCause>,
    /// The mode after the cycle differs from the mode before it (what the log reports as a
    /// mode change). A round trip within the cycle (AUTO -> MANUAL -> AUTO) is not one here,
    /// though it resets the controllers like any transition.
    pub mode_changed: bool,
    /// What became of the sensor packet.
    pub verdict: PacketVerdict,
    /// Request to packet complete, ns, when a packet arrived (whatever its verdict).
    pub request_to_packet_ns: Option<Nanos>,
    /// The packet used this cycle, decoded.
    pub packet: Option<SensorPacket>,
    /// A revive was refused this cycle, and why.
    pub refused: Option<ReviveRefusal>,
    /// Speed setpoints rejected this cycle.
    pub setpoints_rejected: u32,
    /// A new fresh GNSS fix was used this cycle.
    pub gnss_new: bool,
    /// Age of the newest fresh GNSS fix, ns.
    pub gnss_age_ns: Option<Nanos>,
    /// Controller output (held from the last good packet in AUTO; zero otherwise).
    pub action: Actuation,
    /// Controller inputs.
    pub values: SensorValues,
    /// The state estimate after this cycle.
    pub estimate: StateEstimate,
    /// Where AUTO's setpoints came from (`None` outside AUTO).
    pub auto_source: Option<AutoSource>,
    /// The mission's status, while AUTO follows one.
    pub mission: Option<MissionStatus>,
}

/// Everything the step remembers between cycles.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CoreState {
    /// Mode, setpoints, link time, bad-packet run.
    pub safety: SafetyState,
    /// Estimator state.
    pub estimator: EstimatorState,
    /// The state estimate of the last cycle.
    pub estimate: StateEstimate,
    /// The last controller output, held while packets are missing.
    pub action: Actuation,
    /// Controller inputs from the last good packet.
    pub values: SensorValues,
    /// GNSS freshness.
    pub gnss: GnssFreshness,
    /// Stuck-IMU runs, one per die.
    pub imu: ImuStuckDetector,
    /// Late wake-ups within the last second.
    pub overruns: OverrunWindow,
    /// How long the car has been tilted.
    pub rollover: RolloverMonitor,
    /// The newest fix and the revive point, judged against the geofence.
    pub fence: FenceMonitor,
    /// Time of the last controller step.
    pub last_step_ns: Option<Nanos>,
    /// The required realtime setup failed: revives are refused for the whole run.
    pub realtime_fault: bool,
    /// Decision counters (the application adds its I/O counters to the same struct).
    pub counters: Counters,
    /// The waypoint mission's progress.
    pub mission: MissionProgress,
}

impl CoreState {
    /// Start-up: KILLED.
    pub fn new() -> CoreState {
        CoreState::default()
    }
}

/// The configuration in the form the step uses, and the channels' controllers (which keep
/// their own state: one `Core` runs one [`CoreState`]).
#[derive(Debug)]
pub struct Core {
    limits: SafetyLimits,
    outputs: OutputMap,
    controllers: ControllerSet,
    estimator: Estimator,
    answer: AnswerWindow,
    period_ns: Nanos,
    gnss_timeout_ns: Nanos,
    max_speed_accuracy_mm_s: u32,
    imu_stuck_packets: u32,
    overrun: OverrunRule,
    rollover: RolloverRule,
    fence: Geofence,
    follower_params: FollowerParams,
    follower: Option<Follower>,
}

impl Core {
    /// From a configuration; fails only as [`Config::validate`] would.
    pub fn new(config: &Config) -> Result<Core, ConfigError> {
        config.validate()?;
        let controllers = config.controllers()?;
        let us = |v: u32| u64::from(v) * 1_000;
        Ok(Core {
            limits: SafetyLimits::new(&config.safety, &config.control),
            outputs: OutputMap::new(&config.channels),
            controllers,
            estimator: Estimator::new(
                &config.estimator,
                u64::from(config.safety.gnss_timeout_ms) * 1_000_000,
            ),
            answer: AnswerWindow::new(
                config.packet_wire_ns(),
                us(config.sensor.wire_tolerance_us),
                config.packet_deadline_after_request_ns(),
            ),
            period_ns: config.period_ns(),
            gnss_timeout_ns: u64::from(config.safety.gnss_timeout_ms) * 1_000_000,
            max_speed_accuracy_mm_s: config.control.max_speed_accuracy_mm_s,
            imu_stuck_packets: config.safety.imu_stuck_packets,
            overrun: OverrunRule {
                limit: config.safety.overrun_limit,
                max_stall_ns: u64::from(config.safety.max_stall_ms) * 1_000_000,
                period_ns: config.period_ns(),
            },
            rollover: RolloverRule::new(
                config.navigation.rollover_tilt_deg,
                config.navigation.rollover_ms,
                -config.estimator.gyro_yaw_sign,
            ),
            fence: Geofence::new(&config.navigation.fence),
            follower_params: config.navigation.follower_params(),
            follower: None,
        })
    }

    /// Loads the waypoint mission (`[navigation]`'s settings): from the next time AUTO is
    /// entered, AUTO follows it (see [`MissionProgress`]). Allocates: call it before the loop.
    pub fn set_mission(&mut self, mission: &Mission) {
        self.follower = Some(Follower::new(mission, self.follower_params));
    }

    /// Loads the mission and the fence in force (see [`Navigation`]): the fence from the next
    /// fix, the mission from the next time AUTO is entered. Allocates: call it before the loop.
    pub fn set_navigation(&mut self, navigation: &Navigation) {
        self.fence = Geofence::new(&navigation.fence);
        self.follower = navigation
            .mission
            .as_ref()
            .map(|m| Follower::new(m, self.follower_params));
    }

    /// The loaded mission's follower.
    pub fn follower(&self) -> Option<&Follower> {
        self.follower.as_ref()
    }

    /// The mission's setpoints for this cycle: the follower's heading, and its speed capped by
    /// the operator's speed setpoint (without one the speed controller holds neutral, as in
    /// AUTO on setpoints). Neither without a fresh GNSS position.
    fn mission_setpoints(&self, state: &mut CoreState, now: Nanos) -> Setpoints {
        let operator = state.safety.setpoints;
        let steer_nowhere = Setpoints {
            speed_mm_s: None,
            heading_deg_e5: None,
            ..operator
        };
        let (Some(follower), Some(fix)) = (&self.follower, state.values.gnss) else {
            state.mission.guidance = None;
            return steer_nowhere;
        };
        let mut car = follower.frame().to_local(
            f64::from(fix.lat_deg_e7) * 1e-7,
            f64::from(fix.lon_deg_e7) * 1e-7,
        );
        let speed_m_s = state
            .estimate
            .speed_mm_s
            .map_or(f64::from(fix.g_speed_mm_s.max(0)) * 1e-3, |s| {
                f64::from(s.value) * 1e-3
            });
        // Carried forward from the fix (10 Hz) to now along the estimated heading.
        if let Some(heading) = state.estimate.heading_deg {
            let travelled_m = speed_m_s * now.saturating_sub(fix.at_ns) as f64 * 1e-9;
            let h = f64::from(heading.value).to_radians();
            car = LocalPoint {
                north_m: car.north_m + travelled_m * h.cos(),
                east_m: car.east_m + travelled_m * h.sin(),
            };
        }
        let g = follower.update(&mut state.mission.follower, car, speed_m_s);
        state.mission.guidance = Some(g);
        let mission_mm_s = (g.speed_m_s * 1e3).round() as i32;
        Setpoints {
            speed_mm_s: operator.speed_mm_s.map(|cap| cap.min(mission_mm_s)),
            heading_deg_e5: Some(((g.heading_deg * 1e5).round() as i32).rem_euclid(36_000_000)),
            ..operator
        }
    }

    /// The channel table.
    pub fn outputs(&self) -> &OutputMap {
        &self.outputs
    }

    /// When, after its request, a packet counts as the answer.
    pub fn answer_window(&self) -> AnswerWindow {
        self.answer
    }

    /// What blocks a revive besides the sensor link.
    fn revive_blocker(&self, state: &CoreState, now: Nanos) -> Option<ReviveRefusal> {
        if state.realtime_fault {
            Some(ReviveRefusal::RealtimeSetup)
        } else if state.imu.is_stuck(self.imu_stuck_packets) {
            Some(ReviveRefusal::ImuStuck)
        } else if state.overruns.exceeded(now, &self.overrun) {
            Some(ReviveRefusal::Overrun)
        } else if state.rollover.is_tilted() {
            Some(ReviveRefusal::RolledOver)
        } else if state.fence.refuses_revive(
            &self.fence,
            state.gnss.current(now, self.gnss_timeout_ns).is_some(),
        ) {
            Some(ReviveRefusal::OutsideFence)
        } else {
            None
        }
    }

    /// Judges the sensor input; on a good packet updates the sensor monitors.
    fn acquire(
        &self,
        state: &mut CoreState,
        sensor: &SensorInput,
        now: Nanos,
    ) -> (PacketVerdict, Option<Nanos>, Option<SensorPacket>) {
        let (verdict, latency, raw) = match *sensor {
            SensorInput::NotRequested => (PacketVerdict::NotRequested, None, None),
            SensorInput::DeviceError => (PacketVerdict::DeviceError, None, None),
            SensorInput::NoAnswer { .. } => (PacketVerdict::Missing, None, None),
            SensorInput::Packet {
                raw,
                t_request_ns,
                t_complete_ns,
            } => (
                self.answer.judge(t_request_ns, t_complete_ns),
                Some(t_complete_ns.saturating_sub(t_request_ns)),
                Some(raw),
            ),
        };
        let c = &mut state.counters;
        match verdict {
            PacketVerdict::Ok => c.packets_ok += 1,
            PacketVerdict::Stale => c.packets_stale += 1,
            PacketVerdict::Late => c.packets_late += 1,
            _ => c.packets_missing += 1,
        }
        let packet = raw.filter(|_| verdict.is_ok()).map(|raw| raw.decode());
        if let Some(p) = &packet {
            state.imu.update(p.accel, p.gyro, self.imu_stuck_packets);
            state
                .rollover
                .update(p.accel.map(units::accel_mg_2g), now, &self.rollover);
            state.values.gyro_z_dps = units::gyro_dps_2000(p.gyro[2]);
        }
        let epoch = state.gnss.update(
            packet.as_ref().and_then(SensorPacket::nav_pvt).as_ref(),
            self.max_speed_accuracy_mm_s,
            now,
        );
        match epoch {
            GnssEpoch::New(_) => state.counters.gnss_fixes += 1,
            GnssEpoch::NotAdvancing => state.counters.gnss_backwards += 1,
            _ => {}
        }
        let new_fix = epoch.fix();
        if new_fix.is_some() {
            if let Some(pvt) = packet.as_ref().and_then(SensorPacket::nav_pvt) {
                let position = LatLon::from_deg_e7(pvt.lat_deg_e7, pvt.lon_deg_e7);
                state.fence.on_fix(position, &self.fence);
            }
        }
        state.values.gnss = state.gnss.current(now, self.gnss_timeout_ns);
        state.values.gnss_new = new_fix.is_some();
        let imu = packet.as_ref().map(|p| ImuSample {
            gyro_z_dps: state.values.gyro_z_dps,
            accel_x_m_s2: units::accel_m_s2_2g(p.accel[0]),
            accel_y_m_s2: units::accel_m_s2_2g(p.accel[1]),
        });
        state.estimate = self.estimator.update(
            &mut state.estimator,
            imu,
            state.values.gnss,
            state.values.gnss_new,
            now,
        );
        (verdict, latency, packet)
    }

    /// The controllers, in AUTO on a good packet; the last action is held on a missing one.
    /// Every mode transition this cycle (`transitioned`, also one that came back to the mode the
    /// cycle started in) resets them and drops the held action.
    fn control(&mut self, state: &mut CoreState, packet_ok: bool, transitioned: bool, now: Nanos) {
        if transitioned {
            self.controllers.reset();
            state.action = Actuation::default();
            state.last_step_ns = None;
            state.mission = MissionProgress::default();
        }
        if state.safety.mode != Mode::Auto {
            state.action = Actuation::default();
            state.last_step_ns = None;
            state.mission = MissionProgress::default();
            return;
        }
        if transitioned && self.follower.is_some() {
            state.mission.active = true;
        }
        if !packet_ok {
            return;
        }
        let setpoints = if state.mission.active {
            self.mission_setpoints(state, now)
        } else {
            state.safety.setpoints
        };
        let dt_ns = state
            .last_step_ns
            .map_or(self.period_ns, |t| now.saturating_sub(t));
        state.action = self.controllers.update(ControlInput {
            estimate: &state.estimate,
            setpoints: &setpoints,
            mode: state.safety.mode,
            dt_s: dt_ns as f32 * 1e-9,
            earlier: Actuation::default(),
        });
        state.last_step_ns = Some(now);
    }

    /// One cycle at `now` (the cycle's wake-up time, ns, on the same clock as the inputs'
    /// timestamps).
    pub fn step(
        &mut self,
        state: &mut CoreState,
        inputs: &CycleInputs,
        now: Nanos,
    ) -> CycleOutputs {
        let mode_before = state.safety.mode;
        let transitions_before = state.safety.mode_transitions;
        state.counters.cycles += 1;
        state.counters.packets_stale += u64::from(inputs.stale_packets);
        state.counters.missed_periods += u64::from(inputs.missed_periods);
        let overrunning = state
            .overruns
            .record(inputs.missed_periods, now, &self.overrun);

        let mut refused = None;
        let mut rejected = 0;
        for &received in inputs.commands {
            let was_safe = state.safety.mode.is_safe();
            let blocked = self.revive_blocker(state, now);
            let effect = state
                .safety
                .on_command(&self.limits, received, now, blocked);
            if effect.stale {
                state.counters.commands_stale += 1;
                continue;
            }
            if was_safe && !state.safety.mode.is_safe() {
                state.fence.on_revive(&self.fence);
            }
            state.counters.commands += 1;
            if effect.rejected {
                rejected += 1;
                state.counters.setpoints_rejected += 1;
            }
            if effect.refused.is_some() {
                refused = effect.refused;
                state.counters.revives_refused += 1;
            }
        }

        let (verdict, request_to_packet_ns, packet) = self.acquire(state, &inputs.sensor, now);
        let health = CycleHealth {
            packet_ok: verdict.is_ok(),
            overrunning,
            imu_stuck: state.imu.is_stuck(self.imu_stuck_packets),
            gnss_stale: state.values.gnss.is_none(),
            rolled_over: state.rollover.is_rolled_over(),
            outside_fence: state.fence.is_outside(),
            fenced: self.fence.is_configured(),
        };
        state.safety.on_cycle(&self.limits, health, now);
        let mode_changed = state.safety.mode != mode_before;
        let transitioned = state.safety.mode_transitions != transitions_before;
        if transitioned && state.safety.mode == Mode::Failsafe {
            state.counters.failsafes += 1;
        }
        self.control(state, verdict.is_ok(), transitioned, now);

        let targets =
            self.outputs
                .outputs(state.safety.mode, &state.safety.setpoints, &state.action);
        CycleOutputs {
            targets,
            mode: state.safety.mode,
            cause: state.safety.cause,
            mode_changed,
            verdict,
            request_to_packet_ns,
            packet,
            refused,
            setpoints_rejected: rejected,
            gnss_new: state.values.gnss_new,
            gnss_age_ns: state.gnss.age_ns(now),
            action: state.action,
            values: state.values,
            estimate: state.estimate,
            auto_source: (state.safety.mode == Mode::Auto).then(|| state.mission.source()),
            mission: state.mission.status(),
        }
    }

    /// The safe targets (KILLED, FAILSAFE, shutdown).
    pub fn safe_targets(&self) -> ServoTargets {
        self.outputs.safe()
    }
}
