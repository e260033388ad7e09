//! Gyroscope FIFO: 100 frames, bypass / FIFO / stream, watermark, frame reads.

#[cfg(feature = "async")]
use super::AsyncGyroscope;
use super::{register as reg, GyroRaw, Gyroscope};
#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::{FifoRegisters, Registers};
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::RegisterInterface;
use crate::types::{fifo_frame_registers, FifoData, FifoMode, FifoStatus};
use crate::Error;

/// The FIFO's status and data registers, for the shared frame reader.
pub(crate) const GYRO_FIFO_REGISTERS: FifoRegisters = FifoRegisters {
    status: reg::FIFO_STATUS,
    data: reg::FIFO_DATA,
};

/// FIFO depth in frames.
pub const GYRO_FIFO_FRAMES: u8 = 100;

/// Gyroscope FIFO settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroFifoConfig {
    /// Operating mode.
    pub mode: FifoMode,
    /// Axes stored per frame.
    pub data: FifoData,
    /// Watermark in frames (0..=99).
    pub watermark: u8,
}

impl GyroFifoConfig {
    /// The register writes (watermark, then mode and data select, which also clears the
    /// FIFO). `None` if the watermark is above 99 frames.
    pub fn register_writes(&self) -> Option<[(u8, u8); 2]> {
        if self.watermark >= GYRO_FIFO_FRAMES {
            return None;
        }
        Some([
            (reg::FIFO_CONFIG_0, self.watermark & 0x7F),
            (
                reg::FIFO_CONFIG_1,
                ((self.mode as u8) << reg::FIFO_MODE_SHIFT) | self.data as u8,
            ),
        ])
    }
}

/// Decode one FIFO frame; single-axis frames fill only their axis.
pub fn decode_gyro_fifo_frame(data: FifoData, frame: &[u8]) -> GyroRaw {
    GyroRaw::from_registers(&fifo_frame_registers(data, frame))
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Gyroscope<IFACE> {
        /// Configure the FIFO. [`DeviceError::InvalidInput`](crate::DeviceError::InvalidInput) if the watermark is above 99.
        pub async fn configure_fifo(
            &mut self,
            config: &GyroFifoConfig,
        ) -> Result<(), Error<IFACE::Error>> {
            let writes = config
                .register_writes()
                .ok_or(Error::Device(crate::DeviceError::InvalidInput))?;
            self.iface.write_all(writes).await?;
            self.fifo_data = config.data;
            Ok(())
        }

        /// Frames waiting and the overrun flag.
        pub async fn fifo_status(&mut self) -> Result<FifoStatus, Error<IFACE::Error>> {
            Ok(FifoStatus::from_register(
                self.iface.read(reg::FIFO_STATUS).await?,
            ))
        }

        /// Read up to `out.len()` frames (never more than are waiting), whole frames per burst.
        /// Returns the number of frames written to `out`.
        pub async fn read_fifo(&mut self, out: &mut [GyroRaw]) -> Result<usize, Error<IFACE::Error>> {
            let data = self.fifo_data;
            self.iface
                .read_fifo(GYRO_FIFO_REGISTERS, data, out, decode_gyro_fifo_frame)
                .await
        }
    }
}
