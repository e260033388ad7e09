//! Web Mercator as slippy-map tiles use it: latitude/longitude ↔ tile coordinates at a zoom,
//! and the zoom whose tile pixels are closest to the screen's.

/// Side of a tile, pixels.
pub const TILE_PX: f64 = 256.0;
/// The highest tile zoom considered (OpenStreetMap serves up to 19).
pub const MAX_ZOOM: u8 = 19;
/// The northern (and, negated, southern) limit of the square Web Mercator world, degrees.
pub const MAX_LAT_DEG: f64 = 85.051_128_779_806_6;
/// Earth's equatorial circumference on the Web Mercator sphere (radius 6 378 137 m), m.
pub const EQUATOR_M: f64 = 40_075_016.685_578_49;

/// Number of tiles along one side of the world at `zoom`.
pub fn tiles_per_side(zoom: u8) -> f64 {
    f64::from(1u32 << zoom.min(30))
}

/// Fractional tile coordinates `(x, y)` of a position at `zoom`: the integer parts name the
/// tile, x grows east from the antimeridian, y grows south from [`MAX_LAT_DEG`]. Latitudes are
/// clamped to the Mercator square.
pub fn tile_xy(lat_deg: f64, lon_deg: f64, zoom: u8) -> (f64, f64) {
    let n = tiles_per_side(zoom);
    let lat = lat_deg.clamp(-MAX_LAT_DEG, MAX_LAT_DEG).to_radians();
    let x = (lon_deg + 180.0) / 360.0 * n;
    let y = (1.0 - lat.tan().asinh() / std::f64::consts::PI) / 2.0 * n;
    (x, y)
}

/// Latitude and longitude, degrees, of the fractional tile coordinates `(x, y)` at `zoom`
/// (for whole numbers: the north-west corner of tile `x, y`).
pub fn lat_lon(x: f64, y: f64, zoom: u8) -> (f64, f64) {
    let n = tiles_per_side(zoom);
    let lon = x / n * 360.0 - 180.0;
    let lat = (std::f64::consts::PI * (1.0 - 2.0 * y / n))
        .sinh()
        .atan()
        .to_degrees();
    (lat, lon)
}

/// Ground metres per tile pixel at `zoom` and latitude `lat_deg`.
pub fn metres_per_tile_px(lat_deg: f64, zoom: u8) -> f64 {
    EQUATOR_M * lat_deg.to_radians().cos() / (TILE_PX * tiles_per_side(zoom))
}

/// The tile zoom (0 to `max_zoom`) whose pixels are closest in size to a view of
/// `metres_per_screen_px` at latitude `lat_deg`: tiles are drawn neither much blurred nor
/// much shrunk.
pub fn zoom_for(metres_per_screen_px: f64, lat_deg: f64, max_zoom: u8) -> u8 {
    if !(metres_per_screen_px.is_finite() && metres_per_screen_px > 0.0) {
        return 0;
    }
    let at_zero = metres_per_tile_px(lat_deg, 0);
    let z = (at_zero / metres_per_screen_px).log2().round();
    z.clamp(0.0, f64::from(max_zoom)) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    // Expected values computed independently (Python, the OpenStreetMap wiki's formulas:
    // x = (lon + 180) / 360 · 2^z, y = (1 − asinh(tan φ) / π) / 2 · 2^z, and the inverse
    // φ = atan(sinh(π (1 − 2 y / 2^z)))).
    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn tile_zero_covers_the_world() {
        assert_eq!(tile_xy(0.0, 0.0, 0), (0.5, 0.5));
        let (lat, lon) = lat_lon(0.0, 0.0, 0);
        assert!(close(lat, 85.051_128_779_806_6, 1e-9) && lon == -180.0);
        let (lat, lon) = lat_lon(1.0, 1.0, 0);
        assert!(close(lat, -85.051_128_779_806_6, 1e-9) && lon == 180.0);
        assert_eq!(lat_lon(1.0, 1.0, 1), (0.0, 0.0));
        let (x, y) = tile_xy(89.9, -180.0, 0);
        assert!(
            x == 0.0 && close(y, 0.0, 1e-12),
            "clamped to the square: {y}"
        );
    }

    #[test]
    fn positions_fall_in_the_expected_tiles() {
        let vectors = [
            // (lat, lon, zoom, x, y)
            (
                -34.0885,
                18.4750,
                18,
                144_525.084_444_444_45,
                157_503.506_456_791_6,
            ),
            (
                -34.0885,
                18.4750,
                17,
                72_262.542_222_222_23,
                78_751.753_228_395_8,
            ),
            (
                47.3769,
                8.5417,
                16,
                34_322.969_031_111_11,
                22_949.767_365_290_496,
            ),
        ];
        for (lat, lon, z, ex, ey) in vectors {
            let (x, y) = tile_xy(lat, lon, z);
            assert!(close(x, ex, 1e-6) && close(y, ey, 1e-6), "{z}: {x} {y}");
        }
    }

    #[test]
    fn tile_corners_match_known_values() {
        let vectors = [
            (
                34_322.0,
                22_950.0,
                16,
                47.376_034_633_497_58,
                8.536_376_953_125,
            ),
            (
                148_953.0,
                159_164.0,
                18,
                -35.955_776_540_565_31,
                24.555_816_650_390_625,
            ),
        ];
        for (x, y, z, elat, elon) in vectors {
            let (lat, lon) = lat_lon(x, y, z);
            assert!(
                close(lat, elat, 1e-9) && close(lon, elon, 1e-9),
                "{lat} {lon}"
            );
            let (bx, by) = tile_xy(lat, lon, z);
            assert!(
                close(bx, x, 1e-6) && close(by, y, 1e-6),
                "round trip {bx} {by}"
            );
        }
    }

    #[test]
    fn the_zoom_matches_tile_pixels_to_screen_pixels() {
        // At the equator a zoom-0 pixel is 156 543 m; zoom 18 is 0.597 m.
        assert!(close(metres_per_tile_px(0.0, 18), 0.597_164, 1e-6));
        assert_eq!(zoom_for(0.6, 0.0, MAX_ZOOM), 18);
        assert_eq!(zoom_for(1.2, 0.0, MAX_ZOOM), 17);
        // At 60° a pixel of the same zoom covers half the ground.
        assert_eq!(zoom_for(0.3, 60.0, MAX_ZOOM), 18);
        assert_eq!(zoom_for(0.001, 0.0, MAX_ZOOM), MAX_ZOOM);
        assert_eq!(zoom_for(1e9, 0.0, MAX_ZOOM), 0);
        assert_eq!(zoom_for(f64::NAN, 0.0, MAX_ZOOM), 0);
    }
}
