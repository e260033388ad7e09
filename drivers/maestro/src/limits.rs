//! Per-channel target limits, so the application cannot command a pulse the mechanics or the
//! ESC must not see.

use crate::error::InvalidInput;
use crate::types::{Channel, QuarterMicros, MAX_CHANNELS};

/// The allowed range and the neutral target of one channel, in quarter-microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChannelLimits {
    min: QuarterMicros,
    max: QuarterMicros,
    neutral: QuarterMicros,
}

impl ChannelLimits {
    /// Limits `min..=max` with `neutral` in between; [`InvalidInput`] unless
    /// `min <= neutral <= max`.
    pub const fn new(
        min: QuarterMicros,
        max: QuarterMicros,
        neutral: QuarterMicros,
    ) -> Result<Self, InvalidInput> {
        if min.get() <= neutral.get() && neutral.get() <= max.get() {
            Ok(Self { min, max, neutral })
        } else {
            Err(InvalidInput)
        }
    }

    /// Limits in whole microseconds (e.g. a steering servo: 1250, 1840, 1545); [`InvalidInput`]
    /// if a value exceeds 4095 µs or the order is wrong.
    pub const fn from_micros(
        min_us: u16,
        max_us: u16,
        neutral_us: u16,
    ) -> Result<Self, InvalidInput> {
        match (
            QuarterMicros::from_micros(min_us),
            QuarterMicros::from_micros(max_us),
            QuarterMicros::from_micros(neutral_us),
        ) {
            (Ok(min), Ok(max), Ok(neutral)) => Self::new(min, max, neutral),
            _ => Err(InvalidInput),
        }
    }

    /// Lowest allowed target.
    pub const fn min(&self) -> QuarterMicros {
        self.min
    }

    /// Highest allowed target.
    pub const fn max(&self) -> QuarterMicros {
        self.max
    }

    /// The neutral (safe) target.
    pub const fn neutral(&self) -> QuarterMicros {
        self.neutral
    }

    /// True if `target` is within `min..=max`.
    pub const fn contains(&self, target: QuarterMicros) -> bool {
        self.min.get() <= target.get() && target.get() <= self.max.get()
    }

    /// `target` clamped into `min..=max`. An explicit choice of the caller; the driver never
    /// clamps on its own.
    pub const fn clamp(&self, target: QuarterMicros) -> QuarterMicros {
        if target.get() < self.min.get() {
            self.min
        } else if target.get() > self.max.get() {
            self.max
        } else {
            target
        }
    }
}

/// A target rejected by [`Limits::check`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LimitViolation {
    /// The channel.
    pub channel: Channel,
    /// The rejected target.
    pub target: QuarterMicros,
    /// The channel's limits.
    pub limits: ChannelLimits,
}

/// Optional limits for each of up to 24 channels. Channels without limits accept any target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Limits {
    channels: [Option<ChannelLimits>; MAX_CHANNELS as usize],
}

impl Limits {
    /// No limits on any channel.
    pub const fn new() -> Self {
        Self {
            channels: [None; MAX_CHANNELS as usize],
        }
    }

    /// These limits with `limits` set for `channel` (builder style).
    pub const fn with(mut self, channel: Channel, limits: ChannelLimits) -> Self {
        self.channels[channel.index() as usize] = Some(limits);
        self
    }

    /// Set or remove the limits of `channel`.
    pub fn set(&mut self, channel: Channel, limits: Option<ChannelLimits>) {
        if let Some(slot) = self.channels.get_mut(channel.index() as usize) {
            *slot = limits;
        }
    }

    /// The limits of `channel`, if any.
    pub fn get(&self, channel: Channel) -> Option<ChannelLimits> {
        self.channels
            .get(channel.index() as usize)
            .copied()
            .flatten()
    }

    /// `Ok(target)` if `channel` has no limits or `target` is within them.
    ///
    /// [`QuarterMicros::OFF`] is rejected on a limited channel like any other value below the
    /// minimum: stopping pulses is a separate, explicit driver call.
    pub fn check(
        &self,
        channel: Channel,
        target: QuarterMicros,
    ) -> Result<QuarterMicros, LimitViolation> {
        match self.get(channel) {
            Some(limits) if !limits.contains(target) => Err(LimitViolation {
                channel,
                target,
                limits,
            }),
            _ => Ok(target),
        }
    }

    /// `target` clamped into the limits of `channel` (unchanged if it has none).
    pub fn clamp(&self, channel: Channel, target: QuarterMicros) -> QuarterMicros {
        match self.get(channel) {
            Some(limits) => limits.clamp(target),
            None => target,
        }
    }

    /// The neutral target of `channel`, if it has limits.
    pub fn neutral(&self, channel: Channel) -> Option<QuarterMicros> {
        self.get(channel).map(|l| l.neutral())
    }
}
