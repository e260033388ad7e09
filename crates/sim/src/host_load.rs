//! When the host, not the robot, failed a run: the simulated robot runs its real loop on the
//! machine's scheduler, and on a busy laptop the loop misses periods, trips its own `Overrun`
//! protection (FAILSAFE, revives refused) and fails the scenario. [`HostLoad`] gathers what the
//! log shows of that and [`host_overload_hint`] turns it into the line `dima sim` prints under
//! its FAIL line, with the ways out.

use dima_core::{FailsafeCause, ReviveRefusal};

use crate::logcheck::LogSummary;

/// What a run's log shows of the loop falling behind the host's scheduler.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct HostLoad {
    /// Entries into FAILSAFE with cause `Overrun`.
    pub overrun_failsafes: usize,
    /// Revives refused because the loop was overrunning.
    pub overrun_refusals: usize,
    /// Periods the loop missed over the whole run.
    pub missed_periods: u64,
    /// The most periods missed at one wake-up.
    pub worst_stall_periods: u64,
    /// The loop rate, Hz.
    pub loop_rate_hz: u32,
    /// `safety.overrun_limit` of the run.
    pub overrun_limit: u32,
    /// `safety.max_stall_ms` of the run.
    pub max_stall_ms: u32,
    /// The run injected a `loop:busy` fault: the overload was asked for, not the host's.
    pub busy_fault: bool,
    /// `--realtime` was given (the configuration's realtime setup was required).
    pub realtime_flag: bool,
    /// The loop thread's scheduler as the log's realtime report read it back, e.g.
    /// `SCHED_OTHER priority 0`.
    pub scheduler: Option<String>,
}

impl HostLoad {
    /// The facts in `log`, a run at `loop_rate_hz` with or without `--realtime`, with or
    /// without a `loop:busy` fault.
    pub fn from_log(
        log: &LogSummary,
        loop_rate_hz: u32,
        realtime_flag: bool,
        busy_fault: bool,
    ) -> HostLoad {
        HostLoad {
            overrun_failsafes: log
                .failsafes()
                .iter()
                .filter(|(_, cause)| *cause == Some(FailsafeCause::Overrun))
                .count(),
            overrun_refusals: log
                .states
                .iter()
                .filter(|s| s.refused == Some(ReviveRefusal::Overrun))
                .count(),
            missed_periods: log.cycles.iter().map(|c| c.missed).sum(),
            worst_stall_periods: log.cycles.iter().map(|c| c.missed).max().unwrap_or(0),
            loop_rate_hz,
            overrun_limit: log.config.as_ref().map_or(0, |c| c.safety.overrun_limit),
            max_stall_ms: log.config.as_ref().map_or(0, |c| c.safety.max_stall_ms),
            busy_fault,
            realtime_flag,
            scheduler: log.rt_setup.as_deref().and_then(scheduler_line),
        }
    }
}

/// The `scheduler:` line of a realtime setup report (`SCHED_FIFO priority 80`).
fn scheduler_line(report: &str) -> Option<String> {
    report
        .lines()
        .find_map(|l| l.trim().strip_prefix("scheduler:"))
        .map(|s| s.trim().to_owned())
}

/// The explanation to print under a FAIL line when the loop's own `Overrun` protection tripped
/// or refused revives (`None` otherwise, and when a `loop:busy` fault asked for the overload):
/// the host was too busy for the loop, what was seen, and the ways out.
pub fn host_overload_hint(load: &HostLoad) -> Option<String> {
    if load.busy_fault || (load.overrun_failsafes == 0 && load.overrun_refusals == 0) {
        return None;
    }
    let mut seen = Vec::new();
    if load.overrun_failsafes > 0 {
        seen.push(format!("{} FAILSAFE `Overrun`", load.overrun_failsafes));
    }
    if load.overrun_refusals > 0 {
        seen.push(format!(
            "{} revive(s) refused for `Overrun`",
            load.overrun_refusals
        ));
    }
    let scheduler = load
        .scheduler
        .as_ref()
        .map(|s| format!(" under {s}"))
        .unwrap_or_default();
    let lower_rate = (load.loop_rate_hz / 2).max(10);
    let had_fifo = load
        .scheduler
        .as_deref()
        .is_some_and(|s| s.starts_with("SCHED_FIFO"));
    let realtime = if load.realtime_flag {
        "--realtime was given: check that the loop got SCHED_FIFO (`dima log info` shows the \
         RT setup; it needs root or CAP_SYS_NICE)"
    } else if had_fifo {
        "--realtime (the loop had SCHED_FIFO already; it adds the configuration's CPU pinning \
         and locked memory, and keeps the robot KILLED when they are refused)"
    } else {
        "--realtime (SCHED_FIFO with the configuration's pinning and locked memory; needs root \
         or CAP_SYS_NICE, and keeps the robot KILLED when refused)"
    };
    Some(format!(
        "the host, not the robot: this machine kept the {rate} Hz loop from running on time \
         ({missed} periods missed, up to {worst} at one wake-up{scheduler}) and the robot's \
         own protection reacted: {seen}. Ways out: --loop-rate {lower_rate}; a --config file \
         with a larger safety.overrun_limit (late wake-ups a second, now {limit}, at most \
         {max}) or safety.max_stall_ms (now {stall}); {realtime}; or a quieter machine.",
        rate = load.loop_rate_hz,
        missed = load.missed_periods,
        worst = load.worst_stall_periods,
        seen = seen.join(", "),
        limit = load.overrun_limit,
        max = dima_core::config::max_overrun_limit(load.loop_rate_hz),
        stall = load.max_stall_ms,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::logcheck::{CycleEntry, StateChange};
    use dima_core::Mode;
    use dima_log::schema::Event;

    fn busy_laptop() -> HostLoad {
        HostLoad {
            overrun_failsafes: 1,
            overrun_refusals: 2,
            missed_periods: 57,
            worst_stall_periods: 14,
            loop_rate_hz: 250,
            overrun_limit: 10,
            max_stall_ms: 250,
            busy_fault: false,
            realtime_flag: false,
            scheduler: Some("SCHED_OTHER priority 0".into()),
        }
    }

    #[test]
    fn an_overrun_names_the_host_the_missed_periods_and_the_ways_out() {
        let hint = host_overload_hint(&busy_laptop()).expect("a hint");
        for needle in [
            "the host, not the robot",
            "1 FAILSAFE `Overrun`",
            "2 revive(s) refused for `Overrun`",
            "57 periods missed, up to 14 at one wake-up under SCHED_OTHER priority 0",
            "--loop-rate 125",
            "safety.overrun_limit (late wake-ups a second, now 10, at most 25)",
            "safety.max_stall_ms (now 250)",
            "--realtime (SCHED_FIFO",
        ] {
            assert!(hint.contains(needle), "{needle:?} in {hint}");
        }
        let refusals_only = HostLoad {
            overrun_failsafes: 0,
            realtime_flag: true,
            ..busy_laptop()
        };
        let hint = host_overload_hint(&refusals_only).expect("refusals alone are enough");
        assert!(!hint.contains("FAILSAFE `Overrun`"), "{hint}");
        assert!(hint.contains("--realtime was given"), "{hint}");
        let had_fifo = HostLoad {
            scheduler: Some("SCHED_FIFO priority 80".into()),
            ..busy_laptop()
        };
        let hint = host_overload_hint(&had_fifo).unwrap();
        assert!(hint.contains("the loop had SCHED_FIFO already"), "{hint}");
    }

    #[test]
    fn no_overrun_no_hint() {
        let calm = HostLoad {
            overrun_failsafes: 0,
            overrun_refusals: 0,
            ..busy_laptop()
        };
        assert_eq!(host_overload_hint(&calm), None);
        assert_eq!(host_overload_hint(&HostLoad::default()), None);
        let asked_for = HostLoad {
            busy_fault: true,
            ..busy_laptop()
        };
        assert_eq!(host_overload_hint(&asked_for), None, "a loop:busy fault");
    }

    #[test]
    fn the_facts_come_from_the_log() {
        let state = |t_ns, mode, cause, refused| StateChange {
            t_ns,
            mode,
            cause,
            refused,
            events: vec![Event::ModeChanged],
        };
        let cycle = |t_ns, missed| CycleEntry {
            t_ns,
            mode: Mode::Manual,
            packet_ok: true,
            commands: 0,
            missed,
            targets_us: [1500, 1545, 1500],
            link_ns: None,
        };
        let log = LogSummary {
            states: vec![
                state(1, Mode::Manual, None, None),
                state(2, Mode::Failsafe, Some(FailsafeCause::Overrun), None),
                state(
                    3,
                    Mode::Failsafe,
                    Some(FailsafeCause::Overrun),
                    Some(ReviveRefusal::Overrun),
                ),
                state(
                    4,
                    Mode::Failsafe,
                    Some(FailsafeCause::Overrun),
                    Some(ReviveRefusal::TooSoon),
                ),
                state(5, Mode::Manual, None, None),
                state(6, Mode::Failsafe, Some(FailsafeCause::CommsLoss), None),
            ],
            cycles: vec![cycle(1, 0), cycle(2, 9), cycle(3, 3), cycle(4, 0)],
            config: Some(dima_core::config::Config::default()),
            rt_setup: Some(
                "RT setup report (dima-loop)\n  scheduler:          SCHED_OTHER priority 0\n    \
                 refused:          SCHED_FIFO 80: EPERM\n"
                    .into(),
            ),
            ..LogSummary::default()
        };
        let load = HostLoad::from_log(&log, 250, false, false);
        assert_eq!(
            load,
            HostLoad {
                overrun_failsafes: 1,
                overrun_refusals: 1,
                missed_periods: 12,
                worst_stall_periods: 9,
                loop_rate_hz: 250,
                overrun_limit: 10,
                max_stall_ms: 250,
                busy_fault: false,
                realtime_flag: false,
                scheduler: Some("SCHED_OTHER priority 0".into()),
            }
        );
    }
}
