//! The driving panel: kill, revive, the manual sliders (what the operator asks for) with the
//! servo targets the robot reports it commanded, control-mode setpoints with the setpoints the
//! robot reports it follows, the gamepad and the keys. The drive controls are greyed while the
//! robot is not live (no fresh report, or KILLED/FAILSAFE).

use dima_groundlink::station::ManualChannel;
use dima_groundlink::{Command, Percent};

use eframe::egui::{self, Color32, RichText};

use super::connection::{BAD, GOOD, WARN};
use super::GroundApp;
use crate::control::Source;
use crate::keys::REVIVE_HOLD;
use crate::link::LinkControl;
use crate::robot_view::{slider_text, Liveness, Truth};
use crate::units::{heading_setpoint_deg_e5, speed_setpoint_mm_s};

pub fn left_panel(ui: &mut egui::Ui, app: &mut GroundApp) {
    egui::Panel::left("drive")
        .resizable(false)
        .exact_size(330.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                // A replay sends nothing: every control disabled.
                let replaying = app.replay.is_some();
                if !replaying {
                    kill_and_revive(ui, app);
                    ui.separator();
                }
                // Drive controls act only while the robot is live: greyed otherwise.
                let liveness = Liveness::of(&app.status, app.now());
                if replaying {
                    ui.label(RichText::new("REPLAY: the controls send nothing").color(WARN));
                } else if let Some(why) = liveness.why_greyed() {
                    ui.label(RichText::new(why).color(WARN));
                }
                let live = liveness.is_live() && !replaying;
                ui.add_enabled_ui(live, |ui| manual(ui, app));
                ui.separator();
                ui.add_enabled_ui(live, |ui| setpoints(ui, app));
                robot_setpoints(ui, app);
                if !replaying {
                    ui.separator();
                    gamepad(ui, app);
                    ui.separator();
                    keys_legend(ui, app);
                }
            });
        });
}

fn kill_and_revive(ui: &mut egui::Ui, app: &mut GroundApp) {
    let kill = egui::Button::new(
        RichText::new("KILL  (Space)")
            .size(26.0)
            .strong()
            .color(Color32::WHITE),
    )
    .fill(BAD)
    .min_size(egui::vec2(ui.available_width(), 56.0));
    if ui.add(kill).clicked() {
        app.kill();
    }
    if app.status.killing {
        ui.label(RichText::new("sending kill (repeated for 1 s)").color(BAD));
    }
    ui.horizontal(|ui| {
        if ui
            .add(egui::Button::new("Revive…").min_size(egui::vec2(90.0, 28.0)))
            .on_hover_text("asks for confirmation; or hold R for one second")
            .clicked()
        {
            app.confirm_revive = true;
        }
        let progress = egui::ProgressBar::new(app.revive_progress)
            .desired_width(ui.available_width())
            .text(if app.revive_progress > 0.0 {
                format!(
                    "R held {:.1} s",
                    app.revive_progress * REVIVE_HOLD.as_secs_f32()
                )
            } else {
                "hold R 1 s to revive".to_owned()
            });
        ui.add(progress);
    });
}

/// The Revive button's confirmation.
pub fn revive_confirmation(ctx: &egui::Context, app: &mut GroundApp) {
    if !app.confirm_revive {
        return;
    }
    let modal = egui::Modal::new(egui::Id::unique("confirm-revive")).show(ctx, |ui| {
        ui.heading("Revive the robot?");
        ui.label("It leaves KILLED/FAILSAFE and follows manual commands.");
        ui.horizontal(|ui| {
            if ui
                .button(RichText::new("Revive").color(GOOD).strong())
                .clicked()
            {
                app.revive();
                app.confirm_revive = false;
            }
            if ui.button("Cancel").clicked() {
                app.confirm_revive = false;
            }
        });
    });
    if modal.should_close() {
        app.confirm_revive = false;
    }
}

fn manual(ui: &mut egui::Ui, app: &mut GroundApp) {
    ui.heading("Manual");
    let now = app.now();
    let truth = Truth::of(&app.status, now);
    for (i, channel) in ManualChannel::ALL.into_iter().enumerate() {
        let mut value = app.manual.shown[i].get();
        let readout = slider_text(truth, i);
        let holder = match app.manual.holder(channel) {
            Some(Source::Key) => " (key)",
            Some(Source::Gamepad) => " (gamepad)",
            Some(Source::Slider) => " (slider)",
            None => "",
        };
        ui.label(format!("{}{holder}", channel.name()));
        ui.horizontal(|ui| {
            let r = ui.add(egui::Slider::new(&mut value, 0..=100).suffix(" %"));
            ui.label(RichText::new(readout).monospace());
            let v = Percent::new(value).unwrap_or(Percent::HALF);
            app.slider_dragged[i] = r.dragged().then_some(v);
            if r.changed() && !r.dragged() {
                if let Some(request) = app.manual.set(channel, v) {
                    app.link.send(request);
                }
            }
        });
    }
    ui.small(
        "After a kill, a revive or the robot failing safe the sliders return to neutral: \
         let go of a key, stick or slider and move it again to drive.",
    );
    if ui
        .button("Centre all")
        .on_hover_text("send each channel's neutral")
        .clicked()
    {
        for c in ManualChannel::ALL {
            let n = app.manual.neutral(c);
            if let Some(request) = app.manual.set(c, n) {
                app.link.send(request);
            }
        }
    }
}

fn setpoints(ui: &mut egui::Ui, app: &mut GroundApp) {
    ui.heading("Control mode");
    let form = &mut app.setpoints;
    let mut sent = None;
    egui::Grid::new("setpoints").num_columns(3).show(ui, |ui| {
        ui.label("speed");
        let max_m_s = f64::from(app.table.max_speed_mm_s) / 1000.0;
        ui.add(
            egui::DragValue::new(&mut form.speed_m_s)
                .speed(0.05)
                .range(0.0..=max_m_s)
                .suffix(" m/s"),
        )
        .on_hover_text(format!(
            "AUTO is forward-only, up to {max_m_s:.1} m/s (control.max_speed_mm_s)"
        ));
        if ui.button("Send speed").clicked() {
            sent = Some(
                speed_setpoint_mm_s(form.speed_m_s).map(|mm_s| Command::SpeedSetpoint { mm_s }),
            );
        }
        ui.end_row();
        ui.label("heading");
        ui.add(
            egui::DragValue::new(&mut form.heading_deg)
                .speed(1.0)
                .range(0.0..=359.99)
                .suffix(" °"),
        );
        if ui.button("Send heading").clicked() {
            sent = Some(
                heading_setpoint_deg_e5(form.heading_deg)
                    .map(|deg_e5| Command::HeadingSetpoint { deg_e5 }),
            );
        }
        ui.end_row();
    });
    match sent {
        Some(Ok(command)) => {
            form.message = Some(format!("sent {command:?}"));
            app.link.send(LinkControl::Request(command));
        }
        Some(Err(e)) => form.message = Some(format!("not sent: {e}")),
        None => {}
    }
    if let Some(m) = &app.setpoints.message {
        ui.small(m);
    }
    ui.small("A setpoint switches MANUAL to AUTO; any manual command switches back.");
}

/// What the robot reports it follows: its setpoints (or none), estimates, controllers.
fn robot_setpoints(ui: &mut egui::Ui, app: &GroundApp) {
    let truth = Truth::of(&app.status, app.now());
    ui.label(RichText::new("the robot reports").strong());
    egui::Grid::new("robot-setpoints")
        .num_columns(2)
        .striped(true)
        .show(ui, |ui| {
            for (k, v) in [
                ("speed setpoint", truth.speed_setpoint_text()),
                ("heading setpoint", truth.heading_setpoint_text()),
                ("speed (estimate)", truth.speed_estimate_text()),
                ("heading (estimate)", truth.heading_estimate_text()),
                ("speed error", truth.speed_error_text()),
            ] {
                ui.label(k);
                let colour = reported_colour(&truth, &v);
                ui.label(RichText::new(v).monospace().color(colour));
                ui.end_row();
            }
        });
    // On a line of its own, wrapped: three controller names do not fit beside a label.
    let controllers = truth.controllers_text();
    ui.add(
        egui::Label::new(
            RichText::new(format!("controllers: {controllers}"))
                .monospace()
                .color(reported_colour(&truth, &controllers)),
        )
        .wrap(),
    );
}

/// Green only for a fresh value; amber for none, unknown or old.
fn reported_colour(truth: &Truth, value: &str) -> egui::Color32 {
    if matches!(truth, Truth::Fresh(_)) && value != "none" {
        GOOD
    } else {
        WARN
    }
}

fn gamepad(ui: &mut egui::Ui, app: &mut GroundApp) {
    super::joystick::gamepad_section(ui, &mut app.joystick);
}

fn keys_legend(ui: &mut egui::Ui, app: &GroundApp) {
    ui.heading("Keys");
    let step = app.keyboard.step();
    egui::Grid::new("keys")
        .num_columns(2)
        .striped(true)
        .show(ui, |ui| {
            for (keys, what) in [
                ("Space", "KILL (always)".to_owned()),
                ("R held 1 s", "revive".to_owned()),
                ("Up / W, Down / S", format!("throttle ±{step} % while held")),
                (
                    "Right / D, Left / A",
                    format!("steering ±{step} % while held"),
                ),
                ("E, Q", format!("tail ±{step} % while held")),
            ] {
                ui.label(RichText::new(keys).monospace());
                ui.label(what);
                ui.end_row();
            }
        });
}
