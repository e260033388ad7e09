//! The Maestro's error register (reply of Get Errors).

bitflags::bitflags! {
    /// Bits of the Maestro's 16-bit error register, as documented in the user's guide
    /// ("Errors"). Any set bit lights the red LED and sends the channels to their home
    /// positions; Get Errors reads and clears the register.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
    pub struct ErrorFlags: u16 {
        /// Bit 0: a byte's stop bit was not where expected (usually a baud rate mismatch).
        const SERIAL_SIGNAL = 1 << 0;
        /// Bit 1: the UART's hardware buffer overran.
        const SERIAL_OVERRUN = 1 << 1;
        /// Bit 2: the firmware's receive buffer was full and a byte was lost.
        const SERIAL_BUFFER_FULL = 1 << 2;
        /// Bit 3: a packet's CRC-7 byte did not match (CRC mode only); the packet was ignored.
        const SERIAL_CRC = 1 << 3;
        /// Bit 4: malformed packet (unknown command, or a packet interrupted by another).
        const SERIAL_PROTOCOL = 1 << 4;
        /// Bit 5: no valid command within the configured serial timeout.
        const SERIAL_TIMEOUT = 1 << 5;
        /// Bit 6: script stack overflow or underflow.
        const SCRIPT_STACK = 1 << 6;
        /// Bit 7: script call stack overflow or underflow.
        const SCRIPT_CALL_STACK = 1 << 7;
        /// Bit 8: script program counter out of bounds.
        const SCRIPT_PROGRAM_COUNTER = 1 << 8;
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ErrorFlags {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "ErrorFlags({=u16:#06x})", self.bits())
    }
}
