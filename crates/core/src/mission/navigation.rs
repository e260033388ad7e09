//! What the robot navigates by: the mission AUTO follows and the fence it must stay in, as
//! loaded from `[navigation]` and the plan file together, checked once, and written into the
//! log so that a replay uses what the robot used.

use serde::{Deserialize, Serialize};

use super::plan::Plan;
use super::{Mission, PlanError};
use crate::config::{FenceConfig, NavigationConfig, FENCE_MAX_AREAS};
use crate::geo::LatLon;
use crate::monitor::Geofence;

/// The mission and the fence in force.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Navigation {
    /// The mission AUTO follows (`None`: AUTO holds the operator's setpoints).
    pub mission: Option<Mission>,
    /// The fence: `[navigation.fence]` joined with the plan's `geoFence`.
    pub fence: FenceConfig,
}

impl Navigation {
    /// No mission, and the configured fence.
    pub fn from_config(config: &NavigationConfig) -> Navigation {
        Navigation {
            mission: None,
            fence: config.fence.clone(),
        }
    }

    /// The plan's mission, and the configured fence joined with the plan's: the car may be in
    /// any inclusion area of either. The whole plan is refused (nothing is half-loaded) when
    /// the joined fence has too many areas or a waypoint lies outside its inclusion areas (the
    /// distance from the revive point is judged when the robot is revived, not here).
    pub fn with_plan(config: &NavigationConfig, plan: Plan) -> Result<Navigation, PlanError> {
        let fence = config.fence.joined(&plan.fence);
        for (what, count) in [
            ("circles", fence.circles.len()),
            ("polygons", fence.polygons.len()),
        ] {
            if count > FENCE_MAX_AREAS {
                return Err(PlanError::new(
                    format!("geoFence.{what}"),
                    format!(
                        "{count} {what} with navigation.fence's: the fence holds at most \
                         {FENCE_MAX_AREAS}"
                    ),
                ));
            }
        }
        let areas = Geofence::new(&fence);
        if let Some(w) = plan
            .mission
            .waypoints
            .iter()
            .find(|w| !areas.in_areas(LatLon::new(w.lat_deg, w.lon_deg)))
        {
            return Err(PlanError::new(
                format!("mission.items[{}]", w.item),
                format!(
                    "waypoint ({}, {}) lies outside the fence (navigation.fence and the plan's \
                     geoFence): the mission is refused",
                    w.lat_deg, w.lon_deg
                ),
            ));
        }
        Ok(Navigation {
            mission: Some(plan.mission),
            fence,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::FenceCircle;
    use crate::mission::parse_plan_file;

    /// A plan of two waypoints (at items 0 and 2: a speed change between) and `geofence`.
    fn plan(geofence: &str) -> Plan {
        parse_plan_file(&format!(
            r#"{{"fileType": "Plan", "geoFence": {geofence}, "mission": {{"items": [
                {{"command": 16, "params": [0, 0, 0, null, 48.1, 11.5, 0]}},
                {{"command": 178, "params": [1, 2.5, -1, 0, 0, 0, 0]}},
                {{"command": 16, "params": [0, 0, 0, null, 48.1005, 11.5, 0]}}]}}}}"#
        ))
        .unwrap()
    }

    /// A circle of `radius_m` around the first waypoint.
    const CIRCLE: &str = r#"{"circles": [{"circle": {"center": [48.1, 11.5], "radius": RADIUS},
                                          "inclusion": true}]}"#;

    #[test]
    fn a_waypoint_outside_the_plans_fence_refuses_the_whole_mission() {
        // The second waypoint is 55.6 m north of the first.
        let nav = NavigationConfig::default();
        let ok = Navigation::with_plan(&nav, plan(&CIRCLE.replace("RADIUS", "60"))).unwrap();
        assert_eq!(ok.mission.as_ref().map(|m| m.waypoints.len()), Some(2));
        assert_eq!(ok.fence.circles.len(), 1);
        let e = Navigation::with_plan(&nav, plan(&CIRCLE.replace("RADIUS", "50"))).unwrap_err();
        assert_eq!(e.location, "mission.items[2]");
        assert!(e.message.contains("lies outside the fence"), "{e}");
    }

    #[test]
    fn the_configured_fence_and_the_plans_are_joined() {
        // The configured circle holds the second waypoint, the plan's the first.
        let mut nav = NavigationConfig::default();
        nav.fence.max_distance_m = Some(300.0);
        nav.fence.circles.push(FenceCircle {
            lat_deg: 48.1005,
            lon_deg: 11.5,
            radius_m: 10.0,
        });
        let joined = Navigation::with_plan(&nav, plan(&CIRCLE.replace("RADIUS", "10"))).unwrap();
        assert_eq!(joined.fence.circles.len(), 2);
        assert_eq!(joined.fence.max_distance_m, Some(300.0));
        // Without the configured circle the second waypoint is outside.
        nav.fence.circles.clear();
        let e = Navigation::with_plan(&nav, plan(&CIRCLE.replace("RADIUS", "10"))).unwrap_err();
        assert_eq!(e.location, "mission.items[2]");
        // A plan without a fence keeps the configured one; no fence at all refuses nothing.
        let kept = Navigation::with_plan(&nav, plan("{}")).unwrap();
        assert_eq!(kept.fence, nav.fence);
        let none = Navigation::with_plan(&NavigationConfig::default(), plan("{}")).unwrap();
        assert_eq!(none.fence, FenceConfig::default());
    }

    #[test]
    fn more_areas_than_the_fence_holds_are_refused() {
        let mut nav = NavigationConfig::default();
        for _ in 0..FENCE_MAX_AREAS {
            nav.fence.circles.push(FenceCircle {
                lat_deg: 48.1,
                lon_deg: 11.5,
                radius_m: 100.0,
            });
        }
        let e = Navigation::with_plan(&nav, plan(&CIRCLE.replace("RADIUS", "100"))).unwrap_err();
        assert_eq!(e.location, "geoFence.circles");
        assert!(e.message.contains("at most 16"), "{e}");
    }

    #[test]
    fn the_joined_max_distance_is_the_smaller() {
        let a = FenceConfig {
            max_distance_m: Some(80.0),
            ..FenceConfig::default()
        };
        let b = FenceConfig {
            max_distance_m: Some(50.0),
            ..FenceConfig::default()
        };
        assert_eq!(a.joined(&b).max_distance_m, Some(50.0));
        assert_eq!(b.joined(&a).max_distance_m, Some(50.0));
        assert_eq!(a.joined(&FenceConfig::default()).max_distance_m, Some(80.0));
    }

    #[test]
    fn navigation_round_trips_through_json() {
        let nav = Navigation::with_plan(
            &NavigationConfig::default(),
            plan(&CIRCLE.replace("RADIUS", "60")),
        )
        .unwrap();
        let json = serde_json::to_string(&nav).unwrap();
        assert_eq!(serde_json::from_str::<Navigation>(&json).unwrap(), nav);
    }
}
