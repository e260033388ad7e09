//! The gamepad: its section of the driving panel (connected or disconnected, what drives
//! what, a stick waiting for centre) and the "Calibrate joystick" window. The logic is
//! [`GamepadDriver`] and [`CalibrationFlow`]; this only feeds them, draws them and saves the
//! file.

use std::path::PathBuf;
use std::time::Duration;

use dima_groundlink::station::ManualChannel;
use dima_groundlink::Percent;
use eframe::egui::{self, RichText};

use super::connection::{BAD, GOOD, WARN};
use crate::gamepad::{GamepadDriver, GamepadInput, Gamepads, PadStatus};
use crate::joystick::calibration::{to_save, MIN_TRAVEL, STILL_TIME};
use crate::joystick::config::{LoadedConfig, MAX_DEAD_ZONE};
use crate::joystick::{
    AxesSample, AxisCalibration, CalibrationFlow, CalibrationStep, JoystickConfig, PadButton,
    StickAxis,
};

/// The gamepad, its configuration and the calibration window.
pub struct JoystickState {
    config: JoystickConfig,
    /// Where the calibration window saves.
    path: Option<PathBuf>,
    /// Where the configuration came from (or that it was saved).
    note: String,
    gamepads: Gamepads,
    driver: GamepadDriver,
    /// This frame's gamepad input.
    input: GamepadInput,
    /// This frame's raw axes of the gamepad in use.
    raw: Option<AxesSample>,
    window: Option<CalibrationWindow>,
}

/// The calibration window's state.
struct CalibrationWindow {
    flow: CalibrationFlow,
    /// The settings being edited (axes, inversion, dead zone, expo, kill button).
    draft: JoystickConfig,
    /// Why Next or Save did nothing.
    message: Option<String>,
}

impl CalibrationWindow {
    fn new(config: JoystickConfig) -> CalibrationWindow {
        CalibrationWindow {
            flow: CalibrationFlow::new(),
            draft: config,
            message: None,
        }
    }
}

impl JoystickState {
    /// The gamepads read with `loaded`; with `calibrate`, the calibration window open.
    pub fn new(loaded: LoadedConfig, calibrate: bool) -> JoystickState {
        JoystickState {
            window: calibrate.then(|| CalibrationWindow::new(loaded.config)),
            config: loaded.config,
            path: loaded.path,
            note: loaded.note,
            gamepads: Gamepads::new(),
            driver: GamepadDriver::default(),
            input: GamepadInput::default(),
            raw: None,
        }
    }

    /// Reads the gamepad for this frame (`now`: time since start): the kill and the sticks,
    /// each channel around its `neutral`. While the calibration window is open the sticks
    /// feed it and drive nothing.
    pub fn poll(&mut self, neutral: [Percent; 3], now: Duration) -> &GamepadInput {
        let reading = self.gamepads.poll(self.config.kill_button);
        self.raw = reading.pad.as_ref().map(|p| p.axes);
        if let Some(w) = self.window.as_mut() {
            w.flow.sample(self.raw.as_ref(), now);
        }
        self.input = self
            .driver
            .update(&reading, &self.config, neutral, self.window.is_some());
        &self.input
    }
}

/// The gamepad's section of the driving panel.
pub fn gamepad_section(ui: &mut egui::Ui, joystick: &mut JoystickState) {
    ui.heading("Gamepad");
    match (&joystick.input.status, joystick.gamepads.unavailable()) {
        (_, Some(why)) => {
            ui.label(RichText::new(format!("unavailable: {why}")).color(WARN));
        }
        (PadStatus::Connected(name), None) => {
            ui.label(RichText::new(format!("{name}: connected")).color(GOOD));
        }
        (PadStatus::Disconnected(name), None) => {
            ui.label(
                RichText::new(format!(
                    "{name}: DISCONNECTED (its channels went to neutral)"
                ))
                .color(BAD),
            );
        }
        (PadStatus::NoneConnected, None) => {
            ui.label("none connected");
        }
    }
    ui.small(mapping(&joystick.config));
    for (i, channel) in ManualChannel::ALL.into_iter().enumerate() {
        if joystick.input.waiting_for_centre[i] {
            ui.label(
                RichText::new(format!(
                    "{}: let the stick go to centre before it drives",
                    channel.name()
                ))
                .color(WARN),
            );
        }
    }
    ui.small(format!("joystick configuration: {}", joystick.note));
    if joystick.window.is_some() {
        ui.label(RichText::new("calibrating: the gamepad drives nothing").color(WARN));
    } else if ui.button("Calibrate joystick…").clicked() {
        joystick.window = Some(CalibrationWindow::new(joystick.config));
    }
}

/// "throttle LeftStickY, steering RightStickX inverted expo 0.30, tail none; kill South".
fn mapping(config: &JoystickConfig) -> String {
    let channels: Vec<String> = ManualChannel::ALL
        .into_iter()
        .map(|c| {
            let a = config.channel(c);
            let mut text = format!("{} {}", c.name(), a.axis.map_or("none", StickAxis::name));
            if a.axis.is_some() && a.invert {
                text.push_str(" inverted");
            }
            if a.axis.is_some() && a.expo > 0.0 {
                text.push_str(&format!(" expo {:.2}", a.expo));
            }
            text
        })
        .collect();
    format!("{}; kill {}", channels.join(", "), config.kill_button)
}

/// The "Calibrate joystick" window, when open.
pub fn calibration_window(ctx: &egui::Context, joystick: &mut JoystickState) {
    let Some(window) = joystick.window.as_mut() else {
        return;
    };
    let mut open = true;
    let mut saved = None;
    egui::Window::new("Calibrate joystick")
        .open(&mut open)
        .collapsible(false)
        .resizable(false)
        .default_width(560.0)
        // Over the plots, never over the kill button.
        .pivot(egui::Align2::CENTER_CENTER)
        .default_pos(ctx.content_rect().center())
        .show(ctx, |ui| {
            if joystick.raw.is_none() {
                ui.label(RichText::new("No gamepad connected: connect one.").color(WARN));
            }
            steps(ui, window);
            ui.separator();
            axes_table(ui, window, joystick.raw.as_ref());
            ui.separator();
            settings(ui, &mut window.draft, joystick.raw.as_ref());
            ui.separator();
            saved = save_row(ui, window, joystick.path.as_ref());
        });
    if let Some((config, note)) = saved {
        joystick.config = config;
        joystick.note = note;
        joystick.window = None;
    } else if !open {
        joystick.window = None;
    }
}

/// What to do now, and Next / Start again.
fn steps(ui: &mut egui::Ui, window: &mut CalibrationWindow) {
    match window.flow.step().clone() {
        CalibrationStep::MoveToEnds => {
            ui.label(RichText::new("1. Move every stick to all its ends").strong());
            ui.label(format!(
                "Full circles with each stick (each axis a channel uses must travel at least \
                 {MIN_TRAVEL:.1}), then Next."
            ));
            if ui.button("Next").clicked() {
                window.message = window.flow.next(&window.draft).err();
            }
        }
        CalibrationStep::ReleaseToCentre => {
            ui.label(RichText::new("2. Let go of every stick").strong());
            ui.label(format!(
                "Hands off: the centre is taken once every axis has rested for {:.0} s.",
                STILL_TIME.as_secs_f32()
            ));
        }
        CalibrationStep::Done => {
            ui.label(RichText::new("3. Measured").strong().color(GOOD));
            ui.label("Check the ends and centres below, then Save.");
        }
        CalibrationStep::Failed(why) => {
            ui.label(RichText::new(format!("Stopped: {why}")).color(BAD));
        }
    }
    if window.flow.step() != &CalibrationStep::MoveToEnds && ui.button("Start again").clicked() {
        window.flow.restart();
        window.message = None;
    }
}

/// Per axis the gamepad has: the channel using it, the raw value, the travel and the centre.
fn axes_table(ui: &mut egui::Ui, window: &CalibrationWindow, raw: Option<&AxesSample>) {
    egui::Grid::new("calibration-axes")
        .num_columns(5)
        .striped(true)
        .show(ui, |ui| {
            for heading in ["axis", "channel", "now", "travel", "centre"] {
                ui.label(RichText::new(heading).strong());
            }
            ui.end_row();
            for axis in StickAxis::ALL {
                let value = raw.and_then(|r| axis.value_in(r));
                let travel = window.flow.travel(axis);
                let channel = ManualChannel::ALL
                    .into_iter()
                    .find(|c| window.draft.channel(*c).axis == Some(axis));
                if value.is_none() && travel.is_none() && channel.is_none() {
                    continue;
                }
                ui.label(RichText::new(axis.name()).monospace());
                ui.label(channel.map_or("", ManualChannel::name));
                ui.add(
                    egui::ProgressBar::new(value.map_or(0.0, |v| (v + 1.0) / 2.0))
                        .desired_width(120.0)
                        .text(value.map_or("—".to_owned(), |v| format!("{v:+.2}"))),
                );
                match travel {
                    Some(t) => {
                        let enough = t.span() >= MIN_TRAVEL;
                        let text = format!("{:+.2} .. {:+.2}", t.min, t.max);
                        let colour = if enough || channel.is_none() {
                            ui.visuals().text_color()
                        } else {
                            WARN
                        };
                        ui.label(RichText::new(text).color(colour).monospace());
                    }
                    None => {
                        ui.label("—");
                    }
                }
                ui.label(
                    window
                        .flow
                        .centre(axis)
                        .map_or("—".to_owned(), |c| format!("{c:+.3}")),
                );
                ui.end_row();
            }
        });
}

/// The draft's axes, inversion, dead zone, expo and kill button, with what each channel's
/// stick gives with them now.
fn settings(ui: &mut egui::Ui, draft: &mut JoystickConfig, raw: Option<&AxesSample>) {
    egui::Grid::new("calibration-settings")
        .num_columns(6)
        .show(ui, |ui| {
            for heading in ["channel", "axis", "invert", "dead zone", "expo", "output"] {
                ui.label(RichText::new(heading).strong());
            }
            ui.end_row();
            for channel in ManualChannel::ALL {
                let a: &mut AxisCalibration = draft.channel_mut(channel);
                ui.label(channel.name());
                egui::ComboBox::from_id_salt(("axis", channel.name()))
                    .selected_text(a.axis.map_or("none", StickAxis::name))
                    .show_ui(ui, |ui| {
                        ui.selectable_value(&mut a.axis, None, "none");
                        for axis in StickAxis::ALL {
                            ui.selectable_value(&mut a.axis, Some(axis), axis.name());
                        }
                    });
                ui.checkbox(&mut a.invert, "");
                ui.add(egui::Slider::new(&mut a.dead_zone, 0.0..=MAX_DEAD_ZONE).fixed_decimals(2));
                ui.add(egui::Slider::new(&mut a.expo, 0.0..=1.0).fixed_decimals(2));
                let output = match (a.axis, raw) {
                    (None, _) | (_, None) => "—".to_owned(),
                    (Some(_), Some(r)) => a
                        .read(r)
                        .map_or("released".to_owned(), |x| format!("{x:+.2}")),
                };
                ui.label(RichText::new(output).monospace());
                ui.end_row();
            }
        });
    ui.horizontal(|ui| {
        ui.label("kill button");
        egui::ComboBox::from_id_salt("kill-button")
            .selected_text(draft.kill_button.name())
            .show_ui(ui, |ui| {
                for button in PadButton::ALL {
                    ui.selectable_value(&mut draft.kill_button, button, button.name());
                }
            });
    });
    ui.small("expo e: out = (1 - e)·x + e·x³ (0 linear; more is gentler around centre)");
}

/// Save (the measured calibration, or only the settings before it is measured) and where;
/// the saved configuration and a note once saved.
fn save_row(
    ui: &mut egui::Ui,
    window: &mut CalibrationWindow,
    path: Option<&PathBuf>,
) -> Option<(JoystickConfig, String)> {
    let measured = window.flow.step() == &CalibrationStep::Done;
    let mut saved = None;
    ui.horizontal(|ui| {
        let label = if measured {
            "Save calibration"
        } else {
            "Save settings only"
        };
        let button = ui.add_enabled(path.is_some(), egui::Button::new(label));
        match path {
            Some(p) => ui.small(format!("to {}", p.display())),
            None => ui.small("no configuration directory: start with --config FILE"),
        };
        if let (true, Some(path)) = (button.clicked(), path) {
            let origin = path.display().to_string();
            match to_save(&window.flow, &window.draft, &origin)
                .and_then(|c| c.save(path).map(|()| c).map_err(|e| e.to_string()))
            {
                Ok(c) => saved = Some((c, format!("{origin} (saved)"))),
                Err(e) => window.message = Some(e),
            }
        }
    });
    if let Some(m) = &window.message {
        ui.label(RichText::new(m).color(BAD));
    }
    saved
}
