//! The BMP280 register map (datasheet section 4.3, table 18).
//!
//! Addresses are named constants; the bit fields of `status` are a `bitflags` type and the fields
//! of `ctrl_meas` and `config` have their shifts and masks beside them. `register_tests.rs` pins
//! every address and bit position against the datasheet.

use bitflags::bitflags;

/// First calibration register, `calib00` (`dig_T1` LSB). The 24 bytes 0x88..=0x9F hold
/// `dig_T1`..`dig_P9`, each a little-endian 16-bit word.
pub const CALIB_START: u8 = 0x88;
/// Number of calibration bytes read in one burst from [`CALIB_START`].
pub const CALIB_LEN: usize = 24;
/// Chip identification register `id` (0xD0): 0x58 on a production BMP280.
pub const CHIP_ID: u8 = 0xD0;
/// Soft-reset register `reset` (0xE0): writing [`RESET_COMMAND`] performs a power-on reset.
pub const RESET: u8 = 0xE0;
/// The only value that resets the device when written to [`RESET`]; other values are ignored.
pub const RESET_COMMAND: u8 = 0xB6;
/// Status register `status` (0xF3), see [`Status`].
pub const STATUS: u8 = 0xF3;
/// Measurement control `ctrl_meas` (0xF4): `osrs_t[7:5]`, `osrs_p[4:2]`, `mode[1:0]`.
pub const CTRL_MEAS: u8 = 0xF4;
/// Rate, filter and interface options `config` (0xF5): `t_sb[7:5]`, `filter[4:2]`, `spi3w_en[0]`.
pub const CONFIG: u8 = 0xF5;
/// First data register `press_msb` (0xF7). The 6 bytes 0xF7..=0xFC are pressure MSB, LSB, XLSB
/// then temperature MSB, LSB, XLSB; a burst read of all six keeps both values of one sample.
pub const DATA_START: u8 = 0xF7;
/// Number of data bytes read in one burst from [`DATA_START`].
pub const DATA_LEN: usize = 6;
/// Temperature data `temp_msb` (0xFA), the fourth byte of the data burst.
#[allow(dead_code)] // part of the map, pinned by the register tests; bursts start at DATA_START
pub const TEMP_START: u8 = 0xFA;

/// SPI: bit 7 of the control byte set means read (`register | 0x80`).
pub const SPI_READ: u8 = 0x80;
/// SPI: writes send the register address with bit 7 cleared (`register & 0x7F`).
pub const SPI_WRITE_MASK: u8 = 0x7F;

/// Bit shift of `osrs_t` in `ctrl_meas`.
pub const OSRS_T_SHIFT: u8 = 5;
/// Bit shift of `osrs_p` in `ctrl_meas`.
pub const OSRS_P_SHIFT: u8 = 2;
/// Mask of `mode` in `ctrl_meas`.
pub const MODE_MASK: u8 = 0b11;
/// Bit shift of `t_sb` in `config`.
pub const T_SB_SHIFT: u8 = 5;
/// Bit shift of `filter` in `config`.
pub const FILTER_SHIFT: u8 = 2;
/// Mask of a 3-bit field (`osrs_t`, `osrs_p`, `t_sb`, `filter`) after shifting it down.
pub const FIELD3_MASK: u8 = 0b111;
/// `spi3w_en` bit in `config`: enables the 3-wire SPI interface.
pub const SPI3W_EN: u8 = 1 << 0;

bitflags! {
    /// The `status` register (0xF3).
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
    pub struct Status: u8 {
        /// Bit 3 `measuring`: a conversion is running; cleared when the results have been
        /// transferred to the data registers.
        const MEASURING = 1 << 3;
        /// Bit 0 `im_update`: the non-volatile memory (calibration) is being copied to the image
        /// registers, after power-on or soft reset and at the start of each conversion.
        const IM_UPDATE = 1 << 0;
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Status {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "Status({=u8:#04x})", self.bits())
    }
}
