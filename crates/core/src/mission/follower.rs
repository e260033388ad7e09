//! The path follower: pure pursuit along the legs between waypoints, with corner speed limits.
//!
//! Each cycle, with the car's position in the [`LocalFrame`] around the first waypoint and its
//! ground speed:
//! 1. **acceptance**: the current waypoint is reached when the car is within its acceptance
//!    radius, or when it has passed the line through the waypoint perpendicular to the leg (it
//!    went by outside the radius: it is counted reached, and the follower goes on rather than
//!    turning back); the next one becomes current, and after the last the mission is finished;
//! 2. **heading**: the bearing from the car to the carrot, the point on the current leg one
//!    lookahead distance (`lookahead_s` × speed, at least `lookahead_min_m`) beyond the car's
//!    projection on the leg, never beyond the waypoint itself;
//! 3. **speed**: the leg's speed, limited so that the car can brake (at `decel_m_s2`) to the
//!    corner speed by the waypoint. The corner speed of a turn sharper than
//!    `corner_angle_deg` is `sqrt(lateral_accel_m_s2 × r)`, with `r = lookahead_min_m / (2
//!    sin θ)` the radius pure pursuit turns at when its carrot is θ off the nose (θ the turn
//!    angle, at most 90 degrees); at the last waypoint it is 0 (the car stops there);
//! 4. **cross-track error**: the car's signed distance from the leg, metres, positive right of
//!    the track.
//!
//! The first leg runs from where the car was when the mission started to the first waypoint.

use super::local::{LocalFrame, LocalPoint};
use super::Mission;

/// The follower's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FollowerParams {
    /// Ground speed where the plan sets none, m/s.
    pub default_speed_m_s: f64,
    /// Acceptance radius where the plan sets none, m.
    pub default_acceptance_m: f64,
    /// Shortest lookahead distance, m.
    pub lookahead_min_m: f64,
    /// Lookahead distance per m/s of ground speed, s.
    pub lookahead_s: f64,
    /// Lateral acceleration allowed in a corner, m/s².
    pub lateral_accel_m_s2: f64,
    /// Deceleration allowed when slowing down for a corner or the end, m/s².
    pub decel_m_s2: f64,
    /// Turns sharper than this (degrees) are taken at the corner speed.
    pub corner_angle_deg: f64,
}

impl Default for FollowerParams {
    fn default() -> Self {
        FollowerParams {
            default_speed_m_s: 2.0,
            default_acceptance_m: 1.0,
            lookahead_min_m: 3.0,
            lookahead_s: 1.0,
            lateral_accel_m_s2: 3.0,
            decel_m_s2: 1.5,
            corner_angle_deg: 20.0,
        }
    }
}

/// One waypoint, ready to follow.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Target {
    point: LocalPoint,
    acceptance_m: f64,
    speed_m_s: f64,
}

/// A mission in the local frame around its first waypoint, and the follower's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Follower {
    frame: LocalFrame,
    targets: Vec<Target>,
    params: FollowerParams,
}

/// What the follower remembers between cycles.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FollowerState {
    /// Index of the current waypoint.
    pub current: usize,
    /// Where the car was when the mission started (the first leg's start).
    pub start: Option<LocalPoint>,
    /// The last waypoint was reached.
    pub finished: bool,
}

/// The follower's output for one cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guidance {
    /// Heading setpoint, degrees clockwise from north, `0..360`.
    pub heading_deg: f64,
    /// Speed setpoint, m/s (0 once finished).
    pub speed_m_s: f64,
    /// Index of the current waypoint (the last one once finished).
    pub waypoint: usize,
    /// Signed distance from the current leg, m, positive right of the track.
    pub cross_track_m: f64,
    /// Distance along the current leg from its start, m.
    pub along_track_m: f64,
    /// Length of the current leg, m.
    pub leg_length_m: f64,
    /// Distance from the car to the current waypoint, m.
    pub to_go_m: f64,
    /// The last waypoint has been reached.
    pub finished: bool,
}

/// A leg's geometry seen from the car.
struct LegView {
    from: LocalPoint,
    unit: (f64, f64),
    length_m: f64,
    along_m: f64,
    cross_m: f64,
}

fn leg_view(from: LocalPoint, to: LocalPoint, car: LocalPoint) -> LegView {
    let (dn, de) = (to.north_m - from.north_m, to.east_m - from.east_m);
    let length_m = dn.hypot(de);
    let unit = if length_m > 1e-9 {
        (dn / length_m, de / length_m)
    } else {
        (1.0, 0.0)
    };
    let (cn, ce) = (car.north_m - from.north_m, car.east_m - from.east_m);
    LegView {
        from,
        unit,
        length_m,
        along_m: cn * unit.0 + ce * unit.1,
        cross_m: -cn * unit.1 + ce * unit.0,
    }
}

impl Follower {
    /// The mission in the frame around its first waypoint.
    pub fn new(mission: &Mission, params: FollowerParams) -> Follower {
        let first = mission.waypoints[0];
        let frame = LocalFrame::new(first.lat_deg, first.lon_deg);
        let targets = mission
            .waypoints
            .iter()
            .map(|w| Target {
                point: frame.to_local(w.lat_deg, w.lon_deg),
                acceptance_m: w.acceptance_m.unwrap_or(params.default_acceptance_m),
                speed_m_s: w.speed_m_s.unwrap_or(params.default_speed_m_s),
            })
            .collect();
        Follower {
            frame,
            targets,
            params,
        }
    }

    /// The local frame (around the first waypoint).
    pub fn frame(&self) -> &LocalFrame {
        &self.frame
    }

    /// Number of waypoints.
    pub fn len(&self) -> usize {
        self.targets.len()
    }

    /// Never true: a mission has at least one waypoint.
    pub fn is_empty(&self) -> bool {
        self.targets.is_empty()
    }

    /// Waypoint `index` in the local frame.
    pub fn waypoint(&self, index: usize) -> Option<LocalPoint> {
        self.targets.get(index).map(|t| t.point)
    }

    /// The speed at which the car may pass waypoint `index`, m/s.
    pub fn corner_speed_m_s(&self, index: usize) -> f64 {
        let Some(next) = self.targets.get(index + 1) else {
            return 0.0;
        };
        let at = self.targets[index].point;
        let before = if index == 0 {
            return f64::INFINITY;
        } else {
            self.targets[index - 1].point
        };
        let turn_deg =
            (before.bearing_to(at) - at.bearing_to(next.point) + 180.0).rem_euclid(360.0) - 180.0;
        let turn_deg = turn_deg.abs();
        if turn_deg <= self.params.corner_angle_deg {
            return f64::INFINITY;
        }
        let radius_m = self.params.lookahead_min_m / (2.0 * turn_deg.min(90.0).to_radians().sin());
        (self.params.lateral_accel_m_s2 * radius_m).sqrt()
    }

    /// One cycle: the car at `car` (local frame) moving at `speed_m_s`.
    pub fn update(&self, state: &mut FollowerState, car: LocalPoint, speed_m_s: f64) -> Guidance {
        let start = *state.start.get_or_insert(car);
        let last = self.targets.len() - 1;
        let leg = |index: usize| {
            let from = if index == 0 {
                start
            } else {
                self.targets[index - 1].point
            };
            leg_view(from, self.targets[index].point, car)
        };
        while !state.finished {
            let target = self.targets[state.current];
            let view = leg(state.current);
            let reached = car.distance_to(target.point) <= target.acceptance_m
                || (view.length_m > 1e-9 && view.along_m >= view.length_m);
            if !reached {
                break;
            }
            if state.current == last {
                state.finished = true;
            } else {
                state.current += 1;
            }
        }
        let view = leg(state.current);
        let target = self.targets[state.current];
        if state.finished {
            return Guidance {
                heading_deg: view.from.bearing_to(target.point),
                speed_m_s: 0.0,
                waypoint: state.current,
                cross_track_m: view.cross_m,
                along_track_m: view.along_m,
                leg_length_m: view.length_m,
                to_go_m: car.distance_to(target.point),
                finished: true,
            };
        }
        let lookahead_m = (self.params.lookahead_s * speed_m_s).max(self.params.lookahead_min_m);
        let carrot_along = (view.along_m.max(0.0) + lookahead_m).min(view.length_m);
        let carrot = LocalPoint {
            north_m: view.from.north_m + view.unit.0 * carrot_along,
            east_m: view.from.east_m + view.unit.1 * carrot_along,
        };
        let heading_deg = if car.distance_to(carrot) > 1e-6 {
            car.bearing_to(carrot)
        } else {
            view.from.bearing_to(target.point)
        };
        let corner = self.corner_speed_m_s(state.current);
        let to_go_m = car.distance_to(target.point);
        let braking = (corner * corner + 2.0 * self.params.decel_m_s2 * to_go_m).sqrt();
        Guidance {
            heading_deg,
            speed_m_s: target.speed_m_s.min(braking),
            waypoint: state.current,
            cross_track_m: view.cross_m,
            along_track_m: view.along_m,
            leg_length_m: view.length_m,
            to_go_m,
            finished: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::Waypoint;

    /// A mission through local points (north, east) around 48 N, 11 E.
    fn follower(points: &[(f64, f64)]) -> Follower {
        let frame = LocalFrame::new(48.0, 11.0);
        let waypoints = points
            .iter()
            .enumerate()
            .map(|(item, &(north_m, east_m))| {
                let (lat_deg, lon_deg) = frame.to_geodetic(LocalPoint { north_m, east_m });
                Waypoint {
                    lat_deg,
                    lon_deg,
                    acceptance_m: None,
                    speed_m_s: Some(3.0),
                    item,
                }
            })
            .collect();
        Follower::new(&Mission { waypoints }, FollowerParams::default())
    }

    fn at(north_m: f64, east_m: f64) -> LocalPoint {
        LocalPoint { north_m, east_m }
    }

    #[test]
    fn sharp_corners_are_slow_gentle_ones_are_not_and_the_end_is_a_stop() {
        let f = follower(&[(0.0, 0.0), (40.0, 0.0), (40.0, 40.0), (80.0, 45.0)]);
        // 90 degrees: r = 3 / 2 = 1.5 m, sqrt(3 * 1.5) = 2.12 m/s.
        assert!((f.corner_speed_m_s(1) - 4.5f64.sqrt()).abs() < 1e-6);
        // About 83 degrees, still sharper than 20: slowed.
        assert!(f.corner_speed_m_s(2) < 2.5);
        assert_eq!(f.corner_speed_m_s(3), 0.0);
        let gentle = follower(&[(0.0, 0.0), (40.0, 0.0), (80.0, 10.0)]);
        assert_eq!(gentle.corner_speed_m_s(1), f64::INFINITY);
    }

    #[test]
    fn the_car_slows_before_a_corner_so_it_can_brake_to_the_corner_speed() {
        let f = follower(&[(0.0, 0.0), (40.0, 0.0), (40.0, 40.0)]);
        let mut state = FollowerState::default();
        f.update(&mut state, at(0.0, 0.0), 0.0);
        let far = f.update(&mut state, at(10.0, 0.0), 3.0);
        assert_eq!((far.waypoint, far.speed_m_s), (1, 3.0));
        let near = f.update(&mut state, at(38.8, 0.0), 3.0);
        let expected = (4.5f64 + 2.0 * 1.5 * 1.2).sqrt();
        assert!(expected < 3.0);
        assert!((near.speed_m_s - expected).abs() < 1e-6, "{near:?}");
    }

    #[test]
    fn passing_a_waypoint_outside_its_radius_moves_on_and_cross_track_is_positive_right() {
        let f = follower(&[(0.0, 0.0), (40.0, 0.0), (40.0, 40.0)]);
        let mut state = FollowerState::default();
        f.update(&mut state, at(0.0, 0.0), 0.0);
        let g = f.update(&mut state, at(20.0, 2.0), 3.0);
        assert_eq!(g.waypoint, 1);
        assert!((g.cross_track_m - 2.0).abs() < 1e-6, "{g:?}");
        // Steers back left of north towards the track.
        assert!(g.heading_deg > 270.0, "{g:?}");
        // 3 m right of the corner and past it: waypoint 1 counts as passed.
        let g = f.update(&mut state, at(40.5, 3.0), 3.0);
        assert_eq!(g.waypoint, 2);
        assert!(!g.finished);
        let g = f.update(&mut state, at(40.0, 39.5), 1.0);
        assert!(g.finished && g.speed_m_s == 0.0, "{g:?}");
    }
}
