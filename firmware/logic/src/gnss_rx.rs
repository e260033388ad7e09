//! The GNSS receive side's double buffer, independent of the DMA stream behind it.
//!
//! On the board USART1's bytes go by DMA into one of two buffers. Two interrupts end a
//! buffer: USART1's idle line (end of a burst) and the DMA stream's transfer complete (buffer
//! full). Each handler must acknowledge the flags of its own source: an NVIC line stays
//! pending, and its handler re-entered, as long as an enabled flag is set. So whichever
//! interrupt runs, [`DoubleBufferRx::drain`] first clears every flag of both sources, then
//! hands the bytes received so far on and restarts the stream on the other buffer. The
//! firmware binds it to both USART1 and the stream's interrupt, and relies on neither running
//! before the other.

/// A receive DMA stream into one buffer at a time, with the USART's idle line.
pub trait RxStream {
    /// A buffer the stream fills.
    type Buffer: AsRef<[u8]>;

    /// Clears the stream's flags (transfer complete, half transfer, errors) and the USART's
    /// idle-line flag.
    fn clear_flags(&mut self);

    /// Stops the stream, swaps in `spare` and restarts it: returns the buffer it was filling
    /// with the number of bytes in it, or `spare` back if the swap failed (the stream keeps
    /// its buffer and runs again).
    fn swap(&mut self, spare: Self::Buffer) -> Result<(Self::Buffer, usize), Self::Buffer>;
}

/// A stream and its spare buffer.
pub struct DoubleBufferRx<S: RxStream> {
    stream: S,
    spare: Option<S::Buffer>,
}

impl<S: RxStream> DoubleBufferRx<S> {
    /// Takes a started stream and the second buffer.
    pub fn new(stream: S, spare: S::Buffer) -> Self {
        Self {
            stream,
            spare: Some(spare),
        }
    }

    /// In the USART's or the stream's interrupt: acknowledges both sources, passes the bytes
    /// received so far to `on_bytes` and restarts reception on the other buffer.
    pub fn drain(&mut self, on_bytes: impl FnOnce(&[u8])) {
        // First and unconditionally: a flag left set re-enters the handler for ever.
        self.stream.clear_flags();
        let Some(spare) = self.spare.take() else {
            return;
        };
        match self.stream.swap(spare) {
            Ok((full, received)) => {
                on_bytes(full.as_ref().get(..received).unwrap_or(&[]));
                self.spare = Some(full);
            }
            Err(spare) => self.spare = Some(spare),
        }
    }

    /// The stream, for what the firmware does beside draining.
    pub fn stream(&self) -> &S {
        &self.stream
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stream with the two interrupt sources' flags, filled by the test.
    struct FakeStream {
        buffer: [u8; 8],
        filled: usize,
        transfer_complete: bool,
        idle: bool,
    }

    impl RxStream for FakeStream {
        type Buffer = [u8; 8];

        fn clear_flags(&mut self) {
            self.transfer_complete = false;
            self.idle = false;
        }

        fn swap(&mut self, spare: [u8; 8]) -> Result<([u8; 8], usize), [u8; 8]> {
            let full = core::mem::replace(&mut self.buffer, spare);
            Ok((full, core::mem::take(&mut self.filled)))
        }
    }

    fn receiver() -> DoubleBufferRx<FakeStream> {
        DoubleBufferRx::new(
            FakeStream {
                buffer: [0; 8],
                filled: 0,
                transfer_complete: false,
                idle: false,
            },
            [0; 8],
        )
    }

    fn fill(rx: &mut DoubleBufferRx<FakeStream>, bytes: &[u8]) {
        rx.stream.buffer[..bytes.len()].copy_from_slice(bytes);
        rx.stream.filled = bytes.len();
        rx.stream.transfer_complete = bytes.len() == 8;
    }

    /// The stream's interrupt alone (USART1 never runs first, as with another pin-out or
    /// priority): its line is pending while the flag is set; the handler must clear it.
    #[test]
    fn the_stream_interrupt_clears_its_own_flag() {
        let mut rx = receiver();
        fill(&mut rx, &[1, 2, 3, 4, 5, 6, 7, 8]);
        let mut entries = 0;
        let mut got = heapless::Vec::<u8, 16>::new();
        while rx.stream().transfer_complete {
            entries += 1;
            assert!(
                entries <= 1,
                "the stream's handler re-entered {entries} times"
            );
            rx.drain(|bytes| got.extend_from_slice(bytes).unwrap());
        }
        assert_eq!(entries, 1);
        assert_eq!(got, [1, 2, 3, 4, 5, 6, 7, 8]);
    }

    #[test]
    fn the_idle_line_clears_both_sources_and_hands_on_a_partial_buffer() {
        let mut rx = receiver();
        fill(&mut rx, &[9, 8, 7]);
        rx.stream.idle = true;
        rx.stream.transfer_complete = true;
        let mut got = heapless::Vec::<u8, 16>::new();
        rx.drain(|bytes| got.extend_from_slice(bytes).unwrap());
        assert!(!rx.stream().idle && !rx.stream().transfer_complete);
        assert_eq!(got, [9, 8, 7]);
        // The next buffer starts empty: a drain with nothing received hands on nothing.
        let mut again = heapless::Vec::<u8, 16>::new();
        rx.drain(|bytes| again.extend_from_slice(bytes).unwrap());
        assert!(again.is_empty());
    }

    #[test]
    fn a_failed_swap_keeps_the_spare_and_still_clears_the_flags() {
        struct Refuses(bool);
        impl RxStream for Refuses {
            type Buffer = [u8; 4];
            fn clear_flags(&mut self) {
                self.0 = false;
            }
            fn swap(&mut self, spare: [u8; 4]) -> Result<([u8; 4], usize), [u8; 4]> {
                Err(spare)
            }
        }
        let mut rx = DoubleBufferRx::new(Refuses(true), [0; 4]);
        let mut called = false;
        rx.drain(|_| called = true);
        assert!(!called && !rx.stream().0 && rx.spare.is_some());
    }
}
