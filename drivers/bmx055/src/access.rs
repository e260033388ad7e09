//! Register access shared by the three dies (blocking): bus errors become
//! [`Error::Comm`], plus the sequences the dies have in common — write lists, the chip-id
//! retry and FIFO frame reads. The async twin is `asynch::access`, with the same shape.

#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::RegisterInterface;
use crate::types::{FifoData, FifoStatus};
use crate::Error;
use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

/// Bytes the FIFO reads move per burst (a whole number of 6- and 2-byte frames).
pub(crate) const FIFO_BURST_BYTES: usize = 48;

/// Where a die keeps its FIFO: the fill-level register and the data register that pops
/// frames.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FifoRegisters {
    pub(crate) status: u8,
    pub(crate) data: u8,
}

/// The part of `out` a FIFO read fills: never more frames than are `waiting`.
pub(crate) fn fifo_destination<T>(out: &mut [T], waiting: u8) -> &mut [T] {
    let want = usize::from(waiting).min(out.len());
    &mut out[..want]
}

/// Decode the whole frames of one burst (`bytes`, frames of `data.frame_len()` bytes) into
/// `slots`, in order.
pub(crate) fn decode_frames<T>(
    slots: &mut [T],
    bytes: &[u8],
    data: FifoData,
    decode: fn(FifoData, &[u8]) -> T,
) {
    for (slot, frame) in slots.iter_mut().zip(bytes.chunks_exact(data.frame_len())) {
        *slot = decode(data, frame);
    }
}

crate::blocking_and_async! {
    /// Driver-level register access on top of any [`RegisterInterface`].
    pub(crate) trait Registers: RegisterInterface {
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
        /// Read the chip id at `register` up to `attempts` times (at least once, 1 ms apart)
        /// until it is `expected`; a die that is still starting up answers late.
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
            Err(Error::Device(crate::DeviceError::InvalidChipId { found }))
        }
        /// Read up to `out.len()` frames (never more than the status register says are
        /// waiting), whole frames per burst, decoding each with `decode`. Returns the number of
        /// frames written to `out`.
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
}

crate::blocking_and_async! {
    impl<I: RegisterInterface> Registers for I {}
}
