//! Typed API frames: the frame data between the length and the checksum, starting with the
//! frame type byte. Parsing borrows the payload from the decoder's buffer; nothing allocates.

mod layout;

use self::layout::{Cursor, Emitter};
use crate::at::AtCommand;
use crate::codec::ByteSink;
use crate::types::{Address16, Address64, FrameError};

/// Frame type bytes.
pub mod frame_type {
    /// Local AT command, applied at once.
    pub const AT_COMMAND: u8 = 0x08;
    /// Local AT command, queued until `AC` or an applying command.
    pub const AT_COMMAND_QUEUE: u8 = 0x09;
    /// Transmit request.
    pub const TRANSMIT_REQUEST: u8 = 0x10;
    /// Explicit addressing command request (endpoints, cluster and profile).
    pub const EXPLICIT_ADDRESSING: u8 = 0x11;
    /// Remote AT command request.
    pub const REMOTE_AT_COMMAND: u8 = 0x17;
    /// Local AT command response.
    pub const AT_RESPONSE: u8 = 0x88;
    /// Modem status.
    pub const MODEM_STATUS: u8 = 0x8A;
    /// Transmit status.
    pub const TRANSMIT_STATUS: u8 = 0x8B;
    /// Receive packet.
    pub const RECEIVE_PACKET: u8 = 0x90;
    /// Explicit receive indicator.
    pub const EXPLICIT_RX: u8 = 0x91;
    /// Remote AT command response.
    pub const REMOTE_AT_RESPONSE: u8 = 0x97;
}

/// Status byte of an AT command response.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandStatus {
    /// 0: the command succeeded.
    Ok,
    /// 1: generic error.
    Error,
    /// 2: unknown command.
    InvalidCommand,
    /// 3: parameter out of range.
    InvalidParameter,
    /// 4: the remote command could not be delivered.
    TransmissionFailure,
    /// Any other value (newer firmware sets flag bits), kept as received.
    Other(u8),
}

impl From<u8> for CommandStatus {
    fn from(value: u8) -> Self {
        match value {
            0 => Self::Ok,
            1 => Self::Error,
            2 => Self::InvalidCommand,
            3 => Self::InvalidParameter,
            4 => Self::TransmissionFailure,
            other => Self::Other(other),
        }
    }
}

impl From<CommandStatus> for u8 {
    fn from(value: CommandStatus) -> Self {
        match value {
            CommandStatus::Ok => 0,
            CommandStatus::Error => 1,
            CommandStatus::InvalidCommand => 2,
            CommandStatus::InvalidParameter => 3,
            CommandStatus::TransmissionFailure => 4,
            CommandStatus::Other(other) => other,
        }
    }
}

/// Modem status codes (frame 0x8A).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModemStatus {
    /// 0x00: power-up or hardware reset.
    HardwareReset,
    /// 0x01: watchdog timer reset.
    WatchdogReset,
    /// 0x02: joined a network (routers and end devices) or associated (802.15.4).
    Joined,
    /// 0x03: left the network (disassociated).
    Disassociated,
    /// 0x06: coordinator started a network.
    CoordinatorStarted,
    /// 0x07: network security key updated.
    SecurityKeyUpdated,
    /// Any other code, kept as received.
    Other(u8),
}

impl From<u8> for ModemStatus {
    fn from(value: u8) -> Self {
        match value {
            0x00 => Self::HardwareReset,
            0x01 => Self::WatchdogReset,
            0x02 => Self::Joined,
            0x03 => Self::Disassociated,
            0x06 => Self::CoordinatorStarted,
            0x07 => Self::SecurityKeyUpdated,
            other => Self::Other(other),
        }
    }
}

impl From<ModemStatus> for u8 {
    fn from(value: ModemStatus) -> Self {
        match value {
            ModemStatus::HardwareReset => 0x00,
            ModemStatus::WatchdogReset => 0x01,
            ModemStatus::Joined => 0x02,
            ModemStatus::Disassociated => 0x03,
            ModemStatus::CoordinatorStarted => 0x06,
            ModemStatus::SecurityKeyUpdated => 0x07,
            ModemStatus::Other(other) => other,
        }
    }
}

/// AT command request (0x08) or queued AT command (0x09).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AtCommandFrame<'a> {
    /// Frame id echoed by the response; 0 asks for no response.
    pub frame_id: u8,
    /// Command name.
    pub command: AtCommand,
    /// Binary parameter (empty for a query).
    pub parameter: &'a [u8],
}

/// Transmit request (0x10).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TransmitRequest<'a> {
    /// Frame id echoed by the transmit status; 0 asks for no status.
    pub frame_id: u8,
    /// Destination 64-bit address.
    pub destination: Address64,
    /// Destination network address, [`Address16::UNKNOWN`] if not known.
    pub destination_16: Address16,
    /// Maximum hops of a broadcast; 0 means the network maximum.
    pub broadcast_radius: u8,
    /// Transmit options bit field (0 uses the `TO` setting).
    pub options: u8,
    /// Payload.
    pub data: &'a [u8],
}

/// Explicit addressing command request (0x11).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ExplicitAddressing<'a> {
    /// Frame id echoed by the transmit status.
    pub frame_id: u8,
    /// Destination 64-bit address.
    pub destination: Address64,
    /// Destination network address.
    pub destination_16: Address16,
    /// Source endpoint.
    pub source_endpoint: u8,
    /// Destination endpoint.
    pub destination_endpoint: u8,
    /// Cluster id.
    pub cluster_id: u16,
    /// Profile id.
    pub profile_id: u16,
    /// Maximum hops of a broadcast.
    pub broadcast_radius: u8,
    /// Transmit options.
    pub options: u8,
    /// Payload.
    pub data: &'a [u8],
}

/// Remote AT command request (0x17).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RemoteAtCommand<'a> {
    /// Frame id echoed by the response.
    pub frame_id: u8,
    /// Remote module's 64-bit address.
    pub destination: Address64,
    /// Remote module's network address.
    pub destination_16: Address16,
    /// Remote command options (bit 1: apply changes).
    pub options: u8,
    /// Command name.
    pub command: AtCommand,
    /// Binary parameter.
    pub parameter: &'a [u8],
}

/// AT command response (0x88).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AtResponse<'a> {
    /// Frame id of the request.
    pub frame_id: u8,
    /// Command name.
    pub command: AtCommand,
    /// Outcome.
    pub status: CommandStatus,
    /// Value of a query, binary (empty after a set).
    pub data: &'a [u8],
}

impl AtResponse<'_> {
    /// The value of a numeric query, read big-endian (1 to 8 bytes); `None` otherwise.
    pub fn number(&self) -> Option<u64> {
        be_number(self.data)
    }
}

impl RemoteAtResponse<'_> {
    /// The value of a numeric query, read big-endian (1 to 8 bytes); `None` otherwise.
    pub fn number(&self) -> Option<u64> {
        be_number(self.data)
    }
}

fn be_number(bytes: &[u8]) -> Option<u64> {
    if bytes.is_empty() || bytes.len() > 8 {
        return None;
    }
    Some(bytes.iter().fold(0u64, |acc, &b| (acc << 8) | u64::from(b)))
}

/// Transmit status (0x8B).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TransmitStatus {
    /// Frame id of the transmit request.
    pub frame_id: u8,
    /// Network address the packet went to.
    pub destination_16: Address16,
    /// Number of retries.
    pub retry_count: u8,
    /// Delivery status; 0 means delivered.
    pub delivery_status: u8,
    /// Route discovery status.
    pub discovery_status: u8,
}

impl TransmitStatus {
    /// Whether the packet was delivered (delivery status 0).
    pub const fn delivered(&self) -> bool {
        self.delivery_status == 0
    }
}

/// Receive packet (0x90).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReceivePacket<'a> {
    /// Sender's 64-bit address.
    pub source: Address64,
    /// Sender's network address.
    pub source_16: Address16,
    /// Receive options (0x01 acknowledged, 0x02 broadcast).
    pub options: u8,
    /// Payload.
    pub data: &'a [u8],
}

/// Explicit receive indicator (0x91).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ExplicitRx<'a> {
    /// Sender's 64-bit address.
    pub source: Address64,
    /// Sender's network address.
    pub source_16: Address16,
    /// Source endpoint.
    pub source_endpoint: u8,
    /// Destination endpoint.
    pub destination_endpoint: u8,
    /// Cluster id.
    pub cluster_id: u16,
    /// Profile id.
    pub profile_id: u16,
    /// Receive options.
    pub options: u8,
    /// Payload.
    pub data: &'a [u8],
}

/// Remote AT command response (0x97).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RemoteAtResponse<'a> {
    /// Frame id of the request.
    pub frame_id: u8,
    /// Remote module's 64-bit address.
    pub source: Address64,
    /// Remote module's network address.
    pub source_16: Address16,
    /// Command name.
    pub command: AtCommand,
    /// Outcome.
    pub status: CommandStatus,
    /// Value of a query.
    pub data: &'a [u8],
}

/// One API frame, typed by its frame type byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Frame<'a> {
    /// 0x08.
    AtCommand(AtCommandFrame<'a>),
    /// 0x09.
    AtCommandQueue(AtCommandFrame<'a>),
    /// 0x10.
    TransmitRequest(TransmitRequest<'a>),
    /// 0x11.
    ExplicitAddressing(ExplicitAddressing<'a>),
    /// 0x17.
    RemoteAtCommand(RemoteAtCommand<'a>),
    /// 0x88.
    AtResponse(AtResponse<'a>),
    /// 0x8A.
    ModemStatus(ModemStatus),
    /// 0x8B.
    TransmitStatus(TransmitStatus),
    /// 0x90.
    ReceivePacket(ReceivePacket<'a>),
    /// 0x91.
    ExplicitRx(ExplicitRx<'a>),
    /// 0x97.
    RemoteAtResponse(RemoteAtResponse<'a>),
    /// Any other frame type, kept as bytes.
    Unknown {
        /// The frame type byte.
        frame_type: u8,
        /// The bytes after it.
        data: &'a [u8],
    },
}

impl<'a> Frame<'a> {
    /// Reads frame data (frame type first, no delimiter, length or checksum).
    ///
    /// Frame types this crate does not know become [`Frame::Unknown`]; a known type whose
    /// length does not match its fields is an error.
    pub fn parse(frame_data: &'a [u8]) -> Result<Self, FrameError> {
        let (&frame_type, body) = frame_data.split_first().ok_or(FrameError::Empty)?;
        let invalid = FrameError::InvalidLength {
            frame_type,
            len: frame_data.len(),
        };
        Self::parse_body(frame_type, Cursor(body)).ok_or(invalid)
    }

    /// The fields after the frame type byte `kind`, by the layout of that frame type;
    /// `None` if they do not fit it.
    fn parse_body(kind: u8, c: Cursor<'a>) -> Option<Self> {
        use crate::frames::frame_type as ft;
        Some(match kind {
            ft::AT_COMMAND => Frame::AtCommand(AtCommandFrame::parse_fields(c)?),
            ft::AT_COMMAND_QUEUE => Frame::AtCommandQueue(AtCommandFrame::parse_fields(c)?),
            ft::TRANSMIT_REQUEST => Frame::TransmitRequest(TransmitRequest::parse_fields(c)?),
            ft::EXPLICIT_ADDRESSING => {
                Frame::ExplicitAddressing(ExplicitAddressing::parse_fields(c)?)
            }
            ft::REMOTE_AT_COMMAND => Frame::RemoteAtCommand(RemoteAtCommand::parse_fields(c)?),
            ft::AT_RESPONSE => Frame::AtResponse(AtResponse::parse_fields(c)?),
            ft::MODEM_STATUS => Frame::ModemStatus(ModemStatus::parse_fields(c)?),
            ft::TRANSMIT_STATUS => Frame::TransmitStatus(TransmitStatus::parse_fields(c)?),
            ft::RECEIVE_PACKET => Frame::ReceivePacket(ReceivePacket::parse_fields(c)?),
            ft::EXPLICIT_RX => Frame::ExplicitRx(ExplicitRx::parse_fields(c)?),
            ft::REMOTE_AT_RESPONSE => Frame::RemoteAtResponse(RemoteAtResponse::parse_fields(c)?),
            other => Frame::Unknown {
                frame_type: other,
                data: c.rest(),
            },
        })
    }

    /// The frame type byte.
    pub const fn frame_type(&self) -> u8 {
        use crate::frames::frame_type as ft;
        match self {
            Frame::AtCommand(_) => ft::AT_COMMAND,
            Frame::AtCommandQueue(_) => ft::AT_COMMAND_QUEUE,
            Frame::TransmitRequest(_) => ft::TRANSMIT_REQUEST,
            Frame::ExplicitAddressing(_) => ft::EXPLICIT_ADDRESSING,
            Frame::RemoteAtCommand(_) => ft::REMOTE_AT_COMMAND,
            Frame::AtResponse(_) => ft::AT_RESPONSE,
            Frame::ModemStatus(_) => ft::MODEM_STATUS,
            Frame::TransmitStatus(_) => ft::TRANSMIT_STATUS,
            Frame::ReceivePacket(_) => ft::RECEIVE_PACKET,
            Frame::ExplicitRx(_) => ft::EXPLICIT_RX,
            Frame::RemoteAtResponse(_) => ft::REMOTE_AT_RESPONSE,
            Frame::Unknown { frame_type, .. } => *frame_type,
        }
    }

    /// The frame id a response will echo, for the frame types that carry one.
    pub const fn frame_id(&self) -> Option<u8> {
        match self {
            Frame::AtCommand(f) | Frame::AtCommandQueue(f) => Some(f.frame_id),
            Frame::TransmitRequest(f) => Some(f.frame_id),
            Frame::ExplicitAddressing(f) => Some(f.frame_id),
            Frame::RemoteAtCommand(f) => Some(f.frame_id),
            Frame::AtResponse(f) => Some(f.frame_id),
            Frame::TransmitStatus(f) => Some(f.frame_id),
            Frame::RemoteAtResponse(f) => Some(f.frame_id),
            _ => None,
        }
    }

    /// Length of the frame data (frame type included): the value of the length field.
    pub fn data_len(&self) -> usize {
        1 + match self {
            Frame::AtCommand(f) | Frame::AtCommandQueue(f) => 3 + f.parameter.len(),
            Frame::TransmitRequest(f) => 13 + f.data.len(),
            Frame::ExplicitAddressing(f) => 19 + f.data.len(),
            Frame::RemoteAtCommand(f) => 14 + f.parameter.len(),
            Frame::AtResponse(f) => 4 + f.data.len(),
            Frame::ModemStatus(_) => 1,
            Frame::TransmitStatus(_) => 6,
            Frame::ReceivePacket(f) => 11 + f.data.len(),
            Frame::ExplicitRx(f) => 17 + f.data.len(),
            Frame::RemoteAtResponse(f) => 14 + f.data.len(),
            Frame::Unknown { data, .. } => data.len(),
        }
    }

    /// Writes the frame data (frame type first) to `sink`, one byte at a time.
    pub fn emit<K: ByteSink>(&self, sink: &mut K) -> Result<(), K::Error> {
        let mut w = Emitter(sink);
        w.u8(self.frame_type())?;
        match self {
            Frame::AtCommand(f) | Frame::AtCommandQueue(f) => f.emit_fields(&mut w),
            Frame::TransmitRequest(f) => f.emit_fields(&mut w),
            Frame::ExplicitAddressing(f) => f.emit_fields(&mut w),
            Frame::RemoteAtCommand(f) => f.emit_fields(&mut w),
            Frame::AtResponse(f) => f.emit_fields(&mut w),
            Frame::ModemStatus(status) => status.emit_fields(&mut w),
            Frame::TransmitStatus(f) => f.emit_fields(&mut w),
            Frame::ReceivePacket(f) => f.emit_fields(&mut w),
            Frame::ExplicitRx(f) => f.emit_fields(&mut w),
            Frame::RemoteAtResponse(f) => f.emit_fields(&mut w),
            Frame::Unknown { data, .. } => w.bytes(data),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_type_bytes_are_pinned() {
        use frame_type::*;
        assert_eq!(
            [
                AT_COMMAND,
                AT_COMMAND_QUEUE,
                TRANSMIT_REQUEST,
                EXPLICIT_ADDRESSING,
                REMOTE_AT_COMMAND,
                AT_RESPONSE,
                MODEM_STATUS,
                TRANSMIT_STATUS,
                RECEIVE_PACKET,
                EXPLICIT_RX,
                REMOTE_AT_RESPONSE
            ],
            [0x08, 0x09, 0x10, 0x11, 0x17, 0x88, 0x8A, 0x8B, 0x90, 0x91, 0x97]
        );
    }

    #[test]
    fn short_known_frames_are_errors_not_panics() {
        for t in [
            0x08, 0x09, 0x10, 0x11, 0x17, 0x88, 0x8A, 0x8B, 0x90, 0x91, 0x97,
        ] {
            assert_eq!(
                Frame::parse(&[t]),
                Err(FrameError::InvalidLength {
                    frame_type: t,
                    len: 1
                })
            );
        }
        assert_eq!(Frame::parse(&[]), Err(FrameError::Empty));
    }

    #[test]
    fn fixed_length_frames_refuse_trailing_bytes() {
        assert_eq!(
            Frame::parse(&[0x8A, 0x02]),
            Ok(Frame::ModemStatus(ModemStatus::Joined))
        );
        assert_eq!(
            Frame::parse(&[0x8A, 0x02, 0x00]),
            Err(FrameError::InvalidLength {
                frame_type: 0x8A,
                len: 3
            })
        );
        let status = [0x8B, 0x01, 0xFF, 0xFE, 0x00, 0x00, 0x00];
        assert!(matches!(
            Frame::parse(&status),
            Ok(Frame::TransmitStatus(TransmitStatus {
                frame_id: 1,
                destination_16: Address16(0xFFFE),
                ..
            }))
        ));
        let longer = [0x8B, 0x01, 0xFF, 0xFE, 0x00, 0x00, 0x00, 0xAA];
        assert_eq!(
            Frame::parse(&longer),
            Err(FrameError::InvalidLength {
                frame_type: 0x8B,
                len: 8
            })
        );
    }

    #[test]
    fn numeric_responses() {
        let response = |data| AtResponse {
            frame_id: 1,
            command: AtCommand::ID,
            status: CommandStatus::Ok,
            data,
        };
        assert_eq!(response(&[0x7F, 0xFF]).number(), Some(0x7FFF));
        assert_eq!(response(&[]).number(), None);
        assert_eq!(response(&[1; 9]).number(), None);
        assert_eq!(response(&[0xFF; 8]).number(), Some(u64::MAX));
    }

    #[test]
    fn status_codes_round_trip() {
        for b in 0..=255u8 {
            assert_eq!(u8::from(CommandStatus::from(b)), b);
            assert_eq!(u8::from(ModemStatus::from(b)), b);
        }
    }
}
