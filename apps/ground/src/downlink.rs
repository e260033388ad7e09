//! What the station can honestly say about the robot's reports, from what the link received.
//!
//! The station never shows its own intent as the robot's mode: a mode is shown only from an
//! authentic report (ground link v2, a display frame whose tag verifies, received recently).
//! When none comes back, [`DownlinkHealth::classify`] tells why as far as the bytes show it:
//!
//! - display frames v2 arrive whose tag does not verify, and none that does: the key is wrong
//!   (or the robot was given another one);
//! - a version 1 station hears display frames v2 (start token `A5 44`, length 126): the robot
//!   requires ground link v2 and a key, and ignores this station's commands;
//! - bytes arrive but no frame decodes: another baud rate, or noise;
//! - nothing arrives at all: the robot is off, out of radio range, or on another port.
//!
//! Pure: the ages are arguments, so every rule is tested without a clock.

use std::time::Duration;

use dima_groundlink::v2::{
    DISPLAY_FRAME_LEN, DISPLAY_START, DISPLAY_V3_FRAME_LEN, DISPLAY_V3_START,
};

/// A report older than this is not the robot's current state (four display periods at the
/// robot's default 2 Hz).
pub const REPORT_FRESH: Duration = Duration::from_secs(2);
/// A rejected frame, a v2 start token or a byte this recent counts as still arriving.
pub const RECENT: Duration = Duration::from_secs(3);

/// What the link received, as ages at one instant (`None`: never since the station started).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DownlinkObservation {
    /// The station speaks ground link v2 (it has a key).
    pub authenticated: bool,
    /// Since the port was opened (`None`: not connected).
    pub connected_for: Option<Duration>,
    /// Since the last byte arrived.
    pub since_byte: Option<Duration>,
    /// Since the last valid display frame: authentic (v2) or CRC-valid (v1).
    pub since_valid_frame: Option<Duration>,
    /// v2: since the last display frame whose tag did not verify.
    pub since_bad_tag: Option<Duration>,
    /// v1: since the last display frame v2 start token.
    pub since_v2_token: Option<Duration>,
}

/// What the station can say about the robot's reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DownlinkHealth {
    /// No port open.
    NotConnected,
    /// Connected a moment ago; nothing valid yet.
    Waiting,
    /// v2: authentic reports arrive: the robot's mode is known.
    Authentic,
    /// v1: valid frames arrive, but version 1 carries no mode.
    V1NoReport,
    /// v2: display frames arrive whose tag does not verify, and none that does.
    KeyMismatch,
    /// v1 station: the robot sends display frames v2 (it requires a key).
    RobotSpeaksV2,
    /// Bytes arrive but no display frame decodes.
    Garbled,
    /// Nothing arrives.
    Silent,
}

/// How bad a [`DownlinkHealth`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// The robot's state is known.
    Good,
    /// Known to be unknown (v1), or not yet.
    Warning,
    /// The robot's state is unknown and something is wrong.
    Fault,
}

fn within(age: Option<Duration>, limit: Duration) -> bool {
    age.is_some_and(|a| a < limit)
}

impl DownlinkHealth {
    /// Classifies what the link received.
    pub fn classify(o: &DownlinkObservation) -> DownlinkHealth {
        let Some(connected_for) = o.connected_for else {
            return DownlinkHealth::NotConnected;
        };
        if within(o.since_valid_frame, REPORT_FRESH) {
            return if o.authenticated {
                DownlinkHealth::Authentic
            } else {
                DownlinkHealth::V1NoReport
            };
        }
        if o.authenticated && within(o.since_bad_tag, RECENT) {
            return DownlinkHealth::KeyMismatch;
        }
        if !o.authenticated && within(o.since_v2_token, RECENT) {
            return DownlinkHealth::RobotSpeaksV2;
        }
        if connected_for < REPORT_FRESH {
            return DownlinkHealth::Waiting;
        }
        if within(o.since_byte, RECENT) {
            DownlinkHealth::Garbled
        } else {
            DownlinkHealth::Silent
        }
    }

    /// What the operator reads in place of the robot's mode.
    pub fn text(self) -> &'static str {
        match self {
            DownlinkHealth::NotConnected => "not connected: the robot's state is unknown",
            DownlinkHealth::Waiting => "waiting for the robot's first report",
            DownlinkHealth::Authentic => "authenticated reports arriving",
            DownlinkHealth::V1NoReport => "mode unknown (v1 has no report)",
            DownlinkHealth::KeyMismatch => {
                "no authenticated report from the robot: wrong or missing key? \
                 (its display frames arrive, their tag does not verify)"
            }
            DownlinkHealth::RobotSpeaksV2 => {
                "no authenticated report from the robot: it speaks ground link v2 and \
                 requires a key (--key-file); it ignores this station's v1 commands"
            }
            DownlinkHealth::Garbled => {
                "no report from the robot: bytes arrive but no display frame decodes \
                 (baud rate? protocol version?)"
            }
            DownlinkHealth::Silent => {
                "no report from the robot: nothing received (robot off? out of radio \
                 range? wrong port?)"
            }
        }
    }

    /// The same in a few words, for a status bar or a table row.
    pub fn short(self) -> &'static str {
        match self {
            DownlinkHealth::NotConnected => "not connected",
            DownlinkHealth::Waiting => "waiting for a report",
            DownlinkHealth::Authentic => "authenticated reports arriving",
            DownlinkHealth::V1NoReport => "mode unknown (v1 has no report)",
            DownlinkHealth::KeyMismatch => "no authenticated report: wrong or missing key?",
            DownlinkHealth::RobotSpeaksV2 => "no authenticated report: robot requires a key",
            DownlinkHealth::Garbled => "no report: bytes but no frame",
            DownlinkHealth::Silent => "no report: nothing received",
        }
    }

    /// How bad it is: only [`DownlinkHealth::Authentic`] is good.
    pub fn severity(self) -> Severity {
        match self {
            DownlinkHealth::Authentic => Severity::Good,
            DownlinkHealth::V1NoReport | DownlinkHealth::Waiting => Severity::Warning,
            DownlinkHealth::NotConnected
            | DownlinkHealth::KeyMismatch
            | DownlinkHealth::RobotSpeaksV2
            | DownlinkHealth::Garbled
            | DownlinkHealth::Silent => Severity::Fault,
        }
    }
}

/// Spots the start tokens of the authenticated display frames (v2: `A5 44` and the length 126;
/// v3, what the robot sends: `A5 46` and the length 156) in a byte stream read as version 1,
/// across reads.
#[derive(Debug, Clone, Copy, Default)]
pub struct V2TokenSpotter {
    last: [u8; 2],
}

impl V2TokenSpotter {
    /// Whether `bytes` complete a start token.
    pub fn feed(&mut self, bytes: &[u8]) -> bool {
        let mut seen = false;
        for &b in bytes {
            seen |= (self.last == DISPLAY_START && usize::from(b) == DISPLAY_FRAME_LEN)
                || (self.last == DISPLAY_V3_START && usize::from(b) == DISPLAY_V3_FRAME_LEN);
            self.last = [self.last[1], b];
        }
        seen
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_groundlink::v2::{DisplayFrame, LinkKey};

    fn s(secs: f64) -> Option<Duration> {
        Some(Duration::from_secs_f64(secs))
    }

    /// A v2 station connected 10 s ago that received nothing.
    fn v2() -> DownlinkObservation {
        DownlinkObservation {
            authenticated: true,
            connected_for: s(10.0),
            ..DownlinkObservation::default()
        }
    }

    #[test]
    fn only_a_fresh_authentic_report_is_good() {
        let fresh = DownlinkObservation {
            since_byte: s(0.1),
            since_valid_frame: s(0.4),
            since_bad_tag: s(0.2),
            ..v2()
        };
        assert_eq!(DownlinkHealth::classify(&fresh), DownlinkHealth::Authentic);
        assert_eq!(DownlinkHealth::Authentic.severity(), Severity::Good);
        // The same frames read by a v1 station: valid, but no mode.
        let v1 = DownlinkObservation {
            authenticated: false,
            ..fresh
        };
        assert_eq!(DownlinkHealth::classify(&v1), DownlinkHealth::V1NoReport);
        assert_eq!(
            DownlinkHealth::V1NoReport.text(),
            "mode unknown (v1 has no report)"
        );
        // A report 2.5 s old is no longer the robot's state.
        let old = DownlinkObservation {
            since_valid_frame: s(2.5),
            since_bad_tag: None,
            ..fresh
        };
        assert_eq!(DownlinkHealth::classify(&old), DownlinkHealth::Garbled);
        let not_connected = DownlinkObservation {
            connected_for: None,
            ..fresh
        };
        assert_eq!(
            DownlinkHealth::classify(&not_connected),
            DownlinkHealth::NotConnected
        );
    }

    #[test]
    fn rejected_tags_without_an_authentic_frame_are_a_key_mismatch_and_silence_is_not() {
        let wrong_key = DownlinkObservation {
            since_byte: s(0.1),
            since_bad_tag: s(0.4),
            ..v2()
        };
        let health = DownlinkHealth::classify(&wrong_key);
        assert_eq!(health, DownlinkHealth::KeyMismatch);
        assert!(health
            .text()
            .starts_with("no authenticated report from the robot: wrong or missing key?"));
        assert_eq!(health.severity(), Severity::Fault);
        assert!(health.short().contains("wrong or missing key?"));
        // Authentic frames stopped and rejected ones go on (the robot got another key).
        let rekeyed = DownlinkObservation {
            since_valid_frame: s(30.0),
            ..wrong_key
        };
        assert_eq!(
            DownlinkHealth::classify(&rekeyed),
            DownlinkHealth::KeyMismatch
        );
        // The rejections stopped too: silence, not a key problem.
        let silent = DownlinkObservation {
            since_byte: s(5.0),
            since_bad_tag: s(5.0),
            ..wrong_key
        };
        assert_eq!(DownlinkHealth::classify(&silent), DownlinkHealth::Silent);
        let never = v2();
        assert_eq!(DownlinkHealth::classify(&never), DownlinkHealth::Silent);
        // Bytes but no candidate frame at all.
        let noise = DownlinkObservation {
            since_byte: s(0.2),
            ..v2()
        };
        assert_eq!(DownlinkHealth::classify(&noise), DownlinkHealth::Garbled);
        // Just connected: not yet a verdict, unless a rejected frame already says it.
        let young = DownlinkObservation {
            connected_for: s(0.5),
            ..v2()
        };
        assert_eq!(DownlinkHealth::classify(&young), DownlinkHealth::Waiting);
        let young_wrong = DownlinkObservation {
            connected_for: s(0.5),
            ..wrong_key
        };
        assert_eq!(
            DownlinkHealth::classify(&young_wrong),
            DownlinkHealth::KeyMismatch
        );
    }

    #[test]
    fn a_v1_station_hearing_v2_frames_says_the_robot_requires_a_key() {
        let v1 = DownlinkObservation {
            authenticated: false,
            connected_for: s(10.0),
            since_byte: s(0.1),
            since_v2_token: s(0.3),
            ..DownlinkObservation::default()
        };
        let health = DownlinkHealth::classify(&v1);
        assert_eq!(health, DownlinkHealth::RobotSpeaksV2);
        assert!(
            health.text().contains("requires a key"),
            "{}",
            health.text()
        );
        assert_eq!(health.severity(), Severity::Fault);
        // A v2 station ignores the token (its decoder judges those frames).
        let v2 = DownlinkObservation {
            authenticated: true,
            ..v1
        };
        assert_eq!(DownlinkHealth::classify(&v2), DownlinkHealth::Garbled);
        // No fault is ever shown as good.
        for h in [
            DownlinkHealth::NotConnected,
            DownlinkHealth::Waiting,
            DownlinkHealth::V1NoReport,
            DownlinkHealth::KeyMismatch,
            DownlinkHealth::RobotSpeaksV2,
            DownlinkHealth::Garbled,
            DownlinkHealth::Silent,
        ] {
            assert_ne!(h.severity(), Severity::Good, "{h:?}");
        }
    }

    #[test]
    fn the_spotter_finds_v2_display_frames_split_across_reads() {
        let key = LinkKey::from_bytes([7; 16]);
        let frame = DisplayFrame::default().encode(&key);
        let mut spotter = V2TokenSpotter::default();
        assert!(!spotter.feed(&[0x00, 0xA5]));
        assert!(spotter.feed(&frame[1..10]), "A5 | 44 7E ...");
        assert!(!spotter.feed(&frame[10..]));
        // A5 44 followed by anything but the length is not a token.
        assert!(!spotter.feed(&[0xA5, 0x44, 0x10, 0x24, 0x44]));
        let mut fresh = V2TokenSpotter::default();
        assert!(fresh.feed(&frame));
    }

    #[test]
    fn the_spotter_finds_the_display_frames_v3_the_robot_sends() {
        let key = LinkKey::from_bytes([7; 16]);
        let frame = dima_groundlink::v2::DisplayFrameV3::default().encode(&key);
        let mut spotter = V2TokenSpotter::default();
        assert!(spotter.feed(&frame[..3]), "A5 46 9C");
        assert!(!spotter.feed(&[0xA5, 0x46, 0x10]));
    }
}
