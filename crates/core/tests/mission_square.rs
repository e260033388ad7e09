//! The path follower on a hand-written QGroundControl plan (a square of 40 m sides at 3 m/s),
//! driving a kinematic car in virtual time: every waypoint is reached and the car keeps to the
//! straights.

use dima_core::mission::{parse_plan, Follower, FollowerParams, FollowerState, LocalPoint};

const SQUARE: &str = include_str!("fixtures/square-40m.plan");

/// A unicycle whose heading loop and speed loop are first-order, with the limits of a small
/// car: the yaw rate at most `v / min_radius`, the acceleration at most 3 m/s².
struct Car {
    at: LocalPoint,
    heading_deg: f64,
    speed_m_s: f64,
}

impl Car {
    const MIN_RADIUS_M: f64 = 1.0;
    const HEADING_GAIN_PER_S: f64 = 4.0;
    const SPEED_GAIN_PER_S: f64 = 2.0;
    const ACCEL_M_S2: f64 = 3.0;

    fn step(&mut self, heading_sp_deg: f64, speed_sp_m_s: f64, dt_s: f64) {
        let error_deg = (heading_sp_deg - self.heading_deg + 180.0).rem_euclid(360.0) - 180.0;
        let max_rate_dps = (self.speed_m_s / Car::MIN_RADIUS_M).to_degrees();
        let rate_dps = (Car::HEADING_GAIN_PER_S * error_deg).clamp(-max_rate_dps, max_rate_dps);
        self.heading_deg = (self.heading_deg + rate_dps * dt_s).rem_euclid(360.0);
        let accel = (Car::SPEED_GAIN_PER_S * (speed_sp_m_s - self.speed_m_s))
            .clamp(-Car::ACCEL_M_S2, Car::ACCEL_M_S2);
        self.speed_m_s = (self.speed_m_s + accel * dt_s).max(0.0);
        let h = self.heading_deg.to_radians();
        self.at.north_m += self.speed_m_s * h.cos() * dt_s;
        self.at.east_m += self.speed_m_s * h.sin() * dt_s;
    }
}

#[test]
fn the_fixture_is_a_square_of_five_waypoints_at_3_m_s() {
    let mission = parse_plan(SQUARE).expect("the fixture is a valid plan");
    assert_eq!(mission.waypoints.len(), 5);
    assert!(mission.waypoints.iter().all(|w| w.speed_m_s == Some(3.0)));
    let follower = Follower::new(&mission, FollowerParams::default());
    let corners = [
        (0.0, 0.0),
        (40.0, 0.0),
        (40.0, 40.0),
        (0.0, 40.0),
        (0.0, 0.0),
    ];
    for (i, (n, e)) in corners.into_iter().enumerate() {
        let p = follower.waypoint(i).unwrap();
        assert!(
            (p.north_m - n).abs() < 0.01 && (p.east_m - e).abs() < 0.01,
            "{i}: {p:?}"
        );
    }
}

#[test]
fn a_40_m_square_at_3_m_s_reaches_every_waypoint_and_keeps_to_the_straights() {
    let mission = parse_plan(SQUARE).unwrap();
    let follower = Follower::new(&mission, FollowerParams::default());
    let mut state = FollowerState::default();
    let mut car = Car {
        at: LocalPoint::default(),
        heading_deg: 0.0,
        speed_m_s: 0.0,
    };
    let dt_s = 0.004;
    let mut reached = vec![false; follower.len()];
    let mut closest = vec![f64::INFINITY; follower.len()];
    let (mut sum_sq, mut samples, mut max_abs) = (0.0, 0usize, 0.0f64);
    let mut top_speed = 0.0f64;
    let mut t_s = 0.0;
    while t_s < 120.0 {
        let g = follower.update(&mut state, car.at, car.speed_m_s);
        for (i, c) in closest.iter_mut().enumerate() {
            *c = c.min(car.at.distance_to(follower.waypoint(i).unwrap()));
        }
        if g.finished {
            reached[g.waypoint] = true;
            break;
        }
        if g.waypoint > 0 {
            reached[g.waypoint - 1] = true;
        }
        // The straights: more than 10 m past a corner and 5 m before the next.
        if g.waypoint > 1 && g.along_track_m > 10.0 && g.along_track_m < g.leg_length_m - 5.0 {
            sum_sq += g.cross_track_m * g.cross_track_m;
            samples += 1;
            max_abs = max_abs.max(g.cross_track_m.abs());
        }
        top_speed = top_speed.max(car.speed_m_s);
        car.step(g.heading_deg, g.speed_m_s, dt_s);
        t_s += dt_s;
    }
    assert!(state.finished, "not finished after {t_s} s: {state:?}");
    assert!(reached.iter().all(|&r| r), "{reached:?}");
    for (i, d) in closest.iter().enumerate() {
        assert!(*d <= 1.0, "waypoint {i} passed {d} m away");
    }
    let rms = (sum_sq / samples as f64).sqrt();
    assert!(samples > 1000, "{samples}");
    assert!(
        rms <= 0.3,
        "RMS cross-track error on the straights {rms} m (max {max_abs} m)"
    );
    assert!(
        top_speed > 2.9 && top_speed < 3.1,
        "top speed {top_speed} m/s"
    );
    // Four 40 m sides at up to 3 m/s (less the acceptance radii at the corners and the end),
    // slowing for three corners and stopping at the end.
    assert!(t_s > 150.0 / 3.0 && t_s < 80.0, "lap {t_s} s");
    eprintln!("lap {t_s:.1} s, cross-track RMS {rms:.3} m, max {max_abs:.3} m");
}
