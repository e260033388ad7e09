//! `kind = "heading_pid"`: heading -> steering.

use super::controller::{ControlInput, Controller};
use super::pid::PidLoop;
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
    pid: PidLoop,
    engaged: bool,
}

impl HeadingPid {
    /// From `[control.steering]`'s parameters (see [`PidConfig`]).
    pub fn from_params(params: &toml::Table) -> Result<HeadingPid, ParamError> {
        let config: PidConfig = super::registry::parse(params)?;
        config.check()?;
        Ok(HeadingPid {
            pid: PidLoop::new(config.into()),
            engaged: false,
        })
    }
}

impl Controller for HeadingPid {
    fn update(&mut self, input: &ControlInput<'_>) -> f32 {
        let e = input.estimate;
        self.engaged = e.heading_deg.is_some() && (self.engaged || e.heading_from_gnss);
        let heading = e.heading_deg.filter(|_| self.engaged);
        let error_deg = match (input.setpoints.heading_deg_e5, heading) {
            (Some(target), Some(heading)) => Some((
                wrap_180(target as f32 * 1e-5 - heading.value),
                e.yaw_rate_dps.map_or(0.0, |r| r.value),
            )),
            _ => None,
        };
        self.pid.update(error_deg, input.dt_s)
    }

    fn reset(&mut self) {
        self.pid.reset();
        self.engaged = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ControlConfig;
    use crate::control::Actuation;
    use crate::estimate::{Measured, StateEstimate};
    use crate::safety::{Mode, Setpoints};

    fn controller() -> HeadingPid {
        HeadingPid::from_params(&ControlConfig::default().steering.params).unwrap()
    }

    fn heading(deg: f32, from_gnss: bool) -> StateEstimate {
        StateEstimate {
            heading_deg: Some(Measured {
                value: deg,
                age_ns: 0,
            }),
            heading_from_gnss: from_gnss,
            ..StateEstimate::default()
        }
    }

    fn steer(c: &mut HeadingPid, estimate: &StateEstimate, target_deg: f32) -> f32 {
        c.update(&ControlInput {
            estimate,
            setpoints: &Setpoints {
                heading_deg_e5: Some((target_deg * 1e5) as i32),
                ..Setpoints::default()
            },
            mode: Mode::Auto,
            dt_s: 0.004,
            earlier: Actuation::default(),
        })
    }

    #[test]
    fn the_error_takes_the_short_way_round() {
        // At 350° for 10°: clockwise by 20°, not anticlockwise by 340°.
        assert!(steer(&mut controller(), &heading(350.0, true), 10.0) > 0.0);
        assert!(steer(&mut controller(), &heading(10.0, true), 350.0) < 0.0);
    }

    #[test]
    fn engages_on_a_gnss_confirmed_heading_only() {
        let mut c = controller();
        assert_eq!(steer(&mut c, &heading(0.0, false), 90.0), 0.0);
        assert!(steer(&mut c, &heading(0.0, true), 90.0) > 0.0);
        assert!(
            steer(&mut c, &heading(1.0, false), 90.0) > 0.0,
            "stays engaged"
        );
        c.reset();
        assert_eq!(steer(&mut c, &heading(1.0, false), 90.0), 0.0);
    }
}
