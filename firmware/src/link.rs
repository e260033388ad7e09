//! The link to the host: USART3 transmit, 8N2, as a [`TxDma`] for
//! `dima_firmware_logic::TxLink`, which decides what goes out and rotates the buffers.
//!
//! On the board the bytes go out by DMA (DMA1 stream 3, channel 4); the stream's interrupt
//! runs `link_done`. Under QEMU (`qemu` feature) DMA is not modelled: the bytes are written one
//! by one and the completion interrupt is pended by hand, so the same completion path runs.

use dima_firmware_logic::TxDma;

#[cfg(feature = "qemu")]
pub use self::blocking::LinkDma;
#[cfg(not(feature = "qemu"))]
pub use self::dma::LinkDma;

/// The link's transmit side.
pub type Link = dima_firmware_logic::TxLink<LinkDma>;

#[cfg(not(feature = "qemu"))]
mod dma {
    use super::TxDma;
    use stm32f4xx_hal::dma::{DMAError, DmaFlag, MemoryToPeripheral, Stream3, Transfer};
    use stm32f4xx_hal::pac::{DMA1, USART3};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::serial::Tx;

    /// USART3 TX is DMA1 stream 3, channel 4.
    pub type TxTransfer =
        Transfer<Stream3<DMA1>, 4, Tx<USART3>, MemoryToPeripheral, &'static mut [u8]>;

    /// DMA1 stream 3 with the buffer it holds.
    pub struct LinkDma(pub TxTransfer);

    impl TxDma for LinkDma {
        type Buffer = &'static mut [u8];

        fn start(&mut self, buffer: Self::Buffer) -> Result<Self::Buffer, Self::Buffer> {
            match self.0.next_transfer(buffer) {
                Ok((previous, _)) => Ok(previous),
                Err(
                    DMAError::NotReady(buffer)
                    | DMAError::SmallBuffer(buffer)
                    | DMAError::Overrun(buffer),
                ) => Err(buffer),
            }
        }

        fn is_done(&self) -> bool {
            self.0.flags().is_transfer_complete()
        }

        fn error(&self) -> bool {
            self.0.flags().is_transfer_error()
        }

        fn clear(&mut self) {
            self.0.clear_flags(
                DmaFlag::TransferComplete
                    | DmaFlag::TransferError
                    | DmaFlag::FifoError
                    | DmaFlag::DirectModeError
                    | DmaFlag::HalfTransfer,
            );
        }
    }
}

#[cfg(feature = "qemu")]
mod blocking {
    use super::TxDma;
    use stm32f4xx_hal::pac::{Interrupt, USART3};
    use stm32f4xx_hal::serial::Tx;

    /// Blocking writes standing in for the DMA stream under QEMU.
    pub struct LinkDma {
        tx: Tx<USART3>,
        held: Option<&'static mut [u8]>,
        done: bool,
    }

    impl LinkDma {
        /// Wraps the USART3 transmitter; `held` plays the buffer the stream holds at start.
        pub fn new(tx: Tx<USART3>, held: &'static mut [u8]) -> Self {
            Self {
                tx,
                held: Some(held),
                done: false,
            }
        }
    }

    impl TxDma for LinkDma {
        type Buffer = &'static mut [u8];

        fn start(&mut self, buffer: Self::Buffer) -> Result<Self::Buffer, Self::Buffer> {
            let Some(previous) = self.held.take() else {
                return Err(buffer);
            };
            for &byte in buffer.iter() {
                // QEMU's USART accepts a byte as soon as it is written.
                let _ = nb::block!(embedded_hal_nb::serial::Write::write(&mut self.tx, byte));
            }
            self.held = Some(buffer);
            self.done = true;
            cortex_m::peripheral::NVIC::pend(Interrupt::DMA1_STREAM3);
            Ok(previous)
        }

        fn is_done(&self) -> bool {
            self.done
        }

        fn error(&self) -> bool {
            false
        }

        fn clear(&mut self) {
            self.done = false;
        }
    }
}
