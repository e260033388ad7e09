//! A local flat frame in metres (north, east) around an origin: close enough for a car's
//! mission (the error of the tangent-plane approximation is millimetres over a few hundred
//! metres).

/// A point in the local frame, metres north and east of the origin.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LocalPoint {
    /// Metres north of the origin.
    pub north_m: f64,
    /// Metres east of the origin.
    pub east_m: f64,
}

impl LocalPoint {
    /// Distance to `other`, m.
    pub fn distance_to(self, other: LocalPoint) -> f64 {
        (other.north_m - self.north_m).hypot(other.east_m - self.east_m)
    }

    /// Bearing to `other`, degrees clockwise from north, `0..360`.
    pub fn bearing_to(self, other: LocalPoint) -> f64 {
        (other.east_m - self.east_m)
            .atan2(other.north_m - self.north_m)
            .to_degrees()
            .rem_euclid(360.0)
    }
}

/// WGS84 semi-major axis, m.
const WGS84_A_M: f64 = 6_378_137.0;
/// WGS84 first eccentricity squared.
const WGS84_E2: f64 = 6.694_379_990_14e-3;

/// The tangent plane at an origin: metres per degree of latitude and of longitude there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFrame {
    origin_lat_deg: f64,
    origin_lon_deg: f64,
    m_per_deg_lat: f64,
    m_per_deg_lon: f64,
}

impl LocalFrame {
    /// The frame around (`lat_deg`, `lon_deg`), with WGS84's meridian and prime-vertical radii
    /// of curvature at that latitude.
    pub fn new(lat_deg: f64, lon_deg: f64) -> LocalFrame {
        let sin = lat_deg.to_radians().sin();
        let w = 1.0 - WGS84_E2 * sin * sin;
        let meridian_m = WGS84_A_M * (1.0 - WGS84_E2) / (w * w.sqrt());
        let prime_vertical_m = WGS84_A_M / w.sqrt();
        LocalFrame {
            origin_lat_deg: lat_deg,
            origin_lon_deg: lon_deg,
            m_per_deg_lat: meridian_m.to_radians(),
            m_per_deg_lon: (prime_vertical_m * lat_deg.to_radians().cos()).to_radians(),
        }
    }

    /// A latitude and longitude (degrees) in the frame.
    pub fn to_local(&self, lat_deg: f64, lon_deg: f64) -> LocalPoint {
        LocalPoint {
            north_m: (lat_deg - self.origin_lat_deg) * self.m_per_deg_lat,
            east_m: (lon_deg - self.origin_lon_deg) * self.m_per_deg_lon,
        }
    }

    /// A point of the frame as latitude and longitude, degrees.
    pub fn to_geodetic(&self, point: LocalPoint) -> (f64, f64) {
        (
            self.origin_lat_deg + point.north_m / self.m_per_deg_lat,
            self.origin_lon_deg + point.east_m / self.m_per_deg_lon,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_degree_of_latitude_is_about_111_km_and_longitude_shrinks_with_latitude() {
        let frame = LocalFrame::new(48.0, 11.0);
        let p = frame.to_local(49.0, 12.0);
        // WGS84 at 48 degrees: 111.2 km per degree of latitude, 74.6 km of longitude.
        assert!((p.north_m - 111_200.0).abs() < 300.0, "{p:?}");
        assert!((p.east_m - 74_600.0).abs() < 300.0, "{p:?}");
        let back = frame.to_geodetic(LocalPoint {
            north_m: 40.0,
            east_m: -40.0,
        });
        let again = frame.to_local(back.0, back.1);
        assert!((again.north_m - 40.0).abs() < 1e-9 && (again.east_m + 40.0).abs() < 1e-9);
    }

    #[test]
    fn bearings_are_clockwise_from_north() {
        let o = LocalPoint::default();
        let at = |n, e| LocalPoint {
            north_m: n,
            east_m: e,
        };
        assert_eq!(o.bearing_to(at(1.0, 0.0)), 0.0);
        assert_eq!(o.bearing_to(at(0.0, 1.0)), 90.0);
        assert_eq!(o.bearing_to(at(-1.0, 0.0)), 180.0);
        assert_eq!(o.bearing_to(at(0.0, -1.0)), 270.0);
        assert_eq!(o.distance_to(at(3.0, 4.0)), 5.0);
    }
}
