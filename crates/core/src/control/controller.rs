//! The [`Controller`] trait: one controller per output channel, chosen in the configuration.

use core::fmt;

use super::Actuation;
use crate::estimate::StateEstimate;
use crate::safety::{Mode, Setpoints};

/// What a controller sees each cycle.
#[derive(Debug, Clone, Copy)]
pub struct ControlInput<'a> {
    /// The state estimate (computed once per cycle, shared by all controllers).
    pub estimate: &'a StateEstimate,
    /// The operator's setpoints.
    pub setpoints: &'a Setpoints,
    /// The mode (controllers run in AUTO).
    pub mode: Mode,
    /// Time since the last update, s.
    pub dt_s: f32,
    /// This cycle's outputs of the channels computed before this one, in the order throttle,
    /// steering, tail (later channels read 0): how a tail controller sees the steering demand.
    pub earlier: Actuation,
}

/// A feedback controller for one output channel.
///
/// `update` runs in the realtime loop, on every good sensor packet in AUTO: it must not
/// allocate, block, read a clock or touch a device (time comes in as `dt_s`). Its output is a
/// fraction of the channel's travel around neutral, `-1..=1`; the step clamps it, replaces a
/// non-finite value by 0 and keeps the throttle at or above neutral (AUTO is forward-only), so a
/// controller cannot break those rules, but it should not rely on that.
pub trait Controller: Send + fmt::Debug {
    /// One control step; returns the channel's output.
    fn update(&mut self, input: &ControlInput<'_>) -> f32;

    /// Forgets integrators, filters and anything learnt while active. Called before the first
    /// update and on every mode change.
    fn reset(&mut self);
}

/// The output channels, in the order their controllers run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// Throttle ESC.
    Throttle,
    /// Steering servo.
    Steering,
    /// Tail servo.
    Tail,
}

impl Channel {
    /// All channels, in order.
    pub const ALL: [Channel; 3] = [Channel::Throttle, Channel::Steering, Channel::Tail];

    /// The configuration section's name, e.g. `throttle` for `[control.throttle]`.
    pub fn name(self) -> &'static str {
        match self {
            Channel::Throttle => "throttle",
            Channel::Steering => "steering",
            Channel::Tail => "tail",
        }
    }
}
