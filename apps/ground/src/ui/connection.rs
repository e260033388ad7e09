//! The connection bar: port picker (refreshed on demand, or a typed path for a pty), baud
//! rate, connect/disconnect, automatic reconnect, and where the session is recorded.

use std::path::PathBuf;

use eframe::egui::{self, Color32, RichText};

use super::{ConnectionForm, GroundApp};
use crate::downlink::Severity;
use crate::link::{LinkControl, LinkState, LinkStatus};
use crate::serial::{list_ports, COMMON_BAUDS};

/// Colour of a healthy state.
pub const GOOD: Color32 = Color32::from_rgb(60, 180, 90);
/// Colour of a warning.
pub const WARN: Color32 = Color32::from_rgb(230, 160, 40);
/// Colour of a fault.
pub const BAD: Color32 = Color32::from_rgb(220, 50, 50);

/// The connection bar: the port, the baud rate and the link's state on the first row; the
/// link version, the recording, the simulated robot, the channel table and the calibration
/// on the second.
pub fn top_bar(ui: &mut egui::Ui, app: &mut GroundApp) {
    egui::Panel::top("connection").show(ui, |ui| {
        ui.horizontal_wrapped(|ui| {
            ui.label(RichText::new("DIMA ground station").strong());
            ui.separator();
            ui.label("Port");
            port_and_baud(ui, &mut app.connection);
            connect_controls(ui, app);
            ui.separator();
            link_state(ui, &app.status);
        });
        ui.horizontal_wrapped(|ui| notes(ui, app));
    });
}

/// The port list (with its refresh button), the typed path and the baud rate.
fn port_and_baud(ui: &mut egui::Ui, form: &mut ConnectionForm) {
    egui::ComboBox::from_id_salt("port-list")
        .selected_text("serial ports")
        .width(120.0)
        .show_ui(ui, |ui| {
            if form.ports.is_empty() {
                ui.label("none found (type a path)");
            }
            for p in &form.ports {
                let text = p.display().to_string();
                if ui.selectable_label(form.path_text == text, &text).clicked() {
                    form.path_text = text;
                }
            }
        });
    if ui
        .button("Refresh")
        .on_hover_text("refresh the list of serial ports")
        .clicked()
    {
        form.ports = list_ports();
    }
    ui.add(
        egui::TextEdit::singleline(&mut form.path_text)
            .hint_text("/dev/ttyUSB0 or a pty path")
            .desired_width(260.0),
    );
    egui::ComboBox::from_id_salt("baud")
        .selected_text(format!("{} baud", form.baud))
        .width(100.0)
        .show_ui(ui, |ui| {
            for b in COMMON_BAUDS {
                ui.selectable_value(&mut form.baud, b, b.to_string());
            }
        });
}

/// Connect or Disconnect, and the automatic reconnect.
fn connect_controls(ui: &mut egui::Ui, app: &mut GroundApp) {
    let form = &mut app.connection;
    let chosen = app.status.state != LinkState::Disconnected;
    if chosen {
        if ui.button("Disconnect").clicked() {
            app.link.send(LinkControl::Disconnect);
        }
    } else {
        let path = form.path_text.trim();
        let clicked = ui
            .add_enabled(!path.is_empty(), egui::Button::new("Connect"))
            .clicked();
        if clicked {
            app.link.send(LinkControl::Connect {
                path: PathBuf::from(path),
                baud: form.baud,
            });
        }
    }
    if ui
        .checkbox(&mut form.auto_reconnect, "reconnect")
        .on_hover_text("reopen the port every second when it goes away")
        .changed()
    {
        app.link
            .send(LinkControl::AutoReconnect(form.auto_reconnect));
    }
}

/// The link's state in its colour: connected, waiting for the port (and why), or not.
fn link_state(ui: &mut egui::Ui, status: &LinkStatus) {
    let port = || {
        status
            .port
            .as_ref()
            .map_or(String::new(), |p| p.display().to_string())
    };
    let (text, colour) = match status.state {
        LinkState::Connected => (format!("connected: {} @ {}", port(), status.baud), GOOD),
        LinkState::Waiting => (
            format!(
                "waiting for {}{}",
                port(),
                status
                    .last_error
                    .as_ref()
                    .map_or(String::new(), |e| format!(" ({e})"))
            ),
            WARN,
        ),
        LinkState::Disconnected => ("not connected".to_owned(), BAD),
    };
    ui.label(RichText::new(text).color(colour));
}

/// The second row: the link version and key (green only while authentic reports arrive),
/// the recording, the simulated robot, the channel table and the calibration.
fn notes(ui: &mut egui::Ui, app: &GroundApp) {
    // Green only while authentic reports arrive: a key file alone proves nothing.
    let health = app.status.downlink(app.now());
    let colour = match health.severity() {
        Severity::Good => GOOD,
        _ if app.status.authenticated => BAD,
        _ => WARN,
    };
    ui.small(RichText::new(&app.link_note).color(colour));
    ui.separator();
    ui.small(&app.recording_note);
    if let Some(note) = &app.sim_note {
        ui.separator();
        ui.small(note);
    }
    ui.separator();
    ui.small(format!("channel table: {}", app.table_source));
    ui.separator();
    ui.small(match app.telemetry.calibration() {
        Some(c) => format!("calibration: {}", c.source),
        None => "calibration unknown: magnetometer and barometer raw (--sensor-info)".into(),
    });
}
