//! Checked value types: every constructor rejects what the wire cannot carry.

use crate::error::InvalidInput;
use crate::model::Model;

/// Largest value a two-data-byte field can carry: 14 bits, 7 per byte.
pub const MAX_14_BIT: u16 = 0x3FFF;

/// Highest channel count of any Maestro (Mini Maestro 24). Every [`Channel`] is below it.
pub const MAX_CHANNELS: u8 = 24;

/// A servo pulse width (or other channel target) in quarter-microseconds, `0..=16383`.
///
/// The Maestro encodes targets in 14 bits of 0.25 µs, so the longest pulse is 4095.75 µs.
/// [`QuarterMicros::OFF`] (0) tells the Maestro to stop sending pulses on the channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct QuarterMicros(u16);

impl QuarterMicros {
    /// Target 0: the Maestro stops sending pulses on the channel.
    pub const OFF: Self = Self(0);
    /// 1500 µs, the neutral pulse of hobby servos and ESCs.
    pub const NEUTRAL: Self = Self(6000);
    /// The largest target, 16383 quarter-microseconds (4095.75 µs).
    pub const MAX: Self = Self(MAX_14_BIT);

    /// A target in quarter-microseconds; fails above 16383.
    pub const fn new(quarter_micros: u16) -> Result<Self, InvalidInput> {
        if quarter_micros <= MAX_14_BIT {
            Ok(Self(quarter_micros))
        } else {
            Err(InvalidInput)
        }
    }

    /// A target in whole microseconds; fails above 4095 µs.
    pub const fn from_micros(micros: u16) -> Result<Self, InvalidInput> {
        if micros <= MAX_14_BIT / 4 {
            Ok(Self(micros * 4))
        } else {
            Err(InvalidInput)
        }
    }

    /// A target in nanoseconds, rounded to the nearest quarter-microsecond; fails above
    /// 4095.75 µs. Useful when a controller computes pulses with sub-microsecond resolution.
    pub const fn from_nanos(nanos: u32) -> Result<Self, InvalidInput> {
        let quarter = (nanos as u64 + 125) / 250;
        if quarter <= MAX_14_BIT as u64 {
            Ok(Self(quarter as u16))
        } else {
            Err(InvalidInput)
        }
    }

    /// The target in quarter-microseconds.
    pub const fn get(self) -> u16 {
        self.0
    }

    /// The target in whole microseconds, rounded down.
    pub const fn as_micros(self) -> u16 {
        self.0 / 4
    }
}

impl TryFrom<u16> for QuarterMicros {
    type Error = InvalidInput;
    fn try_from(value: u16) -> Result<Self, Self::Error> {
        Self::new(value)
    }
}

impl From<QuarterMicros> for u16 {
    fn from(value: QuarterMicros) -> Self {
        value.0
    }
}

/// A channel number that exists on at least one Maestro (`0..24`).
///
/// Build it with [`Channel::new`] for a given model, which checks it against that model's
/// channel count; the driver checks it again against its own model, so a channel made for a
/// Mini Maestro 24 is rejected by a Micro Maestro driver instead of being sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Channel(u8);

impl Channel {
    /// Channel `index` of model `M`; fails if `index >= M::CHANNELS`.
    pub const fn new<M: Model>(index: u8) -> Result<Self, InvalidInput> {
        if index < M::CHANNELS {
            Ok(Self(index))
        } else {
            Err(InvalidInput)
        }
    }

    /// Channel `index` of any model (`index < 24`), for code that does not know the model,
    /// such as a decoder of received commands.
    pub const fn any_model(index: u8) -> Result<Self, InvalidInput> {
        if index < MAX_CHANNELS {
            Ok(Self(index))
        } else {
            Err(InvalidInput)
        }
    }

    /// The channel number.
    pub const fn index(self) -> u8 {
        self.0
    }
}

impl From<Channel> for u8 {
    fn from(value: Channel) -> Self {
        value.0
    }
}

/// A speed limit in units of 0.25 µs per 10 ms, `0..=16383`; 0 means unlimited.
///
/// For example 140 is 3.5 µs/ms: a 350 µs move takes 100 ms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Speed(u16);

impl Speed {
    /// No speed limit.
    pub const UNLIMITED: Self = Self(0);

    /// A speed limit in (0.25 µs)/(10 ms); fails above 16383.
    pub const fn new(value: u16) -> Result<Self, InvalidInput> {
        if value <= MAX_14_BIT {
            Ok(Self(value))
        } else {
            Err(InvalidInput)
        }
    }

    /// The raw value in (0.25 µs)/(10 ms).
    pub const fn get(self) -> u16 {
        self.0
    }
}

/// An acceleration limit in units of (0.25 µs)/(10 ms)/(80 ms), `0..=255`; 0 means unlimited.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Acceleration(u8);

impl Acceleration {
    /// No acceleration limit.
    pub const UNLIMITED: Self = Self(0);

    /// An acceleration limit; every `u8` is valid.
    pub const fn new(value: u8) -> Self {
        Self(value)
    }

    /// The raw value.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// The PWM output of the Mini Maestros: on time and period in units of 1/48 µs.
///
/// Both are 14-bit values and the on time cannot exceed the period.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PwmTiming {
    on_time: u16,
    period: u16,
}

impl PwmTiming {
    /// PWM with `on_time` and `period` in 1/48 µs; fails if either exceeds 16383 or
    /// `on_time > period`.
    pub const fn new(on_time: u16, period: u16) -> Result<Self, InvalidInput> {
        if on_time <= MAX_14_BIT && period <= MAX_14_BIT && on_time <= period {
            Ok(Self { on_time, period })
        } else {
            Err(InvalidInput)
        }
    }

    /// On time in 1/48 µs.
    pub const fn on_time(self) -> u16 {
        self.on_time
    }

    /// Period in 1/48 µs.
    pub const fn period(self) -> u16 {
        self.period
    }
}

/// The number of a script subroutine, `0..=127`, in the order the script defines them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Subroutine(u8);

impl Subroutine {
    /// Subroutine `number`; fails above 127 (one data byte).
    pub const fn new(number: u8) -> Result<Self, InvalidInput> {
        if number <= 0x7F {
            Ok(Self(number))
        } else {
            Err(InvalidInput)
        }
    }

    /// The subroutine number.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// The parameter pushed on the script stack by Restart Script at Subroutine with Parameter,
/// `0..=16383`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScriptParameter(u16);

impl ScriptParameter {
    /// A parameter; fails above 16383 (two 7-bit data bytes).
    pub const fn new(value: u16) -> Result<Self, InvalidInput> {
        if value <= MAX_14_BIT {
            Ok(Self(value))
        } else {
            Err(InvalidInput)
        }
    }

    /// The parameter value.
    pub const fn get(self) -> u16 {
        self.0
    }
}

/// The device number of the Pololu protocol, `0..=127` (factory default 12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DeviceNumber(u8);

impl DeviceNumber {
    /// The factory default device number, 12.
    pub const DEFAULT: Self = Self(12);

    /// Device number `number`; fails above 127.
    pub const fn new(number: u8) -> Result<Self, InvalidInput> {
        if number <= 0x7F {
            Ok(Self(number))
        } else {
            Err(InvalidInput)
        }
    }

    /// The device number.
    pub const fn get(self) -> u8 {
        self.0
    }
}

impl Default for DeviceNumber {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// An 8-bit Mini SSC value, `0..=254`: 127 is the channel's neutral and the ends map to the
/// neutral plus or minus the range configured in the Maestro.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MiniSscValue(u8);

impl MiniSscValue {
    /// The neutral position, 127.
    pub const NEUTRAL: Self = Self(127);

    /// A value; fails on 255 (0xFF is the Mini SSC command byte).
    pub const fn new(value: u8) -> Result<Self, InvalidInput> {
        if value != 0xFF {
            Ok(Self(value))
        } else {
            Err(InvalidInput)
        }
    }

    /// The raw value.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// A Mini SSC servo number, `0..=254`: the Maestro subtracts its configured Mini SSC offset to
/// find the channel, so several controllers can share one line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MiniSscServo(u8);

impl MiniSscServo {
    /// Servo number `number`; fails on 255.
    pub const fn new(number: u8) -> Result<Self, InvalidInput> {
        if number != 0xFF {
            Ok(Self(number))
        } else {
            Err(InvalidInput)
        }
    }

    /// The raw servo number.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// Whether the user script is running (reply of Get Script Status).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScriptStatus {
    /// The script is running (reply byte 0x00).
    Running,
    /// The script is stopped (reply byte 0x01).
    Stopped,
}
