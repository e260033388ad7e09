//! Magnetometer register map (BMX055 datasheet, chapter 8: BMM150-class die).
// The complete map, pinned against the datasheet by the register tests; the driver does not
// use every register.
#![allow(dead_code)]

/// Chip id register; reads [`CHIP_ID_VALUE`] once the die is out of suspend.
pub const CHIP_ID: u8 = 0x40;
/// Expected magnetometer chip id.
pub const CHIP_ID_VALUE: u8 = 0x32;
/// X LSB: bits 7:3 data bits 4:0, bit 0 self-test result.
pub const DATA_X_LSB: u8 = 0x42;
/// X MSB: data bits 12:5.
pub const DATA_X_MSB: u8 = 0x43;
/// Y LSB: bits 7:3 data bits 4:0.
pub const DATA_Y_LSB: u8 = 0x44;
/// Y MSB.
pub const DATA_Y_MSB: u8 = 0x45;
/// Z LSB: bits 7:1 data bits 6:0, bit 0 self-test result.
pub const DATA_Z_LSB: u8 = 0x46;
/// Z MSB: data bits 14:7.
pub const DATA_Z_MSB: u8 = 0x47;
/// RHALL LSB: bits 7:2 data bits 5:0, bit 0 data ready.
pub const RHALL_LSB: u8 = 0x48;
/// RHALL MSB: data bits 13:6.
pub const RHALL_MSB: u8 = 0x49;
/// Interrupt status.
pub const INT_STATUS: u8 = 0x4A;
/// Power control: bit 0 power on, bits 7 and 1 soft reset.
pub const POWER_CONTROL: u8 = 0x4B;
/// Operation mode (bits 2:1), data rate (bits 5:3), self-test.
pub const OP_MODE: u8 = 0x4C;
/// Interrupt enables.
pub const INT_ENABLE: u8 = 0x4D;
/// Pin enables, axis enables, polarities, latch.
pub const INT_CONTROL: u8 = 0x4E;
/// Low-threshold.
pub const LOW_THRESHOLD: u8 = 0x4F;
/// High-threshold.
pub const HIGH_THRESHOLD: u8 = 0x50;
/// X/Y repetitions: nXY = 1 + 2 * value.
pub const REP_XY: u8 = 0x51;
/// Z repetitions: nZ = 1 + value.
pub const REP_Z: u8 = 0x52;

/// Trim burst 1: `dig_x1`, `dig_y1` (2 bytes).
pub const DIG_X1: u8 = 0x5D;
/// `dig_y1`.
pub const DIG_Y1: u8 = 0x5E;
/// Trim burst 2: `dig_z4` (i16), `dig_x2`, `dig_y2` (4 bytes).
pub const DIG_Z4_LSB: u8 = 0x62;
/// `dig_x2`.
pub const DIG_X2: u8 = 0x64;
/// `dig_y2`.
pub const DIG_Y2: u8 = 0x65;
/// Trim burst 3: `dig_z2`, `dig_z1`, `dig_xyz1`, `dig_z3`, `dig_xy2`, `dig_xy1` (10 bytes).
pub const DIG_Z2_LSB: u8 = 0x68;
/// `dig_z1` (u16).
pub const DIG_Z1_LSB: u8 = 0x6A;
/// `dig_xyz1` (u16, 15 bits).
pub const DIG_XYZ1_LSB: u8 = 0x6C;
/// `dig_z3` (i16).
pub const DIG_Z3_LSB: u8 = 0x6E;
/// `dig_xy2` (i8).
pub const DIG_XY2: u8 = 0x70;
/// `dig_xy1` (u8).
pub const DIG_XY1: u8 = 0x71;

/// `POWER_CONTROL`: power on (leave suspend).
pub const POWER_ON: u8 = 1 << 0;
/// `POWER_CONTROL`: both soft-reset bits (7 and 1).
pub const SOFT_RESET: u8 = 0x82;
/// `RHALL_LSB`: data-ready bit.
pub const DATA_READY: u8 = 1 << 0;
/// `OP_MODE`: shift of the two-bit operation-mode field.
pub const OP_MODE_SHIFT: u8 = 1;
/// `OP_MODE`: shift of the three-bit data-rate field.
pub const ODR_SHIFT: u8 = 3;
/// `INT_STATUS`: overflow.
pub const STATUS_OVERFLOW: u8 = 1 << 6;
/// `INT_STATUS`: data overrun.
pub const STATUS_OVERRUN: u8 = 1 << 7;
/// `INT_CONTROL`: data-ready pin enable.
pub const DR_PIN_EN: u8 = 1 << 7;
/// `INT_CONTROL`: data-ready pin active high.
pub const DR_POLARITY: u8 = 1 << 2;
/// `INT_CONTROL` reset value (all axes enabled, active-high polarities, latched).
pub const INT_CONTROL_RESET: u8 = 0x07;
/// Mask of the X and Y data bits in their LSB registers.
pub const XY_LSB_MASK: u8 = 0xF8;
/// Mask of the Z data bits in its LSB register.
pub const Z_LSB_MASK: u8 = 0xFE;
/// Mask of the RHALL data bits in its LSB register.
pub const RHALL_LSB_MASK: u8 = 0xFC;
