//! The geofence: inclusion areas (circles and polygons) and a largest distance from the point
//! where the robot was last revived. A fence is judged on each new valid GNSS fix; between
//! fixes the last judgement holds (a stale fix is `GnssStale`'s business: with a fence
//! configured, GNSS must stay fresh in MANUAL as well as in AUTO).
//!
//! - Inside: within at least one inclusion area (when any are given) and, with
//!   `max_distance_m`, no farther than that from the revive point;
//! - a revive needs a fresh fix inside the inclusion areas; the fix it was revived on is the
//!   revive point.

use crate::config::FenceConfig;
use crate::geo::{distance_m, Circle, LatLon, Polygon};

/// The fence, in the form the step checks a fix against.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Geofence {
    max_distance_m: Option<f64>,
    circles: Vec<Circle>,
    polygons: Vec<Polygon>,
}

impl Geofence {
    /// From the (validated) configuration.
    pub fn new(config: &FenceConfig) -> Geofence {
        Geofence {
            max_distance_m: config.max_distance_m,
            circles: config
                .circles
                .iter()
                .map(|c| Circle {
                    centre: LatLon::new(c.lat_deg, c.lon_deg),
                    radius_m: c.radius_m,
                })
                .collect(),
            polygons: config
                .polygons
                .iter()
                .map(|p| {
                    let vertices: Vec<LatLon> =
                        p.iter().map(|&[lat, lon]| LatLon::new(lat, lon)).collect();
                    Polygon::new(&vertices)
                })
                .collect(),
        }
    }

    /// Anything is configured: without a fence nothing is checked.
    pub fn is_configured(&self) -> bool {
        self.max_distance_m.is_some() || !self.circles.is_empty() || !self.polygons.is_empty()
    }

    /// Whether `p` is within an inclusion area (true when none are given).
    pub fn in_areas(&self, p: LatLon) -> bool {
        (self.circles.is_empty() && self.polygons.is_empty())
            || self.circles.iter().any(|c| c.contains(p))
            || self.polygons.iter().any(|poly| poly.contains(p))
    }

    /// Whether `p` is inside the fence for a robot revived at `revive_point` (none: not
    /// revived since start-up, and the distance is not judged).
    pub fn contains(&self, p: LatLon, revive_point: Option<LatLon>) -> bool {
        let near = match (self.max_distance_m, revive_point) {
            (Some(max), Some(home)) => distance_m(home, p) <= max,
            _ => true,
        };
        near && self.in_areas(p)
    }
}

/// What the step remembers about the fence: the newest fix's position, the revive point and
/// the last judgement.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FenceMonitor {
    /// Position of the newest valid fix.
    position: Option<LatLon>,
    /// Position at the last accepted revive.
    revive_point: Option<LatLon>,
    /// The newest valid fix was outside the fence.
    outside: bool,
}

impl FenceMonitor {
    /// A new valid fix at `p`: judges it; returns whether it is outside.
    pub fn on_fix(&mut self, p: LatLon, fence: &Geofence) -> bool {
        self.position = Some(p);
        self.outside = fence.is_configured() && !fence.contains(p, self.revive_point);
        self.outside
    }

    /// The robot was revived: the newest fix's position is the revive point, and the fence is
    /// judged from it.
    pub fn on_revive(&mut self, fence: &Geofence) {
        self.revive_point = self.position;
        self.outside = match self.position {
            Some(p) => fence.is_configured() && !fence.contains(p, self.revive_point),
            None => false,
        };
    }

    /// Whether the newest valid fix was outside the fence.
    pub fn is_outside(&self) -> bool {
        self.outside
    }

    /// Whether a revive at the newest fix's position would be outside the inclusion areas;
    /// `fresh`: that fix is within the GNSS timeout. Without a fresh fix a configured fence
    /// cannot be judged, and the revive is refused too.
    pub fn refuses_revive(&self, fence: &Geofence, fresh: bool) -> bool {
        if !fence.is_configured() {
            return false;
        }
        match self.position {
            Some(p) if fresh => !fence.in_areas(p),
            _ => true,
        }
    }

    /// The revive point, once revived.
    pub fn revive_point(&self) -> Option<LatLon> {
        self.revive_point
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::FenceCircle;

    fn fence(max_distance_m: Option<f64>) -> Geofence {
        Geofence::new(&FenceConfig {
            max_distance_m,
            circles: vec![FenceCircle {
                lat_deg: 48.0,
                lon_deg: 11.0,
                radius_m: 100.0,
            }],
            polygons: vec![vec![
                [48.01, 11.0],
                [48.01, 11.003],
                [48.011, 11.003],
                [48.011, 11.0],
            ]],
        })
    }

    #[test]
    fn no_fence_is_never_left() {
        let none = Geofence::new(&FenceConfig::default());
        assert!(!none.is_configured());
        let mut m = FenceMonitor::default();
        assert!(!m.on_fix(LatLon::new(-40.0, 170.0), &none));
        assert!(!m.refuses_revive(&none, false));
    }

    #[test]
    fn inside_any_area_is_inside_outside_all_is_outside() {
        let f = fence(None);
        let mut m = FenceMonitor::default();
        assert!(!m.on_fix(LatLon::new(48.0005, 11.0), &f), "in the circle");
        assert!(
            !m.on_fix(LatLon::new(48.0105, 11.0015), &f),
            "in the polygon"
        );
        assert!(m.on_fix(LatLon::new(48.005, 11.0), &f), "between them");
        assert!(m.is_outside());
        assert!(m.refuses_revive(&f, true));
    }

    #[test]
    fn the_distance_counts_from_the_revive_point() {
        let f = Geofence::new(&FenceConfig {
            max_distance_m: Some(50.0),
            ..FenceConfig::default()
        });
        let mut m = FenceMonitor::default();
        m.on_fix(LatLon::new(48.0, 11.0), &f);
        assert!(!m.refuses_revive(&f, true));
        m.on_revive(&f);
        assert_eq!(m.revive_point(), Some(LatLon::new(48.0, 11.0)));
        // 0.0004° north: 44.5 m; 0.0005°: 55.6 m.
        assert!(!m.on_fix(LatLon::new(48.0004, 11.0), &f));
        assert!(m.on_fix(LatLon::new(48.0005, 11.0), &f));
        // A revive out there makes it the new revive point.
        assert!(!m.refuses_revive(&f, true));
        m.on_revive(&f);
        assert!(!m.is_outside());
        assert!(!m.on_fix(LatLon::new(48.0009, 11.0), &f));
    }

    #[test]
    fn without_a_fresh_fix_a_fence_refuses_a_revive() {
        let f = fence(Some(50.0));
        let mut m = FenceMonitor::default();
        assert!(m.refuses_revive(&f, true), "no fix yet");
        m.on_fix(LatLon::new(48.0, 11.0), &f);
        assert!(m.refuses_revive(&f, false), "the fix is stale");
        assert!(!m.refuses_revive(&f, true));
    }
}
