//! The servo controller as the loop sees it.

use anyhow::Context;
use pololu_maestro::{encode_set_targets, Channel, Framing, Mini24, QuarterMicros};

use super::serial::{LineSettings, SerialError, SerialPort};
use crate::config::MaestroConfig;
use crate::control::Nanos;

/// Writes servo targets. Implementations write all channels in as few writes as the device
/// allows and give up at `deadline_ns`.
pub trait ServoOutput {
    /// Why a write failed.
    type Error: core::fmt::Debug;

    /// Sets `targets_qus[i]` (quarter-microseconds, 0 = no pulses) on `channels[i]`.
    fn write_targets(
        &mut self,
        channels: &[u8; 3],
        targets_qus: &[u16; 3],
        deadline_ns: Nanos,
    ) -> Result<(), Self::Error>;
}

/// The Pololu Maestro on its command port: compact-protocol Set Target packets for every
/// channel, concatenated into one write (encoded by the `pololu-maestro` crate).
pub struct MaestroPort {
    port: SerialPort,
}

impl MaestroPort {
    /// From an open port.
    pub fn new(port: SerialPort) -> MaestroPort {
        MaestroPort { port }
    }

    /// Opens the configured command port.
    pub fn open(config: &MaestroConfig) -> anyhow::Result<MaestroPort> {
        SerialPort::open(
            &config.port,
            LineSettings {
                baud: config.baud,
                stop_bits: 1,
            },
        )
        .map(MaestroPort::new)
        .with_context(|| {
            format!(
                "Maestro: cannot open {} (plugged in, and in the dialout group?)",
                config.port.display()
            )
        })
    }
}

/// Why a Maestro write failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaestroWriteError {
    /// A channel or target the Maestro cannot take (configuration validated against this).
    InvalidInput,
    /// The port failed.
    Serial(SerialError),
}

impl ServoOutput for MaestroPort {
    type Error = MaestroWriteError;

    fn write_targets(
        &mut self,
        channels: &[u8; 3],
        targets_qus: &[u16; 3],
        deadline_ns: Nanos,
    ) -> Result<(), MaestroWriteError> {
        let pair = |i: usize| -> Result<(Channel, QuarterMicros), MaestroWriteError> {
            Ok((
                Channel::new::<Mini24>(channels[i]).map_err(|_| MaestroWriteError::InvalidInput)?,
                QuarterMicros::new(targets_qus[i]).map_err(|_| MaestroWriteError::InvalidInput)?,
            ))
        };
        let pairs = [pair(0)?, pair(1)?, pair(2)?];
        let frame =
            encode_set_targets(Framing::COMPACT, &pairs).ok_or(MaestroWriteError::InvalidInput)?;
        self.port
            .write_all(frame.as_bytes(), deadline_ns)
            .map_err(MaestroWriteError::Serial)
    }
}
