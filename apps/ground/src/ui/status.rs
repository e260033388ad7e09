//! Link health, the robot's state as the station knows it, and the onboard values in
//! physical units.

use std::time::{Duration, Instant};

use dima_groundlink::CommandType;
use eframe::egui::{self, RichText};

use super::connection::{BAD, GOOD, WARN};
use super::GroundApp;
use crate::link::LinkState;
use crate::robot_view::{expected_mode, ExpectedMode};
use crate::units::{Baro, MagField};

/// A display frame older than this is shown in red.
const STALE: Duration = Duration::from_secs(1);

pub fn bottom_bar(ui: &mut egui::Ui, app: &GroundApp) {
    egui::Panel::bottom("summary").show(ui, |ui| {
        ui.horizontal(|ui| {
            let now = Instant::now();
            let s = &app.status;
            let mode = expected_mode(&s.last_sent);
            ui.label(
                RichText::new(format!("robot: {} (as sent)", mode.label()))
                    .strong()
                    .color(mode_colour(mode)),
            );
            ui.separator();
            match s.frame_age(now) {
                Some(age) => ui.label(
                    RichText::new(format!("last frame {:.1} s ago", age.as_secs_f64()))
                        .color(if age > STALE { BAD } else { GOOD }),
                ),
                None => ui.label(RichText::new("no frame yet").color(BAD)),
            };
            ui.separator();
            ui.label(format!("{:.1} frames/s", s.frames_per_s));
        });
    });
}

fn mode_colour(mode: ExpectedMode) -> egui::Color32 {
    match mode {
        ExpectedMode::Killed | ExpectedMode::KilledAtStart => BAD,
        ExpectedMode::Manual => GOOD,
        ExpectedMode::Auto => WARN,
    }
}

pub fn right_panel(ui: &mut egui::Ui, app: &GroundApp) {
    egui::Panel::right("status")
        .resizable(false)
        .exact_size(360.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                link_health(ui, app);
                ui.separator();
                robot_state(ui, app);
                ui.separator();
                onboard(ui, app);
            });
        });
}

fn link_health(ui: &mut egui::Ui, app: &GroundApp) {
    let s = &app.status;
    let now = Instant::now();
    ui.heading("Link");
    egui::Grid::new("link")
        .num_columns(2)
        .striped(true)
        .show(ui, |ui| {
            let row = |ui: &mut egui::Ui, k: &str, v: RichText| {
                ui.label(k);
                ui.label(v);
                ui.end_row();
            };
            let state = match s.state {
                LinkState::Connected => RichText::new("connected").color(GOOD),
                LinkState::Waiting => RichText::new("waiting / reconnecting").color(WARN),
                LinkState::Disconnected => RichText::new("disconnected").color(BAD),
            };
            row(ui, "state", state);
            let age =
                match s.frame_age(now) {
                    Some(a) => RichText::new(format!("{:.2} s", a.as_secs_f64()))
                        .color(if a > STALE { BAD } else { GOOD }),
                    None => RichText::new("never").color(BAD),
                };
            row(ui, "since last valid frame", age);
            row(
                ui,
                "display frames/s",
                RichText::new(format!("{:.2}", s.frames_per_s)),
            );
            row(ui, "display frames", RichText::new(s.frames_in.to_string()));
            let bad = |n: u64| RichText::new(n.to_string()).color(if n > 0 { WARN } else { GOOD });
            row(ui, "CRC errors", bad(s.crc_errors));
            row(ui, "bytes skipped (resync)", bad(s.skipped_bytes));
            row(ui, "out-of-range frames", bad(s.out_of_range));
            row(
                ui,
                "bytes in / out",
                RichText::new(format!("{} / {}", s.bytes_in, s.bytes_out)),
            );
            row(
                ui,
                "command frames out",
                RichText::new(s.frames_out.to_string()),
            );
            row(ui, "write errors", bad(s.write_errors));
            row(ui, "port opens", RichText::new(s.opens.to_string()));
        });
}

fn robot_state(ui: &mut egui::Ui, app: &GroundApp) {
    let s = &app.status;
    let now = Instant::now();
    ui.heading("Robot state");
    let mode = expected_mode(&s.last_sent);
    ui.label(
        RichText::new(format!("{} as sent", mode.label()))
            .size(18.0)
            .strong()
            .color(mode_colour(mode)),
    );
    ui.small("v1 downlink has no mode or acknowledgement: this follows from what was sent.");
    egui::Grid::new("sent")
        .num_columns(2)
        .striped(true)
        .show(ui, |ui| {
            for kind in [
                CommandType::Kill,
                CommandType::Revive,
                CommandType::Throttle,
                CommandType::Steering,
                CommandType::Tail,
                CommandType::SpeedSetpoint,
                CommandType::HeadingSetpoint,
            ] {
                ui.label(format!("{kind:?}"));
                match s.last_sent[kind as usize] {
                    Some((t, c)) => ui.label(format!(
                        "{} · {:.1} s ago",
                        describe_data(c),
                        now.saturating_duration_since(t).as_secs_f64()
                    )),
                    None => ui.label("never sent"),
                };
                ui.end_row();
            }
        });
    ui.label("came back:");
    match &app.telemetry.latest {
        Some((_, _, p)) => ui.label(format!(
            "ground speed {:.2} m/s, heading {:.1}°",
            p.ground_speed_m_s, p.heading_deg
        )),
        None => ui.label(RichText::new("nothing yet").color(WARN)),
    };
}

fn describe_data(c: dima_groundlink::Command) -> String {
    use dima_groundlink::Command as C;
    match c {
        C::Heartbeat | C::Kill | C::Revive => "sent".into(),
        C::Throttle(p) | C::Steering(p) | C::Tail(p) => format!("{} %", p.get()),
        C::SpeedSetpoint { mm_s } => format!("{:.3} m/s", f64::from(mm_s) / 1000.0),
        C::HeadingSetpoint { deg_e5 } => format!("{:.2}°", f64::from(deg_e5) / 1e5),
    }
}

fn onboard(ui: &mut egui::Ui, app: &GroundApp) {
    ui.heading("Onboard");
    let Some((_, _, p)) = &app.telemetry.latest else {
        ui.label("waiting for a display frame");
        return;
    };
    let xyz = |v: [f32; 3], digits: usize| {
        format!("{:+.d$}  {:+.d$}  {:+.d$}", v[0], v[1], v[2], d = digits)
    };
    egui::Grid::new("onboard")
        .num_columns(3)
        .striped(true)
        .show(ui, |ui| {
            let mut row = |k: &str, v: String, unit: &str| {
                ui.label(k);
                ui.label(RichText::new(v).monospace());
                ui.label(unit);
                ui.end_row();
            };
            row("acceleration X Y Z", xyz(p.acc_m_s2, 2), "m/s²");
            row("angular rate X Y Z", xyz(p.gyro_dps, 1), "°/s");
            match p.mag {
                MagField::MicroTesla(v) => row("magnetic field X Y Z", xyz(v, 1), "µT"),
                MagField::Raw(v, hall) => row(
                    "magnetic field X Y Z",
                    format!("{} {} {} (hall {hall})", v[0], v[1], v[2]),
                    "raw",
                ),
            }
            match p.baro {
                Baro::Compensated {
                    pressure_pa,
                    temperature_c,
                } => {
                    row(
                        "pressure",
                        pressure_pa.map_or("—".into(), |pa| format!("{:.2}", pa / 100.0)),
                        "hPa",
                    );
                    row("temperature", format!("{temperature_c:.2}"), "°C");
                }
                Baro::Raw { adc_p, adc_t } => {
                    row("pressure", adc_p.to_string(), "raw ADC");
                    row("temperature", adc_t.to_string(), "raw ADC");
                }
            }
            row("latitude", format!("{:.7}", p.lat_deg), "°");
            row("longitude", format!("{:.7}", p.lon_deg), "°");
            row(
                "velocity N E D",
                format!(
                    "{:+.2}  {:+.2}  {:+.2}",
                    p.vel_ned_m_s[0], p.vel_ned_m_s[1], p.vel_ned_m_s[2]
                ),
                "m/s",
            );
            row("height (ellipsoid)", format!("{:.2}", p.height_m), "m");
            row("height (MSL)", format!("{:.2}", p.h_msl_m), "m");
            row("ground speed", format!("{:.2}", p.ground_speed_m_s), "m/s");
            row("heading of motion", format!("{:.1}", p.heading_deg), "°");
        });
}
