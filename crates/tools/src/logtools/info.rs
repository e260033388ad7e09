//! `dima log info FILE`: what happened in a run, from a terminal.

use std::fmt::Write as _;

use dima_log::schema::Event;

use super::read::LoggedRun;

/// The `p`-th percentile (0..=100) of `values` by nearest rank (`None` when empty).
pub fn percentile(sorted: &[f64], p: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let rank = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
    Some(sorted[rank.clamp(1, sorted.len()) - 1])
}

fn percentiles_line(name: &str, mut values: Vec<f64>) -> String {
    values.sort_by(f64::total_cmp);
    let p = |q| percentile(&values, q).map_or("-".to_owned(), |v| format!("{v:.0}"));
    format!(
        "{name:<18} n {} | p50 {} p99 {} p99.9 {} max {} µs",
        values.len(),
        p(50.0),
        p(99.0),
        p(99.9),
        p(100.0)
    )
}

/// The report, as printed: one named step after another.
pub fn report(run: &LoggedRun) -> String {
    let mut out = String::new();
    let steps: [fn(&mut String, &LoggedRun); 9] = [
        files,
        overview,
        mode_changes,
        counters,
        navigation,
        board_health,
        ground_link,
        timings,
        setup_and_configuration,
    ];
    for step in steps {
        step(&mut out, run);
    }
    out
}

/// `files: N (first, ...)`: the files of the run read (nothing for a run read from bytes).
fn files(out: &mut String, run: &LoggedRun) {
    if !run.files.is_empty() {
        let _ = writeln!(out, "files: {}", dima_log::run::files_line(run));
    }
}

/// Duration, cycles, loop rate and version.
fn overview(out: &mut String, run: &LoggedRun) {
    let cycles = run.cycles.len();
    let duration = run.cycles.last().map_or(0.0, |c| run.seconds(c.t_ns));
    let rate = if duration > 0.0 {
        (cycles.saturating_sub(1)) as f64 / duration
    } else {
        0.0
    };
    let _ = writeln!(
        out,
        "duration {duration:.2} s | {cycles} cycles | loop rate {rate:.1} Hz{}",
        run.version
            .as_deref()
            .map(|v| format!(" | dima {v}"))
            .unwrap_or_default()
    );
}

/// Mode changes and refused revives, merged in time order (a state record may be both).
fn mode_changes(out: &mut String, run: &LoggedRun) {
    let _ = writeln!(out, "\nmode changes:");
    let mut lines: Vec<(u64, u64, String)> = Vec::new();
    for s in &run.states {
        if s.msg.events.contains(&Event::ModeChanged) {
            let cause = s.msg.cause.map(|c| format!(" ({c:?})")).unwrap_or_default();
            lines.push((s.t_ns, s.msg.cycle, format!("{}{cause}", s.msg.mode)));
        }
        if let Some(refusal) = s.msg.refused {
            lines.push((s.t_ns, s.msg.cycle, format!("revive refused ({refusal:?})")));
        }
    }
    // Stable: a record's mode change stays before its refusal.
    lines.sort_by_key(|(t_ns, cycle, _)| (*t_ns, *cycle));
    for (t_ns, cycle, text) in lines {
        let _ = writeln!(
            out,
            "  {:8.3} s  cycle {cycle:>7}  {text}",
            run.seconds(t_ns)
        );
    }
}

/// Packet and link counts, from the summary or else the last cycle.
fn counters(out: &mut String, run: &LoggedRun) {
    let counters = run
        .summary
        .as_ref()
        .map(|s| s.counters)
        .or_else(|| run.cycles.last().map(|c| c.msg.counters));
    if let Some(c) = counters {
        let _ = writeln!(
            out,
            "\npackets: ok {} missing {} stale {} late {} crc {} skipped-bytes {} | info frames {}",
            c.packets_ok,
            c.packets_missing,
            c.packets_stale,
            c.packets_late,
            c.packet_crc_errors,
            c.packet_bytes_skipped,
            c.info_frames
        );
        let _ = writeln!(
            out,
            "link: commands {} (setpoints rejected {}, revives refused {}, stale commands dropped \
             {}) | gnss fixes {} | \
             servo writes {} errors {} missing {} | missed periods {} | failsafes {} | log \
             dropped {}",
            c.commands,
            c.setpoints_rejected,
            c.revives_refused,
            c.commands_stale,
            c.gnss_fixes,
            c.servo_writes,
            c.servo_errors,
            c.servo_missing,
            c.missed_periods,
            c.failsafes,
            c.log_dropped
        );
    }
}

/// The sensor board's last info frame.
fn board_health(out: &mut String, run: &LoggedRun) {
    if let Some(info) = run.infos.last().filter(|i| i.msg.version < 2) {
        let _ = writeln!(
            out,
            "sensor board (info frame v{}, firmware {}.{}.{}): requests skipped {}; no health \
             counters before frame version 2",
            info.msg.version,
            info.msg.firmware[0],
            info.msg.firmware[1],
            info.msg.firmware[2],
            info.msg.requests_skipped
        );
    }
    if let Some(info) = run.infos.last().filter(|i| i.msg.version >= 2) {
        let h = &info.msg.health;
        let _ = writeln!(
            out,
            "sensor board (info frame v{}, firmware {}.{}.{}, up {:.1} s): requests skipped {} \
             early {} | errors: accel {} gyro {} mag {} bmp280 {} mag-timeout {} dma {} gnss \
             frames {} (bytes dropped {}) | watchdog resets {} | last good read ms: accel {} \
             gyro {} mag {} bmp280 {}",
            info.msg.version,
            info.msg.firmware[0],
            info.msg.firmware[1],
            info.msg.firmware[2],
            f64::from(info.msg.uptime_ms) * 1e-3,
            info.msg.requests_skipped,
            h.requests_early,
            h.accel_errors,
            h.gyro_errors,
            h.mag_errors,
            h.bmp280_errors,
            h.mag_timeout_errors,
            h.dma_errors,
            h.gnss_frame_errors,
            h.gnss_bytes_dropped,
            h.watchdog_resets,
            h.last_good_read_age_ms[0],
            h.last_good_read_age_ms[1],
            h.last_good_read_age_ms[2],
            h.last_good_read_age_ms[3]
        );
    }
}

/// The ground link's counts at exit.
fn ground_link(out: &mut String, run: &LoggedRun) {
    if let Some(ground) = &run.ground_link {
        let _ = writeln!(out, "{ground}");
    }
}

/// Wake-up latency and request-to-packet percentiles.
fn timings(out: &mut String, run: &LoggedRun) {
    let _ = writeln!(out, "\ntimings:");
    let _ = writeln!(
        out,
        "  {}",
        percentiles_line(
            "wake latency",
            run.cycles.iter().map(|c| c.msg.wake_latency_us).collect()
        )
    );
    let _ = writeln!(
        out,
        "  {}",
        percentiles_line(
            "request->packet",
            run.cycles
                .iter()
                .filter_map(|c| c.msg.request_to_packet_us)
                .collect()
        )
    );
}

/// `navigation: ...`: the mission and the fence the robot ran with (the `navigation` record;
/// nothing for logs written before it).
fn navigation(out: &mut String, run: &LoggedRun) {
    let Some(n) = &run.navigation else {
        return;
    };
    let mission = match &n.mission {
        Some(m) => format!(
            "mission of {} waypoint{}",
            m.waypoints.len(),
            if m.waypoints.len() == 1 { "" } else { "s" }
        ),
        None => "no mission".to_owned(),
    };
    let f = &n.fence;
    let fence = if *f == Default::default() {
        "no fence".to_owned()
    } else {
        let mut parts = vec![
            format!("{} circle(s)", f.circles.len()),
            format!("{} polygon(s)", f.polygons.len()),
        ];
        if let Some(m) = f.max_distance_m {
            parts.push(format!("at most {m} m from the revive point"));
        }
        format!("fence of {}", parts.join(", "))
    };
    let _ = writeln!(out, "navigation: {mission}, {fence}");
}

/// The realtime setup and the configuration that ran.
fn setup_and_configuration(out: &mut String, run: &LoggedRun) {
    if let Some(rt) = &run.rt_setup {
        let _ = writeln!(out, "\n{}", rt.trim_end());
    }
    if let Some(config) = &run.config {
        let text = toml::to_string(config).unwrap_or_default();
        let _ = writeln!(out, "\nconfiguration:\n{}", text.trim_end());
    }
}

/// One channel of an MCAP file (or of all files of a run), summarized.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelSummary {
    /// Topic.
    pub topic: String,
    /// Message encoding.
    pub encoding: String,
    /// Messages.
    pub messages: u64,
    /// Bytes of the messages' payloads.
    pub bytes: u64,
    /// Log time of the first message, ns.
    pub first_ns: u64,
    /// Log time of the last message, ns.
    pub last_ns: u64,
}

/// Every channel with messages in the MCAP files `files` (bytes), by topic in order of first
/// appearance, and what could not be read. Any MCAP file: a robot log, a ground station
/// session, a comparison file.
pub fn channel_summaries(files: &[&[u8]]) -> (Vec<ChannelSummary>, Vec<String>) {
    let mut out: Vec<ChannelSummary> = Vec::new();
    let mut warnings = Vec::new();
    for bytes in files {
        let read = super::read::for_each_message(bytes, |m| {
            let len = m.data.len() as u64;
            match out.iter_mut().find(|c| c.topic == m.channel.topic) {
                Some(c) => {
                    c.messages += 1;
                    c.bytes += len;
                    c.first_ns = c.first_ns.min(m.log_time);
                    c.last_ns = c.last_ns.max(m.log_time);
                }
                None => out.push(ChannelSummary {
                    topic: m.channel.topic.clone(),
                    encoding: m.channel.message_encoding.clone(),
                    messages: 1,
                    bytes: len,
                    first_ns: m.log_time,
                    last_ns: m.log_time,
                }),
            }
            Ok(())
        });
        if let Err(e) = read {
            warnings.push(format!("read up to a damaged record: {e:#}"));
        }
    }
    (out, warnings)
}

/// What the messages of a ground station session's channels are.
fn meaning(topic: &str) -> &'static str {
    match topic {
        "/ground/command" => "command frames sent",
        "/ground/display" => "display frames received",
        "/ground/ack" => "command deliveries (acknowledged, given up, dropped)",
        "/ground/rx_bytes" => "chunks of bytes received",
        "/ground/link" => "link events (connects, disconnects, errors)",
        "/dima/cycle" => "control cycles",
        "/dima/state" => "mode changes and events",
        "/replay/cycle" => "replayed cycles",
        _ => "",
    }
}

/// The report on an MCAP file that is not a robot log (no control cycles), such as a ground
/// station session: its files, its duration from the first to the last message, and per
/// channel the messages, their rate and bytes, and what they are.
pub fn session_report(
    file_names: &[String],
    channels: &[ChannelSummary],
    metadata: &[String],
) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "files: {} ({})",
        file_names.len(),
        file_names.join(", ")
    );
    let _ = writeln!(
        out,
        "no control cycles (/dima/cycle): not a robot log; a ground station session or another \
         MCAP file"
    );
    let first = channels.iter().map(|c| c.first_ns).min();
    let last = channels.iter().map(|c| c.last_ns).max();
    let duration = first
        .zip(last)
        .map_or(0.0, |(a, b)| b.saturating_sub(a) as f64 * 1e-9);
    let messages: u64 = channels.iter().map(|c| c.messages).sum();
    let _ = writeln!(
        out,
        "duration {duration:.2} s (first to last message) | {messages} messages on {} channel{}",
        channels.len(),
        if channels.len() == 1 { "" } else { "s" }
    );
    let _ = writeln!(out, "\nchannels:");
    let width = channels.iter().map(|c| c.topic.len()).max().unwrap_or(0);
    for c in channels {
        let rate = if duration > 0.0 {
            format!("{:.1}/s", c.messages as f64 / duration)
        } else {
            "-".to_owned()
        };
        let what = meaning(&c.topic);
        let _ = writeln!(
            out,
            "  {:<width$}  {:>8} messages  {:>8}  {:>10} bytes  {}{}",
            c.topic,
            c.messages,
            rate,
            c.bytes,
            c.encoding,
            if what.is_empty() {
                String::new()
            } else {
                format!("  ({what})")
            }
        );
    }
    if !metadata.is_empty() {
        let _ = writeln!(out, "\nmetadata: {}", metadata.join(", "));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{channel_summaries, percentile, session_report};
    use crate::logtools::read::{LoggedRun, Timed};
    use dima_log::schema::{BoardHealthMessage, SensorInfoMessage};

    fn with_info(version: u8, health: BoardHealthMessage) -> LoggedRun {
        LoggedRun {
            infos: vec![Timed {
                t_ns: 0,
                msg: SensorInfoMessage {
                    version,
                    firmware: [0, 2, 0],
                    status: 0,
                    bmp280_calibration: Vec::new(),
                    bmm150_trim: Vec::new(),
                    uptime_ms: 61_500,
                    requests_skipped: 3,
                    health,
                },
            }],
            ..LoggedRun::default()
        }
    }

    #[test]
    fn the_board_health_is_shown_from_frame_version_2() {
        let health = BoardHealthMessage {
            mag_errors: 7,
            watchdog_resets: 1,
            last_good_read_age_ms: [1, 1, 250, 40],
            ..BoardHealthMessage::default()
        };
        let text = super::report(&with_info(2, health));
        assert!(
            text.contains("firmware 0.2.0, up 61.5 s): requests skipped 3"),
            "{text}"
        );
        assert!(text.contains("mag 7 "), "{text}");
        assert!(text.contains("watchdog resets 1"), "{text}");
        assert!(text.contains("mag 250 bmp280 40"), "{text}");
        let old = super::report(&with_info(1, BoardHealthMessage::default()));
        assert!(
            old.contains("no health counters before frame version 2"),
            "{old}"
        );
    }

    #[test]
    fn the_mission_and_fence_the_robot_ran_with_are_named() {
        use dima_core::config::{FenceCircle, FenceConfig};
        use dima_core::mission::{Mission, Navigation, Waypoint};
        let waypoint = Waypoint {
            lat_deg: 48.1,
            lon_deg: 11.5,
            acceptance_m: None,
            speed_m_s: None,
            item: 0,
        };
        let mut run = LoggedRun {
            navigation: Some(Navigation {
                mission: Some(Mission {
                    waypoints: vec![waypoint; 5],
                }),
                fence: FenceConfig {
                    max_distance_m: Some(80.0),
                    circles: vec![FenceCircle {
                        lat_deg: 48.1,
                        lon_deg: 11.5,
                        radius_m: 60.0,
                    }],
                    polygons: Vec::new(),
                },
            }),
            ..LoggedRun::default()
        };
        let text = super::report(&run);
        assert!(
            text.contains(
                "navigation: mission of 5 waypoints, fence of 1 circle(s), 0 polygon(s), at \
                 most 80 m from the revive point\n"
            ),
            "{text}"
        );
        run.navigation = Some(Navigation::default());
        let text = super::report(&run);
        assert!(
            text.contains("navigation: no mission, no fence\n"),
            "{text}"
        );
        run.navigation = None;
        assert!(!super::report(&run).contains("navigation:"));
    }

    #[test]
    fn nearest_rank_percentiles() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 50.0), Some(50.0));
        assert_eq!(percentile(&v, 99.0), Some(99.0));
        assert_eq!(percentile(&v, 99.9), Some(100.0));
        assert_eq!(percentile(&v, 0.0), Some(1.0));
        assert_eq!(percentile(&[], 50.0), None);
    }

    #[test]
    fn refusals_and_mode_changes_are_listed_in_time_order() {
        use dima_core::{Mode, ReviveRefusal};
        use dima_log::schema::{Event, StateMessage};
        let state = |t_s: u64, cycle, mode, refused: Option<ReviveRefusal>| Timed {
            t_ns: t_s * 1_000_000_000,
            msg: StateMessage {
                cycle,
                mode,
                cause: None,
                refused,
                events: if refused.is_some() {
                    vec![Event::ReviveRefused]
                } else {
                    vec![Event::ModeChanged]
                },
            },
        };
        let run = LoggedRun {
            states: vec![
                state(1, 250, Mode::Manual, None),
                state(2, 500, Mode::Killed, Some(ReviveRefusal::SensorLoss)),
                state(3, 750, Mode::Auto, None),
            ],
            ..LoggedRun::default()
        };
        let text = super::report(&run);
        let at = |needle: &str| {
            text.find(needle)
                .unwrap_or_else(|| panic!("{needle}: {text}"))
        };
        assert!(at("MANUAL") < at("revive refused"), "{text}");
        assert!(at("revive refused") < at("AUTO"), "{text}");
    }

    #[test]
    fn a_station_session_is_summarised_by_channel() {
        use dima_log::schema::ChannelSpec;
        use dima_log::writer::{Channel, McapLog};
        let spec = |topic| ChannelSpec {
            topic,
            encoding: "json",
            schema_name: "",
        };
        let (command, display) = (spec("/ground/command"), spec("/ground/display"));
        let path =
            std::env::temp_dir().join(format!("dima-info-session-{}.mcap", std::process::id()));
        let channels = [command, display].map(|spec| Channel { spec, schema: None });
        let mut log = McapLog::create_with_channels(&path, channels.to_vec()).unwrap();
        log.set_time_offset(0);
        let t0 = 1_800_000_000_000_000_000u64;
        for k in 0..40u64 {
            log.message_on(&command, t0 + k * 50_000_000, b"{}")
                .unwrap();
        }
        for k in 0..4u64 {
            log.message_on(&display, t0 + k * 500_000_000, b"{\"a\":1}")
                .unwrap();
        }
        log.finish().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        let (channels, warnings) = channel_summaries(&[&bytes]);
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(channels.len(), 2);
        assert_eq!((channels[0].messages, channels[0].bytes), (40, 80));
        assert_eq!(channels[1].messages, 4);
        let text = session_report(&["ground.mcap".to_owned()], &channels, &[]);
        assert!(text.contains("duration 1.95 s"), "{text}");
        assert!(text.contains("44 messages on 2 channels"), "{text}");
        let command_line = text
            .lines()
            .find(|l| l.contains("/ground/command"))
            .unwrap();
        assert!(command_line.contains("40 messages"), "{command_line}");
        assert!(
            command_line.contains("command frames sent"),
            "{command_line}"
        );
        assert!(text.contains("display frames received"), "{text}");
    }
}
