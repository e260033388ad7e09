//! The Maestro command set: command bytes and the typed [`Command`].

use crate::error::InvalidInput;
use crate::types::{
    Acceleration, Channel, MiniSscServo, MiniSscValue, PwmTiming, QuarterMicros, ScriptParameter,
    Speed, Subroutine, MAX_CHANNELS,
};

/// Command bytes of the compact protocol (the Pololu protocol sends them with bit 7 cleared).
pub mod opcode {
    /// Set Target: channel, target low 7 bits, target high 7 bits.
    pub const SET_TARGET: u8 = 0x84;
    /// Set Speed: channel, speed low 7 bits, speed high 7 bits.
    pub const SET_SPEED: u8 = 0x87;
    /// Set Acceleration: channel, acceleration low 7 bits, acceleration high 7 bits.
    pub const SET_ACCELERATION: u8 = 0x89;
    /// Set PWM (Mini Maestro only): on time low/high, period low/high, in 1/48 µs.
    pub const SET_PWM: u8 = 0x8A;
    /// Get Position: channel; reply position low byte, high byte.
    pub const GET_POSITION: u8 = 0x90;
    /// Get Moving State (Mini Maestro only); reply 0x00 (no servo moving) or 0x01.
    pub const GET_MOVING_STATE: u8 = 0x93;
    /// Set Multiple Targets (Mini Maestro only): count, first channel, count targets.
    pub const SET_MULTIPLE_TARGETS: u8 = 0x9F;
    /// Get Errors; reply error bits 0-7, then bits 8-15. Reading clears them.
    pub const GET_ERRORS: u8 = 0xA1;
    /// Go Home: all channels to their configured home positions.
    pub const GO_HOME: u8 = 0xA2;
    /// Stop Script.
    pub const STOP_SCRIPT: u8 = 0xA4;
    /// Restart Script at Subroutine: subroutine number.
    pub const RESTART_SCRIPT: u8 = 0xA7;
    /// Restart Script at Subroutine with Parameter: subroutine, parameter low/high 7 bits.
    pub const RESTART_SCRIPT_WITH_PARAMETER: u8 = 0xA8;
    /// Get Script Status; reply 0x00 (running) or 0x01 (stopped).
    pub const GET_SCRIPT_STATUS: u8 = 0xAE;
    /// First byte of a Pololu protocol packet: 0xAA, device number, command with bit 7 cleared.
    pub const POLOLU: u8 = 0xAA;
    /// First byte of a Mini SSC packet: 0xFF, servo number, 8-bit value.
    pub const MINI_SSC: u8 = 0xFF;
}

/// The number of data bytes following a compact command byte, or `None` for an unknown command.
///
/// Set Multiple Targets has a variable length: this gives its fixed head (count and first
/// channel); the targets follow.
pub(crate) const fn data_len(command: u8) -> Option<usize> {
    match command {
        opcode::SET_TARGET | opcode::SET_SPEED | opcode::SET_ACCELERATION => Some(3),
        opcode::SET_PWM => Some(4),
        opcode::GET_POSITION | opcode::RESTART_SCRIPT => Some(1),
        opcode::GET_MOVING_STATE
        | opcode::GET_ERRORS
        | opcode::GO_HOME
        | opcode::STOP_SCRIPT
        | opcode::GET_SCRIPT_STATUS => Some(0),
        opcode::SET_MULTIPLE_TARGETS => Some(2),
        opcode::RESTART_SCRIPT_WITH_PARAMETER => Some(3),
        _ => None,
    }
}

/// Targets for consecutive channels, for Set Multiple Targets: between 1 and 24 targets, the
/// last channel below 24.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MultiTargets {
    first: Channel,
    /// Slots past `len` stay [`QuarterMicros::OFF`], so the derived equality is exact.
    targets: [QuarterMicros; MAX_CHANNELS as usize],
    len: u8,
}

impl MultiTargets {
    /// Targets for channels `first`, `first + 1`, ...; fails if `targets` is empty or runs past
    /// channel 23.
    pub fn new(first: Channel, targets: &[QuarterMicros]) -> Result<Self, InvalidInput> {
        if targets.is_empty() || first.index() as usize + targets.len() > MAX_CHANNELS as usize {
            return Err(InvalidInput);
        }
        let mut slots = [QuarterMicros::OFF; MAX_CHANNELS as usize];
        for (slot, target) in slots.iter_mut().zip(targets) {
            *slot = *target;
        }
        Ok(Self {
            first,
            targets: slots,
            len: targets.len() as u8,
        })
    }

    /// The first channel.
    pub fn first(&self) -> Channel {
        self.first
    }

    /// The targets, in channel order from [`first`](Self::first).
    pub fn targets(&self) -> &[QuarterMicros] {
        self.targets.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// `(channel, target)` pairs.
    pub fn iter(&self) -> impl Iterator<Item = (u8, QuarterMicros)> + '_ {
        self.targets()
            .iter()
            .enumerate()
            .map(|(i, t)| (self.first.index() + i as u8, *t))
    }
}

/// One Maestro command with checked fields.
///
/// Encode it with [`encode`](crate::encode); the device-side
/// [`CommandDecoder`](crate::CommandDecoder) produces the same values.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// Set Target: pulse width of a servo channel (0 stops pulses).
    SetTarget {
        /// The channel.
        channel: Channel,
        /// The target in quarter-microseconds.
        target: QuarterMicros,
    },
    /// Set Multiple Targets (Mini Maestro only).
    SetMultipleTargets(MultiTargets),
    /// Set Speed: speed limit of a channel.
    SetSpeed {
        /// The channel.
        channel: Channel,
        /// The speed limit.
        speed: Speed,
    },
    /// Set Acceleration: acceleration limit of a channel.
    SetAcceleration {
        /// The channel.
        channel: Channel,
        /// The acceleration limit.
        acceleration: Acceleration,
    },
    /// Set PWM (Mini Maestro only).
    SetPwm(PwmTiming),
    /// Get Position of a channel (two-byte reply).
    GetPosition {
        /// The channel.
        channel: Channel,
    },
    /// Get Moving State (Mini Maestro only; one-byte reply).
    GetMovingState,
    /// Get Errors (two-byte reply; clears the error register).
    GetErrors,
    /// Go Home.
    GoHome,
    /// Stop Script.
    StopScript,
    /// Restart Script at Subroutine.
    RestartScript(Subroutine),
    /// Restart Script at Subroutine with Parameter.
    RestartScriptWithParameter {
        /// The subroutine.
        subroutine: Subroutine,
        /// The parameter pushed on the script stack.
        parameter: ScriptParameter,
    },
    /// Get Script Status (one-byte reply).
    GetScriptStatus,
    /// Mini SSC Set Target: its own protocol (0xFF, servo, value), never framed or CRC'd.
    MiniSsc {
        /// The servo number (channel plus the Maestro's Mini SSC offset).
        servo: MiniSscServo,
        /// The 8-bit position.
        value: MiniSscValue,
    },
}

impl Command {
    /// The compact command byte (bit 7 set); 0xFF for Mini SSC.
    pub fn opcode(&self) -> u8 {
        match self {
            Command::SetTarget { .. } => opcode::SET_TARGET,
            Command::SetMultipleTargets(_) => opcode::SET_MULTIPLE_TARGETS,
            Command::SetSpeed { .. } => opcode::SET_SPEED,
            Command::SetAcceleration { .. } => opcode::SET_ACCELERATION,
            Command::SetPwm(_) => opcode::SET_PWM,
            Command::GetPosition { .. } => opcode::GET_POSITION,
            Command::GetMovingState => opcode::GET_MOVING_STATE,
            Command::GetErrors => opcode::GET_ERRORS,
            Command::GoHome => opcode::GO_HOME,
            Command::StopScript => opcode::STOP_SCRIPT,
            Command::RestartScript(_) => opcode::RESTART_SCRIPT,
            Command::RestartScriptWithParameter { .. } => opcode::RESTART_SCRIPT_WITH_PARAMETER,
            Command::GetScriptStatus => opcode::GET_SCRIPT_STATUS,
            Command::MiniSsc { .. } => opcode::MINI_SSC,
        }
    }

    /// The number of reply bytes the Maestro sends for this command (0 for commands without a
    /// reply).
    pub fn reply_len(&self) -> usize {
        match self {
            Command::GetPosition { .. } | Command::GetErrors => 2,
            Command::GetMovingState | Command::GetScriptStatus => 1,
            _ => 0,
        }
    }

    /// True for the commands only the Mini Maestros understand.
    pub fn is_mini_only(&self) -> bool {
        matches!(
            self,
            Command::SetMultipleTargets(_) | Command::SetPwm(_) | Command::GetMovingState
        )
    }
}
