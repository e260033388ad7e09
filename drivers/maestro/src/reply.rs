//! Sans-IO replies: the bytes the Maestro answers to queries, both directions.
//!
//! The host decodes them; a simulated Maestro encodes them. Replies are raw bytes (8 bits each,
//! low byte first) without framing, and without CRC even in CRC mode (the user's guide: the
//! Maestro does not append a CRC byte to its responses).

use crate::status::ErrorFlags;
use crate::types::ScriptStatus;

/// Decode a Get Position reply (low byte, high byte).
///
/// For a servo channel this is the pulse width currently output, in quarter-microseconds; for
/// an input channel the measured value (0..=1023).
pub const fn decode_position(reply: [u8; 2]) -> u16 {
    u16::from_le_bytes(reply)
}

/// Encode a Get Position reply.
pub const fn encode_position(position: u16) -> [u8; 2] {
    position.to_le_bytes()
}

/// Decode a Get Errors reply (bits 0-7, bits 8-15). Undocumented bits are kept.
pub const fn decode_errors(reply: [u8; 2]) -> ErrorFlags {
    ErrorFlags::from_bits_retain(u16::from_le_bytes(reply))
}

/// Encode a Get Errors reply.
pub const fn encode_errors(errors: ErrorFlags) -> [u8; 2] {
    errors.bits().to_le_bytes()
}

/// Decode a Get Moving State reply: `Ok(true)` if any servo is still moving; `Err(byte)` for a
/// byte other than 0 or 1.
pub const fn decode_moving_state(reply: u8) -> Result<bool, u8> {
    match reply {
        0 => Ok(false),
        1 => Ok(true),
        other => Err(other),
    }
}

/// Encode a Get Moving State reply.
pub const fn encode_moving_state(moving: bool) -> u8 {
    moving as u8
}

/// Decode a Get Script Status reply; `Err(byte)` for a byte other than 0 or 1.
pub const fn decode_script_status(reply: u8) -> Result<ScriptStatus, u8> {
    match reply {
        0 => Ok(ScriptStatus::Running),
        1 => Ok(ScriptStatus::Stopped),
        other => Err(other),
    }
}

/// Encode a Get Script Status reply.
pub const fn encode_script_status(status: ScriptStatus) -> u8 {
    match status {
        ScriptStatus::Running => 0,
        ScriptStatus::Stopped => 1,
    }
}
