//! `kind = "speed_pid"`: ground speed -> throttle.

use super::controller::{ControlInput, Controller};
use super::pid::{Pid, PidState};
use super::registry::ParamError;
use crate::config::PidConfig;

/// A PID on the speed error in m/s. Without a speed setpoint or a speed estimate the output is
/// neutral and the integral is forgotten.
#[derive(Debug, Clone, Copy)]
pub struct SpeedPid {
    pid: Pid,
    state: PidState,
}

impl SpeedPid {
    /// From `[control.throttle]`'s parameters (see [`PidConfig`]).
    pub fn from_params(params: &toml::Table) -> Result<SpeedPid, ParamError> {
        let config: PidConfig = super::registry::parse(params)?;
        config.check()?;
        Ok(SpeedPid {
            pid: config.into(),
            state: PidState::default(),
        })
    }
}

impl Controller for SpeedPid {
    fn update(&mut self, input: &ControlInput<'_>) -> f32 {
        match (input.setpoints.speed_mm_s, input.estimate.speed_mm_s) {
            (Some(target), Some(speed)) => {
                let error_m_s = (target as f32 - speed.value) * 1e-3;
                let (s, u) = self.pid.step(self.state, error_m_s, 0.0, input.dt_s);
                self.state = s;
                u
            }
            _ => {
                self.state = PidState::default();
                0.0
            }
        }
    }

    fn reset(&mut self) {
        self.state = PidState::default();
    }
}
