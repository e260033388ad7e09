//! Accelerometer FIFO: 32 frames, bypass / FIFO / stream, watermark, frame reads.

use super::{register as reg, AccelRaw, Accelerometer};
use crate::interface::RegisterInterface;
use crate::types::{FifoData, FifoMode, FifoStatus};
use crate::Error;

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
    AccelRaw::from_registers(&b)
}

impl<IFACE: RegisterInterface> Accelerometer<IFACE> {
    /// Configure the FIFO. `Error::InvalidInput` if the watermark is above 31.
    pub fn configure_fifo(&mut self, config: &AccelFifoConfig) -> Result<(), Error<IFACE::Error>> {
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
    pub fn read_fifo(&mut self, out: &mut [AccelRaw]) -> Result<usize, Error<IFACE::Error>> {
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
                *slot = decode_accel_fifo_frame(data, frame);
            }
            done += n;
        }
        Ok(done)
    }
}
