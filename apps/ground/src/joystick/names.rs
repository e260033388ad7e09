//! The gamepad axes and buttons by name, as the configuration file spells them (the names of
//! the gamepad library's standard layout).

use std::fmt;

/// A gamepad axis of the standard layout. Sticks read -1..=1: up and right positive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StickAxis {
    /// Left stick, horizontal.
    LeftStickX,
    /// Left stick, vertical.
    LeftStickY,
    /// Left trigger or third left axis.
    LeftZ,
    /// Right stick, horizontal.
    RightStickX,
    /// Right stick, vertical.
    RightStickY,
    /// Right trigger or third right axis.
    RightZ,
    /// Directional pad, horizontal (on pads that report it as an axis).
    DPadX,
    /// Directional pad, vertical.
    DPadY,
}

/// One value per [`StickAxis`] (indexed by `axis as usize`), `None` where the gamepad has no
/// such axis or none is connected.
pub type AxesSample = [Option<f32>; StickAxis::COUNT];

impl StickAxis {
    /// How many axes there are.
    pub const COUNT: usize = 8;

    /// Every axis, in index order.
    pub const ALL: [StickAxis; StickAxis::COUNT] = [
        StickAxis::LeftStickX,
        StickAxis::LeftStickY,
        StickAxis::LeftZ,
        StickAxis::RightStickX,
        StickAxis::RightStickY,
        StickAxis::RightZ,
        StickAxis::DPadX,
        StickAxis::DPadY,
    ];

    /// The name in the configuration file.
    pub fn name(self) -> &'static str {
        match self {
            StickAxis::LeftStickX => "LeftStickX",
            StickAxis::LeftStickY => "LeftStickY",
            StickAxis::LeftZ => "LeftZ",
            StickAxis::RightStickX => "RightStickX",
            StickAxis::RightStickY => "RightStickY",
            StickAxis::RightZ => "RightZ",
            StickAxis::DPadX => "DPadX",
            StickAxis::DPadY => "DPadY",
        }
    }

    /// The axis called `name` (exact spelling).
    pub fn from_name(name: &str) -> Option<StickAxis> {
        StickAxis::ALL.into_iter().find(|a| a.name() == name)
    }

    /// This axis's value in `sample`.
    pub fn value_in(self, sample: &AxesSample) -> Option<f32> {
        sample[self as usize]
    }
}

impl fmt::Display for StickAxis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A gamepad button of the standard layout (South is A on Xbox pads, × on PlayStation pads).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PadButton {
    /// A / ×.
    South,
    /// B / ○.
    East,
    /// Y / △.
    North,
    /// X / □.
    West,
    /// Extra action button C.
    C,
    /// Extra action button Z.
    Z,
    /// Left shoulder (LB / L1).
    LeftTrigger,
    /// Left trigger (LT / L2).
    LeftTrigger2,
    /// Right shoulder (RB / R1).
    RightTrigger,
    /// Right trigger (RT / R2).
    RightTrigger2,
    /// Select / Back / Share.
    Select,
    /// Start / Options.
    Start,
    /// The vendor's logo button.
    Mode,
    /// Left stick pressed.
    LeftThumb,
    /// Right stick pressed.
    RightThumb,
    /// Directional pad up.
    DPadUp,
    /// Directional pad down.
    DPadDown,
    /// Directional pad left.
    DPadLeft,
    /// Directional pad right.
    DPadRight,
}

impl PadButton {
    /// Every button.
    pub const ALL: [PadButton; 19] = [
        PadButton::South,
        PadButton::East,
        PadButton::North,
        PadButton::West,
        PadButton::C,
        PadButton::Z,
        PadButton::LeftTrigger,
        PadButton::LeftTrigger2,
        PadButton::RightTrigger,
        PadButton::RightTrigger2,
        PadButton::Select,
        PadButton::Start,
        PadButton::Mode,
        PadButton::LeftThumb,
        PadButton::RightThumb,
        PadButton::DPadUp,
        PadButton::DPadDown,
        PadButton::DPadLeft,
        PadButton::DPadRight,
    ];

    /// The name in the configuration file.
    pub fn name(self) -> &'static str {
        match self {
            PadButton::South => "South",
            PadButton::East => "East",
            PadButton::North => "North",
            PadButton::West => "West",
            PadButton::C => "C",
            PadButton::Z => "Z",
            PadButton::LeftTrigger => "LeftTrigger",
            PadButton::LeftTrigger2 => "LeftTrigger2",
            PadButton::RightTrigger => "RightTrigger",
            PadButton::RightTrigger2 => "RightTrigger2",
            PadButton::Select => "Select",
            PadButton::Start => "Start",
            PadButton::Mode => "Mode",
            PadButton::LeftThumb => "LeftThumb",
            PadButton::RightThumb => "RightThumb",
            PadButton::DPadUp => "DPadUp",
            PadButton::DPadDown => "DPadDown",
            PadButton::DPadLeft => "DPadLeft",
            PadButton::DPadRight => "DPadRight",
        }
    }

    /// The button called `name` (exact spelling).
    pub fn from_name(name: &str) -> Option<PadButton> {
        PadButton::ALL.into_iter().find(|b| b.name() == name)
    }
}

impl fmt::Display for PadButton {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_index_their_sample_slot() {
        for (i, axis) in StickAxis::ALL.into_iter().enumerate() {
            assert_eq!(axis as usize, i);
            assert_eq!(StickAxis::from_name(axis.name()), Some(axis));
        }
        for button in PadButton::ALL {
            assert_eq!(PadButton::from_name(button.name()), Some(button));
        }
        assert_eq!(StickAxis::from_name("leftsticky"), None);
        assert_eq!(PadButton::from_name("A"), None);
        let mut sample: AxesSample = [None; StickAxis::COUNT];
        sample[StickAxis::RightStickX as usize] = Some(0.5);
        assert_eq!(StickAxis::RightStickX.value_in(&sample), Some(0.5));
        assert_eq!(StickAxis::LeftStickX.value_in(&sample), None);
    }
}
