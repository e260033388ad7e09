//! The packet CRC with a boot-time self-check of the CRC unit and a small software fallback.
//!
//! At boot the firmware feeds the reference packet bytes (`0x00..=0x7F`, the sensor CRC's
//! reference vector in docs/wire-formats.md) to the STM32 CRC unit and compares the result
//! with the published vector `0x6557_DE1A`. A unit that
//! passes computes every packet and info-frame CRC; one that fails (a broken unit, or QEMU,
//! which does not model it) is replaced by [`NibbleCrc`], so packets stay valid either way.
//! The outcome is a status bit of the info frame.
//!
//! [`NibbleCrc`] needs a 64-byte table instead of the 8 KiB of the host's four-byte slicing:
//! the fallback costs flash only in proportion to how rarely it runs.

use dima_sensorboard::{SensorCrc, INITIAL, POLYNOMIAL};

/// CRC of the reference packet bytes `0x00..=0x7F` (docs/wire-formats.md, sensor CRC).
pub const REFERENCE_CRC: u32 = 0x6557_DE1A;

/// The reference bytes of the self-check: `0x00, 0x01, ..., 0x7F`.
#[must_use]
pub fn reference_bytes() -> [u8; 128] {
    core::array::from_fn(|i| i as u8)
}

/// `NIBBLE_TABLE[n]` is the register after shifting `n << 28` through four zero bits.
const NIBBLE_TABLE: [u32; 16] = {
    let mut table = [0u32; 16];
    let mut n = 0;
    while n < 16 {
        let mut crc = (n as u32) << 28;
        let mut bit = 0;
        while bit < 4 {
            crc = if crc & 0x8000_0000 != 0 {
                (crc << 1) ^ POLYNOMIAL
            } else {
                crc << 1
            };
            bit += 1;
        }
        table[n] = crc;
        n += 1;
    }
    table
};

/// Software sensor CRC, four bits per step through a 16-entry table (about 30 µs for a packet
/// at 168 MHz).
#[derive(Debug, Clone, Copy, Default)]
pub struct NibbleCrc;

impl NibbleCrc {
    /// Feeds one zero-extended byte (one 32-bit word) into `crc`.
    #[must_use]
    pub const fn update_byte(mut crc: u32, byte: u8) -> u32 {
        crc ^= byte as u32;
        let mut step = 0;
        while step < 8 {
            crc = (crc << 4) ^ NIBBLE_TABLE[(crc >> 28) as usize];
            step += 1;
        }
        crc
    }
}

impl SensorCrc for NibbleCrc {
    fn checksum(&mut self, bytes: &[u8]) -> u32 {
        bytes
            .iter()
            .fold(INITIAL, |crc, &byte| Self::update_byte(crc, byte))
    }
}

/// The CRC the firmware uses: the unit if it passed the self-check, else the fallback.
#[derive(Debug)]
pub enum CheckedCrc<H> {
    /// The CRC unit passed the self-check.
    Hardware(H),
    /// The CRC unit failed the self-check (kept so it is not dropped; never used).
    Software(H),
}

impl<H: SensorCrc> CheckedCrc<H> {
    /// Runs the self-check on `unit` and keeps it if it computes [`REFERENCE_CRC`].
    pub fn check(mut unit: H) -> Self {
        if unit.checksum(&reference_bytes()) == REFERENCE_CRC {
            Self::Hardware(unit)
        } else {
            Self::Software(unit)
        }
    }

    /// Whether the CRC unit passed the self-check.
    #[must_use]
    pub fn unit_ok(&self) -> bool {
        matches!(self, Self::Hardware(_))
    }
}

impl<H: SensorCrc> SensorCrc for CheckedCrc<H> {
    fn checksum(&mut self, bytes: &[u8]) -> u32 {
        match self {
            Self::Hardware(unit) => unit.checksum(bytes),
            Self::Software(_) => NibbleCrc.checksum(bytes),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_sensorboard::crc32_bitwise;
    use dima_sensorboard::Stm32Crc;

    /// What QEMU's unmodelled CRC unit does: every read is zero.
    struct DeadUnit;

    impl SensorCrc for DeadUnit {
        fn checksum(&mut self, _bytes: &[u8]) -> u32 {
            0
        }
    }

    /// A unit that is off by one bit, as a damaged or misconfigured unit might be.
    struct FlippedUnit;

    impl SensorCrc for FlippedUnit {
        fn checksum(&mut self, bytes: &[u8]) -> u32 {
            crc32_bitwise(bytes) ^ 1
        }
    }

    #[test]
    fn nibble_crc_matches_the_published_vectors() {
        assert_eq!(NibbleCrc.checksum(&reference_bytes()), 0x6557_DE1A);
        assert_eq!(NibbleCrc.checksum(&[0u8; 128]), 0xE151_AAB2);
    }

    #[test]
    fn nibble_crc_agrees_with_the_bitwise_model_on_pseudo_random_data() {
        let mut state = 0x1234_5678u32;
        let mut bytes = [0u8; 300];
        for len in [0usize, 1, 2, 3, 5, 60, 128, 300] {
            for byte in bytes.iter_mut() {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *byte = (state >> 24) as u8;
            }
            assert_eq!(
                NibbleCrc.checksum(&bytes[..len]),
                crc32_bitwise(&bytes[..len])
            );
        }
    }

    #[test]
    fn a_working_unit_is_used() {
        let mut crc = CheckedCrc::check(Stm32Crc);
        assert!(crc.unit_ok());
        assert_eq!(crc.checksum(&[1, 2, 3]), crc32_bitwise(&[1, 2, 3]));
    }

    #[test]
    fn a_dead_unit_falls_back_and_packets_stay_valid() {
        let mut crc = CheckedCrc::check(DeadUnit);
        assert!(!crc.unit_ok());
        assert_eq!(crc.checksum(&reference_bytes()), REFERENCE_CRC);
    }

    #[test]
    fn a_unit_off_by_one_bit_fails_the_check() {
        let mut crc = CheckedCrc::check(FlippedUnit);
        assert!(!crc.unit_ok());
        assert_eq!(crc.checksum(&[0u8; 128]), 0xE151_AAB2);
    }
}
