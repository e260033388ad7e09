//! The middle of the window: the plots or the map, chosen by tabs; and the map panel: the
//! track and the car on a metre grid around the origin (the first fix, or the revive point),
//! over offline tiles when `--map-tiles` gives them, with the mission and the fence of
//! `--plan` (or of the replayed robot log), a scale bar, the heading setpoint, zoom (wheel),
//! pan (drag) and "follow the car".

use std::path::PathBuf;

use eframe::egui::{self, Align2, Color32, FontId, Pos2, Rect, Sense, Shape, Stroke, Vec2};

use crate::cli::Panel;
use crate::map::mercator;
use crate::map::origin::{MapOrigin, OriginKind};
use crate::map::plan::PlanOverlay;
use crate::map::scale::{scale_bar_m, scale_label};
use crate::map::setpoint::{heading_setpoint_deg, shown_heading_setpoint_deg};
use crate::map::tiles::{available_zooms, choose_zoom, load_tile, BoundedCache, TileKey};
use crate::map::view::{self, local_to_lat_lon, MapView};
use crate::plots::{local_en_m, HEADING_MIN_SPEED_M_S};
use crate::robot_view::Truth;

use super::GroundApp;

/// Decoded tiles kept (as textures, 256 KiB each).
const TILE_CACHE: usize = 160;
/// Tiles read from the disk per frame at most (the rest in the next frames).
const TILE_LOADS_PER_FRAME: usize = 12;
/// The car marker's length, pixels.
const CAR_PX: f32 = 24.0;
/// The heading setpoint arrow's length, pixels.
const SETPOINT_ARROW_PX: f32 = 70.0;
/// The longest scale bar, pixels.
const SCALE_BAR_MAX_PX: f64 = 160.0;
/// Grid lines at least this far apart, pixels.
const GRID_MIN_PX: f64 = 60.0;

const TRACK: Color32 = Color32::from_rgb(40, 110, 230);
const CAR: Color32 = Color32::from_rgb(220, 40, 40);
const SETPOINT: Color32 = Color32::from_rgb(255, 150, 0);
const MISSION: Color32 = Color32::from_rgb(70, 70, 70);
const FENCE: Color32 = Color32::from_rgb(200, 30, 30);

/// The map panel's state.
pub struct MapPanel {
    /// Which panel the middle of the window shows.
    pub shown: Panel,
    view: MapView,
    follow: bool,
    origin: MapOrigin,
    tiles_dir: Option<PathBuf>,
    /// The zooms the tile directory has, ascending (read at start).
    tile_zooms: Vec<u8>,
    /// Decoded tiles; `None` for a tile that is missing or unreadable.
    tiles: BoundedCache<Option<egui::TextureHandle>>,
    /// The mission and the fence drawn under the track (`--plan`, or the replayed log's).
    plan: Option<PlanOverlay>,
}

impl MapPanel {
    /// Shows `shown` first; tiles from `tiles_dir` and the mission and fence of `plan` when
    /// given.
    pub fn new(shown: Panel, tiles_dir: Option<PathBuf>, plan: Option<PlanOverlay>) -> MapPanel {
        MapPanel {
            shown,
            view: MapView::default(),
            follow: true,
            origin: MapOrigin::default(),
            tile_zooms: tiles_dir
                .as_deref()
                .map(available_zooms)
                .unwrap_or_default(),
            tiles_dir,
            tiles: BoundedCache::new(TILE_CACHE),
            plan,
        }
    }
}

/// The middle of the window: tabs, then the plots or the map.
pub fn central_panel(ui: &mut egui::Ui, app: &mut GroundApp) {
    ui.horizontal(|ui| {
        ui.selectable_value(&mut app.map.shown, Panel::Plots, "Plots");
        ui.selectable_value(&mut app.map.shown, Panel::Map, "Map");
    });
    match app.map.shown {
        Panel::Plots => super::charts::plots(ui, &app.telemetry),
        Panel::Map => map(ui, app),
    }
}

/// The heading setpoint to draw, degrees.
///
/// The one the robot reports it follows; from a robot that does not report its setpoints,
/// what the station last sent in AUTO.
fn heading_setpoint(app: &GroundApp) -> Option<f64> {
    let truth = Truth::of(&app.status, app.now());
    shown_heading_setpoint_deg(truth, || {
        let mode = app.status.robot.as_ref().map(|r| (r.at, r.mode));
        heading_setpoint_deg(&app.status.last_sent, mode)
    })
}

/// The map panel.
fn map(ui: &mut egui::Ui, app: &mut GroundApp) {
    let t = &app.telemetry;
    let latest_fix = t
        .latest
        .as_ref()
        .filter(|(_, _, p)| p.has_position())
        .map(|(at, _, p)| (*at, (p.lat_deg, p.lon_deg)));
    let revive_sent =
        app.status.last_sent[dima_groundlink::CommandType::Revive as usize].map(|(at, _)| at);
    let panel = &mut app.map;
    if let Some(old) = panel
        .origin
        .update(revive_sent, t.track.origin(), latest_fix)
    {
        // Keep showing the same ground around the new origin.
        if let Some((new, _)) = panel.origin.get() {
            panel.view.centre_m = local_en_m(new, local_to_lat_lon(old, panel.view.centre_m));
        }
    }
    let origin = panel.origin.get();
    // The track and the car in metres around the map's origin (the track keeps its own
    // origin, the first fix).
    let to_map = |en: [f64; 2]| match (origin, t.track.origin()) {
        (Some((o, _)), Some(track_origin)) if o != track_origin => {
            local_en_m(o, local_to_lat_lon(track_origin, en))
        }
        _ => en,
    };
    let track: Vec<[f64; 2]> = t.track.points().into_iter().map(to_map).collect();
    let car = track.last().copied();
    let motion = t
        .latest
        .as_ref()
        .map(|(_, _, p)| (p.heading_deg, p.ground_speed_m_s));
    let setpoint = heading_setpoint(app);
    let panel = &mut app.map;

    ui.horizontal(|ui| {
        ui.checkbox(&mut panel.follow, "follow the car");
        if ui.button("origin").clicked() {
            panel.follow = false;
            panel.view.centre_m = [0.0, 0.0];
        }
        ui.label(match origin {
            Some((_, OriginKind::FirstFix)) => "metres east / north of the first fix; north up",
            Some((_, OriginKind::RevivePoint)) => {
                "metres east / north of the revive point; north up"
            }
            None => "no GNSS fix yet",
        });
        ui.label("· wheel: zoom, drag: pan");
    });

    let (response, painter) = ui.allocate_painter(ui.available_size(), Sense::click_and_drag());
    let rect = response.rect;
    if response.dragged() {
        panel.view.pan(response.drag_delta());
        panel.follow = false;
    }
    if let Some(pointer) = response.hover_pos() {
        let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta.y, i.zoom_delta()));
        let factor = f64::from(zoom) * (f64::from(scroll) / 200.0).exp();
        if factor != 1.0 {
            let about = if panel.follow { rect.center() } else { pointer };
            panel.view.zoom_about(rect, about, factor);
        }
    }
    if panel.follow {
        if let Some(c) = car {
            panel.view.centre_m = c;
        }
    }

    painter.rect_filled(rect, 0.0, Color32::from_gray(235));
    let tile_note = match (origin, &panel.tiles_dir) {
        (Some((o, _)), Some(dir)) => {
            let dir = dir.clone();
            draw_tiles(ui.ctx(), &painter, rect, panel, o, &dir)
        }
        (None, Some(_)) => "tiles: waiting for a fix".to_owned(),
        (_, None) => "no map tiles (--map-tiles DIR)".to_owned(),
    };
    let view = panel.view;
    draw_grid(&painter, rect, &view);
    if let (Some(plan), Some((o, _))) = (&panel.plan, origin) {
        draw_plan(&painter, rect, &view, plan, o);
    }
    if origin.is_some() {
        let o = view.to_screen(rect, [0.0, 0.0]);
        painter.circle_stroke(o, 5.0, Stroke::new(2.0, Color32::BLACK));
    }
    if track.len() >= 2 {
        let points: Vec<Pos2> = track.iter().map(|&p| view.to_screen(rect, p)).collect();
        painter.add(Shape::line(points, Stroke::new(2.5, TRACK)));
    }
    if let Some(c) = car {
        let at = view.to_screen(rect, c);
        if let Some(deg) = setpoint {
            let (tip, wings) = view::heading_arrow(at, deg, SETPOINT_ARROW_PX);
            let stroke = Stroke::new(3.0, SETPOINT);
            painter.line_segment([at, tip], stroke);
            painter.line_segment([tip, wings[0]], stroke);
            painter.line_segment([tip, wings[1]], stroke);
            painter.text(
                tip + view::heading_direction(deg) * 10.0,
                Align2::CENTER_CENTER,
                format!("setpoint {deg:.0}°"),
                FontId::proportional(12.0),
                Color32::BLACK,
            );
        }
        let (heading, speed) = motion.unwrap_or((0.0, 0.0));
        // Below the speed the heading of motion means something, the marker is hollow.
        let moving = speed >= HEADING_MIN_SPEED_M_S;
        let marker = view::car_marker(at, heading, CAR_PX).to_vec();
        let (fill, outline) = if moving {
            (CAR, Stroke::new(1.5, Color32::BLACK))
        } else {
            (Color32::from_white_alpha(200), Stroke::new(2.0, CAR))
        };
        painter.add(Shape::convex_polygon(marker, fill, outline));
    }
    draw_scale_bar(&painter, rect, &view);
    let tile_note = match &panel.plan {
        Some(plan) => format!("{} · {tile_note}", plan.note()),
        None => tile_note,
    };
    let note = painter.layout_no_wrap(tile_note, FontId::proportional(12.0), Color32::BLACK);
    let note_rect = Align2::RIGHT_BOTTOM
        .anchor_size(rect.right_bottom() + Vec2::new(-10.0, -10.0), note.size());
    painter.rect_filled(note_rect.expand(4.0), 3.0, Color32::from_white_alpha(200));
    painter.galley(note_rect.min, note, Color32::BLACK);
    if origin.is_none() {
        painter.text(
            rect.center(),
            Align2::CENTER_CENTER,
            "waiting for a GNSS position",
            FontId::proportional(16.0),
            Color32::from_gray(60),
        );
    }
}

/// Draws the fence's areas and the mission's legs and numbered waypoints.
fn draw_plan(
    painter: &egui::Painter,
    rect: Rect,
    view: &MapView,
    plan: &PlanOverlay,
    origin: (f64, f64),
) {
    let m = plan.in_metres(origin);
    let screen = |points: &[[f64; 2]]| -> Vec<Pos2> {
        points.iter().map(|&p| view.to_screen(rect, p)).collect()
    };
    for area in &m.areas {
        painter.add(Shape::line(screen(area), Stroke::new(2.0, FENCE)));
    }
    if m.waypoints.len() >= 2 {
        painter.add(Shape::line(screen(&m.waypoints), Stroke::new(1.5, MISSION)));
    }
    for (i, at) in screen(&m.waypoints).into_iter().enumerate() {
        painter.circle_stroke(at, 4.0, Stroke::new(1.5, MISSION));
        painter.text(
            at + Vec2::new(6.0, -6.0),
            Align2::LEFT_BOTTOM,
            format!("{i}"),
            FontId::proportional(12.0),
            MISSION,
        );
    }
}

/// Draws the tiles of the zoom that fits under the view; returns a note for the panel.
fn draw_tiles(
    ctx: &egui::Context,
    painter: &egui::Painter,
    rect: Rect,
    panel: &mut MapPanel,
    origin: (f64, f64),
    dir: &std::path::Path,
) -> String {
    let fit = mercator::zoom_for(panel.view.metres_per_px, origin.0, mercator::MAX_ZOOM);
    let Some(zoom) = choose_zoom(fit, &panel.tile_zooms) else {
        return format!("no tiles in {} (ZOOM/X/Y.png)", dir.display());
    };
    let Some(range) = view::tiles_in_view(origin, panel.view.bounds(rect), zoom) else {
        return format!("tiles: zoom {zoom} needs too many; zoom in");
    };
    let (mut drawn, mut loads) = (0, 0);
    for (x, y) in range.tiles() {
        let key = TileKey { zoom, x, y };
        let texture = match panel.tiles.get(key) {
            Some(t) => t.clone(),
            None if loads < TILE_LOADS_PER_FRAME => {
                loads += 1;
                let texture = load_tile(dir, key).map(|image| {
                    let color = egui::ColorImage::from_rgba_unmultiplied(
                        [image.width, image.height],
                        &image.pixels,
                    );
                    ctx.load_texture(
                        format!("tile {zoom}/{x}/{y}"),
                        color,
                        egui::TextureOptions::LINEAR,
                    )
                });
                panel.tiles.insert(key, texture.clone());
                texture
            }
            None => {
                // The rest next frame.
                ctx.request_repaint();
                None
            }
        };
        if let Some(texture) = texture {
            let [nw, se] = view::tile_corners_m(origin, zoom, x, y);
            let screen = Rect::from_min_max(
                panel.view.to_screen(rect, nw),
                panel.view.to_screen(rect, se),
            );
            let uv = Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0));
            painter.image(texture.id(), screen, uv, Color32::WHITE);
            drawn += 1;
        }
    }
    format!("tiles: zoom {zoom}, {drawn} of {} drawn", range.len())
}

/// Grid lines at a round spacing, the axes through the origin darker.
fn draw_grid(painter: &egui::Painter, rect: Rect, view: &MapView) {
    let step = scale_bar_m(view.metres_per_px, GRID_MIN_PX * 2.5).max(1.0);
    let step = if step / view.metres_per_px < GRID_MIN_PX {
        step * 2.0
    } else {
        step
    };
    let [sw, ne] = view.bounds(rect);
    let line = |k: f64| {
        if k == 0.0 {
            Stroke::new(1.5, Color32::from_black_alpha(150))
        } else {
            Stroke::new(1.0, Color32::from_black_alpha(50))
        }
    };
    let mut k = (sw[0] / step).ceil();
    while k * step <= ne[0] {
        let x = view.to_screen(rect, [k * step, 0.0]).x;
        painter.line_segment(
            [Pos2::new(x, rect.top()), Pos2::new(x, rect.bottom())],
            line(k),
        );
        k += 1.0;
    }
    let mut k = (sw[1] / step).ceil();
    while k * step <= ne[1] {
        let y = view.to_screen(rect, [0.0, k * step]).y;
        painter.line_segment(
            [Pos2::new(rect.left(), y), Pos2::new(rect.right(), y)],
            line(k),
        );
        k += 1.0;
    }
}

/// The scale bar in the lower left corner.
fn draw_scale_bar(painter: &egui::Painter, rect: Rect, view: &MapView) {
    let metres = scale_bar_m(view.metres_per_px, SCALE_BAR_MAX_PX);
    let px = (metres / view.metres_per_px) as f32;
    let left = rect.left_bottom() + Vec2::new(16.0, -18.0);
    let right = left + Vec2::new(px, 0.0);
    let backdrop = Rect::from_min_max(left + Vec2::new(-8.0, -24.0), right + Vec2::new(8.0, 8.0));
    painter.rect_filled(backdrop, 3.0, Color32::from_white_alpha(200));
    let stroke = Stroke::new(3.0, Color32::BLACK);
    painter.line_segment([left, right], stroke);
    for end in [left, right] {
        painter.line_segment([end, end - Vec2::new(0.0, 8.0)], stroke);
    }
    painter.text(
        (left + (right - left) / 2.0) - Vec2::new(0.0, 6.0),
        Align2::CENTER_BOTTOM,
        scale_label(metres),
        FontId::proportional(13.0),
        Color32::BLACK,
    );
}
