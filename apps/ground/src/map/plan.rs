//! The mission and the fence on the map: a QGroundControl plan given with `--plan` (its
//! waypoints and its `geoFence`), or in a replay the mission and fence the robot's log says it
//! ran with, as lines in the map's metres.

use std::path::Path;

use anyhow::Context;
use dima_core::mission::{parse_plan_file, Navigation};

use crate::plots::local_en_m;

/// Points on a circle's outline.
const CIRCLE_POINTS: usize = 72;

/// Where the overlay came from, for the panel's note.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PlanSource {
    /// A plan file (`--plan`).
    File(String),
    /// The robot's log (replay).
    RobotLog,
}

/// The mission's waypoints and the fence's inclusion areas, in latitude and longitude.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOverlay {
    /// Where it came from.
    pub source: PlanSource,
    /// The waypoints in order, (latitude, longitude) degrees.
    pub waypoints: Vec<(f64, f64)>,
    /// Inclusion circles: centre (latitude, longitude) and radius, m.
    pub circles: Vec<((f64, f64), f64)>,
    /// Inclusion polygons, (latitude, longitude) vertices.
    pub polygons: Vec<Vec<(f64, f64)>>,
}

/// An overlay in the map's metres east and north of its origin.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OverlayInMetres {
    /// The mission's legs as one line through the waypoints.
    pub waypoints: Vec<[f64; 2]>,
    /// Each inclusion area as a closed outline (first point repeated last).
    pub areas: Vec<Vec<[f64; 2]>>,
}

impl PlanOverlay {
    /// The mission and the fence of `navigation`.
    pub fn of(navigation: &Navigation, source: PlanSource) -> PlanOverlay {
        PlanOverlay {
            source,
            waypoints: navigation
                .mission
                .iter()
                .flat_map(|m| &m.waypoints)
                .map(|w| (w.lat_deg, w.lon_deg))
                .collect(),
            circles: navigation
                .fence
                .circles
                .iter()
                .map(|c| ((c.lat_deg, c.lon_deg), c.radius_m))
                .collect(),
            polygons: navigation
                .fence
                .polygons
                .iter()
                .map(|p| p.iter().map(|&[lat, lon]| (lat, lon)).collect())
                .collect(),
        }
    }

    /// Reads a plan file as the robot would (the same parser, the same errors naming the
    /// item; a waypoint outside the plan's own fence is refused).
    pub fn load(path: &Path) -> anyhow::Result<PlanOverlay> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("--plan {}: cannot be read", path.display()))?;
        let plan = parse_plan_file(&text).with_context(|| format!("--plan {}", path.display()))?;
        let navigation = Navigation::with_plan(&Default::default(), plan)
            .with_context(|| format!("--plan {}", path.display()))?;
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        Ok(PlanOverlay::of(&navigation, PlanSource::File(name)))
    }

    /// In metres east and north of `origin`.
    pub fn in_metres(&self, origin: (f64, f64)) -> OverlayInMetres {
        let circles = self.circles.iter().map(|&(centre, radius_m)| {
            let [e, n] = local_en_m(origin, centre);
            (0..=CIRCLE_POINTS)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / CIRCLE_POINTS as f64;
                    [e + radius_m * a.sin(), n + radius_m * a.cos()]
                })
                .collect()
        });
        let polygons = self.polygons.iter().map(|p| {
            let mut outline: Vec<[f64; 2]> = p.iter().map(|&v| local_en_m(origin, v)).collect();
            outline.extend(outline.first().copied());
            outline
        });
        OverlayInMetres {
            waypoints: self
                .waypoints
                .iter()
                .map(|&w| local_en_m(origin, w))
                .collect(),
            areas: circles.chain(polygons).collect(),
        }
    }

    /// One line for the panel: what is shown and where it came from.
    pub fn note(&self) -> String {
        let from = match &self.source {
            PlanSource::File(name) => format!("plan {name}"),
            PlanSource::RobotLog => "the robot's log".to_owned(),
        };
        let areas = self.circles.len() + self.polygons.len();
        format!(
            "{from}: {} waypoint{}, fence of {areas} area{}",
            self.waypoints.len(),
            if self.waypoints.len() == 1 { "" } else { "s" },
            if areas == 1 { "" } else { "s" },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../crates/core/tests/fixtures/square-40m-fenced.plan"
    );

    fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
        (a[0] - b[0]).hypot(a[1] - b[1])
    }

    #[test]
    fn a_plan_file_shows_its_square_and_its_fence_around_the_first_waypoint() {
        let overlay = PlanOverlay::load(Path::new(SQUARE)).unwrap();
        assert_eq!(
            overlay.note(),
            "plan square-40m-fenced.plan: 5 waypoints, fence of 1 area"
        );
        let m = overlay.in_metres(overlay.waypoints[0]);
        assert_eq!(m.waypoints.len(), 5);
        assert!(distance(m.waypoints[0], [0.0, 0.0]) < 1e-9);
        // North 40 m, then east 40 m (within the sphere-versus-ellipsoid 0.5 %).
        let [e, n] = m.waypoints[1];
        assert!(e.abs() < 0.01 && (n - 40.0).abs() < 0.2, "{e} {n}");
        let [e, n] = m.waypoints[2];
        assert!((e - 40.0).abs() < 0.2 && (n - 40.0).abs() < 0.2, "{e} {n}");
        // The fence polygon, closed, 10 m outside the square's south-west corner.
        assert_eq!(m.areas.len(), 1);
        let outline = &m.areas[0];
        assert_eq!((outline.len(), outline.first()), (5, outline.last()));
        assert!(
            (outline[0][0] + 9.7).abs() < 0.3 && (outline[0][1] + 10.0).abs() < 0.3,
            "{outline:?}"
        );
    }

    #[test]
    fn a_circle_is_an_outline_of_its_radius_around_its_centre() {
        let overlay = PlanOverlay {
            source: PlanSource::RobotLog,
            waypoints: Vec::new(),
            circles: vec![((48.1, 11.5), 30.0)],
            polygons: Vec::new(),
        };
        // From an origin 0.001° of latitude (111.2 m) south of the centre.
        let m = overlay.in_metres((48.099, 11.5));
        let outline = &m.areas[0];
        assert_eq!(outline.len(), CIRCLE_POINTS + 1);
        for p in outline {
            assert!((distance(*p, [0.0, 111.195]) - 30.0).abs() < 0.01, "{p:?}");
        }
        assert_eq!(
            overlay.note(),
            "the robot's log: 0 waypoints, fence of 1 area"
        );
    }

    #[test]
    fn a_bad_plan_names_the_file_and_the_item() {
        let dir = std::env::temp_dir().join(format!("dima-ground-plan-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bad = dir.join("takeoff.plan");
        std::fs::write(
            &bad,
            r#"{"fileType": "Plan", "mission": {"items": [
                {"type": "SimpleItem", "command": 22, "params": [0, 0, 0, null, 48, 11, 10]}]}}"#,
        )
        .unwrap();
        let e = format!("{:#}", PlanOverlay::load(&bad).unwrap_err());
        assert!(
            e.contains("takeoff.plan: mission.items[0]: command 22 (TAKEOFF)"),
            "{e}"
        );
        let e = format!(
            "{:#}",
            PlanOverlay::load(&dir.join("none.plan")).unwrap_err()
        );
        assert!(e.contains("none.plan: cannot be read"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
