//! What the plots show: bounded time series that scroll, and the GNSS track in local metres;
//! and the pure drawing math: lines broken where frames are missing, the heading of motion
//! unwrapped across north and drawn only while the car moves, and a floor on the track's
//! scale.

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

/// Below this ground speed, m/s, the heading of motion is not drawn: standing or creeping,
/// the receiver's heading of motion is the direction of a velocity that is mostly error.
pub const HEADING_MIN_SPEED_M_S: f64 = 0.5;

/// Points further apart than this, s, are not joined: the frames between them are missing
/// (display frames come every 0.5 s at the default 2 Hz, so this is three lost frames).
pub const MAX_GAP_S: f64 = 2.0;

/// The track plot spans at least this many metres, so a receiver's position noise while
/// standing (a metre or two) does not look like driving.
pub const TRACK_MIN_SPAN_M: f64 = 10.0;

/// `points` (`[t_s, value]`, oldest first) split into lines wherever two neighbours are more
/// than `max_gap_s` apart.
pub fn split_at_gaps(points: &[[f64; 2]], max_gap_s: f64) -> Vec<Vec<[f64; 2]>> {
    let mut lines: Vec<Vec<[f64; 2]>> = Vec::new();
    for &p in points {
        match lines.last_mut() {
            Some(line) if line.last().is_some_and(|q| p[0] - q[0] <= max_gap_s) => line.push(p),
            _ => lines.push(vec![p]),
        }
    }
    lines
}

/// `line` (`[t_s, degrees]`) made continuous: each value moved by a multiple of 360° to within
/// 180° of the one before, so 359° -> 1° is a step of 2°, not a bar across the plot.
pub fn unwrap_degrees(line: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = Vec::with_capacity(line.len());
    for &[t, deg] in line {
        let v = match out.last() {
            None => deg,
            Some(&[_, prev]) => prev + (deg - prev + 180.0).rem_euclid(360.0) - 180.0,
        };
        out.push([t, v]);
    }
    out
}

/// The heading of motion as lines to draw: only the points whose ground speed (the `speed`
/// point of the same time) is at least `min_speed_m_s`, broken where the car was slower or a
/// frame is missing, each line unwrapped.
pub fn heading_lines(
    heading: &[[f64; 2]],
    speed: &[[f64; 2]],
    min_speed_m_s: f64,
    max_gap_s: f64,
) -> Vec<Vec<[f64; 2]>> {
    let mut lines: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut current: Vec<[f64; 2]> = Vec::new();
    let mut speeds = speed.iter().peekable();
    for &h in heading {
        // The speed pushed with this heading (both come from one frame).
        while speeds.next_if(|s| s[0] < h[0]).is_some() {}
        let moving = speeds
            .peek()
            .is_some_and(|s| s[0] == h[0] && s[1] >= min_speed_m_s);
        let joined = current.last().is_some_and(|q| h[0] - q[0] <= max_gap_s);
        if (!moving || !joined) && !current.is_empty() {
            lines.push(std::mem::take(&mut current));
        }
        if moving {
            current.push(h);
        }
    }
    if !current.is_empty() {
        lines.push(current);
    }
    lines.iter().map(|l| unwrap_degrees(l)).collect()
}

/// The corners (`[east_m, north_m]`, lower left and upper right) a track plot of `points`
/// must show: centred on the points, at least `min_span_m` across on each axis.
pub fn track_bounds(points: &[[f64; 2]], min_span_m: f64) -> [[f64; 2]; 2] {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in points
        .iter()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
    {
        for i in 0..2 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    if !lo[0].is_finite() {
        (lo, hi) = ([0.0; 2], [0.0; 2]);
    }
    let half = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(min_span_m) / 2.0;
    let c = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    [[c[0] - half, c[1] - half], [c[0] + half, c[1] + half]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heading_across_north_is_unwrapped_and_drawn_only_while_moving() {
        let heading = [
            [0.0, 200.0], // standing
            [0.5, 358.0],
            [1.0, 2.0],
            [1.5, 9.0],
            [2.0, 40.0], // slow again
            [5.0, 350.0],
            [10.0, 355.0], // 5 s after the one before: frames missing
        ];
        let speed = [
            [0.0, 0.0],
            [0.5, 1.0],
            [1.0, 1.2],
            [1.5, HEADING_MIN_SPEED_M_S],
            [2.0, 0.3],
            [5.0, 2.0],
            [10.0, 2.0],
        ];
        let lines = heading_lines(&heading, &speed, HEADING_MIN_SPEED_M_S, MAX_GAP_S);
        assert_eq!(
            lines,
            vec![
                vec![[0.5, 358.0], [1.0, 362.0], [1.5, 369.0]],
                vec![[5.0, 350.0]],
                vec![[10.0, 355.0]],
            ]
        );
        assert_eq!(
            unwrap_degrees(&[[0.0, 5.0], [1.0, 355.0], [2.0, 5.0]]),
            vec![[0.0, 5.0], [1.0, -5.0], [2.0, 5.0]]
        );
    }

    #[test]
    fn lines_break_where_frames_are_missing() {
        let points = [[0.0, 1.0], [0.5, 2.0], [3.0, 3.0], [3.5, 4.0]];
        assert_eq!(
            split_at_gaps(&points, MAX_GAP_S),
            vec![vec![[0.0, 1.0], [0.5, 2.0]], vec![[3.0, 3.0], [3.5, 4.0]]]
        );
        assert!(split_at_gaps(&[], MAX_GAP_S).is_empty());
    }

    #[test]
    fn a_standing_receiver_does_not_fill_the_track_plot() {
        let noise = [[0.4, -0.3], [-0.6, 0.5], [0.1, 0.2]];
        let [lo, hi] = track_bounds(&noise, TRACK_MIN_SPAN_M);
        assert!(
            (hi[0] - lo[0] - TRACK_MIN_SPAN_M).abs() < 1e-9,
            "{lo:?} {hi:?}"
        );
        assert!(
            (hi[1] - lo[1] - TRACK_MIN_SPAN_M).abs() < 1e-9,
            "{lo:?} {hi:?}"
        );
        let drive = [[0.0, 0.0], [80.0, 20.0]];
        let [lo, hi] = track_bounds(&drive, TRACK_MIN_SPAN_M);
        assert_eq!((lo, hi), ([0.0, -30.0], [80.0, 50.0]));
        assert_eq!(track_bounds(&[], 10.0), [[-5.0, -5.0], [5.0, 5.0]]);
    }

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
