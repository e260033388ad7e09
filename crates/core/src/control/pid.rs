//! A PID controller with conditional-integration anti-windup, output and rate limits.

use crate::config::PidConfig;

/// Gains and limits (see [`PidConfig`] for units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pid {
    /// Proportional gain.
    pub kp: f32,
    /// Integral gain.
    pub ki: f32,
    /// Derivative gain, applied to the measurement's rate (no derivative kick on a setpoint
    /// step).
    pub kd: f32,
    /// Output magnitude limit.
    pub output_limit: f32,
    /// Output change limit per second.
    pub rate_limit_per_s: f32,
}

/// What a PID remembers between steps.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PidState {
    /// Integral of the error (error units x seconds).
    pub integral: f32,
    /// The previous output (for the rate limit).
    pub output: f32,
}

impl From<PidConfig> for Pid {
    fn from(c: PidConfig) -> Pid {
        Pid {
            kp: c.kp,
            ki: c.ki,
            kd: c.kd,
            output_limit: c.output_limit.abs(),
            rate_limit_per_s: c.rate_limit_per_s.abs(),
        }
    }
}

impl Pid {
    /// One step: `error` = setpoint - measurement, `measurement_rate` its time derivative,
    /// `dt_s` the time since the last step. Non-finite inputs leave the state unchanged.
    pub fn step(
        &self,
        state: PidState,
        error: f32,
        measurement_rate: f32,
        dt_s: f32,
    ) -> (PidState, f32) {
        if !(error.is_finite() && measurement_rate.is_finite() && dt_s.is_finite() && dt_s > 0.0) {
            return (state, state.output);
        }
        let limit = self.output_limit;
        let p = self.kp * error;
        let d = -self.kd * measurement_rate;
        let candidate = state.integral + error * dt_s;
        // Anti-windup: the integral may only grow until the output reaches its limit (never
        // beyond, and never pulled back just because P or D saturate on their own).
        let integral = if self.ki == 0.0 {
            0.0
        } else {
            let hi = ((limit - p - d) / self.ki).max(state.integral.min(candidate));
            let lo = ((-limit - p - d) / self.ki).min(state.integral.max(candidate));
            let i_max = limit / self.ki.abs();
            candidate.clamp(lo.min(hi), hi.max(lo)).clamp(-i_max, i_max)
        };
        let wanted = (p + self.ki * integral + d).clamp(-limit, limit);
        let max_step = self.rate_limit_per_s * dt_s;
        let output = wanted
            .clamp(state.output - max_step, state.output + max_step)
            .clamp(-limit, limit);
        (PidState { integral, output }, output)
    }
}

/// A PID and its state, run while its error is defined and reset whenever it is not.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidLoop {
    pid: Pid,
    state: PidState,
}

impl PidLoop {
    /// A loop with `pid`'s gains and limits, from rest.
    pub fn new(pid: Pid) -> PidLoop {
        PidLoop {
            pid,
            state: PidState::default(),
        }
    }

    /// One step on `(error, measurement_rate)`; `None` (no setpoint or no measurement) gives
    /// neutral and forgets the integral.
    pub fn update(&mut self, error_and_rate: Option<(f32, f32)>, dt_s: f32) -> f32 {
        match error_and_rate {
            Some((error, rate)) => {
                let (state, output) = self.pid.step(self.state, error, rate, dt_s);
                self.state = state;
                output
            }
            None => {
                self.reset();
                0.0
            }
        }
    }

    /// Back to rest.
    pub fn reset(&mut self) {
        self.state = PidState::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pid(kp: f32, ki: f32, kd: f32) -> Pid {
        Pid {
            kp,
            ki,
            kd,
            output_limit: 1.0,
            rate_limit_per_s: 1000.0,
        }
    }

    #[test]
    fn proportional_only() {
        let (_, u) = pid(0.5, 0.0, 0.0).step(PidState::default(), 1.0, 0.0, 0.01);
        assert_eq!(u, 0.5);
    }

    #[test]
    fn output_is_limited() {
        let (_, u) = pid(10.0, 0.0, 0.0).step(PidState::default(), -1.0, 0.0, 0.01);
        assert_eq!(u, -1.0);
    }

    #[test]
    fn integral_does_not_wind_up_while_saturated() {
        let c = pid(2.0, 1.0, 0.0);
        let mut s = PidState::default();
        for _ in 0..1000 {
            s = c.step(s, 1.0, 0.0, 0.01).0; // saturated by P alone
        }
        assert!(s.integral.abs() < 0.02, "integral {}", s.integral);
        // The error reverses: the output leaves saturation at once.
        let (_, u) = c.step(s, -0.2, 0.0, 0.01);
        assert!(u < 0.0, "{u}");
    }

    #[test]
    fn integral_removes_steady_error() {
        let c = pid(0.0, 1.0, 0.0);
        let mut s = PidState::default();
        for _ in 0..50 {
            s = c.step(s, 0.5, 0.0, 0.01).0;
        }
        assert!((s.output - 0.25).abs() < 1e-4, "{}", s.output);
    }

    #[test]
    fn rate_limit() {
        let c = Pid {
            rate_limit_per_s: 2.0,
            ..pid(1.0, 0.0, 0.0)
        };
        let (s, u) = c.step(PidState::default(), 1.0, 0.0, 0.1);
        assert!((u - 0.2).abs() < 1e-6);
        let (_, u) = c.step(s, 1.0, 0.0, 0.1);
        assert!((u - 0.4).abs() < 1e-6);
    }

    #[test]
    fn derivative_on_measurement_damps() {
        let (_, u) = pid(0.0, 0.0, 0.1).step(PidState::default(), 0.0, 2.0, 0.01);
        assert!((u + 0.2).abs() < 1e-6);
    }

    #[test]
    fn non_finite_inputs_hold() {
        let s = PidState {
            integral: 0.1,
            output: 0.3,
        };
        assert_eq!(pid(1.0, 1.0, 1.0).step(s, f32::NAN, 0.0, 0.01), (s, 0.3));
        assert_eq!(pid(1.0, 1.0, 1.0).step(s, 1.0, 0.0, 0.0), (s, 0.3));
    }
}
