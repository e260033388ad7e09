//! What the plots of `dima log plot` draw, as pure functions: angles unwrapped across the
//! 0/360° wrap, lines broken where data is missing, heading of motion only where the car
//! moves, a floor on the track's scale, and latency buckets up to the 99.9th percentile.

use std::ops::Range;

/// Below this GNSS ground speed, m/s, the heading of motion is not drawn: standing still or
/// creeping, the receiver's heading of motion is noise (it is the direction of the velocity
/// vector, and the velocity is mostly error).
pub const HEADING_MIN_SPEED_M_S: f64 = 0.5;

/// Samples further apart than this, s, are not joined by a line: the data between them is
/// missing (a GNSS outage, a gap in the log). GNSS fixes come every 0.1 s to 0.2 s.
pub const MAX_GAP_S: f64 = 0.5;

/// The track's plot spans at least this many metres on each axis, so that a receiver's
/// position noise while standing (a metre or two) does not fill the plot like a drive.
pub const TRACK_MIN_SPAN_M: f64 = 10.0;

/// At most this many buckets in the latency histogram (wider buckets for a wider range).
pub const LATENCY_MAX_BUCKETS: u32 = 200;

/// `(time, value)` samples split into lines: a line ends at a sample without a value (`None`)
/// and where two samples are more than `max_gap_s` apart. Lines of one point are kept (a lone
/// fix is still drawn, as a dot).
pub fn split_at_gaps(samples: &[(f64, Option<f64>)], max_gap_s: f64) -> Vec<Vec<(f64, f64)>> {
    let mut lines: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    for &(t, value) in samples {
        match value.filter(|v| v.is_finite()) {
            Some(v) => {
                if current.last().is_some_and(|&(t0, _)| t - t0 > max_gap_s) {
                    lines.push(std::mem::take(&mut current));
                }
                current.push((t, v));
            }
            None => {
                if !current.is_empty() {
                    lines.push(std::mem::take(&mut current));
                }
            }
        }
    }
    if !current.is_empty() {
        lines.push(current);
    }
    lines
}

/// `degrees` made continuous: each value moved by a multiple of 360° to within 180° of the one
/// before, so 359° -> 1° is a step of 2°, not a vertical bar across the plot. The first value
/// is kept as it is.
pub fn unwrap_degrees(line: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(line.len());
    for &(t, deg) in line {
        let v = match out.last() {
            None => deg,
            Some(&(_, prev)) => prev + (deg - prev + 180.0).rem_euclid(360.0) - 180.0,
        };
        out.push((t, v));
    }
    out
}

/// The heading of motion as lines to draw: only where the ground speed is at least
/// `min_speed_m_s` (see [`HEADING_MIN_SPEED_M_S`]), broken at gaps, each line unwrapped.
/// `samples` are `(time, heading in degrees, ground speed in m/s)`, either absent.
pub fn heading_lines(
    samples: &[(f64, Option<f64>, Option<f64>)],
    min_speed_m_s: f64,
    max_gap_s: f64,
) -> Vec<Vec<(f64, f64)>> {
    let moving: Vec<(f64, Option<f64>)> = samples
        .iter()
        .map(|&(t, heading, speed)| {
            (
                t,
                heading.filter(|_| speed.is_some_and(|s| s >= min_speed_m_s)),
            )
        })
        .collect();
    split_at_gaps(&moving, max_gap_s)
        .iter()
        .map(|line| unwrap_degrees(line))
        .collect()
}

/// Angles (any series, e.g. a heading setpoint) as lines: broken at gaps, each unwrapped.
pub fn angle_lines(samples: &[(f64, Option<f64>)], max_gap_s: f64) -> Vec<Vec<(f64, f64)>> {
    split_at_gaps(samples, max_gap_s)
        .iter()
        .map(|line| unwrap_degrees(line))
        .collect()
}

/// `lines` of angles (a setpoint, an estimate) each moved by a whole number of turns to lie
/// nearest the `reference` lines (the measured heading) at the time the line starts, so that
/// a setpoint of 5° beside a heading unwrapped to 358° is drawn at 365°, 7° away, not 353°
/// away. The reference point nearest in time to the line's start decides; without reference
/// points the lines are left as they are.
pub fn align_turns(
    lines: &[Vec<(f64, f64)>],
    reference: &[Vec<(f64, f64)>],
) -> Vec<Vec<(f64, f64)>> {
    let refs: Vec<(f64, f64)> = reference.iter().flatten().copied().collect();
    lines
        .iter()
        .map(|line| {
            let Some(&(t0, v0)) = line.first() else {
                return Vec::new();
            };
            let nearest = refs
                .iter()
                .min_by(|a, b| (a.0 - t0).abs().total_cmp(&(b.0 - t0).abs()));
            let turns = nearest.map_or(0.0, |&(_, r)| ((r - v0) / 360.0).round());
            line.iter().map(|&(t, v)| (t, v + 360.0 * turns)).collect()
        })
        .collect()
}

/// The east and north ranges, m, of a track plot of `points` (`(east, north)`) drawn in an
/// area `aspect` times as wide as high (pixels): one scale on both axes (a metre is as many
/// pixels east as north), centred on the points, spanning at least `min_span_m` and 10 % more
/// than the points on each axis. No points: `min_span_m` around 0.
pub fn track_extent(
    points: &[(f64, f64)],
    min_span_m: f64,
    aspect: f64,
) -> (Range<f64>, Range<f64>) {
    let finite = points.iter().filter(|p| p.0.is_finite() && p.1.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0.0);
    let mut any = false;
    for &(e, n) in finite {
        if !any {
            (y0, y1) = (n, n);
            any = true;
        }
        (x0, x1, y0, y1) = (x0.min(e), x1.max(e), f64::min(y0, n), f64::max(y1, n));
    }
    if !any {
        (x0, x1) = (0.0, 0.0);
    }
    let aspect = if aspect.is_finite() && aspect > 0.0 {
        aspect
    } else {
        1.0
    };
    // Half the north span; the east span is `aspect` times the north span.
    let half_n = ((x1 - x0) / aspect).max(y1 - y0) * 1.1 / 2.0;
    let half_n = half_n.max(min_span_m / 2.0).max(min_span_m / 2.0 / aspect);
    let half_e = half_n * aspect;
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    (cx - half_e..cx + half_e, cy - half_n..cy + half_n)
}

/// A latency histogram: buckets of `width_us` from 0 up to `top_us` (the 99.9th percentile,
/// rounded up to a whole bucket), and how many samples lie beyond it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LatencyHistogram {
    /// Bucket width, µs (1, 2, 5, 10, 20, 50, ...).
    pub width_us: u32,
    /// Upper end of the last bucket, µs.
    pub top_us: u32,
    /// Samples per bucket, from 0 µs.
    pub counts: Vec<u64>,
    /// Samples at or beyond `top_us` (drawn as a count in the caption, not as bars).
    pub beyond: u64,
}

/// Buckets `values_us` up to their 99.9th percentile (nearest rank) in at most `max_buckets`
/// buckets of a 1-2-5 width, so one stall of the host does not squeeze the distribution into a
/// one-pixel spike at the left edge.
pub fn latency_histogram(values_us: &[f64], max_buckets: u32) -> LatencyHistogram {
    let mut sorted: Vec<f64> = values_us
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .map(|v| v.max(0.0))
        .collect();
    sorted.sort_by(f64::total_cmp);
    let p999 = super::info::percentile(&sorted, 99.9).unwrap_or(0.0);
    let range = (p999.ceil() as u32).saturating_add(1).max(10);
    let width_us = nice_width(range.div_ceil(max_buckets.max(1)));
    let buckets = range.div_ceil(width_us);
    let top_us = buckets * width_us;
    let mut counts = vec![0u64; buckets as usize];
    let mut beyond = 0;
    for v in sorted {
        match counts.get_mut((v / f64::from(width_us)) as usize) {
            Some(c) if v < f64::from(top_us) => *c += 1,
            _ => beyond += 1,
        }
    }
    LatencyHistogram {
        width_us,
        top_us,
        counts,
        beyond,
    }
}

/// The smallest of 1, 2, 5, 10, 20, 50, ... at least `min`.
fn nice_width(min: u32) -> u32 {
    let mut decade = 1u32;
    loop {
        for step in [1, 2, 5] {
            let w = step * decade;
            if w >= min {
                return w;
            }
        }
        decade = decade.saturating_mul(10);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_heading_across_north_is_unwrapped_not_a_vertical_bar() {
        let line = [
            (0.0, 350.0),
            (0.1, 355.0),
            (0.2, 1.0),
            (0.3, 8.0),
            (0.4, 352.0),
        ];
        let u = unwrap_degrees(&line);
        let values: Vec<f64> = u.iter().map(|p| p.1).collect();
        assert_eq!(values, [350.0, 355.0, 361.0, 368.0, 352.0]);
        // No step between neighbours is larger than 180°.
        let left = unwrap_degrees(&[(0.0, 5.0), (0.1, 355.0), (0.2, 5.0)]);
        assert_eq!(
            left.iter().map(|p| p.1).collect::<Vec<_>>(),
            [5.0, -5.0, 5.0]
        );
        assert!(unwrap_degrees(&[]).is_empty());
    }

    #[test]
    fn a_setpoint_is_drawn_in_the_turn_of_the_heading_beside_it() {
        let heading = vec![vec![(0.0, 350.0), (1.0, 358.0), (2.0, 365.0)]];
        let setpoint = vec![vec![(0.5, 5.0), (2.0, 5.0)], vec![(10.0, 90.0)]];
        let aligned = align_turns(&setpoint, &heading);
        assert_eq!(aligned[0], vec![(0.5, 365.0), (2.0, 365.0)]);
        // Nearest in time is the last heading point (365°): 90° is drawn 85° from it, at 450°.
        assert_eq!(aligned[1], vec![(10.0, 450.0)]);
        let below = align_turns(&[vec![(0.0, 355.0)]], &[vec![(0.0, -3.0)]]);
        assert_eq!(below, vec![vec![(0.0, -5.0)]]);
        assert_eq!(align_turns(&setpoint, &[]), setpoint);
    }

    #[test]
    fn lines_break_at_missing_values_and_at_gaps_in_time() {
        let samples = [
            (0.0, Some(1.0)),
            (0.1, Some(2.0)),
            (0.2, None),
            (0.3, Some(3.0)),
            (0.4, Some(4.0)),
            (1.5, Some(5.0)), // 1.1 s after the one before: data missing
            (1.6, Some(f64::NAN)),
        ];
        let lines = split_at_gaps(&samples, MAX_GAP_S);
        assert_eq!(
            lines,
            vec![
                vec![(0.0, 1.0), (0.1, 2.0)],
                vec![(0.3, 3.0), (0.4, 4.0)],
                vec![(1.5, 5.0)],
            ]
        );
        assert!(split_at_gaps(&[(0.0, None)], MAX_GAP_S).is_empty());
    }

    #[test]
    fn heading_is_drawn_only_while_the_car_moves() {
        let s = |t: f64, h: f64, v: f64| (t, Some(h), Some(v));
        let samples = [
            s(0.0, 123.0, 0.0), // standing: noise
            s(0.1, 301.0, 0.2),
            s(0.2, 358.0, HEADING_MIN_SPEED_M_S),
            s(0.3, 2.0, 1.5),
            s(0.4, 90.0, 0.1),
            (0.5, Some(10.0), None),
            s(0.6, 20.0, 2.0),
        ];
        let lines = heading_lines(&samples, HEADING_MIN_SPEED_M_S, MAX_GAP_S);
        assert_eq!(
            lines,
            vec![vec![(0.2, 358.0), (0.3, 362.0)], vec![(0.6, 20.0)]]
        );
    }

    #[test]
    fn a_standing_receiver_does_not_fill_the_track_plot() {
        // A metre of noise around the origin.
        let noise = [(0.3, -0.4), (-0.5, 0.6), (0.2, 0.1), (-0.1, -0.5)];
        let (x, y) = track_extent(&noise, TRACK_MIN_SPAN_M, 1.0);
        assert!((x.end - x.start - TRACK_MIN_SPAN_M).abs() < 1e-9, "{x:?}");
        assert!((y.end - y.start - TRACK_MIN_SPAN_M).abs() < 1e-9, "{y:?}");
        assert!(x.contains(&0.3) && y.contains(&0.6));
        // In a wide area the shorter (north) axis gets the floor, east as many metres per pixel.
        let (x, y) = track_extent(&noise, TRACK_MIN_SPAN_M, 2.0);
        assert!((y.end - y.start - TRACK_MIN_SPAN_M).abs() < 1e-9, "{y:?}");
        assert!(
            (x.end - x.start - 2.0 * TRACK_MIN_SPAN_M).abs() < 1e-9,
            "{x:?}"
        );
        // A drive of 100 m east keeps its own scale, the same on both axes.
        let drive = [(0.0, 0.0), (100.0, 5.0)];
        let (x, y) = track_extent(&drive, TRACK_MIN_SPAN_M, 1.0);
        assert!((x.end - x.start - 110.0).abs() < 1e-9, "{x:?}");
        assert!((y.end - y.start - 110.0).abs() < 1e-9, "{y:?}");
        assert!((x.start + x.end) / 2.0 == 50.0 && (y.start + y.end) / 2.0 == 2.5);
        let (x, y) = track_extent(&drive, TRACK_MIN_SPAN_M, 2.0);
        assert!((x.end - x.start - 110.0).abs() < 1e-9, "{x:?}");
        assert!((y.end - y.start - 55.0).abs() < 1e-9, "{y:?}");
        let (x, _) = track_extent(&[], TRACK_MIN_SPAN_M, 1.0);
        assert_eq!(x, -5.0..5.0);
    }

    #[test]
    fn one_outlier_does_not_squeeze_the_latency_histogram() {
        // 10 000 wake-ups between 40 and 139 µs, and one stall of 16 ms.
        let mut values: Vec<f64> = (0..10_000).map(|i| 40.0 + f64::from(i % 100)).collect();
        values.push(16_000.0);
        let h = latency_histogram(&values, LATENCY_MAX_BUCKETS);
        assert!(h.top_us < 200, "{h:?}");
        assert_eq!(h.beyond, 1);
        assert_eq!(h.counts.iter().sum::<u64>(), 10_000);
        assert_eq!(h.width_us, 1);
        // A wide range gets wider buckets, never more than the maximum.
        let wide: Vec<f64> = (0..5_000).map(f64::from).collect();
        let h = latency_histogram(&wide, LATENCY_MAX_BUCKETS);
        assert_eq!(h.width_us, 50);
        assert!(h.counts.len() <= LATENCY_MAX_BUCKETS as usize);
        assert_eq!(h.counts.iter().sum::<u64>() + h.beyond, 5_000);
        assert_eq!(latency_histogram(&[], 10).counts.iter().sum::<u64>(), 0);
    }
}
