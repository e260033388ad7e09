//! Types shared by the three dies.

/// Three values, one per axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Xyz<T> {
    /// X axis.
    pub x: T,
    /// Y axis.
    pub y: T,
    /// Z axis.
    pub z: T,
}

impl<T> Xyz<T> {
    /// Build from three values.
    pub const fn new(x: T, y: T, z: T) -> Self {
        Self { x, y, z }
    }
    /// Apply `f` to each axis.
    pub fn map<U>(self, mut f: impl FnMut(T) -> U) -> Xyz<U> {
        Xyz {
            x: f(self.x),
            y: f(self.y),
            z: f(self.z),
        }
    }
}

impl<T: Copy> Xyz<T> {
    /// The three values as an array `[x, y, z]`.
    pub fn to_array(self) -> [T; 3] {
        [self.x, self.y, self.z]
    }
}

/// INT1 or INT2 pin of a die.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InterruptPin {
    /// INT1 (accel INT1 / gyro INT3 on the BMX055 pinout).
    Int1,
    /// INT2 (accel INT2 / gyro INT4 on the BMX055 pinout).
    Int2,
}

/// Electrical behaviour of an interrupt pin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PinConfig {
    /// `true`: active high; `false`: active low.
    pub active_high: bool,
    /// `true`: open drain; `false`: push-pull.
    pub open_drain: bool,
}

impl Default for PinConfig {
    /// The reset state: active high, push-pull.
    fn default() -> Self {
        Self {
            active_high: true,
            open_drain: false,
        }
    }
}

/// FIFO operating mode (accelerometer and gyroscope share the encoding).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FifoMode {
    /// FIFO off; only the latest sample is kept.
    Bypass = 0,
    /// Collect until full, then stop.
    Fifo = 1,
    /// Collect continuously, discarding the oldest frame when full.
    Stream = 2,
}

/// Which axes a FIFO frame carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FifoData {
    /// X, Y and Z: 6-byte frames.
    Xyz = 0,
    /// X only: 2-byte frames.
    X = 1,
    /// Y only.
    Y = 2,
    /// Z only.
    Z = 3,
}

impl FifoData {
    /// Bytes per FIFO frame.
    pub const fn frame_len(self) -> usize {
        match self {
            FifoData::Xyz => 6,
            _ => 2,
        }
    }
}

/// FIFO fill level read from a die's `FIFO_STATUS` register.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FifoStatus {
    /// Frames waiting in the FIFO.
    pub frames: u8,
    /// Frames were lost because the FIFO was full.
    pub overrun: bool,
}

impl FifoStatus {
    /// Decode the `FIFO_STATUS` byte (bit 7 overrun, bits 6:0 frame count).
    pub const fn from_register(value: u8) -> Self {
        Self {
            frames: value & 0x7F,
            overrun: value & 0x80 != 0,
        }
    }
}
