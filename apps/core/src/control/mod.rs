//! Control: the safety state machine, the AUTO-mode controllers and the output mapping.
//!
//! Everything here is a pure function of its inputs: time comes in as a number, nothing reads a
//! clock, touches a device or allocates, so the realtime loop, the simulator and the tests run
//! the very same code.

pub mod controllers;
pub mod mapping;
pub mod pid;

pub use controllers::{AutoController, AutoState, Controller};
pub use mapping::{OutputMap, ServoTargets};
pub use pid::{Pid, PidState};

use crate::monitor::FreshFix;

/// What the controllers need from the sensors, in physical units.
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
    /// Tail.
    pub tail: f32,
}
