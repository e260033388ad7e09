//! Control: the safety state machine, the AUTO-mode controllers and the output mapping.
//!
//! Everything here is a pure function of its inputs: time comes in as a number, nothing reads a
//! clock, touches a device or allocates, so the realtime loop, the simulator and the tests run
//! the very same code.

pub mod controllers;
pub mod mapping;
pub mod pid;
pub mod safety;

pub use controllers::{AutoController, AutoState, Controller};
pub use mapping::{OutputMap, ServoTargets};
pub use pid::{Pid, PidState};
pub use safety::{CycleHealth, FailsafeCause, Mode, SafetyLimits, SafetyState, Setpoints};

/// Monotonic time in nanoseconds (CLOCK_MONOTONIC in the application, anything in tests).
pub type Nanos = u64;

/// What the controllers need from one sensor packet, in physical units.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SensorValues {
    /// Gyroscope Z rate, degrees per second (board frame).
    pub gyro_z_dps: f32,
    /// GNSS fix usable (gnssFixOK with a 2D/3D fix).
    pub gnss_fix_ok: bool,
    /// GNSS time of week of the solution, ms: a change means a new fix.
    pub gnss_itow_ms: u32,
    /// GNSS ground speed, mm/s.
    pub g_speed_mm_s: i32,
    /// GNSS heading of motion, 1e-5 degrees.
    pub head_mot_deg_e5: i32,
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
