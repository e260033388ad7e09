//! The factory calibration (trimming) words stored in the NVM, registers 0x88..=0x9F.

/// The twelve calibration words `dig_T1`..`dig_P9` (datasheet table 17), read once at bring-up.
///
/// A host that receives raw samples from a sensor board compensates them with these words, so
/// the type converts both ways between the 24 register bytes and the words.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Calibration {
    /// `dig_T1`, registers 0x88/0x89 (temperature, unsigned).
    pub dig_t1: u16,
    /// `dig_T2`, registers 0x8A/0x8B (temperature).
    pub dig_t2: i16,
    /// `dig_T3`, registers 0x8C/0x8D (temperature).
    pub dig_t3: i16,
    /// `dig_P1`, registers 0x8E/0x8F (pressure, unsigned). 0 would make the pressure formulas
    /// divide by zero, so `init` rejects it.
    pub dig_p1: u16,
    /// `dig_P2`, registers 0x90/0x91 (pressure).
    pub dig_p2: i16,
    /// `dig_P3`, registers 0x92/0x93 (pressure).
    pub dig_p3: i16,
    /// `dig_P4`, registers 0x94/0x95 (pressure).
    pub dig_p4: i16,
    /// `dig_P5`, registers 0x96/0x97 (pressure).
    pub dig_p5: i16,
    /// `dig_P6`, registers 0x98/0x99 (pressure).
    pub dig_p6: i16,
    /// `dig_P7`, registers 0x9A/0x9B (pressure).
    pub dig_p7: i16,
    /// `dig_P8`, registers 0x9C/0x9D (pressure).
    pub dig_p8: i16,
    /// `dig_P9`, registers 0x9E/0x9F (pressure).
    pub dig_p9: i16,
}

impl Calibration {
    /// Calibration registers 0x88..=0x9F of the worked example in the Bosch BMP280 datasheet
    /// (section 8.1: `dig_T1` 27504, `dig_T2` 26435, `dig_T3` -1000, `dig_P1` 36477, ...,
    /// `dig_P9` 6000), as [`Calibration::from_bytes`] takes them: for tests, simulations and
    /// tools that need a believable device without one.
    pub const DATASHEET_EXAMPLE_BYTES: [u8; 24] = [
        0x70, 0x6B, 0x43, 0x67, 0x18, 0xFC, 0x7D, 0x8E, 0x43, 0xD6, 0xD0, 0x0B, 0x27, 0x0B, 0x8C,
        0x00, 0xF9, 0xFF, 0x8C, 0x3C, 0xF8, 0xC6, 0x70, 0x17,
    ];

    /// Parses the 24 bytes read from 0x88..=0x9F: twelve little-endian words, `dig_T1` and
    /// `dig_P1` unsigned, the others two's complement.
    pub const fn from_bytes(b: &[u8; 24]) -> Self {
        Self {
            dig_t1: word(b, 0),
            dig_t2: word(b, 2) as i16,
            dig_t3: word(b, 4) as i16,
            dig_p1: word(b, 6),
            dig_p2: word(b, 8) as i16,
            dig_p3: word(b, 10) as i16,
            dig_p4: word(b, 12) as i16,
            dig_p5: word(b, 14) as i16,
            dig_p6: word(b, 16) as i16,
            dig_p7: word(b, 18) as i16,
            dig_p8: word(b, 20) as i16,
            dig_p9: word(b, 22) as i16,
        }
    }

    /// The 24 register bytes of this calibration, the inverse of [`Calibration::from_bytes`].
    pub const fn to_bytes(&self) -> [u8; 24] {
        let words = [
            self.dig_t1,
            self.dig_t2 as u16,
            self.dig_t3 as u16,
            self.dig_p1,
            self.dig_p2 as u16,
            self.dig_p3 as u16,
            self.dig_p4 as u16,
            self.dig_p5 as u16,
            self.dig_p6 as u16,
            self.dig_p7 as u16,
            self.dig_p8 as u16,
            self.dig_p9 as u16,
        ];
        let mut out = [0u8; 24];
        let mut i = 0;
        while i < 12 {
            let [lo, hi] = words[i].to_le_bytes();
            out[2 * i] = lo;
            out[2 * i + 1] = hi;
            i += 1;
        }
        out
    }
}

const fn word(b: &[u8; 24], i: usize) -> u16 {
    u16::from_le_bytes([b[i], b[i + 1]])
}
