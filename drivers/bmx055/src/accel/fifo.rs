//! Accelerometer FIFO: 32 frames, bypass / FIFO / stream, watermark, frame reads.

#[cfg(feature = "async")]
use super::AsyncAccelerometer;
use super::{register as reg, AccelRaw, Accelerometer};
#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::{FifoRegisters, Registers};
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::RegisterInterface;
use crate::types::{fifo_frame_registers, FifoData, FifoMode, FifoStatus};
use crate::Error;

/// The FIFO's status and data registers, for the shared frame reader.
pub(crate) const ACCEL_FIFO_REGISTERS: FifoRegisters = FifoRegisters {
    status: reg::FIFO_STATUS,
    data: reg::FIFO_DATA,
};

/// FIFO depth in frames.
pub const ACCEL_FIFO_FRAMES: u8 = 32;

/// Accelerometer FIFO settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelFifoConfig {
    /// Operating mode.
    pub mode: FifoMode,
    /// Axes stored per frame.
    pub data: FifoData,
    /// Watermark in frames (0..=31); 0 disables the watermark interrupt.
    pub watermark: u8,
}

impl AccelFifoConfig {
    /// The register writes (watermark, then mode and data select; the second write also
    /// clears the FIFO). `None` if the watermark is above 31 frames.
    pub fn register_writes(&self) -> Option<[(u8, u8); 2]> {
        if self.watermark >= ACCEL_FIFO_FRAMES {
            return None;
        }
        Some([
            (reg::FIFO_CONFIG_0, self.watermark),
            (
                reg::FIFO_CONFIG_1,
                ((self.mode as u8) << reg::FIFO_MODE_SHIFT) | self.data as u8,
            ),
        ])
    }
}

/// Decode one FIFO frame (same byte layout as the data registers); single-axis frames fill
/// only their axis, the others stay 0.
pub fn decode_accel_fifo_frame(data: FifoData, frame: &[u8]) -> AccelRaw {
    AccelRaw::from_registers(&fifo_frame_registers(data, frame))
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Accelerometer<IFACE> {
        /// Configure the FIFO. [`DeviceError::InvalidInput`](crate::DeviceError::InvalidInput) if the watermark is above 31.
        pub async fn configure_fifo(
            &mut self,
            config: &AccelFifoConfig,
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
        pub async fn read_fifo(&mut self, out: &mut [AccelRaw]) -> Result<usize, Error<IFACE::Error>> {
            let data = self.fifo_data;
            self.iface
                .read_fifo(ACCEL_FIFO_REGISTERS, data, out, decode_accel_fifo_frame)
                .await
        }
    }
}
