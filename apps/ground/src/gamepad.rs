//! Gamepad driving through `gilrs`: the left stick's vertical axis is the throttle, the right
//! stick's horizontal axis the steering, and the South button (A on Xbox, × on PlayStation)
//! kills. A stick inside its dead zone counts as released (the axis goes back to neutral), so
//! a gamepad lying on the table never holds a value.

use dima_groundlink::Percent;

/// Stick deflection below which the stick counts as released.
pub const DEAD_ZONE: f32 = 0.12;

/// The percentage a stick deflection (-1..=1) asks for around `neutral`: +1 is 100 %, -1 is
/// 0 %, linear on each side of neutral. `None` inside the dead zone (released).
pub fn stick_percent(value: f32, neutral: Percent) -> Option<Percent> {
    if !value.is_finite() || value.abs() < DEAD_ZONE {
        return None;
    }
    let v = value.clamp(-1.0, 1.0);
    let n = f32::from(neutral.get());
    let p = if v > 0.0 {
        n + v * (100.0 - n)
    } else {
        n + v * n
    };
    Percent::new(p.round().clamp(0.0, 100.0) as u8)
}

/// What the gamepad asks for in one frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GamepadInput {
    /// Throttle stick, -1..=1 (up positive), when a gamepad is connected.
    pub throttle: Option<f32>,
    /// Steering stick, -1..=1 (right positive), when a gamepad is connected.
    pub steering: Option<f32>,
    /// The kill button was pressed since the last frame.
    pub kill: bool,
    /// Name of the gamepad in use.
    pub name: Option<String>,
}

/// The gamepads, or why there are none.
pub struct Gamepads {
    gilrs: Result<gilrs::Gilrs, String>,
}

impl Default for Gamepads {
    fn default() -> Self {
        Gamepads::new()
    }
}

impl Gamepads {
    /// Opens the gamepad subsystem (a failure is kept and shown, not fatal).
    pub fn new() -> Gamepads {
        Gamepads {
            gilrs: gilrs::Gilrs::new().map_err(|e| e.to_string()),
        }
    }

    /// Why gamepads are unavailable, if they are.
    pub fn unavailable(&self) -> Option<&str> {
        self.gilrs.as_ref().err().map(String::as_str)
    }

    /// Reads the events since the last call and the sticks of the first connected gamepad.
    pub fn poll(&mut self) -> GamepadInput {
        let Ok(gilrs) = self.gilrs.as_mut() else {
            return GamepadInput::default();
        };
        let mut input = GamepadInput::default();
        while let Some(event) = gilrs.next_event() {
            if let gilrs::EventType::ButtonPressed(gilrs::Button::South, _) = event.event {
                input.kill = true;
            }
        }
        if let Some((_, pad)) = gilrs.gamepads().find(|(_, p)| p.is_connected()) {
            input.throttle = Some(pad.value(gilrs::Axis::LeftStickY));
            input.steering = Some(pad.value(gilrs::Axis::RightStickX));
            input.name = Some(pad.name().to_owned());
        }
        input
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    #[test]
    fn sticks_map_around_neutral() {
        assert_eq!(stick_percent(0.0, pct(50)), None);
        assert_eq!(stick_percent(0.1, pct(50)), None);
        assert_eq!(stick_percent(-0.1, pct(50)), None);
        assert_eq!(stick_percent(1.0, pct(50)), Some(pct(100)));
        assert_eq!(stick_percent(-1.0, pct(50)), Some(pct(0)));
        assert_eq!(stick_percent(0.5, pct(50)), Some(pct(75)));
        // An off-centre neutral: each side scales to its own end.
        assert_eq!(stick_percent(0.5, pct(20)), Some(pct(60)));
        assert_eq!(stick_percent(-0.5, pct(20)), Some(pct(10)));
        assert_eq!(stick_percent(3.0, pct(50)), Some(pct(100)));
        assert_eq!(stick_percent(f32::NAN, pct(50)), None);
    }
}
