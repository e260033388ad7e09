//! The servo controller as the loop sees it.

use anyhow::Context;
use pololu_maestro::{encode_set_targets, Channel, Framing, Mini24, QuarterMicros, TargetFrame};

use linux_embedded_hal::I2cdev;

use super::pca9685::Pca9685Output;
use super::serial::{LineSettings, SerialError, SerialPort};
use crate::config::{Config, MaestroConfig, ServoKind};
use dima_core::Nanos;

/// Why a servo write failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ServoError {
    /// The device did not take the bytes before the deadline (its input is full); the device
    /// stays in use and the targets are resent.
    #[error("servo write deadline passed")]
    Timeout,
    /// A channel or target the device cannot take (the configuration is validated against it).
    #[error("servo channel or target out of range")]
    InvalidInput,
    /// The device failed (unplugged, I/O error): it is closed and reopened.
    #[error("servo device failed")]
    Device,
}

/// Writes servo targets. Implementations write all channels in as few writes as the device
/// allows and give up at `deadline_ns`.
pub trait ServoOutput {
    /// Sets `targets_qus[i]` (quarter-microseconds, 0 = no pulses) on `channels[i]`.
    fn write_targets(
        &mut self,
        channels: &[u8; 3],
        targets_qus: &[u16; 3],
        deadline_ns: Nanos,
    ) -> Result<(), ServoError>;
}

/// The compact-protocol Set Target packets for three channels, concatenated (what
/// [`MaestroPort`] writes in one go).
pub fn encode_targets(
    channels: &[u8; 3],
    targets_qus: &[u16; 3],
) -> Result<TargetFrame, ServoError> {
    let pair = |i: usize| -> Result<(Channel, QuarterMicros), ServoError> {
        Ok((
            Channel::new::<Mini24>(channels[i]).map_err(|_| ServoError::InvalidInput)?,
            QuarterMicros::new(targets_qus[i]).map_err(|_| ServoError::InvalidInput)?,
        ))
    };
    let pairs = [pair(0)?, pair(1)?, pair(2)?];
    encode_set_targets(Framing::COMPACT, &pairs).ok_or(ServoError::InvalidInput)
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

impl ServoOutput for MaestroPort {
    fn write_targets(
        &mut self,
        channels: &[u8; 3],
        targets_qus: &[u16; 3],
        deadline_ns: Nanos,
    ) -> Result<(), ServoError> {
        let frame = encode_targets(channels, targets_qus)?;
        self.port
            .write_all(frame.as_bytes(), deadline_ns)
            .map_err(|e| match e {
                SerialError::Timeout => ServoError::Timeout,
                SerialError::HangUp | SerialError::Io(_) => ServoError::Device,
            })
    }
}

/// The servo board the configuration names (`servo.kind`).
pub enum ServoBoard {
    /// A Pololu Maestro on its USB command port (boxed: its port carries buffers; opened on the
    /// device thread, never in the loop).
    Maestro(Box<MaestroPort>),
    /// A PCA9685 PWM board on I2C.
    Pca9685(Pca9685Output<I2cdev>),
}

impl ServoBoard {
    /// Opens the configured board.
    pub fn open(config: &Config) -> anyhow::Result<ServoBoard> {
        Ok(match config.servo.kind {
            ServoKind::Maestro => {
                ServoBoard::Maestro(Box::new(MaestroPort::open(&config.maestro)?))
            }
            ServoKind::Pca9685 => ServoBoard::Pca9685(Pca9685Output::open(&config.pca9685)?),
        })
    }
}

impl ServoOutput for ServoBoard {
    fn write_targets(
        &mut self,
        channels: &[u8; 3],
        targets_qus: &[u16; 3],
        deadline_ns: Nanos,
    ) -> Result<(), ServoError> {
        match self {
            ServoBoard::Maestro(m) => m.write_targets(channels, targets_qus, deadline_ns),
            ServoBoard::Pca9685(p) => p.write_targets(channels, targets_qus, deadline_ns),
        }
    }
}
