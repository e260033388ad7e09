//! The link to the host: USART3 transmit, 8N2, as a [`TxDma`] for
//! `dima_firmware_logic::TxLink`, which decides what goes out and rotates the buffers.
//!
//! On the board the bytes go out by DMA (DMA1 stream 3, channel 4); the stream's interrupt
//! runs `link_done`. Under QEMU (`qemu` feature) DMA is not modelled: the bytes are written one
//! by one and the completion interrupt is pended by hand, so the same completion path runs, and
//! bytes on USART3's receiver (PD9) stand in for the request edge.

use crate::board::LINK_BAUD;
use dima_firmware_logic::TxDma;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::serial::{self, config::StopBits};

#[cfg(feature = "qemu")]
pub use self::blocking::{set_up, LinkDma};
#[cfg(not(feature = "qemu"))]
pub use self::dma::{set_up, LinkDma};

/// The link's transmit side.
pub type Link = dima_firmware_logic::TxLink<LinkDma>;

/// The link's buffers, each `'static`: the piece buffer the stream holds at start
/// (`INFO_PIECE_LEN` bytes) and the two packet buffers (`PACKET_LEN` bytes each).
pub struct Buffers {
    /// The buffer the stream holds before the first transfer.
    pub piece: &'static mut [u8],
    /// First packet buffer.
    pub packet_a: &'static mut [u8],
    /// Second packet buffer.
    pub packet_b: &'static mut [u8],
}

/// What [`set_up`] gives `init`.
pub struct Parts {
    /// The transmitter, idle.
    pub link: Link,
    /// Under QEMU: USART3's receiver, listening; each byte on it is a request.
    #[cfg(feature = "qemu")]
    pub host_rx: serial::Rx<stm32f4xx_hal::pac::USART3>,
}

/// USART3's settings: [`LINK_BAUD`], 8 data bits, no parity, 2 stop bits.
fn serial_config() -> serial::Config {
    serial::Config::default()
        .baudrate(LINK_BAUD.bps())
        .wordlength_8()
        .parity_none()
        .stopbits(StopBits::STOP2)
}

#[cfg(not(feature = "qemu"))]
mod dma {
    use super::{serial_config, Buffers, Link, Parts, TxDma};
    use stm32f4xx_hal::dma::config::DmaConfig;
    use stm32f4xx_hal::dma::{
        DMAError, DmaFlag, MemoryToPeripheral, Stream3, StreamsTuple, Transfer,
    };
    use stm32f4xx_hal::gpio::{PD8, PD9};
    use stm32f4xx_hal::pac::{DMA1, USART3};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Rcc;
    use stm32f4xx_hal::serial::{self, config::InvalidConfig, Tx};

    /// USART3 TX is DMA1 stream 3, channel 4.
    pub type TxTransfer =
        Transfer<Stream3<DMA1>, 4, Tx<USART3>, MemoryToPeripheral, &'static mut [u8]>;

    /// DMA1 stream 3 with the buffer it holds.
    pub struct LinkDma(pub TxTransfer);

    /// Brings up USART3's transmitter on PD8 with DMA requests, then DMA1 stream 3 (not
    /// started) holding the piece buffer, interrupting on completion and on error. PD9 stays
    /// unused: on the board requests come on PD10. Fails if USART3 rejects its settings.
    pub fn set_up(
        usart3: USART3,
        dma1: DMA1,
        (tx_pin, _rx_pin): (PD8, PD9),
        buffers: Buffers,
        rcc: &mut Rcc,
    ) -> Result<Parts, InvalidConfig> {
        let tx = usart3.tx(
            tx_pin,
            serial_config().dma(serial::config::DmaConfig::Tx),
            rcc,
        )?;
        let streams = StreamsTuple::new(dma1, rcc);
        let transfer = Transfer::init_memory_to_peripheral(
            streams.3,
            tx,
            buffers.piece,
            None,
            DmaConfig::default()
                .memory_increment(true)
                .transfer_complete_interrupt(true)
                .transfer_error_interrupt(true),
        );
        Ok(Parts {
            link: Link::new(LinkDma(transfer), buffers.packet_a, buffers.packet_b),
        })
    }

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
    use super::{serial_config, Buffers, Link, Parts, TxDma};
    use stm32f4xx_hal::gpio::{PD8, PD9};
    use stm32f4xx_hal::pac::{Interrupt, DMA1, USART3};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Rcc;
    use stm32f4xx_hal::serial::{config::InvalidConfig, Tx};

    /// Brings up USART3 on PD8 (transmit, blocking) and PD9 (receive, listening: a byte from
    /// the host is a request). DMA1 stays unused: QEMU does not model it. Fails if USART3
    /// rejects its settings.
    pub fn set_up(
        usart3: USART3,
        _dma1: DMA1,
        pins: (PD8, PD9),
        buffers: Buffers,
        rcc: &mut Rcc,
    ) -> Result<Parts, InvalidConfig> {
        let (tx, mut host_rx) = usart3.serial(pins, serial_config(), rcc)?.split();
        host_rx.listen();
        let dma = LinkDma::new(tx, buffers.piece);
        Ok(Parts {
            link: Link::new(dma, buffers.packet_a, buffers.packet_b),
            host_rx,
        })
    }

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
