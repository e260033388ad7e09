//! Gamepad driving through `gilrs`: [`Gamepads`] reads the gamepad in use (its raw axes and
//! whether the kill button was pressed), and [`GamepadDriver`], pure, turns what was read into
//! the channels' values with the joystick configuration ([`crate::joystick`]): which axis
//! drives which channel, its calibration, dead zone, inversion and expo.
//!
//! A stick inside its dead zone counts as released (the channel goes back to neutral), so a
//! gamepad lying on the table never holds a value. A gamepad that connects (or comes back)
//! drives a channel only once that stick has been inside its dead zone: a stick held while it
//! connects does not jump the robot. When the gamepad in use disconnects, its channels are
//! released at once (so [`crate::control::ManualControl`] sends neutral once for those it
//! held, as it does when the window loses focus and the keys are released), and the station
//! shows it as disconnected until it, or another, connects. While the calibration window
//! measures the sticks, the gamepad drives nothing (the kill button still kills).

use dima_groundlink::station::ManualChannel;
use dima_groundlink::Percent;

use crate::joystick::shaping::percent_around;
use crate::joystick::{AxesSample, JoystickConfig, PadButton, StickAxis};

/// The gamepad in use, as read in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PadSnapshot {
    /// Which connection: a new number for a different gamepad, or the same one plugged in
    /// again.
    pub id: usize,
    /// Its name.
    pub name: String,
    /// Its raw axis values.
    pub axes: AxesSample,
}

/// What the gamepads gave in one frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PadReading {
    /// The gamepad in use; `None` when none is connected.
    pub pad: Option<PadSnapshot>,
    /// The kill button was pressed, on any gamepad, since the last frame.
    pub kill: bool,
}

/// What the station shows about the gamepad.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum PadStatus {
    /// None has been connected.
    #[default]
    NoneConnected,
    /// This gamepad is in use.
    Connected(String),
    /// The gamepad in use (named) disconnected and none has taken its place.
    Disconnected(String),
}

/// What the gamepad asks for in one frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GamepadInput {
    /// Throttle, steering, tail: the value of each stick outside its dead zone.
    pub sticks: [Option<Percent>; 3],
    /// A stick is out of its dead zone but has not been inside it since the gamepad connected
    /// (or since the calibration): it drives once it has.
    pub waiting_for_centre: [bool; 3],
    /// The kill button was pressed since the last frame.
    pub kill: bool,
    /// Connected, disconnected or none.
    pub status: PadStatus,
}

/// The gamepad's part of manual driving, as a pure function of what was read.
#[derive(Debug, Clone, Default)]
pub struct GamepadDriver {
    in_use: Option<(usize, String)>,
    lost: Option<String>,
    centred: [bool; 3],
}

impl GamepadDriver {
    /// One frame: `reading` through `config`, each channel around its `neutral`. With
    /// `suspended` (the calibration window is measuring) no stick drives, and each must come
    /// back inside its dead zone afterwards before it does.
    pub fn update(
        &mut self,
        reading: &PadReading,
        config: &JoystickConfig,
        neutral: [Percent; 3],
        suspended: bool,
    ) -> GamepadInput {
        let mut input = GamepadInput {
            kill: reading.kill,
            ..GamepadInput::default()
        };
        let Some(pad) = &reading.pad else {
            if let Some((_, name)) = self.in_use.take() {
                self.lost = Some(name);
            }
            self.centred = [false; 3];
            input.status = match &self.lost {
                Some(name) => PadStatus::Disconnected(name.clone()),
                None => PadStatus::NoneConnected,
            };
            return input;
        };
        if self.in_use.as_ref().map(|(id, _)| *id) != Some(pad.id) {
            self.in_use = Some((pad.id, pad.name.clone()));
            self.centred = [false; 3];
        }
        self.lost = None;
        input.status = PadStatus::Connected(pad.name.clone());
        for (i, channel) in ManualChannel::ALL.into_iter().enumerate() {
            let deflection = config.channel(channel).read(&pad.axes);
            if suspended {
                self.centred[i] = false;
                continue;
            }
            match deflection {
                None => self.centred[i] = true,
                Some(x) if self.centred[i] => input.sticks[i] = Some(percent_around(x, neutral[i])),
                Some(_) => input.waiting_for_centre[i] = true,
            }
        }
        input
    }
}

/// The gamepads, or why there are none.
pub struct Gamepads {
    gilrs: Result<gilrs::Gilrs, String>,
    in_use: Option<gilrs::GamepadId>,
    /// Counts the gamepads taken into use ([`PadSnapshot::id`]).
    connections: usize,
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
            in_use: None,
            connections: 0,
        }
    }

    /// Why gamepads are unavailable, if they are.
    pub fn unavailable(&self) -> Option<&str> {
        self.gilrs.as_ref().err().map(String::as_str)
    }

    /// Reads the events since the last call (`kill_button` pressed on any gamepad) and the
    /// axes of the gamepad in use: the one used so far while it stays connected, else the
    /// first connected. A gamepad unplugged and plugged in again between two calls counts as
    /// a new connection.
    pub fn poll(&mut self, kill_button: PadButton) -> PadReading {
        let Ok(gilrs) = self.gilrs.as_mut() else {
            return PadReading::default();
        };
        let mut reading = PadReading::default();
        let kill = gilrs_button(kill_button);
        while let Some(event) = gilrs.next_event() {
            match event.event {
                gilrs::EventType::ButtonPressed(button, _) => reading.kill |= button == kill,
                gilrs::EventType::Disconnected if Some(event.id) == self.in_use => {
                    self.in_use = None;
                }
                _ => {}
            }
        }
        let still_connected = self
            .in_use
            .and_then(|id| gilrs.connected_gamepad(id))
            .map(|p| p.id());
        if still_connected.is_none() {
            self.in_use = gilrs
                .gamepads()
                .find(|(_, p)| p.is_connected())
                .map(|(id, _)| id);
            self.connections += usize::from(self.in_use.is_some());
        }
        if let Some(pad) = self.in_use.and_then(|id| gilrs.connected_gamepad(id)) {
            reading.pad = Some(PadSnapshot {
                id: self.connections,
                name: pad.name().to_owned(),
                axes: StickAxis::ALL.map(|a| {
                    let axis = gilrs_axis(a);
                    pad.axis_code(axis).map(|_| pad.value(axis))
                }),
            });
        }
        reading
    }
}

/// The gamepad library's name for an axis.
fn gilrs_axis(axis: StickAxis) -> gilrs::Axis {
    match axis {
        StickAxis::LeftStickX => gilrs::Axis::LeftStickX,
        StickAxis::LeftStickY => gilrs::Axis::LeftStickY,
        StickAxis::LeftZ => gilrs::Axis::LeftZ,
        StickAxis::RightStickX => gilrs::Axis::RightStickX,
        StickAxis::RightStickY => gilrs::Axis::RightStickY,
        StickAxis::RightZ => gilrs::Axis::RightZ,
        StickAxis::DPadX => gilrs::Axis::DPadX,
        StickAxis::DPadY => gilrs::Axis::DPadY,
    }
}

/// The gamepad library's name for a button.
fn gilrs_button(button: PadButton) -> gilrs::Button {
    match button {
        PadButton::South => gilrs::Button::South,
        PadButton::East => gilrs::Button::East,
        PadButton::North => gilrs::Button::North,
        PadButton::West => gilrs::Button::West,
        PadButton::C => gilrs::Button::C,
        PadButton::Z => gilrs::Button::Z,
        PadButton::LeftTrigger => gilrs::Button::LeftTrigger,
        PadButton::LeftTrigger2 => gilrs::Button::LeftTrigger2,
        PadButton::RightTrigger => gilrs::Button::RightTrigger,
        PadButton::RightTrigger2 => gilrs::Button::RightTrigger2,
        PadButton::Select => gilrs::Button::Select,
        PadButton::Start => gilrs::Button::Start,
        PadButton::Mode => gilrs::Button::Mode,
        PadButton::LeftThumb => gilrs::Button::LeftThumb,
        PadButton::RightThumb => gilrs::Button::RightThumb,
        PadButton::DPadUp => gilrs::Button::DPadUp,
        PadButton::DPadDown => gilrs::Button::DPadDown,
        PadButton::DPadLeft => gilrs::Button::DPadLeft,
        PadButton::DPadRight => gilrs::Button::DPadRight,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::channels::ChannelTable;
    use crate::control::{ManualControl, ManualInputs, Source};
    use crate::link::LinkControl;
    use dima_groundlink::Command;

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    /// Gamepad `id` with the default throttle (LeftStickY) and steering (RightStickX) axes.
    fn pad(id: usize, throttle: f32, steering: f32) -> PadReading {
        let mut axes: AxesSample = [Some(0.0); StickAxis::COUNT];
        axes[StickAxis::LeftStickY as usize] = Some(throttle);
        axes[StickAxis::RightStickX as usize] = Some(steering);
        PadReading {
            pad: Some(PadSnapshot {
                id,
                name: format!("Pad {id}"),
                axes,
            }),
            kill: false,
        }
    }

    /// The station's loop for the gamepad alone: driver, then the manual merge.
    struct Station {
        driver: GamepadDriver,
        manual: ManualControl,
        config: JoystickConfig,
        calibrating: bool,
    }

    impl Station {
        fn new() -> Station {
            Station {
                driver: GamepadDriver::default(),
                manual: ManualControl::new(&ChannelTable::default()),
                config: JoystickConfig::default(),
                calibrating: false,
            }
        }

        fn frame(&mut self, reading: &PadReading) -> (GamepadInput, Vec<LinkControl>) {
            let neutral = ManualChannel::ALL.map(|c| self.manual.neutral(c));
            let input = self
                .driver
                .update(reading, &self.config, neutral, self.calibrating);
            let sent = self.manual.update(&ManualInputs {
                gamepad: input.sticks,
                ..ManualInputs::default()
            });
            (input, sent)
        }
    }

    fn hold_throttle(v: u8) -> Vec<LinkControl> {
        vec![LinkControl::Hold(
            ManualChannel::Throttle,
            Some(Command::Throttle(pct(v))),
        )]
    }

    fn neutral_once() -> Vec<LinkControl> {
        vec![
            LinkControl::Hold(ManualChannel::Throttle, None),
            LinkControl::Request(Command::Throttle(pct(50))),
        ]
    }

    #[test]
    fn a_disconnect_sends_neutral_once_and_shows_disconnected() {
        let mut s = Station::new();
        let (input, sent) = s.frame(&pad(3, 0.0, 0.0));
        assert_eq!(input.status, PadStatus::Connected("Pad 3".into()));
        assert!(sent.is_empty());
        let (_, sent) = s.frame(&pad(3, 1.0, 0.0));
        assert_eq!(sent, hold_throttle(100));
        assert_eq!(
            s.manual.holder(ManualChannel::Throttle),
            Some(Source::Gamepad)
        );

        // Unplugged with the stick held: neutral once, shown as disconnected.
        let (input, sent) = s.frame(&PadReading::default());
        assert_eq!(input.status, PadStatus::Disconnected("Pad 3".into()));
        assert_eq!(input.sticks, [None; 3]);
        assert_eq!(sent, neutral_once());
        assert_eq!(s.manual.shown[0], pct(50));
        for _ in 0..5 {
            let (input, sent) = s.frame(&PadReading::default());
            assert!(sent.is_empty(), "neutral is sent once: {sent:?}");
            assert_eq!(input.status, PadStatus::Disconnected("Pad 3".into()));
        }

        // Plugged in again (a new id) with the stick still held: it does not drive until
        // it has been back to centre.
        let (input, sent) = s.frame(&pad(4, 1.0, 0.0));
        assert_eq!(input.status, PadStatus::Connected("Pad 4".into()));
        assert!(sent.is_empty());
        assert_eq!(input.waiting_for_centre, [true, false, false]);
        assert!(s.frame(&pad(4, 0.8, 0.0)).1.is_empty());
        assert!(s.frame(&pad(4, 0.0, 0.0)).1.is_empty());
        assert_eq!(s.frame(&pad(4, 1.0, 0.0)).1, hold_throttle(100));
    }

    #[test]
    fn a_stick_held_when_the_gamepad_connects_waits_for_centre() {
        let mut s = Station::new();
        assert_eq!(
            s.frame(&PadReading::default()).0.status,
            PadStatus::NoneConnected
        );
        for _ in 0..3 {
            let (input, sent) = s.frame(&pad(0, -1.0, 0.0));
            assert!(sent.is_empty());
            assert!(input.waiting_for_centre[0]);
        }
        s.frame(&pad(0, 0.05, 0.0));
        assert_eq!(s.frame(&pad(0, -1.0, 0.0)).1, hold_throttle(0));
    }

    #[test]
    fn another_gamepad_taking_over_releases_the_first_ones_channels() {
        let mut s = Station::new();
        s.frame(&pad(1, 0.0, 0.0));
        assert_eq!(s.frame(&pad(1, 1.0, 0.0)).1, hold_throttle(100));
        // Pad 1 gone, pad 2 (already connected, its stick pushed) is now the one in use.
        let (input, sent) = s.frame(&pad(2, 1.0, 0.0));
        assert_eq!(input.status, PadStatus::Connected("Pad 2".into()));
        assert_eq!(sent, neutral_once());
    }

    #[test]
    fn calibrating_releases_every_stick_and_kill_still_kills() {
        let mut s = Station::new();
        s.frame(&pad(0, 0.0, 0.0));
        assert_eq!(s.frame(&pad(0, 1.0, 0.0)).1, hold_throttle(100));
        s.calibrating = true;
        assert_eq!(s.frame(&pad(0, 1.0, 0.0)).1, neutral_once());
        // Full deflections while measuring: nothing drives.
        for (t, st) in [(-1.0, 1.0), (1.0, -1.0), (0.0, 0.0), (1.0, 0.0)] {
            let (input, sent) = s.frame(&pad(0, t, st));
            assert!(sent.is_empty());
            assert_eq!(input.sticks, [None; 3]);
        }
        let mut kill = pad(0, 1.0, 0.0);
        kill.kill = true;
        assert!(s.frame(&kill).0.kill);
        // Calibration over with the stick still held: back to centre first.
        s.calibrating = false;
        assert!(s.frame(&pad(0, 1.0, 0.0)).1.is_empty());
        s.frame(&pad(0, 0.0, 0.0));
        assert_eq!(s.frame(&pad(0, 1.0, 0.0)).1, hold_throttle(100));
    }

    #[test]
    fn the_configuration_shapes_what_drives() {
        let mut s = Station::new();
        s.config.throttle.invert = true;
        s.config.throttle.expo = 1.0;
        s.config.throttle.dead_zone = 0.0;
        s.config.tail.axis = Some(StickAxis::RightStickY);
        s.config.tail.dead_zone = 0.0;
        let mut reading = pad(0, 0.0, 0.0);
        s.frame(&reading);
        // Throttle pushed up half way: inverted, and expo 1 gives 0.5³ = 0.125 below centre.
        let axes = &mut reading.pad.as_mut().unwrap().axes;
        axes[StickAxis::LeftStickY as usize] = Some(0.5);
        axes[StickAxis::RightStickY as usize] = Some(1.0);
        let (input, _) = s.frame(&reading);
        assert_eq!(input.sticks, [Some(pct(44)), None, Some(pct(100))]);
    }
}
