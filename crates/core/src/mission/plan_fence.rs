//! A plan file's `geoFence` as the robot's fence ([`FenceConfig`]).
//!
//! QGroundControl writes (fence version 2) `geoFence: {circles: [...], polygons: [...]}`, each
//! circle `{circle: {center: [lat, lon], radius: m}, inclusion: bool}` and each polygon
//! `{polygon: [[lat, lon], ...], inclusion: bool}`; files of fence version 1 hold one
//! inclusion `polygon` directly (and a `breachReturn` point, which a car has no use for). The
//! robot's fence holds inclusion areas only: an exclusion area is an error naming it, never
//! dropped in silence (the car would drive into it).

use serde_json::Value;

use super::PlanError;
use crate::config::{FenceCircle, FenceConfig};

/// A `[lat, lon]` pair, or the error naming `at`.
fn lat_lon(value: Option<&Value>, at: &str) -> Result<[f64; 2], PlanError> {
    let pair = value
        .and_then(Value::as_array)
        .filter(|a| a.len() >= 2)
        .ok_or_else(|| PlanError::new(at, "expected [latitude, longitude]"))?;
    match (pair[0].as_f64(), pair[1].as_f64()) {
        (Some(lat), Some(lon)) => Ok([lat, lon]),
        _ => Err(PlanError::new(
            at,
            format!(
                "expected [latitude, longitude] numbers, found {}",
                Value::Array(pair.clone())
            ),
        )),
    }
}

/// Refuses an exclusion area (`inclusion: false`); an area without the key is an inclusion
/// (fence version 1).
fn inclusion_only(area: &Value, at: &str) -> Result<(), PlanError> {
    match area.get("inclusion") {
        None | Some(Value::Bool(true)) => Ok(()),
        Some(Value::Bool(false)) => Err(PlanError::new(
            at,
            "exclusion areas are not supported: the robot's fence is the inclusion areas \
             (plan the areas to keep out of as the outside of an inclusion polygon)",
        )),
        Some(other) => Err(PlanError::new(
            at,
            format!("inclusion is not true or false: {other}"),
        )),
    }
}

/// The vertices of a polygon array, or the error naming `at`.
fn vertices(polygon: Option<&Value>, at: &str) -> Result<Vec<[f64; 2]>, PlanError> {
    let points = polygon
        .and_then(Value::as_array)
        .ok_or_else(|| PlanError::new(at, "missing or not an array of [latitude, longitude]"))?;
    points
        .iter()
        .enumerate()
        .map(|(j, p)| lat_lon(Some(p), &format!("{at}[{j}]")))
        .collect()
}

/// The fence of a plan's root object (empty without `geoFence`), bounds checked as
/// `[navigation.fence]` is.
pub(super) fn parse_geofence(root: &Value) -> Result<FenceConfig, PlanError> {
    let mut fence = FenceConfig::default();
    let Some(geofence) = root.get("geoFence") else {
        return Ok(fence);
    };
    if !geofence.is_object() {
        return Err(PlanError::new("geoFence", "not an object"));
    }
    if let Some(polygon) = geofence.get("polygon") {
        let polygon = vertices(Some(polygon), "geoFence.polygon")?;
        if !polygon.is_empty() {
            fence.polygons.push(polygon);
        }
    }
    let list = |key: &str| -> Result<Vec<Value>, PlanError> {
        match geofence.get(key) {
            None => Ok(Vec::new()),
            Some(Value::Array(items)) => Ok(items.clone()),
            Some(_) => Err(PlanError::new(format!("geoFence.{key}"), "not an array")),
        }
    };
    for (i, area) in list("circles")?.iter().enumerate() {
        let at = format!("geoFence.circles[{i}]");
        inclusion_only(area, &at)?;
        let circle = area
            .get("circle")
            .ok_or_else(|| PlanError::new(&at, "missing circle"))?;
        let [lat_deg, lon_deg] = lat_lon(circle.get("center"), &format!("{at}.circle.center"))?;
        let radius_m = circle
            .get("radius")
            .and_then(Value::as_f64)
            .ok_or_else(|| {
                PlanError::new(format!("{at}.circle.radius"), "missing or not a number")
            })?;
        fence.circles.push(FenceCircle {
            lat_deg,
            lon_deg,
            radius_m,
        });
    }
    for (i, area) in list("polygons")?.iter().enumerate() {
        let at = format!("geoFence.polygons[{i}]");
        inclusion_only(area, &at)?;
        fence
            .polygons
            .push(vertices(area.get("polygon"), &format!("{at}.polygon"))?);
    }
    fence.validate_at("geoFence").map_err(|e| {
        let message = e.to_string();
        PlanError::new("geoFence", message)
    })?;
    Ok(fence)
}

#[cfg(test)]
mod tests {
    use crate::mission::{parse_plan_file, PlanError};

    /// A one-waypoint plan with `geofence` as its `geoFence` object.
    fn plan(geofence: &str) -> String {
        format!(
            r#"{{"fileType": "Plan", "version": 1, "geoFence": {geofence},
                "mission": {{"items": [{{"type": "SimpleItem", "command": 16,
                             "params": [0, 0, 0, null, 48.1, 11.5, 0]}}]}}}}"#
        )
    }

    fn error(geofence: &str) -> PlanError {
        parse_plan_file(&plan(geofence)).unwrap_err()
    }

    #[test]
    fn inclusion_circles_and_polygons_become_the_fence() {
        let p = parse_plan_file(&plan(
            r#"{"version": 2,
                "circles": [{"circle": {"center": [48.1, 11.5], "radius": 75.5},
                             "inclusion": true, "version": 1}],
                "polygons": [{"inclusion": true, "version": 1,
                              "polygon": [[48.0, 11.0], [48.0, 11.01], [48.01, 11.01]]}]}"#,
        ))
        .unwrap();
        assert_eq!(p.fence.max_distance_m, None);
        assert_eq!(p.fence.circles.len(), 1);
        let c = &p.fence.circles[0];
        assert_eq!((c.lat_deg, c.lon_deg, c.radius_m), (48.1, 11.5, 75.5));
        assert_eq!(
            p.fence.polygons,
            vec![vec![[48.0, 11.0], [48.0, 11.01], [48.01, 11.01]]]
        );
        assert_eq!(p.mission.waypoints.len(), 1);
    }

    #[test]
    fn an_empty_or_missing_geofence_is_no_fence() {
        let empty = parse_plan_file(&plan(r#"{"circles": [], "polygons": [], "version": 2}"#));
        assert_eq!(empty.unwrap().fence, Default::default());
        let text = plan("{}").replace(r#""geoFence": {},"#, "");
        assert!(!text.contains("geoFence"));
        assert_eq!(parse_plan_file(&text).unwrap().fence, Default::default());
    }

    #[test]
    fn a_version_1_fence_is_one_inclusion_polygon() {
        let p = parse_plan_file(&plan(
            r#"{"version": 1, "breachReturn": [48.1, 11.5],
                "polygon": [[48.0, 11.0], [48.0, 11.01], [48.01, 11.01], [48.01, 11.0]]}"#,
        ))
        .unwrap();
        assert_eq!(p.fence.polygons.len(), 1);
        assert_eq!(p.fence.polygons[0].len(), 4);
    }

    #[test]
    fn an_exclusion_area_is_refused_by_name_never_dropped() {
        let e = error(
            r#"{"polygons": [
                {"inclusion": true, "polygon": [[48.0, 11.0], [48.0, 11.01], [48.01, 11.01]]},
                {"inclusion": false, "polygon": [[48.0, 11.0], [48.0, 11.001], [48.001, 11.0]]}]}"#,
        );
        assert_eq!(e.location, "geoFence.polygons[1]");
        assert!(
            e.message.contains("exclusion areas are not supported"),
            "{e}"
        );
        let e = error(
            r#"{"circles": [{"circle": {"center": [48.1, 11.5], "radius": 5}, "inclusion": false}]}"#,
        );
        assert_eq!(e.location, "geoFence.circles[0]");
    }

    #[test]
    fn bad_areas_name_what_is_wrong() {
        let e = error(r#"{"circles": [{"circle": {"center": [48.1], "radius": 5}}]}"#);
        assert_eq!(e.location, "geoFence.circles[0].circle.center");
        let e = error(r#"{"circles": [{"circle": {"center": [48.1, 11.5]}}]}"#);
        assert_eq!(e.location, "geoFence.circles[0].circle.radius");
        let e = error(r#"{"polygons": [{"polygon": [[48.0, 11.0], [48.0, "x"]]}]}"#);
        assert_eq!(e.location, "geoFence.polygons[0].polygon[1]");
        // Bounds as `[navigation.fence]`'s: a latitude out of range, two vertices, a radius
        // below a metre, a polygon spanning more than 50 km.
        for (fence, key) in [
            (
                r#"{"polygons": [{"polygon": [[48.0, 11.0], [95.0, 11.0], [48.0, 11.1]]}]}"#,
                "geoFence.polygons[0][1]",
            ),
            (
                r#"{"polygons": [{"polygon": [[48.0, 11.0], [48.1, 11.0]]}]}"#,
                "geoFence.polygons[0] vertices",
            ),
            (
                r#"{"circles": [{"circle": {"center": [48.1, 11.5], "radius": 0.5}}]}"#,
                "geoFence.circles[0].radius_m",
            ),
            (
                r#"{"polygons": [{"polygon": [[48.0, 11.0], [48.0, 12.0], [48.1, 11.0]]}]}"#,
                "geoFence.polygons[0][1]",
            ),
        ] {
            let e = error(fence);
            assert_eq!(e.location, "geoFence", "{fence}");
            assert!(e.message.contains(key), "{fence}: {e}");
        }
        assert_eq!(error("[]").location, "geoFence");
        assert_eq!(error(r#"{"circles": 3}"#).location, "geoFence.circles");
    }
}
