//! The panic handler: stop answering, record the panic, reset at once.
//!
//! A halted core with interrupts on would keep answering requests with the last packet (a
//! valid CRC) until the watchdog reset it 68-188 ms later, and the next boot would only say
//! "watchdog reset". Instead: interrupts off (no request, link or sampling task runs again),
//! the link's DMA stream and USART3's transmitter stopped and the request line masked (the
//! host sees the answer in flight cut short, which its CRC rejects, then silence), the
//! fault [`BootFault::Panic`] written into the reset record, and a system reset. The next
//! boot reports it once (`BOOT_FAULT` = 4; under QEMU its boot message).

use dima_firmware_logic::reset_record::BootFault;
use stm32f4xx_hal::pac;

/// The EXTI line of the request pin (PD10).
const REQUEST_EXTI_LINE: u32 = 10;
/// The link's DMA stream (DMA1 stream 3, USART3 TX).
const LINK_DMA_STREAM: usize = 3;

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    stop_answering();
    crate::reset_record::record_fault(BootFault::Panic);
    #[cfg(feature = "qemu")]
    cortex_m_semihosting::hprintln!("panic: resetting");
    cortex_m::peripheral::SCB::sys_reset()
}

/// Stops the link: no new request edge, the running transfer cut off.
#[allow(unsafe_code)]
fn stop_answering() {
    // SAFETY: interrupts are off and the handler never returns, so no task's view of these
    // peripherals is used again. Each write only disables: the EXTI mask clears one line, the
    // stream's enable bit and USART3's transmitter enable are cleared.
    unsafe {
        let exti = &*pac::EXTI::ptr();
        exti.imr()
            .modify(|r, w| w.bits(r.bits() & !(1 << REQUEST_EXTI_LINE)));
        (*pac::DMA1::ptr())
            .st(LINK_DMA_STREAM)
            .cr()
            .modify(|_, w| w.en().clear_bit());
        (*pac::USART3::ptr())
            .cr1()
            .modify(|_, w| w.te().clear_bit());
    }
}
