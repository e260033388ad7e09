//! The factory calibration (trimming) words stored in the NVM, registers 0x88..=0x9F.

/// The twelve calibration words `dig_T1`..`dig_P9` (datasheet table 17), read once at bring-up.
///
/// The DIMA host receives these bytes from the sensor board and compensates raw packets with
/// them, so the type converts both ways between the 24 register bytes and the words.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // the fields are the datasheet's names; their meaning is the formulas
pub struct Calibration {
    pub dig_t1: u16,
    pub dig_t2: i16,
    pub dig_t3: i16,
    pub dig_p1: u16,
    pub dig_p2: i16,
    pub dig_p3: i16,
    pub dig_p4: i16,
    pub dig_p5: i16,
    pub dig_p6: i16,
    pub dig_p7: i16,
    pub dig_p8: i16,
    pub dig_p9: i16,
}

impl Calibration {
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
