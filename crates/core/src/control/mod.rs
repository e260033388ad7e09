//! Control: the safety state machine's outputs, the AUTO-mode controllers and the output
//! mapping.
//!
//! One [`Controller`] per output channel, chosen by name in the configuration
//! ([`registry::KINDS`]), each reading the shared [`StateEstimate`](crate::estimate::StateEstimate).
//! Everything here is a pure function of its inputs: time comes in as a number, nothing reads a
//! clock, touches a device or allocates in a cycle, so the realtime loop, the simulator, replays
//! and the tests run the very same code.

pub mod controller;
pub mod heading_pid;
pub mod mapping;
pub mod neutral;
pub mod pid;
pub mod registry;
pub mod speed_pid;
pub mod yaw_rate;

pub use controller::{Channel, ControlInput, Controller};
pub use mapping::{OutputMap, ServoTargets};
pub use pid::{Pid, PidLoop, PidState};
pub use registry::{ControllerSet, ParamError, KINDS};

use crate::monitor::FreshFix;

/// The sensor values of the last good packet and the GNSS freshness, as the step tracks them.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SensorValues {
    /// Gyroscope Z rate, degrees per second (board frame), from the last good packet.
    pub gyro_z_dps: f32,
    /// The newest fresh GNSS fix (valid, iTOW advancing) if it is within the GNSS timeout.
    pub gnss: Option<FreshFix>,
    /// That fix arrived this cycle.
    pub gnss_new: bool,
}

/// Controller output: fractions of each channel's travel around neutral, -1..=1 (+1 is
/// `max_us`, -1 is `min_us`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Actuation {
    /// Throttle (+ forward).
    pub throttle: f32,
    /// Steering (+ towards `max_us`, clockwise by convention).
    pub steering: f32,
    /// Tail (+ towards `max_us`, a clockwise yaw moment by convention).
    pub tail: f32,
}
