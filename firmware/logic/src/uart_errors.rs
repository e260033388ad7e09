//! Receive errors of a UART, counted from its status register (RM0090 30.6.1, USART_SR):
//! overrun (ORE, bit 3), noise (NF, bit 2) and framing (FE, bit 1) errors.
//!
//! The flags are cleared by a read of the status register followed by a read of the data
//! register, which on the board the DMA stream does with the next byte. A drain that received
//! nothing since the previous one can therefore still see the flags the previous one counted:
//! they are counted only when bytes arrived in between (every flag comes with a byte, or, for
//! an overrun, with the byte that pushed another out).

/// USART_SR's overrun error flag.
pub const SR_ORE: u32 = 1 << 3;
/// USART_SR's noise flag.
pub const SR_NF: u32 = 1 << 2;
/// USART_SR's framing error flag.
pub const SR_FE: u32 = 1 << 1;

/// The receive errors seen so far (each count wraps).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UartErrors {
    /// Overrun errors: a byte lost because the previous one was not read in time.
    pub overrun: u32,
    /// Framing errors: no stop bit where one belongs (baud rate, line break, wiring).
    pub framing: u32,
    /// Noise errors: the line changed within a bit's samples.
    pub noise: u32,
}

impl UartErrors {
    /// No error yet.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            overrun: 0,
            framing: 0,
            noise: 0,
        }
    }

    /// Counts the error flags in `status` (USART_SR as read before handing the received bytes
    /// on) if `bytes_received` since the previous call is not zero.
    pub fn count(&mut self, status: u32, bytes_received: usize) {
        if bytes_received == 0 {
            return;
        }
        let bump = |counter: &mut u32, flag: u32| {
            if status & flag != 0 {
                *counter = counter.wrapping_add(1);
            }
        };
        bump(&mut self.overrun, SR_ORE);
        bump(&mut self.framing, SR_FE);
        bump(&mut self.noise, SR_NF);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RXNE, TC and TXE, which say nothing about errors.
    const OTHER_FLAGS: u32 = 1 << 5 | 1 << 6 | 1 << 7;

    #[test]
    fn each_flag_counts_in_its_own_counter() {
        let mut errors = UartErrors::new();
        errors.count(SR_ORE | OTHER_FLAGS, 3);
        errors.count(SR_FE, 1);
        errors.count(SR_NF | SR_FE, 1);
        assert_eq!(
            errors,
            UartErrors {
                overrun: 1,
                framing: 2,
                noise: 1
            }
        );
    }

    #[test]
    fn flags_without_new_bytes_are_the_ones_already_counted() {
        let mut errors = UartErrors::new();
        // Transfer complete, then the idle line at the end of the same burst.
        errors.count(SR_FE, 128);
        errors.count(SR_FE, 0);
        assert_eq!(errors.framing, 1);
        errors.count(OTHER_FLAGS, 5);
        assert_eq!(
            errors,
            UartErrors {
                framing: 1,
                ..UartErrors::new()
            }
        );
    }

    #[test]
    fn counters_wrap() {
        let mut errors = UartErrors {
            overrun: u32::MAX,
            ..UartErrors::new()
        };
        errors.count(SR_ORE, 1);
        assert_eq!(errors.overrun, 0);
    }
}
