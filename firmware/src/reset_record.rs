//! A record in RAM that survives resets (not power loss): the watchdog-reset count.
//!
//! The word pair lives in cortex-m-rt's `.uninit` section, which the start-up code leaves
//! alone. A magic word tells a record written by this firmware from the random contents of
//! RAM after power-on; a power-on reset (or no valid record) starts the count at zero.

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

/// Marks a valid record ("DIMA").
const MAGIC: u32 = 0x4449_4D41;

#[link_section = ".uninit.dima_reset_record"]
static mut RECORD: MaybeUninit<[u32; 2]> = MaybeUninit::uninit();

/// Updates the record for this boot and returns the watchdog resets since power-on.
///
/// Call once, from `init`, before anything else could touch the record.
#[allow(unsafe_code)]
pub fn count_watchdog_resets(power_on: bool, watchdog_reset: bool) -> u32 {
    // SAFETY: called once from `init` with interrupts disabled: no other reference to
    // `RECORD` exists. Any bit pattern is a valid `[u32; 2]`, so reading it uninitialised
    // after power-on is a valid (if meaningless) read; the magic word rejects it.
    let record = unsafe { &mut *addr_of_mut!(RECORD) };
    let words = record.as_mut_ptr();
    // SAFETY: `words` points to the two words of the record, valid for reads and writes.
    let [magic, count] = unsafe { words.read_volatile() };
    let mut count = if power_on || magic != MAGIC { 0 } else { count };
    if watchdog_reset {
        count = count.wrapping_add(1);
    }
    // SAFETY: as above.
    unsafe { words.write_volatile([MAGIC, count]) };
    count
}
