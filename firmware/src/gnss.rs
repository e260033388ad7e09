//! The GNSS receive side: USART1 at 115 200 baud from the NEO-M8T.
//!
//! On the board the bytes arrive by DMA (DMA2 stream 2, channel 4) into one of two buffers; the
//! idle-line interrupt (end of a burst) and the transfer-complete interrupt (buffer full) each
//! clear their flags, hand the bytes received so far to the UBX reader and restart the stream
//! on the other buffer (`dima_firmware_logic::gnss_rx`). The USART keeps a byte in its data register while the stream is briefly stopped, so
//! at 115 200 baud (87 µs per byte) nothing is lost in the swap.
//!
//! Under QEMU (`qemu` feature) DMA is not modelled: the receive-not-empty interrupt delivers
//! one byte at a time.
//!
//! USART1 TX (PB6) carries only the configuration messages of `gnss_setup`.

use crate::board::GNSS_BAUD;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::serial;

#[cfg(not(feature = "qemu"))]
pub use self::dma::{set_up, GnssRx};
#[cfg(feature = "qemu")]
pub use self::interrupt::{set_up, GnssRx};

/// USART1's status register (USART_SR) as it stands: its error flags are counted by
/// `dima_firmware_logic::uart_errors`. The read is the first half of the flags' clearing
/// sequence; the second, a read of the data register, is the DMA stream's (or, under QEMU,
/// the receive interrupt's) next byte.
pub fn line_status() -> u32 {
    // SAFETY: a read of USART1_SR; its only side effect is the intended first step of
    // clearing the error flags (see above). The receive path owns USART1 otherwise.
    #[allow(unsafe_code)]
    unsafe {
        u32::from((*stm32f4xx_hal::pac::USART1::ptr()).sr().read().bits())
    }
}

/// USART1's settings: [`GNSS_BAUD`], the HAL's defaults otherwise (8N1).
fn serial_config() -> serial::Config {
    serial::Config::default().baudrate(GNSS_BAUD.bps())
}

#[cfg(not(feature = "qemu"))]
mod dma {
    use super::serial_config;
    use crate::board::GNSS_DMA_LEN;
    use dima_firmware_logic::gnss_rx::{DoubleBufferRx, RxStream};
    use stm32f4xx_hal::dma::config::DmaConfig;
    use stm32f4xx_hal::dma::{
        DMAError, DmaFlag, PeripheralToMemory, Stream2, StreamsTuple, Transfer,
    };
    use stm32f4xx_hal::gpio::{PB6, PB7};
    use stm32f4xx_hal::pac::{DMA2, USART1};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Rcc;
    use stm32f4xx_hal::serial::{self, config::InvalidConfig, Rx, RxISR, Tx};

    /// USART1 RX is DMA2 stream 2, channel 4.
    pub type RxTransfer =
        Transfer<Stream2<DMA2>, 4, Rx<USART1>, PeripheralToMemory, &'static mut [u8; GNSS_DMA_LEN]>;

    /// Brings up USART1 on PB6 (TX) and PB7 (RX, DMA requests, idle-line interrupt), then
    /// starts DMA2 stream 2 into the first buffer (interrupting when it is full); the second
    /// is the spare. Returns the receiver and the transmitter. Fails if USART1 rejects its
    /// settings.
    pub fn set_up(
        usart1: USART1,
        dma2: DMA2,
        pins: (PB6, PB7),
        [first, spare]: [&'static mut [u8; GNSS_DMA_LEN]; 2],
        rcc: &mut Rcc,
    ) -> Result<(GnssRx, Tx<USART1>), InvalidConfig> {
        let (tx, mut rx) = usart1
            .serial(
                pins,
                serial_config().dma(serial::config::DmaConfig::Rx),
                rcc,
            )?
            .split();
        rx.listen_idle();
        let streams = StreamsTuple::new(dma2, rcc);
        let mut transfer = Transfer::init_peripheral_to_memory(
            streams.2,
            rx,
            first,
            None,
            DmaConfig::default()
                .memory_increment(true)
                .transfer_complete_interrupt(true),
        );
        transfer.start(|_| {});
        Ok((GnssRx::new(RxStreamOf(transfer), spare), tx))
    }

    /// The DMA receiver with its spare buffer; `drain` (from `dima_firmware_logic::gnss_rx`)
    /// acknowledges USART1's idle line and every flag of the stream, whichever of the two
    /// interrupts runs it.
    pub type GnssRx = DoubleBufferRx<RxStreamOf>;

    /// DMA2 stream 2 behind USART1, as the double buffer sees it.
    pub struct RxStreamOf(RxTransfer);

    impl RxStream for RxStreamOf {
        type Buffer = &'static mut [u8; GNSS_DMA_LEN];

        fn clear_flags(&mut self) {
            if self.0.is_idle() {
                self.0.clear_idle_interrupt();
            }
            self.0.clear_flags(
                DmaFlag::TransferComplete
                    | DmaFlag::HalfTransfer
                    | DmaFlag::FifoError
                    | DmaFlag::TransferError
                    | DmaFlag::DirectModeError,
            );
        }

        fn swap(&mut self, spare: Self::Buffer) -> Result<(Self::Buffer, usize), Self::Buffer> {
            self.0.pause(|_| {});
            let received = GNSS_DMA_LEN.saturating_sub(usize::from(self.0.number_of_transfers()));
            match self.0.next_transfer(spare) {
                Ok((full, _)) => Ok((full, received)),
                // Single-buffer peripheral-to-memory transfers do not fail; if one ever did,
                // keep receiving into the old buffer.
                Err(
                    DMAError::NotReady(spare)
                    | DMAError::SmallBuffer(spare)
                    | DMAError::Overrun(spare),
                ) => {
                    self.0.start(|_| {});
                    Err(spare)
                }
            }
        }
    }
}

#[cfg(feature = "qemu")]
mod interrupt {
    use super::serial_config;
    use crate::board::GNSS_DMA_LEN;
    use stm32f4xx_hal::gpio::{PB6, PB7};
    use stm32f4xx_hal::pac::{DMA2, USART1};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Rcc;
    use stm32f4xx_hal::serial::{config::InvalidConfig, Rx, Tx};

    /// Brings up USART1 on PB6 (TX) and PB7 (RX, receive-not-empty interrupt). DMA2 and the
    /// two DMA buffers stay unused: QEMU does not model DMA. Returns the receiver and the
    /// transmitter. Fails if USART1 rejects its settings.
    pub fn set_up(
        usart1: USART1,
        _dma2: DMA2,
        pins: (PB6, PB7),
        _buffers: [&'static mut [u8; GNSS_DMA_LEN]; 2],
        rcc: &mut Rcc,
    ) -> Result<(GnssRx, Tx<USART1>), InvalidConfig> {
        let (tx, mut rx) = usart1.serial(pins, serial_config(), rcc)?.split();
        rx.listen();
        Ok((GnssRx::new(rx), tx))
    }

    /// The interrupt-driven receiver used under QEMU.
    pub struct GnssRx {
        rx: Rx<USART1>,
    }

    impl GnssRx {
        /// Wraps a receiver that listens for receive-not-empty.
        pub fn new(rx: Rx<USART1>) -> Self {
            Self { rx }
        }

        /// In the USART1 interrupt: passes the received bytes to `on_bytes`.
        pub fn drain(&mut self, on_bytes: impl FnOnce(&[u8])) {
            let mut bytes = [0u8; 16];
            let mut count = 0;
            while count < bytes.len() {
                match embedded_hal_nb::serial::Read::read(&mut self.rx) {
                    Ok(byte) => {
                        bytes[count] = byte;
                        count += 1;
                    }
                    Err(_) => break,
                }
            }
            on_bytes(&bytes[..count]);
        }
    }
}
