//! Accelerometer register map (BMX055 datasheet, chapter 6: BMA2x2-class die).
//!
//! Addresses are `u8` constants; single-bit fields are masks named after the datasheet field.
// The complete map, pinned against the datasheet by the register tests; the driver does not
// use every register.
#![allow(dead_code)]

/// Chip id register; reads [`CHIP_ID_VALUE`].
pub const BGW_CHIPID: u8 = 0x00;
/// Expected accelerometer chip id.
pub const CHIP_ID_VALUE: u8 = 0xFA;
/// X LSB: bits 7:4 data bits 3:0, bit 0 `new_data_x`.
pub const ACCD_X_LSB: u8 = 0x02;
/// X MSB: data bits 11:4.
pub const ACCD_X_MSB: u8 = 0x03;
/// Y LSB.
pub const ACCD_Y_LSB: u8 = 0x04;
/// Y MSB.
pub const ACCD_Y_MSB: u8 = 0x05;
/// Z LSB.
pub const ACCD_Z_LSB: u8 = 0x06;
/// Z MSB.
pub const ACCD_Z_MSB: u8 = 0x07;
/// Temperature, two's complement, 0.5 K/LSB, 0 = 23 °C.
pub const ACCD_TEMP: u8 = 0x08;
/// Interrupt status 0 (motion engines).
pub const INT_STATUS_0: u8 = 0x09;
/// Interrupt status 1 (data, FIFO).
pub const INT_STATUS_1: u8 = 0x0A;
/// Interrupt status 2 (slope/tap sign and first axis).
pub const INT_STATUS_2: u8 = 0x0B;
/// Interrupt status 3 (orientation, flat, high-g sign).
pub const INT_STATUS_3: u8 = 0x0C;
/// FIFO status: bit 7 overrun, bits 6:0 frame counter.
pub const FIFO_STATUS: u8 = 0x0E;
/// g-range selection.
pub const PMU_RANGE: u8 = 0x0F;
/// Filter bandwidth selection.
pub const PMU_BW: u8 = 0x10;
/// Power mode (bits 7:5) and sleep duration (bits 4:1).
pub const PMU_LPW: u8 = 0x11;
/// Low-power configuration.
pub const PMU_LOW_POWER: u8 = 0x12;
/// Data acquisition: bit 7 unfiltered data, bit 6 shadowing disable.
pub const ACCD_HBW: u8 = 0x13;
/// Soft reset: write [`SOFT_RESET_CMD`].
pub const BGW_SOFTRESET: u8 = 0x14;
/// Soft-reset command byte.
pub const SOFT_RESET_CMD: u8 = 0xB6;
/// Interrupt enable 0: slope, tap, orient, flat.
pub const INT_EN_0: u8 = 0x16;
/// Interrupt enable 1: data ready, FIFO, low-g, high-g.
pub const INT_EN_1: u8 = 0x17;
/// Interrupt enable 2: slow/no-motion.
pub const INT_EN_2: u8 = 0x18;
/// Interrupt map to INT1 (motion engines).
pub const INT_MAP_0: u8 = 0x19;
/// Interrupt map of data and FIFO to INT1/INT2.
pub const INT_MAP_1: u8 = 0x1A;
/// Interrupt map to INT2 (motion engines).
pub const INT_MAP_2: u8 = 0x1B;
/// Interrupt source: unfiltered data for the engines.
pub const INT_SRC: u8 = 0x1E;
/// Interrupt pin electrical behaviour.
pub const INT_OUT_CTRL: u8 = 0x20;
/// Interrupt latch mode and reset.
pub const INT_RST_LATCH: u8 = 0x21;
/// Slope (any-motion) duration (bits 1:0) and slow/no-motion duration (bits 7:2).
pub const INT_5: u8 = 0x27;
/// Slope (any-motion) threshold.
pub const INT_6: u8 = 0x28;
/// FIFO watermark level (bits 5:0).
pub const FIFO_CONFIG_0: u8 = 0x30;
/// Self-test control.
pub const PMU_SELF_TEST: u8 = 0x32;
/// Digital interface: SPI 3-wire, I2C watchdog.
pub const BGW_SPI3_WDT: u8 = 0x34;
/// Offset compensation control.
pub const OFC_CTRL: u8 = 0x36;
/// Offset compensation settings (fast-compensation targets).
pub const OFC_SETTING: u8 = 0x37;
/// Offset X (i8, 7.8 mg/LSB).
pub const OFC_OFFSET_X: u8 = 0x38;
/// Offset Y.
pub const OFC_OFFSET_Y: u8 = 0x39;
/// Offset Z.
pub const OFC_OFFSET_Z: u8 = 0x3A;
/// FIFO mode (bits 7:6) and data select (bits 1:0).
pub const FIFO_CONFIG_1: u8 = 0x3E;
/// FIFO data output (burst reads pop frames).
pub const FIFO_DATA: u8 = 0x3F;

/// Mask keeping the data bits of an `ACCD_*_LSB` register (bits 3:0 are status).
pub const LSB_DATA_MASK: u8 = 0xF0;
/// `new_data_*` bit in an `ACCD_*_LSB` register.
pub const NEW_DATA: u8 = 0x01;

/// `INT_EN_0` / `INT_MAP_*`: slope X enable.
pub const SLOPE_EN_X: u8 = 1 << 0;
/// `INT_EN_0`: slope Y enable.
pub const SLOPE_EN_Y: u8 = 1 << 1;
/// `INT_EN_0`: slope Z enable.
pub const SLOPE_EN_Z: u8 = 1 << 2;
/// `INT_EN_1`: data-ready enable.
pub const DATA_EN: u8 = 1 << 4;
/// `INT_EN_1`: FIFO full enable.
pub const INT_FFULL_EN: u8 = 1 << 5;
/// `INT_EN_1`: FIFO watermark enable.
pub const INT_FWM_EN: u8 = 1 << 6;
/// `INT_MAP_0` / `INT_MAP_2`: slope interrupt to the pin.
pub const MAP_SLOPE: u8 = 1 << 2;
/// `INT_MAP_1`: data ready to INT1.
pub const INT1_DATA: u8 = 1 << 0;
/// `INT_MAP_1`: FIFO watermark to INT1.
pub const INT1_FWM: u8 = 1 << 1;
/// `INT_MAP_1`: FIFO full to INT1.
pub const INT1_FFULL: u8 = 1 << 2;
/// `INT_MAP_1`: FIFO full to INT2.
pub const INT2_FFULL: u8 = 1 << 5;
/// `INT_MAP_1`: FIFO watermark to INT2.
pub const INT2_FWM: u8 = 1 << 6;
/// `INT_MAP_1`: data ready to INT2.
pub const INT2_DATA: u8 = 1 << 7;
/// `INT_STATUS_0`: slope interrupt active.
pub const STATUS_SLOPE: u8 = 1 << 2;
/// `INT_STATUS_1`: FIFO full interrupt active.
pub const STATUS_FFULL: u8 = 1 << 5;
/// `INT_STATUS_1`: FIFO watermark interrupt active.
pub const STATUS_FWM: u8 = 1 << 6;
/// `INT_STATUS_1`: data-ready interrupt active.
pub const STATUS_DATA: u8 = 1 << 7;
/// `INT_OUT_CTRL`: INT1 active level high.
pub const INT1_LVL: u8 = 1 << 0;
/// `INT_OUT_CTRL`: INT1 open drain.
pub const INT1_OD: u8 = 1 << 1;
/// `INT_OUT_CTRL`: INT2 active level high.
pub const INT2_LVL: u8 = 1 << 2;
/// `INT_OUT_CTRL`: INT2 open drain.
pub const INT2_OD: u8 = 1 << 3;
/// `INT_RST_LATCH`: clear latched interrupts.
pub const RESET_INT: u8 = 1 << 7;
/// `FIFO_STATUS`: overrun flag.
pub const FIFO_OVERRUN: u8 = 1 << 7;
/// `FIFO_STATUS`: frame counter mask.
pub const FIFO_FRAME_COUNTER: u8 = 0x7F;
/// `PMU_SELF_TEST`: sign bit (1 = positive deflection).
pub const SELF_TEST_SIGN: u8 = 1 << 2;
/// `PMU_SELF_TEST`: `self_test_amp`, 1 = high deflection amplitude (Bosch BMA2 SensorAPI
/// `BMA2_ACCEL_SELFTEST_AMP_MSK`; its self-test sets it high for every axis, and the pass
/// limits of [`SELF_TEST_MIN_MG`](super::SELF_TEST_MIN_MG) assume it).
pub const SELF_TEST_AMP: u8 = 1 << 4;
/// `OFC_CTRL`: reset the offset registers to zero.
pub const OFFSET_RESET: u8 = 1 << 7;
/// `OFC_CTRL`: fast compensation ready.
pub const CAL_RDY: u8 = 1 << 4;
/// `OFC_CTRL`: shift of the two-bit `cal_trigger` field (1 = X, 2 = Y, 3 = Z).
pub const CAL_TRIGGER_SHIFT: u8 = 5;
/// `PMU_LPW`: shift of the three-bit power-mode field.
pub const POWER_MODE_SHIFT: u8 = 5;
/// `FIFO_CONFIG_1`: shift of the two-bit FIFO mode field.
pub const FIFO_MODE_SHIFT: u8 = 6;
