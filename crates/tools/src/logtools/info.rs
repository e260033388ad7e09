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
    let steps: [fn(&mut String, &LoggedRun); 8] = [
        files,
        overview,
        mode_changes,
        counters,
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

/// Mode changes and refused revives, in time.
fn mode_changes(out: &mut String, run: &LoggedRun) {
    let _ = writeln!(out, "\nmode changes:");
    for s in run
        .states
        .iter()
        .filter(|s| s.msg.events.contains(&Event::ModeChanged))
    {
        let cause = s.msg.cause.map(|c| format!(" ({c:?})")).unwrap_or_default();
        let _ = writeln!(
            out,
            "  {:8.3} s  cycle {:>7}  {}{cause}",
            run.seconds(s.t_ns),
            s.msg.cycle,
            s.msg.mode
        );
    }
    for s in run.states.iter().filter(|s| s.msg.refused.is_some()) {
        let _ = writeln!(
            out,
            "  {:8.3} s  cycle {:>7}  revive refused ({:?})",
            run.seconds(s.t_ns),
            s.msg.cycle,
            s.msg
                .refused
                .unwrap_or(dima_core::ReviveRefusal::SensorLoss)
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

#[cfg(test)]
mod tests {
    use super::percentile;
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
    fn nearest_rank_percentiles() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 50.0), Some(50.0));
        assert_eq!(percentile(&v, 99.0), Some(99.0));
        assert_eq!(percentile(&v, 99.9), Some(100.0));
        assert_eq!(percentile(&v, 0.0), Some(1.0));
        assert_eq!(percentile(&[], 50.0), None);
    }
}
