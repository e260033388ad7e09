//! The plots: acceleration, angular rate, speed and heading over time, and the GNSS track.

use eframe::egui;
use egui_plot::{Legend, Line, Plot, Points};

use crate::plots;
use crate::telemetry::Telemetry;

pub fn plots(ui: &mut egui::Ui, t: &Telemetry) {
    let height = ((ui.available_height() - 40.0) / 2.0).max(120.0);
    let width = ui.available_width();
    ui.horizontal(|ui| {
        ui.vertical(|ui| {
            ui.set_width(width * 0.5 - 6.0);
            ui.label("acceleration, m/s²");
            Plot::new("acc")
                .height(height / 2.0 - 12.0)
                .legend(Legend::default())
                .show(ui, |p| {
                    for (i, name) in ["X", "Y", "Z"].into_iter().enumerate() {
                        p.line(Line::new(format!("acc {name}"), t.acc[i].points()));
                    }
                });
            ui.label("angular rate, °/s");
            Plot::new("gyro")
                .height(height / 2.0 - 12.0)
                .legend(Legend::default())
                .show(ui, |p| {
                    for (i, name) in ["X", "Y", "Z"].into_iter().enumerate() {
                        p.line(Line::new(format!("gyro {name}"), t.gyro[i].points()));
                    }
                });
        });
        ui.vertical(|ui| {
            ui.label("GNSS track, m east / north of the first fix");
            // At least TRACK_MIN_SPAN_M across: a standing receiver's noise stays small.
            let [lo, hi] = plots::track_bounds(&t.track.points(), plots::TRACK_MIN_SPAN_M);
            Plot::new("track")
                .height(height)
                .data_aspect(1.0)
                .include_x(lo[0])
                .include_x(hi[0])
                .include_y(lo[1])
                .include_y(hi[1])
                .show(ui, |p| {
                    let points = t.track.points();
                    if let Some(last) = points.last().copied() {
                        p.line(Line::new("track", points).width(2.0));
                        p.points(Points::new("robot", vec![last]).radius(5.0));
                    }
                });
        });
    });
    ui.label(format!(
        "ground speed, m/s, and heading of motion, ° / 100 (so both fit; unwrapped across \
         north, drawn above {} m/s)",
        plots::HEADING_MIN_SPEED_M_S
    ));
    Plot::new("speed-heading")
        .height(height)
        .legend(Legend::default())
        .show(ui, |p| {
            // One colour per series: a series broken at gaps is drawn as several lines.
            let (speed_color, heading_color) = (series_color(0), series_color(1));
            let speed = t.speed.points();
            for line in plots::split_at_gaps(&speed, plots::MAX_GAP_S) {
                p.line(Line::new("ground speed m/s", line).color(speed_color));
            }
            let heading = t.heading.points();
            let lines = plots::heading_lines(
                &heading,
                &speed,
                plots::HEADING_MIN_SPEED_M_S,
                plots::MAX_GAP_S,
            );
            for line in lines {
                let scaled: Vec<[f64; 2]> = line.into_iter().map(|[x, y]| [x, y / 100.0]).collect();
                p.line(Line::new("heading °/100", scaled).color(heading_color));
            }
        });
}

/// The colour the plot gives its `index`-th series by default (so a series drawn as several
/// lines keeps one colour).
fn series_color(index: u8) -> egui::Color32 {
    // The golden ratio's fractional part, as egui_plot steps its automatic hues.
    let hue = f32::from(index) * 0.618_034;
    egui::ecolor::Hsva::new(hue.fract(), 0.85, 0.5, 1.0).into()
}
