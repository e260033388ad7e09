//! GNSS waypoint missions: the mission a QGroundControl `.plan` file describes
//! ([`plan::parse_plan`]), the local metric frame around its first waypoint ([`local`]) and the
//! pure-pursuit path follower that turns the mission and the car's position into the heading and
//! speed setpoints the AUTO controllers track ([`follower`]).
//!
//! Everything here is pure: the plan is parsed from a string (the caller reads the file), the
//! follower is a function of its state, the position and the speed. Loading and projecting
//! allocate (once, at start-up); a follower update does not.

pub mod follower;
pub mod local;
pub mod navigation;
pub mod plan;
mod plan_fence;
pub mod progress;

pub use follower::{Follower, FollowerParams, FollowerState, Guidance};
pub use local::{LocalFrame, LocalPoint};
pub use navigation::Navigation;
pub use plan::{parse_plan, parse_plan_file, Plan, PlanError};
pub use progress::{AutoSource, MissionProgress, MissionStatus};

/// One waypoint of a mission, as the plan gives it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Waypoint {
    /// Latitude, degrees (WGS84).
    pub lat_deg: f64,
    /// Longitude, degrees (WGS84).
    pub lon_deg: f64,
    /// Acceptance radius, m (`None`: the follower's default).
    pub acceptance_m: Option<f64>,
    /// Ground speed towards this waypoint, m/s, from the last speed change before it (`None`:
    /// the follower's default speed).
    pub speed_m_s: Option<f64>,
    /// Index of the plan item it came from (`mission.items[i]`), for messages.
    pub item: usize,
}

/// A mission: waypoints in the order they are followed (at least one).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Mission {
    /// The waypoints.
    pub waypoints: Vec<Waypoint>,
}
