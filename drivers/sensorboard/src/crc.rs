//! The sensor packet CRC, as computed by the STM32F4 hardware CRC unit.
//!
//! The board resets the unit (data register = `0xFFFF_FFFF`) and writes each packet byte as
//! its own 32-bit word whose value is the zero-extended byte. The result equals
//! CRC-32/MPEG-2 (polynomial `0x04C1_1DB7`, initial value `0xFFFF_FFFF`, no reflection, no
//! final XOR) over a stream in which every byte `b` becomes `00 00 00 b`.
//!
//! Two software implementations are provided: [`crc32_bitwise`], a direct model of the
//! hardware that shifts one bit at a time, and [`Stm32Crc`], which folds whole words through
//! 256-entry tables, four bytes per step. They agree on every input; the tests check this on
//! the published vectors and on random data.

/// The CRC-32 polynomial the STM32 CRC unit implements (normal, non-reflected form).
pub const POLYNOMIAL: u32 = 0x04C1_1DB7;

/// The value of the CRC unit's data register after a reset.
pub const INITIAL: u32 = 0xFFFF_FFFF;

/// Something that computes the sensor packet CRC, one zero-extended byte per 32-bit word.
///
/// The firmware implements this for the STM32 hardware CRC unit; [`Stm32Crc`] is the portable
/// software implementation used on the host.
pub trait SensorCrc {
    /// Resets the CRC to [`INITIAL`], then feeds `bytes`, each as one zero-extended word, and
    /// returns the final register value.
    fn checksum(&mut self, bytes: &[u8]) -> u32;
}

/// Reference model of the hardware: feeds one 32-bit word into `crc`, most significant bit
/// first, one bit per step.
#[must_use]
pub const fn update_word_bitwise(mut crc: u32, word: u32) -> u32 {
    crc ^= word;
    let mut bit = 0;
    while bit < 32 {
        crc = if crc & 0x8000_0000 != 0 {
            (crc << 1) ^ POLYNOMIAL
        } else {
            crc << 1
        };
        bit += 1;
    }
    crc
}

/// Reference model of the sensor packet CRC: every byte is one zero-extended word, processed a
/// bit at a time. Slow, obviously correct; the tests hold [`Stm32Crc`] against it.
#[must_use]
pub fn crc32_bitwise(bytes: &[u8]) -> u32 {
    bytes.iter().fold(INITIAL, |crc, &byte| {
        update_word_bitwise(crc, u32::from(byte))
    })
}

/// Advances `crc` by eight zero bits (a byte of the polynomial division with no data).
const fn shift_byte(mut crc: u32) -> u32 {
    let mut bit = 0;
    while bit < 8 {
        crc = if crc & 0x8000_0000 != 0 {
            (crc << 1) ^ POLYNOMIAL
        } else {
            crc << 1
        };
        bit += 1;
    }
    crc
}

/// `TABLES[k][i]` is the CRC contribution of byte value `i` in position `k` of a word
/// (`k = 0` the most significant byte) after the whole word has been shifted through.
const TABLES: [[u32; 256]; 4] = {
    let mut tables = [[0u32; 256]; 4];
    let mut i = 0;
    while i < 256 {
        // The most significant byte of the register, shifted through one byte.
        let mut value = shift_byte((i as u32) << 24);
        // Each further zero byte that follows moves it one table down.
        let mut k = 4;
        while k > 0 {
            k -= 1;
            tables[k][i] = value;
            if k > 0 {
                value = shift_byte(value);
            }
        }
        i += 1;
    }
    tables
};

/// Feeds one zero-extended byte (a 32-bit word `0x0000_00bb`) into `crc` through the tables.
///
/// XOR-ing the word into the register leaves the top three bytes as they were and changes the
/// lowest one; after 32 shifts, each register byte contributes independently (the CRC is
/// linear), so four table lookups replace 32 conditional shifts.
#[inline]
#[must_use]
pub const fn update_byte(crc: u32, byte: u8) -> u32 {
    let register = crc ^ byte as u32;
    TABLES[0][(register >> 24) as usize]
        ^ TABLES[1][((register >> 16) & 0xFF) as usize]
        ^ TABLES[2][((register >> 8) & 0xFF) as usize]
        ^ TABLES[3][(register & 0xFF) as usize]
}

/// Shifts `crc` through 32 zero bits (one all-zero word) using the tables.
const fn shift_word(crc: u32) -> u32 {
    update_byte(crc, 0)
}

/// Tables for four bytes per step.
///
/// Write `F` for "shift through one zero word". Feeding bytes `b1..b4` (each a word) into `c`
/// gives `F⁴(c) ^ F⁴(b1) ^ F³(b2) ^ F²(b3) ^ F(b4)`, because every step is linear.
/// `SLICE4[k]` (`k` in 0..4) is `F⁴` of register byte `k` (most significant first);
/// `SLICE4[4 + j]` is `F^(j+1)` of a lone low byte. The register then waits on one round of
/// lookups per four bytes instead of one per byte.
const SLICE4: [[u32; 256]; 8] = {
    let mut tables = [[0u32; 256]; 8];
    let mut i = 0;
    while i < 256 {
        let mut k = 0;
        while k < 4 {
            // TABLES[k][i] is F of byte i in register position k: three more shifts give F⁴.
            tables[k][i] = shift_word(shift_word(shift_word(TABLES[k][i])));
            k += 1;
        }
        let mut power = TABLES[3][i];
        let mut j = 0;
        while j < 4 {
            tables[4 + j][i] = power;
            power = shift_word(power);
            j += 1;
        }
        i += 1;
    }
    tables
};

/// Tables for sixteen bytes per step (20 KiB), the same construction as [`SLICE4`]:
/// `SLICE16[k]` (`k` in 0..4) is `F¹⁶` of register byte `k`; `SLICE16[4 + j]` is `F^(j+1)` of a
/// lone low byte. Twenty lookups per sixteen bytes instead of eight per four.
#[cfg(feature = "slice16")]
static SLICE16: [[u32; 256]; 20] = {
    let mut tables = [[0u32; 256]; 20];
    let mut i = 0;
    while i < 256 {
        let mut k = 0;
        while k < 4 {
            let mut value = TABLES[k][i];
            let mut n = 1;
            while n < 16 {
                value = shift_word(value);
                n += 1;
            }
            tables[k][i] = value;
            k += 1;
        }
        let mut power = TABLES[3][i];
        let mut j = 0;
        while j < 16 {
            tables[4 + j][i] = power;
            power = shift_word(power);
            j += 1;
        }
        i += 1;
    }
    tables
};

/// Continues a CRC from `crc` with `bytes`, four bytes per step through `SLICE4` (8 KiB of
/// tables: the default, small enough for the firmware).
#[must_use]
pub fn update_slice4(mut crc: u32, bytes: &[u8]) -> u32 {
    let mut words = bytes.chunks_exact(4);
    for word in &mut words {
        if let &[b1, b2, b3, b4] = word {
            crc = SLICE4[0][(crc >> 24) as usize]
                ^ SLICE4[1][((crc >> 16) & 0xFF) as usize]
                ^ SLICE4[2][((crc >> 8) & 0xFF) as usize]
                ^ SLICE4[3][(crc & 0xFF) as usize]
                ^ SLICE4[7][usize::from(b1)]
                ^ SLICE4[6][usize::from(b2)]
                ^ SLICE4[5][usize::from(b3)]
                ^ SLICE4[4][usize::from(b4)];
        }
    }
    words
        .remainder()
        .iter()
        .fold(crc, |crc, &byte| update_byte(crc, byte))
}

/// Continues a CRC from `crc` with `bytes`, sixteen bytes per step through 20 KiB of tables
/// (feature `slice16`, for hosts: about 1.5 times [`update_slice4`]'s speed).
#[cfg(feature = "slice16")]
#[must_use]
pub fn update_slice16(mut crc: u32, bytes: &[u8]) -> u32 {
    let mut blocks = bytes.chunks_exact(16);
    for block in &mut blocks {
        let mut next = SLICE16[0][(crc >> 24) as usize]
            ^ SLICE16[1][((crc >> 16) & 0xFF) as usize]
            ^ SLICE16[2][((crc >> 8) & 0xFF) as usize]
            ^ SLICE16[3][(crc & 0xFF) as usize];
        // Byte m (1-based) is shifted through 17 - m words: table 4 + 16 - m.
        for (m, &byte) in block.iter().enumerate() {
            next ^= SLICE16[19 - m][usize::from(byte)];
        }
        crc = next;
    }
    update_slice4(crc, blocks.remainder())
}

/// Table-driven software implementation of the sensor packet CRC.
///
/// Processes four bytes per step through eight 256-entry tables (8 KiB), or with the
/// `slice16` feature sixteen bytes per step through twenty (20 KiB), then the remaining bytes
/// one at a time with [`update_byte`]. Same result as [`crc32_bitwise`] on every input.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Stm32Crc;

impl Stm32Crc {
    /// Computes the CRC of `bytes`, each fed as one zero-extended word after a reset.
    #[must_use]
    pub fn compute(bytes: &[u8]) -> u32 {
        Self::update(INITIAL, bytes)
    }

    /// Continues a CRC from register value `crc` with `bytes` (one zero-extended word each).
    #[must_use]
    pub fn update(crc: u32, bytes: &[u8]) -> u32 {
        #[cfg(feature = "slice16")]
        {
            update_slice16(crc, bytes)
        }
        #[cfg(not(feature = "slice16"))]
        {
            update_slice4(crc, bytes)
        }
    }
}

impl SensorCrc for Stm32Crc {
    fn checksum(&mut self, bytes: &[u8]) -> u32 {
        Self::compute(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Both implementations, so every vector checks both.
    fn both(bytes: &[u8]) -> (u32, u32) {
        (crc32_bitwise(bytes), Stm32Crc::compute(bytes))
    }

    #[test]
    fn ascending_bytes_vector() {
        let bytes: [u8; 128] = core::array::from_fn(|i| i as u8);
        assert_eq!(both(&bytes), (0x6557_DE1A, 0x6557_DE1A));
        assert_eq!(
            Stm32Crc::compute(&bytes).to_le_bytes(),
            [0x1A, 0xDE, 0x57, 0x65]
        );
    }

    #[test]
    fn zero_bytes_vector() {
        assert_eq!(both(&[0u8; 128]), (0xE151_AAB2, 0xE151_AAB2));
    }

    #[test]
    fn ascii_check_string_vector() {
        assert_eq!(both(b"123456789"), (0x1556_F485, 0x1556_F485));
    }

    #[test]
    fn single_word_vectors() {
        assert_eq!(update_word_bitwise(INITIAL, 0x0000_0000), 0xC704_DD7B);
        assert_eq!(update_word_bitwise(INITIAL, 0x1234_5678), 0xDF8A_8A2B);
        assert_eq!(update_byte(INITIAL, 0x00), 0xC704_DD7B);
    }

    #[test]
    fn trait_object_matches_compute() {
        let mut crc = Stm32Crc;
        let crc: &mut dyn SensorCrc = &mut crc;
        assert_eq!(crc.checksum(b"123456789"), 0x1556_F485);
    }

    proptest! {
        #[test]
        fn table_agrees_with_bitwise_model(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let (bitwise, table) = both(&bytes);
            prop_assert_eq!(bitwise, table);
        }

        #[test]
        fn update_continues_from_any_register(
            crc in any::<u32>(),
            bytes in proptest::collection::vec(any::<u8>(), 0..40),
        ) {
            let bitwise = bytes
                .iter()
                .fold(crc, |crc, &b| update_word_bitwise(crc, u32::from(b)));
            prop_assert_eq!(Stm32Crc::update(crc, &bytes), bitwise);
        }

        #[test]
        fn both_slicings_agree_with_the_model(
            crc in any::<u32>(),
            bytes in proptest::collection::vec(any::<u8>(), 0..300),
        ) {
            let bitwise = bytes
                .iter()
                .fold(crc, |crc, &b| update_word_bitwise(crc, u32::from(b)));
            prop_assert_eq!(update_slice4(crc, &bytes), bitwise);
            #[cfg(feature = "slice16")]
            prop_assert_eq!(update_slice16(crc, &bytes), bitwise);
        }

        #[test]
        fn table_step_agrees_for_any_register(crc in any::<u32>(), byte in any::<u8>()) {
            prop_assert_eq!(update_byte(crc, byte), update_word_bitwise(crc, u32::from(byte)));
        }
    }
}
