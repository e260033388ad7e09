//! The reset record: what the board remembers across resets (not power loss).
//!
//! Three words in RAM that the start-up code leaves alone: a magic word, the number of
//! watchdog resets since power-on, and the cause of a fault (in `init`, or a panic) that is
//! waiting to be reported. A fault in `init` writes its cause here, starts the watchdog and
//! waits for it; a panic writes [`BootFault::Panic`] and resets at once; the next boot reads the cause back, reports it once and
//! clears it. This module is the pure part (what the words become); the firmware reads and
//! writes them.

/// Marks a valid record ("DIMA").
pub const MAGIC: u32 = 0x4449_4D41;

/// The record as stored: `[MAGIC, watchdog resets, pending fault code]`.
pub type Words = [u32; 3];

/// A step of `init` that failed: the board resets instead of running without it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum BootFault {
    /// The host link's USART3 rejected its configuration.
    LinkSerial = 1,
    /// The GNSS USART1 rejected its configuration.
    GnssSerial = 2,
    /// The sampling timer TIM2 rejected its rate.
    SampleTimer = 3,
    /// The firmware panicked: the panic handler stopped the link, recorded this and reset
    /// the board at once (a software reset, not the watchdog).
    Panic = 4,
}

impl BootFault {
    /// The stored code back to a fault; `None` for 0 (no fault) and unknown codes.
    #[must_use]
    pub fn from_code(code: u32) -> Option<Self> {
        match code {
            1 => Some(Self::LinkSerial),
            2 => Some(Self::GnssSerial),
            3 => Some(Self::SampleTimer),
            4 => Some(Self::Panic),
            _ => None,
        }
    }
}

/// What this boot learns from the record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ResetReport {
    /// Watchdog resets since power-on, this one included.
    pub watchdog_resets: u32,
    /// The fault that made the previous boot reset the board, if any.
    pub boot_fault: Option<BootFault>,
}

/// The record for this boot, from the stored words and the reset flags: returns the words to
/// store back (fault cleared) and the report.
///
/// A power-on reset, or words without the magic (RAM contents after power-on), start from
/// zero and no fault.
#[must_use]
pub fn after_reset(stored: Words, power_on: bool, watchdog_reset: bool) -> (Words, ResetReport) {
    let [magic, count, fault] = stored;
    let valid = !power_on && magic == MAGIC;
    let mut watchdog_resets = if valid { count } else { 0 };
    if watchdog_reset {
        watchdog_resets = watchdog_resets.wrapping_add(1);
    }
    let boot_fault = if valid {
        BootFault::from_code(fault)
    } else {
        None
    };
    (
        [MAGIC, watchdog_resets, 0],
        ResetReport {
            watchdog_resets,
            boot_fault,
        },
    )
}

/// The words with `fault` recorded as pending (the count is kept; a record without the magic
/// is started afresh).
#[must_use]
pub fn with_fault(stored: Words, fault: BootFault) -> Words {
    let count = if stored[0] == MAGIC { stored[1] } else { 0 };
    [MAGIC, count, fault as u32]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_on_starts_from_zero_whatever_ram_holds() {
        let (words, report) = after_reset([MAGIC, 7, 2], true, false);
        assert_eq!(words, [MAGIC, 0, 0]);
        assert_eq!(report.watchdog_resets, 0);
        assert_eq!(report.boot_fault, None);
    }

    #[test]
    fn words_without_magic_are_ignored() {
        let (words, report) = after_reset([0x1234_5678, 99, 1], false, true);
        assert_eq!(words, [MAGIC, 1, 0]);
        assert_eq!(report.watchdog_resets, 1);
        assert_eq!(report.boot_fault, None);
    }

    #[test]
    fn watchdog_resets_accumulate_until_power_on() {
        let mut words = after_reset([0; 3], true, false).0;
        for expected in 1..=3 {
            let (next, report) = after_reset(words, false, true);
            assert_eq!(report.watchdog_resets, expected);
            words = next;
        }
        // A pin reset keeps the count without adding to it.
        let (words, report) = after_reset(words, false, false);
        assert_eq!(report.watchdog_resets, 3);
        assert_eq!(after_reset(words, true, false).1.watchdog_resets, 0);
    }

    #[test]
    fn a_boot_fault_is_reported_once_after_the_reset_it_causes() {
        let words = after_reset([0; 3], true, false).0;
        let faulted = with_fault(words, BootFault::GnssSerial);
        // The fault starts the watchdog, which resets the board.
        let (words, report) = after_reset(faulted, false, true);
        assert_eq!(report.boot_fault, Some(BootFault::GnssSerial));
        assert_eq!(report.watchdog_resets, 1);
        // Cleared: the boot after that reports nothing.
        let (_, report) = after_reset(words, false, false);
        assert_eq!(report.boot_fault, None);
        assert_eq!(report.watchdog_resets, 1);
    }

    #[test]
    fn a_panic_is_reported_once_by_the_next_boot_without_a_watchdog_reset() {
        let words = after_reset([0; 3], true, false).0;
        let words = after_reset(words, false, true).0;
        let panicked = with_fault(words, BootFault::Panic);
        assert_eq!(panicked, [MAGIC, 1, 4]);
        // The panic handler resets by software: no watchdog flag, the count stays.
        let (words, report) = after_reset(panicked, false, false);
        assert_eq!(report.boot_fault, Some(BootFault::Panic));
        assert_eq!(report.watchdog_resets, 1);
        assert_eq!(after_reset(words, false, false).1.boot_fault, None);
    }

    #[test]
    fn a_fault_keeps_the_count_and_power_loss_forgets_it() {
        let words = [MAGIC, 4, 0];
        let faulted = with_fault(words, BootFault::SampleTimer);
        assert_eq!(faulted, [MAGIC, 4, 3]);
        assert_eq!(after_reset(faulted, true, false).1.boot_fault, None);
        // Without a valid record the fault starts a fresh one.
        assert_eq!(with_fault([5, 6, 7], BootFault::LinkSerial), [MAGIC, 0, 1]);
    }

    #[test]
    fn every_fault_code_round_trips_and_unknown_codes_are_none() {
        for fault in [
            BootFault::LinkSerial,
            BootFault::GnssSerial,
            BootFault::SampleTimer,
            BootFault::Panic,
        ] {
            assert_eq!(BootFault::from_code(fault as u32), Some(fault));
        }
        assert_eq!(BootFault::from_code(0), None);
        assert_eq!(BootFault::from_code(5), None);
        assert_eq!(BootFault::from_code(u32::MAX), None);
    }
}
