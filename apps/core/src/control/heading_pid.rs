//! `kind = "heading_pid"`: heading -> steering.

use super::controller::{ControlInput, Controller};
use super::pid::{Pid, PidState};
use super::registry::ParamError;
use crate::config::PidConfig;
use crate::estimate::heading::wrap_180;

/// A PID on the heading error in degrees (the short way round), damped by the yaw rate.
///
/// It engages on a heading that GNSS has just confirmed (within one fix, 100 ms, of entering
/// AUTO), not on one the gyro has carried since, and disengages (neutral, integral forgotten)
/// whenever the heading setpoint or the heading estimate is missing.
#[derive(Debug, Clone, Copy)]
pub struct HeadingPid {
    pid: Pid,
    state: PidState,
    engaged: bool,
}

impl HeadingPid {
    /// From `[control.steering]`'s parameters (see [`PidConfig`]).
    pub fn from_params(params: &toml::Table) -> Result<HeadingPid, ParamError> {
        let config: PidConfig = super::registry::parse(params)?;
        config.check()?;
        Ok(HeadingPid {
            pid: config.into(),
            state: PidState::default(),
            engaged: false,
        })
    }
}

impl Controller for HeadingPid {
    fn update(&mut self, input: &ControlInput<'_>) -> f32 {
        let e = input.estimate;
        self.engaged = e.heading_deg.is_some() && (self.engaged || e.heading_from_gnss);
        let heading = e.heading_deg.filter(|_| self.engaged);
        match (input.setpoints.heading_deg_e5, heading) {
            (Some(target), Some(heading)) => {
                let error_deg = wrap_180(target as f32 * 1e-5 - heading.value);
                let rate = e.yaw_rate_dps.map_or(0.0, |r| r.value);
                let (s, u) = self.pid.step(self.state, error_deg, rate, input.dt_s);
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
        self.engaged = false;
    }
}
