//! `dima log plot --what track`: the GNSS track in local metres, coloured by mode, over the
//! mission the robot followed (its legs and waypoints) and the fence it had to stay in (the
//! inclusion circles and polygons, and the largest distance around each revive point), all
//! from the log itself: the `navigation` record, or for logs written before it the logged
//! configuration's `[navigation.fence]`.

use dima_core::config::FenceConfig;
use dima_core::geo::LatLon;
use dima_core::mission::{LocalFrame, Navigation};
use dima_core::Mode;
use plotters::prelude::*;

use super::plot::{mode_color, FONT};
use super::plot_math::{track_extent, TRACK_MIN_SPAN_M};
use super::read::LoggedRun;

/// Points on a circle outline.
const CIRCLE_POINTS: usize = 96;

/// Everything a track plot draws, in metres east and north of its origin.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrackLayers {
    /// The GNSS fixes (fix OK) and the mode of their cycle.
    pub fixes: Vec<(f64, f64, Mode)>,
    /// The mission's waypoints, in order.
    pub waypoints: Vec<(f64, f64)>,
    /// The fence's inclusion areas, as closed outlines (first point repeated last).
    pub areas: Vec<Vec<(f64, f64)>>,
    /// The largest distance from each revive point, as closed outlines.
    pub reach: Vec<Vec<(f64, f64)>>,
}

/// The mission and fence of `run`: its `navigation` record, else the logged configuration's
/// fence without a mission.
fn navigation_of(run: &LoggedRun) -> Navigation {
    run.navigation.clone().unwrap_or_else(|| Navigation {
        mission: None,
        fence: run
            .config
            .as_ref()
            .map(|c| c.navigation.fence.clone())
            .unwrap_or_default(),
    })
}

/// A circle of `radius_m` around `centre` (local metres) as a closed outline.
fn circle_outline(centre: (f64, f64), radius_m: f64) -> Vec<(f64, f64)> {
    (0..=CIRCLE_POINTS)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / CIRCLE_POINTS as f64;
            (centre.0 + radius_m * a.sin(), centre.1 + radius_m * a.cos())
        })
        .collect()
}

/// `(east, north)` of a point in `frame`.
fn east_north(frame: &LocalFrame, p: LatLon) -> (f64, f64) {
    let l = frame.to_local(p.lat_deg, p.lon_deg);
    (l.east_m, l.north_m)
}

/// The fence's inclusion areas as outlines in `frame`.
fn area_outlines(fence: &FenceConfig, frame: &LocalFrame) -> Vec<Vec<(f64, f64)>> {
    let local = |lat: f64, lon: f64| east_north(frame, LatLon::new(lat, lon));
    let circles = fence
        .circles
        .iter()
        .map(|c| circle_outline(local(c.lat_deg, c.lon_deg), c.radius_m));
    let polygons = fence.polygons.iter().map(|p| {
        let mut outline: Vec<(f64, f64)> = p.iter().map(|&[lat, lon]| local(lat, lon)).collect();
        outline.extend(outline.first().copied());
        outline
    });
    circles.chain(polygons).collect()
}

/// The layers of `run`'s track plot. The origin is the first fix (the first waypoint when the
/// log has no fix); a revive point is the first fix of a cycle in MANUAL after KILLED or
/// FAILSAFE.
pub fn track_layers(run: &LoggedRun) -> TrackLayers {
    let navigation = navigation_of(run);
    let fixes: Vec<(LatLon, Mode)> = run
        .cycles
        .iter()
        .filter_map(|c| {
            let s = c.msg.sensor.as_ref()?;
            Some((LatLon::new(s.lat_deg?, s.lon_deg?), c.msg.mode)).filter(|_| s.gnss_fix_ok)
        })
        .collect();
    let first_waypoint = navigation
        .mission
        .as_ref()
        .and_then(|m| m.waypoints.first())
        .map(|w| LatLon::new(w.lat_deg, w.lon_deg));
    let origin = fixes
        .first()
        .map(|f| f.0)
        .or(first_waypoint)
        .unwrap_or(LatLon::new(0.0, 0.0));
    // The mission's own flat frame (WGS84's radii of curvature at the origin).
    let frame = LocalFrame::new(origin.lat_deg, origin.lon_deg);
    let local = |p: LatLon| east_north(&frame, p);
    let mut reach = Vec::new();
    if let Some(max) = navigation.fence.max_distance_m {
        let mut before = Mode::Killed;
        for (p, mode) in &fixes {
            if *mode == Mode::Manual && matches!(before, Mode::Killed | Mode::Failsafe) {
                reach.push(circle_outline(local(*p), max));
            }
            before = *mode;
        }
    }
    TrackLayers {
        fixes: fixes
            .iter()
            .map(|&(p, m)| {
                let (e, n) = local(p);
                (e, n, m)
            })
            .collect(),
        waypoints: navigation
            .mission
            .iter()
            .flat_map(|m| &m.waypoints)
            .map(|w| local(LatLon::new(w.lat_deg, w.lon_deg)))
            .collect(),
        areas: area_outlines(&navigation.fence, &frame),
        reach,
    }
}

/// Draws the track plot of `run` on `root`.
pub fn track(
    run: &LoggedRun,
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
) -> anyhow::Result<()> {
    let layers = track_layers(run);
    // Same scale on both axes, at least TRACK_MIN_SPAN_M (standing noise stays small), wide
    // enough for the track, the mission and the fence.
    let extent: Vec<(f64, f64)> = layers
        .fixes
        .iter()
        .map(|p| (p.0, p.1))
        .chain(layers.waypoints.iter().copied())
        .chain(layers.areas.iter().chain(&layers.reach).flatten().copied())
        .collect();
    // The plotting area: the whole less the label areas, margins and caption.
    let (w, h) = root.dim_in_pixel();
    let aspect = f64::from(w.saturating_sub(70 + 24).max(1))
        / f64::from(h.saturating_sub(44 + 24 + 30).max(1));
    let (x, y) = track_extent(&extent, TRACK_MIN_SPAN_M, aspect);
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("GNSS track (coloured by mode; at least {TRACK_MIN_SPAN_M} m across)"),
            (FONT, 22),
        )
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .x_desc("east of the first fix (m)")
        .y_desc("north of the first fix (m)")
        .label_style((FONT, 15))
        .draw()?;
    let fence_color = RGBColor(200, 30, 30);
    for (i, outline) in layers.areas.iter().enumerate() {
        let series = chart.draw_series(LineSeries::new(
            outline.iter().copied(),
            fence_color.stroke_width(2),
        ))?;
        if i == 0 {
            series
                .label("fence")
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], fence_color));
        }
    }
    let reach_color = RGBColor(230, 130, 0);
    for (i, outline) in layers.reach.iter().enumerate() {
        let series = chart.draw_series(LineSeries::new(
            outline.iter().copied(),
            reach_color.stroke_width(1),
        ))?;
        if i == 0 {
            series
                .label("fence: largest distance from the revive")
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], reach_color));
        }
    }
    if !layers.waypoints.is_empty() {
        let grey = RGBColor(90, 90, 90);
        chart
            .draw_series(LineSeries::new(
                layers.waypoints.iter().copied(),
                grey.stroke_width(1),
            ))?
            .label("mission")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], grey));
        chart.draw_series(layers.waypoints.iter().enumerate().map(|(i, &p)| {
            EmptyElement::at(p)
                + Cross::new((0, 0), 5, grey.stroke_width(2))
                + Text::new(
                    format!("{i}"),
                    (6, -16),
                    (FONT, 14).into_font().color(&grey),
                )
        }))?;
    }
    for mode in [Mode::Killed, Mode::Manual, Mode::Auto, Mode::Failsafe] {
        let c = mode_color(mode);
        chart
            .draw_series(
                layers
                    .fixes
                    .iter()
                    .filter(|p| p.2 == mode)
                    .map(move |p| Circle::new((p.0, p.1), 2, c.filled())),
            )?
            .label(mode.name())
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, c.filled()));
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_core::config::{FenceCircle, NavigationConfig};
    use dima_core::mission::parse_plan_file;
    use std::path::Path;

    fn fixture_run() -> LoggedRun {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/fixtures/auto-pid-before-plugins.mcap"
        );
        LoggedRun::read(Path::new(path)).unwrap()
    }

    fn fenced_square() -> Navigation {
        let text = include_str!("../../../core/tests/fixtures/square-40m-fenced.plan");
        Navigation::with_plan(&NavigationConfig::default(), parse_plan_file(text).unwrap()).unwrap()
    }

    fn distance(a: (f64, f64), b: (f64, f64)) -> f64 {
        (a.0 - b.0).hypot(a.1 - b.1)
    }

    #[test]
    fn the_mission_and_the_plans_fence_are_drawn_in_local_metres() {
        let mut run = fixture_run();
        run.cycles.clear();
        run.navigation = Some(fenced_square());
        let layers = track_layers(&run);
        // No fix: the origin is the first waypoint; the plan's square has 40 m sides.
        assert_eq!(layers.waypoints.len(), 5);
        assert!(distance(layers.waypoints[0], (0.0, 0.0)) < 1e-9);
        for leg in layers.waypoints.windows(2) {
            let d = distance(leg[0], leg[1]);
            assert!((d - 40.0).abs() < 0.05, "{d}");
        }
        // The fence polygon, closed: 10 m outside the square on every side.
        assert_eq!(layers.areas.len(), 1);
        let outline = &layers.areas[0];
        assert_eq!((outline.len(), outline.first()), (5, outline.last()));
        let (e0, n0) = outline[0];
        assert!(
            (e0 + 9.7).abs() < 0.3 && (n0 + 10.0).abs() < 0.3,
            "{outline:?}"
        );
        assert!(layers.reach.is_empty() && layers.fixes.is_empty());
    }

    #[test]
    fn circles_and_the_distance_from_each_revive_are_outlines_of_their_radius() {
        let mut run = fixture_run();
        let fixes = track_layers(&run).fixes;
        assert!(!fixes.is_empty(), "the fixture has GNSS fixes");
        let revives = fixes
            .windows(2)
            .filter(|w| w[1].2 == Mode::Manual && matches!(w[0].2, Mode::Killed | Mode::Failsafe))
            .count()
            + usize::from(fixes[0].2 == Mode::Manual);
        assert!(revives >= 1, "the fixture revives");
        let first = run
            .cycles
            .iter()
            .find_map(|c| {
                c.msg
                    .sensor
                    .as_ref()
                    .and_then(|s| Some((s.lat_deg?, s.lon_deg?)))
            })
            .unwrap();
        run.navigation = Some(Navigation {
            mission: None,
            fence: FenceConfig {
                max_distance_m: Some(25.0),
                circles: vec![FenceCircle {
                    lat_deg: first.0,
                    lon_deg: first.1,
                    radius_m: 60.0,
                }],
                polygons: Vec::new(),
            },
        });
        let layers = track_layers(&run);
        assert_eq!(layers.reach.len(), revives);
        assert_eq!(layers.areas.len(), 1);
        for p in &layers.areas[0] {
            assert!((distance(*p, (0.0, 0.0)) - 60.0).abs() < 1e-6, "{p:?}");
        }
        // Without the record, the logged configuration's fence (none in this log).
        run.navigation = None;
        let layers = track_layers(&run);
        assert!(layers.areas.is_empty() && layers.reach.is_empty() && layers.waypoints.is_empty());
    }
}
