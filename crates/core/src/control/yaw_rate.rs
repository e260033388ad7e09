//! `kind = "yaw_rate"`: the tail tracks the yaw rate the heading controller asks for.
//!
//! The steering output is the heading controller's demand; at full travel it asks for
//! `max_yaw_rate_dps`. The reference `r_ref = steering * max_yaw_rate_dps` is what the car
//! should be turning at; the tail's yaw moment makes up the difference to the measured yaw rate
//! (a PI loop with the PID's output limit, rate limit and anti-windup). In a fast turn the tail
//! adds yaw while the steering is saturated and brakes the rotation as the demand falls near
//! the target heading; going straight it damps yaw disturbances. Below `min_speed_mm_s` the
//! tail's moment (it grows with speed squared) is too weak to matter: the tail stays neutral.

use serde::{Deserialize, Serialize};

use super::controller::{ControlInput, Controller};
use super::pid::PidLoop;
use super::registry::ParamError;
use crate::config::PidConfig;

/// `[control.tail]` parameters of `kind = "yaw_rate"`; in a configuration, a key left out
/// takes its value from [`YawRateConfig::RECOMMENDED`] (see `registry::build`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YawRateConfig {
    /// Proportional gain, tail travel per °/s of yaw-rate error.
    pub kp: f32,
    /// Integral gain, tail travel per ° of accumulated yaw-rate error.
    pub ki: f32,
    /// Output limit, fraction of the tail's travel (0..=1).
    pub output_limit: f32,
    /// Largest output change, fraction of travel per second.
    pub rate_limit_per_s: f32,
    /// Yaw rate asked for at full steering demand, °/s.
    pub max_yaw_rate_dps: f32,
    /// Below this ground speed the tail stays neutral, mm/s.
    pub min_speed_mm_s: f32,
}

impl YawRateConfig {
    /// The tuning docs/controllers.md derives on the simulator's car: proportional only, a
    /// reference above what the steering alone achieves (600 °/s), neutral below 1.5 m/s.
    pub const RECOMMENDED: YawRateConfig = YawRateConfig {
        kp: 0.02,
        ki: 0.0,
        output_limit: 1.0,
        rate_limit_per_s: 50.0,
        max_yaw_rate_dps: 600.0,
        min_speed_mm_s: 1500.0,
    };
}

/// The tail's yaw-rate loop.
#[derive(Debug, Clone, Copy)]
pub struct YawRate {
    pid: PidLoop,
    max_yaw_rate_dps: f32,
    min_speed_mm_s: f32,
}

impl YawRate {
    /// From `[control.tail]`'s parameters (see [`YawRateConfig`]).
    pub fn from_params(params: &toml::Table) -> Result<YawRate, ParamError> {
        let c: YawRateConfig = super::registry::parse(params)?;
        let pid = PidConfig {
            kp: c.kp,
            ki: c.ki,
            kd: 0.0,
            output_limit: c.output_limit,
            rate_limit_per_s: c.rate_limit_per_s,
        };
        pid.check()?;
        if !(c.max_yaw_rate_dps.is_finite() && c.max_yaw_rate_dps > 0.0) {
            return Err(ParamError::invalid(
                "max_yaw_rate_dps",
                c.max_yaw_rate_dps,
                "expected a finite rate > 0",
            ));
        }
        if !(c.min_speed_mm_s.is_finite() && c.min_speed_mm_s >= 0.0) {
            return Err(ParamError::invalid(
                "min_speed_mm_s",
                c.min_speed_mm_s,
                "expected a finite speed >= 0",
            ));
        }
        Ok(YawRate {
            pid: PidLoop::new(pid.into()),
            max_yaw_rate_dps: c.max_yaw_rate_dps,
            min_speed_mm_s: c.min_speed_mm_s,
        })
    }
}

impl Controller for YawRate {
    fn update(&mut self, input: &ControlInput<'_>) -> f32 {
        let e = input.estimate;
        let fast = e.speed_mm_s.is_some_and(|v| v.value >= self.min_speed_mm_s);
        let error_dps = e.yaw_rate_dps.filter(|_| fast).map(|rate| {
            let reference = input.earlier.steering.clamp(-1.0, 1.0) * self.max_yaw_rate_dps;
            (reference - rate.value, 0.0)
        });
        self.pid.update(error_dps, input.dt_s)
    }

    fn reset(&mut self) {
        self.pid.reset();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Actuation;
    use crate::estimate::{Measured, StateEstimate};
    use crate::safety::{Mode, Setpoints};

    fn controller() -> YawRate {
        let params: toml::Table = toml::from_str(
            "kp = 0.01\nki = 0.0\noutput_limit = 1.0\nrate_limit_per_s = 1000.0\n\
             max_yaw_rate_dps = 200.0\nmin_speed_mm_s = 1000.0",
        )
        .unwrap();
        YawRate::from_params(&params).unwrap()
    }

    fn input(estimate: &StateEstimate, steering: f32) -> f32 {
        let mut c = controller();
        c.update(&ControlInput {
            estimate,
            setpoints: &Setpoints::default(),
            mode: Mode::Auto,
            dt_s: 0.004,
            earlier: Actuation {
                steering,
                ..Actuation::default()
            },
        })
    }

    fn at(speed_mm_s: f32, yaw_rate_dps: f32) -> StateEstimate {
        let m = |value| Some(Measured { value, age_ns: 0 });
        StateEstimate {
            speed_mm_s: m(speed_mm_s),
            yaw_rate_dps: m(yaw_rate_dps),
            ..StateEstimate::default()
        }
    }

    #[test]
    fn adds_yaw_while_the_car_turns_slower_than_asked() {
        // Half steering asks for 100 °/s; the car turns at 40 °/s: tail clockwise.
        assert!((input(&at(4_000.0, 40.0), 0.5) - 0.6).abs() < 1e-6);
        // Turning faster than asked: the tail brakes the rotation.
        assert!(input(&at(4_000.0, 150.0), 0.5) < 0.0);
    }

    #[test]
    fn neutral_when_slow_or_without_a_yaw_rate() {
        assert_eq!(input(&at(500.0, 0.0), 1.0), 0.0);
        let no_rate = StateEstimate {
            yaw_rate_dps: None,
            ..at(4_000.0, 0.0)
        };
        assert_eq!(input(&no_rate, 1.0), 0.0);
    }

    #[test]
    fn parameters_are_checked_by_name() {
        let bad: toml::Table = toml::from_str(
            "kp = 0.01\nki = 0.0\noutput_limit = 1.0\nrate_limit_per_s = 10.0\n\
             max_yaw_rate_dps = 0.0\nmin_speed_mm_s = 0.0",
        )
        .unwrap();
        let e = YawRate::from_params(&bad).unwrap_err();
        assert_eq!(e.field(), Some("max_yaw_rate_dps"));
        let typo: toml::Table = toml::from_str("kpp = 1.0").unwrap();
        assert!(YawRate::from_params(&typo).is_err());
    }
}
