//! Geometry on the Earth for the geofence: distances between latitude/longitude points, and
//! polygons on a local tangent plane.
//!
//! Distances are great-circle distances on a sphere of the Earth's mean radius (haversine):
//! within 0.5 % of the ellipsoid's, which is far below what a fence margin must allow for
//! anyway. A polygon is flattened once onto the plane tangent to the Earth at its first vertex
//! (east and north in metres, equirectangular: exact enough within the 50 km a polygon may
//! span, a few metres at most), and a point is tested there by its crossing number.

/// Mean radius of the Earth, m.
pub const EARTH_RADIUS_M: f64 = 6_371_008.8;

/// A point on the Earth, degrees (north and east positive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatLon {
    /// Latitude, degrees, -90..=90.
    pub lat_deg: f64,
    /// Longitude, degrees, -180..=180.
    pub lon_deg: f64,
}

impl LatLon {
    /// From degrees.
    pub const fn new(lat_deg: f64, lon_deg: f64) -> LatLon {
        LatLon { lat_deg, lon_deg }
    }

    /// From NAV-PVT's 1e-7 degrees.
    pub fn from_deg_e7(lat_deg_e7: i32, lon_deg_e7: i32) -> LatLon {
        LatLon::new(f64::from(lat_deg_e7) * 1e-7, f64::from(lon_deg_e7) * 1e-7)
    }

    /// Both coordinates finite and within their ranges.
    pub fn is_valid(&self) -> bool {
        self.lat_deg.is_finite()
            && self.lon_deg.is_finite()
            && (-90.0..=90.0).contains(&self.lat_deg)
            && (-180.0..=180.0).contains(&self.lon_deg)
    }
}

/// `deg` brought into -180..180 (a longitude difference across the antimeridian).
fn wrap_deg(deg: f64) -> f64 {
    (deg + 180.0).rem_euclid(360.0) - 180.0
}

/// Great-circle distance from `a` to `b`, m (haversine).
pub fn distance_m(a: LatLon, b: LatLon) -> f64 {
    let (p1, p2) = (a.lat_deg.to_radians(), b.lat_deg.to_radians());
    let dp = p2 - p1;
    let dl = wrap_deg(b.lon_deg - a.lon_deg).to_radians();
    let h = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
    2.0 * EARTH_RADIUS_M * h.sqrt().min(1.0).asin()
}

/// The plane tangent to the Earth at `origin`: east and north, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalPlane {
    origin: LatLon,
    cos_lat: f64,
}

impl LocalPlane {
    /// Tangent at `origin`.
    pub fn new(origin: LatLon) -> LocalPlane {
        LocalPlane {
            origin,
            cos_lat: origin.lat_deg.to_radians().cos(),
        }
    }

    /// `p` as `[east_m, north_m]` from the origin.
    pub fn to_local(&self, p: LatLon) -> [f64; 2] {
        let m_per_deg = EARTH_RADIUS_M * core::f64::consts::PI / 180.0;
        [
            wrap_deg(p.lon_deg - self.origin.lon_deg) * m_per_deg * self.cos_lat,
            (p.lat_deg - self.origin.lat_deg) * m_per_deg,
        ]
    }
}

/// Whether `point` lies inside the polygon `vertices` (any order, closed implicitly, on a
/// plane): an odd number of its edges cross the ray from `point` towards +x. A point exactly
/// on an edge may fall either side.
pub fn point_in_polygon(point: [f64; 2], vertices: &[[f64; 2]]) -> bool {
    let [x, y] = point;
    let mut inside = false;
    let mut j = vertices.len().wrapping_sub(1);
    for (i, &[xi, yi]) in vertices.iter().enumerate() {
        let [xj, yj] = vertices[j];
        if (yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// A polygon of latitude/longitude vertices, flattened onto the plane at its first vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    plane: LocalPlane,
    local: Vec<[f64; 2]>,
}

impl Polygon {
    /// From its vertices (at least three for an area; fewer contain nothing).
    pub fn new(vertices: &[LatLon]) -> Polygon {
        let plane = LocalPlane::new(vertices.first().copied().unwrap_or(LatLon::new(0.0, 0.0)));
        Polygon {
            plane,
            local: vertices.iter().map(|&v| plane.to_local(v)).collect(),
        }
    }

    /// Whether `p` is inside.
    pub fn contains(&self, p: LatLon) -> bool {
        self.local.len() >= 3 && point_in_polygon(self.plane.to_local(p), &self.local)
    }
}

/// A circle: every point within `radius_m` of `centre`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre.
    pub centre: LatLon,
    /// Radius, m.
    pub radius_m: f64,
}

impl Circle {
    /// Whether `p` is inside (or on the edge).
    pub fn contains(&self, p: LatLon) -> bool {
        distance_m(self.centre, p) <= self.radius_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One thousandth of a degree of latitude, m: 2 pi R / 360 000.
    const MILLIDEGREE_M: f64 = 111.195_080_2;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn distances_by_hand() {
        let o = LatLon::new(0.0, 0.0);
        assert!(close(
            distance_m(o, LatLon::new(0.001, 0.0)),
            MILLIDEGREE_M,
            1e-3
        ));
        // Along the equator a degree of longitude is a degree of latitude.
        assert!(close(
            distance_m(o, LatLon::new(0.0, 0.001)),
            MILLIDEGREE_M,
            1e-3
        ));
        // At 60° north it is half as long.
        let n60 = LatLon::new(60.0, 10.0);
        let d = distance_m(n60, LatLon::new(60.0, 10.001));
        assert!(close(d, MILLIDEGREE_M / 2.0, 1e-3), "{d}");
        // A quarter of the way round, pole to equator.
        let d = distance_m(LatLon::new(90.0, 0.0), o);
        assert!(
            close(d, EARTH_RADIUS_M * core::f64::consts::FRAC_PI_2, 1e-6),
            "{d}"
        );
        assert_eq!(distance_m(n60, n60), 0.0);
    }

    #[test]
    fn distances_computed_independently() {
        // Haversine in double precision, R = 6 371 008.8 m, written out separately.
        for (a, b, expected) in [
            (
                LatLon::new(48.137154, 11.576124),
                LatLon::new(48.139127, 11.580186),
                372.806_214_8,
            ),
            (
                LatLon::new(-33.8688, 151.2093),
                LatLon::new(-33.8650, 151.2150),
                674.912_897_2,
            ),
            // Across the antimeridian: 0.001° of longitude on the equator.
            (
                LatLon::new(0.0, 179.9995),
                LatLon::new(0.0, -179.9995),
                111.195_080_2,
            ),
        ] {
            let d = distance_m(a, b);
            assert!(close(d, expected, 1e-3), "{a:?} {b:?}: {d}");
            assert!(close(distance_m(b, a), expected, 1e-3));
        }
    }

    #[test]
    fn the_local_plane_is_east_and_north_in_metres() {
        let plane = LocalPlane::new(LatLon::new(60.0, 10.0));
        let [e, n] = plane.to_local(LatLon::new(60.001, 10.002));
        assert!(
            close(n, MILLIDEGREE_M, 1e-3) && close(e, MILLIDEGREE_M, 1e-3),
            "{e} {n}"
        );
        let [e, n] = plane.to_local(LatLon::new(59.999, 9.998));
        assert!(close(n, -MILLIDEGREE_M, 1e-3) && close(e, -MILLIDEGREE_M, 1e-3));
        // Across the antimeridian the short way.
        let plane = LocalPlane::new(LatLon::new(0.0, 179.9995));
        let [e, _] = plane.to_local(LatLon::new(0.0, -179.9995));
        assert!(close(e, MILLIDEGREE_M, 1e-3), "{e}");
    }

    #[test]
    fn points_in_a_concave_polygon_by_hand() {
        // An L: the unit square's right half and bottom half, the top-left quarter cut out.
        let l = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 2.0],
            [1.0, 2.0],
            [1.0, 1.0],
            [0.0, 1.0],
        ];
        for (p, inside) in [
            ([0.5, 0.5], true),
            ([1.5, 1.5], true),
            ([1.5, 0.5], true),
            ([0.5, 1.5], false),
            ([-0.5, 0.5], false),
            ([2.5, 0.5], false),
            ([1.5, 2.5], false),
            ([1.5, -0.1], false),
        ] {
            assert_eq!(point_in_polygon(p, &l), inside, "{p:?}");
            // The order of the vertices does not matter.
            let mut reversed = l;
            reversed.reverse();
            assert_eq!(point_in_polygon(p, &reversed), inside, "{p:?} reversed");
        }
    }

    #[test]
    fn a_field_polygon_in_latitude_and_longitude() {
        // A 222 m x 111 m field at 48° N: 0.003° of longitude is 223 m there.
        let field = Polygon::new(&[
            LatLon::new(48.0, 11.0),
            LatLon::new(48.0, 11.003),
            LatLon::new(48.001, 11.003),
            LatLon::new(48.001, 11.0),
        ]);
        assert!(field.contains(LatLon::new(48.0005, 11.0015)));
        assert!(field.contains(LatLon::new(48.00001, 11.00299)));
        assert!(!field.contains(LatLon::new(48.0011, 11.0015)));
        assert!(!field.contains(LatLon::new(48.0005, 11.0031)));
        assert!(!field.contains(LatLon::new(47.9999, 11.0015)));
        // Two vertices make no area.
        let line = Polygon::new(&[LatLon::new(48.0, 11.0), LatLon::new(48.001, 11.0)]);
        assert!(!line.contains(LatLon::new(48.0005, 11.0)));
    }

    #[test]
    fn circles_contain_what_is_within_their_radius() {
        let c = Circle {
            centre: LatLon::new(48.0, 11.0),
            radius_m: 100.0,
        };
        // 0.0009° north: 100.08 m, just outside; 0.00089°: 98.96 m, inside.
        assert!(!c.contains(LatLon::new(48.0009, 11.0)));
        assert!(c.contains(LatLon::new(48.00089, 11.0)));
        assert!(c.contains(c.centre));
    }

    #[test]
    fn coordinates_out_of_range_or_not_finite_are_not_valid() {
        assert!(LatLon::new(48.0, 11.0).is_valid());
        assert!(LatLon::new(-90.0, 180.0).is_valid());
        for bad in [
            LatLon::new(90.1, 0.0),
            LatLon::new(0.0, -180.1),
            LatLon::new(f64::NAN, 0.0),
            LatLon::new(0.0, f64::INFINITY),
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }
}
