//! A busy-wait delay counted in CPU cycles, for sensor start-up waits.
//!
//! Each SPI device gets its own copy (it is `Copy`); SysTick belongs to the monotonic clock and
//! the timers to sampling, so this needs no peripheral.

use embedded_hal::delay::DelayNs;

/// Busy-waits for a number of core clock cycles.
#[derive(Debug, Clone, Copy)]
pub struct CycleDelay {
    cycles_per_us: u32,
}

impl CycleDelay {
    /// A delay for a core running at `sysclk_hz`.
    pub const fn new(sysclk_hz: u32) -> Self {
        Self {
            cycles_per_us: sysclk_hz / 1_000_000,
        }
    }
}

impl DelayNs for CycleDelay {
    /// Rounds up to whole microseconds: 32-bit arithmetic only (a 64-bit division would pull
    /// about 860 bytes of library code into the firmware for start-up waits of milliseconds).
    fn delay_ns(&mut self, ns: u32) {
        self.delay_us(ns.div_ceil(1000));
    }

    fn delay_us(&mut self, us: u32) {
        cortex_m::asm::delay(us.saturating_mul(self.cycles_per_us).max(1));
    }
}
