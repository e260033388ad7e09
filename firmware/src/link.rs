//! The link to the host: USART3 transmit, 8N2.
//!
//! The request interrupt hands a complete packet (and, when due, an info frame) to [`Link`],
//! which starts the transfer and returns at once; the transfer-complete interrupt then starts
//! the info frame or ends the answer. Only the request state machine decides when to call these
//! methods, so a transfer is never started while another one runs.
//!
//! On the board the bytes go out by DMA (DMA1 stream 3, channel 4). Three static buffers take
//! turns: two for packets and one for the info frame. The DMA always owns one of them (the one
//! it sends or sent last), so the request interrupt fills a buffer the DMA is not reading.
//!
//! Under QEMU (`qemu` feature) DMA is not modelled: the bytes are written one by one and the
//! completion interrupt is pended by hand, so the same completion path runs.

use dima_sensorboard::{INFO_V2_LEN, PACKET_LEN};

#[cfg(feature = "qemu")]
pub use self::blocking::Link;
#[cfg(not(feature = "qemu"))]
pub use self::dma::Link;

#[cfg(not(feature = "qemu"))]
mod dma {
    use super::{INFO_V2_LEN, PACKET_LEN};
    use stm32f4xx_hal::dma::{DMAError, MemoryToPeripheral, Stream3, Transfer};
    use stm32f4xx_hal::pac::{DMA1, USART3};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::serial::Tx;

    /// USART3 TX is DMA1 stream 3, channel 4.
    pub type TxTransfer =
        Transfer<Stream3<DMA1>, 4, Tx<USART3>, MemoryToPeripheral, &'static mut [u8]>;

    /// The DMA transmitter with its three buffers.
    pub struct Link {
        transfer: TxTransfer,
        spare_packets: [Option<&'static mut [u8]>; 2],
        spare_info: Option<&'static mut [u8]>,
        dma_errors: u32,
        /// A transfer could not be started: the next completion interrupt ends the answer.
        failed_start: bool,
    }

    impl Link {
        /// Takes the transfer (initialised with the info buffer, not started) and the two
        /// packet buffers.
        pub fn new(
            transfer: TxTransfer,
            packet_a: &'static mut [u8; PACKET_LEN],
            packet_b: &'static mut [u8; PACKET_LEN],
        ) -> Self {
            Self {
                transfer,
                spare_packets: [Some(packet_a), Some(packet_b)],
                spare_info: None,
                dma_errors: 0,
                failed_start: false,
            }
        }

        fn put_back(&mut self, buffer: &'static mut [u8]) {
            if buffer.len() == PACKET_LEN {
                if let Some(slot) = self.spare_packets.iter_mut().find(|slot| slot.is_none()) {
                    *slot = Some(buffer);
                }
            } else {
                self.spare_info = Some(buffer);
            }
        }

        fn start(&mut self, buffer: &'static mut [u8]) {
            match self.transfer.next_transfer(buffer) {
                Ok((previous, _)) => self.put_back(previous),
                Err(
                    DMAError::NotReady(buffer)
                    | DMAError::SmallBuffer(buffer)
                    | DMAError::Overrun(buffer),
                ) => {
                    self.put_back(buffer);
                    self.fail();
                }
            }
        }

        /// Nothing will complete: count it and have the completion interrupt end the answer,
        /// so the link never stays busy.
        fn fail(&mut self) {
            self.dma_errors = self.dma_errors.wrapping_add(1);
            self.failed_start = true;
            cortex_m::peripheral::NVIC::pend(stm32f4xx_hal::pac::Interrupt::DMA1_STREAM3);
        }

        /// Starts sending `packet`.
        pub fn send_packet(&mut self, packet: &[u8; PACKET_LEN]) {
            let spare = self.spare_packets.iter_mut().find_map(Option::take);
            match spare {
                Some(buffer) => {
                    buffer.copy_from_slice(packet);
                    self.start(buffer);
                }
                None => self.fail(),
            }
        }

        /// Stores the info frame that [`Link::send_info`] will send. Call after
        /// [`Link::send_packet`] (which frees the info buffer if the DMA held it).
        pub fn stage_info(&mut self, frame: &[u8; INFO_V2_LEN]) {
            if let Some(buffer) = self.spare_info.as_deref_mut() {
                buffer.copy_from_slice(frame);
            }
        }

        /// Starts sending the staged info frame.
        pub fn send_info(&mut self) {
            match self.spare_info.take() {
                Some(buffer) => self.start(buffer),
                None => self.fail(),
            }
        }

        /// In the DMA interrupt: true if a transfer ended (completed, or failed: a failed
        /// transfer is counted and ends the answer so the link never stays busy).
        pub fn take_completion(&mut self) -> bool {
            let flags = self.transfer.flags();
            self.transfer.clear_flags(
                stm32f4xx_hal::dma::DmaFlag::TransferComplete
                    | stm32f4xx_hal::dma::DmaFlag::TransferError
                    | stm32f4xx_hal::dma::DmaFlag::FifoError
                    | stm32f4xx_hal::dma::DmaFlag::DirectModeError
                    | stm32f4xx_hal::dma::DmaFlag::HalfTransfer,
            );
            if core::mem::take(&mut self.failed_start) {
                return true;
            }
            if flags.is_transfer_error() {
                self.dma_errors = self.dma_errors.wrapping_add(1);
                return true;
            }
            flags.is_transfer_complete()
        }

        /// DMA errors so far.
        pub fn dma_errors(&self) -> u32 {
            self.dma_errors
        }
    }
}

#[cfg(feature = "qemu")]
mod blocking {
    use super::{INFO_V2_LEN, PACKET_LEN};
    use stm32f4xx_hal::pac::{Interrupt, USART3};
    use stm32f4xx_hal::serial::Tx;

    /// The blocking transmitter used under QEMU.
    pub struct Link {
        tx: Tx<USART3>,
        info: [u8; INFO_V2_LEN],
    }

    impl Link {
        /// Wraps the USART3 transmitter.
        pub fn new(tx: Tx<USART3>) -> Self {
            Self {
                tx,
                info: [0; INFO_V2_LEN],
            }
        }

        fn write_all(&mut self, bytes: &[u8]) {
            for &byte in bytes {
                // QEMU's USART accepts a byte as soon as it is written.
                let _ = nb::block!(embedded_hal_nb::serial::Write::write(&mut self.tx, byte));
            }
            cortex_m::peripheral::NVIC::pend(Interrupt::DMA1_STREAM3);
        }

        /// Sends `packet`, then pends the completion interrupt.
        pub fn send_packet(&mut self, packet: &[u8; PACKET_LEN]) {
            self.write_all(packet);
        }

        /// Stores the info frame that [`Link::send_info`] will send.
        pub fn stage_info(&mut self, frame: &[u8; INFO_V2_LEN]) {
            self.info = *frame;
        }

        /// Sends the staged info frame, then pends the completion interrupt.
        pub fn send_info(&mut self) {
            let info = self.info;
            self.write_all(&info);
        }

        /// Every transfer has completed by the time its interrupt runs.
        pub fn take_completion(&mut self) -> bool {
            true
        }

        /// No DMA, no DMA errors.
        pub fn dma_errors(&self) -> u32 {
            0
        }
    }
}
