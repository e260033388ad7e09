//! Device-side streaming decoder: the bytes a host sends in, typed [`Command`]s out.

use crate::codec::{join_14, MAX_PACKET_LEN};
use crate::command::{data_len, opcode, Command, MultiTargets};
use crate::crc7::crc7;
use crate::status::ErrorFlags;
use crate::types::{
    Acceleration, Channel, DeviceNumber, MiniSscServo, MiniSscValue, PwmTiming, QuarterMicros,
    ScriptParameter, Speed, Subroutine, MAX_CHANNELS,
};

/// The serial settings of the simulated Maestro.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecoderConfig {
    /// The device number Pololu protocol packets must carry to be accepted.
    pub device: DeviceNumber,
    /// Expect a CRC-7 byte after every compact and Pololu packet.
    pub crc: bool,
}

/// What the decoder has seen so far. Counters saturate instead of wrapping.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecoderStats {
    /// Commands decoded.
    pub commands: u32,
    /// Bytes that did not become part of a command: stray data bytes, abandoned, invalid or
    /// CRC-failed packets. Bytes of packets for other devices are not counted here.
    pub dropped_bytes: u32,
    /// Packets that were malformed: unknown command byte, interrupted by another command byte,
    /// or a field out of range (e.g. a channel above 23).
    pub invalid_packets: u32,
    /// Packets dropped because their CRC-7 byte did not match.
    pub crc_errors: u32,
    /// Pololu protocol packets addressed to another device number (skipped, not errors).
    pub other_device_packets: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Waiting for a command byte.
    Idle,
    /// Inside a compact packet; `buf[0]` is the command byte.
    Compact,
    /// Inside a Pololu packet; `buf[0]` is 0xAA, then device number, command, data.
    Pololu,
    /// Inside a Mini SSC packet; `buf[0]` is 0xFF.
    MiniSsc,
    /// Skipping a Pololu packet for another device until the next command byte.
    OtherDevice,
}

/// Device-side streaming decoder: the bytes a host sends in, typed [`Command`]s out.
///
/// Sans-IO and total: any byte sequence is accepted, nothing panics, and every byte that does
/// not end up in a command is counted. It follows the Maestro's own framing rules, so a
/// simulator built on it reacts like the real device:
///
/// - a byte with bit 7 set starts a packet; one arriving inside an unfinished packet abandons
///   that packet (a protocol error) and starts the new one, so one lost byte costs at most one
///   command;
/// - data bytes outside a packet are dropped;
/// - Pololu protocol packets for another device number are skipped up to the next command
///   byte, as a daisy-chained Maestro does;
/// - in CRC mode, a packet whose CRC-7 byte does not match is dropped (a CRC error);
/// - Mini SSC packets (0xFF, servo, value) carry 8-bit data, so only 0xFF restarts them.
///
/// The serial error bits the real Maestro would set are collected for a simulated Get Errors
/// ([`CommandDecoder::take_errors`]).
///
/// ```
/// use pololu_maestro::{Command, CommandDecoder, DecoderConfig, QuarterMicros};
///
/// let mut maestro = CommandDecoder::new(DecoderConfig::default());
/// // A stray data byte, then Set Target channel 2 = 1500 µs (Pololu guide example).
/// let commands: Vec<Command> = maestro.decode(&[0x2E, 0x84, 0x02, 0x70, 0x2E]).collect();
/// match &commands[..] {
///     [Command::SetTarget { channel, target }] => {
///         assert_eq!((channel.index(), *target), (2, QuarterMicros::NEUTRAL));
///     }
///     other => panic!("unexpected {other:?}"),
/// }
/// assert_eq!(maestro.stats().dropped_bytes, 1);
/// ```
#[derive(Debug, Clone)]
pub struct CommandDecoder {
    config: DecoderConfig,
    state: State,
    buf: [u8; MAX_PACKET_LEN],
    len: usize,
    stats: DecoderStats,
    errors: ErrorFlags,
}

impl CommandDecoder {
    /// A decoder for a Maestro with the given serial settings.
    pub const fn new(config: DecoderConfig) -> Self {
        Self {
            config,
            state: State::Idle,
            buf: [0; MAX_PACKET_LEN],
            len: 0,
            stats: DecoderStats {
                commands: 0,
                dropped_bytes: 0,
                invalid_packets: 0,
                crc_errors: 0,
                other_device_packets: 0,
            },
            errors: ErrorFlags::empty(),
        }
    }

    /// The serial settings.
    pub fn config(&self) -> DecoderConfig {
        self.config
    }

    /// The counters.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// The serial error bits ([`ErrorFlags::SERIAL_CRC`], [`ErrorFlags::SERIAL_PROTOCOL`])
    /// raised since the last call, then cleared, like the Maestro's Get Errors.
    pub fn take_errors(&mut self) -> ErrorFlags {
        core::mem::take(&mut self.errors)
    }

    /// Forget a partially received packet (not counted). Counters and errors are kept.
    pub fn reset(&mut self) {
        self.state = State::Idle;
        self.len = 0;
    }

    /// Decode the commands in `bytes`, lazily, in order.
    pub fn decode<'a>(&'a mut self, bytes: &'a [u8]) -> Decoded<'a> {
        Decoded {
            decoder: self,
            bytes: bytes.iter(),
        }
    }

    /// Push one received byte; returns the command it completes, if any.
    pub fn push(&mut self, byte: u8) -> Option<Command> {
        match self.state {
            State::MiniSsc => return self.push_mini_ssc(byte),
            State::OtherDevice if byte & 0x80 == 0 => return None,
            State::OtherDevice => self.state = State::Idle,
            _ => {}
        }
        if byte & 0x80 != 0 {
            if self.len > 0 {
                self.abandon();
            }
            return self.start(byte);
        }
        if self.state == State::Idle {
            self.stats.dropped_bytes = self.stats.dropped_bytes.saturating_add(1);
            return None;
        }
        let Some(slot) = self.buf.get_mut(self.len) else {
            self.abandon();
            self.drop_bytes(1);
            return None;
        };
        *slot = byte;
        self.len += 1;
        if self.state == State::Pololu && self.len == 2 && byte != self.config.device.get() {
            self.stats.other_device_packets = self.stats.other_device_packets.saturating_add(1);
            self.state = State::OtherDevice;
            self.len = 0;
            return None;
        }
        self.try_complete()
    }

    fn start(&mut self, byte: u8) -> Option<Command> {
        self.len = 1;
        self.buf[0] = byte;
        self.state = match byte {
            opcode::MINI_SSC => State::MiniSsc,
            opcode::POLOLU => State::Pololu,
            b if data_len(b).is_some() => State::Compact,
            _ => {
                self.abandon();
                return None;
            }
        };
        self.try_complete()
    }

    fn push_mini_ssc(&mut self, byte: u8) -> Option<Command> {
        if byte == opcode::MINI_SSC {
            self.abandon();
            return self.start(byte);
        }
        let Some(slot) = self.buf.get_mut(self.len) else {
            self.abandon();
            return None;
        };
        *slot = byte;
        self.len += 1;
        if self.len < 3 {
            return None;
        }
        let (servo, value) = (self.buf[1], self.buf[2]);
        match (MiniSscServo::new(servo), MiniSscValue::new(value)) {
            (Ok(servo), Ok(value)) => self.emit(Command::MiniSsc { servo, value }),
            _ => {
                self.abandon();
                None
            }
        }
    }

    /// The compact command byte and the header length of the packet being received, once known.
    fn command(&self) -> Option<(u8, usize)> {
        match self.state {
            State::Compact => Some((self.buf[0], 1)),
            State::Pololu if self.len >= 3 => Some((self.buf[2] | 0x80, 3)),
            _ => None,
        }
    }

    fn try_complete(&mut self) -> Option<Command> {
        let (command, header) = self.command()?;
        let Some(mut body) = data_len(command) else {
            self.abandon();
            return None;
        };
        if command == opcode::SET_MULTIPLE_TARGETS {
            let count = *self.buf.get(header).filter(|_| self.len > header)?;
            if count == 0 || count > MAX_CHANNELS {
                self.abandon();
                return None;
            }
            body += 2 * count as usize;
        }
        let total = header + body + usize::from(self.config.crc);
        if self.len < total {
            return None;
        }
        if self.config.crc {
            let (packet, crc) = self.buf.split_at(total - 1);
            if crc7(packet) != crc[0] {
                self.stats.crc_errors = self.stats.crc_errors.saturating_add(1);
                self.errors |= ErrorFlags::SERIAL_CRC;
                self.drop_bytes(total);
                self.reset();
                return None;
            }
        }
        let data = self.buf.get(header..header + body).unwrap_or(&[]);
        match parse(command, data) {
            Some(cmd) => self.emit(cmd),
            None => {
                self.abandon();
                None
            }
        }
    }

    fn emit(&mut self, command: Command) -> Option<Command> {
        self.stats.commands = self.stats.commands.saturating_add(1);
        self.reset();
        Some(command)
    }

    /// Drop the partial or invalid packet in the buffer as a protocol error.
    fn abandon(&mut self) {
        self.stats.invalid_packets = self.stats.invalid_packets.saturating_add(1);
        self.errors |= ErrorFlags::SERIAL_PROTOCOL;
        self.drop_bytes(self.len);
        self.reset();
    }

    fn drop_bytes(&mut self, n: usize) {
        let n = u32::try_from(n).unwrap_or(u32::MAX);
        self.stats.dropped_bytes = self.stats.dropped_bytes.saturating_add(n);
    }
}

/// Parse the data bytes of compact command `command`; `None` if a field is out of range.
fn parse(command: u8, data: &[u8]) -> Option<Command> {
    let u14 = |i: usize| -> Option<u16> { Some(join_14(*data.get(i)?, *data.get(i + 1)?)) };
    let channel = || Channel::any_model(*data.first()?).ok();
    Some(match command {
        opcode::SET_TARGET => Command::SetTarget {
            channel: channel()?,
            target: QuarterMicros::new(u14(1)?).ok()?,
        },
        opcode::SET_SPEED => Command::SetSpeed {
            channel: channel()?,
            speed: Speed::new(u14(1)?).ok()?,
        },
        opcode::SET_ACCELERATION => Command::SetAcceleration {
            channel: channel()?,
            acceleration: Acceleration::new(u8::try_from(u14(1)?).ok()?),
        },
        opcode::SET_PWM => Command::SetPwm(PwmTiming::new(u14(0)?, u14(2)?).ok()?),
        opcode::GET_POSITION => Command::GetPosition {
            channel: channel()?,
        },
        opcode::GET_MOVING_STATE => Command::GetMovingState,
        opcode::SET_MULTIPLE_TARGETS => {
            let first = Channel::any_model(*data.get(1)?).ok()?;
            let mut targets = [QuarterMicros::OFF; MAX_CHANNELS as usize];
            let count = usize::from(*data.first()?);
            for (i, slot) in targets.iter_mut().take(count).enumerate() {
                *slot = QuarterMicros::new(u14(2 + 2 * i)?).ok()?;
            }
            Command::SetMultipleTargets(MultiTargets::new(first, targets.get(..count)?).ok()?)
        }
        opcode::GET_ERRORS => Command::GetErrors,
        opcode::GO_HOME => Command::GoHome,
        opcode::STOP_SCRIPT => Command::StopScript,
        opcode::RESTART_SCRIPT => Command::RestartScript(Subroutine::new(*data.first()?).ok()?),
        opcode::RESTART_SCRIPT_WITH_PARAMETER => Command::RestartScriptWithParameter {
            subroutine: Subroutine::new(*data.first()?).ok()?,
            parameter: ScriptParameter::new(u14(1)?).ok()?,
        },
        opcode::GET_SCRIPT_STATUS => Command::GetScriptStatus,
        _ => return None,
    })
}

/// Iterator over the commands decoded from a byte slice ([`CommandDecoder::decode`]).
#[derive(Debug)]
pub struct Decoded<'a> {
    decoder: &'a mut CommandDecoder,
    bytes: core::slice::Iter<'a, u8>,
}

impl Iterator for Decoded<'_> {
    type Item = Command;

    fn next(&mut self) -> Option<Command> {
        for &byte in self.bytes.by_ref() {
            if let Some(command) = self.decoder.push(byte) {
                return Some(command);
            }
        }
        None
    }
}
