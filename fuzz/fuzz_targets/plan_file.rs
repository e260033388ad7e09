//! The mission loader: `dima_core::mission::parse_plan_file` and `Navigation::with_plan`, the
//! functions the robot (`[navigation] mission_file`), `dima sim --mission` and
//! `dima-ground --plan` run on a QGroundControl plan file's text, on any text.
//!
//! Beyond "no panic": a plan that is accepted
//! - has at least one waypoint, every one at a finite latitude and longitude within range;
//! - has a fence that passes the same bounds as `[navigation.fence]`;
//! - once joined with no configured fence, has every waypoint inside the fence's areas, goes
//!   through the log's JSON record and back unchanged (so a replay follows the same mission),
//!   and gives the path follower finite guidance wherever the car is.
#![no_main]

use dima_core::config::NavigationConfig;
use dima_core::geo::LatLon;
use dima_core::mission::{parse_plan_file, Follower, FollowerState, LocalPoint, Navigation};
use dima_core::monitor::Geofence;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(plan) = parse_plan_file(text) else {
        return;
    };
    assert!(!plan.mission.waypoints.is_empty());
    for w in &plan.mission.waypoints {
        assert!(LatLon::new(w.lat_deg, w.lon_deg).is_valid(), "{w:?}");
    }
    plan.fence
        .validate_at("geoFence")
        .expect("an accepted plan's fence is within the fence's bounds");
    let Ok(navigation) = Navigation::with_plan(&NavigationConfig::default(), plan) else {
        return;
    };
    let mission = navigation.mission.as_ref().expect("with_plan keeps the mission");
    let areas = Geofence::new(&navigation.fence);
    for w in &mission.waypoints {
        assert!(areas.in_areas(LatLon::new(w.lat_deg, w.lon_deg)), "{w:?}");
    }
    let json = serde_json::to_string(&navigation).expect("the log record serialises");
    let back: Navigation = serde_json::from_str(&json).expect("the log record reads back");
    assert_eq!(back, navigation, "{json}");
    let follower = Follower::new(mission, Default::default());
    let mut state = FollowerState::default();
    for (north_m, east_m) in [(0.0, 0.0), (-3.5, 12.0), (1e4, -1e4), (0.25, 0.25)] {
        let g = follower.update(&mut state, LocalPoint { north_m, east_m }, 2.0);
        assert!(
            g.heading_deg.is_finite() && g.speed_m_s.is_finite() && g.speed_m_s >= 0.0,
            "{g:?}"
        );
        assert!(g.waypoint < follower.len());
    }
});
