//! Which alert the operator must see now, as a pure function of what the robot reports and
//! whether reports arrive: FAILSAFE (with its cause), a kill, the link lost and regained, a
//! refused revive. [`Alerts::update`] says which alerts were just raised (each sounds once)
//! and [`Alerts::banner`] which one the banner shows.

use std::time::{Duration, Instant};

use dima_groundlink::v2::{FailsafeCause, ReviveRefusal, RobotMode};

use crate::recording::{cause_name, refusal_name};

/// How long "link regained" stays on the banner.
pub const REGAINED_SHOWN: Duration = Duration::from_secs(3);
/// How long "revive refused" stays on the banner (less if the robot drives again).
pub const REFUSAL_SHOWN: Duration = Duration::from_secs(5);

/// One alert.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Alert {
    /// Reports stopped arriving after they did: the robot's state is unknown.
    LinkLost,
    /// The robot reports FAILSAFE, with its cause.
    Failsafe(Option<FailsafeCause>),
    /// The robot refused a revive, and why.
    ReviveRefused(ReviveRefusal),
    /// The robot reports KILLED.
    Killed,
    /// Reports arrive again after the link was lost.
    LinkRegained,
}

impl Alert {
    /// The banner's text.
    pub fn text(&self) -> String {
        match self {
            Alert::LinkLost => "LINK LOST: no report from the robot; its state is unknown".into(),
            Alert::Failsafe(Some(cause)) => format!("FAILSAFE: {}", cause_name(*cause)),
            Alert::Failsafe(None) => "FAILSAFE".into(),
            Alert::ReviveRefused(why) => format!("REVIVE REFUSED: {}", refusal_name(*why)),
            Alert::Killed => "KILLED: outputs safe; revive to drive".into(),
            Alert::LinkRegained => "LINK REGAINED: reports arrive again".into(),
        }
    }

    /// A short name for recordings and file names.
    pub fn name(&self) -> &'static str {
        match self {
            Alert::LinkLost => "link-lost",
            Alert::Failsafe(_) => "failsafe",
            Alert::ReviveRefused(_) => "revive-refused",
            Alert::Killed => "killed",
            Alert::LinkRegained => "link-regained",
        }
    }
}

/// What the station knows at one moment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Observation {
    /// Fresh reports arrive (an authentic v2/v3 report, or v1 frames).
    pub reports_fresh: bool,
    /// The robot's mode, from a fresh report (`None`: not known now, or v1).
    pub mode: Option<RobotMode>,
    /// Its failsafe cause, from that report.
    pub cause: Option<FailsafeCause>,
    /// Its last revive refusal, from that report.
    pub refusal: Option<ReviveRefusal>,
}

/// The alert state: what was seen last, and when the transient alerts were raised.
#[derive(Debug, Clone, Default)]
pub struct Alerts {
    /// Reports have arrived at least once.
    link_seen: bool,
    /// Reports stopped arriving after they did, and have not come back.
    link_lost: bool,
    regained_at: Option<Instant>,
    /// The mode of the last fresh report.
    mode: Option<RobotMode>,
    cause: Option<FailsafeCause>,
    /// The refusal of the last fresh report (the robot keeps it until a revive succeeds).
    refusal_seen: Option<ReviveRefusal>,
    refused: Option<(ReviveRefusal, Instant)>,
}

impl Alerts {
    /// Takes in what the station knows at `now`; returns the alerts raised by it (each to be
    /// sounded once), most urgent first.
    pub fn update(&mut self, o: &Observation, now: Instant) -> Vec<Alert> {
        let mut raised = Vec::new();
        if o.reports_fresh {
            if self.link_lost {
                self.link_lost = false;
                self.regained_at = Some(now);
                raised.push(Alert::LinkRegained);
            }
            self.link_seen = true;
        } else if self.link_seen && !self.link_lost {
            self.link_lost = true;
            self.regained_at = None;
            raised.push(Alert::LinkLost);
        }
        if let (true, Some(mode)) = (o.reports_fresh, o.mode) {
            let before = self.mode;
            if mode == RobotMode::Failsafe && before != Some(RobotMode::Failsafe) {
                raised.push(Alert::Failsafe(o.cause));
            }
            // A kill: KILLED after another mode (the start-up KILLED is shown, not sounded).
            if mode == RobotMode::Killed && before.is_some_and(|m| m != RobotMode::Killed) {
                raised.push(Alert::Killed);
            }
            if o.refusal.is_some() && o.refusal != self.refusal_seen {
                let why = o.refusal.unwrap_or(ReviveRefusal::Other(0));
                self.refused = Some((why, now));
                raised.push(Alert::ReviveRefused(why));
            }
            if matches!(mode, RobotMode::Manual | RobotMode::Auto) {
                self.refused = None;
            }
            self.mode = Some(mode);
            self.cause = o.cause;
            self.refusal_seen = o.refusal;
        }
        if self
            .regained_at
            .is_some_and(|t| now.saturating_duration_since(t) >= REGAINED_SHOWN)
        {
            self.regained_at = None;
        }
        if self
            .refused
            .is_some_and(|(_, t)| now.saturating_duration_since(t) >= REFUSAL_SHOWN)
        {
            self.refused = None;
        }
        raised.sort_by_key(priority);
        raised
    }

    /// Every alert active now, most urgent first.
    pub fn active(&self) -> Vec<Alert> {
        let mut active = Vec::new();
        if self.link_lost {
            active.push(Alert::LinkLost);
        }
        if self.mode == Some(RobotMode::Failsafe) {
            active.push(Alert::Failsafe(self.cause));
        }
        if let Some((why, _)) = self.refused {
            active.push(Alert::ReviveRefused(why));
        }
        if self.mode == Some(RobotMode::Killed) {
            active.push(Alert::Killed);
        }
        if self.regained_at.is_some() {
            active.push(Alert::LinkRegained);
        }
        active
    }

    /// The alert the banner shows: the most urgent active one.
    pub fn banner(&self) -> Option<Alert> {
        self.active().first().copied()
    }
}

fn priority(alert: &Alert) -> u8 {
    match alert {
        Alert::LinkLost => 0,
        Alert::Failsafe(_) => 1,
        Alert::ReviveRefused(_) => 2,
        Alert::Killed => 3,
        Alert::LinkRegained => 4,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fresh(mode: RobotMode) -> Observation {
        Observation {
            reports_fresh: true,
            mode: Some(mode),
            ..Observation::default()
        }
    }

    const SILENT: Observation = Observation {
        reports_fresh: false,
        mode: None,
        cause: None,
        refusal: None,
    };

    #[test]
    fn start_up_killed_is_shown_not_sounded_and_a_kill_is_both() {
        let t0 = Instant::now();
        let mut a = Alerts::default();
        assert_eq!(a.banner(), None);
        assert!(a.update(&fresh(RobotMode::Killed), t0).is_empty());
        assert_eq!(a.banner(), Some(Alert::Killed));
        assert!(a.update(&fresh(RobotMode::Manual), t0).is_empty());
        assert_eq!(a.banner(), None);
        let t1 = t0 + Duration::from_secs(1);
        assert_eq!(a.update(&fresh(RobotMode::Killed), t1), vec![Alert::Killed]);
        assert_eq!(a.banner(), Some(Alert::Killed));
        // Still killed: not raised again.
        assert!(a.update(&fresh(RobotMode::Killed), t1).is_empty());
    }

    #[test]
    fn failsafe_with_its_cause_until_the_robot_leaves_it() {
        let t0 = Instant::now();
        let mut a = Alerts::default();
        a.update(&fresh(RobotMode::Manual), t0);
        let failsafe = Observation {
            cause: Some(FailsafeCause::SensorLoss),
            ..fresh(RobotMode::Failsafe)
        };
        let raised = a.update(&failsafe, t0);
        assert_eq!(
            raised,
            vec![Alert::Failsafe(Some(FailsafeCause::SensorLoss))]
        );
        assert_eq!(a.banner().unwrap().text(), "FAILSAFE: sensor loss");
        assert!(a.update(&failsafe, t0 + Duration::from_secs(60)).is_empty());
        assert_eq!(a.banner(), raised.first().copied());
        a.update(&fresh(RobotMode::Manual), t0 + Duration::from_secs(61));
        assert_eq!(a.banner(), None);
    }

    #[test]
    fn link_lost_outranks_everything_and_regained_clears_after_a_while() {
        let t0 = Instant::now();
        let mut a = Alerts::default();
        // Silence before any report is not a lost link.
        assert!(a.update(&SILENT, t0).is_empty());
        a.update(&fresh(RobotMode::Failsafe), t0);
        let t1 = t0 + Duration::from_secs(2);
        assert_eq!(a.update(&SILENT, t1), vec![Alert::LinkLost]);
        assert_eq!(a.banner(), Some(Alert::LinkLost));
        assert!(a.update(&SILENT, t1 + Duration::from_secs(30)).is_empty());
        let t2 = t1 + Duration::from_secs(31);
        assert_eq!(
            a.update(&fresh(RobotMode::Manual), t2),
            vec![Alert::LinkRegained]
        );
        assert_eq!(a.banner(), Some(Alert::LinkRegained));
        a.update(
            &fresh(RobotMode::Manual),
            t2 + REGAINED_SHOWN - Duration::from_millis(1),
        );
        assert_eq!(a.banner(), Some(Alert::LinkRegained));
        a.update(&fresh(RobotMode::Manual), t2 + REGAINED_SHOWN);
        assert_eq!(a.banner(), None);
    }

    #[test]
    fn a_refused_revive_is_raised_once_and_clears_on_driving_or_after_a_while() {
        let t0 = Instant::now();
        let mut a = Alerts::default();
        a.update(&fresh(RobotMode::Killed), t0);
        let refused = Observation {
            refusal: Some(ReviveRefusal::TooSoon),
            ..fresh(RobotMode::Killed)
        };
        assert_eq!(
            a.update(&refused, t0),
            vec![Alert::ReviveRefused(ReviveRefusal::TooSoon)]
        );
        assert_eq!(
            a.banner(),
            Some(Alert::ReviveRefused(ReviveRefusal::TooSoon))
        );
        assert!(a.update(&refused, t0 + Duration::from_secs(1)).is_empty());
        a.update(&refused, t0 + REFUSAL_SHOWN);
        assert_eq!(a.banner(), Some(Alert::Killed));
        // Another refusal, then a revive that works.
        let sensors = Observation {
            refusal: Some(ReviveRefusal::SensorLoss),
            ..fresh(RobotMode::Killed)
        };
        let t1 = t0 + Duration::from_secs(10);
        assert_eq!(
            a.update(&sensors, t1),
            vec![Alert::ReviveRefused(ReviveRefusal::SensorLoss)]
        );
        a.update(&fresh(RobotMode::Manual), t1);
        assert_eq!(a.banner(), None);
    }
}
