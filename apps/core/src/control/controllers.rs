//! AUTO-mode controllers: the [`Controller`] trait and the speed + heading controller.

use super::pid::{Pid, PidState};
use super::{Actuation, SensorValues};
use crate::config::ControlConfig;
use crate::safety::Setpoints;

/// A controller as a pure function: its state, the setpoints, the sensor values and the time
/// step in; the new state and the actuation out. No clock, no I/O, no allocation.
pub trait Controller {
    /// What the controller remembers between steps.
    type State: Copy + Default;

    /// One control step of `dt_s` seconds.
    fn step(
        &self,
        state: Self::State,
        setpoints: &Setpoints,
        sensors: &SensorValues,
        dt_s: f32,
    ) -> (Self::State, Actuation);
}

/// Ground speed -> throttle, heading -> steering; the tail stays neutral.
///
/// Only fresh GNSS is used ([`SensorValues::gnss`]: valid, iTOW advancing, within the GNSS
/// timeout). Heading comes from GNSS heading of motion at each new fix (while moving faster
/// than `min_heading_speed_mm_s`) and is carried between fixes (10 Hz) by integrating the gyro
/// yaw rate, but only while the last fix is fresh: without GNSS the estimate is dropped.
/// Without a heading estimate or a heading setpoint the steering is neutral; without fresh
/// GNSS or a speed setpoint the throttle is neutral. The throttle never goes below neutral:
/// AUTO is forward-only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoController {
    speed: Pid,
    heading: Pid,
    gyro_yaw_sign: f32,
    min_heading_speed_mm_s: i32,
}

/// State of [`AutoController`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AutoState {
    /// Speed PID.
    pub speed: PidState,
    /// Heading PID.
    pub heading: PidState,
    /// Heading estimate, degrees clockwise from north in `0..360`.
    pub heading_deg: Option<f32>,
}

/// Wraps an angle difference into `-180..180` degrees.
pub fn wrap_180(deg: f32) -> f32 {
    (deg + 180.0).rem_euclid(360.0) - 180.0
}

impl AutoController {
    /// From the configuration.
    pub fn new(config: &ControlConfig) -> AutoController {
        AutoController {
            speed: config.speed.into(),
            heading: config.heading.into(),
            gyro_yaw_sign: config.gyro_yaw_sign,
            min_heading_speed_mm_s: config.min_heading_speed_mm_s,
        }
    }

    fn estimate_heading(&self, state: &mut AutoState, s: &SensorValues, dt_s: f32) -> f32 {
        let yaw_rate_dps = self.gyro_yaw_sign * s.gyro_z_dps;
        state.heading_deg = match s.gnss {
            None => None,
            Some(fix) if s.gnss_new && fix.g_speed_mm_s >= self.min_heading_speed_mm_s => {
                Some((fix.head_mot_deg_e5 as f32 * 1e-5).rem_euclid(360.0))
            }
            Some(_) => state
                .heading_deg
                .map(|h| (h + yaw_rate_dps * dt_s).rem_euclid(360.0)),
        };
        yaw_rate_dps
    }
}

impl Controller for AutoController {
    type State = AutoState;

    fn step(
        &self,
        mut state: AutoState,
        setpoints: &Setpoints,
        sensors: &SensorValues,
        dt_s: f32,
    ) -> (AutoState, Actuation) {
        let yaw_rate_dps = self.estimate_heading(&mut state, sensors, dt_s);

        let throttle = match (setpoints.speed_mm_s, sensors.gnss) {
            (Some(target), Some(fix)) => {
                let error_m_s = (target as f32 - fix.g_speed_mm_s as f32) * 1e-3;
                let (s, u) = self.speed.step(state.speed, error_m_s, 0.0, dt_s);
                state.speed = s;
                u.max(0.0)
            }
            // No setpoint or no speed measurement: coast at neutral, forget the integral.
            _ => {
                state.speed = PidState::default();
                0.0
            }
        };

        let steering = match (setpoints.heading_deg_e5, state.heading_deg) {
            (Some(target), Some(heading)) => {
                let error_deg = wrap_180(target as f32 * 1e-5 - heading);
                let (s, u) = self
                    .heading
                    .step(state.heading, error_deg, yaw_rate_dps, dt_s);
                state.heading = s;
                u
            }
            _ => {
                state.heading = PidState::default();
                0.0
            }
        };

        (
            state,
            Actuation {
                throttle,
                steering,
                tail: 0.0,
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::monitor::FreshFix;

    fn controller() -> AutoController {
        AutoController::new(&ControlConfig::default())
    }

    /// A new fresh fix at 2 m/s.
    fn moving(head_deg_e5: i32, itow: u32) -> SensorValues {
        SensorValues {
            gyro_z_dps: 0.0,
            gnss: Some(FreshFix {
                itow_ms: itow,
                g_speed_mm_s: 2_000,
                head_mot_deg_e5: head_deg_e5,
                at_ns: 0,
            }),
            gnss_new: true,
        }
    }

    /// The same fix, still fresh, no new epoch.
    fn between_fixes(v: SensorValues) -> SensorValues {
        SensorValues {
            gnss_new: false,
            ..v
        }
    }

    #[test]
    fn wrap() {
        assert_eq!(wrap_180(350.0 - 10.0), -20.0);
        assert_eq!(wrap_180(10.0 - 350.0), 20.0);
        assert_eq!(wrap_180(180.0), -180.0);
        assert_eq!(wrap_180(-190.0), 170.0);
    }

    #[test]
    fn heading_error_takes_the_short_way_round() {
        let c = controller();
        let sp = Setpoints {
            heading_deg_e5: Some(1_000_000), // 10°
            ..Setpoints::default()
        };
        // Heading 350°: turn clockwise by 20°, not anticlockwise by 340°.
        let (_, a) = c.step(AutoState::default(), &sp, &moving(35_000_000, 1), 0.004);
        assert!(a.steering > 0.0, "{a:?}");
        let sp = Setpoints {
            heading_deg_e5: Some(35_000_000),
            ..Setpoints::default()
        };
        let (_, a) = c.step(AutoState::default(), &sp, &moving(1_000_000, 1), 0.004);
        assert!(a.steering < 0.0, "{a:?}");
    }

    #[test]
    fn gyro_carries_the_heading_between_fixes() {
        let c = controller();
        let sp = Setpoints::default();
        let (mut s, _) = c.step(AutoState::default(), &sp, &moving(9_000_000, 100), 0.004);
        assert_eq!(s.heading_deg, Some(90.0));
        // Same fix (same iTOW) for 0.1 s while turning clockwise at 50 °/s: Z up, so the gyro
        // reads -50 °/s with the default sign.
        let turning = SensorValues {
            gyro_z_dps: -50.0,
            ..between_fixes(moving(9_000_000, 100))
        };
        for _ in 0..25 {
            s = c.step(s, &sp, &turning, 0.004).0;
        }
        assert!((s.heading_deg.unwrap() - 95.0).abs() < 1e-3, "{s:?}");
        // The next fix resets the estimate.
        let (s, _) = c.step(s, &sp, &moving(9_200_000, 200), 0.004);
        assert_eq!(s.heading_deg, Some(92.0));
    }

    #[test]
    fn slow_fixes_do_not_set_the_heading() {
        let c = controller();
        let mut slow = moving(4_500_000, 1);
        slow.gnss.as_mut().unwrap().g_speed_mm_s = 100;
        let (s, _) = c.step(AutoState::default(), &Setpoints::default(), &slow, 0.004);
        assert_eq!(s.heading_deg, None);
    }

    #[test]
    fn speed_controller_accelerates_and_is_limited() {
        let c = controller();
        let sp = Setpoints {
            speed_mm_s: Some(5_000),
            ..Setpoints::default()
        };
        let mut s = AutoState::default();
        let mut last = 0.0;
        for i in 0..2_000 {
            let v = if i % 25 == 0 {
                moving(0, i)
            } else {
                between_fixes(moving(0, i - i % 25))
            };
            let (ns, a) = c.step(s, &sp, &v, 0.004);
            s = ns;
            assert!(
                a.throttle >= last - 1e-6,
                "monotonic while below the setpoint"
            );
            assert!(a.throttle <= 0.5 + 1e-6, "output limit");
            last = a.throttle;
        }
        assert!((last - 0.5).abs() < 1e-6, "{last} {s:?}");
    }

    #[test]
    fn without_fresh_gnss_the_gyro_heading_is_dropped() {
        let c = controller();
        let sp = Setpoints::default();
        let (s, _) = c.step(AutoState::default(), &sp, &moving(9_000_000, 100), 0.004);
        assert_eq!(s.heading_deg, Some(90.0));
        let no_gnss = SensorValues {
            gyro_z_dps: -50.0,
            ..SensorValues::default()
        };
        let (s, _) = c.step(s, &sp, &no_gnss, 0.004);
        assert_eq!(s.heading_deg, None);
    }

    #[test]
    fn auto_never_reverses() {
        let c = controller();
        let sp = Setpoints {
            speed_mm_s: Some(0),
            ..Setpoints::default()
        };
        // Far too fast for the setpoint: the speed loop wants to brake, AUTO coasts.
        let (_, a) = c.step(AutoState::default(), &sp, &moving(0, 1), 0.004);
        assert_eq!(a.throttle, 0.0);
    }

    #[test]
    fn no_fix_means_neutral() {
        let c = controller();
        let sp = Setpoints {
            speed_mm_s: Some(5_000),
            heading_deg_e5: Some(0),
            ..Setpoints::default()
        };
        let (_, a) = c.step(AutoState::default(), &sp, &SensorValues::default(), 0.004);
        assert_eq!(a, Actuation::default());
    }
}
