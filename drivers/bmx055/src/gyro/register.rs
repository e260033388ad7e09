//! Gyroscope register map (BMX055 datasheet, chapter 7: BMG160-class die).
// The complete map, pinned against the datasheet by the register tests; the driver does not
// use every register.
#![allow(dead_code)]

/// Chip id register; reads [`CHIP_ID_VALUE`].
pub const CHIP_ID: u8 = 0x00;
/// Expected gyroscope chip id.
pub const CHIP_ID_VALUE: u8 = 0x0F;
/// X rate LSB (16-bit two's complement, LSB first).
pub const RATE_X_LSB: u8 = 0x02;
/// X rate MSB.
pub const RATE_X_MSB: u8 = 0x03;
/// Y rate LSB.
pub const RATE_Y_LSB: u8 = 0x04;
/// Y rate MSB.
pub const RATE_Y_MSB: u8 = 0x05;
/// Z rate LSB.
pub const RATE_Z_LSB: u8 = 0x06;
/// Z rate MSB.
pub const RATE_Z_MSB: u8 = 0x07;
/// Temperature, two's complement, 0.5 K/LSB, 0 = 23 °C.
pub const TEMP: u8 = 0x08;
/// Interrupt status 0 (any-motion, high-rate).
pub const INT_STATUS_0: u8 = 0x09;
/// Interrupt status 1 (data, offsets, FIFO).
pub const INT_STATUS_1: u8 = 0x0A;
/// FIFO status: bit 7 overrun, bits 6:0 frame counter.
pub const FIFO_STATUS: u8 = 0x0E;
/// Range selection.
pub const RANGE: u8 = 0x0F;
/// Output data rate and filter bandwidth.
pub const BW: u8 = 0x10;
/// Power mode 1: bit 7 suspend, bit 5 deep suspend.
pub const LPM1: u8 = 0x11;
/// Power mode 2: fast power-up, external trigger, autosleep.
pub const LPM2: u8 = 0x12;
/// Data acquisition: bit 7 unfiltered data, bit 6 shadowing disable.
pub const RATE_HBW: u8 = 0x13;
/// Soft reset: write [`SOFT_RESET_CMD`].
pub const BGW_SOFTRESET: u8 = 0x14;
/// Soft-reset command byte.
pub const SOFT_RESET_CMD: u8 = 0xB6;
/// Interrupt enable 0: data, FIFO, auto-offset.
pub const INT_EN_0: u8 = 0x15;
/// Interrupt pin electrical behaviour.
pub const INT_EN_1: u8 = 0x16;
/// Interrupt map 0 (any-motion, high-rate to INT1).
pub const INT_MAP_0: u8 = 0x17;
/// Interrupt map 1 (data, FIFO, offsets to INT1/INT2).
pub const INT_MAP_1: u8 = 0x18;
/// Interrupt map 2 (any-motion, high-rate to INT2).
pub const INT_MAP_2: u8 = 0x19;
/// FIFO watermark interrupt enable (bit 7).
pub const FIFO_WM_EN: u8 = 0x1E;
/// Interrupt latch mode and reset.
pub const INT_RST_LATCH: u8 = 0x21;
/// Built-in self-test.
pub const BIST: u8 = 0x3C;
/// FIFO tag (bit 7) and watermark level (bits 6:0).
pub const FIFO_CONFIG_0: u8 = 0x3D;
/// FIFO mode (bits 7:6) and data select (bits 1:0).
pub const FIFO_CONFIG_1: u8 = 0x3E;
/// FIFO data output.
pub const FIFO_DATA: u8 = 0x3F;

/// `LPM1`: suspend.
pub const SUSPEND: u8 = 1 << 7;
/// `LPM1`: deep suspend.
pub const DEEP_SUSPEND: u8 = 1 << 5;
/// `INT_EN_0`: data-ready enable.
pub const DATA_EN: u8 = 1 << 7;
/// `INT_EN_0`: FIFO interrupt enable.
pub const FIFO_EN: u8 = 1 << 6;
/// `INT_EN_1`: INT1 active level high.
pub const INT1_LVL: u8 = 1 << 0;
/// `INT_EN_1`: INT1 open drain.
pub const INT1_OD: u8 = 1 << 1;
/// `INT_EN_1`: INT2 active level high.
pub const INT2_LVL: u8 = 1 << 2;
/// `INT_EN_1`: INT2 open drain.
pub const INT2_OD: u8 = 1 << 3;
/// `INT_MAP_1`: data ready to INT1.
pub const INT1_DATA: u8 = 1 << 0;
/// `INT_MAP_1`: FIFO to INT1.
pub const INT1_FIFO: u8 = 1 << 2;
/// `INT_MAP_1`: FIFO to INT2.
pub const INT2_FIFO: u8 = 1 << 5;
/// `INT_MAP_1`: data ready to INT2.
pub const INT2_DATA: u8 = 1 << 7;
/// `FIFO_WM_EN`: watermark interrupt enable.
pub const FIFO_WM_ENABLE: u8 = 1 << 7;
/// `INT_STATUS_1`: FIFO interrupt active.
pub const STATUS_FIFO: u8 = 1 << 4;
/// `INT_STATUS_1`: data-ready interrupt active.
pub const STATUS_DATA: u8 = 1 << 7;
/// `INT_STATUS_0`: any-motion interrupt active.
pub const STATUS_ANY: u8 = 1 << 2;
/// `INT_RST_LATCH`: clear latched interrupts.
pub const RESET_INT: u8 = 1 << 7;
/// `BIST`: start the built-in self-test.
pub const TRIG_BIST: u8 = 1 << 0;
/// `BIST`: self-test finished.
pub const BIST_RDY: u8 = 1 << 1;
/// `BIST`: self-test failed.
pub const BIST_FAIL: u8 = 1 << 2;
/// `BIST`: rate output plausible (checked continuously).
pub const RATE_OK: u8 = 1 << 4;
/// `FIFO_CONFIG_1`: shift of the two-bit FIFO mode field.
pub const FIFO_MODE_SHIFT: u8 = 6;
