//! The local metre grid on the screen: where a point in metres east/north of the map's origin
//! is drawn, zoom about the pointer, pan by dragging, which tiles a view needs, and the car
//! marker and heading arrow as screen geometry.

use eframe::egui::{Pos2, Rect, Vec2};

use super::mercator;
use crate::plots::{local_en_m, EARTH_RADIUS_M};

/// The closest zoom, metres per screen pixel.
pub const MIN_METRES_PER_PX: f64 = 0.005;
/// The farthest zoom, metres per screen pixel.
pub const MAX_METRES_PER_PX: f64 = 200.0;
/// The zoom a new map starts at, metres per screen pixel (a panel 800 px wide shows 80 m).
pub const DEFAULT_METRES_PER_PX: f64 = 0.1;
/// A view needing more tiles than this draws none (a far zoom with no fitting tiles).
pub const MAX_TILES_IN_VIEW: usize = 150;

/// Latitude and longitude, degrees, of the point `[east_m, north_m]` from `origin`: the
/// inverse of [`local_en_m`] (equirectangular around the origin's latitude).
pub fn local_to_lat_lon(origin: (f64, f64), en: [f64; 2]) -> (f64, f64) {
    let (lat0, lon0) = origin;
    let lat = lat0 + (en[1] / EARTH_RADIUS_M).to_degrees();
    let lon = lon0 + (en[0] / (EARTH_RADIUS_M * lat0.to_radians().cos())).to_degrees();
    (lat, (lon + 540.0).rem_euclid(360.0) - 180.0)
}

/// What part of the metre grid the panel shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapView {
    /// The point at the panel's centre, `[east_m, north_m]`.
    pub centre_m: [f64; 2],
    /// Metres per screen pixel.
    pub metres_per_px: f64,
}

impl Default for MapView {
    fn default() -> Self {
        MapView {
            centre_m: [0.0, 0.0],
            metres_per_px: DEFAULT_METRES_PER_PX,
        }
    }
}

impl MapView {
    /// Where `[east_m, north_m]` is drawn in `rect` (north up, east right).
    pub fn to_screen(&self, rect: Rect, en: [f64; 2]) -> Pos2 {
        let c = rect.center();
        Pos2::new(
            c.x + ((en[0] - self.centre_m[0]) / self.metres_per_px) as f32,
            c.y - ((en[1] - self.centre_m[1]) / self.metres_per_px) as f32,
        )
    }

    /// The point `[east_m, north_m]` drawn at `pos` in `rect`.
    pub fn to_local(&self, rect: Rect, pos: Pos2) -> [f64; 2] {
        let c = rect.center();
        [
            self.centre_m[0] + f64::from(pos.x - c.x) * self.metres_per_px,
            self.centre_m[1] - f64::from(pos.y - c.y) * self.metres_per_px,
        ]
    }

    /// Moves the map with a drag of `delta` pixels (the ground follows the pointer).
    pub fn pan(&mut self, delta: Vec2) {
        self.centre_m[0] -= f64::from(delta.x) * self.metres_per_px;
        self.centre_m[1] += f64::from(delta.y) * self.metres_per_px;
    }

    /// Zooms by `factor` (above 1: closer) keeping the ground under `pos` where it is; the
    /// zoom stays within [`MIN_METRES_PER_PX`] and [`MAX_METRES_PER_PX`].
    pub fn zoom_about(&mut self, rect: Rect, pos: Pos2, factor: f64) {
        if !(factor.is_finite() && factor > 0.0) {
            return;
        }
        let before = self.to_local(rect, pos);
        self.metres_per_px =
            (self.metres_per_px / factor).clamp(MIN_METRES_PER_PX, MAX_METRES_PER_PX);
        let after = self.to_local(rect, pos);
        self.centre_m[0] += before[0] - after[0];
        self.centre_m[1] += before[1] - after[1];
    }

    /// The south-west and north-east corners, `[east_m, north_m]`, of what `rect` shows.
    pub fn bounds(&self, rect: Rect) -> [[f64; 2]; 2] {
        let sw = self.to_local(rect, rect.left_bottom());
        let ne = self.to_local(rect, rect.right_top());
        [sw, ne]
    }
}

/// The tiles of one zoom covering a view: columns `x0..=x1`, rows `y0..=y1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileRange {
    /// The zoom.
    pub zoom: u8,
    /// The westernmost column.
    pub x0: u32,
    /// The easternmost column.
    pub x1: u32,
    /// The northernmost row.
    pub y0: u32,
    /// The southernmost row.
    pub y1: u32,
}

impl TileRange {
    /// Number of tiles.
    pub fn len(&self) -> usize {
        (self.x1 - self.x0 + 1) as usize * (self.y1 - self.y0 + 1) as usize
    }

    /// Whether the range holds no tile (never: a range has at least one).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The tiles, `(x, y)`, row by row from the north-west.
    pub fn tiles(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        (self.y0..=self.y1).flat_map(move |y| (self.x0..=self.x1).map(move |x| (x, y)))
    }
}

/// The tiles of `zoom` covering the local rectangle `bounds` (south-west and north-east
/// corners around `origin`), clamped to the world; `None` when more than
/// [`MAX_TILES_IN_VIEW`] would be needed. (Across the antimeridian the range stops at the
/// world's edge.)
pub fn tiles_in_view(origin: (f64, f64), bounds: [[f64; 2]; 2], zoom: u8) -> Option<TileRange> {
    let [sw, ne] = bounds;
    let (s, w) = local_to_lat_lon(origin, sw);
    let (n, e) = local_to_lat_lon(origin, ne);
    let (fx0, fy0) = mercator::tile_xy(n, w, zoom);
    let (fx1, fy1) = mercator::tile_xy(s, e, zoom);
    let last = mercator::tiles_per_side(zoom) - 1.0;
    let cell = |v: f64| v.floor().clamp(0.0, last) as u32;
    let range = TileRange {
        zoom,
        x0: cell(fx0.min(fx1)),
        x1: cell(fx0.max(fx1)),
        y0: cell(fy0.min(fy1)),
        y1: cell(fy0.max(fy1)),
    };
    (range.len() <= MAX_TILES_IN_VIEW).then_some(range)
}

/// The north-west and south-east corners of tile `x, y` of `zoom`, `[east_m, north_m]`
/// around `origin`.
pub fn tile_corners_m(origin: (f64, f64), zoom: u8, x: u32, y: u32) -> [[f64; 2]; 2] {
    let nw = mercator::lat_lon(f64::from(x), f64::from(y), zoom);
    let se = mercator::lat_lon(f64::from(x) + 1.0, f64::from(y) + 1.0, zoom);
    [local_en_m(origin, nw), local_en_m(origin, se)]
}

/// The screen direction of a compass heading (degrees clockwise from north; screen y down).
pub fn heading_direction(heading_deg: f64) -> Vec2 {
    let h = heading_deg.to_radians();
    Vec2::new(h.sin() as f32, -h.cos() as f32)
}

/// The car marker: a triangle `length_px` long centred on `at`, its tip along `heading_deg`,
/// half as wide as long. Corners: tip, rear left, rear right.
pub fn car_marker(at: Pos2, heading_deg: f64, length_px: f32) -> [Pos2; 3] {
    let forward = heading_direction(heading_deg);
    let right = Vec2::new(-forward.y, forward.x);
    let tip = at + forward * (length_px * 0.6);
    let rear = at - forward * (length_px * 0.4);
    let half_width = length_px * 0.25;
    [tip, rear - right * half_width, rear + right * half_width]
}

/// An arrow from `from`, `length_px` long along `heading_deg`: its tip and the two ends of its
/// head (each a quarter of the length back from the tip, at ±30°).
pub fn heading_arrow(from: Pos2, heading_deg: f64, length_px: f32) -> (Pos2, [Pos2; 2]) {
    let tip = from + heading_direction(heading_deg) * length_px;
    let head = length_px * 0.25;
    let wing = |turn: f64| tip - heading_direction(heading_deg + turn) * head;
    (tip, [wing(30.0), wing(-30.0)])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect() -> Rect {
        Rect::from_min_size(Pos2::new(100.0, 50.0), Vec2::new(800.0, 600.0))
    }

    fn near(a: Pos2, b: Pos2) -> bool {
        (a - b).length() < 1e-3
    }

    #[test]
    fn north_is_up_and_east_is_right() {
        let v = MapView {
            centre_m: [10.0, 20.0],
            metres_per_px: 0.5,
        };
        let r = rect();
        assert_eq!(v.to_screen(r, [10.0, 20.0]), r.center());
        assert_eq!(
            v.to_screen(r, [20.0, 20.0]),
            r.center() + Vec2::new(20.0, 0.0)
        );
        assert_eq!(
            v.to_screen(r, [10.0, 30.0]),
            r.center() + Vec2::new(0.0, -20.0)
        );
        let p = Pos2::new(123.0, 456.0);
        assert!(near(v.to_screen(r, v.to_local(r, p)), p));
        let [sw, ne] = v.bounds(r);
        assert_eq!((sw, ne), ([-190.0, -130.0], [210.0, 170.0]));
    }

    #[test]
    fn zoom_keeps_the_ground_under_the_pointer_and_pan_follows_the_drag() {
        let mut v = MapView::default();
        let r = rect();
        let pointer = Pos2::new(700.0, 120.0);
        let under = v.to_local(r, pointer);
        v.zoom_about(r, pointer, 2.0);
        assert!((v.metres_per_px - DEFAULT_METRES_PER_PX / 2.0).abs() < 1e-12);
        assert!(near(v.to_screen(r, under), pointer));
        v.zoom_about(r, pointer, 1e-9);
        assert_eq!(v.metres_per_px, MAX_METRES_PER_PX);
        v.zoom_about(r, pointer, 1e12);
        assert_eq!(v.metres_per_px, MIN_METRES_PER_PX);

        let mut v = MapView::default();
        let ground = v.to_local(r, Pos2::new(300.0, 300.0));
        v.pan(Vec2::new(40.0, -10.0));
        assert!(near(v.to_screen(r, ground), Pos2::new(340.0, 290.0)));
    }

    #[test]
    fn local_metres_round_trip_through_latitude_and_longitude() {
        let origin = (-34.0885, 18.4750);
        for en in [[0.0, 0.0], [120.0, -35.5], [-800.0, 950.0]] {
            let back = local_en_m(origin, local_to_lat_lon(origin, en));
            assert!((back[0] - en[0]).abs() < 1e-6 && (back[1] - en[1]).abs() < 1e-6);
        }
    }

    #[test]
    fn the_view_needs_the_tiles_around_it() {
        // The simulator's start point lies in tile (144525, 157503) at zoom 18 (see the
        // mercator vectors); a 100 m square around it spans the neighbouring tiles too
        // (a zoom-18 tile there is 0.597·cos(34.09°) · 256 = 126.6 m wide).
        let origin = (-34.0885, 18.4750);
        let r = tiles_in_view(origin, [[-50.0, -50.0], [50.0, 50.0]], 18).unwrap();
        assert_eq!(
            (r.x0, r.x1, r.y0, r.y1),
            (144_524, 144_525, 157_503, 157_503)
        );
        assert_eq!(r.len(), 2);
        assert_eq!(
            r.tiles().collect::<Vec<_>>(),
            [(144_524, 157_503), (144_525, 157_503)]
        );
        let small = tiles_in_view(origin, [[-1.0, -1.0], [1.0, 1.0]], 18).unwrap();
        assert_eq!(small.len(), 1);
        assert_eq!((small.x0, small.y0), (144_525, 157_503));
        // The whole world at zoom 1 is four tiles; too many tiles draw none.
        let world = tiles_in_view((0.0, 0.0), [[-3e7, -3e7], [3e7, 3e7]], 1).unwrap();
        assert_eq!((world.x0, world.x1, world.y0, world.y1), (0, 1, 0, 1));
        assert!(tiles_in_view(origin, [[-5e4, -5e4], [5e4, 5e4]], 18).is_none());
        // A tile's corners: it contains the origin, and is 126.6 m wide.
        let [nw, se] = tile_corners_m(origin, 18, 144_525, 157_503);
        assert!(nw[0] <= 0.0 && se[0] >= 0.0 && nw[1] >= 0.0 && se[1] <= 0.0);
        assert!((se[0] - nw[0] - 126.6).abs() < 0.5, "{nw:?} {se:?}");
    }

    #[test]
    fn the_car_points_along_its_heading() {
        let at = Pos2::new(200.0, 200.0);
        let [tip, left, right] = car_marker(at, 0.0, 20.0);
        assert!(near(tip, Pos2::new(200.0, 188.0)), "north is up: {tip:?}");
        assert!(near(left, Pos2::new(195.0, 208.0)) && near(right, Pos2::new(205.0, 208.0)));
        let [tip, left, right] = car_marker(at, 90.0, 20.0);
        assert!(near(tip, Pos2::new(212.0, 200.0)), "east is right: {tip:?}");
        assert!(near(left, Pos2::new(192.0, 195.0)) && near(right, Pos2::new(192.0, 205.0)));
        let [tip, ..] = car_marker(at, 225.0, 20.0);
        assert!(
            tip.x < at.x && tip.y > at.y,
            "south-west is down left: {tip:?}"
        );

        let (tip, [a, b]) = heading_arrow(at, 180.0, 40.0);
        assert!(near(tip, Pos2::new(200.0, 240.0)), "south is down: {tip:?}");
        assert!(a.y < tip.y && b.y < tip.y && (a.x - 200.0) * (b.x - 200.0) < 0.0);
    }
}
