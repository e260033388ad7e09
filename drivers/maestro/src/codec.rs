//! Sans-IO encoder: [`Command`] and framing in, wire bytes out. No I/O, no allocation.

use core::ops::Deref;

use crate::command::{opcode, Command};
use crate::crc7::crc7;
use crate::types::{Channel, DeviceNumber, QuarterMicros, MAX_CHANNELS};

/// Longest packet: Pololu header (2) + Set Multiple Targets for 24 channels (1 + 2 + 48) + CRC.
pub const MAX_PACKET_LEN: usize = 2 + 1 + 2 + 2 * MAX_CHANNELS as usize + 1;

/// Longest Set Target packet: Pololu header (2) + command + channel + 2 target bytes + CRC.
pub const MAX_SET_TARGET_LEN: usize = 7;

/// Capacity of a [`TargetFrame`]: one Set Target packet per channel of a Mini Maestro 24.
pub const MAX_TARGET_FRAME_LEN: usize = MAX_SET_TARGET_LEN * MAX_CHANNELS as usize;

/// Split a 14-bit value into the two 7-bit data bytes the Maestro expects (low bits first).
///
/// Bits above 13 are dropped; the checked types never carry them.
pub const fn split_14(value: u16) -> [u8; 2] {
    [(value & 0x7F) as u8, ((value >> 7) & 0x7F) as u8]
}

/// Join two 7-bit data bytes (low bits first) into a 14-bit value; bit 7 of each is ignored.
pub const fn join_14(low: u8, high: u8) -> u16 {
    (low & 0x7F) as u16 | (((high & 0x7F) as u16) << 7)
}

/// Which of the Maestro's native protocols frames a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Protocol {
    /// Compact protocol: command byte, data. For a Maestro alone on its serial line.
    #[default]
    Compact,
    /// Pololu protocol: 0xAA, device number, command with bit 7 cleared, data. Addresses one
    /// device on a daisy-chained line.
    Pololu(DeviceNumber),
}

/// How commands are framed on the wire: protocol and whether a CRC-7 byte follows each packet
/// (it must match the Maestro's "CRC enabled" serial setting).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Framing {
    /// The protocol.
    pub protocol: Protocol,
    /// Append the CRC-7 byte to every compact or Pololu packet.
    pub crc: bool,
}

impl Framing {
    /// Compact protocol without CRC (the Maestro's default settings over USB).
    pub const COMPACT: Self = Self {
        protocol: Protocol::Compact,
        crc: false,
    };

    /// Pololu protocol addressed to `device`, without CRC.
    pub const fn pololu(device: DeviceNumber) -> Self {
        Self {
            protocol: Protocol::Pololu(device),
            crc: false,
        }
    }

    /// The same framing with CRC-7 enabled or disabled.
    pub const fn with_crc(self, crc: bool) -> Self {
        Self {
            protocol: self.protocol,
            crc,
        }
    }
}

/// A fixed-capacity byte buffer holding encoded packets; dereferences to the bytes.
#[derive(Clone, PartialEq, Eq)]
pub struct Bytes<const N: usize> {
    buf: [u8; N],
    len: usize,
}

impl<const N: usize> Bytes<N> {
    const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
        }
    }

    /// Append `bytes`; the callers size `N` so this never overflows, but it stops at capacity
    /// rather than panic.
    fn extend(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
        }
    }

    /// The encoded bytes.
    pub fn as_bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }
}

impl<const N: usize> Deref for Bytes<N> {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.as_bytes()
    }
}

impl<const N: usize> AsRef<[u8]> for Bytes<N> {
    fn as_ref(&self) -> &[u8] {
        self.as_bytes()
    }
}

impl<const N: usize> core::fmt::Debug for Bytes<N> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{:02X?}", self.as_bytes())
    }
}

#[cfg(feature = "defmt")]
impl<const N: usize> defmt::Format for Bytes<N> {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=[u8]:02X}", self.as_bytes())
    }
}

/// One encoded command packet.
pub type Packet = Bytes<MAX_PACKET_LEN>;

/// Set Target packets for several channels, concatenated: written to the serial port in one
/// call, once per control cycle.
pub type TargetFrame = Bytes<MAX_TARGET_FRAME_LEN>;

/// Frame `body` (compact command byte first) according to `framing` into `out`.
fn frame_into<const N: usize>(framing: Framing, body: &[u8], out: &mut Bytes<N>) {
    let start = out.len;
    match framing.protocol {
        Protocol::Compact => out.extend(body),
        Protocol::Pololu(device) => {
            out.extend(&[opcode::POLOLU, device.get()]);
            if let Some((&command, data)) = body.split_first() {
                out.extend(&[command & 0x7F]);
                out.extend(data);
            }
        }
    }
    if framing.crc {
        let crc = crc7(out.buf.get(start..out.len).unwrap_or(&[]));
        out.extend(&[crc]);
    }
}

/// Encode `command` with `framing`.
///
/// Mini SSC commands ignore the framing: that protocol has neither device number nor CRC.
pub fn encode(command: &Command, framing: Framing) -> Packet {
    let mut body = Bytes::<{ MAX_PACKET_LEN }>::new();
    body.extend(&[command.opcode()]);
    match command {
        Command::SetTarget { channel, target } => {
            body.extend(&[channel.index()]);
            body.extend(&split_14(target.get()));
        }
        Command::SetMultipleTargets(multi) => {
            body.extend(&[multi.targets().len() as u8, multi.first().index()]);
            for target in multi.targets() {
                body.extend(&split_14(target.get()));
            }
        }
        Command::SetSpeed { channel, speed } => {
            body.extend(&[channel.index()]);
            body.extend(&split_14(speed.get()));
        }
        Command::SetAcceleration {
            channel,
            acceleration,
        } => {
            body.extend(&[channel.index()]);
            body.extend(&split_14(acceleration.get() as u16));
        }
        Command::SetPwm(pwm) => {
            body.extend(&split_14(pwm.on_time()));
            body.extend(&split_14(pwm.period()));
        }
        Command::GetPosition { channel } => body.extend(&[channel.index()]),
        Command::RestartScript(subroutine) => body.extend(&[subroutine.get()]),
        Command::RestartScriptWithParameter {
            subroutine,
            parameter,
        } => {
            body.extend(&[subroutine.get()]);
            body.extend(&split_14(parameter.get()));
        }
        Command::MiniSsc { servo, value } => {
            body.extend(&[servo.get(), value.get()]);
            let mut out = Packet::new();
            out.extend(&body);
            return out;
        }
        Command::GetMovingState
        | Command::GetErrors
        | Command::GoHome
        | Command::StopScript
        | Command::GetScriptStatus => {}
    }
    let mut out = Packet::new();
    frame_into(framing, &body, &mut out);
    out
}

/// Encode one Set Target packet (the hot path, without building a [`Command`]).
pub fn encode_set_target(framing: Framing, channel: Channel, target: QuarterMicros) -> Packet {
    let [low, high] = split_14(target.get());
    let mut out = Packet::new();
    frame_into(
        framing,
        &[opcode::SET_TARGET, channel.index(), low, high],
        &mut out,
    );
    out
}

/// Concatenated Set Target packets for `targets`, in the given order, to be written in one
/// call. `None` if there are more than 24 targets.
///
/// Works on every model and protocol; on a Mini Maestro with consecutive channels,
/// [`Command::SetMultipleTargets`] is shorter.
pub fn encode_set_targets(
    framing: Framing,
    targets: &[(Channel, QuarterMicros)],
) -> Option<TargetFrame> {
    if targets.len() > MAX_CHANNELS as usize {
        return None;
    }
    let mut out = TargetFrame::new();
    for &(channel, target) in targets {
        let [low, high] = split_14(target.get());
        frame_into(
            framing,
            &[opcode::SET_TARGET, channel.index(), low, high],
            &mut out,
        );
    }
    Some(out)
}
