//! The alert banner: the most urgent alert ([`crate::alerts`]) across the window on its own
//! colour, under the connection bar.

use eframe::egui::{self, Color32, RichText};

use super::GroundApp;
use crate::alerts::Alert;

/// The banner's background and text colours for `alert`.
pub fn colours(alert: &Alert) -> (Color32, Color32) {
    match alert {
        Alert::LinkLost => (Color32::from_rgb(150, 40, 170), Color32::WHITE),
        Alert::Failsafe(_) => (Color32::from_rgb(235, 110, 20), Color32::BLACK),
        Alert::ReviveRefused(_) => (Color32::from_rgb(240, 200, 40), Color32::BLACK),
        Alert::Killed => (Color32::from_rgb(200, 30, 30), Color32::WHITE),
        Alert::LinkRegained => (Color32::from_rgb(60, 170, 90), Color32::BLACK),
    }
}

pub fn banner(ui: &mut egui::Ui, app: &GroundApp) {
    let Some(alert) = app.banner() else {
        return;
    };
    let (fill, text) = colours(&alert);
    egui::Panel::top("alert")
        .frame(egui::Frame::new().fill(fill).inner_margin(8.0))
        .show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.label(RichText::new(alert.text()).size(24.0).strong().color(text));
                let sound = if app.sounder.muted() {
                    "sound muted (--mute)".to_owned()
                } else if app.sounder.skipped() > 0 {
                    format!("no sound ({} skipped)", app.sounder.skipped())
                } else {
                    String::new()
                };
                if !sound.is_empty() {
                    ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                        ui.label(RichText::new(sound).small().color(text));
                    });
                }
            });
        });
}
