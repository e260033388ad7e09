//! The vehicle model: a kinematic bicycle with first-order throttle -> speed dynamics,
//! steering -> yaw rate through the wheelbase, and an active tail whose yaw moment grows with
//! deflection and speed squared, acting on the car's yaw inertia.
//!
//! Pure and deterministic: the state advances in fixed sub-steps from inputs and time only, so
//! the same inputs at the same times give the same trajectory. Headings are degrees clockwise
//! from north (as GNSS heading of motion), positions metres north and east of the start.

/// Physical parameters of the simulated car.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleParams {
    /// Wheelbase, m.
    pub wheelbase_m: f64,
    /// Front-wheel angle at full steering travel, degrees.
    pub max_steer_deg: f64,
    /// Steady-state speed at full forward throttle, m/s (reverse reaches half of it).
    pub top_speed_m_s: f64,
    /// Time constant of the speed response to throttle, s.
    pub speed_tau_s: f64,
    /// Tail yaw moment at full deflection per squared speed, N·m/(m/s)² (the tail's forces,
    /// like any aerodynamic or ground-reaction force, grow with the square of the speed).
    pub tail_moment_n_m_per_m2_s2: f64,
    /// Yaw moment of inertia of the car, kg·m².
    pub yaw_inertia_kg_m2: f64,
    /// Time constant with which the tyres take back the tail-induced yaw rate, s.
    pub tail_decay_tau_s: f64,
    /// Throttle fractions smaller than this are the ESC's dead band (no drive).
    pub throttle_dead_band: f64,
}

impl Default for VehicleParams {
    fn default() -> Self {
        VehicleParams {
            wheelbase_m: 0.33,
            max_steer_deg: 25.0,
            top_speed_m_s: 10.0,
            speed_tau_s: 0.4,
            // 0.25 N·m at 5 m/s: 240 °/s² on the 0.06 kg·m² of a 2.5 kg, 45 x 25 cm car.
            tail_moment_n_m_per_m2_s2: 0.01,
            yaw_inertia_kg_m2: 0.06,
            tail_decay_tau_s: 0.3,
            throttle_dead_band: 0.02,
        }
    }
}

/// Actuator inputs as fractions of travel around neutral, -1..=1 (steering +1 turns
/// clockwise, i.e. to the right).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Inputs {
    /// Throttle (+ forward).
    pub throttle: f64,
    /// Steering (+ clockwise).
    pub steering: f64,
    /// Tail (+ clockwise yaw torque).
    pub tail: f64,
}

/// The state of the car.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct VehicleState {
    /// Simulation time, s.
    pub t_s: f64,
    /// Position north of the start, m.
    pub north_m: f64,
    /// Position east of the start, m.
    pub east_m: f64,
    /// Heading, degrees clockwise from north, 0..360.
    pub heading_deg: f64,
    /// Speed along the heading, m/s.
    pub speed_m_s: f64,
    /// Longitudinal acceleration, m/s².
    pub accel_m_s2: f64,
    /// Yaw rate, degrees/s clockwise.
    pub yaw_rate_dps: f64,
    /// Part of the yaw rate due to the tail, degrees/s clockwise.
    pub tail_yaw_dps: f64,
}

impl VehicleState {
    /// Velocity north, m/s.
    pub fn vel_north_m_s(&self) -> f64 {
        self.speed_m_s * self.heading_deg.to_radians().cos()
    }

    /// Velocity east, m/s.
    pub fn vel_east_m_s(&self) -> f64 {
        self.speed_m_s * self.heading_deg.to_radians().sin()
    }

    /// Lateral acceleration towards the car's left, m/s² (a right turn pushes right: negative).
    pub fn lateral_accel_left_m_s2(&self) -> f64 {
        -self.speed_m_s * self.yaw_rate_dps.to_radians()
    }
}

/// Integration sub-step, s.
pub const SUBSTEP_S: f64 = 0.001;

/// The simulated car.
#[derive(Debug, Clone)]
pub struct Vehicle {
    params: VehicleParams,
    state: VehicleState,
    inputs: Inputs,
}

impl Vehicle {
    /// At rest at the origin, heading `heading_deg`.
    pub fn new(params: VehicleParams, heading_deg: f64) -> Vehicle {
        Vehicle {
            params,
            state: VehicleState {
                heading_deg: heading_deg.rem_euclid(360.0),
                ..VehicleState::default()
            },
            inputs: Inputs::default(),
        }
    }

    /// The current state.
    pub fn state(&self) -> &VehicleState {
        &self.state
    }

    /// The inputs in force.
    pub fn inputs(&self) -> Inputs {
        self.inputs
    }

    /// New actuator inputs, in force from now (values are clamped to -1..=1).
    pub fn set_inputs(&mut self, inputs: Inputs) {
        let c = |x: f64| {
            if x.is_finite() {
                x.clamp(-1.0, 1.0)
            } else {
                0.0
            }
        };
        self.inputs = Inputs {
            throttle: c(inputs.throttle),
            steering: c(inputs.steering),
            tail: c(inputs.tail),
        };
    }

    /// Advances the state to `t_s` in fixed sub-steps (nothing happens if `t_s` is not later).
    pub fn advance_to(&mut self, t_s: f64) {
        while self.state.t_s + SUBSTEP_S <= t_s {
            self.step(SUBSTEP_S);
        }
        let rest = t_s - self.state.t_s;
        if rest > 1e-9 {
            self.step(rest);
        }
    }

    fn step(&mut self, dt: f64) {
        let p = &self.params;
        let u = self.inputs;
        let s = &mut self.state;
        let throttle = if u.throttle.abs() < p.throttle_dead_band {
            0.0
        } else {
            u.throttle
        };
        let target = if throttle >= 0.0 {
            throttle * p.top_speed_m_s
        } else {
            throttle * p.top_speed_m_s * 0.5
        };
        let accel = (target - s.speed_m_s) / p.speed_tau_s;
        s.speed_m_s += accel * dt;
        s.accel_m_s2 = accel;
        let steer = (u.steering * p.max_steer_deg).to_radians();
        let bicycle_dps = (s.speed_m_s / p.wheelbase_m * steer.tan()).to_degrees();
        let tail_moment = u.tail * p.tail_moment_n_m_per_m2_s2 * s.speed_m_s * s.speed_m_s;
        let tail_yaw_accel_dps2 = (tail_moment / p.yaw_inertia_kg_m2).to_degrees();
        s.tail_yaw_dps += (tail_yaw_accel_dps2 - s.tail_yaw_dps / p.tail_decay_tau_s) * dt;
        s.yaw_rate_dps = bicycle_dps + s.tail_yaw_dps;
        s.heading_deg = (s.heading_deg + s.yaw_rate_dps * dt).rem_euclid(360.0);
        let h = s.heading_deg.to_radians();
        s.north_m += s.speed_m_s * h.cos() * dt;
        s.east_m += s.speed_m_s * h.sin() * dt;
        s.t_s += dt;
    }
}

/// Pulse width -> fraction of travel for one channel: the inverse of the application's output
/// mapping (neutral is 0, `max_us` is +1, `min_us` is -1, target 0 = no pulses = 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PulseMap {
    /// Pulse width at -1, µs.
    pub min_us: u16,
    /// Neutral pulse width, µs.
    pub neutral_us: u16,
    /// Pulse width at +1, µs.
    pub max_us: u16,
}

impl PulseMap {
    /// The fraction for a pulse width in µs (0: no pulses, treated as neutral).
    pub fn fraction(&self, pulse_us: f64) -> f64 {
        if pulse_us <= 0.0 {
            return 0.0;
        }
        let n = f64::from(self.neutral_us);
        let f = if pulse_us >= n {
            (pulse_us - n) / f64::from(self.max_us.saturating_sub(self.neutral_us).max(1))
        } else {
            (pulse_us - n) / f64::from(self.neutral_us.saturating_sub(self.min_us).max(1))
        };
        f.clamp(-1.0, 1.0)
    }
}

/// The DIMA car's channels (docs/wire-formats.md, "Servo controller: Pololu Maestro"): throttle
/// 1000-1500-2000, steering 1250-1545-1840, tail 1000-1500-2000 µs.
pub const DIMA_PULSE_MAPS: [PulseMap; 3] = [
    PulseMap {
        min_us: 1000,
        neutral_us: 1500,
        max_us: 2000,
    },
    PulseMap {
        min_us: 1250,
        neutral_us: 1545,
        max_us: 1840,
    },
    PulseMap {
        min_us: 1000,
        neutral_us: 1500,
        max_us: 2000,
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    fn car() -> Vehicle {
        Vehicle::new(VehicleParams::default(), 90.0)
    }

    #[test]
    fn throttle_speed_is_first_order() {
        let mut v = car();
        v.set_inputs(Inputs {
            throttle: 0.3,
            ..Inputs::default()
        });
        v.advance_to(0.4); // one time constant: 63 %
        let s = v.state().speed_m_s;
        assert!((s - 3.0 * (1.0 - (-1.0f64).exp())).abs() < 0.02, "{s}");
        v.advance_to(4.0);
        assert!((v.state().speed_m_s - 3.0).abs() < 1e-3);
        // Heading 90°: driving east.
        assert!(v.state().east_m > 9.0 && v.state().north_m.abs() < 1e-6);
        // Dead band: a tiny throttle coasts down.
        v.set_inputs(Inputs {
            throttle: 0.01,
            ..Inputs::default()
        });
        v.advance_to(8.0);
        assert!(v.state().speed_m_s < 0.01);
    }

    #[test]
    fn steering_gives_the_bicycle_yaw_rate_clockwise() {
        let mut v = car();
        v.set_inputs(Inputs {
            throttle: 0.2,
            steering: 0.4,
            tail: 0.0,
        });
        v.advance_to(5.0);
        let s = *v.state();
        let expected = (2.0 / 0.33 * (10.0f64).to_radians().tan()).to_degrees();
        assert!((s.yaw_rate_dps - expected).abs() < 0.05, "{s:?}");
        // A right turn pushes to the right.
        assert!(s.lateral_accel_left_m_s2() < 0.0);
        // Reverse steering turns the other way.
        let mut w = car();
        w.set_inputs(Inputs {
            throttle: 0.2,
            steering: -0.4,
            tail: 0.0,
        });
        w.advance_to(5.0);
        assert!((w.state().yaw_rate_dps + expected).abs() < 0.05);
    }

    #[test]
    fn tail_yaw_grows_with_speed_squared_and_decays() {
        let p = VehicleParams::default();
        // Steady tail yaw rate at full deflection: moment / inertia x decay time constant.
        let steady = |speed: f64| {
            (p.tail_moment_n_m_per_m2_s2 * speed * speed / p.yaw_inertia_kg_m2).to_degrees()
                * p.tail_decay_tau_s
        };
        for (throttle, t_end) in [(0.0, 10.0), (0.25, 12.0), (0.5, 14.0)] {
            let mut v = car();
            v.set_inputs(Inputs {
                throttle,
                ..Inputs::default()
            });
            v.advance_to(t_end - 2.0);
            let speed = v.state().speed_m_s;
            v.set_inputs(Inputs {
                throttle,
                tail: 1.0,
                ..Inputs::default()
            });
            v.advance_to(t_end);
            let r = v.state().tail_yaw_dps;
            assert!(
                (r - steady(speed)).abs() < 0.02 * steady(speed) + 0.01,
                "{speed} m/s: {r}"
            );
            v.set_inputs(Inputs {
                throttle,
                ..Inputs::default()
            });
            v.advance_to(t_end + 3.0);
            assert!(v.state().tail_yaw_dps.abs() < 0.5);
        }
        // At 5 m/s: 0.25 N·m, 240 °/s², 72 °/s after the tyres' decay.
        assert!((steady(5.0) - 71.6).abs() < 0.1);
    }

    #[test]
    fn deterministic_whatever_the_call_pattern() {
        let inputs = Inputs {
            throttle: 0.5,
            steering: 0.3,
            tail: -0.2,
        };
        let mut a = car();
        let mut b = car();
        a.set_inputs(inputs);
        b.set_inputs(inputs);
        a.advance_to(3.0);
        for i in 1..=3000 {
            b.advance_to(f64::from(i) * 0.001);
        }
        let (sa, sb) = (a.state(), b.state());
        assert!((sa.north_m - sb.north_m).abs() < 1e-9);
        assert!((sa.heading_deg - sb.heading_deg).abs() < 1e-9);
    }

    #[test]
    fn pulse_maps_invert_the_documented_mapping() {
        let [t, s, _] = DIMA_PULSE_MAPS;
        assert_eq!(t.fraction(1500.0), 0.0);
        assert_eq!(t.fraction(2000.0), 1.0);
        assert_eq!(t.fraction(1000.0), -1.0);
        assert_eq!(s.fraction(1840.0), 1.0);
        assert_eq!(s.fraction(1250.0), -1.0);
        assert_eq!(s.fraction(0.0), 0.0);
        assert!((t.fraction(1750.0) - 0.5).abs() < 1e-12);
    }
}
