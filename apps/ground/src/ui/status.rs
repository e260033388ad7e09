//! Link health, the robot's state (v2: as the robot reports it in authentic display frames;
//! otherwise why it is unknown), and the onboard values in physical units. The station never
//! shows its own intent as the robot's mode.

use std::time::{Duration, Instant};

use dima_groundlink::station::{CommandStatus, Delivery};
use dima_groundlink::v2::{Health, RobotMode};
use dima_groundlink::CommandType;
use eframe::egui::{self, Color32, RichText};

use super::connection::{BAD, GOOD, WARN};
use super::GroundApp;
use crate::downlink::{DownlinkHealth, Severity};
use crate::link::{station_time, LinkState, LinkStatus, RobotReport, UplinkView};
use crate::recording::{cause_name, mode_name, overrun_advice, refusal_name};
use crate::units::{Baro, MagField};

/// Colour of AUTO (the controllers drive).
const AUTO: Color32 = Color32::from_rgb(70, 130, 230);
/// Colour of FAILSAFE.
const FAILSAFE: Color32 = Color32::from_rgb(235, 110, 20);

/// A display frame older than this is shown in red.
const STALE: Duration = Duration::from_secs(1);

pub fn bottom_bar(ui: &mut egui::Ui, app: &GroundApp) {
    egui::Panel::bottom("summary").show(ui, |ui| {
        ui.horizontal(|ui| {
            let now = app.now();
            let s = &app.status;
            match s.fresh_report(now) {
                Some(r) => {
                    ui.label(
                        RichText::new(format!("robot: {}", mode_name(r.mode)))
                            .strong()
                            .color(robot_mode_colour(r.mode)),
                    );
                    if let Some(last) = s.uplink.as_ref().and_then(|u| u.last_command.as_ref()) {
                        ui.separator();
                        let refused = if last.accepted_but_refused {
                            ", refused"
                        } else {
                            ""
                        };
                        ui.label(
                            RichText::new(format!(
                                "{}: {}{refused}",
                                describe_command(last.command),
                                last.delivery.label()
                            ))
                            .color(status_colour(last)),
                        );
                    }
                }
                None => {
                    let health = s.downlink(now);
                    ui.label(
                        RichText::new(format!("robot: {}", health.short()))
                            .strong()
                            .color(problem_colour(health)),
                    );
                    if !s.authenticated {
                        ui.separator();
                        ui.label(RichText::new("not authenticated (v1)").color(WARN));
                    }
                }
            }
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

pub(super) fn robot_mode_colour(mode: RobotMode) -> Color32 {
    match mode {
        RobotMode::Killed => BAD,
        RobotMode::Manual => GOOD,
        RobotMode::Auto => AUTO,
        RobotMode::Failsafe => FAILSAFE,
    }
}

/// The colour of a command's line: its delivery's, amber for a revive the robot accepted but
/// refused (acknowledged, and still KILLED or FAILSAFE).
fn status_colour(status: &CommandStatus) -> Color32 {
    if status.accepted_but_refused {
        WARN
    } else {
        delivery_colour(status.delivery)
    }
}

fn delivery_colour(delivery: Delivery) -> Color32 {
    match delivery {
        Delivery::Acknowledged { .. } => GOOD,
        Delivery::Pending => WARN,
        Delivery::Unacknowledged | Delivery::RobotRestarted => BAD,
        Delivery::Superseded
        | Delivery::Cancelled
        | Delivery::CancelledByRevive
        | Delivery::CancelledRobotSafe => Color32::GRAY,
    }
}

/// The colour of a downlink that gives no mode: amber or red, never green.
fn problem_colour(health: DownlinkHealth) -> Color32 {
    match health.severity() {
        Severity::Good | Severity::Warning => WARN,
        Severity::Fault => BAD,
    }
}

/// Why the robot's state is unknown, large, in place of its mode.
fn health_banner(ui: &mut egui::Ui, health: DownlinkHealth) {
    let text = RichText::new(health.text())
        .size(18.0)
        .strong()
        .color(problem_colour(health));
    ui.add(egui::Label::new(text).wrap());
}

pub fn right_panel(ui: &mut egui::Ui, app: &GroundApp) {
    egui::Panel::right("status")
        .resizable(false)
        .exact_size(360.0)
        .show(ui, |ui| {
            // Scrolls both ways: content wider than the panel must never widen it, since a
            // right panel's overflow is taken from the middle of the window.
            egui::ScrollArea::both().show(ui, |ui| {
                link_health(ui, app);
                ui.separator();
                if app.status.authenticated {
                    robot_report(ui, &app.status, app.now());
                } else {
                    robot_state(ui, app);
                }
                ui.separator();
                onboard(ui, app);
            });
        });
}

fn link_health(ui: &mut egui::Ui, app: &GroundApp) {
    let s = &app.status;
    let now = app.now();
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
            let health = s.downlink(now);
            row(
                ui,
                "protocol",
                match (s.authenticated, health) {
                    (true, DownlinkHealth::Authentic) => {
                        RichText::new("v2, authenticated").color(GOOD)
                    }
                    (true, _) => RichText::new("v2: no authentic frame").color(BAD),
                    (false, _) => RichText::new("not authenticated (v1)").color(WARN),
                },
            );
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
            if s.authenticated {
                let l = &s.loss;
                let pct =
                    |f: Option<f64>| f.map_or("-".to_owned(), |f| format!("{:.0} %", 100.0 * f));
                let colour = match l.recent_fraction() {
                    Some(f) if f > 0.2 => BAD,
                    Some(f) if f > 0.0 => WARN,
                    _ => GOOD,
                };
                // Two short rows: one long value would widen the panel past its size.
                row(
                    ui,
                    "downlink loss, recent",
                    RichText::new(pct(l.recent_fraction())).color(colour),
                );
                row(
                    ui,
                    "downlink loss, total",
                    RichText::new(format!(
                        "{} ({} of {})",
                        pct(l.total_fraction()),
                        l.lost,
                        l.lost + l.received
                    ))
                    .color(colour),
                );
            }
            let bad = |n: u64| RichText::new(n.to_string()).color(if n > 0 { WARN } else { GOOD });
            if s.authenticated {
                row(ui, "frames rejected (bad tag)", bad(s.bad_tag));
            } else {
                row(ui, "CRC errors", bad(s.crc_errors));
            }
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
    let now = app.now();
    ui.heading("Robot");
    health_banner(ui, s.downlink(now));
    ui.small(
        "Ground link v1 brings no mode and no acknowledgement back (--key-file for v2). \
         Below: what this station sent, not the robot's state.",
    );
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

/// The robot's report (v2): mode, causes, acknowledgements, health and rejections.
fn robot_report(ui: &mut egui::Ui, s: &LinkStatus, now: Instant) {
    ui.heading("Robot");
    report_mode(ui, s, now);
    let Some(r) = &s.robot else {
        ui.label(
            RichText::new("no authenticated display frame yet: only Kill can be sent").color(WARN),
        );
        if let Some(u) = &s.uplink {
            last_command(ui, u, now);
        }
        return;
    };
    report_causes(ui, r);
    if let Some(u) = &s.uplink {
        last_command(ui, u, now);
        uplink_grid(ui, r, u);
    }
    report_health(ui, &r.health);
}

/// The mode while the report is fresh; otherwise the link's health and what the last
/// authentic report said (not the robot's state now).
fn report_mode(ui: &mut egui::Ui, s: &LinkStatus, now: Instant) {
    match s.fresh_report(now) {
        Some(r) => mode_badge(ui, r, now),
        None => {
            health_banner(ui, s.downlink(now));
            if let Some(r) = &s.robot {
                let age = now.saturating_duration_since(r.at).as_secs_f64();
                ui.label(
                    RichText::new(format!(
                        "last authentic report {age:.1} s ago said {}: not its state now",
                        mode_name(r.mode)
                    ))
                    .color(WARN),
                );
            }
        }
    }
}

/// Why the robot is in FAILSAFE, and why its last revive was refused.
fn report_causes(ui: &mut egui::Ui, r: &RobotReport) {
    if let Some(cause) = r.failsafe_cause {
        ui.label(RichText::new(format!("failsafe cause: {}", cause_name(cause))).color(FAILSAFE));
    }
    if let Some(refusal) = r.revive_refusal {
        ui.label(
            RichText::new(format!("last revive refused: {}", refusal_name(refusal))).color(WARN),
        );
    }
    if let Some(advice) = overrun_advice(r.failsafe_cause, r.revive_refusal) {
        ui.label(RichText::new(advice).color(WARN));
    }
}

/// Session, sequence numbers and the station's delivery counters.
fn uplink_grid(ui: &mut egui::Ui, r: &RobotReport, u: &UplinkView) {
    let rows = [
        [
            ("session", format!("{:08X}", r.session)),
            ("ack seq", r.ack_seq.to_string()),
        ],
        [
            ("next seq", u.next_seq.to_string()),
            ("re-sends", u.stats.resends.to_string()),
        ],
        [
            ("acknowledged", u.stats.acknowledged.to_string()),
            ("given up", u.stats.unacknowledged.to_string()),
        ],
        [
            ("held back", u.stats.held_back.to_string()),
            ("old frames", u.stats.old_display_frames.to_string()),
        ],
    ];
    egui::Grid::new("uplink")
        .num_columns(4)
        .striped(true)
        .show(ui, |ui| {
            for row in rows {
                for (k, v) in row {
                    ui.label(k);
                    ui.label(RichText::new(v).monospace());
                }
                ui.end_row();
            }
        });
}

/// The robot's health counters and the command frames it rejected.
fn report_health(ui: &mut egui::Ui, h: &Health) {
    ui.label(RichText::new("health").strong());
    counters(
        ui,
        "health",
        &[
            ("missed periods", h.missed_periods),
            ("commands accepted", h.commands),
            ("sensor bad", h.sensor_bad),
            ("sensor missing", h.sensor_missing),
        ],
        &["commands accepted"],
    );
    ui.label(RichText::new("command frames the robot rejected").strong());
    counters(
        ui,
        "rejections",
        &[
            ("bad tag", h.bad_tag),
            ("replayed", h.replayed),
            ("stale session", h.stale_session),
            ("malformed", h.malformed),
            ("v1 ignored", h.v1_ignored),
        ],
        &[],
    );
}

/// The mode, large, on its colour.
fn mode_badge(ui: &mut egui::Ui, r: &RobotReport, now: Instant) {
    ui.horizontal(|ui| {
        let text = RichText::new(format!(" {} ", mode_name(r.mode)))
            .size(24.0)
            .strong()
            .color(Color32::WHITE)
            .background_color(robot_mode_colour(r.mode));
        ui.label(text);
        let age = now.saturating_duration_since(r.at);
        ui.label(
            RichText::new(format!("reported {:.1} s ago", age.as_secs_f64()))
                .color(if age > STALE { BAD } else { GOOD }),
        );
    });
}

/// The latest command and what became of it, and what else waits.
fn last_command(ui: &mut egui::Ui, u: &UplinkView, now: Instant) {
    let Some(last) = &u.last_command else {
        ui.label("no command sent yet");
        return;
    };
    ui.label(RichText::new(command_line(last, now)).color(status_colour(last)));
    for p in u
        .pending
        .iter()
        .filter(|p| p.requested_at != last.requested_at)
    {
        ui.label(RichText::new(command_line(p, now)).color(status_colour(p)));
    }
}

fn command_line(c: &CommandStatus, now: Instant) -> String {
    let what = describe_command(c.command);
    let sent = match c.transmissions {
        0 => "not sent yet".to_owned(),
        1 => "sent once".to_owned(),
        n => format!("sent {n}×"),
    };
    let refused = if c.accepted_but_refused {
        ", accepted but refused"
    } else {
        ""
    };
    match c.delivery {
        Delivery::Acknowledged { seq } => {
            format!("{what}: acknowledged, seq {seq} ({sent}{refused})")
        }
        Delivery::Pending => format!(
            "{what}: pending {:.1} s ({sent}{refused})",
            station_time(now)
                .saturating_sub(c.requested_at)
                .as_secs_f64()
        ),
        other => format!("{what}: {} ({sent}{refused})", other.label()),
    }
}

/// Counters in two columns of name and value; nonzero ones stand out unless listed in `plain`.
fn counters(ui: &mut egui::Ui, id: &str, items: &[(&str, u32)], plain: &[&str]) {
    egui::Grid::new(id)
        .num_columns(4)
        .striped(true)
        .show(ui, |ui| {
            for pair in items.chunks(2) {
                for (k, v) in pair {
                    ui.label(*k);
                    let colour = if *v == 0 || plain.contains(k) {
                        ui.visuals().text_color()
                    } else {
                        WARN
                    };
                    ui.label(RichText::new(v.to_string()).monospace().color(colour));
                }
                ui.end_row();
            }
        });
}

fn describe_command(c: dima_groundlink::Command) -> String {
    use dima_groundlink::Command as C;
    match c {
        C::Heartbeat => "heartbeat".into(),
        C::Kill => "kill".into(),
        C::Revive => "revive".into(),
        C::Throttle(p) => format!("throttle {} %", p.get()),
        C::Steering(p) => format!("steering {} %", p.get()),
        C::Tail(p) => format!("tail {} %", p.get()),
        C::SpeedSetpoint { mm_s } => format!("speed {:.2} m/s", f64::from(mm_s) / 1000.0),
        C::HeadingSetpoint { deg_e5 } => format!("heading {:.1}°", f64::from(deg_e5) / 1e5),
    }
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
