//! The QGroundControl plan file (`.plan`, JSON) as a [`Mission`].
//!
//! The file is an object with `fileType: "Plan"`, a `mission` object whose `items` are the
//! mission items, a `geoFence` object (read by [`parse_plan_file`]: see `plan_fence`) and a
//! `rallyPoints` object (accepted and not read: a car has no rally point). Each item is a `SimpleItem` with a MAVLink
//! `command` and seven `params` `[param1, param2, param3, param4, latitude, longitude,
//! altitude]` (QGroundControl writes a NaN parameter as `null`); files of the older format give
//! the position as `coordinate: [latitude, longitude, altitude]` and the parameters as
//! `param1`..`param4`. A ground vehicle follows:
//! - `MAV_CMD_NAV_WAYPOINT` (16): a waypoint; `param2` is its acceptance radius in metres (0:
//!   the follower's default); hold time, pass radius, yaw and altitude are ignored;
//! - `MAV_CMD_DO_CHANGE_SPEED` (178): `param2` is the ground speed in m/s for the waypoints
//!   after it (-1 or 0: no change).
//!
//! Any other command, a `ComplexItem` (survey, corridor scan) or a waypoint without a finite
//! latitude and longitude is an error that names the item.

use serde_json::Value;

use super::plan_fence::parse_geofence;
use super::{Mission, Waypoint};
use crate::config::FenceConfig;

/// `MAV_CMD_NAV_WAYPOINT`.
pub const MAV_CMD_NAV_WAYPOINT: u64 = 16;
/// `MAV_CMD_DO_CHANGE_SPEED`.
pub const MAV_CMD_DO_CHANGE_SPEED: u64 = 178;

/// Why a plan file cannot be followed: where in the file, and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{location}: {message}")]
pub struct PlanError {
    /// The JSON path of the offending part, e.g. `mission.items[3]`.
    pub location: String,
    /// What is wrong with it.
    pub message: String,
}

impl PlanError {
    pub(super) fn new(location: impl Into<String>, message: impl Into<String>) -> PlanError {
        PlanError {
            location: location.into(),
            message: message.into(),
        }
    }
}

/// The MAVLink name of commands a plan may hold, for messages.
fn command_name(command: u64) -> &'static str {
    match command {
        16 => "WAYPOINT",
        17 => "LOITER_UNLIM",
        18 => "LOITER_TURNS",
        19 => "LOITER_TIME",
        20 => "RETURN_TO_LAUNCH",
        21 => "LAND",
        22 => "TAKEOFF",
        31 => "LOITER_TO_ALT",
        82 => "SPLINE_WAYPOINT",
        84 => "VTOL_TAKEOFF",
        85 => "VTOL_LAND",
        93 => "DELAY",
        112 => "CONDITION_DELAY",
        177 => "DO_JUMP",
        178 => "DO_CHANGE_SPEED",
        183 => "DO_SET_SERVO",
        201 => "DO_SET_ROI",
        206 => "DO_SET_CAM_TRIGG_DIST",
        2000 => "IMAGE_START_CAPTURE",
        _ => "unknown",
    }
}

/// Parameter `index` (0-based: `params[index]`, or `param{index+1}` in the older format);
/// `None` when absent or `null` (QGroundControl's NaN).
fn param(item: &Value, index: usize) -> Option<f64> {
    if let Some(params) = item.get("params").and_then(Value::as_array) {
        return params.get(index).and_then(Value::as_f64);
    }
    match index {
        0..=3 => item
            .get(format!("param{}", index + 1))
            .and_then(Value::as_f64),
        4 | 5 => item
            .get("coordinate")
            .and_then(Value::as_array)
            .and_then(|c| c.get(index - 4))
            .and_then(Value::as_f64),
        _ => None,
    }
}

/// A finite latitude or longitude within its range, or the error naming it.
fn coordinate(item: &Value, index: usize, at: &str) -> Result<f64, PlanError> {
    let (name, limit) = if index == 4 {
        ("latitude", 90.0)
    } else {
        ("longitude", 180.0)
    };
    let raw = item
        .get("params")
        .and_then(Value::as_array)
        .and_then(|p| p.get(index))
        .or_else(|| {
            item.get("coordinate")
                .and_then(Value::as_array)
                .and_then(|c| c.get(index - 4))
        });
    let value = match raw {
        None => return Err(PlanError::new(at, format!("waypoint without a {name}"))),
        Some(Value::Null) => {
            return Err(PlanError::new(
                at,
                format!("waypoint {name} is not a finite number (null)"),
            ))
        }
        Some(v) => v
            .as_f64()
            .ok_or_else(|| PlanError::new(at, format!("waypoint {name} is not a number: {v}")))?,
    };
    if !value.is_finite() || value.abs() > limit {
        return Err(PlanError::new(
            at,
            format!("waypoint {name} {value} is outside -{limit}..={limit}"),
        ));
    }
    Ok(value)
}

/// A whole plan file: the mission and the plan's own fence.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The waypoints.
    pub mission: Mission,
    /// The plan's `geoFence` (inclusion areas; empty when the plan has none).
    pub fence: FenceConfig,
}

/// Parses a QGroundControl plan file's text into the mission a ground vehicle follows (its
/// `geoFence` is not read: see [`parse_plan_file`]).
pub fn parse_plan(text: &str) -> Result<Mission, PlanError> {
    mission_of(&plan_root(text)?)
}

/// Parses a QGroundControl plan file's text into its mission and its fence.
pub fn parse_plan_file(text: &str) -> Result<Plan, PlanError> {
    let root = plan_root(text)?;
    Ok(Plan {
        mission: mission_of(&root)?,
        fence: parse_geofence(&root)?,
    })
}

/// The root object of a plan file.
fn plan_root(text: &str) -> Result<Value, PlanError> {
    let root: Value = serde_json::from_str(text)
        .map_err(|e| PlanError::new("plan", format!("not valid JSON: {e}")))?;
    match root.get("fileType").and_then(Value::as_str) {
        Some("Plan") => {}
        Some(other) => {
            return Err(PlanError::new(
                "fileType",
                format!("\"{other}\" is not a plan file (expected \"Plan\")"),
            ))
        }
        None => return Err(PlanError::new("fileType", "missing (expected \"Plan\")")),
    }
    Ok(root)
}

/// The mission of a plan's root object.
fn mission_of(root: &Value) -> Result<Mission, PlanError> {
    let items = root
        .get("mission")
        .ok_or_else(|| PlanError::new("mission", "missing"))?
        .get("items")
        .and_then(Value::as_array)
        .ok_or_else(|| PlanError::new("mission.items", "missing or not an array"))?;
    let mut speed_m_s = None;
    let mut waypoints = Vec::new();
    for (i, item) in items.iter().enumerate() {
        let at = format!("mission.items[{i}]");
        let kind = item
            .get("type")
            .and_then(Value::as_str)
            .unwrap_or("SimpleItem");
        if kind != "SimpleItem" {
            return Err(PlanError::new(
                at,
                format!("{kind} items (surveys, scans) are not supported: plan plain waypoints"),
            ));
        }
        let command = item
            .get("command")
            .and_then(Value::as_u64)
            .ok_or_else(|| PlanError::new(&at, "missing or invalid command"))?;
        match command {
            MAV_CMD_NAV_WAYPOINT => {
                let lat_deg = coordinate(item, 4, &at)?;
                let lon_deg = coordinate(item, 5, &at)?;
                let acceptance_m = match param(item, 1) {
                    Some(r) if !r.is_finite() || r < 0.0 => {
                        return Err(PlanError::new(
                            at,
                            format!("acceptance radius {r} m is negative"),
                        ))
                    }
                    Some(r) if r > 0.0 => Some(r),
                    _ => None,
                };
                waypoints.push(Waypoint {
                    lat_deg,
                    lon_deg,
                    acceptance_m,
                    speed_m_s,
                    item: i,
                });
            }
            MAV_CMD_DO_CHANGE_SPEED => match param(item, 1) {
                Some(s) if s.is_finite() && s > 0.0 => speed_m_s = Some(s),
                Some(s) if s == -1.0 || s == 0.0 => {}
                other => {
                    return Err(PlanError::new(
                        at,
                        format!(
                            "command 178 (DO_CHANGE_SPEED): speed {} is not a positive number \
                             of m/s (or -1: no change)",
                            other.map_or("missing".to_string(), |s| s.to_string())
                        ),
                    ))
                }
            },
            other => {
                return Err(PlanError::new(
                    at,
                    format!(
                        "command {other} ({}) is not supported by a ground vehicle",
                        command_name(other)
                    ),
                ))
            }
        }
    }
    if waypoints.is_empty() {
        return Err(PlanError::new("mission.items", "no waypoint (command 16)"));
    }
    Ok(Mission { waypoints })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(items: &str) -> String {
        format!(
            r#"{{"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
                "geoFence": {{"circles": [], "polygons": [], "version": 2}},
                "rallyPoints": {{"points": [], "version": 2}},
                "mission": {{"version": 2, "firmwareType": 3, "vehicleType": 10,
                             "plannedHomePosition": [48.1, 11.5, 520], "items": [{items}]}}}}"#
        )
    }

    fn wp(lat: &str, lon: &str, radius: f64) -> String {
        format!(
            r#"{{"type": "SimpleItem", "command": 16, "frame": 3, "autoContinue": true,
                "doJumpId": 1, "params": [0, {radius}, 0, null, {lat}, {lon}, 0]}}"#
        )
    }

    #[test]
    fn waypoints_take_their_radius_and_the_speed_set_before_them() {
        let speed = r#"{"type": "SimpleItem", "command": 178, "params": [1, 2.5, -1, 0, 0, 0, 0]}"#;
        let items = [
            wp("48.1", "11.5", 0.0),
            speed.into(),
            wp("48.1001", "11.5", 1.5),
        ];
        let mission = parse_plan(&plan(&items.join(","))).unwrap();
        assert_eq!(mission.waypoints.len(), 2);
        let (a, b) = (mission.waypoints[0], mission.waypoints[1]);
        assert_eq!(
            (a.lat_deg, a.lon_deg, a.acceptance_m, a.speed_m_s),
            (48.1, 11.5, None, None)
        );
        assert_eq!(
            (b.lat_deg, b.acceptance_m, b.speed_m_s, b.item),
            (48.1001, Some(1.5), Some(2.5), 2)
        );
    }

    #[test]
    fn the_older_coordinate_format_is_read() {
        let old = r#"{"type": "SimpleItem", "command": 16, "coordinate": [47.5, 8.25, 10],
                      "param1": 0, "param2": 2, "param3": 0, "param4": 0}"#;
        let mission = parse_plan(&plan(old)).unwrap();
        let w = mission.waypoints[0];
        assert_eq!(
            (w.lat_deg, w.lon_deg, w.acceptance_m),
            (47.5, 8.25, Some(2.0))
        );
    }

    #[test]
    fn an_airborne_command_is_refused_naming_the_item() {
        let takeoff =
            r#"{"type": "SimpleItem", "command": 22, "params": [0,0,0,null,48.1,11.5,10]}"#;
        let items = [
            wp("48.1", "11.5", 0.0),
            wp("48.1", "11.5001", 0.0),
            wp("48.1", "11.5002", 0.0),
            takeoff.into(),
        ];
        let err = parse_plan(&plan(&items.join(","))).unwrap_err();
        assert_eq!(
            err.to_string(),
            "mission.items[3]: command 22 (TAKEOFF) is not supported by a ground vehicle"
        );
    }

    #[test]
    fn a_waypoint_without_a_finite_position_is_refused() {
        let err = parse_plan(&plan(&wp("null", "11.5", 0.0))).unwrap_err();
        assert_eq!(err.location, "mission.items[0]");
        assert!(err.message.contains("latitude"), "{err}");
        let no_lon = r#"{"type": "SimpleItem", "command": 16, "params": [0, 0, 0, 0, 48.1]}"#;
        let err = parse_plan(&plan(no_lon)).unwrap_err();
        assert!(err.to_string().contains("without a longitude"), "{err}");
        let err = parse_plan(&plan(&wp("91", "11.5", 0.0))).unwrap_err();
        assert!(err.message.contains("outside"), "{err}");
    }

    #[test]
    fn files_that_are_not_plans_or_hold_no_waypoint_are_refused() {
        assert_eq!(parse_plan("{").unwrap_err().location, "plan");
        let fence = r#"{"fileType": "GeoFence"}"#;
        assert_eq!(parse_plan(fence).unwrap_err().location, "fileType");
        assert!(parse_plan(&plan(""))
            .unwrap_err()
            .message
            .contains("no waypoint"));
        let survey = r#"{"type": "ComplexItem", "complexItemType": "survey"}"#;
        let err = parse_plan(&plan(survey)).unwrap_err();
        assert_eq!(err.location, "mission.items[0]");
    }
}
