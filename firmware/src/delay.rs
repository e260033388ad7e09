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
    fn delay_ns(&mut self, ns: u32) {
        let cycles = u64::from(ns) * u64::from(self.cycles_per_us) / 1000;
        cortex_m::asm::delay(u32::try_from(cycles).unwrap_or(u32::MAX).max(1));
    }

    fn delay_us(&mut self, us: u32) {
        cortex_m::asm::delay(us.saturating_mul(self.cycles_per_us).max(1));
    }
}
