//! `qemu` build only: the four sensor dies as register images in RAM, fed by the host over
//! USART2 (`dima_firmware_logic::sensor_image`: frame layout, register semantics).
//!
//! QEMU's `netduinoplus2` has no sensors on SPI1, so this build's SPI devices answer from the
//! images instead: the firmware's bring-up (chip ids, configuration writes, calibration and
//! trim reads) and its sampling run unchanged against what the host wrote. At boot `init`
//! waits for the host's images (see [`wait_for_boot_images`]); afterwards the USART2
//! interrupt applies each update frame as it arrives. Every SPI transaction and every update runs
//! in a critical section, so a transaction never sees half an update.

use core::cell::RefCell;
use cortex_m::interrupt::{free, Mutex};
use dima_firmware_logic::sensor_image::{
    Die, ImageFrame, ImageFrameParser, ImageUpdate, SensorImages,
};
use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use stm32f4xx_hal::pac::{self, interrupt};

/// The dies' registers, shared by the SPI devices (sampling task) and the update task.
static IMAGES: Mutex<RefCell<SensorImages>> = Mutex::new(RefCell::new(SensorImages::ZERO));

/// How long `init` waits for the host's first image byte before it brings the dies up
/// without images (they stay absent, as before this build had images), ms.
const FIRST_BYTE_WAIT_MS: u32 = 1_000;
/// How long `init` waits for the end of the boot images once the host started sending, ms.
const BOOT_IMAGES_WAIT_MS: u32 = 10_000;

/// One die as an SPI device answering from its image.
pub struct ImageSpi {
    die: Die,
}

impl ImageSpi {
    /// The device of `die`.
    pub const fn new(die: Die) -> Self {
        Self { die }
    }
}

impl ErrorType for ImageSpi {
    type Error = ErrorKind;
}

impl SpiDevice for ImageSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        free(|cs| {
            IMAGES
                .borrow(cs)
                .borrow_mut()
                .transaction(self.die, operations)
        })
    }
}

/// USART2's registers. The firmware uses USART2 for nothing else.
fn usart2() -> &'static pac::usart1::RegisterBlock {
    // SAFETY: USART2 is owned by this module alone (the board build does not use it); the
    // register block is valid for the whole program.
    #[allow(unsafe_code)]
    unsafe {
        &*pac::USART2::ptr()
    }
}

/// Turns on USART2's receiver (QEMU models neither pins nor baud rate: no pin set-up).
fn start_receiver() {
    // SAFETY: a read-modify-write of RCC_APB1ENR's USART2 enable bit in `init` (interrupts
    // off); no other code changes that bit.
    #[allow(unsafe_code)]
    unsafe {
        (*pac::RCC::ptr())
            .apb1enr()
            .modify(|_, w| w.usart2en().set_bit());
    }
    usart2().cr1().write(|w| w.ue().set_bit().re().set_bit());
}

/// The next received byte, if any.
pub fn read_byte() -> Option<u8> {
    let usart = usart2();
    if usart.sr().read().rxne().bit_is_set() {
        Some(usart.dr().read().dr().bits() as u8)
    } else {
        None
    }
}

/// Applies one update from the host.
pub fn apply(update: &ImageUpdate<'_>) {
    free(|cs| IMAGES.borrow(cs).borrow_mut().apply(update));
}

/// USART2 received a byte: applies every update frame it completes. A plain interrupt
/// handler, not an RTIC task: it shares nothing with the tasks but [`IMAGES`], which it only
/// touches in a critical section, so any priority is sound; it runs at the GNSS tasks' (see
/// [`enable_update_interrupt`]). (An RTIC task, even one compiled only here, would set
/// USART2's priority and unmask it in the board build too.)
#[interrupt]
fn USART2() {
    static mut PARSER: ImageFrameParser = ImageFrameParser::new();
    while let Some(byte) = read_byte() {
        if let Some(ImageFrame::Update(update)) = PARSER.push(byte) {
            apply(&update);
        }
    }
}

/// RTIC priority of the update interrupt: the GNSS tasks'.
const UPDATE_PRIORITY: u8 = 2;

/// Enables USART2's receive interrupt at [`UPDATE_PRIORITY`] (RTIC's mapping: logical 1 is
/// the lowest hardware level).
fn enable_update_interrupt() {
    usart2().cr1().modify(|_, w| w.rxneie().set_bit());
    let hardware = ((1u8 << pac::NVIC_PRIO_BITS) - UPDATE_PRIORITY) << (8 - pac::NVIC_PRIO_BITS);
    // SAFETY: called at the end of the sensors' set-up in `init` (interrupts off); RTIC owns
    // no USART2 task and no lock depends on this interrupt's priority (the handler takes a
    // critical section for everything it shares).
    #[allow(unsafe_code)]
    unsafe {
        let mut core = cortex_m::Peripherals::steal();
        core.NVIC.set_priority(pac::Interrupt::USART2, hardware);
        cortex_m::peripheral::NVIC::unmask(pac::Interrupt::USART2);
    }
}

/// In `init`, before the sensors' bring-up: says `sensor images: waiting` (the host's cue),
/// applies the host's frames until its end-of-boot-images frame, then enables USART2's
/// receive interrupt for the updates that follow. Without a byte from the host within
/// [`FIRST_BYTE_WAIT_MS`] (no host on USART2, e.g. the smoke test) it goes on with blank
/// images, and the dies are reported absent.
pub fn wait_for_boot_images() {
    start_receiver();
    cortex_m_semihosting::hprintln!("sensor images: waiting");
    let mut parser = ImageFrameParser::new();
    let mut waited = 0u32;
    let mut heard = false;
    let outcome = loop {
        if let Some(byte) = read_byte() {
            heard = true;
            match parser.push(byte) {
                Some(ImageFrame::Update(update)) => apply(&update),
                Some(ImageFrame::EndOfBootImages) => break "loaded",
                None => {}
            }
        }
        if systick_wrapped() {
            waited += 1000 / crate::board::MONO_HZ;
        }
        if !heard && waited > FIRST_BYTE_WAIT_MS {
            break "none";
        }
        if waited > BOOT_IMAGES_WAIT_MS {
            break "incomplete";
        }
    };
    cortex_m_semihosting::hprintln!("sensor images: {}", outcome);
    enable_update_interrupt();
}

/// SysTick wrapped since the last call (its COUNTFLAG, cleared by the read): one period of
/// the monotonic clock, which `init` runs before this. Read here rather than through the
/// monotonic clock: the clock's own count then stays where a board without this wait would
/// have it when `init` ends.
fn systick_wrapped() -> bool {
    // SAFETY: a read of SYST_CSR in `init` (interrupts off); its only side effect clears
    // COUNTFLAG, which the monotonic clock reads only to count wraps.
    #[allow(unsafe_code)]
    unsafe {
        (*cortex_m::peripheral::SYST::PTR).csr.read() & (1 << 16) != 0
    }
}

/// The four dies' devices: accelerometer, gyroscope, magnetometer, BMP280.
pub fn devices() -> [ImageSpi; 4] {
    [
        ImageSpi::new(Die::Accel),
        ImageSpi::new(Die::Gyro),
        ImageSpi::new(Die::Mag),
        ImageSpi::new(Die::Bmp280),
    ]
}
