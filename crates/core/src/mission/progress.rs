//! The mission as the step runs it: where AUTO's setpoints come from, and what the step
//! remembers and reports of the mission's progress.

use serde::{Deserialize, Serialize};

use super::follower::{FollowerState, Guidance};

/// Where AUTO's heading and speed setpoints come from.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum AutoSource {
    /// The operator's setpoints, as sent over the ground link.
    #[default]
    Setpoints,
    /// The path follower, along the loaded mission (AUTO's `MISSION` sub-mode).
    Mission,
}

/// The mission's progress, as the step remembers it. Every mode transition forgets it: a
/// mission interrupted by a kill, a failsafe or a manual command starts again from its first
/// waypoint the next time AUTO is entered.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MissionProgress {
    /// AUTO follows the mission (entered while a mission was loaded).
    pub active: bool,
    /// The follower's state.
    pub follower: FollowerState,
    /// The follower's last output.
    pub guidance: Option<Guidance>,
}

impl MissionProgress {
    /// Where AUTO's setpoints come from now.
    pub fn source(&self) -> AutoSource {
        if self.active {
            AutoSource::Mission
        } else {
            AutoSource::Setpoints
        }
    }

    /// What the log reports, while the mission is followed and the follower has run.
    pub fn status(&self) -> Option<MissionStatus> {
        let g = self.guidance.filter(|_| self.active)?;
        Some(MissionStatus {
            waypoint: g.waypoint as u32,
            cross_track_m: g.cross_track_m as f32,
            along_track_m: g.along_track_m as f32,
            leg_length_m: g.leg_length_m as f32,
            to_go_m: g.to_go_m as f32,
            heading_deg: g.heading_deg as f32,
            speed_m_s: g.speed_m_s as f32,
            finished: g.finished,
        })
    }
}

/// One cycle's mission status.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MissionStatus {
    /// Index of the current waypoint (the last one once finished).
    pub waypoint: u32,
    /// Signed distance from the current leg, m, positive right of the track.
    pub cross_track_m: f32,
    /// Distance along the current leg from its start, m.
    pub along_track_m: f32,
    /// Length of the current leg, m.
    pub leg_length_m: f32,
    /// Distance to the current waypoint, m.
    pub to_go_m: f32,
    /// The follower's heading setpoint, degrees clockwise from north.
    pub heading_deg: f32,
    /// The follower's speed, m/s, before the operator's speed setpoint caps it.
    pub speed_m_s: f32,
    /// The last waypoint has been reached.
    pub finished: bool,
}
