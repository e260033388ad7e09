//! `kind = "speed_pid"`: ground speed -> throttle.

use super::controller::{ControlInput, Controller};
use super::pid::PidLoop;
use super::registry::ParamError;
use crate::config::PidConfig;

/// A PID on the speed error in m/s. Without a speed setpoint or a speed estimate the output is
/// neutral and the integral is forgotten.
#[derive(Debug, Clone, Copy)]
pub struct SpeedPid {
    pid: PidLoop,
}

impl SpeedPid {
    /// From `[control.throttle]`'s parameters (see [`PidConfig`]).
    pub fn from_params(params: &toml::Table) -> Result<SpeedPid, ParamError> {
        let config: PidConfig = super::registry::parse(params)?;
        config.check()?;
        Ok(SpeedPid {
            pid: PidLoop::new(config.into()),
        })
    }
}

impl Controller for SpeedPid {
    fn update(&mut self, input: &ControlInput<'_>) -> f32 {
        let error_m_s = match (input.setpoints.speed_mm_s, input.estimate.speed_mm_s) {
            (Some(target), Some(speed)) => Some(((target as f32 - speed.value) * 1e-3, 0.0)),
            _ => None,
        };
        self.pid.update(error_m_s, input.dt_s)
    }

    fn reset(&mut self) {
        self.pid.reset();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ControlConfig;
    use crate::control::Actuation;
    use crate::estimate::{Measured, StateEstimate};
    use crate::safety::{Mode, Setpoints};

    fn throttle(c: &mut SpeedPid, speed_mm_s: Option<f32>, target_mm_s: Option<i32>) -> f32 {
        let estimate = StateEstimate {
            speed_mm_s: speed_mm_s.map(|value| Measured { value, age_ns: 0 }),
            ..StateEstimate::default()
        };
        c.update(&ControlInput {
            estimate: &estimate,
            setpoints: &Setpoints {
                speed_mm_s: target_mm_s,
                ..Setpoints::default()
            },
            mode: Mode::Auto,
            dt_s: 0.004,
            earlier: Actuation::default(),
        })
    }

    #[test]
    fn accelerates_up_to_its_output_limit_and_is_neutral_without_inputs() {
        let mut c = SpeedPid::from_params(&ControlConfig::default().throttle.params).unwrap();
        let mut last = 0.0;
        for _ in 0..2_000 {
            let u = throttle(&mut c, Some(0.0), Some(5_000));
            assert!(u >= last - 1e-6 && u <= 0.5 + 1e-6, "{u}");
            last = u;
        }
        assert!((last - 0.5).abs() < 1e-6);
        assert_eq!(throttle(&mut c, None, Some(5_000)), 0.0);
        assert_eq!(throttle(&mut c, Some(0.0), None), 0.0);
    }
}
