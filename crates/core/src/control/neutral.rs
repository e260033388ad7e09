//! `kind = "none"`: the channel stays at neutral in AUTO.

use super::controller::{ControlInput, Controller};

/// Always 0: neutral.
#[derive(Debug, Clone, Copy, Default)]
pub struct Neutral;

impl Controller for Neutral {
    fn update(&mut self, _input: &ControlInput<'_>) -> f32 {
        0.0
    }

    fn reset(&mut self) {}
}
