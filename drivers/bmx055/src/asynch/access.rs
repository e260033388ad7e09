//! Async twin of the shared register access (`crate::access`): the same sequences, with
//! the I/O awaited.

use crate::access::{decode_frames, fifo_destination, FifoRegisters, FIFO_BURST_BYTES};
use crate::interface::AsyncRegisterInterface;
use crate::types::{FifoData, FifoStatus};
use crate::Error;
use embedded_hal_async::delay::DelayNs;

/// Driver-level register access on top of any [`AsyncRegisterInterface`].
pub(crate) trait AsyncRegisters: AsyncRegisterInterface {
    /// Write one register.
    async fn write(&mut self, r: u8, v: u8) -> Result<(), Error<Self::Error>> {
        self.write_register(r, v).await.map_err(Error::Comm)
    }
    /// Read one register.
    async fn read(&mut self, r: u8) -> Result<u8, Error<Self::Error>> {
        self.read_register(r).await.map_err(Error::Comm)
    }
    /// Burst read starting at `r`.
    async fn read_into(&mut self, r: u8, buf: &mut [u8]) -> Result<(), Error<Self::Error>> {
        self.read_registers(r, buf).await.map_err(Error::Comm)
    }
    /// Write `(register, value)` pairs in order, stopping at the first bus error.
    async fn write_all(
        &mut self,
        writes: impl IntoIterator<Item = (u8, u8)>,
    ) -> Result<(), Error<Self::Error>> {
        for (r, v) in writes {
            self.write(r, v).await?;
        }
        Ok(())
    }
    /// See `Registers::check_chip_id`.
    async fn check_chip_id(
        &mut self,
        delay: &mut impl DelayNs,
        register: u8,
        expected: u8,
        attempts: u8,
    ) -> Result<(), Error<Self::Error>> {
        let mut found = 0;
        for i in 0..attempts.max(1) {
            if i > 0 {
                delay.delay_ms(1).await;
            }
            found = self.read(register).await?;
            if found == expected {
                return Ok(());
            }
        }
        Err(Error::InvalidChipId { found })
    }
    /// See `Registers::read_fifo`.
    async fn read_fifo<T>(
        &mut self,
        fifo: FifoRegisters,
        data: FifoData,
        out: &mut [T],
        decode: fn(FifoData, &[u8]) -> T,
    ) -> Result<usize, Error<Self::Error>> {
        let waiting = FifoStatus::from_register(self.read(fifo.status).await?).frames;
        let out = fifo_destination(out, waiting);
        let len = data.frame_len();
        let mut buf = [0u8; FIFO_BURST_BYTES];
        for slots in out.chunks_mut(FIFO_BURST_BYTES / len) {
            let bytes = &mut buf[..slots.len() * len];
            self.read_into(fifo.data, bytes).await?;
            decode_frames(slots, bytes, data, decode);
        }
        Ok(out.len())
    }
}

impl<I: AsyncRegisterInterface> AsyncRegisters for I {}
