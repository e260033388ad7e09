//! Pins every register address and bit against the BMX055 datasheet register maps
//! (accelerometer chapter 6, gyroscope chapter 7, magnetometer chapter 8), cross-checked with
//! Bosch's SensorAPI headers: `bma2_defs.h` (BMA2 SensorAPI, BMA253/BMA255 die, chip id 0xFA),
//! `bmg160.h` (BMG160_driver) and `bmm150_defs.h` (BMM150 SensorAPI).

// Unit tests, because the register maps are private: the public API speaks in typed values.
use crate::accel::register as a;
use crate::gyro::register as g;
use crate::mag::register as m;

#[test]
fn accelerometer_addresses() {
    let pinned = [
        (a::BGW_CHIPID, 0x00),
        (a::ACCD_X_LSB, 0x02),
        (a::ACCD_X_MSB, 0x03),
        (a::ACCD_Y_LSB, 0x04),
        (a::ACCD_Y_MSB, 0x05),
        (a::ACCD_Z_LSB, 0x06),
        (a::ACCD_Z_MSB, 0x07),
        (a::ACCD_TEMP, 0x08),
        (a::INT_STATUS_0, 0x09),
        (a::INT_STATUS_1, 0x0A),
        (a::INT_STATUS_2, 0x0B),
        (a::INT_STATUS_3, 0x0C),
        (a::FIFO_STATUS, 0x0E),
        (a::PMU_RANGE, 0x0F),
        (a::PMU_BW, 0x10),
        (a::PMU_LPW, 0x11),
        (a::PMU_LOW_POWER, 0x12),
        (a::ACCD_HBW, 0x13),
        (a::BGW_SOFTRESET, 0x14),
        (a::INT_EN_0, 0x16),
        (a::INT_EN_1, 0x17),
        (a::INT_EN_2, 0x18),
        (a::INT_MAP_0, 0x19),
        (a::INT_MAP_1, 0x1A),
        (a::INT_MAP_2, 0x1B),
        (a::INT_SRC, 0x1E),
        (a::INT_OUT_CTRL, 0x20),
        (a::INT_RST_LATCH, 0x21),
        (a::INT_5, 0x27),
        (a::INT_6, 0x28),
        (a::FIFO_CONFIG_0, 0x30),
        (a::PMU_SELF_TEST, 0x32),
        (a::BGW_SPI3_WDT, 0x34),
        (a::OFC_CTRL, 0x36),
        (a::OFC_SETTING, 0x37),
        (a::OFC_OFFSET_X, 0x38),
        (a::OFC_OFFSET_Y, 0x39),
        (a::OFC_OFFSET_Z, 0x3A),
        (a::FIFO_CONFIG_1, 0x3E),
        (a::FIFO_DATA, 0x3F),
    ];
    for (got, want) in pinned {
        assert_eq!(got, want);
    }
    assert_eq!(a::CHIP_ID_VALUE, 0xFA);
    assert_eq!(a::SOFT_RESET_CMD, 0xB6);
}

#[test]
fn accelerometer_bits() {
    let pinned = [
        (a::LSB_DATA_MASK, 0xF0),
        (a::NEW_DATA, 0x01),
        (a::SLOPE_EN_X, 0x01),
        (a::SLOPE_EN_Y, 0x02),
        (a::SLOPE_EN_Z, 0x04),
        (a::DATA_EN, 0x10),
        (a::INT_FFULL_EN, 0x20),
        (a::INT_FWM_EN, 0x40),
        (a::MAP_SLOPE, 0x04),
        (a::INT1_DATA, 0x01),
        (a::INT1_FWM, 0x02),
        (a::INT1_FFULL, 0x04),
        (a::INT2_FFULL, 0x20),
        (a::INT2_FWM, 0x40),
        (a::INT2_DATA, 0x80),
        (a::STATUS_SLOPE, 0x04),
        (a::STATUS_FFULL, 0x20),
        (a::STATUS_FWM, 0x40),
        (a::STATUS_DATA, 0x80),
        (a::INT1_LVL, 0x01),
        (a::INT1_OD, 0x02),
        (a::INT2_LVL, 0x04),
        (a::INT2_OD, 0x08),
        (a::RESET_INT, 0x80),
        (a::FIFO_OVERRUN, 0x80),
        (a::FIFO_FRAME_COUNTER, 0x7F),
        (a::SELF_TEST_SIGN, 0x04),
        // Bosch BMA2 SensorAPI bma2_defs.h: BMA2_ACCEL_SELFTEST_AMP_MSK 0x10.
        (a::SELF_TEST_AMP, 0x10),
        (a::OFFSET_RESET, 0x80),
        (a::CAL_RDY, 0x10),
        (a::CAL_TRIGGER_SHIFT, 5),
        (a::POWER_MODE_SHIFT, 5),
        (a::FIFO_MODE_SHIFT, 6),
    ];
    for (i, (got, want)) in pinned.into_iter().enumerate() {
        assert_eq!(got, want, "entry {i}");
    }
}

#[test]
fn accelerometer_field_values() {
    use crate::accel::*;
    assert_eq!(AccelRange::G2.bits(), 0x03);
    assert_eq!(AccelRange::G4.bits(), 0x05);
    assert_eq!(AccelRange::G8.bits(), 0x08);
    assert_eq!(AccelRange::G16.bits(), 0x0C);
    assert_eq!(AccelBandwidth::Hz7_81.bits(), 0x08);
    assert_eq!(AccelBandwidth::Hz1000.bits(), 0x0F);
    assert_eq!(AccelPowerMode::Normal.bits(), 0x00);
    assert_eq!(AccelPowerMode::DeepSuspend.bits(), 0x20);
    assert_eq!(AccelPowerMode::Suspend.bits(), 0x80);
    assert_eq!(
        AccelPowerMode::LowPower(AccelSleepDuration::Ms0_5).bits(),
        0x4A
    );
    assert_eq!(
        AccelPowerMode::LowPower(AccelSleepDuration::S1).bits(),
        0x5E
    );
}

#[test]
fn gyroscope_addresses() {
    let pinned = [
        (g::CHIP_ID, 0x00),
        (g::RATE_X_LSB, 0x02),
        (g::RATE_X_MSB, 0x03),
        (g::RATE_Y_LSB, 0x04),
        (g::RATE_Y_MSB, 0x05),
        (g::RATE_Z_LSB, 0x06),
        (g::RATE_Z_MSB, 0x07),
        (g::TEMP, 0x08),
        (g::INT_STATUS_0, 0x09),
        (g::INT_STATUS_1, 0x0A),
        (g::FIFO_STATUS, 0x0E),
        (g::RANGE, 0x0F),
        (g::BW, 0x10),
        (g::LPM1, 0x11),
        (g::LPM2, 0x12),
        (g::RATE_HBW, 0x13),
        (g::BGW_SOFTRESET, 0x14),
        (g::INT_EN_0, 0x15),
        (g::INT_EN_1, 0x16),
        (g::INT_MAP_0, 0x17),
        (g::INT_MAP_1, 0x18),
        (g::INT_MAP_2, 0x19),
        (g::FIFO_WM_EN, 0x1E),
        (g::INT_RST_LATCH, 0x21),
        (g::BIST, 0x3C),
        (g::FIFO_CONFIG_0, 0x3D),
        (g::FIFO_CONFIG_1, 0x3E),
        (g::FIFO_DATA, 0x3F),
    ];
    for (got, want) in pinned {
        assert_eq!(got, want);
    }
    assert_eq!(g::CHIP_ID_VALUE, 0x0F);
    assert_eq!(g::SOFT_RESET_CMD, 0xB6);
}

#[test]
fn gyroscope_bits_and_fields() {
    use crate::gyro::*;
    let pinned = [
        (g::SUSPEND, 0x80),
        (g::DEEP_SUSPEND, 0x20),
        (g::DATA_EN, 0x80),
        (g::FIFO_EN, 0x40),
        (g::INT1_LVL, 0x01),
        (g::INT1_OD, 0x02),
        (g::INT2_LVL, 0x04),
        (g::INT2_OD, 0x08),
        (g::INT1_DATA, 0x01),
        (g::INT1_FIFO, 0x04),
        (g::INT2_FIFO, 0x20),
        (g::INT2_DATA, 0x80),
        (g::FIFO_WM_ENABLE, 0x80),
        (g::STATUS_FIFO, 0x10),
        (g::STATUS_DATA, 0x80),
        (g::STATUS_ANY, 0x04),
        (g::RESET_INT, 0x80),
        (g::TRIG_BIST, 0x01),
        (g::BIST_RDY, 0x02),
        (g::BIST_FAIL, 0x04),
        (g::RATE_OK, 0x10),
        (g::FIFO_MODE_SHIFT, 6),
    ];
    for (i, (got, want)) in pinned.into_iter().enumerate() {
        assert_eq!(got, want, "entry {i}");
    }
    assert_eq!(GyroRange::Dps2000.bits(), 0x00);
    assert_eq!(GyroRange::Dps1000.bits(), 0x01);
    assert_eq!(GyroRange::Dps500.bits(), 0x02);
    assert_eq!(GyroRange::Dps250.bits(), 0x03);
    assert_eq!(GyroRange::Dps125.bits(), 0x04);
    assert_eq!(GyroBandwidth::Odr2000Bw523.bits(), 0x80);
    assert_eq!(GyroBandwidth::Odr2000Bw230.bits(), 0x81);
    assert_eq!(GyroBandwidth::Odr100Bw32.bits(), 0x87);
    assert_eq!(GyroPowerMode::Normal.bits(), 0x00);
}

#[test]
fn magnetometer_addresses() {
    let pinned = [
        (m::CHIP_ID, 0x40),
        (m::DATA_X_LSB, 0x42),
        (m::DATA_X_MSB, 0x43),
        (m::DATA_Y_LSB, 0x44),
        (m::DATA_Y_MSB, 0x45),
        (m::DATA_Z_LSB, 0x46),
        (m::DATA_Z_MSB, 0x47),
        (m::RHALL_LSB, 0x48),
        (m::RHALL_MSB, 0x49),
        (m::INT_STATUS, 0x4A),
        (m::POWER_CONTROL, 0x4B),
        (m::OP_MODE, 0x4C),
        (m::INT_ENABLE, 0x4D),
        (m::INT_CONTROL, 0x4E),
        (m::LOW_THRESHOLD, 0x4F),
        (m::HIGH_THRESHOLD, 0x50),
        (m::REP_XY, 0x51),
        (m::REP_Z, 0x52),
        (m::DIG_X1, 0x5D),
        (m::DIG_Y1, 0x5E),
        (m::DIG_Z4_LSB, 0x62),
        (m::DIG_X2, 0x64),
        (m::DIG_Y2, 0x65),
        (m::DIG_Z2_LSB, 0x68),
        (m::DIG_Z1_LSB, 0x6A),
        (m::DIG_XYZ1_LSB, 0x6C),
        (m::DIG_Z3_LSB, 0x6E),
        (m::DIG_XY2, 0x70),
        (m::DIG_XY1, 0x71),
    ];
    for (got, want) in pinned {
        assert_eq!(got, want);
    }
    assert_eq!(m::CHIP_ID_VALUE, 0x32);
}

#[test]
fn magnetometer_bits_and_fields() {
    use crate::mag::*;
    let pinned = [
        (m::POWER_ON, 0x01),
        (m::SOFT_RESET, 0x82),
        (m::DATA_READY, 0x01),
        (m::OP_MODE_SHIFT, 1),
        (m::ODR_SHIFT, 3),
        (m::STATUS_OVERFLOW, 0x40),
        (m::STATUS_OVERRUN, 0x80),
        (m::DR_PIN_EN, 0x80),
        (m::DR_POLARITY, 0x04),
        (m::INT_CONTROL_RESET, 0x07),
        (m::XY_LSB_MASK, 0xF8),
        (m::Z_LSB_MASK, 0xFE),
        (m::RHALL_LSB_MASK, 0xFC),
    ];
    for (i, (got, want)) in pinned.into_iter().enumerate() {
        assert_eq!(got, want, "entry {i}");
    }
    assert_eq!(TRIM_BURST_1, (0x5D, 2));
    assert_eq!(TRIM_BURST_2, (0x62, 4));
    assert_eq!(TRIM_BURST_3, (0x68, 10));
    assert_eq!(op_mode_bits(MagOpMode::Normal, MagDataRate::Hz10), 0x00);
    assert_eq!(op_mode_bits(MagOpMode::Forced, MagDataRate::Hz10), 0x02);
    assert_eq!(op_mode_bits(MagOpMode::Sleep, MagDataRate::Hz10), 0x06);
    assert_eq!(op_mode_bits(MagOpMode::Normal, MagDataRate::Hz30), 0x38);
    // Bosch BMM150 SensorAPI bmm150_defs.h: BMM150_{LOWPOWER,REGULAR,ENHANCED,HIGHACCURACY}
    // _REPXY 1, 4, 7, 23 and _REPZ 2, 14, 26, 82; bmm150_set_presetmode: 20 Hz for high accuracy.
    let presets = [
        (MagPreset::LowPower, 0x01, 0x02),
        (MagPreset::Regular, 0x04, 0x0E),
        (MagPreset::EnhancedRegular, 0x07, 0x1A),
        (MagPreset::HighAccuracy, 0x17, 0x52),
    ];
    for (p, xy, z) in presets {
        assert_eq!((p.rep_xy(), p.rep_z()), (xy, z), "{p:?}");
    }
    assert_eq!(MagPreset::HighAccuracy.data_rate(), MagDataRate::Hz20);
    // Low power: nXY = 3, nZ = 3 -> 145*3 + 500*3 + 980 µs.
    assert_eq!(measurement_time_us(0x01, 0x02), 2915);
}

#[test]
fn i2c_strap_addresses() {
    use crate::accel::AccelAddress;
    use crate::gyro::GyroAddress;
    use crate::mag::MagAddress;
    assert_eq!(AccelAddress::Sdo1Low as u8, 0x18);
    assert_eq!(AccelAddress::Sdo1High as u8, 0x19);
    assert_eq!(GyroAddress::Sdo2Low as u8, 0x68);
    assert_eq!(GyroAddress::Sdo2High as u8, 0x69);
    assert_eq!(MagAddress::Csb3LowSdo3Low as u8, 0x10);
    assert_eq!(MagAddress::Csb3LowSdo3High as u8, 0x11);
    assert_eq!(MagAddress::Csb3HighSdo3Low as u8, 0x12);
    assert_eq!(MagAddress::Csb3HighSdo3High as u8, 0x13);
    assert_eq!(crate::interface::SPI_READ, 0x80);
}

#[test]
fn fifo_fields() {
    use crate::{FifoData, FifoMode, FifoStatus};
    assert_eq!(FifoMode::Bypass as u8, 0);
    assert_eq!(FifoMode::Fifo as u8, 1);
    assert_eq!(FifoMode::Stream as u8, 2);
    assert_eq!(FifoData::Xyz as u8, 0);
    assert_eq!(FifoData::Z as u8, 3);
    assert_eq!(
        FifoStatus::from_register(0x85),
        FifoStatus {
            frames: 5,
            overrun: true
        }
    );
}
