//! The reset record in RAM that survives resets (not power loss): watchdog-reset count and a
//! pending boot fault. What the words mean is `dima_firmware_logic::reset_record`; this
//! module only keeps them.
//!
//! The words live in cortex-m-rt's `.uninit` section, which the start-up code leaves alone.

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;
use dima_firmware_logic::reset_record::{self, BootFault, ResetReport, Words};

#[link_section = ".uninit.dima_reset_record"]
static mut RECORD: MaybeUninit<Words> = MaybeUninit::uninit();

/// Reads the record.
#[allow(unsafe_code)]
fn read() -> Words {
    // SAFETY: the record is only touched from `init`, from `fault()` (also in `init`) and
    // from the panic handler, each with interrupts disabled and the last two never
    // returning, so no other access can overlap. Any bit pattern is a valid
    // `[u32; 3]`, so reading it uninitialised after power-on is a valid (if meaningless)
    // read; the magic word rejects it.
    unsafe { (*addr_of_mut!(RECORD)).as_ptr().read_volatile() }
}

/// Writes the record.
#[allow(unsafe_code)]
fn write(words: Words) {
    // SAFETY: as in `read`.
    unsafe { (*addr_of_mut!(RECORD)).as_mut_ptr().write_volatile(words) }
}

/// Updates the record for this boot and returns what it says: the watchdog resets since
/// power-on and the fault that reset the previous boot, if any (reported once).
///
/// Call once, from `init`, before anything else could touch the record.
pub fn after_reset(power_on: bool, watchdog_reset: bool) -> ResetReport {
    let (words, report) = reset_record::after_reset(read(), power_on, watchdog_reset);
    write(words);
    report
}

/// Records `fault` for the next boot to report.
pub fn record_fault(fault: BootFault) {
    write(reset_record::with_fault(read(), fault));
}
