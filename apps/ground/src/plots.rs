//! What the plots show: bounded time series that scroll, and the GNSS track in local metres.

use std::collections::VecDeque;

/// Mean Earth radius, m (spherical model: plenty for a track of a few hundred metres).
pub const EARTH_RADIUS_M: f64 = 6_371_008.8;

/// A time series that keeps the last `window_s` seconds (and at most `capacity` points).
#[derive(Debug, Clone)]
pub struct TimeSeries {
    points: VecDeque<[f64; 2]>,
    window_s: f64,
    capacity: usize,
}

impl TimeSeries {
    /// An empty series keeping `window_s` seconds, at most `capacity` points.
    pub fn new(window_s: f64, capacity: usize) -> TimeSeries {
        TimeSeries {
            points: VecDeque::new(),
            window_s,
            capacity: capacity.max(1),
        }
    }

    /// Appends a value at time `t_s`. A time earlier than the last point (a clock step) clears
    /// the series instead of drawing a line backwards. Non-finite values are skipped.
    pub fn push(&mut self, t_s: f64, value: f64) {
        if !t_s.is_finite() || !value.is_finite() {
            return;
        }
        if self.points.back().is_some_and(|p| t_s < p[0]) {
            self.points.clear();
        }
        self.points.push_back([t_s, value]);
        while self.points.len() > self.capacity
            || self
                .points
                .front()
                .is_some_and(|p| t_s - p[0] > self.window_s)
        {
            self.points.pop_front();
        }
    }

    /// The points, oldest first, as `[t_s, value]`.
    pub fn points(&self) -> Vec<[f64; 2]> {
        self.points.iter().copied().collect()
    }

    /// Number of points held.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether nothing is held.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The latest value.
    pub fn last(&self) -> Option<f64> {
        self.points.back().map(|p| p[1])
    }
}

/// GNSS positions in metres east and north of the first position received.
#[derive(Debug, Clone)]
pub struct Track {
    origin: Option<(f64, f64)>,
    points: VecDeque<[f64; 2]>,
    capacity: usize,
}

impl Track {
    /// An empty track keeping at most `capacity` points.
    pub fn new(capacity: usize) -> Track {
        Track {
            origin: None,
            points: VecDeque::new(),
            capacity: capacity.max(1),
        }
    }

    /// The origin, (latitude, longitude) in degrees, once a position was added.
    pub fn origin(&self) -> Option<(f64, f64)> {
        self.origin
    }

    /// Adds a position; returns its local `[east_m, north_m]`.
    pub fn push(&mut self, lat_deg: f64, lon_deg: f64) -> [f64; 2] {
        let (lat0, lon0) = *self.origin.get_or_insert((lat_deg, lon_deg));
        let p = local_en_m((lat0, lon0), (lat_deg, lon_deg));
        self.points.push_back(p);
        if self.points.len() > self.capacity {
            self.points.pop_front();
        }
        p
    }

    /// The positions, oldest first, as `[east_m, north_m]`.
    pub fn points(&self) -> Vec<[f64; 2]> {
        self.points.iter().copied().collect()
    }

    /// Forgets the positions and the origin.
    pub fn clear(&mut self) {
        self.origin = None;
        self.points.clear();
    }
}

/// `[east_m, north_m]` of `point` relative to `origin` (degrees), equirectangular around the
/// origin's latitude; longitude differences wrap across the antimeridian.
pub fn local_en_m(origin: (f64, f64), point: (f64, f64)) -> [f64; 2] {
    let (lat0, lon0) = origin;
    let (lat, lon) = point;
    let dlon = (lon - lon0 + 540.0).rem_euclid(360.0) - 180.0;
    let east = dlon.to_radians() * lat0.to_radians().cos() * EARTH_RADIUS_M;
    let north = (lat - lat0).to_radians() * EARTH_RADIUS_M;
    [east, north]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_scrolls_by_time_and_capacity() {
        let mut s = TimeSeries::new(10.0, 1_000);
        for k in 0..=30 {
            s.push(f64::from(k), f64::from(k) * 2.0);
        }
        let p = s.points();
        assert_eq!(p.first(), Some(&[20.0, 40.0]));
        assert_eq!(p.last(), Some(&[30.0, 60.0]));
        assert_eq!(s.len(), 11);
        let mut small = TimeSeries::new(100.0, 3);
        for k in 0..5 {
            small.push(f64::from(k), 0.0);
        }
        assert_eq!(small.points()[0][0], 2.0);
    }

    #[test]
    fn series_skips_nan_and_restarts_on_a_clock_step() {
        let mut s = TimeSeries::new(10.0, 100);
        s.push(1.0, f64::NAN);
        assert!(s.is_empty());
        s.push(5.0, 1.0);
        s.push(6.0, 2.0);
        s.push(2.0, 3.0);
        assert_eq!(s.points(), vec![[2.0, 3.0]]);
        assert_eq!(s.last(), Some(3.0));
    }

    #[test]
    fn local_metres_match_the_arc_length() {
        // 0.001° of latitude is 111.2 m on a 6371 km sphere; at 60° N a degree of longitude
        // is half as long as at the equator.
        let [e, n] = local_en_m((47.0, 8.0), (47.001, 8.0));
        assert!(e.abs() < 1e-9 && (n - 111.195).abs() < 0.01, "{e} {n}");
        let [e, n] = local_en_m((60.0, 10.0), (60.0, 10.001));
        assert!((e - 55.597).abs() < 0.01 && n.abs() < 1e-9, "{e} {n}");
        let [e, _] = local_en_m((0.0, 179.9999), (0.0, -179.9999));
        assert!((e - 22.239).abs() < 0.01, "across the antimeridian: {e}");
        let [e, n] = local_en_m((-33.9, 18.4), (-33.901, 18.399));
        assert!(e < 0.0 && n < 0.0, "south-west is negative: {e} {n}");
    }

    #[test]
    fn track_starts_at_its_first_position() {
        let mut t = Track::new(2);
        assert_eq!(t.push(47.0, 8.0), [0.0, 0.0]);
        t.push(47.0001, 8.0);
        t.push(47.0002, 8.0);
        let p = t.points();
        assert_eq!(p.len(), 2);
        assert!((p[1][1] - 22.239).abs() < 0.01, "{p:?}");
        assert_eq!(t.origin(), Some((47.0, 8.0)));
        t.clear();
        assert_eq!(t.origin(), None);
    }
}
