//! Replay mode's bars: the REPLAY banner with the file at the top (in place of the connection
//! bar) and the timeline at the bottom: play/pause, the speeds, the log time and a slider over
//! the log's duration that seeks on a click or a drag. Keys: P play/pause, Left/Right 5 s,
//! Minus/Plus speed, Home/End.

use std::time::Duration;

use eframe::egui::{self, Color32, Key, RichText};

use super::connection::{GOOD, WARN};
use super::GroundApp;
use crate::replay::clock::SPEEDS;
use crate::replay::source::LogKind;
use crate::replay::Replay;

/// The banner's colour.
const REPLAY: Color32 = Color32::from_rgb(120, 60, 170);
/// Seconds Left/Right skip.
const SKIP_S: f64 = 5.0;
/// The keys, as the timeline shows them.
pub const KEYS: &str = "P play/pause · Left/Right 5 s · -/+ speed · Home/End";

/// The replay keys (only in replay mode: Space, the kill key live, does nothing here).
pub fn keys(ctx: &egui::Context, replay: &mut Replay) {
    let pressed = |key| ctx.input(|i| i.key_pressed(key));
    let clock = replay.clock_mut();
    if pressed(Key::P) {
        clock.toggle();
    }
    if pressed(Key::Minus) {
        clock.slower();
    }
    if pressed(Key::Plus) || pressed(Key::Equals) {
        clock.faster();
    }
    let position = replay.clock().position();
    let duration = replay.clock().duration();
    if pressed(Key::ArrowLeft) {
        replay.seek(position.saturating_sub(Duration::from_secs_f64(SKIP_S)));
    }
    if pressed(Key::ArrowRight) {
        replay.seek(position + Duration::from_secs_f64(SKIP_S));
    }
    if pressed(Key::Home) {
        replay.seek(Duration::ZERO);
    }
    if pressed(Key::End) {
        replay.seek(duration);
    }
}

/// The banner: REPLAY, the file, what kind of log, and the notes.
pub fn top_bar(ui: &mut egui::Ui, app: &GroundApp) {
    let Some(replay) = &app.replay else {
        return;
    };
    let log = replay.log();
    egui::Panel::top("replay-banner").show(ui, |ui| {
        ui.horizontal(|ui| {
            ui.label(
                RichText::new("  REPLAY  ")
                    .size(22.0)
                    .strong()
                    .color(Color32::WHITE)
                    .background_color(REPLAY),
            );
            let name = log.path.file_name().map_or_else(
                || log.path.display().to_string(),
                |n| n.to_string_lossy().into(),
            );
            ui.label(RichText::new(name).size(18.0).strong());
            ui.separator();
            ui.label(match log.kind {
                LogKind::Station => "station session log: the bytes read, decoded again",
                LogKind::Robot => "robot log: the reports it would have sent",
            });
            ui.separator();
            ui.label(RichText::new("nothing is sent, nothing is recorded").color(WARN));
        });
        ui.horizontal(|ui| {
            ui.small(&app.link_note);
            ui.separator();
            ui.small(format!("channel table: {}", app.table_source));
            ui.separator();
            ui.small(match app.telemetry.calibration() {
                Some(c) => format!("calibration: {}", c.source),
                None => {
                    "calibration unknown: magnetometer and barometer raw (--sensor-info)".into()
                }
            });
        });
    });
}

/// The timeline: play/pause, speed, the time and the slider.
pub fn timeline(ui: &mut egui::Ui, app: &mut GroundApp) {
    let Some(replay) = app.replay.as_mut() else {
        return;
    };
    egui::Panel::bottom("replay-timeline").show(ui, |ui| {
        ui.add_space(4.0);
        ui.horizontal(|ui| {
            let playing = replay.clock().is_playing();
            let label = if playing { "Pause" } else { "Play" };
            if ui
                .add(
                    egui::Button::new(RichText::new(label).strong())
                        .min_size(egui::vec2(80.0, 24.0)),
                )
                .on_hover_text("P")
                .clicked()
            {
                replay.clock_mut().toggle();
            }
            ui.separator();
            let speed = replay.clock().speed();
            for s in SPEEDS {
                if ui
                    .selectable_label((s - speed).abs() < 1e-9, format!("{s}×"))
                    .clicked()
                {
                    replay.clock_mut().set_speed(s);
                }
            }
            ui.separator();
            let position = replay.clock().position();
            let duration = replay.clock().duration();
            let state = if playing {
                RichText::new("playing").color(GOOD)
            } else if replay.clock().at_end() {
                RichText::new("end of log").color(WARN)
            } else {
                RichText::new("paused").color(WARN)
            };
            ui.label(state);
            ui.label(
                RichText::new(format!(
                    "{} / {}   ({} UTC)",
                    clock_text(position),
                    clock_text(duration),
                    time_of_day(replay.log().start_ns, position)
                ))
                .monospace()
                .strong(),
            );
            ui.separator();
            ui.small(KEYS);
        });
        let duration_s = replay.clock().duration().as_secs_f64();
        let mut t = replay.clock().position().as_secs_f64();
        ui.spacing_mut().slider_width = ui.available_width() - 16.0;
        let slider = egui::Slider::new(&mut t, 0.0..=duration_s.max(1e-3))
            .show_value(false)
            .trailing_fill(true);
        let response = ui.add(slider);
        if response.changed() {
            replay.seek(Duration::from_secs_f64(t.clamp(0.0, duration_s)));
        }
        mode_band(ui, replay, response.rect);
        ui.add_space(4.0);
    });
}

/// Under the slider's rail, the robot's reported mode along the log, on the mode colours.
fn mode_band(ui: &mut egui::Ui, replay: &Replay, slider: egui::Rect) {
    // Before the first report the band is empty: the mode is not known.
    let (left, right) = (slider.left(), slider.right());
    let y = slider.bottom() + 1.0..=slider.bottom() + 6.0;
    ui.add_space(7.0);
    let duration = replay.clock().duration().as_secs_f64().max(1e-9);
    let x = |t: Duration| left + (right - left) * (t.as_secs_f64() / duration) as f32;
    let modes = &replay.log().modes;
    for (i, (from, mode)) in modes.iter().enumerate() {
        let to = modes.get(i + 1).map_or(replay.clock().duration(), |m| m.0);
        let rect = egui::Rect::from_x_y_ranges(x(*from)..=x(to), y.clone());
        ui.painter()
            .rect_filled(rect, 0.0, super::status::robot_mode_colour(*mode));
    }
}

/// `m:ss.s` (or `h:mm:ss.s`).
fn clock_text(t: Duration) -> String {
    let s = t.as_secs_f64();
    let (h, m, sec) = ((s / 3600.0) as u64, ((s % 3600.0) / 60.0) as u64, s % 60.0);
    if h > 0 {
        format!("{h}:{m:02}:{sec:04.1}")
    } else {
        format!("{m}:{sec:04.1}")
    }
}

/// The UTC time of day of log time `t` in a log that starts at `start_ns` (Unix-epoch ns).
fn time_of_day(start_ns: u64, t: Duration) -> String {
    let ns = start_ns.saturating_add(t.as_nanos() as u64);
    let s = (ns / 1_000_000_000) % 86_400;
    format!("{:02}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_read_as_a_clock() {
        assert_eq!(clock_text(Duration::from_millis(75_300)), "1:15.3");
        assert_eq!(clock_text(Duration::from_secs(3_725)), "1:02:05.0");
        // 2023-11-14 22:13:20 UTC, plus 100 s.
        assert_eq!(
            time_of_day(1_700_000_000_000_000_000, Duration::from_secs(100)),
            "22:15:00"
        );
    }
}
