//! Where each field of each frame type sits on the wire, after the frame type byte: one
//! `parse_fields` and one `emit_fields` per frame type, side by side, so the two directions
//! can be checked against each other at a glance. Multi-byte fields are big-endian.

use super::{
    AtCommandFrame, AtResponse, ExplicitAddressing, ExplicitRx, ModemStatus, ReceivePacket,
    RemoteAtCommand, RemoteAtResponse, TransmitRequest, TransmitStatus,
};
use crate::at::AtCommand;
use crate::codec::ByteSink;
use crate::types::{Address16, Address64};

/// Bounds-checked reader over frame data; every accessor returns `None` past the end.
pub(super) struct Cursor<'a>(pub(super) &'a [u8]);

impl<'a> Cursor<'a> {
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let (head, tail) = self.0.split_first_chunk::<N>()?;
        self.0 = tail;
        Some(*head)
    }
    fn u8(&mut self) -> Option<u8> {
        self.take::<1>().map(|[b]| b)
    }
    fn u16(&mut self) -> Option<u16> {
        self.take().map(u16::from_be_bytes)
    }
    fn addr64(&mut self) -> Option<Address64> {
        self.take().map(|b| Address64(u64::from_be_bytes(b)))
    }
    fn addr16(&mut self) -> Option<Address16> {
        self.u16().map(Address16)
    }
    fn command(&mut self) -> Option<AtCommand> {
        self.take().map(AtCommand)
    }
    /// Everything not read yet (a trailing variable-length field).
    pub(super) fn rest(self) -> &'a [u8] {
        self.0
    }
}

/// Writes frame data into a [`ByteSink`], one byte at a time.
pub(super) struct Emitter<'s, K>(pub(super) &'s mut K);

impl<K: ByteSink> Emitter<'_, K> {
    pub(super) fn u8(&mut self, byte: u8) -> Result<(), K::Error> {
        self.0.put(byte)
    }
    pub(super) fn bytes(&mut self, bytes: &[u8]) -> Result<(), K::Error> {
        bytes.iter().try_for_each(|&b| self.0.put(b))
    }
}

/// 0x08 and 0x09: frame id, command, parameter.
impl<'a> AtCommandFrame<'a> {
    pub(super) fn parse_fields(mut c: Cursor<'a>) -> Option<Self> {
        Some(Self {
            frame_id: c.u8()?,
            command: c.command()?,
            parameter: c.rest(),
        })
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.u8(self.frame_id)?;
        w.bytes(&self.command.0)?;
        w.bytes(self.parameter)
    }
}

/// 0x10: frame id, destination (64 and 16 bits), broadcast radius, options, data.
impl<'a> TransmitRequest<'a> {
    pub(super) fn parse_fields(mut c: Cursor<'a>) -> Option<Self> {
        Some(Self {
            frame_id: c.u8()?,
            destination: c.addr64()?,
            destination_16: c.addr16()?,
            broadcast_radius: c.u8()?,
            options: c.u8()?,
            data: c.rest(),
        })
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.u8(self.frame_id)?;
        w.bytes(&self.destination.to_be_bytes())?;
        w.bytes(&self.destination_16.0.to_be_bytes())?;
        w.u8(self.broadcast_radius)?;
        w.u8(self.options)?;
        w.bytes(self.data)
    }
}

/// 0x11: frame id, destination (64 and 16 bits), source and destination endpoints, cluster,
/// profile, broadcast radius, options, data.
impl<'a> ExplicitAddressing<'a> {
    pub(super) fn parse_fields(mut c: Cursor<'a>) -> Option<Self> {
        Some(Self {
            frame_id: c.u8()?,
            destination: c.addr64()?,
            destination_16: c.addr16()?,
            source_endpoint: c.u8()?,
            destination_endpoint: c.u8()?,
            cluster_id: c.u16()?,
            profile_id: c.u16()?,
            broadcast_radius: c.u8()?,
            options: c.u8()?,
            data: c.rest(),
        })
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.u8(self.frame_id)?;
        w.bytes(&self.destination.to_be_bytes())?;
        w.bytes(&self.destination_16.0.to_be_bytes())?;
        w.u8(self.source_endpoint)?;
        w.u8(self.destination_endpoint)?;
        w.bytes(&self.cluster_id.to_be_bytes())?;
        w.bytes(&self.profile_id.to_be_bytes())?;
        w.u8(self.broadcast_radius)?;
        w.u8(self.options)?;
        w.bytes(self.data)
    }
}

/// 0x17: frame id, destination (64 and 16 bits), options, command, parameter.
impl<'a> RemoteAtCommand<'a> {
    pub(super) fn parse_fields(mut c: Cursor<'a>) -> Option<Self> {
        Some(Self {
            frame_id: c.u8()?,
            destination: c.addr64()?,
            destination_16: c.addr16()?,
            options: c.u8()?,
            command: c.command()?,
            parameter: c.rest(),
        })
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.u8(self.frame_id)?;
        w.bytes(&self.destination.to_be_bytes())?;
        w.bytes(&self.destination_16.0.to_be_bytes())?;
        w.u8(self.options)?;
        w.bytes(&self.command.0)?;
        w.bytes(self.parameter)
    }
}

/// 0x88: frame id, command, status, data.
impl<'a> AtResponse<'a> {
    pub(super) fn parse_fields(mut c: Cursor<'a>) -> Option<Self> {
        Some(Self {
            frame_id: c.u8()?,
            command: c.command()?,
            status: c.u8()?.into(),
            data: c.rest(),
        })
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.u8(self.frame_id)?;
        w.bytes(&self.command.0)?;
        w.u8(self.status.into())?;
        w.bytes(self.data)
    }
}

/// 0x8A: the status byte, nothing after it.
impl ModemStatus {
    pub(super) fn parse_fields(mut c: Cursor<'_>) -> Option<Self> {
        let status = c.u8()?;
        if !c.rest().is_empty() {
            return None;
        }
        Some(status.into())
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.u8((*self).into())
    }
}

/// 0x8B: frame id, destination (16 bits), retry count, delivery and discovery status,
/// nothing after them.
impl TransmitStatus {
    pub(super) fn parse_fields(mut c: Cursor<'_>) -> Option<Self> {
        let status = Self {
            frame_id: c.u8()?,
            destination_16: c.addr16()?,
            retry_count: c.u8()?,
            delivery_status: c.u8()?,
            discovery_status: c.u8()?,
        };
        if !c.rest().is_empty() {
            return None;
        }
        Some(status)
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.u8(self.frame_id)?;
        w.bytes(&self.destination_16.0.to_be_bytes())?;
        w.u8(self.retry_count)?;
        w.u8(self.delivery_status)?;
        w.u8(self.discovery_status)
    }
}

/// 0x90: source (64 and 16 bits), options, data.
impl<'a> ReceivePacket<'a> {
    pub(super) fn parse_fields(mut c: Cursor<'a>) -> Option<Self> {
        Some(Self {
            source: c.addr64()?,
            source_16: c.addr16()?,
            options: c.u8()?,
            data: c.rest(),
        })
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.bytes(&self.source.to_be_bytes())?;
        w.bytes(&self.source_16.0.to_be_bytes())?;
        w.u8(self.options)?;
        w.bytes(self.data)
    }
}

/// 0x91: source (64 and 16 bits), source and destination endpoints, cluster, profile,
/// options, data.
impl<'a> ExplicitRx<'a> {
    pub(super) fn parse_fields(mut c: Cursor<'a>) -> Option<Self> {
        Some(Self {
            source: c.addr64()?,
            source_16: c.addr16()?,
            source_endpoint: c.u8()?,
            destination_endpoint: c.u8()?,
            cluster_id: c.u16()?,
            profile_id: c.u16()?,
            options: c.u8()?,
            data: c.rest(),
        })
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.bytes(&self.source.to_be_bytes())?;
        w.bytes(&self.source_16.0.to_be_bytes())?;
        w.u8(self.source_endpoint)?;
        w.u8(self.destination_endpoint)?;
        w.bytes(&self.cluster_id.to_be_bytes())?;
        w.bytes(&self.profile_id.to_be_bytes())?;
        w.u8(self.options)?;
        w.bytes(self.data)
    }
}

/// 0x97: frame id, source (64 and 16 bits), command, status, data.
impl<'a> RemoteAtResponse<'a> {
    pub(super) fn parse_fields(mut c: Cursor<'a>) -> Option<Self> {
        Some(Self {
            frame_id: c.u8()?,
            source: c.addr64()?,
            source_16: c.addr16()?,
            command: c.command()?,
            status: c.u8()?.into(),
            data: c.rest(),
        })
    }

    pub(super) fn emit_fields<K: ByteSink>(&self, w: &mut Emitter<'_, K>) -> Result<(), K::Error> {
        w.u8(self.frame_id)?;
        w.bytes(&self.source.to_be_bytes())?;
        w.bytes(&self.source_16.0.to_be_bytes())?;
        w.bytes(&self.command.0)?;
        w.u8(self.status.into())?;
        w.bytes(self.data)
    }
}
