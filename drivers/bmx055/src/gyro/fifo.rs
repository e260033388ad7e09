//! Gyroscope FIFO: 100 frames, bypass / FIFO / stream, watermark, frame reads.

use super::{register as reg, GyroRaw, Gyroscope};
use crate::interface::RegisterInterface;
use crate::types::{FifoData, FifoMode, FifoStatus};
use crate::Error;

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
    let mut b = [0u8; 6];
    let at = match data {
        FifoData::Xyz | FifoData::X => 0,
        FifoData::Y => 2,
        FifoData::Z => 4,
    };
    for (i, v) in frame.iter().take(data.frame_len()).enumerate() {
        if let Some(slot) = b.get_mut(at + i) {
            *slot = *v;
        }
    }
    GyroRaw::from_registers(&b)
}

impl<IFACE: RegisterInterface> Gyroscope<IFACE> {
    /// Configure the FIFO. `Error::InvalidInput` if the watermark is above 99.
    pub fn configure_fifo(&mut self, config: &GyroFifoConfig) -> Result<(), Error<IFACE::Error>> {
        let writes = config.register_writes().ok_or(Error::InvalidInput)?;
        for (r, v) in writes {
            self.write(r, v)?;
        }
        self.fifo_data = config.data;
        Ok(())
    }

    /// Frames waiting and the overrun flag.
    pub fn fifo_status(&mut self) -> Result<FifoStatus, Error<IFACE::Error>> {
        Ok(FifoStatus::from_register(self.read(reg::FIFO_STATUS)?))
    }

    /// Read up to `out.len()` frames (never more than are waiting), whole frames per burst.
    /// Returns the number of frames written to `out`.
    pub fn read_fifo(&mut self, out: &mut [GyroRaw]) -> Result<usize, Error<IFACE::Error>> {
        let waiting = usize::from(self.fifo_status()?.frames);
        let want = waiting.min(out.len());
        let data = self.fifo_data;
        let len = data.frame_len();
        let mut buf = [0u8; 48];
        let per_burst = buf.len() / len;
        let mut done = 0;
        while done < want {
            let n = (want - done).min(per_burst);
            let bytes = &mut buf[..n * len];
            self.read_into(reg::FIFO_DATA, bytes)?;
            for (slot, frame) in out[done..done + n].iter_mut().zip(bytes.chunks_exact(len)) {
                *slot = decode_gyro_fifo_frame(data, frame);
            }
            done += n;
        }
        Ok(done)
    }
}
