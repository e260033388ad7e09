//! Factory trim registers: three bursts, decoded with Bosch's exact types.

use super::register as reg;

/// Trim burst 1: start register and length.
pub const TRIM_BURST_1: (u8, usize) = (reg::DIG_X1, 2);
/// Trim burst 2: start register and length.
pub const TRIM_BURST_2: (u8, usize) = (reg::DIG_Z4_LSB, 4);
/// Trim burst 3: start register and length.
pub const TRIM_BURST_3: (u8, usize) = (reg::DIG_Z2_LSB, 10);

/// The magnetometer's factory trim values, as Bosch's SensorAPI types them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagTrim {
    /// 0x5D, i8.
    pub dig_x1: i8,
    /// 0x5E, i8.
    pub dig_y1: i8,
    /// 0x64, i8.
    pub dig_x2: i8,
    /// 0x65, i8.
    pub dig_y2: i8,
    /// 0x6A..=0x6B, u16.
    pub dig_z1: u16,
    /// 0x68..=0x69, i16.
    pub dig_z2: i16,
    /// 0x6E..=0x6F, i16.
    pub dig_z3: i16,
    /// 0x62..=0x63, i16.
    pub dig_z4: i16,
    /// 0x71, u8.
    pub dig_xy1: u8,
    /// 0x70, i8.
    pub dig_xy2: i8,
    /// 0x6C..=0x6D, u16 masked to 15 bits.
    pub dig_xyz1: u16,
}

impl MagTrim {
    /// The three trim bursts ([`TRIM_BURST_1`], [`TRIM_BURST_2`], [`TRIM_BURST_3`]: registers
    /// 0x5D..=0x5E, 0x62..=0x65 and 0x68..=0x71) of a real BMM150 from Bosch's SensorAPI test
    /// data, concatenated in that order: for tests, simulations and tools that need a believable
    /// device without one.
    pub const EXAMPLE_BURST_BYTES: [u8; 16] = [
        0x00, 0x00, 0x00, 0x00, 0x1A, 0x1A, 0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD,
        0x1D,
    ];

    /// Decode the three trim bursts (0x5D..=0x5E, 0x62..=0x65, 0x68..=0x71).
    pub const fn from_bursts(b1: &[u8; 2], b2: &[u8; 4], b3: &[u8; 10]) -> Self {
        Self {
            dig_x1: b1[0] as i8,
            dig_y1: b1[1] as i8,
            dig_z4: i16::from_le_bytes([b2[0], b2[1]]),
            dig_x2: b2[2] as i8,
            dig_y2: b2[3] as i8,
            dig_z2: i16::from_le_bytes([b3[0], b3[1]]),
            dig_z1: u16::from_le_bytes([b3[2], b3[3]]),
            dig_xyz1: u16::from_le_bytes([b3[4], b3[5] & 0x7F]),
            dig_z3: i16::from_le_bytes([b3[6], b3[7]]),
            dig_xy2: b3[8] as i8,
            dig_xy1: b3[9],
        }
    }

    /// Serialise back to the three bursts (for an info frame carrying trim to the host);
    /// `from_bursts(to_bursts(t)) == t` for every trim with `dig_xyz1 < 0x8000`.
    pub const fn to_bursts(&self) -> ([u8; 2], [u8; 4], [u8; 10]) {
        let z4 = self.dig_z4.to_le_bytes();
        let z2 = self.dig_z2.to_le_bytes();
        let z1 = self.dig_z1.to_le_bytes();
        let xyz1 = self.dig_xyz1.to_le_bytes();
        let z3 = self.dig_z3.to_le_bytes();
        (
            [self.dig_x1 as u8, self.dig_y1 as u8],
            [z4[0], z4[1], self.dig_x2 as u8, self.dig_y2 as u8],
            [
                z2[0],
                z2[1],
                z1[0],
                z1[1],
                xyz1[0],
                xyz1[1],
                z3[0],
                z3[1],
                self.dig_xy2 as u8,
                self.dig_xy1,
            ],
        )
    }
}
