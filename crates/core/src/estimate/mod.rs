//! The state estimate every controller reads, computed once per cycle in the step.
//!
//! From the IMU (yaw rate, longitudinal and lateral acceleration, on every good packet) and
//! fresh GNSS fixes (ground speed and heading of motion, 10 Hz):
//! - **yaw rate**: the gyro's Z rate (signed clockwise with `gyro_yaw_sign`) less its bias, which
//!   [`bias::StillBias`] learns while the car stands still;
//! - **heading**: the bias-corrected yaw rate integrated between fixes, pulled towards the GNSS
//!   heading of motion at each fix faster than `min_heading_speed_mm_s` by a complementary
//!   filter with time constant `heading_tau_s` ([`heading::HeadingFilter`]);
//! - **ground speed**: GNSS ground speed at each fix, bridged between fixes by integrating the
//!   longitudinal acceleration ([`speed::SpeedBridge`]); never negative, bridged or not (a
//!   negative GNSS ground speed is not a valid fix in the first place);
//! - **accelerations**: the accelerometer's X (forward) and Y (left) axes in m/s².
//!
//! Heading and speed exist only while the GNSS is fresh (valid, iTOW advancing, within the GNSS
//! timeout): without it the gyro alone would drift without bound. The heading, moreover, only
//! while its last GNSS correction is within the GNSS timeout: below `min_heading_speed_mm_s` no
//! fix corrects it, and the gyro alone may carry it for that long and no longer, however fresh
//! the fixes (the heading controller then steers neutral). Every quantity carries its age.
//! With `heading_tau_s = 0`, `gyro_bias_tau_s = 0` and `accel_bridging = false` the estimate is
//! what the first DIMA-RS controllers used: each GNSS heading replaces the estimate, the raw gyro
//! carries it between fixes, and the speed is the last fix's.

pub mod bias;
pub mod heading;
pub mod speed;

use serde::{Deserialize, Serialize};

use crate::config::EstimatorConfig;
use crate::monitor::FreshFix;
use crate::Nanos;

/// A value and how old the newest measurement behind it is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Measured {
    /// The value, in the unit its field names.
    pub value: f32,
    /// Time since the newest measurement that fed it, ns.
    pub age_ns: Nanos,
}

/// What the controllers know about the car's motion. `None`: not valid now.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct StateEstimate {
    /// Ground speed, mm/s (the unit of GNSS and of the speed setpoint); never negative: GNSS
    /// ground speed is a magnitude, whatever a fix or the bridging says.
    pub speed_mm_s: Option<Measured>,
    /// Heading, degrees clockwise from north, `0..360`; its age is that of the last GNSS
    /// correction.
    pub heading_deg: Option<Measured>,
    /// The heading was corrected by a GNSS heading of motion this cycle.
    pub heading_from_gnss: bool,
    /// Yaw rate, degrees per second clockwise, gyro bias removed.
    pub yaw_rate_dps: Option<Measured>,
    /// Longitudinal acceleration, m/s², forward positive.
    pub accel_long_m_s2: Option<Measured>,
    /// Lateral acceleration, m/s², towards the car's left positive.
    pub accel_lat_m_s2: Option<Measured>,
    /// The gyro bias removed from the yaw rate, degrees per second clockwise.
    pub gyro_bias_dps: f32,
}

/// One IMU sample in physical units, in the board's frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ImuSample {
    /// Gyroscope Z, degrees per second (board frame, before `gyro_yaw_sign`).
    pub gyro_z_dps: f32,
    /// Accelerometer X (the car's forward axis), m/s².
    pub accel_x_m_s2: f32,
    /// Accelerometer Y (the car's left), m/s².
    pub accel_y_m_s2: f32,
}

/// What the estimator remembers between cycles.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EstimatorState {
    heading: heading::HeadingFilter,
    speed: speed::SpeedBridge,
    bias: bias::StillBias,
    imu: Option<(ImuSample, Nanos)>,
}

/// The estimator's settings, from `[estimator]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimator {
    gyro_yaw_sign: f32,
    min_heading_speed_mm_s: i32,
    heading_tau_s: f32,
    bias_tau_s: f32,
    still_speed_mm_s: i32,
    still_rate_dps: f32,
    accel_bridging: bool,
    heading_timeout_ns: Nanos,
}

impl Estimator {
    /// From the (validated) configuration: `[estimator]`, and the GNSS timeout
    /// (`safety.gnss_timeout_ms`, in ns), the longest the gyro alone carries the heading.
    pub fn new(config: &EstimatorConfig, gnss_timeout_ns: Nanos) -> Estimator {
        Estimator {
            gyro_yaw_sign: config.gyro_yaw_sign,
            min_heading_speed_mm_s: config.min_heading_speed_mm_s,
            heading_tau_s: config.heading_tau_s,
            bias_tau_s: config.gyro_bias_tau_s,
            still_speed_mm_s: config.still_speed_mm_s,
            still_rate_dps: config.still_rate_dps,
            accel_bridging: config.accel_bridging,
            heading_timeout_ns: gnss_timeout_ns,
        }
    }

    /// One cycle at `now`: `imu` from this cycle's good packet (None without one), `gnss` the
    /// newest fresh fix and whether it arrived this cycle.
    pub fn update(
        &self,
        state: &mut EstimatorState,
        imu: Option<ImuSample>,
        gnss: Option<FreshFix>,
        gnss_new: bool,
        now: Nanos,
    ) -> StateEstimate {
        let mut heading_from_gnss = false;
        state.heading.expire(now, self.heading_timeout_ns);
        if let Some(sample) = imu {
            let dt_s = state
                .imu
                .map_or(0.0, |(_, t)| now.saturating_sub(t) as f32 * 1e-9);
            let raw_rate_dps = self.gyro_yaw_sign * sample.gyro_z_dps;
            let still = gnss.is_some_and(|f| f.g_speed_mm_s < self.still_speed_mm_s)
                && raw_rate_dps.abs() < self.still_rate_dps;
            if still && self.bias_tau_s > 0.0 {
                state
                    .bias
                    .learn(raw_rate_dps, sample.accel_x_m_s2, dt_s, self.bias_tau_s);
            }
            let rate_dps = state.bias.yaw_rate_dps(raw_rate_dps);
            let fix_heading = gnss
                .filter(|f| gnss_new && f.g_speed_mm_s >= self.min_heading_speed_mm_s)
                .map(|f| (f.head_mot_deg_e5 as f32 * 1e-5).rem_euclid(360.0));
            heading_from_gnss = fix_heading.is_some();
            state
                .heading
                .update(rate_dps, dt_s, fix_heading, self.heading_tau_s, now);
            if self.accel_bridging {
                let accel = state.bias.accel_long_m_s2(sample.accel_x_m_s2);
                state.speed.bridge(accel, dt_s);
            }
            state.imu = Some((sample, now));
        }
        if let Some(fix) = gnss.filter(|_| gnss_new) {
            state.speed.fix(fix.g_speed_mm_s);
        }
        if gnss.is_none() {
            state.heading = heading::HeadingFilter::default();
            state.speed = speed::SpeedBridge::default();
        }
        self.estimate(state, gnss, heading_from_gnss, now)
    }

    fn estimate(
        &self,
        state: &EstimatorState,
        gnss: Option<FreshFix>,
        heading_from_gnss: bool,
        now: Nanos,
    ) -> StateEstimate {
        let measured = |value: f32, at: Nanos| Measured {
            value,
            age_ns: now.saturating_sub(at),
        };
        let imu = state.imu;
        let speed = gnss.and_then(|fix| {
            let mm_s = if self.accel_bridging {
                state.speed.mm_s()?
            } else {
                fix.g_speed_mm_s.max(0) as f32
            };
            Some(measured(mm_s, fix.at_ns))
        });
        StateEstimate {
            speed_mm_s: speed,
            heading_deg: state.heading.heading_deg().map(|(h, at)| measured(h, at)),
            heading_from_gnss,
            yaw_rate_dps: imu.map(|(s, at)| {
                measured(
                    state.bias.yaw_rate_dps(self.gyro_yaw_sign * s.gyro_z_dps),
                    at,
                )
            }),
            accel_long_m_s2: imu
                .map(|(s, at)| measured(state.bias.accel_long_m_s2(s.accel_x_m_s2), at)),
            accel_lat_m_s2: imu.map(|(s, at)| measured(s.accel_y_m_s2, at)),
            gyro_bias_dps: state.bias.gyro_dps(),
        }
    }
}

#[cfg(test)]
mod tests {
    //! Synthetic trajectories at 250 Hz with GNSS at 10 Hz, seeded noise, and the bounds the
    //! estimate keeps.

    use super::heading::wrap_180;
    use super::*;

    const PERIOD_NS: Nanos = 4_000_000;
    /// `safety.gnss_timeout_ms`'s default, ns.
    const GNSS_TIMEOUT_NS: Nanos = 500_000_000;

    fn estimator(config: EstimatorConfig) -> Estimator {
        Estimator::new(&config, GNSS_TIMEOUT_NS)
    }

    /// Deterministic Gaussian noise (xorshift64 and Box-Muller).
    struct Noise(u64);

    impl Noise {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }

        fn normal(&mut self, sigma: f64) -> f32 {
            let (u1, u2) = (self.uniform().max(1e-12), self.uniform());
            (sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
        }
    }

    /// The car's true motion at one instant.
    #[derive(Clone, Copy)]
    struct Truth {
        heading_deg: f64,
        speed_m_s: f64,
        yaw_rate_dps: f64,
        accel_m_s2: f64,
    }

    /// Sensor errors.
    struct Sensors {
        gyro_bias_dps: f32,
        gyro_sigma_dps: f64,
        gnss_heading_sigma_deg: f64,
        gnss_speed_sigma_mm_s: f64,
        noise: Noise,
    }

    /// Runs `estimator` over `seconds` of `motion(t)` starting at `t0_s`, calling `check` with
    /// the truth and the estimate every cycle.
    fn run(
        estimator: &Estimator,
        state: &mut EstimatorState,
        sensors: &mut Sensors,
        t0_s: f64,
        seconds: f64,
        motion: impl Fn(f64) -> Truth,
        mut check: impl FnMut(f64, &Truth, &StateEstimate),
    ) {
        let cycles = (seconds * 250.0).round() as u64;
        let first = (t0_s * 250.0).round() as u64;
        let mut last_fix = None;
        for k in first..first + cycles {
            let now = k * PERIOD_NS;
            let t = now as f64 * 1e-9;
            let truth = motion(t);
            let imu = ImuSample {
                gyro_z_dps: -(truth.yaw_rate_dps as f32
                    + sensors.gyro_bias_dps
                    + sensors.noise.normal(sensors.gyro_sigma_dps)),
                accel_x_m_s2: truth.accel_m_s2 as f32,
                accel_y_m_s2: 0.0,
            };
            // A new epoch every 100 ms; the board repeats the last one in between.
            let gnss_new = k % 25 == 0;
            if gnss_new || last_fix.is_none() {
                last_fix = Some(FreshFix {
                    itow_ms: (k / 25) as u32,
                    g_speed_mm_s: (truth.speed_m_s * 1e3) as i32
                        + sensors.noise.normal(sensors.gnss_speed_sigma_mm_s) as i32,
                    head_mot_deg_e5: ((truth.heading_deg
                        + f64::from(sensors.noise.normal(sensors.gnss_heading_sigma_deg)))
                        * 1e5) as i32,
                    lat_deg_e7: 0,
                    lon_deg_e7: 0,
                    at_ns: now,
                });
            }
            let fix = last_fix.expect("set above");
            let e = estimator.update(state, Some(imu), Some(fix), gnss_new, now);
            check(t, &truth, &e);
        }
    }

    fn still(_: f64) -> Truth {
        Truth {
            heading_deg: 0.0,
            speed_m_s: 0.0,
            yaw_rate_dps: 0.0,
            accel_m_s2: 0.0,
        }
    }

    fn sensors(gyro_bias_dps: f32) -> Sensors {
        Sensors {
            gyro_bias_dps,
            gyro_sigma_dps: 0.1,
            gnss_heading_sigma_deg: 1.0,
            gnss_speed_sigma_mm_s: 30.0,
            noise: Noise(0x9E37_79B9_7F4A_7C15),
        }
    }

    fn heading_error(truth: &Truth, e: &StateEstimate) -> f64 {
        let h = e.heading_deg.expect("a heading").value;
        f64::from(wrap_180(h - truth.heading_deg as f32)).abs()
    }

    #[test]
    fn constant_turn_heading_within_2_degrees_speed_within_100_mm_s() {
        // 3 s standing still (the bias is learnt), then 3 m/s in a 60 °/s clockwise circle.
        let est = estimator(EstimatorConfig::default());
        let mut state = EstimatorState::default();
        let mut s = sensors(0.5);
        run(&est, &mut state, &mut s, 0.0, 3.0, still, |_, _, _| {});
        let turn = |t: f64| Truth {
            heading_deg: (60.0 * (t - 3.0)).rem_euclid(360.0),
            speed_m_s: 3.0,
            yaw_rate_dps: 60.0,
            accel_m_s2: 0.0,
        };
        let (mut worst_heading, mut worst_speed) = (0.0f64, 0.0f64);
        run(&est, &mut state, &mut s, 3.0, 6.0, turn, |t, truth, e| {
            if t > 5.0 {
                worst_heading = worst_heading.max(heading_error(truth, e));
                let v = f64::from(e.speed_mm_s.unwrap().value);
                worst_speed = worst_speed.max((v - truth.speed_m_s * 1e3).abs());
            }
        });
        eprintln!("constant turn: worst heading {worst_heading:.2}°, speed {worst_speed:.0} mm/s");
        assert!(worst_heading < 2.0, "heading error {worst_heading:.2}°");
        assert!(worst_speed < 100.0, "speed error {worst_speed:.0} mm/s");
    }

    #[test]
    fn straight_line_heading_noise_is_averaged() {
        // 3 m/s at 45° with a 2° GNSS heading noise: the filter's RMS error is under half of it.
        let est = estimator(EstimatorConfig::default());
        let mut state = EstimatorState::default();
        let mut s = Sensors {
            gnss_heading_sigma_deg: 2.0,
            ..sensors(0.0)
        };
        let line = |_: f64| Truth {
            heading_deg: 45.0,
            speed_m_s: 3.0,
            yaw_rate_dps: 0.0,
            accel_m_s2: 0.0,
        };
        let (mut sum, mut n) = (0.0, 0.0);
        run(&est, &mut state, &mut s, 0.0, 20.0, line, |t, truth, e| {
            if t > 3.0 {
                sum += heading_error(truth, e).powi(2);
                n += 1.0;
            }
        });
        let rms = (sum / n).sqrt();
        eprintln!("straight line: RMS heading error {rms:.2}° (GNSS noise 2°)");
        assert!(rms < 1.0, "RMS heading error {rms:.2}°");
    }

    #[test]
    fn gyro_bias_is_learnt_standing_still_and_stops_the_drift() {
        // The drift the learnt bias saves shows over seconds; the gyro alone may carry the
        // heading that long here (in the car only for the GNSS timeout, see the next test).
        let est = Estimator::new(&EstimatorConfig::default(), 10 * GNSS_TIMEOUT_NS);
        let mut state = EstimatorState::default();
        let mut s = sensors(0.8);
        let mut bias = 0.0;
        run(&est, &mut state, &mut s, 0.0, 5.0, still, |_, _, e| {
            bias = e.gyro_bias_dps;
        });
        assert!((bias - 0.8).abs() < 0.05, "learnt bias {bias}");
        // Rolling straight at 0.3 m/s, too slow for GNSS heading: 4 s on the gyro alone. One
        // heading from a fast fix first (a GNSS heading at 0°).
        let mut e0 = est.update(
            &mut state,
            Some(ImuSample::default()),
            Some(FreshFix {
                itow_ms: 1_000,
                g_speed_mm_s: 2_000,
                head_mot_deg_e5: 0,
                lat_deg_e7: 0,
                lon_deg_e7: 0,
                at_ns: 5_000_000_000,
            }),
            true,
            5_000_000_000,
        );
        assert!(e0.heading_from_gnss);
        let slow = |_: f64| Truth {
            heading_deg: 0.0,
            speed_m_s: 0.3,
            yaw_rate_dps: 0.0,
            accel_m_s2: 0.0,
        };
        run(&est, &mut state, &mut s, 5.004, 4.0, slow, |_, _, e| {
            e0 = *e
        });
        let drift = heading_error(&slow(0.0), &e0);
        eprintln!("gyro bias: learnt {bias:.3} °/s of 0.8, drift {drift:.2}° in 4 s");
        // Uncorrected, 0.8 °/s for 4 s would be 3.2°.
        assert!(drift < 0.3, "drift {drift:.2}° in 4 s");
    }

    #[test]
    fn slow_fixes_keep_the_heading_only_within_the_gnss_timeout() {
        // A heading from a fast fix, then 2 s at 0.3 m/s with fresh fixes and a 2 °/s gyro bias.
        let est = estimator(EstimatorConfig::default());
        let mut state = EstimatorState::default();
        let mut s = sensors(2.0);
        let fast = |_: f64| Truth {
            heading_deg: 30.0,
            speed_m_s: 2.0,
            yaw_rate_dps: 0.0,
            accel_m_s2: 0.0,
        };
        run(&est, &mut state, &mut s, 0.0, 1.0, fast, |_, _, _| {});
        let slow = |_: f64| Truth {
            speed_m_s: 0.3,
            ..fast(0.0)
        };
        let mut last_heading = None;
        run(&est, &mut state, &mut s, 1.0, 2.0, slow, |t, _, e| {
            assert!(e.speed_mm_s.is_some(), "the fixes are fresh");
            if let Some(h) = e.heading_deg {
                assert!(h.age_ns <= GNSS_TIMEOUT_NS, "{h:?}");
                last_heading = Some(t);
            }
        });
        // The last fast fix is at 0.9 s: the gyro alone carries the heading until 1.4 s.
        let last = last_heading.expect("the gyro carries the heading for a while");
        assert!((last - 1.4).abs() < 0.002, "heading kept until {last} s");
    }

    #[test]
    fn accelerometer_bridges_the_speed_between_fixes() {
        // 2 m/s² from 1 m/s: a held fix is up to 0.2 m/s behind; the bridge stays within 30 mm/s.
        let est = estimator(EstimatorConfig::default());
        let held = estimator(EstimatorConfig {
            accel_bridging: false,
            ..EstimatorConfig::default()
        });
        let accelerating = |t: f64| Truth {
            heading_deg: 0.0,
            speed_m_s: 1.0 + 2.0 * t,
            yaw_rate_dps: 0.0,
            accel_m_s2: 2.0,
        };
        let mut worst = [0.0f64; 2];
        for (i, e) in [est, held].iter().enumerate() {
            let mut state = EstimatorState::default();
            let mut s = Sensors {
                gnss_speed_sigma_mm_s: 0.0,
                ..sensors(0.0)
            };
            run(
                e,
                &mut state,
                &mut s,
                0.0,
                2.0,
                accelerating,
                |t, truth, est| {
                    if t > 0.2 {
                        let v = f64::from(est.speed_mm_s.unwrap().value);
                        worst[i] = worst[i].max((v - truth.speed_m_s * 1e3).abs());
                    }
                },
            );
        }
        eprintln!(
            "speed: bridged {:.0} mm/s, held {:.0} mm/s",
            worst[0], worst[1]
        );
        assert!(worst[0] < 30.0, "bridged {:.0} mm/s", worst[0]);
        assert!(worst[1] > 150.0, "held {:.0} mm/s", worst[1]);
    }

    #[test]
    fn the_speed_is_never_negative_bridged_or_not() {
        for accel_bridging in [true, false] {
            let est = estimator(EstimatorConfig {
                accel_bridging,
                ..EstimatorConfig::default()
            });
            let mut state = EstimatorState::default();
            let fix = FreshFix {
                itow_ms: 1_000,
                g_speed_mm_s: -3_000,
                head_mot_deg_e5: 0,
                lat_deg_e7: 0,
                lon_deg_e7: 0,
                at_ns: 0,
            };
            let e = est.update(&mut state, Some(ImuSample::default()), Some(fix), true, 0);
            let speed = e.speed_mm_s.expect("a speed");
            assert_eq!(speed.value, 0.0, "bridging {accel_bridging}");
        }
    }

    #[test]
    fn without_fresh_gnss_there_is_no_heading_or_speed() {
        let est = estimator(EstimatorConfig::default());
        let mut state = EstimatorState::default();
        let mut s = sensors(0.0);
        run(
            &est,
            &mut state,
            &mut s,
            0.0,
            1.0,
            |t| Truth {
                heading_deg: 10.0,
                speed_m_s: 2.0 + t,
                yaw_rate_dps: 0.0,
                accel_m_s2: 1.0,
            },
            |_, _, _| {},
        );
        let imu = ImuSample::default();
        let e = est.update(&mut state, Some(imu), None, false, 2_000_000_000);
        assert_eq!((e.heading_deg, e.speed_mm_s), (None, None));
        assert!(e.yaw_rate_dps.is_some());
    }
}
