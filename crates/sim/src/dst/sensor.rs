//! The sensor board as the loop sees it: `dima-sim`'s board model answering each request with
//! a real v1 packet, with the faults of the run's [`FaultPlan`] applied to the answer, and
//! the loop's own rules for pairing an answer with its request (stale frames drained before a
//! request, a busy board skipping a request, answers too soon passed over, the deadline).

use crate::board::{BoardConfig, BoardSim, SensorFaultState};
use crate::model::VehicleState;
use crate::rng::SimRng;
use dima_core::config::Config;
use dima_core::step::SensorInput;
use dima_core::Nanos;
use dima_sensorboard::{GnssFrame, RawPacket, SensorPacket, GNSS_FRAME_LEN};

use super::faults::{Fault, FaultPlan};

/// Time from the wake-up to the request edge, ns.
const REQUEST_AFTER_WAKE_NS: Nanos = 15_000;
/// Most stale frames passed over in one wait (as the loop).
const MAX_STALE: u32 = 8;

/// What the sensor phase of one cycle got.
#[derive(Debug, Clone, Copy)]
pub struct SensorCycle {
    /// The input to the step.
    pub input: SensorInput,
    /// Frames passed over as stale while waiting.
    pub stale: u32,
    /// The packet delivered, decoded (the harness's own copy).
    pub packet: Option<SensorPacket>,
}

/// GNSS faults' memory.
#[derive(Debug, Clone, Default)]
struct GnssMemory {
    /// The last two true NAV-PVT areas, oldest first.
    history: [Option<[u8; GNSS_FRAME_LEN]>; 2],
    /// The replay of a back-and-forth time of week: the two areas and which one is out.
    replay: Option<([[u8; GNSS_FRAME_LEN]; 2], usize)>,
    /// Position offset of a jump, 1e-7 degrees.
    jump_e7: Option<(i32, i32)>,
    /// Ground speed a negative-speed fault subtracts, mm/s.
    negative_mm_s: Option<i32>,
}

/// The simulated board with its faults.
pub struct Sensor {
    board: BoardSim,
    rng: SimRng,
    boards: u64,
    config: BoardConfig,
    in_flight: Option<(Nanos, RawPacket)>,
    frozen_accel: Option<[i16; 3]>,
    frozen_gyro: Option<[i16; 3]>,
    gnss: GnssMemory,
    resetting: bool,
    /// Probability of a late or missing answer inside those faults' windows.
    late: f64,
    missing: f64,
    wire_ns: Nanos,
    earliest_ns: Nanos,
    deadline_ns: Nanos,
    start_ns: Nanos,
}

impl Sensor {
    /// A board that booted at `start_ns`, for the loop configured by `config`.
    pub fn new(config: &Config, mut rng: SimRng, start_ns: Nanos) -> Sensor {
        let board_config = BoardConfig::default();
        let board = BoardSim::new(board_config, rng.fork(1));
        let wire_ns = config.packet_wire_ns();
        Sensor {
            board,
            boards: 1,
            config: board_config,
            in_flight: None,
            frozen_accel: None,
            frozen_gyro: None,
            gnss: GnssMemory::default(),
            resetting: false,
            late: 0.2 + rng.uniform() * 0.8,
            missing: 0.2 + rng.uniform() * 0.8,
            rng,
            wire_ns,
            earliest_ns: wire_ns.saturating_sub(u64::from(config.sensor.wire_tolerance_us) * 1_000),
            deadline_ns: config.packet_deadline_after_request_ns(),
            start_ns,
        }
    }

    /// The sensor phase of a cycle that woke at `wake_ns`, with the car in `car`.
    pub fn cycle(
        &mut self,
        wake_ns: Nanos,
        car: &VehicleState,
        plan: &mut FaultPlan,
    ) -> SensorCycle {
        let t_req = wake_ns + REQUEST_AFTER_WAKE_NS;
        // Complete frames that arrived since the last cycle are drained before the request.
        if self.in_flight.is_some_and(|(t, _)| t <= t_req) {
            self.in_flight = None;
        }
        self.answer(t_req, car, plan);
        let mut stale = 0;
        let give_up = t_req + self.deadline_ns;
        let input = match self.in_flight {
            Some((t_complete, raw)) if t_complete <= give_up => {
                self.in_flight = None;
                if t_complete < t_req + self.earliest_ns && stale < MAX_STALE {
                    stale += 1;
                    SensorInput::NoAnswer {
                        t_request_ns: t_req,
                    }
                } else {
                    SensorInput::Packet {
                        raw,
                        t_request_ns: t_req,
                        t_complete_ns: t_complete,
                    }
                }
            }
            _ => SensorInput::NoAnswer {
                t_request_ns: t_req,
            },
        };
        let packet = match input {
            SensorInput::Packet { raw, .. } => Some(SensorPacket::decode_unchecked(raw.as_bytes())),
            _ => None,
        };
        SensorCycle {
            input,
            stale,
            packet,
        }
    }

    /// The board's answer to a request at `t_req`, if it gives one: into `in_flight`.
    fn answer(&mut self, t_req: Nanos, car: &VehicleState, plan: &mut FaultPlan) {
        if plan.active(Fault::BoardReset, t_req) {
            self.resetting = true;
            self.in_flight = None;
            return;
        }
        if self.resetting {
            self.resetting = false;
            self.boards += 1;
            self.board = BoardSim::new(self.config, self.rng.fork(self.boards));
            self.frozen_accel = None;
            self.frozen_gyro = None;
            self.gnss = GnssMemory::default();
        }
        if self.in_flight.is_some() {
            // Still sending an earlier answer: like the firmware, the request is skipped.
            self.board.skip_request();
            return;
        }
        if plan.active(Fault::MissingAnswers, t_req) && self.rng.chance(self.missing) {
            return;
        }
        let now_s = (t_req - self.start_ns) as f64 * 1e-9;
        let faults = SensorFaultState {
            gnss_frozen: plan.active(Fault::GnssFrozen, t_req),
            gnss_lost: plan.active(Fault::GnssLost, t_req),
            imu_stuck: false,
            rolled_over: false,
        };
        let answer = self.board.answer_with(now_s, car, faults);
        let packet = self.apply_faults(answer.packet, t_req, plan);
        let Ok(raw) = RawPacket::new(packet) else {
            return;
        };
        let t_complete = if plan.active(Fault::LateAnswers, t_req) && self.rng.chance(self.late) {
            t_req + self.deadline_ns + 1_000 + self.rng.below(2 * self.deadline_ns)
        } else {
            t_req + self.wire_ns + self.rng.below(self.deadline_ns - self.wire_ns)
        };
        self.in_flight = Some((t_complete, raw));
    }

    /// The die and GNSS faults on one packet (re-encoded only when one changed it).
    fn apply_faults(&mut self, bytes: [u8; 132], t: Nanos, plan: &mut FaultPlan) -> [u8; 132] {
        let mut p = SensorPacket::decode_unchecked(&bytes);
        let mut changed = false;
        if plan.active(Fault::AccelFrozen, t) {
            p.accel = *self.frozen_accel.get_or_insert(p.accel);
            changed = true;
        } else {
            self.frozen_accel = None;
        }
        if plan.active(Fault::GyroFrozen, t) {
            p.gyro = *self.frozen_gyro.get_or_insert(p.gyro);
            changed = true;
        } else {
            self.frozen_gyro = None;
        }
        let truth = p.gnss.into_bytes();
        let new_epoch = self.gnss.history[1] != Some(truth);
        if new_epoch && !GnssFrame::from_bytes(truth).is_zero() {
            self.gnss.history = [self.gnss.history[1], Some(truth)];
        }
        if plan.active(Fault::ItowBackwards, t) {
            if let [Some(a), Some(b)] = self.gnss.history {
                let (frames, mut which) = *self.gnss.replay.get_or_insert(([a, b], 1));
                if new_epoch {
                    which ^= 1;
                }
                self.gnss.replay = Some((frames, which));
                p.gnss = GnssFrame::from_bytes(frames[which]);
                changed = true;
            }
        } else if self.gnss.replay.is_some() {
            self.gnss.replay = None;
            // The replay kept the history's two areas; what the receiver sends now is new.
            self.gnss.history = [None, Some(truth)];
        }
        if let Some(mut pvt) = p.gnss.nav_pvt() {
            let mut edited = false;
            if plan.active(Fault::NegativeSpeed, t) {
                let extra = *self
                    .gnss
                    .negative_mm_s
                    .get_or_insert_with(|| 500 + self.rng.below(4_000) as i32);
                pvt.g_speed_mm_s = -(pvt.g_speed_mm_s.abs() + extra);
                edited = true;
            } else {
                self.gnss.negative_mm_s = None;
            }
            if plan.active(Fault::PositionJump, t) {
                let r = &mut self.rng;
                let (dlat, dlon) = *self.gnss.jump_e7.get_or_insert_with(|| {
                    let e7 = |r: &mut SimRng| (r.below(90_000) as i32 - 45_000) * 100;
                    (e7(r), e7(r))
                });
                pvt.lat_deg_e7 = pvt.lat_deg_e7.saturating_add(dlat);
                pvt.lon_deg_e7 = pvt.lon_deg_e7.saturating_add(dlon);
                edited = true;
            } else {
                self.gnss.jump_e7 = None;
            }
            if edited {
                p.gnss = GnssFrame::from_nav_pvt(&pvt);
                changed = true;
            }
        }
        if changed {
            p.encode()
        } else {
            bytes
        }
    }
}
