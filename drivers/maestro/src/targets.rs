//! Sans-IO, checked target encoding: the per-cycle hot path of an application.
//!
//! [`TargetEncoder`] holds the model, framing and [`Limits`], checks every target and gives the
//! bytes to write; the application writes them with its own deadline. The driver
//! ([`Maestro`](crate::Maestro)) uses the same encoder, so both paths refuse the same targets.

use core::fmt;
use core::marker::PhantomData;

use crate::codec::{encode, encode_set_target, encode_set_targets, Framing, Packet, TargetFrame};
use crate::command::{Command, MultiTargets};
use crate::error::InvalidInput;
use crate::limits::Limits;
use crate::model::{MiniModel, Model};
use crate::types::{Channel, QuarterMicros};

/// Why a target was refused. Nothing is encoded when this is returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum TargetError {
    /// The channel does not exist on the model.
    InvalidChannel {
        /// The requested channel number.
        channel: u8,
        /// The number of channels of the model.
        channels: u8,
    },
    /// The target is outside the channel's limits.
    OutOfRange {
        /// The channel number.
        channel: u8,
        /// The rejected target in quarter-microseconds.
        target: u16,
        /// The lowest allowed target in quarter-microseconds.
        min: u16,
        /// The highest allowed target in quarter-microseconds.
        max: u16,
    },
    /// Too many targets, none, or consecutive channels running past the last channel.
    InvalidInput,
}

impl From<InvalidInput> for TargetError {
    fn from(_: InvalidInput) -> Self {
        TargetError::InvalidInput
    }
}

impl fmt::Display for TargetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TargetError::InvalidChannel { channel, channels } => write!(
                f,
                "channel {channel} does not exist on this Maestro (it has {channels} channels)"
            ),
            TargetError::OutOfRange {
                channel,
                target,
                min,
                max,
            } => write!(
                f,
                "target {target} (quarter-µs) on channel {channel} is outside the configured limits {min}..={max}"
            ),
            TargetError::InvalidInput => {
                f.write_str("value out of the range the Maestro protocol accepts")
            }
        }
    }
}

impl core::error::Error for TargetError {}

/// Checked, allocation-free encoder of targets for model `M`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TargetEncoder<M> {
    framing: Framing,
    limits: Limits,
    _model: PhantomData<M>,
}

impl<M: Model> TargetEncoder<M> {
    /// An encoder for `model` with `framing` and no limits.
    pub fn new(_model: M, framing: Framing) -> Self {
        Self {
            framing,
            limits: Limits::new(),
            _model: PhantomData,
        }
    }

    /// The same encoder with `limits` (builder style).
    pub const fn with_limits(mut self, limits: Limits) -> Self {
        self.limits = limits;
        self
    }

    /// Replace the limits.
    pub fn set_limits(&mut self, limits: Limits) {
        self.limits = limits;
    }

    /// The limits.
    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// The framing.
    pub fn framing(&self) -> Framing {
        self.framing
    }

    /// `Ok` if `channel` exists on model `M`.
    pub fn check_channel(&self, channel: Channel) -> Result<(), TargetError> {
        if channel.index() < M::CHANNELS {
            Ok(())
        } else {
            Err(TargetError::InvalidChannel {
                channel: channel.index(),
                channels: M::CHANNELS,
            })
        }
    }

    /// `Ok` if `channel` exists and `target` is within its limits.
    pub fn check(&self, channel: Channel, target: QuarterMicros) -> Result<(), TargetError> {
        self.check_channel(channel)?;
        match self.limits.check(channel, target) {
            Ok(_) => Ok(()),
            Err(v) => Err(TargetError::OutOfRange {
                channel: channel.index(),
                target: target.get(),
                min: v.limits.min().get(),
                max: v.limits.max().get(),
            }),
        }
    }

    /// One checked Set Target packet.
    pub fn encode_target(
        &self,
        channel: Channel,
        target: QuarterMicros,
    ) -> Result<Packet, TargetError> {
        self.check(channel, target)?;
        Ok(encode_set_target(self.framing, channel, target))
    }

    /// Set Target packets for every `(channel, target)`, concatenated for one write. Nothing
    /// is encoded unless every target passes.
    pub fn encode_targets(
        &self,
        targets: &[(Channel, QuarterMicros)],
    ) -> Result<TargetFrame, TargetError> {
        for &(channel, target) in targets {
            self.check(channel, target)?;
        }
        encode_set_targets(self.framing, targets).ok_or(TargetError::InvalidInput)
    }

    /// Set Target 0 (stop pulses) for `channel`, regardless of limits.
    pub fn encode_stop_pulses(&self, channel: Channel) -> Result<Packet, TargetError> {
        self.check_channel(channel)?;
        Ok(encode_set_target(self.framing, channel, QuarterMicros::OFF))
    }
}

impl<M: MiniModel> TargetEncoder<M> {
    /// One checked Set Multiple Targets packet for consecutive channels from `first`
    /// (Mini Maestro only): 3 bytes plus 2 per channel, plus framing.
    pub fn encode_multiple_targets(
        &self,
        first: Channel,
        targets: &[QuarterMicros],
    ) -> Result<Packet, TargetError> {
        let multi = MultiTargets::new(first, targets)?;
        for (index, target) in multi.iter() {
            self.check(Channel::any_model(index)?, target)?;
        }
        Ok(encode(&Command::SetMultipleTargets(multi), self.framing))
    }
}
